//! Reading the `.npz` files octoarm writes (`trajectory.npz`, `series.npz`) for the viewer:
//! member names and shapes from the `.npy` headers, and members thinned along their first
//! axis (frames) to a bounded number of rows, streamed so memory stays bounded by what is kept.
//! Little-endian float64 and float32 members only (what octoarm writes); others are skipped.

use anyhow::{anyhow, bail, Context, Result};
use std::fs::File;
use std::io::{self, Read};
use std::path::Path;
use zip::ZipArchive;

/// One member of an `.npz` file: its name (without `.npy`) and shape.
#[derive(Debug, Clone, PartialEq)]
pub struct Member {
    /// Name, e.g. `position` or `left/position`.
    pub name: String,
    /// Shape (first axis: frames for per-frame arrays).
    pub shape: Vec<usize>,
    /// Bytes per value: 8 (float64) or 4 (float32).
    width: usize,
}

fn open(path: &Path) -> Result<ZipArchive<File>> {
    let file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    ZipArchive::new(file).with_context(|| format!("{}: not an .npz file", path.display()))
}

/// Parse an `.npy` header: (shape, bytes per value). Only little-endian `<f8`/`<f4`, C order.
fn header(r: &mut impl Read, name: &str) -> Result<(Vec<usize>, usize)> {
    let mut magic = [0u8; 8];
    r.read_exact(&mut magic)?;
    if &magic[..6] != b"\x93NUMPY" {
        bail!("{name}: not an .npy member");
    }
    let len = if magic[6] == 1 {
        let mut b = [0u8; 2];
        r.read_exact(&mut b)?;
        u16::from_le_bytes(b) as usize
    } else {
        let mut b = [0u8; 4];
        r.read_exact(&mut b)?;
        u32::from_le_bytes(b) as usize
    };
    if len > 1 << 16 {
        bail!("{name}: .npy header of {len} bytes");
    }
    let mut text = vec![0u8; len];
    r.read_exact(&mut text)?;
    let text = String::from_utf8_lossy(&text);
    let width = if text.contains("'<f8'") {
        8
    } else if text.contains("'<f4'") {
        4
    } else {
        bail!("{name}: only little-endian float64/float32 members are read");
    };
    if text.contains("'fortran_order': True") {
        bail!("{name}: Fortran-ordered members are not read");
    }
    let open = text
        .find("'shape': (")
        .ok_or_else(|| anyhow!("{name}: .npy header without a shape"))?;
    let rest = &text[open + 10..];
    let close = rest
        .find(')')
        .ok_or_else(|| anyhow!("{name}: bad .npy shape"))?;
    let shape = rest[..close]
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<usize>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|_| anyhow!("{name}: bad .npy shape {:?}", &rest[..close]))?;
    Ok((shape, width))
}

/// The readable members of `path` with their shapes, in file order.
pub fn members(path: &Path) -> Result<Vec<Member>> {
    let mut zip = open(path)?;
    let mut out = Vec::new();
    for i in 0..zip.len() {
        let mut file = zip.by_index(i)?;
        let Some(name) = file.name().strip_suffix(".npy").map(str::to_string) else {
            continue;
        };
        if let Ok((shape, width)) = header(&mut file, &name) {
            out.push(Member { name, shape, width });
        }
    }
    Ok(out)
}

/// `count` frame indices evenly spread over `0..frames`, the first and last included, in
/// increasing order without repeats (all frames when `frames <= count`).
pub fn pick_frames(frames: usize, count: usize) -> Vec<usize> {
    if frames == 0 || count == 0 {
        return Vec::new();
    }
    if frames <= count {
        return (0..frames).collect();
    }
    let mut v: Vec<usize> = (0..count)
        .map(|i| {
            if count == 1 {
                frames - 1
            } else {
                (i as u128 * (frames - 1) as u128 / (count - 1) as u128) as usize
            }
        })
        .collect();
    v.dedup();
    v
}

/// Member `m` of `path` as float32, keeping only the rows (entries along the first axis) at
/// `picks` (increasing, each below the first axis's length). A scalar member is one row.
/// Reads the member once, front to back.
pub fn read_rows(path: &Path, m: &Member, picks: &[usize]) -> Result<Vec<f32>> {
    let mut zip = open(path)?;
    let mut file = zip
        .by_name(&format!("{}.npy", m.name))
        .with_context(|| format!("{}: no member {}", path.display(), m.name))?;
    header(&mut file, &m.name)?;
    let rows = m.shape.first().copied().unwrap_or(1);
    let per: usize = m.shape.iter().skip(1).product();
    let row_bytes = per * m.width;
    let mut out = Vec::with_capacity(picks.len() * per);
    let mut row = vec![0u8; row_bytes];
    let mut at = 0usize;
    for &p in picks {
        if p >= rows || p < at {
            bail!("{}: row {p} requested of {rows}", m.name);
        }
        io::copy(
            &mut file.by_ref().take(((p - at) * row_bytes) as u64),
            &mut io::sink(),
        )?;
        file.read_exact(&mut row)
            .with_context(|| format!("{}: truncated member", m.name))?;
        at = p + 1;
        if m.width == 8 {
            out.extend(
                row.chunks_exact(8)
                    .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")) as f32),
            );
        } else {
            out.extend(
                row.chunks_exact(4)
                    .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes"))),
            );
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn npy(shape: &[usize], values: &[f64]) -> Vec<u8> {
        let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
        let shape_text = if shape.len() == 1 {
            format!("({},)", dims[0])
        } else {
            format!("({})", dims.join(", "))
        };
        let mut h = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': {shape_text}, }}");
        while (10 + h.len() + 1) % 64 != 0 {
            h.push(' ');
        }
        h.push('\n');
        let mut out = b"\x93NUMPY\x01\x00".to_vec();
        out.extend((h.len() as u16).to_le_bytes());
        out.extend(h.as_bytes());
        for v in values {
            out.extend(v.to_le_bytes());
        }
        out
    }

    #[test]
    fn thinned_rows_are_the_picked_frames() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.npz");
        let mut zip = zip::ZipWriter::new(File::create(&path).unwrap());
        let opts = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated);
        let values: Vec<f64> = (0..10 * 2 * 3).map(|v| v as f64).collect();
        zip.start_file("rod/position.npy", opts).unwrap();
        zip.write_all(&npy(&[10, 2, 3], &values)).unwrap();
        zip.start_file("time.npy", opts).unwrap();
        zip.write_all(&npy(&[10], &(0..10).map(|v| v as f64).collect::<Vec<_>>()))
            .unwrap();
        zip.finish().unwrap();
        let m = members(&path).unwrap();
        assert_eq!(m[0].name, "rod/position");
        assert_eq!(m[0].shape, vec![10, 2, 3]);
        let picks = pick_frames(10, 4);
        assert_eq!(picks, vec![0, 3, 6, 9]);
        let rows = read_rows(&path, &m[0], &picks).unwrap();
        assert_eq!(rows.len(), 4 * 6);
        assert_eq!(rows[6], 18.0);
        assert_eq!(rows[23], 59.0);
        let t = read_rows(&path, &m[1], &picks).unwrap();
        assert_eq!(t, vec![0.0, 3.0, 6.0, 9.0]);
    }

    #[test]
    fn picks_include_both_ends() {
        assert_eq!(pick_frames(3, 10), vec![0, 1, 2]);
        assert_eq!(pick_frames(1001, 3), vec![0, 500, 1000]);
        assert_eq!(pick_frames(5, 1), vec![4]);
        assert!(pick_frames(0, 5).is_empty());
    }
}
