//! Claim (issue 11): the scenario format's contact keys — `[[plane]]`, `[[cylinder]]`,
//! `[[obstacle]] friction`, `[contact] rods / self_contact / rod_friction / friction_eta /
//! stick_stiffness / slip_velocity / rod_geometry`, `[numerics] clamp_order` — reach the physics, and bad
//! values are errors naming the key and the allowed range.
//!
//! Reference: the built `RodSystem` (its planes, cylinders, contact parameters and settings), and
//! the error texts. A key that is parsed but not passed on shows as a default in the system; a
//! range not checked shows as a scenario that builds.

use octoarm::build::build_system;
use octoarm::scenario::Scenario;
use std::path::Path;

const BASE: &str = r#"
[rod]
n_elements = 10
length = 0.2
base_diameter = 0.01
density = 1000.0
youngs_modulus = 1.0e6
shear_modulus = 3.0e5
base_position = [0.0, 0.0, 0.005]

[time]
dt = 1.0e-5
duration = 0.001
"#;

fn parse(extra: &str) -> Result<Scenario, String> {
    Scenario::from_str(Path::new("s.toml"), &format!("{BASE}{extra}")).map_err(|e| e.to_string())
}

#[test]
fn contact_keys_reach_the_system() {
    let scn = parse(
        r#"
[numerics]
clamp_order = 2
[contact]
self_contact = true
rod_geometry = "smooth"
rod_friction = 0.3
friction_eta = 0.25
[[obstacle]]
kind = "sphere"
center = [0.1, 0.1, 0.0]
diameter = 0.02
friction = 0.4
[[plane]]
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 2.0]
friction = [0.1, 0.2, 0.3]
kinetic_friction = [0.05, 0.1, 0.2]
[[cylinder]]
center = [0.1, 0.0, -0.05]
axis = [0.0, 1.0, 0.0]
diameter = 0.05
length = 0.3
friction = 0.2
"#,
    )
    .unwrap();
    let (system, _) = build_system(&scn).unwrap();
    assert_eq!(system.settings().clamp_order, 2);
    let c = system.contact();
    assert!(c.self_contact && !c.rods);
    assert_eq!(c.rod_geometry, octoarm_physics::RodGeometry::Smooth);
    assert_eq!(c.rod_friction.static_mu, [0.3; 3]);
    assert_eq!(c.friction_eta, 0.25);
    assert_eq!(system.obstacles()[0].friction.kinetic_mu, [0.4; 3]);
    let p = system.planes()[0];
    assert_eq!(p.normal, [0.0, 0.0, 1.0]);
    assert_eq!(p.friction.static_mu, [0.1, 0.2, 0.3]);
    assert_eq!(p.friction.kinetic_mu, [0.05, 0.1, 0.2]);
    let cyl = system.cylinders()[0];
    assert_eq!((cyl.radius, cyl.length), (0.025, 0.3));
    assert_eq!(cyl.friction.static_mu, [0.2; 3]);
    // The contact springs enter the stable time step.
    assert!(system.contact_max_frequency() > 0.0);
}

#[test]
fn rod_geometry_defaults_to_the_polyline_and_a_typo_names_the_choices() {
    let (system, _) = build_system(&parse("[contact]\nrods = true\n").unwrap()).unwrap();
    assert_eq!(
        system.contact().rod_geometry,
        octoarm_physics::RodGeometry::Polyline
    );
    let e = parse("[contact]\nrod_geometry = \"smoth\"\n").unwrap_err();
    assert!(
        e.contains("rod_geometry") && e.contains("smooth") && e.contains("polyline"),
        "{e}"
    );
}

#[test]
fn bad_contact_values_name_the_key() {
    for (extra, key, words) in [
        (
            "[[plane]]\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nfriction = 0.2\nkinetic_friction = 0.3\n",
            "plane[0].kinetic_friction",
            "cannot exceed static",
        ),
        (
            "[[plane]]\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 0.0]\n",
            "plane[0].normal",
            "non-zero",
        ),
        (
            "[[cylinder]]\ncenter = [0.0, 0.0, 0.0]\naxis = [0.0, 0.0, 1.0]\ndiameter = -1.0\nlength = 1.0\n",
            "cylinder[0].diameter",
            "(0, inf)",
        ),
        (
            "[[obstacle]]\nkind = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\ndiameter = 0.1\nfriction = -0.5\n",
            "obstacle[0].friction",
            "[0, inf)",
        ),
        ("[contact]\nfriction_eta = 1.5\n", "contact.friction_eta", "(0, 1]"),
        ("[contact]\nrod_kinetic_friction = 0.1\n", "contact.rod_kinetic_friction", "static"),
        ("[numerics]\nclamp_order = 3\n", "numerics.clamp_order", "{1, 2}"),
    ] {
        let e = parse(extra).expect_err(extra);
        assert!(e.contains(key) && e.contains(words), "{extra}: {e}");
    }
}
