//! The actuated hand of the physics replay (`--physics-hand actuated`): an articulated
//! multibody on joint motors capped at the URDF's effort limits.

use dexwarp::Limits;
use dexwarp::model::Demo;
use dexwarp::physics::world::ReplayWorld;
use dexwarp::physics::{HandModel, Params, object_shape};
use dexwarp::robot::Robot;
use nalgebra::{Isometry3, Vector3};

use crate::fixtures::{dexwarp, repo, stderr};
use crate::physics::box_mesh;

/// Without anything to touch, the actuated hand follows the cube demonstration's hand
/// (wrist motion, fingers closing) within 3 mm at every link and frame (the largest lag, 2.3 mm, is a fingertip where the hand moves fastest): the multibody's
/// joint frames, signs and starting configuration are the URDF's.
#[test]
fn an_unloaded_actuated_hand_follows_its_trajectory() {
    let limits = Limits::default();
    let demo = Demo::load(&repo("scenes/demos/cube.demo.json"), &limits).unwrap();
    let robot = Robot::from_urdf_file(&demo.robot, &limits).unwrap();
    let params = Params {
        hand: HandModel::Actuated,
        ..Params::single_replay()
    };
    // An object far away, in free fall: nothing for the hand to touch.
    let far = object_shape(&box_mesh([0.05; 3]), &params.decomposition)
        .unwrap()
        .0;
    let mut poses = robot.new_link_poses();
    let f0 = &demo.frames[0];
    robot.forward_kinematics(&f0.wrist, &f0.joints, &mut poses);
    let n = 8;
    let mut world = ReplayWorld::with_hand_model(
        &robot,
        &poses,
        &f0.joints,
        &far,
        &Isometry3::translation(50.0, 0.0, 0.0),
        0.2,
        &[],
        &params,
        1.0 / (n as f64 * demo.fps),
        Vector3::from(params.gravity),
    )
    .unwrap();
    let mut q = vec![0.0; robot.dof()];
    let mut worst = (0.0f64, 0usize, String::new());
    for i in 1..demo.frames.len() {
        let (a, b) = (&demo.frames[i - 1], &demo.frames[i]);
        for k in 1..=n {
            let u = k as f64 / n as f64;
            for ((qk, qa), qb) in q.iter_mut().zip(&a.joints).zip(&b.joints) {
                *qk = qa + (qb - qa) * u;
            }
            let wrist = a.wrist.lerp_slerp(&b.wrist, u);
            robot.forward_kinematics(&wrist, &q, &mut poses);
            world.drive_hand(&poses, &q);
            world.step();
        }
        robot.forward_kinematics(&b.wrist, &b.joints, &mut poses);
        for (l, link) in robot.links().iter().enumerate() {
            let sim = world.hand_link_pose(l).expect("every link has a body");
            let e = (sim.translation.vector - poses[l].translation.vector).norm();
            if e > worst.0 {
                worst = (e, i, link.name.clone());
            }
        }
    }
    assert!(
        worst.0 < 0.003,
        "link {} is {:.2} mm off its trajectory at frame {}",
        worst.2,
        worst.0 * 1e3,
        worst.1
    );
}

/// A joint without an effort limit cannot be actuated: the error names the URDF joint.
#[test]
fn an_actuated_hand_needs_effort_limits() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = dir.path().join("no_effort.urdf");
    std::fs::write(
        &urdf,
        r#"<robot name="no_effort">
  <link name="palm"><collision><geometry><box size="0.05 0.05 0.01"/></geometry></collision></link>
  <link name="tip"><collision><geometry><sphere radius="0.01"/></geometry></collision></link>
  <joint name="tip_joint" type="revolute">
    <parent link="palm"/><child link="tip"/><origin xyz="0 0 0.03"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="1" velocity="1"/>
  </joint>
</robot>"#,
    )
    .unwrap();
    let limits = Limits::default();
    let robot = Robot::from_urdf_file(&urdf, &limits).unwrap();
    let params = Params {
        hand: HandModel::Actuated,
        ..Params::single_replay()
    };
    let obj = object_shape(&box_mesh([0.05; 3]), &params.decomposition)
        .unwrap()
        .0;
    let mut poses = robot.new_link_poses();
    robot.forward_kinematics(&Isometry3::identity(), &[0.0], &mut poses);
    let err = ReplayWorld::with_hand_model(
        &robot,
        &poses,
        &[0.0],
        &obj,
        &Isometry3::translation(1.0, 0.0, 0.0),
        0.2,
        &[],
        &params,
        1.0 / 240.0,
        Vector3::zeros(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("no_effort.urdf") && err.contains("joint 'tip_joint' <limit effort>"),
        "{err}"
    );
}

/// `validate --physics-hand actuated` replays with the actuated hand and says so in the
/// report; a grasp the kinematic hand holds, the actuated hand holds too.
#[test]
fn validate_with_the_actuated_hand() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("v");
    let o = dexwarp(&[
        "validate",
        repo("scenes/demos/small_box.demo.json").to_str().unwrap(),
        "--physics-hand",
        "actuated",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let physics = &report["physics"];
    assert_eq!(physics["replay"]["hand"], "actuated", "{physics}");
    assert_eq!(physics["verdict"], "pass", "{}", physics["reasons"]);
}
