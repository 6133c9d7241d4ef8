//! Python values and JSON values, both ways.
//!
//! A dict given to dexwarp (a config) becomes a `serde_json::Value`, whose text then goes
//! through the library's own JSON loader: the same checks and the same messages as a file
//! with that content. A report goes back as plain dicts, lists, floats and strings.

use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use serde_json::Value;

/// `obj` as JSON. `label` names the value in messages (`<dict>`); `field` is the JSON path of
/// `obj` in it (`waypoints[0].t`). NaN and infinity are refused with the field named (JSON has
/// neither); NumPy arrays and scalars are read through their `tolist()`; path-like objects
/// become strings.
pub fn to_json(obj: &Bound<'_, PyAny>, label: &str, field: &str) -> PyResult<Value> {
    let here = || {
        if field.is_empty() {
            "(top level)".to_string()
        } else {
            field.to_string()
        }
    };
    if obj.is_none() {
        return Ok(Value::Null);
    }
    if let Ok(b) = obj.cast::<PyBool>() {
        return Ok(Value::Bool(b.is_true()));
    }
    if obj.is_instance_of::<PyInt>() {
        if let Ok(i) = obj.extract::<i64>() {
            return Ok(Value::from(i));
        }
        if let Ok(u) = obj.extract::<u64>() {
            return Ok(Value::from(u));
        }
        return Err(crate::invalid(
            label,
            &here(),
            "is an integer too large for 64 bits",
        ));
    }
    if obj.is_instance_of::<PyFloat>() {
        let v: f64 = obj.extract()?;
        return serde_json::Number::from_f64(v)
            .map(Value::Number)
            .ok_or_else(|| {
                crate::invalid(
                    label,
                    &here(),
                    format!("is {v}; expected a finite number (JSON has no NaN or infinity)"),
                )
            });
    }
    if let Ok(s) = obj.cast::<PyString>() {
        return Ok(Value::String(s.to_str()?.to_owned()));
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        let mut map = serde_json::Map::new();
        for (k, v) in d.iter() {
            let key: String = k.extract().map_err(|_| {
                crate::invalid(
                    label,
                    &here(),
                    format!(
                        "has the key {}; expected string keys",
                        k.repr().map_or_else(|_| "?".into(), |r| r.to_string())
                    ),
                )
            })?;
            let sub = if field.is_empty() {
                key.clone()
            } else {
                format!("{field}.{key}")
            };
            map.insert(key, to_json(&v, label, &sub)?);
        }
        return Ok(Value::Object(map));
    }
    if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        let mut items = Vec::new();
        for (i, v) in obj.try_iter()?.enumerate() {
            items.push(to_json(&v?, label, &format!("{field}[{i}]"))?);
        }
        return Ok(Value::Array(items));
    }
    if obj.hasattr("tolist")? {
        return to_json(&obj.call_method0("tolist")?, label, field);
    }
    if obj.hasattr("__fspath__")? {
        return to_json(&obj.call_method0("__fspath__")?, label, field);
    }
    Err(PyTypeError::new_err(format!(
        "{label}: {}: a {} is not a JSON value; expected a dict, list, str, number, bool or None",
        here(),
        obj.get_type().name()?
    )))
}

/// A JSON value as plain Python objects (dict, list, float, int, str, bool, None).
pub fn to_py<'py>(py: Python<'py>, value: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match value {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => PyBool::new(py, *b).to_owned().into_any(),
        Value::Number(n) => {
            if let Some(i) = n.as_i64() {
                i.into_pyobject(py)?.into_any()
            } else if let Some(u) = n.as_u64() {
                u.into_pyobject(py)?.into_any()
            } else {
                n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any()
            }
        }
        Value::String(s) => PyString::new(py, s).into_any(),
        Value::Array(items) => {
            let list = PyList::empty(py);
            for v in items {
                list.append(to_py(py, v)?)?;
            }
            list.into_any()
        }
        Value::Object(map) => {
            let dict = PyDict::new(py);
            for (k, v) in map {
                dict.set_item(k, to_py(py, v)?)?;
            }
            dict.into_any()
        }
    })
}

/// A serializable value (a report, stats) as plain Python objects.
pub fn serialize<'py, T: serde::Serialize>(
    py: Python<'py>,
    value: &T,
) -> PyResult<Bound<'py, PyAny>> {
    let v = serde_json::to_value(value)
        .map_err(|e| crate::raise(format!("(output): {e}"), None, None))?;
    to_py(py, &v)
}
