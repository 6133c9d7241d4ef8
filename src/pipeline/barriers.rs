//! The barriers a config names, built once per run from the scene by the one builder of a
//! scene item's shape ([`Scene::collision_shape`], which the physics replay uses too): the
//! shapes for the IK's barrier term, their hulls inflated for the object's and the hand's
//! push-out.

use crate::geometry::shape::CollisionShape;
use crate::hand::{HandPath, pushout};
use crate::model::{Scene, WarpConfig};
use crate::robot::Robot;
use crate::warp::ObjectWarp;
use crate::warp::barrier::Barrier;
use crate::{Error, Limits, Result};

/// Stage 4b: the barriers inflated by the hand radius, and the hand push-out outside the
/// contact segment ([`pushout`]): the wrist ball, then every link against the shapes.
pub(super) fn hand_pushout(
    config: &WarpConfig,
    scene: &Scene,
    robot: &Robot,
    shapes: &[CollisionShape],
    object: &ObjectWarp,
    hand: HandPath,
    params: &pushout::Params,
) -> Result<(HandPath, pushout::Stats)> {
    let hulls = if params.radius_m > 0.0 {
        pushout_hulls(config, scene, shapes, params.radius_m)?
    } else {
        Vec::new()
    };
    let barriers = pushout::Barriers {
        names: &config.barriers,
        hulls: &hulls,
        shapes,
    };
    Ok(pushout::run(hand, &object.plan, robot, barriers, params))
}

/// The barriers a config names, as world-frame collision shapes, in the config's order.
pub fn shapes(config: &WarpConfig, scene: &Scene, limits: &Limits) -> Result<Vec<CollisionShape>> {
    config
        .barriers
        .iter()
        .map(|name| {
            scene.collision_shape(scene.item(name).expect("checked by check_scene"), limits)
        })
        .collect()
}

/// The barriers' hulls inflated by `radius` for the push-out (`shapes` from [`shapes`]).
pub(super) fn pushout_hulls(
    config: &WarpConfig,
    scene: &Scene,
    shapes: &[CollisionShape],
    radius: f64,
) -> Result<Vec<Barrier>> {
    config
        .barriers
        .iter()
        .zip(shapes)
        .enumerate()
        .map(|(j, (name, shape))| {
            Barrier::from_points(name, &shape.hull_points(), radius).ok_or_else(|| {
                Error::invalid(
                    &scene.source,
                    format!("items[{name:?}]"),
                    format!(
                        "barriers[{j}] has a flat or degenerate convex hull; give it a thickness"
                    ),
                )
            })
        })
        .collect()
}
