//! `reproduce` on a one-config scene folder: the tables and `index.html` are written, and the
//! page renders in a real headless browser with its tables and plots.

use std::path::Path;
use std::process::Command;

use dexwarp::reproduce::{ReproduceOptions, run};

use crate::fixtures::gripper_fixture;

/// Headless Chromium's rendered DOM of `page`.
fn rendered_dom(page: &Path, profile: &Path) -> Option<String> {
    let out = Command::new("chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-first-run",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg("--dump-dom")
        .arg(format!("file://{}", page.display()))
        .output()
        .ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).into_owned())
}

#[test]
fn reproduce_writes_tables_and_a_page_that_renders() {
    let root = tempfile::tempdir().unwrap();
    let configs = root.path().join("scenes/configs");
    std::fs::create_dir_all(&configs).unwrap();
    let config = gripper_fixture(root.path());
    std::fs::rename(&config, configs.join("box_lift.json")).unwrap();
    // Paths in the config are relative to it: point them back at the fixture files.
    let text = std::fs::read_to_string(configs.join("box_lift.json"))
        .unwrap()
        .replace("\"box.demo.json\"", "\"../../box.demo.json\"")
        .replace("\"scene.json\"", "\"../../scene.json\"");
    std::fs::write(configs.join("box_lift.json"), text).unwrap();
    let out = root.path().join("report");
    let rep = run(&ReproduceOptions {
        out: out.clone(),
        root: root.path().to_path_buf(),
        quick: true,
        jobs: 2,
        physics: dexwarp::pipeline::PhysicsOptions::default(),
        limits: dexwarp::Limits::default(),
        progress: false,
        all_demos: false,
    })
    .unwrap();
    // Three LM thresholds on each objective, Adam and the baseline for the one config.
    assert_eq!(
        rep.runs.len(),
        8,
        "{:?}",
        rep.runs.iter().map(|r| &r.variant.name).collect::<Vec<_>>()
    );
    for r in &rep.runs {
        assert!(
            r.report.error.is_none(),
            "{}: {:?}",
            r.variant.name,
            r.report.error
        );
        assert!(r.dir.join("report.json").is_file() && r.dir.join("frames.csv").is_file());
        // The warped demonstration is kept for the compared runs only (what export and the
        // player use); the others feed the tables from their reports.
        let compared = ["lm_3.5mm", "baseline"].contains(&r.variant.name.as_str());
        assert_eq!(
            r.dir.join("box_lift.demo.json").is_file(),
            compared,
            "{}",
            r.variant.name
        );
    }
    for t in [
        "table1_dwo",
        "table3_dc",
        "table4_runtime",
        "table5_plr_timewarp",
        "baseline_comparison",
        "physics_verdicts",
    ] {
        let md = std::fs::read_to_string(out.join(format!("tables/{t}.md"))).unwrap();
        assert!(md.contains("box_lift"), "{t}: {md}");
        assert!(out.join(format!("tables/{t}.csv")).is_file());
    }
    // The compared runs (contact IK at 3.5 mm and the baseline), and only they, carry their
    // robustness margin (how the table words it: `tables::tests`); a run without a nominal
    // pass has none to name.
    let mut margins = 0;
    for r in &rep.runs {
        let margin = r
            .report
            .physics
            .as_ref()
            .and_then(|p| p.measures.get("margin"))
            .filter(|m| !m.is_null());
        let compared = ["lm_3.5mm", "baseline"].contains(&r.variant.name.as_str());
        assert_eq!(margin.is_some(), compared, "{}", r.variant.name);
        if let Some(m) = margin {
            margins += 1;
            let passed = r.report.physics.as_ref().unwrap().verdict == "pass";
            assert_eq!(m["weakest"].is_array(), passed, "{}: {m}", r.variant.name);
        }
    }
    assert_eq!(margins, 2);
    // The comparison table's onset columns: each hand's object error at its first contact
    // frame, as its report gives it.
    let csv = std::fs::read_to_string(out.join("tables/baseline_comparison.csv")).unwrap();
    let head: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let row: Vec<&str> = csv
        .lines()
        .find(|l| l.starts_with("box_lift,"))
        .unwrap()
        .split(',')
        .collect();
    for (column, variant) in [
        ("onset baseline [mm]", "baseline"),
        ("onset contact IK [mm]", "lm_3.5mm"),
    ] {
        let k = head.iter().position(|h| *h == column).unwrap();
        let run = rep.runs.iter().find(|r| r.variant.name == variant).unwrap();
        let onset = run
            .report
            .physics
            .as_ref()
            .unwrap()
            .onset_error_mm()
            .unwrap();
        assert!(onset.is_finite() && onset >= 0.0, "{column}: {onset}");
        assert_eq!(row[k], format!("{onset:.1}"), "{column}");
    }
    let page = out.join("index.html");
    let html = std::fs::read_to_string(&page).unwrap();
    // Nothing is loaded from the network: the only URL allowed is the SVG namespace name.
    let outside = html.replace("http://www.w3.org/2000/svg", "");
    assert!(
        !outside.contains("http://") && !outside.contains("https://"),
        "the page must not load anything from the network"
    );
    // The player's data: contact IK at 3.5 mm of the config, and its baseline (the showcase).
    for f in [
        "reproduce-box_lift-lm_3.5mm.js",
        "reproduce-box_lift-baseline.js",
    ] {
        assert!(out.join("player").join(f).is_file(), "player/{f} missing");
    }
    assert!(html.contains("id=\"player\""), "the page has no player");
    // The paper's Fig. "naive" of the config with the most stretched segment (the only one
    // here), on the page and as a file.
    let naive = std::fs::read_to_string(out.join("figures/naive_box_lift.svg")).unwrap();
    assert!(naive.contains("<svg") && naive.contains("wrist, baseline"));
    assert!(
        html.contains("Fig. \"naive\""),
        "the page has no Fig. naive"
    );
    // `dexwarp report` on the same folder keeps reproduce's page and writes report.html.
    let o = crate::fixtures::dexwarp(&["report", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", crate::fixtures::stderr(&o));
    let report_page = out.join("report.html");
    assert!(report_page.is_file());
    if crate::player::have_chromium() {
        crate::player::check_player(&page, "box_lift/lm_3.5mm");
        crate::player::check_player(&report_page, "runs/box_lift/baseline");
    }
    // Render it in a real browser (CI installs Debian's chromium; see .ci/run).
    let profile = tempfile::tempdir().unwrap();
    let Some(dom) = rendered_dom(&page, profile.path()) else {
        // Required in CI (.ci/run installs chromium); a notice elsewhere, so `cargo test`
        // passes on a fresh machine without a browser.
        assert!(
            std::env::var_os("CI").is_none(),
            "headless chromium must be installed to check the report (apt-get install chromium)"
        );
        eprintln!("note: chromium not found; the rendered-page checks of the report were skipped");
        return;
    };
    let tables = dom.matches("<table").count();
    let svgs = dom.matches("<svg").count();
    assert!(
        tables >= 7,
        "rendered page has {tables} tables, expected the 7 report tables"
    );
    assert!(
        svgs >= 3,
        "rendered page has {svgs} SVG plots, expected at least 3"
    );
    assert!(dom.contains("Table 1: D_WO"), "rendered page lacks Table 1");
}
