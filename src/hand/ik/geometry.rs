//! Obstacles of the IK: barrier shapes in the world and the object's signed distance field,
//! with the culling that keeps the barrier and penetration terms cheap (bounding spheres per
//! link, AABBs per barrier, probe clusters against the object field).

use nalgebra::{Isometry3, Point3, Vector3};
use rapier3d_f64::parry::math::Pose;

use crate::geometry::ObjectSdf;
use crate::math::convert::{from_point, from_vec, to_point, to_pose};
use crate::robot::{CollisionShape, LinkId, Robot, WRIST_DOF};

/// An obstacle prepared for point queries: parry pose and bounding volumes (world).
#[derive(Clone, Debug)]
pub(super) struct Obstacle {
    pub(super) pose: Pose,
    pub(super) mins: Vector3<f64>,
    pub(super) maxs: Vector3<f64>,
    pub(super) center: Vector3<f64>,
    pub(super) radius: f64,
}

impl Obstacle {
    pub(super) fn new(shape: &CollisionShape, world_from_shape: &Isometry3<f64>) -> Obstacle {
        let pose = to_pose(world_from_shape);
        let aabb = shape.shape.compute_aabb(&pose);
        let (mins, maxs) = (from_vec(aabb.mins), from_vec(aabb.maxs));
        Obstacle {
            pose,
            mins,
            maxs,
            center: (mins + maxs) / 2.0,
            radius: (maxs - mins).norm() / 2.0,
        }
    }

    /// Distance from `p` to the AABB (0 inside): a lower bound of the SDF.
    #[inline]
    pub(super) fn aabb_distance(&self, p: &Point3<f64>) -> f64 {
        let d = (self.mins - p.coords)
            .sup(&(p.coords - self.maxs))
            .sup(&Vector3::zeros());
        d.norm()
    }

    /// Signed distance and its gradient (unit, pointing out) at `p`.
    #[inline]
    pub(super) fn sdf(&self, shape: &CollisionShape, p: &Point3<f64>) -> (f64, Vector3<f64>) {
        let proj = shape.shape.project_point(&self.pose, to_point(p), false);
        let diff = p - from_point(proj.point);
        let d = diff.norm();
        let sign = if proj.is_inside { -1.0 } else { 1.0 };
        let grad = if d > 1e-12 {
            diff * (sign / d)
        } else {
            (p.coords - self.center)
                .try_normalize(1e-12)
                .unwrap_or_else(Vector3::z)
        };
        (sign * d, grad)
    }
}

/// Immutable per-solver geometry: the robot, link bounding spheres, non-zero Jacobian
/// columns of each link, barriers.
#[derive(Debug)]
pub(super) struct Geometry<'a> {
    pub(super) robot: &'a Robot,
    pub(super) barriers: &'a [CollisionShape],
    pub(super) barrier_obstacles: Vec<Obstacle>,
    pub(super) object: Option<&'a ObjectSdf>,
    /// Per link: bounding sphere of its penetration probes (link frame); radius < 0 when none.
    pub(super) probe_spheres: Vec<(Point3<f64>, f64)>,
    /// Per link: bounding sphere of its surface points (link frame); radius < 0 when none.
    pub(super) spheres: Vec<(Point3<f64>, f64)>,
    /// Per link: range into `col_idx`.
    pub(super) col_range: Vec<(usize, usize)>,
    /// Non-zero Jacobian columns of each link, ascending: the wrist's 6, then its chain.
    pub(super) col_idx: Vec<usize>,
}

impl<'a> Geometry<'a> {
    pub(super) fn new(
        robot: &'a Robot,
        barriers: &'a [CollisionShape],
        object: Option<&'a ObjectSdf>,
    ) -> Self {
        let mut spheres = Vec::with_capacity(robot.link_count());
        let mut col_range = Vec::with_capacity(robot.link_count());
        let mut col_idx = Vec::new();
        for (l, link) in robot.links().iter().enumerate() {
            let pts = &link.surface_points;
            if pts.is_empty() {
                spheres.push((Point3::origin(), -1.0));
            } else {
                let (lo, hi) = pts.iter().fold(
                    (
                        Vector3::repeat(f64::INFINITY),
                        Vector3::repeat(f64::NEG_INFINITY),
                    ),
                    |(lo, hi), p| (lo.inf(&p.coords), hi.sup(&p.coords)),
                );
                let c = Point3::from((lo + hi) / 2.0);
                let r = pts.iter().map(|p| (p - c).norm()).fold(0.0, f64::max);
                spheres.push((c, r));
            }
            let start = col_idx.len();
            let mut cols: Vec<usize> = (0..WRIST_DOF).collect();
            for &j in robot.chain(LinkId(l as u32)) {
                let joint = robot.joint(j);
                if let Some(d) = joint.dof {
                    cols.push(WRIST_DOF + d);
                } else if let Some(m) = &joint.mimic {
                    cols.push(WRIST_DOF + m.driver);
                }
            }
            cols.sort_unstable();
            cols.dedup();
            col_idx.extend_from_slice(&cols);
            col_range.push((start, col_idx.len()));
        }
        let barrier_obstacles = barriers
            .iter()
            .map(|b| Obstacle::new(b, &b.shape_pose))
            .collect();
        let probe_spheres = robot
            .links()
            .iter()
            .map(|l| l.probes.bounding_sphere())
            .collect();
        Geometry {
            robot,
            barriers,
            barrier_obstacles,
            object,
            probe_spheres,
            spheres,
            col_range,
            col_idx,
        }
    }

    #[inline]
    pub(super) fn cols(&self, link: usize) -> &[usize] {
        let (a, b) = self.col_range[link];
        &self.col_idx[a..b]
    }

    /// Calls `f(link, p, sdf, ∇sdf)` for every hand surface point whose SDF to `obstacle`
    /// is below `reach`.
    pub(super) fn near_points(
        &self,
        poses: &[Isometry3<f64>],
        shape: &CollisionShape,
        obstacle: &Obstacle,
        reach: f64,
        mut f: impl FnMut(usize, &Point3<f64>, f64, &Vector3<f64>),
    ) {
        for (l, link) in self.robot.links().iter().enumerate() {
            let (c, r) = self.spheres[l];
            if r < 0.0 {
                continue;
            }
            let cw = poses[l] * c;
            if (cw.coords - obstacle.center).norm() - r - obstacle.radius > reach {
                continue;
            }
            for s in &link.surface_points {
                let p = poses[l] * s;
                if obstacle.aabb_distance(&p) > reach {
                    continue;
                }
                let (d, grad) = obstacle.sdf(shape, &p);
                if d < reach {
                    f(l, &p, d, &grad);
                }
            }
        }
    }

    /// Smallest SDF from any hand surface point to any barrier [m] (branch and bound on
    /// the bounding volumes); `None` without barriers.
    pub(super) fn min_clearance(&self, poses: &[Isometry3<f64>]) -> Option<f64> {
        if self.barriers.is_empty() {
            return None;
        }
        let mut best = f64::INFINITY;
        for (shape, obstacle) in self.barriers.iter().zip(&self.barrier_obstacles) {
            for (l, link) in self.robot.links().iter().enumerate() {
                let (c, r) = self.spheres[l];
                if r < 0.0 {
                    continue;
                }
                let cw = poses[l] * c;
                if (cw.coords - obstacle.center).norm() - r - obstacle.radius >= best {
                    continue;
                }
                for s in &link.surface_points {
                    let p = poses[l] * s;
                    if obstacle.aabb_distance(&p) >= best {
                        continue;
                    }
                    best = best.min(obstacle.sdf(shape, &p).0);
                }
            }
        }
        Some(best)
    }

    /// Calls `f(link, c, depth, ∇φ)` for every penetration probe deeper than `active` [m] in
    /// the object (`object_from_world` maps world to object frame): `c` is the probe centre
    /// (world), `depth = r − φ(c)`, `∇φ` the field's gradient in the world frame.
    pub(super) fn active_probes(
        &self,
        sdf: &ObjectSdf,
        poses: &[Isometry3<f64>],
        object_from_world: &Isometry3<f64>,
        active: f64,
        mut f: impl FnMut(usize, &Point3<f64>, f64, &Vector3<f64>),
    ) {
        let world_from_object = object_from_world.inverse();
        for (l, link) in self.robot.links().iter().enumerate() {
            let (c, r) = self.probe_spheres[l];
            if r < 0.0 {
                continue;
            }
            let to_object = object_from_world * poses[l];
            if r - sdf.distance(&(to_object * c)) <= active {
                continue;
            }
            for cluster in &link.probes.clusters {
                if cluster.radius - sdf.distance(&(to_object * cluster.center)) <= active {
                    continue;
                }
                for p in link.probes.of(cluster) {
                    let local = to_object * p.point;
                    let (phi, grad) = sdf.distance_and_gradient(&local);
                    let depth = p.radius - phi;
                    if depth > active {
                        let world = poses[l] * p.point;
                        f(l, &world, depth, &(world_from_object.rotation * grad));
                    }
                }
            }
        }
    }
}
