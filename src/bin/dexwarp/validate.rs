//! `dexwarp validate`.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use dexwarp::Limits;
use dexwarp::pipeline;

use crate::args::{OutDir, PhysicsArgs, verdict_line};

/// Replay any demonstration, warped or original, in physics; write DIR/report.json and
/// DIR/frames.csv.
#[derive(Debug, Args)]
#[command(
    after_help = "The scene and barriers are the ones the demonstration names (warp and synth outputs name theirs). Exits 0 whatever the verdict (read it in report.json), or 3 on a failed verdict with --strict.\n\nExamples:\n  dexwarp validate scenes/demos/mug.demo.json --out out/mug_check\n  dexwarp validate out/mug/mug_pass_wall.demo.json --out out/mug_check\n  dexwarp validate my.demo.json --scene scenes/kitchen.json --barrier wall_back --out out/x"
)]
pub struct ValidateArgs {
    /// Demonstration (`dexwarp.demo/1`).
    demo: PathBuf,
    #[command(flatten)]
    out: OutDir,
    /// Scene to replay in instead of the demonstration's own.
    #[arg(long, value_name = "FILE")]
    scene: Option<PathBuf>,
    /// Barrier to check against (repeat for several); default: the demonstration's own.
    #[arg(long = "barrier", value_name = "NAME")]
    barriers: Vec<String>,
    #[command(flatten)]
    physics: PhysicsArgs,
    /// Exit non-zero (status 3) when the physics verdict is fail.
    #[arg(long)]
    strict: bool,
    /// Only test whether the recorded grasp holds: at sampled contact frames the hand is
    /// frozen, the object released without support under gravity; writes DIR/grasp.json.
    #[arg(long)]
    grasp_only: bool,
}

pub fn run(args: ValidateArgs, limits: Limits) -> Result<()> {
    let ValidateArgs {
        demo,
        out,
        scene,
        barriers,
        physics,
        strict,
        grasp_only,
    } = args;
    let out = out.out;
    let params = physics.options().apply(dexwarp::physics::Params::default());
    if grasp_only {
        return grasp(&demo, &out, &params, strict, &limits);
    }
    let (report, frames) = pipeline::validate(
        &demo,
        scene.as_deref(),
        (!barriers.is_empty()).then_some(barriers.as_slice()),
        &params,
        &limits,
    )?;
    dexwarp::output::check_not_inputs(
        &out,
        &["frames.csv".into(), dexwarp::output::REPORT.into()],
        &[demo.as_path()],
    )?;
    let frames_path = out.join("frames.csv");
    let mut report = report;
    dexwarp::output::commit_set(
        &out,
        vec![(
            "frames.csv".into(),
            dexwarp::model::frames::csv_bytes(&frames_path, &frames)?,
        )],
        &mut report,
    )?;
    let physics = report.physics.as_ref();
    eprintln!(
        "{}: physics {}{}; D_C {:.2} mm; report in {}",
        demo.display(),
        physics.map_or("not run", |p| p.verdict.as_str()),
        physics
            .filter(|p| !p.reasons.is_empty())
            .map(|p| format!(" ({})", p.reasons.join("; ")))
            .unwrap_or_default(),
        report.metrics.d_c_mm.warped,
        out.join("report.json").display()
    );
    let onset = physics
        .and_then(|p| p.measures.get("onset"))
        .and_then(|o| serde_json::from_value::<dexwarp::physics::Onset>(o.clone()).ok());
    if let Some(o) = onset {
        eprintln!(
            "onset: the object is {:.1} mm and {:.1}° off its plan at the first contact frame {} (how far the approach and the closing moved it)",
            o.position_error_mm, o.rotation_error_deg, o.frame
        );
    }
    let replay = physics
        .and_then(|p| p.measures.get("replay"))
        .and_then(|r| serde_json::from_value::<dexwarp::physics::ReplayInfo>(r.clone()).ok());
    if let Some(replay) = replay {
        if let Some(r) = &replay.mesh_repair {
            eprintln!("{}: its object mesh was repaired: {r}", demo.display());
        }
        if let Some(w) = dexwarp::geometry::hull::fuller_than_mesh(replay.object_volume_ratio) {
            eprintln!("{}: warning: {w}", demo.display());
        }
        if let Some([hull, mesh]) = replay.hull_fallback_volumes_cm3 {
            eprintln!(
                "{}: its object mesh is open, simulated as its convex hull: {hull:.1} cm³ against the mesh's {mesh:.1} cm³",
                demo.display()
            );
        }
    }
    eprintln!("{}", verdict_line(&report));
    if strict && physics.is_some_and(|p| p.verdict != "pass") {
        std::process::exit(3);
    }
    Ok(())
}

/// `validate --grasp-only`: the hold test of the recorded grasp ([`dexwarp::physics::hold`]).
fn grasp(
    demo_path: &std::path::Path,
    out: &std::path::Path,
    params: &dexwarp::physics::Params,
    strict: bool,
    limits: &Limits,
) -> Result<()> {
    let Some(hold) = pipeline::grasp_hold(demo_path, params, limits)? else {
        anyhow::bail!(
            "{}: no frame has contacts, so there is no grasp to test",
            demo_path.display()
        );
    };
    let (s, c) = (&hold.stability, &hold.carry.tracking);
    let measured = format!(
        "frozen at {} sampled contact frames, the object moves {:.1} mm at most (limit {:.1} mm); carried over frames {}-{}, its error is {:.1} mm and {:.1}° on average (limits {:.1} mm, {:.1}°)",
        s.frames.len(),
        s.max_mm,
        params.max_sim_displacement_m * 1e3,
        hold.carry.first_frame,
        hold.carry.last_frame,
        c.mean_position_error_mm,
        c.mean_rotation_error_deg,
        params.max_mean_position_error_m * 1e3,
        params.max_mean_rotation_error_deg,
    );
    let holds = hold.holds();
    let sentence = if holds {
        format!("{}: the grasp holds ({measured})", demo_path.display())
    } else {
        format!(
            "{}: the grasp does not hold: {} ({measured})",
            demo_path.display(),
            hold.reasons.join("; ")
        )
    };
    dexwarp::output::check_not_inputs(out, &["grasp.json".into()], &[demo_path])?;
    dexwarp::model::json::write_json_atomic(
        &out.join("grasp.json"),
        &serde_json::json!({
            "format": "dexwarp.grasp/2",
            "demo": demo_path.display().to_string(),
            "holds": holds,
            "reasons": hold.reasons,
            "sentence": sentence,
            "stability": hold.stability,
            "carry": hold.carry,
        }),
    )?;
    eprintln!("{sentence}");
    if strict && !holds {
        std::process::exit(3);
    }
    Ok(())
}
