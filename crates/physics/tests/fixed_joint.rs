//! Two rods joined end to end by a fixed joint behave as one rod, up to the joint's own compliance.
//!
//! Claim: rod A (n = 10 elements, length L/2, clamped base) whose tip is joined by a
//! `JointKind::Fixed` joint with `JointParams::default_for` to the base of rod B (n elements,
//! L/2, free tip; B starts where A ends, same direction and frame) behaves like one cantilever of
//! 2n elements and length L (L = 1 m, r̂ = 50 mm, ρ = 1000, E = 1e6, G = E/3, default α_c):
//! * statics, lateral tip force P (δ ≈ 5e-3 L), relaxed by mass-proportional damping: every node
//!   of A sits where the single rod's node i does, every node of B where the single rod's node
//!   n + i does, shifted by the joint's gap P/k along the force;
//! * the first bending frequency (undamped, amplitude 1e-6 m) differs from the single rod's by
//!   the joint's compliance, δω/ω ≈ −9.3e-5, as predicted below.
//!
//! Expected difference (derived for this test, linear theory). The default joint has translational
//! stiffness k = E Â/l̂ (the end element's axial stiffness) and rotational stiffness
//! k_t = E I/l̂, the bending stiffness B/D̂ of the Voronoi point the single rod has at the
//! junction (D̂ = l̂). Compared with the single rod, the joined system
//! * replaces that Voronoi point by the rotational spring: in planar bending the Voronoi couple is
//!   B θ/D̂ for a relative rotation θ, i.e. k_t θ, and its bend–twist term ½ D̂ κ × τ vanishes
//!   (κ ∥ τ); the twist stiffness differs (k_t vs G I₃/D̂) but planar bending does not twist;
//!   the spring lacks the 1/ε³ of the Voronoi couple: with the junction's axial strain
//!   P θ_J/(E Â) ≈ 5e-8 (θ_J ≈ 5.6e-3 the slope there) the junction couple differs by
//!   3(ε − 1) ≈ 1.6e-7, which moves B through the junction's share (3/4)(l̂/L) of δ by
//!   ≈ 2.8e-11 m = 6e-5 of the gap below;
//! * splits the junction node into two half-mass nodes joined by the spring k, isotropic: the
//!   force transmitted through the junction is the tip load, F = −P e_y in every configuration of
//!   a static state, so the gap is exactly F/k, parallel to F (so it adds no moment), and rod B is
//!   translated by it: Δδ = P/k = P l̂/(E Â) at every node of B, nothing on A. Relative to the
//!   tip deflection P L³/(3EI) this is (3/4)(r̂/L)² (l̂/L) ≈ 1e-4: O(1/n), times (r̂/L)².
//!
//! Dynamically the two half nodes move together at low frequency, so the masses are the single
//! rod's; the added compliance 1/k carrying the mode's shear force V at the junction lowers ω by
//! the Rayleigh estimate δω/ω = −½ (V²/k) / (∫ EI w''² + ∫ V²/(α_c G Â)), evaluated with the
//! Euler–Bernoulli cantilever mode on the span L − l̂/2 (the clamp sits at the middle of
//! element 0, spec §7) by Simpson's rule: −9.27e-5 (−8.4e-5 on the span L).
//!
//! A ×100 stiffer joint (both stiffnesses) is not the single rod: its translational part shrinks
//! the gap to P/(100k), but its rotational part makes the junction 100× stiffer than the Voronoi
//! point it replaces, removing 99 % of that point's bending compliance l̂/(EI) under the junction
//! moment P L/2: Δδ = −0.99 (P/k + P (L/2)² l̂/(EI)), ≈ −0.99 (3/4)(l̂/L) P L³/(3EI) ≈ −4 % of δ,
//! the O(1/n) size of one Voronoi point. So a stiffer joint does change the bending result, by
//! exactly the compliance the default reproduces; the test checks the change against this
//! prediction. With the rotational stiffness set to 0 (a free joint) the junction carries no
//! moment: rod B turns about it, overdamped by the mass-proportional damping (torque ν I_B φ̇
//! about the joint, I_B of B's node masses and element inertias): φ̇ = P (L/2) cos φ/(ν I_B),
//! φ = gd(Ω₀ t), so its tip moves by (L/2) sin φ = (L/2) tanh(Ω₀ t_eff) with Ω₀ = P (L/2)/(ν I_B),
//! t_eff = T − T_ramp/2 − 1/ν (ramp and inertial lag), less A's tip deflection under the joint's
//! reaction P/2 (for a uniform rod turning about one end in a viscous medium the drag is 3P/2,
//! so the pivot pulls back with P/2): ≈ 27× the single rod's deflection at T = 15 s, and still
//! moving.
//!
//! Measured (reference run): single-rod tip deflection 4.6603 mm; joined − single at B's nodes
//! equals P/k = 4.6875e-7 m to 6.0e-5 of the gap, at A's nodes to 7e-9 of it; ×100 joint change
//! −1.86074e-4 m vs predicted −1.86089e-4 m (−8e-5 relative); free joint 0.12552 m vs 0.12504 m
//! predicted (+0.4 %); frequency 2.904104 rad/s (single), shift −9.186e-5 against −9.270e-5
//! predicted (−0.9 %).
//!
//! How a wrong implementation fails: a joint whose couple has the wrong sign or acts on the wrong
//! elements has no equilibrium or a large shape error; a wrong rest rotation bends B; a wrong
//! default stiffness (e.g. E Â instead of E Â/l̂, or B̄/L) changes the gap or the junction
//! compliance by orders of magnitude beyond 1e-3 of the gap; a joint force not equal and opposite,
//! or applied to the wrong nodes, breaks the node-by-node match; a "free" joint that still
//! transmitted a moment would stop B near the single rod's shape. (Injected in a scratch copy of
//! the crate while writing this test: the couple's sign flipped, k_t halved, the joint force
//! missing on the second node, a 0.01 rad error in the rest rotation, a frame-free clamp: each
//! fails it.)
//!
//! Tolerances:
//! * node-by-node statics, 1e-3 P/k (4.7e-10 m, 1e-7 of δ): the 1/ε³ difference above, 6e-5 of
//!   P/k; relaxation error ≤ max|v|/λ (max|v| < 1e-10 m/s, slowest decay λ ≈ 2.2 s⁻¹ for ν = 6 s⁻¹
//!   and ω₁ = 2.9 rad/s: ≤ 1e-4 of P/k); round-off ~1e-16 m;
//! * ×100 joint, change within 1e-3 of the prediction: the linear prediction neglects the
//!   shortening of the moment arm and of the lever, O(θ_tip²) ≈ 6e-5;
//! * free joint within 2 % of the viscous-pendulum prediction: neglected are B's own bending
//!   under its drag (< 1e-3), the lag approximation during the ramp and the motion of the pivot
//!   (A's tip);
//! * frequency shift within 5 % of the Rayleigh estimate: the estimate uses the continuum mode of
//!   the clamp-offset span, exact at first order; neglected are O(1/n²) ≈ 0.3 %, rotary inertia
//!   and the Timoshenko change of the mode shape (≈ 1 %); the crossings fit resolves ω to ~1e-8.

use octoarm_physics::{
    Damping, EndCondition, Joint, JointEnd, JointKind, JointParams, Load, Material, RodAccess,
    RodModel, RodSpec, RodState, Schedule, Settings, Side, Simulation, StraightRod, SystemBuilder,
    Vec3,
};
use std::f64::consts::PI;
use std::sync::Arc;

const N_EACH: usize = 10;
const LENGTH: f64 = 1.0;
const RADIUS: f64 = 0.05;
const DENSITY: f64 = 1000.0;
const YOUNG: f64 = 1.0e6;
const ALPHA_C: f64 = Material::DEFAULT_SHEAR_COEFFICIENT;
/// Tip force as a fraction of 3EI/L³ (the Euler–Bernoulli tip deflection over L).
const LOAD: f64 = 5e-3;
const RAMP: f64 = 2.0;
const STATIC_TIME: f64 = 15.0;
const DAMPING_RATE: f64 = 6.0;
const PERIODS: f64 = 10.0;
const AMPLITUDE: f64 = 1.0e-6;
/// Clamped–free root of cos β cosh β = −1.
const BETA_CANTILEVER: f64 = 1.875_104_068_711_961;

fn material() -> Material {
    Material {
        density: DENSITY,
        youngs_modulus: YOUNG,
        shear_modulus: YOUNG / 3.0,
        shear_coefficient: ALPHA_C,
    }
}

fn area() -> f64 {
    PI * RADIUS * RADIUS
}

fn bend_stiffness() -> f64 {
    YOUNG * PI * RADIUS.powi(4) / 4.0
}

fn tip_force() -> f64 {
    LOAD * 3.0 * bend_stiffness() / LENGTH.powi(3)
}

fn element_length() -> f64 {
    LENGTH / (2 * N_EACH) as f64
}

/// The half rods: model, A's state (from the origin) and B's state (from A's tip).
fn half_rods() -> (RodModel, RodState, RodState) {
    let rod = StraightRod::uniform(N_EACH, 0.5 * LENGTH, 2.0 * RADIUS, material());
    let (model, a) = rod.build().unwrap();
    let mut second = rod.clone();
    second.base_position = [0.5 * LENGTH, 0.0, 0.0];
    let (_, b) = second.build().unwrap();
    (model, a, b)
}

fn default_params() -> JointParams {
    let (model, _, _) = half_rods();
    JointParams::default_for((&model, Side::Tip), (&model, Side::Base))
}

#[derive(Clone, Copy)]
enum Variant {
    Single,
    Jointed(JointParams),
}

/// A simulation of the variant with every rod damped at `rate`, dt = 0.2 × its stable dt;
/// returns it with the (rod, node) of the free tip.
fn build(variant: Variant, rate: f64) -> (Simulation, usize, usize) {
    let mut builder = SystemBuilder::new(Settings::default());
    let damping = Damping::mass_proportional(rate);
    let tip = match variant {
        Variant::Single => {
            let (model, state) = StraightRod::uniform(2 * N_EACH, LENGTH, 2.0 * RADIUS, material())
                .build()
                .unwrap();
            builder.rod(RodSpec {
                damping,
                ..RodSpec::cantilever("single", Arc::new(model), state)
            });
            (0, 2 * N_EACH)
        }
        Variant::Jointed(params) => {
            let (model, a, b) = half_rods();
            let model = Arc::new(model);
            builder.rod(RodSpec {
                damping,
                ..RodSpec::cantilever("a", Arc::clone(&model), a)
            });
            builder.rod(RodSpec {
                name: "b".into(),
                model,
                state: b,
                base: EndCondition::Free,
                tip: EndCondition::Free,
                damping,
            });
            builder.joint(Joint::new(
                JointKind::Fixed,
                JointEnd {
                    rod: 0,
                    side: Side::Tip,
                },
                JointEnd {
                    rod: 1,
                    side: Side::Base,
                },
                params,
            ));
            (1, N_EACH)
        }
    };
    let (mut system, state) = builder.build().unwrap();
    let dt = 0.2 * system.stable_dt();
    system.set_settings(Settings::with_dt(dt)).unwrap();
    (Simulation::from_parts(system, state), tip.0, tip.1)
}

/// Every node of the system, rod by rod.
fn nodes(sim: &Simulation) -> Vec<Vec3> {
    (0..sim.system.rods().len())
        .flat_map(|r| sim.system.rod_state(&sim.state, r).position)
        .collect()
}

fn max_speed(sim: &Simulation) -> f64 {
    (0..sim.system.n_nodes())
        .map(|i| {
            let v = sim.state.velocity.get(i);
            (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
        })
        .fold(0.0, f64::max)
}

/// Load the tip with −P e_y (ramped), damp, run `time`; nodes, tip deflection and max |v|.
fn load_and_run(variant: Variant, time: f64) -> (Vec<Vec3>, f64, f64) {
    let (mut sim, rod, tip) = build(variant, DAMPING_RATE);
    sim.system
        .add_load(
            rod,
            Load::NodeForce {
                node: tip,
                force: [0.0, -tip_force(), 0.0],
            },
            Schedule::Ramp { duration: RAMP },
        )
        .unwrap();
    sim.run((time / sim.settings().dt).ceil() as u64).unwrap();
    let deflection = -sim.system.view(&sim.state, rod).position(tip)[1];
    (nodes(&sim), deflection, max_speed(&sim))
}

fn gap() -> f64 {
    tip_force() * element_length() / (YOUNG * area())
}

#[test]
fn default_joint_stiffness_is_the_end_elements() {
    // The prediction rests on k = E Â/l̂ and k_t = E I/D̂ with D̂ = l̂ (uniform rods): checked to
    // round-off.
    let p = default_params();
    let l_hat = element_length();
    assert!((p.stiffness / (YOUNG * area() / l_hat) - 1.0).abs() < 1e-12);
    assert!((p.rotational_stiffness / (bend_stiffness() / l_hat) - 1.0).abs() < 1e-12);
    assert!(p.damping == 0.0 && p.rotational_damping == 0.0);
}

#[test]
fn fixed_joint_statics_are_the_single_rods_plus_the_joint_gap() {
    let (single, d_single, v_single) = load_and_run(Variant::Single, STATIC_TIME);
    let (joined, d_joined, v_joined) =
        load_and_run(Variant::Jointed(default_params()), STATIC_TIME);
    let g = gap();
    println!(
        "single tip deflection {d_single:.10e} m (max|v| {v_single:.1e}), joined {d_joined:.10e} m \
         (max|v| {v_joined:.1e}); difference {:.6e} m, predicted gap P/k = {g:.6e} m ({:.2e} of delta)",
        d_joined - d_single,
        g / d_single
    );
    assert!(v_single < 1e-10 && v_joined < 1e-10, "not relaxed");
    // A's nodes 0..=n against the single rod's 0..=n; B's nodes 0..=n against n..=2n shifted by
    // the gap −(P/k) e_y.
    let mut worst_a: f64 = 0.0;
    let mut worst_b: f64 = 0.0;
    for i in 0..=N_EACH {
        let (a, s) = (joined[i], single[i]);
        worst_a = worst_a.max(norm([a[0] - s[0], a[1] - s[1], a[2] - s[2]]));
        let (b, s) = (joined[N_EACH + 1 + i], single[N_EACH + i]);
        worst_b = worst_b.max(norm([b[0] - s[0], b[1] - s[1] + g, b[2] - s[2]]));
    }
    println!(
        "node-by-node: rod A vs single {:.2e} of P/k, rod B vs single + gap {:.2e} of P/k",
        worst_a / g,
        worst_b / g
    );
    assert!(
        worst_a <= 1e-3 * g,
        "rod A differs from the single rod by {worst_a:e} m"
    );
    assert!(
        worst_b <= 1e-3 * g,
        "rod B differs from the shifted single rod by {worst_b:e} m"
    );
}

#[test]
fn stiffer_joint_removes_the_junction_compliance() {
    let default = default_params();
    let stiff = JointParams {
        stiffness: 100.0 * default.stiffness,
        rotational_stiffness: 100.0 * default.rotational_stiffness,
        ..default
    };
    let (_, d_default, _) = load_and_run(Variant::Jointed(default), STATIC_TIME);
    let (_, d_stiff, v_stiff) = load_and_run(Variant::Jointed(stiff), STATIC_TIME);
    let p = tip_force();
    let junction = p * (0.5 * LENGTH).powi(2) * element_length() / bend_stiffness();
    let predicted = -0.99 * (gap() + junction);
    let change = d_stiff - d_default;
    println!(
        "x100 joint: deflection {d_stiff:.10e} m vs default {d_default:.10e} m: change {change:.6e} m \
         ({:+.3} % of delta), predicted {predicted:.6e} m (rel. diff {:.1e}); max|v| {v_stiff:.1e}",
        100.0 * change / d_default,
        change / predicted - 1.0
    );
    assert!(v_stiff < 1e-10, "not relaxed");
    assert!(
        (change / predicted - 1.0).abs() <= 1e-3,
        "change {change:e} m, predicted {predicted:e} m"
    );
}

#[test]
fn free_joint_turns_like_a_viscous_pendulum() {
    let hinge = JointParams {
        rotational_stiffness: 0.0,
        ..default_params()
    };
    let (_, d_single, _) = load_and_run(Variant::Single, STATIC_TIME);
    let (_, d_hinge, v_hinge) = load_and_run(Variant::Jointed(hinge), STATIC_TIME);
    // Moment of inertia of B about its base node: lumped node masses and element inertias about
    // d2 (both damped at the same rate ν).
    let (model, _, _) = half_rods();
    let l_hat = element_length();
    let inertia: f64 = (0..=N_EACH)
        .map(|i| model.node_mass[i] * (i as f64 * l_hat).powi(2))
        .sum::<f64>()
        + model.inertia.iter().map(|j| j[1]).sum::<f64>();
    let p = tip_force();
    let half = 0.5 * LENGTH;
    let rate = p * half / (DAMPING_RATE * inertia);
    let t_eff = STATIC_TIME - 0.5 * RAMP - 1.0 / DAMPING_RATE;
    let shear = ALPHA_C * YOUNG / 3.0 * area();
    let a_back = 0.5 * p * (half.powi(3) / (3.0 * bend_stiffness()) + half / shear);
    let predicted = half * (rate * t_eff).tanh() - a_back;
    println!(
        "free joint: tip deflection {d_hinge:.6e} m ({:.1}x the single rod's {d_single:.4e} m), \
         viscous-pendulum prediction {predicted:.6e} m (rel. diff {:+.2e}), still moving at {v_hinge:.2e} m/s",
        d_hinge / d_single,
        d_hinge / predicted - 1.0
    );
    assert!(
        (d_hinge / predicted - 1.0).abs() <= 0.02,
        "free joint: deflection {d_hinge} m, predicted {predicted} m"
    );
}

/// d-th derivative of the Euler–Bernoulli cantilever first mode on the span `span`, clamped at
/// x = L − span, evaluated at x (0 before the clamp).
fn cantilever_mode(x: f64, span: f64, d: usize) -> f64 {
    let z = x - (LENGTH - span);
    if z <= 0.0 {
        return 0.0;
    }
    let b = BETA_CANTILEVER;
    let sigma = (b.cosh() + b.cos()) / (b.sinh() + b.sin());
    let u = b * z / span;
    let scale = (b / span).powi(d as i32);
    scale
        * match d % 4 {
            0 => u.cosh() - u.cos() - sigma * (u.sinh() - u.sin()),
            1 => u.sinh() + u.sin() - sigma * (u.cosh() - u.cos()),
            2 => u.cosh() + u.cos() - sigma * (u.sinh() + u.sin()),
            _ => u.sinh() - u.sin() - sigma * (u.cosh() + u.cos()),
        }
}

/// First bending frequency [rad/s]: undamped, initial velocity in the mode, zero crossings of
/// the tip's transverse displacement fitted by a line over `PERIODS` periods.
fn first_frequency(variant: Variant, span: f64, omega_guess: f64) -> f64 {
    let (mut sim, rod, tip) = build(variant, 0.0);
    let v0 = AMPLITUDE * omega_guess;
    for r in 0..sim.system.rods().len() {
        let mut s = sim.system.rod_state(&sim.state, r);
        let n = s.n_elements();
        for i in 0..=n {
            s.velocity[i] = [0.0, v0 * cantilever_mode(s.position[i][0], span, 0), 0.0];
        }
        for j in 0..n {
            let x = 0.5 * (s.position[j][0] + s.position[j + 1][0]);
            s.omega[j] = [0.0, v0 * cantilever_mode(x, span, 1), 0.0];
        }
        sim.system.set_rod_state(&mut sim.state, r, &s).unwrap();
    }
    let dt = sim.settings().dt;
    let steps = (PERIODS * 2.0 * PI / (omega_guess * dt)).ceil() as u64;
    let mut crossings = Vec::new();
    let (mut t_prev, mut y_prev) = (0.0, 0.0_f64);
    for _ in 0..steps {
        sim.step().unwrap();
        let (t, y) = (
            sim.time(),
            sim.system.view(&sim.state, rod).position(tip)[1],
        );
        if y_prev != 0.0 && y.signum() != y_prev.signum() {
            crossings.push(t_prev + (t - t_prev) * y_prev / (y_prev - y));
        }
        (t_prev, y_prev) = (t, y);
    }
    sim.check().unwrap();
    let m = crossings.len();
    assert!(m >= 10, "only {m} zero crossings");
    let k_mean = 0.5 * (m as f64 - 1.0);
    let t_mean = crossings.iter().sum::<f64>() / m as f64;
    let (mut num, mut den) = (0.0, 0.0);
    for (k, t) in crossings.iter().enumerate() {
        num += (k as f64 - k_mean) * (t - t_mean);
        den += (k as f64 - k_mean).powi(2);
    }
    PI / (num / den)
}

#[test]
fn fixed_joint_first_frequency_is_the_single_rods_less_the_joint_compliance() {
    let l_hat = element_length();
    let span = LENGTH - 0.5 * l_hat;
    let ei = bend_stiffness();
    // Rayleigh estimate: −½ (V²/k) / (∫ EI w''² + ∫ (EI w''')²/(α_c G Â)) (Simpson).
    let q = 20_000;
    let h = span / q as f64;
    let shear = ALPHA_C * YOUNG / 3.0 * area();
    let mut energy = 0.0;
    for i in 0..=q {
        let x = LENGTH - span + i as f64 * h;
        let w = if i == 0 || i == q {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let (m, v) = (
            ei * cantilever_mode(x, span, 2),
            ei * cantilever_mode(x, span, 3),
        );
        energy += w * (m * m / ei + v * v / shear);
    }
    energy *= h / 3.0;
    let v_joint = ei * cantilever_mode(0.5 * LENGTH, span, 3);
    let k = default_params().stiffness;
    let predicted = -0.5 * v_joint * v_joint / k / energy;
    let w_eb = (BETA_CANTILEVER / span).powi(2) * (ei / (DENSITY * area())).sqrt();
    let w_single = first_frequency(Variant::Single, span, w_eb);
    let w_joined = first_frequency(Variant::Jointed(default_params()), span, w_eb);
    let shift = w_joined / w_single - 1.0;
    println!(
        "first bending frequency: single {w_single:.10} rad/s, joined {w_joined:.10} rad/s \
         (Euler-Bernoulli on the clamp-offset span {w_eb:.6}); shift {shift:.5e}, predicted \
         {predicted:.5e} (rel. diff {:+.2e})",
        shift / predicted - 1.0
    );
    assert!(
        (shift / predicted - 1.0).abs() <= 0.05,
        "frequency shift {shift:e}, predicted {predicted:e}"
    );
}

fn norm(a: Vec3) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}
