//! Runs of the muscular arm (muscles-3d spec §7): the design over activations of a scenario's
//! `[muscle_control]` (reach or grasp, solved before t = 0 by `octoarm_control::MuscleDesign`)
//! with its figures of merit, the `MuscleShapingController` holding it, and `MuscleRecorder`,
//! which samples the run every `series_interval` (tip error, θ_Q, the shaped Hamiltonian 𝓗,
//! grasp gaps) and writes `series.npz`, `activations.npy` [7, N], `design_pose.npz`,
//! `design.json` and the `[[acceptance]]` checks of the scenario into `summary.json`.

use crate::acceptance::Check;
use crate::output::{npy_header, write_json, write_member, OutputDir};
use crate::pipeline::{Moment, Recorder, RunInfo};
use crate::scenario::config::{MuscleTaskKind, TipFrameKind, MUSCLE_GROUP_NAMES};
use crate::scenario::{AcceptanceConfig, AcceptanceQuantity, Scenario, ScenarioError};
use anyhow::{Context, Result};
use octoarm_control::{
    DesignOutcome, DesignReport, GraspTask, MuscleDesign, MuscleShapingController, MuscleStatics,
    ReachTask,
};
use octoarm_physics::math::{cross, dot, log_relative, norm, Mat3};
use octoarm_physics::muscles::{group, Strains};
use octoarm_physics::{
    energies, strains, MuscleModel, RodAccess, RodModel, RodState, RodSystem, SystemState, Vec3,
    N_GROUPS,
};
use serde_json::{json, Map, Value};
use std::fs::File;
use std::io::{BufWriter, Write};

/// The task a muscle design was solved for.
#[derive(Debug, Clone, PartialEq)]
pub enum MuscleTask {
    /// A reach (spec §7 A, B).
    Reach(ReachTask),
    /// A grasp (spec §7 C).
    Grasp(GraspTask),
}

/// Figures of merit of a grasp pose over the distal elements s_j = j/(n − 1) ≥ 0.3 (spec §7 C).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GraspMetrics {
    /// Range of the unwrapped azimuth of the element midpoints about the axis [deg].
    pub wrap_angle: f64,
    /// max(−ζ), ζ_j = ρ_j − (R + r̂_j) the surface gap [m] (≤ 0: no penetration).
    pub penetration: f64,
    /// Mean |ζ| [m].
    pub mean_gap: f64,
    /// Max |ζ| [m].
    pub max_gap: f64,
    /// Sucker alignment ᾱ = Σ w_j d1_j · u_j / Σ w_j, u_j towards the centre.
    pub alignment: f64,
}

/// The grasp metrics of element midpoints of `position` (n + 1 nodes) with directors `director`.
pub fn grasp_metrics(
    position: &[Vec3],
    director: &[Mat3],
    radius: &[f64],
    task: &GraspTask,
) -> GraspMetrics {
    let n = director.len();
    let a = task.axis;
    // A basis of the plane perpendicular to the axis.
    let helper = if a[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let e1 = {
        let v = cross(a, helper);
        let l = norm(v);
        [v[0] / l, v[1] / l, v[2] / l]
    };
    let e2 = cross(a, e1);
    let (mut count, mut sum_gap, mut max_gap, mut pen) = (0usize, 0.0, 0.0f64, f64::NEG_INFINITY);
    let (mut wsum, mut asum) = (0.0, 0.0);
    let (mut lo, mut hi, mut last, mut unwrapped) =
        (f64::INFINITY, f64::NEG_INFINITY, None::<f64>, 0.0);
    for j in 0..n {
        if (j as f64) / ((n - 1) as f64) < 0.3 {
            continue;
        }
        let p: Vec3 = std::array::from_fn(|k| 0.5 * (position[j][k] + position[j + 1][k]));
        let dp = [
            p[0] - task.center[0],
            p[1] - task.center[1],
            p[2] - task.center[2],
        ];
        let z = dot(dp, a);
        let radial = [dp[0] - z * a[0], dp[1] - z * a[1], dp[2] - z * a[2]];
        let zeta = norm(radial) - (task.radius + radius[j]);
        count += 1;
        sum_gap += zeta.abs();
        max_gap = max_gap.max(zeta.abs());
        pen = pen.max(-zeta);
        let phi = dot(radial, e2).atan2(dot(radial, e1));
        unwrapped = match last {
            None => phi,
            Some(prev) => {
                let mut d = phi - prev;
                while d > std::f64::consts::PI {
                    d -= 2.0 * std::f64::consts::PI;
                }
                while d < -std::f64::consts::PI {
                    d += 2.0 * std::f64::consts::PI;
                }
                unwrapped + d
            }
        };
        last = Some(phi);
        lo = lo.min(unwrapped);
        hi = hi.max(unwrapped);
        let dist = norm(dp);
        if dist > 0.0 {
            let w = GraspTask::weight(j, n);
            let u = [-dp[0] / dist, -dp[1] / dist, -dp[2] / dist];
            wsum += w;
            asum += w * dot(director[j][0], u);
        }
    }
    GraspMetrics {
        wrap_angle: (hi - lo).max(0.0).to_degrees(),
        penetration: pen,
        mean_gap: sum_gap / count.max(1) as f64,
        max_gap,
        alignment: if wsum > 0.0 { asum / wsum } else { 0.0 },
    }
}

/// A solved design and its figures of merit.
#[derive(Debug, Clone)]
pub struct MuscleDesignRun {
    /// The rod it drives.
    pub rod: usize,
    /// Elements n.
    pub n: usize,
    /// L0 [m].
    pub length: f64,
    /// Rest radii r̂_j [m].
    pub radius: Vec<f64>,
    /// The task.
    pub task: MuscleTask,
    /// Activations a* (group-major `[7][n]`).
    pub activations: Vec<f64>,
    /// The solver's report.
    pub report: DesignReport,
    /// The design pose (static equilibrium under a*).
    pub pose: RodState,
    /// Scaled equilibrium residual ρ_R at a*.
    pub residual: f64,
    /// max_k D̂_k |κ_k| [rad].
    pub max_turn: f64,
    /// Total twist Σ D̂_k κ₃ [rad].
    pub twist: f64,
    /// ∫ a ds / L0 per group.
    pub group_integrals: [f64; N_GROUPS],
    /// Activations outside [0, 1].
    pub violations: usize,
    /// Grasp metrics of the design pose (grasp only).
    pub grasp: Option<GraspMetrics>,
    /// The ramp [s].
    pub ramp: f64,
}

impl MuscleDesignRun {
    /// The task's tip target and frame (reach only).
    pub fn reach(&self) -> Option<&ReachTask> {
        match &self.task {
            MuscleTask::Reach(t) => Some(t),
            MuscleTask::Grasp(_) => None,
        }
    }

    /// The design report as JSON (spec §5.6).
    pub fn to_json(&self) -> Value {
        let c = &self.report.costs;
        let mut groups = Map::new();
        for (g, name) in MUSCLE_GROUP_NAMES.iter().enumerate() {
            groups.insert((*name).into(), json!(self.group_integrals[g]));
        }
        let mut v = json!({
            "outcome": format!("{:?}", self.report.outcome),
            "iterations": self.report.iterations,
            "evaluations": self.report.evaluations,
            "newton_iterations": self.report.newton_iterations,
            "seconds": self.report.seconds,
            "starts": self.report.starts,
            "winner": self.report.winner,
            "cost": c.total,
            "activation_cost": c.activation,
            "position_cost": c.position,
            "orientation_cost": c.orientation,
            "attraction_cost": c.attraction,
            "obstacle_cost": c.obstacle,
            "sucker_cost": c.sucker,
            "tip_error": c.tip_error,
            "tip_error_l0": c.tip_error / self.length,
            "orientation_error": c.orientation_error,
            "activations_at_zero": self.report.at_zero,
            "activations_at_one": self.report.at_one,
            "activations_outside_bounds": self.violations,
            "residual": self.residual,
            "max_turn": self.max_turn,
            "twist": self.twist,
            "group_integrals_l0": Value::Object(groups),
            "target": self.reach().map(|t| t.target.to_vec()),
        });
        if let (Some(g), Value::Object(m)) = (&self.grasp, &mut v) {
            m.insert(
                "grasp".into(),
                json!({
                    "wrap_angle_deg": g.wrap_angle,
                    "penetration": g.penetration,
                    "mean_gap": g.mean_gap,
                    "max_gap": g.max_gap,
                    "sucker_alignment": g.alignment,
                }),
            );
        }
        v
    }
}

/// Solve the design of `[muscle_control]` and build the controller holding it.
pub fn design(
    scn: &Scenario,
    system: &RodSystem,
    state: &SystemState,
) -> Result<(MuscleShapingController, MuscleDesignRun), ScenarioError> {
    let cfg = &scn.config;
    let mc = cfg
        .muscle_control
        .as_ref()
        .expect("called for a [muscle_control] scenario");
    let mcfg = cfg.muscles.as_ref().expect("validated: [muscles] present");
    let r = cfg
        .find_rod("muscles.rod", mcfg.rod.as_deref())
        .map_err(|b| scn.error_at(&b.key, b.to_string()))?;
    let rod = system.rod(r);
    let model: &RodModel = &rod.model;
    let n = model.n_elements;
    let muscles: MuscleModel = rod
        .muscles
        .as_deref()
        .cloned()
        .expect("build gives the rod its muscles");
    let view = system.view(state, r);
    let base = view.position(0);
    let tip0 = view.position(n);
    let statics = MuscleStatics::new(model, muscles.clone(), base, view.director(0));
    let mut d = MuscleDesign::new(statics);
    d.config.max_iterations = mc.max_iterations;
    if let Some(k) = mc.max_starts {
        d.config.max_starts = k;
    }
    if let Some(k) = mc.max_total_iterations {
        d.config.max_total_iterations = k;
    }
    if let Some(groups) = &mc.groups {
        d.config.groups =
            std::array::from_fn(|g| groups.iter().any(|x| x == MUSCLE_GROUP_NAMES[g]));
    }
    let length = model.length();
    let a0 = vec![0.0; N_GROUPS * n];
    let (task, (a, report)) = match mc.task {
        MuscleTaskKind::Reach => {
            let mut t = match (mc.target, mc.target_seed) {
                (Some(target), _) => {
                    let mut t = ReachTask::coomm(target, base, tip0);
                    match mc.frame {
                        TipFrameKind::None => t.frame = None,
                        TipFrameKind::Coomm => {}
                        TipFrameKind::CoommRolled => t = t.rolled(),
                    }
                    t
                }
                (None, Some(seed)) => {
                    let a = random_activations(seed, n);
                    // A statics of its own: the design starts cold from the straight arm.
                    let mut st = MuscleStatics::new(model, muscles.clone(), base, view.director(0));
                    st.solve(&a, None).map_err(|e| {
                        scn.error_at(
                            "muscle_control.target_seed",
                            format!("muscle_control.target_seed = {seed}: no equilibrium for the drawn activations: {e}"),
                        )
                    })?;
                    let pose = st.pose(st.solution());
                    let p: Vec3 = std::array::from_fn(|c| {
                        0.5 * (pose.position[n - 1][c] + pose.position[n][c])
                    });
                    ReachTask {
                        target: p,
                        position_weight: 1e6,
                        frame: (mc.frame != TipFrameKind::None)
                            .then_some((pose.director[n - 1], [1.0, 1.0, 1.0])),
                        orientation_weight: 1e3,
                    }
                }
                (None, None) => unreachable!("validated: a reach has a target"),
            };
            t.position_weight = mc.position_weight;
            t.orientation_weight = mc.orientation_weight;
            if mc.stop_at_bounds {
                d.config.stop_when = Some((1.5e-4 * length, 1e-3, f64::INFINITY));
            }
            let out = d
                .try_solve(&t, &a0)
                .map_err(|e| scn.error_at("muscle_control", format!("muscle_control: {e}")))?;
            (MuscleTask::Reach(t), out)
        }
        MuscleTaskKind::Grasp => {
            let c = &cfg.cylinders[0];
            let axis = {
                let l = norm(c.axis);
                [c.axis[0] / l, c.axis[1] / l, c.axis[2] / l]
            };
            let t = GraspTask {
                center: c.center,
                axis,
                radius: 0.5 * c.diameter,
                length: c.length,
                attraction_weight: mc.attraction_weight,
                obstacle_weight: mc.obstacle_weight,
                sucker_weight: mc.sucker_weight,
            };
            let out = d.solve_continuation(&t, mc.stages, &a0);
            (MuscleTask::Grasp(t), out)
        }
    };
    if report.outcome == DesignOutcome::LineSearchFailed && report.iterations == 0 {
        return Err(scn.error_at(
            "muscle_control",
            "muscle_control: the design could not start (no equilibrium of the arm at a = 0)"
                .into(),
        ));
    }
    let w = d.statics().solution().to_vec();
    let pose = d.statics().pose(&w);
    let mut res = vec![0.0; w.len()];
    let st = d.statics_mut();
    st.residual(&w, &a, &mut res);
    let residual = st.scaled_norm(&res);
    let (mut max_turn, mut twist) = (0.0f64, 0.0);
    for k in 0..n - 1 {
        let dk = model.rest_voronoi_length[k];
        let kap = MuscleStatics::kappa(&w, k);
        max_turn = max_turn.max(dk * norm(kap));
        twist += dk * kap[2];
    }
    let group_integrals = std::array::from_fn(|g| {
        (0..n)
            .map(|j| model.rest_length[j] * a[g * n + j])
            .sum::<f64>()
            / length
    });
    let violations = a.iter().filter(|v| !(0.0..=1.0).contains(*v)).count();
    let grasp = match &task {
        MuscleTask::Grasp(t) => Some(grasp_metrics(
            &pose.position,
            &pose.director,
            &model.radius,
            t,
        )),
        MuscleTask::Reach(_) => None,
    };
    let target = match &task {
        MuscleTask::Reach(t) => Some(t.target),
        MuscleTask::Grasp(_) => None,
    };
    let ctrl = MuscleShapingController::new(
        r,
        a.clone(),
        mc.ramp,
        mc.update_interval,
        target,
        pose.position.clone(),
        report.costs.tip_error,
        length,
    )
    .map_err(|e| scn.error_at("muscle_control", format!("muscle_control: {e}")))?;
    tracing::info!(
        "{}: muscle design {:?} after {} iterations ({} evaluations, start {} of {}) in {:.2} s: J = {:.4}, tip error {:.2e} m, θ_Q {:.2e} rad",
        scn.name,
        report.outcome,
        report.iterations,
        report.evaluations,
        report.winner + 1,
        report.starts,
        report.seconds,
        report.costs.total,
        report.costs.tip_error,
        report.costs.orientation_error
    );
    Ok((
        ctrl,
        MuscleDesignRun {
            rod: r,
            n,
            length,
            radius: model.radius.clone(),
            task,
            activations: a,
            report,
            pose,
            residual,
            max_turn,
            twist,
            group_integrals,
            violations,
            grasp,
            ramp: mc.ramp,
        },
    ))
}

/// The random activations of `target_seed` (group-major `[7][n]`): per group, with probability
/// ½, a linear profile between two U(0, 1) values at the base and the tip, else zero
/// (SplitMix64 from the seed).
pub fn random_activations(seed: u64, n: usize) -> Vec<f64> {
    let mut state = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut next = || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut a = vec![0.0; N_GROUPS * n];
    for g in 0..N_GROUPS {
        let on = next() < 0.5;
        let (a0, a1) = (next(), next());
        if on {
            for j in 0..n {
                let s = (j as f64 + 0.5) / n as f64;
                a[g * n + j] = a0 + (a1 - a0) * s;
            }
        }
    }
    a
}

/// One sample of a muscle run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MuscleSample {
    /// Time [s].
    pub time: f64,
    /// Tip point (last element's midpoint) [m].
    pub tip: Vec3,
    /// |tip − p*| / L0 (reach; NaN for a grasp).
    pub tip_error: f64,
    /// θ_Q = |Log(Q_{n−1} Q*ᵀ)| [rad] (reach with a frame; NaN otherwise).
    pub orientation_error: f64,
    /// 𝓗 = K_t + K_r + U_s + U_b + Σ W (fibres' stored energy at the activations in force)
    /// + the obstacles' contact energy [J].
    pub hamiltonian: f64,
    /// Grasp: max(−ζ) [m] (NaN for a reach).
    pub penetration: f64,
    /// Grasp: wrap angle [deg].
    pub wrap_angle: f64,
    /// Grasp: mean |ζ| [m].
    pub mean_gap: f64,
}

/// Derived figures of a muscle run.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MuscleSummary {
    /// Tip error / L0 at the end.
    pub final_tip_error: f64,
    /// θ_Q at the end [rad].
    pub final_orientation_error: f64,
    /// First time the tip error / L0 is ≤ 0.05 [s].
    pub time_to_5_percent: Option<f64>,
    /// First time the tip error / L0 is ≤ 0.01 [s].
    pub time_to_1_percent: Option<f64>,
    /// max_i |x_i(T) − x_i^design| / L0.
    pub node_deviation: f64,
    /// Largest rise of 𝓗 between samples after the ramp [J].
    pub hamiltonian_rise: f64,
    /// 𝓗 at the end of the ramp and at the end [J].
    pub hamiltonian_ramp: f64,
    /// 𝓗 at the end [J].
    pub hamiltonian_end: f64,
    /// Grasp at the end (grasp only).
    pub grasp: Option<GraspMetrics>,
    /// Largest penetration over every sample [m] (grasp).
    pub max_penetration: f64,
}

/// Samples a muscle run; writes its files and checks at the end.
pub struct MuscleRecorder {
    every: u64,
    design: MuscleDesignRun,
    muscles: MuscleModel,
    energy_consistent: bool,
    claims: Vec<AcceptanceConfig>,
    last_position: Vec<Vec3>,
    last_director: Vec<Mat3>,
    /// The samples.
    pub samples: Vec<MuscleSample>,
    /// Derived figures, after `finish`.
    pub summary: Option<MuscleSummary>,
    /// Acceptance checks, after `finish`.
    pub checks: Vec<Check>,
}

impl MuscleRecorder {
    /// A recorder of the run of `design`, sampling every `every` steps.
    pub fn new(
        every: u64,
        design: MuscleDesignRun,
        system: &RodSystem,
        claims: Vec<AcceptanceConfig>,
    ) -> Self {
        let muscles = system
            .rod(design.rod)
            .muscles
            .as_deref()
            .cloned()
            .expect("the rod has muscles");
        Self {
            every,
            last_position: design.pose.position.clone(),
            last_director: design.pose.director.clone(),
            muscles,
            energy_consistent: system.settings().energy_consistent,
            design,
            claims,
            samples: Vec::new(),
            summary: None,
            checks: Vec::new(),
        }
    }

    /// The design.
    pub fn design(&self) -> &MuscleDesignRun {
        &self.design
    }

    fn ramp_factor(&self, t: f64) -> f64 {
        if self.design.ramp <= 0.0 {
            1.0
        } else {
            (t / self.design.ramp).clamp(0.0, 1.0)
        }
    }

    fn hamiltonian(&self, model: &RodModel, s: &impl RodAccess, factor: f64) -> f64 {
        let n = model.n_elements;
        let e = energies(model, s, self.energy_consistent);
        let mut sigma = vec![[0.0; 3]; n];
        let mut kappa = vec![[0.0; 3]; n - 1];
        strains(model, s, &mut sigma, &mut kappa);
        let comp = |v: &[Vec3], c: usize| v.iter().map(|x| x[c]).collect::<Vec<f64>>();
        let (s0, s1, s2) = (comp(&sigma, 0), comp(&sigma, 1), comp(&sigma, 2));
        let (k0, k1, k2) = (comp(&kappa, 0), comp(&kappa, 1), comp(&kappa, 2));
        let dil: Vec<f64> = sigma
            .iter()
            .map(|v| (v[0] * v[0] + v[1] * v[1] + (1.0 + v[2]) * (1.0 + v[2])).sqrt())
            .collect();
        let eps: Vec<f64> = (0..n - 1)
            .map(|k| {
                0.5 * (model.rest_length[k] * dil[k] + model.rest_length[k + 1] * dil[k + 1])
                    / model.rest_voronoi_length[k]
            })
            .collect();
        let st = Strains {
            sigma: [&s0, &s1, &s2],
            dilatation: &dil,
            kappa: [&k0, &k1, &k2],
            voronoi_dilatation: &eps,
        };
        let a: Vec<f64> = self.design.activations.iter().map(|v| factor * v).collect();
        let act: [&[f64]; N_GROUPS] = std::array::from_fn(|g| &a[g * n..(g + 1) * n]);
        e.kinetic() + e.potential() + self.muscles.stored_energy(act, &st)
    }
}

impl Recorder for MuscleRecorder {
    fn every(&self) -> u64 {
        self.every
    }

    fn record(&mut self, m: &mut Moment<'_>) -> Result<()> {
        let r = self.design.rod;
        let rod = m.system.rod(r);
        let model = &rod.model;
        let v = m.system.view(m.state, r);
        let n = self.design.n;
        let t = m.state.time;
        let pos: Vec<Vec3> = (0..=n).map(|i| v.position(i)).collect();
        let dir: Vec<Mat3> = (0..n).map(|j| v.director(j)).collect();
        let tip: Vec3 = std::array::from_fn(|c| 0.5 * (pos[n - 1][c] + pos[n][c]));
        let (mut tip_error, mut orientation_error) = (f64::NAN, f64::NAN);
        let (mut penetration, mut wrap_angle, mut mean_gap) = (f64::NAN, f64::NAN, f64::NAN);
        match &self.design.task {
            MuscleTask::Reach(task) => {
                let d = [
                    tip[0] - task.target[0],
                    tip[1] - task.target[1],
                    tip[2] - task.target[2],
                ];
                tip_error = norm(d) / self.design.length;
                if let Some((q, _)) = task.frame {
                    orientation_error = log_relative(&dir[n - 1], &q).1;
                }
            }
            MuscleTask::Grasp(task) => {
                let g = grasp_metrics(&pos, &dir, &self.design.radius, task);
                penetration = g.penetration;
                wrap_angle = g.wrap_angle;
                mean_gap = g.mean_gap;
            }
        }
        // 𝓗 with the obstacles' contact energy (the grasp's cylinder).
        let hamiltonian = self.hamiltonian(model, &v, self.ramp_factor(t))
            + octoarm_physics::obstacle_energy(
                model,
                &v,
                m.system.obstacle_set(),
                m.system.contact(),
                t,
            );
        self.last_position = pos;
        self.last_director = dir;
        self.samples.push(MuscleSample {
            time: t,
            tip,
            tip_error,
            orientation_error,
            hamiltonian,
            penetration,
            wrap_angle,
            mean_gap,
        });
        Ok(())
    }

    fn finish(&mut self, out: &OutputDir, run: &RunInfo) -> Result<Map<String, Value>> {
        let s = &self.samples;
        let t = s.len();
        // series.npz
        let path = out.path("series.npz");
        let file =
            File::create(&path).with_context(|| format!("cannot create {}", path.display()))?;
        let mut npz = zip::ZipWriter::new(BufWriter::new(file));
        let col = |f: &dyn Fn(&MuscleSample) -> f64| -> Vec<f64> { s.iter().map(f).collect() };
        write_member(&mut npz, "time", &[t], &col(&|x| x.time))?;
        let tips: Vec<f64> = s.iter().flat_map(|x| x.tip).collect();
        write_member(&mut npz, "tip", &[t, 3], &tips)?;
        write_member(&mut npz, "tip_error", &[t], &col(&|x| x.tip_error))?;
        write_member(
            &mut npz,
            "orientation_error",
            &[t],
            &col(&|x| x.orientation_error),
        )?;
        write_member(&mut npz, "hamiltonian", &[t], &col(&|x| x.hamiltonian))?;
        if self.design.grasp.is_some() {
            write_member(&mut npz, "penetration", &[t], &col(&|x| x.penetration))?;
            write_member(&mut npz, "wrap_angle", &[t], &col(&|x| x.wrap_angle))?;
            write_member(&mut npz, "mean_gap", &[t], &col(&|x| x.mean_gap))?;
        }
        npz.finish()?.into_inner().map_err(|e| e.into_error())?;
        // activations.npy [7, n]
        let n = self.design.n;
        let path = out.path("activations.npy");
        let mut f = BufWriter::new(
            File::create(&path).with_context(|| format!("cannot create {}", path.display()))?,
        );
        f.write_all(&npy_header(&[N_GROUPS, n]))?;
        for v in &self.design.activations {
            f.write_all(&v.to_le_bytes())?;
        }
        f.flush()?;
        // design_pose.npz
        let path = out.path("design_pose.npz");
        let file =
            File::create(&path).with_context(|| format!("cannot create {}", path.display()))?;
        let mut npz = zip::ZipWriter::new(BufWriter::new(file));
        let p: Vec<f64> = self
            .design
            .pose
            .position
            .iter()
            .flatten()
            .copied()
            .collect();
        write_member(&mut npz, "position", &[n + 1, 3], &p)?;
        let q: Vec<f64> = self
            .design
            .pose
            .director
            .iter()
            .flat_map(|m| m.iter().flatten().copied())
            .collect();
        write_member(&mut npz, "director", &[n, 3, 3], &q)?;
        npz.finish()?.into_inner().map_err(|e| e.into_error())?;
        write_json(&out.path("design.json"), &self.design.to_json())?;

        let summary = self.derive();
        self.checks = evaluate(&self.claims, &self.design, s, &summary, run);
        self.summary = Some(summary);
        let mut m = Map::new();
        let checks: Vec<Value> = self
            .checks
            .iter()
            .map(|c| {
                json!({"claim": c.claim, "measured": c.measured,
                    "result": match c.pass { Some(true) => "pass", Some(false) => "fail", None => "undecided" },
                    "note": c.note})
            })
            .collect();
        m.insert(
            "muscles".into(),
            json!({
                "design": self.design.to_json(),
                "final_tip_error_l0": summary.final_tip_error,
                "final_orientation_error": summary.final_orientation_error,
                "time_to_0.05_l0": summary.time_to_5_percent,
                "time_to_0.01_l0": summary.time_to_1_percent,
                "node_deviation_l0": summary.node_deviation,
                "hamiltonian_after_ramp": summary.hamiltonian_ramp,
                "hamiltonian_end": summary.hamiltonian_end,
                "hamiltonian_largest_rise": summary.hamiltonian_rise,
                "max_penetration": summary.max_penetration,
                "grasp_end": summary.grasp.map(|g| json!({
                    "wrap_angle_deg": g.wrap_angle, "penetration": g.penetration,
                    "mean_gap": g.mean_gap, "max_gap": g.max_gap, "sucker_alignment": g.alignment})),
            }),
        );
        m.insert("acceptance".into(), Value::Array(checks));
        Ok(m)
    }
}

impl MuscleRecorder {
    fn derive(&self) -> MuscleSummary {
        let s = &self.samples;
        let Some(last) = s.last() else {
            return MuscleSummary::default();
        };
        let l0 = self.design.length;
        let node_deviation = self
            .last_position
            .iter()
            .zip(&self.design.pose.position)
            .map(|(a, b)| norm([a[0] - b[0], a[1] - b[1], a[2] - b[2]]))
            .fold(0.0, f64::max)
            / l0;
        let first_below = |b: f64| s.iter().find(|x| x.tip_error <= b).map(|x| x.time);
        let after: Vec<&MuscleSample> = s
            .iter()
            .filter(|x| x.time >= self.design.ramp - 1e-9)
            .collect();
        let rise = after
            .windows(2)
            .map(|w| w[1].hamiltonian - w[0].hamiltonian)
            .fold(0.0, f64::max);
        let grasp = match &self.design.task {
            MuscleTask::Grasp(task) => Some(grasp_metrics(
                &self.last_position,
                &self.last_director,
                &self.design.radius,
                task,
            )),
            MuscleTask::Reach(_) => None,
        };
        MuscleSummary {
            final_tip_error: last.tip_error,
            final_orientation_error: last.orientation_error,
            time_to_5_percent: first_below(0.05),
            time_to_1_percent: first_below(0.01),
            node_deviation,
            hamiltonian_rise: rise,
            hamiltonian_ramp: after.first().map_or(f64::NAN, |x| x.hamiltonian),
            hamiltonian_end: last.hamiltonian,
            grasp,
            max_penetration: s
                .iter()
                .map(|x| x.penetration)
                .filter(|v| v.is_finite())
                .fold(f64::NEG_INFINITY, f64::max),
        }
    }
}

/// Evaluate the `[[acceptance]]` claims of a muscle run. A claim about a time the run did not
/// reach, or about the dynamics of a run that failed, is undecided.
pub fn evaluate(
    claims: &[AcceptanceConfig],
    design: &MuscleDesignRun,
    samples: &[MuscleSample],
    summary: &MuscleSummary,
    run: &RunInfo,
) -> Vec<Check> {
    use AcceptanceQuantity as Q;
    let end = samples.last().map_or(0.0, |x| x.time);
    let complete = run.failure.is_none() && end >= run.duration - 1e-9;
    let c = &design.report.costs;
    let l0 = design.length;
    let within = |v: f64, a: &AcceptanceConfig| {
        a.min.map_or(true, |m| v >= m) && a.max.map_or(true, |m| v <= m)
    };
    let nearest = |t: f64| {
        samples
            .iter()
            .min_by(|a, b| (a.time - t).abs().total_cmp(&(b.time - t).abs()))
    };
    let g = design.grasp.unwrap_or_default();
    let spacing = match samples {
        [a, b, ..] => b.time - a.time,
        _ => 0.0,
    };
    claims
        .iter()
        .map(|a| {
            let t = a.time.unwrap_or(0.0);
            let reached = end >= t - 1e-9;
            let value = |v: f64, text: String| (text, Some(within(v, a)));
            let (measured, pass) = match a.quantity {
                Q::MuscleDesignTipError => value(
                    c.tip_error / l0,
                    format!("{:.2e} L0 ({:.1} µm)", c.tip_error / l0, c.tip_error * 1e6),
                ),
                Q::MuscleDesignOrientationError => value(
                    c.orientation_error,
                    format!("{:.2e} rad", c.orientation_error),
                ),
                Q::MuscleDesignCost => value(c.total, format!("{:.4}", c.total)),
                Q::MuscleDesignResidual => {
                    value(design.residual, format!("{:.1e}", design.residual))
                }
                Q::MuscleDesignMaxTurn => {
                    value(design.max_turn, format!("{:.3} rad", design.max_turn))
                }
                Q::MuscleGroupIntegral => {
                    let k = MUSCLE_GROUP_NAMES
                        .iter()
                        .position(|x| Some(*x) == a.group.as_deref())
                        .unwrap_or(0);
                    let v = design.group_integrals[k];
                    value(v, format!("{v:.3} L0"))
                }
                Q::MuscleObliqueIntegral => {
                    let v = design.group_integrals[group::OM_POS]
                        + design.group_integrals[group::OM_NEG];
                    value(v, format!("{v:.3} L0"))
                }
                Q::MuscleActivationViolations => {
                    value(design.violations as f64, format!("{}", design.violations))
                }
                Q::MuscleDesignTwist => value(design.twist, format!("{:.3e} rad", design.twist)),
                Q::MuscleDesignWrapAngle => value(g.wrap_angle, format!("{:.0}°", g.wrap_angle)),
                Q::MuscleDesignPenetration => {
                    value(g.penetration, format!("{:.2} mm", g.penetration * 1e3))
                }
                Q::MuscleDesignMeanGap => value(g.mean_gap, format!("{:.2} mm", g.mean_gap * 1e3)),
                Q::MuscleDesignMaxGap => value(g.max_gap, format!("{:.2} mm", g.max_gap * 1e3)),
                Q::MuscleDesignSuckerAlignment => value(g.alignment, format!("{:.3}", g.alignment)),
                Q::TipErrorAt | Q::OrientationErrorAt => match nearest(t) {
                    Some(x) if reached && (x.time - t).abs() <= spacing + 1e-9 => {
                        let v = if a.quantity == Q::TipErrorAt {
                            x.tip_error
                        } else {
                            x.orientation_error
                        };
                        value(v, format!("{v:.2e} at {:.2} s", x.time))
                    }
                    _ => (format!("the run ended at {end:.2} s"), None),
                },
                Q::TipErrorRise => {
                    if !complete || !reached {
                        (format!("the run ended at {end:.2} s"), None)
                    } else {
                        // Every 0.5 s from `time` on.
                        let mut picks = Vec::new();
                        let mut k = 0;
                        loop {
                            let tk = t + 0.5 * k as f64;
                            if tk > end + 1e-9 {
                                break;
                            }
                            if let Some(x) = nearest(tk) {
                                picks.push(x.tip_error);
                            }
                            k += 1;
                        }
                        let rise = picks
                            .windows(2)
                            .map(|w| w[1] - w[0])
                            .fold(f64::NEG_INFINITY, f64::max);
                        value(rise, format!("largest 0.5 s rise {rise:.2e}"))
                    }
                }
                Q::NodeDeviation => {
                    if complete && reached {
                        value(
                            summary.node_deviation,
                            format!("{:.2e} L0", summary.node_deviation),
                        )
                    } else {
                        (format!("the run ended at {end:.2} s"), None)
                    }
                }
                Q::HamiltonianRise | Q::HamiltonianChange => {
                    if !complete || !reached {
                        (format!("the run ended at {end:.2} s"), None)
                    } else {
                        let after: Vec<&MuscleSample> =
                            samples.iter().filter(|x| x.time >= t - 1e-9).collect();
                        let h0 = after.first().map_or(f64::NAN, |x| x.hamiltonian);
                        let h1 = after.last().map_or(f64::NAN, |x| x.hamiltonian);
                        if a.quantity == Q::HamiltonianChange {
                            value(h1 - h0, format!("𝓗 {h0:.4e} → {h1:.4e} J"))
                        } else {
                            let rise = after
                                .windows(2)
                                .map(|w| w[1].hamiltonian - w[0].hamiltonian)
                                .fold(0.0, f64::max);
                            let rel = if h0 > h1 {
                                rise / (h0 - h1)
                            } else {
                                f64::INFINITY
                            };
                            value(
                                rel,
                                format!("largest rise {rise:.2e} J = {rel:.2e} of the drop"),
                            )
                        }
                    }
                }
                Q::GraspPenetration => {
                    let (text, pass) = value(
                        summary.max_penetration,
                        format!("{:.2} mm", summary.max_penetration * 1e3),
                    );
                    // A failure is decided at once; a pass only over the whole interval.
                    if pass == Some(true) && !reached {
                        (format!("{text} up to {end:.2} s"), None)
                    } else {
                        (text, pass)
                    }
                }
                Q::GraspWrapAngle | Q::GraspMeanGap => match (complete && reached, summary.grasp) {
                    (true, Some(ge)) => {
                        if a.quantity == Q::GraspWrapAngle {
                            value(ge.wrap_angle, format!("{:.0}°", ge.wrap_angle))
                        } else {
                            value(ge.mean_gap, format!("{:.2} mm", ge.mean_gap * 1e3))
                        }
                    }
                    _ => (format!("the run ended at {end:.2} s"), None),
                },
                _ => ("not a quantity of muscle runs".into(), None),
            };
            Check {
                claim: a.claim.clone(),
                measured,
                pass,
                note: a.note.clone(),
                infeasible: a.infeasible,
            }
        })
        .collect()
}
