//! Claim: a time step performs no heap allocation (spec §6 "All scratch arrays are allocated
//! once", §14) — not `step()`, not `step_with` with a load closure, and not the periodic paths
//! (stability guard, orthonormality check, Björck re-orthonormalisation), with contact, rate and
//! per-length damping, the energy-consistent model and a change of damping between steps.
//!
//! Reference: a counting global allocator. Every `alloc`, `alloc_zeroed` and `realloc` made by the
//! current thread is counted (per thread, so tests running in parallel do not disturb each other),
//! and the count over hundreds of steps must be exactly zero.
//!
//! A wrong implementation fails if any stage collects into a new `Vec`, grows a buffer, formats a
//! string on the success path, or sizes its scratch lazily on the first step.

use octoarm_physics::{
    max_penetration, AnalyticalDamper, Damping, Load, Settings, Simulation, Sphere, StraightRod,
};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

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
    assert!(
        sim.state.tip()[1] > 0.0,
        "the tip force should have bent the arm"
    );
}

#[test]
fn step_with_closure_contact_and_damping_does_not_allocate() {
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
    let (r, x) = (sim.model.radius[75], sim.model.node_arc_length[75]);
    sim.add_obstacle(Sphere::fixed([x, r + 0.01 - 2e-5, 0.0], 0.01))
        .unwrap();
    assert!(max_penetration(&sim.model, &sim.state, &sim.obstacles).0 > 0.0);

    let mut calls = 0u64;
    let mut contact_steps = 0u64;
    let n = allocations_during(|| {
        for k in 0..STEPS {
            sim.step_with(|_, state, internal, external| {
                // A controller-like load: reads state and internal loads, writes forces and couples.
                calls += 1;
                // Only contact pushes nodes 75/76 along −y (the sphere sits above them).
                contact_steps +=
                    u64::from(external.force[75][1] < 0.0 || external.force[76][1] < 0.0);
                let tip = state.position.len() - 1;
                external.force[tip][2] +=
                    1e-7 * (k as f64 * 0.01).sin() - 1e-3 * internal.force[tip][2];
                external.couple[50][0] += 1e-9;
            })
            .unwrap();
            if k == STEPS / 2 {
                // Changing the damping between steps recomputes the kick factors in place.
                sim.damping.rate = 5.0;
                sim.damping.analytical = Some(AnalyticalDamper::Uniform { nu: 1.0 });
            }
        }
        sim.run(50).unwrap();
    });
    assert_eq!(n, 0, "{n} heap allocations in {} steps", STEPS + 50);
    assert_eq!(calls, STEPS as u64);
    assert!(contact_steps > 0, "the contact forces never acted");
}
