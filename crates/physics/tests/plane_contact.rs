//! Claims (issue 11): a rod resting on a rigid plane under gravity carries its weight (normal
//! forces sum to the weight, penetration ≤ 1 % of the radius); Coulomb friction holds a rod on
//! an incline below tan⁻¹ μ_s and lets it slide above, with the kinetic acceleration
//! g (sin θ − μ_k cos θ); a rod sliding on a level plane decelerates at μ_k g in the direction it
//! slides (forward, backward, lateral coefficients of anisotropic friction).
//!
//! Independent references: statics (the plane is the only support), Coulomb's law for a block
//! on an incline (a straight free rod lying on a plane moves as a rigid body), Newton's second
//! law for the deceleration.
//!
//! How a wrong implementation fails: a normal force split that does not sum to F_n or a normal
//! measured from the wrong side breaks the weight balance or lets the rod sink; a friction force
//! not capped by μ F_n holds the rod above the threshold; static and kinetic coefficients
//! swapped move the threshold or the acceleration; forward/backward/lateral mixed up gives the
//! wrong deceleration in one of the three directions.

mod common;

use common::{max_norm, norm};
use octoarm_physics::{
    obstacle_penetration, Damping, EndCondition, Friction, Load, Material, Plane, RodAccess,
    Schedule, Settings, Simulation, StraightRod,
};

const G: f64 = 9.81;

fn material() -> Material {
    Material {
        density: 1000.0,
        youngs_modulus: 1e6,
        shear_modulus: 1e6 / 3.0,
        shear_coefficient: Material::DEFAULT_SHEAR_COEFFICIENT,
    }
}

/// A free straight rod (L = 0.5 m, d = 1 cm, N = 50) along `direction`, lying on the plane
/// z = 0 (its centreline at z = r), with gravity `g` and a plane with `friction`.
fn rod_on_floor(direction: [f64; 3], g: [f64; 3], friction: Friction) -> Simulation {
    moving_rod_on_floor(direction, g, friction, [0.0; 3])
}

/// As `rod_on_floor`, every node starting with velocity `v0`.
fn moving_rod_on_floor(
    direction: [f64; 3],
    g: [f64; 3],
    friction: Friction,
    v0: [f64; 3],
) -> Simulation {
    let mut rod = StraightRod::uniform(50, 0.5, 0.01, material());
    rod.direction = direction;
    rod.normal = [0.0, 0.0, 1.0];
    // Sunk by the static penetration ρ g_n l̂² / (β E) of the penalty springs (β = 1), so that
    // the rod starts at rest on the plane with its weight carried, as a block set down gently.
    let l = 0.5 / 50.0;
    let sink = 1000.0 * (-g[2]) * l * l / 1e6;
    rod.base_position = [0.0, 0.0, 0.005 - sink];
    let (model, mut state) = rod.build().unwrap();
    for v in &mut state.velocity {
        *v = v0;
    }
    let mut sim = Simulation::with_ends(
        model,
        state,
        EndCondition::Free,
        EndCondition::Free,
        Settings::with_dt(2e-5),
    )
    .unwrap();
    assert!(2e-5 < 0.2 * sim.system.stable_dt());
    sim.system
        .add_load(0, Load::Gravity { acceleration: g }, Schedule::Constant)
        .unwrap();
    sim.add_plane(Plane::new([0.0; 3], [0.0, 0.0, 1.0], friction))
        .unwrap();
    sim
}

/// Mean velocity of the rod's nodes weighted by mass (centre-of-mass velocity).
fn com_velocity(sim: &Simulation) -> [f64; 3] {
    let m = sim.model();
    let s = sim.view();
    let mut p = [0.0; 3];
    for i in 0..=m.n_elements {
        let v = s.velocity(i);
        for c in 0..3 {
            p[c] += m.node_mass[i] * v[c];
        }
    }
    let total = m.total_mass();
    [p[0] / total, p[1] / total, p[2] / total]
}

fn com_position(sim: &Simulation) -> [f64; 3] {
    let m = sim.model();
    let s = sim.view();
    let mut p = [0.0; 3];
    for i in 0..=m.n_elements {
        let x = s.position(i);
        for c in 0..3 {
            p[c] += m.node_mass[i] * x[c];
        }
    }
    let total = m.total_mass();
    [p[0] / total, p[1] / total, p[2] / total]
}

// Tolerances: the normal forces balance the weight to 1e-4 once every node is slower than
// 1e-7 m/s (the residual is the damping force ν M |v| ≈ 5 · 0.04 kg · 1e-7 m/s = 2e-8 N against
// a weight of 0.39 N); the penetration is m̄ g l̂ / (E Â) ≈ 1e-6 m = 2e-4 of the radius, and must
// stay below 1 %.
#[test]
fn rod_resting_on_plane_carries_its_weight() {
    let mut sim = rod_on_floor([1.0, 0.0, 0.0], [0.0, 0.0, -G], Friction::NONE);
    sim.set_damping(Damping::mass_proportional(5.0)).unwrap();
    loop {
        sim.run(100).unwrap();
        if max_norm(&sim.rod_state().velocity) < 1e-7 && sim.time() > 0.2 {
            break;
        }
        assert!(sim.time() < 10.0, "not at rest");
    }
    let m = sim.model();
    let weight = m.total_mass() * G;
    let mut normal = 0.0;
    for i in 0..=m.n_elements {
        normal += sim.workspace.external.force.get(i)[2] + m.node_mass[i] * G;
    }
    let (g, j) = obstacle_penetration(m, &sim.view(), sim.system.obstacle_set(), sim.time());
    let rel = g / m.radius[j];
    println!(
        "rod on plane at rest after {:.2} s: normal force {normal:.6e} N, weight {weight:.6e} N, \
         penetration {g:.3e} m = {rel:.2e} of the radius",
        sim.time()
    );
    assert!((normal - weight).abs() < 1e-4 * weight);
    assert!(g > 0.0 && rel < 0.01, "penetration {rel:e}");
}

/// Displacement of the centre of mass along the slope after `t` s on a plane tilted by θ
/// (gravity tilted instead: g (sin θ, 0, −cos θ)), and its acceleration over the last half of
/// the run.
fn incline(theta_deg: f64, friction: Friction, along: [f64; 3], t: f64) -> (f64, f64) {
    let th = theta_deg.to_radians();
    let mut sim = rod_on_floor(along, [G * th.sin(), 0.0, -G * th.cos()], friction);
    let x0 = com_position(&sim)[0];
    let steps = (t / sim.system.settings().dt).round() as u64;
    sim.run(steps / 2).unwrap();
    let (v1, t1) = (com_velocity(&sim)[0], sim.time());
    sim.run(steps - steps / 2).unwrap();
    let (v2, t2) = (com_velocity(&sim)[0], sim.time());
    (com_position(&sim)[0] - x0, (v2 - v1) / (t2 - t1))
}

// μ_s = 0.5 (threshold 26.57°), μ_k = 0.3. Below (24°): the rod holds — the stick springs
// deform by F_t / k_t ~ 1e-6 m — so over 0.5 s it moves less than 0.05 mm, where sliding at μ_k
// would cover 0.16 m. Above (29°): it slides with
// a = g (sin θ − μ_k cos θ) = 2.18 m/s², matched to 1 %.
#[test]
fn incline_holds_below_the_friction_angle_and_slides_above_it() {
    let friction = Friction::isotropic(0.5, 0.3);
    for along in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for theta in [24.0, 26.0] {
            let (dx, _) = incline(theta, friction, along, 0.5);
            println!(
                "{theta}° (below tan⁻¹0.5 = 26.57°), rod along {along:?}: moved {dx:.3e} m in 0.5 s"
            );
            assert!(
                dx.abs() < 5e-5,
                "the rod slid {dx} m below the friction angle"
            );
        }
        for theta in [27.0f64, 29.0] {
            let (dx, a) = incline(theta, friction, along, 0.5);
            let th = theta.to_radians();
            let expected = G * (th.sin() - 0.3 * th.cos());
            println!(
                "{theta}° rod along {along:?}: moved {dx:.3e} m, acceleration {a:.4} m/s² vs Coulomb {expected:.4}"
            );
            assert!(dx > 0.05);
            assert!((a - expected).abs() < 0.01 * expected, "{a} vs {expected}");
        }
    }
}

// A rod along x sliding on a level plane with anisotropic kinetic friction (forward 0.1,
// backward 0.4, lateral 0.6; static equal to kinetic) decelerates at μ g in each direction:
// forward = +x (its tangent), backward = −x, lateral = ±y. Matched to 1 %.
#[test]
fn anisotropic_kinetic_friction_decelerates_at_mu_g() {
    let mu = [0.1, 0.4, 0.6];
    let friction = Friction {
        static_mu: mu,
        kinetic_mu: mu,
    };
    for (v0, expected_mu) in [
        ([1.0, 0.0, 0.0], mu[0]),
        ([-1.0, 0.0, 0.0], mu[1]),
        ([0.0, 1.0, 0.0], mu[2]),
        ([0.0, -1.0, 0.0], mu[2]),
    ] {
        let mut sim = moving_rod_on_floor([1.0, 0.0, 0.0], [0.0, 0.0, -G], friction, v0);
        sim.run(2000).unwrap(); // 0.04 s: the initial contact transient has passed
        let (va, ta) = (com_velocity(&sim), sim.time());
        sim.run(2500).unwrap();
        let (vb, tb) = (com_velocity(&sim), sim.time());
        let dv = [vb[0] - va[0], vb[1] - va[1], vb[2] - va[2]];
        let decel = -(dv[0] * v0[0] + dv[1] * v0[1]) / (tb - ta);
        let sideways = (dv[0] * v0[1] - dv[1] * v0[0]).abs() / (tb - ta);
        println!(
            "sliding {v0:?}: deceleration {decel:.4} m/s² vs μ g = {:.4}, sideways {sideways:.2e}",
            expected_mu * G
        );
        assert!((decel - expected_mu * G).abs() < 0.01 * expected_mu * G);
        assert!(sideways < 1e-3 * expected_mu * G);
        assert!(norm(vb) > 0.2, "still sliding");
    }
}
