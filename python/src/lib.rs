//! `dexwarp._dexwarp`: the Python binding of dexwarp (PyO3).
//!
//! The same library as the command line, called in-process: [`Demo`] and [`Config`] wrap the
//! validated model types (loaded from files, or built from NumPy arrays and dicts through the
//! same validation as a file), [`warp`] and [`validate`] run `pipeline::warp` and
//! `pipeline::validate_demo` with the GIL released, and the outputs come back as NumPy arrays
//! and the report as a dict (the JSON `dexwarp warp` writes, parsed).
//!
//! Every refusal of dexwarp is raised as `dexwarp.DexwarpError` with the command line's
//! message (file, field, what was expected) and the `path` and `field` as attributes.

mod arrays;
mod config;
mod demo;
mod run;
mod value;

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    dexwarp,
    DexwarpError,
    PyException,
    "An input dexwarp refuses, or a run that failed: the message names the file, the field and \
     what was expected, as the command line's does; `path` and `field` hold the first two \
     (None when the error has none)."
);

/// The error text of the command line (`main.rs`): the error, then each cause the text does
/// not already contain.
fn error_text(err: &dyn std::error::Error) -> String {
    let mut text = err.to_string();
    let mut cause = err.source();
    while let Some(c) = cause {
        let c_text = c.to_string();
        if !text.contains(&c_text) {
            text.push_str(": ");
            text.push_str(&c_text);
        }
        cause = c.source();
    }
    text
}

/// A library error as a [`DexwarpError`] carrying its message, `path` and `field`.
pub(crate) fn to_py(err: dexwarp::Error) -> PyErr {
    use dexwarp::Error as E;
    let (path, field) = match &err {
        E::Parse { path, field, .. }
        | E::Invalid { path, field, .. }
        | E::Unsupported { path, field, .. } => (Some(path.clone()), Some(field.clone())),
        E::Io { path, .. } | E::TooLarge { path, .. } | E::NonFinite { path, .. } => {
            (Some(path.clone()), None)
        }
    };
    raise(
        error_text(&err),
        path.map(|p| p.display().to_string()),
        field,
    )
}

/// A [`DexwarpError`] with `message`, `path` and `field`.
pub(crate) fn raise(message: String, path: Option<String>, field: Option<String>) -> PyErr {
    Python::attach(|py| {
        let err = DexwarpError::new_err(message);
        let value = err.value(py);
        // Setting attributes on a fresh exception instance cannot fail but for memory.
        let _ = value.setattr("path", path);
        let _ = value.setattr("field", field);
        err
    })
}

/// An input error of a value given in Python (no file): `path` is the label of the value
/// (`<arrays>`, `<dict>`), `field` the argument or key.
pub(crate) fn invalid(path: &str, field: &str, message: impl Into<String>) -> PyErr {
    to_py(dexwarp::Error::invalid(
        std::path::Path::new(path),
        field,
        message,
    ))
}

#[pymodule]
fn _dexwarp(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("DexwarpError", m.py().get_type::<DexwarpError>())?;
    m.add_class::<demo::Demo>()?;
    m.add_class::<config::Config>()?;
    m.add_class::<run::WarpResult>()?;
    m.add_function(wrap_pyfunction!(run::warp, m)?)?;
    m.add_function(wrap_pyfunction!(run::validate, m)?)?;
    m.add_function(wrap_pyfunction!(run::augment, m)?)?;
    Ok(())
}
