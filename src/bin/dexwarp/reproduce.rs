//! `dexwarp reproduce`.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use dexwarp::Limits;

use crate::args::{EnsembleArgs, Workers};

/// The main job: every config in scenes/configs at the paper's thresholds, with Adam and
/// the baseline, the robustness sweep, physics on every output; the paper's tables and an
/// HTML report.
#[derive(Debug, Args)]
#[command(
    after_help = "Run it from the repository root (it reads scenes/ and robots/ there).\n\nExamples:\n  dexwarp reproduce\n  dexwarp reproduce --quick --out /tmp/quick\n  dexwarp reproduce --out reports/latest --jobs 2   # refresh the committed example run"
)]
pub struct ReproduceArgs {
    /// Output folder (ignored by git in the repository; `--out reports/latest` refreshes the
    /// committed example run).
    #[arg(long, value_name = "DIR", default_value = "out/reproduce")]
    out: PathBuf,
    /// A quick pass: Adam on three configs only, robustness at 0/50/100 %.
    #[arg(long)]
    quick: bool,
    #[command(flatten)]
    workers: Workers,
    /// Folder holding scenes/configs (default: the current folder, else the source tree
    /// this binary was built from).
    #[arg(long, value_name = "DIR")]
    root: Option<PathBuf>,
    /// Keep every run's warped demonstration (by default only those of contact IK at 3.5 mm
    /// and the baseline, which export and the player use; the rest only feed the tables).
    #[arg(long)]
    all_demos: bool,
    /// The ensemble verdict of the baseline comparison's runs (contact IK at 3.5 mm and the
    /// baseline); the other runs of the tables replay once.
    #[command(flatten)]
    ensemble: EnsembleArgs,
}

pub fn run(args: ReproduceArgs, limits: Limits) -> Result<()> {
    let ReproduceArgs {
        out,
        quick,
        workers,
        root,
        all_demos,
        ensemble,
    } = args;
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
        jobs: workers.jobs(),
        physics: ensemble.options(),
        limits,
        progress: true,
        all_demos,
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
