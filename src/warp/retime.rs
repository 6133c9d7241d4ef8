//! Stage 3: temporal retiming (docs/METHOD.md stage 3, paper "Temporal Waypoint-Constrained Object
//! Warping").
//!
//! 1. For each segment between consecutive anchors (input frames `t_i..=t_{i+1}`), a normalized
//!    timewarp `τ_i: [0,1] → [0,1]` is built from the segment's positions, then scaled and
//!    shifted to `[t'_i, t'_{i+1}]`; composing them gives the global timewarp `τ`: input frame →
//!    output time (real-valued, strictly increasing). Two rules:
//!    * `chord` (docs/METHOD.md, the paper; default): `τ_i` maps uniform time to the chord-length
//!      parameter of the segment, so the object moves at constant speed along each segment.
//!      A step's length is that of the object's farthest point, bounded by `|Δp| + r·|Δθ|`
//!      (`r` the bounding radius of the mesh, `Δθ` the turn): a turn in place (a pour) takes
//!      the time a move of the same extent would, where the position's chord alone would play
//!      it within a few output frames. Each step's length is floored at
//!      `min_speed_fraction` of the segment's mean step, so frames where the object rests
//!      still take time and `τ` stays strictly increasing.
//!    * `paper` (the paper's reference code; the default of the built-in configs): `τ_i` is the
//!      chord-length parameter with no floor, so frames where the object rests get almost no
//!      output time and the moving part is stretched over the window. Each step's length is
//!      raised by [`PAPER_EPS_M`] = 1e-8 m (the size of the reference's duplicate-breaking
//!      shift), which keeps `τ` strictly increasing; a segment that does not move at all is
//!      timed uniformly.
//!    * `speed`: each step takes output time proportional to `(ℓ' + ε)/(ℓ + ε)`, its warped
//!      length over its original length (ε = 1 mm, ratio clamped to [1/8, 8]), so the
//!      demonstration's own speed profile is kept where the path is not stretched. An identity
//!      warp gives the identity timewarp exactly.
//!
//!    Under `chord` and `paper` the object runs each segment at its constant mean speed, which
//!    jumps at every waypoint. With [`Params::continuous_speed`] (the default) each segment's
//!    progress is spread over its time by a monotone cubic ease instead, so the speed at an
//!    anchor is the same on both sides (the harmonic mean of the two segments' mean speeds;
//!    the untouched frames' own speed at the contact window's ends). Anchors, durations and
//!    the frames' order along the path are unchanged.
//! 2. One global cubic B-spline (C²) interpolates the warped positions of the contact segment
//!    at parameters `τ(frame)` (frames closer than [`MIN_SPLINE_GAP`] output frames to the
//!    previous fitted one are left out of the fit: under `paper` they rest, and nearly equal
//!    parameters would make the interpolation ill-conditioned; anchors are always fitted) (NURBS Book A9.1, [`crate::math::bspline`]); every anchor sits
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
use crate::math::rotation::angle_between;
use crate::model::RetimeMode;

/// `paper` mode: length added to every step [m], so a resting step still takes a sliver of
/// output time and τ is strictly increasing. 1e-8 m is the shift the paper's reference code
/// gives adjacent duplicate positions; a 0.1 m segment of 100 frames gives a resting step
/// about 1e-7 of the segment's time.
pub const PAPER_EPS_M: f64 = 1e-8;

/// Smallest gap [output frames] between the parameters of two frames fitted by the global
/// spline; closer frames (resting frames under `paper`) are left out of the fit.
pub const MIN_SPLINE_GAP: f64 = 1e-3;

/// The gap the paper's reference code leaves at the end of each segment's normalized time
/// (its segments end at `t'_i − 0.001`, the next starts at `t'_i`).
pub const PAPER_SEGMENT_GAP: f64 = 1e-3;

/// Parameters of the retiming.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Params {
    /// Timewarp rule. Default `chord`.
    pub mode: RetimeMode,
    /// `chord` mode: floor of a step's length as a fraction of the segment's mean step.
    /// Default 0.05.
    pub min_speed_fraction: f64,
    /// `chord` and `paper`: the object's speed is continuous at the waypoints. Each segment
    /// keeps its anchors' output frames and its frames' order along the path, but its progress
    /// eases from the speed at one anchor to the speed at the next ([`Ease`]) instead of
    /// running at the segment's constant mean speed, which jumps at every waypoint (on
    /// teapot_pour_empty from 4.5 to 65.9 mm per frame: a second difference of 68 mm per
    /// frame², 62 m/s² at 30 fps). Default true; `false` is the paper's constant speed per
    /// segment.
    pub continuous_speed: bool,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            mode: RetimeMode::Chord,
            min_speed_fraction: 0.05,
            continuous_speed: true,
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
    /// Timewarp discrepancy as the paper's code computes it ([`paper_discrepancy`]).
    pub discrepancy_paper: f64,
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
/// the object path after stages 1 and 2 (all input frames), `object_radius` the bounding
/// radius of the object mesh [m] (for the `chord` rule's turns).
pub fn run(
    original: &[Vector3<f64>],
    warped: &ObjectPath,
    plan: &WarpPlan,
    object_radius: f64,
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
    let extent = Extent {
        path: warped,
        radius: if params.mode == RetimeMode::Chord {
            object_radius.max(0.0)
        } else {
            0.0
        },
    };
    let eases = segment_eases(&extent, plan, params);
    let mut weights = Vec::new();
    for (pair, ease) in plan.anchors.windows(2).zip(&eases) {
        let (a, b) = (&pair[0], &pair[1]);
        segment_weights(original, &extent, a.t, b.t, params, &mut weights);
        let total: f64 = weights.iter().sum();
        let span = (b.t_new - a.t_new) as f64;
        let mut acc = 0.0;
        tau[a.t] = a.t_new as f64;
        for (j, w) in weights.iter().enumerate() {
            acc += w;
            let u = acc / total;
            let u = ease.map_or(u, |e| e.time_of(u));
            tau[a.t + j + 1] = a.t_new as f64 + span * u;
        }
        tau[b.t] = b.t_new as f64; // exact, free of rounding
    }

    let (params_u, points) = spline_samples(&tau, &warped.positions, plan);
    let spline =
        BSpline::interpolate3(&params_u, &points, 3).map_err(|e| RetimeFailure(e.to_string()))?;
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
            discrepancy_paper: paper_discrepancy(&warped.positions, plan),
            time_s: clock.elapsed().as_secs_f64(),
        },
    })
}

/// The parameters and positions the global spline interpolates: every contact-segment frame
/// whose τ is at least [`MIN_SPLINE_GAP`] after the previous fitted one, and every anchor (an
/// anchor replaces a fitted frame closer than the gap before it).
fn spline_samples(
    tau: &[f64],
    positions: &[Vector3<f64>],
    plan: &WarpPlan,
) -> (Vec<f64>, Vec<Vector3<f64>>) {
    let (c0, c1) = (plan.segment.start, plan.segment.end);
    let mut anchors = plan.anchors.iter().map(|a| a.t).peekable();
    let mut u: Vec<f64> = Vec::with_capacity(c1 - c0 + 1);
    let mut p = Vec::with_capacity(c1 - c0 + 1);
    let mut last_is_anchor = false;
    for f in c0..=c1 {
        while anchors.peek().is_some_and(|&a| a < f) {
            anchors.next();
        }
        let is_anchor = anchors.peek() == Some(&f);
        let far = u.last().is_none_or(|&l| tau[f] - l >= MIN_SPLINE_GAP);
        if is_anchor && !far && !last_is_anchor {
            u.pop();
            p.pop();
        }
        if far || (is_anchor && !last_is_anchor) || u.is_empty() {
            u.push(tau[f]);
            p.push(positions[f]);
            last_is_anchor = is_anchor;
        }
    }
    (u, p)
}

/// Timewarp discrepancy as the paper's reference code computes it (its "contact timewarp"):
/// every input frame gets a normalized time in `[0, 1]` from per-segment chord length, with the
/// segments split at the waypoints' input frames only (the first runs from frame 0, the last to
/// the final frame, so the pre- and post-contact frames are inside them); segment `i` ends at
/// `f_i − 0.001` ([`PAPER_SEGMENT_GAP`]) where `f_i = (t'_i − c0)/(t'_end − c0)` is the
/// waypoint's place in the output contact window and the next starts at `f_i`; a step between
/// identical positions counts [`PAPER_EPS_M`]. The discrepancy is the RMS deviation of those
/// times from `linspace(min, max, N)`. `positions` are the warped object positions of every
/// input frame (after the push-out, before retiming).
pub fn paper_discrepancy(positions: &[Vector3<f64>], plan: &WarpPlan) -> f64 {
    let n = positions.len();
    if n < 2 {
        return 0.0;
    }
    let c0 = plan.segment.start as f64;
    let window = (plan.t_end_new() as f64 - c0).max(1.0);
    let inner = &plan.anchors[1..plan.anchors.len() - 1];
    let mut bounds: Vec<(usize, f64)> = inner
        .iter()
        .map(|a| (a.t, (a.t_new as f64 - c0) / window))
        .collect();
    bounds.push((n, 1.0));
    let mut t = vec![0.0; n];
    let (mut start, mut prev) = (0usize, 0.0);
    for &(end, target) in &bounds {
        let end = end.min(n);
        if end <= start {
            continue;
        }
        let seg = &mut t[start..end];
        seg[0] = 0.0;
        for j in 1..seg.len() {
            let d = positions[start + j] - positions[start + j - 1];
            let step = if d == Vector3::zeros() {
                PAPER_EPS_M
            } else {
                d.norm()
            };
            seg[j] = seg[j - 1] + step;
        }
        let total = seg[seg.len() - 1];
        let m = seg.len();
        for (j, v) in seg.iter_mut().enumerate() {
            let u = if total > 0.0 {
                *v / total
            } else if m > 1 {
                j as f64 / (m - 1) as f64
            } else {
                0.0
            };
            *v = u * (target - prev - PAPER_SEGMENT_GAP) + prev;
        }
        start = end;
        prev = target;
    }
    let (lo, hi) = t
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    let sum: f64 = t
        .iter()
        .enumerate()
        .map(|(i, &x)| (x - (lo + (hi - lo) * i as f64 / (n - 1) as f64)).powi(2))
        .sum();
    (sum / n as f64).sqrt()
}

/// Largest end slope of a segment's ease, in units of the segment's mean speed. With both
/// slopes at most 2 the cubic is strictly increasing (Fritsch-Carlson: `a² + b² ≤ 9`).
const MAX_EASE_SLOPE: f64 = 2.0;

/// The progress curve of one segment under [`Params::continuous_speed`]: the cubic Hermite
/// `g: [0, 1] → [0, 1]` with `g(0) = 0`, `g(1) = 1`, `g'(0) = a`, `g'(1) = b`. Under `chord` and
/// `paper` a segment's progress is linear in its output time (constant speed); with the ease
/// the progress at normalized output time `w` is `g(w)`, so the object leaves the segment's
/// first anchor at `a` times the segment's mean speed and reaches the last at `b` times it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Ease {
    a: f64,
    b: f64,
}

impl Ease {
    fn progress(&self, w: f64) -> f64 {
        let (a, b) = (self.a, self.b);
        ((a + b - 2.0) * w + (3.0 - 2.0 * a - b)) * w * w + a * w
    }

    /// `w = g⁻¹(u)`: the normalized output time at which the segment's progress is `u`
    /// (bisection: `g` is strictly increasing; 52 halvings reach the spacing of f64 on [0, 1]).
    fn time_of(&self, u: f64) -> f64 {
        if u <= 0.0 {
            return 0.0;
        }
        if u >= 1.0 {
            return 1.0;
        }
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        for _ in 0..52 {
            let mid = 0.5 * (lo + hi);
            if self.progress(mid) < u {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }
}

/// The ease of every segment (`None`: constant speed), see [`Params::continuous_speed`]. The
/// object's speed at an anchor between two segments is the harmonic mean of their mean speeds
/// (at most twice the slower one, 0 when either rests); at the contact window's ends it is the
/// speed of the untouched frames outside (the recording's own, usually at rest). A segment that
/// does not move keeps constant speed. Speeds are in the rule's step length (under `chord`,
/// that of the object's farthest point, [`Extent`]).
fn segment_eases(extent: &Extent, plan: &WarpPlan, params: &Params) -> Vec<Option<Ease>> {
    let segments = plan.anchors.len().saturating_sub(1);
    if !params.continuous_speed || params.mode == RetimeMode::Speed {
        return vec![None; segments];
    }
    let step = |f: usize| extent.step(f);
    let speeds: Vec<f64> = plan
        .anchors
        .windows(2)
        .map(|p| (p[0].t..p[1].t).map(step).sum::<f64>() / (p[1].t_new - p[0].t_new) as f64)
        .collect();
    let (c0, c1) = (plan.segment.start, plan.segment.end);
    let before = if c0 > 0 { step(c0 - 1) } else { 0.0 };
    let after = if c1 + 1 < extent.path.len() {
        step(c1)
    } else {
        0.0
    };
    let mut nodes = Vec::with_capacity(segments + 1);
    nodes.push(before);
    for w in speeds.windows(2) {
        let sum = w[0] + w[1];
        nodes.push(if sum > 0.0 {
            2.0 * w[0] * w[1] / sum
        } else {
            0.0
        });
    }
    nodes.push(after);
    speeds
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            (v > 1e-9).then(|| Ease {
                a: (nodes[i] / v).min(MAX_EASE_SLOPE),
                b: (nodes[i + 1] / v).min(MAX_EASE_SLOPE),
            })
        })
        .collect()
}

/// How far the object's farthest point moves in a step, bounded by `|Δp| + radius·|Δθ|`:
/// the step length of the `chord` rule (`radius` 0: the position's chord, the `paper` rule's).
struct Extent<'a> {
    path: &'a ObjectPath,
    radius: f64,
}

impl Extent<'_> {
    /// Length [m] of the step `f → f+1`.
    fn step(&self, f: usize) -> f64 {
        let p = &self.path.positions;
        let moved = (p[f + 1] - p[f]).norm();
        if self.radius > 0.0 {
            let r = &self.path.rotations;
            moved + self.radius * angle_between(&r[f], &r[f + 1])
        } else {
            moved
        }
    }
}

/// Output-time weight of each step `f → f+1` for `f` in `a..b` (reuses `out`).
fn segment_weights(
    original: &[Vector3<f64>],
    extent: &Extent,
    a: usize,
    b: usize,
    params: &Params,
    out: &mut Vec<f64>,
) {
    out.clear();
    let m = b - a;
    let warped = &extent.path.positions;
    match params.mode {
        RetimeMode::Chord => {
            out.extend((a..b).map(|f| extent.step(f)));
            let total: f64 = out.iter().sum();
            if total <= 1e-12 {
                out.iter_mut().for_each(|w| *w = 1.0);
                return;
            }
            let floor = params.min_speed_fraction * total / m as f64;
            out.iter_mut().for_each(|w| *w += floor);
        }
        RetimeMode::Paper => {
            out.extend((a..b).map(|f| (warped[f + 1] - warped[f]).norm() + PAPER_EPS_M));
            if out.iter().sum::<f64>() <= m as f64 * PAPER_EPS_M * 2.0 {
                out.iter_mut().for_each(|w| *w = 1.0);
            }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ContactSegment;
    use nalgebra::UnitQuaternion;

    /// 100 frames, contact 10..=90; the object rests on 10..=30 and 70..=90 and moves 0.4 m at
    /// constant speed in between.
    fn rest_move_rest() -> (ObjectPath, WarpPlan) {
        along_x(|i| 0.01 * (i.clamp(30, 70) - 30) as f64)
    }

    /// 100 frames, contact 10..=90, the object at `x(frame)` on the x axis, no waypoints.
    fn along_x(x: impl Fn(usize) -> f64) -> (ObjectPath, WarpPlan) {
        let positions: Vec<Vector3<f64>> = (0..100).map(|i| Vector3::new(x(i), 0.0, 0.0)).collect();
        let path = ObjectPath {
            rotations: vec![UnitQuaternion::identity(); positions.len()],
            positions,
        };
        let segment = ContactSegment {
            start: 10,
            end: 90,
            gap_frames: 0,
        };
        let plan = WarpPlan::identity(&path.positions, segment);
        (path, plan)
    }

    /// Under `chord` a turn in place takes the time a move of its extent (bounding radius ×
    /// angle) would; under `paper` it takes almost none.
    #[test]
    fn chord_mode_gives_a_turn_in_place_the_time_of_its_extent() {
        // Contact 10..=90: the object moves 0.4 m along x over 10..50, then turns 2 rad about
        // z in place over 50..90 (at a 0.1 m radius, 0.2 m of travel).
        let (mut path, plan) = along_x(|i| 0.01 * (i.clamp(10, 50) - 10) as f64);
        for (i, r) in path.rotations.iter_mut().enumerate() {
            let angle = 0.05 * (i.clamp(50, 90) - 50) as f64;
            *r = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), angle);
        }
        let params = |mode| Params {
            mode,
            continuous_speed: false,
            ..Params::default()
        };
        let turn_time = |radius, mode| {
            let out = run(&path.positions, &path, &plan, radius, &params(mode)).unwrap();
            out.timewarp.tau[90] - out.timewarp.tau[50]
        };
        // Steps of 0.01 m moving and 0.005 m turning, each plus the floor of 5 % of the
        // mean step (0.6 m / 80): the turn's share of the 80 output frames.
        let floor = 0.05 * 0.6 / 80.0;
        let share = (0.2 + 40.0 * floor) / (0.6 + 80.0 * floor);
        let chord = turn_time(0.1, RetimeMode::Chord);
        assert!((chord - 80.0 * share).abs() < 1e-6, "{chord}");
        // Without a radius the turn is a rest, played at the floor (5 % of 0.4 m / 80): 1.9
        // output frames.
        let position_only = turn_time(0.0, RetimeMode::Chord);
        let floor = 0.05 * 0.4 / 80.0;
        let rest = 80.0 * 40.0 * floor / (0.4 + 80.0 * floor);
        assert!((position_only - rest).abs() < 1e-6, "{position_only}");
        // The paper's rule times by the position's chord only, whatever the radius.
        assert!(turn_time(0.1, RetimeMode::Paper) < 1e-3);
    }

    #[test]
    fn paper_mode_gives_resting_frames_almost_no_time_and_stays_increasing() {
        let (path, plan) = rest_move_rest();
        let params = Params {
            mode: RetimeMode::Paper,
            continuous_speed: false,
            ..Params::default()
        };
        let out = run(&path.positions, &path, &plan, 0.0, &params).unwrap();
        let tau = &out.timewarp.tau;
        assert!(
            tau.windows(2).all(|w| w[1] > w[0]),
            "τ not strictly increasing"
        );
        let rest = tau[30] - tau[10];
        assert!(rest < 1e-3, "20 resting frames took {rest} output frames");
        // The 40 moving steps share the 80 output frames of the window: 2 frames each.
        for f in 30..70 {
            let step = tau[f + 1] - tau[f];
            assert!((step - 2.0).abs() < 1e-3, "step {f}: {step}");
        }
        assert!(out.stats.max_anchor_error_m < 1e-9);
        // Every output frame lies on the input path (no overshoot of the spline).
        for p in &out.path.positions {
            assert!(p.x > -1e-6 && p.x < 0.4 + 1e-6, "{p:?} off the path");
        }
        // The floored chord rule keeps time on the resting frames: 20 steps at the floor
        // (5 % of the mean step 0.005 m) take 20·0.00025/0.42·80 ≈ 0.95 output frames.
        let constant = Params {
            continuous_speed: false,
            ..Params::default()
        };
        let chord = run(&path.positions, &path, &plan, 0.0, &constant).unwrap();
        let kept = chord.timewarp.tau[30] - chord.timewarp.tau[10];
        assert!((kept - 0.952).abs() < 0.01, "{kept}");
    }

    /// Largest change of the output object's speed between consecutive output frames
    /// [m per frame²] over output frames `a..b`.
    fn largest_speed_change(out: &Output, a: usize, b: usize) -> f64 {
        let p = &out.path.positions;
        (a.max(1)..b.min(p.len() - 1))
            .map(|t| (p[t + 1] - 2.0 * p[t] + p[t - 1]).norm())
            .fold(0.0, f64::max)
    }

    #[test]
    fn continuous_speed_eases_through_a_waypoint_and_keeps_every_anchor() {
        // 0.2 m over input frames 10..=90 at constant speed, resting outside; the waypoint
        // puts input frame 50 at output frame 30: the first half runs 2x faster, the second
        // 0.67x (mean speeds 5 and 1.67 mm per frame).
        let (path, mut plan) = along_x(|i| 0.0025 * (i.clamp(10, 90) - 10) as f64);
        let mut mid = plan.anchors[0].clone();
        (mid.t, mid.t_new, mid.position) = (50, 30, path.positions[50]);
        plan.anchors.insert(1, mid);
        for mode in [RetimeMode::Chord, RetimeMode::Paper] {
            let eased = Params {
                mode,
                ..Params::default()
            };
            let constant = Params {
                continuous_speed: false,
                ..eased.clone()
            };
            let a = run(&path.positions, &path, &plan, 0.0, &eased).unwrap();
            let c = run(&path.positions, &path, &plan, 0.0, &constant).unwrap();
            for out in [&a, &c] {
                let tau = &out.timewarp.tau;
                assert!(
                    tau.windows(2).all(|w| w[1] > w[0]),
                    "{mode:?}: τ not increasing"
                );
                assert_eq!((tau[10], tau[50], tau[90]), (10.0, 30.0, 90.0));
                assert!(out.stats.max_anchor_error_m < 1e-9, "{mode:?}");
                assert!(
                    out.path
                        .positions
                        .iter()
                        .all(|p| p.x > -1e-6 && p.x < 0.2 + 1e-6)
                );
            }
            // Constant speed jumps from 0 to 5 mm per frame at the start, and to 1.67 at the
            // waypoint; the ease spreads both changes over the segments. Its largest is at the
            // start, where g = 2.5w² − 1.5w³ (a = 0, b = 0.5): L·g''(0)/T² = 0.1·5/20² m per
            // frame².
            let (jump, eased_jump) = (
                largest_speed_change(&c, 10, 90),
                largest_speed_change(&a, 10, 90),
            );
            assert!(
                jump > 2.5e-3,
                "{mode:?}: constant speed changed by {jump} at most"
            );
            assert!(
                eased_jump < 1.4e-3,
                "{mode:?}: eased speed changed by {eased_jump}"
            );
            // At the waypoint the eased speed is the harmonic mean of the segments' (2.5 mm
            // per frame): the steps on either side differ by their half-frame of easing, not
            // by the 3.3 mm per frame of constant speed.
            let step =
                |out: &Output, t: usize| (out.path.positions[t + 1] - out.path.positions[t]).norm();
            let central = 0.5 * (step(&a, 29) + step(&a, 30));
            assert!((central - 2.5e-3).abs() < 0.3e-3, "{mode:?}: {central}");
            assert!((step(&a, 29) - step(&a, 30)).abs() < 0.6e-3, "{mode:?}");
            assert!((step(&c, 29) - step(&c, 30)).abs() > 2.5e-3, "{mode:?}");
        }
    }

    #[test]
    fn ease_is_a_strictly_increasing_bijection_of_the_unit_interval() {
        for (a, b) in [
            (0.0, 0.0),
            (0.0, 2.0),
            (2.0, 0.0),
            (2.0, 2.0),
            (1.0, 1.0),
            (0.3, 1.7),
        ] {
            let e = Ease { a, b };
            assert_eq!((e.progress(0.0), e.progress(1.0)), (0.0, 1.0));
            let mut last = -1.0;
            for i in 0..=1000 {
                let w = i as f64 / 1000.0;
                let g = e.progress(w);
                assert!(
                    g > last,
                    "g({w}) = {g} not above {last} for a = {a}, b = {b}"
                );
                assert!((e.time_of(g) - w).abs() < 1e-9, "a = {a}, b = {b}, w = {w}");
                last = g;
            }
        }
    }

    #[test]
    fn paper_discrepancy_is_zero_for_uniform_motion_and_matches_the_ideal_for_a_rest() {
        let n = 101;
        let uniform: Vec<Vector3<f64>> = (0..n)
            .map(|i| Vector3::new(i as f64 * 0.01, 0.0, 0.0))
            .collect();
        let seg = ContactSegment {
            start: 0,
            end: n - 1,
            gap_frames: 0,
        };
        let plan = WarpPlan::identity(&uniform, seg);
        assert!(paper_discrepancy(&uniform, &plan) < 1e-12);

        // The first 40 frames rest: their normalized times are ~0, the rest rise linearly.
        let rest: Vec<Vector3<f64>> = (0..n)
            .map(|i| Vector3::new(i.saturating_sub(40) as f64 * 0.01, 0.0, 0.0))
            .collect();
        // The code's segment ends at 1 − 0.001; the reference line spans min..max, so the
        // gap scales the whole deviation by 0.999.
        let scale = 1.0 - PAPER_SEGMENT_GAP;
        let ideal: Vec<f64> = (0..n).map(|i| i.saturating_sub(40) as f64 / 60.0).collect();
        let expected = (ideal
            .iter()
            .enumerate()
            .map(|(i, t)| (t - i as f64 / 100.0).powi(2))
            .sum::<f64>()
            / n as f64)
            .sqrt()
            * scale;
        let got = paper_discrepancy(&rest, &WarpPlan::identity(&rest, seg));
        assert!((got - expected).abs() < 1e-6, "{got} vs {expected}");
        assert!(got > 0.1);
    }
}
