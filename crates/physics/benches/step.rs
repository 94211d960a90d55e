//! Criterion benchmark: µs per step of the paper's arm (damping + tip force) for N = 25..400.
#![allow(missing_docs)] // criterion_group! generates an undocumented public function
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use octoarm_physics::{Damping, Load, Settings, Simulation, StraightRod};

fn arm(n: usize) -> Simulation {
    let (model, state) = StraightRod::paper_arm().with_elements(n).build().unwrap();
    let dt = (1e-5f64).min(0.1 * model.stable_dt());
    let mut sim = Simulation::new(model, state, Settings::with_dt(dt)).unwrap();
    sim.set_damping(Damping::mass_proportional(10.0)).unwrap();
    sim.add_load(Load::tip_force(n, [0.0, 2e-5, 0.0])).unwrap();
    // Start from a bent, moving state so that no branch sees only the rest state.
    sim.run(2000).unwrap();
    sim
}

fn bench_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("step");
    for n in [25usize, 50, 100, 200, 400] {
        let mut sim = arm(n);
        group.bench_with_input(BenchmarkId::new("paper_arm", n), &n, |b, _| {
            b.iter(|| sim.step().unwrap());
        });
    }
    group.finish();
}

criterion_group!(benches, bench_step);
criterion_main!(benches);
