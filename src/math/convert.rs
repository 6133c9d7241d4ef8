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
//! arrays go through [`quat_from_wxyz`] / [`quat_to_wxyz`] only.

use nalgebra::{Isometry3, Point3, Quaternion, Translation3, UnitQuaternion, Vector3};
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

/// A rotation from a file's `[w, x, y, z]` array, normalised.
///
/// Returns `None` when a component is not finite or the norm is below `1e-9`: such an array
/// is not a rotation, and the caller reports it with the file and field.
pub fn quat_from_wxyz(q: [f64; 4]) -> Option<UnitQuaternion<f64>> {
    if q.iter().any(|c| !c.is_finite()) {
        return None;
    }
    UnitQuaternion::try_new(Quaternion::new(q[0], q[1], q[2], q[3]), 1e-9)
}

/// A rotation as the `[w, x, y, z]` array written to files.
pub fn quat_to_wxyz(q: &UnitQuaternion<f64>) -> [f64; 4] {
    [q.w, q.i, q.j, q.k]
}

/// An isometry from a position `[x, y, z]` and a `[w, x, y, z]` quaternion; `None` when the
/// quaternion is not a rotation (see [`quat_from_wxyz`]) or the position is not finite.
pub fn iso_from_arrays(position: [f64; 3], wxyz: [f64; 4]) -> Option<Isometry3<f64>> {
    if position.iter().any(|c| !c.is_finite()) {
        return None;
    }
    let rotation = quat_from_wxyz(wxyz)?;
    Some(Isometry3::from_parts(
        Translation3::new(position[0], position[1], position[2]),
        rotation,
    ))
}

/// The position `[x, y, z]` and `[w, x, y, z]` quaternion of an isometry.
pub fn iso_to_arrays(p: &Isometry3<f64>) -> ([f64; 3], [f64; 4]) {
    let t = p.translation.vector;
    ([t.x, t.y, t.z], quat_to_wxyz(&p.rotation))
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

    #[test]
    fn wxyz_order_is_w_first() {
        // 90 degrees about z: w = cos 45°, z = sin 45°.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let q = quat_from_wxyz([h, 0.0, 0.0, h]).unwrap();
        let x = q * Vector3::x();
        assert!((x - Vector3::y()).norm() < 1e-12);
        let back = quat_to_wxyz(&q);
        assert!((back[0] - h).abs() < 1e-15 && (back[3] - h).abs() < 1e-15);
    }

    #[test]
    fn wxyz_normalises_and_rejects_garbage() {
        let q = quat_from_wxyz([2.0, 0.0, 0.0, 0.0]).unwrap();
        assert_eq!(quat_to_wxyz(&q), [1.0, 0.0, 0.0, 0.0]);
        assert!(quat_from_wxyz([0.0; 4]).is_none());
        assert!(quat_from_wxyz([f64::NAN, 0.0, 0.0, 1.0]).is_none());
        assert!(iso_from_arrays([f64::INFINITY, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]).is_none());
    }

    #[test]
    fn arrays_round_trip() {
        let iso = sample_iso();
        let (p, q) = iso_to_arrays(&iso);
        let back = iso_from_arrays(p, q).unwrap();
        assert!((back.translation.vector - iso.translation.vector).norm() < 1e-15);
        assert!(back.rotation.angle_to(&iso.rotation) < 1e-12);
    }
}
