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
//!   `r(1 − cos(s/2r))` (0.4 mm for an 8 mm finger). And balls inside: the interior on a
//!   grid (3 mm, or a third of the thinnest extent), each point with its distance to the
//!   surface as radius ([`inner_balls`]), so a wall thinner than the surface points' spacing
//!   (a 2 mm box wall) cannot pass through the shape's core between them unseen.
//!
//! A link's probes are the leaves of a bounding-sphere tree (a median split along the
//! longest axis of each node's box, at most [`LEAF_SIZE`] probes per leaf), so a query asks
//! `φ` at a node's centre first: since `φ` is 1-Lipschitz, no probe under the node can be
//! deeper than `R_node − φ(centre)`. A finger away from the object costs one query, a palm
//! touching it only the queries of the patches that touch.

use nalgebra::{Isometry3, Point3, Vector3};

use crate::geometry::shape::{CollisionShape, ShapeKind, SurfaceSampling};
use crate::geometry::{ObjectSdf, SphereTree};

/// Largest distance between neighbouring probes on a capsule's axis [m].
pub const AXIS_SPACING_M: f64 = 0.002;
/// Spacing of surface probes on boxes, cylinders and meshes [m].
pub const SURFACE_SPACING_M: f64 = 0.005;
/// Spacing of the inner balls of boxes, cylinders and meshes [m] ([`inner_balls`]).
pub const INNER_SPACING_M: f64 = 0.003;
/// Most inner grid points of one shape.
const MAX_INNER_PROBES: usize = 300;
/// Smallest inner ball [m].
const MIN_INNER_RADIUS_M: f64 = 0.0015;
/// Most probes in a leaf of a link's probe tree.
pub const LEAF_SIZE: usize = 4;
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

/// The penetration probes of one link and their tree.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Probes {
    pub probes: Vec<Probe>,
    /// Bounding-sphere tree of the probe balls (leaves of at most [`LEAF_SIZE`]).
    pub tree: SphereTree,
}

impl Probes {
    /// The probes of a link with these collision shapes (link frame).
    pub fn of_shapes(shapes: &[CollisionShape]) -> Probes {
        let mut probes = Vec::new();
        for shape in shapes {
            match shape.kind {
                ShapeKind::Capsule { radius, length } => {
                    let n = (length / AXIS_SPACING_M).ceil().max(0.0) as usize;
                    for k in 0..=n {
                        let z = if n == 0 {
                            0.0
                        } else {
                            -length / 2.0 + length * k as f64 / n as f64
                        };
                        probes.push(Probe {
                            point: shape.origin * Point3::new(0.0, 0.0, z),
                            radius,
                        });
                    }
                }
                ShapeKind::Sphere { radius } => probes.push(Probe {
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
                    probes.extend(points.into_iter().map(|point| Probe { point, radius: 0.0 }));
                    inner_balls(shape, &mut probes);
                }
            }
        }
        let centres: Vec<Point3<f64>> = probes.iter().map(|p| p.point).collect();
        let tree = SphereTree::new(&centres, |i| probes[i].radius, LEAF_SIZE);
        Probes { probes, tree }
    }

    /// Calls `f(probe, φ, ∇φ)` (object frame) for every probe deeper than `active` [m] in
    /// the object, `r − φ(c) > active`, in the tree's leaf order; `to_object` maps the link
    /// frame to the object frame. A subtree whose sphere cannot reach that depth costs one
    /// query.
    #[inline]
    pub fn visit_deeper(
        &self,
        sdf: &ObjectSdf,
        to_object: &Isometry3<f64>,
        active: f64,
        mut f: impl FnMut(&Probe, f64, &Vector3<f64>),
    ) {
        self.tree.visit(
            |node| node.radius - sdf.distance(&(to_object * node.center)) <= active,
            |leaf| {
                for &i in leaf {
                    let p = &self.probes[i as usize];
                    let (phi, grad) = sdf.distance_and_gradient(&(to_object * p.point));
                    if p.radius - phi > active {
                        f(p, phi, &grad);
                    }
                }
            },
        );
    }
}

/// Balls inside a box, cylinder or mesh: its interior sampled on a grid of
/// [`INNER_SPACING_M`] or a third of its thinnest extent, whichever is larger (coarser still
/// for a large shape: at most [`MAX_INNER_PROBES`] points), each point a ball as large as
/// its distance to the shape's surface (those under half the spacing, or
/// [`MIN_INNER_RADIUS_M`], left out: the surface points stand for them). Surface points alone let a wall thinner than their
/// spacing cut through the shape between them unseen; a wall through the interior comes
/// within reach of some ball.
fn inner_balls(shape: &CollisionShape, probes: &mut Vec<Probe>) {
    let corners = shape.hull_points();
    let (lo, hi) = corners.iter().fold(
        (
            Vector3::repeat(f64::INFINITY),
            Vector3::repeat(f64::NEG_INFINITY),
        ),
        |(lo, hi), p| (lo.inf(&p.coords), hi.sup(&p.coords)),
    );
    let size = hi - lo;
    if !size.iter().all(|s| s.is_finite()) {
        return;
    }
    // An odd count along each axis, so the grid has the shape's middle planes; spacing a
    // third of the thinnest extent at least, coarser until the count is bounded.
    let cells = |h: f64| size.map(|s| 2 * (s / (2.0 * h)).floor() as usize + 1);
    let mut h = INNER_SPACING_M.max(size.min() / 3.0);
    while cells(h).iter().product::<usize>() > MAX_INNER_PROBES {
        h *= 1.25;
    }
    let n = cells(h);
    let min_radius = MIN_INNER_RADIUS_M.max(h / 2.0);
    let start = lo + (size - (n - Vector3::repeat(1)).cast::<f64>() * h) / 2.0;
    for i in 0..n.x {
        for j in 0..n.y {
            for k in 0..n.z {
                let point = Point3::from(start + Vector3::new(i as f64, j as f64, k as f64) * h);
                let radius = shape.depth_of(&point);
                if radius >= min_radius {
                    probes.push(Probe { point, radius });
                }
            }
        }
    }
}

/// The deepest probe of the hand at `link_poses` (world) in the object whose frame is
/// `object_from_world`: `(depth [m], link)`, or `None` when no probe is deeper than 0.
/// Branch and bound on each link's probe tree (`φ` is 1-Lipschitz), the deeper-looking
/// child first, so a hand far from the object costs one query per link and a hand touching
/// it little more than the leaves that hold the deepest probes.
pub fn deepest(
    robot: &super::Robot,
    link_poses: &[Isometry3<f64>],
    object_from_world: &Isometry3<f64>,
    sdf: &ObjectSdf,
) -> Option<(f64, super::LinkId)> {
    // Minimizes φ(c) − r = −depth; `best` starts at 0, so only probes deeper than 0 count.
    let mut best = 0.0;
    let mut link = None;
    for (l, links) in robot.links().iter().enumerate() {
        let probes = &links.probes;
        let to_object = object_from_world * link_poses[l];
        best = probes.tree.minimize(
            best,
            |node| sdf.distance(&(to_object * node.center)) - node.radius,
            |leaf, best| {
                for &i in leaf {
                    let p = &probes.probes[i as usize];
                    let v = sdf.distance(&(to_object * p.point)) - p.radius;
                    if v < *best {
                        *best = v;
                        link = Some(super::LinkId(l as u32));
                    }
                }
            },
        );
    }
    link.map(|l| (-best, l))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::SdfParams;
    use crate::robot::LinkId;
    use crate::synth::objects::{ObjectKind, object_mesh};
    use nalgebra::{Translation3, UnitQuaternion};

    /// The tree queries give what a query of every probe gives: the same probes deeper than
    /// the threshold (in leaf order) and the same deepest probe, on the human hand at poses
    /// that put the palm and fingers in, at and away from the apple.
    #[test]
    fn tree_queries_match_every_probe() {
        let robot = crate::robot::test_human_hand();
        let sdf = ObjectSdf::new(object_mesh(ObjectKind::Apple), &SdfParams::default()).unwrap();
        let mut q = robot.neutral_q();
        for (i, v) in q.iter_mut().enumerate() {
            *v += 0.3 * ((i % 3) as f64);
        }
        robot.clamp(&mut q);
        let mut poses = robot.new_link_poses();
        let mut hits = 0;
        for k in 0..40 {
            let s = k as f64 / 40.0;
            let wrist = Isometry3::from_parts(
                Translation3::new(0.12 * (s - 0.5), 0.08 * (3.0 * s).sin(), 0.03 - 0.1 * s),
                UnitQuaternion::from_euler_angles(2.0 * s, -s, 0.5 * s),
            );
            robot.forward_kinematics(&wrist, &q, &mut poses);
            let object_from_world = Isometry3::identity();
            let mut every: Option<(f64, LinkId)> = None;
            for (l, link) in robot.links().iter().enumerate() {
                let to_object = object_from_world * poses[l];
                for active in [0.0, 5e-4, 3e-3] {
                    let expected: Vec<Point3<f64>> = link
                        .probes
                        .tree
                        .order
                        .iter()
                        .map(|&i| &link.probes.probes[i as usize])
                        .filter(|p| p.radius - sdf.distance(&(to_object * p.point)) > active)
                        .map(|p| p.point)
                        .collect();
                    let mut found = Vec::new();
                    link.probes
                        .visit_deeper(&sdf, &to_object, active, |p, _, _| found.push(p.point));
                    assert_eq!(found, expected, "link {l}, pose {k}, threshold {active}");
                    hits += found.len();
                }
                for p in &link.probes.probes {
                    let depth = p.radius - sdf.distance(&(to_object * p.point));
                    if depth > every.map_or(0.0, |(d, _)| d) {
                        every = Some((depth, LinkId(l as u32)));
                    }
                }
            }
            assert_eq!(
                deepest(&robot, &poses, &object_from_world, &sdf),
                every,
                "pose {k}"
            );
        }
        assert!(hits > 100, "the poses must put probes in the apple: {hits}");
    }

    /// Every probe is in exactly one leaf, and every node's sphere holds its probes' balls.
    #[test]
    fn tree_covers_every_probe_once() {
        let robot = crate::robot::test_human_hand();
        for link in robot.links() {
            let (t, probes) = (&link.probes.tree, &link.probes.probes);
            let mut sorted = t.order.clone();
            sorted.sort_unstable();
            assert_eq!(
                sorted,
                (0..probes.len() as u32).collect::<Vec<_>>(),
                "{}",
                link.name
            );
            for (i, n) in t.nodes.iter().enumerate() {
                // The probes under node i: walk its subtree.
                let mut stack = vec![i];
                while let Some(j) = stack.pop() {
                    let m = &t.nodes[j];
                    if m.is_leaf() {
                        assert!(m.end - m.start <= LEAF_SIZE as u32);
                        for &k in &t.order[m.start as usize..m.end as usize] {
                            let p = &probes[k as usize];
                            assert!((p.point - n.center).norm() + p.radius <= n.radius + 1e-12);
                        }
                    } else {
                        stack.extend([j + 1, m.end as usize]);
                    }
                }
            }
        }
    }
}
