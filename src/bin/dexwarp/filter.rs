//! `dexwarp filter`.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use dexwarp::filter;

use crate::args::{fraction, positive_deg, positive_mm};

/// Read the reports below DIR, keep what passes, and list why each of the rest was dropped.
#[derive(Debug, Args)]
#[command(
    after_help = "Writes KEEP.csv (kept) and KEEP.dropped.csv (dropped, with every reason).\n\nExamples:\n  dexwarp filter out/reproduce --out keep.csv\n  dexwarp filter out/batch --max-dc-mm 5 --min-converged 0.99 --out keep.csv"
)]
pub struct FilterArgs {
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
    /// Drop items whose onset is above this [mm]: how far the approach and the closing moved
    /// the object by the first contact frame.
    #[arg(long, value_name = "MM", value_parser = positive_mm, allow_negative_numbers = true)]
    max_onset_mm: Option<f64>,
    /// Drop items whose hand turned the released object more than this [deg] (the retreat
    /// spun the put-down object).
    #[arg(long, value_name = "DEG", value_parser = positive_deg, allow_negative_numbers = true)]
    max_release_turn_deg: Option<f64>,
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
    /// Keep items whose ensemble pass fraction reaches this, instead of those the run's own
    /// keep threshold kept (reports written with --ensemble K > 1, the default).
    #[arg(long, value_name = "FRACTION", value_parser = fraction, conflicts_with = "no_physics")]
    min_pass_fraction: Option<f64>,
    /// Drop items whose ensemble cannot tell which side of the threshold they are on (the
    /// pass fraction's 95 % interval contains it).
    #[arg(long)]
    exclude_uncertain: bool,
}

pub fn run(args: FilterArgs) -> Result<()> {
    let FilterArgs {
        dir,
        out,
        max_dc_mm,
        min_converged,
        max_waypoint_error_mm,
        max_timewarp,
        max_onset_mm,
        max_release_turn_deg,
        no_physics,
        allow_narrow_gap,
        robust,
        min_pass_fraction,
        exclude_uncertain,
    } = args;
    let criteria = filter::Criteria {
        require_physics_pass: !no_physics,
        require_robust: robust,
        max_dc_mm,
        min_converged_fraction: min_converged,
        max_waypoint_error_mm,
        max_timewarp_discrepancy: max_timewarp,
        max_onset_mm,
        max_release_turn_deg,
        reject_narrow_gap: !allow_narrow_gap,
        min_pass_fraction,
        exclude_uncertain,
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
