//! The variation spec: the `dexwarp.variations/1` file format.
//!
//! A spec says what to sample for every variation of one demonstration, in world units
//! (metres, radians, frames): the start and end of the object (a region on a named support,
//! or a box), the number of waypoints and their positions (a box, or offsets around the
//! original path), their rotations (an axis from a list, an angle range), the retiming (a
//! duration factor per segment), the barriers (scene items always or sometimes included, and
//! primitive barriers placed between start and end), and the IK threshold. Every range is
//! `[lo, hi]` with `lo <= hi` and is sampled uniformly; `[x, x]` fixes a value.
//! Validation names the file, the JSON path and what was expected.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::model::WarpParams;
use crate::model::config::{CONFIG_FORMAT, ConfigFile, WarpConfig};
use crate::model::json::{self, FieldCheck};
use crate::model::scene::{Role, Scene};
use crate::{Error, Limits, Result};

/// The `format` value of a variation spec.
pub const VARIATIONS_FORMAT: &str = "dexwarp.variations/1";

/// A closed interval `[lo, hi]`, sampled uniformly.
pub type Range = [f64; 2];

/// An axis-aligned box in the world [m].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxJson {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

/// A rectangle in the world's x-y plane [m].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RectJson {
    pub min: [f64; 2],
    pub max: [f64; 2],
}

/// Where a new start or end is sampled: exactly one of `support` or `box`.
///
/// * `support`: x-y uniform in `region` (default: the support's top face shrunk by `margin_m`,
///   for faces aligned with the world axes; a square inside a disc), z = the top of the
///   support plus the object's resting height in the demonstration (its height above the
///   support it rests on at the first, resp. last, in-contact frame). A sample whose x-y is
///   not on the top face shrunk by `margin_m` is rejected (`start_off_support`).
/// * `box`: uniform in the box; rejected unless it rests on some support: over a top face
///   (shrunk by `margin_m`) at the resting height within `tolerance_m`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlaceJson {
    #[serde(default)]
    pub support: Option<String>,
    #[serde(default)]
    pub region: Option<RectJson>,
    #[serde(default, rename = "box")]
    pub bbox: Option<BoxJson>,
    /// Distance the object origin keeps from the support's edges [m]. Default 0.03.
    #[serde(default = "default_margin")]
    pub margin_m: f64,
    /// Height tolerance of the on-support test for `box` [m]. Default 0.01.
    #[serde(default = "default_tolerance")]
    pub tolerance_m: f64,
}

fn default_margin() -> f64 {
    0.03
}

fn default_tolerance() -> f64 {
    0.01
}

/// Where waypoint positions are sampled: exactly one of `offset` or `box`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WaypointPositionJson {
    /// Offset from the original path at the waypoint's input frame, carried along with the
    /// new start and end (their displacements blended linearly over the contact segment) [m].
    #[serde(default)]
    pub offset: Option<BoxJson>,
    /// Absolute world box [m].
    #[serde(default, rename = "box")]
    pub bbox: Option<BoxJson>,
}

/// Waypoint rotations: an axis chosen uniformly from `axes`, an angle uniform in `angle_rad`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotationJson {
    pub axes: Vec<[f64; 3]>,
    pub angle_rad: Range,
}

/// Waypoints: how many, when, where, how rotated.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WaypointsJson {
    /// Number of waypoints, `[lo, hi]` (whole numbers).
    pub count: [u32; 2],
    /// Input frames are spread evenly over the contact segment and jittered by up to this
    /// fraction of half the spacing, `0 <= jitter < 1`. Default 0.5.
    #[serde(default = "default_jitter")]
    pub t_jitter: f64,
    pub position: WaypointPositionJson,
    #[serde(default)]
    pub rotation: Option<RotationJson>,
}

fn default_jitter() -> f64 {
    0.5
}

/// Retiming: each segment between anchors (start, waypoints, end) lasts its input duration
/// times a factor drawn from `duration_factor` (> 1 slows down), independently per segment,
/// rounded to whole frames.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RetimeJson {
    pub duration_factor: Range,
    /// How the factor is drawn from its range.
    #[serde(default)]
    pub distribution: FactorDistribution,
}

/// The largest duration factor a spec may ask for.
pub const MAX_DURATION_FACTOR: f64 = 100.0;

/// How a duration factor is drawn from its range `[lo, hi]`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FactorDistribution {
    /// Uniform in `[lo, hi]`.
    #[default]
    Uniform,
    /// Uniform in `[ln lo, ln hi]`: a range like `[0.3, 10]` compresses as often as it
    /// stretches (a factor below 1 and one above it are equally likely when `lo·hi = 1`),
    /// where a uniform draw would almost always stretch.
    LogUniform,
}

/// Shape of a primitive barrier.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PrimitiveShape {
    Box,
    Cylinder,
}

/// Primitive barriers placed between start and end.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PrimitivesJson {
    /// How many, `[lo, hi]`.
    pub count: [u32; 2],
    pub shape: PrimitiveShape,
    /// Full edge lengths for `box` [m].
    #[serde(default)]
    pub size: Option<BoxJson>,
    /// Radius for `cylinder` [m].
    #[serde(default)]
    pub radius_m: Option<Range>,
    /// Height for `cylinder` (axis vertical) [m].
    #[serde(default)]
    pub length_m: Option<Range>,
    /// Position along the segment from the (new) start to the (new) end, 0..1.
    pub between: Range,
    /// Offset added to that point [m]; z is ignored when `on_support`.
    #[serde(default)]
    pub offset: Option<BoxJson>,
    /// Turn about the vertical axis [rad]. Default `[0, 0]`.
    #[serde(default)]
    pub yaw_rad: Option<Range>,
    /// Stand on the support below (bottom face on its top). Default true; a barrier with no
    /// support below is rejected (`barrier_off_support`).
    #[serde(default = "yes")]
    pub on_support: bool,
}

fn yes() -> bool {
    true
}

/// Barriers of every variation.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BarriersJson {
    /// Scene items (role `barrier`) in every variation.
    #[serde(default)]
    pub items: Vec<String>,
    /// Scene items each included with `optional_probability`.
    #[serde(default)]
    pub optional_items: Vec<String>,
    /// Default 0.5.
    #[serde(default = "half")]
    pub optional_probability: f64,
    #[serde(default)]
    pub primitives: Option<PrimitivesJson>,
}

fn half() -> f64 {
    0.5
}

/// What a run must meet to be kept (besides a physics pass and no narrow gap).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KeepJson {
    /// Smallest fraction of contact frames the IK solved: it met its threshold, or stopped
    /// where going on would press the hand into the object or a barrier (the report's
    /// `ik.stop_reasons` `penetration_limited`, `barrier_limited`). Default 0.95: a few
    /// frames that stall in a local minimum beside solved neighbours are smoothed over, and
    /// physics and D_C judge the result.
    #[serde(default = "min_solved")]
    pub min_converged: f64,
    /// Largest output D_C [mm]. Default none.
    #[serde(default)]
    pub max_dc_mm: Option<f64>,
}

fn min_solved() -> f64 {
    0.95
}

impl Default for KeepJson {
    fn default() -> Self {
        KeepJson {
            min_converged: min_solved(),
            max_dc_mm: None,
        }
    }
}

/// A variation spec as stored.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpecFile {
    pub format: String,
    pub name: String,
    /// Scene, relative to the spec; default: the scene the demonstration names.
    #[serde(default)]
    pub scene: Option<PathBuf>,
    /// New start; absent: the demonstration's.
    #[serde(default)]
    pub start: Option<PlaceJson>,
    /// New end; absent: the demonstration's.
    #[serde(default)]
    pub end: Option<PlaceJson>,
    #[serde(default)]
    pub waypoints: Option<WaypointsJson>,
    #[serde(default)]
    pub retime: Option<RetimeJson>,
    #[serde(default)]
    pub barriers: BarriersJson,
    /// IK threshold [mm]; default: `params.threshold_mm`.
    #[serde(default)]
    pub threshold_mm: Option<Range>,
    /// Warp parameters shared by every variation (as in a config's `params`).
    #[serde(default)]
    pub params: WarpParams,
    #[serde(default)]
    pub keep: KeepJson,
}

/// A validated spec (scene names not yet checked; see [`Spec::check_scene`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Spec {
    pub file: SpecFile,
    /// Scene resolved against the spec, if given.
    pub scene: Option<PathBuf>,
    pub source: PathBuf,
    /// FNV-1a hash of the file's bytes: a run folder remembers which spec made it.
    pub hash: u64,
}

/// FNV-1a, 64 bit: a stable hash (std's hasher may change between releases).
pub fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

impl Spec {
    /// Reads and validates a spec.
    pub fn load(path: &Path, limits: &Limits) -> Result<Spec> {
        let bytes = json::read_limited(path, limits, limits.max_file_bytes, "--max-file-mb")?;
        let file: SpecFile = json::parse_json(path, &bytes)?;
        let mut spec = Spec::from_file(file, path)?;
        spec.hash = fnv1a(&bytes);
        Ok(spec)
    }

    /// Validates a parsed spec.
    pub fn from_file(file: SpecFile, path: &Path) -> Result<Spec> {
        let c = FieldCheck::new(path);
        if file.format != VARIATIONS_FORMAT {
            return Err(Error::invalid(
                path,
                "format",
                format!(
                    "is {:?}; expected {VARIATIONS_FORMAT:?} (is this a variation spec?)",
                    file.format
                ),
            ));
        }
        if file.name.is_empty() || file.name.contains(['/', '\\']) {
            return Err(Error::invalid(
                path,
                "name",
                format!("is {:?}; expected a plain name without slashes", file.name),
            ));
        }
        for (key, place) in [("start", &file.start), ("end", &file.end)] {
            if let Some(p) = place {
                check_place(&c, key, p)?;
            }
        }
        if let Some(w) = &file.waypoints {
            check_waypoints(&c, w)?;
        }
        if let Some(r) = &file.retime {
            check_range(&c, "retime.duration_factor", r.duration_factor, Some(0.0))?;
            if r.duration_factor[1] > MAX_DURATION_FACTOR {
                return Err(Error::invalid(
                    c.path,
                    "retime.duration_factor[1]",
                    format!(
                        "is {}; expected at most {MAX_DURATION_FACTOR} (a segment that many times its recorded duration)",
                        r.duration_factor[1]
                    ),
                ));
            }
        }
        if let Some(t) = file.threshold_mm {
            check_range(&c, "threshold_mm", t, Some(0.0))?;
        }
        let b = &file.barriers;
        if !(0.0..=1.0).contains(&b.optional_probability) {
            return Err(Error::invalid(
                path,
                "barriers.optional_probability",
                format!(
                    "is {}; expected a probability from 0 to 1",
                    b.optional_probability
                ),
            ));
        }
        if let Some(p) = &b.primitives {
            check_primitives(&c, p)?;
        }
        let k = &file.keep;
        if !(0.0..=1.0).contains(&k.min_converged) {
            return Err(Error::invalid(
                path,
                "keep.min_converged",
                format!("is {}; expected a fraction from 0 to 1", k.min_converged),
            ));
        }
        if let Some(d) = k.max_dc_mm {
            c.positive(|| "keep.max_dc_mm".into(), d, "mm")?;
        }
        // The shared parameters obey the config's rules; errors name this file.
        WarpConfig::from_file(
            ConfigFile {
                format: CONFIG_FORMAT.into(),
                description: None,
                name: file.name.clone(),
                demo: PathBuf::new(),
                scene: PathBuf::new(),
                waypoints: Vec::new(),
                barriers: Vec::new(),
                start: None,
                end: None,
                params: file.params.clone(),
            },
            path,
        )?;
        Ok(Spec {
            scene: file.scene.as_ref().map(|s| json::resolve_relative(path, s)),
            file,
            source: path.to_path_buf(),
            hash: 0,
        })
    }

    /// Checks every name against the scene: supports have role `support` and a box or
    /// vertical-cylinder shape, barrier items have role `barrier`.
    pub fn check_scene(&self, scene: &Scene) -> Result<()> {
        let path = &self.source;
        for (key, place) in [("start", &self.file.start), ("end", &self.file.end)] {
            if let Some(name) = place.as_ref().and_then(|p| p.support.as_ref()) {
                let field = format!("{key}.support");
                let item = scene.item(name).ok_or_else(|| {
                    Error::invalid(
                        path,
                        &field,
                        format!(
                            "{name:?} is not an item of scene {:?}; supports there: {}",
                            scene.name,
                            scene.names_with_role(Role::Support).join(", ")
                        ),
                    )
                })?;
                if item.role != Role::Support {
                    return Err(Error::invalid(
                        path,
                        field,
                        format!("{name:?} is a barrier; expected a support (role \"support\")"),
                    ));
                }
                if super::sampler::top_face(item).is_none() {
                    return Err(Error::unsupported(
                        path,
                        field,
                        format!(
                            "{name:?} is not a box or cylinder with a vertical axis; expected a support with a flat, level top face"
                        ),
                    ));
                }
            }
        }
        let b = &self.file.barriers;
        for (key, names) in [("items", &b.items), ("optional_items", &b.optional_items)] {
            for (j, name) in names.iter().enumerate() {
                let field = format!("barriers.{key}[{j}]");
                match scene.item(name) {
                    None => {
                        return Err(Error::invalid(
                            path,
                            field,
                            format!(
                                "{name:?} is not an item of scene {:?}; barriers there: {}",
                                scene.name,
                                scene.names_with_role(Role::Barrier).join(", ")
                            ),
                        ));
                    }
                    Some(i) if i.role != Role::Barrier => {
                        return Err(Error::invalid(
                            path,
                            field,
                            format!("{name:?} is a support; expected a barrier"),
                        ));
                    }
                    Some(_) => {}
                }
            }
        }
        Ok(())
    }
}

/// Checks the waypoints' count, jitter, position distribution and rotations.
fn check_waypoints(c: &FieldCheck, w: &WaypointsJson) -> Result<()> {
    let path = c.path;
    check_count(path, "waypoints.count", w.count)?;
    if !(0.0..1.0).contains(&w.t_jitter) {
        return Err(Error::invalid(
            path,
            "waypoints.t_jitter",
            format!(
                "is {}; expected a fraction with 0 <= t_jitter < 1",
                w.t_jitter
            ),
        ));
    }
    match (&w.position.offset, &w.position.bbox) {
        (Some(b), None) => check_box(c, "waypoints.position.offset", b, false)?,
        (None, Some(b)) => check_box(c, "waypoints.position.box", b, false)?,
        _ => {
            return Err(Error::invalid(
                path,
                "waypoints.position",
                "expected exactly one of \"offset\" (around the original path) or \"box\" (world box)",
            ));
        }
    }
    if let Some(r) = &w.rotation {
        if r.axes.is_empty() {
            return Err(Error::invalid(
                path,
                "waypoints.rotation.axes",
                "is empty; expected at least one axis, like [[0, 0, 1]]",
            ));
        }
        for (k, a) in r.axes.iter().enumerate() {
            let v = c.vec3(|| format!("waypoints.rotation.axes[{k}]"), *a)?;
            if v.norm() < 1e-9 {
                return Err(Error::invalid(
                    path,
                    format!("waypoints.rotation.axes[{k}]"),
                    "is zero; expected a non-zero axis",
                ));
            }
        }
        check_range(c, "waypoints.rotation.angle_rad", r.angle_rad, None)?;
    }
    Ok(())
}

/// Checks the primitive barriers: count, shape and size ranges, placement.
fn check_primitives(c: &FieldCheck, p: &PrimitivesJson) -> Result<()> {
    let path = c.path;
    check_count(path, "barriers.primitives.count", p.count)?;
    match p.shape {
        PrimitiveShape::Box => match &p.size {
            Some(s) => check_box(c, "barriers.primitives.size", s, true)?,
            None => {
                return Err(Error::invalid(
                    path,
                    "barriers.primitives.size",
                    "is missing; a box barrier needs {\"min\": [x, y, z], \"max\": [x, y, z]} edge lengths in metres",
                ));
            }
        },
        PrimitiveShape::Cylinder => {
            for (key, r) in [("radius_m", p.radius_m), ("length_m", p.length_m)] {
                let field = format!("barriers.primitives.{key}");
                match r {
                    Some(r) => check_range(c, &field, r, Some(0.0))?,
                    None => {
                        return Err(Error::invalid(
                            path,
                            field,
                            "is missing; a cylinder barrier needs radius_m and length_m ranges [lo, hi] in metres",
                        ));
                    }
                }
            }
        }
    }
    check_range(c, "barriers.primitives.between", p.between, None)?;
    if p.between[0] < 0.0 || p.between[1] > 1.0 {
        return Err(Error::invalid(
            path,
            "barriers.primitives.between",
            format!(
                "is {:?}; expected fractions of the way from start to end, within [0, 1]",
                p.between
            ),
        ));
    }
    if let Some(o) = &p.offset {
        check_box(c, "barriers.primitives.offset", o, false)?;
    }
    if let Some(y) = p.yaw_rad {
        check_range(c, "barriers.primitives.yaw_rad", y, None)?;
    }
    Ok(())
}

fn check_place(c: &FieldCheck, key: &str, p: &PlaceJson) -> Result<()> {
    match (&p.support, &p.bbox) {
        (Some(_), None) => {
            if let Some(r) = &p.region {
                for a in 0..2 {
                    let lo = c.finite(|| format!("{key}.region.min[{a}]"), r.min[a])?;
                    let hi = c.finite(|| format!("{key}.region.max[{a}]"), r.max[a])?;
                    if lo > hi {
                        return Err(Error::invalid(
                            c.path,
                            format!("{key}.region"),
                            format!("min[{a}] = {lo} > max[{a}] = {hi}; expected min <= max"),
                        ));
                    }
                }
            }
        }
        (None, Some(b)) => {
            if p.region.is_some() {
                return Err(Error::invalid(
                    c.path,
                    format!("{key}.region"),
                    "is only meaningful with \"support\"; with \"box\" the box is the region",
                ));
            }
            check_box(c, &format!("{key}.box"), b, false)?;
        }
        _ => {
            return Err(Error::invalid(
                c.path,
                key,
                "expected exactly one of \"support\" (a support's name, with an optional x-y \"region\") or \"box\" ({\"min\": [x, y, z], \"max\": [x, y, z]})",
            ));
        }
    }
    c.non_negative(|| format!("{key}.margin_m"), p.margin_m, "m")?;
    c.positive(|| format!("{key}.tolerance_m"), p.tolerance_m, "m")?;
    Ok(())
}

fn check_box(c: &FieldCheck, key: &str, b: &BoxJson, positive: bool) -> Result<()> {
    for a in 0..3 {
        let lo = c.finite(|| format!("{key}.min[{a}]"), b.min[a])?;
        let hi = c.finite(|| format!("{key}.max[{a}]"), b.max[a])?;
        if lo > hi {
            return Err(Error::invalid(
                c.path,
                key,
                format!("min[{a}] = {lo} > max[{a}] = {hi}; expected min <= max"),
            ));
        }
        if positive && lo <= 0.0 {
            return Err(Error::invalid(
                c.path,
                format!("{key}.min[{a}]"),
                format!("is {lo}; expected a length in metres > 0"),
            ));
        }
    }
    Ok(())
}

fn check_range(c: &FieldCheck, key: &str, r: Range, above: Option<f64>) -> Result<()> {
    let lo = c.finite(|| format!("{key}[0]"), r[0])?;
    let hi = c.finite(|| format!("{key}[1]"), r[1])?;
    if lo > hi {
        return Err(Error::invalid(
            c.path,
            key,
            format!("is [{lo}, {hi}]; expected [lo, hi] with lo <= hi"),
        ));
    }
    if let Some(a) = above
        && lo <= a
    {
        return Err(Error::invalid(
            c.path,
            format!("{key}[0]"),
            format!("is {lo}; expected a value > {a}"),
        ));
    }
    Ok(())
}

fn check_count(path: &Path, key: &str, n: [u32; 2]) -> Result<()> {
    if n[0] > n[1] {
        return Err(Error::invalid(
            path,
            key,
            format!("is {n:?}; expected [lo, hi] with lo <= hi"),
        ));
    }
    if n[1] > 64 {
        return Err(Error::invalid(
            path,
            key,
            format!("is {n:?}; expected at most 64"),
        ));
    }
    Ok(())
}
