//! The warp plan: waypoints completed with the implicit start and end (docs/METHOD.md, stage 1).
//!
//! The waypoint list is `[w_start, w_1..w_k, w_end]` with
//! `w_start = (p'_start or x(c0), identity, c0, c0)` and
//! `w_end = (p'_end or x(c1), identity, c1, t'_end)`. Unless the config gives `end_t_new`,
//! `t'_end = c1 + (t'_k - t_k)`: the contact segment ends shifted by the last waypoint's time
//! shift, so the post-contact duration is kept. Times must be strictly increasing in both t and
//! t'. Frames before `c0` keep their times; frames after `c1` are shifted by `t'_end - c1`.

use nalgebra::{UnitQuaternion, Vector3};

use crate::model::{ContactSegment, WarpConfig};
use crate::{Error, Result};

/// One constraint of the warp: where the object must be, when, in both time lines.
#[derive(Clone, Debug, PartialEq)]
pub struct Anchor {
    /// World position of the object origin [m].
    pub position: Vector3<f64>,
    /// Rotation imposed over the segment ending here (identity for the implicit anchors).
    pub rotation: UnitQuaternion<f64>,
    /// Input frame.
    pub t: usize,
    /// Output frame.
    pub t_new: usize,
}

/// The complete list of anchors and the frame bookkeeping of one warp.
#[derive(Clone, Debug, PartialEq)]
pub struct WarpPlan {
    /// `[w_start, w_1..w_k, w_end]`, strictly increasing in `t` and `t_new`.
    pub anchors: Vec<Anchor>,
    /// Number of input frames.
    pub frames_in: usize,
    /// The input's contact segment.
    pub segment: ContactSegment,
    /// True when a new start was given (pre-contact frames are shifted).
    pub new_start: bool,
    /// True when a new end was given (post-contact frames are shifted).
    pub new_end: bool,
}

impl WarpPlan {
    /// Builds the plan from a validated config and the input object positions.
    pub fn new(
        config: &WarpConfig,
        positions: &[Vector3<f64>],
        segment: ContactSegment,
    ) -> Result<WarpPlan> {
        let frames_in = positions.len();
        let (c0, c1) = (segment.start, segment.end);
        if c1 <= c0 {
            return Err(Error::invalid(
                &config.source,
                "demo",
                format!(
                    "the demonstration's contact segment is the single frame {c0}; a warp needs at least two in-contact frames"
                ),
            ));
        }
        config.check_demo(frames_in, c0, c1)?;
        let mut anchors = Vec::with_capacity(config.waypoints.len() + 2);
        anchors.push(Anchor {
            position: config.start.unwrap_or(positions[c0]),
            rotation: UnitQuaternion::identity(),
            t: c0,
            t_new: c0,
        });
        for w in &config.waypoints {
            anchors.push(Anchor {
                position: w.position,
                rotation: w.rotation,
                t: w.t,
                t_new: w.t_new,
            });
        }
        let last = anchors.last().expect("start anchor");
        let shift = last.t_new as i64 - last.t as i64;
        let t_end = match config.params.end_t_new {
            Some(e) => e as i64,
            None => c1 as i64 + shift,
        };
        if t_end <= last.t_new as i64 {
            return Err(Error::invalid(
                &config.source,
                "params.end_t_new",
                format!(
                    "the contact segment would end at output frame {t_end}, not after the last waypoint's t_new ({}); give a later params.end_t_new",
                    last.t_new
                ),
            ));
        }
        anchors.push(Anchor {
            position: config.end.unwrap_or(positions[c1]),
            rotation: UnitQuaternion::identity(),
            t: c1,
            t_new: t_end as usize,
        });
        Ok(WarpPlan {
            anchors,
            frames_in,
            segment,
            new_start: config.start.is_some(),
            new_end: config.end.is_some(),
        })
    }

    /// The identity plan: no waypoints, start and end where they are.
    pub fn identity(positions: &[Vector3<f64>], segment: ContactSegment) -> WarpPlan {
        let (c0, c1) = (segment.start, segment.end);
        WarpPlan {
            anchors: vec![
                Anchor {
                    position: positions[c0],
                    rotation: UnitQuaternion::identity(),
                    t: c0,
                    t_new: c0,
                },
                Anchor {
                    position: positions[c1],
                    rotation: UnitQuaternion::identity(),
                    t: c1,
                    t_new: c1,
                },
            ],
            frames_in: positions.len(),
            segment,
            new_start: false,
            new_end: false,
        }
    }

    /// Output frame of the end of the contact segment (t'_end).
    pub fn t_end_new(&self) -> usize {
        self.anchors.last().map(|a| a.t_new).unwrap_or(0)
    }

    /// Number of output frames: pre-contact, the retimed contact segment, post-contact.
    pub fn frames_out(&self) -> usize {
        self.t_end_new() + (self.frames_in - self.segment.end)
    }

    /// Time shift of the post-contact frames (t'_end - c1).
    pub fn post_shift(&self) -> i64 {
        self.t_end_new() as i64 - self.segment.end as i64
    }

    /// Cumulative rotations `C_i = r_0 r_1 ... r_i`, one per anchor.
    pub fn cumulative_rotations(&self) -> Vec<UnitQuaternion<f64>> {
        let mut acc = UnitQuaternion::identity();
        self.anchors
            .iter()
            .map(|a| {
                acc *= a.rotation;
                acc
            })
            .collect()
    }
}
