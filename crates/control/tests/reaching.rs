//! Claim (spec §7 test 5, issue item 3): offline L-BFGS solves for the targets (9, 9), (0, 2) and
//! (12, 9) cm reach the stopping rule within 5000 sweeps with tip error ≤ 1e-4 L0, the cost never
//! increases, the tip error equals the required tip force over μ_tip (the error the penalty
//! implies) and falls ≥ 5× when μ_tip goes from 1e3 to 1e4 N/m.
//! Independent reference: the transversality condition n_{N−1} = μ_tip (r* − r_N) read from the
//! costate, and the tip force F of the μ_tip = 1e4 solution: the μ_tip = 1e3 error must be close
//! to |F|/1e3 (the arm's compliance at the design is small against 1/μ_tip), so the error scales
//! as 1/μ_tip. A wrong gradient stalls with a large residual; a wrong tip term misses the target.
//! Tolerances: the spec's acceptance numbers (reference prototype measured 0.7–7 µm).

mod common;
use common::*;
use octoarm_control::{OfflineSolver, Outcome, SolverConfig, Task};
use octoarm_physics::math::norm;

#[test]
fn offline_solutions_reach_the_paper_targets() {
    let (model, state) = paper_arm();
    let mut solver = OfflineSolver::new(&model, &state, SolverConfig::default()).unwrap();
    for target in [[0.09, 0.09, 0.0], [0.0, 0.02, 0.0], [0.12, 0.09, 0.0]] {
        let mut errors = Vec::new();
        let mut warm = None;
        for mu in [1e3, 1e4] {
            // μ_tip = 1e4 is warm-started from the 1e3 design (continuation in μ_tip).
            let sol = solver
                .solve(&Task::reach(target, mu), warm.as_ref())
                .unwrap();
            let rep = &sol.report;
            let force = norm(solver.statics().force_costate()[model.n_elements - 1]);
            println!(
                "target {:?} cm, mu_tip {mu:.0e}: {:?}/{:?}, {} iterations, {} sweeps, J = {:.6e}, tip error {:.3e} m = {:.2e} L0, |F_tip|/mu = {:.3e}, residual {:.1e}, {:.1} ms",
                target.map(|x| x * 100.0),
                rep.outcome,
                rep.stop,
                rep.iterations,
                rep.sweeps,
                rep.cost.total,
                rep.tip_error,
                rep.tip_error / L0,
                force / mu,
                rep.residual,
                rep.wall_time.as_secs_f64() * 1e3
            );
            assert_eq!(rep.outcome, Outcome::Converged);
            assert!(rep.is_admissible(), "{:?}", rep.warnings);
            assert!(rep.warnings.is_empty(), "{:?}", rep.warnings);
            if mu == 1e3 {
                assert!(rep.sweeps <= 5000, "{} sweeps", rep.sweeps);
                assert!(rep.tip_error <= 1e-4 * L0, "{}", rep.tip_error);
            }
            // Transversality: the tip error is the tip force over the spring stiffness.
            assert!((rep.tip_error - force / mu).abs() <= 1e-9 * L0);
            errors.push((rep.tip_error, force));
            warm = Some(sol.strains.clone());
        }
        let ratio = errors[0].0 / errors[1].0;
        println!("  tip error ratio mu 1e3 / 1e4 = {ratio:.2}");
        assert!(ratio >= 5.0, "{ratio}");
        // The error at 1e3 is close to the force the design needs (from the 1e4 solution) over 1e3.
        let implied = errors[1].1 / 1e3;
        assert!(
            (errors[0].0 / implied - 1.0).abs() < 0.2,
            "{} vs {implied}",
            errors[0].0
        );
    }
}

#[test]
fn cost_never_increases_under_lbfgs() {
    // Rule Q accepts only Armijo steps: record J after each of a few hundred single-sweep-budget
    // solves would be slow, so instead run the solver in short budgets and check monotonicity.
    let (model, state) = paper_arm();
    let task = Task::reach([0.12, 0.09, 0.0], 1e3);
    let mut last = f64::INFINITY;
    let mut w = None;
    for _ in 0..40 {
        let cfg = SolverConfig {
            max_sweeps: 25,
            ..SolverConfig::default()
        };
        let mut s = OfflineSolver::new(&model, &state, cfg).unwrap();
        let sol = s.solve(&task, w.as_ref()).unwrap();
        assert!(
            sol.report.cost.total <= last * (1.0 + 1e-15),
            "{} > {last}",
            sol.report.cost.total
        );
        last = sol.report.cost.total;
        w = Some(sol.strains);
    }
}
