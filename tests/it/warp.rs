//! Object stages 1-3 on synthetic trajectories: waypoints hit, τ monotone, C² spline,
//! continuous orientation, identity, push-out, narrow gap, and bad specs.

use std::path::Path;

use dexwarp::model::config::{ConfigFile, WarpConfig};
use dexwarp::model::{ContactSegment, WarpParams};
use dexwarp::model::{PushoutMode, RetimeMode};
use dexwarp::warp::barrier::Barrier;
use dexwarp::warp::{ObjectParams, ObjectPath, WarpPlan, warp_object};
use nalgebra::{Point3, UnitQuaternion, Vector3};
use proptest::prelude::*;

const N: usize = 300;
const SEG: ContactSegment = ContactSegment {
    start: 40,
    end: 260,
    gap_frames: 0,
};

/// A lift-carry-place path with a slow start and a turning object.
fn demo_path() -> ObjectPath {
    let mut path = ObjectPath::default();
    for i in 0..N {
        let s = ((i as f64 - 40.0) / 220.0).clamp(0.0, 1.0);
        let ease = s * s * (3.0 - 2.0 * s);
        let x = 0.5 * ease;
        let z = 0.9 + 0.25 * (std::f64::consts::PI * s).sin();
        let y = 0.05 * (6.0 * s).sin();
        path.positions.push(Vector3::new(x, y, z));
        path.rotations
            .push(UnitQuaternion::from_euler_angles(0.0, 0.3 * s, 0.8 * ease));
    }
    path
}

fn config(json: serde_json::Value) -> dexwarp::Result<WarpConfig> {
    let file: ConfigFile = serde_json::from_value(json).expect("test config parses");
    WarpConfig::from_file(file, Path::new("test.config.json"))
}

fn base_json() -> serde_json::Value {
    serde_json::json!({
        "format": "dexwarp.config/1", "name": "t", "demo": "d.demo.json", "scene": "s.json",
        "waypoints": [], "barriers": []
    })
}

fn params(mode: RetimeMode) -> ObjectParams {
    ObjectParams::from_config(&WarpParams {
        retime: mode,
        ..WarpParams::default()
    })
}

fn run(
    cfg: &WarpConfig,
    barriers: &[Barrier],
    mode: RetimeMode,
) -> dexwarp::Result<dexwarp::warp::ObjectWarp> {
    let input = demo_path();
    let plan = WarpPlan::new(cfg, &input.positions, SEG)?;
    warp_object(&input, &plan, barriers, 0.05, &params(mode), &cfg.source)
}

fn box_barrier(name: &str, center: [f64; 3], half: [f64; 3]) -> Barrier {
    let mut pts = Vec::new();
    for sx in [-1.0, 1.0] {
        for sy in [-1.0, 1.0] {
            for sz in [-1.0, 1.0] {
                pts.push(Point3::new(
                    center[0] + sx * half[0],
                    center[1] + sy * half[1],
                    center[2] + sz * half[2],
                ));
            }
        }
    }
    Barrier::from_points(name, &pts, 0.05).expect("box hull")
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Every waypoint (and the new start/end) is reached at its output frame within 1e-6 m;
    /// τ is strictly increasing and hits every anchor's t' exactly.
    #[test]
    fn waypoints_are_hit_and_tau_is_monotone(
        k in 0usize..6,
        offsets in prop::collection::vec((-0.4f64..0.4, -0.4f64..0.4, -0.2f64..0.3), 6),
        stretch in prop::collection::vec(0.3f64..3.0, 7),
        new_start in any::<bool>(),
        new_end in any::<bool>(),
        chord in any::<bool>(),
    ) {
        let input = demo_path();
        let mut wps = Vec::new();
        let (mut t_new, mut prev_t) = (SEG.start as f64, SEG.start);
        for j in 0..k {
            let t = SEG.start + (j + 1) * (SEG.end - SEG.start) / (k + 1);
            t_new += ((t - prev_t) as f64 * stretch[j]).round().max(1.0);
            prev_t = t;
            let p = input.positions[t] + Vector3::new(offsets[j].0, offsets[j].1, offsets[j].2);
            wps.push(serde_json::json!({"position": [p.x, p.y, p.z], "t": t, "t_new": t_new,
                "rotation": {"axis": [0.0, 0.0, 1.0], "angle": 0.3 * j as f64}}));
        }
        let mut j = base_json();
        j["waypoints"] = serde_json::Value::Array(wps);
        if new_start { j["start"] = serde_json::json!([0.1, -0.2, 0.92]); }
        if new_end { j["end"] = serde_json::json!([0.7, 0.3, 0.95]); }
        let cfg = config(j).unwrap();
        let mode = if chord { RetimeMode::Chord } else { RetimeMode::Speed };
        let out = run(&cfg, &[], mode).unwrap();
        let path = out.path();
        for a in &out.plan.anchors {
            let err = (path.positions[a.t_new] - a.position).norm();
            prop_assert!(err < 1e-6, "anchor t={} t'={} missed by {err} m", a.t, a.t_new);
        }
        let tau = &out.retime.timewarp.tau;
        for w in tau.windows(2) {
            prop_assert!(w[1] > w[0], "tau not increasing: {} then {}", w[0], w[1]);
        }
        for a in &out.plan.anchors {
            prop_assert_eq!(tau[a.t], a.t_new as f64);
        }
        prop_assert_eq!(path.len(), out.plan.frames_out());
        if new_start {
            prop_assert!((path.positions[SEG.start] - Vector3::new(0.1, -0.2, 0.92)).norm() < 1e-6);
            // Pre-contact frames move rigidly with the start.
            let shift = Vector3::new(0.1, -0.2, 0.92) - input.positions[SEG.start];
            prop_assert!((path.positions[0] - input.positions[0] - shift).norm() < 1e-9);
        }
        if new_end {
            prop_assert!((path.positions[out.plan.t_end_new()] - Vector3::new(0.7, 0.3, 0.95)).norm() < 1e-6);
        }
    }
}

/// The position spline is C²: the second derivative agrees from both sides of every knot.
#[test]
fn position_spline_is_c2() {
    let input = demo_path();
    let mut j = base_json();
    j["waypoints"] = serde_json::json!([
        {"position": [0.2, 0.2, 1.3], "t": 100, "t_new": 130},
        {"position": [0.4, -0.1, 1.1], "t": 200, "t_new": 215}
    ]);
    let cfg = config(j).unwrap();
    let out = run(&cfg, &[], RetimeMode::Chord).unwrap();
    let spline = &out.retime.spline;
    let knots = spline.knots().to_vec();
    let (lo, hi) = spline.domain();
    let scale = input.length();
    let mut worst = 0.0f64;
    let mut checked = 0;
    for &u in &knots {
        if u <= lo + 1e-6 || u >= hi - 1e-6 {
            continue;
        }
        checked += 1;
        let d = 1e-7;
        let a = spline.eval_derivative3(u - d, 2);
        let b = spline.eval_derivative3(u + d, 2);
        worst = worst.max((a - b).norm());
    }
    // The third derivative is bounded, so a jump in the second derivative over 2e-7 frames
    // would have to come from a discontinuity. Typical |x''| here is ~1e-4 m/frame².
    assert!(checked > 100, "only {checked} interior knots");
    assert!(
        worst < 1e-8 * scale.max(1.0),
        "second derivative jumps by {worst} at a knot"
    );
    // The check has teeth: the first derivative of the piecewise-linear interpolant of the
    // same data does jump at its knots by far more than this tolerance.
    let a = out.retime.path.positions[150] - out.retime.path.positions[149];
    let b = out.retime.path.positions[151] - out.retime.path.positions[150];
    assert!((a - b).norm() > 1e-8);
}

/// A 90° waypoint rotation is spread over its segment: no jump between consecutive frames.
#[test]
fn orientation_is_continuous_at_waypoints() {
    let mut j = base_json();
    j["waypoints"] = serde_json::json!([
        {"position": [0.2, 0.0, 1.1], "t": 120, "t_new": 120,
         "rotation": {"axis": [0, 0, 1], "angle": std::f64::consts::FRAC_PI_2}},
        {"position": [0.4, 0.0, 1.0], "t": 200, "t_new": 200,
         "rotation": {"axis": [1, 0, 0], "angle": -0.6}}
    ]);
    let cfg = config(j).unwrap();
    let out = run(&cfg, &[], RetimeMode::Speed).unwrap();
    let path = out.path();
    let mut worst = 0.0f64;
    for t in SEG.start..out.plan.t_end_new() + 5 {
        worst = worst.max(path.rotations[t].angle_to(&path.rotations[t + 1]));
    }
    assert!(
        worst < 0.05,
        "largest frame-to-frame rotation {worst} rad (a jump)"
    );
    // After the last waypoint the full cumulative rotation holds.
    let input = demo_path();
    let c = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2)
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -0.6);
    let want = c * input.rotations[SEG.end];
    let got = path.rotations[out.plan.t_end_new()];
    assert!(
        want.angle_to(&got) < 1e-9,
        "end rotation off by {}",
        want.angle_to(&got)
    );
}

/// No waypoints, barriers, start or end: the output equals the input (speed rule).
#[test]
fn identity_warp_returns_the_input() {
    let input = demo_path();
    let cfg = config(base_json()).unwrap();
    let out = run(&cfg, &[], RetimeMode::Speed).unwrap();
    assert_eq!(out.path().len(), N);
    for i in 0..N {
        let dp = (out.path().positions[i] - input.positions[i]).norm();
        let da = out.path().rotations[i].angle_to(&input.rotations[i]);
        assert!(
            dp < 1e-9 && da < 1e-9,
            "frame {i}: moved {dp} m, turned {da} rad"
        );
        assert!((out.retime.timewarp.tau[i] - i as f64).abs() < 1e-9);
    }
    assert!(out.retime.timewarp.discrepancy() < 1e-12);
}

/// The paper's chord rule keeps the path (only the timing changes) on an identity spec.
#[test]
fn identity_spec_under_chord_rule_keeps_the_path() {
    let input = demo_path();
    let cfg = config(base_json()).unwrap();
    let out = run(&cfg, &[], RetimeMode::Chord).unwrap();
    assert_eq!(out.path().len(), N);
    // Every input position is passed through at its τ.
    for f in SEG.start..=SEG.end {
        let p = out.retime.spline.eval3(out.retime.timewarp.tau[f]);
        assert!((p - input.positions[f]).norm() < 1e-9);
    }
    assert!(
        out.retime.timewarp.discrepancy() > 0.0,
        "chord rule retimes a non-uniform demo"
    );
}

/// After the push-out no movable position is inside an inflated barrier, and the barriers
/// did push (the path went through them).
#[test]
fn pushout_leaves_no_point_inside() {
    let input = demo_path();
    let barriers = vec![
        box_barrier("block", [0.25, 0.0, 1.12], [0.04, 0.15, 0.05]),
        box_barrier("post", [0.4, 0.05, 1.0], [0.02, 0.02, 0.1]),
    ];
    for mode in [PushoutMode::Paper, PushoutMode::Exact] {
        let cfg = config(base_json()).unwrap();
        let plan = WarpPlan::new(&cfg, &input.positions, SEG).unwrap();
        let mut p = params(RetimeMode::Chord);
        p.barrier.mode = mode;
        let out = warp_object(&input, &plan, &barriers, 0.05, &p, &cfg.source).unwrap();
        let st = &out.barrier.stats;
        assert!(st.frames_moved > 5, "{mode:?}: expected pushes, got {st:?}");
        assert!(st.narrow_gap.is_none(), "{mode:?}: {st:?}");
        for f in SEG.start + 1..SEG.end {
            let q = Point3::from(out.barrier.positions[f]);
            for b in &barriers {
                assert!(
                    !b.contains(&q, mode),
                    "{mode:?}: frame {f} inside {}",
                    b.name
                );
            }
        }
    }
}

/// Exact mode is less conservative than the paper's scaled hull for an elongated barrier.
#[test]
fn exact_mode_moves_less_than_paper_mode() {
    let input = demo_path();
    let wall = vec![box_barrier("wall", [0.25, 0.0, 1.0], [0.01, 0.5, 0.1])];
    let cfg = config(base_json()).unwrap();
    let plan = WarpPlan::new(&cfg, &input.positions, SEG).unwrap();
    let mut moved = Vec::new();
    for mode in [PushoutMode::Paper, PushoutMode::Exact] {
        let mut p = params(RetimeMode::Chord);
        p.barrier.mode = mode;
        let out = warp_object(&input, &plan, &wall, 0.05, &p, &cfg.source).unwrap();
        moved.push(out.barrier.stats.max_push_m);
    }
    assert!(
        moved[1] < moved[0],
        "exact {} m vs paper {} m",
        moved[1],
        moved[0]
    );
}

/// Two barriers facing each other across the path trap it: reported as a narrow gap, with
/// frames and both barriers named, after a bounded number of sweeps.
#[test]
fn narrow_gap_is_reported() {
    let input = demo_path();
    let barriers = vec![
        box_barrier("left", [0.25, -0.06, 1.12], [0.03, 0.03, 0.3]),
        box_barrier("right", [0.25, 0.1, 1.12], [0.03, 0.03, 0.3]),
    ];
    let cfg = config(base_json()).unwrap();
    let plan = WarpPlan::new(&cfg, &input.positions, SEG).unwrap();
    let out = warp_object(
        &input,
        &plan,
        &barriers,
        0.05,
        &params(RetimeMode::Chord),
        &cfg.source,
    )
    .unwrap();
    let gap = out
        .barrier
        .stats
        .narrow_gap
        .as_ref()
        .unwrap_or_else(|| panic!("expected a narrow gap: {:?}", out.barrier.stats));
    assert!(!gap.frames.is_empty());
    assert!(
        gap.barriers.contains(&"left".to_string()) || gap.barriers.contains(&"right".to_string())
    );
    assert!(out.barrier.stats.sweeps <= 64);
}

#[test]
fn waypoint_inside_inflated_barrier_is_a_conflict() {
    let mut j = base_json();
    j["waypoints"] = serde_json::json!([{"position": [0.25, 0.0, 1.12], "t": 120, "t_new": 120}]);
    let cfg = config(j).unwrap();
    let barriers = vec![box_barrier("block", [0.25, 0.0, 1.12], [0.04, 0.15, 0.05])];
    let err = run(&cfg, &barriers, RetimeMode::Chord)
        .unwrap_err()
        .to_string();
    assert!(err.contains("waypoints[0].position"), "{err}");
    assert!(err.contains("inside barrier \"block\""), "{err}");
}

#[test]
fn bad_specs_are_refused_with_the_field_named() {
    let cases = [
        (
            serde_json::json!([{"position": [0,0,1], "t": 100, "t_new": 100},
                             {"position": [0,0,1], "t": 90, "t_new": 120}]),
            "waypoints[1].t",
            "strictly increasing t",
        ),
        (
            serde_json::json!([{"position": [0,0,1], "t": 100, "t_new": 100},
                             {"position": [0,0,1], "t": 120, "t_new": 100}]),
            "waypoints[1].t_new",
            "strictly increasing t_new",
        ),
        (
            serde_json::json!([{"position": [0,0,1], "t": 100, "t_new": -5}]),
            "waypoints[0].t_new",
            "whole number >= 0",
        ),
        (
            serde_json::json!([{"position": [0,0,1], "t": 10.5, "t_new": 20}]),
            "waypoints[0].t",
            "whole number",
        ),
        (
            serde_json::json!([{"position": [0,0,1], "t": 100, "t_new": 100,
                             "rotation": {"axis": [0,0,0], "angle": 1.0}}]),
            "waypoints[0].rotation.axis",
            "non-zero axis",
        ),
    ];
    for (wps, field, expect) in cases {
        let mut j = base_json();
        j["waypoints"] = wps;
        let err = config(j).unwrap_err().to_string();
        assert!(err.contains(field) && err.contains(expect), "{err}");
    }
    // A waypoint outside the demonstration, and one outside the contact segment.
    for (t, expect) in [
        (5000, "outside the demonstration"),
        (20, "strictly inside the contact segment"),
    ] {
        let mut j = base_json();
        j["waypoints"] = serde_json::json!([{"position": [0,0,1], "t": t, "t_new": 100}]);
        let cfg = config(j).unwrap();
        let err = WarpPlan::new(&cfg, &demo_path().positions, SEG)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("waypoints[0].t") && err.contains(expect),
            "{err}"
        );
    }
    // NaN cannot be written in JSON: the parser says so with the position.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("c.json");
    std::fs::write(
        &p,
        r#"{"format": "dexwarp.config/1", "name": "x", "demo": "d", "scene": "s",
        "waypoints": [{"position": [NaN, 0, 1], "t": 3, "t_new": 4}]}"#,
    )
    .unwrap();
    let err = WarpConfig::load(&p, &dexwarp::Limits::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("line 2") && err.contains("no NaN"), "{err}");
}
