//! The `dexwarp` command line: the commands and their dispatch, a thin layer over the
//! library. Each command's flags and its run live in a module of its own; the flags several
//! commands share are defined once in [`args`].

mod args;
mod augment;
mod batch;
mod export;
mod filter;
mod import;
mod report;
mod reproduce;
mod robot;
mod synth;
mod validate;
mod warp;

use std::process::ExitCode;

use anyhow::Result;
use clap::{Parser, Subcommand};

/// Warp one dexterous-manipulation demonstration into many.
///
/// dexwarp moves the object of a demonstration through new waypoints, around barriers, on a
/// new timing and from a new start to a new end, recovers the hand by contact IK, replays every
/// output in physics, and writes a quality report per trajectory.
#[derive(Debug, Parser)]
#[command(name = "dexwarp", version, propagate_version = true)]
struct Cli {
    #[command(flatten)]
    limits: args::LimitArgs,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    Reproduce(reproduce::ReproduceArgs),
    Synth(synth::SynthArgs),
    Robot(robot::RobotArgs),
    Warp(warp::WarpArgs),
    Validate(validate::ValidateArgs),
    Batch(batch::BatchArgs),
    Augment(augment::AugmentArgs),
    Filter(filter::FilterArgs),
    Report(report::ReportArgs),
    Export(export::ExportArgs),
    Import(import::ImportArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {}", error_text(&err));
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    let limits = cli.limits.limits();
    match cli.command {
        Command::Reproduce(a) => reproduce::run(a, limits),
        Command::Synth(a) => synth::run(a, limits),
        Command::Robot(a) => robot::run(a, limits),
        Command::Warp(a) => warp::run(a, limits),
        Command::Validate(a) => validate::run(a, limits),
        Command::Batch(a) => batch::run(a, limits),
        Command::Augment(a) => augment::run(a, limits),
        Command::Filter(a) => filter::run(a),
        Command::Report(a) => report::run(a, limits),
        Command::Export(a) => export::run(a, limits),
        Command::Import(a) => import::run(a, limits),
    }
}

/// The error and its causes, each cause only when the text so far does not already say it
/// (our file errors carry the OS error in their own message).
fn error_text(err: &anyhow::Error) -> String {
    let mut text = err.to_string();
    for cause in err.chain().skip(1) {
        let c = cause.to_string();
        if !text.contains(&c) {
            text.push_str(": ");
            text.push_str(&c);
        }
    }
    text
}
