//! Controllers behind one trait, and the energy-shaping controller of the CDC-2020 paper.
//! A `Controller` is updated every `period()` seconds of simulated time by the run pipeline: it
//! reads the system and its state and writes the system's `Actuation`; the stepper never calls
//! it. `TaskSchedule` is a task over time (tip targets, a via path for the design, obstacles, a
//! grasp); `ShapingController` designs w̄ for it offline (before t = 0) or online and drives the
//! rod with the energy-shaping law. Nothing here records, writes files or knows experiments.

use crate::error::{ShapingError, SolveError, StaticsError};
use crate::shaping::{EnergyShapingController, ShapingConfig};
use crate::solver::{OfflineSolver, OnlineConfig, OnlineSolver, SolverConfig};
use crate::statics::Statics;
use crate::strains::StrainField;
use crate::task::{Grasp, GraspWeight, Task};
use octoarm_physics::math::{norm, sub};
use octoarm_physics::{
    Actuation, EndCondition, Energies, ModelError, RodAccess, RodSystem, SystemState, Vec3,
};

/// Why a controller could not be set up or updated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ControlError {
    /// A setting outside its range.
    #[error("{field} = {value} is outside the allowed range {range}")]
    OutOfRange {
        /// Name of the setting.
        field: &'static str,
        /// Value given.
        value: f64,
        /// Allowed range.
        range: &'static str,
    },
    /// Neither a target nor a grasp.
    #[error("the task has neither a target nor a grasp")]
    NoTask,
    /// The controlled rod is not held as the statics assume.
    #[error("rod `{rod}`: the energy-shaping controller needs a rod clamped at its base and free at its tip (base is {base}, tip is {tip})")]
    Ends {
        /// Name of the rod.
        rod: String,
        /// Its base condition.
        base: &'static str,
        /// Its tip condition.
        tip: &'static str,
    },
    /// A physics input was rejected.
    #[error("physics: {0}")]
    Model(#[from] ModelError),
    /// The statics could not be built.
    #[error("building the statics: {0}")]
    Statics(#[from] StaticsError),
    /// A design could not be solved.
    #[error("solving the design: {0}")]
    Solve(#[from] SolveError),
    /// The law refused a design.
    #[error("applying the design: {0}")]
    Shaping(#[from] ShapingError),
}

/// What a controller reports at a sample time, for recorders (all optional but the rod).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Signals {
    /// The rod it controls.
    pub rod: usize,
    /// Counter of design changes: constant between changes of the control (Lyapunov intervals).
    pub design_epoch: u64,
    /// The task target in force [m] (None for a grasp).
    pub target: Option<Vec3>,
    /// The design target in force (a via point or the task target).
    pub design_target: Option<Vec3>,
    /// Task error / L0: tip distance to the target, or the grasp's weighted mean surface gap.
    pub distance: f64,
    /// Energies with the strain energy measured from the design w̄ (the shaped Hamiltonian's
    /// parts), if the controller shapes energy.
    pub shaped: Option<Energies>,
}

/// Counters and design figures of a controller's run.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ControlReport {
    /// Total solver sweeps (offline and online).
    pub sweeps: usize,
    /// Tip error (or grasp gap) of each offline design [m].
    pub design_tip_errors: Vec<f64>,
    /// Largest penetration of each offline design [m].
    pub design_penetrations: Vec<f64>,
    /// Online updates that failed (the previous design was kept).
    pub failed_updates: usize,
    /// (time [s], tip error [m] of the design in force after the update) of each online update.
    /// At most `MAX_UPDATE_RECORDS` entries: beyond, neighbouring entries are merged into one
    /// (the later time, the larger error), so that "the largest error at or after t" never
    /// misses an update (it may include a few earlier ones).
    pub update_tip_errors: Vec<(f64, f64)>,
}

/// Most entries of `ControlReport::update_tip_errors` (memory does not grow with the run).
pub const MAX_UPDATE_RECORDS: usize = 1 << 16;

impl ControlReport {
    /// Record the tip error of an online update, merging pairs of entries beyond
    /// `MAX_UPDATE_RECORDS`.
    pub fn push_update_tip_error(&mut self, time: f64, error: f64) {
        let v = &mut self.update_tip_errors;
        v.push((time, error));
        if v.len() > MAX_UPDATE_RECORDS {
            let merged: Vec<(f64, f64)> = v
                .chunks(2)
                .map(|c| {
                    let last = c[c.len() - 1];
                    (last.0, c.iter().map(|e| e.1).fold(f64::NAN, f64::max))
                })
                .collect();
            *v = merged;
        }
    }
}

/// A controller of one rod of a system, updated by the run pipeline every `period()` seconds
/// (at t = 0, then every period; never at the run's last instant). It writes the system's
/// actuation; the stepper applies it, unchanged, until the next update.
pub trait Controller: Send {
    /// Simulated time between updates [s], > 0.
    fn period(&self) -> f64;

    /// Update at time `t` [s]: read `system` and `state`, write `actuation`. An error stops
    /// the run.
    fn update(
        &mut self,
        t: f64,
        system: &RodSystem,
        state: &SystemState,
        actuation: &mut Actuation,
    ) -> Result<(), ControlError>;

    /// Signals at time `t` for the state `state` (called at sample times, between updates).
    fn signals(&self, t: f64, system: &RodSystem, state: &SystemState) -> Signals;

    /// The shape the controller currently aims at (node positions [m]), if it has one.
    fn desired_shape(&mut self) -> Option<&[Vec3]>;

    /// Counters and design figures so far.
    fn report(&self) -> ControlReport;
}

/// A task target in force from time `from` [s] on: r*(t) = `position` + `velocity`·(t − from).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TargetPhase {
    /// Start of the phase [s].
    pub from: f64,
    /// Target at `from` [m], lab frame.
    pub position: Vec3,
    /// Constant velocity [m/s] (zero for a static target).
    pub velocity: Vec3,
}

impl TargetPhase {
    /// A static target from `from` [s].
    pub fn fixed(position: Vec3, from: f64) -> Self {
        Self {
            from,
            position,
            velocity: [0.0; 3],
        }
    }

    /// A piecewise-linear path through `points` traversed at constant speed from `start` to
    /// `end` [s]: one moving phase per segment.
    pub fn polyline(points: &[Vec3], start: f64, end: f64) -> Vec<Self> {
        let lengths: Vec<f64> = points.windows(2).map(|w| norm(sub(w[1], w[0]))).collect();
        let total: f64 = lengths.iter().sum();
        let mut phases = Vec::new();
        let mut t = start;
        for (w, l) in points.windows(2).zip(&lengths) {
            let dur = if total > 0.0 {
                (end - start) * l / total
            } else {
                0.0
            };
            let velocity = if dur > 0.0 {
                let d = sub(w[1], w[0]);
                [d[0] / dur, d[1] / dur, d[2] / dur]
            } else {
                [0.0; 3]
            };
            phases.push(Self {
                from: t,
                position: w[0],
                velocity,
            });
            t += dur;
        }
        phases
    }

    /// Target at time t [m].
    pub fn at(&self, t: f64) -> Vec3 {
        let dt = t - self.from;
        [
            self.position[0] + dt * self.velocity[0],
            self.position[1] + dt * self.velocity[1],
            self.position[2] + dt * self.velocity[2],
        ]
    }
}

fn phase_at(phases: &[TargetPhase], t: f64) -> Option<&TargetPhase> {
    // The phase with the latest start not after t (the first phase also covers earlier times).
    let mut found = phases.first()?;
    for p in phases {
        if p.from <= t + 1e-12 {
            found = p;
        }
    }
    Some(found)
}

/// A sphere of a task: a design constraint (weight ξ) of the statics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereSpec {
    /// Centre [m].
    pub center: Vec3,
    /// Diameter [m].
    pub diameter: f64,
}

/// The grasp of a sphere (spec §5.5): μ_grasp = `weight` on [`from_fraction`·L0, L0], no tip term.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GraspSpec {
    /// The object.
    pub object: SphereSpec,
    /// μ_grasp on the interval [N/m].
    pub weight: f64,
    /// Start of the grasping interval as a fraction of L0.
    pub from_fraction: f64,
}

/// A task over time: tip targets in time order, an optional via path for the design only,
/// spheres to avoid, or a grasp; and the cost weights.
#[derive(Debug, Clone, PartialEq)]
pub struct TaskSchedule {
    /// Task targets in time order; the distance d(t) is measured to the target in force.
    pub targets: Vec<TargetPhase>,
    /// Intermediate design targets for the controller only: while a via phase is in force
    /// (t < `via_until`), the design aims at it instead of the task target.
    pub via_points: Vec<TargetPhase>,
    /// End of the via phases [s].
    pub via_until: f64,
    /// Spheres to avoid (design constraints).
    pub obstacles: Vec<SphereSpec>,
    /// Grasp, if any.
    pub grasp: Option<GraspSpec>,
    /// Tip weight μ_tip [N/m].
    pub mu_tip: f64,
    /// Obstacle weight ξ [N/m²].
    pub xi: f64,
    /// Arm length L0 [m] used to place the grasp interval.
    pub length: f64,
}

impl TaskSchedule {
    /// The task target in force at `t`, if any.
    pub fn target_at(&self, t: f64) -> Option<Vec3> {
        phase_at(&self.targets, t).map(|p| p.at(t))
    }

    /// The design target at `t`: the via point in force, else the task target.
    pub fn design_target_at(&self, t: f64) -> Option<Vec3> {
        if t < self.via_until {
            if let Some(p) = phase_at(&self.via_points, t) {
                return Some(p.at(t));
            }
        }
        self.target_at(t)
    }

    /// The statics task for a tip target (obstacles, grasp, weights).
    pub fn task(&self, target: Option<Vec3>) -> Task {
        let mut task = match target {
            Some(t) => Task::reach(t, self.mu_tip),
            None => Task::default(),
        };
        for o in &self.obstacles {
            task = task.with_obstacle(o.center, o.diameter, self.xi);
        }
        if let Some(g) = &self.grasp {
            let mut grasp = Grasp::paper(
                g.object.center,
                0.5 * g.object.diameter,
                g.weight,
                self.length,
            );
            if let GraspWeight::Interval { from, .. } = &mut grasp.weight {
                *from = g.from_fraction * self.length;
            }
            task = task.with_grasp(grasp, self.xi);
        }
        task
    }

    /// Times at which the design target changes phase (0 first), for offline designs.
    pub fn boundaries(&self) -> Vec<f64> {
        let mut b: Vec<f64> = vec![0.0];
        for p in self.targets.iter().chain(&self.via_points) {
            if p.from > 0.0 {
                b.push(p.from);
            }
        }
        if !self.via_points.is_empty() && self.via_until > 0.0 {
            b.push(self.via_until);
        }
        b.sort_by(f64::total_cmp);
        b.dedup_by(|a, c| (*a - *c).abs() < 1e-12);
        b
    }

    /// Task error at time t of the rod state `s` (node weights and radii of the statics, rest
    /// arc lengths `arc`, rod length `length`): d/L0 for a target, the grasp's weighted mean
    /// absolute surface gap / L0 for a grasp, NaN without either; and the target (NaN for none).
    pub fn distance(
        &self,
        s: &impl RodAccess,
        t: f64,
        arc: &[f64],
        node_weight: &[f64],
        node_radius: &[f64],
        length: f64,
    ) -> (f64, Vec3) {
        let n = s.n_elements();
        match (&self.grasp, self.target_at(t)) {
            (Some(g), _) => {
                let (mut num, mut den) = (0.0, 0.0);
                let r = 0.5 * g.object.diameter;
                for i in 0..=n {
                    if arc[i] + 1e-9 * length >= g.from_fraction * length {
                        let w = node_weight[i] * g.weight;
                        let zeta = norm(sub(s.position(i), g.object.center)) - (r + node_radius[i]);
                        num += w * zeta.abs();
                        den += w;
                    }
                }
                (num / den / length, [f64::NAN; 3])
            }
            (None, Some(target)) => (norm(sub(s.position(n), target)) / length, target),
            (None, None) => (f64::NAN, [f64::NAN; 3]),
        }
    }
}

/// How the design w̄ is scheduled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DesignMode {
    /// Every design solved before t = 0 from the straight strains (grasps with a μ_grasp
    /// continuation of `grasp_stages` log-spaced stages, spec §3.2); a design takes effect at the
    /// first update at or after its phase's start, at once (`ramp_time` = 0) or through a linear
    /// ramp of `ramp_time` [s] advanced at every update.
    Offline {
        /// Ramp duration T_ramp [s] (spec §4.7), ≥ 0.
        ramp_time: f64,
        /// Stages of the grasp continuation, ≥ 1.
        grasp_stages: usize,
    },
    /// Spec §3.3: at every update, sample the design target and run `iterations_per_update`
    /// warm-started iterations; the new w̄ is applied at once.
    Online {
        /// Solver iterations per update, ≥ 1.
        iterations_per_update: usize,
        /// If set, cap each component's change per update so that the design needs about this
        /// long [s] to form.
        trust_form_time: Option<f64>,
        /// Solve the first design target offline before t = 0 and start from it.
        presolve: bool,
    },
}

/// Settings of a `ShapingController`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShapingControllerConfig {
    /// The solver (space, floor, rule, tolerances).
    pub solver: SolverConfig,
    /// Design schedule.
    pub mode: DesignMode,
    /// Time between updates [s] (online iterations, ramp increments, design switches), > 0.
    pub period: f64,
}

/// The energy-shaping controller of one clamped–free rod: designs w̄ for a `TaskSchedule`
/// offline or online and writes the law's stresses into the actuation.
#[derive(Debug, Clone)]
pub struct ShapingController {
    config: ShapingControllerConfig,
    schedule: TaskSchedule,
    rod: usize,
    law: EnergyShapingController,
    shape: Statics,
    shape_valid: bool,
    offline: Vec<(f64, StrainField)>,
    next_offline: usize,
    ramp: Option<(u64, StrainField, StrainField)>,
    online: Option<OnlineSolver>,
    online_task: Task,
    scratch: StrainField,
    arc: Vec<f64>,
    epoch: u64,
    report: ControlReport,
}

impl ShapingController {
    /// A controller of rod `rod` of `system` at its initial state `state`; offline designs (and
    /// an online pre-solve) are solved here, before t = 0. Errors name the bad setting.
    pub fn new(
        system: &RodSystem,
        state: &SystemState,
        rod: usize,
        schedule: TaskSchedule,
        config: ShapingControllerConfig,
    ) -> Result<Self, ControlError> {
        let check = |field: &'static str, v: f64, ok: bool, range: &'static str| {
            if v.is_finite() && ok {
                Ok(())
            } else {
                Err(ControlError::OutOfRange {
                    field,
                    value: v,
                    range,
                })
            }
        };
        check("period", config.period, config.period > 0.0, "(0, inf)")?;
        if schedule.targets.is_empty() && schedule.grasp.is_none() {
            return Err(ControlError::NoTask);
        }
        match config.mode {
            DesignMode::Offline {
                ramp_time,
                grasp_stages,
            } => {
                check("ramp_time", ramp_time, ramp_time >= 0.0, "[0, inf)")?;
                check(
                    "grasp_stages",
                    grasp_stages as f64,
                    grasp_stages >= 1,
                    "[1, inf)",
                )?;
            }
            DesignMode::Online {
                iterations_per_update,
                trust_form_time,
                ..
            } => {
                check(
                    "iterations_per_update",
                    iterations_per_update as f64,
                    iterations_per_update >= 1,
                    "[1, inf)",
                )?;
                if let Some(t) = trust_form_time {
                    check("trust_form_time", t, t > 0.0, "(0, inf)")?;
                }
            }
        }
        let r = system.rod(rod);
        if r.base.condition != EndCondition::Clamped || r.tip.condition != EndCondition::Free {
            return Err(ControlError::Ends {
                rod: r.name.clone(),
                base: r.base.condition.name(),
                tip: r.tip.condition.name(),
            });
        }
        let model = &r.model;
        let rod_state = system.rod_state(state, rod);
        let law = EnergyShapingController::for_rod(system, rod, ShapingConfig::default())?;
        let shape = Statics::new(
            model,
            &rod_state,
            config.solver.space,
            config.solver.floor_diameter,
        )?;
        let rest = shape.rest().clone();
        let mut report = ControlReport::default();
        let mut offline = Vec::new();
        let mut online = None;
        match config.mode {
            DesignMode::Offline { grasp_stages, .. } => {
                let mut solver = OfflineSolver::new(model, &rod_state, config.solver)?;
                for b in schedule.boundaries() {
                    let task = schedule.task(schedule.design_target_at(b));
                    let sol = if task.grasp.is_some() {
                        grasp_continuation(&mut solver, &task, grasp_stages)?
                    } else {
                        solver.solve(&task, None)?
                    };
                    report.sweeps += sol.report.sweeps;
                    report.design_tip_errors.push(sol.report.tip_error);
                    report.design_penetrations.push(sol.report.max_penetration);
                    offline.push((b, sol.strains));
                }
            }
            DesignMode::Online {
                iterations_per_update,
                trust_form_time,
                presolve,
            } => {
                // One offline solve for the design target at t = 0 serves both the trust region
                // (its size) and the pre-solve (the starting design).
                let first = if trust_form_time.is_some() || presolve {
                    let mut solver = OfflineSolver::new(model, &rod_state, config.solver)?;
                    let task = schedule.task(schedule.design_target_at(0.0));
                    let sol = solver.solve(&task, None)?;
                    report.sweeps += sol.report.sweeps;
                    if presolve {
                        report.design_tip_errors.push(sol.report.tip_error);
                        report.design_penetrations.push(sol.report.max_penetration);
                    }
                    Some(sol.strains)
                } else {
                    None
                };
                let trust_region = match (trust_form_time, &first) {
                    (Some(form), Some(w)) => Some(OnlineConfig::trust_region_from(
                        w,
                        &rest,
                        config.period,
                        form,
                    )),
                    _ => None,
                };
                let cfg = OnlineConfig {
                    iterations_per_update,
                    trust_region,
                };
                let initial = if presolve { first.as_ref() } else { None };
                online = Some(OnlineSolver::new(
                    model,
                    &rod_state,
                    config.solver,
                    cfg,
                    initial,
                )?);
            }
        }
        let online_task = schedule.task(schedule.design_target_at(0.0));
        Ok(Self {
            config,
            rod,
            scratch: StrainField::intrinsic(model),
            arc: model.node_arc_length.clone(),
            law,
            shape,
            shape_valid: false,
            offline,
            next_offline: 0,
            ramp: None,
            online,
            online_task,
            schedule,
            epoch: 0,
            report,
        })
    }

    /// The law (design in force, stresses).
    pub fn law(&self) -> &EnergyShapingController {
        &self.law
    }

    /// The task schedule.
    pub fn schedule(&self) -> &TaskSchedule {
        &self.schedule
    }

    /// The statics of the rod (node weights and radii, the forward map of the last design).
    pub fn statics(&self) -> &Statics {
        &self.shape
    }

    fn set_design(&mut self, system: &RodSystem, w: &StrainField) -> Result<(), ControlError> {
        self.law.set_design(&system.rod(self.rod).model, w)?;
        self.epoch += 1;
        self.shape_valid = false;
        Ok(())
    }
}

impl Controller for ShapingController {
    fn period(&self) -> f64 {
        self.config.period
    }

    fn update(
        &mut self,
        t: f64,
        system: &RodSystem,
        _state: &SystemState,
        actuation: &mut Actuation,
    ) -> Result<(), ControlError> {
        let dt = system.settings().dt;
        let step = (t / dt).round() as u64;
        let step_of = |b: f64| (b / dt - 1e-9).ceil().max(0.0) as u64;
        if let DesignMode::Offline { ramp_time, .. } = self.config.mode {
            while self.next_offline < self.offline.len()
                && step >= step_of(self.offline[self.next_offline].0)
            {
                let to = self.offline[self.next_offline].1.clone();
                if ramp_time > 0.0 {
                    self.ramp = Some((step, self.law.design().clone(), to));
                } else {
                    self.set_design(system, &to)?;
                }
                self.next_offline += 1;
            }
            if let Some((start, from, to)) = self.ramp.take() {
                let a = ((step - start) as f64 * dt / ramp_time).min(1.0);
                for ((w, f), g) in self
                    .scratch
                    .as_mut_slice()
                    .iter_mut()
                    .zip(from.as_slice())
                    .zip(to.as_slice())
                {
                    *w = f + a * (g - f);
                }
                let w = self.scratch.clone();
                self.set_design(system, &w)?;
                if a < 1.0 {
                    self.ramp = Some((start, from, to));
                }
            }
        }
        if let Some(solver) = &mut self.online {
            if let Some(target) = self.schedule.design_target_at(t) {
                self.online_task.set_target(target);
            }
            match solver.update(&self.online_task) {
                Ok(rep) => {
                    self.report.sweeps += rep.sweeps;
                    self.report.push_update_tip_error(t, rep.tip_error);
                    if !rep.accepted {
                        self.report.failed_updates += 1;
                    }
                }
                Err(_) => self.report.failed_updates += 1,
            }
            let w = solver.design().clone();
            self.set_design(system, &w)?;
        }
        self.law.actuate(system, actuation);
        Ok(())
    }

    fn signals(&self, t: f64, system: &RodSystem, state: &SystemState) -> Signals {
        let r = system.rod(self.rod);
        let view = system.view(state, self.rod);
        let (distance, _) = self.schedule.distance(
            &view,
            t,
            &self.arc,
            self.shape.node_weight(),
            self.shape.node_radius(),
            r.model.length(),
        );
        let grasp = self.schedule.grasp.is_some();
        Signals {
            rod: self.rod,
            design_epoch: self.epoch,
            target: self.schedule.target_at(t).filter(|_| !grasp),
            design_target: self.schedule.design_target_at(t).filter(|_| !grasp),
            distance,
            shaped: Some(self.law.shaped_energies(
                &r.model,
                &view,
                system.settings().energy_consistent,
            )),
        }
    }

    fn desired_shape(&mut self) -> Option<&[Vec3]> {
        if !self.shape_valid {
            self.shape.forward(self.law.design());
            self.shape_valid = true;
        }
        Some(self.shape.position())
    }

    fn report(&self) -> ControlReport {
        self.report.clone()
    }
}

fn grasp_continuation(
    solver: &mut OfflineSolver,
    task: &Task,
    stages: usize,
) -> Result<crate::solver::Solution, SolveError> {
    let mut warm: Option<StrainField> = None;
    let mut sweeps = 0;
    let mut last = None;
    for k in 0..stages {
        let exponent = if stages == 1 {
            0.0
        } else {
            -3.0 + 3.0 * k as f64 / (stages - 1) as f64
        };
        let mut staged = task.clone();
        if let Some(g) = &mut staged.grasp {
            match &mut g.weight {
                GraspWeight::Interval { weight, .. } => *weight *= 10f64.powf(exponent),
                GraspWeight::PerNode(w) => w.iter_mut().for_each(|x| *x *= 10f64.powf(exponent)),
            }
        }
        let sol = solver.solve(&staged, warm.as_ref())?;
        sweeps += sol.report.sweeps;
        warm = Some(sol.strains.clone());
        last = Some(sol);
    }
    let mut sol = last.expect("at least one stage");
    sol.report.sweeps = sweeps;
    Ok(sol)
}

#[cfg(test)]
mod bounded_report_tests {
    use super::*;

    #[test]
    fn update_tip_errors_stay_bounded_and_never_miss_a_late_large_error() {
        let mut r = ControlReport::default();
        let n = 3 * MAX_UPDATE_RECORDS + 17;
        for k in 0..n {
            let e = if k == n - 5 { 9.0 } else { 1e-3 };
            r.push_update_tip_error(k as f64, e);
            assert!(r.update_tip_errors.len() <= MAX_UPDATE_RECORDS);
        }
        let late = |t: f64| {
            r.update_tip_errors
                .iter()
                .filter(|e| e.0 >= t)
                .map(|e| e.1)
                .fold(f64::NAN, f64::max)
        };
        assert_eq!(late((n - 5) as f64), 9.0);
        assert_eq!(r.update_tip_errors.last().unwrap().0, (n - 1) as f64);
    }
}
