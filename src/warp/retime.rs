//! Stage 3: temporal retiming (METHOD.md stage 3, paper "Temporal Waypoint-Constrained Object
//! Warping").
//!
//! 1. For each segment between consecutive anchors (input frames `t_i..=t_{i+1}`), a normalized
//!    timewarp `τ_i: [0,1] → [0,1]` is built from the segment's positions, then scaled and
//!    shifted to `[t'_i, t'_{i+1}]`; composing them gives the global timewarp `τ`: input frame →
//!    output time (real-valued, strictly increasing). Two rules:
//!    * `chord` (METHOD.md, the paper; default): `τ_i` maps uniform time to the chord-length
//!      parameter of the segment, so the object moves at constant speed along each segment.
//!      Each step's length is floored at `min_speed_fraction` of the segment's mean step, so
//!      frames where the object rests still take time and `τ` stays strictly increasing.
//!    * `speed`: each step takes output time proportional to `(ℓ' + ε)/(ℓ + ε)`, its warped
//!      length over its original length (ε = 1 mm, ratio clamped to [1/8, 8]), so the
//!      demonstration's own speed profile is kept where the path is not stretched. An identity
//!      warp gives the identity timewarp exactly.
//! 2. One global cubic B-spline (C²) interpolates the warped positions of the contact segment
//!    at parameters `τ(frame)` (NURBS Book A9.1, [`crate::math::bspline`]); every anchor sits
//!    at an integer `t'`, so every waypoint is hit at its output frame. It is sampled at the
//!    integer output frames `c0..=t'_end`.
//! 3. Orientation at output frame `t`: slerp between the warped rotations of the input frames
//!    `s` and `s+1` that bracket `t` in `τ` (continuous, exact at input frames).
//! 4. The pre-contact frames keep their times; the post-contact frames are shifted by
//!    `t'_end − c1`.

use std::time::Instant;

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::ObjectPath;
use super::plan::WarpPlan;
use crate::math::bspline::BSpline;

/// Timewarp rule of the retiming (stage 3; see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RetimeMode {
    /// Constant speed along each segment between waypoints (the paper).
    #[default]
    Chord,
    /// Keep the demonstration's speed profile, scaled by the stretch of each step.
    Speed,
}

/// Parameters of the retiming.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Params {
    /// Timewarp rule. Default `chord`.
    pub mode: RetimeMode,
    /// `chord` mode: floor of a step's length as a fraction of the segment's mean step.
    /// Default 0.05.
    pub min_speed_fraction: f64,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            mode: RetimeMode::Chord,
            min_speed_fraction: 0.05,
        }
    }
}

/// The global timewarp τ: output time [frames] of every input frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Timewarp {
    pub tau: Vec<f64>,
    /// Number of output frames.
    pub frames_out: usize,
}

impl Timewarp {
    /// The identity timewarp over `n` frames.
    pub fn identity(n: usize) -> Timewarp {
        Timewarp {
            tau: (0..n).map(|i| i as f64).collect(),
            frames_out: n,
        }
    }

    /// `t*`: the last input frame `s` with `τ(s) ≤ t` (the first frame when none is).
    pub fn source_frame(&self, t: f64) -> usize {
        self.tau
            .partition_point(|&x| x <= t + 1e-9)
            .saturating_sub(1)
    }

    /// Timewarp discrepancy `D = sqrt((1/N) Σ (t_i − (i−1)/(N−1))²)`, with `t_i` the output
    /// time of input frame `i` normalized to [0, 1] by the output length. 0 = uniform timing.
    pub fn discrepancy(&self) -> f64 {
        let n = self.tau.len();
        if n < 2 || self.frames_out < 2 {
            return 0.0;
        }
        let scale = (self.frames_out - 1) as f64;
        let sum: f64 = self
            .tau
            .iter()
            .enumerate()
            .map(|(i, &t)| (t / scale - i as f64 / (n - 1) as f64).powi(2))
            .sum();
        (sum / n as f64).sqrt()
    }
}

/// What the retiming did.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    pub frames_in: usize,
    pub frames_out: usize,
    /// Smallest and largest output time between consecutive in-contact input frames.
    pub min_step: f64,
    pub max_step: f64,
    /// Largest distance from a waypoint to the sampled path at its output frame [m].
    pub max_anchor_error_m: f64,
    /// Wall time [s].
    pub time_s: f64,
}

/// Output of the retiming.
#[derive(Clone, Debug)]
pub struct Output {
    /// Object poses at every output frame.
    pub path: ObjectPath,
    pub timewarp: Timewarp,
    /// The global position spline over the contact segment, parameterized by output time.
    pub spline: BSpline,
    pub stats: Stats,
}

/// Why the retiming failed (only on degenerate numerical input; specs are validated before).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("retiming failed: {0}")]
pub struct RetimeFailure(pub String);

/// Runs stage 3. `original` are the input object positions (for the `speed` rule), `warped`
/// the object path after stages 1 and 2 (all input frames).
pub fn run(
    original: &[Vector3<f64>],
    warped: &ObjectPath,
    plan: &WarpPlan,
    params: &Params,
) -> Result<Output, RetimeFailure> {
    let clock = Instant::now();
    let n = warped.len();
    let (c0, c1) = (plan.segment.start, plan.segment.end);
    let post_shift = plan.post_shift();
    let mut tau: Vec<f64> = (0..n).map(|i| i as f64).collect();
    for t in &mut tau[c1 + 1..] {
        *t += post_shift as f64;
    }
    let mut weights = Vec::new();
    for pair in plan.anchors.windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        segment_weights(original, &warped.positions, a.t, b.t, params, &mut weights);
        let total: f64 = weights.iter().sum();
        let span = (b.t_new - a.t_new) as f64;
        let mut acc = 0.0;
        tau[a.t] = a.t_new as f64;
        for (j, w) in weights.iter().enumerate() {
            acc += w;
            tau[a.t + j + 1] = a.t_new as f64 + span * (acc / total);
        }
        tau[b.t] = b.t_new as f64; // exact, free of rounding
    }

    let params_u = &tau[c0..=c1];
    let spline = BSpline::interpolate3(params_u, &warped.positions[c0..=c1], 3)
        .map_err(|e| RetimeFailure(e.to_string()))?;
    let t_end = plan.t_end_new();
    let frames_out = plan.frames_out();
    let mut positions = Vec::with_capacity(frames_out);
    let mut rotations = Vec::with_capacity(frames_out);
    positions.extend_from_slice(&warped.positions[..c0]);
    rotations.extend_from_slice(&warped.rotations[..c0]);
    let timewarp = Timewarp { tau, frames_out };
    for t in c0..=t_end {
        let tf = t as f64;
        positions.push(spline.eval3(tf));
        let s = timewarp.source_frame(tf).clamp(c0, c1);
        let r = if s >= c1 {
            warped.rotations[c1]
        } else {
            let (ta, tb) = (timewarp.tau[s], timewarp.tau[s + 1]);
            let u = ((tf - ta) / (tb - ta)).clamp(0.0, 1.0);
            warped.rotations[s]
                .try_slerp(&warped.rotations[s + 1], u, 1e-12)
                .unwrap_or(if u < 0.5 {
                    warped.rotations[s]
                } else {
                    warped.rotations[s + 1]
                })
        };
        rotations.push(r);
    }
    positions.extend_from_slice(&warped.positions[c1 + 1..]);
    rotations.extend_from_slice(&warped.rotations[c1 + 1..]);

    let steps = timewarp.tau[c0..=c1].windows(2).map(|w| w[1] - w[0]);
    let (min_step, max_step) = steps.fold((f64::INFINITY, 0.0f64), |(lo, hi), s| {
        (lo.min(s), hi.max(s))
    });
    let max_anchor_error_m = plan
        .anchors
        .iter()
        .map(|a| (positions[a.t_new] - a.position).norm())
        .fold(0.0, f64::max);
    Ok(Output {
        path: ObjectPath {
            positions,
            rotations,
        },
        timewarp,
        spline,
        stats: Stats {
            frames_in: n,
            frames_out,
            min_step,
            max_step,
            max_anchor_error_m,
            time_s: clock.elapsed().as_secs_f64(),
        },
    })
}

/// Output-time weight of each step `f → f+1` for `f` in `a..b` (reuses `out`).
fn segment_weights(
    original: &[Vector3<f64>],
    warped: &[Vector3<f64>],
    a: usize,
    b: usize,
    params: &Params,
    out: &mut Vec<f64>,
) {
    out.clear();
    let m = b - a;
    match params.mode {
        RetimeMode::Chord => {
            out.extend((a..b).map(|f| (warped[f + 1] - warped[f]).norm()));
            let total: f64 = out.iter().sum();
            if total <= 1e-12 {
                out.iter_mut().for_each(|w| *w = 1.0);
                return;
            }
            let floor = params.min_speed_fraction * total / m as f64;
            out.iter_mut().for_each(|w| *w += floor);
        }
        RetimeMode::Speed => {
            const EPS: f64 = 1e-3;
            out.extend((a..b).map(|f| {
                let l_new = (warped[f + 1] - warped[f]).norm();
                let l_old = (original[f + 1] - original[f]).norm();
                ((l_new + EPS) / (l_old + EPS)).clamp(0.125, 8.0)
            }));
        }
    }
}
