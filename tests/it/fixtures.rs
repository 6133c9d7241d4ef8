//! Small input files for integration tests, written into a temporary folder.

use std::path::{Path, PathBuf};

use dexwarp::model::demo::{Contact, Demo, Frame, ObjectInfo};
use dexwarp::robot::Robot;
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

/// A path in the repository.
pub fn repo(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

/// A gripper lifting a small box over a short wall, with exact correspondences (D_C = 0).
/// Writes `scene.json`, `box.demo.json` and `lift.config.json` into `dir`.
pub fn gripper_fixture(dir: &Path) -> PathBuf {
    let robot_path = repo("robots/parallel_gripper.urdf");
    let robot = Robot::from_urdf_file(&robot_path, &dexwarp::Limits::default()).unwrap();
    let n = 60;
    let down = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI);
    let mut poses = robot.new_link_poses();
    let mut frames = Vec::new();
    for i in 0..n {
        let s = ((i as f64 - 10.0) / 40.0).clamp(0.0, 1.0);
        let e = s * s * (3.0 - 2.0 * s);
        let lift = 0.12 * (std::f64::consts::PI * s).sin();
        let object = Isometry3::from_parts(
            Translation3::new(0.3 * e, 0.0, 0.93 + lift),
            UnitQuaternion::identity(),
        );
        let wrist =
            Isometry3::from_parts(Translation3::new(0.3 * e, 0.0, 0.93 + lift + 0.13), down);
        let q = vec![0.024];
        let mut contacts = Vec::new();
        if (10..50).contains(&i) {
            robot.forward_kinematics(&wrist, &q, &mut poses);
            for (link, y) in [("left_finger", 0.002), ("right_finger", -0.002)] {
                let id = robot.link_id(link).unwrap();
                for z in [0.04, 0.045, 0.05] {
                    let hand_point = Point3::new(0.0, y, z);
                    let world = poses[id.index()] * hand_point;
                    contacts.push(Contact {
                        link: link.into(),
                        hand_point,
                        object_point: object.inverse() * world,
                    });
                }
            }
        }
        frames.push(Frame {
            object,
            wrist,
            joints: q,
            contacts,
        });
    }
    let demo = Demo {
        name: "box".into(),
        fps: 30.0,
        robot: robot_path,
        object: ObjectInfo {
            name: "small_box".into(),
            mesh: repo("scenes/objects/small_box.obj"),
            mass: 0.1,
        },
        joint_names: vec!["finger_joint1".into()],
        frames,
        timewarp: None,
        scene: None,
        barriers: Vec::new(),
        wrist_link: None,
        source: dir.join("box.demo.json"),
    };
    demo.save(&dir.join("box.demo.json")).unwrap();
    std::fs::write(
        dir.join("scene.json"),
        serde_json::json!({
            "format": "dexwarp.scene/1", "name": "bench",
            "items": [
                {"name": "table", "role": "support", "pose": {"position": [0.2, 0.0, 0.45]},
                 "shape": {"type": "box", "size": [1.2, 0.8, 0.9]}},
                {"name": "wall", "role": "barrier", "pose": {"position": [0.15, 0.6, 1.1]},
                 "shape": {"type": "box", "size": [0.3, 0.1, 0.3]}}
            ]
        })
        .to_string(),
    )
    .unwrap();
    let config = dir.join("lift.config.json");
    std::fs::write(
        &config,
        serde_json::json!({
            "format": "dexwarp.config/1", "name": "box_lift", "demo": "box.demo.json",
            "scene": "scene.json",
            "waypoints": [{"position": [0.12, -0.1, 1.12], "t": 30, "t_new": 36}],
            "barriers": ["wall"], "end": [0.35, -0.05, 0.93]
        })
        .to_string(),
    )
    .unwrap();
    config
}

/// Runs the `dexwarp` binary with `args`.
pub fn dexwarp(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_dexwarp"))
        .args(args)
        .output()
        .expect("run dexwarp")
}

/// The standard error of a finished run, as text.
pub fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}
