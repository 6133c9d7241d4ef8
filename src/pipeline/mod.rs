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

mod barriers;
mod checks;
mod params;
mod report;
mod stages;
mod validate;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub use barriers::shapes as barrier_shapes;
pub use checks::check_hand_path;
pub use params::{PhysicsOptions, StageParams, physics_params, physics_params_of};
pub use validate::{grasp_hold, validate, validate_demo};

use crate::geometry::Mesh;
use crate::hand::HandPath;
use crate::hand::ik::Solver;
use crate::model::frames::FrameRow;
use crate::model::report::Report;
use crate::model::{Demo, Frame, Scene, WarpConfig};
use crate::robot::Robot;
use crate::warp::{ObjectPath, ObjectWarp};
use crate::{Limits, Result};

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

/// Options of one warp run that are not part of the config: overrides on top of it. Build
/// them with [`Options::new`] and its setters; [`StageParams::resolve`] turns a config and
/// these into every stage's parameters.
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
    /// The physics replay on top of the config's parameters; `None` skips it (the report's
    /// `physics` is null).
    pub physics: Option<PhysicsOptions>,
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
    pub fn new(config: WarpConfig, demo: Demo, limits: &Limits) -> Result<Inputs> {
        crate::model::demo::require_file(&config.source, "scene", &config.scene)?;
        Inputs::with(config, Loaded::new(demo, limits)?, limits)
    }

    /// The inputs of a config with a demonstration, robot and mesh loaded before (`augment`
    /// loads them once for all its samples): loads the config's scene and checks it.
    pub fn with(config: WarpConfig, loaded: Loaded, limits: &Limits) -> Result<Inputs> {
        crate::model::demo::require_file(&config.source, "scene", &config.scene)?;
        let scene = Scene::load(&config.scene, limits)?;
        config.check_scene(&scene)?;
        let Loaded { demo, robot, mesh } = loaded;
        Ok(Inputs {
            config,
            demo,
            robot,
            scene,
            mesh,
        })
    }
}

/// A demonstration with the robot it names and its object's mesh, loaded and checked against
/// each other: the part of [`Inputs`] that does not depend on the config.
#[derive(Clone, Debug)]
pub struct Loaded {
    pub demo: Demo,
    pub robot: Robot,
    pub mesh: Mesh,
}

impl Loaded {
    /// Loads the robot `demo` names and its object's mesh, and checks `demo` against the
    /// robot (its joints are put in the robot's order).
    pub fn new(mut demo: Demo, limits: &Limits) -> Result<Loaded> {
        let robot = demo.load_robot(limits)?;
        demo.check_robot(&robot)?;
        let mesh = Mesh::load(&demo.object.mesh, nalgebra::Vector3::repeat(1.0), limits)?;
        Ok(Loaded { demo, robot, mesh })
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
    let input = ObjectPath::from_poses(demo.frames.iter().map(|f| &f.object));
    let params = StageParams::resolve(config, demo.fps, options)?;
    let plan = stages::plan(inputs, options, &params, &input)?;
    let radius = mesh.bounding_radius();
    let barrier_shapes = barriers::shapes(config, scene, &options.limits)?;
    let barriers = barriers::pushout_hulls(config, scene, &barrier_shapes, radius)?;

    // Stages 1-3: spatial warp, barrier push-out, retiming.
    let object = stages::object(
        inputs,
        &input,
        &plan,
        &barriers,
        &params.object,
        &mut timing,
    )?;
    // Stage 4: the rigid transfer: the baseline hand, and contact IK's first warm start.
    let base = stages::baseline(inputs, &object, &mut timing)?;
    let mut provenance = stages::provenance(inputs, options, &params);
    // Stages 4-5: contact IK and smoothing inside the contact segment (contact IK only).
    let (hand, ik) = match options.hand {
        HandMethod::Baseline => (base, None),
        HandMethod::Contact => {
            let (hand, ik) = stages::contact_ik(
                inputs,
                &params,
                &barrier_shapes,
                &object,
                &base,
                &mut provenance,
                &mut timing,
            )?;
            (hand, Some(ik))
        }
    };
    // Stage 4b: the hand's own path outside contact pushed out of the barriers.
    let (mut hand, hand_push) = barriers::hand_pushout(
        config,
        scene,
        robot,
        &barrier_shapes,
        &object,
        hand,
        &params.hand_pushout,
    )?;
    timing.insert("hand_pushout".into(), hand_push.time_s);
    // Stage 5b: no hand pressed deeper into the object than the IK left it.
    let guard = ik
        .as_ref()
        .and_then(|ik| stages::guard(robot, &object, ik, &mut hand, &mut timing));
    checks::hand(&config.source, "hand recovery (4-5)", &hand)?;
    let mut out = assemble(demo, &object, &hand, &config.name);
    out.scene = Some(config.scene.clone());
    out.barriers = config.barriers.clone();
    // Stage 6: physics replay.
    let physics = stages::physics(inputs, options, &params, &out, &mut timing)?;
    // Stages 7-8: metrics and report.
    let clock = Instant::now();
    let (mut report, frames) = report::warp_report(
        inputs,
        options,
        report::Stages {
            out: &out,
            object: &object,
            barriers: &barriers,
            ik: ik.as_ref(),
            guard: guard.as_ref(),
            hand_push: &hand_push,
            physics: physics.as_ref(),
            threshold_mm: params.ik.threshold_mm,
        },
    )?;
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
