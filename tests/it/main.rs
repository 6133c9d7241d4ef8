//! All integration tests in one binary (one link step on a 2-core machine).
mod kinematics;
mod warp;
mod cli;
mod ik;
mod support;
mod fixtures;
mod physics;
mod model;
mod synth;
mod html;
