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
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::sync::Mutex;
use std::time::Duration;

/// The signal number recorded for an interrupt from Python (SIGINT).
const SIGINT: usize = 2;

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
/// their `report` attribute (status "unstable" / "failed"). Ctrl-C stops the run at the current
/// step: what was recorded is written (status "interrupted") and `KeyboardInterrupt` is raised
/// with the report attached.
///
/// `source`, if given, is the scenario's text: `path` then only names it (messages, the
/// default output folder, `scenario.toml`'s header, relative file references) and is not read.
/// A sweep's Ray workers run each scenario this way.
#[pyfunction]
#[pyo3(signature = (path, out_dir = None, duration = None, *, source = None))]
pub fn run_scenario<'py>(
    py: Python<'py>,
    path: PathBuf,
    out_dir: Option<PathBuf>,
    duration: Option<f64>,
    source: Option<String>,
) -> PyResult<Bound<'py, PyDict>> {
    let bad = |e: &dyn std::fmt::Display| PyValueError::new_err(e.to_string());
    let mut scn = match &source {
        Some(text) => Scenario::from_str(&path, text),
        None => Scenario::load(&path),
    }
    .map_err(|e| bad(&e))?;
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
    // The run goes on a worker thread while this one waits with the GIL released and, every
    // 50 ms, lets Python handle signals: Ctrl-C (or any handler that raises) sets the stop flag,
    // the run records the state it stopped at and writes its outputs, and the handler's
    // exception (KeyboardInterrupt) is raised with the report attached.
    let stop = AtomicUsize::new(0);
    let mut pending: Option<PyErr> = None;
    let report = std::thread::scope(|s| {
        let (tx, rx) = mpsc::channel();
        // In a mutex only so that the waiting closure may borrow it across `detach`.
        let rx = Mutex::new(rx);
        let stop = &stop;
        s.spawn(move || {
            let opts = RunOptions {
                progress: None,
                figures: None,
                stop: Some(stop),
            };
            // The receiver outlives the scope's threads, so the send cannot fail.
            let _ = tx.send(pipeline::run(&scn, prepared, out, &opts));
        });
        loop {
            match py.detach(|| recv(&rx)) {
                Ok(result) => break Some(result),
                Err(RecvTimeoutError::Timeout) => {
                    if pending.is_none() {
                        if let Err(e) = py.check_signals() {
                            pending = Some(e);
                            stop.store(SIGINT, Ordering::SeqCst);
                        }
                    }
                }
                // Only if the worker panicked; the scope then re-raises its panic.
                Err(RecvTimeoutError::Disconnected) => break None,
            }
        }
    })
    .ok_or_else(|| PyRuntimeError::new_err("the run's thread ended without a result"))?
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
        Some(Failure::Interrupted(sig)) => pending.unwrap_or_else(|| {
            PyKeyboardInterrupt::new_err(format!("interrupted by signal {sig}"))
        }),
    };
    err.value(py).setattr("report", d)?;
    Err(err)
}

/// Wait up to 50 ms for the run's result.
fn recv<T>(rx: &Mutex<Receiver<T>>) -> Result<T, RecvTimeoutError> {
    let rx = rx.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    rx.recv_timeout(Duration::from_millis(50))
}
