//! Stage 4 (contact IK), smoothing and robustness on the synthetic grasp of `support`.
//!
//! Correctness only: timing lives in `benches/ik.rs`.

use dexwarp::hand::ik::{self, IkSolver, Params, ResolvedContact, Solver};
use dexwarp::hand::{HandPath, baseline};
use dexwarp::model::config::RetimeMode;
use dexwarp::warp::ObjectWarp;
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

use crate::support::{GraspDemo, GraspOptions};

fn small() -> GraspDemo {
    GraspDemo::build(&GraspOptions {
        pre: 10,
        contact: 80,
        post: 10,
        ..GraspOptions::default()
    })
}

/// A warp that moves the carry's middle 12 cm sideways and up, same timing.
fn waypoint_warp(g: &GraspDemo) -> ObjectWarp {
    let seg = g.demo.contact_segment().unwrap();
    let mid = (seg.start + seg.end) / 2;
    let p = g.demo.frames[mid].object.translation.vector + Vector3::new(0.0, 0.12, 0.05);
    g.warp(
        serde_json::json!([{"position": [p.x, p.y, p.z], "t": mid, "t_new": mid}]),
        RetimeMode::Speed,
    )
}

fn lm(threshold_mm: f64) -> Params {
    Params {
        threshold_mm,
        ..Params::default()
    }
}

fn run_ik(g: &GraspDemo, warp: &ObjectWarp, params: &Params) -> (HandPath, ik::Stats) {
    let init = baseline::run(&g.demo, warp).expect("baseline");
    ik::run(&g.robot, &g.demo, warp, &init, &[], None, params)
}

/// Every frame meets the threshold or says it did not; the reported mean is the truth.
fn check_threshold(stats: &ik::Stats, threshold_mm: f64) {
    for (k, f) in stats.frames.iter().enumerate() {
        if f.converged {
            assert!(
                f.mean_mm < threshold_mm,
                "frame {}: converged with mean {:.3} mm >= {threshold_mm} mm",
                stats.first_frame + k,
                f.mean_mm
            );
        }
    }
}

#[test]
fn identity_warp_recovers_the_original_hand() {
    let g = small();
    let warp = g.identity_warp();
    let (hand, stats) = run_ik(&g, &warp, &lm(3.5));
    assert_eq!(hand.len(), g.demo.frames.len());
    assert_eq!(stats.converged_fraction, 1.0);
    for (t, f) in g.demo.frames.iter().enumerate() {
        let dw = (hand.wrists[t].translation.vector - f.wrist.translation.vector).norm();
        assert!(dw < 1e-3, "frame {t}: wrist {:.3} mm from the original", dw * 1e3);
    }
    assert!(stats.d_c_mm < 0.1, "D_C {:.4} mm", stats.d_c_mm);
}

#[test]
fn lm_meets_each_paper_threshold() {
    let g = small();
    let warp = waypoint_warp(&g);
    for threshold in [10.0, 5.0, 3.5] {
        let (_, stats) = run_ik(&g, &warp, &lm(threshold));
        check_threshold(&stats, threshold);
        assert!(
            stats.converged_fraction > 0.99,
            "{threshold} mm: only {:.1} % converged, frames {:?}",
            stats.converged_fraction * 100.0,
            stats.not_converged
        );
        eprintln!(
            "lm {threshold} mm: D_C {:.2} mm, mean iterations {:.2}, {:.1} ms",
            stats.d_c_mm,
            stats.mean_iterations,
            stats.time_s * 1e3
        );
    }
}

#[test]
fn adam_meets_the_threshold() {
    let g = small();
    let warp = waypoint_warp(&g);
    let params = Params {
        solver: Solver::Adam,
        ..lm(5.0)
    };
    let (_, stats) = run_ik(&g, &warp, &params);
    check_threshold(&stats, 5.0);
    assert!(
        stats.converged_fraction > 0.99,
        "only {:.1} % converged, frames {:?}",
        stats.converged_fraction * 100.0,
        stats.not_converged
    );
    eprintln!(
        "adam 5 mm: D_C {:.2} mm, mean iterations {:.1}, {:.1} ms",
        stats.d_c_mm,
        stats.mean_iterations,
        stats.time_s * 1e3
    );
}

/// A frame that hits the cap is reported, not accepted.
#[test]
fn capped_frames_are_reported() {
    let g = small();
    let warp = waypoint_warp(&g);
    let params = Params {
        threshold_mm: 1e-6,
        max_iterations: 2,
        ..Params::default()
    };
    let (_, stats) = run_ik(&g, &warp, &params);
    let capped = stats.frames.iter().filter(|f| !f.converged).count();
    assert!(capped > 0);
    assert_eq!(capped, stats.not_converged.len());
    assert!(stats.frames.iter().all(|f| f.iterations <= 2));
}

#[test]
fn solver_names_round_trip() {
    for s in [Solver::Lm, Solver::Adam] {
        assert_eq!(s.as_str().parse::<Solver>().unwrap(), s);
        let json = serde_json::to_string(&s).unwrap();
        assert_eq!(json, format!("\"{}\"", s.as_str()));
    }
    assert!("sgd".parse::<Solver>().is_err());
}

/// Random reachable targets: FK of a random configuration gives the object points; the
/// solver starts from a perturbed configuration and, when converged, reproduces them.
#[test]
fn fk_of_ik_reaches_the_targets() {
    let g = small();
    let robot = &g.robot;
    let contacts: Vec<ResolvedContact> = ik::resolve_contacts(robot, &g.demo.frames[20].contacts);
    let mut solver = IkSolver::new(robot, &[], None, lm(0.5));
    let mut poses = robot.new_link_poses();
    let mut rng = 12345u64;
    let mut next = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let mut converged = 0;
    for _ in 0..20 {
        let mut q_true = g.grasp_q.clone();
        for v in q_true.iter_mut() {
            *v += 0.4 * next();
        }
        robot.clamp(&mut q_true);
        let wrist_true = Isometry3::from_parts(
            Translation3::new(next(), next(), 1.0 + next()),
            UnitQuaternion::from_euler_angles(next(), next(), next()),
        );
        robot.forward_kinematics(&wrist_true, &q_true, &mut poses);
        let object = Isometry3::identity();
        let targets: Vec<ResolvedContact> = contacts
            .iter()
            .map(|c| ResolvedContact {
                object_point: poses[c.link.index()] * c.hand_point,
                ..*c
            })
            .collect();
        let mut wrist = Isometry3::from_parts(
            Translation3::from(wrist_true.translation.vector + Vector3::new(0.01, -0.01, 0.01)),
            UnitQuaternion::from_euler_angles(0.05, -0.05, 0.05) * wrist_true.rotation,
        );
        let mut q: Vec<f64> = q_true.iter().map(|v| v + 0.1 * next()).collect();
        robot.clamp(&mut q);
        let r = solver.solve(&object, &targets, &mut wrist, &mut q);
        if !r.converged {
            continue;
        }
        converged += 1;
        robot.forward_kinematics(&wrist, &q, &mut poses);
        let mean: f64 = targets
            .iter()
            .map(|c| (poses[c.link.index()] * c.hand_point - c.object_point).norm())
            .sum::<f64>()
            / targets.len() as f64;
        assert!(mean < 0.5e-3, "FK(IK(x)) is {:.3} mm from x", mean * 1e3);
        assert!((mean * 1e3 - r.mean_mm).abs() < 1e-9);
        let _ = Point3::<f64>::origin();
    }
    assert!(converged >= 18, "only {converged}/20 converged");
}
