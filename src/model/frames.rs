//! `frames.csv`: per-frame metrics of one output trajectory.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::model::json::write_atomic;
use crate::{Error, Result};

/// One row of `frames.csv`. Empty cells are values a run did not compute.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameRow {
    /// Output frame.
    pub frame: usize,
    /// Input frame whose correspondences this frame uses (`t*`).
    pub source_frame: usize,
    /// True inside the output contact segment.
    pub in_contact: bool,
    /// Warped object position [m].
    pub object_x: f64,
    pub object_y: f64,
    pub object_z: f64,
    /// Output wrist position [m].
    pub wrist_x: f64,
    pub wrist_y: f64,
    pub wrist_z: f64,
    /// Mean correspondence distance of the output [mm].
    pub d_c_mm: Option<f64>,
    /// Mean correspondence distance before smoothing [mm].
    pub d_c_unsmoothed_mm: Option<f64>,
    /// IK: frame met the threshold.
    pub ik_converged: Option<bool>,
    /// IK iterations of the frame.
    pub ik_iterations: Option<usize>,
    /// IK: why the frame's solve ended (`converged`, `penetration_limited`, ...).
    pub ik_stop: Option<String>,
    /// IK: deepest penetration probe in the object at the solution [mm].
    pub ik_penetration_mm: Option<f64>,
    /// Physics: simulated vs warped object position [mm].
    pub physics_position_error_mm: Option<f64>,
    /// Physics: simulated vs warped object rotation [deg].
    pub physics_rotation_error_deg: Option<f64>,
}

impl FrameRow {
    /// The row of output frame `frame` of `demo`, whose correspondences come from input frame
    /// `source_frame`, with its contact distance `d_c_mm` (before and after smoothing alike
    /// until the caller sets them apart).
    pub fn new(
        demo: &crate::model::Demo,
        frame: usize,
        source_frame: usize,
        in_contact: bool,
        d_c_mm: Option<f64>,
    ) -> FrameRow {
        let f = &demo.frames[frame];
        let (o, w) = (f.object.translation.vector, f.wrist.translation.vector);
        FrameRow {
            frame,
            source_frame,
            in_contact,
            object_x: o.x,
            object_y: o.y,
            object_z: o.z,
            wrist_x: w.x,
            wrist_y: w.y,
            wrist_z: w.z,
            d_c_mm,
            d_c_unsmoothed_mm: d_c_mm,
            ..FrameRow::default()
        }
    }
}

/// Writes rows as CSV atomically.
pub fn write_csv(path: &Path, rows: &[FrameRow]) -> Result<()> {
    write_atomic(path, &csv_bytes(path, rows)?)
}

/// The CSV text of `rows` (`path` names the file in errors).
pub fn csv_bytes(path: &Path, rows: &[FrameRow]) -> Result<Vec<u8>> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r)
            .map_err(|e| Error::write(path, std::io::Error::other(e)))?;
    }
    w.into_inner()
        .map_err(|e| Error::write(path, std::io::Error::other(e.to_string())))
}
