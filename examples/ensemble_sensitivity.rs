//! Which of the ensemble's perturbations a trajectory is sensitive to: its pass fraction
//! with every perturbation on (the default ensemble), with all of them at a thousandth of
//! their size (a micrometre: what is left is the replay's own chaos at the edge of holding),
//! then with each one alone at its default magnitude, over the same members.
//!
//!     cargo run --release --example ensemble_sensitivity -- DEMO [K]
//!
//! DEMO is a `dexwarp.demo/1` file naming its scene (a built-in demonstration, or an output
//! of `warp`); K defaults to 16. Prints a Markdown table.

use std::path::PathBuf;

use dexwarp::physics::{EnsembleParams, Params};
use dexwarp::{Limits, pipeline};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let demo = PathBuf::from(args.next().ok_or("usage: ensemble_sensitivity DEMO [K]")?);
    let k: usize = args.next().map_or(Ok(16), |s| s.parse())?;
    let limits = Limits::default();
    let all = EnsembleParams {
        members: k,
        early_stop: false,
        ..EnsembleParams::default()
    };
    let none = EnsembleParams {
        hand_offset_mm: 0.0,
        hand_rotation_deg: 0.0,
        wrist_jitter_mm: 0.0,
        joint_jitter_rad: 0.0,
        object_start_mm: 0.0,
        object_start_yaw_deg: 0.0,
        friction_spread: 0.0,
        mass_spread: 0.0,
        skin_spread_mm: 0.0,
        ..all.clone()
    };
    let d = EnsembleParams::default();
    let rows: Vec<(&str, EnsembleParams)> = vec![
        ("all (default)", all.clone()),
        ("none (the nominal replay K times)", none.clone()),
        (
            "all at 1/1000 (chaos alone)",
            EnsembleParams {
                hand_offset_mm: d.hand_offset_mm * 1e-3,
                hand_rotation_deg: d.hand_rotation_deg * 1e-3,
                wrist_jitter_mm: d.wrist_jitter_mm * 1e-3,
                object_start_mm: d.object_start_mm * 1e-3,
                object_start_yaw_deg: d.object_start_yaw_deg * 1e-3,
                friction_spread: d.friction_spread * 1e-3,
                mass_spread: d.mass_spread * 1e-3,
                skin_spread_mm: d.skin_spread_mm * 1e-3,
                ..none.clone()
            },
        ),
        (
            "hand offset",
            EnsembleParams {
                hand_offset_mm: d.hand_offset_mm,
                ..none.clone()
            },
        ),
        (
            "hand rotation",
            EnsembleParams {
                hand_rotation_deg: d.hand_rotation_deg,
                ..none.clone()
            },
        ),
        (
            "wrist jitter",
            EnsembleParams {
                wrist_jitter_mm: d.wrist_jitter_mm,
                ..none.clone()
            },
        ),
        (
            "joint jitter 0.002 rad (off by default)",
            EnsembleParams {
                joint_jitter_rad: 0.002,
                ..none.clone()
            },
        ),
        (
            "object start",
            EnsembleParams {
                object_start_mm: d.object_start_mm,
                object_start_yaw_deg: d.object_start_yaw_deg,
                ..none.clone()
            },
        ),
        (
            "friction",
            EnsembleParams {
                friction_spread: d.friction_spread,
                ..none.clone()
            },
        ),
        (
            "mass",
            EnsembleParams {
                mass_spread: d.mass_spread,
                ..none.clone()
            },
        ),
        (
            "skin",
            EnsembleParams {
                skin_spread_mm: d.skin_spread_mm,
                ..none.clone()
            },
        ),
    ];
    println!("| perturbation | passed | pass fraction | 95 % interval | first failure |");
    println!("|---|---:|---:|---|---|");
    for (name, ensemble) in rows {
        let params = Params {
            ensemble,
            ..Params::default()
        };
        let (report, _) = pipeline::validate(&demo, None, None, &params, &limits)?;
        let p = report.physics.ok_or("no physics")?;
        let e = p.ensemble().ok_or("no ensemble")?;
        let first = e["member"]
            .as_array()
            .and_then(|m| m.iter().find(|m| m["passed"] == false))
            .and_then(|m| m["reason"].as_str())
            .unwrap_or("")
            .chars()
            .take(70)
            .collect::<String>();
        let [lo, hi] = p.pass_interval().unwrap_or([0.0, 1.0]);
        println!(
            "| {name} | {} of {} | {:.2} | {lo:.2}-{hi:.2} | {first} |",
            e["passed"],
            e["replayed"],
            e["pass_fraction"].as_f64().unwrap_or(f64::NAN)
        );
    }
    Ok(())
}
