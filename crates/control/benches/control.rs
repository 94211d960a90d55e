//! Criterion benchmarks of the control crate (spec §7 item 11): one sweep for N = 25..400
//! (target ≤ 5 µs at N = 100), the offline L-BFGS solve for (9, 9) cm at N = 100 (≤ 50 ms), and
//! a closed-loop step against a plain simulation step at N = 100 (overhead ≤ 30 %), and the
//! closed-loop step with the energy-consistent correction on.
#![allow(missing_docs)] // criterion_group! generates an undocumented function.
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use octoarm_control::{
    EnergyShapingController, OfflineSolver, ShapingConfig, SolverConfig, Statics, StrainSpace, Task,
};
use octoarm_physics::{Damping, Settings, Simulation, StraightRod};

fn bench_sweep(c: &mut Criterion) {
    let mut group = c.benchmark_group("sweep");
    for n in [25usize, 50, 100, 200, 400] {
        let (model, state) = StraightRod::paper_arm().with_elements(n).build().unwrap();
        let task = Task::reach([0.09, 0.09, 0.0], 1e3);
        // A bent field: the offline design for (9, 9) cm.
        let mut solver = OfflineSolver::new(&model, &state, SolverConfig::default()).unwrap();
        let w = solver.solve(&task, None).unwrap().strains;
        let mut st = Statics::new(&model, &state, StrainSpace::Planar, 4e-3).unwrap();
        let mut grad = vec![0.0; 6 * n - 3];
        group.bench_with_input(BenchmarkId::new("paper_arm", n), &n, |b, _| {
            b.iter(|| st.sweep(&w, &task, &mut grad).total);
        });
    }
    group.finish();
}

fn bench_offline(c: &mut Criterion) {
    let (model, state) = StraightRod::paper_arm().build().unwrap();
    let task = Task::reach([0.09, 0.09, 0.0], 1e3);
    let mut solver = OfflineSolver::new(&model, &state, SolverConfig::default()).unwrap();
    c.bench_function("offline_solve/target_9_9cm/100", |b| {
        b.iter(|| solver.solve(&task, None).unwrap().report.sweeps)
    });
}

fn bench_closed_loop(c: &mut Criterion) {
    let (model, state) = StraightRod::paper_arm().build().unwrap();
    let mut solver = OfflineSolver::new(&model, &state, SolverConfig::default()).unwrap();
    let w = solver
        .solve(&Task::reach([0.09, 0.09, 0.0], 1e3), None)
        .unwrap()
        .strains;
    let mut group = c.benchmark_group("step");
    let mut sim = Simulation::new(model.clone(), state, Settings::with_dt(1e-5)).unwrap();
    let mut ctrl = EnergyShapingController::new(&model, ShapingConfig::default()).unwrap();
    ctrl.set_design(&model, &w).unwrap();
    ctrl.attach(&mut sim).unwrap();
    // Start both from a bent, moving state.
    ctrl.run(&mut sim, 2000).unwrap();
    let mut plain =
        Simulation::new(model.clone(), sim.rod_state(), Settings::with_dt(1e-5)).unwrap();
    plain.set_damping(Damping::mass_proportional(10.0)).unwrap();
    group.bench_function("plain/100", |b| b.iter(|| plain.step().unwrap()));
    group.bench_function("energy_shaping/100", |b| {
        b.iter(|| ctrl.step(&mut sim).unwrap())
    });
    // The law with the energy-consistent correction on (the stepper adds the difference of the
    // eq. 4.5 corrections; this replaces the former two-load-evaluation form of the law).
    let mut sim_ec = Simulation::new(
        model.clone(),
        sim.rod_state(),
        Settings {
            energy_consistent: true,
            ..Settings::with_dt(1e-5)
        },
    )
    .unwrap();
    let mut ctrl_ec = EnergyShapingController::new(&model, ShapingConfig::default()).unwrap();
    ctrl_ec.set_design(&model, &w).unwrap();
    ctrl_ec.attach(&mut sim_ec).unwrap();
    group.bench_function("energy_shaping_energy_consistent/100", |b| {
        b.iter(|| ctrl_ec.step(&mut sim_ec).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench_sweep, bench_offline, bench_closed_loop);
criterion_main!(benches);
