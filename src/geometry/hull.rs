//! Convex decompositions: the object's collision shape (its mesh in convex parts) and the
//! convex parts of hand link meshes, cached per process and on disk.
//!
//! Rapier simulates a dynamic body well only with convex parts (a triangle mesh has no
//! inside, so a thin wall can be crossed in one step). The mesh is split with V-HACD
//! (parry's `VHACD`, parameters in [`DecompositionParams`]) and each part becomes the exact
//! convex hull of the mesh triangles it covers. Shortcuts and fallbacks, in order:
//! 1. a mesh whose volume is within 1 % of its convex hull's is already convex: the hull is
//!    used as is (a box or a cube, no V-HACD slivers);
//! 2. otherwise V-HACD; when it panics or returns no part, the convex hull is used and
//!    [`ObjectShape::method`] says so.
//!
//! A mesh that is not closed has no inside to decompose: it is first repaired
//! ([`Mesh::repair`]: slivers, repeated triangles, small holes; [`ObjectShape::repair`] says
//! what changed). One that stays open is refused ([`ShapeError::Open`], with its defects)
//! unless [`DecompositionParams::hull_fallback`] asks for its convex hull, which is then
//! simulated and reported with both volumes ([`ObjectShape::fallback_volumes_m3`]): a
//! concave object's hull can hold several times its volume, and a finger inside the
//! object's opening is then inside the simulated solid.
//!
//! Hand links with mesh collision geometry get convex parts by the same machinery
//! ([`link_hulls`]), with a looser rule for step 1: a connected part of a link mesh is
//! replaced by its convex hull when the part's volume is at least [`LINK_HULL_RATIO`] of its
//! hull's (the hull adds at most a quarter of the part's volume: a fingertip pad, a
//! phalanx shell) or when the part is not closed (it has no volume to compare); otherwise it
//! is split by V-HACD with [`DecompositionParams::default`], through the same disk cache.
//!
//! Decompositions are cached for the life of the process, keyed by a hash of the vertex
//! coordinates, the triangles and the parameters, so a batch that replays the same object
//! many times decomposes it once.
//!
//! The V-HACD output (the exact hull vertices and triangles of every part) is also cached on
//! disk, one file per connected part of the mesh, named by the hash of that part's vertex
//! bits, triangles and the parameters, so separate processes (`warp` runs, batch shards,
//! `reproduce`) decompose each object once ([`cache_dir`] says where). Rebuilding the parts
//! from the stored vertices gives the same shapes to the bit as the first run. Entries are
//! written atomically (temporary file, then rename); an entry that cannot be read, is
//! truncated or does not match its key is ignored and rebuilt. With the cache, the
//! teapot's 0.5 s decomposition becomes a file read of a few kilobytes.

use std::collections::HashMap;
use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

use rapier3d_f64::parry::mass_properties::MassProperties;
use rapier3d_f64::parry::math::{Pose, Vector};
use rapier3d_f64::parry::shape::SharedShape;
use rapier3d_f64::parry::transformation::vhacd::{VHACD, VHACDParameters};
use serde::{Deserialize, Serialize};

use super::Mesh;
use super::repair::{Defects, MAX_HOLE_EDGES, Repair};
use crate::math::convert::to_point;

/// How the object mesh is split into convex parts (V-HACD, parry's `VHACDParameters`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DecompositionParams {
    /// Voxel grid resolution along the longest axis; default 32. parry's 64 takes 0.5-2 s on
    /// the mug and teapot; 32 keeps handles and spouts as separate parts in well under a
    /// second.
    pub resolution: u32,
    /// Largest concavity a part may keep, relative to the mesh size; default 0.02 (parry's
    /// 0.01 splits a plain box into many slivers without a better fit).
    pub concavity: f64,
    /// Most convex parts; default 24 (the contact work per step grows with it).
    pub max_parts: u32,
    /// Simulate a mesh that stays open after [`Mesh::repair`] as its convex hull instead of
    /// refusing it; default `false`.
    pub hull_fallback: bool,
    /// What the physics simulates: the convex parts (default) or the closed mesh itself.
    pub collider: ObjectCollider,
}

/// The object's collision shape in the physics replay.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ObjectCollider {
    /// Convex parts (V-HACD): robust contacts, but thin walls and hollows come out filled
    /// ([`ObjectShape::volume_ratio`]).
    #[default]
    Parts,
    /// The closed mesh as a Rapier triangle mesh: exactly the mesh the IK keeps the hand out
    /// of, so a thin-walled shell (an open box, a pan, a bowl) is simulated as the shell it
    /// is. Its mass properties are the closed mesh's. A triangle mesh has no inside: a finger
    /// driven more than half a wall's thickness into it can pass through.
    Mesh,
}

impl Default for DecompositionParams {
    fn default() -> Self {
        DecompositionParams {
            resolution: 32,
            concavity: 0.02,
            max_parts: 24,
            hull_fallback: false,
            collider: ObjectCollider::Parts,
        }
    }
}

/// How the object's parts were obtained.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShapeMethod {
    /// The mesh is convex: one part, its hull.
    ConvexMesh,
    /// V-HACD parts.
    Decomposition,
    /// The closed mesh itself ([`ObjectCollider::Mesh`]).
    Mesh,
    /// V-HACD failed, or the mesh is open and [`DecompositionParams::hull_fallback`] asked
    /// for it: one part, the convex hull (a concave object is then simulated fuller than it
    /// is).
    HullFallback,
}

/// Why an object mesh has no collision shape.
#[derive(Clone, Debug, PartialEq)]
pub enum ShapeError {
    /// Fewer than four non-coplanar vertices.
    Degenerate,
    /// Not closed after [`Mesh::repair`], and the hull fallback was not asked for.
    Open {
        defects: Defects,
        /// The volume of the mesh's convex hull and the mesh's own signed volume [m³].
        hull_volume_m3: f64,
        mesh_volume_m3: f64,
    },
}

impl std::fmt::Display for ShapeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ShapeError::Degenerate => write!(
                f,
                "the mesh is degenerate (fewer than four non-coplanar vertices); expected a solid object"
            ),
            ShapeError::Open {
                defects,
                hull_volume_m3,
                mesh_volume_m3,
            } => write!(
                f,
                "the mesh is not closed ({defects}) and too damaged to repair (slivers, repeated triangles and holes of at most {MAX_HOLE_EDGES} edges are); expected a closed object mesh. Close it in a mesh tool, or ask for its convex hull (hull_fallback: `import --hull-fallback`, `physics.decomposition.hull_fallback` in a config), {:.1} cm³ against the mesh's {:.1} cm³",
                hull_volume_m3 * 1e6,
                mesh_volume_m3.abs() * 1e6
            ),
        }
    }
}

/// Convex parts of an object mesh, in the object frame.
#[derive(Clone, Debug)]
pub struct ObjectShape {
    /// The convex parts (parry `ConvexPolyhedron`s), object frame.
    pub parts: Vec<SharedShape>,
    /// The same parts as one compound, for the Rapier collider.
    pub compound: SharedShape,
    /// The compound's mass properties at unit density, computed once: Rapier would sum the
    /// parts' tetrahedra again for every world a replay, a stability sample or a margin
    /// condition builds.
    pub unit_mass: MassProperties,
    /// How the parts were obtained.
    pub method: ShapeMethod,
    /// What [`Mesh::repair`] changed to close the mesh (`None` when it was closed).
    pub repair: Option<Repair>,
    /// With [`ShapeMethod::HullFallback`] of an open mesh: the hull's volume and the mesh's
    /// [m³].
    pub fallback_volumes_m3: Option<[f64; 2]>,
    /// The parts' volume over the closed mesh's (1 for a convex mesh; V-HACD fills thin
    /// walls and hollows, so a shell reads several times its volume: a hand resting on the
    /// mesh's surface there is inside the simulated object). `None` for an open mesh.
    pub volume_ratio: Option<f64>,
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
/// hit. An open mesh is repaired first; see the module docs for what is refused.
pub fn object_shape(
    mesh: &Mesh,
    params: &DecompositionParams,
) -> Result<(Arc<ObjectShape>, bool), ShapeError> {
    let key = content_key(mesh, params);
    if let Some(s) = cache().lock().ok().and_then(|c| c.get(&key).cloned()) {
        return Ok((s, true));
    }
    let (solid, repair) = solid_mesh(mesh);
    let closed = solid.is_closed_and_consistently_wound();
    let shape = if closed && params.collider == ObjectCollider::Mesh {
        mesh_collider(&solid, repair)?
    } else if closed {
        let mut shape = build(&solid, params).ok_or(ShapeError::Degenerate)?;
        shape.repair = repair;
        let volume = solid.signed_volume().abs();
        shape.volume_ratio = (volume > 0.0).then(|| shape.unit_mass.mass() / volume);
        shape
    } else {
        let (hull, volumes) = open_mesh_hull(mesh, params.hull_fallback)?;
        let start = Instant::now();
        let compound = SharedShape::compound(vec![(Pose::IDENTITY, hull.clone())]);
        ObjectShape {
            parts: vec![hull],
            unit_mass: compound.mass_properties(1.0),
            compound,
            method: ShapeMethod::HullFallback,
            repair,
            fallback_volumes_m3: Some(volumes),
            volume_ratio: None,
            build_s: start.elapsed().as_secs_f64(),
        }
    };
    let shape = Arc::new(shape);
    if let Ok(mut c) = cache().lock() {
        c.insert(key, shape.clone());
    }
    Ok((shape, false))
}

/// The convex hull of a `mesh` that stays open after its repair, with the hull's and the
/// mesh's volumes [m³], when `hull_fallback` asks for it; [`ShapeError::Open`] otherwise.
pub fn open_mesh_hull(
    mesh: &Mesh,
    hull_fallback: bool,
) -> Result<(SharedShape, [f64; 2]), ShapeError> {
    let hull = mesh.convex_hull().ok_or(ShapeError::Degenerate)?;
    let volumes = [hull.mass_properties(1.0).mass(), mesh.signed_volume().abs()];
    if !hull_fallback {
        return Err(ShapeError::Open {
            defects: mesh.defects(),
            hull_volume_m3: volumes[0],
            mesh_volume_m3: volumes[1],
        });
    }
    Ok((hull, volumes))
}

/// The closed, outward-wound `mesh` ([`solid_mesh`]) as one triangle-mesh part
/// ([`ObjectCollider::Mesh`]).
fn mesh_collider(mesh: &Mesh, repair: Option<Repair>) -> Result<ObjectShape, ShapeError> {
    let start = Instant::now();
    let shape = SharedShape::new(mesh.to_trimesh(true).ok_or(ShapeError::Degenerate)?);
    let unit_mass = shape.mass_properties(1.0);
    Ok(ObjectShape {
        parts: vec![shape.clone()],
        compound: shape,
        unit_mass,
        method: ShapeMethod::Mesh,
        repair,
        fallback_volumes_m3: None,
        volume_ratio: Some(1.0),
        build_s: start.elapsed().as_secs_f64(),
    })
}

/// Above this [`ObjectShape::volume_ratio`], commands warn that the simulated object is
/// fuller than its mesh.
pub const FULLER_THAN_MESH: f64 = 1.25;

/// The warning `import` and `validate` give when the simulated object is fuller than its
/// mesh (`ratio`: [`ObjectShape::volume_ratio`] above [`FULLER_THAN_MESH`]).
pub fn fuller_than_mesh(ratio: Option<f64>) -> Option<String> {
    ratio.filter(|r| *r > FULLER_THAN_MESH).map(|r| {
        format!(
            "the object's convex parts (what physics simulates) hold {r:.2}x its mesh's volume: thin walls or hollows are filled, so a hand on the mesh's surface there is inside the simulated object (--object-collider mesh simulates the mesh itself)"
        )
    })
}

/// `mesh` closed and wound outward by [`Mesh::repair`] when it is open or inside out (with
/// what the repair did), or `mesh` itself when it is closed and outward. A mesh the repair
/// cannot close comes back unchanged.
pub fn solid_mesh(mesh: &Mesh) -> (std::borrow::Cow<'_, Mesh>, Option<Repair>) {
    if mesh.is_closed_and_consistently_wound() && mesh.signed_volume() >= 0.0 {
        return (std::borrow::Cow::Borrowed(mesh), None);
    }
    let mut repaired = mesh.clone();
    let repair = repaired.repair();
    if repair.closed {
        (std::borrow::Cow::Owned(repaired), Some(repair))
    } else {
        (std::borrow::Cow::Borrowed(mesh), Some(repair))
    }
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
    params.hull_fallback.hash(&mut h);
    params.collider.hash(&mut h);
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
    let unit_mass = compound.mass_properties(1.0);
    Some(ObjectShape {
        parts,
        compound,
        unit_mass,
        method,
        repair: None,
        fallback_volumes_m3: None,
        volume_ratio: None,
        build_s: start.elapsed().as_secs_f64(),
    })
}

/// Smallest ratio of a link mesh part's volume to its convex hull's for the hull to stand
/// for the part (see the module docs).
pub const LINK_HULL_RATIO: f64 = 0.8;

/// Convex parts of a hand link's collision mesh, as exact hull vertices and triangles
/// (outward-wound): one hull per connected part whose volume is at least
/// [`LINK_HULL_RATIO`] of its hull's or that is not closed, V-HACD parts (disk-cached) for
/// the others. `None` when no part has a hull (every part degenerate, e.g. flat).
pub fn link_hulls(mesh: &Mesh) -> Option<Hulls> {
    let params = DecompositionParams::default();
    let mut out = Hulls::new();
    for part in mesh.connected_parts() {
        let points: Vec<Vector> = part.vertices.iter().map(to_point).collect();
        let hull = rapier3d_f64::parry::transformation::try_convex_hull(&points).ok();
        let Some(hull) = hull.filter(|(v, t)| v.len() >= 4 && !t.is_empty()) else {
            continue; // a flat or degenerate part has no volume to collide with
        };
        let closed = part.is_closed_and_consistently_wound();
        let hull_volume = SharedShape::convex_mesh(hull.0.clone(), &hull.1)
            .map_or(0.0, |s| s.mass_properties(1.0).mass());
        if !closed || part.signed_volume().abs() >= LINK_HULL_RATIO * hull_volume {
            out.push(hull);
            continue;
        }
        match cached_hulls(&points, &part.triangles, &params, cache_dir().as_deref()) {
            Some(parts) if !parts.is_empty() => out.extend(parts),
            _ => out.push(hull),
        }
    }
    let out: Hulls = out.into_iter().map(simplify_hull).collect();
    (!out.is_empty()).then_some(out)
}

/// Most vertices of a link hull: a support query on a convex polyhedron visits its vertices,
/// so a hull of a finely tessellated fingertip (6,000 vertices) would make every contact
/// test slow.
pub const LINK_HULL_MAX_VERTICES: usize = 96;

/// A hull with more than [`LINK_HULL_MAX_VERTICES`] vertices is rebuilt from one vertex per
/// cell of a grid (the vertex farthest from the hull's centroid), the cell starting at
/// 0.25 mm and doubling until the new hull is small enough: the new hull lies inside the old
/// one, within `√3` cells of its surface (0.9 mm at a 0.5 mm cell).
fn simplify_hull(hull: (Vec<Vector>, Vec<[u32; 3]>)) -> (Vec<Vector>, Vec<[u32; 3]>) {
    if hull.0.len() <= LINK_HULL_MAX_VERTICES {
        return hull;
    }
    let centroid = hull.0.iter().fold(Vector::ZERO, |a, p| a + *p) / hull.0.len() as f64;
    let mut cell = 2.5e-4;
    let mut best = hull;
    for _ in 0..12 {
        let mut grid: HashMap<[i64; 3], Vector> = HashMap::new();
        for p in &best.0 {
            let key = [p.x, p.y, p.z].map(|c| (c / cell).floor() as i64);
            let e = grid.entry(key).or_insert(*p);
            if (*p - centroid).length() > (*e - centroid).length() {
                *e = *p;
            }
        }
        let mut pts: Vec<Vector> = grid.into_values().collect();
        pts.sort_by(|a, b| {
            [a.x, a.y, a.z]
                .partial_cmp(&[b.x, b.y, b.z])
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        match rapier3d_f64::parry::transformation::try_convex_hull(&pts) {
            Ok(h) if h.0.len() >= 4 && !h.1.is_empty() => {
                let small = h.0.len() <= LINK_HULL_MAX_VERTICES;
                best = h;
                if small {
                    break;
                }
            }
            _ => break,
        }
        cell *= 2.0;
    }
    best
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
        let hulls = cached_hulls(&points, &mesh.triangles, params, cache_dir().as_deref());
        let parts: Vec<SharedShape> = hulls
            .into_iter()
            .flatten()
            .filter_map(|(v, i)| SharedShape::convex_mesh(v, &i))
            .collect();
        if parts.is_empty() {
            (vec![hull], ShapeMethod::HullFallback)
        } else {
            (parts, ShapeMethod::Decomposition)
        }
    })
}

/// Exact hulls `(vertices, triangles)` of the V-HACD parts.
pub type Hulls = Vec<(Vec<Vector>, Vec<[u32; 3]>)>;

/// The V-HACD hulls of one closed part, from the disk cache in `dir` or computed now (and
/// stored there).
fn cached_hulls(
    points: &[Vector],
    triangles: &[[u32; 3]],
    params: &DecompositionParams,
    dir: Option<&Path>,
) -> Option<Hulls> {
    let key = part_key(points, triangles, params);
    let file = dir.map(|d| d.join(format!("vhacd-{key:016x}.bin")));
    if let Some(hulls) = file.as_deref().and_then(|f| read_entry(f, key)) {
        return Some(hulls);
    }
    let hulls = decompose(points, triangles, params)?;
    if let Some(f) = &file {
        // A cache that cannot be written only costs time.
        let _ = write_entry(f, key, &hulls);
    }
    Some(hulls)
}

/// The folder of the on-disk decomposition cache: `$DEXWARP_CACHE_DIR` when set (empty or
/// `off` disables the disk cache), else `$XDG_CACHE_HOME/dexwarp`, else
/// `$HOME/.cache/dexwarp`; `None` (no disk cache) when none is set.
pub fn cache_dir() -> Option<PathBuf> {
    if let Some(v) = std::env::var_os("DEXWARP_CACHE_DIR") {
        return (!v.is_empty() && v != "off").then(|| PathBuf::from(v));
    }
    let base = std::env::var_os("XDG_CACHE_HOME")
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))?;
    Some(base.join("dexwarp"))
}

/// Format tag of a cache entry; bump it when the entry layout or the hull construction
/// changes, so old entries are ignored.
const ENTRY_MAGIC: &[u8; 8] = b"DXWVH001";

fn part_key(points: &[Vector], triangles: &[[u32; 3]], params: &DecompositionParams) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    ENTRY_MAGIC.hash(&mut h);
    for p in points {
        for c in [p.x, p.y, p.z] {
            c.to_bits().hash(&mut h);
        }
    }
    triangles.hash(&mut h);
    params.resolution.hash(&mut h);
    params.concavity.to_bits().hash(&mut h);
    params.max_parts.hash(&mut h);
    h.finish()
}

/// Entry layout (little endian): magic, key `u64`, part count `u64`, then per part the
/// vertex count `u64`, the vertices as `3 × f64` bits, the triangle count `u64`, the
/// triangles as `3 × u32`.
fn encode(key: u64, hulls: &Hulls) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(ENTRY_MAGIC);
    out.extend_from_slice(&key.to_le_bytes());
    out.extend_from_slice(&(hulls.len() as u64).to_le_bytes());
    for (v, t) in hulls {
        out.extend_from_slice(&(v.len() as u64).to_le_bytes());
        for p in v {
            for c in [p.x, p.y, p.z] {
                out.extend_from_slice(&c.to_bits().to_le_bytes());
            }
        }
        out.extend_from_slice(&(t.len() as u64).to_le_bytes());
        for tri in t {
            for i in tri {
                out.extend_from_slice(&i.to_le_bytes());
            }
        }
    }
    out
}

/// Decodes an entry; `None` when it is truncated, has trailing bytes, another key, or a
/// triangle index out of range.
fn decode(bytes: &[u8], key: u64) -> Option<Hulls> {
    struct Reader<'a>(&'a [u8]);
    impl Reader<'_> {
        fn take<const N: usize>(&mut self) -> Option<[u8; N]> {
            let (head, rest) = self.0.split_at_checked(N)?;
            self.0 = rest;
            head.try_into().ok()
        }
        fn u64(&mut self) -> Option<u64> {
            self.take::<8>().map(u64::from_le_bytes)
        }
        fn count(&mut self, item_bytes: usize) -> Option<usize> {
            let n = usize::try_from(self.u64()?).ok()?;
            (n.checked_mul(item_bytes)? <= self.0.len()).then_some(n)
        }
    }
    let mut r = Reader(bytes);
    if &r.take::<8>()? != ENTRY_MAGIC || r.u64()? != key {
        return None;
    }
    let parts = r.count(16)?;
    let mut hulls = Vec::with_capacity(parts);
    for _ in 0..parts {
        let nv = r.count(24)?;
        let mut v = Vec::with_capacity(nv);
        for _ in 0..nv {
            let mut c = [0.0; 3];
            for x in &mut c {
                *x = f64::from_bits(r.u64()?);
            }
            if c.iter().any(|x| !x.is_finite()) {
                return None;
            }
            v.push(Vector::new(c[0], c[1], c[2]));
        }
        let nt = r.count(12)?;
        let mut t = Vec::with_capacity(nt);
        for _ in 0..nt {
            let mut tri = [0u32; 3];
            for i in &mut tri {
                *i = u32::from_le_bytes(r.take::<4>()?);
                if *i as usize >= nv {
                    return None;
                }
            }
            t.push(tri);
        }
        hulls.push((v, t));
    }
    r.0.is_empty().then_some(hulls)
}

fn read_entry(file: &Path, key: u64) -> Option<Hulls> {
    decode(&std::fs::read(file).ok()?, key)
}

/// Writes an entry atomically: a temporary file unique to this process and call, then a
/// rename over the entry (concurrent writers of the same entry write the same bytes).
fn write_entry(file: &Path, key: u64, hulls: &Hulls) -> std::io::Result<()> {
    static SERIAL: AtomicU64 = AtomicU64::new(0);
    let dir = file.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    let tmp = dir.join(format!(
        ".{}.{}.{}.tmp",
        file.file_name().and_then(|n| n.to_str()).unwrap_or("entry"),
        std::process::id(),
        SERIAL.fetch_add(1, Ordering::Relaxed)
    ));
    let result =
        std::fs::write(&tmp, encode(key, hulls)).and_then(|()| std::fs::rename(&tmp, file));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// V-HACD parts as exact hulls of the triangles each voxel part covers; `None` if parry
/// panics (degenerate hulls inside V-HACD).
fn decompose(
    points: &[Vector],
    triangles: &[[u32; 3]],
    params: &DecompositionParams,
) -> Option<Hulls> {
    let vparams = VHACDParameters {
        resolution: params.resolution,
        concavity: params.concavity,
        max_convex_hulls: params.max_parts,
        ..VHACDParameters::default()
    };
    std::panic::catch_unwind(|| {
        let decomposition = VHACD::decompose(&vparams, points, triangles, true);
        decomposition.compute_exact_convex_hulls(points, triangles)
    })
    .ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cone without its base: open, with a 30-edge rim (too large a hole to fill).
    fn open_cone() -> Mesh {
        let n = 30u32;
        let mut vertices = vec![nalgebra::Point3::new(0.0, 0.0, 0.05)];
        for k in 0..n {
            let a = std::f64::consts::TAU * k as f64 / n as f64;
            vertices.push(nalgebra::Point3::new(0.04 * a.cos(), 0.04 * a.sin(), 0.0));
        }
        let triangles = (0..n).map(|k| [0, 1 + k, 1 + (k + 1) % n]).collect();
        Mesh {
            vertices,
            triangles,
        }
    }

    #[test]
    fn an_open_mesh_is_refused_unless_its_hull_is_asked_for() {
        let params = DecompositionParams::default();
        let err = object_shape(&open_cone(), &params).unwrap_err();
        let text = err.to_string();
        assert!(
            matches!(err, ShapeError::Open { ref defects, .. } if defects.boundary_edges == 30),
            "{text}"
        );
        assert!(
            text.contains("hull_fallback") && text.contains("cm³"),
            "{text}"
        );
        let asked = DecompositionParams {
            hull_fallback: true,
            ..params
        };
        let (shape, _) = object_shape(&open_cone(), &asked).unwrap();
        assert_eq!(shape.method, ShapeMethod::HullFallback);
        let [hull, _] = shape.fallback_volumes_m3.unwrap();
        // The cone's volume: π r² h / 3.
        let cone = std::f64::consts::PI * 0.04f64.powi(2) * 0.05 / 3.0;
        assert!((hull - cone).abs() < 0.02 * cone, "{hull} vs {cone}");
        // Refused again without the flag: the cache keeps the two apart.
        assert!(object_shape(&open_cone(), &params).is_err());
    }

    #[test]
    fn a_mesh_with_a_sliver_is_repaired_and_decomposed_as_closed() {
        let mut mesh = l_mesh();
        let [a, b, c] = mesh.triangles[0];
        mesh.triangles.push([a, b, c]);
        mesh.triangles.push([a, c, b]);
        let (shape, _) = object_shape(&mesh, &DecompositionParams::default()).unwrap();
        assert_ne!(shape.method, ShapeMethod::HullFallback);
        assert_eq!(shape.repair.as_ref().map(|r| r.sliver_pairs), Some(1));
    }

    #[test]
    fn the_mesh_collider_is_the_closed_mesh_with_its_own_mass() {
        let mesh = l_mesh();
        let params = DecompositionParams {
            collider: ObjectCollider::Mesh,
            ..DecompositionParams::default()
        };
        let (shape, _) = object_shape(&mesh, &params).unwrap();
        assert_eq!(shape.method, ShapeMethod::Mesh);
        assert_eq!(shape.parts.len(), 1);
        assert_eq!(shape.volume_ratio, Some(1.0));
        // The L's volume: (0.1 x 0.03 + 0.03 x 0.07) x 0.05 m³; unit density gives it as mass.
        let volume = (0.1 * 0.03 + 0.03 * 0.07) * 0.05;
        let mass = shape.unit_mass.mass();
        assert!((mass - volume).abs() < 1e-3 * volume, "{mass} vs {volume}");
        // The parts of the same mesh are a different shape, not a cache hit of this one.
        let (parts, _) = object_shape(&mesh, &DecompositionParams::default()).unwrap();
        assert_ne!(parts.method, ShapeMethod::Mesh);
    }

    /// [`l_shape`] as a [`Mesh`].
    fn l_mesh() -> Mesh {
        let (v, t) = l_shape();
        Mesh {
            vertices: v
                .iter()
                .map(|p| nalgebra::Point3::new(p.x, p.y, p.z))
                .collect(),
            triangles: t,
        }
    }

    /// An L-shaped prism (concave): two boxes sharing a face, as one closed mesh.
    fn l_shape() -> (Vec<Vector>, Vec<[u32; 3]>) {
        // Outline in the xy plane, counter-clockwise, extruded along z.
        let outline = [
            (0.0, 0.0),
            (0.1, 0.0),
            (0.1, 0.03),
            (0.03, 0.03),
            (0.03, 0.1),
            (0.0, 0.1),
        ];
        let n = outline.len() as u32;
        let mut v = Vec::new();
        for z in [0.0, 0.05] {
            for &(x, y) in &outline {
                v.push(Vector::new(x, y, z));
            }
        }
        // Bottom (z = 0, facing down) and top fans from the outline's concave-safe vertex 0
        // would cross the notch, so triangulate the two rectangles explicitly.
        let mut t = vec![[0, 2, 1], [0, 3, 2], [0, 4, 3], [0, 5, 4]];
        t.extend([[6, 7, 8], [6, 8, 9], [6, 9, 10], [6, 10, 11]]);
        for i in 0..n {
            let j = (i + 1) % n;
            t.push([i, j, j + n]);
            t.push([i, j + n, i + n]);
        }
        (v, t)
    }

    #[test]
    fn link_meshes_become_their_hull_or_parts_by_the_volume_rule() {
        let mesh = l_mesh();
        // The L fills 51 % of its hull (< LINK_HULL_RATIO): split into parts.
        let parts = link_hulls(&mesh).expect("has volume");
        assert!(parts.len() >= 2, "{} parts", parts.len());
        // The same mesh opened (two side triangles removed) has no volume to compare:
        // its hull, one part.
        let mut open = mesh.clone();
        open.triangles.truncate(open.triangles.len() - 2);
        assert_eq!(link_hulls(&open).map(|h| h.len()), Some(1));
        // A flat mesh has no volume: refused.
        let flat = Mesh {
            vertices: vec![
                nalgebra::Point3::new(0.0, 0.0, 0.0),
                nalgebra::Point3::new(1.0, 0.0, 0.0),
                nalgebra::Point3::new(0.0, 1.0, 0.0),
            ],
            triangles: vec![[0, 1, 2]],
        };
        assert!(link_hulls(&flat).is_none());
    }

    #[test]
    fn entries_round_trip_to_the_bit_and_bad_ones_are_refused() {
        let hulls: Hulls = vec![
            (
                vec![
                    Vector::new(0.1, -0.2, 1.0 / 3.0),
                    Vector::new(1e-17, 2.0, 3.0),
                ],
                vec![[0, 1, 1]],
            ),
            (vec![Vector::new(4.0, 5.0, 6.0)], vec![]),
        ];
        let bytes = encode(42, &hulls);
        let back = decode(&bytes, 42).expect("decodes");
        assert_eq!(back.len(), 2);
        for ((v, t), (w, u)) in hulls.iter().zip(&back) {
            assert_eq!(t, u);
            for (a, b) in v.iter().zip(w) {
                assert_eq!(
                    [a.x, a.y, a.z].map(f64::to_bits),
                    [b.x, b.y, b.z].map(f64::to_bits)
                );
            }
        }
        assert!(decode(&bytes, 43).is_none(), "another key must not match");
        for cut in [0, 7, 8, 20, bytes.len() - 1] {
            assert!(decode(&bytes[..cut], 42).is_none(), "truncated at {cut}");
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(decode(&longer, 42).is_none(), "trailing bytes");
        let mut bad_index = encode(42, &vec![(vec![Vector::ZERO], vec![[0, 0, 1]])]);
        assert!(decode(&bad_index, 42).is_none(), "index out of range");
        bad_index.clear();
        assert!(decode(&bad_index, 42).is_none());
    }

    #[test]
    fn disk_cache_gives_the_same_parts_and_survives_a_corrupt_entry() {
        let dir = tempfile::tempdir().unwrap();
        let (v, t) = l_shape();
        let params = DecompositionParams::default();
        let fresh = cached_hulls(&v, &t, &params, Some(dir.path())).expect("decomposes");
        assert!(
            fresh.len() >= 2,
            "an L shape needs two parts, got {}",
            fresh.len()
        );
        let files: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(files.len(), 1, "one entry, no temporary left");
        let entry = files[0].as_ref().unwrap().path();
        let bits = |h: &Hulls| -> Vec<u64> {
            h.iter()
                .flat_map(|(v, _)| v.iter().flat_map(|p| [p.x, p.y, p.z].map(f64::to_bits)))
                .collect()
        };
        // A hit: the same vertices, to the bit.
        let hit = cached_hulls(&v, &t, &params, Some(dir.path())).unwrap();
        assert_eq!(bits(&hit), bits(&fresh));
        // A corrupt entry is ignored, rebuilt and rewritten.
        std::fs::write(&entry, b"DXWVH001garbage").unwrap();
        let rebuilt = cached_hulls(&v, &t, &params, Some(dir.path())).unwrap();
        assert_eq!(bits(&rebuilt), bits(&fresh));
        assert!(decode(&std::fs::read(&entry).unwrap(), part_key(&v, &t, &params)).is_some());
        // Other parameters are another entry.
        let coarse = DecompositionParams {
            resolution: 16,
            ..params
        };
        cached_hulls(&v, &t, &coarse, Some(dir.path())).unwrap();
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    }
}
