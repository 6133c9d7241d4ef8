//! dexwarp: warp one contact-rich dexterous manipulation demonstration into many.
//!
//! The pipeline (see [`pipeline`] once it lands, and `docs/METHOD.md`):
//! 1. spatial warp of the object through waypoints,
//! 2. barrier push-out of the object,
//! 3. temporal retiming (global C² B-spline and the timewarp τ),
//! 4. hand recovery by per-frame contact IK,
//! 5. smoothing of the hand,
//! 6. physics replay in Rapier,
//! 7. metrics,
//! 8. report.
//!
//! Folders follow the architecture: [`math`] holds pure numerical kernels, [`model`] the
//! data model and its JSON formats, [`robot`] URDF hands and their kinematics, [`geometry`]
//! meshes and shape queries.

pub mod augment;
pub mod batch;
pub mod error;
pub mod export;
pub mod filter;
pub mod geometry;
pub mod hand;
pub mod import;
pub mod limits;
pub mod math;
pub mod metrics;
pub mod model;
pub mod output;
pub mod overview;
pub mod physics;
pub mod pipeline;
pub mod player;
pub mod reproduce;
pub mod robot;
pub mod synth;
pub mod warp;

pub use error::{Error, Result};
pub use limits::Limits;
