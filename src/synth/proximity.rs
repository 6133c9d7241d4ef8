//! Hand-object proximity: the object's signed distance and the hand's penetration into it.
//!
//! The objects of [`super::objects`] are unions of closed, outward-wound parts that overlap
//! where a handle meets a body; their signed distance is the shared one of
//! [`crate::geometry::sdf`] (inside any part: minus the largest distance to the surface of a
//! part that contains it; outside: the distance to the whole mesh).
//!
//! The penetration of a hand link is measured on its collision shapes (capsules, boxes,
//! spheres, cylinders) against the object mesh with two parry queries, the larger wins:
//! 1. `query::contact` shape vs triangle mesh: the deepest triangle contact (exact for the
//!    shallow overlaps a grasp has);
//! 2. the shape's core (centre, or points along a capsule's or cylinder's axis every 5 mm)
//!    inside the object: depth = core depth + the shape's radius (catches a shape buried
//!    so deep that the triangle contacts no longer see it).
//!
//! Both are signed: a positive depth is an overlap in metres, zero means apart or touching.

use nalgebra::{Isometry3, Point3, Vector3};
use rapier3d_f64::parry::query;

use std::sync::Arc;

use crate::geometry::Mesh;
use crate::geometry::sdf::{ObjectSdf, SurfacePoint, object_sdf};
use crate::geometry::shape::{CollisionShape, ShapeKind};
use crate::math::convert::to_pose;
use crate::robot::{LinkId, Robot};

/// An object mesh prepared for distance queries, in the object frame: the shared signed
/// distance field of [`crate::geometry::sdf`] (exact queries here, the grid in the IK).
#[derive(Clone, Debug)]
pub struct ObjectGeometry {
    /// The mesh.
    pub mesh: Mesh,
    /// The object's signed distance field.
    pub sdf: Arc<ObjectSdf>,
    /// Lowest vertex height in the object frame [m] (negative: below the origin).
    pub min_z: f64,
}

impl ObjectGeometry {
    /// Prepares `mesh`; `None` when it has no triangles.
    pub fn new(mesh: Mesh) -> Option<ObjectGeometry> {
        let sdf = object_sdf(&mesh)?;
        let min_z = mesh
            .vertices
            .iter()
            .map(|v| v.z)
            .fold(f64::INFINITY, f64::min);
        Some(ObjectGeometry { mesh, sdf, min_z })
    }

    /// Signed distance and closest surface point of the object-frame point `p` (exact).
    pub fn surface_point(&self, p: &Point3<f64>) -> SurfacePoint {
        self.sdf.exact().surface_point(p)
    }

    /// True when the object-frame point `p` is inside the object.
    pub fn contains(&self, p: &Point3<f64>) -> bool {
        self.surface_point(p).signed_distance < 0.0
    }

    /// Outward normal of the surface near the object-frame point `p`, by central
    /// differences (1 mm) of the signed distance.
    pub fn normal(&self, p: &Point3<f64>) -> Vector3<f64> {
        let h = 1e-3;
        let mut g = Vector3::zeros();
        for a in 0..3 {
            let mut e = Vector3::zeros();
            e[a] = h;
            g[a] = self.surface_point(&(p + e)).signed_distance
                - self.surface_point(&(p - e)).signed_distance;
        }
        g.try_normalize(1e-12).unwrap_or_else(Vector3::z)
    }
}

/// The worst overlap of a hand with the object.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Penetration {
    /// Largest overlap depth over all links [m]; 0 when apart.
    pub depth_m: f64,
    /// The link with that overlap (`None` when apart).
    pub link: Option<LinkId>,
}

/// Depth [m] of the overlap of one collision shape of a link at world pose `link_pose` with
/// the object at `object_pose` (0 when apart).
pub fn shape_depth(
    object: &ObjectGeometry,
    object_pose: &Isometry3<f64>,
    shape: &CollisionShape,
    link_pose: &Isometry3<f64>,
) -> f64 {
    let shape_pose = link_pose * shape.shape_pose;
    let mut depth: f64 = 0.0;
    if let Ok(Some(c)) = query::contact(
        &to_pose(object_pose),
        object.sdf.exact().whole(),
        &to_pose(&shape_pose),
        shape.shape.as_ref(),
        0.0,
    ) {
        depth = depth.max(-c.dist);
    }
    let inv = object_pose.inverse();
    let (radius, core) = core_points(shape);
    for p in core {
        let local = inv * (link_pose * (shape.origin * p));
        let s = object.surface_point(&local);
        if s.signed_distance < 0.0 {
            depth = depth.max(radius - s.signed_distance);
        }
    }
    depth
}

/// Penetration of the hand at `link_poses` (from forward kinematics) into the object at
/// `object_pose`.
pub fn penetration(
    robot: &Robot,
    link_poses: &[Isometry3<f64>],
    object: &ObjectGeometry,
    object_pose: &Isometry3<f64>,
) -> Penetration {
    let mut worst = Penetration::default();
    for i in 0..robot.link_count() {
        let d = link_depth(robot, LinkId(i as u32), link_poses, object, object_pose);
        if d > worst.depth_m {
            worst = Penetration {
                depth_m: d,
                link: Some(LinkId(i as u32)),
            };
        }
    }
    worst
}

/// Penetration depth of one link [m].
pub fn link_depth(
    robot: &Robot,
    link: LinkId,
    link_poses: &[Isometry3<f64>],
    object: &ObjectGeometry,
    object_pose: &Isometry3<f64>,
) -> f64 {
    let reach = object.mesh.bounding_radius();
    let pose = &link_poses[link.index()];
    let mut worst: f64 = 0.0;
    for shape in &robot.link(link).collision {
        // Cheap reject: the shape's centre farther than the object's ball plus its extent.
        let centre = pose * Point3::from(shape.origin.translation.vector);
        if (centre.coords - object_pose.translation.vector).norm() > reach + shape_extent(shape) {
            continue;
        }
        worst = worst.max(shape_depth(object, object_pose, shape, pose));
    }
    worst
}

/// Largest distance from a shape's origin to its surface [m].
fn shape_extent(shape: &CollisionShape) -> f64 {
    match &shape.kind {
        ShapeKind::Box { size } => size.norm() / 2.0,
        ShapeKind::Sphere { radius } => *radius,
        ShapeKind::Capsule { radius, length } => length / 2.0 + radius,
        ShapeKind::Cylinder { radius, length } => (radius * radius + length * length / 4.0).sqrt(),
        ShapeKind::Mesh { mesh, .. } => mesh.bounding_radius(),
    }
}

/// The inscribed radius of a shape and points of its core (its own frame) such that a
/// ball of that radius about each core point lies inside the shape.
fn core_points(shape: &CollisionShape) -> (f64, Vec<Point3<f64>>) {
    let axis = |half: f64| -> Vec<Point3<f64>> {
        let n = ((2.0 * half / 0.005).ceil() as usize).max(1);
        (0..=n)
            .map(|i| Point3::new(0.0, 0.0, -half + 2.0 * half * i as f64 / n as f64))
            .collect()
    };
    match &shape.kind {
        ShapeKind::Box { size } => (size.min() / 2.0, vec![Point3::origin()]),
        ShapeKind::Sphere { radius } => (*radius, vec![Point3::origin()]),
        ShapeKind::Capsule { radius, length } => (*radius, axis(length / 2.0)),
        ShapeKind::Cylinder { radius, length } => {
            let r = radius.min(length / 2.0);
            (r, axis((length / 2.0 - r).max(0.0)))
        }
        ShapeKind::Mesh { .. } => (0.0, Vec::new()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::objects::ObjectKind;

    #[test]
    fn cube_signed_distance_and_normal() {
        let geo = ObjectGeometry::new(ObjectKind::Cube.mesh()).unwrap();
        assert!((geo.min_z + 0.03).abs() < 1e-9);
        let s = geo.surface_point(&Point3::new(0.0, 0.0, 0.0));
        assert!((s.signed_distance + 0.03).abs() < 1e-9, "{s:?}");
        let s = geo.surface_point(&Point3::new(0.0, 0.05, 0.0));
        assert!((s.signed_distance - 0.02).abs() < 1e-9, "{s:?}");
        let n = geo.normal(&Point3::new(0.0, 0.03, 0.01));
        assert!((n - Vector3::y()).norm() < 1e-6, "{n}");
    }

    #[test]
    fn the_mug_handle_is_inside_the_object() {
        let mesh = ObjectKind::Mug.mesh();
        assert_eq!(mesh.connected_parts().len(), 2);
        let geo = ObjectGeometry::new(mesh).unwrap();
        let far = geo
            .mesh
            .vertices
            .iter()
            .copied()
            .fold(Point3::origin(), |a, v| if v.x > a.x { v } else { a });
        assert!(far.x > 0.06, "{far}");
        assert!(geo.contains(&Point3::new(far.x - 0.004, 0.0, far.z)));
        assert!(!geo.contains(&Point3::new(far.x + 0.001, 0.0, far.z)));
    }

    #[test]
    fn a_capsule_pressed_into_the_cube_reports_its_depth() {
        use crate::geometry::shape::ShapeKind;
        let geo = ObjectGeometry::new(ObjectKind::Cube.mesh()).unwrap();
        let capsule = CollisionShape::new(
            ShapeKind::Capsule {
                radius: 0.0075,
                length: 0.015,
            },
            Isometry3::identity(),
        )
        .unwrap();
        for (gap, want) in [(0.002, 0.0), (-0.0015, 0.0015), (-0.012, 0.012)] {
            // Capsule axis along x, lying on the +y face.
            let pose = Isometry3::new(
                Vector3::new(0.0, 0.03 + 0.0075 + gap, 0.0),
                Vector3::y() * std::f64::consts::FRAC_PI_2,
            );
            let d = shape_depth(&geo, &Isometry3::identity(), &capsule, &pose);
            assert!((d - want).abs() < 2e-4, "gap {gap}: depth {d}, want {want}");
        }
    }
}
