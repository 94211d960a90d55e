//! `octoarm paper --suite muscles` (muscles-3d spec §7) end to end, **reduced**: the four
//! scenario files of `scenarios/muscles/` with N = 20 elements, 0.05 s of dynamics and a few
//! design iterations, so that it runs in CI time. Claims: every promised file exists in every
//! folder with its shape (`activations.npy` [7, N], `design_pose.npz`, `series.npz` every
//! 10 ms with tip error, θ_Q and 𝓗, `design.json`, `design.png`); the design claims are decided
//! and the claims about later times are undecided; report.md has one row per experiment and the
//! acceptance table; a grasp run records the gaps; the planar case stays in its plane.
//! The full-length acceptance numbers are checked by `full_length_acceptance` (ignored: run it
//! in release, `cargo test --release -p octoarm --test muscles_suite -- --ignored`).

use ndarray::{Array1, Array2, Array3};
use ndarray_npy::{NpzReader, ReadNpyExt};
use octoarm::paper;
use octoarm::progress::Progress;
use std::fs::File;

#[test]
fn reduced_muscle_suite_writes_every_output() {
    let n = 20;
    let mut scenarios = paper::muscle_scenarios(Some(0.05)).unwrap();
    for scn in &mut scenarios {
        let c = &mut scn.config;
        c.rods.list[0].n_elements = n;
        let mc = c.muscle_control.as_mut().unwrap();
        mc.max_iterations = 8;
        mc.stages = 2;
        c.validate().unwrap();
    }
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("muscles");
    let _lock = paper::prepare_root(&root).unwrap();
    let report = paper::run_paper(
        &scenarios,
        &root,
        2,
        true,
        false,
        &Progress::new(false),
        None,
    )
    .unwrap();
    assert!(report.all_ok());
    let text = std::fs::read_to_string(root.join("report.md")).unwrap();
    assert!(text.contains("muscles-3d spec §7"), "{text}");
    // Columns that do not apply (a grasp's tip target, a point reach's frame) read "—", never a
    // number the run did not measure.
    assert!(
        !text.contains("NaN") && !text.contains("0.00e0"),
        "report.md prints values for columns that do not apply: {text}"
    );
    for name in ["reach", "reach-rolled", "grasp", "planar"] {
        assert!(text.contains(&format!(" {name} |")), "{name} row: {text}");
        let dir = root.join(name);
        for f in [
            "trajectory.npz",
            "series.npz",
            "activations.npy",
            "design_pose.npz",
            "design.json",
            "design.png",
            "shapes.png",
            "summary.json",
            "scenario.toml",
        ] {
            assert!(dir.join(f).is_file(), "{name}/{f} missing");
        }
        let a = Array2::<f64>::read_npy(File::open(dir.join("activations.npy")).unwrap()).unwrap();
        assert_eq!(a.shape(), &[7, n]);
        assert!(
            a.iter().all(|v| (0.0..=1.0).contains(v)),
            "{name}: a in [0, 1]"
        );
        assert!(
            a.iter().any(|v| *v > 0.0),
            "{name}: the design activates something"
        );
        let mut pose = NpzReader::new(File::open(dir.join("design_pose.npz")).unwrap()).unwrap();
        let p: Array2<f64> = pose.by_name("position").unwrap();
        assert_eq!(p.shape(), &[n + 1, 3]);
        let q: Array3<f64> = pose.by_name("director").unwrap();
        assert_eq!(q.shape(), &[n, 3, 3]);
        let mut series = NpzReader::new(File::open(dir.join("series.npz")).unwrap()).unwrap();
        let t: Array1<f64> = series.by_name("time").unwrap();
        // 0.05 s every 10 ms: 0, 0.01, ..., 0.05.
        assert_eq!(t.len(), 6, "{name}");
        assert!((t[5] - 0.05).abs() < 1e-12);
        let h: Array1<f64> = series.by_name("hamiltonian").unwrap();
        assert!(h.iter().all(|v| v.is_finite()), "{name}: 𝓗 finite");
        let e: Array1<f64> = series.by_name("tip_error").unwrap();
        if name == "grasp" {
            assert!(e.iter().all(|v| v.is_nan()), "a grasp has no tip target");
            let g: Array1<f64> = series.by_name("wrap_angle").unwrap();
            assert!(g.iter().all(|v| v.is_finite()));
        } else {
            // The arm starts straight: the tip error at t = 0 is the straight tip's distance.
            assert!(e[0] > 0.3 && e.iter().all(|v| v.is_finite()), "{name}: {e}");
        }
        let summary: serde_json::Value =
            serde_json::from_reader(File::open(dir.join("summary.json")).unwrap()).unwrap();
        assert_eq!(summary["status"], "completed");
        assert_eq!(
            summary["controlled"], true,
            "{name}: a muscle run is controlled"
        );
        let checks = summary["acceptance"].as_array().unwrap();
        assert!(!checks.is_empty());
        for c in checks {
            let claim = c["claim"].as_str().unwrap();
            let result = c["result"].as_str().unwrap();
            if claim.starts_with("design") || claim.starts_with("all activations") {
                assert_ne!(result, "undecided", "{name}: {claim}");
            }
            if claim.contains("15 s") || claim.contains("Lyapunov") || claim.contains("0.5 s") {
                assert_eq!(result, "undecided", "{name}: {claim} in a 0.05 s run");
            }
        }
        if name == "planar" {
            // Group mask: the out-of-plane groups stay at zero and the pose in the x–z plane.
            for g in [2, 4, 5, 6] {
                assert!(a.row(g).iter().all(|v| *v == 0.0), "group {g} masked");
            }
            assert!(
                p.column(1).iter().all(|y| y.abs() <= 1e-15),
                "y of the planar design"
            );
        }
    }
}

/// Spec §7 claims octoarm knowingly misses today (measured, docs/muscles.md "Known misses"):
/// (experiment, claim). Each must still be decided and **fail**, so that a change which meets
/// it shows up here and the entry is removed. The spec's numbers are not changed.
/// (The design misses of an earlier solver — A's LM2 integral and the planar tip error within
/// 150 iterations — are met since the analytic-Jacobian solver with its interpolating line
/// search; their entries were removed when this test reported them passing.)
/// * `reach`, 15 s (full length only): the creep is slower than COOMM's; tip error 1.09e-2 L0
///   and node deviation 1.10e-2 L0 at 15 s against 1e-2 (0.05 L0 reached at 13.2 s).
const KNOWN_DEVIATIONS: [(&str, &str); 2] = [
    ("reach", "tip-point error at 15 s ≤ 1e-2 L0"),
    (
        "reach",
        "every node within 0.01 L0 of the design pose at 15 s",
    ),
];

/// The acceptance checks of `dir/summary.json` as (claim, result).
fn checks_of(dir: &std::path::Path) -> Vec<(String, String)> {
    let summary: serde_json::Value =
        serde_json::from_reader(File::open(dir.join("summary.json")).unwrap()).unwrap();
    summary["acceptance"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            (
                c["claim"].as_str().unwrap().to_string(),
                c["result"].as_str().unwrap().to_string(),
            )
        })
        .collect()
}

/// Every claim passes except the known deviations, which fail; `undecided_ok` admits undecided
/// claims (a shortened run).
fn assert_claims(name: &str, dir: &std::path::Path, undecided_ok: bool) {
    let mut wrong = Vec::new();
    for (claim, result) in checks_of(dir) {
        let deviation = KNOWN_DEVIATIONS.contains(&(name, claim.as_str()));
        match result.as_str() {
            "pass" if deviation => wrong.push(format!(
                "{name}: {claim} passes now: remove it from KNOWN_DEVIATIONS"
            )),
            "fail" if !deviation => wrong.push(format!("{name}: {claim} fails")),
            "pass" | "fail" => {}
            _ if !undecided_ok => {
                wrong.push(format!("{name}: {claim} undecided in a full-length run"))
            }
            _ => {}
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// The twist Σ D̂ κ₃ of `dir/design.json`.
fn twist_of(dir: &std::path::Path) -> f64 {
    let d: serde_json::Value =
        serde_json::from_reader(File::open(dir.join("design.json")).unwrap()).unwrap();
    d["twist"].as_f64().unwrap()
}

/// Every **design** acceptance number of spec §7 (A, B, C and the planar case) at full size:
/// N = 100, the scenarios' own iteration limits and continuation, from a = 0; the dynamics cut
/// to 0.02 s (their claims about 15 s are then undecided; the full-length dynamics are
/// `full_length_acceptance`). Plus B's twist against A's (spec §7 B: ≥ 1 rad apart). The
/// faithful shorter check that CI runs (≈ 1 min with the test profile's optimisation).
#[test]
fn full_designs_meet_section_7_bounds() {
    let scenarios = paper::muscle_scenarios(Some(0.02)).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("muscles");
    let _lock = paper::prepare_root(&root).unwrap();
    let report = paper::run_paper(
        &scenarios,
        &root,
        2,
        false,
        false,
        &Progress::new(false),
        None,
    )
    .unwrap();
    assert!(report.all_ok());
    for name in ["reach", "reach-rolled", "grasp", "planar"] {
        let dir = root.join(name);
        assert_claims(name, &dir, true);
        for (claim, result) in checks_of(&dir) {
            if claim.starts_with("design")
                || claim.starts_with("all activations")
                || claim.starts_with("∫")
                || claim.starts_with("equilibrium")
                || claim.starts_with("max D")
                || claim.starts_with("pose")
            {
                assert_ne!(result, "undecided", "{name}: {claim}");
            }
        }
    }
    let (a, b) = (
        twist_of(&root.join("reach")),
        twist_of(&root.join("reach-rolled")),
    );
    assert!((a - b).abs() >= 1.0, "twist A {a} vs B {b}");
    assert_planar_pose(&root.join("planar"));
}

/// Spec §7 planar case: the design pose lies exactly in the x–z plane, |y_i| ≤ 1e-15 m, and
/// |κ₁|, |κ₃| ≤ 1e-12 1/m, with κ_k = −Log(Q_{k+1} Q_kᵀ)/D̂_k from the recorded directors
/// (uniform elements: D̂ = L0/N).
fn assert_planar_pose(dir: &std::path::Path) {
    let mut pose = NpzReader::new(File::open(dir.join("design_pose.npz")).unwrap()).unwrap();
    let p: Array2<f64> = pose.by_name("position").unwrap();
    let q: Array3<f64> = pose.by_name("director").unwrap();
    let n = q.shape()[0];
    assert!(
        p.column(1).iter().all(|y| y.abs() <= 1e-15),
        "y of the planar design"
    );
    let d_hat = 0.2 / n as f64;
    for k in 0..n - 1 {
        // R = Q_{k+1} Q_kᵀ and its axis–angle logarithm.
        let r: [[f64; 3]; 3] = std::array::from_fn(|i| {
            std::array::from_fn(|j| (0..3).map(|m| q[[k + 1, i, m]] * q[[k, j, m]]).sum())
        });
        let theta = ((r[0][0] + r[1][1] + r[2][2] - 1.0) / 2.0)
            .clamp(-1.0, 1.0)
            .acos();
        let vee = [r[2][1] - r[1][2], r[0][2] - r[2][0], r[1][0] - r[0][1]];
        let f = if theta > 1e-8 {
            theta / (2.0 * theta.sin())
        } else {
            0.5
        };
        let (k1, k3) = (f * vee[0] / d_hat, f * vee[2] / d_hat);
        assert!(
            k1.abs() <= 1e-12 && k3.abs() <= 1e-12,
            "κ₁ {k1:e}, κ₃ {k3:e} at {k}"
        );
    }
}

/// Every acceptance number of spec §7 at full length (15 s runs, full designs): ≈ 10 min in
/// release on two cores (each 15 s run is 1.5e6 steps at ≈ 30–40 µs), so not in CI; run it with
/// `cargo test --release -p octoarm --test muscles_suite -- --ignored`.
#[test]
#[ignore]
fn full_length_acceptance() {
    let scenarios = paper::muscle_scenarios(None).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("muscles");
    let _lock = paper::prepare_root(&root).unwrap();
    let report = paper::run_paper(
        &scenarios,
        &root,
        2,
        false,
        false,
        &Progress::new(false),
        None,
    )
    .unwrap();
    let text = std::fs::read_to_string(root.join("report.md")).unwrap();
    eprintln!("{text}");
    assert!(report.all_ok(), "{text}");
    for name in ["reach", "reach-rolled", "grasp", "planar"] {
        assert_claims(name, &root.join(name), false);
    }
    let (a, b) = (
        twist_of(&root.join("reach")),
        twist_of(&root.join("reach-rolled")),
    );
    assert!((a - b).abs() >= 1.0, "twist A {a} vs B {b}");
    assert_planar_pose(&root.join("planar"));
}

/// `[muscles]` builds COOMM's muscles on the rod, its drag, its damping preset and, when asked,
/// the net weight (ρ − ρ_w) g per unit volume along −e_z; bad input is named.
#[test]
fn muscles_section_builds_the_arm_in_water() {
    use octoarm::scenario::Scenario;
    use octoarm_physics::{AnalyticalDamper, Load};
    let text = paper::MUSCLE_SCENARIOS[0].1.replace(
        "damping = \"coomm\"",
        "damping = \"coomm\"\nnet_weight = true",
    );
    let scn = Scenario::from_str(std::path::Path::new("reach.toml"), &text).unwrap();
    let (system, _) = octoarm::build::build_system(&scn).unwrap();
    let rod = system.rod(0);
    assert_eq!(rod.muscles.as_ref().unwrap().n_elements(), 100);
    match rod.damping.analytical {
        Some(AnalyticalDamper::Rates {
            translational,
            rotational,
        }) => {
            assert!((translational - 0.10526).abs() < 1e-5, "{translational}");
            assert!((rotational[0] - 2923.9).abs() < 0.1 && (rotational[2] - 1461.96).abs() < 0.1);
        }
        d => panic!("damping {d:?}"),
    }
    let loads = system.loads();
    assert!(loads.iter().any(|l| matches!(l.load, Load::Drag { .. })));
    let g = loads
        .iter()
        .find_map(|l| match l.load {
            Load::Gravity { acceleration } => Some(acceleration),
            _ => None,
        })
        .expect("the net weight");
    assert!((g[2] + 9.81 * (1.0 - 1022.0 / 1050.0)).abs() < 1e-12 && g[0] == 0.0 && g[1] == 0.0);
    // water_density and gravity set the net weight: g (1 − ρ_w/ρ).
    let text2 = text.replace(
        "net_weight = true",
        "net_weight = true\nwater_density = 1000.0\ngravity = [1.0, 0.0, -9.0]",
    );
    let scn2 = Scenario::from_str(std::path::Path::new("reach.toml"), &text2).unwrap();
    let (system2, _) = octoarm::build::build_system(&scn2).unwrap();
    let g2 = system2
        .loads()
        .iter()
        .find_map(|l| match l.load {
            Load::Gravity { acceleration } => Some(acceleration),
            _ => None,
        })
        .expect("the net weight");
    let f = 1.0 - 1000.0 / 1050.0;
    assert!((g2[0] - f).abs() < 1e-15 && g2[1] == 0.0 && (g2[2] + 9.0 * f).abs() < 1e-15);
    // Bad input is named.
    let bad = |from: &str, to: &str, key: &str| {
        let t = paper::MUSCLE_SCENARIOS[0].1.replace(from, to);
        let e = Scenario::from_str(std::path::Path::new("reach.toml"), &t).unwrap_err();
        assert!(e.to_string().contains(key), "{key}: {e}");
    };
    // [controller] appended as the last table, so that it takes none of the other keys.
    let both = format!(
        "{}\n[controller]\nkind = \"energy_shaping\"\n",
        paper::MUSCLE_SCENARIOS[0].1
    );
    let e = Scenario::from_str(std::path::Path::new("reach.toml"), &both).unwrap_err();
    assert!(e.to_string().contains("muscle_control"), "{e}");
    bad(
        "target = [0.01, 0.15, 0.06]",
        "target = [0.01, 0.15, 0.06]\ntarget_seed = 3",
        "target_seed",
    );
    bad(
        "max_iterations = 2000",
        "max_iterations = 2000\ngroups = [\"lm9\"]",
        "groups[0]",
    );
    bad(
        "max_iterations = 2000",
        "max_iterations = 0",
        "max_iterations",
    );
    bad(
        "damping = \"coomm\"",
        "damping = \"coomm\"\nwater_density = -1.0",
        "muscles.water_density",
    );
    bad(
        "damping = \"coomm\"",
        "damping = \"coomm\"\ngravity = [0.0, nan, -9.81]",
        "muscles.gravity",
    );
}
