//! The checks on a replay: tracking, drops, penetration, simulation displacement, release.
//!
//! - **Tracking**: per frame, `e_p = ‖p_sim − p_demo‖` and `e_R = angle(R_sim⁻¹ R_demo)`.
//! - **Drop**: the first frame of the contact segment `[c0, c1]` with `e_p` above
//!   [`Params::drop_error_m`]; the cause is [`DropCause::LostContact`] when the hand does not
//!   touch the simulated object there or within the next 0.2 s (parry distance from the
//!   hand to the simulated object above skin + tolerance), [`DropCause::Slipped`] when it
//!   keeps touching it (the object moved in the grasp).
//! - **Penetration**: parry `contact` queries at the demonstration's poses (not Rapier's
//!   cached manifolds, which recycling leaves stale, and not the simulated poses, which the
//!   solver has already pushed apart): hand link shapes against the object's convex parts,
//!   against the checked barriers and against the supports, and object parts against the
//!   barriers. An AABB test skips far pairs. Per frame the deepest pair counts.
//! - **Simulation displacement** (ObMan, GraspTTA): at sampled in-contact frames, a fresh
//!   world with the hand frozen at that frame, the object at the demonstration's pose,
//!   gravity and no support or barrier; the object's displacement after
//!   [`Params::stability_steps`] steps of [`Params::stability_dt_s`]. In `validate`, frames
//!   where the demonstration's object rests on a support (within [`Params::support_gap_m`])
//!   are not sampled: there the support holds it, and a hand that has only begun to close
//!   (a recording's first touch) is not asked to. A contact segment spent entirely on a
//!   support (a push) has no sampled frame.
//! - **Release**: after the last contact frame, the object must end within
//!   [`Params::support_gap_m`] of a support and move less than [`Params::rest_motion_m`] over
//!   the last [`Params::rest_window_s`], counted from the first frame the hand no longer
//!   touches it (a take that ends half a second after the fingers open still shows the
//!   object settling out of them, which is the hand's doing, not a failure to rest). When the object's largest position error comes
//!   after the release and the hand touched it in between, the position error's reason says
//!   the hand pushed the released object ([`find_push`]): the carry held, the retreat did not
//!   clear the object. The object's largest turn after the release is reported with the
//!   hand's links when the hand still touches it once it has turned 5° ([`find_turn`]); a
//!   diagnostic with no limit (a round object rolls off the opening fingers).

use nalgebra::{Isometry3, Vector3};
use rapier3d_f64::parry::bounding_volume::{Aabb, BoundingVolume};
use rapier3d_f64::parry::math::Pose;
use rapier3d_f64::parry::query;
use rapier3d_f64::parry::shape::Shape;

use super::params::Params;
use super::report::{Drop, DropCause, Grip, Penetration, Pushed, Stability, Touch, Tracking, Turn};
use super::world::{GripSample, ReplayWorld};
use crate::geometry::hull::ObjectShape;
use crate::geometry::shape::CollisionShape;
use crate::math::convert::to_pose;
use crate::math::quantile::quantile_sorted;
use crate::math::rotation::angle_between;
use crate::model::{ContactSegment, Demo};
use crate::robot::Robot;

/// Per-frame position [m] and rotation [rad] errors of the simulated object.
pub fn tracking_errors(
    demo: &Demo,
    simulated: &[Isometry3<f64>],
) -> (Vec<f64>, Vec<f64>, Tracking) {
    let mut pos = Vec::with_capacity(simulated.len());
    let mut rot = Vec::with_capacity(simulated.len());
    for (f, s) in demo.frames.iter().zip(simulated) {
        pos.push((s.translation.vector - f.object.translation.vector).norm());
        rot.push(angle_between(&s.rotation, &f.object.rotation));
    }
    let n = pos.len().max(1) as f64;
    let (pf, pm) = argmax(&pos);
    let (rf, rm) = argmax(&rot);
    let tracking = Tracking {
        mean_position_error_mm: pos.iter().sum::<f64>() / n * 1e3,
        max_position_error_mm: pm * 1e3,
        max_position_error_frame: pf,
        mean_rotation_error_deg: rot.iter().sum::<f64>() / n * 180.0 / std::f64::consts::PI,
        max_rotation_error_deg: rm.to_degrees(),
        max_rotation_error_frame: rf,
    };
    (pos, rot, tracking)
}

/// The index and value of the first largest of the non-negative values `v`; `(0, 0.0)` when
/// `v` is empty.
fn argmax(v: &[f64]) -> (usize, f64) {
    v.iter()
        .enumerate()
        .fold((0, 0.0f64), |b, (i, &x)| if x > b.1 { (i, x) } else { b })
}

/// The first drop inside `segment` (see the module docs). `window` is how many frames after
/// the drop frame are searched for the moment the hand lets go: an object that slides out
/// between opening fingers still grazes them for a few frames when its error passes the
/// limit.
pub fn find_drop(
    segment: ContactSegment,
    position_error: &[f64],
    touching: &[bool],
    window: usize,
    params: &Params,
) -> Option<Drop> {
    let last = position_error.len().saturating_sub(1);
    let end = segment.end.min(last);
    let frame = (segment.start..=end).find(|&f| position_error[f] > params.drop_error_m)?;
    let lost = if touching[frame] {
        (frame..=(frame + window).min(last)).find(|&f| !touching[f])
    } else {
        let mut first = frame;
        while first > segment.start && !touching[first - 1] {
            first -= 1;
        }
        Some(first)
    };
    Some(Drop {
        frame,
        cause: if lost.is_some() {
            DropCause::LostContact
        } else {
            DropCause::Slipped
        },
        position_error_mm: position_error[frame] * 1e3,
        contact_lost_frame: lost,
        touching_links: Vec::new(),
    })
}

/// How far [m] the released object must have moved off its plan (its position error grown
/// since the release) at a frame where the hand touches it for the hand to count as pushing
/// it: fingers still brushing it as they open, before it moves, do not count.
pub const PUSHED_WHILE_TOUCHED_M: f64 = 0.01;

/// The hand pushing the object after the release ([`Pushed`]): the largest position error
/// after the last contact frame `released`, when it is above [`Params::max_position_error_m`]
/// and more than [`Params::drop_error_m`] above the error at `released`, and the hand touches
/// the object at a frame up to it where the error has grown by [`PUSHED_WHILE_TOUCHED_M`].
pub fn find_push(
    released: usize,
    position_error: &[f64],
    touching: &[bool],
    params: &Params,
) -> Option<Pushed> {
    let at_release = *position_error.get(released)?;
    let (after, error) = argmax(&position_error[released + 1..]);
    let frame = released + 1 + after;
    if error <= params.max_position_error_m || error - at_release <= params.drop_error_m {
        return None;
    }
    let last_touch_frame = (released + 1..=frame)
        .rev()
        .find(|&f| touching[f] && position_error[f] - at_release >= PUSHED_WHILE_TOUCHED_M)?;
    Some(Pushed {
        frame,
        position_error_mm: error * 1e3,
        release_error_mm: at_release * 1e3,
        last_touch_frame,
        touching_links: Vec::new(),
    })
}

/// The hand is taken to turn the released object when it still touches it once the object
/// has turned this far from its pose at the last contact frame [rad] (5°; see [`find_turn`]).
pub const TURNED_WHILE_TOUCHED_RAD: f64 = 5.0 * std::f64::consts::PI / 180.0;

/// The object's largest turn after the last contact frame `released` ([`Turn`]), from its
/// rotation there (`object`: its simulated poses), with the last frame up to it at which the
/// hand touches the object once it has turned [`TURNED_WHILE_TOUCHED_RAD`]: the hand turned
/// it (`by_hand` is `None` when it turned by itself, as a round object rolls a little as it
/// settles; its links are left for the caller). The turn's frame is `released` when it never
/// turns.
pub fn find_turn(released: usize, object: &[Isometry3<f64>], touching: &[bool]) -> Turn {
    let Some(at_release) = object.get(released) else {
        return Turn {
            frame: released,
            ..Turn::default()
        };
    };
    let turns: Vec<f64> = object[released + 1..]
        .iter()
        .map(|p| angle_between(&p.rotation, &at_release.rotation))
        .collect();
    let (k, turn) = argmax(&turns);
    let frame = if turn > 0.0 {
        released + 1 + k
    } else {
        released
    };
    let by_hand = (released + 1..=frame)
        .rev()
        .find(|&f| {
            touching.get(f).copied().unwrap_or(false)
                && turns[f - released - 1] >= TURNED_WHILE_TOUCHED_RAD
        })
        .map(|frame| Touch {
            frame,
            links: Vec::new(),
        });
    Turn {
        deg: turn.to_degrees(),
        frame,
        by_hand,
    }
}

/// A shape placed in the world for a parry query; `owner` indexes a name list.
#[derive(Clone, Copy)]
pub struct Placed<'a> {
    pub shape: &'a dyn Shape,
    pub pose: Pose,
    pub aabb: Aabb,
    pub owner: usize,
}

impl<'a> Placed<'a> {
    pub fn new(shape: &'a dyn Shape, pose: Pose, owner: usize) -> Self {
        Placed {
            shape,
            pose,
            aabb: shape.compute_aabb(&pose),
            owner,
        }
    }
}

/// The deepest penetration [m] between any shape of `a` and any of `b`, with the owners;
/// `None` when nothing penetrates. Pairs parry cannot query add to `unsupported`.
pub fn deepest(
    a: &[Placed<'_>],
    b: &[Placed<'_>],
    unsupported: &mut usize,
) -> Option<(f64, usize, usize)> {
    let mut best: Option<(f64, usize, usize)> = None;
    for x in a {
        for y in b {
            if !x.aabb.intersects(&y.aabb) {
                continue;
            }
            match query::contact(&x.pose, x.shape, &y.pose, y.shape, 0.0) {
                Ok(Some(c)) if c.dist < 0.0 => {
                    let depth = -c.dist;
                    if best.is_none_or(|b| depth > b.0) {
                        best = Some((depth, x.owner, y.owner));
                    }
                }
                Ok(_) => {}
                Err(_) => *unsupported += 1,
            }
        }
    }
    best
}

/// The deepest hand-object penetration at one frame: `(depth [m], link index, 0)`, from the
/// hand's penetration probes ([`crate::robot::probes`]) in the object's signed distance
/// field ([`crate::geometry::sdf`], exact for unions of overlapping parts, measured against
/// the mesh rather than its convex parts). The IK keeps the same probes out of the same
/// field, so the two agree on what "inside" means.
pub fn hand_object_depth(
    robot: &Robot,
    link_poses: &[Isometry3<f64>],
    object_pose: &Isometry3<f64>,
    sdf: &crate::geometry::ObjectSdf,
) -> Option<(f64, usize, usize)> {
    crate::robot::probes::deepest(robot, link_poses, &object_pose.inverse(), sdf)
        .map(|(d, l)| (d, l.index(), 0))
}

/// Accumulates per-frame deepest penetrations into a [`Penetration`].
#[derive(Debug, Default)]
pub struct PenetrationAcc {
    pub out: Penetration,
    sum: f64,
}

impl PenetrationAcc {
    pub fn new(limit_m: Option<f64>) -> Self {
        PenetrationAcc {
            out: Penetration {
                limit_mm: limit_m.map(|l| l * 1e3),
                ..Penetration::default()
            },
            sum: 0.0,
        }
    }

    /// Records frame `frame`'s deepest penetration; returns its depth [m] (0 if none).
    pub fn add(
        &mut self,
        frame: usize,
        hit: Option<(f64, usize, usize)>,
        names_a: &[String],
        names_b: &[String],
    ) -> f64 {
        let Some((depth, a, b)) = hit else {
            return 0.0;
        };
        let mm = depth * 1e3;
        self.out.frames_penetrating += 1;
        self.sum += mm;
        if self.out.limit_mm.is_some_and(|l| mm > l) {
            self.out.frames_over_limit += 1;
        }
        if mm > self.out.max_mm {
            self.out.max_mm = mm;
            self.out.worst_frame = Some(frame);
            self.out.worst_pair = Some(format!("{} / {}", names_a[a], names_b[b]));
        }
        depth
    }

    pub fn finish(mut self, unsupported: usize) -> Penetration {
        if self.out.frames_penetrating > 0 {
            self.out.mean_mm = self.sum / self.out.frames_penetrating as f64;
        }
        self.out.unsupported_pairs = unsupported;
        self.out
    }
}

/// Fills `out` with the hand's shapes placed at `link_poses`, owners = link indices.
pub fn place_hand<'a>(
    shapes: &[(usize, &'a CollisionShape)],
    link_poses: &[Isometry3<f64>],
    out: &mut Vec<Placed<'a>>,
) {
    out.clear();
    for &(link, cs) in shapes {
        let pose = to_pose(&(link_poses[link] * cs.shape_pose));
        out.push(Placed::new(cs.shape.as_ref(), pose, link));
    }
}

/// Fills `out` with the object's convex parts at `pose`, owner 0.
pub fn place_object<'a>(object: &'a ObjectShape, pose: &Isometry3<f64>, out: &mut Vec<Placed<'a>>) {
    out.clear();
    let pose = to_pose(pose);
    for part in &object.parts {
        out.push(Placed::new(part.as_ref(), pose, 0));
    }
}

/// `true` when some placed hand shape is within `reach` [m] of the object at `pose`
/// (parry distance, AABB pre-test).
pub fn hand_touches(
    hand: &[Placed<'_>],
    object: &ObjectShape,
    pose: &Isometry3<f64>,
    reach: f64,
) -> bool {
    let pose = to_pose(pose);
    let aabb = object.compound.compute_aabb(&pose).loosened(reach);
    hand.iter()
        .any(|h| shape_within(h, object, &pose, &aabb, reach))
}

/// The owners (link indices, with [`place_hand`]) of the placed hand shapes within `reach`
/// [m] of the object at `pose`, each once, in increasing order.
pub fn touching_links(
    hand: &[Placed<'_>],
    object: &ObjectShape,
    pose: &Isometry3<f64>,
    reach: f64,
) -> Vec<usize> {
    let pose = to_pose(pose);
    let aabb = object.compound.compute_aabb(&pose).loosened(reach);
    let mut links: Vec<usize> = hand
        .iter()
        .filter(|h| shape_within(h, object, &pose, &aabb, reach))
        .map(|h| h.owner)
        .collect();
    links.sort_unstable();
    links.dedup();
    links
}

fn shape_within(
    h: &Placed<'_>,
    object: &ObjectShape,
    pose: &Pose,
    aabb: &Aabb,
    reach: f64,
) -> bool {
    h.aabb.intersects(aabb)
        && query::distance(&h.pose, h.shape, pose, object.compound.as_ref())
            .is_ok_and(|d| d.distance <= reach)
}

/// Simulation displacement [m] at one frame (see the module docs).
pub fn sim_displacement(
    robot: &Robot,
    link_poses: &[Isometry3<f64>],
    object: &ObjectShape,
    object_pose: &Isometry3<f64>,
    mass: f64,
    params: &Params,
) -> f64 {
    let mut world = ReplayWorld::new(
        robot,
        link_poses,
        object,
        object_pose,
        mass,
        &[],
        params,
        params.stability_dt_s,
        Vector3::from(params.gravity),
    );
    for _ in 0..params.stability_steps {
        world.drive_hand(link_poses, &[]);
        world.step();
    }
    let end = world.object_pose().translation.vector;
    let d = (end - object_pose.translation.vector).norm();
    if d.is_finite() { d } else { f64::INFINITY }
}

/// The in-contact frames to test for stability: `samples` frames evenly spread over the
/// segment's frames that `eligible` accepts, both ends included, without repeats.
pub fn stability_frames(
    segment: ContactSegment,
    samples: usize,
    eligible: impl Fn(usize) -> bool,
) -> Vec<usize> {
    let pool: Vec<usize> = (segment.start..=segment.end)
        .filter(|&f| eligible(f))
        .collect();
    let Some(last) = pool.len().checked_sub(1) else {
        return Vec::new();
    };
    let mut frames: Vec<usize> = match samples {
        0 => Vec::new(),
        1 => vec![pool[last / 2]],
        k => (0..k)
            .map(|i| pool[(i * last + (k - 1) / 2) / (k - 1)])
            .collect(),
    };
    frames.dedup();
    frames
}

/// Collects stability results into a [`Stability`].
pub fn stability_stats(frames: Vec<usize>, displacement_m: &[f64], params: &Params) -> Stability {
    let mm: Vec<f64> = displacement_m.iter().map(|d| d * 1e3).collect();
    let (max_frame, max_mm) = frames.iter().zip(&mm).fold((None, 0.0f64), |b, (&f, &d)| {
        if d > b.1 || b.0.is_none() {
            (Some(f), d)
        } else {
            b
        }
    });
    Stability {
        mean_mm: if mm.is_empty() {
            0.0
        } else {
            mm.iter().sum::<f64>() / mm.len() as f64
        },
        max_mm,
        max_frame,
        frames,
        displacement_mm: mm,
        steps: params.stability_steps,
        dt_s: params.stability_dt_s,
    }
}

/// The nearest support to the object at `pose` and its distance [m] (0 when touching or
/// penetrating); `None` without supports.
pub fn nearest_support(
    object: &ObjectShape,
    pose: &Isometry3<f64>,
    supports: &[(String, &CollisionShape)],
) -> Option<(String, f64)> {
    let pose = to_pose(pose);
    let mut best: Option<(String, f64)> = None;
    for (name, cs) in supports {
        let sp = to_pose(&cs.shape_pose);
        let d = query::distance(&pose, object.compound.as_ref(), &sp, cs.shape.as_ref())
            .map_or(f64::INFINITY, |d| d.distance);
        if best.as_ref().is_none_or(|b| d < b.1) {
            best = Some((name.clone(), d));
        }
    }
    best
}

/// Whether the object at `pose` rests on a support: within `gap` [m] of one. A bounding-box
/// test first, so a carried object costs no distance query.
pub fn on_support(
    object: &ObjectShape,
    pose: &Isometry3<f64>,
    supports: &[(String, CollisionShape)],
    gap: f64,
) -> bool {
    let pose = to_pose(pose);
    let aabb = object.compound.compute_aabb(&pose).loosened(gap);
    supports.iter().any(|(_, cs)| {
        let sp = to_pose(&cs.shape_pose);
        aabb.intersects(&cs.shape.compute_aabb(&sp))
            && query::distance(&pose, object.compound.as_ref(), &sp, cs.shape.as_ref())
                .is_ok_and(|d| d.distance <= gap)
    })
}

/// The grip over the contact segment's samples `segment` (one per frame), for an object of
/// weight `weight_n` [N].
pub fn grip(segment: &[GripSample], weight_n: f64) -> Grip {
    let mut forces: Vec<f64> = segment
        .iter()
        .map(|g| g.normal_n)
        .filter(|&f| f > 0.0)
        .collect();
    forces.sort_by(f64::total_cmp);
    let total: f64 = forces.iter().sum();
    let share = |part: f64| if total > 0.0 { part / total } else { 0.0 };
    Grip {
        frames: segment.len(),
        frames_pressing: forces.len(),
        median_normal_force_n: quantile_sorted(&forces, 0.5).unwrap_or(0.0),
        max_normal_force_n: forces.last().copied().unwrap_or(0.0),
        weight_n,
        at_overlap_share: share(segment.iter().map(|g| g.at_overlap_n).sum()),
        from_overlap_share: share(segment.iter().map(|g| g.from_overlap_n).sum()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Errors [m] of a replay released at frame 4 on its plan (5 mm off), then the hand
    /// touching it at frames 5-6 and the error growing to `end` by frame 8.
    fn pushed_replay(end: f64) -> (Vec<f64>, Vec<bool>) {
        let err = vec![0.0, 0.005, 0.005, 0.005, 0.005, 0.01, 0.03, end * 0.8, end];
        let touching = vec![false, true, true, true, true, true, true, false, false];
        (err, touching)
    }

    #[test]
    fn a_push_after_the_release_is_found_with_its_frames() {
        let params = Params::default();
        let (err, touching) = pushed_replay(0.12);
        let p = find_push(4, &err, &touching, &params).expect("pushed 115 mm while touched");
        assert_eq!((p.frame, p.last_touch_frame), (8, 6));
        assert!((p.position_error_mm - 120.0).abs() < 1e-9);
        assert!((p.release_error_mm - 5.0).abs() < 1e-9);
    }

    #[test]
    fn no_push_without_a_touch_or_below_the_limits() {
        let params = Params::default();
        // Within the position limit (50 mm).
        let (err, touching) = pushed_replay(0.045);
        assert_eq!(find_push(4, &err, &touching, &params), None);
        // The hand never touches it after the release: it moved by itself.
        let (err, mut touching) = pushed_replay(0.12);
        touching[5..].iter_mut().for_each(|t| *t = false);
        assert_eq!(find_push(4, &err, &touching, &params), None);
        // The fingers brush it as they open (5 mm moved), then it moves by itself.
        touching[5] = true;
        assert_eq!(find_push(4, &err, &touching, &params), None);
        // Already off its plan at the release, and it grew by less than the drop limit
        // (30 mm): the push is not what broke the limit.
        let (mut err, touching) = pushed_replay(0.12);
        err[4] = 0.1;
        assert_eq!(find_push(4, &err, &touching, &params), None);
        // Released at the last frame: nothing after it.
        assert_eq!(find_push(8, &err, &touching, &params), None);
    }

    /// Released at frame 2, the object turns 4° a frame about the vertical to 24° at frame
    /// 8, then settles back to 20°.
    fn turned_replay() -> Vec<Isometry3<f64>> {
        let deg = [0.0, 0.0, 0.0, 4.0, 8.0, 12.0, 16.0, 20.0, 24.0, 20.0];
        deg.iter()
            .map(|d: &f64| {
                let r =
                    nalgebra::UnitQuaternion::from_axis_angle(&Vector3::z_axis(), d.to_radians());
                Isometry3::from_parts(Vector3::new(0.0, 0.0, 1.0).into(), r)
            })
            .collect()
    }

    #[test]
    fn a_turn_after_the_release_is_found_with_the_hand_that_turned_it() {
        let rotations = turned_replay();
        let found = |released: usize, rotations: &[Isometry3<f64>], touching: &[bool]| {
            let t = find_turn(released, rotations, touching);
            (t.deg, t.frame, t.by_hand.map(|b| b.frame))
        };
        // The hand touches it through frame 6 (16° turned): the hand turned it.
        let touching = [
            true, true, true, true, true, true, true, false, false, false,
        ];
        let (a, f, t) = found(2, &rotations, &touching);
        assert!((a - 24.0).abs() < 1e-9, "{a}");
        assert_eq!((f, t), (8, Some(6)));
        // Only the fingers brushing it as they open (4° turned, under 5°): it turned by itself.
        let touching = [
            true, true, true, true, false, false, false, false, false, false,
        ];
        assert_eq!(found(2, &rotations, &touching).2, None);
        // Touched only after its largest turn: not the hand's turn.
        let mut touching = [false; 10];
        touching[9] = true;
        assert_eq!(found(2, &rotations, &touching).2, None);
        // Never turning, or released at the last frame: no turn.
        let still = vec![Isometry3::identity(); 10];
        assert_eq!(found(2, &still, &[true; 10]), (0.0, 2, None));
        assert_eq!(found(9, &rotations, &[true; 10]), (0.0, 9, None));
    }
}
