//! Penetration probes: where a link's collision geometry is tested against the object's
//! signed distance field (the IK's non-penetration term and the physics replay's
//! hand-object penetration check use the same probes, so they measure the same thing).
//!
//! A probe is a point `c` (link frame) with a radius `r`: the ball `B(c, r)` lies inside the
//! link's geometry, and the link penetrates the object by `max_probes (r − φ(c))` where `φ`
//! is the object's signed distance:
//! - capsule: its axis sampled every [`AXIS_SPACING_M`] or less, radius = the capsule's (the
//!   capsule is exactly the union of such balls along the axis; between two axis samples
//!   the depth is missed by at most `s²/8r` against a sharp object edge, 0.06 mm for
//!   `s` = 2 mm and a 8 mm finger, and not at all against a flat or convex face);
//! - sphere: its centre, its radius;
//! - box, cylinder, mesh: surface points every [`SURFACE_SPACING_M`] (5 mm), radius 0; a
//!   flat face pressed onto a convex object of curvature radius `R` hides at most `s²/8R`
//!   of depth between points (0.3 mm for `R` = 1 cm), a cylinder of radius `r` at most
//!   `r(1 − cos(s/2r))` (0.4 mm for an 8 mm finger).
//!
//! Probes are grouped in clusters of at most [`CLUSTER_SIZE`] neighbours with a bounding
//! radius, so a query first asks `φ` at a cluster's centre: since `φ` is 1-Lipschitz, no
//! probe of the cluster can be deeper than `R_cluster − φ(centre)`.

use nalgebra::Point3;

use super::shape::{CollisionShape, ShapeKind, SurfaceSampling};

/// Largest distance between neighbouring probes on a capsule's axis [m].
pub const AXIS_SPACING_M: f64 = 0.002;
/// Spacing of surface probes on boxes, cylinders and meshes [m].
pub const SURFACE_SPACING_M: f64 = 0.005;
/// Probes per cluster.
pub const CLUSTER_SIZE: usize = 16;
/// Most surface probes on one shape (a large mesh is sampled more coarsely).
const MAX_SURFACE_PROBES: usize = 4000;

/// One probe: the ball `B(point, radius)` lies inside the link's geometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Probe {
    /// Centre, link frame [m].
    pub point: Point3<f64>,
    /// Radius [m].
    pub radius: f64,
}

/// Consecutive probes with a bounding sphere: every probe ball lies inside
/// `B(center, radius)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeCluster {
    /// Centre, link frame [m].
    pub center: Point3<f64>,
    /// Bounding radius [m], probe radii included.
    pub radius: f64,
    /// Range of the cluster's probes in [`Probes::probes`].
    pub start: u32,
    pub end: u32,
}

/// The penetration probes of one link.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Probes {
    pub probes: Vec<Probe>,
    pub clusters: Vec<ProbeCluster>,
}

impl Probes {
    /// The probes of a link with these collision shapes (link frame).
    pub fn of_shapes(shapes: &[CollisionShape]) -> Probes {
        let mut out = Probes::default();
        for shape in shapes {
            let first = out.probes.len();
            match shape.kind {
                ShapeKind::Capsule { radius, length } => {
                    let n = (length / AXIS_SPACING_M).ceil().max(0.0) as usize;
                    for k in 0..=n {
                        let z = if n == 0 {
                            0.0
                        } else {
                            -length / 2.0 + length * k as f64 / n as f64
                        };
                        out.probes.push(Probe {
                            point: shape.origin * Point3::new(0.0, 0.0, z),
                            radius,
                        });
                    }
                }
                ShapeKind::Sphere { radius } => out.probes.push(Probe {
                    point: shape.origin * Point3::origin(),
                    radius,
                }),
                _ => {
                    let sampling = SurfaceSampling {
                        spacing: SURFACE_SPACING_M,
                        max_per_shape: MAX_SURFACE_PROBES,
                    };
                    let (mut points, mut normals) = (Vec::new(), Vec::new());
                    shape.sample_surface(&sampling, &mut points, &mut normals);
                    out.probes
                        .extend(points.into_iter().map(|point| Probe { point, radius: 0.0 }));
                }
            }
            // Clusters never span two shapes.
            let mut start = first;
            while start < out.probes.len() {
                let end = (start + CLUSTER_SIZE).min(out.probes.len());
                let chunk = &out.probes[start..end];
                let center = Point3::from(
                    chunk
                        .iter()
                        .map(|p| p.point.coords)
                        .sum::<nalgebra::Vector3<f64>>()
                        / chunk.len() as f64,
                );
                let radius = chunk
                    .iter()
                    .map(|p| (p.point - center).norm() + p.radius)
                    .fold(0.0, f64::max);
                out.clusters.push(ProbeCluster {
                    center,
                    radius,
                    start: start as u32,
                    end: end as u32,
                });
                start = end;
            }
        }
        out
    }

    /// The probes of one cluster.
    #[inline]
    pub fn of(&self, c: &ProbeCluster) -> &[Probe] {
        &self.probes[c.start as usize..c.end as usize]
    }

    /// Bounding sphere of all clusters (link frame); radius < 0 when there are none.
    pub fn bounding_sphere(&self) -> (Point3<f64>, f64) {
        if self.clusters.is_empty() {
            return (Point3::origin(), -1.0);
        }
        let center = Point3::from(
            self.clusters
                .iter()
                .map(|c| c.center.coords)
                .sum::<nalgebra::Vector3<f64>>()
                / self.clusters.len() as f64,
        );
        let radius = self
            .clusters
            .iter()
            .map(|c| (c.center - center).norm() + c.radius)
            .fold(0.0, f64::max);
        (center, radius)
    }
}

/// The deepest probe of the hand at `link_poses` (world) in the object whose frame is
/// `object_from_world`: `(depth [m], link)`, or `None` when no probe is deeper than 0.
/// Branch and bound on link and cluster spheres (`φ` is 1-Lipschitz), so a hand far from
/// the object costs one query per link.
pub fn deepest(
    robot: &super::Robot,
    link_poses: &[nalgebra::Isometry3<f64>],
    object_from_world: &nalgebra::Isometry3<f64>,
    sdf: &crate::geometry::ObjectSdf,
) -> Option<(f64, super::LinkId)> {
    let mut best: Option<(f64, super::LinkId)> = None;
    let floor = |b: &Option<(f64, super::LinkId)>| b.map_or(0.0, |(d, _)| d);
    for (l, link) in robot.links().iter().enumerate() {
        let (c, r) = link.probes.bounding_sphere();
        if r < 0.0 {
            continue;
        }
        let to_object = object_from_world * link_poses[l];
        if r - sdf.distance(&(to_object * c)) <= floor(&best) {
            continue;
        }
        for cluster in &link.probes.clusters {
            if cluster.radius - sdf.distance(&(to_object * cluster.center)) <= floor(&best) {
                continue;
            }
            for p in link.probes.of(cluster) {
                let depth = p.radius - sdf.distance(&(to_object * p.point));
                if depth > floor(&best) {
                    best = Some((depth, super::LinkId(l as u32)));
                }
            }
        }
    }
    best
}
