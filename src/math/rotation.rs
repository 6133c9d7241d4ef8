//! Rotation helpers: validated quaternion I/O, quaternion averaging, moving-window smoothing.
//!
//! Quaternions are nalgebra `UnitQuaternion<f64>`; on disk they are `[w, x, y, z]` (scalar
//! first). q and −q are the same rotation; functions that return a quaternion say which of the
//! two they pick, so that consecutive frames of a trajectory stay in one hemisphere.
//!
//! Averaging follows Markley, Cheng, Crassidis & Oshman, "Averaging Quaternions" (JGCD 2007):
//! the weighted average of q_1..q_n minimizes Σ w_i ‖R(q) − R(q_i)‖_F², and its solution is
//! the unit eigenvector of the largest eigenvalue of the 4×4 symmetric matrix
//! M = Σ w_i q_i q_iᵀ. M is unchanged when any q_i is replaced by −q_i, so the average does
//! not depend on the input signs (unlike a normalized arithmetic mean).
//!
//! Moving windows ([`windowed_average`], [`windowed_mean`]) are centered and *shrink
//! symmetrically* at the ends: frame i averages frames i−h'..=i+h' with h' = min(h, i,
//! n−1−i). The end frames are therefore kept as they are, and a linear ramp (constant
//! angular velocity about a fixed axis, to first order) is not pulled inward at the ends, as
//! a one-sided truncated window would do.

use nalgebra::{Matrix4, Quaternion, SymmetricEigen, UnitQuaternion, Vector3, Vector4};

/// Largest accepted deviation of a stored quaternion's norm from 1 before normalization.
pub const QUAT_NORM_TOLERANCE: f64 = 1e-3;

/// Why a rotation could not be built or averaged.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RotationError {
    /// A component is NaN or infinite.
    #[error("rotation has a non-finite component ({values:?})")]
    NonFinite { values: [f64; 4] },
    /// The quaternion's norm is too far from 1 to be a rotation written with rounding.
    #[error(
        "quaternion [w, x, y, z] = {wxyz:?} has norm {norm}, not within {QUAT_NORM_TOLERANCE} of 1; \
         store unit quaternions in [w, x, y, z] order"
    )]
    NotUnit { wxyz: [f64; 4], norm: f64 },
    /// Axis-angle with a zero axis but a nonzero angle.
    #[error("rotation axis is zero but the angle is {angle} rad; give a nonzero axis")]
    ZeroAxis { angle: f64 },
    /// Nothing to average.
    #[error("no rotations to average")]
    Empty,
    /// Weights are not one per rotation.
    #[error("{weights} weights for {rotations} rotations; give one weight per rotation")]
    WeightCount { weights: usize, rotations: usize },
    /// A weight is negative or not finite.
    #[error("weight {index} is {value}; weights must be finite and non-negative")]
    BadWeight { index: usize, value: f64 },
    /// All weights are zero.
    #[error("all weights are zero")]
    ZeroWeights,
    /// A value to average is NaN or infinite.
    #[error("value {index} is {value}; values must be finite")]
    NonFiniteValue { index: usize, value: f64 },
    /// The symmetric eigen-solver did not converge.
    #[error("the quaternion-averaging eigen-decomposition did not converge")]
    NoConvergence,
}

/// A unit quaternion from `[w, x, y, z]`, renormalized if its norm is within
/// [`QUAT_NORM_TOLERANCE`] of 1, otherwise an error naming the norm (a zero quaternion or a
/// wrong component order usually shows up here).
pub fn quat_from_wxyz(wxyz: [f64; 4]) -> Result<UnitQuaternion<f64>, RotationError> {
    if wxyz.iter().any(|v| !v.is_finite()) {
        return Err(RotationError::NonFinite { values: wxyz });
    }
    let [w, x, y, z] = wxyz;
    let q = Quaternion::new(w, x, y, z);
    let norm = q.norm();
    if (norm - 1.0).abs() > QUAT_NORM_TOLERANCE {
        return Err(RotationError::NotUnit { wxyz, norm });
    }
    Ok(UnitQuaternion::new_unchecked(q / norm))
}

/// `[w, x, y, z]` of a unit quaternion (the sign is kept as stored).
pub fn quat_to_wxyz(q: &UnitQuaternion<f64>) -> [f64; 4] {
    [q.w, q.i, q.j, q.k]
}

/// Rotation of `angle` [rad] about `axis` (any nonzero length; it is normalized).
///
/// A zero (or subnormal) axis is accepted only with a zero angle, giving the identity;
/// with a nonzero angle the rotation is undefined and an error is returned.
pub fn quat_from_axis_angle(
    axis: &Vector3<f64>,
    angle: f64,
) -> Result<UnitQuaternion<f64>, RotationError> {
    if axis.iter().any(|v| !v.is_finite()) || !angle.is_finite() {
        return Err(RotationError::NonFinite {
            values: [axis.x, axis.y, axis.z, angle],
        });
    }
    let norm = axis.norm();
    if norm < f64::MIN_POSITIVE {
        return if angle == 0.0 {
            Ok(UnitQuaternion::identity())
        } else {
            Err(RotationError::ZeroAxis { angle })
        };
    }
    let (s, c) = (0.5 * angle).sin_cos();
    let v = axis * (s / norm);
    Ok(UnitQuaternion::new_unchecked(Quaternion::new(
        c, v.x, v.y, v.z,
    )))
}

/// Rotation angle from `a` to `b` in [0, π] [rad], the same for ±a and ±b.
///
/// Uses 2·atan2(‖vec(a⁻¹b)‖, |w(a⁻¹b)|), accurate for small angles where acos is not.
pub fn angle_between(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> f64 {
    let d = a.inverse() * b;
    2.0 * d.imag().norm().atan2(d.w.abs())
}

/// Spherical linear interpolation from `a` (t = 0) to `b` (t = 1) along the shorter arc.
///
/// b is replaced by −b when a·b < 0, so the path never exceeds π; the result is in a's
/// hemisphere for t ∈ [0, 1]. t is not clamped (values outside [0, 1] extrapolate along
/// the same great circle). For nearly equal rotations (angle < 1e-6 rad) a normalized
/// linear interpolation is used, where sin θ would lose all precision.
pub fn slerp_shortest(
    a: &UnitQuaternion<f64>,
    b: &UnitQuaternion<f64>,
    t: f64,
) -> UnitQuaternion<f64> {
    let qa = a.coords;
    let mut qb = b.coords;
    let mut cos = qa.dot(&qb);
    if cos < 0.0 {
        qb = -qb;
        cos = -cos;
    }
    // θ = half the rotation angle; clamp against rounding just above 1.
    let sin = (qb - qa * cos).norm();
    let theta = sin.atan2(cos.min(1.0));
    let v: Vector4<f64> = if theta < 5e-7 {
        qa * (1.0 - t) + qb * t
    } else {
        (qa * ((1.0 - t) * theta).sin() + qb * (t * theta).sin()) / theta.sin()
    };
    UnitQuaternion::from_quaternion(Quaternion::from(v))
}

/// Weighted average rotation (Markley's eigenvector method, see the module docs).
///
/// `weights` = `None` means equal weights; otherwise one finite, non-negative weight per
/// rotation, not all zero. The result's sign is chosen in the hemisphere of the input with
/// the largest weight (the first one on ties). When the largest eigenvalue is repeated (e.g.
/// two rotations π apart with equal weights) the average is not unique; the member of the
/// top eigenspace closest to that same input is returned, so the result is deterministic.
pub fn average_quaternions(
    quats: &[UnitQuaternion<f64>],
    weights: Option<&[f64]>,
) -> Result<UnitQuaternion<f64>, RotationError> {
    if quats.is_empty() {
        return Err(RotationError::Empty);
    }
    if let Some(w) = weights {
        if w.len() != quats.len() {
            return Err(RotationError::WeightCount {
                weights: w.len(),
                rotations: quats.len(),
            });
        }
        if let Some(index) = w.iter().position(|v| !v.is_finite() || *v < 0.0) {
            return Err(RotationError::BadWeight {
                index,
                value: w[index],
            });
        }
        if w.iter().all(|v| *v == 0.0) {
            return Err(RotationError::ZeroWeights);
        }
    }
    let weight = |i: usize| weights.map_or(1.0, |w| w[i]);
    let heaviest =
        (0..quats.len()).fold(0, |best, i| if weight(i) > weight(best) { i } else { best });
    average_near(quats, weight, &quats[heaviest])
}

/// Markley average of `quats` with weights `weight(i)` (validated by the caller), sign and
/// tie-break taken from `reference`.
fn average_near(
    quats: &[UnitQuaternion<f64>],
    weight: impl Fn(usize) -> f64,
    reference: &UnitQuaternion<f64>,
) -> Result<UnitQuaternion<f64>, RotationError> {
    let mut m = Matrix4::zeros();
    for (i, q) in quats.iter().enumerate() {
        if q.coords.iter().any(|v| !v.is_finite()) {
            let c = q.coords;
            return Err(RotationError::NonFinite {
                values: [c.w, c.x, c.y, c.z],
            });
        }
        m += q.coords * q.coords.transpose() * weight(i);
    }
    let total = m.trace();
    if quats.len() == 1 || total <= 0.0 {
        return Ok(*reference);
    }
    // Scale to trace 1 so the eigenvalue tolerances below are absolute.
    let eig =
        SymmetricEigen::try_new(m / total, 1e-15, 10_000).ok_or(RotationError::NoConvergence)?;
    let top = eig.eigenvalues.imax();
    let lambda = eig.eigenvalues[top];
    // Project the reference onto the (possibly multi-dimensional) top eigenspace.
    let r = reference.coords;
    let mut v = Vector4::zeros();
    for j in 0..4 {
        if eig.eigenvalues[j] >= lambda - 1e-12 {
            let e = eig.eigenvectors.column(j);
            v += e * e.dot(&r);
        }
    }
    if v.norm() < 1e-9 {
        // Reference orthogonal to the top eigenspace: any member is an average; take the top one.
        v = eig.eigenvectors.column(top).into_owned();
    }
    if v.dot(&r) < 0.0 {
        v = -v;
    }
    Ok(UnitQuaternion::from_quaternion(Quaternion::from(v)))
}

/// Centered moving-window average of a rotation sequence, window 2·`half_window`+1 frames,
/// shrinking symmetrically at the ends (see the module docs). Each output is in the same
/// hemisphere as the input at that frame (q_out · q_in ≥ 0), so the smoothed sequence has
/// no sign flips that the input did not have.
pub fn windowed_average(
    quats: &[UnitQuaternion<f64>],
    half_window: usize,
) -> Result<Vec<UnitQuaternion<f64>>, RotationError> {
    let n = quats.len();
    (0..n)
        .map(|i| {
            let h = half_window.min(i).min(n - 1 - i);
            average_near(&quats[i - h..=i + h], |_| 1.0, &quats[i])
        })
        .collect()
}

/// Centered moving average of a scalar sequence (e.g. one joint angle [rad]), window
/// 2·`half_window`+1 samples, shrinking symmetrically at the ends (see the module docs).
///
/// Values are averaged as real numbers: unwrap continuous-joint angles before calling.
/// Non-finite values are an error, since they would spread over the window.
pub fn windowed_mean(values: &[f64], half_window: usize) -> Result<Vec<f64>, RotationError> {
    if let Some(index) = values.iter().position(|v| !v.is_finite()) {
        return Err(RotationError::NonFiniteValue {
            index,
            value: values[index],
        });
    }
    let n = values.len();
    Ok((0..n)
        .map(|i| {
            let h = half_window.min(i).min(n - 1 - i);
            values[i - h..=i + h].iter().sum::<f64>() / (2 * h + 1) as f64
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::f64::consts::PI;

    fn rot(axis: [f64; 3], angle: f64) -> UnitQuaternion<f64> {
        quat_from_axis_angle(&Vector3::from(axis), angle).unwrap()
    }

    fn flip(q: &UnitQuaternion<f64>) -> UnitQuaternion<f64> {
        UnitQuaternion::new_unchecked(-q.into_inner())
    }

    #[test]
    fn wxyz_round_trip_and_validation() {
        let q = rot([1.0, 2.0, -0.5], 0.7);
        let back = quat_from_wxyz(quat_to_wxyz(&q)).unwrap();
        assert_eq!(quat_to_wxyz(&back), quat_to_wxyz(&q));
        // Scalar first: [1, 0, 0, 0] is the identity.
        assert_eq!(
            quat_from_wxyz([1.0, 0.0, 0.0, 0.0]).unwrap(),
            UnitQuaternion::identity()
        );
        let slightly_off = quat_from_wxyz([1.0005, 0.0, 0.0, 0.0]).unwrap();
        assert!((slightly_off.into_inner().norm() - 1.0).abs() < 1e-15);
        assert!(matches!(
            quat_from_wxyz([0.0; 4]),
            Err(RotationError::NotUnit { .. })
        ));
        assert!(matches!(
            quat_from_wxyz([1.01, 0.0, 0.0, 0.0]),
            Err(RotationError::NotUnit { .. })
        ));
        assert!(matches!(
            quat_from_wxyz([f64::NAN, 0.0, 0.0, 1.0]),
            Err(RotationError::NonFinite { .. })
        ));
    }

    #[test]
    fn axis_angle_validation() {
        let q = rot([0.0, 0.0, 2.0], PI / 2.0);
        let v = q * Vector3::x();
        assert!((v - Vector3::y()).norm() < 1e-15);
        assert_eq!(rot([0.0; 3], 0.0), UnitQuaternion::identity());
        assert_eq!(
            quat_from_axis_angle(&Vector3::zeros(), 0.1),
            Err(RotationError::ZeroAxis { angle: 0.1 })
        );
        assert!(quat_from_axis_angle(&Vector3::x(), f64::INFINITY).is_err());
    }

    #[test]
    fn angle_and_slerp() {
        let a = rot([0.0, 1.0, 0.0], 0.3);
        let b = rot([0.0, 1.0, 0.0], 1.1);
        assert!((angle_between(&a, &b) - 0.8).abs() < 1e-14);
        assert!((angle_between(&a, &flip(&b)) - 0.8).abs() < 1e-14);
        let tiny = rot([1.0, 0.0, 0.0], 1e-9);
        assert!((angle_between(&UnitQuaternion::identity(), &tiny) - 1e-9).abs() < 1e-20);
        let mid = slerp_shortest(&a, &flip(&b), 0.25);
        assert!(angle_between(&mid, &rot([0.0, 1.0, 0.0], 0.5)) < 1e-14);
        assert!(mid.coords.dot(&a.coords) > 0.0, "stays in a's hemisphere");
        assert!(angle_between(&slerp_shortest(&a, &a, 0.3), &a) < 1e-15);
        let near = slerp_shortest(&a, &(a * tiny), 0.5);
        assert!(angle_between(&near, &(a * rot([1.0, 0.0, 0.0], 5e-10))) < 1e-15);
    }

    #[test]
    fn symmetric_set_averages_to_its_center() {
        let q = rot([0.3, -1.0, 0.2], 2.0);
        let mut set = vec![q];
        for axis in [
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, -1.0],
        ] {
            set.push(q * rot(axis, 0.4));
            set.push(q * rot(axis, -0.4));
        }
        let avg = average_quaternions(&set, None).unwrap();
        assert!(angle_between(&avg, &q) < 1e-12);
        assert!(avg.coords.dot(&q.coords) > 0.0);
    }

    #[test]
    fn average_is_invariant_to_input_signs() {
        let set: Vec<_> = (0..7)
            .map(|i| rot([1.0, 0.5 * i as f64, -0.2], 0.1 * i as f64))
            .collect();
        let w: Vec<f64> = (0..7).map(|i| 1.0 + i as f64).collect();
        let avg = average_quaternions(&set, Some(&w)).unwrap();
        let flipped: Vec<_> = set
            .iter()
            .enumerate()
            .map(|(i, q)| if i % 2 == 1 { flip(q) } else { *q })
            .collect();
        let avg2 = average_quaternions(&flipped, Some(&w)).unwrap();
        assert!(angle_between(&avg, &avg2) < 1e-12);
        // The heaviest input (the last, not flipped) fixes the sign: same coordinates.
        assert!(avg2.coords.dot(&set[6].coords) > 0.0);
        assert!((avg.coords - avg2.coords).norm() < 1e-12);
    }

    #[test]
    fn weights_select_and_validate() {
        let a = rot([0.0, 0.0, 1.0], 0.2);
        let b = rot([0.0, 0.0, 1.0], 1.0);
        assert!(
            angle_between(
                &average_quaternions(&[a, b], Some(&[1.0, 0.0])).unwrap(),
                &a
            ) < 1e-12
        );
        // Two rotations: the Markley average lies on the geodesic, here at the midpoint.
        let mid = average_quaternions(&[a, b], None).unwrap();
        assert!(angle_between(&mid, &rot([0.0, 0.0, 1.0], 0.6)) < 1e-12);
        assert_eq!(average_quaternions(&[], None), Err(RotationError::Empty));
        assert!(matches!(
            average_quaternions(&[a], Some(&[])),
            Err(RotationError::WeightCount { .. })
        ));
        assert!(matches!(
            average_quaternions(&[a], Some(&[-1.0])),
            Err(RotationError::BadWeight { .. })
        ));
        assert_eq!(
            average_quaternions(&[a], Some(&[0.0])),
            Err(RotationError::ZeroWeights)
        );
    }

    #[test]
    fn ambiguous_average_is_deterministic() {
        // Identity and a half-turn with equal weights: every rotation about z between them is
        // an average; the one closest to the first input (identity) is returned.
        let a = UnitQuaternion::identity();
        let b = rot([0.0, 0.0, 1.0], PI);
        let avg = average_quaternions(&[a, b], None).unwrap();
        assert!(
            angle_between(&avg, &a) < 1e-9,
            "got angle {}",
            angle_between(&avg, &a)
        );
    }

    #[test]
    fn windowed_average_of_a_constant_is_the_constant() {
        let q = rot([1.0, -2.0, 0.5], 2.5);
        let seq: Vec<_> = (0..20)
            .map(|i| if i % 3 == 0 { flip(&q) } else { q })
            .collect();
        let out = windowed_average(&seq, 4).unwrap();
        assert_eq!(out.len(), 20);
        for (o, i) in out.iter().zip(&seq) {
            assert!(angle_between(o, &q) < 1e-12);
            assert!(
                o.coords.dot(&i.coords) > 0.0,
                "output keeps the input's hemisphere"
            );
        }
        assert!(windowed_average(&[], 3).unwrap().is_empty());
    }

    #[test]
    fn windowed_average_keeps_ends_and_constant_rate_rotation() {
        let seq: Vec<_> = (0..15)
            .map(|i| rot([0.2, 1.0, 0.0], 0.05 * i as f64))
            .collect();
        let out = windowed_average(&seq, 3).unwrap();
        for (o, i) in out.iter().zip(&seq) {
            assert!(angle_between(o, i) < 1e-12);
        }
    }

    #[test]
    fn windowed_mean_shrinks_symmetrically() {
        let x = [0.0, 10.0, 0.0, 10.0, 0.0];
        let y = windowed_mean(&x, 1).unwrap();
        assert_eq!(y[0], 0.0);
        assert!((y[1] - 10.0 / 3.0).abs() < 1e-15);
        assert!((y[2] - 20.0 / 3.0).abs() < 1e-15);
        assert_eq!(y[4], 0.0);
        let ramp: Vec<f64> = (0..10).map(|i| 0.1 * i as f64).collect();
        let r = windowed_mean(&ramp, 3).unwrap();
        assert!(r.iter().zip(&ramp).all(|(a, b)| (a - b).abs() < 1e-14));
        assert!(windowed_mean(&[1.0, f64::NAN], 1).is_err());
        assert!(windowed_mean(&[], 1).unwrap().is_empty());
    }

    fn any_quat() -> impl Strategy<Value = UnitQuaternion<f64>> {
        (prop::array::uniform3(-1.0f64..1.0), -PI..PI).prop_filter_map("nonzero axis", |(a, t)| {
            let axis = Vector3::from(a);
            (axis.norm() > 1e-3).then(|| rot(a, t))
        })
    }

    proptest! {
        #[test]
        fn prop_average_ignores_signs_and_order(
            qs in prop::collection::vec(any_quat(), 1..8),
            flips in prop::collection::vec(any::<bool>(), 8),
        ) {
            // Keep the set within a half-turn so the average is unique.
            let center = qs[0];
            let set: Vec<_> = qs.iter().map(|q| slerp_shortest(&center, q, 0.3)).collect();
            let avg = average_quaternions(&set, None).unwrap();
            let mut flipped: Vec<_> = set.iter().zip(&flips).map(|(q, f)| if *f { flip(q) } else { *q }).collect();
            flipped.reverse();
            let avg2 = average_quaternions(&flipped, None).unwrap();
            prop_assert!(angle_between(&avg, &avg2) < 1e-9);
            // The average is within the set's spread of its first member.
            let spread = set.iter().map(|q| angle_between(q, &center)).fold(0.0, f64::max);
            prop_assert!(angle_between(&avg, &center) <= spread + 1e-9);
        }

        #[test]
        fn prop_slerp_ends_and_midpoint(a in any_quat(), b in any_quat()) {
            prop_assert!(angle_between(&slerp_shortest(&a, &b, 0.0), &a) < 1e-9);
            prop_assert!(angle_between(&slerp_shortest(&a, &b, 1.0), &b) < 1e-7);
            let m = slerp_shortest(&a, &b, 0.5);
            let d = angle_between(&a, &b);
            prop_assert!((angle_between(&a, &m) - d / 2.0).abs() < 1e-7);
            prop_assert!((angle_between(&m, &b) - d / 2.0).abs() < 1e-7);
        }
    }
}
