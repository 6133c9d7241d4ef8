//! The data model and its file formats: demonstrations, warp configs, scenes, reports, the
//! per-frame rows of `frames.csv`, and the stage variants a config chooses among. Plain
//! data: it imports no stage.
//!
//! Each format has a stored form (`*File`, exactly the JSON, serde) and a validated form
//! with nalgebra types and resolved paths. Loading validates and rejects bad input with the
//! file, the JSON path of the field and what was expected.

pub mod config;
pub mod demo;
pub mod frames;
pub mod json;
pub mod modes;
pub mod provenance;
pub mod report;
pub mod scene;

pub use config::{WarpConfig, WarpParams, Waypoint};
pub use demo::{Contact, ContactSegment, Demo, Frame};
pub use modes::{GraspMode, Objective, PushoutMode, RetimeMode, WarmStart};
pub use scene::{Role, Scene, SceneItem};
