//! Filtering a folder of reports: keep what passes, say why each of the rest was dropped.
//!
//! Every `report.json` below the folder is read. An item is kept when it has no error, its
//! physics verdict is `pass` (unless physics is not required), and it meets every threshold the
//! user set. A dropped item lists every reason, not just the first.

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::model::json::write_atomic;
use crate::model::report::Report;
use crate::physics::Turn;
use crate::{Error, Result};

/// What an item must meet to be kept. `None` leaves a check out.
#[derive(Clone, Debug, PartialEq)]
pub struct Criteria {
    /// Require `physics.verdict == "pass"`. Default true.
    pub require_physics_pass: bool,
    /// Require `physics.robust == true` (a margin measured, every condition held).
    /// Default false.
    pub require_robust: bool,
    /// Largest output D_C [mm].
    pub max_dc_mm: Option<f64>,
    /// Smallest IK converged fraction.
    pub min_converged_fraction: Option<f64>,
    /// Largest waypoint error [mm].
    pub max_waypoint_error_mm: Option<f64>,
    /// Largest timewarp discrepancy.
    pub max_timewarp_discrepancy: Option<f64>,
    /// Largest onset [mm]: how far the hand's approach and closing moved the object by the
    /// first contact frame (`physics.onset`); a trajectory that shoves the object as it
    /// grasps it passes physics yet teaches a policy to shove.
    pub max_onset_mm: Option<f64>,
    /// Largest turn [deg] of the released object by the hand (`physics.release.turn`, when
    /// the hand still touches the object once it has turned 5°): a retreat that spins the
    /// put-down object passes physics yet teaches a policy to knock it.
    pub max_release_turn_deg: Option<f64>,
    /// Reject items whose push-out hit the narrow-gap failure. Default true.
    pub reject_narrow_gap: bool,
    /// Keep on the ensemble's pass fraction reaching this instead of on the verdict (which
    /// is the pass fraction reaching the run's own keep threshold). Items judged by a single
    /// replay have no pass fraction and are dropped, saying so.
    pub min_pass_fraction: Option<f64>,
    /// Drop items whose ensemble cannot tell the side of the threshold in use: its 95 %
    /// interval contains it (`min_pass_fraction`, else the run's keep threshold). Default
    /// false.
    pub exclude_uncertain: bool,
}

impl Default for Criteria {
    fn default() -> Self {
        Criteria {
            require_physics_pass: true,
            require_robust: false,
            max_dc_mm: None,
            min_converged_fraction: None,
            max_waypoint_error_mm: None,
            max_timewarp_discrepancy: None,
            max_onset_mm: None,
            max_release_turn_deg: None,
            reject_narrow_gap: true,
            min_pass_fraction: None,
            exclude_uncertain: false,
        }
    }
}

/// One row of the kept or dropped list.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Row {
    pub name: String,
    pub report: String,
    /// The output demonstration next to the report (empty when there is none).
    pub demo: String,
    pub d_c_mm: Option<f64>,
    pub verdict: String,
    /// The ensemble's pass fraction (empty for a single replay).
    pub pass_fraction: Option<f64>,
    /// Every reason the item was dropped, separated by `; ` (empty when kept).
    pub reasons: String,
}

/// Result of a filter run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Filtered {
    pub kept: Vec<Row>,
    pub dropped: Vec<Row>,
}

/// All `report.json` files below `dir`, sorted.
pub fn find_reports(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let entries = std::fs::read_dir(&d).map_err(|e| Error::read(&d, e))?;
        for e in entries {
            let p = e.map_err(|e| Error::read(&d, e))?.path();
            let hidden = p
                .file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with('.'));
            if p.is_dir() {
                // Hidden folders are temporaries of runs in progress or killed.
                if !hidden {
                    stack.push(p);
                }
            } else if p.file_name().is_some_and(|n| n == "report.json") {
                out.push(p);
            }
        }
    }
    out.sort();
    Ok(out)
}

/// Applies `criteria` to every report below `dir`.
pub fn filter(dir: &Path, criteria: &Criteria) -> Result<Filtered> {
    let reports = find_reports(dir)?;
    if reports.is_empty() {
        return Err(Error::invalid(
            dir,
            "(folder)",
            "contains no report.json; expected the output folder of warp, batch or reproduce",
        ));
    }
    let mut result = Filtered::default();
    for path in reports {
        let (row, keep) = judge(&path, criteria);
        if keep {
            result.kept.push(row);
        } else {
            result.dropped.push(row);
        }
    }
    Ok(result)
}

/// The criteria on the physics report's diagnostics (onset, release turn), as reasons.
fn physics_figures(report: &Report, c: &Criteria, reasons: &mut Vec<String>) {
    if let Some(max) = c.max_onset_mm {
        match report.physics.as_ref().and_then(|p| p.onset_error_mm()) {
            Some(mm) if mm > max => {
                reasons.push(format!(
                    "onset {mm:.1} mm > {max} mm (the grasp moved the object that far as it closed)"
                ));
            }
            Some(_) => {}
            None => reasons.push(
                "no onset in the report (no physics, no contact segment, or a report written before onsets)".into(),
            ),
        }
    }
    if let Some(max) = c.max_release_turn_deg {
        let physics = report.physics.as_ref();
        match (physics, physics.and_then(Turn::of)) {
            (None, _) => reasons.push("no release turn in the report (no physics)".into()),
            (Some(_), Some(t)) => {
                if let Some(by) = t.by_hand.as_ref().filter(|_| t.deg > max) {
                    let with = if by.links.is_empty() {
                        String::new()
                    } else {
                        format!(" with {}", by.links.join(", "))
                    };
                    reasons.push(format!(
                        "the hand turned the released object {:.1}° > {max}° (at frame {}; it touches it up to frame {}{with})",
                        t.deg, t.frame, by.frame
                    ));
                }
            }
            // Nothing after the last contact frame, or a replay stopped at a drop.
            (Some(p), None) if !p.has_release() => {}
            (Some(_), None) => reasons.push(
                "no release turn in the report (a report written before release turns)".into(),
            ),
        }
    }
}

/// The physics part of [`judge`]: the verdict (or the pass fraction against
/// [`Criteria::min_pass_fraction`]), robustness and certainty.
fn physics_reasons(
    physics: Option<&crate::model::report::PhysicsSummary>,
    c: &Criteria,
    row: &mut Row,
    reasons: &mut Vec<String>,
) {
    const NO_ENSEMBLE: &str =
        "no ensemble in the report (a single replay); write it with --ensemble K > 1";
    let Some(p) = physics else {
        if c.require_physics_pass || c.require_robust {
            reasons.push("no physics verdict in the report".into());
        }
        return;
    };
    row.verdict = p.verdict.clone();
    row.pass_fraction = p.pass_fraction();
    match (c.min_pass_fraction, p.pass_fraction()) {
        (Some(min), Some(f)) => {
            if f + 1e-12 < min {
                reasons.push(format!(
                    "physics: pass fraction {f:.2} ({} of {} ensemble replays) < {min}",
                    p.ensemble()
                        .and_then(|e| e.get("passed")?.as_u64())
                        .unwrap_or(0),
                    p.ensemble_members().1
                ));
                reasons.extend(p.reasons.iter().map(|r| format!("physics: {r}")));
            }
        }
        (Some(_), None) => reasons.push(NO_ENSEMBLE.into()),
        (None, _) => {
            if c.require_physics_pass && p.verdict != "pass" {
                if p.reasons.is_empty() {
                    reasons.push(format!("physics verdict {}", p.verdict));
                }
                reasons.extend(p.reasons.iter().map(|r| format!("physics: {r}")));
            }
        }
    }
    if c.require_robust && p.verdict == "pass" {
        reasons.extend(p.not_robust_because());
    }
    if c.exclude_uncertain {
        let threshold = c
            .min_pass_fraction
            .or_else(|| p.ensemble().and_then(|e| e.get("keep_threshold")?.as_f64()));
        match (p.pass_interval(), threshold) {
            (Some([lo, hi]), Some(t)) if lo < t && t < hi => reasons.push(format!(
                "uncertain: the pass fraction's 95 % interval {lo:.2}-{hi:.2} contains {t}"
            )),
            (Some(_), _) => {}
            (None, _) => reasons.push(NO_ENSEMBLE.into()),
        }
    }
}

fn judge(path: &Path, c: &Criteria) -> (Row, bool) {
    let mut row = Row {
        name: String::new(),
        report: path.display().to_string(),
        demo: String::new(),
        d_c_mm: None,
        verdict: String::new(),
        pass_fraction: None,
        reasons: String::new(),
    };
    let report: Report = match std::fs::read(path)
        .map_err(|e| e.to_string())
        .and_then(|b| serde_json::from_slice(&b).map_err(|e| e.to_string()))
    {
        Ok(r) => r,
        Err(e) => {
            row.reasons = format!("unreadable report: {e}");
            return (row, false);
        }
    };
    row.name = report.name.clone();
    let demo = path.with_file_name(format!("{}.demo.json", report.name));
    if demo.is_file() {
        row.demo = demo.display().to_string();
    }
    let mut reasons = Vec::new();
    if let Err(why) = crate::output::set_is_complete(path, &report) {
        reasons.push(why);
    }
    if let Some(e) = &report.error {
        reasons.push(format!("failed: {e}"));
    } else {
        row.d_c_mm = Some(report.metrics.d_c_mm.warped);
        physics_reasons(report.physics.as_ref(), c, &mut row, &mut reasons);
        let m = &report.metrics;
        if let Some(max) = c.max_dc_mm
            && m.d_c_mm.warped > max
        {
            reasons.push(format!("D_C {:.2} mm > {max} mm", m.d_c_mm.warped));
        }
        if let (Some(min), Some(ik)) = (c.min_converged_fraction, &report.ik)
            && ik.converged_fraction < min
        {
            reasons.push(format!(
                "IK converged on {:.1}% of frames < {:.1}%",
                ik.converged_fraction * 100.0,
                min * 100.0
            ));
        }
        if let Some(max) = c.max_waypoint_error_mm
            && report.constraints.max_waypoint_error_mm > max
        {
            reasons.push(format!(
                "waypoint error {:.3} mm > {max} mm",
                report.constraints.max_waypoint_error_mm
            ));
        }
        if let Some(max) = c.max_timewarp_discrepancy
            && m.timewarp_discrepancy > max
        {
            reasons.push(format!(
                "timewarp discrepancy {:.3} > {max}",
                m.timewarp_discrepancy
            ));
        }
        physics_figures(&report, c, &mut reasons);
        if c.reject_narrow_gap
            && let Some(gap) = &report.constraints.narrow_gap
        {
            reasons.push(format!(
                "narrow gap: {} frames still inside barrier(s) {}",
                gap.frames.len(),
                gap.barriers.join(", ")
            ));
        }
    }
    let keep = reasons.is_empty();
    row.reasons = reasons.join("; ");
    (row, keep)
}

/// Writes `rows` as CSV to `path` atomically.
pub fn write_rows(path: &Path, rows: &[Row]) -> Result<()> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r)
            .map_err(|e| Error::write(path, std::io::Error::other(e)))?;
    }
    // An empty list still gets its header, so readers see the columns.
    if rows.is_empty() {
        w.write_record([
            "name",
            "report",
            "demo",
            "d_c_mm",
            "verdict",
            "pass_fraction",
            "reasons",
        ])
        .map_err(|e| Error::write(path, std::io::Error::other(e)))?;
    }
    let bytes = w
        .into_inner()
        .map_err(|e| Error::write(path, std::io::Error::other(e.to_string())))?;
    write_atomic(path, &bytes)
}

/// The dropped list's path next to the kept list: `KEEP.csv` → `KEEP.dropped.csv`.
pub fn dropped_path(keep: &Path) -> PathBuf {
    let stem = keep
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "keep".into());
    keep.with_file_name(format!("{stem}.dropped.csv"))
}
