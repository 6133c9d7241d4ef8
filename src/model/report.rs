//! Quality reports: the `dexwarp.report/1` file format, one per trajectory.
//!
//! Reports are written from the stages' `Stats`; nothing here recomputes a metric. Fields that
//! a run did not compute (physics before it runs, IK for the baseline hand) are `null`.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::warp::barrier::NarrowGap;

/// The `format` value of a report.
pub const REPORT_FORMAT: &str = "dexwarp.report/1";

/// A value before and after the warp.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pair {
    pub original: f64,
    pub warped: f64,
}

/// Contact distance: the original demonstration, the hand before smoothing, and the output.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ContactDistance {
    pub original: f64,
    /// Before smoothing (equal to `warped` when the hand is not smoothed, e.g. baseline).
    pub unsmoothed: f64,
    pub warped: f64,
    /// Robustness runs: the output measured against the demonstration's uncorrupted
    /// correspondences (the hand was recovered from corrupted ones).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uncorrupted: Option<f64>,
}

/// The paper's metrics.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// `D_WO` [mm].
    pub d_wo_mm: Pair,
    /// `D_C` [mm].
    pub d_c_mm: ContactDistance,
    /// Path length ratio of the object origin.
    pub plr_object: f64,
    /// Path length ratio of the wrist.
    pub plr_hand: f64,
    /// Timewarp discrepancy (0 = uniform timing).
    pub timewarp_discrepancy: f64,
}

/// Constraint checks on the output.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Constraints {
    /// Largest distance between a waypoint (or the new start/end) and the output object at its
    /// output frame [mm].
    pub max_waypoint_error_mm: f64,
    /// Smallest distance between the object mesh's hull and a barrier's hull over the output
    /// frames [mm] (0 = touching or intersecting); `null` without barriers.
    pub min_object_barrier_clearance_mm: Option<f64>,
    /// Object bounding radius used by the push-out [mm].
    pub object_radius_mm: f64,
    /// Frames moved by the barrier push-out.
    pub pushout_frames_moved: usize,
    /// Sweeps over all barriers the push-out needed.
    pub pushout_sweeps: usize,
    /// Largest distance the push-out moved a frame [mm].
    pub pushout_max_mm: f64,
    /// The push-out's narrow-gap failure, when it happened.
    pub narrow_gap: Option<NarrowGap>,
    /// In-contact input frames without correspondences (the segment is treated as one).
    pub contact_gap_frames: usize,
}

/// Hand recovery summary.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct IkSummary {
    /// Fraction of contact-segment output frames that met the threshold.
    pub converged_fraction: f64,
    /// Frames that did not meet the stop rule, by output frame.
    pub not_converged_frames: Vec<usize>,
    /// Those frames counted by why their solve ended (`penetration_limited`,
    /// `barrier_limited`, `iteration_cap`, `local_minimum`, `non_finite`).
    #[serde(default)]
    pub stop_reasons: BTreeMap<String, usize>,
    /// Objective minimized (`non_penetrating` or `paper`).
    #[serde(default)]
    pub objective: Option<String>,
    /// Deepest penetration probe of the IK's hand in the object over the frames [mm].
    #[serde(default)]
    pub max_penetration_mm: Option<f64>,
    /// Mean and largest iterations per frame.
    pub mean_iterations: f64,
    pub max_iterations: usize,
    /// Smallest hand-barrier clearance over the frames [mm] (`null` without barriers).
    pub min_barrier_clearance_mm: Option<f64>,
}

/// Physics verdict summary.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PhysicsSummary {
    /// `pass` or `fail`.
    pub verdict: String,
    /// Every failed check, in words.
    pub reasons: Vec<String>,
    /// The measured values behind the verdict.
    #[serde(flatten)]
    pub measures: BTreeMap<String, serde_json::Value>,
}

/// A report on one output trajectory.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Report {
    pub format: String,
    pub name: String,
    /// Config file the warp came from (`null` for `validate`).
    pub config: Option<String>,
    pub threshold_mm: Option<f64>,
    /// IK solver (`lm` or `adam`), `null` for the baseline.
    pub solver: Option<String>,
    /// Hand method: `contact` or `baseline` (`null` for `validate`).
    pub hand: Option<String>,
    pub frames_in: usize,
    pub frames_out: usize,
    pub metrics: Metrics,
    pub constraints: Constraints,
    pub ik: Option<IkSummary>,
    pub physics: Option<PhysicsSummary>,
    /// Wall time of each stage [s].
    pub timing_s: BTreeMap<String, f64>,
    /// Tool, input files with content hashes, and every parameter in effect.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub provenance: Option<crate::model::provenance::Provenance>,
    /// SHA-256 of each other file of this run's output set, by file name (the report is
    /// written last; `filter` and `batch` trust a report only when these match).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub outputs: BTreeMap<String, String>,
    /// Set when the item failed; the other fields are then partial.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}
