//! Meshes (OBJ, STL), their convex decompositions (the object's collision shape, hand link
//! hulls) with their disk cache, collision shapes (a hand link's or a scene item's geometry
//! as a parry shape, with deterministic surface points), the object's signed distance field,
//! bounding-sphere trees, and shape queries on parry shapes.

pub mod hull;
pub mod mesh;
pub mod repair;
pub mod sdf;
pub mod shape;
pub mod sphere_tree;

pub use mesh::Mesh;
pub use repair::{Defects, Repair};
pub use sdf::{ObjectSdf, SdfParams, object_sdf};
pub use sphere_tree::SphereTree;
