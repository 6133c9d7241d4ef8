//! Object meshes for the demonstrations: cube, frying pan, mug, teapot, apple, small box.
//!
//! Every object is a union of closed parts (a body plus handles, a spout ...). Each part
//! is a closed 2-manifold, wound counter-clockwise seen from outside: every undirected
//! edge is shared by exactly two triangles that traverse it in opposite directions, and
//! the signed volume `Σ a · (b × c) / 6` is positive. Parts share no vertices; where a
//! handle meets a body the two solids overlap, as in a CSG union.
//!
//! Frames: metres; the origin is the volume centroid of the main body (the revolved body
//! for the pan, mug and teapot, the whole object otherwise) and `+z` points up when the
//! object rests on a table in its natural pose. Handles and spouts lie in the `xz` plane:
//! the pan and mug handles and the teapot spout point to `+x`, the teapot handle to `-x`.
//!
//! The meshes are built from three primitives, each closed by construction:
//! - a surface of revolution of a profile `(r, z)` that starts and ends on the axis
//!   (a cup with a cavity is one profile going up the outside and down the inside),
//! - a tube swept along a path with an elliptical cross-section, capped at both ends,
//! - a box whose faces are regular grids (so contact sampling finds vertices on faces).
//!
//! Output is deterministic: no randomness, fixed resolutions.

use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::fmt;
use std::str::FromStr;

use nalgebra::{Point3, Vector3};

use crate::geometry::Mesh;

/// The objects dexwarp generates.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ObjectKind {
    /// Wooden cube, 6 cm edge.
    Cube,
    /// Frying pan, 24 cm rim diameter, 4 cm deep, 3 mm wall, 18 cm handle.
    FryingPan,
    /// Mug, 8 cm diameter, 9.5 cm tall, with a cavity and a D-shaped handle.
    Mug,
    /// Teapot, 15 cm wide body (solid), lid knob, spout and handle.
    Teapot,
    /// Apple, 8.2 cm wide, slightly flattened, dimpled at both poles.
    Apple,
    /// Gripper-friendly box, 4 x 4 x 6 cm (long side up).
    SmallBox,
}

impl ObjectKind {
    /// Every object, in a fixed order.
    pub const ALL: [ObjectKind; 6] = [
        ObjectKind::Cube,
        ObjectKind::FryingPan,
        ObjectKind::Mug,
        ObjectKind::Teapot,
        ObjectKind::Apple,
        ObjectKind::SmallBox,
    ];

    /// The name used on the command line and for `scenes/objects/<name>.obj`.
    pub fn name(self) -> &'static str {
        match self {
            ObjectKind::Cube => "cube",
            ObjectKind::FryingPan => "frying_pan",
            ObjectKind::Mug => "mug",
            ObjectKind::Teapot => "teapot",
            ObjectKind::Apple => "apple",
            ObjectKind::SmallBox => "small_box",
        }
    }

    /// The object's mesh; same as [`object_mesh`].
    pub fn mesh(self) -> Mesh {
        object_mesh(self)
    }

    /// The object's mass [kg]; same as [`object_mass_kg`].
    pub fn mass_kg(self) -> f64 {
        object_mass_kg(self)
    }
}

impl fmt::Display for ObjectKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An object name that [`ObjectKind::from_str`] does not know.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown object '{name}'; valid objects are: {}", valid_names())]
pub struct UnknownObject {
    /// The name as given.
    pub name: String,
}

fn valid_names() -> String {
    ObjectKind::ALL.map(ObjectKind::name).join(", ")
}

impl FromStr for ObjectKind {
    type Err = UnknownObject;

    /// Accepts the [`ObjectKind::name`]s, case-insensitively, with `-` for `_`, and the
    /// paper's spellings `fryingpan` and `box`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let key = s.trim().to_ascii_lowercase().replace('-', "_");
        let alias = match key.as_str() {
            "fryingpan" | "pan" => Some(ObjectKind::FryingPan),
            "box" | "smallbox" => Some(ObjectKind::SmallBox),
            _ => None,
        };
        alias
            .or_else(|| ObjectKind::ALL.into_iter().find(|k| k.name() == key))
            .ok_or_else(|| UnknownObject {
                name: s.to_string(),
            })
    }
}

/// Realistic mass of each object [kg]: a wooden (beech) cube, an aluminium pan with a
/// steel handle, a ceramic mug, an empty ceramic teapot, an apple, a light cardboard box.
pub fn object_mass_kg(kind: ObjectKind) -> f64 {
    match kind {
        ObjectKind::Cube => 0.10,
        ObjectKind::FryingPan => 0.90,
        ObjectKind::Mug => 0.30,
        ObjectKind::Teapot => 0.60,
        ObjectKind::Apple => 0.18,
        ObjectKind::SmallBox => 0.10,
    }
}

/// The mesh of `kind`, in the object frame described in the module documentation.
pub fn object_mesh(kind: ObjectKind) -> Mesh {
    let mesh = match kind {
        ObjectKind::Cube => centred(grid_box(Vector3::new(0.06, 0.06, 0.06), [6, 6, 6])),
        ObjectKind::SmallBox => centred(grid_box(Vector3::new(0.04, 0.04, 0.06), [4, 4, 6])),
        ObjectKind::Apple => centred(apple()),
        ObjectKind::FryingPan => frying_pan(),
        ObjectKind::Mug => mug(),
        ObjectKind::Teapot => teapot(),
    };
    in_order_of_first_use(mesh)
}

// ---------------------------------------------------------------------------------------
// Objects

/// Segments around the axis of every revolved body.
const AROUND: usize = 40;

fn apple() -> Mesh {
    // A sphere of radius 41 mm squashed to 78 mm height, a little wider above the equator,
    // with a 7 mm stem dimple on top and a 3 mm calyx dimple below.
    let (radius, half_height) = (0.041, 0.039);
    let n = 32;
    let profile: Vec<[f64; 2]> = (0..=n)
        .map(|i| {
            let phi = PI * i as f64 / n as f64; // 0 at the bottom pole, π at the top
            let (s, c) = phi.sin_cos();
            let r = radius * s * (1.0 - 0.06 * c);
            let top = (-((PI - phi) / 0.38).powi(2)).exp();
            let bottom = (-(phi / 0.30).powi(2)).exp();
            let z = -half_height * c - 0.007 * top + 0.003 * bottom;
            [if i == 0 || i == n { 0.0 } else { r }, z]
        })
        .collect();
    revolve(&profile, 40)
}

fn frying_pan() -> Mesh {
    // Aluminium pan: flat 200 mm base, flared wall up to a 240 mm rim 40 mm above the
    // ground, 3 mm wall and 4 mm base.
    let wall: f64 = 0.003;
    let outer = [
        [0.0, 0.0],
        [0.096, 0.0],
        [0.1015, 0.0015],
        [0.104, 0.0055],
        [0.120, 0.040],
    ];
    // The inside follows the outside, offset by the wall thickness along the normal of
    // the flared wall (slope dr/dz = 16/34.5).
    let slope: f64 = (0.120 - 0.104) / (0.040 - 0.0055);
    let offset = wall * (1.0 + slope * slope).sqrt();
    let inner = [
        [0.120 - offset, 0.040],
        [0.104 - offset + slope * 0.001, 0.0065],
        [0.1005 - offset, 0.004],
        [0.096 - offset, 0.004],
        [0.0, 0.004],
    ];
    let mut profile: Vec<[f64; 2]> = outer.to_vec();
    profile.push([0.1195, 0.0405]); // rolled rim
    profile.push([0.1185 - offset + wall, 0.0405]);
    profile.extend_from_slice(&inner);
    let body = revolve(&refine(&profile, 0.014), AROUND);

    // Handle: starts inside the wall, leaving it along the wall's outward normal, bends up
    // to 12° and runs 180 mm; flat oval section 20 x 14 mm, thicker toward the end, with a
    // rounded end.
    let z0 = 0.026;
    let r0 = 0.104 + slope * (z0 - 0.0055) - 0.5 * offset; // mid-wall radius at z0
    let start = Point3::new(r0, 0.0, z0);
    let normal_angle = -slope.atan(); // outward wall normal, below the horizontal
    let lift = 12f64.to_radians();
    let bend_radius = 0.03;
    let mut path = arc_turn(start, normal_angle, lift, bend_radius, 8);
    let last = *path.last().expect("arc has points");
    let dir = Vector3::new(lift.cos(), 0.0, lift.sin());
    let straight = 0.165;
    let n = 18;
    for i in 1..=n {
        path.push(last + dir * (straight * i as f64 / n as f64));
    }
    let m = path.len();
    let section: Vec<[f64; 2]> = (0..m)
        .map(|k| {
            let s = k as f64 / (m - 1) as f64;
            // in-plane half thickness, out-of-plane half width
            let (mut a, mut b) = (0.006 + 0.002 * s, 0.009 + 0.003 * s);
            // round the far end over its last 4 rings
            let from_end = (m - 1 - k) as f64;
            if from_end < 4.0 {
                let f = (1.0 - ((4.0 - from_end) / 4.5).powi(2)).sqrt();
                a *= f;
                b *= f;
            }
            [a, b]
        })
        .collect();
    let handle = tube(&path, &section, Vector3::y(), 16);
    union_about_body(body, vec![handle])
}

fn mug() -> Mesh {
    // Ceramic mug: 80 mm diameter, 95 mm tall, 4 mm wall, 7 mm base.
    let (ro, h, wall, base) = (0.040, 0.095, 0.004, 0.007);
    let ri = ro - wall;
    let profile = [
        [0.0, 0.0],
        [ro - 0.004, 0.0],
        [ro - 0.0012, 0.0012],
        [ro, 0.004],
        [ro, h - 0.0015],
        [ro - 0.0005, h - 0.0003],
        [ro - wall / 2.0, h],
        [ri + 0.0005, h - 0.0003],
        [ri, h - 0.0015],
        [ri, base + 0.003],
        [ri - 0.001, base + 0.001],
        [ri - 0.003, base],
        [0.0, base],
    ];
    let body = revolve(&refine(&profile, 0.014), AROUND);

    // D-shaped handle in the xz plane: short stubs leave the wall radially, joined by a
    // half-turn of radius 27 mm; flat section 9 x 14 mm. The stubs start 1.5 mm inside
    // the outer surface so the caps sit within the wall, never in the cavity.
    let path = d_handle(ro - 0.0015, 0.007, 0.079, 0.025, 14, 1.0);
    let section = vec![[0.0045, 0.007]; path.len()];
    let handle = tube(&path, &section, Vector3::y(), 16);
    union_about_body(body, vec![handle])
}

fn teapot() -> Mesh {
    // Solid body of revolution, 150 mm wide, 134 mm to the top of the lid knob.
    let profile = [
        [0.0, 0.0],
        [0.050, 0.0],
        [0.056, 0.003],
        [0.064, 0.012],
        [0.071, 0.026],
        [0.075, 0.045],
        [0.0745, 0.058],
        [0.071, 0.073],
        [0.064, 0.087],
        [0.055, 0.097],
        [0.047, 0.102],
        // lid seat and lid
        [0.045, 0.1025],
        [0.044, 0.105],
        [0.040, 0.109],
        [0.032, 0.1135],
        [0.022, 0.1165],
        [0.010, 0.118],
        // knob: neck and ball
        [0.0055, 0.1195],
        [0.0055, 0.1225],
        [0.010, 0.1255],
        [0.0115, 0.1285],
        [0.010, 0.1315],
        [0.0055, 0.1335],
        [0.0, 0.134],
    ];
    let body = revolve(&refine(&profile, 0.012), AROUND);

    // Spout: a tapered tube on a quadratic Bézier from inside the body out and up,
    // 14 mm radius at the root down to 6 mm at the tip (cut flat).
    let (p0, p1, p2) = (
        Point3::new(0.050, 0.0, 0.032),
        Point3::new(0.108, 0.0, 0.040),
        Point3::new(0.122, 0.0, 0.100),
    );
    let n = 20;
    let spout_path: Vec<Point3<f64>> = (0..=n)
        .map(|i| {
            let t = i as f64 / n as f64;
            let u = 1.0 - t;
            Point3::from(p0.coords * (u * u) + p1.coords * (2.0 * u * t) + p2.coords * (t * t))
        })
        .collect();
    let spout_section: Vec<[f64; 2]> = (0..=n)
        .map(|i| {
            let r = 0.014 - 0.008 * (i as f64 / n as f64);
            [r, r]
        })
        .collect();
    let spout = tube(&spout_path, &spout_section, Vector3::y(), 16);

    // Handle: D shape on the -x side, flat section 12 x 18 mm; its ends start 5 mm or more
    // inside the body so the end caps stay hidden.
    let handle_path = d_handle(0.052, 0.032, 0.088, 0.030, 14, -1.0);
    let handle_section = vec![[0.006, 0.009]; handle_path.len()];
    let handle = tube(&handle_path, &handle_section, Vector3::y(), 16);
    union_about_body(body, vec![spout, handle])
}

// ---------------------------------------------------------------------------------------
// Paths

/// Points of an arc in the `xz` plane starting at `start` heading at `from` [rad] above
/// the `+x` axis and turning (counter-clockwise seen from `-y`, i.e. upward) to `to`,
/// with the given radius; `n` segments. Includes `start`.
fn arc_turn(start: Point3<f64>, from: f64, to: f64, radius: f64, n: usize) -> Vec<Point3<f64>> {
    // Centre is on the left of the heading (toward +z for a heading along +x).
    let left = Vector3::new(-from.sin(), 0.0, from.cos());
    let centre = start + left * radius;
    (0..=n)
        .map(|i| {
            let a = from + (to - from) * i as f64 / n as f64;
            centre - Vector3::new(-a.sin(), 0.0, a.cos()) * radius
        })
        .collect()
}

/// A D-shaped handle path in the `xz` plane on the `side` (±1) of the `x` axis: a radial
/// stub at height `z_top` from `|x| = r_start` out by `stub`, a half turn of radius
/// `(z_top - z_bottom) / 2` with `n` segments, and a stub back at `z_bottom`.
fn d_handle(
    r_start: f64,
    stub: f64,
    z_top: f64,
    z_bottom: f64,
    n: usize,
    side: f64,
) -> Vec<Point3<f64>> {
    let radius = (z_top - z_bottom) / 2.0;
    let zc = (z_top + z_bottom) / 2.0;
    let xc = r_start + stub;
    let mut path = vec![
        Point3::new(side * r_start, 0.0, z_top),
        Point3::new(side * (r_start + stub * 0.5), 0.0, z_top),
    ];
    for i in 0..=n {
        let a = FRAC_PI_2 - PI * i as f64 / n as f64;
        path.push(Point3::new(
            side * (xc + radius * a.cos()),
            0.0,
            zc + radius * a.sin(),
        ));
    }
    path.push(Point3::new(side * (r_start + stub * 0.5), 0.0, z_bottom));
    path.push(Point3::new(side * r_start, 0.0, z_bottom));
    path
}

/// Inserts points on each profile segment so that no segment is longer than `max_len`.
fn refine(profile: &[[f64; 2]], max_len: f64) -> Vec<[f64; 2]> {
    let mut out = vec![profile[0]];
    for w in profile.windows(2) {
        let [a, b] = [w[0], w[1]];
        let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        let n = (len / max_len).ceil().max(1.0) as usize;
        for i in 1..=n {
            let t = i as f64 / n as f64;
            out.push([a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t]);
        }
    }
    out
}

// ---------------------------------------------------------------------------------------
// Closed primitives

/// Revolves the profile `[r, z]` about the `z` axis with `segments` steps. The profile's
/// first and last points must lie on the axis (`r = 0`, they become poles), the others
/// off it; traversed with the solid on its left in the `(r, z)` plane (up the outside,
/// down the inside), the result is closed and outward-wound.
fn revolve(profile: &[[f64; 2]], segments: usize) -> Mesh {
    let n = profile.len();
    assert!(n >= 3 && profile[0][0] == 0.0 && profile[n - 1][0] == 0.0);
    let rings = n - 2;
    let mut mesh = Mesh::default();
    mesh.vertices.push(Point3::new(0.0, 0.0, profile[0][1]));
    for p in &profile[1..n - 1] {
        assert!(p[0] > 0.0, "interior profile points must be off the axis");
        for j in 0..segments {
            let (s, c) = (TAU * j as f64 / segments as f64).sin_cos();
            mesh.vertices.push(Point3::new(p[0] * c, p[0] * s, p[1]));
        }
    }
    let top = mesh.vertices.len() as u32;
    mesh.vertices.push(Point3::new(0.0, 0.0, profile[n - 1][1]));
    let v = |ring: usize, j: usize| (1 + ring * segments + j % segments) as u32;
    for j in 0..segments {
        mesh.triangles.push([0, v(0, j + 1), v(0, j)]);
    }
    for i in 0..rings - 1 {
        for j in 0..segments {
            mesh.triangles.push([v(i, j), v(i, j + 1), v(i + 1, j + 1)]);
            mesh.triangles.push([v(i, j), v(i + 1, j + 1), v(i + 1, j)]);
        }
    }
    for j in 0..segments {
        mesh.triangles
            .push([v(rings - 1, j), v(rings - 1, j + 1), top]);
    }
    mesh
}

/// Sweeps an elliptical section along `path`, capped flat at both ends. `section[k]` gives
/// the half-axes at point `k`: along the in-plane normal `n` and along the binormal `b`.
/// The frame starts with `b` = `binormal_hint` made normal to the first tangent and is
/// parallel-transported (for a planar path with the hint normal to its plane, `b` stays
/// the plane normal). `(n, b, t)` is right-handed, which makes the quads outward-wound.
fn tube(
    path: &[Point3<f64>],
    section: &[[f64; 2]],
    binormal_hint: Vector3<f64>,
    segments: usize,
) -> Mesh {
    let m = path.len();
    assert!(m >= 2 && section.len() == m);
    let tangent = |k: usize| {
        let (a, b) = (path[k.saturating_sub(1)], path[(k + 1).min(m - 1)]);
        (b - a).normalize()
    };
    let mut t = tangent(0);
    let mut b = (binormal_hint - t * binormal_hint.dot(&t)).normalize();
    let mut mesh = Mesh::default();
    for k in 0..m {
        let tk = tangent(k);
        // parallel transport: rotate b by the rotation taking t to tk
        let axis = t.cross(&tk);
        if axis.norm() > 1e-12 {
            let angle = t.dot(&tk).clamp(-1.0, 1.0).acos();
            let rot =
                nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle);
            b = rot * b;
        }
        t = tk;
        b = (b - t * b.dot(&t)).normalize();
        let n = b.cross(&t);
        let [ra, rb] = section[k];
        for j in 0..segments {
            let (s, c) = (TAU * j as f64 / segments as f64).sin_cos();
            mesh.vertices.push(path[k] + n * (ra * c) + b * (rb * s));
        }
    }
    let v = |k: usize, j: usize| (k * segments + j % segments) as u32;
    for k in 0..m - 1 {
        for j in 0..segments {
            mesh.triangles.push([v(k, j), v(k, j + 1), v(k + 1, j + 1)]);
            mesh.triangles.push([v(k, j), v(k + 1, j + 1), v(k + 1, j)]);
        }
    }
    let start = mesh.vertices.len() as u32;
    mesh.vertices.push(path[0]);
    let end = start + 1;
    mesh.vertices.push(path[m - 1]);
    for j in 0..segments {
        mesh.triangles.push([start, v(0, j + 1), v(0, j)]);
        mesh.triangles.push([end, v(m - 1, j), v(m - 1, j + 1)]);
    }
    mesh
}

/// A box with corner at the origin and the given size whose faces are `div` grids
/// (`div[axis]` cells along each axis). Vertices on shared edges are shared, so the box
/// is closed.
fn grid_box(size: Vector3<f64>, div: [usize; 3]) -> Mesh {
    use std::collections::HashMap;
    let mut index: HashMap<[usize; 3], u32> = HashMap::new();
    let mut mesh = Mesh::default();
    let mut vertex = |mesh: &mut Mesh, key: [usize; 3]| -> u32 {
        *index.entry(key).or_insert_with(|| {
            mesh.vertices.push(Point3::new(
                size.x * key[0] as f64 / div[0] as f64,
                size.y * key[1] as f64 / div[1] as f64,
                size.z * key[2] as f64 / div[2] as f64,
            ));
            (mesh.vertices.len() - 1) as u32
        })
    };
    // (normal axis, at max?, u axis, v axis) with u × v pointing out of the box
    let faces = [
        (0, true, 1, 2),
        (0, false, 2, 1),
        (1, true, 2, 0),
        (1, false, 0, 2),
        (2, true, 0, 1),
        (2, false, 1, 0),
    ];
    for (axis, at_max, u, w) in faces {
        for i in 0..div[u] {
            for j in 0..div[w] {
                let key = |di: usize, dj: usize| {
                    let mut k = [0; 3];
                    k[axis] = if at_max { div[axis] } else { 0 };
                    k[u] = i + di;
                    k[w] = j + dj;
                    k
                };
                let a = vertex(&mut mesh, key(0, 0));
                let b = vertex(&mut mesh, key(1, 0));
                let c = vertex(&mut mesh, key(1, 1));
                let d = vertex(&mut mesh, key(0, 1));
                mesh.triangles.push([a, b, c]);
                mesh.triangles.push([a, c, d]);
            }
        }
    }
    mesh
}

// ---------------------------------------------------------------------------------------
// Assembly

/// Volume centroid of a closed, outward-wound mesh (sum over the tetrahedra it makes with
/// the origin).
fn centroid(mesh: &Mesh) -> Point3<f64> {
    let (mut moment, mut volume) = (Vector3::zeros(), 0.0);
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.vertices[i as usize].coords);
        let v = a.dot(&b.cross(&c)) / 6.0;
        volume += v;
        moment += (a + b + c) * (v / 4.0);
    }
    Point3::from(moment / volume)
}

fn translate(mesh: &mut Mesh, by: Vector3<f64>) {
    for p in &mut mesh.vertices {
        *p += by;
    }
}

/// Renumbers the vertices in the order the triangles first use them, which is the order
/// [`Mesh::load`] gives back from an OBJ file: a written and reloaded mesh then equals
/// the generated one index for index.
fn in_order_of_first_use(mesh: Mesh) -> Mesh {
    let mut new_index = vec![u32::MAX; mesh.vertices.len()];
    let mut out = Mesh::default();
    for t in &mesh.triangles {
        let tri = t.map(|v| {
            let slot = &mut new_index[v as usize];
            if *slot == u32::MAX {
                *slot = out.vertices.len() as u32;
                out.vertices.push(mesh.vertices[v as usize]);
            }
            *slot
        });
        out.triangles.push(tri);
    }
    out
}

/// The mesh moved so that its volume centroid is the origin.
fn centred(mut mesh: Mesh) -> Mesh {
    let c = centroid(&mesh);
    translate(&mut mesh, -c.coords);
    mesh
}

/// Concatenates `body` and `parts` (vertex indices renumbered, nothing shared) and moves
/// the result so that the body's volume centroid is the origin.
fn union_about_body(body: Mesh, parts: Vec<Mesh>) -> Mesh {
    let c = centroid(&body);
    let mut out = body;
    for part in parts {
        let offset = out.vertices.len() as u32;
        out.vertices.extend(part.vertices);
        out.triangles
            .extend(part.triangles.iter().map(|t| t.map(|i| i + offset)));
    }
    translate(&mut out, -c.coords);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;
    use std::path::Path;

    /// Splits a mesh into its vertex-connected parts (union-find over triangles).
    fn parts(mesh: &Mesh) -> Vec<Mesh> {
        let mut parent: Vec<usize> = (0..mesh.vertices.len()).collect();
        fn find(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        for t in &mesh.triangles {
            let a = find(&mut parent, t[0] as usize);
            for &v in &t[1..] {
                let b = find(&mut parent, v as usize);
                parent[b] = a;
            }
        }
        let mut groups: HashMap<usize, Mesh> = HashMap::new();
        let mut order = Vec::new();
        let mut remap: HashMap<u32, u32> = HashMap::new();
        for t in &mesh.triangles {
            let root = find(&mut parent, t[0] as usize);
            if !groups.contains_key(&root) {
                order.push(root);
            }
            let part = groups.entry(root).or_default();
            let tri = t.map(|v| {
                *remap.entry(v).or_insert_with(|| {
                    part.vertices.push(mesh.vertices[v as usize]);
                    (part.vertices.len() - 1) as u32
                })
            });
            part.triangles.push(tri);
        }
        order
            .into_iter()
            .map(|r| groups.remove(&r).expect("group"))
            .collect()
    }

    fn bbox(mesh: &Mesh) -> (Point3<f64>, Point3<f64>) {
        let mut lo = Point3::from(Vector3::repeat(f64::INFINITY));
        let mut hi = Point3::from(Vector3::repeat(f64::NEG_INFINITY));
        for p in &mesh.vertices {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        (lo, hi)
    }

    fn min_triangle_area(mesh: &Mesh) -> f64 {
        mesh.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
                (b - a).cross(&(c - a)).norm() / 2.0
            })
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn every_part_is_closed_outward_wound_and_non_degenerate() {
        let expected_parts = |k: ObjectKind| match k {
            ObjectKind::FryingPan | ObjectKind::Mug => 2,
            ObjectKind::Teapot => 3,
            _ => 1,
        };
        for kind in ObjectKind::ALL {
            let mesh = object_mesh(kind);
            let ps = parts(&mesh);
            assert_eq!(ps.len(), expected_parts(kind), "{kind}: number of parts");
            for (i, p) in ps.iter().enumerate() {
                assert!(
                    p.is_closed_and_consistently_wound(),
                    "{kind} part {i}: not closed and consistently wound"
                );
                let v = p.signed_volume();
                assert!(
                    v > 0.0,
                    "{kind} part {i}: signed volume {v} m³, expected > 0"
                );
                let a = min_triangle_area(p);
                assert!(
                    a > 1e-10,
                    "{kind} part {i}: degenerate triangle, area {a} m²"
                );
            }
            assert!(
                mesh.is_closed_and_consistently_wound(),
                "{kind}: whole mesh"
            );
            assert!(
                mesh.vertices
                    .iter()
                    .all(|p| p.coords.iter().all(|x| x.is_finite())),
                "{kind}: non-finite vertex"
            );
            assert!(
                mesh.triangles.len() <= 5000,
                "{kind}: {} triangles, keep the OBJ small",
                mesh.triangles.len()
            );
        }
    }

    #[test]
    fn sizes_are_realistic() {
        // (kind, min extent, max extent) per axis x, y, z [m]
        let cases: [(ObjectKind, [f64; 3], [f64; 3]); 6] = [
            (ObjectKind::Cube, [0.06; 3], [0.06; 3]),
            (ObjectKind::SmallBox, [0.04, 0.04, 0.06], [0.04, 0.04, 0.06]),
            (ObjectKind::Apple, [0.075, 0.075, 0.065], [0.09, 0.09, 0.08]),
            (ObjectKind::Mug, [0.10, 0.079, 0.094], [0.13, 0.081, 0.096]),
            (
                ObjectKind::FryingPan,
                [0.38, 0.239, 0.04],
                [0.44, 0.241, 0.08],
            ),
            (ObjectKind::Teapot, [0.20, 0.149, 0.13], [0.26, 0.151, 0.14]),
        ];
        for (kind, lo, hi) in cases {
            let (a, b) = bbox(&object_mesh(kind));
            let ext = b - a;
            for i in 0..3 {
                assert!(
                    ext[i] >= lo[i] - 1e-9 && ext[i] <= hi[i] + 1e-9,
                    "{kind}: extent along axis {i} is {:.4} m, expected {:.4}..{:.4}",
                    ext[i],
                    lo[i],
                    hi[i]
                );
            }
        }
    }

    #[test]
    fn origin_is_the_main_body_centroid_and_z_is_up() {
        for kind in ObjectKind::ALL {
            let mesh = object_mesh(kind);
            let body = &parts(&mesh)[0];
            let c = centroid(body);
            assert!(c.coords.norm() < 1e-9, "{kind}: body centroid at {c}");
            // resting on a table: the lowest points form the flat base (or the apple's
            // bottom), below the origin; the body is not wider than tall for the upright
            // objects
            let (lo, hi) = bbox(body);
            assert!(
                lo.z < 0.0 && hi.z > 0.0,
                "{kind}: origin not inside the body height"
            );
        }
        // the pan's base is flat and lowest; its handle rises
        let pan = object_mesh(ObjectKind::FryingPan);
        let ps = parts(&pan);
        let (body_lo, _) = bbox(&ps[0]);
        let (handle_lo, handle_hi) = bbox(&ps[1]);
        assert!(
            handle_lo.z > body_lo.z + 0.01 && handle_hi.x > 0.25,
            "pan handle spans {handle_lo}..{handle_hi}, body bottom at {}",
            body_lo.z
        );
    }

    #[test]
    fn volumes_match_the_design() {
        // closed forms where they exist
        let cube = object_mesh(ObjectKind::Cube).signed_volume();
        assert!((cube - 0.06f64.powi(3)).abs() < 1e-12, "cube volume {cube}");
        let small = object_mesh(ObjectKind::SmallBox).signed_volume();
        assert!(
            (small - 0.04 * 0.04 * 0.06).abs() < 1e-12,
            "box volume {small}"
        );
        // the mug's ceramic volume: wall + base of a 40/36 mm radius cylinder ≈ 1.3e-4 m³
        let mug_body = &parts(&object_mesh(ObjectKind::Mug))[0];
        let v = mug_body.signed_volume();
        assert!((1.0e-4..1.5e-4).contains(&v), "mug body volume {v} m³");
        // the apple: a bit less than the 4/3 π 41² 39 mm³ spheroid (dimples)
        let apple = object_mesh(ObjectKind::Apple).signed_volume();
        let spheroid = 4.0 / 3.0 * PI * 0.041 * 0.041 * 0.039;
        assert!(
            apple < spheroid * 1.02 && apple > spheroid * 0.9,
            "apple volume {apple} vs spheroid {spheroid}"
        );
    }

    #[test]
    fn names_parse_and_unknown_names_list_the_valid_ones() {
        for kind in ObjectKind::ALL {
            assert_eq!(kind.name().parse::<ObjectKind>(), Ok(kind));
            assert_eq!(kind.to_string(), kind.name());
        }
        assert_eq!("fryingpan".parse(), Ok(ObjectKind::FryingPan));
        assert_eq!("Frying-Pan".parse(), Ok(ObjectKind::FryingPan));
        let err = "spoon".parse::<ObjectKind>().unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("spoon") && msg.contains("frying_pan") && msg.contains("small_box"));
    }

    #[test]
    #[ignore = "prints statistics"]
    fn print_stats() {
        for kind in ObjectKind::ALL {
            let mesh = object_mesh(kind);
            let (a, b) = bbox(&mesh);
            println!(
                "{kind}: {} vertices, {} triangles, bbox {:.4?}..{:.4?}, volume {:.3e} m³, parts {}",
                mesh.vertices.len(),
                mesh.triangles.len(),
                a.coords.as_slice(),
                b.coords.as_slice(),
                mesh.signed_volume(),
                parts(&mesh).len()
            );
        }
    }

    #[test]
    fn masses_are_realistic() {
        for kind in ObjectKind::ALL {
            let m = object_mass_kg(kind);
            assert!((0.05..=1.5).contains(&m), "{kind}: {m} kg");
        }
    }

    #[test]
    fn output_is_deterministic() {
        for kind in ObjectKind::ALL {
            assert_eq!(object_mesh(kind), object_mesh(kind), "{kind}");
            assert_eq!(
                object_mesh(kind).to_obj_string(),
                object_mesh(kind).to_obj_string()
            );
        }
    }

    #[test]
    fn obj_round_trip_keeps_every_part_closed() {
        let dir = tempfile::tempdir().expect("temp dir");
        for kind in ObjectKind::ALL {
            let path = dir.path().join(format!("{}.obj", kind.name()));
            let mesh = object_mesh(kind);
            mesh.write_obj(&path).expect("write");
            let back =
                Mesh::load(&path, Vector3::repeat(1.0), &crate::Limits::default()).expect("load");
            assert_eq!(back.triangles.len(), mesh.triangles.len(), "{kind}");
            assert!(back.is_closed_and_consistently_wound(), "{kind}");
            let (vb, vm) = (back.signed_volume(), mesh.signed_volume());
            assert!(
                (vb - vm).abs() < 1e-4 * vm,
                "{kind}: volume {vb} after the round trip, {vm} before"
            );
        }
    }

    /// The committed OBJ files are what the generator makes today (to the micrometre the
    /// OBJ text keeps, so that a last-bit difference in `sin` between C libraries does not
    /// fail the test).
    #[test]
    fn committed_objs_are_up_to_date() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/objects");
        for kind in ObjectKind::ALL {
            let path = dir.join(format!("{}.obj", kind.name()));
            let stale = format!(
                "{} is stale: run `cargo test --lib write_scene_objs -- --ignored`",
                path.display()
            );
            let committed = Mesh::load(&path, Vector3::repeat(1.0), &crate::Limits::default())
                .unwrap_or_else(|e| panic!("{e}; {stale}"));
            let fresh = object_mesh(kind);
            assert!(
                committed.triangles == fresh.triangles,
                "{stale} (triangles differ)"
            );
            let worst = committed
                .vertices
                .iter()
                .zip(&fresh.vertices)
                .map(|(a, b)| (a - b).amax())
                .fold(0.0, f64::max);
            assert!(
                committed.vertices.len() == fresh.vertices.len() && worst < 2e-6,
                "{stale} (largest vertex difference {worst} m)"
            );
        }
    }

    /// Writes `scenes/objects/<name>.obj` for every object (until the CLI does it).
    #[test]
    #[ignore = "writes into the repository"]
    fn write_scene_objs() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/objects");
        std::fs::create_dir_all(&dir).expect("create scenes/objects");
        for kind in ObjectKind::ALL {
            object_mesh(kind)
                .write_obj(&dir.join(format!("{}.obj", kind.name())))
                .expect("write obj");
        }
    }

    /// The robots of `robots/` parse with urdf-rs and load through [`crate::robot::Robot`].
    #[test]
    fn robot_urdfs_load() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("robots");
        for (file, root, dof, joints) in [
            ("human_hand.urdf", "palm", 20, 25),
            ("allegro_hand.urdf", "palm", 16, 20),
            ("parallel_gripper.urdf", "hand", 1, 3),
        ] {
            let path = dir.join(file);
            let urdf = urdf_rs::read_file(&path).expect(file);
            assert_eq!(urdf.joints.len(), joints, "{file}");
            let robot = crate::robot::Robot::from_urdf_file(&path, &crate::Limits::default())
                .unwrap_or_else(|e| panic!("{file}: {e}"));
            assert_eq!(robot.dof(), dof, "{file}");
            assert_eq!(robot.link(robot.root()).name, root, "{file}");
        }
    }

    /// Frame conventions of `robots/README.md`, checked through the crate's own FK against
    /// values computed independently when the hands were designed: fingers point +z and
    /// curl toward +x (palm side), the thumb sits toward +y and opposes the fingers.
    #[test]
    fn robot_frames_follow_the_conventions() {
        use crate::robot::Robot;
        use nalgebra::Isometry3;
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("robots");
        let load =
            |f: &str| Robot::from_urdf_file(&dir.join(f), &crate::Limits::default()).unwrap();
        let pose = |robot: &Robot, q: &[(&str, f64)], link: &str| -> Isometry3<f64> {
            let mut qv = vec![0.0; robot.dof()];
            for (name, v) in q {
                qv[robot.actuated_index(name).expect(name)] = *v;
            }
            let mut poses = robot.new_link_poses();
            robot.forward_kinematics(&Isometry3::identity(), &qv, &mut poses);
            poses[robot.link_id(link).expect(link).index()]
        };
        let close = |a: Vector3<f64>, b: [f64; 3], what: &str| {
            let d = (a - Vector3::from(b)).norm();
            assert!(d < 2e-4, "{what}: {a:?}, expected {b:?} (off by {d} m)");
        };

        let human = load("human_hand.urdf");
        close(
            pose(&human, &[], "index_tip").translation.vector,
            [0.0008, 0.03128, 0.16784],
            "index tip, zero",
        );
        close(
            pose(&human, &[], "thumb_tip").translation.vector,
            [0.065, 0.06534, 0.10608],
            "thumb tip, zero",
        );
        let flexed = [
            ("index_mcp_flex", 1.57),
            ("index_pip_flex", 1.9),
            ("index_dip_flex", 1.4),
        ];
        close(
            pose(&human, &flexed, "index_tip").translation.vector,
            [0.0226, 0.02466, 0.05766],
            "index tip, flexed",
        );
        // thumb-index pulp pinch: pad points (tip + radius along the pad normal +x) meet
        // and the pad normals face each other
        let pinch = [
            ("thumb_cmc_abd", 0.26),
            ("thumb_cmc_flex", 0.49),
            ("thumb_mcp_flex", -0.17),
            ("thumb_ip_flex", -0.26),
            ("index_mcp_abd", -0.35),
            ("index_mcp_flex", 0.87),
            ("index_pip_flex", 0.2),
            ("index_dip_flex", 0.4),
        ];
        let (t, i) = (
            pose(&human, &pinch, "thumb_tip"),
            pose(&human, &pinch, "index_tip"),
        );
        let (nt, ni) = (t.rotation * Vector3::x(), i.rotation * Vector3::x());
        let gap =
            ((t.translation.vector + nt * 0.0088) - (i.translation.vector + ni * 0.0075)).norm();
        assert!(
            gap < 0.003 && nt.dot(&ni) < -0.6,
            "pinch: gap {gap} m, normals {}",
            nt.dot(&ni)
        );

        let allegro = load("allegro_hand.urdf");
        let tip = pose(
            &allegro,
            &[("index_joint_1", 1.2), ("index_joint_2", 1.2)],
            "index_tip",
        );
        assert!(
            tip.translation.x > 0.05,
            "allegro index curls toward +x: {tip}"
        );
        assert!(
            pose(&allegro, &[], "thumb_tip").translation.y > 0.1,
            "allegro thumb at +y"
        );

        let gripper = load("parallel_gripper.urdf");
        let open = [("finger_joint1", 0.04)];
        close(
            pose(&gripper, &open, "left_finger").translation.vector,
            [0.0, 0.04, 0.0584],
            "left jaw",
        );
        close(
            pose(&gripper, &open, "right_finger").translation.vector,
            [0.0, -0.04, 0.0584],
            "right jaw",
        );
        close(
            pose(&gripper, &[], "tcp").translation.vector,
            [0.0, 0.0, 0.1034],
            "tcp",
        );
    }
}
