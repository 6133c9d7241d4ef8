//! The yield of an augment run: one row per sample (`samples.csv`) and `stats.json`.
//!
//! A sample is **rejected** (not run: infeasible by construction), **kept** (no error, physics
//! `pass`, no narrow gap, the IK solved at least `keep.min_converged` of its frames (met its
//! threshold or stopped at the penetration or barrier limit,
//! [`crate::model::report::IkSummary::solved_fraction`]), D_C at most `keep.max_dc_mm`) or
//! **failed** (every reason listed). Reasons are stable keys:
//! `physics:<check>` (from the physics verdict's sentences), `ik:not_converged`,
//! `ik:d_c_above_max`, `narrow_gap`, `error`. A failed sample counts once under each of its
//! reasons, so the reason counts can add up to more than `failed`.
//!
//! With `--compare-baseline` every sample that ran is also run with the SE(3) baseline hand
//! on the same object trajectory; its verdict by the same rule, its reasons and D_C are
//! columns of the row, and `stats.json` gains a `baseline` object: its yield, reasons and
//! the paired counts (both pass, only contact IK, only the baseline, neither) with the exact
//! McNemar test of whether the two yields differ by more than chance.
//!
//! With `--margin` every sample that passes physics also replays the robustness margin
//! ([`crate::physics::margin`]); a kept sample is **robust** when the margin holds under every
//! condition. The rows say it per hand, and `stats.json` gains `robust` (and, with the
//! comparison, `baseline.robust` and `baseline.paired_robust`, the pairing of robust samples).
//!
//! `stats.json` is a function of the rows alone, apart from its `timing` object (wall time,
//! throughput, time per stage, samples skipped because they were already finished): two runs
//! of the same spec, demonstration and seed give the same bytes outside `timing`.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::spec::KeepJson;
use crate::math::quantile::quantile_sorted;
use crate::math::sign_test::{format_p, mcnemar_exact_p};
use crate::model::report::Report;

/// The `format` value of `stats.json`.
pub const STATS_FORMAT: &str = "dexwarp.augment-stats/1";

/// One sample of a run, as listed in `samples.csv`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Row {
    pub index: u64,
    pub id: String,
    /// `kept`, `failed` or `rejected`.
    pub status: String,
    /// Reason keys separated by `;` (empty when kept).
    pub reasons: String,
    /// The first reason in words.
    pub detail: String,
    pub waypoints: usize,
    pub barriers: usize,
    pub threshold_mm: f64,
    pub d_c_mm: Option<f64>,
    pub d_c_original_mm: Option<f64>,
    /// D_WO of the output minus D_WO of the input [mm].
    pub d_wo_change_mm: Option<f64>,
    pub plr_object: Option<f64>,
    pub timewarp_discrepancy: Option<f64>,
    pub converged_fraction: Option<f64>,
    pub frames_out: Option<usize>,
    /// The largest duration factor of the sample's segments (> 1 stretches).
    #[serde(default)]
    pub stretch_max: Option<f64>,
    /// Mean D_C over the output frames of the stretched segments (duration factor at least
    /// [`STRETCHED`]), when there are any [mm].
    #[serde(default)]
    pub d_c_stretched_mm: Option<f64>,
    /// With `--compare-baseline`: the SE(3) baseline hand on the same object trajectory,
    /// judged by the same rule (`kept` or `failed`; empty without the comparison).
    #[serde(default)]
    pub baseline_status: String,
    /// The baseline's reason keys, separated by `;`.
    #[serde(default)]
    pub baseline_reasons: String,
    #[serde(default)]
    pub baseline_d_c_mm: Option<f64>,
    #[serde(default)]
    pub baseline_d_c_stretched_mm: Option<f64>,
    /// How far each hand slides on the object over the contact segment
    /// (`metrics::grasp_slide_mm`) [mm].
    #[serde(default)]
    pub grasp_slide_mm: Option<f64>,
    #[serde(default)]
    pub baseline_grasp_slide_mm: Option<f64>,
    /// How far each hand's grasp sits from the recorded one (`metrics::grasp_shift_mm`) [mm].
    #[serde(default)]
    pub grasp_shift_mm: Option<f64>,
    #[serde(default)]
    pub baseline_grasp_shift_mm: Option<f64>,
    /// How far each hand's approach and closing moved the simulated object before the carry:
    /// its position error when the contact segment starts (`physics.onset`) [mm].
    #[serde(default)]
    pub onset_error_mm: Option<f64>,
    #[serde(default)]
    pub baseline_onset_error_mm: Option<f64>,
    /// How far each hand turned the released object (`physics.release.turn`, when the hand
    /// still touches it once it has turned 5°; 0 when it turned by itself, empty without a
    /// release) [deg].
    #[serde(default)]
    pub release_turn_by_hand_deg: Option<f64>,
    #[serde(default)]
    pub baseline_release_turn_by_hand_deg: Option<f64>,
    /// With `--margin`: whether the sample's physics holds under every condition of the
    /// robustness margin (lower friction, heavier object; `false` when the nominal replay
    /// fails; empty without a margin).
    #[serde(default)]
    pub robust: Option<bool>,
    #[serde(default)]
    pub baseline_robust: Option<bool>,
    /// The ensemble verdict (`physics.ensemble`): the pass fraction over the members
    /// replayed, K, the members replayed, and whether the 95 % interval contains the keep
    /// threshold; empty for a single replay.
    #[serde(default)]
    pub pass_fraction: Option<f64>,
    #[serde(default)]
    pub ensemble_members: Option<usize>,
    #[serde(default)]
    pub ensemble_replayed: Option<usize>,
    #[serde(default)]
    pub uncertain: Option<bool>,
    #[serde(default)]
    pub baseline_pass_fraction: Option<f64>,
    #[serde(default)]
    pub baseline_uncertain: Option<bool>,
}

/// A segment whose duration factor is at least this is *stretched*: its D_C is reported
/// apart (`d_c_stretched_mm`), since that is where the paper expects a rigidly transferred
/// hand, interpolated between the frames whose pose it knows, to drift off the object; the
/// comparison measures whether it does.
pub const STRETCHED: f64 = 2.0;

/// A per-sample figure of a row (`None` when the sample did not run).
pub type Metric = fn(&Row) -> Option<f64>;

/// The stable key of a physics verdict sentence (`physics::verdict` wording).
pub fn physics_key(sentence: &str) -> String {
    const KEYS: [(&str, &str); 13] = [
        ("the simulation diverged", "diverged"),
        ("object dropped", "dropped"),
        ("object slipped", "slipped"),
        ("object pushed after the release", "pushed_after_release"),
        ("mean object position error", "mean_position_error"),
        ("object position error", "position_error"),
        ("mean object rotation error", "rotation_error"),
        ("hand-object penetration", "hand_object_penetration"),
        ("hand-barrier penetration", "hand_barrier_penetration"),
        ("object-barrier penetration", "object_barrier_penetration"),
        ("simulation displacement", "unstable"),
        ("released unsupported", "released_unsupported"),
        ("passes in", "below_keep_threshold"),
    ];
    if let Some((_, k)) = KEYS.iter().find(|(p, _)| sentence.starts_with(p)) {
        return format!("physics:{k}");
    }
    // A sentence we do not know yet: its words up to the first number or punctuation.
    let head: String = sentence
        .chars()
        .take_while(|c| c.is_alphabetic() || *c == ' ' || *c == '-')
        .collect();
    let slug: Vec<&str> = head.split([' ', '-']).filter(|w| !w.is_empty()).collect();
    format!("physics:{}", slug.join("_").to_lowercase())
}

/// Judges a report under `keep`: the status and every reason (keys and words).
pub fn classify(report: &Report, keep: &KeepJson) -> (&'static str, Vec<String>, Vec<String>) {
    let (mut keys, mut words) = (Vec::new(), Vec::new());
    if let Some(e) = &report.error {
        keys.push("error".to_string());
        words.push(e.clone());
        return ("failed", keys, words);
    }
    match &report.physics {
        Some(p) if p.verdict == "pass" => {}
        Some(p) => {
            for r in &p.reasons {
                keys.push(physics_key(r));
                words.push(r.clone());
            }
            if p.reasons.is_empty() {
                keys.push("physics:fail".into());
                words.push(format!("physics verdict {}", p.verdict));
            }
        }
        None => {
            keys.push("physics:missing".into());
            words.push("no physics verdict".into());
        }
    }
    if let Some(ik) = &report.ik
        && ik.solved_fraction() < keep.min_converged
    {
        keys.push("ik:not_converged".into());
        words.push(format!(
            "IK solved {:.1}% of frames < {:.1}% (met its threshold on {:.1}%; stop reasons {})",
            ik.solved_fraction() * 100.0,
            keep.min_converged * 100.0,
            ik.converged_fraction * 100.0,
            ik.stop_reasons
                .iter()
                .map(|(k, n)| format!("{k} {n}"))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    if let Some(max) = keep.max_dc_mm
        && report.metrics.d_c_mm.warped > max
    {
        keys.push("ik:d_c_above_max".into());
        words.push(format!(
            "D_C {:.2} mm > {max} mm",
            report.metrics.d_c_mm.warped
        ));
    }
    if let Some(gap) = &report.constraints.narrow_gap {
        keys.push("narrow_gap".into());
        words.push(format!(
            "narrow gap: {} frames inside barrier(s) {}",
            gap.frames.len(),
            gap.barriers.join(", ")
        ));
    }
    let status = if keys.is_empty() { "kept" } else { "failed" };
    (status, keys, words)
}

/// Median, 10th and 90th percentile, mean, min and max of some values.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub n: usize,
    pub median: Option<f64>,
    pub p10: Option<f64>,
    pub p90: Option<f64>,
    pub mean: Option<f64>,
    pub min: Option<f64>,
    pub max: Option<f64>,
}

impl Summary {
    pub fn of(values: impl Iterator<Item = f64>) -> Summary {
        let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
        v.sort_by(f64::total_cmp);
        Summary {
            n: v.len(),
            median: quantile_sorted(&v, 0.5),
            p10: quantile_sorted(&v, 0.1),
            p90: quantile_sorted(&v, 0.9),
            mean: (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64),
            min: v.first().copied(),
            max: v.last().copied(),
        }
    }
}

/// Time and throughput: the only part of `stats.json` that changes between identical runs.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Timing {
    /// Wall time of the run (of the slowest shard after a merge) [s].
    pub wall_s: f64,
    /// Core-seconds: wall time times worker threads, summed over shards [s].
    pub core_s: f64,
    /// Worker threads of each shard.
    pub threads: Vec<usize>,
    /// Samples run in this invocation (the others were rejected or already finished).
    pub ran_now: u64,
    /// Samples skipped because they were already finished.
    pub skipped_now: u64,
    /// `ran_now` per hour of wall time.
    pub samples_per_hour: f64,
    /// `ran_now` per hour per core.
    pub samples_per_hour_per_core: f64,
    /// Time of each stage summed over the samples run now (worker time, not wall time) [s]:
    /// `sample` (sampling and feasibility), `load`, the pipeline's stages, `write`.
    pub stage_s: BTreeMap<String, f64>,
    /// Each stage's share of the summed stage time.
    pub stage_share: BTreeMap<String, f64>,
}

impl Timing {
    /// Fills in the rates and shares from the sums.
    pub fn finish(&mut self) {
        self.samples_per_hour = rate(self.ran_now as f64, self.wall_s);
        self.samples_per_hour_per_core = rate(self.ran_now as f64, self.core_s);
        let total: f64 = self.stage_s.values().sum();
        self.stage_share = self
            .stage_s
            .iter()
            .map(|(k, v)| (k.clone(), if total > 0.0 { v / total } else { 0.0 }))
            .collect();
    }
}

fn rate(n: f64, seconds: f64) -> f64 {
    if seconds > 0.0 {
        n / seconds * 3600.0
    } else {
        0.0
    }
}

/// `stats.json`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    pub format: String,
    /// `dexwarp <version>`.
    pub tool: String,
    pub spec: String,
    /// FNV-1a of the spec file, hex.
    pub spec_hash: String,
    pub demo: String,
    pub seed: u64,
    pub count: u64,
    /// The shards these figures cover (`K/N`), or `["all"]`.
    pub shards: Vec<String>,
    pub attempts: u64,
    pub rejected: u64,
    pub rejected_by_reason: BTreeMap<String, u64>,
    pub ran: u64,
    pub passed: u64,
    pub failed: u64,
    pub failed_by_physics_reason: BTreeMap<String, u64>,
    pub failed_by_ik_reason: BTreeMap<String, u64>,
    pub failed_by_other_reason: BTreeMap<String, u64>,
    /// `passed / attempts`.
    #[serde(rename = "yield")]
    pub yield_: f64,
    /// `passed / ran`.
    pub pass_rate: f64,
    /// D_C of the demonstration itself [mm].
    pub original_d_c_mm: Option<f64>,
    /// Distributions over the kept samples: `d_c_mm`, `d_wo_change_mm`, `plr_object`,
    /// `timewarp_discrepancy`.
    pub kept: BTreeMap<String, Summary>,
    /// The kept samples' median D_C is at most the demonstration's.
    pub kept_median_d_c_no_worse: Option<bool>,
    /// With `--margin`: the kept samples whose margin holds under every condition.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub robust: Option<Robust>,
    /// The ensemble verdicts of the samples that ran (absent for single replays).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ensemble: Option<EnsembleStats>,
    /// With `--compare-baseline`: the SE(3) baseline hand on the same samples.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub baseline: Option<BaselineStats>,
    pub timing: Timing,
}

/// The SE(3) baseline hand run on every sample that ran, judged by the same rule as contact
/// IK (`stats.json` `baseline`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BaselineStats {
    pub ran: u64,
    pub passed: u64,
    pub failed: u64,
    /// Reason keys of the baseline's failures (`physics:dropped`, `narrow_gap`, ...), a
    /// sample counted once under each.
    pub failed_by_reason: BTreeMap<String, u64>,
    /// `passed / attempts` (rejected samples count, as in contact IK's yield).
    #[serde(rename = "yield")]
    pub yield_: f64,
    /// `passed / ran`.
    pub pass_rate: f64,
    /// Samples where both hands ran, by which passed.
    pub paired: Paired,
    /// D_C of both hands over the samples where both ran, and over their stretched segments
    /// (duration factor at least [`STRETCHED`]) [mm].
    pub d_c_mm: HandPair,
    pub d_c_stretched_mm: HandPair,
    /// How far each hand slides on the object over the contact segment [mm].
    #[serde(default)]
    pub grasp_slide_mm: HandPair,
    /// How far each hand's grasp sits from the recorded one over the contact segment [mm].
    #[serde(default)]
    pub grasp_shift_mm: HandPair,
    /// How far each hand's approach and closing moved the object before the carry [mm].
    #[serde(default)]
    pub onset_error_mm: HandPair,
    /// How far each hand turned the released object [deg] (0 where it turned by itself).
    #[serde(default)]
    pub release_turn_by_hand_deg: HandPair,
    /// Each hand's failures over the same samples, by [`Cause`].
    #[serde(default)]
    pub failed_by_cause: CausePair,
    /// With `--margin`: the baseline's robust samples, and the pairing of robust samples
    /// (a sample counts for a hand when that hand keeps it and its margin holds under every
    /// condition).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub robust: Option<Robust>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub paired_robust: Option<Paired>,
    /// With the ensemble verdict: the two hands' pass fractions paired per sample.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub paired_pass_fraction: Option<PairedFractions>,
}

/// Both hands' pass fractions over the samples where both have an ensemble
/// (`stats.json` `baseline.paired_pass_fraction`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PairedFractions {
    /// Samples with both pass fractions.
    pub samples: u64,
    /// Mean pass fraction of each hand over them.
    pub contact_ik_mean: f64,
    pub baseline_mean: f64,
    /// Samples where contact IK's is higher, the baseline's, and equal.
    pub contact_ik_higher: u64,
    pub baseline_higher: u64,
    pub equal: u64,
    /// The exact two-sided Wilcoxon signed-rank test of the differences
    /// ([`crate::math::signed_rank`]): below 0.05 the two hands' pass fractions differ by
    /// more than the draw of samples explains.
    pub signed_rank_p: f64,
}

impl PairedFractions {
    fn of(pairs: &[(f64, f64)]) -> Option<PairedFractions> {
        if pairs.is_empty() {
            return None;
        }
        let n = pairs.len() as f64;
        let d: Vec<f64> = pairs.iter().map(|(c, b)| c - b).collect();
        let test = crate::math::signed_rank::signed_rank(&d);
        Some(PairedFractions {
            samples: pairs.len() as u64,
            contact_ik_mean: pairs.iter().map(|p| p.0).sum::<f64>() / n,
            baseline_mean: pairs.iter().map(|p| p.1).sum::<f64>() / n,
            contact_ik_higher: test.positive as u64,
            baseline_higher: test.negative as u64,
            equal: (pairs.len() - test.n) as u64,
            signed_rank_p: test.p,
        })
    }

    /// `signed_rank_p` for a page or a terminal.
    pub fn p_text(&self) -> String {
        format_p(self.signed_rank_p)
    }
}

/// The ensemble verdicts of a run's samples (`stats.json` `ensemble`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EnsembleStats {
    /// Samples with an ensemble verdict.
    pub samples: u64,
    /// Their pass fractions.
    pub pass_fraction: Summary,
    /// How many have each pass fraction, by the fraction with two decimals (`"0.75"`).
    pub pass_fraction_counts: BTreeMap<String, u64>,
    /// Samples whose interval contains the keep threshold, kept and dropped.
    pub uncertain: u64,
    pub uncertain_kept: u64,
    /// Members replayed over all samples, and what K replays of each would have been.
    pub replayed: u64,
    pub asked: u64,
}

impl EnsembleStats {
    fn of(rows: &[Row]) -> Option<EnsembleStats> {
        let with: Vec<&Row> = rows.iter().filter(|r| r.pass_fraction.is_some()).collect();
        if with.is_empty() {
            return None;
        }
        let mut e = EnsembleStats {
            samples: with.len() as u64,
            pass_fraction: Summary::of(with.iter().filter_map(|r| r.pass_fraction)),
            ..EnsembleStats::default()
        };
        for r in &with {
            let f = r.pass_fraction.unwrap_or(0.0);
            *e.pass_fraction_counts.entry(format!("{f:.2}")).or_default() += 1;
            if r.uncertain == Some(true) {
                e.uncertain += 1;
                e.uncertain_kept += u64::from(r.status == "kept");
            }
            e.replayed += r.ensemble_replayed.unwrap_or(0) as u64;
            e.asked += r.ensemble_members.unwrap_or(0) as u64;
        }
        Some(e)
    }
}

/// Kept samples whose robustness margin holds under every condition (`--margin`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Robust {
    /// Kept and robust.
    pub kept: u64,
    /// `kept / attempts`.
    #[serde(rename = "yield")]
    pub yield_: f64,
    /// Share of the kept samples that are robust.
    pub share_of_kept: f64,
}

impl Robust {
    /// The robust samples of one hand: `status` and `robust` of each row; `None` when no row
    /// has a margin.
    fn of<'a>(
        rows: &'a [Row],
        hand: impl Fn(&'a Row) -> (&'a str, Option<bool>),
    ) -> Option<Robust> {
        if rows.iter().all(|r| hand(r).1.is_none()) {
            return None;
        }
        let kept = rows.iter().filter(|r| hand(r).0 == "kept").count() as u64;
        let robust = rows.iter().filter(|r| is_robust(hand(r))).count() as u64;
        Some(Robust {
            kept: robust,
            yield_: ratio(robust, rows.len() as u64),
            share_of_kept: ratio(robust, kept),
        })
    }
}

/// Kept, with a margin that holds under every condition.
fn is_robust((status, robust): (&str, Option<bool>)) -> bool {
    status == "kept" && robust == Some(true)
}

/// Contact IK's status and robustness of a row.
fn contact_hand(r: &Row) -> (&str, Option<bool>) {
    (&r.status, r.robust)
}

/// The baseline's status and robustness of a row.
fn baseline_hand(r: &Row) -> (&str, Option<bool>) {
    (&r.baseline_status, r.baseline_robust)
}

impl Paired {
    /// The pairing of `(contact IK's outcome, the baseline's)` over some samples.
    pub fn of(outcomes: impl IntoIterator<Item = (bool, bool)>) -> Paired {
        let mut p = Paired {
            both: 0,
            only_contact_ik: 0,
            only_baseline: 0,
            neither: 0,
            mcnemar_p: 1.0,
        };
        for (contact, base) in outcomes {
            *match (contact, base) {
                (true, true) => &mut p.both,
                (true, false) => &mut p.only_contact_ik,
                (false, true) => &mut p.only_baseline,
                (false, false) => &mut p.neither,
            } += 1;
        }
        p.mcnemar_p = mcnemar_exact_p(p.only_contact_ik, p.only_baseline);
        p
    }

    /// `mcnemar_p` for a page or a terminal ([`format_p`]).
    pub fn p_text(&self) -> String {
        format_p(self.mcnemar_p)
    }
}

impl Default for Paired {
    fn default() -> Self {
        Paired::of([])
    }
}

/// Why a sample failed, in one word: the first of these its reason keys name. Unlike the
/// reason keys (a sample counted under each of its reasons), every failure has exactly one
/// cause, so a hand's causes add up to its failures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cause {
    /// The object lost while the hand carries it (`physics:slipped`, `physics:dropped`):
    /// what the paper expects of rigid transfer under non-uniform retiming.
    LostInGrasp,
    /// The carry held; the hand moved the object after letting go
    /// (`physics:pushed_after_release`).
    PushedAfterRelease,
    /// The object off its plan by the tracking limits, neither lost in the grasp nor pushed
    /// (`physics:mean_position_error`, `physics:position_error`, `physics:rotation_error`).
    Tracking,
    /// The hand or the object in the object or a barrier (`physics:*_penetration`).
    Penetration,
    /// Physics passed (or did not run) and too few IK frames converged (`ik:not_converged`).
    IkNotConverged,
    /// Anything else (`physics:unstable`, `physics:released_unsupported`, `narrow_gap`,
    /// `ik:d_c_above_max`, `error`, ...).
    Other,
}

impl Cause {
    /// The cause of a failure with the reason keys `keys` (`;`-separated, as in
    /// `samples.csv`).
    pub fn of(keys: &str) -> Cause {
        let keys: Vec<&str> = keys.split(';').filter(|k| !k.is_empty()).collect();
        let any = |names: &[&str]| keys.iter().any(|k| names.contains(k));
        if any(&["physics:slipped", "physics:dropped"]) {
            Cause::LostInGrasp
        } else if any(&["physics:pushed_after_release"]) {
            Cause::PushedAfterRelease
        } else if any(&[
            "physics:mean_position_error",
            "physics:position_error",
            "physics:rotation_error",
        ]) {
            Cause::Tracking
        } else if keys.iter().any(|k| k.ends_with("_penetration")) {
            Cause::Penetration
        } else if any(&["ik:not_converged"]) {
            Cause::IkNotConverged
        } else {
            Cause::Other
        }
    }
}

/// Failures by [`Cause`] (`stats.json` `baseline.failed_by_cause.<hand>`).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CauseCounts {
    pub lost_in_grasp: u64,
    pub pushed_after_release: u64,
    pub tracking: u64,
    pub penetration: u64,
    pub ik_not_converged: u64,
    pub other: u64,
}

impl CauseCounts {
    fn add(&mut self, cause: Cause) {
        *match cause {
            Cause::LostInGrasp => &mut self.lost_in_grasp,
            Cause::PushedAfterRelease => &mut self.pushed_after_release,
            Cause::Tracking => &mut self.tracking,
            Cause::Penetration => &mut self.penetration,
            Cause::IkNotConverged => &mut self.ik_not_converged,
            Cause::Other => &mut self.other,
        } += 1;
    }

    /// `(cause, count)` in the order of [`Cause`], for tables.
    pub fn rows(&self) -> [(&'static str, u64); 6] {
        [
            ("lost in the grasp (slipped or dropped)", self.lost_in_grasp),
            ("pushed after the release", self.pushed_after_release),
            ("off its plan (tracking limits)", self.tracking),
            ("penetration", self.penetration),
            ("IK not converged", self.ik_not_converged),
            ("other", self.other),
        ]
    }
}

/// Failures by cause of each hand over the same samples.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CausePair {
    pub contact_ik: CauseCounts,
    pub baseline: CauseCounts,
}

/// The paired outcome of contact IK and the baseline on the same samples.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Paired {
    pub both: u64,
    pub only_contact_ik: u64,
    pub only_baseline: u64,
    pub neither: u64,
    /// Whether the hands' yields differ by more than the draw of samples explains: the exact
    /// two-sided McNemar test of the samples only one hand keeps ([`mcnemar_exact_p`]), the
    /// chance of a split of them at least this uneven were either hand as likely to be the
    /// one keeping such a sample. 1 when no sample is kept by one hand only; below 0.05 the
    /// difference is unlikely to be chance. (Absent in files of older versions: read as 1.)
    #[serde(default = "no_evidence")]
    pub mcnemar_p: f64,
}

/// The p-value of no discordant sample.
fn no_evidence() -> f64 {
    1.0
}

/// One figure's distribution for each hand, over the same samples.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct HandPair {
    pub contact_ik: Summary,
    pub baseline: Summary,
}

impl BaselineStats {
    /// The baseline's figures of `rows`, or `None` when no row has a baseline run.
    fn of(rows: &[Row]) -> Option<BaselineStats> {
        let ran: Vec<&Row> = rows
            .iter()
            .filter(|r| !r.baseline_status.is_empty())
            .collect();
        if ran.is_empty() {
            return None;
        }
        let mut b = BaselineStats {
            ran: ran.len() as u64,
            ..BaselineStats::default()
        };
        for r in &ran {
            let base = r.baseline_status == "kept";
            if base {
                b.passed += 1;
            } else {
                b.failed += 1;
                for k in r.baseline_reasons.split(';').filter(|k| !k.is_empty()) {
                    *b.failed_by_reason.entry(k.to_string()).or_default() += 1;
                }
                b.failed_by_cause
                    .baseline
                    .add(Cause::of(&r.baseline_reasons));
            }
            if r.status != "kept" {
                b.failed_by_cause.contact_ik.add(Cause::of(&r.reasons));
            }
        }
        b.paired = Paired::of(
            ran.iter()
                .map(|r| (r.status == "kept", r.baseline_status == "kept")),
        );
        b.robust = Robust::of(rows, baseline_hand);
        if b.robust.is_some() {
            b.paired_robust =
                Some(Paired::of(ran.iter().map(|r| {
                    (is_robust(contact_hand(r)), is_robust(baseline_hand(r)))
                })));
        }
        let fractions: Vec<(f64, f64)> = ran
            .iter()
            .filter_map(|r| Some((r.pass_fraction?, r.baseline_pass_fraction?)))
            .collect();
        b.paired_pass_fraction = PairedFractions::of(&fractions);
        b.yield_ = ratio(b.passed, rows.len() as u64);
        b.pass_rate = ratio(b.passed, b.ran);
        let pair = |contact: Metric, base: Metric| {
            let both: Vec<(f64, f64)> = ran
                .iter()
                .filter_map(|r| Some((contact(r)?, base(r)?)))
                .collect();
            HandPair {
                contact_ik: Summary::of(both.iter().map(|p| p.0)),
                baseline: Summary::of(both.iter().map(|p| p.1)),
            }
        };
        b.d_c_mm = pair(|r| r.d_c_mm, |r| r.baseline_d_c_mm);
        b.d_c_stretched_mm = pair(|r| r.d_c_stretched_mm, |r| r.baseline_d_c_stretched_mm);
        b.grasp_slide_mm = pair(|r| r.grasp_slide_mm, |r| r.baseline_grasp_slide_mm);
        b.grasp_shift_mm = pair(|r| r.grasp_shift_mm, |r| r.baseline_grasp_shift_mm);
        b.onset_error_mm = pair(|r| r.onset_error_mm, |r| r.baseline_onset_error_mm);
        b.release_turn_by_hand_deg = pair(
            |r| r.release_turn_by_hand_deg,
            |r| r.baseline_release_turn_by_hand_deg,
        );
        Some(b)
    }
}

/// Identity of a run: what the figures are of.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunId {
    pub spec: String,
    pub spec_hash: u64,
    pub demo: String,
    pub seed: u64,
    pub count: u64,
    pub shards: Vec<String>,
}

impl Stats {
    /// The figures of `rows` (sorted by index).
    pub fn of(id: &RunId, rows: &[Row], timing: Timing) -> Stats {
        let mut s = Stats {
            format: STATS_FORMAT.into(),
            tool: format!("dexwarp {}", env!("CARGO_PKG_VERSION")),
            spec: id.spec.clone(),
            spec_hash: format!("{:016x}", id.spec_hash),
            demo: id.demo.clone(),
            seed: id.seed,
            count: id.count,
            shards: id.shards.clone(),
            attempts: rows.len() as u64,
            timing,
            ..Stats::default()
        };
        for r in rows {
            let keys = r.reasons.split(';').filter(|k| !k.is_empty());
            match r.status.as_str() {
                "rejected" => {
                    s.rejected += 1;
                    for k in keys {
                        *s.rejected_by_reason.entry(k.to_string()).or_default() += 1;
                    }
                }
                "kept" => {
                    s.ran += 1;
                    s.passed += 1;
                }
                _ => {
                    s.ran += 1;
                    s.failed += 1;
                    for k in keys {
                        let map = if let Some(p) = k.strip_prefix("physics:") {
                            (&mut s.failed_by_physics_reason, p)
                        } else if let Some(p) = k.strip_prefix("ik:") {
                            (&mut s.failed_by_ik_reason, p)
                        } else {
                            (&mut s.failed_by_other_reason, k)
                        };
                        *map.0.entry(map.1.to_string()).or_default() += 1;
                    }
                }
            }
        }
        s.yield_ = ratio(s.passed, s.attempts);
        s.pass_rate = ratio(s.passed, s.ran);
        s.original_d_c_mm = rows.iter().find_map(|r| r.d_c_original_mm);
        let kept: Vec<&Row> = rows.iter().filter(|r| r.status == "kept").collect();
        let fields: [(&str, Metric); 4] = [
            ("d_c_mm", |r| r.d_c_mm),
            ("d_wo_change_mm", |r| r.d_wo_change_mm),
            ("plr_object", |r| r.plr_object),
            ("timewarp_discrepancy", |r| r.timewarp_discrepancy),
        ];
        for (name, get) in fields {
            s.kept.insert(
                name.to_string(),
                Summary::of(kept.iter().filter_map(|r| get(r))),
            );
        }
        s.kept_median_d_c_no_worse = match (s.kept["d_c_mm"].median, s.original_d_c_mm) {
            (Some(m), Some(o)) => Some(m <= o),
            _ => None,
        };
        s.robust = Robust::of(rows, contact_hand);
        s.ensemble = EnsembleStats::of(rows);
        s.baseline = BaselineStats::of(rows);
        s
    }
}

fn ratio(a: u64, b: u64) -> f64 {
    if b == 0 { 0.0 } else { a as f64 / b as f64 }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 7 samples only contact IK keeps, 15 only the baseline, 3 both, 2 neither, 1 without a
    /// baseline run: the paired counts and the exact test of 7 against 15 (p = 0.1338); with
    /// the margin, the robust pairing is its own table and test.
    #[test]
    fn the_pairing_counts_each_sample_once_and_tests_the_discordant_ones() {
        let row = |contact: &str, base: &str, robust: Option<bool>| Row {
            status: contact.into(),
            baseline_status: base.into(),
            robust,
            baseline_robust: robust.map(|_| false),
            ..Row::default()
        };
        let mut rows = Vec::new();
        rows.extend((0..7).map(|_| row("kept", "failed", Some(true))));
        rows.extend((0..15).map(|_| row("failed", "kept", Some(false))));
        rows.extend((0..3).map(|_| row("kept", "kept", Some(true))));
        rows.extend((0..2).map(|_| row("failed", "failed", Some(false))));
        rows.push(row("kept", "", None));
        let b = BaselineStats::of(&rows).unwrap();
        let p = &b.paired;
        assert_eq!(
            (p.both, p.only_contact_ik, p.only_baseline, p.neither),
            (3, 7, 15, 2)
        );
        assert!((p.mcnemar_p - 0.13380050659179688).abs() < 1e-12, "{p:?}");
        assert_eq!(p.p_text(), "0.13");
        // Robust: contact IK's 10 kept are robust, none of the baseline's 18.
        let r = b.paired_robust.as_ref().unwrap();
        assert_eq!(
            (r.both, r.only_contact_ik, r.only_baseline, r.neither),
            (0, 10, 0, 17)
        );
        assert!((r.mcnemar_p - 2.0 / 1024.0).abs() < 1e-15, "{r:?}");
        assert_eq!(r.p_text(), "0.0020");
    }

    #[test]
    fn physics_sentences_get_stable_keys() {
        assert_eq!(
            physics_key("hand-object penetration 7.6 mm at frame 412 (a / b) > 5.0 mm; 3 frames"),
            "physics:hand_object_penetration"
        );
        assert_eq!(
            physics_key("object position error 12.0 mm at frame 3 > 10.0 mm"),
            "physics:position_error"
        );
        assert_eq!(
            physics_key(
                "object pushed after the release: position error 166.7 mm at frame 679 > 50.0 mm (7.8 mm at the last contact frame 534); the hand touches it up to frame 630"
            ),
            "physics:pushed_after_release"
        );
        assert_eq!(
            physics_key("grip lost 3 times"),
            "physics:grip_lost",
            "unknown sentences keep their leading words"
        );
    }

    #[test]
    fn every_failure_has_one_cause_in_order() {
        for (keys, cause) in [
            (
                "physics:mean_position_error;physics:slipped;ik:not_converged",
                Cause::LostInGrasp,
            ),
            (
                "physics:mean_position_error;physics:pushed_after_release",
                Cause::PushedAfterRelease,
            ),
            (
                "physics:rotation_error;physics:hand_object_penetration",
                Cause::Tracking,
            ),
            (
                "physics:hand_barrier_penetration;ik:not_converged",
                Cause::Penetration,
            ),
            ("ik:not_converged", Cause::IkNotConverged),
            ("physics:unstable", Cause::Other),
            ("narrow_gap", Cause::Other),
            ("ik:d_c_above_max", Cause::Other),
            ("", Cause::Other),
        ] {
            assert_eq!(Cause::of(keys), cause, "{keys}");
        }
    }

    #[test]
    fn frames_stopped_at_a_constraint_count_as_solved() {
        use crate::model::report::IkSummary;
        // 100 contact frames: 60 met the threshold, 30 stopped at the penetration limit,
        // 10 in a local minimum.
        let ik = IkSummary {
            converged_fraction: 0.6,
            stop_reasons: [
                ("penetration_limited".to_string(), 30),
                ("local_minimum".to_string(), 10),
            ]
            .into_iter()
            .collect(),
            ..IkSummary::default()
        };
        assert!((ik.solved_fraction() - 0.9).abs() < 1e-12);
        let all = IkSummary {
            converged_fraction: 1.0,
            ..IkSummary::default()
        };
        assert_eq!(all.solved_fraction(), 1.0);
        let none = IkSummary {
            converged_fraction: 0.0,
            stop_reasons: [("iteration_cap".to_string(), 7)].into_iter().collect(),
            ..IkSummary::default()
        };
        assert_eq!(none.solved_fraction(), 0.0);
    }

    #[test]
    fn percentiles_interpolate_between_ranks() {
        let s = Summary::of([4.0, 1.0, 3.0, 2.0, f64::NAN].into_iter());
        assert_eq!(s.n, 4);
        assert_eq!(s.median, Some(2.5));
        assert!((s.p10.unwrap() - 1.3).abs() < 1e-12);
        assert_eq!((s.min, s.max), (Some(1.0), Some(4.0)));
    }
}
