//! The data model and its JSON formats: demonstrations, warp configs, scenes, reports.
//!
//! Each format has a stored form (`*File`, exactly the JSON, serde) and a validated form
//! with nalgebra types and resolved paths. Loading validates and rejects bad input with the
//! file, the JSON path of the field and what was expected.

pub mod bind;
pub mod config;
pub mod demo;
pub mod json;
pub mod provenance;
pub mod report;
pub mod scene;

pub use config::{WarpConfig, WarpParams, Waypoint};
pub use demo::{Contact, ContactSegment, Demo, Frame};
pub use scene::{Role, Scene, SceneItem};
