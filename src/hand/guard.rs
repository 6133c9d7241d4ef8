//! Stage 5b: smoothing never presses the hand into the object (docs/METHOD.md, "Smoothing
//! without pressing in"). The pipeline runs it last, over every output frame, so the same
//! rule also covers the fade at the contact segment's ends ([`super::smooth::ease_ends`])
//! and the hand's barrier push-out outside the segment ([`super::pushout`]), which moved
//! the community LEAP hand's thumb 7 mm into the cube on the first frame after the release.
//!
//! Smoothing averages neighbouring IK solutions. Where consecutive output frames use input
//! frames far apart (`t*` jumps where the retiming compresses time: frames where the
//! object rests get almost no output time), the neighbours are different grasps, and their
//! average can put fingers several millimetres inside the object although neither
//! neighbour does. Measured on the built-in configs before this stage: up to 14.8 mm on
//! teapot_pour_empty and 12.3 mm on cube_messy2, from IK frames at or below 1 mm.
//!
//! The rule: at every smoothed frame `t`, the hand may be at most
//! `allowed(t) = max(depth_raw(t), tolerance)` deep, where `depth_raw` is the deepest
//! probe of the unsmoothed (IK) hand. A frame that is deeper gets the smallest blend
//! `α(t) ∈ [0, 1]` toward its unsmoothed configuration that brings it within the limit
//! (bisection; `α = 1` is the IK solution itself, which meets the rule by definition).
//! So that the correction does not put a step into the smoothed path, `α` is spread to the
//! neighbours with a tent of half width `spread` frames (`α'(t) = max_s α(s)·(1 −
//! |t − s|/(spread + 1))`); frames still too deep after that are set to `α = 1`.
//! The blend interpolates the wrist translation and joint values linearly and the wrist
//! rotation by normalized quaternion interpolation.

use std::ops::RangeInclusive;
use std::time::Instant;

use nalgebra::{Isometry3, Translation3};
use serde::{Deserialize, Serialize};

use super::HandPath;
use crate::geometry::ObjectSdf;
use crate::robot::Robot;

/// Parameters of the guard.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Params {
    /// Depth the smoothing may always reach [m] (the IK's penetration tolerance).
    pub tolerance_m: f64,
    /// Half width of the tent that spreads a correction to the neighbours [frames].
    pub spread: usize,
    /// Bisection steps for `α` (resolution `2^-steps`).
    pub bisection_steps: usize,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            tolerance_m: 1e-3,
            spread: 4,
            bisection_steps: 8,
        }
    }
}

/// What the guard changed.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Frames where the smoothed hand was deeper than allowed.
    pub frames_too_deep: usize,
    /// Frames blended toward the unsmoothed hand (the above and their neighbours).
    pub frames_blended: usize,
    /// Deepest hand-object penetration of the smoothed hand before the guard [mm].
    pub max_depth_before_mm: f64,
    /// Deepest penetration after the guard [mm].
    pub max_depth_after_mm: f64,
    /// Wall time [s].
    pub time_s: f64,
}

/// The pose and joints of `a` blended toward `b` by `alpha` (0 = `a`, 1 = `b`).
fn blend(
    a: (&Isometry3<f64>, &[f64]),
    b: (&Isometry3<f64>, &[f64]),
    alpha: f64,
    q: &mut [f64],
) -> Isometry3<f64> {
    let t = a.0.translation.vector.lerp(&b.0.translation.vector, alpha);
    let r = a.0.rotation.nlerp(&b.0.rotation, alpha);
    for ((o, x), y) in q.iter_mut().zip(a.1).zip(b.1) {
        *o = x + (y - x) * alpha;
    }
    Isometry3::from_parts(Translation3::from(t), r)
}

/// Deepest probe of the hand `(wrist, q)` in the object at `object` [m] (0 if none).
struct Depth<'a> {
    robot: &'a Robot,
    sdf: &'a ObjectSdf,
    poses: Vec<Isometry3<f64>>,
}

impl Depth<'_> {
    fn of(&mut self, wrist: &Isometry3<f64>, q: &[f64], object: &Isometry3<f64>) -> f64 {
        self.robot.forward_kinematics(wrist, q, &mut self.poses);
        crate::robot::probes::deepest(self.robot, &self.poses, &object.inverse(), self.sdf)
            .map_or(0.0, |(d, _)| d)
    }
}

/// Applies the guard to `smoothed` inside `range` (see the module docs). `raw` is the hand
/// before smoothing, `object(t)` the object's pose at output frame `t`.
pub fn run(
    robot: &Robot,
    sdf: &ObjectSdf,
    object: impl Fn(usize) -> Isometry3<f64>,
    raw: &HandPath,
    smoothed: &mut HandPath,
    range: RangeInclusive<usize>,
    params: &Params,
) -> Stats {
    let clock = Instant::now();
    let dof = raw.dof;
    let (a, b) = (
        *range.start(),
        (*range.end()).min(raw.len().saturating_sub(1)),
    );
    let mut stats = Stats::default();
    if a > b || smoothed.len() != raw.len() {
        return stats;
    }
    let mut depth = Depth {
        robot,
        sdf,
        poses: robot.new_link_poses(),
    };
    let mut q = vec![0.0; dof];
    let n = b + 1 - a;
    let mut allowed = vec![0.0; n];
    let mut alpha = vec![0.0f64; n];
    for t in a..=b {
        let pose = object(t);
        let d_raw = depth.of(&raw.wrists[t], raw.q(t), &pose);
        let d_smooth = depth.of(&smoothed.wrists[t], smoothed.q(t), &pose);
        allowed[t - a] = d_raw.max(params.tolerance_m);
        stats.max_depth_before_mm = stats.max_depth_before_mm.max(d_smooth * 1e3);
        if d_smooth <= allowed[t - a] {
            continue;
        }
        stats.frames_too_deep += 1;
        // Smallest α with depth ≤ allowed; α = 1 (the raw hand) always qualifies.
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..params.bisection_steps {
            let mid = 0.5 * (lo + hi);
            let w = blend(
                (&smoothed.wrists[t], smoothed.q(t)),
                (&raw.wrists[t], raw.q(t)),
                mid,
                &mut q,
            );
            if depth.of(&w, &q, &pose) <= allowed[t - a] {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        alpha[t - a] = hi;
    }
    if stats.frames_too_deep == 0 {
        stats.max_depth_after_mm = stats.max_depth_before_mm;
        stats.time_s = clock.elapsed().as_secs_f64();
        return stats;
    }

    let original = smoothed.clone();
    let tent = |alpha: &[f64]| -> Vec<f64> {
        let h = params.spread;
        (0..n)
            .map(|t| {
                (t.saturating_sub(h)..=(t + h).min(n - 1))
                    .map(|s| alpha[s] * (1.0 - t.abs_diff(s) as f64 / (h as f64 + 1.0)))
                    .fold(0.0, f64::max)
            })
            .collect()
    };
    // Two passes: spread, apply, and raise the frames still too deep to α = 1.
    for pass in 0..2 {
        let spread = tent(&alpha);
        let mut still = false;
        stats.frames_blended = 0;
        stats.max_depth_after_mm = 0.0;
        for t in a..=b {
            let s = spread[t - a];
            let pose = object(t);
            if s > 0.0 {
                stats.frames_blended += 1;
                let w = blend(
                    (&original.wrists[t], original.q(t)),
                    (&raw.wrists[t], raw.q(t)),
                    s,
                    &mut q,
                );
                smoothed.wrists[t] = w;
                smoothed.joints[t * dof..(t + 1) * dof].copy_from_slice(&q);
            }
            let d = depth.of(&smoothed.wrists[t], smoothed.q(t), &pose);
            if d > allowed[t - a] + 1e-9 && pass == 0 {
                alpha[t - a] = 1.0;
                still = true;
            }
            stats.max_depth_after_mm = stats.max_depth_after_mm.max(d * 1e3);
        }
        if !still {
            break;
        }
    }
    stats.time_s = clock.elapsed().as_secs_f64();
    stats
}
