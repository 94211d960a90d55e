//! Figures of controlled runs, in the style of the paper's Fig. 3 and Fig. 4 (control spec §5.6):
//! `shapes.png` (arm shapes at 8 instants in purple shades, desired shape in green, targets as
//! red crosses, obstacles as grey discs, axes in units of L0), the animated `shapes.gif`, and the
//! run-wide `distance.png`. Drawn from recorded frames and series only.

use crate::gif::GifWriter;
use crate::plot::{
    draw_disc, ensure_font, equal_box, equal_chart, err, legend, mesh, mix_rgb, png_canvas, tick,
    Chart,
};
use anyhow::{anyhow, Result};
use octoarm_control::{SphereSpec, TargetPhase};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

pub use crate::recorder::ControlFrame as FigureFrame;

/// What the control figures need to know about a controlled run.
#[derive(Debug, Clone)]
pub struct ControlFigureSpec {
    /// Name (the scenario's file stem), shown in the GIF.
    pub name: String,
    /// Arm length L0 [m], the axes' unit.
    pub length: f64,
    /// Task targets (segments).
    pub targets: Vec<TargetPhase>,
    /// Spheres drawn (obstacles and the grasped object).
    pub spheres: Vec<SphereSpec>,
    /// Whether it is a grasp (no tip targets).
    pub grasp: bool,
    /// Time between frames [s].
    pub frame_interval: f64,
}

/// Green of the desired shape.
const DESIRED: RGBColor = RGBColor(34, 160, 60);
/// Light green of B's many desired shapes.
const DESIRED_LIGHT: RGBColor = RGBColor(150, 215, 150);
/// Red of the targets.
const TARGET: RGBColor = RGBColor(220, 20, 30);
/// Grey of the obstacles.
const OBSTACLE: RGBColor = RGBColor(170, 170, 170);

/// Purple shade for `u` in [0, 1]: light (early) to dark (late).
pub fn purple(u: f64) -> RGBColor {
    mix_rgb(
        (205.0, 180.0, 235.0),
        (60.0, 10.0, 110.0),
        u.clamp(0.0, 1.0),
    )
}

/// Start times of the segments of constant task target (one segment for a grasp or a single
/// target).
fn segment_starts(spec: &ControlFigureSpec) -> Vec<f64> {
    let mut s: Vec<f64> = spec.targets.iter().map(|t| t.from.max(0.0)).collect();
    if s.is_empty() {
        s.push(0.0);
    }
    s[0] = 0.0;
    s
}

/// Whether the task target moves (experiment B).
fn moving_target(spec: &ControlFigureSpec) -> bool {
    spec.targets.iter().any(|t| t.velocity != [0.0; 3])
}

/// Frames drawn in `shapes.png`: 8 evenly spaced over the run, split evenly between the
/// segments (A: 4 per segment), each segment's first and last frame included. Returns, per
/// segment, the frame indices.
pub fn picked_frames(spec: &ControlFigureSpec, frames: &[FigureFrame]) -> Vec<Vec<usize>> {
    let starts = segment_starts(spec);
    let per = (8 / starts.len()).max(2);
    let mut out = Vec::new();
    for (k, &start) in starts.iter().enumerate() {
        let end = starts.get(k + 1).copied().unwrap_or(f64::INFINITY);
        let idx: Vec<usize> = (0..frames.len())
            .filter(|&i| frames[i].time >= start - 1e-9 && frames[i].time < end - 1e-9)
            .collect();
        if idx.is_empty() {
            continue;
        }
        let m = per.min(idx.len());
        let mut pick: Vec<usize> = (0..m)
            .map(|j| idx[(j * (idx.len() - 1) + (m - 1).max(1) / 2) / (m - 1).max(1)])
            .collect();
        pick.dedup();
        out.push(pick);
    }
    out
}

/// Bounding box (in units of L0) of the given points and spheres.
fn bounds<'a>(
    points: impl Iterator<Item = &'a [f64; 3]>,
    spheres: &[SphereSpec],
    length: f64,
) -> ([f64; 2], [f64; 2]) {
    let mut lo = [0.0f64; 2];
    let mut hi = [0.0f64; 2];
    for p in points {
        for c in 0..2 {
            if p[c].is_finite() {
                lo[c] = lo[c].min(p[c] / length);
                hi[c] = hi[c].max(p[c] / length);
            }
        }
    }
    for s in spheres {
        let r = 0.5 * s.diameter / length;
        for c in 0..2 {
            lo[c] = lo[c].min(s.center[c] / length - r);
            hi[c] = hi[c].max(s.center[c] / length + r);
        }
    }
    (lo, hi)
}

fn scaled(x: &[[f64; 3]], length: f64) -> Vec<(f64, f64)> {
    x.iter().map(|p| (p[0] / length, p[1] / length)).collect()
}

/// A polyline `width` pixels wide drawn as filled quads with round joints: plotters' own wide
/// lines leave jagged edges. `per_px` is data units per pixel (equal on both axes).
fn thick_path(
    chart: &mut Chart,
    pts: &[(f64, f64)],
    colour: RGBColor,
    width: f64,
    per_px: f64,
) -> Result<()> {
    let h = 0.5 * width * per_px;
    let style = colour.filled();
    chart
        .draw_series(pts.windows(2).filter_map(|w| {
            let (a, b) = (w[0], w[1]);
            let (dx, dy) = (b.0 - a.0, b.1 - a.1);
            let l = (dx * dx + dy * dy).sqrt();
            (l > 0.0).then(|| {
                let (nx, ny) = (-dy / l * h, dx / l * h);
                Polygon::new(
                    vec![
                        (a.0 + nx, a.1 + ny),
                        (b.0 + nx, b.1 + ny),
                        (b.0 - nx, b.1 - ny),
                        (a.0 - nx, a.1 - ny),
                    ],
                    style,
                )
            })
        }))
        .map_err(err)?;
    let r = (0.5 * width).round().max(1.0) as i32;
    chart
        .draw_series(pts.iter().map(|&p| Circle::new(p, r - 1, style)))
        .map_err(err)?;
    Ok(())
}

fn draw_spheres(chart: &mut Chart, spheres: &[SphereSpec], length: f64) -> Result<()> {
    for s in spheres {
        draw_disc(
            chart,
            (s.center[0] / length, s.center[1] / length),
            0.5 * s.diameter / length,
            OBSTACLE.filled(),
            RGBColor(120, 120, 120).stroke_width(1),
        )?;
    }
    Ok(())
}

fn draw_cross(chart: &mut Chart, p: [f64; 3], length: f64, size: i32) -> Result<()> {
    chart
        .draw_series(std::iter::once(Cross::new(
            (p[0] / length, p[1] / length),
            size,
            TARGET.stroke_width(3),
        )))
        .map_err(err)?;
    Ok(())
}

fn draw_base(chart: &mut Chart) -> Result<()> {
    chart
        .draw_series(std::iter::once(Rectangle::new(
            [(-0.02, -0.06), (0.0, 0.06)],
            BLACK.filled(),
        )))
        .map_err(err)?;
    Ok(())
}

/// `shapes.png` in the style of the paper's Fig. 3 (control spec §5.6).
pub fn shapes_png(
    path: &Path,
    spec: &ControlFigureSpec,
    frames: &[FigureFrame],
    title: &str,
) -> Result<()> {
    ensure_font();
    if frames.is_empty() {
        return Err(anyhow!("no recorded frames"));
    }
    let length = spec.length;
    let spheres = spec.spheres.clone();
    let segments = picked_frames(spec, frames);
    let picks: Vec<usize> = segments.iter().flatten().copied().collect();
    let moving = moving_target(spec);
    let last_of_segment: Vec<usize> = segments.iter().filter_map(|s| s.last().copied()).collect();
    let desired_drawn: Vec<usize> = if moving {
        picks.clone()
    } else {
        last_of_segment.clone()
    };
    let targets: Vec<[f64; 3]> = if moving {
        picks.iter().filter_map(|&i| frames[i].target).collect()
    } else {
        last_of_segment
            .iter()
            .filter_map(|&i| frames[i].target)
            .collect()
    };
    let points = picks
        .iter()
        .flat_map(|&i| frames[i].position.iter())
        .chain(desired_drawn.iter().flat_map(|&i| frames[i].desired.iter()))
        .chain(targets.iter());
    let flat: Vec<&[f64; 3]> = points.clone().collect();
    if crate::projection::is_three_dimensional(flat.iter().copied()) {
        return shapes_png_3d(path, spec, frames, &picks, &desired_drawn, &targets, title);
    }
    let (mut lo, hi) = bounds(points, &spheres, length);
    lo[0] = lo[0].min(-0.05);

    let width = 1100u32;
    let root = png_canvas(path, (width, 800), title, 28)?;
    let (main, side) = root.split_horizontally(width - 230);
    let mut chart = equal_chart(&main, lo, hi, 20, 60, 75)?;
    mesh(&mut chart, "x / L0", "y / L0", 18, 22)
        .x_label_formatter(&|v| tick(*v, 1))
        .y_label_formatter(&|v| tick(*v, 1))
        .draw()
        .map_err(err)?;
    draw_spheres(&mut chart, &spheres, length)?;
    let (area_w, _) = chart.plotting_area().dim_in_pixel();
    let x_range = chart.x_range();
    let per_px = (x_range.end - x_range.start) / area_w as f64;
    let n_picks = picks.len().max(2);
    if moving {
        // B: every drawn instant's desired shape, thin and light, under the arm.
        for &i in &desired_drawn {
            thick_path(
                &mut chart,
                &scaled(&frames[i].desired, length),
                DESIRED_LIGHT,
                2.5,
                per_px,
            )?;
        }
    }
    for (k, &i) in picks.iter().enumerate() {
        let colour = purple(k as f64 / (n_picks - 1) as f64);
        thick_path(
            &mut chart,
            &scaled(&frames[i].position, length),
            colour,
            4.5,
            per_px,
        )?;
    }
    if !moving {
        // The desired shape of each segment's last instant, over the arm that converged to it.
        for &i in &desired_drawn {
            thick_path(
                &mut chart,
                &scaled(&frames[i].desired, length),
                DESIRED,
                2.0,
                per_px,
            )?;
        }
    }
    for t in &targets {
        draw_cross(&mut chart, *t, length, 10)?;
    }
    draw_base(&mut chart)?;

    // Legend on the right: one entry per drawn instant, then the other marks.
    let font = ("sans-serif", 19).into_font();
    let mut y = 60i32;
    side.draw(&Text::new("arm at", (10, y), font.clone()))
        .map_err(err)?;
    y += 30;
    for (k, &i) in picks.iter().enumerate() {
        let colour = purple(k as f64 / (n_picks - 1) as f64);
        side.draw(&PathElement::new(
            vec![(10, y + 10), (50, y + 10)],
            colour.stroke_width(5),
        ))
        .map_err(err)?;
        side.draw(&Text::new(
            format!("t = {:.2} s", frames[i].time),
            (60, y),
            font.clone(),
        ))
        .map_err(err)?;
        y += 28;
    }
    y += 14;
    let desired_label = if moving {
        "desired shapes"
    } else {
        "desired shape"
    };
    side.draw(&PathElement::new(
        vec![(10, y + 10), (50, y + 10)],
        (if moving { DESIRED_LIGHT } else { DESIRED }).stroke_width(4),
    ))
    .map_err(err)?;
    side.draw(&Text::new(desired_label, (60, y), font.clone()))
        .map_err(err)?;
    y += 30;
    if !targets.is_empty() {
        side.draw(&Cross::new((30, y + 10), 8, TARGET.stroke_width(3)))
            .map_err(err)?;
        side.draw(&Text::new("target", (60, y), font.clone()))
            .map_err(err)?;
        y += 30;
    }
    if !spheres.is_empty() {
        side.draw(&Circle::new((30, y + 10), 10, OBSTACLE.filled()))
            .map_err(err)?;
        let label = if spec.grasp { "object" } else { "obstacle" };
        side.draw(&Text::new(label, (60, y), font.clone()))
            .map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}

/// The 3D scene of a controlled run: the arm at `picks` in purple shades (or one frame in
/// `purple(0.8)`), desired shapes in green, targets as red crosses, spheres in grey.
fn control_scene(
    spec: &ControlFigureSpec,
    frames: &[FigureFrame],
    picks: &[usize],
    desired: &[usize],
    targets: &[[f64; 3]],
) -> crate::projection::Scene3 {
    use crate::projection::{Scene3, Stroke};
    let mut scene = Scene3::default();
    for s in &spec.spheres {
        scene.balls.push((s.center, 0.5 * s.diameter, OBSTACLE));
    }
    let n = picks.len().max(2);
    for (k, &i) in picks.iter().enumerate() {
        let colour = if picks.len() == 1 {
            purple(0.8)
        } else {
            purple(k as f64 / (n - 1) as f64)
        };
        scene.strokes.push(Stroke {
            points: frames[i].position.clone(),
            colours: vec![colour],
            width: 3.5,
        });
    }
    for &i in desired {
        if frames[i].desired.iter().flatten().all(|x| x.is_finite()) {
            scene.strokes.push(Stroke {
                points: frames[i].desired.clone(),
                colours: vec![DESIRED],
                width: 1.5,
            });
        }
    }
    for t in targets {
        scene.crosses.push((*t, TARGET));
    }
    scene
}

/// `shapes.png` of a controlled run leaving the x–y plane: the picked instants in three
/// orthographic projections and a perspective view.
fn shapes_png_3d(
    path: &Path,
    spec: &ControlFigureSpec,
    frames: &[FigureFrame],
    picks: &[usize],
    desired: &[usize],
    targets: &[[f64; 3]],
    title: &str,
) -> Result<()> {
    let scene = control_scene(spec, frames, picks, desired, targets);
    let root = png_canvas(path, (1200, 1000), &format!("{title} (3D)"), 28)?;
    crate::projection::draw_four_views(&root, &scene, 16)?;
    root.present().map_err(err)?;
    Ok(())
}

/// Draw one animation frame into `area`.
#[allow(clippy::too_many_arguments)]
fn gif_frame(
    area: &DrawingArea<BitMapBackend, Shift>,
    spec: &ControlFigureSpec,
    frame: &FigureFrame,
    range: (f64, f64, f64, f64),
    margin: u32,
    xlab: u32,
    ylab: u32,
) -> Result<()> {
    let length = spec.length;
    area.fill(&WHITE).map_err(err)?;
    let (x0, x1, y0, y1) = range;
    let mut chart = ChartBuilder::on(area)
        .margin(margin)
        .x_label_area_size(xlab)
        .y_label_area_size(ylab)
        .caption(
            format!("{}   t = {:.2} s", spec.name, frame.time),
            ("sans-serif", 20),
        )
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(err)?;
    // A slightly darker grid than the still figure's: the frames are small.
    mesh(&mut chart, "x / L0", "y / L0", 14, 16)
        .x_label_formatter(&|v| tick(*v, 1))
        .y_label_formatter(&|v| tick(*v, 1))
        .bold_line_style(BLACK.mix(0.1))
        .draw()
        .map_err(err)?;
    draw_spheres(&mut chart, &spec.spheres, length)?;
    let (pw, _) = chart.plotting_area().dim_in_pixel();
    let per_px = (x1 - x0) / pw as f64;
    thick_path(
        &mut chart,
        &scaled(&frame.position, length),
        purple(0.8),
        4.0,
        per_px,
    )?;
    thick_path(
        &mut chart,
        &scaled(&frame.desired, length),
        DESIRED,
        2.0,
        per_px,
    )?;
    if let Some(t) = frame.target {
        draw_cross(&mut chart, t, length, 7)?;
    }
    draw_base(&mut chart)?;
    Ok(())
}

/// `shapes.gif`: every k-th frame (at most ~100 frames, played in real time), arm in purple,
/// desired shape in green, target, obstacles; fixed axes in units of L0.
pub fn shapes_gif(path: &Path, spec: &ControlFigureSpec, frames: &[FigureFrame]) -> Result<()> {
    ensure_font();
    if frames.is_empty() {
        return Err(anyhow!("no recorded frames"));
    }
    let length = spec.length;
    let stride = frames.len().div_ceil(100).max(1);
    let shown: Vec<&FigureFrame> = frames
        .iter()
        .enumerate()
        .filter(|(i, _)| i % stride == 0 || *i == frames.len() - 1)
        .map(|(_, f)| f)
        .collect();
    let points = shown.iter().flat_map(|f| {
        f.position
            .iter()
            .chain(f.desired.iter())
            .chain(f.target.iter())
    });
    let three_d = crate::projection::is_three_dimensional(points.clone());
    let (mut lo, hi) = bounds(points, &spec.spheres, length);
    lo[0] = lo[0].min(-0.05);
    let (w, h) = if three_d {
        (720u32, 600u32)
    } else {
        (560u32, 440u32)
    };
    let (margin, xlab, ylab) = (10u32, 45u32, 55u32);
    let range = equal_box(
        lo,
        hi,
        (w - 2 * margin - ylab) as f64,
        (h - 2 * margin - xlab - 30) as f64,
    );
    let frame_dt = if frames.len() >= 2 {
        frames[1].time - frames[0].time
    } else {
        spec.frame_interval
    };
    let delay = ((stride as f64 * frame_dt * 100.0).round() as u16).max(2);
    let box3 = {
        let all = control_scene(
            spec,
            frames,
            &(0..frames.len()).step_by(stride).collect::<Vec<_>>(),
            &[],
            &[],
        );
        all.bounds()
    };
    let file = BufWriter::new(File::create(path)?);
    let mut gif = GifWriter::new(file, w as u16, h as u16)?;
    let mut buf = vec![0u8; (3 * w * h) as usize];
    for (k, f) in shown.iter().enumerate() {
        {
            let area = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            if three_d {
                // Every frame in the same box: the first, all shown frames and the spheres.
                area.fill(&WHITE).map_err(err)?;
                let area = area
                    .titled(
                        &format!("{}   t = {:.2} s", spec.name, f.time),
                        ("sans-serif", 18),
                    )
                    .map_err(err)?;
                let targets: Vec<[f64; 3]> = f.target.into_iter().collect();
                let mut scene = control_scene(spec, std::slice::from_ref(*f), &[0], &[0], &targets);
                // Fix the panels' box: invisible zero-width strokes at the run's corners.
                scene.strokes.push(crate::projection::Stroke {
                    points: vec![box3.0, box3.1],
                    colours: vec![WHITE],
                    width: 0.0,
                });
                crate::projection::draw_four_views(&area, &scene, 12)?;
            } else {
                gif_frame(&area, spec, f, range, margin, xlab, ylab)?;
            }
            area.present().map_err(err)?;
        }
        // Hold the last frame for a second before the loop restarts.
        let d = if k + 1 == shown.len() {
            delay.max(100)
        } else {
            delay
        };
        gif.frame(&buf, d)?;
    }
    gif.finish()?;
    Ok(())
}

/// One curve of `distance.png`.
pub struct DistanceCurve<'a> {
    /// Legend label.
    pub label: String,
    /// Line colour.
    pub colour: RGBColor,
    /// (time [s], distance / L0) samples.
    pub points: &'a [(f64, f64)],
}

/// Colour of the i-th curve of `distance.png`: orange (the paper's A), blue, green, purple,
/// then black.
pub fn experiment_colour(i: usize) -> RGBColor {
    match i {
        0 => RGBColor(245, 130, 20),
        1 => RGBColor(31, 100, 200),
        2 => RGBColor(40, 160, 60),
        3 => RGBColor(130, 50, 170),
        _ => BLACK,
    }
}

/// At most about `max` of `points`, evenly strided, the last one always included (wide lines
/// through thousands of 1 ms samples come out frayed).
fn thin(points: &[(f64, f64)], max: usize) -> impl Iterator<Item = (f64, f64)> + '_ {
    let stride = points.len().div_ceil(max.max(1)).max(1);
    let last = points.len().saturating_sub(1);
    points
        .iter()
        .enumerate()
        .filter(move |(i, _)| i % stride == 0 || *i == last)
        .map(|(_, p)| *p)
}

/// `distance.png` in the style of the paper's Fig. 4: distance / L0 against time for every run,
/// linear axes, with a target switch marked at `switch` (label, time [s]); a second,
/// logarithmic panel below shows the tails (B's tracking lag, the final distances).
pub fn distance_png(
    path: &Path,
    curves: &[DistanceCurve],
    switch: Option<(String, f64)>,
) -> Result<()> {
    ensure_font();
    let t_end = curves
        .iter()
        .filter_map(|c| c.points.last().map(|p| p.0))
        .fold(0.0f64, f64::max)
        .max(1e-3);
    let d_max = curves
        .iter()
        .flat_map(|c| c.points.iter().map(|p| p.1))
        .filter(|d| d.is_finite())
        .fold(0.0f64, f64::max)
        .max(1e-3);
    let root = png_canvas(
        path,
        (1100, 900),
        "distance to target (A-C: tip; D: grasp gap)",
        26,
    )?;
    let (top, bottom) = root.split_vertically(560);
    let mut chart = ChartBuilder::on(&top)
        .margin(20)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..t_end, 0.0..1.08 * d_max)
        .map_err(err)?;
    mesh(&mut chart, "time [s]", "distance / L0", 18, 22)
        .x_label_formatter(&|v| format!("{v:.1}"))
        .y_label_formatter(&|v| format!("{v:.1}"))
        .draw()
        .map_err(err)?;
    if let Some((who, ts)) = switch.filter(|s| s.1 < t_end) {
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(ts, 0.0), (ts, 1.08 * d_max)],
                BLACK.mix(0.45).stroke_width(1),
            )))
            .map_err(err)?;
        chart
            .draw_series(std::iter::once(Text::new(
                format!("{who}: target switch at {ts} s"),
                // Left of the line, above the curves (A peaks just after the switch).
                ((ts - 0.22 * t_end).max(0.0), 1.0 * d_max),
                ("sans-serif", 18).into_font(),
            )))
            .map_err(err)?;
    }
    for c in curves {
        let colour = c.colour;
        chart
            .draw_series(LineSeries::new(thin(c.points, 800), colour.stroke_width(2)))
            .map_err(err)?
            .label(c.label.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 26, y)], colour.stroke_width(4))
            });
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight, 18, 0.9)?;

    // Logarithmic panel: the same curves, to read the tails.
    let floor = 1e-5;
    let mut log = ChartBuilder::on(&bottom)
        .margin(20)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..t_end, (floor..2.0 * d_max).log_scale())
        .map_err(err)?;
    mesh(&mut log, "time [s]", "distance / L0 (log)", 16, 20)
        .x_label_formatter(&|v| format!("{v:.1}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(err)?;
    log.draw_series(std::iter::once(PathElement::new(
        vec![(0.0, 0.02), (t_end, 0.02)],
        BLACK.mix(0.35).stroke_width(1),
    )))
    .map_err(err)?;
    log.draw_series(std::iter::once(Text::new(
        "settling band 0.02",
        (0.01 * t_end, 0.024),
        ("sans-serif", 15).into_font(),
    )))
    .map_err(err)?;
    for c in curves {
        log.draw_series(LineSeries::new(
            thin(c.points, 800)
                .filter(|p| p.1.is_finite())
                .map(|(t, d)| (t, d.max(floor))),
            c.colour.stroke_width(2),
        ))
        .map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}
