//! The barriers a config names, built from the scene: as collision shapes for the IK's
//! barrier term, and as inflated hulls for the object's and the hand's push-out.

use crate::geometry::shape::CollisionShape;
use crate::hand::{HandPath, pushout};
use crate::model::{Scene, WarpConfig};
use crate::warp::ObjectWarp;
use crate::warp::barrier::{Barrier, item_hull_points};
use crate::{Error, Limits, Result};

/// Stage 4b: the barriers prepared with the hand radius, and the hand push-out outside the
/// contact segment ([`pushout`]).
pub(super) fn hand_pushout(
    config: &WarpConfig,
    scene: &Scene,
    object: &ObjectWarp,
    hand: HandPath,
    params: &pushout::Params,
    limits: &Limits,
) -> Result<(HandPath, pushout::Stats)> {
    let barriers = if params.radius_m > 0.0 {
        prepare(config, scene, params.radius_m, limits)?
    } else {
        Vec::new()
    };
    Ok(pushout::run(hand, &object.plan, &barriers, params))
}

/// The barriers a config names, as world-frame collision shapes (the IK barrier term).
pub fn shapes(config: &WarpConfig, scene: &Scene, limits: &Limits) -> Result<Vec<CollisionShape>> {
    config
        .barriers
        .iter()
        .map(|name| {
            scene.collision_shape(scene.item(name).expect("checked by check_scene"), limits)
        })
        .collect()
}

/// The barriers a config names, prepared for the push-out.
pub fn prepare(
    config: &WarpConfig,
    scene: &Scene,
    radius: f64,
    limits: &Limits,
) -> Result<Vec<Barrier>> {
    config
        .barriers
        .iter()
        .enumerate()
        .map(|(j, name)| {
            let item = scene.item(name).expect("checked by check_scene");
            let pts = item_hull_points(item, limits)?;
            Barrier::from_points(name, &pts, radius).ok_or_else(|| {
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
