//! Stage 1: spatial warp of the object through the waypoints (paper Alg. 1,
//! `TransformSegment`, in the continuous form of docs/METHOD.md).
//!
//! For the segment between anchors `i` and `i+1` (input frames `t_i..=t_{i+1}`):
//!
//! ```text
//! Δs = p_i − x(t_i),  Δe = p_{i+1} − x(t_{i+1}),  β = sqrt(clip(max(|Δs|, |Δe|)/α, 0, 1))
//! u = (t − t_i)/(t_{i+1} − t_i)
//! x'(t) = x(t) + (1 − β)((1−u)²Δs + u²Δe) + β((1−u)Δs + uΔe)
//! R'(t) = Slerp(C_i, C_{i+1}, u) · R(t),      C_i = r_0 r_1 ⋯ r_i
//! ```
//!
//! The quadratic blend applies only a quarter of each end's displacement at u = ½: that is the
//! paper's "preserve the original shape", not a bug. The rotation is the continuous form: read
//! literally, Alg. 1 restarts the slerp from identity in each segment and the orientation jumps
//! at every waypoint. The object rotates about its own origin (left-multiplied world rotation).
//!
//! Outside the contact segment the object (and with it the hand) moves rigidly:
//! pre-contact frames by `T_pre = translate(p'_start − x(c0))`, post-contact frames by
//! `T_post = translate(p'_end) · C_end · translate(−x(c1))`, the rigid motion that carries the
//! object's pose at `c1` onto the warped pose at `c1`. With no rotation waypoints this is the
//! plain shift of docs/METHOD.md; with them, the hand keeps its pose relative to the object while it
//! releases and retreats.

use std::time::Instant;

use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use serde::{Deserialize, Serialize};

use super::ObjectPath;
use super::plan::WarpPlan;

/// Parameters of the spatial warp.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Params {
    /// α: endpoint displacement at which the blend is fully linear [m]. Default 0.2.
    pub alpha_m: f64,
}

impl Default for Params {
    fn default() -> Self {
        Params { alpha_m: 0.2 }
    }
}

/// What the spatial warp did.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// β of each segment, in order.
    pub blend_beta: Vec<f64>,
    /// Largest displacement applied to any frame [m].
    pub max_displacement_m: f64,
    /// Wall time [s].
    pub time_s: f64,
}

/// Output of the spatial warp: the warped object path (same frames as the input) and the
/// rigid transforms applied to the pre- and post-contact frames.
#[derive(Clone, Debug, PartialEq)]
pub struct Output {
    pub path: ObjectPath,
    /// Rigid motion of the pre-contact frames (object and hand).
    pub pre: Isometry3<f64>,
    /// Rigid motion of the post-contact frames (object and hand).
    pub post: Isometry3<f64>,
    pub stats: Stats,
}

/// Runs stage 1 on `input` (object poses of every input frame).
pub fn run(input: &ObjectPath, plan: &WarpPlan, params: &Params) -> Output {
    let clock = Instant::now();
    let n = input.len();
    let mut positions = input.positions.clone();
    let mut rotations = input.rotations.clone();
    let cumulative = plan.cumulative_rotations();
    let mut stats = Stats::default();
    let (c0, c1) = (plan.segment.start, plan.segment.end);

    for (i, pair) in plan.anchors.windows(2).enumerate() {
        let (a, b) = (&pair[0], &pair[1]);
        let ds = a.position - input.positions[a.t];
        let de = b.position - input.positions[b.t];
        let beta = (ds.norm().max(de.norm()) / params.alpha_m)
            .clamp(0.0, 1.0)
            .sqrt();
        stats.blend_beta.push(beta);
        let span = (b.t - a.t) as f64;
        let ca = cumulative[i];
        for t in a.t..=b.t {
            let u = (t - a.t) as f64 / span;
            let quad = (1.0 - u).powi(2) * ds + u * u * de;
            let lin = (1.0 - u) * ds + u * de;
            let d = (1.0 - beta) * quad + beta * lin;
            positions[t] = input.positions[t] + d;
            stats.max_displacement_m = stats.max_displacement_m.max(d.norm());
            let q = slerp_along(&ca, &b.rotation, u);
            rotations[t] = q * input.rotations[t];
        }
    }

    let start = &plan.anchors[0];
    let pre = Isometry3::from_parts(
        Translation3::from(start.position - input.positions[c0]),
        UnitQuaternion::identity(),
    );
    let end = plan.anchors.last().expect("end anchor");
    let c_end = *cumulative.last().expect("end anchor");
    let post = Translation3::from(end.position)
        * Isometry3::from_parts(Translation3::identity(), c_end)
        * Translation3::from(-input.positions[c1]);
    for t in 0..c0 {
        positions[t] = input.positions[t] + pre.translation.vector;
        stats.max_displacement_m = stats.max_displacement_m.max(pre.translation.vector.norm());
    }
    for t in c1 + 1..n {
        let pose = post * input.pose(t);
        stats.max_displacement_m = stats
            .max_displacement_m
            .max((pose.translation.vector - input.positions[t]).norm());
        positions[t] = pose.translation.vector;
        rotations[t] = pose.rotation;
    }
    stats.time_s = clock.elapsed().as_secs_f64();
    Output {
        path: ObjectPath {
            positions,
            rotations,
        },
        pre,
        post,
        stats,
    }
}

/// `a · r^u`: the slerp from `a` to `a·r` along `r`'s shortest arc. Unlike
/// `UnitQuaternion::slerp` it is defined for half turns (r of angle π).
fn slerp_along(a: &UnitQuaternion<f64>, r: &UnitQuaternion<f64>, u: f64) -> UnitQuaternion<f64> {
    if u <= 0.0 {
        return *a;
    }
    if u >= 1.0 {
        return a * r;
    }
    a * r.powf(u)
}
