//! The `dexwarp` command line: a thin layer over the library.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand, ValueEnum};
use dexwarp::Limits;
use dexwarp::model::json::write_json_atomic;
use dexwarp::pipeline::{self, HandMethod, Inputs, Options};
use dexwarp::robot::Robot;

/// Warp one dexterous-manipulation demonstration into many.
///
/// dexwarp moves the object of a demonstration through new waypoints, around barriers, on a
/// new timing and from a new start to a new end, recovers the hand, and writes a quality report
/// per trajectory.
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
}

impl LimitArgs {
    fn limits(&self) -> Limits {
        let mut l = Limits::default();
        if let Some(mb) = self.max_file_mb {
            l.max_file_bytes = mb << 20;
            l.max_mesh_bytes = mb << 20;
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
        l
    }
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Load a hand and print its links, DoF, joint limits, mimic joints and collision shapes.
    #[command(
        after_help = "Examples:\n  dexwarp robot robots/human_hand.urdf\n  dexwarp robot robots/parallel_gripper.urdf"
    )]
    Robot {
        /// URDF file.
        urdf: PathBuf,
    },
    /// Warp one demonstration with one config; writes DIR/<name>.demo.json and DIR/report.json.
    #[command(
        after_help = "Examples:\n  dexwarp warp --config scenes/configs/mug_pass_wall.json --out out/mug\n  dexwarp warp --config my.json --demo my.demo.json --out out/x --hand baseline"
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
        #[arg(long, value_name = "MM", value_parser = positive_mm)]
        threshold_mm: Option<f64>,
        /// How the hand is recovered.
        #[arg(long, value_enum, default_value_t = HandArg::Baseline)]
        hand: HandArg,
    },
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum HandArg {
    /// Rigid SE(3) transfer at the timewarp, B-spline in between (the paper's baseline).
    Baseline,
}

fn positive_mm(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!(
            "expected a distance in millimetres > 0, like 3.5; got {s:?}"
        )),
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    let limits = cli.limits.limits();
    match cli.command {
        Command::Robot { urdf } => {
            let robot = Robot::from_urdf_file(&urdf, &limits)?;
            print!("{}", robot.describe());
            Ok(())
        }
        Command::Warp {
            config,
            demo,
            out,
            threshold_mm,
            hand,
        } => {
            let inputs = Inputs::load(&config, demo.as_deref(), &limits)?;
            let options = Options {
                demo,
                threshold_mm,
                hand: match hand {
                    HandArg::Baseline => HandMethod::Baseline,
                },
                limits,
            };
            let run = pipeline::warp(&inputs, &options)?;
            write_outputs(&out, &run)
        }
    }
}

fn write_outputs(out: &Path, run: &pipeline::WarpRun) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let demo_path = out.join(format!("{}.demo.json", run.demo.name));
    run.demo.save(&demo_path)?;
    write_json_atomic(&out.join("report.json"), &run.report)?;
    eprintln!(
        "wrote {} ({} frames) and {}",
        demo_path.display(),
        run.demo.frames.len(),
        out.join("report.json").display()
    );
    Ok(())
}
