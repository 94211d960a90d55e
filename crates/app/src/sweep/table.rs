//! The sweep's results table: one row per run (its parameters, its scalar results read from the
//! run's `summary.json`, its status and error), as CSV lines and as an `.npz` twin. Rows are made
//! from the committed run folders only, so every executor writes the same table.

use super::plan::{Cell, SweepPlan};
use crate::output::write_member;
use anyhow::{Context, Result};
use serde_json::Value;
use std::io::Write;
use std::path::Path;
use zip::write::SimpleFileOptions;
use zip::{CompressionMethod, ZipWriter};

/// One run's row.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// Position in the plan.
    pub index: usize,
    /// Run id (folder `runs/<id>/`).
    pub id: String,
    /// `completed`, `unstable`, `failed` (controller), `interrupted`, `invalid` (the scenario
    /// or its build failed), `lost` (the Ray worker died twice) or `error` (anything else).
    pub status: String,
    /// The parameter cells, then the scalar results (NaN where missing).
    pub cells: Vec<Cell>,
    /// Why the run failed (empty if it completed).
    pub error: String,
}

impl Row {
    /// Whether the run completed.
    pub fn completed(&self) -> bool {
        self.status == "completed"
    }
}

/// Scalar results of a run, read from its `summary.json`: (column, where in the JSON).
pub fn result_columns(plan: &SweepPlan) -> Vec<String> {
    let cfg = &plan.base.config;
    let mut out = vec!["steps".to_string(), "final_time".to_string()];
    let multi = cfg.rods.list.len() > 1;
    for r in &cfg.rods.list {
        let prefix = if multi {
            format!("{}.", r.name.as_deref().unwrap_or("rod"))
        } else {
            String::new()
        };
        for c in ROD_RESULTS {
            out.push(format!("{prefix}{}", c.0));
        }
    }
    if cfg.controller.is_some() {
        out.extend(CONTROL_RESULTS.iter().map(|c| c.0.to_string()));
    }
    if cfg.muscle_control.is_some() {
        out.extend(MUSCLE_RESULTS.iter().map(|c| c.0.to_string()));
    }
    out
}

/// Muscle-run results (`[muscle_control]`): column and path in `summary.json`'s `muscles`.
const MUSCLE_RESULTS: [(&str, &[&str]); 16] = [
    ("design_seconds", &["design", "seconds"]),
    ("design_iterations", &["design", "iterations"]),
    ("design_evaluations", &["design", "evaluations"]),
    ("design_starts", &["design", "starts"]),
    ("design_winner", &["design", "winner"]),
    ("design_cost", &["design", "cost"]),
    ("design_tip_error_l0", &["design", "tip_error_l0"]),
    ("design_orientation_error", &["design", "orientation_error"]),
    ("design_residual", &["design", "residual"]),
    ("target_x", &["design", "target", "0"]),
    ("target_y", &["design", "target", "1"]),
    ("target_z", &["design", "target", "2"]),
    ("final_tip_error_l0", &["final_tip_error_l0"]),
    ("final_orientation_error", &["final_orientation_error"]),
    ("node_deviation_l0", &["node_deviation_l0"]),
    ("hamiltonian_largest_rise", &["hamiltonian_largest_rise"]),
];

/// Per-rod results: column and path in the rod's entry of `summary.json`'s `rods`.
const ROD_RESULTS: [(&str, &[&str]); 8] = [
    ("tip_x", &["final_tip_position", "0"]),
    ("tip_y", &["final_tip_position", "1"]),
    ("tip_z", &["final_tip_position", "2"]),
    ("energy_kinetic", &["final_energies", "kinetic"]),
    ("energy_strain", &["final_energies", "strain"]),
    ("energy_total", &["final_energies", "total"]),
    ("external_work", &["final_energies", "external_work"]),
    ("dissipated", &["final_energies", "dissipated"]),
];

/// Control results: column and path in `summary.json`'s `control`.
const CONTROL_RESULTS: [(&str, &[&str]); 7] = [
    ("final_distance", &["final_distance"]),
    ("settling_time", &["segments", "-1", "settling_time"]),
    ("control_force_effort", &["control_force_effort"]),
    ("control_couple_effort", &["control_couple_effort"]),
    ("control_work", &["control_work"]),
    ("max_penetration", &["max_penetration"]),
    ("sweeps", &["sweeps"]),
];

fn lookup<'a>(mut v: &'a Value, path: &[&str]) -> Option<&'a Value> {
    for p in path {
        v = match v {
            Value::Array(a) => {
                let i = if *p == "-1" {
                    a.len().checked_sub(1)?
                } else {
                    p.parse().ok()?
                };
                a.get(i)?
            }
            other => other.get(p)?,
        };
    }
    Some(v)
}

fn number(v: Option<&Value>) -> f64 {
    v.and_then(Value::as_f64).unwrap_or(f64::NAN)
}

/// The scalar results of a run from its `summary.json` (in `result_columns` order; NaN where
/// missing, e.g. a settling time never reached), its status and its failure message.
pub fn results_of(plan: &SweepPlan, summary: &Value) -> (String, Vec<f64>, String) {
    let cfg = &plan.base.config;
    let mut out = vec![
        number(summary.get("steps")),
        number(summary.get("final_time")),
    ];
    let rods = summary.get("rods").and_then(Value::as_array);
    for r in &cfg.rods.list {
        let entry = rods.and_then(|list| {
            list.iter()
                .find(|e| e.get("name").and_then(Value::as_str) == r.name.as_deref())
        });
        for (_, path) in ROD_RESULTS {
            out.push(number(entry.and_then(|e| lookup(e, path))));
        }
    }
    if cfg.controller.is_some() {
        let control = summary.get("control");
        for (_, path) in CONTROL_RESULTS {
            out.push(number(control.and_then(|c| lookup(c, path))));
        }
    }
    if cfg.muscle_control.is_some() {
        let m = summary.get("muscles");
        for (_, path) in MUSCLE_RESULTS {
            out.push(number(m.and_then(|c| lookup(c, path))));
        }
    }
    let status = summary
        .get("status")
        .and_then(Value::as_str)
        .unwrap_or("error")
        .to_string();
    let error = summary
        .get("failure")
        .and_then(|f| f.get("message"))
        .and_then(Value::as_str)
        .unwrap_or("")
        .to_string();
    (status, out, error)
}

/// The table's header: `run,id,status,<parameter columns>,<results>,error`.
pub fn columns(plan: &SweepPlan) -> Vec<String> {
    let mut out = vec!["run".to_string(), "id".into(), "status".into()];
    for p in &plan.parameters {
        out.extend(p.columns.iter().cloned());
    }
    out.extend(result_columns(plan));
    out.push("error".into());
    out
}

/// A number as the shortest text that reads back exactly (`nan`, `inf` for non-finite ones;
/// empty for a missing value).
pub fn fmt_cell_num(x: f64) -> String {
    if x.is_nan() {
        String::new()
    } else if x.is_infinite() {
        if x > 0.0 { "inf" } else { "-inf" }.to_string()
    } else {
        format!("{x:?}")
    }
}

fn csv_text(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The CSV header line (with its newline).
pub fn csv_header(plan: &SweepPlan) -> String {
    let cols: Vec<String> = columns(plan).iter().map(|c| csv_text(c)).collect();
    cols.join(",") + "\n"
}

/// A row as one CSV line (with its newline).
pub fn csv_line(row: &Row) -> String {
    let mut cells = vec![row.index.to_string(), row.id.clone(), row.status.clone()];
    for c in &row.cells {
        cells.push(match c {
            Cell::Num(x) => fmt_cell_num(*x),
            Cell::Text(s) => csv_text(s),
        });
    }
    cells.push(csv_text(&row.error.replace(['\n', '\r'], " ")));
    cells.join(",") + "\n"
}

/// Write the whole table as CSV to `path` (through a temporary file and a rename).
pub fn write_csv(path: &Path, plan: &SweepPlan, rows: &[&Row]) -> Result<()> {
    let mut text = csv_header(plan);
    for r in rows {
        text.push_str(&csv_line(r));
    }
    write_replacing(path, text.as_bytes())
}

/// Write `bytes` to `path` through a temporary sibling and a rename: whole or not at all.
pub fn write_replacing(path: &Path, bytes: &[u8]) -> Result<()> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.partial-{}", std::process::id()));
    std::fs::write(&tmp, bytes).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("cannot write {}", path.display()))
}

/// The table as `.npz`: one float64 array [runs] per numeric column and a Unicode array per
/// text column (`id`, `status`, `error`, text parameters), named by the column.
pub fn write_npz(path: &Path, plan: &SweepPlan, rows: &[&Row]) -> Result<()> {
    let cols = columns(plan);
    let n = rows.len();
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.partial-{}", std::process::id()));
    let file =
        std::fs::File::create(&tmp).with_context(|| format!("cannot write {}", tmp.display()))?;
    let mut npz = ZipWriter::new(std::io::BufWriter::new(file));
    let run: Vec<f64> = rows.iter().map(|r| r.index as f64).collect();
    write_member(&mut npz, "run", &[n], &run)?;
    write_text(&mut npz, "id", rows.iter().map(|r| r.id.as_str()).collect())?;
    write_text(
        &mut npz,
        "status",
        rows.iter().map(|r| r.status.as_str()).collect(),
    )?;
    for (c, col) in cols[3..cols.len() - 1].iter().enumerate() {
        let numeric = rows
            .iter()
            .all(|r| matches!(r.cells.get(c), Some(Cell::Num(_)) | None));
        if numeric {
            let xs: Vec<f64> = rows
                .iter()
                .map(|r| match r.cells.get(c) {
                    Some(Cell::Num(x)) => *x,
                    _ => f64::NAN,
                })
                .collect();
            write_member(&mut npz, col, &[n], &xs)?;
        } else {
            let texts: Vec<String> = rows
                .iter()
                .map(|r| match r.cells.get(c) {
                    Some(Cell::Num(x)) => fmt_cell_num(*x),
                    Some(Cell::Text(s)) => s.clone(),
                    None => String::new(),
                })
                .collect();
            write_text(&mut npz, col, texts.iter().map(String::as_str).collect())?;
        }
    }
    write_text(
        &mut npz,
        "error",
        rows.iter().map(|r| r.error.as_str()).collect(),
    )?;
    npz.finish()
        .and_then(|mut w| w.flush().map_err(Into::into))
        .with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("cannot write {}", path.display()))
}

/// A 1-D NumPy Unicode array (`<U{width}`, UTF-32 little endian) as a member of `npz`.
fn write_text<W: Write + std::io::Seek>(
    npz: &mut ZipWriter<W>,
    name: &str,
    texts: Vec<&str>,
) -> Result<()> {
    let width = texts
        .iter()
        .map(|t| t.chars().count())
        .max()
        .unwrap_or(0)
        .max(1);
    let mut dict = format!(
        "{{'descr': '<U{width}', 'fortran_order': False, 'shape': ({},), }}",
        texts.len()
    );
    // Padded so that the data starts at a multiple of 64 bytes, as npy_header does.
    let unpadded = 10 + dict.len() + 1;
    dict.push_str(&" ".repeat((64 - unpadded % 64) % 64));
    dict.push('\n');
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    bytes.extend_from_slice(&(dict.len() as u16).to_le_bytes());
    bytes.extend_from_slice(dict.as_bytes());
    for t in &texts {
        let mut k = 0;
        for c in t.chars() {
            bytes.extend_from_slice(&(c as u32).to_le_bytes());
            k += 1;
        }
        bytes.resize(bytes.len() + 4 * (width - k), 0);
    }
    npz.start_file(
        format!("{name}.npy"),
        SimpleFileOptions::default()
            .compression_method(CompressionMethod::Deflated)
            .compression_level(Some(crate::output::NPZ_LEVEL))
            .large_file(bytes.len() as u64 >= u32::MAX as u64 / 2),
    )?;
    npz.write_all(&bytes)?;
    Ok(())
}
