//! Stage 4 over a whole trajectory: [`run`] solves every output frame of the contact
//! segment in order, warm-starting each from the previous one (or, with the rigid warm
//! start, from `init` at that frame), and sums the frames up in [`Stats`].

use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::params::{FrameResult, Params, ResolvedContact, Solver, StopReason};
use super::solver::IkSolver;
use crate::geometry::ObjectSdf;
use crate::geometry::shape::CollisionShape;
use crate::hand::HandPath;
use crate::model::{Demo, Objective, WarmStart};
use crate::robot::{LinkId, Robot};
use crate::warp::ObjectWarp;

/// The default objective's per-source-frame stop targets [m] (0 for frames without
/// contacts), indexed from `c0`: a frame stops only below the tighter of the threshold and
/// its target, so a loose threshold never returns contacts fitting worse than the
/// recording's (the paper's objective keeps its stop rule as printed).
///
/// The target of source frame `s` is the recording's own mean contact distance `d(s)`,
/// scaled by `min(1, (D_C − room) / D_τ)`: `D_C` is the recording's D_C (the mean of `d`
/// over its frames with contacts), `D_τ` the mean of `d(τ⁻¹(t))` over the output frames
/// (above `D_C` where τ gives the worse-fitting frames more output time), and `room` =
/// 0.1 mm is left for stage 5, whose smoothing adds 0.001-0.06 mm to D_C on the built-in
/// configs. So the output's D_C stays at or below the recording's however τ weights the
/// frames, and where the rigid transfer is exact (`D_τ = D_C`) the targets ask it for
/// 0.1 mm of D_C at most (about 2 %). Each target carries 1 µm of slack so a frame that
/// fits exactly as well as its target counts as meeting it.
fn recording_targets_m(robot: &Robot, demo: &Demo, warp: &ObjectWarp) -> Vec<f64> {
    const SLACK_MM: f64 = 1e-3;
    const ROOM_MM: f64 = 0.1;
    const LEAST_MM: f64 = 1.0;
    let plan = &warp.plan;
    let (c0, c1) = (plan.segment.start, plan.segment.end);
    // The same per-frame distances and D_C as the report's `d_c_mm.original`.
    let per_frame = crate::metrics::contact_distance_per_frame_mm(robot, demo);
    let d = &per_frame[c0..=c1];
    let d_c = crate::metrics::d_c_mm(&per_frame);
    let stretched: Vec<Option<f64>> = (c0..=plan.t_end_new())
        .map(|t| d[warp.source_frame(t) - c0])
        .collect();
    let d_tau = crate::metrics::d_c_mm(&stretched);
    let scale = if d_c > 0.0 && d_tau > d_c - ROOM_MM {
        ((d_c - ROOM_MM) / d_tau).max(0.0)
    } else {
        1.0
    };
    d.iter()
        .map(|x| x.map_or(0.0, |x| ((x * scale).max(LEAST_MM) + SLACK_MM) * 1e-3))
        .collect()
}

/// A frame's restart from the recorded grasp ([`run`]) is solved only when the objective
/// at the recorded grasp is below this times the carried hand's end. On the shared TACO
/// take's warps the restarts that pay off start at 0.5-1.07 times it; on the teapot configs
/// at 3.5 mm, whose frames all miss the stop rule beside the pot, the recorded grasp starts
/// 1.15-1.5 times above and never ends converged: a full solve there made the IK three to
/// four times slower.
const RESTART_GATE: f64 = 1.1;

/// What stage 4 did.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Solver used.
    pub solver: Solver,
    /// Threshold [mm].
    pub threshold_mm: f64,
    /// Iteration cap per frame.
    pub max_iterations: usize,
    /// One result per output frame of the contact segment `c0..=t'_end`, in order.
    pub frames: Vec<FrameResult>,
    /// First output frame of `frames` (c0).
    pub first_frame: usize,
    /// Fraction of `frames` that met the stop rule (the threshold, or the recording's fit
    /// where tighter).
    pub converged_fraction: f64,
    /// Output frames that did not meet the stop rule (the reason is in each frame's `stop`).
    pub not_converged: Vec<usize>,
    /// Output frames whose solution was not finite (the warm start was kept).
    pub non_finite: Vec<usize>,
    /// Output frames solved again from the rigid transfer of the recorded hand, which met
    /// the stop rule and ended lower where the carried-along start did not (see [`run`]).
    pub restarted: Vec<usize>,
    /// Mean iterations per frame.
    pub mean_iterations: f64,
    /// Most iterations in one frame.
    pub max_iterations_used: usize,
    /// D_C of the IK solution before smoothing: mean over frames with contacts of
    /// `mean_mm` [mm].
    pub d_c_mm: f64,
    /// Smallest hand-barrier clearance over all frames [mm]; `None` without barriers.
    pub min_barrier_clearance_mm: Option<f64>,
    /// Frames per stop reason other than `converged`.
    pub stop_reasons: std::collections::BTreeMap<StopReason, usize>,
    /// Deepest penetration probe over all frames [mm] (0 without an object field).
    pub max_penetration_mm: f64,
    /// Objective minimized.
    pub objective: Objective,
    /// Wall time [s].
    pub time_s: f64,
}

/// Runs stage 4 (see the module docs).
///
/// For every output frame `t` in `[c0, t'_end]`: the correspondences of
/// `t* = warp.retime.timewarp.source_frame(t)`, the object pose of the warped object at
/// `t`, and the warm start of [`Params::warm_start`] from the previous frame's solution (the
/// first frame starts from `init`, e.g. the baseline hand; with the rigid warm start every
/// frame starts from `init` at that frame). A frame the carried-along start leaves short of
/// the stop rule is solved again (LM only: Adam stays the paper's solver as printed) from
/// `init` at that frame when the objective there is below [`RESTART_GATE`] times the carried
/// hand's end, and takes that solution when it meets the stop rule and ends lower
/// ([`Stats::restarted`]): where the carried hand is caught on the wrong side of a rim or a
/// thin wall, the recording's own grasp is not; where neither start gets there (a hand held
/// off by a barrier) the carried one is kept, so the hand does not jump between them. A frame
/// whose `t*` has no
/// correspondences (a gap inside the segment) has nothing to fit: its hand is the previous
/// solution carried along by the object's motion. Frames outside the contact segment are
/// copied from `init` (the rigid shift of stage 1). `demo` must be in robot joint order
/// ([`Demo::check_robot`]) and `init` must have one frame per output frame.
pub fn run(
    robot: &Robot,
    demo: &Demo,
    warp: &ObjectWarp,
    init: &HandPath,
    barriers: &[CollisionShape],
    object: Option<&ObjectSdf>,
    params: &Params,
) -> (HandPath, Stats) {
    let clock = Instant::now();
    let plan = &warp.plan;
    let (c0, c1) = (plan.segment.start, plan.segment.end);
    let t_end = plan.t_end_new();
    let path = warp.path();
    assert_eq!(
        init.len(),
        plan.frames_out(),
        "init must have one frame per output frame"
    );
    let names: std::collections::HashMap<&str, LinkId> = robot
        .links()
        .iter()
        .enumerate()
        .map(|(i, l)| (l.name.as_str(), LinkId(i as u32)))
        .collect();
    let resolved: Vec<Vec<ResolvedContact>> = demo.frames[c0..=c1]
        .iter()
        .map(|f| {
            f.contacts
                .iter()
                .map(|c| ResolvedContact {
                    link: *names
                        .get(c.link.as_str())
                        .unwrap_or_else(|| panic!("{:?} is not a link of the robot", c.link)),
                    hand_point: c.hand_point,
                    object_point: c.object_point,
                })
                .collect()
        })
        .collect();

    let threshold_m = params.threshold_mm * 1e-3;
    let recording_m = (params.objective == Objective::NonPenetrating)
        .then(|| recording_targets_m(robot, demo, warp));
    let mut out = init.clone();
    let dof = robot.dof();
    let mut solver = IkSolver::new(robot, barriers, object, params.clone());
    let mut wrist = init.wrists[c0];
    let mut q = init.q(c0).to_vec();
    let mut q2 = q.clone();
    let mut prev_object = path.pose(c0);
    let mut stats = Stats {
        solver: params.solver,
        threshold_mm: params.threshold_mm,
        max_iterations: params.iteration_cap(),
        first_frame: c0,
        frames: Vec::with_capacity(t_end + 1 - c0),
        ..Stats::default()
    };
    for t in c0..=t_end {
        let s = warp.source_frame(t);
        let contacts = &resolved[s - c0];
        let object_pose = path.pose(t);
        if params.warm_start == WarmStart::Rigid {
            wrist = init.wrists[t];
            q.copy_from_slice(init.q(t));
        } else if t > c0 && (contacts.is_empty() || params.warm_start == WarmStart::FollowObject) {
            wrist = object_pose * prev_object.inverse() * wrist;
        }
        let target_m = match &recording_m {
            Some(d) if d[s - c0] > 0.0 => threshold_m.min(d[s - c0]),
            _ => threshold_m,
        };
        let mut r = solver.solve_within(&object_pose, contacts, &mut wrist, &mut q, target_m);
        // A frame the carried-along start cannot bring to the stop rule (fingers caught on
        // the wrong side of a rim or a thin wall) tries again from the recording's own grasp
        // at that frame, and takes it only when that meets the stop rule and ends lower
        // (the objective counts the barriers, the stop rule does not): where neither start
        // gets there (a hand held off by a barrier), the carried hand stays and does not jump.
        if !r.converged
            && params.solver == Solver::Lm
            && params.warm_start != WarmStart::Rigid
            && !contacts.is_empty()
        {
            let mut w2 = init.wrists[t];
            q2.copy_from_slice(init.q(t));
            // Where the recorded grasp starts above [`RESTART_GATE`] times the carried hand's
            // end (a hand held off by a barrier), no solve is spent on it.
            let start = solver.objective_at(&object_pose, contacts, &w2, &q2, target_m);
            let r2 = (start < RESTART_GATE * r.objective_end)
                .then(|| solver.solve_within(&object_pose, contacts, &mut w2, &mut q2, target_m));
            if let Some(r2) = r2
                && r2.converged
                && r2.objective_end < r.objective_end
                && !r2.non_finite
            {
                wrist = w2;
                q.copy_from_slice(&q2);
                r = r2;
                stats.restarted.push(t);
            }
        }
        if r.non_finite {
            stats.non_finite.push(t);
        }
        if !r.converged {
            stats.not_converged.push(t);
        }
        out.wrists[t] = wrist;
        out.joints[t * dof..(t + 1) * dof].copy_from_slice(&q);
        stats.frames.push(r);
        prev_object = object_pose;
    }
    summarize(&mut stats);
    stats.objective = params.objective;
    stats.time_s = clock.elapsed().as_secs_f64();
    (out, stats)
}

/// The totals of `stats` over its frames: convergence, iterations, D_C, clearance, stop
/// reasons and deepest probe.
fn summarize(stats: &mut Stats) {
    let count = stats.frames.len().max(1) as f64;
    stats.converged_fraction = stats.frames.iter().filter(|f| f.converged).count() as f64 / count;
    stats.mean_iterations = stats.frames.iter().map(|f| f.iterations).sum::<usize>() as f64 / count;
    stats.max_iterations_used = stats.frames.iter().map(|f| f.iterations).max().unwrap_or(0);
    let with_contacts: Vec<f64> = stats
        .frames
        .iter()
        .filter(|f| f.contacts > 0)
        .map(|f| f.mean_mm)
        .collect();
    stats.d_c_mm = if with_contacts.is_empty() {
        0.0
    } else {
        with_contacts.iter().sum::<f64>() / with_contacts.len() as f64
    };
    stats.min_barrier_clearance_mm = stats
        .frames
        .iter()
        .filter_map(|f| f.min_barrier_clearance_mm)
        .reduce(f64::min);
    for f in &stats.frames {
        if f.stop != StopReason::Converged {
            *stats.stop_reasons.entry(f.stop).or_default() += 1;
        }
    }
    stats.max_penetration_mm = stats
        .frames
        .iter()
        .map(|f| f.max_penetration_mm)
        .fold(0.0, f64::max);
}
