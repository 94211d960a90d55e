//! Claim (spec §3.3, §5.3): the online solver, 10 warm-started L-BFGS iterations per 1 ms update,
//! tracks a target that moves at 1 cm/s from (12, 9) cm (experiment B's target, design only):
//! after 0.5 s of updates the design's tip error stays ≤ 0.005 L0 at every update; the design in
//! force is always finite; the trust region caps every component's change per update; the
//! paper-literal schedule (1 iteration of rule R per update) runs without error.
//! Independent reference: the offline solution for the final target position (its tip error and
//! shape) — the online design must end near it.
//! A solver that forgets the warm start, or does not re-evaluate J after the target moved, lags
//! by far more than 0.005 L0 (the target moves 1e-5 m per update, 5e-5 L0).

mod common;
use common::*;
use octoarm_control::{OfflineSolver, OnlineConfig, OnlineSolver, SolverConfig, Task, UpdateRule};

#[test]
fn online_design_tracks_a_moving_target() {
    let (model, state) = paper_arm();
    let mut online = OnlineSolver::new(
        &model,
        &state,
        SolverConfig::default(),
        OnlineConfig::default(),
        None,
    )
    .unwrap();
    let mut task = Task::reach([0.12, 0.09, 0.0], 1e3);
    let mut worst_late: f64 = 0.0;
    let mut sweeps = 0;
    let updates = 2000; // 2 s at 1 ms
    for u in 0..updates {
        let t = u as f64 * 1e-3;
        task.set_target([0.12 - 0.01 * t, 0.09, 0.0]);
        let rep = online.update(&task).unwrap();
        sweeps += rep.sweeps;
        assert!(rep.accepted && online.design().is_finite());
        if t >= 0.5 {
            worst_late = worst_late.max(rep.tip_error);
        }
    }
    println!(
        "online: {updates} updates, {:.1} sweeps per update, worst design tip error after 0.5 s {:.2e} L0",
        sweeps as f64 / updates as f64,
        worst_late / L0
    );
    assert!(worst_late <= 0.005 * L0);
    // Compare with the offline design for the last target.
    let mut off = OfflineSolver::new(&model, &state, SolverConfig::default()).unwrap();
    let sol = off.solve(&task, None).unwrap();
    let gap = online
        .statics()
        .position()
        .iter()
        .zip(off.statics().position())
        .map(|(a, b)| dist(*a, *b))
        .fold(0.0, f64::max);
    println!(
        "online vs offline design for the final target: {:.2e} L0 (offline tip error {:.1e} m)",
        gap / L0,
        sol.report.tip_error
    );
    assert!(gap < 0.02 * L0);
}

#[test]
fn trust_region_caps_each_update() {
    let (model, state) = paper_arm();
    let task = Task::reach([0.09, 0.09, 0.0], 1e3);
    let mut off = OfflineSolver::new(&model, &state, SolverConfig::default()).unwrap();
    let fin = off.solve(&task, None).unwrap().strains;
    let rest = off.statics().rest().clone();
    let cap = OnlineConfig::trust_region_from(&fin, &rest, 1e-3, 1.5);
    let cfg = OnlineConfig {
        iterations_per_update: 10,
        trust_region: Some(cap.clone()),
    };
    let mut online = OnlineSolver::new(&model, &state, SolverConfig::default(), cfg, None).unwrap();
    let mut prev = online.design().clone();
    let mut limited = 0;
    for _ in 0..200 {
        let rep = online.update(&task).unwrap();
        limited += rep.limited as usize;
        for ((a, b), c) in online
            .design()
            .as_slice()
            .iter()
            .zip(prev.as_slice())
            .zip(cap.as_slice())
        {
            // Allow the rounding of (b + c) − b: half an ulp of b.
            assert!((a - b).abs() <= c + 2.0 * f64::EPSILON * b.abs());
        }
        prev = online.design().clone();
    }
    println!("trust region: {limited} of 200 updates limited");
    assert!(limited > 100);
}

#[test]
fn paper_literal_schedule_runs() {
    let (model, state) = paper_arm();
    let cfg = OnlineConfig {
        iterations_per_update: 1,
        trust_region: None,
    };
    let solver = SolverConfig {
        rule: UpdateRule::paper(),
        ..SolverConfig::default()
    };
    let mut online = OnlineSolver::new(&model, &state, solver, cfg, None).unwrap();
    let task = Task::reach([0.09, 0.09, 0.0], 1e3);
    let mut first = None;
    let mut last = 0.0;
    for _ in 0..5000 {
        let rep = online.update(&task).unwrap();
        first.get_or_insert(rep.cost.total);
        last = rep.cost.total;
        assert!(online.design().is_finite());
    }
    println!(
        "rule R, 1 iteration per update: J {:.3e} -> {last:.3e} after 5000 updates",
        first.unwrap()
    );
    // Rule R is slow (spec §3.1: it relaxes slowly after the first approach); the claim here is
    // only that the literal schedule runs, stays finite and keeps lowering J.
    assert!(last < 0.5 * first.unwrap());
}
