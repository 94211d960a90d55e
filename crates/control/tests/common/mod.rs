//! Helpers shared by the control tests: the paper's arm, seeded random strain fields and a
//! Box–Muller normal sampler (rand 0.8 has no normal distribution without rand_distr).
#![allow(dead_code)]

use octoarm_control::{StrainField, StrainSpace};
use octoarm_physics::{RodModel, RodState, StraightRod};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

pub const L0: f64 = 0.2;

pub fn paper_arm() -> (RodModel, RodState) {
    StraightRod::paper_arm().build().unwrap()
}

pub fn rng(seed: u64) -> StdRng {
    StdRng::seed_from_u64(seed)
}

pub fn normal(r: &mut StdRng) -> f64 {
    let u1: f64 = r.gen_range(1e-300..1.0);
    let u2: f64 = r.gen();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// Random strains around the intrinsic ones: ν − ν° ~ `nu_sd`·N, κ ~ `kappa_sd`·N [1/m]; in the
/// planar space only the free components (for d1 = e_y, d2 = e_z: ν1, ν3, κ2) are perturbed.
pub fn random_field(
    model: &RodModel,
    space: StrainSpace,
    nu_sd: f64,
    kappa_sd: f64,
    r: &mut StdRng,
) -> StrainField {
    let mut w = StrainField::intrinsic(model);
    let (fnu, fk) = match space {
        StrainSpace::Planar => ([true, false, true], [false, true, false]),
        StrainSpace::Full => ([true; 3], [true; 3]),
    };
    for j in 0..model.n_elements {
        let mut v = w.nu(j);
        for c in 0..3 {
            if fnu[c] {
                v[c] += nu_sd * normal(r);
            }
        }
        w.set_nu(j, v);
    }
    for k in 0..model.n_interior() {
        let mut v = w.kappa(k);
        for c in 0..3 {
            if fk[c] {
                v[c] += kappa_sd * normal(r);
            }
        }
        w.set_kappa(k, v);
    }
    w
}

pub fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}
