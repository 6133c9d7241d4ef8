//! The robustness margin in reports (`--margin`) and `filter --robust`.

use serde_json::Value;

use crate::fixtures::{dexwarp, repo, stderr};

fn read(p: &std::path::Path) -> Value {
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

/// `validate --margin` (as `warp --margin`) writes the margin and the robust flag; the margin's nominal condition is
/// the nominal replay itself (same verdict), every condition is listed, and `robust` is
/// exactly "every condition passed". `filter --robust` keeps an item only when it is, and
/// says why otherwise (also for a report written without a margin).
#[test]
fn margin_is_reported_and_filter_keeps_only_robust_passes() {
    let dir = tempfile::tempdir().unwrap();
    let demo = repo("scenes/demos/cube.demo.json");
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let with = dir.path().join("runs/with");
    let without = dir.path().join("runs/without");
    for (out, extra) in [(&with, vec!["--margin"]), (&without, vec![])] {
        let (out_s, demo_s) = (s(out), s(&demo));
        let mut args = vec!["validate", &demo_s, "--out", &out_s];
        args.extend(extra);
        let o = dexwarp(&args);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let r = read(&with.join("report.json"));
    let p = &r["physics"];
    assert_eq!(p["verdict"], "pass", "{p}");
    let m = &p["margin"];
    let conditions = m["conditions"].as_array().unwrap();
    assert_eq!(conditions.len(), 6, "{m}");
    assert_eq!(conditions[0]["friction_scale"], 1.0);
    assert_eq!(conditions[0]["mass_scale"], 1.0);
    assert_eq!(conditions[0]["passed"], true);
    let all = conditions.iter().all(|c| c["passed"] == true);
    assert_eq!(m["robust"], all);
    assert_eq!(p["robust"], all);
    assert!(
        m["sentence"]
            .as_str()
            .unwrap()
            .starts_with("holds down to μ = "),
        "{m}"
    );
    assert!(p["timing_s"]["margin"].as_f64().unwrap() > 0.0);
    // Without --margin: the fields are there, null.
    let r0 = read(&without.join("report.json"));
    assert!(r0["physics"]["margin"].is_null() && r0["physics"]["robust"].is_null());
    // The nominal figures do not depend on whether the margin was measured.
    assert_eq!(r["physics"]["tracking"], r0["physics"]["tracking"]);

    let keep = dir.path().join("keep.csv");
    let o = dexwarp(&[
        "filter",
        &s(&dir.path().join("runs")),
        "--out",
        &s(&keep),
        "--robust",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let kept = std::fs::read_to_string(&keep).unwrap();
    let dropped = std::fs::read_to_string(dir.path().join("keep.dropped.csv")).unwrap();
    assert!(
        dropped.contains("no robustness margin in the report; write it with --margin"),
        "{dropped}"
    );
    if all {
        assert!(kept.contains("with"), "{kept}");
    } else {
        assert!(dropped.contains("not robust: holds down to"), "{dropped}");
    }

    // The HTML report shows the margin of the run that has one, `-` for the other.
    let page = dir.path().join("page.html");
    let o = dexwarp(&["report", &s(&dir.path().join("runs")), "--out", &s(&page)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let html = std::fs::read_to_string(&page).unwrap();
    let sentence = m["sentence"].as_str().unwrap();
    let shown = if all {
        format!("<td>robust: {sentence}</td>")
    } else {
        format!("<td>{sentence}</td>")
    };
    assert!(html.contains(&shown), "{shown} is not in the page's table");
    assert!(html.contains("<th>margin</th>"));
}
