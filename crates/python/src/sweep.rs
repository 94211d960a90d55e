//! `Sweep`: a parameter sweep's plan and output folder from the application's library (the same
//! code as `octoarm sweep`): runs executed locally in Rust threads, or handed to Python (the Ray
//! executor in `octoarm/sweep.py`) and committed back as staged files. Thin: no sweep logic here.

use octoarm_app::sweep::{self, Outcome, Row, SweepDir, SweepPlan};
use pyo3::exceptions::{PyIndexError, PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// The signal number recorded for an interrupt from Python (SIGINT).
const SIGINT: usize = 2;

/// A sweep planned and its output folder prepared (locked until `finish` or deletion).
///
/// `Sweep(sweep_file, out=None, *, resume=False, duration=None)`: reads the sweep file and its
/// base scenario, checks every run (`ValueError` with file:line:col for a bad sweep file), and
/// prepares `out` (default results/<sweep file stem>; `OSError` if it is not usable; an
/// earlier sweep there needs `resume=True`). Then run the `pending` runs with `run_local` or
/// elsewhere (`run_source`, `commit_staged`, `record_failure`), and `finish`.
#[pyclass(module = "octoarm._octoarm")]
pub struct Sweep {
    plan: SweepPlan,
    dir: Option<SweepDir>,
    pending: Vec<usize>,
    start: Instant,
}

fn row_dict<'py>(py: Python<'py>, row: &Row) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("run", row.index)?;
    d.set_item("id", &row.id)?;
    d.set_item("status", &row.status)?;
    d.set_item("error", &row.error)?;
    Ok(d)
}

impl Sweep {
    fn dir(&self) -> PyResult<&SweepDir> {
        self.dir
            .as_ref()
            .ok_or_else(|| PyRuntimeError::new_err("the sweep is finished"))
    }

    fn check_index(&self, index: usize) -> PyResult<()> {
        if index < self.plan.runs.len() {
            Ok(())
        } else {
            Err(PyIndexError::new_err(format!(
                "index = {index} is outside the allowed range [0, {}]",
                self.plan.runs.len().saturating_sub(1)
            )))
        }
    }
}

#[pymethods]
impl Sweep {
    #[new]
    #[pyo3(signature = (sweep_file, out = None, *, resume = false, duration = None))]
    fn new(
        py: Python<'_>,
        sweep_file: PathBuf,
        out: Option<PathBuf>,
        resume: bool,
        duration: Option<f64>,
    ) -> PyResult<Self> {
        let start = Instant::now();
        let plan = py
            .detach(|| SweepPlan::load(&sweep_file, duration))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let out = out.unwrap_or_else(|| {
            PathBuf::from("results").join(
                sweep_file
                    .file_stem()
                    .map_or_else(|| "sweep".into(), |s| s.to_string_lossy().into_owned()),
            )
        });
        let (dir, pending) = SweepDir::prepare(&out, &plan, resume)
            .map_err(|e| PyOSError::new_err(e.to_string()))?;
        Ok(Self {
            plan,
            dir: Some(dir),
            pending,
            start,
        })
    }

    /// The output folder.
    #[getter]
    fn out(&self) -> PyResult<String> {
        Ok(self.dir()?.root().display().to_string())
    }

    /// Number of runs in the plan.
    #[getter]
    fn n_runs(&self) -> usize {
        self.plan.runs.len()
    }

    /// Plan indices of the runs to execute (valid runs not already complete), in plan order.
    #[getter]
    fn pending(&self) -> Vec<usize> {
        self.pending.clone()
    }

    /// Run `index` as (id, path, source): `octoarm.run_scenario(path, out, source=source)`
    /// computes it exactly as the local executor does.
    fn run_source(&self, index: usize) -> PyResult<(String, String, String)> {
        self.check_index(index)?;
        Ok((
            self.plan.runs[index].id.clone(),
            self.plan.base.path.display().to_string(),
            self.plan.scenario_text(index),
        ))
    }

    /// A hidden folder inside `out` for staged run files (removed by `finish`).
    fn stage_dir(&self) -> PyResult<String> {
        self.dir()?
            .stage_dir()
            .map(|p| p.display().to_string())
            .map_err(|e| PyOSError::new_err(format!("{e:#}")))
    }

    /// Commit the files in `staged` (a run's outputs) as `out/runs/<id>/` and record the run;
    /// returns its row (run, id, status, error).
    fn commit_staged<'py>(
        &self,
        py: Python<'py>,
        index: usize,
        staged: PathBuf,
    ) -> PyResult<Bound<'py, PyDict>> {
        self.check_index(index)?;
        let row = self
            .dir()?
            .commit_staged(&self.plan, index, &staged)
            .map_err(|e| PyOSError::new_err(format!("{e:#}")))?;
        row_dict(py, &row)
    }

    /// Record run `index` as ended without a folder: `status` ("invalid", "lost", "error") and
    /// `message`; returns its row.
    fn record_failure<'py>(
        &self,
        py: Python<'py>,
        index: usize,
        status: &str,
        message: &str,
    ) -> PyResult<Bound<'py, PyDict>> {
        self.check_index(index)?;
        let outcome = Outcome::Failed {
            status: status.to_string(),
            message: message.to_string(),
        };
        let row = self
            .dir()?
            .record(&self.plan, index, outcome)
            .map_err(|e| PyOSError::new_err(format!("{e:#}")))?;
        row_dict(py, &row)
    }

    /// Run the pending runs on this machine in Rust threads (`threads`, default all cores),
    /// with the GIL released. Ctrl-C stops the running runs where they are (they write what
    /// they recorded) and starts no new one; returns True if so (then call `finish` and raise).
    #[pyo3(signature = (threads = None))]
    fn run_local(&self, py: Python<'_>, threads: Option<usize>) -> PyResult<bool> {
        let threads = match threads {
            Some(t) if (1..=256).contains(&t) => t,
            Some(t) => {
                return Err(PyValueError::new_err(format!(
                    "threads = {t} is outside the allowed range [1, 256]"
                )))
            }
            None => std::thread::available_parallelism().map_or(1, |n| n.get()),
        };
        let dir = self.dir()?;
        let stop = AtomicUsize::new(0);
        let mut interrupted = false;
        let result = std::thread::scope(|s| {
            let worker = s.spawn(|| {
                let opts = sweep::LocalOptions {
                    threads,
                    stop: Some(&stop),
                    events: None,
                };
                sweep::run_local(&self.plan, dir, &self.pending, &opts)
            });
            // Wait with the GIL released, letting Python handle signals every 50 ms.
            while !worker.is_finished() {
                py.detach(|| std::thread::sleep(Duration::from_millis(50)));
                if !interrupted && py.check_signals().is_err() {
                    interrupted = true;
                    stop.store(SIGINT, Ordering::SeqCst);
                }
            }
            worker.join()
        });
        match result {
            Ok(Ok(())) => Ok(interrupted),
            Ok(Err(e)) => Err(PyOSError::new_err(format!("{e:#}"))),
            Err(_) => Err(PyRuntimeError::new_err(
                "the sweep's worker thread panicked",
            )),
        }
    }

    /// Write results.csv (plan order), results.npz and sweep.json (`executor`: a JSON text
    /// describing what ran the runs), release the folder, and return the report: out, total,
    /// completed, failed, interrupted, not_run, skipped, wall_seconds, and rows (run, id,
    /// status, error) in plan order.
    fn finish<'py>(&mut self, py: Python<'py>, executor: &str) -> PyResult<Bound<'py, PyDict>> {
        let executor: serde_json::Value = serde_json::from_str(executor)
            .map_err(|e| PyValueError::new_err(format!("executor is not JSON: {e}")))?;
        let dir = self.dir()?;
        let (rows, counts) = dir
            .finish(&self.plan, executor, self.start.elapsed().as_secs_f64())
            .map_err(|e| PyOSError::new_err(format!("{e:#}")))?;
        let d = PyDict::new(py);
        d.set_item("out", dir.root().display().to_string())?;
        d.set_item("total", counts.total)?;
        d.set_item("completed", counts.completed)?;
        d.set_item("failed", counts.failed)?;
        d.set_item("interrupted", counts.interrupted)?;
        d.set_item("not_run", counts.not_run)?;
        d.set_item("skipped", counts.skipped)?;
        d.set_item("wall_seconds", self.start.elapsed().as_secs_f64())?;
        let list: Vec<Bound<'py, PyDict>> = rows
            .iter()
            .map(|r| row_dict(py, r))
            .collect::<PyResult<_>>()?;
        d.set_item("rows", list)?;
        self.dir = None;
        Ok(d)
    }
}
