//! The ensemble verdict end to end: `validate` writes `physics.ensemble`, the same seed gives
//! the same report, another seed other draws, and `filter --min-pass-fraction` and
//! `--exclude-uncertain` decide on it. (The pass fractions of built trajectories, firm, open
//! and at the edge, are in `physics.rs`.)

use serde_json::Value;

use crate::fixtures::{dexwarp, repo, stderr};

fn read(p: &std::path::Path) -> Value {
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

fn validate(demo: &str, out: &std::path::Path, extra: &[&str]) -> Value {
    let demo = repo(demo);
    let mut args = vec![
        "validate",
        demo.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(extra);
    let o = dexwarp(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    read(&out.join("report.json"))
}

/// The report without its wall times.
fn timeless(mut r: Value) -> Value {
    r["timing_s"] = Value::Null;
    r["physics"]["timing_s"] = Value::Null;
    r["physics"]["replay"]["decomposition_cached"] = Value::Null;
    r
}

#[test]
fn ensemble_reports_are_seeded_and_filter_decides_on_them() {
    let dir = tempfile::tempdir().unwrap();
    let runs = dir.path().join("runs");
    let teapot = "scenes/demos/teapot.demo.json";
    let a = validate(teapot, &runs.join("teapot"), &[]);
    let e = &a["physics"]["ensemble"];
    println!("{e}");
    assert_eq!(e["members"], 8, "{e}");
    let (passed, replayed) = (
        e["passed"].as_u64().unwrap(),
        e["replayed"].as_u64().unwrap(),
    );
    let members = e["member"].as_array().unwrap();
    assert_eq!(members.len() as u64, replayed);
    assert_eq!(
        members.iter().filter(|m| m["passed"] == true).count() as u64,
        passed
    );
    let fraction = e["pass_fraction"].as_f64().unwrap();
    assert_eq!(fraction, passed as f64 / replayed as f64);
    let kept = e["decision"] == "keep";
    assert_eq!(kept, fraction >= 0.5);
    assert_eq!(a["physics"]["verdict"], if kept { "pass" } else { "fail" });
    let [lo, hi] = [
        e["interval"][0].as_f64().unwrap(),
        e["interval"][1].as_f64().unwrap(),
    ];
    assert_eq!(e["uncertain"], lo < 0.5 && 0.5 < hi, "{e}");

    // The same seed: the same report, wall times aside. Another seed: other draws.
    let again = validate(teapot, &dir.path().join("again"), &[]);
    assert_eq!(timeless(a.clone()), timeless(again));
    let other = validate(teapot, &dir.path().join("other"), &["--ensemble-seed", "2"]);
    let draws = |r: &Value| r["physics"]["ensemble"]["member"][1]["draw"].clone();
    assert_ne!(draws(&a), draws(&other));
    assert_eq!(other["physics"]["ensemble"]["seed"], 2);
    // The nominal member is the same replay whatever the seed.
    assert_eq!(a["physics"]["tracking"], other["physics"]["tracking"]);

    // A firm grasp (the cube), and a single replay of it.
    let cube = validate("scenes/demos/cube.demo.json", &runs.join("cube"), &[]);
    assert_eq!(cube["physics"]["ensemble"]["pass_fraction"], 1.0);
    let single = validate(
        "scenes/demos/cube.demo.json",
        &runs.join("single"),
        &["--ensemble", "1"],
    );
    assert!(single["physics"]["ensemble"].is_null());
    assert_eq!(single["physics"]["tracking"], cube["physics"]["tracking"]);

    let filter = |extra: &[&str]| -> (String, String) {
        let keep = dir.path().join("keep.csv");
        let mut args = vec![
            "filter",
            runs.to_str().unwrap(),
            "--out",
            keep.to_str().unwrap(),
        ];
        args.extend(extra);
        let o = dexwarp(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        (
            std::fs::read_to_string(&keep).unwrap(),
            std::fs::read_to_string(dir.path().join("keep.dropped.csv")).unwrap(),
        )
    };
    let line = |csv: &str, name: &str| csv.lines().any(|l| l.contains(&format!("runs/{name}/")));

    let (kept_csv, _) = filter(&[]);
    assert!(
        line(&kept_csv, "cube") && line(&kept_csv, "single"),
        "{kept_csv}"
    );
    assert_eq!(line(&kept_csv, "teapot"), kept, "{kept_csv}");

    let (kept_csv, dropped) = filter(&["--exclude-uncertain"]);
    assert!(line(&kept_csv, "cube"), "{kept_csv}");
    assert!(line(&dropped, "single") && dropped.contains("no ensemble in the report"));
    if e["uncertain"] == true {
        assert!(line(&dropped, "teapot") && dropped.contains("uncertain: the pass fraction"));
    } else {
        assert_eq!(line(&kept_csv, "teapot"), kept, "{kept_csv}");
    }

    let (kept_csv, dropped) = filter(&["--min-pass-fraction", "0.9"]);
    assert!(line(&kept_csv, "cube"), "{kept_csv}");
    assert!(line(&dropped, "single"), "{dropped}");
    assert_eq!(
        line(&kept_csv, "teapot"),
        fraction >= 0.9,
        "{kept_csv}\n{dropped}"
    );
    if fraction < 0.9 {
        assert!(dropped.contains("physics: pass fraction"), "{dropped}");
    }
}

/// A copy of built-in demonstration `name` in `dir` with absolute paths, its hand shifted by
/// `shift` [m] along world x at every frame (the same name, so the same ensemble draws).
fn shifted_demo(name: &str, dir: &std::path::Path, shift: f64) -> std::path::PathBuf {
    let src = repo(&format!("scenes/demos/{name}.demo.json"));
    let base = src.parent().unwrap();
    let mut d = read(&src);
    let abs = |v: &Value| Value::from(base.join(v.as_str().unwrap()).to_str().unwrap());
    d["robot"] = abs(&d["robot"]);
    d["object"]["mesh"] = abs(&d["object"]["mesh"]);
    d["scene"] = abs(&d["scene"]);
    for f in d["frames"].as_array_mut().unwrap() {
        let x = f["wrist"]["position"][0].as_f64().unwrap();
        f["wrist"]["position"][0] = Value::from(x + shift);
    }
    let path = dir.join(format!("{name}.demo.json"));
    std::fs::write(&path, serde_json::to_vec(&d).unwrap()).unwrap();
    path
}

/// `report --compare` on ensemble verdicts: two runs of the same trajectories with other
/// ensemble seeds exit 0 whatever their verdicts at the edge do; the teapot's hand 5 mm off
/// (its pass fraction falls to none) exits 1 and says why.
#[test]
fn report_compare_flags_a_real_drop_in_pass_fraction_and_not_another_seed() {
    let dir = tempfile::tempdir().unwrap();
    let inputs = dir.path().join("inputs");
    std::fs::create_dir_all(&inputs).unwrap();
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    for (run, seed, shift) in [("a", "0", 0.0), ("b", "2", 0.0), ("off", "0", 0.005)] {
        for name in ["teapot", "cube"] {
            let shift = if name == "teapot" { shift } else { 0.0 };
            let demo = shifted_demo(name, &inputs, shift);
            let out = dir.path().join(run).join(name);
            let o = dexwarp(&[
                "validate",
                &s(&demo),
                "--out",
                &s(&out),
                "--ensemble-seed",
                seed,
            ]);
            assert!(o.status.success(), "{}", stderr(&o));
        }
    }
    let compare = |run: &str| {
        let o = dexwarp(&[
            "report",
            &s(&dir.path().join(run)),
            "--compare",
            &s(&dir.path().join("a")),
            "--out",
            &s(&dir.path().join(format!("{run}.html"))),
        ]);
        let md = std::fs::read_to_string(dir.path().join("compare.md")).unwrap_or_default();
        (o.status.code(), md, stderr(&o))
    };
    let (code, md, err) = compare("b");
    assert_eq!(
        code,
        Some(0),
        "another ensemble seed is not a regression:\n{md}\n{err}"
    );
    let (code, md, err) = compare("off");
    assert_eq!(
        code,
        Some(1),
        "the hand 5 mm off is a regression:\n{md}\n{err}"
    );
    assert!(md.contains("beyond both intervals"), "{md}");
}
