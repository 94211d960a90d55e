//! Design-time benchmark (muscles-3d spec §9): COOMM's arm, task A (p* = (0.01, 0.15, 0.06) m
//! with COOMM's tip frame), projected L-BFGS stopped when §7 A's design bounds are met (tip error
//! ≤ 30 µm, θ_Q ≤ 1e-3 rad, J ≤ 0.15): from a = 0, and warm-started from the design of a target
//! 1 cm away. Prints the median wall time of 3 runs with the evaluation and Newton counts.
//! Run: `cargo bench -p octoarm-control --bench muscle_design`.
#![allow(missing_docs)]
use octoarm_control::{MuscleDesign, MuscleStatics, ReachTask};
use octoarm_physics::{MuscleModel, MuscleSpec, StraightRod, N_GROUPS};

fn main() {
    let (model, state) = StraightRod::coomm_arm().build().unwrap();
    let n = model.n_elements;
    let mm = MuscleModel::new(MuscleSpec::coomm(), &model).unwrap();
    let base = MuscleStatics::new(&model, mm, state.position[0], state.director[0]);
    let tip0 = state.position[n];
    let task = ReachTask::coomm([0.01, 0.15, 0.06], [0.0; 3], tip0);
    let near = ReachTask::coomm([0.01, 0.14, 0.06], [0.0; 3], tip0);
    let bounds = Some((1.5e-4 * 0.2, 1e-3, 0.15));
    let run = |from: &[f64], warm_task: Option<&ReachTask>| {
        let mut d = MuscleDesign::new(base.clone());
        d.config.stop_when = bounds;
        let mut a0 = from.to_vec();
        if let Some(t) = warm_task {
            // The neighbouring design (not timed), then its equilibrium as the warm start.
            let (a, _) = d.solve(t, from);
            a0 = a;
        }
        let (_, rep) = d.solve(&task, &a0);
        rep
    };
    let zero = vec![0.0; N_GROUPS * n];
    for (name, warm) in [
        ("from a = 0", None),
        ("warm, target 1 cm away", Some(&near)),
    ] {
        let mut reps: Vec<_> = (0..3).map(|_| run(&zero, warm)).collect();
        reps.sort_by(|a, b| a.seconds.total_cmp(&b.seconds));
        let r = reps[1];
        println!(
            "design A {name}: {:.1} ms median of 3 ({:?}, {} iterations, {} evaluations, {} Newton iterations; tip {:.2} µm, θ_Q {:.2e} rad, J {:.4})",
            1e3 * r.seconds,
            r.outcome,
            r.iterations,
            r.evaluations,
            r.newton_iterations,
            1e6 * r.costs.tip_error,
            r.costs.orientation_error,
            r.costs.total
        );
    }
}
