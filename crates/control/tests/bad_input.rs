//! Claim (spec §3.4, §7 test 10, issue item 6): bad task input gets a clear, named error or a
//! documented detected outcome, never a silent NaN: negative weights, non-positive diameters,
//! off-plane points, an obstacle enclosing the base and a target beyond 1.5 L0 are rejected with
//! the field named; a target inside 1.5 L0 but out of reach returns the *unreachable* warning
//! with finite strains; a diverging learning rate returns *Diverged* (see `update_rules`); a
//! degenerate design is refused by the controller; a starting shape inside an obstacle is
//! reported as *initial penetration*.
//! Independent reference: the error text must name the field (checked by substring), and every
//! returned strain field is checked finite. A solver without validation would return NaN
//! (negative ξ makes J unbounded below) or silently run into the base sphere.

mod common;
use common::*;
use octoarm_control::{
    EnergyShapingController, Grasp, GraspWeight, OfflineSolver, ShapingConfig, ShapingError,
    SolveError, SolverConfig, Task, TaskError, Warning,
};

fn solver() -> OfflineSolver {
    let (model, state) = paper_arm();
    OfflineSolver::new(&model, &state, SolverConfig::default()).unwrap()
}

fn expect_task_error(task: &Task, needle: &str) {
    let err = solver().solve(task, None).unwrap_err();
    let text = err.to_string();
    println!("{text}");
    assert!(matches!(err, SolveError::Task(_)), "{err:?}");
    assert!(text.contains(needle), "'{text}' does not name '{needle}'");
}

#[test]
fn bad_tasks_are_rejected_with_named_fields() {
    expect_task_error(&Task::reach([0.09, 0.09, 0.0], -1.0), "mu_tip");
    expect_task_error(
        &Task::reach([0.09, 0.09, 0.0], 1e3).with_obstacle([0.1, 0.1, 0.0], 0.05, -1.0),
        "obstacles[0].weight (xi)",
    );
    expect_task_error(
        &Task::reach([0.09, 0.09, 0.0], 1e3).with_obstacle([0.1, 0.1, 0.0], 0.0, 1e5),
        "obstacles[0].diameter",
    );
    expect_task_error(&Task::reach([0.09, 0.09, 0.01], 1e3), "off the plane");
    expect_task_error(&Task::reach([f64::NAN, 0.09, 0.0], 1e3), "tip.position[0]");
    let mut g = Grasp::paper([0.1, 0.05, 0.0], 0.02, 1e3, L0);
    g.weight = GraspWeight::Interval {
        weight: -5.0,
        from: 0.08,
        to: 0.2,
    };
    expect_task_error(
        &Task {
            grasp: Some(g.clone()),
            ..Task::default()
        },
        "mu_grasp",
    );
    g.weight = GraspWeight::Interval {
        weight: 1e3,
        from: 0.08,
        to: 0.2,
    };
    g.smoothing = -1e-3;
    expect_task_error(
        &Task {
            grasp: Some(g),
            ..Task::default()
        },
        "epsilon",
    );
    // An obstacle enclosing the base.
    let err = solver()
        .solve(
            &Task::reach([0.09, 0.09, 0.0], 1e3).with_obstacle([0.01, 0.0, 0.0], 0.04, 1e5),
            None,
        )
        .unwrap_err();
    println!("{err}");
    assert!(matches!(
        err,
        SolveError::Task(TaskError::ObstacleContainsBase { index: 0, .. })
    ));
    // A target beyond 1.5 L0.
    let err = solver()
        .solve(&Task::reach([0.5, 0.0, 0.0], 1e3), None)
        .unwrap_err();
    println!("{err}");
    assert!(matches!(
        err,
        SolveError::Task(TaskError::TargetTooFar { .. })
    ));
}

#[test]
fn unreachable_target_is_reported_not_nan() {
    let mut s = solver();
    let sol = s.solve(&Task::reach([0.28, 0.0, 0.0], 1e3), None).unwrap();
    println!(
        "target (28, 0) cm: {:?}, tip error {:.3e} m, warnings {:?}",
        sol.report.outcome, sol.report.tip_error, sol.report.warnings
    );
    assert!(sol.strains.is_finite() && sol.report.cost.total.is_finite());
    assert!(sol
        .report
        .warnings
        .iter()
        .any(|w| matches!(w, Warning::Unreachable { .. })));
}

#[test]
fn initial_penetration_is_reported() {
    let mut s = solver();
    // The straight arm runs through this sphere; the penalty pushes the design out.
    let task = Task::reach([0.09, 0.09, 0.0], 1e3).with_obstacle([0.15, 0.0, 0.0], 0.02, 1e5);
    let sol = s.solve(&task, None).unwrap();
    println!(
        "warnings {:?}, final penetration {:.2e} m",
        sol.report.warnings, sol.report.max_penetration
    );
    assert!(sol
        .report
        .warnings
        .iter()
        .any(|w| matches!(w, Warning::InitialPenetration { .. })));
    assert!(sol.strains.is_finite());
}

#[test]
fn controller_refuses_degenerate_designs() {
    let (model, _) = paper_arm();
    let mut ctrl = EnergyShapingController::new(&model, ShapingConfig::default()).unwrap();
    let good = ctrl.design().clone();
    let mut w = good.clone();
    w.set_kappa(50, [0.0, 900.0, 0.0]); // D̂|κ| = 1.8 rad ≥ π/2
    let err = ctrl.set_design(&model, &w).unwrap_err();
    println!("{err}");
    assert!(matches!(
        err,
        ShapingError::DegenerateDesign { index: 50, .. }
    ));
    let mut w = good.clone();
    w.set_nu(10, [0.0, 0.0, -0.1]);
    assert!(matches!(
        ctrl.set_design(&model, &w).unwrap_err(),
        ShapingError::DegenerateDesign { index: 10, .. }
    ));
    let mut w = good.clone();
    w.set_nu(3, [f64::NAN, 0.0, 1.0]);
    assert!(ctrl.set_design(&model, &w).is_err());
    assert_eq!(ctrl.design(), &good, "the previous design stays in force");
    assert!(EnergyShapingController::new(
        &model,
        ShapingConfig {
            damping_rate: -1.0,
            ..ShapingConfig::default()
        }
    )
    .is_err());
}
