//! `dexwarp report` and its 3D player: the page of a batch renders in headless Chromium (the
//! player draws, a frame change changes the picture, the slider moves time, no console
//! errors), and `--compare` reports exactly what changed between two runs, with the exit
//! status a nightly job can gate on. The browser checks skip with a notice when Chromium is
//! absent, unless `CI` is set (`.ci/run` installs it).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::fixtures::{dexwarp, repo, stderr};

/// Headless Chromium on `url` with `args`; `None` when there is no browser.
fn chromium(url: &str, args: &[String]) -> Option<Output> {
    let profile = tempfile::tempdir().ok()?;
    let out = Command::new("chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-first-run",
            "--enable-logging=stderr",
            "--v=0",
            "--hide-scrollbars",
        ])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .args(args)
        .arg(url)
        .output()
        .ok()?;
    out.status.success().then_some(out)
}

/// True when the browser checks can run; otherwise prints the notice (and fails in CI).
pub fn have_chromium() -> bool {
    let ok = Command::new("chromium")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        assert!(
            std::env::var_os("CI").is_none(),
            "headless chromium must be installed to check the report pages (apt-get install chromium)"
        );
        eprintln!("note: chromium not found; the player's browser checks were skipped");
    }
    ok
}

/// The `data-*` attribute `name` of the rendered `<body>`.
fn body_attr(dom: &str, name: &str) -> Option<String> {
    let body = &dom[dom.find("<body")?..];
    let body = &body[..body.find('>')?];
    let key = format!("{name}=\"");
    let start = body.find(&key)? + key.len();
    Some(body[start..][..body[start..].find('"')?].replace("&gt;", ">"))
}

/// Opens `page` at trajectory `id` in headless Chromium and checks the player: it draws
/// (a fair share of the canvas is not background), the slider moves time and the picture,
/// screenshots at two frames differ, and the console stays empty.
pub fn check_player(page: &Path, id: &str) {
    let url = |frag: &str| format!("file://{}#play={id}&{frag}", page.display());
    let Some(out) = chromium(
        &url("frame=5&selftest=1"),
        &["--dump-dom".into(), "--virtual-time-budget=10000".into()],
    ) else {
        panic!("chromium could not open {}", page.display());
    };
    let dom = String::from_utf8_lossy(&out.stdout);
    let log = String::from_utf8_lossy(&out.stderr);
    let console: Vec<&str> = log.lines().filter(|l| l.contains(":CONSOLE")).collect();
    assert!(
        console.is_empty(),
        "console messages on {}: {console:#?}",
        page.display()
    );
    assert_eq!(
        body_attr(&dom, "data-player-errors"),
        None,
        "player errors on {}",
        page.display()
    );
    assert_eq!(body_attr(&dom, "data-player-id").as_deref(), Some(id));
    let ink: usize = body_attr(&dom, "data-player-ink")
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("the player did not draw on {}", page.display()));
    // The canvas is 960 x 540: the scene, hand and object cover far more than 5 % of it.
    assert!(ink > 960 * 540 / 20, "only {ink} pixels drawn");
    let selftest = body_attr(&dom, "data-player-selftest").unwrap_or_default();
    assert!(
        selftest.starts_with("ok"),
        "slider self-test on {}: {selftest:?}",
        page.display()
    );
    let shots = tempfile::tempdir().unwrap();
    let shot = |frame: usize| -> Vec<u8> {
        let png = shots.path().join(format!("f{frame}.png"));
        chromium(
            &url(&format!("frame={frame}&only=1")),
            &[
                format!("--screenshot={}", png.display()),
                "--window-size=1000,760".into(),
                "--virtual-time-budget=10000".into(),
            ],
        )
        .expect("screenshot");
        std::fs::read(&png).expect("screenshot written")
    };
    let (a, b) = (shot(2), shot(40));
    assert!(
        a.len() > 20_000,
        "screenshot is {} bytes: blank page?",
        a.len()
    );
    assert_ne!(a, b, "screenshots at frames 2 and 40 are identical");
}

fn manifest(dir: &Path, name: &str, b_item: &str) -> PathBuf {
    manifest_with(dir, name, &repo("scenes/configs/cube_messy2.json"), b_item)
}

/// As [`manifest`], with item b's config at `b_config`.
fn manifest_with(dir: &Path, name: &str, b_config: &Path, b_item: &str) -> PathBuf {
    let config = |c: &str| {
        repo(&format!("scenes/configs/{c}.json"))
            .display()
            .to_string()
    };
    let path = dir.join(name);
    std::fs::write(
        &path,
        format!(
            "{{\"config\": {:?}, \"name\": \"a\"}}\n{{\"config\": {:?}, {b_item}, \"name\": \"b\"}}\n",
            config("mug_pass_wall"),
            b_config.display().to_string(),
        ),
    )
    .unwrap();
    path
}

fn batch(manifest: &Path, out: &Path) {
    let o = dexwarp(&[
        "batch",
        manifest.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--jobs",
        "2",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn report_of_a_batch_renders_and_compare_reports_exactly_the_change() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    // cube_messy2 passes with the baseline hand and fails with per-frame contact IK on the
    // paper's objective at 3.5 mm (its smoothed hand presses 14.7 mm into the cube at frame 410;
    // README, Results).
    let same = manifest(t, "same.jsonl", "\"hand\": \"baseline\"");
    let changed = manifest_with(
        t,
        "changed.jsonl",
        &paper_objective_copy(t, "cube_messy2"),
        "\"threshold_mm\": 3.5",
    );
    let (first, second, third) = (t.join("first"), t.join("second"), t.join("third"));
    batch(&same, &first);
    batch(&same, &second);
    batch(&changed, &third);

    let o = dexwarp(&["report", first.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let page = first.join("index.html");
    let html = std::fs::read_to_string(&page).unwrap();
    // The only URL allowed is the SVG namespace name.
    let outside = html.replace("http://www.w3.org/2000/svg", "");
    assert!(
        !outside.contains("http://") && !outside.contains("https://"),
        "the page must not load anything from the network"
    );
    for id in ["a", "b"] {
        assert!(
            html.contains(&format!("href=\"#play={id}\"")),
            "no player link for {id}"
        );
    }
    assert_eq!(
        std::fs::read_dir(first.join("player")).unwrap().count(),
        2,
        "one data script per trajectory"
    );

    // Identical runs: nothing to report, exit 0.
    let o = dexwarp(&[
        "report",
        second.to_str().unwrap(),
        "--compare",
        first.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let md = std::fs::read_to_string(second.join("compare.md")).unwrap();
    assert!(md.contains("No change beyond the tolerances"), "{md}");
    assert!(md.contains("2 items matched"), "{md}");

    // One item changed to fail: exactly that item is reported, with its verdict flip, and
    // the exit status says something got worse.
    let o = dexwarp(&[
        "report",
        third.to_str().unwrap(),
        "--compare",
        first.to_str().unwrap(),
    ]);
    assert!(!o.status.success(), "a regression must fail the command");
    assert!(stderr(&o).contains("worse"), "{}", stderr(&o));
    let md = std::fs::read_to_string(third.join("compare.md")).unwrap();
    let rows: Vec<&str> = md
        .lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("| item"))
        .collect();
    assert!(!rows.is_empty(), "{md}");
    assert!(
        rows.iter().all(|r| r.starts_with("| b |")),
        "only item b changed:\n{md}"
    );
    assert!(
        rows.iter()
            .any(|r| r.contains("| verdict | pass -> fail") && r.ends_with("| **yes** |")),
        "{md}"
    );
    let html = std::fs::read_to_string(third.join("index.html")).unwrap();
    let (top, players) = (html.find("id=\"compare\""), html.find("id=\"player\""));
    assert!(
        top.is_some() && top < players,
        "the comparison is at the top of the page"
    );

    if have_chromium() {
        check_player(&page, "a");
    }
}

#[test]
fn report_refuses_a_missing_folder_and_keeps_other_pages() {
    let o = dexwarp(&["report", "/nonexistent/outputs"]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("/nonexistent/outputs"),
        "{}",
        stderr(&o)
    );
    // A folder whose index.html another command wrote keeps it: the report goes beside it.
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("index.html"), "<p>augment page</p>").unwrap();
    let o = dexwarp(&["report", tmp.path().to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(tmp.path().join("index.html")).unwrap(),
        "<p>augment page</p>"
    );
    assert!(tmp.path().join("report.html").is_file());
}

/// A copy of a built-in config with the paper's method (its objective, a per-frame grasp) and
/// absolute paths.
fn paper_objective_copy(dir: &Path, name: &str) -> PathBuf {
    let src = repo(&format!("scenes/configs/{name}.json"));
    let mut c: serde_json::Value = serde_json::from_slice(&std::fs::read(&src).unwrap()).unwrap();
    for key in ["demo", "scene"] {
        let rel = c[key].as_str().unwrap().to_string();
        c[key] = src.parent().unwrap().join(rel).display().to_string().into();
    }
    c["params"]["objective"] = "paper".into();
    // The paper's method: each frame keeps its own IK solution (the default holds one grasp).
    c["params"]["grasp"] = "per_frame".into();
    let path = dir.join(format!("{name}_paper.json"));
    std::fs::write(&path, serde_json::to_vec_pretty(&c).unwrap()).unwrap();
    path
}

#[test]
fn warp_ends_with_the_verdict_and_its_first_reason() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("w");
    let config = paper_objective_copy(tmp.path(), "cube_messy2");
    let o = dexwarp(&[
        "warp",
        "--config",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    let last = err.lines().last().unwrap_or_default();
    assert!(
        last.starts_with("verdict: fail (hand-object penetration"),
        "last line: {last:?}"
    );
    let demo = out.join("cube_messy2.demo.json");
    let o = dexwarp(&[
        "validate",
        demo.to_str().unwrap(),
        "--out",
        tmp.path().join("v").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    let last = err.lines().last().unwrap_or_default();
    assert!(last.starts_with("verdict: "), "last line: {last:?}");
    // A report over both folders: the validate output plays its own demonstration.
    let o = dexwarp(&["report", tmp.path().to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let html = std::fs::read_to_string(tmp.path().join("index.html")).unwrap();
    for id in ["v", "w"] {
        assert!(
            html.contains(&format!("href=\"#play={id}\"")),
            "no player for {id}"
        );
    }
}

/// The committed `reproduce` page, `reports/latest/index.html`, carries the player with its
/// data scripts in `reports/latest/player/`, and it plays in the browser.
#[test]
fn the_committed_reproduce_page_plays() {
    let page = repo("reports/latest/index.html");
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(
        html.contains("id=\"player\"")
            && html.contains("player/reproduce-teapot_pour_cups-lm_3.5mm.js"),
        "reports/latest/index.html has no player for teapot_pour_cups"
    );
    if have_chromium() {
        check_player(&page, "teapot_pour_cups/lm_3.5mm");
    }
}
