//! Where the physics replay's time goes, per built-in config: steps simulated, steps with a
//! hand on the object, idle steps (no hand contact, the object at rest), contact manifolds and
//! points per step, and the replay's time per phase. Contact IK at 3.5 mm, default physics.
//!
//!     cargo run --release --example physics_profile [CONFIG...]
//!
//! Prints a Markdown table (the one in the physics module's docs).

use std::path::PathBuf;

use dexwarp::pipeline::{self, HandMethod, Inputs, Options};
use dexwarp::{Limits, physics};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/configs");
    let mut configs: Vec<PathBuf> = std::env::args().skip(1).map(PathBuf::from).collect();
    if configs.is_empty() {
        configs = std::fs::read_dir(&root)?
            .map(|e| e.map(|e| e.path()))
            .collect::<Result<_, _>>()?;
        configs.sort();
    }
    let limits = Limits::default();
    let params = physics::Params {
        ensemble: physics::EnsembleParams::single(),
        ..physics::Params::default()
    };
    println!(
        "| config | frames | steps | skipped | hand contact | idle | hand manifolds / step | hand points / step | other manifolds / step | decomposition s | replay s | penetration s | stability s | total s | hand contact s | idle s | other s | verdict |"
    );
    println!(
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"
    );
    let mut totals = [0.0f64; 5];
    for config in &configs {
        let inputs = Inputs::load(config, None, &limits)?;
        let options = Options::new(HandMethod::Contact)
            .threshold_mm(Some(3.5))
            .physics(None)
            .limits(limits);
        let run = pipeline::warp(&inputs, &options)?;
        let out = run.demo.as_stored(&limits)?;
        let p = physics::validate(
            &inputs.robot,
            &out,
            &inputs.scene,
            &inputs.config.barriers,
            &inputs.mesh,
            &params,
            &limits,
        )?;
        let f = p.profile;
        let steps = f.steps.max(1) as f64;
        let pct = |n: usize| 100.0 * n as f64 / steps;
        let t = &p.timing_s;
        for (sum, v) in totals.iter_mut().zip([
            t.decomposition,
            t.replay,
            t.penetration,
            t.stability,
            t.total,
        ]) {
            *sum += v;
        }
        println!(
            "| {} | {} | {} | {} | {:.0} % | {:.0} % | {:.2} | {:.1} | {:.2} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {} |",
            inputs.config.name,
            out.frames.len(),
            f.steps,
            p.replay.skipped_steps,
            pct(f.hand_contact_steps),
            pct(f.idle_steps),
            f.hand_manifolds as f64 / steps,
            f.hand_points as f64 / steps,
            f.other_manifolds as f64 / steps,
            t.decomposition,
            t.replay,
            t.penetration,
            t.stability,
            t.total,
            f.times.hand_contact_s,
            f.times.idle_s,
            f.times.other_s,
            if p.passed() { "pass" } else { "fail" },
        );
    }
    let n = configs.len().max(1) as f64;
    println!(
        "| mean of {} | | | | | | | | | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | |",
        configs.len(),
        totals[0] / n,
        totals[1] / n,
        totals[2] / n,
        totals[3] / n,
        totals[4] / n
    );
    Ok(())
}
