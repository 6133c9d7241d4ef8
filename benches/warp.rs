//! Object stages 1-3 on a 700-frame trajectory with 6 waypoints and 8 barriers
//! (issue target: under 5 ms, median, release).

use dexwarp::model::ContactSegment;
use dexwarp::model::config::{ConfigFile, WarpConfig};
use dexwarp::model::{PushoutMode, RetimeMode};
use dexwarp::warp::barrier::Barrier;
use dexwarp::warp::{ObjectParams, ObjectPath, WarpPlan, warp_object};
use nalgebra::{Point3, UnitQuaternion, Vector3};

fn main() {
    divan::main();
}

const N: usize = 700;
const SEG: ContactSegment = ContactSegment {
    start: 80,
    end: 620,
    gap_frames: 0,
};

fn path() -> ObjectPath {
    let mut p = ObjectPath::default();
    for i in 0..N {
        let s = ((i as f64 - 80.0) / 540.0).clamp(0.0, 1.0);
        let e = s * s * (3.0 - 2.0 * s);
        p.positions.push(Vector3::new(
            0.8 * e,
            0.1 * (5.0 * s).sin(),
            0.9 + 0.3 * (std::f64::consts::PI * s).sin(),
        ));
        p.rotations
            .push(UnitQuaternion::from_euler_angles(0.0, 0.4 * s, 1.2 * e));
    }
    p
}

fn setup(
    mode: PushoutMode,
    retime: RetimeMode,
) -> (ObjectPath, WarpPlan, Vec<Barrier>, ObjectParams, WarpConfig) {
    let input = path();
    let wps: Vec<_> = (0..6)
        .map(|j| {
            let t = 80 + (j + 1) * 540 / 7;
            let p = input.positions[t] + Vector3::new(0.05, 0.15 * (j as f64 - 2.5), 0.1);
            serde_json::json!({"position": [p.x, p.y, p.z], "t": t, "t_new": t + 10 * j,
                "rotation": {"axis": [0, 0, 1], "angle": 0.1}})
        })
        .collect();
    let file: ConfigFile = serde_json::from_value(serde_json::json!({
        "format": "dexwarp.config/1", "name": "bench", "demo": "d", "scene": "s",
        "waypoints": wps, "barriers": []
    }))
    .unwrap();
    let cfg = WarpConfig::from_file(file, std::path::Path::new("bench.json")).unwrap();
    let plan = WarpPlan::new(&cfg, &input.positions, SEG).unwrap();
    // Six boxes beside the path and two small ones on it, between waypoints, so the push-out
    // has real work (frames moved is printed once).
    let boxes: Vec<(Vector3<f64>, Vector3<f64>)> = (0..6)
        .map(|k| {
            let c = Vector3::new(0.15 * k as f64, if k % 2 == 0 { 0.6 } else { -0.6 }, 0.95);
            (c, Vector3::new(0.03, 0.05, 0.12))
        })
        .collect();
    let free = warp_object(
        &input,
        &plan,
        &[],
        0.05,
        &ObjectParams::default(),
        &cfg.source,
    )
    .unwrap();
    let cube = |c: Vector3<f64>, h: Vector3<f64>, name: String| {
        let mut pts = Vec::new();
        for sx in [-1.0, 1.0] {
            for sy in [-1.0, 1.0] {
                for sz in [-1.0, 1.0] {
                    pts.push(Point3::from(c + Vector3::new(sx * h.x, sy * h.y, sz * h.z)));
                }
            }
        }
        Barrier::from_points(&name, &pts, 0.05).unwrap()
    };
    let mut barriers: Vec<Barrier> = boxes
        .iter()
        .enumerate()
        .map(|(k, (c, h))| cube(*c, *h, format!("b{k}")))
        .collect();
    // Two small cubes on the warped path, clear of every waypoint.
    for f in (160..600).step_by(9) {
        if barriers.len() == 8 {
            break;
        }
        let c = free.barrier.positions[f] + Vector3::new(0.0, 0.03, 0.0);
        let b = cube(c, Vector3::repeat(0.02), format!("b{}", barriers.len()));
        let clear = plan
            .anchors
            .iter()
            .all(|a| !b.contains(&Point3::from(a.position), PushoutMode::Paper));
        let apart = barriers
            .last()
            .is_none_or(|l| (l.centroid - b.centroid).norm() > 0.3);
        if clear && apart {
            barriers.push(b);
        }
    }
    assert_eq!(barriers.len(), 8, "bench layout must place eight barriers");
    let mut params = ObjectParams::default();
    params.barrier.mode = mode;
    params.retime.mode = retime;
    (input, plan, barriers, params, cfg)
}

#[divan::bench(args = ["paper", "exact"])]
fn object_stages(bencher: divan::Bencher, mode: &str) {
    let m = if mode == "paper" {
        PushoutMode::Paper
    } else {
        PushoutMode::Exact
    };
    let (input, plan, barriers, params, cfg) = setup(m, RetimeMode::Chord);
    let once = warp_object(&input, &plan, &barriers, 0.05, &params, &cfg.source).unwrap();
    eprintln!(
        "{mode}: {} frames in, {} out, {} frames pushed out, narrow gap: {}",
        N,
        once.path().len(),
        once.barrier.stats.frames_moved,
        once.barrier.stats.narrow_gap.is_some()
    );
    bencher.bench(|| warp_object(&input, &plan, &barriers, 0.05, &params, &cfg.source).unwrap());
}
