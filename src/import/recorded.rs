//! `dexwarp import --keypoints`: a recorded human hand onto a robot hand, with the object's
//! mesh made solid and the table it rests on written as the demonstration's scene.
//!
//! Beside `DIR/NAME.demo.json` it writes `NAME.scene.json` (a support item `table`, see
//! [`infer_table`]), `NAME.object.obj` when the mesh had to be repaired or mirrored (the
//! demonstration names it instead of the input), and `NAME.import.json`: what the import
//! did and, per frame, what the cleaning cost ([`super::keypoints::Residuals`]) and how deep
//! the cleaned hand is in the object.

use std::path::{Path, PathBuf};
use std::time::Instant;

use nalgebra::{Isometry3, Vector3};
use serde::Serialize;

use super::keypoints::{self, Handedness, KeypointMap, Recording};
use super::{Target, check_fps, check_mass, finish_in};
use crate::geometry::{Mesh, Repair};
use crate::model::Demo;
use crate::model::scene::{
    Role, SCENE_FORMAT, Scene, SceneFile, SceneItemJson, ScenePoseJson, ShapeJson,
};
use crate::robot::Robot;
use crate::synth::proximity::ObjectGeometry;
use crate::{Error, Limits, Result};

/// Options of [`import_keypoints`].
#[derive(Clone, Debug)]
pub struct KeypointOptions {
    /// Frame rate of the recording [Hz].
    pub fps: f64,
    /// The recorded hand; a left hand is mirrored onto the (right) robot hand.
    pub handedness: Handedness,
    /// A keypoint map (JSON, [`KeypointMap`]); default the built-in human hand's.
    pub keypoint_map: Option<PathBuf>,
    /// Simulate an object mesh that cannot be repaired as its convex hull.
    pub hull_fallback: bool,
    /// A scene to name instead of the inferred table.
    pub scene: Option<PathBuf>,
    /// Refine the hand inside the contact segment with the warp's contact IK on the recorded
    /// correspondences (default on; see [`refine_contacts`]).
    pub refine: bool,
    /// Retargeting parameters (`--retarget`); `None`: the map's, else the defaults.
    pub params: Option<keypoints::Params>,
}

/// What [`import_keypoints`] did.
#[derive(Clone, Debug, Serialize)]
pub struct KeypointImport {
    #[serde(skip)]
    pub demo: Demo,
    pub recording: PathBuf,
    pub handedness: Handedness,
    /// The recording was mirrored (left hand onto a right robot hand).
    pub mirrored: bool,
    /// The object's mesh and scene.
    #[serde(flatten)]
    pub placement: Placement,
    /// What the contact refinement did (`None` when it was not asked for).
    pub refinement: Option<Refinement>,
    /// The retargeting parameters used (`--retarget`, the map's, or the defaults).
    pub retarget: keypoints::Params,
    /// First and last frame where the recorded hand touches the object.
    pub touch_frames: Option<[usize; 2]>,
    /// Warnings about the recording (object moving before the hand touches it, ...).
    pub warnings: Vec<String>,
    /// Keypoint residuals of the cleaned hand [mm], mean and largest over frames.
    pub residual_mean_mm: f64,
    pub residual_max_mm: f64,
    /// Deepest the cleaned hand is in the object over all frames [mm].
    pub max_penetration_mm: f64,
    /// Wall time of the import [s].
    pub time_s: f64,
    /// Per frame: keypoint residuals and the cleaned hand's depth in the object.
    pub per_frame: PerFrame,
}

/// Per-frame figures of the import.
#[derive(Clone, Debug, Default, Serialize)]
pub struct PerFrame {
    pub residual_mean_mm: Vec<f64>,
    pub residual_max_mm: Vec<f64>,
    pub residual_worst_keypoint: Vec<String>,
    pub penetration_mm: Vec<f64>,
}

/// The file `NAME.SUFFIX` beside the demonstration `out` (`DIR/NAME.demo.json`).
pub(crate) fn beside(out: &Path, suffix: &str) -> PathBuf {
    let name = out
        .file_name()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_default();
    let stem = name
        .strip_suffix(".demo.json")
        .or_else(|| name.strip_suffix(".json"))
        .unwrap_or(&name)
        .to_string();
    out.with_file_name(format!("{stem}.{suffix}"))
}

/// The height of the support under the object: its lowest point at the first frame, where
/// the recording has it at rest. World z must be up: no frame may put the object's lowest
/// point more than 2 cm below that (it would go through the support), and the hand must be
/// above it at the first frame. `columns`: the recording's names of the object's pose
/// columns and of the hand's height, for the errors.
pub fn infer_table(
    path: &Path,
    columns: [&str; 2],
    object: &[Isometry3<f64>],
    hand_z0: f64,
    mesh: &Mesh,
) -> Result<f64> {
    let lowest = |pose: &Isometry3<f64>| {
        mesh.vertices
            .iter()
            .map(|v| (pose * v).z)
            .fold(f64::INFINITY, f64::min)
    };
    let top = lowest(&object[0]);
    if let Some(t) = (0..object.len()).find(|&t| lowest(&object[t]) < top - 0.02) {
        return Err(Error::invalid(
            path,
            format!("row {}, {}", t + 1, columns[0]),
            format!(
                "puts the object's lowest point at z = {:.3} m, below where it rests at the first frame ({top:.3} m); expected world z up and the object starting on its support; give a scene with --scene",
                lowest(&object[t])
            ),
        ));
    }
    if hand_z0 < top {
        return Err(Error::invalid(
            path,
            format!("row 1, {}", columns[1]),
            format!(
                "puts the hand below the support inferred at z = {top:.3} m; expected world z up"
            ),
        ));
    }
    Ok(top)
}

/// The inferred scene: a table 0.8 m across and 4 cm thick whose top is at `top`, centred
/// under the object's first position.
fn table_scene(name: &str, first: &Isometry3<f64>, top: f64) -> SceneFile {
    let c = first.translation.vector;
    SceneFile {
        format: SCENE_FORMAT.into(),
        name: format!("{name} (inferred from the recording)"),
        items: vec![SceneItemJson {
            name: "table".into(),
            role: Role::Support,
            pose: ScenePoseJson {
                position: [c.x, c.y, top - 0.02],
                orientation: [1.0, 0.0, 0.0, 0.0],
            },
            shape: ShapeJson::Box {
                size: [0.8, 0.8, 0.04],
            },
        }],
    }
}

/// A warning when the object moves more than 5 mm from its first pose before the first
/// frame the hand touches it, naming those frames.
pub(crate) fn moved_before_touch(
    object: &[Isometry3<f64>],
    touch: Option<[usize; 2]>,
) -> Option<String> {
    let first = touch.map_or(object.len(), |t| t[0]);
    let start = object[0].translation.vector;
    let moved: Vec<usize> = (0..first)
        .filter(|&t| (object[t].translation.vector - start).norm() > 0.005)
        .collect();
    let (a, b) = (moved.first()?, moved.last()?);
    Some(format!(
        "the object moves more than 5 mm from its first pose on frames {a}-{b}, before the hand touches it (first touch: {}); the replay cannot reproduce that",
        touch.map_or("never".into(), |t| format!("frame {}", t[0]))
    ))
}

/// What the contact refinement did: D_C [mm] before and after, how deep the hand is in the
/// object before and after, and the share of the contact segment's frames where the IK
/// reached its threshold.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Refinement {
    pub d_c_before_mm: f64,
    /// D_C of the demonstration written: the refined hand's when it was kept.
    pub d_c_mm: f64,
    /// D_C the refinement reached, and whether it was kept (only when lower than before
    /// and the hand no deeper in the object).
    pub d_c_refined_mm: f64,
    /// The deepest penetration probe in the object over every frame [mm], before and after
    /// the refinement (the measure the IK keeps out and `validate` reports).
    pub depth_before_mm: f64,
    pub depth_refined_mm: f64,
    pub kept: bool,
    pub ik_converged_fraction: Option<f64>,
    pub time_s: f64,
}

/// The retargeted hand fits the recorded keypoints and the correspondences together, and a
/// hand of another size cannot meet both: its fingertips end centimetres from the recorded
/// contacts. Inside the contact segment the warp's contact IK (non-penetrating objective, its
/// default threshold) then solves the hand on the correspondences alone, starting from the
/// retargeted hand, as an identity warp would: no waypoints, the recorded timing kept
/// (`retime: speed`), no physics. Outside contact the hand stays as retargeted.
pub fn refine_contacts(
    demo: Demo,
    robot: &Robot,
    mesh: &Mesh,
    scene: &Path,
    limits: &Limits,
) -> Result<(Demo, Refinement)> {
    let clock = Instant::now();
    let out = demo.source.clone();
    let scene = std::path::absolute(scene).map_err(|e| Error::read(scene, e))?;
    let config = crate::model::config::WarpConfig {
        name: demo.name.clone(),
        description: None,
        demo: out.clone(),
        scene,
        waypoints: Vec::new(),
        barriers: Vec::new(),
        start: None,
        end: None,
        params: crate::model::config::WarpParams {
            retime: crate::model::RetimeMode::Speed,
            ..Default::default()
        },
        source: out.clone(),
    };
    let loaded = crate::pipeline::Loaded {
        demo,
        robot: robot.clone(),
        mesh: mesh.clone(),
    };
    let inputs = crate::pipeline::Inputs::with(config, loaded, limits)?;
    let run = crate::pipeline::warp(
        &inputs,
        &crate::pipeline::Options::new(crate::pipeline::HandMethod::Contact)
            .physics(None)
            .limits(*limits),
    )?;
    let r = &run.report;
    let (before, after) = (r.metrics.d_c_mm.original, r.metrics.d_c_mm.warped);
    let sdf = crate::geometry::object_sdf(mesh);
    let deepest = |d: &Demo| {
        sdf.as_deref().map_or(0.0, |sdf| {
            crate::metrics::max_hand_object_penetration_mm(robot, d, sdf)
        })
    };
    let (depth_before, depth_after) = (deepest(&inputs.demo), deepest(&run.demo));
    // Kept only where it brings the fingertips closer without pressing the hand deeper: an IK
    // that cannot reach the contacts (a hand far from the person's proportions) would
    // otherwise trade the recording's approach for nothing, and a closer fit bought with
    // fingers further in the object is not a better one.
    let kept = after < before && depth_after <= depth_before;
    let demo = if kept {
        let mut refined = run.demo;
        refined.timewarp = None;
        refined.source = out.clone();
        refined.save(&out)?;
        Demo::load(&out, limits)?
    } else {
        inputs.demo
    };
    Ok((
        demo,
        Refinement {
            d_c_before_mm: before,
            d_c_mm: if kept { after } else { before },
            d_c_refined_mm: after,
            depth_before_mm: depth_before,
            depth_refined_mm: depth_after,
            kept,
            ik_converged_fraction: r.ik.as_ref().map(|ik| ik.converged_fraction),
            time_s: clock.elapsed().as_secs_f64(),
        },
    ))
}

/// How the recorded rest poses of the object were moved onto the supports.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct RestCorrection {
    /// At the first frame and at the last: how far the object moved as it settled [mm] and
    /// [deg], and whether that pose was corrected (a pose that does not rest on a support,
    /// an object held in the air at the end, falls further than [`REST_TOLERANCE`] and is
    /// kept as recorded).
    pub start_mm: f64,
    pub start_deg: f64,
    pub start_corrected: bool,
    pub end_mm: f64,
    pub end_deg: f64,
    pub end_corrected: bool,
}

/// Largest settling of a recorded rest pose that is taken as capture error [mm], [deg];
/// beyond it the object was not resting there.
pub const REST_TOLERANCE: (f64, f64) = (15.0, 10.0);

/// Moves the recording's rest poses to where physics lets the object rest. The recorded
/// object stands a few millimetres and degrees off its support (marker and calibration
/// error), and the replay settles it at its first step: every finger placed on the recorded
/// pose is then off by as much and pushes the object before the lift. The first and the last
/// pose are each let go on the supports with no hand about for a second of simulated time;
/// the correction (in the object's own frame) is applied in full while the object rests
/// within 5 mm of its first (last) pose, blended between. Returns, besides what was done,
/// each frame's correction as a motion of the world: the caller moves the hand by it, so the
/// hand-object relation of every frame stays as recorded.
pub fn settle_rest_poses(
    object: &mut [Isometry3<f64>],
    robot: &Robot,
    mesh_path: &Path,
    mesh: &Mesh,
    mass: f64,
    supports: &[crate::geometry::shape::CollisionShape],
) -> Result<(RestCorrection, Vec<Isometry3<f64>>)> {
    let n = object.len();
    let shape = crate::geometry::hull::object_shape(mesh, &Default::default())
        .map_err(|e| Error::invalid(mesh_path, "(mesh)", e.to_string()))?
        .0;
    let params = crate::physics::Params::default();
    let settle = |pose: &Isometry3<f64>| {
        let end = crate::physics::settle(robot, &shape, pose, mass, supports, &params, 1.0);
        let delta = pose.inverse() * end;
        let mm = (end.translation.vector - pose.translation.vector).norm() * 1e3;
        let deg = delta.rotation.angle().to_degrees();
        let ok = mm <= REST_TOLERANCE.0 && deg <= REST_TOLERANCE.1;
        (if ok { delta } else { Isometry3::identity() }, mm, deg, ok)
    };
    let (first, start_mm, start_deg, start_corrected) = settle(&object[0]);
    let (last, end_mm, end_deg, end_corrected) = settle(&object[n - 1]);
    let near = |t: usize, to: usize| {
        (object[t].translation.vector - object[to].translation.vector).norm() <= 0.005
    };
    // Frames [0, lift) rest at the start, [down, n) at the end.
    let lift = (0..n).find(|&t| !near(t, 0)).unwrap_or(n);
    let down = (lift..n)
        .rev()
        .find(|&t| !near(t, n - 1))
        .map_or(lift, |t| t + 1);
    let mut world = Vec::with_capacity(n);
    for (t, pose) in object.iter_mut().enumerate() {
        let delta = if t < lift {
            first
        } else if t >= down {
            last
        } else {
            let s = (t + 1 - lift) as f64 / (down - lift + 1) as f64;
            first.lerp_slerp(&last, s)
        };
        let before = *pose;
        *pose = before * delta;
        world.push(*pose * before.inverse());
    }
    Ok((
        RestCorrection {
            start_mm,
            start_deg,
            start_corrected,
            end_mm,
            end_deg,
            end_corrected,
        },
        world,
    ))
}

/// The object mesh made solid as physics makes it ([`crate::geometry::hull::solid_mesh`]):
/// repaired when open or inside out, refused when that cannot close it (or replaced by its
/// hull with `hull_fallback`); returns the mesh, the repair, and the hull's and mesh's
/// volumes [cm³] when the hull stands in.
pub(crate) fn solid_object(
    path: &Path,
    mesh: Mesh,
    hull_fallback: bool,
) -> Result<(Mesh, Option<Repair>, Option<[f64; 2]>)> {
    let (solid, repair) = crate::geometry::hull::solid_mesh(&mesh);
    if solid.is_closed_and_consistently_wound() {
        return Ok((solid.into_owned(), repair, None));
    }
    let refused =
        |e: crate::geometry::hull::ShapeError| Error::invalid(path, "(mesh)", e.to_string());
    let (_, [hull, whole]) =
        crate::geometry::hull::open_mesh_hull(&mesh, hull_fallback).map_err(refused)?;
    let hull_mesh = mesh
        .convex_hull_mesh()
        .ok_or_else(|| refused(crate::geometry::hull::ShapeError::Degenerate))?;
    Ok((hull_mesh, repair, Some([hull * 1e6, whole * 1e6])))
}

/// What [`place_object`] needs to know of an import.
pub(crate) struct Placing<'a> {
    /// The recording and its names of the object's pose columns and of the hand's height.
    pub recording: &'a Path,
    pub columns: [&'a str; 2],
    /// The object mesh as the demonstration will name it, what made it solid
    /// ([`solid_object`]), and whether it was mirrored: a mesh repaired, replaced by its hull
    /// or mirrored is written beside the demonstration, which names it instead of the input.
    pub mesh: Mesh,
    pub repair: Option<Repair>,
    pub hull_volumes_cm3: Option<[f64; 2]>,
    pub mirrored: bool,
    /// A scene given with `--scene`, instead of the inferred table.
    pub scene: Option<&'a Path>,
    /// The hand's height at the first frame [m] (it must be above the inferred table).
    pub hand_z0: f64,
}

/// Where an import put the object: its mesh and scene, as the import record says them.
#[derive(Clone, Debug, Serialize)]
pub struct Placement {
    /// What the repair of the object mesh changed (`None`: it was closed).
    pub mesh_repair: Option<Repair>,
    /// The hull's and the mesh's volumes [cm³] when the hull stands in for an open mesh.
    pub hull_volumes_cm3: Option<[f64; 2]>,
    /// The object mesh the demonstration names.
    pub mesh: PathBuf,
    /// The scene the demonstration names, and the table's top height when inferred [m].
    pub scene: PathBuf,
    pub table_top_z_m: Option<f64>,
    /// How far the object's recorded rest poses were moved to where it settles on the
    /// supports (see [`settle_rest_poses`]); `None` without supports.
    pub rest_correction: Option<RestCorrection>,
    /// The simulated object's volume over its mesh's (see
    /// [`crate::geometry::hull::ObjectShape::volume_ratio`]).
    pub object_volume_ratio: Option<f64>,
}

/// The object in its scene, as [`place_object`] left it.
pub(crate) struct Placed {
    pub mesh: Mesh,
    pub geometry: ObjectGeometry,
    pub supports: Vec<crate::geometry::shape::CollisionShape>,
    /// Per frame, the rest correction as a motion of the world ([`settle_rest_poses`]): the
    /// caller moves the hand by it.
    pub world: Vec<Isometry3<f64>>,
    pub record: Placement,
    /// Warnings about the object (a decomposition fuller than the mesh).
    pub warnings: Vec<String>,
}

/// The demonstration's name: `--name`, else the output file's stem.
pub(crate) fn demo_name(target: &Target) -> String {
    target.name.clone().unwrap_or_else(|| {
        beside(&target.out, "x")
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_else(|| "recording".into())
    })
}

/// Puts the recorded object in a scene: writes the mesh beside the demonstration when it is
/// not the input's (see [`Placing::mesh`]), names the given scene or writes the table inferred under the object
/// ([`infer_table`]), and settles the object's rest poses on the supports
/// ([`settle_rest_poses`], `object` corrected in place).
pub(crate) fn place_object(
    placing: Placing<'_>,
    object: &mut [Isometry3<f64>],
    robot: &Robot,
    target: &Target,
    limits: &Limits,
) -> Result<Placed> {
    let out = &target.out;
    if let Some(dir) = out.parent()
        && !dir.as_os_str().is_empty()
    {
        std::fs::create_dir_all(dir).map_err(|e| Error::write(dir, e))?;
    }
    let mut mesh = placing.mesh;
    let rewritten =
        placing.mirrored || placing.repair.is_some() || placing.hull_volumes_cm3.is_some();
    let mesh_path = if rewritten {
        let p = beside(out, "object.obj");
        crate::model::json::write_atomic(&p, mesh.to_obj_string().as_bytes())?;
        // What every later command reads back.
        mesh = Mesh::load(&p, Vector3::repeat(1.0), limits)?;
        p
    } else {
        target.mesh.clone()
    };
    let (scene_path, table_top) = match placing.scene {
        Some(s) => (s.to_path_buf(), None),
        None => {
            let top = infer_table(
                placing.recording,
                placing.columns,
                object,
                placing.hand_z0,
                &mesh,
            )?;
            let p = beside(out, "scene.json");
            let scene = table_scene(&demo_name(target), &object[0], top);
            crate::model::json::write_json_atomic(&p, &scene)?;
            (p, Some(top))
        }
    };
    let scene = Scene::load(&scene_path, limits)?;
    let supports: Vec<_> = scene
        .items
        .iter()
        .filter(|i| i.role == Role::Support)
        .map(|i| scene.collision_shape(i, limits))
        .collect::<Result<_>>()?;
    let (rest_correction, world) = if supports.is_empty() {
        (None, vec![Isometry3::identity(); object.len()])
    } else {
        let (r, w) = settle_rest_poses(object, robot, &mesh_path, &mesh, target.mass, &supports)?;
        (Some(r), w)
    };
    let geometry = ObjectGeometry::new(mesh.clone())
        .ok_or_else(|| Error::invalid(&mesh_path, "(mesh)", "has no triangles"))?;
    let volume_ratio = crate::geometry::hull::object_shape(&mesh, &Default::default())
        .ok()
        .and_then(|(s, _)| s.volume_ratio);
    Ok(Placed {
        mesh,
        geometry,
        supports,
        world,
        record: Placement {
            mesh_repair: placing.repair,
            hull_volumes_cm3: placing.hull_volumes_cm3,
            mesh: mesh_path,
            scene: scene_path,
            table_top_z_m: table_top,
            rest_correction,
            object_volume_ratio: volume_ratio,
        },
        warnings: crate::geometry::hull::fuller_than_mesh(volume_ratio)
            .into_iter()
            .collect(),
    })
}

/// The keypoint map (`--keypoint-map`, else the built-in human hand's) and the retargeting
/// parameters: `--retarget`'s, else the map's own (checked), else the defaults.
fn map_and_params(
    options: &KeypointOptions,
    limits: &Limits,
) -> Result<(KeypointMap, keypoints::Params)> {
    let map = match &options.keypoint_map {
        Some(p) => crate::model::json::read_json::<KeypointMap>(p, limits)?,
        None => KeypointMap::human_hand(),
    };
    let params = match (&options.params, &map.retarget, &options.keypoint_map) {
        (Some(p), _, _) => p.clone(),
        (None, Some(p), Some(path)) => {
            p.check(path)?;
            p.clone()
        }
        _ => keypoints::Params::default(),
    };
    Ok((map, params))
}

/// The object's name in the demonstration: `target`'s, else its mesh file's stem, marked
/// `(mirrored)` when the recording was.
fn object_name(target: &Target, mirrored: bool) -> String {
    if let Some(n) = &target.object_name {
        return n.clone();
    }
    let stem = target
        .mesh
        .file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_else(|| "object".into());
    if mirrored {
        format!("{stem} (mirrored)")
    } else {
        stem
    }
}

/// The recording read, mirrored when it is a left hand (its object mesh too), and its object
/// placed in its scene ([`place_object`]) with the keypoints moved by the rest correction.
fn read_and_place(
    frames: &Path,
    options: &KeypointOptions,
    robot: &Robot,
    target: &Target,
    limits: &Limits,
) -> Result<(Recording, Placed)> {
    let mut rec = keypoints::read_keypoints_csv(frames, limits)?;
    let mesh = Mesh::load(&target.mesh, Vector3::repeat(1.0), limits)?;
    let (mut mesh, mesh_repair, hull_volumes_cm3) =
        solid_object(&target.mesh, mesh, options.hull_fallback)?;
    let mirrored = options.handedness == Handedness::Left;
    if mirrored {
        rec.mirror(rec.object[0].translation.x);
        mesh = keypoints::mirror_mesh(&mesh);
    }
    let hand_z0 = rec.keypoints[0][0].z;
    let placed = place_object(
        Placing {
            recording: frames,
            columns: ["obj_x..obj_qz", "wrist_z"],
            mesh,
            repair: mesh_repair,
            hull_volumes_cm3,
            mirrored,
            scene: options.scene.as_deref(),
            hand_z0,
        },
        &mut rec.object,
        robot,
        target,
        limits,
    )?;
    for (k, world) in rec.keypoints.iter_mut().zip(&placed.world) {
        for p in k.iter_mut() {
            *p = world * *p;
        }
    }
    Ok((rec, placed))
}

/// `dexwarp import --keypoints` (see the module docs and [`keypoints`]).
pub fn import_keypoints(
    frames: &Path,
    options: &KeypointOptions,
    target: &Target,
    limits: &Limits,
) -> Result<KeypointImport> {
    let clock = Instant::now();
    check_fps(frames, options.fps)?;
    check_mass(target)?;
    let robot = Robot::from_urdf_file(&target.robot, limits)?;
    let (map, params) = map_and_params(options, limits)?;
    let (rec, placed) = read_and_place(frames, options, &robot, target, limits)?;
    let mirrored = options.handedness == Handedness::Left;
    let Placed {
        mesh,
        geometry,
        supports,
        record: placement,
        mut warnings,
        ..
    } = placed;
    let hand = keypoints::retarget(
        &robot,
        &target.robot,
        &map,
        &rec,
        &geometry,
        &supports,
        &params,
    )?;
    warnings.extend(moved_before_touch(&rec.object, hand.touch));
    if hand.touch.is_none() {
        warnings.push(
            "the recorded hand never touches the object: the demonstration has no contact segment"
                .into(),
        );
    }
    let poses: Vec<super::Pose> = rec
        .object
        .iter()
        .zip(hand.wrists.iter().zip(&hand.joints))
        .map(|(o, (w, q))| (*o, *w, q.clone()))
        .collect();
    let target = Target {
        mesh: placement.mesh.clone(),
        object_name: Some(object_name(target, mirrored)),
        name: Some(demo_name(target)),
        ..target.clone()
    };
    let demo = finish_in(
        &target,
        &robot,
        options.fps,
        poses,
        Some(hand.contacts.clone()),
        Some(placement.scene.clone()),
        limits,
    )?;
    // Refined where the recording touches; a refinement that cannot run leaves the
    // retargeted hand and says why.
    let (demo, refinement) = if options.refine && hand.touch.is_some() {
        match refine_contacts(demo.clone(), &robot, &mesh, &placement.scene, limits) {
            Ok((d, r)) => (d, Some(r)),
            Err(e) => {
                warnings.push(format!("contact refinement not applied: {e}"));
                (demo, None)
            }
        }
    } else {
        (demo, None)
    };
    let penetration_mm = depths(
        &robot,
        &geometry,
        demo.frames.iter().map(|f| (&f.object, &f.wrist, &f.joints)),
    );
    let r = &hand.residuals;
    let import = KeypointImport {
        demo,
        recording: frames.to_path_buf(),
        handedness: options.handedness,
        mirrored,
        placement,
        refinement,
        retarget: params.clone(),
        touch_frames: hand.touch,
        warnings,
        residual_mean_mm: r.mean_mm.iter().sum::<f64>() / r.mean_mm.len().max(1) as f64,
        residual_max_mm: r.max_mm.iter().copied().fold(0.0, f64::max),
        max_penetration_mm: penetration_mm.iter().copied().fold(0.0, f64::max),
        time_s: clock.elapsed().as_secs_f64(),
        per_frame: PerFrame {
            residual_mean_mm: r.mean_mm.clone(),
            residual_max_mm: r.max_mm.clone(),
            residual_worst_keypoint: r.worst.clone(),
            penetration_mm,
        },
    };
    write_record(&target.out, &import)?;
    Ok(import)
}

/// Writes what an import did as `NAME.import.json` (`dexwarp.import/1`) beside `out`.
pub(crate) fn write_record(out: &Path, import: &impl Serialize) -> Result<()> {
    crate::model::json::write_json_atomic(
        &beside(out, "import.json"),
        &serde_json::json!({
            "format": "dexwarp.import/1",
            "import": import,
        }),
    )
}

/// Per frame (object pose, wrist pose, joints), how deep the hand is in the object [mm]: the
/// deepest of the hand's penetration probes in the object's distance field, the measure the IK
/// keeps out and `validate` reports. Not a contact query against the mesh's triangles: on the
/// shared take's open box that query, and the exact layer's pseudo-normal inside test it rests
/// on, put a LEAP link 50 mm above the box's rim 50 mm inside it (the field's ray parity: 52 mm
/// outside).
pub(crate) fn depths<'a>(
    robot: &Robot,
    geometry: &ObjectGeometry,
    frames: impl Iterator<Item = (&'a Isometry3<f64>, &'a Isometry3<f64>, &'a Vec<f64>)>,
) -> Vec<f64> {
    let mut links = robot.new_link_poses();
    frames
        .map(|(o, w, q)| {
            robot.forward_kinematics(w, q, &mut links);
            crate::robot::probes::deepest(robot, &links, &o.inverse(), &geometry.sdf)
                .map_or(0.0, |(d, _)| d * 1e3)
        })
        .collect()
}
