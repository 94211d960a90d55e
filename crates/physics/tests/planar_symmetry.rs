//! Spec §13 (g): planar symmetry.
//!
//! Claim: a run whose initial state lies in the x–y plane with d2 = e_z on every element, driven
//! only by in-plane forces and by couples along e_z (lab) or d2 (material), stays planar to the
//! bit: x_z, v_z and the material components ω1, ω3, κ1, κ3, σ2 are exactly 0.0 (either sign) at
//! every step of the whole run — with clamped and free ends, every damping path (mass-proportional
//! and per-length exponential kicks, the uniform/physical analytical dampers), every kind of
//! external load, sphere obstacles centred at z = 0 in active contact, the controller actuation, the
//! energy-consistent correction, and the Björck re-orthonormalisation step of §5 (forced to run by
//! starting from frames that are orthonormal only to ~1e-10 and checking every 100 steps).
//! For the same scene rotated by an arbitrary rotation R and translated, the out-of-plane position
//! components (along R e_z) stay below 1e-12 L.
//!
//! Independent reference: symmetry. With d2 = e_z and in-plane data, every product that could feed
//! an out-of-plane component multiplies an exact zero (e.g. σ2 = d2·Δx/l̂ with Δx_z = 0, the
//! off-diagonal R_01, R_12 of the Log, the contact normal from centres at z = 0, Björck's
//! QᵀQ block structure), so IEEE arithmetic keeps them exactly zero. The rotated scene has the
//! same symmetry about a tilted plane, where round-off (~1e-16 |x|) is the only source of leakage.
//!
//! How a wrong implementation fails: any index slip (a σ or κ component used in the wrong slot,
//! a transposed director, a couple added in lab instead of material components), a contact normal
//! or a re-orthonormalisation that mixes rows, or a damper that treats components unequally
//! through mixed terms, produces a non-zero out-of-plane value — exactly zero is the only
//! acceptable result, so even a 1e-300 leak fails. In the rotated scene a real coupling grows far
//! above round-off (the out-of-plane modes are driven, not just seeded at 1e-16).

mod common;

use common::{rot, rotation};
use octoarm_physics::{
    max_penetration, AnalyticalDamper, ContactParams, Damping, EndCondition, Load, Mat3, Material,
    RodAccess, Schedule, Settings, Simulation, Sphere, StraightRod, Vec3,
};
use std::f64::consts::PI;

/// Per-step planar checks on the full-step state and on the strains of the last force evaluation.
fn assert_planar(sim: &Simulation, label: &str) {
    let step = sim.steps();
    let s = sim.view();
    let n = s.n_elements();
    for (i, (x, v)) in (0..=n).map(|i| (i, (s.position(i), s.velocity(i)))) {
        assert!(
            x[2] == 0.0 && v[2] == 0.0,
            "{label}, step {step}: node {i} x = {x:?}, v = {v:?}"
        );
    }
    for (j, (q, w)) in (0..n).map(|j| (j, (s.director(j), s.omega(j)))) {
        assert!(
            w[0] == 0.0 && w[2] == 0.0,
            "{label}, step {step}: element {j} omega = {w:?}"
        );
        // d1, d3 in the plane, d2 along e_z.
        assert!(
            q[0][2] == 0.0 && q[2][2] == 0.0 && q[1][0] == 0.0 && q[1][1] == 0.0,
            "{label}, step {step}: Q_{j} = {q:?}"
        );
    }
    let loads = &sim.workspace.internal;
    for (j, sg) in common::vecs(&loads.sigma).iter().enumerate() {
        assert!(
            sg[1] == 0.0,
            "{label}, step {step}: element {j} sigma = {sg:?}"
        );
    }
    for (k, kp) in common::vecs(&loads.kappa).iter().enumerate() {
        assert!(
            kp[0] == 0.0 && kp[2] == 0.0,
            "{label}, step {step}: voronoi {k} kappa = {kp:?}"
        );
    }
    for (i, f) in common::vecs(&loads.force).iter().enumerate() {
        assert!(
            f[2] == 0.0,
            "{label}, step {step}: node {i} internal force = {f:?}"
        );
    }
    for (j, t) in common::vecs(&loads.torque).iter().enumerate() {
        assert!(
            t[0] == 0.0 && t[2] == 0.0,
            "{label}, step {step}: element {j} internal torque = {t:?}"
        );
    }
}

/// Make every frame except the clamped one orthonormal only to ~2e-10 while keeping the planar
/// structure, so that the Björck step (triggered when the defect exceeds 1e-12) must run.
fn perturb_frames(frames: &mut [Mat3], first: usize) {
    for (j, q) in frames.iter_mut().enumerate().skip(first) {
        // Defect ≈ 2e-10 (diagonal) and 1e-10 (off-diagonal): above Björck's 1e-12 trigger, below
        // the 1e-9 accepted by `Simulation::new`.
        let a = 1.0 + 1e-10 * (1.0 + 0.1 * (j % 3) as f64);
        q[0][0] *= a;
        q[0][1] *= a;
        let d1 = q[0];
        q[2][0] += 1e-10 * d1[0];
        q[2][1] += 1e-10 * d1[1];
    }
}

fn max_defect(frames: &[Mat3]) -> f64 {
    let mut worst: f64 = 0.0;
    for q in frames {
        for r in 0..3 {
            for c in 0..3 {
                let g = q[r][0] * q[c][0] + q[r][1] * q[c][1] + q[r][2] * q[c][2];
                worst = worst.max((g - if r == c { 1.0 } else { 0.0 }).abs());
            }
        }
    }
    worst
}

/// What a planar run saw: the frame defect before it, after the first Björck check (step 100)
/// and at its end, and the number of steps with an obstacle penetrated.
struct PlanarRun {
    defect0: f64,
    defect_first_check: f64,
    defect: f64,
    contact_steps: usize,
}

/// Whether the rod's surface penetrates an obstacle (at their positions of the current time).
fn penetrated(sim: &Simulation) -> bool {
    max_penetration(sim.model(), &sim.view(), sim.system.obstacles(), sim.time()).0 > 0.0
}

/// Take `steps` steps with `step`, asserting planarity after each, and report what was seen.
fn run_planar(
    sim: &mut Simulation,
    label: &str,
    steps: usize,
    mut step: impl FnMut(&mut Simulation),
) -> PlanarRun {
    let defect0 = max_defect(&sim.rod_state().director);
    let mut defect_first_check = f64::NAN;
    let mut contact_steps = 0;
    for _ in 0..steps {
        step(sim);
        assert_planar(sim, label);
        if sim.steps() == 100 {
            defect_first_check = max_defect(&sim.rod_state().director);
        }
        if penetrated(sim) {
            contact_steps += 1;
        }
    }
    let defect = max_defect(&sim.rod_state().director);
    println!(
        "{label}: {steps} steps, contact in {contact_steps} steps, tip {:?}, frame defect {defect0:.2e} -> \
         {defect_first_check:.2e} (first check) -> {defect:.2e} (end)",
        sim.tip()
    );
    PlanarRun {
        defect0,
        defect_first_check,
        defect,
        contact_steps,
    }
}

/// Scene of case (a): clamped rod with every load kind, two spheres at z = 0 (one fixed and
/// initially penetrated, one moving in the plane), all damping paths. The scene is mapped by the
/// rigid motion (r, b); r = I, b = 0 gives the planar scene.
fn cantilever_scene(r: &Mat3, b: Vec3) -> Simulation {
    let material = Material {
        density: 5000.0,
        youngs_modulus: 1.0e6,
        shear_modulus: 1.0e4,
        shear_coefficient: 4.0 / 3.0,
    };
    let n = 50;
    let (model, mut state) = StraightRod::uniform(n, 3.0, 0.5, material).build().unwrap();
    perturb_frames(&mut state.director, 1);
    state.rigid_transform(r, b);
    let settings = Settings {
        dt: 3e-4,
        orthonormality_interval: 100,
        ..Settings::default()
    };
    let mut sim = Simulation::new(model, state, settings).unwrap();
    sim.set_damping(Damping {
        rate: 0.5,
        gamma: 50.0,
        analytical: Some(AnalyticalDamper::Uniform { nu: 0.3 }),
    })
    .unwrap();
    let ez = rot(r, [0.0, 0.0, 1.0]);
    let loads = [
        (
            Load::tip_force(n, rot(r, [0.0, -15.0, 0.0])),
            Schedule::Constant,
        ),
        (
            Load::Gravity {
                acceleration: rot(r, [0.002, -0.01, 0.0]),
            },
            Schedule::Constant,
        ),
        (
            Load::UniformForce {
                force_per_length: rot(r, [0.3, -0.5, 0.0]),
            },
            Schedule::Constant,
        ),
        (
            Load::ElementCouple {
                element: n / 2,
                couple: [2.0 * ez[0], 2.0 * ez[1], 2.0 * ez[2]],
            },
            Schedule::Ramp { duration: 0.5 },
        ),
        (
            Load::UniformCouple {
                couple_per_length: [0.3 * ez[0], 0.3 * ez[1], 0.3 * ez[2]],
            },
            Schedule::Constant,
        ),
        (
            Load::FollowerCouple {
                couple_per_length: [0.0, -0.2, 0.0],
            },
            Schedule::Constant,
        ),
        (
            Load::NodeForce {
                node: n / 3,
                force: rot(r, [1.0, 4.0, 0.0]),
            },
            Schedule::Ramp { duration: 0.2 },
        ),
    ];
    for (load, schedule) in loads {
        sim.add_scheduled_load(load, schedule).unwrap();
    }
    let place = |c: Vec3| {
        let p = rot(r, c);
        [p[0] + b[0], p[1] + b[1], p[2] + b[2]]
    };
    // A soft penalty (β = 0.01, k ≈ 3e4 N/m) keeps contact forces comparable to the other loads on
    // this shear-soft rod (α_c G Â ≈ 2.6e3 N). The fixed sphere penetrates the rod surface
    // (r̂ = 0.25) by 0.5 mm under x = 2.5 from the start and the rod is pushed onto it; the moving
    // one starts 1 cm away and presses on the rod from above after 0.5 s.
    sim.set_contact(ContactParams {
        beta: 0.01,
        zeta: 0.5,
        ..ContactParams::default()
    })
    .unwrap();
    sim.add_obstacle(Sphere::fixed(place([2.5, -0.5495, 0.0]), 0.3))
        .unwrap();
    sim.add_obstacle(Sphere {
        center: place([1.2, 0.62, 0.0]),
        radius: 0.36,
        velocity: rot(r, [0.0, -0.02, 0.0]),
        friction: octoarm_physics::Friction::NONE,
    })
    .unwrap();
    sim
}

/// Time of the force evaluation of the next step, the mid-step time t + Δt/2 [s]: what the
/// actuation written now is held at (and what schedules are evaluated at).
fn mid_step_time(sim: &Simulation) -> f64 {
    sim.state.origin + (sim.state.step as f64 + 0.5) * sim.settings().dt
}

/// The controller input: an in-plane tip force and a d2 couple on the tip element, written into
/// the external actuation before a step (time-dependent only, so that the rotated scene sees the
/// rotated input).
fn actuate(sim: &mut Simulation, r: &Mat3) {
    let amp = (3.0 * mid_step_time(sim)).sin();
    let f = rot(r, [0.0, 0.2 * amp, 0.0]);
    let n = sim.model().n_elements;
    let ext = sim.actuation.external_mut();
    ext.force[n] = f;
    ext.couple[n - 1] = [0.0, 0.05 * amp, 0.0];
}

#[test]
fn planar_cantilever_with_contact_loads_damping_and_bjorck_stays_exactly_planar() {
    let id = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mut sim = cantilever_scene(&id, [0.0; 3]);
    let PlanarRun {
        defect0,
        defect_first_check,
        defect,
        contact_steps,
    } = run_planar(&mut sim, "cantilever", 5000, |sim| {
        actuate(sim, &id);
        sim.step().unwrap()
    });
    assert!(contact_steps > 1000, "the scene must exercise contact");
    // The exact rotations preserve a ~1e-10 defect; only the Björck step (quadratic convergence:
    // 1e-10 → ~1e-20 + round-off) removes it at the first check, after which it stays below the
    // 1e-12 trigger up to drift between checks.
    assert!(
        defect0 > 1e-11 && defect_first_check < 1e-13 && defect < 1e-12,
        "Björck step did not run"
    );
}

#[test]
fn planar_arm_with_planar_control_spheres_and_energy_consistent_stays_exactly_planar() {
    // The paper arm with the energy-shaping rest curvature of §13 (j), the paper's spheres at z = 0,
    // both exponential damping presets and the energy-consistent correction.
    let (mut model, mut state) = StraightRod::paper_arm().build().unwrap();
    let n = model.n_elements;
    model.rest_kappa = vec![[0.0, 10.0, 0.0]; n - 1];
    perturb_frames(&mut state.director, 1);
    let settings = Settings {
        dt: 5e-5,
        energy_consistent: true,
        orthonormality_interval: 100,
        ..Settings::default()
    };
    let mut sim = Simulation::new(model, state, settings).unwrap();
    sim.set_damping(Damping {
        rate: 10.0,
        gamma: 0.01,
        analytical: None,
    })
    .unwrap();
    for (c, d) in [
        ([0.054, 0.06, 0.0], 0.08),
        ([0.154, 0.06, 0.0], 0.08),
        ([0.06, 0.03, 0.0], 0.04),
    ] {
        sim.add_obstacle(Sphere::fixed(c, 0.5 * d)).unwrap();
    }
    let PlanarRun {
        defect0,
        defect_first_check,
        defect,
        contact_steps,
    } = run_planar(&mut sim, "arm", 6000, |sim| {
        // Planar control through the actuation: a force per unit length along e_y and a couple
        // about e_z.
        let t = mid_step_time(sim);
        let m = &sim.system.rod(0).model;
        let ext = sim.actuation.external_mut();
        for (i, f) in ext.force.iter_mut().enumerate() {
            *f = [0.0, 1e-4 * m.nodal_rest_length[i] * (20.0 * t).cos(), 0.0];
        }
        for (j, c) in ext.couple.iter_mut().enumerate() {
            *c = [0.0, 1e-6 * m.rest_length[j], 0.0];
        }
        sim.step().unwrap()
    });
    assert!(contact_steps > 100, "the scene must exercise contact");
    assert!(
        defect0 > 1e-11 && defect_first_check < 1e-13 && defect < 1e-12,
        "Björck step did not run"
    );
}

#[test]
fn planar_free_rod_curling_with_physical_damper_stays_exactly_planar() {
    // Case (c1) released (free ends, large rotations) with the physical analytical damper.
    let material = Material {
        density: 1000.0,
        youngs_modulus: 1.0e6,
        shear_modulus: 1.0e6 / 3.0,
        shear_coefficient: 4.0 / 3.0,
    };
    let mut spec = StraightRod::uniform(100, 1.0, 0.04, material);
    spec.rest_curvature = [0.0, 2.0 * PI, 0.0];
    let (model, mut state) = spec.build().unwrap();
    perturb_frames(&mut state.director, 0);
    let settings = Settings {
        dt: 1e-4,
        orthonormality_interval: 100,
        ..Settings::default()
    };
    let mut sim = Simulation::with_ends(
        model,
        state,
        EndCondition::Free,
        EndCondition::Free,
        settings,
    )
    .unwrap();
    let damper = AnalyticalDamper::Physical {
        translational: 0.02,
        rotational: 1e-6,
    };
    sim.set_damping(Damping {
        analytical: Some(damper),
        ..Damping::default()
    })
    .unwrap();
    // No obstacles: the contact count stays 0.
    let PlanarRun {
        defect0,
        defect_first_check,
        defect,
        ..
    } = run_planar(&mut sim, "free rod", 3000, |sim| sim.step().unwrap());
    assert!(
        defect0 > 1e-11 && defect_first_check < 1e-13 && defect < 1e-12,
        "Björck step did not run"
    );
}

#[test]
fn rotated_planar_scene_stays_in_its_plane_to_round_off() {
    let r = rotation([0.3, -1.1, 2.0]);
    let b = [0.5, -2.0, 3.0];
    let normal = rot(&r, [0.0, 0.0, 1.0]);
    let mut sim = cantilever_scene(&r, b);
    let length = sim.model().length();
    let mut worst_x: f64 = 0.0;
    let mut worst_v: f64 = 0.0;
    let mut worst_w: f64 = 0.0;
    let mut contact_steps = 0;
    for _ in 0..5000 {
        actuate(&mut sim, &r);
        sim.step().unwrap();
        let s = sim.view();
        let n = s.n_elements();
        for (x, v) in (0..=n).map(|i| (s.position(i), s.velocity(i))) {
            let d = [x[0] - b[0], x[1] - b[1], x[2] - b[2]];
            worst_x = worst_x.max((d[0] * normal[0] + d[1] * normal[1] + d[2] * normal[2]).abs());
            worst_v = worst_v.max((v[0] * normal[0] + v[1] * normal[1] + v[2] * normal[2]).abs());
        }
        for w in (0..n).map(|j| s.omega(j)) {
            worst_w = worst_w.max(w[0].abs()).max(w[2].abs());
        }
        if penetrated(&sim) {
            contact_steps += 1;
        }
    }
    println!(
        "rotated scene: max out-of-plane |x| = {worst_x:.3e} m ({:.3e} L), |v| = {worst_v:.3e} m/s, \
         max |omega1|,|omega3| = {worst_w:.3e} rad/s, contact in {contact_steps} steps",
        worst_x / length
    );
    assert!(contact_steps > 1000, "the scene must exercise contact");
    // Spec §13 (g): 1e-12 L. Positions of order 4 m carry ~1e-15 m of round-off per operation;
    // the out-of-plane modes are stable and damped, so leakage stays at that level, three orders
    // below the bound, while any genuine coupling would be driven by the O(1 N) loads.
    assert!(
        worst_x < 1e-12 * length,
        "out-of-plane displacement {worst_x:e} m"
    );
}
