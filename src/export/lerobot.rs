//! LeRobot v3.0 datasets, state only: writing ([`write`]) and reading ([`read`]).
//!
//! Layout (LeRobot's `codebase_version` "v3.0"):
//! - `meta/info.json`: `codebase_version`, `robot_type`, `fps` (whole Hz), the totals,
//!   `chunks_size` (1000 files per chunk folder), `data_files_size_in_mb` (100),
//!   `data_path` (`data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet`),
//!   `video_path: null`, `splits` (`{"train": "0:N"}`) and `features` (dtype, shape, names);
//! - `meta/stats.json`: [`super::stats`] of every numeric feature;
//! - `meta/tasks.parquet`: `task_index` with the task string as the pandas index `task`;
//! - `meta/episodes/chunk-000/file-000.parquet`: one row per episode with LeRobot's columns
//!   (`episode_index`, `tasks`, `length`, `data/chunk_index`, `data/file_index`,
//!   `dataset_from_index`, `dataset_to_index`, `meta/episodes/chunk_index`,
//!   `meta/episodes/file_index`), the `quality/...` columns of [`super::Quality`], and
//!   LeRobot's per-episode statistics `stats/<feature>/<stat>` for every feature of
//!   `meta/stats.json` (lists of float64, `count` a list of one int64), which LeRobot's
//!   episode tools (`delete_episodes`, `split_dataset`, `merge_datasets`) recombine into the
//!   `meta/stats.json` of what they write;
//! - `data/chunk-CCC/file-FFF.parquet`: one row per frame: `observation.state`,
//!   `observation.environment_state`, `action` (fixed-size lists of float32), `timestamp`
//!   (float32, `frame_index / fps`), `frame_index`, `episode_index`, `index` (the frame's
//!   index over the dataset), `task_index` (int64).
//!
//! Chunking is LeRobot's rule: episodes are appended to a data file until its size would
//! pass `data_files_size_in_mb` (an episode is never split; we count the uncompressed bytes
//! of its rows, LeRobot the written file's size), then the next file starts; a chunk folder
//! holds at most `chunks_size` files. The episodes table is one file (it is small: one row
//! per episode).

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow_array::builder::{Float64Builder, Int64Builder, ListBuilder, StringBuilder};
use arrow_array::cast::AsArray;
use arrow_array::types::{Float32Type, Float64Type, Int32Type, Int64Type};
use arrow_array::{
    Array, ArrayRef, BooleanArray, FixedSizeListArray, Float32Array, Float64Array, Int64Array,
    RecordBatch, StringArray,
};
use arrow_schema::{DataType, Field, Schema};
use parquet::arrow::ArrowWriter;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::basic::Compression;
use parquet::file::properties::WriterProperties;
use serde_json::{Value, json};

use super::{Collected, Episode, pose_names};
use crate::{Error, Result};

/// LeRobot's `codebase_version` written.
pub const CODEBASE_VERSION: &str = "v3.0";
/// LeRobot's default largest data file [MB].
pub const DEFAULT_DATA_FILE_MB: u64 = 100;
/// LeRobot's default most files per chunk folder.
pub const CHUNKS_SIZE: usize = 1000;
/// LeRobot's `data_path` template.
pub const DATA_PATH: &str = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet";
/// Where the episodes table goes.
pub const EPISODES_FILE: &str = "meta/episodes/chunk-000/file-000.parquet";

/// The per-frame vector features: key and whether its names are the state's.
pub const STATE: &str = "observation.state";
pub const ENV_STATE: &str = "observation.environment_state";
pub const ACTION: &str = "action";

/// `chunk-CCC/file-FFF` of file number `n` (LeRobot's chunk rule).
pub fn chunk_file(n: usize) -> (usize, usize) {
    (n / CHUNKS_SIZE, n % CHUNKS_SIZE)
}

/// The data file of chunk `c`, file `f`, relative to the dataset root.
pub fn data_file(c: usize, f: usize) -> String {
    format!("data/chunk-{c:03}/file-{f:03}.parquet")
}

/// Groups episodes of `frames[i]` frames into data files so that no file passes
/// `limit_bytes` at `bytes_per_frame` (a file holds at least one episode). Returns the file
/// number of each episode.
pub fn assign_files(frames: &[usize], bytes_per_frame: usize, limit_bytes: u64) -> Vec<usize> {
    let mut out = Vec::with_capacity(frames.len());
    let (mut file, mut used) = (0usize, 0u64);
    for &n in frames {
        let size = (n * bytes_per_frame) as u64;
        if used > 0 && used + size >= limit_bytes {
            file += 1;
            used = 0;
        }
        used += size;
        out.push(file);
    }
    out
}

fn feature(dtype: &str, shape: usize, names: Option<Vec<String>>) -> Value {
    json!({"dtype": dtype, "shape": [shape], "names": names})
}

/// The `features` of `meta/info.json`.
pub fn features(joint_names: &[String]) -> Value {
    let mut state_names = pose_names("wrist");
    state_names.extend(joint_names.iter().cloned());
    let n = state_names.len();
    json!({
        STATE: feature("float32", n, Some(state_names.clone())),
        ENV_STATE: feature("float32", 7, Some(pose_names("object"))),
        ACTION: feature("float32", n, Some(state_names)),
        "timestamp": feature("float32", 1, None),
        "frame_index": feature("int64", 1, None),
        "episode_index": feature("int64", 1, None),
        "index": feature("int64", 1, None),
        "task_index": feature("int64", 1, None),
    })
}

/// The Hugging Face `datasets` schema of the data files (their `huggingface` metadata), so
/// a reader without LeRobot's `info.json` sees the same types.
fn hf_metadata(state_len: usize) -> String {
    let seq = |n: usize| json!({"feature": {"dtype": "float32", "_type": "Value"}, "length": n, "_type": "Sequence"});
    let val = |t: &str| json!({"dtype": t, "_type": "Value"});
    json!({"info": {"features": {
        STATE: seq(state_len),
        ENV_STATE: seq(7),
        ACTION: seq(state_len),
        "timestamp": val("float32"),
        "frame_index": val("int64"),
        "episode_index": val("int64"),
        "index": val("int64"),
        "task_index": val("int64"),
    }}})
    .to_string()
}

fn f32_list(rows: &[&[f32]], n: usize) -> Result<ArrayRef> {
    let values: Vec<f32> = rows.iter().flat_map(|r| r.iter().copied()).collect();
    let field = Arc::new(Field::new("item", DataType::Float32, true));
    FixedSizeListArray::try_new(field, n as i32, Arc::new(Float32Array::from(values)), None)
        .map(|a| Arc::new(a) as ArrayRef)
        .map_err(|e| Error::write(Path::new("(parquet)"), std::io::Error::other(e)))
}

fn arrow_err(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::write(path, std::io::Error::other(e.to_string()))
}

fn write_parquet(path: &Path, batch: &RecordBatch) -> Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| Error::write(dir, e))?;
    }
    let file = File::create(path).map_err(|e| Error::write(path, e))?;
    let props = WriterProperties::builder()
        .set_compression(Compression::SNAPPY)
        .build();
    let mut w =
        ArrowWriter::try_new(file, batch.schema(), Some(props)).map_err(|e| arrow_err(path, e))?;
    w.write(batch).map_err(|e| arrow_err(path, e))?;
    let file = w.into_inner().map_err(|e| arrow_err(path, e))?;
    file.sync_all().map_err(|e| Error::write(path, e))
}

/// Writes the dataset of `c` into the folder `root` (which exists and is empty). Returns the
/// number of data files.
pub fn write(root: &Path, c: &Collected, data_file_mb: u64) -> Result<usize> {
    let state_len = 7 + c.joint_names.len();
    let eps = &c.episodes;
    // Tasks: one per distinct task string, in order of first use.
    let mut tasks: Vec<String> = Vec::new();
    let task_of: Vec<i64> = eps
        .iter()
        .map(|e| match tasks.iter().position(|t| *t == e.task) {
            Some(i) => i as i64,
            None => {
                tasks.push(e.task.clone());
                (tasks.len() - 1) as i64
            }
        })
        .collect();
    let frames: Vec<usize> = eps.iter().map(|e| e.state.len()).collect();
    // Uncompressed bytes of one row: three float32 vectors, timestamp, four int64.
    let bytes_per_frame = 4 * (2 * state_len + 7) + 4 + 4 * 8;
    let files = assign_files(
        &frames,
        bytes_per_frame,
        data_file_mb.saturating_mul(1 << 20),
    );
    let mut from = Vec::with_capacity(eps.len());
    let mut total = 0usize;
    for n in &frames {
        from.push(total);
        total += n;
    }

    // Data files.
    let nfiles = files.last().map_or(0, |f| f + 1);
    for file in 0..nfiles {
        let members: Vec<usize> = (0..eps.len()).filter(|&i| files[i] == file).collect();
        let (ci, fi) = chunk_file(file);
        let path = root.join(data_file(ci, fi));
        let batch =
            data_batch(c, &members, &from, &task_of, state_len).map_err(|e| arrow_err(&path, e))?;
        write_parquet(&path, &batch)?;
    }

    // Episodes table, with each episode's statistics.
    let path = root.join(EPISODES_FILE);
    let per_episode: Vec<Value> = (0..eps.len())
        .map(|i| features_stats(&episode_features(c, i, &task_of, from[i])))
        .collect();
    let batch = episodes_batch(eps, &files, &from, &tasks, &task_of, &per_episode)
        .map_err(|e| arrow_err(&path, e))?;
    write_parquet(&path, &batch)?;

    // Tasks table, as pandas writes a DataFrame indexed by `task`.
    let path = root.join("meta/tasks.parquet");
    let pandas = json!({
        "index_columns": ["task"],
        "column_indexes": [{"name": null, "field_name": null, "pandas_type": "unicode",
                            "numpy_type": "object", "metadata": {"encoding": "UTF-8"}}],
        "columns": [
            {"name": "task_index", "field_name": "task_index", "pandas_type": "int64",
             "numpy_type": "int64", "metadata": null},
            {"name": "task", "field_name": "task", "pandas_type": "unicode",
             "numpy_type": "object", "metadata": null}],
        "creator": {"library": "dexwarp", "version": env!("CARGO_PKG_VERSION")},
        "pandas_version": "2.2.3"
    });
    let schema = Schema::new(vec![
        Field::new("task_index", DataType::Int64, false),
        Field::new("task", DataType::Utf8, false),
    ])
    .with_metadata(HashMap::from([("pandas".to_string(), pandas.to_string())]));
    let batch = RecordBatch::try_new(
        Arc::new(schema),
        vec![
            Arc::new(Int64Array::from_iter_values(0..tasks.len() as i64)),
            Arc::new(StringArray::from_iter_values(&tasks)),
        ],
    )
    .map_err(|e| arrow_err(&path, e))?;
    write_parquet(&path, &batch)?;

    // Stats over every frame.
    let stats = dataset_stats(c, &task_of);
    write_json(&root.join("meta/stats.json"), &stats)?;

    let info = json!({
        "codebase_version": CODEBASE_VERSION,
        "robot_type": c.robot,
        "total_episodes": eps.len(),
        "total_frames": total,
        "total_tasks": tasks.len(),
        "chunks_size": CHUNKS_SIZE,
        "data_files_size_in_mb": data_file_mb,
        "video_files_size_in_mb": 200,
        "fps": c.fps,
        "splits": {"train": format!("0:{}", eps.len())},
        "data_path": DATA_PATH,
        "video_path": null,
        "features": features(&c.joint_names),
    });
    write_json(&root.join("meta/info.json"), &info)?;
    Ok(nfiles)
}

fn write_json(path: &Path, v: &Value) -> Result<()> {
    let mut bytes = serde_json::to_vec_pretty(v).map_err(|e| arrow_err(path, e))?;
    bytes.push(b'\n');
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| Error::write(dir, e))?;
    }
    std::fs::write(path, bytes).map_err(|e| Error::write(path, e))
}

/// The action of frame `i`: the next frame's state (the last frame keeps its own).
fn action_row(e: &Episode, i: usize) -> &[f32] {
    &e.state[(i + 1).min(e.state.len() - 1)]
}

fn data_batch(
    c: &Collected,
    members: &[usize],
    from: &[usize],
    task_of: &[i64],
    state_len: usize,
) -> std::result::Result<RecordBatch, String> {
    let mut state: Vec<&[f32]> = Vec::new();
    let mut env: Vec<&[f32]> = Vec::new();
    let mut action: Vec<&[f32]> = Vec::new();
    let (mut ts, mut fidx, mut eidx, mut idx, mut tidx) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for &i in members {
        let e = &c.episodes[i];
        for k in 0..e.state.len() {
            state.push(&e.state[k]);
            env.push(&e.object[k]);
            action.push(action_row(e, k));
            ts.push((k as f64 / c.fps as f64) as f32);
            fidx.push(k as i64);
            eidx.push(i as i64);
            idx.push((from[i] + k) as i64);
            tidx.push(task_of[i]);
        }
    }
    let list = |n: usize| {
        DataType::FixedSizeList(
            Arc::new(Field::new("item", DataType::Float32, true)),
            n as i32,
        )
    };
    let schema = Schema::new(vec![
        Field::new(STATE, list(state_len), false),
        Field::new(ENV_STATE, list(7), false),
        Field::new(ACTION, list(state_len), false),
        Field::new("timestamp", DataType::Float32, false),
        Field::new("frame_index", DataType::Int64, false),
        Field::new("episode_index", DataType::Int64, false),
        Field::new("index", DataType::Int64, false),
        Field::new("task_index", DataType::Int64, false),
    ])
    .with_metadata(HashMap::from([(
        "huggingface".to_string(),
        hf_metadata(state_len),
    )]));
    let cols: Vec<ArrayRef> = vec![
        f32_list(&state, state_len).map_err(|e| e.to_string())?,
        f32_list(&env, 7).map_err(|e| e.to_string())?,
        f32_list(&action, state_len).map_err(|e| e.to_string())?,
        Arc::new(Float32Array::from(ts)),
        Arc::new(Int64Array::from(fidx)),
        Arc::new(Int64Array::from(eidx)),
        Arc::new(Int64Array::from(idx)),
        Arc::new(Int64Array::from(tidx)),
    ];
    RecordBatch::try_new(Arc::new(schema), cols).map_err(|e| e.to_string())
}

/// The `quality/...` float columns: name and getter.
type Getter = fn(&super::Quality) -> Option<f64>;
pub const QUALITY_FLOATS: [(&str, Getter); 14] = [
    ("quality/pass_fraction", |q| q.pass_fraction),
    ("quality/d_c_mm", |q| q.d_c_mm),
    ("quality/d_c_original_mm", |q| q.d_c_original_mm),
    ("quality/d_wo_mm", |q| q.d_wo_mm),
    ("quality/d_wo_original_mm", |q| q.d_wo_original_mm),
    ("quality/plr_object", |q| q.plr_object),
    ("quality/plr_hand", |q| q.plr_hand),
    ("quality/timewarp_discrepancy", |q| q.timewarp_discrepancy),
    ("quality/hand_object_penetration_mm", |q| {
        q.hand_object_penetration_mm
    }),
    ("quality/physics_hand_object_penetration_mm", |q| {
        q.physics_hand_object_penetration_mm
    }),
    ("quality/physics_object_barrier_penetration_mm", |q| {
        q.physics_object_barrier_penetration_mm
    }),
    ("quality/tracking_max_position_error_mm", |q| {
        q.tracking_max_position_error_mm
    }),
    ("quality/tracking_max_rotation_error_deg", |q| {
        q.tracking_max_rotation_error_deg
    }),
    ("quality/ik_converged_fraction", |q| q.ik_converged_fraction),
];

/// The `quality/...` string columns: name and getter.
type StrGetter = fn(&super::Quality) -> &str;
pub const QUALITY_STRINGS: [(&str, StrGetter); 5] = [
    ("quality/name", |q| &q.name),
    ("quality/verdict", |q| &q.verdict),
    ("quality/source_demo", |q| &q.source_demo),
    ("quality/config", |q| &q.config),
    ("quality/report", |q| &q.report),
];

fn string_lists(lists: impl Iterator<Item = Vec<String>>) -> ArrayRef {
    let mut b = ListBuilder::new(StringBuilder::new());
    for l in lists {
        for s in l {
            b.values().append_value(s);
        }
        b.append(true);
    }
    Arc::new(b.finish())
}

fn episodes_batch(
    eps: &[Episode],
    files: &[usize],
    from: &[usize],
    tasks: &[String],
    task_of: &[i64],
    stats: &[Value],
) -> std::result::Result<RecordBatch, String> {
    let n = eps.len();
    let int = |f: &dyn Fn(usize) -> i64| -> ArrayRef {
        Arc::new(Int64Array::from_iter_values((0..n).map(f)))
    };
    let mut fields = Vec::new();
    let mut cols: Vec<ArrayRef> = Vec::new();
    let mut push = |name: &str, dt: DataType, nullable: bool, a: ArrayRef| {
        fields.push(Field::new(name, dt, nullable));
        cols.push(a);
    };
    let str_list = DataType::List(Arc::new(Field::new("item", DataType::Utf8, true)));
    push("episode_index", DataType::Int64, false, int(&|i| i as i64));
    push(
        "tasks",
        str_list.clone(),
        false,
        string_lists((0..n).map(|i| vec![tasks[task_of[i] as usize].clone()])),
    );
    push(
        "length",
        DataType::Int64,
        false,
        int(&|i| eps[i].state.len() as i64),
    );
    push(
        "data/chunk_index",
        DataType::Int64,
        false,
        int(&|i| chunk_file(files[i]).0 as i64),
    );
    push(
        "data/file_index",
        DataType::Int64,
        false,
        int(&|i| chunk_file(files[i]).1 as i64),
    );
    push(
        "dataset_from_index",
        DataType::Int64,
        false,
        int(&|i| from[i] as i64),
    );
    push(
        "dataset_to_index",
        DataType::Int64,
        false,
        int(&|i| (from[i] + eps[i].state.len()) as i64),
    );
    push(
        "meta/episodes/chunk_index",
        DataType::Int64,
        false,
        int(&|_| 0),
    );
    push(
        "meta/episodes/file_index",
        DataType::Int64,
        false,
        int(&|_| 0),
    );
    for (name, get) in QUALITY_STRINGS {
        let a = StringArray::from_iter_values(eps.iter().map(|e| get(&e.quality)));
        push(name, DataType::Utf8, false, Arc::new(a));
    }
    push(
        "quality/passed",
        DataType::Boolean,
        false,
        Arc::new(BooleanArray::from_iter(
            eps.iter().map(|e| Some(e.quality.verdict == "pass")),
        )),
    );
    push(
        "quality/robust",
        DataType::Boolean,
        true,
        Arc::new(BooleanArray::from_iter(
            eps.iter().map(|e| e.quality.robust),
        )),
    );
    push(
        "quality/uncertain",
        DataType::Boolean,
        true,
        Arc::new(BooleanArray::from_iter(
            eps.iter().map(|e| e.quality.uncertain),
        )),
    );
    push(
        "quality/failure_reasons",
        str_list,
        false,
        string_lists(eps.iter().map(|e| e.quality.failure_reasons.clone())),
    );
    for (name, get) in QUALITY_FLOATS {
        let a = Float64Array::from_iter(eps.iter().map(|e| get(&e.quality)));
        push(name, DataType::Float64, true, Arc::new(a));
    }
    for feature in STATS_FEATURES {
        for stat in super::stats::STATS {
            let values = stats.iter().map(|s| &s[feature][stat]);
            let (dt, a) = stat_column(stat == "count", values);
            push(&format!("stats/{feature}/{stat}"), dt, false, a);
        }
    }
    RecordBatch::try_new(Arc::new(Schema::new(fields)), cols).map_err(|e| e.to_string())
}

/// One `stats/<feature>/<stat>` column: a list per episode, of int64 for `count`, else of
/// float64.
fn stat_column<'a>(count: bool, values: impl Iterator<Item = &'a Value>) -> (DataType, ArrayRef) {
    let list = |item: DataType| DataType::List(Arc::new(Field::new("item", item, true)));
    let numbers = |v: &Value| v.as_array().cloned().unwrap_or_default();
    if count {
        let mut b = ListBuilder::new(Int64Builder::new());
        for v in values {
            for x in numbers(v) {
                b.values().append_value(x.as_i64().unwrap_or(0));
            }
            b.append(true);
        }
        (list(DataType::Int64), Arc::new(b.finish()))
    } else {
        let mut b = ListBuilder::new(Float64Builder::new());
        for v in values {
            for x in numbers(v) {
                b.values().append_value(x.as_f64().unwrap_or(f64::NAN));
            }
            b.append(true);
        }
        (list(DataType::Float64), Arc::new(b.finish()))
    }
}

/// The features of `meta/stats.json` and of the per-episode `stats/...` columns, in order.
pub const STATS_FEATURES: [&str; 8] = [
    STATE,
    ENV_STATE,
    ACTION,
    "timestamp",
    "frame_index",
    "episode_index",
    "index",
    "task_index",
];

/// The rows of every feature of [`STATS_FEATURES`] over episode `i` (its first frame is
/// `first_index` over the dataset), as LeRobot computes statistics over them.
fn episode_features(
    c: &Collected,
    i: usize,
    task_of: &[i64],
    first_index: usize,
) -> Vec<Vec<Vec<f64>>> {
    let e = &c.episodes[i];
    let widen = |r: &[f32]| r.iter().map(|&v| f64::from(v)).collect::<Vec<f64>>();
    let n = e.state.len();
    vec![
        e.state.iter().map(|r| widen(r)).collect(),
        e.object.iter().map(|r| widen(r)).collect(),
        (0..n).map(|k| widen(action_row(e, k))).collect(),
        (0..n)
            .map(|k| vec![f64::from((k as f64 / c.fps as f64) as f32)])
            .collect(),
        (0..n).map(|k| vec![k as f64]).collect(),
        vec![vec![i as f64]; n],
        (0..n).map(|k| vec![(first_index + k) as f64]).collect(),
        vec![vec![task_of[i] as f64]; n],
    ]
}

/// `{feature: stats}` of rows given per feature of [`STATS_FEATURES`].
fn features_stats(rows: &[Vec<Vec<f64>>]) -> Value {
    let mut out = serde_json::Map::new();
    for (feature, rows) in STATS_FEATURES.iter().zip(rows) {
        let rows: Vec<&[f64]> = rows.iter().map(|r| &r[..]).collect();
        out.insert((*feature).into(), super::stats::feature_stats(&rows));
    }
    Value::Object(out)
}

fn dataset_stats(c: &Collected, task_of: &[i64]) -> Value {
    let mut all: Vec<Vec<Vec<f64>>> = vec![Vec::new(); STATS_FEATURES.len()];
    let mut index = 0;
    for i in 0..c.episodes.len() {
        for (into, rows) in all.iter_mut().zip(episode_features(c, i, task_of, index)) {
            into.extend(rows);
        }
        index += c.episodes[i].state.len();
    }
    features_stats(&all)
}

/// One column of a parquet table as read back.
#[derive(Clone, Debug, PartialEq)]
pub enum Column {
    /// Lists (fixed or variable size) of float32 or float64, widened to f64.
    Vectors(Vec<Vec<f64>>),
    /// float32 or float64 scalars, widened; `None` for nulls.
    Floats(Vec<Option<f64>>),
    /// int32 or int64 scalars.
    Ints(Vec<i64>),
    /// Booleans; `None` for nulls.
    Bools(Vec<Option<bool>>),
    /// Strings; `None` for nulls.
    Strings(Vec<Option<String>>),
    /// Lists of strings.
    StringLists(Vec<Vec<String>>),
}

/// A parquet file read back, by column name.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Table {
    pub rows: usize,
    pub columns: BTreeMap<String, Column>,
}

impl Table {
    /// The column `name`, or an error naming the file and the column.
    pub fn column(&self, path: &Path, name: &str) -> Result<&Column> {
        self.columns.get(name).ok_or_else(|| {
            Error::invalid(
                path,
                name,
                format!(
                    "no such column; the file has {}",
                    self.columns.keys().cloned().collect::<Vec<_>>().join(", ")
                ),
            )
        })
    }

    /// The int column `name`.
    pub fn ints(&self, path: &Path, name: &str) -> Result<&[i64]> {
        match self.column(path, name)? {
            Column::Ints(v) => Ok(v),
            _ => Err(Error::invalid(path, name, "is not an integer column")),
        }
    }

    /// The vector column `name`.
    pub fn vectors(&self, path: &Path, name: &str) -> Result<&[Vec<f64>]> {
        match self.column(path, name)? {
            Column::Vectors(v) => Ok(v),
            _ => Err(Error::invalid(
                path,
                name,
                "is not a column of float vectors",
            )),
        }
    }
}

fn read_column(a: &dyn Array) -> Option<Column> {
    let floats = |a: &dyn Array| -> Option<Vec<f64>> {
        if let Some(p) = a.as_primitive_opt::<Float32Type>() {
            return Some(p.iter().map(|v| v.unwrap_or(f32::NAN) as f64).collect());
        }
        if let Some(p) = a.as_primitive_opt::<Int64Type>() {
            return Some(p.iter().map(|v| v.unwrap_or(0) as f64).collect());
        }
        a.as_primitive_opt::<Float64Type>()
            .map(|p| p.iter().map(|v| v.unwrap_or(f64::NAN)).collect())
    };
    let strings = |a: &dyn Array| -> Option<Vec<Option<String>>> {
        if let Some(s) = a.as_string_opt::<i32>() {
            return Some(s.iter().map(|v| v.map(str::to_string)).collect());
        }
        a.as_string_opt::<i64>()
            .map(|s| s.iter().map(|v| v.map(str::to_string)).collect())
    };
    if let Some(p) = a.as_primitive_opt::<Float32Type>() {
        return Some(Column::Floats(p.iter().map(|v| v.map(f64::from)).collect()));
    }
    if let Some(p) = a.as_primitive_opt::<Float64Type>() {
        return Some(Column::Floats(p.iter().collect()));
    }
    if let Some(p) = a.as_primitive_opt::<Int64Type>() {
        return Some(Column::Ints(p.iter().map(|v| v.unwrap_or(0)).collect()));
    }
    if let Some(p) = a.as_primitive_opt::<Int32Type>() {
        return Some(Column::Ints(
            p.iter().map(|v| v.unwrap_or(0) as i64).collect(),
        ));
    }
    if let Some(b) = a.as_boolean_opt() {
        return Some(Column::Bools(b.iter().collect()));
    }
    if let Some(s) = strings(a) {
        return Some(Column::Strings(s));
    }
    let lists: Vec<ArrayRef> = if let Some(l) = a.as_fixed_size_list_opt() {
        (0..l.len()).map(|i| l.value(i)).collect()
    } else if let Some(l) = a.as_list_opt::<i32>() {
        (0..l.len()).map(|i| l.value(i)).collect()
    } else if let Some(l) = a.as_list_opt::<i64>() {
        (0..l.len()).map(|i| l.value(i)).collect()
    } else {
        return None;
    };
    if let Some(first) = lists.first()
        && strings(first.as_ref()).is_some()
    {
        return Some(Column::StringLists(
            lists
                .iter()
                .map(|l| {
                    strings(l.as_ref())
                        .unwrap_or_default()
                        .into_iter()
                        .flatten()
                        .collect()
                })
                .collect(),
        ));
    }
    let v: Option<Vec<Vec<f64>>> = lists.iter().map(|l| floats(l.as_ref())).collect();
    v.map(Column::Vectors)
}

fn append(into: &mut Column, more: Column) {
    match (into, more) {
        (Column::Vectors(a), Column::Vectors(b)) => a.extend(b),
        (Column::Floats(a), Column::Floats(b)) => a.extend(b),
        (Column::Ints(a), Column::Ints(b)) => a.extend(b),
        (Column::Bools(a), Column::Bools(b)) => a.extend(b),
        (Column::Strings(a), Column::Strings(b)) => a.extend(b),
        (Column::StringLists(a), Column::StringLists(b)) => a.extend(b),
        _ => {}
    }
}

/// Reads a whole parquet file. Columns of types this reader does not know are left out.
pub fn read_parquet(path: &Path) -> Result<Table> {
    let bad = |e: &dyn std::fmt::Display| Error::Parse {
        path: path.to_path_buf(),
        field: "(parquet)".into(),
        message: format!("{e}; expected a parquet file"),
    };
    let file = File::open(path).map_err(|e| Error::read(path, e))?;
    let reader = ParquetRecordBatchReaderBuilder::try_new(file)
        .map_err(|e| bad(&e))?
        .build()
        .map_err(|e| bad(&e))?;
    let mut table = Table::default();
    for batch in reader {
        let batch = batch.map_err(|e| bad(&e))?;
        table.rows += batch.num_rows();
        let schema = batch.schema();
        for (field, col) in schema.fields().iter().zip(batch.columns()) {
            let Some(c) = read_column(col.as_ref()) else {
                continue;
            };
            match table.columns.get_mut(field.name()) {
                Some(have) => append(have, c),
                None => {
                    table.columns.insert(field.name().clone(), c);
                }
            }
        }
    }
    Ok(table)
}

/// A LeRobot v3 dataset read back: its `info.json`, episodes table and frames (all data
/// files, in file order).
#[derive(Clone, Debug)]
pub struct Dataset {
    pub root: PathBuf,
    pub info: Value,
    pub episodes: Table,
    pub frames: Table,
}

/// The parquet files of `dir/chunk-*/file-*.parquet`, sorted (LeRobot's order).
fn chunk_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    let Ok(chunks) = std::fs::read_dir(dir) else {
        return Ok(out);
    };
    for c in chunks.flatten() {
        if !c.path().is_dir() {
            continue;
        }
        for f in std::fs::read_dir(c.path())
            .map_err(|e| Error::read(&c.path(), e))?
            .flatten()
        {
            if f.path().extension().is_some_and(|e| e == "parquet") {
                out.push(f.path());
            }
        }
    }
    out.sort();
    Ok(out)
}

fn read_all(dir: &Path, root: &Path) -> Result<Table> {
    let files = chunk_files(dir)?;
    if files.is_empty() {
        return Err(Error::invalid(
            root,
            dir.strip_prefix(root).unwrap_or(dir).display().to_string(),
            "has no chunk-*/file-*.parquet; expected a LeRobot v3 dataset",
        ));
    }
    let mut table = Table::default();
    for f in files {
        let t = read_parquet(&f)?;
        table.rows += t.rows;
        for (k, c) in t.columns {
            match table.columns.get_mut(&k) {
                Some(have) => append(have, c),
                None => {
                    table.columns.insert(k, c);
                }
            }
        }
    }
    Ok(table)
}

/// Reads the LeRobot v3 dataset at `root`.
pub fn read(root: &Path) -> Result<Dataset> {
    let info_path = root.join("meta/info.json");
    let bytes = std::fs::read(&info_path).map_err(|e| Error::read(&info_path, e))?;
    let info: Value = serde_json::from_slice(&bytes).map_err(|e| Error::Parse {
        path: info_path.clone(),
        field: format!("line {}, column {}", e.line(), e.column()),
        message: e.to_string(),
    })?;
    let version = info["codebase_version"].as_str().unwrap_or("");
    if !version.starts_with("v3") {
        return Err(Error::invalid(
            &info_path,
            "codebase_version",
            format!(
                "is {version:?}; expected \"v3.0\" (convert older datasets with LeRobot first)"
            ),
        ));
    }
    Ok(Dataset {
        root: root.to_path_buf(),
        info,
        episodes: read_all(&root.join("meta/episodes"), root)?,
        frames: read_all(&root.join("data"), root)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn files_fill_up_to_the_limit() {
        // 100 bytes per frame, limit 1000 bytes: 4 + 5 frames fit, the next starts a file.
        assert_eq!(assign_files(&[4, 5, 1, 3], 100, 1000), vec![0, 0, 1, 1]);
        // An episode larger than the limit gets a file of its own.
        assert_eq!(assign_files(&[20, 1, 20], 100, 1000), vec![0, 1, 2]);
        assert_eq!(chunk_file(999), (0, 999));
        assert_eq!(chunk_file(1000), (1, 0));
        assert_eq!(data_file(1, 2), "data/chunk-001/file-002.parquet");
    }
}
