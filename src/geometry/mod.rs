//! Meshes (OBJ, STL) and shape queries on parry shapes.

pub mod mesh;

pub use mesh::Mesh;
