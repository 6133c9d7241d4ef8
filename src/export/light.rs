//! A demonstration read for export only: poses and joints, correspondences skipped.
//!
//! A reproduce output holds gigabytes of correspondences that a state-only dataset never
//! uses; parsing them into vectors dominated an export. Here they are skipped by the JSON
//! parser (`IgnoredAny`), and only what the dataset takes is checked, as the demonstration
//! loader checks it: the format, `fps`, the frame count limit, finite values, joint counts,
//! and unit quaternions (normalized by the same rule, so the values equal the loader's).

use std::path::Path;

use serde::Deserialize;
use serde::de::IgnoredAny;

use crate::math::rotation::{quat_from_wxyz, quat_to_wxyz};
use crate::model::demo::PoseJson;
use crate::{Error, Limits, Result};

#[derive(Deserialize)]
struct ObjectName {
    name: String,
}

#[derive(Deserialize)]
struct LightFrame {
    object: PoseJson,
    wrist: PoseJson,
    joints: Vec<f64>,
    #[serde(default)]
    #[allow(dead_code)]
    contacts: IgnoredAny,
}

#[derive(Deserialize)]
struct LightFile {
    format: String,
    name: String,
    fps: f64,
    robot: std::path::PathBuf,
    object: ObjectName,
    joint_names: Vec<String>,
    frames: Vec<LightFrame>,
}

/// The parts of a demonstration a dataset takes.
#[derive(Debug)]
pub struct LightDemo {
    pub name: String,
    pub fps: f64,
    robot: std::path::PathBuf,
    pub object_name: String,
    pub joint_names: Vec<String>,
    /// Per frame: object pose (7), wrist pose (7), joints.
    frames: Vec<([f64; 7], [f64; 7], Vec<f64>)>,
}

impl LightDemo {
    /// The robot's URDF file stem (`human_hand`).
    pub fn robot_stem(&self) -> String {
        self.robot
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    }

    /// `observation.state` and `observation.environment_state` rows, every `stride`-th frame.
    pub fn rows(&self, stride: usize) -> (Vec<Vec<f32>>, Vec<Vec<f32>>) {
        let mut state = Vec::new();
        let mut object = Vec::new();
        for (o, w, q) in self.frames.iter().step_by(stride.max(1)) {
            let mut s: Vec<f32> = w.iter().map(|&v| v as f32).collect();
            s.extend(q.iter().map(|&v| v as f32));
            state.push(s);
            object.push(o.iter().map(|&v| v as f32).collect());
        }
        (state, object)
    }
}

fn pose(path: &Path, field: impl Fn() -> String, p: &PoseJson) -> Result<[f64; 7]> {
    if p.position.iter().any(|v| !v.is_finite()) {
        return Err(Error::invalid(
            path,
            format!("{}.position", field()),
            "holds a non-finite number; expected [x, y, z] in metres",
        ));
    }
    let q = quat_from_wxyz(p.orientation).map_err(|e| {
        Error::invalid(
            path,
            format!("{}.orientation", field()),
            format!("{e}; expected a unit quaternion [w, x, y, z]"),
        )
    })?;
    let [w, x, y, z] = quat_to_wxyz(&q);
    let [px, py, pz] = p.position;
    Ok([px, py, pz, w, x, y, z])
}

/// Parses and checks `bytes`, the demonstration file `path`.
pub fn parse(path: &Path, bytes: &[u8], limits: &Limits) -> Result<LightDemo> {
    let file: LightFile = crate::model::json::parse_json(path, bytes)?;
    crate::model::demo::check_header(path, &file.format, file.fps, file.frames.len(), limits)?;
    let n = file.frames.len();
    let mut frames = Vec::with_capacity(n);
    for (i, f) in file.frames.into_iter().enumerate() {
        if f.joints.len() != file.joint_names.len() {
            return Err(Error::invalid(
                path,
                format!("frames[{i}].joints"),
                format!(
                    "has {} values; expected {} (one per joint_names)",
                    f.joints.len(),
                    file.joint_names.len()
                ),
            ));
        }
        if f.joints.iter().any(|v| !v.is_finite()) {
            return Err(Error::invalid(
                path,
                format!("frames[{i}].joints"),
                "holds a non-finite number; expected joint values in rad or m",
            ));
        }
        let o = pose(path, || format!("frames[{i}].object"), &f.object)?;
        let w = pose(path, || format!("frames[{i}].wrist"), &f.wrist)?;
        frames.push((o, w, f.joints));
    }
    Ok(LightDemo {
        name: file.name,
        fps: file.fps,
        robot: file.robot,
        object_name: file.object.name,
        joint_names: file.joint_names,
        frames,
    })
}
