//! `dexwarp import`.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use dexwarp::Limits;

/// Make a dexwarp.demo/1 file from a recording: a CSV of frames (optionally a CSV of
/// contacts), or one episode of a LeRobot v3 dataset; correspondences are extracted
/// geometrically when not given.
#[derive(Debug, Args)]
#[command(
    after_help = "CSV columns: object.x,object.y,object.z,object.qw,object.qx,object.qy,object.qz, wrist.x..wrist.qz, one column per actuated joint of the URDF (see the README).\n\nExamples:\n  dexwarp import --csv rec.csv --fps 30 --robot robots/human_hand.urdf --mesh scenes/objects/mug.obj --mass 0.3 --out out/rec.demo.json\n  dexwarp import --csv rec.csv --contacts rec.contacts.csv --fps 30 --robot robots/human_hand.urdf --mesh mug.obj --mass 0.3 --out out/rec.demo.json\n  dexwarp import --lerobot out/dataset --episode 3 --robot robots/human_hand.urdf --mesh scenes/objects/mug.obj --mass 0.3 --out out/ep3.demo.json"
)]
pub struct ImportArgs {
    /// Frames CSV.
    #[arg(
        long,
        value_name = "FILE",
        conflicts_with = "lerobot",
        required_unless_present = "lerobot"
    )]
    csv: Option<PathBuf>,
    /// Contacts CSV for --csv (frame, link, hand_x..z, object_x..z).
    #[arg(long, value_name = "FILE", requires = "csv")]
    contacts: Option<PathBuf>,
    /// Frame rate of the CSV [Hz].
    #[arg(long, value_name = "HZ", requires = "csv")]
    fps: Option<f64>,
    /// A LeRobot v3 dataset folder.
    #[arg(long, value_name = "DIR")]
    lerobot: Option<PathBuf>,
    /// Episode of the LeRobot dataset.
    #[arg(long, value_name = "N", default_value_t = 0)]
    episode: usize,
    /// LeRobot feature holding the wrist pose (7) then the joints.
    #[arg(long, value_name = "KEY", default_value = "observation.state")]
    state_key: String,
    /// LeRobot feature holding the object pose (7).
    #[arg(
        long,
        value_name = "KEY",
        default_value = "observation.environment_state"
    )]
    object_key: String,
    /// URDF of the hand.
    #[arg(long, value_name = "URDF")]
    robot: PathBuf,
    /// Object mesh (OBJ or STL).
    #[arg(long, value_name = "FILE")]
    mesh: PathBuf,
    /// Object mass [kg].
    #[arg(long, value_name = "KG")]
    mass: f64,
    /// Name of the demonstration (default: the output file's stem).
    #[arg(long, value_name = "NAME")]
    name: Option<String>,
    /// Output demonstration file.
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
}

pub fn run(args: ImportArgs, limits: Limits) -> Result<()> {
    let ImportArgs {
        csv,
        contacts,
        fps,
        lerobot,
        episode,
        state_key,
        object_key,
        robot,
        mesh,
        mass,
        name,
        out,
    } = args;
    let target = dexwarp::import::Target {
        name,
        robot,
        mesh,
        mass,
        object_name: None,
        out: out.clone(),
    };
    let demo = match (csv, lerobot) {
        (Some(csv), _) => {
            let Some(fps) = fps else {
                anyhow::bail!("--fps is required with --csv: the frame rate of the recording [Hz]");
            };
            dexwarp::import::import_csv(&csv, contacts.as_deref(), fps, &target, &limits)?
        }
        (None, Some(root)) => dexwarp::import::import_lerobot(
            &root,
            episode,
            &dexwarp::import::LerobotMapping {
                state_key,
                object_key,
            },
            &target,
            &limits,
        )?,
        (None, None) => anyhow::bail!("give --csv FILE or --lerobot DIR"),
    };
    let with = demo
        .frames
        .iter()
        .filter(|f| !f.contacts.is_empty())
        .count();
    eprintln!(
        "wrote {}: {} frames at {} Hz, {with} with correspondences",
        out.display(),
        demo.frames.len(),
        demo.fps
    );
    Ok(())
}
