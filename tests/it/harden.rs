//! Hostile and absurd input (issue 18): one test per class of bad input, a seeded mutation
//! fuzz loop over demo and config JSON, and a kill-and-rerun batch.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use dexwarp::pipeline::{self, HandMethod, Inputs, Options, PhysicsOptions};
use dexwarp::{Error, Limits};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::Value;

use crate::fixtures::{dexwarp, gripper_fixture, stderr};

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn read_json(p: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

fn write_json(p: &Path, v: &Value) {
    std::fs::write(p, serde_json::to_vec_pretty(v).unwrap()).unwrap();
}

/// Runs `warp` (baseline hand, no physics unless asked) and expects a refusal whose text
/// holds every one of `needles`, within `seconds`.
fn refused(args: &[&str], needles: &[&str], seconds: f64) {
    let clock = Instant::now();
    let o = dexwarp(args);
    let took = clock.elapsed().as_secs_f64();
    let err = stderr(&o);
    assert!(!o.status.success(), "accepted {args:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: no {n:?} in {err}");
    }
    assert!(took < seconds, "{args:?} took {took:.2} s");
}

#[test]
fn output_length_and_physics_work_are_bounded_before_work() {
    let dir = tempfile::tempdir().unwrap();
    let config = gripper_fixture(dir.path());
    let mut c = read_json(&config);
    c["waypoints"][0]["t_new"] = 5_000_000.into();
    let long = dir.path().join("long.config.json");
    write_json(&long, &c);
    let out = dir.path().join("out");
    refused(
        &["warp", "--config", s(&long), "--out", s(&out)],
        &[
            "long.config.json",
            "output frames",
            "5000030",
            "--max-frames",
        ],
        3.0,
    );
    // Physics steps: 60 frames at 8 steps each, over a limit of 100.
    refused(
        &[
            "warp",
            "--config",
            s(&config),
            "--out",
            s(&out),
            "--hand",
            "baseline",
            "--max-physics-steps",
            "100",
        ],
        &["physics steps", "528", "--max-physics-steps"],
        10.0,
    );
    // The frame rate that made the replay run for ever is refused at load.
    let demo_path = dir.path().join("box.demo.json");
    let mut d = read_json(&demo_path);
    d["fps"] = serde_json::json!(1e-300);
    let slow = dir.path().join("slow.demo.json");
    write_json(&slow, &d);
    refused(
        &[
            "validate",
            s(&slow),
            "--out",
            s(&out),
            "--scene",
            s(&dir.path().join("scene.json")),
        ],
        &["slow.demo.json", "fps", "1e-300", "0.1 to 10000"],
        3.0,
    );
    assert!(!out.exists(), "no output on refusal");
}

#[test]
fn finite_but_absurd_numbers_are_refused_with_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let config = gripper_fixture(dir.path());
    let demo = read_json(&dir.path().join("box.demo.json"));
    let out = dir.path().join("out");
    type Case = (&'static str, fn(&mut Value), &'static str);
    let cases: [Case; 7] = [
        (
            "hand point",
            |d| d["frames"][20]["contacts"][0]["hand_point"][1] = serde_json::json!(1e308),
            "frames[20].contacts[0].hand_point",
        ),
        (
            "object point",
            |d| d["frames"][20]["contacts"][1]["object_point"][0] = serde_json::json!(-1e308),
            "frames[20].contacts[1].object_point",
        ),
        (
            "object position",
            |d| d["frames"][3]["object"]["position"][2] = serde_json::json!(1e308),
            "frames[3].object.position",
        ),
        (
            "wrist position",
            |d| d["frames"][4]["wrist"]["position"][0] = serde_json::json!(2000.0),
            "frames[4].wrist.position",
        ),
        (
            "joint angle",
            |d| d["frames"][5]["joints"][0] = serde_json::json!(1e308),
            "frames[5].joints[0]",
        ),
        ("fps", |d| d["fps"] = serde_json::json!(1e300), "fps"),
        (
            "mass",
            |d| d["object"]["mass"] = serde_json::json!(1e-300),
            "object.mass",
        ),
    ];
    for (what, mutate, field) in cases {
        let mut d = demo.clone();
        mutate(&mut d);
        let p = dir.path().join("bad.demo.json");
        write_json(&p, &d);
        let o = dexwarp(&[
            "warp",
            "--config",
            s(&config),
            "--demo",
            s(&p),
            "--out",
            s(&out),
            "--hand",
            "baseline",
        ]);
        let err = stderr(&o);
        assert!(!o.status.success(), "{what} accepted");
        assert!(
            err.contains("bad.demo.json") && err.contains(field) && err.contains("expected"),
            "{what}: {err}"
        );
    }
    let mut c = read_json(&config);
    c["waypoints"][0]["position"][0] = serde_json::json!(1e308);
    c["params"] = serde_json::json!({"pushout_step_m": 1e-300});
    let p = dir.path().join("bad.config.json");
    write_json(&p, &c);
    refused(
        &["warp", "--config", s(&p), "--out", s(&out)],
        &["waypoints[0].position", "1000 m"],
        3.0,
    );
    c["waypoints"][0]["position"][0] = serde_json::json!(0.1);
    write_json(&p, &c);
    refused(
        &["warp", "--config", s(&p), "--out", s(&out)],
        &["params.pushout_step_m", "1e-300"],
        3.0,
    );
    assert!(!out.exists());
}

#[test]
fn every_cli_float_is_validated() {
    let dir = tempfile::tempdir().unwrap();
    let config = gripper_fixture(dir.path());
    let out = dir.path().join("out");
    let warp = |extra: &[&str], needles: &[&str]| {
        let mut args = vec!["warp", "--config", s(&config), "--out", s(&out)];
        args.extend_from_slice(extra);
        refused(&args, needles, 3.0);
    };
    warp(
        &["--threshold-mm", "-1"],
        &["--threshold-mm", "must be positive"],
    );
    warp(&["--threshold-mm", "NaN"], &["--threshold-mm", "finite"]);
    warp(
        &["--penetration-weight", "NaN"],
        &["--penetration-weight", "finite"],
    );
    warp(
        &["--penetration-weight", "-3"],
        &["--penetration-weight", "must not be negative"],
    );
    let demo = dir.path().join("synth.demo.json");
    refused(
        &[
            "synth",
            "--object",
            "cube",
            "--robot",
            s(&crate::fixtures::repo("robots/parallel_gripper.urdf")),
            "--motion",
            "lift_place",
            "--out",
            s(&demo),
            "--noise-mm",
            "NaN",
        ],
        &["--noise-mm", "finite"],
        3.0,
    );
    refused(
        &[
            "filter",
            s(dir.path()),
            "--out",
            s(&dir.path().join("k.csv")),
            "--max-dc-mm",
            "inf",
        ],
        &["--max-dc-mm"],
        3.0,
    );
    refused(
        &[
            "filter",
            s(dir.path()),
            "--out",
            s(&dir.path().join("k.csv")),
            "--min-converged",
            "NaN",
        ],
        &["--min-converged"],
        3.0,
    );
    assert!(!out.exists() && !demo.exists());
}

#[test]
fn output_names_are_names_and_never_replace_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let work = dir.path().join("work");
    std::fs::create_dir(&work).unwrap();
    let config = gripper_fixture(&work);
    let out = work.join("out");
    let long = "x".repeat(300);
    for (name, needle) in [
        ("../../escaped", "path separator"),
        ("", "is empty"),
        ("..", "starts with '.'"),
        (long.as_str(), "300 characters"),
    ] {
        let mut c = read_json(&config);
        c["name"] = name.into();
        let p = work.join("named.config.json");
        write_json(&p, &c);
        let clock = Instant::now();
        refused(
            &["warp", "--config", s(&p), "--out", s(&out)],
            &["named.config.json", "name", needle],
            3.0,
        );
        assert!(clock.elapsed() < Duration::from_secs(3));
    }
    // A name equal to the demonstration's, with --out on its folder, would replace the input.
    let before = std::fs::read(work.join("box.demo.json")).unwrap();
    let mut c = read_json(&config);
    c["name"] = "box".into();
    let p = work.join("same.config.json");
    write_json(&p, &c);
    refused(
        &[
            "warp",
            "--config",
            s(&p),
            "--out",
            s(&work),
            "--hand",
            "baseline",
        ],
        &["box.demo.json", "is an input of this run"],
        3.0,
    );
    assert_eq!(std::fs::read(work.join("box.demo.json")).unwrap(), before);
    let outside: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(
        outside,
        vec![std::ffi::OsString::from("work")],
        "nothing written outside"
    );
    assert!(!out.exists());
}

#[test]
fn hostile_urdfs_are_refused_fast_without_overflow() {
    let dir = tempfile::tempdir().unwrap();
    let deep = dir.path().join("deep.urdf");
    let mut text = String::from("<robot name='r'><link name='a'>");
    text.push_str(&"<visual>".repeat(20_000));
    text.push_str(&"</visual>".repeat(20_000));
    text.push_str("</link></robot>");
    std::fs::write(&deep, &text).unwrap();
    refused(
        &["robot", s(&deep)],
        &["deep.urdf", "nesting depth", "--max-xml-depth"],
        1.0,
    );
    let many = dir.path().join("many.urdf");
    let mut text = String::from("<robot name='r'><!-- <link name='not counted'/> -->");
    for i in 0..100_000 {
        text.push_str(&format!("<link name='l{i}'/>"));
    }
    text.push_str("</robot>");
    std::fs::write(&many, &text).unwrap();
    refused(
        &["robot", s(&many)],
        &["many.urdf", "<link> elements", "100000", "--max-links"],
        1.0,
    );
    // The pre-scan does not miscount a real hand: comments, attributes with '>' and all.
    let o = dexwarp(&["robot", s(&crate::fixtures::repo("robots/human_hand.urdf"))]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn special_files_and_oversized_files_are_refused_while_reading() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    refused(
        &["validate", "/dev/zero", "--out", s(&out)],
        &["/dev/zero", "not a regular file", "--allow-special-files"],
        2.0,
    );
    // Allowed, /dev/zero is cut off at the byte cap instead of filling memory.
    refused(
        &[
            "validate",
            "/dev/zero",
            "--out",
            s(&out),
            "--allow-special-files",
            "--max-file-mb",
            "1",
        ],
        &["/dev/zero", "over the limit of 1048576", "--max-file-mb"],
        3.0,
    );
    // A FIFO nobody writes to: refused from its metadata, never opened (opening would block).
    let fifo = dir.path().join("demo.fifo");
    let made = Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|s| s.success());
    if made {
        refused(
            &["validate", s(&fifo), "--out", s(&out)],
            &["demo.fifo", "not a regular file"],
            2.0,
        );
    }
    // A mesh over the triangle limit is refused before it is parsed.
    let config = gripper_fixture(dir.path());
    refused(
        &[
            "warp",
            "--config",
            s(&config),
            "--out",
            s(&out),
            "--max-triangles",
            "4",
        ],
        &["small_box.obj", "triangles", "--max-triangles"],
        3.0,
    );
    assert!(!out.exists());
}

#[test]
fn error_text_is_plain_and_says_what_a_file_is() {
    let dir = tempfile::tempdir().unwrap();
    let config = gripper_fixture(dir.path());
    let out = dir.path().join("out");
    let o = dexwarp(&[
        "warp",
        "--config",
        s(&dir.path().join("missing.json")),
        "--out",
        s(&out),
    ]);
    let err = stderr(&o);
    assert_eq!(err.matches("os error 2").count(), 1, "{err}");
    let o = dexwarp(&[
        "warp",
        "--config",
        s(&config),
        "--demo",
        s(&config),
        "--out",
        s(&out),
    ]);
    let err = stderr(&o);
    assert!(
        err.contains("warp config") && err.contains("expected a demonstration"),
        "{err}"
    );
    let o = dexwarp(&["validate", s(&config), "--out", s(&out)]);
    assert!(
        stderr(&o).contains("this file is a warp config"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn jobs_are_capped_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let config = gripper_fixture(dir.path());
    let manifest = dir.path().join("items.jsonl");
    std::fs::write(
        &manifest,
        format!(
            "{{\"config\": \"{}\", \"hand\": \"baseline\"}}\n",
            config.display()
        ),
    )
    .unwrap();
    let out = dir.path().join("batch");
    let o = dexwarp(&["batch", s(&manifest), "--out", s(&out), "--jobs", "5000"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("--jobs 5000 is more than 4 per core"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn reports_carry_provenance_and_output_sets_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    let config = gripper_fixture(dir.path());
    // A killed run's staging folder (a process id that is not running) is cleaned.
    let stale = dir.path().join(".out.dexwarp-tmp-4194300-0");
    std::fs::create_dir(&stale).unwrap();
    std::fs::write(stale.join("report.json"), "{}").unwrap();
    let out = dir.path().join("out");
    let o = dexwarp(&[
        "warp",
        "--config",
        s(&config),
        "--out",
        s(&out),
        "--hand",
        "baseline",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stale.exists(), "stale temporary left");
    let report = read_json(&out.join("report.json"));
    let prov = &report["provenance"];
    assert_eq!(prov["tool_version"], env!("CARGO_PKG_VERSION"));
    assert!(!prov["git_revision"].as_str().unwrap().is_empty());
    for role in ["config", "demo", "scene", "robot", "mesh"] {
        let f = &prov["inputs"][role];
        let bytes = std::fs::read(f["path"].as_str().unwrap()).unwrap();
        assert_eq!(
            f["sha256"],
            dexwarp::model::provenance::sha256_hex(&bytes),
            "{role}"
        );
    }
    for group in ["warp", "options", "limits", "physics"] {
        assert!(prov["parameters"][group].is_object(), "{group}: {prov}");
    }
    assert_eq!(prov["parameters"]["options"]["hand"], "baseline");
    // A set whose files no longer match its report is not a finished run.
    let keep = dir.path().join("keep.csv");
    let o = dexwarp(&["filter", s(dir.path()), "--out", s(&keep), "--no-physics"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("kept 1 of 1"), "{}", stderr(&o));
    std::fs::write(out.join("frames.csv"), "frame\n").unwrap();
    let o = dexwarp(&["filter", s(dir.path()), "--out", s(&keep), "--no-physics"]);
    assert!(stderr(&o).contains("kept 0 of 1"), "{}", stderr(&o));
    let dropped = std::fs::read_to_string(dir.path().join("keep.dropped.csv")).unwrap();
    assert!(
        dropped.contains("frames.csv is not the file this report was written with"),
        "{dropped}"
    );
    // validate reports carry provenance too.
    let v = dir.path().join("v");
    let o = dexwarp(&[
        "validate",
        s(&out.join("box_lift.demo.json")),
        "--out",
        s(&v),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        read_json(&v.join("report.json"))["provenance"]["inputs"]["demo"]["sha256"].is_string()
    );
}

#[test]
fn nan_inside_a_stage_is_an_error_not_a_pass() {
    // Loading refuses every non-finite or absurd input, so drive the stage check directly:
    // a hand whose wrist is NaN at one frame.
    let dir = tempfile::tempdir().unwrap();
    let config = gripper_fixture(dir.path());
    let inputs = Inputs::load(&config, None, &Limits::default()).unwrap();
    let run = pipeline::warp(&inputs, &Options::new(HandMethod::Baseline).physics(None)).unwrap();
    let mut hand = run.hand.clone();
    hand.wrists[7].translation.vector.y = f64::NAN;
    let err = pipeline::check_hand_path(&config, &hand).unwrap_err();
    let msg = err.to_string();
    assert!(
        matches!(err, Error::NonFinite { frame: Some(7), .. }),
        "{msg}"
    );
    assert!(
        msg.contains("hand recovery")
            && msg.contains("wrist position")
            && msg.contains("output frame 7"),
        "{msg}"
    );
}

// ---------------------------------------------------------------------------------------
// Fuzz: seeded mutations of the demo and config JSON.

/// Every numeric leaf of `v`, as JSON pointers.
fn leaves(v: &Value, at: String, out: &mut Vec<String>) {
    match v {
        Value::Object(m) => m
            .iter()
            .for_each(|(k, x)| leaves(x, format!("{at}/{k}"), out)),
        Value::Array(a) => a
            .iter()
            .enumerate()
            .for_each(|(i, x)| leaves(x, format!("{at}/{i}"), out)),
        _ => out.push(at),
    }
}

fn mutate(v: &mut Value, rng: &mut ChaCha8Rng) {
    let mut ptrs = Vec::new();
    leaves(v, String::new(), &mut ptrs);
    let p = &ptrs[rng.random_range(0..ptrs.len())];
    let choices = [
        serde_json::json!(1e308),
        serde_json::json!(-1e308),
        serde_json::json!(1e-300),
        serde_json::json!(0),
        serde_json::json!(-1),
        serde_json::json!(5_000_000),
        serde_json::json!(0.5),
        serde_json::json!("../../escaped"),
        serde_json::json!(""),
        Value::Null,
        serde_json::json!([]),
    ];
    let new = choices[rng.random_range(0..choices.len())].clone();
    if let Some(slot) = v.pointer_mut(p) {
        match (slot.as_f64(), rng.random_range(0..3)) {
            // Also small relative nudges of a number, which mostly load.
            (Some(x), 0) => *slot = serde_json::json!(x * rng.random_range(-3.0..3.0)),
            _ => *slot = new,
        }
    }
}

fn files_below(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p.clone());
            }
            out.push(p);
        }
    }
    out.sort();
    out
}

#[test]
fn fuzz_mutated_demos_and_configs_never_panic_nan_or_escape() {
    let root = tempfile::tempdir().unwrap();
    let config_path = gripper_fixture(root.path());
    let demo0 = read_json(&root.path().join("box.demo.json"));
    let config0 = read_json(&config_path);
    let mut rng = ChaCha8Rng::seed_from_u64(18);
    let cases = 300;
    let (mut accepted, mut refused) = (0, 0);
    for case in 0..cases {
        let mut demo = demo0.clone();
        let mut config = config0.clone();
        for _ in 0..rng.random_range(1..4) {
            if rng.random_bool(0.5) {
                mutate(&mut demo, &mut rng);
            } else {
                mutate(&mut config, &mut rng);
            }
        }
        // Beside the fixture, so that its relative paths (robot, mesh, scene) still resolve.
        let demo_path = root.path().join(format!("case{case}.demo.json"));
        write_json(&demo_path, &demo);
        let cfg_path = root.path().join(format!("case{case}.config.json"));
        write_json(&cfg_path, &config);
        let before = files_below(root.path());
        let out = root.path().join(format!("case{case}_out"));
        let physics = case % 25 == 0;
        // Contact IK on every fifth case (it dominates the test's time), baseline otherwise.
        let hand = if case % 5 == 0 {
            HandMethod::Contact
        } else {
            HandMethod::Baseline
        };
        let result = std::panic::catch_unwind(|| -> dexwarp::Result<()> {
            let inputs = Inputs::load(&cfg_path, Some(&demo_path), &Limits::default())?;
            let options = Options::new(hand)
                .demo(Some(demo_path.clone()))
                .physics(physics.then(PhysicsOptions::default));
            let run = pipeline::warp(&inputs, &options)?;
            dexwarp::output::write_run(&out, &run)?;
            Ok(())
        });
        let result = result.unwrap_or_else(|_| panic!("case {case} panicked: {demo} {config}"));
        let after = files_below(root.path());
        for p in after.iter().filter(|p| !before.contains(p)) {
            assert!(
                p.starts_with(&out),
                "case {case} wrote {} outside its output",
                p.display()
            );
        }
        match result {
            Ok(()) => {
                accepted += 1;
                for p in files_below(&out) {
                    let text = std::fs::read_to_string(&p).unwrap();
                    for bad in ["NaN", "inf", "null"] {
                        let hit = match bad {
                            // `null` is legitimate in reports for fields a run did not compute:
                            // every number the report must have is checked by parsing it below.
                            "null" => false,
                            _ => text.contains(bad),
                        };
                        assert!(!hit, "case {case}: {bad} in {}", p.display());
                    }
                }
                let report: dexwarp::model::report::Report =
                    serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap())
                        .unwrap_or_else(|e| panic!("case {case}: report does not parse: {e}"));
                assert!(report.metrics.d_c_mm.warped.is_finite());
            }
            Err(e) => {
                refused += 1;
                let msg = e.to_string();
                let named = match &e {
                    Error::Invalid { field, .. }
                    | Error::Parse { field, .. }
                    | Error::Unsupported { field, .. } => {
                        !field.is_empty() && msg.contains(field.as_str())
                    }
                    Error::TooLarge { flag, .. } => msg.contains(flag),
                    Error::NonFinite { quantity, .. } => msg.contains(quantity),
                    Error::Io { .. } => false,
                };
                assert!(named, "case {case}: refusal names no field: {msg}");
                assert!(
                    msg.contains(".json") || msg.contains(".obj") || msg.contains(".urdf"),
                    "case {case}: names no file: {msg}"
                );
            }
        }
    }
    eprintln!("fuzz: {cases} cases, {accepted} accepted, {refused} refused");
    assert!(
        accepted > 20 && refused > 20,
        "accepted {accepted}, refused {refused}"
    );
}

// ---------------------------------------------------------------------------------------
// Kill and rerun.

/// Every file below `dir` (relative path → content), reports without their timing.
fn snapshot(dir: &Path) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    for p in files_below(dir) {
        if p.is_dir() {
            continue;
        }
        let rel = p.strip_prefix(dir).unwrap().display().to_string();
        let text = std::fs::read_to_string(&p).unwrap();
        let text = if rel.ends_with("report.json") {
            let mut v: Value = serde_json::from_str(&text).unwrap();
            v.as_object_mut().unwrap().remove("timing_s");
            // Whether the convex decomposition came from the in-process cache depends on
            // which items ran in the same process: a run fact like the timing.
            if let Some(r) = v
                .pointer_mut("/physics/replay")
                .and_then(Value::as_object_mut)
            {
                r.remove("decomposition_cached");
            }
            if let Some(p) = v.get_mut("physics").and_then(Value::as_object_mut) {
                p.remove("timing_s");
            }
            v.to_string()
        } else if rel.ends_with("batch.csv") {
            // Timing and status aside (a resumed batch reports finished items as skipped).
            text.lines()
                .map(|l| {
                    let cells: Vec<&str> = l.split(',').collect();
                    let n = cells.len();
                    format!("{}|{}", cells[..2].join(","), cells[3..n - 1].join(","))
                })
                .collect::<Vec<_>>()
                .join("\n")
        } else {
            text
        };
        out.insert(rel, text);
    }
    out
}

#[test]
fn killed_batches_rerun_to_the_files_of_an_uninterrupted_run() {
    let dir = tempfile::tempdir().unwrap();
    let config = gripper_fixture(dir.path());
    let manifest = dir.path().join("items.jsonl");
    std::fs::write(
        &manifest,
        format!(
            "{{\"config\": \"{c}\", \"name\": \"a\", \"hand\": \"baseline\"}}\n{{\"config\": \"{c}\", \"name\": \"b\", \"threshold_mm\": 5}}\n{{\"config\": \"{c}\", \"name\": \"c\", \"hand\": \"baseline\", \"threshold_mm\": 8}}\n{{\"config\": \"missing.json\", \"name\": \"d\"}}\n",
            c = config.display()
        ),
    )
    .unwrap();
    let batch = |out: &Path| {
        Command::new(env!("CARGO_BIN_EXE_dexwarp"))
            .args(["batch", s(&manifest), "--out", s(out), "--jobs", "2"])
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap()
    };
    let reference = dir.path().join("reference");
    let clock = Instant::now();
    batch(&reference).wait().unwrap();
    let full = clock.elapsed();
    let expected = snapshot(&reference);
    assert!(expected.contains_key("batch.csv") && expected.contains_key("b/report.json"));

    let out = dir.path().join("killed");
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for _ in 0..6 {
        let mut child = batch(&out);
        let at = full.mul_f64(rng.random_range(0.0..1.0));
        std::thread::sleep(at);
        let _ = child.kill();
        child.wait().unwrap();
    }
    batch(&out).wait().unwrap();
    let got = snapshot(&out);
    let names = |m: &BTreeMap<String, String>| m.keys().cloned().collect::<Vec<_>>();
    assert_eq!(names(&got), names(&expected), "file sets differ");
    for (k, v) in &expected {
        assert_eq!(&got[k], v, "{k} differs");
    }
    assert!(
        files_below(&out).iter().all(|p| !p
            .file_name()
            .unwrap()
            .to_string_lossy()
            .starts_with('.')),
        "temporaries left"
    );
}

/// A full disk while writing (simulated by a file-size limit: writes past it fail with
/// EFBIG, as on a full disk they fail with ENOSPC): `warp` fails with the folder named, the
/// previous run's set in `--out` is left whole and unchanged, and no staging folder stays.
#[test]
fn a_write_that_fails_leaves_the_previous_set_whole() {
    let dir = tempfile::tempdir().unwrap();
    let config = gripper_fixture(dir.path());
    let out = dir.path().join("out");
    let args = ["warp", "--config", s(&config), "--out", s(&out)];
    let o = dexwarp(&[&args[..], &["--hand", "baseline"]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let before = snapshot(&out);
    assert_eq!(before.len(), 3, "{:?}", before.keys());
    let entries = || {
        let mut v: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    };
    let listed = entries();

    // The same command under a 4 KiB file-size limit, with SIGXFSZ ignored so the write
    // fails instead of the process being killed (ignored signals survive exec).
    let script = format!(
        "trap '' XFSZ; ulimit -f 8; exec '{}' \"$@\"",
        env!("CARGO_BIN_EXE_dexwarp")
    );
    let o = std::process::Command::new("sh")
        .arg("-c")
        .arg(&script)
        .arg("sh")
        .args(args)
        .output()
        .unwrap();
    assert!(!o.status.success(), "a failed write must fail the run");
    let err = stderr(&o);
    assert!(
        err.contains("cannot write") && err.contains(s(&out)),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(snapshot(&out), before, "the previous set changed");
    assert_eq!(
        entries(),
        listed,
        "a staging folder or a partial file was left"
    );
}

/// Two runs writing into one folder at the same time: the folder ends with one run's whole
/// set (every file the one its report was written with), never a mix of the two.
#[test]
fn concurrent_runs_into_one_folder_leave_one_whole_set() {
    let dir = tempfile::tempdir().unwrap();
    let config = gripper_fixture(dir.path());
    let out = dir.path().join("out");
    for _round in 0..3 {
        let spawn = |hand: &str| {
            std::process::Command::new(env!("CARGO_BIN_EXE_dexwarp"))
                .args([
                    "warp",
                    "--config",
                    s(&config),
                    "--out",
                    s(&out),
                    "--hand",
                    hand,
                ])
                .output()
        };
        let (a, b) = std::thread::scope(|sc| {
            let a = sc.spawn(|| spawn("baseline"));
            let b = sc.spawn(|| spawn("contact"));
            (a.join().unwrap().unwrap(), b.join().unwrap().unwrap())
        });
        assert!(a.status.success(), "{}", stderr(&a));
        assert!(b.status.success(), "{}", stderr(&b));
        let report_path = out.join("report.json");
        let report: dexwarp::model::report::Report =
            serde_json::from_slice(&std::fs::read(&report_path).unwrap()).unwrap();
        dexwarp::output::set_is_complete(&report_path, &report)
            .unwrap_or_else(|why| panic!("a mixed set: {why}"));
        let names: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains("dexwarp-tmp"))
            .collect();
        assert!(names.is_empty(), "staging left: {names:?}");
    }
}

/// A config's `params.physics` block sets the replay's parameters for every command that runs
/// it (here `batch`, which has no physics flags), on top of the defaults; a key that is not a
/// physics parameter, a value of the wrong type or out of range is refused before any work,
/// naming the config's field.
#[test]
fn a_configs_physics_block_reaches_the_replay_and_bad_ones_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let config = gripper_fixture(dir.path());
    let with_physics = |name: &str, physics: Value| {
        let mut c = read_json(&config);
        c["name"] = Value::from(name);
        c["params"]["physics"] = physics;
        let path = dir.path().join(format!("{name}.json"));
        std::fs::write(&path, serde_json::to_string_pretty(&c).unwrap()).unwrap();
        path
    };
    let set = with_physics(
        "set",
        serde_json::json!({"hand_friction": 0.5, "max_mean_rotation_error_deg": 20.0}),
    );
    let manifest = dir.path().join("items.jsonl");
    let item = serde_json::json!({"config": set, "hand": "baseline", "name": "set"});
    std::fs::write(&manifest, format!("{item}\n")).unwrap();
    let out = dir.path().join("batch");
    let o = dexwarp(&["batch", s(&manifest), "--out", s(&out), "--jobs", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = read_json(&out.join("set/report.json"));
    let physics = &report["provenance"]["parameters"]["physics"];
    assert_eq!(physics["hand_friction"], 0.5, "{physics}");
    assert_eq!(physics["max_mean_rotation_error_deg"], 20.0, "{physics}");
    let default = dexwarp::physics::Params::default();
    assert_eq!(
        physics["object_friction"], default.object_friction,
        "{physics}"
    );
    assert_eq!(physics["max_dt_s"], default.max_dt_s, "{physics}");

    for (name, block, field, expected) in [
        (
            "unknown",
            serde_json::json!({"friction": 1.0}),
            "params.physics.friction",
            "hand_friction",
        ),
        (
            "wrong_type",
            serde_json::json!({"hand_friction": "high"}),
            "params.physics.hand_friction",
            "invalid type",
        ),
        (
            "negative",
            serde_json::json!({"max_dt_s": -0.01}),
            "params.physics.max_dt_s",
            "> 0",
        ),
    ] {
        let path = with_physics(name, block);
        let o = dexwarp(&[
            "warp",
            "--config",
            s(&path),
            "--out",
            s(&dir.path().join(name)),
        ]);
        let err = stderr(&o);
        assert!(!o.status.success(), "{name}: {err}");
        assert!(
            err.contains(&format!("{}", path.display())),
            "{name}: {err}"
        );
        assert!(
            err.contains(field) && err.contains(expected),
            "{name}: {err}"
        );
        assert!(!dir.path().join(name).exists(), "{name}: output written");
    }
}

#[test]
fn typos_and_inputs_no_command_could_use_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let config = gripper_fixture(dir.path());
    let out = dir.path().join("out");
    let c = read_json(&config);
    // A typo of a config key: refused with the nearest known key, not run without the wall.
    let mut typo = c.clone();
    let walls = typo.as_object_mut().unwrap().remove("barriers").unwrap();
    typo["barrier"] = walls;
    let path = dir.path().join("typo.config.json");
    write_json(&path, &typo);
    refused(
        &["warp", "--config", s(&path), "--out", s(&out)],
        &[
            "typo.config.json",
            "unknown field `barrier`",
            "did you mean `barriers`?",
        ],
        3.0,
    );
    // And in a batch manifest's line.
    let manifest = dir.path().join("items.jsonl");
    std::fs::write(&manifest, "{\"confg\": \"lift.config.json\"}\n").unwrap();
    refused(
        &["batch", s(&manifest), "--out", s(&out)],
        &["items.jsonl", "line 1", "did you mean `config`?"],
        3.0,
    );
    // Unknown keys in a demonstration's object and in one of its frames: refused, with the
    // JSON path.
    let demo_path = dir.path().join("box.demo.json");
    let demo = read_json(&demo_path);
    for (at, key) in [("object", "maas"), ("frames[3]", "contact")] {
        let mut d = demo.clone();
        let target = if at == "object" {
            &mut d["object"]
        } else {
            &mut d["frames"][3]
        };
        target[key] = 1.into();
        let p = dir.path().join("typo.demo.json");
        write_json(&p, &d);
        refused(
            &["validate", s(&p), "--out", s(&out)],
            &["typo.demo.json", &format!("{at}.{key}"), "unknown field"],
            3.0,
        );
    }
    // A rotation axis whose norm overflows is a direction like any other: the warp runs
    // (and is not blamed on the demonstration's frames).
    let mut axis = c.clone();
    axis["waypoints"][0]["rotation"] =
        serde_json::json!({"axis": [1e300, 1e300, 0.0], "angle": 0.2});
    let path = dir.path().join("axis.config.json");
    write_json(&path, &axis);
    let o = dexwarp(&[
        "warp",
        "--config",
        s(&path),
        "--out",
        s(&out),
        "--hand",
        "baseline",
        "--no-physics",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // An output far longer than memory can hold: refused at once, naming the flag.
    let mut long = c.clone();
    long["waypoints"][0]["t_new"] = 999_000.into();
    long["params"] = serde_json::json!({"end_t_new": 999_100});
    let path = dir.path().join("long.config.json");
    write_json(&path, &long);
    refused(
        &["warp", "--config", s(&path), "--out", s(&out)],
        &["long.config.json", "999", "--max-frames", "48 KiB"],
        3.0,
    );
    // synth referencing a mesh that does not exist: refused before anything is written.
    let synth_out = dir.path().join("synth/box.demo.json");
    let o = dexwarp(&[
        "synth",
        "--object",
        "small_box",
        "--robot",
        s(&crate::fixtures::repo("robots/parallel_gripper.urdf")),
        "--motion",
        "lift_place",
        "--mesh",
        "/nope/box.obj",
        "--out",
        s(&synth_out),
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("/nope/box.obj"),
        "{}",
        stderr(&o)
    );
    assert!(!synth_out.exists() && !dir.path().join("synth").exists());
}

#[test]
fn recordings_whose_clock_runs_backwards_are_refused_and_inside_out_meshes_turned() {
    let dir = tempfile::tempdir().unwrap();
    let robot = crate::fixtures::repo("robots/parallel_gripper.urdf");
    let header = "timestamp,object.x,object.y,object.z,object.qw,object.qx,object.qy,object.qz,wrist.x,wrist.y,wrist.z,wrist.qw,wrist.qx,wrist.qy,wrist.qz,finger_joint1";
    let row = |t: f64| format!("{t},0,0,0.93,1,0,0,0,0,0,1.06,0,1,0,0,0.024");
    let csv = dir.path().join("rec.csv");
    let rows: Vec<String> = [0.0, 0.033, 0.033, 0.1].iter().map(|&t| row(t)).collect();
    std::fs::write(&csv, format!("{header}\n{}\n", rows.join("\n"))).unwrap();
    // The small box, inside out: every triangle reversed.
    let mesh =
        std::fs::read_to_string(crate::fixtures::repo("scenes/objects/small_box.obj")).unwrap();
    let flipped: String = mesh
        .lines()
        .map(|l| match l.strip_prefix("f ") {
            Some(f) => {
                let v: Vec<&str> = f.split_whitespace().collect();
                format!("f {} {} {}\n", v[0], v[2], v[1])
            }
            None => format!("{l}\n"),
        })
        .collect();
    let inside_out = dir.path().join("inside_out.obj");
    std::fs::write(&inside_out, flipped).unwrap();
    let import = |csv: &Path, out: &Path| {
        dexwarp(&[
            "import",
            "--csv",
            s(csv),
            "--fps",
            "30",
            "--robot",
            s(&robot),
            "--mesh",
            s(&inside_out),
            "--mass",
            "0.1",
            "--out",
            s(out),
        ])
    };
    let with_correspondences = |err: &str| -> usize {
        let (head, _) = err.split_once(" with correspondences").expect(err);
        head.rsplit(' ').next().unwrap().parse().unwrap()
    };
    let out = dir.path().join("rec.demo.json");
    let o = import(&csv, &out);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("rec.csv")
            && err.contains("row 3, column timestamp")
            && err.contains("increase"),
        "{err}"
    );
    assert!(!out.exists());
    // In order, it imports; the inside-out mesh is said and used turned outward.
    let rows: Vec<String> = [0.0, 0.033, 0.066, 0.1].iter().map(|&t| row(t)).collect();
    std::fs::write(&csv, format!("{header}\n{}\n", rows.join("\n"))).unwrap();
    let o = import(&csv, &out);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("inside_out.obj") && err.contains("inside out"),
        "{err}"
    );
    // Its correspondences are the outward mesh's (inside out, the fingers read as inside the
    // object and none were found).
    let found = with_correspondences(&err);
    let o = dexwarp(&[
        "import",
        "--csv",
        s(&csv),
        "--fps",
        "30",
        "--robot",
        s(&robot),
        "--mesh",
        s(&crate::fixtures::repo("scenes/objects/small_box.obj")),
        "--mass",
        "0.1",
        "--out",
        s(&dir.path().join("outward.demo.json")),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let expected = with_correspondences(&stderr(&o));
    assert!(expected > 0 && found == expected, "{found} vs {expected}");
}

/// Retargeting parameters come from a file a user writes: a misspelled field is refused with
/// the nearest one, a value out of range with the field and its range, and nothing is
/// written.
#[test]
fn retargeting_parameters_are_read_strictly() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out/rec.demo.json");
    // The import with `json` written to `file` and given as `flag`.
    let run_with = |flag: &str, file: &str, json: &str| {
        let params = dir.path().join(file);
        std::fs::write(&params, json).unwrap();
        let o = dexwarp(&[
            "import",
            "--keypoints",
            s(&dir.path().join("frames.csv")),
            "--fps",
            "30",
            "--robot",
            s(&crate::fixtures::repo("robots/human_hand.urdf")),
            "--mesh",
            s(&crate::fixtures::repo("scenes/objects/small_box.obj")),
            "--mass",
            "0.1",
            "--out",
            s(&out),
            flag,
            s(&params),
        ]);
        (o.status.success(), stderr(&o))
    };
    let run = |json: &str| run_with("--retarget", "retarget.json", json);
    let (ok, err) = run(r#"{"regrasp_m": 20}"#);
    assert!(!ok && err.contains("retarget.json"), "{err}");
    assert!(err.contains("did you mean `regrasp_mm`"), "{err}");
    let (ok, err) = run(r#"{"touch_mm": 6, "release_mm": 5}"#);
    assert!(
        !ok && err.contains("release_mm") && err.contains("[6, 100]"),
        "{err}"
    );
    let (ok, err) = run(r#"{"smoothing_window": 8}"#);
    assert!(
        !ok && err.contains("smoothing_window") && err.contains("odd"),
        "{err}"
    );
    // A keypoint map's own parameters are checked the same way, naming the map.
    let (ok, err) = run_with(
        "--keypoint-map",
        "hand.keypoints.json",
        r#"{"keypoints": [["wrist", "palm", [0, 0, 0]]], "bones": [], "retarget": {"smoothing_window": 4}}"#,
    );
    assert!(
        !ok && err.contains("hand.keypoints.json")
            && err.contains("smoothing_window")
            && err.contains("odd"),
        "{err}"
    );
    assert!(!out.exists() && !dir.path().join("out").exists());
}
