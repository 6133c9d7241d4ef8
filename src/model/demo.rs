//! Demonstrations: the `dexwarp.demo/1` file format and its validated in-memory form.
//!
//! A demonstration is N frames at a fixed rate. Each frame holds the object pose, the floating
//! wrist pose, the hand's actuated joint angles (named by `joint_names`), and the contact
//! correspondences: a point on a named hand link (link frame) paired with a point on the object
//! (object frame). Warped outputs also carry `timewarp`, the output time of each input frame.
//!
//! Conventions: quaternions are stored `[w, x, y, z]`; lengths in metres; angles in radians;
//! paths inside a file are relative to that file.

use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion};
use serde::{Deserialize, Serialize};

use super::json::{self, FieldCheck};
use crate::limits::{FPS_RANGE_HZ, MASS_RANGE_KG, MAX_JOINT_ABS};
use crate::{Error, Limits, Result};

/// The `format` value of a demonstration file.
pub const DEMO_FORMAT: &str = "dexwarp.demo/1";

/// A pose as stored in JSON.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseJson {
    /// World position [m].
    pub position: [f64; 3],
    /// Orientation `[w, x, y, z]`.
    pub orientation: [f64; 4],
}

impl PoseJson {
    pub fn from_isometry(iso: &Isometry3<f64>) -> Self {
        PoseJson {
            position: iso.translation.vector.into(),
            orientation: crate::math::rotation::quat_to_wxyz(&iso.rotation),
        }
    }
}

/// The object of a demonstration, as stored.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectJson {
    pub name: String,
    /// Mesh file (OBJ or STL), relative to the demonstration file.
    pub mesh: PathBuf,
    /// Mass [kg].
    pub mass: f64,
}

/// One contact correspondence, as stored.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactJson {
    /// Hand link name (a link of the robot).
    pub link: String,
    /// Point on the hand, in the link frame [m].
    pub hand_point: [f64; 3],
    /// Point on the object, in the object frame [m].
    pub object_point: [f64; 3],
}

/// One frame, as stored.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrameJson {
    pub object: PoseJson,
    pub wrist: PoseJson,
    /// Joint angles [rad] (or [m] for prismatic joints) in the order of `joint_names`.
    pub joints: Vec<f64>,
    #[serde(default)]
    pub contacts: Vec<ContactJson>,
}

/// A demonstration file exactly as stored (`dexwarp.demo/1`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DemoFile {
    pub format: String,
    pub name: String,
    /// Frame rate [Hz].
    pub fps: f64,
    /// URDF of the hand, relative to the demonstration file.
    pub robot: PathBuf,
    pub object: ObjectJson,
    /// Actuated joints of the robot, in the order of every frame's `joints`.
    pub joint_names: Vec<String>,
    pub frames: Vec<FrameJson>,
    /// Output time [frames] of each frame of the demonstration this one was warped from
    /// (warped outputs only; its length is the input's frame count).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub timewarp: Option<Vec<f64>>,
    /// Scene the demonstration happens in, relative to the file (`validate` replays it there).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scene: Option<PathBuf>,
    /// Scene items the hand and object must avoid (barriers of the warp, for `validate`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub barriers: Vec<String>,
    /// The robot link whose pose `wrist` is; the links above it are not part of the hand.
    /// Absent: the URDF root.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wrist_link: Option<String>,
}

/// A contact correspondence in memory.
#[derive(Clone, Debug, PartialEq)]
pub struct Contact {
    pub link: String,
    /// Point on the hand in the link frame [m].
    pub hand_point: Point3<f64>,
    /// Point on the object in the object frame [m].
    pub object_point: Point3<f64>,
}

/// One validated frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Object pose in the world.
    pub object: Isometry3<f64>,
    /// Wrist (robot root link) pose in the world.
    pub wrist: Isometry3<f64>,
    /// Joint values in the order of [`Demo::joint_names`].
    pub joints: Vec<f64>,
    pub contacts: Vec<Contact>,
}

/// The object of a demonstration.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectInfo {
    pub name: String,
    /// Resolved mesh path.
    pub mesh: PathBuf,
    /// Mass [kg].
    pub mass: f64,
}

/// A validated demonstration. Paths are resolved against the file it was read from.
#[derive(Clone, Debug, PartialEq)]
pub struct Demo {
    pub name: String,
    /// Frame rate [Hz].
    pub fps: f64,
    /// Resolved URDF path.
    pub robot: PathBuf,
    pub object: ObjectInfo,
    pub joint_names: Vec<String>,
    pub frames: Vec<Frame>,
    /// Output time [frames] of each input frame, for warped outputs.
    pub timewarp: Option<Vec<f64>>,
    /// Resolved scene path, when the file names one.
    pub scene: Option<PathBuf>,
    /// Barrier names of the scene that apply to this demonstration.
    pub barriers: Vec<String>,
    /// The link the wrist pose is of (`None`: the URDF root); see [`Demo::load_robot`].
    pub wrist_link: Option<String>,
    /// The file this demonstration was read from, for messages.
    pub source: PathBuf,
}

/// The in-contact segment of a demonstration: first and last frame with correspondences.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ContactSegment {
    /// First frame with correspondences (c0).
    pub start: usize,
    /// Last frame with correspondences (c1), inclusive.
    pub end: usize,
    /// Frames inside [c0, c1] without correspondences. The method treats [c0, c1] as one
    /// segment anyway (docs/METHOD.md, Inputs); reports state this count.
    pub gap_frames: usize,
}

impl Demo {
    /// Reads and validates a demonstration file. Does not load the robot: see
    /// [`Demo::check_robot`].
    pub fn load(path: &Path, limits: &Limits) -> Result<Demo> {
        let file: DemoFile = json::read_json_format(path, limits, DEMO_FORMAT)?;
        Demo::from_file(file, path, limits)
    }

    /// Validates a parsed file; `path` is used to resolve relative paths and in messages.
    pub fn from_file(file: DemoFile, path: &Path, limits: &Limits) -> Result<Demo> {
        let c = FieldCheck::new(path);
        check_header(path, &file.format, file.fps, file.frames.len(), limits)?;
        let n = file.frames.len();
        c.in_range(
            || "object.mass".into(),
            file.object.mass,
            MASS_RANGE_KG,
            "kg",
        )?;
        let robot = json::resolve_relative(path, &file.robot);
        require_file(path, "robot", &robot)?;
        let mesh = json::resolve_relative(path, &file.object.mesh);
        require_file(path, "object.mesh", &mesh)?;
        let scene = match &file.scene {
            Some(sc) => {
                let p = json::resolve_relative(path, sc);
                require_file(path, "scene", &p)?;
                Some(p)
            }
            None => None,
        };
        let mut seen = std::collections::HashSet::new();
        for (j, name) in file.joint_names.iter().enumerate() {
            if !seen.insert(name.as_str()) {
                return Err(Error::invalid(
                    path,
                    format!("joint_names[{j}]"),
                    format!("{name:?} appears twice; each joint must be listed once"),
                ));
            }
        }

        let dof = file.joint_names.len();
        let mut frames = Vec::with_capacity(n);
        for (i, f) in file.frames.into_iter().enumerate() {
            frames.push(validate_frame(&c, i, f, dof, limits)?);
        }
        if let Some(tw) = &file.timewarp {
            // τ has one entry per frame of the demonstration that was warped (the input), each
            // an output time inside this file's frames.
            if tw.is_empty() || tw.len() as u64 > limits.max_frames {
                return Err(Error::invalid(
                    path,
                    "timewarp",
                    format!(
                        "has {} entries; expected one output time per input frame (1 to {})",
                        tw.len(),
                        limits.max_frames
                    ),
                ));
            }
            for (i, &t) in tw.iter().enumerate() {
                c.finite(|| format!("timewarp[{i}]"), t)?;
                if t < -1e-9 || t > (n - 1) as f64 + 1e-9 {
                    return Err(Error::invalid(
                        path,
                        format!("timewarp[{i}]"),
                        format!(
                            "is {t}; expected an output time within the file's frames 0..{}",
                            n - 1
                        ),
                    ));
                }
                if i > 0 && t <= tw[i - 1] {
                    return Err(Error::invalid(
                        path,
                        format!("timewarp[{i}]"),
                        format!(
                            "is {t}, not after timewarp[{}] = {}; expected strictly increasing output times",
                            i - 1,
                            tw[i - 1]
                        ),
                    ));
                }
            }
        }
        Ok(Demo {
            name: file.name,
            fps: file.fps,
            robot,
            object: ObjectInfo {
                name: file.object.name,
                mesh,
                mass: file.object.mass,
            },
            joint_names: file.joint_names,
            frames,
            timewarp: file.timewarp,
            scene,
            barriers: file.barriers,
            wrist_link: file.wrist_link,
            source: path.to_path_buf(),
        })
    }

    /// The in-contact segment [c0, c1], or `None` when no frame has correspondences.
    pub fn contact_segment(&self) -> Option<ContactSegment> {
        let start = self.frames.iter().position(|f| !f.contacts.is_empty())?;
        let end = self.frames.iter().rposition(|f| !f.contacts.is_empty())?;
        let gap_frames = self.frames[start..=end]
            .iter()
            .filter(|f| f.contacts.is_empty())
            .count();
        Some(ContactSegment {
            start,
            end,
            gap_frames,
        })
    }

    /// Converts back to the stored form. Paths are written relative to `out_path`'s folder
    /// when possible, so the file can be moved with its assets.
    pub fn to_file(&self, out_path: &Path) -> DemoFile {
        let base = out_path.parent().unwrap_or(Path::new("."));
        DemoFile {
            format: DEMO_FORMAT.into(),
            name: self.name.clone(),
            fps: self.fps,
            robot: relative_path(base, &self.robot),
            object: ObjectJson {
                name: self.object.name.clone(),
                mesh: relative_path(base, &self.object.mesh),
                mass: self.object.mass,
            },
            joint_names: self.joint_names.clone(),
            frames: self
                .frames
                .iter()
                .map(|f| FrameJson {
                    object: PoseJson::from_isometry(&f.object),
                    wrist: PoseJson::from_isometry(&f.wrist),
                    joints: f.joints.clone(),
                    contacts: f
                        .contacts
                        .iter()
                        .map(|c| ContactJson {
                            link: c.link.clone(),
                            hand_point: c.hand_point.coords.into(),
                            object_point: c.object_point.coords.into(),
                        })
                        .collect(),
                })
                .collect(),
            timewarp: self.timewarp.clone(),
            scene: self.scene.as_ref().map(|s| relative_path(base, s)),
            barriers: self.barriers.clone(),
            wrist_link: self.wrist_link.clone(),
        }
    }

    /// The file's text as [`Demo::save`] writes it to `path`: compact JSON on one line (paths
    /// relative to `path`'s folder). The frames are machine data: pretty-printed, with one
    /// number a line, a 504-frame mug output (59 correspondences in each of its 244 contact
    /// frames) took 4.2 MB, compact 1.8 MB.
    pub fn to_bytes(&self, path: &Path) -> Result<Vec<u8>> {
        let mut text = serde_json::to_vec(&self.to_file(path)).map_err(|e| Error::Parse {
            path: path.to_path_buf(),
            field: "(output)".into(),
            message: e.to_string(),
        })?;
        text.push(b'\n');
        Ok(text)
    }

    /// Writes the demonstration to `path` atomically ([`Demo::to_bytes`]).
    pub fn save(&self, path: &Path) -> Result<()> {
        json::write_atomic(path, &self.to_bytes(path)?)
    }

    /// The demonstration exactly as [`Demo::load`] reads back the file [`Demo::save`]
    /// writes: the stored form checked by the same loader, which renormalizes every
    /// quaternion (`q / ‖q‖`, which moves the last bits of a quaternion whose computed norm
    /// is not exactly 1). So a replay of the returned demo and `dexwarp validate` of the
    /// written file simulate the same poses to the bit. The JSON text itself is skipped:
    /// every number survives it unchanged (shortest round-trip output, correctly rounded
    /// parsing: serde_json's `float_roundtrip`), so the loader sees the same values either
    /// way (test `one_verdict::warp_replays_exactly_the_file_validate_reads`, on every
    /// built-in config and both hand methods); for the 20 MB output of teapot_pour_cups the
    /// text took 0.21 s, the rest 0.006 s (medians of 5, release). Paths are written
    /// relative to [`Demo::source`]'s folder and resolved back from it.
    pub fn as_stored(&self, limits: &Limits) -> Result<Demo> {
        let path = &self.source;
        Demo::from_file(self.to_file(path), path, limits)
    }
}

fn validate_frame(
    c: &FieldCheck,
    i: usize,
    f: FrameJson,
    dof: usize,
    limits: &Limits,
) -> Result<Frame> {
    let object = pose(c, i, "object", &f.object)?;
    let wrist = pose(c, i, "wrist", &f.wrist)?;
    if f.joints.len() != dof {
        return Err(Error::invalid(
            c.path,
            format!("frames[{i}].joints"),
            format!(
                "has {} values; expected one per entry of joint_names ({dof})",
                f.joints.len()
            ),
        ));
    }
    for (j, &v) in f.joints.iter().enumerate() {
        c.in_range(
            || format!("frames[{i}].joints[{j}]"),
            v,
            (-MAX_JOINT_ABS, MAX_JOINT_ABS),
            "rad, or m for a prismatic joint",
        )?;
    }
    if f.contacts.len() as u64 > limits.max_contacts_per_frame {
        return Err(Error::TooLarge {
            path: c.path.to_path_buf(),
            what: "the number of contacts in one frame",
            found: f.contacts.len() as u64,
            limit: limits.max_contacts_per_frame,
            flag: "--max-contacts",
        });
    }
    let mut contacts = Vec::with_capacity(f.contacts.len());
    for (k, ct) in f.contacts.into_iter().enumerate() {
        let hand_point = c.local_point3(
            || format!("frames[{i}].contacts[{k}].hand_point"),
            ct.hand_point,
        )?;
        let object_point = c.local_point3(
            || format!("frames[{i}].contacts[{k}].object_point"),
            ct.object_point,
        )?;
        if ct.link.is_empty() {
            return Err(Error::invalid(
                c.path,
                format!("frames[{i}].contacts[{k}].link"),
                "is empty; expected a link name of the robot",
            ));
        }
        contacts.push(Contact {
            link: ct.link,
            hand_point,
            object_point,
        });
    }
    Ok(Frame {
        object,
        wrist,
        joints: f.joints,
        contacts,
    })
}

fn pose(c: &FieldCheck, i: usize, which: &str, p: &PoseJson) -> Result<Isometry3<f64>> {
    let t = c.world_vec3(|| format!("frames[{i}].{which}.position"), p.position)?;
    let r: UnitQuaternion<f64> =
        c.quaternion(|| format!("frames[{i}].{which}.orientation"), p.orientation)?;
    Ok(Isometry3::from_parts(Translation3::from(t), r))
}

/// Checks that `target`, named by `field` of `path`, is a file, naming the field if not.
pub(crate) fn require_file(path: &Path, field: &str, target: &Path) -> Result<()> {
    match std::fs::metadata(target) {
        Ok(m) if m.is_file() => Ok(()),
        Ok(_) => Err(Error::invalid(
            path,
            field,
            format!("{} is not a file", target.display()),
        )),
        Err(e) => Err(Error::invalid(
            path,
            field,
            format!(
                "cannot open {}: {e} (paths are relative to the file that names them)",
                target.display()
            ),
        )),
    }
}

/// `target` relative to `base` when both share a prefix, otherwise `target` as an absolute
/// path; either may be relative to the working directory, and `base` need not exist yet.
pub fn relative_path(base: &Path, target: &Path) -> PathBuf {
    let (base, target_abs) = (absolute(base), absolute(target));
    let b: Vec<_> = base.components().collect();
    let t: Vec<_> = target_abs.components().collect();
    let common = b.iter().zip(&t).take_while(|(x, y)| x == y).count();
    if common == 0 {
        return target_abs;
    }
    let mut out = PathBuf::new();
    for _ in common..b.len() {
        out.push("..");
    }
    for c in &t[common..] {
        out.push(c);
    }
    out
}

/// `p` as an absolute path with symbolic links resolved, also when it does not exist yet
/// (an output folder): its deepest existing ancestor is resolved and the rest appended. A
/// path relative to the working directory is taken from it.
fn absolute(p: &Path) -> PathBuf {
    let abs = std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let mut existing = abs.as_path();
    let mut rest = Vec::new();
    loop {
        if let Ok(c) = std::fs::canonicalize(existing) {
            return rest
                .iter()
                .rev()
                .fold(c, |acc: PathBuf, part| acc.join(part));
        }
        match (existing.parent(), existing.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name.to_os_string());
                existing = parent;
            }
            _ => return abs,
        }
    }
}

/// The checks every reader of a demonstration file makes before its frames: the format tag,
/// the frame rate, and a frame count of at least one and within `--max-frames`.
pub(crate) fn check_header(
    path: &Path,
    format: &str,
    fps: f64,
    frames: usize,
    limits: &Limits,
) -> Result<()> {
    if format != DEMO_FORMAT {
        return Err(Error::invalid(
            path,
            "format",
            format!("is {format:?}; expected {DEMO_FORMAT:?} (is this a demonstration file?)"),
        ));
    }
    FieldCheck::new(path).in_range(|| "fps".into(), fps, FPS_RANGE_HZ, "frames per second")?;
    if frames == 0 {
        return Err(Error::invalid(
            path,
            "frames",
            "is empty; expected at least one frame",
        ));
    }
    if frames as u64 > limits.max_frames {
        return Err(Error::TooLarge {
            path: path.to_path_buf(),
            what: "the number of frames",
            found: frames as u64,
            limit: limits.max_frames,
            flag: "--max-frames",
        });
    }
    Ok(())
}
