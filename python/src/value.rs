//! Python values as JSON values: keyword arguments become the name/value
//! pairs of `volscene::Request::from_pairs` (and of the other tools'
//! options), so the options' names and parsing stay in one place.

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use serde_json::Value;

/// `v` as JSON: None, bools, ints, floats, strings, paths (`os.PathLike`),
/// lists and tuples, dicts with string keys, and numpy scalars and arrays
/// (through `.tolist()`).
pub fn to_json(v: &Bound<'_, PyAny>) -> PyResult<Value> {
    if v.is_none() {
        return Ok(Value::Null);
    }
    if v.is_instance_of::<PyBool>() {
        return Ok(Value::Bool(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        if let Ok(i) = v.extract::<i64>() {
            return Ok(Value::from(i));
        }
        return Ok(Value::from(v.extract::<u64>()?));
    }
    if v.is_instance_of::<PyFloat>() {
        let f: f64 = v.extract()?;
        return serde_json::Number::from_f64(f)
            .map(Value::Number)
            .ok_or_else(|| crate::errors::value(format!("{f} is not a finite number")));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(Value::String(v.extract()?));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let items = v
            .try_iter()?
            .map(|i| to_json(&i?))
            .collect::<PyResult<Vec<_>>>()?;
        return Ok(Value::Array(items));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut map = serde_json::Map::new();
        for (k, item) in d.iter() {
            let key: String = k
                .extract()
                .map_err(|_| crate::errors::value("dictionary keys must be strings"))?;
            map.insert(key, to_json(&item)?);
        }
        return Ok(Value::Object(map));
    }
    if v.hasattr("__fspath__")? {
        let os = v.py().import("os")?;
        let p = os.call_method1("fspath", (v,))?;
        return to_json(&p);
    }
    if v.hasattr("tolist")? {
        return to_json(&v.call_method0("tolist")?);
    }
    Err(crate::errors::value(format!(
        "cannot pass a {} as an option value",
        v.get_type().name()?
    )))
}

/// Keyword arguments as name/value pairs, in the order given.
pub fn pairs(kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<(String, Value)>> {
    let mut out = Vec::new();
    if let Some(kw) = kwargs {
        for (k, v) in kw.iter() {
            out.push((k.extract::<String>()?, to_json(&v)?));
        }
    }
    Ok(out)
}

/// A JSON value as a Python object (for reports).
pub fn to_py<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
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
            for i in items {
                list.append(to_py(py, i)?)?;
            }
            list.into_any()
        }
        Value::Object(map) => {
            let d = PyDict::new(py);
            for (k, i) in map {
                d.set_item(k, to_py(py, i)?)?;
            }
            d.into_any()
        }
    })
}
