//! Kinematics benchmarks: forward kinematics of the human hand, and FK plus the point
//! Jacobians of 50 contact points (the per-iteration work of the contact IK).
//!
//! Targets (release): FK < 2 µs, FK + 50 Jacobians < 20 µs. Run with
//! `cargo bench --bench kinematics`; read the medians.
//!
//! Uses `robots/human_hand.urdf` when present, else a built-in 20-joint hand of the same shape
//! (5 fingers × 4 joints, distal joints as mimics, capsules).

use std::hint::black_box;
use std::path::{Path, PathBuf};

use dexwarp::Limits;
use dexwarp::robot::{LinkId, Robot, WRIST_DOF};
use nalgebra::{Isometry3, Point3, Vector3};

fn main() {
    divan::main();
}

/// A 20-joint, five-finger test hand (16 actuated + 4 mimic distal joints).
fn builtin_hand() -> String {
    let mut s = String::from(
        r#"<robot name="bench_hand"><link name="palm"><collision><origin xyz="0 0 0.05"/>
           <geometry><box size="0.085 0.025 0.1"/></geometry></collision></link>"#,
    );
    let fingers = [
        ("thumb", -0.045, 0.02, 0.012),
        ("index", -0.03, 0.1, 0.010),
        ("middle", -0.01, 0.105, 0.010),
        ("ring", 0.01, 0.1, 0.0095),
        ("little", 0.03, 0.09, 0.0085),
    ];
    for (f, x, z, r) in fingers {
        let names = ["base", "prox", "mid", "dist"];
        for n in names {
            s += &format!(
                r#"<link name="{f}_{n}"><collision><origin xyz="0 0 0.015"/><geometry>
                   <capsule radius="{r}" length="0.025"/></geometry></collision></link>"#
            );
        }
        let lim = |lo: f64, hi: f64| {
            format!(r#"<limit lower="{lo}" upper="{hi}" effort="1" velocity="1"/>"#)
        };
        s += &format!(
            r#"<joint name="{f}_abd" type="revolute"><parent link="palm"/><child link="{f}_base"/>
               <origin xyz="{x} 0 {z}" rpy="0 0 0.1"/><axis xyz="0 1 0"/>{}</joint>"#,
            lim(-0.3, 0.3)
        );
        s += &format!(
            r#"<joint name="{f}_mcp" type="revolute"><parent link="{f}_base"/><child link="{f}_prox"/>
               <origin xyz="0 0 0.005"/><axis xyz="1 0 0"/>{}</joint>"#,
            lim(-0.2, 1.6)
        );
        s += &format!(
            r#"<joint name="{f}_pip" type="revolute"><parent link="{f}_prox"/><child link="{f}_mid"/>
               <origin xyz="0 0 0.04"/><axis xyz="1 0 0"/>{}</joint>"#,
            lim(0.0, 1.9)
        );
        s += &format!(
            r#"<joint name="{f}_dip" type="revolute"><parent link="{f}_mid"/><child link="{f}_dist"/>
               <origin xyz="0 0 0.03"/><axis xyz="1 0 0"/>{}
               <mimic joint="{f}_pip" multiplier="0.7" offset="0"/></joint>"#,
            lim(0.0, 1.4)
        );
    }
    s + "</robot>"
}

fn hand() -> Robot {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("robots/human_hand.urdf");
    if path.exists() {
        match Robot::from_urdf_file(&path, &Limits::default()) {
            Ok(r) => return r,
            Err(e) => eprintln!("human_hand.urdf does not load ({e}); using the built-in hand"),
        }
    } else {
        eprintln!("robots/human_hand.urdf missing; using the built-in 20-joint hand");
    }
    Robot::from_urdf_str(
        &builtin_hand(),
        Path::new("."),
        Path::new("bench_hand.urdf"),
        &Limits::default(),
    )
    .expect("built-in hand loads")
}

/// A fixed wrist and a mid-range configuration.
fn configuration(robot: &Robot) -> (Isometry3<f64>, Vec<f64>) {
    let wrist = Isometry3::new(Vector3::new(0.1, -0.2, 0.9), Vector3::new(0.3, -0.5, 0.8));
    (wrist, robot.neutral_q())
}

/// 50 contact points spread deterministically over the links' surface points.
fn contacts(robot: &Robot) -> Vec<(LinkId, Point3<f64>)> {
    let all: Vec<(LinkId, Point3<f64>)> = robot
        .links()
        .iter()
        .enumerate()
        .flat_map(|(i, l)| l.surface_points.iter().map(move |p| (LinkId(i as u32), *p)))
        .collect();
    assert!(!all.is_empty(), "the hand has no surface points");
    (0..50).map(|k| all[(k * 7919) % all.len()]).collect()
}

#[divan::bench]
fn forward_kinematics(bencher: divan::Bencher) {
    let robot = hand();
    let (wrist, q) = configuration(&robot);
    let mut poses = robot.new_link_poses();
    bencher.bench_local(|| {
        robot.forward_kinematics(black_box(&wrist), black_box(&q), &mut poses);
        black_box(&poses);
    });
}

#[divan::bench]
fn fk_and_50_point_jacobians(bencher: divan::Bencher) {
    let robot = hand();
    let (wrist, q) = configuration(&robot);
    let points = contacts(&robot);
    let mut poses = robot.new_link_poses();
    let mut jac = vec![Vector3::zeros(); (WRIST_DOF + robot.dof()) * points.len()];
    let cols = WRIST_DOF + robot.dof();
    bencher.bench_local(|| {
        robot.forward_kinematics(black_box(&wrist), black_box(&q), &mut poses);
        for ((link, p), out) in points.iter().zip(jac.chunks_exact_mut(cols)) {
            robot.point_jacobian(&poses, *link, p, out);
        }
        black_box(&jac);
    });
}

#[divan::bench]
fn load_urdf(bencher: divan::Bencher) {
    let text = builtin_hand();
    bencher.bench_local(|| {
        Robot::from_urdf_str(
            black_box(&text),
            Path::new("."),
            Path::new("bench_hand.urdf"),
            &Limits::default(),
        )
        .unwrap()
    });
}
