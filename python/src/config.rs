//! `dexwarp.Config`: a validated warp config, from a `dexwarp.config/1` file or a dict.

use std::path::{Path, PathBuf};

use dexwarp::Limits;
use dexwarp::model::WarpConfig;
use dexwarp::model::config::{CONFIG_FORMAT, ConfigFile};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::value;

/// The label of a config built from a dict, in messages (its folder resolves the paths).
pub const DICT: &str = "<dict>";

/// A warp config (`dexwarp.config/1`): waypoints, barriers, new start and end, parameters,
/// the scene (and the demonstration it was written for).
#[pyclass(frozen, module = "dexwarp")]
#[derive(Clone, Debug)]
pub struct Config {
    pub inner: WarpConfig,
    /// The config as stored, for `to_dict`.
    pub file: ConfigFile,
}

impl Config {
    fn from_parts(file: ConfigFile, path: &Path) -> PyResult<Config> {
        let inner = WarpConfig::from_file(file.clone(), path).map_err(crate::to_py)?;
        Ok(Config { inner, file })
    }
}

#[pymethods]
impl Config {
    /// Reads and validates a config file (`dexwarp.config/1`); paths inside it are relative
    /// to it. Raises DexwarpError naming the file and field on bad input.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Config> {
        let file: ConfigFile = py
            .detach(|| {
                dexwarp::model::json::read_json_format(&path, &Limits::default(), CONFIG_FORMAT)
            })
            .map_err(crate::to_py)?;
        Config::from_parts(file, &path)
    }

    /// A config from a dict with the fields of a `dexwarp.config/1` file (`format` may be
    /// left out; so may `demo` when the demonstration is given to `warp`), checked as that
    /// file would be. Paths in it are relative to the folder of `path` (default: the current
    /// folder); messages name `path`, or `<dict>`.
    #[staticmethod]
    #[pyo3(signature = (data, *, path=None))]
    fn from_dict(data: &Bound<'_, PyDict>, path: Option<PathBuf>) -> PyResult<Config> {
        let path = path.unwrap_or_else(|| PathBuf::from(DICT));
        let label = path.display().to_string();
        let mut json = value::to_json(data.as_any(), &label, "")?;
        if let Some(map) = json.as_object_mut() {
            map.entry("format").or_insert_with(|| CONFIG_FORMAT.into());
            map.entry("demo").or_insert_with(|| "".into());
        }
        let text =
            serde_json::to_vec(&json).map_err(|e| crate::raise(e.to_string(), None, None))?;
        let file: ConfigFile =
            dexwarp::model::json::parse_json(&path, &text).map_err(crate::to_py)?;
        Config::from_parts(file, &path)
    }

    /// The config as a dict with the fields of its file (paths as written in it).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        value::serialize(py, &self.file)
    }

    /// Name of the config (names the outputs).
    #[getter]
    fn name(&self) -> &str {
        &self.inner.name
    }

    /// The demonstration the config was written for (resolved path), or None.
    #[getter]
    fn demo(&self) -> Option<PathBuf> {
        (!self.file.demo.as_os_str().is_empty()).then(|| self.inner.demo.clone())
    }

    /// Scene file (resolved path).
    #[getter]
    fn scene(&self) -> PathBuf {
        self.inner.scene.clone()
    }

    /// Barrier names (scene items the object and hand must avoid).
    #[getter]
    fn barriers(&self) -> Vec<String> {
        self.inner.barriers.clone()
    }

    /// The file the config was read from (`<dict>`, or the `path` given, for a dict).
    #[getter]
    fn source(&self) -> PathBuf {
        self.inner.source.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "Config(name={:?}, waypoints={}, barriers={:?}, source={:?})",
            self.inner.name,
            self.inner.waypoints.len(),
            self.inner.barriers,
            self.inner.source.display().to_string()
        )
    }
}
