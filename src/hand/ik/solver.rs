//! The per-frame solver [`IkSolver`]: its workspace, the objective and its active points,
//! and the stop rule; the LM and Adam steps are in `lm.rs` and `adam.rs`.

mod adam;
mod lm;

use nalgebra::{Cholesky, DMatrix, DVector, Isometry3, Point3, Vector3};

use super::geometry::{Geometry, Obstacle};
use super::params::{FrameResult, Params, ResolvedContact, Solver, StopReason};
use crate::geometry::ObjectSdf;
use crate::geometry::shape::CollisionShape;
use crate::model::Objective;
use crate::robot::{LinkId, Robot, WRIST_DOF, apply_wrist_step};

/// Length scale of the non-penetration residual [m] (1 mm).
const DEPTH_SCALE_M: f64 = 1e-3;
/// Floor of the contact distance in the IRLS weights [m] (0.1 mm).
const CONTACT_FLOOR_M: f64 = 1e-4;
/// Length scale of the wrist translation in the proximal term [m].
const TRANSLATION_SCALE_M: f64 = 0.1;
/// Initial LM damping (relative to `diag(H)`).
const MU_INIT: f64 = 1e-3;
/// Damping beyond which LM gives up (the model no longer predicts any decrease).
const MU_MAX: f64 = 1e12;
/// LM stops (not converged) when [`Params::stall_steps`] accepted steps in a row each lower
/// `F` by less than [`Params::stall_decrease`] of itself, or when the step's largest component
/// is below this [m or rad].
const STALL_STEP: f64 = 1e-10;

/// Values of the objective's parts at one configuration.
#[derive(Clone, Copy, Debug, Default)]
struct Eval {
    /// Σ_i |r_i| [m].
    sum_m: f64,
    /// max_i |r_i| [m].
    max_m: f64,
    /// w_B Σ Γ_B.
    barrier: f64,
    /// w_P Σ Γ_P.
    penetration: f64,
    /// Deepest active probe [m] (0 when none is deeper than the hinge start).
    max_depth_m: f64,
    /// ρ |D(θ − θ₀)|² (LM only).
    proximal: f64,
}

impl Eval {
    fn mean_m(&self, n: usize) -> f64 {
        if n == 0 { 0.0 } else { self.sum_m / n as f64 }
    }

    fn total(&self, n: usize) -> f64 {
        self.mean_m(n) + self.barrier + self.penetration + self.proximal
    }
}

/// A point where a term of `F` is active at one configuration, as [`IkSolver::evaluate`]
/// found it, so the linearization at that configuration reuses it instead of querying the
/// obstacles again.
#[derive(Clone, Copy, Debug)]
struct Hit {
    link: u32,
    /// World point (a surface point, or a probe centre).
    point: Point3<f64>,
    /// Barrier and surface terms: the signed distance; probes: the depth `r − φ(c)` [m].
    d: f64,
    /// World gradient of the distance.
    grad: Vector3<f64>,
}

/// The active points of each term at one configuration, in the order the queries found
/// them (so sums over them are the same as over the queries).
#[derive(Clone, Debug, Default)]
struct Hits {
    barrier: Vec<Hit>,
    surface: Vec<Hit>,
    probes: Vec<Hit>,
}

impl Hits {
    fn clear(&mut self) {
        self.barrier.clear();
        self.surface.clear();
        self.probes.clear();
    }
}

/// A per-frame contact IK solver with its preallocated workspace. Reuse one for many frames.
#[derive(Debug)]
pub struct IkSolver<'a> {
    geo: Geometry<'a>,
    params: Params,
    /// 6 + dof.
    n: usize,
    poses: Vec<Isometry3<f64>>,
    trial_poses: Vec<Isometry3<f64>>,
    /// The active points at `poses` and at `trial_poses` (swapped with them).
    hits: Hits,
    trial_hits: Hits,
    /// Per barrier, the hand's closest surface point in the last frame (link, point), and
    /// the link order buffer of [`Geometry::min_clearance`].
    clearance_seeds: Vec<(u32, u32)>,
    clearance_order: Vec<(f64, usize)>,
    /// Candidate surface points of one link ([`Geometry::near_points`]).
    near_scratch: Vec<u32>,
    jac: Vec<Vector3<f64>>,
    row: Vec<f64>,
    h: DMatrix<f64>,
    a: DMatrix<f64>,
    g: DVector<f64>,
    step: DVector<f64>,
    diag: Vec<f64>,
    frozen: Vec<bool>,
    wrist0: Isometry3<f64>,
    q0: Vec<f64>,
    q_trial: Vec<f64>,
    adam_m: Vec<f64>,
    adam_v: Vec<f64>,
    /// Object frame from world of the current frame, when the non-penetration term is on.
    object_from_world: Option<Isometry3<f64>>,
    /// The object shape of the surface-point penetration term, and its obstacle this frame.
    surface_object: Option<&'a CollisionShape>,
    surface_obstacle: Option<Obstacle>,
    /// The stop rule's contact threshold for the frame being solved [m].
    target_m: f64,
}

impl<'a> IkSolver<'a> {
    /// A solver for `robot` among `barriers` (world-frame shapes). `object` is the object's
    /// signed distance field, used by the non-penetration term and to report each frame's
    /// deepest probe.
    pub fn new(
        robot: &'a Robot,
        barriers: &'a [CollisionShape],
        object: Option<&'a ObjectSdf>,
        params: Params,
    ) -> Self {
        let n = WRIST_DOF + robot.dof();
        IkSolver {
            geo: Geometry::new(robot, barriers, object),
            n,
            poses: robot.new_link_poses(),
            trial_poses: robot.new_link_poses(),
            hits: Hits::default(),
            trial_hits: Hits::default(),
            clearance_seeds: vec![(u32::MAX, u32::MAX); barriers.len()],
            clearance_order: Vec::with_capacity(robot.link_count()),
            near_scratch: Vec::new(),
            jac: vec![Vector3::zeros(); n],
            row: vec![0.0; n],
            h: DMatrix::zeros(n, n),
            a: DMatrix::zeros(n, n),
            g: DVector::zeros(n),
            step: DVector::zeros(n),
            diag: vec![0.0; n],
            frozen: vec![false; n],
            wrist0: Isometry3::identity(),
            q0: vec![0.0; robot.dof()],
            q_trial: vec![0.0; robot.dof()],
            adam_m: vec![0.0; n],
            adam_v: vec![0.0; n],
            object_from_world: None,
            surface_object: None,
            surface_obstacle: None,
            target_m: params.threshold_mm * 1e-3,
            params,
        }
    }

    /// Gives the surface-point penetration term its object shape (object frame); see
    /// [`Params::surface_penetration_weight`].
    pub fn with_surface_object(mut self, shape: &'a CollisionShape) -> Self {
        self.surface_object = Some(shape);
        self
    }

    /// The parameters in use.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// Solves one frame in place (warm start = the given `wrist` and `q`, joints in robot
    /// order). On a non-finite result the warm start is restored and the frame is reported
    /// not converged.
    pub fn solve(
        &mut self,
        object_pose: &Isometry3<f64>,
        contacts: &[ResolvedContact],
        wrist: &mut Isometry3<f64>,
        q: &mut [f64],
    ) -> FrameResult {
        let threshold_m = self.params.threshold_mm * 1e-3;
        self.solve_within(object_pose, contacts, wrist, q, threshold_m)
    }

    /// The objective `F` at `wrist`, `q` (what [`IkSolver::solve_within`] would start from),
    /// without solving: whether a second start is worth a solve.
    pub fn objective_at(
        &mut self,
        object_pose: &Isometry3<f64>,
        contacts: &[ResolvedContact],
        wrist: &Isometry3<f64>,
        q: &[f64],
        threshold_m: f64,
    ) -> f64 {
        self.prepare(object_pose, wrist, q, threshold_m);
        self.evaluate(false, object_pose, contacts, wrist, q)
            .total(contacts.len())
    }

    /// Sets what a solve from `wrist`, `q` at `object_pose` reads: the stop rule's threshold,
    /// the start, the object's frame for the penetration probes and the surface obstacle.
    fn prepare(
        &mut self,
        object_pose: &Isometry3<f64>,
        wrist: &Isometry3<f64>,
        q: &[f64],
        threshold_m: f64,
    ) {
        self.target_m = threshold_m;
        assert_eq!(q.len(), self.geo.robot.dof(), "q has the wrong length");
        self.wrist0 = *wrist;
        self.q0.copy_from_slice(q);
        self.object_from_world = match self.geo.object {
            Some(_) if self.params.non_penetrating() => Some(object_pose.inverse()),
            _ => None,
        };
        self.surface_obstacle = match self.surface_object {
            Some(shape) if self.params.surface_penetration_weight > 0.0 => {
                Some(Obstacle::new(shape, &(object_pose * shape.shape_pose)))
            }
            _ => None,
        };
    }

    /// [`IkSolver::solve`] with the stop rule's contact threshold `threshold_m` [m] for this
    /// frame instead of [`Params::threshold_mm`] (see [`run`](super::run): never above the recording's
    /// own fit).
    pub fn solve_within(
        &mut self,
        object_pose: &Isometry3<f64>,
        contacts: &[ResolvedContact],
        wrist: &mut Isometry3<f64>,
        q: &mut [f64],
        threshold_m: f64,
    ) -> FrameResult {
        self.prepare(object_pose, wrist, q, threshold_m);
        let start = self.evaluate(false, object_pose, contacts, wrist, q);
        let f_start = start.total(contacts.len());
        let (converged, iterations, eval, capped) = match self.params.solver {
            Solver::Lm => self.solve_lm(object_pose, contacts, wrist, q, start),
            Solver::Adam => self.solve_adam(object_pose, contacts, wrist, q, start),
        };
        let finite = wrist.translation.vector.iter().all(|v| v.is_finite())
            && wrist.rotation.coords.iter().all(|v| v.is_finite())
            && q.iter().all(|v| v.is_finite());
        let n = contacts.len();
        // The active points are those of the returned configuration, except when Adam
        // ran out of iterations and returned an earlier iterate.
        let mut hits_current = !(self.params.solver == Solver::Adam && capped && !converged);
        let (stop, eval) = if !finite {
            // NaN or infinity is a reported event, never the output.
            *wrist = self.wrist0;
            q.copy_from_slice(&self.q0);
            let e = self.evaluate(false, object_pose, contacts, wrist, q);
            hits_current = true;
            (StopReason::NonFinite, e)
        } else if converged {
            (StopReason::Converged, eval)
        } else if self.object_from_world.is_some()
            && (eval.penetration > 0.0 || eval.max_depth_m > self.tolerance_m())
        {
            (StopReason::PenetrationLimited, eval)
        } else if eval.barrier > 1e-9 {
            (StopReason::BarrierLimited, eval)
        } else if capped {
            (StopReason::IterationCap, eval)
        } else {
            (StopReason::LocalMinimum, eval)
        };
        // The deepest probe and the smallest barrier clearance at the solution. `eval`'s own
        // active points give them exactly when there are any (the deepest probe is deeper
        // than the hinge start, the closest point within the barrier term's reach); only
        // otherwise is the hand searched again.
        let hits = hits_current.then_some(&self.hits);
        let deepest_known = self.object_from_world.is_some() && eval.max_depth_m > 0.0;
        let clearance_known = hits.is_some_and(|h| !h.barrier.is_empty());
        let need_poses = (!self.geo.barriers.is_empty() && !clearance_known)
            || (self.geo.object.is_some() && !deepest_known);
        if need_poses {
            self.geo.robot.forward_kinematics(wrist, q, &mut self.poses);
        }
        let clearance = if self.geo.barriers.is_empty() {
            None
        } else if let Some(h) = hits.filter(|_| clearance_known) {
            h.barrier.iter().map(|h| h.d).reduce(f64::min)
        } else {
            self.geo.min_clearance(
                &self.poses,
                &mut self.clearance_seeds,
                &mut self.clearance_order,
            )
        };
        let max_penetration_mm = match self.geo.object {
            None => 0.0,
            Some(_) if deepest_known => eval.max_depth_m * 1e3,
            Some(sdf) => crate::robot::probes::deepest(
                self.geo.robot,
                &self.poses,
                &object_pose.inverse(),
                sdf,
            )
            .map_or(0.0, |(d, _)| d * 1e3),
        };
        FrameResult {
            converged: stop == StopReason::Converged,
            iterations,
            contacts: n,
            mean_mm: eval.mean_m(n) * 1e3,
            max_mm: eval.max_m * 1e3,
            min_barrier_clearance_mm: clearance.map(|d| d * 1e3),
            non_finite: !finite,
            stop,
            max_penetration_mm,
            objective_start: f_start,
            objective_end: eval.total(n),
        }
    }

    /// Penetration tolerance [m].
    fn tolerance_m(&self) -> f64 {
        self.params.penetration_tolerance_mm * 1e-3
    }

    /// Depth at which the non-penetration hinge starts [m].
    fn hinge_start_m(&self) -> f64 {
        0.5 * self.tolerance_m()
    }

    /// The stop rule: contacts within the threshold and, with the non-penetration term, no
    /// probe deeper than the tolerance.
    fn meets_stop_rule(&self, e: &Eval, contacts: usize) -> bool {
        e.mean_m(contacts) < self.threshold_m()
            && (self.object_from_world.is_none() || e.max_depth_m <= self.tolerance_m())
    }

    fn threshold_m(&self) -> f64 {
        self.target_m
    }

    /// FK into `poses` (or `trial_poses`), the objective's parts, and the active points
    /// into `hits` (or `trial_hits`).
    fn evaluate(
        &mut self,
        trial: bool,
        object_pose: &Isometry3<f64>,
        contacts: &[ResolvedContact],
        wrist: &Isometry3<f64>,
        q: &[f64],
    ) -> Eval {
        let hinge = self.hinge_start_m();
        let (poses, hits) = if trial {
            (&mut self.trial_poses, &mut self.trial_hits)
        } else {
            (&mut self.poses, &mut self.hits)
        };
        self.geo.robot.forward_kinematics(wrist, q, poses);
        let poses = &poses[..];
        hits.clear();
        let hit = |l: usize, p: &Point3<f64>, d: f64, grad: &Vector3<f64>| Hit {
            link: l as u32,
            point: *p,
            d,
            grad: *grad,
        };
        let mut e = Eval::default();
        for c in contacts {
            let d = (poses[c.link.index()] * c.hand_point - object_pose * c.object_point).norm();
            e.sum_m += d;
            e.max_m = e.max_m.max(d);
        }
        let p = &self.params;
        if p.barrier_weight > 0.0 {
            // The paper's potential (1 − SDF/m)^n out to m, or the clearance hinge out to c.
            let paper = p.objective == Objective::Paper;
            let (m, n, c) = (p.margin_m, p.steepness, p.barrier_clearance_mm * 1e-3);
            let reach = if paper { m } else { c };
            let mut sum = 0.0;
            for (shape, obstacle) in self.geo.barriers.iter().zip(&self.geo.barrier_obstacles) {
                self.geo.near_points(
                    poses,
                    shape,
                    obstacle,
                    reach,
                    &mut self.near_scratch,
                    |l, pt, d, grad| {
                        sum += if paper {
                            (1.0 - d / m).powf(n)
                        } else {
                            let v = (c - d) / DEPTH_SCALE_M;
                            v * v
                        };
                        hits.barrier.push(hit(l, pt, d, grad));
                    },
                );
            }
            e.barrier = p.barrier_weight * sum;
        }
        if let (Some(shape), Some(obstacle)) = (self.surface_object, &self.surface_obstacle) {
            let m = p.margin_m;
            let mut sum = 0.0;
            self.geo.near_points(
                poses,
                shape,
                obstacle,
                0.0,
                &mut self.near_scratch,
                |l, pt, d, grad| {
                    sum += (d / m) * (d / m);
                    hits.surface.push(hit(l, pt, d, grad));
                },
            );
            e.penetration = p.surface_penetration_weight * sum;
        }
        if let (Some(sdf), Some(object_from_world)) = (self.geo.object, &self.object_from_world) {
            let a = hinge;
            let (mut sum, mut deepest) = (0.0, 0.0f64);
            self.geo
                .active_probes(sdf, poses, object_from_world, a, |l, c, depth, grad| {
                    let v = (depth - a) / DEPTH_SCALE_M;
                    sum += v * v;
                    deepest = deepest.max(depth);
                    hits.probes.push(hit(l, c, depth, grad));
                });
            e.penetration = p.penetration_weight * sum;
            e.max_depth_m = deepest;
        }
        if p.solver == Solver::Lm && p.regularization > 0.0 {
            let dt =
                (wrist.translation.vector - self.wrist0.translation.vector) / TRANSLATION_SCALE_M;
            let dr = (wrist.rotation * self.wrist0.rotation.inverse()).scaled_axis();
            let dq: f64 = q.iter().zip(&self.q0).map(|(a, b)| (a - b) * (a - b)).sum();
            e.proximal = p.regularization * (dt.norm_squared() + dr.norm_squared() + dq);
        }
        e
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::shape::ShapeKind;
    use nalgebra::{Translation3, UnitQuaternion};

    fn hand() -> Robot {
        crate::robot::test_human_hand()
    }

    /// The configuration, object and terms of [`gradients_match_finite_differences`].
    struct GradientCase {
        q: Vec<f64>,
        wrist: Isometry3<f64>,
        object_pose: Isometry3<f64>,
        contacts: Vec<ResolvedContact>,
        barriers: [CollisionShape; 1],
        sdf: ObjectSdf,
    }

    /// A bent hand, an object at its index tip with contacts 1-5 mm off a few surface
    /// points per link, a barrier box overlapping the palm, and the apple's field around
    /// the index tip.
    fn gradient_case(robot: &Robot) -> GradientCase {
        let mut q = robot.neutral_q();
        for (i, v) in q.iter_mut().enumerate() {
            *v += 0.05 * ((i * 7 % 5) as f64 - 2.0);
        }
        robot.clamp(&mut q);
        let wrist = Isometry3::from_parts(
            Translation3::new(0.1, -0.2, 0.9),
            UnitQuaternion::from_euler_angles(0.3, -0.2, 0.5),
        );
        let mut poses = robot.new_link_poses();
        robot.forward_kinematics(&wrist, &q, &mut poses);
        let object_pose = Isometry3::from_parts(
            Translation3::from(
                poses[robot.link_id("index_tip").unwrap().index()]
                    .translation
                    .vector,
            ),
            UnitQuaternion::from_euler_angles(0.1, 0.2, 0.3),
        );
        // Contacts: a few surface points per finger link, object points 1-5 mm away.
        let mut contacts = Vec::new();
        for (l, link) in robot.links().iter().enumerate() {
            for (k, p) in link.surface_points.iter().enumerate().step_by(37) {
                let off = Vector3::new(0.001 * (k % 5) as f64, -0.002, 0.003);
                let world = poses[l] * p + off;
                contacts.push(ResolvedContact {
                    link: LinkId(l as u32),
                    hand_point: *p,
                    object_point: object_pose.inverse() * world,
                });
            }
        }
        let palm = poses[robot.root().index()];
        let barrier = CollisionShape::new(
            ShapeKind::Box {
                size: Vector3::new(0.03, 0.1, 0.1),
            },
            palm * Isometry3::translation(-0.03, 0.0, 0.03),
        )
        .unwrap();
        // The object: the apple mesh (about 4 cm in radius) around the index tip, so the
        // fingers are inside it.
        let sdf = ObjectSdf::new(
            crate::synth::objects::object_mesh(crate::synth::objects::ObjectKind::Apple),
            &crate::geometry::SdfParams::default(),
        )
        .unwrap();
        GradientCase {
            q,
            wrist,
            object_pose,
            contacts,
            barriers: [barrier],
            sdf,
        }
    }

    /// Central difference of `F` along tangent column `k` with step `h`.
    fn finite_difference(ik: &mut IkSolver<'_>, case: &GradientCase, k: usize, h: f64) -> f64 {
        let n = case.contacts.len();
        let mut f = |sign: f64| {
            let (mut w, mut qq) = (case.wrist, case.q.clone());
            let mut d = [0.0; 6];
            if k < WRIST_DOF {
                d[k] = sign * h;
            } else {
                qq[k - WRIST_DOF] += sign * h;
            }
            apply_wrist_step(
                &mut w,
                &Vector3::new(d[0], d[1], d[2]),
                &Vector3::new(d[3], d[4], d[5]),
            );
            ik.evaluate(false, &case.object_pose, &case.contacts, &w, &qq)
                .total(n)
        };
        (f(1.0) - f(-1.0)) / (2.0 * h)
    }

    /// The analytic gradient of `F` (Adam) and the LM model gradient `2g` (IRLS, so it
    /// touches `F`) agree with central differences of `F` in the tangent parameterization,
    /// with every term active: contacts, a barrier box overlapping the palm, and the
    /// non-penetration term against an object the fingers enter.
    #[test]
    fn gradients_match_finite_differences() {
        let robot = hand();
        let case = gradient_case(&robot);
        let (wrist, q, object_pose) = (case.wrist, &case.q, case.object_pose);
        let contacts = &case.contacts;
        for (solver, objective) in [
            (Solver::Adam, Objective::NonPenetrating),
            (Solver::Lm, Objective::NonPenetrating),
            (Solver::Adam, Objective::Paper),
            (Solver::Lm, Objective::Paper),
        ] {
            let params = Params {
                solver,
                objective,
                regularization: 0.0,
                penetration_weight: 0.5,
                penetration_tolerance_mm: 2.0,
                steepness: 3.0,
                ..Params::default()
            };
            let mut ik = IkSolver::new(&robot, &case.barriers, Some(&case.sdf), params);
            ik.wrist0 = wrist;
            ik.q0.copy_from_slice(q);
            ik.object_from_world = Some(object_pose.inverse());
            if objective == Objective::Paper {
                ik.object_from_world = None;
            }
            let e = ik.evaluate(false, &object_pose, contacts, &wrist, q);
            assert!(e.barrier > 0.0, "{e:?}");
            assert!(
                e.penetration > 0.0 || objective == Objective::Paper,
                "{e:?}"
            );
            let analytic: Vec<f64> = match solver {
                Solver::Adam => {
                    ik.gradient(&object_pose, contacts);
                    ik.g.iter().copied().collect()
                }
                Solver::Lm => {
                    ik.linearize(&object_pose, contacts, &wrist, q);
                    ik.g.iter().map(|v| 2.0 * v).collect()
                }
            };
            for k in 0..ik.n {
                let fd = finite_difference(&mut ik, &case, k, 1e-7);
                let err = (fd - analytic[k]).abs();
                // The object field's gradient is that of its trilinear interpolant, which
                // jumps where a probe crosses a cell face (and where a query moves from the
                // grid to the exact layer): a few per cent there, exact elsewhere.
                let tol = match objective {
                    Objective::Paper => 1e-5 * (1.0 + fd.abs()),
                    Objective::NonPenetrating => 1e-5 + 0.03 * fd.abs(),
                };
                assert!(
                    err < tol,
                    "{solver:?} {objective:?}, column {k}: analytic {} vs finite difference {fd}",
                    analytic[k]
                );
            }
        }
    }

    /// A joint at its limit whose gradient points outward stays there; the solver never
    /// leaves the limits.
    #[test]
    fn joint_limits_hold() {
        let robot = hand();
        let q_lo: Vec<f64> = robot.lower().to_vec();
        let wrist = Isometry3::translation(0.0, 0.0, 1.0);
        let mut poses = robot.new_link_poses();
        robot.forward_kinematics(&wrist, &q_lo, &mut poses);
        // Targets that would need the fingers beyond their lower limits (bent backwards).
        let tip = robot.link_id("index_tip").unwrap();
        let target = poses[tip.index()] * Point3::new(-0.03, 0.0, 0.0);
        let contacts = [ResolvedContact {
            link: tip,
            hand_point: Point3::origin(),
            object_point: target,
        }];
        let mut ik = IkSolver::new(&robot, &[], None, Params::default());
        let (mut w, mut q) = (wrist, q_lo.clone());
        let r = ik.solve(&Isometry3::identity(), &contacts, &mut w, &mut q);
        assert!(r.mean_mm < 3.5 || !r.converged);
        for (j, v) in q.iter().enumerate() {
            assert!(
                *v >= robot.lower()[j] && *v <= robot.upper()[j],
                "joint {j}: {v}"
            );
        }
    }
}
