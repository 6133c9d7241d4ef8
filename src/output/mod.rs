//! Output files of a run: the warped demonstration, `report.json` and `frames.csv`.
//!
//! Every file is written atomically (temporary file in the same folder, then rename), so an
//! interrupted run never leaves a truncated report.

pub mod frames;
pub mod progress;

use std::path::{Path, PathBuf};

use crate::Result;
use crate::model::json::write_json_atomic;
use crate::pipeline::WarpRun;

/// Paths written by [`write_run`].
#[derive(Clone, Debug, PartialEq)]
pub struct Written {
    pub demo: PathBuf,
    pub report: PathBuf,
    pub frames: PathBuf,
}

/// Writes `DIR/<name>.demo.json`, `DIR/report.json` and `DIR/frames.csv`.
pub fn write_run(dir: &Path, run: &WarpRun) -> Result<Written> {
    let demo = dir.join(format!("{}.demo.json", run.demo.name));
    run.demo.save(&demo)?;
    let frames = dir.join("frames.csv");
    frames::write_csv(&frames, &run.frames)?;
    // The report last: its presence marks a finished item for `batch`.
    let report = dir.join("report.json");
    write_json_atomic(&report, &run.report)?;
    Ok(Written {
        demo,
        report,
        frames,
    })
}
