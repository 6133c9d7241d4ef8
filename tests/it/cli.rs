//! The command line, end to end, in a temporary folder: every command, errors included.

use dexwarp::model::demo::Demo;

use crate::fixtures::{dexwarp, gripper_fixture, repo, stderr};

#[test]
fn robot_prints_the_hand_and_refuses_bad_files() {
    let o = dexwarp(&["robot", repo("robots/allegro_hand.urdf").to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("16 actuated"), "{text}");
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.urdf");
    std::fs::write(&bad, "<robot name='x'><link name='a'/><joint name='j' type='revolute'><parent link='a'/><child link='b'/></joint></robot>").unwrap();
    let o = dexwarp(&["robot", bad.to_str().unwrap()]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains("bad.urdf"), "{err}");
    let o = dexwarp(&["robot", "/nonexistent/hand.urdf"]);
    assert!(!o.status.success() && stderr(&o).contains("/nonexistent/hand.urdf"));
}

#[test]
fn warp_writes_demo_report_and_frames() {
    let dir = tempfile::tempdir().unwrap();
    let config = gripper_fixture(dir.path());
    let out = dir.path().join("out");
    let o = dexwarp(&[
        "warp",
        "--config",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--hand",
        "baseline",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["format"], "dexwarp.report/1");
    assert_eq!(report["frames_in"], 60);
    assert!(
        report["constraints"]["max_waypoint_error_mm"]
            .as_f64()
            .unwrap()
            < 1e-3
    );
    assert!(report["metrics"]["d_c_mm"]["original"].as_f64().unwrap() < 1e-6);
    let demo = Demo::load(&out.join("box_lift.demo.json"), &dexwarp::Limits::default()).unwrap();
    assert_eq!(demo.timewarp.as_ref().unwrap().len(), 60);
    let frames = std::fs::read_to_string(out.join("frames.csv")).unwrap();
    assert!(
        frames.starts_with("frame,source_frame,in_contact"),
        "{frames}"
    );
    assert_eq!(frames.lines().count(), demo.frames.len() + 1);
}

#[test]
fn warp_errors_name_the_file_and_value() {
    let dir = tempfile::tempdir().unwrap();
    let config = gripper_fixture(dir.path());
    let out = dir.path().join("out");
    let o = dexwarp(&[
        "warp",
        "--config",
        "missing.json",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("missing.json"),
        "{}",
        stderr(&o)
    );
    let o = dexwarp(&[
        "warp",
        "--config",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--threshold-mm=-2",
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("millimetres > 0"), "{}", stderr(&o));
    assert!(!out.join("report.json").exists(), "no output on error");
}

#[test]
fn batch_records_failures_skips_finished_and_shards() {
    let dir = tempfile::tempdir().unwrap();
    let config = gripper_fixture(dir.path());
    let manifest = dir.path().join("items.jsonl");
    std::fs::write(
        &manifest,
        format!(
            "# two good items and one whose config is missing\n{{\"config\": \"{}\", \"name\": \"a\"}}\n\n{{\"config\": \"lift.config.json\", \"name\": \"b\", \"threshold_mm\": 5}}\n{{\"config\": \"nope.json\", \"name\": \"c\"}}\n",
            config.display()
        ),
    )
    .unwrap();
    let out = dir.path().join("batch");
    let run = |extra: &[&str]| {
        let mut args = vec![
            "batch",
            manifest.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--jobs",
            "2",
        ];
        args.extend_from_slice(extra);
        dexwarp(&args)
    };
    let o = run(&[]);
    assert!(!o.status.success(), "a failed item makes the exit non-zero");
    assert!(stderr(&o).contains("1 failed"), "{}", stderr(&o));
    assert!(out.join("a/report.json").is_file() && out.join("b/report.json").is_file());
    let failed: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("c/report.json")).unwrap()).unwrap();
    assert!(
        failed["error"].as_str().unwrap().contains("nope.json"),
        "{failed}"
    );
    let summary = std::fs::read_to_string(out.join("batch.csv")).unwrap();
    assert_eq!(summary.lines().count(), 4, "{summary}");
    // A second run skips the finished items and retries the failed one.
    let o = run(&[]);
    assert!(stderr(&o).contains("0 done, 2 skipped"), "{}", stderr(&o));
    // Shards split the items without overlap.
    let o = run(&["--shard", "0/2", "--force"]);
    let s0 = std::fs::read_to_string(out.join("batch.shard0of2.csv")).unwrap();
    let _ = o;
    let o = run(&["--shard", "1/2", "--force"]);
    assert!(
        o.status.success(),
        "shard 1 has only item b: {}",
        stderr(&o)
    );
    let s1 = std::fs::read_to_string(out.join("batch.shard1of2.csv")).unwrap();
    assert!(
        s0.contains("\na,") && s0.contains("\nc,") && !s0.contains("\nb,"),
        "{s0}"
    );
    assert!(s1.contains("\nb,") && !s1.contains("\na,"), "{s1}");
    // Bad shard specs and bad manifest lines are refused with a clear message.
    for bad in ["2/2", "1", "a/b", "0/0"] {
        let o = run(&["--shard", bad]);
        assert!(
            !o.status.success() && stderr(&o).contains("K/N"),
            "{bad}: {}",
            stderr(&o)
        );
    }
    std::fs::write(
        &manifest,
        "{\"config\": \"lift.config.json\"}\n{\"confg\": \"x\"}\n",
    )
    .unwrap();
    let o = run(&[]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("line 2") && stderr(&o).contains("confg"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn filter_keeps_and_explains() {
    let dir = tempfile::tempdir().unwrap();
    let config = gripper_fixture(dir.path());
    let out = dir.path().join("out");
    // x: no physics replay; y: replayed (the fixture's jaws do not squeeze the box, so the
    // physics verdict is a drop).
    for (name, extra) in [("x", "--no-physics"), ("y", "--threshold-mm=2.5")] {
        let d = out.join(name);
        let args = [
            "warp",
            "--config",
            config.to_str().unwrap(),
            "--out",
            d.to_str().unwrap(),
            extra,
        ];
        let o = dexwarp(&args);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let keep = dir.path().join("keep.csv");
    // The default requires a physics pass: both are dropped, each with its reasons.
    let o = dexwarp(&[
        "filter",
        out.to_str().unwrap(),
        "--out",
        keep.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let dropped = std::fs::read_to_string(dir.path().join("keep.dropped.csv")).unwrap();
    assert_eq!(dropped.lines().count(), 3, "{dropped}");
    let x = dropped.lines().find(|l| l.contains("/x/")).unwrap();
    let y = dropped.lines().find(|l| l.contains("/y/")).unwrap();
    assert!(x.contains("no physics verdict"), "{x}");
    assert!(
        y.contains(",fail,") && y.contains("physics: object dropped"),
        "{y}"
    );
    let o = dexwarp(&[
        "filter",
        out.to_str().unwrap(),
        "--out",
        keep.to_str().unwrap(),
        "--no-physics",
        "--max-waypoint-error-mm",
        "1",
    ]);
    assert!(o.status.success());
    assert_eq!(std::fs::read_to_string(&keep).unwrap().lines().count(), 3);
    // The onset: y's, from its report, is checked against the limit; x has none to check.
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("y/report.json")).unwrap()).unwrap();
    let onset = report["physics"]["onset"]["position_error_mm"]
        .as_f64()
        .unwrap();
    assert!(onset > 0.0, "{onset}");
    for (limit, y_kept) in [(onset * 2.0, true), (onset / 2.0, false)] {
        let o = dexwarp(&[
            "filter",
            out.to_str().unwrap(),
            "--out",
            keep.to_str().unwrap(),
            "--no-physics",
            "--max-onset-mm",
            &format!("{limit}"),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let kept = std::fs::read_to_string(&keep).unwrap();
        let dropped = std::fs::read_to_string(dir.path().join("keep.dropped.csv")).unwrap();
        assert_eq!(kept.contains("/y/"), y_kept, "{kept}");
        let x = dropped.lines().find(|l| l.contains("/x/")).unwrap();
        assert!(x.contains("no onset in the report"), "{x}");
        if !y_kept {
            let y = dropped.lines().find(|l| l.contains("/y/")).unwrap();
            assert!(
                y.contains(&format!("onset {onset:.1} mm > {limit} mm")),
                "{y}"
            );
        }
    }
    // The release turn: z's hand turned the released object 24.5°, w's turned by itself
    // (no touch once it had turned 5°); y has no release (its replay stopped at the drop).
    let turned = dir.path().join("turned");
    for (name, by_hand) in [
        ("y", None),
        (
            "z",
            Some(serde_json::json!({"frame": 692, "links": ["left_finger"]})),
        ),
        ("w", Some(serde_json::Value::Null)),
    ] {
        let mut r = report.clone();
        if let Some(by_hand) = by_hand {
            r["physics"]["release"] = serde_json::json!({
                "frame": 658, "rests_on_support": true, "final_motion_mm": 0.1,
                "final_speed_m_s": 0.0,
                "turn": {"deg": 24.5, "frame": 700, "by_hand": by_hand},
            });
        }
        std::fs::create_dir_all(turned.join(name)).unwrap();
        for f in std::fs::read_dir(out.join("y")).unwrap() {
            let f = f.unwrap().path();
            if f.is_file() {
                std::fs::copy(&f, turned.join(name).join(f.file_name().unwrap())).unwrap();
            }
        }
        std::fs::write(
            turned.join(name).join("report.json"),
            serde_json::to_vec(&r).unwrap(),
        )
        .unwrap();
    }
    for (limit, z_kept) in [(30.0, true), (20.0, false)] {
        let o = dexwarp(&[
            "filter",
            turned.to_str().unwrap(),
            "--out",
            keep.to_str().unwrap(),
            "--no-physics",
            "--max-release-turn-deg",
            &format!("{limit}"),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let kept = std::fs::read_to_string(&keep).unwrap();
        let dropped = std::fs::read_to_string(dir.path().join("keep.dropped.csv")).unwrap();
        for (name, expect) in [("y", true), ("w", true), ("z", z_kept)] {
            assert_eq!(
                kept.contains(&format!("/{name}/")),
                expect,
                "{name}: {kept} {dropped}"
            );
        }
        if !z_kept {
            let z = dropped.lines().find(|l| l.contains("/z/")).unwrap();
            assert!(
                z.contains("the hand turned the released object 24.5° > 20° (at frame 700; it touches it up to frame 692 with left_finger)"),
                "{z}"
            );
        }
    }
    let o = dexwarp(&[
        "filter",
        turned.to_str().unwrap(),
        "--out",
        keep.to_str().unwrap(),
        "--max-release-turn-deg",
        "-3",
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("angle in degrees > 0"),
        "{}",
        stderr(&o)
    );
    let o = dexwarp(&[
        "filter",
        dir.path().join("empty").to_str().unwrap(),
        "--out",
        keep.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let o = dexwarp(&[
        "filter",
        out.to_str().unwrap(),
        "--out",
        keep.to_str().unwrap(),
        "--min-converged",
        "2",
    ]);
    assert!(!o.status.success() && stderr(&o).contains("from 0 to 1"));
}

#[test]
fn synth_writes_a_demo_that_validates_and_refuses_unknown_names() {
    let dir = tempfile::tempdir().unwrap();
    let demo = dir.path().join("box.demo.json");
    let synth = || {
        dexwarp(&[
            "synth",
            "--object",
            "small_box",
            "--robot",
            repo("robots/parallel_gripper.urdf").to_str().unwrap(),
            "--motion",
            "lift_place",
            "--out",
            demo.to_str().unwrap(),
        ])
    };
    let o = synth();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        dir.path().join("small_box.obj").is_file(),
        "the mesh is written beside the demo"
    );
    let first = std::fs::read(&demo).unwrap();
    // Validate it in the kitchen: the synthesized grasp holds.
    let out = dir.path().join("check");
    let o = dexwarp(&[
        "validate",
        demo.to_str().unwrap(),
        "--scene",
        repo("scenes/kitchen.json").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(
        report["physics"]["verdict"], "pass",
        "{}",
        report["physics"]
    );
    assert!(out.join("frames.csv").is_file());
    // It says where the grasp's closing left the box, as the report gives it.
    let onset = &report["physics"]["onset"];
    let said = format!(
        "onset: the object is {:.1} mm and {:.1}° off its plan at the first contact frame {}",
        onset["position_error_mm"].as_f64().unwrap(),
        onset["rotation_error_deg"].as_f64().unwrap(),
        onset["frame"].as_u64().unwrap()
    );
    assert!(stderr(&o).contains(&said), "{}", stderr(&o));
    // Deterministic: the same arguments give the same bytes.
    let o = synth();
    assert!(o.status.success());
    assert!(
        std::fs::read(&demo).unwrap() == first,
        "synth is not deterministic"
    );
    // Unknown names list what is available.
    let o = dexwarp(&[
        "synth", "--object", "kettle", "--robot", "x.urdf", "--motion", "pour", "--out", "k.json",
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("valid objects are: cube"),
        "{}",
        stderr(&o)
    );
    let o = dexwarp(&[
        "synth",
        "--object",
        "mug",
        "--robot",
        repo("robots/human_hand.urdf").to_str().unwrap(),
        "--motion",
        "juggle",
        "--out",
        dir.path().join("m.json").to_str().unwrap(),
    ]);
    assert!(!o.status.success() && stderr(&o).contains("valid motions are: lift_place"));
}

#[test]
fn validate_errors_name_what_is_missing() {
    let dir = tempfile::tempdir().unwrap();
    gripper_fixture(dir.path());
    let demo = dir.path().join("box.demo.json");
    let out = dir.path().join("v");
    let o = dexwarp(&[
        "validate",
        demo.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("names no scene") && stderr(&o).contains("--scene"),
        "{}",
        stderr(&o)
    );
    let o = dexwarp(&[
        "validate",
        demo.to_str().unwrap(),
        "--scene",
        dir.path().join("scene.json").to_str().unwrap(),
        "--barrier",
        "cupboard",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("\"cupboard\" is not an item"),
        "{}",
        stderr(&o)
    );
    assert!(!out.join("report.json").exists());
}

#[test]
fn reproduce_runs_on_a_scene_folder_and_refuses_a_folder_without_configs() {
    let root = tempfile::tempdir().unwrap();
    let configs = root.path().join("scenes/configs");
    std::fs::create_dir_all(&configs).unwrap();
    let config = gripper_fixture(root.path());
    let text = std::fs::read_to_string(&config)
        .unwrap()
        .replace("\"box.demo.json\"", "\"../../box.demo.json\"")
        .replace("\"scene.json\"", "\"../../scene.json\"");
    std::fs::write(configs.join("box_lift.json"), text).unwrap();
    let out = root.path().join("out");
    // Standard error is a pipe here, as in a Slurm or CI log: progress comes as lines.
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_dexwarp"))
        .args([
            "reproduce",
            "--quick",
            "--root",
            root.path().to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .env("DEXWARP_PROGRESS_S", "0.05")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    // Three LM thresholds on each objective, Adam and the baseline for the one config.
    assert!(stderr(&o).contains("8 runs"), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("reproduce: 8/8 (100 %) in "),
        "{}",
        stderr(&o)
    );
    assert!(out.join("summary.md").is_file() && out.join("index.html").is_file());
    let o = dexwarp(&[
        "reproduce",
        "--root",
        out.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("no scenes/configs"),
        "{}",
        stderr(&o)
    );
}

/// `validate --grasp-only`: the teapot's recorded grasp holds; the cube's with the hand lifted
/// 5 cm off it at every contact frame lets it fall, and `--strict` exits 3.
#[test]
fn validate_grasp_only_tells_a_holding_grasp_from_an_empty_hand() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("teapot");
    let o = dexwarp(&[
        "validate",
        repo("scenes/demos/teapot.demo.json").to_str().unwrap(),
        "--grasp-only",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("the grasp holds"), "{}", stderr(&o));
    let g: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("grasp.json")).unwrap()).unwrap();
    assert_eq!(g["format"], "dexwarp.grasp/2");
    assert_eq!(g["holds"], true);
    assert_eq!(g["stability"]["frames"].as_array().unwrap().len(), 8);
    // Carried over the contact segment without the table, the pot follows the hand.
    let carried = &g["carry"]["tracking"];
    assert!(
        carried["mean_rotation_error_deg"].as_f64().unwrap() < 5.0,
        "{carried}"
    );
    assert!(
        carried["max_position_error_mm"].as_f64().unwrap() < 10.0,
        "{carried}"
    );
    assert!(!out.join("report.json").exists());

    let mut demo: serde_json::Value =
        serde_json::from_slice(&std::fs::read(repo("scenes/demos/cube.demo.json")).unwrap())
            .unwrap();
    let demos = repo("scenes/demos");
    for key in ["robot", "scene"] {
        let p = demos.join(demo[key].as_str().unwrap());
        demo[key] = p.to_str().unwrap().into();
    }
    let mesh = demos.join(demo["object"]["mesh"].as_str().unwrap());
    demo["object"]["mesh"] = mesh.to_str().unwrap().into();
    let mut lifted = 0;
    for f in demo["frames"].as_array_mut().unwrap() {
        if f["contacts"].as_array().is_some_and(|c| !c.is_empty()) {
            let z = f["wrist"]["position"][2].as_f64().unwrap();
            f["wrist"]["position"][2] = (z + 0.05).into();
            lifted += 1;
        }
    }
    assert!(lifted > 100);
    let path = dir.path().join("empty_hand.demo.json");
    std::fs::write(&path, serde_json::to_vec(&demo).unwrap()).unwrap();
    let out = dir.path().join("empty");
    let o = dexwarp(&[
        "validate",
        path.to_str().unwrap(),
        "--grasp-only",
        "--strict",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains("does not hold"), "{}", stderr(&o));
    let g: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("grasp.json")).unwrap()).unwrap();
    assert_eq!(g["holds"], false);
    assert!(g["stability"]["max_mm"].as_f64().unwrap() > 30.0);
    // Carried, the cube falls out of the lifted hand: the carry stops one drop window after.
    let reasons = g["reasons"].to_string();
    assert!(
        reasons.contains("carried, the object drops out of the grasp"),
        "{reasons}"
    );
    let c = &g["carry"];
    assert!(
        c["frames_replayed"].as_u64().unwrap()
            < c["last_frame"].as_u64().unwrap() - c["first_frame"].as_u64().unwrap(),
        "{c}"
    );
}

/// Every command's `--help` lists its own options first and the size limits once, under one
/// "Limits" heading, with the same text everywhere.
#[test]
fn help_shows_each_commands_options_before_the_limits() {
    let limits_of = |command: &str| -> String {
        let o = dexwarp(&[command, "--help"]);
        assert!(o.status.success(), "{command}: {}", stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        let options = text
            .find("\nOptions:\n")
            .unwrap_or_else(|| panic!("{command}: {text}"));
        let limits = text
            .find("\nLimits:\n")
            .unwrap_or_else(|| panic!("{command}: {text}"));
        assert!(options < limits, "{command}: the limits come first");
        let (own, rest) = text.split_at(limits);
        assert!(
            !own.contains("--max-frames"),
            "{command}: a limit among its options"
        );
        // `rest` starts with the newline before the heading.
        let block: String = rest
            .lines()
            .skip(2)
            .take_while(|l| l.is_empty() || l.starts_with(' '))
            .collect::<Vec<_>>()
            .join("\n");
        assert!(block.contains("--max-frames") && block.contains("--allow-special-files"));
        // The same words; clap lays them out in one or two columns by the command's other
        // options.
        block.split_whitespace().collect::<Vec<_>>().join(" ")
    };
    let first = limits_of("validate");
    for command in [
        "reproduce",
        "synth",
        "robot",
        "warp",
        "batch",
        "augment",
        "filter",
        "report",
        "export",
        "import",
    ] {
        assert_eq!(limits_of(command), first, "{command}");
    }
}
