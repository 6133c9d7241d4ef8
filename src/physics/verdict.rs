//! The verdict: every failed check as a sentence naming the frame and the value.

use super::params::Params;
use super::report::{Carry, DropCause, Penetration, PhysicsReport, Pushed, Stability, Tracking};

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
                "object slipped in the grasp at frame {}: position error {:.1} mm > {:.1} mm while the hand touches it{}",
                d.frame,
                d.position_error_mm,
                params.drop_error_m * 1e3,
                with_links(&d.touching_links)
            ),
        });
    }
    let pushed = report
        .release
        .as_ref()
        .and_then(|r| r.pushed.as_ref().map(|p| (r.frame, p)));
    out.extend(tracking(&report.tracking, pushed, params));
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

/// ` (with a, b)` naming the links that touch, or nothing when none is known.
fn with_links(links: &[String]) -> String {
    if links.is_empty() {
        String::new()
    } else {
        format!(" (with {})", links.join(", "))
    }
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

/// The tracking limits `t` breaks, as sentences. When the largest position error is the
/// hand pushing the released object (`pushed`: the last contact frame and the push), its
/// sentence says so.
fn tracking(t: &Tracking, pushed: Option<(usize, &Pushed)>, params: &Params) -> Vec<String> {
    let mut out = Vec::new();
    if t.mean_position_error_mm > params.max_mean_position_error_m * 1e3 {
        out.push(format!(
            "mean object position error {:.1} mm > {:.1} mm",
            t.mean_position_error_mm,
            params.max_mean_position_error_m * 1e3
        ));
    }
    if t.max_position_error_mm > params.max_position_error_m * 1e3 {
        let (error, frame, limit) = (
            t.max_position_error_mm,
            t.max_position_error_frame,
            params.max_position_error_m * 1e3,
        );
        out.push(match pushed.filter(|(_, p)| p.frame == frame) {
            Some((released, p)) => format!(
                "object pushed after the release: position error {error:.1} mm at frame {frame} > {limit:.1} mm ({:.1} mm at the last contact frame {released}); the hand touches it up to frame {}{}",
                p.release_error_mm,
                p.last_touch_frame,
                with_links(&p.touching_links)
            ),
            None => format!("object position error {error:.1} mm at frame {frame} > {limit:.1} mm"),
        });
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
        tracking(t, None, params)
            .into_iter()
            .map(|r| format!("carried, {r}")),
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::Release;

    #[test]
    fn the_position_error_of_a_push_after_the_release_says_so() {
        let params = Params::default();
        let mut report = PhysicsReport {
            tracking: Tracking {
                mean_position_error_mm: 27.5,
                max_position_error_mm: 166.7,
                max_position_error_frame: 679,
                ..Tracking::default()
            },
            release: Some(Release {
                frame: 534,
                rests_on_support: true,
                pushed: Some(Pushed {
                    frame: 679,
                    position_error_mm: 166.7,
                    release_error_mm: 7.8,
                    last_touch_frame: 630,
                    touching_links: vec!["index_middle".into(), "middle_middle".into()],
                }),
                ..Release::default()
            }),
            ..PhysicsReport::default()
        };
        let r = reasons(&report, &params);
        assert_eq!(r.len(), 2, "{r:?}");
        assert_eq!(
            r[1],
            "object pushed after the release: position error 166.7 mm at frame 679 > 50.0 mm (7.8 mm at the last contact frame 534); the hand touches it up to frame 630 (with index_middle, middle_middle)"
        );
        // The largest error elsewhere (in the grasp): the plain sentence, same count.
        report.tracking.max_position_error_frame = 300;
        let r = reasons(&report, &params);
        assert_eq!(r.len(), 2, "{r:?}");
        assert!(
            r[1].starts_with("object position error 166.7 mm at frame 300"),
            "{r:?}"
        );
    }
}
