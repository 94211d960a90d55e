//! The animated-GIF writer of the figures: RGB frames are mapped onto one fixed 256-colour
//! palette (a 6×6×6 colour cube plus 40 greys) and encoded by the `gif` crate (GIF89a,
//! looping). It knows nothing of plots; the figure modules draw the frames.

use std::io::{self, Write};

/// Width of the palette's grey ramp.
const GREYS: usize = 40;

/// The fixed palette: 216 cube colours (levels 0, 51, …, 255) then 40 greys, as RGB triples.
fn palette() -> Vec<u8> {
    let mut p = Vec::with_capacity(768);
    for r in 0..6u8 {
        for g in 0..6u8 {
            for b in 0..6u8 {
                p.extend_from_slice(&[51 * r, 51 * g, 51 * b]);
            }
        }
    }
    for k in 0..GREYS {
        let v = ((k as f64 + 0.5) * 255.0 / GREYS as f64).round() as u8;
        p.extend_from_slice(&[v, v, v]);
    }
    p
}

/// Palette index of an RGB colour: near-greys (channel spread < 16) go to the grey ramp, which is
/// finer than the cube's diagonal, everything else to the nearest cube colour.
fn index_of(r: u8, g: u8, b: u8) -> u8 {
    let (lo, hi) = (r.min(g).min(b), r.max(g).max(b));
    if hi - lo < 16 {
        if hi == 255 && lo >= 250 {
            return 215; // pure white: the cube's corner
        }
        let v = (r as usize + g as usize + b as usize) / 3;
        return (216 + (v * GREYS / 256).min(GREYS - 1)) as u8;
    }
    let q = |c: u8| ((c as u16 + 25) / 51) as u8;
    36 * q(r) + 6 * q(g) + q(b)
}

/// Writes an animated GIF frame by frame (the `gif` crate encodes; this maps RGB onto the
/// fixed palette).
pub struct GifWriter<W: Write> {
    encoder: gif::Encoder<W>,
    width: u16,
    height: u16,
    indices: Vec<u8>,
}

fn gif_error(e: gif::EncodingError) -> io::Error {
    match e {
        gif::EncodingError::Io(e) => e,
        other => io::Error::other(other.to_string()),
    }
}

impl<W: Write> GifWriter<W> {
    /// Start a looping GIF of `width` × `height` pixels.
    pub fn new(out: W, width: u16, height: u16) -> io::Result<Self> {
        let mut encoder = gif::Encoder::new(out, width, height, &palette()).map_err(gif_error)?;
        encoder
            .set_repeat(gif::Repeat::Infinite)
            .map_err(gif_error)?;
        Ok(Self {
            encoder,
            width,
            height,
            indices: Vec::new(),
        })
    }

    /// Append one frame of packed RGB pixels (row-major, 3 bytes each), shown for
    /// `delay_cs` hundredths of a second.
    pub fn frame(&mut self, rgb: &[u8], delay_cs: u16) -> io::Result<()> {
        let n = self.width as usize * self.height as usize;
        if rgb.len() != 3 * n {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!("frame of {} bytes, expected {}", rgb.len(), 3 * n),
            ));
        }
        self.indices.clear();
        self.indices
            .extend(rgb.chunks_exact(3).map(|c| index_of(c[0], c[1], c[2])));
        let frame = gif::Frame {
            width: self.width,
            height: self.height,
            delay: delay_cs,
            buffer: std::borrow::Cow::Borrowed(&self.indices),
            ..gif::Frame::default()
        };
        self.encoder.write_frame(&frame).map_err(gif_error)
    }

    /// Write the trailer and return the writer.
    pub fn finish(self) -> io::Result<W> {
        let mut out = self.encoder.into_inner().map_err(gif_error)?;
        out.flush()?;
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_decode_to_their_palette_colours() {
        // Two frames (a gradient and noise, beyond one LZW table) decoded by the `gif` crate's
        // decoder give back each pixel's palette colour, the delays and the size.
        let (w, h) = (97u16, 61u16);
        let mut frames = Vec::new();
        let mut x: u32 = 12345;
        for f in 0..2 {
            let rgb: Vec<u8> = (0..3 * w as usize * h as usize)
                .map(|i| {
                    x = x.wrapping_mul(1_103_515_245).wrapping_add(12_345);
                    if f == 0 {
                        (i / 3 % 256) as u8
                    } else {
                        (x >> 16) as u8
                    }
                })
                .collect();
            frames.push(rgb);
        }
        let mut writer = GifWriter::new(Vec::new(), w, h).unwrap();
        for rgb in &frames {
            writer.frame(rgb, 7).unwrap();
        }
        let bytes = writer.finish().unwrap();
        let mut opts = gif::DecodeOptions::new();
        opts.set_color_output(gif::ColorOutput::Indexed);
        let mut dec = opts.read_info(bytes.as_slice()).unwrap();
        assert_eq!((dec.width(), dec.height()), (w, h));
        let pal = palette();
        for rgb in &frames {
            let frame = dec.read_next_frame().unwrap().unwrap().clone();
            assert_eq!(frame.delay, 7);
            for (px, &k) in rgb.chunks_exact(3).zip(frame.buffer.iter()) {
                assert_eq!(k, index_of(px[0], px[1], px[2]));
                let c = &pal[3 * k as usize..3 * k as usize + 3];
                // The palette colour is near the pixel's (cube step 51, grey step ~6.4).
                assert!(c
                    .iter()
                    .zip(px)
                    .all(|(a, b)| (*a as i32 - *b as i32).abs() <= 26));
            }
        }
        assert!(dec.read_next_frame().unwrap().is_none());
    }

    #[test]
    fn palette_maps_white_and_greys() {
        let p = palette();
        assert_eq!(p.len(), 768);
        assert_eq!(index_of(255, 255, 255), 215);
        assert_eq!(&p[215 * 3..216 * 3], &[255, 255, 255]);
        assert_eq!(index_of(255, 0, 0), 180);
        assert!(index_of(128, 128, 128) >= 216);
    }
}
