//! Claim (spec §13 d, §12): without damping or loads the discrete arm conserves its total energy
//! H = K_t + K_r + U_s + U_b over 10⁵ steps — to 5e-5 for the default (PyElastica) model, to 1e-6
//! with the energy-consistent tension correction (eq. 4.5) — with no secular drift; and with
//! damping and an external load the books balance, H(t) + D(t) − W(t) = H(0).
//!
//! Independent reference: the conservation law itself (position Verlet is symplectic, so the
//! energy error of a conservative system stays bounded and does not drift), the closed-form
//! initial energy H(0) = 6.748866e-7 J of the spec's initial condition, and, for the balance, the
//! exact work of a constant point force, W = P · (x(t) − x(0)) at its node (position Verlet moves a node by
//! exactly Δt times its midpoint velocity, the velocity the work accumulator uses).
//!
//! How a wrong implementation fails: a force that is not the gradient of the strain energy (wrong
//! sign or factor in eq. 4.1/4.3, a missing bend–twist or shear–stretch couple, a wrong 1/e, a
//! wrong inertia factor J/e in the ω kick) makes H drift or jump by far more than 5e-5; a wrong
//! stage order (forces from the wrong half-step state) makes the integrator first order and adds
//! a secular drift; a missing or wrongly scaled correction in eq. 4.5 leaves the consistent run at
//! the default model's 2e-5; a work or dissipation accumulator that uses the wrong velocities or
//! forgets a term breaks the balance.

mod common;

use common::set_case_d_velocities;
use octoarm_physics::{
    energies, Damping, Load, RodAccess, RodModel, RodState, Settings, Simulation, StraightRod,
};

/// The spec's initial condition (§13 d) on the paper's straight arm.
fn initial_state(a: f64) -> (RodModel, RodState) {
    let (model, mut state) = StraightRod::paper_arm().build().unwrap();
    set_case_d_velocities(&model, &mut state, a);
    (model, state)
}

/// Run 10⁵ undamped, unloaded steps at dt = 1e-5 s; return (t, H/H0) sampled every 10 steps.
fn conservative_run(energy_consistent: bool) -> Vec<(f64, f64)> {
    let (model, state) = initial_state(0.05);
    let settings = Settings {
        energy_consistent,
        ..Settings::with_dt(1e-5)
    };
    let mut sim = Simulation::new(model, state, settings).unwrap();
    let h0 = sim.energies().total();
    let mut samples = vec![(0.0, 1.0)];
    for k in 1..=100_000u32 {
        sim.step().unwrap();
        if k % 10 == 0 {
            samples.push((sim.state.time, sim.energies().total() / h0));
        }
    }
    sim.check().unwrap();
    samples
}

fn max_deviation(samples: &[(f64, f64)]) -> f64 {
    samples
        .iter()
        .map(|(_, r)| (r - 1.0).abs())
        .fold(0.0, f64::max)
}

/// Least-squares slope of H/H0 against t [1/s].
fn slope(samples: &[(f64, f64)]) -> f64 {
    let n = samples.len() as f64;
    let tm = samples.iter().map(|p| p.0).sum::<f64>() / n;
    let rm = samples.iter().map(|p| p.1).sum::<f64>() / n;
    let num: f64 = samples.iter().map(|(t, r)| (t - tm) * (r - rm)).sum();
    let den: f64 = samples.iter().map(|(t, _)| (t - tm) * (t - tm)).sum();
    num / den
}

// §13 (d)/(i6): the check value of the initial energy to 5 significant digits (relative 5e-6
// of the 7-digit reference; the energy is a plain sum, so any disagreement is a wrong mass,
// inertia or the wrong component of ω, not round-off).
#[test]
fn initial_energy_matches_reference() {
    let (model, state) = initial_state(0.05);
    let h0 = energies(&model, &state, false).total();
    println!("H(0) = {h0:.7e} J (reference 6.748866e-7 J)");
    assert!((h0 / 6.748866e-7 - 1.0).abs() < 5e-6, "H(0) = {h0:e}");
    // The initial state is straight and unstrained: all of H(0) is kinetic, in both variants.
    let e = energies(&model, &state, true);
    // (Round-off in the rest positions i·l̂ leaves ~1e-31 J of strain energy.)
    assert!(e.potential() < 1e-20 * h0);
    assert!((e.total() / h0 - 1.0).abs() < 1e-15);
}

// Default model: the spec's reference is max|H/H0 − 1| = 2.1e-5 (the non-variational part of
// the model, the same at dt = 5e-6 and 2e-5); the pass bound 5e-5 leaves a factor 2.4 for
// rounding and summation-order differences, while a non-conservative force error of the size of
// any single torque term would give O(1e-2) or more. Slope bound 1e-5 1/s (reference 1.3e-6).
#[test]
fn default_model_conserves_energy_without_drift() {
    let samples = conservative_run(false);
    let dev = max_deviation(&samples);
    let s = slope(&samples);
    println!("default: max|H/H0-1| = {dev:.3e} (ref 2.1e-5, pass < 5e-5), slope = {s:.3e} 1/s (ref 1.3e-6)");
    assert!(dev < 5e-5, "max|H/H0-1| = {dev:e}");
    assert!(s.abs() < 1e-5, "secular drift {s:e} 1/s");
}

// Energy-consistent model: reference 3.1e-7; pass bound 1e-6 (spec). What remains is the
// O(Δt²) bounded oscillation of the symplectic integrator and the O(θ²) Log Jacobian terms.
#[test]
fn energy_consistent_model_conserves_energy_without_drift() {
    let samples = conservative_run(true);
    let dev = max_deviation(&samples);
    let s = slope(&samples);
    println!("consistent: max|H/H0-1| = {dev:.3e} (ref 3.1e-7, pass < 1e-6), slope = {s:.3e} 1/s");
    assert!(dev < 1e-6, "max|H/H0-1| = {dev:e}");
    assert!(s.abs() < 1e-5, "secular drift {s:e} 1/s");
}

/// Arm with the (d) initial state, mass-proportional damping and a constant point force at
/// mid-arm; returns the largest balance residual |H + D − W − H0| relative to the energy scale
/// max(H0, max W, max D), the largest |W − P·Δx| relative to max W, and max W/H0, max D/H0.
fn balance_run(energy_consistent: bool, steps: u32) -> (f64, f64, f64, f64) {
    let (model, state) = initial_state(0.05);
    let node = model.n_elements / 2;
    let settings = Settings {
        energy_consistent,
        ..Settings::with_dt(1e-5)
    };
    let mut sim = Simulation::new(model, state, settings).unwrap();
    // ν = 2 1/s dissipates about H0 over the 1 s run without freezing the motion. The force acts
    // at mid-arm (node 50) so that the strains stay in the regime of case (d) (measured: turning
    // angle ≤ 0.095 rad, |σ| ≤ 8.3e-3, against 0.034 rad and 3e-3 in (d)) while its work is of
    // the order of H0. (A tip force of 1e-5 N bends the thin tip to 0.5 rad per Voronoi
    // point; there the O(θ²) remainder of eq. 4.5 makes the consistent model's balance error
    // 1e-6 and the default model's 1.3e-4 — a property of the model, spec §4, not of the books.)
    sim.set_damping(Damping::mass_proportional(2.0)).unwrap();
    let p = [0.0, 2e-4, -1e-4];
    sim.add_load(Load::NodeForce { node, force: p }).unwrap();
    let x0 = sim.view().position(node);
    let h0 = sim.energies().total();
    let mut worst_work: f64 = 0.0;
    let (mut max_w, mut max_d): (f64, f64) = (0.0, 0.0);
    let mut residuals = Vec::new();
    for k in 1..=steps {
        sim.step().unwrap();
        if k % 50 == 0 {
            let w = sim.external_work();
            let d = sim.dissipated_energy();
            let x = sim.view().position(node);
            let w_exact = p[0] * (x[0] - x0[0]) + p[1] * (x[1] - x0[1]) + p[2] * (x[2] - x0[2]);
            worst_work = worst_work.max((w - w_exact).abs());
            max_w = max_w.max(w.abs());
            max_d = max_d.max(d);
            residuals.push(sim.energies().total() + d - w - h0);
        }
    }
    let scale = h0.max(max_w).max(max_d);
    let worst_balance = residuals
        .iter()
        .map(|r| r.abs() / scale)
        .fold(0.0, f64::max);
    (worst_balance, worst_work / max_w, max_w / h0, max_d / h0)
}

// Balance H + D − W = H0 with damping and a load. Tolerances, relative to the energy scale
// max(H0, W, D):
// * work accumulator vs P·Δx: the two are algebraically identical for a constant force in
//   position Verlet (Δx = Δt v̄ each step), so only round-off separates them: 1e-9;
// * dissipation: the midpoint-velocity power m λ |v̄|² differs from the energy the exact
//   exponential kick removes by O((λΔt)²) = 4e-10 of D (measured balance error of a damped,
//   unloaded run: 1.5e-7, the conservative part's own error);
// * balance, energy-consistent model: the bound of case (d), 1e-6 (measured 1.7e-7);
// * balance, default model: the bound of case (d), 5e-5 (measured 2.1e-5) — the default forces
//   are not the gradient of the energy, which costs O(strain²) of the energy either way.
// A dissipation accumulator that missed the rotational DOFs or the damping of a node, or used
// start-of-step instead of midpoint velocities, is off by O(λΔt) = 2e-5 of D per step and
// O(1e-2) over the run; a work accumulator using start-of-step velocities is off by O(1e-1).
#[test]
fn energy_balance_with_damping_and_load() {
    for (consistent, tol) in [(true, 1e-6), (false, 5e-5)] {
        let (balance, work, w_over_h0, d_over_h0) = balance_run(consistent, 100_000);
        println!(
            "balance (energy_consistent = {consistent}): max|H+D-W-H0|/scale = {balance:.3e} (pass < {tol:e}), \
             |W - P·Δx|/W = {work:.3e}, max W/H0 = {w_over_h0:.2}, max D/H0 = {d_over_h0:.2}"
        );
        assert!(
            work < 1e-9,
            "work accumulator differs from P·Δx by {work:e} of W"
        );
        assert!(
            d_over_h0 > 0.5 && w_over_h0 > 0.5,
            "the run must exercise both D and W"
        );
        assert!(
            balance < tol,
            "energy balance residual {balance:e} (tolerance {tol:e})"
        );
    }
}
