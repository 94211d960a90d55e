//! Output files: the output directory written under a temporary name and swapped in whole at
//! the end (never half-overwritten), `.npy` headers, `.npz` archives assembled from streamed
//! members, and JSON. It knows nothing of rods or scenarios; `recorder.rs` decides what to write.

use anyhow::{bail, Context, Result};
use std::fs::{self, File};
use std::io::{self, BufWriter, Read, Seek, Write};
use std::path::{Path, PathBuf};
use zip::write::SimpleFileOptions;
use zip::{CompressionMethod, ZipArchive, ZipWriter};

/// Deflate level of `.npz` members: 1 (fastest) costs a few percent in size against numpy's
/// default 6 and compresses about three times faster, which keeps writing off the critical path.
pub const NPZ_LEVEL: i64 = 1;

/// Files that mark a directory as an earlier octoarm output, safe to replace.
const MARKERS: [&str; 2] = ["summary.json", "scenario.toml"];

/// An output directory under construction: files go into a hidden sibling directory and
/// `commit` swaps it in for the target, so an existing output is replaced whole or not at all.
#[derive(Debug)]
pub struct OutputDir {
    target: PathBuf,
    tmp: PathBuf,
    committed: bool,
}

/// A problem with the output location, found before the first step (exit code 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct OutputError(pub String);

impl OutputDir {
    /// Check that `target` is new, empty or an earlier octoarm output, and create the temporary
    /// directory beside it. Errors name the path and what to change.
    pub fn prepare(target: &Path) -> Result<Self, OutputError> {
        if target.exists() {
            if !target.is_dir() {
                return Err(OutputError(format!(
                    "--out {}: exists and is not a directory; choose another --out",
                    target.display()
                )));
            }
            let mut entries = fs::read_dir(target).map_err(|e| {
                OutputError(format!(
                    "--out {}: cannot read the directory: {e}",
                    target.display()
                ))
            })?;
            let empty = entries.next().is_none();
            if !empty && !MARKERS.iter().any(|m| target.join(m).is_file()) {
                return Err(OutputError(format!(
                    "--out {}: exists and is not an octoarm output directory (no summary.json); \
                     refusing to replace it: choose another --out or remove it",
                    target.display()
                )));
            }
        }
        let name = target
            .file_name()
            .ok_or_else(|| {
                OutputError(format!(
                    "--out {}: needs a directory name",
                    target.display()
                ))
            })?
            .to_string_lossy()
            .into_owned();
        let parent = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        fs::create_dir_all(&parent).map_err(|e| {
            OutputError(format!(
                "--out {}: cannot create {}: {e}",
                target.display(),
                parent.display()
            ))
        })?;
        let tmp = parent.join(format!(".{name}.partial-{}", std::process::id()));
        if tmp.exists() {
            let _ = fs::remove_dir_all(&tmp);
        }
        fs::create_dir(&tmp).map_err(|e| {
            OutputError(format!(
                "--out {}: cannot create {}: {e}",
                target.display(),
                tmp.display()
            ))
        })?;
        Ok(Self {
            target: target.to_path_buf(),
            tmp,
            committed: false,
        })
    }

    /// Path of a file inside the (temporary) directory.
    pub fn path(&self, name: &str) -> PathBuf {
        self.tmp.join(name)
    }

    /// The final location.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Move the finished directory into place, replacing an earlier output whole.
    pub fn commit(mut self) -> Result<PathBuf> {
        if self.target.exists() {
            let old = self.tmp.with_file_name(format!(
                ".{}.old-{}",
                self.target
                    .file_name()
                    .unwrap_or_default()
                    .to_string_lossy(),
                std::process::id()
            ));
            fs::rename(&self.target, &old).with_context(|| {
                format!(
                    "cannot move the earlier output {} aside",
                    self.target.display()
                )
            })?;
            if let Err(e) = fs::rename(&self.tmp, &self.target) {
                let _ = fs::rename(&old, &self.target);
                return Err(e).with_context(|| {
                    format!("cannot move the output into {}", self.target.display())
                });
            }
            fs::remove_dir_all(&old).with_context(|| format!("cannot remove {}", old.display()))?;
        } else {
            fs::rename(&self.tmp, &self.target).with_context(|| {
                format!("cannot move the output into {}", self.target.display())
            })?;
        }
        self.committed = true;
        Ok(self.target.clone())
    }
}

impl Drop for OutputDir {
    fn drop(&mut self) {
        if !self.committed {
            let _ = fs::remove_dir_all(&self.tmp);
        }
    }
}

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
    zip: ZipWriter<BufWriter<File>>,
    bytes: Vec<u8>,
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
        zip.start_file(format!("{name}.npy"), member_options(total))?;
        zip.write_all(&npy_header(&shape))?;
        Ok(Self {
            name: name.to_string(),
            frame_shape: frame_shape.to_vec(),
            frame_len,
            planned,
            written: 0,
            path,
            zip,
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
        self.zip.write_all(&self.bytes)?;
        self.written += 1;
        Ok(())
    }

    /// Frames written so far.
    pub fn frames(&self) -> usize {
        self.written
    }

    /// Close the spool and copy it into `npz` as a member. When fewer frames than planned were
    /// written (a failed run), the member is rewritten with the true frame count.
    pub fn append_to<W: Write + Seek>(self, npz: &mut ZipWriter<W>) -> Result<()> {
        let Self {
            name,
            frame_shape,
            frame_len,
            planned,
            written,
            path,
            zip,
            ..
        } = self;
        let file = zip.finish()?.into_inner().map_err(|e| e.into_error())?;
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

    #[test]
    fn output_dir_refuses_foreign_directories_and_replaces_its_own() {
        let dir = tempfile::tempdir().unwrap();
        let foreign = dir.path().join("home");
        fs::create_dir(&foreign).unwrap();
        fs::write(foreign.join("notes.txt"), "keep").unwrap();
        assert!(OutputDir::prepare(&foreign).is_err());

        let target = dir.path().join("run");
        let out = OutputDir::prepare(&target).unwrap();
        fs::write(out.path("summary.json"), "1").unwrap();
        out.commit().unwrap();
        let out = OutputDir::prepare(&target).unwrap();
        fs::write(out.path("summary.json"), "2").unwrap();
        // Before commit the earlier output is untouched.
        assert_eq!(
            fs::read_to_string(target.join("summary.json")).unwrap(),
            "1"
        );
        out.commit().unwrap();
        assert_eq!(
            fs::read_to_string(target.join("summary.json")).unwrap(),
            "2"
        );
        // No temporary directories are left behind.
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 2);
    }
}
