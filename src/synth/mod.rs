//! Synthetic assets and demonstrations: object meshes, and (later) scripted demonstrations.

pub mod objects;
