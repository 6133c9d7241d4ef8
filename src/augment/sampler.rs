//! The sampler: variation `i` of a spec, a function of `(seed, i)` only.
//!
//! Each variation draws from its own ChaCha8 stream seeded with [`super::variation_seed`],
//! in a fixed order (start, end, waypoints, retiming, threshold, barriers), so shards and
//! reruns agree sample by sample. The draws become an ordinary `dexwarp.config/1`:
//!
//! * start / end: see [`super::spec::PlaceJson`]; the resting height `h` is measured on the
//!   demonstration, `z = top + h`.
//! * waypoints: `k` uniform in `count`; input frames `t_j = c0 + (j+1)·s + J·(s/2)·u`,
//!   `s = (c1 − c0)/(k+1)`, `u ∈ [−1, 1)`, rounded and kept strictly increasing inside
//!   `(c0, c1)`; positions in a world box, or `x(t_j) + (1−λ)·Δ0 + λ·Δ1 + o` with
//!   `λ = (t_j − c0)/(c1 − c0)`, `Δ0`, `Δ1` the start and end displacements, `o` in the box.
//! * retiming: segment `j` between anchors lasts `max(1, round(f_j·d_j))` output frames,
//!   `f_j` drawn from `duration_factor` independently per segment (uniform, or log-uniform
//!   with `distribution: "log_uniform"`); the end's output frame is written as `end_t_new`.
//! * barriers: the `items`, each of `optional_items` with its probability, and primitives at
//!   `lerp(start, end, b) + o`, standing on the support below.
//!
//! A sample is rejected before running (and counted by reason) when its start or end is off
//! its support, a primitive has no support below, or an anchor (start, waypoint, end) lies in
//! an inflated barrier (the test the push-out itself refuses, [`Barrier::contains`]).

use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::spec::{
    BoxJson, FactorDistribution, PlaceJson, PrimitiveShape, PrimitivesJson, Range, RetimeJson,
    Spec, WaypointsJson,
};
use crate::model::PushoutMode;
use crate::model::config::{AxisAngleJson, CONFIG_FORMAT, ConfigFile, WaypointJson};
use crate::model::scene::{
    SCENE_FORMAT, SceneFile, SceneItem, SceneItemJson, ScenePoseJson, ShapeJson,
};
use crate::model::{Demo, Role, Scene};
use crate::warp::barrier::Barrier;
use crate::{Error, Limits, Result};

/// The level top face of a support (a box or a cylinder whose axis is vertical).
#[derive(Clone, Debug, PartialEq)]
pub struct TopFace {
    /// Item pose (its local z is the world's).
    pub pose: Isometry3<f64>,
    /// Height of the face [m].
    pub z: f64,
    /// Half extents of a box face, or the radius of a disc (`[r, r]`, `disc`).
    pub half: [f64; 2],
    pub disc: bool,
}

impl TopFace {
    /// True when the x-y of `p` lies on the face shrunk by `margin` [m].
    pub fn contains_xy(&self, p: &Vector3<f64>, margin: f64) -> bool {
        let l = self
            .pose
            .inverse_transform_point(&Point3::new(p.x, p.y, self.z));
        if self.disc {
            (l.x * l.x + l.y * l.y).sqrt() <= self.half[0] - margin
        } else {
            l.x.abs() <= self.half[0] - margin && l.y.abs() <= self.half[1] - margin
        }
    }
}

/// The top face of `item`, if it is a box or vertical cylinder.
pub fn top_face(item: &SceneItem) -> Option<TopFace> {
    let up = item.pose.rotation * Vector3::z();
    if up.z < 1.0 - 1e-9 {
        return None;
    }
    let (half, height, disc) = match item.shape {
        ShapeJson::Box { size } => ([size[0] / 2.0, size[1] / 2.0], size[2], false),
        ShapeJson::Cylinder { radius, length } => ([radius, radius], length, true),
        _ => return None,
    };
    Some(TopFace {
        pose: item.pose,
        z: (item.pose * Point3::new(0.0, 0.0, height / 2.0)).z,
        half,
        disc,
    })
}

/// The highest support top face under `p` (x-y on the face shrunk by `margin`, top at most
/// 2 cm above `p`): its name and height.
pub fn support_under(scene: &Scene, p: &Vector3<f64>, margin: f64) -> Option<(String, f64)> {
    scene
        .items
        .iter()
        .filter(|i| i.role == Role::Support)
        .filter_map(|i| top_face(i).map(|f| (i, f)))
        .filter(|(_, f)| f.z <= p.z + 0.02 && f.contains_xy(p, margin))
        .max_by(|a, b| a.1.z.total_cmp(&b.1.z))
        .map(|(i, f)| (i.name.clone(), f.z))
}

/// What the sampler needs to know about the demonstration and the scene, computed once.
#[derive(Debug)]
pub struct Context {
    /// Demonstration and scene, absolute (the sampled configs name them so).
    pub demo_path: PathBuf,
    pub scene_path: PathBuf,
    pub scene: Scene,
    /// Object positions of every input frame [m].
    pub positions: Vec<Vector3<f64>>,
    /// The contact segment `[c0, c1]`.
    pub c0: usize,
    pub c1: usize,
    /// Resting height of the object origin above its support at `c0` and `c1` [m].
    pub rest_start: Option<f64>,
    pub rest_end: Option<f64>,
    /// Bounding radius of the object [m].
    pub radius: f64,
    /// Scene barriers the spec may include, prepared for the conflict test.
    pub barriers: Vec<Barrier>,
    pub pushout: PushoutMode,
}

impl Context {
    /// Prepares the sampler for `spec` on `demo` (loaded from `demo_path`).
    pub fn new(spec: &Spec, demo: &Demo, demo_path: &Path, limits: &Limits) -> Result<Context> {
        let scene_path = match (&spec.scene, &demo.scene) {
            (Some(s), _) => s.clone(),
            (None, Some(s)) => s.clone(),
            (None, None) => {
                return Err(Error::invalid(
                    &spec.source,
                    "scene",
                    "is missing and the demonstration names no scene; expected a scene file relative to the spec",
                ));
            }
        };
        let scene = Scene::load(&scene_path, limits)?;
        spec.check_scene(&scene)?;
        let seg = demo.contact_segment().ok_or_else(|| {
            Error::invalid(
                &demo.source,
                "frames",
                "no frame has contact correspondences; a warp needs an in-contact segment",
            )
        })?;
        let (c0, c1) = (seg.start, seg.end);
        if let Some(w) = &spec.file.waypoints
            && w.count[1] as usize + 1 > c1.saturating_sub(c0)
        {
            return Err(Error::invalid(
                &spec.source,
                "waypoints.count",
                format!(
                    "allows {} waypoints; the contact segment {c0}..{c1} has room for at most {}",
                    w.count[1],
                    c1.saturating_sub(c0).saturating_sub(1)
                ),
            ));
        }
        let positions: Vec<Vector3<f64>> = demo
            .frames
            .iter()
            .map(|f| f.object.translation.vector)
            .collect();
        let rest = |key: &str,
                    p: &Vector3<f64>,
                    place: &Option<PlaceJson>|
         -> Result<Option<f64>> {
            if place.is_none() {
                return Ok(None);
            }
            match support_under(&scene, p, 0.0) {
                Some((_, top)) => Ok(Some(p.z - top)),
                None => Err(Error::invalid(
                    &spec.source,
                    key,
                    format!(
                        "cannot be placed on a support: the demonstration's object at {key} ({:.3}, {:.3}, {:.3}) is over no support of scene {:?}, so its resting height is unknown",
                        p.x, p.y, p.z, scene.name
                    ),
                )),
            }
        };
        let rest_start = rest("start", &positions[c0], &spec.file.start)?;
        let rest_end = rest("end", &positions[c1], &spec.file.end)?;
        let mesh = crate::geometry::Mesh::load(&demo.object.mesh, Vector3::repeat(1.0), limits)?;
        let radius = mesh.bounding_radius();
        let b = &spec.file.barriers;
        let mut barriers = Vec::new();
        for name in b.items.iter().chain(&b.optional_items) {
            let item = scene.item(name).expect("checked by check_scene");
            barriers.push(prepare(item, radius, &scene.source, limits)?);
        }
        let canon = |p: &Path| std::fs::canonicalize(p).map_err(|e| Error::read(p, e));
        Ok(Context {
            demo_path: canon(demo_path)?,
            scene_path: canon(&scene_path)?,
            scene,
            positions,
            c0,
            c1,
            rest_start,
            rest_end,
            radius,
            barriers,
            pushout: spec.file.params.pushout,
        })
    }

    fn barrier(&self, name: &str) -> Option<&Barrier> {
        self.barriers.iter().find(|b| b.name == name)
    }
}

fn prepare(item: &SceneItem, radius: f64, scene: &Path, limits: &Limits) -> Result<Barrier> {
    let pts = item.collision_shape(scene, limits)?.hull_points();
    Barrier::from_points(&item.name, &pts, radius).ok_or_else(|| {
        Error::invalid(
            scene,
            format!("items[{:?}]", item.name),
            "has a flat or degenerate convex hull; give it a thickness",
        )
    })
}

/// Why a sample was not run.
#[derive(Clone, Debug, PartialEq)]
pub struct Rejection {
    /// Stable key for counting (`start_off_support`, `waypoint_in_barrier`, ...).
    pub reason: &'static str,
    /// The same in words, with the values.
    pub detail: String,
}

/// One sampled variation.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    pub index: u64,
    pub id: String,
    /// The config to run; its `scene` is `scene.json` next to it when there are primitives.
    pub config: ConfigFile,
    /// Primitive barriers added to the scene.
    pub primitives: Vec<SceneItemJson>,
    /// Duration factor of each segment (start→w1, ..., wk→end).
    pub duration_factors: Vec<f64>,
    /// Output frame of each anchor (start, waypoints, end): segment `j` is the output frames
    /// `anchors_t_new[j]..anchors_t_new[j + 1]`.
    pub anchors_t_new: Vec<usize>,
    pub rejection: Option<Rejection>,
}

impl Sample {
    /// The scene file of this sample (the base scene plus the primitives), when it has any.
    pub fn scene_file(&self, ctx: &Context) -> Option<SceneFile> {
        if self.primitives.is_empty() {
            return None;
        }
        let mut items: Vec<SceneItemJson> = ctx.scene.items.iter().map(item_json).collect();
        items.extend(self.primitives.iter().cloned());
        Some(SceneFile {
            format: SCENE_FORMAT.into(),
            name: format!("{}+{}", ctx.scene.name, self.id),
            items,
        })
    }
}

fn item_json(i: &SceneItem) -> SceneItemJson {
    let q = i.pose.rotation;
    let t = i.pose.translation.vector;
    let shape = match &i.shape {
        ShapeJson::Mesh { path, scale } => ShapeJson::Mesh {
            path: std::fs::canonicalize(path).unwrap_or_else(|_| path.clone()),
            scale: *scale,
        },
        s => s.clone(),
    };
    SceneItemJson {
        name: i.name.clone(),
        role: i.role,
        pose: ScenePoseJson {
            position: [t.x, t.y, t.z],
            orientation: [q.w, q.i, q.j, q.k],
        },
        shape,
    }
}

/// A uniform draw in `[lo, hi)` (exactly `lo` when `lo == hi`).
fn uniform(rng: &mut ChaCha8Rng, r: Range) -> f64 {
    let u: f64 = rng.random();
    r[0] + (r[1] - r[0]) * u
}

fn uniform_int(rng: &mut ChaCha8Rng, r: [u32; 2]) -> usize {
    let u: f64 = rng.random();
    let n = (r[1] - r[0] + 1) as f64;
    (r[0] as usize + (u * n) as usize).min(r[1] as usize)
}

fn uniform_box(rng: &mut ChaCha8Rng, b: &BoxJson) -> Vector3<f64> {
    Vector3::from_fn(|a, _| uniform(rng, [b.min[a], b.max[a]]))
}

/// Samples variation `index` of `spec` with `seed`.
pub fn sample(spec: &Spec, ctx: &Context, seed: u64, index: u64) -> Sample {
    let mut rng = ChaCha8Rng::seed_from_u64(super::variation_seed(seed, index));
    let f = &spec.file;
    let mut rejection: Option<Rejection> = None;
    let (c0, c1) = (ctx.c0, ctx.c1);

    // Start and end.
    let start = place(&mut rng, ctx, "start", &f.start, ctx.rest_start);
    let end = place(&mut rng, ctx, "end", &f.end, ctx.rest_end);
    for (p, key) in [(&start, "start_off_support"), (&end, "end_off_support")] {
        if let Some((q, false, which)) = p {
            reject(
                &mut rejection,
                key,
                format!(
                    "{which} ({:.3}, {:.3}, {:.3}) does not rest on a support",
                    q.x, q.y, q.z
                ),
            );
        }
    }
    let start = start.map(|s| s.0);
    let end = end.map(|s| s.0);
    let s0 = start.unwrap_or(ctx.positions[c0]);
    let s1 = end.unwrap_or(ctx.positions[c1]);
    let (d0, d1) = (s0 - ctx.positions[c0], s1 - ctx.positions[c1]);

    // Waypoints: input frames, positions, rotations.
    let (ts, positions, rotations) = match &f.waypoints {
        Some(w) => waypoints(&mut rng, w, ctx, d0, d1),
        None => (Vec::new(), Vec::new(), Vec::new()),
    };

    // Retiming: one factor per segment between anchors.
    let (factors, t_new) = retime(&mut rng, &f.retime, c0, c1, &ts);
    let threshold = f.threshold_mm.map(|r| uniform(&mut rng, r));

    // Barriers.
    let b = &f.barriers;
    let mut barrier_names = b.items.clone();
    for name in &b.optional_items {
        let u: f64 = rng.random();
        if u < b.optional_probability {
            barrier_names.push(name.clone());
        }
    }
    let id = super::sample_id(index);
    let primitives = match &b.primitives {
        Some(p) => primitives(&mut rng, p, ctx, s0, s1, &mut rejection),
        None => Vec::new(),
    };

    // Feasibility: no anchor inside an inflated barrier.
    let anchors = anchors(s0, &positions, s1);
    check_barriers(ctx, &anchors, &barrier_names, &primitives, &mut rejection);
    barrier_names.extend(primitives.iter().map(|p| p.name.clone()));

    let mut params = f.params.clone();
    if let Some(t) = threshold {
        params.threshold_mm = t;
    }
    params.end_t_new = Some(*t_new.last().expect("end anchor") as f64);
    let waypoints = ts
        .iter()
        .enumerate()
        .map(|(j, &t)| WaypointJson {
            position: positions[j].into(),
            rotation: rotations[j],
            t: t as f64,
            t_new: t_new[j + 1] as f64,
        })
        .collect();
    let config = ConfigFile {
        format: CONFIG_FORMAT.into(),
        description: None,
        name: format!("{}_{id}", f.name),
        demo: ctx.demo_path.clone(),
        scene: if primitives.is_empty() {
            ctx.scene_path.clone()
        } else {
            PathBuf::from("scene.json")
        },
        waypoints,
        barriers: barrier_names,
        start: start.map(Into::into),
        end: end.map(Into::into),
        params,
    };
    Sample {
        index,
        id,
        config,
        primitives,
        duration_factors: factors,
        anchors_t_new: t_new,
        rejection,
    }
}

/// Records a rejection unless an earlier check already rejected the sample (the first
/// reason is the one counted).
fn reject(rejection: &mut Option<Rejection>, reason: &'static str, detail: String) {
    if rejection.is_none() {
        *rejection = Some(Rejection { reason, detail });
    }
}

/// Draws the start or end (`which`) placed by `p`: the point, whether it rests on a
/// support, and `which`. `None` when the spec does not move it.
fn place(
    rng: &mut ChaCha8Rng,
    ctx: &Context,
    which: &str,
    p: &Option<PlaceJson>,
    rest: Option<f64>,
) -> Option<(Vector3<f64>, bool, String)> {
    let p = p.as_ref()?;
    let (point, ok) = match (&p.support, &p.bbox) {
        (Some(name), _) => {
            let item = ctx.scene.item(name).expect("checked by check_scene");
            let face = top_face(item).expect("checked by check_scene");
            let (lo, hi) = match &p.region {
                Some(r) => (r.min, r.max),
                None => {
                    // The face shrunk by the margin (a square inside a disc).
                    let shrink = if face.disc {
                        std::f64::consts::FRAC_1_SQRT_2
                    } else {
                        1.0
                    };
                    let ex = ((face.half[0] - p.margin_m) * shrink).max(0.0);
                    let ey = ((face.half[1] - p.margin_m) * shrink).max(0.0);
                    let c = face.pose.translation.vector;
                    ([c.x - ex, c.y - ey], [c.x + ex, c.y + ey])
                }
            };
            let x = uniform(rng, [lo[0], hi[0]]);
            let y = uniform(rng, [lo[1], hi[1]]);
            let point = Vector3::new(x, y, face.z + rest.unwrap_or(0.0));
            (point, face.contains_xy(&point, p.margin_m))
        }
        (None, Some(b)) => {
            let point = uniform_box(rng, b);
            let ok = support_under(&ctx.scene, &point, p.margin_m).is_some_and(|(_, top)| {
                (point.z - top - rest.unwrap_or(0.0)).abs() <= p.tolerance_m
            });
            (point, ok)
        }
        (None, None) => unreachable!("checked by Spec::from_file"),
    };
    Some((point, ok, which.to_string()))
}

/// Draws the waypoints: their input frames, positions and rotations. `d0`, `d1` are the
/// start and end displacements.
fn waypoints(
    rng: &mut ChaCha8Rng,
    w: &WaypointsJson,
    ctx: &Context,
    d0: Vector3<f64>,
    d1: Vector3<f64>,
) -> (Vec<usize>, Vec<Vector3<f64>>, Vec<Option<AxisAngleJson>>) {
    let (c0, c1) = (ctx.c0, ctx.c1);
    let mut ts: Vec<usize> = Vec::new();
    let mut positions: Vec<Vector3<f64>> = Vec::new();
    let mut rotations: Vec<Option<AxisAngleJson>> = Vec::new();
    let k = uniform_int(rng, w.count);
    let spacing = (c1 - c0) as f64 / (k + 1) as f64;
    for j in 0..k {
        let u = uniform(rng, [-1.0, 1.0]);
        let t = c0 as f64 + spacing * (j + 1) as f64 + w.t_jitter * spacing / 2.0 * u;
        let lo = ts.last().map_or(c0 + 1, |p| p + 1);
        let hi = c1 - (k - j);
        ts.push((t.round() as usize).clamp(lo, hi));
    }
    for &t in &ts {
        let p = match (&w.position.offset, &w.position.bbox) {
            (Some(o), _) => {
                let lambda = (t - c0) as f64 / (c1 - c0) as f64;
                ctx.positions[t] + (1.0 - lambda) * d0 + lambda * d1 + uniform_box(rng, o)
            }
            (None, Some(b)) => uniform_box(rng, b),
            (None, None) => unreachable!("checked by Spec::from_file"),
        };
        positions.push(p);
        rotations.push(w.rotation.as_ref().map(|r| {
            let a = uniform_int(rng, [0, r.axes.len() as u32 - 1]);
            AxisAngleJson {
                axis: r.axes[a],
                angle: uniform(rng, r.angle_rad),
            }
        }));
    }
    (ts, positions, rotations)
}

/// Draws the duration factor of each segment between the anchors (`c0`, the waypoint
/// frames `ts`, `c1`) and returns the factors and the anchors' output frames.
fn retime(
    rng: &mut ChaCha8Rng,
    retime: &Option<RetimeJson>,
    c0: usize,
    c1: usize,
    ts: &[usize],
) -> (Vec<f64>, Vec<usize>) {
    let anchors_t: Vec<usize> = std::iter::once(c0)
        .chain(ts.iter().copied())
        .chain(std::iter::once(c1))
        .collect();
    let factors: Vec<f64> = (0..anchors_t.len() - 1)
        .map(|_| {
            retime.as_ref().map_or(1.0, |r| match r.distribution {
                FactorDistribution::Uniform => uniform(rng, r.duration_factor),
                FactorDistribution::LogUniform => {
                    let [lo, hi] = r.duration_factor;
                    uniform(rng, [lo.ln(), hi.ln()]).exp()
                }
            })
        })
        .collect();
    let mut t_new = Vec::with_capacity(anchors_t.len());
    t_new.push(c0);
    for (j, w) in anchors_t.windows(2).enumerate() {
        let d = ((w[1] - w[0]) as f64 * factors[j]).round().max(1.0) as usize;
        t_new.push(t_new[j] + d);
    }
    (factors, t_new)
}

/// Draws the primitive barriers between `s0` and `s1`, each standing on the support below
/// when `p.on_support` (rejecting the sample when there is none).
fn primitives(
    rng: &mut ChaCha8Rng,
    p: &PrimitivesJson,
    ctx: &Context,
    s0: Vector3<f64>,
    s1: Vector3<f64>,
    rejection: &mut Option<Rejection>,
) -> Vec<SceneItemJson> {
    let mut primitives = Vec::new();
    let n = uniform_int(rng, p.count);
    for m in 0..n {
        let along = uniform(rng, p.between);
        let offset = p
            .offset
            .as_ref()
            .map_or(Vector3::zeros(), |o| uniform_box(rng, o));
        let yaw = p.yaw_rad.map_or(0.0, |y| uniform(rng, y));
        let (shape, height) = match p.shape {
            PrimitiveShape::Box => {
                let s = uniform_box(rng, p.size.as_ref().expect("checked"));
                (
                    ShapeJson::Box {
                        size: [s.x, s.y, s.z],
                    },
                    s.z,
                )
            }
            PrimitiveShape::Cylinder => {
                let radius = uniform(rng, p.radius_m.expect("checked"));
                let length = uniform(rng, p.length_m.expect("checked"));
                (ShapeJson::Cylinder { radius, length }, length)
            }
        };
        let mut centre = s0 + along * (s1 - s0) + offset;
        if p.on_support {
            match support_under(&ctx.scene, &centre, 0.0) {
                Some((_, top)) => centre.z = top + height / 2.0,
                None => reject(
                    rejection,
                    "barrier_off_support",
                    format!(
                        "primitive barrier {m} at ({:.3}, {:.3}) has no support below",
                        centre.x, centre.y
                    ),
                ),
            }
        }
        let q = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw);
        primitives.push(SceneItemJson {
            name: format!("augment_barrier_{m}"),
            role: Role::Barrier,
            pose: ScenePoseJson {
                position: [centre.x, centre.y, centre.z],
                orientation: [q.w, q.i, q.j, q.k],
            },
            shape,
        });
    }
    primitives
}

/// The anchors of a sample, named as in the rejections: start, waypoints, end.
fn anchors(
    s0: Vector3<f64>,
    positions: &[Vector3<f64>],
    s1: Vector3<f64>,
) -> Vec<(String, Vector3<f64>)> {
    let mut anchors: Vec<(String, Vector3<f64>)> = vec![("start".into(), s0)];
    anchors.extend(
        positions
            .iter()
            .enumerate()
            .map(|(j, p)| (format!("waypoints[{j}]"), *p)),
    );
    anchors.push(("end".into(), s1));
    anchors
}

/// Rejects the sample when an anchor lies inside an inflated barrier: the scene barriers
/// `barrier_names`, then the primitives.
fn check_barriers(
    ctx: &Context,
    anchors: &[(String, Vector3<f64>)],
    barrier_names: &[String],
    primitives: &[SceneItemJson],
    rejection: &mut Option<Rejection>,
) {
    let mut check = |name: &str, barrier: &Barrier| {
        for (what, p) in anchors {
            if barrier.contains(&Point3::from(*p), ctx.pushout) {
                let reason = match what.as_str() {
                    "start" => "start_in_barrier",
                    "end" => "end_in_barrier",
                    _ => "waypoint_in_barrier",
                };
                reject(
                    rejection,
                    reason,
                    format!("{what} is inside the inflated barrier {name:?}"),
                );
            }
        }
    };
    for name in barrier_names {
        if let Some(barrier) = ctx.barrier(name) {
            check(name, barrier);
        }
    }
    for item in primitives {
        let validated = SceneItem {
            name: item.name.clone(),
            role: item.role,
            pose: Isometry3::from_parts(
                Translation3::from(Vector3::from(item.pose.position)),
                UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                    item.pose.orientation[0],
                    item.pose.orientation[1],
                    item.pose.orientation[2],
                    item.pose.orientation[3],
                )),
            ),
            shape: item.shape.clone(),
        };
        let pts = validated
            .collision_shape(Path::new("scene"), &Limits::default())
            .map(|shape| shape.hull_points())
            .unwrap_or_default();
        if let Some(barrier) = Barrier::from_points(&item.name, &pts, ctx.radius) {
            check(&item.name, &barrier);
        }
    }
}
