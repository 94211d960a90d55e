//! `run_scenario`: the command line's `octoarm run` from Python, through the app crate's library
//! (same loader, runner and writers), so `trajectory.npz` is the binary's to the last bit.

use crate::step_error;
use octoarm_app::output::OutputDir;
use octoarm_app::runner::{self, RunOptions};
use octoarm_app::scenario::Scenario;
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// Run the scenario file `path` and write its outputs (trajectory.npz, summary.json,
/// scenario.toml, figures unless `figures=False`) to `out_dir` (default: the command line's
/// default), exactly as `octoarm run [--duration D] --out OUT_DIR PATH` does (GIL released).
/// Returns a dict (out_dir, steps, planned_steps, frames, wall_seconds). A bad scenario raises
/// `ValueError`, an output-directory problem `OSError`, and a run stopped by the stability guard
/// `InstabilityError` after the frames recorded so far are written.
#[pyfunction]
#[pyo3(signature = (path, out_dir = None, duration = None, figures = true))]
pub fn run_scenario<'py>(
    py: Python<'py>,
    path: PathBuf,
    out_dir: Option<PathBuf>,
    duration: Option<f64>,
    figures: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let mut scn = Scenario::load(&path).map_err(|e| PyValueError::new_err(format!("{e:#}")))?;
    if let Some(d) = duration {
        octoarm_app::override_duration(&mut scn, d)
            .map_err(|e| PyValueError::new_err(format!("{e:#}")))?;
    }
    runner::build_simulation(&scn).map_err(|e| PyValueError::new_err(format!("{e:#}")))?;
    let target = out_dir.unwrap_or_else(|| octoarm_app::default_out_dir(&scn));
    let out = OutputDir::prepare(&target).map_err(|e| PyOSError::new_err(format!("{e:#}")))?;
    let opts = RunOptions {
        progress: false,
        no_figures: !figures,
    };
    let report = py
        .detach(|| runner::run(&scn, out, opts))
        .map_err(|e| PyOSError::new_err(format!("{e:#}")))?;
    if let Some(failure) = report.failure {
        return Err(step_error(py, failure));
    }
    let d = PyDict::new(py);
    d.set_item("out_dir", report.out_dir)?;
    d.set_item("steps", report.steps)?;
    d.set_item("planned_steps", report.planned_steps)?;
    d.set_item("frames", report.frames)?;
    d.set_item("wall_seconds", report.wall_seconds)?;
    Ok(d)
}
