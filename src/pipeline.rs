//! The pipeline: one function, one line per stage, in the order of docs/METHOD.md.
//!
//! [`warp`] runs, for one config:
//! 1. spatial warp of the object through the waypoints ([`crate::warp::spatial`]),
//! 2. barrier push-out of the object ([`crate::warp::barrier`]),
//! 3. temporal retiming: global C² B-spline and the timewarp τ ([`crate::warp::retime`]),
//! 4. hand recovery: per-frame contact IK ([`crate::hand::ik`]) warm-started from the SE(3)
//!    baseline ([`crate::hand::baseline`]), or the baseline alone; outside the contact
//!    segment the hand's path is pushed out of the barriers ([`crate::hand::pushout`]),
//! 5. smoothing of the hand (contact IK only), and with the non-penetrating objective the
//!    guard that keeps it from pressing the hand into the object ([`crate::hand::guard`]),
//! 6. physics replay in Rapier ([`crate::physics`]),
//! 7. metrics ([`crate::metrics`]),
//! 8. report ([`crate::model::report`]).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use rapier3d_f64::parry::query;
use rapier3d_f64::parry::shape::SharedShape;

use crate::geometry::Mesh;
use crate::geometry::shape::CollisionShape;
use crate::hand::ik::{self, Solver};
use crate::hand::{HandPath, baseline, guard, pushout, smooth};
use crate::math::convert::to_pose;
use crate::metrics;
use crate::model::Objective;
use crate::model::frames::FrameRow;
use crate::model::provenance::Provenance;
use crate::model::report::{
    Constraints, ContactDistance, GuardSummary, IkSummary, Metrics, Pair, REPORT_FORMAT, Report,
    WorstFrame,
};
use crate::model::{Demo, Frame, Scene, WarpConfig};
use crate::physics;
use crate::robot::Robot;
use crate::warp::barrier::{Barrier, item_hull_points};
use crate::warp::{ObjectParams, ObjectPath, ObjectWarp, WarpPlan, warp_object};
use crate::{Error, Limits, Result};

/// How the hand is recovered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HandMethod {
    /// Per-frame contact IK on the correspondences (the method).
    #[default]
    Contact,
    /// Rigid SE(3) transfer at τ, B-spline in between (the paper's baseline).
    Baseline,
}

impl HandMethod {
    pub fn as_str(self) -> &'static str {
        match self {
            HandMethod::Contact => "contact",
            HandMethod::Baseline => "baseline",
        }
    }
}

/// Options of one warp run that are not part of the config.
#[derive(Clone, Debug, Default)]
pub struct Options {
    /// Demonstration to warp instead of the one the config names.
    pub demo: Option<PathBuf>,
    /// IK threshold overriding the config's [mm].
    pub threshold_mm: Option<f64>,
    pub hand: HandMethod,
    /// IK solver (contact IK only).
    pub solver: Solver,
    /// IK objective overriding the config's.
    pub objective: Option<crate::model::Objective>,
    /// IK penetration weight overriding the config's.
    pub penetration_weight: Option<f64>,
    /// IK warm start overriding the config's.
    pub warm_start: Option<crate::model::WarmStart>,
    /// Physics replay parameters; `None` skips the replay (the report's `physics` is null).
    pub physics: Option<physics::Params>,
    pub limits: Limits,
}

/// Everything a warp run produces.
#[derive(Debug)]
pub struct WarpRun {
    /// The output demonstration (with `timewarp`).
    pub demo: Demo,
    pub report: Report,
    pub object: ObjectWarp,
    pub hand: HandPath,
    /// Per-frame metrics (`frames.csv`).
    pub frames: Vec<FrameRow>,
}

/// The inputs of a warp, loaded and checked against each other.
#[derive(Debug)]
pub struct Inputs {
    pub config: WarpConfig,
    pub demo: Demo,
    pub robot: Robot,
    pub scene: Scene,
    pub mesh: Mesh,
}

impl Inputs {
    /// Loads the config, its demonstration (or `demo`), robot, scene and object mesh.
    pub fn load(config: &Path, demo: Option<&Path>, limits: &Limits) -> Result<Inputs> {
        let config = WarpConfig::load(config, limits)?;
        // Missing files named by the config are errors of its fields.
        if demo.is_none() {
            crate::model::demo::require_file(&config.source, "demo", &config.demo)?;
        }
        crate::model::demo::require_file(&config.source, "scene", &config.scene)?;
        let demo_path = demo
            .map(Path::to_path_buf)
            .unwrap_or_else(|| config.demo.clone());
        let demo = Demo::load(&demo_path, limits)?;
        Inputs::new(config, demo, limits)
    }

    /// The inputs of a config and a demonstration already in memory (the Python binding's
    /// entry point; [`Inputs::load`] ends here too): loads the robot the demonstration names,
    /// the config's scene and the object mesh, and checks them against each other. The
    /// config's own `demo` is not read.
    pub fn new(config: WarpConfig, mut demo: Demo, limits: &Limits) -> Result<Inputs> {
        crate::model::demo::require_file(&config.source, "scene", &config.scene)?;
        let robot = demo.load_robot(limits)?;
        demo.check_robot(&robot)?;
        let scene = Scene::load(&config.scene, limits)?;
        config.check_scene(&scene)?;
        let mesh = Mesh::load(&demo.object.mesh, nalgebra::Vector3::repeat(1.0), limits)?;
        Ok(Inputs {
            config,
            demo,
            robot,
            scene,
            mesh,
        })
    }
}

impl Inputs {
    /// The files these inputs were read from: config, demonstration, scene, robot, mesh.
    pub fn paths(&self) -> [&Path; 5] {
        [
            &self.config.source,
            &self.demo.source,
            &self.config.scene,
            &self.demo.robot,
            &self.demo.object.mesh,
        ]
    }
}

/// How long the IK hand's difference from the rigid transfer fades out beyond each end of
/// the contact segment [s] (stage 5c, [`smooth::ease_ends`]).
const EASE_S: f64 = 0.25;

/// Runs the pipeline on loaded inputs (see the module docs for the stages).
pub fn warp(inputs: &Inputs, options: &Options) -> Result<WarpRun> {
    let Inputs {
        config,
        demo,
        robot,
        scene,
        mesh,
    } = inputs;
    let mut timing = BTreeMap::new();
    let segment = demo.contact_segment().ok_or_else(|| {
        Error::invalid(
            &demo.source,
            "frames",
            "no frame has contact correspondences; a warp needs an in-contact segment",
        )
    })?;
    let input = ObjectPath::from_poses(demo.frames.iter().map(|f| &f.object));
    let plan = WarpPlan::new(config, &input.positions, segment)?;
    options
        .limits
        .check_output_frames(&config.source, plan.frames_out() as u64)?;
    if let Some(p) = &options.physics {
        check_physics_work(
            &options.limits,
            &config.source,
            plan.frames_out(),
            demo.fps,
            p,
        )?;
    }
    let radius = mesh.bounding_radius();
    let barriers = prepare_barriers(config, scene, radius, &options.limits)?;
    let params = ObjectParams::from_config(&config.params);

    // Stages 1-3: spatial warp, barrier push-out, retiming.
    let object = warp_object(&input, &plan, &barriers, radius, &params, &config.source)?;
    timing.insert("spatial".into(), object.spatial.stats.time_s);
    timing.insert("barrier".into(), object.barrier.stats.time_s);
    timing.insert("retime".into(), object.retime.stats.time_s);
    check_path(&config.source, "object warp (1-3)", object.path())?;

    // Stage 4: hand recovery (the baseline is also contact IK's first warm start).
    let clock = Instant::now();
    let threshold = options.threshold_mm.unwrap_or(config.params.threshold_mm);
    let base = baseline::run(demo, &object)
        .map_err(|e| Error::invalid(&config.source, "(hand)", e.to_string()))?;
    timing.insert("baseline".into(), clock.elapsed().as_secs_f64());
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
            "threshold_mm": threshold,
            "solver": options.solver,
            "physics": options.physics.is_some(),
        }),
    );
    provenance.parameters("limits", &options.limits);
    if let Some(p) = &options.physics {
        provenance.parameters("physics", p);
    }
    let mut unsmoothed: Option<HandPath> = None;
    let mut guard_stats: Option<guard::Stats> = None;
    let mut guard_with = None;
    let mut ik_tolerance_mm: Option<f64> = None;
    let (hand, ik_stats) = match options.hand {
        HandMethod::Baseline => (base, None),
        HandMethod::Contact => {
            let shapes = barrier_shapes(config, scene, &options.limits)?;
            let object_sdf = crate::geometry::object_sdf(mesh);
            let tolerance_mm = config.params.penetration_tolerance_mm.unwrap_or_else(|| {
                crate::model::config::auto_penetration_tolerance_mm(
                    object_sdf.as_deref().map_or(0.0, |sdf| {
                        metrics::max_hand_object_penetration_mm(robot, demo, sdf)
                    }),
                )
            });
            ik_tolerance_mm = Some(tolerance_mm);
            let params = ik::Params {
                solver: options.solver,
                threshold_mm: threshold,
                margin_m: config.params.margin_m,
                steepness: config.params.steepness,
                objective: options.objective.unwrap_or(config.params.objective),
                penetration_tolerance_mm: tolerance_mm,
                penetration_weight: options
                    .penetration_weight
                    .unwrap_or(config.params.penetration_weight),
                warm_start: options.warm_start.unwrap_or(config.params.warm_start),
                ..ik::Params::default()
            };
            provenance.parameters("ik", &params);
            provenance.parameters("smooth", &smooth::Params::default());
            let (raw, stats) = ik::run(
                robot,
                demo,
                &object,
                &base,
                &shapes,
                object_sdf.as_deref(),
                &params,
            );
            timing.insert("ik".into(), stats.time_s);

            // Stage 5: smoothing inside the contact segment.
            let clock = Instant::now();
            let range = object.plan.segment.start..=object.plan.t_end_new();
            let (mut hand, _) = smooth::run(&raw, range.clone(), &smooth::Params::default())
                .map_err(|e| Error::invalid(&config.source, "(smoothing)", e.to_string()))?;
            // Stage 5c: no jump between the IK hand and the rigid transfer at the segment's
            // ends: the difference fades out over `EASE_S` outside it.
            let ease = ((EASE_S * demo.fps).round() as usize).max(1);
            smooth::ease_ends(&mut hand, &base, range.clone(), ease, |q| {
                robot.clamp(q);
            });
            timing.insert("smooth".into(), clock.elapsed().as_secs_f64());

            if let (Objective::NonPenetrating, Some(sdf)) = (params.objective, object_sdf) {
                guard_with = Some((sdf, params.penetration_tolerance_mm * 1e-3));
            }
            unsmoothed = Some(raw);
            (hand, Some(stats))
        }
    };

    // Stage 4b: the hand's own path outside contact pushed out of the barriers.
    let (mut hand, hand_push) = hand_pushout(config, scene, &object, hand, &options.limits)?;
    timing.insert("hand_pushout".into(), hand_push.time_s);

    // Stage 5b (non-penetrating objective): neither the smoothing, nor the fade at the
    // segment's ends, nor the push-out may press the hand deeper into the object than the
    // IK (or, outside the segment, the rigid transfer) left it.
    if let (Some((sdf, tolerance_m)), Some(raw)) = (&guard_with, &unsmoothed) {
        let last = hand.len() - 1;
        let g = guard::run(
            robot,
            sdf,
            |t| object.path().pose(t),
            raw,
            &mut hand,
            0..=last,
            &guard::Params {
                tolerance_m: *tolerance_m,
                ..guard::Params::default()
            },
        );
        timing.insert("smooth_guard".into(), g.time_s);
        guard_stats = Some(g);
    }

    check_hand(&config.source, "hand recovery (4-5)", &hand)?;
    let mut out = assemble(demo, &object, &hand, &config.name);
    out.scene = Some(config.scene.clone());
    out.barriers = config.barriers.clone();

    // Stage 6: physics replay, of the output as its file reads back, so `dexwarp validate`
    // of the written file gives the same report (one verdict per trajectory file).
    let physics = match &options.physics {
        Some(params) => Some(physics::validate(
            robot,
            &out.as_stored(&options.limits)?,
            scene,
            &config.barriers,
            mesh,
            params,
            &options.limits,
        )?),
        None => None,
    };
    if let Some(p) = &physics {
        timing.insert("physics".into(), p.timing_s.total);
        check_physics(&config.source, p)?;
    }

    // Stages 7-8: metrics and report.
    let clock = Instant::now();
    let threshold = options.threshold_mm.unwrap_or(config.params.threshold_mm);
    let dc_frames = metrics::contact_distance_per_frame_mm(robot, &out);
    let mut report = report(demo, &out, &dc_frames, robot, &object, &barriers, mesh)?;
    let mut frames = frame_rows(&out, &object, &dc_frames);
    if let Some(raw) = &unsmoothed {
        // D_C before smoothing (the paper's drift is the difference).
        let before = metrics::contact_distance_per_frame_mm(
            robot,
            &assemble(demo, &object, raw, &config.name),
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
    report.config = Some(config.source.display().to_string());
    report.threshold_mm = Some(threshold);
    report.hand = Some(options.hand.as_str().into());
    if let Some(p) = &physics {
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
    if let Some(st) = &ik_stats {
        report.solver = Some(st.solver.as_str().into());
        report.ik = Some(IkSummary {
            converged_fraction: st.converged_fraction,
            not_converged_frames: st.not_converged.clone(),
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
            penetration_tolerance_mm: ik_tolerance_mm,
            smoothing_guard: guard_stats.as_ref().map(|g| GuardSummary {
                frames_too_deep: g.frames_too_deep,
                frames_blended: g.frames_blended,
                max_depth_before_mm: g.max_depth_before_mm,
                max_depth_after_mm: g.max_depth_after_mm,
            }),
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
    check_metrics(&config.source, &report, &frames)?;
    report.provenance = Some(provenance);
    timing.insert("metrics".into(), clock.elapsed().as_secs_f64());
    report.timing_s = timing;
    Ok(WarpRun {
        demo: out,
        report,
        object,
        hand,
        frames,
    })
}

/// Stage 4b: the barriers prepared with the hand radius, and the hand push-out outside the
/// contact segment ([`pushout`]).
fn hand_pushout(
    config: &WarpConfig,
    scene: &Scene,
    object: &ObjectWarp,
    hand: HandPath,
    limits: &Limits,
) -> Result<(HandPath, pushout::Stats)> {
    let params = pushout::Params {
        radius_m: config.params.hand_radius_m,
        mode: config.params.pushout,
        step_m: config.params.pushout_step_m,
        ..pushout::Params::default()
    };
    let barriers = if params.radius_m > 0.0 {
        prepare_barriers(config, scene, params.radius_m, limits)?
    } else {
        Vec::new()
    };
    Ok(pushout::run(hand, &object.plan, &barriers, &params))
}

/// The barriers a config names, as world-frame collision shapes (the IK barrier term).
pub fn barrier_shapes(
    config: &WarpConfig,
    scene: &Scene,
    limits: &Limits,
) -> Result<Vec<CollisionShape>> {
    config
        .barriers
        .iter()
        .map(|name| {
            scene.collision_shape(scene.item(name).expect("checked by check_scene"), limits)
        })
        .collect()
}

/// The barriers a config names, prepared for the push-out.
pub fn prepare_barriers(
    config: &WarpConfig,
    scene: &Scene,
    radius: f64,
    limits: &Limits,
) -> Result<Vec<Barrier>> {
    config
        .barriers
        .iter()
        .enumerate()
        .map(|(j, name)| {
            let item = scene.item(name).expect("checked by check_scene");
            let pts = item_hull_points(item, limits)?;
            Barrier::from_points(name, &pts, radius).ok_or_else(|| {
                Error::invalid(
                    &scene.source,
                    format!("items[{name:?}]"),
                    format!(
                        "barriers[{j}] has a flat or degenerate convex hull; give it a thickness"
                    ),
                )
            })
        })
        .collect()
}

/// The output demonstration: warped object, recovered hand, contacts of `t*` (the last input
/// frame mapped at or before each output frame), and the timewarp.
pub fn assemble(demo: &Demo, object: &ObjectWarp, hand: &HandPath, name: &str) -> Demo {
    let plan = &object.plan;
    let tw = &object.retime.timewarp;
    let path = object.path();
    let frames = (0..plan.frames_out())
        .map(|t| {
            let src = object.source_frame(t);
            Frame {
                object: path.pose(t),
                wrist: hand.wrists[t],
                joints: hand.q(t).to_vec(),
                contacts: demo.frames[src].contacts.clone(),
            }
        })
        .collect();
    Demo {
        name: name.to_string(),
        fps: demo.fps,
        robot: demo.robot.clone(),
        object: demo.object.clone(),
        joint_names: demo.joint_names.clone(),
        frames,
        timewarp: Some(tw.tau.clone()),
        scene: None,
        barriers: Vec::new(),
        wrist_link: demo.wrist_link.clone(),
        source: demo.source.clone(),
    }
}

fn report(
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

/// Replays any demonstration, warped or original, in physics and reports on it
/// (`dexwarp validate`): the physics verdict, D_WO, D_C and, for warped outputs, the timewarp
/// discrepancy. The scene is the demonstration's own (`scene`, `barriers` in the file) unless
/// `scene` is given.
pub fn validate(
    demo_path: &Path,
    scene: Option<&Path>,
    barriers: Option<&[String]>,
    params: &physics::Params,
    limits: &Limits,
) -> Result<(Report, Vec<FrameRow>)> {
    validate_demo(
        Demo::load(demo_path, limits)?,
        scene,
        barriers,
        params,
        limits,
    )
}

/// [`validate`] of a demonstration already in memory (the Python binding's entry point;
/// [`validate`] ends here too); messages and the report's provenance name [`Demo::source`].
pub fn validate_demo(
    mut demo: Demo,
    scene: Option<&Path>,
    barriers: Option<&[String]>,
    params: &physics::Params,
    limits: &Limits,
) -> Result<(Report, Vec<FrameRow>)> {
    let source = demo.source.clone();
    let demo_path = source.as_path();
    let robot = demo.load_robot(limits)?;
    demo.check_robot(&robot)?;
    let scene_path = match (scene, &demo.scene) {
        (Some(s), _) => s.to_path_buf(),
        (None, Some(s)) => s.clone(),
        (None, None) => {
            return Err(Error::invalid(
                demo_path,
                "scene",
                "the demonstration names no scene; give one with --scene (e.g. scenes/kitchen.json)",
            ));
        }
    };
    let scene = Scene::load(&scene_path, limits)?;
    let barriers: Vec<String> = barriers
        .map(<[String]>::to_vec)
        .unwrap_or_else(|| demo.barriers.clone());
    for (j, b) in barriers.iter().enumerate() {
        if scene.item(b).is_none() {
            return Err(Error::invalid(
                demo_path,
                format!("barriers[{j}]"),
                format!("{b:?} is not an item of scene {}", scene_path.display()),
            ));
        }
    }
    let mesh = Mesh::load(&demo.object.mesh, nalgebra::Vector3::repeat(1.0), limits)?;
    check_physics_work(limits, demo_path, demo.frames.len(), demo.fps, params)?;
    let report_p = physics::validate(&robot, &demo, &scene, &barriers, &mesh, params, limits)?;
    check_physics(demo_path, &report_p)?;
    let dc = metrics::contact_distance_per_frame_mm(&robot, &demo);
    let d_c = metrics::d_c_mm(&dc);
    let d_wo = metrics::d_wo_mm(&demo);
    let n = demo.frames.len();
    let discrepancy = demo
        .timewarp
        .as_ref()
        .map(|tau| {
            crate::warp::retime::Timewarp {
                tau: tau.clone(),
                frames_out: n,
            }
            .discrepancy()
        })
        .unwrap_or(0.0);
    let segment = demo.contact_segment();
    let frames: Vec<FrameRow> = (0..n)
        .map(|t| FrameRow {
            physics_position_error_mm: report_p.per_frame.position_error_mm.get(t).copied(),
            physics_rotation_error_deg: report_p.per_frame.rotation_error_deg.get(t).copied(),
            ..FrameRow::new(
                &demo,
                t,
                t,
                segment.is_some_and(|s| (s.start..=s.end).contains(&t)),
                dc[t],
            )
        })
        .collect();
    let mut timing_s = BTreeMap::new();
    timing_s.insert("physics".to_string(), report_p.timing_s.total);
    let report = Report {
        format: REPORT_FORMAT.into(),
        name: demo.name.clone(),
        frames_in: demo.timewarp.as_ref().map_or(n, Vec::len),
        frames_out: n,
        metrics: Metrics {
            d_wo_mm: Pair {
                original: d_wo,
                warped: d_wo,
            },
            d_c_mm: ContactDistance {
                original: d_c,
                unsmoothed: d_c,
                warped: d_c,
                uncorrupted: None,
            },
            plr_object: 1.0,
            plr_hand: 1.0,
            timewarp_discrepancy: discrepancy,
            timewarp_discrepancy_paper: None,
            d_c_worst: metrics::worst_frame(&dc)
                .map(|(frame, d_c_mm)| WorstFrame { frame, d_c_mm }),
            ..Metrics::default()
        },
        constraints: Constraints {
            object_radius_mm: mesh.bounding_radius() * 1e3,
            contact_gap_frames: segment.map_or(0, |s| s.gap_frames),
            ..Constraints::default()
        },
        physics: Some(report_p.to_summary()),
        timing_s,
        ..Report::default()
    };
    check_metrics(demo_path, &report, &frames)?;
    let mut provenance = Provenance::new();
    provenance.input("demo", demo_path);
    provenance.input("scene", &scene_path);
    provenance.input("robot", &demo.robot);
    provenance.input("mesh", &demo.object.mesh);
    provenance.parameters("barriers", &barriers);
    provenance.parameters("physics", params);
    provenance.parameters("limits", limits);
    let report = Report {
        provenance: Some(provenance),
        ..report
    };
    Ok((report, frames))
}

/// Refuses a replay whose step count (frames × steps per frame at `params.max_dt_s`) is over
/// [`Limits::max_physics_steps`], before any step: the count grows as 1 / fps.
fn check_physics_work(
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
fn check_path(path: &Path, stage: &'static str, object: &ObjectPath) -> Result<()> {
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
fn check_hand(path: &Path, stage: &'static str, hand: &HandPath) -> Result<()> {
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
fn check_physics(path: &Path, p: &physics::PhysicsReport) -> Result<()> {
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
fn check_metrics(path: &Path, report: &Report, frames: &[FrameRow]) -> Result<()> {
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
    check_hand(path, "hand recovery (4-5)", hand)
}
