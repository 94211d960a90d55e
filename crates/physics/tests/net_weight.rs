//! Claims (muscles-3d spec §3.3): the optional net weight in water, (ρ − ρ_w) g Â_j l̂_j per
//! element split ½/½ onto its nodes, sums on COOMM's arm to (ρ − ρ_w) g V with V the rest
//! volume, vanishes for ρ_w = ρ, and a muscular arm hanging under it settles to a static pose
//! whose base reaction balances it.
//!
//! Independent references: V in closed form — the elements sample the linear radius at their
//! midpoints, so Σ π r̂_j² l̂ is the midpoint rule for the cone's ∫ π r² ds, whose error for
//! the quadratic r² is exactly −π l̂² (r_t − r_b)²/(12 L); statics — at rest the base
//! reaction (−F_int of node 0) equals minus the load on the free nodes 1..n.
//!
//! How a wrong implementation fails: ρ in place of ρ − ρ_w (or ρ_w − ρ) misses the sum by 20×
//! or flips it; a load on one node per element or on element counts fails the per-node check;
//! a load not applied in the stepper leaves the reaction at zero.

mod common;

use common::max_norm;
use octoarm_physics::muscles::group;
use octoarm_physics::{Damping, Load, ModelError, MuscleSpec, Settings, Simulation, StraightRod};

const G: [f64; 3] = [0.0, 0.0, -9.81];

fn acceleration(load: &Load) -> [f64; 3] {
    match load {
        Load::Gravity { acceleration } => *acceleration,
        other => panic!("not a gravity-like load: {other:?}"),
    }
}

// The load's total and its per-node values on the COOMM arm (n = 100): the sum to 1e-13 of
// (ρ − ρ_w) g V with V of the closed form; node i receives ½ (ρ − ρ_w) g (Â_{i−1} l̂ + Â_i l̂).
#[test]
fn net_weight_sums_to_buoyancy_corrected_weight() {
    let (model, _) = StraightRod::coomm_arm().build().unwrap();
    let n = model.n_elements;
    let (rb, rt, l0) = (0.012, 0.0012, 0.2);
    let h = l0 / n as f64;
    let pi = std::f64::consts::PI;
    let volume = pi * l0 / 3.0 * (rb * rb + rb * rt + rt * rt)
        - pi * h * h * (rt - rb).powi(2) / (12.0 * l0);
    for rho_w in [1000.0, 1022.0, 0.0] {
        let load = Load::net_weight(&model, rho_w, G).unwrap();
        let acc = acceleration(&load);
        let f = 1050.0 - rho_w;
        let mut total = [0.0; 3];
        for (i, m) in model.node_mass.iter().enumerate() {
            let mut share = 0.0;
            if i > 0 {
                share += 0.5 * pi * model.radius[i - 1].powi(2) * h;
            }
            if i < n {
                share += 0.5 * pi * model.radius[i].powi(2) * h;
            }
            for k in 0..3 {
                let fi = m * acc[k];
                assert!((fi - f * G[k] * share).abs() <= 1e-12 * (f * 9.81 * share).abs());
                total[k] += fi;
            }
        }
        for k in 0..3 {
            let expect = f * G[k] * volume;
            assert!(
                (total[k] - expect).abs() <= 1e-13 * (f * 9.81 * volume),
                "ρ_w = {rho_w}: {total:?} vs {expect}"
            );
        }
    }
    // COOMM's arm: 35.15 g (spec §1.1), so V = 3.348e-5 m³.
    assert!((1050.0 * volume - 0.03515).abs() < 5e-6);
    // ρ_w = ρ: no load at all.
    let load = Load::net_weight(&model, 1050.0, G).unwrap();
    assert_eq!(acceleration(&load), [0.0; 3]);
    // Bad inputs are named.
    for (rho_w, g, field) in [
        (-1.0, G, "net_weight.fluid_density"),
        (f64::NAN, G, "net_weight.fluid_density"),
        (1000.0, [0.0, f64::INFINITY, 0.0], "net_weight.gravity"),
    ] {
        let e = Load::net_weight(&model, rho_w, g).unwrap_err();
        match e {
            ModelError::OutOfRange { field: f, .. } | ModelError::BadVector { field: f, .. } => {
                assert_eq!(f, field)
            }
            other => panic!("{other:?}"),
        }
    }
}

// A 20-element COOMM arm with LM0 at 0.3, clamped, under its net weight with g across the arm
// (−e_z, the side LM0 bends to) plus along it, damped (mass-proportional, 2.5 s⁻¹), relaxed
// until every node is slower than 1e-8 m/s: the base reaction equals minus the net weight on
// the free nodes 1..n (node 0's own share goes to the support directly) to 1e-6 of |W| (W at
// ρ_w = 1000 kg/m³; measured 1e-7); with ρ_w = ρ the load is zero and the reaction vanishes
// to the same absolute bound (measured 2.2e-9 N, the relaxation's residual), and the arm sags
// less (tip higher).
#[test]
fn hanging_muscular_arm_balances_net_weight_at_the_base() {
    let g: [f64; 3] = [4.0, 0.0, -9.0];
    let (m20, _) = StraightRod::coomm_arm().with_elements(20).build().unwrap();
    let mass: f64 = m20.node_mass.iter().sum();
    let w_ref = mass * (1.0 - 1000.0 / 1050.0) * (g[0] * g[0] + g[2] * g[2]).sqrt();
    let mut tips = Vec::new();
    for rho_w in [1000.0, 1050.0] {
        let (model, state) = StraightRod::coomm_arm().with_elements(20).build().unwrap();
        let n = model.n_elements;
        let load = Load::net_weight(&model, rho_w, g).unwrap();
        let acc = acceleration(&load);
        let mut sim = Simulation::new(model.clone(), state, Settings::default()).unwrap();
        sim.use_auto_dt().unwrap();
        sim.set_damping(Damping::mass_proportional(2.5)).unwrap();
        sim.set_muscles(Some(MuscleSpec::coomm())).unwrap();
        sim.set_activation(group::LM0, &vec![0.3; n]).unwrap();
        sim.add_load(load).unwrap();
        let t = loop {
            sim.run(1000).unwrap();
            let t = sim.time();
            if max_norm(&sim.rod_state().velocity) < 1e-8 || t > 60.0 {
                break t;
            }
        };
        let free: Vec<f64> = (0..3)
            .map(|k| model.node_mass[1..].iter().map(|m| m * acc[k]).sum())
            .collect();
        let r = sim.base_reaction_force();
        let tip = sim.tip();
        eprintln!("ρ_w = {rho_w}: t = {t:.2} s, tip {tip:?}, reaction {r:?}, free load {free:?}");
        assert!(t <= 60.0, "did not settle");
        for k in 0..3 {
            assert!((r[k] + free[k]).abs() <= 1e-6 * w_ref, "{r:?} vs {free:?}");
        }
        tips.push(tip);
    }
    assert!(
        tips[0][2] < tips[1][2] - 0.01,
        "the net weight makes the arm sag: {tips:?}"
    );
}
