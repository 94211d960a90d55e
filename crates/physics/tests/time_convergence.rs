//! Claim (spec §13 e, time; §6): position Verlet as implemented is second order in Δt for the
//! positions, velocities and angular velocities of the arm: halving Δt divides the max-norm error
//! at T = 0.02 s by at least 3.5 (spec reference 4.2, 4.1, 4.1 for 2e-5 s → 1e-5 s), and the error
//! levels themselves match those of the spec's independent implementation.
//!
//! Independent reference: (1) the convergence order of the method, measured against a run of the
//! same code at Δt = 6.25e-7 s (its own error is (6.25e-7/Δt)² of the compared errors, ≤ 1.6 %);
//! (2) the absolute errors of the spec's table, produced by an independent implementation of the
//! same formulas — they depend on every force and torque term through the fast tip modes, so
//! agreeing to 2 % is a whole-model cross-check.
//!
//! How a wrong implementation fails: a stage-order slip that makes the scheme first order (forces
//! from the start- instead of the mid-step positions, a full instead of a half drift, the clamp
//! enforced once per step, forces from post-kick velocities) gives ratios near 2; a wrong term in
//! the torque (4.3), a wrong inertia factor (J instead of J/e), a wrong shear stiffness or mass
//! moves the fast tip modes and the error levels by far more than 2 %.

mod common;

use common::set_case_d_velocities;
use octoarm_physics::{RodState, Settings, Simulation, StraightRod};

const T_END: f64 = 0.02;

/// State at T_END from the (d) initial condition with A = 0.2 m/s, no damping, no loads.
fn run(shear_coefficient: f64, dt: f64) -> RodState {
    let mut arm = StraightRod::paper_arm();
    arm.material.shear_coefficient = shear_coefficient;
    let (model, mut state) = arm.build().unwrap();
    set_case_d_velocities(&model, &mut state, 0.2);
    let mut sim = Simulation::new(model, state, Settings::with_dt(dt)).unwrap();
    let steps = (T_END / dt).round() as u64;
    assert!((steps as f64 * dt - T_END).abs() < 1e-15);
    sim.run(steps).unwrap();
    sim.rod_state()
}

/// Max-norm (largest absolute component) distance of two arrays of 3-vectors.
fn max_err(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    a.iter()
        .zip(b)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs()))
        .fold(0.0, f64::max)
}

/// Errors of x, v, ω against the reference state.
fn errors(s: &RodState, reference: &RodState) -> [f64; 3] {
    [
        max_err(&s.position, &reference.position),
        max_err(&s.velocity, &reference.velocity),
        max_err(&s.omega, &reference.omega),
    ]
}

const NAMES: [&str; 3] = ["x [m]", "v [m/s]", "omega [rad/s]"];

// The spec's case: Δt = 2e-5 → 1e-5 s. Its reference errors are reproduced (to 0.4 %) only with
// α_c = 4/3, the 2020-era PyElastica coefficient; the case does not state α_c, so the spec's
// reference run evidently used 4/3 and this test states it explicitly. (With the default 27/28 the
// fast tip shear–rotation mode is 15 % slower, the errors are 1.3–1.7× smaller and the x ratio of
// this pair is 3.40 — pre-asymptotic; see the next test for the default model.)
#[test]
fn verlet_is_second_order_in_time_spec_case() {
    let ac = 4.0 / 3.0;
    let reference = run(ac, 6.25e-7);
    let coarse = errors(&run(ac, 2e-5), &reference);
    let fine = errors(&run(ac, 1e-5), &reference);
    let spec_coarse = [5.86e-10, 1.10e-5, 0.806];
    let spec_fine = [1.39e-10, 2.67e-6, 0.197];
    for c in 0..3 {
        let ratio = coarse[c] / fine[c];
        println!(
            "alpha_c = 4/3, {}: err(2e-5) = {:.4e} (ref {:.3e}), err(1e-5) = {:.4e} (ref {:.3e}), ratio = {ratio:.2} (pass >= 3.5)",
            NAMES[c], coarse[c], spec_coarse[c], fine[c], spec_fine[c]
        );
        // Pass bound from the spec: a first-order scheme gives ~2.
        assert!(ratio >= 3.5, "{}: error ratio {ratio} < 3.5", NAMES[c]);
        // The reference values carry 3 significant digits (±0.5 % rounding); the compared errors
        // are 1e5× above round-off. 2 % leaves room for that and nothing else.
        for (e, r) in [(coarse[c], spec_coarse[c]), (fine[c], spec_fine[c])] {
            assert!(
                (e / r - 1.0).abs() < 0.02,
                "{}: error {e:e} differs from the reference {r:e}",
                NAMES[c]
            );
        }
    }
}

// The default model (α_c = 27/28): second order in the asymptotic range, Δt = 1e-5 → 5e-6 s
// (Δt ω_max = 0.11 → 0.06). Measured ratios 3.9, 4.1, 4.1; pass bound 3.5 as in the spec.
#[test]
fn verlet_is_second_order_in_time_default_model() {
    let ac = 27.0 / 28.0;
    let reference = run(ac, 6.25e-7);
    let coarse = errors(&run(ac, 1e-5), &reference);
    let fine = errors(&run(ac, 5e-6), &reference);
    for c in 0..3 {
        let ratio = coarse[c] / fine[c];
        println!(
            "alpha_c = 27/28, {}: err(1e-5) = {:.4e}, err(5e-6) = {:.4e}, ratio = {ratio:.2} (pass >= 3.5)",
            NAMES[c], coarse[c], fine[c]
        );
        assert!(ratio >= 3.5, "{}: error ratio {ratio} < 3.5", NAMES[c]);
    }
}
