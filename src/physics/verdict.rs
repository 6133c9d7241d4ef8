//! The verdict: every failed check as a sentence naming the frame and the value.

use super::params::Params;
use super::report::{Carry, DropCause, Penetration, PhysicsReport, Stability, Tracking};

/// The reasons `report` fails under `params`, in a fixed order: divergence, drop, tracking,
/// penetration (hand-object, hand-barrier, object-barrier), stability, release.
pub(crate) fn reasons(report: &PhysicsReport, params: &Params) -> Vec<String> {
    let mut out = Vec::new();
    if let Some(f) = report.replay.diverged_frame {
        out.push(format!(
            "the simulation diverged at frame {f} (the object pose became non-finite)"
        ));
    }
    if let Some(d) = &report.drop {
        out.push(match d.cause {
            DropCause::LostContact => format!(
                "object dropped at frame {}: position error {:.1} mm > {:.1} mm; the hand lost contact at frame {}",
                d.frame,
                d.position_error_mm,
                params.drop_error_m * 1e3,
                d.contact_lost_frame.unwrap_or(d.frame)
            ),
            DropCause::Slipped => format!(
                "object slipped in the grasp at frame {}: position error {:.1} mm > {:.1} mm while the hand touches it",
                d.frame,
                d.position_error_mm,
                params.drop_error_m * 1e3
            ),
        });
    }
    out.extend(tracking(&report.tracking, params));
    let p = &report.penetration;
    penetration(&mut out, "hand-object", &p.hand_object);
    penetration(&mut out, "hand-barrier", &p.hand_barrier);
    penetration(&mut out, "object-barrier", &p.object_barrier);
    if let Some(s) = &report.stability
        && s.max_mm > params.max_sim_displacement_m * 1e3
    {
        out.push(format!(
            "simulation displacement {:.1} mm at frame {} > {:.1} mm (mean {:.1} mm over {} sampled frames)",
            s.max_mm,
            s.max_frame.unwrap_or(0),
            params.max_sim_displacement_m * 1e3,
            s.mean_mm,
            s.frames.len()
        ));
    }
    if let Some(r) = &report.release
        && !r.rests_on_support
    {
        let nearest = match (&r.support, r.support_gap_mm) {
            (Some(s), Some(g)) => format!("nearest support {s:?} {g:.1} mm away"),
            _ => "the scene has no support".to_string(),
        };
        out.push(format!(
            "released unsupported: after the last contact frame {} the object does not come to rest on a support (it moves {:.1} mm over the last {:.1} s, {nearest})",
            r.frame, r.final_motion_mm, params.rest_window_s
        ));
    }
    out
}

fn penetration(out: &mut Vec<String>, what: &str, p: &Penetration) {
    if let Some(limit) = p.limit_mm
        && p.max_mm > limit
    {
        out.push(format!(
            "{what} penetration {:.1} mm at frame {} ({}) > {:.1} mm; {} frames over the limit",
            p.max_mm,
            p.worst_frame.unwrap_or(0),
            p.worst_pair.as_deref().unwrap_or("?"),
            limit,
            p.frames_over_limit
        ));
    }
}

/// The tracking limits `t` breaks, as sentences.
fn tracking(t: &Tracking, params: &Params) -> Vec<String> {
    let mut out = Vec::new();
    if t.mean_position_error_mm > params.max_mean_position_error_m * 1e3 {
        out.push(format!(
            "mean object position error {:.1} mm > {:.1} mm",
            t.mean_position_error_mm,
            params.max_mean_position_error_m * 1e3
        ));
    }
    if t.max_position_error_mm > params.max_position_error_m * 1e3 {
        out.push(format!(
            "object position error {:.1} mm at frame {} > {:.1} mm",
            t.max_position_error_mm,
            t.max_position_error_frame,
            params.max_position_error_m * 1e3
        ));
    }
    if t.mean_rotation_error_deg > params.max_mean_rotation_error_deg {
        out.push(format!(
            "mean object rotation error {:.1}° > {:.1}° (largest {:.1}° at frame {})",
            t.mean_rotation_error_deg,
            params.max_mean_rotation_error_deg,
            t.max_rotation_error_deg,
            t.max_rotation_error_frame
        ));
    }
    out
}

/// The reasons a grasp fails the hold test: the frozen hand lets the object move past
/// [`Params::max_sim_displacement_m`], or the carried object drops (position error past
/// [`Params::drop_error_m`]) or breaks the replay's tracking limits.
pub(crate) fn hold(stability: &Stability, carry: &Carry, params: &Params) -> Vec<String> {
    let mut out = Vec::new();
    if stability.max_mm > params.max_sim_displacement_m * 1e3 {
        out.push(format!(
            "with the hand frozen the object moves {:.1} mm at frame {} > {:.1} mm (mean {:.1} mm over {} sampled frames)",
            stability.max_mm,
            stability.max_frame.unwrap_or(0),
            params.max_sim_displacement_m * 1e3,
            stability.mean_mm,
            stability.frames.len()
        ));
    }
    let t = &carry.tracking;
    if t.max_position_error_mm > params.drop_error_m * 1e3 {
        out.push(format!(
            "carried, the object drops out of the grasp at frame {}: position error {:.1} mm > {:.1} mm",
            t.max_position_error_frame,
            t.max_position_error_mm,
            params.drop_error_m * 1e3
        ));
    }
    out.extend(
        tracking(t, params)
            .into_iter()
            .map(|r| format!("carried, {r}")),
    );
    out
}
