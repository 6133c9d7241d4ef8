//! The `dexwarp` command line: a thin layer over the library.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Result;
use clap::{Args, Parser, Subcommand, ValueEnum};
use dexwarp::hand::ik::Solver;
use dexwarp::pipeline::{self, HandMethod, Inputs, Options};
use dexwarp::robot::Robot;
use dexwarp::{Limits, batch, filter};

/// Warp one dexterous-manipulation demonstration into many.
///
/// dexwarp moves the object of a demonstration through new waypoints, around barriers, on a
/// new timing and from a new start to a new end, recovers the hand by contact IK, replays every
/// output in physics, and writes a quality report per trajectory.
#[derive(Debug, Parser)]
#[command(name = "dexwarp", version, propagate_version = true)]
struct Cli {
    #[command(flatten)]
    limits: LimitArgs,
    #[command(subcommand)]
    command: Command,
}

/// Size limits on inputs; raise them for genuine large datasets.
#[derive(Debug, Args)]
struct LimitArgs {
    /// Largest JSON, URDF or mesh file read [MiB] (default 512).
    #[arg(long, global = true, value_name = "MIB")]
    max_file_mb: Option<u64>,
    /// Most frames in one demonstration (default 1000000).
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
    fn limits(&self) -> Limits {
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

#[derive(Debug, Subcommand)]
enum Command {
    /// The main job: every config in scenes/configs at the paper's thresholds, with Adam and
    /// the baseline, the robustness sweep, physics on every output; the paper's tables and an
    /// HTML report.
    #[command(
        after_help = "Run it from the repository root (it reads scenes/ and robots/ there).\n\nExamples:\n  dexwarp reproduce\n  dexwarp reproduce --quick --out /tmp/quick\n  dexwarp reproduce --out reports/latest --jobs 2"
    )]
    Reproduce {
        /// Output folder.
        #[arg(long, value_name = "DIR", default_value = "reports/latest")]
        out: PathBuf,
        /// A quick pass: Adam on three configs only, robustness at 0/50/100 %.
        #[arg(long)]
        quick: bool,
        /// Worker threads (default: one per core).
        #[arg(long, value_name = "N", default_value_t = 0)]
        jobs: usize,
        /// Folder holding scenes/configs (default: the current folder, else the source tree
        /// this binary was built from).
        #[arg(long, value_name = "DIR")]
        root: Option<PathBuf>,
    },
    /// Make a demonstration: the object resting on a support, the hand reaching and grasping
    /// it (contact IK), a scripted motion, release and retreat, with geometric correspondences.
    #[command(
        after_help = "Objects: cube, frying_pan, mug, teapot, apple, small_box. Motions: lift_place, pour, pass.\n\nExamples:\n  dexwarp synth --object mug --robot robots/human_hand.urdf --motion pass --out out/mug.demo.json\n  dexwarp synth --object apple --robot robots/allegro_hand.urdf --motion lift_place --out out/apple.demo.json --noise-mm 2 --seed 3"
    )]
    Synth {
        /// Object name.
        #[arg(long, value_name = "NAME")]
        object: String,
        /// URDF of the hand.
        #[arg(long, value_name = "URDF")]
        robot: PathBuf,
        /// Motion name.
        #[arg(long, value_name = "NAME")]
        motion: String,
        /// Output demonstration file (the object mesh is written beside it unless --mesh).
        #[arg(long, value_name = "FILE")]
        out: PathBuf,
        /// Existing object mesh to reference instead of writing one.
        #[arg(long, value_name = "FILE")]
        mesh: Option<PathBuf>,
        /// Seed of the correspondence noise.
        #[arg(long, value_name = "N")]
        seed: Option<u64>,
        /// Correspondence noise, standard deviation per axis [mm].
        #[arg(long, value_name = "MM", value_parser = non_negative, allow_negative_numbers = true)]
        noise_mm: Option<f64>,
        /// Fingertip links, comma-separated (default: our hands' templates, else the leaf links).
        #[arg(long, value_name = "A,B,C", value_delimiter = ',')]
        tips: Option<Vec<String>>,
        /// The link whose pose is the wrist (default: the fingertips' common link, moved up
        /// through fixed joints); links above it are dropped.
        #[arg(long, value_name = "LINK")]
        wrist_link: Option<String>,
    },
    /// Load a hand and print its links, DoF, joint limits, mimic joints and collision shapes.
    #[command(
        after_help = "Examples:\n  dexwarp robot robots/human_hand.urdf\n  dexwarp robot robots/parallel_gripper.urdf"
    )]
    Robot {
        /// URDF file.
        urdf: PathBuf,
        /// The link whose pose is the wrist (default: the URDF root); links above it are dropped.
        #[arg(long, value_name = "LINK")]
        wrist_link: Option<String>,
    },
    /// Warp one demonstration with one config; writes DIR/<name>.demo.json, DIR/report.json and
    /// DIR/frames.csv.
    #[command(
        after_help = "Examples:\n  dexwarp warp --config scenes/configs/mug_pass_wall.json --out out/mug\n  dexwarp warp --config my.json --demo my.demo.json --out out/x --hand baseline\n  dexwarp warp --config scenes/configs/teapot_pour_cups.json --out out/t --threshold-mm 5 --solver adam"
    )]
    Warp {
        /// Warp config (`dexwarp.config/1`).
        #[arg(long, value_name = "FILE")]
        config: PathBuf,
        /// Demonstration to warp instead of the one the config names.
        #[arg(long, value_name = "FILE")]
        demo: Option<PathBuf>,
        /// Output folder.
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        /// IK stop threshold on the mean contact distance [mm] (overrides the config).
        #[arg(long, value_name = "MM", value_parser = positive_mm, allow_negative_numbers = true)]
        threshold_mm: Option<f64>,
        /// How the hand is recovered.
        #[arg(long, value_enum, default_value_t = HandArg::Contact)]
        hand: HandArg,
        /// IK solver for contact IK: lm (fast, default) or adam (the paper's).
        #[arg(long, value_enum, default_value_t = SolverArg::Lm)]
        solver: SolverArg,
        /// Skip the physics replay (the report's physics is null).
        #[arg(long)]
        no_physics: bool,
        /// IK objective (overrides the config): non-penetrating (default: fingers kept out of
        /// the object) or paper (the paper's objective as printed).
        #[arg(long, value_enum, value_name = "OBJ")]
        objective: Option<ObjectiveArg>,
        /// Weight of the IK's non-penetration term (overrides the config; 0 = off).
        #[arg(long, value_name = "W", value_parser = non_negative, allow_negative_numbers = true)]
        penetration_weight: Option<f64>,
        /// IK warm start (overrides the config): previous (the paper) or follow-object.
        #[arg(long, value_enum, value_name = "HOW")]
        warm_start: Option<WarmStartArg>,
        /// Also measure the robustness margin when physics passes: five more replays with
        /// less friction and more mass (report `physics.margin`, `physics.robust`).
        #[arg(long, conflicts_with = "no_physics")]
        margin: bool,
        /// The hand in the physics replay: kinematic (on the trajectory, the default) or
        /// actuated (joint motors capped at the URDF's effort limits, wrist on a stiff spring).
        #[arg(
            long,
            value_enum,
            value_name = "MODEL",
            default_value = "kinematic",
            conflicts_with = "no_physics"
        )]
        physics_hand: PhysicsHandArg,
    },
    /// Replay any demonstration, warped or original, in physics; write DIR/report.json and
    /// DIR/frames.csv.
    #[command(
        after_help = "The scene and barriers are the ones the demonstration names (warp and synth outputs name theirs). Exits 0 whatever the verdict (read it in report.json), or 3 on a failed verdict with --strict.\n\nExamples:\n  dexwarp validate scenes/demos/mug.demo.json --out out/mug_check\n  dexwarp validate out/mug/mug_pass_wall.demo.json --out out/mug_check\n  dexwarp validate my.demo.json --scene scenes/kitchen.json --barrier wall_back --out out/x"
    )]
    Validate {
        /// Demonstration (`dexwarp.demo/1`).
        demo: PathBuf,
        /// Output folder.
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        /// Scene to replay in instead of the demonstration's own.
        #[arg(long, value_name = "FILE")]
        scene: Option<PathBuf>,
        /// Barrier to check against (repeat for several); default: the demonstration's own.
        #[arg(long = "barrier", value_name = "NAME")]
        barriers: Vec<String>,
        /// Also measure the robustness margin when physics passes (see `warp --margin`).
        #[arg(long)]
        margin: bool,
        /// The hand in the physics replay (see `warp --physics-hand`).
        #[arg(long, value_enum, value_name = "MODEL", default_value = "kinematic")]
        physics_hand: PhysicsHandArg,
        /// Exit non-zero (status 3) when the physics verdict is fail.
        #[arg(long)]
        strict: bool,
    },
    /// Run many (demo, config) items of a manifest in parallel; a failed item is recorded and
    /// the rest go on.
    #[command(
        after_help = "The manifest is JSON Lines, one item per line (paths relative to it):\n  {\"config\": \"scenes/configs/mug_pass_wall.json\", \"threshold_mm\": 5}\n  {\"config\": \"scenes/configs/cube_messy.json\", \"hand\": \"baseline\", \"name\": \"cube_base\"}\n\nExamples:\n  dexwarp batch items.jsonl --out out/batch --jobs 2\n  dexwarp batch items.jsonl --out out/batch --shard $SLURM_ARRAY_TASK_ID/8\n  dexwarp batch items.jsonl --out out/batch --shard $JOB_COMPLETION_INDEX/8 --force"
    )]
    Batch {
        /// Manifest (JSON Lines).
        manifest: PathBuf,
        /// Output folder: one sub-folder per item, plus batch.csv.
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        /// Worker threads (default: one per core).
        #[arg(long, value_name = "N", default_value_t = 0)]
        jobs: usize,
        /// Run only shard K of N (K is 0-based): items whose position is K modulo N.
        #[arg(long, value_name = "K/N")]
        shard: Option<dexwarp::batch::Shard>,
        /// Re-run items that already have a report.
        #[arg(long)]
        force: bool,
    },
    /// Sample N variations of a demonstration from a spec, run each with physics, and sort
    /// them into DIR/kept and DIR/failed with the yield in DIR/stats.json and DIR/index.html.
    #[command(
        after_help = "The spec is a dexwarp.variations/1 file (README, \"augment\"); scenes/variations has one per built-in demonstration.\nSample i depends only on --seed and i: shards and reruns agree; finished samples are skipped unless --force.\n\nExamples:\n  dexwarp augment --demo scenes/demos/mug.demo.json --variations scenes/variations/mug.json --count 200 --seed 1 --out out/mug\n  dexwarp augment --demo scenes/demos/cube.demo.json --variations scenes/variations/cube.json --count 1000 --seed 1 --out /shared/cube --shard $SLURM_ARRAY_TASK_ID/8\n  dexwarp augment --merge /shared/cube --out /shared/cube"
    )]
    Augment {
        /// Demonstration to vary (`dexwarp.demo/1`).
        #[arg(long, value_name = "FILE", required_unless_present = "merge")]
        demo: Option<PathBuf>,
        /// Variation spec (`dexwarp.variations/1`).
        #[arg(long, value_name = "FILE", required_unless_present = "merge")]
        variations: Option<PathBuf>,
        /// Number of variations to sample.
        #[arg(long, value_name = "N", required_unless_present = "merge")]
        count: Option<u64>,
        /// Seed of the sampler.
        #[arg(long, value_name = "S", default_value_t = 0)]
        seed: u64,
        /// Output folder: kept/, failed/, stats.json, samples.csv, index.html.
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        /// Worker threads (default: one per core).
        #[arg(long, value_name = "N", default_value_t = 0)]
        jobs: usize,
        /// Run only shard K of N (K is 0-based): samples whose index is K modulo N.
        #[arg(long, value_name = "K/N")]
        shard: Option<dexwarp::batch::Shard>,
        /// Redo samples that are already finished.
        #[arg(long)]
        force: bool,
        /// Also run every sample with the SE(3) baseline hand (rigid transfer) on the same
        /// object trajectory: its verdict and D_C per sample in samples.csv, its yield and the
        /// paired counts in stats.json and index.html (about twice the time).
        #[arg(long)]
        compare_baseline: bool,
        /// Combine the shard files found in these folders into DIR (--out).
        #[arg(long, value_name = "DIR", num_args = 1.., conflicts_with_all = ["demo", "variations", "count", "shard"])]
        merge: Vec<PathBuf>,
    },
    /// Read the reports below DIR, keep what passes, and list why each of the rest was dropped.
    #[command(
        after_help = "Writes KEEP.csv (kept) and KEEP.dropped.csv (dropped, with every reason).\n\nExamples:\n  dexwarp filter reports/latest --out keep.csv\n  dexwarp filter out/batch --max-dc-mm 5 --min-converged 0.99 --out keep.csv"
    )]
    Filter {
        /// Folder with report.json files (searched recursively).
        dir: PathBuf,
        /// Kept list (CSV); the dropped list is written next to it.
        #[arg(long, value_name = "KEEP.csv")]
        out: PathBuf,
        /// Drop items whose output D_C is above this [mm].
        #[arg(long, value_name = "MM", value_parser = positive_mm, allow_negative_numbers = true)]
        max_dc_mm: Option<f64>,
        /// Drop items whose IK converged on fewer frames than this fraction (0-1).
        #[arg(long, value_name = "FRACTION", value_parser = fraction, allow_negative_numbers = true)]
        min_converged: Option<f64>,
        /// Drop items whose waypoint error is above this [mm].
        #[arg(long, value_name = "MM", value_parser = positive_mm, allow_negative_numbers = true)]
        max_waypoint_error_mm: Option<f64>,
        /// Drop items whose timewarp discrepancy is above this.
        #[arg(long, value_name = "D", value_parser = fraction, allow_negative_numbers = true)]
        max_timewarp: Option<f64>,
        /// Do not require a physics pass.
        #[arg(long)]
        no_physics: bool,
        /// Keep items whose barrier push-out hit the narrow-gap failure.
        #[arg(long)]
        allow_narrow_gap: bool,
        /// Keep only robust passes: items that hold under every margin condition (reports
        /// written with `--margin`).
        #[arg(long, conflicts_with = "no_physics")]
        robust: bool,
    },
    /// The HTML report of any folder of outputs (reproduce, batch, augment, warp, validate):
    /// verdicts and reasons, metric distributions, a 3D player per trajectory; with
    /// --compare, what changed since a previous run (exit status 1 when something got worse).
    #[command(
        after_help = "Writes DIR/index.html (DIR/report.html when DIR/index.html is another command's page) and the player's data in player/ next to it; with --compare also compare.md there.\n\nExamples:\n  dexwarp report out/batch\n  dexwarp report reports/latest --out /tmp/latest.html\n  dexwarp report out/tonight --compare out/last_night --tol-dc-mm 1"
    )]
    Report {
        /// Folder of outputs (every report.json below it is an item).
        dir: PathBuf,
        /// The page to write (default DIR/index.html).
        #[arg(long, value_name = "FILE")]
        out: Option<PathBuf>,
        /// A previous run of the same items to compare with.
        #[arg(long, value_name = "PREV_DIR")]
        compare: Option<PathBuf>,
        /// Largest D_C increase not reported [mm].
        #[arg(long, value_name = "MM", default_value_t = 0.5, value_parser = non_negative, allow_negative_numbers = true)]
        tol_dc_mm: f64,
        /// Largest D_WO increase not reported [mm].
        #[arg(long, value_name = "MM", default_value_t = 1.0, value_parser = non_negative, allow_negative_numbers = true)]
        tol_dwo_mm: f64,
        /// Largest hand-object penetration increase not reported [mm].
        #[arg(long, value_name = "MM", default_value_t = 0.5, value_parser = non_negative, allow_negative_numbers = true)]
        tol_penetration_mm: f64,
        /// Largest waypoint error increase not reported [mm].
        #[arg(long, value_name = "MM", default_value_t = 1.0, value_parser = non_negative, allow_negative_numbers = true)]
        tol_waypoint_mm: f64,
        /// Largest object path length ratio change not reported.
        #[arg(long, value_name = "X", default_value_t = 0.05, value_parser = non_negative, allow_negative_numbers = true)]
        tol_plr: f64,
        /// Largest timewarp discrepancy change not reported.
        #[arg(long, value_name = "X", default_value_t = 0.02, value_parser = non_negative, allow_negative_numbers = true)]
        tol_timewarp: f64,
        /// Stage time ratio (now / before) above which an item is listed as slower.
        #[arg(long, value_name = "X", default_value_t = 1.5, value_parser = non_negative, allow_negative_numbers = true)]
        time_ratio: f64,
    },
    /// Write the trajectories below DIR (reports with their warped demonstrations, or
    /// .demo.json files) as one training dataset, quality figures as per-episode columns.
    #[command(
        after_help = "Formats: lerobot (LeRobot v3.0, state only, a folder), robomimic (one HDF5 file; a build with --features robomimic and the HDF5 C library). The column mapping and the HDF5 layout are in the README (Export and import).\n\nExamples:\n  dexwarp export reports/latest --format lerobot --robot human_hand --out out/dataset\n  dexwarp export out/aug/mug --format lerobot --only-passing --out out/mug_kept\n  dexwarp export out/mug.demo.json --format lerobot --fps 30 --out out/mug_lerobot\n  dexwarp export out/aug/mug --format robomimic --out out/mug.hdf5"
    )]
    Export {
        /// Folders (searched recursively for report.json) or demonstration files.
        #[arg(required = true, value_name = "DIR")]
        inputs: Vec<PathBuf>,
        /// Dataset format.
        #[arg(long, value_enum)]
        format: ExportFormat,
        /// Dataset folder (lerobot) or file (robomimic) to create, written atomically.
        #[arg(long, value_name = "OUT")]
        out: PathBuf,
        /// Only trajectories whose physics verdict is pass.
        #[arg(long)]
        only_passing: bool,
        /// Frame rate of the dataset [Hz]; must divide the trajectories' rate (every k-th frame is kept).
        #[arg(long, value_name = "F")]
        fps: Option<u32>,
        /// Only trajectories of this robot (URDF file stem, e.g. human_hand); needed when DIR holds several.
        #[arg(long, value_name = "NAME")]
        robot: Option<String>,
        /// Largest data file [MB] before the next one starts (LeRobot's data_files_size_in_mb).
        #[arg(long, value_name = "MB", default_value_t = 100)]
        data_file_mb: u64,
        /// Replace OUT if it exists.
        #[arg(long)]
        force: bool,
    },
    /// Make a dexwarp.demo/1 file from a recording: a CSV of frames (optionally a CSV of
    /// contacts), or one episode of a LeRobot v3 dataset; correspondences are extracted
    /// geometrically when not given.
    #[command(
        after_help = "CSV columns: object.x,object.y,object.z,object.qw,object.qx,object.qy,object.qz, wrist.x..wrist.qz, one column per actuated joint of the URDF (see the README).\n\nExamples:\n  dexwarp import --csv rec.csv --fps 30 --robot robots/human_hand.urdf --mesh scenes/objects/mug.obj --mass 0.3 --out out/rec.demo.json\n  dexwarp import --csv rec.csv --contacts rec.contacts.csv --fps 30 --robot robots/human_hand.urdf --mesh mug.obj --mass 0.3 --out out/rec.demo.json\n  dexwarp import --lerobot out/dataset --episode 3 --robot robots/human_hand.urdf --mesh scenes/objects/mug.obj --mass 0.3 --out out/ep3.demo.json"
    )]
    Import {
        /// Frames CSV.
        #[arg(
            long,
            value_name = "FILE",
            conflicts_with = "lerobot",
            required_unless_present = "lerobot"
        )]
        csv: Option<PathBuf>,
        /// Contacts CSV for --csv (frame, link, hand_x..z, object_x..z).
        #[arg(long, value_name = "FILE", requires = "csv")]
        contacts: Option<PathBuf>,
        /// Frame rate of the CSV [Hz].
        #[arg(long, value_name = "HZ", requires = "csv")]
        fps: Option<f64>,
        /// A LeRobot v3 dataset folder.
        #[arg(long, value_name = "DIR")]
        lerobot: Option<PathBuf>,
        /// Episode of the LeRobot dataset.
        #[arg(long, value_name = "N", default_value_t = 0)]
        episode: usize,
        /// LeRobot feature holding the wrist pose (7) then the joints.
        #[arg(long, value_name = "KEY", default_value = "observation.state")]
        state_key: String,
        /// LeRobot feature holding the object pose (7).
        #[arg(
            long,
            value_name = "KEY",
            default_value = "observation.environment_state"
        )]
        object_key: String,
        /// URDF of the hand.
        #[arg(long, value_name = "URDF")]
        robot: PathBuf,
        /// Object mesh (OBJ or STL).
        #[arg(long, value_name = "FILE")]
        mesh: PathBuf,
        /// Object mass [kg].
        #[arg(long, value_name = "KG")]
        mass: f64,
        /// Name of the demonstration (default: the output file's stem).
        #[arg(long, value_name = "NAME")]
        name: Option<String>,
        /// Output demonstration file.
        #[arg(long, value_name = "FILE")]
        out: PathBuf,
    },
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum ExportFormat {
    /// LeRobot v3.0 (parquet and meta/), state only.
    Lerobot,
    /// robomimic HDF5 (one file; needs a build with the cargo feature robomimic).
    Robomimic,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum PhysicsHandArg {
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
enum HandArg {
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
enum ObjectiveArg {
    /// Contacts and barriers, plus fingers kept out of the object.
    NonPenetrating,
    /// The paper's objective as printed (contacts and barriers).
    Paper,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum WarmStartArg {
    /// The previous frame's solution (the paper).
    Previous,
    /// The previous frame's solution carried along by the object's motion.
    FollowObject,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum SolverArg {
    /// Levenberg-Marquardt with analytic Jacobians.
    Lm,
    /// Adam, learning rate 0.01, as in the paper.
    Adam,
}

impl From<SolverArg> for Solver {
    fn from(s: SolverArg) -> Self {
        match s {
            SolverArg::Lm => Solver::Lm,
            SolverArg::Adam => Solver::Adam,
        }
    }
}

fn positive_mm(s: &str) -> std::result::Result<f64, String> {
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

fn non_negative(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        Ok(v) if v.is_finite() => Err(format!(
            "the value must not be negative: a finite number >= 0, like 2; got {v}"
        )),
        _ => Err(format!("expected a finite number >= 0, like 2; got {s:?}")),
    }
}

/// The folder holding `scenes/` and `robots/`: the current folder, or the source tree this
/// binary was built from.
fn repository_root() -> Result<PathBuf> {
    let here = std::env::current_dir()?;
    if here.join("scenes/configs").is_dir() {
        return Ok(here);
    }
    let built = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    if built.join("scenes/configs").is_dir() {
        return Ok(built);
    }
    anyhow::bail!(
        "no scenes/configs in {} or {}; run dexwarp reproduce from the repository root",
        here.display(),
        built.display()
    )
}

fn fraction(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        _ => Err(format!(
            "expected a number from 0 to 1, like 0.99; got {s:?}"
        )),
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {}", error_text(&err));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes, each cause only when the text so far does not already say it
/// (our file errors carry the OS error in their own message).
fn error_text(err: &anyhow::Error) -> String {
    let mut text = err.to_string();
    for cause in err.chain().skip(1) {
        let c = cause.to_string();
        if !text.contains(&c) {
            text.push_str(": ");
            text.push_str(&c);
        }
    }
    text
}

/// Worker threads asked for, capped at [`MAX_JOBS_PER_CORE`] per core with a message: more
/// threads than that only add switching and memory (5000 jobs ran 30x slower than 2).
fn capped_jobs(jobs: usize) -> usize {
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

fn run(cli: Cli) -> Result<()> {
    let limits = cli.limits.limits();
    match cli.command {
        Command::Reproduce {
            out,
            quick,
            jobs,
            root,
        } => {
            let root = match root {
                Some(r) if r.join("scenes/configs").is_dir() => r,
                Some(r) => anyhow::bail!(
                    "{}: no scenes/configs folder; --root must be a folder holding scenes/configs/*.json",
                    r.display()
                ),
                None => repository_root()?,
            };
            let rep = dexwarp::reproduce::run(&dexwarp::reproduce::ReproduceOptions {
                out: out.clone(),
                root,
                quick,
                jobs: capped_jobs(jobs),
                limits,
                progress: true,
            })?;
            eprint!(
                "{}",
                dexwarp::reproduce::tables::paper_comparison(&rep).markdown()
            );
            let failed = rep.runs.iter().filter(|r| r.report.error.is_some()).count();
            let passed = rep
                .runs
                .iter()
                .filter(|r| {
                    r.report
                        .physics
                        .as_ref()
                        .is_some_and(|p| p.verdict == "pass")
                })
                .count();
            eprintln!(
                "{} runs in {:.1} s: {passed} physics pass, {failed} failed to run; tables in {}, report {}",
                rep.runs.len(),
                rep.seconds,
                out.join("summary.md").display(),
                out.join("index.html").display()
            );
            Ok(())
        }
        Command::Synth {
            object,
            robot,
            motion,
            out,
            mesh,
            seed,
            noise_mm,
            tips,
            wrist_link,
        } => {
            let syn = dexwarp::synth::defaults::run(
                &dexwarp::synth::defaults::SynthRequest {
                    object,
                    robot,
                    motion,
                    out: out.clone(),
                    mesh,
                    seed,
                    noise_mm,
                    tips,
                    wrist_link,
                },
                &limits,
            )?;
            eprintln!(
                "wrote {} ({} frames, {} correspondences per in-contact frame, D_C {:.2} mm)",
                out.display(),
                syn.demo.frames.len(),
                syn.stats.contacts_per_frame,
                syn.stats.d_c_mm
            );
            if let Some(w) = &syn.demo.wrist_link {
                eprintln!("wrist link: {w} (the links above it are left out)");
            }
            Ok(())
        }
        Command::Robot { urdf, wrist_link } => {
            let robot = Robot::from_urdf_file_at(&urdf, &limits, wrist_link.as_deref())?;
            print!("{}", robot.describe());
            Ok(())
        }
        Command::Warp {
            config,
            demo,
            out,
            threshold_mm,
            hand,
            solver,
            no_physics,
            objective,
            penetration_weight,
            warm_start,
            margin,
            physics_hand,
        } => {
            let inputs = Inputs::load(&config, demo.as_deref(), &limits)?;
            // Before any work: no output may replace an input of this run.
            dexwarp::output::check_not_inputs(
                &out,
                &dexwarp::output::run_file_names(&inputs.config.name),
                &inputs.paths(),
            )?;
            let options = Options {
                demo,
                threshold_mm,
                hand: hand.into(),
                solver: solver.into(),
                objective: objective.map(|o| match o {
                    ObjectiveArg::NonPenetrating => dexwarp::model::Objective::NonPenetrating,
                    ObjectiveArg::Paper => dexwarp::model::Objective::Paper,
                }),
                penetration_weight,
                warm_start: warm_start.map(|w| match w {
                    WarmStartArg::Previous => dexwarp::model::WarmStart::Previous,
                    WarmStartArg::FollowObject => dexwarp::model::WarmStart::FollowObject,
                }),
                physics: (!no_physics).then(|| dexwarp::physics::Params {
                    margin,
                    hand: physics_hand.into(),
                    ..dexwarp::physics::Params::default()
                }),
                limits,
            };
            let run = pipeline::warp(&inputs, &options)?;
            write_outputs(&out, &run)
        }
        Command::Validate {
            demo,
            out,
            scene,
            barriers,
            margin,
            physics_hand,
            strict,
        } => {
            let (report, frames) = pipeline::validate(
                &demo,
                scene.as_deref(),
                (!barriers.is_empty()).then_some(barriers.as_slice()),
                &dexwarp::physics::Params {
                    margin,
                    hand: physics_hand.into(),
                    ..dexwarp::physics::Params::default()
                },
                &limits,
            )?;
            dexwarp::output::check_not_inputs(
                &out,
                &["frames.csv".into(), dexwarp::output::REPORT.into()],
                &[demo.as_path()],
            )?;
            let frames_path = out.join("frames.csv");
            let mut report = report;
            dexwarp::output::commit_set(
                &out,
                vec![(
                    "frames.csv".into(),
                    dexwarp::model::frames::csv_bytes(&frames_path, &frames)?,
                )],
                &mut report,
            )?;
            let physics = report.physics.as_ref();
            eprintln!(
                "{}: physics {}{}; D_C {:.2} mm; report in {}",
                demo.display(),
                physics.map_or("not run", |p| p.verdict.as_str()),
                physics
                    .filter(|p| !p.reasons.is_empty())
                    .map(|p| format!(" ({})", p.reasons.join("; ")))
                    .unwrap_or_default(),
                report.metrics.d_c_mm.warped,
                out.join("report.json").display()
            );
            eprintln!("{}", verdict_line(&report));
            if strict && physics.is_some_and(|p| p.verdict != "pass") {
                std::process::exit(3);
            }
            Ok(())
        }
        Command::Batch {
            manifest,
            out,
            jobs,
            shard,
            force,
        } => {
            let items = batch::read_manifest(&manifest, &limits)?;
            let outcomes = batch::run(
                &items,
                &out,
                &batch::BatchOptions {
                    jobs: capped_jobs(jobs),
                    shard,
                    force,
                    limits,
                    progress: true,
                },
            )?;
            let count = |s: &str| outcomes.iter().filter(|o| o.status == s).count();
            eprintln!(
                "{} items: {} done, {} skipped (already finished), {} failed; summary in {}",
                outcomes.len(),
                count("done"),
                count("skipped"),
                count("failed"),
                out.display()
            );
            if count("failed") > 0 {
                anyhow::bail!(
                    "{} of {} items failed; their report.json says why",
                    count("failed"),
                    outcomes.len()
                );
            }
            Ok(())
        }
        Command::Augment {
            demo,
            variations,
            count,
            seed,
            out,
            jobs,
            shard,
            force,
            compare_baseline,
            merge,
        } => {
            let aug = if merge.is_empty() {
                let (Some(demo), Some(variations), Some(count)) = (demo, variations, count) else {
                    anyhow::bail!("--demo, --variations and --count are required without --merge");
                };
                dexwarp::augment::run(&dexwarp::augment::AugmentOptions {
                    demo,
                    variations,
                    count,
                    seed,
                    out: out.clone(),
                    jobs,
                    shard,
                    force,
                    compare_baseline,
                    limits,
                    progress: true,
                })?
            } else {
                dexwarp::augment::merge(&merge, &out, &limits)?
            };
            let s = &aug.stats;
            let file = match shard {
                Some(k) if merge.is_empty() => {
                    format!("stats.shard-{}-of-{}.json", k.index, k.count)
                }
                _ => "stats.json".into(),
            };
            eprintln!(
                "{} attempts: {} rejected, {} ran, {} kept, {} failed (yield {:.1} %); {} run now, {} already finished, {:.0} samples/hour; {}",
                s.attempts,
                s.rejected,
                s.ran,
                s.passed,
                s.failed,
                s.yield_ * 100.0,
                s.timing.ran_now,
                s.timing.skipped_now,
                s.timing.samples_per_hour,
                out.join(file).display()
            );
            if let Some(b) = &s.baseline {
                let p = &b.paired;
                eprintln!(
                    "baseline hand: {} kept of {} ran (yield {:.1} %); paired: both {}, only contact IK {}, only baseline {}, neither {}",
                    b.passed,
                    b.ran,
                    b.yield_ * 100.0,
                    p.both,
                    p.only_contact_ik,
                    p.only_baseline,
                    p.neither
                );
            }
            Ok(())
        }
        Command::Export {
            inputs,
            format,
            out,
            only_passing,
            fps,
            robot,
            data_file_mb,
            force,
        } => {
            let mut options = dexwarp::export::ExportOptions::new(inputs, out.clone());
            options.only_passing = only_passing;
            options.fps = fps;
            options.robot = robot;
            options.data_file_mb = data_file_mb.max(1);
            options.force = force;
            options.progress = true;
            let t = std::time::Instant::now();
            let done = match format {
                ExportFormat::Lerobot => dexwarp::export::export_lerobot(&options, &limits)?,
                ExportFormat::Robomimic => dexwarp::export::export_robomimic(&options, &limits)?,
            };
            for (p, why) in &done.skipped {
                eprintln!("skipped {}: {why}", p.display());
            }
            eprintln!(
                "wrote {}: {} episodes, {} frames, {} data file(s), {} skipped, in {:.1} s",
                out.display(),
                done.episodes,
                done.frames,
                done.data_files,
                done.skipped.len(),
                t.elapsed().as_secs_f64()
            );
            Ok(())
        }
        Command::Import {
            csv,
            contacts,
            fps,
            lerobot,
            episode,
            state_key,
            object_key,
            robot,
            mesh,
            mass,
            name,
            out,
        } => {
            let target = dexwarp::import::Target {
                name,
                robot,
                mesh,
                mass,
                object_name: None,
                out: out.clone(),
            };
            let demo = match (csv, lerobot) {
                (Some(csv), _) => {
                    let Some(fps) = fps else {
                        anyhow::bail!(
                            "--fps is required with --csv: the frame rate of the recording [Hz]"
                        );
                    };
                    dexwarp::import::import_csv(&csv, contacts.as_deref(), fps, &target, &limits)?
                }
                (None, Some(root)) => dexwarp::import::import_lerobot(
                    &root,
                    episode,
                    &dexwarp::import::LerobotMapping {
                        state_key,
                        object_key,
                    },
                    &target,
                    &limits,
                )?,
                (None, None) => anyhow::bail!("give --csv FILE or --lerobot DIR"),
            };
            let with = demo
                .frames
                .iter()
                .filter(|f| !f.contacts.is_empty())
                .count();
            eprintln!(
                "wrote {}: {} frames at {} Hz, {with} with correspondences",
                out.display(),
                demo.frames.len(),
                demo.fps
            );
            Ok(())
        }
        Command::Filter {
            dir,
            out,
            max_dc_mm,
            min_converged,
            max_waypoint_error_mm,
            max_timewarp,
            no_physics,
            allow_narrow_gap,
            robust,
        } => {
            let criteria = filter::Criteria {
                require_physics_pass: !no_physics,
                require_robust: robust,
                max_dc_mm,
                min_converged_fraction: min_converged,
                max_waypoint_error_mm,
                max_timewarp_discrepancy: max_timewarp,
                reject_narrow_gap: !allow_narrow_gap,
            };
            let result = filter::filter(&dir, &criteria)?;
            filter::write_rows(&out, &result.kept)?;
            let dropped = filter::dropped_path(&out);
            filter::write_rows(&dropped, &result.dropped)?;
            eprintln!(
                "kept {} of {} ({}); dropped list with reasons in {}",
                result.kept.len(),
                result.kept.len() + result.dropped.len(),
                out.display(),
                dropped.display()
            );
            Ok(())
        }
        Command::Report {
            dir,
            out,
            compare,
            tol_dc_mm,
            tol_dwo_mm,
            tol_penetration_mm,
            tol_waypoint_mm,
            tol_plr,
            tol_timewarp,
            time_ratio,
        } => {
            use dexwarp::overview;
            let items = overview::collect(&dir, &limits)?;
            let page = out.unwrap_or_else(|| {
                let index = dir.join("index.html");
                let ours = std::fs::read_to_string(&index).map_or(true, |t| {
                    t.contains(&format!(
                        "<meta name=\"generator\" content=\"{}\">",
                        overview::GENERATOR
                    ))
                });
                if ours {
                    index
                } else {
                    eprintln!(
                        "note: {} is another command's page; writing report.html beside it",
                        index.display()
                    );
                    dir.join("report.html")
                }
            });
            let comparison = match &compare {
                Some(prev) => {
                    let before = overview::collect(prev, &limits)?;
                    let tol = overview::compare::Tolerances {
                        d_c_mm: tol_dc_mm,
                        d_wo_mm: tol_dwo_mm,
                        penetration_mm: tol_penetration_mm,
                        waypoint_mm: tol_waypoint_mm,
                        plr: tol_plr,
                        timewarp: tol_timewarp,
                        time_ratio,
                    };
                    Some(overview::compare::compare(
                        &prev.display().to_string(),
                        &before,
                        &items,
                        &tol,
                    ))
                }
                None => None,
            };
            overview::write_page(&dir, &page, &items, comparison.as_ref(), &limits)?;
            let fails = items
                .iter()
                .filter(|i| matches!(i.status(), "fail" | "error"))
                .count();
            eprintln!(
                "{} items, {fails} fail or error; report {}",
                items.len(),
                page.display()
            );
            if let Some(c) = comparison {
                let md = page.with_file_name("compare.md");
                dexwarp::model::json::write_atomic(&md, c.markdown().as_bytes())?;
                eprintln!("{}; summary {}", c.headline(), md.display());
                if c.worse() > 0 {
                    anyhow::bail!(
                        "{} changes are worse than {} beyond the tolerances; see {}",
                        c.worse(),
                        c.previous,
                        md.display()
                    );
                }
            }
            Ok(())
        }
    }
}

fn write_outputs(out: &Path, run: &pipeline::WarpRun) -> Result<()> {
    let written = dexwarp::output::write_run(out, run)?;
    eprintln!(
        "wrote {} ({} frames), {} and {}",
        written.demo.display(),
        run.demo.frames.len(),
        written.report.display(),
        written.frames.display()
    );
    eprintln!("{}", verdict_line(&run.report));
    Ok(())
}

/// The last line of `warp` and `validate`: the verdict and its first reason.
fn verdict_line(report: &dexwarp::model::report::Report) -> String {
    match &report.physics {
        None => "verdict: not run (no physics replay)".into(),
        Some(p) => match p.reasons.first() {
            Some(r) => format!("verdict: {} ({r})", p.verdict),
            None => format!("verdict: {}", p.verdict),
        },
    }
}
