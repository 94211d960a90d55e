//! Claims (spec §4.6, §5.2, §5.3, §5.5): the `ShapingController` drives the paper's arm on the
//! paper's tasks (fixtures in `common`, the constants of `scenarios/paper/*.toml`; 1 ms updates,
//! N = 100, dt = 1e-5 s, ν_d = 10 s⁻¹), updated every period as the application's pipeline does:
//! * A (4 s, not shortened): the controller's distance signal is |tip − r*(t)|/L0 recomputed here
//!   from the tip and the task's targets (1e-12 at every 1 ms sample); the shaped Hamiltonian
//!   from its signals does not rise between design changes (1 ms samples: H_n ≤ min_{m≤n} H_m +
//!   1e-4 H_0, spec §4.6) and falls below 1e-2 H_0 by the end of the first segment; and A's
//!   acceptance numbers: d(1.8⁻) ≤ 0.02; the switch makes d jump to 0.55–0.59
//!   (= |r*₁ − r*₂|/L0 = 0.57); settling ≤ 1.5 s after the switch; d(4 s) ≤ 0.01.
//! * B (4 s, not shortened), online: every update succeeds and is recorded (4000 updates, one
//!   design tip error per update, none failed); after 0.5 s the design's tip error at each update
//!   is ≤ 0.005 L0; and B's acceptance number d ≤ 0.04 on [2, 4] s. (Spec §5.3's "d never
//!   exceeds d(0)" is infeasible from rest: an ignored test below.)
//! * D (4 s, not shortened): after the 1.5 s ramp the design is constant and the shaped
//!   Hamiltonian with the contact energy does not rise (same bound); and D's acceptance numbers:
//!   weighted gap d_D(4 s) ≤ 0.01, settling (band 0.02) ≤ 2.5 s, penetration ≤ 1e-3 L0.
//!
//! Moved to the application: the end-to-end acceptance of the four experiments at full length
//! now lives in the scenario files' `[[acceptance]]` tables, asserted by `crates/app/tests/`
//! (regression.rs). Only experiment C's claims left this file: d(4 s) ≤ 0.02 (the arm passes the
//! spheres instead of staying pinned, d ≈ 0.58) and the arm's surface never penetrates a sphere by
//! more than 1 mm = 0.005 L0 (scenarios/paper/obstacles.toml). The acceptance numbers of A, B and
//! D are in their scenario tables too and stay here as well, because the runs are needed for the
//! controller's own claims (Lyapunov function, signals, online updates) anyway.
//!
//! Independent reference: distances of A are recomputed here from the tip and the fixture's
//! targets; the Lyapunov function is the physics crate's energy with the design rest strains
//! (the controller's signals) plus the physics crate's contact energy.
//! Tolerances are the spec's [J] acceptance numbers; none is widened.

mod common;
use common::*;

fn print_run(name: &str, samples: &[Sample], report: &octoarm_control::ControlReport) {
    let pen = samples.iter().map(|s| s.penetration).fold(0.0, f64::max);
    println!(
        "{name}: final d = {:.2e}, max penetration = {:.3} mm, sweeps = {}, failed updates = {}",
        samples.last().unwrap().distance,
        pen * 1e3,
        report.sweeps,
        report.failed_updates,
    );
}

fn d_at(samples: &[Sample], t: f64) -> f64 {
    samples
        .iter()
        .min_by(|a, b| (a.time - t).abs().total_cmp(&(b.time - t).abs()))
        .unwrap()
        .distance
}

#[test]
fn experiment_a_two_targets() {
    let (mut sim, mut ctrl) = paper_closed_loop(paper_a_schedule(), paper_a_config());
    let (series, report) = run_closed_loop(&mut sim, &mut ctrl, 4.0, 1e-3);
    print_run("experiment A", &series, &report);
    assert_eq!(series.len(), 4001);
    for s in &series {
        let target = if s.time >= 1.8 - 1e-9 {
            [0.0, 0.02, 0.0]
        } else {
            [0.09, 0.09, 0.0]
        };
        assert!((s.distance - dist(s.tip, target) / L0).abs() < 1e-12);
    }
    let before = series.iter().rfind(|s| s.time < 1.8 - 1e-9).unwrap();
    let after = series.iter().find(|s| s.time >= 1.8 - 1e-9).unwrap();
    println!(
        "d(1.8-) = {:.4}, d(1.8+) = {:.4}",
        before.distance, after.distance
    );
    assert!(before.distance <= 0.02);
    assert!((0.55..=0.59).contains(&after.distance));
    let second: Vec<&Sample> = series.iter().filter(|s| s.time >= 1.8 - 1e-12).collect();
    let settle = settling_time(&second, 0.02).expect("settles after the switch") - 1.8;
    println!("settling after the switch {settle:.3} s");
    assert!(settle <= 1.5);
    assert!(series.last().unwrap().distance <= 0.01);
    let rise = worst_lyapunov_rise(&series, 0.0);
    println!("largest Lyapunov rise {rise:.2e} H0");
    assert!(rise <= 1e-4);
    let h0 = series[0].hamiltonian;
    assert!(before.hamiltonian <= 1e-2 * h0);
}

#[test]
fn experiment_b_moving_target() {
    let (mut sim, mut ctrl) = paper_closed_loop(paper_b_schedule(), paper_b_config());
    let (series, report) = run_closed_loop(&mut sim, &mut ctrl, 4.0, 1e-3);
    print_run("experiment B", &series, &report);
    let late = series
        .iter()
        .filter(|s| s.time >= 2.0)
        .map(|s| s.distance)
        .fold(0.0, f64::max);
    println!(
        "d(0) = {:.3}, d(1.2) = {:.3}, max d on [2, 4] s = {late:.4}",
        series[0].distance,
        d_at(&series, 1.2)
    );
    assert!(late <= 0.04);
    // Spec §5.3: the desired shape's tip error at each update after 0.5 s ≤ 0.005 L0. The online
    // sweeps start from an offline design of the initial target (pre-solve) and then track the
    // moving target with 10 warm-started L-BFGS iterations per 1 ms update. A design that fell
    // behind the target (e.g. a trust region freezing small strains: 0.29 L0 at 0.5 s) fails this.
    // Every update (t = 0, 1 ms, …, 3.999 s) succeeds and is recorded.
    assert_eq!(report.failed_updates, 0);
    assert_eq!(report.update_tip_errors.len(), 4000);
    for (k, e) in report.update_tip_errors.iter().enumerate() {
        assert!(
            (e.0 - k as f64 * 1e-3).abs() < 1e-12,
            "update {k} at {}",
            e.0
        );
    }
    let worst = report
        .update_tip_errors
        .iter()
        .filter(|e| e.0 >= 0.5)
        .map(|e| e.1 / L0)
        .fold(0.0, f64::max);
    println!("largest design tip error after 0.5 s = {worst:.2e} L0");
    assert!(worst <= 0.005);
}

/// Spec §5.3 also asks that d never exceeds d(0). This cannot hold for any controller: the arm
/// starts at rest (tip velocity 0) while the target recedes along the tip-to-target direction, so
/// d'(0+) = (v* · u)/L0 = +0.033 L0/s > 0 and d rises above d(0) immediately; a tip that has to
/// gain speed from rest can only catch up later. Measured with the pre-solved design: d rises
/// from 0.6021 to 0.6063 (+0.7 %) at 52 ms, of which the receding target accounts for +0.0017 and
/// the first stretch/shear and base-first bending of the arm for the rest
/// (docs/paper-experiments.md, "Experiment B"). Kept as an ignored test so the shortfall is
/// visible (the scenario's acceptance table notes it as infeasible); run with `--ignored`.
#[test]
#[ignore = "infeasible as stated (arm at rest, receding target: d'(0+) > 0); measured max d 0.6063 vs d(0) 0.6021"]
fn experiment_b_distance_never_exceeds_start() {
    let (mut sim, mut ctrl) = paper_closed_loop(paper_b_schedule(), paper_b_config());
    let (series, _) = run_closed_loop(&mut sim, &mut ctrl, 4.0, 1e-3);
    let d0 = series[0].distance;
    let max = series.iter().map(|s| s.distance).fold(0.0, f64::max);
    println!("d(0) = {d0:.4}, max d = {max:.4}");
    assert!(max <= d0 + 1e-12);
}

#[test]
fn experiment_d_grasp() {
    let (mut sim, mut ctrl) = paper_closed_loop(paper_d_schedule(), paper_d_config());
    let (series, report) = run_closed_loop(&mut sim, &mut ctrl, 4.0, 1e-3);
    print_run("experiment D", &series, &report);
    let all: Vec<&Sample> = series.iter().collect();
    let settling = settling_time(&all, 0.02);
    let final_distance = series.last().unwrap().distance;
    let max_penetration = series.iter().map(|s| s.penetration).fold(0.0, f64::max);
    println!(
        "d_D(0) = {:.3}, d_D(1.6) = {:.4}, settling {settling:?} s, d_D(4) = {final_distance:.2e}",
        series[0].distance,
        d_at(&series, 1.6),
    );
    assert!(final_distance <= 0.01);
    assert!(settling.expect("settles") <= 2.5);
    assert!(max_penetration <= 1e-3 * L0);
    // After the 1.5 s ramp the design is constant: H (with the contact energy) must not rise.
    let rise = worst_lyapunov_rise(&series, 1.5 + 1e-3);
    println!("largest Lyapunov rise after the ramp {rise:.2e} H0");
    assert!(rise <= 1e-4);
}
