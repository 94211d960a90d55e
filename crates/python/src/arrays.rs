//! NumPy conversion: every getter returns a fresh C-contiguous copy (the simulation rewrites its
//! buffers in place, with the GIL released, so a view could change or tear under the reader), and
//! every array argument is read through `read_array`, which accepts any array-like, requires the
//! exact shape (never reshapes) and finite entries, and names the argument in its errors.

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

/// An array-like argument as a float64 array with its shape and entries (row-major), finite.
/// Errors name `field`.
fn as_f64_array(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<(Vec<usize>, Vec<f64>)> {
    let py = obj.py();
    let converted = py
        .import("numpy")?
        .call_method1("asarray", (obj, "float64"))
        .map_err(|e| PyValueError::new_err(format!("{field} is not an array of numbers: {e}")))?;
    let arr = converted.cast::<PyArrayDyn<f64>>()?.readonly();
    let shape = arr.shape().to_vec();
    let view = arr.as_array();
    let values: Vec<f64> = view.iter().copied().collect();
    if let Some((flat, v)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        let mut index = Vec::with_capacity(shape.len());
        let mut rest = flat;
        for d in shape.iter().rev() {
            index.push(rest % d);
            rest /= d;
        }
        index.reverse();
        let index: Vec<String> = index.iter().map(|i| i.to_string()).collect();
        return Err(PyValueError::new_err(format!(
            "{field} must be finite: entry [{}] is {v}",
            index.join(", ")
        )));
    }
    Ok((shape, values))
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
    Ok(values)
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
    Ok(values)
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
