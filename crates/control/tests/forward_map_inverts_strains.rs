//! Claim (spec §7 test 1): the forward map of §2.2 is the exact inverse of the simulator's strain
//! measurement: building (r, Q) from random strains and letting the physics crate measure
//! (σ, κ) returns the same strains to 1e-12.
//! Independent reference: `octoarm_physics::strains` (the simulator's own strain kernel, log map
//! of relative frames), which shares no code with the control crate's Rodrigues forward map.
//! A wrong implementation fails by a sign of κ (error ~|κ|), stepping frames with ℓ̂ instead of
//! D̂ (error ~|κ| on non-uniform rods), or applying Q instead of Qᵀ to ν (error ~|ν|).
//! Tolerance: 1e-12 absolute on strains of size ~1 and κ of size ~3 m⁻¹ (round-off of ~100
//! chained rotations is ~1e-14 per step).

mod common;
use common::*;
use octoarm_control::{Statics, StrainField, StrainSpace};
use octoarm_physics::{Material, StraightRod};

fn check(
    model: &octoarm_physics::RodModel,
    state: &octoarm_physics::RodState,
    space: StrainSpace,
    seed: u64,
) -> f64 {
    let mut r = rng(seed);
    let w = random_field(model, space, 0.05, 3.0, &mut r);
    let mut st = Statics::new(model, state, space, 0.0).unwrap();
    let built = st.state_of(&w);
    let measured = StrainField::from_state(model, &built);
    measured.max_abs_diff(&w)
}

#[test]
fn forward_map_inverts_the_simulator_strains() {
    let (model, state) = paper_arm();
    for (seed, space) in [
        (1, StrainSpace::Full),
        (2, StrainSpace::Planar),
        (3, StrainSpace::Full),
    ] {
        let err = check(&model, &state, space, seed);
        println!("paper arm {space:?}: max strain error {err:.2e}");
        assert!(err < 1e-12, "{err}");
    }
    // A coarse uniform rod with a rotated base frame (normal (0,0,-1), the authors' convention).
    let mut arm = StraightRod::uniform(
        17,
        0.3,
        0.01,
        Material {
            density: 1000.0,
            youngs_modulus: 1e5,
            shear_modulus: 4e4,
            shear_coefficient: 27.0 / 28.0,
        },
    );
    arm.normal = [0.0, 0.0, -1.0];
    let (m2, s2) = arm.build().unwrap();
    for seed in 10..13 {
        let err = check(&m2, &s2, StrainSpace::Full, seed);
        println!("uniform rod, normal -e_z: max strain error {err:.2e}");
        assert!(err < 1e-12, "{err}");
    }
}
