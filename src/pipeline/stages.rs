//! The stages of [`super::warp`] that take more than a line: the plan and its limits, the
//! object stages' timing, the contact IK with its smoothing, the guard, the physics replay.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Instant;

use nalgebra::Isometry3;

use super::{Inputs, Options, StageParams, checks};
use crate::geometry::ObjectSdf;
use crate::geometry::shape::CollisionShape;
use crate::hand::ik;
use crate::hand::{HandPath, baseline as rigid, guard as hand_guard, smooth};
use crate::metrics;
use crate::model::provenance::Provenance;
use crate::model::report::{HeldSpan, HeldYield};
use crate::model::{Demo, GraspMode, Objective};
use crate::physics;
use crate::robot::Robot;
use crate::warp::barrier::Barrier;
use crate::warp::{ObjectParams, ObjectPath, ObjectWarp, WarpPlan, warp_object};
use crate::{Error, Result};

/// Wall time of each stage [s], by stage name (the report's `timing_s`).
pub(super) type Timing = BTreeMap<String, f64>;

/// How long the IK hand's difference from the rigid transfer fades out beyond each end of
/// the contact segment [s] (stage 5c, [`smooth::ease_ends`]).
const EASE_S: f64 = 0.25;

/// How far the object moves from where it rests at an end of the contact segment before
/// it counts as carried ([`smooth::carried`]): 2 mm, 2°.
const CARRY_REACH_M: f64 = 0.002;
const CARRY_REACH_RAD: f64 = 2.0 * std::f64::consts::PI / 180.0;

/// How far a link of the per-frame hand may be from its place in the carry's grasp while the
/// object rests before the carry for the grasp to count as formed there [m]. The
/// built-in demonstrations, whose hands close before they touch, stay within 8 mm; a recorded
/// hand still closing when it touches (a thumb that arrives as the object lifts) is 26-66 mm
/// away.
const FORMING_GAP_M: f64 = 0.015;

/// What contact IK left besides the hand: the unsmoothed solution, its statistics, and what
/// the guard holds the smoothed hand to.
pub(super) struct IkRun {
    /// The IK's hand before smoothing.
    pub raw: HandPath,
    pub stats: ik::Stats,
    /// Deepest a finger may sit in the object in a converged frame [mm].
    pub tolerance_mm: f64,
    /// The object's distance field and the tolerance [m] (non-penetrating objective only).
    pub guard_with: Option<(Arc<ObjectSdf>, f64)>,
    /// Where the held grasp yielded to a barrier; `None` for a per-frame grasp or without
    /// barriers.
    pub held_yield: Option<HeldYield>,
    /// Where the held grasp is held (held grasp only).
    pub held: Option<HeldSpan>,
}

/// The warp plan of the inputs (contact segment, output frames), refused before any work
/// when its output or its physics replay is over the limits.
pub(super) fn plan(
    inputs: &Inputs,
    options: &Options,
    params: &StageParams,
    input: &ObjectPath,
) -> Result<WarpPlan> {
    let Inputs { config, demo, .. } = inputs;
    let segment = demo.contact_segment().ok_or_else(|| {
        Error::invalid(
            &demo.source,
            "frames",
            "no frame has contact correspondences; a warp needs an in-contact segment",
        )
    })?;
    let plan = WarpPlan::new(config, &input.positions, segment)?;
    options
        .limits
        .check_output_frames(&config.source, plan.frames_out() as u64)?;
    if let Some(p) = &params.physics {
        checks::physics_work(
            &options.limits,
            &config.source,
            plan.frames_out(),
            demo.fps,
            p,
        )?;
    }
    Ok(plan)
}

/// Stages 1-3: spatial warp, barrier push-out, retiming, each timed.
pub(super) fn object(
    inputs: &Inputs,
    input: &ObjectPath,
    plan: &WarpPlan,
    barriers: &[Barrier],
    params: &ObjectParams,
    timing: &mut Timing,
) -> Result<ObjectWarp> {
    let radius = inputs.mesh.bounding_radius();
    let source = &inputs.config.source;
    let object = warp_object(input, plan, barriers, radius, params, source)?;
    timing.insert("spatial".into(), object.spatial.stats.time_s);
    timing.insert("barrier".into(), object.barrier.stats.time_s);
    timing.insert("retime".into(), object.retime.stats.time_s);
    checks::path(source, "object warp (1-3)", object.path())?;
    Ok(object)
}

/// Stage 4, the rigid SE(3) transfer at τ.
pub(super) fn baseline(
    inputs: &Inputs,
    object: &ObjectWarp,
    timing: &mut Timing,
) -> Result<HandPath> {
    let clock = Instant::now();
    let base = rigid::run(&inputs.demo, object)
        .map_err(|e| Error::invalid(&inputs.config.source, "(hand)", e.to_string()))?;
    timing.insert("baseline".into(), clock.elapsed().as_secs_f64());
    Ok(base)
}

/// The run's inputs and parameters, as the report's provenance records them.
pub(super) fn provenance(inputs: &Inputs, options: &Options, params: &StageParams) -> Provenance {
    let Inputs { config, demo, .. } = inputs;
    let mut provenance = Provenance::new();
    provenance.input("config", &config.source);
    provenance.input("demo", &demo.source);
    provenance.input("scene", &config.scene);
    provenance.input("robot", &demo.robot);
    provenance.input("mesh", &demo.object.mesh);
    provenance.parameters("warp", &config.params);
    provenance.parameters(
        "options",
        &serde_json::json!({
            "hand": options.hand,
            "threshold_mm": params.ik.threshold_mm,
            "solver": options.solver,
            "physics": options.physics.is_some(),
        }),
    );
    provenance.parameters("hand_pushout", &params.hand_pushout);
    provenance.parameters("limits", &options.limits);
    if let Some(p) = &params.physics {
        provenance.parameters("physics", p);
    }
    provenance
}

/// Stages 4-5 of contact IK: the per-frame solve warm-started from `base`, then smoothing
/// inside the contact segment and the fade to the rigid transfer beyond its ends.
pub(super) fn contact_ik(
    inputs: &Inputs,
    params: &StageParams,
    shapes: &[CollisionShape],
    object: &ObjectWarp,
    base: &HandPath,
    provenance: &mut Provenance,
    timing: &mut Timing,
) -> Result<(HandPath, IkRun)> {
    let Inputs {
        config,
        demo,
        robot,
        mesh,
        ..
    } = inputs;
    let object_sdf = crate::geometry::object_sdf(mesh);
    let smoothing = &params.smooth;
    let params = params.ik(config, || {
        crate::model::config::auto_penetration_tolerance_mm(
            object_sdf.as_deref().map_or(0.0, |sdf| {
                metrics::max_hand_object_penetration_mm(robot, demo, sdf)
            }),
        )
    });
    let tolerance_mm = params.penetration_tolerance_mm;
    provenance.parameters("ik", &params);
    provenance.parameters("smooth", smoothing);
    let (raw, stats) = ik::run(
        robot,
        demo,
        object,
        base,
        shapes,
        object_sdf.as_deref(),
        &params,
    );
    timing.insert("ik".into(), stats.time_s);

    // Stage 5: smoothing inside the contact segment.
    let clock = Instant::now();
    let range = object.plan.segment.start..=object.plan.t_end_new();
    let ease = crate::math::frames_in(EASE_S, demo.fps).max(1);
    let (mut hand, _) = smooth::run(&raw, range.clone(), smoothing)
        .map_err(|e| Error::invalid(&config.source, "(smoothing)", e.to_string()))?;
    let (mut held_yield, mut held) = (None, None);
    if config.params.grasp == GraspMode::Held {
        let path = object.path();
        let objects: Vec<_> = (0..path.len()).map(|t| path.pose(t)).collect();
        let per_frame = hand.clone();
        held = held_grasp(robot, &mut hand, &per_frame, &objects, range.clone(), ease)
            .map_err(|e| Error::invalid(&config.source, "params.grasp", e.to_string()))?;
        // Without barriers nothing else makes the per-frame solution come back.
        if !shapes.is_empty() {
            let clearance = config.params.hand_clearance_m;
            held_yield = Some(yield_to_barriers(
                robot,
                shapes,
                &mut hand,
                &per_frame,
                &objects,
                range.clone(),
                clearance,
                ease,
            ));
        }
    }
    // Stage 5c: no jump between the IK hand and the rigid transfer at the segment's ends:
    // the difference fades out over `EASE_S` outside it.
    smooth::ease_ends(&mut hand, base, range, ease, |q| {
        robot.clamp(q);
    });
    timing.insert("smooth".into(), clock.elapsed().as_secs_f64());

    let guard_with = match (params.objective, object_sdf) {
        (Objective::NonPenetrating, Some(sdf)) => {
            Some((sdf, params.penetration_tolerance_mm * 1e-3))
        }
        _ => None,
    };
    let ik = IkRun {
        raw,
        stats,
        tolerance_mm,
        guard_with,
        held_yield,
        held,
    };
    Ok((hand, ik))
}

/// Stage 5 with a held grasp: the carry's grasp ([`smooth::hold_grasp`] from the first frame
/// that carries the object, [`smooth::carried`]) on the object at every frame of the contact
/// segment `range`, `hand` the per-frame IK's. Where the object rests before the carry and the
/// hand is still closing on it there (a link more than [`FORMING_GAP_M`] from its place in the
/// carry's grasp), pressing the finished grasp on the resting object would shove it before
/// the hand has closed; there the hand keeps its per-frame solution and blends into the held
/// grasp over the carry's first `ease` frames. A grasp already formed at rest is held there
/// too, and the average taken over it. After the carry the grasp that put the object down is
/// held to the segment's end whatever the per-frame hand does: it lies on the object where the
/// carry left it, and the fade beyond the segment opens it as recorded (the per-frame opening
/// swept the Allegro's fingers into a box that had settled off its plan, pushing it away in 17
/// of 40 augmented samples). `hand` is `per_frame` on entry. Returns where it held (`None` for
/// an empty segment).
fn held_grasp(
    robot: &Robot,
    hand: &mut HandPath,
    per_frame: &HandPath,
    objects: &[Isometry3<f64>],
    range: std::ops::RangeInclusive<usize>,
    ease: usize,
) -> std::result::Result<Option<HeldSpan>, crate::math::rotation::RotationError> {
    let clamp = |q: &mut [f64]| {
        robot.clamp(q);
    };
    let (a, b) = (*range.start(), *range.end());
    if a > b || b >= hand.len() || objects.len() != hand.len() {
        return Ok(None);
    }
    let carry = smooth::carried(objects, range.clone(), CARRY_REACH_M, CARRY_REACH_RAD);
    let (s, e) = (*carry.start(), *carry.end());
    smooth::hold_grasp(hand, objects, range.clone(), s..=b, clamp)?;
    let mut own = robot.new_link_poses();
    let mut held = robot.new_link_poses();
    let closing = (a..s).any(|t| {
        robot.forward_kinematics(&per_frame.wrists[t], per_frame.q(t), &mut own);
        robot.forward_kinematics(&hand.wrists[t], hand.q(t), &mut held);
        own.iter()
            .zip(&held)
            .any(|(x, y)| (x.translation.vector - y.translation.vector).norm() > FORMING_GAP_M)
    });
    if closing {
        let share = smooth::closing_shares(range.clone(), s, ease);
        smooth::release_held(hand, per_frame, objects, range, &share, 0);
    } else {
        // Formed at rest: held from the segment's first frame, the average over it all.
        hand.clone_from(per_frame);
        smooth::hold_grasp(hand, objects, range.clone(), range, clamp)?;
    }
    Ok(Some(HeldSpan {
        carry: [s, e],
        closing,
    }))
}

/// Reach within which a held grasp is checked against the barriers [m]: the IK's barrier
/// hinge (5 mm) plus room.
const HELD_BARRIER_REACH_M: f64 = 0.01;

/// Moves the held grasp `hand` toward `per_frame` where a barrier asks
/// ([`release_shares`], [`smooth::release_held`]) and says how far it went.
#[allow(clippy::too_many_arguments)]
fn yield_to_barriers(
    robot: &Robot,
    shapes: &[CollisionShape],
    hand: &mut HandPath,
    per_frame: &HandPath,
    objects: &[Isometry3<f64>],
    range: std::ops::RangeInclusive<usize>,
    clearance: f64,
    ease: usize,
) -> HeldYield {
    let share = release_shares(
        robot,
        shapes,
        hand,
        per_frame,
        objects,
        range.clone(),
        clearance,
    );
    let on_object = |h: &HandPath, t: usize| (objects[t].inverse() * h.wrists[t]).translation;
    let held: Vec<_> = range.clone().map(|t| on_object(hand, t)).collect();
    let frames = smooth::release_held(hand, per_frame, objects, range.clone(), &share, ease);
    let max_move_mm = range
        .zip(&held)
        .map(|(t, h)| (on_object(hand, t).vector - h.vector).norm() * 1e3)
        .fold(0.0, f64::max);
    HeldYield {
        frames,
        max_share: share.iter().copied().fold(0.0, f64::max),
        max_move_mm,
    }
}

/// Halvings of the share's interval in [`release_shares`]: 2⁻¹⁰ of the way between the two
/// hands, under 0.02 mm for the 11 mm a per-frame hand moved off a held grasp beside a wall.
const SHARE_BISECTIONS: usize = 10;

/// The share of the per-frame solution each frame of `range` needs
/// ([`smooth::release_held`]): 0 where the held grasp `held` keeps `clearance` from every
/// barrier (or comes no nearer than `per_frame` did); elsewhere the least share, to 2⁻¹⁰, that
/// takes the hand to `clearance`, or as far as the per-frame solution got when that is nearer.
/// The per-frame IK keeps its barrier hinge's reach (5 mm) where it can; the held grasp need
/// only keep the clearance the hand keeps outside the contact segment.
fn release_shares(
    robot: &Robot,
    shapes: &[CollisionShape],
    held: &HandPath,
    per_frame: &HandPath,
    objects: &[Isometry3<f64>],
    range: std::ops::RangeInclusive<usize>,
    clearance: f64,
) -> Vec<f64> {
    let links = crate::hand::pushout::LinkClearance::new(robot, shapes, HELD_BARRIER_REACH_M);
    let mut poses = robot.new_link_poses();
    let mut distance = |wrist: &Isometry3<f64>, q: &[f64]| {
        robot.forward_kinematics(wrist, q, &mut poses);
        links
            .nearest(&poses)
            .map_or(HELD_BARRIER_REACH_M, |(d, _, _)| d)
    };
    let mut q = vec![0.0; held.dof];
    range
        .map(|t| {
            // The goal is at most the clearance: a held hand that keeps it needs no
            // per-frame query.
            let at_held = distance(&held.wrists[t], held.q(t));
            if at_held >= clearance - 1e-4 {
                return 0.0;
            }
            let goal = clearance.min(distance(&per_frame.wrists[t], per_frame.q(t))) - 1e-4;
            if at_held >= goal {
                return 0.0;
            }
            let (mut lo, mut hi) = (0.0, 1.0);
            for _ in 0..SHARE_BISECTIONS {
                let mid = 0.5 * (lo + hi);
                let wrist = smooth::blend_toward(held, per_frame, &objects[t], t, mid, &mut q);
                if distance(&wrist, &q) >= goal {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            hi
        })
        .collect()
}

/// Stage 5b (non-penetrating objective): neither the smoothing, nor the fade at the
/// segment's ends, nor the push-out may press the hand deeper into the object than the IK
/// (or, outside the segment, the rigid transfer) left it.
pub(super) fn guard(
    robot: &Robot,
    object: &ObjectWarp,
    ik: &IkRun,
    hand: &mut HandPath,
    timing: &mut Timing,
) -> Option<hand_guard::Stats> {
    let (sdf, tolerance_m) = ik.guard_with.as_ref()?;
    let last = hand.len() - 1;
    let g = hand_guard::run(
        robot,
        sdf,
        |t| object.path().pose(t),
        &ik.raw,
        hand,
        0..=last,
        &hand_guard::Params {
            tolerance_m: *tolerance_m,
            ..hand_guard::Params::default()
        },
    );
    timing.insert("smooth_guard".into(), g.time_s);
    Some(g)
}

/// Stage 6: the physics replay, of the output as its file reads back, so `dexwarp validate`
/// of the written file gives the same report (one verdict per trajectory file).
pub(super) fn physics(
    inputs: &Inputs,
    options: &Options,
    params: &StageParams,
    out: &Demo,
    timing: &mut Timing,
) -> Result<Option<physics::PhysicsReport>> {
    let Some(params) = &params.physics else {
        return Ok(None);
    };
    let Inputs {
        config,
        robot,
        scene,
        mesh,
        ..
    } = inputs;
    let p = physics::validate(
        robot,
        &out.as_stored(&options.limits)?,
        scene,
        &config.barriers,
        mesh,
        params,
        &options.limits,
    )?;
    timing.insert("physics".into(), p.timing_s.total);
    checks::physics(&config.source, &p)?;
    Ok(Some(p))
}
