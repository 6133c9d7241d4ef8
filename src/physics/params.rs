//! Parameters of the physics replay and the thresholds of its verdict.
//!
//! Lengths in metres, times in seconds, angles in degrees where the name says `_deg`; every
//! default is documented with the reason it was chosen (measurements in the module docs of
//! [`super`]).

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::ensemble::EnsembleParams;
use crate::geometry::hull::DecompositionParams;
use crate::{Error, Result};

/// How the hand moves in the replay.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HandModel {
    /// Every link a kinematic body on the trajectory exactly (default): the grip is the
    /// contact solver resolving the fingers' overlap with the object, through the skin.
    #[default]
    Kinematic,
    /// Every link a dynamic body of an articulated multibody: each joint driven toward the
    /// trajectory by a position motor whose torque (force, for prismatic joints) is capped
    /// at the URDF's `<limit effort>`, the hand's root link pulled toward the trajectory by
    /// a stiff spring-damper ([`Actuation`]). Answers "would a position-controlled hand with
    /// these actuators hold this?": fingers stop where the object stops them and grip with
    /// what their motors give.
    Actuated,
}

impl HandModel {
    /// The name in reports and on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            HandModel::Kinematic => "kinematic",
            HandModel::Actuated => "actuated",
        }
    }
}

/// The actuated hand's controller ([`HandModel::Actuated`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Actuation {
    /// Tracking error [rad, or m for prismatic joints] at which a joint's motor reaches its
    /// effort limit; default 0.05. The motor is a PD controller on the joint value, stiffness
    /// `effort / saturation_error` [N·m/rad], capped at the effort: a finger held 3° short of
    /// its target by the object presses with full effort.
    pub saturation_error: f64,
    /// Motor damping as a time constant [s]: damping = stiffness × this; default 0.005.
    pub damping_time_s: f64,
    /// Natural frequency [Hz] of the spring-damper pulling the root link toward the
    /// trajectory (a soft six-axis lock); default 20. The lock is acceleration-based, so gravity
    /// alone sags the hand by g / (2π · 20 Hz)² ≈ 0.6 mm (computed, not measured).
    pub wrist_frequency_hz: f64,
    /// Damping ratio of that spring-damper; default 1 (critical).
    pub wrist_damping_ratio: f64,
    /// Mass [kg] of a link whose URDF gives none; default 0.01.
    pub default_link_mass_kg: f64,
}

impl Default for Actuation {
    fn default() -> Self {
        Actuation {
            saturation_error: 0.05,
            damping_time_s: 0.005,
            wrist_frequency_hz: 20.0,
            wrist_damping_ratio: 1.0,
            default_link_mass_kg: 0.01,
        }
    }
}

/// Parameters of [`super::validate`]. `Default` is the configuration the reports use.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Params {
    /// Largest simulation step [s]; default 1/240. The frame period is split into the fewest
    /// equal steps not longer than this. 1/240 s is PyBullet's default and what ObMan and
    /// GraspTTA simulate at; a fingertip moving at 0.5 m/s moves 2 mm per step, less than
    /// the finger skin, so contacts are never stepped over.
    pub max_dt_s: f64,
    /// Solver iterations per step (Rapier's `num_solver_iterations`, which are substeps);
    /// default 4 (Rapier's default; 8 changed the gripper's tracking error by < 0.1 mm).
    pub solver_iterations: usize,
    /// Rapier's stabilization passes per substep (`num_internal_stabilization_iterations`: a
    /// solve without the penetration bias, after the biased one); default 1 (Rapier's).
    pub stabilization_iterations: usize,
    /// How far apart [m] two colliders start to make contacts (Rapier's prediction distance,
    /// `normalized_prediction_distance` at a length unit of 1 m; the hand's contact skin comes
    /// on top); default 0.02 (Rapier's). Contacts within it but apart keep the bodies from
    /// closing the gap faster than it within a step.
    pub prediction_distance_m: f64,
    /// Rapier's contact recycling (reuse of a pair's contacts while it moved less than
    /// 5 cm); default `false`. Fingers slide along objects by centimetres, and recycled
    /// contacts keep stale normals: open gripper jaws passing 10 mm beside a box pushed it
    /// 21 mm with recycling, 1.7 mm without.
    pub contact_recycling: bool,
    /// Hand-object solver manifolds whose every contact's gap (the finger skin deducted)
    /// stays at least this [m] through the step are left out of the solver (see `world.rs`);
    /// default `None`: every manifold Rapier predicts (20 mm) is solved. `Some(0.003)` makes
    /// the replay 1.6-1.8x faster but moves tracking errors by up to 6.5 mm (the physics
    /// module docs say why), so it is asked for, not the default.
    pub solver_contact_gap_m: Option<f64>,
    /// Gravity [m/s²]; default `[0, 0, -9.81]`: scenes are z-up.
    pub gravity: [f64; 3],
    /// Friction coefficient between the hand and the object; default 1.0 (rubber finger pads
    /// or skin on plastic and ceramic, 0.8-1.2). The hand's colliders use the `Max` combine
    /// rule so this value is the one used, whatever the object's own friction.
    pub hand_friction: f64,
    /// Friction coefficient of the object against supports and barriers; default 0.6
    /// (ceramic or plastic on wood or laminate).
    pub object_friction: f64,
    /// The finger softness model: Rapier contact skin on every hand collider [m]; default
    /// 0.003. The solver treats the hand as inflated by this much, so a fingertip within
    /// 3 mm of the surface already presses on it and one 2 mm inside presses with 5 mm of
    /// "compression". See the module docs of [`super`] for why and what was measured.
    pub finger_skin_m: f64,
    /// Convex decomposition of the object mesh.
    pub decomposition: DecompositionParams,
    /// How the hand moves: kinematic on the trajectory (default) or actuated.
    pub hand: HandModel,
    /// The actuated hand's controller (used with [`HandModel::Actuated`] only).
    pub actuation: Actuation,

    /// Largest mean object position error over all frames [m]; default 0.02.
    pub max_mean_position_error_m: f64,
    /// Largest object position error at any frame [m]; default 0.05.
    pub max_position_error_m: f64,
    /// Largest mean object rotation error over all frames [deg]; default 15.
    pub max_mean_rotation_error_deg: f64,
    /// Position error [m] past which the object counts as dropped, when it happens inside
    /// the contact segment; default 0.03 (ten times a good grasp's tracking error, and a
    /// free fall passes it within 80 ms, about two frames at 30 fps).
    pub drop_error_m: f64,
    /// Gap [m] between the hand's colliders and the object beyond the finger skin within
    /// which they count as touching; default 0.001.
    pub touch_tolerance_m: f64,
    /// Largest hand-object penetration at the demonstration's poses [m]; default 0.005
    /// (a fingertip pad compresses a few millimetres).
    pub max_hand_object_penetration_m: f64,
    /// Largest hand-barrier penetration at the demonstration's poses [m]; default 0.002.
    pub max_hand_barrier_penetration_m: f64,
    /// Largest object-barrier penetration at the demonstration's poses [m]; default 0.002.
    pub max_object_barrier_penetration_m: f64,

    /// In-contact frames sampled for the simulation displacement; default 8, evenly spread
    /// over the contact segment including both ends.
    pub stability_samples: usize,
    /// Steps of the simulation displacement test; default 35 (ObMan, GraspTTA).
    pub stability_steps: usize,
    /// Step of the simulation displacement test [s]; default 1/240 (PyBullet's, as in
    /// ObMan and GraspTTA).
    pub stability_dt_s: f64,
    /// Largest simulation displacement at a sampled frame [m]; default 0.03 (a free fall
    /// over the test moves 10.4 cm; a firm grasp moves a few millimetres).
    pub max_sim_displacement_m: f64,

    /// Final stretch [s] over which the released object must stay put to count as at rest;
    /// default 0.5 (clipped to the frames after the hand last touches it).
    pub rest_window_s: f64,
    /// Largest distance [m] the released object may move from its final position over the
    /// rest window; default 0.01. Not a speed threshold: a round object (the apple's faceted
    /// hull) keeps rocking by a few millimetres at 5-8 cm/s on its support for seconds.
    pub rest_motion_m: f64,
    /// Gap [m] to a support within which the released object counts as resting on it;
    /// default 0.003.
    pub support_gap_m: f64,

    /// Also replay the robustness margin's conditions when the nominal replay passes
    /// ([`super::margin`]: five more replays, in parallel); default `false`.
    pub margin: bool,

    /// Leave the world unstepped while the object rests on its support and no hand link is
    /// within reach (the approach and the retreat; see `replay.rs`); default `true`.
    pub skip_rest: bool,
    /// Stop the replay once a drop is decided (the drop window after the first frame off
    /// the plan by more than [`Params::drop_error_m`]); default `true`. The tracking figures
    /// then cover the replayed frames, and the release is not judged.
    pub stop_after_drop: bool,

    /// The ensemble verdict ([`super::ensemble`]): K replays under seeded perturbations,
    /// the trajectory kept on their pass fraction; default 8 members. `members: 1` is the
    /// single nominal replay.
    pub ensemble: EnsembleParams,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            max_dt_s: 1.0 / 240.0,
            solver_iterations: 4,
            stabilization_iterations: 1,
            prediction_distance_m: 0.02,
            contact_recycling: false,
            solver_contact_gap_m: None,
            gravity: [0.0, 0.0, -9.81],
            hand_friction: 1.0,
            object_friction: 0.6,
            finger_skin_m: 0.003,
            decomposition: DecompositionParams::default(),
            hand: HandModel::Kinematic,
            actuation: Actuation::default(),
            max_mean_position_error_m: 0.02,
            max_position_error_m: 0.05,
            max_mean_rotation_error_deg: 15.0,
            drop_error_m: 0.03,
            touch_tolerance_m: 0.001,
            max_hand_object_penetration_m: 0.005,
            max_hand_barrier_penetration_m: 0.002,
            max_object_barrier_penetration_m: 0.002,
            stability_samples: 8,
            stability_steps: 35,
            stability_dt_s: 1.0 / 240.0,
            max_sim_displacement_m: 0.03,
            rest_window_s: 0.5,
            rest_motion_m: 0.01,
            support_gap_m: 0.003,
            margin: false,
            skip_rest: true,
            stop_after_drop: true,
            ensemble: EnsembleParams::default(),
        }
    }
}

impl Params {
    /// The defaults judged by one nominal replay instead of the ensemble.
    pub fn single_replay() -> Params {
        Params {
            ensemble: EnsembleParams::single(),
            ..Params::default()
        }
    }

    /// Checks that every value is usable; the error names the field and what is expected.
    pub fn check(&self) -> Result<()> {
        let path = Path::new("physics parameters");
        let positive = |field: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(Error::invalid(
                    path,
                    field,
                    format!("is {v}; expected a finite value > 0"),
                ))
            }
        };
        let non_negative = |field: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(Error::invalid(
                    path,
                    field,
                    format!("is {v}; expected a finite value >= 0"),
                ))
            }
        };
        positive("max_dt_s", self.max_dt_s)?;
        positive("prediction_distance_m", self.prediction_distance_m)?;
        if let Some(gap) = self.solver_contact_gap_m {
            non_negative("solver_contact_gap_m", gap)?;
        }
        positive("stability_dt_s", self.stability_dt_s)?;
        for (field, v) in [
            ("hand_friction", self.hand_friction),
            ("object_friction", self.object_friction),
            ("finger_skin_m", self.finger_skin_m),
            ("touch_tolerance_m", self.touch_tolerance_m),
            ("support_gap_m", self.support_gap_m),
        ] {
            non_negative(field, v)?;
        }
        for (field, v) in [
            ("max_mean_position_error_m", self.max_mean_position_error_m),
            ("max_position_error_m", self.max_position_error_m),
            (
                "max_mean_rotation_error_deg",
                self.max_mean_rotation_error_deg,
            ),
            ("drop_error_m", self.drop_error_m),
            (
                "max_hand_object_penetration_m",
                self.max_hand_object_penetration_m,
            ),
            (
                "max_hand_barrier_penetration_m",
                self.max_hand_barrier_penetration_m,
            ),
            (
                "max_object_barrier_penetration_m",
                self.max_object_barrier_penetration_m,
            ),
            ("max_sim_displacement_m", self.max_sim_displacement_m),
            ("rest_window_s", self.rest_window_s),
            ("rest_motion_m", self.rest_motion_m),
        ] {
            positive(field, v)?;
        }
        let a = &self.actuation;
        for (field, v) in [
            ("actuation.saturation_error", a.saturation_error),
            ("actuation.wrist_frequency_hz", a.wrist_frequency_hz),
            ("actuation.default_link_mass_kg", a.default_link_mass_kg),
        ] {
            positive(field, v)?;
        }
        for (field, v) in [
            ("actuation.damping_time_s", a.damping_time_s),
            ("actuation.wrist_damping_ratio", a.wrist_damping_ratio),
        ] {
            non_negative(field, v)?;
        }
        if self.gravity.iter().any(|g| !g.is_finite()) {
            return Err(Error::invalid(
                path,
                "gravity",
                format!("is {:?}; expected finite components", self.gravity),
            ));
        }
        if self.solver_iterations == 0 {
            return Err(Error::invalid(
                path,
                "solver_iterations",
                "is 0; expected at least 1",
            ));
        }
        for (field, n) in [
            ("solver_iterations", self.solver_iterations),
            ("stabilization_iterations", self.stabilization_iterations),
        ] {
            if n > 64 {
                return Err(Error::invalid(
                    path,
                    field,
                    format!("is {n}; expected at most 64"),
                ));
            }
        }
        self.ensemble.check()?;
        let d = &self.decomposition;
        if d.resolution < 4 || d.max_parts == 0 || d.concavity.is_nan() || d.concavity < 0.0 {
            return Err(Error::invalid(
                path,
                "decomposition",
                format!("is {d:?}; expected resolution >= 4, max_parts >= 1, concavity >= 0"),
            ));
        }
        Ok(())
    }
}
