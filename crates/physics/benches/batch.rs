//! Criterion benchmark: batched arms (`RodBatch`, SIMD lanes across rods) against the same rods
//! stepped one `Simulation` at a time, for 64 of the RL environment's arms (N = 20, dt = 5e-5 s)
//! and 64 paper arms (N = 100, dt = 1e-5 s), each from a bent, moving state with per-lane rest
//! curvatures. Throughput is in element-steps (criterion's "thrpt"; ns per element-step =
//! 1e9 / thrpt). One thread (a one-worker rayon pool) and two threads, interleaved in one
//! process so that their ratio is measured in the same sitting. One iteration = 10 steps of
//! every rod (one `run` call, as the environment runs a control period in one call).
#![allow(missing_docs)] // criterion_group! generates an undocumented public function
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use octoarm_physics::{Damping, RodBatch, Settings, Simulation, StraightRod};

const ARMS: usize = 64;
const STEPS: u64 = 10;

/// Arm `lane` of a batch: bent by its own rest curvature for 2000 steps (4 mm tip for N = 20,
/// the environment's arm; the paper's 0.4 mm tip for N = 100).
fn arm(n: usize, lane: usize) -> Simulation {
    let rod = if n == 20 {
        StraightRod {
            tip_diameter: 0.004,
            ..StraightRod::paper_arm().with_elements(n)
        }
    } else {
        StraightRod::paper_arm().with_elements(n)
    };
    let dt = if n == 20 { 5e-5 } else { 1e-5 };
    let (model, state) = rod.build().unwrap();
    let mut sim = Simulation::new(model, state, Settings::with_dt(dt)).unwrap();
    sim.set_damping(Damping::mass_proportional(10.0)).unwrap();
    for k in &mut sim.system.rest_kappa {
        k[1] = 2.0 + 0.2 * lane as f64;
    }
    sim.run(2000).unwrap();
    sim
}

fn bench_batch(c: &mut Criterion) {
    let mut group = c.benchmark_group("batch");
    let pools: Vec<(usize, rayon::ThreadPool)> = [1usize, 2]
        .into_iter()
        .map(|t| {
            let p = rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap();
            (t, p)
        })
        .collect();
    for n in [20usize, 100] {
        group.throughput(Throughput::Elements((ARMS * n) as u64 * STEPS));
        let mut sims: Vec<Simulation> = (0..ARMS).map(|l| arm(n, l)).collect();
        let mut batch = RodBatch::new(&sims[0], ARMS).unwrap();
        for (l, s) in sims.iter().enumerate() {
            batch.set_lane(l, s).unwrap();
        }
        let id = BenchmarkId::new(format!("{ARMS}_separate_sims/1_thread"), n);
        group.bench_with_input(id, &n, |b, _| {
            b.iter(|| {
                for s in sims.iter_mut() {
                    for _ in 0..STEPS {
                        s.step().unwrap();
                    }
                }
            })
        });
        for (t, pool) in &pools {
            let id = BenchmarkId::new(format!("{ARMS}_arms_batch/{t}_thread"), n);
            group.bench_with_input(id, &n, |b, _| {
                pool.install(|| b.iter(|| batch.run(STEPS)));
            });
        }
        assert_eq!(batch.check(), 0, "every lane stays stable");
    }
    group.finish();
}

criterion_group!(benches, bench_batch);
criterion_main!(benches);
