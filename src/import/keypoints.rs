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
//! **Retargeting** ([`retarget`]):
//! 1. *Where the recording touches.* The recorded hand is modelled as capsules along its
//!    bones ([`Bone`]: a radius a bone, an adult hand's). A bone's axis is walked from the
//!    joint it hangs from through its own length; the point where its capsule is nearest
//!    the surface, before the axis first enters the object, is where it touches, and the
//!    direction from there to the axis is the face's normal on the finger's side. A fitted
//!    hand sinks through a thin wall by centimetres (the shared take's fingertips come out
//!    on the far side of a 2 mm wall), so the nearest face is a coin toss while the face
//!    the finger reached first is not. A bone starts touching when its capsule comes within
//!    [`Params::touch_mm`] and lets go past [`Params::release_mm`] (hysteresis against
//!    marker noise); touch spans shorter than [`Params::min_touch_frames`] are dropped and
//!    gaps of at most that many frames closed. The contact segment is where the recording
//!    touches, not where a larger robot hand happens to come near.
//! 2. *Held points.* A touch span is cut where its point moves more than
//!    [`Params::regrasp_mm`] and stays away [`Params::regrasp_frames`] frames (a regrasp);
//!    each part holds its median point, so jitter and small slides do not make the grasp
//!    slide, and a finger that moves to a new place gets a new point. Of a finger's touching
//!    bones only the most distal gives correspondences with
//!    [`Params::distal_contacts_only`].
//! 3. *Free fit.* Per frame, every keypoint is a target for a point of the robot (a
//!    [`KeypointMap`]: the wrist on the palm's origin, each finger joint on the origin of
//!    the link it moves, each tip on the tip link), fitted by the contact IK
//!    ([`crate::hand::ik`]) without the object, warm-started from the previous frame's free
//!    fit: the recording as it is, never caught on the object.
//! 4. *Contacts.* Each touching bone's link gets its pad (the link's surface sample facing
//!    the face, nearest the held point, chosen once per held point) on the point, and the
//!    pad's inside 5 mm in on the point 5 mm off the face, so the link lies on the face's
//!    side; the keypoints at the ends of touching bones are dropped (the touch stands for
//!    them), the others stay targets. This is solved with the object's non-penetration term
//!    and the table's barrier from two starts, the previous frame's solution carried along
//!    with the object and the frame's free fit, keeping the lower end: the first carries a
//!    grasp through frames where the recorded keypoints pass through the object, the second
//!    gets a hand caught on a rim back to the side the recording is on. Off the object the
//!    hand takes its free fit only once it is 10 mm clear; nearer, its targets move at most
//!    5 mm a frame, so letting go of a grasp in a hollow slides the fingers out over the rim
//!    instead of through the wall.
//! 5. *Backward.* From the last frame back, each touching frame is solved again from the
//!    next frame's solution and keeps it where it ends lower: a grasp the forward pass
//!    reaches only some frames into a touch (a finger caught on a rim while the
//!    recording's passes through it) is carried back to where the touch began. Then the
//!    approach: the frames before each touch are solved from the next frame's hand, their
//!    targets at most 5 mm a frame away and the hand 5 mm off the object, until it is 10 mm
//!    clear, so the hand closes onto the grasp instead of jumping into it at the first
//!    touching frame (a hand larger than the person's would sweep through the object
//!    there).
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

/// Where each keypoint sits on the robot, which link each recorded bone maps onto, and the
/// retargeting parameters that suit the hand.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KeypointMap {
    /// Keypoint name → (link, point in the link frame [m]).
    pub keypoints: Vec<(String, String, [f64; 3])>,
    /// The recorded hand's bones and their links.
    pub bones: Vec<Bone>,
    /// Retargeting parameters for this hand (absent fields keep their defaults), used when
    /// `import` is given no `--retarget` file: a hand of other proportions than a person's
    /// may need other weights (see `robots/maps/`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub retarget: Option<Params>,
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
        KeypointMap {
            keypoints,
            bones,
            retarget: None,
        }
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

/// Parameters of [`retarget`] (`import --retarget FILE`: a JSON object of any of these
/// fields; the others keep their defaults).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// A bone touches the object when its capsule is within this of the surface [mm].
    pub touch_mm: f64,
    /// A touching bone lets go when its capsule is farther than this from the surface [mm]
    /// (hysteresis; at least `touch_mm`).
    pub release_mm: f64,
    /// A touch point that moves farther than this for [`Params::regrasp_frames`] frames
    /// starts a new held point (a regrasp) [mm].
    pub regrasp_mm: f64,
    /// How long a touch point must stay away to count as a regrasp [frames].
    pub regrasp_frames: usize,
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
            release_mm: 10.0,
            regrasp_mm: 15.0,
            regrasp_frames: 10,
            min_touch_frames: 3,
            smoothing_window: 7,
            distal_contacts_only: true,
            scale_blend_frames: 10,
            contact_weight: 3,
            support_margin_m: 0.005,
        }
    }
}

impl Params {
    /// Every field within its range; an error names `path`, the field and what it expects.
    pub fn check(&self, path: &Path) -> Result<()> {
        let range = |field: &str, v: f64, lo: f64, hi: f64| {
            if v.is_finite() && (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(Error::invalid(
                    path,
                    field,
                    format!("must be a number in [{lo}, {hi}], got {v}"),
                ))
            }
        };
        range("touch_mm", self.touch_mm, 0.0, 50.0)?;
        range("release_mm", self.release_mm, self.touch_mm, 100.0)?;
        range("regrasp_mm", self.regrasp_mm, 1.0, 1000.0)?;
        range("support_margin_m", self.support_margin_m, 0.0, 0.1)?;
        // Whole numbers (serde refuses fractions) against the same kind of range.
        let count = |field: &str, v: usize, lo: usize, hi: usize| {
            range(field, v as f64, lo as f64, hi as f64)
        };
        count("regrasp_frames", self.regrasp_frames, 1, 10_000)?;
        count("min_touch_frames", self.min_touch_frames, 0, 10_000)?;
        count("smoothing_window", self.smoothing_window, 1, 1001)?;
        if self.smoothing_window.is_multiple_of(2) {
            return Err(Error::invalid(
                path,
                "smoothing_window",
                format!(
                    "must be odd (1 turns the smoothing off), got {}",
                    self.smoothing_window
                ),
            ));
        }
        count("scale_blend_frames", self.scale_blend_frames, 0, 10_000)?;
        count("contact_weight", self.contact_weight, 1, 100)?;
        Ok(())
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

/// Where a bone touches the object on a frame (object frame): the surface point and the
/// surface's normal on the side the bone is on.
type Touch = Option<(Point3<f64>, Vector3<f64>)>;

/// A bone's clearance from the object on a frame [m], with the surface point and normal of
/// [`Touch`] ([`bone_touch`]).
type Seen = Option<(f64, Point3<f64>, Vector3<f64>)>;

/// Per bone and frame, where the bone touches (see the module docs, steps 2 and 3); `None`
/// where it does not touch.
fn touches(
    rec: &Recording,
    bones: &[(usize, usize, f64, LinkId)],
    object: &ObjectGeometry,
    params: &Params,
) -> Vec<Vec<Touch>> {
    let n = rec.len();
    bones
        .iter()
        .map(|&(a, b, r, _)| {
            // The joint the bone hangs from: the side of the surface the finger comes from.
            let parent = bones.iter().find(|x| x.1 == a).map_or(a, |x| x.0);
            let seen: Vec<Seen> = (0..n)
                .map(|t| {
                    let inv = rec.object[t].inverse();
                    let k = |i: usize| inv * rec.keypoints[t][i];
                    bone_touch(object, &k(parent), &k(a), &k(b), r)
                })
                .collect();
            let mut points = hysteresis(&seen, params);
            debounce(&mut points, params.min_touch_frames);
            hold_spans(&mut points, params.regrasp_mm * 1e-3, params.regrasp_frames);
            points
        })
        .collect()
}

/// Where the capsule `a`-`b` of radius `r`, hanging from the joint `parent`, is nearest the
/// object (object frame): its clearance (axis to surface minus the radius, negative when the
/// capsule sinks in), the surface point there, on the side the finger comes from, and the
/// direction from that point to the axis (the face's normal on that side). The
/// axis is walked from `parent` through `a` to `b`; samples past the first one inside the
/// object are not used, so a bone that passes through a thin wall touches the face it
/// reached first, not whichever face happens to be nearer. A walk that starts inside the
/// object falls back to the nearest surface point of the bone's own samples.
fn bone_touch(
    object: &ObjectGeometry,
    parent: &Point3<f64>,
    a: &Point3<f64>,
    b: &Point3<f64>,
    r: f64,
) -> Seen {
    const STEP: f64 = 1e-3;
    let sample = |p: Point3<f64>| object.surface_point(&p);
    let lead = (a - parent).norm();
    let len = lead + (b - a).norm();
    let steps = ((len / STEP).ceil() as usize).clamp(1, 400);
    let mut best: Seen = None;
    let mut last_outside: Seen = None;
    for i in 0..=steps {
        let s = len * i as f64 / steps as f64;
        let p = if s <= lead && lead > 0.0 {
            parent + (a - parent) * (s / lead)
        } else {
            let d = (b - a).norm();
            if d > 0.0 {
                a + (b - a) * ((s - lead) / d).min(1.0)
            } else {
                *a
            }
        };
        let sp = sample(p);
        if sp.signed_distance < 0.0 {
            if i == 0 {
                break;
            }
            // Entered the object: the face reached first is where it touches.
            let across = (sp.point - p)
                .try_normalize(1e-9)
                .unwrap_or_else(Vector3::z);
            return Some(
                best.or(last_outside)
                    .map_or((sp.signed_distance - r, sp.point, across), |x| {
                        (x.0.min(-r), x.1, x.2)
                    }),
            );
        }
        let Some(normal) = (p - sp.point).try_normalize(1e-9) else {
            continue;
        };
        let here = (sp.signed_distance - r, sp.point, normal);
        last_outside = Some(here);
        if s >= lead && best.is_none_or(|x| here.0 < x.0) {
            best = Some(here);
        }
    }
    if best.is_some() {
        return best;
    }
    // The walk starts inside: the bone's own samples, nearest surface point.
    (0..5)
        .map(|i| {
            let p = a + (b - a) * (i as f64 / 4.0);
            (p, sample(p))
        })
        .min_by(|x, y| x.1.signed_distance.total_cmp(&y.1.signed_distance))
        .map(|(p, sp)| {
            let n = (sp.point - p)
                .try_normalize(1e-9)
                .unwrap_or_else(Vector3::z);
            (sp.signed_distance - r, sp.point, n)
        })
}

/// Touch with hysteresis: a bone starts touching when its clearance falls to
/// [`Params::touch_mm`] and stops when it rises past [`Params::release_mm`], so a fingertip
/// whose recorded clearance wanders around the threshold with marker noise does not
/// flicker in and out of the grasp.
fn hysteresis(seen: &[Seen], params: &Params) -> Vec<Touch> {
    let (on, off) = (
        params.touch_mm * 1e-3,
        params.release_mm.max(params.touch_mm) * 1e-3,
    );
    let mut touching = false;
    seen.iter()
        .map(|s| {
            let Some((d, p, normal)) = *s else {
                touching = false;
                return None;
            };
            touching = if touching { d <= off } else { d <= on };
            touching.then_some((p, normal))
        })
        .collect()
}

/// Closes gaps of at most `k` frames inside a touch (repeating the last point) and drops
/// touch spans shorter than `k`.
fn debounce<T: Copy>(points: &mut [Option<T>], k: usize) {
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
fn keep_most_distal(touch: &mut [Vec<Touch>], bones: &[(usize, usize, f64, LinkId)]) {
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

/// Holds each touch span's point still: a span is cut where its recorded point moves more
/// than `regrasp` from where the current part of it began and stays away for at least
/// `min_frames` frames (a regrasp, a finger sliding to a new place), and every frame of a
/// part gets the part's median point (per axis). Marker noise and jitter under `regrasp` do
/// not make the grasp slide; a finger that moves to a new face or end gets a new point.
fn hold_spans(points: &mut [Touch], regrasp: f64, min_frames: usize) {
    let n = points.len();
    let mut t = 0;
    while t < n {
        if points[t].is_none() {
            t += 1;
            continue;
        }
        let start = t;
        while t < n && points[t].is_some() {
            t += 1;
        }
        let span: Vec<(Point3<f64>, Vector3<f64>)> =
            points[start..t].iter().flatten().copied().collect();
        let mut cuts = vec![0];
        let mut anchor = span[0].0;
        let mut i = 1;
        while i < span.len() {
            let away = span[i..]
                .iter()
                .take_while(|p| (p.0 - anchor).norm() > regrasp)
                .count();
            if away >= min_frames.max(1) {
                cuts.push(i);
                anchor = span[i + away / 2].0;
                i += away;
            } else {
                i += away.max(1);
            }
        }
        cuts.push(span.len());
        for w in cuts.windows(2) {
            let part = &span[w[0]..w[1]];
            let median = |axis: usize| {
                let mut v: Vec<f64> = part.iter().map(|p| p.0[axis]).collect();
                v.sort_by(f64::total_cmp);
                v[v.len() / 2]
            };
            let m = Point3::new(median(0), median(1), median(2));
            let normal = part
                .iter()
                .fold(Vector3::zeros(), |a, p| a + p.1)
                .try_normalize(1e-9)
                .unwrap_or(part[0].1);
            for p in &mut points[start + w[0]..start + w[1]] {
                *p = Some((m, normal));
            }
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
fn scale_centres(rec: &Recording, touch: &[Vec<Touch>], blend: usize) -> Vec<Point3<f64>> {
    let n = rec.len();
    let centroid: Vec<Option<Point3<f64>>> = (0..n)
        .map(|t| {
            let pts: Vec<Point3<f64>> = touch.iter().filter_map(|b| b[t].map(|x| x.0)).collect();
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

/// The pad of `link` (at world pose `pose`) that goes onto the world point `at` of a face
/// whose normal there is `normal`: of the link's surface samples facing the face (outward
/// normal against the face's), the one nearest `at` (link frame). Pulling it onto the point
/// puts the link on the face's side, not across the surface; a link with no sample facing
/// the face gives its sample nearest `at`.
fn pad(
    samples: &[(LinkId, Point3<f64>, Vector3<f64>)],
    link: LinkId,
    pose: &Isometry3<f64>,
    at: &Point3<f64>,
    normal: &Vector3<f64>,
) -> (Point3<f64>, Vector3<f64>) {
    let nearest = |facing: bool| {
        samples
            .iter()
            .filter(|(l, _, n)| *l == link && (!facing || (pose * n).dot(normal) < -0.7))
            .map(|(_, p, n)| (*p, *n))
            .min_by(|x, y| {
                (pose * x.0 - at)
                    .norm()
                    .total_cmp(&(pose * y.0 - at).norm())
            })
    };
    nearest(true)
        .or_else(|| nearest(false))
        .unwrap_or_else(|| (Point3::origin(), Vector3::zeros()))
}

/// How far inside a pad its second correspondence sits, and how far off the surface its
/// target [m] (see [`Tracker::frame`]).
const PAD_DEPTH_M: f64 = 0.005;

/// Off the object, a hand closer to it than this keeps to its previous frame's solution
/// [m] (see [`Tracker::frame`]).
const RELEASE_CLEARANCE_M: f64 = 0.01;

/// How far a hand without contacts keeps from the object [m]: farther than the physics
/// replay's contact skin (3 mm), so a hand that approaches or has let go does not push the
/// object.
const OFF_CLEARANCE_M: f64 = 0.005;

/// Off the object and near it, how far a target may be from where its point was on the
/// previous frame [m] (see [`Tracker::within_reach`]).
const RELEASE_STEP_M: f64 = 0.005;

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

/// A touching bone's correspondence for one held point: the point and the face's normal
/// there (object frame), and the link's pad on it with its outward normal (link frame).
#[derive(Clone, Copy, Debug)]
struct HeldPad {
    object_point: Point3<f64>,
    normal: Vector3<f64>,
    hand_point: Point3<f64>,
    pad_normal: Vector3<f64>,
}

/// One frame as [`Tracker::frame`] solved it.
struct Solved {
    wrist: Isometry3<f64>,
    q: Vec<f64>,
    /// The correspondences written to the demonstration.
    contacts: Vec<ResolvedContact>,
    /// Everything the frame was solved for, and the objective it ended at.
    targets: Vec<ResolvedContact>,
    objective: f64,
    /// Solved backward from a grasp ([`Tracker::approach`]).
    approaching: bool,
}

/// The state carried from frame to frame by [`retarget`].
struct Tracker<'a> {
    robot: &'a Robot,
    solver: IkSolver<'a>,
    samples: Vec<(LinkId, Point3<f64>, Vector3<f64>)>,
    poses: Vec<Isometry3<f64>>,
    wrist: Isometry3<f64>,
    q: Vec<f64>,
    /// The solver of frames without contacts: the hand keeps [`OFF_CLEARANCE_M`] from the
    /// object.
    off_solver: IkSolver<'a>,
    /// The keypoint fit without the object ([`Tracker::frame`]), and its state.
    free_solver: IkSolver<'a>,
    free_wrist: Isometry3<f64>,
    free_q: Vec<f64>,
    /// The previous frame's link poses, carried along with the object when it held it.
    prev_poses: Vec<Isometry3<f64>>,
    sdf: &'a crate::geometry::ObjectSdf,
    /// The correspondence (hand point, object point) of each bone's current touch span,
    /// chosen at its first frame.
    span: Vec<Option<HeldPad>>,
}

impl Tracker<'_> {
    /// Solves frame `t`: the keypoints `k` (already scaled), then with the touching bones'
    /// correspondences; returns those correspondences.
    fn frame(
        &mut self,
        resolved: &Resolved,
        pose: &Isometry3<f64>,
        k: &[Point3<f64>; 21],
        touch: impl Fn(usize) -> Touch,
        contact_weight: usize,
    ) -> Solved {
        let inv = pose.inverse();
        self.robot
            .forward_kinematics(&self.wrist, &self.q, &mut self.prev_poses);
        // The keypoints at the ends of a touching bone are not targets: where the recording
        // touches, its keypoints are the least trustworthy (a fitted hand sinks through a
        // thin wall and puts a fingertip on its far side), and the touch stands for them.
        let touching: Vec<usize> = resolved
            .bones
            .iter()
            .enumerate()
            .filter(|(b, _)| touch(*b).is_some())
            .flat_map(|(_, bone)| [bone.0, bone.1])
            .collect();
        let all_targets: Vec<ResolvedContact> = resolved
            .keypoints
            .iter()
            .map(|&(i, link, p)| ResolvedContact {
                link,
                hand_point: p,
                object_point: inv * k[i],
            })
            .collect();
        let targets: Vec<ResolvedContact> = resolved
            .keypoints
            .iter()
            .zip(&all_targets)
            .filter(|((i, _, _), _)| !touching.contains(i))
            .map(|(_, c)| *c)
            .collect();
        // The recording as it is: every keypoint, the object ignored, from the previous
        // frame's free fit, so the hand follows the recording and is never caught on the
        // object's far side.
        self.free_solver
            .solve(pose, &all_targets, &mut self.free_wrist, &mut self.free_q);
        // Where the pads are chosen: the free fit (the previous frame's solution is tried
        // too, see `best_of`).
        self.robot
            .forward_kinematics(&self.free_wrist, &self.free_q, &mut self.poses);
        let mut contacts = Vec::new();
        let mut centres = Vec::new();
        for (b, &(_, _, _, link)) in resolved.bones.iter().enumerate() {
            let Some((recorded, normal)) = touch(b) else {
                self.span[b] = None;
                continue;
            };
            if self.span[b].is_some_and(|s| s.object_point != recorded) {
                self.span[b] = None;
            }
            let (samples, poses) = (&self.samples, &self.poses);
            let held = *self.span[b].get_or_insert_with(|| {
                let (hand_point, pad_normal) = pad(
                    samples,
                    link,
                    &poses[link.index()],
                    &(pose * recorded),
                    &(pose * normal),
                );
                HeldPad {
                    object_point: recorded,
                    normal,
                    hand_point,
                    pad_normal,
                }
            });
            contacts.push(ResolvedContact {
                link,
                hand_point: held.hand_point,
                object_point: held.object_point,
            });
            // The pad's inside, off the surface by as much: the link lies on the face's side.
            centres.push(ResolvedContact {
                link,
                hand_point: held.hand_point - held.pad_normal * PAD_DEPTH_M,
                object_point: held.object_point + held.normal * PAD_DEPTH_M,
            });
        }
        if contacts.is_empty() {
            // Off the object the hand may jump to its free fit only while it is clear of the
            // object: a hand letting go of a grasp leaves it continuously, not through it.
            let objective = if self.clearance(pose) > RELEASE_CLEARANCE_M {
                self.best_of(pose, &targets, true)
            } else {
                let near = self.within_reach(pose, &targets);
                self.carry_on(pose, &near)
            };
            return self.solved(contacts, targets, objective);
        }
        let mut all: Vec<ResolvedContact> = Vec::new();
        for _ in 0..contact_weight.max(1) {
            all.extend_from_slice(&contacts);
            all.extend_from_slice(&centres);
        }
        all.extend(
            targets
                .iter()
                .filter(|c| !contacts.iter().any(|x| x.link == c.link)),
        );
        let objective = self.best_of(pose, &all, false);
        self.solved(contacts, all, objective)
    }

    fn solved(
        &self,
        contacts: Vec<ResolvedContact>,
        targets: Vec<ResolvedContact>,
        objective: f64,
    ) -> Solved {
        Solved {
            wrist: self.wrist,
            q: self.q.clone(),
            contacts,
            targets,
            objective,
            approaching: false,
        }
    }

    /// Solves `targets` from the previous frame's solution, [`OFF_CLEARANCE_M`] off the
    /// object.
    fn carry_on(&mut self, pose: &Isometry3<f64>, targets: &[ResolvedContact]) -> f64 {
        let end = self
            .off_solver
            .solve(pose, targets, &mut self.wrist, &mut self.q)
            .objective_end;
        self.robot
            .forward_kinematics(&self.wrist, &self.q, &mut self.poses);
        end
    }

    /// `targets` brought within [`RELEASE_STEP_M`] of where their points were on the
    /// previous frame: near the object the hand moves there at a hand's pace, so a finger
    /// in a hollow slides out over its rim instead of being swept through it when the
    /// recording's targets jump.
    fn within_reach(
        &self,
        pose: &Isometry3<f64>,
        targets: &[ResolvedContact],
    ) -> Vec<ResolvedContact> {
        let inv = pose.inverse();
        targets
            .iter()
            .map(|c| {
                let from = self.prev_poses[c.link.index()] * c.hand_point;
                let to = pose * c.object_point;
                let d = (to - from).norm();
                let to = if d > RELEASE_STEP_M {
                    from + (to - from) * (RELEASE_STEP_M / d)
                } else {
                    to
                };
                ResolvedContact {
                    object_point: inv * to,
                    ..*c
                }
            })
            .collect()
    }

    /// The approach to each grasp, solved backward from it (see the module docs, step 5):
    /// every frame without contacts before a touching one is solved from the next frame's
    /// hand, its targets within [`RELEASE_STEP_M`] of where that hand's points are and
    /// [`OFF_CLEARANCE_M`] off the object, until the hand is [`RELEASE_CLEARANCE_M`] clear of
    /// it; farther back the forward pass's hand stays. The hand then closes onto the grasp
    /// at a hand's pace instead of jumping into it on the first touching frame (a robot hand
    /// larger than the person's, its fingers scaled out on the approach, would sweep through
    /// the object there).
    fn approach(&mut self, object: &[Isometry3<f64>], solved: &mut [Solved]) {
        for t in (0..solved.len().saturating_sub(1)).rev() {
            if !solved[t].contacts.is_empty() {
                continue;
            }
            let next = &solved[t + 1];
            let from_grasp = !next.contacts.is_empty() || next.approaching;
            if !from_grasp {
                continue;
            }
            self.wrist = object[t] * object[t + 1].inverse() * next.wrist;
            self.q.clone_from(&next.q);
            self.robot
                .forward_kinematics(&self.wrist, &self.q, &mut self.prev_poses);
            if self.clearance(&object[t]) > RELEASE_CLEARANCE_M {
                continue;
            }
            let near = self.within_reach(&object[t], &solved[t].targets);
            let objective = self.carry_on(&object[t], &near);
            solved[t].wrist = self.wrist;
            solved[t].q.clone_from(&self.q);
            solved[t].objective = objective;
            solved[t].approaching = true;
        }
    }

    /// How far the previous frame's hand (its link poses, `self.poses` before this frame's
    /// solve) is from the object at `pose` [m], over the hand's surface samples.
    fn clearance(&self, pose: &Isometry3<f64>) -> f64 {
        let inv = pose.inverse();
        self.samples
            .iter()
            .map(|(l, p, _)| self.sdf.distance(&(inv * (self.prev_poses[l.index()] * p))))
            .fold(f64::INFINITY, f64::min)
    }

    /// Solves `targets` with the object from two starts, the previous frame's solution and
    /// this frame's free fit, and keeps the one that ends lower: the previous solution
    /// carries a grasp through frames where the recording's keypoints pass through the
    /// object, the free fit gets a hand caught on the object's wrong side back.
    /// `off`: the frame has no contacts, and the hand keeps [`OFF_CLEARANCE_M`] from the
    /// object.
    fn best_of(&mut self, pose: &Isometry3<f64>, targets: &[ResolvedContact], off: bool) -> f64 {
        let solver = if off {
            &mut self.off_solver
        } else {
            &mut self.solver
        };
        let (mut w2, mut q2) = (self.free_wrist, self.free_q.clone());
        let from_free = solver.solve(pose, targets, &mut w2, &mut q2);
        let from_prev = solver.solve(pose, targets, &mut self.wrist, &mut self.q);
        let mut end = from_prev.objective_end;
        if from_free.objective_end < end {
            self.wrist = w2;
            self.q = q2;
            end = from_free.objective_end;
        }
        self.robot
            .forward_kinematics(&self.wrist, &self.q, &mut self.poses);
        end
    }
}

/// The backward pass (see the module docs, step 5): a grasp the forward pass reaches only
/// some frames into a touch (a finger caught on a rim while the recording's passes through
/// it) is carried back to the frames before, wherever it ends lower.
fn backward(solver: &mut IkSolver<'_>, object: &[Isometry3<f64>], solved: &mut [Solved]) {
    for t in (0..solved.len().saturating_sub(1)).rev() {
        if solved[t].contacts.is_empty() || solved[t + 1].contacts.is_empty() {
            continue;
        }
        let mut wrist = object[t] * object[t + 1].inverse() * solved[t + 1].wrist;
        let mut q = solved[t + 1].q.clone();
        let end = solver
            .solve(&object[t], &solved[t].targets, &mut wrist, &mut q)
            .objective_end;
        if end < solved[t].objective {
            solved[t].wrist = wrist;
            solved[t].q = q;
            solved[t].objective = end;
        }
    }
}

/// Retargets `rec` onto `robot` (see the module docs). `support` is the table as a world
/// shape. The IK keeps its defaults (non-penetration on) but for a stop rule of 0.5 mm and the
/// support's reach [`Params::support_margin_m`].
pub fn retarget(
    robot: &Robot,
    robot_path: &Path,
    map: &KeypointMap,
    rec: &Recording,
    object: &ObjectGeometry,
    support: &[CollisionShape],
    params: &Params,
) -> Result<Retargeted> {
    let ik = &IkParams {
        threshold_mm: 0.5,
        margin_m: params.support_margin_m,
        ..IkParams::default()
    };
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
        samples: crate::synth::contacts::hand_surface(robot, 0.004),
        poses,
        off_solver: IkSolver::new(
            robot,
            support,
            Some(&object.sdf),
            IkParams {
                // The hinge starts at half the tolerance: a clearance.
                penetration_tolerance_mm: -2.0 * OFF_CLEARANCE_M * 1e3,
                ..ik.clone()
            },
        ),
        free_solver: IkSolver::new(robot, support, None, ik.clone()),
        free_wrist: wrist,
        free_q: q.clone(),
        prev_poses: robot.new_link_poses(),
        sdf: &object.sdf,
        wrist,
        q,
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
    // Forward: each frame from the previous one's solution or its free fit.
    let mut solved: Vec<Solved> = Vec::with_capacity(n);
    for t in 0..n {
        // A hand that holds the object starts the frame carried along with it.
        if t > 0 && !solved[t - 1].contacts.is_empty() {
            tracker.wrist = rec.object[t] * rec.object[t - 1].inverse() * tracker.wrist;
        }
        solved.push(tracker.frame(
            &resolved,
            &rec.object[t],
            &scaled[t],
            |b| touch[b][t],
            params.contact_weight,
        ));
    }
    backward(&mut tracker.solver, &rec.object, &mut solved);
    tracker.approach(&rec.object, &mut solved);
    let mut poses = robot.new_link_poses();
    for (t, frame) in solved.into_iter().enumerate() {
        robot.forward_kinematics(&frame.wrist, &frame.q, &mut poses);
        let contacts = frame.contacts;
        if !contacts.is_empty() {
            out.touch = Some([out.touch.map_or(t, |[a, _]| a), t]);
        }
        let (mean, max, at) = residual(&resolved.keypoints, &poses, &scaled[t]);
        out.residuals.mean_mm.push(mean);
        out.residuals.max_mm.push(max);
        out.residuals.worst.push(KEYPOINTS[at].to_string());
        out.wrists.push(frame.wrist);
        out.joints.push(frame.q);
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
        let p = Some(Point3::<f64>::origin());
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
    fn a_touch_holds_its_median_and_a_regrasp_starts_a_new_point() {
        let n = Vector3::x();
        let at = |x: f64, t: usize| Some((Point3::new(x + 0.002 * (t % 3) as f64, 0.0, 0.0), n));
        // 12 frames about A, 4 frames 30 mm away (too short for a regrasp), 8 about A, 12
        // frames about B = A + 30 mm (a regrasp), then no touch.
        let mut v: Vec<Touch> = (0..12).map(|t| at(0.0, t)).collect();
        v.extend((0..4).map(|t| at(0.03, t)));
        v.extend((0..8).map(|t| at(0.0, t)));
        v.extend((0..12).map(|t| at(0.03, t)));
        v.push(None);
        hold_spans(&mut v, 0.015, 10);
        let x: Vec<f64> = v.iter().map(|p| p.map_or(f64::NAN, |p| p.0.x)).collect();
        // The excursion is held at the first part's median (per axis over its 24 frames),
        // the regrasp gets the second part's.
        assert!(x[..24].iter().all(|&a| a == x[0]), "{x:?}");
        assert!((x[0] - 0.002).abs() < 1e-12, "{}", x[0]);
        assert!(
            x[24..36].iter().all(|&a| (a - 0.032).abs() < 1e-12),
            "{x:?}"
        );
        assert!(v[36].is_none());
    }

    #[test]
    fn a_touch_lasts_until_the_bone_is_released() {
        let params = Params::default();
        let seen: Vec<Seen> = [5.0, 3.0, 6.0, 9.0, 11.0, 5.0, 3.5]
            .iter()
            .map(|mm| Some((mm * 1e-3, Point3::origin(), Vector3::x())))
            .collect();
        let on: Vec<bool> = hysteresis(&seen, &params)
            .iter()
            .map(Option::is_some)
            .collect();
        assert_eq!(on, [false, true, true, true, false, false, true]);
    }

    #[test]
    fn a_bone_through_a_thin_wall_touches_the_face_it_came_from() {
        // A wall 2 mm thick (x in [-1, 1] mm), 60 mm square.
        let mut mesh = crate::synth::objects::object_mesh(crate::synth::objects::ObjectKind::Cube);
        for v in &mut mesh.vertices {
            v.x *= 0.002 / 0.06;
        }
        let wall = ObjectGeometry::new(mesh).unwrap();
        // A finger coming from the -x side whose tip keypoint ends past the wall, nearer
        // its +x face: it touches the -x face.
        let mm = |x: f64, y: f64, z: f64| Point3::new(x, y, z) * 1e-3;
        let (d, p, n) = bone_touch(
            &wall,
            &mm(-30.0, 0.0, 20.0),
            &mm(-10.0, 0.0, 0.0),
            &mm(8.0, 0.0, 0.0),
            0.0075,
        )
        .unwrap();
        assert!(d < 0.0, "clearance {d}");
        assert!((p.x + 0.001).abs() < 1e-4, "touch at {p}");
        assert!(n.x < -0.9, "normal {n}");
        // The same bone from the +x side touches the +x face.
        let (_, p, n) = bone_touch(
            &wall,
            &mm(30.0, 0.0, 20.0),
            &mm(10.0, 0.0, 0.0),
            &mm(-8.0, 0.0, 0.0),
            0.0075,
        )
        .unwrap();
        assert!(
            (p.x - 0.001).abs() < 1e-4 && n.x > 0.9,
            "touch at {p}, normal {n}"
        );
        // Off the wall by 20 mm: a clearance of 20 mm less the radius.
        let (d, _, _) = bone_touch(
            &wall,
            &mm(-60.0, 0.0, 0.0),
            &mm(-40.0, 0.0, 0.0),
            &mm(-21.0, 0.0, 0.0),
            0.0075,
        )
        .unwrap();
        assert!((d - 0.0125).abs() < 1e-4, "clearance {d}");
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
