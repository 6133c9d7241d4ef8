//! Grasps for any URDF hand: fingertips from the tree, closing directions from the
//! kinematics, no link or joint names.
//!
//! [`layout`] reads a hand at its reference configuration `q_ref` (every joint at 0, clamped
//! into its limits), wrist at the identity:
//! 1. **fingertips**: the links given with `--tips`, else every leaf link (no child joint)
//!    with at least one movable joint between it and the root. A tip without collision
//!    geometry (a frame at the end of a finger) marks the finger's end; its *distal link* is
//!    the nearest link up the tree with collision geometry, which carries the pad;
//! 2. **closing direction of a joint**: the side of its range that is larger from `q_ref`
//!    (flexion ranges are asymmetric: `[-0.2, 1.6]` rad closes toward `+`); a joint whose
//!    two sides differ by less than 10 % of its range (abduction) has none;
//! 3. **closing motion of a finger**: the tip velocity `Σ_j σ_j J_j` over the closing
//!    joints of its chain (`J_j` the tip's Jacobian column, `σ_j` the closing sign);
//! 4. **the thumb**: the finger whose direction (finger base to tip) is farthest from the
//!    mean direction of the fingers; the others are the opposing fingers;
//! 5. **palm frame**: fingers direction `f` = the mean direction of the opposing fingers,
//!    palm normal `n` = their mean closing motion orthogonal to `f` (the side the fingers
//!    close toward); when that is zero (a gripper's jaws close toward each other),
//!    `n = f × (tip₀ − tip₁)`;
//! 6. **pad point** of a finger: the point of its distal link's surface (3 mm samples) most
//!    along the finger's closing motion (plus a third of the way along the finger), with
//!    the pad centre [`PAD_RADIUS_M`] inside along the surface normal.
//!
//! A prismatic joint's closing sign is instead the side that moves its finger toward the
//! other fingers (a jaw's range does not say which end is closed), and the pad is taken
//! among the surface points that face the closing motion. When the thumb closes against
//! the others' motion (jaws), the fingers' direction is the mean of all of them and the
//! palm normal is `f × (tip₀ − tip₁)`. [`wrist_link`] finds the palm link of a hand that
//! comes with its forearm; [`tripod`] keeps the thumb and the two fingers it opposes.
//!
//! [`template`] turns a layout into a [`GraspTemplate`] for an object, as the named
//! templates are made: palm down over the object, fingers along object `+x`; the thumb's pad
//! on the near side (`−x`), the opposing fingers' pads on the far side (`+x`), spread along
//! `y` as their bases are (squeezed to 70 % of the object's width), a quarter of the object's
//! height above its centre. The grasp is then contact IK toward these targets
//! ([`super::grasp::solve`]). [`open_q`] opens the solved grasp along each finger's closing
//! motion reversed: the joint step `−Jᵀ(c − tip)` toward the object centre `c`, scaled so
//! that no joint moves more than 0.4 rad (15 mm for prismatic joints).

use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};

use super::grasp::{Closing, GraspTemplate, PadTarget, hand_rotation};
use super::proximity::ObjectGeometry;
use crate::geometry::shape::SurfaceSampling;
use crate::robot::{JointKind, LinkId, Robot, WRIST_DOF};

/// Distance from a pad's surface point to its centre [m].
pub const PAD_RADIUS_M: f64 = 0.008;

/// One finger of a [`HandLayout`].
#[derive(Clone, Debug, PartialEq)]
pub struct Finger {
    /// The fingertip link (a leaf, or given).
    pub tip: LinkId,
    /// The link that carries the pad (the tip, or its nearest ancestor with geometry).
    pub distal: LinkId,
    /// Pad surface point, distal link frame [m].
    pub pad: Point3<f64>,
    /// Unit direction from the pad point to the pad centre, distal link frame.
    pub inward: Vector3<f64>,
    /// Finger base (the first movable joint's frame), root frame at `q_ref` [m].
    pub base: Point3<f64>,
    /// Fingertip point, root frame at `q_ref` [m].
    pub end: Point3<f64>,
    /// Unit closing motion of the tip, root frame (zero when no joint has a side).
    pub closing: Vector3<f64>,
}

/// What [`layout`] found in a hand.
#[derive(Clone, Debug, PartialEq)]
pub struct HandLayout {
    pub fingers: Vec<Finger>,
    /// Index of the thumb in `fingers`.
    pub thumb: usize,
    /// Palm normal, root frame (unit).
    pub palm_normal: Vector3<f64>,
    /// Finger direction, root frame (unit, orthogonal to `palm_normal`).
    pub finger_dir: Vector3<f64>,
    /// The reference configuration.
    pub q_ref: Vec<f64>,
}

/// The closing sign of each actuated joint (see the module docs): `+1`, `-1` or `0`.
pub fn closing_signs(robot: &Robot, q_ref: &[f64]) -> Vec<f64> {
    robot
        .lower()
        .iter()
        .zip(robot.upper())
        .zip(q_ref)
        .map(|((&lo, &hi), &q)| {
            if !lo.is_finite() || !hi.is_finite() || hi - lo <= 0.0 {
                return 0.0;
            }
            let (down, up) = (q - lo, hi - q);
            if (up - down).abs() < 0.1 * (hi - lo) {
                0.0
            } else {
                (up - down).signum()
            }
        })
        .collect()
}

/// The link that should carry the wrist pose when none is given: the deepest common
/// ancestor of the fingertips (the `tips` links, else every leaf link moved by a joint),
/// moved up through fixed joints (links rigidly attached to it are the palm's). `None` when
/// that is the root or fewer than two fingertips are known; otherwise the links above it
/// (a forearm and its wrist joints) do not belong in a grasp.
pub fn wrist_link(robot: &Robot, tips: Option<&[String]>) -> Option<String> {
    // A name the robot lacks is the layout's error to report; one tip is no hand.
    let ids: Vec<LinkId> = match tips {
        Some(names) => names
            .iter()
            .map(|n| robot.link_id(n))
            .collect::<Option<_>>()?,
        None => leaf_tips(robot),
    };
    if ids.len() < 2 {
        return None;
    }
    let ancestors = |l: LinkId| {
        let mut out = vec![l];
        let mut cur = l;
        while let Some(j) = robot.link(cur).parent_joint {
            cur = robot.joint(j).parent;
            out.push(cur);
        }
        out.reverse();
        out
    };
    let mut common = ancestors(*ids.first()?);
    for &t in &ids[1..] {
        let a = ancestors(t);
        let n = common.iter().zip(&a).take_while(|(x, y)| x == y).count();
        common.truncate(n);
    }
    let mut wrist = *common.last()?;
    while let Some(j) = robot.link(wrist).parent_joint {
        if robot.joint(j).kind.is_movable() {
            break;
        }
        wrist = robot.joint(j).parent;
    }
    (wrist != robot.root()).then(|| robot.link(wrist).name.clone())
}

/// Leaf links (no child joint) with at least one movable joint above them.
fn leaf_tips(robot: &Robot) -> Vec<LinkId> {
    let mut has_child = vec![false; robot.link_count()];
    for j in robot.joints() {
        has_child[j.parent.index()] = true;
    }
    (0..robot.link_count())
        .map(|i| LinkId(i as u32))
        .filter(|&l| !has_child[l.index()] && !robot.chain(l).is_empty())
        .collect()
}

/// The fingers, thumb and palm frame of `robot` (see the module docs). `tips` names the
/// fingertip links; `None` finds them from the tree. The error says what is missing and
/// how to give it.
pub fn layout(robot: &Robot, tips: Option<&[String]>) -> Result<HandLayout, String> {
    let tip_ids = fingertips(robot, tips)?;
    let q_ref = {
        let mut q = vec![0.0; robot.dof()];
        robot.clamp(&mut q);
        q
    };
    let mut signs = closing_signs(robot, &q_ref);
    let mut poses = robot.new_link_poses();
    robot.forward_kinematics(&Isometry3::identity(), &q_ref, &mut poses);
    let mut jac = vec![Vector3::zeros(); WRIST_DOF + robot.dof()];
    let found = tip_surfaces(robot, &tip_ids)?;
    prismatic_signs(robot, &poses, &found, &mut signs, &mut jac);
    let mut fingers = Vec::new();
    for (tip, distal, pts, normals) in found {
        fingers.push(finger(
            robot, &poses, &signs, &mut jac, tip, distal, &pts, &normals,
        )?);
    }
    let (thumb, palm_normal, f_dir) = palm(&fingers)?;
    Ok(HandLayout {
        fingers,
        thumb,
        palm_normal,
        finger_dir: f_dir,
        q_ref,
    })
}

/// A fingertip, its distal link and that link's surface samples and normals (link frame).
type TipSurface = (LinkId, LinkId, Vec<Point3<f64>>, Vec<Vector3<f64>>);

/// The fingertip links: `tips` (each moved by a joint), else the leaf links. At least two.
fn fingertips(robot: &Robot, tips: Option<&[String]>) -> Result<Vec<LinkId>, String> {
    let movable = |l: LinkId| !robot.chain(l).is_empty();
    let tip_ids: Vec<LinkId> = match tips {
        Some(names) => names
            .iter()
            .map(|n| {
                let id = robot.link_id(n).ok_or_else(|| {
                    format!("--tips names link {n:?}, which the robot does not have (see `dexwarp robot URDF` for its links)")
                })?;
                if movable(id) {
                    Ok(id)
                } else {
                    Err(format!("--tips names link {n:?}, which no joint moves; give the fingertip links"))
                }
            })
            .collect::<Result<_, String>>()?,
        None => leaf_tips(robot),
    };
    if tip_ids.len() < 2 {
        return Err(format!(
            "synthesis needs at least two fingertips and found {} leaf link(s) moved by a joint; give the fingertip links with --tips a,b,c",
            tip_ids.len()
        ));
    }
    Ok(tip_ids)
}

/// Per fingertip: its distal link and that link's surface samples (link frame).
fn tip_surfaces(robot: &Robot, tip_ids: &[LinkId]) -> Result<Vec<TipSurface>, String> {
    let fine = SurfaceSampling {
        spacing: 0.003,
        max_per_shape: 4000,
    };
    let mut found = Vec::with_capacity(tip_ids.len());
    for &tip in tip_ids {
        let mut distal = tip;
        while robot.link(distal).collision.is_empty() {
            match robot.link(distal).parent_joint {
                Some(j) => distal = robot.joint(j).parent,
                None => break,
            }
        }
        if robot.link(distal).collision.is_empty() || robot.chain(distal).is_empty() {
            return Err(format!(
                "fingertip {:?} has no link with collision geometry between it and the palm; give the fingertip links with --tips a,b,c",
                robot.link(tip).name
            ));
        }
        let (mut pts, mut normals) = (Vec::new(), Vec::new());
        for s in &robot.link(distal).collision {
            s.sample_surface(&fine, &mut pts, &mut normals);
        }
        if pts.is_empty() {
            return Err(format!("link {:?} has no surface", robot.link(distal).name));
        }
        found.push((tip, distal, pts, normals));
    }
    Ok(found)
}

/// A prismatic joint closes toward the other fingers (a jaw's range says nothing about
/// which end is closed): the sign of its motion of the distal link's surface centroid
/// toward the centroid of the other fingers' ones. Overwrites those joints' `signs`.
fn prismatic_signs(
    robot: &Robot,
    poses: &[Isometry3<f64>],
    found: &[TipSurface],
    signs: &mut [f64],
    jac: &mut [Vector3<f64>],
) {
    let centres: Vec<Point3<f64>> = found
        .iter()
        .map(|(_, distal, pts, _)| {
            let sum: Vector3<f64> = pts.iter().map(|p| (poses[distal.index()] * p).coords).sum();
            Point3::from(sum / pts.len() as f64)
        })
        .collect();
    for (k, (tip, ..)) in found.iter().enumerate() {
        let others: Vector3<f64> = centres
            .iter()
            .enumerate()
            .filter(|&(i, _)| i != k)
            .map(|(_, c)| c.coords)
            .sum::<Vector3<f64>>()
            / (centres.len() - 1) as f64;
        robot.world_point_jacobian(poses, *tip, &centres[k], jac);
        for &j in robot.chain(*tip) {
            let joint = robot.joint(j);
            let Some(i) = joint.dof.or(joint.mimic.map(|m| m.driver)) else {
                continue;
            };
            if joint.kind == JointKind::Prismatic {
                let g = jac[WRIST_DOF + i].dot(&(others - centres[k].coords));
                if g.abs() > 1e-9 {
                    signs[i] = g.signum();
                }
            }
        }
    }
}

/// The finger of fingertip `tip`: base, end, closing motion and pad on `distal`'s surface
/// (`pts`, `normals`, link frame).
fn finger(
    robot: &Robot,
    poses: &[Isometry3<f64>],
    signs: &[f64],
    jac: &mut [Vector3<f64>],
    tip: LinkId,
    distal: LinkId,
    pts: &[Point3<f64>],
    normals: &[Vector3<f64>],
) -> Result<Finger, String> {
    let first = robot.chain(tip)[0];
    let base = Point3::from(poses[robot.joint(first).child.index()].translation.vector);
    let dpose = poses[distal.index()];
    // The fingertip point: the tip frame when the tip has no geometry, else the distal
    // surface point farthest from the base.
    let end = if robot.link(tip).collision.is_empty() && tip != distal {
        Point3::from(poses[tip.index()].translation.vector)
    } else {
        pts.iter()
            .map(|p| dpose * p)
            .max_by(|a, b| (a - base).norm().total_cmp(&(b - base).norm()))
            .unwrap_or(base)
    };
    robot.world_point_jacobian(poses, tip, &end, jac);
    let closing: Vector3<f64> = robot
        .chain(tip)
        .iter()
        .filter_map(|&j| {
            robot
                .joint(j)
                .dof
                .or(robot.joint(j).mimic.map(|m| m.driver))
        })
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .map(|i| jac[WRIST_DOF + i] * signs[i])
        .sum();
    let closing = closing.try_normalize(1e-9).unwrap_or_else(Vector3::zeros);
    let along = (end - base).try_normalize(1e-9).unwrap_or_else(Vector3::z);
    // Pad: the surface point most along the closing motion (toward the other fingers
    // when the finger has none), a third of the weight toward the finger's end, among
    // the points whose surface faces that way (all points when none does).
    let toward = if closing == Vector3::zeros() {
        -along
    } else {
        closing
    };
    let score = |p: &Point3<f64>| {
        let w = dpose * p;
        w.coords.dot(&toward) + (w - base).dot(&along) / 3.0
    };
    let faces = |n: &Vector3<f64>| (dpose.rotation * n).dot(&toward) >= 0.5;
    let any_faces = normals.iter().any(faces);
    let best = pts
        .iter()
        .zip(normals)
        .filter(|(_, n)| !any_faces || faces(n))
        .max_by(|(a, _), (b, _)| score(a).total_cmp(&score(b)))
        .ok_or_else(|| format!("link {:?} has no surface", robot.link(distal).name))?;
    Ok(Finger {
        tip,
        distal,
        pad: *best.0,
        inward: -best.1,
        base,
        end,
        closing,
    })
}

/// The thumb (the odd one out among the fingers' directions), the palm normal and the
/// fingers' direction.
fn palm(fingers: &[Finger]) -> Result<(usize, Vector3<f64>, Vector3<f64>), String> {
    // Directions of the fingers, the thumb as the odd one out.
    let dirs: Vec<Vector3<f64>> = fingers
        .iter()
        .map(|f| {
            (f.end - f.base)
                .try_normalize(1e-9)
                .unwrap_or_else(Vector3::z)
        })
        .collect();
    let mean: Vector3<f64> = dirs.iter().sum();
    let mean = mean.try_normalize(1e-9).unwrap_or_else(Vector3::z);
    let thumb = (0..dirs.len())
        .min_by(|&a, &b| dirs[a].dot(&mean).total_cmp(&dirs[b].dot(&mean)))
        .unwrap_or(0);
    let others: Vec<usize> = (0..fingers.len()).filter(|&i| i != thumb).collect();
    let close: Vector3<f64> = others.iter().map(|&i| fingers[i].closing).sum();
    // Jaws: the thumb closes against the others' closing motion (a gripper), so that motion
    // is no palm side; the fingers point along the mean of all of them.
    let jaws = fingers[thumb]
        .closing
        .dot(&close.try_normalize(1e-9).unwrap_or_else(Vector3::zeros))
        < -0.5;
    let f_dir: Vector3<f64> = if jaws {
        mean
    } else {
        let sum: Vector3<f64> = others.iter().map(|&i| dirs[i]).sum();
        sum.try_normalize(1e-9).unwrap_or(mean)
    };
    let close = if jaws {
        Vector3::zeros()
    } else {
        close - f_dir * f_dir.dot(&close)
    };
    let palm_normal = match close.try_normalize(1e-6) {
        Some(n) => n,
        None => {
            let across = fingers[others[0]].end - fingers[thumb].end;
            f_dir.cross(&across).try_normalize(1e-9).ok_or_else(|| {
                "cannot tell the palm side of this hand from its joint limits (every finger joint has a symmetric range); give the fingertip links with --tips a,b,c, thumb first"
                    .to_string()
            })?
        }
    };
    Ok((thumb, palm_normal, f_dir))
}

/// The thumb and the two opposing fingers whose bases are nearest the thumb's tip across
/// the hand (the fingers it opposes), as a layout of its own (thumb first); `None` when the hand has no more fingers
/// than that.
pub fn tripod(layout: &HandLayout) -> Option<HandLayout> {
    if layout.fingers.len() <= 3 {
        return None;
    }
    let lateral = layout.finger_dir.cross(&layout.palm_normal);
    let mut others: Vec<usize> = (0..layout.fingers.len())
        .filter(|&i| i != layout.thumb)
        .collect();
    let l = |i: usize| layout.fingers[i].base.coords.dot(&lateral);
    let thumb = layout.fingers[layout.thumb].end.coords.dot(&lateral);
    others.sort_by(|&a, &b| (l(a) - thumb).abs().total_cmp(&(l(b) - thumb).abs()));
    others.truncate(2);
    others.sort_unstable();
    let mut fingers = vec![layout.fingers[layout.thumb].clone()];
    fingers.extend(others.iter().map(|&i| layout.fingers[i].clone()));
    Some(HandLayout {
        fingers,
        thumb: 0,
        ..layout.clone()
    })
}

/// A grasp template of the object `geo` for the hand of `layout` (see the module docs).
pub fn template(robot: &Robot, layout: &HandLayout, geo: &ObjectGeometry) -> GraspTemplate {
    let (mut lo, mut hi) = (
        Vector3::repeat(f64::INFINITY),
        Vector3::repeat(f64::NEG_INFINITY),
    );
    for v in &geo.mesh.vertices {
        lo = lo.inf(&v.coords);
        hi = hi.sup(&v.coords);
    }
    let centre = (lo + hi) / 2.0;
    let half = (hi - lo) / 2.0;
    let z = centre.z + 0.25 * half.z;
    // Hand axes as hand_rotation builds them: x = palm normal, z = fingers, y = z × x.
    let lateral = layout.finger_dir.cross(&layout.palm_normal);
    let others: Vec<usize> = (0..layout.fingers.len())
        .filter(|&i| i != layout.thumb)
        .collect();
    let l: Vec<f64> = others
        .iter()
        .map(|&i| layout.fingers[i].base.coords.dot(&lateral))
        .collect();
    let l_mean = l.iter().sum::<f64>() / l.len() as f64;
    let spread = l.iter().map(|v| (v - l_mean).abs()).fold(0.0, f64::max);
    let squeeze = if spread > 0.7 * half.y {
        0.7 * half.y / spread
    } else {
        1.0
    };
    let pad = |i: usize, object_point: [f64; 3]| {
        let f = &layout.fingers[i];
        PadTarget {
            link: robot.link(f.distal).name.clone(),
            hand_point: f.pad.coords.into(),
            radius: PAD_RADIUS_M,
            object_point,
            inward: f.inward.into(),
        }
    };
    let mut targets = vec![pad(layout.thumb, [centre.x - half.x, centre.y, z])];
    for (k, &i) in others.iter().enumerate() {
        targets.push(pad(
            i,
            [centre.x + half.x, centre.y + (l[k] - l_mean) * squeeze, z],
        ));
    }
    // The template's palm normal and finger direction are in the hand_rotation convention
    // (hand x = palm normal, z = fingers); this hand's own axes are rotated into it by the
    // initial rotation of grasp::solve, so express the object-frame axes through the
    // hand's: R0 = hand_rotation(obj) · hand_rotation(hand)⁻¹ maps the hand's palm normal
    // onto object −z and its fingers onto object +x.
    let r_hand = hand_rotation(&layout.palm_normal, &layout.finger_dir);
    let r_obj = hand_rotation(&-Vector3::z(), &Vector3::x());
    let r0: UnitQuaternion<f64> = r_obj * r_hand.inverse();
    // grasp::solve builds its rotation as hand_rotation(palm_normal, fingers) with the
    // template's vectors, i.e. the images of the hand's x and z axes.
    let x_img = r0 * Vector3::x();
    let z_img = r0 * Vector3::z();
    GraspTemplate {
        palm_normal: x_img.into(),
        fingers: z_img.into(),
        preshape: Vec::new(),
        targets,
        open: Vec::new(),
        approach: [-0.4, 0.0, 1.0],
        slide: [0.0, 0.0, 1.0],
        turn_rad: 0.25,
        preshape_q: Some(layout.q_ref.clone()),
        kinematic_open: true,
        closing: Closing::WHILE_MOVING,
        level_release: false,
    }
}

/// Joint values of the open hand for the grasp `(wrist, q)`: each finger moved away from the
/// world point `centre` along its closing motion reversed (see the module docs), clamped.
pub fn open_q(robot: &Robot, wrist: &Isometry3<f64>, q: &[f64], centre: &Point3<f64>) -> Vec<f64> {
    let mut poses = robot.new_link_poses();
    robot.forward_kinematics(wrist, q, &mut poses);
    let mut has_child = vec![false; robot.link_count()];
    for j in robot.joints() {
        has_child[j.parent.index()] = true;
    }
    let mut jac = vec![Vector3::zeros(); WRIST_DOF + robot.dof()];
    let mut step: Vec<f64> = vec![0.0; robot.dof()];
    for l in 0..robot.link_count() {
        let link = LinkId(l as u32);
        if has_child[l] || robot.chain(link).is_empty() {
            continue;
        }
        let tip = Point3::from(poses[l].translation.vector);
        robot.world_point_jacobian(&poses, link, &tip, &mut jac);
        let to_centre = centre - tip;
        for (i, s) in step.iter_mut().enumerate() {
            let g = jac[WRIST_DOF + i].dot(&to_centre);
            if g.abs() > s.abs() {
                *s = g;
            }
        }
    }
    // Scale: at most 0.4 rad (15 mm prismatic) on any joint.
    let cap: Vec<f64> = robot
        .actuated()
        .iter()
        .map(|&j| {
            if robot.joint(j).kind == JointKind::Prismatic {
                0.015
            } else {
                0.4
            }
        })
        .collect();
    let ratio = step
        .iter()
        .zip(&cap)
        .map(|(s, c)| s.abs() / c)
        .fold(0.0, f64::max);
    let mut out = q.to_vec();
    if ratio > 1e-12 {
        for (v, s) in out.iter_mut().zip(&step) {
            *v -= s / ratio;
        }
    }
    robot.clamp(&mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn robot(text: &str) -> Robot {
        Robot::from_urdf_str(
            text,
            Path::new("."),
            Path::new("test.urdf"),
            &crate::Limits::default(),
        )
        .unwrap()
    }

    /// A box link and a joint, as URDF text.
    fn part(link: &str, size: &str, joint: &str) -> String {
        format!(
            r#"<link name="{link}"><collision><geometry><box size="{size}"/></geometry></collision></link>{joint}"#
        )
    }

    #[test]
    fn the_wrist_is_the_fingers_common_link_above_fixed_parts() {
        // forearm -(revolute)-> palm -(fixed)-> plate, two fingers on the plate, a sensor
        // frame fixed to the palm: the wrist is the palm, not the plate and not the forearm.
        let finger = |n: &str, y: f64| {
            part(
                n,
                "0.01 0.01 0.04",
                &format!(
                    r#"<joint name="{n}_j" type="revolute"><parent link="plate"/><child link="{n}"/><origin xyz="0 {y} 0.05"/><axis xyz="0 1 0"/><limit lower="0" upper="1.5" effort="1" velocity="1"/></joint>"#
                ),
            )
        };
        let text = format!(
            r#"<robot name="arm">{}{}{}{}{}<link name="imu"/><joint name="imu_j" type="fixed"><parent link="palm"/><child link="imu"/></joint></robot>"#,
            part("forearm", "0.05 0.05 0.2", ""),
            part(
                "palm",
                "0.08 0.08 0.02",
                r#"<joint name="wrist" type="revolute"><parent link="forearm"/><child link="palm"/><origin xyz="0 0 0.2"/><axis xyz="1 0 0"/><limit lower="-0.5" upper="0.5" effort="1" velocity="1"/></joint>"#
            ),
            part(
                "plate",
                "0.08 0.08 0.01",
                r#"<joint name="plate_j" type="fixed"><parent link="palm"/><child link="plate"/></joint>"#
            ),
            finger("a", 0.02),
            finger("b", -0.02),
        );
        let r = robot(&text);
        assert_eq!(wrist_link(&r, None).as_deref(), Some("palm"));
        let tips = ["a".to_string(), "b".to_string()];
        assert_eq!(wrist_link(&r, Some(&tips)).as_deref(), Some("palm"));
        // At its root the hand needs no other wrist link.
        let ours = Robot::from_urdf_file(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("robots/allegro_hand.urdf"),
            &crate::Limits::default(),
        )
        .unwrap();
        assert_eq!(wrist_link(&ours, None), None);
    }

    #[test]
    fn jaws_close_toward_each_other_whatever_their_range() {
        // Two prismatic jaws at 0 when closed, opening to 0.04 (the larger side of the
        // range is the open one), one mimicking the other.
        let jaw = |n: &str, y: &str, mimic: &str| {
            part(
                n,
                "0.02 0.01 0.04",
                &format!(
                    r#"<joint name="{n}_j" type="prismatic"><parent link="palm"/><child link="{n}"/><origin xyz="0 0 0.05"/><axis xyz="0 {y} 0"/><limit lower="0" upper="0.04" effort="1" velocity="1"/>{mimic}</joint>"#
                ),
            )
        };
        let text = format!(
            r#"<robot name="jaws">{}{}{}</robot>"#,
            part("palm", "0.04 0.2 0.04", ""),
            jaw("left", "1", ""),
            jaw("right", "-1", r#"<mimic joint="left_j"/>"#),
        )
        // Jaw geometry off the joint axis, so each jaw's surface is on its own side.
        .replace(
            r#"<link name="left"><collision>"#,
            r#"<link name="left"><collision><origin xyz="0 0.01 0.02"/>"#,
        )
        .replace(
            r#"<link name="right"><collision>"#,
            r#"<link name="right"><collision><origin xyz="0 -0.01 0.02"/>"#,
        );
        let r = robot(&text);
        let l = layout(&r, None).unwrap();
        assert_eq!(l.fingers.len(), 2);
        for f in &l.fingers {
            // Each jaw closes toward the other (toward y = 0).
            let side = (r.link(f.distal).name == "left") as i32 as f64 * 2.0 - 1.0;
            assert!(f.closing.y * side < -0.99, "{:?}", f.closing);
        }
        // The palm normal is across the jaws' motion, the fingers along z.
        assert!(l.palm_normal.y.abs() < 1e-6, "{:?}", l.palm_normal);
        assert!(l.finger_dir.z > 0.9, "{:?}", l.finger_dir);
    }
}
