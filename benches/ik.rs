//! Contact IK benchmarks (stage 4), on the synthetic grasp of `tests/it/support.rs`
//! (human_hand, 50 correspondences on the finger links).
//!
//! - `frame_3_5mm(lm|adam)`: one frame at 3.5 mm from a realistic warm start: the exact hand
//!   of the previous input frame of a fast 30 fps demonstration (object and in-hand motion of
//!   several mm per frame), cycling over the frames whose warm start misses the threshold.
//! - `hand_stage_lm` / `hand_stage_adam`: `ik::run` over a 700-frame demonstration warped
//!   through two waypoints (baseline hand as `init`), 3.5 mm.
//!
//! Targets (release): LM median < 100 µs per frame, the LM hand stage < 0.1 s; with
//! non-penetration on (the built-in configs below), < 50 µs per frame. Before divan runs, `main` times both solvers in the same process
//! (hand stage at 10, 5 and 3.5 mm, and the per-frame problems) and prints the medians,
//! iteration counts and Adam/LM ratios; then the IK stage of every built-in human-hand
//! config at 3.5 mm, default objective (non-penetration on, barriers, the recording's stop
//! targets), as `warp` runs it: median over runs of the stage's own clock, per frame of
//! the contact segment. (The synthetic grasp has no object field: its contacts are the
//! hand's own points, inside the cube, so non-penetration cannot be measured on it.) Run with `cargo bench --bench ik`.

use std::hint::black_box;
use std::sync::LazyLock;
use std::time::Instant;

use dexwarp::hand::ik::{self, IkSolver, Params, ResolvedContact, Solver};
use dexwarp::hand::{HandPath, baseline};
use dexwarp::pipeline::{self, HandMethod, Inputs, Options};
use dexwarp::warp::ObjectWarp;
use nalgebra::{Isometry3, Vector3};

#[path = "../tests/it/support.rs"]
mod support;

use dexwarp::model::RetimeMode;
use support::{GraspDemo, GraspOptions};

/// One frame's problem: object pose, correspondences, warm start.
struct Problem {
    object: Isometry3<f64>,
    contacts: Vec<ResolvedContact>,
    wrist: Isometry3<f64>,
    q: Vec<f64>,
}

/// Per-frame problems of a fast demonstration: frame t's correspondences and object pose,
/// warm-started from the demonstrated hand of frame t − 1; only the frames whose warm start
/// misses the 3.5 mm threshold (the others cost no iteration).
static FRAMES: LazyLock<(GraspDemo, Vec<Problem>)> = LazyLock::new(|| {
    let g = GraspDemo::build(&GraspOptions {
        pre: 5,
        contact: 60,
        post: 5,
        in_hand_slide: Vector3::new(0.0, 0.0, 0.05),
        in_hand_turn_rad: 0.5,
        ..GraspOptions::default()
    });
    let seg = g.demo.contact_segment().unwrap();
    let problems = (seg.start + 1..=seg.end)
        .map(|t| {
            let (f, prev) = (&g.demo.frames[t], &g.demo.frames[t - 1]);
            Problem {
                object: f.object,
                contacts: ik::resolve_contacts(&g.robot, &f.contacts),
                wrist: prev.wrist,
                q: prev.joints.clone(),
            }
        })
        .filter(|p| mean_distance_mm(&g, p) >= 3.5)
        .collect();
    (g, problems)
});

/// A 700-frame demonstration, its warp through two waypoints and the baseline hand.
static STAGE: LazyLock<(GraspDemo, ObjectWarp, HandPath)> = LazyLock::new(|| {
    let g = GraspDemo::build(&GraspOptions {
        pre: 20,
        contact: 660,
        post: 20,
        in_hand_slide: Vector3::new(0.0, 0.0, 0.04),
        in_hand_turn_rad: 0.4,
        ..GraspOptions::default()
    });
    let seg = g.demo.contact_segment().unwrap();
    let (t1, t2) = (seg.start + 220, seg.start + 440);
    let p1 = g.demo.frames[t1].object.translation.vector + Vector3::new(0.0, 0.1, 0.05);
    let p2 = g.demo.frames[t2].object.translation.vector + Vector3::new(0.05, -0.05, 0.1);
    let warp = g.warp(
        serde_json::json!([
            {"position": [p1.x, p1.y, p1.z], "t": t1, "t_new": t1 - 40},
            {"position": [p2.x, p2.y, p2.z], "t": t2, "t_new": t2 + 20,
             "rotation": {"axis": [0, 0, 1], "angle": 0.4}}
        ]),
        RetimeMode::Chord,
    );
    let init = baseline::run(&g.demo, &warp).unwrap();
    (g, warp, init)
});

fn params(solver: Solver) -> Params {
    Params {
        solver,
        threshold_mm: 3.5,
        ..Params::default()
    }
}

/// The built-in configs whose demonstration is the human hand's.
const HUMAN_HAND_CONFIGS: [&str; 14] = [
    "cube_messy",
    "cube_messy2",
    "fryingpan_change_tops",
    "fryingpan_island",
    "fryingpan_onto_shelf",
    "fryingpan_timewarp_stress_rotate",
    "mug_pass_in_sink",
    "mug_pass_wall",
    "mug_pass_wall_short",
    "mug_timewarp_stress_barrier",
    "mug_timewarp_stress_compress",
    "teapot_pour_cup_long",
    "teapot_pour_cups",
    "teapot_pour_cups_wall",
];

/// The IK stage of each built-in human-hand config at 3.5 mm (default objective), as `warp`
/// runs it: median over `runs` of the stage's own clock per contact-segment frame.
fn builtin_configs(runs: usize) {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/configs");
    let options = Options::new(HandMethod::Contact)
        .threshold_mm(Some(3.5))
        .physics(None);
    let mut per_frame = Vec::new();
    for name in HUMAN_HAND_CONFIGS {
        let inputs = Inputs::load(&root.join(format!("{name}.json")), None, &options.limits)
            .expect("built-in config loads");
        let mut times = Vec::new();
        let mut summary = String::new();
        for _ in 0..runs {
            let run = pipeline::warp(&inputs, &options).expect("built-in config warps");
            let plan = &run.object.plan;
            let frames = plan.t_end_new() + 1 - plan.segment.start;
            times.push(run.report.timing_s["ik"] / frames as f64);
            if let Some(ik) = &run.report.ik {
                summary = format!(
                    "{frames} frames, {:.2} iterations per frame, {:.1} % converged",
                    ik.mean_iterations,
                    ik.converged_fraction * 100.0
                );
            }
        }
        let m = median(times);
        println!(
            "builtin {name:<34} median {:7.1} µs per frame; {summary}",
            m * 1e6
        );
        per_frame.push(m);
    }
    println!(
        "builtin human-hand configs: median of the medians {:.1} µs per frame, largest {:.1}",
        median(per_frame.clone()) * 1e6,
        per_frame.iter().copied().fold(0.0, f64::max) * 1e6
    );
}

fn stage(params: &Params) -> (HandPath, ik::Stats) {
    let (g, warp, init) = &*STAGE;
    ik::run(&g.robot, &g.demo, warp, init, &[], None, params)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    // Same-run medians of both hand stages and their ratio (divan's own report follows).
    let time = |f: &mut dyn FnMut()| {
        let times: Vec<f64> = (0..7)
            .map(|_| {
                let clock = Instant::now();
                f();
                clock.elapsed().as_secs_f64()
            })
            .collect();
        median(times)
    };
    for threshold_mm in [10.0, 5.0, 3.5] {
        let mut medians = Vec::new();
        for solver in [Solver::Lm, Solver::Adam] {
            let p = Params {
                threshold_mm,
                ..params(solver)
            };
            let (_, stats) = stage(&p);
            let m = time(&mut || {
                black_box(stage(&p));
            });
            println!(
                "hand stage {threshold_mm:>4} mm {:>4}: median {:7.2} ms over {} frames; \
                 {:.1} % converged, mean {:.2} / max {} iterations, D_C {:.2} mm",
                solver.as_str(),
                m * 1e3,
                stats.frames.len(),
                stats.converged_fraction * 100.0,
                stats.mean_iterations,
                stats.max_iterations_used,
                stats.d_c_mm
            );
            medians.push(m);
        }
        println!(
            "hand stage {threshold_mm:>4} mm Adam / LM: {:.1}x",
            medians[1] / medians[0]
        );
    }
    let (g, problems) = &*FRAMES;
    let mut medians = Vec::new();
    for solver in [Solver::Lm, Solver::Adam] {
        let mut ik = IkSolver::new(&g.robot, &[], None, params(solver));
        let mut iterations = 0;
        let mut solve_all = |iterations: &mut usize| {
            for p in problems {
                let (mut w, mut q) = (p.wrist, p.q.clone());
                *iterations += ik.solve(&p.object, &p.contacts, &mut w, &mut q).iterations;
            }
        };
        solve_all(&mut iterations);
        let m = time(&mut || solve_all(&mut 0)) / problems.len() as f64;
        println!(
            "frame {:>4} 3.5 mm: median {:7.2} µs per frame over {} frames whose warm start \
             is {:.2} mm off on average; {:.2} iterations per frame",
            solver.as_str(),
            m * 1e6,
            problems.len(),
            problems.iter().map(|p| mean_distance_mm(g, p)).sum::<f64>() / problems.len() as f64,
            iterations as f64 / problems.len() as f64
        );
        medians.push(m);
    }
    println!("frame Adam / LM: {:.1}x", medians[1] / medians[0]);
    builtin_configs(9);
    divan::main();
}

/// Mean contact distance of a problem's warm start [mm].
fn mean_distance_mm(g: &GraspDemo, p: &Problem) -> f64 {
    let mut poses = g.robot.new_link_poses();
    g.robot.forward_kinematics(&p.wrist, &p.q, &mut poses);
    p.contacts
        .iter()
        .map(|c| (poses[c.link.index()] * c.hand_point - p.object * c.object_point).norm())
        .sum::<f64>()
        / p.contacts.len() as f64
        * 1e3
}

#[divan::bench(args = [Solver::Lm, Solver::Adam])]
fn frame_3_5mm(bencher: divan::Bencher, solver: Solver) {
    let (g, problems) = &*FRAMES;
    let mut solver = IkSolver::new(&g.robot, &[], None, params(solver));
    let mut next = 0;
    bencher
        .with_inputs(|| {
            let p = &problems[next % problems.len()];
            next += 1;
            (p, p.wrist, p.q.clone())
        })
        .bench_local_values(|(p, mut w, mut q)| {
            solver.solve(&p.object, &p.contacts, &mut w, &mut q)
        });
}

#[divan::bench(sample_count = 20)]
fn hand_stage_lm(bencher: divan::Bencher) {
    LazyLock::force(&STAGE);
    bencher.bench(|| stage(&params(Solver::Lm)));
}

#[divan::bench(sample_count = 5, sample_size = 1)]
fn hand_stage_adam(bencher: divan::Bencher) {
    LazyLock::force(&STAGE);
    bencher.bench(|| stage(&params(Solver::Adam)));
}
