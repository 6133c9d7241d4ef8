//! The geometry one player shows, computed here and handed to the page as one JSON value
//! (`dexwarp.player/1`): the scene's items, the object mesh, every link's collision shapes,
//! and per frame the object pose and every link pose through our forward kinematics, for the
//! output trajectory and the original it was warped from.
//!
//! Arrays are compact: poses are 7 `int16` each (position on a per-trajectory grid of about
//! 0.05 mm for a 3 m scene, quaternion × 32767), meshes `int16` vertices on their own grid
//! with `uint32` triangles, all little-endian in base64 ([`super::encode`]). A 900-frame
//! human-hand trajectory with its original comes to about 0.5 MB.
//!
//! Per output frame, `penetration_mm` is the deepest penetration probe of the output hand in
//! the object's distance field, the measure of the physics check at the trajectory's poses,
//! so the frames the page marks red are those the physics verdict counts over the limit.
//!
//! Correspondences are stored once per frame of the trajectory they come from (the original
//! when there is one) in their link and object frames, at most [`MAX_CONTACTS_SHOWN`] per
//! frame (evenly strided); output frame `f` shows those of its source frame `t*`
//! (`frames.csv` `source_frame`), placed by the output's link and object poses, so each
//! segment's length is that frame's correspondence error.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use nalgebra::{Isometry3, Vector3};
use serde_json::{Value, json};

use super::encode::{self, Grid};
use crate::geometry::Mesh;
use crate::geometry::shape::ShapeKind;
use crate::model::config::WarpConfig;
use crate::model::demo::{Demo, Frame};
use crate::model::frames::FrameRow;
use crate::model::report::Report;
use crate::model::scene::{Role, Scene, ShapeJson};
use crate::robot::Robot;
use crate::{Error, Limits, Result};

/// The `format` value of a player's data.
pub const PLAYER_FORMAT: &str = "dexwarp.player/1";
/// Correspondences drawn per frame at most (evenly strided over the frame's list).
pub const MAX_CONTACTS_SHOWN: usize = 32;
/// Triangles drawn per mesh at most (larger meshes are thinned by a stride).
pub const MAX_MESH_TRIANGLES: usize = 20_000;
/// Frames of one trajectory a player accepts (about 40 MB of page data for a human hand).
pub const MAX_FRAMES: usize = 50_000;
/// Hand-object penetration limit when the report does not state it [mm] (physics default).
const DEFAULT_PENETRATION_LIMIT_MM: f64 = 5.0;

/// Files read once per report page: the same demonstration, robot, mesh and scene serve
/// every trajectory that names them.
#[derive(Debug, Default)]
pub struct Cache {
    demos: HashMap<PathBuf, Arc<Demo>>,
    robots: HashMap<PathBuf, Arc<Robot>>,
    meshes: HashMap<PathBuf, Arc<Mesh>>,
    scenes: HashMap<PathBuf, Arc<Scene>>,
}

impl Cache {
    fn robot(&mut self, path: &Path, limits: &Limits) -> Result<Arc<Robot>> {
        if let Some(r) = self.robots.get(path) {
            return Ok(r.clone());
        }
        let r = Arc::new(Robot::from_urdf_file(path, limits)?);
        self.robots.insert(path.to_path_buf(), r.clone());
        Ok(r)
    }

    /// A demonstration with its joints in the robot's order (see `Demo::check_robot`).
    fn demo(&mut self, path: &Path, limits: &Limits) -> Result<Arc<Demo>> {
        if let Some(d) = self.demos.get(path) {
            return Ok(d.clone());
        }
        let mut d = Demo::load(path, limits)?;
        let robot = self.robot(&d.robot.clone(), limits)?;
        d.check_robot(&robot)?;
        let d = Arc::new(d);
        // Outputs are read once each; only inputs (shared by many outputs) are kept.
        if d.timewarp.is_none() {
            self.demos.insert(path.to_path_buf(), d.clone());
        }
        Ok(d)
    }

    fn mesh(&mut self, path: &Path, scale: Vector3<f64>, limits: &Limits) -> Result<Arc<Mesh>> {
        if scale == Vector3::repeat(1.0)
            && let Some(m) = self.meshes.get(path)
        {
            return Ok(m.clone());
        }
        let m = Arc::new(Mesh::load(path, scale, limits)?);
        if scale == Vector3::repeat(1.0) {
            self.meshes.insert(path.to_path_buf(), m.clone());
        }
        Ok(m)
    }

    fn scene(&mut self, path: &Path, limits: &Limits) -> Result<Arc<Scene>> {
        if let Some(s) = self.scenes.get(path) {
            return Ok(s.clone());
        }
        let s = Arc::new(Scene::load(path, limits)?);
        self.scenes.insert(path.to_path_buf(), s.clone());
        Ok(s)
    }
}

/// The output demonstration of a run folder (`<name>.demo.json`), if it has one.
pub fn output_demo(dir: &Path) -> Option<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().ends_with(".demo.json"))
        })
        .collect();
    v.sort();
    v.into_iter().next()
}

fn read_rows(path: &Path) -> Option<Vec<FrameRow>> {
    let mut r = csv::Reader::from_path(path).ok()?;
    r.deserialize()
        .collect::<std::result::Result<Vec<FrameRow>, _>>()
        .ok()
}

/// The player data of the run in `dir` whose report is `report` (see the module docs).
/// Fails when the trajectory cannot be drawn (its demonstration, robot or mesh missing).
pub fn trajectory(
    dir: &Path,
    report: &Report,
    title: &str,
    cache: &mut Cache,
    limits: &Limits,
) -> Result<Value> {
    let (primary, original) = demos(dir, report, cache, limits)?;
    let robot = cache.robot(&primary.robot, limits)?;
    let drawn: Vec<usize> = (0..robot.link_count())
        .filter(|&l| !robot.links()[l].collision.is_empty())
        .collect();
    let mut index_of = vec![-1i16; robot.link_count()];
    for (k, &l) in drawn.iter().enumerate() {
        index_of[l] = k as i16;
    }

    // Poses of every frame, then one grid for all of them.
    let mut buf = robot.new_link_poses();
    let mut track = |d: &Demo| -> Vec<Isometry3<f64>> {
        let mut v = Vec::with_capacity(d.frames.len() * (1 + drawn.len()));
        for f in &d.frames {
            robot.forward_kinematics(&f.wrist, &f.joints, &mut buf);
            v.push(f.object);
            v.extend(drawn.iter().map(|&l| buf[l]));
        }
        v
    };
    let primary_poses = track(&primary);
    let original_poses = original.as_deref().map(&mut track);
    let grid = Grid::around(
        primary_poses
            .iter()
            .chain(original_poses.iter().flatten())
            .map(|p| &p.translation.vector),
    );
    let encode_track = |poses: &[Isometry3<f64>]| {
        let mut q = Vec::with_capacity(poses.len() * 7);
        for p in poses {
            encode::pose(&grid, p, &mut q);
        }
        encode::i16s(&q)
    };

    let rows = read_rows(&dir.join("frames.csv")).filter(|r| r.len() == primary.frames.len());
    let n = primary.frames.len();
    let contact_source: &Demo = original.as_deref().unwrap_or(&primary);
    let source: Vec<u32> = match (&rows, &original) {
        (Some(rows), Some(o)) => rows
            .iter()
            .map(|r| r.source_frame.min(o.frames.len().saturating_sub(1)) as u32)
            .collect(),
        _ => (0..n as u32).collect(),
    };
    let in_contact: Vec<u32> = match &rows {
        Some(rows) => rows.iter().map(|r| u32::from(r.in_contact)).collect(),
        None => primary
            .frames
            .iter()
            .map(|f| u32::from(!f.contacts.is_empty()))
            .collect(),
    };
    let object = cache.mesh(&primary.object.mesh, Vector3::repeat(1.0), limits)?;
    let penetration = penetration_mm(&robot, &primary, &object);
    let limit_mm = report
        .provenance
        .as_ref()
        .and_then(|p| p.parameters.get("physics"))
        .and_then(|p| p.get("max_hand_object_penetration_m"))
        .and_then(Value::as_f64)
        .map_or(DEFAULT_PENETRATION_LIMIT_MM, |m| m * 1000.0);
    let waypoints = waypoints_json(report, limits);
    let scene = scene_json(&primary, cache, limits)?;
    let links = links_json(&robot, &drawn);
    let (contact_counts, contacts, contact_grid) = contacts_json(&contact_source.frames, |name| {
        robot
            .link_id(name)
            .map(|id| index_of[id.index()])
            .filter(|&k| k >= 0)
    });
    let verdict = report.physics.as_ref().map(|p| p.verdict.clone());
    let reasons = report
        .physics
        .as_ref()
        .map(|p| p.reasons.clone())
        .unwrap_or_default();
    Ok(json!({
        "format": PLAYER_FORMAT,
        "title": title,
        "fps": primary.fps,
        "n": n,
        "n_original": original.as_ref().map_or(0, |o| o.frames.len()),
        "grid": grid.json(),
        "links": links,
        "object": mesh_json(&object),
        "object_name": primary.object.name,
        "primary": encode_track(&primary_poses),
        "original": original_poses.as_deref().map(encode_track),
        "source": encode::u32s(&source),
        "in_contact": encode::u32s(&in_contact),
        "contacts": {"count": encode::u32s(&contact_counts), "data": encode::i16s(&contacts), "grid": contact_grid.json()},
        "penetration_mm": penetration,
        "penetration_limit_mm": limit_mm,
        "tau": primary.timewarp.as_ref().map(|t| t.iter().map(|x| (x * 100.0).round() / 100.0).collect::<Vec<f64>>()),
        "waypoints": waypoints,
        "scene": scene,
        "verdict": verdict,
        "reasons": reasons,
    }))
}

/// The path of the report's provenance input `role` (`demo`, `config`, ...).
fn input(report: &Report, role: &str) -> Option<PathBuf> {
    let inputs = report.provenance.as_ref().map(|p| &p.inputs);
    inputs
        .and_then(|i| i.get(role))
        .map(|f| PathBuf::from(&f.path))
}

/// The trajectory shown (the folder's output demonstration, else the report's input) and
/// the original it was warped from, when it has the same robot. Fails when there is no
/// demonstration or one has more than [`MAX_FRAMES`] frames.
fn demos(
    dir: &Path,
    report: &Report,
    cache: &mut Cache,
    limits: &Limits,
) -> Result<(Arc<Demo>, Option<Arc<Demo>>)> {
    let (primary, original) = match output_demo(dir) {
        Some(out) => (
            cache.demo(&out, limits)?,
            input(report, "demo").and_then(|p| cache.demo(&p, limits).ok()),
        ),
        None => {
            let Some(p) = input(report, "demo") else {
                return Err(Error::invalid(
                    &dir.join("report.json"),
                    "provenance.inputs.demo",
                    "the folder has no *.demo.json and the report names no demonstration",
                ));
            };
            (cache.demo(&p, limits)?, None)
        }
    };
    let same = |a: &Path, b: &Path| {
        a == b
            || std::fs::canonicalize(a)
                .ok()
                .is_some_and(|x| std::fs::canonicalize(b).ok() == Some(x))
    };
    let original = original.filter(|o| same(&o.robot, &primary.robot));
    for d in std::iter::once(&primary).chain(original.as_ref()) {
        if d.frames.len() > MAX_FRAMES {
            return Err(Error::invalid(
                &d.source,
                "frames",
                format!(
                    "has {} frames; the player draws at most {MAX_FRAMES}",
                    d.frames.len()
                ),
            ));
        }
    }
    Ok((primary, original))
}

/// The output hand's deepest probe in the object per frame [mm], as the physics check
/// measures it at the trajectory's poses (frames.csv has the IK's, before smoothing).
fn penetration_mm(robot: &Robot, primary: &Demo, object: &Mesh) -> Vec<Value> {
    match crate::geometry::object_sdf(object) {
        Some(sdf) => {
            let mut poses = robot.new_link_poses();
            primary
                .frames
                .iter()
                .map(|f| {
                    robot.forward_kinematics(&f.wrist, &f.joints, &mut poses);
                    let d = crate::robot::probes::deepest(robot, &poses, &f.object.inverse(), &sdf)
                        .map_or(0.0, |(d, _)| d * 1000.0);
                    json!((d * 100.0).round() / 100.0)
                })
                .collect()
        }
        None => Vec::new(),
    }
}

/// The waypoints, new start and new end of the run's config, as labelled points.
fn waypoints_json(report: &Report, limits: &Limits) -> Vec<Value> {
    input(report, "config")
        .and_then(|c| WarpConfig::load(&c, limits).ok())
        .map(|c| {
            let mut w: Vec<Value> = c
                .waypoints
                .iter()
                .map(|w| json!({"p": [w.position.x, w.position.y, w.position.z], "t_new": w.t_new, "label": format!("waypoint t_new {}", w.t_new)}))
                .collect();
            if let Some(s) = c.start {
                w.push(json!({"p": [s.x, s.y, s.z], "t_new": null, "label": "new start"}));
            }
            if let Some(e) = c.end {
                w.push(json!({"p": [e.x, e.y, e.z], "t_new": null, "label": "new end"}));
            }
            w
        })
        .unwrap_or_default()
}

/// The scene's items (mesh items with their meshes), barriers the trajectory avoids marked
/// active.
fn scene_json(primary: &Demo, cache: &mut Cache, limits: &Limits) -> Result<Vec<Value>> {
    Ok(match &primary.scene {
        Some(path) => {
            let s = cache.scene(path, limits)?;
            let mut items = Vec::new();
            for it in &s.items {
                let shape = match &it.shape {
                    ShapeJson::Mesh { path, scale } => {
                        let m = cache.mesh(path, Vector3::from(*scale), limits)?;
                        json!({"type": "mesh", "mesh": mesh_json(&m)})
                    }
                    other => serde_json::to_value(other).unwrap_or(Value::Null),
                };
                items.push(json!({
                    "name": it.name,
                    "role": it.role.as_str(),
                    "active": it.role == Role::Barrier && primary.barriers.contains(&it.name),
                    "pose": encode::pose_json(&it.pose),
                    "shape": shape,
                }));
            }
            items
        }
        None => Vec::new(),
    })
}

/// The collision shapes of the `drawn` links, in their link frames.
fn links_json(robot: &Robot, drawn: &[usize]) -> Vec<Value> {
    drawn
        .iter()
        .map(|&l| {
            let link = &robot.links()[l];
            let shapes: Vec<Value> = link
                .collision
                .iter()
                .map(|c| {
                    let mut s = match &c.kind {
                        ShapeKind::Box { size } => {
                            json!({"type": "box", "size": [size.x, size.y, size.z]})
                        }
                        ShapeKind::Sphere { radius } => json!({"type": "sphere", "radius": radius}),
                        ShapeKind::Cylinder { radius, length } => {
                            json!({"type": "cylinder", "radius": radius, "length": length})
                        }
                        ShapeKind::Capsule { radius, length } => {
                            json!({"type": "capsule", "radius": radius, "length": length})
                        }
                        ShapeKind::Mesh { mesh, .. } => {
                            json!({"type": "mesh", "mesh": mesh_json(mesh)})
                        }
                    };
                    s["pose"] = encode::pose_json(&c.origin);
                    s
                })
                .collect();
            json!({"name": link.name, "shapes": shapes})
        })
        .collect()
}

/// A mesh as `{v, t, grid}`: `int16` vertices on their own grid, `uint32` triangles (every
/// k-th triangle when there are more than [`MAX_MESH_TRIANGLES`]).
fn mesh_json(m: &Mesh) -> Value {
    let coords: Vec<Vector3<f64>> = m.vertices.iter().map(|p| p.coords).collect();
    let grid = Grid::around(coords.iter());
    let mut v = Vec::with_capacity(coords.len() * 3);
    for p in &coords {
        grid.quantize(p, &mut v);
    }
    let stride = m.triangles.len().div_ceil(MAX_MESH_TRIANGLES).max(1);
    let t: Vec<u32> = m
        .triangles
        .iter()
        .step_by(stride)
        .flat_map(|t| t.iter().copied())
        .collect();
    json!({"v": encode::i16s(&v), "t": encode::u32s(&t), "grid": grid.json(), "thinned": stride > 1})
}

/// Correspondences per frame: counts, then `(link, hand xyz, object xyz)` as `int16` on one
/// local grid (links without collision shapes are not drawn, nor their contacts).
fn contacts_json(
    frames: &[Frame],
    link_index: impl Fn(&str) -> Option<i16>,
) -> (Vec<u32>, Vec<i16>, Grid) {
    let shown = |f: &Frame| -> Vec<usize> {
        let n = f.contacts.len();
        let step = n.div_ceil(MAX_CONTACTS_SHOWN).max(1);
        (0..n).step_by(step).collect()
    };
    let mut pts = Vec::new();
    for f in frames {
        for k in shown(f) {
            pts.push(f.contacts[k].hand_point.coords);
            pts.push(f.contacts[k].object_point.coords);
        }
    }
    let grid = Grid::around(pts.iter());
    let (mut counts, mut data) = (Vec::with_capacity(frames.len()), Vec::new());
    for f in frames {
        let mut c = 0;
        for k in shown(f) {
            let ct = &f.contacts[k];
            let Some(l) = link_index(&ct.link) else {
                continue;
            };
            data.push(l);
            encode::point(&grid, &ct.hand_point, &mut data);
            encode::point(&grid, &ct.object_point, &mut data);
            c += 1;
        }
        counts.push(c);
    }
    (counts, data, grid)
}

/// The data of one player as a script for the page: `file://` pages cannot fetch JSON in
/// Chromium, but they can load a script, which hands the value to the player.
pub fn script(id: &str, data: &Value) -> String {
    format!(
        "dexwarpPlayer.loaded({}, {});\n",
        serde_json::to_string(id).unwrap_or_else(|_| "\"\"".into()),
        data
    )
}
