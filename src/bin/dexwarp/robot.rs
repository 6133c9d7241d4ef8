//! `dexwarp robot`.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use dexwarp::Limits;
use dexwarp::robot::Robot;

/// Load a hand and print its links, DoF, joint limits, mimic joints and collision shapes.
#[derive(Debug, Args)]
#[command(
    after_help = "Examples:\n  dexwarp robot robots/human_hand.urdf\n  dexwarp robot robots/parallel_gripper.urdf"
)]
pub struct RobotArgs {
    /// URDF file.
    urdf: PathBuf,
    /// The link whose pose is the wrist (default: the URDF root); links above it are dropped.
    #[arg(long, value_name = "LINK")]
    wrist_link: Option<String>,
}

pub fn run(args: RobotArgs, limits: Limits) -> Result<()> {
    let RobotArgs { urdf, wrist_link } = args;
    let robot = Robot::from_urdf_file_at(&urdf, &limits, wrist_link.as_deref())?;
    print!("{}", robot.describe());
    Ok(())
}
