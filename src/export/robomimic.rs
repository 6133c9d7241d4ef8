//! robomimic HDF5 datasets (cargo feature `robomimic`): writing ([`write`]) and reading
//! ([`read`]), through the `hdf5-metno` binding of the HDF5 C library.
//!
//! Layout (robomimic's dataset structure, low-dimensional observations only):
//! - `data` (group): attributes `total` (frames over all demos, int64), `actions_normalized`
//!   (bool), `action_offset` and `action_scale` (float64 `[7 + J]`, when normalized) and
//!   `env_args` (a JSON
//!   string: `env_name` `dexwarp/<robot>`, `type` 2, robomimic's type for environments it
//!   does not build itself, and `env_kwargs` with the robot, fps, joint names and the layout
//!   of `states`);
//! - `data/demo_<i>` (group, one per trajectory, `i` from 0 in export order): attribute
//!   `num_samples` (frames, int64), the quality figures of [`super::Quality`] as attributes
//!   (floats as float64, left out when the report does not have them; `name`, `verdict`,
//!   `source_demo`, `config`, `report`, `task` as strings; `passed` as bool (and `robust`
//!   when the report has a robustness margin, `uncertain` when it has an ensemble);
//!   `failure_reasons` as a JSON list of strings), and the datasets
//!   - `obs/<key>` and `next_obs/<key>` ([`OBS_KEYS`], float32 `[N, width]`; `next_obs` is
//!     the next frame's, the last frame repeats its own),
//!   - `actions` (float32 `[N, 7 + J]`): the next frame's hand state (as LeRobot's
//!     `action`) scaled per dimension into [-1, 1], as robomimic's policies (a tanh output)
//!     and its `get_dataset_info` expect: `actions = (target - action_offset) / action_scale`
//!     with `action_offset` the middle and `action_scale` the half range of that dimension
//!     over the whole file (1 for a dimension that does not vary). The targets themselves are
//!     `actions_abs` (float32, metres and radians). With `--absolute-actions` (for users who
//!     normalize themselves), `actions` holds the targets and neither is written;
//!   - `states` (float32 `[N, 14 + J]`: object pose, wrist pose, joints),
//!   - `rewards` (float64 `[N]`: 1 at the last frame of a trajectory whose physics verdict is
//!     pass, else 0) and `dones` (int64 `[N]`: 1 at the last frame);
//! - `mask/<key>` (fixed-length byte strings of demo names, robomimic's filter keys):
//!   `pass` and `fail` (physics verdict; `unknown` is in neither), `train` and `valid` (a
//!   90/10 split of every demo: every tenth demo, `demo_9`, `demo_19`, ..., is `valid`;
//!   with fewer than ten, the last one).
//!
//! Poses are position `[x, y, z]` then quaternion `[w, x, y, z]`, as in the LeRobot export.

use std::collections::BTreeMap;
use std::path::Path;

use hdf5::types::{FixedAscii, TypeDescriptor, VarLenUnicode};
use serde_json::{Value, json};

use super::{Collected, Episode};
use crate::{Error, Result};

/// `obs/<key>`: name, whether it is cut from the hand state (else the object pose), and the
/// column range (`None` end: to the end of the row).
pub const OBS_KEYS: [(&str, bool, usize, Option<usize>); 5] = [
    ("wrist_pos", true, 0, Some(3)),
    ("wrist_quat", true, 3, Some(7)),
    ("joint_pos", true, 7, None),
    ("object_pos", false, 0, Some(3)),
    ("object_quat", false, 3, Some(7)),
];

/// The mask (filter key) names written.
pub const MASKS: [&str; 4] = ["pass", "fail", "train", "valid"];

/// robomimic's `EnvType.GYM_TYPE`: environments robomimic does not build itself.
pub const ENV_TYPE: i64 = 2;

/// Longest demo name in `mask/*` (`demo_` and up to 19 digits).
type Name = FixedAscii<24>;

fn h5_err(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::write(path, std::io::Error::other(e.to_string()))
}

/// Whether demo `i` of `n` is in the validation split.
pub fn is_valid(i: usize, n: usize) -> bool {
    if n >= 10 {
        i % 10 == 9
    } else {
        n >= 2 && i == n - 1
    }
}

/// The demo names of each mask, in demo order.
pub fn masks(eps: &[Episode]) -> BTreeMap<&'static str, Vec<String>> {
    let n = eps.len();
    let mut out: BTreeMap<&'static str, Vec<String>> =
        MASKS.iter().map(|m| (*m, Vec::new())).collect();
    for (i, e) in eps.iter().enumerate() {
        let name = format!("demo_{i}");
        match e.quality.verdict.as_str() {
            "pass" => out.get_mut("pass").unwrap().push(name.clone()),
            "fail" => out.get_mut("fail").unwrap().push(name.clone()),
            _ => {}
        }
        let split = if is_valid(i, n) { "valid" } else { "train" };
        out.get_mut(split).unwrap().push(name);
    }
    out
}

/// The `obs/<key>` rows of frame `k` of `e`.
fn obs_row(e: &Episode, key: usize, k: usize) -> &[f32] {
    let (_, hand, from, to) = OBS_KEYS[key];
    let row: &[f32] = if hand { &e.state[k] } else { &e.object[k] };
    &row[from..to.unwrap_or(row.len())]
}

fn write_2d(
    path: &Path,
    g: &hdf5::Group,
    name: &str,
    width: usize,
    rows: impl Iterator<Item = impl AsRef<[f32]>>,
) -> Result<()> {
    let mut flat = Vec::new();
    for r in rows {
        flat.extend_from_slice(r.as_ref());
    }
    let n = flat.len() / width.max(1);
    g.new_dataset::<f32>()
        .shape((n, width))
        .create(name)
        .and_then(|d| d.write_raw(&flat[..]))
        .map_err(|e| h5_err(path, format!("{}/{name}: {e}", g.name())))
}

fn str_attr(path: &Path, loc: &hdf5::Location, name: &str, value: &str) -> Result<()> {
    let v: VarLenUnicode = value
        .parse()
        .map_err(|e| h5_err(path, format!("attribute {name}: {e}")))?;
    loc.new_attr::<VarLenUnicode>()
        .create(name)
        .and_then(|a| a.write_scalar(&v))
        .map_err(|e| h5_err(path, format!("attribute {name}: {e}")))
}

fn scalar_attr<T: hdf5::H5Type>(path: &Path, loc: &hdf5::Location, name: &str, v: T) -> Result<()> {
    loc.new_attr::<T>()
        .create(name)
        .and_then(|a| a.write_scalar(&v))
        .map_err(|e| h5_err(path, format!("attribute {name}: {e}")))
}

/// The name of a quality float as a demo attribute (`quality/d_c_mm` -> `d_c_mm`).
pub fn attr_name(column: &str) -> &str {
    column.strip_prefix("quality/").unwrap_or(column)
}

/// How `actions` are scaled: per dimension, `(target - offset) / scale`.
#[derive(Clone, Debug, PartialEq)]
pub struct ActionScaling {
    pub offset: Vec<f64>,
    pub scale: Vec<f64>,
}

impl ActionScaling {
    /// Middle and half range of every dimension of `rows` (of width `width`); a dimension
    /// that does not vary gets scale 1.
    pub fn of<'a>(width: usize, rows: impl Iterator<Item = &'a [f32]>) -> ActionScaling {
        let mut lo = vec![f64::INFINITY; width];
        let mut hi = vec![f64::NEG_INFINITY; width];
        for r in rows {
            for (j, v) in r.iter().enumerate().take(width) {
                lo[j] = lo[j].min(f64::from(*v));
                hi[j] = hi[j].max(f64::from(*v));
            }
        }
        let (offset, scale) = lo
            .iter()
            .zip(&hi)
            .map(|(&l, &h)| {
                if !(l.is_finite() && h.is_finite()) {
                    return (0.0, 1.0);
                }
                let half = (h - l) / 2.0;
                (l + half, if half > 0.0 { half } else { 1.0 })
            })
            .unzip();
        ActionScaling { offset, scale }
    }

    /// `row` scaled into [-1, 1].
    pub fn apply(&self, row: &[f32]) -> Vec<f32> {
        row.iter()
            .zip(self.offset.iter().zip(&self.scale))
            .map(|(v, (o, s))| (((f64::from(*v) - o) / s) as f32).clamp(-1.0, 1.0))
            .collect()
    }
}

/// The action rows of `e`: the next frame's hand state, the last repeating its own.
fn action_rows(e: &Episode) -> impl Iterator<Item = &Vec<f32>> {
    let n = e.state.len();
    (0..n).map(move |k| &e.state[(k + 1).min(n - 1)])
}

fn write_demo(
    path: &Path,
    data: &hdf5::Group,
    i: usize,
    e: &Episode,
    state_len: usize,
    scaling: Option<&ActionScaling>,
) -> Result<()> {
    let g = data
        .create_group(&format!("demo_{i}"))
        .map_err(|err| h5_err(path, format!("data/demo_{i}: {err}")))?;
    let n = e.state.len();
    for (sub, shift) in [("obs", 0usize), ("next_obs", 1)] {
        let og = g
            .create_group(sub)
            .map_err(|err| h5_err(path, format!("{}/{sub}: {err}", g.name())))?;
        for (key, &(name, hand, from, to)) in OBS_KEYS.iter().enumerate() {
            let width = to.unwrap_or(if hand { state_len } else { 7 }) - from;
            let rows = (0..n).map(|k| obs_row(e, key, (k + shift).min(n - 1)));
            write_2d(path, &og, name, width, rows)?;
        }
    }
    match scaling {
        Some(s) => {
            let scaled: Vec<Vec<f32>> = action_rows(e).map(|r| s.apply(r)).collect();
            write_2d(path, &g, "actions", state_len, scaled.iter())?;
            write_2d(path, &g, "actions_abs", state_len, action_rows(e))?;
        }
        None => write_2d(path, &g, "actions", state_len, action_rows(e))?,
    }
    let states = (0..n).map(|k| {
        let mut r = e.object[k].clone();
        r.extend_from_slice(&e.state[k]);
        r
    });
    write_2d(path, &g, "states", 7 + state_len, states)?;
    let q = &e.quality;
    let passed = q.verdict == "pass";
    let rewards: Vec<f64> = (0..n)
        .map(|k| if passed && k + 1 == n { 1.0 } else { 0.0 })
        .collect();
    let dones: Vec<i64> = (0..n).map(|k| i64::from(k + 1 == n)).collect();
    g.new_dataset::<f64>()
        .shape(n)
        .create("rewards")
        .and_then(|d| d.write_raw(&rewards[..]))
        .map_err(|err| h5_err(path, format!("{}/rewards: {err}", g.name())))?;
    g.new_dataset::<i64>()
        .shape(n)
        .create("dones")
        .and_then(|d| d.write_raw(&dones[..]))
        .map_err(|err| h5_err(path, format!("{}/dones: {err}", g.name())))?;

    scalar_attr(path, &g, "num_samples", n as i64)?;
    scalar_attr(path, &g, "passed", passed)?;
    if let Some(robust) = q.robust {
        scalar_attr(path, &g, "robust", robust)?;
    }
    if let Some(uncertain) = q.uncertain {
        scalar_attr(path, &g, "uncertain", uncertain)?;
    }
    for (column, get) in super::lerobot::QUALITY_STRINGS {
        str_attr(path, &g, attr_name(column), get(q))?;
    }
    str_attr(path, &g, "task", &e.task)?;
    let reasons = serde_json::to_string(&q.failure_reasons).unwrap_or_else(|_| "[]".into());
    str_attr(path, &g, "failure_reasons", &reasons)?;
    for (column, get) in super::lerobot::QUALITY_FLOATS {
        if let Some(v) = get(q) {
            scalar_attr(path, &g, attr_name(column), v)?;
        }
    }
    Ok(())
}

/// `env_args` of `data`.
pub fn env_args(c: &Collected) -> Value {
    let mut state = super::pose_names("object");
    state.extend(super::pose_names("wrist"));
    state.extend(c.joint_names.iter().cloned());
    json!({
        "env_name": format!("dexwarp/{}", c.robot),
        "type": ENV_TYPE,
        "env_kwargs": {
            "robot": c.robot,
            "fps": c.fps,
            "joint_names": c.joint_names,
            "states": state,
            "obs_keys": OBS_KEYS.iter().map(|k| k.0).collect::<Vec<_>>(),
            "writer": format!("dexwarp {}", env!("CARGO_PKG_VERSION")),
        },
    })
}

/// Writes the dataset of `c` as the HDF5 file `path` (created; the caller renames it into
/// place).
/// With `absolute_actions`, `actions` are the targets themselves (see the module docs).
pub fn write(path: &Path, c: &Collected, absolute_actions: bool) -> Result<()> {
    let state_len = 7 + c.joint_names.len();
    let file = hdf5::File::create(path).map_err(|e| h5_err(path, e))?;
    let data = file.create_group("data").map_err(|e| h5_err(path, e))?;
    let total: usize = c.episodes.iter().map(|e| e.state.len()).sum();
    let scaling = (!absolute_actions).then(|| {
        ActionScaling::of(
            state_len,
            c.episodes
                .iter()
                .flat_map(action_rows)
                .map(|r| r.as_slice()),
        )
    });
    for (i, e) in c.episodes.iter().enumerate() {
        write_demo(path, &data, i, e, state_len, scaling.as_ref())?;
    }
    scalar_attr(path, &data, "total", total as i64)?;
    scalar_attr(path, &data, "actions_normalized", scaling.is_some())?;
    if let Some(s) = &scaling {
        for (name, values) in [("action_offset", &s.offset), ("action_scale", &s.scale)] {
            data.new_attr::<f64>()
                .shape(values.len())
                .create(name)
                .and_then(|a| a.write_raw(&values[..]))
                .map_err(|e| h5_err(path, format!("data@{name}: {e}")))?;
        }
    }
    str_attr(path, &data, "env_args", &env_args(c).to_string())?;
    let mask = file.create_group("mask").map_err(|e| h5_err(path, e))?;
    for (key, names) in masks(&c.episodes) {
        let names: Vec<Name> = names
            .iter()
            .map(|n| Name::from_ascii(n.as_bytes()))
            .collect::<std::result::Result<_, _>>()
            .map_err(|e| h5_err(path, format!("mask/{key}: {e}")))?;
        mask.new_dataset::<Name>()
            .shape(names.len())
            .create(key)
            .and_then(|d| d.write_raw(&names[..]))
            .map_err(|e| h5_err(path, format!("mask/{key}: {e}")))?;
    }
    file.flush().map_err(|e| h5_err(path, e))?;
    file.close().map_err(|e| h5_err(path, e))?;
    std::fs::File::open(path)
        .and_then(|f| f.sync_all())
        .map_err(|e| Error::write(path, e))
}

/// A value of a demo attribute as read back.
#[derive(Clone, Debug, PartialEq)]
pub enum Attr {
    Float(f64),
    Int(i64),
    Bool(bool),
    Str(String),
}

/// One `data/demo_<i>` group read back.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DemoGroup {
    pub name: String,
    pub attrs: BTreeMap<String, Attr>,
    /// `obs/<key>` rows, by key.
    pub obs: BTreeMap<String, Vec<Vec<f32>>>,
    pub next_obs: BTreeMap<String, Vec<Vec<f32>>>,
    pub actions: Vec<Vec<f32>>,
    /// The absolute targets when `actions` are normalized.
    pub actions_abs: Option<Vec<Vec<f32>>>,
    pub states: Vec<Vec<f32>>,
    pub rewards: Vec<f64>,
    pub dones: Vec<i64>,
}

/// A robomimic file read back.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Dataset {
    pub total: i64,
    /// How `actions` were scaled into [-1, 1] (`None`: absolute actions).
    pub action_scaling: Option<ActionScaling>,
    pub env_args: Value,
    /// Demos in robomimic's order (by the number after `demo_`).
    pub demos: Vec<DemoGroup>,
    /// `mask/<key>`: demo names.
    pub masks: BTreeMap<String, Vec<String>>,
}

fn bad(path: &Path, field: impl Into<String>, e: impl std::fmt::Display) -> Error {
    Error::invalid(path, field, format!("{e}; expected a robomimic HDF5 file"))
}

fn read_2d(path: &Path, g: &hdf5::Group, name: &str) -> Result<Vec<Vec<f32>>> {
    let field = format!("{}/{name}", g.name());
    let d = g.dataset(name).map_err(|e| bad(path, &field, e))?;
    let shape = d.shape();
    if shape.len() != 2 {
        return Err(bad(path, &field, format!("has shape {shape:?}")));
    }
    let flat: Vec<f32> = d.read_raw().map_err(|e| bad(path, &field, e))?;
    Ok(flat.chunks(shape[1].max(1)).map(<[f32]>::to_vec).collect())
}

fn read_attrs(path: &Path, g: &hdf5::Group) -> Result<BTreeMap<String, Attr>> {
    let mut out = BTreeMap::new();
    for name in g.attr_names().map_err(|e| bad(path, g.name(), e))? {
        let field = format!("{}@{name}", g.name());
        let a = g.attr(&name).map_err(|e| bad(path, &field, e))?;
        if !a.is_scalar() {
            // Vectors (data@action_offset, data@action_scale) are read by name.
            continue;
        }
        let t = a
            .dtype()
            .and_then(|t| t.to_descriptor())
            .map_err(|e| bad(path, &field, e))?;
        let v = match t {
            TypeDescriptor::Float(_) => a.read_scalar::<f64>().map(Attr::Float),
            TypeDescriptor::Integer(_) | TypeDescriptor::Unsigned(_) => {
                a.read_scalar::<i64>().map(Attr::Int)
            }
            TypeDescriptor::Boolean => a.read_scalar::<bool>().map(Attr::Bool),
            TypeDescriptor::VarLenUnicode => a
                .read_scalar::<VarLenUnicode>()
                .map(|s| Attr::Str(s.as_str().to_string())),
            other => return Err(bad(path, &field, format!("has type {other:?}"))),
        }
        .map_err(|e| bad(path, &field, e))?;
        out.insert(name, v);
    }
    Ok(out)
}

/// Reads the robomimic file `path` (as [`write`] lays it out).
pub fn read(path: &Path) -> Result<Dataset> {
    let file = hdf5::File::open(path).map_err(|e| bad(path, "(file)", e))?;
    let data = file.group("data").map_err(|e| bad(path, "data", e))?;
    let attrs = read_attrs(path, &data)?;
    let total = match attrs.get("total") {
        Some(Attr::Int(n)) => *n,
        _ => return Err(bad(path, "data@total", "missing")),
    };
    let env_args = match attrs.get("env_args") {
        Some(Attr::Str(s)) => serde_json::from_str(s).map_err(|e| bad(path, "data@env_args", e))?,
        _ => return Err(bad(path, "data@env_args", "missing")),
    };
    let mut names: Vec<(u64, String)> = data
        .member_names()
        .map_err(|e| bad(path, "data", e))?
        .into_iter()
        .filter_map(|n| Some((n.strip_prefix("demo_")?.parse().ok()?, n)))
        .collect();
    names.sort();
    let mut demos = Vec::with_capacity(names.len());
    for (_, name) in names {
        let g = data.group(&name).map_err(|e| bad(path, &name, e))?;
        let mut d = DemoGroup {
            name: name.clone(),
            attrs: read_attrs(path, &g)?,
            actions: read_2d(path, &g, "actions")?,
            actions_abs: g
                .dataset("actions_abs")
                .is_ok()
                .then(|| read_2d(path, &g, "actions_abs"))
                .transpose()?,
            states: read_2d(path, &g, "states")?,
            ..DemoGroup::default()
        };
        for (sub, into) in [("obs", &mut d.obs), ("next_obs", &mut d.next_obs)] {
            let og = g
                .group(sub)
                .map_err(|e| bad(path, format!("{name}/{sub}"), e))?;
            for key in og.member_names().map_err(|e| bad(path, og.name(), e))? {
                into.insert(key.clone(), read_2d(path, &og, &key)?);
            }
        }
        let field = format!("{name}/rewards");
        d.rewards = g
            .dataset("rewards")
            .and_then(|x| x.read_raw())
            .map_err(|e| bad(path, &field, e))?;
        let field = format!("{name}/dones");
        d.dones = g
            .dataset("dones")
            .and_then(|x| x.read_raw())
            .map_err(|e| bad(path, &field, e))?;
        demos.push(d);
    }
    let mut masks = BTreeMap::new();
    if let Ok(m) = file.group("mask") {
        for key in m.member_names().map_err(|e| bad(path, "mask", e))? {
            let field = format!("mask/{key}");
            let names: Vec<Name> = m
                .dataset(&key)
                .and_then(|x| x.read_raw())
                .map_err(|e| bad(path, &field, e))?;
            masks.insert(key, names.iter().map(|n| n.as_str().to_string()).collect());
        }
    }
    let vector = |name: &str| -> Result<Vec<f64>> {
        data.attr(name)
            .and_then(|a| a.read_raw())
            .map_err(|e| bad(path, format!("data@{name}"), e))
    };
    let action_scaling = match attrs.get("actions_normalized") {
        Some(Attr::Bool(true)) => Some(ActionScaling {
            offset: vector("action_offset")?,
            scale: vector("action_scale")?,
        }),
        _ => None,
    };
    Ok(Dataset {
        total,
        action_scaling,
        env_args,
        demos,
        masks,
    })
}
