//! Stages 7-8 of [`super::warp`]: the metrics, the report and the rows of `frames.csv`.

use rapier3d_f64::parry::query;
use rapier3d_f64::parry::shape::SharedShape;

use super::stages::IkRun;
use super::{Inputs, Options, checks};
use crate::Result;
use crate::geometry::Mesh;
use crate::hand::{guard, pushout};
use crate::math::convert::to_pose;
use crate::metrics;
use crate::model::Demo;
use crate::model::frames::FrameRow;
use crate::model::report::{
    Constraints, ContactDistance, GuardSummary, IkSummary, Metrics, Pair, REPORT_FORMAT, Report,
    WorstFrame,
};
use crate::physics::PhysicsReport;
use crate::robot::Robot;
use crate::warp::barrier::Barrier;
use crate::warp::{ObjectPath, ObjectWarp};

/// What the stages of one warp produced, for its report.
pub(super) struct Stages<'a> {
    /// The output demonstration.
    pub out: &'a Demo,
    pub object: &'a ObjectWarp,
    /// The barriers as the object's push-out saw them.
    pub barriers: &'a [Barrier],
    /// Contact IK's run (none for the baseline hand).
    pub ik: Option<&'a IkRun>,
    pub guard: Option<&'a guard::Stats>,
    pub hand_push: &'a pushout::Stats,
    pub physics: Option<&'a PhysicsReport>,
    /// The IK threshold of the run [mm] (the config's, or the options').
    pub threshold_mm: f64,
}

/// The report of a warp and its per-frame rows, checked for non-finite figures.
pub(super) fn warp_report(
    inputs: &Inputs,
    options: &Options,
    stages: Stages<'_>,
) -> Result<(Report, Vec<FrameRow>)> {
    let Inputs {
        config,
        demo,
        robot,
        mesh,
        ..
    } = inputs;
    let Stages {
        out,
        object,
        barriers,
        ik,
        guard,
        hand_push,
        physics,
        threshold_mm,
    } = stages;
    let dc_frames = metrics::contact_distance_per_frame_mm(robot, out);
    let mut report = metrics_report(demo, out, &dc_frames, robot, object, barriers, mesh)?;
    let mut frames = frame_rows(out, object, &dc_frames);
    if let Some(ik) = ik {
        // D_C before smoothing (the paper's drift is the difference).
        let before = metrics::contact_distance_per_frame_mm(
            robot,
            &super::assemble(demo, object, &ik.raw, &config.name),
        );
        report.metrics.d_c_mm.unsmoothed = metrics::d_c_mm(&before);
        for (r, v) in frames.iter_mut().zip(&before) {
            r.d_c_unsmoothed_mm = *v;
        }
    }
    report.constraints.hand_radius_mm = hand_push.radius_m * 1e3;
    report.constraints.hand_pushout_frames_moved = hand_push.frames_moved;
    report.constraints.hand_pushout_max_mm = hand_push.max_push_m * 1e3;
    report.constraints.hand_narrow_gap = hand_push.narrow_gap.clone();
    report.constraints.hand_clearance_mm = hand_push.link_clearance_m * 1e3;
    report.constraints.hand_link_frames_moved = hand_push.link_frames_moved;
    report.constraints.hand_min_barrier_distance_mm =
        hand_push.min_link_clearance_m.map(|d| d * 1e3);
    report.config = Some(config.source.display().to_string());
    report.threshold_mm = Some(threshold_mm);
    report.hand = Some(options.hand.as_str().into());
    if let Some(p) = physics {
        report.physics = Some(p.to_summary());
        for (r, (pos, rot)) in frames.iter_mut().zip(
            p.per_frame
                .position_error_mm
                .iter()
                .zip(&p.per_frame.rotation_error_deg),
        ) {
            r.physics_position_error_mm = Some(*pos);
            r.physics_rotation_error_deg = Some(*rot);
        }
    }
    if let Some(ik) = ik {
        let st = &ik.stats;
        report.solver = Some(st.solver.as_str().into());
        report.ik = Some(IkSummary {
            converged_fraction: st.converged_fraction,
            not_converged_frames: st.not_converged.clone(),
            restarted_frames: st.restarted.clone(),
            mean_iterations: st.mean_iterations,
            max_iterations: st.max_iterations_used,
            min_barrier_clearance_mm: st.min_barrier_clearance_mm,
            objective: Some(st.objective.as_str().into()),
            stop_reasons: st
                .stop_reasons
                .iter()
                .map(|(r, n)| (r.as_str().to_string(), *n))
                .collect(),
            max_penetration_mm: Some(st.max_penetration_mm),
            penetration_tolerance_mm: Some(ik.tolerance_mm),
            smoothing_guard: guard.map(|g| GuardSummary {
                frames_too_deep: g.frames_too_deep,
                frames_blended: g.frames_blended,
                max_depth_before_mm: g.max_depth_before_mm,
                max_depth_after_mm: g.max_depth_after_mm,
            }),
            held_yield: ik.held_yield.clone(),
            held: ik.held.clone(),
        });
        for r in &mut frames {
            if let Some(f) = r
                .frame
                .checked_sub(st.first_frame)
                .and_then(|i| st.frames.get(i))
            {
                r.ik_converged = Some(f.converged);
                r.ik_iterations = Some(f.iterations);
                r.ik_stop = Some(f.stop.as_str().into());
                r.ik_penetration_mm = Some(f.max_penetration_mm);
            }
        }
    }
    checks::metrics(&config.source, &report, &frames)?;
    Ok((report, frames))
}

fn metrics_report(
    original: &Demo,
    out: &Demo,
    dc_frames: &[Option<f64>],
    robot: &Robot,
    object: &ObjectWarp,
    barriers: &[Barrier],
    mesh: &Mesh,
) -> Result<Report> {
    let dc_orig = metrics::d_c_mm(&metrics::contact_distance_per_frame_mm(robot, original));
    let dc_out = metrics::d_c_mm(dc_frames);
    let plan = &object.plan;
    let stretched = metrics::stretched_frames(
        &object.retime.timewarp,
        plan.segment.start..=plan.t_end_new(),
    );
    let min_clearance = if barriers.is_empty() {
        None
    } else {
        let hull = mesh.convex_hull();
        hull.map(|h| min_clearance_mm(&h, object.path(), barriers))
    };
    Ok(Report {
        format: REPORT_FORMAT.into(),
        name: out.name.clone(),
        frames_in: original.frames.len(),
        frames_out: out.frames.len(),
        metrics: Metrics {
            d_wo_mm: Pair {
                original: metrics::d_wo_mm(original),
                warped: metrics::d_wo_mm(out),
            },
            d_c_mm: ContactDistance {
                original: dc_orig,
                unsmoothed: dc_out,
                warped: dc_out,
                uncorrupted: None,
            },
            plr_object: metrics::ratio(
                metrics::object_path_length(out),
                metrics::object_path_length(original),
            ),
            plr_hand: metrics::ratio(
                metrics::wrist_path_length(out),
                metrics::wrist_path_length(original),
            ),
            timewarp_discrepancy: object.retime.timewarp.discrepancy(),
            timewarp_discrepancy_paper: Some(object.retime.stats.discrepancy_paper),
            d_c_stretched_mm: metrics::d_c_over_mm(dc_frames, &stretched),
            stretched_frames: stretched.len(),
            d_c_worst: metrics::worst_frame(dc_frames)
                .map(|(frame, d_c_mm)| WorstFrame { frame, d_c_mm }),
            grasp_slide_mm: metrics::grasp_slide_mm(original)
                .zip(metrics::grasp_slide_mm(out))
                .map(|(original, warped)| Pair { original, warped }),
            grasp_shift_mm: metrics::grasp_shift_mm(
                original,
                out,
                plan.segment.start..=plan.t_end_new(),
                |t| object.source_frame(t),
            ),
        },
        constraints: Constraints {
            hand_object_penetration_mm: crate::geometry::object_sdf(mesh).map(|sdf| Pair {
                original: metrics::max_hand_object_penetration_mm(robot, original, &sdf),
                warped: metrics::max_hand_object_penetration_mm(robot, out, &sdf),
            }),
            max_waypoint_error_mm: object.retime.stats.max_anchor_error_m * 1e3,
            min_object_barrier_clearance_mm: min_clearance,
            object_radius_mm: object.barrier.stats.object_radius_m * 1e3,
            pushout_frames_moved: object.barrier.stats.frames_moved,
            pushout_sweeps: object.barrier.stats.sweeps,
            pushout_max_mm: object.barrier.stats.max_push_m * 1e3,
            narrow_gap: object.barrier.stats.narrow_gap.clone(),
            contact_gap_frames: plan.segment.gap_frames,
            ..Constraints::default()
        },
        ..Report::default()
    })
}

/// Smallest distance between the object's hull and any barrier hull over the output frames.
fn min_clearance_mm(hull: &SharedShape, path: &ObjectPath, barriers: &[Barrier]) -> f64 {
    let identity = rapier3d_f64::parry::math::Pose::IDENTITY;
    let mut best = f64::INFINITY;
    for i in 0..path.len() {
        let pose = to_pose(&path.pose(i));
        for b in barriers {
            if let Ok(d) = query::distance(&pose, hull.as_ref(), &identity, b.hull()) {
                best = best.min(d.distance);
            }
        }
    }
    best * 1e3
}

/// Per-frame rows of `frames.csv` from the stages' outputs.
fn frame_rows(out: &Demo, object: &ObjectWarp, dc: &[Option<f64>]) -> Vec<FrameRow> {
    let in_contact = object.plan.segment.start..=object.plan.t_end_new();
    (0..out.frames.len())
        .map(|t| {
            FrameRow::new(
                out,
                t,
                object.source_frame(t),
                in_contact.contains(&t),
                dc[t],
            )
        })
        .collect()
}
