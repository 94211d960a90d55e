//! Claim: every kernel the stepper can dispatch to at run time (`octoarm_physics::kernel`)
//! gives bit-identical trajectories — positions, velocities, directors, angular velocities,
//! external work and dissipated energy equal to the last bit after thousands of steps — in runs
//! that exercise every stage of the step: per-length and mass-proportional damping (the
//! dilatation-dependent kick factors), PyElastica's analytical damper, a scheduled tip force,
//! gravity, sphere contact, an internal actuation through the energy-consistent correction and an
//! external couple. And `OCTOARM_KERNEL=baseline` selects the baseline kernel (CI runs the
//! physics tests and the scenario regression test once that way, and this test and the
//! PyElastica cross-check under `qemu-x86_64 -cpu Nehalem`, where `OCTOARM_EXPECT_KERNEL=baseline`
//! checks that the baseline is the best kernel found).
//!
//! Reference: the baseline kernel's own run (SSE2 code, the code any x86-64 runs).
//!
//! How a wrong implementation fails: a kernel that fused a multiply–add (`mul_add`, or an
//! `fma` intrinsic), reordered a sum, took another branch of the rotation update or skipped a
//! stage would differ in the last bits within a few steps, and the difference grows along the
//! run; comparing `to_bits` catches a single-ulp difference.

mod common;

use octoarm_physics::kernel::{Kernel, KERNEL_ENV};
use octoarm_physics::{
    AnalyticalDamper, Damping, Load, Schedule, Settings, Simulation, Sphere, StraightRod,
};

/// Every bit of the evolving state (`common::state_bits`).
fn bits(sim: &Simulation) -> Vec<u64> {
    common::state_bits(sim)
}

/// The paper's arm (n elements) with damping, loads, contact and actuation chosen by `case`.
fn arm(n: usize, case: usize) -> Simulation {
    let (model, state) = StraightRod::paper_arm().with_elements(n).build().unwrap();
    let settings = Settings {
        energy_consistent: case == 1,
        ..Settings::with_dt(1e-5)
    };
    let mut sim = Simulation::new(model, state, settings).unwrap();
    match case {
        0 => {
            sim.set_damping(Damping {
                rate: 5.0,
                gamma: 1e-3,
                analytical: None,
            })
            .unwrap();
            sim.add_scheduled_load(
                Load::tip_force(n, [0.0, 2e-5, 1e-5]),
                Schedule::Ramp { duration: 0.01 },
            )
            .unwrap();
            sim.add_obstacle(Sphere::fixed([0.1, 0.02, 0.0], 0.01))
                .unwrap();
        }
        _ => {
            sim.set_damping(Damping {
                rate: 2.0,
                gamma: 0.0,
                analytical: Some(AnalyticalDamper::Uniform { nu: 3.0 }),
            })
            .unwrap();
            sim.add_load(Load::Gravity {
                acceleration: [0.0, -0.5, 0.0],
            })
            .unwrap();
            let a = sim.actuation.internal_mut();
            for (k, c) in a.couple.iter_mut().enumerate() {
                *c = [1e-9 * (k as f64 / n as f64), 2e-9, -1e-10];
            }
            for (j, s) in a.stress.iter_mut().enumerate() {
                *s = [0.0, 1e-7, -1e-5 * (j as f64 / n as f64)];
            }
            let e = sim.actuation.external_mut();
            e.couple[n / 2] = [0.0, 0.0, 1e-9];
        }
    }
    sim
}

#[test]
fn every_kernel_gives_bit_identical_trajectories() {
    let available: Vec<Kernel> = Kernel::ALL
        .into_iter()
        .filter(|k| k.is_available())
        .collect();
    eprintln!("kernels on this CPU: {available:?}");
    for case in 0..2 {
        for n in [7usize, 50, 101] {
            let mut runs = Vec::new();
            for &k in &available {
                let mut sim = arm(n, case);
                assert!(sim.workspace.set_kernel(k));
                assert_eq!(sim.workspace.kernel(), k);
                let mut snapshots = Vec::new();
                for _ in 0..4 {
                    sim.run(1500)
                        .unwrap_or_else(|e| panic!("case {case}, n = {n}: {e}"));
                    snapshots.push(bits(&sim));
                }
                runs.push((k, snapshots));
            }
            let (k0, reference) = &runs[0];
            for (k, snapshots) in &runs[1..] {
                assert!(
                    snapshots == reference,
                    "case {case}, n = {n}: {k:?} differs from {k0:?}"
                );
            }
            // The run moved: the comparison is not between two rest states.
            let rest = bits(&arm(n, case));
            assert!(reference[0] != rest && reference[3] != reference[0]);
        }
    }
}

#[test]
fn unavailable_kernels_are_refused() {
    for k in Kernel::ALL {
        let mut sim = arm(7, 0);
        let before = sim.workspace.kernel();
        assert_eq!(sim.workspace.set_kernel(k), k.is_available());
        if !k.is_available() {
            assert_eq!(sim.workspace.kernel(), before);
        }
    }
}

#[test]
fn environment_variable_forces_the_baseline() {
    let requested = std::env::var(KERNEL_ENV).unwrap_or_default();
    let selected = Kernel::selected();
    eprintln!("{KERNEL_ENV}={requested:?}: selected {selected:?}");
    if requested == "baseline" {
        assert_eq!(selected, Kernel::Baseline);
    } else if requested.is_empty() {
        assert_eq!(selected, Kernel::best());
    }
    assert_eq!(arm(7, 0).workspace.kernel(), selected);
    // CI sets this when it runs the tests on an emulated CPU without AVX2 (QEMU -cpu Nehalem).
    if let Ok(expected) = std::env::var("OCTOARM_EXPECT_KERNEL") {
        assert_eq!(Kernel::best().name(), expected);
        assert_eq!(selected.name(), expected);
    }
}
