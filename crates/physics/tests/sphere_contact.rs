//! Claim (issue; spec §10): a rod pushed against a fixed rigid sphere comes to rest outside it —
//! at equilibrium the largest penetration of the rod's surface is below 1 % of the local current
//! radius r̂_j/√e_j — and the contact forces balance the load.
//!
//! Independent reference: statics. (1) A free uniform rod pressed by a uniform force p onto a
//! sphere under its midpoint has no other support, so the total contact force must equal −p L
//! exactly (and act along the load). (2) The paper's arm, clamped, loaded at the tip and propped by
//! a sphere above its middle, is in equilibrium when load + contact + base reaction sum to zero,
//! with the contact carrying a substantial share of the load.
//! The penetration bound follows from the penalty law: g = F/k_j with k_j = E Â_j/l̂_j, orders of
//! magnitude below 1 % of the radius for these loads — a larger value means the force is not
//! acting.
//!
//! How a wrong implementation fails: a contact normal with the wrong sign pulls the rod into the
//! sphere (penetration grows to the radius sum); penetration measured against the wrong radius
//! (rest radius of the wrong element, diameter) or a closest point not clamped to the element
//! leaves the rod inside or floating; a force split that does not sum to F_n (e.g. ½/½ plus the
//! end-element weights) breaks the force balance; an adhesive force (no max(0, ·)) holds the rod
//! against the sphere when it should lift off.

mod common;

use common::{max_norm, norm};
use octoarm_physics::{
    max_penetration, Damping, EndCondition, Load, Material, RodAccess, Settings, Simulation,
    Sphere, StraightRod,
};

/// Step until every node is slower than 1e-7 m/s (100× stricter than the spec's static
/// criterion, §13, so that the force balance is resolved to ~1e-5), checking every 100 steps,
/// for at most `t_max` seconds. Returns the time reached.
fn relax(sim: &mut Simulation, t_max: f64) -> f64 {
    loop {
        sim.run(100).unwrap();
        let vmax = max_norm(&sim.rod_state().velocity);
        if vmax < 1e-7 && sim.state.time > 0.5 {
            return sim.state.time;
        }
        assert!(
            sim.state.time < t_max,
            "not at rest after {t_max} s: max |v| = {vmax:e} m/s"
        );
    }
}

/// Penetration relative to the current radius r̂_j/√e_j of the element where it is largest.
fn relative_penetration(sim: &Simulation) -> (f64, f64, usize) {
    let s = sim.view();
    let (g, j) = max_penetration(sim.model(), &s, sim.system.obstacles(), sim.time());
    let (a, b) = (s.position(j), s.position(j + 1));
    let l = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt();
    let r = sim.model().radius[j] / (l / sim.model().rest_length[j]).sqrt();
    (g / r, g, j)
}

/// Total contact force of the last force evaluation: all external forces minus the uniform load.
fn contact_force(sim: &Simulation, p: [f64; 3], first_node: usize) -> [f64; 3] {
    let mut f = [0.0; 3];
    let external = &sim.workspace.external.force;
    for i in first_node..sim.model().n_nodes() {
        let fi = external.get(i);
        for c in 0..3 {
            f[c] += fi[c] - p[c] * sim.model().nodal_rest_length[i];
        }
    }
    f
}

// (1) Free uniform rod (paper material, L = 0.2 m, d = 1 cm, N = 50) pushed by p = 5e-3 N/m
// along −y onto a sphere of radius 2 cm whose top is 1 mm below the rod's surface at its middle.
// Tolerances: penetration < 1 % of the local radius (issue); the contact force equals −p L to
// 1e-4 relative — at rest (|v| < 1e-7 m/s) the unbalanced force is the damping and inertial
// force of the remaining motion, ≤ ν M |v| = 6 · 1.1e-2 kg · 1e-7 m/s ≈ 7e-9 N = 7e-6 of
// p L = 1e-3 N, plus the slowly decaying acceleration of the same size (measured 8e-4 at the
// spec's 1e-5 m/s criterion, i.e. the bound scales with the rest criterion as expected).
#[test]
fn free_rod_rests_on_sphere_and_contact_carries_the_load() {
    let material = Material {
        density: 700.0,
        youngs_modulus: 1e4,
        shear_modulus: 1e3,
        shear_coefficient: Material::DEFAULT_SHEAR_COEFFICIENT,
    };
    let rod = StraightRod::uniform(50, 0.2, 0.01, material);
    let (model, state) = rod.build().unwrap();
    let mut sim = Simulation::with_ends(
        model,
        state,
        EndCondition::Free,
        EndCondition::Free,
        Settings::with_dt(1e-4),
    )
    .unwrap();
    assert!(1e-4 < 0.2 * sim.model().stable_dt());
    sim.set_damping(Damping::mass_proportional(6.0)).unwrap();
    let p = [0.0, -5e-3, 0.0];
    sim.add_load(Load::UniformForce {
        force_per_length: p,
    })
    .unwrap();
    let radius = 0.02;
    sim.add_obstacle(Sphere::fixed([0.1, -(0.005 + 0.001 + radius), 0.0], radius))
        .unwrap();
    let t = relax(&mut sim, 20.0);
    let (rel, g, j) = relative_penetration(&sim);
    let fc = contact_force(&sim, p, 0);
    let load = [p[0] * 0.2, p[1] * 0.2, p[2] * 0.2];
    let imbalance = norm([fc[0] + load[0], fc[1] + load[1], fc[2] + load[2]]) / norm(load);
    println!(
        "free rod at rest after {t:.2} s: penetration {g:.3e} m = {rel:.2e} of the local radius (element {j}); \
         contact force {fc:?} N vs load {load:?} N, imbalance {imbalance:.2e}"
    );
    assert!(g > 0.0, "the rod must touch the sphere");
    assert!(rel < 0.01, "penetration {rel:e} of the radius");
    assert!(
        imbalance < 1e-4,
        "contact force does not balance the load: {imbalance:e}"
    );
}

// (2) The paper's arm, clamped, with a tip force of 5e-5 N along +y, propped by a sphere of
// radius 2 cm above its middle (x = 0.1 m, local radius 5.1 mm, gap 1 mm): a propped cantilever.
// (With the tapered arm's stiff base and a 3 cm tip deflection the clamp takes about half of the
// load, unlike a uniform linear propped beam, whose prop carries more than P.) Tolerances:
// penetration < 1 % of the local radius (issue); force balance Σ_{i≥1} F_ext + base reaction = 0
// to 1e-4 of the tip force — at rest (|v| < 1e-7 m/s) the residual is the damping and inertial
// force ≤ ν M |v| = 10 · 1.5e-2 kg · 1e-7 m/s = 1.5e-8 N = 3e-4 of P as a worst case with every
// node at the bound; the nodes near the base barely move, so the measured residual is far
// smaller. The contact must carry a substantial share (> 10 %) of the tip force.
#[test]
fn paper_arm_propped_by_sphere_rests_outside_it() {
    let (model, state) = StraightRod::paper_arm().build().unwrap();
    let n = model.n_elements;
    let mut sim = Simulation::new(model, state, Settings::with_dt(2e-5)).unwrap();
    sim.set_damping(Damping::mass_proportional(10.0)).unwrap();
    let tip = [0.0, 5e-5, 0.0];
    sim.add_load(Load::tip_force(n, tip)).unwrap();
    let r_mid = 0.5 * (0.0004 * 0.1 + 0.02 * 0.1) / 0.2;
    sim.add_obstacle(Sphere::fixed([0.1, r_mid + 1e-3 + 0.02, 0.0], 0.02))
        .unwrap();
    let t = relax(&mut sim, 30.0);
    let (rel, g, j) = relative_penetration(&sim);
    let mut fc = [0.0; 3];
    let mut applied = [0.0; 3];
    for i in 1..=n {
        let fi = sim.workspace.external.force.get(i);
        for c in 0..3 {
            applied[c] += fi[c];
            fc[c] += fi[c] - if i == n { tip[c] } else { 0.0 };
        }
    }
    let reaction = sim.base_reaction_force();
    let imbalance = norm([
        applied[0] + reaction[0],
        applied[1] + reaction[1],
        applied[2] + reaction[2],
    ]) / norm(tip);
    println!(
        "paper arm at rest after {t:.2} s: penetration {g:.3e} m = {rel:.2e} of the local radius (element {j}); \
         contact force {fc:?} N, base reaction {reaction:?} N, tip force {tip:?} N, imbalance {imbalance:.2e}; \
         tip at {:?}",
        sim.tip()
    );
    assert!(g > 0.0, "the arm must touch the sphere");
    assert!(rel < 0.01, "penetration {rel:e} of the radius");
    // The contact force points from the sphere to the rod (down, −y), never adhesive, and
    // carries a substantial share of the load.
    assert!(fc[1] < -0.1 * norm(tip), "contact force {fc:?}");
    assert!(
        imbalance < 1e-4,
        "tip force, contact and base reaction do not balance: {imbalance:e}"
    );
}
