//! `octoarm paper` end to end, **shortened**: the four experiments run for 0.2 s of simulated
//! time each (`--duration 0.2`, instead of the paper's 4 s; the full run is in the README and
//! its acceptance checks are asserted at full length in tests/regression.rs).
//! Claims: every promised file exists in every folder; trajectory.npz has the `run` members plus
//! `target` [F, 3] and `desired` [F, N+1, 3]; series.npz has the 1 ms series; distance.csv has the
//! header `time,distance`; report.md has one row per experiment and marks the checks about
//! later times as undecided; `octoarm run scenarios/paper/two-targets.toml` gives the same
//! distances bit for bit as `octoarm paper` (same spec, no dependence on the worker threads).
//! Without a terminal (as here), a controlled run longer than a second prints no progress bar:
//! its stderr is empty and its outputs are those of the same run with `-q`.

mod common;
use common::{octoarm, workspace};

use ndarray::{Array1, Array2, Array3, Array4};
use ndarray_npy::NpzReader;
use std::fs::File;

const DURATION: &str = "0.2";
const N: usize = 100;

#[test]
fn paper_command_writes_every_output_and_matches_run() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("results");
    let o = octoarm(
        &[
            "paper",
            "--out",
            root.to_str().unwrap(),
            "--duration",
            DURATION,
            "-q",
        ],
        tmp.path(),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(o.stdout.is_empty(), "-q prints nothing on success");
    for f in ["distance.png", "report.md"] {
        assert!(root.join(f).is_file(), "{f} missing");
    }
    // 0.2 s at 10 ms: frames at 0, 0.01, ..., 0.2; series at 1 ms.
    let (frames, samples) = (21, 201);
    for name in ["two-targets", "moving-target", "obstacles", "grasp"] {
        let dir = root.join(name);
        for f in [
            "trajectory.npz",
            "series.npz",
            "distance.csv",
            "shapes.png",
            "shapes.gif",
            "summary.json",
            "scenario.toml",
        ] {
            assert!(dir.join(f).is_file(), "{name}/{f} missing");
        }
        let mut npz = NpzReader::new(File::open(dir.join("trajectory.npz")).unwrap()).unwrap();
        let time: Array1<f64> = npz.by_name("time").unwrap();
        assert_eq!(time.len(), frames, "{name}");
        assert_eq!(time[0], 0.0);
        assert!((time[frames - 1] - 0.2).abs() < 1e-12);
        for member in ["position", "velocity", "desired"] {
            let a: Array3<f64> = npz.by_name(member).unwrap();
            assert_eq!(a.shape(), &[frames, N + 1, 3], "{name}/{member}");
            assert!(a.iter().all(|v| v.is_finite()), "{name}/{member}");
        }
        let d: Array4<f64> = npz.by_name("director").unwrap();
        assert_eq!(d.shape(), &[frames, N, 3, 3]);
        let sigma: Array3<f64> = npz.by_name("sigma").unwrap();
        assert_eq!(sigma.shape(), &[frames, N, 3]);
        let kappa: Array3<f64> = npz.by_name("kappa").unwrap();
        assert_eq!(kappa.shape(), &[frames, N - 1, 3]);
        let target: Array2<f64> = npz.by_name("target").unwrap();
        assert_eq!(target.shape(), &[frames, 3]);
        // A grasp has no tip target (NaN); the others have the target in force.
        assert_eq!(target[[0, 0]].is_nan(), name == "grasp", "{name}");
        if name == "moving-target" {
            assert!((target[[0, 0]] - 0.12).abs() < 1e-12);
            assert!((target[[frames - 1, 0]] - (0.12 - 0.01 * 0.2)).abs() < 1e-12);
        }

        let mut series = NpzReader::new(File::open(dir.join("series.npz")).unwrap()).unwrap();
        let t: Array1<f64> = series.by_name("time").unwrap();
        assert_eq!(t.len(), samples, "{name}");
        let tip: Array2<f64> = series.by_name("tip").unwrap();
        assert_eq!(tip.shape(), &[samples, 3]);
        for member in [
            "distance",
            "hamiltonian",
            "kinetic",
            "shaped_potential",
            "contact_energy",
            "control_force_effort",
            "control_couple_effort",
            "control_power",
            "penetration",
            "design_epoch",
        ] {
            let a: Array1<f64> = series.by_name(member).unwrap();
            assert_eq!(a.len(), samples, "{name}/{member}");
        }
        let spheres: Array2<f64> = series.by_name("obstacles").unwrap();
        let expected_spheres = match name {
            "obstacles" => 2,
            "grasp" => 1,
            _ => 0,
        };
        assert_eq!(spheres.shape(), &[expected_spheres, 4], "{name}");

        let csv = std::fs::read_to_string(dir.join("distance.csv")).unwrap();
        let mut lines = csv.lines();
        assert_eq!(lines.next(), Some("time,distance"));
        let rows: Vec<(f64, f64)> = lines
            .map(|l| {
                let (a, b) = l.split_once(',').unwrap();
                (a.parse().unwrap(), b.parse().unwrap())
            })
            .collect();
        assert_eq!(rows.len(), samples);
        assert_eq!(rows[0].0, 0.0);
        // Normalised by L0: the straight arm's tip is 0.6 L0 (B) to 0.71 L0 (A, C) from its
        // target, and the grasp gap starts at 0.315.
        assert!(
            (0.3..0.75).contains(&rows[0].1),
            "{name}: d(0) = {}",
            rows[0].1
        );

        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap())
                .unwrap();
        assert_eq!(summary["status"], "completed", "{name}");
        assert_eq!(summary["name"], name);
        assert_eq!(summary["controlled"], true);
        // The claims come from the scenario file's [[acceptance]] tables; at 0.2 s the ones
        // about later times are undecided (null).
        let checks = summary["acceptance"].as_array().unwrap();
        assert!(checks.len() >= 2, "{name}: {checks:?}");
        assert!(
            checks.iter().any(|c| c["pass"].is_null()),
            "{name}: {checks:?}"
        );
    }

    let report = std::fs::read_to_string(root.join("report.md")).unwrap();
    for row in [
        "| A two-targets |",
        "| B moving-target |",
        "| C obstacles |",
        "| D grasp |",
    ] {
        assert!(report.contains(row), "{row} missing from\n{report}");
    }
    assert!(report.contains("| experiment | final distance / L0 | settling time [s] | overshoot |"));
    assert!(report.contains("**shortened**"), "{report}");
    assert!(report.contains("undecided"), "{report}");

    // The same scenario through `octoarm run` (single-threaded): identical distances.
    let out = tmp.path().join("run-a");
    let o = octoarm(
        &[
            "run",
            workspace()
                .join("scenarios/paper/two-targets.toml")
                .to_str()
                .unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--duration",
            DURATION,
            "-q",
        ],
        tmp.path(),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        std::fs::read_to_string(out.join("distance.csv")).unwrap(),
        std::fs::read_to_string(root.join("two-targets/distance.csv")).unwrap()
    );

    // A second run replaces the earlier output; a foreign directory is refused (exit 2).
    let foreign = tmp.path().join("foreign");
    std::fs::create_dir(&foreign).unwrap();
    std::fs::write(foreign.join("notes.txt"), "keep").unwrap();
    let o = octoarm(
        &[
            "paper",
            "--out",
            foreign.to_str().unwrap(),
            "--duration",
            "0.01",
        ],
        tmp.path(),
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("not an octoarm output"));
    assert_eq!(
        std::fs::read_to_string(foreign.join("notes.txt")).unwrap(),
        "keep"
    );
}

#[test]
fn controlled_run_without_a_terminal_prints_no_progress_and_quiet_changes_no_output() {
    let tmp = tempfile::tempdir().unwrap();
    let scn = workspace().join("scenarios/paper/two-targets.toml");
    // The full 4 s: about 2 s of stepping on one core, so a bar would have appeared after its
    // 1 s delay.
    let run = |out: &str, quiet: bool| {
        let mut args = vec!["run", scn.to_str().unwrap(), "--out", out];
        if quiet {
            args.push("-q");
        }
        octoarm(&args, tmp.path())
    };
    let loud = run("loud", false);
    assert!(
        loud.status.success(),
        "{}",
        String::from_utf8_lossy(&loud.stderr)
    );
    assert!(
        loud.stderr.is_empty(),
        "stderr is not a terminal: no progress bar, got {:?}",
        String::from_utf8_lossy(&loud.stderr)
    );
    assert!(String::from_utf8_lossy(&loud.stdout).starts_with("wrote loud ("));
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(tmp.path().join("loud/summary.json")).unwrap(),
    )
    .unwrap();
    let stepping = summary["loop_seconds"].as_f64().unwrap();
    assert!(
        stepping > 1.0,
        "the run stepped for {stepping} s, too short for a bar to appear: use a longer scenario"
    );

    let quiet = run("quiet", true);
    assert!(
        quiet.status.success(),
        "{}",
        String::from_utf8_lossy(&quiet.stderr)
    );
    assert!(quiet.stderr.is_empty() && quiet.stdout.is_empty());
    for f in [
        "trajectory.npz",
        "series.npz",
        "distance.csv",
        "scenario.toml",
        "shapes.png",
        "shapes.gif",
        "energy.png",
    ] {
        assert_eq!(
            std::fs::read(tmp.path().join("loud").join(f)).unwrap(),
            std::fs::read(tmp.path().join("quiet").join(f)).unwrap(),
            "{f}"
        );
    }
}

/// Exit codes of `paper`: 0 when every claim passes or is undecided (a shortened run), 3 when
/// every experiment ran but a claim failed — with every output written and the failed claim
/// named on stderr.
#[test]
fn a_failed_acceptance_check_exits_3_with_every_output_written() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scn");
    std::fs::create_dir(&dir).unwrap();
    let base =
        std::fs::read_to_string(workspace().join("scenarios/paper/two-targets.toml")).unwrap();
    std::fs::write(dir.join("two-targets.toml"), &base).unwrap();
    let args = |out: &str| {
        vec![
            "paper".to_string(),
            "-q".into(),
            "--scenarios".into(),
            dir.to_str().unwrap().into(),
            "--duration".into(),
            "0.01".into(),
            "--out".into(),
            out.into(),
        ]
    };
    let run = |out: &str| {
        let a = args(out);
        octoarm(
            &a.iter().map(String::as_str).collect::<Vec<_>>(),
            tmp.path(),
        )
    };
    let o = run("undecided");
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );

    // The arm starts 0.5 L0 or more from its first target: d(5 ms) ≤ 1e-9 fails. The same
    // claim marked `infeasible` is reported as failed but does not count.
    let failing = base
        + "\n[[acceptance]]\nclaim = \"d(5 ms) ≤ 1e-9 (cannot hold)\"\nquantity = \"distance_before\"\n\
           time = 0.005\nmax = 1e-9\n"
        + "\n[[acceptance]]\nclaim = \"d(6 ms) ≤ 1e-9 (marked)\"\nquantity = \"distance_before\"\n\
           time = 0.006\nmax = 1e-9\ninfeasible = true\n";
    std::fs::write(dir.join("two-targets.toml"), failing).unwrap();
    let o = run("failed");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{stderr}");
    assert!(stderr.contains("1 acceptance check(s) failed"), "{stderr}");
    assert!(stderr.contains("d(5 ms) ≤ 1e-9 (cannot hold)"), "{stderr}");
    let out = tmp.path().join("failed");
    for f in [
        "report.md",
        "distance.png",
        "two-targets/trajectory.npz",
        "two-targets/summary.json",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    assert!(!stderr.contains("(marked)"), "{stderr}");
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("**fail**"), "{report}");
    assert!(
        report.contains("**fail** (infeasible as stated)"),
        "{report}"
    );
}
