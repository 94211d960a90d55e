//! Drawing 3D figures on 2D bitmaps: projections (orthographic along a lab axis, or a
//! perspective camera), a scene of polylines with per-segment colours (rods coloured by time,
//! strain or muscle activation), balls and crosses, and the four-panel view (x–y, x–z, y–z and
//! a perspective view) that `shapes.png` and `shapes.gif` use for runs leaving the x–y plane.
//! It decides no figure's content: callers build the `Scene3`.

use crate::plot::{equal_chart, err, mesh, tick, Chart};
use anyhow::Result;
use octoarm_physics::Vec3;
use plotters::coord::Shift;
use plotters::prelude::*;

/// How 3D points map to a panel's 2D coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Projection {
    /// Orthographic: the panel's axes are lab axes `h` (right) and `v` (up); the viewer looks
    /// along the remaining axis, from its positive side if `from_positive`.
    Axes {
        /// Lab axis to the right (0 x, 1 y, 2 z).
        h: usize,
        /// Lab axis up.
        v: usize,
        /// Whether the viewer sits on the positive side of the third axis.
        from_positive: bool,
    },
    /// A pinhole camera at `eye` looking at `target`, `up` giving the panel's up direction,
    /// vertical field of view `fov` [rad].
    Perspective {
        /// Camera position [m].
        eye: Vec3,
        /// Point looked at [m].
        target: Vec3,
        /// Up direction (any length, not along the view).
        up: Vec3,
        /// Vertical field of view [rad], in (0, π).
        fov: f64,
    },
}

fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn unit(a: Vec3) -> Vec3 {
    let l = dot(a, a).sqrt();
    if l > 0.0 {
        [a[0] / l, a[1] / l, a[2] / l]
    } else {
        a
    }
}

/// The axis names.
pub const AXIS: [&str; 3] = ["x", "y", "z"];

impl Projection {
    /// The orthographic views x–y (from +z), x–z (from −y) and y–z (from +x).
    pub const ORTHOGRAPHIC: [Projection; 3] = [
        Projection::Axes {
            h: 0,
            v: 1,
            from_positive: true,
        },
        Projection::Axes {
            h: 0,
            v: 2,
            from_positive: false,
        },
        Projection::Axes {
            h: 1,
            v: 2,
            from_positive: true,
        },
    ];

    /// A perspective view of the box [lo, hi] from the front-right above (z up), the whole
    /// box in view.
    pub fn oblique(lo: Vec3, hi: Vec3) -> Self {
        let c = [
            0.5 * (lo[0] + hi[0]),
            0.5 * (lo[1] + hi[1]),
            0.5 * (lo[2] + hi[2]),
        ];
        let radius = 0.5 * dot(sub(hi, lo), sub(hi, lo)).sqrt().max(1e-6);
        let fov = 30f64.to_radians();
        let dist = 1.1 * radius / (0.5 * fov).sin();
        let dir = unit([0.9, -1.3, 0.8]);
        Projection::Perspective {
            eye: [
                c[0] + dist * dir[0],
                c[1] + dist * dir[1],
                c[2] + dist * dir[2],
            ],
            target: c,
            up: [0.0, 0.0, 1.0],
            fov,
        }
    }

    /// Panel coordinates (right, up) and depth (larger is farther from the viewer) of `p`; None
    /// behind a perspective camera. Orthographic coordinates are metres; perspective ones are
    /// tangents of the view angle.
    pub fn project(&self, p: Vec3) -> Option<(f64, f64, f64)> {
        match *self {
            Projection::Axes {
                h,
                v,
                from_positive,
            } => {
                let d = 3 - h - v;
                let depth = if from_positive { -p[d] } else { p[d] };
                Some((p[h], p[v], depth))
            }
            Projection::Perspective {
                eye, target, up, ..
            } => {
                let f = unit(sub(target, eye));
                let r = unit(cross(f, up));
                let u = cross(r, f);
                let q = sub(p, eye);
                let z = dot(q, f);
                (z > 1e-9).then(|| (dot(q, r) / z, dot(q, u) / z, z))
            }
        }
    }

    /// Panel units per metre at `p` (1 for orthographic views): to draw a radius.
    pub fn scale_at(&self, p: Vec3) -> f64 {
        match self {
            Projection::Axes { .. } => 1.0,
            Projection::Perspective { .. } => self.project(p).map_or(0.0, |(_, _, z)| 1.0 / z),
        }
    }

    /// Axis labels of an orthographic view.
    pub fn labels(&self) -> Option<(&'static str, &'static str)> {
        match *self {
            Projection::Axes { h, v, .. } => Some((AXIS[h], AXIS[v])),
            Projection::Perspective { .. } => None,
        }
    }
}

/// A polyline with a colour per segment (or one for all), `width` pixels wide.
#[derive(Debug, Clone)]
pub struct Stroke {
    /// Points [m].
    pub points: Vec<Vec3>,
    /// One colour per segment (`points.len() − 1`), or a single colour for every segment.
    pub colours: Vec<RGBColor>,
    /// Width [pixels].
    pub width: f64,
}

/// What a 3D figure shows.
#[derive(Debug, Clone, Default)]
pub struct Scene3 {
    /// Polylines (rods, desired shapes, paths).
    pub strokes: Vec<Stroke>,
    /// Balls: centre [m], radius [m], fill colour (obstacles, held bases).
    pub balls: Vec<(Vec3, f64, RGBColor)>,
    /// Crosses: position [m], colour (targets).
    pub crosses: Vec<(Vec3, RGBColor)>,
    /// Dots 8 pixels wide: position [m], colour (held bases).
    pub dots: Vec<(Vec3, RGBColor)>,
}

impl Scene3 {
    /// The bounding box of every point and ball.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        let mut add = |p: Vec3, r: f64| {
            if p.iter().all(|x| x.is_finite()) {
                for c in 0..3 {
                    lo[c] = lo[c].min(p[c] - r);
                    hi[c] = hi[c].max(p[c] + r);
                }
            }
        };
        for s in &self.strokes {
            for &p in &s.points {
                add(p, 0.0);
            }
        }
        for &(c, r, _) in &self.balls {
            add(c, r);
        }
        for &(p, _) in self.crosses.iter().chain(&self.dots) {
            add(p, 0.0);
        }
        if !lo[0].is_finite() {
            return ([-1e-3; 3], [1e-3; 3]);
        }
        (lo, hi)
    }
}

/// Whether points leave every coordinate plane: their extent along each lab axis exceeds 1 %
/// of the largest extent (a planar motion in the x–y, x–z or y–z plane is not 3D).
pub fn is_three_dimensional<'a>(points: impl IntoIterator<Item = &'a Vec3>) -> bool {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for c in 0..3 {
            if p[c].is_finite() {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
        }
    }
    let ext: Vec<f64> = (0..3).map(|c| (hi[c] - lo[c]).max(0.0)).collect();
    let largest = ext.iter().cloned().fold(0.0, f64::max);
    largest > 0.0 && ext.iter().all(|&e| e > 0.01 * largest)
}

/// Something to draw at a depth (painter's algorithm: far first).
enum Item {
    Segment((f64, f64), (f64, f64), RGBColor, f64),
    Ball((f64, f64), f64, RGBColor),
    Cross((f64, f64), RGBColor),
    Dot((f64, f64), RGBColor),
}

/// Draw `scene` seen through `projection` into `area`: an equal-scale chart with axes for an
/// orthographic view (titled `title`), a frameless one for a perspective view, far things
/// first. `box_lo`/`box_hi` are the box that must be in view (e.g. all frames' bounds).
pub fn draw_panel(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    scene: &Scene3,
    projection: &Projection,
    box_lo: Vec3,
    box_hi: Vec3,
    title: &str,
    font_px: i32,
) -> Result<()> {
    // The panel's 2D box: every corner of the 3D box projected.
    let mut lo2 = [f64::INFINITY; 2];
    let mut hi2 = [f64::NEG_INFINITY; 2];
    for k in 0..8 {
        let p = [
            if k & 1 == 0 { box_lo[0] } else { box_hi[0] },
            if k & 2 == 0 { box_lo[1] } else { box_hi[1] },
            if k & 4 == 0 { box_lo[2] } else { box_hi[2] },
        ];
        if let Some((x, y, _)) = projection.project(p) {
            lo2 = [lo2[0].min(x), lo2[1].min(y)];
            hi2 = [hi2[0].max(x), hi2[1].max(y)];
        }
    }
    if !lo2[0].is_finite() {
        return Ok(());
    }
    let labelled = projection.labels();
    let (xlab, ylab) = if labelled.is_some() {
        (2 * font_px as u32 + 8, 4 * font_px as u32)
    } else {
        (0, 0)
    };
    let (titled, _) = area.split_vertically(font_px as u32 + 10);
    titled
        .titled(title, ("sans-serif", font_px + 2))
        .map_err(err)?;
    let inner = area.margin(font_px as u32 + 10, 0, 0, 0);
    let mut chart = equal_chart(&inner, lo2, hi2, 8, xlab, ylab)?;
    if let Some((h, v)) = labelled {
        // Enough decimals to tell ticks about a fifth of the shown range apart.
        let xr = chart.x_range();
        let step = 0.2 * (xr.end - xr.start).max(1e-12);
        let decimals = (-step.log10()).ceil().clamp(0.0, 8.0) as usize;
        mesh(
            &mut chart,
            &format!("{h} [m]"),
            &format!("{v} [m]"),
            font_px - 2,
            font_px,
        )
        .x_label_formatter(&|v| tick(*v, decimals))
        .y_label_formatter(&|v| tick(*v, decimals))
        .x_labels(5)
        .y_labels(5)
        .draw()
        .map_err(err)?;
    }
    let (w_px, _) = chart.plotting_area().dim_in_pixel();
    let xr = chart.x_range();
    let per_px = (xr.end - xr.start) / w_px.max(1) as f64;
    let mut items: Vec<(f64, Item)> = Vec::new();
    for s in &scene.strokes {
        for (j, w) in s.points.windows(2).enumerate() {
            let colour = s
                .colours
                .get(j)
                .or(s.colours.first())
                .copied()
                .unwrap_or(BLACK);
            if let (Some(a), Some(b)) = (projection.project(w[0]), projection.project(w[1])) {
                items.push((
                    0.5 * (a.2 + b.2),
                    Item::Segment((a.0, a.1), (b.0, b.1), colour, s.width),
                ));
            }
        }
    }
    for &(c, r, colour) in &scene.balls {
        if let Some(p) = projection.project(c) {
            items.push((
                p.2,
                Item::Ball((p.0, p.1), r * projection.scale_at(c), colour),
            ));
        }
    }
    for &(c, colour) in &scene.crosses {
        if let Some(p) = projection.project(c) {
            // Targets stay on top.
            items.push((f64::NEG_INFINITY, Item::Cross((p.0, p.1), colour)));
        }
    }
    for &(c, colour) in &scene.dots {
        if let Some(p) = projection.project(c) {
            items.push((p.2, Item::Dot((p.0, p.1), colour)));
        }
    }
    items.sort_by(|a, b| b.0.total_cmp(&a.0));
    for (_, item) in items {
        match item {
            Item::Segment(a, b, colour, width) => segment(&mut chart, a, b, colour, width, per_px)?,
            Item::Ball(c, r, colour) => {
                let ring: Vec<(f64, f64)> = (0..=72)
                    .map(|k| {
                        let t = k as f64 / 72.0 * std::f64::consts::TAU;
                        (c.0 + r * t.cos(), c.1 + r * t.sin())
                    })
                    .collect();
                chart
                    .draw_series(std::iter::once(Polygon::new(
                        ring.clone(),
                        colour.mix(0.6).filled(),
                    )))
                    .map_err(err)?;
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        ring,
                        RGBColor(110, 110, 110).stroke_width(1),
                    )))
                    .map_err(err)?;
            }
            Item::Dot(c, colour) => {
                chart
                    .draw_series(std::iter::once(Circle::new(c, 4, colour.filled())))
                    .map_err(err)?;
            }
            Item::Cross(c, colour) => {
                chart
                    .draw_series(std::iter::once(Cross::new(c, 6, colour.stroke_width(2))))
                    .map_err(err)?;
            }
        }
    }
    Ok(())
}

/// One segment `width` pixels wide with round ends (a filled quad and two discs).
fn segment(
    chart: &mut Chart,
    a: (f64, f64),
    b: (f64, f64),
    colour: RGBColor,
    width: f64,
    per_px: f64,
) -> Result<()> {
    let h = 0.5 * width * per_px;
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let l = (dx * dx + dy * dy).sqrt();
    let style = colour.filled();
    if l > 0.0 {
        let (nx, ny) = (-dy / l * h, dx / l * h);
        chart
            .draw_series(std::iter::once(Polygon::new(
                vec![
                    (a.0 + nx, a.1 + ny),
                    (b.0 + nx, b.1 + ny),
                    (b.0 - nx, b.1 - ny),
                    (a.0 - nx, a.1 - ny),
                ],
                style,
            )))
            .map_err(err)?;
    }
    if width >= 2.5 {
        let r = (0.5 * width).round() as i32 - 1;
        chart
            .draw_series([a, b].into_iter().map(|p| Circle::new(p, r, style)))
            .map_err(err)?;
    }
    Ok(())
}

/// The four-panel view of `scene` in `area` (2 × 2: x–y, x–z, y–z, perspective), every panel
/// showing the scene's whole bounding box.
pub fn draw_four_views(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    scene: &Scene3,
    font_px: i32,
) -> Result<()> {
    let (lo, hi) = scene.bounds();
    let panels = area.split_evenly((2, 2));
    let titles = ["top (x–y)", "front (x–z)", "side (y–z)", "perspective"];
    for (k, panel) in panels.iter().enumerate() {
        let projection = if k < 3 {
            Projection::ORTHOGRAPHIC[k]
        } else {
            Projection::oblique(lo, hi)
        };
        draw_panel(panel, scene, &projection, lo, hi, titles[k], font_px)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orthographic_views_drop_one_axis() {
        let p = [1.0, 2.0, 3.0];
        let [xy, xz, yz] = Projection::ORTHOGRAPHIC;
        assert_eq!(xy.project(p), Some((1.0, 2.0, -3.0)));
        assert_eq!(xz.project(p), Some((1.0, 3.0, 2.0)));
        assert_eq!(yz.project(p), Some((2.0, 3.0, -1.0)));
    }

    #[test]
    fn perspective_centres_the_target_and_shrinks_with_distance() {
        let cam = Projection::Perspective {
            eye: [0.0, -2.0, 0.0],
            target: [0.0, 0.0, 0.0],
            up: [0.0, 0.0, 1.0],
            fov: 0.5,
        };
        let (x, y, z) = cam.project([0.0, 0.0, 0.0]).unwrap();
        assert!(x.abs() < 1e-12 && y.abs() < 1e-12 && (z - 2.0).abs() < 1e-12);
        // +x is to the right, +z up, and a point twice as far looks half as far off-centre.
        let near = cam.project([0.1, 0.0, 0.1]).unwrap();
        let far = cam.project([0.1, 2.0, 0.1]).unwrap();
        assert!(near.0 > 0.0 && near.1 > 0.0);
        assert!((near.0 / far.0 - 2.0).abs() < 1e-12);
        assert!(cam.project([0.0, -3.0, 0.0]).is_none(), "behind the camera");
    }

    #[test]
    fn planar_motions_are_not_three_dimensional() {
        let planar: Vec<Vec3> = (0..10).map(|i| [i as f64, (i * i) as f64, 0.0]).collect();
        assert!(!is_three_dimensional(&planar));
        let xz: Vec<Vec3> = (0..10).map(|i| [i as f64, 0.0, i as f64]).collect();
        assert!(!is_three_dimensional(&xz));
        let helix: Vec<Vec3> = (0..50)
            .map(|i| {
                let t = i as f64 * 0.3;
                [t.cos(), t.sin(), 0.1 * t]
            })
            .collect();
        assert!(is_three_dimensional(&helix));
    }
}
