//! Bad input of every class is refused with a message naming the file, the field and what was
//! expected; good input that is only slightly off (quaternion norms) is normalized.

use std::path::Path;

use dexwarp::Limits;
use dexwarp::geometry::Mesh;
use dexwarp::model::scene::Scene;
use dexwarp::model::{Demo, WarpConfig};
use dexwarp::robot::Robot;
use serde_json::{Value, json};

use crate::fixtures::gripper_fixture;

/// Loads a demonstration and binds it to its robot, as every command does.
fn load(path: &Path, limits: &Limits) -> dexwarp::Result<Demo> {
    let mut demo = Demo::load(path, limits)?;
    let robot = Robot::from_urdf_file(&demo.robot, limits)?;
    demo.check_robot(&robot)?;
    Ok(demo)
}

/// Writes a mutated copy of the fixture demo and returns the error message of loading it.
fn error_after(edit: impl FnOnce(&mut Value)) -> String {
    let dir = tempfile::tempdir().unwrap();
    gripper_fixture(dir.path());
    let path = dir.path().join("box.demo.json");
    let mut v: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    edit(&mut v);
    std::fs::write(&path, serde_json::to_vec(&v).unwrap()).unwrap();
    let msg = load(&path, &Limits::default()).unwrap_err().to_string();
    assert!(
        msg.contains("box.demo.json"),
        "message must name the file: {msg}"
    );
    msg
}

fn error_of_text(edit: impl FnOnce(String) -> String) -> String {
    let dir = tempfile::tempdir().unwrap();
    gripper_fixture(dir.path());
    let path = dir.path().join("box.demo.json");
    let text = edit(std::fs::read_to_string(&path).unwrap());
    std::fs::write(&path, text).unwrap();
    load(&path, &Limits::default()).unwrap_err().to_string()
}

fn has(msg: &str, parts: &[&str]) {
    for p in parts {
        assert!(msg.contains(p), "expected {p:?} in: {msg}");
    }
}

#[test]
fn the_fixture_itself_loads() {
    let dir = tempfile::tempdir().unwrap();
    gripper_fixture(dir.path());
    let demo = load(&dir.path().join("box.demo.json"), &Limits::default()).unwrap();
    assert_eq!(demo.frames.len(), 60);
    assert_eq!(
        demo.contact_segment().map(|s| (s.start, s.end)),
        Some((10, 49))
    );
}

#[test]
fn malformed_json_gives_line_and_column() {
    let msg = error_of_text(|t| t[..t.len() / 2].to_string());
    has(&msg, &["box.demo.json", "line ", "column"]);
    let msg = error_of_text(|t| t.replacen("\"fps\":30.0", "\"fps\":NaN", 1));
    has(&msg, &["line ", "no NaN"]);
    let msg = error_of_text(|t| t.replacen("\"fps\":30.0", "\"fps\":1e999", 1));
    has(&msg, &["line "]);
}

#[test]
fn wrong_types_name_the_json_path() {
    let msg = error_after(|v| v["frames"][3]["joints"] = json!("open"));
    has(&msg, &["frames[3].joints", "invalid type"]);
    let msg = error_after(|v| v["frames"][12]["contacts"][1]["hand_point"] = json!([0.0, 1.0]));
    has(&msg, &["frames[12].contacts[1].hand_point"]);
    let msg = error_after(|v| v["format"] = json!("dexwarp.config/1"));
    has(&msg, &["format", "dexwarp.demo/1"]);
    let msg = error_after(|v| v["fps"] = json!(0.0));
    has(&msg, &["fps", "from 0.1 to 10000"]);
}

#[test]
fn quaternions_zero_or_far_from_unit_are_refused_and_near_unit_normalized() {
    let msg = error_after(|v| v["frames"][2]["object"]["orientation"] = json!([0, 0, 0, 0]));
    has(&msg, &["frames[2].object.orientation", "zero quaternion"]);
    let msg = error_after(|v| v["frames"][7]["wrist"]["orientation"] = json!([0.0, 1.0, 1.0, 0.0]));
    has(&msg, &["frames[7].wrist.orientation", "norm 1.414214"]);
    // Rounded storage (norm 1.0004) is accepted and normalized.
    let dir = tempfile::tempdir().unwrap();
    gripper_fixture(dir.path());
    let path = dir.path().join("box.demo.json");
    let mut v: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    v["frames"][0]["object"]["orientation"] = json!([1.0004, 0.0, 0.0, 0.0]);
    std::fs::write(&path, serde_json::to_vec(&v).unwrap()).unwrap();
    let demo = load(&path, &Limits::default()).unwrap();
    assert!((demo.frames[0].object.rotation.quaternion().norm() - 1.0).abs() < 1e-12);
}

#[test]
fn joints_and_links_must_match_the_robot() {
    let msg = error_after(|v| v["joint_names"] = json!(["fingr_joint1"]));
    has(
        &msg,
        &[
            "joint_names[0]",
            "\"fingr_joint1\" is not a joint",
            "finger_joint1",
        ],
    );
    let msg = error_after(|v| v["joint_names"] = json!(["finger_joint2"]));
    has(&msg, &["joint_names[0]", "mimic"]);
    let msg = error_after(|v| v["frames"][12]["contacts"][1]["link"] = json!("pinky"));
    has(
        &msg,
        &["frames[12].contacts[1].link", "\"pinky\" is not a link"],
    );
    let msg = error_after(|v| v["frames"][5]["joints"] = json!([0.02, 0.01]));
    has(
        &msg,
        &["frames[5].joints", "has 2 values", "joint_names (1)"],
    );
    let msg = error_after(|v| v["joint_names"] = json!(["finger_joint1", "finger_joint1"]));
    has(&msg, &["joint_names[1]", "appears twice"]);
}

#[test]
fn missing_or_unreadable_files_are_named() {
    let msg = error_after(|v| v["object"]["mesh"] = json!("nope/missing.obj"));
    has(
        &msg,
        &["object.mesh", "missing.obj", "relative to the file"],
    );
    let msg = error_after(|v| v["robot"] = json!("hands/none.urdf"));
    has(&msg, &["robot", "none.urdf"]);
    let dir = tempfile::tempdir().unwrap();
    let garbage = dir.path().join("bad.obj");
    std::fs::write(&garbage, "v 1 2\nf 1 2 9\n").unwrap();
    let msg = Mesh::load(&garbage, nalgebra::Vector3::repeat(1.0), &Limits::default())
        .unwrap_err()
        .to_string();
    has(&msg, &["bad.obj"]);
    let msg = Mesh::load(
        &dir.path().join("x.ply"),
        nalgebra::Vector3::repeat(1.0),
        &Limits::default(),
    )
    .unwrap_err()
    .to_string();
    has(&msg, &["x.ply"]);
}

#[test]
fn timewarp_must_be_increasing_output_times() {
    let msg = error_after(|v| v["timewarp"] = json!([0.0, 2.0, 1.0]));
    has(&msg, &["timewarp[2]", "strictly increasing"]);
    let msg = error_after(|v| v["timewarp"] = json!([0.0, 500.0]));
    has(&msg, &["timewarp[1]", "within the file's frames"]);
}

#[test]
fn absurd_sizes_are_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    gripper_fixture(dir.path());
    let path = dir.path().join("box.demo.json");
    let small = Limits {
        max_frames: 10,
        ..Limits::default()
    };
    has(
        &load(&path, &small).unwrap_err().to_string(),
        &["number of frames is 60", "--max-frames"],
    );
    let tiny_file = Limits {
        max_file_bytes: 1000,
        ..Limits::default()
    };
    has(
        &load(&path, &tiny_file).unwrap_err().to_string(),
        &["file size", "--max-file-mb"],
    );
    let few_contacts = Limits {
        max_contacts_per_frame: 2,
        ..Limits::default()
    };
    has(
        &load(&path, &few_contacts).unwrap_err().to_string(),
        &["contacts in one frame is 6", "--max-contacts"],
    );
    // A binary STL whose header claims 10^8 triangles is refused from the header alone.
    let stl = dir.path().join("huge.stl");
    let mut bytes = vec![0u8; 80];
    bytes.extend_from_slice(&100_000_000u32.to_le_bytes());
    std::fs::write(&stl, &bytes).unwrap();
    let msg = Mesh::load(&stl, nalgebra::Vector3::repeat(1.0), &Limits::default())
        .unwrap_err()
        .to_string();
    has(&msg, &["huge.stl", "100000000"]);
}

#[test]
fn scene_and_config_errors_name_the_item() {
    let dir = tempfile::tempdir().unwrap();
    let config = gripper_fixture(dir.path());
    let scene = dir.path().join("scene.json");
    let mut v: Value = serde_json::from_slice(&std::fs::read(&scene).unwrap()).unwrap();
    v["items"][1]["name"] = json!("table");
    std::fs::write(&scene, v.to_string()).unwrap();
    has(
        &Scene::load(&scene, &Limits::default())
            .unwrap_err()
            .to_string(),
        &["items[1].name", "used twice"],
    );
    v["items"][1]["name"] = json!("wall");
    v["items"][1]["role"] = json!("obstacle");
    std::fs::write(&scene, v.to_string()).unwrap();
    has(
        &Scene::load(&scene, &Limits::default())
            .unwrap_err()
            .to_string(),
        &["items[1].role", "unknown variant"],
    );
    v["items"][1]["role"] = json!("barrier");
    v["items"][1]["shape"] = json!({"type": "box", "size": [0.3, -0.1, 0.3]});
    std::fs::write(&scene, v.to_string()).unwrap();
    has(
        &Scene::load(&scene, &Limits::default())
            .unwrap_err()
            .to_string(),
        &["items[1].shape.size[1]", "> 0"],
    );
    v["items"][1]["shape"] = json!({"type": "box", "size": [0.3, 0.1, 0.3]});
    std::fs::write(&scene, v.to_string()).unwrap();
    // A config naming a support as a barrier.
    let mut c: Value = serde_json::from_slice(&std::fs::read(&config).unwrap()).unwrap();
    c["barriers"] = json!(["table"]);
    std::fs::write(&config, c.to_string()).unwrap();
    let cfg = WarpConfig::load(&config, &Limits::default()).unwrap();
    let s = Scene::load(&scene, &Limits::default()).unwrap();
    has(
        &cfg.check_scene(&s).unwrap_err().to_string(),
        &["barriers[0]", "is a support", "not a barrier"],
    );
    c["barriers"] = json!(["shelf"]);
    std::fs::write(&config, c.to_string()).unwrap();
    let cfg = WarpConfig::load(&config, &Limits::default()).unwrap();
    has(
        &cfg.check_scene(&s).unwrap_err().to_string(),
        &["barriers[0]", "\"shelf\" is not an item", "wall"],
    );
    c["params"] = json!({"alhpa_m": 0.3});
    std::fs::write(&config, c.to_string()).unwrap();
    has(
        &WarpConfig::load(&config, &Limits::default())
            .unwrap_err()
            .to_string(),
        &["params", "alhpa_m"],
    );
}
