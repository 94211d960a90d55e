//! A sweep's output folder: `DIR/` (marker kind "sweep", locked for the sweep's life) with
//! `runs/<id>/` (each an `OutputDir`: temporary folder swapped into place), `results.csv`
//! (a row appended as each run ends, rewritten in plan order at the end), `results.npz`,
//! `sweep.json`. It finds the runs a `--resume` can skip and records every run's outcome; it
//! runs nothing (executors do).

use super::plan::{run_id, RunCheck, SweepPlan};
use super::table::{self, Row};
use crate::outdir::{alive, clean_stale, parent_and_name, Lock, Marker, OutputError};
use crate::output::OutputDir;
use anyhow::{Context, Result};
use serde_json::{json, Value};
use std::collections::BTreeSet;
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// How a run ended, as an executor reports it.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// Its folder `runs/<id>/` was committed (completed, unstable, failed or interrupted: its
    /// `summary.json` says which).
    Committed,
    /// It has no folder: `status` (`invalid`, `lost`, `error`) and why.
    Failed {
        /// The table's status.
        status: String,
        /// The error message.
        message: String,
    },
}

/// Counts of a sweep's runs by outcome.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Counts {
    /// Runs in the plan.
    pub total: usize,
    /// Completed (this time or, with `--resume`, before).
    pub completed: usize,
    /// Ended otherwise (unstable, failed, invalid, lost, error).
    pub failed: usize,
    /// Stopped by a signal.
    pub interrupted: usize,
    /// Not run (the sweep was interrupted first).
    pub not_run: usize,
    /// Skipped because `--resume` found them complete.
    pub skipped: usize,
}

struct Inner {
    rows: Vec<Option<Row>>,
    csv: fs::File,
    run_entries: BTreeSet<String>,
    root_entries: BTreeSet<String>,
}

/// The output folder of a sweep, prepared and locked.
pub struct SweepDir {
    root: PathBuf,
    runs: PathBuf,
    stage: PathBuf,
    run_id: String,
    skipped: usize,
    inner: Mutex<Inner>,
    _lock: Lock,
}

/// Whether `dir` is a complete run of scenario id `id`: octoarm's committed run folder with a
/// `summary.json` whose status is final (not "interrupted") and a `scenario.toml` hashing to
/// `id`.
pub fn run_complete(dir: &Path, id: &str) -> Option<Value> {
    let marker = Marker::read(dir)?;
    if marker.kind != "run" {
        return None;
    }
    let summary: Value =
        serde_json::from_str(&fs::read_to_string(dir.join("summary.json")).ok()?).ok()?;
    let status = summary.get("status")?.as_str()?;
    if status == "interrupted" {
        return None;
    }
    let text = fs::read_to_string(dir.join("scenario.toml")).ok()?;
    (run_id(&text) == id).then_some(summary)
}

/// Remove the hidden leftovers of dead processes in `dir`: `.NAME.partial-PID`, `.NAME.old-PID`
/// (by `outdir`'s rules: only octoarm's), `.NAME.lock` and `.stage-PID` folders of octoarm's
/// sweeps.
fn clean_dead(dir: &Path) {
    let Ok(list) = fs::read_dir(dir) else { return };
    let mut names = BTreeSet::new();
    for e in list.flatten() {
        let file = e.file_name().to_string_lossy().into_owned();
        let Some(rest) = file.strip_prefix('.') else {
            continue;
        };
        if let Some(pid) = rest.strip_prefix("stage-") {
            if pid
                .parse::<u32>()
                .is_ok_and(|p| !alive(p) && p != std::process::id())
                && e.path().join(STAGE_MARKER).is_file()
            {
                let _ = fs::remove_dir_all(e.path());
            }
            continue;
        }
        if let Some(name) = rest.strip_suffix(".lock") {
            let owner = fs::read_to_string(e.path())
                .ok()
                .and_then(|s| s.trim().parse::<u32>().ok());
            if owner.is_some_and(|p| !alive(p)) {
                let _ = fs::remove_file(e.path());
            }
            names.insert(name.to_string());
            continue;
        }
        for tag in [".partial-", ".old-"] {
            if let Some((name, _)) = rest.rsplit_once(tag) {
                names.insert(name.to_string());
            }
        }
    }
    for name in names {
        clean_stale(dir, &name);
    }
}

/// The file in a staging folder that says octoarm made it.
const STAGE_MARKER: &str = ".octoarm-stage";

impl SweepDir {
    /// Check, create and lock the sweep's folder. `root` must be new or empty — or, with
    /// `resume`, an earlier sweep's output (its `.octoarm` marker says "sweep"), whose complete
    /// runs of this plan are kept and skipped. Returns the folder and the indices of the runs
    /// to execute (valid runs not found complete), in plan order. Invalid runs are recorded at
    /// once. Errors name the folder and what to change; nothing is written then.
    pub fn prepare(
        root: &Path,
        plan: &SweepPlan,
        resume: bool,
    ) -> Result<(Self, Vec<usize>), OutputError> {
        let what = "--out";
        let fail = |m: String| OutputError(format!("{what} {}: {m}", root.display()));
        let (parent, name) = parent_and_name(root, what)?;
        let lock = Lock::take(&parent, &name, what, root)?;
        let runs = root.join("runs");
        let mut fresh = true;
        if root.exists() {
            if !root.is_dir() {
                return Err(fail(
                    "exists and is not a directory; choose another place".into(),
                ));
            }
            let empty = fs::read_dir(root)
                .map_err(|e| fail(format!("cannot read it: {e}")))?
                .next()
                .is_none();
            if !empty {
                match Marker::read(root) {
                    Some(m) if m.kind == "sweep" => {
                        if !resume {
                            return Err(fail(
                                "holds an earlier sweep; pass --resume to continue it (its \
                                 complete runs are kept and skipped), or choose another --out"
                                    .into(),
                            ));
                        }
                        fresh = false;
                    }
                    Some(m) => {
                        return Err(fail(format!(
                            "is the output of `octoarm {}`, not of a sweep; choose another --out",
                            m.kind
                        )))
                    }
                    None => {
                        crate::outdir::check_replaceable(root, what)?;
                    }
                }
            }
        }
        if resume && fresh {
            tracing::info!(
                "--resume: {} holds no earlier sweep; starting afresh",
                root.display()
            );
        }
        let io = |e: std::io::Error| fail(format!("cannot write into it: {e}"));
        fs::create_dir_all(&runs).map_err(io)?;
        if !fresh {
            clean_dead(root);
            clean_dead(&runs);
        }
        let mut run_entries: BTreeSet<String> = Marker::read(&runs)
            .map(|m| m.entries.into_iter().collect())
            .unwrap_or_default();
        let mut root_entries: BTreeSet<String> = Marker::read(root)
            .map(|m| m.entries.into_iter().collect())
            .unwrap_or_default();
        root_entries.insert("runs/".into());
        root_entries.insert("results.csv".into());

        // Rows known before anything runs: invalid runs and, with --resume, complete ones.
        let mut rows: Vec<Option<Row>> = vec![None; plan.runs.len()];
        let mut pending = Vec::new();
        let mut skipped = 0;
        for r in &plan.runs {
            match &r.check {
                RunCheck::Invalid(message) => {
                    rows[r.index] = Some(failed_row(plan, r.index, "invalid", message));
                }
                RunCheck::Valid => {
                    let dir = runs.join(&r.id);
                    match (!fresh).then(|| run_complete(&dir, &r.id)).flatten() {
                        Some(summary) => {
                            rows[r.index] = Some(committed_row(plan, r.index, &summary));
                            run_entries.insert(format!("{}/", r.id));
                            skipped += 1;
                        }
                        None => pending.push(r.index),
                    }
                }
            }
        }
        let run_marker = Marker {
            kind: "runs".into(),
            run: String::new(),
            entries: run_entries.iter().cloned().collect(),
        };
        let sweep_run = crate::outdir::new_run_id();
        let root_marker = Marker {
            kind: "sweep".into(),
            run: sweep_run.clone(),
            entries: root_entries.iter().cloned().collect(),
        };
        let write_all = || -> Result<fs::File> {
            run_marker.write(&runs)?;
            root_marker.write(root)?;
            let known: Vec<&Row> = rows.iter().flatten().collect();
            let csv_path = root.join("results.csv");
            table::write_csv(&csv_path, plan, &known)?;
            fs::OpenOptions::new()
                .append(true)
                .open(&csv_path)
                .with_context(|| format!("cannot open {}", csv_path.display()))
        };
        let csv = write_all().map_err(|e| fail(format!("{e:#}")))?;
        let stage = root.join(format!(".stage-{}", std::process::id()));
        Ok((
            Self {
                root: root.to_path_buf(),
                runs,
                stage,
                run_id: sweep_run,
                skipped,
                inner: Mutex::new(Inner {
                    rows,
                    csv,
                    run_entries,
                    root_entries,
                }),
                _lock: lock,
            },
            pending,
        ))
    }

    /// The sweep's folder.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// The folder of run `id`: `DIR/runs/<id>`.
    pub fn run_dir(&self, id: &str) -> PathBuf {
        self.runs.join(id)
    }

    /// A hidden folder for files of runs computed elsewhere (Ray workers) before they are
    /// committed; created on first use, removed by `finish`.
    pub fn stage_dir(&self) -> Result<PathBuf> {
        if !self.stage.is_dir() {
            fs::create_dir_all(&self.stage)
                .with_context(|| format!("cannot create {}", self.stage.display()))?;
            fs::write(self.stage.join(STAGE_MARKER), "octoarm sweep staging\n")?;
        }
        Ok(self.stage.clone())
    }

    /// Commit the files of run `index` found in `staged` (a folder of plain files, e.g. a Ray
    /// worker's outputs written by the driver) as `runs/<id>/`, exactly as a local run commits
    /// its folder, then record it. The staged folder is removed.
    pub fn commit_staged(&self, plan: &SweepPlan, index: usize, staged: &Path) -> Result<Row> {
        let id = &plan.runs[index].id;
        let out = OutputDir::prepare(&self.run_dir(id))?;
        for e in
            fs::read_dir(staged).with_context(|| format!("cannot read {}", staged.display()))?
        {
            let e = e?;
            let name = e.file_name().to_string_lossy().into_owned();
            if name.starts_with('.') || !e.file_type()?.is_file() {
                continue;
            }
            fs::rename(e.path(), out.path(&name))
                .or_else(|_| fs::copy(e.path(), out.path(&name)).map(|_| ()))
                .with_context(|| format!("cannot move {} into place", e.path().display()))?;
        }
        out.commit()?;
        let _ = fs::remove_dir_all(staged);
        self.record(plan, index, Outcome::Committed)
    }

    /// Record how run `index` ended: its row (from its committed `summary.json`, or the
    /// failure) is appended to `results.csv`, and a committed folder is added to the `runs/`
    /// marker. Returns the row.
    pub fn record(&self, plan: &SweepPlan, index: usize, outcome: Outcome) -> Result<Row> {
        let id = &plan.runs[index].id;
        let row = match &outcome {
            Outcome::Committed => {
                let path = self.run_dir(id).join("summary.json");
                let summary: Value = fs::read_to_string(&path)
                    .ok()
                    .and_then(|t| serde_json::from_str(&t).ok())
                    .with_context(|| format!("cannot read {}", path.display()))?;
                committed_row(plan, index, &summary)
            }
            Outcome::Failed { status, message } => failed_row(plan, index, status, message),
        };
        let mut inner = self.inner.lock().unwrap_or_else(|p| p.into_inner());
        let line = table::csv_line(&row);
        inner
            .csv
            .write_all(line.as_bytes())
            .and_then(|()| inner.csv.flush())
            .with_context(|| format!("cannot write {}", self.root.join("results.csv").display()))?;
        if outcome == Outcome::Committed && inner.run_entries.insert(format!("{id}/")) {
            Marker {
                kind: "runs".into(),
                run: String::new(),
                entries: inner.run_entries.iter().cloned().collect(),
            }
            .write(&self.runs)?;
        }
        inner.rows[index] = Some(row.clone());
        Ok(row)
    }

    /// Rows recorded so far, in plan order (None: not run yet).
    pub fn rows(&self) -> Vec<Option<Row>> {
        self.inner
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .rows
            .clone()
    }

    /// Counts of the runs by outcome so far.
    pub fn counts(&self) -> Counts {
        let rows = self.rows();
        let mut c = Counts {
            total: rows.len(),
            skipped: self.skipped,
            ..Default::default()
        };
        for r in &rows {
            match r {
                None => c.not_run += 1,
                Some(r) if r.completed() => c.completed += 1,
                Some(r) if r.status == "interrupted" => c.interrupted += 1,
                Some(_) => c.failed += 1,
            }
        }
        c
    }

    /// Add files written into the root (figures) to its marker.
    pub fn add_entries(&self, names: &[String]) -> Result<()> {
        let mut inner = self.inner.lock().unwrap_or_else(|p| p.into_inner());
        inner.root_entries.extend(names.iter().cloned());
        Marker {
            kind: "sweep".into(),
            run: self.run_id.clone(),
            entries: inner.root_entries.iter().cloned().collect(),
        }
        .write(&self.root)
    }

    /// End the sweep: rewrite `results.csv` in plan order (rows of the runs that ended),
    /// write `results.npz` and `sweep.json` (the resolved plan, the program version, the
    /// executor `executor`, counts, each run's status, `wall_seconds`), remove the staging
    /// folder and update the marker. Returns the rows in plan order and the counts.
    pub fn finish(
        &self,
        plan: &SweepPlan,
        executor: Value,
        wall_seconds: f64,
    ) -> Result<(Vec<Row>, Counts)> {
        let rows = self.rows();
        let done: Vec<&Row> = rows.iter().flatten().collect();
        table::write_csv(&self.root.join("results.csv"), plan, &done)?;
        table::write_npz(&self.root.join("results.npz"), plan, &done)?;
        let counts = self.counts();
        let mut doc = plan.to_json();
        let status: Vec<Value> = rows
            .iter()
            .map(|r| r.as_ref().map_or(json!("not_run"), |r| json!(r.status)))
            .collect();
        if let Some(runs) = doc.get_mut("runs").and_then(Value::as_array_mut) {
            for (r, s) in runs.iter_mut().zip(status) {
                r["status"] = s;
            }
        }
        let head = json!({
            "program": "octoarm",
            "version": env!("CARGO_PKG_VERSION"),
            "executor": executor,
            "wall_seconds": wall_seconds,
            "counts": {
                "total": counts.total,
                "completed": counts.completed,
                "failed": counts.failed,
                "interrupted": counts.interrupted,
                "not_run": counts.not_run,
                "skipped_as_complete": counts.skipped,
            },
            "columns": table::columns(plan),
        });
        let mut out = head.as_object().cloned().unwrap_or_default();
        out.extend(doc.as_object().cloned().unwrap_or_default());
        let text = serde_json::to_string_pretty(&Value::Object(out))? + "\n";
        table::write_replacing(&self.root.join("sweep.json"), text.as_bytes())?;
        if self.stage.is_dir() {
            let _ = fs::remove_dir_all(&self.stage);
        }
        self.add_entries(&["results.npz".into(), "sweep.json".into()])?;
        Ok((done.into_iter().cloned().collect(), counts))
    }
}

fn committed_row(plan: &SweepPlan, index: usize, summary: &Value) -> Row {
    let (status, results, error) = table::results_of(plan, summary);
    let mut cells = plan.parameter_cells(index);
    cells.extend(results.into_iter().map(super::plan::Cell::Num));
    Row {
        index,
        id: plan.runs[index].id.clone(),
        status,
        cells,
        error,
    }
}

fn failed_row(plan: &SweepPlan, index: usize, status: &str, message: &str) -> Row {
    let mut cells = plan.parameter_cells(index);
    let n = table::result_columns(plan).len();
    cells.extend(std::iter::repeat(super::plan::Cell::Num(f64::NAN)).take(n));
    Row {
        index,
        id: plan.runs[index].id.clone(),
        status: status.to_string(),
        cells,
        error: message.to_string(),
    }
}
