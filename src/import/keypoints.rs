//! A recorded human hand in: 21 keypoints a frame and the object's pose, retargeted onto a
//! robot hand that keeps out of the object and the table.
//!
//! **Format** (`import --keypoints FRAMES.csv`, one row per frame at `--fps`): the object's
//! pose `obj_x, obj_y, obj_z` [m] and `obj_qw, obj_qx, obj_qy, obj_qz` (rotation from the
//! mesh frame to the world), and 21 keypoints [m] as `NAME_x, NAME_y, NAME_z` in the
//! MANO/OpenPose order ([`KEYPOINTS`]: `wrist`, then `thumb_cmc, thumb_mcp, thumb_ip,
//! thumb_tip`, then `mcp, pip, dip, tip` of `index`, `middle`, `ring`, `little`). A `.` may
//! stand for the `_` before the axis (`wrist.x`), and `pinky` for `little`. A `frame` column is
//! allowed and ignored, a `time_s` column must increase row by row; any other column is
//! refused. World z is up.
//!
//! **Mirroring.** The target hands are right hands. A left-hand recording
//! (`--handedness left`) is mirrored through the vertical plane `x = x₀` of the object's
//! first position: every keypoint and object position `p ↦ M(p − c) + c` with
//! `M = diag(−1, 1, 1)`, every object rotation `R ↦ M R M`, and the object mesh `v ↦ M v`
//! with its triangles' winding reversed (written beside the demonstration). The result is
//! the same motion done by a right hand on the mirror image of the object.
//!
//! **Retargeting** ([`retarget`]), per frame, warm-started from the previous frame:
//! 1. *Keypoints.* Each keypoint is a target for a point of the robot (a [`KeypointMap`]:
//!    the wrist on the palm's origin, each finger joint on the origin of the link it
//!    moves, each tip on the tip link); the contact IK ([`crate::hand::ik`]) fits those
//!    points to the keypoints with its non-penetration term on the object and its barrier
//!    term on the table, so the hand follows the recording outside contact but never sinks
//!    into the object or the support.
//! 2. *Where the recording touches.* The recorded hand is modelled as capsules along its
//!    bones ([`Bone`]: a radius a bone, an adult hand's); a bone touches the object on a
//!    frame when its capsule comes within [`Params::touch_mm`] of the object's surface
//!    (capsules that sink in touch too). Touch spans shorter than
//!    [`Params::min_touch_frames`] are dropped and gaps of at most that many frames are
//!    closed. The contact segment is where the recording touches, not where a larger robot
//!    hand happens to come near.
//! 3. *Correspondences.* For each touching bone (only the most distal of a finger with
//!    [`Params::distal_contacts_only`]), the object point is the surface point nearest the
//!    bone at the first frame of its touch span, held for the span: marker noise and small
//!    regrasps do not make the grasp slide, and a bone that sinks through a thin wall later
//!    does not flip its point to the wall's other face. The hand point is the surface sample ([`crate::synth::contacts::hand_samples`])
//!    of the bone's link nearest the object point after step 1, chosen once per span so
//!    the grasp is a fixed set of pairs.
//! 4. *Contacts.* The IK is solved again with the correspondences and the keypoints of
//!    the links that do not touch: the touching links go onto the surface (non-penetration
//!    holds them at most [`crate::hand::ik::Params::penetration_tolerance_mm`] deep), the
//!    rest follow the recording.
//!
//! The keypoints are smoothed first (Savitzky-Golay, [`Params::smoothing_window`] frames,
//! quadratic); the object's path is kept as recorded. [`Residuals`] says per frame how far
//! the robot's keypoint points ended from the recording: what the cleaning cost.

use std::collections::HashMap;
use std::path::Path;

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::geometry::Mesh;
use crate::geometry::shape::CollisionShape;
use crate::hand::ik::{IkSolver, Params as IkParams, ResolvedContact};
use crate::model::Contact;
use crate::robot::{LinkId, Robot};
use crate::synth::proximity::ObjectGeometry;
use crate::{Error, Limits, Result};

/// The 21 keypoints, in the MANO/OpenPose order.
pub const KEYPOINTS: [&str; 21] = [
    "wrist",
    "thumb_cmc",
    "thumb_mcp",
    "thumb_ip",
    "thumb_tip",
    "index_mcp",
    "index_pip",
    "index_dip",
    "index_tip",
    "middle_mcp",
    "middle_pip",
    "middle_dip",
    "middle_tip",
    "ring_mcp",
    "ring_pip",
    "ring_dip",
    "ring_tip",
    "little_mcp",
    "little_pip",
    "little_dip",
    "little_tip",
];

/// The index of keypoint `name` in [`KEYPOINTS`].
pub fn keypoint_index(name: &str) -> Option<usize> {
    KEYPOINTS.iter().position(|k| *k == name)
}

/// Which hand the recording is of.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum Handedness {
    Left,
    Right,
}

/// A recording: per frame the object's pose and the 21 keypoints (world, metres).
#[derive(Clone, Debug, PartialEq)]
pub struct Recording {
    pub object: Vec<Isometry3<f64>>,
    pub keypoints: Vec<[Point3<f64>; 21]>,
}

impl Recording {
    /// Number of frames.
    pub fn len(&self) -> usize {
        self.object.len()
    }

    /// `true` without frames.
    pub fn is_empty(&self) -> bool {
        self.object.is_empty()
    }

    /// Mirrors the recording through the plane `x = x0` (see the module docs).
    pub fn mirror(&mut self, x0: f64) {
        let m = nalgebra::Matrix3::from_diagonal(&Vector3::new(-1.0, 1.0, 1.0));
        let flip = |p: &Point3<f64>| Point3::new(2.0 * x0 - p.x, p.y, p.z);
        for o in &mut self.object {
            let r = m * o.rotation.to_rotation_matrix().matrix() * m;
            let rot = UnitQuaternion::from_matrix(&r);
            let t = flip(&Point3::from(o.translation.vector));
            *o = Isometry3::from_parts(Translation3::from(t.coords), rot);
        }
        for k in &mut self.keypoints {
            for p in k.iter_mut() {
                *p = flip(p);
            }
        }
    }
}

/// The object mesh mirrored by `x ↦ −x` in its own frame, wound outward again.
pub fn mirror_mesh(mesh: &Mesh) -> Mesh {
    Mesh {
        vertices: mesh
            .vertices
            .iter()
            .map(|v| Point3::new(-v.x, v.y, v.z))
            .collect(),
        triangles: mesh.triangles.iter().map(|&[a, b, c]| [a, c, b]).collect(),
    }
}

/// The column name `name` in the canonical spelling: `.` before the axis read as `_`,
/// `pinky` as `little`, `object_`/`obj.` as `obj_`.
fn canonical(name: &str) -> String {
    let mut s = name.trim().to_ascii_lowercase();
    for axis in ["x", "y", "z", "qw", "qx", "qy", "qz"] {
        if let Some(stem) = s.strip_suffix(&format!(".{axis}")) {
            s = format!("{stem}_{axis}");
        }
    }
    if let Some(rest) = s.strip_prefix("object_") {
        s = format!("obj_{rest}");
    }
    s.replace("pinky", "little")
}

/// The columns a keypoints CSV must have, in reading order, and where each is in `header`.
fn keypoint_columns(path: &Path, header: &[String]) -> Result<(Vec<String>, Vec<usize>)> {
    let mut wanted: Vec<String> = ["x", "y", "z", "qw", "qx", "qy", "qz"]
        .iter()
        .map(|a| format!("obj_{a}"))
        .collect();
    for k in KEYPOINTS {
        for a in ["x", "y", "z"] {
            wanted.push(format!("{k}_{a}"));
        }
    }
    let mut at: HashMap<&str, usize> = HashMap::new();
    for (i, h) in header.iter().enumerate() {
        if h == "frame" || h == "time_s" {
            continue;
        }
        if !wanted.contains(h) {
            return Err(Error::invalid(
                path,
                format!("column {}", i + 1),
                format!(
                    "{h:?} is not a column of the keypoints format; expected obj_x..obj_qz, NAME_x/y/z for the 21 keypoints ({}), frame, time_s",
                    KEYPOINTS.join(", ")
                ),
            ));
        }
        if at.insert(h.as_str(), i).is_some() {
            return Err(Error::invalid(
                path,
                format!("column {h}"),
                "appears twice; expected each column once",
            ));
        }
    }
    let columns: Vec<usize> = wanted
        .iter()
        .map(|w| {
            at.get(w.as_str()).copied().ok_or_else(|| {
                Error::invalid(path, format!("column {w}"), "is missing from the header")
            })
        })
        .collect::<Result<_>>()?;
    Ok((wanted, columns))
}

/// Reads a keypoints CSV (see the module docs). Errors name the file, row and column.
pub fn read_keypoints_csv(path: &Path, limits: &Limits) -> Result<Recording> {
    let (mut rdr, header) = super::open_csv(path, limits, canonical)?;
    let (wanted, columns) = keypoint_columns(path, &header)?;
    let mut rec = Recording {
        object: Vec::new(),
        keypoints: Vec::new(),
    };
    let mut clock = super::Clock::find(&header, &["time_s"]);
    for (row, record) in rdr.records().enumerate() {
        let record = record.map_err(|e| {
            Error::invalid(
                path,
                format!("row {}", row + 1),
                format!("{e}; expected one value per header column"),
            )
        })?;
        if let Some(c) = &mut clock {
            c.check(path, row + 1, &record)?;
        }
        if rec.object.len() as u64 >= limits.max_frames {
            return Err(Error::TooLarge {
                path: path.to_path_buf(),
                what: "the number of frames",
                found: rec.object.len() as u64 + 1,
                limit: limits.max_frames,
                flag: "--max-frames",
            });
        }
        let mut v = Vec::with_capacity(columns.len());
        for (w, &c) in wanted.iter().zip(&columns) {
            let text = record.get(c).unwrap_or("");
            let x: f64 = text.parse().map_err(|_| {
                Error::invalid(
                    path,
                    format!("row {}, column {w}", row + 1),
                    format!("{text:?} is not a number"),
                )
            })?;
            if !x.is_finite() {
                return Err(Error::invalid(
                    path,
                    format!("row {}, column {w}", row + 1),
                    format!("is {x}; expected a finite number"),
                ));
            }
            v.push(x);
        }
        let q = crate::math::rotation::quat_from_wxyz([v[3], v[4], v[5], v[6]]).map_err(|e| {
            Error::invalid(
                path,
                format!("row {}, columns obj_qw..obj_qz", row + 1),
                format!("{e}; expected a unit quaternion [w, x, y, z]"),
            )
        })?;
        rec.object.push(Isometry3::from_parts(
            Translation3::new(v[0], v[1], v[2]),
            q,
        ));
        let mut k = [Point3::origin(); 21];
        for (j, p) in k.iter_mut().enumerate() {
            *p = Point3::new(v[7 + 3 * j], v[8 + 3 * j], v[9 + 3 * j]);
        }
        rec.keypoints.push(k);
    }
    if rec.object.len() < 2 {
        return Err(Error::invalid(
            path,
            "rows",
            format!("has {} frames; expected at least 2", rec.object.len()),
        ));
    }
    Ok(rec)
}

/// A bone of the recorded hand: the capsule from keypoint `from` to `to` with `radius` [m],
/// and the robot link it maps onto.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Bone {
    pub from: String,
    pub to: String,
    pub radius_m: f64,
    pub link: String,
}

/// Where each keypoint sits on the robot, and which link each recorded bone maps onto.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KeypointMap {
    /// Keypoint name → (link, point in the link frame [m]).
    pub keypoints: Vec<(String, String, [f64; 3])>,
    /// The recorded hand's bones and their links.
    pub bones: Vec<Bone>,
}

impl KeypointMap {
    /// The map for the built-in human hand (`robots/human_hand.urdf`): each keypoint on the
    /// origin of the link its joint moves, the tips on the tip links; bone radii of an adult
    /// hand (the built-in hand's capsules).
    pub fn human_hand() -> KeypointMap {
        let mut keypoints = vec![("wrist".to_string(), "palm".to_string(), [0.0; 3])];
        let mut bones = Vec::new();
        let thumb = [
            ("thumb_cmc", "thumb_metacarpal", 0.012),
            ("thumb_mcp", "thumb_proximal", 0.010),
            ("thumb_ip", "thumb_distal", 0.0088),
            ("thumb_tip", "thumb_tip", 0.0),
        ];
        let fingers = ["index", "middle", "ring", "little"].map(|f| {
            [
                (format!("{f}_mcp"), format!("{f}_proximal"), 0.0095),
                (format!("{f}_pip"), format!("{f}_middle"), 0.0085),
                (format!("{f}_dip"), format!("{f}_distal"), 0.0075),
                (format!("{f}_tip"), format!("{f}_tip"), 0.0),
            ]
        });
        let mut chains: Vec<Vec<(String, String, f64)>> = vec![
            thumb
                .iter()
                .map(|(k, l, r)| (k.to_string(), l.to_string(), *r))
                .collect(),
        ];
        chains.extend(fingers.iter().map(|c| c.to_vec()));
        for chain in &chains {
            for (i, (k, link, r)) in chain.iter().enumerate() {
                keypoints.push((k.clone(), link.clone(), [0.0; 3]));
                if let Some((next, _, _)) = chain.get(i + 1) {
                    bones.push(Bone {
                        from: k.clone(),
                        to: next.clone(),
                        radius_m: *r,
                        link: link.clone(),
                    });
                }
            }
        }
        for f in ["index", "middle", "ring", "little"] {
            bones.push(Bone {
                from: "wrist".into(),
                to: format!("{f}_mcp"),
                radius_m: 0.012,
                link: "palm".into(),
            });
        }
        KeypointMap { keypoints, bones }
    }

    /// The map resolved against `robot`: every link must exist.
    fn resolve(&self, robot: &Robot, robot_path: &Path) -> Result<Resolved> {
        let link = |name: &str, field: String| {
            robot.link_id(name).ok_or_else(|| {
                Error::invalid(
                    robot_path,
                    field,
                    format!("the keypoint map names link {name:?}, which the URDF does not have"),
                )
            })
        };
        let kp = |name: &str, field: String| {
            keypoint_index(name).ok_or_else(|| {
                Error::invalid(
                    robot_path,
                    field,
                    format!(
                        "{name:?} is not a keypoint; expected one of {}",
                        KEYPOINTS.join(", ")
                    ),
                )
            })
        };
        let keypoints = self
            .keypoints
            .iter()
            .enumerate()
            .map(|(i, (k, l, p))| {
                Ok((
                    kp(k, format!("keypoints[{i}]"))?,
                    link(l, format!("keypoints[{i}]"))?,
                    Point3::from(*p),
                ))
            })
            .collect::<Result<_>>()?;
        let bones = self
            .bones
            .iter()
            .enumerate()
            .map(|(i, b)| {
                Ok((
                    kp(&b.from, format!("bones[{i}].from"))?,
                    kp(&b.to, format!("bones[{i}].to"))?,
                    b.radius_m,
                    link(&b.link, format!("bones[{i}].link"))?,
                ))
            })
            .collect::<Result<_>>()?;
        Ok(Resolved { keypoints, bones })
    }
}

struct Resolved {
    keypoints: Vec<(usize, LinkId, Point3<f64>)>,
    bones: Vec<(usize, usize, f64, LinkId)>,
}

/// Parameters of [`retarget`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Params {
    /// A bone touches the object when its capsule is within this of the surface [mm].
    pub touch_mm: f64,
    /// Touch spans shorter than this are dropped, gaps this short closed [frames].
    pub min_touch_frames: usize,
    /// Savitzky-Golay window of the keypoint smoothing [frames, odd]; 1 turns it off.
    pub smoothing_window: usize,
    /// Of a finger's touching bones, only the most distal one gives correspondences: a robot
    /// hand of other proportions cannot put every phalanx where a person's was, and the
    /// fingertips carry a grasp. Default `true`.
    pub distal_contacts_only: bool,
    /// Frames over which the scaling centre moves between the wrist and the touches.
    pub scale_blend_frames: usize,
    /// Each correspondence counts this many times against one keypoint in the IK.
    pub contact_weight: usize,
    /// The support's reach in the IK's barrier term [m]: links closer than this to the
    /// table are pushed up.
    pub support_margin_m: f64,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            touch_mm: 4.0,
            min_touch_frames: 3,
            smoothing_window: 7,
            distal_contacts_only: true,
            scale_blend_frames: 10,
            contact_weight: 3,
            support_margin_m: 0.005,
        }
    }
}

/// Per frame, how far the robot's keypoint points ended from the recording's keypoints
/// [mm]: what the cleaning cost.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Residuals {
    pub mean_mm: Vec<f64>,
    pub max_mm: Vec<f64>,
    /// The keypoint of each frame's largest residual.
    pub worst: Vec<String>,
}

/// The retargeted hand: per frame wrist pose, joints (robot order) and correspondences.
#[derive(Clone, Debug)]
pub struct Retargeted {
    pub wrists: Vec<Isometry3<f64>>,
    pub joints: Vec<Vec<f64>>,
    pub contacts: Vec<Vec<Contact>>,
    pub residuals: Residuals,
    /// Frames on which the recorded hand touches, first and last.
    pub touch: Option<[usize; 2]>,
    /// The robot hand's size over the recorded hand's (see [`hand_scale`]).
    pub scale: f64,
}

/// Smooths every keypoint's path (Savitzky-Golay, quadratic).
fn smooth_keypoints(rec: &mut Recording, window: usize) {
    if window < 3 {
        return;
    }
    for j in 0..21 {
        let path: Vec<Vector3<f64>> = rec.keypoints.iter().map(|k| k[j].coords).collect();
        if let Ok(s) = crate::math::savgol::savgol_filter3(&path, window, 2) {
            for (k, p) in rec.keypoints.iter_mut().zip(s) {
                k[j] = Point3::from(p);
            }
        }
    }
}

/// The palm frame of the recording at frame `t`: z from the wrist to the middle MCP, y
/// from the little MCP to the index MCP, x = y × z (a right hand's palm normal).
fn palm_frame(k: &[Point3<f64>; 21]) -> Isometry3<f64> {
    let z = (k[9] - k[0]).try_normalize(1e-9).unwrap_or_else(Vector3::z);
    let y0 = k[5] - k[17];
    let y = (y0 - z * z.dot(&y0))
        .try_normalize(1e-9)
        .unwrap_or_else(|| z.cross(&Vector3::x()).normalize());
    let x = y.cross(&z);
    let r = nalgebra::Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_columns(&[x, y, z]));
    Isometry3::from_parts(
        Translation3::from(k[0].coords),
        UnitQuaternion::from_rotation_matrix(&r),
    )
}

/// Per bone and frame, the object-frame surface point the bone touches (see the module
/// docs, step 2 and 3's smoothing); `None` where it does not touch.
fn touches(
    rec: &Recording,
    bones: &[(usize, usize, f64, LinkId)],
    object: &ObjectGeometry,
    params: &Params,
) -> Vec<Vec<Option<Point3<f64>>>> {
    let n = rec.len();
    let samples = 5;
    bones
        .iter()
        .map(|&(a, b, r, _)| {
            let mut points: Vec<Option<Point3<f64>>> = (0..n)
                .map(|t| {
                    let inv = rec.object[t].inverse();
                    let (pa, pb) = (inv * rec.keypoints[t][a], inv * rec.keypoints[t][b]);
                    (0..samples)
                        .map(|i| {
                            let s = pa + (pb - pa) * (i as f64 / (samples - 1) as f64);
                            object.surface_point(&s)
                        })
                        .min_by(|x, y| x.signed_distance.total_cmp(&y.signed_distance))
                        .filter(|s| s.signed_distance - r <= params.touch_mm * 1e-3)
                        .map(|s| s.point)
                })
                .collect();
            debounce(&mut points, params.min_touch_frames);
            hold_spans(&mut points);
            points
        })
        .collect()
}

/// Closes gaps of at most `k` frames inside a touch (repeating the last point) and drops
/// touch spans shorter than `k`.
fn debounce(points: &mut [Option<Point3<f64>>], k: usize) {
    let n = points.len();
    let mut t = 0;
    while t < n {
        if points[t].is_none() {
            let start = t;
            while t < n && points[t].is_none() {
                t += 1;
            }
            if start > 0 && t < n && t - start <= k {
                let fill = points[start - 1];
                for p in &mut points[start..t] {
                    *p = fill;
                }
            }
        } else {
            t += 1;
        }
    }
    let mut t = 0;
    while t < n {
        if points[t].is_some() {
            let start = t;
            while t < n && points[t].is_some() {
                t += 1;
            }
            if t - start < k {
                for p in &mut points[start..t] {
                    *p = None;
                }
            }
        } else {
            t += 1;
        }
    }
}

/// Drops a bone's touch on frames where a bone farther along its chain (one starting where
/// it ends, transitively) touches too.
fn keep_most_distal(touch: &mut [Vec<Option<Point3<f64>>>], bones: &[(usize, usize, f64, LinkId)]) {
    let descendants: Vec<Vec<usize>> = (0..bones.len())
        .map(|b| {
            let mut out = Vec::new();
            let mut ends = vec![bones[b].1];
            while let Some(e) = ends.pop() {
                for (c, bone) in bones.iter().enumerate() {
                    if bone.0 == e && !out.contains(&c) && c != b {
                        out.push(c);
                        ends.push(bone.1);
                    }
                }
            }
            out
        })
        .collect();
    let n = touch.first().map_or(0, Vec::len);
    for t in 0..n {
        let drop: Vec<usize> = (0..bones.len())
            .filter(|&b| descendants[b].iter().any(|&c| touch[c][t].is_some()))
            .collect();
        for b in drop {
            touch[b][t] = None;
        }
    }
}

/// Every frame of a touch span gets the span's first point.
fn hold_spans(points: &mut [Option<Point3<f64>>]) {
    let mut first = None;
    for p in points.iter_mut() {
        match p {
            Some(x) => *p = Some(*first.get_or_insert(*x)),
            None => first = None,
        }
    }
}

/// The length of the recorded hand's keypoint chains (wrist to each MCP and along every
/// bone of the map) on the robot at its zero configuration over the recording's (median over
/// frames): how much smaller the robot hand is than the person's.
fn hand_scale(robot: &Robot, resolved: &Resolved, rec: &Recording) -> f64 {
    let mut poses = robot.new_link_poses();
    let q = flat_hand(robot);
    robot.forward_kinematics(&Isometry3::identity(), &q, &mut poses);
    let on_robot: HashMap<usize, Point3<f64>> = resolved
        .keypoints
        .iter()
        .map(|&(k, l, p)| (k, poses[l.index()] * p))
        .collect();
    let pairs: Vec<(usize, usize)> = resolved
        .bones
        .iter()
        .map(|b| (b.0, b.1))
        .filter(|(a, b)| on_robot.contains_key(a) && on_robot.contains_key(b))
        .collect();
    let robot_len: f64 = pairs
        .iter()
        .map(|(a, b)| (on_robot[a] - on_robot[b]).norm())
        .sum();
    let mut recorded: Vec<f64> = rec
        .keypoints
        .iter()
        .map(|k| pairs.iter().map(|&(a, b)| (k[a] - k[b]).norm()).sum())
        .collect();
    recorded.sort_by(f64::total_cmp);
    let median = recorded.get(recorded.len() / 2).copied().unwrap_or(0.0);
    if robot_len > 0.0 && median > 0.0 {
        (robot_len / median).clamp(0.25, 4.0)
    } else {
        1.0
    }
}

/// The robot's flat hand: every joint at 0, clamped into its limits.
fn flat_hand(robot: &Robot) -> Vec<f64> {
    let mut q = vec![0.0; robot.dof()];
    robot.clamp(&mut q);
    q
}

/// Per frame the point the recorded hand is scaled about: the centroid of its touches while
/// it touches (the contacts stay where they were), the wrist away from the object (the wrist
/// stays), blended linearly over [`Params::scale_blend_frames`] frames before and after each
/// touch.
fn scale_centres(
    rec: &Recording,
    touch: &[Vec<Option<Point3<f64>>>],
    blend: usize,
) -> Vec<Point3<f64>> {
    let n = rec.len();
    let centroid: Vec<Option<Point3<f64>>> = (0..n)
        .map(|t| {
            let pts: Vec<Point3<f64>> = touch.iter().filter_map(|b| b[t]).collect();
            (!pts.is_empty()).then(|| {
                let sum = pts.iter().fold(Vector3::zeros(), |a, p| a + p.coords);
                rec.object[t] * Point3::from(sum / pts.len() as f64)
            })
        })
        .collect();
    (0..n)
        .map(|t| {
            let wrist = rec.keypoints[t][0];
            if let Some(c) = centroid[t] {
                return c;
            }
            // The nearest touching frame within the blend, before or after.
            let near = (1..=blend).find_map(|d| {
                let before = t.checked_sub(d).and_then(|s| centroid[s]);
                let after = centroid.get(t + d).copied().flatten();
                before.or(after).map(|c| (d, c))
            });
            match near {
                Some((d, c)) => {
                    let w = 1.0 - d as f64 / (blend + 1) as f64;
                    wrist + (c - wrist) * w
                }
                None => wrist,
            }
        })
        .collect()
}

/// The surface sample of `link` (at world pose `pose`) closest to the object, in the link
/// frame, and the object's surface point nearest it (object frame; `inv` is the object's
/// pose inverted): where the robot's link touches, on the side of the surface it is on.
fn closest_pair(
    samples: &[(LinkId, Point3<f64>)],
    link: LinkId,
    pose: &Isometry3<f64>,
    object: &ObjectGeometry,
    inv: &Isometry3<f64>,
) -> (Point3<f64>, Point3<f64>) {
    samples
        .iter()
        .filter(|(l, _)| *l == link)
        .map(|(_, p)| (*p, object.surface_point(&(inv * (pose * p)))))
        .min_by(|a, b| a.1.signed_distance.total_cmp(&b.1.signed_distance))
        .map(|(p, s)| (p, s.point))
        .unwrap_or_else(|| {
            let p = Point3::origin();
            (p, object.surface_point(&(inv * (pose * p))).point)
        })
}

/// Per keypoint, how far the robot's point is from its target [mm]: mean, largest, and the
/// largest's keypoint.
fn residual(
    targets: &[(usize, LinkId, Point3<f64>)],
    poses: &[Isometry3<f64>],
    k: &[Point3<f64>; 21],
) -> (f64, f64, usize) {
    let res: Vec<(f64, usize)> = targets
        .iter()
        .map(|&(i, link, p)| ((poses[link.index()] * p - k[i]).norm() * 1e3, i))
        .collect();
    let (worst, at) = res
        .iter()
        .copied()
        .fold((0.0, 0), |a, b| if b.0 > a.0 { b } else { a });
    (
        res.iter().map(|r| r.0).sum::<f64>() / res.len().max(1) as f64,
        worst,
        at,
    )
}

/// The state carried from frame to frame by [`retarget`].
struct Tracker<'a> {
    robot: &'a Robot,
    solver: IkSolver<'a>,
    samples: Vec<(LinkId, Point3<f64>)>,
    poses: Vec<Isometry3<f64>>,
    wrist: Isometry3<f64>,
    q: Vec<f64>,
    object: &'a ObjectGeometry,
    /// The correspondence (hand point, object point) of each bone's current touch span,
    /// chosen at its first frame.
    span: Vec<Option<(Point3<f64>, Point3<f64>)>>,
}

impl Tracker<'_> {
    /// Solves frame `t`: the keypoints `k` (already scaled), then with the touching bones'
    /// correspondences; returns those correspondences.
    fn frame(
        &mut self,
        resolved: &Resolved,
        pose: &Isometry3<f64>,
        k: &[Point3<f64>; 21],
        touch: impl Fn(usize) -> Option<Point3<f64>>,
        contact_weight: usize,
    ) -> Vec<ResolvedContact> {
        let inv = pose.inverse();
        let targets: Vec<ResolvedContact> = resolved
            .keypoints
            .iter()
            .map(|&(i, link, p)| ResolvedContact {
                link,
                hand_point: p,
                object_point: inv * k[i],
            })
            .collect();
        self.solver
            .solve(pose, &targets, &mut self.wrist, &mut self.q);
        self.robot
            .forward_kinematics(&self.wrist, &self.q, &mut self.poses);
        let mut contacts = Vec::new();
        for (b, &(_, _, _, link)) in resolved.bones.iter().enumerate() {
            if touch(b).is_none() {
                self.span[b] = None;
                continue;
            }
            let (samples, poses, object) = (&self.samples, &self.poses, self.object);
            let (hand_point, object_point) = *self.span[b].get_or_insert_with(|| {
                closest_pair(samples, link, &poses[link.index()], object, &inv)
            });
            contacts.push(ResolvedContact {
                link,
                hand_point,
                object_point,
            });
        }
        if contacts.is_empty() {
            return contacts;
        }
        let mut all: Vec<ResolvedContact> = Vec::new();
        for _ in 0..contact_weight.max(1) {
            all.extend_from_slice(&contacts);
        }
        all.extend(
            targets
                .iter()
                .filter(|c| !contacts.iter().any(|x| x.link == c.link)),
        );
        self.solver.solve(pose, &all, &mut self.wrist, &mut self.q);
        self.robot
            .forward_kinematics(&self.wrist, &self.q, &mut self.poses);
        contacts
    }
}

/// Retargets `rec` onto `robot` (see the module docs). `support` is the table as a world
/// shape; `ik` the IK's parameters (non-penetration on).
#[allow(clippy::too_many_arguments)]
pub fn retarget(
    robot: &Robot,
    robot_path: &Path,
    map: &KeypointMap,
    rec: &Recording,
    object: &ObjectGeometry,
    support: &[CollisionShape],
    ik: &IkParams,
    params: &Params,
) -> Result<Retargeted> {
    let resolved = map.resolve(robot, robot_path)?;
    let mut rec = rec.clone();
    smooth_keypoints(&mut rec, params.smoothing_window);
    let n = rec.len();
    let mut touch = touches(&rec, &resolved.bones, object, params);
    if params.distal_contacts_only {
        keep_most_distal(&mut touch, &resolved.bones);
    }
    let scale = hand_scale(robot, &resolved, &rec);
    let centres = scale_centres(&rec, &touch, params.scale_blend_frames);
    let scaled: Vec<[Point3<f64>; 21]> = (0..n)
        .map(|t| rec.keypoints[t].map(|p| centres[t] + (p - centres[t]) * scale))
        .collect();
    // The first frame starts from the palm frame of the keypoints.
    let q = flat_hand(robot);
    let mut poses = robot.new_link_poses();
    robot.forward_kinematics(&Isometry3::identity(), &q, &mut poses);
    let palm_link = resolved
        .keypoints
        .iter()
        .find(|(k, _, _)| *k == 0)
        .map_or(robot.root(), |(_, l, _)| *l);
    let wrist = palm_frame(&scaled[0]) * poses[palm_link.index()].inverse();
    let mut tracker = Tracker {
        robot,
        solver: IkSolver::new(robot, support, Some(&object.sdf), ik.clone()),
        samples: crate::synth::contacts::hand_samples(robot, 0.004),
        poses,
        wrist,
        q,
        object,
        span: vec![None; resolved.bones.len()],
    };
    let mut out = Retargeted {
        wrists: Vec::with_capacity(n),
        joints: Vec::with_capacity(n),
        contacts: Vec::with_capacity(n),
        residuals: Residuals::default(),
        touch: None,
        scale,
    };
    for t in 0..n {
        // A hand that holds the object starts the frame carried along with it.
        if t > 0 && !out.contacts[t - 1].is_empty() {
            tracker.wrist = rec.object[t] * rec.object[t - 1].inverse() * tracker.wrist;
        }
        let contacts = tracker.frame(
            &resolved,
            &rec.object[t],
            &scaled[t],
            |b| touch[b][t],
            params.contact_weight,
        );
        if !contacts.is_empty() {
            out.touch = Some([out.touch.map_or(t, |[a, _]| a), t]);
        }
        let (mean, max, at) = residual(&resolved.keypoints, &tracker.poses, &scaled[t]);
        out.residuals.mean_mm.push(mean);
        out.residuals.max_mm.push(max);
        out.residuals.worst.push(KEYPOINTS[at].to_string());
        out.wrists.push(tracker.wrist);
        out.joints.push(tracker.q.clone());
        out.contacts.push(
            contacts
                .iter()
                .map(|c| Contact {
                    link: robot.link(c.link).name.clone(),
                    hand_point: c.hand_point,
                    object_point: c.object_point,
                })
                .collect(),
        );
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mirroring_twice_gives_the_recording_back() {
        let mut k = [Point3::origin(); 21];
        for (i, p) in k.iter_mut().enumerate() {
            *p = Point3::new(0.1 + i as f64 * 0.01, -0.2, 0.5 + i as f64 * 0.002);
        }
        let rec = Recording {
            object: vec![Isometry3::new(
                Vector3::new(0.05, 0.1, 0.6),
                Vector3::new(0.1, -0.2, 0.7),
            )],
            keypoints: vec![k],
        };
        let mut m = rec.clone();
        m.mirror(0.05);
        assert!((m.keypoints[0][3].x - (0.1 - 0.13)).abs() < 1e-12);
        assert!(m.object[0].rotation.into_inner().norm() > 0.999);
        m.mirror(0.05);
        assert!((m.object[0].translation.vector - rec.object[0].translation.vector).norm() < 1e-12);
        assert!(m.object[0].rotation.angle_to(&rec.object[0].rotation) < 1e-9);
        assert!((m.keypoints[0][20] - rec.keypoints[0][20]).norm() < 1e-12);
    }

    #[test]
    fn a_mirrored_object_point_lands_where_the_mirrored_world_point_is() {
        let pose = Isometry3::new(Vector3::new(0.05, 0.1, 0.6), Vector3::new(0.3, -0.2, 0.7));
        let v = Point3::new(0.02, -0.03, 0.04);
        let mut rec = Recording {
            object: vec![pose],
            keypoints: vec![[pose * v; 21]],
        };
        rec.mirror(0.0);
        let mesh = mirror_mesh(&Mesh {
            vertices: vec![v],
            triangles: vec![],
        });
        let world = rec.object[0] * mesh.vertices[0];
        assert!(
            (world - rec.keypoints[0][0]).norm() < 1e-12,
            "{world} vs {}",
            rec.keypoints[0][0]
        );
    }

    #[test]
    fn short_touches_are_dropped_and_short_gaps_closed() {
        let p = Some(Point3::origin());
        let mut v = vec![
            None, p, p, None, None, p, p, p, None, p, None, None, None, None,
        ];
        debounce(&mut v, 2);
        let on: Vec<bool> = v.iter().map(Option::is_some).collect();
        assert_eq!(
            on,
            [
                false, true, true, true, true, true, true, true, true, true, false, false, false,
                false
            ]
        );
        let mut w = vec![None, p, None, None, None, p, p, p, None, None, None];
        debounce(&mut w, 2);
        let on: Vec<bool> = w.iter().map(Option::is_some).collect();
        assert_eq!(
            on,
            [
                false, false, false, false, false, true, true, true, false, false, false
            ]
        );
    }

    #[test]
    fn column_names_are_read_in_either_spelling() {
        assert_eq!(canonical("wrist.x"), "wrist_x");
        assert_eq!(canonical("Pinky_Tip.z"), "little_tip_z");
        assert_eq!(canonical("object.qw"), "obj_qw");
        assert_eq!(canonical("obj_qw"), "obj_qw");
    }

    #[test]
    fn the_human_hand_map_resolves_on_the_built_in_hand() {
        let robot = crate::robot::test_human_hand();
        let map = KeypointMap::human_hand();
        let r = map.resolve(&robot, Path::new("human_hand.urdf")).unwrap();
        assert_eq!(r.keypoints.len(), 21);
        assert_eq!(r.bones.len(), 3 + 4 * 3 + 4);
    }
}
