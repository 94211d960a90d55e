//! The command line's bridge to the Ray executor, which is Python (`octoarm.sweep`): it starts
//! `python3 -m octoarm.sweep serve --address A`, waits until Ray is connected, sends the pending
//! runs (id, scenario text) as JSON lines and commits each run's files as the executor reports
//! them staged. The sweep's folder, table and figures stay the command line's, as for local runs.
//! Protocol (one JSON object per line): to Python `{"stage": DIR}`, then `{"index", "id", "path",
//! "source"}` per run, then `{"end": true}`; from Python `ready` (cpus), `started`, `retry`,
//! `done` (staged folder), `failed` (status, message), `interrupted`, `end` or `error`.

use super::dir::{Outcome, SweepDir};
use super::local::Event;
use super::plan::SweepPlan;
use anyhow::{bail, Context, Result};
use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Write};
use std::path::Path;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

/// Ray could not be used: Python, the octoarm package or ray is missing, or the cluster could
/// not be reached. Found before anything is written (exit code 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct RayUnavailable(pub String);

/// How long to wait for Python to import octoarm and ray and connect to the cluster.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(300);

/// A running Python Ray executor, connected to its cluster.
pub struct RayExecutor {
    child: Child,
    stdin: Option<ChildStdin>,
    lines: Receiver<String>,
    /// CPUs of the cluster (the executor keeps at most this many runs in flight).
    pub cpus: usize,
    /// The cluster's address as Ray reports it.
    pub address: String,
}

const INSTALL: &str = "install them into that Python with `pip install ./crates/python ray` \
                       (the octoarm package and ray), or name another interpreter with --python";

impl RayExecutor {
    /// Start `python -m octoarm.sweep serve --address ADDRESS` and wait until it is connected
    /// to Ray (`auto`: a running cluster; `local`: a new one on this machine for this sweep;
    /// else the cluster at that address).
    pub fn start(python: &str, address: &str) -> Result<Self, RayUnavailable> {
        let unavailable = |m: String| RayUnavailable(format!("--ray {address}: {m}"));
        let mut child = Command::new(python)
            // `-W ignore:::runpy`: `octoarm` imports its `sweep` module, which makes `-m` warn
            // that the module was already imported; harmless here, and noise on stderr.
            .args([
                "-u",
                "-W",
                "ignore:::runpy",
                "-m",
                "octoarm.sweep",
                "serve",
                "--address",
                address,
            ])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .map_err(|e| {
                unavailable(format!(
                    "cannot start the Python interpreter {python:?} ({e}); the Ray executor is \
                     Python: {INSTALL}"
                ))
            })?;
        let stdout = child.stdout.take().expect("piped");
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let stdin = child.stdin.take();
        let mut ex = Self {
            child,
            stdin,
            lines,
            cpus: 1,
            address: address.to_string(),
        };
        let start = Instant::now();
        loop {
            match ex.lines.recv_timeout(Duration::from_millis(200)) {
                Ok(line) => {
                    let Ok(v) = serde_json::from_str::<Value>(&line) else {
                        continue;
                    };
                    match v.get("event").and_then(Value::as_str) {
                        Some("ready") => {
                            ex.cpus =
                                v.get("cpus").and_then(Value::as_u64).unwrap_or(1).max(1) as usize;
                            if let Some(a) = v.get("address").and_then(Value::as_str) {
                                ex.address = a.to_string();
                            }
                            return Ok(ex);
                        }
                        Some("error") => {
                            let m = v.get("message").and_then(Value::as_str).unwrap_or("");
                            return Err(unavailable(m.to_string()));
                        }
                        _ => {}
                    }
                }
                Err(RecvTimeoutError::Disconnected) => {
                    let status = ex.child.wait().ok();
                    return Err(unavailable(format!(
                        "{python} -m octoarm.sweep ended ({}) before connecting to Ray; if it \
                         says that a module is missing, {INSTALL}",
                        status.map_or("?".into(), |s| s.to_string())
                    )));
                }
                Err(RecvTimeoutError::Timeout) if start.elapsed() > CONNECT_TIMEOUT => {
                    return Err(unavailable(format!(
                        "no connection to Ray after {} s",
                        CONNECT_TIMEOUT.as_secs()
                    )));
                }
                Err(RecvTimeoutError::Timeout) => {}
            }
        }
    }

    /// Execute the runs `pending` on the cluster, committing and recording each as it ends.
    /// When `stop` is set (a signal), the executor is interrupted: runs in flight are
    /// cancelled (not recorded: `--resume` runs them again), and this returns.
    pub fn run(
        &mut self,
        plan: &SweepPlan,
        dir: &SweepDir,
        pending: &[usize],
        stop: Option<&AtomicUsize>,
        events: Option<&(dyn Fn(Event<'_>) + Sync)>,
    ) -> Result<()> {
        let stage = dir.stage_dir()?;
        let path = plan.base.path.display().to_string();
        let mut stdin = self.stdin.take().context("the executor was already used")?;
        let mut interrupted_sent = false;
        let mut first_error: Option<anyhow::Error> = None;
        std::thread::scope(|s| -> Result<()> {
            // The runs go out on a thread: the executor reads them while it reports.
            s.spawn(move || {
                let mut send = |v: Value| writeln!(stdin, "{v}");
                let _ = send(json!({"stage": stage}));
                for &i in pending {
                    let run = json!({
                        "index": i,
                        "id": plan.runs[i].id,
                        "path": path,
                        "source": plan.scenario_text(i),
                    });
                    if send(run).is_err() {
                        return;
                    }
                }
                let _ = send(json!({"end": true}));
            });
            loop {
                if !interrupted_sent && stop.is_some_and(|s| s.load(Ordering::Relaxed) != 0) {
                    self.interrupt();
                    interrupted_sent = true;
                }
                let line = match self.lines.recv_timeout(Duration::from_millis(100)) {
                    Ok(l) => l,
                    Err(RecvTimeoutError::Timeout) => continue,
                    Err(RecvTimeoutError::Disconnected) => {
                        if interrupted_sent {
                            return Ok(());
                        }
                        bail!(
                            "the Ray executor (Python) ended unexpectedly; its messages are above"
                        );
                    }
                };
                let Ok(v) = serde_json::from_str::<Value>(&line) else {
                    continue;
                };
                let index = v.get("index").and_then(Value::as_u64).map(|i| i as usize);
                let index = index.filter(|&i| i < plan.runs.len());
                let text = |k: &str| v.get(k).and_then(Value::as_str).unwrap_or("").to_string();
                match (v.get("event").and_then(Value::as_str), index) {
                    (Some("started"), Some(i)) => {
                        if let Some(ev) = events {
                            ev(Event::Started(i));
                        }
                    }
                    (Some("retry"), Some(i)) => tracing::warn!(
                        "run {i} ({}): {}; running it again",
                        plan.runs[i].id,
                        text("message")
                    ),
                    (Some("done"), Some(i)) => {
                        let staged = text("staged");
                        let row = dir.commit_staged(plan, i, Path::new(&staged));
                        record(row, events, &mut first_error);
                    }
                    (Some("failed"), Some(i)) => {
                        let outcome = Outcome::Failed {
                            status: text("status"),
                            message: text("message"),
                        };
                        record(dir.record(plan, i, outcome), events, &mut first_error);
                    }
                    (Some("interrupted"), _) | (Some("end"), _) => return Ok(()),
                    (Some("error"), _) => bail!("the Ray executor failed: {}", text("message")),
                    _ => {}
                }
            }
        })?;
        let _ = self.child.wait();
        match first_error {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// Ask the executor to stop (SIGINT: it cancels the runs in flight and reports
    /// "interrupted").
    fn interrupt(&self) {
        // SAFETY: kill(2) on our own child's pid has no memory-safety preconditions.
        unsafe {
            libc::kill(self.child.id() as libc::pid_t, libc::SIGINT);
        }
    }
}

fn record(
    row: Result<super::table::Row>,
    events: Option<&(dyn Fn(Event<'_>) + Sync)>,
    first_error: &mut Option<anyhow::Error>,
) {
    match row {
        Ok(row) => {
            if let Some(ev) = events {
                ev(Event::Finished(&row));
            }
        }
        Err(e) => {
            first_error.get_or_insert(e);
        }
    }
}

impl Drop for RayExecutor {
    // Never leave the executor (and a local Ray it started) behind: interrupt it, give it ten
    // seconds to shut Ray down, then kill it.
    fn drop(&mut self) {
        self.stdin.take();
        if matches!(self.child.try_wait(), Ok(None)) {
            self.interrupt();
            let start = Instant::now();
            while start.elapsed() < Duration::from_secs(10) {
                if !matches!(self.child.try_wait(), Ok(None)) {
                    return;
                }
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}
