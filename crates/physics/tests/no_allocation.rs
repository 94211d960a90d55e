//! Claim: a time step performs no heap allocation (spec §6 "All scratch arrays are allocated
//! once", §14) — not `step()`, not a step under internal and external actuation that a
//! controller updates between steps, and not the periodic paths (stability guard, orthonormality
//! check, Björck re-orthonormalisation), with contact, rate and per-length damping, the
//! energy-consistent model and a change of damping between steps; nor a step of a system of
//! several rods joined by fixed and hinge joints, with every kind of end condition, scheduled
//! (ramped) loads and rest strains, a moving obstacle and actuation, guard checks included.
//!
//! Reference: a counting global allocator. Every `alloc`, `alloc_zeroed` and `realloc` made by the
//! current thread is counted (per thread, so tests running in parallel do not disturb each other),
//! and the count over hundreds of steps must be exactly zero.
//!
//! A wrong implementation fails if any stage collects into a new `Vec`, grows a buffer, formats a
//! string on the success path, or sizes its scratch lazily on the first step.

use octoarm_physics::math::orthonormality_defect;
use octoarm_physics::{
    check, max_penetration, step, Actuation, AnalyticalDamper, Damping, EndCondition, Joint,
    JointEnd, JointKind, JointParams, Load, Material, Motion, RestChange, RodAccess, RodSpec,
    Schedule, Settings, Side, Simulation, Sphere, StraightRod, SystemBuilder, SystemState,
    Workspace,
};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::Arc;

struct CountingAllocator;

thread_local! {
    // Const-initialised and without a destructor: reading it never allocates.
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

fn count_one() {
    // `try_with` because the allocator may run while the thread's locals are being torn down.
    let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
}

// SAFETY: every call forwards to the system allocator unchanged; counting has no other effect.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count_one();
        System.alloc(layout)
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count_one();
        System.alloc_zeroed(layout)
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count_one();
        System.realloc(ptr, layout, new_size)
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
}

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

/// Heap allocations made by this thread while running `f`.
fn allocations_during(f: impl FnOnce()) -> u64 {
    let before = ALLOCATIONS.with(Cell::get);
    f();
    ALLOCATIONS.with(Cell::get) - before
}

// Enough steps for two guard checks (every 100 steps) and, with the small orthonormality
// interval, many orthonormality checks.
const STEPS: usize = 250;

fn settings() -> Settings {
    Settings {
        orthonormality_interval: 7,
        ..Settings::with_dt(1e-5)
    }
}

#[test]
fn counting_allocator_sees_allocations() {
    // The reference itself must work, or a zero below would prove nothing.
    let n = allocations_during(|| {
        let v: Vec<u64> = std::hint::black_box((0..100).collect());
        assert_eq!(v.len(), 100);
    });
    assert!(
        n >= 1,
        "the counting allocator counted {n} allocations for a new Vec"
    );
}

#[test]
fn step_does_not_allocate() {
    let (model, state) = StraightRod::paper_arm().build().unwrap();
    let mut sim = Simulation::new(model, state, settings()).unwrap();
    sim.set_damping(Damping::mass_proportional(10.0)).unwrap();
    sim.add_load(Load::tip_force(100, [0.0, 2e-5, 0.0]))
        .unwrap();
    let n = allocations_during(|| {
        for _ in 0..STEPS {
            sim.step().unwrap();
        }
        sim.check().unwrap();
    });
    assert_eq!(n, 0, "{n} heap allocations in {STEPS} steps");
    assert_eq!(sim.steps(), STEPS as u64);
    assert!(sim.tip()[1] > 0.0, "the tip force should have bent the arm");
}

#[test]
fn step_with_actuation_contact_and_damping_does_not_allocate() {
    let (model, state) = StraightRod::paper_arm().build().unwrap();
    let st = Settings {
        energy_consistent: true,
        ..settings()
    };
    let mut sim = Simulation::new(model, state, st).unwrap();
    sim.set_damping(Damping {
        rate: 10.0,
        gamma: 0.01,
        analytical: None,
    })
    .unwrap();
    sim.add_load(Load::tip_force(100, [0.0, 2e-5, 0.0]))
        .unwrap();
    sim.add_load(Load::FollowerCouple {
        couple_per_length: [0.0, 0.0, 1e-9],
    })
    .unwrap();
    // A sphere pressed 20 µm into the arm's surface at node 75, so that the contact narrow phase
    // runs on every step.
    let (r, x) = (sim.model().radius[75], sim.model().node_arc_length[75]);
    sim.add_obstacle(Sphere::fixed([x, r + 0.01 - 2e-5, 0.0], 0.01))
        .unwrap();
    assert!(max_penetration(sim.model(), &sim.view(), sim.system.obstacles(), sim.time()).0 > 0.0);
    // Actuation written once before stepping: an added internal stress along d3 and internal
    // couple about d2 everywhere (the energy-shaping law's input), and an external couple.
    let a = sim.actuation.internal_mut();
    a.stress.fill([0.0, 0.0, 1e-7]);
    a.couple.fill([0.0, 1e-12, 0.0]);
    sim.actuation.external_mut().couple[50][0] = 1e-9;

    let tip = sim.model().n_elements;
    let mut calls = 0u64;
    let mut contact_steps = 0u64;
    let n = allocations_during(|| {
        for k in 0..STEPS {
            // A controller-like input between steps: reads the state and the internal loads of
            // the last force evaluation, writes a force.
            let f_int = sim.workspace.internal.force.get(tip);
            let v_tip = sim.view().velocity(tip);
            sim.actuation.external_mut().force[tip][2] =
                1e-7 * (k as f64 * 0.01).sin() - 1e-3 * f_int[2] - 1e-9 * v_tip[2];
            sim.step().unwrap();
            // The stepper read the actuation in this step.
            let Some(act) = sim.workspace.actuation_force() else {
                continue;
            };
            calls += 1;
            // Only contact pushes nodes 75/76 along −y (the sphere sits above them): the
            // external loads of the step minus the actuation's share.
            let ext = &sim.workspace.external.force;
            contact_steps += u64::from(ext.y[75] - act.y[75] < 0.0 || ext.y[76] - act.y[76] < 0.0);
            if k == STEPS / 2 {
                // Changing the damping between steps recomputes the kick factors in place.
                sim.set_damping(Damping {
                    rate: 5.0,
                    gamma: 0.01,
                    analytical: Some(AnalyticalDamper::Uniform { nu: 1.0 }),
                })
                .unwrap();
            }
        }
        sim.run(50).unwrap();
    });
    assert_eq!(n, 0, "{n} heap allocations in {} steps", STEPS + 50);
    assert_eq!(calls, STEPS as u64);
    assert!(contact_steps > 0, "the contact forces never acted");
}

/// Largest orthonormality defect of the frames of a system state.
fn max_defect(state: &SystemState) -> f64 {
    let q = &state.director;
    (0..q.len())
        .map(|j| orthonormality_defect(&q.get(j)))
        .fold(0.0, f64::max)
}

// Steps of the rod-system case: 50 guard checks (every 10 steps) and 10 orthonormality checks
// (every 50 steps).
const SYSTEM_STEPS: u64 = 500;

// Three rods in one store: "upper" clamped at its base, joined tip-to-base by a fixed joint to
// "middle", joined by a hinge (axis e_z) to "lower", whose tip is driven (a slow turn about e_z).
// Each rod has its own damping path; loads on every rod, two of them ramped; a ramped rest
// curvature on the middle rod (rest strains in force change every step, so the guard resets its
// energy reference at every check); a moving sphere pressed into the upper rod; internal and
// external actuation on every rod. The middle and lower rods start with frames orthonormal only
// to ~1e-10, so that the Björck step runs at the first orthonormality check.
#[test]
fn jointed_rod_system_step_and_guard_do_not_allocate() {
    let material = Material {
        density: 700.0,
        youngs_modulus: 1e4,
        shear_modulus: 1e3,
        shear_coefficient: Material::DEFAULT_SHEAR_COEFFICIENT,
    };
    let n = 20;
    let length = 0.1;
    let straight = |base: [f64; 3], direction: [f64; 3], normal: [f64; 3]| {
        let mut rod = StraightRod::uniform(n, length, 0.01, material);
        rod.base_position = base;
        rod.direction = direction;
        rod.normal = normal;
        rod.build().unwrap()
    };
    let (model, upper) = straight([0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
    let (_, mut middle) = straight([length, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
    let (_, mut lower) = straight([2.0 * length, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]);
    for q in middle.director.iter_mut().chain(lower.director.iter_mut()) {
        for d1 in q[0].iter_mut() {
            *d1 *= 1.0 + 1e-10;
        }
    }
    let model = Arc::new(model);
    let settings = Settings {
        guard_interval: 10,
        orthonormality_interval: 50,
        ..Settings::with_dt(1e-5)
    };
    let mut b = SystemBuilder::new(settings);
    let spec = |name: &str, state, base, tip, damping| RodSpec {
        name: name.into(),
        model: Arc::clone(&model),
        state,
        base,
        tip,
        damping,
    };
    let r0 = b.rod(spec(
        "upper",
        upper,
        EndCondition::Clamped,
        EndCondition::Free,
        Damping::mass_proportional(10.0),
    ));
    let r1 = b.rod(spec(
        "middle",
        middle,
        EndCondition::Free,
        EndCondition::Free,
        Damping {
            rate: 5.0,
            gamma: 0.01,
            analytical: None,
        },
    ));
    let r2 = b.rod(spec(
        "lower",
        lower,
        EndCondition::Free,
        EndCondition::Driven(Motion::constant_rotation([0.0, 0.0, 1.0], 1.0)),
        Damping {
            analytical: Some(AnalyticalDamper::Physical {
                translational: 1e-3,
                rotational: 1e-9,
            }),
            ..Damping::default()
        },
    ));
    let mut params = JointParams::default_for((&model, Side::Tip), (&model, Side::Base));
    params.damping = 1e-4;
    params.rotational_damping = 1e-9;
    let end = |rod, side| JointEnd { rod, side };
    b.joint(Joint::new(
        JointKind::Fixed,
        end(r0, Side::Tip),
        end(r1, Side::Base),
        params,
    ));
    b.joint(Joint::new(
        JointKind::Hinge {
            axis: [0.0, 0.0, 1.0],
        },
        end(r1, Side::Tip),
        end(r2, Side::Base),
        params,
    ));
    let (mut system, mut state) = b.build().unwrap();
    system
        .add_load(
            r0,
            Load::FollowerElementCouple {
                element: n / 2,
                couple: [0.0, 1e-8, 0.0],
            },
            Schedule::Ramp { duration: 2e-3 },
        )
        .unwrap();
    system
        .add_load(
            r1,
            Load::Gravity {
                acceleration: [0.0, -9.81, 0.0],
            },
            Schedule::Constant,
        )
        .unwrap();
    system
        .add_load(
            r2,
            Load::NodeForce {
                node: n / 2,
                force: [1e-5, 0.0, 2e-6],
            },
            Schedule::Ramp { duration: 1e-3 },
        )
        .unwrap();
    system
        .add_rest_change(RestChange {
            rod: r1,
            sigma: Vec::new(),
            kappa: vec![[0.0, 1.0, 0.0]; n - 1],
            schedule: Schedule::Ramp { duration: 3e-3 },
        })
        .unwrap();
    // A sphere pressed 20 µm into the upper rod's surface at node 10, moving slowly along it.
    let x10 = model.node_arc_length[10];
    let (rr, radius) = (model.radius[10], 0.01);
    system
        .add_obstacle(Sphere {
            center: [x10, rr + radius - 2e-5, 0.0],
            radius,
            velocity: [1e-3, 0.0, 0.0],
            friction: octoarm_physics::Friction::NONE,
        })
        .unwrap();
    let mut actuation =
        Actuation::zeros(system.n_nodes(), system.n_elements(), system.n_interior());
    let a = actuation.internal_mut();
    a.stress.fill([0.0, 0.0, 1e-7]);
    a.couple.fill([0.0, 1e-12, 0.0]);
    let e = actuation.external_mut();
    e.force[system.rod(r2).nodes().end - 1] = [0.0, 0.0, 1e-6];
    e.couple[system.rod(r1).elements().start + 3] = [1e-9, 0.0, 0.0];
    let mut ws = Workspace::new(&system, &state);
    let penetrated = |system: &octoarm_physics::RodSystem, state: &SystemState| {
        let v = system.view(state, r0);
        max_penetration(&model, &v, system.obstacles(), state.time).0 > 0.0
    };
    assert!(penetrated(&system, &state));
    let defect0 = max_defect(&state);

    let mut contact_steps = 0u64;
    let count = allocations_during(|| {
        for _ in 0..SYSTEM_STEPS {
            step(&system, &mut state, &actuation, &mut ws).unwrap();
            contact_steps += u64::from(penetrated(&system, &state));
        }
        check(&system, &state, &mut ws).unwrap();
    });
    assert_eq!(
        count, 0,
        "{count} heap allocations in {SYSTEM_STEPS} steps of a jointed system"
    );
    assert_eq!(state.step, SYSTEM_STEPS);
    assert!(contact_steps > 0, "the contact forces never acted");
    assert!(ws.actuation_force().is_some(), "the actuation was not read");
    // The periodic paths ran: the Björck step removed the initial frame defect.
    let defect = max_defect(&state);
    assert!(
        defect0 > 1e-11 && defect < 1e-12,
        "frame defect {defect0:e} -> {defect:e}: Björck step did not run"
    );
    // The joints act: the joined end nodes stay together to a quarter of the drop ½ g t² by which
    // gravity on the middle rod alone would have separated them (measured: 0.05 and 0.1 of it).
    let drop = 0.5 * 9.81 * state.time * state.time;
    let view = |r| system.view(&state, r);
    for (a, b) in [(view(r0), view(r1)), (view(r1), view(r2))] {
        let (x, y) = (a.position(n), b.position(0));
        let gap = ((x[0] - y[0]).powi(2) + (x[1] - y[1]).powi(2) + (x[2] - y[2]).powi(2)).sqrt();
        println!("joint gap {gap:.3e} m, free-fall drop {drop:.3e} m");
        assert!(gap < 0.25 * drop, "joint gap {gap:e} m (drop {drop:e} m)");
    }
}

// The muscular arm of muscles-3d spec §7: muscles (all seven groups), drag and the `coomm`
// damper, activations rewritten between steps as a controller would.
#[test]
fn muscular_arm_step_does_not_allocate() {
    let (model, state) = StraightRod::coomm_arm().build().unwrap();
    let n = model.n_elements;
    let drag = Load::coomm_drag(&model);
    let mut sim = Simulation::new(model, state, settings()).unwrap();
    sim.set_damping(Damping::coomm(1050.0, 0.012)).unwrap();
    sim.add_load(drag).unwrap();
    sim.set_muscles(Some(octoarm_physics::MuscleSpec::coomm()))
        .unwrap();
    let values = vec![0.2; n];
    for g in 0..7 {
        sim.set_activation(g, &values).unwrap();
    }
    let count = allocations_during(|| {
        for k in 0..STEPS {
            let a = sim.actuation.activations_mut();
            a[k % a.len()] = 0.4;
            sim.step().unwrap();
        }
        sim.check().unwrap();
    });
    assert_eq!(count, 0, "{count} heap allocations in {STEPS} steps");
}

// Every contact model at once — a plane and a cylinder with anisotropic / isotropic friction, a
// moving sphere with friction, rod–rod and self contact with friction on a coiling rod lying on
// the plane — after the Verlet list has been built once: no step allocates, guard included.
#[test]
fn contact_with_friction_rod_and_self_contact_does_not_allocate() {
    for geometry in [
        octoarm_physics::RodGeometry::Polyline,
        octoarm_physics::RodGeometry::Smooth,
    ] {
        every_contact_model(geometry);
    }
}

fn every_contact_model(geometry: octoarm_physics::RodGeometry) {
    use octoarm_physics::{ContactParams, Cylinder, Friction, Plane};
    let mut rod = StraightRod::uniform(
        60,
        0.3,
        0.005,
        Material {
            density: 1000.0,
            youngs_modulus: 1e6,
            shear_modulus: 1e6 / 3.0,
            shear_coefficient: Material::DEFAULT_SHEAR_COEFFICIENT,
        },
    );
    rod.rest_curvature = [0.0, 31.4, 0.0];
    rod.base_position = [0.0, 0.0, 0.0025 - 1e-6];
    rod.normal = [0.0, 0.0, 1.0];
    let (model, state) = rod.build().unwrap();
    let mut sim = Simulation::with_ends(
        model,
        state,
        EndCondition::Free,
        EndCondition::Free,
        Settings::with_dt(2e-5),
    )
    .unwrap();
    sim.add_load(Load::Gravity {
        acceleration: [0.0, 0.0, -9.81],
    })
    .unwrap();
    sim.add_plane(Plane::new(
        [0.0; 3],
        [0.0, 0.0, 1.0],
        Friction {
            static_mu: [0.2, 0.5, 0.6],
            kinetic_mu: [0.1, 0.4, 0.5],
        },
    ))
    .unwrap();
    sim.add_cylinder(Cylinder::fixed(
        [0.15, 0.0, -0.049],
        [0.0, 1.0, 0.0],
        0.05,
        0.1,
        Friction::coulomb(0.3),
    ))
    .unwrap();
    sim.add_obstacle(Sphere {
        center: [0.05, 0.0, 0.0125 - 1e-5],
        radius: 0.01,
        velocity: [1e-2, 0.0, 0.0],
        friction: Friction::coulomb(0.5),
    })
    .unwrap();
    sim.set_contact(ContactParams {
        rods: true,
        self_contact: true,
        rod_friction: Friction::coulomb(0.3),
        rod_geometry: geometry,
        ..ContactParams::default()
    })
    .unwrap();
    sim.workspace = Workspace::new(&sim.system, &sim.state);
    sim.run(50).unwrap();
    let rebuilds = sim.workspace.rod_contact.rebuilds();
    let n = allocations_during(|| {
        for _ in 0..STEPS {
            sim.step().unwrap();
        }
        sim.check().unwrap();
    });
    assert_eq!(
        n, 0,
        "{n} heap allocations in {STEPS} steps with every contact model ({geometry:?})"
    );
    assert!(rebuilds >= 1, "the broad phase never ran");
    let (g, _) = octoarm_physics::obstacle_penetration(
        sim.model(),
        &sim.view(),
        sim.system.obstacle_set(),
        sim.time(),
    );
    assert!(g > 0.0, "no obstacle contact");
}

// A batch of arms (`RodBatch`, one chunk of `LANES` rods, so that it runs on this thread where
// allocations are counted): steps with a per-step rest-curvature update, the per-lane guard and
// re-orthonormalisation (one lane's frames start off orthonormal so that Björck runs), the
// guard run on demand and the observation getters.
#[test]
fn batched_arms_step_guard_and_observe_without_allocating() {
    use octoarm_physics::{batch::LANES, RodBatch, Vec3};
    let (model, state) = StraightRod::paper_arm().with_elements(20).build().unwrap();
    let mut sim = Simulation::new(model, state, settings()).unwrap();
    sim.set_damping(Damping::mass_proportional(10.0)).unwrap();
    let mut batch = RodBatch::new(&sim, LANES).unwrap();
    let mut skewed = sim.clone();
    for a in &mut skewed.state.director.m {
        for x in a.iter_mut() {
            *x *= 1.0 + 1e-9;
        }
    }
    batch.set_lane(1, &skewed).unwrap();
    assert!(max_defect(&skewed.state) > 1e-9);
    let update = |lane: usize, k: &mut [Vec3]| {
        for kap in k.iter_mut() {
            kap[1] += 0.01 * (lane as f64 - kap[1]);
        }
    };
    let mut out = [vec![0.0; 21], vec![0.0; 21], vec![0.0; 21]];
    let n = allocations_during(|| {
        batch.run_with(STEPS as u64, Some(&update));
        assert_eq!(batch.check(), 0);
        let [x, y, z] = &mut out;
        batch.positions(3, [x, y, z]).unwrap();
        batch.velocities(3, [x, y, z]).unwrap();
    });
    assert_eq!(n, 0, "{n} heap allocations in {STEPS} batched steps");
    let lane = batch.simulation(1).unwrap();
    assert_eq!(lane.state.step, STEPS as u64);
    assert!(max_defect(&lane.state) < 1e-12, "Björck ran on lane 1");
}
