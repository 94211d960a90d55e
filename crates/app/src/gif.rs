//! A small animated-GIF writer for the figures: RGB frames are mapped onto one fixed 256-colour
//! palette (a 6×6×6 colour cube plus 40 greys) and LZW-compressed (GIF89a, looping). It knows
//! nothing of plots; `paper_figures.rs` draws the frames. Written here because the plotting
//! crate's GIF backend would add a dependency for a few dozen lines of encoder.

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

/// LSB-first bit packer into GIF sub-blocks of at most 255 bytes.
struct Bits {
    out: Vec<u8>,
    acc: u32,
    n: u32,
}

impl Bits {
    fn put(&mut self, code: u16, size: u32) {
        self.acc |= (code as u32) << self.n;
        self.n += size;
        while self.n >= 8 {
            self.out.push(self.acc as u8);
            self.acc >>= 8;
            self.n -= 8;
        }
    }

    fn finish(mut self) -> Vec<u8> {
        if self.n > 0 {
            self.out.push(self.acc as u8);
        }
        self.out
    }
}

/// LZW-compress 8-bit palette indices (minimum code size 8), the way giflib's encoder does:
/// the code size grows when the next free code reaches 2^size, and the table is cleared when it
/// is full (4095 codes).
fn lzw(indices: &[u8]) -> Vec<u8> {
    const MIN: u32 = 8;
    let clear: u16 = 1 << MIN;
    let eoi = clear + 1;
    // table[prefix * 256 + k] = code of the string prefix + k, 0 if absent.
    let mut table = vec![0u16; 4096 * 256];
    let mut next = eoi + 1;
    let mut size = MIN + 1;
    let mut bits = Bits {
        out: Vec::new(),
        acc: 0,
        n: 0,
    };
    bits.put(clear, size);
    let Some((&first, rest)) = indices.split_first() else {
        bits.put(eoi, size);
        return bits.finish();
    };
    let mut prefix = first as u16;
    for &k in rest {
        let slot = prefix as usize * 256 + k as usize;
        if table[slot] != 0 {
            prefix = table[slot];
            continue;
        }
        bits.put(prefix, size);
        if next >= 4095 {
            bits.put(clear, size);
            table.fill(0);
            next = eoi + 1;
            size = MIN + 1;
        } else {
            if next >= 1 << size {
                size += 1;
            }
            table[slot] = next;
            next += 1;
        }
        prefix = k as u16;
    }
    bits.put(prefix, size);
    if next >= 1 << size && size < 12 {
        size += 1;
    }
    bits.put(eoi, size);
    bits.finish()
}

/// Writes an animated GIF frame by frame.
pub struct GifWriter<W: Write> {
    out: W,
    width: u16,
    height: u16,
}

impl<W: Write> GifWriter<W> {
    /// Start a looping GIF of `width` × `height` pixels.
    pub fn new(mut out: W, width: u16, height: u16) -> io::Result<Self> {
        out.write_all(b"GIF89a")?;
        out.write_all(&width.to_le_bytes())?;
        out.write_all(&height.to_le_bytes())?;
        // Global colour table of 256 entries, 8 bits per channel.
        out.write_all(&[0xF7, 0, 0])?;
        out.write_all(&palette())?;
        // Loop forever (NETSCAPE2.0 application extension).
        out.write_all(&[0x21, 0xFF, 0x0B])?;
        out.write_all(b"NETSCAPE2.0")?;
        out.write_all(&[0x03, 0x01, 0x00, 0x00, 0x00])?;
        Ok(Self { out, width, height })
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
        let indices: Vec<u8> = rgb
            .chunks_exact(3)
            .map(|c| index_of(c[0], c[1], c[2]))
            .collect();
        let o = &mut self.out;
        // Graphic control extension: no disposal, no transparency.
        o.write_all(&[0x21, 0xF9, 0x04, 0x00])?;
        o.write_all(&delay_cs.to_le_bytes())?;
        o.write_all(&[0x00, 0x00])?;
        // Image descriptor: whole canvas, global palette, not interlaced.
        o.write_all(&[0x2C, 0, 0, 0, 0])?;
        o.write_all(&self.width.to_le_bytes())?;
        o.write_all(&self.height.to_le_bytes())?;
        o.write_all(&[0x00, 8])?;
        for block in lzw(&indices).chunks(255) {
            o.write_all(&[block.len() as u8])?;
            o.write_all(block)?;
        }
        o.write_all(&[0x00])
    }

    /// Write the trailer and return the writer.
    pub fn finish(mut self) -> io::Result<W> {
        self.out.write_all(&[0x3B])?;
        self.out.flush()?;
        Ok(self.out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reference LZW decoder (as in the GIF specification) to check the encoder.
    fn decode(data: &[u8]) -> Vec<u8> {
        let (clear, eoi) = (256usize, 257usize);
        let mut dict: Vec<Vec<u8>> = Vec::new();
        let reset = |dict: &mut Vec<Vec<u8>>| {
            dict.clear();
            dict.extend((0..256).map(|i| vec![i as u8]));
            dict.push(Vec::new());
            dict.push(Vec::new());
        };
        reset(&mut dict);
        let (mut size, mut pos) = (9usize, 0usize);
        let read = |pos: &mut usize, size: usize| {
            let mut v = 0usize;
            for b in 0..size {
                let bit = (data[(*pos + b) / 8] >> ((*pos + b) % 8)) & 1;
                v |= (bit as usize) << b;
            }
            *pos += size;
            v
        };
        let mut out = Vec::new();
        let mut prev: Option<Vec<u8>> = None;
        loop {
            let code = read(&mut pos, size);
            if code == clear {
                reset(&mut dict);
                size = 9;
                prev = None;
                continue;
            }
            if code == eoi {
                return out;
            }
            let entry = if code < dict.len() {
                dict[code].clone()
            } else {
                let p = prev.clone().unwrap();
                let mut e = p.clone();
                e.push(p[0]);
                e
            };
            out.extend_from_slice(&entry);
            if let Some(p) = prev {
                let mut e = p;
                e.push(entry[0]);
                dict.push(e);
                if dict.len() == 1 << size && size < 12 {
                    size += 1;
                }
            }
            prev = Some(entry);
        }
    }

    #[test]
    fn lzw_round_trips_through_a_reference_decoder() {
        // Long runs (table growth past 512, 1024, 2048 and a clear at 4095) and noise.
        let mut data = Vec::new();
        let mut x: u32 = 12345;
        for i in 0..200_000u32 {
            x = x.wrapping_mul(1_103_515_245).wrapping_add(12_345);
            data.push(if i % 7000 < 3000 {
                (x >> 16) as u8
            } else {
                (i / 50) as u8 % 4
            });
        }
        assert_eq!(decode(&lzw(&data)), data);
        assert_eq!(decode(&lzw(&[7])), vec![7]);
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
