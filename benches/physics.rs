//! Physics stage: `physics::validate` on a 700-frame parallel-gripper pick and place at
//! 30 fps (5,592 steps of 1/240 s, plus penetration queries and 8 stability tests).
//! Also `validate_committed_demo`: the human hand with the teapot and the frying pan, the
//! Allegro hand with the apple, the gripper with the small box (`scenes/demos`).
//! Issue target: under 0.5 s median, release, one core. Run with
//! `cargo bench --bench physics`.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use dexwarp::Limits;
use dexwarp::geometry::Mesh;
use dexwarp::model::demo::ObjectInfo;
use dexwarp::model::scene::ShapeJson;
use dexwarp::model::{Contact, Demo, Frame, Role, Scene, SceneItem};
use dexwarp::physics::{Params, validate};
use dexwarp::robot::Robot;
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

fn main() {
    divan::main();
}

const FRAMES: usize = 700;
const BOX: [f64; 3] = [0.03, 0.04, 0.06];
const TCP_Z: f64 = 0.1034;
const Q_OPEN: f64 = 0.03;
const Q_CLOSED: f64 = 0.019;
/// `(frame of 231, wrist offset from the grasp pose, jaw q)`; the bench stretches it.
const KEYS: [(f64, [f64; 3], f64); 10] = [
    (0.0, [0.0, 0.0, 0.10], Q_OPEN),
    (15.0, [0.0, 0.0, 0.10], Q_OPEN),
    (45.0, [0.0, 0.0, 0.0], Q_OPEN),
    (60.0, [0.0, 0.0, 0.0], Q_CLOSED),
    (90.0, [0.0, 0.0, 0.15], Q_CLOSED),
    (140.0, [0.25, 0.0, 0.15], Q_CLOSED),
    (170.0, [0.25, 0.0, 0.0], Q_CLOSED),
    (185.0, [0.25, 0.0, 0.0], Q_OPEN),
    (215.0, [0.25, 0.0, 0.10], Q_OPEN),
    (230.0, [0.25, 0.0, 0.10], Q_OPEN),
];

struct Input {
    robot: Robot,
    demo: Demo,
    scene: Scene,
    mesh: Mesh,
}

fn box_mesh() -> Mesh {
    let h = Vector3::from(BOX) / 2.0;
    let vertices = (0..8)
        .map(|i: usize| {
            let s = |bit: usize| if i >> bit & 1 == 1 { 1.0 } else { -1.0 };
            Point3::new(s(0) * h.x, s(1) * h.y, s(2) * h.z)
        })
        .collect();
    let triangles = vec![
        [0, 3, 1],
        [0, 2, 3],
        [4, 5, 7],
        [4, 7, 6],
        [0, 1, 5],
        [0, 5, 4],
        [3, 2, 6],
        [3, 6, 7],
        [0, 4, 6],
        [0, 6, 2],
        [1, 3, 7],
        [1, 7, 5],
    ];
    Mesh {
        vertices,
        triangles,
    }
}

fn state(f: f64) -> (Vector3<f64>, f64) {
    let i = KEYS
        .iter()
        .rposition(|k| k.0 <= f)
        .unwrap()
        .min(KEYS.len() - 2);
    let (a, b) = (&KEYS[i], &KEYS[i + 1]);
    let u = ((f - a.0) / (b.0 - a.0)).clamp(0.0, 1.0);
    let u = u * u * (3.0 - 2.0 * u);
    (
        Vector3::from(a.1).lerp(&Vector3::from(b.1), u),
        a.2 + (b.2 - a.2) * u,
    )
}

fn input() -> Input {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let urdf = root.join("robots/parallel_gripper.urdf");
    let robot = Robot::from_urdf_file(&urdf, &Limits::default()).unwrap();
    let down = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), PI);
    let grasp = Vector3::new(0.0, 0.0, BOX[2] / 2.0 + TCP_Z);
    let wrist = |f: f64| Isometry3::from_parts(Translation3::from(grasp + state(f).0), down);
    let rest = Isometry3::translation(0.0, 0.0, BOX[2] / 2.0);
    let carry = wrist(60.0).inverse() * rest;
    let frames = (0..FRAMES)
        .map(|i| {
            let f = i as f64 * 230.0 / (FRAMES - 1) as f64;
            let held = (60.0..=170.0).contains(&f);
            let contact = |link: &str, y: f64| Contact {
                link: link.into(),
                hand_point: Point3::new(0.0, 0.0, 0.045),
                object_point: Point3::new(0.0, y, 0.0),
            };
            Frame {
                object: wrist(f.clamp(60.0, 170.0)) * carry,
                wrist: wrist(f),
                joints: vec![state(f).1],
                contacts: if held {
                    vec![
                        contact("left_finger", -BOX[1] / 2.0),
                        contact("right_finger", BOX[1] / 2.0),
                    ]
                } else {
                    Vec::new()
                },
            }
        })
        .collect();
    let demo = Demo {
        name: "bench_gripper".into(),
        fps: 30.0,
        robot: urdf,
        object: ObjectInfo {
            name: "small_box".into(),
            mesh: PathBuf::from("small_box.obj"),
            mass: 0.1,
        },
        joint_names: robot.actuated_names(),
        frames,
        timewarp: None,
        source: PathBuf::from("bench.demo.json"),
        scene: None,
        barriers: Vec::new(),
        wrist_link: None,
    };
    let item = |name: &str, role, pose, size| SceneItem {
        name: String::from(name),
        role,
        pose,
        shape: ShapeJson::Box { size },
    };
    let scene = Scene {
        name: "bench".into(),
        items: vec![
            item(
                "table",
                Role::Support,
                Isometry3::translation(0.15, 0.0, -0.02),
                [0.8, 0.4, 0.04],
            ),
            item(
                "beam",
                Role::Barrier,
                Isometry3::translation(-0.3, 0.3, 0.25),
                [0.01, 0.3, 0.02],
            ),
        ],
        source: Path::new("bench_scene.json").to_path_buf(),
    };
    Input {
        robot,
        demo,
        scene,
        mesh: box_mesh(),
    }
}

/// The replay's parameters: one replay with the defaults (rest spans out of the hand's reach
/// skipped, stop after a drop), one with every step simulated, or the whole default ensemble
/// verdict (8 replays, early stop).
fn params(mode: &str) -> Params {
    match mode {
        "every_step" => Params {
            skip_rest: false,
            stop_after_drop: false,
            ..Params::single_replay()
        },
        "ensemble" => Params::default(),
        _ => Params::single_replay(),
    }
}

/// The whole stage: replay, penetration queries, stability tests, verdict. The gripper
/// rests out of reach for the first 45 and the last 200 frames: `default` skips those
/// spans, `every_step` steps them.
#[divan::bench(sample_count = 20, args = ["default", "every_step", "ensemble"])]
fn validate_700_frames(bencher: divan::Bencher, mode: &str) {
    let input = input();
    let barriers = vec!["beam".to_string()];
    let params = params(mode);
    let run = || {
        validate(
            &input.robot,
            &input.demo,
            &input.scene,
            &barriers,
            &input.mesh,
            &params,
            &Limits::default(),
        )
        .unwrap()
    };
    let report = run();
    assert!(report.passed(), "{:?}", report.reasons);
    eprintln!(
        "validate_700_frames ({mode}): {} steps, {} skipped; replay {:.3} s, penetration {:.3} s, stability {:.3} s, ensemble members {:.3} s (one run)",
        report.replay.steps,
        report.replay.skipped_steps,
        report.timing_s.replay,
        report.timing_s.penetration,
        report.timing_s.stability,
        report.timing_s.ensemble
    );
    bencher.bench_local(run);
}

/// A committed base demonstration of `scenes/demos`, loaded as `dexwarp validate` does.
fn committed(name: &str) -> (Input, Vec<String>) {
    let limits = Limits::default();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/demos/{name}.demo.json"));
    let mut demo = Demo::load(&path, &limits).unwrap();
    let robot = Robot::from_urdf_file(&demo.robot, &limits).unwrap();
    demo.check_robot(&robot).unwrap();
    let scene = Scene::load(demo.scene.as_ref().unwrap(), &limits).unwrap();
    let mesh = Mesh::load(&demo.object.mesh, Vector3::repeat(1.0), &limits).unwrap();
    let barriers = demo.barriers.clone();
    (
        Input {
            robot,
            demo,
            scene,
            mesh,
        },
        barriers,
    )
}

/// `validate` of a committed demonstration under `params`, one run printed, then timed.
fn bench_committed(bencher: divan::Bencher, name: &str, label: &str, params: &Params) {
    let (input, barriers) = committed(name);
    let run = || {
        validate(
            &input.robot,
            &input.demo,
            &input.scene,
            &barriers,
            &input.mesh,
            params,
            &Limits::default(),
        )
        .unwrap()
    };
    let report = run();
    eprintln!(
        "{name} ({label}): {} ({} steps, {} skipped; replay {:.3} s, penetration {:.3} s, stability {:.3} s, one run)",
        report.verdict(),
        report.replay.steps,
        report.replay.skipped_steps,
        report.timing_s.replay,
        report.timing_s.penetration,
        report.timing_s.stability
    );
    bencher.bench_local(run);
}

/// The whole stage on a committed demonstration: the human hand with the teapot and the
/// frying pan, the Allegro hand with the apple, the parallel gripper with the small box.
/// The decomposition is cached after the first run (in the process), as in a batch.
#[divan::bench(sample_count = 5, args = ["teapot", "frying_pan", "apple", "small_box"])]
fn validate_committed_demo(bencher: divan::Bencher, name: &str) {
    bench_committed(bencher, name, "default", &Params::single_replay());
}

/// The contact-heavy case: the human hand pinching the teapot's handle (about 40 contact
/// manifolds per step with the hand on it), one replay with the defaults and with every step
/// simulated, and the whole default ensemble.
#[divan::bench(sample_count = 5, args = ["default", "every_step", "ensemble"])]
fn teapot_contact_heavy(bencher: divan::Bencher, mode: &str) {
    bench_committed(bencher, "teapot", mode, &params(mode));
}
