//! Helpers shared by the control tests: the paper's arm, seeded random strain fields, a
//! Box–Muller normal sampler (rand 0.8 has no normal distribution without rand_distr), and the
//! paper's experiments as closed-loop fixtures of `ShapingController`.
#![allow(dead_code)]

use octoarm_control::{
    ControlReport, Controller, DesignMode, GraspSpec, ShapingController, ShapingControllerConfig,
    SolverConfig, SphereSpec, StrainField, StrainSpace, TargetPhase, TaskSchedule,
};
use octoarm_physics::{
    contact_energy, max_penetration, Damping, RodModel, RodState, Settings, Simulation, Sphere,
    StraightRod, Vec3,
};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

pub const L0: f64 = 0.2;

pub fn paper_arm() -> (RodModel, RodState) {
    StraightRod::paper_arm().build().unwrap()
}

pub fn rng(seed: u64) -> StdRng {
    StdRng::seed_from_u64(seed)
}

pub fn normal(r: &mut StdRng) -> f64 {
    let u1: f64 = r.gen_range(1e-300..1.0);
    let u2: f64 = r.gen();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// Random strains around the intrinsic ones: ν − ν° ~ `nu_sd`·N, κ ~ `kappa_sd`·N [1/m]; in the
/// planar space only the free components (for d1 = e_y, d2 = e_z: ν1, ν3, κ2) are perturbed.
pub fn random_field(
    model: &RodModel,
    space: StrainSpace,
    nu_sd: f64,
    kappa_sd: f64,
    r: &mut StdRng,
) -> StrainField {
    let mut w = StrainField::intrinsic(model);
    let (fnu, fk) = match space {
        StrainSpace::Planar => ([true, false, true], [false, true, false]),
        StrainSpace::Full => ([true; 3], [true; 3]),
    };
    for j in 0..model.n_elements {
        let mut v = w.nu(j);
        for c in 0..3 {
            if fnu[c] {
                v[c] += nu_sd * normal(r);
            }
        }
        w.set_nu(j, v);
    }
    for k in 0..model.n_interior() {
        let mut v = w.kappa(k);
        for c in 0..3 {
            if fk[c] {
                v[c] += kappa_sd * normal(r);
            }
        }
        w.set_kappa(k, v);
    }
    w
}

pub fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

// ---------------------------------------------------------------------------------------------
// The paper's experiments as test fixtures (the constants of the former `ExperimentSpec::paper_a()`
// … `paper_d()`, as in `scenarios/paper/*.toml`), run in closed loop with `ShapingController` on
// a `Simulation` the way the application's pipeline runs a controlled scenario: the controller is
// updated at t = 0 and then every period (never at the last instant), samples are taken after the
// update and before the step.

/// Time step of the paper's runs [s].
pub const PAPER_DT: f64 = 1.0e-5;
/// Controller period (design updates, ramp increments) [s].
pub const PAPER_PERIOD: f64 = 1.0e-3;

fn paper_schedule() -> TaskSchedule {
    TaskSchedule {
        targets: Vec::new(),
        via_points: Vec::new(),
        via_until: 0.0,
        obstacles: Vec::new(),
        grasp: None,
        mu_tip: 1.0e3,
        xi: 1.0e5,
        length: L0,
    }
}

/// Experiment A (spec §5.2): (9, 9) cm, then (0, 2) cm from 1.8 s.
pub fn paper_a_schedule() -> TaskSchedule {
    TaskSchedule {
        targets: vec![
            TargetPhase::fixed([0.09, 0.09, 0.0], 0.0),
            TargetPhase::fixed([0.0, 0.02, 0.0], 1.8),
        ],
        ..paper_schedule()
    }
}

/// Experiment B (spec §5.3): target from (12, 9) cm at 1 cm/s towards −x.
pub fn paper_b_schedule() -> TaskSchedule {
    TaskSchedule {
        targets: vec![TargetPhase {
            from: 0.0,
            position: [0.12, 0.09, 0.0],
            velocity: [-0.01, 0.0, 0.0],
        }],
        ..paper_schedule()
    }
}

/// Experiment D (spec §5.5): grasp a 4 cm sphere at (6, 3) cm, μ_grasp = 1e3 N/m on [0.4 L0, L0].
pub fn paper_d_schedule() -> TaskSchedule {
    TaskSchedule {
        grasp: Some(GraspSpec {
            object: SphereSpec {
                center: [0.06, 0.03, 0.0],
                diameter: 0.04,
            },
            weight: 1.0e3,
            from_fraction: 0.4,
        }),
        ..paper_schedule()
    }
}

/// A: offline designs, switched at once.
pub fn paper_a_config() -> ShapingControllerConfig {
    ShapingControllerConfig {
        solver: SolverConfig::default(),
        mode: DesignMode::Offline {
            ramp_time: 0.0,
            grasp_stages: 4,
        },
        period: PAPER_PERIOD,
    }
}

/// B: online, 10 iterations per 1 ms update, from an offline pre-solve of the starting target.
pub fn paper_b_config() -> ShapingControllerConfig {
    ShapingControllerConfig {
        solver: SolverConfig::default(),
        mode: DesignMode::Online {
            iterations_per_update: 10,
            trust_form_time: None,
            presolve: true,
        },
        period: PAPER_PERIOD,
    }
}

/// D: offline design with a 10-stage continuation and an 8 mm floor, through a 1.5 s ramp.
pub fn paper_d_config() -> ShapingControllerConfig {
    ShapingControllerConfig {
        solver: SolverConfig {
            floor_diameter: 8.0e-3,
            ..SolverConfig::default()
        },
        mode: DesignMode::Offline {
            ramp_time: 1.5,
            grasp_stages: 10,
        },
        period: PAPER_PERIOD,
    }
}

/// The paper arm clamped at its base, ν_d = 10 s⁻¹, with the schedule's spheres (obstacles and
/// the grasped object) as physical obstacles, and the controller built for it.
pub fn paper_closed_loop(
    schedule: TaskSchedule,
    config: ShapingControllerConfig,
) -> (Simulation, ShapingController) {
    let (model, state) = paper_arm();
    let mut sim = Simulation::new(model, state, Settings::with_dt(PAPER_DT)).unwrap();
    sim.set_damping(Damping::mass_proportional(10.0)).unwrap();
    let spheres = schedule
        .obstacles
        .iter()
        .copied()
        .chain(schedule.grasp.map(|g| g.object));
    for s in spheres {
        sim.add_obstacle(Sphere::fixed(s.center, 0.5 * s.diameter))
            .unwrap();
    }
    let ctrl = ShapingController::new(&sim.system, &sim.state, 0, schedule, config).unwrap();
    (sim, ctrl)
}

/// One sample of a closed-loop run.
#[derive(Debug, Clone, Copy)]
pub struct Sample {
    pub time: f64,
    pub tip: Vec3,
    /// The controller's task error (d/L0, or the grasp's d_D).
    pub distance: f64,
    /// Shaped Hamiltonian: kinetic + strain energy against w̄ (the controller's signals) +
    /// contact energy [J].
    pub hamiltonian: f64,
    pub design_epoch: u64,
    /// Largest penetration of the arm's surface into a sphere [m].
    pub penetration: f64,
}

/// Run `duration` seconds in closed loop, sampling every `sample_interval` (and at the end).
pub fn run_closed_loop(
    sim: &mut Simulation,
    ctrl: &mut ShapingController,
    duration: f64,
    sample_interval: f64,
) -> (Vec<Sample>, ControlReport) {
    let dt = sim.settings().dt;
    let every = (ctrl.period() / dt).round() as u64;
    let sample_every = (sample_interval / dt).round() as u64;
    let total = (duration / dt).round() as u64;
    let mut samples = Vec::new();
    for k in 0..=total {
        let t = sim.time();
        if k < total && k % every == 0 {
            ctrl.update(t, &sim.system, &sim.state, &mut sim.actuation)
                .unwrap();
        }
        if k % sample_every == 0 || k == total {
            let sig = ctrl.signals(t, &sim.system, &sim.state);
            let view = sim.view();
            let spheres = sim.system.obstacles();
            let contact = contact_energy(sim.model(), &view, spheres, sim.system.contact(), t);
            let (penetration, _) = max_penetration(sim.model(), &view, spheres, t);
            samples.push(Sample {
                time: t,
                tip: sim.tip(),
                distance: sig.distance,
                hamiltonian: sig.shaped.expect("the law shapes energy").total() + contact,
                design_epoch: sig.design_epoch,
                penetration,
            });
        }
        if k == total {
            break;
        }
        sim.step().unwrap();
    }
    (samples, ctrl.report())
}

/// First time after which d ≤ `band` for the rest of `samples` (None if the last is above).
pub fn settling_time(samples: &[&Sample], band: f64) -> Option<f64> {
    let mut settling = samples.first().map(|s| s.time);
    for s in samples {
        if s.distance > band {
            settling = None;
        } else if settling.is_none() {
            settling = Some(s.time);
        }
    }
    settling
}

/// Largest rise of H above its running minimum, relative to H at the start of each interval of
/// constant design (epochs), over samples with time ≥ `from`.
pub fn worst_lyapunov_rise(series: &[Sample], from: f64) -> f64 {
    let mut worst: f64 = 0.0;
    let mut epoch = u64::MAX;
    let (mut h0, mut hmin) = (0.0, 0.0);
    for s in series.iter().filter(|s| s.time >= from) {
        if s.design_epoch != epoch {
            epoch = s.design_epoch;
            h0 = s.hamiltonian;
            hmin = s.hamiltonian;
            continue;
        }
        worst = worst.max((s.hamiltonian - hmin) / h0);
        hmin = hmin.min(s.hamiltonian);
    }
    worst
}

/// COOMM's muscular arm with `n_elements` elements, its design solver, and spec §7 A's reach
/// task (p* = (0.01, 0.15, 0.06) m, COOMM's tip frame).
pub fn coomm_reach_design(
    n_elements: usize,
) -> (octoarm_control::MuscleDesign, octoarm_control::ReachTask) {
    use octoarm_physics::{MuscleModel, MuscleSpec};
    let (model, state) = StraightRod::coomm_arm()
        .with_elements(n_elements)
        .build()
        .unwrap();
    let mm = MuscleModel::new(MuscleSpec::coomm(), &model).unwrap();
    let st = octoarm_control::MuscleStatics::new(&model, mm, state.position[0], state.director[0]);
    let task =
        octoarm_control::ReachTask::coomm([0.01, 0.15, 0.06], [0.0; 3], state.position[n_elements]);
    (octoarm_control::MuscleDesign::new(st), task)
}

/// `n` numbers uniform in [0, hi) from a 64-bit linear congruential generator seeded by `seed`
/// (no dependency on `rand`'s stream, so the values never change with its version).
pub fn lcg_uniform(n: usize, seed: u64, hi: f64) -> Vec<f64> {
    let mut s = seed;
    (0..n)
        .map(|_| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            hi * ((s >> 11) as f64) / ((1u64 << 53) as f64)
        })
        .collect()
}
