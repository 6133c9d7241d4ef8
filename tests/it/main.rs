//! All integration tests in one binary (one link step on a 2-core machine).
mod augment;
mod cli;
mod fixtures;
mod html;
mod ik;
mod kinematics;
mod model;
mod physics;
mod support;
mod synth;
mod warp;
