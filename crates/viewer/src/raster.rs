//! A small software rasteriser for frames rendered without a display (the Gymnasium
//! environments' `render_mode="rgb_array"`): an RGB image, a world-to-pixel view with equal
//! scales, and anti-aliased discs, rectangles and tapered capsules (a rod element with its true
//! radius at both ends). It knows nothing of rods or environments; callers compose the scene.

/// An RGB colour, 8 bits per channel.
pub type Rgb = [u8; 3];

/// A packed RGB image, row-major from the top-left pixel, 3 bytes per pixel.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width [pixels].
    pub width: usize,
    /// Height [pixels].
    pub height: usize,
    /// `height × width × 3` bytes.
    pub pixels: Vec<u8>,
}

impl Image {
    /// A `width` × `height` image filled with `background`.
    pub fn new(width: usize, height: usize, background: Rgb) -> Self {
        let mut img = Self {
            width,
            height,
            pixels: vec![0; width * height * 3],
        };
        img.clear(background);
        img
    }

    /// Fill the whole image with `colour`.
    pub fn clear(&mut self, colour: Rgb) {
        for px in self.pixels.chunks_exact_mut(3) {
            px.copy_from_slice(&colour);
        }
    }

    /// The colour of pixel (`col`, `row`); None outside the image.
    pub fn get(&self, col: usize, row: usize) -> Option<Rgb> {
        (col < self.width && row < self.height).then(|| {
            let i = 3 * (row * self.width + col);
            [self.pixels[i], self.pixels[i + 1], self.pixels[i + 2]]
        })
    }

    /// Blend `colour` over pixel (`col`, `row`) with opacity `alpha` in [0, 1].
    fn blend(&mut self, col: usize, row: usize, colour: Rgb, alpha: f64) {
        let i = 3 * (row * self.width + col);
        let a = alpha.clamp(0.0, 1.0);
        for (px, &c) in self.pixels[i..i + 3].iter_mut().zip(&colour) {
            let old = *px as f64;
            *px = (old + a * (c as f64 - old)).round() as u8;
        }
    }

    /// The pixel box (columns, rows) covering [x0, x1] × [y0, y1] in pixel coordinates,
    /// clipped to the image; None if it is empty or not finite.
    fn clip(&self, x0: f64, x1: f64, y0: f64, y1: f64) -> Option<(usize, usize, usize, usize)> {
        if !(x0.is_finite() && x1.is_finite() && y0.is_finite() && y1.is_finite()) {
            return None;
        }
        let c0 = x0.floor().max(0.0);
        let r0 = y0.floor().max(0.0);
        let c1 = x1.ceil().min(self.width as f64);
        let r1 = y1.ceil().min(self.height as f64);
        (c0 < c1 && r0 < r1).then_some((c0 as usize, c1 as usize, r0 as usize, r1 as usize))
    }

    /// An axis-aligned filled rectangle [x0, x1] × [y0, y1] (pixel coordinates, y down),
    /// with partial coverage blended at its edges.
    pub fn fill_rect(&mut self, x0: f64, x1: f64, y0: f64, y1: f64, colour: Rgb) {
        let (x0, x1) = (x0.min(x1), x0.max(x1));
        let (y0, y1) = (y0.min(y1), y0.max(y1));
        let Some((c0, c1, r0, r1)) = self.clip(x0, x1, y0, y1) else {
            return;
        };
        for row in r0..r1 {
            let cov_y = (y1.min(row as f64 + 1.0) - y0.max(row as f64)).clamp(0.0, 1.0);
            for col in c0..c1 {
                let cov_x = (x1.min(col as f64 + 1.0) - x0.max(col as f64)).clamp(0.0, 1.0);
                self.blend(col, row, colour, cov_x * cov_y);
            }
        }
    }

    /// A filled disc of radius `r` [pixels] about (`cx`, `cy`), anti-aliased.
    pub fn fill_disc(&mut self, cx: f64, cy: f64, r: f64, colour: Rgb) {
        self.fill_capsule([cx, cy], [cx, cy], r, r, colour);
    }

    /// A tapered capsule: the points within r(t) = ra + t (rb − ra) of the segment a → b
    /// (t the projection's parameter in [0, 1]), radii in pixels, anti-aliased over one pixel.
    /// Rounded ends; consecutive capsules of a polyline join smoothly.
    pub fn fill_capsule(&mut self, a: [f64; 2], b: [f64; 2], ra: f64, rb: f64, colour: Rgb) {
        let (ra, rb) = (ra.max(0.0), rb.max(0.0));
        let r = ra.max(rb) + 1.0;
        let Some((c0, c1, r0, r1)) = self.clip(
            a[0].min(b[0]) - r,
            a[0].max(b[0]) + r,
            a[1].min(b[1]) - r,
            a[1].max(b[1]) + r,
        ) else {
            return;
        };
        let d = [b[0] - a[0], b[1] - a[1]];
        let len2 = d[0] * d[0] + d[1] * d[1];
        for row in r0..r1 {
            let py = row as f64 + 0.5;
            for col in c0..c1 {
                let px = col as f64 + 0.5;
                let t = if len2 > 0.0 {
                    (((px - a[0]) * d[0] + (py - a[1]) * d[1]) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let (qx, qy) = (a[0] + t * d[0], a[1] + t * d[1]);
                let dist = ((px - qx).powi(2) + (py - qy).powi(2)).sqrt();
                let radius = ra + t * (rb - ra);
                // Coverage of a pixel by an edge at distance `radius`: linear over one pixel,
                // so a thin tip (< 1 px) still shows as a faint line instead of vanishing.
                let cover = (radius - dist + 0.5).clamp(0.0, 1.0);
                if cover > 0.0 {
                    self.blend(col, row, colour, cover);
                }
            }
        }
    }
}

/// A view from world coordinates (x right, y up, metres) to pixel coordinates (column right,
/// row down) with the same scale on both axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    /// World x at pixel column 0 [m].
    pub x0: f64,
    /// World y at pixel row 0 (the top edge) [m].
    pub y_top: f64,
    /// Pixels per metre (> 0).
    pub scale: f64,
}

impl View {
    /// The view showing at least the box [lo, hi] (metres) centred in a `width` × `height`
    /// image, with `margin` pixels around it. A degenerate box is widened to 1 mm.
    pub fn fit(lo: [f64; 2], hi: [f64; 2], width: usize, height: usize, margin: f64) -> Self {
        let w = (hi[0] - lo[0]).max(1e-3);
        let h = (hi[1] - lo[1]).max(1e-3);
        let avail_w = (width as f64 - 2.0 * margin).max(1.0);
        let avail_h = (height as f64 - 2.0 * margin).max(1.0);
        let scale = (avail_w / w).min(avail_h / h);
        let cx = 0.5 * (lo[0] + hi[0]);
        let cy = 0.5 * (lo[1] + hi[1]);
        Self {
            x0: cx - 0.5 * width as f64 / scale,
            y_top: cy + 0.5 * height as f64 / scale,
            scale,
        }
    }

    /// Pixel coordinates (column, row) of world point `p` = (x, y) [m].
    pub fn to_px(&self, p: [f64; 2]) -> [f64; 2] {
        [
            (p[0] - self.x0) * self.scale,
            (self.y_top - p[1]) * self.scale,
        ]
    }

    /// A world length [m] in pixels.
    pub fn len_px(&self, l: f64) -> f64 {
        l * self.scale
    }
}

/// Draw a rod's centreline `nodes` (world x, y [m]) as a chain of tapered capsules whose
/// radius at each node is the mean of the adjacent elements' `radius` [m] (per element, one
/// fewer than the nodes; the end nodes take their element's). Nothing is drawn if the lengths
/// disagree.
pub fn draw_rod(img: &mut Image, view: &View, nodes: &[[f64; 2]], radius: &[f64], colour: Rgb) {
    let n = radius.len();
    if n == 0 || nodes.len() != n + 1 {
        return;
    }
    let node_radius = |i: usize| -> f64 {
        let r = if i == 0 {
            radius[0]
        } else if i == n {
            radius[n - 1]
        } else {
            0.5 * (radius[i - 1] + radius[i])
        };
        view.len_px(r)
    };
    for j in 0..n {
        img.fill_capsule(
            view.to_px(nodes[j]),
            view.to_px(nodes[j + 1]),
            node_radius(j),
            node_radius(j + 1),
            colour,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const WHITE: Rgb = [255, 255, 255];
    const RED: Rgb = [255, 0, 0];

    #[test]
    fn a_disc_covers_its_area() {
        // The covered area (sum of coverages) equals π r² to within the one-pixel edge ramp.
        let mut img = Image::new(64, 64, WHITE);
        img.fill_disc(32.0, 32.0, 10.0, [0, 0, 0]);
        let covered: f64 = img
            .pixels
            .chunks_exact(3)
            .map(|p| 1.0 - p[0] as f64 / 255.0)
            .sum();
        let exact = std::f64::consts::PI * 100.0;
        assert!(
            (covered - exact).abs() < 0.01 * exact,
            "{covered} vs {exact}"
        );
        assert_eq!(img.get(32, 32), Some([0, 0, 0]));
        assert_eq!(img.get(32, 45), Some(WHITE));
    }

    #[test]
    fn a_capsule_tapers() {
        let mut img = Image::new(100, 40, WHITE);
        img.fill_capsule([10.0, 20.0], [90.0, 20.0], 10.0, 2.0, RED);
        // Thick at the start, thin at the end, nothing beyond the radii.
        assert_eq!(img.get(12, 27), Some(RED));
        assert_eq!(img.get(88, 27), Some(WHITE));
        assert_eq!(img.get(88, 20), Some(RED));
        assert_eq!(img.get(50, 5), Some(WHITE));
    }

    #[test]
    fn the_view_keeps_equal_scales_and_puts_y_up() {
        let v = View::fit([0.0, 0.0], [2.0, 1.0], 200, 200, 0.0);
        assert_eq!(v.scale, 100.0);
        let p = v.to_px([2.0, 1.0]);
        let q = v.to_px([0.0, 0.0]);
        assert!((p[0] - 200.0).abs() < 1e-9 && (q[0]).abs() < 1e-9);
        assert!(p[1] < q[1], "y up means smaller rows");
        assert!((q[1] - p[1] - 100.0).abs() < 1e-9);
    }

    #[test]
    fn a_rod_is_drawn_with_its_radius() {
        let mut img = Image::new(200, 100, WHITE);
        let view = View::fit([0.0, -0.05], [0.2, 0.05], 200, 100, 0.0);
        let nodes: Vec<[f64; 2]> = (0..=4).map(|i| [0.05 * i as f64, 0.0]).collect();
        draw_rod(&mut img, &view, &nodes, &[0.01; 4], RED);
        // 1000 px/m: a 1 cm radius is 10 px either side of row 50.
        assert_eq!(img.get(100, 42), Some(RED));
        assert_eq!(img.get(100, 62), Some(WHITE));
        // Wrong lengths draw nothing.
        let mut blank = Image::new(10, 10, WHITE);
        draw_rod(&mut blank, &view, &nodes[..3], &[0.01; 4], RED);
        assert!(blank.pixels.iter().all(|&b| b == 255));
    }

    #[test]
    fn non_finite_input_draws_nothing() {
        let mut img = Image::new(10, 10, WHITE);
        img.fill_capsule([f64::NAN, 0.0], [5.0, 5.0], 2.0, 2.0, RED);
        img.fill_rect(0.0, f64::INFINITY, 0.0, 5.0, RED);
        assert!(img.pixels.iter().all(|&b| b == 255));
    }
}
