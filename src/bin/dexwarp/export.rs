//! `dexwarp export`.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, ValueEnum};
use dexwarp::Limits;

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ExportFormat {
    /// LeRobot v3.0 (parquet and meta/), state only.
    Lerobot,
    /// robomimic HDF5 (one file; needs a build with the cargo feature robomimic).
    Robomimic,
}

/// Write the trajectories below DIR (reports with their warped demonstrations, or
/// .demo.json files) as one training dataset, quality figures as per-episode columns.
#[derive(Debug, Args)]
#[command(
    after_help = "Formats: lerobot (LeRobot v3.0, state only, a folder), robomimic (one HDF5 file; a build with --features robomimic and the HDF5 C library). The column mapping and the HDF5 layout are in the README (Export and import).\n\nExamples:\n  dexwarp export out/reproduce --format lerobot --robot human_hand --out out/dataset\n  dexwarp export out/aug/mug --format lerobot --only-passing --out out/mug_kept\n  dexwarp export out/mug.demo.json --format lerobot --fps 30 --out out/mug_lerobot\n  dexwarp export out/aug/mug --format robomimic --out out/mug.hdf5\n  dexwarp filter out/aug/mug --max-dc-mm 5 --out keep.csv && dexwarp export keep.csv --format lerobot --out out/mug_dc5"
)]
pub struct ExportArgs {
    /// Folders (searched recursively for report.json), demonstration files, or lists
    /// `dexwarp filter` wrote (KEEP.csv: exactly the trajectories it kept).
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
    /// Only passing trajectories whose robustness margin holds under every condition
    /// (reports written with --margin: warp, validate, augment).
    #[arg(long)]
    only_robust: bool,
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
    /// robomimic: write `actions` as the absolute targets [m, rad] instead of scaled into
    /// [-1, 1] (for training code that normalizes itself).
    #[arg(long)]
    absolute_actions: bool,
}

pub fn run(args: ExportArgs, limits: Limits) -> Result<()> {
    let ExportArgs {
        inputs,
        format,
        out,
        only_passing,
        only_robust,
        fps,
        robot,
        data_file_mb,
        force,
        absolute_actions,
    } = args;
    if absolute_actions && matches!(format, ExportFormat::Lerobot) {
        anyhow::bail!(
            "--absolute-actions applies to --format robomimic; LeRobot's action is always the absolute target (its training normalizes with meta/stats.json)"
        );
    }
    let mut options = dexwarp::export::ExportOptions::new(inputs, out.clone());
    options.only_passing = only_passing;
    options.only_robust = only_robust;
    options.fps = fps;
    options.robot = robot;
    options.data_file_mb = data_file_mb.max(1);
    options.force = force;
    options.absolute_actions = absolute_actions;
    options.progress = true;
    let t = std::time::Instant::now();
    let done = match format {
        ExportFormat::Lerobot => dexwarp::export::export_lerobot(&options, &limits)?,
        ExportFormat::Robomimic => dexwarp::export::export_robomimic(&options, &limits)?,
    };
    // One line per trajectory, or per reason when a reason repeats (a reproduce folder's
    // table-only runs).
    let mut reasons: Vec<(&str, Vec<&std::path::Path>)> = Vec::new();
    for (p, why) in &done.skipped {
        match reasons.iter_mut().find(|(w, _)| *w == why.as_str()) {
            Some((_, paths)) => paths.push(p),
            None => reasons.push((why, vec![p])),
        }
    }
    for (why, paths) in reasons {
        match paths.as_slice() {
            [one] => eprintln!("skipped {}: {why}", one.display()),
            [first, ..] => eprintln!(
                "skipped {} trajectories ({}, ...): {why}",
                paths.len(),
                first.display()
            ),
            [] => {}
        }
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
