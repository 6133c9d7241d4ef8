//! NumPy arrays in and out.
//!
//! In: anything `numpy.asarray(x, dtype=float64)` accepts (arrays of any float or int dtype,
//! nested lists), checked for its shape with the argument named. Out: new C-ordered float64
//! arrays owned by Python.

use numpy::ndarray::Array2;
use numpy::{
    AllowTypeChange, IntoPyArray, PyArray1, PyArray2, PyArrayLikeDyn, PyUntypedArrayMethods,
};
use pyo3::prelude::*;

/// A 2-D array of `rows x cols` float64 read in row order; `rows = None` takes any count.
/// `label` names the value (`<arrays>`), `arg` the argument.
pub fn matrix(
    obj: &Bound<'_, PyAny>,
    label: &str,
    arg: &str,
    rows: Option<usize>,
    cols: usize,
) -> PyResult<(usize, Vec<f64>)> {
    let expected = match rows {
        Some(r) => format!("an array of shape ({r}, {cols})"),
        None => format!("an array of shape (N, {cols})"),
    };
    let a = obj
        .extract::<PyArrayLikeDyn<'_, f64, AllowTypeChange>>()
        .map_err(|_| {
            crate::invalid(
                label,
                arg,
                format!("is not an array of numbers; expected {expected}"),
            )
        })?;
    let shape = a.shape().to_vec();
    let ok = shape.len() == 2 && shape[1] == cols && rows.is_none_or(|r| shape[0] == r);
    // An empty list of rows reads as shape (0,): accept it where any count is.
    let empty = rows.is_none() && shape == [0];
    if !ok && !empty {
        return Err(crate::invalid(
            label,
            arg,
            format!("has shape {}; expected {expected}", shape_text(&shape)),
        ));
    }
    let values: Vec<f64> = a.as_array().iter().copied().collect();
    Ok((if empty { 0 } else { shape[0] }, values))
}

/// A 1-D array of float64 (`len = None` takes any length).
pub fn vector(
    obj: &Bound<'_, PyAny>,
    label: &str,
    arg: &str,
    len: Option<usize>,
) -> PyResult<Vec<f64>> {
    let expected = match len {
        Some(n) => format!("an array of shape ({n},)"),
        None => "a one-dimensional array".to_string(),
    };
    let a = obj
        .extract::<PyArrayLikeDyn<'_, f64, AllowTypeChange>>()
        .map_err(|_| {
            crate::invalid(
                label,
                arg,
                format!("is not an array of numbers; expected {expected}"),
            )
        })?;
    let shape = a.shape().to_vec();
    if shape.len() != 1 || len.is_some_and(|n| shape[0] != n) {
        return Err(crate::invalid(
            label,
            arg,
            format!("has shape {}; expected {expected}", shape_text(&shape)),
        ));
    }
    Ok(a.as_array().iter().copied().collect())
}

fn shape_text(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(|n| n.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// `rows` rows of `N` values as an `(rows, N)` array.
pub fn rows_out<'py, const N: usize>(
    py: Python<'py>,
    rows: impl ExactSizeIterator<Item = [f64; N]>,
) -> Bound<'py, PyArray2<f64>> {
    let n = rows.len();
    let flat: Vec<f64> = rows.flatten().collect();
    Array2::from_shape_vec((n, N), flat)
        .expect("n rows of N values")
        .into_pyarray(py)
}

/// Rows of `cols` values each (joint vectors) as an `(rows, cols)` array.
pub fn table_out<'py>(py: Python<'py>, rows: &[&[f64]], cols: usize) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = rows.iter().flat_map(|r| r.iter().copied()).collect();
    Array2::from_shape_vec((rows.len(), cols), flat)
        .expect("every row has cols values")
        .into_pyarray(py)
}

/// A vector as a 1-D array.
pub fn vector_out<'py>(py: Python<'py>, v: Vec<f64>) -> Bound<'py, PyArray1<f64>> {
    v.into_pyarray(py)
}
