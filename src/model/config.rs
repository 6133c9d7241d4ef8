//! Warp configurations: the `dexwarp.config/1` file format.
//!
//! A config names a demonstration and a scene, and asks for waypoints
//! `w_j = (p_j, r_j, t_j, t'_j)` (world position, rotation imposed over the segment that ends
//! at `w_j`, input frame, output frame), barriers (names of scene items with role `barrier`),
//! and an optional new start and end position of the object (docs/METHOD.md, Inputs).

use std::path::{Path, PathBuf};

use nalgebra::{Unit, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use super::json::{self, FieldCheck};
use super::modes::{GraspMode, Objective, PushoutMode, RetimeMode, WarmStart};
use super::scene::{Role, Scene};
use crate::limits::MAX_JOINT_ABS;
use crate::{Error, Limits, Result};

/// The `format` value of a config file.
pub const CONFIG_FORMAT: &str = "dexwarp.config/1";

/// A rotation stored as axis and angle.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisAngleJson {
    /// Rotation axis (any non-zero length; normalized on load).
    pub axis: [f64; 3],
    /// Angle [rad].
    pub angle: f64,
}

/// A waypoint as stored.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WaypointJson {
    /// World position the object origin must pass through [m].
    pub position: [f64; 3],
    /// Rotation imposed over the segment ending at this waypoint (identity when absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation: Option<AxisAngleJson>,
    /// Input frame at which the object passes `position`.
    pub t: f64,
    /// Output frame at which the warped object passes `position`.
    pub t_new: f64,
}

/// Default bounding radius of the hand about the wrist for its barrier push-out [m].
pub const DEFAULT_HAND_RADIUS_M: f64 = 0.05;

/// Default clearance every hand link keeps from the barriers outside contact [m].
pub const DEFAULT_HAND_CLEARANCE_M: f64 = 0.002;

/// Tunable parameters of a warp, with the paper's defaults.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WarpParams {
    /// α: displacement at which the blend is fully linear [m]. Default 0.2.
    pub alpha_m: f64,
    /// IK stop threshold on the mean contact distance [mm]. Default 3.5.
    pub threshold_mm: f64,
    /// m: barrier margin of the IK barrier term [m]. Default 0.05.
    pub margin_m: f64,
    /// n: steepness of the IK barrier term. Default 2.
    pub steepness: f64,
    /// Barrier push-out mode. Default `paper`.
    pub pushout: PushoutMode,
    /// Step of the barrier push-out along the centroid ray [m]. Default 0.002.
    pub pushout_step_m: f64,
    /// What the IK minimizes: `non_penetrating` (default: the paper's objective plus
    /// non-penetration of the object) or `paper` (the objective as printed).
    pub objective: Objective,
    /// Weight of the IK's non-penetration term (see `hand::ik`; 0 = off). Default 1.
    pub penetration_weight: f64,
    /// Deepest a finger may sit in the object in a converged IK frame [mm]. Absent (the
    /// default): the demonstration's own deepest hand-object penetration plus 1 mm, within
    /// [1, 4] mm ([`auto_penetration_tolerance_mm`]), so the IK holds the fingers at about
    /// the depth the recorded grasp itself has.
    pub penetration_tolerance_mm: Option<f64>,
    /// Warm start of each IK frame: `follow_object` (default: the previous frame's solution
    /// carried along by the object's motion) or `previous` (that solution unchanged, the
    /// paper's literal reading). With `previous` the hand lags a moving object by up to the
    /// threshold and the object runs into the fingers: on the 14 built-in configs the physics
    /// pass count was 1 (10 mm) and 3 (3.5 mm) with `previous`, 6 and 4 with `follow_object`
    /// (measured on one revision, before the teapot grasp was fixed). `rigid` starts every
    /// frame from the rigid transfer of the recorded hand, so the grasp stays nearer the
    /// recording's (docs/RESULTS.md "At 10 fps": fewer frames meet the threshold, and the
    /// teapot at 10 fps keeps its grasp as at 30 fps).
    pub warm_start: WarmStart,
    /// Timewarp rule: `chord` (default: constant speed per segment, resting frames keep time),
    /// `paper` (chord length without a floor, as the paper's reference code; the built-in
    /// configs use it) or `speed` (the demonstration's speed profile).
    pub retime: RetimeMode,
    /// `chord` and `paper`: the object's speed is continuous at the waypoints (default true;
    /// `false`: constant speed per segment, jumping at every waypoint, as the paper).
    pub continuous_speed: bool,
    /// Bounding radius of the hand about the wrist for the hand's barrier push-out outside
    /// the contact segment [m] (`hand::pushout`); 0 turns it off. Default 0.05.
    pub hand_radius_m: f64,
    /// How the hand holds the object over the contact segment: `held` (default: one grasp,
    /// the average of the frames' IK solutions in the object's frame, at every frame but
    /// where the hand is still closing on the resting object; `hand::smooth::hold_grasp`)
    /// or `per_frame` (the paper: every frame keeps its IK solution).
    pub grasp: GraspMode,
    /// Clearance every link of the hand keeps from every barrier outside the contact segment,
    /// the hand push-out's link pass [m] (`hand::pushout`); 0 turns it off. Default 0.002.
    pub hand_clearance_m: f64,
    /// Output frame of the end of the contact segment; by default the input's end shifted by
    /// the last waypoint's time shift.
    pub end_t_new: Option<f64>,
    /// The physics replay's parameters this config sets, by name (`max_dt_s`,
    /// `hand_friction`, `max_mean_rotation_error_deg`, ...), over the replay's defaults;
    /// absent: the defaults. Checked against the replay's parameters when a run starts.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub physics: Option<serde_json::Map<String, serde_json::Value>>,
}

impl Default for WarpParams {
    fn default() -> Self {
        WarpParams {
            alpha_m: 0.2,
            threshold_mm: 3.5,
            margin_m: 0.05,
            steepness: 2.0,
            pushout: PushoutMode::Paper,
            pushout_step_m: 0.002,
            objective: Objective::NonPenetrating,
            penetration_weight: 1.0,
            penetration_tolerance_mm: None,
            warm_start: WarmStart::FollowObject,
            retime: RetimeMode::Chord,
            continuous_speed: true,
            hand_radius_m: DEFAULT_HAND_RADIUS_M,
            grasp: GraspMode::default(),
            hand_clearance_m: DEFAULT_HAND_CLEARANCE_M,
            end_t_new: None,
            physics: None,
        }
    }
}

/// A config file exactly as stored.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConfigFile {
    pub format: String,
    pub name: String,
    /// What the config asks of the method, in words (optional; shown in reports).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// Demonstration file, relative to the config.
    pub demo: PathBuf,
    /// Scene file, relative to the config.
    pub scene: PathBuf,
    #[serde(default)]
    pub waypoints: Vec<WaypointJson>,
    /// Names of scene items with role `barrier`.
    #[serde(default)]
    pub barriers: Vec<String>,
    /// New start position of the object [m].
    #[serde(default)]
    pub start: Option<[f64; 3]>,
    /// New end position of the object [m].
    #[serde(default)]
    pub end: Option<[f64; 3]>,
    #[serde(default)]
    pub params: WarpParams,
}

/// A validated waypoint.
#[derive(Clone, Debug, PartialEq)]
pub struct Waypoint {
    pub position: Vector3<f64>,
    pub rotation: UnitQuaternion<f64>,
    /// Input frame.
    pub t: usize,
    /// Output frame.
    pub t_new: usize,
}

/// A validated config. Paths are resolved against the config file.
#[derive(Clone, Debug, PartialEq)]
pub struct WarpConfig {
    pub name: String,
    /// What the config asks of the method (optional).
    pub description: Option<String>,
    pub demo: PathBuf,
    pub scene: PathBuf,
    pub waypoints: Vec<Waypoint>,
    pub barriers: Vec<String>,
    pub start: Option<Vector3<f64>>,
    pub end: Option<Vector3<f64>>,
    pub params: WarpParams,
    pub source: PathBuf,
}

impl WarpConfig {
    /// Reads and validates a config file (the demo and scene are not loaded here).
    pub fn load(path: &Path, limits: &Limits) -> Result<WarpConfig> {
        let file: ConfigFile = json::read_json_format(path, limits, CONFIG_FORMAT)?;
        WarpConfig::from_file(file, path)
    }

    /// Validates a parsed config.
    pub fn from_file(file: ConfigFile, path: &Path) -> Result<WarpConfig> {
        let c = FieldCheck::new(path);
        if file.format != CONFIG_FORMAT {
            return Err(Error::invalid(
                path,
                "format",
                format!(
                    "is {:?}; expected {CONFIG_FORMAT:?} (is this a warp config?)",
                    file.format
                ),
            ));
        }
        check_output_name(path, "name", &file.name)?;
        let mut waypoints = Vec::with_capacity(file.waypoints.len());
        for (j, w) in file.waypoints.iter().enumerate() {
            let position = c.world_vec3(|| format!("waypoints[{j}].position"), w.position)?;
            let rotation = match w.rotation {
                None => UnitQuaternion::identity(),
                Some(r) => axis_angle(&c, j, r)?,
            };
            let t = frame_index(&c, || format!("waypoints[{j}].t"), w.t, "input")?;
            let t_new = frame_index(&c, || format!("waypoints[{j}].t_new"), w.t_new, "output")?;
            if let Some(prev) = waypoints.last() {
                let prev: &Waypoint = prev;
                if t <= prev.t {
                    return Err(Error::invalid(
                        path,
                        format!("waypoints[{j}].t"),
                        format!(
                            "is {t}, not after waypoints[{}].t = {}; waypoints must have strictly increasing t",
                            j - 1,
                            prev.t
                        ),
                    ));
                }
                if t_new <= prev.t_new {
                    return Err(Error::invalid(
                        path,
                        format!("waypoints[{j}].t_new"),
                        format!(
                            "is {t_new}, not after waypoints[{}].t_new = {}; waypoints must have strictly increasing t_new",
                            j - 1,
                            prev.t_new
                        ),
                    ));
                }
            }
            waypoints.push(Waypoint {
                position,
                rotation,
                t,
                t_new,
            });
        }
        let start = file
            .start
            .map(|s| c.world_vec3(|| "start".into(), s))
            .transpose()?;
        let end = file
            .end
            .map(|s| c.world_vec3(|| "end".into(), s))
            .transpose()?;
        check_params(&c, &file.params)?;
        Ok(WarpConfig {
            name: file.name,
            description: file.description,
            demo: json::resolve_relative(path, &file.demo),
            scene: json::resolve_relative(path, &file.scene),
            waypoints,
            barriers: file.barriers,
            start,
            end,
            params: file.params,
            source: path.to_path_buf(),
        })
    }

    /// Checks that every barrier names a scene item with role `barrier`.
    pub fn check_scene(&self, scene: &Scene) -> Result<()> {
        for (j, name) in self.barriers.iter().enumerate() {
            match scene.item(name) {
                None => {
                    return Err(Error::invalid(
                        &self.source,
                        format!("barriers[{j}]"),
                        format!(
                            "{name:?} is not an item of scene {:?}; barriers there: {}",
                            scene.name,
                            scene.names_with_role(Role::Barrier).join(", ")
                        ),
                    ));
                }
                Some(item) if item.role != Role::Barrier => {
                    return Err(Error::invalid(
                        &self.source,
                        format!("barriers[{j}]"),
                        format!(
                            "{name:?} is a {} in scene {:?}, not a barrier; supports are what the object may rest on and are never pushed out of",
                            item.role.as_str(),
                            scene.name
                        ),
                    ));
                }
                Some(_) => {}
            }
        }
        Ok(())
    }

    /// Checks the waypoint times against a demonstration with `frames` frames whose contact
    /// segment is `[c0, c1]`: every waypoint must lie strictly inside it.
    pub fn check_demo(&self, frames: usize, c0: usize, c1: usize) -> Result<()> {
        for (j, w) in self.waypoints.iter().enumerate() {
            if w.t >= frames {
                return Err(Error::invalid(
                    &self.source,
                    format!("waypoints[{j}].t"),
                    format!(
                        "is {}, outside the demonstration (frames 0..{}); expected a frame inside the contact segment {c0}..{c1}",
                        w.t,
                        frames - 1
                    ),
                ));
            }
            if w.t <= c0 || w.t >= c1 {
                return Err(Error::invalid(
                    &self.source,
                    format!("waypoints[{j}].t"),
                    format!(
                        "is {}; expected a frame strictly inside the contact segment {c0}..{c1} (the segment ends are the implicit start and end waypoints)",
                        w.t
                    ),
                ));
            }
            if w.t_new <= c0 {
                return Err(Error::invalid(
                    &self.source,
                    format!("waypoints[{j}].t_new"),
                    format!(
                        "is {}; expected an output frame after the start of the contact segment ({c0}), which is not retimed",
                        w.t_new
                    ),
                ));
            }
        }
        if let (Some(e), Some(last)) = (self.params.end_t_new, self.waypoints.last())
            && (e as usize) <= last.t_new
        {
            return Err(Error::invalid(
                &self.source,
                "params.end_t_new",
                format!(
                    "is {e}; expected an output frame after the last waypoint's t_new ({})",
                    last.t_new
                ),
            ));
        }
        Ok(())
    }
}

fn axis_angle(c: &FieldCheck, j: usize, r: AxisAngleJson) -> Result<UnitQuaternion<f64>> {
    let axis = c.vec3(|| format!("waypoints[{j}].rotation.axis"), r.axis)?;
    let angle = c.in_range(
        || format!("waypoints[{j}].rotation.angle"),
        r.angle,
        (-MAX_JOINT_ABS, MAX_JOINT_ABS),
        "rad",
    )?;
    if angle == 0.0 {
        return Ok(UnitQuaternion::identity());
    }
    // Scaled by its largest component first: the norm of [1e300, 1e300, 0] overflows.
    let largest = axis.amax();
    if largest == 0.0 {
        return Err(Error::invalid(
            c.path,
            format!("waypoints[{j}].rotation.axis"),
            format!(
                "is {:?} with angle {angle}; expected a non-zero axis",
                r.axis
            ),
        ));
    }
    Ok(UnitQuaternion::from_axis_angle(
        &Unit::new_normalize(axis / largest),
        angle,
    ))
}

fn frame_index(c: &FieldCheck, field: impl Fn() -> String, v: f64, which: &str) -> Result<usize> {
    let v = c.finite(&field, v)?;
    if v < 0.0 || v.fract() != 0.0 || v > 1e9 {
        return Err(Error::invalid(
            c.path,
            field(),
            format!("is {v}; expected an {which} frame index (a whole number >= 0)"),
        ));
    }
    Ok(v as usize)
}

/// Longest output name: a config's `name` or a batch item's (the warped demonstration is
/// `<name>.demo.json`, a batch item's folder `<name>`).
pub const MAX_NAME_CHARS: usize = 128;

/// Checks that `name` is a file name and not a path: not empty, at most [`MAX_NAME_CHARS`]
/// characters, no `/`, `\\` or NUL, not `.` or `..`, no leading `.` (hidden files and our
/// temporaries), no control characters. `field` names it in the error.
pub fn check_output_name(path: &Path, field: &str, name: &str) -> Result<()> {
    let problem = if name.is_empty() {
        Some("is empty".to_string())
    } else if name.chars().count() > MAX_NAME_CHARS {
        Some(format!("has {} characters", name.chars().count()))
    } else if name.contains(['/', '\\']) {
        Some("contains a path separator".to_string())
    } else if name.starts_with('.') {
        Some("starts with '.' (a hidden file, or '..')".to_string())
    } else if name.chars().any(char::is_control) {
        Some("contains a control character".to_string())
    } else {
        None
    };
    match problem {
        None => Ok(()),
        Some(p) => Err(Error::invalid(
            path,
            field,
            format!(
                "{name:?} {p}; expected a plain file name of 1 to {MAX_NAME_CHARS} characters without slashes, not starting with '.' (it names the output files)"
            ),
        )),
    }
}

/// The IK's penetration tolerance when a config gives none [mm]: the demonstration's own
/// deepest hand-object penetration `original_mm` plus 1 mm, at least 1 mm and at most 4 mm
/// (below the physics check's 5 mm limit). The IK's hinge starts at half of it, so the
/// fingers rest at about the recorded grasp's own depth: a grasp the recording holds with
/// 1.5 mm of finger overlap is not recovered with 0.5 mm.
pub fn auto_penetration_tolerance_mm(original_mm: f64) -> f64 {
    if original_mm.is_finite() {
        (original_mm + 1.0).clamp(1.0, 4.0)
    } else {
        1.0
    }
}

/// The ranges of a config's `params`: beyond them a parameter only makes sense as a typo, and
/// some set work (the push-out walks its ray in steps of `pushout_step_m`).
fn check_params(c: &FieldCheck, p: &WarpParams) -> Result<()> {
    c.in_range(|| "params.alpha_m".into(), p.alpha_m, (1e-6, 1e3), "m")?;
    c.in_range(
        || "params.threshold_mm".into(),
        p.threshold_mm,
        (1e-3, 1e4),
        "mm",
    )?;
    c.in_range(|| "params.margin_m".into(), p.margin_m, (1e-6, 10.0), "m")?;
    c.in_range(
        || "params.steepness".into(),
        p.steepness,
        (1e-3, 100.0),
        "exponent",
    )?;
    c.in_range(
        || "params.pushout_step_m".into(),
        p.pushout_step_m,
        (1e-5, 1.0),
        "m",
    )?;
    c.in_range(
        || "params.penetration_weight".into(),
        p.penetration_weight,
        (0.0, 1e6),
        "weight",
    )?;
    if let Some(tol) = p.penetration_tolerance_mm {
        c.in_range(
            || "params.penetration_tolerance_mm".into(),
            tol,
            (0.01, 100.0),
            "mm",
        )?;
    }
    c.non_negative(|| "params.hand_radius_m".into(), p.hand_radius_m, "m")?;
    c.in_range(
        || "params.hand_clearance_m".into(),
        p.hand_clearance_m,
        (0.0, 0.05),
        "m",
    )?;
    if let Some(e) = p.end_t_new {
        frame_index(c, || "params.end_t_new".into(), e, "output")?;
    }
    Ok(())
}
