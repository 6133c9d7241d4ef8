//! `dexwarp report DIR`: one HTML page for any folder of outputs (`reproduce`, `batch`,
//! `augment`, single `warp` or `validate` folders): every `report.json` below `DIR` is an
//! item, identified by its folder relative to `DIR`.
//!
//! The page: the comparison with a previous run when asked ([`compare`], at the top), the
//! counts of verdicts, the failure reasons (numbers folded so that alike reasons count
//! together), histograms of the metrics, the 3D player ([`crate::player`], one data script
//! per trajectory next to the page, loaded when picked) and a table of every item with its
//! verdict and first reason.

pub mod compare;
mod page;

use std::path::{Path, PathBuf};

use crate::model::report::Report;
use crate::{Error, Limits, Result};

pub use page::{GENERATOR, write_page};

/// Folders below `DIR` searched at most.
pub const MAX_DEPTH: usize = 12;
/// Items one page lists at most.
pub const MAX_ITEMS: usize = 200_000;

/// One output folder.
#[derive(Clone, Debug)]
pub struct Item {
    /// The folder relative to `DIR`, `/`-separated (`.` for `DIR` itself).
    pub id: String,
    pub dir: PathBuf,
    /// The report, or why it could not be read.
    pub report: std::result::Result<Report, String>,
}

impl Item {
    /// `pass`, `fail`, `error` (the run failed or its report is unreadable) or `not run`
    /// (no physics).
    pub fn status(&self) -> &str {
        match &self.report {
            Err(_) => "error",
            Ok(r) if r.error.is_some() => "error",
            Ok(r) => r.physics.as_ref().map_or("not run", |p| p.verdict.as_str()),
        }
    }

    /// The run's error, or every failed physics check.
    pub fn reasons(&self) -> Vec<String> {
        match &self.report {
            Err(e) => vec![e.clone()],
            Ok(r) => match &r.error {
                Some(e) => vec![e.clone()],
                None => r
                    .physics
                    .as_ref()
                    .map(|p| p.reasons.clone())
                    .unwrap_or_default(),
            },
        }
    }

    /// The report when the run finished.
    pub fn finished(&self) -> Option<&Report> {
        self.report.as_ref().ok().filter(|r| r.error.is_none())
    }
}

/// Total wall time of the stages of a report [s].
pub fn seconds(r: &Report) -> f64 {
    r.timing_s.values().filter(|x| x.is_finite()).sum()
}

/// Every `report.json` below `dir` (hidden folders, temporaries and `player/` skipped),
/// sorted by id.
pub fn collect(dir: &Path, limits: &Limits) -> Result<Vec<Item>> {
    if !dir.is_dir() {
        return Err(Error::invalid(
            dir,
            "(folder)",
            "is not a folder; expected a folder of dexwarp outputs (reproduce, batch, augment or warp)",
        ));
    }
    let mut items = Vec::new();
    let mut stack = vec![(dir.to_path_buf(), 0usize)];
    while let Some((d, depth)) = stack.pop() {
        let report = d.join(crate::output::REPORT);
        if report.is_file() {
            if items.len() >= MAX_ITEMS {
                return Err(Error::invalid(
                    dir,
                    "(folder)",
                    format!("holds more than {MAX_ITEMS} reports; make a page per sub-folder"),
                ));
            }
            let id = d
                .strip_prefix(dir)
                .ok()
                .map(|p| {
                    p.components()
                        .map(|c| c.as_os_str().to_string_lossy().into_owned())
                        .collect::<Vec<_>>()
                        .join("/")
                })
                .filter(|s| !s.is_empty())
                .unwrap_or_else(|| ".".into());
            items.push(Item {
                id,
                dir: d.clone(),
                report: crate::model::json::read_json::<Report>(&report, limits)
                    .map_err(|e| e.to_string()),
            });
        }
        if depth >= MAX_DEPTH {
            continue;
        }
        let Ok(rd) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in rd.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            let skip = name.starts_with('.') || name.ends_with(".tmp") || name == "player";
            if !skip && e.file_type().is_ok_and(|t| t.is_dir()) {
                stack.push((e.path(), depth + 1));
            }
        }
    }
    items.sort_by(|a, b| a.id.cmp(&b.id));
    Ok(items)
}
