//! `dexwarp batch`.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use dexwarp::{Limits, batch};

use crate::args::{EnsembleArgs, OutDir, Sharding, Workers};

/// Run many (demo, config) items of a manifest in parallel; a failed item is recorded and
/// the rest go on.
#[derive(Debug, Args)]
#[command(
    after_help = "Writes one sub-folder per item and batch.csv into DIR (--out).\nThe manifest is JSON Lines, one item per line (paths relative to it):\n  {\"config\": \"scenes/configs/mug_pass_wall.json\", \"threshold_mm\": 5}\n  {\"config\": \"scenes/configs/cube_messy.json\", \"hand\": \"baseline\", \"name\": \"cube_base\"}\n\nExamples:\n  dexwarp batch items.jsonl --out out/batch --jobs 2\n  dexwarp batch items.jsonl --out out/batch --shard $SLURM_ARRAY_TASK_ID/8\n  dexwarp batch items.jsonl --out out/batch --shard $JOB_COMPLETION_INDEX/8 --force"
)]
pub struct BatchArgs {
    /// Manifest (JSON Lines).
    manifest: PathBuf,
    #[command(flatten)]
    out: OutDir,
    #[command(flatten)]
    workers: Workers,
    #[command(flatten)]
    sharding: Sharding,
    #[command(flatten)]
    ensemble: EnsembleArgs,
}

pub fn run(args: BatchArgs, limits: Limits) -> Result<()> {
    let BatchArgs {
        manifest,
        out: OutDir { out },
        workers,
        sharding: Sharding { shard, force },
        ensemble,
    } = args;
    let items = batch::read_manifest(&manifest, &limits)?;
    let outcomes = batch::run(
        &items,
        &out,
        &batch::BatchOptions {
            jobs: workers.jobs(),
            shard,
            force,
            physics: ensemble.options(),
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
