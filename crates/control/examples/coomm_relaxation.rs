//! COOMM's relaxation (muscles-3d spec §5.5) on experiment A against the L-BFGS design:
//! `cargo run --release -p octoarm-control --example coomm_relaxation -- [iterations ...]`
//! (default 1000 10000) prints, per iteration count and equilibrium mode (exact, one Picard
//! pass), the relaxation's J, Φ, tip error and θ_Q
//! from a = 0 with η = 1e-8, its wall time per iteration, and the L-BFGS
//! design's (2000 iterations from a = 0) for comparison. Wall times: run on an idle machine.
use octoarm_control::{CoommRelaxation, MuscleDesign, MuscleStatics, ReachTask};
use octoarm_physics::{MuscleModel, MuscleSpec, StraightRod, N_GROUPS};

fn main() {
    let counts: Vec<usize> = std::env::args()
        .skip(1)
        .map(|s| s.parse().expect("iteration count"))
        .collect();
    let counts = if counts.is_empty() {
        vec![1000, 10_000]
    } else {
        counts
    };
    let n = 100;
    let (model, state) = StraightRod::coomm_arm().with_elements(n).build().unwrap();
    let mm = MuscleModel::new(MuscleSpec::coomm(), &model).unwrap();
    let st = MuscleStatics::new(&model, mm, state.position[0], state.director[0]);
    let task = ReachTask::coomm([0.01, 0.15, 0.06], [0.0; 3], state.position[n]);
    let a0 = vec![0.0; N_GROUPS * n];
    let mut d = MuscleDesign::new(st.clone());
    let (_, lbfgs) = d.solve(&task, &a0);
    println!(
        "L-BFGS: {} iterations, {:.3} s, J {:.6}, Φ {:.3e}, R {:.6}, tip {:.3e} m, θ_Q {:.3e} rad ({:?})",
        lbfgs.iterations,
        lbfgs.seconds,
        lbfgs.costs.total,
        lbfgs.costs.total - lbfgs.costs.activation,
        lbfgs.costs.activation,
        lbfgs.costs.tip_error,
        lbfgs.costs.orientation_error,
        lbfgs.outcome
    );
    for (&it, picard_pass) in counts.iter().flat_map(|c| [(c, false), (c, true)]) {
        let mut d = MuscleDesign::new(st.clone());
        let cfg = CoommRelaxation {
            max_iterations: it,
            picard_pass,
            ..Default::default()
        };
        let (a, rep) = d.relax_coomm(&task, &a0, &cfg).unwrap();
        let amax = a.iter().fold(0.0f64, |m, v| m.max(*v));
        println!(
            "relaxation ({}) {} iterations: {:.3} s ({:.3} ms/iteration, {} Newton), J {:.6}, Φ {:.6}, \
             R {:.6}, tip {:.3e} m, θ_Q {:.3e} rad, max a {amax:.4}, last change {:.3e}",
            if picard_pass { "one Picard pass" } else { "exact equilibrium" },
            rep.iterations,
            rep.seconds,
            1e3 * rep.seconds / rep.iterations as f64,
            rep.newton_iterations,
            rep.costs.total,
            rep.costs.total - rep.costs.activation,
            rep.costs.activation,
            rep.costs.tip_error,
            rep.costs.orientation_error,
            rep.last_change
        );
    }
}
