//! `dexwarp warp`.

use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::Args;
use dexwarp::Limits;
use dexwarp::pipeline::{self, Inputs, Options};

use crate::args::{
    HandArg, ObjectiveArg, OutDir, PhysicsArgs, SolverArg, WarmStartArg, non_negative, positive_mm,
    verdict_line,
};

/// Warp one demonstration with one config; writes DIR/<name>.demo.json, DIR/report.json and
/// DIR/frames.csv.
#[derive(Debug, Args)]
#[command(
    after_help = "Examples:\n  dexwarp warp --config scenes/configs/mug_pass_wall.json --out out/mug\n  dexwarp warp --config my.json --demo my.demo.json --out out/x --hand baseline\n  dexwarp warp --config scenes/configs/teapot_pour_cups.json --out out/t --threshold-mm 5 --solver adam"
)]
pub struct WarpArgs {
    /// Warp config (`dexwarp.config/1`).
    #[arg(long, value_name = "FILE")]
    config: PathBuf,
    /// Demonstration to warp instead of the one the config names.
    #[arg(long, value_name = "FILE")]
    demo: Option<PathBuf>,
    #[command(flatten)]
    out: OutDir,
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
    #[arg(long, conflicts_with_all = ["margin", "physics_hand"])]
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
    #[command(flatten)]
    physics: PhysicsArgs,
}

pub fn run(args: WarpArgs, limits: Limits) -> Result<()> {
    let WarpArgs {
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
        physics,
    } = args;
    let out = out.out;
    let inputs = Inputs::load(&config, demo.as_deref(), &limits)?;
    // Before any work: no output may replace an input of this run.
    dexwarp::output::check_not_inputs(
        &out,
        &dexwarp::output::run_file_names(&inputs.config.name),
        &inputs.paths(),
    )?;
    let options = Options::new(hand.into())
        .demo(demo)
        .threshold_mm(threshold_mm)
        .solver(solver.into())
        .objective(objective.map(Into::into))
        .penetration_weight(penetration_weight)
        .warm_start(warm_start.map(Into::into))
        .physics((!no_physics).then(|| physics.options()))
        .limits(limits);
    let run = pipeline::warp(&inputs, &options)?;
    write_outputs(&out, &run)
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
