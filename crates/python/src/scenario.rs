//! `run_scenario`: the command line's `octoarm run` from Python, through the application's
//! library (the same loader, `pipeline::prepare`, `pipeline::run`, recorders and writers), so
//! `trajectory.npz` and `distance.csv` are the binary's to the last bit. Passive and controlled
//! scenarios alike; no figures (the library draws none).

use crate::step_error;
use octoarm_app::output::OutputDir;
use octoarm_app::pipeline::{self, Failure, RunOptions};
use octoarm_app::scenario::Scenario;
use pyo3::exceptions::{
    PyKeyboardInterrupt, PyOSError, PyRuntimeError, PyUserWarning, PyValueError,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::ffi::CString;
use std::path::PathBuf;

/// Run the scenario file `path` (passive or controlled) and write its outputs to `out_dir`
/// (default: the command line's, results/<name>), exactly as `octoarm run [--duration D] --out
/// OUT_DIR PATH` does, with the GIL released: trajectory.npz, summary.json, scenario.toml, and
/// for a controlled run series.npz and distance.csv (no figures). The command line's warnings
/// about the scenario are issued as `UserWarning`s.
///
/// Returns a dict: out_dir, steps, planned_steps, frames, wall_seconds, loop_seconds, status
/// ("completed"), controlled (bool) and, for a controlled run, final_distance (d / L0 at the
/// end). A bad scenario raises `ValueError` (file:line:col: message), an output-directory
/// problem `OSError`; a run stopped by the stability guard raises `InstabilityError` and a
/// controller failure `RuntimeError`, both after writing what was recorded, with the dict as
/// their `report` attribute (status "unstable" / "failed").
#[pyfunction]
#[pyo3(signature = (path, out_dir = None, duration = None))]
pub fn run_scenario<'py>(
    py: Python<'py>,
    path: PathBuf,
    out_dir: Option<PathBuf>,
    duration: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let bad = |e: &dyn std::fmt::Display| PyValueError::new_err(e.to_string());
    let mut scn = Scenario::load(&path).map_err(|e| bad(&e))?;
    if let Some(d) = duration {
        octoarm_app::override_duration(&mut scn, d).map_err(|e| bad(&e))?;
    }
    // Everything about the input is checked (offline designs solved) before the output
    // directory is touched, as on the command line.
    let prepared = py.detach(|| pipeline::prepare(&scn)).map_err(|e| bad(&e))?;
    let category = py.get_type::<PyUserWarning>();
    for warning in octoarm_app::advisories(&scn, &prepared.system, &prepared.state) {
        let msg = CString::new(warning.replace('\0', " ")).expect("no NUL left");
        PyErr::warn(py, &category, &msg, 1)?;
    }
    let target = out_dir.unwrap_or_else(|| octoarm_app::default_out_dir(&scn));
    let out = OutputDir::prepare(&target).map_err(|e| PyOSError::new_err(e.to_string()))?;
    let controlled = scn.config.controller.is_some();
    let report = py
        .detach(|| {
            let opts = RunOptions {
                progress: None,
                figures: None,
                stop: None,
            };
            pipeline::run(&scn, prepared, out, &opts)
        })
        .map_err(|e| PyOSError::new_err(format!("{e:#}")))?;
    let status = match &report.failure {
        None => "completed",
        Some(Failure::Unstable(_)) => "unstable",
        Some(Failure::Control(_)) => "failed",
        Some(Failure::Interrupted(_)) => "interrupted",
    };
    let d = PyDict::new(py);
    d.set_item("out_dir", &report.out_dir)?;
    d.set_item("steps", report.steps)?;
    d.set_item("planned_steps", report.planned_steps)?;
    d.set_item("frames", report.frames)?;
    d.set_item("wall_seconds", report.wall_seconds)?;
    d.set_item("loop_seconds", report.loop_seconds)?;
    d.set_item("status", status)?;
    d.set_item("controlled", controlled)?;
    if controlled {
        let final_distance = report
            .data
            .series
            .as_ref()
            .and_then(|s| s.summary.as_ref())
            .map_or(f64::NAN, |s| s.final_distance);
        d.set_item("final_distance", final_distance)?;
    }
    let err = match report.failure {
        None => return Ok(d),
        Some(Failure::Unstable(e)) => step_error(py, e),
        Some(Failure::Control(msg)) => PyRuntimeError::new_err(format!("controller: {msg}")),
        // Not reached: no stop flag is passed (`RunOptions::stop` is None).
        Some(Failure::Interrupted(sig)) => {
            PyKeyboardInterrupt::new_err(format!("interrupted by signal {sig}"))
        }
    };
    err.value(py).setattr("report", d)?;
    Err(err)
}
