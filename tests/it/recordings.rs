//! A real recording in: the shared TACO take (optical motion capture, a left hand lifting an
//! object; CC BY 4.0, see `../shared/recordings/README.md`) imported onto the built-in
//! human hand. Outside CI a missing `../shared/recordings` is said in one line and the test
//! is skipped; under CI (`CI` set) it fails.

use std::path::PathBuf;

use crate::fixtures::{dexwarp, repo, stderr};

/// The shared take's folder, or `None` with a message (a failure under CI).
fn take() -> Option<PathBuf> {
    let dir = std::env::var_os("DEXWARP_RECORDINGS")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo("../shared/recordings"))
        .join("taco_20231104_017");
    if dir.join("frames.csv").is_file() {
        return Some(dir);
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "no recording at {} (CI must have ../shared/recordings)",
        dir.display()
    );
    eprintln!(
        "skipped: no recording at {} (set DEXWARP_RECORDINGS)",
        dir.display()
    );
    None
}

fn json(p: &std::path::Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

/// `import --keypoints` of the take's `frames` (a left hand, 30 fps, 0.2 kg) onto `robot`,
/// with `extra` arguments, into `out`; it must succeed and its stderr is returned.
fn import_take(
    take: &std::path::Path,
    frames: &std::path::Path,
    robot: &std::path::Path,
    extra: &[&str],
    out: &std::path::Path,
) -> String {
    let mut args = vec![
        "import",
        "--keypoints",
        frames.to_str().unwrap(),
        "--fps",
        "30",
        "--handedness",
        "left",
        "--robot",
        robot.to_str().unwrap(),
    ];
    args.extend(extra);
    let mesh = take.join("object.obj");
    args.extend(["--mesh", mesh.to_str().unwrap(), "--mass", "0.2"]);
    args.extend(["--out", out.to_str().unwrap()]);
    let o = dexwarp(&args);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    err
}

/// The deepest the import record says the cleaned hand is in the object, over its frames [mm].
fn deepest(import: &serde_json::Value) -> f64 {
    import["per_frame"]["penetration_mm"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| d.as_f64().unwrap())
        .fold(0.0, f64::max)
}

/// `validate` of the demonstration `demo` into `dir`; its report, after checking that the
/// ensemble keeps it with a pass fraction of at least 0.75.
fn validate_keeps(demo: &std::path::Path, dir: &std::path::Path) -> serde_json::Value {
    let o = dexwarp(&[
        "validate",
        demo.to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = json(&dir.join("report.json"));
    let ensemble = &report["physics"]["ensemble"];
    let fraction = ensemble["pass_fraction"].as_f64().unwrap();
    assert!(
        fraction >= 0.75 && ensemble["decision"] == "keep",
        "pass fraction {fraction}: {}",
        report["physics"]["reasons"]
    );
    report
}

#[test]
fn the_shared_take_imports_with_its_mesh_repaired_its_table_inferred_and_a_grasp_that_holds() {
    let Some(take) = take() else { return };
    let tmp = tempfile::tempdir().unwrap();
    // The first 60 frames: the approach, the grasp and the start of the lift.
    let text = std::fs::read_to_string(take.join("frames.csv")).unwrap();
    let head: Vec<&str> = text.lines().take(61).collect();
    let frames = tmp.path().join("frames.csv");
    std::fs::write(&frames, head.join("\n") + "\n").unwrap();
    let out = tmp.path().join("out/taco.demo.json");
    let err = import_take(&take, &frames, &repo("robots/human_hand.urdf"), &[], &out);
    // The open mesh as shipped: three zero-volume slivers, removed and said.
    assert!(
        err.contains("object.obj repaired: removed 3 zero-volume slivers"),
        "{err}"
    );
    assert!(err.contains("mirrored"), "{err}");
    let demo = json(&out);
    assert_eq!(demo["scene"], "taco.scene.json");
    assert_eq!(demo["object"]["mesh"], "taco.object.obj");
    assert!(
        demo["object"]["name"]
            .as_str()
            .unwrap()
            .ends_with("(mirrored)"),
        "{}",
        demo["object"]["name"]
    );
    assert_eq!(demo["frames"].as_array().unwrap().len(), 60);
    // The table: its top where the object rests (about 0.55 m, see the take's README).
    let scene = json(&out.with_file_name("taco.scene.json"));
    let table = &scene["items"][0];
    assert_eq!(table["name"], "table");
    assert_eq!(table["role"], "support");
    let top = table["pose"]["position"][2].as_f64().unwrap() + 0.02;
    assert!((top - 0.55).abs() < 0.01, "table top at {top}");
    // The recording touches from about frame 18 (its README); the cleaned hand is out of
    // the object (at most 2 mm deep) on every frame.
    let import = &json(&out.with_file_name("taco.import.json"))["import"];
    let first = import["touch_frames"][0].as_u64().unwrap();
    assert!((15..=21).contains(&first), "first touch at {first}");
    assert_eq!(
        import["per_frame"]["penetration_mm"]
            .as_array()
            .unwrap()
            .len(),
        60
    );
    let deepest = deepest(import);
    assert!(
        deepest <= 2.0,
        "the cleaned hand is {deepest} mm in the object"
    );
    // The fingertips are on the recorded contacts (the pads on the faces the recording
    // touches: the four fingers inside the box's end wall, the thumb outside it).
    let refined = &import["refinement"];
    let d_c = refined["d_c_mm"].as_f64().unwrap();
    assert!(d_c <= 5.0, "D_C {d_c} mm");
    // A refinement is kept only when it brings the pads closer without pressing the hand
    // deeper; the record says both depths.
    let depth = |k: &str| refined[k].as_f64().unwrap_or(f64::NAN);
    let (before, after) = (depth("depth_before_mm"), depth("depth_refined_mm"));
    assert!(before.is_finite() && after.is_finite(), "{refined}");
    if refined["kept"] == true {
        assert!(after <= before, "{refined}");
    }
    // The recorded rest pose stands a few millimetres and degrees off the table (4.0 mm,
    // 2.3 degrees as the object settles) and is moved to where it rests; the last of the 60
    // frames is in the air, mid-lift, and stays as recorded.
    let rest = &import["rest_correction"];
    assert_eq!(rest["start_corrected"], true, "{rest}");
    let moved = rest["start_mm"].as_f64().unwrap();
    assert!((1.0..15.0).contains(&moved), "{rest}");
    assert_eq!(rest["end_corrected"], false, "{rest}");
    // The repaired mesh is closed: validate replays it as its decomposition, not its hull,
    // and finds the scene from the demonstration; the grasp holds through the start of the
    // lift, under the ensemble's perturbations.
    let report = validate_keeps(&out, &tmp.path().join("val"));
    assert_eq!(report["physics"]["replay"]["object_shape"], "decomposition");
    // Settled, the object waits for the hand where the replay put it: at the first contact
    // it is within 5 mm of its plan (3.4-3.8 mm: the hand closes from 5 mm off onto its
    // contacts in that frame; 7.5 mm before the contact when the recorded tilt was kept).
    let onset = report["physics"]["onset"]["position_error_mm"]
        .as_f64()
        .unwrap();
    assert!(
        onset < 5.0,
        "object {onset} mm off its plan at first contact"
    );
}

/// The whole take onto the community Allegro (a right hand: the recording mirrored), with
/// the keypoint map in `robots/maps/` and the retargeting parameters it carries: one
/// command. The cleaned hand is out of the object, its pads on the recorded contacts, and the
/// grasp carries the box through the lift and back under the ensemble's perturbations.
#[test]
fn the_shared_take_imports_onto_the_community_allegro_with_its_map() {
    let Some(take) = take() else { return };
    let Some(hands) = crate::hands::community() else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("taco.demo.json");
    let urdf = hands.join("allegro_hand/allegro_hand_right.urdf");
    let map = repo("robots/maps/allegro_hand_right.keypoints.json");
    let map = ["--keypoint-map", map.to_str().unwrap()];
    import_take(&take, &take.join("frames.csv"), &urdf, &map, &out);
    let import = &json(&out.with_file_name("taco.import.json"))["import"];
    // The map's parameters were used.
    assert_eq!(
        import["retarget"]["contact_weight"], 10,
        "{}",
        import["retarget"]
    );
    let deepest = deepest(import);
    assert!(
        deepest <= 2.0,
        "the cleaned hand is {deepest} mm in the object"
    );
    let d_c = import["refinement"]["d_c_mm"].as_f64().unwrap();
    assert!(d_c <= 5.0, "D_C {d_c} mm");
    validate_keeps(&out, &tmp.path().join("val"));

    // An identity warp (the end where the object is at the last contact frame) gives the
    // grasp back: its thumb arrives as the box lifts, so the warp holds the carry's grasp and
    // follows the recording while the hand closes on the resting box.
    let demo = json(&out);
    let last = import["touch_frames"][1].as_u64().unwrap() as usize;
    let end = &demo["frames"][last]["object"]["position"];
    let config = tmp.path().join("identity.config.json");
    let text = serde_json::json!({
        "format": "dexwarp.config/1", "name": "identity", "demo": "taco.demo.json",
        "scene": "taco.scene.json", "end": end,
    });
    std::fs::write(&config, text.to_string()).unwrap();
    let dir = tmp.path().join("identity");
    let o = dexwarp(&[
        "warp",
        "--config",
        config.to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
        "--no-physics",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = json(&dir.join("report.json"));
    let held = &report["ik"]["held"];
    assert_eq!(held["closing"], true, "{held}");
    let first = import["touch_frames"][0].as_u64().unwrap();
    assert!(first < held["carry"][0].as_u64().unwrap(), "{held}");
    let warped = report["metrics"]["d_c_mm"]["warped"].as_f64().unwrap();
    assert!(
        (warped - d_c).abs() <= 0.5,
        "D_C {warped} mm against {d_c} mm"
    );
}
