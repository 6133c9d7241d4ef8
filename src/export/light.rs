//! A demonstration read for export only: poses and joints, correspondences skipped.
//!
//! A reproduce output holds gigabytes of correspondences that a state-only dataset never
//! uses; parsing them into vectors dominated an export. Here they are skipped by the JSON
//! parser (`IgnoredAny`), and only what the dataset takes is checked, as the demonstration
//! loader checks it: the format, `fps`, the frame count limit, finite values, joint counts,
//! and unit quaternions (normalized by the same rule, so the values equal the loader's).
//!
//! Even skipped, the correspondences cost a JSON scan of every number. A file whose SHA-256
//! matches the report it was written with is known to be what our writer wrote, so
//! [`parse_verified`] first empties its `contacts` arrays with a byte scan (brackets matched
//! outside strings) and parses the rest, about a tenth of the file.

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

/// [`parse`] for a file whose bytes are known to be valid (their SHA-256 matched the report
/// they were written with): the `contacts` arrays are cut out unparsed. Any error comes from
/// [`parse`] of the whole file, so the messages are the same.
pub fn parse_verified(path: &Path, bytes: &[u8], limits: &Limits) -> Result<LightDemo> {
    match without_contacts(bytes) {
        Some(stripped) => parse(path, &stripped, limits).or_else(|_| parse(path, bytes, limits)),
        None => parse(path, bytes, limits),
    }
}

const CONTACTS_KEY: &[u8] = b"\"contacts\"";

/// `bytes` with the value of every `"contacts"` key that is an array emptied to `[]`;
/// `None` when such an array does not close.
fn without_contacts(bytes: &[u8]) -> Option<Vec<u8>> {
    let finder = memchr::memmem::Finder::new(CONTACTS_KEY);
    let mut out = Vec::with_capacity(bytes.len() / 8);
    let mut copied = 0;
    let mut from = 0;
    while let Some(k) = finder.find(&bytes[from..]) {
        let after_key = from + k + CONTACTS_KEY.len();
        from = after_key;
        let colon = skip_whitespace(bytes, after_key);
        if bytes.get(colon) != Some(&b':') {
            continue;
        }
        let open = skip_whitespace(bytes, colon + 1);
        if bytes.get(open) != Some(&b'[') {
            continue;
        }
        let close = closing_bracket(bytes, open)?;
        out.extend_from_slice(&bytes[copied..=open]);
        copied = close;
        from = close;
    }
    out.extend_from_slice(&bytes[copied..]);
    Some(out)
}

fn skip_whitespace(bytes: &[u8], mut i: usize) -> usize {
    while bytes.get(i).is_some_and(|b| b.is_ascii_whitespace()) {
        i += 1;
    }
    i
}

/// The index of the `]` that closes the `[` at `open`, brackets inside strings ignored.
fn closing_bracket(bytes: &[u8], open: usize) -> Option<usize> {
    let mut depth = 0usize;
    let mut i = open;
    loop {
        i += memchr::memchr3(b'[', b']', b'"', bytes.get(i..)?)?;
        match bytes[i] {
            b'[' => depth += 1,
            b']' => {
                depth -= 1;
                if depth == 0 {
                    return Some(i);
                }
            }
            _ => {
                // A string: to its closing quote, past escaped characters.
                i += 1;
                loop {
                    i += memchr::memchr2(b'"', b'\\', bytes.get(i..)?)?;
                    if bytes[i] == b'"' {
                        break;
                    }
                    i += 2;
                }
            }
        }
        i += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contacts_arrays_are_emptied_and_nothing_else_changes() {
        let json = br#"{"name": "contacts", "frames": [
            {"joints": [1, 2], "contacts" : [{"link": "a]\"[", "p": [[1], [2]]}]},
            {"contacts": [], "x": "\"contacts\": [1]"}, {"contacts": 3}]}"#;
        let out = without_contacts(json).unwrap();
        let expected = br#"{"name": "contacts", "frames": [
            {"joints": [1, 2], "contacts" : []},
            {"contacts": [], "x": "\"contacts\": [1]"}, {"contacts": 3}]}"#;
        assert_eq!(
            String::from_utf8_lossy(&out),
            String::from_utf8_lossy(expected)
        );
        let a: serde_json::Value = serde_json::from_slice(&out).unwrap();
        assert_eq!(a["frames"][1]["x"], "\"contacts\": [1]");
    }

    #[test]
    fn an_unclosed_array_is_refused() {
        assert_eq!(without_contacts(br#"{"contacts": [[1], "]""#), None);
        assert_eq!(without_contacts(br#"{"contacts": ["\"#), None);
    }
}
