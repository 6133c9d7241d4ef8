//! Quality reports: the `dexwarp.report/1` file format, one per trajectory.
//!
//! Reports are written from the stages' `Stats`; nothing here recomputes a metric. Fields that
//! a run did not compute (physics before it runs, IK for the baseline hand) are `null`.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// Frames the push-out could not free: the paper's narrow-gap failure.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NarrowGap {
    /// Input frames still inside an inflated barrier after the last sweep.
    pub frames: Vec<usize>,
    /// Barriers those frames are inside.
    pub barriers: Vec<String>,
}

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
    /// Timewarp discrepancy, our definition (0 = uniform timing): every input frame, output
    /// time normalized by the output length.
    pub timewarp_discrepancy: f64,
    /// Timewarp discrepancy as the paper's reference code computes it: its per-segment
    /// chord-length "contact timewarp" over every input frame, segments split at the
    /// waypoints only (`warp::retime::paper_discrepancy`). `null` for `validate`, which has no
    /// warp plan.
    #[serde(default)]
    pub timewarp_discrepancy_paper: Option<f64>,
    /// `D_C` over the stretched output frames (`metrics::stretched_frames`: the bracketing
    /// input step got more than one output frame) [mm]; `null` when no frame is stretched.
    #[serde(default)]
    pub d_c_stretched_mm: Option<f64>,
    /// Number of stretched output frames.
    #[serde(default)]
    pub stretched_frames: usize,
    /// The output frame with the largest contact distance.
    #[serde(default)]
    pub d_c_worst: Option<WorstFrame>,
    /// How far the hand slides on the object over the contact segment
    /// (`metrics::grasp_slide_mm`) [mm]; `null` without contacts.
    #[serde(default)]
    pub grasp_slide_mm: Option<Pair>,
    /// How far the output's grasp sits from the recording's over the contact segment
    /// (`metrics::grasp_shift_mm`) [mm]; `null` without contacts or for `validate`.
    #[serde(default)]
    pub grasp_shift_mm: Option<f64>,
}

/// One frame and its contact distance.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WorstFrame {
    /// Output frame.
    pub frame: usize,
    /// Its mean correspondence distance [mm].
    pub d_c_mm: f64,
}

/// Constraint checks on the output.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Constraints {
    /// Deepest hand-object penetration over the frames, input and output [mm] (penetration
    /// probes in the object's signed distance field).
    #[serde(default)]
    pub hand_object_penetration_mm: Option<Pair>,
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
    /// Hand bounding radius of the hand's push-out outside contact [mm].
    #[serde(default)]
    pub hand_radius_mm: f64,
    /// Output frames outside contact whose wrist the hand push-out moved.
    #[serde(default)]
    pub hand_pushout_frames_moved: usize,
    /// Largest distance the hand push-out moved a wrist [mm].
    #[serde(default)]
    pub hand_pushout_max_mm: f64,
    /// The hand push-out's narrow-gap failure (output frames), when it happened.
    #[serde(default)]
    pub hand_narrow_gap: Option<NarrowGap>,
    /// Clearance every hand link keeps from the barriers outside contact (the push-out's
    /// link pass) [mm]; 0 when off.
    #[serde(default)]
    pub hand_clearance_mm: f64,
    /// Output frames outside contact the link pass moved (counted in
    /// `hand_pushout_frames_moved` too).
    #[serde(default)]
    pub hand_link_frames_moved: usize,
    /// Smallest hand-link-to-barrier distance outside contact after the push-out [mm], where
    /// a link is within `hand_clearance_mm` of a barrier; null when every link keeps it.
    #[serde(default)]
    pub hand_min_barrier_distance_mm: Option<f64>,
    /// In-contact input frames without correspondences (the segment is treated as one).
    pub contact_gap_frames: usize,
}

/// Hand recovery summary.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct IkSummary {
    /// Fraction of contact-segment output frames that met the stop rule (the threshold, or
    /// with the default objective the recording's own fit where that is tighter).
    pub converged_fraction: f64,
    /// Frames that did not meet the stop rule, by output frame.
    pub not_converged_frames: Vec<usize>,
    /// Frames solved again from the rigid transfer of the recorded hand because the hand
    /// carried along from the previous frame was caught far from its contacts (see
    /// `hand::ik::run`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub restarted_frames: Vec<usize>,
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
    /// The penetration tolerance the IK used [mm] (the config's, or the automatic one).
    #[serde(default)]
    pub penetration_tolerance_mm: Option<f64>,
    /// Mean and largest iterations per frame.
    pub mean_iterations: f64,
    pub max_iterations: usize,
    /// Smallest hand-barrier clearance over the frames [mm] (`null` without barriers).
    pub min_barrier_clearance_mm: Option<f64>,
    /// What the smoothing guard changed (non-penetrating objective only; docs/METHOD.md
    /// "Smoothing without pressing in").
    #[serde(default)]
    pub smoothing_guard: Option<GuardSummary>,
    /// Where the held grasp yielded to a barrier (`params.grasp: "held"` with barriers;
    /// docs/METHOD.md "A held grasp"); `null` otherwise.
    #[serde(default)]
    pub held_yield: Option<HeldYield>,
    /// Where the held grasp is held (`params.grasp: "held"`; docs/METHOD.md "The grasp is
    /// held where it carries the object"); `null` otherwise.
    #[serde(default)]
    pub held: Option<HeldSpan>,
}

/// Where the held grasp is held: the carry, the output frames where the object is away from
/// where it rests at the contact segment's ends, and whether the hand was still closing on
/// the resting object before it. Where it was, the hand follows its per-frame solution there
/// and takes the held grasp over the carry's first 0.25 s; the grasp is the average from the
/// carry's first frame to the segment's end (from the segment's first frame otherwise).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct HeldSpan {
    /// First and last output frame of the carry.
    pub carry: [usize; 2],
    /// The hand was still closing on the resting object before the carry.
    pub closing: bool,
}

/// How far the held grasp moved toward the per-frame solution to keep the hand clear of the
/// barriers.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct HeldYield {
    /// Frames where the hand is not the held grasp (those asked and their neighbours).
    pub frames: usize,
    /// Largest share of the way to the per-frame solution a frame asked (0-1).
    pub max_share: f64,
    /// Largest move of the wrist off the held grasp, in the object's frame [mm].
    pub max_move_mm: f64,
}

impl IkSummary {
    /// Fraction of contact-segment output frames whose solve ended where it should: it met
    /// the threshold, or it stopped at a constraint, where going on would press the hand
    /// into the object (`penetration_limited`) or a barrier (`barrier_limited`). What is left
    /// are the solver's own failures (`iteration_cap`, `local_minimum`, `non_finite`).
    pub fn solved_fraction(&self) -> f64 {
        let missed: usize = self.stop_reasons.values().sum();
        if missed == 0 {
            return self.converged_fraction;
        }
        let limited = ["penetration_limited", "barrier_limited"]
            .iter()
            .filter_map(|k| self.stop_reasons.get(*k))
            .sum::<usize>();
        // `missed` frames are the (1 - converged_fraction) share of the segment.
        let unsolved =
            (1.0 - self.converged_fraction) * (missed - limited.min(missed)) as f64 / missed as f64;
        (1.0 - unsolved).clamp(0.0, 1.0)
    }
}

/// The smoothing guard: frames the smoothing had pressed deeper than the IK allowed.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GuardSummary {
    /// Smoothed frames deeper than `max(IK depth, tolerance)`.
    pub frames_too_deep: usize,
    /// Frames blended back toward the IK solution (those and their neighbours).
    pub frames_blended: usize,
    /// Deepest hand-object penetration of the smoothed hand, before and after the guard [mm].
    pub max_depth_before_mm: f64,
    pub max_depth_after_mm: f64,
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

impl PhysicsSummary {
    /// The robustness margin (`physics.margin`), when it was measured.
    pub fn margin(&self) -> Option<&serde_json::Value> {
        self.measures.get("margin").filter(|m| !m.is_null())
    }

    /// The ensemble verdict (`physics.ensemble`), when the trajectory was replayed by one.
    pub fn ensemble(&self) -> Option<&serde_json::Value> {
        self.measures.get("ensemble").filter(|e| !e.is_null())
    }

    /// The ensemble's pass fraction; `None` for a single replay.
    pub fn pass_fraction(&self) -> Option<f64> {
        self.ensemble()?.get("pass_fraction")?.as_f64()
    }

    /// The ensemble's 95 % interval of the pass fraction; `None` for a single replay.
    pub fn pass_interval(&self) -> Option<[f64; 2]> {
        let i = self.ensemble()?.get("interval")?.as_array()?;
        Some([i.first()?.as_f64()?, i.get(1)?.as_f64()?])
    }

    /// Whether the ensemble's interval contains its keep threshold; `None` for a single
    /// replay.
    pub fn uncertain(&self) -> Option<bool> {
        self.ensemble()?.get("uncertain")?.as_bool()
    }

    /// Members asked (K) and replayed; `(1, 1)` for a single replay.
    pub fn ensemble_members(&self) -> (usize, usize) {
        let get = |k: &str| {
            self.ensemble()
                .and_then(|e| e.get(k)?.as_u64())
                .map_or(1, |v| v as usize)
        };
        (get("members"), get("replayed"))
    }

    /// The ensemble's members that passed and members replayed; `None` for a single replay.
    pub fn ensemble_count(&self) -> Option<(usize, usize)> {
        let e = self.ensemble()?;
        Some((
            e.get("passed")?.as_u64()? as usize,
            e.get("replayed")?.as_u64()? as usize,
        ))
    }

    /// The most members the ensemble would replay while uncertain; `None` for a single
    /// replay or a report from before the extension.
    pub fn ensemble_max(&self) -> Option<usize> {
        Some(self.ensemble()?.get("max_members")?.as_u64()? as usize)
    }

    /// The seed of the ensemble's draws; `None` for a single replay.
    pub fn ensemble_seed(&self) -> Option<u64> {
        self.ensemble()?.get("seed")?.as_u64()
    }

    /// The object's position error when the contact segment starts (`physics.onset`) [mm]:
    /// how far the approach and the closing moved it; `None` without one.
    pub fn onset_error_mm(&self) -> Option<f64> {
        self.measures
            .get("onset")?
            .get("position_error_mm")?
            .as_f64()
    }

    /// Whether the replay judged a release (`physics.release`): the trajectory goes on after
    /// the last contact frame and the replay did not stop at a drop.
    pub fn has_release(&self) -> bool {
        self.measures.get("release").is_some_and(|r| !r.is_null())
    }

    /// Whether the margin holds under every condition; `None` without a margin.
    pub fn robust(&self) -> Option<bool> {
        self.margin()?.get("robust")?.as_bool()
    }

    /// Why a passing verdict is not robust, in words (no margin measured, or the margin's
    /// sentence); `None` when it is.
    pub fn not_robust_because(&self) -> Option<String> {
        match (self.margin(), self.robust()) {
            (_, Some(true)) => None,
            (None, _) => Some("no robustness margin in the report; write it with --margin".into()),
            (Some(m), _) => Some(format!(
                "not robust: {}",
                m.get("sentence").and_then(|s| s.as_str()).unwrap_or("?")
            )),
        }
    }
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
