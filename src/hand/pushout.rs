//! Barrier push-out of the hand outside the contact segment (beyond docs/METHOD.md stage 4; the
//! paper's reference code does the same with a hand bounding radius).
//!
//! Outside the contact segment the hand follows the object's rigid shift of stage 1, so a new
//! start or end can sweep it through a barrier on the approach or the retreat. This stage
//! treats the hand as a ball of radius `r_h` ([`Params::radius_m`]) about the wrist origin and
//! pushes every pre-contact (`t < c0`) and post-contact (`t > t'_end`) wrist position out of the
//! barriers exactly as stage 2 pushes the object ([`crate::warp::barrier`]): in paper mode each
//! barrier's hull is scaled about its centroid by `1 + r_h/ρ` and a position inside is moved
//! along the centroid ray, in steps, until outside; sweeps repeat until no position is inside
//! any barrier or the sweep cap is hit (a narrow gap, reported with its frames). The wrist
//! rotation and the joints are kept, so the whole hand moves rigidly with its wrist. Frames
//! in the contact segment are the IK's (or the baseline's) and are never moved here.

use std::time::Instant;

use nalgebra::Point3;
use serde::{Deserialize, Serialize};

use super::HandPath;
use crate::model::PushoutMode;
use crate::model::config::DEFAULT_HAND_RADIUS_M;
use crate::model::report::NarrowGap;
use crate::warp::WarpPlan;
use crate::warp::barrier::Barrier;

/// Parameters of the hand push-out.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Params {
    /// Bounding radius of the hand about the wrist origin [m] (palm-sized; the fingers of a
    /// human hand reach farther, they are the IK's concern in contact). 0 turns the stage off.
    /// Default 0.05.
    pub radius_m: f64,
    /// Paper (scaled hull) or exact clearance, as the object's push-out. Default paper.
    pub mode: PushoutMode,
    /// Step along the centroid ray [m]. Default 0.002.
    pub step_m: f64,
    /// Most sweeps over all barriers before declaring a narrow gap. Default 64.
    pub max_sweeps: usize,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            radius_m: DEFAULT_HAND_RADIUS_M,
            mode: PushoutMode::Paper,
            step_m: 0.002,
            max_sweeps: 64,
        }
    }
}

/// What the hand push-out did.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Hand bounding radius used [m].
    pub radius_m: f64,
    /// Sweeps over all barriers (0 when off or without barriers).
    pub sweeps: usize,
    /// Output frames whose wrist was moved.
    pub frames_moved: usize,
    /// Largest distance a wrist was moved [m].
    pub max_push_m: f64,
    /// Set when the sweep cap was hit (output frames).
    pub narrow_gap: Option<NarrowGap>,
    /// Wall time [s].
    pub time_s: f64,
}

/// Pushes the wrist of every output frame outside the contact segment out of `barriers`
/// (prepared with the hand radius, [`Barrier::from_points`]); returns the hand and the stats.
pub fn run(
    mut hand: HandPath,
    plan: &WarpPlan,
    barriers: &[Barrier],
    params: &Params,
) -> (HandPath, Stats) {
    let clock = Instant::now();
    let mut stats = Stats {
        radius_m: params.radius_m,
        ..Stats::default()
    };
    if params.radius_m <= 0.0 || barriers.is_empty() {
        stats.time_s = clock.elapsed().as_secs_f64();
        return (hand, stats);
    }
    let (c0, t_end) = (plan.segment.start, plan.t_end_new());
    let n = hand.len();
    let frames: Vec<usize> = (0..c0.min(n)).chain((t_end + 1).min(n)..n).collect();
    let before: Vec<Point3<f64>> = frames
        .iter()
        .map(|&t| Point3::from(hand.wrists[t].translation.vector))
        .collect();
    let mut converged = false;
    for sweep in 1..=params.max_sweeps.max(1) {
        stats.sweeps = sweep;
        let mut any = false;
        for b in barriers {
            for &t in &frames {
                let p = Point3::from(hand.wrists[t].translation.vector);
                if b.contains(&p, params.mode) {
                    let q = b.push(&p, params.mode, params.step_m);
                    hand.wrists[t].translation.vector = q.coords;
                    any = true;
                }
            }
        }
        if !any {
            converged = true;
            break;
        }
    }
    for (&t, p0) in frames.iter().zip(&before) {
        let d = (hand.wrists[t].translation.vector - p0.coords).norm();
        if d > 0.0 {
            stats.frames_moved += 1;
            stats.max_push_m = stats.max_push_m.max(d);
        }
    }
    if !converged {
        let mut gap = NarrowGap::default();
        for &t in &frames {
            let p = Point3::from(hand.wrists[t].translation.vector);
            let inside: Vec<&Barrier> = barriers
                .iter()
                .filter(|b| b.contains(&p, params.mode))
                .collect();
            if !inside.is_empty() {
                gap.frames.push(t);
                for b in inside {
                    if !gap.barriers.contains(&b.name) {
                        gap.barriers.push(b.name.clone());
                    }
                }
            }
        }
        stats.narrow_gap = Some(gap);
    }
    stats.time_s = clock.elapsed().as_secs_f64();
    (hand, stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ContactSegment;
    use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

    fn box_points(center: Vector3<f64>, half: f64) -> Vec<Point3<f64>> {
        let mut v = Vec::new();
        for sx in [-1.0, 1.0] {
            for sy in [-1.0, 1.0] {
                for sz in [-1.0, 1.0] {
                    v.push(Point3::from(center + Vector3::new(sx, sy, sz) * half));
                }
            }
        }
        v
    }

    /// A wrist path along x through a 10 cm box, contact segment in the middle: after the
    /// push-out no pre- or post-contact wrist is inside the inflated box, in-contact frames
    /// are untouched, and the stats count the moved frames.
    #[test]
    fn pushes_approach_and_retreat_out_and_keeps_contact_frames() {
        let n = 60;
        let positions: Vec<Vector3<f64>> = (0..n)
            .map(|i| Vector3::new(-0.3 + 0.6 * i as f64 / (n - 1) as f64, 0.0, 0.0))
            .collect();
        let segment = ContactSegment {
            start: 25,
            end: 35,
            gap_frames: 0,
        };
        let plan = WarpPlan::identity(&positions, segment);
        let mut hand = HandPath::with_capacity(n, 0);
        for p in &positions {
            hand.push(
                Isometry3::from_parts(Translation3::from(*p), UnitQuaternion::identity()),
                &[],
            );
        }
        let params = Params::default();
        // One box on the approach, one on the retreat.
        let barriers = [
            Barrier::from_points("a", &box_points(Vector3::new(-0.2, 0.0, 0.0), 0.05), 0.05)
                .unwrap(),
            Barrier::from_points("b", &box_points(Vector3::new(0.2, 0.0, 0.0), 0.05), 0.05)
                .unwrap(),
        ];
        let (out, stats) = run(hand.clone(), &plan, &barriers, &params);
        assert!(stats.narrow_gap.is_none());
        assert!(stats.frames_moved > 0, "nothing moved: {stats:?}");
        for t in 0..n {
            let p = Point3::from(out.wrists[t].translation.vector);
            if (25..=35).contains(&t) {
                assert_eq!(out.wrists[t], hand.wrists[t], "contact frame {t} moved");
            } else {
                for b in &barriers {
                    assert!(
                        !b.contains(&p, params.mode),
                        "frame {t} still inside {}",
                        b.name
                    );
                }
            }
        }
        let moved_max = (0..n)
            .map(|t| (out.wrists[t].translation.vector - positions[t]).norm())
            .fold(0.0, f64::max);
        assert!((moved_max - stats.max_push_m).abs() < 1e-12);
    }

    #[test]
    fn radius_zero_is_off() {
        let positions = vec![Vector3::zeros(); 4];
        let plan = WarpPlan::identity(
            &positions,
            ContactSegment {
                start: 1,
                end: 2,
                gap_frames: 0,
            },
        );
        let mut hand = HandPath::with_capacity(4, 0);
        for _ in 0..4 {
            hand.push(Isometry3::identity(), &[]);
        }
        let b = Barrier::from_points("a", &box_points(Vector3::zeros(), 0.05), 0.0).unwrap();
        let params = Params {
            radius_m: 0.0,
            ..Params::default()
        };
        let (out, stats) = run(hand.clone(), &plan, &[b], &params);
        assert_eq!(out, hand);
        assert_eq!(stats.frames_moved, 0);
    }
}
