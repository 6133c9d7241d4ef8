//! Triangle meshes: loading (OBJ, STL), checks, and conversion to parry shapes.
//!
//! A [`Mesh`] is an indexed triangle list in metres. Loading is defensive: sizes are checked
//! against [`Limits`] before anything large is read (the file size first; for binary STL also
//! the triangle count in the 84-byte header), and the result is validated (at least one
//! triangle, finite vertices, indices in range) so that later stages can index freely.
//!
//! Orientation: a closed mesh is *outward-wound* when every triangle `(a, b, c)` has its
//! normal `(b - a) × (c - a)` pointing out, equivalently when the signed volume
//! `V = Σ a · (b × c) / 6` is positive. parry answers inside/outside queries on a `TriMesh`
//! only for such meshes built with `TriMeshFlags::ORIENTED` (see `CRATES.md`).

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use nalgebra::{Point3, Vector3};
use rapier3d_f64::parry::shape::{SharedShape, TriMesh, TriMeshFlags};

use crate::error::{Error, Result};
use crate::limits::Limits;
use crate::math::convert::to_point;

/// A triangle mesh in its own frame, metres. Triangles index `vertices` and are wound
/// counter-clockwise seen from outside when the mesh is closed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub vertices: Vec<Point3<f64>>,
    pub triangles: Vec<[u32; 3]>,
}

/// File formats [`Mesh::load`] reads, for messages.
const SUPPORTED: &str = "supported mesh formats are .obj and .stl; convert other formats \
     (.dae, .glb, .gltf, .ply) first, e.g. `assimp export in.dae out.obj` or \
     `meshlab`/Blender export as OBJ, and point the URDF <mesh filename> at the .obj";

impl Mesh {
    /// The mesh split into its vertex-connected parts (closed parts that overlap without
    /// sharing vertices, like a mug's body and handle, come out separately).
    pub fn connected_parts(&self) -> Vec<Mesh> {
        let mesh = self;
        fn find(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        let n = mesh.vertices.len();
        let mut parent: Vec<usize> = (0..n).collect();
        for t in &mesh.triangles {
            let a = find(&mut parent, t[0] as usize);
            for &v in &t[1..] {
                let b = find(&mut parent, v as usize);
                if a != b {
                    parent[b] = a;
                }
            }
        }
        let mut part_of_root = vec![usize::MAX; n];
        let mut parts: Vec<Mesh> = Vec::new();
        let mut local = vec![u32::MAX; n];
        for t in &mesh.triangles {
            let root = find(&mut parent, t[0] as usize);
            if part_of_root[root] == usize::MAX {
                part_of_root[root] = parts.len();
                parts.push(Mesh::default());
            }
            let part = &mut parts[part_of_root[root]];
            let tri = t.map(|v| {
                let v = v as usize;
                if local[v] == u32::MAX {
                    local[v] = part.vertices.len() as u32;
                    part.vertices.push(mesh.vertices[v]);
                }
                local[v]
            });
            part.triangles.push(tri);
        }
        parts
    }

    /// Loads an OBJ (all objects and groups merged, polygons triangulated, identical
    /// positions merged, vertices renumbered in order of first use, unused ones dropped) or STL (binary or ASCII) file and multiplies every vertex
    /// component-wise by `scale`.
    ///
    /// Refuses, with the file named: files over `limits.max_mesh_bytes` and meshes over
    /// `limits.max_mesh_triangles` (before reading, for binary STL), unknown extensions,
    /// meshes without triangles, non-finite vertices and out-of-range indices.
    pub fn load(path: &Path, scale: Vector3<f64>, limits: &Limits) -> Result<Mesh> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        if ext != "obj" && ext != "stl" {
            return Err(Error::unsupported(
                path,
                "mesh",
                format!(
                    "cannot read a mesh with extension '{}'; {SUPPORTED}",
                    if ext.is_empty() { "(none)" } else { &ext }
                ),
            ));
        }
        // Special files are refused and the byte cap holds while reading (`Limits::read_file`).
        let bytes = limits.read_file(path, limits.max_mesh_bytes, "--max-file-mb")?;
        let mut mesh = if ext == "obj" {
            read_obj(path, &bytes, limits)?
        } else {
            read_stl(path, bytes, limits)?
        };
        mesh.validate(path)?;
        if scale != Vector3::repeat(1.0) {
            for v in &mut mesh.vertices {
                v.coords.component_mul_assign(&scale);
            }
        }
        Ok(mesh)
    }

    /// Checks that the mesh has triangles, finite vertices and indices in range.
    pub fn validate(&self, path: &Path) -> Result<()> {
        if self.triangles.is_empty() {
            return Err(Error::invalid(
                path,
                "triangles",
                "the mesh has no triangles; expected a non-empty triangle mesh",
            ));
        }
        if let Some(i) = self
            .vertices
            .iter()
            .position(|v| !v.iter().all(|c| c.is_finite()))
        {
            return Err(Error::invalid(
                path,
                format!("vertex {}", i + 1),
                format!(
                    "{:?} is not finite; expected finite coordinates",
                    self.vertices[i].coords.as_slice()
                ),
            ));
        }
        let n = self.vertices.len();
        for (t, tri) in self.triangles.iter().enumerate() {
            if let Some(&i) = tri.iter().find(|&&i| i as usize >= n) {
                return Err(Error::invalid(
                    path,
                    format!("triangle {}", t + 1),
                    format!(
                        "refers to vertex {} but the mesh has {n} vertices",
                        i as u64 + 1
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Largest distance of a vertex from the mesh origin \[m\]; `0` for an empty mesh.
    pub fn bounding_radius(&self) -> f64 {
        self.vertices
            .iter()
            .map(|v| v.coords.norm_squared())
            .fold(0.0, f64::max)
            .sqrt()
    }

    /// Sum of the triangle areas \[m²\].
    pub fn surface_area(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.vertices[i as usize]);
                (b - a).cross(&(c - a)).norm() / 2.0
            })
            .sum()
    }

    /// Signed volume `Σ a · (b × c) / 6` \[m³\]: the enclosed volume for a closed,
    /// outward-wound mesh, its negative for an inward-wound one.
    pub fn signed_volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.vertices[i as usize].coords);
                a.dot(&b.cross(&c))
            })
            .sum::<f64>()
            / 6.0
    }

    /// `true` when every undirected edge is shared by exactly two triangles that traverse
    /// it in opposite directions (a closed, consistently wound 2-manifold-with-edges).
    /// Triangles with a repeated vertex make the answer `false`.
    pub fn is_closed_and_consistently_wound(&self) -> bool {
        if self.triangles.is_empty() {
            return false;
        }
        let mut directed: HashMap<(u32, u32), u32> =
            HashMap::with_capacity(self.triangles.len() * 3);
        for &[a, b, c] in &self.triangles {
            if a == b || b == c || c == a {
                return false;
            }
            for e in [(a, b), (b, c), (c, a)] {
                let n = directed.entry(e).or_insert(0);
                *n += 1;
                if *n > 1 {
                    return false; // two triangles run the same way along this edge
                }
            }
        }
        directed
            .keys()
            .all(|&(a, b)| directed.contains_key(&(b, a)))
    }

    /// Reverses the winding of every triangle when the mesh is closed, consistently wound
    /// and has a negative signed volume, so that normals point out. Returns `true` if it
    /// flipped. Open meshes are left as they are.
    pub fn orient_outward(&mut self) -> bool {
        if self.signed_volume() < 0.0 && self.is_closed_and_consistently_wound() {
            for t in &mut self.triangles {
                t.swap(1, 2);
            }
            true
        } else {
            false
        }
    }

    /// The mesh as a parry `TriMesh`; with `oriented`, built with `TriMeshFlags::ORIENTED`
    /// so that point queries tell inside from outside (meaningful only for a closed,
    /// outward-wound mesh). `None` when parry refuses the mesh (no triangles).
    pub fn to_trimesh(&self, oriented: bool) -> Option<TriMesh> {
        let vertices = self.vertices.iter().map(to_point).collect();
        let flags = if oriented {
            TriMeshFlags::ORIENTED
        } else {
            TriMeshFlags::empty()
        };
        TriMesh::with_flags(vertices, self.triangles.clone(), flags).ok()
    }

    /// The convex hull of the vertices as a parry shape; `None` when the vertices are
    /// degenerate (fewer than 4, or all coplanar).
    pub fn convex_hull(&self) -> Option<SharedShape> {
        let points: Vec<_> = self.vertices.iter().map(to_point).collect();
        SharedShape::convex_hull(&points)
    }

    /// The convex hull of the vertices as a closed, outward-wound mesh; `None` when the
    /// vertices are degenerate.
    pub fn convex_hull_mesh(&self) -> Option<Mesh> {
        let points: Vec<_> = self.vertices.iter().map(to_point).collect();
        let (v, triangles) = rapier3d_f64::parry::transformation::try_convex_hull(&points).ok()?;
        let mut hull = Mesh {
            vertices: v.iter().map(|p| Point3::new(p.x, p.y, p.z)).collect(),
            triangles,
        };
        (hull.vertices.len() >= 4).then(|| {
            hull.orient_outward();
            hull
        })
    }

    /// The OBJ text of the mesh: a comment line, `v x y z` lines with 6 decimals
    /// (micrometres), then `f a b c` lines with 1-based indices. Deterministic.
    pub fn to_obj_string(&self) -> String {
        let mut s = String::with_capacity(32 * (self.vertices.len() + self.triangles.len()) + 64);
        let _ = writeln!(
            s,
            "# dexwarp mesh: {} vertices, {} triangles, metres",
            self.vertices.len(),
            self.triangles.len()
        );
        for v in &self.vertices {
            // `+ 0.0` turns -0.0 into 0.0 so that equal meshes give equal text.
            let _ = writeln!(s, "v {:.6} {:.6} {:.6}", v.x + 0.0, v.y + 0.0, v.z + 0.0);
        }
        for [a, b, c] in &self.triangles {
            let _ = writeln!(s, "f {} {} {}", a + 1, b + 1, c + 1);
        }
        s
    }

    /// The mesh as [`Mesh::write_obj`] writes it and [`Mesh::load`] reads it back (positions
    /// to the micrometre, read in single precision): what every command that loads the
    /// written file sees.
    pub fn as_written(&self) -> Result<Mesh> {
        let text = self.to_obj_string();
        read_obj(
            Path::new("(mesh as written).obj"),
            text.as_bytes(),
            &Limits::default(),
        )
    }

    /// Writes [`Mesh::to_obj_string`] to `path`.
    pub fn write_obj(&self, path: &Path) -> Result<()> {
        std::fs::write(path, self.to_obj_string()).map_err(|e| Error::write(path, e))
    }
}

/// Merges identical positions (bit-exact) so that groups of an OBJ share their vertices.
#[derive(Default)]
struct VertexMerger {
    index: HashMap<[u64; 3], u32>,
    mesh: Mesh,
}

impl VertexMerger {
    fn push(&mut self, p: [f64; 3]) -> u32 {
        let key = p.map(f64::to_bits);
        let next = self.mesh.vertices.len() as u32;
        *self.index.entry(key).or_insert_with(|| {
            self.mesh.vertices.push(Point3::from(p));
            next
        })
    }
}

/// The [`Error::TooLarge`] for a mesh over `limits.max_mesh_triangles`.
fn too_many_triangles(path: &Path, found: u64, limits: &Limits) -> Error {
    Error::TooLarge {
        path: path.to_path_buf(),
        what: "the number of mesh triangles",
        found,
        limit: limits.max_mesh_triangles,
        flag: "--max-triangles",
    }
}

/// Reads an OBJ with tobj: `v` positions (f32 in tobj, widened to f64), polygonal `f`
/// faces fan-triangulated, points and lines ignored, materials ignored (`mtllib` files are
/// not opened). Every object/group becomes part of one mesh; equal positions are merged so
/// that closedness is judged across groups. The triangle count is checked after parsing
/// (the file size bounds it beforehand: each `f` line takes at least 6 bytes).
fn read_obj(path: &Path, bytes: &[u8], limits: &Limits) -> Result<Mesh> {
    // Count the triangles of the `f` lines (a polygon of k corners makes k - 2) before tobj
    // parses anything.
    let counted: u64 = bytes
        .split(|&c| c == b'\n')
        .filter(|l| l.starts_with(b"f ") || l.starts_with(b"f\t"))
        .map(|l| {
            let corners = l[1..]
                .split(|c| c.is_ascii_whitespace())
                .filter(|t| !t.is_empty())
                .count();
            corners.saturating_sub(2) as u64
        })
        .sum();
    if counted > limits.max_mesh_triangles {
        return Err(too_many_triangles(path, counted, limits));
    }
    // `..Default::default()` covers the fields behind tobj's optional features.
    #[allow(clippy::needless_update)]
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    // Materials do not matter for collision: an empty material list for any `mtllib`.
    let (models, _) = tobj::load_obj_buf(&mut &bytes[..], &options, |_| {
        Ok((Vec::new(), Default::default()))
    })
    .map_err(|e| Error::Parse {
        path: path.to_path_buf(),
        field: "OBJ".into(),
        message: format!("not a valid OBJ file: {e}"),
    })?;
    let triangles: u64 = models.iter().map(|m| m.mesh.indices.len() as u64 / 3).sum();
    if triangles > limits.max_mesh_triangles {
        return Err(too_many_triangles(path, triangles, limits));
    }
    let mut merger = VertexMerger::default();
    for model in &models {
        let m = &model.mesh;
        let mut local = Vec::with_capacity(m.positions.len() / 3);
        for p in m.positions.chunks_exact(3) {
            local.push(merger.push([p[0] as f64, p[1] as f64, p[2] as f64]));
        }
        for t in m.indices.chunks_exact(3) {
            let mut tri = [0u32; 3];
            for k in 0..3 {
                // tobj checks face indices against the positions it read; stay defensive.
                tri[k] = *local.get(t[k] as usize).ok_or_else(|| {
                    Error::invalid(
                        path,
                        format!("object '{}'", model.name),
                        format!("face index {} is out of range", t[k] as u64 + 1),
                    )
                })?;
            }
            merger.mesh.triangles.push(tri);
        }
    }
    Ok(merger.mesh)
}

/// Reads an STL with stl_io; vertices are merged bit-exactly by stl_io's indexing.
///
/// Binary or ASCII is decided from the size, not from the first bytes: a file is binary
/// exactly when its size is `84 + 50 n` with `n` the header's triangle count (many binary
/// files start their header with `solid`, which fools a text probe). Otherwise it must start
/// with `solid` to be read as ASCII.
///
/// Binary STL layout: 80-byte header, `u32` little-endian triangle count, then 50 bytes
/// per triangle (normal, three vertices as `f32`, 2 attribute bytes).
fn read_stl(path: &Path, mut bytes: Vec<u8>, limits: &Limits) -> Result<Mesh> {
    let size = bytes.len() as u64;
    let mut head = [0u8; 84];
    let binary_count = if size >= 84 {
        head.copy_from_slice(&bytes[..84]);
        let n = u32::from_le_bytes([head[80], head[81], head[82], head[83]]) as u64;
        (84 + 50 * n == size).then_some(n)
    } else {
        None
    };
    let ascii = head.starts_with(b"solid") || (5..84).contains(&size);
    if let Some(n) = binary_count {
        if n > limits.max_mesh_triangles {
            return Err(too_many_triangles(path, n, limits));
        }
    } else if !ascii {
        let n = u32::from_le_bytes([head[80], head[81], head[82], head[83]]) as u64;
        return Err(Error::invalid(
            path,
            "STL",
            format!(
                "not an ASCII STL (no leading 'solid') and not a binary STL: the header says {n} \
                 triangles, which needs {} bytes, but the file has {size}",
                84 + 50 * n
            ),
        ));
    }
    if binary_count.is_some() && bytes.starts_with(b"solid ") {
        // Many binary STLs start their header with "solid "; hide it from stl_io's ASCII probe.
        bytes[0] = b'S';
    }
    let stl = stl_io::read_stl(&mut std::io::Cursor::new(bytes)).map_err(|e| Error::Parse {
        path: path.to_path_buf(),
        field: "STL".into(),
        message: format!("not a valid STL file: {e}"),
    })?;
    if stl.faces.len() as u64 > limits.max_mesh_triangles {
        return Err(too_many_triangles(path, stl.faces.len() as u64, limits));
    }
    let vertices = stl
        .vertices
        .iter()
        .map(|v| Point3::new(v[0] as f64, v[1] as f64, v[2] as f64))
        .collect();
    let mut triangles = Vec::with_capacity(stl.faces.len());
    for f in &stl.faces {
        let [a, b, c] = f.vertices;
        let idx = |i: usize| u32::try_from(i).unwrap_or(u32::MAX);
        triangles.push([idx(a), idx(b), idx(c)]);
    }
    Ok(Mesh {
        vertices,
        triangles,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn as_written_is_what_load_reads_back_from_the_written_file() {
        let mut mesh = cube();
        // -0.03 + 0.01 is -0.019999999999999997 in memory, -0.020000 in the file, and the
        // OBJ reader's single precision reads that back as -0.019999999552965164.
        mesh.vertices[0].x = -0.03 + 0.01;
        mesh.vertices[1].y = 1.0 / 3.0;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.obj");
        mesh.write_obj(&path).unwrap();
        let loaded = Mesh::load(&path, Vector3::repeat(1.0), &Limits::default()).unwrap();
        let written = mesh.as_written().unwrap();
        assert_eq!(written.vertices, loaded.vertices);
        assert_eq!(written.triangles, loaded.triangles);
        // (The reader orders the vertices as the faces first use them.)
        assert!(written.vertices.iter().any(|v| v.x == f64::from(-0.02f32)));
        assert!(
            written
                .vertices
                .iter()
                .any(|v| v.y == f64::from(0.333333f32))
        );
        assert_ne!(written.vertices, mesh.vertices);
    }

    /// A unit cube centred at the origin, outward-wound.
    fn cube() -> Mesh {
        let vertices = (0..8)
            .map(|i| {
                Point3::new(
                    if i & 1 == 0 { -0.5 } else { 0.5 },
                    if i & 2 == 0 { -0.5 } else { 0.5 },
                    if i & 4 == 0 { -0.5 } else { 0.5 },
                )
            })
            .collect();
        let triangles = vec![
            [0, 2, 1],
            [1, 2, 3], // z = -0.5
            [4, 5, 6],
            [5, 7, 6], // z = +0.5
            [0, 1, 4],
            [1, 5, 4], // y = -0.5
            [2, 6, 3],
            [3, 6, 7], // y = +0.5
            [0, 4, 2],
            [2, 4, 6], // x = -0.5
            [1, 3, 5],
            [3, 7, 5], // x = +0.5
        ];
        Mesh {
            vertices,
            triangles,
        }
    }

    #[test]
    fn cube_is_closed_with_unit_volume() {
        let m = cube();
        assert!(m.is_closed_and_consistently_wound());
        assert!(
            (m.signed_volume() - 1.0).abs() < 1e-12,
            "{}",
            m.signed_volume()
        );
        assert!((m.surface_area() - 6.0).abs() < 1e-12);
        assert!((m.bounding_radius() - 0.75f64.sqrt()).abs() < 1e-12);
        let mut open = m.clone();
        open.triangles.pop();
        assert!(!open.is_closed_and_consistently_wound());
        let mut flipped = m.clone();
        flipped.triangles[0].swap(1, 2);
        assert!(!flipped.is_closed_and_consistently_wound());
    }

    #[test]
    fn orient_outward_flips_inside_out_mesh() {
        let mut m = cube();
        for t in &mut m.triangles {
            t.swap(0, 1);
        }
        assert!(m.signed_volume() < 0.0);
        assert!(m.orient_outward());
        assert!((m.signed_volume() - 1.0).abs() < 1e-12);
        assert!(!m.orient_outward());
    }

    #[test]
    fn oriented_trimesh_tells_inside() {
        let m = cube();
        let tm = m.to_trimesh(true).unwrap();
        use rapier3d_f64::parry::query::PointQuery;
        let inside = tm.contains_local_point(to_point(&Point3::new(0.1, 0.2, -0.3)));
        let outside = tm.contains_local_point(to_point(&Point3::new(0.1, 0.7, -0.3)));
        assert!(inside && !outside);
        assert!(m.convex_hull().is_some());
    }

    #[test]
    fn obj_round_trip_with_scale() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("cube.obj");
        let m = cube();
        m.write_obj(&path).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(
            text.contains("\nv -0.500000 -0.500000 -0.500000\n"),
            "{text}"
        );
        assert!(text.contains("\nf 1 3 2\n"), "{text}");
        let back = Mesh::load(&path, Vector3::repeat(1.0), &Limits::default()).unwrap();
        // tobj renumbers vertices by first use; the triangles' corners are what must match.
        let corners = |m: &Mesh| -> Vec<[Point3<f64>; 3]> {
            m.triangles
                .iter()
                .map(|t| t.map(|i| m.vertices[i as usize]))
                .collect()
        };
        assert_eq!(corners(&back), corners(&m));
        assert_eq!(back.vertices.len(), 8);
        let scaled = Mesh::load(&path, Vector3::new(2.0, 1.0, 1.0), &Limits::default()).unwrap();
        assert!((scaled.signed_volume() - 2.0).abs() < 1e-12);
    }

    #[test]
    fn obj_groups_are_merged_and_quads_triangulated() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("quad.OBJ");
        std::fs::write(
            &path,
            "mtllib missing.mtl\no a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\no b\nf 1 3 2\n",
        )
        .unwrap();
        let m = Mesh::load(&path, Vector3::repeat(1.0), &Limits::default()).unwrap();
        assert_eq!(m.vertices.len(), 4);
        assert_eq!(m.triangles.len(), 3);
    }

    fn binary_stl(m: &Mesh, header: &[u8]) -> Vec<u8> {
        let mut out = vec![0u8; 80];
        out[..header.len()].copy_from_slice(header);
        out.extend_from_slice(&(m.triangles.len() as u32).to_le_bytes());
        for t in &m.triangles {
            out.extend_from_slice(&[0u8; 12]);
            for &i in t {
                for c in m.vertices[i as usize].iter() {
                    out.extend_from_slice(&(*c as f32).to_le_bytes());
                }
            }
            out.extend_from_slice(&[0, 0]);
        }
        out
    }

    #[test]
    fn stl_binary_and_ascii() {
        let dir = tempfile::tempdir().unwrap();
        let m = cube();
        // Binary with a misleading "solid " header.
        let path = dir.path().join("cube.stl");
        std::fs::write(&path, binary_stl(&m, b"solid cube")).unwrap();
        let back = Mesh::load(&path, Vector3::repeat(0.1), &Limits::default()).unwrap();
        assert_eq!(back.triangles.len(), 12);
        assert_eq!(back.vertices.len(), 8);
        assert!(back.is_closed_and_consistently_wound());
        assert!((back.signed_volume() - 1e-3).abs() < 1e-12);
        // ASCII.
        let path = dir.path().join("tri.stl");
        std::fs::write(
            &path,
            "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n\
             endloop\nendfacet\nendsolid t\n",
        )
        .unwrap();
        let tri = Mesh::load(&path, Vector3::repeat(1.0), &Limits::default()).unwrap();
        assert_eq!(tri.triangles.len(), 1);
    }

    #[test]
    fn limits_are_checked_before_reading() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("cube.stl");
        std::fs::write(&path, binary_stl(&cube(), b"bin")).unwrap();
        let limits = Limits {
            max_mesh_triangles: 11,
            ..Limits::default()
        };
        let err = Mesh::load(&path, Vector3::repeat(1.0), &limits).unwrap_err();
        assert!(
            matches!(
                err,
                Error::TooLarge {
                    found: 12,
                    limit: 11,
                    ..
                }
            ),
            "{err}"
        );
        assert!(err.to_string().contains("--max-triangles"), "{err}");
        let limits = Limits {
            max_mesh_bytes: 100,
            ..Limits::default()
        };
        let err = Mesh::load(&path, Vector3::repeat(1.0), &limits).unwrap_err();
        assert!(err.to_string().contains("cube.stl"), "{err}");
        assert!(matches!(err, Error::TooLarge { .. }), "{err}");
    }

    #[test]
    fn bad_meshes_are_refused_with_the_file_named() {
        let dir = tempfile::tempdir().unwrap();
        let l = Limits::default();
        let one = Vector3::repeat(1.0);

        let path = dir.path().join("model.ply");
        std::fs::write(&path, "ply").unwrap();
        let err = Mesh::load(&path, one, &l).unwrap_err();
        assert!(matches!(err, Error::Unsupported { .. }));
        let msg = err.to_string();
        assert!(
            msg.contains("model.ply") && msg.contains(".obj") && msg.contains(".stl"),
            "{msg}"
        );

        let path = dir.path().join("empty.obj");
        std::fs::write(&path, "v 0 0 0\n").unwrap();
        let msg = Mesh::load(&path, one, &l).unwrap_err().to_string();
        assert!(
            msg.contains("empty.obj") && msg.contains("no triangles"),
            "{msg}"
        );

        let path = dir.path().join("nan.obj");
        std::fs::write(&path, "v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let msg = Mesh::load(&path, one, &l).unwrap_err().to_string();
        assert!(
            msg.contains("nan.obj") && msg.contains("not finite"),
            "{msg}"
        );

        let path = dir.path().join("range.obj");
        std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n").unwrap();
        let msg = Mesh::load(&path, one, &l).unwrap_err().to_string();
        assert!(msg.contains("range.obj"), "{msg}");

        let path = dir.path().join("garbage.stl");
        std::fs::write(&path, vec![7u8; 200]).unwrap();
        let msg = Mesh::load(&path, one, &l).unwrap_err().to_string();
        assert!(
            msg.contains("garbage.stl") && msg.contains("binary STL"),
            "{msg}"
        );

        let missing = dir.path().join("missing.obj");
        let msg = Mesh::load(&missing, one, &l).unwrap_err().to_string();
        assert!(msg.contains("missing.obj"), "{msg}");

        let m = Mesh {
            vertices: vec![Point3::origin(); 3],
            triangles: vec![[0, 1, 3]],
        };
        let msg = m.validate(Path::new("x.obj")).unwrap_err().to_string();
        assert!(
            msg.contains("triangle 1") && msg.contains("vertex 4"),
            "{msg}"
        );
    }
}
