//! Claim (spec §5.4, §7 test 9, issue item 5): the offline design for target (9, 9) cm past the
//! two 8 cm spheres at (5.4, 6) and (15.4, 6) cm (ξ = 1e5 N/m²) keeps every node outside each
//! sphere by its local radius, |p_j − r_i| ≥ (φ_j + φ(s_i))/2 − 1e-3 L0, with tip error ≤ 1e-3 L0.
//! Independent reference: the clearance is measured here from the statics' centreline and the
//! taper φ(s) of the paper (§1.3), not from the cost. A wrong obstacle gradient (sign) pulls the
//! arm into the spheres (penetration ~ cm); a missing arm radius lets the surface cut ~5 mm in.
//! Tolerance: the spec's 1e-3 L0 (reference measured contact 0–10 µm with the right sphere).
//! Also: a grasp design with continuation wraps the distal arm on the object (mean gap small).

mod common;
use common::*;
use octoarm_control::{Grasp, OfflineSolver, Outcome, SolverConfig, Task};

fn phi(s: f64) -> f64 {
    0.02 + (0.0004 - 0.02) * s / L0
}

#[test]
fn obstacle_design_stays_outside_both_spheres() {
    let (model, state) = paper_arm();
    let centers = [[0.054, 0.06, 0.0], [0.154, 0.06, 0.0]];
    let task = Task::reach([0.09, 0.09, 0.0], 1e3)
        .with_obstacle(centers[0], 0.08, 1e5)
        .with_obstacle(centers[1], 0.08, 1e5);
    let mut solver = OfflineSolver::new(&model, &state, SolverConfig::default()).unwrap();
    let sol = solver.solve(&task, None).unwrap();
    let rep = &sol.report;
    let pos = solver.statics().position();
    let mut clearance = [f64::INFINITY; 2];
    for (j, c) in centers.iter().enumerate() {
        for (i, p) in pos.iter().enumerate() {
            let s = i as f64 * L0 / 100.0;
            clearance[j] = clearance[j].min(dist(*p, *c) - 0.5 * (0.08 + phi(s)));
        }
    }
    println!(
        "{:?}/{:?}: {} sweeps, tip error {:.2e} m, clearance left {:.2e} m, right {:.2e} m (negative = penetration), obstacle costs {:?} J, {:.1} ms",
        rep.outcome,
        rep.stop,
        rep.sweeps,
        rep.tip_error,
        clearance[0],
        clearance[1],
        rep.obstacle_costs,
        rep.wall_time.as_secs_f64() * 1e3
    );
    assert_eq!(rep.outcome, Outcome::Converged);
    assert!(rep.is_admissible());
    assert!(rep.tip_error <= 1e-3 * L0);
    for c in clearance {
        assert!(c >= -1e-3 * L0, "{c}");
    }
    assert!((rep.max_penetration + clearance[0].min(clearance[1]).min(0.0)).abs() < 1e-12);
}

#[test]
fn grasp_design_wraps_the_object() {
    let (model, state) = paper_arm();
    // Experiment D's object is not needed here: a sphere of radius 2 cm above the arm's middle.
    let g = Grasp::paper([0.12, 0.05, 0.0], 0.02, 1e3, L0);
    let task = Task::default().with_grasp(g, 1e5);
    let mut solver = OfflineSolver::new(&model, &state, SolverConfig::default()).unwrap();
    let sol = solver.solve_with_continuation(&task, None).unwrap();
    let rep = &sol.report;
    let st = solver.statics();
    let (mut num, mut den) = (0.0, 0.0);
    for i in 40..=100 {
        let gap = dist(st.position()[i], [0.12, 0.05, 0.0]) - (0.02 + st.node_radius()[i]);
        num += st.node_weight()[i] * gap.abs();
        den += st.node_weight()[i];
    }
    println!(
        "grasp: {:?}, {} sweeps over 4 stages, mean |gap| on [0.4 L0, L0] = {:.2e} L0, penetration {:.2e} m, warnings {:?}",
        rep.outcome,
        rep.sweeps,
        num / den / L0,
        rep.max_penetration,
        rep.warnings
    );
    assert!(rep.is_admissible());
    assert!(num / den < 0.02 * L0);
    assert!(rep.max_penetration < 1e-3 * L0);
}
