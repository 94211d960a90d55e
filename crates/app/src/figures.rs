//! Figures drawn from recorded data only: `shapes.png` (centrelines over time, coloured by time,
//! equal axes, obstacles outlined) and `energy.png` (energies, work and dissipation over time).
//! Text uses DejaVu Sans compiled into the binary, so no system font is ever looked up.

use crate::plot::{
    draw_disc, ensure_font, equal_chart, err, legend, mesh, mix_rgb, png_canvas, tick,
};
use crate::recorder::TrajectoryRecorder as Recorder;
use anyhow::{anyhow, Result};
use octoarm_physics::Sphere;
use plotters::prelude::*;
use std::path::Path;

/// Viridis colour map, `u` in [0, 1] (perceptually uniform, readable in grey).
pub fn viridis(u: f64) -> RGBColor {
    const STOPS: [(f64, f64, f64); 6] = [
        (68.0, 1.0, 84.0),
        (65.0, 68.0, 135.0),
        (42.0, 120.0, 142.0),
        (34.0, 168.0, 132.0),
        (122.0, 209.0, 81.0),
        (253.0, 231.0, 37.0),
    ];
    let x = u.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    mix_rgb(STOPS[i], STOPS[i + 1], x - i as f64)
}

const AXIS: [&str; 3] = ["x", "y", "z"];

/// Centrelines of every rod at the recorded frames (up to ~40, evenly spread in time, the last
/// always included), projected on the two lab axes with the largest extent, equal scales,
/// colour by time with a colour bar; the tip paths as thin grey lines; obstacles as outlines;
/// held bases as black dots.
pub fn shapes_png(
    path: &Path,
    rec: &Recorder,
    obstacles: &[Sphere],
    bases: &[[f64; 3]],
    title: &str,
) -> Result<()> {
    ensure_font();
    let shapes = &rec.shapes;
    if shapes.is_empty() {
        return Err(anyhow!("no recorded frames"));
    }
    let (t0, t1) = (shapes[0].0, shapes[shapes.len() - 1].0);
    let pick: Vec<usize> = {
        let k = 40usize.min(shapes.len());
        let mut v: Vec<usize> = (0..k)
            .map(|i| i * (shapes.len() - 1) / (k - 1).max(1))
            .collect();
        v.dedup();
        v
    };
    // Axes: the two with the largest extent over all drawn points.
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in shapes
        .iter()
        .flat_map(|(_, rods)| rods.iter().flatten())
        .chain(rec.tips.iter().flatten())
    {
        for c in 0..3 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    let all_points = shapes
        .iter()
        .flat_map(|(_, rods)| rods.iter().flatten())
        .chain(rec.tips.iter().flatten());
    if crate::projection::is_three_dimensional(all_points) {
        return shapes_png_3d(path, rec, obstacles, bases, title, &pick, t0, t1);
    }
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| (hi[b] - lo[b]).total_cmp(&(hi[a] - lo[a])).then(a.cmp(&b)));
    let (ax, ay) = if order[0] < order[1] {
        (order[0], order[1])
    } else {
        (order[1], order[0])
    };
    for o in obstacles {
        let r = o.radius;
        for c in [ax, ay] {
            lo[c] = lo[c].min(o.center[c] - r);
            hi[c] = hi[c].max(o.center[c] + r);
        }
    }

    let width = 1000u32;
    let root = png_canvas(path, (width, 800), &format!("{title}: centrelines"), 26)?;
    let (main, bar) = root.split_horizontally(width - 130);
    let (margin, xlab, ylab) = (20u32, 55u32, 85u32);
    let mut chart = equal_chart(
        &main,
        [lo[ax], lo[ay]],
        [hi[ax], hi[ay]],
        margin,
        xlab,
        ylab,
    )?;
    mesh(
        &mut chart,
        &format!("{} [m]", AXIS[ax]),
        &format!("{} [m]", AXIS[ay]),
        16,
        20,
    )
    .x_label_formatter(&|v| tick(*v, 3))
    .y_label_formatter(&|v| tick(*v, 3))
    .draw()
    .map_err(err)?;

    for o in obstacles {
        draw_disc(
            &mut chart,
            (o.center[ax], o.center[ay]),
            o.radius,
            RGBColor(200, 200, 200).mix(0.5).filled(),
            RGBColor(120, 120, 120).stroke_width(2),
        )?;
    }
    for tips in &rec.tips {
        let tip: Vec<(f64, f64)> = tips.iter().map(|p| (p[ax], p[ay])).collect();
        chart
            .draw_series(LineSeries::new(
                tip,
                RGBColor(150, 150, 150).stroke_width(1),
            ))
            .map_err(err)?;
    }
    let span = if t1 > t0 { t1 - t0 } else { 1.0 };
    for &i in &pick {
        let (t, rods) = &shapes[i];
        let colour = viridis((t - t0) / span);
        for x in rods {
            let line: Vec<(f64, f64)> = x.iter().map(|p| (p[ax], p[ay])).collect();
            chart
                .draw_series(LineSeries::new(line, colour.stroke_width(2)))
                .map_err(err)?;
        }
    }
    if !bases.is_empty() {
        chart
            .draw_series(
                bases
                    .iter()
                    .map(|b| Circle::new((b[ax], b[ay]), 5, BLACK.filled())),
            )
            .map_err(err)?
            .label("held base")
            .legend(|(x, y)| Circle::new((x, y), 4, BLACK.filled()));
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight, 16, 0.8)?;
    colour_bar(&bar, margin, xlab, t0, span)?;
    root.present().map_err(err)?;
    Ok(())
}

/// `shapes.png` of a run leaving the plane: the centrelines (coloured by time), tip paths,
/// obstacles and held bases in three orthographic projections and a perspective view.
#[allow(clippy::too_many_arguments)]
fn shapes_png_3d(
    path: &Path,
    rec: &Recorder,
    obstacles: &[Sphere],
    bases: &[[f64; 3]],
    title: &str,
    pick: &[usize],
    t0: f64,
    t1: f64,
) -> Result<()> {
    use crate::projection::{draw_four_views, Scene3, Stroke};
    let span = if t1 > t0 { t1 - t0 } else { 1.0 };
    let mut scene = Scene3::default();
    for tips in &rec.tips {
        scene.strokes.push(Stroke {
            points: tips.clone(),
            colours: vec![RGBColor(150, 150, 150)],
            width: 1.0,
        });
    }
    for &i in pick {
        let (t, rods) = &rec.shapes[i];
        let colour = viridis((t - t0) / span);
        for x in rods {
            scene.strokes.push(Stroke {
                points: x.clone(),
                colours: vec![colour],
                width: 2.0,
            });
        }
    }
    for o in obstacles {
        scene
            .balls
            .push((o.center, o.radius, RGBColor(200, 200, 200)));
    }
    for b in bases {
        scene.dots.push((*b, BLACK));
    }
    let width = 1200u32;
    let root = png_canvas(
        path,
        (width, 1000),
        &format!("{title}: centrelines (3D)"),
        26,
    )?;
    let (main, bar) = root.split_horizontally(width - 130);
    draw_four_views(&main, &scene, 16)?;
    colour_bar(&bar, 20, 55, t0, span)?;
    root.present().map_err(err)?;
    Ok(())
}

/// Colours of the seven muscle groups in `design.png` (TM, LM0..LM3, OM+, OM−).
pub const GROUP_COLOURS: [RGBColor; 7] = [
    RGBColor(120, 120, 120),
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(227, 119, 194),
];

/// `design.png` of a muscle run: the design pose in three orthographic projections and a
/// perspective view, each element coloured by its most active group (the group's colour mixed
/// from light grey by the activation), the final pose of the run (black, thin), the tip target
/// (cross), the base and the grasped cylinder (outline).
pub fn design_png(
    path: &Path,
    design: &crate::muscle_run::MuscleDesignRun,
    final_pose: Option<&[[f64; 3]]>,
    cylinders: &[octoarm_physics::Cylinder],
    title: &str,
) -> Result<()> {
    use crate::projection::{draw_four_views, Scene3, Stroke};
    ensure_font();
    let n = design.n;
    let a = &design.activations;
    let colours: Vec<RGBColor> = (0..n)
        .map(|j| {
            let (g, v) =
                (0..7)
                    .map(|g| (g, a[g * n + j]))
                    .fold((0, 0.0), |b, x| if x.1 > b.1 { x } else { b });
            let c = GROUP_COLOURS[g];
            mix_rgb(
                (225.0, 225.0, 225.0),
                (f64::from(c.0), f64::from(c.1), f64::from(c.2)),
                v.clamp(0.0, 1.0),
            )
        })
        .collect();
    let mut scene = Scene3::default();
    for c in cylinders {
        let ax = c.axis;
        let helper = if ax[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let e1 = octoarm_physics::math::normalize(octoarm_physics::math::cross(ax, helper))
            .unwrap_or([1.0, 0.0, 0.0]);
        let e2 = octoarm_physics::math::cross(ax, e1);
        let grey = RGBColor(170, 170, 170);
        for h in [-0.5, -0.25, 0.0, 0.25, 0.5] {
            let ring: Vec<[f64; 3]> = (0..=48)
                .map(|k| {
                    let t = k as f64 / 48.0 * std::f64::consts::TAU;
                    std::array::from_fn(|i| {
                        c.center[i]
                            + h * c.length * ax[i]
                            + c.radius * (t.cos() * e1[i] + t.sin() * e2[i])
                    })
                })
                .collect();
            scene.strokes.push(Stroke {
                points: ring,
                colours: vec![grey],
                width: 1.0,
            });
        }
        for k in 0..8 {
            let t = k as f64 / 8.0 * std::f64::consts::TAU;
            let line: Vec<[f64; 3]> = [-0.5, 0.5]
                .iter()
                .map(|h| {
                    std::array::from_fn(|i| {
                        c.center[i]
                            + h * c.length * ax[i]
                            + c.radius * (t.cos() * e1[i] + t.sin() * e2[i])
                    })
                })
                .collect();
            scene.strokes.push(Stroke {
                points: line,
                colours: vec![grey],
                width: 1.0,
            });
        }
    }
    if let Some(p) = final_pose {
        scene.strokes.push(Stroke {
            points: p.to_vec(),
            colours: vec![BLACK],
            width: 1.0,
        });
    }
    scene.strokes.push(Stroke {
        points: design.pose.position.clone(),
        colours,
        width: 4.0,
    });
    if let Some(t) = design.reach() {
        scene.crosses.push((t.target, RGBColor(200, 0, 0)));
    }
    scene.dots.push((design.pose.position[0], BLACK));
    let width = 1200u32;
    let root = png_canvas(
        path,
        (width, 1000),
        &format!(
            "{title}: design pose (colour: most active group × activation; black: pose at the end)"
        ),
        22,
    )?;
    let (main, bar) = root.split_horizontally(width - 130);
    draw_four_views(&main, &scene, 16)?;
    for (g, name) in crate::scenario::config::MUSCLE_GROUP_NAMES
        .iter()
        .enumerate()
    {
        let y = 80 + 30 * g as i32;
        bar.draw(&Rectangle::new(
            [(10, y), (30, y + 16)],
            GROUP_COLOURS[g].filled(),
        ))
        .map_err(err)?;
        bar.draw(&Text::new(
            name.to_string(),
            (38, y),
            ("sans-serif", 16).into_font(),
        ))
        .map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}

/// The colour bar of the centrelines' times [t0, t0 + span] (viridis).
fn colour_bar(
    bar: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    margin: u32,
    xlab: u32,
    t0: f64,
    span: f64,
) -> Result<()> {
    let mut cb = ChartBuilder::on(bar)
        .margin_top(margin + 10)
        .margin_bottom(margin + xlab)
        .margin_right(55)
        .y_label_area_size(0)
        .right_y_label_area_size(50)
        .build_cartesian_2d(0.0..1.0, t0..t0 + span)
        .map_err(err)?;
    cb.configure_mesh()
        .disable_x_mesh()
        .disable_y_mesh()
        .disable_x_axis()
        .y_desc("t [s]")
        .y_label_formatter(&|v| tick(*v, 3))
        .label_style(("sans-serif", 16))
        .axis_desc_style(("sans-serif", 20))
        .draw()
        .map_err(err)?;
    let slices = 100;
    cb.draw_series((0..slices).map(|k| {
        let a = t0 + span * k as f64 / slices as f64;
        let b = t0 + span * (k + 1) as f64 / slices as f64;
        Rectangle::new(
            [(0.0, a), (1.0, b)],
            viridis((k as f64 + 0.5) / slices as f64).filled(),
        )
    }))
    .map_err(err)?;
    Ok(())
}

/// Kinetic, strain and total energy, external work and dissipated energy of all rods together
/// against time.
pub fn energy_png(path: &Path, rec: &Recorder, title: &str) -> Result<()> {
    ensure_font();
    let t = &rec.time;
    if t.is_empty() {
        return Err(anyhow!("no recorded frames"));
    }
    let s: Vec<[f64; 6]> = (0..t.len())
        .map(|f| {
            let mut row = [0.0; 6];
            for rod in &rec.series {
                for (c, v) in row.iter_mut().enumerate() {
                    *v += rod[f][c];
                }
            }
            row
        })
        .collect();
    let curves: [(&str, RGBColor, Vec<f64>); 5] = [
        (
            "kinetic K",
            RGBColor(31, 119, 180),
            s.iter().map(|r| r[0] + r[1]).collect(),
        ),
        (
            "strain U",
            RGBColor(255, 127, 14),
            s.iter().map(|r| r[2] + r[3]).collect(),
        ),
        (
            "total H = K + U",
            BLACK,
            s.iter().map(|r| r[0] + r[1] + r[2] + r[3]).collect(),
        ),
        (
            "work of loads W",
            RGBColor(44, 160, 44),
            s.iter().map(|r| r[4]).collect(),
        ),
        (
            "dissipated D",
            RGBColor(214, 39, 40),
            s.iter().map(|r| r[5]).collect(),
        ),
    ];
    let (mut lo, mut hi) = (0.0f64, 0.0f64);
    for (_, _, v) in &curves {
        for &x in v {
            if x.is_finite() {
                lo = lo.min(x);
                hi = hi.max(x);
            }
        }
    }
    if hi - lo <= 0.0 {
        hi = lo + 1e-12;
    }
    let pad = 0.05 * (hi - lo);
    let (ta, tb) = (
        t[0],
        if t[t.len() - 1] > t[0] {
            t[t.len() - 1]
        } else {
            t[0] + 1e-9
        },
    );

    let root = png_canvas(path, (1000, 650), &format!("{title}: energy"), 26)?;
    let mut chart = ChartBuilder::on(&root)
        .margin(20)
        .x_label_area_size(55)
        .y_label_area_size(95)
        .build_cartesian_2d(ta..tb, (lo - pad)..(hi + pad))
        .map_err(err)?;
    mesh(&mut chart, "t [s]", "energy [J]", 16, 20)
        .y_label_formatter(&|v| {
            if *v == 0.0 {
                "0".into()
            } else {
                format!("{v:.2e}")
            }
        })
        .draw()
        .map_err(err)?;
    for (name, colour, v) in curves {
        let style = colour.stroke_width(2);
        chart
            .draw_series(LineSeries::new(t.iter().copied().zip(v), style))
            .map_err(err)?
            .label(name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 24, y)], colour.stroke_width(3))
            });
    }
    legend(&mut chart, SeriesLabelPosition::UpperLeft, 16, 0.85)?;
    root.present().map_err(err)?;
    Ok(())
}

/// The command line's figures: for a controlled run the paper-style `shapes.png` and the
/// animated `shapes.gif` of the controlled rod, for every run `energy.png`, and for a passive
/// run the centrelines of every rod in `shapes.png`. A figure that cannot be drawn is a warning.
pub struct CliFigures;

impl crate::pipeline::Figures for CliFigures {
    fn draw(
        &self,
        scn: &crate::scenario::Scenario,
        data: &crate::pipeline::RunData,
        out: &crate::output::OutputDir,
        title: &str,
    ) {
        let rec = &data.trajectory;
        let warn = |file: &str, r: Result<()>| {
            if let Err(e) = r {
                tracing::warn!("{}: {file} not written: {e:#}", scn.name);
            }
        };
        match (&data.series, crate::build::task_schedule(&scn.config)) {
            (Some(_), Some(task)) => {
                let mut spheres: Vec<octoarm_control::SphereSpec> = task.obstacles.clone();
                if let Some(g) = &task.grasp {
                    spheres.push(g.object);
                }
                let spec = crate::paper_figures::ControlFigureSpec {
                    name: scn.name.clone(),
                    length: task.length,
                    targets: task.targets.clone(),
                    spheres,
                    grasp: task.grasp.is_some(),
                    frame_interval: scn.config.time.save_interval,
                };
                if !rec.control_frames.is_empty() {
                    warn(
                        "shapes.png",
                        crate::paper_figures::shapes_png(
                            &out.path("shapes.png"),
                            &spec,
                            &rec.control_frames,
                            title,
                        ),
                    );
                    warn(
                        "shapes.gif",
                        crate::paper_figures::shapes_gif(
                            &out.path("shapes.gif"),
                            &spec,
                            &rec.control_frames,
                        ),
                    );
                }
            }
            _ => {
                let bases: Vec<[f64; 3]> = data
                    .system
                    .rods()
                    .iter()
                    .filter(|r| r.base.condition.holds_position())
                    .map(|r| r.base.position)
                    .collect();
                warn(
                    "shapes.png",
                    shapes_png(
                        &out.path("shapes.png"),
                        rec,
                        data.system.obstacles(),
                        &bases,
                        title,
                    ),
                );
            }
        }
        warn(
            "energy.png",
            energy_png(&out.path("energy.png"), rec, title),
        );
        if let Some(m) = &data.muscle {
            let last = rec
                .shapes
                .last()
                .and_then(|(_, rods)| rods.get(m.design().rod));
            warn(
                "design.png",
                design_png(
                    &out.path("design.png"),
                    m.design(),
                    last.map(|v| &v[..]),
                    data.system.cylinders(),
                    title,
                ),
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viridis_ends() {
        assert_eq!(viridis(0.0), RGBColor(68, 1, 84));
        assert_eq!(viridis(1.0), RGBColor(253, 231, 37));
        assert_eq!(viridis(2.0), viridis(1.0));
    }
}
