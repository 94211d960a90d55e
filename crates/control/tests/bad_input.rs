//! Claim (spec §3.4, §7 test 10, issue item 6): bad task input gets a clear, named error or a
//! documented detected outcome, never a silent NaN: negative weights, non-positive diameters,
//! off-plane points, an obstacle enclosing the base and a target beyond 1.5 L0 are rejected with
//! the field named; a target inside 1.5 L0 but out of reach returns the *unreachable* warning
//! with finite strains; a diverging learning rate returns *Diverged* (see `update_rules`); a
//! degenerate design is refused by the controller; a starting shape inside an obstacle is
//! reported as *initial penetration*. The `ShapingController` rejects bad settings with the
//! setting named (period, ramp time, grasp stages, iterations per update, trust form time), a
//! schedule with neither target nor grasp (`NoTask`), a rod that is not clamped at its base and
//! free at its tip (`Ends`, naming both conditions), and a task the solver rejects (`Solve`).
//! Independent reference: the error text must name the field (checked by substring), and every
//! returned strain field is checked finite. A solver without validation would return NaN
//! (negative ξ makes J unbounded below) or silently run into the base sphere.

mod common;
use common::*;
use octoarm_control::{
    ControlError, DesignMode, EnergyShapingController, Grasp, GraspWeight, OfflineSolver,
    ShapingConfig, ShapingController, ShapingControllerConfig, ShapingError, SolveError,
    SolverConfig, Task, TaskError, TaskSchedule, Warning,
};
use octoarm_physics::{EndCondition, Settings, Simulation};

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
    assert!(EnergyShapingController::new(&model, ShapingConfig { damping_rate: -1.0 }).is_err());
}

/// `ShapingController::new` for experiment A's schedule on the paper arm with these ends.
fn controller(
    base: EndCondition,
    tip: EndCondition,
    schedule: TaskSchedule,
    config: ShapingControllerConfig,
) -> Result<ShapingController, ControlError> {
    let (model, state) = paper_arm();
    let sim = Simulation::with_ends(model, state, base, tip, Settings::with_dt(1e-5)).unwrap();
    ShapingController::new(&sim.system, &sim.state, 0, schedule, config)
}

fn clamped_free(
    schedule: TaskSchedule,
    config: ShapingControllerConfig,
) -> Result<ShapingController, ControlError> {
    controller(EndCondition::Clamped, EndCondition::Free, schedule, config)
}

fn expect_out_of_range(result: Result<ShapingController, ControlError>, name: &str, bad: f64) {
    let err = result.unwrap_err();
    let text = err.to_string();
    println!("{text}");
    match err {
        ControlError::OutOfRange { field, value, .. } => {
            assert_eq!(field, name, "{text}");
            assert!(value == bad || (value.is_nan() && bad.is_nan()), "{text}");
        }
        other => panic!("expected OutOfRange for {name}, got {other:?}"),
    }
    assert!(text.contains(name), "'{text}' does not name '{name}'");
}

#[test]
fn shaping_controller_rejects_bad_settings() {
    let online = |iterations_per_update, trust_form_time| ShapingControllerConfig {
        mode: DesignMode::Online {
            iterations_per_update,
            trust_form_time,
            presolve: false,
        },
        ..paper_a_config()
    };
    let offline = |ramp_time, grasp_stages| ShapingControllerConfig {
        mode: DesignMode::Offline {
            ramp_time,
            grasp_stages,
        },
        ..paper_a_config()
    };
    for period in [0.0, -1e-3, f64::NAN, f64::INFINITY] {
        expect_out_of_range(
            clamped_free(
                paper_a_schedule(),
                ShapingControllerConfig {
                    period,
                    ..paper_a_config()
                },
            ),
            "period",
            period,
        );
    }
    for ramp in [-1.0, f64::NAN] {
        expect_out_of_range(
            clamped_free(paper_a_schedule(), offline(ramp, 4)),
            "ramp_time",
            ramp,
        );
    }
    expect_out_of_range(
        clamped_free(paper_a_schedule(), offline(0.0, 0)),
        "grasp_stages",
        0.0,
    );
    expect_out_of_range(
        clamped_free(paper_b_schedule(), online(0, None)),
        "iterations_per_update",
        0.0,
    );
    expect_out_of_range(
        clamped_free(paper_b_schedule(), online(10, Some(0.0))),
        "trust_form_time",
        0.0,
    );
    // Neither a target nor a grasp.
    let empty = TaskSchedule {
        targets: Vec::new(),
        ..paper_a_schedule()
    };
    let err = clamped_free(empty, paper_a_config()).unwrap_err();
    println!("{err}");
    assert_eq!(err, ControlError::NoTask);
    // The statics assume a clamped base and a free tip.
    for (base, tip) in [
        (EndCondition::Free, EndCondition::Free),
        (EndCondition::Pinned, EndCondition::Free),
        (EndCondition::Clamped, EndCondition::Clamped),
    ] {
        let (bn, tn) = (base.name(), tip.name());
        let err = controller(base, tip, paper_a_schedule(), paper_a_config()).unwrap_err();
        let text = err.to_string();
        println!("{text}");
        assert!(
            matches!(&err, ControlError::Ends { base, tip, .. } if *base == bn && *tip == tn),
            "{err:?}"
        );
        assert!(text.contains(bn) && text.contains(tn), "{text}");
    }
    // A task the solver rejects is reported as such (a target beyond 1.5 L0).
    let far = TaskSchedule {
        targets: vec![octoarm_control::TargetPhase::fixed([0.5, 0.0, 0.0], 0.0)],
        ..paper_a_schedule()
    };
    let err = clamped_free(far, paper_a_config()).unwrap_err();
    println!("{err}");
    assert!(
        matches!(
            err,
            ControlError::Solve(SolveError::Task(TaskError::TargetTooFar { .. }))
        ),
        "{err:?}"
    );
    // And the valid settings build.
    assert!(clamped_free(paper_a_schedule(), offline(0.0, 4)).is_ok());
}
