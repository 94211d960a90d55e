//! NumPy conversion: every getter returns a fresh C-contiguous copy (the simulation rewrites its
//! buffers in place, with the GIL released, so a view could change or tear under the reader), and
//! every array argument is read through `read_array`, which accepts any array-like, requires the
//! exact shape (never reshapes) and finite entries, converts any real dtype to float64, and
//! names the argument in its errors.

use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArray3, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods,
};
use octoarm_physics::{Mat3, Vec3};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Two (len, 3) arrays, e.g. strains σ and κ.
pub type ArrayPair<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>);

/// (len, 3) float64 copy of a list of vectors.
pub fn vec3s<'py>(py: Python<'py>, v: &[Vec3]) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_vec((v.len(), 3), v.as_flattened().to_vec())
        .expect("shape matches length")
        .into_pyarray(py)
}

/// (len, 3, 3) float64 copy of a list of matrices.
pub fn mat3s<'py>(py: Python<'py>, v: &[Mat3]) -> Bound<'py, PyArray3<f64>> {
    let flat: Vec<f64> = v
        .iter()
        .flat_map(|m| m.as_flattened().iter().copied())
        .collect();
    Array3::from_shape_vec((v.len(), 3, 3), flat)
        .expect("shape matches length")
        .into_pyarray(py)
}

/// 1-D float64 copy.
pub fn scalars<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyArray1<f64>> {
    Array1::from_vec(v.to_vec()).into_pyarray(py)
}

/// An array-like argument as a float64 array: its shape and entries (row-major).
/// Any real dtype is accepted and converted to float64 (float16/32/64/128, signed and unsigned
/// integers, object arrays of numbers); booleans, complex numbers, strings, dates and other
/// non-numbers are refused. Never reshapes.
/// Errors (`ValueError`) name `field`.
fn as_f64_array(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<(Vec<usize>, Vec<f64>)> {
    if let Ok(arr) = obj.cast::<PyArrayDyn<f64>>() {
        // Fast path (the usual case): already float64.
        let arr = arr.readonly();
        return Ok((
            arr.shape().to_vec(),
            arr.as_array().iter().copied().collect(),
        ));
    }
    let py = obj.py();
    let numpy = py.import("numpy")?;
    let not_numbers =
        |e: PyErr| PyValueError::new_err(format!("{field} is not an array of numbers: {e}"));
    let raw = numpy.call_method1("asarray", (obj,)).map_err(not_numbers)?;
    let dtype = raw.getattr("dtype")?;
    let kind: String = dtype.getattr("kind")?.extract()?;
    // f: floats, i / u: integers, O: objects (e.g. a list mixing numbers and other objects).
    if !matches!(kind.as_str(), "f" | "i" | "u" | "O") {
        return Err(PyValueError::new_err(format!(
            "{field} has dtype {}; expected real numbers (any float or integer dtype, converted \
             to float64)",
            dtype.str()?
        )));
    }
    // Object arrays go through float() entry by entry, which refuses complex numbers and
    // non-numbers (a ValueError naming the field).
    let converted = numpy
        .call_method1("asarray", (&raw, "float64"))
        .map_err(not_numbers)?;
    let arr = converted.cast::<PyArrayDyn<f64>>()?.readonly();
    let shape = arr.shape().to_vec();
    let view = arr.as_array();
    Ok((shape, view.iter().copied().collect()))
}

/// Refuse a non-finite entry of an array of shape `shape`, naming `field` and the entry's index,
/// e.g. "actions must be finite: entry [1, 2] is NaN".
fn check_finite(field: &str, shape: &[usize], values: &[f64]) -> PyResult<()> {
    let Some((flat, v)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) else {
        return Ok(());
    };
    let mut index = Vec::with_capacity(shape.len());
    let mut rest = flat;
    for d in shape.iter().rev() {
        index.push(rest % d);
        rest /= d;
    }
    index.reverse();
    let index: Vec<String> = index.iter().map(|i| i.to_string()).collect();
    Err(PyValueError::new_err(format!(
        "{field} must be finite: entry [{}] is {v}",
        index.join(", ")
    )))
}

/// Read an array-like of exactly the shape `expected` (float64, finite, row-major entries). The
/// error names `field`, the shape given and the one required, e.g. "positions has shape (3,),
/// expected (101, 3)".
pub fn read_array(obj: &Bound<'_, PyAny>, field: &str, expected: &[usize]) -> PyResult<Vec<f64>> {
    let (shape, values) = as_f64_array(obj, field)?;
    if shape != expected {
        return Err(PyValueError::new_err(format!(
            "{field} has shape {}, expected {}",
            shape_str(&shape),
            shape_str(expected)
        )));
    }
    check_finite(field, &shape, &values)?;
    Ok(values)
}

/// Read an array-like of any shape (float64, finite): its shape and row-major entries.
pub fn read_any(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<(Vec<usize>, Vec<f64>)> {
    let (shape, values) = as_f64_array(obj, field)?;
    check_finite(field, &shape, &values)?;
    Ok((shape, values))
}

/// Read a 1-D array-like of any length (float64, finite).
pub fn read_vector(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<Vec<f64>> {
    let (shape, values) = as_f64_array(obj, field)?;
    if shape.len() != 1 {
        return Err(PyValueError::new_err(format!(
            "{field} has shape {}, expected (k,): one dimension",
            shape_str(&shape)
        )));
    }
    check_finite(field, &shape, &values)?;
    Ok(values)
}

/// Read a 3-vector argument (any array-like of 3 real numbers, finite); the errors name `field`.
pub fn read_vec3(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<Vec3> {
    let v = read_array(obj, field, &[3])?;
    Ok([v[0], v[1], v[2]])
}

/// Read an optional 3-vector argument, `default` when None.
pub fn read_vec3_or(obj: Option<&Bound<'_, PyAny>>, field: &str, default: Vec3) -> PyResult<Vec3> {
    obj.map_or(Ok(default), |o| read_vec3(o, field))
}

/// Read an (expected, 3) array-like of vectors.
pub fn read_vec3s(obj: &Bound<'_, PyAny>, field: &str, expected: usize) -> PyResult<Vec<Vec3>> {
    let flat = read_array(obj, field, &[expected, 3])?;
    Ok(flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
}

/// Read an (expected, 3, 3) array-like of matrices.
pub fn read_mat3s(obj: &Bound<'_, PyAny>, field: &str, expected: usize) -> PyResult<Vec<Mat3>> {
    let flat = read_array(obj, field, &[expected, 3, 3])?;
    Ok(flat
        .chunks_exact(9)
        .map(|c| [[c[0], c[1], c[2]], [c[3], c[4], c[5]], [c[6], c[7], c[8]]])
        .collect())
}

/// A NumPy-style shape, e.g. "(3, 3)".
pub fn shape_str(shape: &[usize]) -> String {
    let parts: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    if parts.len() == 1 {
        format!("({},)", parts[0])
    } else {
        format!("({})", parts.join(", "))
    }
}
