//! `index.html`: the tables and SVG plots of a reproduction, one page that works offline (no
//! CDN; plots are inline SVG drawn with plotters), with the 3D player ([`crate::player`]) of
//! every config's contact-IK output at 3.5 mm and of the showcase config's baseline, their
//! data in `player/reproduce-*.js` next to the page (loaded when picked).
//!
//! Plots: the timewarp (input frame against output time, the paper's Allegro figure (c)); object
//! and wrist height over time for the baseline against contact IK (the paper's baseline
//! figure); per-frame D_C; per-frame physics tracking error; the robustness curves; for every
//! `*_timewarp_stress*` config and for the config whose retiming stretches a segment the most,
//! the paper's Fig. "naive" (object height, baseline wrist and contact-IK wrist over output
//! time, τ's control points marked, the frames where the object is off its plan shaded),
//! also written as `figures/naive_<config>.svg`.

use std::path::Path;

use plotters::prelude::*;

use super::tables::{self, Table};
use super::{ROBUSTNESS_CONFIG, Reproduction};
use crate::model::frames::FrameRow;
use crate::model::json::write_atomic;
use crate::{Error, Result};

const W: u32 = 760;
const H: u32 = 300;

/// A named series of (x, y) points.
struct Series<'a> {
    label: &'a str,
    color: RGBColor,
    points: Vec<(f64, f64)>,
}

fn line_chart(title: &str, x_label: &str, y_label: &str, series: &[Series]) -> String {
    line_chart_shaded(title, x_label, y_label, series, &[], &[])
}

/// A line chart with vertical marker lines at the x values `marks` (τ's control points) and
/// bands shaded behind the lines: each `(frames, color, label)` shades `[f, f + 1)` for every
/// listed x value `f` (sorted), the first in the lower half of the plot and the second in the
/// upper half, so two sets stay apart where they overlap.
fn line_chart_shaded(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    marks: &[f64],
    shaded: &[(Vec<usize>, RGBColor, &str)],
) -> String {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        let _ = root.fill(&WHITE);
        let pts = series.iter().flat_map(|s| s.points.iter());
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &(x, y) in pts.filter(|(x, y)| x.is_finite() && y.is_finite()) {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        if x0 > x1 {
            (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
        }
        if (y1 - y0).abs() < 1e-12 {
            y1 = y0 + 1.0;
        }
        let pad = 0.05 * (y1 - y0);
        let chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(32)
            .y_label_area_size(56)
            .build_cartesian_2d(x0..x1.max(x0 + 1e-9), (y0 - pad)..(y1 + pad));
        let Ok(mut chart) = chart else {
            return svg_error(title);
        };
        let _ = chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .light_line_style(RGBColor(235, 235, 235))
            .draw();
        let (lo, hi) = (y0 - pad, y1 + pad);
        for (k, (frames, color, label)) in shaded.iter().enumerate() {
            let (b0, b1) = if k % 2 == 0 {
                (lo, (lo + hi) / 2.0)
            } else {
                ((lo + hi) / 2.0, hi)
            };
            let drawn = chart.draw_series(spans(frames).into_iter().map(|(a, b)| {
                Rectangle::new([(a as f64, b0), (b as f64, b1)], color.mix(0.18).filled())
            }));
            if let (Ok(a), false) = (drawn, frames.is_empty()) {
                let c = *color;
                a.label(*label).legend(move |(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 18, y + 5)], c.mix(0.18).filled())
                });
            }
        }
        for (k, &m) in marks.iter().enumerate() {
            let a = chart.draw_series(std::iter::once(PathElement::new(
                vec![(m, y0 - pad), (m, y1 + pad)],
                GREY.mix(0.6).stroke_width(1),
            )));
            if k == 0
                && let Ok(a) = a
            {
                a.label("τ control point").legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], GREY.stroke_width(1))
                });
            }
        }
        for s in series {
            let color = s.color;
            if let Ok(a) = chart.draw_series(LineSeries::new(
                s.points
                    .iter()
                    .copied()
                    .filter(|(x, y)| x.is_finite() && y.is_finite()),
                color.stroke_width(2),
            )) {
                a.label(s.label).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
                });
            }
        }
        let _ = chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.3))
            .draw();
        let _ = root.present();
    }
    svg
}

/// Runs of consecutive values of the sorted `frames` as half-open spans `[first, last + 1)`.
fn spans(frames: &[usize]) -> Vec<(usize, usize)> {
    let mut out: Vec<(usize, usize)> = Vec::new();
    for &f in frames {
        match out.last_mut() {
            Some(last) if last.1 == f => last.1 = f + 1,
            _ => out.push((f, f + 1)),
        }
    }
    out
}

fn svg_error(title: &str) -> String {
    format!("<p>plot {title:?} could not be drawn</p>")
}

fn read_frames(dir: &Path) -> Option<Vec<FrameRow>> {
    let mut r = csv::Reader::from_path(dir.join("frames.csv")).ok()?;
    r.deserialize()
        .collect::<std::result::Result<Vec<FrameRow>, _>>()
        .ok()
}

fn read_timewarp(dir: &Path) -> Option<Vec<f64>> {
    let entry = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok())
        .find(|e| e.file_name().to_string_lossy().ends_with(".demo.json"))?;
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(entry.path()).ok()?).ok()?;
    v.get("timewarp")?
        .as_array()?
        .iter()
        .map(|x| x.as_f64())
        .collect()
}

const BLUE: RGBColor = RGBColor(31, 119, 180);
const ORANGE: RGBColor = RGBColor(255, 127, 14);
const GREEN: RGBColor = RGBColor(44, 160, 44);
const GREY: RGBColor = RGBColor(150, 150, 150);

/// The config whose timewarp is least uniform: where the baseline has most to interpolate.
fn showcase(rep: &Reproduction) -> Option<String> {
    rep.runs
        .iter()
        .filter(|r| r.variant.name == "lm_3.5mm" && r.report.error.is_none())
        .max_by(|a, b| {
            a.report
                .metrics
                .timewarp_discrepancy
                .total_cmp(&b.report.metrics.timewarp_discrepancy)
        })
        .map(|r| r.config.clone())
}

fn run_dir(rep: &Reproduction, config: &str, variant: &str) -> Option<std::path::PathBuf> {
    rep.runs
        .iter()
        .find(|r| r.config == config && r.variant.name == variant && r.report.error.is_none())
        .map(|r| r.dir.clone())
}

/// The waypoints of a config as `(t, t_new)`, read from the config file its runs name (empty
/// when it has none or the file does not read).
fn waypoint_frames(rep: &Reproduction, config: &str) -> Vec<(f64, f64)> {
    let path = rep
        .runs
        .iter()
        .find(|r| r.config == config)
        .and_then(|r| r.report.config.clone());
    let Some(json) = path
        .and_then(|p| std::fs::read(p).ok())
        .and_then(|text| serde_json::from_slice::<serde_json::Value>(&text).ok())
    else {
        return Vec::new();
    };
    json.get("waypoints")
        .and_then(|w| w.as_array())
        .map_or_else(Vec::new, |ws| {
            ws.iter()
                .filter_map(|w| Some((w.get("t")?.as_f64()?, w.get("t_new")?.as_f64()?)))
                .collect()
        })
}

/// τ's control points in output frames: the start of the contact segment, every waypoint's
/// `t_new`, and the end of the contact segment.
fn control_points(rep: &Reproduction, config: &str, rows: &[FrameRow]) -> Vec<f64> {
    let in_contact: Vec<usize> = rows
        .iter()
        .filter(|r| r.in_contact)
        .map(|r| r.frame)
        .collect();
    let mut v: Vec<f64> = in_contact.first().map(|&c| c as f64).into_iter().collect();
    v.extend(waypoint_frames(rep, config).iter().map(|w| w.1));
    v.extend(in_contact.last().map(|&c| c as f64));
    v
}

/// How much the retiming stretches the config's most stretched segment: the largest
/// `(τ(b) − τ(a)) / (b − a)` over the segments `[a, b]` between τ's input anchors (the
/// contact segment's ends and the waypoints' `t`), from the contact-IK run's files.
fn max_stretch(rep: &Reproduction, config: &str) -> Option<f64> {
    let dir = run_dir(rep, config, "lm_3.5mm")?;
    let tau = read_timewarp(&dir)?;
    let rows = read_frames(&dir)?;
    let contact: Vec<&FrameRow> = rows.iter().filter(|r| r.in_contact).collect();
    let (c0, c1) = (contact.first()?.source_frame, contact.last()?.source_frame);
    let mut anchors = vec![c0];
    anchors.extend(waypoint_frames(rep, config).iter().map(|w| w.0 as usize));
    anchors.push(c1);
    anchors
        .windows(2)
        .filter(|w| w[1] > w[0] && w[1] < tau.len())
        .map(|w| (tau[w[1]] - tau[w[0]]) / (w[1] - w[0]) as f64)
        .reduce(f64::max)
}

/// The configs of the paper's Fig. "naive": every `*_timewarp_stress*` config, and the config
/// whose retiming stretches one segment the most.
fn naive_configs(rep: &Reproduction) -> Vec<String> {
    let configs = tables::configs(rep);
    let mut out: Vec<String> = configs
        .iter()
        .filter(|c| c.contains("_timewarp_stress"))
        .cloned()
        .collect();
    let most = configs
        .iter()
        .filter_map(|c| Some((c, max_stretch(rep, c)?)))
        .max_by(|a, b| a.1.total_cmp(&b.1));
    if let Some((c, _)) = most
        && !out.contains(c)
    {
        out.push(c.clone());
    }
    out
}

/// Output frames where the simulated object is off its plan by more than the drop limit
/// (30 mm) or by more than the mean rotation limit (15°): where a hand is losing the object.
fn failing_frames(rows: &[FrameRow]) -> Vec<usize> {
    let p = crate::physics::Params::default();
    rows.iter()
        .filter(|r| {
            r.physics_position_error_mm
                .is_some_and(|e| e > p.drop_error_m * 1e3)
                || r.physics_rotation_error_deg
                    .is_some_and(|e| e > p.max_mean_rotation_error_deg)
        })
        .map(|r| r.frame)
        .collect()
}

/// Object height, baseline wrist and contact-IK wrist height over output time, τ's control
/// points marked, the frames where the object is off its plan shaded per hand; with the
/// number of shaded frames of the baseline and of contact IK.
fn heights_chart(
    rep: &Reproduction,
    c: &str,
    lm: &[FrameRow],
    base: &[FrameRow],
) -> (String, usize, usize) {
    let marks = control_points(rep, c, lm);
    let z = |rows: &[FrameRow], f: fn(&FrameRow) -> f64| -> Vec<(f64, f64)> {
        rows.iter().map(|r| (r.frame as f64, f(r))).collect()
    };
    let shaded = [
        (
            failing_frames(base),
            ORANGE,
            "object off its plan, baseline",
        ),
        (failing_frames(lm), BLUE, "object off its plan, contact IK"),
    ];
    let svg = line_chart_shaded(
        &format!("object and wrist height: {c}"),
        "output frame",
        "z [m]",
        &[
            Series {
                label: "object",
                color: GREY,
                points: z(lm, |r| r.object_z),
            },
            Series {
                label: "wrist, baseline",
                color: ORANGE,
                points: z(base, |r| r.wrist_z),
            },
            Series {
                label: "wrist, contact IK",
                color: BLUE,
                points: z(lm, |r| r.wrist_z),
            },
        ],
        &marks,
        &shaded,
    );
    let (nb, nl) = (shaded[0].0.len(), shaded[1].0.len());
    (svg, nb, nl)
}

/// The paper's Fig. "naive" for each of [`naive_configs`]: object height, baseline wrist and
/// contact-IK wrist height over output time, τ's control points marked, the frames where
/// the object is off its plan with either hand shaded (orange: the baseline, blue: contact
/// IK), each also written as `figures/naive_<config>.svg` beside the page.
fn naive_plots(rep: &Reproduction, out: &mut Vec<(String, String)>) {
    for c in naive_configs(rep) {
        let lm = run_dir(rep, &c, "lm_3.5mm").and_then(|d| read_frames(&d));
        let base = run_dir(rep, &c, "baseline").and_then(|d| read_frames(&d));
        let (Some(lm), Some(base)) = (lm, base) else {
            continue;
        };
        let (svg, nb, nl) = heights_chart(rep, &c, &lm, &base);
        let file = rep.out.join("figures").join(format!("naive_{c}.svg"));
        let _ = std::fs::create_dir_all(rep.out.join("figures"));
        let _ = write_atomic(&file, svg.as_bytes());
        out.push((
            format!(
                "Fig. \"naive\": heights over output time, baseline against contact IK ({c}; shaded: the {nb} frames with the baseline and the {nl} with contact IK where the simulated object is over 30 mm or 15° off its plan)"
            ),
            svg,
        ));
    }
}

/// The page's figures, each with its caption: the timewarp, the showcase's heights, D_C and
/// tracking error, the robustness curves and the naive figures.
fn plots(rep: &Reproduction) -> Vec<(String, String)> {
    let mut out = Vec::new();
    timewarp_plot(rep, &mut out);
    showcase_plots(rep, &mut out);
    robustness_plot(rep, &mut out);
    naive_plots(rep, &mut out);
    out
}

/// τ of `allegro_apple_plate` (else the showcase) with contact IK, against a uniform retiming.
fn timewarp_plot(rep: &Reproduction, out: &mut Vec<(String, String)>) {
    let tw_config = ["allegro_apple_plate"]
        .into_iter()
        .map(String::from)
        .find(|c| run_dir(rep, c, "lm_3.5mm").is_some())
        .or_else(|| showcase(rep));
    if let Some(c) = tw_config
        && let Some(tau) = run_dir(rep, &c, "lm_3.5mm").and_then(|d| read_timewarp(&d))
    {
        let n = tau.len();
        out.push((
            format!("Timewarp of {c}"),
            line_chart(
                &format!("timewarp τ: {c}"),
                "input frame",
                "output frame",
                &[
                    Series {
                        label: "τ(input frame)",
                        color: BLUE,
                        points: tau
                            .iter()
                            .enumerate()
                            .map(|(i, &t)| (i as f64, t))
                            .collect(),
                    },
                    Series {
                        label: "uniform",
                        color: GREY,
                        points: vec![(0.0, 0.0), ((n - 1) as f64, *tau.last().unwrap_or(&0.0))],
                    },
                ],
            ),
        ));
    }
}

/// The showcase's heights, per-frame D_C and physics tracking error, baseline against
/// contact IK.
fn showcase_plots(rep: &Reproduction, out: &mut Vec<(String, String)>) {
    if let Some(c) = showcase(rep) {
        let lm = run_dir(rep, &c, "lm_3.5mm").and_then(|d| read_frames(&d));
        let base = run_dir(rep, &c, "baseline").and_then(|d| read_frames(&d));
        if let (Some(lm), Some(base)) = (lm, base) {
            let col = |rows: &[FrameRow], f: fn(&FrameRow) -> Option<f64>| -> Vec<(f64, f64)> {
                rows.iter()
                    .filter_map(|r| f(r).map(|v| (r.frame as f64, v)))
                    .collect()
            };
            out.push((
                format!("Heights over time, baseline against contact IK ({c})"),
                heights_chart(rep, &c, &lm, &base).0,
            ));
            out.push((
                format!("Per-frame D_C ({c})"),
                line_chart(
                    &format!("contact distance per frame: {c}"),
                    "output frame",
                    "D_C [mm]",
                    &[
                        Series {
                            label: "baseline",
                            color: ORANGE,
                            points: col(&base, |r| r.d_c_mm),
                        },
                        Series {
                            label: "contact IK (3.5 mm)",
                            color: BLUE,
                            points: col(&lm, |r| r.d_c_mm),
                        },
                    ],
                ),
            ));
            let track_lm = col(&lm, |r| r.physics_position_error_mm);
            let track_base = col(&base, |r| r.physics_position_error_mm);
            if !track_lm.is_empty() || !track_base.is_empty() {
                out.push((
                    format!("Physics tracking error ({c})"),
                    line_chart(
                        &format!("simulated vs warped object position: {c}"),
                        "output frame",
                        "error [mm]",
                        &[
                            Series {
                                label: "baseline",
                                color: ORANGE,
                                points: track_base,
                            },
                            Series {
                                label: "contact IK",
                                color: BLUE,
                                points: track_lm,
                            },
                        ],
                    ),
                ));
            }
        }
    }
}

/// D_C of [`ROBUSTNESS_CONFIG`] against the share of correspondences deleted or permuted.
fn robustness_plot(rep: &Reproduction, out: &mut Vec<(String, String)>) {
    let curve = |kind: &str| -> Vec<(f64, f64)> {
        (0..=100)
            .step_by(10)
            .filter_map(|pct| {
                rep.runs
                    .iter()
                    .find(|r| {
                        r.config == ROBUSTNESS_CONFIG
                            && r.variant.name == format!("robust_{kind}_{pct:03}")
                            && r.report.error.is_none()
                    })
                    .and_then(|r| r.report.metrics.d_c_mm.uncorrupted.map(|d| (pct as f64, d)))
            })
            .collect()
    };
    let (del, per) = (curve("delete"), curve("permute"));
    if !del.is_empty() {
        out.push((
            format!("Robustness ({ROBUSTNESS_CONFIG})"),
            line_chart(
                &format!("robustness: {ROBUSTNESS_CONFIG}"),
                "corrupted correspondences [%]",
                "D_C [mm]",
                &[
                    Series {
                        label: "deleted",
                        color: GREEN,
                        points: del,
                    },
                    Series {
                        label: "permuted",
                        color: ORANGE,
                        points: per,
                    },
                ],
            ),
        ));
    }
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

fn html_table(t: &Table) -> String {
    let mut s = format!("<h3>{}</h3>\n<table>\n<tr>", escape(&t.title));
    for h in &t.header {
        s.push_str(&format!("<th>{}</th>", escape(h)));
    }
    s.push_str("</tr>\n");
    for r in &t.rows {
        s.push_str("<tr>");
        for c in r {
            let c = c.trim_matches('*');
            s.push_str(&format!("<td>{}</td>", escape(c)));
        }
        s.push_str("</tr>\n");
    }
    s.push_str("</table>\n");
    if !t.note.is_empty() {
        s.push_str(&format!("<p class=\"note\">{}</p>\n", escape(&t.note)));
    }
    s
}

/// The player's trajectories: contact IK (LM, 3.5 mm) of every config, and the baseline of
/// the showcase config; their data scripts written into `player/`.
fn player_entries(rep: &Reproduction, limits: &crate::Limits) -> Result<Vec<crate::player::Entry>> {
    use rayon::prelude::*;
    let showcase = showcase(rep);
    let runs: Vec<&super::RunRecord> = rep
        .runs
        .iter()
        .filter(|r| r.report.error.is_none())
        .filter(|r| {
            r.variant.name == "lm_3.5mm"
                || (r.variant.name == "baseline" && Some(&r.config) == showcase.as_ref())
        })
        .collect();
    let built: Vec<_> = runs
        .par_iter()
        .map_init(crate::player::data::Cache::default, |cache, r| {
            let id = format!("{}/{}", r.config, r.variant.name);
            let verdict = r
                .report
                .physics
                .as_ref()
                .map_or("not run", |p| p.verdict.as_str());
            let entry = crate::player::Entry {
                label: format!("{id} ({verdict})"),
                src: format!("player/reproduce-{}-{}.js", r.config, r.variant.name),
                id: id.clone(),
            };
            let data = crate::player::data::trajectory(&r.dir, &r.report, &id, cache, limits);
            (entry, data)
        })
        .collect();
    let (ok, _) = crate::player::write_scripts(&rep.out.join("player"), "reproduce-", built)?;
    Ok(ok)
}

/// Writes `index.html` (and the player's data in `player/`) into the reproduction's folder.
pub fn write_index(rep: &Reproduction, limits: &crate::Limits) -> Result<()> {
    let mut body = String::new();
    body.push_str(&format!(
        "<h1>dexwarp reproduce</h1>\n<p class=\"prov\">{}</p>\n",
        escape(&tables::provenance(rep))
    ));
    body.push_str(&crate::player::section(&player_entries(rep, limits)?));
    body.push_str("<h2>Plots</h2>\n");
    for (title, svg) in plots(rep) {
        body.push_str(&format!(
            "<figure><figcaption>{}</figcaption>\n{svg}\n</figure>\n",
            escape(&title)
        ));
    }
    body.push_str("<h2>Tables</h2>\n");
    for t in tables::all(rep) {
        body.push_str(&html_table(&t));
    }
    let page = format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>dexwarp reproduce</title>\n<style>\nbody {{ font-family: sans-serif; margin: 2em auto; max-width: 1100px; color: #222; }}\ntable {{ border-collapse: collapse; margin: 0.5em 0 1.5em; font-size: 0.9em; }}\nth, td {{ border: 1px solid #ccc; padding: 3px 8px; text-align: right; }}\nth:first-child, td:first-child {{ text-align: left; }}\nfigure {{ margin: 1em 0; }}\nfigcaption {{ font-weight: bold; margin-bottom: 0.3em; }}\n.prov, .note {{ color: #555; font-size: 0.9em; }}\n{}</style>\n</head>\n<body>\n{body}</body>\n</html>\n",
        crate::player::STYLE
    );
    let path = rep.out.join("index.html");
    write_atomic(&path, page.as_bytes()).map_err(|e| match e {
        Error::Io { source, .. } => Error::write(&path, source),
        other => other,
    })
}
