//! Explore the paper's experiments: `cargo run --release -p octoarm-control --example
//! paper_explore -- <a|b|c|d> [key=value ...]` runs one in closed loop with `ShapingController`
//! (updated every `every` steps, as the application's pipeline does; the scenarios in
//! `scenarios/paper/` are the reference runs) and prints d(t) every 0.1 s, the penetration and the
//! summary. Keys (C's remedies): trust=<form time s>, notrust=1, presolve=1, iters=<n>,
//! every=<steps>, beta=<contact>, zeta=<contact>, via=<x,y[;x,y...]>@<until s>, offline=1,
//! ramp=<s>, duration=<s>, damping=<1/s>.
use octoarm_control::{
    Controller, DesignMode, GraspSpec, ShapingController, ShapingControllerConfig, SolverConfig,
    SphereSpec, TargetPhase, TaskSchedule,
};
use octoarm_physics::{
    contact_energy, max_penetration, ContactParams, Damping, Settings, Simulation, Sphere,
    StraightRod,
};
use std::time::Instant;

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
        "a" => Spec::paper_a(),
        "b" => Spec::paper_b(),
        "d" => Spec::paper_d(),
        _ => Spec::paper_c(),
    };
    for kv in &args[1..] {
        let (k, v) = kv.split_once('=').expect("key=value");
        match k {
            "trust" | "iters" | "every" | "notrust" | "presolve" => {
                if let Some(online) = &mut spec.online {
                    match k {
                        "trust" => online.trust_form_time = Some(v.parse().unwrap()),
                        "notrust" => online.trust_form_time = None,
                        "presolve" => online.presolve = v == "1",
                        "iters" => online.iterations_per_update = v.parse().unwrap(),
                        _ => spec.update_every = v.parse().unwrap(),
                    }
                }
            }
            "beta" => spec.contact.beta = v.parse().unwrap(),
            "zeta" => spec.contact.zeta = v.parse().unwrap(),
            "offline" => spec.online = None,
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
                spec.schedule.via_points = TargetPhase::polyline(&path, 0.0, until);
                spec.schedule.via_until = until;
            }
            _ => panic!("unknown key {k}"),
        }
    }
    run(&spec);
}

/// Online design settings of an experiment.
#[derive(Debug, Clone, Copy)]
struct Online {
    iterations_per_update: usize,
    trust_form_time: Option<f64>,
    presolve: bool,
}

/// One experiment: the task, the design schedule and the simulation settings (the paper's
/// experiments as in `scenarios/paper/*.toml`).
#[derive(Debug, Clone)]
struct Spec {
    schedule: TaskSchedule,
    solver: SolverConfig,
    /// Online design (None: offline designs).
    online: Option<Online>,
    /// Steps between controller updates (online iterations, ramp increments).
    update_every: u64,
    ramp_time: f64,
    grasp_stages: usize,
    contact: ContactParams,
    dt: f64,
    duration: f64,
    damping_rate: f64,
}

impl Spec {
    fn common() -> Self {
        Self {
            schedule: TaskSchedule {
                targets: Vec::new(),
                via_points: Vec::new(),
                via_until: 0.0,
                obstacles: Vec::new(),
                grasp: None,
                mu_tip: 1.0e3,
                xi: 1.0e5,
                length: 0.2,
            },
            solver: SolverConfig::default(),
            online: None,
            update_every: 100,
            ramp_time: 0.0,
            grasp_stages: 4,
            contact: ContactParams::default(),
            dt: 1.0e-5,
            duration: 4.0,
            damping_rate: 10.0,
        }
    }

    fn online_default() -> Option<Online> {
        Some(Online {
            iterations_per_update: 10,
            trust_form_time: None,
            presolve: false,
        })
    }

    fn paper_a() -> Self {
        let mut s = Self::common();
        s.schedule.targets = vec![
            TargetPhase::fixed([0.09, 0.09, 0.0], 0.0),
            TargetPhase::fixed([0.0, 0.02, 0.0], 1.8),
        ];
        s
    }

    fn paper_b() -> Self {
        let mut s = Self::common();
        s.schedule.targets = vec![TargetPhase {
            from: 0.0,
            position: [0.12, 0.09, 0.0],
            velocity: [-0.01, 0.0, 0.0],
        }];
        s.online = Some(Online {
            presolve: true,
            ..Self::online_default().unwrap()
        });
        s
    }

    fn paper_c() -> Self {
        let mut s = Self::common();
        s.schedule.targets = vec![TargetPhase::fixed([0.09, 0.09, 0.0], 0.0)];
        s.schedule.obstacles = vec![
            SphereSpec {
                center: [0.054, 0.06, 0.0],
                diameter: 0.08,
            },
            SphereSpec {
                center: [0.154, 0.06, 0.0],
                diameter: 0.08,
            },
        ];
        s.schedule.via_points = TargetPhase::polyline(
            &[
                [0.20, 0.0, 0.0],
                [0.13, 0.015, 0.0],
                [0.105, 0.03, 0.0],
                [0.105, 0.09, 0.0],
                [0.09, 0.09, 0.0],
            ],
            0.0,
            2.0,
        );
        s.schedule.via_until = 2.0;
        s.online = Self::online_default();
        s
    }

    fn paper_d() -> Self {
        let mut s = Self::common();
        s.schedule.grasp = Some(GraspSpec {
            object: SphereSpec {
                center: [0.06, 0.03, 0.0],
                diameter: 0.04,
            },
            weight: 1.0e3,
            from_fraction: 0.4,
        });
        s.solver.floor_diameter = 8.0e-3;
        s.grasp_stages = 10;
        s.ramp_time = 1.5;
        s
    }

    fn config(&self) -> ShapingControllerConfig {
        let mode = match self.online {
            Some(o) => DesignMode::Online {
                iterations_per_update: o.iterations_per_update,
                trust_form_time: o.trust_form_time,
                presolve: o.presolve,
            },
            None => DesignMode::Offline {
                ramp_time: self.ramp_time,
                grasp_stages: self.grasp_stages,
            },
        };
        ShapingControllerConfig {
            solver: self.solver,
            mode,
            period: self.update_every as f64 * self.dt,
        }
    }
}

/// Run one experiment in closed loop; print d(t) every 0.1 s, the design tip every 0.2 s and the
/// summary.
fn run(spec: &Spec) {
    let wall = Instant::now();
    let (model, state) = StraightRod::paper_arm().build().unwrap();
    let length = model.length();
    let mut sim = Simulation::new(model, state, Settings::with_dt(spec.dt)).unwrap();
    sim.set_damping(Damping::mass_proportional(spec.damping_rate))
        .unwrap();
    let sch = &spec.schedule;
    for s in sch
        .obstacles
        .iter()
        .chain(sch.grasp.as_ref().map(|g| &g.object))
    {
        sim.add_obstacle(Sphere::fixed(s.center, 0.5 * s.diameter))
            .unwrap();
    }
    sim.set_contact(spec.contact).unwrap();
    let mut ctrl =
        ShapingController::new(&sim.system, &sim.state, 0, sch.clone(), spec.config()).unwrap();
    let every = spec.update_every.max(1);
    let total = (spec.duration / spec.dt).round() as u64;
    let (sample_every, frame_every) = (100u64, 1000u64);
    let (mut d0, mut max_d, mut max_pen, mut last_d) = (f64::NAN, 0.0f64, 0.0f64, f64::NAN);
    // Distances sampled every 1 ms with their time, for the settling times.
    let mut series: Vec<(f64, f64)> = Vec::new();
    for k in 0..=total {
        let t = sim.time();
        if k < total && k % every == 0 {
            ctrl.update(t, &sim.system, &sim.state, &mut sim.actuation)
                .expect("update");
        }
        if k % frame_every == 0 && (t * 100.0).round() as i64 % 20 == 0 {
            let design_target = ctrl
                .signals(t, &sim.system, &sim.state)
                .design_target
                .unwrap_or([f64::NAN; 3]);
            let shape = ctrl.desired_shape().expect("a shape");
            let d = shape[shape.len() - 1];
            println!(
                "  frame t = {t:.2}: design tip ({:.2}, {:.2}) cm, design target ({:.2}, {:.2}) cm",
                d[0] * 100.0,
                d[1] * 100.0,
                design_target[0] * 100.0,
                design_target[1] * 100.0
            );
        }
        if k % sample_every == 0 || k == total {
            let sig = ctrl.signals(t, &sim.system, &sim.state);
            let view = sim.view();
            let spheres = sim.system.obstacles();
            let contact = contact_energy(sim.model(), &view, spheres, sim.system.contact(), t);
            let (pen, _) = max_penetration(sim.model(), &view, spheres, t);
            let h = sig.shaped.map_or(f64::NAN, |e| e.total()) + contact;
            if k == 0 {
                d0 = sig.distance;
            }
            max_d = max_d.max(sig.distance);
            max_pen = max_pen.max(pen);
            last_d = sig.distance;
            series.push((t, sig.distance));
            if k % (100 * sample_every) == 0 {
                let tip = sim.tip();
                println!(
                    "t = {t:.2} s  d = {:.4}  tip = ({:.2}, {:.2}) cm  pen = {:.2} mm  H = {h:.3e} J",
                    sig.distance,
                    tip[0] * 100.0,
                    tip[1] * 100.0,
                    pen * 1e3,
                );
            }
        }
        if k == total {
            break;
        }
        sim.step().expect("step");
    }
    // Settling time (d ≤ 0.02 for good) of each task-target phase (a grasp is one segment).
    let mut starts: Vec<f64> = sch.targets.iter().map(|p| p.from.max(0.0)).collect();
    if starts.is_empty() {
        starts.push(0.0);
    }
    starts[0] = 0.0;
    let mut settling = Vec::new();
    for (i, &start) in starts.iter().enumerate() {
        let end = starts.get(i + 1).copied().unwrap_or(f64::INFINITY);
        let mut settle = None;
        for &(t, d) in series
            .iter()
            .filter(|s| s.0 >= start - 1e-12 && s.0 < end - 1e-12)
        {
            if d > 0.02 {
                settle = None;
            } else if settle.is_none() {
                settle = Some(t);
            }
        }
        settling.push((start, settle));
    }
    let rep = ctrl.report();
    let late_err = rep
        .update_tip_errors
        .iter()
        .filter(|e| e.0 >= 0.5)
        .map(|e| e.1 / length)
        .fold(0.0, f64::max);
    println!(
        "d(0) = {d0:.4}, max d = {max_d:.4}, largest online design tip error after 0.5 s = {late_err:.4} L0"
    );
    println!(
        "final d = {last_d:.4}, reached = {}, max penetration = {:.3} mm, settling (segment start, time) = {settling:?}, sweeps = {}, failed updates = {}, design tip errors = {:?}, design pen = {:?}, wall = {:.1} s",
        last_d <= 0.02,
        max_pen * 1e3,
        rep.sweeps,
        rep.failed_updates,
        rep.design_tip_errors,
        rep.design_penetrations,
        wall.elapsed().as_secs_f64()
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
