//! The contact IK's parameters, its solvers and stop reasons, the resolved correspondences
//! it fits and the outcome of one frame.

use std::fmt;
use std::str::FromStr;

use nalgebra::Point3;
use serde::{Deserialize, Serialize};

use crate::model::{Contact, Objective, WarmStart};
use crate::robot::{LinkId, Robot};

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
    /// LM only: how many accepted steps in a row must each lower `F` by less than
    /// [`Params::stall_decrease`] of itself to end a frame as a local minimum. Default 3. One
    /// small decrease is also what a step shortened by raised damping gives, right after
    /// rejected trials, in a valley the next steps follow: with 1, 85 consecutive frames of
    /// mug_pass_in_sink at 10 mm stopped after 8 iterations each at a D_C of 13 mm that 10-50
    /// iterations bring under the threshold (767 iterations in all against 179 with 3, on the
    /// demonstrations of 5a49336; on today's, stage 4 alone leaves 54 frames short of the
    /// threshold with 1 and 8 with 3: `one_small_decrease_does_not_end_a_frame`).
    pub stall_steps: usize,
    /// Grasp synthesis only: weight of the surface-point penetration term
    /// `Σ_{p ∈ P(θ)} (min(0, SDF(p, object))/m)²` on the links' surface points against the
    /// object shape given by [`IkSolver::with_surface_object`](super::IkSolver::with_surface_object) (a triangle mesh). It keeps
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
            stall_steps: 3,
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
/// ([`Demo::check_robot`](crate::model::Demo::check_robot) rejects such demonstrations).
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
