//! dexwarp: warp one contact-rich dexterous manipulation demonstration into many.
//!
//! The pipeline ([`pipeline::warp`], and `docs/METHOD.md`):
//! 1. spatial warp of the object through waypoints,
//! 2. barrier push-out of the object,
//! 3. temporal retiming (global C² B-spline and the timewarp τ),
//! 4. hand recovery by per-frame contact IK,
//! 5. smoothing of the hand,
//! 6. physics replay in Rapier,
//! 7. metrics,
//! 8. report.
//!
//! # Layers
//!
//! The modules read bottom-up: each imports only modules on the lines above its own (its
//! unit tests may use any module for their fixtures). The integration test `structure` checks
//! this list against the sources, so it is the order the code has.
//!
//! 1. [`error`]: the error type, naming the file, the field and what was expected.
//! 2. [`limits`]: bounds on every input, so no input asks for unbounded work.
//! 3. [`math`]: numerical kernels (B-splines, rotations, Savitzky-Golay, quantiles).
//! 4. [`geometry`]: meshes, convex decompositions and their disk cache, collision shapes,
//!    the object's distance field, sphere trees.
//! 5. [`model`]: plain data and its file formats: demonstration, scene, config, the stage
//!    variants a config chooses, report, frame rows. It imports no stage.
//! 6. [`robot`]: URDF hands, kinematics, penetration probes, a demonstration bound to its hand.
//! 7. [`warp`]: the object stages: spatial warp, barrier push-out, retiming.
//! 8. [`metrics`]: D_WO, D_C, path length ratio, timewarp discrepancy.
//! 9. [`hand`]: the hand stages: contact IK, the SE(3) baseline, push-out, smoothing, guard.
//! 10. [`physics`]: the Rapier replay and its checks.
//! 11. [`pipeline`]: the stage list of one warp, every stage's parameters from a config and
//!     the run's options, its report, and `validate`.
//! 12. [`output`]: a run's files written as one set.
//! 13. [`synth`]: demonstrations synthesized for a hand and an object.
//! 14. [`player`]: the 3D player page of a trajectory.
//! 15. [`filter`]: selecting reports by their figures.
//! 16. [`export`]: LeRobot and robomimic datasets.
//! 17. [`import`]: a recording (CSV, LeRobot) in as a demonstration.
//! 18. [`batch`]: many warps from a manifest.
//! 19. [`augment`]: sampled variations of one demonstration.
//! 20. [`overview`]: the HTML overview of a run folder and the comparison of two.
//! 21. [`reproduce`]: the paper's experiments, tables and figures.
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
