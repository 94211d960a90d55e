//! Claim (spec §13 j, informative smoke test): the paper's arm, given the uniform target curvature
//! κ°2 = 10 1/m at t = 0 (the energy-shaping control for a uniform curvature, spec §9), curls into
//! the discrete arc; with the `mass_proportional` damping preset (ν_d = 10 1/s) it approaches the
//! arc monotonically along the spec's reference curve, with the paper's literal `per_length`
//! damping (γ = 0.01) it oscillates (period ≈ 1.5 s) and is still moving at t = 8 s.
//!
//! Independent reference: the target is the exact stress-free equilibrium of the discrete model,
//! the arc whose element j makes the angle j κ° D̂ with e_x (tip computed here in closed form and
//! checked against the spec's (0.092343, 0.140701) m); the time history is the spec's table from an
//! independent implementation. That table reproduces to its last digit only with the shear
//! coefficient α_c = 4/3 (with the default 27/28 the late mass-proportional values are 2–7 %
//! higher, the per-length oscillation up to 30 % different in phase-sensitive samples), so the
//! table is checked at α_c = 4/3 and the default arm is checked for the qualitative behaviour.
//!
//! How a wrong implementation fails: a wrong sign of κ or of the bending couple curls the arm the
//! other way (distance ≈ 1.3 L0) or not at all; a wrong damping module (the rejected rotational
//! reading −γ l̂ ω, per-node γ, or a rate applied to the wrong DOFs) freezes the tip or changes
//! the decay curve far beyond 5 %; a wrong rest-strain handling leaves a residual stress, so the
//! arm settles elsewhere and the distance stops decreasing.

use octoarm_physics::{Damping, Material, Settings, Simulation, StraightRod};

const L0: f64 = 0.2;
const KAPPA: f64 = 10.0;

/// Node i of the discrete arc: element j at angle j θ0, θ0 = κ° D̂ (uniform l̂ = D̂).
fn arc_nodes(n: usize) -> Vec<[f64; 2]> {
    let l_hat = L0 / n as f64;
    let theta0 = KAPPA * l_hat;
    let mut nodes = vec![[0.0; 2]];
    for j in 0..n {
        let last = nodes[j];
        let a = j as f64 * theta0;
        nodes.push([last[0] + l_hat * a.cos(), last[1] + l_hat * a.sin()]);
    }
    nodes
}

/// Run the curling arm; return the tip distance to the arc's tip / L0 at the sample times and
/// the largest node distance to the arc [m] at the last sample.
fn curl(shear_coefficient: f64, damping: Damping, times: &[f64]) -> (Vec<f64>, f64) {
    let mut arm = StraightRod::paper_arm();
    arm.material.shear_coefficient = shear_coefficient;
    arm.rest_curvature = [0.0, KAPPA, 0.0];
    let (model, state) = arm.build().unwrap();
    let n = model.n_elements;
    let dt = 5e-5;
    let mut sim = Simulation::new(model, state, Settings::with_dt(dt)).unwrap();
    sim.set_damping(damping).unwrap();
    let arc = arc_nodes(n);
    let mut out = Vec::new();
    for &t in times {
        let steps = ((t - sim.state.time) / dt).round() as u64;
        sim.run(steps).unwrap();
        let tip = sim.tip();
        out.push((tip[0] - arc[n][0]).hypot(tip[1] - arc[n][1]) / L0);
    }
    let worst = sim
        .rod_state()
        .position
        .iter()
        .zip(&arc)
        .map(|(x, a)| (x[0] - a[0]).hypot(x[1] - a[1]))
        .fold(0.0, f64::max);
    (out, worst)
}

const TIMES: [f64; 5] = [0.5, 1.0, 1.5, 2.0, 2.5];

#[test]
fn target_arc_matches_spec() {
    let tip = arc_nodes(100)[100];
    println!(
        "discrete arc tip = ({:.6}, {:.6}) m (spec (0.092343, 0.140701))",
        tip[0], tip[1]
    );
    // The spec prints 6 decimals: agreement to 1e-6 m.
    assert!((tip[0] - 0.092343).abs() < 1e-6 && (tip[1] - 0.140701).abs() < 1e-6);
}

// The spec's table at α_c = 4/3. Tolerance 5 % relative per sample for both presets: the table
// carries 2–3 significant digits (0.0096 and 0.047 are known to ±0.5 % and ±1 %); a correct
// implementation of the same formulas matches it to those digits (measured ≤ 0.9 %), while a
// 10 % error in a damping rate moves the t = 2.5 s mass-proportional value by ~25 % and shifts
// the per-length oscillation phase, and the default α_c's 1.3 % change in the late decay rate
// already gives 6.7 %.
#[test]
fn reference_table_at_alpha_four_thirds() {
    let ac = 4.0 / 3.0;
    let reference = [0.611, 0.228, 0.081, 0.028, 0.0096];
    let (dist, _) = curl(ac, Damping::mass_proportional(10.0), &TIMES);
    for ((t, d), r) in TIMES.iter().zip(&dist).zip(&reference) {
        println!(
            "alpha_c = 4/3, mass_proportional: t = {t} s: |tip - target|/L0 = {d:.4} (ref {r})"
        );
        assert!(
            (d / r - 1.0).abs() < 0.05,
            "t = {t} s: distance {d} vs reference {r}"
        );
    }
    assert!(
        dist.windows(2).all(|w| w[1] < w[0]),
        "distance must decrease monotonically: {dist:?}"
    );

    let reference = [0.047, 0.356, 0.505, 0.073, 0.227];
    let mut times = TIMES.to_vec();
    times.push(8.0);
    let (dist, worst_at_8) = curl(ac, Damping::per_length(0.01), &times);
    for ((t, d), r) in times.iter().zip(&dist).zip(&reference) {
        println!("alpha_c = 4/3, per_length: t = {t} s: |tip - target|/L0 = {d:.4} (ref {r})");
        assert!(
            (d / r - 1.0).abs() < 0.05,
            "t = {t} s: distance {d} vs reference {r}"
        );
    }
    // The spec quotes a max node error of 8.6e-4 m at t = 8 s, without a tolerance; here it is
    // only required that the arm is still visibly moving (mass-proportional damping would have
    // brought it to ~1e-7 m by then): above 2e-4 m = 0.1 % of L0.
    println!(
        "alpha_c = 4/3, per_length: t = 8 s: max node error {worst_at_8:.3e} m (spec 8.6e-4 m)"
    );
    assert!(
        worst_at_8 > 2e-4,
        "per_length arm already at rest at 8 s: {worst_at_8:e} m"
    );
}

// The product's default arm (α_c = 27/28): the same qualitative behaviour. mass_proportional:
// monotone approach, more than half an arm length away at 0.5 s (the arm needs time to curl),
// within 2 % of L0 at 2.5 s (the α_c = 4/3 reference is 0.96 %). per_length: the distance
// rises again after 0.5 s and after 2 s (oscillation with period ≈ 1.5 s).
#[test]
fn default_arm_curls_into_the_arc() {
    let ac = Material::DEFAULT_SHEAR_COEFFICIENT;
    let (dist, _) = curl(ac, Damping::mass_proportional(10.0), &TIMES);
    println!("alpha_c = 27/28, mass_proportional: {dist:.4?}");
    assert!(
        dist.windows(2).all(|w| w[1] < w[0]),
        "distance must decrease monotonically: {dist:?}"
    );
    assert!(dist[0] > 0.5 && dist[4] < 0.02, "{dist:?}");
    let (dist, _) = curl(ac, Damping::per_length(0.01), &TIMES);
    println!("alpha_c = 27/28, per_length: {dist:.4?}");
    assert!(
        dist[1] > dist[0] && dist[2] > dist[1] && dist[3] < dist[2] && dist[4] > dist[3],
        "no oscillation: {dist:?}"
    );
}
