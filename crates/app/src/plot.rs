//! Drawing pieces shared by the figures of plain runs (`figures`) and of controlled runs
//! (`paper_figures`): the embedded font, the titled PNG canvas, axis and legend styling,
//! equal-scale axes, colour interpolation and filled discs. It decides no figure's content.

use anyhow::{anyhow, Result};
use plotters::chart::MeshStyle;
use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};
use std::path::Path;
use std::sync::Once;

static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// A chart with linear axes on a bitmap.
pub(crate) type Chart<'a, 'b> =
    ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Register the embedded DejaVu Sans as "sans-serif" (once).
pub(crate) fn ensure_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The font is a known-good TTF shipped in the crate; failure would be a build mistake.
        if register_font("sans-serif", FontStyle::Normal, FONT).is_err() {
            panic!("assets/DejaVuSans.ttf is not a valid font");
        }
    });
}

/// A plotters error as an `anyhow` error (plotters' errors are not `Send + Sync`).
pub(crate) fn err<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow!("{e:?}")
}

/// The colour a fraction `f` of the way from `a` to `b` (RGB components in 0..=255).
pub(crate) fn mix_rgb(a: (f64, f64, f64), b: (f64, f64, f64), f: f64) -> RGBColor {
    let mix = |p: f64, q: f64| (p + f * (q - p)).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// A tick label with `decimals` decimals and no negative zero ("-0.000" → "0.000").
pub(crate) fn tick(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// A white `size` PNG canvas at `path` with `title` on top (`title_px` high); the returned area
/// lies below the title. Nothing is written before `present`.
pub(crate) fn png_canvas<'a>(
    path: &'a Path,
    size: (u32, u32),
    title: &str,
    title_px: i32,
) -> Result<DrawingArea<BitMapBackend<'a>, Shift>> {
    let root = BitMapBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    root.titled(title, ("sans-serif", title_px)).map_err(err)
}

/// The figures' mesh style: axis descriptions, tick labels `label_px` and descriptions
/// `desc_px` high, no minor grid lines, a faint major grid. Callers add tick formatters (or
/// other overrides) and `draw`.
pub(crate) fn mesh<'a, 'b, DB, X, Y>(
    chart: &'b mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    x_desc: &str,
    y_desc: &str,
    label_px: i32,
    desc_px: i32,
) -> MeshStyle<'a, 'b, X, Y, DB>
where
    DB: DrawingBackend,
    X: Ranged + ValueFormatter<X::ValueType>,
    Y: Ranged + ValueFormatter<Y::ValueType>,
{
    let mut style = chart.configure_mesh();
    style
        .x_desc(x_desc)
        .y_desc(y_desc)
        .label_style(("sans-serif", label_px))
        .axis_desc_style(("sans-serif", desc_px))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.08));
    style
}

/// Draw the legend of the labelled series at `position`, font `font_px` high, on a white
/// background of opacity `background` with a faint border.
pub(crate) fn legend<'a, 'b: 'a>(
    chart: &mut Chart<'a, 'b>,
    position: SeriesLabelPosition,
    font_px: i32,
    background: f64,
) -> Result<()> {
    chart
        .configure_series_labels()
        .position(position)
        .label_font(("sans-serif", font_px))
        .background_style(WHITE.mix(background))
        .border_style(BLACK.mix(0.3))
        .draw()
        .map_err(err)
}

/// Axis limits (x0, x1, y0, y1) with equal scales: the box [lo, hi] widened about its centre to
/// the aspect of a plot of `w` × `h` pixels, with a 5 % margin.
pub(crate) fn equal_box(lo: [f64; 2], hi: [f64; 2], w: f64, h: f64) -> (f64, f64, f64, f64) {
    let pad = 0.05 * (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-6);
    let (x0, x1, y0, y1) = (lo[0] - pad, hi[0] + pad, lo[1] - pad, hi[1] + pad);
    let scale = ((x1 - x0) / w).max((y1 - y0) / h);
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    (
        cx - 0.5 * scale * w,
        cx + 0.5 * scale * w,
        cy - 0.5 * scale * h,
        cy + 0.5 * scale * h,
    )
}

/// A chart on `area` showing at least the box [lo, hi] with equal scales on both axes (see
/// `equal_box`), `margin` pixels around it and label areas `xlab` (below) and `ylab` (left).
pub(crate) fn equal_chart<'a, 'b>(
    area: &'a DrawingArea<BitMapBackend<'b>, Shift>,
    lo: [f64; 2],
    hi: [f64; 2],
    margin: u32,
    xlab: u32,
    ylab: u32,
) -> Result<Chart<'a, 'b>> {
    let (pw, ph) = area.dim_in_pixel();
    let (plot_w, plot_h) = (
        (pw - 2 * margin - ylab) as f64,
        (ph - 2 * margin - xlab) as f64,
    );
    let (x0, x1, y0, y1) = equal_box(lo, hi, plot_w, plot_h);
    ChartBuilder::on(area)
        .margin(margin)
        .x_label_area_size(xlab)
        .y_label_area_size(ylab)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(err)
}

/// A disc of radius `r` about `centre` (chart coordinates), filled with `fill` and outlined
/// with `edge` (a closed 120-segment polygon).
pub(crate) fn draw_disc(
    chart: &mut Chart,
    centre: (f64, f64),
    r: f64,
    fill: ShapeStyle,
    edge: ShapeStyle,
) -> Result<()> {
    let ring: Vec<(f64, f64)> = (0..=120)
        .map(|k| {
            let a = k as f64 / 120.0 * std::f64::consts::TAU;
            (centre.0 + r * a.cos(), centre.1 + r * a.sin())
        })
        .collect();
    chart
        .draw_series(std::iter::once(Polygon::new(ring.clone(), fill)))
        .map_err(err)?;
    chart
        .draw_series(std::iter::once(PathElement::new(ring, edge)))
        .map_err(err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_have_no_negative_zero() {
        assert_eq!(tick(-0.0001, 3), "0.000");
        assert_eq!(tick(-0.04, 1), "0.0");
        assert_eq!(tick(-0.5, 1), "-0.5");
        assert_eq!(tick(1.5, 3), "1.500");
    }

    #[test]
    fn equal_box_matches_the_plot_aspect() {
        let (x0, x1, y0, y1) = equal_box([0.0, 0.0], [2.0, 1.0], 400.0, 100.0);
        assert!(((x1 - x0) / (y1 - y0) - 4.0).abs() < 1e-12);
        assert!(x0 < 0.0 && x1 > 2.0 && y0 < 0.0 && y1 > 1.0);
    }
}
