//! `warp`, `validate`, `augment` and the warp's `Result`.
//!
//! Each call does its work with the GIL released (`Python::detach`): other Python threads run
//! meanwhile, and the pipeline's own rayon parallelism (physics) runs inside the call.

use std::path::PathBuf;

use dexwarp::Limits;
use dexwarp::math::rotation::quat_to_wxyz;
use dexwarp::pipeline::{self, HandMethod, Inputs, Options, PhysicsOptions, WarpRun};
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use serde::de::DeserializeOwned;

use crate::config::Config;
use crate::demo::Demo;
use crate::{arrays, value};

/// A keyword's string value as the library's enum (`hand="contact"`), with serde's message
/// naming the accepted values.
fn choice<T: DeserializeOwned>(arg: &str, v: &str) -> PyResult<T> {
    serde_json::from_value(serde_json::Value::String(v.to_string()))
        .map_err(|e| crate::raise(format!("{arg}: {e}"), None, Some(arg.to_string())))
}

/// A positive finite number, with the command line's message (`--threshold-mm -1`).
fn positive_mm(arg: &str, v: f64) -> PyResult<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else if v.is_finite() {
        Err(crate::raise(
            format!(
                "{arg}: the value must be positive: a distance in millimetres > 0, like 3.5; got {v}"
            ),
            None,
            Some(arg.into()),
        ))
    } else {
        Err(crate::raise(
            format!("{arg}: expected a finite distance in millimetres > 0, like 3.5; got {v}"),
            None,
            Some(arg.into()),
        ))
    }
}

/// What one warp produced: the output demonstration, its arrays and the report.
#[pyclass(frozen, name = "Result", module = "dexwarp")]
#[derive(Debug)]
pub struct WarpResult {
    run: WarpRun,
    /// Files read, which `save` may not overwrite.
    inputs: Vec<PathBuf>,
}

#[pymethods]
impl WarpResult {
    /// The warped demonstration (with `timewarp`).
    #[getter]
    fn demo(&self) -> Demo {
        Demo {
            inner: self.run.demo.clone(),
        }
    }

    /// The report as a dict: the JSON `dexwarp warp` writes to `report.json` (without
    /// `outputs`, the hashes of written files, until `save`).
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        value::serialize(py, &self.run.report)
    }

    /// Warped object positions, shape (T_out, 3) [m].
    #[getter]
    fn object_positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let f = &self.run.demo.frames;
        arrays::rows_out(py, f.iter().map(|f| f.object.translation.vector.into()))
    }

    /// Warped object orientations, shape (T_out, 4), [w, x, y, z].
    #[getter]
    fn object_quaternions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let f = &self.run.demo.frames;
        arrays::rows_out(py, f.iter().map(|f| quat_to_wxyz(&f.object.rotation)))
    }

    /// Recovered wrist positions, shape (T_out, 3) [m].
    #[getter]
    fn wrist_positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let f = &self.run.demo.frames;
        arrays::rows_out(py, f.iter().map(|f| f.wrist.translation.vector.into()))
    }

    /// Recovered wrist orientations, shape (T_out, 4), [w, x, y, z].
    #[getter]
    fn wrist_quaternions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let f = &self.run.demo.frames;
        arrays::rows_out(py, f.iter().map(|f| quat_to_wxyz(&f.wrist.rotation)))
    }

    /// Recovered joint values, shape (T_out, D), columns as `demo.joint_names` (the robot's
    /// actuated order).
    #[getter]
    fn joints<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let d = &self.run.demo;
        let rows: Vec<&[f64]> = d.frames.iter().map(|f| f.joints.as_slice()).collect();
        arrays::table_out(py, &rows, d.joint_names.len())
    }

    /// τ: the output frame time of each input frame, shape (T_in,).
    #[getter]
    fn tau<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        arrays::vector_out(py, self.run.object.retime.timewarp.tau.clone())
    }

    /// Writes `DIR/<name>.demo.json`, `DIR/frames.csv` and `DIR/report.json` as one set, as
    /// `dexwarp warp --out DIR` does; returns the report written (with `outputs`).
    fn save<'py>(&self, py: Python<'py>, dir: PathBuf) -> PyResult<Bound<'py, PyAny>> {
        let names = dexwarp::output::run_file_names(&self.run.demo.name);
        let inputs: Vec<&std::path::Path> = self.inputs.iter().map(PathBuf::as_path).collect();
        let written = py
            .detach(|| {
                dexwarp::output::check_not_inputs(&dir, &names, &inputs)?;
                dexwarp::output::write_run(&dir, &self.run)
            })
            .map_err(crate::to_py)?;
        let report: dexwarp::model::report::Report = py
            .detach(|| dexwarp::model::json::read_json(&written.report, &Limits::default()))
            .map_err(crate::to_py)?;
        value::serialize(py, &report)
    }

    fn __repr__(&self) -> String {
        let r = &self.run.report;
        format!(
            "Result(name={:?}, frames_out={}, d_c_mm={:.3}, physics={})",
            r.name,
            r.frames_out,
            r.metrics.d_c_mm.warped,
            r.physics.as_ref().map_or("not run", |p| p.verdict.as_str())
        )
    }
}

/// Warps `demo` with `config` (the pipeline of `dexwarp warp`: spatial warp, barrier
/// push-out, retiming, hand recovery, smoothing, physics replay, metrics, report). The
/// config's own `demo` is not read. Keywords as the command line's flags: threshold_mm
/// overrides the config's IK threshold; hand "contact" or "baseline"; solver "lm" or
/// "adam"; physics=False skips the replay (the report's physics is None); objective
/// "non_penetrating" or "paper", penetration_weight and warm_start ("follow_object",
/// "previous" or "rigid") override the config; ensemble (K replays, 1 for a single one),
/// ensemble_seed and ensemble_max (most replays while uncertain) set the ensemble verdict.
#[pyfunction]
#[pyo3(signature = (
    demo, config, *, threshold_mm=None, hand="contact", solver="lm", physics=true,
    objective=None, penetration_weight=None, warm_start=None, ensemble=None, ensemble_seed=None, ensemble_max=None
))]
pub fn warp(
    py: Python<'_>,
    demo: &Demo,
    config: &Config,
    threshold_mm: Option<f64>,
    hand: &str,
    solver: &str,
    physics: bool,
    objective: Option<&str>,
    penetration_weight: Option<f64>,
    warm_start: Option<&str>,
    ensemble: Option<usize>,
    ensemble_seed: Option<u64>,
    ensemble_max: Option<usize>,
) -> PyResult<WarpResult> {
    let threshold_mm = threshold_mm
        .map(|t| positive_mm("threshold_mm", t))
        .transpose()?;
    let penetration_weight = match penetration_weight {
        Some(w) if !(w.is_finite() && w >= 0.0) => {
            return Err(crate::raise(
                format!(
                    "penetration_weight: the value must not be negative: a finite number >= 0, like 2; got {w}"
                ),
                None,
                Some("penetration_weight".into()),
            ));
        }
        w => w,
    };
    let options = Options::new(choice::<HandMethod>("hand", hand)?)
        .threshold_mm(threshold_mm)
        .solver(choice("solver", solver)?)
        .objective(objective.map(|o| choice("objective", o)).transpose()?)
        .penetration_weight(penetration_weight)
        .warm_start(warm_start.map(|w| choice("warm_start", w)).transpose()?)
        .physics(physics.then(|| PhysicsOptions {
            ensemble,
            ensemble_seed,
            ensemble_max,
            ..PhysicsOptions::default()
        }))
        .limits(Limits::default());
    let (config, demo) = (config.inner.clone(), demo.inner.clone());
    let (run, inputs) = py
        .detach(|| {
            let inputs = Inputs::new(config, demo, &options.limits)?;
            let run = pipeline::warp(&inputs, &options)?;
            Ok::<_, dexwarp::Error>((run, inputs.paths().map(PathBuf::from).to_vec()))
        })
        .map_err(crate::to_py)?;
    Ok(WarpResult { run, inputs })
}

/// Replays `demo` in physics and reports on it (`dexwarp validate`): the report as a dict.
/// The scene is the demonstration's own unless `scene` is given; `barriers` (scene item
/// names) default to the demonstration's; `ensemble` (K replays, 1 for a single one),
/// `ensemble_seed` and `ensemble_max` (most replays while uncertain) set the ensemble verdict.
#[pyfunction]
#[pyo3(signature = (demo, *, scene=None, barriers=None, ensemble=None, ensemble_seed=None, ensemble_max=None))]
pub fn validate<'py>(
    py: Python<'py>,
    demo: &Demo,
    scene: Option<PathBuf>,
    barriers: Option<Vec<String>>,
    ensemble: Option<usize>,
    ensemble_seed: Option<u64>,
    ensemble_max: Option<usize>,
) -> PyResult<Bound<'py, PyAny>> {
    let demo = demo.inner.clone();
    let params = PhysicsOptions {
        ensemble,
        ensemble_seed,
        ensemble_max,
        ..PhysicsOptions::default()
    }
    .apply(dexwarp::physics::Params::default());
    let (report, _) = py
        .detach(|| {
            pipeline::validate_demo(
                demo,
                scene.as_deref(),
                barriers.as_deref(),
                &params,
                &Limits::default(),
            )
        })
        .map_err(crate::to_py)?;
    value::serialize(py, &report)
}

/// `dexwarp augment`: samples `count` variations of the demonstration file `demo` from the
/// spec `variations` (`dexwarp.variations/1`), runs each with physics into `out/kept/` and
/// `out/failed/` and returns `stats.json` as a dict. `shard` is "K/N"; `jobs` 0 means one
/// worker per core. `compare_baseline` also runs every sample with the SE(3) baseline hand
/// (`stats["baseline"]`: its yield and the paired counts); `margin` also measures the
/// robustness margin of every sample that passes physics (`stats["robust"]`).
#[pyfunction]
#[pyo3(signature = (demo, variations, *, count, out, seed=0, jobs=0, shard=None, force=false, compare_baseline=false, margin=false, ensemble=None, ensemble_seed=None, ensemble_max=None))]
pub fn augment<'py>(
    py: Python<'py>,
    demo: PathBuf,
    variations: PathBuf,
    count: u64,
    out: PathBuf,
    seed: u64,
    jobs: usize,
    shard: Option<&str>,
    force: bool,
    compare_baseline: bool,
    margin: bool,
    ensemble: Option<usize>,
    ensemble_seed: Option<u64>,
    ensemble_max: Option<usize>,
) -> PyResult<Bound<'py, PyAny>> {
    let shard = shard
        .map(|s| {
            s.parse::<dexwarp::batch::Shard>()
                .map_err(|e| crate::raise(format!("shard: {e}"), None, Some("shard".into())))
        })
        .transpose()?;
    let options = dexwarp::augment::AugmentOptions {
        demo,
        variations,
        count,
        seed,
        out,
        jobs,
        shard,
        force,
        compare_baseline,
        margin,
        physics: PhysicsOptions {
            ensemble,
            ensemble_seed,
            ensemble_max,
            ..PhysicsOptions::default()
        },
        limits: Limits::default(),
        progress: false,
    };
    let aug = py
        .detach(|| dexwarp::augment::run(&options))
        .map_err(crate::to_py)?;
    value::serialize(py, &aug.stats)
}
