//! Physics stage: physical laws of the replay world, then trajectory-level verdicts.
//!
//! The laws run in [`ReplayWorld`] with the default [`Params`] (the configuration the
//! reports use): two kinematic plates squeezing a cube lift it, a free cube falls as ½gt²,
//! a released cube comes to rest on its support. The trajectory tests build a pick-and-place
//! demonstration with `robots/parallel_gripper.urdf` and a small box, check that it passes,
//! and that broken versions fail for the right reason. Every assertion prints measured vs
//! expected.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use dexwarp::Limits;
use dexwarp::geometry::Mesh;
use dexwarp::geometry::shape::{CollisionShape, ShapeKind};
use dexwarp::model::demo::ObjectInfo;
use dexwarp::model::scene::ShapeJson;
use dexwarp::model::{Contact, Demo, Frame, Role, Scene, SceneItem};
use dexwarp::physics::world::{FixedItem, GripSample, MemberStart, ReplayWorld, Tag};
use dexwarp::physics::{DropCause, Params, PhysicsReport, object_shape, validate};
use dexwarp::robot::Robot;
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

const G: f64 = 9.81;

/// A closed, outward-wound box centred on the origin with full edge lengths `size`.
pub fn box_mesh(size: [f64; 3]) -> Mesh {
    let h = Vector3::from(size) / 2.0;
    let vertices = (0..8)
        .map(|i| {
            let s = |bit: usize| if i >> bit & 1 == 1 { 1.0 } else { -1.0 };
            Point3::new(s(0) * h.x, s(1) * h.y, s(2) * h.z)
        })
        .collect();
    // Vertex i has x from bit 0, y from bit 1, z from bit 2.
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

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A one-link "hand" made of two vertical plates facing each other across y, their inner
/// faces at `±inner` from the link origin.
fn plates(inner: f64) -> Robot {
    let t = 0.01;
    let y = inner + t / 2.0;
    let urdf = format!(
        r#"<robot name="plates"><link name="plates">
        <collision><origin xyz="0 {y} 0"/><geometry><box size="0.05 {t} 0.05"/></geometry></collision>
        <collision><origin xyz="0 -{y} 0"/><geometry><box size="0.05 {t} 0.05"/></geometry></collision>
        </link></robot>"#
    );
    Robot::from_urdf_str(
        &urdf,
        Path::new("."),
        Path::new("plates.urdf"),
        &Limits::default(),
    )
    .expect("plates URDF")
}

fn table() -> CollisionShape {
    CollisionShape::new(
        ShapeKind::Box {
            size: Vector3::new(1.0, 1.0, 0.04),
        },
        Isometry3::translation(0.0, 0.0, -0.02),
    )
    .unwrap()
}

fn at(x: f64, y: f64, z: f64) -> Isometry3<f64> {
    Isometry3::translation(x, y, z)
}

/// The 6 cm cube of the squeeze tests as the physics simulates it.
fn six_cm_cube(params: &Params) -> std::sync::Arc<dexwarp::physics::ObjectShape> {
    object_shape(&box_mesh([0.06; 3]), &params.decomposition)
        .unwrap()
        .0
}

fn smoothstep(u: f64) -> f64 {
    let u = u.clamp(0.0, 1.0);
    u * u * (3.0 - 2.0 * u)
}

/// Squeezes a 6 cm, 0.2 kg cube between the plates with the given overlap per side
/// (negative = gap), lifts 20 cm in 1 s, holds 0.5 s; returns the final error [m].
fn squeeze_lift(overlap: f64, params: &Params) -> f64 {
    squeeze_lift_grip(overlap, params).0
}

/// [`squeeze_lift`], with the plates' contact forces on the cube at the end of the hold.
fn squeeze_lift_grip(overlap: f64, params: &Params) -> (f64, GripSample) {
    let robot = plates(0.03 - overlap);
    let cube = six_cm_cube(params);
    let support = table();
    let fixed = [FixedItem {
        shape: &support,
        tag: Tag::Support,
    }];
    let start = at(0.0, 0.0, 0.03);
    let mut poses = robot.new_link_poses();
    robot.forward_kinematics(&start, &[], &mut poses);
    let dt = params.max_dt_s;
    let mut world = ReplayWorld::new(
        &robot,
        &poses,
        &cube,
        &start,
        0.2,
        &fixed,
        params,
        dt,
        Vector3::from(params.gravity),
    );
    let (lift, hold) = (240, 120);
    for k in 1..=lift + hold {
        let z = 0.03 + 0.2 * smoothstep(k as f64 / lift as f64);
        robot.forward_kinematics(&at(0.0, 0.0, z), &[], &mut poses);
        world.drive_hand(&poses, &[]);
        world.step();
    }
    let err = (world.object_pose().translation.vector - Vector3::new(0.0, 0.0, 0.23)).norm();
    (err, world.grip())
}

#[test]
fn plates_squeezing_a_cube_lift_it_for_surfaces_within_2mm() {
    let params = Params::single_replay();
    for overlap in [-0.002, -0.001, 0.0, 0.001, 0.002] {
        let err = squeeze_lift(overlap, &params);
        println!(
            "plates at {:+.1} mm overlap: cube error after a 20 cm lift {:.3} mm",
            overlap * 1e3,
            err * 1e3
        );
        assert!(
            err < 0.002,
            "overlap {:+.1} mm: cube ended {:.3} mm from the plates' lift; expected < 2 mm",
            overlap * 1e3,
            err * 1e3
        );
    }
}

#[test]
fn the_grip_force_splits_into_the_skin_and_the_overlap() {
    // Friction carries the weight: the plates' total normal force N must reach m·g / μ
    // (two faces, each at most μ·N/2), and it grows with the compression skin + overlap.
    let params = Params::single_replay();
    let mu = params.hand_friction.max(params.object_friction);
    let weight = 0.2 * 9.81;
    let mut last = 0.0;
    for overlap in [-0.002, 0.0, 0.001, 0.002] {
        let (err, g) = squeeze_lift_grip(overlap, &params);
        let (at, from) = (g.at_overlap_n / g.normal_n, g.from_overlap_n / g.normal_n);
        println!(
            "plates at {:+.1} mm: error {:.3} mm, normal force {:.2} N (weight / μ {:.2} N), \
             at overlapping points {:.0} %, from the overlap {:.0} %",
            overlap * 1e3,
            err * 1e3,
            g.normal_n,
            weight / mu,
            100.0 * at,
            100.0 * from
        );
        assert!(err < 0.002, "the cube must be held ({:.3} mm)", err * 1e3);
        assert!(
            g.normal_n >= 0.99 * weight / mu,
            "a held cube needs N >= m·g/μ = {:.2} N; measured {:.2} N",
            weight / mu,
            g.normal_n
        );
        assert!(
            g.normal_n > last,
            "more compression must press harder: {:.2} N after {last:.2} N",
            g.normal_n
        );
        last = g.normal_n;
        if overlap < 0.0 {
            // Plates off the surface: everything presses through the skin.
            assert!(at == 0.0 && from == 0.0, "no overlap: {at} and {from}");
        } else if overlap == 0.0 {
            // At the surface (a point may sit a rounding error inside).
            assert!(from < 0.01, "plates at the surface: overlap share {from}");
        } else {
            // Every point overlaps; by compression, overlap / (overlap + skin).
            let expected = overlap / (overlap + params.finger_skin_m);
            assert!(at > 0.99, "every point overlaps: {at}");
            assert!(
                (from - expected).abs() < 0.05,
                "overlap share {from:.3}; expected about {expected:.3}"
            );
        }
    }
}

#[test]
fn without_finger_skin_plates_at_the_surface_do_not_hold() {
    // Why the softness model exists: rigid plates exactly at the surface grip nothing.
    let params = Params {
        finger_skin_m: 0.0,
        ..Params::single_replay()
    };
    let err = squeeze_lift(0.0, &params);
    println!(
        "no skin, plates at the surface: cube error {:.1} mm",
        err * 1e3
    );
    assert!(
        err > 0.1,
        "rigid plates at 0 overlap moved the cube within {:.1} mm of the lift; expected it to stay behind (> 100 mm)",
        err * 1e3
    );
}

#[test]
fn a_shared_world_keeps_its_members_apart() {
    // Three members in one world, all starting in the same place: their cubes and hands
    // overlap one another from the first step. Member 0's plates lift their cube 20 cm;
    // member 1's stay on theirs without lifting; member 2 is left out of the steps after
    // the first. Each must do what it would alone: no member's bodies touch another's.
    let params = Params::single_replay();
    let robot = plates(0.03);
    let cube = six_cm_cube(&params);
    let support = table();
    let fixed = [FixedItem {
        shape: &support,
        tag: Tag::Support,
    }];
    let start = at(0.0, 0.0, 0.03);
    let mut poses = robot.new_link_poses();
    robot.forward_kinematics(&start, &[], &mut poses);
    let member = |mass: f64| MemberStart {
        link_poses: &poses,
        object_pose: start,
        mass,
        hand_friction: params.hand_friction,
        finger_skin_m: params.finger_skin_m,
    };
    let starts = [member(0.2), member(0.2), member(0.2)];
    let mut world = ReplayWorld::shared(
        &robot,
        &starts,
        &cube,
        &fixed,
        &params,
        params.max_dt_s,
        Vector3::from(params.gravity),
    );
    assert_eq!(world.member_count(), 3);
    let rest_poses = poses.clone();
    let (lift, hold) = (240, 120);
    let mut left_out = None;
    for k in 1..=lift + hold {
        let z = 0.03 + 0.2 * smoothstep(k as f64 / lift as f64);
        robot.forward_kinematics(&at(0.0, 0.0, z), &[], &mut poses);
        world.drive_member_hand(0, &poses, &[]);
        world.drive_member_hand(1, &rest_poses, &[]);
        world.drive_member_hand(2, &rest_poses, &[]);
        world.step();
        if k == 1 {
            world.set_stepped(2, false);
            left_out = Some(world.member_object_pose(2));
        }
    }
    let lifted =
        (world.member_object_pose(0).translation.vector - Vector3::new(0.0, 0.0, 0.23)).norm();
    let stayed = (world.member_object_pose(1).translation.vector - start.translation.vector).norm();
    let alone = squeeze_lift(0.0, &params);
    println!(
        "shared world: lifted cube {:.3} mm off its plan (alone {:.3} mm), the held one {:.3} mm off its start",
        lifted * 1e3,
        alone * 1e3,
        stayed * 1e3
    );
    assert!(
        lifted < 0.001 && alone < 0.001,
        "the lifted cube is {:.2} mm off its plan (alone {:.2} mm); expected < 1 mm, as alone",
        lifted * 1e3,
        alone * 1e3
    );
    assert!(
        stayed < 0.001,
        "the cube whose plates stayed moved {:.2} mm; expected < 1 mm: another member's bodies touched it",
        stayed * 1e3
    );
    assert_eq!(
        Some(world.member_object_pose(2)),
        left_out,
        "a member left out of the steps moved"
    );
}

/// A world with the plates far away, a 6 cm cube at `z0` and the table.
fn lone_cube(z0: f64, params: &Params) -> (ReplayWorld, Robot, Vec<Isometry3<f64>>) {
    let robot = plates(0.03);
    let mut poses = robot.new_link_poses();
    robot.forward_kinematics(&at(5.0, 5.0, 5.0), &[], &mut poses);
    let cube = six_cm_cube(params);
    let support = table();
    let fixed = [FixedItem {
        shape: &support,
        tag: Tag::Support,
    }];
    let world = ReplayWorld::new(
        &robot,
        &poses,
        &cube,
        &at(0.0, 0.0, z0),
        0.2,
        &fixed,
        params,
        params.max_dt_s,
        Vector3::from(params.gravity),
    );
    (world, robot, poses)
}

#[test]
fn a_free_cube_falls_as_half_g_t_squared_until_it_hits_the_table() {
    let params = Params::single_replay();
    let z0 = 1.0;
    let (mut world, _robot, poses) = lone_cube(z0, &params);
    let dt = params.max_dt_s;
    // The cube's bottom reaches the table after a fall of z0 - 0.03.
    let t_hit = (2.0 * (z0 - 0.03) / G).sqrt();
    let mut worst: f64 = 0.0;
    let mut k = 0;
    while (k + 1) as f64 * dt < t_hit - 0.02 {
        world.drive_hand(&poses, &[]);
        world.step();
        k += 1;
        let t = k as f64 * dt;
        let fallen = z0 - world.object_pose().translation.z;
        let expected = 0.5 * G * t * t;
        // Rapier integrates gravity by symplectic Euler over dt/4 substeps, which falls
        // ½gt²·(1 + 1/(4k)) after k steps: 1 % ahead at t = 0.104 s, less later.
        if t >= 0.125 {
            let rel = (fallen - expected).abs() / expected;
            worst = worst.max(rel);
            assert!(
                rel < 0.01,
                "at t = {t:.3} s the cube fell {fallen:.5} m; ½gt² = {expected:.5} m (relative error {:.3} %, expected < 1 %)",
                rel * 100.0
            );
        }
    }
    println!(
        "free fall: largest relative error vs ½gt² over t in [0.125, {:.3}] s: {:.3} %",
        k as f64 * dt,
        worst * 100.0
    );
    // Then it hits the table and stops there.
    for _ in 0..480 {
        world.drive_hand(&poses, &[]);
        world.step();
    }
    let z = world.object_pose().translation.z;
    println!("after the impact the cube rests at z = {z:.5} m (expected 0.03)");
    assert!(
        (z - 0.03).abs() < 0.002,
        "the cube ended at z = {z:.5} m; expected on the table at 0.03 m"
    );
}

#[test]
fn a_released_cube_comes_to_rest_on_its_support() {
    let params = Params::single_replay();
    let (mut world, _robot, poses) = lone_cube(0.08, &params);
    for _ in 0..360 {
        world.drive_hand(&poses, &[]);
        world.step();
    }
    let pose = world.object_pose();
    let speed = world.object_speed();
    let tilt = pose.rotation.angle().to_degrees();
    println!(
        "released 5 cm above the table: rests at z = {:.5} m (expected 0.03), speed {speed:.2e} m/s, tilt {tilt:.3}°",
        pose.translation.z
    );
    assert!(
        (pose.translation.z - 0.03).abs() < 0.001,
        "rest height {:.5} m; expected 0.030 ± 0.001 m",
        pose.translation.z
    );
    assert!(speed < 0.01, "speed {speed} m/s; expected at rest (< 0.01)");
    assert!(tilt < 1.0, "tilt {tilt}°; expected < 1°");
}

// ---------------------------------------------------------------------------------------
// Trajectory level: a parallel-gripper pick and place of a small box.

/// Ways to break the demonstration.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Variant {
    Good,
    /// The jaws open mid-carry while the demo still carries the object.
    OpenMidCarry,
    /// The gripper follows its path 3 cm beside the object.
    Offset3cm,
    /// The gripper's body passes through a barrier beam during the carry.
    ThroughBarrier,
}

/// Box 3 x 4 x 6 cm (x, y, z), 0.1 kg, origin at its centre.
const BOX: [f64; 3] = [0.03, 0.04, 0.06];
const TCP_Z: f64 = 0.1034;
const Q_OPEN: f64 = 0.03;
/// Jaws closed 1 mm into each side of the box.
const Q_CLOSED: f64 = 0.02 - 0.001;

struct Case {
    _dir: tempfile::TempDir,
    robot: Robot,
    demo: Demo,
    scene: Scene,
    barriers: Vec<String>,
    mesh: Mesh,
}

/// Keyframes `(frame, wrist offset from the grasp pose, jaw q)`, smoothstep in between.
const KEYS: [(usize, [f64; 3], f64); 10] = [
    (0, [0.0, 0.0, 0.10], Q_OPEN),
    (15, [0.0, 0.0, 0.10], Q_OPEN),
    (45, [0.0, 0.0, 0.0], Q_OPEN),
    (60, [0.0, 0.0, 0.0], Q_CLOSED),
    (90, [0.0, 0.0, 0.15], Q_CLOSED),
    (140, [0.25, 0.0, 0.15], Q_CLOSED),
    (170, [0.25, 0.0, 0.0], Q_CLOSED),
    (185, [0.25, 0.0, 0.0], Q_OPEN),
    (215, [0.25, 0.0, 0.10], Q_OPEN),
    (230, [0.25, 0.0, 0.10], Q_OPEN),
];

/// The good demonstration's wrist offset and jaw q at (real) keyframe time `f`.
fn key_state(f: f64) -> (Vector3<f64>, f64) {
    let i = KEYS
        .iter()
        .rposition(|k| k.0 as f64 <= f)
        .unwrap()
        .min(KEYS.len() - 2);
    let (a, b) = (&KEYS[i], &KEYS[i + 1]);
    let u = smoothstep((f - a.0 as f64) / (b.0 - a.0) as f64);
    let p = Vector3::from(a.1).lerp(&Vector3::from(b.1), u);
    (p, a.2 + (b.2 - a.2) * u)
}

fn gripper_case(variant: Variant, frames_out: Option<usize>) -> Case {
    let dir = tempfile::tempdir().unwrap();
    let limits = Limits::default();
    let robot = Robot::from_urdf_file(&root().join("robots/parallel_gripper.urdf"), &limits)
        .expect("parallel gripper URDF");
    let mesh_path = dir.path().join("small_box.obj");
    box_mesh(BOX).write_obj(&mesh_path).unwrap();
    let mesh = Mesh::load(&mesh_path, Vector3::repeat(1.0), &limits).unwrap();

    // Hand pointing down: hand +z (approach) = world -z, hand y = world -y.
    let down = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), PI);
    let rest = at(0.0, 0.0, BOX[2] / 2.0);
    let grasp = Vector3::new(0.0, 0.0, BOX[2] / 2.0 + TCP_Z);
    let shift = if variant == Variant::Offset3cm {
        Vector3::new(0.03, 0.0, 0.0)
    } else {
        Vector3::zeros()
    };
    let last = KEYS[KEYS.len() - 1].0;
    let n = frames_out.unwrap_or(last + 1);
    let (grasped, placed) = (60usize, 170usize);
    let good_wrist = |f: f64| -> Isometry3<f64> {
        Isometry3::from_parts(Translation3::from(grasp + key_state(f).0), down)
    };
    let w_grasp = good_wrist(grasped as f64);
    let mut frames = Vec::with_capacity(n);
    for i in 0..n {
        // Stretch the 231 keyframe frames over n output frames.
        let f = i as f64 * last as f64 / (n - 1) as f64;
        let mut wrist = good_wrist(f);
        wrist.translation.vector += shift;
        let mut q = key_state(f).1;
        if variant == Variant::OpenMidCarry && f >= 105.0 {
            // The jaws open over frames 105-115 in mid-carry and stay open.
            q = Q_CLOSED + (Q_OPEN - Q_CLOSED) * smoothstep((f - 105.0) / 10.0);
        }
        // The object follows the good grasp between grasp and place.
        let object = if f <= grasped as f64 {
            rest
        } else if f <= placed as f64 {
            good_wrist(f) * w_grasp.inverse() * rest
        } else {
            good_wrist(placed as f64) * w_grasp.inverse() * rest
        };
        let contacts = if f >= grasped as f64 && f <= placed as f64 {
            vec![
                Contact {
                    link: "left_finger".into(),
                    hand_point: Point3::new(0.0, 0.0, 0.045),
                    object_point: Point3::new(0.0, -BOX[1] / 2.0, 0.0),
                },
                Contact {
                    link: "right_finger".into(),
                    hand_point: Point3::new(0.0, 0.0, 0.045),
                    object_point: Point3::new(0.0, BOX[1] / 2.0, 0.0),
                },
            ]
        } else {
            Vec::new()
        };
        frames.push(Frame {
            object,
            wrist,
            joints: vec![q],
            contacts,
        });
    }
    let demo = Demo {
        name: format!("gripper_{variant:?}"),
        fps: 30.0,
        robot: root().join("robots/parallel_gripper.urdf"),
        object: ObjectInfo {
            name: "small_box".into(),
            mesh: mesh_path,
            mass: 0.1,
        },
        joint_names: robot.actuated_names(),
        frames,
        timewarp: None,
        scene: None,
        barriers: Vec::new(),
        wrist_link: None,
        source: dir.path().join("gripper.demo.json"),
    };
    // The beam crosses the carry path at the height of the gripper's body (z 0.225-0.273
    // during the carry), above the box (top at 0.21): only the hand can hit it.
    let beam_pose = if variant == Variant::ThroughBarrier {
        at(0.125, 0.0, 0.25)
    } else {
        at(-0.3, 0.3, 0.25)
    };
    let scene = Scene {
        name: "gripper_table".into(),
        items: vec![
            SceneItem {
                name: "table".into(),
                role: Role::Support,
                pose: at(0.15, 0.0, -0.02),
                shape: ShapeJson::Box {
                    size: [0.8, 0.4, 0.04],
                },
            },
            SceneItem {
                name: "beam".into(),
                role: Role::Barrier,
                pose: beam_pose,
                shape: ShapeJson::Box {
                    size: [0.01, 0.3, 0.02],
                },
            },
        ],
        source: dir.path().join("scene.json"),
    };
    Case {
        _dir: dir,
        robot,
        demo,
        scene,
        barriers: vec!["beam".into()],
        mesh,
    }
}

fn run(case: &Case) -> PhysicsReport {
    let report = run_with(case, &Params::single_replay());
    println!(
        "{}: {} {:#?}\nmeasures: {}",
        case.demo.name,
        report.verdict(),
        report.reasons,
        serde_json::to_string_pretty(&report.to_summary()).unwrap()
    );
    report
}

#[test]
fn gripper_pick_and_place_passes() {
    let report = run(&gripper_case(Variant::Good, None));
    assert!(
        report.passed(),
        "the good pick and place failed: {:?}",
        report.reasons
    );
    let t = &report.tracking;
    assert!(
        t.max_position_error_mm < 5.0,
        "largest tracking error {:.2} mm at frame {}; expected < 5 mm for a firm grasp",
        t.max_position_error_mm,
        t.max_position_error_frame
    );
    let release = report.release.as_ref().expect("the demo releases the box");
    assert!(release.rests_on_support, "release: {release:?}");
    assert_eq!(release.support.as_deref(), Some("table"));
    let s = report.stability.as_ref().unwrap();
    assert!(
        s.max_mm < 5.0,
        "simulation displacement {:.2} mm; expected a few mm at most",
        s.max_mm
    );
    assert_eq!(report.penetration.hand_barrier.max_mm, 0.0);
    let ho = report.penetration.hand_object.max_mm;
    assert!(
        (ho - 1.0).abs() < 0.1,
        "hand-object penetration {ho:.3} mm; expected the designed 1 mm overlap"
    );
    assert!(report.drop.is_none());
}

/// The solver cut (`solver_contact_gap_m`, off by default) leaves the gripper's pick and
/// place passing with the same drop-free replay, within 1 mm of the default's tracking.
#[test]
fn solver_cut_keeps_the_gripper_pick_and_place() {
    let case = gripper_case(Variant::Good, None);
    let full = run(&case);
    let params = Params {
        solver_contact_gap_m: Some(0.003),
        ..Params::single_replay()
    };
    let cut = validate(
        &case.robot,
        &case.demo,
        &case.scene,
        &case.barriers,
        &case.mesh,
        &params,
        &Limits::default(),
    )
    .unwrap();
    assert!(full.passed() && cut.passed(), "{:?}", cut.reasons);
    let (a, b) = (&full.tracking, &cut.tracking);
    assert!(
        (a.max_position_error_mm - b.max_position_error_mm).abs() < 1.0,
        "{a:?} vs {b:?}"
    );
}

#[test]
fn gripper_report_is_deterministic() {
    let case = gripper_case(Variant::Good, None);
    let mut a = run(&case);
    let mut b = run(&case);
    a.timing_s = Default::default();
    b.timing_s = Default::default();
    a.profile.times = Default::default();
    b.profile.times = Default::default();
    // The second run hits the decomposition cache.
    b.replay.decomposition_cached = a.replay.decomposition_cached;
    assert_eq!(a, b, "two runs on the same input differ");
}

#[test]
fn gripper_opening_mid_carry_is_a_drop() {
    let report = run(&gripper_case(Variant::OpenMidCarry, None));
    assert!(!report.passed());
    let d = report.drop.as_ref().expect("a drop");
    assert_eq!(d.cause, DropCause::LostContact, "{d:?}");
    assert!(
        (105..=125).contains(&d.frame),
        "drop detected at frame {}; the jaws open over frames 105-115",
        d.frame
    );
    assert!(
        report
            .reasons
            .iter()
            .any(|r| r.starts_with("object dropped at frame")),
        "{:?}",
        report.reasons
    );
}

#[test]
fn gripper_offset_3cm_misses_the_box() {
    let report = run(&gripper_case(Variant::Offset3cm, None));
    assert!(!report.passed());
    let d = report.drop.as_ref().expect("a drop");
    assert_eq!(d.cause, DropCause::LostContact, "{d:?}");
    assert!(
        report.tracking.max_position_error_mm > 50.0,
        "tracking error {:.1} mm; expected the box left behind",
        report.tracking.max_position_error_mm
    );
    assert!(
        report
            .reasons
            .iter()
            .any(|r| r.starts_with("object position error")),
        "{:?}",
        report.reasons
    );
}

#[test]
fn gripper_through_a_barrier_fails_on_hand_barrier_penetration() {
    let report = run(&gripper_case(Variant::ThroughBarrier, None));
    let hb = &report.penetration.hand_barrier;
    assert!(
        hb.max_mm > 5.0 && hb.frames_over_limit > 0,
        "hand-barrier penetration {hb:?}; expected the gripper body deep in the beam"
    );
    assert_eq!(hb.worst_pair.as_deref(), Some("hand / beam"));
    assert!(
        report
            .reasons
            .iter()
            .any(|r| r.starts_with("hand-barrier penetration")),
        "{:?}",
        report.reasons
    );
    assert!(
        report.drop.is_none() && report.penetration.object_barrier.max_mm == 0.0,
        "only the hand hits the beam: drop {:?}, object-barrier {:?}",
        report.drop,
        report.penetration.object_barrier
    );
}

#[test]
fn summary_has_the_report_fields() {
    let report = run(&gripper_case(Variant::Good, None));
    let s = report.to_summary();
    let v = serde_json::to_value(&s).unwrap();
    assert_eq!(v["verdict"], "pass");
    for key in [
        "tracking",
        "drop",
        "penetration",
        "stability",
        "release",
        "replay",
        "timing_s",
        "released_on_support",
        "drop_frame",
    ] {
        assert!(v.get(key).is_some(), "summary lacks {key}: {v}");
    }
    assert_eq!(v["released_on_support"], true);
}

/// The bench's input, shared so the test checks what the bench measures.
pub fn stretched_gripper_case(frames: usize) -> PhysicsReport {
    run(&gripper_case(Variant::Good, Some(frames)))
}

#[test]
fn stretched_700_frame_gripper_demo_passes() {
    let report = stretched_gripper_case(700);
    assert!(report.passed(), "{:?}", report.reasons);
    assert_eq!(report.replay.frames, 700);
}

/// Every committed base demonstration, unwarped, passes the physics check under the default
/// parameters (otherwise the check would say nothing about the warps). Prints each verdict's
/// measures with `--nocapture`.
#[test]
fn committed_demos_verdicts() {
    let limits = Limits::default();
    let params = Params::single_replay();
    let mut failed = Vec::new();
    for name in ["cube", "mug", "frying_pan", "teapot", "apple", "small_box"] {
        let path = root().join(format!("scenes/demos/{name}.demo.json"));
        let mut demo = Demo::load(&path, &limits).unwrap();
        let robot = Robot::from_urdf_file(&demo.robot, &limits).unwrap();
        demo.check_robot(&robot).unwrap();
        let scene_path = demo
            .scene
            .clone()
            .expect("base demonstrations name their scene");
        let scene = Scene::load(&scene_path, &limits).unwrap();
        let mesh = Mesh::load(&demo.object.mesh, Vector3::repeat(1.0), &limits).unwrap();
        let r = validate(
            &robot,
            &demo,
            &scene,
            &demo.barriers,
            &mesh,
            &params,
            &limits,
        )
        .unwrap();
        println!(
            "{name}: {} (tracking mean {:.1} / max {:.1} mm, rotation mean {:.1}°, stability max {:.1} mm, {} parts {:?}, decomposition {:.3} s, replay {:.3} s) {:?}",
            r.verdict(),
            r.tracking.mean_position_error_mm,
            r.tracking.max_position_error_mm,
            r.tracking.mean_rotation_error_deg,
            r.stability.as_ref().map_or(0.0, |s| s.max_mm),
            r.replay.object_parts,
            r.replay.object_shape,
            r.timing_s.decomposition,
            r.timing_s.replay,
            r.reasons
        );
        if !r.passed() {
            failed.push(format!("{name}: {}", r.reasons.join("; ")));
        }
    }
    assert!(
        failed.is_empty(),
        "base demonstrations failing physics: {failed:#?}"
    );
}

/// The teapot demonstration carries the pot and releases it on the island; its hand, its
/// fingers still in the handle, then moves 10 cm toward the pot instead of retreating (the
/// frames after the release edited here). The report names the push, with frames that bracket it,
/// instead of a bare position error, and the links that still touch the pot there: the
/// fingers in its handle. Unedited, the pot stays put; slid straight out of the handle, the
/// hand turns it, and the report's turn names the links.
#[test]
fn a_hand_that_pushes_or_turns_the_released_teapot_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let demos = crate::fixtures::repo("scenes/demos");
    let mut demo: serde_json::Value =
        serde_json::from_slice(&std::fs::read(demos.join("teapot.demo.json")).unwrap()).unwrap();
    for key in ["scene", "robot"] {
        let abs = demos.join(demo[key].as_str().unwrap());
        demo[key] = abs.to_str().unwrap().into();
    }
    let mesh = demos.join(demo["object"]["mesh"].as_str().unwrap());
    demo["object"]["mesh"] = mesh.to_str().unwrap().into();
    let (plain, mut straight) = (demo.clone(), demo.clone());
    let frames = demo["frames"].as_array_mut().unwrap();
    let last_contact = frames
        .iter()
        .rposition(|f| !f["contacts"].as_array().unwrap().is_empty())
        .unwrap();
    // The fingers are open 15 frames after the last contact; from there the wrist moves
    // 10 cm along +x (the palm's normal, toward the pot) over 40 frames and stays.
    let start = last_contact + 15;
    let wrist = frames[start]["wrist"].clone();
    let x0 = wrist["position"][0].as_f64().unwrap();
    for (k, f) in frames.iter_mut().enumerate().skip(start + 1) {
        let s = ((k - start) as f64 / 40.0).min(1.0);
        f["wrist"] = wrist.clone();
        f["wrist"]["position"][0] = (x0 + 0.1 * s).into();
    }
    // Validates the demonstration `demo` (written as `name`), returns its report.
    let validate = |demo: &serde_json::Value, name: &str| -> serde_json::Value {
        let path = dir.path().join(format!("{name}.demo.json"));
        std::fs::write(&path, serde_json::to_vec(demo).unwrap()).unwrap();
        let out = dir.path().join(name);
        let o = crate::fixtures::dexwarp(&[
            "validate",
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", crate::fixtures::stderr(&o));
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap()
    };
    let report = validate(&demo, "push");
    let p = &report["physics"];
    assert_eq!(p["verdict"], "fail");
    let release = &p["release"];
    assert_eq!(release["rests_on_support"], true, "{release}");
    let pushed = &release["pushed"];
    let f = |v: &serde_json::Value| v.as_f64().unwrap();
    let (released, frame, touch) = (
        f(&release["frame"]),
        f(&pushed["frame"]),
        f(&pushed["last_touch_frame"]),
    );
    assert!(released < touch && touch <= frame, "{release}");
    assert!(f(&pushed["release_error_mm"]) < 30.0, "{pushed}");
    assert!(f(&pushed["position_error_mm"]) > 80.0, "{pushed}");
    let links: Vec<&str> = pushed["touching_links"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| l.as_str().unwrap())
        .collect();
    assert!(
        links.contains(&"index_middle") && links.contains(&"middle_middle"),
        "{links:?}"
    );
    let reasons: Vec<&str> = p["reasons"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r.as_str().unwrap())
        .collect();
    assert!(
        reasons
            .iter()
            .any(|r| r.starts_with("object pushed after the release")
                && r.ends_with(&format!("(with {})", links.join(", ")))),
        "{reasons:?}"
    );
    assert!(
        !reasons
            .iter()
            .any(|r| r.starts_with("object position error")),
        "{reasons:?}"
    );
    // Unedited, the hand slides out of the handle around it and leaves the pot as it put it
    // down (a straight slide-out turned it 25°).
    let report = validate(&plain, "plain");
    let release = &report["physics"]["release"];
    assert!(f(&release["turn"]["deg"]) < 5.0, "{release}");
    assert!(
        release["turn"]["by_hand"].is_null() && release["pushed"].is_null(),
        "{release}"
    );

    // Slid straight out instead (the wrist kept on the line from the grasp for the 45 frames
    // after the release), the fingers drag the handle round: the pot turns, and the report
    // says the hand did it and with which links.
    let frames = straight["frames"].as_array_mut().unwrap();
    let at_release = frames[last_contact]["wrist"]["position"].clone();
    for f in &mut frames[last_contact + 1..=last_contact + 45] {
        for axis in [0, 2] {
            f["wrist"]["position"][axis] = at_release[axis].clone();
        }
    }
    let report = validate(&straight, "straight");
    let turn = &report["physics"]["release"]["turn"];
    assert!(f(&turn["deg"]) > 15.0, "{turn}");
    let by = f(&turn["by_hand"]["frame"]);
    assert!(
        by > last_contact as f64 && by <= f(&turn["frame"]),
        "{turn}"
    );
    assert!(
        !turn["by_hand"]["links"].as_array().unwrap().is_empty(),
        "{turn}"
    );
}

/// [`validate`] of `case` with `params`.
fn run_with(case: &Case, params: &Params) -> PhysicsReport {
    validate(
        &case.robot,
        &case.demo,
        &case.scene,
        &case.barriers,
        &case.mesh,
        params,
        &Limits::default(),
    )
    .expect("validate")
}

/// The default ensemble (8 members) on a trajectory built to hold firmly: every member
/// passes, the decision is a certain keep, and member 0 is the nominal replay.
#[test]
fn ensemble_of_a_firm_grasp_passes_in_every_member() {
    let case = gripper_case(Variant::Good, None);
    let nominal = run(&case);
    let report = run_with(&case, &Params::default());
    let e = report
        .ensemble
        .as_ref()
        .expect("the default params ask for an ensemble");
    println!("{e:#?}");
    assert_eq!(e.members, 8);
    assert_eq!(e.passed, e.replayed, "{:?}", e.member);
    assert_eq!(e.pass_fraction, 1.0);
    assert_eq!(e.decision, dexwarp::physics::Decision::Keep);
    assert!(!e.uncertain, "interval {:?}", e.interval);
    assert!(report.passed());
    // The early stop: 7 of 7 already decide a certain keep.
    assert_eq!(e.replayed, 7);
    assert!(e.member[0].draw.is_nominal());
    assert!(e.member[1..].iter().all(|m| !m.draw.is_nominal()));
    // Member 0 is the nominal replay: the report's figures are its own.
    assert_eq!(report.tracking, nominal.tracking);
    assert_eq!(report.drop, nominal.drop);
}

/// A member whose tracking fails beyond recovery stops there: the box's plan leaves its
/// placed pose by 30 cm for the last 60 frames, so the mean position error of the whole
/// trajectory is about 78 mm (limit 20 mm) and every member fails. The nominal replay runs
/// to the end; each perturbed member stops once its summed errors pass 20 mm times the
/// frames (about 16 frames into the shift), so the mean over what it replayed is a third of
/// the nominal's, still over the limit: the same verdict for less replay.
#[test]
fn ensemble_members_stop_once_their_tracking_has_failed() {
    let mut case = gripper_case(Variant::Good, None);
    let n = case.demo.frames.len();
    for f in &mut case.demo.frames[n - 60..] {
        f.object.translation.vector.x += 0.3;
    }
    let report = run_with(&case, &Params::default());
    let e = report.ensemble.as_ref().expect("the default ensemble");
    let mean = |reason: &str| -> f64 {
        let rest = reason
            .split("mean object position error ")
            .nth(1)
            .unwrap_or_else(|| panic!("no mean position error in {reason:?}"));
        rest.split(' ').next().unwrap().parse().unwrap()
    };
    let nominal = mean(&report.reasons.join("; "));
    println!(
        "nominal {nominal} mm over {n} frames; members {:?}",
        e.member
            .iter()
            .map(|m| m.reason.clone())
            .collect::<Vec<_>>()
    );
    assert!(nominal > 60.0, "{nominal}");
    assert_eq!(e.passed, 0);
    assert!(!e.uncertain);
    for m in &e.member[1..] {
        let reason = m.reason.as_deref().expect("a failed member has a reason");
        let replayed_mean = mean(reason);
        assert!(
            replayed_mean > 20.0 && replayed_mean < nominal / 2.0,
            "member {}: {reason}",
            m.index
        );
    }
}

/// Jaws that open mid-carry drop the box in every member: pass fraction 0, the nominal's
/// drop as the reason.
#[test]
fn ensemble_of_jaws_opening_mid_carry_passes_in_no_member() {
    let report = run_with(
        &gripper_case(Variant::OpenMidCarry, None),
        &Params::default(),
    );
    let e = report.ensemble.as_ref().unwrap();
    println!("{e:#?}");
    assert_eq!(e.passed, 0, "{:?}", e.member);
    assert_eq!(e.pass_fraction, 0.0);
    assert_eq!(e.decision, dexwarp::physics::Decision::Drop);
    assert!(!e.uncertain);
    assert!(
        e.member.iter().all(|m| m
            .reason
            .as_deref()
            .is_some_and(|r| r.starts_with("object dropped"))),
        "{:?}",
        e.member
    );
    assert!(
        report.reasons[0].starts_with("object dropped"),
        "{:?}",
        report.reasons
    );
}

/// At the edge: the gripper shifted sideways along the box (bisection) until the nominal
/// replay barely holds it, then an ensemble whose members draw a hand offset of σ = 3 mm
/// around that: some hold, some lose the box, and the interval is the Wilson interval of
/// what was replayed, narrower for a larger K.
#[test]
fn ensemble_at_the_slip_limit_splits_and_its_interval_reflects_k() {
    let case = gripper_case(Variant::Good, None);
    let shifted = |dx: f64, params: &Params| {
        let mut demo = case.demo.clone();
        for f in &mut demo.frames {
            f.wrist.translation.vector.x += dx;
        }
        validate(
            &case.robot,
            &demo,
            &case.scene,
            &case.barriers,
            &case.mesh,
            params,
            &Limits::default(),
        )
        .expect("validate")
    };
    let holds = |dx: f64| shifted(dx, &Params::single_replay()).passed();
    let (mut lo, mut hi) = (0.0_f64, 0.03_f64);
    assert!(
        holds(lo) && !holds(hi),
        "expected a hold at {lo} m and a miss at {hi} m"
    );
    for _ in 0..8 {
        let mid = 0.5 * (lo + hi);
        if holds(mid) { lo = mid } else { hi = mid }
    }
    println!(
        "the grasp is lost between {:.2} and {:.2} mm off",
        lo * 1e3,
        hi * 1e3
    );
    let quiet = dexwarp::physics::EnsembleParams {
        hand_offset_mm: 3.0,
        hand_rotation_deg: 0.0,
        wrist_jitter_mm: 0.0,
        object_start_mm: 0.0,
        object_start_yaw_deg: 0.0,
        friction_spread: 0.0,
        skin_spread_mm: 0.0,
        mass_spread: 0.0,
        ..dexwarp::physics::EnsembleParams::default()
    };
    let fractions: Vec<(usize, f64, [f64; 2])> = [8, 24]
        .into_iter()
        .map(|k| {
            let params = Params {
                ensemble: dexwarp::physics::EnsembleParams {
                    members: k,
                    max_members: k,
                    early_stop: false,
                    ..quiet.clone()
                },
                ..Params::default()
            };
            let e = shifted(lo, &params).ensemble.unwrap();
            println!(
                "K = {k}: {} of {} pass, interval {:?}; x offsets [mm] {:?}",
                e.passed,
                e.replayed,
                e.interval,
                e.member
                    .iter()
                    .map(|m| (m.draw.hand_offset_mm[0], m.passed))
                    .collect::<Vec<_>>()
            );
            assert_eq!(e.replayed, k);
            assert!(e.member[0].passed, "the nominal holds {lo} m off");
            assert!(0 < e.passed && e.passed < k, "{} of {k}", e.passed);
            assert_eq!(e.interval, dexwarp::physics::ensemble::wilson(e.passed, k));
            // Members drawn a millimetre or more further off lose the box, those nearer
            // keep it.
            for m in &e.member {
                let x = m.draw.hand_offset_mm[0];
                assert!(x.abs() < 1.0 || m.passed == (x < 0.0), "member {m:?}");
            }
            (k, e.pass_fraction, e.interval)
        })
        .collect();
    let width = |i: [f64; 2]| i[1] - i[0];
    assert!(
        width(fractions[1].2) < width(fractions[0].2),
        "intervals {fractions:?}"
    );
    // The default rule: 8 replays, 8 more at a time while uncertain, at most 24 here.
    let params = Params {
        ensemble: dexwarp::physics::EnsembleParams {
            max_members: 24,
            ..quiet.clone()
        },
        ..Params::default()
    };
    let e = shifted(lo, &params).ensemble.unwrap();
    let first = &e.member[..e.replayed.min(8)];
    let passed = first.iter().filter(|m| m.passed).count();
    let undecided = dexwarp::physics::ensemble::decide(passed, first.len(), 0.5).1;
    println!(
        "K = 8 up to 24: {} of {} pass ({} of the first {}), uncertain {}",
        e.passed,
        e.replayed,
        passed,
        first.len(),
        e.uncertain
    );
    assert_eq!(e.max_members, 24);
    assert!(e.replayed <= 24);
    assert_eq!(e.replayed > 8, undecided && first.len() == 8, "{e:?}");
    assert!(!e.uncertain || e.replayed == 24, "{e:?}");
    assert!(
        e.replayed > 8,
        "the slip limit's ensemble is undecided at 8: {e:?}"
    );
}
