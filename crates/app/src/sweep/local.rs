//! The local executor: a sweep's pending runs on this machine's cores, each through the one run
//! pipeline into its own `OutputDir` (`runs/<id>/`), recorded as it ends. A failed run (invalid,
//! unstable, a panic) is recorded and the others go on; a stop flag (a signal) stops the running
//! runs where they are (they write what they recorded) and starts no new one.

use super::dir::{Outcome, SweepDir};
use super::plan::SweepPlan;
use super::table::Row;
use crate::output::OutputDir;
use crate::pipeline::{self, RunOptions};
use anyhow::Result;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// What the local executor tells its caller (from its worker threads).
pub enum Event<'a> {
    /// Run `index` started.
    Started(usize),
    /// A run ended; its row was recorded.
    Finished(&'a Row),
}

/// How to run a sweep locally.
pub struct LocalOptions<'a> {
    /// Worker threads (≥ 1); each runs one scenario at a time.
    pub threads: usize,
    /// Set (to a signal number) to stop: see the module documentation.
    pub stop: Option<&'a AtomicUsize>,
    /// Called for every event.
    pub events: Option<&'a (dyn Fn(Event<'_>) + Sync)>,
}

/// Run one scenario of the plan into its folder; never panics out (a panic is an `error`).
pub fn run_one(
    plan: &SweepPlan,
    dir: &SweepDir,
    index: usize,
    stop: Option<&AtomicUsize>,
) -> Outcome {
    let failed = |status: &str, message: String| Outcome::Failed {
        status: status.into(),
        message,
    };
    let attempt = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let scn = match plan.scenario(index) {
            Ok(s) => s,
            Err(e) => return failed("invalid", e.to_string()),
        };
        let prepared = match pipeline::prepare(&scn) {
            Ok(p) => p,
            Err(e) => return failed("invalid", e.to_string()),
        };
        let out = match OutputDir::prepare(&dir.run_dir(&plan.runs[index].id)) {
            Ok(o) => o,
            Err(e) => return failed("error", e.to_string()),
        };
        let opts = RunOptions {
            progress: None,
            figures: None,
            stop,
        };
        match pipeline::run(&scn, prepared, out, &opts) {
            Ok(_) => Outcome::Committed,
            Err(e) => failed("error", format!("{e:#}")),
        }
    }));
    attempt.unwrap_or_else(|panic| {
        let what = panic
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "unknown".into());
        failed("error", format!("the run panicked: {what}"))
    })
}

/// Run the runs `pending` (plan indices) on `opts.threads` threads, in plan order, recording
/// each as it ends. Returns the first error recording a run (I/O on the sweep's folder), after
/// the other threads have finished their current runs.
pub fn run_local(
    plan: &SweepPlan,
    dir: &SweepDir,
    pending: &[usize],
    opts: &LocalOptions<'_>,
) -> Result<()> {
    let next = AtomicUsize::new(0);
    let first_error: Mutex<Option<anyhow::Error>> = Mutex::new(None);
    let stopped = || {
        opts.stop.is_some_and(|s| s.load(Ordering::Relaxed) != 0)
            || first_error.lock().map_or(true, |e| e.is_some())
    };
    let threads = opts.threads.clamp(1, pending.len().max(1));
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| loop {
                if stopped() {
                    break;
                }
                let k = next.fetch_add(1, Ordering::SeqCst);
                let Some(&index) = pending.get(k) else { break };
                if let Some(ev) = opts.events {
                    ev(Event::Started(index));
                }
                let outcome = run_one(plan, dir, index, opts.stop);
                match dir.record(plan, index, outcome) {
                    Ok(row) => {
                        if let Some(ev) = opts.events {
                            ev(Event::Finished(&row));
                        }
                    }
                    Err(e) => {
                        let mut first = first_error.lock().unwrap_or_else(|p| p.into_inner());
                        first.get_or_insert(e);
                    }
                }
            });
        }
    });
    match first_error.into_inner().unwrap_or_else(|p| p.into_inner()) {
        Some(e) => Err(e),
        None => Ok(()),
    }
}
