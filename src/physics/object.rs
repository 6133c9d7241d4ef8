//! The object's collision shape: a convex decomposition of its mesh, cached per process.
//!
//! Rapier simulates a dynamic body well only with convex parts (a triangle mesh has no
//! inside, so a thin wall can be crossed in one step). The mesh is split with V-HACD
//! (parry's `VHACD`, parameters in [`DecompositionParams`]) and each part becomes the exact
//! convex hull of the mesh triangles it covers. Shortcuts and fallbacks, in order:
//! 1. a mesh whose volume is within 1 % of its convex hull's is already convex: the hull is
//!    used as is (a box or a cube, no V-HACD slivers);
//! 2. otherwise V-HACD; when it panics, returns no part, or the mesh is not closed, the
//!    convex hull is used and [`ObjectShape::method`] says so.
//!
//! Decompositions are cached for the life of the process, keyed by a hash of the vertex
//! coordinates, the triangles and the parameters, so a batch that replays the same object
//! many times decomposes it once.

use std::collections::HashMap;
use std::hash::{Hash, Hasher};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

use rapier3d_f64::parry::math::{Pose, Vector};
use rapier3d_f64::parry::shape::SharedShape;
use rapier3d_f64::parry::transformation::vhacd::{VHACD, VHACDParameters};
use serde::{Deserialize, Serialize};

use super::params::DecompositionParams;
use crate::geometry::Mesh;
use crate::math::convert::to_point;

/// How the object's parts were obtained.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShapeMethod {
    /// The mesh is convex: one part, its hull.
    ConvexMesh,
    /// V-HACD parts.
    Decomposition,
    /// V-HACD failed or the mesh is open: one part, the convex hull (a concave object is
    /// then simulated fuller than it is).
    HullFallback,
}

/// Convex parts of an object mesh, in the object frame.
#[derive(Clone, Debug)]
pub struct ObjectShape {
    /// The convex parts (parry `ConvexPolyhedron`s), object frame.
    pub parts: Vec<SharedShape>,
    /// The same parts as one compound, for the Rapier collider.
    pub compound: SharedShape,
    /// How the parts were obtained.
    pub method: ShapeMethod,
    /// Wall time of the decomposition when it was first computed [s]; a cache hit returns
    /// the same value (see [`object_shape`]'s flag).
    pub build_s: f64,
}

type Cache = Mutex<HashMap<u64, Arc<ObjectShape>>>;

fn cache() -> &'static Cache {
    static CACHE: OnceLock<Cache> = OnceLock::new();
    CACHE.get_or_init(|| Mutex::new(HashMap::new()))
}

/// The object's convex parts, from the cache or computed now; the flag is `true` on a cache
/// hit. `None` when the mesh is degenerate (fewer than four non-coplanar vertices).
pub fn object_shape(mesh: &Mesh, params: &DecompositionParams) -> Option<(Arc<ObjectShape>, bool)> {
    let key = content_key(mesh, params);
    if let Some(s) = cache().lock().ok().and_then(|c| c.get(&key).cloned()) {
        return Some((s, true));
    }
    let shape = Arc::new(build(mesh, params)?);
    if let Ok(mut c) = cache().lock() {
        c.insert(key, shape.clone());
    }
    Some((shape, false))
}

fn content_key(mesh: &Mesh, params: &DecompositionParams) -> u64 {
    // SipHash with fixed keys: deterministic within and across runs.
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for v in &mesh.vertices {
        for c in v.iter() {
            c.to_bits().hash(&mut h);
        }
    }
    mesh.triangles.hash(&mut h);
    params.resolution.hash(&mut h);
    params.concavity.to_bits().hash(&mut h);
    params.max_parts.hash(&mut h);
    h.finish()
}

fn build(mesh: &Mesh, params: &DecompositionParams) -> Option<ObjectShape> {
    let start = Instant::now();
    let points: Vec<Vector> = mesh.vertices.iter().map(to_point).collect();
    // Degenerate check on the whole object.
    SharedShape::convex_hull(&points)?;
    // Each connected part on its own: a handle that overlaps a body without sharing its
    // vertices keeps its opening (decomposing the union at once fills it, because the voxel
    // grid is sized to the whole object).
    let mut parts = Vec::new();
    let mut methods = Vec::new();
    for part in mesh.connected_parts() {
        let (shapes, method) = build_part(&part, params)?;
        parts.extend(shapes);
        methods.push(method);
    }
    let method = if methods.contains(&ShapeMethod::HullFallback) {
        ShapeMethod::HullFallback
    } else if methods.iter().all(|m| *m == ShapeMethod::ConvexMesh) {
        ShapeMethod::ConvexMesh
    } else {
        ShapeMethod::Decomposition
    };
    let compound =
        SharedShape::compound(parts.iter().map(|p| (Pose::IDENTITY, p.clone())).collect());
    Some(ObjectShape {
        parts,
        compound,
        method,
        build_s: start.elapsed().as_secs_f64(),
    })
}

/// One connected part: its hull when it is convex (or not closed), else its V-HACD parts.
fn build_part(
    mesh: &Mesh,
    params: &DecompositionParams,
) -> Option<(Vec<SharedShape>, ShapeMethod)> {
    let points: Vec<Vector> = mesh.vertices.iter().map(to_point).collect();
    let hull = SharedShape::convex_hull(&points)?;
    let hull_volume = hull.mass_properties(1.0).mass();
    let mesh_volume = mesh.signed_volume().abs();
    let closed = mesh.is_closed_and_consistently_wound();
    Some(if closed && mesh_volume >= 0.99 * hull_volume {
        (vec![hull], ShapeMethod::ConvexMesh)
    } else if !closed {
        (vec![hull], ShapeMethod::HullFallback)
    } else {
        match decompose(&points, &mesh.triangles, params) {
            Some(parts) if !parts.is_empty() => (parts, ShapeMethod::Decomposition),
            _ => (vec![hull], ShapeMethod::HullFallback),
        }
    })
}

/// V-HACD parts as exact hulls of the triangles each voxel part covers; `None` if parry
/// panics (degenerate hulls inside V-HACD).
fn decompose(
    points: &[Vector],
    triangles: &[[u32; 3]],
    params: &DecompositionParams,
) -> Option<Vec<SharedShape>> {
    let vparams = VHACDParameters {
        resolution: params.resolution,
        concavity: params.concavity,
        max_convex_hulls: params.max_parts,
        ..VHACDParameters::default()
    };
    std::panic::catch_unwind(|| {
        let decomposition = VHACD::decompose(&vparams, points, triangles, true);
        decomposition
            .compute_exact_convex_hulls(points, triangles)
            .into_iter()
            .filter_map(|(v, i)| SharedShape::convex_mesh(v, &i))
            .collect()
    })
    .ok()
}
