//! All integration tests in one binary (one link step on a 2-core machine).
mod augment;
mod cli;
mod export;
mod fixtures;
mod harden;
mod html;
mod ik;
mod kinematics;
mod model;
mod nonpen;
mod one_verdict;
mod physics;
mod physics_regression;
mod sdf;
mod support;
mod synth;
mod warp;
