//! What several commands share: size limits, workers, shards, physics flags, value parsers.

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use dexwarp::Limits;
use dexwarp::hand::ik::Solver;
use dexwarp::model::{Objective, WarmStart};
use dexwarp::pipeline::{HandMethod, PhysicsOptions};

/// Size limits on inputs; raise them for genuine large datasets. Every command shows them
/// under one "Limits" heading, after its own options.
#[derive(Debug, Args)]
#[command(next_help_heading = "Limits")]
pub struct LimitArgs {
    /// Largest JSON, URDF or mesh file read [MiB] (default 512).
    #[arg(long, global = true, value_name = "MIB")]
    max_file_mb: Option<u64>,
    /// Most frames in one demonstration (default 200000).
    #[arg(long, global = true, value_name = "N")]
    max_frames: Option<u64>,
    /// Most contact correspondences in one frame (default 2048).
    #[arg(long, global = true, value_name = "N")]
    max_contacts: Option<u64>,
    /// Most triangles in one mesh (default 5000000).
    #[arg(long, global = true, value_name = "N")]
    max_triangles: Option<u64>,
    /// Most links or joints in one robot (default 1024).
    #[arg(long, global = true, value_name = "N")]
    max_links: Option<u64>,
    /// Deepest XML element nesting in a URDF (default 64).
    #[arg(long, global = true, value_name = "N")]
    max_xml_depth: Option<u64>,
    /// Most physics steps of one replay, frames x steps per frame (default 10000000).
    #[arg(long, global = true, value_name = "N")]
    max_physics_steps: Option<u64>,
    /// Read devices and pipes as input files (the byte limit still applies).
    #[arg(long, global = true)]
    allow_special_files: bool,
}

impl LimitArgs {
    pub fn limits(&self) -> Limits {
        let mut l = Limits::default();
        if let Some(mb) = self.max_file_mb {
            l.max_file_bytes = mb.saturating_mul(1 << 20);
            l.max_mesh_bytes = mb.saturating_mul(1 << 20);
        }
        if let Some(n) = self.max_frames {
            l.max_frames = n;
        }
        if let Some(n) = self.max_contacts {
            l.max_contacts_per_frame = n;
        }
        if let Some(n) = self.max_triangles {
            l.max_mesh_triangles = n;
        }
        if let Some(n) = self.max_links {
            l.max_links = n;
        }
        if let Some(n) = self.max_xml_depth {
            l.max_xml_depth = n;
        }
        if let Some(n) = self.max_physics_steps {
            l.max_physics_steps = n;
        }
        l.allow_special_files = self.allow_special_files;
        l
    }
}

/// `--jobs`: worker threads.
#[derive(Debug, Args)]
pub struct Workers {
    /// Worker threads (default: one per core).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub jobs: usize,
}

impl Workers {
    /// The threads asked for, capped at [`MAX_JOBS_PER_CORE`] per core.
    pub fn jobs(&self) -> usize {
        capped_jobs(self.jobs)
    }
}

/// `--shard` and `--force`: which items of a job this process runs, and whether finished
/// ones are redone.
#[derive(Debug, Args)]
pub struct Sharding {
    /// Run only shard K of N (K is 0-based): the items (manifest lines, samples) whose
    /// index is K modulo N.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<dexwarp::batch::Shard>,
    /// Redo items that are already finished (by default they are skipped).
    #[arg(long)]
    pub force: bool,
}

/// `--out DIR`: the output folder of a run.
#[derive(Debug, Args)]
pub struct OutDir {
    /// Output folder (created when missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

/// The physics replay's flags of `warp` and `validate`.
#[derive(Debug, Args)]
pub struct PhysicsArgs {
    /// Also measure the robustness margin when physics passes: five more replays with
    /// less friction and more mass (report `physics.margin`, `physics.robust`).
    #[arg(long)]
    pub margin: bool,
    /// The hand in the physics replay: kinematic (on the trajectory; the default, unless a
    /// config's params.physics says otherwise) or actuated (joint motors capped at the
    /// URDF's effort limits, wrist on a stiff spring).
    #[arg(long, value_enum, value_name = "MODEL")]
    pub physics_hand: Option<PhysicsHandArg>,
    /// The object's collision shape: its convex parts (the default, unless a config's
    /// params.physics.decomposition.collider says otherwise) or the closed mesh itself (for
    /// thin-walled objects, whose convex parts come out filled).
    #[arg(long, value_enum, value_name = "SHAPE")]
    pub object_collider: Option<ObjectColliderArg>,
    #[command(flatten)]
    pub ensemble: EnsembleArgs,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ObjectColliderArg {
    /// Convex parts of the mesh (V-HACD).
    Parts,
    /// The closed mesh as a triangle mesh.
    Mesh,
}

impl From<ObjectColliderArg> for dexwarp::physics::ObjectCollider {
    fn from(a: ObjectColliderArg) -> Self {
        match a {
            ObjectColliderArg::Parts => dexwarp::physics::ObjectCollider::Parts,
            ObjectColliderArg::Mesh => dexwarp::physics::ObjectCollider::Mesh,
        }
    }
}

impl PhysicsArgs {
    /// The replay these flags ask for, on top of a config's physics parameters.
    pub fn options(&self) -> PhysicsOptions {
        PhysicsOptions {
            margin: self.margin,
            hand: self.physics_hand.map(Into::into),
            object_collider: self.object_collider.map(Into::into),
            ..self.ensemble.options()
        }
    }
}

/// The ensemble verdict's flags (`warp`, `validate`, `batch`, `augment`, `reproduce`).
#[derive(Debug, Args)]
pub struct EnsembleArgs {
    /// Replays per trajectory for the ensemble verdict, the nominal one included (default
    /// 8, or the config's params.physics.ensemble.members); 1 is a single nominal replay.
    /// The trajectory is kept when its pass fraction reaches the keep threshold (0.5).
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u32).range(1..=256))]
    pub ensemble: Option<u32>,
    /// Seed of the ensemble members' perturbations (default 0, mixed with each
    /// trajectory's name): the same seed gives the same reports.
    #[arg(long, value_name = "S")]
    pub ensemble_seed: Option<u64>,
    /// Most replays for a trajectory whose decision stays uncertain (its 95 % interval
    /// contains the keep threshold): K more at a time until it is certain or this many are
    /// replayed (default 32, or the config's params.physics.ensemble.max_members; K for none).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=256))]
    pub ensemble_max: Option<u32>,
}

impl EnsembleArgs {
    /// The physics options with only the ensemble set.
    pub fn options(&self) -> PhysicsOptions {
        PhysicsOptions {
            ensemble: self.ensemble.map(|k| k as usize),
            ensemble_seed: self.ensemble_seed,
            ensemble_max: self.ensemble_max.map(|n| n as usize),
            ..PhysicsOptions::default()
        }
    }
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum PhysicsHandArg {
    /// Every link kinematic, exactly on the trajectory (the grip comes from the fingers'
    /// overlap with the object through the contact skin).
    Kinematic,
    /// Every link dynamic: joints driven by position motors capped at the URDF's
    /// `<limit effort>`, the root link pulled to the trajectory by a stiff spring-damper.
    Actuated,
}

impl From<PhysicsHandArg> for dexwarp::physics::HandModel {
    fn from(h: PhysicsHandArg) -> Self {
        match h {
            PhysicsHandArg::Kinematic => dexwarp::physics::HandModel::Kinematic,
            PhysicsHandArg::Actuated => dexwarp::physics::HandModel::Actuated,
        }
    }
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum TrackingErrorArg {
    /// The correspondences (the default of the built-in demonstrations).
    Correspondences,
    /// The recorded hand's pose on the object.
    Hand,
}

impl From<TrackingErrorArg> for dexwarp::synth::contacts::TrackingError {
    fn from(t: TrackingErrorArg) -> Self {
        match t {
            TrackingErrorArg::Correspondences => Self::Correspondences,
            TrackingErrorArg::Hand => Self::Hand,
        }
    }
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum HandArg {
    /// Per-frame contact IK on the correspondences (the method).
    Contact,
    /// Rigid SE(3) transfer at the timewarp, B-spline in between (the paper's baseline).
    Baseline,
}

impl From<HandArg> for HandMethod {
    fn from(h: HandArg) -> Self {
        match h {
            HandArg::Contact => HandMethod::Contact,
            HandArg::Baseline => HandMethod::Baseline,
        }
    }
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ObjectiveArg {
    /// Contacts and barriers, plus fingers kept out of the object.
    NonPenetrating,
    /// The paper's objective as printed (contacts and barriers).
    Paper,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum WarmStartArg {
    /// The previous frame's solution (the paper).
    Previous,
    /// The previous frame's solution carried along by the object's motion.
    FollowObject,
    /// The rigid transfer of the recorded hand at that frame.
    Rigid,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum SolverArg {
    /// Levenberg-Marquardt with analytic Jacobians.
    Lm,
    /// Adam, learning rate 0.01, as in the paper.
    Adam,
}

impl From<ObjectiveArg> for Objective {
    fn from(o: ObjectiveArg) -> Self {
        match o {
            ObjectiveArg::NonPenetrating => Objective::NonPenetrating,
            ObjectiveArg::Paper => Objective::Paper,
        }
    }
}

impl From<WarmStartArg> for WarmStart {
    fn from(w: WarmStartArg) -> Self {
        match w {
            WarmStartArg::Previous => WarmStart::Previous,
            WarmStartArg::FollowObject => WarmStart::FollowObject,
            WarmStartArg::Rigid => WarmStart::Rigid,
        }
    }
}

impl From<SolverArg> for Solver {
    fn from(s: SolverArg) -> Self {
        match s {
            SolverArg::Lm => Solver::Lm,
            SolverArg::Adam => Solver::Adam,
        }
    }
}

pub fn positive_mm(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        Ok(v) if v.is_finite() => Err(format!(
            "the value must be positive: a distance in millimetres > 0, like 3.5; got {v}"
        )),
        _ => Err(format!(
            "expected a finite distance in millimetres > 0, like 3.5; got {s:?}"
        )),
    }
}

pub fn positive_deg(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!(
            "expected a finite angle in degrees > 0, like 15; got {s:?}"
        )),
    }
}

pub fn non_negative(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        Ok(v) if v.is_finite() => Err(format!(
            "the value must not be negative: a finite number >= 0, like 2; got {v}"
        )),
        _ => Err(format!("expected a finite number >= 0, like 2; got {s:?}")),
    }
}

pub fn fraction(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        _ => Err(format!(
            "expected a number from 0 to 1, like 0.99; got {s:?}"
        )),
    }
}

/// Worker threads asked for, capped at [`MAX_JOBS_PER_CORE`] per core with a message: more
/// threads than that only add switching and memory (5000 jobs ran 30x slower than 2).
pub fn capped_jobs(jobs: usize) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let cap = MAX_JOBS_PER_CORE * cores;
    if jobs > cap {
        eprintln!(
            "note: --jobs {jobs} is more than {MAX_JOBS_PER_CORE} per core; using {cap} ({cores} cores)"
        );
        cap
    } else {
        jobs
    }
}

/// Most worker threads per core `--jobs` may ask for.
const MAX_JOBS_PER_CORE: usize = 4;

/// The last line of `warp` and `validate`: the verdict and its first reason.
pub fn verdict_line(report: &dexwarp::model::report::Report) -> String {
    match &report.physics {
        None => "verdict: not run (no physics replay)".into(),
        Some(p) => match p.reasons.first() {
            Some(r) => format!("verdict: {} ({r})", p.verdict),
            None => format!("verdict: {}", p.verdict),
        },
    }
}
