//! Kinematic quality metrics (docs/METHOD.md "Metrics", paper "Quantitative evaluation").
//!
//! * `D_WO`: mean over frames of `|wrist position − object origin|` [mm].
//! * `D_C`: mean over in-contact frames of the mean correspondence distance
//!   `|FK(link)·hand_point − O·object_point|` [mm].
//! * PLR: path length of the warped trajectory over that of the original, for the object
//!   origin and for the wrist.
//! * Timewarp discrepancy: ours in [`crate::warp::retime::Timewarp::discrepancy`], the
//!   paper's in [`crate::warp::retime::paper_discrepancy`].
//! * `D_C` over the stretched frames: output frames `t` of the contact segment whose bracketing
//!   input step `s → s+1` (`s = t*`) was given more than one output frame,
//!   `τ(s+1) − τ(s) > 1`: few input frames cover many output frames there, which is where the
//!   rigid baseline's interpolation between correct poses departs from the contacts.

use nalgebra::Isometry3;

use crate::model::Demo;
use crate::robot::Robot;
use crate::warp::retime::Timewarp;

/// `D_WO` of a demonstration [mm].
pub fn d_wo_mm(demo: &Demo) -> f64 {
    let n = demo.frames.len().max(1) as f64;
    demo.frames
        .iter()
        .map(|f| (f.wrist.translation.vector - f.object.translation.vector).norm())
        .sum::<f64>()
        / n
        * 1e3
}

/// The wrist origin of a frame in its object's frame [m].
fn wrist_in_object(f: &crate::model::Frame) -> nalgebra::Vector3<f64> {
    f.object
        .inverse_transform_point(&f.wrist.translation.vector.into())
        .coords
}

/// How far the hand slides on the object while it holds it [mm]: over the contact segment,
/// the largest distance of the wrist origin, in the object's frame, from its mean position
/// there. 0 for a grasp held rigidly (a synthesized recording, the rigid baseline); a hand
/// that follows drifting correspondences slides. `None` without a contact segment.
pub fn grasp_slide_mm(demo: &Demo) -> Option<f64> {
    let s = demo.contact_segment()?;
    let rel: Vec<nalgebra::Vector3<f64>> = demo.frames[s.start..=s.end]
        .iter()
        .map(wrist_in_object)
        .collect();
    let mean = rel.iter().sum::<nalgebra::Vector3<f64>>() / rel.len() as f64;
    Some(rel.iter().map(|r| (r - mean).norm()).fold(0.0, f64::max) * 1e3)
}

/// How far an output's grasp sits from the recording's [mm]: over the output frames
/// `frames` (the contact segment), the mean distance between the wrist origin in the object's
/// frame and the recorded one at the source frame `source(t)`. 0 for the rigid transfer at
/// its known frames; contact IK moves it where it fits correspondences that the recorded hand
/// does not (a capture error shared by a frame's points). `None` for an empty range.
pub fn grasp_shift_mm(
    original: &Demo,
    out: &Demo,
    frames: std::ops::RangeInclusive<usize>,
    source: impl Fn(usize) -> usize,
) -> Option<f64> {
    let shifts: Vec<f64> = frames
        .filter_map(|t| {
            let (o, s) = (out.frames.get(t)?, original.frames.get(source(t))?);
            Some((wrist_in_object(o) - wrist_in_object(s)).norm())
        })
        .collect();
    (!shifts.is_empty()).then(|| shifts.iter().sum::<f64>() / shifts.len() as f64 * 1e3)
}

/// The deepest hand-object penetration over all frames of `demo` [mm]: the hand's
/// penetration probes in the object's signed distance field (the measure the contact IK
/// constrains and the physics check reports). 0 when the hand never enters the object.
pub fn max_hand_object_penetration_mm(
    robot: &Robot,
    demo: &Demo,
    sdf: &crate::geometry::ObjectSdf,
) -> f64 {
    let mut poses = robot.new_link_poses();
    demo.frames
        .iter()
        .map(|f| {
            robot.forward_kinematics(&f.wrist, &f.joints, &mut poses);
            crate::robot::probes::deepest(robot, &poses, &f.object.inverse(), sdf)
                .map_or(0.0, |(d, _)| d * 1e3)
        })
        .fold(0.0, f64::max)
}

/// Mean correspondence distance of every frame [mm]; `None` for frames without contacts.
/// The demonstration's joints must be in robot order ([`Demo::check_robot`]).
pub fn contact_distance_per_frame_mm(robot: &Robot, demo: &Demo) -> Vec<Option<f64>> {
    let mut poses = robot.new_link_poses();
    let mut ids = Vec::new();
    demo.frames
        .iter()
        .map(|f| {
            if f.contacts.is_empty() {
                return None;
            }
            robot.forward_kinematics(&f.wrist, &f.joints, &mut poses);
            ids.clear();
            ids.extend(f.contacts.iter().map(|c| robot.link_id(&c.link)));
            let sum: f64 = f
                .contacts
                .iter()
                .zip(&ids)
                .map(|(c, id)| match id {
                    Some(id) => {
                        let hand = poses[id.index()] * c.hand_point;
                        let obj = f.object * c.object_point;
                        (hand - obj).norm()
                    }
                    None => f64::NAN,
                })
                .sum();
            Some(sum / f.contacts.len() as f64 * 1e3)
        })
        .collect()
}

/// `D_C` [mm]: the mean of [`contact_distance_per_frame_mm`] over frames with contacts
/// (0 when there are none).
pub fn d_c_mm(per_frame: &[Option<f64>]) -> f64 {
    let (sum, n) = per_frame
        .iter()
        .flatten()
        .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    if n == 0 { 0.0 } else { sum / n as f64 }
}

/// Polyline length of the object origin over all frames [m].
pub fn object_path_length(demo: &Demo) -> f64 {
    path_length(demo.frames.iter().map(|f| &f.object))
}

/// Polyline length of the wrist over all frames [m].
pub fn wrist_path_length(demo: &Demo) -> f64 {
    path_length(demo.frames.iter().map(|f| &f.wrist))
}

fn path_length<'a>(poses: impl Iterator<Item = &'a Isometry3<f64>>) -> f64 {
    let mut prev: Option<&Isometry3<f64>> = None;
    let mut total = 0.0;
    for p in poses {
        if let Some(q) = prev {
            total += (p.translation.vector - q.translation.vector).norm();
        }
        prev = Some(p);
    }
    total
}

/// `a / b`, or 1 when both are (near) zero, so a still object gives PLR 1, not NaN.
pub fn ratio(a: f64, b: f64) -> f64 {
    if b.abs() < 1e-12 {
        if a.abs() < 1e-12 { 1.0 } else { f64::INFINITY }
    } else {
        a / b
    }
}

/// Output frames in `range` that lie in a stretched input step (see the module docs): `true`
/// when `τ(t*+1) − τ(t*) > 1`.
pub fn stretched_frames(tw: &Timewarp, range: std::ops::RangeInclusive<usize>) -> Vec<usize> {
    let n = tw.tau.len();
    range
        .filter(|&t| {
            let s = tw.source_frame(t as f64);
            s + 1 < n && tw.tau[s + 1] - tw.tau[s] > 1.0 + 1e-9
        })
        .collect()
}

/// Mean of the per-frame contact distance over `frames` (frames without contacts skipped);
/// `None` when none has one.
pub fn d_c_over_mm(per_frame: &[Option<f64>], frames: &[usize]) -> Option<f64> {
    let (sum, n) = frames
        .iter()
        .filter_map(|&t| per_frame.get(t).copied().flatten())
        .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    (n > 0).then(|| sum / n as f64)
}

/// The output frame with the largest contact distance and that distance [mm].
pub fn worst_frame(per_frame: &[Option<f64>]) -> Option<(usize, f64)> {
    per_frame
        .iter()
        .enumerate()
        .filter_map(|(t, v)| v.map(|v| (t, v)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::demo::ObjectInfo;
    use crate::model::{Contact, Frame};
    use nalgebra::{Point3, Translation3, UnitQuaternion, Vector3};
    use std::path::PathBuf;

    /// An object turning and rising over 20 frames with the wrist 10 cm from it in its frame;
    /// frames 5-14 have contacts.
    fn carried(wrist_in_object: impl Fn(usize) -> Vector3<f64>) -> Demo {
        let contact = Contact {
            link: "palm".into(),
            hand_point: Point3::origin(),
            object_point: Point3::origin(),
        };
        let frames = (0..20)
            .map(|i| {
                let object = Isometry3::from_parts(
                    Translation3::new(0.0, 0.0, 0.01 * i as f64),
                    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.1 * i as f64),
                );
                let wrist = object * Translation3::from(wrist_in_object(i));
                Frame {
                    object,
                    wrist: Isometry3::from_parts(wrist.translation, wrist.rotation),
                    joints: Vec::new(),
                    contacts: if (5..15).contains(&i) {
                        vec![contact.clone()]
                    } else {
                        Vec::new()
                    },
                }
            })
            .collect();
        Demo {
            name: "t".into(),
            fps: 30.0,
            robot: PathBuf::new(),
            object: ObjectInfo {
                name: "o".into(),
                mesh: PathBuf::new(),
                mass: 0.1,
            },
            joint_names: Vec::new(),
            frames,
            timewarp: None,
            scene: None,
            barriers: Vec::new(),
            wrist_link: None,
            source: PathBuf::new(),
        }
    }

    /// A wrist fixed in the object's frame does not slide however the object moves; one
    /// that moves 4 mm along the object's x over the contact segment slides 2 mm from its
    /// mean; frames outside contact do not count; no contacts, no figure.
    #[test]
    fn grasp_slide_is_the_wrists_travel_in_the_objects_frame_while_in_contact() {
        let rigid = carried(|_| Vector3::new(0.1, 0.0, 0.0));
        assert!(grasp_slide_mm(&rigid).unwrap() < 1e-9);
        let sliding = carried(|i| {
            let s = (i.clamp(5, 14) - 5) as f64 / 9.0;
            Vector3::new(0.1 + 0.004 * s, 0.0, 0.0) + Vector3::y() * if i < 5 { 0.05 } else { 0.0 }
        });
        assert!((grasp_slide_mm(&sliding).unwrap() - 2.0).abs() < 1e-9);
        let mut none = rigid;
        for f in &mut none.frames {
            f.contacts.clear();
        }
        assert_eq!(grasp_slide_mm(&none), None);
    }

    /// The same grasp gives no shift whatever the frame mapping; a grasp 3 mm along the
    /// object's z from the recorded one, turned with the object, gives 3 mm; an empty range
    /// gives no figure.
    #[test]
    fn grasp_shift_is_the_wrists_distance_from_the_recorded_grasp_in_the_objects_frame() {
        let recorded = carried(|_| Vector3::new(0.1, 0.0, 0.0));
        assert!(grasp_shift_mm(&recorded, &recorded, 5..=14, |t| t).unwrap() < 1e-9);
        // Output frame t shows input frame t / 2 (a 2x stretch): still the recorded grasp.
        assert!(grasp_shift_mm(&recorded, &recorded, 5..=14, |t| t / 2).unwrap() < 1e-9);
        let higher = carried(|_| Vector3::new(0.1, 0.0, 0.003));
        let shift = grasp_shift_mm(&recorded, &higher, 5..=14, |t| t).unwrap();
        assert!((shift - 3.0).abs() < 1e-9, "{shift}");
        #[allow(clippy::reversed_empty_ranges)]
        let empty = 5..=4;
        assert_eq!(grasp_shift_mm(&recorded, &higher, empty, |t| t), None);
    }
}
