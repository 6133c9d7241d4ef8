//! Output files of a run: the warped demonstration, `report.json` and `frames.csv`.
//!
//! A run's files are committed as a set ([`commit_set`]): all of them are written into a
//! temporary folder beside the output folder, then moved into place, the report last. Into a
//! new folder the whole temporary folder is renamed at once; into an existing one the old
//! report goes first (no report = no finished run), then the other files, then the new
//! report. Runs committing into one folder at the same time take turns (a lock on the parent
//! folder), so the last one's whole set is what stays. The report records the SHA-256 of every other file of its set
//! ([`Report::outputs`]), and `filter`, `batch` and reruns trust a report only when those
//! match ([`set_is_complete`]), so a full disk, a kill or two runs into one folder never pass
//! off a mixed set as a finished run. Temporaries left by killed runs are removed by the next
//! run that writes there ([`clean_stale`]).

pub mod progress;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::model::provenance::sha256_hex;
use crate::model::report::Report;
use crate::pipeline::WarpRun;
use crate::{Error, Result};

/// Paths written by [`write_run`].
#[derive(Clone, Debug, PartialEq)]
pub struct Written {
    pub demo: PathBuf,
    pub report: PathBuf,
    pub frames: PathBuf,
}

/// The report's file name in every output folder.
pub const REPORT: &str = "report.json";

/// The file names a warp run named `name` writes.
pub fn run_file_names(name: &str) -> [String; 3] {
    [
        format!("{name}.demo.json"),
        "frames.csv".to_string(),
        REPORT.to_string(),
    ]
}

/// Writes `DIR/<name>.demo.json`, `DIR/frames.csv` and `DIR/report.json` as one set.
pub fn write_run(dir: &Path, run: &WarpRun) -> Result<Written> {
    let [demo_name, frames_name, _] = run_file_names(&run.demo.name);
    let demo = dir.join(&demo_name);
    let demo_bytes = run.demo.to_bytes(&demo)?;
    let frames = dir.join(&frames_name);
    let frames_bytes = crate::model::frames::csv_bytes(&frames, &run.frames)?;
    let mut report = run.report.clone();
    commit_set(
        dir,
        vec![(demo_name, demo_bytes), (frames_name, frames_bytes)],
        &mut report,
    )?;
    Ok(Written {
        demo,
        report: dir.join(REPORT),
        frames,
    })
}

/// [`write_run`] without the demonstration: `DIR/frames.csv` and `DIR/report.json` as one
/// set (the report's figures hold; the warped trajectory is not kept).
pub fn write_run_without_demo(dir: &Path, run: &WarpRun) -> Result<()> {
    let [_, frames_name, _] = run_file_names(&run.demo.name);
    let frames_bytes = crate::model::frames::csv_bytes(&dir.join(&frames_name), &run.frames)?;
    let mut report = run.report.clone();
    commit_set(dir, vec![(frames_name, frames_bytes)], &mut report)
}

/// Refuses an output folder where a file of the run would replace one of its inputs (a
/// config `name` equal to the demonstration's file stem, with `--out` on its folder).
pub fn check_not_inputs(dir: &Path, names: &[String], inputs: &[&Path]) -> Result<()> {
    let canon = |p: &Path| std::fs::canonicalize(p).ok();
    let inputs: Vec<PathBuf> = inputs.iter().filter_map(|p| canon(p)).collect();
    for name in names {
        let out = dir.join(name);
        if let Some(c) = canon(&out)
            && inputs.contains(&c)
        {
            return Err(Error::invalid(
                &out,
                "(output)",
                "is an input of this run; the run would overwrite it: choose another --out folder or another config name",
            ));
        }
    }
    Ok(())
}

/// Writes `files` and then `report` (with [`Report::outputs`] set to the files' hashes) into
/// `dir` as one set; see the module docs.
pub fn commit_set(dir: &Path, files: Vec<(String, Vec<u8>)>, report: &mut Report) -> Result<()> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    report.outputs = files
        .iter()
        .map(|(n, b)| (n.clone(), sha256_hex(b)))
        .collect();
    let mut report_bytes = serde_json::to_vec_pretty(report)
        .map_err(|e| Error::write(&dir.join(REPORT), std::io::Error::other(e)))?;
    report_bytes.push(b'\n');

    let parent = match dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&parent).map_err(|e| Error::write(&parent, e))?;
    clean_stale(&parent);
    if dir.is_dir() {
        clean_stale(dir);
    }
    let base = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let staging = parent.join(format!(
        ".{base}.dexwarp-tmp-{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let write_all = || -> std::io::Result<()> {
        std::fs::create_dir(&staging)?;
        for (name, bytes) in files
            .iter()
            .chain(std::iter::once(&(REPORT.to_string(), report_bytes.clone())))
        {
            let mut f = std::fs::File::create(staging.join(name))?;
            f.write_all(bytes)?;
            f.sync_all()?;
        }
        Ok(())
    };
    if let Err(e) = write_all() {
        let _ = std::fs::remove_dir_all(&staging);
        return Err(Error::write(dir, e));
    }
    // Runs committing into the same folder at the same time take turns (an advisory lock on
    // the parent folder, held until this function returns), so the folder never ends with one
    // run's report beside another run's files. Where the file system has no locks, best effort.
    let _turn = std::fs::File::open(&parent).and_then(|f| f.lock().map(|()| f));
    // A new folder: the whole set at once.
    if !dir.exists() && std::fs::rename(&staging, dir).is_ok() {
        return Ok(());
    }
    let moved = (|| -> std::io::Result<()> {
        std::fs::create_dir_all(dir)?;
        match std::fs::remove_file(dir.join(REPORT)) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(e),
            _ => {}
        }
        for (name, _) in &files {
            std::fs::rename(staging.join(name), dir.join(name))?;
        }
        std::fs::rename(staging.join(REPORT), dir.join(REPORT))
    })();
    let _ = std::fs::remove_dir_all(&staging);
    moved.map_err(|e| Error::write(dir, e))
}

/// True when every file `report` lists in [`Report::outputs`] sits beside `report_path` with
/// that content. Reports that list none (older reports, failure reports) count as complete.
pub fn set_is_complete(report_path: &Path, report: &Report) -> std::result::Result<(), String> {
    let dir = report_path.parent().unwrap_or(Path::new("."));
    for (name, sha) in &report.outputs {
        match std::fs::read(dir.join(name)) {
            Ok(b) if sha256_hex(&b) == *sha => {}
            Ok(_) => {
                return Err(format!(
                    "{name} is not the file this report was written with (a mixed or interrupted output set)"
                ));
            }
            Err(_) => return Err(format!("{name} is missing (an interrupted output set)")),
        }
    }
    Ok(())
}

/// Removes the temporaries of killed runs from `dir`: staging folders
/// `.<name>.dexwarp-tmp-<pid>-<n>` and atomic-write files `.<name>.<pid>.tmp` whose process
/// is gone. Temporaries of live processes (a concurrent run) are left alone; so is
/// everything where liveness cannot be told (no `/proc`).
pub fn clean_stale(dir: &Path) {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let me = std::process::id();
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if !name.starts_with('.') {
            continue;
        }
        let pid = if let Some((_, tail)) = name.rsplit_once(".dexwarp-tmp-") {
            tail.split('-').next().and_then(|p| p.parse::<u32>().ok())
        } else if let Some(stem) = name.strip_suffix(".tmp") {
            stem.rsplit_once('.')
                .and_then(|(_, p)| p.parse::<u32>().ok())
        } else {
            None
        };
        let Some(pid) = pid else { continue };
        if pid == me || Path::new(&format!("/proc/{pid}")).exists() {
            continue;
        }
        let p = e.path();
        let _ = if p.is_dir() {
            std::fs::remove_dir_all(&p)
        } else {
            std::fs::remove_file(&p)
        };
    }
}
