//! `dexwarp report DIR --compare PREV_DIR`: what changed between two runs of the same items
//! (matched by folder): verdict flips, new failures, items gone or added, and metric changes
//! beyond a tolerance. A change is *worse* when a verdict got worse (pass → fail → error), a
//! new item fails, an item is gone, or D_C, D_WO, hand-object penetration, the waypoint
//! error or the onset (how far the grasp's closing moved the object, `physics.onset`) grew
//! by more than its tolerance; PLR and timewarp changes beyond their tolerances
//! are listed but do not count as worse (either direction can be the intent of a change).
//! Timing is listed apart (stage totals per item slower by more than `time_ratio` and by
//! more than a second; the run's totals) and never counts as worse: it depends on the
//! machine. With an ensemble verdict on both sides, a verdict flip or a fall of the pass
//! fraction is worse only when the fall is beyond what the two ensembles' intervals allow
//! ([`crate::physics::ensemble::dropped_significantly`]): two runs of the same code with other
//! ensemble seeds differ by chance at the edge, and that is not a regression.

use super::{Item, seconds};
use crate::model::report::Report;

/// How much a figure may move before it is reported.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerances {
    /// D_C of the output [mm] (default 0.5).
    pub d_c_mm: f64,
    /// D_WO of the output [mm] (default 1).
    pub d_wo_mm: f64,
    /// Deepest hand-object penetration of the output [mm] (default 0.5).
    pub penetration_mm: f64,
    /// Largest waypoint error [mm] (default 1).
    pub waypoint_mm: f64,
    /// The object's error at the first contact frame (`physics.onset`) [mm] (default 2: every
    /// grasp's closing moves the object a few millimetres, 2.2-8.1 mm on the built-in configs;
    /// what to flag is a grasp that starts shoving it).
    pub onset_mm: f64,
    /// Object path length ratio (default 0.05).
    pub plr: f64,
    /// Timewarp discrepancy (default 0.02).
    pub timewarp: f64,
    /// Stage time ratio, now over before (default 1.5).
    pub time_ratio: f64,
}

impl Default for Tolerances {
    fn default() -> Self {
        Tolerances {
            d_c_mm: 0.5,
            d_wo_mm: 1.0,
            penetration_mm: 0.5,
            waypoint_mm: 1.0,
            onset_mm: 2.0,
            plr: 0.05,
            timewarp: 0.02,
            time_ratio: 1.5,
        }
    }
}

/// One reported difference.
#[derive(Clone, Debug, PartialEq)]
pub struct Change {
    /// Item id (its folder).
    pub id: String,
    /// `verdict`, `new item`, `missing`, or the metric's name.
    pub what: String,
    /// Before and after, in words.
    pub text: String,
    pub worse: bool,
}

/// The differences between two runs.
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    /// The previous run's folder, as given.
    pub previous: String,
    /// Items present in both runs.
    pub matched: usize,
    pub changes: Vec<Change>,
    /// Items whose stage time grew beyond the ratio: (id, before [s], now [s]).
    pub slower: Vec<(String, f64, f64)>,
    /// Total stage time of all items, before and now [s].
    pub total_seconds: (f64, f64),
}

fn rank(status: &str) -> u8 {
    match status {
        "pass" | "not run" => 0,
        "fail" => 1,
        _ => 2,
    }
}

/// `(passed, replayed)` of an item's ensemble, when its report has one.
fn ensemble_counts(item: &Item) -> Option<(usize, usize)> {
    item.finished()?.physics.as_ref()?.ensemble_count()
}

fn fraction_text(before: (usize, usize), now: (usize, usize)) -> String {
    format!("{}/{} -> {}/{}", before.0, before.1, now.0, now.1)
}

fn first(reasons: &[String]) -> String {
    reasons
        .first()
        .map(|r| format!(" ({r})"))
        .unwrap_or_default()
}

/// Compares `now` with `before` (both from [`super::collect`]).
pub fn compare(previous: &str, before: &[Item], now: &[Item], tol: &Tolerances) -> Comparison {
    let mut changes = Vec::new();
    let mut slower = Vec::new();
    let mut matched = 0;
    let find = |items: &'_ [Item], id: &str| items.binary_search_by(|i| i.id.as_str().cmp(id)).ok();
    for n in now {
        let Some(b) = find(before, &n.id).map(|k| &before[k]) else {
            let worse = rank(n.status()) > 0;
            changes.push(change(
                &n.id,
                if worse { "new failure" } else { "new item" },
                format!("{}{}", n.status(), first(&n.reasons())),
                worse,
            ));
            continue;
        };
        matched += 1;
        let (sb, sn) = (b.status(), n.status());
        let fractions = ensemble_counts(b).zip(ensemble_counts(n));
        if sb != sn {
            // With an ensemble on both sides, a flip is worse only when the pass fraction
            // fell by more than the two ensembles' intervals allow.
            let (worse, why) = match fractions {
                Some((fb, fnow)) if rank(sb) < 2 && rank(sn) < 2 => {
                    let worse = crate::physics::ensemble::dropped_significantly(fb, fnow);
                    let words = if worse {
                        "a drop beyond both intervals"
                    } else {
                        "within what two ensembles differ by"
                    };
                    (
                        worse,
                        format!(" [pass fraction {}, {words}]", fraction_text(fb, fnow)),
                    )
                }
                _ => (rank(sn) > rank(sb), String::new()),
            };
            changes.push(change(
                &n.id,
                "verdict",
                format!("{sb} -> {sn}{why}{}", first(&n.reasons())),
                worse,
            ));
        } else if let Some((fb, fnow)) = fractions
            && crate::physics::ensemble::dropped_significantly(fb, fnow)
        {
            changes.push(change(
                &n.id,
                "pass fraction",
                format!("{} (a drop beyond both intervals)", fraction_text(fb, fnow)),
                true,
            ));
        }
        let (Some(rb), Some(rn)) = (b.finished(), n.finished()) else {
            continue;
        };
        changes.extend(metric_changes(&n.id, rb, rn, tol));
        let (tb, tn) = (seconds(rb), seconds(rn));
        if tn > tb * tol.time_ratio && tn - tb > 1.0 {
            slower.push((n.id.clone(), tb, tn));
        }
    }
    for b in before {
        if find(now, &b.id).is_none() {
            changes.push(change(
                &b.id,
                "missing",
                format!("was {}, no report now", b.status()),
                true,
            ));
        }
    }
    let total = |items: &[Item]| items.iter().filter_map(Item::finished).map(seconds).sum();
    Comparison {
        previous: previous.into(),
        matched,
        changes,
        slower,
        total_seconds: (total(before), total(now)),
    }
}

/// The metric changes of one item beyond `tol`, `rb` before and `rn` now: D_C, D_WO,
/// penetration, waypoint error and onset (worse when they grew), PLR and timewarp
/// discrepancy.
fn metric_changes(id: &str, rb: &Report, rn: &Report, tol: &Tolerances) -> Vec<Change> {
    let grew = |what: &str, x: Option<f64>, y: Option<f64>, tol: f64, unit: &str| {
        let (Some(x), Some(y)) = (x, y) else {
            return None;
        };
        let d = y - x;
        (d.abs() > tol || (x.is_finite() != y.is_finite())).then(|| {
            change(
                id,
                what,
                format!("{x:.2} -> {y:.2}{unit} ({d:+.2}, tolerance {tol}{unit})"),
                d > tol || d.is_nan(),
            )
        })
    };
    let moved = |what: &str, x: f64, y: f64, tol: f64| {
        let d = y - x;
        (d.abs() > tol || d.is_nan()).then(|| {
            change(
                id,
                what,
                format!("{x:.3} -> {y:.3} ({d:+.3}, tolerance {tol})"),
                false,
            )
        })
    };
    let pen = |r: &Report| r.constraints.hand_object_penetration_mm.map(|p| p.warped);
    let onset = |r: &Report| r.physics.as_ref().and_then(|p| p.onset_error_mm());
    [
        grew(
            "D_C",
            Some(rb.metrics.d_c_mm.warped),
            Some(rn.metrics.d_c_mm.warped),
            tol.d_c_mm,
            " mm",
        ),
        grew(
            "D_WO",
            Some(rb.metrics.d_wo_mm.warped),
            Some(rn.metrics.d_wo_mm.warped),
            tol.d_wo_mm,
            " mm",
        ),
        grew(
            "hand-object penetration",
            pen(rb),
            pen(rn),
            tol.penetration_mm,
            " mm",
        ),
        grew(
            "waypoint error",
            Some(rb.constraints.max_waypoint_error_mm),
            Some(rn.constraints.max_waypoint_error_mm),
            tol.waypoint_mm,
            " mm",
        ),
        grew("onset", onset(rb), onset(rn), tol.onset_mm, " mm"),
        moved(
            "PLR object",
            rb.metrics.plr_object,
            rn.metrics.plr_object,
            tol.plr,
        ),
        moved(
            "timewarp discrepancy",
            rb.metrics.timewarp_discrepancy,
            rn.metrics.timewarp_discrepancy,
            tol.timewarp,
        ),
    ]
    .into_iter()
    .flatten()
    .collect()
}

/// A [`Change`] of item `id`.
fn change(id: &str, what: &str, text: String, worse: bool) -> Change {
    Change {
        id: id.into(),
        what: what.into(),
        text,
        worse,
    }
}

impl Comparison {
    /// Changes that count as worse.
    pub fn worse(&self) -> usize {
        self.changes.iter().filter(|c| c.worse).count()
    }

    /// One line of counts.
    pub fn headline(&self) -> String {
        format!(
            "{} items matched with {}: {} changes beyond the tolerances, {} worse; stage time {:.1} s -> {:.1} s",
            self.matched,
            self.previous,
            self.changes.len(),
            self.worse(),
            self.total_seconds.0,
            self.total_seconds.1
        )
    }

    /// The Markdown summary (`compare.md`).
    pub fn markdown(&self) -> String {
        let mut s = format!("# dexwarp report --compare\n\n{}\n\n", self.headline());
        if self.changes.is_empty() {
            s.push_str("No change beyond the tolerances.\n");
        } else {
            s.push_str("| item | what | change | worse |\n|---|---|---|---|\n");
            for c in &self.changes {
                s.push_str(&format!(
                    "| {} | {} | {} | {} |\n",
                    c.id.replace('|', "\\|"),
                    c.what,
                    c.text.replace('|', "\\|"),
                    if c.worse { "**yes**" } else { "no" }
                ));
            }
        }
        if !self.slower.is_empty() {
            s.push_str("\nSlower (stage time, not counted as worse):\n\n");
            for (id, b, n) in &self.slower {
                s.push_str(&format!("- {id}: {b:.1} s -> {n:.1} s\n"));
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::report::PhysicsSummary;

    fn item(onset_mm: Option<f64>) -> Item {
        let mut physics = PhysicsSummary {
            verdict: "pass".into(),
            ..PhysicsSummary::default()
        };
        if let Some(mm) = onset_mm {
            physics.measures.insert(
                "onset".into(),
                serde_json::json!({"frame": 75, "position_error_mm": mm, "rotation_error_deg": 1.0}),
            );
        }
        Item {
            id: "a".into(),
            dir: "a".into(),
            report: Ok(Report {
                physics: Some(physics),
                ..Report::default()
            }),
        }
    }

    /// An item whose ensemble passed `passed` of `replayed`, its verdict the decision at 0.5.
    fn ensemble_item(passed: usize, replayed: usize) -> Item {
        let keep = 2 * passed >= replayed;
        let mut physics = PhysicsSummary {
            verdict: if keep { "pass" } else { "fail" }.into(),
            ..PhysicsSummary::default()
        };
        physics.measures.insert(
            "ensemble".into(),
            serde_json::json!({"passed": passed, "replayed": replayed, "members": 8,
                "pass_fraction": passed as f64 / replayed as f64}),
        );
        Item {
            id: "a".into(),
            dir: "a".into(),
            report: Ok(Report {
                physics: Some(physics),
                ..Report::default()
            }),
        }
    }

    /// With ensembles on both sides a verdict flip is listed, but worse only when the pass
    /// fraction fell beyond both intervals; such a fall without a flip is worse too.
    #[test]
    fn a_flip_within_the_ensembles_intervals_is_not_worse() {
        let tol = Tolerances::default();
        let run = |b: (usize, usize), n: (usize, usize)| {
            compare(
                "prev",
                &[ensemble_item(b.0, b.1)],
                &[ensemble_item(n.0, n.1)],
                &tol,
            )
        };
        let c = run((5, 8), (3, 8));
        assert_eq!(c.changes.len(), 1, "{:?}", c.changes);
        assert_eq!(c.worse(), 0, "{:?}", c.changes);
        assert!(
            c.changes[0]
                .text
                .contains("within what two ensembles differ by")
        );
        let c = run((8, 8), (1, 8));
        assert_eq!(c.worse(), 1, "{:?}", c.changes);
        assert!(c.changes[0].text.contains("beyond both intervals"));
        let c = run((8, 8), (4, 8));
        assert_eq!(
            (c.changes[0].what.as_str(), c.worse()),
            ("pass fraction", 1)
        );
        assert!(run((3, 8), (8, 8)).changes.iter().all(|c| !c.worse));
    }

    /// A grasp that pushes the object further as it closes is worse beyond the tolerance;
    /// within it, or smaller, or unknown on either side, nothing is reported.
    #[test]
    fn a_grown_onset_counts_as_worse() {
        let tol = Tolerances::default();
        let run = |before: Option<f64>, now: Option<f64>| {
            compare("prev", &[item(before)], &[item(now)], &tol)
        };
        let c = run(Some(3.0), Some(17.7));
        assert_eq!(c.worse(), 1, "{:?}", c.changes);
        assert_eq!(c.changes[0].what, "onset");
        assert!(
            c.changes[0].text.starts_with("3.00 -> 17.70 mm"),
            "{:?}",
            c.changes
        );
        let c = run(Some(17.7), Some(3.0));
        assert_eq!((c.changes.len(), c.worse()), (1, 0), "{:?}", c.changes);
        for (before, now) in [
            (Some(3.0), Some(4.9)),
            (None, Some(17.7)),
            (Some(3.0), None),
        ] {
            assert!(run(before, now).changes.is_empty(), "{before:?} -> {now:?}");
        }
    }
}
