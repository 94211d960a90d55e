//! Output files: `.npy` headers, `.npz` archives assembled from streamed members (and read back,
//! for initial states), and JSON. The output folder itself (ownership marker, lock, swap) is
//! `outdir.rs`. It knows nothing of rods or scenarios; the recorders decide what to write.

use anyhow::{bail, Context, Result};
use std::fs::{self, File};
use std::io::{self, BufWriter, Read, Seek, Write};
use std::path::{Path, PathBuf};
use zip::write::SimpleFileOptions;
use zip::{CompressionMethod, ZipArchive, ZipWriter};

/// Deflate level of `.npz` members: 1 (fastest) costs a few percent in size against numpy's
/// default 6 and compresses about three times faster, which keeps writing off the critical path.
pub const NPZ_LEVEL: i64 = 1;

pub use crate::outdir::{OutputDir, OutputError};

/// The `.npy` (format 1.0) header of a little-endian f64 C-order array of `shape`, padded so
/// that the data starts at a multiple of 64 bytes.
pub fn npy_header(shape: &[usize]) -> Vec<u8> {
    let dims = match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(|d| d.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    let mut dict = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': {dims}, }}");
    let unpadded = 10 + dict.len() + 1;
    dict.push_str(&" ".repeat((64 - unpadded % 64) % 64));
    dict.push('\n');
    let mut out = Vec::with_capacity(10 + dict.len());
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(dict.len() as u16).to_le_bytes());
    out.extend_from_slice(dict.as_bytes());
    out
}

fn member_options(bytes: u64) -> SimpleFileOptions {
    SimpleFileOptions::default()
        .compression_method(CompressionMethod::Deflated)
        .compression_level(Some(NPZ_LEVEL))
        .large_file(bytes >= u32::MAX as u64 / 2)
}

/// One `.npz` member written while the run goes on: a single-member zip spool file whose
/// `.npy` header announces `planned` frames of `frame_shape`. `finish` returns the spool.
pub struct SpooledArray {
    name: String,
    frame_shape: Vec<usize>,
    frame_len: usize,
    planned: usize,
    written: usize,
    path: PathBuf,
    // None once finished. A spool dropped unfinished (after an I/O error) is abandoned without
    // the zip writer's own drop, which would try to finish and print to stderr.
    zip: Option<ZipWriter<BufWriter<File>>>,
    bytes: Vec<u8>,
}

impl Drop for SpooledArray {
    fn drop(&mut self) {
        if let Some(zip) = self.zip.take() {
            std::mem::forget(zip);
        }
    }
}

impl SpooledArray {
    /// Start a spool at `path` for member `name` ("position" → `position.npy`).
    pub fn create(
        path: PathBuf,
        name: &str,
        frame_shape: &[usize],
        planned: usize,
    ) -> Result<Self> {
        let frame_len: usize = frame_shape.iter().product();
        let file =
            File::create(&path).with_context(|| format!("cannot create {}", path.display()))?;
        let mut zip = ZipWriter::new(BufWriter::with_capacity(1 << 16, file));
        let mut shape = vec![planned];
        shape.extend_from_slice(frame_shape);
        let total = (planned * frame_len * 8) as u64;
        zip.start_file(format!("{name}.npy"), member_options(total))
            .and_then(|()| zip.write_all(&npy_header(&shape)).map_err(Into::into))
            .with_context(|| format!("cannot write {}", path.display()))?;
        Ok(Self {
            name: name.to_string(),
            frame_shape: frame_shape.to_vec(),
            frame_len,
            planned,
            written: 0,
            path,
            zip: Some(zip),
            bytes: Vec::with_capacity(frame_len * 8),
        })
    }

    /// One spool per member `(name, frame_shape)`, in the order given, each at
    /// `dir/.{name}.spool` for `planned` frames.
    pub fn create_members<'n>(
        dir: &Path,
        members: impl IntoIterator<Item = (&'n str, Vec<usize>)>,
        planned: usize,
    ) -> Result<Vec<Self>> {
        members
            .into_iter()
            .map(|(name, shape)| {
                let file = format!(".{}.spool", name.replace('/', "__"));
                Self::create(dir.join(file), name, &shape, planned)
            })
            .collect()
    }

    /// Append one frame (`frame_len` values). Errors if more than `planned` frames are pushed.
    pub fn push(&mut self, values: &[f64]) -> Result<()> {
        if values.len() != self.frame_len {
            bail!(
                "{}: frame of {} values, expected {}",
                self.name,
                values.len(),
                self.frame_len
            );
        }
        if self.written == self.planned {
            bail!(
                "{}: more than the {} planned frames",
                self.name,
                self.planned
            );
        }
        self.bytes.clear();
        for v in values {
            self.bytes.extend_from_slice(&v.to_le_bytes());
        }
        let zip = self
            .zip
            .as_mut()
            .expect("a spool is written before it is finished");
        zip.write_all(&self.bytes).with_context(|| {
            format!(
                "cannot write array `{}` ({})",
                self.name,
                self.path.display()
            )
        })?;
        self.written += 1;
        Ok(())
    }

    /// Frames written so far.
    pub fn frames(&self) -> usize {
        self.written
    }

    /// Close the spool and copy it into `npz` as a member. When fewer frames than planned were
    /// written (a failed run), the member is rewritten with the true frame count.
    pub fn append_to<W: Write + Seek>(mut self, npz: &mut ZipWriter<W>) -> Result<()> {
        let zip = self.zip.take().expect("a spool is finished once");
        let (name, frame_shape, frame_len, planned, written, path) = (
            self.name.clone(),
            self.frame_shape.clone(),
            self.frame_len,
            self.planned,
            self.written,
            self.path.clone(),
        );
        let file = zip
            .finish()
            .map_err(anyhow::Error::from)
            .and_then(|w| w.into_inner().map_err(|e| e.into_error().into()))
            .with_context(|| format!("cannot write {}", path.display()))?;
        drop(file);
        let mut archive = ZipArchive::new(File::open(&path)?)?;
        if written == planned {
            npz.raw_copy_file(archive.by_index_raw(0)?)?;
        } else {
            let mut member = archive.by_index(0)?;
            let mut shape = vec![planned];
            shape.extend_from_slice(&frame_shape);
            let mut skip = vec![0u8; npy_header(&shape).len()];
            member.read_exact(&mut skip)?;
            let mut shape = vec![written];
            shape.extend_from_slice(&frame_shape);
            let bytes = (written * frame_len * 8) as u64;
            npz.start_file(format!("{name}.npy"), member_options(bytes))?;
            npz.write_all(&npy_header(&shape))?;
            io::copy(&mut member.by_ref().take(bytes), npz)?;
        }
        drop(archive);
        fs::remove_file(&path).with_context(|| format!("cannot remove {}", path.display()))?;
        Ok(())
    }
}

/// Write a whole f64 array as a member of `npz`.
pub fn write_member<W: Write + Seek>(
    npz: &mut ZipWriter<W>,
    name: &str,
    shape: &[usize],
    data: &[f64],
) -> Result<()> {
    debug_assert_eq!(shape.iter().product::<usize>(), data.len());
    npz.start_file(
        format!("{name}.npy"),
        member_options((data.len() * 8) as u64),
    )?;
    npz.write_all(&npy_header(shape))?;
    let mut bytes = Vec::with_capacity(data.len() * 8);
    for v in data {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    npz.write_all(&bytes)?;
    Ok(())
}

/// An array member of an `.npz` file as its shape (little-endian f64, C order).
fn read_npy_header<R: Read>(r: &mut R, name: &str) -> Result<Vec<usize>> {
    let mut magic = [0u8; 10];
    r.read_exact(&mut magic)
        .with_context(|| format!("{name}: not an .npy array"))?;
    if &magic[..6] != b"\x93NUMPY" {
        bail!("{name}: not an .npy array");
    }
    let len = match magic[6] {
        1 => u16::from_le_bytes([magic[8], magic[9]]) as usize,
        2 | 3 => {
            let mut more = [0u8; 2];
            r.read_exact(&mut more)?;
            u32::from_le_bytes([magic[8], magic[9], more[0], more[1]]) as usize
        }
        v => bail!("{name}: unsupported .npy version {v}"),
    };
    let mut dict = vec![0u8; len];
    r.read_exact(&mut dict)?;
    let dict = String::from_utf8_lossy(&dict);
    if !dict.contains("'descr': '<f8'") || !dict.contains("'fortran_order': False") {
        bail!("{name}: expected a little-endian float64 C-order array, header {dict}");
    }
    let shape = dict
        .split("'shape': (")
        .nth(1)
        .and_then(|t| t.split(')').next())
        .ok_or_else(|| anyhow::anyhow!("{name}: no shape in the header {dict}"))?;
    shape
        .split(',')
        .map(str::trim)
        .filter(|d| !d.is_empty())
        .map(|d| {
            d.parse::<usize>()
                .with_context(|| format!("{name}: bad shape {shape}"))
        })
        .collect()
}

/// Names of the members of an `.npz` file (without `.npy`).
pub fn npz_names(path: &Path) -> Result<Vec<String>> {
    let zip = open_npz(path)?;
    Ok(zip
        .file_names()
        .map(|n| n.trim_end_matches(".npy").to_string())
        .collect())
}

/// Open an `.npz` file as a zip archive.
fn open_npz(path: &Path) -> Result<ZipArchive<File>> {
    let file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    ZipArchive::new(file).with_context(|| format!("{}: not an .npz file", path.display()))
}

/// The shape of member `name` and the values of its entry `index` along the first axis (a
/// frame). Reads the member up to that frame only.
pub fn read_npz_frame(path: &Path, name: &str, index: usize) -> Result<(Vec<usize>, Vec<f64>)> {
    let mut zip = open_npz(path)?;
    let mut member = zip
        .by_name(&format!("{name}.npy"))
        .with_context(|| format!("{}: has no array `{name}`", path.display()))?;
    let shape = read_npy_header(&mut member, name)?;
    let Some((&frames, rest)) = shape.split_first() else {
        bail!("{name}: a scalar, expected an array over frames");
    };
    if index >= frames {
        bail!("{name}: frame {index} requested, the array has {frames}");
    }
    let per: usize = rest.iter().product();
    io::copy(
        &mut member.by_ref().take((index * per * 8) as u64),
        &mut io::sink(),
    )?;
    let mut bytes = vec![0u8; per * 8];
    member.read_exact(&mut bytes)?;
    let values = bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
        .collect();
    Ok((shape, values))
}

/// A whole 1-D member of an `.npz` file.
pub fn read_npz_vector(path: &Path, name: &str) -> Result<Vec<f64>> {
    let mut zip = open_npz(path)?;
    let mut member = zip
        .by_name(&format!("{name}.npy"))
        .with_context(|| format!("{}: has no array `{name}`", path.display()))?;
    let shape = read_npy_header(&mut member, name)?;
    if shape.len() != 1 {
        bail!("{name}: shape {shape:?}, expected one axis");
    }
    let mut bytes = Vec::new();
    member.read_to_end(&mut bytes)?;
    if bytes.len() != shape[0] * 8 {
        bail!(
            "{name}: {} bytes of data for {} values",
            bytes.len(),
            shape[0]
        );
    }
    Ok(bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
        .collect())
}

/// Write `value` as pretty JSON to `path`.
pub fn write_json(path: &Path, value: &serde_json::Value) -> Result<()> {
    let text = serde_json::to_string_pretty(value)? + "\n";
    fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn npy_header_is_aligned_and_readable() {
        for shape in [vec![7], vec![3, 101, 3], vec![10_000_000, 100, 3, 3]] {
            let h = npy_header(&shape);
            assert_eq!(h.len() % 64, 0);
            assert_eq!(&h[..6], b"\x93NUMPY");
            assert_eq!(u16::from_le_bytes([h[8], h[9]]) as usize, h.len() - 10);
            assert_eq!(*h.last().unwrap(), b'\n');
        }
        assert!(String::from_utf8_lossy(&npy_header(&[7])).contains("'shape': (7,)"));
    }

    #[test]
    fn spooled_members_read_back_with_ndarray_npy() {
        let dir = tempfile::tempdir().unwrap();
        let npz_path = dir.path().join("t.npz");
        let mut npz = ZipWriter::new(File::create(&npz_path).unwrap());
        // A complete member (raw copy) and a short one (rewritten with the true count).
        let mut full = SpooledArray::create(dir.path().join("a.zip"), "a", &[2, 3], 2).unwrap();
        let mut short = SpooledArray::create(dir.path().join("b.zip"), "b", &[4], 5).unwrap();
        for k in 0..2 {
            full.push(&[k as f64; 6]).unwrap();
            short.push(&[1.0 + k as f64; 4]).unwrap();
        }
        assert!(full.push(&[0.0; 6]).is_err());
        full.append_to(&mut npz).unwrap();
        short.append_to(&mut npz).unwrap();
        write_member(&mut npz, "time", &[2], &[0.0, 0.5]).unwrap();
        npz.finish().unwrap();
        let mut r = ndarray_npy::NpzReader::new(File::open(&npz_path).unwrap()).unwrap();
        let a: ndarray::Array3<f64> = r.by_name("a.npy").unwrap();
        assert_eq!(a.shape(), &[2, 2, 3]);
        assert_eq!(a[[1, 1, 2]], 1.0);
        let b: ndarray::Array2<f64> = r.by_name("b.npy").unwrap();
        assert_eq!(b.shape(), &[2, 4]);
        assert_eq!(b[[1, 3]], 2.0);
        let t: ndarray::Array1<f64> = r.by_name("time.npy").unwrap();
        assert_eq!(t.to_vec(), vec![0.0, 0.5]);
    }
}
