//! Output folders that never lose a user's work. Every folder octoarm writes carries a marker
//! file, `.octoarm` (program, version, run id, and the list of entries it wrote); a folder is
//! replaced only if it is empty or carries octoarm's marker and holds nothing else, and then only
//! the entries the marker lists are removed. A run writes into a hidden sibling
//! (`.NAME.partial-PID`) and swaps it in at the end, so an output appears whole or not at all; a
//! lock file (`.NAME.lock`) keeps two octoarm processes from writing the same place; stale
//! partial folders of dead processes are removed on the next run into the same place.

use anyhow::{Context, Result};
use std::fs;
use std::path::{Path, PathBuf};

/// Name of the marker file in every folder octoarm writes.
pub const MARKER: &str = ".octoarm";

/// A problem with the output location, found before the first step (exit code 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct OutputError(pub String);

/// What a marker says.
#[derive(Debug, Clone, PartialEq)]
pub struct Marker {
    /// "run" (one run's folder) or "paper" (the root of `octoarm paper`).
    pub kind: String,
    /// The run id of the output.
    pub run: String,
    /// Entries octoarm wrote (file names; folders with a trailing `/`).
    pub entries: Vec<String>,
}

impl Marker {
    fn text(&self) -> String {
        let list = self
            .entries
            .iter()
            .map(|e| format!("{e:?}"))
            .collect::<Vec<_>>()
            .join(", ");
        format!(
            "# Written by octoarm: this folder is an octoarm output. octoarm replaces it only while\n\
             # it holds nothing but the entries listed here.\nprogram = \"octoarm\"\nversion = \"{}\"\n\
             kind = \"{}\"\nrun = \"{}\"\nentries = [{list}]\n",
            env!("CARGO_PKG_VERSION"),
            self.kind,
            self.run
        )
    }

    /// The marker of `dir`, if it has one written by octoarm.
    pub fn read(dir: &Path) -> Option<Self> {
        let text = fs::read_to_string(dir.join(MARKER)).ok()?;
        let v: toml::Value = toml::from_str(&text).ok()?;
        if v.get("program")?.as_str()? != "octoarm" {
            return None;
        }
        Some(Self {
            kind: v.get("kind")?.as_str()?.to_string(),
            run: v.get("run")?.as_str()?.to_string(),
            entries: v
                .get("entries")?
                .as_array()?
                .iter()
                .filter_map(|e| e.as_str().map(str::to_string))
                .collect(),
        })
    }

    /// Write the marker into `dir`, through a temporary file and a rename: a marker that is
    /// rewritten as a folder fills (a sweep's) is never seen half written.
    pub fn write(&self, dir: &Path) -> Result<()> {
        let path = dir.join(MARKER);
        let tmp = dir.join(format!("{MARKER}.partial-{}", std::process::id()));
        fs::write(&tmp, self.text()).with_context(|| format!("cannot write {}", tmp.display()))?;
        fs::rename(&tmp, &path).with_context(|| format!("cannot write {}", path.display()))
    }
}

/// A run id: UTC time, process id and a counter, unique on this machine.
pub fn new_run_id() -> String {
    use std::sync::atomic::{AtomicU64, Ordering};
    static COUNT: AtomicU64 = AtomicU64::new(0);
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_millis());
    format!(
        "{now}-{}-{}",
        std::process::id(),
        COUNT.fetch_add(1, Ordering::Relaxed)
    )
}

/// The entries of a folder (names; folders with a trailing `/`), sorted.
fn entries(dir: &Path) -> std::io::Result<Vec<String>> {
    let mut out = Vec::new();
    for e in fs::read_dir(dir)? {
        let e = e?;
        let name = e.file_name().to_string_lossy().into_owned();
        if e.file_type()?.is_dir() {
            out.push(format!("{name}/"));
        } else {
            out.push(name);
        }
    }
    out.sort();
    Ok(out)
}

fn show(list: &[String]) -> String {
    let mut s = list.iter().take(6).cloned().collect::<Vec<_>>().join(", ");
    if list.len() > 6 {
        s += &format!(" and {} more", list.len() - 6);
    }
    s
}

/// Whether `dir` may be replaced: empty, or octoarm's with nothing but what its marker lists
/// (folders it lists checked the same way), and writable. `what` names the flag in messages.
pub fn check_replaceable(dir: &Path, what: &str) -> Result<(), OutputError> {
    let fail = |msg: String| Err(OutputError(format!("{what} {}: {msg}", dir.display())));
    if !dir.is_dir() {
        return fail("exists and is not a directory; choose another place".into());
    }
    let found = match entries(dir) {
        Ok(e) => e,
        Err(e) => return fail(format!("cannot read the directory: {e}")),
    };
    if found.is_empty() {
        return writable(dir, what);
    }
    let Some(marker) = Marker::read(dir) else {
        return fail(format!(
            "exists and is not an octoarm output (it has no {MARKER} marker); it holds {}. \
             octoarm never replaces a folder it did not write: choose another place, or empty it",
            show(&found)
        ));
    };
    let foreign: Vec<String> = found
        .iter()
        .filter(|e| e.as_str() != MARKER && !marker.entries.contains(e))
        .cloned()
        .collect();
    if !foreign.is_empty() {
        return fail(format!(
            "is an octoarm output, but it also holds {} that octoarm did not write; octoarm never \
             removes files it did not write: move them out, or choose another place",
            show(&foreign)
        ));
    }
    for e in &marker.entries {
        if let Some(sub) = e.strip_suffix('/') {
            if dir.join(sub).is_dir() {
                check_replaceable(&dir.join(sub), what)?;
            }
        }
    }
    writable(dir, what)
}

fn writable(dir: &Path, what: &str) -> Result<(), OutputError> {
    match fs::metadata(dir) {
        Ok(m) if m.permissions().readonly() => Err(OutputError(format!(
            "{what} {}: is read-only: octoarm could not replace it; make it writable or choose another place",
            dir.display()
        ))),
        Ok(_) => Ok(()),
        Err(e) => Err(OutputError(format!(
            "{what} {}: cannot read it: {e}",
            dir.display()
        ))),
    }
}

/// Remove the entries a marker lists (and the marker), then the folder if it is empty. Never
/// removes anything else.
pub fn remove_owned(dir: &Path) -> Result<()> {
    let Some(marker) = Marker::read(dir) else {
        return Ok(());
    };
    for e in &marker.entries {
        let p = dir.join(e.trim_end_matches('/'));
        if e.ends_with('/') {
            if p.is_dir() {
                remove_owned(&p)?;
            }
        } else if p.exists() {
            fs::remove_file(&p).with_context(|| format!("cannot remove {}", p.display()))?;
        }
    }
    let m = dir.join(MARKER);
    if m.exists() {
        fs::remove_file(&m).with_context(|| format!("cannot remove {}", m.display()))?;
    }
    // Only an empty folder is removed: anything else in it stays where it is.
    let _ = fs::remove_dir(dir);
    Ok(())
}

/// Whether process `pid` is alive (Linux: /proc; elsewhere assumed alive).
pub(crate) fn alive(pid: u32) -> bool {
    if cfg!(target_os = "linux") {
        Path::new(&format!("/proc/{pid}")).exists()
    } else {
        true
    }
}

/// Remove `.NAME.partial-PID` / `.NAME.old-PID` siblings of `target` left by dead processes
/// (only folders with octoarm's marker, and only what the marker lists — for partial folders,
/// which only octoarm writes into, everything).
pub(crate) fn clean_stale(parent: &Path, name: &str) {
    let Ok(list) = fs::read_dir(parent) else {
        return;
    };
    for e in list.flatten() {
        let file = e.file_name().to_string_lossy().into_owned();
        for (prefix, partial) in [
            (format!(".{name}.partial-"), true),
            (format!(".{name}.old-"), false),
        ] {
            let Some(pid) = file.strip_prefix(&prefix) else {
                continue;
            };
            let Ok(pid) = pid.parse::<u32>() else {
                continue;
            };
            let path = e.path();
            if pid == std::process::id() || alive(pid) || Marker::read(&path).is_none() {
                continue;
            }
            if partial {
                let _ = fs::remove_dir_all(&path);
            } else {
                let _ = remove_owned(&path);
            }
            tracing::info!("removed {}, left by a process that ended", path.display());
        }
    }
}

/// A lock on an output place: `.NAME.lock` beside it, holding the owner's pid.
#[derive(Debug)]
pub struct Lock {
    path: PathBuf,
}

impl Lock {
    /// Take the lock of `target` (in `parent`), or fail naming the process that holds it.
    pub fn take(parent: &Path, name: &str, what: &str, target: &Path) -> Result<Self, OutputError> {
        let path = parent.join(format!(".{name}.lock"));
        for _ in 0..2 {
            match fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path)
            {
                Ok(mut f) => {
                    use std::io::Write;
                    let _ = write!(f, "{}", std::process::id());
                    return Ok(Self { path });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let owner = fs::read_to_string(&path)
                        .ok()
                        .and_then(|s| s.trim().parse::<u32>().ok());
                    match owner {
                        Some(pid) if alive(pid) && pid != std::process::id() => {
                            return Err(OutputError(format!(
                                "{what} {}: another octoarm (process {pid}) is writing it; wait for it \
                                 or choose another place",
                                target.display()
                            )));
                        }
                        // A lock of a process that ended: take it over.
                        _ => {
                            let _ = fs::remove_file(&path);
                        }
                    }
                }
                Err(e) => {
                    return Err(OutputError(format!(
                        "{what} {}: cannot create {}: {e}",
                        target.display(),
                        path.display()
                    )))
                }
            }
        }
        Err(OutputError(format!(
            "{what} {}: cannot take the lock {}",
            target.display(),
            path.display()
        )))
    }
}

impl Drop for Lock {
    fn drop(&mut self) {
        let _ = fs::remove_file(&self.path);
    }
}

/// Split `target` into its parent folder and its name, creating the parent.
pub fn parent_and_name(target: &Path, what: &str) -> Result<(PathBuf, String), OutputError> {
    let name = target
        .file_name()
        .ok_or_else(|| {
            OutputError(format!(
                "{what} {}: needs a directory name",
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
            "{what} {}: cannot create {}: {e}",
            target.display(),
            parent.display()
        ))
    })?;
    Ok((parent, name))
}

/// An output directory under construction: files go into a hidden sibling directory and
/// `commit` swaps it in for the target, so an existing output is replaced whole or not at all.
#[derive(Debug)]
pub struct OutputDir {
    target: PathBuf,
    tmp: PathBuf,
    run: String,
    committed: bool,
    _lock: Lock,
}

impl OutputDir {
    /// Check that `target` is new, empty or octoarm's own output holding nothing else, lock it,
    /// and create the temporary directory beside it. Errors name the path and what to change.
    pub fn prepare(target: &Path) -> Result<Self, OutputError> {
        let what = "--out";
        let (parent, name) = parent_and_name(target, what)?;
        let lock = Lock::take(&parent, &name, what, target)?;
        clean_stale(&parent, &name);
        if target.exists() {
            check_replaceable(target, what)?;
        }
        let tmp = parent.join(format!(".{name}.partial-{}", std::process::id()));
        if tmp.exists() {
            let _ = fs::remove_dir_all(&tmp);
        }
        fs::create_dir(&tmp).map_err(|e| {
            OutputError(format!(
                "{what} {}: cannot create {}: {e}",
                target.display(),
                tmp.display()
            ))
        })?;
        let run = new_run_id();
        let out = Self {
            target: target.to_path_buf(),
            tmp,
            run,
            committed: false,
            _lock: lock,
        };
        // The partial folder carries the marker from the start, so that a stale one is known.
        Marker {
            kind: "partial".into(),
            run: out.run.clone(),
            entries: Vec::new(),
        }
        .write(&out.tmp)
        .map_err(|e| OutputError(format!("{e:#}")))?;
        Ok(out)
    }

    /// Path of a file inside the (temporary) directory.
    pub fn path(&self, name: &str) -> PathBuf {
        self.tmp.join(name)
    }

    /// The final location.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// This output's run id (also in its marker).
    pub fn run_id(&self) -> &str {
        &self.run
    }

    /// Move the finished directory into place. An earlier octoarm output there is replaced
    /// (only the entries its marker lists are removed). If, meanwhile, someone put a file into
    /// the target, nothing of theirs is touched: the new output stays beside it as
    /// `NAME.new-RUN` and the error says so.
    pub fn commit(mut self) -> Result<PathBuf> {
        let listed: Vec<String> = entries(&self.tmp)
            .with_context(|| format!("cannot read {}", self.tmp.display()))?
            .into_iter()
            .filter(|e| e.as_str() != MARKER && !e.starts_with('.'))
            .collect();
        // Spools (hidden members in progress) must be gone by now.
        for e in entries(&self.tmp)? {
            if e.starts_with('.') && e != MARKER {
                let p = self.tmp.join(e.trim_end_matches('/'));
                let _ = fs::remove_file(&p);
            }
        }
        Marker {
            kind: "run".into(),
            run: self.run.clone(),
            entries: listed,
        }
        .write(&self.tmp)?;
        let name = self
            .target
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned();
        if self.target.exists() {
            if let Err(e) = check_replaceable(&self.target, "--out") {
                let aside = self
                    .target
                    .with_file_name(format!("{name}.new-{}", self.run));
                fs::rename(&self.tmp, &aside)
                    .with_context(|| format!("cannot move the output to {}", aside.display()))?;
                self.committed = true;
                anyhow::bail!(
                    "{e}\n  the new output was kept beside it, in {}",
                    aside.display()
                );
            }
            let old = self
                .tmp
                .with_file_name(format!(".{name}.old-{}", std::process::id()));
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
            self.committed = true;
            if let Err(e) = remove_owned(&old) {
                tracing::warn!(
                    "the earlier output could not be removed from {}: {e:#}",
                    old.display()
                );
            }
        } else {
            fs::rename(&self.tmp, &self.target).with_context(|| {
                format!("cannot move the output into {}", self.target.display())
            })?;
            self.committed = true;
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_foreign_folders_and_replaces_only_its_own() {
        let dir = tempfile::tempdir().unwrap();
        let foreign = dir.path().join("home");
        fs::create_dir(&foreign).unwrap();
        fs::write(foreign.join("notes.txt"), "keep").unwrap();
        let e = OutputDir::prepare(&foreign).unwrap_err();
        assert!(e.0.contains("notes.txt"), "{e}");

        let target = dir.path().join("run");
        let out = OutputDir::prepare(&target).unwrap();
        fs::write(out.path("summary.json"), "1").unwrap();
        out.commit().unwrap();
        assert!(Marker::read(&target).is_some());
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
        // No temporary directories or locks are left behind.
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 2);

        // A user's file put into an octoarm output makes it foreign.
        fs::write(target.join("thesis.md"), "mine").unwrap();
        let e = OutputDir::prepare(&target).unwrap_err();
        assert!(
            e.0.contains("thesis.md") && e.0.contains("did not write"),
            "{e}"
        );
        // ... also when it appears during the run: the new output goes beside it.
        fs::remove_file(target.join("thesis.md")).unwrap();
        let out = OutputDir::prepare(&target).unwrap();
        fs::write(out.path("summary.json"), "3").unwrap();
        fs::write(target.join("late.txt"), "mine too").unwrap();
        let e = out.commit().unwrap_err().to_string();
        assert!(e.contains("late.txt") && e.contains(".new-"), "{e}");
        assert_eq!(
            fs::read_to_string(target.join("late.txt")).unwrap(),
            "mine too"
        );
        assert_eq!(
            fs::read_to_string(target.join("summary.json")).unwrap(),
            "2"
        );
    }

    #[test]
    fn a_second_writer_is_refused_and_stale_partials_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("run");
        let first = OutputDir::prepare(&target).unwrap();
        // Same process: the lock file names us, so fake another live owner (pid 1).
        fs::write(dir.path().join(".run.lock"), "1").unwrap();
        let e = OutputDir::prepare(&target).unwrap_err();
        assert!(e.0.contains("another octoarm (process 1)"), "{e}");
        drop(first);
        // A stale partial of a dead process (pid 2^31 - 1 is not running) is removed.
        let stale = dir.path().join(".run.partial-2147483646");
        fs::create_dir(&stale).unwrap();
        Marker {
            kind: "partial".into(),
            run: "x".into(),
            entries: vec![],
        }
        .write(&stale)
        .unwrap();
        fs::write(stale.join(".position.spool"), vec![0u8; 1000]).unwrap();
        let out = OutputDir::prepare(&target).unwrap();
        assert!(!stale.exists());
        drop(out);
        // A folder without the marker next to it is not touched, whatever its name.
        let lookalike = dir.path().join(".run.partial-2147483645");
        fs::create_dir(&lookalike).unwrap();
        fs::write(lookalike.join("data"), "mine").unwrap();
        let _out = OutputDir::prepare(&target).unwrap();
        assert!(lookalike.join("data").exists());
    }
}
