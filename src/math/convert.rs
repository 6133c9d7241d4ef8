//! The one place where our nalgebra `f64` types meet rapier/parry's glam types.
//!
//! dexwarp computes in nalgebra (`Vector3<f64>`, `Point3<f64>`, `UnitQuaternion<f64>`,
//! `Isometry3<f64>`); rapier 0.36 and parry 0.31 take glam types (`Vector = DVec3`,
//! `Rotation = DQuat`, `Pose = DPose3`). nalgebra 0.35 (feature `convert-glam033`, enabled
//! through glamx) and glamx (feature `nalgebra`) implement `From` both ways; these functions
//! name the conversions so a reader sees where a value crosses the boundary, and the unit
//! tests pin the round trips.
//!
//! Quaternions in files are stored `[w, x, y, z]` (see `DESIGN.md`); nalgebra's
//! `Quaternion::new(w, i, j, k)` takes the same order, glam's `DQuat::from_xyzw` does not, so
//! arrays go through `math::rotation::quat_from_wxyz` / `quat_to_wxyz` only.

use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};
use rapier3d_f64::parry::math::{Pose, Rotation, Vector};

/// nalgebra vector → glam `DVec3`.
#[inline]
pub fn to_vec(v: &Vector3<f64>) -> Vector {
    (*v).into()
}

/// glam `DVec3` → nalgebra vector.
#[inline]
pub fn from_vec(v: Vector) -> Vector3<f64> {
    v.into()
}

/// nalgebra point → glam `DVec3` (parry represents points as vectors).
#[inline]
pub fn to_point(p: &Point3<f64>) -> Vector {
    (*p).into()
}

/// glam `DVec3` → nalgebra point.
#[inline]
pub fn from_point(p: Vector) -> Point3<f64> {
    p.into()
}

/// nalgebra unit quaternion → glam `DQuat`.
#[inline]
pub fn to_rot(r: &UnitQuaternion<f64>) -> Rotation {
    (*r).into()
}

/// glam `DQuat` → nalgebra unit quaternion. The quaternion is taken as unit, not renormalised.
#[inline]
pub fn from_rot(r: Rotation) -> UnitQuaternion<f64> {
    r.into()
}

/// nalgebra isometry → glam `DPose3` (same rotation, same translation).
#[inline]
pub fn to_pose(p: &Isometry3<f64>) -> Pose {
    (*p).into()
}

/// glam `DPose3` → nalgebra isometry.
#[inline]
pub fn from_pose(p: &Pose) -> Isometry3<f64> {
    (*p).into()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_iso() -> Isometry3<f64> {
        Isometry3::new(Vector3::new(0.1, -2.0, 3.5), Vector3::new(0.3, -0.7, 1.1))
    }

    #[test]
    fn vector_and_point_round_trip() {
        let v = Vector3::new(1.0, -2.5, 1e-12);
        let g = to_vec(&v);
        assert_eq!((g.x, g.y, g.z), (1.0, -2.5, 1e-12));
        assert_eq!(from_vec(g), v);
        let p = Point3::new(-3.0, 0.25, 7.0);
        assert_eq!(from_point(to_point(&p)), p);
    }

    #[test]
    fn rotation_round_trip_and_same_action() {
        let r = sample_iso().rotation;
        let g = to_rot(&r);
        assert_eq!(from_rot(g), r);
        let v = Vector3::new(0.3, 0.2, -0.9);
        let by_glam = from_vec(g * to_vec(&v));
        assert!((by_glam - r * v).norm() < 1e-14, "{by_glam} vs {}", r * v);
    }

    #[test]
    fn pose_round_trip_and_same_action() {
        let iso = sample_iso();
        let pose = to_pose(&iso);
        let back = from_pose(&pose);
        assert!((back.translation.vector - iso.translation.vector).norm() < 1e-15);
        assert!(back.rotation.angle_to(&iso.rotation) < 1e-12);
        let p = Point3::new(0.5, -0.1, 0.2);
        let by_glam = from_point(pose * to_point(&p));
        assert!((by_glam - iso * p).norm() < 1e-14);
    }
}
