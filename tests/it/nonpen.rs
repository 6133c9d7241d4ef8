//! Contact IK whose outputs are physical: fingers kept out of the object by default, an
//! honest stop rule, and the rigid transfer kept where it is exact.

use std::path::Path;

use dexwarp::Limits;
use dexwarp::hand::ik::{Solver, StopReason};
use dexwarp::model::config::{ConfigFile, WarpConfig};
use dexwarp::pipeline::{self, HandMethod, Inputs, Options};

use crate::fixtures::repo;
use dexwarp::model::Objective;

fn warp(
    config: &Path,
    objective: Objective,
    solver: Solver,
    hand: HandMethod,
) -> pipeline::WarpRun {
    let inputs = Inputs::load(config, None, &Limits::default()).expect("config loads");
    pipeline::warp(
        &inputs,
        &Options::new(hand)
            .threshold_mm(Some(3.5))
            .objective(Some(objective))
            .solver(solver)
            .physics(None),
    )
    .expect("warp runs")
}

/// Stage 4 alone on a built-in config: contact IK with `params`, warm-started from the
/// baseline hand, with the config's barriers and the object's distance field.
fn solve_ik(config: &str, params: &dexwarp::hand::ik::Params) -> dexwarp::hand::ik::Stats {
    use dexwarp::hand::{baseline, ik};
    let config = repo(config);
    let inputs = Inputs::load(&config, None, &Limits::default()).unwrap();
    let run = warp(
        &config,
        Objective::NonPenetrating,
        Solver::Lm,
        HandMethod::Baseline,
    );
    let sdf = dexwarp::geometry::object_sdf(&inputs.mesh).unwrap();
    let barriers =
        pipeline::barrier_shapes(&inputs.config, &inputs.scene, &Limits::default()).unwrap();
    let init = baseline::run(&inputs.demo, &run.object).unwrap();
    ik::run(
        &inputs.robot,
        &inputs.demo,
        &run.object,
        &init,
        &barriers,
        Some(&sdf),
        params,
    )
    .1
}

/// A loose threshold never returns contacts fitting worse than the recording's: at 10 mm
/// the default objective stops a frame only below the recording's own fit (its source
/// frame's and its D_C), so D_C stays at or below the original's even where τ stretches the
/// worst-fitting frames; the paper's objective keeps its stop rule as printed and stops at
/// the warm start once the mean is under 10 mm.
#[test]
fn a_loose_threshold_never_fits_worse_than_the_recording() {
    for name in [
        "cube_messy2",
        "teapot_pour_empty",
        "fryingpan_timewarp_stress_rotate",
    ] {
        let inputs = Inputs::load(
            &repo(&format!("scenes/configs/{name}.json")),
            None,
            &Limits::default(),
        )
        .expect("config loads");
        let run = |objective| {
            pipeline::warp(
                &inputs,
                &Options::new(HandMethod::Contact)
                    .threshold_mm(Some(10.0))
                    .objective(Some(objective))
                    .physics(None),
            )
            .expect("warp runs")
        };
        let ours = run(Objective::NonPenetrating);
        let dc = &ours.report.metrics.d_c_mm;
        let ik = ours.report.ik.as_ref().expect("contact IK ran");
        eprintln!(
            "{name} at 10 mm: D_C original {:.3} mm, output {:.3} mm, {:.1} % converged",
            dc.original,
            dc.warped,
            100.0 * ik.converged_fraction
        );
        assert!(dc.warped <= dc.original, "{name}: D_C {dc:?}");
        let paper = run(Objective::Paper);
        let paper_ik = paper.report.ik.as_ref().expect("contact IK ran");
        let paper_dc = &paper.report.metrics.d_c_mm;
        eprintln!(
            "{name} at 10 mm, the paper's stop rule: D_C {:.3} mm, {:.3} iterations per frame (ours {:.3})",
            paper_dc.warped, paper_ik.mean_iterations, ik.mean_iterations
        );
        assert!(
            paper_dc.warped > dc.warped,
            "{name}: without the recording's targets the fit is looser ({paper_dc:?} vs {dc:?})"
        );
        assert!(
            paper_ik.mean_iterations < ik.mean_iterations,
            "{name}: the paper's stop rule stops earlier ({} vs {} iterations per frame)",
            paper_ik.mean_iterations,
            ik.mean_iterations
        );
    }
}

/// At 3.5 mm the default objective keeps the deepest finger within the original's depth plus
/// 1 mm and D_C at or below the original's, where the paper's objective presses fingers in;
/// every frame that misses the stop rule says why.
#[test]
fn default_objective_keeps_fingers_out_where_the_paper_presses_in() {
    for name in ["mug_pass_wall", "cube_messy"] {
        let config = repo(&format!("scenes/configs/{name}.json"));
        let ours = warp(
            &config,
            Objective::NonPenetrating,
            Solver::Lm,
            HandMethod::Contact,
        );
        let paper = warp(&config, Objective::Paper, Solver::Lm, HandMethod::Contact);
        let pen = |r: &pipeline::WarpRun| r.report.constraints.hand_object_penetration_mm.unwrap();
        let (po, pp) = (pen(&ours), pen(&paper));
        let dc = &ours.report.metrics.d_c_mm;
        eprintln!(
            "{name}: penetration original {:.2} mm, default {:.2} mm, paper {:.2} mm; D_C original {:.2}, default {:.2}, paper {:.2} mm",
            po.original,
            po.warped,
            pp.warped,
            dc.original,
            dc.warped,
            paper.report.metrics.d_c_mm.warped
        );
        assert!(po.warped <= po.original + 1.0, "{name}: {po:?}");
        assert!(dc.warped <= dc.original, "{name}: D_C {dc:?}");
        assert!(
            pp.warped > po.warped + 1.0,
            "{name}: paper {pp:?} vs default {po:?}"
        );
        let ik = ours.report.ik.as_ref().unwrap();
        let counted: usize = ik.stop_reasons.values().sum();
        assert_eq!(
            counted,
            ik.not_converged_frames.len(),
            "{name}: {:?}",
            ik.stop_reasons
        );
        assert!(!ik.stop_reasons.contains_key("converged"));
    }
}

/// Neither solver returns a frame with a higher objective than its warm start.
#[test]
fn no_frame_ends_worse_than_its_warm_start() {
    use dexwarp::hand::ik;
    for solver in [Solver::Lm, Solver::Adam] {
        let params = ik::Params {
            solver,
            max_iterations: if solver == Solver::Adam { 200 } else { 0 },
            warm_start: dexwarp::model::WarmStart::FollowObject,
            ..ik::Params::default()
        };
        let stats = solve_ik("scenes/configs/mug_pass_wall.json", &params);
        for (k, f) in stats.frames.iter().enumerate() {
            assert!(
                f.objective_end <= f.objective_start * (1.0 + 1e-12) + 1e-15,
                "{solver:?} frame {k}: F {} after, {} at the warm start ({:?})",
                f.objective_end,
                f.objective_start,
                f.stop
            );
            assert_eq!(f.converged, f.stop == StopReason::Converged);
        }
    }
}

/// A pure translation of the whole demonstration by 25 cm (past α, so the blend is linear),
/// timing kept: contact IK gives back the rigid transfer within 1 mm at every frame.
#[test]
fn a_pure_translation_returns_the_rigid_transfer() {
    let dir = tempfile::tempdir().unwrap();
    let src = repo("scenes/configs/cube_messy.json");
    let text = std::fs::read_to_string(&src).unwrap();
    let mut file: ConfigFile = serde_json::from_str(&text).unwrap();
    let demo_path = repo("scenes/demos/cube.demo.json");
    let demo = dexwarp::model::Demo::load(&demo_path, &Limits::default()).unwrap();
    let seg = demo.contact_segment().unwrap();
    let shift = nalgebra::Vector3::new(0.25, 0.0, 0.0);
    let p0 = demo.frames[seg.start].object.translation.vector + shift;
    let p1 = demo.frames[seg.end].object.translation.vector + shift;
    file.name = "translated".into();
    file.demo = demo_path.clone();
    file.scene = repo("scenes/kitchen.json");
    file.waypoints.clear();
    file.barriers.clear();
    file.start = Some([p0.x, p0.y, p0.z]);
    file.end = Some([p1.x, p1.y, p1.z]);
    file.params.retime = dexwarp::model::RetimeMode::Speed;
    file.params.threshold_mm = 10.0;
    let path = dir.path().join("translated.json");
    std::fs::write(&path, serde_json::to_string_pretty(&file).unwrap()).unwrap();
    let _ = WarpConfig::load(&path, &Limits::default()).expect("the translated config loads");
    let inputs = Inputs::load(&path, None, &Limits::default()).unwrap();
    let opts = |hand| Options::new(hand).physics(None);
    let ik = pipeline::warp(&inputs, &opts(HandMethod::Contact)).unwrap();
    let rigid = pipeline::warp(&inputs, &opts(HandMethod::Baseline)).unwrap();
    assert_eq!(ik.demo.frames.len(), demo.frames.len());
    let mut worst = 0.0f64;
    for (a, b) in ik.demo.frames.iter().zip(&rigid.demo.frames) {
        worst = worst.max((a.wrist.translation.vector - b.wrist.translation.vector).norm());
        let moved = a.wrist.translation.vector - b.wrist.translation.vector;
        assert!(
            moved.norm() < 1e-3,
            "wrist {:.3} mm off the rigid transfer",
            moved.norm() * 1e3
        );
    }
    eprintln!("largest wrist difference {:.4} mm", worst * 1e3);
}

/// Where the retiming makes `t*` jump (mug_pass_wall_short: its waypoints compress the
/// carry 4-6x), smoothing averages different grasps and presses fingers 7.8 mm into the
/// mug although every IK frame was within its tolerance. The guard brings the output back
/// within the original's depth plus 1 mm (the automatic tolerance) and leaves frames that
/// were not too deep as the smoothing made them.
#[test]
fn smoothing_does_not_press_the_hand_in_where_time_jumps() {
    use dexwarp::hand::{baseline, guard, ik, smooth};

    let config = repo("scenes/configs/mug_pass_wall_short.json");
    // The default held grasp does not press in here (one grasp for the segment, no jump to
    // average), and the guard keeps it within the tolerance too.
    let held = warp(
        &config,
        Objective::NonPenetrating,
        Solver::Lm,
        HandMethod::Contact,
    );
    let pen = held.report.constraints.hand_object_penetration_mm.unwrap();
    assert!(pen.warped <= pen.original + 1.0 + 1e-6, "held: {pen:?}");
    // Each frame with its own IK solution, the smoothing averages different grasps.
    let mut inputs = Inputs::load(&config, None, &Limits::default()).unwrap();
    inputs.config.params.grasp = dexwarp::model::GraspMode::PerFrame;
    let run = pipeline::warp(
        &inputs,
        &Options::new(HandMethod::Contact)
            .threshold_mm(Some(3.5))
            .objective(Some(Objective::NonPenetrating))
            .solver(Solver::Lm)
            .physics(None),
    )
    .unwrap();
    let ik_summary = run.report.ik.as_ref().unwrap();
    let g = ik_summary.smoothing_guard.clone().unwrap();
    // The automatic tolerance: the original's own deepest penetration plus 1 mm.
    let tol = ik_summary.penetration_tolerance_mm.unwrap();
    let pen = run.report.constraints.hand_object_penetration_mm.unwrap();
    eprintln!("mug_pass_wall_short: guard {g:?}, penetration {pen:?}");
    assert!(
        g.frames_too_deep > 0 && g.max_depth_before_mm > 5.0,
        "{g:?}"
    );
    assert!(
        (tol - (pen.original + 1.0)).abs() < 1e-9,
        "{tol} vs {pen:?}"
    );
    assert!(g.max_depth_after_mm <= tol + 1e-6, "{g:?}");
    assert!(pen.warped <= pen.original + 1.0 + 1e-6, "{pen:?}");

    // The same stages by hand: the guard changes only frames within its spread of a frame
    // that was too deep, and every changed frame lies between the smoothed and the IK hand.
    let inputs = Inputs::load(&config, None, &Limits::default()).unwrap();
    let object = &run.object;
    let base = baseline::run(&inputs.demo, object).unwrap();
    let sdf = dexwarp::geometry::object_sdf(&inputs.mesh).unwrap();
    let params = ik::Params {
        threshold_mm: 3.5,
        ..ik::Params::default()
    };
    let (raw, _) = ik::run(
        &inputs.robot,
        &inputs.demo,
        object,
        &base,
        &[],
        Some(&sdf),
        &params,
    );
    let range = object.plan.segment.start..=object.plan.t_end_new();
    let (smoothed, _) = smooth::run(&raw, range.clone(), &smooth::Params::default()).unwrap();
    let mut guarded = smoothed.clone();
    // The pipeline's tolerance (the original's depth plus 1 mm), as the run above used.
    let gp = guard::Params {
        tolerance_m: tol * 1e-3,
        ..guard::Params::default()
    };
    let stats = guard::run(
        &inputs.robot,
        &sdf,
        |t| object.path().pose(t),
        &raw,
        &mut guarded,
        range.clone(),
        &gp,
    );
    assert!(stats.frames_too_deep > 0);
    assert!(stats.frames_blended >= stats.frames_too_deep);
    assert!(stats.max_depth_after_mm <= tol + 1e-6, "{stats:?}");
    let mut changed = 0;
    for t in range {
        let moved = (guarded.wrists[t].translation.vector - smoothed.wrists[t].translation.vector)
            .norm()
            + guarded
                .q(t)
                .iter()
                .zip(smoothed.q(t))
                .map(|(a, b)| (a - b).abs())
                .sum::<f64>();
        if moved > 0.0 {
            changed += 1;
            // Between the two: each joint within the interval of its smoothed and IK value.
            for ((g, s), r) in guarded.q(t).iter().zip(smoothed.q(t)).zip(raw.q(t)) {
                assert!(*g >= s.min(*r) - 1e-12 && *g <= s.max(*r) + 1e-12);
            }
        }
    }
    assert!(changed >= stats.frames_too_deep && changed <= stats.frames_blended);
}

/// LM ends a frame as a local minimum only after `stall_steps` small decreases in a row: on
/// mug_pass_in_sink at 10 mm, ending at the first one left a run of frames stopped after a
/// few iterations far above the threshold, which more iterations bring under it.
#[test]
fn one_small_decrease_does_not_end_a_frame() {
    use dexwarp::hand::ik;
    let solve = |stall_steps: usize| {
        let params = ik::Params {
            threshold_mm: 10.0,
            warm_start: dexwarp::model::WarmStart::FollowObject,
            stall_steps,
            ..ik::Params::default()
        };
        solve_ik("scenes/configs/mug_pass_in_sink.json", &params)
    };
    let (first, three) = (solve(1), solve(ik::Params::default().stall_steps));
    let iterations = |s: &ik::Stats| s.frames.iter().map(|f| f.iterations).sum::<usize>();
    let summary = format!(
        "stall_steps 1: {} frames not converged, {} iterations, D_C {:.2} mm; 3: {}, {}, {:.2} mm",
        first.not_converged.len(),
        iterations(&first),
        first.d_c_mm,
        three.not_converged.len(),
        iterations(&three),
        three.d_c_mm
    );
    // Measured: 54 frames not converged, 522 iterations, 6.78 mm against 8, 239, 5.44 mm.
    eprintln!("mug_pass_in_sink at 10 mm: {summary}");
    assert!(
        2 * three.not_converged.len() <= first.not_converged.len(),
        "{summary}"
    );
    assert!(iterations(&three) <= iterations(&first), "{summary}");
    assert!(three.d_c_mm <= first.d_c_mm, "{summary}");
}

/// Beside the low wall of teapot_pour_cups_wall the held hook grasp would come 5.3 mm into the
/// wall while the pot turns back from the pour. The per-frame solution (the IK's barrier
/// term) keeps 5 mm from it by sliding 11 mm up the handle, and a hand sliding on a carried
/// pot drags it along: taken in full, the pot slipped 30.3 mm off its path. The grasp now
/// yields only as far as the clearance asks: the hand stays out of the wall, the pot stays
/// in the hand, and asking for more clearance moves the hand farther.
#[test]
fn a_held_grasp_yields_to_a_wall_only_as_far_as_the_clearance_asks() {
    let config = repo("scenes/configs/teapot_pour_cups_wall.json");
    let run = |clearance_m: f64, physics: bool| {
        let mut inputs = Inputs::load(&config, None, &Limits::default()).unwrap();
        inputs.config.params.hand_clearance_m = clearance_m;
        let options = Options::new(HandMethod::Contact).threshold_mm(Some(3.5));
        let options = if physics {
            options
        } else {
            options.physics(None)
        };
        pipeline::warp(&inputs, &options).unwrap()
    };
    let slide = |r: &pipeline::WarpRun| r.report.metrics.grasp_slide_mm.as_ref().unwrap().warped;
    let asked = run(0.002, true);
    let physics = asked.report.physics.as_ref().unwrap();
    let in_wall = physics.measures["penetration"]["hand_barrier"]["max_mm"].as_f64();
    let max_error = physics.measures["tracking"]["max_position_error_mm"].as_f64();
    let wide = run(0.008, false);
    eprintln!(
        "grasp slide: 2 mm clearance {:.2} mm, 8 mm {:.2} mm; {} (max position error {max_error:?} mm); hand in the wall {in_wall:?} mm",
        slide(&asked),
        slide(&wide),
        physics.verdict,
    );
    // The pot stays in the hand as written (the nominal replay, member 0). Its ensemble is
    // at the edge of holding (9 of 31 members hold with the default draws): a test of the
    // yield must not decide on it.
    let ensemble = physics.ensemble().expect("the default ensemble");
    eprintln!(
        "ensemble: {} of {} hold",
        ensemble["passed"], ensemble["replayed"]
    );
    assert_eq!(
        ensemble["member"][0]["passed"].as_bool(),
        Some(true),
        "{:?}",
        ensemble["nominal_reasons"]
    );
    assert_eq!(in_wall, Some(0.0));
    assert!(slide(&asked) > 1.0, "the wall asks the grasp to yield");
    assert!(
        slide(&wide) > slide(&asked) + 1.0,
        "{} vs {}",
        slide(&wide),
        slide(&asked)
    );
    // The report says where and how far the grasp yielded.
    let held = |r: &pipeline::WarpRun| r.report.ik.as_ref().unwrap().held_yield.clone().unwrap();
    let (a, w) = (held(&asked), held(&wide));
    eprintln!("yield: 2 mm {a:?}; 8 mm {w:?}");
    assert!(
        a.frames > 0 && a.max_share > 0.0 && a.max_share < 1.0,
        "{a:?}"
    );
    assert!(
        w.max_share > a.max_share && w.max_move_mm > a.max_move_mm,
        "{a:?} vs {w:?}"
    );
    assert!(a.max_move_mm > 1.0, "{a:?}");
}

/// Where the held grasp keeps its clearance from every barrier, it does not yield: the
/// report says so (and nothing without barriers or with a per-frame grasp). It also says where
/// the grasp is held: the built-in mug's hand is formed before the lift, so held from the
/// first contact frame.
#[test]
fn a_held_grasp_clear_of_the_barriers_does_not_yield() {
    let run = |name: &str, grasp: dexwarp::model::GraspMode| {
        let config = repo(&format!("scenes/configs/{name}.json"));
        let mut inputs = Inputs::load(&config, None, &Limits::default()).unwrap();
        inputs.config.params.grasp = grasp;
        let options = Options::new(HandMethod::Contact)
            .threshold_mm(Some(3.5))
            .physics(None);
        let run = pipeline::warp(&inputs, &options).unwrap();
        let frames = run.demo.frames.len();
        (run.report.ik.unwrap(), frames)
    };
    use dexwarp::model::GraspMode::{Held, PerFrame};
    let (mug, frames) = run("mug_pass_wall", Held);
    let clear = mug.held_yield.expect("a held grasp with a barrier");
    assert_eq!(
        (clear.frames, clear.max_share, clear.max_move_mm),
        (0, 0.0, 0.0)
    );
    let held = mug.held.expect("where the grasp is held");
    let [s, e] = held.carry;
    assert!(
        0 < s && s + 100 < e && e + 1 < frames,
        "{held:?} of {frames} frames"
    );
    assert!(!held.closing, "{held:?}");
    assert_eq!(
        run("fryingpan_island", Held).0.held_yield,
        None,
        "no barrier"
    );
    let (per_frame, _) = run("mug_pass_wall", PerFrame);
    assert_eq!(per_frame.held_yield, None, "no held grasp");
    assert_eq!(per_frame.held, None, "no held grasp");
}
