//! Claim (issue 13, item 4): the automatic time step is `AUTO_DT_FRACTION` = 0.2 of the stable
//! limit 2/ω̂_max (spec §11), rounded down so that it divides the sampling interval; the stable
//! limit is re-estimated at the deformed state (`RodSystem::stable_dt_at`), which equals the
//! rest estimate at rest and follows the stiffening of compressed elements (force n/e,
//! couple τ/ε³ of spec §3); and with `Settings::max_dt_fraction` set the guard stops a run whose
//! dt has become too large for the deformed arm, with advice naming a fixed dt.
//!
//! Independent reference: the spec's closed-form per-mode frequencies (§11) and the scaling of
//! the discrete internal loads with the dilatations (§3), evaluated here by hand; Verlet's
//! stability bound ω Δt < 2.
//!
//! How a wrong implementation fails: an estimate that ignores the state (or uses e instead of
//! ε³ for bending) fails the compression case; an auto dt that rounds up, or does not divide
//! the interval, fails `auto_dt_divides_the_interval_below_the_target`; a guard that never
//! re-checks lets the compressed rod pass.

use octoarm_physics::{
    auto_dt, ModelError, Settings, Simulation, StepError, StraightRod, AUTO_DT_FRACTION,
    AUTO_DT_RECHECK,
};

fn paper_sim(settings: Settings) -> Simulation {
    let (model, state) = StraightRod::paper_arm().build().unwrap();
    Simulation::new(model, state, settings).unwrap()
}

#[test]
fn rest_estimate_equals_the_guards_limit() {
    let sim = paper_sim(Settings::default());
    let rest = sim.system.max_frequency();
    let now = sim.system.max_frequency_at(&sim.state);
    assert!(((now - rest) / rest).abs() < 1e-12, "{now} vs {rest}");
    assert!(((sim.system.stable_dt_at(&sim.state) - 2.0 / rest) * rest / 2.0).abs() < 1e-12);
}

#[test]
fn uniform_compression_follows_the_spec_scaling() {
    // Every element compressed to e = 0.8 (positions scaled towards the base): ε = 0.8 too, so
    // the axial/bending term scales by max(1/e², 1/ε³) = 1/0.8³ and the shear–rotation term
    // by max(1, e²) = 1.
    let mut sim = paper_sim(Settings::default());
    let e = 0.8;
    let mut s = sim.rod_state();
    for p in &mut s.position {
        *p = [p[0] * e, p[1] * e, p[2] * e];
    }
    sim.set_rod_state(&s).unwrap();
    let m = sim.model().clone();
    let mat = &m.material;
    let mut expected: f64 = 0.0;
    for j in 0..m.n_elements {
        let axial = 4.0 * mat.youngs_modulus / (mat.density * m.rest_length[j].powi(2));
        let shear = 4.0 * std::f64::consts::PI * mat.shear_coefficient * mat.shear_modulus
            / (mat.density * m.area[j]);
        expected = expected.max(axial / e.powi(3) + shear);
    }
    let got = sim.system.max_frequency_at(&sim.state);
    assert!(
        ((got - expected.sqrt()) / got).abs() < 1e-9,
        "{got} vs {}",
        expected.sqrt()
    );
    assert!(got > sim.system.max_frequency());

    // Stretched to e = 1.5: the axial term falls by 1/e² (ε³ > e²) and the shear–rotation
    // term rises by e².
    let e = 1.5;
    let mut s = sim.rod_state();
    let rest = StraightRod::paper_arm().build().unwrap().1;
    for (p, p0) in s.position.iter_mut().zip(&rest.position) {
        *p = [p0[0] * e, p0[1] * e, p0[2] * e];
    }
    sim.set_rod_state(&s).unwrap();
    let mut expected: f64 = 0.0;
    for j in 0..m.n_elements {
        let axial = 4.0 * mat.youngs_modulus / (mat.density * m.rest_length[j].powi(2));
        let shear = 4.0 * std::f64::consts::PI * mat.shear_coefficient * mat.shear_modulus
            / (mat.density * m.area[j]);
        expected = expected.max(axial / (e * e) + shear * e * e);
    }
    let got = sim.system.max_frequency_at(&sim.state);
    assert!(((got - expected.sqrt()) / got).abs() < 1e-9);
}

#[test]
fn auto_dt_divides_the_interval_below_the_target() {
    for (limit, interval) in [
        (1.97e-4, 1e-3),
        (1.97e-4, 1e-2),
        (1e-3, 1e-3),
        (3.3e-7, 1e-3),
        (1.0, 1e-3),
        (2e-4, 3.9e-5),
    ] {
        let dt = auto_dt(limit, interval).unwrap();
        let target = AUTO_DT_FRACTION * limit;
        assert!(dt <= target, "{dt} > {target}");
        let steps = (interval / dt).round();
        assert!(
            ((steps * dt - interval) / interval).abs() < 1e-12,
            "{interval}/{dt}"
        );
        // The largest such: one step fewer would exceed the target.
        if steps > 1.0 {
            assert!(interval / (steps - 1.0) > target * (1.0 - 1e-12));
        }
        assert!(dt * 2.0 / limit < 2.0, "Verlet bound");
    }
    for (limit, interval) in [
        (0.0, 1e-3),
        (f64::NAN, 1e-3),
        (f64::INFINITY, 1e-3),
        (1e-4, 0.0),
        (1e-4, -1.0),
        (1e-4, f64::NAN),
    ] {
        assert_eq!(auto_dt(limit, interval), None, "{limit} {interval}");
    }
}

#[test]
fn bad_recheck_fraction_is_refused_naming_the_field() {
    for f in [0.0, -0.5, 1.5, f64::NAN, f64::INFINITY] {
        let settings = Settings {
            max_dt_fraction: Some(f),
            ..Settings::default()
        };
        let (model, state) = StraightRod::paper_arm().build().unwrap();
        match Simulation::new(model, state, settings) {
            Err(ModelError::OutOfRange { field, .. }) => assert_eq!(field, "max_dt_fraction"),
            other => panic!("{f}: {other:?}"),
        }
    }
}

#[test]
fn guard_rechecks_the_automatic_step_as_the_arm_deforms() {
    let limit = paper_sim(Settings::default()).system.stable_dt();
    // dt at 0.49 of the rest limit passes a re-check at 0.5 on the straight arm ...
    let settings = Settings {
        dt: 0.49 * limit,
        max_dt_fraction: Some(AUTO_DT_RECHECK),
        ..Settings::default()
    };
    let mut sim = paper_sim(settings);
    sim.check().unwrap();
    // ... and fails once the tip elements are compressed to e = 0.7 (1/ε³ = 2.9 on the axial/bending
    // term: ω̂ up ≈ 10 % at the tip, where the shear–rotation term dominates).
    let mut s = sim.rod_state();
    let n = s.position.len() - 1;
    let x0 = s.position[n - 10];
    for i in n - 9..=n {
        let p = s.position[i];
        s.position[i] = [
            x0[0] + 0.7 * (p[0] - x0[0]),
            x0[1] + 0.7 * (p[1] - x0[1]),
            x0[2] + 0.7 * (p[2] - x0[2]),
        ];
    }
    sim.set_rod_state(&s).unwrap();
    let e = sim.check().unwrap_err();
    let StepError::Unstable {
        what,
        value,
        index,
        advice,
        ..
    } = &e;
    assert!(what.contains("automatic time step"), "{e}");
    assert!(*value > AUTO_DT_RECHECK, "{e}");
    assert!(*index >= n - 10, "{e}");
    assert!(advice.contains("set a fixed dt"), "{e}");
    // Without the re-check the guard does not look at dt against the deformed limit (it stops
    // this state, if at all, for its energy jump from the straight reference).
    let mut plain = paper_sim(Settings::with_dt(0.49 * limit));
    plain.set_rod_state(&s).unwrap();
    if let Err(StepError::Unstable { what, .. }) = plain.check() {
        assert!(!what.contains("automatic time step"), "{what}");
    }
}

/// `Simulation::use_auto_dt` (the library and Python form of `dt = "auto"`): dt is 0.2 of the
/// stable limit with the guard's re-check armed; a stiffer system added before the first step
/// re-chooses it (here a stiff contact spring, whose frequency the limit includes), one added
/// after the first step does not (dt stays, the guard watches).
#[test]
fn use_auto_dt_follows_the_system_until_the_first_step() {
    use octoarm_physics::{ContactParams, Friction, Sphere};
    let mut sim = paper_sim(Settings::default());
    let dt = sim.use_auto_dt().unwrap();
    let limit = sim.system.stable_dt();
    assert_eq!(dt, AUTO_DT_FRACTION * limit);
    assert_eq!(sim.settings().dt, dt);
    assert_eq!(sim.settings().max_dt_fraction, Some(AUTO_DT_RECHECK));

    // A floor under the arm with a contact spring 400× the default: ω_contact = 20 × the
    // default's, far above the rod's own ω̂_max, so the limit (and dt) must drop.
    add_stiff_floor(&mut sim);
    let stiff = sim.system.stable_dt();
    assert!(
        stiff < 0.5 * limit,
        "contact spring should set the limit: {stiff} vs {limit}"
    );
    assert_eq!(sim.settings().dt, AUTO_DT_FRACTION * stiff);

    sim.run(10).unwrap();
    let dt_run = sim.settings().dt;
    sim.set_contact(ContactParams {
        beta: 1600.0,
        ..ContactParams::default()
    })
    .unwrap();
    sim.add_obstacle(Sphere {
        center: [0.1, 0.2, 0.0],
        radius: 0.01,
        velocity: [0.0; 3],
        friction: Friction::NONE,
    })
    .unwrap();
    assert_eq!(
        sim.settings().dt,
        dt_run,
        "dt must not change once stepping has begun"
    );
}

/// Without `use_auto_dt` the mutators leave dt as given.
#[test]
fn fixed_dt_is_never_rechosen() {
    let mut sim = paper_sim(Settings::with_dt(1e-5));
    add_stiff_floor(&mut sim);
    assert_eq!(sim.settings().dt, 1e-5);
    assert_eq!(sim.settings().max_dt_fraction, None);
}

/// A frictionless floor 5 cm below the arm, with a contact spring 400× the default (β = 400).
fn add_stiff_floor(sim: &mut Simulation) {
    use octoarm_physics::{ContactParams, Friction, Plane};
    sim.add_plane(Plane::new(
        [0.0, -0.05, 0.0],
        [0.0, 1.0, 0.0],
        Friction::NONE,
    ))
    .unwrap();
    sim.set_contact(ContactParams {
        beta: 400.0,
        ..ContactParams::default()
    })
    .unwrap();
}
