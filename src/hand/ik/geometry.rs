//! Obstacles of the IK: barrier shapes in the world and the object's signed distance field,
//! with the culling that keeps the barrier and penetration terms cheap (bounding spheres per
//! link, AABBs per barrier, each link's probe tree against the object field).

use nalgebra::{Isometry3, Point3, Vector3};
use rapier3d_f64::parry::math::Pose;

use crate::geometry::shape::CollisionShape;
use crate::geometry::{ObjectSdf, SphereTree};
use crate::math::convert::{from_point, from_vec, to_point, to_pose};
use crate::robot::{LinkId, Robot, WRIST_DOF};

/// Most surface points in a leaf of a link's surface tree.
const SURFACE_LEAF_SIZE: usize = 8;

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
    /// Per link: the tree of its surface points (link frame); its root is the link's
    /// bounding sphere.
    pub(super) surface_trees: Vec<SphereTree>,
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
        let mut col_range = Vec::with_capacity(robot.link_count());
        let mut col_idx = Vec::new();
        for l in 0..robot.link_count() {
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
        let surface_trees = robot
            .links()
            .iter()
            .map(|l| SphereTree::new(&l.surface_points, |_| 0.0, SURFACE_LEAF_SIZE))
            .collect();
        let barrier_obstacles = barriers
            .iter()
            .map(|b| Obstacle::new(b, &b.shape_pose))
            .collect();
        Geometry {
            robot,
            barriers,
            barrier_obstacles,
            object,
            surface_trees,
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
    /// is below `reach`, link by link and in each link's point order. A link's tree of
    /// surface points skips the subtrees whose box distance is beyond `reach`; `scratch`
    /// holds the candidates of one link.
    pub(super) fn near_points(
        &self,
        poses: &[Isometry3<f64>],
        shape: &CollisionShape,
        obstacle: &Obstacle,
        reach: f64,
        scratch: &mut Vec<u32>,
        mut f: impl FnMut(usize, &Point3<f64>, f64, &Vector3<f64>),
    ) {
        for (l, link) in self.robot.links().iter().enumerate() {
            let (c, r) = self.surface_trees[l].bounding_sphere();
            if r < 0.0 {
                continue;
            }
            let pose = &poses[l];
            let cw = pose * c;
            if (cw.coords - obstacle.center).norm() - r - obstacle.radius > reach {
                continue;
            }
            scratch.clear();
            self.surface_trees[l].visit(
                |node| obstacle.aabb_distance(&(pose * node.center)) - node.radius > reach,
                |leaf| scratch.extend_from_slice(leaf),
            );
            scratch.sort_unstable();
            for &k in scratch.iter() {
                let p = pose * link.surface_points[k as usize];
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

    /// Smallest SDF from any hand surface point to any barrier [m] (negative = inside);
    /// `None` without barriers. Branch and bound: the bound starts at the points `seeds`
    /// names (per barrier, the closest point of an earlier call, a close guess on the next
    /// frame); then, per barrier, links are searched in the order of their spheres' distance
    /// to the barrier's bounding volumes, each through its tree of surface points, so
    /// barriers, links and points that cannot be closer cost no query. A distance to a
    /// barrier's box or sphere bounds its SDF from below only when positive (a point inside
    /// the box may be inside the barrier), so nothing is skipped on a bound of 0. A barrier's
    /// seed is updated when it gives a new closest point; the result does not depend on
    /// the seeds.
    pub(super) fn min_clearance(
        &self,
        poses: &[Isometry3<f64>],
        seeds: &mut [(u32, u32)],
        order: &mut Vec<(f64, usize)>,
    ) -> Option<f64> {
        /// A lower bound of the SDF from a positive distance to a bounding volume.
        fn outside(d: f64) -> f64 {
            if d > 0.0 { d } else { f64::NEG_INFINITY }
        }
        if self.barriers.is_empty() {
            return None;
        }
        let links = self.robot.links();
        let mut best = f64::INFINITY;
        for ((shape, obstacle), seed) in self
            .barriers
            .iter()
            .zip(&self.barrier_obstacles)
            .zip(&*seeds)
        {
            if let Some(s) = links
                .get(seed.0 as usize)
                .and_then(|l| l.surface_points.get(seed.1 as usize))
            {
                best = best.min(obstacle.sdf(shape, &(poses[seed.0 as usize] * s)).0);
            }
        }
        for ((shape, obstacle), seed) in self
            .barriers
            .iter()
            .zip(&self.barrier_obstacles)
            .zip(seeds.iter_mut())
        {
            order.clear();
            for (l, tree) in self.surface_trees.iter().enumerate() {
                let (c, r) = tree.bounding_sphere();
                if r >= 0.0 {
                    let cw = poses[l] * c;
                    let spheres = (cw.coords - obstacle.center).norm() - r - obstacle.radius;
                    let bound = outside(spheres.max(obstacle.aabb_distance(&cw) - r));
                    order.push((bound, l));
                }
            }
            order.sort_by(|a, b| a.0.total_cmp(&b.0));
            for &(bound, l) in order.iter() {
                if bound >= best {
                    break;
                }
                let (pose, points) = (&poses[l], &links[l].surface_points);
                best = self.surface_trees[l].minimize(
                    best,
                    |node| outside(obstacle.aabb_distance(&(pose * node.center)) - node.radius),
                    |leaf, best| {
                        for &k in leaf {
                            let p = pose * points[k as usize];
                            if outside(obstacle.aabb_distance(&p)) >= *best {
                                continue;
                            }
                            let d = obstacle.sdf(shape, &p).0;
                            if d < *best {
                                *best = d;
                                *seed = (l as u32, k);
                            }
                        }
                    },
                );
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
            let to_object = object_from_world * poses[l];
            link.probes
                .visit_deeper(sdf, &to_object, active, |p, phi, grad| {
                    let world = poses[l] * p.point;
                    f(
                        l,
                        &world,
                        p.radius - phi,
                        &(world_from_object.rotation * grad),
                    );
                });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::shape::ShapeKind;
    use nalgebra::{Translation3, UnitQuaternion};

    /// `min_clearance` is the smallest SDF over every surface point and barrier, whatever
    /// its seeds, with the hand away from the barriers, near them and inside one.
    #[test]
    fn min_clearance_is_the_smallest_over_every_point() {
        let robot = crate::robot::test_human_hand();
        let barriers = [
            CollisionShape::new(
                ShapeKind::Box {
                    size: Vector3::new(0.3, 0.2, 0.05),
                },
                Isometry3::translation(0.0, 0.0, -0.08),
            )
            .unwrap(),
            CollisionShape::new(
                ShapeKind::Cylinder {
                    radius: 0.04,
                    length: 0.1,
                },
                Isometry3::from_parts(
                    Translation3::new(0.12, 0.05, 0.0),
                    UnitQuaternion::from_euler_angles(0.3, 0.0, 0.0),
                ),
            )
            .unwrap(),
        ];
        let geo = Geometry::new(&robot, &barriers, None);
        let q = robot.neutral_q();
        let mut poses = robot.new_link_poses();
        let mut seeds = vec![(u32::MAX, u32::MAX); barriers.len()];
        let mut order = Vec::new();
        let mut inside = 0;
        for k in 0..60 {
            let s = k as f64 / 60.0;
            let wrist = Isometry3::from_parts(
                Translation3::new(0.2 * (s - 0.5), 0.1 * (4.0 * s).sin(), 0.12 - 0.2 * s),
                UnitQuaternion::from_euler_angles(3.0 * s, -s, 2.0 * s),
            );
            robot.forward_kinematics(&wrist, &q, &mut poses);
            let mut every = f64::INFINITY;
            for (shape, obstacle) in barriers.iter().zip(&geo.barrier_obstacles) {
                for (l, link) in robot.links().iter().enumerate() {
                    for p in &link.surface_points {
                        every = every.min(obstacle.sdf(shape, &(poses[l] * p)).0);
                    }
                }
            }
            if every < 0.0 {
                inside += 1;
            }
            // Seeds from the previous pose, and none.
            assert_eq!(
                geo.min_clearance(&poses, &mut seeds, &mut order),
                Some(every),
                "pose {k}"
            );
            let mut fresh = vec![(u32::MAX, u32::MAX); barriers.len()];
            assert_eq!(
                geo.min_clearance(&poses, &mut fresh, &mut order),
                Some(every),
                "pose {k}"
            );
        }
        assert!(
            inside > 5 && inside < 55,
            "poses inside a barrier: {inside} of 60"
        );
    }
}
