//! Running an augment: sample, reject, run in parallel, sort into `kept/` and `failed/`.
//!
//! Every sample runs in `DIR/.work/<id>/` (its `config.json`, `scene.json` when it adds
//! primitive barriers, the warped demonstration, `report.json`, `frames.csv`), and the folder
//! is then renamed to `DIR/kept/<id>/` or `DIR/failed/<id>/` in one step, so a folder under
//! `kept/` or `failed/` is always complete. A sample with a readable `report.json` there is
//! finished and skipped on a rerun (`force` redoes it). `DIR/augment.json` records the spec
//! (by hash), the demonstration and the seed; a rerun into the same folder with a different
//! one is refused, since its samples would not be the ones recorded. The count may grow:
//! sample `i` does not depend on it.
//!
//! Outputs: `samples.csv`, `stats.json`, `index.html` and `manifest.jsonl` (every sample that
//! ran, as a `batch` manifest). A shard `K/N` writes `samples.shard-K-of-N.csv` and
//! `stats.shard-K-of-N.json` only; [`merge`] combines shards into the four files.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::page;
use super::sampler::{Context, Sample, sample};
use super::spec::Spec;
use super::stats::{Row, RunId, STRETCHED, Stats, Timing, classify};
use crate::batch::Shard;
use crate::model::demo::relative_path;
use crate::model::json::{read_json, write_atomic, write_json_atomic};
use crate::model::report::{REPORT_FORMAT, Report};
use crate::model::{Demo, WarpConfig};
use crate::output::progress;
use crate::physics::Turn;
use crate::pipeline::{self, HandMethod, Inputs, Loaded, Options, PhysicsOptions};
use crate::{Error, Limits, Result};

/// The `format` value of `augment.json`.
pub const RUN_FORMAT: &str = "dexwarp.augment/1";

/// `DIR/augment.json`: what made this folder.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunFile {
    pub format: String,
    pub tool: String,
    pub spec: String,
    pub spec_hash: String,
    pub demo: String,
    pub seed: u64,
}

/// Options of an augment run.
#[derive(Clone, Debug)]
pub struct AugmentOptions {
    pub demo: PathBuf,
    pub variations: PathBuf,
    pub count: u64,
    pub seed: u64,
    pub out: PathBuf,
    /// Worker threads (0 = one per core).
    pub jobs: usize,
    pub shard: Option<Shard>,
    pub force: bool,
    /// Also run every sample with the SE(3) baseline hand (see [`super::stats`]).
    pub compare_baseline: bool,
    /// Also replay the robustness margin of every sample that passes physics, with each
    /// hand run (`physics.margin` in its report, `robust` in the rows and stats).
    pub margin: bool,
    /// The ensemble verdict's members and seed (`margin` and `hand` here are ignored).
    pub physics: PhysicsOptions,
    pub limits: Limits,
    pub progress: bool,
}

/// What a run produced.
#[derive(Clone, Debug)]
pub struct Augment {
    pub stats: Stats,
    pub rows: Vec<Row>,
}

fn shard_suffix(s: Shard) -> String {
    format!("shard-{}-of-{}", s.index, s.count)
}

/// Samples the spec, runs every feasible sample through the pipeline with physics, and
/// writes the run's files (see the module docs).
pub fn run(o: &AugmentOptions) -> Result<Augment> {
    let clock = Instant::now();
    let spec = Spec::load(&o.variations, &o.limits)?;
    let demo = Demo::load(&o.demo, &o.limits)?;
    let ctx = Context::new(&spec, &demo, &o.demo, &o.limits)?;
    // What every sample shares, loaded once: the demonstration as the samples' configs name
    // it (by its absolute path), its robot and its object's mesh.
    let loaded = Loaded::new(Demo::load(&ctx.demo_path, &o.limits)?, &o.limits)?;
    std::fs::create_dir_all(&o.out).map_err(|e| Error::write(&o.out, e))?;
    let out = std::fs::canonicalize(&o.out).map_err(|e| Error::read(&o.out, e))?;
    let run_file = RunFile {
        format: RUN_FORMAT.into(),
        tool: format!("dexwarp {}", env!("CARGO_PKG_VERSION")),
        spec: spec.file.name.clone(),
        spec_hash: format!("{:016x}", spec.hash),
        demo: demo.name.clone(),
        seed: o.seed,
    };
    check_run_file(&out.join("augment.json"), &run_file, o.force, &o.limits)?;
    write_json_atomic(&out.join("augment.json"), &run_file)?;

    let indices: Vec<u64> = (0..o.count)
        .filter(|i| {
            o.shard
                .is_none_or(|s| *i % s.count as u64 == s.index as u64)
        })
        .collect();
    let mut bar = progress::Progress::new("augment", indices.len() as u64, o.progress);
    let work = || {
        indices
            .par_iter()
            .map(|&i| {
                let r = run_sample(&spec, &ctx, &loaded, o, &out, i);
                bar.inc(1);
                r
            })
            .collect::<Vec<_>>()
    };
    let results = progress::with_jobs(o.jobs, work)
        .map_err(|e| Error::invalid(&o.out, "--jobs", e.to_string()))?;
    bar.finish_and_clear();
    let threads = if o.jobs == 0 {
        rayon::current_num_threads()
    } else {
        o.jobs
    };

    let mut timing = Timing {
        threads: vec![threads],
        ..Timing::default()
    };
    let mut rows = Vec::with_capacity(results.len());
    for (row, stages, ran) in results {
        match ran {
            Ran::Now => timing.ran_now += 1,
            Ran::Skipped => timing.skipped_now += 1,
            Ran::No => {}
        }
        for (k, v) in stages {
            *timing.stage_s.entry(k).or_default() += v;
        }
        rows.push(row);
    }
    let id = RunId {
        spec: spec.file.name.clone(),
        spec_hash: spec.hash,
        demo: demo.name.clone(),
        seed: o.seed,
        count: o.count,
        shards: vec![
            o.shard
                .map_or("all".into(), |s| format!("{}/{}", s.index, s.count)),
        ],
    };
    let _ = std::fs::remove_dir(out.join(".work"));
    timing.wall_s = clock.elapsed().as_secs_f64();
    timing.core_s = timing.wall_s * threads as f64;
    timing.finish();
    let stats = Stats::of(&id, &rows, timing);
    match o.shard {
        Some(s) => {
            let suffix = shard_suffix(s);
            write_rows(&out.join(format!("samples.{suffix}.csv")), &rows)?;
            write_json_atomic(&out.join(format!("stats.{suffix}.json")), &stats)?;
        }
        None => write_all(&out, &stats, &rows)?,
    }
    Ok(Augment { stats, rows })
}

fn write_all(out: &Path, stats: &Stats, rows: &[Row]) -> Result<()> {
    write_rows(&out.join("samples.csv"), rows)?;
    write_json_atomic(&out.join("stats.json"), stats)?;
    let mut manifest = String::from("# every sample that ran, as a batch manifest\n");
    for r in rows.iter().filter(|r| r.status != "rejected") {
        let line = serde_json::json!({
            "config": format!("{}/{}/config.json", r.status, r.id),
            "name": r.id,
        });
        manifest.push_str(&line.to_string());
        manifest.push('\n');
    }
    write_atomic(&out.join("manifest.jsonl"), manifest.as_bytes())?;
    page::write(out, stats, rows)
}

fn check_run_file(path: &Path, want: &RunFile, force: bool, limits: &Limits) -> Result<()> {
    if force || !path.is_file() {
        return Ok(());
    }
    let have: RunFile = read_json(path, limits)?;
    for (field, a, b) in [
        ("spec_hash", &have.spec_hash, &want.spec_hash),
        ("demo", &have.demo, &want.demo),
        ("seed", &have.seed.to_string(), &want.seed.to_string()),
    ] {
        if a != b {
            return Err(Error::invalid(
                path,
                field,
                format!(
                    "is {a:?}, this run's is {b:?}; the folder holds samples of another spec, demonstration or seed: use a new --out, or --force to redo every sample"
                ),
            ));
        }
    }
    Ok(())
}

/// Whether a sample ran in this invocation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ran {
    Now,
    Skipped,
    No,
}

fn base_row(s: &Sample) -> Row {
    Row {
        index: s.index,
        id: s.id.clone(),
        waypoints: s.config.waypoints.len(),
        barriers: s.config.barriers.len(),
        threshold_mm: s.config.params.threshold_mm,
        stretch_max: s.duration_factors.iter().copied().reduce(f64::max),
        ..Row::default()
    }
}

/// The output frames of the sample's stretched segments (duration factor at least
/// [`STRETCHED`]).
fn stretched_frames(s: &Sample) -> Vec<Range<usize>> {
    s.duration_factors
        .iter()
        .zip(s.anchors_t_new.windows(2))
        .filter(|(f, _)| **f >= STRETCHED)
        .map(|(_, w)| w[0]..w[1])
        .collect()
}

/// Mean of the `d_c_mm` column of a `frames.csv` over the output frames in `ranges`; `None`
/// when there are no such frames with a D_C, or the file does not read.
fn mean_d_c_over(frames_csv: &Path, ranges: &[Range<usize>]) -> Option<f64> {
    #[derive(Deserialize)]
    struct Frame {
        frame: usize,
        d_c_mm: Option<f64>,
    }
    if ranges.is_empty() {
        return None;
    }
    let mut r = csv::Reader::from_path(frames_csv).ok()?;
    let (mut sum, mut n) = (0.0, 0usize);
    for f in r.deserialize::<Frame>() {
        let f = f.ok()?;
        if let Some(d) = f.d_c_mm
            && ranges.iter().any(|r| r.contains(&f.frame))
        {
            sum += d;
            n += 1;
        }
    }
    (n > 0).then(|| sum / n as f64)
}

/// The report and frames of the baseline hand in a sample's folder (`--compare-baseline`).
const BASELINE_REPORT: &str = "baseline.report.json";
const BASELINE_FRAMES: &str = "baseline.frames.csv";

fn fill(row: &mut Row, report: &Report, spec: &Spec, dir: &Path, stretched: &[Range<usize>]) {
    let (status, keys, words) = classify(report, &spec.file.keep);
    row.status = status.into();
    row.reasons = keys.join(";");
    row.detail = words.first().cloned().unwrap_or_default();
    if report.error.is_none() {
        let m = &report.metrics;
        row.d_c_mm = Some(m.d_c_mm.warped);
        row.d_c_original_mm = Some(m.d_c_mm.original);
        row.d_wo_change_mm = Some(m.d_wo_mm.warped - m.d_wo_mm.original);
        row.plr_object = Some(m.plr_object);
        row.timewarp_discrepancy = Some(m.timewarp_discrepancy);
        row.converged_fraction = report.ik.as_ref().map(|i| i.converged_fraction);
        row.frames_out = Some(report.frames_out);
        row.d_c_stretched_mm = mean_d_c_over(&dir.join("frames.csv"), stretched);
        row.grasp_slide_mm = m.grasp_slide_mm.as_ref().map(|p| p.warped);
        row.grasp_shift_mm = m.grasp_shift_mm;
        row.onset_error_mm = onset_error_mm(report);
        row.release_turn_by_hand_deg = release_turn_by_hand_deg(report);
        row.robust = robust(report);
        if let Some(p) = report.physics.as_ref().filter(|p| p.ensemble().is_some()) {
            let (k, n) = p.ensemble_members();
            row.pass_fraction = p.pass_fraction();
            row.ensemble_members = Some(k);
            row.ensemble_replayed = Some(n);
            row.uncertain = p.uncertain();
        }
    }
}

/// Whether the report's robustness margin holds under every condition; `None` without one.
fn robust(report: &Report) -> Option<bool> {
    report.physics.as_ref().and_then(|p| p.robust())
}

/// The object's position error when the contact segment starts; `None` without one.
fn onset_error_mm(report: &Report) -> Option<f64> {
    report.physics.as_ref().and_then(|p| p.onset_error_mm())
}

/// How far the hand turned the released object [deg]: the largest turn after the release
/// when the hand turned it, 0 when it turned by itself; `None` without a release.
fn release_turn_by_hand_deg(report: &Report) -> Option<f64> {
    Turn::of(report.physics.as_ref()?).map(|t| t.by_hand_deg())
}

fn fill_baseline(
    row: &mut Row,
    report: &Report,
    spec: &Spec,
    dir: &Path,
    stretched: &[Range<usize>],
) {
    let (status, keys, _) = classify(report, &spec.file.keep);
    row.baseline_status = status.into();
    row.baseline_reasons = keys.join(";");
    if report.error.is_none() {
        row.baseline_d_c_mm = Some(report.metrics.d_c_mm.warped);
        row.baseline_d_c_stretched_mm = mean_d_c_over(&dir.join(BASELINE_FRAMES), stretched);
        row.baseline_grasp_slide_mm = report.metrics.grasp_slide_mm.as_ref().map(|p| p.warped);
        row.baseline_grasp_shift_mm = report.metrics.grasp_shift_mm;
        row.baseline_onset_error_mm = onset_error_mm(report);
        row.baseline_release_turn_by_hand_deg = release_turn_by_hand_deg(report);
        row.baseline_robust = robust(report);
        if let Some(p) = &report.physics {
            row.baseline_pass_fraction = p.pass_fraction();
            row.baseline_uncertain = p.uncertain();
        }
    }
}

fn read_report(path: &Path) -> Option<Report> {
    std::fs::read(path)
        .ok()
        .and_then(|b| serde_json::from_slice::<Report>(&b).ok())
}

/// A report as a rerun will read it back: serde_json's default float parsing is not an exact
/// round trip, and stats.json must not depend on whether a sample was skipped.
fn as_read_back(report: Report) -> Report {
    serde_json::to_vec(&report)
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok())
        .unwrap_or(report)
}

fn run_sample(
    spec: &Spec,
    ctx: &Context,
    loaded: &Loaded,
    o: &AugmentOptions,
    out: &Path,
    index: u64,
) -> (Row, BTreeMap<String, f64>, Ran) {
    let mut stages = BTreeMap::new();
    let clock = Instant::now();
    let s = sample(spec, ctx, o.seed, index);
    let mut row = base_row(&s);
    if let Some(r) = &s.rejection {
        row.status = "rejected".into();
        row.reasons = r.reason.into();
        row.detail = r.detail.clone();
        stages.insert("sample".into(), clock.elapsed().as_secs_f64());
        return (row, stages, Ran::No);
    }
    let stretched = stretched_frames(&s);
    let kept = out.join("kept").join(&s.id);
    let failed = out.join("failed").join(&s.id);
    if !o.force {
        for dir in [&kept, &failed] {
            let Some(report) = read_report(&dir.join("report.json")) else {
                continue;
            };
            // A sample finished without the baseline, or without a margin, runs again when
            // the comparison or the margin is asked.
            let baseline = read_report(&dir.join(BASELINE_REPORT));
            if o.compare_baseline && baseline.is_none() {
                continue;
            }
            // A sample finished with another ensemble (members or seed) runs again too.
            let ensemble =
                crate::pipeline::physics_params_of(s.config.params.physics.as_ref(), &o.variations)
                    .map(|p| o.physics.apply(p).ensemble)
                    .ok();
            let lacks_margin = |r: &Report| {
                r.physics.as_ref().is_some_and(|p| {
                    (o.margin && p.margin().is_none())
                        || ensemble.as_ref().is_some_and(|e| !same_ensemble(p, e))
                })
            };
            if lacks_margin(&report)
                || (o.compare_baseline && baseline.as_ref().is_some_and(lacks_margin))
            {
                continue;
            }
            fill(&mut row, &report, spec, dir, &stretched);
            if let (true, Some(b)) = (o.compare_baseline, &baseline) {
                fill_baseline(&mut row, b, spec, dir, &stretched);
            }
            return (row, BTreeMap::new(), Ran::Skipped);
        }
    }
    stages.insert("sample".into(), clock.elapsed().as_secs_f64());
    let stage = out.join(".work").join(&s.id);
    let (report, baseline) = execute(&s, ctx, loaded, o, &stage, &mut stages);
    fill(&mut row, &as_read_back(report), spec, &stage, &stretched);
    if let Some(b) = baseline {
        fill_baseline(&mut row, &as_read_back(b), spec, &stage, &stretched);
    }
    let clock = Instant::now();
    let dest = if row.status == "kept" { &kept } else { &failed };
    let moved = (|| -> std::io::Result<()> {
        for d in [&kept, &failed] {
            if d.exists() {
                std::fs::remove_dir_all(d)?;
            }
        }
        std::fs::create_dir_all(dest.parent().expect("kept/ or failed/"))?;
        std::fs::rename(&stage, dest)
    })();
    if let Err(e) = moved {
        row.status = "failed".into();
        row.reasons = "error".into();
        row.detail = Error::write(dest, e).to_string();
    }
    *stages.entry("write".into()).or_default() += clock.elapsed().as_secs_f64();
    (row, stages, Ran::Now)
}

/// Writes the sample's files into `stage` and runs the pipeline there with contact IK, and
/// with `--compare-baseline` again with the baseline hand (its report and frames written as
/// `baseline.report.json` and `baseline.frames.csv`: no other command takes them for an
/// output of the run). Always returns a report per hand run (with `error` set when
/// something failed, which is then also written).
fn execute(
    s: &Sample,
    ctx: &Context,
    loaded: &Loaded,
    o: &AugmentOptions,
    stage: &Path,
    stages: &mut BTreeMap<String, f64>,
) -> (Report, Option<Report>) {
    let clock = Instant::now();
    let inputs = match prepare(s, ctx, loaded, o, stage) {
        Ok(inputs) => inputs,
        Err(e) => {
            let message = e.to_string();
            let baseline = o
                .compare_baseline
                .then(|| error_report(s, "baseline", stage, BASELINE_REPORT, message.clone()));
            return (
                error_report(s, "contact", stage, "report.json", message),
                baseline,
            );
        }
    };
    stages.insert("load".into(), clock.elapsed().as_secs_f64());
    let contact = (|| -> Result<Report> {
        let mut run = pipeline::warp(&inputs, &sample_options(o, HandMethod::Contact))?;
        stages.extend(run.report.timing_s.clone());
        let clock = Instant::now();
        run.report.config = Some("config.json".into());
        crate::output::write_run(stage, &run)?;
        stages.insert("write".into(), clock.elapsed().as_secs_f64());
        Ok(run.report)
    })()
    .unwrap_or_else(|e| error_report(s, "contact", stage, "report.json", e.to_string()));
    let baseline = o.compare_baseline.then(|| {
        (|| -> Result<Report> {
            let mut run = pipeline::warp(&inputs, &sample_options(o, HandMethod::Baseline))?;
            for (k, v) in &run.report.timing_s {
                stages.insert(format!("baseline.{k}"), *v);
            }
            let clock = Instant::now();
            run.report.config = Some("config.json".into());
            let frames = stage.join(BASELINE_FRAMES);
            write_atomic(
                &frames,
                &crate::model::frames::csv_bytes(&frames, &run.frames)?,
            )?;
            write_json_atomic(&stage.join(BASELINE_REPORT), &run.report)?;
            stages.insert("baseline.write".into(), clock.elapsed().as_secs_f64());
            Ok(run.report)
        })()
        .unwrap_or_else(|e| error_report(s, "baseline", stage, BASELINE_REPORT, e.to_string()))
    });
    (contact, baseline)
}

/// The sample's config (and scene) written into `stage`, and the run's inputs: the config
/// read back from it with its scene, and the demonstration, robot and mesh loaded before.
fn prepare(
    s: &Sample,
    ctx: &Context,
    loaded: &Loaded,
    o: &AugmentOptions,
    stage: &Path,
) -> Result<Inputs> {
    if stage.exists() {
        std::fs::remove_dir_all(stage).map_err(|e| Error::write(stage, e))?;
    }
    std::fs::create_dir_all(stage).map_err(|e| Error::write(stage, e))?;
    // Paths relative to the sample folder: `.work/<id>`, `kept/<id>` and `failed/<id>`
    // are at the same depth, so they stay valid after the move.
    let mut config = s.config.clone();
    config.demo = relative_path(stage, &config.demo);
    config.scene = if config.scene.is_absolute() {
        relative_path(stage, &config.scene)
    } else {
        config.scene
    };
    if let Some(scene) = s.scene_file(ctx) {
        write_json_atomic(&stage.join("scene.json"), &scene)?;
    }
    let config_path = stage.join("config.json");
    write_json_atomic(&config_path, &config)?;
    let config = WarpConfig::load(&config_path, &o.limits)?;
    Inputs::with(config, loaded.clone(), &o.limits)
}

fn sample_options(o: &AugmentOptions, hand: HandMethod) -> Options {
    Options::new(hand)
        .limits(o.limits)
        .physics(Some(PhysicsOptions {
            margin: o.margin,
            ..o.physics.clone()
        }))
}

/// Whether a finished sample's physics was judged by the ensemble a run now asks for
/// (`want`: the spec's with the options on top): the same members and, with more than one,
/// the same seed and most members (a report from before the most members counts as K).
fn same_ensemble(
    p: &crate::model::report::PhysicsSummary,
    want: &crate::physics::EnsembleParams,
) -> bool {
    let (k, _) = p.ensemble_members();
    k == want.members
        && (k == 1
            || (p.ensemble_seed() == Some(want.seed)
                && p.ensemble_max().unwrap_or(k) == want.most_members()))
}

/// A report carrying the error of a hand run (`hand`), also written to `stage/file`.
fn error_report(s: &Sample, hand: &str, stage: &Path, file: &str, message: String) -> Report {
    let report = Report {
        format: REPORT_FORMAT.into(),
        name: s.config.name.clone(),
        config: Some("config.json".into()),
        threshold_mm: Some(s.config.params.threshold_mm),
        hand: Some(hand.into()),
        error: Some(message),
        ..Report::default()
    };
    // Best effort: the row carries the error even when this write fails.
    let _ = std::fs::create_dir_all(stage)
        .map_err(|e| Error::write(stage, e))
        .and_then(|_| write_json_atomic(&stage.join(file), &report));
    report
}

fn write_rows(path: &Path, rows: &[Row]) -> Result<()> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r)
            .map_err(|e| Error::write(path, std::io::Error::other(e)))?;
    }
    let bytes = w
        .into_inner()
        .map_err(|e| Error::write(path, std::io::Error::other(e.to_string())))?;
    write_atomic(path, &bytes)
}

fn read_rows(path: &Path) -> Result<Vec<Row>> {
    let mut r = csv::Reader::from_path(path)
        .map_err(|e| Error::read(path, std::io::Error::other(e.to_string())))?;
    r.deserialize()
        .enumerate()
        .map(|(k, row)| {
            row.map_err(|e| {
                Error::invalid(
                    path,
                    format!("row {}", k + 1),
                    format!("{e}; expected a samples.csv written by dexwarp augment"),
                )
            })
        })
        .collect()
}

/// Combines the shard files (`stats.shard-*.json`, `samples.shard-*.csv`) found in `dirs` into
/// `out/stats.json`, `samples.csv`, `manifest.jsonl` and `index.html`. Shards must come from the
/// same spec, demonstration, seed and count, and cover every sample exactly once.
pub fn merge(dirs: &[PathBuf], out: &Path, limits: &Limits) -> Result<Augment> {
    let mut shards: Vec<(PathBuf, Stats)> = Vec::new();
    let mut rows: Vec<Row> = Vec::new();
    for dir in dirs {
        let entries = std::fs::read_dir(dir).map_err(|e| Error::read(dir, e))?;
        let mut names: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
        names.sort();
        for p in names {
            let name = p.file_name().map(|n| n.to_string_lossy().into_owned());
            let Some(name) = name else { continue };
            if let Some(rest) = name.strip_prefix("stats.shard-")
                && let Some(suffix) = rest.strip_suffix(".json")
            {
                let stats: Stats = read_json(&p, limits)?;
                let samples = dir.join(format!("samples.shard-{suffix}.csv"));
                rows.extend(read_rows(&samples)?);
                shards.push((p, stats));
            }
        }
    }
    let Some((first_path, first)) = shards.first().cloned() else {
        return Err(Error::invalid(
            dirs.first().map_or(Path::new("."), |d| d.as_path()),
            "(folder)",
            "holds no stats.shard-K-of-N.json; expected folders written by dexwarp augment --shard K/N",
        ));
    };
    for (p, s) in &shards {
        for (field, a, b) in [
            ("spec_hash", &s.spec_hash, &first.spec_hash),
            ("demo", &s.demo, &first.demo),
            ("seed", &s.seed.to_string(), &first.seed.to_string()),
            ("count", &s.count.to_string(), &first.count.to_string()),
        ] {
            if a != b {
                return Err(Error::invalid(
                    p,
                    field,
                    format!(
                        "is {a:?} but {} has {b:?}; expected shards of one run (same spec, demonstration, seed and count)",
                        first_path.display()
                    ),
                ));
            }
        }
    }
    rows.sort_by_key(|r| r.index);
    let n = rows.len();
    rows.dedup_by_key(|r| r.index);
    if rows.len() != n {
        return Err(Error::invalid(
            &first_path,
            "shards",
            "some samples appear in two shards; expected each shard K/N of one run once",
        ));
    }
    if rows.len() as u64 != first.count {
        let have: std::collections::BTreeSet<u64> = rows.iter().map(|r| r.index).collect();
        let missing: Vec<String> = (0..first.count)
            .filter(|i| !have.contains(i))
            .take(5)
            .map(|i| i.to_string())
            .collect();
        return Err(Error::invalid(
            &first_path,
            "shards",
            format!(
                "cover {} of {} samples (missing {}...); expected every shard 0..N of the run to be finished",
                rows.len(),
                first.count,
                missing.join(", ")
            ),
        ));
    }
    let mut timing = Timing::default();
    let mut labels = Vec::new();
    for (_, s) in &shards {
        let t = &s.timing;
        timing.wall_s = timing.wall_s.max(t.wall_s);
        timing.core_s += t.core_s;
        timing.threads.extend(&t.threads);
        timing.ran_now += t.ran_now;
        timing.skipped_now += t.skipped_now;
        for (k, v) in &t.stage_s {
            *timing.stage_s.entry(k.clone()).or_default() += v;
        }
        labels.extend(s.shards.iter().cloned());
    }
    timing.finish();
    labels.sort();
    let id = RunId {
        spec: first.spec.clone(),
        spec_hash: u64::from_str_radix(&first.spec_hash, 16).unwrap_or(0),
        demo: first.demo.clone(),
        seed: first.seed,
        count: first.count,
        shards: labels,
    };
    std::fs::create_dir_all(out).map_err(|e| Error::write(out, e))?;
    let stats = Stats::of(&id, &rows, timing);
    write_all(out, &stats, &rows)?;
    Ok(Augment { stats, rows })
}
