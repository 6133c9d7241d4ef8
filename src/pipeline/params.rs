//! The one place where a config and a run's options become the stages' parameters: the
//! object stages', the contact IK's, the hand push-out's and the physics replay's. Every
//! command and the Python binding build their [`Options`] with the same builder and get the
//! same parameters from the same config.

use std::path::PathBuf;

use serde_json::Value;

use super::{HandMethod, Options};
use crate::hand::ik::{self, Solver};
use crate::hand::{pushout, smooth};
use crate::model::{Objective, WarmStart, WarpConfig};
use crate::physics::{self, HandModel};
use crate::warp::ObjectParams;
use crate::{Error, Limits, Result};

/// The physics replay of a run, on top of the config's `params.physics`: whether the
/// robustness margin is measured, the hand model and the ensemble when the caller names them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PhysicsOptions {
    /// Also replay the margin's conditions when the nominal replay passes.
    pub margin: bool,
    /// The hand model; `None` keeps the config's (kinematic by default).
    pub hand: Option<HandModel>,
    /// Members of the ensemble verdict, K; `None` keeps the config's (8 by default).
    pub ensemble: Option<usize>,
    /// Seed of the ensemble's draws; `None` keeps the config's (0 by default).
    pub ensemble_seed: Option<u64>,
    /// Most members while the decision is uncertain; `None` keeps the config's (32 by
    /// default).
    pub ensemble_max: Option<usize>,
    /// The object's collision shape; `None` keeps the config's (convex parts by default).
    pub object_collider: Option<physics::ObjectCollider>,
}

impl PhysicsOptions {
    /// `base` with these options applied.
    pub fn apply(&self, mut base: physics::Params) -> physics::Params {
        base.margin |= self.margin;
        if let Some(hand) = self.hand {
            base.hand = hand;
        }
        if let Some(k) = self.ensemble {
            base.ensemble.members = k;
        }
        if let Some(seed) = self.ensemble_seed {
            base.ensemble.seed = seed;
        }
        if let Some(n) = self.ensemble_max {
            base.ensemble.max_members = n;
        }
        if let Some(c) = self.object_collider {
            base.decomposition.collider = c;
        }
        base
    }
}

impl Options {
    /// Options of a run with `hand`: LM for contact IK, the physics replay on, the config's
    /// values for everything else, default limits.
    pub fn new(hand: HandMethod) -> Options {
        Options {
            hand,
            physics: Some(PhysicsOptions::default()),
            ..Options::default()
        }
    }

    /// Warp this demonstration instead of the one the config names.
    pub fn demo(mut self, demo: Option<PathBuf>) -> Options {
        self.demo = demo;
        self
    }

    /// The IK threshold [mm], instead of the config's when `Some`.
    pub fn threshold_mm(mut self, threshold_mm: Option<f64>) -> Options {
        self.threshold_mm = threshold_mm;
        self
    }

    /// The IK solver.
    pub fn solver(mut self, solver: Solver) -> Options {
        self.solver = solver;
        self
    }

    /// The IK objective, instead of the config's when `Some`.
    pub fn objective(mut self, objective: Option<Objective>) -> Options {
        self.objective = objective;
        self
    }

    /// The IK's penetration weight, instead of the config's when `Some`.
    pub fn penetration_weight(mut self, weight: Option<f64>) -> Options {
        self.penetration_weight = weight;
        self
    }

    /// The IK warm start, instead of the config's when `Some`.
    pub fn warm_start(mut self, warm_start: Option<WarmStart>) -> Options {
        self.warm_start = warm_start;
        self
    }

    /// The physics replay (`None` skips it).
    pub fn physics(mut self, physics: Option<PhysicsOptions>) -> Options {
        self.physics = physics;
        self
    }

    /// Size limits on the inputs and the work.
    pub fn limits(mut self, limits: Limits) -> Options {
        self.limits = limits;
        self
    }
}

/// Every stage's parameters for one run.
#[derive(Clone, Debug)]
pub struct StageParams {
    /// Spatial warp, barrier push-out, retiming.
    pub object: ObjectParams,
    /// Contact IK, but for the penetration tolerance, which a config may leave to the
    /// demonstration (see [`StageParams::ik`]).
    pub ik: ik::Params,
    /// The hand's push-out outside the contact segment (its blend at the demonstration's
    /// rate).
    pub hand_pushout: pushout::Params,
    /// Smoothing inside the contact segment (contact IK), at the demonstration's rate.
    pub smooth: smooth::Params,
    /// The physics replay; `None` skips it.
    pub physics: Option<physics::Params>,
}

impl StageParams {
    /// The parameters `config` asks for with `options` on top, for a demonstration recorded
    /// at `fps` (the windows the hand stages give in seconds, in its frames). Fails, naming
    /// the config and the field, when its `params.physics` block names no physics parameter
    /// or has a value of the wrong type.
    pub fn resolve(config: &WarpConfig, fps: f64, options: &Options) -> Result<StageParams> {
        let p = &config.params;
        let ik = ik::Params {
            solver: options.solver,
            threshold_mm: options.threshold_mm.unwrap_or(p.threshold_mm),
            margin_m: p.margin_m,
            steepness: p.steepness,
            objective: options.objective.unwrap_or(p.objective),
            penetration_weight: options.penetration_weight.unwrap_or(p.penetration_weight),
            warm_start: options.warm_start.unwrap_or(p.warm_start),
            ..ik::Params::default()
        };
        let hand_pushout = pushout::Params {
            radius_m: p.hand_radius_m,
            mode: p.pushout,
            step_m: p.pushout_step_m,
            link_clearance_m: p.hand_clearance_m,
            ..pushout::Params::default()
        }
        .at_fps(fps);
        let physics = match &options.physics {
            Some(o) => Some(o.apply(physics_params(config)?)),
            None => None,
        };
        Ok(StageParams {
            object: ObjectParams::from_config(p),
            ik,
            hand_pushout,
            smooth: smooth::Params::at_fps(fps),
            physics,
        })
    }

    /// The contact IK's parameters with the penetration tolerance: the config's, else
    /// `auto_mm` (the demonstration's own deepest penetration plus a millimetre).
    pub fn ik(&self, config: &WarpConfig, auto_mm: impl FnOnce() -> f64) -> ik::Params {
        ik::Params {
            penetration_tolerance_mm: config
                .params
                .penetration_tolerance_mm
                .unwrap_or_else(auto_mm),
            ..self.ik.clone()
        }
    }
}

/// The physics parameters of a config: the defaults with its `params.physics` block on top.
pub fn physics_params(config: &WarpConfig) -> Result<physics::Params> {
    physics_params_of(config.params.physics.as_ref(), &config.source)
}

/// The defaults with a `params.physics` block on top; errors name `source` and the field.
pub fn physics_params_of(
    block: Option<&serde_json::Map<String, Value>>,
    source: &std::path::Path,
) -> Result<physics::Params> {
    let Some(block) = block else {
        return Ok(physics::Params::default());
    };
    let field = field_of;
    let Value::Object(mut merged) =
        serde_json::to_value(physics::Params::default()).expect("physics parameters serialize")
    else {
        unreachable!("physics parameters serialize as an object")
    };
    for (key, value) in block {
        if !merged.contains_key(key) {
            let mut known: Vec<&String> = merged.keys().collect();
            known.sort();
            return Err(Error::invalid(
                source,
                field(key),
                format!(
                    "is not a physics parameter; expected one of {}",
                    known
                        .iter()
                        .map(|k| k.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
        // Each value alone, so a wrong one is named by its own key.
        let mut one = merged.clone();
        one.insert(key.clone(), value.clone());
        if let Err(e) = serde_json::from_value::<physics::Params>(Value::Object(one)) {
            return Err(Error::invalid(source, field(key), format!("{e}")));
        }
        merged.insert(key.clone(), value.clone());
    }
    let params: physics::Params = serde_json::from_value(Value::Object(merged))
        .map_err(|e| Error::invalid(source, "params.physics", format!("{e}")))?;
    // The replay's own check, its error moved onto the config's field.
    params.check().map_err(|e| match e {
        Error::Invalid { field, message, .. } => {
            Error::invalid(source, self::field_of(&field), message)
        }
        other => other,
    })?;
    Ok(params)
}

/// The config field of physics parameter `key`.
fn field_of(key: &str) -> String {
    format!("params.physics.{key}")
}
