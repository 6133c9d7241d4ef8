//! `DIR/index.html` of an augment run, in the style of the reproduce report: the yield, the
//! reasons of failure and rejection as a bar chart, the distributions of D_C, D_WO change, PLR
//! and timewarp discrepancy over the kept samples (histograms), and a table of samples
//! linking to their files. One self-contained page (inline SVG drawn with plotters, no script).

use std::path::Path;

use plotters::prelude::*;

use super::stats::{BaselineStats, Metric, Row, STRETCHED, Stats};
use crate::Result;
use crate::model::json::write_atomic;

const W: u32 = 760;
const BLUE: RGBColor = RGBColor(31, 119, 180);
const ORANGE: RGBColor = RGBColor(255, 127, 14);
/// Rows shown in the table; `samples.csv` lists all.
const TABLE_ROWS: usize = 1000;

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Horizontal bars, one per (label, count).
fn bar_chart(title: &str, bars: &[(String, u64)]) -> String {
    if bars.is_empty() {
        return format!("<p class=\"note\">{}: none</p>", escape(title));
    }
    let h = 60 + 26 * bars.len() as u32;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, h)).into_drawing_area();
        let _ = root.fill(&WHITE);
        let max = bars.iter().map(|b| b.1).max().unwrap_or(1).max(1) as f64;
        let n = bars.len();
        let labels: Vec<String> = bars.iter().map(|b| b.0.clone()).collect();
        let chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(28)
            .y_label_area_size(230)
            .build_cartesian_2d(0.0..max * 1.1, -0.5..(n as f64 - 0.5));
        let Ok(mut chart) = chart else {
            return String::new();
        };
        let _ = chart
            .configure_mesh()
            .disable_y_mesh()
            .y_labels(n)
            .y_label_formatter(&|y: &f64| {
                let i = y.round();
                if (y - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < labels.len() {
                    labels[n - 1 - i as usize].clone()
                } else {
                    String::new()
                }
            })
            .x_desc("samples")
            .light_line_style(RGBColor(235, 235, 235))
            .draw();
        let _ = chart.draw_series(bars.iter().enumerate().map(|(k, (label, v))| {
            let y = (n - 1 - k) as f64;
            let color = if label.starts_with("rejected") {
                ORANGE
            } else {
                BLUE
            };
            Rectangle::new([(0.0, y - 0.35), (*v as f64, y + 0.35)], color.filled())
        }));
        let _ = root.present();
    }
    svg
}

/// A histogram of the finite `values` in 20 bins, as inline SVG; `counted` names what is
/// counted (the y axis, and the note when there is nothing). Also the `dexwarp report`
/// page's.
pub(crate) fn histogram(title: &str, x_label: &str, counted: &str, values: &[f64]) -> String {
    let v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return format!("<p class=\"note\">{}: no {counted}</p>", escape(title));
    }
    let (mut lo, mut hi) = v
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
    if hi - lo < 1e-9 {
        lo -= 0.5;
        hi += 0.5;
    }
    const BINS: usize = 20;
    let width = (hi - lo) / BINS as f64;
    let mut counts = [0u32; BINS];
    for x in &v {
        counts[(((x - lo) / width) as usize).min(BINS - 1)] += 1;
    }
    let top = *counts.iter().max().unwrap_or(&1) as f64;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W / 2 - 10, 260)).into_drawing_area();
        let _ = root.fill(&WHITE);
        let chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 15))
            .margin(8)
            .x_label_area_size(32)
            .y_label_area_size(40)
            .build_cartesian_2d(lo..hi, 0.0..top * 1.1);
        let Ok(mut chart) = chart else {
            return String::new();
        };
        let _ = chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(counted)
            .x_labels(5)
            .light_line_style(RGBColor(235, 235, 235))
            .draw();
        let _ = chart.draw_series(counts.iter().enumerate().map(|(k, &c)| {
            let x0 = lo + k as f64 * width;
            Rectangle::new([(x0, 0.0), (x0 + width, c as f64)], BLUE.filled())
        }));
        let _ = root.present();
    }
    svg
}

/// The run's ensemble verdicts in one paragraph.
fn ensemble_line(e: &super::stats::EnsembleStats) -> String {
    format!(
        "<p>ensemble verdicts: {} samples, median pass fraction {}; {} uncertain (the 95 % interval contains the keep threshold), {} of them kept; {} replays run for the {} asked (the early stop saves some, an uncertain decision takes more)</p>\n",
        e.samples,
        num(e.pass_fraction.median, 2),
        e.uncertain,
        e.uncertain_kept,
        e.replayed,
        e.asked
    )
}

/// A pass fraction for the samples table: `0.62`, `0.62 ?` when uncertain, `-` without one.
fn fraction(f: Option<f64>, uncertain: Option<bool>) -> String {
    match f {
        None => "-".into(),
        Some(f) if uncertain == Some(true) => format!("{f:.2} ?"),
        Some(f) => format!("{f:.2}"),
    }
}

/// A hand's status for the samples table, `kept, robust` when its margin holds under every
/// condition.
fn with_robust(status: &str, robust: Option<bool>) -> String {
    match (status, robust) {
        ("kept", Some(true)) => "kept, robust".into(),
        _ => escape(status),
    }
}

fn num(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "-".into(), |x| format!("{x:.digits$}"))
}

/// What the McNemar column says, as its header's tooltip.
const MCNEMAR: &str = "exact two-sided McNemar test of the samples only one hand keeps: the chance of a split at least this uneven if either hand were as likely to keep such a sample; below 0.05 the yields differ by more than the draw of samples explains";

/// Contact IK against the SE(3) baseline on the same samples (`--compare-baseline`).
fn baseline_section(b: &BaselineStats) -> String {
    let p = &b.paired;
    let mut h = format!(
        "<h2>Contact IK against the SE(3) baseline</h2>\n<p class=\"note\">every sample that ran, run again with the rigidly transferred hand on the same object trajectory and judged by the same rule; McNemar p: below 0.05 the two yields differ by more than the draw of samples explains</p>\n<table><tr><th>baseline: ran</th><th>kept</th><th>failed</th><th>yield</th><th>both kept</th><th>only contact IK</th><th>only baseline</th><th>neither</th><th title=\"{MCNEMAR}\">McNemar p</th></tr>\n<tr><td>{}</td><td>{}</td><td>{}</td><td>{:.1} %</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr></table>\n",
        b.ran,
        b.passed,
        b.failed,
        b.yield_ * 100.0,
        p.both,
        p.only_contact_ik,
        p.only_baseline,
        p.neither,
        p.p_text()
    );
    if let Some(f) = &b.paired_pass_fraction {
        h.push_str(&format!(
            "<p>pass fractions over the {} samples both hands ran: contact IK {:.2}, baseline {:.2} (mean); higher for contact IK on {}, for the baseline on {}, equal on {}; Wilcoxon signed-rank p {}</p>\n",
            f.samples,
            f.contact_ik_mean,
            f.baseline_mean,
            f.contact_ik_higher,
            f.baseline_higher,
            f.equal,
            f.p_text()
        ));
    }
    if let (Some(r), Some(p)) = (&b.robust, &b.paired_robust) {
        h.push_str(&format!(
            "<p class=\"note\">robust: kept, and the robustness margin holds under every condition (friction ×0.75 and ×0.5, mass ×1.5)</p>\n<table><tr><th>baseline: robust</th><th>yield</th><th>of its kept</th><th>both robust</th><th>only contact IK</th><th>only baseline</th><th>neither</th><th title=\"{MCNEMAR}\">McNemar p</th></tr>\n<tr><td>{}</td><td>{:.1} %</td><td>{:.1} %</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr></table>\n",
            r.kept,
            r.yield_ * 100.0,
            r.share_of_kept * 100.0,
            p.both,
            p.only_contact_ik,
            p.only_baseline,
            p.neither,
            p.p_text()
        ));
    }
    h.push_str("<table><tr><th>same samples [mm]</th><th>n</th><th>contact IK median</th><th>p90</th><th>baseline median</th><th>p90</th></tr>\n");
    for (what, pair) in [
        ("D_C, whole contact segment", &b.d_c_mm),
        (
            &format!("D_C, stretched segments (duration ×{STRETCHED} or more)"),
            &b.d_c_stretched_mm,
        ),
        (
            "grasp slide: the wrist's travel on the object while in contact",
            &b.grasp_slide_mm,
        ),
        (
            "grasp shift: the wrist's distance from the recorded grasp, on the object",
            &b.grasp_shift_mm,
        ),
        (
            "grasp onset: the simulated object's distance from its plan as the carry starts (the approach and the closing moved it)",
            &b.onset_error_mm,
        ),
        (
            "release turn [°, not mm]: how far the hand turned the released object (0 where it turned by itself)",
            &b.release_turn_by_hand_deg,
        ),
    ] {
        h.push_str(&format!(
            "<tr><td>{what}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
            pair.contact_ik.n,
            num(pair.contact_ik.median, 2),
            num(pair.contact_ik.p90, 2),
            num(pair.baseline.median, 2),
            num(pair.baseline.p90, 2)
        ));
    }
    h.push_str("</table>\n");
    let (ik, base) = (
        b.failed_by_cause.contact_ik.rows(),
        b.failed_by_cause.baseline.rows(),
    );
    h.push_str("<table><tr><th>failed, by cause (same samples; one cause each, the first that applies)</th><th>contact IK</th><th>baseline</th></tr>\n");
    for ((what, n_ik), (_, n_base)) in ik.iter().zip(&base) {
        h.push_str(&format!(
            "<tr><td>{what}</td><td>{n_ik}</td><td>{n_base}</td></tr>\n"
        ));
    }
    h.push_str("</table>\n");
    let bars: Vec<(String, u64)> = b
        .failed_by_reason
        .iter()
        .map(|(k, v)| (k.clone(), *v))
        .collect();
    h.push_str("<figure>\n");
    h.push_str(&bar_chart("why the baseline's samples failed", &bars));
    h.push_str("\n</figure>\n");
    h
}

/// Writes `out/index.html`.
pub fn write(out: &Path, stats: &Stats, rows: &[Row]) -> Result<()> {
    let mut body = format!(
        "<h1>dexwarp augment: {}</h1>\n<p class=\"prov\">demonstration {}, seed {}, {} samples, shards {}; {}</p>\n",
        escape(&stats.spec),
        escape(&stats.demo),
        stats.seed,
        stats.count,
        escape(&stats.shards.join(", ")),
        escape(&stats.tool)
    );
    body.push_str(&format!(
        "<table><tr><th>attempts</th><th>rejected</th><th>ran</th><th>kept</th><th>failed</th><th>yield</th><th>pass rate of ran</th><th>D_C original [mm]</th><th>D_C kept, median [mm]</th></tr>\n<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.1} %</td><td>{:.1} %</td><td>{}</td><td>{}</td></tr></table>\n",
        stats.attempts,
        stats.rejected,
        stats.ran,
        stats.passed,
        stats.failed,
        stats.yield_ * 100.0,
        stats.pass_rate * 100.0,
        num(stats.original_d_c_mm, 2),
        num(stats.kept.get("d_c_mm").and_then(|s| s.median), 2),
    ));
    if let Some(r) = &stats.robust {
        body.push_str(&format!(
            "<p>robust (kept, and the robustness margin holds under every condition): {} of the {} kept ({:.1} %), yield {:.1} %</p>\n",
            r.kept,
            stats.passed,
            r.share_of_kept * 100.0,
            r.yield_ * 100.0
        ));
    }
    if let Some(e) = &stats.ensemble {
        body.push_str(&ensemble_line(e));
    }
    if let Some(b) = &stats.baseline {
        body.push_str(&baseline_section(b));
    }
    let mut bars: Vec<(String, u64)> = Vec::new();
    for (prefix, map) in [
        ("physics", &stats.failed_by_physics_reason),
        ("ik", &stats.failed_by_ik_reason),
        ("other", &stats.failed_by_other_reason),
        ("rejected", &stats.rejected_by_reason),
    ] {
        bars.extend(map.iter().map(|(k, v)| (format!("{prefix}: {k}"), *v)));
    }
    body.push_str("<h2>Why samples were not kept</h2>\n<figure>\n");
    body.push_str(&bar_chart(
        "failed (blue, by reason; a sample may have several) and rejected before running (orange)",
        &bars,
    ));
    body.push_str("\n</figure>\n<h2>Kept samples</h2>\n<div class=\"grid\">\n");
    let kept: Vec<&Row> = rows.iter().filter(|r| r.status == "kept").collect();
    let series: [(&str, &str, Metric); 4] = [
        ("D_C", "D_C [mm]", |r| r.d_c_mm),
        ("D_WO change", "D_WO warped - original [mm]", |r| {
            r.d_wo_change_mm
        }),
        ("PLR (object)", "path length ratio", |r| r.plr_object),
        ("timewarp discrepancy", "discrepancy", |r| {
            r.timewarp_discrepancy
        }),
    ];
    for (title, x, get) in series {
        let values: Vec<f64> = kept.iter().filter_map(|r| get(r)).collect();
        body.push_str(&format!(
            "<figure>{}</figure>\n",
            histogram(title, x, "kept samples", &values)
        ));
    }
    body.push_str("</div>\n<h2>Samples</h2>\n");
    if rows.len() > TABLE_ROWS {
        body.push_str(&format!(
            "<p class=\"note\">the first {TABLE_ROWS} of {}; samples.csv lists all</p>\n",
            rows.len()
        ));
    }
    body.push_str("<table>\n<tr><th>sample</th><th>status</th><th>pass fraction</th><th>waypoints</th><th>barriers</th><th>threshold [mm]</th><th>D_C [mm]</th><th>ΔD_WO [mm]</th><th>PLR</th><th>timewarp</th><th>stretch</th><th>baseline</th><th>baseline D_C [mm]</th><th>files</th><th>reasons</th></tr>\n");
    for r in rows.iter().take(TABLE_ROWS) {
        let files = if r.status == "rejected" {
            String::new()
        } else {
            let d = format!("{}/{}", r.status, r.id);
            format!(
                "<a href=\"{d}/config.json\">config</a> <a href=\"{d}/report.json\">report</a> <a href=\"{d}/frames.csv\">frames</a> <a href=\"{d}/\">folder</a>"
            )
        };
        body.push_str(&format!(
            "<tr><td>{}</td><td class=\"{}\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.2}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"{}\">{}</td><td>{}</td><td>{files}</td><td class=\"why\">{}</td></tr>\n",
            escape(&r.id),
            escape(&r.status),
            with_robust(&r.status, r.robust),
            fraction(r.pass_fraction, r.uncertain),
            r.waypoints,
            r.barriers,
            r.threshold_mm,
            num(r.d_c_mm, 2),
            num(r.d_wo_change_mm, 1),
            num(r.plr_object, 3),
            num(r.timewarp_discrepancy, 3),
            num(r.stretch_max, 2),
            escape(&r.baseline_status),
            with_robust(&r.baseline_status, r.baseline_robust),
            num(r.baseline_d_c_mm, 2),
            escape(&r.detail)
        ));
    }
    body.push_str("</table>\n");
    let page = format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>dexwarp augment {}</title>\n<style>\nbody {{ font-family: sans-serif; margin: 2em auto; max-width: 1100px; color: #222; }}\ntable {{ border-collapse: collapse; margin: 0.5em 0 1.5em; font-size: 0.9em; }}\nth, td {{ border: 1px solid #ccc; padding: 3px 8px; text-align: right; }}\nth:first-child, td:first-child {{ text-align: left; }}\ntd.why {{ text-align: left; font-size: 0.85em; color: #555; }}\ntd.kept {{ color: #2a7; }} td.failed {{ color: #c33; }} td.rejected {{ color: #c80; }}\n.grid {{ display: flex; flex-wrap: wrap; }}\nfigure {{ margin: 0.5em 0; }}\n.prov, .note {{ color: #555; font-size: 0.9em; }}\n</style>\n</head>\n<body>\n{body}</body>\n</html>\n",
        escape(&stats.spec)
    );
    write_atomic(&out.join("index.html"), page.as_bytes())
}
