//! What the physics stage measured, its verdict, and the conversion to the report's
//! [`PhysicsSummary`].
//!
//! Every field is a measurement, in millimetres, degrees, seconds or frames (frame indices
//! are output frames of the replayed demonstration). The verdict is `pass` exactly when
//! [`PhysicsReport::reasons`] is empty; each reason names the check, the frame and the
//! measured value against its limit.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::geometry::hull::ShapeMethod;
use crate::model::report::PhysicsSummary;

/// Simulated object pose vs the demonstration's, over all frames.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Tracking {
    pub mean_position_error_mm: f64,
    pub max_position_error_mm: f64,
    pub max_position_error_frame: usize,
    pub mean_rotation_error_deg: f64,
    pub max_rotation_error_deg: f64,
    pub max_rotation_error_frame: usize,
}

/// Why the object left the grasp.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DropCause {
    /// The hand no longer touched the object.
    LostContact,
    /// The hand still touched the object, which slid or turned out of place.
    Slipped,
}

/// A drop inside the contact segment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Drop {
    /// First frame at which the position error exceeded the drop limit.
    pub frame: usize,
    pub cause: DropCause,
    /// Position error at `frame` [mm].
    pub position_error_mm: f64,
    /// For [`DropCause::LostContact`]: first frame of the contact-less run that ends at
    /// `frame`.
    pub contact_lost_frame: Option<usize>,
    /// For [`DropCause::Slipped`]: the hand's links touching the object at `frame` (within
    /// the finger skin and the touch tolerance), in the robot's link order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub touching_links: Vec<String>,
}

/// Penetration depths of one pair type, measured with parry at the demonstration's poses.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Penetration {
    /// Deepest penetration over all frames [mm] (0 when nothing penetrates).
    pub max_mm: f64,
    /// Mean of the per-frame deepest penetration over the frames that penetrate [mm].
    pub mean_mm: f64,
    /// Frames with any penetration.
    pub frames_penetrating: usize,
    /// Frames deeper than the limit (0 without a limit).
    pub frames_over_limit: usize,
    /// The limit [mm]; `null` for pairs that are measured but not judged.
    pub limit_mm: Option<f64>,
    /// Frame of `max_mm`.
    pub worst_frame: Option<usize>,
    /// The two shapes of `max_mm`, e.g. `left_finger / counter`.
    pub worst_pair: Option<String>,
    /// Shape pairs parry cannot query (mesh against mesh), skipped.
    pub unsupported_pairs: usize,
}

/// All pair types.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Penetrations {
    pub hand_object: Penetration,
    pub hand_barrier: Penetration,
    pub object_barrier: Penetration,
    /// Measured only: a placing hand may touch the support it places on.
    pub hand_support: Penetration,
}

/// Simulation displacement (ObMan, GraspTTA): per sampled in-contact frame, the hand frozen,
/// the object at the demonstration's pose, gravity, no support.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stability {
    pub frames: Vec<usize>,
    pub displacement_mm: Vec<f64>,
    pub mean_mm: f64,
    pub max_mm: f64,
    pub max_frame: Option<usize>,
    /// Steps and step length of each test.
    pub steps: usize,
    pub dt_s: f64,
}

/// The grasp carried: the contact segment replayed with the hand on its recorded poses and
/// the object's supports taken away ([`super::carry`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Carry {
    /// The contact segment's first and last frame (frames of the demonstration).
    pub first_frame: usize,
    pub last_frame: usize,
    /// Frames replayed (fewer than the segment's when the object dropped and the replay
    /// stopped).
    pub frames_replayed: usize,
    /// The object's pose against the recorded one over the replayed frames (frames of the
    /// demonstration).
    pub tracking: Tracking,
}

/// The grasp hold test ([`super::hold`], `validate --grasp-only`, and `synth`'s choice of
/// grasp): the hand frozen at sampled contact frames, and the hand carrying the object.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GraspHold {
    /// The hand frozen at sampled contact frames, the object released without support.
    pub stability: Stability,
    /// The contact segment replayed without supports.
    pub carry: Carry,
    /// Every limit the two break, as sentences; empty when the grasp holds.
    pub reasons: Vec<String>,
}

impl GraspHold {
    /// True when the grasp holds the object both frozen and carried.
    pub fn holds(&self) -> bool {
        self.reasons.is_empty()
    }
}

/// The object after the last contact frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Release {
    /// The last contact frame (c1).
    pub frame: usize,
    /// At the last frame the object is within the gap of a support and has stayed put over
    /// the rest window.
    pub rests_on_support: bool,
    /// The nearest support and its distance at the last frame.
    pub support: Option<String>,
    pub support_gap_mm: Option<f64>,
    /// Largest distance of the object from its final position over the rest window [mm].
    pub final_motion_mm: f64,
    /// Object speed at the last frame [m/s].
    pub final_speed_m_s: f64,
    /// The hand moved the released object off its plan (see [`Pushed`]); `None` otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pushed: Option<Pushed>,
    /// The object's largest turn after the release (absent in reports written before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub turn: Option<Turn>,
}

/// The object's largest turn after the release: its rotation from its simulated pose at the
/// last contact frame. A diagnostic, no limit of its own (`filter --max-release-turn-deg`):
/// a retreat that spins the put-down object stays within the tracking limits, and a round
/// object the opening fingers roll 15-20° is no failure.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Turn {
    pub deg: f64,
    pub frame: usize,
    /// When the hand turned it: the last frame up to `frame` at which the hand touches the
    /// object once it has turned 5° ([`super::checks::find_turn`]), with the links touching
    /// there. `None` when the object turned by itself (a round object rolling as it settles).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub by_hand: Option<Touch>,
}

impl Turn {
    /// The release turn a written report's physics summary holds (`release.turn`); `None`
    /// without a release, or in a report written before release turns.
    pub fn of(summary: &PhysicsSummary) -> Option<Turn> {
        let turn = summary.measures.get("release")?.get("turn")?;
        serde_json::from_value(turn.clone()).ok()
    }

    /// How far the hand turned the object [deg]: the turn when the hand turned it, 0 when
    /// the object turned by itself.
    pub fn by_hand_deg(&self) -> f64 {
        if self.by_hand.is_some() {
            self.deg
        } else {
            0.0
        }
    }
}

/// The hand touching the object at a frame, and with which links.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Touch {
    pub frame: usize,
    /// The hand's links within touching reach of the object, in the robot's link order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub links: Vec<String>,
}

/// A released object the hand moved: after the last contact frame the object's position
/// error grew by more than the drop limit to above the position limit, and the hand touched
/// it in between once it had moved 10 mm from where it was let go (typically the retreat
/// sweeping a finger through a handle the object turned in the grasp). The carry itself
/// held: the trajectory fails on what the hand does after letting go.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pushed {
    /// The frame of the largest position error after the release.
    pub frame: usize,
    /// The position error there [mm].
    pub position_error_mm: f64,
    /// The position error at the last contact frame [mm].
    pub release_error_mm: f64,
    /// The last frame up to `frame` at which the hand touches the moved object.
    pub last_touch_frame: usize,
    /// The hand's links touching the object at `last_touch_frame`, in the robot's link order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub touching_links: Vec<String>,
}

/// How the hand held the simulated object: its normal contact forces at the frame times of
/// the contact segment, and how much of them the fingers' overlap with the object accounts
/// for rather than the contact skin (see the module docs of [`super`], "Finger softness").
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Grip {
    /// Frames of the contact segment.
    pub frames: usize,
    /// Of those, the frames at which the hand pressed on the object.
    pub frames_pressing: usize,
    /// Median and largest total normal force of the hand on the object over the pressing
    /// frames [N].
    pub median_normal_force_n: f64,
    pub max_normal_force_n: f64,
    /// The object's weight m·g [N], for scale.
    pub weight_n: f64,
    /// Of the normal force summed over the pressing frames, the share at contact points
    /// where the rigid shapes overlap (the rest presses through the skin alone).
    pub at_overlap_share: f64,
    /// The share the overlap accounts for when each point's force is split in proportion
    /// to its compression, overlap against skin; the skin's share is `1 −` this.
    pub from_overlap_share: f64,
}

/// How the replay ran.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ReplayInfo {
    pub frames: usize,
    /// Steps simulated.
    pub steps: usize,
    /// Steps left unstepped while the object rested out of the hand's reach
    /// ([`super::Params::skip_rest`]).
    #[serde(default)]
    pub skipped_steps: usize,
    /// The last frame replayed when the replay stopped on a decided drop
    /// ([`super::Params::stop_after_drop`]): the tracking figures and the per-frame object
    /// errors cover frames `0..=stopped_frame`, and the release is not judged.
    #[serde(default)]
    pub stopped_frame: Option<usize>,
    pub dt_s: f64,
    pub steps_per_frame: usize,
    pub solver_iterations: usize,
    /// `[c0, c1]`, `null` without contacts.
    pub contact_segment: Option<[usize; 2]>,
    pub object_parts: usize,
    pub object_shape: Option<ShapeMethod>,
    /// What the object mesh's repair changed to close it (`null` when it was closed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mesh_repair: Option<String>,
    /// The object's convex parts' volume over its mesh's (see
    /// [`crate::geometry::hull::ObjectShape::volume_ratio`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub object_volume_ratio: Option<f64>,
    /// With `object_shape: hull_fallback` of an open mesh: the simulated hull's volume and
    /// the mesh's own [cm³].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hull_fallback_volumes_cm3: Option<[f64; 2]>,
    /// The decomposition came from a cache (this process's or the one on disk).
    pub decomposition_cached: bool,
    /// First frame whose simulated object pose was not finite.
    pub diverged_frame: Option<usize>,
    /// The hand model of the replay (reports before it existed read as kinematic).
    #[serde(default)]
    pub hand: super::params::HandModel,
}

/// Wall times [s]. With [`ReplayInfo::decomposition_cached`] (a cache state), the only fields
/// that differ between two runs on the same input.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Timing {
    pub decomposition: f64,
    pub replay: f64,
    pub penetration: f64,
    pub stability: f64,
    /// The margin's extra replays (0 when not asked for).
    #[serde(default)]
    pub margin: f64,
    /// The ensemble's perturbed members (0 for a single replay).
    #[serde(default)]
    pub ensemble: f64,
    pub total: f64,
}

/// Per-frame values, for `frames.csv` and plots (not in the summary).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PerFrame {
    pub position_error_mm: Vec<f64>,
    pub rotation_error_deg: Vec<f64>,
    /// The hand touches the simulated object (within the skin and the touch tolerance).
    pub hand_touching: Vec<bool>,
    pub hand_object_penetration_mm: Vec<f64>,
    pub hand_barrier_penetration_mm: Vec<f64>,
}

/// Where the simulated object is when the contact segment starts: how far the hand's
/// approach and closing moved it before it is carried. A grasp that shoves the object as it
/// closes starts the carry this far off its plan, and every tracking limit has that much
/// less room (a diagnostic: no limit of its own).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Onset {
    /// The contact segment's first frame.
    pub frame: usize,
    /// The object's position error there [mm].
    pub position_error_mm: f64,
    /// Its rotation error there [deg].
    pub rotation_error_deg: f64,
}

/// Everything [`super::validate`] measured.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PhysicsReport {
    /// Every failed check, in words; empty = pass.
    pub reasons: Vec<String>,
    pub tracking: Tracking,
    pub drop: Option<Drop>,
    pub penetration: Penetrations,
    /// `null` without a contact segment.
    pub stability: Option<Stability>,
    /// `null` when the contact segment runs to the last frame (nothing is released).
    pub release: Option<Release>,
    /// `null` without a contact segment (reports before it existed read as `null`).
    #[serde(default)]
    pub grip: Option<Grip>,
    /// `null` without a contact segment, or when the simulated pose there is not finite.
    #[serde(default)]
    pub onset: Option<Onset>,
    pub replay: ReplayInfo,
    pub timing_s: Timing,
    /// The robustness margin ([`super::margin`]); `None` when not asked for
    /// ([`super::Params::margin`]).
    #[serde(default)]
    pub margin: Option<super::Margin>,
    /// The ensemble verdict ([`super::ensemble`]); `None` for a single replay. The other
    /// fields are its nominal member's; the reasons follow its decision.
    #[serde(default)]
    pub ensemble: Option<super::Ensemble>,
    #[serde(skip)]
    pub per_frame: PerFrame,
    /// Where the nominal replay's steps went (the physics module's profile; not in reports).
    #[serde(skip)]
    pub profile: super::replay::StepProfile,
}

impl PhysicsReport {
    /// `true` when no check failed.
    pub fn passed(&self) -> bool {
        self.reasons.is_empty()
    }

    /// `"pass"` or `"fail"`.
    pub fn verdict(&self) -> &'static str {
        if self.passed() { "pass" } else { "fail" }
    }

    /// The report's physics section: verdict, reasons and the measures (everything but the
    /// per-frame values), with `released_on_support` and `drop_frame` at the top level for
    /// filtering.
    pub fn to_summary(&self) -> PhysicsSummary {
        let mut measures = BTreeMap::new();
        let mut put = |k: &str, v: serde_json::Value| {
            measures.insert(k.to_string(), v);
        };
        put("tracking", json(&self.tracking));
        put("drop", json(&self.drop));
        put("penetration", json(&self.penetration));
        put("stability", json(&self.stability));
        put("release", json(&self.release));
        put("grip", json(&self.grip));
        put("onset", json(&self.onset));
        put("replay", json(&self.replay));
        put("timing_s", json(&self.timing_s));
        put("margin", json(&self.margin));
        put("ensemble", json(&self.ensemble));
        put(
            "robust",
            serde_json::json!(self.margin.as_ref().map(|m| m.robust)),
        );
        put(
            "drop_frame",
            serde_json::json!(self.drop.as_ref().map(|d| d.frame)),
        );
        put(
            "released_on_support",
            serde_json::json!(self.release.as_ref().map(|r| r.rests_on_support)),
        );
        PhysicsSummary {
            verdict: self.verdict().to_string(),
            reasons: self.reasons.clone(),
            measures,
        }
    }
}

/// A plain struct as a JSON value (serialising these types cannot fail).
fn json<T: Serialize>(v: &T) -> serde_json::Value {
    serde_json::to_value(v).unwrap_or(serde_json::Value::Null)
}
