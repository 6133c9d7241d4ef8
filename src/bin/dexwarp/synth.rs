//! `dexwarp synth`.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use dexwarp::Limits;

use crate::args::{TrackingErrorArg, non_negative};

/// Make a demonstration: the object resting on a support, the hand reaching and grasping
/// it (contact IK), a scripted motion, release and retreat, with geometric correspondences.
/// The grasp must hold the object in a physics hold test (hand frozen, object released
/// without support); a grasp that does not hold gives way to the next candidate.
#[derive(Debug, Args)]
#[command(
    after_help = "Objects: cube, frying_pan, mug, teapot, apple, small_box. Motions: lift_place, pour, pass.\n\nExamples:\n  dexwarp synth --object mug --robot robots/human_hand.urdf --motion pass --out out/mug.demo.json\n  dexwarp synth --object apple --robot robots/allegro_hand.urdf --motion lift_place --out out/apple.demo.json --noise-mm 2 --seed 3"
)]
pub struct SynthArgs {
    /// Object name.
    #[arg(long, value_name = "NAME")]
    object: String,
    /// URDF of the hand.
    #[arg(long, value_name = "URDF")]
    robot: PathBuf,
    /// Motion name.
    #[arg(long, value_name = "NAME")]
    motion: String,
    /// Output demonstration file (the object mesh is written beside it unless --mesh).
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
    /// Existing object mesh to reference instead of writing one.
    #[arg(long, value_name = "FILE")]
    mesh: Option<PathBuf>,
    /// Seed of the correspondence noise.
    #[arg(long, value_name = "N")]
    seed: Option<u64>,
    /// Correspondence noise, standard deviation per axis [mm].
    #[arg(long, value_name = "MM", value_parser = non_negative, allow_negative_numbers = true)]
    noise_mm: Option<f64>,
    /// What carries the recording's shared tracking offset: the correspondences (the
    /// recorded hand is the grasp that holds) or the recorded hand (the correspondences
    /// are on that grasp, as after cleaning).
    #[arg(long, value_enum, value_name = "WHAT")]
    tracking_error: Option<TrackingErrorArg>,
    /// Fingertip links, comma-separated (default: our hands' templates, else the leaf links).
    #[arg(long, value_name = "A,B,C", value_delimiter = ',')]
    tips: Option<Vec<String>>,
    /// The link whose pose is the wrist (default: the fingertips' common link, moved up
    /// through fixed joints); links above it are dropped.
    #[arg(long, value_name = "LINK")]
    wrist_link: Option<String>,
}

pub fn run(args: SynthArgs, limits: Limits) -> Result<()> {
    let SynthArgs {
        object,
        robot,
        motion,
        out,
        mesh,
        seed,
        noise_mm,
        tracking_error,
        tips,
        wrist_link,
    } = args;
    let syn = dexwarp::synth::defaults::run(
        &dexwarp::synth::defaults::SynthRequest {
            object,
            robot,
            motion,
            out: out.clone(),
            mesh,
            seed,
            noise_mm,
            tracking_error: tracking_error.map(Into::into),
            tips,
            wrist_link,
        },
        &limits,
    )?;
    eprintln!(
        "wrote {} ({} frames, {} correspondences per in-contact frame, D_C {:.2} mm)",
        out.display(),
        syn.demo.frames.len(),
        syn.stats.contacts_per_frame,
        syn.stats.d_c_mm
    );
    let choice = &syn.stats.choice;
    eprintln!(
        "grasp: {}, holds (the object moves {:.1} mm in the physics hold test), {}{}",
        choice.candidate,
        choice.hold_mm,
        match &choice.replay {
            None => "its demonstration passes the replay".to_string(),
            Some(why) => why.clone(),
        },
        if choice.tried.is_empty() {
            String::new()
        } else {
            format!("; tried first: {}", choice.tried.join("; "))
        }
    );
    if let Some(w) = &syn.demo.wrist_link {
        eprintln!("wrist link: {w} (the links above it are left out)");
    }
    Ok(())
}
