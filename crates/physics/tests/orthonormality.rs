//! Claim (issue; spec §5): the director frames stay orthonormal, max_j ‖Q_j Q_jᵀ − I‖_max < 1e-12,
//! after every one of 1e5 steps of the arm under a constant tip load — the worst case, steady
//! bending, where nearly the same small rotation repeats every step and rounding drift grows
//! linearly — and the periodic Björck step keeps the exact zeros of the planar state.
//!
//! Independent reference: orthonormality itself (Q Qᵀ = I), measured after every step; a control
//! run with the Björck step disabled shows that the drift does exceed the bound within the same
//! 1e5 steps (spec §5: "exceeds 1e-12 within about 1e5 steps"), so the test exercises the
//! re-orthonormalisation rather than passing vacuously.
//!
//! How a wrong implementation fails: no re-orthonormalisation, or one that triggers only at the
//! bound itself (drift between two checks then carries the defect past 1e-12: 1.09e-12 was
//! measured), or a Björck step with the wrong formula (it must be Q(3I − QᵀQ)/2), or a rotation
//! update that is not an exact rotation (e.g. a truncated series, I − h[ω]×) which drifts by
//! O(h²ω²) per step. A re-orthonormalisation that mixes components (e.g. Gram–Schmidt on columns)
//! would also break the exact planar zeros checked at the end.

use octoarm_physics::math::orthonormality_defect;
use octoarm_physics::{Damping, Load, Settings, Simulation, StraightRod};

/// Run 1e5 steps of the arm (dt = 1e-5 s, ν_d = 10 1/s) under a tip force of 2e-5 N along +y;
/// return the largest defect seen after any step and the simulation.
fn run(orthonormality_interval: u64) -> (f64, Simulation) {
    let (model, state) = StraightRod::paper_arm().build().unwrap();
    let n = model.n_elements;
    let settings = Settings {
        orthonormality_interval,
        ..Settings::with_dt(1e-5)
    };
    let mut sim = Simulation::new(model, state, settings).unwrap();
    sim.set_damping(Damping::mass_proportional(10.0)).unwrap();
    sim.add_load(Load::tip_force(n, [0.0, 2e-5, 0.0])).unwrap();
    let mut worst: f64 = 0.0;
    for _ in 0..100_000 {
        sim.step().unwrap();
        let q = &sim.state.director;
        worst = worst.max(
            (0..q.len())
                .map(|j| orthonormality_defect(&q.get(j)))
                .fold(0.0, f64::max),
        );
    }
    (worst, sim)
}

// Bound 1e-12 (issue and spec §5). The run reaches steady bending (tip deflection ≈ 1.7 cm
// after 1 s at ν_d = 10 1/s).
#[test]
fn directors_stay_orthonormal_under_steady_bending() {
    let (worst, sim) = run(Settings::default().orthonormality_interval);
    let tip = sim.tip();
    println!(
        "default settings: max defect over 1e5 steps = {worst:.3e} (pass < 1e-12), tip = {tip:?}"
    );
    assert!(tip[1] > 0.01, "the arm must be bent: tip {tip:?}");
    assert!(worst < 1e-12, "director defect {worst:e} exceeds 1e-12");
    // Planar state (spec §13 g): the Björck step keeps exact zeros.
    let state = sim.rod_state();
    for (i, x) in state.position.iter().enumerate() {
        assert_eq!(x[2], 0.0, "node {i} left the plane");
    }
    for (j, q) in state.director.iter().enumerate() {
        assert!(
            q[0][2] == 0.0 && q[2][2] == 0.0 && q[1][0] == 0.0 && q[1][1] == 0.0,
            "frame {j}: {q:?}"
        );
    }
}

// Control: without re-orthonormalisation the same run drifts past the bound (measured 3.3e-12),
// so the bound above is a real test of the Björck step.
#[test]
fn without_bjorck_the_drift_exceeds_the_bound() {
    let (worst, _) = run(u64::MAX);
    println!("Björck disabled: max defect over 1e5 steps = {worst:.3e}");
    assert!(
        worst > 1e-12,
        "the control run does not drift ({worst:e}); the test above would be vacuous"
    );
}
