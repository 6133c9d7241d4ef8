//! Synthetic assets and demonstrations: object meshes, grasps by contact IK, scripted
//! motions, geometric contact extraction, and the base demonstrations of `scenes/demos/`.
//!
//! - [`objects`]: the object meshes and masses;
//! - [`motion`]: the scripted in-contact motions (`lift_place`, `pour`, `pass`);
//! - [`proximity`]: object signed distance, hand-object penetration;
//! - [`grasp`], [`templates`]: grasp synthesis by contact IK toward chosen pad targets;
//! - [`generic`]: the grasp targets of any URDF hand, from its tree and joint limits;
//! - [`contacts`]: correspondence extraction and motion-capture noise;
//! - [`demo`]: [`demo::synthesize`], the three segments of a demonstration;
//! - [`defaults`]: the six base demonstrations and [`defaults::run`] (`dexwarp synth`).

pub mod contacts;
pub mod defaults;
pub mod demo;
pub mod generic;
pub mod grasp;
pub mod motion;
pub mod objects;
pub mod proximity;
pub mod templates;
