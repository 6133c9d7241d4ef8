//! Datasets in: a user's recording, or an episode of a LeRobot v3 dataset, as a
//! `dexwarp.demo/1` file that `warp` and `validate` accept.
//!
//! **CSV** (one row per frame, at `--fps`, header names the columns, any order):
//! `object.x, object.y, object.z, object.qw, object.qx, object.qy, object.qz` (object pose in
//! the world [m], quaternion `[w, x, y, z]`), `wrist.x` ... `wrist.qz` (the pose of the
//! URDF's root link, same layout), and one column per actuated joint of the URDF, named as
//! the joint [rad or m]. A `frame` column is allowed and ignored, a `timestamp` column must
//! increase row by row and is otherwise ignored; any other column is refused (a typo would
//! otherwise drop a joint silently).
//!
//! **Contacts** (optional second CSV, one row per correspondence): `frame` (0-based row of
//! the frames CSV), `link` (a link of the URDF), `hand_x, hand_y, hand_z` (point in the link
//! frame [m]), `object_x, object_y, object_z` (point in the object frame [m]). Without it the
//! correspondences are extracted geometrically, as `synth` makes them
//! ([`crate::synth::contacts::extract`]: hand surface samples every 6 mm within 5 mm of the
//! object's surface, paired with the closest surface point).
//!
//! **LeRobot v3**: one episode of a dataset; `observation.state` holds the wrist pose (7)
//! then the joints, `observation.environment_state` the object pose (7) (the layout
//! `export` writes; other keys by `--state-key`, `--object-key`). Joint order: the feature's
//! `names` after the first 7 when they name the URDF's actuated joints, else the URDF's
//! actuated order. Correspondences are extracted geometrically.
//!
//! **Cleaning** ([`clean`], unless `--no-clean`): the mesh repaired, the table inferred (or
//! `--scene`), the rest poses settled, the hand smoothed and taken out of the object and the
//! table; `NAME.import.json` says what it cost per frame.
//!
//! Every error names the file, the column (or field) and the row. The output is written
//! atomically and read back through the demonstration loader before the command succeeds.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Point3, Translation3, Vector3};

pub mod clean;
pub mod keypoints;
mod recorded;

pub use clean::{CleanOptions, RobotImport};
pub use recorded::{KeypointImport, KeypointOptions, Placement, RestCorrection, import_keypoints};

use crate::export::lerobot::{self, Column};
use crate::geometry::Mesh;
use crate::model::demo::{Frame, ObjectInfo};
use crate::model::{Contact, Demo};
use crate::robot::Robot;
use crate::synth::contacts::{self, ContactParams};
use crate::synth::proximity::ObjectGeometry;
use crate::{Error, Limits, Result};

/// What the demonstration is about, besides its frames.
#[derive(Clone, Debug)]
pub struct Target {
    /// Name of the demonstration (default: the output file's stem).
    pub name: Option<String>,
    /// URDF of the hand.
    pub robot: PathBuf,
    /// Object mesh (OBJ or STL), object frame.
    pub mesh: PathBuf,
    /// Object mass [kg].
    pub mass: f64,
    /// Object name (default: the mesh file's stem).
    pub object_name: Option<String>,
    /// The `.demo.json` file to write.
    pub out: PathBuf,
}

/// One frame before correspondences: object pose, wrist pose, joints in the robot's
/// actuated order.
type Pose = (Isometry3<f64>, Isometry3<f64>, Vec<f64>);

fn pose_columns(prefix: &str) -> [String; 7] {
    ["x", "y", "z", "qw", "qx", "qy", "qz"].map(|s| format!("{prefix}.{s}"))
}

/// A finite number or an error naming the file, row and column.
fn finite(path: &Path, row: usize, column: &str, v: f64) -> Result<f64> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Error::invalid(
            path,
            format!("row {row}, column {column}"),
            format!("is {v}; expected a finite number"),
        ))
    }
}

fn pose_from(path: &Path, row: usize, names: &[String; 7], v: &[f64]) -> Result<Isometry3<f64>> {
    let q = crate::math::rotation::quat_from_wxyz([v[3], v[4], v[5], v[6]]).map_err(|e| {
        Error::invalid(
            path,
            format!("row {row}, columns {}..{}", names[3], names[6]),
            format!("{e}; expected a unit quaternion [w, x, y, z]"),
        )
    })?;
    Ok(Isometry3::from_parts(
        Translation3::new(v[0], v[1], v[2]),
        q,
    ))
}

/// A clock column of a frames CSV (`timestamp`, `time_s`): read for its order only, which must
/// be increasing, since a clock that runs backwards or stands still means rows out of order
/// or repeated (the frame rate comes from `--fps`).
pub(crate) struct Clock {
    column: usize,
    name: String,
    last: Option<f64>,
}

impl Clock {
    /// The first of `names` in `header`, if any.
    pub(crate) fn find(header: &[String], names: &[&str]) -> Option<Self> {
        header.iter().enumerate().find_map(|(column, h)| {
            names.contains(&h.as_str()).then(|| Clock {
                column,
                name: h.clone(),
                last: None,
            })
        })
    }

    /// Checks `record` (1-based `row`) against the previous row.
    pub(crate) fn check(
        &mut self,
        path: &Path,
        row: usize,
        record: &csv::StringRecord,
    ) -> Result<()> {
        let text = record.get(self.column).unwrap_or("");
        let field = || format!("row {row}, column {}", self.name);
        let t: f64 = text.parse().map_err(|_| {
            Error::invalid(path, field(), format!("is {text:?}; expected a number"))
        })?;
        if !t.is_finite() {
            return Err(Error::invalid(
                path,
                field(),
                format!("is {t}; expected a finite time"),
            ));
        }
        if let Some(last) = self.last
            && t <= last
        {
            return Err(Error::invalid(
                path,
                field(),
                format!(
                    "is {t}, not after the previous row's {last}; expected times that increase row by row (rows out of order or repeated)"
                ),
            ));
        }
        self.last = Some(t);
        Ok(())
    }
}

/// A CSV reader over a file read whole.
pub(crate) type CsvReader = csv::Reader<std::io::Cursor<Vec<u8>>>;

/// A CSV file read whole (within `--max-file-mb`), fields trimmed: its reader, positioned
/// after the header, and the header's names through `name`.
pub(crate) fn open_csv(
    path: &Path,
    limits: &Limits,
    name: impl Fn(&str) -> String,
) -> Result<(CsvReader, Vec<String>)> {
    let bytes =
        crate::model::json::read_limited(path, limits, limits.max_file_bytes, "--max-file-mb")?;
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(std::io::Cursor::new(bytes));
    let header = rdr
        .headers()
        .map_err(|e| Error::invalid(path, "header", format!("{e}; expected a CSV header row")))?
        .iter()
        .map(name)
        .collect();
    Ok((rdr, header))
}

/// Reads the frames CSV (see the module docs) for `robot`.
pub fn read_frames_csv(path: &Path, robot: &Robot, limits: &Limits) -> Result<Vec<Pose>> {
    let (mut rdr, header) = open_csv(path, limits, str::to_string)?;
    let index: HashMap<&str, usize> = header
        .iter()
        .enumerate()
        .map(|(i, h)| (h.as_str(), i))
        .collect();
    let (obj, wrist) = (pose_columns("object"), pose_columns("wrist"));
    let joints = robot.actuated_names();
    let mut wanted: Vec<String> = obj.iter().chain(wrist.iter()).cloned().collect();
    wanted.extend(joints.iter().cloned());
    for (i, h) in header.iter().enumerate() {
        if header[..i].contains(h) {
            return Err(Error::invalid(
                path,
                format!("column {h}"),
                "appears twice in the header",
            ));
        }
        if !wanted.contains(h) && h != "frame" && h != "timestamp" {
            return Err(Error::invalid(
                path,
                format!("column {h}"),
                format!(
                    "is not a column of the format; expected object.x..object.qz, wrist.x..wrist.qz and the joints of robot {:?}: {}",
                    robot.name,
                    joints.join(", ")
                ),
            ));
        }
    }
    let mut cols = Vec::with_capacity(wanted.len());
    for w in &wanted {
        match index.get(w.as_str()) {
            Some(&i) => cols.push(i),
            None => {
                return Err(Error::invalid(
                    path,
                    format!("column {w}"),
                    "is missing from the header; expected object.x..object.qz, wrist.x..wrist.qz and one column per actuated joint of the robot",
                ));
            }
        }
    }
    let mut out = Vec::new();
    let mut values = vec![0.0; wanted.len()];
    let mut clock = Clock::find(&header, &["timestamp"]);
    for (r, rec) in rdr.records().enumerate() {
        let row = r + 1;
        if out.len() as u64 >= limits.max_frames {
            return Err(Error::TooLarge {
                path: path.to_path_buf(),
                what: "the number of frames",
                found: out.len() as u64 + 1,
                limit: limits.max_frames,
                flag: "--max-frames",
            });
        }
        let rec = rec.map_err(|e| {
            let msg = match e.kind() {
                csv::ErrorKind::UnequalLengths {
                    len, expected_len, ..
                } => format!("has {len} fields; expected {expected_len}, one per header column"),
                _ => e.to_string(),
            };
            Error::invalid(path, format!("row {row}"), msg)
        })?;
        if let Some(c) = &mut clock {
            c.check(path, row, &rec)?;
        }
        for (k, &c) in cols.iter().enumerate() {
            let text = rec.get(c).unwrap_or("");
            let v: f64 = text.parse().map_err(|_| {
                Error::invalid(
                    path,
                    format!("row {row}, column {}", wanted[k]),
                    format!("is {text:?}; expected a number"),
                )
            })?;
            values[k] = finite(path, row, &wanted[k], v)?;
        }
        let o = pose_from(path, row, &obj, &values[0..7])?;
        let w = pose_from(path, row, &wrist, &values[7..14])?;
        out.push((o, w, values[14..].to_vec()));
    }
    if out.is_empty() {
        return Err(Error::invalid(
            path,
            "rows",
            "none; expected one row per frame",
        ));
    }
    Ok(out)
}

/// Reads the contacts CSV (see the module docs) for `frames` frames of `robot`.
pub fn read_contacts_csv(
    path: &Path,
    robot: &Robot,
    frames: usize,
    limits: &Limits,
) -> Result<Vec<Vec<Contact>>> {
    let bytes =
        crate::model::json::read_limited(path, limits, limits.max_file_bytes, "--max-file-mb")?;
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(bytes.as_slice());
    let header: Vec<String> = rdr
        .headers()
        .map_err(|e| Error::invalid(path, "header", e.to_string()))?
        .iter()
        .map(str::to_string)
        .collect();
    let names = [
        "frame", "link", "hand_x", "hand_y", "hand_z", "object_x", "object_y", "object_z",
    ];
    let mut cols = [0usize; 8];
    for (k, n) in names.iter().enumerate() {
        cols[k] = header.iter().position(|h| h == n).ok_or_else(|| {
            Error::invalid(
                path,
                format!("column {n}"),
                "is missing from the header; expected frame, link, hand_x, hand_y, hand_z, object_x, object_y, object_z",
            )
        })?;
    }
    let mut out = vec![Vec::new(); frames];
    for (r, rec) in rdr.records().enumerate() {
        let row = r + 1;
        let rec = rec.map_err(|e| Error::invalid(path, format!("row {row}"), e.to_string()))?;
        let field = |k: usize| rec.get(cols[k]).unwrap_or("");
        let frame: usize = field(0).parse().map_err(|_| {
            Error::invalid(
                path,
                format!("row {row}, column frame"),
                format!(
                    "is {:?}; expected a frame number 0..{}",
                    field(0),
                    frames - 1
                ),
            )
        })?;
        if frame >= frames {
            return Err(Error::invalid(
                path,
                format!("row {row}, column frame"),
                format!(
                    "is {frame}; the frames file has {frames} rows (0..{})",
                    frames - 1
                ),
            ));
        }
        let link = field(1).to_string();
        if robot.link_id(&link).is_none() {
            return Err(Error::invalid(
                path,
                format!("row {row}, column link"),
                format!("{link:?} is not a link of robot {:?}", robot.name),
            ));
        }
        let mut v = [0.0; 6];
        for k in 0..6 {
            let text = field(k + 2);
            let x: f64 = text.parse().map_err(|_| {
                Error::invalid(
                    path,
                    format!("row {row}, column {}", names[k + 2]),
                    format!("is {text:?}; expected a number"),
                )
            })?;
            v[k] = finite(path, row, names[k + 2], x)?;
        }
        if out[frame].len() as u64 >= limits.max_contacts_per_frame {
            return Err(Error::TooLarge {
                path: path.to_path_buf(),
                what: "the correspondences of one frame",
                found: out[frame].len() as u64 + 1,
                limit: limits.max_contacts_per_frame,
                flag: "--max-contacts",
            });
        }
        out[frame].push(Contact {
            link,
            hand_point: Point3::new(v[0], v[1], v[2]),
            object_point: Point3::new(v[3], v[4], v[5]),
        });
    }
    Ok(out)
}

/// Correspondences of every frame extracted geometrically (see the module docs).
pub fn extract_contacts(
    robot: &Robot,
    object: &ObjectGeometry,
    poses: &[Pose],
) -> Vec<Vec<Contact>> {
    use rayon::prelude::*;
    let params = ContactParams::default();
    let samples = contacts::hand_samples(robot, params.spacing_mm * 1e-3);
    poses
        .par_iter()
        .map_init(
            || robot.new_link_poses(),
            |links, (o, w, q)| {
                robot.forward_kinematics(w, q, links);
                contacts::extract(
                    robot,
                    &samples,
                    links,
                    object,
                    o,
                    params.max_distance_mm * 1e-3,
                )
            },
        )
        .collect()
}

/// Assembles, writes (atomically) and reloads the demonstration, which names `scene` when
/// given.
fn finish_in(
    target: &Target,
    robot: &Robot,
    fps: f64,
    poses: Vec<Pose>,
    contacts: Option<Vec<Vec<Contact>>>,
    scene: Option<PathBuf>,
    limits: &Limits,
) -> Result<Demo> {
    let mesh = Mesh::load(&target.mesh, Vector3::repeat(1.0), limits)?;
    let contacts = match contacts {
        Some(c) => c,
        None => {
            let geo = ObjectGeometry::new(mesh)
                .ok_or_else(|| Error::invalid(&target.mesh, "(mesh)", "has no triangles"))?;
            extract_contacts(robot, &geo, &poses)
        }
    };
    let stem = |p: &Path| {
        p.file_stem()
            .map(|s| s.to_string_lossy().trim_end_matches(".demo").to_string())
            .unwrap_or_else(|| "demo".into())
    };
    let abs = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    let demo = Demo {
        name: target.name.clone().unwrap_or_else(|| stem(&target.out)),
        fps,
        robot: abs(&target.robot),
        wrist_link: None,
        object: ObjectInfo {
            name: target
                .object_name
                .clone()
                .unwrap_or_else(|| stem(&target.mesh)),
            mesh: abs(&target.mesh),
            mass: target.mass,
        },
        joint_names: robot.actuated_names(),
        frames: poses
            .into_iter()
            .zip(contacts)
            .map(|((object, wrist, joints), contacts)| Frame {
                object,
                wrist,
                joints,
                contacts,
            })
            .collect(),
        timewarp: None,
        scene: scene.as_deref().map(abs),
        barriers: Vec::new(),
        source: target.out.clone(),
    };
    if let Some(dir) = target.out.parent()
        && !dir.as_os_str().is_empty()
    {
        std::fs::create_dir_all(dir).map_err(|e| Error::write(dir, e))?;
    }
    // Paths relative to the output's folder (absolute first, so they resolve from anywhere).
    let out_abs = match target.out.parent() {
        Some(d) if !d.as_os_str().is_empty() => {
            abs(d).join(target.out.file_name().unwrap_or_default())
        }
        _ => abs(Path::new(".")).join(&target.out),
    };
    demo.save(&out_abs)?;
    // What warp and validate will read.
    let mut back = Demo::load(&target.out, limits)?;
    back.check_robot(robot)?;
    Ok(back)
}

/// What a `--csv` or `--lerobot` import made: the demonstration, and what the cleaning did
/// (`None` with `--no-clean`).
pub type Imported = (Demo, Option<RobotImport>);

/// The demonstration of `poses`: cleaned ([`clean`]) when `clean` is given, else written as
/// recorded, naming `scene` when given (checked before anything is written).
#[allow(clippy::too_many_arguments)]
fn finish_recorded(
    source: clean::Source<'_>,
    robot: &Robot,
    fps: f64,
    poses: Vec<Pose>,
    contacts: Option<Vec<Vec<Contact>>>,
    scene: Option<&Path>,
    clean: Option<&CleanOptions>,
    target: &Target,
    limits: &Limits,
) -> Result<Imported> {
    let scene = checked_scene(scene, limits)?;
    match clean {
        Some(options) => {
            let options = CleanOptions {
                scene,
                ..options.clone()
            };
            let import = clean::clean(
                source, robot, fps, poses, contacts, &options, target, limits,
            )?;
            Ok((import.demo.clone(), Some(import)))
        }
        None => Ok((
            finish_in(target, robot, fps, poses, contacts, scene, limits)?,
            None,
        )),
    }
}

/// `dexwarp import --csv`: frames (and optionally contacts) from CSV, cleaned unless `clean`
/// is `None` (see [`clean`]); the demonstration names `scene` when given (checked before
/// anything is written), else the inferred table when cleaned.
pub fn import_csv(
    frames: &Path,
    contacts_csv: Option<&Path>,
    fps: f64,
    scene: Option<&Path>,
    clean: Option<&CleanOptions>,
    target: &Target,
    limits: &Limits,
) -> Result<Imported> {
    check_fps(frames, fps)?;
    check_mass(target)?;
    let robot = Robot::from_urdf_file(&target.robot, limits)?;
    let poses = read_frames_csv(frames, &robot, limits)?;
    let contacts = match contacts_csv {
        Some(p) => Some(read_contacts_csv(p, &robot, poses.len(), limits)?),
        None => None,
    };
    let source = clean::Source {
        path: frames,
        columns: ["object.x..object.qz", "wrist.z"],
    };
    finish_recorded(
        source, &robot, fps, poses, contacts, scene, clean, target, limits,
    )
}

/// `scene` after checking that it loads (a scene the demonstration will name).
fn checked_scene(scene: Option<&Path>, limits: &Limits) -> Result<Option<PathBuf>> {
    scene
        .map(|p| crate::model::Scene::load(p, limits).map(|_| p.to_path_buf()))
        .transpose()
}

/// `--fps` of the recording `path` within the frame rates dexwarp takes.
fn check_fps(path: &Path, fps: f64) -> Result<()> {
    crate::model::json::FieldCheck::new(path)
        .in_range(
            || "--fps".into(),
            fps,
            crate::limits::FPS_RANGE_HZ,
            "frames per second",
        )
        .map(|_| ())
}

fn check_mass(target: &Target) -> Result<()> {
    crate::model::json::FieldCheck::new(&target.mesh)
        .in_range(
            || "--mass".into(),
            target.mass,
            crate::limits::MASS_RANGE_KG,
            "kg",
        )
        .map(|_| ())
}

/// Which columns of a LeRobot dataset hold what.
#[derive(Clone, Debug)]
pub struct LerobotMapping {
    /// Wrist pose (7) then joints. Default `observation.state`.
    pub state_key: String,
    /// Object pose (7). Default `observation.environment_state`.
    pub object_key: String,
}

impl Default for LerobotMapping {
    fn default() -> Self {
        LerobotMapping {
            state_key: lerobot::STATE.into(),
            object_key: lerobot::ENV_STATE.into(),
        }
    }
}

/// `dexwarp import --lerobot`: episode `episode` of the dataset at `root`, cleaned unless
/// `clean` is `None`; the demonstration names `scene` when given.
pub fn import_lerobot(
    root: &Path,
    episode: usize,
    mapping: &LerobotMapping,
    scene: Option<&Path>,
    clean: Option<&CleanOptions>,
    target: &Target,
    limits: &Limits,
) -> Result<Imported> {
    check_mass(target)?;
    let robot = Robot::from_urdf_file(&target.robot, limits)?;
    let ds = lerobot::read(root)?;
    let info_path = root.join("meta/info.json");
    let fps = ds.info["fps"].as_f64().ok_or_else(|| {
        Error::invalid(
            &info_path,
            "fps",
            "is missing or not a number; expected the frame rate [Hz]",
        )
    })?;
    let total = ds.episodes.rows;
    if episode >= total {
        return Err(Error::invalid(
            root,
            "--episode",
            format!(
                "is {episode}; the dataset has {total} episodes (0..{})",
                total.max(1) - 1
            ),
        ));
    }
    let data = root.join("data");
    let ep = ds.frames.ints(&data, "episode_index")?;
    let fi = ds.frames.ints(&data, "frame_index")?;
    let state = ds.frames.vectors(&data, &mapping.state_key)?;
    let object = ds.frames.vectors(&data, &mapping.object_key)?;
    let mut rows: Vec<usize> = (0..ds.frames.rows)
        .filter(|&i| ep[i] == episode as i64)
        .collect();
    rows.sort_by_key(|&i| fi[i]);
    if rows.is_empty() {
        return Err(Error::invalid(
            &data,
            "episode_index",
            format!("has no frame of episode {episode}"),
        ));
    }
    let order = joint_order(&robot, &ds.info, &mapping.state_key);
    let poses = episode_poses(
        &robot, &data, episode, mapping, &rows, state, object, &order,
    )?;
    let mut target = target.clone();
    if target.name.is_none()
        && let Ok(Column::Strings(n)) = ds.episodes.column(root, "quality/name")
        && let Some(Some(name)) = n.get(episode)
        && !name.is_empty()
    {
        target.name = Some(name.clone());
    }
    let columns = [mapping.object_key.as_str(), mapping.state_key.as_str()];
    let source = clean::Source {
        path: &data,
        columns,
    };
    finish_recorded(
        source, &robot, fps, poses, None, scene, clean, &target, limits,
    )
}

/// The robot joint of each joint value of the state vector: the feature's names when they
/// are the robot's joints, else the robot's order.
fn joint_order(robot: &Robot, info: &serde_json::Value, state_key: &str) -> Vec<usize> {
    let dof = robot.dof();
    let names: Vec<String> = info["features"][state_key]["names"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|v| v.as_str().map(str::to_string))
                .collect()
        })
        .unwrap_or_default();
    if names.len() == 7 + dof && names[7..].iter().all(|n| robot.actuated_index(n).is_some()) {
        names[7..]
            .iter()
            .map(|n| robot.actuated_index(n).unwrap_or(0))
            .collect()
    } else {
        (0..dof).collect()
    }
}

/// The poses of the dataset `rows` of `episode` (in frame order): object, wrist, joints in
/// robot order. Fails on a row of the wrong length, a non-finite value or a quaternion that
/// is not unit.
fn episode_poses(
    robot: &Robot,
    data: &Path,
    episode: usize,
    mapping: &LerobotMapping,
    rows: &[usize],
    state: &[Vec<f64>],
    object: &[Vec<f64>],
    order: &[usize],
) -> Result<Vec<Pose>> {
    let dof = robot.dof();
    let (sk, ok) = (&mapping.state_key, &mapping.object_key);
    let mut poses = Vec::with_capacity(rows.len());
    for (k, &i) in rows.iter().enumerate() {
        let s = &state[i];
        let o = &object[i];
        let field = |key: &str| format!("{key}, episode {episode} frame {k}");
        if s.len() != 7 + dof {
            return Err(Error::invalid(
                data,
                field(sk),
                format!(
                    "has {} values; expected 7 (wrist pose) + {dof} (joints of robot {:?})",
                    s.len(),
                    robot.name
                ),
            ));
        }
        if o.len() != 7 {
            return Err(Error::invalid(
                data,
                field(ok),
                format!("has {} values; expected 7 (object pose)", o.len()),
            ));
        }
        if let Some(v) = s.iter().chain(o.iter()).find(|v| !v.is_finite()) {
            return Err(Error::invalid(
                data,
                field(sk),
                format!("holds {v}; expected finite numbers"),
            ));
        }
        let pose = |v: &[f64], key: &str| -> Result<Isometry3<f64>> {
            let q =
                crate::math::rotation::quat_from_wxyz([v[3], v[4], v[5], v[6]]).map_err(|e| {
                    Error::invalid(
                        data,
                        field(key),
                        format!("{e}; values 3..7 must be a unit quaternion [w, x, y, z]"),
                    )
                })?;
            Ok(Isometry3::from_parts(
                Translation3::new(v[0], v[1], v[2]),
                q,
            ))
        };
        let mut q = vec![0.0; dof];
        for (j, &a) in order.iter().enumerate() {
            q[a] = s[7 + j];
        }
        poses.push((pose(o, ok)?, pose(s, sk)?, q));
    }
    Ok(poses)
}
