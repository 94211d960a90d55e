//! Design-time benchmark (muscles-3d spec §9): COOMM's arm, task A (p* = (0.01, 0.15, 0.06) m
//! with COOMM's tip frame), projected L-BFGS stopped when §7 A's design bounds are met (tip error
//! ≤ 30 µm, θ_Q ≤ 1e-3 rad, J ≤ 0.15): from a = 0, and warm-started from the design of a target
//! 1 cm away. Prints the median wall time of 3 runs with the evaluation and Newton counts, with
//! the analytic equilibrium Jacobian (the default) and, in the same sitting, with the coloured
//! finite-difference one; also the thread's own CPU time (`/proc/thread-self/schedstat`), which
//! a machine shared with other work inflates less than the wall time. An argument `analytic` or
//! `finite` runs only that Jacobian's cases.
//! Run: `cargo bench -p octoarm-control --bench muscle_design`.
#![allow(missing_docs)]
use octoarm_control::{JacobianKind, MuscleDesign, MuscleStatics, ReachTask};
use octoarm_physics::{MuscleModel, MuscleSpec, StraightRod, N_GROUPS};

fn main() {
    let (model, state) = StraightRod::coomm_arm().build().unwrap();
    let n = model.n_elements;
    let mm = MuscleModel::new(MuscleSpec::coomm(), &model).unwrap();
    let mut base = MuscleStatics::new(&model, mm, state.position[0], state.director[0]);
    let tip0 = state.position[n];
    let task = ReachTask::coomm([0.01, 0.15, 0.06], [0.0; 3], tip0);
    let near = ReachTask::coomm([0.01, 0.14, 0.06], [0.0; 3], tip0);
    let bounds = Some((1.5e-4 * 0.2, 1e-3, 0.15));
    let run = |base: &MuscleStatics, from: &[f64], warm_task: Option<&ReachTask>| {
        let mut d = MuscleDesign::new(base.clone());
        d.config.stop_when = bounds;
        let mut a0 = from.to_vec();
        if let Some(t) = warm_task {
            // The neighbouring design (not timed), then its equilibrium as the warm start.
            let (a, _) = d.solve(t, from);
            a0 = a;
        }
        let c0 = cpu_ns();
        let (_, rep) = d.solve(&task, &a0);
        (rep, (cpu_ns() - c0) as f64 * 1e-6)
    };
    let zero = vec![0.0; N_GROUPS * n];
    let only: Option<String> = std::env::args()
        .skip(1)
        .find(|a| a == "analytic" || a == "finite");
    for (kind, name, warm) in [
        (JacobianKind::Analytic, "from a = 0", None),
        (
            JacobianKind::Analytic,
            "warm, target 1 cm away",
            Some(&near),
        ),
        (JacobianKind::FiniteDifference, "from a = 0", None),
        (
            JacobianKind::FiniteDifference,
            "warm, target 1 cm away",
            Some(&near),
        ),
    ] {
        if only
            .as_deref()
            .is_some_and(|o| (o == "analytic") != (kind == JacobianKind::Analytic))
        {
            continue;
        }
        base.config.jacobian = kind;
        let mut reps: Vec<_> = (0..3).map(|_| run(&base, &zero, warm)).collect();
        reps.sort_by(|a, b| a.0.seconds.total_cmp(&b.0.seconds));
        let r = reps[1].0;
        let mut cpu: Vec<f64> = reps.iter().map(|r| r.1).collect();
        cpu.sort_by(f64::total_cmp);
        println!(
            "design A {name} ({kind:?} Jacobian): {:.1} ms median of 3 (CPU time {:.1} ms; {:?}, {} iterations, {} evaluations, {} Newton + {} chord iterations; tip {:.2} µm, θ_Q {:.2e} rad, J {:.4})",
            1e3 * r.seconds,
            cpu[1],
            r.outcome,
            r.iterations,
            r.evaluations,
            r.newton_iterations,
            r.chord_iterations,
            1e6 * r.costs.tip_error,
            r.costs.orientation_error,
            r.costs.total
        );
    }
}

/// On-CPU time of this thread [ns] (Linux).
fn cpu_ns() -> u64 {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat")
        .expect("/proc/thread-self/schedstat (Linux)");
    s.split_whitespace().next().unwrap().parse().unwrap()
}
