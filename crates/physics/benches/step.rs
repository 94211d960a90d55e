//! Criterion benchmark: time per step of the paper's arm (damping + tip force) for N = 25..1000,
//! with each kernel this CPU can run (`octoarm_physics::kernel`), interleaved in one process so
//! that their ratio is measured in the same sitting. Throughput is in elements: criterion's
//! "thrpt" is element-steps per second (its inverse is the cost per element-step).
#![allow(missing_docs)] // criterion_group! generates an undocumented public function
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use octoarm_physics::kernel::Kernel;
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
    for n in [25usize, 50, 100, 200, 400, 1000] {
        group.throughput(Throughput::Elements(n as u64));
        for kernel in Kernel::ALL.into_iter().filter(|k| k.is_available()) {
            let mut sim = arm(n);
            sim.workspace.set_kernel(kernel);
            let id = BenchmarkId::new(format!("paper_arm/{}", kernel.name()), n);
            group.bench_with_input(id, &n, |b, _| {
                b.iter(|| sim.step().unwrap());
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench_step);
criterion_main!(benches);
