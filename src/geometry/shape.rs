//! Collision geometry of a link and deterministic surface sampling.
//!
//! Each URDF `<collision>` becomes a [`CollisionShape`]: the URDF geometry ([`ShapeKind`],
//! kept for printing and sampling), its `origin` in the link frame, and a parry
//! [`SharedShape`] with the pose `shape_pose` at which parry must place it. The two poses
//! differ for cylinders only: URDF cylinders run along their local `z`, parry's along `y`, so
//! `shape_pose = origin · R_x(+π/2)` (which maps parry's `y` onto URDF's `z`). Capsules are
//! built along `z` directly (`SharedShape::capsule_z`).
//!
//! Surface points (link frame) are placed on a lattice of spacing `h` (default 8 mm):
//! - box: every lattice point of the surface, `⌈a/h⌉ + 1` per edge of length `a`;
//! - sphere: `⌈4πr²/h²⌉` points on a Fibonacci spiral;
//! - cylinder: rings every `≤ h` along the axis with `⌈2πr/h⌉` points, plus concentric
//!   rings on both caps;
//! - capsule: cylinder rings plus latitude rings on both hemispheres, a point at each pole;
//! - mesh: points at least `h` apart whatever the triangulation: dense candidates (`9/h²`
//!   per unit area, carried over from triangle to triangle by error diffusion, at
//!   low-discrepancy barycentric points) thinned greedily in triangle order, a candidate
//!   kept only when no kept point is within `h` (a grid of cell `h` finds the neighbours).
//!   A fingertip mesh of 2,000 triangles gives the same count as a box of its size, not
//!   one point per vertex.
//!
//! Every count is capped by [`SurfaceSampling::max_per_shape`]: a primitive is resampled
//! with a larger spacing, a mesh with a larger spacing too. No randomness is involved, so
//! the same URDF always gives the same points.
//!
//! Hand links with mesh collision geometry are built with [`CollisionShape::new_link`]: the
//! mesh is replaced by its convex parts ([`crate::geometry::hull::link_hulls`]: the hull of
//! each connected part, or its V-HACD parts when the hull is far from it), and the
//! [`ShapeKind::Mesh`] it keeps is the union of those parts' hulls, so the physics collider,
//! the penetration probes, the IK's surface points and the checks all see the same convex
//! shapes (a triangle mesh in Rapier is a hollow shell, and 30-700x slower to collide).

use std::f64::consts::{PI, TAU};
use std::fmt;
use std::path::PathBuf;
use std::sync::Arc;

use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};
use rapier3d_f64::parry::shape::SharedShape;

use crate::geometry::Mesh;

/// The URDF geometry of a collision element, in its own frame, metres.
#[derive(Clone, Debug, PartialEq)]
pub enum ShapeKind {
    /// `<box size="x y z">`, centred.
    Box {
        /// Full edge lengths.
        size: Vector3<f64>,
    },
    /// `<sphere radius>`, centred.
    Sphere { radius: f64 },
    /// `<cylinder radius length>`, centred, along `z`.
    Cylinder { radius: f64, length: f64 },
    /// `<capsule radius length>`, centred, along `z`; `length` is the straight part (the
    /// distance between the two hemisphere centres), as in URDF.
    Capsule { radius: f64, length: f64 },
    /// `<mesh filename scale>`.
    Mesh {
        /// The resolved file.
        path: PathBuf,
        /// Per-axis scale applied to the vertices.
        scale: Vector3<f64>,
        /// The scaled mesh, outward-wound when it is closed.
        mesh: Arc<Mesh>,
    },
}

/// One collision element of a link.
#[derive(Clone)]
pub struct CollisionShape {
    /// The URDF geometry.
    pub kind: ShapeKind,
    /// URDF `<origin>`: pose of the geometry frame in the link frame.
    pub origin: Isometry3<f64>,
    /// The parry shape (a cylinder along `y`, everything else as in `kind`).
    pub shape: SharedShape,
    /// Pose of `shape` in the link frame (`origin`, composed with `R_x(π/2)` for cylinders).
    pub shape_pose: Isometry3<f64>,
    /// Convex parts a link mesh was replaced by ([`CollisionShape::new_link`]); 0 for
    /// primitives and meshes kept as triangle meshes.
    pub convex_parts: usize,
}

impl fmt::Debug for CollisionShape {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("CollisionShape")
            .field("kind", &self.kind)
            .field("origin", &self.origin)
            .field("shape_pose", &self.shape_pose)
            .finish_non_exhaustive()
    }
}

impl CollisionShape {
    /// Builds the parry shape for `kind` placed at `origin`. `None` when parry refuses the
    /// geometry (a mesh without triangles); dimensions are validated by the loader.
    pub fn new(kind: ShapeKind, origin: Isometry3<f64>) -> Option<CollisionShape> {
        let (shape, shape_pose) = match &kind {
            ShapeKind::Box { size } => (
                SharedShape::cuboid(size.x / 2.0, size.y / 2.0, size.z / 2.0),
                origin,
            ),
            ShapeKind::Sphere { radius } => (SharedShape::ball(*radius), origin),
            ShapeKind::Cylinder { radius, length } => {
                let y_to_z = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), PI / 2.0);
                (
                    SharedShape::cylinder(length / 2.0, *radius),
                    origin * y_to_z,
                )
            }
            ShapeKind::Capsule { radius, length } => {
                (SharedShape::capsule_z(length / 2.0, *radius), origin)
            }
            ShapeKind::Mesh { mesh, .. } => {
                let oriented = mesh.is_closed_and_consistently_wound();
                (SharedShape::new(mesh.to_trimesh(oriented)?), origin)
            }
        };
        Some(CollisionShape {
            kind,
            origin,
            shape,
            shape_pose,
            convex_parts: 0,
        })
    }

    /// Points whose convex hull encloses the shape, in the frame `origin` is given in (a
    /// scene item's: the world): a box's corners; a sphere's or a capsule's 256 spiral points
    /// on a ball inflated so the hull of the samples contains the true surface; a cylinder's
    /// two rings of 64 points on the circumscribed polygon; a mesh's vertices. The barrier
    /// push-out inflates the hull of these points.
    pub fn hull_points(&self) -> Vec<Point3<f64>> {
        let local: Vec<Point3<f64>> = match &self.kind {
            ShapeKind::Box { size } => {
                let h = size / 2.0;
                let mut v = Vec::with_capacity(8);
                for sx in [-1.0, 1.0] {
                    for sy in [-1.0, 1.0] {
                        for sz in [-1.0, 1.0] {
                            v.push(Point3::new(sx * h.x, sy * h.y, sz * h.z));
                        }
                    }
                }
                v
            }
            ShapeKind::Sphere { radius } => spiral_points(*radius / SAGITTA, 256),
            ShapeKind::Capsule { radius, length } => {
                let mut v = spiral_points(*radius / SAGITTA, 256);
                for p in &mut v {
                    p.z += if p.z >= 0.0 {
                        length / 2.0
                    } else {
                        -length / 2.0
                    };
                }
                v
            }
            ShapeKind::Cylinder { radius, length } => {
                let mut v = Vec::with_capacity(128);
                for i in 0..64 {
                    let a = i as f64 * TAU / 64.0;
                    let (s, c) = a.sin_cos();
                    let r = radius / (PI / 64.0).cos();
                    v.push(Point3::new(r * c, r * s, -length / 2.0));
                    v.push(Point3::new(r * c, r * s, length / 2.0));
                }
                v
            }
            ShapeKind::Mesh { mesh, .. } => mesh.vertices.clone(),
        };
        local.into_iter().map(|p| self.origin * p).collect()
    }

    /// As [`CollisionShape::new`] for a hand link: a mesh becomes its convex parts (see the
    /// module docs); the kind keeps the file and scale, with the parts' hulls as its mesh.
    /// `None` when no part of the mesh has a volume.
    pub fn new_link(kind: ShapeKind, origin: Isometry3<f64>) -> Option<CollisionShape> {
        let ShapeKind::Mesh { path, scale, mesh } = kind else {
            return CollisionShape::new(kind, origin);
        };
        let hulls = crate::geometry::hull::link_hulls(&mesh)?;
        let mut merged = Mesh::default();
        let mut parts = Vec::with_capacity(hulls.len());
        for (v, t) in &hulls {
            let base = merged.vertices.len() as u32;
            merged
                .vertices
                .extend(v.iter().map(|p| Point3::new(p.x, p.y, p.z)));
            merged
                .triangles
                .extend(t.iter().map(|tri| tri.map(|i| i + base)));
            parts.push(SharedShape::convex_mesh(v.clone(), t)?);
        }
        let n = parts.len();
        let shape = if n == 1 {
            parts.pop()?
        } else {
            use rapier3d_f64::parry::math::Pose;
            SharedShape::compound(parts.into_iter().map(|p| (Pose::IDENTITY, p)).collect())
        };
        Some(CollisionShape {
            kind: ShapeKind::Mesh {
                path,
                scale,
                mesh: Arc::new(merged),
            },
            origin,
            shape,
            shape_pose: origin,
            convex_parts: n,
        })
    }

    /// A one-line description with dimensions in millimetres, e.g. `capsule r 9.0 mm, length 40.0 mm`.
    pub fn describe(&self) -> String {
        match &self.kind {
            ShapeKind::Box { size } => format!(
                "box {:.1} x {:.1} x {:.1} mm",
                size.x * 1e3,
                size.y * 1e3,
                size.z * 1e3
            ),
            ShapeKind::Sphere { radius } => format!("sphere r {:.1} mm", radius * 1e3),
            ShapeKind::Cylinder { radius, length } => format!(
                "cylinder r {:.1} mm, length {:.1} mm",
                radius * 1e3,
                length * 1e3
            ),
            ShapeKind::Capsule { radius, length } => format!(
                "capsule r {:.1} mm, length {:.1} mm",
                radius * 1e3,
                length * 1e3
            ),
            ShapeKind::Mesh { path, scale, mesh } => {
                let name = path.file_name().map_or_else(
                    || path.display().to_string(),
                    |n| n.to_string_lossy().into_owned(),
                );
                let scale = if *scale == Vector3::repeat(1.0) {
                    String::new()
                } else {
                    format!(", scale {} {} {}", scale.x, scale.y, scale.z)
                };
                if self.convex_parts > 0 {
                    format!(
                        "mesh {name} as {} convex part{} ({} hull vertices{scale})",
                        self.convex_parts,
                        if self.convex_parts == 1 { "" } else { "s" },
                        mesh.vertices.len()
                    )
                } else {
                    format!(
                        "mesh {name} ({} vertices, {} triangles{scale})",
                        mesh.vertices.len(),
                        mesh.triangles.len()
                    )
                }
            }
        }
    }

    /// Penetration depth of the link-frame point `p` into this shape \[m\]: positive inside,
    /// `≤ 0` outside (for a mesh, meaningful only when it is closed and outward-wound).
    pub fn depth_of(&self, p: &Point3<f64>) -> f64 {
        let pose = crate::math::convert::to_pose(&self.shape_pose);
        -self
            .shape
            .distance_to_point(&pose, crate::math::convert::to_point(p), false)
    }

    /// Appends surface points and outward normals of this shape, in the link frame.
    pub fn sample_surface(
        &self,
        sampling: &SurfaceSampling,
        points: &mut Vec<Point3<f64>>,
        normals: &mut Vec<Vector3<f64>>,
    ) {
        let mut local = Vec::new();
        sample_kind(&self.kind, sampling, &mut local);
        for (p, n) in local {
            points.push(self.origin * p);
            normals.push(self.origin.rotation * n);
        }
    }
}

/// How densely link surfaces are sampled (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceSampling {
    /// Target distance between neighbouring points \[m\]; default 0.008.
    pub spacing: f64,
    /// Most points on one collision shape; default 600.
    pub max_per_shape: usize,
}

impl Default for SurfaceSampling {
    fn default() -> Self {
        SurfaceSampling {
            spacing: 0.008,
            max_per_shape: 600,
        }
    }
}

/// Depth \[m\] beyond which a surface point of one shape, inside another shape of the same
/// link, is dropped (0.5 mm: points on touching faces are kept).
pub const BURIED_DEPTH: f64 = 5e-4;

/// A surface point and its outward unit normal, in the shape's own frame.
type Sample = (Point3<f64>, Vector3<f64>);

/// Samples `kind` in its own frame, honouring the per-shape cap.
fn sample_kind(kind: &ShapeKind, sampling: &SurfaceSampling, out: &mut Vec<Sample>) {
    let cap = sampling.max_per_shape.max(1);
    if let ShapeKind::Mesh { mesh, .. } = kind {
        sample_mesh(mesh, sampling.spacing, cap, out);
        return;
    }
    let mut h = sampling.spacing.max(1e-6);
    // Counts scale as 1/h²; a few rounds always get below the cap (each round shrinks the
    // count by at least the ratio, and a single-point sample exists for every primitive).
    for _ in 0..32 {
        out.clear();
        match *kind {
            ShapeKind::Box { size } => sample_box(size, h, out),
            ShapeKind::Sphere { radius } => sample_sphere(radius, h, out),
            ShapeKind::Cylinder { radius, length } => sample_cylinder(radius, length, h, out),
            ShapeKind::Capsule { radius, length } => sample_capsule(radius, length, h, out),
            ShapeKind::Mesh { .. } => unreachable!(),
        }
        if out.len() <= cap {
            return;
        }
        h *= (out.len() as f64 / cap as f64).sqrt() * 1.05;
    }
    out.truncate(cap);
}

/// Number of lattice intervals covering `len` with spacing at most `h`.
fn intervals(len: f64, h: f64) -> usize {
    ((len / h).ceil() as usize).clamp(1, 1 << 16)
}

/// Box of full edge lengths `size`, centred: the lattice `(i, j, k)` with `⌈size/h⌉`
/// intervals per axis, keeping the points with an index at either end (on a face). Edge
/// and corner normals are the normalised sums of the adjacent face normals.
fn sample_box(size: Vector3<f64>, h: f64, out: &mut Vec<Sample>) {
    let half = size / 2.0;
    let n = [
        intervals(size.x, h),
        intervals(size.y, h),
        intervals(size.z, h),
    ];
    let coord = |axis: usize, i: usize| -half[axis] + size[axis] * i as f64 / n[axis] as f64;
    for i in 0..=n[0] {
        for j in 0..=n[1] {
            for k in 0..=n[2] {
                let idx = [i, j, k];
                // Normal: sum of the outward face normals of the faces the point lies on.
                let mut normal = Vector3::zeros();
                for a in 0..3 {
                    if idx[a] == 0 {
                        normal[a] -= 1.0;
                    } else if idx[a] == n[a] {
                        normal[a] += 1.0;
                    }
                }
                if normal == Vector3::zeros() {
                    continue; // interior lattice point
                }
                let p = Point3::new(coord(0, i), coord(1, j), coord(2, k));
                out.push((p, normal.normalize()));
            }
        }
    }
}

/// Sphere: `⌈4πr²/h²⌉` Fibonacci points (area per point ≈ h²), normals radial.
fn sample_sphere(radius: f64, h: f64, out: &mut Vec<Sample>) {
    let n = ((4.0 * PI * radius * radius / (h * h)).ceil() as usize).clamp(1, 1 << 20);
    fibonacci_sphere(n, |dir| out.push((Point3::from(dir * radius), dir)));
}

/// `n` near-uniform unit vectors on a Fibonacci spiral (golden-angle longitude steps,
/// equal-area latitude steps `z_i = 1 - (2i + 1)/n`).
fn fibonacci_sphere(n: usize, mut f: impl FnMut(Vector3<f64>)) {
    let golden = PI * (3.0 - 5f64.sqrt());
    for i in 0..n {
        let z = 1.0 - (2 * i + 1) as f64 / n as f64;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = golden * i as f64;
        f(Vector3::new(r * phi.cos(), r * phi.sin(), z));
    }
}

/// One ring of radius `r` at height `z`, with at most `h` between neighbours; the normal
/// is `n(cos, sin)` built by `normal`.
fn ring(r: f64, z: f64, h: f64, out: &mut Vec<Sample>, normal: impl Fn(f64, f64) -> Vector3<f64>) {
    if r <= 1e-12 {
        out.push((Point3::new(0.0, 0.0, z), normal(1.0, 0.0)));
        return;
    }
    let m = intervals(TAU * r, h).max(3);
    for k in 0..m {
        let a = TAU * k as f64 / m as f64;
        let (s, c) = a.sin_cos();
        out.push((Point3::new(r * c, r * s, z), normal(c, s)));
    }
}

/// Cylinder along `z`: side rings at `⌈L/h⌉ + 1` heights including both rims, each with
/// `⌈2πr/h⌉` points; each cap gets concentric rings at radii `r k/⌈r/h⌉`, `k < ⌈r/h⌉`
/// (a single centre point for `k = 0`).
fn sample_cylinder(radius: f64, length: f64, h: f64, out: &mut Vec<Sample>) {
    let half = length / 2.0;
    let rings = intervals(length, h);
    for i in 0..=rings {
        let z = -half + length * i as f64 / rings as f64;
        ring(radius, z, h, out, |c, s| Vector3::new(c, s, 0.0));
    }
    // Caps: concentric rings strictly inside the rim (the rim belongs to the side rings).
    let caps = intervals(radius, h);
    for side in [-1.0, 1.0] {
        for k in 0..caps {
            let r = radius * k as f64 / caps as f64;
            ring(r, side * half, h, out, |_, _| Vector3::new(0.0, 0.0, side));
        }
    }
}

/// Capsule along `z` (segment from `-L/2` to `L/2`, radius `r`): side rings as for the
/// cylinder, then on each hemisphere latitude rings at `φ_k = (π/2) k / ⌈(π/2) r / h⌉`,
/// `k ≥ 1`, ending in one pole point. Normals are radial from the nearest segment point.
fn sample_capsule(radius: f64, length: f64, h: f64, out: &mut Vec<Sample>) {
    let half = length / 2.0;
    let rings = if length > 0.0 {
        intervals(length, h)
    } else {
        0
    };
    for i in 0..=rings {
        let z = if rings == 0 {
            0.0
        } else {
            -half + length * i as f64 / rings as f64
        };
        ring(radius, z, h, out, |c, s| Vector3::new(c, s, 0.0));
    }
    // Hemispheres: latitude φ_k = k·(π/2)/n for k = 1..=n (k = 0 is the equator ring above).
    let lat = intervals(PI / 2.0 * radius, h);
    for side in [-1.0, 1.0] {
        for k in 1..=lat {
            let phi = PI / 2.0 * k as f64 / lat as f64;
            let (sp, cp) = phi.sin_cos();
            let r = if k == lat { 0.0 } else { radius * cp };
            ring(r, side * (half + radius * sp), h, out, |c, s| {
                Vector3::new(cp * c, cp * s, side * sp)
            });
        }
    }
}

/// Points at least `h` apart on the triangles (see the module docs); when more than `cap`
/// would come out, the spacing grows until they fit.
fn sample_mesh(mesh: &Mesh, h: f64, cap: usize, out: &mut Vec<Sample>) {
    if mesh.vertices.is_empty() || mesh.triangles.is_empty() {
        return;
    }
    let total_area: f64 = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
            (b - a).cross(&(c - a)).norm() / 2.0
        })
        .sum();
    // A disc of radius h/2 per kept point: at most ~area/(0.7 h²) points fit; start with a
    // spacing that fits the cap, then grow it while the count is over.
    let mut h = h.max(1e-6).max((total_area / (0.7 * cap as f64)).sqrt());
    for _ in 0..16 {
        out.clear();
        thin_mesh_samples(mesh, total_area, h, out);
        if out.len() <= cap {
            return;
        }
        h *= (out.len() as f64 / cap as f64).sqrt() * 1.05;
    }
    out.truncate(cap);
}

/// Candidates at density `9/h²` (at most 200,000), kept when no kept point is within `h`.
fn thin_mesh_samples(mesh: &Mesh, total_area: f64, h: f64, out: &mut Vec<Sample>) {
    use std::collections::HashMap;
    let density = (9.0 / (h * h)).min(200_000.0 / total_area.max(1e-300));
    let cell = |p: &Point3<f64>| -> [i64; 3] { p.coords.map(|c| (c / h).floor() as i64).into() };
    let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    let mut try_keep = |p: Point3<f64>, n: Vector3<f64>, out: &mut Vec<Sample>| {
        let c = cell(&p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(ids) = grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz])
                        && ids.iter().any(|&i| (out[i].0 - p).norm() < h)
                    {
                        return;
                    }
                }
            }
        }
        grid.entry(c).or_default().push(out.len());
        out.push((p, n));
    };
    let mut carry = 0.0;
    let mut seq = 0u64;
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
        let cross = (b - a).cross(&(c - a));
        let Some(n) = cross.try_normalize(1e-300) else {
            continue;
        };
        // The first candidate of a triangle is its centroid, so small triangles are seen.
        carry += cross.norm() / 2.0 * density;
        if carry < 1.0 {
            continue;
        }
        try_keep(Point3::from((a.coords + b.coords + c.coords) / 3.0), n, out);
        carry -= 1.0;
        while carry >= 1.0 {
            carry -= 1.0;
            // R2 low-discrepancy sequence, folded into the triangle.
            seq += 1;
            let mut u = (0.5 + seq as f64 * 0.754_877_666_246_692_8).fract();
            let mut v = (0.5 + seq as f64 * 0.569_840_290_998_053_3).fract();
            if u + v > 1.0 {
                u = 1.0 - u;
                v = 1.0 - v;
            }
            try_keep(a + (b - a) * u + (c - a) * v, n, out);
        }
    }
}

/// Inflation of sampled round shapes so the hull of the samples encloses the true surface.
const SAGITTA: f64 = 0.985;

/// `n` points of a Fibonacci spiral on the sphere of radius `r` about the origin, for hulls
/// (the same spiral as [`fibonacci_sphere`], computed in the order the barrier hulls have
/// always used, so their points stay bit for bit the same).
fn spiral_points(r: f64, n: usize) -> Vec<Point3<f64>> {
    let golden = PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let rr = (1.0 - z * z).sqrt();
            let th = golden * i as f64;
            Point3::new(r * rr * th.cos(), r * rr * th.sin(), r * z)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn samples(kind: ShapeKind, h: f64) -> Vec<Sample> {
        let mut out = Vec::new();
        let sampling = SurfaceSampling {
            spacing: h,
            max_per_shape: 100_000,
        };
        sample_kind(&kind, &sampling, &mut out);
        out
    }

    /// Every sample lies on the parry surface and its normal points outwards.
    fn check_on_surface(kind: ShapeKind) {
        let shape = CollisionShape::new(kind.clone(), Isometry3::identity()).unwrap();
        let pose = crate::math::convert::to_pose(&shape.shape_pose);
        let pts = samples(kind.clone(), 0.004);
        assert!(pts.len() > 10, "{kind:?}: {} points", pts.len());
        for (p, n) in &pts {
            assert!((n.norm() - 1.0).abs() < 1e-9);
            let d = shape
                .shape
                .distance_to_point(&pose, crate::math::convert::to_point(p), false);
            assert!(d.abs() < 1e-9, "{kind:?}: {p} is {d} from the surface");
            let outside = p + n * 1e-4;
            let d = shape.shape.distance_to_point(
                &pose,
                crate::math::convert::to_point(&outside),
                false,
            );
            assert!(d > 0.0, "{kind:?}: normal {n} at {p} does not point out");
        }
    }

    #[test]
    fn primitives_are_sampled_on_their_surface() {
        check_on_surface(ShapeKind::Box {
            size: Vector3::new(0.02, 0.03, 0.05),
        });
        check_on_surface(ShapeKind::Sphere { radius: 0.015 });
        check_on_surface(ShapeKind::Cylinder {
            radius: 0.01,
            length: 0.04,
        });
        check_on_surface(ShapeKind::Capsule {
            radius: 0.009,
            length: 0.035,
        });
    }

    #[test]
    fn spacing_and_cap_are_respected() {
        let kind = ShapeKind::Box {
            size: Vector3::new(0.1, 0.1, 0.1),
        };
        // 0.1 m at 10 mm: 11 per edge, 11³ - 9³ = 602 surface lattice points.
        assert_eq!(samples(kind.clone(), 0.01).len(), 602);
        let mut out = Vec::new();
        let sampling = SurfaceSampling {
            spacing: 0.001,
            max_per_shape: 200,
        };
        sample_kind(&kind, &sampling, &mut out);
        assert!(out.len() <= 200 && out.len() > 50, "{}", out.len());
        // Deterministic.
        let mut again = Vec::new();
        sample_kind(&kind, &sampling, &mut again);
        assert_eq!(out, again);
    }

    #[test]
    fn cylinder_is_along_urdf_z() {
        let shape = CollisionShape::new(
            ShapeKind::Cylinder {
                radius: 0.01,
                length: 0.1,
            },
            Isometry3::identity(),
        )
        .unwrap();
        let pose = crate::math::convert::to_pose(&shape.shape_pose);
        let inside_z = crate::math::convert::to_vec(&Vector3::new(0.0, 0.0, 0.045));
        let outside_y = crate::math::convert::to_vec(&Vector3::new(0.0, 0.045, 0.0));
        assert!(shape.shape.contains_point(&pose, inside_z));
        assert!(!shape.shape.contains_point(&pose, outside_y));
    }
}
