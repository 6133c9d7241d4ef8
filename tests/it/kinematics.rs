//! Robot loading, forward kinematics and point Jacobians.
//!
//! FK is checked against poses multiplied out by hand (explicit rotation matrices, not the
//! crate's composition), the point Jacobian against central finite differences on fixed-seed
//! random configurations, and every loader error class against its message.

use std::f64::consts::FRAC_PI_2;
use std::path::{Path, PathBuf};

use dexwarp::geometry::shape::ShapeKind;
use dexwarp::robot::{JointKind, LinkId, Robot, WRIST_DOF, apply_wrist_step};
use dexwarp::{Error, Limits};
use nalgebra::{Isometry3, Matrix3, Point3, Translation3, UnitQuaternion, Vector3};
use proptest::prelude::*;
use proptest::test_runner::RngSeed;

fn load(urdf: &str) -> dexwarp::Result<Robot> {
    Robot::from_urdf_str(
        urdf,
        Path::new("."),
        Path::new("test.urdf"),
        &Limits::default(),
    )
}

fn load_err(urdf: &str) -> (Error, String) {
    let err = load(urdf).expect_err("the URDF should be refused");
    let msg = err.to_string();
    (err, msg)
}

/// base --(revolute z, origin z 0.1)--> l1 --(prismatic x, origin x 0.2)--> l2
///      --(revolute y, origin y 0.05, rpy (0.1, 0.2, 0.3))--> l3
const CHAIN: &str = r#"<robot name="chain">
  <link name="base"/> <link name="l1"/> <link name="l2"/> <link name="l3"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="prismatic"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.2 0 0"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.5" effort="1" velocity="1"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/>
    <origin xyz="0 0.05 0" rpy="0.1 0.2 0.3"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
</robot>"#;

fn rx(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}
fn ry(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}
fn rz(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

/// A pose as (rotation matrix, translation), composed by hand.
#[derive(Clone, Copy)]
struct Frame(Matrix3<f64>, Vector3<f64>);
impl Frame {
    fn then(self, r: Matrix3<f64>, t: Vector3<f64>) -> Frame {
        Frame(self.0 * r, self.1 + self.0 * t)
    }
}

fn assert_pose(got: &Isometry3<f64>, want: Frame, what: &str) {
    let r = got.rotation.to_rotation_matrix().into_inner();
    let dr = (r - want.0).abs().max();
    let dt = (got.translation.vector - want.1).norm();
    assert!(
        dr < 1e-12 && dt < 1e-12,
        "{what}: rotation off by {dr:e}, translation off by {dt:e}\n got {got}\n want R {} t {}",
        want.0,
        want.1
    );
}

#[test]
fn fk_of_a_three_link_chain_matches_hand_computation() {
    let robot = load(CHAIN).unwrap();
    assert_eq!(robot.dof(), 3);
    assert_eq!(robot.actuated_names(), ["j1", "j2", "j3"]);
    let mut poses = robot.new_link_poses();
    let wrist = Isometry3::new(Vector3::new(0.3, -0.2, 1.0), Vector3::new(0.2, -0.4, 0.7));
    let w = Frame(
        wrist.rotation.to_rotation_matrix().into_inner(),
        wrist.translation.vector,
    );
    let rpy = rz(0.3) * ry(0.2) * rx(0.1); // URDF: roll about x, then pitch y, then yaw z
    for q in [[0.0, 0.0, 0.0], [FRAC_PI_2, 0.1, 0.0], [-1.2, 0.35, 1.7]] {
        for (wrist, w) in [
            (
                Isometry3::identity(),
                Frame(Matrix3::identity(), Vector3::zeros()),
            ),
            (wrist, w),
        ] {
            robot.forward_kinematics(&wrist, &q, &mut poses);
            let l1 = w.then(rz(q[0]), Vector3::new(0.0, 0.0, 0.1));
            let l2 = l1
                .then(Matrix3::identity(), Vector3::new(0.2, 0.0, 0.0))
                .then(Matrix3::identity(), Vector3::new(q[1], 0.0, 0.0));
            let l3 = l2.then(rpy * ry(q[2]), Vector3::new(0.0, 0.05, 0.0));
            let id = |n: &str| robot.link_id(n).unwrap().0 as usize;
            assert_pose(&poses[id("base")], w, "base");
            assert_pose(&poses[id("l1")], l1, &format!("l1 at {q:?}"));
            assert_pose(&poses[id("l2")], l2, &format!("l2 at {q:?}"));
            assert_pose(&poses[id("l3")], l3, &format!("l3 at {q:?}"));
        }
    }
    // One configuration in plain numbers: j1 = 90°, slide 0.1 → l2 origin at (0, 0.3, 0.1).
    robot.forward_kinematics(&Isometry3::identity(), &[FRAC_PI_2, 0.1, 0.0], &mut poses);
    let l2 = poses[robot.link_id("l2").unwrap().0 as usize]
        .translation
        .vector;
    assert!((l2 - Vector3::new(0.0, 0.3, 0.1)).norm() < 1e-12, "{l2}");
}

/// A two-finger test hand: mimic chains (j2 mimics j1, j3 mimics j2), a continuous and a
/// prismatic joint, a non-normalised axis, a fixed tip and every primitive shape.
const MIMIC_HAND: &str = r#"<robot name="mimic_hand">
  <link name="palm"><collision><geometry><box size="0.08 0.02 0.09"/></geometry></collision>
    <collision><origin xyz="0 0 0.05" rpy="0 1.5707963 0"/>
      <geometry><cylinder radius="0.01" length="0.06"/></geometry></collision></link>
  <link name="a1"><collision><origin xyz="0 0 0.02"/>
    <geometry><capsule radius="0.009" length="0.03"/></geometry></collision></link>
  <link name="a2"><collision><origin xyz="0 0 0.015"/>
    <geometry><capsule radius="0.008" length="0.025"/></geometry></collision></link>
  <link name="a3"><collision><geometry><sphere radius="0.008"/></geometry></collision></link>
  <link name="a_tip"/>
  <link name="b1"><collision><geometry><box size="0.02 0.02 0.04"/></geometry></collision></link>
  <link name="b2"><collision><geometry><sphere radius="0.01"/></geometry></collision></link>
  <joint name="j1" type="revolute"><parent link="palm"/><child link="a1"/>
    <origin xyz="0.03 0 0.1" rpy="0.2 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-0.5" upper="1.6" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="a1"/><child link="a2"/>
    <origin xyz="0 0 0.04"/><axis xyz="1 1 0"/>
    <limit lower="-1" upper="2" effort="1" velocity="1"/>
    <mimic joint="j1" multiplier="0.8" offset="0.1"/></joint>
  <joint name="j3" type="revolute"><parent link="a2"/><child link="a3"/>
    <origin xyz="0 0.01 0.03" rpy="0 0.3 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="2" effort="1" velocity="1"/>
    <mimic joint="j2" multiplier="0.5" offset="-0.2"/></joint>
  <joint name="tip" type="fixed"><parent link="a3"/><child link="a_tip"/>
    <origin xyz="0 0 0.01"/></joint>
  <joint name="slide" type="prismatic"><parent link="palm"/><child link="b1"/>
    <origin xyz="-0.03 0 0.1"/><axis xyz="0 0.6 0.8"/>
    <limit lower="-0.02" upper="0.03" effort="1" velocity="1"/></joint>
  <joint name="spin" type="continuous"><parent link="b1"/><child link="b2"/>
    <origin xyz="0 0 0.03" rpy="0.4 -0.2 1.0"/><axis xyz="0 0 1"/></joint>
</robot>"#;

#[test]
fn mimic_chains_resolve_to_the_driver() {
    let robot = load(MIMIC_HAND).unwrap();
    assert_eq!(robot.dof(), 3, "j1, slide, spin");
    assert_eq!(robot.actuated_names(), ["j1", "slide", "spin"]);
    let j = |n: &str| robot.joint(robot.joint_id(n).unwrap());
    let m2 = j("j2").mimic.unwrap();
    assert_eq!((m2.driver, m2.multiplier, m2.offset), (0, 0.8, 0.1));
    // θ3 = 0.5 θ2 - 0.2 = 0.5 (0.8 q + 0.1) - 0.2 = 0.4 q - 0.15
    let m3 = j("j3").mimic.unwrap();
    assert_eq!(m3.driver, 0);
    assert!((m3.multiplier - 0.4).abs() < 1e-15 && (m3.offset + 0.15).abs() < 1e-15);
    assert!(robot.actuated_index("j2").is_none());
    assert_eq!(robot.actuated_index("spin"), Some(2));
    assert_eq!(robot.upper()[2], f64::INFINITY);
    assert_eq!(j("spin").kind, JointKind::Continuous);

    // FK of a3 by hand, with the mimic values.
    let q = [0.7, 0.01, 2.0];
    let (t2, t3) = (0.8 * q[0] + 0.1, 0.4 * q[0] - 0.15);
    let axis2 = Vector3::new(1.0, 1.0, 0.0).normalize();
    let r_axis2 = UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(axis2), t2)
        .to_rotation_matrix()
        .into_inner();
    let f = Frame(Matrix3::identity(), Vector3::zeros())
        .then(rx(0.2) * ry(q[0]), Vector3::new(0.03, 0.0, 0.1))
        .then(r_axis2, Vector3::new(0.0, 0.0, 0.04))
        .then(ry(0.3) * ry(t3), Vector3::new(0.0, 0.01, 0.03));
    let mut poses = robot.new_link_poses();
    robot.forward_kinematics(&Isometry3::identity(), &q, &mut poses);
    assert_pose(&poses[robot.link_id("a3").unwrap().0 as usize], f, "a3");
}

#[test]
fn clamp_limits_and_lookups() {
    let robot = load(MIMIC_HAND).unwrap();
    let mut q = vec![5.0, -1.0, 100.0];
    assert_eq!(robot.clamp(&mut q), 2);
    assert_eq!(q, [1.6, -0.02, 100.0]);
    assert_eq!(robot.lower(), [-0.5, -0.02, f64::NEG_INFINITY]);
    assert!(robot.link_id("nope").is_none());
    assert_eq!(robot.link(robot.root()).name, "palm");
    let nq = robot.neutral_q();
    assert!((nq[0] - 0.55).abs() < 1e-15 && nq[2] == 0.0);
}

#[test]
fn collision_shapes_and_surface_points() {
    let mut robot = load(MIMIC_HAND).unwrap();
    let palm = robot.link(robot.link_id("palm").unwrap());
    assert_eq!(palm.collision.len(), 2);
    assert!(matches!(palm.collision[1].kind, ShapeKind::Cylinder { .. }));
    assert_eq!(palm.surface_points.len(), palm.surface_normals.len());
    // Every surface point lies on its link's parry surface (cylinder axis conversion included).
    for link in robot.links() {
        for (p, n) in link.surface_points.iter().zip(&link.surface_normals) {
            let d = link
                .collision
                .iter()
                .map(|c| {
                    let pose = dexwarp::math::convert::to_pose(&c.shape_pose);
                    c.shape
                        .distance_to_point(&pose, dexwarp::math::convert::to_point(p), false)
                })
                .fold(f64::INFINITY, |a, b| a.min(b.abs()));
            assert!(
                d < 1e-7,
                "link {}: point {p} is {d} m from the surface",
                link.name
            );
            assert!((n.norm() - 1.0).abs() < 1e-9);
        }
    }
    let before = robot.surface_point_count();
    robot.sample_surface_points(&dexwarp::geometry::shape::SurfaceSampling {
        spacing: 0.004,
        max_per_shape: 10_000,
    });
    assert!(robot.surface_point_count() > 3 * before);
    let text = robot.describe();
    for needle in [
        "mimic_hand",
        "DoF: 6 (floating wrist) + 3",
        "= 0.4 * j1 - 0.15 (via 'j2')",
        "capsule r 9.0 mm",
        "continuous",
        "surface points",
    ] {
        assert!(text.contains(needle), "{needle:?} missing from:\n{text}");
    }
}

/// Central finite differences of the world point `p(t, ω, q)` along every Jacobian column.
fn finite_difference_jacobian(
    robot: &Robot,
    wrist: &Isometry3<f64>,
    q: &[f64],
    link: LinkId,
    point: &Point3<f64>,
) -> Vec<Vector3<f64>> {
    let h = 1e-6;
    let mut poses = robot.new_link_poses();
    let mut eval = |w: &Isometry3<f64>, q: &[f64]| {
        robot.forward_kinematics(w, q, &mut poses);
        poses[link.0 as usize] * point
    };
    let mut cols = Vec::new();
    for k in 0..6 {
        let mut d = [Vector3::zeros(), Vector3::zeros()];
        for (s, sign) in [1.0, -1.0].into_iter().enumerate() {
            let mut w = *wrist;
            let mut e = Vector3::zeros();
            e[k % 3] = sign * h;
            if k < 3 {
                apply_wrist_step(&mut w, &e, &Vector3::zeros());
            } else {
                apply_wrist_step(&mut w, &Vector3::zeros(), &e);
            }
            d[s] = eval(&w, q).coords;
        }
        cols.push((d[0] - d[1]) / (2.0 * h));
    }
    for i in 0..q.len() {
        let mut qp = q.to_vec();
        let mut qm = q.to_vec();
        qp[i] += h;
        qm[i] -= h;
        cols.push((eval(wrist, &qp) - eval(wrist, &qm)) / (2.0 * h));
    }
    cols
}

/// Robots the Jacobian law is checked on: the test hands, plus the shipped ones if present.
fn jacobian_robots() -> Vec<Robot> {
    let mut robots = vec![load(MIMIC_HAND).unwrap(), load(CHAIN).unwrap()];
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("robots");
    for name in ["human_hand", "allegro_hand", "parallel_gripper"] {
        let path = dir.join(format!("{name}.urdf"));
        if path.exists() {
            let robot = Robot::from_urdf_file(&path, &Limits::default())
                .unwrap_or_else(|e| panic!("{name} does not load: {e}"));
            robots.push(robot);
        } else {
            eprintln!(
                "note: {} is missing; Jacobian test skips it",
                path.display()
            );
        }
    }
    robots
}

#[test]
fn shipped_robots_load_if_present() {
    let robots = jacobian_robots();
    for r in &robots {
        eprintln!(
            "{}: {} links, {} DoF, {} surface points",
            r.name,
            r.link_count(),
            r.dof(),
            r.surface_point_count()
        );
        assert!(r.dof() > 0, "{}", r.name);
        assert_eq!(
            r.surface_point_count() > 0,
            r.links().iter().any(|l| !l.collision.is_empty())
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 96,
        rng_seed: RngSeed::Fixed(0x00de_c0de),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// J = central finite differences, relative error < 1e-6, on random wrists, configurations,
    /// links and points of every test robot.
    #[test]
    fn point_jacobian_matches_finite_differences(
        wrist_t in prop::array::uniform3(-1.0..1.0f64),
        wrist_r in prop::array::uniform3(-2.0..2.0f64),
        unit_q in prop::collection::vec(0.0..1.0f64, 32),
        link_pick in 0usize..1000,
        point in prop::array::uniform3(-0.06..0.06f64),
    ) {
        let wrist = Isometry3::from_parts(
            Translation3::from(Vector3::from(wrist_t)),
            UnitQuaternion::from_scaled_axis(Vector3::from(wrist_r)),
        );
        let point = Point3::from(point);
        for robot in jacobian_robots_cached() {
            let q: Vec<f64> = (0..robot.dof())
                .map(|i| {
                    let (lo, hi) = (robot.lower()[i].max(-3.0), robot.upper()[i].min(3.0));
                    lo + (hi - lo) * unit_q[i % unit_q.len()]
                })
                .collect();
            let link = LinkId((link_pick % robot.link_count()) as u32);
            let mut poses = robot.new_link_poses();
            robot.forward_kinematics(&wrist, &q, &mut poses);
            let mut jac = vec![Vector3::zeros(); WRIST_DOF + robot.dof()];
            robot.point_jacobian(&poses, link, &point, &mut jac);
            let fd = finite_difference_jacobian(robot, &wrist, &q, link, &point);
            let scale = jac.iter().map(|c| c.norm()).fold(1.0, f64::max);
            for (k, (a, b)) in jac.iter().zip(&fd).enumerate() {
                let err = (a - b).norm() / scale;
                prop_assert!(
                    err < 1e-6,
                    "{}: link {} column {k}: analytic {a} vs finite difference {b} (rel. error {err:e})",
                    robot.name, robot.link(link).name
                );
            }
        }
    }
}

fn jacobian_robots_cached() -> &'static [Robot] {
    static ROBOTS: std::sync::OnceLock<Vec<Robot>> = std::sync::OnceLock::new();
    ROBOTS.get_or_init(jacobian_robots)
}

#[test]
fn wrist_step_is_a_left_rotation_about_the_wrist_origin() {
    let mut w = Isometry3::new(Vector3::new(1.0, 2.0, 3.0), Vector3::new(0.1, 0.2, 0.3));
    let r0 = w.rotation;
    apply_wrist_step(
        &mut w,
        &Vector3::new(0.1, 0.0, 0.0),
        &Vector3::new(0.0, 0.0, 0.5),
    );
    assert!((w.translation.vector - Vector3::new(1.1, 2.0, 3.0)).norm() < 1e-15);
    let want = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.5) * r0;
    assert!(w.rotation.angle_to(&want) < 1e-12);
}

// ---- bad input: each error names the element and says what was expected ----

fn joint(name: &str, ty: &str, parent: &str, child: &str, extra: &str) -> String {
    format!(
        r#"<joint name="{name}" type="{ty}"><parent link="{parent}"/><child link="{child}"/>{extra}</joint>"#
    )
}
const LIM: &str = r#"<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>"#;

fn robot_of(links: &[&str], joints: &[String]) -> String {
    let links: String = links
        .iter()
        .map(|l| format!(r#"<link name="{l}"/>"#))
        .collect();
    format!(r#"<robot name="bad">{links}{}</robot>"#, joints.concat())
}

#[test]
fn refuses_more_than_one_root() {
    let (err, msg) = load_err(&robot_of(
        &["palm", "a", "stray"],
        &[joint("j", "revolute", "palm", "a", LIM)],
    ));
    assert!(matches!(err, Error::Invalid { .. }));
    assert!(
        msg.contains("test.urdf") && msg.contains("more than one root") && msg.contains("'stray'"),
        "{msg}"
    );
}

#[test]
fn refuses_cycles() {
    let (_, msg) = load_err(&robot_of(
        &["a", "b"],
        &[
            joint("ab", "fixed", "a", "b", ""),
            joint("ba", "fixed", "b", "a", ""),
        ],
    ));
    assert!(msg.contains("cycle"), "{msg}");
    let (_, msg) = load_err(&robot_of(
        &["palm", "a", "b"],
        &[
            joint("ab", "fixed", "a", "b", ""),
            joint("ba", "fixed", "b", "a", ""),
        ],
    ));
    assert!(msg.contains("cycle") && msg.contains("'ab'"), "{msg}");
    let (_, msg) = load_err(&robot_of(
        &["palm", "a"],
        &[
            joint("j1", "fixed", "palm", "a", ""),
            joint("j2", "fixed", "palm", "a", ""),
        ],
    ));
    assert!(
        msg.contains("joint 'j2'") && msg.contains("already the child of joint 'j1'"),
        "{msg}"
    );
}

#[test]
fn refuses_unknown_links() {
    let (_, msg) = load_err(&robot_of(
        &["palm"],
        &[joint("index_mcp", "revolute", "palm", "index_prox", LIM)],
    ));
    assert!(
        msg.contains("joint 'index_mcp'")
            && msg.contains("'index_prox'")
            && msg.contains("no link"),
        "{msg}"
    );
}

#[test]
fn refuses_zero_axis_bad_limits_and_nan() {
    let zero = r#"<axis xyz="0 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>"#;
    let (_, msg) = load_err(&robot_of(
        &["palm", "a"],
        &[joint("index_pip", "revolute", "palm", "a", zero)],
    ));
    assert!(
        msg.contains("joint 'index_pip' <axis>") && msg.contains("zero"),
        "{msg}"
    );

    let swapped = r#"<axis xyz="0 0 1"/><limit lower="1.5" upper="-0.2" effort="1" velocity="1"/>"#;
    let (_, msg) = load_err(&robot_of(
        &["palm", "a"],
        &[joint("index_pip", "revolute", "palm", "a", swapped)],
    ));
    assert!(
        msg.contains("joint 'index_pip' <limit>") && msg.contains("lower") && msg.contains("upper"),
        "{msg}"
    );

    let nan = r#"<origin xyz="0 NaN 0"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>"#;
    let (_, msg) = load_err(&robot_of(
        &["palm", "a"],
        &[joint("index_pip", "revolute", "palm", "a", nan)],
    ));
    assert!(
        msg.contains("joint 'index_pip' <origin>") && msg.contains("not finite"),
        "{msg}"
    );

    let nan_lim = r#"<axis xyz="0 0 1"/><limit lower="nan" upper="1" effort="1" velocity="1"/>"#;
    let (_, msg) = load_err(&robot_of(
        &["palm", "a"],
        &[joint("index_pip", "prismatic", "palm", "a", nan_lim)],
    ));
    assert!(msg.contains("<limit>") && msg.contains("NaN"), "{msg}");
}

#[test]
fn refuses_floating_planar_spherical_joints() {
    for ty in ["floating", "planar", "spherical"] {
        let (err, msg) = load_err(&robot_of(
            &["world", "palm"],
            &[joint("wrist", ty, "world", "palm", "")],
        ));
        assert!(matches!(err, Error::Unsupported { .. }), "{ty}: {err:?}");
        assert!(
            msg.contains("joint 'wrist'") && msg.contains(ty) && msg.contains("floating wrist"),
            "{msg}"
        );
    }
}

#[test]
fn refuses_bad_mimics() {
    let mimic = |target: &str| format!(r#"{LIM}<mimic joint="{target}" multiplier="1"/>"#);
    let (_, msg) = load_err(&robot_of(
        &["palm", "a", "b"],
        &[
            joint("j1", "revolute", "palm", "a", LIM),
            joint("j2", "revolute", "a", "b", &mimic("ghost")),
        ],
    ));
    assert!(
        msg.contains("joint 'j2'") && msg.contains("'ghost'"),
        "{msg}"
    );
    let (_, msg) = load_err(&robot_of(
        &["palm", "a", "b"],
        &[
            joint("j1", "fixed", "palm", "a", ""),
            joint("j2", "revolute", "a", "b", &mimic("j1")),
        ],
    ));
    assert!(
        msg.contains("joint 'j2'") && msg.contains("'j1' is fixed"),
        "{msg}"
    );
    let (_, msg) = load_err(&robot_of(
        &["palm", "a", "b"],
        &[
            joint("j1", "revolute", "palm", "a", &mimic("j2")),
            joint("j2", "revolute", "a", "b", &mimic("j1")),
        ],
    ));
    assert!(msg.contains("cycle"), "{msg}");
}

#[test]
fn refuses_malformed_xml_and_too_many_links() {
    let (err, msg) = load_err("<robot name=\"x\"><link name=\"a\"></robot");
    assert!(matches!(err, Error::Parse { .. }), "{err:?}");
    assert!(msg.contains("test.urdf"), "{msg}");
    let (_, msg) = load_err("<robot name=\"x\"></robot>");
    assert!(msg.contains("no <link>"), "{msg}");
    let limits = Limits {
        max_links: 2,
        ..Limits::default()
    };
    let err =
        Robot::from_urdf_str(CHAIN, Path::new("."), Path::new("chain.urdf"), &limits).unwrap_err();
    assert!(
        matches!(
            err,
            Error::TooLarge {
                found: 4,
                limit: 2,
                ..
            }
        ),
        "{err:?}"
    );
    assert!(err.to_string().contains("--max-links"));
}

#[test]
fn refuses_bad_collision_geometry() {
    let urdf = r#"<robot name="x"><link name="palm">
        <collision><geometry><sphere radius="0.01"/></geometry></collision>
        <collision><geometry><cylinder radius="-1" length="0.1"/></geometry></collision>
      </link></robot>"#;
    let (_, msg) = load_err(urdf);
    assert!(
        msg.contains("link 'palm' collision[1]") && msg.contains("radius"),
        "{msg}"
    );
}

#[test]
fn meshes_load_relative_to_the_urdf_with_package_and_file_prefixes() {
    let dir = tempfile::tempdir().unwrap();
    let robots = dir.path().join("pkg/robots");
    std::fs::create_dir_all(robots.join("meshes")).unwrap();
    let cube = dexwarp::geometry::Mesh {
        vertices: (0..8)
            .map(|i| {
                Point3::new(
                    (i & 1) as f64 - 0.5,
                    ((i >> 1) & 1) as f64 - 0.5,
                    ((i >> 2) & 1) as f64 - 0.5,
                )
            })
            .collect(),
        // Inward-wound on purpose: the loader orients closed meshes outward.
        triangles: vec![
            [0, 1, 2],
            [2, 1, 3],
            [4, 6, 5],
            [5, 6, 7],
            [0, 4, 1],
            [1, 4, 5],
            [2, 3, 6],
            [3, 7, 6],
            [0, 2, 4],
            [2, 6, 4],
            [1, 5, 3],
            [3, 5, 7],
        ],
    };
    cube.write_obj(&robots.join("meshes/cube.obj")).unwrap();
    let urdf = |filename: &str| {
        format!(
            r#"<robot name="m"><link name="palm"><collision><geometry>
               <mesh filename="{filename}" scale="0.02 0.02 0.04"/></geometry></collision></link></robot>"#
        )
    };
    let path = robots.join("m.urdf");
    let abs = robots.join("meshes/cube.obj");
    for filename in [
        "meshes/cube.obj".to_string(),
        "package://pkg/robots/meshes/cube.obj".to_string(),
        "package://robots/meshes/cube.obj".to_string(),
        format!("file://{}", abs.display()),
    ] {
        std::fs::write(&path, urdf(&filename)).unwrap();
        let robot = Robot::from_urdf_file(&path, &Limits::default())
            .unwrap_or_else(|e| panic!("{filename}: {e}"));
        let shape = &robot.link(robot.root()).collision[0];
        let ShapeKind::Mesh { mesh, .. } = &shape.kind else {
            panic!("not a mesh")
        };
        assert!(
            (mesh.signed_volume() - 0.02 * 0.02 * 0.04).abs() < 1e-12,
            "{}",
            mesh.signed_volume()
        );
        assert!(robot.surface_point_count() >= 8);
        assert!(robot.describe().contains("mesh cube.obj"));
    }
    std::fs::write(&path, urdf("meshes/missing.stl")).unwrap();
    let msg = Robot::from_urdf_file(&path, &Limits::default())
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("link 'palm' collision[0]")
            && msg.contains("not found")
            && msg.contains("missing.stl"),
        "{msg}"
    );
    std::fs::write(robots.join("meshes/cube.dae"), "x").unwrap();
    std::fs::write(&path, urdf("meshes/cube.dae")).unwrap();
    let err = Robot::from_urdf_file(&path, &Limits::default()).unwrap_err();
    assert!(matches!(err, Error::Unsupported { .. }), "{err:?}");
    assert!(err.to_string().contains(".obj and .stl"), "{err}");
    let missing =
        Robot::from_urdf_file(&dir.path().join("none.urdf"), &Limits::default()).unwrap_err();
    assert!(missing.to_string().contains("none.urdf"));
}

#[test]
fn truncated_or_mangled_urdf_never_panics() {
    // Every prefix (in steps) and a few byte substitutions: an error or a robot, no panic.
    for end in (0..MIMIC_HAND.len()).step_by(23) {
        if MIMIC_HAND.is_char_boundary(end) {
            let _ = load(&MIMIC_HAND[..end]);
        }
    }
    for (from, to) in [
        ("0.8", "x"),
        ("\"0 1 0\"", "\"0 1\""),
        ("revolute", "bogus"),
        ("<limit", "<limt"),
    ] {
        let _ = load(&MIMIC_HAND.replacen(from, to, 1));
    }
}
