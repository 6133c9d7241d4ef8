//! Batches: many (demo, config, parameters) items in parallel.
//!
//! A manifest is JSON Lines: one item per line, blank lines and lines starting with `#`
//! ignored. Each item is an object with `config` (required), and optionally `demo`, `name`,
//! `threshold_mm`, `hand`; paths are relative to the manifest. Every item writes into
//! `OUT/<name>/` (the warped demonstration, `report.json`, `frames.csv`); a failed item writes
//! a `report.json` whose `error` says why, and the batch goes on. `OUT/batch.csv` lists every
//! item of the run with its status.
//!
//! Sharding: `--shard K/N` (K is 0-based, 0 ≤ K < N) keeps the items whose position in the
//! manifest is K modulo N, so a Slurm array (`--array=0-3` with `--shard $SLURM_ARRAY_TASK_ID/4`)
//! or a Kubernetes indexed job (`--shard $JOB_COMPLETION_INDEX/4`) splits one manifest without
//! coordination. Items whose `report.json` exists without an error are skipped unless `force`;
//! failed items are retried.
//!
//! Memory stays flat as the batch grows: items are run and written one at a time per worker and
//! only a one-line summary of each is kept.

use std::path::{Path, PathBuf};
use std::str::FromStr;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::hand::ik::Solver;
use crate::model::json::{read_limited, resolve_relative, write_atomic, write_json_atomic};
use crate::model::report::{REPORT_FORMAT, Report};
use crate::output::progress;
use crate::pipeline::{self, HandMethod, Inputs, Options};
use crate::{Error, Limits, Result};

/// One manifest line as written.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ItemJson {
    /// Warp config, relative to the manifest.
    pub config: PathBuf,
    /// Demonstration to warp instead of the config's.
    #[serde(default)]
    pub demo: Option<PathBuf>,
    /// Output sub-folder; default: the config's file stem, with the hand and threshold.
    #[serde(default)]
    pub name: Option<String>,
    /// IK threshold [mm].
    #[serde(default)]
    pub threshold_mm: Option<f64>,
    /// Hand recovery method: `contact` (default) or `baseline`.
    #[serde(default)]
    pub hand: Option<HandMethod>,
    /// IK solver: `lm` (default) or `adam`.
    #[serde(default)]
    pub solver: Option<Solver>,
}

/// A validated manifest item.
#[derive(Clone, Debug, PartialEq)]
pub struct Item {
    /// 1-based manifest line.
    pub line: usize,
    /// Position among the manifest's items (0-based), for sharding.
    pub index: usize,
    pub name: String,
    pub config: PathBuf,
    pub demo: Option<PathBuf>,
    pub threshold_mm: Option<f64>,
    pub hand: HandMethod,
    pub solver: Solver,
}

/// `K/N`: this process runs the items whose index is K modulo N.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl FromStr for Shard {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let usage = || {
            format!(
                "expected K/N with 0 <= K < N (K is 0-based, like a Kubernetes completion index), e.g. 0/4; got {s:?}"
            )
        };
        let (k, n) = s.split_once('/').ok_or_else(usage)?;
        let index: usize = k.trim().parse().map_err(|_| usage())?;
        let count: usize = n.trim().parse().map_err(|_| usage())?;
        if count == 0 || index >= count {
            return Err(usage());
        }
        Ok(Shard { index, count })
    }
}

/// Reads and validates a manifest; errors name the line.
pub fn read_manifest(path: &Path, limits: &Limits) -> Result<Vec<Item>> {
    let bytes = read_limited(path, limits, limits.max_file_bytes, "--max-file-mb")?;
    let text = String::from_utf8(bytes)
        .map_err(|_| Error::invalid(path, "(file)", "is not UTF-8 text; expected JSON Lines"))?;
    let mut items: Vec<Item> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        let field = format!("line {}", i + 1);
        let j: ItemJson = serde_json::from_str(trimmed).map_err(|e| {
            Error::invalid(
                path,
                field.clone(),
                format!(
                    "{}; expected one JSON object per line like {{\"config\": \"scenes/configs/mug_pass_wall.json\", \"threshold_mm\": 5}}",
                    crate::model::json::with_suggestion(crate::model::json::strip_position(
                        &e.to_string()
                    ))
                ),
            )
        })?;
        if let Some(t) = j.threshold_mm
            && !(t.is_finite() && t > 0.0)
        {
            return Err(Error::invalid(
                path,
                format!("{field}.threshold_mm"),
                format!("is {t}; expected a distance in millimetres > 0"),
            ));
        }
        let hand = j.hand.unwrap_or_default();
        let name = match j.name {
            Some(n) => {
                crate::model::config::check_output_name(path, &format!("{field}.name"), &n)?;
                n
            }
            None => {
                let stem = j
                    .config
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_else(|| "item".into());
                let stem = stem.strip_suffix(".config").unwrap_or(&stem).to_string();
                let method = match (hand, j.solver.unwrap_or_default()) {
                    (HandMethod::Baseline, _) => "baseline".to_string(),
                    (HandMethod::Contact, s) => s.as_str().to_string(),
                };
                match j.threshold_mm {
                    Some(t) => format!("{stem}_{method}_{t}mm"),
                    None => format!("{stem}_{method}"),
                }
            }
        };
        if let Some(prev) = items.iter().find(|it| it.name == name) {
            return Err(Error::invalid(
                path,
                field,
                format!(
                    "output name {name:?} is already used by line {}; give one of them a distinct \"name\"",
                    prev.line
                ),
            ));
        }
        items.push(Item {
            line: i + 1,
            index: items.len(),
            name,
            config: resolve_relative(path, &j.config),
            demo: j.demo.map(|d| resolve_relative(path, &d)),
            threshold_mm: j.threshold_mm,
            hand,
            solver: j.solver.unwrap_or_default(),
        });
    }
    if items.is_empty() {
        return Err(Error::invalid(
            path,
            "(file)",
            "has no items; expected one JSON object per line",
        ));
    }
    Ok(items)
}

/// Options of a batch run.
#[derive(Clone, Debug, Default)]
pub struct BatchOptions {
    /// Worker threads (0 = one per core).
    pub jobs: usize,
    pub shard: Option<Shard>,
    /// Re-run items that already have a report.
    pub force: bool,
    /// The ensemble verdict's members and seed, over each config's own.
    pub physics: crate::pipeline::PhysicsOptions,
    pub limits: Limits,
    /// Show a progress bar (only when stderr is a terminal).
    pub progress: bool,
}

/// What happened to one item.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Outcome {
    pub name: String,
    pub line: usize,
    /// `done`, `skipped` or `failed`.
    pub status: &'static str,
    pub error: String,
    pub frames_out: Option<usize>,
    pub d_c_mm: Option<f64>,
    pub verdict: Option<String>,
    pub seconds: f64,
}

/// Runs the items of `shard` into `out` and returns the outcomes in manifest order.
///
/// `out/batch.csv` (or `batch.shardKofN.csv`) is rewritten atomically each time an item
/// finishes, in manifest order, so a killed batch leaves the rows of every item it finished;
/// skipped items (finished by an earlier run) keep the figures of their report. Temporaries
/// of killed runs below `out` are removed first.
pub fn run(items: &[Item], out: &Path, options: &BatchOptions) -> Result<Vec<Outcome>> {
    std::fs::create_dir_all(out).map_err(|e| Error::write(out, e))?;
    crate::output::clean_stale(out);
    let selected: Vec<&Item> = items
        .iter()
        .filter(|it| options.shard.is_none_or(|s| it.index % s.count == s.index))
        .collect();
    for it in &selected {
        let dir = out.join(&it.name);
        if dir.is_dir() {
            crate::output::clean_stale(&dir);
        }
    }
    let summary = match options.shard {
        Some(s) => out.join(format!("batch.shard{}of{}.csv", s.index, s.count)),
        None => out.join("batch.csv"),
    };
    let done: std::sync::Mutex<Vec<Option<Outcome>>> =
        std::sync::Mutex::new(vec![None; selected.len()]);
    let mut bar = progress::Progress::new("batch", selected.len() as u64, options.progress);
    let work = || {
        selected
            .par_iter()
            .enumerate()
            .map(|(k, it)| {
                let o = run_item(it, out, options);
                bar.set_message(o.name.clone());
                bar.inc(1);
                if o.status == "failed" {
                    bar.println(format!("{}: {}", o.name, o.error));
                }
                // One writer at a time: the summary's temporary name is per process.
                let mut done = done.lock().unwrap_or_else(|p| p.into_inner());
                done[k] = Some(o.clone());
                let written = write_summary(&summary, done.iter().flatten());
                drop(done);
                written.map(|()| o)
            })
            .collect::<Result<Vec<_>>>()
    };
    let outcomes = progress::with_jobs(options.jobs, work)
        .map_err(|e| Error::invalid(out, "--jobs", e.to_string()))??;
    bar.finish_and_clear();
    Ok(outcomes)
}

/// Writes the summary CSV of `outcomes` atomically.
fn write_summary<'a>(path: &Path, outcomes: impl Iterator<Item = &'a Outcome>) -> Result<()> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for o in outcomes {
        w.serialize(o)
            .map_err(|e| Error::write(path, std::io::Error::other(e)))?;
    }
    let bytes = w
        .into_inner()
        .map_err(|e| Error::write(path, std::io::Error::other(e.to_string())))?;
    write_atomic(path, &bytes)
}

fn run_item(item: &Item, out: &Path, options: &BatchOptions) -> Outcome {
    let dir = out.join(&item.name);
    let report_path = dir.join("report.json");
    let mut outcome = Outcome {
        name: item.name.clone(),
        line: item.line,
        status: "done",
        error: String::new(),
        frames_out: None,
        d_c_mm: None,
        verdict: None,
        seconds: 0.0,
    };
    if !options.force
        && let Some(done) = finished(&report_path)
    {
        outcome.status = "skipped";
        outcome.frames_out = Some(done.frames_out);
        outcome.d_c_mm = Some(done.metrics.d_c_mm.warped);
        outcome.verdict = done.physics.map(|p| p.verdict);
        return outcome;
    }
    let clock = std::time::Instant::now();
    let result = (|| -> Result<Report> {
        let inputs = Inputs::load(&item.config, item.demo.as_deref(), &options.limits)?;
        crate::output::check_not_inputs(
            &dir,
            &crate::output::run_file_names(&inputs.config.name),
            &inputs.paths(),
        )?;
        let run = pipeline::warp(
            &inputs,
            &Options::new(item.hand)
                .demo(item.demo.clone())
                .threshold_mm(item.threshold_mm)
                .solver(item.solver)
                .physics(Some(options.physics.clone()))
                .limits(options.limits),
        )?;
        crate::output::write_run(&dir, &run)?;
        Ok(run.report)
    })();
    outcome.seconds = clock.elapsed().as_secs_f64();
    match result {
        Ok(report) => {
            outcome.frames_out = Some(report.frames_out);
            outcome.d_c_mm = Some(report.metrics.d_c_mm.warped);
            outcome.verdict = report.physics.map(|p| p.verdict);
        }
        Err(e) => {
            outcome.status = "failed";
            outcome.error = e.to_string();
            let report = Report {
                format: REPORT_FORMAT.into(),
                name: item.name.clone(),
                config: Some(item.config.display().to_string()),
                threshold_mm: item.threshold_mm,
                hand: Some(item.hand.as_str().into()),
                error: Some(outcome.error.clone()),
                ..Report::default()
            };
            if let Err(w) = write_json_atomic(&report_path, &report) {
                outcome.error.push_str(&format!(
                    " (and the failure report could not be written: {w})"
                ));
            }
        }
    }
    outcome
}

/// The report of a finished item: `report.json` exists, parses, has no error, and the
/// files of its output set are the ones it was written with.
fn finished(report: &Path) -> Option<Report> {
    let r = std::fs::read(report)
        .ok()
        .and_then(|b| serde_json::from_slice::<Report>(&b).ok())
        .filter(|r| r.error.is_none())?;
    crate::output::set_is_complete(report, &r).ok()?;
    Some(r)
}
