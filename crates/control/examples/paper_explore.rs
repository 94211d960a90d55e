//! Explore the paper's experiments: `cargo run --release -p octoarm-control --example
//! paper_explore -- <a|b|c|d> [key=value ...]` prints d(t) every 0.1 s, the penetration and the
//! summary. Keys (C's remedies): trust=<form time s>, notrust=1, presolve=1, iters=<n>,
//! every=<steps>, beta=<contact>, via=<x,y[;x,y...]>@<until s>, offline=1, ramp=<s>, duration=<s>.
use octoarm_control::{run_experiment, ExperimentSpec, NoFrames, SolverMode, TargetPhase};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("designd") {
        use octoarm_control::{Grasp, OfflineSolver, SolverConfig, Task};
        let (model, state) = octoarm_physics::StraightRod::paper_arm().build().unwrap();
        let floor: f64 = args.get(1).map(|x| x.parse().unwrap()).unwrap_or(0.004);
        let stages: usize = args.get(2).map(|x| x.parse().unwrap()).unwrap_or(4);
        let cfg = SolverConfig {
            floor_diameter: floor,
            ..SolverConfig::default()
        };
        let mut solver = OfflineSolver::new(&model, &state, cfg).unwrap();
        let task = Task::default().with_grasp(Grasp::paper([0.06, 0.03, 0.0], 0.02, 1e3, 0.2), 1e5);
        let mut w = None;
        let mut sol = None;
        for k in 0..stages {
            let f = 10f64.powf(-3.0 + 3.0 * k as f64 / (stages - 1) as f64);
            let mut t = task.clone();
            if let Some(g) = &mut t.grasp {
                g.weight = octoarm_control::GraspWeight::Interval {
                    weight: 1e3 * f,
                    from: 0.08,
                    to: 0.2,
                };
            }
            let s = solver.solve(&t, w.as_ref()).unwrap();
            println!(
                "stage {k} factor {f:.1e}: {:?} {} sweeps",
                s.report.outcome, s.report.sweeps
            );
            w = Some(s.strains.clone());
            sol = Some(s);
        }
        let sol = sol.unwrap();
        for j in (0..100).step_by(5) {
            let v = sol.strains.nu(j);
            let k = if j < 99 { sol.strains.kappa(j)[1] } else { 0.0 };
            println!(
                "element {j}: shear {:.3} stretch {:.3} kappa {:.1}",
                v[0],
                v[2] - 1.0,
                k
            );
        }
        println!("{:?}", sol.report);
        return;
    }
    if args.first().map(String::as_str) == Some("design") {
        design_probe();
        return;
    }
    let which = args.first().map(String::as_str).unwrap_or("c");
    let mut spec = match which {
        "a" => ExperimentSpec::paper_a(),
        "b" => ExperimentSpec::paper_b(),
        "d" => ExperimentSpec::paper_d(),
        _ => ExperimentSpec::paper_c(),
    };
    for kv in &args[1..] {
        let (k, v) = kv.split_once('=').expect("key=value");
        match k {
            "trust" | "iters" | "every" | "notrust" | "presolve" => {
                if let SolverMode::Online {
                    update_every,
                    iterations_per_update,
                    trust_form_time,
                    presolve,
                } = &mut spec.mode
                {
                    match k {
                        "trust" => *trust_form_time = Some(v.parse().unwrap()),
                        "notrust" => *trust_form_time = None,
                        "presolve" => *presolve = v == "1",
                        "iters" => *iterations_per_update = v.parse().unwrap(),
                        _ => *update_every = v.parse().unwrap(),
                    }
                }
            }
            "beta" => spec.contact.beta = v.parse().unwrap(),
            "zeta" => spec.contact.zeta = v.parse().unwrap(),
            "offline" => spec.mode = SolverMode::Offline,
            "ramp" => spec.ramp_time = v.parse().unwrap(),
            "duration" => spec.duration = v.parse().unwrap(),
            "damping" => spec.damping_rate = v.parse().unwrap(),
            "via" => {
                // Polyline path for the design target: "x,y;x,y;...@T" in cm, starting at the
                // straight arm's tip (20, 0) cm, traversed at constant speed, ending at time T.
                let (pts, until) = v.split_once('@').unwrap();
                let until: f64 = until.parse().unwrap();
                let mut path = vec![[0.2, 0.0, 0.0]];
                for p in pts.split(';') {
                    let c: Vec<f64> = p
                        .split(',')
                        .map(|x| x.parse::<f64>().unwrap() * 0.01)
                        .collect();
                    path.push([c[0], c[1], 0.0]);
                }
                spec.via_points = TargetPhase::polyline(&path, 0.0, until);
                spec.via_until = until;
            }
            _ => panic!("unknown key {k}"),
        }
    }
    struct Print;
    impl octoarm_control::ExperimentSink for Print {
        fn frame(&mut self, f: &octoarm_control::Frame) {
            if (f.time * 100.0).round() as i64 % 20 == 0 {
                let d = f.desired[f.desired.len() - 1];
                let t = f.design_target.unwrap_or([f64::NAN; 3]);
                println!(
                    "  frame t = {:.2}: design tip ({:.2}, {:.2}) cm, design target ({:.2}, {:.2}) cm",
                    f.time, d[0] * 100.0, d[1] * 100.0, t[0] * 100.0, t[1] * 100.0
                );
            }
        }
    }
    let _ = NoFrames;
    let out = run_experiment(&spec, &mut Print).expect("run");
    for s in out.series.iter().step_by(100) {
        println!(
            "t = {:.2} s  d = {:.4}  tip = ({:.2}, {:.2}) cm  pen = {:.2} mm  H = {:.3e} J",
            s.time,
            s.distance,
            s.tip[0] * 100.0,
            s.tip[1] * 100.0,
            s.penetration * 1e3,
            s.hamiltonian
        );
    }
    let sm = &out.summary;
    let late_err = sm
        .update_tip_errors
        .iter()
        .filter(|e| e.0 >= 0.5)
        .map(|e| e.1 / out.length)
        .fold(0.0, f64::max);
    let max_d = out.series.iter().map(|s| s.distance).fold(0.0, f64::max);
    println!(
        "d(0) = {:.4}, max d = {max_d:.4}, largest online design tip error after 0.5 s = {late_err:.4} L0",
        out.series[0].distance
    );
    println!(
        "final d = {:.4}, reached = {}, max penetration = {:.3} mm, segments = {:?}, sweeps = {}, failed updates = {}, design tip errors = {:?}, design pen = {:?}, wall = {:.1} s",
        sm.final_distance,
        sm.reached,
        sm.max_penetration * 1e3,
        sm.segments,
        sm.sweeps,
        sm.failed_updates,
        sm.design_tip_errors,
        sm.design_penetrations,
        sm.wall_time.as_secs_f64()
    );
}

/// Largest design strain |ν̄ − e3| per online update for B's first updates (why B trips the guard).
fn design_probe() {
    use octoarm_control::{OnlineConfig, OnlineSolver, SolverConfig, Task};
    use octoarm_physics::StraightRod;
    let (model, state) = StraightRod::paper_arm().build().unwrap();
    let mut online = OnlineSolver::new(
        &model,
        &state,
        SolverConfig::default(),
        OnlineConfig::default(),
        None,
    )
    .unwrap();
    let task = Task::reach([0.12, 0.09, 0.0], 1e3);
    for u in 0..60 {
        let rep = online.update(&task).unwrap();
        let w = online.design();
        let (mut worst, mut at, mut comp) = (0.0f64, 0, 0);
        for j in 0..model.n_elements {
            let v = w.nu(j);
            for (c, x) in [v[0], v[1], v[2] - 1.0].iter().enumerate() {
                if x.abs() > worst {
                    (worst, at, comp) = (x.abs(), j, c);
                }
            }
        }
        if u % 3 == 0 {
            println!(
                "update {u}: tip error {:.3} m, max |sigma| {worst:.3} at element {at} comp {comp}",
                rep.tip_error
            );
        }
    }
}
