//! Command-line behaviour, tested by running the built `octoarm` binary: every shipped scenario
//! runs to completion, outputs have the promised names, shapes and units, bad scenarios are
//! rejected with file, line, key and range and leave nothing behind (exit 2), and an unstable
//! run keeps a readable partial trajectory and exits 1.

mod common;
use common::{octoarm, stderr, workspace, TINY};

use ndarray::{Array1, Array2, Array3, Array4};
use ndarray_npy::NpzReader;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::Output;

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

struct Trajectory {
    time: Array1<f64>,
    position: Array3<f64>,
    velocity: Array3<f64>,
    director: Array4<f64>,
    sigma: Array3<f64>,
    kappa: Array3<f64>,
}

fn read_trajectory(dir: &Path) -> Trajectory {
    read_rod(dir, "")
}

/// The arrays of one rod: `prefix` is "" for a lone rod, "<name>/" in a system of rods.
fn read_rod(dir: &Path, prefix: &str) -> Trajectory {
    let mut npz = NpzReader::new(File::open(dir.join("trajectory.npz")).unwrap()).unwrap();
    let names = npz.names().unwrap();
    for required in [
        "position", "velocity", "director", "omega", "sigma", "kappa",
    ] {
        let key = format!("{prefix}{required}");
        assert!(names.contains(&key), "{key} missing from {names:?}");
    }
    let key = |f: &str| format!("{prefix}{f}");
    let omega: Array3<f64> = npz.by_name(&key("omega")).unwrap();
    let t = Trajectory {
        time: npz.by_name("time").unwrap(),
        position: npz.by_name(&key("position")).unwrap(),
        velocity: npz.by_name(&key("velocity")).unwrap(),
        director: npz.by_name(&key("director")).unwrap(),
        sigma: npz.by_name(&key("sigma")).unwrap(),
        kappa: npz.by_name(&key("kappa")).unwrap(),
    };
    assert_eq!(omega.shape(), t.sigma.shape(), "omega is [T, N, 3]");
    assert!(omega.iter().all(|v| v.is_finite()));
    t
}

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

fn check_shapes(t: &Trajectory, n: usize) {
    let frames = t.time.len();
    assert_eq!(t.position.shape(), &[frames, n + 1, 3]);
    assert_eq!(t.velocity.shape(), &[frames, n + 1, 3]);
    assert_eq!(t.director.shape(), &[frames, n, 3, 3]);
    assert_eq!(t.sigma.shape(), &[frames, n, 3]);
    assert_eq!(t.kappa.shape(), &[frames, n - 1, 3]);
    for a in [
        t.position.as_slice().unwrap(),
        t.velocity.as_slice().unwrap(),
        t.sigma.as_slice().unwrap(),
    ] {
        assert!(a.iter().all(|v| v.is_finite()), "non-finite values written");
    }
    assert!(t
        .director
        .iter()
        .chain(t.kappa.iter())
        .all(|v| v.is_finite()));
}

/// No output directory and no temporary directory left in `dir` besides the scenario files.
fn nothing_written(dir: &Path) {
    let left: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !n.ends_with(".toml") && n != "keep")
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

#[test]
fn every_shipped_scenario_runs_to_completion() {
    // Full durations (1-2 s of simulated time each, about a second of wall time each).
    let scenarios: Vec<PathBuf> = std::fs::read_dir(workspace().join("scenarios"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    assert!(scenarios.len() >= 4, "{scenarios:?}");
    let tmp = tempfile::tempdir().unwrap();
    for scn in scenarios {
        let name = scn.file_stem().unwrap().to_string_lossy().into_owned();
        let out = tmp.path().join(&name);
        let o = octoarm(
            &[
                "run",
                scn.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
                "--quiet",
            ],
            tmp.path(),
        );
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        for f in [
            "trajectory.npz",
            "summary.json",
            "scenario.toml",
            "shapes.png",
            "energy.png",
        ] {
            assert!(out.join(f).is_file(), "{name}: {f} missing");
        }
        let s = summary(&out);
        assert_eq!(s["status"], "completed", "{name}");
        let rods = s["rods"].as_array().unwrap();
        let multi = rods.len() > 1;
        let mut t = None;
        for rod in rods {
            let prefix = if multi {
                format!("{}/", rod["name"].as_str().unwrap())
            } else {
                String::new()
            };
            let n = s["arrays"][format!("{prefix}director")]["shape"][1]
                .as_u64()
                .unwrap() as usize;
            assert_eq!(rod["n_elements"].as_u64().unwrap() as usize, n);
            let tr = read_rod(&out, &prefix);
            check_shapes(&tr, n);
            assert_eq!(rod["final_tip_position"].as_array().unwrap().len(), 3);
            t = Some(tr);
        }
        let t = t.unwrap();
        assert_eq!(t.time[0], 0.0);
        let steps = s["steps"].as_u64().unwrap();
        assert_eq!(steps, s["planned_steps"].as_u64().unwrap());
        assert!((t.time[t.time.len() - 1] - s["simulated_seconds"].as_f64().unwrap()).abs() < 1e-9);
        assert_eq!(s["version"], env!("CARGO_PKG_VERSION"));
        assert!(s["us_per_step"].as_f64().unwrap() > 0.0);
        if !multi {
            assert_eq!(s["final_tip_position"].as_array().unwrap().len(), 3);
        }
    }
}

#[test]
fn tip_force_moves_the_tip_toward_plus_y() {
    let tmp = tempfile::tempdir().unwrap();
    let scn = workspace().join("scenarios/arm_tip_force.toml");
    let o = octoarm(
        &[
            "run",
            scn.to_str().unwrap(),
            "--out",
            "out",
            "--duration",
            "0.3",
            "-q",
        ],
        tmp.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let t = read_trajectory(&tmp.path().join("out"));
    let last = t.time.len() - 1;
    assert_eq!(t.position[[0, 100, 1]], 0.0);
    assert!(
        t.position[[last, 100, 1]] > 1e-3,
        "tip y = {}",
        t.position[[last, 100, 1]]
    );
    // The base stays clamped at the origin.
    assert_eq!(t.position[[last, 0, 0]], 0.0);
    assert_eq!(t.position[[last, 0, 1]], 0.0);
}

#[test]
fn frames_are_sampled_by_simulated_time_including_start_and_end() {
    let tmp = tempfile::tempdir().unwrap();
    // 0.0505 s: frames every 1 ms plus the final state at 50.5 ms.
    write(
        tmp.path(),
        "s.toml",
        &TINY.replace("duration = 0.05", "duration = 0.0505"),
    );
    let o = octoarm(&["run", "s.toml", "--out", "out", "-q"], tmp.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let t = read_trajectory(&tmp.path().join("out"));
    check_shapes(&t, 10);
    assert_eq!(t.time.len(), 52);
    assert!((t.time[1] - 1e-3).abs() < 1e-12);
    assert!((t.time[51] - 0.0505).abs() < 1e-12);
    // sigma is the shear/stretch strain: zero at rest.
    assert!(t
        .sigma
        .index_axis(ndarray::Axis(0), 0)
        .iter()
        .all(|v| v.abs() < 1e-12));
}

#[test]
fn default_output_is_results_slash_scenario_name_and_reruns_are_identical() {
    let tmp = tempfile::tempdir().unwrap();
    write(tmp.path(), "tiny.toml", TINY);
    let o = octoarm(&["run", "tiny.toml", "-q"], tmp.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let out = tmp.path().join("results/tiny");
    let first = std::fs::read(out.join("trajectory.npz")).unwrap();
    // The resolved scenario repeats the run bit for bit, and replaces the earlier output whole.
    std::fs::copy(out.join("scenario.toml"), tmp.path().join("resolved.toml")).unwrap();
    let o = octoarm(
        &["run", "resolved.toml", "--out", "results/tiny", "-q"],
        tmp.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(first, std::fs::read(out.join("trajectory.npz")).unwrap());
    let names: Vec<_> = std::fs::read_dir(tmp.path().join("results"))
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 1, "temporary directories left: {names:?}");
}

#[test]
fn check_prints_stable_dt_and_steps_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let scn = workspace().join("scenarios/arm_tip_force.toml");
    let o = octoarm(&["check", scn.to_str().unwrap()], tmp.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(text.contains("stable dt: 1.969e-4 s"), "{text}");
    assert!(text.contains("steps: 200000"), "{text}");
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 0);
}

#[test]
fn help_describes_commands_and_exit_codes() {
    let tmp = tempfile::tempdir().unwrap();
    let o = octoarm(&["--help"], tmp.path());
    let text = stdout(&o);
    for needle in ["run", "check", "--quiet", "--verbose", "Exit codes"] {
        assert!(text.contains(needle), "{needle} not in {text}");
    }
    let o = octoarm(&["run", "--help"], tmp.path());
    let text = stdout(&o);
    for needle in ["--out", "--duration", "results/", "trajectory.npz"] {
        assert!(text.contains(needle), "{needle} not in {text}");
    }
}

/// One bad input: the scenario text (or None to use TINY), extra args, and what stderr must say.
fn rejects(name: &str, text: &str, args: &[&str], expected: &[&str]) {
    let tmp = tempfile::tempdir().unwrap();
    write(tmp.path(), "bad.toml", text);
    let mut all = vec!["run", "bad.toml", "--out", "out"];
    all.extend_from_slice(args);
    let o = octoarm(&all, tmp.path());
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{name}: {err}");
    assert!(err.starts_with("error: "), "{name}: {err}");
    for e in expected {
        assert!(err.contains(e), "{name}: expected {e:?} in {err:?}");
    }
    nothing_written(tmp.path());
}

#[test]
fn unknown_key_names_the_nearest_valid_key() {
    rejects(
        "unknown key",
        &TINY.replace("density", "densty"),
        &[],
        &[
            "bad.toml:7:1: unknown key `densty` in [rod]; did you mean `density`?",
            "allowed: name, n_elements, length",
        ],
    );
}

#[test]
fn unknown_section_names_the_nearest_valid_section() {
    rejects(
        "unknown section",
        &TINY.replace("[damping]", "[dampng]"),
        &[],
        &[
            "bad.toml:",
            "unknown section [dampng]; did you mean `damping`?",
        ],
    );
}

#[test]
fn unknown_load_kind_names_the_nearest_valid_kind() {
    rejects(
        "unknown kind",
        &TINY.replace("\"tip_force\"", "\"tip_forse\""),
        &[],
        &[
            "bad.toml:20:8:",
            "unknown kind \"tip_forse\"; did you mean `tip_force`?",
            "gravity, tip_force, node_force, uniform_force, tip_couple",
        ],
    );
}

#[test]
fn negative_length_names_line_key_and_range() {
    rejects(
        "negative",
        &TINY.replace("length = 0.2", "length = -0.2"),
        &[],
        &["bad.toml:4:1: rod.length = -0.2 is outside the allowed range (0, inf), finite"],
    );
}

#[test]
fn nan_is_out_of_range() {
    rejects(
        "nan",
        &TINY.replace("density = 700.0", "density = nan"),
        &[],
        &["bad.toml:7:1: rod.density = NaN is outside the allowed range (0, inf)"],
    );
}

#[test]
fn too_few_elements() {
    rejects(
        "n_elements",
        &TINY.replace("n_elements = 10", "n_elements = 1"),
        &[],
        &["bad.toml:3:1: rod.n_elements = 1 is outside the allowed range [2, 100000]"],
    );
}

#[test]
fn wrong_type_names_the_key() {
    rejects(
        "type",
        &TINY.replace("length = 0.2", "length = \"long\""),
        &[],
        &[
            "bad.toml:4:",
            "rod.length",
            "invalid type: string \"long\", expected f64",
        ],
    );
}

#[test]
fn missing_key_is_named_with_its_section() {
    rejects(
        "missing",
        &TINY.replace("dt = 1.0e-4\n", ""),
        &[],
        &["bad.toml:", "missing required key `dt` in [time]"],
    );
}

#[test]
fn missing_section_is_named() {
    let text = TINY.split("[time]").next().unwrap().to_string();
    rejects("no [time]", &text, &[], &["bad.toml:", "`time`"]);
}

#[test]
fn normal_must_be_perpendicular_to_direction() {
    rejects(
        "normal",
        &TINY.replace("[time]", "normal = [1.0, 1.0, 0.0]\n\n[time]"),
        &[],
        &["bad.toml:11:1: rod.normal = [1, 1, 0] is outside the allowed range of vectors perpendicular to rod.direction"],
    );
}

#[test]
fn save_interval_below_dt() {
    rejects("save_interval", &TINY.replace("save_interval = 1.0e-3", "save_interval = 1.0e-5"), &[], &["bad.toml:14:1: time.save_interval = 0.00001 is outside the allowed range [time.dt = 1e-4, inf)"]);
}

#[test]
fn ramp_time_must_be_non_negative_and_exclusive_with_a_schedule() {
    let text = format!(
        "{TINY}\n[[load]]\nkind = \"gravity\"\nvalue = [0.0, -9.81, 0.0]\nramp_time = -0.1\n"
    );
    rejects(
        "ramp",
        &text,
        &[],
        &["bad.toml:26:1: load[1].ramp_time = -0.1 is outside the allowed range [0, inf)"],
    );
    let text = format!(
        "{TINY}\n[[load]]\nkind = \"gravity\"\nvalue = [0.0, -9.81, 0.0]\nramp_time = 0.1\nschedule = {{ kind = \"step\", time = 0.5 }}\n"
    );
    rejects(
        "ramp and schedule",
        &text,
        &[],
        &["load[1].ramp_time: give either ramp_time or schedule, not both"],
    );
    let text = format!(
        "{TINY}\n[[load]]\nkind = \"gravity\"\nvalue = [0.0, -9.81, 0.0]\nschedule = {{ kind = \"ramp\" }}\n"
    );
    rejects(
        "ramp without duration",
        &text,
        &[],
        &["load[1].schedule.duration: missing: kind = \"ramp\" needs it"],
    );
}

#[test]
fn obstacle_diameter_must_be_positive() {
    let text = format!(
        "{TINY}\n[[obstacle]]\nkind = \"sphere\"\ncenter = [0.1, 0.1, 0.0]\ndiameter = 0.0\n"
    );
    rejects(
        "diameter",
        &text,
        &[],
        &["bad.toml:26:1: obstacle[0].diameter = 0 is outside the allowed range (0, inf)"],
    );
}

#[test]
fn toml_syntax_error_gives_the_line() {
    rejects(
        "syntax",
        &TINY.replace("value = [0.0, 1.0e-4, 0.0]", "value = [0.0, 1.0e-4, 0.0"),
        &[],
        &["bad.toml:22:1: invalid array: expected `]`"],
    );
}

#[test]
fn duration_override_is_validated() {
    rejects(
        "duration",
        TINY,
        &["--duration=-1"],
        &["--duration -1: time.duration = -1 is outside the allowed range [time.dt = 1e-4, inf)"],
    );
}

#[test]
fn missing_file_is_reported() {
    let tmp = tempfile::tempdir().unwrap();
    let o = octoarm(&["run", "nope.toml"], tmp.path());
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("nope.toml: cannot read the scenario file"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 0);
}

#[test]
fn refuses_to_replace_a_directory_that_is_not_an_output() {
    let tmp = tempfile::tempdir().unwrap();
    write(tmp.path(), "s.toml", TINY);
    std::fs::create_dir(tmp.path().join("keep")).unwrap();
    write(&tmp.path().join("keep"), "notes.txt", "mine");
    let o = octoarm(&["run", "s.toml", "--out", "keep"], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("is not an octoarm output") && stderr(&o).contains("notes.txt"),
        "{}",
        stderr(&o)
    );
    assert_eq!(
        std::fs::read_to_string(tmp.path().join("keep/notes.txt")).unwrap(),
        "mine"
    );
    nothing_written(tmp.path());
}

#[test]
fn a_bad_scenario_leaves_an_earlier_output_untouched() {
    let tmp = tempfile::tempdir().unwrap();
    write(tmp.path(), "s.toml", TINY);
    assert!(
        octoarm(&["run", "s.toml", "--out", "out", "-q"], tmp.path())
            .status
            .success()
    );
    let before = std::fs::read(tmp.path().join("out/trajectory.npz")).unwrap();
    write(
        tmp.path(),
        "s.toml",
        &TINY.replace("length = 0.2", "length = 0"),
    );
    let o = octoarm(&["run", "s.toml", "--out", "out"], tmp.path());
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(
        before,
        std::fs::read(tmp.path().join("out/trajectory.npz")).unwrap()
    );
}

#[test]
fn unstable_dt_keeps_a_readable_partial_trajectory_and_exits_1() {
    let tmp = tempfile::tempdir().unwrap();
    // Stable limit of this rod is ~1.8e-3 s... use a dt far above it and record every step.
    let text = TINY
        .replace("dt = 1.0e-4", "dt = 4.0e-3")
        .replace("duration = 0.05", "duration = 2.0")
        .replace("save_interval = 1.0e-3", "save_interval = 4.0e-3");
    write(tmp.path(), "s.toml", &text);
    let o = octoarm(&["run", "s.toml", "--out", "out"], tmp.path());
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("exceeds this rod's stable limit"),
        "warning expected: {err}"
    );
    assert!(err.contains("error: unstable:"), "{err}");
    assert!(err.contains("frames recorded before the failure"), "{err}");
    let out = tmp.path().join("out");
    let t = read_trajectory(&out);
    check_shapes(&t, 10);
    assert!(!t.time.is_empty());
    let s = summary(&out);
    assert_eq!(s["status"], "unstable");
    let f = &s["failure"];
    assert!(f["time"].as_f64().unwrap() > 0.0);
    assert!(f["element"].as_u64().unwrap() < 10);
    let suggested = f["suggested_dt"].as_f64().unwrap();
    assert!(suggested > 0.0 && suggested < 4.0e-3);
    assert_eq!(s["frames"].as_u64().unwrap() as usize, t.time.len());
    assert!(s["steps"].as_u64().unwrap() < s["planned_steps"].as_u64().unwrap());
    for f in ["scenario.toml", "shapes.png", "energy.png"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
}

#[test]
fn paper_arm_cannot_carry_2e_4_newton_and_stops_with_the_instability_error() {
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(workspace().join("scenarios/arm_tip_force.toml"))
        .unwrap()
        .replace("value = [0.0, 2.0e-5, 0.0]", "value = [0.0, 2.0e-4, 0.0]");
    write(tmp.path(), "heavy.toml", &text);
    let o = octoarm(
        &["run", "heavy.toml", "--out", "out", "--duration", "0.2"],
        tmp.path(),
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("no equilibrium"), "{}", stderr(&o));
    let t = read_trajectory(&tmp.path().join("out"));
    check_shapes(&t, 100);
    let _: Array2<f64> = t.position.index_axis(ndarray::Axis(0), 0).to_owned();
}

/// A run's `trajectory.npz` members as raw bytes, by name.
fn npz_bytes(dir: &Path) -> Vec<(String, Vec<u8>)> {
    use std::io::Read;
    let mut zip = zip::ZipArchive::new(File::open(dir.join("trajectory.npz")).unwrap()).unwrap();
    (0..zip.len())
        .map(|i| {
            let mut m = zip.by_index(i).unwrap();
            let mut b = Vec::new();
            m.read_to_end(&mut b).unwrap();
            (m.name().to_string(), b)
        })
        .collect()
}

fn run_ok(dir: &Path, name: &str, text: &str) -> PathBuf {
    write(dir, &format!("{name}.toml"), text);
    let o = octoarm(&["run", "-q", &format!("{name}.toml"), "--out", name], dir);
    assert!(o.status.success(), "{name}: {}", stderr(&o));
    dir.join(name)
}

#[test]
fn loads_placed_by_arc_length_and_by_index_are_the_same_load() {
    let tmp = tempfile::tempdir().unwrap();
    let tip = run_ok(tmp.path(), "tip", TINY);
    let by_s = run_ok(
        tmp.path(),
        "by_s",
        &TINY.replace("kind = \"tip_force\"", "kind = \"node_force\"\ns = 0.2"),
    );
    let by_index = run_ok(
        tmp.path(),
        "by_index",
        &TINY.replace("kind = \"tip_force\"", "kind = \"node_force\"\nnode = 10"),
    );
    assert_eq!(npz_bytes(&tip), npz_bytes(&by_s));
    assert_eq!(npz_bytes(&tip), npz_bytes(&by_index));
    // An arc length off the rod names the range.
    rejects(
        "s off the rod",
        &TINY.replace("kind = \"tip_force\"", "kind = \"node_force\"\ns = 0.3"),
        &[],
        &["load[0].s = 0.3 is outside the allowed range [0, 0.2] m"],
    );
}

#[test]
fn rest_curvature_as_a_function_of_arc_length_equals_the_uniform_value() {
    let tmp = tempfile::tempdir().unwrap();
    let base = TINY.replace(
        "[[load]]\nkind = \"tip_force\"\nvalue = [0.0, 1.0e-4, 0.0]\n",
        "",
    );
    let uniform = run_ok(
        tmp.path(),
        "uniform",
        &base.replace(
            "shear_modulus = 1.0e3",
            "shear_modulus = 1.0e3\nrest_curvature = [0.0, 5.0, 0.0]",
        ),
    );
    let function = run_ok(
        tmp.path(),
        "function",
        &base.replace(
            "shear_modulus = 1.0e3",
            "shear_modulus = 1.0e3\nrest_kappa = { s = [0.0, 0.2], value = [[0.0, 5.0, 0.0], [0.0, 5.0, 0.0]] }",
        ),
    );
    assert_eq!(npz_bytes(&uniform), npz_bytes(&function));
    rejects(
        "per-entry length",
        &base.replace(
            "shear_modulus = 1.0e3",
            "shear_modulus = 1.0e3\nrest_kappa = [[0.0, 5.0, 0.0], [0.0, 5.0, 0.0]]",
        ),
        &[],
        &["rod.rest_kappa = 2 vectors is outside the allowed range of exactly 9 vectors"],
    );
}

#[test]
fn joints_and_rods_are_referenced_by_name_with_errors_naming_the_choices() {
    let rod = |name: &str, extra: &str| {
        format!(
            "[[rod]]\nname = \"{name}\"\nn_elements = 10\nlength = 0.1\nbase_diameter = 0.01\n\
             density = 1000.0\nyoungs_modulus = 1.0e5\nshear_modulus = 4.0e4\n{extra}\n"
        )
    };
    let text = format!(
        "{}{}[time]\ndt = 2.0e-5\nduration = 0.02\n\n[[joint]]\nkind = \"fixed\"\nfirst = \"a.tip\"\nsecond = \"b.base\"\n",
        rod("a", ""),
        rod("b", "base_position = [0.1, 0.0, 0.0]\nbase = \"free\""),
    );
    let tmp = tempfile::tempdir().unwrap();
    let out = run_ok(tmp.path(), "joined", &text);
    let names: Vec<String> = npz_bytes(&out).into_iter().map(|(n, _)| n).collect();
    for key in [
        "time.npy",
        "a/position.npy",
        "b/omega.npy",
        "b/energy_bend.npy",
    ] {
        assert!(
            names.iter().any(|n| n == key),
            "{key} missing from {names:?}"
        );
    }
    rejects(
        "joint end",
        &text.replace("second = \"b.base\"", "second = \"c.base\""),
        &[],
        &[
            "joint[0].second = \"c.base\" is outside the allowed range of ends of the rods \"a\", \"b\"",
        ],
    );
    rejects(
        "joint side",
        &text.replace("second = \"b.base\"", "second = \"b.middle\""),
        &[],
        &["of the form \"<rod name>.base\" or \"<rod name>.tip\""],
    );
    rejects(
        "load without a rod",
        &format!("{text}\n[[load]]\nkind = \"tip_force\"\nvalue = [0.0, 1.0e-4, 0.0]\n"),
        &[],
        &["load[0].rod: missing: with several rods, name one of \"a\", \"b\""],
    );
    rejects(
        "duplicate names",
        &text.replace("name = \"b\"", "name = \"a\""),
        &[],
        &["rod[1].name = \"a\" is outside the allowed range of names not used by another rod"],
    );
}

#[test]
fn a_controlled_run_accepts_loads_per_length_damping_numerics_and_moving_obstacles() {
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(workspace().join("scenarios/paper/two-targets.toml"))
        .unwrap()
        .replace("duration = 4.0", "duration = 0.02")
        .replace("rate = 10.0 ", "rate = 10.0\ngamma = 0.001 ")
        + "\n[numerics]\nguard_interval = 50\nenergy_consistent = true\n\
           \n[[load]]\nkind = \"gravity\"\nvalue = [0.0, -0.1, 0.0]\n\
           \n[[obstacle]]\nkind = \"sphere\"\ncenter = [0.1, -0.05, 0.0]\ndiameter = 0.02\nvelocity = [0.0, 0.1, 0.0]\n";
    let out = run_ok(tmp.path(), "controlled", &text);
    let s = summary(&out);
    assert_eq!(s["status"], "completed");
    assert_eq!(s["controlled"], true);
    assert!(out.join("distance.csv").is_file() && out.join("series.npz").is_file());
    assert!(s["control"]["final_distance"].as_f64().unwrap().is_finite());
}

#[test]
fn pyelastica_damping_protocol_has_one_rate() {
    rejects(
        "protocol",
        &TINY.replace(
            "rate = 10.0",
            "rate = 10.0\ngamma = 0.01\nprotocol = \"pyelastica\"",
        ),
        &[],
        &["damping.gamma = 0.01 is outside the allowed range of 0 with protocol = \"pyelastica\""],
    );
}

#[test]
fn initial_state_errors_name_the_file_and_the_mismatch() {
    let tmp = tempfile::tempdir().unwrap();
    run_ok(tmp.path(), "first", TINY);
    rejects(
        "missing file",
        &format!("{TINY}\n[initial_state]\nfile = \"nowhere/trajectory.npz\"\n"),
        &[],
        &["initial_state.file: cannot open", "nowhere/trajectory.npz"],
    );
    // Same folder layout as `rejects` uses: the earlier run is copied beside bad.toml.
    let twenty = TINY.replace("n_elements = 10", "n_elements = 20");
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "a.toml", TINY);
    let o = octoarm(&["run", "-q", "a.toml", "--out", "a"], dir.path());
    assert!(o.status.success());
    write(
        dir.path(),
        "b.toml",
        &format!("{twenty}\n[initial_state]\nfile = \"a/trajectory.npz\"\nframe = 3\n"),
    );
    let o = octoarm(&["run", "b.toml", "--out", "b"], dir.path());
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(
            "`position` has frames of shape [11, 3]; rod \"rod\" with 20 elements needs [21, 3]"
        ),
        "{}",
        stderr(&o)
    );
    assert!(!dir.path().join("b").exists());
    write(
        dir.path(),
        "c.toml",
        &format!("{TINY}\n[initial_state]\nfile = \"a/trajectory.npz\"\nframe = 99\n"),
    );
    let o = octoarm(&["run", "c.toml", "--out", "c"], dir.path());
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("initial_state.frame: 99 is outside the allowed range [-51, 50]"),
        "{}",
        stderr(&o)
    );
}
