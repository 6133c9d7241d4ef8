//! Demonstration synthesis: a grasp, a scripted motion and geometric correspondences.
//!
//! [`synthesize`] builds the frames of one demonstration in three segments:
//! 1. **pre-contact**: the object rests on its support (its lowest point on the support
//!    top). The hand waits at a retreat pose with the fingers open ([`Timing::idle`]),
//!    reaches a pre-grasp 5 cm short of the grasp along the approach direction
//!    ([`Timing::reach`]), then moves in and the fingers close onto the grasp
//!    ([`Timing::close`], [`GraspTemplate::closing`] says when each happens); all with
//!    minimum-jerk timing;
//! 2. **in-contact**: the grasp is held ([`Timing::hold`]), the object follows the scripted
//!    motion ([`super::motion`], [`Timing::motion`]) and is held again on its new support;
//!    the hand is rigidly attached to the object. Correspondences of every frame are
//!    extracted geometrically at the grasp ([`super::contacts`]), with seeded noise (with
//!    [`TrackingError::Hand`] the recorded hand carries the noise's shared offset instead,
//!    at every frame of all three segments, and moves on the object by it);
//! 3. **post-contact**: release (fingers open, the hand backs off 1 cm along the approach;
//!    with [`GraspTemplate::level_release`] the fingers open first, the hand backs off level
//!    and slides out 8 cm level, stepping around the object where it is near, before it
//!    rises) and retreat to the
//!    retreat pose of the final object pose, then rest.
//!
//! The grasp comes from contact IK ([`super::grasp`]); every frame is checked for
//! hand-object penetration ([`super::proximity`]) and refused above
//! [`SynthSpec::max_penetration_mm`]. Numbers are rounded to micrometres (positions, contact
//! points), 1e-7 (quaternions) and microradians (joints), so a file is compact and the same
//! spec always gives the same bytes.

use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

use super::contacts::{self, ContactParams, Noise, TrackingError};
use super::grasp::{self, Grasp, GraspParams, GraspTemplate, HandFamily};
use super::motion::{self, Motion, MotionParams, min_jerk};
use super::objects::ObjectKind;
use super::proximity::{ObjectGeometry, penetration};
use super::templates;
use crate::geometry::Mesh;
use crate::geometry::shape::{CollisionShape, ShapeKind};
use crate::hand::pushout::LinkClearance;
use crate::model::demo::ObjectInfo;
use crate::model::{Contact, Demo, Frame};
use crate::robot::Robot;
use crate::{Error, Result};

/// Frames of each phase.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Timing {
    /// Hand still at the retreat pose.
    pub idle: usize,
    /// Retreat pose → pre-grasp.
    pub reach: usize,
    /// Pre-grasp → grasp, fingers closing.
    pub close: usize,
    /// Grasp held before and after the motion (each).
    pub hold: usize,
    /// The scripted motion.
    pub motion: usize,
    /// Fingers opening.
    pub release: usize,
    /// Back to the retreat pose.
    pub retreat: usize,
    /// Hand still at the end.
    pub rest: usize,
}

impl Timing {
    /// Total number of frames.
    pub fn frames(&self) -> usize {
        self.idle
            + self.reach
            + self.close
            + 2 * self.hold
            + self.motion
            + self.release
            + self.retreat
            + self.rest
    }

    /// Frames with correspondences (the in-contact segment).
    pub fn contact_frames(&self) -> usize {
        2 * self.hold + self.motion
    }
}

impl Default for Timing {
    fn default() -> Self {
        Timing {
            idle: 45,
            reach: 60,
            close: 30,
            hold: 15,
            motion: 240,
            release: 15,
            retreat: 60,
            rest: 30,
        }
    }
}

/// Everything that defines a synthetic demonstration.
#[derive(Clone, Debug, PartialEq)]
pub struct SynthSpec {
    /// Demonstration name.
    pub name: String,
    pub object: ObjectKind,
    pub motion: Motion,
    /// Frame rate [Hz]. Default 30.
    pub fps: f64,
    /// Where the object rests at the start: `(x, y)` of its origin [m].
    pub start_xy: [f64; 2],
    /// Height of the support top [m].
    pub support_z: f64,
    /// Yaw of the object at rest [rad] (about world `z`).
    pub yaw_rad: f64,
    pub motion_params: MotionParams,
    pub timing: Timing,
    pub contacts: ContactParams,
    pub grasp: GraspParams,
    /// Distance of the retreat pose from the grasp along the approach direction [m].
    pub retreat_m: f64,
    /// Largest hand-object penetration accepted at any frame [mm]. Default 2.
    pub max_penetration_mm: f64,
    /// Fingertip links of a hand without a named template (`--tips`); `None` finds them
    /// from the tree ([`super::generic`]).
    pub tips: Option<Vec<String>>,
    /// The link the wrist is (`--wrist-link`), written into the demonstration; the robot
    /// given to [`synthesize`] must be loaded rooted there.
    pub wrist_link: Option<String>,
    /// The physics of the grasp's hold test and of its demonstration's replay (the
    /// replay's defaults).
    pub hold: crate::physics::Params,
}

impl SynthSpec {
    /// A spec with defaults: the object on a 0.9 m table at the origin, carried 0.4 m along
    /// `−x` (a pour tilts 60° about `y` halfway), 30 fps, 510 frames.
    pub fn new(name: &str, object: ObjectKind, motion: Motion) -> SynthSpec {
        let mut motion_params = MotionParams::default();
        match motion {
            Motion::Pour => {
                motion_params.tilt_rad = 1.0;
                motion_params.tilt_axis = Vector3::y();
            }
            Motion::Pass => {
                motion_params.lift_m = 0.2;
                motion_params.arc_m = 0.08;
            }
            Motion::LiftPlace => {}
        }
        SynthSpec {
            name: name.to_string(),
            object,
            motion,
            fps: 30.0,
            start_xy: [0.0, 0.0],
            support_z: 0.9,
            yaw_rad: 0.0,
            motion_params,
            timing: Timing::default(),
            contacts: ContactParams::default(),
            grasp: GraspParams::default(),
            retreat_m: 0.18,
            max_penetration_mm: 2.0,
            tips: None,
            wrist_link: None,
            hold: crate::physics::Params::default(),
        }
    }
}

/// What synthesis measured on its output.
#[derive(Clone, Debug, PartialEq)]
pub struct SynthStats {
    pub grasp: Grasp,
    /// Which grasp candidate was kept, its hold test, and what was tried before it.
    pub choice: GraspChoice,
    /// Correspondences per in-contact frame.
    pub contacts_per_frame: usize,
    /// Mean correspondence distance over the in-contact frames (`D_C`) [mm].
    pub d_c_mm: f64,
    /// Largest hand-object penetration over all frames [mm].
    pub max_penetration_mm: f64,
    /// The in-contact segment `[c0, c1]`.
    pub contact_segment: (usize, usize),
}

/// A synthetic demonstration and its stats.
#[derive(Clone, Debug)]
pub struct Synthesis {
    pub demo: Demo,
    pub stats: SynthStats,
}

/// The scene a synthesized demonstration is replayed in: the table of
/// [`super::defaults::scene_bytes`], which `synth` writes beside it.
fn synth_scene(spec: &SynthSpec, robot_path: &Path) -> Result<crate::model::Scene> {
    let file = serde_json::from_slice(&super::defaults::scene_bytes(spec))
        .map_err(|e| Error::invalid(robot_path, "(scene)", format!("synthesized scene: {e}")))?;
    crate::model::Scene::from_file(file, Path::new(&format!("{}.scene.json", spec.name)))
}

/// The object as a collision shape in its own frame (the grasp IK's penetration term).
fn object_shape(mesh: &Mesh, path: &Path) -> Option<CollisionShape> {
    CollisionShape::new(
        ShapeKind::Mesh {
            path: path.to_path_buf(),
            scale: Vector3::repeat(1.0),
            mesh: std::sync::Arc::new(mesh.clone()),
        },
        Isometry3::identity(),
    )
}

/// Builds the demonstration `spec` asks for with `robot` (loaded from `robot_path`); the
/// object mesh is the one of `spec.object`, referenced as `mesh_path` in the output (the
/// file must exist when the demonstration is loaded again).
pub fn synthesize(
    spec: &SynthSpec,
    robot: &Robot,
    robot_path: &Path,
    mesh_path: &Path,
) -> Result<Synthesis> {
    let object = spec.object;
    let fail = |field: &str, msg: String| Error::invalid(robot_path, field, msg);
    let mesh = object.mesh();
    let geo = ObjectGeometry::new(mesh.clone())
        .ok_or_else(|| fail("(object)", format!("object '{object}' has no triangles")))?;
    let shape = object_shape(&mesh, mesh_path)
        .ok_or_else(|| fail("(object)", format!("object '{object}' has no triangles")))?;
    // The replay that picks a grasp sees the mesh as its file will hold it: the OBJ text's
    // rounding (micrometres, single precision) decides verdicts at the edge (the Ability
    // cube: a pass here, 23.4° in `validate`). The grasp solve and hold test keep the mesh in
    // memory; moving them to this one moves every committed demonstration's grasp.
    let written_mesh = mesh.as_written()?;

    // Rest pose on the support, and the support as a barrier of the grasp IK.
    let yaw = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), spec.yaw_rad);
    let start = Isometry3::from_parts(
        Translation3::new(
            spec.start_xy[0],
            spec.start_xy[1],
            spec.support_z - geo.min_z,
        ),
        yaw,
    );
    let table = CollisionShape::new(
        ShapeKind::Box {
            size: Vector3::new(2.0, 2.0, 0.2),
        },
        Isometry3::translation(spec.start_xy[0], spec.start_xy[1], spec.support_z - 0.1),
    )
    .expect("a box is a valid shape");

    // Each candidate grasp that holds is built into its demonstration and replayed on the
    // synthesized table (the scene `validate` finds beside it).
    let scene = synth_scene(spec, robot_path)?;
    let mut poses = robot.new_link_poses();
    let samples = contacts::hand_samples(robot, spec.contacts.spacing_mm * 1e-3);
    let mut clear = Clearance::new(robot, &shape);
    let mut build = |template: &GraspTemplate, g: &Grasp| -> Result<Candidate> {
        // Correspondences at the grasp, object frame.
        let wrist0 = start * g.wrist_in_object;
        robot.forward_kinematics(&wrist0, &g.q, &mut poses);
        let base_contacts = contacts::extract(
            robot,
            &samples,
            &poses,
            &geo,
            &start,
            spec.contacts.max_distance_mm * 1e-3,
        );
        if base_contacts.is_empty() {
            return Err(fail(
                "(grasp)",
                format!("the grasp of '{object}' touches the object nowhere"),
            ));
        }
        let mut clearance = |o: &Isometry3<f64>, w: &Isometry3<f64>| clear.of(&g.q_open, o, w);
        let frames = build_frames(spec, &start, g, template, &base_contacts, &mut clearance);
        let mut demo = new_demo(spec, robot, robot_path, mesh_path, frames);
        round_demo(&mut demo);
        // One nominal replay: the grasp search compares candidates, it does not filter.
        let hold = crate::physics::Params {
            ensemble: crate::physics::EnsembleParams::single(),
            ..spec.hold.clone()
        };
        let replay = crate::physics::validate(
            robot,
            &demo,
            &scene,
            &[],
            &written_mesh,
            &hold,
            &crate::Limits::default(),
        )?;
        Ok(Candidate {
            demo,
            contacts_per_frame: base_contacts.len(),
            replay,
        })
    };
    let (g, choice, built) = grasp_search(
        spec, robot, robot_path, &geo, &shape, &start, &table, &mut build,
    )?;
    let Candidate {
        demo,
        contacts_per_frame,
        ..
    } = built;

    // Every frame: hand-object penetration (in-contact frames share one relative pose).
    let (worst, c0, c1) = check_penetration(spec, robot, robot_path, &geo, &demo, &mut poses)?;
    let per_frame = crate::metrics::contact_distance_per_frame_mm(robot, &demo);
    let d_c_mm = crate::metrics::d_c_mm(&per_frame);
    Ok(Synthesis {
        stats: SynthStats {
            grasp: g,
            choice,
            contacts_per_frame,
            d_c_mm,
            max_penetration_mm: worst * 1e3,
            contact_segment: (c0, c1),
        },
        demo,
    })
}

/// The demonstration of `spec` with `frames`, its robot and object files named.
fn new_demo(
    spec: &SynthSpec,
    robot: &Robot,
    robot_path: &Path,
    mesh_path: &Path,
    frames: Vec<Frame>,
) -> Demo {
    Demo {
        name: spec.name.clone(),
        fps: spec.fps,
        robot: robot_path.to_path_buf(),
        object: ObjectInfo {
            name: spec.object.name().to_string(),
            mesh: mesh_path.to_path_buf(),
            mass: spec.object.mass_kg(),
        },
        joint_names: robot.actuated_names(),
        frames,
        timewarp: None,
        scene: None,
        barriers: Vec::new(),
        wrist_link: spec.wrist_link.clone(),
        source: PathBuf::from(format!("{}.demo.json", spec.name)),
    }
}

/// A candidate grasp built into its demonstration, and that demonstration's replay.
struct Candidate {
    demo: Demo,
    contacts_per_frame: usize,
    replay: crate::physics::PhysicsReport,
}

/// The grasp, the choice, and its demonstration: the first candidate whose grasp IK
/// succeeds on the object at `start` (with the support `table` as a barrier), whose grasp
/// holds the object in physics with the hand frozen ([`HoldTest`]), and whose demonstration
/// (`build`) passes the replay. When every grasp that holds fails the replay, the one whose
/// replay turns the object least is kept, and the choice says so. Fails naming every
/// candidate and why it failed when no grasp holds.
#[allow(clippy::too_many_arguments)]
fn grasp_search(
    spec: &SynthSpec,
    robot: &Robot,
    robot_path: &Path,
    geo: &ObjectGeometry,
    shape: &CollisionShape,
    start: &Isometry3<f64>,
    table: &CollisionShape,
    build: &mut dyn FnMut(&GraspTemplate, &Grasp) -> Result<Candidate>,
) -> Result<(Grasp, GraspChoice, Candidate)> {
    let object = spec.object;
    let fail = |field: &str, msg: String| Error::invalid(robot_path, field, msg);
    // Our hands have named templates for the objects they were made with; any other hand,
    // object or `--tips` gets its grasp from the hand's kinematics (so does a hand whose
    // link names match ours but whose named grasp fails). When the grasp of every finger is
    // out of reach or does not hold, the thumb and the two fingers it opposes try alone.
    let named = HandFamily::detect(robot)
        .filter(|_| spec.tips.is_none())
        .and_then(|family| templates::template(family, object));
    let generic = || -> Result<Vec<(&'static str, GraspTemplate)>> {
        let layout = super::generic::layout(robot, spec.tips.as_deref())
            .map_err(|e| fail("(robot)", format!("robot {:?}: {e}", robot.name)))?;
        let mut out = vec![(
            "every finger",
            super::generic::template(robot, &layout, geo),
        )];
        if let Some(tripod) = super::generic::tripod(&layout) {
            out.push((
                "thumb and two fingers",
                super::generic::template(robot, &tripod, geo),
            ));
        }
        Ok(out)
    };
    let hold = HoldTest::new(object, &geo.mesh, &spec.hold, robot_path)?;
    let mut queue: Vec<(&'static str, GraspTemplate)> = named
        .into_iter()
        .map(|t| ("the hand's template", t))
        .collect();
    let mut generic_queued = false;
    let mut tried: Vec<String> = Vec::new();
    // The grasp that holds whose replay turned the object least, when none passes.
    let mut best: Option<Held> = None;
    let mut k = 0;
    loop {
        if k == queue.len() {
            if generic_queued {
                break;
            }
            generic_queued = true;
            match generic() {
                Ok(ts) => queue.extend(ts),
                Err(e) if tried.is_empty() => return Err(e),
                Err(_) => break,
            }
            continue;
        }
        let (label, template) = queue[k].clone();
        k += 1;
        let g = match grasp::solve(
            robot,
            &template,
            geo,
            shape,
            start,
            std::slice::from_ref(table),
            &spec.grasp,
        ) {
            Ok(g) => g,
            Err(e) => {
                tried.push(format!("{label}: {e}"));
                continue;
            }
        };
        match judge(label, &template, g, &hold, robot, start, build) {
            Judged::Rejected(why) => tried.push(why),
            Judged::Passed(held) => {
                let choice = GraspChoice {
                    candidate: label.to_string(),
                    hold_mm: held.hold_mm,
                    replay: None,
                    tried,
                };
                return Ok((held.grasp, choice, held.built));
            }
            Judged::FailsReplay(held) => {
                tried.push(format!(
                    "{label}: the grasp holds the object ({:.1} mm in the hold test) but its demonstration fails the replay: {}",
                    held.hold_mm, held.why
                ));
                if best.as_ref().is_none_or(|b| held.rotation < b.rotation) {
                    best = Some(held);
                }
            }
        }
    }
    if let Some(b) = best {
        // The kept candidate's own replay failure is in the choice, not among the others.
        let own = format!("{}: ", b.label);
        tried.retain(|t| !t.starts_with(&own));
        let choice = GraspChoice {
            candidate: b.label.to_string(),
            hold_mm: b.hold_mm,
            replay: Some(format!(
                "no candidate's demonstration passes the replay; kept the one that turns the object least ({:.1}° on average): {}",
                b.rotation, b.why
            )),
            tried,
        };
        return Ok((b.grasp, choice, b.built));
    }
    Err(refusal(spec, robot, robot_path, geo, &tried))
}

/// Why no grasp holds: every candidate tried and why it failed, and the jaws' span when a
/// two-finger hand cannot open around the object.
fn refusal(
    spec: &SynthSpec,
    robot: &Robot,
    robot_path: &Path,
    geo: &ObjectGeometry,
    tried: &[String],
) -> Error {
    let too_wide = super::generic::layout(robot, spec.tips.as_deref())
        .ok()
        .and_then(|layout| jaws_too_narrow(robot, &layout, geo))
        .unwrap_or_default();
    Error::invalid(
        robot_path,
        "(grasp)",
        format!(
            "cannot grasp object '{}' with robot {:?}: {}{too_wide}; try another object, or name the fingertip links with --tips a,b,c (see `dexwarp robot` for the hand's links and limits)",
            spec.object,
            robot.name,
            tried.join("; ")
        ),
    )
}

/// A grasp that holds with the hand frozen, built and replayed.
struct Held {
    label: &'static str,
    hold_mm: f64,
    /// Mean rotation error of its replay [deg].
    rotation: f64,
    /// Its replay's first reason; empty when it passes.
    why: String,
    grasp: Grasp,
    built: Candidate,
}

/// What one candidate grasp came to.
enum Judged {
    /// Why it was passed over before its replay.
    Rejected(String),
    Passed(Held),
    FailsReplay(Held),
}

/// The hold test of grasp `g`, then its demonstration (`build`) and replay.
fn judge(
    label: &'static str,
    template: &GraspTemplate,
    g: Grasp,
    hold: &HoldTest,
    robot: &Robot,
    start: &Isometry3<f64>,
    build: &mut dyn FnMut(&GraspTemplate, &Grasp) -> Result<Candidate>,
) -> Judged {
    let hold_mm = hold.displacement_mm(robot, &g, start);
    if hold_mm > hold.limit_mm() {
        return Judged::Rejected(format!(
            "{label}: the grasp does not hold the object (it moves {hold_mm:.1} mm in the hold test, limit {:.1} mm)",
            hold.limit_mm()
        ));
    }
    let built = match build(template, &g) {
        Ok(b) => b,
        Err(e) => return Judged::Rejected(format!("{label}: {e}")),
    };
    let held = Held {
        label,
        hold_mm,
        rotation: built.replay.tracking.mean_rotation_error_deg,
        why: built.replay.reasons.first().cloned().unwrap_or_default(),
        grasp: g,
        built,
    };
    if held.built.replay.passed() {
        Judged::Passed(held)
    } else {
        Judged::FailsReplay(held)
    }
}

/// For a two-finger hand whose pads open less far than the object is wide (its narrowest
/// horizontal width, 5° steps): a clause saying both, for the refusal.
fn jaws_too_narrow(
    robot: &Robot,
    layout: &super::generic::HandLayout,
    geo: &ObjectGeometry,
) -> Option<String> {
    let [a, b] = layout.fingers.as_slice() else {
        return None;
    };
    let mut poses = robot.new_link_poses();
    let mut span = |q: &[f64]| {
        robot.forward_kinematics(&Isometry3::identity(), q, &mut poses);
        (poses[a.distal.index()] * a.pad - poses[b.distal.index()] * b.pad).norm()
    };
    let open = span(robot.lower()).max(span(robot.upper()));
    let width = (0..36)
        .map(|k| {
            let (s, c) = (k as f64 * 5f64.to_radians()).sin_cos();
            let along = geo.mesh.vertices.iter().map(|v| c * v.x + s * v.y);
            along.clone().fold(f64::NEG_INFINITY, f64::max) - along.fold(f64::INFINITY, f64::min)
        })
        .fold(f64::INFINITY, f64::min);
    (open < width).then(|| {
        format!(
            " (its two fingers' pads open at most {:.0} mm apart and the object is {:.0} mm wide at its narrowest)",
            open * 1e3,
            width * 1e3
        )
    })
}

/// Which grasp candidate synthesis kept, and what it tried before it.
#[derive(Clone, Debug, PartialEq)]
pub struct GraspChoice {
    /// The candidate kept: "the hand's template", "every finger" or "thumb and two fingers".
    pub candidate: String,
    /// The object's displacement in the hold test of the kept grasp [mm].
    pub hold_mm: f64,
    /// `None` when the kept grasp's demonstration passes the replay; else why it was kept
    /// anyway (no candidate's passes) and its replay's first reason.
    pub replay: Option<String>,
    /// The candidates tried before it, each with why it failed.
    pub tried: Vec<String>,
}

/// The physics hold test of a synthesized grasp ([`crate::physics::hold_displacement`]):
/// the hand frozen at the grasp, the object released at its start pose with no support,
/// gravity, the replay's contact model and limit.
struct HoldTest {
    object: std::sync::Arc<crate::physics::ObjectShape>,
    mass: f64,
    params: crate::physics::Params,
}

impl HoldTest {
    fn new(
        object: ObjectKind,
        mesh: &Mesh,
        params: &crate::physics::Params,
        robot_path: &Path,
    ) -> Result<HoldTest> {
        params.check()?;
        let (shape, _) =
            crate::physics::object_shape(mesh, &params.decomposition).map_err(|e| {
                Error::invalid(robot_path, "(object)", format!("object '{object}': {e}"))
            })?;
        Ok(HoldTest {
            object: shape,
            mass: object.mass_kg(),
            params: params.clone(),
        })
    }

    fn limit_mm(&self) -> f64 {
        self.params.max_sim_displacement_m * 1e3
    }

    /// The object's displacement [mm] under grasp `g` of the object at `start`.
    fn displacement_mm(&self, robot: &Robot, g: &Grasp, start: &Isometry3<f64>) -> f64 {
        let mut poses = robot.new_link_poses();
        robot.forward_kinematics(&(start * g.wrist_in_object), &g.q, &mut poses);
        crate::physics::hold_displacement(
            robot,
            &poses,
            &self.object,
            start,
            self.mass,
            &self.params,
        ) * 1e3
    }
}

/// The deepest hand-object penetration of the frames outside the in-contact segment
/// `[c0, c1]` (which share the grasp's relative pose, unless the hand carries the tracking
/// error: then of every frame) [m], and `c0`, `c1`. Fails at the first frame over
/// [`SynthSpec::max_penetration_mm`]; a hand that carries the tracking error is allowed the
/// error's length on top (moved by `d`, a hand goes at most `d` deeper), so what is refused
/// is the grasp and its approach, not the error asked for.
fn check_penetration(
    spec: &SynthSpec,
    robot: &Robot,
    robot_path: &Path,
    geo: &ObjectGeometry,
    demo: &Demo,
    poses: &mut [Isometry3<f64>],
) -> Result<(f64, usize, usize)> {
    let fail = |field: &str, msg: String| Error::invalid(robot_path, field, msg);
    let mut worst: f64 = 0.0;
    let c0 = spec.timing.idle + spec.timing.reach + spec.timing.close;
    let c1 = c0 + spec.timing.contact_frames() - 1;
    // A hand that carries the tracking error moves on the object from frame to frame.
    let hand_moves =
        spec.contacts.tracking_error == TrackingError::Hand && spec.contacts.offset_mm > 0.0;
    // Its length at each frame (the direction does not change it).
    let error = hand_moves.then(|| {
        Noise::new(
            spec.contacts.seed,
            0.0,
            spec.contacts.offset_mm * 1e-3,
            Vector3::z(),
        )
    });
    for (i, f) in demo.frames.iter().enumerate() {
        if i > c0 && i <= c1 && !hand_moves {
            continue;
        }
        robot.forward_kinematics(&f.wrist, &f.joints, poses);
        let p = penetration(robot, poses, geo, &f.object);
        let allowed_mm = error
            .as_ref()
            .map_or(0.0, |e| e.shared(i, spec.fps).norm() * 1e3);
        if p.depth_m * 1e3 > spec.max_penetration_mm + allowed_mm {
            let link = p.link.map_or("?", |l| robot.link(l).name.as_str());
            let of_error = if error.is_some() {
                format!(", {allowed_mm:.1} mm more for the tracking error the hand carries there")
            } else {
                String::new()
            };
            return Err(fail(
                "(grasp)",
                format!(
                    "frame {i} of '{}': the hand overlaps the object by {:.1} mm at link {link:?} (limit {} mm{of_error}); the approach or release of this grasp needs another direction",
                    spec.name,
                    p.depth_m * 1e3,
                    spec.max_penetration_mm
                ),
            ));
        }
        worst = worst.max(p.depth_m);
    }
    Ok((worst, c0, c1))
}

/// Retreat pose of an object pose: the grasp `g` moved `dist` back along the approach
/// direction (object frame, unit) and turned about the vertical by `turn`.
fn offset_pose(
    g: &Grasp,
    approach: &Vector3<f64>,
    object: &Isometry3<f64>,
    dist: f64,
    turn: f64,
) -> Isometry3<f64> {
    let grasp = object * g.wrist_in_object;
    let dir = object.rotation * approach;
    let rot = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), turn);
    Isometry3::from_parts(
        Translation3::from(grasp.translation.vector + dir * dist),
        rot * grasp.rotation,
    )
}

fn lerp_q(a: &[f64], b: &[f64], s: f64) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x + (y - x) * s).collect()
}

fn blend(a: &Isometry3<f64>, b: &Isometry3<f64>, s: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(a.translation.vector.lerp(&b.translation.vector, s)),
        a.rotation.slerp(&b.rotation, s),
    )
}

/// The frames of the three segments (see the module docs).
fn build_frames(
    spec: &SynthSpec,
    start: &Isometry3<f64>,
    g: &Grasp,
    template: &GraspTemplate,
    base_contacts: &[Contact],
    clearance: &mut dyn FnMut(&Isometry3<f64>, &Isometry3<f64>) -> f64,
) -> Vec<Frame> {
    let t = &spec.timing;
    let approach = Vector3::from(template.approach)
        .try_normalize(1e-12)
        .unwrap_or_else(Vector3::z);
    let end = motion::object_pose(spec.motion, &spec.motion_params, start, 1.0);
    let mut frames = Vec::with_capacity(t.frames());
    let mut push = |object: Isometry3<f64>, wrist: Isometry3<f64>, q: Vec<f64>, c: Vec<Contact>| {
        frames.push(Frame {
            object,
            wrist,
            joints: q,
            contacts: c,
        });
    };
    let far = offset_pose(g, &approach, start, spec.retreat_m, template.turn_rad);
    let pre = offset_pose(g, &approach, start, 0.05, 0.0);
    let grasp_w = start * g.wrist_in_object;
    for _ in 0..t.idle {
        push(*start, far, g.q_open.clone(), Vec::new());
    }
    for k in 1..=t.reach {
        let s = min_jerk(k as f64 / t.reach as f64);
        push(*start, blend(&far, &pre, s), g.q_open.clone(), Vec::new());
    }
    let closing = template.closing;
    for k in 1..=t.close {
        let u = k as f64 / t.close as f64;
        let s = min_jerk(u / closing.arrive);
        let qs = lerp_q(
            &g.q_open,
            &g.q,
            min_jerk((u - closing.fingers_from) / (1.0 - closing.fingers_from)),
        );
        push(*start, blend(&pre, &grasp_w, s), qs, Vec::new());
    }
    let mut noise = Noise::new(
        spec.contacts.seed,
        spec.contacts.noise_mm * 1e-3,
        spec.contacts.offset_mm * 1e-3,
        Vector3::from(template.slide),
    );
    let fps = spec.fps;
    let mut frame_index = t.idle + t.reach + t.close;
    let mut contact_frame = |object: Isometry3<f64>| {
        let mut c = base_contacts.to_vec();
        noise.perturb(&mut c, frame_index, fps, spec.contacts.tracking_error);
        frame_index += 1;
        (object, object * g.wrist_in_object, c)
    };
    let n = t.motion.max(2) - 1;
    let object_at = |i: usize| -> Isometry3<f64> {
        if i < t.hold {
            *start
        } else if i < t.hold + t.motion {
            let tau = (i - t.hold) as f64 / n as f64;
            motion::object_pose(spec.motion, &spec.motion_params, start, tau)
        } else {
            end
        }
    };
    for i in 0..t.contact_frames() {
        let (o, w, c) = contact_frame(object_at(i));
        push(o, w, g.q.clone(), c);
    }
    for (wrist, q) in post_contact_hand(spec, template, g, &approach, &end, clearance) {
        push(end, wrist, q, Vec::new());
    }
    if spec.contacts.tracking_error == TrackingError::Hand {
        for (i, f) in frames.iter_mut().enumerate() {
            noise.displace_wrist(&f.object, &mut f.wrist, i, fps);
        }
    }
    frames
}

/// How far the open hand is from the object, for a level release's slide-out
/// ([`SlidePath`]), up to [`SLIDE_CLEARANCE_M`].
struct Clearance<'a> {
    robot: &'a Robot,
    /// The object at the origin.
    object: LinkClearance<'a>,
    poses: Vec<Isometry3<f64>>,
}

impl<'a> Clearance<'a> {
    fn new(robot: &'a Robot, object: &'a CollisionShape) -> Clearance<'a> {
        Clearance {
            robot,
            object: LinkClearance::new(robot, std::slice::from_ref(object), SLIDE_CLEARANCE_M),
            poses: robot.new_link_poses(),
        }
    }

    /// The clearance [m] of the hand at joints `q` and wrist `wrist` from the object at
    /// `object` (world poses); negative when they overlap.
    fn of(&mut self, q: &[f64], object: &Isometry3<f64>, wrist: &Isometry3<f64>) -> f64 {
        let wrist = object.inverse() * wrist;
        self.robot.forward_kinematics(&wrist, q, &mut self.poses);
        self.object
            .nearest(&self.poses)
            .map_or(SLIDE_CLEARANCE_M, |(d, _, _)| d)
    }
}

/// How far a level release backs off [m] before the retreat, and how far out it slides
/// level [m], both from the grasp.
const BACK_OFF_M: f64 = 0.01;
const SLIDE_OUT_M: f64 = 0.08;
/// The level slide-out's path: a station every [`SLIDE_STEP_M`] of the way out, each moved
/// at most [`SLIDE_TURN_M`] sideways and up or down from the last, at most
/// [`SLIDE_MAX_OFFSET_M`] off the straight line; clearance counts up to [`SLIDE_CLEARANCE_M`].
const SLIDE_STEP_M: f64 = 0.0025;
const SLIDE_TURN_M: f64 = 0.001;
const SLIDE_MAX_OFFSET_M: f64 = 0.012;
const SLIDE_CLEARANCE_M: f64 = 0.01;

/// The way a level release slides the open hand out of a handle: along `level` (the
/// approach without its vertical part) from the grasp, each station moved sideways and
/// vertically to where the open hand is farthest from the object (`clearance(wrist)`, up to
/// [`SLIDE_CLEARANCE_M`]). A straight slide keeps the hand where its fingers closed, so
/// fingers curled through a handle rub the handle and the body all the way out (the
/// built-in teapot's slid 0.3-2.8 mm from them and turned the released pot by 25°); the
/// stations follow the middle of the gap instead. Greedy from the grasp, one station at a
/// time: of the 3 x 3 moves of [`SLIDE_TURN_M`] the clearest, ties to the nearer the
/// straight line.
struct SlidePath {
    grasp: Isometry3<f64>,
    level: Vector3<f64>,
    /// Offset of each station from the straight line [m], world frame.
    offsets: Vec<Vector3<f64>>,
}

impl SlidePath {
    fn new(
        grasp: Isometry3<f64>,
        level: Vector3<f64>,
        clearance: &mut dyn FnMut(&Isometry3<f64>) -> f64,
    ) -> SlidePath {
        let side = Vector3::z().cross(&level);
        let side = side.try_normalize(1e-12).unwrap_or_else(Vector3::x);
        let stations = (SLIDE_OUT_M / SLIDE_STEP_M).round() as usize;
        let mut path = SlidePath {
            grasp,
            level,
            offsets: vec![Vector3::zeros()],
        };
        for k in 1..=stations {
            let last = path.offsets[k - 1];
            let mut best = (f64::NEG_INFINITY, last);
            for (i, j) in (-1..=1).flat_map(|i| (-1..=1).map(move |j| (i, j))) {
                let offset = last + (side * i as f64 + Vector3::z() * j as f64) * SLIDE_TURN_M;
                if offset.dot(&side).abs() > SLIDE_MAX_OFFSET_M + 1e-12
                    || offset.z.abs() > SLIDE_MAX_OFFSET_M + 1e-12
                {
                    continue;
                }
                let wrist = path.at(k as f64 * SLIDE_STEP_M, &offset);
                let score = clearance(&wrist).min(SLIDE_CLEARANCE_M) - 1e-3 * offset.norm();
                if score > best.0 {
                    best = (score, offset);
                }
            }
            path.offsets.push(best.1);
        }
        path
    }

    fn at(&self, dist: f64, offset: &Vector3<f64>) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::from(self.grasp.translation.vector + self.level * dist + offset),
            self.grasp.rotation,
        )
    }

    /// The wrist `dist` [m] out along the path (clamped to its ends).
    fn pose(&self, dist: f64) -> Isometry3<f64> {
        // `new` makes 33 stations, so there is always a next one.
        let last = self.offsets.len() - 1;
        let x = (dist / SLIDE_STEP_M).clamp(0.0, last as f64);
        let i = (x.floor() as usize).min(last - 1);
        let offset = self.offsets[i].lerp(&self.offsets[i + 1], x - i as f64);
        self.at(dist, &offset)
    }
}

/// The hand of the post-contact frames (release, retreat, rest) about the object's final
/// pose `end`: wrist pose and joints of each frame. `clearance(object, wrist)` is how far
/// the open hand is from the object (for a level release's slide-out, [`SlidePath`]).
fn post_contact_hand(
    spec: &SynthSpec,
    template: &GraspTemplate,
    g: &Grasp,
    approach: &Vector3<f64>,
    end: &Isometry3<f64>,
    clearance: &mut dyn FnMut(&Isometry3<f64>, &Isometry3<f64>) -> f64,
) -> Vec<(Isometry3<f64>, Vec<f64>)> {
    let t = &spec.timing;
    let mut out = Vec::with_capacity(t.release + t.retreat + t.rest);
    let end_grasp = end * g.wrist_in_object;
    // The approach without its vertical part, for a level release.
    let slide = template.level_release.then(|| {
        let dir = end.rotation * approach;
        let level = Vector3::new(dir.x, dir.y, 0.0)
            .try_normalize(1e-12)
            .unwrap_or_else(Vector3::zeros);
        SlidePath::new(end_grasp, level, &mut |w| clearance(end, w))
    });
    // A level release opens the fingers over the first half, then backs off along its path.
    let (open_by, back_from) = if slide.is_some() {
        (0.5, 0.5)
    } else {
        (1.0, 0.0)
    };
    let backed = offset_pose(g, approach, end, BACK_OFF_M, 0.0);
    for k in 1..=t.release {
        let u = k as f64 / t.release as f64;
        let s = min_jerk((u - back_from) / (1.0 - back_from));
        let wrist = match &slide {
            Some(path) => path.pose(BACK_OFF_M * s),
            None => blend(&end_grasp, &backed, s),
        };
        out.push((wrist, lerp_q(&g.q, &g.q_open, min_jerk(u / open_by))));
    }
    let far_end = offset_pose(g, approach, end, spec.retreat_m, -template.turn_rad);
    // A level release slides out (the fingers clear of a handle) over the first half of the
    // retreat, then goes to the retreat pose.
    for k in 1..=t.retreat {
        let u = k as f64 / t.retreat as f64;
        let pose = match &slide {
            Some(path) if u <= 0.5 => {
                path.pose(BACK_OFF_M + (SLIDE_OUT_M - BACK_OFF_M) * min_jerk(u / 0.5))
            }
            Some(path) => blend(&path.pose(SLIDE_OUT_M), &far_end, min_jerk((u - 0.5) / 0.5)),
            None => blend(&backed, &far_end, min_jerk(u)),
        };
        out.push((pose, g.q_open.clone()));
    }
    for _ in 0..t.rest {
        out.push((far_end, g.q_open.clone()));
    }
    out
}

/// Rounds to `1/scale`; `+ 0.0` turns `-0.0` into `0.0`.
fn round(v: f64, scale: f64) -> f64 {
    (v * scale).round() / scale + 0.0
}

fn round_pose(p: &Isometry3<f64>) -> Isometry3<f64> {
    let t = p.translation.vector.map(|v| round(v, 1e6));
    let q = p.rotation.quaternion();
    let q = nalgebra::Quaternion::new(
        round(q.w, 1e7),
        round(q.i, 1e7),
        round(q.j, 1e7),
        round(q.k, 1e7),
    );
    Isometry3::from_parts(
        Translation3::from(t),
        UnitQuaternion::new_unchecked(q.normalize()),
    )
}

/// Rounds every number of `demo` (see the module docs). Quaternions are renormalised after
/// rounding and rounded again, so the stored and the reloaded value agree.
pub fn round_demo(demo: &mut Demo) {
    for f in &mut demo.frames {
        f.object = round_pose(&f.object);
        f.wrist = round_pose(&f.wrist);
        for v in &mut f.joints {
            *v = round(*v, 1e6);
        }
        for c in &mut f.contacts {
            c.hand_point = Point3::from(c.hand_point.coords.map(|v| round(v, 1e6)));
            c.object_point = Point3::from(c.object_point.coords.map(|v| round(v, 1e6)));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The frames of `object`'s human template around a grasp 10 cm beside the object, with
    /// a two-joint hand closing from 1 to 0 (the frame builder needs no robot).
    fn frames_of(object: ObjectKind, motion: Motion) -> (SynthSpec, Grasp, Vec<Frame>) {
        let spec = SynthSpec::new("t", object, motion);
        let template = templates::template(HandFamily::Human, object).unwrap();
        let g = Grasp {
            wrist_in_object: Isometry3::translation(-0.1, 0.0, 0.0),
            q: vec![0.0, 0.0],
            q_open: vec![1.0, 1.0],
            ik_mean_mm: 0.0,
            ik_iterations: 0,
            depth_mm: 0.0,
            nudges: 0,
        };
        let start = Isometry3::translation(0.0, 0.0, 1.0);
        let frames = build_frames(&spec, &start, &g, &template, &[], &mut |_, _| 1.0);
        assert_eq!(frames.len(), spec.timing.frames());
        (spec, g, frames)
    }

    fn wrist_in_object(f: &Frame) -> Vector3<f64> {
        (f.object.inverse() * f.wrist).translation.vector
    }

    /// The shared tracking offset on the hand instead of the correspondences: the same data
    /// between hand and correspondences at every in-contact frame, with the correspondences
    /// on the grasp and the recorded wrist moved by the offset at every frame.
    #[test]
    fn the_tracking_error_moves_to_the_hand_with_the_same_data_between_them() {
        let (mut spec, g, _) = frames_of(ObjectKind::Mug, Motion::Pass);
        spec.contacts.noise_mm = 1.0;
        spec.contacts.offset_mm = 8.0;
        spec.contacts.seed = 5;
        let template = templates::template(HandFamily::Human, ObjectKind::Mug).unwrap();
        let start = Isometry3::translation(0.0, 0.0, 1.0);
        let base: Vec<Contact> = [[0.03, 0.0, 0.02], [0.035, 0.01, -0.01]]
            .iter()
            .map(|p| Contact {
                link: "index_distal".into(),
                hand_point: Point3::origin(),
                object_point: Point3::from(Vector3::from(*p)),
            })
            .collect();
        let build = |on: TrackingError| {
            let mut spec = spec.clone();
            spec.contacts.tracking_error = on;
            build_frames(&spec, &start, &g, &template, &base, &mut |_, _| 1.0)
        };
        let on_points = build(TrackingError::Correspondences);
        let on_hand = build(TrackingError::Hand);
        let noise = Noise::new(5, 1e-3, 8e-3, Vector3::from(template.slide));
        let t = spec.timing;
        let c0 = t.idle + t.reach + t.close;
        let mut largest: f64 = 0.0;
        for (i, (a, b)) in on_points.iter().zip(&on_hand).enumerate() {
            assert_eq!((a.object, &a.joints), (b.object, &b.joints));
            let shared = noise.shared(i, spec.fps);
            largest = largest.max(shared.norm());
            // The hand carries the offset at every frame, approach and retreat too.
            let moved = wrist_in_object(a) - wrist_in_object(b);
            assert!(
                (moved - shared).norm() < 1e-12,
                "frame {i}: {moved:?} vs {shared:?}"
            );
            if (c0..c0 + t.contact_frames()).contains(&i) {
                assert_eq!(a.contacts.len(), base.len());
                for ((ca, cb), c) in a.contacts.iter().zip(&b.contacts).zip(&base) {
                    // Hand and correspondences stand as they do with the offset on the points.
                    let gap_a = ca.object_point.coords - wrist_in_object(a);
                    let gap_b = cb.object_point.coords - wrist_in_object(b);
                    assert!((gap_a - gap_b).norm() < 1e-12, "frame {i}");
                    // On the grasp but for the per-point noise (1 mm σ per axis).
                    assert!(
                        (cb.object_point - c.object_point).norm() < 6e-3,
                        "frame {i}"
                    );
                }
            } else {
                assert!(a.contacts.is_empty() && b.contacts.is_empty());
            }
        }
        assert!(largest > 4e-3, "the offset is {largest} m at most");
    }

    #[test]
    fn the_teapot_hand_is_in_place_before_its_fingers_close() {
        let (spec, g, frames) = frames_of(ObjectKind::Teapot, Motion::Pour);
        let t = spec.timing;
        let first = t.idle + t.reach;
        for k in 1..=t.close {
            let (u, f) = (k as f64 / t.close as f64, &frames[first + k - 1]);
            let off = (wrist_in_object(f) - g.wrist_in_object.translation.vector).norm();
            if u >= 0.6 {
                assert!(
                    off < 1e-12,
                    "frame {k} of the closing: {off} m off the grasp"
                );
            } else {
                assert!(
                    off > 1e-6,
                    "frame {k} of the closing is already at the grasp"
                );
            }
            if u <= 0.5 {
                assert_eq!(f.joints, g.q_open, "frame {k} of the closing");
            } else {
                assert!(f.joints[0] < 1.0, "frame {k} of the closing");
            }
        }
        // The mug's hand closes its fingers as it moves in.
        let (spec, g, frames) = frames_of(ObjectKind::Mug, Motion::Pass);
        let t = spec.timing;
        let mid = &frames[t.idle + t.reach + t.close / 2 - 1];
        assert!(mid.joints[0] < 1.0);
        assert!((wrist_in_object(mid) - g.wrist_in_object.translation.vector).norm() > 1e-3);
    }

    /// A pole of 8 mm radius stands 3 mm beside the straight slide-out, 4 cm out: the path
    /// steps around it (sideways, not up: rising does not help beside a vertical pole), a
    /// turn at most a station, within the offset bound; with nothing near, it stays on the
    /// straight line.
    #[test]
    fn the_slide_out_steps_around_what_is_beside_it() {
        let grasp = Isometry3::translation(0.1, 0.2, 1.0);
        let level = -Vector3::y();
        // z × level = +x: the pole is on the +x side.
        let pole = Vector3::new(0.103, 0.16, 0.0);
        let mut clearance = |w: &Isometry3<f64>| {
            let p = w.translation.vector - pole;
            p.xy().norm() - 0.008
        };
        let path = SlidePath::new(grasp, level, &mut clearance);
        assert_eq!(path.offsets.len(), 33);
        assert_eq!(path.pose(0.0), grasp);
        let mut closest = f64::INFINITY;
        for (k, o) in path.offsets.iter().enumerate() {
            assert!(o.z.abs() < 1e-12, "station {k} moves up or down: {o}");
            assert!(o.x.abs() <= SLIDE_MAX_OFFSET_M + 1e-12, "station {k}: {o}");
            if k > 0 {
                let turn = (o - path.offsets[k - 1]).abs().max();
                assert!(turn <= SLIDE_TURN_M + 1e-12, "station {k} turns {turn}");
            }
            let at = path.pose(k as f64 * SLIDE_STEP_M);
            let out = (at.translation.vector - grasp.translation.vector).dot(&level);
            assert!((out - k as f64 * SLIDE_STEP_M).abs() < 1e-12);
            closest = closest.min(clearance(&at));
        }
        // Straight on, the hand would be 5 mm inside the pole; around it, it stays clear.
        assert!(
            clearance(&path.pose(0.04)) > 0.0,
            "{}",
            clearance(&path.pose(0.04))
        );
        assert!(closest > 0.0, "{closest}");
        assert!(path.offsets[16].x < -0.004, "{}", path.offsets[16]);
        // Far from the pole, the straight line.
        assert_eq!(path.offsets[1], Vector3::zeros());
        let path = SlidePath::new(grasp, level, &mut |_| 1.0);
        assert!(path.offsets.iter().all(|o| *o == Vector3::zeros()));
    }

    #[test]
    fn the_teapot_hand_opens_then_slides_out_level() {
        let (spec, g, frames) = frames_of(ObjectKind::Teapot, Motion::Pour);
        let t = spec.timing;
        let first = t.idle + t.reach + t.close + t.contact_frames();
        let grasp = frames[first - 1].wrist.translation.vector;
        for k in 1..=t.release {
            let (u, f) = (k as f64 / t.release as f64, &frames[first + k - 1]);
            let moved = f.wrist.translation.vector - grasp;
            if u <= 0.5 {
                assert!(
                    moved.norm() < 1e-12,
                    "frame {k} of the release moved {moved}"
                );
            }
            if u >= 0.5 {
                assert_eq!(f.joints, g.q_open, "frame {k} of the release");
            }
            assert!(
                moved.z.abs() < 1e-12,
                "frame {k} of the release rises {}",
                moved.z
            );
        }
        let backed = frames[first + t.release - 1].wrist.translation.vector - grasp;
        assert!((backed.norm() - 0.01).abs() < 1e-9, "{backed}");
        // It slides out 8 cm level over the first half of the retreat (nothing is near, so
        // straight), then rises.
        let first = first + t.release;
        for k in 1..=t.retreat / 2 {
            let moved = frames[first + k - 1].wrist.translation.vector - grasp;
            assert!(
                moved.z.abs() < 1e-12,
                "frame {k} of the retreat rises {}",
                moved.z
            );
        }
        let out = frames[first + t.retreat / 2 - 1].wrist.translation.vector - grasp;
        assert!((out.norm() - 0.08).abs() < 1e-9, "{out}");
        assert!(frames[first + t.retreat - 1].wrist.translation.z > grasp.z + 0.01);
        // The mug's hand rises with its approach as it backs off, fingers opening.
        let (spec, _, frames) = frames_of(ObjectKind::Mug, Motion::Pass);
        let t = spec.timing;
        let first = t.idle + t.reach + t.close + t.contact_frames();
        let mid = &frames[first + t.release / 2];
        assert!(mid.wrist.translation.z > frames[first - 1].wrist.translation.z + 1e-4);
        assert!(mid.joints[0] > 0.0 && mid.joints[0] < 1.0);
    }
}
