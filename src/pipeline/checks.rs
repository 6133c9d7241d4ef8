//! The pipeline's guards between stages: a non-finite value stops a run with the stage, the
//! frame and the quantity, and a replay over the step limit is refused before any step.

use std::path::Path;

use crate::hand::HandPath;
use crate::model::frames::FrameRow;
use crate::model::report::Report;
use crate::physics;
use crate::warp::ObjectPath;
use crate::{Error, Limits, Result};

/// Refuses a replay whose step count (frames × steps per frame at `params.max_dt_s`) is over
/// [`Limits::max_physics_steps`](crate::Limits::max_physics_steps), before any step: the count grows as 1 / fps.
pub(super) fn physics_work(
    limits: &Limits,
    path: &Path,
    frames: usize,
    fps: f64,
    params: &physics::Params,
) -> Result<()> {
    // The rule of the replay: the fewest equal steps per frame not longer than max_dt_s.
    let per_frame = ((1.0 / fps) / params.max_dt_s).ceil().max(1.0);
    let per_frame = if per_frame.is_finite() && per_frame < u64::MAX as f64 {
        per_frame as u64
    } else {
        u64::MAX
    };
    limits.check_physics_steps(path, frames as u64, per_frame)
}

/// The first non-finite value of `values` (`(frame, quantity, value)`) as [`Error::NonFinite`].
fn first_non_finite(
    path: &Path,
    stage: &'static str,
    values: impl IntoIterator<Item = (Option<usize>, &'static str, f64)>,
) -> Result<()> {
    match values.into_iter().find(|(_, _, v)| !v.is_finite()) {
        None => Ok(()),
        Some((frame, quantity, value)) => Err(Error::NonFinite {
            path: path.to_path_buf(),
            stage,
            frame,
            quantity,
            value,
        }),
    }
}

/// Stage boundary check: every object position and orientation finite.
pub(super) fn path(path: &Path, stage: &'static str, object: &ObjectPath) -> Result<()> {
    first_non_finite(
        path,
        stage,
        (0..object.len()).flat_map(|t| {
            let p = object.positions[t];
            let q = object.rotations[t].coords;
            [p.x, p.y, p.z]
                .map(|v| (Some(t), "object position", v))
                .into_iter()
                .chain([q.x, q.y, q.z, q.w].map(|v| (Some(t), "object orientation", v)))
        }),
    )
}

/// Stage boundary check: every wrist pose and joint value finite.
pub(super) fn hand(path: &Path, stage: &'static str, hand: &HandPath) -> Result<()> {
    first_non_finite(
        path,
        stage,
        hand.wrists.iter().enumerate().flat_map(|(t, w)| {
            let p = w.translation.vector;
            let q = w.rotation.coords;
            [p.x, p.y, p.z]
                .map(|v| (Some(t), "wrist position", v))
                .into_iter()
                .chain([q.x, q.y, q.z, q.w].map(|v| (Some(t), "wrist orientation", v)))
        }),
    )?;
    let dof = hand.dof.max(1);
    first_non_finite(
        path,
        stage,
        hand.joints
            .iter()
            .enumerate()
            .map(|(k, &v)| (Some(k / dof), "joint value", v)),
    )
}

/// Stage boundary check: the replay's per-frame tracking errors finite.
pub(super) fn physics(path: &Path, p: &physics::PhysicsReport) -> Result<()> {
    let pf = &p.per_frame;
    first_non_finite(
        path,
        "physics replay (6)",
        pf.position_error_mm
            .iter()
            .enumerate()
            .map(|(t, &v)| (Some(t), "simulated object position error [mm]", v))
            .chain(
                pf.rotation_error_deg
                    .iter()
                    .enumerate()
                    .map(|(t, &v)| (Some(t), "simulated object rotation error [deg]", v)),
            ),
    )
}

/// Stage boundary check: every metric of the report and every per-frame row finite.
pub(super) fn metrics(path: &Path, report: &Report, frames: &[FrameRow]) -> Result<()> {
    let m = &report.metrics;
    let c = &report.constraints;
    let stage = "metrics (7)";
    first_non_finite(
        path,
        stage,
        [
            (None, "D_WO original [mm]", m.d_wo_mm.original),
            (None, "D_WO [mm]", m.d_wo_mm.warped),
            (None, "D_C original [mm]", m.d_c_mm.original),
            (None, "D_C before smoothing [mm]", m.d_c_mm.unsmoothed),
            (None, "D_C [mm]", m.d_c_mm.warped),
            (None, "object path length ratio", m.plr_object),
            (None, "wrist path length ratio", m.plr_hand),
            (None, "timewarp discrepancy", m.timewarp_discrepancy),
            (None, "largest waypoint error [mm]", c.max_waypoint_error_mm),
            (None, "object radius [mm]", c.object_radius_mm),
            (None, "largest push-out [mm]", c.pushout_max_mm),
        ],
    )?;
    first_non_finite(
        path,
        stage,
        frames.iter().flat_map(|r| {
            let t = Some(r.frame);
            [
                (t, "object position", r.object_x),
                (t, "object position", r.object_y),
                (t, "object position", r.object_z),
                (t, "wrist position", r.wrist_x),
                (t, "wrist position", r.wrist_y),
                (t, "wrist position", r.wrist_z),
                (t, "D_C [mm]", r.d_c_mm.unwrap_or(0.0)),
                (
                    t,
                    "D_C before smoothing [mm]",
                    r.d_c_unsmoothed_mm.unwrap_or(0.0),
                ),
            ]
        }),
    )
}

/// The hand-recovery stage boundary check, for callers holding a [`HandPath`] of their own:
/// the first NaN or infinite wrist coordinate or joint value as [`Error::NonFinite`] with its
/// output frame; `path` names the run's config.
pub fn check_hand_path(path: &Path, hand: &HandPath) -> Result<()> {
    self::hand(path, "hand recovery (4-5)", hand)
}
