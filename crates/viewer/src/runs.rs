//! What `octoarm view PATH` shows: the runs found at PATH (a run folder, a sweep folder with
//! `runs/<id>/`, or a folder of run folders such as `octoarm paper`'s results), and one run's
//! data for the page: its summary, scene and every per-frame array of `trajectory.npz` and
//! `series.npz`, thinned evenly in time to a bounded size (the last frame always kept).
//! Arrays that are absent are simply not sent; the page draws what it gets.

use crate::blob::Blob;
use crate::npz::{self, Member};
use crate::scene::scene_of;
use anyhow::{bail, Result};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// Most frames of a run sent to the page.
pub const MAX_VIEW_FRAMES: usize = 4000;
/// Most float32 values of per-frame arrays sent to the page (128 MB).
pub const MAX_VIEW_VALUES: usize = 32 << 20;
/// Most samples of each series (`series.npz`) sent to the page.
pub const MAX_SERIES_SAMPLES: usize = 8000;
/// Most runs listed from one folder.
pub const MAX_RUNS: usize = 100_000;

/// How the runs were laid out at PATH.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Layout {
    /// PATH is one run's folder.
    Run,
    /// PATH is a sweep: `runs/<id>/` (with `sweep.json`, `results.csv`).
    Sweep,
    /// PATH holds run folders (e.g. `octoarm paper`'s results: one per experiment).
    Collection,
}

/// One run that can be shown.
#[derive(Debug, Clone, PartialEq)]
pub struct RunEntry {
    /// Identifier used by the page ("." for PATH itself, else the path below PATH).
    pub id: String,
    /// Text shown in the picker.
    pub label: String,
    /// Its folder.
    pub dir: PathBuf,
}

/// The runs found at a path.
#[derive(Debug, Clone)]
pub struct Catalog {
    /// The folder given.
    pub root: PathBuf,
    /// How it is laid out.
    pub layout: Layout,
    /// The runs, in order.
    pub runs: Vec<RunEntry>,
}

fn is_run(dir: &Path) -> bool {
    dir.join("trajectory.npz").is_file()
}

/// `summary.json`'s status, if readable.
fn status_of(dir: &Path) -> Option<String> {
    let text = std::fs::read_to_string(dir.join("summary.json")).ok()?;
    let v: Value = serde_json::from_str(&text).ok()?;
    v.get("status")?.as_str().map(str::to_string)
}

/// Sub-folders of `dir` that are runs, sorted by name.
fn run_folders(dir: &Path) -> Vec<(String, PathBuf)> {
    let mut out: Vec<(String, PathBuf)> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            let p = e.path();
            let name = e.file_name().to_str()?.to_string();
            (!name.starts_with('.') && p.is_dir() && is_run(&p)).then_some((name, p))
        })
        .take(MAX_RUNS)
        .collect();
    out.sort();
    out
}

/// Labels of a sweep's runs from `results.csv`: the row whose first column (or `id`/`run`
/// column) is the run's id, as `k=v` pairs of its other columns (the first few).
fn sweep_labels(root: &Path) -> std::collections::HashMap<String, String> {
    let mut labels = std::collections::HashMap::new();
    let Ok(text) = std::fs::read_to_string(root.join("results.csv")) else {
        return labels;
    };
    let mut lines = text.lines();
    let Some(head) = lines.next() else {
        return labels;
    };
    let cols: Vec<&str> = head.split(',').map(str::trim).collect();
    let key = cols
        .iter()
        .position(|c| *c == "id" || *c == "run" || *c == "run_id")
        .unwrap_or(0);
    for line in lines.take(MAX_RUNS) {
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let Some(id) = cells.get(key) else { continue };
        let pairs: Vec<String> = cols
            .iter()
            .zip(&cells)
            .enumerate()
            .filter(|(i, _)| *i != key)
            .take(4)
            .map(|(_, (c, v))| format!("{c}={v}"))
            .collect();
        labels.insert(id.trim_matches('"').to_string(), pairs.join(", "));
    }
    labels
}

/// Find the runs at `path`: a run folder (or its `trajectory.npz`), a sweep folder (`runs/`
/// holding run folders) or a folder of run folders. Errors name what was expected.
pub fn discover(path: &Path) -> Result<Catalog> {
    let root =
        if path.is_file() && path.file_name().and_then(|n| n.to_str()) == Some("trajectory.npz") {
            path.parent().unwrap_or(Path::new(".")).to_path_buf()
        } else {
            path.to_path_buf()
        };
    if !root.exists() {
        bail!("{} does not exist", root.display());
    }
    if !root.is_dir() {
        bail!(
            "{} is not a folder: give a run folder (with trajectory.npz), a sweep folder \
             (with runs/) or a results folder of runs",
            root.display()
        );
    }
    let with_status = |label: String, dir: &Path| match status_of(dir) {
        Some(s) => format!("{label} ({s})"),
        None => label,
    };
    if is_run(&root) {
        let label = root
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or("run")
            .to_string();
        return Ok(Catalog {
            runs: vec![RunEntry {
                id: ".".into(),
                label: with_status(label, &root),
                dir: root.clone(),
            }],
            root,
            layout: Layout::Run,
        });
    }
    let sweep_runs = run_folders(&root.join("runs"));
    if !sweep_runs.is_empty() {
        let labels = sweep_labels(&root);
        let runs = sweep_runs
            .into_iter()
            .map(|(name, dir)| {
                let label = match labels.get(&name) {
                    Some(l) if !l.is_empty() => format!("{name}: {l}"),
                    _ => name.clone(),
                };
                RunEntry {
                    id: format!("runs/{name}"),
                    label: with_status(label, &dir),
                    dir,
                }
            })
            .collect();
        return Ok(Catalog {
            root,
            layout: Layout::Sweep,
            runs,
        });
    }
    let runs: Vec<RunEntry> = run_folders(&root)
        .into_iter()
        .map(|(name, dir)| RunEntry {
            id: name.clone(),
            label: with_status(name, &dir),
            dir,
        })
        .collect();
    if runs.is_empty() {
        bail!(
            "{} holds no run: expected trajectory.npz (a run folder), runs/<id>/trajectory.npz \
             (a sweep) or <name>/trajectory.npz (a results folder such as `octoarm paper`'s)",
            root.display()
        );
    }
    Ok(Catalog {
        root,
        layout: Layout::Collection,
        runs,
    })
}

impl Catalog {
    /// The catalog as the page's JSON.
    pub fn to_json(&self) -> Value {
        let kind = match self.layout {
            Layout::Run => "run",
            Layout::Sweep => "sweep",
            Layout::Collection => "collection",
        };
        json!({
            "kind": kind,
            "root": self.root.display().to_string(),
            "runs": self.runs.iter().map(|r| json!({"id": r.id, "label": r.label})).collect::<Vec<_>>(),
        })
    }

    /// The run with identifier `id` (only ids of the catalog: nothing else on disk is served).
    pub fn get(&self, id: &str) -> Option<&RunEntry> {
        self.runs.iter().find(|r| r.id == id)
    }
}

/// One run's data for the page: header `summary`, `scene`, `frames_total`, `frames`; arrays
/// `trajectory/<member>` (per-frame members thinned to the same frames) and `series/<member>`
/// (1-D members of `series.npz` over its `time`, thinned).
pub fn load_run(dir: &Path) -> Result<Blob> {
    let traj_path = dir.join("trajectory.npz");
    let members = npz::members(&traj_path)?;
    let frames_total = members
        .iter()
        .find(|m| m.name == "time")
        .and_then(|m| m.shape.first().copied())
        .unwrap_or(0);
    // Per-frame members: first axis = frames.
    let per_frame: Vec<&Member> = members
        .iter()
        .filter(|m| m.shape.first() == Some(&frames_total) && frames_total > 0)
        .filter(|m| !m.name.ends_with("velocity") && !m.name.ends_with("omega"))
        .collect();
    let values_per_frame: usize = per_frame
        .iter()
        .map(|m| m.shape.iter().skip(1).product::<usize>())
        .sum::<usize>()
        .max(1);
    let count = MAX_VIEW_FRAMES.min((MAX_VIEW_VALUES / values_per_frame).max(2));
    let picks = npz::pick_frames(frames_total, count);
    let mut blob = Blob::new();
    for m in &per_frame {
        let values = npz::read_rows(&traj_path, m, &picks)?;
        let mut shape = vec![picks.len()];
        shape.extend(m.shape.iter().skip(1));
        blob.push(format!("trajectory/{}", m.name), shape, values);
    }
    let series_path = dir.join("series.npz");
    if series_path.is_file() {
        if let Ok(sm) = npz::members(&series_path) {
            let samples = sm
                .iter()
                .find(|m| m.name == "time")
                .and_then(|m| m.shape.first().copied())
                .unwrap_or(0);
            let picks = npz::pick_frames(samples, MAX_SERIES_SAMPLES);
            for m in sm.iter().filter(|m| m.shape == [samples] && samples > 0) {
                if let Ok(values) = npz::read_rows(&series_path, m, &picks) {
                    blob.push(format!("series/{}", m.name), vec![picks.len()], values);
                }
            }
        }
    }
    let summary: Value = std::fs::read_to_string(dir.join("summary.json"))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or(Value::Null);
    let scenario = std::fs::read_to_string(dir.join("scenario.toml")).ok();
    blob.set("type", json!("run"));
    blob.set("summary", summary);
    blob.set("scene", scene_of(scenario.as_deref()));
    blob.set("frames_total", json!(frames_total));
    blob.set("frames", json!(picks.len()));
    Ok(blob)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn discovery_names_what_it_expected() {
        let dir = tempfile::tempdir().unwrap();
        let err = discover(dir.path()).unwrap_err().to_string();
        assert!(err.contains("holds no run"), "{err}");
        let err = discover(&dir.path().join("nope")).unwrap_err().to_string();
        assert!(err.contains("does not exist"), "{err}");
    }

    #[test]
    fn sweeps_and_collections_are_recognised() {
        let dir = tempfile::tempdir().unwrap();
        for id in ["b", "a"] {
            let run = dir.path().join("runs").join(id);
            std::fs::create_dir_all(&run).unwrap();
            std::fs::write(run.join("trajectory.npz"), b"").unwrap();
        }
        std::fs::write(
            dir.path().join("results.csv"),
            "id,rod.youngs_modulus,final_distance\na,1e4,0.1\nb,2e4,0.2\n",
        )
        .unwrap();
        let c = discover(dir.path()).unwrap();
        assert_eq!(c.layout, Layout::Sweep);
        assert_eq!(c.runs[0].id, "runs/a");
        assert_eq!(
            c.runs[0].label,
            "a: rod.youngs_modulus=1e4, final_distance=0.1"
        );
        assert!(c.get("runs/b").is_some());
        assert!(c.get("../etc").is_none());
        let c = discover(&dir.path().join("runs")).unwrap();
        assert_eq!(c.layout, Layout::Collection);
        assert_eq!(c.runs.len(), 2);
        let c = discover(&dir.path().join("runs/a/trajectory.npz")).unwrap();
        assert_eq!(c.layout, Layout::Run);
        assert_eq!(c.runs[0].id, ".");
    }
}
