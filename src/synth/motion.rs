//! Scripted object motions of the in-contact segment: `lift_place`, `pour`, `pass`.
//!
//! Every motion is a sum of minimum-jerk steps (Flash & Hogan 1985),
//! `mj(s) = 10 s³ − 15 s⁴ + 6 s⁵` for `s ∈ [0, 1]` (0 before, 1 after), each shifted and
//! scaled in time, so position, velocity and acceleration are continuous and the object
//! starts and ends at rest. With `τ ∈ [0, 1]` the normalised time of the motion:
//!
//! - `lift_place`: rise `h·mj(τ/r)`, carry `d·mj((τ − a)/(1 − 2a))`, descend
//!   `(d_z − h)·mj((τ − 1 + r)/r)` with `r` = [`MotionParams::rise_frac`] (0.35 by default)
//!   and `a = 3r/7` (0.15): the object leaves the support vertically, travels in an arc and
//!   comes down vertically onto the place position `start + d`. A smaller `r` overlaps the
//!   rise and the descent more with the carry, which then spans more of the motion: the path
//!   length travelled grows more evenly with time.
//! - `pass`: as `lift_place` with the carry bowed sideways by `a·sin(π·c)` (`c` the carry
//!   progress, `a` = [`MotionParams::arc_m`]): the object is handed along a curve.
//! - `pour`: rise and carry a fraction `f` of `d` to the pour spot, tilt by `θ` about a world
//!   axis (`θ·[mj((τ − 0.36)/0.14) − mj((τ − 0.62)/0.14)]`), hold, untilt, carry the rest
//!   and come down. The object rotates about its own origin (as the warp does).
//!
//! Positions are of the object origin in the world [m]; the start pose is the object resting
//! on its support.

use std::fmt;
use std::str::FromStr;

use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};

/// The scripted motions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Motion {
    /// Lift, carry, place elsewhere.
    LiftPlace,
    /// Lift, tilt to pour, untilt, place.
    Pour,
    /// Lift, carry over and along a curve, place.
    Pass,
}

impl Motion {
    /// Every motion, in a fixed order.
    pub const ALL: [Motion; 3] = [Motion::LiftPlace, Motion::Pour, Motion::Pass];

    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Motion::LiftPlace => "lift_place",
            Motion::Pour => "pour",
            Motion::Pass => "pass",
        }
    }
}

impl fmt::Display for Motion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A motion name that [`Motion::from_str`] does not know.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown motion '{name}'; valid motions are: {}", Motion::ALL.map(Motion::name).join(", "))]
pub struct UnknownMotion {
    /// The name as given.
    pub name: String,
}

impl FromStr for Motion {
    type Err = UnknownMotion;

    /// Accepts the [`Motion::name`]s case-insensitively, with `-` for `_`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let key = s.trim().to_ascii_lowercase().replace('-', "_");
        Motion::ALL
            .into_iter()
            .find(|m| m.name() == key || (key == "liftplace" && *m == Motion::LiftPlace))
            .ok_or_else(|| UnknownMotion {
                name: s.to_string(),
            })
    }
}

/// Shape of the in-contact motion.
#[derive(Clone, Debug, PartialEq)]
pub struct MotionParams {
    /// Displacement of the object origin from its start to its place position (world) [m];
    /// a non-zero `z` places the object on a higher or lower support.
    pub carry: Vector3<f64>,
    /// Height of the carry above the start [m].
    pub lift_m: f64,
    /// Sideways bow of a `pass` (horizontal, left of the carry direction) [m].
    pub arc_m: f64,
    /// Pour angle [rad] (`pour` only).
    pub tilt_rad: f64,
    /// World axis of the pour tilt (`pour` only).
    pub tilt_axis: Vector3<f64>,
    /// Fraction of the carry done before the pour (`pour` only).
    pub pour_at: f64,
    /// Fraction of the motion the rise and the descent each take (`lift_place`, `pass`).
    pub rise_frac: f64,
}

impl Default for MotionParams {
    fn default() -> Self {
        MotionParams {
            carry: Vector3::new(-0.4, 0.0, 0.0),
            lift_m: 0.12,
            arc_m: 0.0,
            tilt_rad: 0.0,
            tilt_axis: Vector3::y(),
            pour_at: 0.6,
            rise_frac: 0.35,
        }
    }
}

/// Minimum-jerk step: 0 for `s ≤ 0`, 1 for `s ≥ 1`, `10s³ − 15s⁴ + 6s⁵` in between.
pub fn min_jerk(s: f64) -> f64 {
    let s = s.clamp(0.0, 1.0);
    s * s * s * (10.0 + s * (-15.0 + 6.0 * s))
}

/// `min_jerk((τ − a)/w)`.
fn step(tau: f64, a: f64, w: f64) -> f64 {
    min_jerk((tau - a) / w)
}

/// The object pose at normalised motion time `tau ∈ [0, 1]`, from its resting `start`.
pub fn object_pose(
    motion: Motion,
    params: &MotionParams,
    start: &Isometry3<f64>,
    tau: f64,
) -> Isometry3<f64> {
    let d = params.carry;
    let horizontal = Vector3::new(d.x, d.y, 0.0);
    let h = params.lift_m;
    let (offset, angle) = match motion {
        Motion::LiftPlace | Motion::Pass => {
            let r = params.rise_frac.clamp(0.05, 0.5);
            let a = 3.0 * r / 7.0;
            let c = step(tau, a, 1.0 - 2.0 * a);
            let z = h * step(tau, 0.0, r) + (d.z - h) * step(tau, 1.0 - r, r);
            let mut o = horizontal * c + Vector3::z() * z;
            if motion == Motion::Pass && horizontal.norm() > 1e-9 {
                let left = Vector3::z().cross(&horizontal).normalize();
                o += left * params.arc_m * (std::f64::consts::PI * c).sin();
            }
            (o, 0.0)
        }
        Motion::Pour => {
            let f = params.pour_at.clamp(0.0, 1.0);
            let c = f * step(tau, 0.04, 0.32) + (1.0 - f) * step(tau, 0.72, 0.2);
            let z = h * step(tau, 0.0, 0.28) + (d.z - h) * step(tau, 0.8, 0.2);
            let angle = params.tilt_rad * (step(tau, 0.36, 0.14) - step(tau, 0.62, 0.14));
            (horizontal * c + Vector3::z() * z, angle)
        }
    };
    let rotation = match Unit::try_new(params.tilt_axis, 1e-12) {
        Some(axis) if angle != 0.0 => UnitQuaternion::from_axis_angle(&axis, angle),
        _ => UnitQuaternion::identity(),
    };
    Isometry3::from_parts(
        Translation3::from(start.translation.vector + offset),
        rotation * start.rotation,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn min_jerk_is_a_smooth_step() {
        assert_eq!(min_jerk(-1.0), 0.0);
        assert_eq!(min_jerk(2.0), 1.0);
        assert!((min_jerk(0.5) - 0.5).abs() < 1e-12);
        let h = 1e-6;
        for s in [1e-3, 1.0 - 1e-3] {
            let v = (min_jerk(s + h) - min_jerk(s - h)) / (2.0 * h);
            assert!(v.abs() < 1e-3, "velocity {v} at {s}");
        }
    }

    #[test]
    fn motions_start_at_rest_and_end_at_the_place_position() {
        let start = Isometry3::translation(1.0, 2.0, 0.9);
        let params = MotionParams {
            carry: Vector3::new(-0.3, 0.1, 0.05),
            tilt_rad: 0.8,
            arc_m: 0.05,
            ..MotionParams::default()
        };
        for m in Motion::ALL {
            let a = object_pose(m, &params, &start, 0.0);
            let b = object_pose(m, &params, &start, 1.0);
            assert!((a.translation.vector - start.translation.vector).norm() < 1e-12);
            let want = start.translation.vector + params.carry;
            assert!((b.translation.vector - want).norm() < 1e-12, "{m}");
            assert!(b.rotation.angle() < 1e-12, "{m}");
            let mid = object_pose(m, &params, &start, 0.5);
            assert!(mid.translation.z > 0.9 + 0.1, "{m} lifts");
        }
        let tilted = object_pose(Motion::Pour, &params, &start, 0.56);
        assert!((tilted.rotation.angle() - 0.8).abs() < 1e-9);
    }

    #[test]
    fn a_smaller_rise_frac_moves_the_object_at_a_more_even_pace() {
        let start = Isometry3::translation(0.0, 0.0, 0.9);
        // RMS deviation of the normalised path length travelled from the normalised time: 0
        // for a constant speed.
        let unevenness = |rise_frac: f64| {
            let params = MotionParams {
                carry: Vector3::new(-0.45, 0.0, 0.0),
                rise_frac,
                ..MotionParams::default()
            };
            let n = 1000;
            let p = |k: usize| {
                object_pose(Motion::LiftPlace, &params, &start, k as f64 / n as f64)
                    .translation
                    .vector
            };
            let mut s = vec![0.0];
            for k in 0..n {
                s.push(s[k] + (p(k + 1) - p(k)).norm());
            }
            let total = s[n];
            let sum: f64 = (0..=n)
                .map(|k| (s[k] / total - k as f64 / n as f64).powi(2))
                .sum();
            (sum / (n + 1) as f64).sqrt()
        };
        let (wide, overlapped) = (unevenness(0.35), unevenness(0.2));
        assert!((wide - 0.0745).abs() < 2e-3, "{wide}");
        assert!((overlapped - 0.0351).abs() < 2e-3, "{overlapped}");
        let params = MotionParams {
            carry: Vector3::new(-0.45, 0.0, 0.0),
            rise_frac: 0.2,
            ..MotionParams::default()
        };
        let end = object_pose(Motion::LiftPlace, &params, &start, 1.0);
        assert!((end.translation.vector - Vector3::new(-0.45, 0.0, 0.9)).norm() < 1e-12);
    }

    #[test]
    fn names_parse_and_unknown_names_list_the_valid_ones() {
        assert_eq!("lift-place".parse::<Motion>().unwrap(), Motion::LiftPlace);
        assert_eq!("POUR".parse::<Motion>().unwrap(), Motion::Pour);
        let msg = "juggle".parse::<Motion>().unwrap_err().to_string();
        assert!(msg.contains("juggle") && msg.contains("lift_place, pour, pass"));
    }
}
