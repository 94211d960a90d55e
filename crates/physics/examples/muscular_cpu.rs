//! CPU time per step of COOMM's muscular arm (muscles-3d spec §9: N = 100, dt = 1e-5 s, all
//! thirteen fibres active, Morison drag, `coomm` damping) next to the bare paper arm of the same
//! size, for each kernel, on a machine shared with other work: the thread's own on-CPU time
//! (`/proc/thread-self/schedstat`), in alternating rounds so that the ratios come from the same
//! sitting (as `step_cpu`). Criterion's `benches/step.rs` (`muscular_arm_100`) is the reference
//! on an idle machine.
//!
//! ```sh
//! cargo run --release -p octoarm-physics --example muscular_cpu -- [steps] [rounds] [filter]
//! ```
//!
//! `filter`: run only the cases whose name contains it (e.g. `muscular_arm_100/avx2`, for
//! `perf record`).
use octoarm_physics::kernel::Kernel;
use octoarm_physics::{Damping, Load, MuscleSpec, Settings, Simulation, StraightRod};

fn paper_arm(kernel: Kernel) -> Simulation {
    let (model, state) = StraightRod::paper_arm().with_elements(100).build().unwrap();
    let mut sim = Simulation::new(model, state, Settings::with_dt(1e-5)).unwrap();
    sim.set_damping(Damping::mass_proportional(10.0)).unwrap();
    sim.add_load(Load::tip_force(100, [0.0, 2e-5, 0.0]))
        .unwrap();
    assert!(sim.workspace.set_kernel(kernel));
    sim.run(2000).unwrap();
    sim
}

/// The benchmark's muscular arm (`benches/step.rs`), 2000 steps in.
fn muscular_arm(kernel: Kernel) -> Simulation {
    let (model, state) = StraightRod::coomm_arm().build().unwrap();
    let n = model.n_elements;
    let drag = Load::coomm_drag(&model);
    let mut sim = Simulation::new(model, state, Settings::with_dt(1e-5)).unwrap();
    sim.set_damping(Damping::coomm(1050.0, 0.012)).unwrap();
    sim.add_load(drag).unwrap();
    sim.set_muscles(Some(MuscleSpec::coomm())).unwrap();
    for g in 0..7 {
        let a: Vec<f64> = (0..n)
            .map(|j| 0.1 + 0.05 * g as f64 + 0.1 * (j as f64 / n as f64))
            .collect();
        sim.set_activation(g, &a).unwrap();
    }
    assert!(sim.workspace.set_kernel(kernel));
    sim.run(2000).unwrap();
    sim
}

/// On-CPU time of this thread [ns].
fn cpu_ns() -> u64 {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat")
        .expect("/proc/thread-self/schedstat (Linux)");
    s.split_whitespace().next().unwrap().parse().unwrap()
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let steps: u64 = args.first().map_or(20_000, |a| a.parse().unwrap());
    let rounds: usize = args.get(1).map_or(7, |a| a.parse().unwrap());
    let kernels: Vec<Kernel> = Kernel::ALL
        .into_iter()
        .filter(|k| k.is_available())
        .collect();
    let mut sims: Vec<(String, Simulation)> = Vec::new();
    for &k in &kernels {
        sims.push((format!("paper_arm_100/{}", k.name()), paper_arm(k)));
        sims.push((format!("muscular_arm_100/{}", k.name()), muscular_arm(k)));
    }
    if let Some(f) = args.get(2) {
        sims.retain(|(name, _)| name.contains(f.as_str()));
    }
    let mut times = vec![Vec::new(); sims.len()];
    for _ in 0..rounds {
        for (i, (_, sim)) in sims.iter_mut().enumerate() {
            let t0 = cpu_ns();
            for _ in 0..steps {
                sim.step().unwrap();
            }
            times[i].push((cpu_ns() - t0) as f64 / steps as f64 / 1e3);
        }
    }
    for ((name, _), t) in sims.iter().zip(&mut times) {
        t.sort_by(f64::total_cmp);
        println!(
            "{name:28} median {:7.2} µs/step  (min {:7.2}, max {:7.2})",
            t[t.len() / 2],
            t[0],
            t[t.len() - 1]
        );
    }
}
