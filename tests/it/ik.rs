//! Stage 4 (contact IK), smoothing and robustness on the synthetic grasp of `support`.
//!
//! Correctness only: timing lives in `benches/ik.rs`.

use dexwarp::hand::ik::{self, IkSolver, Params, ResolvedContact, Solver};
use dexwarp::hand::{HandPath, baseline};
use dexwarp::warp::ObjectWarp;
use dexwarp::{metrics, pipeline};
use std::sync::LazyLock;

use dexwarp::geometry::shape::{CollisionShape, ShapeKind};
use dexwarp::hand::smooth;
use dexwarp::reproduce::robustness::{Corruption, corrupt};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use proptest::prelude::*;

use crate::support::{GraspDemo, GraspOptions};
use dexwarp::model::{RetimeMode, WarmStart};

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

/// The identity warp gives back the demonstrated hand: exactly when the warm start follows
/// the object (the rigid grasp needs no iteration), and within 1 mm when it does not but the
/// threshold is tight.
#[test]
fn identity_warp_recovers_the_original_hand() {
    let g = small();
    let warp = g.identity_warp();
    let cases = [
        (WarmStart::FollowObject, 3.5, 1e-6),
        (WarmStart::Rigid, 3.5, 1e-6),
        (WarmStart::Previous, 0.05, 1e-3),
    ];
    for (warm_start, threshold_mm, wrist_tol_m) in cases {
        let params = Params {
            warm_start,
            ..lm(threshold_mm)
        };
        let (hand, stats) = run_ik(&g, &warp, &params);
        assert_eq!(hand.len(), g.demo.frames.len());
        assert_eq!(stats.converged_fraction, 1.0, "{warm_start:?}");
        for (t, f) in g.demo.frames.iter().enumerate() {
            let dw = (hand.wrists[t].translation.vector - f.wrist.translation.vector).norm();
            assert!(
                dw < wrist_tol_m,
                "{warm_start:?}, frame {t}: wrist {:.4} mm from the original",
                dw * 1e3
            );
        }
        let out = pipeline::assemble(&g.demo, &warp, &hand, "identity");
        let dc = metrics::d_c_mm(&metrics::contact_distance_per_frame_mm(&g.robot, &out));
        let dc_orig = metrics::d_c_mm(&metrics::contact_distance_per_frame_mm(&g.robot, &g.demo));
        assert!(
            (dc - dc_orig).abs() < 0.1,
            "{warm_start:?}: D_C {dc:.4} mm, original {dc_orig:.4} mm"
        );
        assert!(
            (stats.d_c_mm - dc).abs() < 1e-6,
            "stats D_C {} vs {dc}",
            stats.d_c_mm
        );
    }
}

/// With the rigid warm start every frame starts from the rigid transfer at that frame, so a
/// frame's solution owes nothing to the frames before it: moving the warm start of the
/// segment's first half 5 cm away changes none of the second half's solutions, where
/// warm-starting from the previous frame carries the change along.
#[test]
fn with_the_rigid_warm_start_a_frame_owes_nothing_to_the_frames_before_it() {
    let g = small();
    let warp = waypoint_warp(&g);
    let init = baseline::run(&g.demo, &warp).expect("baseline");
    let (c0, t_end) = (warp.plan.segment.start, warp.plan.t_end_new());
    let half = (c0 + t_end) / 2;
    let mut moved = init.clone();
    for w in &mut moved.wrists[c0..half] {
        w.translation.vector += Vector3::new(0.05, 0.0, 0.0);
    }
    for (warm_start, independent) in [(WarmStart::Rigid, true), (WarmStart::FollowObject, false)] {
        let params = Params {
            warm_start,
            ..lm(3.5)
        };
        let (a, _) = ik::run(&g.robot, &g.demo, &warp, &init, &[], None, &params);
        let (b, _) = ik::run(&g.robot, &g.demo, &warp, &moved, &[], None, &params);
        let same = (half..=t_end).all(|t| a.wrists[t] == b.wrists[t] && a.q(t) == b.q(t));
        assert_eq!(same, independent, "{warm_start:?}");
        assert!(
            (c0..half).any(|t| a.wrists[t] != b.wrists[t]),
            "{warm_start:?}: the moved frames' solutions did not change"
        );
    }
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

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

    /// FK(IK(x)) ≈ x when converged: the targets are FK of a random configuration near the
    /// grasp, the solver starts 1-2 cm and several degrees away; a converged frame reproduces
    /// the targets to the threshold and reports its residual truthfully.
    #[test]
    fn fk_of_ik_reaches_the_targets(
        dq in prop::collection::vec(-0.3f64..0.3, 20),
        q_start in prop::collection::vec(-0.1f64..0.1, 20),
        wrist in prop::array::uniform6(-0.5f64..0.5),
    ) {
        let (g, contacts) = &*FIXTURE;
        let robot = &g.robot;
        let mut q_true: Vec<f64> = g.grasp_q.iter().zip(&dq).map(|(a, b)| a + b).collect();
        robot.clamp(&mut q_true);
        let wrist_true = Isometry3::from_parts(
            Translation3::new(wrist[0], wrist[1], 1.0 + wrist[2]),
            UnitQuaternion::from_euler_angles(wrist[3], wrist[4], 2.0 * wrist[5]),
        );
        let mut poses = robot.new_link_poses();
        robot.forward_kinematics(&wrist_true, &q_true, &mut poses);
        let targets: Vec<ResolvedContact> = contacts
            .iter()
            .map(|c| ResolvedContact { object_point: poses[c.link.index()] * c.hand_point, ..*c })
            .collect();
        let mut w = Isometry3::from_parts(
            Translation3::from(wrist_true.translation.vector + Vector3::new(0.01, -0.015, 0.01)),
            UnitQuaternion::from_euler_angles(0.05, -0.05, 0.08) * wrist_true.rotation,
        );
        let mut q: Vec<f64> = q_true.iter().zip(&q_start).map(|(a, b)| a + b).collect();
        robot.clamp(&mut q);
        let mut solver = IkSolver::new(robot, &[], None, lm(0.5));
        let r = solver.solve(&Isometry3::identity(), &targets, &mut w, &mut q);
        prop_assert!(r.converged, "not converged: {r:?}");
        robot.forward_kinematics(&w, &q, &mut poses);
        let mean = targets
            .iter()
            .map(|c| (poses[c.link.index()] * c.hand_point - c.object_point).norm())
            .sum::<f64>()
            / targets.len() as f64;
        prop_assert!(mean < 0.5e-3, "FK(IK(x)) is {:.3} mm from x", mean * 1e3);
        prop_assert!((mean * 1e3 - r.mean_mm).abs() < 1e-9);
        prop_assert!(q.iter().zip(robot.lower()).all(|(v, lo)| v >= lo));
        prop_assert!(q.iter().zip(robot.upper()).all(|(v, hi)| v <= hi));
    }
}

static FIXTURE: LazyLock<(GraspDemo, Vec<ResolvedContact>)> = LazyLock::new(|| {
    let g = small();
    let contacts = ik::resolve_contacts(&g.robot, &g.demo.frames[20].contacts);
    (g, contacts)
});

/// A box barrier across the back of the hand at the middle of the carry: with the barrier
/// term, the hand keeps more clearance than without it.
#[test]
fn barrier_term_keeps_the_hand_clear() {
    let g = small();
    let warp = waypoint_warp(&g);
    let init = baseline::run(&g.demo, &warp).unwrap();
    let mid = (g.demo.contact_segment().unwrap().start + warp.plan.t_end_new()) / 2;
    // The palm's back face is at hand x = -12 mm; the box reaches 7 mm into the palm.
    let w = init.wrists[mid];
    let center = w * Point3::new(-0.025, 0.0, 0.04);
    let barrier = CollisionShape::new(
        ShapeKind::Box {
            size: Vector3::new(0.04, 0.04, 0.04),
        },
        Isometry3::from_parts(Translation3::from(center.coords), w.rotation),
    )
    .unwrap();
    let barriers = [barrier];
    let clearance = |barrier_weight: f64| {
        // The barrier cannot be cleared without giving up contacts: those frames are
        // reported not converged; a small cap keeps the debug-build test quick.
        let params = Params {
            barrier_weight,
            max_iterations: 20,
            ..lm(3.5)
        };
        let (_, stats) = ik::run(&g.robot, &g.demo, &warp, &init, &barriers, None, &params);
        check_threshold(&stats, 3.5);
        eprintln!(
            "barrier weight {barrier_weight}: min clearance {:.2} mm, D_C {:.2} mm, {:.0} % converged, mean {:.1} / max {} iterations",
            stats.min_barrier_clearance_mm.unwrap(),
            stats.d_c_mm,
            stats.converged_fraction * 100.0,
            stats.mean_iterations,
            stats.max_iterations_used
        );
        stats.min_barrier_clearance_mm.unwrap()
    };
    let without = clearance(0.0);
    let with = clearance(1.0);
    assert!(
        without < 0.0,
        "the test should drag the hand through the box: {without} mm"
    );
    assert!(
        with > without + 1.0,
        "clearance with the barrier term {with:.2} mm, without {without:.2} mm"
    );
}

/// A strongly non-uniform τ (the first half of the carry compressed 3x, the second
/// stretched 2.5x) on a demonstration whose hand slides and turns over the object: between
/// two input frames the baseline's interpolated hand has already moved on while the
/// correspondences are still those of `t*`; contact IK fits them.
#[test]
fn contact_ik_beats_the_baseline_under_nonuniform_timing() {
    let g = GraspDemo::build(&GraspOptions {
        pre: 10,
        contact: 40,
        post: 10,
        in_hand_slide: Vector3::new(0.0, 0.0, 0.06),
        in_hand_turn_rad: 0.6,
        ..GraspOptions::default()
    });
    let seg = g.demo.contact_segment().unwrap();
    let mid = (seg.start + seg.end) / 2;
    let p = g.demo.frames[mid].object.translation.vector;
    let t_new = seg.start + (mid - seg.start) / 3;
    let t_end = t_new + (seg.end - mid) * 5 / 2;
    let cfg = crate::support::config_with(
        serde_json::json!([{"position": [p.x, p.y + 0.05, p.z], "t": mid, "t_new": t_new}]),
        serde_json::json!({"end_t_new": t_end}),
    );
    let warp = g.warp_with(&cfg, RetimeMode::Chord);
    let init = baseline::run(&g.demo, &warp).unwrap();
    let threshold = 1.0;
    let (hand, stats) = ik::run(&g.robot, &g.demo, &warp, &init, &[], None, &lm(threshold));
    check_threshold(&stats, threshold);
    assert_eq!(stats.converged_fraction, 1.0, "{:?}", stats.not_converged);
    let d_c = |h: &HandPath| {
        let out = pipeline::assemble(&g.demo, &warp, h, "t");
        metrics::d_c_mm(&metrics::contact_distance_per_frame_mm(&g.robot, &out))
    };
    let (dc_ik, dc_base) = (d_c(&hand), d_c(&init));
    eprintln!("non-uniform tau: D_C contact IK {dc_ik:.3} mm, baseline {dc_base:.3} mm");
    assert!(
        dc_ik < dc_base,
        "contact IK {dc_ik:.3} mm, baseline {dc_base:.3} mm"
    );
}

#[test]
fn corruption_is_deterministic_and_zero_is_identity() {
    let g = small();
    for kind in [Corruption::Delete, Corruption::Permute] {
        assert_eq!(corrupt(&g.demo, kind, 0.0, 7), g.demo, "{kind:?} at 0 %");
        let a = corrupt(&g.demo, kind, 0.4, 7);
        assert_eq!(
            a,
            corrupt(&g.demo, kind, 0.4, 7),
            "{kind:?} not deterministic"
        );
        assert_ne!(
            a,
            corrupt(&g.demo, kind, 0.4, 8),
            "{kind:?} ignores the seed"
        );
        assert_ne!(a, g.demo);
    }
    let seg = g.demo.contact_segment().unwrap();
    for fraction in [0.5, 1.0] {
        let d = corrupt(&g.demo, Corruption::Delete, fraction, 1);
        assert_eq!(
            d.contact_segment(),
            Some(seg),
            "the contact segment must not change"
        );
        for (a, b) in d.frames.iter().zip(&g.demo.frames) {
            let n = b.contacts.len();
            let kept = ((1.0 - fraction) * n as f64).round().max(1.0) as usize;
            assert_eq!(a.contacts.len(), if n == 0 { 0 } else { kept });
            assert!(a.contacts.iter().all(|c| b.contacts.contains(c)));
        }
    }
    // Permuting all pairs moves every object point and keeps the hand side.
    let p = corrupt(&g.demo, Corruption::Permute, 1.0, 3);
    for (a, b) in p.frames.iter().zip(&g.demo.frames) {
        for (ca, cb) in a.contacts.iter().zip(&b.contacts) {
            assert_eq!((&ca.link, ca.hand_point), (&cb.link, cb.hand_point));
            assert_ne!(ca.object_point, cb.object_point);
        }
    }
}

#[test]
fn smoothing_keeps_a_straight_line_and_the_frames_outside() {
    let dof = 3;
    let mut hand = HandPath::with_capacity(60, dof);
    for t in 0..60 {
        let s = t as f64;
        let w = Isometry3::from_parts(
            Translation3::new(0.1 + 0.004 * s, -0.002 * s, 0.9 + 0.001 * s),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.01 * s),
        );
        // Jittery joints inside the range.
        let jitter = if t % 2 == 0 { 0.02 } else { -0.02 };
        hand.push(w, &[0.3 + jitter, 0.1 * s.sin(), 0.0]);
    }
    let (out, stats) = smooth::run(&hand, 10..=49, &smooth::Params::default()).unwrap();
    for t in 0..60 {
        let dp = (out.wrists[t].translation.vector - hand.wrists[t].translation.vector).norm();
        assert!(dp < 1e-12, "frame {t}: straight line moved by {dp} m");
        // Constant angular velocity about a fixed axis: the window average is the centre.
        let da = out.wrists[t].rotation.angle_to(&hand.wrists[t].rotation);
        assert!(da < 1e-9, "frame {t}: rotation moved by {da} rad");
        if !(10..=49).contains(&t) {
            assert_eq!(out.q(t), hand.q(t), "frame {t} is outside the range");
        }
    }
    assert!(stats.max_translation_mm < 1e-9);
    // The ±0.02 rad jitter is averaged down inside the range (window of 5: ±0.004).
    for t in 10..=49 {
        assert!(
            (out.q(t)[0] - 0.3).abs() < 0.0041,
            "frame {t}: {}",
            out.q(t)[0]
        );
    }
    assert!(smooth::run(&hand, 10..=60, &smooth::Params::default()).is_err());
    let even = smooth::Params {
        savgol_window: 8,
        ..smooth::Params::default()
    };
    assert!(smooth::run(&hand, 10..=49, &even).is_err());
}

/// A held grasp: a hand sliding ±2 mm along the object's x and flexing a joint while the
/// object moves and turns ends with one pose in the object's frame over the range (the mean
/// of the frames'), the mean joints, and the frames outside untouched.
#[test]
fn a_held_grasp_is_one_pose_in_the_objects_frame() {
    let n = 40;
    let objects: Vec<Isometry3<f64>> = (0..n)
        .map(|t| {
            Isometry3::from_parts(
                Translation3::new(0.01 * t as f64, 0.0, 0.9),
                UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.05 * t as f64),
            )
        })
        .collect();
    let mut hand = HandPath::with_capacity(n, 1);
    for (t, o) in objects.iter().enumerate() {
        let slide = 0.002 * (t as f64 * 0.3).sin();
        let rel = Isometry3::translation(0.1 + slide, 0.0, 0.05);
        hand.push(o * rel, &[0.2 + 0.1 * (t % 2) as f64]);
    }
    let before = hand.clone();
    smooth::hold_grasp(&mut hand, &objects, 10..=29, 10..=29, |_| {}).unwrap();
    let rel = |t: usize| objects[t].inverse() * hand.wrists[t];
    let mean_x = (10..=29)
        .map(|t| (objects[t].inverse() * before.wrists[t]).translation.x)
        .sum::<f64>()
        / 20.0;
    for t in 10..=29 {
        let r = rel(t);
        assert!((r.translation.x - mean_x).abs() < 1e-12, "frame {t}");
        assert!((r.translation.z - 0.05).abs() < 1e-12);
        assert!(r.rotation.angle() < 1e-9);
        assert!(
            (hand.q(t)[0] - 0.25).abs() < 1e-12,
            "frame {t}: {:?}",
            hand.q(t)
        );
    }
    for t in (0..10).chain(30..n) {
        assert_eq!(
            hand.wrists[t], before.wrists[t],
            "frame {t} is outside the range"
        );
        assert_eq!(hand.q(t), before.q(t));
    }
    // Before, the wrist slid along the object's x by more than 3 mm over the range.
    let xs: Vec<f64> = (10..=29)
        .map(|t| (objects[t].inverse() * before.wrists[t]).translation.x)
        .collect();
    let spread =
        xs.iter().cloned().fold(f64::MIN, f64::max) - xs.iter().cloned().fold(f64::MAX, f64::min);
    assert!(spread > 3e-3, "{spread}");
}

/// The carry of a contact segment: the frames where the object is away from where it rests
/// at the segment's ends (a lift over frames 15-24 inside contact 10-29: frame 24 is already
/// at the end's pose); a grasp held over the carry alone is the carry's grasp, not the mean
/// with the hand still closing; and the per-frame hand's share while the grasp is still
/// closing is 1 at rest, falling to 0 over the carry's first frames.
#[test]
fn a_grasp_is_held_over_the_carry_and_forms_at_rest() {
    let n = 40;
    let lift = |t: usize| 0.01 * (t.clamp(14, 24) - 14) as f64;
    let objects: Vec<Isometry3<f64>> = (0..n)
        .map(|t| Isometry3::translation(0.0, 0.0, 0.9 + lift(t)))
        .collect();
    assert_eq!(smooth::carried(&objects, 10..=29, 0.002, 0.035), 15..=23);
    // Turning in place counts (0.05 rad a frame over frames 20-24).
    let turning: Vec<Isometry3<f64>> = (0..n)
        .map(|t| Isometry3::rotation(Vector3::z() * 0.05 * (t.clamp(19, 24) - 19) as f64))
        .collect();
    assert_eq!(smooth::carried(&turning, 10..=29, 0.002, 0.035), 20..=23);
    // Resting throughout, or a motion within the reach: the whole segment.
    let resting = vec![Isometry3::identity(); n];
    assert_eq!(smooth::carried(&resting, 10..=29, 0.002, 0.035), 10..=29);
    let nudged: Vec<Isometry3<f64>> = (0..n)
        .map(|t| Isometry3::translation(0.001 * lift(t), 0.0, 0.0))
        .collect();
    assert_eq!(smooth::carried(&nudged, 10..=29, 0.002, 0.035), 10..=29);

    // A joint still closing (0.0 at rest, 0.5 once carried): held over the carry, it is 0.5;
    // over the whole segment, the mean of both.
    let mut hand = HandPath::with_capacity(n, 1);
    for (t, o) in objects.iter().enumerate() {
        let q = if t < 15 { 0.0 } else { 0.5 };
        hand.push(o * Isometry3::translation(0.1, 0.0, 0.0), &[q]);
    }
    let mut over_range = hand.clone();
    smooth::hold_grasp(&mut over_range, &objects, 10..=29, 10..=29, |_| {}).unwrap();
    assert!((over_range.q(20)[0] - 0.375).abs() < 1e-12);
    smooth::hold_grasp(&mut hand, &objects, 10..=29, 15..=23, |_| {}).unwrap();
    for t in 10..=29 {
        assert!((hand.q(t)[0] - 0.5).abs() < 1e-12, "frame {t}");
    }

    let share = smooth::closing_shares(10..=29, 15, 4);
    let expect = [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.75, 0.5, 0.25, 0.0];
    for (got, want) in share.iter().zip(expect) {
        assert!((got - want).abs() < 1e-12, "{share:?}");
    }
    assert!(share[10..].iter().all(|&s| s == 0.0), "{share:?}");
}

/// Where a held grasp must give way (a barrier), the per-frame solution comes back at that
/// frame as far as asked and blends into the held grasp over the neighbouring frames.
#[test]
fn a_held_grasp_gives_way_to_the_per_frame_hand_as_far_as_asked() {
    let n = 40;
    let objects: Vec<Isometry3<f64>> = (0..n)
        .map(|t| Isometry3::translation(0.01 * t as f64, 0.0, 0.9))
        .collect();
    let mut per_frame = HandPath::with_capacity(n, 1);
    let mut held = HandPath::with_capacity(n, 1);
    for o in &objects {
        per_frame.push(o * Isometry3::translation(0.1, 0.0, 0.05), &[0.4]);
        held.push(o * Isometry3::translation(0.1, 0.0, 0.02), &[0.2]);
    }
    let z = |h: &HandPath, t: usize| (objects[t].inverse() * h.wrists[t]).translation.z;

    // All the way at frame 20.
    let mut hand = held.clone();
    let mut share = vec![0.0; 20];
    share[10] = 1.0; // frame 20
    let changed = smooth::release_held(&mut hand, &per_frame, &objects, 10..=29, &share, 4);
    assert_eq!(changed, 9);
    assert!((z(&hand, 20) - 0.05).abs() < 1e-12);
    assert!((hand.q(20)[0] - 0.4).abs() < 1e-12);
    // One frame away: 4/5 of the way; five frames away: the held grasp.
    assert!(
        (z(&hand, 21) - (0.02 + 0.8 * 0.03)).abs() < 1e-12,
        "{}",
        z(&hand, 21)
    );
    assert!((z(&hand, 19) - z(&hand, 21)).abs() < 1e-12);
    assert!((z(&hand, 25) - 0.02).abs() < 1e-12 && (z(&hand, 15) - 0.02).abs() < 1e-12);

    // Part of the way: 0.4 at frame 20, 0.3 at frame 22; each frame takes the larger ask.
    let mut hand = held.clone();
    share[10] = 0.4;
    share[12] = 0.3;
    smooth::release_held(&mut hand, &per_frame, &objects, 10..=29, &share, 4);
    let expect = |w: f64| 0.02 + w * 0.03;
    assert!(
        (z(&hand, 20) - expect(0.4)).abs() < 1e-12,
        "{}",
        z(&hand, 20)
    );
    assert!((hand.q(20)[0] - (0.2 + 0.4 * 0.2)).abs() < 1e-12);
    assert!(
        (z(&hand, 21) - expect(0.32)).abs() < 1e-12,
        "{}",
        z(&hand, 21)
    );
    assert!(
        (z(&hand, 22) - expect(0.3)).abs() < 1e-12,
        "{}",
        z(&hand, 22)
    );
    assert!(
        (z(&hand, 23) - expect(0.24)).abs() < 1e-12,
        "{}",
        z(&hand, 23)
    );
    assert!((z(&hand, 27) - 0.02).abs() < 1e-12 && (z(&hand, 15) - 0.02).abs() < 1e-12);
}

/// Smoothing the IK hand costs little contact accuracy ("drift", paper Table 3).
#[test]
fn smoothing_drift_is_small() {
    let g = small();
    let warp = waypoint_warp(&g);
    let (hand, stats) = run_ik(&g, &warp, &lm(3.5));
    let range = stats.first_frame..=warp.plan.t_end_new();
    let (smoothed, s) = smooth::run(&hand, range.clone(), &smooth::Params::default()).unwrap();
    for t in (0..hand.len()).filter(|t| !range.contains(t)) {
        assert_eq!(smoothed.wrists[t], hand.wrists[t]);
        assert_eq!(smoothed.q(t), hand.q(t));
    }
    let d_c = |h: &HandPath| {
        let out = pipeline::assemble(&g.demo, &warp, h, "t");
        metrics::d_c_mm(&metrics::contact_distance_per_frame_mm(&g.robot, &out))
    };
    let (before, after) = (d_c(&hand), d_c(&smoothed));
    eprintln!(
        "smoothing: D_C {before:.3} -> {after:.3} mm; wrist moved <= {:.3} mm, {:.3} deg",
        s.max_translation_mm, s.max_rotation_deg
    );
    assert!(after - before < 1.0, "drift {:.3} mm", after - before);
}
