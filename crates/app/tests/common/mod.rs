//! Helpers shared by the command-line tests: run the built `octoarm` binary, read its stderr,
//! find the workspace, snapshot a folder's files, and the tiny scenario most tests start from.
//! Each test binary uses a subset, hence the `dead_code` allowance.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A 10-element rod under a small tip force for 50 ms: valid, fast, planar.
pub const TINY: &str = r#"
[rod]
n_elements = 10
length = 0.2
base_diameter = 0.02
tip_diameter = 0.01
density = 700.0
youngs_modulus = 1.0e4
shear_modulus = 1.0e3

[time]
dt = 1.0e-4
duration = 0.05
save_interval = 1.0e-3

[damping]
rate = 10.0

[[load]]
kind = "tip_force"
value = [0.0, 1.0e-4, 0.0]
"#;

/// Path of the built `octoarm` binary.
pub fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_octoarm")
}

/// Run `octoarm ARGS` in `cwd` and wait for it.
pub fn octoarm(args: &[&str], cwd: &Path) -> Output {
    Command::new(bin())
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("the binary runs")
}

/// The process's stderr as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The workspace root (where `scenarios/` lives).
pub fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

/// Every file below `dir` with its bytes, sorted by path.
pub fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push((p.clone(), std::fs::read(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}
