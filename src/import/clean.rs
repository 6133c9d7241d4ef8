//! A recorded robot hand made a physically valid source (`import --csv`, `import --lerobot`;
//! off with `--no-clean`).
//!
//! Teleoperation and motion capture of a robot hand bring what a human-hand recording brings
//! ([`super::keypoints`]): fingers some millimetres inside the object or the table, per-frame
//! jitter, an object standing a little off its support, an open mesh, no scene. The
//! recorded hand is the demonstration's hand here, so nothing is retargeted; the cleaning:
//! 1. *Mesh.* An open or inside-out object mesh is repaired (or refused, or replaced by its
//!    hull with `--hull-fallback`), and the repaired mesh written beside the demonstration.
//! 2. *Scene.* Without `--scene`, the table under the object's first pose is inferred and
//!    written as `NAME.scene.json`; the object's first and last rest poses are settled on the
//!    supports and the hand carried with them (see [`super::recorded::place_object`]).
//! 3. *Smoothing.* The wrist's path and every joint's are smoothed (Savitzky-Golay,
//!    quadratic, [`CleanOptions::smoothing_window`] frames; the wrist's rotation as a
//!    hemisphere-aligned quaternion); the object's path is kept as recorded.
//! 4. *Out of the object and the table.* Each frame whose hand sits in the object deeper than
//!    half the IK's penetration tolerance, or closer than [`SUPPORT_CLEARANCE_MM`] to a
//!    support, is solved by the contact IK: every surface sample of the hand (every
//!    [`SAMPLE_SPACING_M`]) a target at its recorded place, moved onto the surface where the
//!    recorded place is inside, with the non-penetration term and the supports' clearance.
//!    The fingers come out onto the surface where the recording touches; frames that need
//!    nothing are left to the bit.
//! 5. *Contacts.* Correspondences given with `--contacts` are kept; otherwise they are
//!    extracted from the cleaned hand (the contact segment is where it touches).
//!
//! `NAME.import.json` says per frame how deep the recorded and the cleaned hand are in the
//! object and how far the cleaning moved the hand's surface samples (mean, largest).

use std::path::{Path, PathBuf};
use std::time::Instant;

use nalgebra::{Isometry3, Point3, Quaternion, UnitQuaternion, Vector3};
use serde::Serialize;

use super::recorded::{
    Placed, Placement, Placing, depths, moved_before_touch, place_object, solid_object,
    write_record,
};
use super::{Pose, Target, extract_contacts, finish_in};
use crate::geometry::Mesh;
use crate::geometry::shape::CollisionShape;
use crate::hand::ik::{IkSolver, ResolvedContact};
use crate::model::{Contact, Demo};
use crate::robot::{LinkId, Robot};
use crate::synth::proximity::ObjectGeometry;
use crate::{Error, Limits, Result};

/// Spacing of the hand's surface samples that the cleaning keeps in place [m].
pub const SAMPLE_SPACING_M: f64 = 0.008;

/// Clearance the cleaned hand keeps from a support [mm].
pub const SUPPORT_CLEARANCE_MM: f64 = 1.0;

/// Options of the cleaning.
#[derive(Clone, Debug)]
pub struct CleanOptions {
    /// Savitzky-Golay window of the hand's smoothing [frames, odd]; 1 turns it off.
    pub smoothing_window: usize,
    /// Simulate an object mesh that cannot be repaired as its convex hull.
    pub hull_fallback: bool,
    /// A scene to name instead of the inferred table.
    pub scene: Option<PathBuf>,
}

impl Default for CleanOptions {
    fn default() -> Self {
        CleanOptions {
            smoothing_window: 7,
            hull_fallback: false,
            scene: None,
        }
    }
}

/// Where a recording came from, for the import's errors and its record.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Source<'a> {
    pub path: &'a Path,
    /// The recording's names of the object's pose and of the wrist's height.
    pub columns: [&'a str; 2],
}

/// What the cleaning of a robot-hand recording did.
#[derive(Clone, Debug, Serialize)]
pub struct RobotImport {
    #[serde(skip)]
    pub demo: Demo,
    pub recording: PathBuf,
    /// The object's mesh and scene.
    #[serde(flatten)]
    pub placement: Placement,
    pub smoothing_window: usize,
    /// Frames on which the hand was solved out of the object or the table.
    pub frames_moved: usize,
    /// First and last frame with correspondences.
    pub contact_frames: Option<[usize; 2]>,
    pub warnings: Vec<String>,
    /// How far the cleaned hand's surface samples are from the recorded hand's (smoothing
    /// and the way out together) [mm]: the mean over frames of each frame's mean, and the
    /// largest.
    pub residual_mean_mm: f64,
    pub residual_max_mm: f64,
    /// Deepest the recorded and the cleaned hand are in the object over all frames [mm].
    pub max_penetration_recorded_mm: f64,
    pub max_penetration_mm: f64,
    /// Wall time of the import [s].
    pub time_s: f64,
    pub per_frame: PerFrame,
}

/// Per-frame figures of the cleaning.
#[derive(Clone, Debug, Default, Serialize)]
pub struct PerFrame {
    pub residual_mean_mm: Vec<f64>,
    pub residual_max_mm: Vec<f64>,
    pub penetration_recorded_mm: Vec<f64>,
    pub penetration_mm: Vec<f64>,
}

/// Smooths the hand's path in place: wrist translation, wrist rotation (a quaternion kept on
/// the previous frame's hemisphere, renormalized) and every joint (clamped to its limits).
pub fn smooth_hand(robot: &Robot, poses: &mut [Pose], window: usize) {
    if window < 3 || poses.len() < 3 {
        return;
    }
    let filter = |v: &[f64]| crate::math::savgol::savgol_filter(v, window, 2).ok();
    let t: Vec<Vector3<f64>> = poses.iter().map(|p| p.1.translation.vector).collect();
    let mut q: Vec<Quaternion<f64>> = poses.iter().map(|p| *p.1.rotation.quaternion()).collect();
    for i in 1..q.len() {
        if q[i].dot(&q[i - 1]) < 0.0 {
            q[i] = -q[i];
        }
    }
    let comps: Vec<Option<Vec<f64>>> = (0..4)
        .map(|c| filter(&q.iter().map(|x| x.coords[c]).collect::<Vec<_>>()))
        .collect();
    if let Ok(t) = crate::math::savgol::savgol_filter3(&t, window, 2) {
        for (p, v) in poses.iter_mut().zip(t) {
            p.1.translation.vector = v;
        }
    }
    if comps.iter().all(Option::is_some) {
        for (i, p) in poses.iter_mut().enumerate() {
            let c = |k: usize| comps[k].as_ref().map_or(0.0, |v| v[i]);
            let s = Quaternion::from(nalgebra::Vector4::new(c(0), c(1), c(2), c(3)));
            if s.norm() > 1e-9 {
                p.1.rotation = UnitQuaternion::from_quaternion(s);
            }
        }
    }
    for j in 0..robot.dof() {
        if let Some(s) = filter(&poses.iter().map(|p| p.2[j]).collect::<Vec<_>>()) {
            for (p, v) in poses.iter_mut().zip(s) {
                p.2[j] = v;
            }
        }
    }
    for p in poses.iter_mut() {
        robot.clamp(&mut p.2);
    }
}

/// Where the world point `p` goes when it is inside a support or nearer to it than
/// [`SUPPORT_CLEARANCE_MM`]: its nearest point on the support's surface, the clearance out.
fn off_supports(supports: &[CollisionShape], p: &Point3<f64>) -> Option<Point3<f64>> {
    let c = SUPPORT_CLEARANCE_MM * 1e-3;
    supports.iter().find_map(|s| {
        let pose = crate::math::convert::to_pose(&s.shape_pose);
        let proj = s
            .shape
            .project_point(&pose, crate::math::convert::to_point(p), false);
        let on = Point3::new(proj.point.x, proj.point.y, proj.point.z);
        let d = (p - on).norm();
        if !proj.is_inside && d >= c {
            return None;
        }
        // Outward: from the point to the surface when inside, away from it when outside.
        let out = if proj.is_inside { on - p } else { p - on };
        let dir = if d > 1e-9 { out / d } else { Vector3::z() };
        Some(on + dir * c)
    })
}

/// Largest distance of the hand's samples from the recording at which a frame that needs
/// no cleaning snaps back onto the recording [m].
const SNAP_BACK_M: f64 = 0.001;

/// Takes the hand out of the object and the supports (see the module docs, step 4), in
/// place, frame by frame from the first; per frame whether it was solved.
fn push_out(
    robot: &Robot,
    samples: &[(LinkId, Point3<f64>)],
    geometry: &ObjectGeometry,
    supports: &[CollisionShape],
    poses: &mut [Pose],
) -> Vec<bool> {
    let params = crate::hand::ik::Params {
        threshold_mm: 0.25,
        margin_m: 0.005,
        barrier_clearance_mm: SUPPORT_CLEARANCE_MM,
        ..crate::hand::ik::Params::default()
    };
    let half_tolerance = params.penetration_tolerance_mm * 0.5e-3;
    let mut solver = IkSolver::new(robot, supports, Some(&geometry.sdf), params);
    let (mut links, mut solved_links) = (robot.new_link_poses(), robot.new_link_poses());
    let recorded = poses.to_vec();
    // The previous frame's cleaned hand while it is off the recording.
    let mut off: Option<(Isometry3<f64>, Vec<f64>)> = None;
    let mut solved = vec![false; poses.len()];
    for (t, (object, wrist, q)) in recorded.iter().enumerate() {
        robot.forward_kinematics(wrist, q, &mut links);
        let inv = object.inverse();
        let world: Vec<Point3<f64>> = samples.iter().map(|&(l, p)| links[l.index()] * p).collect();
        let needs = world.iter().any(|w| {
            geometry.sdf.distance(&(inv * w)) < -half_tolerance
                || off_supports(supports, w).is_some()
        });
        if !needs && off.is_none() {
            continue;
        }
        // Every sample's target is where the recording has it: the non-penetration term and
        // the supports' clearance stop the hand at their surfaces.
        let targets: Vec<ResolvedContact> = samples
            .iter()
            .zip(&world)
            .map(|(&(link, p), w)| ResolvedContact {
                link,
                hand_point: p,
                object_point: inv * w,
            })
            .collect();
        // Two starts, the lower end kept: the previous frame's cleaned hand moved as the
        // recording moves (a hand kept out of the object stays out instead of starting in
        // it), and the recording itself (a hand caught on the object's wrong side, or drifted
        // off with the recording's noise, comes back).
        let (mut w, mut qs) = (*wrist, q.clone());
        let end = solver
            .solve(object, &targets, &mut w, &mut qs)
            .objective_end;
        if let Some((pw, pq)) = &off {
            let (_, w0, q0) = &recorded[t - 1];
            let mut q2: Vec<f64> = pq
                .iter()
                .zip(q.iter().zip(q0))
                .map(|(p, (a, b))| p + a - b)
                .collect();
            robot.clamp(&mut q2);
            let mut w2 = wrist * w0.inverse() * pw;
            let e2 = solver
                .solve(object, &targets, &mut w2, &mut q2)
                .objective_end;
            if e2 < end {
                (w, qs) = (w2, q2);
            }
        }
        robot.forward_kinematics(&w, &qs, &mut solved_links);
        let apart = samples
            .iter()
            .zip(&world)
            .map(|(&(l, p), r)| (solved_links[l.index()] * p - r).norm())
            .fold(0.0, f64::max);
        if !needs && apart < SNAP_BACK_M {
            off = None;
            continue;
        }
        poses[t].1 = w;
        poses[t].2.clone_from(&qs);
        solved[t] = true;
        off = Some((w, qs));
    }
    solved
}

/// Per frame, how far the hand's `samples` are in `b` from where they are in `a` [mm]: mean
/// and largest.
fn residuals(
    robot: &Robot,
    samples: &[(LinkId, Point3<f64>)],
    a: &[Pose],
    b: &[Pose],
) -> (Vec<f64>, Vec<f64>) {
    let (mut la, mut lb) = (robot.new_link_poses(), robot.new_link_poses());
    a.iter()
        .zip(b)
        .map(|(a, b)| {
            robot.forward_kinematics(&a.1, &a.2, &mut la);
            robot.forward_kinematics(&b.1, &b.2, &mut lb);
            let d: Vec<f64> = samples
                .iter()
                .map(|&(l, p)| (lb[l.index()] * p - la[l.index()] * p).norm() * 1e3)
                .collect();
            (
                d.iter().sum::<f64>() / d.len().max(1) as f64,
                d.iter().copied().fold(0.0, f64::max),
            )
        })
        .unzip()
}

/// Cleans a recorded robot hand (see the module docs), writes the demonstration with its
/// scene and `NAME.import.json`, and reads it back.
pub(crate) fn clean(
    source: Source<'_>,
    robot: &Robot,
    fps: f64,
    mut poses: Vec<Pose>,
    contacts: Option<Vec<Vec<Contact>>>,
    options: &CleanOptions,
    target: &Target,
    limits: &Limits,
) -> Result<RobotImport> {
    let clock = Instant::now();
    if poses.is_empty() {
        return Err(Error::invalid(source.path, "(frames)", "has no frames"));
    }
    let mesh = Mesh::load(&target.mesh, Vector3::repeat(1.0), limits)?;
    let (mesh, repair, hull_volumes_cm3) = solid_object(&target.mesh, mesh, options.hull_fallback)?;
    let mut object: Vec<Isometry3<f64>> = poses.iter().map(|p| p.0).collect();
    let placed = place_object(
        Placing {
            recording: source.path,
            columns: source.columns,
            mesh,
            repair,
            hull_volumes_cm3,
            mirrored: false,
            scene: options.scene.as_deref(),
            hand_z0: poses[0].1.translation.z,
        },
        &mut object,
        robot,
        target,
        limits,
    )?;
    for ((p, o), world) in poses.iter_mut().zip(&object).zip(&placed.world) {
        p.0 = *o;
        p.1 = world * p.1;
    }
    let Placed {
        geometry,
        supports,
        record: placement,
        mut warnings,
        ..
    } = placed;
    let frames = |poses: &[Pose]| depths(robot, &geometry, poses.iter().map(|(o, w, q)| (o, w, q)));
    let recorded = poses.clone();
    let recorded_depth = frames(&poses);
    smooth_hand(robot, &mut poses, options.smoothing_window);
    let samples = crate::synth::contacts::hand_samples(robot, SAMPLE_SPACING_M);
    let solved = push_out(robot, &samples, &geometry, &supports, &mut poses);
    let (res_mean, res_max) = residuals(robot, &samples, &recorded, &poses);
    let depth = frames(&poses);
    let contacts = contacts.unwrap_or_else(|| extract_contacts(robot, &geometry, &poses));
    let with: Vec<usize> = (0..contacts.len())
        .filter(|&t| !contacts[t].is_empty())
        .collect();
    let contact_frames = with.first().map(|&a| [a, *with.last().unwrap_or(&a)]);
    warnings.extend(moved_before_touch(&object, contact_frames));
    let target = Target {
        mesh: placement.mesh.clone(),
        ..target.clone()
    };
    let demo = finish_in(
        &target,
        robot,
        fps,
        poses,
        Some(contacts),
        Some(placement.scene.clone()),
        limits,
    )?;
    let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    let import = RobotImport {
        demo,
        recording: source.path.to_path_buf(),
        placement,
        smoothing_window: options.smoothing_window,
        frames_moved: solved.iter().filter(|s| **s).count(),
        contact_frames,
        warnings,
        residual_mean_mm: res_mean.iter().sum::<f64>() / res_mean.len() as f64,
        residual_max_mm: max(&res_max),
        max_penetration_recorded_mm: max(&recorded_depth),
        max_penetration_mm: max(&depth),
        time_s: clock.elapsed().as_secs_f64(),
        per_frame: PerFrame {
            residual_mean_mm: res_mean,
            residual_max_mm: res_max,
            penetration_recorded_mm: recorded_depth,
            penetration_mm: depth,
        },
    };
    write_record(&target.out, &import)?;
    Ok(import)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gripper() -> Robot {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("robots/parallel_gripper.urdf");
        Robot::from_urdf_file(&path, &Limits::default()).unwrap()
    }

    /// A path quadratic in time comes through the smoothing as it was (the filter fits
    /// quadratics); jitter on it comes out smaller; a rotation whose quaternion flips sign
    /// from frame to frame is the same rotation and stays it.
    #[test]
    fn smoothing_keeps_a_smooth_hand_and_takes_the_jitter_out() {
        let robot = gripper();
        let n = 40;
        let truth: Vec<Pose> = (0..n)
            .map(|i| {
                let t = i as f64 / 30.0;
                let rot = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.3 * t);
                (
                    Isometry3::identity(),
                    Isometry3::from_parts(Vector3::new(0.1 * t, -0.05 * t * t, 1.0).into(), rot),
                    vec![0.01 + 0.01 * t * t],
                )
            })
            .collect();
        let mut smooth = truth.clone();
        // Every other quaternion negated: the same rotations.
        for p in smooth.iter_mut().skip(1).step_by(2) {
            let q = -*p.1.rotation.quaternion();
            p.1.rotation = UnitQuaternion::new_unchecked(q);
        }
        smooth_hand(&robot, &mut smooth, 7);
        for (a, b) in truth.iter().zip(&smooth) {
            assert!((a.1.translation.vector - b.1.translation.vector).norm() < 1e-12);
            assert!(a.1.rotation.angle_to(&b.1.rotation) < 1e-4);
            assert!((a.2[0] - b.2[0]).abs() < 1e-12);
        }
        let mut noisy = truth.clone();
        for (i, p) in noisy.iter_mut().enumerate() {
            p.1.translation.vector.x += 1e-3 * if i % 2 == 0 { 1.0 } else { -1.0 };
        }
        smooth_hand(&robot, &mut noisy, 7);
        let err = |v: &[Pose]| {
            v.iter()
                .zip(&truth)
                .skip(3)
                .take(n - 6)
                .map(|(a, b)| (a.1.translation.vector - b.1.translation.vector).norm())
                .fold(0.0, f64::max)
        };
        assert!(err(&noisy) < 0.5e-3, "jitter left: {} m", err(&noisy));
    }

    /// A point in the table or within the clearance above it goes to the clearance above its
    /// top; one farther up stays.
    #[test]
    fn points_in_or_near_a_support_go_above_its_clearance() {
        let table = CollisionShape::new(
            crate::geometry::shape::ShapeKind::Box {
                size: Vector3::new(0.8, 0.8, 0.04),
            },
            Isometry3::translation(0.0, 0.0, 0.88),
        )
        .unwrap();
        let c = SUPPORT_CLEARANCE_MM * 1e-3;
        for z in [0.895, 0.9, 0.9005] {
            let p = off_supports(std::slice::from_ref(&table), &Point3::new(0.1, 0.0, z)).unwrap();
            assert!(
                (p - Point3::new(0.1, 0.0, 0.9 + c)).norm() < 1e-9,
                "{z}: {p}"
            );
        }
        assert!(off_supports(&[table], &Point3::new(0.1, 0.0, 0.91)).is_none());
    }
}
