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
//! in the contact segment are the IK's (or the baseline's) and are never moved here, and the
//! ball is not asked of them: it phases in over [`Params::blend_frames`] `W` from the
//! segment's ends (a wrist `k` frames from the segment gets `min(1, k/(W + 1))` of its push).
//! Pushed in full at the first frame after the release, a wrist that ends the grasp within
//! the ball's reach of a barrier stepped by up to the ball's depth in one frame (24 mm
//! measured on a sampled cube variation), and the fingers, still around the object, knocked
//! it; the ball is a coarse bound on the hand, the link pass is the exact one.
//!
//! A ball about the wrist does not hold the fingers: a long-fingered hand (an Allegro's reach
//! far past 5 cm) sweeps a fingertip through a cup beside the object on the approach while
//! its wrist stays clear. The link pass follows the ball pass: at every frame outside
//! contact each link's collision shapes are placed by forward kinematics and queried against
//! every barrier's shape (parry contacts); where a link comes closer than
//! [`Params::link_clearance_m`] the wrist is moved along the contact normal, away from the
//! barrier, until every link keeps the clearance. A push fades into the neighbouring frames
//! over [`Params::blend_frames`] `W` (a push of `d` at frame `s` asks `d · (1 − |t − s|/(W + 1))`
//! of frame `t`, the largest ask wins; toward the contact segment, whose poses are never
//! moved, the ask reaches 0 at the segment's first or last frame when that is nearer), so the
//! wrist path has no step where a push starts or where the approach meets the grasp; the
//! passes repeat until no link is closer than the clearance or the sweep cap is hit (then
//! the frames still inside a barrier are reported as a narrow gap). Only a push of the very
//! frame next to the contact segment shows as a step there.

use std::time::Instant;

use nalgebra::{Isometry3, Point3, Translation3, Vector3};
use rapier3d_f64::parry::bounding_volume::{Aabb, BoundingVolume};
use rapier3d_f64::parry::math::Pose;
use rapier3d_f64::parry::query;
use serde::{Deserialize, Serialize};

use super::HandPath;
use crate::geometry::shape::CollisionShape;
use crate::math::convert::to_pose;
use crate::model::PushoutMode;
use crate::model::config::{DEFAULT_HAND_CLEARANCE_M, DEFAULT_HAND_RADIUS_M};
use crate::model::report::NarrowGap;
use crate::robot::Robot;
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
    /// Clearance every link of the hand keeps from every barrier outside contact, the link
    /// pass (see the module docs) [m]; 0 turns the link pass off. Default 0.002.
    pub link_clearance_m: f64,
    /// Frames over which a link-pass push fades into its neighbours, and over which the ball
    /// pass phases in from the contact segment. Default 15 ([`BLEND_S`] at 30 fps; set it for
    /// a demonstration's rate with [`Params::at_fps`]).
    pub blend_frames: usize,
}

/// How long a push fades into its neighbours and the ball pass phases in [s].
pub const BLEND_S: f64 = 0.5;

impl Params {
    /// These parameters with [`Params::blend_frames`] set to [`BLEND_S`] at `fps` frames per
    /// second (rounded; 15 at 30 fps, 5 at 10, 60 at 120), so the hand moves off a barrier
    /// over the same time whatever the recording's rate.
    pub fn at_fps(self, fps: f64) -> Params {
        Params {
            blend_frames: crate::math::frames_in(BLEND_S, fps),
            ..self
        }
    }
}

impl Default for Params {
    fn default() -> Self {
        Params {
            radius_m: DEFAULT_HAND_RADIUS_M,
            mode: PushoutMode::Paper,
            step_m: 0.002,
            max_sweeps: 64,
            link_clearance_m: DEFAULT_HAND_CLEARANCE_M,
            blend_frames: 15,
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
    /// Link clearance used [m].
    pub link_clearance_m: f64,
    /// Link pass: sweeps (0 when off, without barriers, or when no link came too close).
    pub link_sweeps: usize,
    /// Link pass: output frames whose wrist it moved.
    pub link_frames_moved: usize,
    /// Smallest distance from any hand link to any barrier outside contact after the
    /// push-out [m] (negative: penetrating) where one is within the link clearance; `None`
    /// when every link keeps the clearance everywhere, or the link pass is off.
    pub min_link_clearance_m: Option<f64>,
    /// Wall time [s].
    pub time_s: f64,
}

/// The barriers of the hand push-out: their hulls inflated by the hand radius for the ball
/// pass ([`Barrier::from_points`]) and their shapes for the link pass, in the same order.
#[derive(Clone, Copy, Debug)]
pub struct Barriers<'a> {
    /// The barriers' names (the config's `barriers`).
    pub names: &'a [String],
    /// Hulls inflated by [`Params::radius_m`]; empty when the ball pass is off.
    pub hulls: &'a [Barrier],
    /// World-frame shapes ([`crate::pipeline::barriers::shapes`]).
    pub shapes: &'a [CollisionShape],
}

/// Pushes the hand of every output frame outside the contact segment out of `barriers`:
/// the wrist ball, then every link (see the module docs); returns the hand and the stats.
pub fn run(
    mut hand: HandPath,
    plan: &WarpPlan,
    robot: &Robot,
    barriers: Barriers<'_>,
    params: &Params,
) -> (HandPath, Stats) {
    let clock = Instant::now();
    let mut stats = Stats {
        radius_m: params.radius_m,
        link_clearance_m: params.link_clearance_m,
        ..Stats::default()
    };
    let (c0, t_end) = (plan.segment.start, plan.t_end_new());
    let n = hand.len();
    let spans = [0..c0.min(n), (t_end + 1).min(n)..n];
    let before: Vec<Vector3<f64>> = hand.wrists.iter().map(|w| w.translation.vector).collect();
    if params.radius_m > 0.0 && !barriers.hulls.is_empty() {
        ball_pass(&mut hand, &spans, barriers.hulls, params, &mut stats);
    }
    if params.link_clearance_m > 0.0 && !barriers.shapes.is_empty() {
        link_pass(&mut hand, &spans, robot, barriers, params, &mut stats);
    }
    for (w, p0) in hand.wrists.iter().zip(&before) {
        let d = (w.translation.vector - p0).norm();
        if d > 0.0 {
            stats.frames_moved += 1;
            stats.max_push_m = stats.max_push_m.max(d);
        }
    }
    stats.time_s = clock.elapsed().as_secs_f64();
    (hand, stats)
}

/// The wrist as a ball of radius `params.radius_m` out of the inflated hulls.
fn ball_pass(
    hand: &mut HandPath,
    spans: &[std::ops::Range<usize>; 2],
    barriers: &[Barrier],
    params: &Params,
    stats: &mut Stats,
) {
    let frames: Vec<usize> = spans.iter().flat_map(|r| r.clone()).collect();
    let before: Vec<Vector3<f64>> = hand.wrists.iter().map(|w| w.translation.vector).collect();
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
    // The ball is not asked of the contact segment's frames, so it phases in from them:
    // `k` frames from the segment a wrist gets `min(1, k/(W + 1))` of its push.
    let w = params.blend_frames as f64 + 1.0;
    for (span, &contact) in spans.iter().zip(&contact_frames(spans)) {
        for t in span.clone() {
            let share = (t.abs_diff(contact) as f64 / w).min(1.0);
            let v = &mut hand.wrists[t].translation.vector;
            *v = before[t] + (*v - before[t]) * share;
        }
    }
}

/// The contact frame each span meets: the approach the segment's first, the retreat its last.
fn contact_frames(spans: &[std::ops::Range<usize>; 2]) -> [usize; 2] {
    [spans[0].end, spans[1].start.saturating_sub(1)]
}

/// The share of frame `s`'s push asked of frame `t`: 1 at `s`, falling linearly to 0 at
/// `w + 1` frames, or at the contact frame `contact` when that is nearer on `t`'s side (the
/// contact segment's poses are not moved, so the approach meets them without a step).
fn fade(t: usize, s: usize, contact: usize, w: usize) -> f64 {
    let toward_contact = (contact > s) == (t > s) && t != s;
    let reach = if toward_contact {
        (w + 1).min(contact.abs_diff(s))
    } else {
        w + 1
    };
    (1.0 - t.abs_diff(s) as f64 / reach as f64).max(0.0)
}

/// Most wrist moves per frame and sweep of the link pass (each closes the worst gap).
const LINK_STEPS: usize = 8;

/// Every link kept `params.link_clearance_m` from every barrier shape (see the module docs).
fn link_pass(
    hand: &mut HandPath,
    spans: &[std::ops::Range<usize>; 2],
    robot: &Robot,
    barriers: Barriers<'_>,
    params: &Params,
    stats: &mut Stats,
) {
    let links = LinkClearance::new(robot, barriers.shapes, params.link_clearance_m);
    let w = params.blend_frames;
    let mut poses = robot.new_link_poses();
    let mut push = vec![Vector3::zeros(); hand.len()];
    let mut moved = vec![false; hand.len()];
    for sweep in 1..=params.max_sweeps.max(1) {
        let mut any = false;
        for span in spans {
            for t in span.clone() {
                robot.forward_kinematics(&hand.wrists[t], hand.q(t), &mut poses);
                let (moved, clear) = links.push(&mut poses);
                push[t] = moved;
                // Pushes between two barriers can cancel out: a frame left too close keeps
                // the sweeps going (up to the cap) even when its push is zero.
                any |= moved != Vector3::zeros() || !clear;
            }
        }
        if !any {
            break;
        }
        stats.link_sweeps = sweep;
        for (span, &contact) in spans.iter().zip(&contact_frames(spans)) {
            for t in span.clone() {
                // The largest ask of the frames within `w` on this side of the contact segment.
                let lo = t.saturating_sub(w).max(span.start);
                let hi = (t + w).min(span.end.saturating_sub(1));
                let mut best = Vector3::zeros();
                for s in lo..=hi {
                    let ask = push[s] * fade(t, s, contact, w);
                    if ask.norm_squared() > best.norm_squared() {
                        best = ask;
                    }
                }
                if best != Vector3::zeros() {
                    hand.wrists[t].translation.vector += best;
                    moved[t] = true;
                }
            }
        }
    }
    stats.link_frames_moved = moved.iter().filter(|&&m| m).count();
    // Where the hand ends up: the smallest distance, and the frames still inside a barrier.
    let mut gap = NarrowGap::default();
    for span in spans {
        for t in span.clone() {
            robot.forward_kinematics(&hand.wrists[t], hand.q(t), &mut poses);
            let Some((d, _, _)) = links.nearest(&poses) else {
                continue;
            };
            stats.min_link_clearance_m = Some(stats.min_link_clearance_m.map_or(d, |m| m.min(d)));
            if d < 0.0 {
                gap.frames.push(t);
                for b in links.penetrated(&poses) {
                    if !gap.barriers.contains(&barriers.names[b]) {
                        gap.barriers.push(barriers.names[b].clone());
                    }
                }
            }
        }
    }
    if !gap.frames.is_empty() {
        if let Some(ball) = stats.narrow_gap.take() {
            gap.frames.extend(ball.frames);
            gap.frames.sort_unstable();
            gap.frames.dedup();
            for b in ball.barriers {
                if !gap.barriers.contains(&b) {
                    gap.barriers.push(b);
                }
            }
        }
        stats.narrow_gap = Some(gap);
    }
}

/// The hand's link shapes against the barrier shapes, with bounding boxes for culling.
pub(crate) struct LinkClearance<'a> {
    /// `(link index, shape)` for every collision shape of the hand.
    hand: Vec<(usize, &'a CollisionShape)>,
    /// Every barrier's shape with its world pose and bounding box.
    barriers: Vec<(Pose, Aabb, &'a CollisionShape)>,
    clearance: f64,
}

impl<'a> LinkClearance<'a> {
    pub(crate) fn new(robot: &'a Robot, barriers: &'a [CollisionShape], clearance: f64) -> Self {
        let barriers = barriers
            .iter()
            .map(|b| {
                let pose = to_pose(&b.shape_pose);
                (pose, b.shape.compute_aabb(&pose), b)
            })
            .collect();
        LinkClearance {
            hand: robot.collision_shapes(),
            barriers,
            clearance,
        }
    }

    /// Calls `f(distance, normal, barrier)` for every link-barrier pair within the clearance
    /// (distance negative: penetrating; the world normal points from the barrier to the link).
    fn each_close(&self, poses: &[Isometry3<f64>], mut f: impl FnMut(f64, Vector3<f64>, usize)) {
        for &(link, cs) in &self.hand {
            let pose = to_pose(&(poses[link] * cs.shape_pose));
            let aabb = cs.shape.compute_aabb(&pose).loosened(self.clearance);
            for (j, (bpose, bb, barrier)) in self.barriers.iter().enumerate() {
                if !aabb.intersects(bb) {
                    continue;
                }
                // Unsupported pairs (none among the shapes URDFs and scenes give) are skipped.
                if let Ok(Some(c)) = query::contact(
                    &pose,
                    cs.shape.as_ref(),
                    bpose,
                    barrier.shape.as_ref(),
                    self.clearance,
                ) {
                    let n1 = c.normal1;
                    f(c.dist, -Vector3::new(n1.x, n1.y, n1.z), j);
                }
            }
        }
    }

    /// The smallest link-barrier distance within the clearance, its normal and its barrier.
    pub(crate) fn nearest(&self, poses: &[Isometry3<f64>]) -> Option<(f64, Vector3<f64>, usize)> {
        let mut best: Option<(f64, Vector3<f64>, usize)> = None;
        self.each_close(poses, |d, n, j| {
            if best.is_none_or(|b| d < b.0) {
                best = Some((d, n, j));
            }
        });
        best
    }

    /// The barriers some link is inside.
    fn penetrated(&self, poses: &[Isometry3<f64>]) -> Vec<usize> {
        let mut inside = Vec::new();
        self.each_close(poses, |d, _, j| {
            if d < 0.0 && !inside.contains(&j) {
                inside.push(j);
            }
        });
        inside
    }

    /// The wrist translation that gives every link the clearance (zero when it has it), and
    /// whether it does after the move (it may not within [`LINK_STEPS`] moves, or between
    /// two barriers). Moves `poses` along.
    fn push(&self, poses: &mut [Isometry3<f64>]) -> (Vector3<f64>, bool) {
        let mut total = Vector3::zeros();
        for _ in 0..LINK_STEPS {
            let Some((d, n, _)) = self.nearest(poses) else {
                return (total, true);
            };
            // A micrometre past the clearance, so the next query does not find it again.
            let gap = self.clearance - d;
            if gap <= 1e-6 {
                return (total, true);
            }
            let m = n * (gap + 1e-6);
            total += m;
            for p in poses.iter_mut() {
                *p = Translation3::from(m) * *p;
            }
        }
        let clear = self
            .nearest(poses)
            .is_none_or(|(d, _, _)| d >= self.clearance - 1e-6);
        (total, clear)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ContactSegment;
    use nalgebra::UnitQuaternion;

    /// A 4 cm palm and one 14 cm finger hanging below it (one revolute joint).
    fn one_finger() -> Robot {
        let urdf = r#"<robot name="t">
            <link name="palm"><collision><geometry><box size="0.04 0.04 0.04"/></geometry></collision></link>
            <link name="finger"><collision><origin xyz="0 0 -0.07"/><geometry><box size="0.01 0.01 0.14"/></geometry></collision></link>
            <joint name="j" type="revolute"><parent link="palm"/><child link="finger"/><origin xyz="0 0 -0.02"/>
              <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"#;
        Robot::from_urdf_str(
            urdf,
            std::path::Path::new("."),
            std::path::Path::new("test.urdf"),
            &crate::Limits::default(),
        )
        .unwrap()
    }

    /// The one-finger hand moving along x from -0.3 m in 1 cm steps over `n` frames, joints at
    /// 0, in contact over `start..=end`: positions, plan, robot, hand.
    fn sweep_along_x(
        n: usize,
        start: usize,
        end: usize,
    ) -> (Vec<Vector3<f64>>, WarpPlan, Robot, HandPath) {
        let segment = ContactSegment {
            start,
            end,
            gap_frames: 0,
        };
        let positions: Vec<Vector3<f64>> = (0..n)
            .map(|i| Vector3::new(-0.3 + 0.01 * i as f64, 0.0, 0.0))
            .collect();
        let plan = WarpPlan::identity(&positions, segment);
        let robot = one_finger();
        let mut hand = HandPath::with_capacity(n, robot.dof());
        for p in &positions {
            hand.push(
                Isometry3::translation(p.x, p.y, p.z),
                &vec![0.0; robot.dof()],
            );
        }
        (positions, plan, robot, hand)
    }

    /// The hulls alone (the ball pass), without names or shapes.
    fn hulls(hulls: &[Barrier]) -> Barriers<'_> {
        Barriers {
            names: &[],
            hulls,
            shapes: &[],
        }
    }

    /// A hand moving along x at z = 0 with its finger reaching to z = -0.16, over a 10 cm box
    /// whose top is at z = -0.15, before contact: the wrist is 15 cm from the box, so the ball
    /// pass leaves it, and the fingertip would go 1 cm into it. The link pass lifts the approach
    /// until the finger keeps the clearance, fades the lift into the neighbouring frames (no
    /// step in the wrist path), and leaves the contact segment alone.
    #[test]
    fn the_link_pass_keeps_a_long_finger_out_of_a_barrier_the_wrist_ball_misses() {
        let n = 60;
        let (positions, plan, robot, hand) = sweep_along_x(n, 25, 35);
        let center = Vector3::new(-0.2, 0.0, -0.2);
        let shape = CollisionShape::new(
            crate::geometry::shape::ShapeKind::Box {
                size: Vector3::repeat(0.1),
            },
            Isometry3::from_parts(Translation3::from(center), UnitQuaternion::identity()),
        )
        .unwrap();
        let names = ["box".to_string()];
        let params = Params::default();
        let hull =
            [Barrier::from_points("box", &box_points(center, 0.05), params.radius_m).unwrap()];
        let shapes = [shape];
        let barriers = Barriers {
            names: &names,
            hulls: &hull,
            shapes: &shapes,
        };
        // Before: the finger is inside the box, the wrist far outside its inflated hull.
        let links = LinkClearance::new(&robot, &shapes, params.link_clearance_m);
        let mut poses = robot.new_link_poses();
        robot.forward_kinematics(&hand.wrists[10], hand.q(10), &mut poses);
        let (d, _, _) = links.nearest(&poses).unwrap();
        assert!((d + 0.01).abs() < 1e-6, "fingertip depth {d}");

        let (out, stats) = run(hand.clone(), &plan, &robot, barriers, &params);
        assert_eq!(stats.sweeps, 1, "the ball pass moved nothing: {stats:?}");
        assert!(
            stats.link_frames_moved > 0 && stats.narrow_gap.is_none(),
            "{stats:?}"
        );
        // 1 cm deep plus the clearance, a little more where pushes of neighbours add up.
        assert!((0.012..0.015).contains(&stats.max_push_m), "{stats:?}");
        for t in 0..n {
            robot.forward_kinematics(&out.wrists[t], out.q(t), &mut poses);
            if let Some((d, _, _)) = links.nearest(&poses) {
                assert!(d >= params.link_clearance_m - 1e-6, "frame {t}: {d}");
            }
            if (25..=35).contains(&t) {
                assert_eq!(out.wrists[t], hand.wrists[t], "contact frame {t} moved");
            }
        }
        // The push fades in and out: each sweep steps a frame by at most its push over
        // blend_frames + 1, or over the 10 frames from the box's last frame (15) to the
        // contact segment (25); two sweeps ran, so no step is above twice that share of the
        // largest push (unfaded, the wrist would step by the whole 12 mm).
        let lift: Vec<f64> = (0..n)
            .map(|t| (out.wrists[t].translation.vector - positions[t]).norm())
            .collect();
        assert_eq!(stats.link_sweeps, 2);
        let share = 2.0 * stats.max_push_m / (params.blend_frames + 1).min(10) as f64;
        for t in 1..n {
            assert!(
                (lift[t] - lift[t - 1]).abs() <= share + 1e-9,
                "frame {t}: the wrist steps {} m",
                lift[t] - lift[t - 1]
            );
        }
        // With the link pass off, the finger stays in the box.
        let off = Params {
            link_clearance_m: 0.0,
            ..params
        };
        let (_, stats) = run(hand, &plan, &robot, barriers, &off);
        assert_eq!((stats.frames_moved, stats.min_link_clearance_m), (0, None));
    }

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
    /// push-out no pre- or post-contact wrist more than `blend_frames` from the segment is
    /// inside the inflated box, the nearer ones get their share of the push, in-contact
    /// frames are untouched, and the stats count the moved frames.
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
        let robot = one_finger();
        let (out, stats) = run(hand.clone(), &plan, &robot, hulls(&barriers), &params);
        assert!(stats.narrow_gap.is_none());
        assert!(stats.frames_moved > 0, "nothing moved: {stats:?}");
        // Without the phase-in (W = 0) every frame outside contact gets its whole push.
        let whole = Params {
            blend_frames: 0,
            ..params.clone()
        };
        let (full, _) = run(hand.clone(), &plan, &robot, hulls(&barriers), &whole);
        let w = params.blend_frames + 1;
        let mut phased = 0;
        for t in 0..n {
            let p = Point3::from(out.wrists[t].translation.vector);
            if (25..=35).contains(&t) {
                assert_eq!(out.wrists[t], hand.wrists[t], "contact frame {t} moved");
                continue;
            }
            for b in &barriers {
                assert!(
                    !b.contains(&Point3::from(full.wrists[t].translation.vector), whole.mode),
                    "frame {t} still inside {} with its whole push",
                    b.name
                );
            }
            let k = if t < 25 { 25 - t } else { t - 35 };
            let share = (k as f64 / w as f64).min(1.0);
            let (got, all) = (
                out.wrists[t].translation.vector - positions[t],
                full.wrists[t].translation.vector - positions[t],
            );
            assert!(
                (got - all * share).norm() < 1e-12,
                "frame {t}: {got:?} of {all:?}"
            );
            if share == 1.0 {
                for b in &barriers {
                    assert!(
                        !b.contains(&p, params.mode),
                        "frame {t} still inside {}",
                        b.name
                    );
                }
            } else if all.norm() > 0.0 {
                phased += 1;
            }
        }
        // Both boxes reach within `W` frames of the segment: those frames got a share only.
        assert!(phased >= 2, "no frame was phased in");
        let moved_max = (0..n)
            .map(|t| (out.wrists[t].translation.vector - positions[t]).norm())
            .fold(0.0, f64::max);
        assert!((moved_max - stats.max_push_m).abs() < 1e-12);
    }

    /// A palm 4 cm wide passing between two walls 3 cm apart: out of one wall is into the
    /// other, so the link pass stops at its sweep cap and reports the frames still inside and
    /// the walls they are in, rather than working on.
    #[test]
    fn the_link_pass_reports_a_gap_too_narrow_for_the_hand() {
        let (_, plan, robot, hand) = sweep_along_x(40, 30, 35);
        let wall = |y: f64| {
            CollisionShape::new(
                crate::geometry::shape::ShapeKind::Box {
                    size: Vector3::new(0.1, 0.02, 0.4),
                },
                Isometry3::translation(-0.2, y, 0.0),
            )
            .unwrap()
        };
        let shapes = [wall(0.025), wall(-0.025)];
        let names = ["left".to_string(), "right".to_string()];
        let params = Params {
            radius_m: 0.0,
            max_sweeps: 8,
            ..Params::default()
        };
        let barriers = Barriers {
            names: &names,
            hulls: &[],
            shapes: &shapes,
        };
        let (_, stats) = run(hand, &plan, &robot, barriers, &params);
        assert_eq!(stats.link_sweeps, 8, "{stats:?}");
        let gap = stats.narrow_gap.clone().expect("a narrow gap");
        assert!(!gap.frames.is_empty(), "{gap:?}");
        assert!(gap.frames.iter().all(|t| (5..=15).contains(t)), "{gap:?}");
        // Where the sweeps left the hand it is inside one wall or the other.
        assert!(!gap.barriers.is_empty(), "{gap:?}");
        assert!(
            gap.barriers.iter().all(|b| b == "left" || b == "right"),
            "{gap:?}"
        );
        assert!(stats.min_link_clearance_m.unwrap() < 0.0, "{stats:?}");
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
        let hulls = [b];
        let barriers = Barriers {
            names: &[],
            hulls: &hulls,
            shapes: &[],
        };
        let (out, stats) = run(hand.clone(), &plan, &one_finger(), barriers, &params);
        assert_eq!(out, hand);
        assert_eq!(stats.frames_moved, 0);
    }

    /// The ball pass phases in over the same time at any frame rate: a wrist resting inside
    /// a box's inflated hull after a 0.5 s contact segment is pushed out in full, and a frame
    /// `s` seconds after the segment gets `s / 0.5 s` of that push, to within a frame's share
    /// of the blend, at 10, 30 and 120 fps. Counted in frames (15 at every rate) the share
    /// 0.3 s after the segment would be 0.19 at 10 fps, not 0.5.
    #[test]
    fn the_ball_pass_phases_in_over_the_same_seconds_at_any_frame_rate() {
        let center = Vector3::new(0.0, 0.0, -0.04);
        for fps in [10.0, 30.0, 120.0] {
            let params = Params::default().at_fps(fps);
            let end = (0.5 * fps).round() as usize;
            let n = end + 1 + (1.5 * fps).round() as usize;
            let segment = ContactSegment {
                start: 0,
                end,
                gap_frames: 0,
            };
            let positions = vec![Vector3::zeros(); n];
            let plan = WarpPlan::identity(&positions, segment);
            let robot = one_finger();
            let mut hand = HandPath::with_capacity(n, robot.dof());
            for _ in 0..n {
                hand.push(Isometry3::identity(), &vec![0.0; robot.dof()]);
            }
            let hull = [
                Barrier::from_points("box", &box_points(center, 0.05), params.radius_m).unwrap(),
            ];
            let (out, stats) = run(hand, &plan, &robot, hulls(&hull), &params);
            assert!(stats.narrow_gap.is_none(), "{stats:?}");
            let full = out.wrists[n - 1].translation.z;
            assert!(full > 0.02, "{fps} fps: pushed {full} m");
            let frame_share = 1.0 / (params.blend_frames as f64 + 1.0);
            for t in end + 1..n {
                let time = (t - end) as f64 / fps;
                let share = out.wrists[t].translation.z / full;
                let expected = (time / BLEND_S).min(1.0);
                assert!(
                    (share - expected).abs() <= frame_share + 1e-9,
                    "{fps} fps, {time:.3} s after the segment: share {share:.3}, {expected:.3} asked"
                );
            }
        }
        assert_eq!(Params::default().at_fps(30.0), Params::default());
        assert_eq!(Params::default().at_fps(10.0).blend_frames, 5);
    }
}
