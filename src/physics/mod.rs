//! Stage 6: physics validation of a trajectory in Rapier (docs/METHOD.md, "Physics validation").
//!
//! [`validate`] replays one demonstration, warped or original, and judges it:
//! 1. **object shape**: convex decomposition of the object mesh, cached per process and on
//!    disk (`DEXWARP_CACHE_DIR`, see [`crate::geometry::hull::cache_dir`]);
//! 2. **world**: every hand link a kinematic position-based body, the object a dynamic body
//!    with the demonstration's mass at its frame-0 pose (resting on its support), supports
//!    and the checked barriers fixed ([`world`]);
//! 3. **replay**: the hand driven along the trajectory at steps of at most 1/240 s, wrist
//!    slerped and joints lerped between frames, then forward kinematics; the object's pose
//!    recorded at every frame (`replay.rs`); spans where the object rests out of the hand's
//!    reach are left unstepped, and the replay stops once a drop is decided
//!    ([`Params::skip_rest`], [`Params::stop_after_drop`]);
//! 4. **checks** (`checks.rs`): tracking error of the simulated object against the
//!    demonstration's, drops inside the contact segment (frame and cause), penetration
//!    depths (hand-object, hand-barrier, object-barrier, hand-support) by parry queries at
//!    the demonstration's poses, simulation displacement at sampled in-contact frames
//!    (ObMan/GraspTTA: hand frozen, gravity, no support, 35 steps of 1/240 s), and where
//!    the object ends after the release;
//! 5. **verdict**: every failed check as a sentence (`verdict.rs`), in a [`PhysicsReport`]
//!    that converts to the report's `PhysicsSummary`;
//! 6. **ensemble** ([`ensemble`]): with [`Params::ensemble`] asking for more than one
//!    member (8 by default, up to 32 while the decision is uncertain), steps 3-5 again under
//!    seeded perturbations, and the verdict becomes the decision on their pass fraction.
//!    With the kinematic hand the perturbed members of a batch share one world ([`world::ReplayWorld::shared`]), where the solver
//!    packs their contacts into SIMD lanes one member's contacts never fill (what it saves:
//!    docs/RESULTS.md, "Physics speed judged by pass fractions"). Everything below measures single replays
//!    (member 0, or `ensemble.members = 1`); the single verdicts it calls "at the edge" are
//!    what the ensemble reports as `uncertain`.
//!
//! # Finger softness: why a contact skin
//!
//! Rapier has no compliant fingers. A kinematic body pushes a dynamic one only by the
//! contact solver resolving their overlap, so a grasp holds by friction only while the
//! fingers overlap the object, and the grip force grows with the overlap (it is the soft
//! constraint's spring: Rapier's contact softness, 30 Hz, ζ = 10). Demonstrations place
//! fingertips *on* the surface, within a few millimetres either way; with rigid colliders a
//! fingertip 1 mm off the surface grips nothing and one 0.5 mm in grips too weakly to lift.
//!
//! The model: every hand collider gets a Rapier **contact skin** of
//! [`Params::finger_skin_m`] (3 mm). The solver then treats the hand as inflated by the
//! skin (it solves for `dist − skin`), like a pad that starts pressing 3 mm before the rigid
//! surfaces meet, while the geometry, the penetration checks and the touch test keep the
//! URDF shapes. A fingertip at the surface ±2 mm "compresses" its pad by 1-5 mm and holds.
//! Why this and not the alternatives: inflating the shapes themselves would do the same
//! for the solver but would also change what the penetration checks measure; softening
//! Rapier's global contact parameters would also soften the object-support contacts.
//!
//! Measured (f64, 1/240 s, 4 solver iterations, μ = 1, tests in `tests/it/physics.rs`):
//! - two kinematic plates squeezing a 6 cm, 0.2 kg cube, plates at −2, −1, 0, +1, +2 mm
//!   from its faces, lift it 20 cm with 0.015-0.016 mm error; without the skin, plates at
//!   0 mm leave it behind (200 mm error);
//! - the gripper pick and place (1 mm jaw overlap) tracks the box within 1.7 mm (mean
//!   1.0 mm, 2.9° largest tilt while the jaws close), simulation displacement 0.05 mm;
//! - the human-hand demonstrations in `scenes/demos` (fingertips 0.7 mm inside to 0.3 mm
//!   off the surface) all pass, with mean tracking errors of 1.7 (mug) to 9.7 mm (teapot).
//!   The teapot (0.6 kg pinched by three fingertips on its handle) is the closest to the
//!   edge: a capsule tip on a face is a one-point contact and Rapier's twist friction needs
//!   two points per manifold, so little resists the torque about the pinch axis. A real
//!   fingertip's contact patch has torsional friction. Two ways to model it were looked at:
//!   extra solver contacts from a contact modification hook do not work in Rapier 0.36
//!   (the solver takes each contact's lever arm from the manifold point it names, so added
//!   contacts sit on the original point); an angular impulse before each step, capped at a
//!   5 mm pad's `(2/3)·μ·a·N` per hand-object manifold, held the mug better (mean rotation
//!   error 1.84° → 0.72°) but the teapot original of then failed with it: after the release
//!   the retreating hand hooked the pot and dragged it 166 mm. Not adopted.
//!
//! # Grip: how much comes from the overlap, how much from the skin
//!
//! Every report has `physics.grip` ([`Grip`]): the hand's normal force on the object at the
//! frame times of the contact segment ([`world::ReplayWorld::grip`], Rapier's contact
//! impulses over the step), and two shares of it: the force at contact points where the
//! rigid shapes overlap, and the part the overlap accounts for when each point's force is
//! split in proportion to its compression, overlap against skin. The test
//! `physics::the_grip_force_splits_into_the_skin_and_the_overlap` checks the split and the
//! scale on the plates: N ≥ m·g/μ whenever the cube is held, the force grows with the
//! overlap, plates 2 mm off grip through the skin alone, plates 2 mm in owe 40 % of it to
//! the overlap (2 / (2 + 3)).
//!
//! The skin carries most of every grip, and a kinematic hand squeezes with tens of times the
//! object's weight: a position-driven body pushes as hard as the solver needs to undo the
//! compression, with no force limit. A kinematic verdict therefore says that the trajectory
//! carries the object under a squeeze no hand applies; whether actuators with the URDF's
//! effort limits would hold it is what the actuated hand below answers. The same squeeze
//! moves the object as the hand closes on it, wherever little stands opposite a contact:
//! every report has `physics.onset` ([`Onset`]), the object's error at the contact
//! segment's first frame. The forces and onsets measured on the demonstrations and configs:
//! docs/RESULTS.md, "Physics: grip and onset".
//!
//! # The actuated hand (an option)
//!
//! [`Params::hand`] = [`HandModel::Actuated`] (`--physics-hand actuated`) replaces the
//! kinematic hand with an articulated one driven by its actuators (`actuated.rs`): dynamic
//! links with the URDF masses, the URDF's joints and limits as one Rapier multibody, a
//! position motor per movable joint capped at the URDF effort, the root link on a stiff
//! spring-damper to the trajectory ([`Actuation`]). The kinematic hand answers "does the
//! trajectory carry the object?"; the actuated one "would a position-controlled hand with
//! these actuators hold it?". Fingers can no longer sink into the object: they stop at its
//! surface (plus the skin) and press with the motor torque their tracking error gives, up
//! to the effort limit. Penetration, tracking and drop checks are unchanged (the
//! penetration checks still measure the trajectory's own poses); the stability test keeps
//! the hand frozen. The default stays kinematic: the product's contract says so.
//!
//! # Where the time goes
//!
//! The contact solver is about half of a replay (Rapier's twist-friction contact
//! constraints), the narrow phase about a sixth (GJK/EPA and support points of the hand's
//! capsules against the object's convex parts), our own per-step work (interpolation,
//! forward kinematics) under 1 %. Solver work grows with the hand-object manifolds, and
//! Rapier 0.36 solves contacts in SIMD chunks of four manifolds whose bodies must differ:
//! every hand-object manifold shares the one dynamic object, so each lands in a chunk of its
//! own and three of its four lanes are padding. What we do about it: the x86-64-v3 build
//! (one 256-bit operation per 4-lane f64 operation, the same roundings), the object's mass
//! properties computed once per object, the ensemble's perturbed members in shared worlds
//! (whose contacts fill each other's lanes), and the shortcuts below. Every cheaper solver
//! setting tried (fewer substeps, longer steps, a shorter prediction distance, the solver
//! cut of [`Params::solver_contact_gap_m`]) moved verdicts or pass fractions more than a
//! second ensemble seed does, so none is the default. The profiles, timings and comparisons:
//! docs/RESULTS.md, "Physics: where the time goes" and "Physics speed judged by pass
//! fractions"; `cargo run --release --example physics_profile` and `cargo bench --bench
//! physics` measure them again.
//!
//! # Simulating less
//!
//! What the replay leaves out by default ([`Params::skip_rest`], [`Params::stop_after_drop`],
//! `replay.rs`): the spans after the release where the object rests with no hand link within
//! reach, the rocking of an untouched object that has not settled after 1 s, everything
//! after a decided drop, and in the ensemble's perturbed members everything after a decided
//! tracking failure (the mean error of the whole trajectory past its limit whatever follows).
//! The regression test replays its trajectories both ways: every
//! verdict, first reason and drop frame is the same, and where nothing is left out the
//! per-frame figures are the same to the bit. A replay near the edge of holding is chaotic
//! (the last-bit differences of a quaternion renormalization can turn a pass into a slip);
//! [`margin`] replays a passing trajectory under lower friction and higher mass to say how
//! close to the edge it is, and the ensemble says it per trajectory.
//!
//! Contact recycling is off ([`Params::contact_recycling`], see [`world`]): stale recycled
//! contacts let open gripper jaws sliding 10 mm beside a box push it 21 mm.
//!
//! Determinism: bodies and colliders are inserted in a fixed order, nothing iterates a
//! `HashMap` into a result, and Rapier runs single-threaded, so the same input gives the
//! same report, wall times and `replay.decomposition_cached` aside.

mod actuated;
mod checks;
pub mod ensemble;
pub mod margin;
pub mod params;
mod replay;
pub use replay::{IDLE_SPEED_M_S, StepProfile, StepTimes};
pub mod report;
mod verdict;
pub mod world;

use std::sync::Arc;
use std::time::Instant;

use nalgebra::Vector3;
use rayon::prelude::*;

pub use crate::geometry::hull::{
    DecompositionParams, ObjectCollider, ObjectShape, ShapeMethod, object_shape,
};
pub use ensemble::{Decision, Ensemble, EnsembleParams};
pub use margin::{Margin, margin};
pub use params::{Actuation, HandModel, Params};
pub use report::{
    Carry, Drop, DropCause, GraspHold, Grip, Onset, Penetration, Penetrations, PerFrame,
    PhysicsReport, Pushed, Release, ReplayInfo, Stability, Timing, Touch, Tracking, Turn,
};

use crate::geometry::Mesh;
use crate::geometry::shape::CollisionShape;
use crate::model::{ContactSegment, Demo, Role, Scene};
use crate::robot::{LinkId, Robot};
use crate::{Error, Limits, Result};
use checks::{PenetrationAcc, Placed};
use world::{FixedItem, ReplayWorld, Tag};

/// Replays `demo` with `robot` in `scene` and judges it (see the module docs).
///
/// - `demo` must be bound to `robot` ([`Demo::check_robot`]): joints in robot order;
/// - `barriers`: names of the scene's items the hand and object are checked against (and
///   that block the object); supports are always in the world;
/// - `object_mesh`: the demonstration's object mesh, object frame;
/// - `limits`: for loading the scene's mesh items.
///
/// Fails only on unusable input (unknown barrier, unbound demo, bad parameters, degenerate
/// mesh); every physical failure is a reason in the returned report.
pub fn validate(
    robot: &Robot,
    demo: &Demo,
    scene: &Scene,
    barriers: &[String],
    object_mesh: &Mesh,
    params: &Params,
    limits: &Limits,
) -> Result<PhysicsReport> {
    let start = Instant::now();
    params.check()?;
    check_demo(robot, demo)?;
    let mut report = validate_one(
        robot,
        demo,
        scene,
        barriers,
        object_mesh,
        params,
        limits,
        None,
    )?;
    if params.ensemble.members > 1 {
        let clock = Instant::now();
        let e = run_ensemble(
            &report,
            robot,
            demo,
            scene,
            barriers,
            object_mesh,
            params,
            limits,
        )?;
        report.reasons = match e.decision {
            Decision::Keep => Vec::new(),
            Decision::Drop if e.nominal_reasons.is_empty() => vec![e.drop_sentence()],
            Decision::Drop => e.nominal_reasons.clone(),
        };
        report.ensemble = Some(e);
        report.timing_s.ensemble = clock.elapsed().as_secs_f64();
    }
    report.timing_s.total = start.elapsed().as_secs_f64();
    Ok(report)
}

/// What a perturbed member of the ensemble replays differently from the nominal replay.
struct MemberSetup<'a> {
    /// The object's pose at the start of the replay.
    object_start: nalgebra::Isometry3<f64>,
    /// The nominal replay's penetration checks, which measure the trajectory as written.
    penetration: &'a PenetrationRun,
}

/// One replay of `demo` and its report (the margin too when asked, for the nominal replay):
/// [`validate`] without the ensemble. With `member`, the object starts at its pose and the
/// penetration checks are the nominal's.
fn validate_one(
    robot: &Robot,
    demo: &Demo,
    scene: &Scene,
    barriers: &[String],
    object_mesh: &Mesh,
    params: &Params,
    limits: &Limits,
    member: Option<&MemberSetup<'_>>,
) -> Result<PhysicsReport> {
    let start = Instant::now();

    // 1. Object shape.
    let (object, cached, sdf) = object_shapes(demo, object_mesh, params)?;
    let decomposition_s = start.elapsed().as_secs_f64();

    // 2. Scene: supports and the checked barriers, in scene order.
    let (supports, solid) = scene_items(scene, barriers, limits)?;

    // 3. Replay, and 4a. the penetration checks at the demonstration's poses, which do not
    // depend on the replay: the two run side by side.
    let barrier_names: Vec<String> = solid.iter().map(|(n, _)| n.clone()).collect();
    let support_names: Vec<String> = supports.iter().map(|(n, _)| n.clone()).collect();
    let object_start = member.map(|m| &m.object_start);
    let (replay, (pen, penetration_s)) = rayon::join(
        || {
            run_replay(
                robot,
                demo,
                &object,
                &supports,
                &solid,
                params,
                object_start,
            )
        },
        || {
            if let Some(m) = member {
                return (m.penetration.clone(), 0.0);
            }
            let t_pen = Instant::now();
            let pen = penetrations(
                robot,
                demo,
                &object,
                &sdf,
                &solid,
                &supports,
                &barrier_names,
                &support_names,
                params,
            );
            (pen, t_pen.elapsed().as_secs_f64())
        },
    );
    let (trace, replay_s) = replay?;

    // 4b. Checks on the replay.
    let checked = check_replay(robot, demo, &object, &supports, &trace, params);

    // 5. Verdict.
    let timing = Timing {
        decomposition: decomposition_s,
        replay: replay_s,
        penetration: penetration_s,
        stability: checked.stability_s,
        margin: 0.0,
        ensemble: 0.0,
        total: 0.0,
    };
    let mut report = judge(demo, &object, cached, &trace, pen, checked, timing, params);
    if params.margin && member.is_none() {
        add_margin(
            &mut report,
            robot,
            demo,
            scene,
            barriers,
            object_mesh,
            params,
            limits,
        )?;
    }
    report.timing_s.total = start.elapsed().as_secs_f64();
    Ok(report)
}

/// The ensemble of `demo` given its nominal replay's `report` ([`ensemble`]): the perturbed
/// members replayed in member order, a batch at a time (members 1 to K − 2, then the last),
/// until all are replayed or the early stop holds.
fn run_ensemble(
    nominal: &PhysicsReport,
    robot: &Robot,
    demo: &Demo,
    scene: &Scene,
    barriers: &[String],
    object_mesh: &Mesh,
    params: &Params,
    limits: &Limits,
) -> Result<Ensemble> {
    let ep = &params.ensemble;
    let (object, cached) = object_parts(demo, object_mesh, params)?;
    let (supports, solid) = scene_items(scene, barriers, limits)?;
    let replays = MemberReplays {
        robot,
        demo,
        scene,
        barriers,
        object_mesh,
        params,
        limits,
        object,
        cached,
        supports,
        solid,
        penetration: PenetrationRun {
            penetration: nominal.penetration.clone(),
            per_ho: nominal.per_frame.hand_object_penetration_mm.clone(),
            per_hb: nominal.per_frame.hand_barrier_penetration_mm.clone(),
        },
    };
    let mut members = vec![ensemble::Member {
        index: 0,
        draw: ensemble::Draw::default(),
        passed: nominal.passed(),
        reason: nominal.reasons.first().cloned(),
    }];
    let stop = |members: &[ensemble::Member], target: usize| {
        let passed = members.iter().filter(|m| m.passed).count();
        members.len() >= target
            || (ep.early_stop
                && ensemble::can_stop(passed, members.len(), target, ep.keep_threshold))
    };
    // The first K: every member but the last in one batch, then the last if the early stop
    // does not hold (a trajectory that passes every replay stops after K − 1 members). While
    // the decision is uncertain, K more at a time in one batch, up to the most members.
    let mut target = ep.members;
    loop {
        'batches: while !stop(&members, target) {
            let next = members.len();
            let end = if next == 1 {
                (target - 1).max(2).min(target)
            } else {
                target
            };
            let indices: Vec<usize> = (next..end).collect();
            for m in replays.run(&indices)? {
                members.push(m);
                if stop(&members, target) {
                    break 'batches;
                }
            }
        }
        let passed = members.iter().filter(|m| m.passed).count();
        let uncertain = ensemble::decide(passed, members.len(), ep.keep_threshold).1;
        if !uncertain || target >= ep.most_members() {
            break;
        }
        target = (target + ep.members).min(ep.most_members());
    }
    Ok(Ensemble::of(ep, members, nominal.reasons.clone()))
}

/// What the perturbed members of one trajectory's ensemble share: the trajectory, its world
/// and the nominal replay's penetration checks (which measure the trajectory as written).
struct MemberReplays<'a> {
    robot: &'a Robot,
    demo: &'a Demo,
    scene: &'a Scene,
    barriers: &'a [String],
    object_mesh: &'a Mesh,
    params: &'a Params,
    limits: &'a Limits,
    /// The object's shape (and whether it came from the cache), the scene's supports and
    /// checked barriers: built once for every shared world of the ensemble.
    object: Arc<ObjectShape>,
    cached: bool,
    supports: NamedShapes,
    solid: NamedShapes,
    penetration: PenetrationRun,
}

impl MemberReplays<'_> {
    /// Member `index`'s draw, trajectory, parameters and object start.
    fn perturbed(&self, index: usize) -> (ensemble::Draw, Demo, Params, nalgebra::Isometry3<f64>) {
        let (demo, params) = (self.demo, self.params);
        let ep = &params.ensemble;
        let draw = ep.draw(&demo.name, index);
        let mut d = demo.clone();
        let mut jitter = ensemble::Jitter::new(&draw, ep, demo.fps);
        for f in &mut d.frames {
            f.wrist = draw.apply_to_wrist(&f.wrist);
            jitter.apply(&mut f.wrist, &mut f.joints);
        }
        d.object.mass *= draw.mass_scale;
        let p = Params {
            hand_friction: params.hand_friction * draw.friction_scale,
            finger_skin_m: (params.finger_skin_m + draw.skin_offset_mm * 1e-3).max(0.0),
            margin: false,
            ensemble: EnsembleParams::single(),
            ..params.clone()
        };
        let start = draw.apply_to_start(&demo.frames[0].object);
        (draw, d, p, start)
    }

    /// Replays the members `indices`: in shared worlds with the kinematic hand, each in a
    /// world of its own with the actuated one.
    fn run(&self, indices: &[usize]) -> Result<Vec<ensemble::Member>> {
        match self.params.hand {
            HandModel::Kinematic => self.shared(indices),
            HandModel::Actuated => self.alone(indices),
        }
    }

    /// Members in worlds of their own, in parallel.
    fn alone(&self, indices: &[usize]) -> Result<Vec<ensemble::Member>> {
        indices
            .par_iter()
            .map(|&index| {
                let (draw, d, p, object_start) = self.perturbed(index);
                let setup = MemberSetup {
                    object_start,
                    penetration: &self.penetration,
                };
                let r = validate_one(
                    self.robot,
                    &d,
                    self.scene,
                    self.barriers,
                    self.object_mesh,
                    &p,
                    self.limits,
                    Some(&setup),
                )?;
                Ok(ensemble::Member {
                    index,
                    draw,
                    passed: r.passed(),
                    reason: r.reasons.first().cloned(),
                })
            })
            .collect()
    }

    /// Members sharing worlds: contiguous groups of at most [`SHARED_MEMBERS`], as even as
    /// they come, one world each, the worlds in parallel. The grouping depends on the
    /// indices alone, so the outcome does not depend on the cores.
    fn shared(&self, indices: &[usize]) -> Result<Vec<ensemble::Member>> {
        let (robot, params) = (self.robot, self.params);
        let (object, supports) = (&self.object, &self.supports);
        let worlds = indices.len().div_ceil(SHARED_MEMBERS).max(1);
        let size = indices.len().div_ceil(worlds).max(1);
        let groups: Vec<&[usize]> = indices.chunks(size).collect();
        let done: Vec<Vec<ensemble::Member>> = groups
            .par_iter()
            .map(|group| {
                let (mut draws, mut demos, mut params_of, mut starts) =
                    (Vec::new(), Vec::new(), Vec::new(), Vec::new());
                for &i in group.iter() {
                    let (draw, d, p, start) = self.perturbed(i);
                    draws.push(draw);
                    demos.push(d);
                    params_of.push(p);
                    starts.push(start);
                }
                let traces = run_shared_replay(
                    robot,
                    &demos,
                    &params_of,
                    &starts,
                    object,
                    supports,
                    &self.solid,
                    params,
                );
                draws
                    .into_iter()
                    .zip(demos.iter().zip(&params_of))
                    .zip(traces)
                    .zip(group.iter())
                    .map(|(((draw, (d, p)), trace), &index)| {
                        let checked = check_replay(robot, d, object, supports, &trace, p);
                        let r = judge(
                            d,
                            object,
                            self.cached,
                            &trace,
                            self.penetration.clone(),
                            checked,
                            Timing::default(),
                            p,
                        );
                        ensemble::Member {
                            index,
                            draw,
                            passed: r.passed(),
                            reason: r.reasons.first().cloned(),
                        }
                    })
                    .collect()
            })
            .collect();
        Ok(done.into_iter().flatten().collect())
    }
}

/// The grasp hold test (`dexwarp validate --grasp-only`, and `synth`'s choice of grasp).
/// Frozen: the stability test of [`validate`] alone, without the replay: at sampled frames
/// of the contact segment the hand is frozen at the frame's pose, the object starts at its
/// recorded pose with no support under it, and gravity acts for [`Params::stability_steps`]
/// steps; the object's displacement is what the grasp lets it fall or turn (ObMan,
/// GraspTTA). Carried: [`carry`], the contact segment replayed without supports, so the
/// grasp also meets the motion's accelerations and turns, with the object placed in it
/// exactly as recorded (what the approach does to the object before the grasp closes is the
/// full replay's to see). The frozen test is short and misses a slow slip: under 45 m/s² the
/// teapot's grasp lets the pot move 20 mm frozen (within the limit) and drops it carried.
/// `None` when the demonstration has no contact frame. The grasp holds when
/// [`GraspHold::reasons`] is empty.
pub fn hold(
    robot: &Robot,
    demo: &Demo,
    object_mesh: &Mesh,
    params: &Params,
) -> Result<Option<GraspHold>> {
    params.check()?;
    check_demo(robot, demo)?;
    let (object, _, _) = object_shapes(demo, object_mesh, params)?;
    let Some(segment) = demo.contact_segment() else {
        return Ok(None);
    };
    let stability = stability(robot, demo, &object, segment, |_| true, params);
    let carry = carry(robot, demo, &object, params)?.expect("the demonstration has contacts");
    let reasons = verdict::hold(&stability, &carry, params);
    Ok(Some(GraspHold {
        stability,
        carry,
        reasons,
    }))
}

/// The grasp carried: the frames of the contact segment replayed with the hand on its
/// recorded poses, the object starting at its recorded pose at the segment's first frame,
/// gravity, no support and no barrier: what the grasp alone does with the object as the hand
/// moves. The replay stops one drop window after the object falls out of the grasp. `None`
/// when the demonstration has no contact frame. [`GraspHold`] judges it.
pub fn carry(
    robot: &Robot,
    demo: &Demo,
    object: &ObjectShape,
    params: &Params,
) -> Result<Option<Carry>> {
    let Some(segment) = demo.contact_segment() else {
        return Ok(None);
    };
    let carried = Demo {
        name: demo.name.clone(),
        fps: demo.fps,
        robot: demo.robot.clone(),
        object: demo.object.clone(),
        joint_names: demo.joint_names.clone(),
        frames: demo.frames[segment.start..=segment.end].to_vec(),
        timewarp: None,
        scene: None,
        barriers: Vec::new(),
        wrist_link: demo.wrist_link.clone(),
        source: demo.source.clone(),
    };
    let (trace, _) = run_replay(robot, &carried, object, &[], &[], params, None)?;
    let (_, _, mut tracking) = checks::tracking_errors(&carried, &trace.object);
    tracking.max_position_error_frame += segment.start;
    tracking.max_rotation_error_frame += segment.start;
    Ok(Some(Carry {
        first_frame: segment.start,
        last_frame: segment.end,
        frames_replayed: trace.object.len(),
        tracking,
    }))
}

/// The hold test of one grasp [m]: the object's displacement with the hand frozen at
/// `link_poses`, the object (mass `mass`) starting at `object_pose` with no support under it,
/// gravity acting for [`Params::stability_steps`] steps (the test [`hold`] runs at sampled
/// contact frames). The grasp holds when it is within [`Params::max_sim_displacement_m`].
pub fn hold_displacement(
    robot: &Robot,
    link_poses: &[nalgebra::Isometry3<f64>],
    object: &ObjectShape,
    object_pose: &nalgebra::Isometry3<f64>,
    mass: f64,
    params: &Params,
) -> f64 {
    checks::sim_displacement(robot, link_poses, object, object_pose, mass, params)
}

/// Where the object comes to rest when let go at `pose` on the `supports` (world shapes)
/// with no hand about: [`Params::stability_dt_s`] steps for `seconds` of simulated time. A
/// recorded rest pose is a few millimetres and degrees off the support it stands on
/// (capture noise); the replay settles it at the first step and every finger placed on the
/// recorded pose is then off by as much.
pub fn settle(
    robot: &Robot,
    object: &ObjectShape,
    pose: &nalgebra::Isometry3<f64>,
    mass: f64,
    supports: &[CollisionShape],
    params: &Params,
    seconds: f64,
) -> nalgebra::Isometry3<f64> {
    // The hand far above, out of the way.
    let away = nalgebra::Isometry3::translation(0.0, 0.0, pose.translation.z + 100.0);
    let link_poses = vec![away; robot.link_count()];
    let fixed: Vec<FixedItem<'_>> = supports
        .iter()
        .map(|s| FixedItem {
            shape: s,
            tag: Tag::Support,
        })
        .collect();
    let mut world = ReplayWorld::new(
        robot,
        &link_poses,
        object,
        pose,
        mass,
        &fixed,
        params,
        params.stability_dt_s,
        Vector3::from(params.gravity),
    );
    let steps = (seconds / params.stability_dt_s)
        .ceil()
        .clamp(1.0, 100_000.0) as usize;
    for _ in 0..steps {
        world.step();
    }
    let end = world.object_pose();
    if end.translation.vector.iter().all(|v| v.is_finite()) {
        end
    } else {
        *pose
    }
}

/// The object's collision shape and whether it came from the cache.
fn object_parts(
    demo: &Demo,
    object_mesh: &Mesh,
    params: &Params,
) -> Result<(Arc<ObjectShape>, bool)> {
    object_shape(object_mesh, &params.decomposition)
        .map_err(|e| Error::invalid(&demo.object.mesh, "(mesh)", e.to_string()))
}

/// The object's convex decomposition (and whether it came from the cache) and its signed
/// distance field: the same one the IK keeps the fingers out of.
fn object_shapes(
    demo: &Demo,
    object_mesh: &Mesh,
    params: &Params,
) -> Result<(Arc<ObjectShape>, bool, Arc<crate::geometry::ObjectSdf>)> {
    let (object, cached) = object_parts(demo, object_mesh, params)?;
    let sdf = crate::geometry::object_sdf(object_mesh).ok_or_else(|| {
        Error::invalid(
            &demo.object.mesh,
            "triangles",
            "is empty; expected a solid object",
        )
    })?;
    Ok((object, cached, sdf))
}

/// Scene items by name with their collision shapes.
type NamedShapes = Vec<(String, CollisionShape)>;

/// The scene's supports and the checked `barriers` with their collision shapes, in scene
/// order. Fails on a barrier the scene does not have.
fn scene_items(
    scene: &Scene,
    barriers: &[String],
    limits: &Limits,
) -> Result<(NamedShapes, NamedShapes)> {
    let mut supports: Vec<(String, CollisionShape)> = Vec::new();
    let mut solid: Vec<(String, CollisionShape)> = Vec::new();
    for name in barriers {
        if scene.item(name).is_none() {
            return Err(Error::invalid(
                &scene.source,
                "items",
                format!(
                    "has no item named {name:?} (a barrier of the config); items: {}",
                    scene
                        .items
                        .iter()
                        .map(|i| i.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
    }
    for item in &scene.items {
        if item.role == Role::Support {
            supports.push((item.name.clone(), scene.collision_shape(item, limits)?));
        } else if barriers.contains(&item.name) {
            solid.push((item.name.clone(), scene.collision_shape(item, limits)?));
        }
    }
    Ok((supports, solid))
}

/// The supports and barriers as the world's fixed items, supports first.
fn fixed_items<'a>(
    supports: &'a [(String, CollisionShape)],
    solid: &'a [(String, CollisionShape)],
) -> Vec<FixedItem<'a>> {
    supports
        .iter()
        .map(|(_, s)| FixedItem {
            shape: s,
            tag: Tag::Support,
        })
        .chain(solid.iter().map(|(_, s)| FixedItem {
            shape: s,
            tag: Tag::Barrier,
        }))
        .collect()
}

/// What the replay of `demo`, its object starting at `start`, may leave out.
fn shortcuts(
    demo: &Demo,
    object: &ObjectShape,
    start: &nalgebra::Isometry3<f64>,
    supports: &[(String, CollisionShape)],
    params: &Params,
) -> replay::Shortcuts {
    replay::Shortcuts {
        rest: params.skip_rest,
        rests_at_start: params.skip_rest
            && checks::nearest_support(object, start, &named(supports))
                .is_some_and(|(_, gap)| gap <= params.support_gap_m),
        tracking: None,
        drop: demo
            .contact_segment()
            .filter(|_| params.stop_after_drop)
            .map(|segment| replay::DropStop {
                segment,
                error_m: params.drop_error_m,
                window: drop_window(demo.fps),
            }),
    }
}

/// Builds the world (hand and object at frame 0, the supports and barriers fixed) and
/// replays the trajectory in it: the trace and the wall time [s]. The object starts at
/// `object_start`, by default its pose at frame 0.
fn run_replay(
    robot: &Robot,
    demo: &Demo,
    object: &ObjectShape,
    supports: &[(String, CollisionShape)],
    solid: &[(String, CollisionShape)],
    params: &Params,
    object_start: Option<&nalgebra::Isometry3<f64>>,
) -> Result<(replay::Trace, f64)> {
    let fixed = fixed_items(supports, solid);
    let n = replay::steps_per_frame(demo.fps, params.max_dt_s);
    let t_replay = Instant::now();
    let mut link_poses = robot.new_link_poses();
    let f0 = &demo.frames[0];
    let start = object_start.unwrap_or(&f0.object);
    robot.forward_kinematics(&f0.wrist, &f0.joints, &mut link_poses);
    let mut world = ReplayWorld::with_hand_model(
        robot,
        &link_poses,
        &f0.joints,
        object,
        start,
        demo.object.mass,
        &fixed,
        params,
        1.0 / (n as f64 * demo.fps),
        Vector3::from(params.gravity),
    )?;
    let shortcuts = shortcuts(demo, object, start, supports, params);
    let trace = replay::replay(robot, demo, &mut world, n, &shortcuts);
    Ok((trace, t_replay.elapsed().as_secs_f64()))
}

/// Most ensemble members replayed in one shared world ([`ReplayWorld::shared`]): the default
/// ensemble's first batch (members 1 to 6) in one.
const SHARED_MEMBERS: usize = 8;

/// Replays the trajectories `demos` (members of one ensemble: the same frames; each with its
/// parameters `member_params` and object start `starts`) with the kinematic hand in one
/// shared world: their traces, in order. `params` gives what they share (step, solver,
/// gravity).
fn run_shared_replay(
    robot: &Robot,
    demos: &[Demo],
    member_params: &[Params],
    starts: &[nalgebra::Isometry3<f64>],
    object: &ObjectShape,
    supports: &[(String, CollisionShape)],
    solid: &[(String, CollisionShape)],
    params: &Params,
) -> Vec<replay::Trace> {
    let fixed = fixed_items(supports, solid);
    let fps = demos[0].fps;
    let n = replay::steps_per_frame(fps, params.max_dt_s);
    let link_poses: Vec<Vec<nalgebra::Isometry3<f64>>> = demos
        .iter()
        .map(|d| {
            let mut poses = robot.new_link_poses();
            robot.forward_kinematics(&d.frames[0].wrist, &d.frames[0].joints, &mut poses);
            poses
        })
        .collect();
    let member_starts: Vec<world::MemberStart<'_>> = demos
        .iter()
        .zip(member_params)
        .zip(starts)
        .zip(&link_poses)
        .map(|(((d, p), start), poses)| world::MemberStart {
            link_poses: poses,
            object_pose: *start,
            mass: d.object.mass,
            hand_friction: p.hand_friction,
            finger_skin_m: p.finger_skin_m,
        })
        .collect();
    let mut world = ReplayWorld::shared(
        robot,
        &member_starts,
        object,
        &fixed,
        params,
        1.0 / (n as f64 * fps),
        Vector3::from(params.gravity),
    );
    let shortcuts: Vec<replay::Shortcuts> = demos
        .iter()
        .zip(member_params)
        .zip(starts)
        .map(|((d, p), start)| {
            // A member's outcome is all the ensemble reads of it: its replay also stops once
            // its tracking has failed beyond recovery.
            let frames = d.frames.len() as f64;
            replay::Shortcuts {
                tracking: p.stop_after_drop.then(|| replay::TrackingStop {
                    position_sum_m: p.max_mean_position_error_m * frames,
                    rotation_sum_rad: p.max_mean_rotation_error_deg.to_radians() * frames,
                }),
                ..shortcuts(d, object, start, supports, p)
            }
        })
        .collect();
    replay::replay_shared(robot, demos, &mut world, n, &shortcuts)
}

/// Frames after a drop's first frame in which the hand's contact is read (0.2 s).
fn drop_window(fps: f64) -> usize {
    (0.2 * fps).ceil() as usize
}

/// The checks on the replay (4b), with the per-frame errors they read.
struct ReplayChecks {
    segment: Option<ContactSegment>,
    /// Position [m] and rotation [rad] error of the simulated object, per frame.
    pos_err: Vec<f64>,
    rot_err: Vec<f64>,
    tracking: Tracking,
    /// Whether the hand touches the simulated object, per frame.
    touching: Vec<bool>,
    dropped: Option<Drop>,
    stability: Option<Stability>,
    /// Wall time of the stability samples [s].
    stability_s: f64,
    release: Option<Release>,
    grip: Option<Grip>,
    onset: Option<Onset>,
}

/// Tracking, drop, stability, release and grip of the replay `trace`.
fn check_replay(
    robot: &Robot,
    demo: &Demo,
    object: &ObjectShape,
    supports: &[(String, CollisionShape)],
    trace: &replay::Trace,
    params: &Params,
) -> ReplayChecks {
    let segment = demo.contact_segment();
    let (pos_err, rot_err, tracking) = checks::tracking_errors(demo, &trace.object);
    let touch_reach = params.finger_skin_m + params.touch_tolerance_m;
    let shapes = robot.collision_shapes();
    let mut link_poses = robot.new_link_poses();
    let mut hand_placed = Vec::new();
    let touching: Vec<bool> = demo
        .frames
        .iter()
        .zip(&trace.object)
        .map(|(frame, sim)| {
            robot.forward_kinematics(&frame.wrist, &frame.joints, &mut link_poses);
            checks::place_hand(&shapes, &link_poses, &mut hand_placed);
            checks::hand_touches(&hand_placed, object, sim, touch_reach)
        })
        .collect();
    // The links touching the simulated object at `frame`.
    let mut links_at = |frame: usize| -> Vec<String> {
        let (Some(f), Some(sim)) = (demo.frames.get(frame), trace.object.get(frame)) else {
            return Vec::new();
        };
        robot.forward_kinematics(&f.wrist, &f.joints, &mut link_poses);
        checks::place_hand(&shapes, &link_poses, &mut hand_placed);
        checks::touching_links(&hand_placed, object, sim, touch_reach)
            .into_iter()
            .map(|l| robot.link(LinkId(l as u32)).name.clone())
            .collect()
    };
    let mut dropped = segment
        .and_then(|s| checks::find_drop(s, &pos_err, &touching, drop_window(demo.fps), params));
    if let Some(d) = dropped.as_mut().filter(|d| d.cause == DropCause::Slipped) {
        d.touching_links = links_at(d.frame);
    }

    let t_stab = Instant::now();
    let off_support = |f: usize| {
        !checks::on_support(
            object,
            &demo.frames[f].object,
            supports,
            params.support_gap_m,
        )
    };
    let stability = segment.map(|s| stability(robot, demo, object, s, off_support, params));
    let stability_s = t_stab.elapsed().as_secs_f64();

    let mut release = release(
        demo, object, supports, trace, segment, &pos_err, &touching, params,
    );
    if let Some(p) = release.as_mut().and_then(|r| r.pushed.as_mut()) {
        p.touching_links = links_at(p.last_touch_frame);
    }
    if let Some(t) = release
        .as_mut()
        .and_then(|r| r.turn.as_mut())
        .and_then(|t| t.by_hand.as_mut())
    {
        t.links = links_at(t.frame);
    }

    let replayed = trace.grip.len();
    let grip = segment.filter(|s| s.start < replayed).map(|s| {
        checks::grip(
            &trace.grip[s.start..=s.end.min(replayed - 1)],
            demo.object.mass * Vector3::from(params.gravity).norm(),
        )
    });
    let onset = segment.and_then(|s| {
        let (p, r) = (*pos_err.get(s.start)?, *rot_err.get(s.start)?);
        (p.is_finite() && r.is_finite()).then(|| Onset {
            frame: s.start,
            position_error_mm: p * 1e3,
            rotation_error_deg: r.to_degrees(),
        })
    });
    ReplayChecks {
        segment,
        pos_err,
        rot_err,
        tracking,
        touching,
        dropped,
        stability,
        stability_s,
        release,
        grip,
        onset,
    }
}

/// Simulation displacement at sampled frames of the contact segment `s` that `eligible`
/// accepts: the hand frozen, each frame in a world of its own.
fn stability(
    robot: &Robot,
    demo: &Demo,
    object: &ObjectShape,
    s: ContactSegment,
    eligible: impl Fn(usize) -> bool,
    params: &Params,
) -> Stability {
    let frames = checks::stability_frames(s, params.stability_samples, eligible);
    // Independent worlds: in parallel, results in frame order.
    let displacement: Vec<f64> = frames
        .par_iter()
        .map(|&f| {
            let frame = &demo.frames[f];
            let mut link_poses = robot.new_link_poses();
            robot.forward_kinematics(&frame.wrist, &frame.joints, &mut link_poses);
            checks::sim_displacement(
                robot,
                &link_poses,
                object,
                &frame.object,
                demo.object.mass,
                params,
            )
        })
        .collect();
    checks::stability_stats(frames, &displacement, params)
}

/// Where the object ends after the release (when the contact segment ends before the last
/// frame): at rest on a support or not.
fn release(
    demo: &Demo,
    object: &ObjectShape,
    supports: &[(String, CollisionShape)],
    trace: &replay::Trace,
    segment: Option<ContactSegment>,
    position_error: &[f64],
    touching: &[bool],
    params: &Params,
) -> Option<Release> {
    if trace.stopped_at.is_some() {
        return None;
    }
    let last = demo.frames.len() - 1;
    segment.filter(|s| s.end < last).map(|s| {
        let pose = &trace.object[last];
        // The window: the last `rest_window_s`, from the first frame the hand no longer
        // touches the object on (its motion while the hand still touches it is the
        // hand's, judged by the push check).
        let let_go = (s.end + 1..=last)
            .rev()
            .find(|&f| touching.get(f).copied().unwrap_or(false))
            .map_or(s.end + 1, |f| f + 1);
        let window = ((params.rest_window_s * demo.fps).ceil() as usize)
            .min(last - s.end)
            .min(last.saturating_sub(let_go));
        let motion = trace.object[last - window..]
            .iter()
            .map(|p| (p.translation.vector - pose.translation.vector).norm())
            .fold(0.0, f64::max);
        let nearest = checks::nearest_support(object, pose, &named(supports));
        let rests = motion <= params.rest_motion_m
            && nearest
                .as_ref()
                .is_some_and(|(_, d)| *d <= params.support_gap_m);
        Release {
            frame: s.end,
            rests_on_support: rests,
            support_gap_mm: nearest.as_ref().map(|(_, d)| d * 1e3),
            support: nearest.map(|(n, _)| n),
            final_motion_mm: motion * 1e3,
            final_speed_m_s: trace.speed_m_s[last],
            pushed: checks::find_push(s.end, position_error, touching, params),
            turn: Some(checks::find_turn(s.end, &trace.object, touching)),
        }
    })
}

/// The report of the checks, with every failed one as a reason (the margin not yet run).
fn judge(
    demo: &Demo,
    object: &ObjectShape,
    cached: bool,
    trace: &replay::Trace,
    pen: PenetrationRun,
    checked: ReplayChecks,
    timing: Timing,
    params: &Params,
) -> PhysicsReport {
    let PenetrationRun {
        penetration,
        per_ho,
        per_hb,
    } = pen;
    let segment = checked.segment;
    let mut report = PhysicsReport {
        reasons: Vec::new(),
        tracking: checked.tracking,
        drop: checked.dropped,
        penetration,
        stability: checked.stability,
        release: checked.release,
        grip: checked.grip,
        onset: checked.onset,
        replay: ReplayInfo {
            frames: demo.frames.len(),
            steps: trace.steps,
            skipped_steps: trace.skipped_steps,
            stopped_frame: trace.stopped_at,
            dt_s: trace.dt_s,
            steps_per_frame: trace.steps_per_frame,
            solver_iterations: params.solver_iterations,
            contact_segment: segment.map(|s| [s.start, s.end]),
            object_parts: object.parts.len(),
            object_shape: Some(object.method),
            mesh_repair: object.repair.as_ref().map(|r| r.to_string()),
            object_volume_ratio: object.volume_ratio,
            hull_fallback_volumes_cm3: object.fallback_volumes_m3.map(|v| v.map(|x| x * 1e6)),
            decomposition_cached: cached,
            diverged_frame: trace.diverged_at,
            hand: params.hand,
        },
        margin: None,
        ensemble: None,
        profile: trace.profile,
        timing_s: timing,
        per_frame: PerFrame {
            position_error_mm: checked.pos_err.iter().map(|e| e * 1e3).collect(),
            rotation_error_deg: checked.rot_err.iter().map(|e| e.to_degrees()).collect(),
            hand_touching: checked.touching,
            hand_object_penetration_mm: per_ho,
            hand_barrier_penetration_mm: per_hb,
        },
    };
    report.reasons = verdict::reasons(&report, params);
    report
}

/// The robustness margin of the judged `report` ([`margin`]): the replay again under lower
/// friction and higher mass, with its wall time.
fn add_margin(
    report: &mut PhysicsReport,
    robot: &Robot,
    demo: &Demo,
    scene: &Scene,
    barriers: &[String],
    object_mesh: &Mesh,
    params: &Params,
    limits: &Limits,
) -> Result<()> {
    let nominal = margin::Condition {
        friction_scale: 1.0,
        friction: params.hand_friction,
        mass_scale: 1.0,
        passed: report.passed(),
        reason: report.reasons.first().cloned(),
    };
    let clock = Instant::now();
    let m = margin::given_nominal(
        nominal,
        robot,
        demo,
        scene,
        barriers,
        object_mesh,
        params,
        limits,
    )?;
    report.timing_s.margin = clock.elapsed().as_secs_f64();
    report.margin = Some(m);
    Ok(())
}

/// The four penetration figures and the per-frame hand-object and hand-barrier depths [mm].
#[derive(Clone)]
struct PenetrationRun {
    penetration: Penetrations,
    per_ho: Vec<f64>,
    per_hb: Vec<f64>,
}

/// Penetration depths at the demonstration's poses (see [`checks`]): hand-object,
/// hand-barrier, object-barrier, hand-support, the deepest pair per frame.
///
/// The hand-object figure is [`checks::hand_object_depth`]: the hand's penetration probes
/// against the object's signed distance field, the measure the contact IK constrains. The
/// others are parry contacts between the placed shapes.
fn penetrations(
    robot: &Robot,
    demo: &Demo,
    object: &ObjectShape,
    sdf: &crate::geometry::ObjectSdf,
    solid: &[(String, CollisionShape)],
    supports: &[(String, CollisionShape)],
    barrier_names: &[String],
    support_names: &[String],
    params: &Params,
) -> PenetrationRun {
    let shapes = robot.collision_shapes();
    let link_names: Vec<String> = robot.links().iter().map(|l| l.name.clone()).collect();
    let object_names = vec![demo.object.name.clone()];
    let barrier_placed = place_fixed(solid);
    let support_placed = place_fixed(supports);
    let mut hand_object = PenetrationAcc::new(Some(params.max_hand_object_penetration_m));
    let mut hand_barrier = PenetrationAcc::new(Some(params.max_hand_barrier_penetration_m));
    let mut object_barrier = PenetrationAcc::new(Some(params.max_object_barrier_penetration_m));
    let mut hand_support = PenetrationAcc::new(None);
    let mut unsupported = [0usize; 4];
    let mut link_poses = robot.new_link_poses();
    let mut hand_placed = Vec::new();
    let mut object_placed = Vec::new();
    let mut per_ho = Vec::with_capacity(demo.frames.len());
    let mut per_hb = Vec::with_capacity(demo.frames.len());
    for (i, frame) in demo.frames.iter().enumerate() {
        robot.forward_kinematics(&frame.wrist, &frame.joints, &mut link_poses);
        checks::place_hand(&shapes, &link_poses, &mut hand_placed);
        checks::place_object(object, &frame.object, &mut object_placed);
        let hit = checks::hand_object_depth(robot, &link_poses, &frame.object, sdf);
        per_ho.push(hand_object.add(i, hit, &link_names, &object_names) * 1e3);
        let hit = checks::deepest(&hand_placed, &barrier_placed, &mut unsupported[1]);
        per_hb.push(hand_barrier.add(i, hit, &link_names, barrier_names) * 1e3);
        let hit = checks::deepest(&object_placed, &barrier_placed, &mut unsupported[2]);
        object_barrier.add(i, hit, &object_names, barrier_names);
        let hit = checks::deepest(&hand_placed, &support_placed, &mut unsupported[3]);
        hand_support.add(i, hit, &link_names, support_names);
    }
    PenetrationRun {
        penetration: Penetrations {
            hand_object: hand_object.finish(unsupported[0]),
            hand_barrier: hand_barrier.finish(unsupported[1]),
            object_barrier: object_barrier.finish(unsupported[2]),
            hand_support: hand_support.finish(unsupported[3]),
        },
        per_ho,
        per_hb,
    }
}

fn place_fixed(items: &[(String, CollisionShape)]) -> Vec<Placed<'_>> {
    items
        .iter()
        .enumerate()
        .map(|(i, (_, cs))| {
            Placed::new(
                cs.shape.as_ref(),
                crate::math::convert::to_pose(&cs.shape_pose),
                i,
            )
        })
        .collect()
}

fn named(items: &[(String, CollisionShape)]) -> Vec<(String, &CollisionShape)> {
    items.iter().map(|(n, s)| (n.clone(), s)).collect()
}

fn check_demo(robot: &Robot, demo: &Demo) -> Result<()> {
    if demo.frames.is_empty() {
        return Err(Error::invalid(
            &demo.source,
            "frames",
            "is empty; expected at least one frame",
        ));
    }
    if let Some((i, f)) = demo
        .frames
        .iter()
        .enumerate()
        .find(|(_, f)| f.joints.len() != robot.dof())
    {
        return Err(Error::invalid(
            &demo.source,
            format!("frames[{i}].joints"),
            format!(
                "has {} values but robot {:?} has {} actuated joints; bind the demonstration with Demo::check_robot first",
                f.joints.len(),
                robot.name,
                robot.dof()
            ),
        ));
    }
    if !(demo.fps.is_finite() && demo.fps > 0.0) {
        return Err(Error::invalid(
            &demo.source,
            "fps",
            format!("is {}; expected > 0", demo.fps),
        ));
    }
    Ok(())
}
