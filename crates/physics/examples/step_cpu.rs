//! CPU time per step of the paper's arm for each kernel, on a machine shared with other work:
//! the thread's own on-CPU time (Linux `/proc/thread-self/schedstat`, nanoseconds) instead of
//! the wall time, which on a loaded machine counts the time the thread waits for a core. The
//! kernels and sizes alternate in rounds so that their ratios come from the same sitting.
//!
//! ```sh
//! cargo run --release -p octoarm-physics --example step_cpu -- [steps] [rounds] [N...]
//! ```
//!
//! Prints, per kernel and N, the median over rounds of the CPU time per step and per
//! element-step. (Criterion's bench `benches/step.rs` is the reference on an idle machine.)
use octoarm_physics::kernel::Kernel;
use octoarm_physics::{Damping, Load, Settings, Simulation, StraightRod};

fn arm(n: usize, kernel: Kernel) -> Simulation {
    let (model, state) = StraightRod::paper_arm().with_elements(n).build().unwrap();
    let dt = (1e-5f64).min(0.1 * model.stable_dt());
    let mut sim = Simulation::new(model, state, Settings::with_dt(dt)).unwrap();
    sim.set_damping(Damping::mass_proportional(10.0)).unwrap();
    sim.add_load(Load::tip_force(n, [0.0, 2e-5, 0.0])).unwrap();
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
    let rounds: usize = args.get(1).map_or(5, |a| a.parse().unwrap());
    let sizes: Vec<usize> = if args.len() > 2 {
        args[2..].iter().map(|a| a.parse().unwrap()).collect()
    } else {
        vec![25, 50, 100, 200, 400, 1000]
    };
    let kernels: Vec<Kernel> = Kernel::ALL
        .into_iter()
        .filter(|k| k.is_available())
        .collect();
    let mut sims: Vec<Vec<Simulation>> = sizes
        .iter()
        .map(|&n| kernels.iter().map(|&k| arm(n, k)).collect())
        .collect();
    let mut times = vec![vec![Vec::new(); kernels.len()]; sizes.len()];
    for _ in 0..rounds {
        for (a, &n) in sizes.iter().enumerate() {
            // Fewer steps for long arms: about the same CPU time per measurement.
            let m = (steps * 100 / n as u64).max(100);
            for (b, sim) in sims[a].iter_mut().enumerate() {
                let t0 = cpu_ns();
                for _ in 0..m {
                    sim.step().unwrap();
                }
                times[a][b].push((cpu_ns() - t0) as f64 / m as f64);
            }
        }
    }
    println!(
        "{:>6} {:>9} {:>12} {:>16}",
        "N", "kernel", "µs/step", "ns/element-step"
    );
    for (a, &n) in sizes.iter().enumerate() {
        for (b, k) in kernels.iter().enumerate() {
            let t = &mut times[a][b];
            t.sort_by(f64::total_cmp);
            let med = t[t.len() / 2];
            println!(
                "{n:>6} {:>9} {:>12.3} {:>16.1}",
                k.name(),
                med / 1e3,
                med / n as f64
            );
        }
    }
}
