//! octoarm-python: the `octoarm._octoarm` extension module. Thin bindings only: argument
//! conversion, NumPy array conversion and error mapping; all physics lives in octoarm-physics,
//! all control in octoarm-control, scenario runs in the application's library (`octoarm`,
//! linked without its command line). The Python package (`python/octoarm`) adds the Gymnasium
//! environments on top of `ArmBatch`.
//!
//! Modules: `arrays` (NumPy conversion and shape checks), `system` (the rod-system description
//! classes `Rod`, `Motion`, `Joint`), `rod` (`Simulation`: one rod or a system of rods, its
//! state, loads, damping, rest strains and pickling), `control` (solver, design, energy-shaping
//! law), `env` (`ArmBatch`), `muscle` (COOMM's muscular arm: `MuscleDesign`,
//! `MuscleShapingController`), `muscle_env` (`MuscleBatch`, the physics of
//! `octoarm/MuscleReach3D-v0`), `scenario` (`run_scenario`), `sweep` (`Sweep`: a parameter
//! sweep's plan and folder, for `octoarm.sweep`).

// `octoarm_physics::StepError` (≥ 128 bytes: it names the rod and carries advice) is passed
// through as it is, once per failed run; boxing it here would only add a conversion.
#![allow(clippy::result_large_err)]

use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::MutexExt;
use std::sync::{Mutex, MutexGuard, PoisonError};

mod arrays;
mod control;
mod env;
mod muscle;
mod muscle_env;
mod rod;
mod scenario;
mod sweep;
mod system;

create_exception!(
    octoarm,
    InstabilityError,
    PyRuntimeError,
    "The stability guard stopped a simulation. Attributes: `what`, `value`, `domain` \
     (\"node\", \"element\" or \"voronoi point\"), `index`, `element` (= `index`), `rod` (the \
     rod's name in a system of several rods, else None), `time` [s], `step`, `dt` [s], \
     `suggested_dt` [s], `advice`. The simulation keeps the state at which the guard fired. \
     Raised by `run_scenario`, it also has `report`, the run's dict (outputs are written)."
);

/// Lock one of the mutexes that make the classes thread-safe, from a thread attached to Python:
/// if another thread holds it (stepping with the GIL released), wait with the GIL released, so
/// that the two cannot deadlock. Never call Python while holding the guard. A panic inside the
/// physics poisons nothing here: the state stays as the panic left it (as without the lock).
pub(crate) fn lock<'a, T>(py: Python<'_>, m: &'a Mutex<T>) -> MutexGuard<'a, T> {
    m.lock_py_attached(py)
        .unwrap_or_else(PoisonError::into_inner)
}

/// Lock such a mutex inside `py.detach` (GIL released).
pub(crate) fn lock_detached<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Map a physics input error to `ValueError`; its text names the argument, value and range.
pub(crate) fn model_error(e: octoarm_physics::ModelError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// Map a step error to `InstabilityError` carrying its fields as attributes.
pub(crate) fn step_error(py: Python<'_>, e: octoarm_physics::StepError) -> PyErr {
    let msg = e.to_string();
    let err = InstabilityError::new_err(msg);
    let octoarm_physics::StepError::Unstable {
        what,
        value,
        domain,
        index,
        rod,
        time,
        step,
        dt,
        suggested_dt,
        advice,
    } = e;
    let v = err.value(py);
    let set = |k: &str, o: Bound<'_, PyAny>| {
        let _ = v.setattr(k, o);
    };
    set("what", what.into_pyobject(py).unwrap().into_any());
    set("value", value.into_pyobject(py).unwrap().into_any());
    set("domain", domain.into_pyobject(py).unwrap().into_any());
    set("index", index.into_pyobject(py).unwrap().into_any());
    set("element", index.into_pyobject(py).unwrap().into_any());
    set("rod", rod.as_deref().into_pyobject(py).unwrap().into_any());
    set("time", time.into_pyobject(py).unwrap().into_any());
    set("step", step.into_pyobject(py).unwrap().into_any());
    set("dt", dt.into_pyobject(py).unwrap().into_any());
    set(
        "suggested_dt",
        suggested_dt.into_pyobject(py).unwrap().into_any(),
    );
    set("advice", advice.into_pyobject(py).unwrap().into_any());
    err
}

#[pymodule]
fn _octoarm(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("InstabilityError", m.py().get_type::<InstabilityError>())?;
    m.add_class::<rod::Simulation>()?;
    m.add_class::<system::Rod>()?;
    m.add_class::<system::Motion>()?;
    m.add_class::<system::Joint>()?;
    m.add_class::<control::Design>()?;
    m.add_class::<control::OfflineSolver>()?;
    m.add_class::<control::EnergyShapingController>()?;
    m.add_class::<env::ArmBatch>()?;
    m.add_class::<muscle::MuscleDesign>()?;
    m.add_class::<muscle::MuscleShapingController>()?;
    m.add_class::<muscle_env::MuscleBatch>()?;
    m.add_class::<sweep::Sweep>()?;
    m.add_function(wrap_pyfunction!(rod::rust_step_rate, m)?)?;
    m.add_function(wrap_pyfunction!(rod::simulation_from_bytes, m)?)?;
    m.add_function(wrap_pyfunction!(scenario::run_scenario, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
