//! Claim (issue 11): with the second-order clamp (`Settings::clamp_order = 2`: the end node held
//! and the end element joined to the clamp frame by a half-Voronoi bending spring, a ghost element
//! at the clamp) a clamped cantilever's tip deflection converges at second order in the element
//! count; PyElastica's rigid clamped element (the default, order 1) converges at first order
//! (cosseratbench: 7.3 % off at 20 elements).
//!
//! Independent reference: the observed order of convergence, p = log2(|w_N − w_2N| / |w_2N −
//! w_4N|) over N = 10, 20, 40, 80 — it needs no exact answer, so shear and geometric
//! nonlinearity (which change the continuum answer by ~0.1 %) do not enter; and, printed for
//! scale, the error against Euler–Bernoulli F L³ / (3 E I) (cosseratbench's cantilever).
//!
//! How a wrong implementation fails: a ghost spring at the wrong distance (a whole element
//! instead of half) or missing leaves an O(l) error (order 1, or worse); the wrong sign of its
//! couple makes the end element turn away (a large error that grows with N); a spring that holds
//! the frame rigidly as well reproduces the first-order clamp.

use octoarm_physics::{
    Damping, EndCondition, Load, Material, RodAccess, Settings, Simulation, StraightRod,
};

const FORCE: f64 = 7.5e-3;

/// cosseratbench's cantilever (L = 1 m, r = 2 cm, E = 1 MPa, G = E/3, ρ = 1000 kg/m³, tip load
/// 7.5 mN) relaxed with critical-ish damping: the tip deflection [m].
fn tip_deflection(n: usize, clamp_order: u8) -> f64 {
    let material = Material {
        density: 1000.0,
        youngs_modulus: 1e6,
        shear_modulus: 1e6 / 3.0,
        shear_coefficient: Material::DEFAULT_SHEAR_COEFFICIENT,
    };
    let rod = StraightRod::uniform(n, 1.0, 0.04, material);
    let (model, state) = rod.build().unwrap();
    let dt = 0.3 * model.stable_dt();
    let settings = Settings {
        clamp_order,
        ..Settings::with_dt(dt)
    };
    let mut sim = Simulation::with_ends(
        model,
        state,
        EndCondition::Clamped,
        EndCondition::Free,
        settings,
    )
    .unwrap();
    // Slowest bending mode 3.516 √(EI/ρA)/L² = 1.11 rad/s; damp at twice it.
    sim.set_damping(Damping::mass_proportional(2.2)).unwrap();
    let tip = sim.model().n_elements;
    sim.add_load(Load::NodeForce {
        node: tip,
        force: [0.0, 0.0, -FORCE],
    })
    .unwrap();
    let steps = (25.0 / dt).ceil() as u64;
    sim.run(steps).unwrap();
    let v = sim.view();
    let vmax = (0..=n)
        .map(|i| {
            let w = v.velocity(i);
            (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt()
        })
        .fold(0.0, f64::max);
    assert!(vmax < 1e-9, "N = {n}: not at rest, |v| = {vmax:e}");
    -v.position(n)[2]
}

fn orders(clamp_order: u8) -> (Vec<f64>, Vec<f64>) {
    let ns = [10, 20, 40, 80];
    let w: Vec<f64> = ns.iter().map(|&n| tip_deflection(n, clamp_order)).collect();
    let eb = FORCE / (3.0 * 1e6 * std::f64::consts::PI * 0.02f64.powi(4) / 4.0);
    for (n, wn) in ns.iter().zip(&w) {
        println!(
            "clamp order {clamp_order}, N = {n:3}: tip deflection {wn:.8e} m, vs Euler–Bernoulli {:+.3} %",
            100.0 * (wn - eb) / eb
        );
    }
    let d: Vec<f64> = w.windows(2).map(|p| (p[1] - p[0]).abs()).collect();
    let p: Vec<f64> = d.windows(2).map(|e| (e[0] / e[1]).log2()).collect();
    println!("clamp order {clamp_order}: observed orders {p:.3?}");
    (w, p)
}

// Tolerances: the issue asks for a measured order ≥ 1.8 for the second-order clamp; the default
// must show its first order (0.8 ≤ p ≤ 1.2), or the measurement could not tell them apart.
#[test]
fn second_order_clamp_converges_at_second_order() {
    let (_, p2) = orders(2);
    let (_, p1) = orders(1);
    assert!(
        p2.iter().all(|&p| p >= 1.8),
        "second-order clamp: orders {p2:?}"
    );
    assert!(
        p1.iter().all(|&p| (0.8..=1.2).contains(&p)),
        "first-order clamp: orders {p1:?}"
    );
}
