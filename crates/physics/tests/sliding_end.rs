//! Claim: a driven end with `slides_along` follows its prescribed motion across the slide
//! direction and turns as prescribed, but slides freely along it under the loads on it
//! (cosseratbench's twist experiment: a clamp that turns while a weight sets the tension).
//!
//! Independent reference: statics of a bar. A straight rod clamped at its base, its tip driven
//! (twisted by 1 rad about the rod axis) and free to slide along the axis under a tension F,
//! settles with its tip displaced by Δ = F L / (E Â − F) along the axis (the rod's constitutive
//! law, axial force E Â (e − 1)/e at dilatation e), and its tip stays on the axis (zero across
//! it), to 1e-5, with and without the twist.
//!
//! How a wrong implementation fails: a slide that is not free (the node held) leaves the tip where
//! it started; a slide along the wrong direction or a projection that keeps the wrong component
//! lets the tip leave the axis; a driven frame that is not applied leaves the twist at zero.

use octoarm_physics::{
    Damping, EndCondition, Load, Material, Motion, RodAccess, Settings, Simulation, StraightRod,
};

#[test]
fn a_sliding_driven_end_slides_under_its_load_and_turns_as_prescribed() {
    for (angle, tol) in [(0.0, 1e-5), (1.0, 1e-5)] {
        slide(angle, tol);
    }
}

fn slide(angle: f64, tol: f64) {
    let material = Material {
        density: 1000.0,
        youngs_modulus: 1e6,
        shear_modulus: 1e6 / 3.0,
        shear_coefficient: Material::DEFAULT_SHEAR_COEFFICIENT,
    };
    let (l, d, n) = (0.5, 0.02, 25);
    let (model, state) = StraightRod::uniform(n, l, d, material).build().unwrap();
    let dt = 0.3 * model.stable_dt();
    let motion = Motion {
        times: vec![0.0, 0.5],
        displacement: vec![[0.0; 3]; 2],
        rotation: vec![[0.0; 3], [angle, 0.0, 0.0]],
        slides_along: Some([2.0, 0.0, 0.0]),
    };
    let mut sim = Simulation::with_ends(
        model,
        state,
        EndCondition::Clamped,
        EndCondition::Driven(motion),
        Settings::with_dt(dt),
    )
    .unwrap();
    sim.set_damping(Damping::mass_proportional(30.0)).unwrap();
    let f = 0.5;
    sim.add_load(Load::NodeForce {
        node: n,
        force: [f, 0.0, 0.0],
    })
    .unwrap();
    sim.run((3.0 / dt) as u64).unwrap();
    let v = sim.view();
    let tip = v.position(n);
    let area = std::f64::consts::PI * 0.25 * d * d;
    let expected = f * l / (1e6 * area - f);
    // Twist of the tip frame about x: angle of its d1 from e_y.
    let q = v.director(n - 1);
    let twist = q[0][2].atan2(q[0][1]);
    println!(
        "sliding tip at {tip:?}: stretch {:.6e} m vs F L / (E A - F) = {expected:.6e} m; twist {twist:.4} rad",
        tip[0] - l
    );
    assert!(((tip[0] - l) - expected).abs() < tol * expected);
    assert!(tip[1].abs() < 1e-12 && tip[2].abs() < 1e-12);
    assert!((twist - angle).abs() < 1e-9, "twist {twist}");
}
