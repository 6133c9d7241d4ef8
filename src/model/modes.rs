//! The variants of the stages a config chooses among, as plain data: each stage reads the
//! choice from here, and the config file, the command line and the reports name it with
//! the same words.

use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// Barrier push-out mode (stage 2).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PushoutMode {
    /// The paper's: convex hull inflated about its centroid, push along the centroid ray.
    #[default]
    Paper,
    /// Exact clearance: the object's bounding ball must clear the barrier's hull.
    Exact,
}

/// Timewarp rule of the retiming (stage 3; `warp::retime` says what each rule does).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RetimeMode {
    /// Constant speed along each segment between waypoints (the paper).
    #[default]
    Chord,
    /// Keep the demonstration's speed profile, scaled by the stretch of each step.
    Speed,
    /// Chord length without a floor, as the paper's reference code: resting frames get almost
    /// no output time (the retiming's `PAPER_EPS_M` keeps τ strictly increasing).
    Paper,
}

impl RetimeMode {
    /// The name used in config files and reports.
    pub fn as_str(self) -> &'static str {
        match self {
            RetimeMode::Chord => "chord",
            RetimeMode::Speed => "speed",
            RetimeMode::Paper => "paper",
        }
    }
}

/// What the IK minimizes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Objective {
    /// Contacts and barriers as in the paper, plus non-penetration of the object (default).
    #[default]
    NonPenetrating,
    /// The paper's objective as printed: contacts and barriers only.
    Paper,
}

impl Objective {
    /// The name used in configs, reports and on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            Objective::NonPenetrating => "non_penetrating",
            Objective::Paper => "paper",
        }
    }
}

impl FromStr for Objective {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "non_penetrating" => Ok(Objective::NonPenetrating),
            "paper" => Ok(Objective::Paper),
            _ => Err(format!(
                "unknown IK objective {s:?}; expected \"non_penetrating\" or \"paper\""
            )),
        }
    }
}

/// Where each frame's solve starts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WarmStart {
    /// The previous frame's solution, unchanged (docs/METHOD.md, the paper). Default.
    #[default]
    Previous,
    /// The previous frame's solution carried along by the object's motion between the two
    /// frames, `W ← O(t)·O(t−1)⁻¹·W` (beyond the paper: fewer iterations, less lag).
    FollowObject,
    /// The rigid transfer of the recorded hand at that frame (the baseline's pose): every
    /// frame starts from the recording's grasp and stops at the first pose that meets the
    /// stop rule, so the solutions stay as near the recorded grasp as the threshold allows
    /// instead of wandering from frame to frame with the correspondences.
    Rigid,
}

/// How the recovered hand holds the object over the contact segment (stage 5).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GraspMode {
    /// Every frame keeps its own IK solution (the paper).
    PerFrame,
    /// One grasp for the segment: the average of the frames' IK solutions in the object's
    /// frame, placed on the object at every frame (`hand::smooth::hold_grasp`), except where
    /// the hand is still closing on the resting object before the carry
    /// (`hand::smooth::carried`; there the per-frame solution, blended into the held grasp
    /// over the carry's first 0.25 s, the grasp averaged from the carry on) and near a
    /// barrier, where the hand moves toward the per-frame solution only as far as the hand
    /// clearance asks (`hand::smooth::release_held`). Default.
    #[default]
    Held,
}
