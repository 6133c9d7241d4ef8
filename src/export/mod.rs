//! Datasets out: the trajectories below a folder as one training dataset.
//!
//! [`collect`] finds every trajectory below the given paths by its files: a `report.json`
//! with the `<name>.demo.json` it was written with beside it (the layout of `warp`,
//! `validate`, `batch`, `augment` and `reproduce`), or a demonstration file given directly
//! (no quality figures then). Each trajectory becomes one episode; [`lerobot::write`] writes
//! them as a LeRobot v3.0 dataset (state only, no video) with the quality figures of each
//! report as per-episode columns, so a learning stack filters on them
//! (`LeRobotDataset(..., episode_filter=...)`).
//!
//! Per frame (float32, the mapping documented in the README):
//! - `observation.state` = wrist position `[x, y, z]`, wrist orientation `[w, x, y, z]`, then
//!   the joint values in the demonstration's `joint_names` order;
//! - `observation.environment_state` = object position and orientation, same layout;
//! - `action` = the next frame's `observation.state` (the hand target one step ahead; the
//!   last frame repeats its own state).
//!
//! [`export_robomimic`] writes the same episodes as one robomimic HDF5 file (cargo feature
//! `robomimic`, see [`robomimic`]).
//!
//! Output is atomic: the dataset is written into a hidden temporary folder (or file) beside
//! `OUT`, then renamed into place; an existing `OUT` is refused unless `force`.

pub mod lerobot;
mod light;
#[cfg(feature = "robomimic")]
pub mod robomimic;
pub mod stats;

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::model::report::Report;
use crate::{Error, Limits, Result};

/// What `export` writes and from what.
#[derive(Clone, Debug)]
pub struct ExportOptions {
    /// Folders (searched recursively for `report.json`) and demonstration files.
    pub inputs: Vec<PathBuf>,
    /// The dataset folder to create.
    pub out: PathBuf,
    /// Keep only trajectories whose physics verdict is `pass` (and that have a report).
    pub only_passing: bool,
    /// Keep only passing trajectories whose robustness margin holds under every condition
    /// (`physics.robust`; runs made with `--margin`).
    pub only_robust: bool,
    /// Frame rate of the dataset [Hz]; must divide the trajectories' own rate (every k-th
    /// frame is kept). `None`: the trajectories' rate, which must be a whole number.
    pub fps: Option<u32>,
    /// Keep only trajectories of this robot (the URDF file's stem, e.g. `human_hand`).
    pub robot: Option<String>,
    /// Largest data file, LeRobot's `data_files_size_in_mb` (default 100).
    pub data_file_mb: u64,
    /// Replace an existing `out`.
    pub force: bool,
    /// Show a progress bar on a terminal.
    pub progress: bool,
    /// robomimic: `actions` as absolute targets instead of scaled into [-1, 1].
    pub absolute_actions: bool,
}

impl ExportOptions {
    pub fn new(inputs: Vec<PathBuf>, out: PathBuf) -> ExportOptions {
        ExportOptions {
            inputs,
            out,
            only_passing: false,
            only_robust: false,
            fps: None,
            robot: None,
            data_file_mb: lerobot::DEFAULT_DATA_FILE_MB,
            force: false,
            progress: false,
            absolute_actions: false,
        }
    }
}

/// One trajectory found below the inputs.
#[derive(Clone, Debug)]
pub struct Found {
    /// The demonstration file.
    pub demo: PathBuf,
    /// Its report, when it has one.
    pub report: Option<PathBuf>,
}

/// The quality figures of one episode, from its report (`None` where the report does not
/// have the figure, or there is no report).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Quality {
    /// The trajectory's name (`report.name`, else the demonstration's).
    pub name: String,
    /// `pass`, `fail`, or `unknown` (no report or no physics).
    pub verdict: String,
    /// Every failed physics check, in words.
    pub failure_reasons: Vec<String>,
    /// The robustness margin holds under every condition (`physics.robust`); `None` when the
    /// report has no margin.
    pub robust: Option<bool>,
    /// The ensemble's pass fraction (`physics.ensemble`); `None` for a single replay.
    pub pass_fraction: Option<f64>,
    /// The ensemble's 95 % interval contains its keep threshold; `None` for a single replay.
    pub uncertain: Option<bool>,
    pub d_c_mm: Option<f64>,
    pub d_c_original_mm: Option<f64>,
    pub d_wo_mm: Option<f64>,
    pub d_wo_original_mm: Option<f64>,
    pub plr_object: Option<f64>,
    pub plr_hand: Option<f64>,
    pub timewarp_discrepancy: Option<f64>,
    /// Deepest hand-object penetration of the output (IK probes) [mm].
    pub hand_object_penetration_mm: Option<f64>,
    /// Deepest hand-object penetration seen by physics [mm].
    pub physics_hand_object_penetration_mm: Option<f64>,
    /// Deepest object-barrier penetration seen by physics [mm].
    pub physics_object_barrier_penetration_mm: Option<f64>,
    /// Largest object tracking errors in physics [mm], [deg].
    pub tracking_max_position_error_mm: Option<f64>,
    pub tracking_max_rotation_error_deg: Option<f64>,
    pub ik_converged_fraction: Option<f64>,
    /// The demonstration the trajectory was warped from (path as the report records it).
    pub source_demo: String,
    /// The config of the warp (path as the report records it).
    pub config: String,
    /// The report file, relative to the export's input when possible.
    pub report: String,
}

/// One episode in memory: per-frame float32 rows and the quality figures.
#[derive(Clone, Debug)]
pub struct Episode {
    /// `observation.state` rows: wrist pose (7) and joints.
    pub state: Vec<Vec<f32>>,
    /// `observation.environment_state` rows: object pose (7).
    pub object: Vec<Vec<f32>>,
    pub quality: Quality,
    /// The natural-language task (LeRobot `tasks`): the object and the trajectory's name.
    pub task: String,
}

/// The episodes of an export and what they share.
#[derive(Clone, Debug)]
pub struct Collected {
    pub fps: u32,
    /// Joint names (the layout of `observation.state` after the wrist).
    pub joint_names: Vec<String>,
    /// Robot name (the URDF file's stem).
    pub robot: String,
    pub episodes: Vec<Episode>,
    /// Trajectories left out, each with why.
    pub skipped: Vec<(PathBuf, String)>,
}

/// The names of the 7 pose entries, prefixed (`wrist.x`, ..., `wrist.qz`).
pub fn pose_names(prefix: &str) -> Vec<String> {
    ["x", "y", "z", "qw", "qx", "qy", "qz"]
        .iter()
        .map(|s| format!("{prefix}.{s}"))
        .collect()
}

/// Every trajectory below `inputs`, sorted by path: reports with their demonstration, and
/// demonstration files given directly.
pub fn find(inputs: &[PathBuf]) -> Result<Vec<Found>> {
    let mut out = Vec::new();
    for input in inputs {
        if input.is_file() && input.extension().is_some_and(|e| e == "csv") {
            out.extend(from_list(input)?);
            continue;
        }
        if input.is_file() {
            out.push(Found {
                demo: input.clone(),
                report: None,
            });
            continue;
        }
        if !input.is_dir() {
            return Err(Error::invalid(
                input,
                "(input)",
                "does not exist; expected an output folder of warp, batch, augment or reproduce, a .demo.json file, or a list `dexwarp filter` wrote",
            ));
        }
        for report in crate::filter::find_reports(input)? {
            // The report names its demonstration: `<name>.demo.json` beside it.
            let name = read_report(&report).map(|r| r.name).unwrap_or_default();
            out.push(Found {
                demo: report.with_file_name(format!("{name}.demo.json")),
                report: Some(report),
            });
        }
    }
    Ok(out)
}

/// The trajectories of a list `dexwarp filter` wrote (`KEEP.csv`, or its `.dropped.csv`):
/// every row's report and demonstration. A relative path is taken from the current folder
/// (where `filter` ran) when it is there, else from the list's folder.
fn from_list(list: &Path) -> Result<Vec<Found>> {
    #[derive(serde::Deserialize)]
    struct ListRow {
        name: String,
        report: String,
        demo: String,
    }
    let bytes = std::fs::read(list).map_err(|e| Error::read(list, e))?;
    let mut rdr = csv::Reader::from_reader(bytes.as_slice());
    let header = rdr
        .headers()
        .map_err(|e| Error::invalid(list, "header", e.to_string()))?
        .clone();
    if !["name", "report", "demo"]
        .iter()
        .all(|c| header.iter().any(|h| h == *c))
    {
        return Err(Error::invalid(
            list,
            "header",
            format!(
                "is {:?}; expected a list written by `dexwarp filter` (columns name, report, demo, ...)",
                header.iter().collect::<Vec<_>>()
            ),
        ));
    }
    let base = list.parent().unwrap_or(Path::new(""));
    let resolve = |p: &str| {
        let p = PathBuf::from(p);
        if p.is_absolute() || p.exists() {
            p
        } else {
            base.join(p)
        }
    };
    let mut out = Vec::new();
    for (i, row) in rdr.deserialize::<ListRow>().enumerate() {
        let row = row.map_err(|e| Error::invalid(list, format!("row {}", i + 1), e.to_string()))?;
        let report = resolve(&row.report);
        let demo = if row.demo.is_empty() {
            report.with_file_name(format!("{}.demo.json", row.name))
        } else {
            resolve(&row.demo)
        };
        out.push(Found {
            demo,
            report: Some(report),
        });
    }
    Ok(out)
}

fn read_report(path: &Path) -> Result<Report> {
    let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
    serde_json::from_slice(&bytes).map_err(|e| Error::Parse {
        path: path.to_path_buf(),
        field: format!("line {}, column {}", e.line(), e.column()),
        message: e.to_string(),
    })
}

/// The quality figures of `report` (see [`Quality`]).
pub fn quality_of(report: &Report, report_path: &str) -> Quality {
    let m = &report.metrics;
    let phys = report.physics.as_ref();
    let measure = |path: &[&str]| -> Option<f64> {
        let mut v = phys?.measures.get(path[0])?;
        for k in &path[1..] {
            v = v.get(k)?;
        }
        v.as_f64()
    };
    let input = |k: &str| {
        report
            .provenance
            .as_ref()
            .and_then(|p| p.inputs.get(k))
            .map(|f| f.path.clone())
            .unwrap_or_default()
    };
    Quality {
        name: report.name.clone(),
        verdict: phys.map_or("unknown".into(), |p| p.verdict.clone()),
        failure_reasons: phys.map(|p| p.reasons.clone()).unwrap_or_default(),
        robust: phys.and_then(|p| p.robust()),
        pass_fraction: phys.and_then(|p| p.pass_fraction()),
        uncertain: phys.and_then(|p| p.uncertain()),
        d_c_mm: Some(m.d_c_mm.warped),
        d_c_original_mm: Some(m.d_c_mm.original),
        d_wo_mm: Some(m.d_wo_mm.warped),
        d_wo_original_mm: Some(m.d_wo_mm.original),
        plr_object: Some(m.plr_object),
        plr_hand: Some(m.plr_hand),
        timewarp_discrepancy: Some(m.timewarp_discrepancy),
        hand_object_penetration_mm: report
            .constraints
            .hand_object_penetration_mm
            .map(|p| p.warped),
        physics_hand_object_penetration_mm: measure(&["penetration", "hand_object", "max_mm"]),
        physics_object_barrier_penetration_mm: measure(&[
            "penetration",
            "object_barrier",
            "max_mm",
        ]),
        tracking_max_position_error_mm: measure(&["tracking", "max_position_error_mm"]),
        tracking_max_rotation_error_deg: measure(&["tracking", "max_rotation_error_deg"]),
        ik_converged_fraction: report.ik.as_ref().map(|i| i.converged_fraction),
        source_demo: input("demo"),
        config: report.config.clone().unwrap_or_else(|| input("config")),
        report: report_path.to_string(),
    }
}

/// The frame stride that turns `demo_fps` into `fps`, or why it cannot.
fn stride_for(demo_fps: f64, fps: Option<u32>, path: &Path) -> Result<(u32, usize)> {
    let whole = |x: f64| (x - x.round()).abs() < 1e-6 && x.round() >= 1.0;
    match fps {
        None if whole(demo_fps) => Ok((demo_fps.round() as u32, 1)),
        None => Err(Error::invalid(
            path,
            "fps",
            format!(
                "is {demo_fps}; a LeRobot dataset needs a whole frame rate: pass --fps F with F dividing {demo_fps}"
            ),
        )),
        Some(f) => {
            let k = demo_fps / f as f64;
            if f == 0 || !whole(k) {
                return Err(Error::invalid(
                    path,
                    "fps",
                    format!(
                        "is {demo_fps}; --fps {f} must divide it (every k-th frame is kept, k whole)"
                    ),
                ));
            }
            Ok((f, k.round() as usize))
        }
    }
}

/// The error for inputs in which no trajectory was found: filter lists that kept none, or
/// folders without reports.
fn nothing_found(inputs: &[PathBuf]) -> Error {
    let lists = inputs
        .iter()
        .all(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv")));
    Error::invalid(
        &inputs[0],
        "(input)",
        if lists {
            "lists no trajectory (the filter that wrote it kept none; its .dropped.csv says why); expected at least one kept trajectory"
        } else {
            "contains no report.json; expected an output folder of warp, batch, augment or reproduce, or a .demo.json file"
        },
    )
}

/// Reads every trajectory below `options.inputs` (in parallel) into episodes, applying
/// `--only-passing`, `--robot` and `--fps`. Trajectories whose set is incomplete, that
/// failed to run, or have no demonstration are skipped with the reason.
pub fn collect(options: &ExportOptions, limits: &Limits) -> Result<Collected> {
    let found = find(&options.inputs)?;
    if found.is_empty() {
        return Err(nothing_found(&options.inputs));
    }
    let mut bar =
        crate::output::progress::Progress::new("export", found.len() as u64, options.progress);
    bar.set_message("reading trajectories");
    let loaded: Vec<(Found, std::result::Result<Loaded, LoadError>)> = found
        .into_par_iter()
        .map(|f| {
            let r = load_one(&f, options, limits);
            bar.inc(1);
            (f, r)
        })
        .collect();
    bar.finish_and_clear();
    let mut skipped = Vec::new();
    let mut kept = Vec::new();
    for (f, r) in loaded {
        match r {
            Ok(x) => kept.push(x),
            Err(LoadError::Skip(why)) => skipped.push((f.report.unwrap_or(f.demo), why)),
            // An input the user named that cannot be used is an error, not a skip.
            Err(LoadError::Fatal(e)) => return Err(e),
        }
    }
    // One robot per dataset: the feature shapes are fixed.
    let mut robots: Vec<(String, usize)> = Vec::new();
    for l in &kept {
        match robots.iter_mut().find(|(r, _)| *r == l.robot) {
            Some(e) => e.1 += 1,
            None => robots.push((l.robot.clone(), 1)),
        }
    }
    if let Some(r) = &options.robot {
        kept.retain(|l| {
            let same = l.robot == *r;
            if !same {
                skipped.push((
                    l.source.clone(),
                    format!("robot {} is not --robot {r}", l.robot),
                ));
            }
            same
        });
    } else if robots.len() > 1 {
        let list: Vec<String> = robots.iter().map(|(r, n)| format!("{r} ({n})")).collect();
        return Err(Error::invalid(
            &options.inputs[0],
            "(robots)",
            format!(
                "holds trajectories of {} robots: {}; a dataset has one state layout: pass --robot NAME",
                robots.len(),
                list.join(", ")
            ),
        ));
    }
    let Some(first) = kept.first() else {
        return Err(Error::invalid(
            &options.inputs[0],
            "(input)",
            format!(
                "no trajectory to export ({} skipped{}); check --only-passing, --only-robust and --robot",
                skipped.len(),
                skipped
                    .first()
                    .map(|(p, w)| format!(", first: {}: {w}", p.display()))
                    .unwrap_or_default()
            ),
        ));
    };
    let (fps, joint_names, robot, first_source) = (
        first.fps,
        first.joint_names.clone(),
        first.robot.clone(),
        first.source.clone(),
    );
    let mut episodes = Vec::with_capacity(kept.len());
    for l in kept {
        if l.joint_names != joint_names {
            return Err(Error::invalid(
                &l.source,
                "joint_names",
                format!(
                    "differ from those of {} (the dataset's state layout); export them separately",
                    first_source.display()
                ),
            ));
        }
        if l.fps != fps {
            return Err(Error::invalid(
                &l.source,
                "fps",
                format!(
                    "gives {} Hz; {} gives {fps} Hz: pass --fps with a rate that divides both",
                    l.fps,
                    first_source.display()
                ),
            ));
        }
        episodes.push(l.episode);
    }
    Ok(Collected {
        fps,
        joint_names,
        robot,
        episodes,
        skipped,
    })
}

/// One trajectory read and converted (the demonstration itself is dropped at once: a
/// reproduce output holds gigabytes of correspondences).
struct Loaded {
    fps: u32,
    joint_names: Vec<String>,
    robot: String,
    source: PathBuf,
    episode: Episode,
}

enum LoadError {
    /// Left out of the dataset, with why.
    Skip(String),
    /// An input the user named that cannot be read.
    Fatal(Error),
}

fn load_one(
    f: &Found,
    options: &ExportOptions,
    limits: &Limits,
) -> std::result::Result<Loaded, LoadError> {
    // A demonstration given directly that cannot be used is the user's error; one of a run
    // folder is skipped with the reason.
    let fail = |e: Error| {
        if f.report.is_none() {
            LoadError::Fatal(e)
        } else {
            LoadError::Skip(e.to_string())
        }
    };
    let mut quality = None;
    let mut listed_sha = None;
    if let Some(path) = &f.report {
        let report = read_report(path).map_err(|e| LoadError::Skip(e.to_string()))?;
        if let Some(e) = &report.error {
            return Err(LoadError::Skip(format!("the run failed: {e}")));
        }
        let passed = report.physics.as_ref().filter(|p| p.verdict == "pass");
        if (options.only_passing || options.only_robust) && passed.is_none() {
            return Err(LoadError::Skip("physics verdict is not pass".into()));
        }
        if let Some(why) = passed
            .filter(|_| options.only_robust)
            .and_then(|p| p.not_robust_because())
        {
            return Err(LoadError::Skip(why));
        }
        // The set's other files must match the report (the demonstration is checked below
        // from the bytes read once).
        let demo_name = f.demo.file_name().map(|n| n.to_string_lossy().into_owned());
        let mut rest = report.clone();
        if let Some(n) = &demo_name {
            listed_sha = rest.outputs.remove(n);
        }
        crate::output::set_is_complete(path, &rest).map_err(LoadError::Skip)?;
        let rel = relative_to_inputs(path, &options.inputs);
        quality = Some(quality_of(&report, &rel));
    } else if options.only_passing || options.only_robust {
        return Err(LoadError::Skip("no report, so no physics pass".into()));
    }
    if !f.demo.is_file() {
        if f.report.is_some() && listed_sha.is_none() {
            return Err(LoadError::Skip(
                "the run kept no demonstration (reproduce keeps those of contact IK at 3.5 mm and the baseline; reproduce --all-demos keeps every run's)".into(),
            ));
        }
        return Err(LoadError::Skip(format!(
            "no demonstration {} beside the report",
            f.demo.display()
        )));
    }
    let bytes =
        crate::model::json::read_limited(&f.demo, limits, limits.max_file_bytes, "--max-file-mb")
            .map_err(fail)?;
    let demo = match listed_sha {
        Some(sha) if crate::model::provenance::sha256_hex(&bytes) != sha => {
            return Err(LoadError::Skip(format!(
                "{} is not the file this report was written with (a mixed or interrupted output set)",
                f.demo.display()
            )));
        }
        Some(_) => light::parse_verified(&f.demo, &bytes, limits),
        None => light::parse(&f.demo, &bytes, limits),
    }
    .map_err(fail)?;
    let (fps, stride) = stride_for(demo.fps, options.fps, &f.demo).map_err(LoadError::Fatal)?;
    let (state, object) = demo.rows(stride);
    let quality = quality.unwrap_or_else(|| Quality {
        name: demo.name.clone(),
        verdict: "unknown".into(),
        ..Quality::default()
    });
    let task = format!("{}: {}", demo.object_name, quality.name);
    Ok(Loaded {
        fps,
        robot: demo.robot_stem(),
        source: f.demo.clone(),
        joint_names: demo.joint_names,
        episode: Episode {
            state,
            object,
            quality,
            task,
        },
    })
}

fn relative_to_inputs(path: &Path, inputs: &[PathBuf]) -> String {
    for i in inputs {
        if let Ok(rel) = path.strip_prefix(i) {
            return rel.display().to_string();
        }
    }
    path.display().to_string()
}

/// What [`export`] wrote.
#[derive(Clone, Debug)]
pub struct Exported {
    pub episodes: usize,
    pub frames: usize,
    pub data_files: usize,
    pub skipped: Vec<(PathBuf, String)>,
}

/// Collects the trajectories and writes the LeRobot v3.0 dataset to `options.out`
/// atomically.
pub fn export_lerobot(options: &ExportOptions, limits: &Limits) -> Result<Exported> {
    check_out(options)?;
    let collected = collect(options, limits)?;
    let frames = collected.episodes.iter().map(|e| e.state.len()).sum();
    let data_files = write_atomic_dir(&options.out, options.force, |tmp| {
        lerobot::write(tmp, &collected, options.data_file_mb)
    })?;
    Ok(Exported {
        episodes: collected.episodes.len(),
        frames,
        data_files,
        skipped: collected.skipped,
    })
}

/// What a user must do to get `--format robomimic` on a build without the feature.
pub const ROBOMIMIC_HOW: &str = "this dexwarp was built without robomimic HDF5 support: install the HDF5 C library (Debian/Ubuntu: apt-get install libhdf5-dev; macOS: brew install hdf5) and build with the cargo feature robomimic (cargo build --release --features robomimic), or export --format lerobot";

/// Collects the trajectories and writes them as one robomimic HDF5 file `options.out`,
/// atomically (see [`robomimic`]). Without the cargo feature `robomimic`, an error that
/// says what to install and enable, before anything is read.
pub fn export_robomimic(options: &ExportOptions, limits: &Limits) -> Result<Exported> {
    #[cfg(not(feature = "robomimic"))]
    {
        let _ = limits;
        Err(Error::invalid(
            &options.out,
            "--format robomimic",
            ROBOMIMIC_HOW,
        ))
    }
    #[cfg(feature = "robomimic")]
    {
        check_out(options)?;
        let collected = collect(options, limits)?;
        let frames = collected.episodes.iter().map(|e| e.state.len()).sum();
        write_atomic_file(&options.out, options.force, |tmp| {
            robomimic::write(tmp, &collected, options.absolute_actions)
        })?;
        Ok(Exported {
            episodes: collected.episodes.len(),
            frames,
            data_files: 1,
            skipped: collected.skipped,
        })
    }
}

/// The hidden temporary path `.<name>.dexwarp-tmp-<pid>-<suffix>` beside `out` that an
/// output is written to before it is renamed into place (its folder made, stale temporaries
/// of killed runs removed).
fn staging_path(out: &Path, suffix: &str) -> Result<PathBuf> {
    let parent = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&parent).map_err(|e| Error::write(&parent, e))?;
    crate::output::clean_stale(&parent);
    let base = out
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "dataset".into());
    Ok(parent.join(format!(
        ".{base}.dexwarp-tmp-{}-{suffix}",
        std::process::id()
    )))
}

/// Runs `write` on a hidden temporary file beside `out`, then renames it to `out`
/// (replacing an old `out` only when `force`). The temporary is removed on error.
pub fn write_atomic_file(
    out: &Path,
    force: bool,
    write: impl FnOnce(&Path) -> Result<()>,
) -> Result<()> {
    let tmp = staging_path(out, "0")?;
    let _ = std::fs::remove_file(&tmp);
    if let Err(e) = write(&tmp) {
        let _ = std::fs::remove_file(&tmp);
        return Err(e);
    }
    if out.exists() && (!force || out.is_dir()) {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::invalid(
            out,
            "(output)",
            if out.is_dir() {
                "is a folder; --format robomimic writes one file: choose a file name such as out/dataset.hdf5"
            } else {
                "exists; choose a new --out file or pass --force to replace it"
            },
        ));
    }
    std::fs::rename(&tmp, out).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::write(out, e)
    })
}

fn check_out(options: &ExportOptions) -> Result<()> {
    if options.out.exists() && !options.force {
        return Err(Error::invalid(
            &options.out,
            "(output)",
            "exists; choose a new --out folder or pass --force to replace it",
        ));
    }
    for i in &options.inputs {
        if let (Ok(a), Ok(b)) = (
            std::fs::canonicalize(i),
            std::fs::canonicalize(&options.out),
        ) && (a.starts_with(&b) || b.starts_with(&a))
        {
            return Err(Error::invalid(
                &options.out,
                "(output)",
                format!(
                    "overlaps the input {}; choose an --out folder outside it",
                    i.display()
                ),
            ));
        }
    }
    Ok(())
}

/// Runs `write` into a hidden temporary folder beside `out`, then renames it to `out`
/// (replacing an old `out` only when `force`). The temporary is removed on error.
pub fn write_atomic_dir<T>(
    out: &Path,
    force: bool,
    write: impl FnOnce(&Path) -> Result<T>,
) -> Result<T> {
    let tmp = staging_path(out, "0")?;
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir(&tmp).map_err(|e| Error::write(&tmp, e))?;
    let result = write(&tmp);
    let value = match result {
        Ok(v) => v,
        Err(e) => {
            let _ = std::fs::remove_dir_all(&tmp);
            return Err(e);
        }
    };
    if out.exists() {
        if !force {
            let _ = std::fs::remove_dir_all(&tmp);
            return Err(Error::invalid(
                out,
                "(output)",
                "exists; choose a new --out folder or pass --force to replace it",
            ));
        }
        let old = staging_path(out, "old")?;
        std::fs::rename(out, &old).map_err(|e| Error::write(out, e))?;
        std::fs::rename(&tmp, out).map_err(|e| Error::write(out, e))?;
        let _ = std::fs::remove_dir_all(&old);
    } else if let Err(e) = std::fs::rename(&tmp, out) {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(Error::write(out, e));
    }
    Ok(value)
}
