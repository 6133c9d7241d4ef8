//! Meshes (OBJ, STL), the object's signed distance field, and shape queries on parry shapes.

pub mod mesh;
pub mod sdf;

pub use mesh::Mesh;
pub use sdf::{ObjectSdf, SdfParams, object_sdf};
