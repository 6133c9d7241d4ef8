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
//! non-penetration term is ours (the default [`Objective::NonPenetrating`](crate::model::Objective::NonPenetrating)): `C(θ)` are the
//! links' penetration probes (balls `B(c, r)` inside the collision geometry, see
//! [`crate::robot::probes`]), `φ` is the object's signed distance field
//! ([`crate::geometry::sdf`], right for unions of overlapping parts), `r − φ(c)` the probe's
//! depth in the object, and the hinge starts at `a = tolerance / 2`, so fingers may rest on
//! or slightly in the surface (the demonstrations' own fingers sit up to about 1 mm in) but
//! are pushed out before they reach the tolerance. Why: correspondences are cleaned by a
//! distance threshold (each hand point a few millimetres off the surface is paired with its
//! nearest surface point), so every pair points into the object and fitting the pairs
//! exactly presses the fingers in; the term makes "closer to the contacts" stop at the
//! surface. [`Objective::Paper`](crate::model::Objective::Paper) drops it: the paper's objective as printed, for
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
//! stops early, not converged, at a local minimum that misses the stop rule
//! ([`Params::stall_steps`] accepted steps in a row each lower `F` by less than
//! [`Params::stall_decrease`] of itself, or the step vanishes): typically fingers that cannot
//! come closer without pressing in, or a barrier.
//!
//! **`adam`**: the paper's solver, faithful: Adam (β = 0.9, 0.999, ε = 1e-8, learning rate
//! 0.01, moments reset every frame) on exactly `F` (no proximal term; with the paper's
//! objective, exactly the printed one), with the parameter
//! vector wrist translation [m], wrist rotation (local steps `R ← exp(δω)·R`, moments on the
//! tangent vector) [rad], joints [rad], clamped to the limits after every step.
//!
//! Mimic joints are folded into their drivers by the point Jacobian. Nothing allocates per
//! iteration: every buffer lives in [`IkSolver`].

mod driver;
mod geometry;
mod params;
mod solver;

pub use driver::{Stats, run};
pub use params::{
    FrameResult, Params, ResolvedContact, Solver, StopReason, UnknownSolver, resolve_contacts,
};
pub use solver::IkSolver;
