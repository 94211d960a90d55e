//! A sweep's summary figures, drawn from its results table only: for each scalar result that
//! varies, `figures/<result>.png` — the result against each swept numeric parameter (one panel
//! each), or, for a grid of exactly two swept numbers, a heat map. Failures are warnings.

use crate::figures::viridis;
use crate::plot::{ensure_font, err, mesh, png_canvas};
use crate::sweep::plan::{Cell, SweepPlan};
use crate::sweep::table::{self, Row};
use anyhow::Result;
use plotters::prelude::*;
use std::path::Path;

/// At most this many result figures (the first results of the table that vary).
const MAX_FIGURES: usize = 24;

/// A numeric column of the table: its name, and per row its value.
struct Column {
    name: String,
    values: Vec<f64>,
}

fn numeric_columns(names: &[String], rows: &[&Row], range: std::ops::Range<usize>) -> Vec<Column> {
    range
        .filter_map(|c| {
            let values: Vec<f64> = rows
                .iter()
                .map(|r| match r.cells.get(c) {
                    Some(Cell::Num(x)) => Some(*x),
                    _ => None,
                })
                .collect::<Option<Vec<f64>>>()?;
            Some(Column {
                name: names[c].clone(),
                values,
            })
        })
        .collect()
}

fn varies(v: &[f64]) -> bool {
    let finite: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    finite.len() >= 2 && finite.iter().any(|x| *x != finite[0])
}

/// Values shown on a log axis (as log10) when positive and spanning more than 100×.
fn log_axis(v: &[f64]) -> bool {
    let finite: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    let (lo, hi) = finite
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
    !finite.is_empty() && lo > 0.0 && hi / lo > 100.0
}

fn bounds(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for x in v.filter(|x| x.is_finite()) {
        lo = lo.min(x);
        hi = hi.max(x);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let pad = if hi > lo {
        0.05 * (hi - lo)
    } else {
        lo.abs().max(1e-12) * 0.05
    };
    (lo - pad, hi + pad)
}

fn label(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if (1e-3..1e4).contains(&v.abs()) {
        format!("{v:.4}")
            .trim_end_matches('0')
            .trim_end_matches('.')
            .to_string()
    } else {
        format!("{v:.2e}")
    }
}

/// Draw the figures of the completed rows into `root/figures/`; returns the names written
/// (relative to `root`, for the folder's marker).
pub fn draw(root: &Path, plan: &SweepPlan, rows: &[Row]) -> Vec<String> {
    let done: Vec<&Row> = rows.iter().filter(|r| r.completed()).collect();
    if done.len() < 2 {
        return Vec::new();
    }
    let names = table::columns(plan)[3..].to_vec();
    let n_params: usize = plan.parameters.iter().map(|p| p.columns.len()).sum();
    let params: Vec<Column> = numeric_columns(&names, &done, 0..n_params)
        .into_iter()
        .filter(|c| varies(&c.values))
        .collect();
    let results: Vec<Column> = numeric_columns(&names, &done, n_params..names.len() - 1)
        .into_iter()
        .filter(|c| varies(&c.values))
        .take(MAX_FIGURES)
        .collect();
    if params.is_empty() || results.is_empty() {
        return Vec::new();
    }
    let dir = root.join("figures");
    // An earlier invocation's figures (resume): removed by their marker, so none is stale.
    let _ = crate::outdir::remove_owned(&dir);
    if std::fs::create_dir_all(&dir).is_err() {
        tracing::warn!("figures not drawn: cannot create {}", dir.display());
        return Vec::new();
    }
    // A heat map needs a full grid of two crossed scalar parameters.
    let grid = params.len() == 2
        && plan.parameters.len() == 2
        && plan.parameters.iter().all(|p| p.columns.len() == 1)
        && plan.parameters[0].group != plan.parameters[1].group;
    let mut written = Vec::new();
    for r in &results {
        let file = format!("{}.png", r.name.replace(['/', '[', ']', '.'], "_"));
        let path = dir.join(&file);
        let drawn = if grid {
            heat_map(&path, &params[0], &params[1], r)
        } else {
            panels(&path, &params, r)
        };
        match drawn {
            Ok(()) => written.push(file),
            Err(e) => tracing::warn!("{} not drawn: {e:#}", path.display()),
        }
    }
    if written.is_empty() {
        let _ = std::fs::remove_dir(&dir);
        return Vec::new();
    }
    // The figures folder is octoarm's too: its own marker lists what it holds.
    let marker = crate::outdir::Marker {
        kind: "figures".into(),
        run: String::new(),
        entries: written.clone(),
    };
    if let Err(e) = marker.write(&dir) {
        tracing::warn!("{e:#}");
    }
    vec!["figures/".to_string()]
}

/// The result against each parameter, one panel per parameter, one point per run.
fn panels(path: &Path, params: &[Column], r: &Column) -> Result<()> {
    ensure_font();
    let n = params.len();
    let cols = n.min(3);
    let rows = n.div_ceil(cols);
    let size = (420 * cols as u32 + 40, 360 * rows as u32 + 60);
    let root = png_canvas(
        path,
        size,
        &format!("{} against the swept parameters", r.name),
        24,
    )?;
    let areas = root.split_evenly((rows, cols));
    let (y0, y1) = bounds(r.values.iter().copied());
    for (p, area) in params.iter().zip(&areas) {
        let log = log_axis(&p.values);
        let xs: Vec<f64> = p
            .values
            .iter()
            .map(|&x| if log { x.log10() } else { x })
            .collect();
        let (x0, x1) = bounds(xs.iter().copied());
        let mut chart = ChartBuilder::on(area)
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(80)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(err)?;
        let x_desc = if log {
            format!("log10 {}", p.name)
        } else {
            p.name.clone()
        };
        mesh(&mut chart, &x_desc, &r.name, 13, 15)
            .x_label_formatter(&|v| label(*v))
            .y_label_formatter(&|v| label(*v))
            .x_labels(5)
            .draw()
            .map_err(err)?;
        let colour = RGBColor(31, 119, 180);
        chart
            .draw_series(
                xs.iter()
                    .zip(&r.values)
                    .filter(|(x, y)| x.is_finite() && y.is_finite())
                    .map(|(&x, &y)| Circle::new((x, y), 4, colour.filled())),
            )
            .map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}

/// A heat map of the result over a grid of two parameters (viridis; the colour scale's range
/// in the title).
fn heat_map(path: &Path, a: &Column, b: &Column, r: &Column) -> Result<()> {
    ensure_font();
    let distinct = |v: &[f64]| {
        let mut d: Vec<f64> = v.to_vec();
        d.sort_by(f64::total_cmp);
        d.dedup();
        d
    };
    let (xa, xb) = (distinct(&a.values), distinct(&b.values));
    let (lo, hi) = r
        .values
        .iter()
        .filter(|x| x.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
            (l.min(x), h.max(x))
        });
    let title = format!(
        "{} over {} and {} (colour: {} to {})",
        r.name,
        a.name,
        b.name,
        label(lo),
        label(hi)
    );
    let root = png_canvas(path, (900, 760), &title, 20)?;
    let (na, nb) = (xa.len() as f64, xb.len() as f64);
    let mut chart = ChartBuilder::on(&root)
        .margin(20)
        .x_label_area_size(55)
        .y_label_area_size(90)
        .build_cartesian_2d(0.0..na, 0.0..nb)
        .map_err(err)?;
    let at = |v: &[f64], k: f64| {
        let i = k.floor() as usize;
        v.get(i).map(|x| label(*x)).unwrap_or_default()
    };
    mesh(&mut chart, &a.name, &b.name, 14, 17)
        .x_labels(xa.len().min(12) + 1)
        .y_labels(xb.len().min(12) + 1)
        .x_label_formatter(&|k| at(&xa, *k))
        .y_label_formatter(&|k| at(&xb, *k))
        .draw()
        .map_err(err)?;
    let cells = a
        .values
        .iter()
        .zip(&b.values)
        .zip(&r.values)
        .filter_map(|((x, y), z)| {
            let i = xa.iter().position(|v| v == x)? as f64;
            let j = xb.iter().position(|v| v == y)? as f64;
            let colour = if z.is_finite() {
                viridis(if hi > lo { (z - lo) / (hi - lo) } else { 0.5 })
            } else {
                RGBColor(200, 200, 200)
            };
            Some(Rectangle::new(
                [(i, j), (i + 1.0, j + 1.0)],
                colour.filled(),
            ))
        });
    chart.draw_series(cells).map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}
