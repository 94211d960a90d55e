//! `octoarm sweep`, tested by running the built binary: a 12-run grid gives one complete row per
//! run and each run's `trajectory.npz` equals a standalone `octoarm run` of its `scenario.toml`
//! byte for byte (and does not depend on the thread count); a failed run is recorded and the
//! others go on; an interrupted sweep resumed with `--resume` runs only the missing runs and keeps
//! the others untouched; bad sweep files get file:line:col errors naming the key, exit 2 and
//! nothing written; seeded random samples are reproducible.

mod common;
use common::{octoarm, stderr};

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const BASE: &str = r#"
[rod]
n_elements = 20
length = 0.2
base_diameter = 0.02
tip_diameter = 0.01
density = 700.0
youngs_modulus = 1.0e4
shear_modulus = 1.0e3

[time]
dt = 2.0e-5
duration = 0.02
save_interval = 2.0e-3

[damping]
rate = 10.0

[[load]]
kind = "tip_force"
value = [0.0, 1.0e-4, 0.0]
"#;

/// A 4 × 3 grid: a log range crossed with a list of vectors (12 runs).
const GRID: &str = r#"
scenario = "base.toml"
description = "stiffness x tip force"

[[parameter]]
path = "rod.youngs_modulus"
range = { start = 1.0e4, stop = 1.0e5, num = 4, scale = "log" }

[[parameter]]
path = "load[0].value"
values = [[0.0, 1.0e-4, 0.0], [0.0, 2.0e-4, 0.0], [0.0, 0.0, 3.0e-4]]
"#;

fn setup(sweep: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("base.toml"), BASE).unwrap();
    fs::write(dir.path().join("sweep.toml"), sweep).unwrap();
    dir
}

/// The data rows of results.csv, split into cells.
fn rows(out: &Path) -> Vec<Vec<String>> {
    let text = fs::read_to_string(out.join("results.csv")).unwrap();
    text.lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

fn run_dirs(out: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = fs::read_dir(out.join("runs"))
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.is_dir())
        .collect();
    v.sort();
    v
}

#[test]
fn grid_runs_equal_standalone_runs_byte_for_byte_for_any_thread_count() {
    let dir = setup(GRID);
    let o = octoarm(
        &["sweep", "sweep.toml", "--out", "one", "--threads", "1"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = octoarm(
        &[
            "sweep",
            "sweep.toml",
            "--out",
            "two",
            "--threads",
            "2",
            "-q",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let (one, two) = (dir.path().join("one"), dir.path().join("two"));
    let table = rows(&one);
    assert_eq!(table.len(), 12);
    assert!(table.iter().all(|r| r[2] == "completed"), "{table:?}");
    // Plan order: the first parameter varies slowest; its log range ends exactly at 1e5.
    assert_eq!(table[0][3], "10000.0");
    assert_eq!(table[11][3], "100000.0");
    assert_eq!(table[1][5], "0.0002");
    assert_eq!(
        fs::read(one.join("results.csv")).unwrap(),
        fs::read(two.join("results.csv")).unwrap(),
        "the table must not depend on the thread count"
    );
    // Every run differs (a stiffer rod or another force moves the tip elsewhere).
    let tips: std::collections::BTreeSet<&String> = table.iter().map(|r| &r[10]).collect();
    assert!(tips.len() >= 8, "{tips:?}");
    assert_eq!(run_dirs(&one).len(), 12);
    for (k, run) in run_dirs(&one).iter().enumerate() {
        let id = run.file_name().unwrap().to_string_lossy().into_owned();
        assert!(table.iter().any(|r| r[1] == id));
        let alone = dir.path().join(format!("alone{k}"));
        let o = octoarm(
            &[
                "run",
                run.join("scenario.toml").to_str().unwrap(),
                "--out",
                alone.to_str().unwrap(),
                "-q",
            ],
            dir.path(),
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let a = fs::read(run.join("trajectory.npz")).unwrap();
        assert_eq!(a, fs::read(alone.join("trajectory.npz")).unwrap(), "{id}");
        assert_eq!(
            a,
            fs::read(two.join("runs").join(&id).join("trajectory.npz")).unwrap()
        );
    }
    // The twin table, sweep.json and figures.
    let json: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(one.join("sweep.json")).unwrap()).unwrap();
    assert_eq!(json["counts"]["completed"], 12);
    assert_eq!(json["version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(json["runs"].as_array().unwrap().len(), 12);
    assert_eq!(json["parameters"][0]["path"], "rod.youngs_modulus");
    assert!(one.join("results.npz").is_file());
    assert!(one.join("figures").join("tip_y.png").is_file());
    // An earlier sweep is not replaced without --resume.
    let o = octoarm(&["sweep", "sweep.toml", "--out", "one"], dir.path());
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--resume"), "{}", stderr(&o));
}

#[test]
fn a_failed_run_is_recorded_and_the_others_go_on() {
    // 1e9 Pa makes dt = 2e-5 s far above the stable limit: that run becomes unstable; -1 is
    // not a valid modulus: that run is invalid. The other two complete.
    let sweep = r#"
scenario = "base.toml"
[[parameter]]
path = "rod.youngs_modulus"
values = [1.0e4, 1.0e9, -1.0, 2.0e4]
"#;
    let dir = setup(sweep);
    let o = octoarm(&["sweep", "sweep.toml", "--out", "out"], dir.path());
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let text = fs::read_to_string(dir.path().join("out").join("results.csv")).unwrap();
    let lines: Vec<&str> = text.lines().skip(1).collect();
    let status: Vec<&str> = lines.iter().map(|l| l.split(',').nth(2).unwrap()).collect();
    assert_eq!(status, ["completed", "unstable", "invalid", "completed"]);
    assert!(lines[1].contains("unstable:"), "{}", lines[1]);
    assert!(
        lines[2]
            .ends_with("\"rod.youngs_modulus = -1 is outside the allowed range (0, inf), finite\""),
        "{}",
        lines[2]
    );
    // The unstable run keeps what it recorded; the invalid one has no folder.
    assert_eq!(run_dirs(&dir.path().join("out")).len(), 3);
}

#[test]
fn resume_after_an_interrupted_sweep_runs_only_the_missing_runs() {
    let dir = setup(GRID);
    // Longer runs, so that the interruption falls in the middle of the sweep.
    fs::write(
        dir.path().join("base.toml"),
        BASE.replace("duration = 0.02", "duration = 0.3"),
    )
    .unwrap();
    let out = dir.path().join("out");
    let child = Command::new(env!("CARGO_BIN_EXE_octoarm"))
        .args(["sweep", "sweep.toml", "--out", "out", "--threads", "1"])
        .current_dir(dir.path())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while rows_if_any(&out) < 3 {
        assert!(start.elapsed() < Duration::from_secs(300), "no progress");
        std::thread::sleep(Duration::from_millis(20));
    }
    Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    let before = rows(&out);
    assert!(before.len() < 12, "the sweep ended before the interrupt");
    let completed: Vec<String> = before
        .iter()
        .filter(|r| r[2] == "completed")
        .map(|r| r[1].clone())
        .collect();
    assert!(completed.len() >= 3);
    let marker = |id: &str| fs::read_to_string(out.join("runs").join(id).join(".octoarm")).unwrap();
    let markers: Vec<String> = completed.iter().map(|id| marker(id)).collect();

    let o = octoarm(
        &["sweep", "sweep.toml", "--out", "out", "--resume"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let missing = 12 - completed.len();
    assert!(
        stderr(&o).contains(&format!(
            "{} complete runs kept; running the other {missing}",
            completed.len()
        )),
        "{}",
        stderr(&o)
    );
    // The runs completed before were not run again (their folders are the same outputs).
    for (id, m) in completed.iter().zip(&markers) {
        assert_eq!(&marker(id), m, "{id} was run again");
    }
    let after = rows(&out);
    assert_eq!(after.len(), 12);
    assert!(after.iter().all(|r| r[2] == "completed"));
    // The resumed table equals an uninterrupted sweep's.
    let o = octoarm(&["sweep", "sweep.toml", "--out", "fresh", "-q"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        fs::read(out.join("results.csv")).unwrap(),
        fs::read(dir.path().join("fresh").join("results.csv")).unwrap()
    );
}

fn rows_if_any(out: &Path) -> usize {
    fs::read_to_string(out.join("results.csv"))
        .map(|t| t.lines().count().saturating_sub(1))
        .unwrap_or(0)
}

/// A bad sweep file: the error, which must name the file, line and column.
fn bad(parameter: &str) -> String {
    let dir = setup(&format!(
        "scenario = \"base.toml\"\n\n[[parameter]]\n{parameter}\n"
    ));
    let o = octoarm(&["sweep", "sweep.toml", "--out", "out"], dir.path());
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(!dir.path().join("out").exists(), "nothing is written");
    let e = stderr(&o);
    assert!(e.starts_with("error: sweep.toml:"), "{e}");
    e
}

#[test]
fn bad_sweep_files_are_refused_with_file_line_column_and_key() {
    let e = bad("path = \"rod.youngs_modulu\"\nvalues = [1.0e4]");
    assert!(e.contains("sweep.toml:4:1:"), "{e}");
    assert!(e.contains("did you mean `youngs_modulus`?"), "{e}");
    let e = bad("path = \"rod.youngs_modulus\"\nrange = { start = 1.0e4, stop = 2.0e4, num = 0 }");
    assert!(e.contains("sweep.toml:5:"), "{e}");
    assert!(
        e.contains("parameter[0].range.num = 0 is outside the allowed range [1, 100000]"),
        "{e}"
    );
    let e = bad("path = \"rod.youngs_modulus\"\nvalues = []");
    assert!(e.contains("parameter[0].values = [] is empty"), "{e}");
    let e = bad("path = \"rod.youngs_modulus\"\nvalues = [1.0e4, \"stiff\"]");
    assert!(e.contains("same type"), "{e}");
    let e = bad("path = \"rod.youngs_modulus\"\nvalues = [\"soft\", \"stiff\"]");
    assert!(
        e.contains("sweep.toml:5:1:") && e.contains("expected f64"),
        "{e}"
    );
    let e = bad("path = \"rod.n_elements\"\nvalues = [10, 12.5]");
    assert!(e.contains("whole number"), "{e}");
    let e = bad("path = \"target[0].position\"\nvalues = [[0.1, 0.0, 0.0]]");
    assert!(e.contains("has no key `target`"), "{e}");
    let e = bad("path = \"load[2].value\"\nvalues = [[0.0, 0.0, 0.0]]");
    assert!(
        e.contains("index 2 is outside the allowed range [0, 0]"),
        "{e}"
    );
    let e = bad("path = \"rod.length\"\nrnage = { start = 0.1, stop = 0.2, num = 3 }");
    assert!(
        e.contains("unknown key `rnage`") && e.contains("allowed: path, values, range"),
        "{e}"
    );
    let e =
        bad("path = \"rod.length\"\nrange = { start = 0.1, stop = 0.2, num = 3, scale = \"lg\" }");
    assert!(
        e.contains("unknown value \"lg\" for `scale`") && e.contains("did you mean `log`"),
        "{e}"
    );
    let e = bad(
        "path = \"rod.length\"\nrange = { start = -0.1, stop = 0.2, num = 3, scale = \"log\" }",
    );
    assert!(e.contains("positive"), "{e}");
    // Too many runs: 1000 x 1000 crossed.
    let e = bad(
        "path = \"rod.length\"\nrange = { start = 0.1, stop = 0.2, num = 1000 }\n\n[[parameter]]\n\
         path = \"rod.density\"\nrange = { start = 500.0, stop = 900.0, num = 1000 }",
    );
    assert!(e.contains("at most 100000 runs"), "{e}");
    // Zipped parameters of different lengths.
    let e = bad(
        "path = \"rod.length\"\nvalues = [0.1, 0.2]\ngroup = \"g\"\n\n[[parameter]]\n\
         path = \"rod.density\"\nvalues = [500.0, 600.0, 700.0]\ngroup = \"g\"",
    );
    assert!(
        e.contains("zipped parameters need the same number of values"),
        "{e}"
    );
    // Every run invalid.
    let e = bad("path = \"rod.length\"\nvalues = [-0.1, -0.2]");
    assert!(e.contains("no run of the sweep is a valid scenario"), "{e}");
}

#[test]
fn random_samples_are_seeded_and_zipped_groups_pair_values() {
    let sweep = r#"
scenario = "base.toml"
seed = 7
[[parameter]]
path = "rod.youngs_modulus"
random = { low = 1.0e4, high = 1.0e5, count = 5, scale = "log" }
group = "material"
[[parameter]]
path = "rod.density"
random = { low = 600.0, high = 800.0, count = 5 }
group = "material"
[[parameter]]
path = "rod.n_elements"
random = { low = 10, high = 30, count = 2 }
"#;
    let dir = setup(sweep);
    let plan = |d: &Path| {
        let o = octoarm(&["sweep", "sweep.toml", "--plan"], d);
        assert!(o.status.success(), "{}", stderr(&o));
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let first = plan(dir.path());
    assert_eq!(first, plan(dir.path()), "a fixed seed gives the same plan");
    assert!(first.contains("10 runs"), "{first}");
    assert!(
        !dir.path().join("results").exists(),
        "--plan writes nothing"
    );
    fs::write(
        dir.path().join("sweep.toml"),
        sweep.replace("seed = 7", "seed = 8"),
    )
    .unwrap();
    assert_ne!(first, plan(dir.path()), "another seed, other samples");
}

#[test]
fn shipped_sweep_files_plan() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let dir = root.join("scenarios").join("sweeps");
    let mut n = 0;
    for e in fs::read_dir(&dir).unwrap().flatten() {
        let p = e.path();
        if p.extension().is_some_and(|x| x == "toml") {
            let o = octoarm(&["sweep", p.to_str().unwrap(), "--plan"], &root);
            assert!(o.status.success(), "{}: {}", p.display(), stderr(&o));
            assert!(String::from_utf8_lossy(&o.stdout).contains("(0 invalid)"));
            n += 1;
        }
    }
    assert!(n >= 2);
}
