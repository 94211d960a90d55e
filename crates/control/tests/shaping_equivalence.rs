//! Claim (spec §7 test 6): the energy-shaping control equals the difference of two elastic-load
//! evaluations 𝓛(x; σ̄, κ̄) − 𝓛(x; σ°, κ°) (the fast affine form to round-off), with the
//! energy-consistent correction it is −∂x(V^d_h − V_h) (finite differences, 1e-6 relative), and
//! the closed loop equals the uncontrolled rod whose rest strains are set to w̄ (same damping) to
//! 1e-10 L0 after 1000 steps.
//! Independent references: the physics crate's `ElasticLoads` and `energies_with_rest` (its own
//! kernels), and a second simulation that never sees the controller.
//! A wrong law fails by O(1): a sign error doubles or cancels the loads, a missing 1/e or 1/ε³
//! factor in the affine form leaves an O(strain) ≈ 5e-2 relative error, using the design-floored
//! stiffness instead of the rod's moves the closed-loop equilibrium.
//! Tolerances: 1e-12 relative for two evaluations of the same affine expression; 1e-6 for
//! central differences with h = 1e-7 m (truncation ~h² relative, round-off ~1e-16 E/h);
//! 1e-10 L0 for two runs differing only in the summation order of the same loads.

mod common;
use common::*;
use octoarm_control::{
    EnergyShapingController, LawEvaluation, ShapingConfig, Statics, StrainField, StrainSpace,
};
use octoarm_physics::{
    energies_with_rest, Damping, ExternalLoads, InternalLoads, RodState, Settings, Simulation,
};
use rand::Rng;

/// A random state: the forward map of random strains, with random velocities.
fn random_state(seed: u64) -> (octoarm_physics::RodModel, RodState, StrainField) {
    let (model, state) = paper_arm();
    let mut r = rng(seed);
    let w = random_field(&model, StrainSpace::Full, 0.05, 3.0, &mut r);
    let mut st = Statics::new(&model, &state, StrainSpace::Full, 0.0).unwrap();
    let mut s = st.state_of(&w);
    for v in s.velocity.iter_mut() {
        *v = [
            1e-3 * normal(&mut r),
            1e-3 * normal(&mut r),
            1e-3 * normal(&mut r),
        ];
    }
    for o in s.omega.iter_mut() {
        *o = [
            0.1 * normal(&mut r),
            0.1 * normal(&mut r),
            0.1 * normal(&mut r),
        ];
    }
    let design = random_field(&model, StrainSpace::Full, 0.03, 2.0, &mut r);
    (model, s, design)
}

fn control(
    model: &octoarm_physics::RodModel,
    s: &RodState,
    design: &StrainField,
    evaluation: LawEvaluation,
    energy_consistent: bool,
) -> ExternalLoads {
    let mut c = EnergyShapingController::new(
        model,
        ShapingConfig {
            damping_rate: 0.0,
            evaluation,
        },
    )
    .unwrap();
    c.set_design(model, design).unwrap();
    let mut sim = Simulation::new(
        model.clone(),
        s.clone(),
        Settings {
            energy_consistent,
            ..Settings::with_dt(1e-5)
        },
    )
    .unwrap();
    c.attach(&mut sim).unwrap();
    let mut internal = InternalLoads::new(model.n_elements);
    internal.compute(
        model,
        s,
        &model.rest_sigma,
        &model.rest_kappa,
        true,
        energy_consistent,
    );
    let mut out = ExternalLoads::zeros(model.n_elements);
    c.apply(model, s, &internal, &mut out);
    out
}

fn max_norm(l: &ExternalLoads) -> (f64, f64) {
    let f = l
        .force
        .iter()
        .map(|v| dist(*v, [0.0; 3]))
        .fold(0.0, f64::max);
    let c = l
        .couple
        .iter()
        .map(|v| dist(*v, [0.0; 3]))
        .fold(0.0, f64::max);
    (f, c)
}

#[test]
fn affine_law_equals_two_load_evaluations() {
    let mut worst: f64 = 0.0;
    for seed in 0..5 {
        let (model, s, design) = random_state(seed);
        let a = control(&model, &s, &design, LawEvaluation::Affine, false);
        let b = control(
            &model,
            &s,
            &design,
            LawEvaluation::TwoLoadEvaluations,
            false,
        );
        let (fmax, cmax) = max_norm(&b);
        let df = a
            .force
            .iter()
            .zip(&b.force)
            .map(|(x, y)| dist(*x, *y))
            .fold(0.0, f64::max)
            / fmax;
        let dc = a
            .couple
            .iter()
            .zip(&b.couple)
            .map(|(x, y)| dist(*x, *y))
            .fold(0.0, f64::max)
            / cmax;
        worst = worst.max(df).max(dc);
    }
    println!("affine vs two evaluations: worst relative difference {worst:.2e}");
    assert!(worst < 1e-12, "{worst}");
}

#[test]
fn energy_consistent_law_is_the_gradient_of_the_shaped_potential() {
    let (model, s, design) = random_state(7);
    let u = control(&model, &s, &design, LawEvaluation::TwoLoadEvaluations, true);
    let (sigma_d, kappa_d) = design.to_rest_strains();
    let shaped = |st: &RodState| {
        energies_with_rest(&model, st, &sigma_d, &kappa_d, true).potential()
            - energies_with_rest(&model, st, &model.rest_sigma, &model.rest_kappa, true).potential()
    };
    let (fmax, _) = max_norm(&u);
    let mut r = rng(8);
    let h = 1e-7;
    let mut worst: f64 = 0.0;
    for _ in 0..40 {
        let i = r.gen_range(1..=model.n_elements);
        let c = r.gen_range(0..3);
        let mut sp = s.clone();
        sp.position[i][c] += h;
        let mut sm = s.clone();
        sm.position[i][c] -= h;
        let fd = -(shaped(&sp) - shaped(&sm)) / (2.0 * h);
        worst = worst.max((fd - u.force[i][c]).abs() / fmax);
    }
    println!("energy-consistent law vs -d(Vd - V)/dx: worst relative error {worst:.2e} over 40 force components");
    assert!(worst < 1e-6, "{worst}");
}

#[test]
fn closed_loop_equals_rod_with_design_rest_strains() {
    let (model, s, design) = random_state(3);
    // Start both from the random state at rest-ish velocities.
    let mut controlled =
        Simulation::new(model.clone(), s.clone(), Settings::with_dt(1e-5)).unwrap();
    let mut ctrl = EnergyShapingController::new(&model, ShapingConfig::default()).unwrap();
    ctrl.set_design(&model, &design).unwrap();
    ctrl.attach(&mut controlled).unwrap();
    let mut shaped_model = model.clone();
    let (sigma_d, kappa_d) = design.to_rest_strains();
    shaped_model.set_rest_strains(&sigma_d, &kappa_d).unwrap();
    let mut passive = Simulation::new(shaped_model, s.clone(), Settings::with_dt(1e-5)).unwrap();
    passive
        .set_damping(Damping::mass_proportional(10.0))
        .unwrap();
    ctrl.run(&mut controlled, 1000).unwrap();
    passive.run(1000).unwrap();
    let gap = controlled
        .state
        .position
        .iter()
        .zip(&passive.state.position)
        .map(|(a, b)| dist(*a, *b))
        .fold(0.0, f64::max);
    let moved = controlled
        .state
        .position
        .iter()
        .zip(&s.position)
        .map(|(a, b)| dist(*a, *b))
        .fold(0.0, f64::max);
    println!("closed loop vs rod with rest strains w̄ after 1000 steps: {:.2e} L0 (the arm moved {:.2e} L0)", gap / L0, moved / L0);
    assert!(moved > 1e-4 * L0);
    assert!(gap < 1e-10 * L0, "{gap}");
}
