//! `dexwarp report`.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use dexwarp::Limits;

use crate::args::non_negative;

/// The HTML report of any folder of outputs (reproduce, batch, augment, warp, validate):
/// verdicts and reasons, metric distributions, a 3D player per trajectory; with
/// --compare, what changed since a previous run (exit status 1 when something got worse).
#[derive(Debug, Args)]
#[command(
    after_help = "Writes DIR/index.html (DIR/report.html when DIR/index.html is another command's page) and the player's data in player/ next to it; with --compare also compare.md there.\n\nExamples:\n  dexwarp report out/batch\n  dexwarp report reports/latest --out /tmp/latest.html\n  dexwarp report out/tonight --compare out/last_night --tol-dc-mm 1"
)]
pub struct ReportArgs {
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
    /// Largest increase of the onset (the object's error at the first contact frame) not
    /// reported [mm].
    #[arg(long, value_name = "MM", default_value_t = 2.0, value_parser = non_negative, allow_negative_numbers = true)]
    tol_onset_mm: f64,
    /// Largest object path length ratio change not reported.
    #[arg(long, value_name = "X", default_value_t = 0.05, value_parser = non_negative, allow_negative_numbers = true)]
    tol_plr: f64,
    /// Largest timewarp discrepancy change not reported.
    #[arg(long, value_name = "X", default_value_t = 0.02, value_parser = non_negative, allow_negative_numbers = true)]
    tol_timewarp: f64,
    /// Stage time ratio (now / before) above which an item is listed as slower.
    #[arg(long, value_name = "X", default_value_t = 1.5, value_parser = non_negative, allow_negative_numbers = true)]
    time_ratio: f64,
}

pub fn run(args: ReportArgs, limits: Limits) -> Result<()> {
    let ReportArgs {
        dir,
        out,
        compare,
        tol_dc_mm,
        tol_dwo_mm,
        tol_penetration_mm,
        tol_waypoint_mm,
        tol_onset_mm,
        tol_plr,
        tol_timewarp,
        time_ratio,
    } = args;
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
                onset_mm: tol_onset_mm,
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
