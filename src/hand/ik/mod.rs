//! Stage 4: hand recovery by per-frame contact IK (docs/METHOD.md stage 4, paper "Hand Warping").
//!
//! For every output frame `t` of the contact segment, with the correspondences of
//! `t* = τ⁻¹(t)` (the last input frame mapped at or before `t`) and the warped object pose
//! `O(t)`, the hand configuration `θ = (wrist t, wrist R, q)` minimizes
//!
//! ```text
//! F(θ) = (1/N) Σ_i |FK_i(θ)·h_i − O(t)·o_i|                       contact distance [m]
//!      + w_B Σ_b Σ_{p ∈ P(θ)} max(0, 1 − SDF(p, b)/m)^n             barrier term
//!      + w_P Σ_{c ∈ C(θ)} (max(0, r_c − φ(c) − a) / 1 mm)²           non-penetration (default)
//! ```
//!
//! `P(θ)` are the links' `surface_points` through forward kinematics and barrier SDFs come
//! from parry (negative inside); `w_B = 1` is the paper's objective as printed. The
//! non-penetration term is ours (the default [`Objective::NonPenetrating`]): `C(θ)` are the
//! links' penetration probes (balls `B(c, r)` inside the collision geometry, see
//! [`crate::robot::probes`]), `φ` is the object's signed distance field
//! ([`crate::geometry::sdf`], right for unions of overlapping parts), `r − φ(c)` the probe's
//! depth in the object, and the hinge starts at `a = tolerance / 2`, so fingers may rest on
//! or slightly in the surface (the demonstrations' own fingers sit up to about 1 mm in) but
//! are pushed out before they reach the tolerance. Why: correspondences are cleaned by a
//! distance threshold (each hand point a few millimetres off the surface is paired with its
//! nearest surface point), so every pair points into the object and fitting the pairs
//! exactly presses the fingers in; the term makes "closer to the contacts" stop at the
//! surface. [`Objective::Paper`] drops it: the paper's objective as printed, for
//! reproducing its tables. Only probes that can matter are evaluated: each link's tree of
//! probe spheres ([`crate::geometry::SphereTree`]) is tested against `φ` (1-Lipschitz) from
//! the root down before the probes of a leaf are.
//!
//! **Query budget.** `evaluate` records the points where each term is active (barrier
//! points within reach, probes past the hinge start) and the linearization at the same
//! configuration reuses them, so one LM iteration queries the obstacles once (its trial
//! point); a frame's warm start is evaluated once. The reported deepest probe and barrier
//! clearance of a frame come from its last evaluation when it has active points, and
//! otherwise from a branch and bound seeded by the previous frame's closest point.
//!
//! **Stop rule** (both solvers): a frame is *converged* when the mean contact distance is
//! below `threshold_mm` and, with the non-penetration objective, no probe is deeper than
//! [`Params::penetration_tolerance_mm`]; it is checked before every iteration, so a warm
//! start that already meets it costs no iteration. With the non-penetration objective,
//! [`run`] also holds each frame to the recording's own fit when that is tighter (see
//! `recording_targets_m`): a loose threshold never returns contacts fitting worse than
//! the demonstration's. Any other ending is reported
//! `converged = false` with a [`StopReason`]: `penetration_limited` (the contacts cannot be
//! reached without pressing in, or the fingers cannot be got out), `barrier_limited` (the
//! barrier term holds the hand off), `iteration_cap` or `local_minimum`. The returned
//! configuration is never worse (higher `F`) than the warm start: LM accepts only decreasing
//! steps, and Adam returns the best iterate it visited.
//!
//! **`lm`** (default): Levenberg-Marquardt on the same `F`. The sum of distances is handled
//! by iteratively reweighted least squares: at the linearization point each contact becomes
//! the residual `r_i / sqrt(2 N a_i)` with `a_i = max(|r_i|, 0.1 mm)`, the majorizer of
//! `|r_i|/N` that touches it there (same value, same gradient). So LM minimizes the paper's
//! objective, not the squared distances: matched contacts stay matched while outliers
//! (e.g. permuted correspondences) pull with bounded force. Barrier points are residuals
//! `sqrt(w_B)·g^(n/2)`, `g = max(0, 1 − SDF/m)`, with gradient
//! `−sqrt(w_B)(n/2) g^(n/2−1)/m · ∇SDFᵀ J`; active probes `sqrt(w_P)(depth − a)/1 mm` with
//! gradient `−sqrt(w_P)/1 mm · ∇φᵀ J`. A
//! proximal term `ρ |D(θ − θ₀)|²` (`ρ = regularization`, `D` = 1/0.1 m on the wrist
//! translation, 1 on rotations [rad] and joints) pulls toward the warm start so joints the
//! contacts do not determine stay put. The normal equations (6 + dof unknowns) use only the
//! non-zero Jacobian columns of each link (wrist + its chain), Marquardt scaling
//! `μ·diag(H)`, Nielsen's damping update, and a Cholesky factorization into preallocated
//! storage; joints at a limit whose gradient pushes outward are frozen for the step, and
//! every trial is clamped to the limits. Each linear solve counts as one iteration. LM also
//! stops early, not converged, at a local minimum that misses the stop rule (an accepted
//! step lowers `F` by less than [`Params::stall_decrease`] of itself, or the step vanishes):
//! typically fingers that cannot come closer without pressing in, or a barrier.
//!
//! **`adam`**: the paper's solver, faithful: Adam (β = 0.9, 0.999, ε = 1e-8, learning rate
//! 0.01, moments reset every frame) on exactly `F` (no proximal term; with the paper's
//! objective, exactly the printed one), with the parameter
//! vector wrist translation [m], wrist rotation (local steps `R ← exp(δω)·R`, moments on the
//! tangent vector) [rad], joints [rad], clamped to the limits after every step.
//!
//! Mimic joints are folded into their drivers by the point Jacobian. Nothing allocates per
//! iteration: every buffer lives in [`IkSolver`].

mod adam;
mod geometry;
mod lm;

use geometry::{Geometry, Obstacle};

use std::fmt;
use std::str::FromStr;
use std::time::Instant;

use nalgebra::{Cholesky, DMatrix, DVector, Isometry3, Point3, Vector3};
use serde::{Deserialize, Serialize};

use super::HandPath;
use crate::geometry::ObjectSdf;
use crate::geometry::shape::CollisionShape;
use crate::model::{Contact, Demo, Objective, WarmStart};
use crate::robot::{LinkId, Robot, WRIST_DOF, apply_wrist_step};
use crate::warp::ObjectWarp;

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
/// LM stops (not converged) when an accepted step lowers `F` by less than
/// [`Params::stall_decrease`] of itself, or when the step's largest component is below this
/// [m or rad].
const STALL_STEP: f64 = 1e-10;

/// The optimizer of the per-frame problem.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Solver {
    /// Levenberg-Marquardt with analytic Jacobians (fast; default).
    #[default]
    Lm,
    /// Adam, learning rate 0.01, as in the paper (reference for reproduction).
    Adam,
}

impl Solver {
    /// The name used in configs and on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            Solver::Lm => "lm",
            Solver::Adam => "adam",
        }
    }

    /// Iteration cap per frame when [`Params::max_iterations`] is 0: LM 100, Adam 3000.
    pub fn default_max_iterations(self) -> usize {
        match self {
            Solver::Lm => 100,
            Solver::Adam => 3000,
        }
    }
}

impl fmt::Display for Solver {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// An unknown solver name.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown IK solver {0:?}; expected \"lm\" or \"adam\"")]
pub struct UnknownSolver(pub String);

impl FromStr for Solver {
    type Err = UnknownSolver;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "lm" => Ok(Solver::Lm),
            "adam" => Ok(Solver::Adam),
            _ => Err(UnknownSolver(s.to_string())),
        }
    }
}

/// Why a frame's solve ended.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// Threshold met (and no probe deeper than the tolerance).
    #[default]
    Converged,
    /// The contacts cannot be reached without pressing into the object, or the fingers
    /// cannot be brought out of it.
    PenetrationLimited,
    /// The barrier term holds the hand off its contacts.
    BarrierLimited,
    /// The iteration cap was reached.
    IterationCap,
    /// No descent direction left (a local minimum above the threshold).
    LocalMinimum,
    /// The solver produced a non-finite configuration; the warm start was kept.
    NonFinite,
}

impl StopReason {
    /// The name used in reports and `frames.csv`.
    pub fn as_str(self) -> &'static str {
        match self {
            StopReason::Converged => "converged",
            StopReason::PenetrationLimited => "penetration_limited",
            StopReason::BarrierLimited => "barrier_limited",
            StopReason::IterationCap => "iteration_cap",
            StopReason::LocalMinimum => "local_minimum",
            StopReason::NonFinite => "non_finite",
        }
    }
}

/// Parameters of the contact IK.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Params {
    /// Optimizer. Default `lm`.
    pub solver: Solver,
    /// Stop when the mean contact distance is below this [mm]. Default 3.5.
    pub threshold_mm: f64,
    /// Iteration cap per frame; 0 = the solver's default (LM 100, Adam 3000). Default 0.
    pub max_iterations: usize,
    /// Barrier margin `m` [m]: points farther than this from every barrier cost nothing.
    /// Default 0.05.
    pub margin_m: f64,
    /// Barrier steepness `n` (dimensionless). Default 2.
    pub steepness: f64,
    /// Weight of the barrier sum (1 = the paper's objective as printed, 0 = off). Default 1.
    pub barrier_weight: f64,
    /// Non-penetrating objective only: the clearance the hand keeps from barriers [mm]; its
    /// barrier term is the hinge `w_B Σ_p (max(0, c − SDF(p, b))/1 mm)²` instead of the
    /// paper's potential, which reaches `m` = 5 cm out and, once a frame cannot meet the
    /// threshold, outweighs the contacts a hundredfold and pulls the hand off the object.
    /// Default 5.
    pub barrier_clearance_mm: f64,
    /// What is minimized. Default `non_penetrating`.
    pub objective: Objective,
    /// Weight `w_P` of the non-penetration term (dimensionless, residuals in mm; see the
    /// module docs). Default 1.
    pub penetration_weight: f64,
    /// Deepest a penetration probe may sit in the object in a converged frame [mm]; the
    /// hinge starts at half of it. Default 1.
    pub penetration_tolerance_mm: f64,
    /// Adam learning rate [m or rad per step]. Default 0.01 (the paper).
    pub learning_rate: f64,
    /// LM only: weight `ρ` of the proximal term toward the warm start (dimensionless, see
    /// the module docs). Default 1e-4.
    pub regularization: f64,
    /// LM only: an accepted step that lowers `F` by less than this fraction of itself ends a
    /// frame that misses the stop rule (a local minimum). Default 1e-5 (measured on the
    /// built-in configs: 1e-6 spends twice the iterations on frames that cannot reach the
    /// threshold for 0.3-0.5 mm of D_C; 1e-3 gives up 1 mm of D_C).
    pub stall_decrease: f64,
    /// Grasp synthesis only: weight of the surface-point penetration term
    /// `Σ_{p ∈ P(θ)} (min(0, SDF(p, object))/m)²` on the links' surface points against the
    /// object shape given by [`IkSolver::with_surface_object`] (a triangle mesh). It keeps
    /// the committed demonstrations reproducible; the warp's IK uses the probes instead.
    /// Default 0.
    pub surface_penetration_weight: f64,
    /// Warm start of each frame. Default `previous`.
    pub warm_start: WarmStart,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            solver: Solver::Lm,
            threshold_mm: 3.5,
            max_iterations: 0,
            margin_m: 0.05,
            steepness: 2.0,
            barrier_weight: 1.0,
            barrier_clearance_mm: 5.0,
            objective: Objective::NonPenetrating,
            penetration_weight: 1.0,
            penetration_tolerance_mm: 1.0,
            learning_rate: 0.01,
            regularization: 1e-4,
            stall_decrease: 1e-5,
            surface_penetration_weight: 0.0,
            warm_start: WarmStart::Previous,
        }
    }
}

impl Params {
    /// The non-penetration term is in effect (objective and weight).
    pub fn non_penetrating(&self) -> bool {
        self.objective == Objective::NonPenetrating && self.penetration_weight > 0.0
    }

    /// The iteration cap in effect (resolves `max_iterations = 0`).
    pub fn iteration_cap(&self) -> usize {
        if self.max_iterations == 0 {
            self.solver.default_max_iterations()
        } else {
            self.max_iterations
        }
    }
}

/// A correspondence with its link resolved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ResolvedContact {
    pub link: LinkId,
    /// Point on the hand, link frame [m].
    pub hand_point: Point3<f64>,
    /// Point on the object, object frame [m].
    pub object_point: Point3<f64>,
}

/// Resolves link names to ids. Panics on a name that is not a link of `robot`
/// ([`Demo::check_robot`] rejects such demonstrations).
pub fn resolve_contacts(robot: &Robot, contacts: &[Contact]) -> Vec<ResolvedContact> {
    contacts
        .iter()
        .map(|c| ResolvedContact {
            link: robot
                .link_id(&c.link)
                .unwrap_or_else(|| panic!("{:?} is not a link of {:?}", c.link, robot.name)),
            hand_point: c.hand_point,
            object_point: c.object_point,
        })
        .collect()
}

/// The outcome of one frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameResult {
    /// The frame met the stop rule: the mean contact distance under the frame's threshold
    /// (always true without contacts) and, with the non-penetration term, no probe deeper
    /// than the tolerance.
    pub converged: bool,
    /// Iterations spent (LM: linear solves; Adam: steps).
    pub iterations: usize,
    /// Number of correspondences.
    pub contacts: usize,
    /// Mean contact distance at the solution [mm] (0 without contacts).
    pub mean_mm: f64,
    /// Largest contact distance at the solution [mm].
    pub max_mm: f64,
    /// Smallest signed distance from a hand surface point to a barrier [mm] (negative =
    /// penetration); `None` without barriers.
    pub min_barrier_clearance_mm: Option<f64>,
    /// The solver produced a non-finite configuration; the warm start was kept.
    pub non_finite: bool,
    /// Why the solve ended.
    pub stop: StopReason,
    /// Deepest penetration probe in the object at the solution [mm] (0 when none is in, or
    /// without an object field).
    pub max_penetration_mm: f64,
    /// The objective `F` at the warm start and at the solution (never higher).
    pub objective_start: f64,
    pub objective_end: f64,
}

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

    /// [`IkSolver::solve`] with the stop rule's contact threshold `threshold_m` [m] for this
    /// frame instead of [`Params::threshold_mm`] (see [`run`]: never above the recording's
    /// own fit).
    pub fn solve_within(
        &mut self,
        object_pose: &Isometry3<f64>,
        contacts: &[ResolvedContact],
        wrist: &mut Isometry3<f64>,
        q: &mut [f64],
        threshold_m: f64,
    ) -> FrameResult {
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

/// The default objective's per-source-frame stop targets [m] (0 for frames without
/// contacts), indexed from `c0`: a frame stops only below the tighter of the threshold and
/// its target, so a loose threshold never returns contacts fitting worse than the
/// recording's (the paper's objective keeps its stop rule as printed).
///
/// The target of source frame `s` is the recording's own mean contact distance `d(s)`,
/// scaled by `min(1, (D_C − room) / D_τ)`: `D_C` is the recording's D_C (the mean of `d`
/// over its frames with contacts), `D_τ` the mean of `d(τ⁻¹(t))` over the output frames
/// (above `D_C` where τ gives the worse-fitting frames more output time), and `room` =
/// 0.1 mm is left for stage 5, whose smoothing adds 0.001-0.06 mm to D_C on the built-in
/// configs. So the output's D_C stays at or below the recording's however τ weights the
/// frames, and where the rigid transfer is exact (`D_τ = D_C`) the targets ask it for
/// 0.1 mm of D_C at most (about 2 %). Each target carries 1 µm of slack so a frame that
/// fits exactly as well as its target counts as meeting it.
fn recording_targets_m(robot: &Robot, demo: &Demo, warp: &ObjectWarp) -> Vec<f64> {
    const SLACK_MM: f64 = 1e-3;
    const ROOM_MM: f64 = 0.1;
    const LEAST_MM: f64 = 1.0;
    let plan = &warp.plan;
    let (c0, c1) = (plan.segment.start, plan.segment.end);
    // The same per-frame distances and D_C as the report's `d_c_mm.original`.
    let per_frame = crate::metrics::contact_distance_per_frame_mm(robot, demo);
    let d = &per_frame[c0..=c1];
    let d_c = crate::metrics::d_c_mm(&per_frame);
    let stretched: Vec<Option<f64>> = (c0..=plan.t_end_new())
        .map(|t| d[warp.source_frame(t) - c0])
        .collect();
    let d_tau = crate::metrics::d_c_mm(&stretched);
    let scale = if d_c > 0.0 && d_tau > d_c - ROOM_MM {
        ((d_c - ROOM_MM) / d_tau).max(0.0)
    } else {
        1.0
    };
    d.iter()
        .map(|x| x.map_or(0.0, |x| ((x * scale).max(LEAST_MM) + SLACK_MM) * 1e-3))
        .collect()
}

/// What stage 4 did.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Solver used.
    pub solver: Solver,
    /// Threshold [mm].
    pub threshold_mm: f64,
    /// Iteration cap per frame.
    pub max_iterations: usize,
    /// One result per output frame of the contact segment `c0..=t'_end`, in order.
    pub frames: Vec<FrameResult>,
    /// First output frame of `frames` (c0).
    pub first_frame: usize,
    /// Fraction of `frames` that met the stop rule (the threshold, or the recording's fit
    /// where tighter).
    pub converged_fraction: f64,
    /// Output frames that did not meet the stop rule (the reason is in each frame's `stop`).
    pub not_converged: Vec<usize>,
    /// Output frames whose solution was not finite (the warm start was kept).
    pub non_finite: Vec<usize>,
    /// Mean iterations per frame.
    pub mean_iterations: f64,
    /// Most iterations in one frame.
    pub max_iterations_used: usize,
    /// D_C of the IK solution before smoothing: mean over frames with contacts of
    /// `mean_mm` [mm].
    pub d_c_mm: f64,
    /// Smallest hand-barrier clearance over all frames [mm]; `None` without barriers.
    pub min_barrier_clearance_mm: Option<f64>,
    /// Frames per stop reason other than `converged`.
    pub stop_reasons: std::collections::BTreeMap<StopReason, usize>,
    /// Deepest penetration probe over all frames [mm] (0 without an object field).
    pub max_penetration_mm: f64,
    /// Objective minimized.
    pub objective: Objective,
    /// Wall time [s].
    pub time_s: f64,
}

/// Runs stage 4 (see the module docs).
///
/// For every output frame `t` in `[c0, t'_end]`: the correspondences of
/// `t* = warp.retime.timewarp.source_frame(t)`, the object pose of the warped object at
/// `t`, and the warm start of [`Params::warm_start`] from the previous frame's solution (the
/// first frame starts from `init`, e.g. the baseline hand). A frame whose `t*` has no
/// correspondences (a gap inside the segment) has nothing to fit: its hand is the previous
/// solution carried along by the object's motion. Frames outside the contact segment are
/// copied from `init` (the rigid shift of stage 1). `demo` must be in robot joint order
/// ([`Demo::check_robot`]) and `init` must have one frame per output frame.
pub fn run(
    robot: &Robot,
    demo: &Demo,
    warp: &ObjectWarp,
    init: &HandPath,
    barriers: &[CollisionShape],
    object: Option<&ObjectSdf>,
    params: &Params,
) -> (HandPath, Stats) {
    let clock = Instant::now();
    let plan = &warp.plan;
    let (c0, c1) = (plan.segment.start, plan.segment.end);
    let t_end = plan.t_end_new();
    let path = warp.path();
    assert_eq!(
        init.len(),
        plan.frames_out(),
        "init must have one frame per output frame"
    );
    let names: std::collections::HashMap<&str, LinkId> = robot
        .links()
        .iter()
        .enumerate()
        .map(|(i, l)| (l.name.as_str(), LinkId(i as u32)))
        .collect();
    let resolved: Vec<Vec<ResolvedContact>> = demo.frames[c0..=c1]
        .iter()
        .map(|f| {
            f.contacts
                .iter()
                .map(|c| ResolvedContact {
                    link: *names
                        .get(c.link.as_str())
                        .unwrap_or_else(|| panic!("{:?} is not a link of the robot", c.link)),
                    hand_point: c.hand_point,
                    object_point: c.object_point,
                })
                .collect()
        })
        .collect();

    let threshold_m = params.threshold_mm * 1e-3;
    let recording_m = (params.objective == Objective::NonPenetrating)
        .then(|| recording_targets_m(robot, demo, warp));
    let mut out = init.clone();
    let dof = robot.dof();
    let mut solver = IkSolver::new(robot, barriers, object, params.clone());
    let mut wrist = init.wrists[c0];
    let mut q = init.q(c0).to_vec();
    let mut prev_object = path.pose(c0);
    let mut stats = Stats {
        solver: params.solver,
        threshold_mm: params.threshold_mm,
        max_iterations: params.iteration_cap(),
        first_frame: c0,
        frames: Vec::with_capacity(t_end + 1 - c0),
        ..Stats::default()
    };
    for t in c0..=t_end {
        let s = warp.source_frame(t);
        let contacts = &resolved[s - c0];
        let object_pose = path.pose(t);
        if t > c0 && (contacts.is_empty() || params.warm_start == WarmStart::FollowObject) {
            wrist = object_pose * prev_object.inverse() * wrist;
        }
        let target_m = match &recording_m {
            Some(d) if d[s - c0] > 0.0 => threshold_m.min(d[s - c0]),
            _ => threshold_m,
        };
        let r = solver.solve_within(&object_pose, contacts, &mut wrist, &mut q, target_m);
        if r.non_finite {
            stats.non_finite.push(t);
        }
        if !r.converged {
            stats.not_converged.push(t);
        }
        out.wrists[t] = wrist;
        out.joints[t * dof..(t + 1) * dof].copy_from_slice(&q);
        stats.frames.push(r);
        prev_object = object_pose;
    }
    let count = stats.frames.len().max(1) as f64;
    stats.converged_fraction = stats.frames.iter().filter(|f| f.converged).count() as f64 / count;
    stats.mean_iterations = stats.frames.iter().map(|f| f.iterations).sum::<usize>() as f64 / count;
    stats.max_iterations_used = stats.frames.iter().map(|f| f.iterations).max().unwrap_or(0);
    let with_contacts: Vec<f64> = stats
        .frames
        .iter()
        .filter(|f| f.contacts > 0)
        .map(|f| f.mean_mm)
        .collect();
    stats.d_c_mm = if with_contacts.is_empty() {
        0.0
    } else {
        with_contacts.iter().sum::<f64>() / with_contacts.len() as f64
    };
    stats.min_barrier_clearance_mm = stats
        .frames
        .iter()
        .filter_map(|f| f.min_barrier_clearance_mm)
        .reduce(f64::min);
    for f in &stats.frames {
        if f.stop != StopReason::Converged {
            *stats.stop_reasons.entry(f.stop).or_default() += 1;
        }
    }
    stats.max_penetration_mm = stats
        .frames
        .iter()
        .map(|f| f.max_penetration_mm)
        .fold(0.0, f64::max);
    stats.objective = params.objective;
    stats.time_s = clock.elapsed().as_secs_f64();
    (out, stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::shape::ShapeKind;
    use nalgebra::{Translation3, UnitQuaternion};

    fn hand() -> Robot {
        crate::robot::test_human_hand()
    }

    /// The analytic gradient of `F` (Adam) and the LM model gradient `2g` (IRLS, so it
    /// touches `F`) agree with central differences of `F` in the tangent parameterization,
    /// with every term active: contacts, a barrier box overlapping the palm, and the
    /// non-penetration term against an object the fingers enter.
    #[test]
    fn gradients_match_finite_differences() {
        let robot = hand();
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
        let barriers = [barrier];
        // The object: the apple mesh (about 4 cm in radius) around the index tip, so the
        // fingers are inside it.
        let sdf = ObjectSdf::new(
            crate::synth::objects::object_mesh(crate::synth::objects::ObjectKind::Apple),
            &crate::geometry::SdfParams::default(),
        )
        .unwrap();
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
            let mut ik = IkSolver::new(&robot, &barriers, Some(&sdf), params);
            ik.wrist0 = wrist;
            ik.q0.copy_from_slice(&q);
            ik.object_from_world = Some(object_pose.inverse());
            if objective == Objective::Paper {
                ik.object_from_world = None;
            }
            let e = ik.evaluate(false, &object_pose, &contacts, &wrist, &q);
            assert!(e.barrier > 0.0, "{e:?}");
            assert!(
                e.penetration > 0.0 || objective == Objective::Paper,
                "{e:?}"
            );
            let analytic: Vec<f64> = match solver {
                Solver::Adam => {
                    ik.gradient(&object_pose, &contacts);
                    ik.g.iter().copied().collect()
                }
                Solver::Lm => {
                    ik.linearize(&object_pose, &contacts, &wrist, &q);
                    ik.g.iter().map(|v| 2.0 * v).collect()
                }
            };
            let n = contacts.len();
            let h = 1e-7;
            for k in 0..ik.n {
                let mut f = |sign: f64| {
                    let (mut w, mut qq) = (wrist, q.clone());
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
                    ik.evaluate(false, &object_pose, &contacts, &w, &qq)
                        .total(n)
                };
                let fd = (f(1.0) - f(-1.0)) / (2.0 * h);
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
