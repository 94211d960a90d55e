//! Claim (issue; style guide "Errors"): every bad parameter — non-positive length, moduli,
//! density, diameters or dt, fewer than 2 elements, NaN or infinite values, a `normal` not
//! perpendicular to `direction`, wrong array lengths, bad loads, damping and obstacles — is
//! rejected before the first step with a `ModelError` whose message names the field, the value
//! and the allowed range.
//!
//! Independent reference: the allowed ranges themselves (physical positivity, finiteness,
//! orthogonality of the frame), and the message format of the style guide,
//! "{field} = {value} is outside the allowed range {range}".
//!
//! How a wrong implementation fails: a missing check lets NaN or a zero modulus through to the
//! stepper (NaN output or a division by zero at the first step, caught here because `build`/`new`
//! returns Ok); a comparison written as `value <= 0.0 → error` lets NaN pass (NaN compares false);
//! a message without the field name, the value or the range fails the text assertions.

use octoarm_physics::{
    ContactParams, Damping, Load, Material, ModelError, RodModel, Schedule, Settings, Simulation,
    Sphere, StraightRod,
};

/// Assert that `result` is an error whose message contains every fragment; return the message.
fn rejects<T: std::fmt::Debug>(result: Result<T, ModelError>, fragments: &[&str]) -> String {
    let err = result.expect_err("bad input was accepted");
    let msg = err.to_string();
    for f in fragments {
        assert!(msg.contains(f), "message {msg:?} lacks {f:?}");
    }
    msg
}

const POSITIVE: &str = "(0, inf), finite";
const BAD_NUMBERS: [f64; 5] = [0.0, -1.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY];

fn shown(v: f64) -> String {
    format!("{v}")
}

#[test]
fn exact_message_format() {
    let mut rod = StraightRod::paper_arm();
    rod.length = -0.2;
    let msg = rejects(rod.build(), &[]);
    assert_eq!(
        msg,
        "length = -0.2 is outside the allowed range (0, inf), finite"
    );
    let mut rod = StraightRod::paper_arm();
    rod.n_elements = 1;
    let msg = rejects(rod.build(), &[]);
    assert_eq!(msg, "n_elements = 1 is outside the allowed range [2, inf)");
    let msg = rejects(
        Simulation::new(
            StraightRod::paper_arm().build().unwrap().0,
            StraightRod::paper_arm().build().unwrap().1,
            Settings::with_dt(0.0),
        ),
        &[],
    );
    assert_eq!(msg, "dt = 0 is outside the allowed range (0, inf), finite");
}

#[test]
fn rod_scalars_must_be_positive_and_finite() {
    type Setter = fn(&mut StraightRod, f64);
    let fields: [(&str, Setter); 7] = [
        ("length", |r, v| r.length = v),
        ("base_diameter", |r, v| r.base_diameter = v),
        ("tip_diameter", |r, v| r.tip_diameter = v),
        ("density", |r, v| r.material.density = v),
        ("youngs_modulus", |r, v| r.material.youngs_modulus = v),
        ("shear_modulus", |r, v| r.material.shear_modulus = v),
        ("shear_coefficient", |r, v| r.material.shear_coefficient = v),
    ];
    for (name, set) in fields {
        for v in BAD_NUMBERS {
            let mut rod = StraightRod::paper_arm();
            set(&mut rod, v);
            let msg = rejects(rod.build(), &[&format!("{name} = {}", shown(v)), POSITIVE]);
            println!("{msg}");
        }
    }
}

#[test]
fn element_count_at_least_two() {
    for n in [0, 1] {
        let rod = StraightRod::paper_arm().with_elements(n);
        rejects(rod.build(), &[&format!("n_elements = {n}"), "[2, inf)"]);
    }
    let m = Material {
        density: 1.0,
        youngs_modulus: 1.0,
        shear_modulus: 1.0,
        shear_coefficient: 1.0,
    };
    rejects(
        RodModel::from_elements(&[0.1], &[0.01], m),
        &["n_elements = 1", "[2, inf)"],
    );
    assert!(StraightRod::paper_arm().with_elements(2).build().is_ok());
}

#[test]
fn per_element_arrays_are_checked() {
    let m = Material {
        density: 1.0,
        youngs_modulus: 1.0,
        shear_modulus: 1.0,
        shear_coefficient: 1.0,
    };
    for v in BAD_NUMBERS {
        rejects(
            RodModel::from_elements(&[0.1, v, 0.1], &[0.01; 3], m),
            &[&format!("rest_length = {}", shown(v)), POSITIVE],
        );
        rejects(
            RodModel::from_elements(&[0.1; 3], &[0.01, 0.01, v], m),
            &[&format!("radius = {}", shown(v)), POSITIVE],
        );
    }
    rejects(
        RodModel::from_elements(&[0.1; 3], &[0.01; 2], m),
        &["radius", "length 2", "expected 3"],
    );
    let (mut model, _) = StraightRod::paper_arm().build().unwrap();
    let n = model.n_elements;
    rejects(
        model.set_rest_strains(&vec![[0.0; 3]; n - 1], &vec![[0.0; 3]; n - 1]),
        &["rest_sigma", "expected 100"],
    );
    let mut kappa = vec![[0.0; 3]; n - 1];
    kappa[5][1] = f64::NAN;
    rejects(
        model.set_rest_strains(&vec![[0.0; 3]; n], &kappa),
        &["rest_kappa", "NaN", "finite"],
    );
}

#[test]
fn frame_vectors_are_checked() {
    // normal not perpendicular to direction
    let mut rod = StraightRod::paper_arm();
    rod.normal = [1.0, 1.0, 0.0];
    let msg = rejects(
        rod.build(),
        &[
            "normal",
            "[1.0, 1.0, 0.0]",
            "perpendicular to direction",
            "1e-10",
        ],
    );
    println!("{msg}");
    // zero-length and non-finite vectors
    let mut rod = StraightRod::paper_arm();
    rod.direction = [0.0; 3];
    rejects(
        rod.build(),
        &["direction", "[0.0, 0.0, 0.0]", "non-zero length"],
    );
    let mut rod = StraightRod::paper_arm();
    rod.normal = [0.0, f64::NAN, 0.0];
    rejects(rod.build(), &["normal", "NaN", "finite"]);
    let mut rod = StraightRod::paper_arm();
    rod.direction = [f64::INFINITY, 0.0, 0.0];
    rejects(rod.build(), &["direction", "inf", "finite"]);
    let mut rod = StraightRod::paper_arm();
    rod.base_position = [0.0, 0.0, f64::NEG_INFINITY];
    rejects(rod.build(), &["base_position", "-inf", "finite"]);
    let mut rod = StraightRod::paper_arm();
    rod.rest_curvature = [0.0, f64::NAN, 0.0];
    rejects(rod.build(), &["rest_curvature", "NaN", "finite"]);
    // A slightly non-unit but perpendicular pair is accepted (both are normalised).
    let mut rod = StraightRod::paper_arm();
    rod.direction = [2.0, 0.0, 0.0];
    rod.normal = [0.0, 0.5, 0.0];
    assert!(rod.build().is_ok());
}

#[test]
fn time_step_and_settings_are_checked() {
    for v in BAD_NUMBERS {
        let (model, state) = StraightRod::paper_arm().build().unwrap();
        rejects(
            Simulation::new(model, state, Settings::with_dt(v)),
            &[&format!("dt = {}", shown(v)), POSITIVE],
        );
    }
    let (model, state) = StraightRod::paper_arm().build().unwrap();
    let settings = Settings {
        guard_interval: 0,
        ..Settings::default()
    };
    rejects(
        Simulation::new(model, state, settings),
        &["guard_interval = 0", "[1, inf)"],
    );
}

#[test]
fn state_must_fit_the_model_and_be_finite() {
    let (model, mut state) = StraightRod::paper_arm().build().unwrap();
    state.velocity[7][2] = f64::NAN;
    rejects(
        Simulation::new(model.clone(), state, Settings::default()),
        &["velocity", "NaN", "finite"],
    );
    let (_, mut state) = StraightRod::paper_arm().build().unwrap();
    state.position.pop();
    rejects(
        Simulation::new(model.clone(), state, Settings::default()),
        &["position", "length 100", "expected 101"],
    );
    let (_, mut state) = StraightRod::paper_arm().build().unwrap();
    state.director[3][0][0] = 1.5;
    rejects(
        Simulation::new(model, state, Settings::default()),
        &["director", "orthonormal"],
    );
}

#[test]
fn loads_damping_and_obstacles_are_checked() {
    let (model, state) = StraightRod::paper_arm().build().unwrap();
    let mut sim = Simulation::new(model, state, Settings::default()).unwrap();
    rejects(
        sim.add_load(Load::tip_force(100, [0.0, f64::NAN, 0.0])),
        &["force", "NaN", "finite"],
    );
    rejects(
        sim.add_load(Load::NodeForce {
            node: 101,
            force: [0.0; 3],
        }),
        &["node = 101", "[0, n_elements]"],
    );
    // A ramp is a schedule now; its duration must be positive (the old `ramp_time = 0` meant "no
    // ramp", which is `Schedule::Constant`).
    rejects(
        sim.add_scheduled_load(
            Load::NodeForce {
                node: 100,
                force: [0.0; 3],
            },
            Schedule::Ramp { duration: -1.0 },
        ),
        &["schedule.duration = -1", POSITIVE],
    );
    rejects(
        sim.add_load(Load::Gravity {
            acceleration: [0.0, f64::INFINITY, 0.0],
        }),
        &["gravity", "inf", "finite"],
    );
    for v in [-1.0, f64::NAN, f64::INFINITY] {
        rejects(
            sim.set_damping(Damping::mass_proportional(v)),
            &[&format!("damping.rate = {}", shown(v)), "[0, inf), finite"],
        );
        rejects(
            sim.set_damping(Damping::per_length(v)),
            &[&format!("damping.gamma = {}", shown(v)), "[0, inf), finite"],
        );
    }
    for v in BAD_NUMBERS {
        rejects(
            sim.add_obstacle(Sphere::fixed([0.1, 0.0, 0.0], v)),
            &[&format!("obstacle.radius = {}", shown(v)), POSITIVE],
        );
        rejects(
            sim.set_contact(ContactParams {
                beta: v,
                zeta: 0.5,
                ..ContactParams::default()
            }),
            &[&format!("contact.beta = {}", shown(v)), POSITIVE],
        );
    }
    rejects(
        sim.add_obstacle(Sphere::fixed([f64::NAN, 0.0, 0.0], 0.01)),
        &["obstacle.center", "NaN", "finite"],
    );
    // Nothing bad was stored.
    assert!(sim.system.loads().is_empty() && sim.system.obstacles().is_empty());
    assert_eq!(sim.damping(), Damping::default());
}
