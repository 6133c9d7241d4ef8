//! The HTML page of `dexwarp report` (see the module docs of [`super`]).

use std::collections::BTreeMap;
use std::path::Path;

use rayon::prelude::*;

use super::compare::Comparison;
use super::{Item, seconds};
use crate::model::json::write_atomic;
use crate::player::{self, Entry};
use crate::{Error, Limits, Result};

/// The `generator` of pages written by `dexwarp report` (a page without it is not replaced).
pub const GENERATOR: &str = "dexwarp report";
/// Rows of the item table at most (the page stays light; the reports hold the rest).
const TABLE_ROWS: usize = 5000;

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn num(v: Option<f64>, digits: usize) -> String {
    match v {
        Some(x) if x.is_finite() => format!("{x:.digits$}"),
        _ => "-".into(),
    }
}

/// A reason with its numbers folded (`penetration 7.2 mm at frame 260` and
/// `penetration 5.1 mm at frame 172` count as one kind).
fn reason_kind(r: &str) -> String {
    let mut out = String::new();
    let mut in_num = false;
    for ch in r.chars() {
        if ch.is_ascii_digit() || (in_num && ch == '.') {
            if !in_num {
                out.push('#');
            }
            in_num = true;
        } else {
            in_num = false;
            out.push(ch);
        }
    }
    out
}

/// What an item is called on the page: its folder, or its report's name for `DIR` itself.
fn label(it: &Item) -> String {
    match (&it.report, it.id.as_str()) {
        (Ok(r), ".") => r.name.clone(),
        _ => it.id.clone(),
    }
}

/// The ensemble's pass fraction, `3/8 (0.38, uncertain)`, or `-` for a single replay.
fn pass_fraction(r: Option<&crate::model::report::Report>) -> String {
    let p = r.and_then(|r| r.physics.as_ref());
    match p.and_then(|p| Some((p.ensemble_count()?, p.pass_fraction()?, p.uncertain()))) {
        None => "-".into(),
        Some(((x, n), f, uncertain)) => format!(
            "{x}/{n} ({f:.2}{})",
            if uncertain == Some(true) {
                ", uncertain"
            } else {
                ""
            }
        ),
    }
}

/// Every ensemble member's outcome, one line each (the pass-fraction cell's tooltip).
fn members(r: Option<&crate::model::report::Report>) -> String {
    let Some(e) = r
        .and_then(|r| r.physics.as_ref())
        .and_then(|p| p.ensemble())
    else {
        return String::new();
    };
    e["member"]
        .as_array()
        .into_iter()
        .flatten()
        .map(|m| {
            format!(
                "member {}: {}",
                m["index"],
                m["reason"].as_str().unwrap_or("pass")
            )
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The robustness margin's sentence (`warp --margin`), `robust` when every condition
/// holds, `-` when the report has none.
fn margin(r: Option<&crate::model::report::Report>) -> String {
    let m = r.and_then(|r| r.physics.as_ref()).and_then(|p| p.margin());
    match m {
        None => "-".into(),
        Some(m) => {
            let sentence = m["sentence"].as_str().unwrap_or("-");
            if m["robust"].as_bool() == Some(true) {
                format!("robust: {sentence}")
            } else {
                sentence.to_string()
            }
        }
    }
}

/// The player entries and data scripts of `items` (next to `page`, in `player/`), built in
/// parallel; items without a drawable trajectory are returned with the reason.
fn players(
    items: &[Item],
    page: &Path,
    limits: &Limits,
) -> Result<(Vec<Entry>, BTreeMap<String, String>)> {
    let dir = page.parent().unwrap_or(Path::new(".")).join("player");
    let stem = page
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "index".into());
    let prefix = format!("{stem}-");
    let built: Vec<(Entry, Result<serde_json::Value>)> = items
        .par_iter()
        .enumerate()
        .filter_map(|(k, it)| it.finished().map(|r| (k, it, r)))
        .map_init(player::data::Cache::default, |cache, (k, it, r)| {
            let entry = Entry {
                id: it.id.clone(),
                label: format!("{} ({})", label(it), it.status()),
                src: format!("player/{prefix}{k}.js"),
            };
            let data = player::data::trajectory(&it.dir, r, &label(it), cache, limits);
            (entry, data)
        })
        .collect();
    let (ok, missing) = player::write_scripts(&dir, &prefix, built)?;
    Ok((
        ok,
        missing.into_iter().map(|(e, why)| (e.id, why)).collect(),
    ))
}

/// Writes the page for `items` of `dir` to `page`, with `comparison` at the top.
pub fn write_page(
    dir: &Path,
    page: &Path,
    items: &[Item],
    comparison: Option<&Comparison>,
    limits: &Limits,
) -> Result<()> {
    let (entries, no_player) = players(items, page, limits)?;
    let playable: std::collections::HashSet<&str> = entries.iter().map(|e| e.id.as_str()).collect();
    let mut body = format!(
        "<h1>dexwarp report: {}</h1>\n<p class=\"prov\">{} items; dexwarp {} ({})</p>\n",
        escape(&dir.display().to_string()),
        items.len(),
        crate::model::provenance::TOOL_VERSION,
        crate::model::provenance::GIT_REVISION
    );
    if let Some(c) = comparison {
        comparison_section(&mut body, c);
    }
    verdicts_section(&mut body, items);
    body.push_str(&player::section(&entries));
    distributions_section(&mut body, items);
    items_table(&mut body, items, &playable, &no_player);
    let html = format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<meta name=\"generator\" content=\"{GENERATOR}\">\n<title>dexwarp report</title>\n<style>\nbody {{ font-family: sans-serif; margin: 2em auto; max-width: 1100px; color: #222; }}\ntable {{ border-collapse: collapse; margin: 0.5em 0 1.5em; font-size: 0.9em; }}\nth, td {{ border: 1px solid #ccc; padding: 3px 8px; text-align: right; }}\nth:first-child, td:first-child {{ text-align: left; }}\ntr.bad td {{ background: #fdecea; }}\np.bad {{ color: #b00; font-weight: bold; }}\np.good {{ color: #080; }}\n.hists {{ display: flex; flex-wrap: wrap; gap: 8px; }}\n.prov, .note {{ color: #555; font-size: 0.9em; }}\n{}</style>\n</head>\n<body>\n{body}</body>\n</html>\n",
        player::STYLE
    );
    write_atomic(page, html.as_bytes()).map_err(|e| match e {
        Error::Io { source, .. } => Error::write(page, source),
        other => other,
    })
}

/// The comparison with the previous report: headline, changes, slower items.
fn comparison_section(body: &mut String, c: &Comparison) {
    body.push_str(&format!(
        "<section id=\"compare\"><h2>Compared with {}</h2>\n<p class=\"{}\">{}</p>\n",
        escape(&c.previous),
        if c.worse() > 0 { "bad" } else { "good" },
        escape(&c.headline())
    ));
    if !c.changes.is_empty() {
        body.push_str("<table><tr><th>item</th><th>what</th><th>change</th><th>worse</th></tr>\n");
        for ch in &c.changes {
            body.push_str(&format!(
                "<tr class=\"{}\"><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                if ch.worse { "bad" } else { "" },
                escape(&ch.id),
                escape(&ch.what),
                escape(&ch.text),
                if ch.worse { "yes" } else { "no" }
            ));
        }
        body.push_str("</table>\n");
    }
    for (id, b, n) in &c.slower {
        body.push_str(&format!(
            "<p class=\"note\">slower: {} {b:.1} s -> {n:.1} s (not counted as worse)</p>\n",
            escape(id)
        ));
    }
    body.push_str("</section>\n");
}

/// The count of items per verdict and of reasons per kind.
fn verdicts_section(body: &mut String, items: &[Item]) {
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    let mut kinds: BTreeMap<String, usize> = BTreeMap::new();
    for it in items {
        *counts.entry(it.status()).or_default() += 1;
        for r in it.reasons() {
            *kinds.entry(reason_kind(&r)).or_default() += 1;
        }
    }
    body.push_str("<h2>Verdicts</h2>\n<table><tr>");
    for k in counts.keys() {
        body.push_str(&format!("<th>{}</th>", escape(k)));
    }
    body.push_str("<th>items</th></tr>\n<tr>");
    for v in counts.values() {
        body.push_str(&format!("<td>{v}</td>"));
    }
    body.push_str(&format!("<td>{}</td></tr></table>\n", items.len()));
    if !kinds.is_empty() {
        let mut kinds: Vec<(String, usize)> = kinds.into_iter().collect();
        kinds.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
        body.push_str(
            "<h3>Reasons</h3>\n<table><tr><th>reason (# = a number)</th><th>items</th></tr>\n",
        );
        for (k, n) in kinds.iter().take(30) {
            body.push_str(&format!("<tr><td>{}</td><td>{n}</td></tr>\n", escape(k)));
        }
        body.push_str("</table>\n");
    }
}

/// Histograms of the finished items' metrics.
fn distributions_section(body: &mut String, items: &[Item]) {
    let done: Vec<&crate::model::report::Report> =
        items.iter().filter_map(Item::finished).collect();
    let col = |f: fn(&crate::model::report::Report) -> Option<f64>| -> Vec<f64> {
        done.iter().filter_map(|r| f(r)).collect()
    };
    body.push_str("<h2>Distributions</h2>\n<div class=\"hists\">\n");
    for (title, values) in [
        (
            "D_C of the output [mm]",
            col(|r| Some(r.metrics.d_c_mm.warped)),
        ),
        (
            "D_WO of the output [mm]",
            col(|r| Some(r.metrics.d_wo_mm.warped)),
        ),
        (
            "hand-object penetration [mm]",
            col(|r| r.constraints.hand_object_penetration_mm.map(|p| p.warped)),
        ),
        (
            "path length ratio, object",
            col(|r| Some(r.metrics.plr_object)),
        ),
        (
            "timewarp discrepancy",
            col(|r| Some(r.metrics.timewarp_discrepancy)),
        ),
        ("stage time [s]", col(|r| Some(seconds(r)))),
    ] {
        body.push_str(&crate::augment::page::histogram(
            title, "", "items", &values,
        ));
        body.push('\n');
    }
    body.push_str("</div>\n");
}

/// The item table (the first [`TABLE_ROWS`]), each item linked to its player when it has one.
fn items_table(
    body: &mut String,
    items: &[Item],
    playable: &std::collections::HashSet<&str>,
    no_player: &BTreeMap<String, String>,
) {
    body.push_str("<h2>Items</h2>\n<table><tr><th>item</th><th>hand</th><th>threshold [mm]</th><th>verdict</th><th>pass fraction</th><th>first reason</th><th>D_C [mm]</th><th>D_WO [mm]</th><th>PLR object</th><th>timewarp disc.</th><th>penetration [mm]</th><th>margin</th><th>time [s]</th></tr>\n");
    for it in items.iter().take(TABLE_ROWS) {
        let reasons = it.reasons();
        let name = if playable.contains(it.id.as_str()) {
            format!(
                "<a href=\"#play={}\">{}</a>",
                escape(&it.id),
                escape(&it.id)
            )
        } else {
            let why = no_player.get(&it.id).map_or("", String::as_str);
            format!(
                "<span title=\"no player: {}\">{}</span>",
                escape(why),
                escape(&it.id)
            )
        };
        let r = it.finished();
        body.push_str(&format!(
            "<tr class=\"{}\"><td>{name}</td><td>{}</td><td>{}</td><td>{}</td><td title=\"{}\">{}</td><td title=\"{}\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
            if matches!(it.status(), "fail" | "error") { "bad" } else { "" },
            escape(r.and_then(|r| r.hand.as_deref()).unwrap_or("-")),
            num(r.and_then(|r| r.threshold_mm), 1),
            escape(it.status()),
            escape(&members(r)),
            escape(&pass_fraction(r)),
            escape(&reasons.join("; ")),
            escape(reasons.first().map_or("", String::as_str)),
            num(r.map(|r| r.metrics.d_c_mm.warped), 2),
            num(r.map(|r| r.metrics.d_wo_mm.warped), 2),
            num(r.map(|r| r.metrics.plr_object), 3),
            num(r.map(|r| r.metrics.timewarp_discrepancy), 3),
            num(r.and_then(|r| r.constraints.hand_object_penetration_mm.map(|p| p.warped)), 2),
            escape(&margin(r)),
            num(r.map(seconds), 1),
        ));
    }
    body.push_str("</table>\n");
    if items.len() > TABLE_ROWS {
        body.push_str(&format!(
            "<p class=\"note\">{TABLE_ROWS} of {} items shown; every report.json has the rest.</p>\n",
            items.len()
        ));
    }
}
