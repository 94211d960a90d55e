//! NumPy conversion: every getter returns a fresh C-contiguous copy (the simulation rewrites its
//! buffers in place, with the GIL released, so a view could change or tear under the reader).

use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyReadonlyArray2, PyUntypedArrayMethods};
use octoarm_physics::{Mat3, Vec3};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

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

/// Read an (expected, 3) float64 array; the error names `field` and the required shape.
pub fn read_vec3s(
    a: &PyReadonlyArray2<'_, f64>,
    field: &str,
    expected: usize,
) -> PyResult<Vec<Vec3>> {
    let shape = a.shape();
    if shape != [expected, 3] {
        return Err(PyValueError::new_err(format!(
            "{field} has shape {}, expected ({expected}, 3)",
            shape_str(shape)
        )));
    }
    let view = a.as_array();
    Ok(view
        .rows()
        .into_iter()
        .map(|r| [r[0], r[1], r[2]])
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
