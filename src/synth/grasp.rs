//! Grasp synthesis by contact IK toward chosen contact regions of the object.
//!
//! A [`GraspTemplate`] (see [`super::templates`]) names, for one hand family and one
//! object, where the pads go: each [`PadTarget`] is a finger's pad (its `<finger>_tip` frame,
//! the pad surface at `+x·radius`) or a palm point, and an object point given roughly (object
//! frame); the object point is projected onto the mesh surface. A pad contributes two
//! correspondences: pad surface point ↔ surface point `s`, and pad centre (the tip frame
//! origin) ↔ `s + n·radius` (`n` the outward surface normal), which also aligns the pad
//! normal with `−n`. The solve:
//! 1. initial guess: the hand in its preshape, oriented by the template's palm normal and
//!    finger direction (object frame), placed so that the centroid of its target points
//!    lies on the centroid of the object targets;
//! 2. contact IK ([`crate::hand::ik::IkSolver`], LM) with the object's penetration term on
//!    and the support top as a barrier, to a tight threshold;
//! 3. the result must converge, else the grasp is unreachable (an error names the hand, the
//!    object and the residual);
//! 4. penetration check with [`super::proximity`]: while a link overlaps the object by more
//!    than [`GraspParams::max_depth_mm`], the joint of its chain (or the wrist, for the
//!    root) whose small move reduces that overlap most is moved.

use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};

use super::proximity::{ObjectGeometry, link_depth, penetration};
use crate::geometry::shape::CollisionShape;
use crate::hand::ik::{IkSolver, Params as IkParams, ResolvedContact};
use crate::robot::Robot;

/// The hand families synthesis knows, recognised by their links.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum HandFamily {
    /// Five fingers with `<finger>_tip` frames (`human_hand`).
    Human,
    /// Three fingers and a thumb with `<finger>_tip` frames, no little finger (`allegro_hand`).
    Allegro,
    /// Two jaws `left_finger`, `right_finger` (`parallel_gripper`).
    Gripper,
}

impl HandFamily {
    /// Every family, in a fixed order.
    pub const ALL: [HandFamily; 3] = [HandFamily::Human, HandFamily::Allegro, HandFamily::Gripper];

    /// A name for messages.
    pub fn name(self) -> &'static str {
        match self {
            HandFamily::Human => "five-finger hand (like human_hand)",
            HandFamily::Allegro => "four-finger hand (like allegro_hand)",
            HandFamily::Gripper => "parallel gripper (like parallel_gripper)",
        }
    }

    /// The family of `robot`, by the links it has.
    pub fn detect(robot: &Robot) -> Option<HandFamily> {
        let has = |n: &str| robot.link_id(n).is_some();
        let fingers = ["thumb_tip", "index_tip", "middle_tip", "ring_tip"];
        if fingers.iter().all(|n| has(n)) {
            Some(if has("little_tip") {
                HandFamily::Human
            } else {
                HandFamily::Allegro
            })
        } else if has("left_finger") && has("right_finger") {
            Some(HandFamily::Gripper)
        } else {
            None
        }
    }
}

/// One pad or palm point of a grasp.
#[derive(Clone, Debug, PartialEq)]
pub struct PadTarget {
    /// Link of the hand point.
    pub link: String,
    /// Hand point, link frame [m]: the pad surface point for a finger pad.
    pub hand_point: [f64; 3],
    /// Pad radius [m]: when positive, the pad centre (`hand_point` moved `radius` along
    /// `inward`: the link origin for a fingertip pad of our hands) is targeted at `radius` above the
    /// surface along the normal (see the module docs).
    pub radius: f64,
    /// Rough object point, object frame [m]; projected onto the surface.
    pub object_point: [f64; 3],
    /// Unit direction from the pad surface point to the pad centre, link frame (`−x` for
    /// the `<finger>_tip` pads of our hands).
    pub inward: [f64; 3],
}

/// A grasp for one hand family and one object.
#[derive(Clone, Debug, PartialEq)]
pub struct GraspTemplate {
    /// Palm normal (hand `+x`) in the object frame, for the initial guess.
    pub palm_normal: [f64; 3],
    /// Finger direction (hand `+z`) in the object frame, for the initial guess.
    pub fingers: [f64; 3],
    /// Joint values of the initial guess, by joint name (others at 0, clamped to limits).
    pub preshape: Vec<(&'static str, f64)>,
    /// Where the pads go.
    pub targets: Vec<PadTarget>,
    /// Offset of the joints for the open hand of the approach and release, by joint name
    /// (added to the grasp, clamped to the limits).
    pub open: Vec<(&'static str, f64)>,
    /// Direction the hand comes from, object frame (unit or not; scaled by the timing).
    pub approach: [f64; 3],
    /// A direction the grasp can slide along without pressing into the object (object
    /// frame), for the motion-capture drift of [`super::contacts::Noise`].
    pub slide: [f64; 3],
    /// Turn of the retreat poses about the vertical [rad]: `+turn_rad` at the start,
    /// `-turn_rad` at the end, as a relaxed hand would be; 0 keeps the hand on the
    /// approach line (where it must slide in and out along a handle).
    pub turn_rad: f64,
    /// Joint values of the initial guess, robot order, replacing `preshape` (hands without
    /// a named template, [`super::generic`]).
    pub preshape_q: Option<Vec<f64>>,
    /// Open the hand along the closing directions found from the kinematics at the grasp
    /// ([`super::generic::open_q`]) instead of `open`.
    pub kinematic_open: bool,
    /// When the wrist arrives and the fingers close in the closing phase.
    pub closing: Closing,
    /// The release opens the fingers first, then backs the hand off along the approach
    /// without its vertical part, and the retreat slides it 8 cm out that way before it
    /// rises (a hand hooked through a handle slides out level: the approach's rise would
    /// lift the object by its handle), stepping sideways and up or down by up to 12 mm to
    /// where the open hand is farthest from the object (`SlidePath` in the synthesis);
    /// `false`: the fingers open as the hand backs off along the approach, and it retreats
    /// along the approach.
    pub level_release: bool,
}

/// The closing phase of a demonstration, as fractions of it: the wrist moves from the
/// pre-grasp to the grasp over `[0, arrive]`, the fingers close over `[fingers_from, 1]`
/// (each with minimum-jerk timing; `0 < arrive <= 1`, `0 <= fingers_from < 1`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Closing {
    pub arrive: f64,
    pub fingers_from: f64,
}

impl Closing {
    /// The hand slides in as the fingers close over the last 70 %.
    pub const WHILE_MOVING: Closing = Closing {
        arrive: 1.0,
        fingers_from: 0.3,
    };
    /// The hand is in place at 60 % and the fingers close from halfway: fingers that close
    /// while the hand still slides drag the object along (the teapot's hook moved its pot
    /// 17.7 mm before the lift, 7.0 mm this way).
    pub const ARRIVE_THEN_CLOSE: Closing = Closing {
        arrive: 0.6,
        fingers_from: 0.5,
    };
}

/// Tunables of the grasp solve.
#[derive(Clone, Debug, PartialEq)]
pub struct GraspParams {
    /// IK stop threshold on the mean target distance [mm]. Default 1.5.
    pub threshold_mm: f64,
    /// Largest acceptable mean target distance after the solve [mm]; above it the grasp
    /// is unreachable. Default 4.
    pub accept_mm: f64,
    /// IK iteration cap. Default 600.
    pub max_iterations: usize,
    /// Largest hand-object overlap left after nudging [mm]. Default 1.
    pub max_depth_mm: f64,
}

impl Default for GraspParams {
    fn default() -> Self {
        GraspParams {
            threshold_mm: 1.5,
            accept_mm: 4.0,
            max_iterations: 600,
            max_depth_mm: 1.0,
        }
    }
}

/// A solved grasp: the hand relative to the object.
#[derive(Clone, Debug, PartialEq)]
pub struct Grasp {
    /// Wrist pose in the object frame.
    pub wrist_in_object: Isometry3<f64>,
    /// Joint values, robot order.
    pub q: Vec<f64>,
    /// Joint values of the open hand (approach and release), robot order.
    pub q_open: Vec<f64>,
    /// Mean target distance after the IK [mm].
    pub ik_mean_mm: f64,
    /// IK iterations.
    pub ik_iterations: usize,
    /// Largest hand-object overlap after nudging [mm].
    pub depth_mm: f64,
    /// Nudges applied.
    pub nudges: usize,
}

/// Why a grasp could not be made.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum GraspFailure {
    /// A link the template needs is missing.
    #[error("the grasp needs link {0:?}, which the robot does not have")]
    MissingLink(String),
    /// The IK did not bring the hand onto the targets.
    #[error(
        "contact IK did not reach the grasp: mean target distance {mean_mm:.1} mm (accepted: {accept_mm:.1} mm) after {iterations} iterations"
    )]
    Unreachable {
        mean_mm: f64,
        accept_mm: f64,
        iterations: usize,
    },
    /// The hand still overlaps the object after nudging.
    #[error("the hand overlaps the object by {depth_mm:.1} mm at link {link:?} after nudging")]
    Penetrating { depth_mm: f64, link: String },
}

/// Resolves the template's targets: pad points and centres paired with surface points.
pub fn resolve_targets(
    robot: &Robot,
    template: &GraspTemplate,
    object: &ObjectGeometry,
) -> Result<Vec<ResolvedContact>, GraspFailure> {
    let mut out = Vec::new();
    for t in &template.targets {
        let link = robot
            .link_id(&t.link)
            .ok_or_else(|| GraspFailure::MissingLink(t.link.clone()))?;
        let s = object.surface_point(&Point3::from(t.object_point)).point;
        out.push(ResolvedContact {
            link,
            hand_point: Point3::from(t.hand_point),
            object_point: s,
        });
        if t.radius > 0.0 {
            let n = object.normal(&s);
            out.push(ResolvedContact {
                link,
                hand_point: Point3::from(t.hand_point) + Vector3::from(t.inward) * t.radius,
                object_point: s + n * t.radius,
            });
        }
    }
    Ok(out)
}

/// A rotation whose `x` axis is `palm_normal` and `z` axis is `fingers` (orthogonalised).
pub fn hand_rotation(palm_normal: &Vector3<f64>, fingers: &Vector3<f64>) -> UnitQuaternion<f64> {
    let x = palm_normal.normalize();
    let z = (fingers - x * x.dot(fingers)).normalize();
    let y = z.cross(&x);
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(Matrix3::from_columns(
        &[x, y, z],
    )))
}

/// Joint vector from `(name, value)` pairs (others 0), clamped to the limits.
pub fn joints_from_names(robot: &Robot, values: &[(&str, f64)], base: Option<&[f64]>) -> Vec<f64> {
    let mut q = base.map_or_else(|| vec![0.0; robot.dof()], <[f64]>::to_vec);
    for (name, v) in values {
        if let Some(i) = robot.actuated_index(name) {
            q[i] += *v;
        }
    }
    robot.clamp(&mut q);
    q
}

/// Solves the grasp of `template` on the object resting at `object_pose`, avoiding the
/// world-frame `barriers` (the support).
pub fn solve(
    robot: &Robot,
    template: &GraspTemplate,
    object: &ObjectGeometry,
    object_shape: &CollisionShape,
    object_pose: &Isometry3<f64>,
    barriers: &[CollisionShape],
    params: &GraspParams,
) -> Result<Grasp, GraspFailure> {
    let targets = resolve_targets(robot, template, object)?;
    // 1. Initial guess.
    let q0 = match &template.preshape_q {
        Some(q) => {
            let mut q = q.clone();
            robot.clamp(&mut q);
            q
        }
        None => joints_from_names(robot, &template.preshape, None),
    };
    let mut poses = robot.new_link_poses();
    robot.forward_kinematics(&Isometry3::identity(), &q0, &mut poses);
    let n = targets.len() as f64;
    let hand_c = targets.iter().fold(Vector3::zeros(), |a, t| {
        a + (poses[t.link.index()] * t.hand_point).coords
    }) / n;
    let obj_c = targets
        .iter()
        .fold(Vector3::zeros(), |a, t| a + t.object_point.coords)
        / n;
    let r0 = hand_rotation(
        &Vector3::from(template.palm_normal),
        &Vector3::from(template.fingers),
    );
    // 2. Contact IK from several initial orientations (the template's, turned about the
    //    palm normal and about the thumb axis), first on the targets alone, then with the
    //    penetration and support terms; the lowest residual wins.
    let plain = IkParams {
        threshold_mm: params.threshold_mm,
        max_iterations: params.max_iterations,
        barrier_weight: 0.0,
        objective: crate::model::Objective::Paper,
        stall_decrease: 1e-6,
        // The committed demonstrations were synthesized ending a solve at the first small
        // decrease; kept so that they stay reproducible.
        stall_steps: 1,
        ..IkParams::default()
    };
    // The grasp's penetration term is the surface-point one on the object's triangle mesh:
    // a grasp holds by pressing its fingertips on the surface, which the warp's stricter
    // probes would refuse (and the committed demonstrations were made with it).
    let careful = IkParams {
        margin_m: 0.01,
        barrier_weight: 0.1,
        surface_penetration_weight: 1.0,
        ..plain.clone()
    };
    let mut solver = IkSolver::new(robot, barriers, Some(&object.sdf), plain);
    let mut fine = IkSolver::new(robot, barriers, Some(&object.sdf), careful)
        .with_surface_object(object_shape);
    let mut best: Option<(f64, Isometry3<f64>, Vec<f64>, crate::hand::ik::FrameResult)> = None;
    for (ax, ay) in TURNS {
        let turn = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), ax)
            * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), ay);
        let r = r0 * turn;
        let wrist_obj = Isometry3::from_parts(Translation3::from(obj_c - r * hand_c), r);
        let mut wrist = object_pose * wrist_obj;
        let mut q = q0.clone();
        solver.solve(object_pose, &targets, &mut wrist, &mut q);
        let res = fine.solve(object_pose, &targets, &mut wrist, &mut q);
        robot.forward_kinematics(&wrist, &q, &mut poses);
        let depth = penetration(robot, &poses, object, object_pose).depth_m;
        let score = res.mean_mm + 2.0 * depth * 1e3;
        if best.as_ref().is_none_or(|(b, ..)| score < *b) {
            best = Some((score, wrist, q, res));
        }
    }
    let (_, mut wrist, mut q, res) = best.expect("at least one initial orientation");
    // 3. Reached?
    // NaN counts as unreachable.
    if res.mean_mm.is_nan() || res.mean_mm > params.accept_mm {
        return Err(GraspFailure::Unreachable {
            mean_mm: res.mean_mm,
            accept_mm: params.accept_mm,
            iterations: res.iterations,
        });
    }
    // 4. Nudge out of penetration.
    let nudges = nudge(
        robot,
        object,
        object_pose,
        &mut wrist,
        &mut q,
        params.max_depth_mm * 1e-3,
    );
    robot.forward_kinematics(&wrist, &q, &mut poses);
    let pen = penetration(robot, &poses, object, object_pose);
    if pen.depth_m > params.max_depth_mm * 1e-3 + 1e-9 {
        return Err(GraspFailure::Penetrating {
            depth_mm: pen.depth_m * 1e3,
            link: pen
                .link
                .map_or_else(String::new, |l| robot.link(l).name.clone()),
        });
    }
    let q_open = if template.kinematic_open {
        super::generic::open_q(robot, &wrist, &q, &(object_pose * Point3::origin()))
    } else {
        joints_from_names(robot, &template.open, Some(&q))
    };
    Ok(Grasp {
        wrist_in_object: object_pose.inverse() * wrist,
        q,
        q_open,
        ik_mean_mm: res.mean_mm,
        ik_iterations: res.iterations,
        depth_mm: pen.depth_m * 1e3,
        nudges,
    })
}

/// Moves joints (or the wrist, for the root link) until no link overlaps the object by more
/// than `tol_m`, or no move helps; returns the number of moves. Each move is the single
/// joint step of ±0.01 rad (±1 mm for prismatic joints; ±0.5 mm of the wrist along each
/// axis for the root) that reduces the worst link's overlap most.
pub fn nudge(
    robot: &Robot,
    object: &ObjectGeometry,
    object_pose: &Isometry3<f64>,
    wrist: &mut Isometry3<f64>,
    q: &mut [f64],
    tol_m: f64,
) -> usize {
    let mut poses = robot.new_link_poses();
    let mut moves = 0;
    for _ in 0..400 {
        robot.forward_kinematics(wrist, q, &mut poses);
        let pen = penetration(robot, &poses, object, object_pose);
        let Some(link) = pen.link else { break };
        if pen.depth_m <= tol_m {
            break;
        }
        let depth_of = |w: &Isometry3<f64>, q: &[f64], poses: &mut Vec<Isometry3<f64>>| {
            robot.forward_kinematics(w, q, poses);
            link_depth(robot, link, poses, object, object_pose)
        };
        let mut best: Option<(f64, Isometry3<f64>, Vec<f64>)> = None;
        let mut consider = |w: Isometry3<f64>, qq: Vec<f64>, poses: &mut Vec<Isometry3<f64>>| {
            let d = depth_of(&w, &qq, poses);
            if d < pen.depth_m - 1e-6 && best.as_ref().is_none_or(|(b, _, _)| d < *b) {
                best = Some((d, w, qq));
            }
        };
        for &j in robot.chain(link) {
            let joint = robot.joint(j);
            let Some(i) = joint.dof else { continue };
            let step = if joint.kind == crate::robot::JointKind::Prismatic {
                0.001
            } else {
                0.01
            };
            for s in [-step, step] {
                let mut qq = q.to_vec();
                qq[i] += s;
                robot.clamp(&mut qq);
                if qq[i] != q[i] {
                    consider(*wrist, qq, &mut poses);
                }
            }
        }
        if link == robot.root() {
            for axis in [Vector3::x(), Vector3::y(), Vector3::z()] {
                for s in [-0.0005, 0.0005] {
                    let w = Translation3::from(axis * s) * *wrist;
                    consider(w, q.to_vec(), &mut poses);
                }
            }
        }
        match best {
            Some((_, w, qq)) => {
                *wrist = w;
                q.copy_from_slice(&qq);
                moves += 1;
            }
            None => break,
        }
    }
    moves
}

/// Turns of the initial orientation tried: (about the palm normal, about the thumb axis) [rad].
const TURNS: [(f64, f64); 7] = [
    (0.0, 0.0),
    (0.5, 0.0),
    (-0.5, 0.0),
    (1.0, 0.0),
    (-1.0, 0.0),
    (0.0, 0.4),
    (0.0, -0.4),
];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::shape::ShapeKind;
    use crate::synth::objects::ObjectKind;
    use crate::synth::templates::template;
    use std::path::Path;

    #[test]
    #[ignore = "prints grasp diagnostics"]
    fn print_grasps() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("robots");
        for (file, objects) in [
            (
                "human_hand.urdf",
                vec![
                    ObjectKind::Cube,
                    ObjectKind::FryingPan,
                    ObjectKind::Mug,
                    ObjectKind::Teapot,
                ],
            ),
            (
                "allegro_hand.urdf",
                vec![ObjectKind::Apple, ObjectKind::Cube],
            ),
            (
                "parallel_gripper.urdf",
                vec![ObjectKind::SmallBox, ObjectKind::Cube],
            ),
        ] {
            let robot = Robot::from_urdf_file(&dir.join(file), &crate::Limits::default()).unwrap();
            let family = HandFamily::detect(&robot).unwrap();
            for object in objects {
                let mesh = object.mesh();
                let geo = ObjectGeometry::new(mesh.clone()).unwrap();
                let shape = CollisionShape::new(
                    ShapeKind::Mesh {
                        path: "x.obj".into(),
                        scale: Vector3::repeat(1.0),
                        mesh: std::sync::Arc::new(mesh),
                    },
                    Isometry3::identity(),
                )
                .unwrap();
                let pose = Isometry3::translation(0.0, 0.0, 0.9 - geo.min_z);
                let table = CollisionShape::new(
                    ShapeKind::Box {
                        size: Vector3::new(2.0, 2.0, 0.1),
                    },
                    Isometry3::translation(0.0, 0.0, 0.85),
                )
                .unwrap();
                let t = template(family, object).unwrap();
                let clock = std::time::Instant::now();
                let r = solve(
                    &robot,
                    &t,
                    &geo,
                    &shape,
                    &pose,
                    std::slice::from_ref(&table),
                    &GraspParams::default(),
                );
                match r {
                    Ok(g) => {
                        let mut poses = robot.new_link_poses();
                        let w = pose * g.wrist_in_object;
                        robot.forward_kinematics(&w, &g.q, &mut poses);
                        let samples = crate::synth::contacts::hand_samples(&robot, 0.006);
                        let c = crate::synth::contacts::extract(
                            &robot, &samples, &poses, &geo, &pose, 0.005,
                        );
                        let mut per: std::collections::BTreeMap<String, usize> = Default::default();
                        for x in &c {
                            *per.entry(x.link.clone()).or_default() += 1;
                        }
                        let lowest = poses
                            .iter()
                            .map(|p| p.translation.z)
                            .fold(f64::INFINITY, f64::min);
                        println!(
                            "{file} {object}: ik {:.2} mm in {} it, depth {:.2} mm after {} nudges, {} contacts {per:?}, lowest link origin z {:.3}, {:.2}s\n  wrist {:?}\n  q {:?}",
                            g.ik_mean_mm,
                            g.ik_iterations,
                            g.depth_mm,
                            g.nudges,
                            c.len(),
                            lowest,
                            clock.elapsed().as_secs_f64(),
                            g.wrist_in_object,
                            g.q.iter()
                                .map(|v| (v * 100.0).round() / 100.0)
                                .collect::<Vec<_>>()
                        );
                    }
                    Err(e) => println!("{file} {object}: {e}"),
                }
            }
        }
    }
}
