//! The forward–backward sweep as an optimiser (spec §3): the three update rules (R: the paper's
//! plain gradient step, P: stiffness-preconditioned step, Q: L-BFGS in the stiffness metric, the
//! default), the offline solve with its stopping rules and report, and the online solver that
//! runs a set number of warm-started iterations per control update. The sweep itself is `statics`.

use crate::error::{SolveError, StaticsError};
use crate::statics::{CostTerms, Statics};
use crate::strains::{StrainField, StrainSpace};
use crate::task::{GraspWeight, Task};
use octoarm_physics::{RodModel, RodState};
use std::time::{Duration, Instant};

/// Strain update rule (spec §3.1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum UpdateRule {
    /// Rule R, the paper's step along the pointwise Hamiltonian gradient:
    /// w ← w − η D⁻¹∇J, D = diag(ℓ̂_j, D̂_k); stretch clamped at ν3 ≥ `min_stretch`.
    /// Stable for η μ_tip (L0 + L0³/3) < 2; default η = 0.005 (the paper's 0.01 sits on the bound).
    Paper {
        /// Step η_R (the paper's η Δt) [m²/N in SI], > 0.
        eta: f64,
        /// Lower clamp of the stretch ν3 (default 0.1).
        min_stretch: f64,
    },
    /// Rule P: w ← w − η P⁻¹∇J with P = diag(ℓ̂ S^d, D̂ B^d); η dimensionless in (0, 1].
    Preconditioned {
        /// Relaxation η.
        eta: f64,
    },
    /// Rule Q (default): L-BFGS with initial inverse Hessian γP⁻¹, Armijo backtracking.
    Lbfgs {
        /// Number of stored pairs (default 10).
        memory: usize,
    },
}

impl Default for UpdateRule {
    fn default() -> Self {
        Self::Lbfgs { memory: 10 }
    }
}

impl UpdateRule {
    /// Rule R with the default step 0.005 and stretch clamp 0.1.
    pub fn paper() -> Self {
        Self::Paper {
            eta: 0.005,
            min_stretch: 0.1,
        }
    }
}

/// Settings of the solver (spec §3.1–§3.2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverConfig {
    /// Planar (default) or full strains.
    pub space: StrainSpace,
    /// Diameter of the design stiffness floor φ_floor [m] (default 4 mm; 0 = paper-literal).
    pub floor_diameter: f64,
    /// Update rule (default L-BFGS, memory 10).
    pub rule: UpdateRule,
    /// Stop when the strain residual ε_res ≤ this (default 1e-8).
    pub tolerance: f64,
    /// Iterations over which the relative decrease of J is measured (default 20).
    pub stall_window: usize,
    /// Stop when J fell by less than this relative amount over the window (default 1e-12).
    pub stall_tolerance: f64,
    /// Stop, not converged, after this many sweeps (default 20 000).
    pub max_sweeps: usize,
}

impl Default for SolverConfig {
    fn default() -> Self {
        Self {
            space: StrainSpace::Planar,
            floor_diameter: 4.0e-3,
            rule: UpdateRule::default(),
            tolerance: 1e-8,
            stall_window: 20,
            stall_tolerance: 1e-12,
            max_sweeps: 20_000,
        }
    }
}

impl SolverConfig {
    fn validate(&self) -> Result<(), SolveError> {
        let bad = |field: &'static str, value: f64, range: &'static str| {
            Err(SolveError::Config {
                field,
                value,
                range,
            })
        };
        match self.rule {
            UpdateRule::Paper { eta, min_stretch } => {
                if !(eta.is_finite() && eta > 0.0) {
                    return bad("rule.eta", eta, "(0, inf)");
                }
                if !(min_stretch.is_finite() && min_stretch > 0.0) {
                    return bad("rule.min_stretch", min_stretch, "(0, inf)");
                }
            }
            UpdateRule::Preconditioned { eta } => {
                if !(eta.is_finite() && eta > 0.0) {
                    return bad("rule.eta", eta, "(0, inf)");
                }
            }
            UpdateRule::Lbfgs { memory } => {
                if memory == 0 {
                    return bad("rule.memory", 0.0, "[1, inf)");
                }
            }
        }
        if !(self.tolerance.is_finite() && self.tolerance >= 0.0) {
            return bad("tolerance", self.tolerance, "[0, inf)");
        }
        if !(self.stall_tolerance.is_finite() && self.stall_tolerance >= 0.0) {
            return bad("stall_tolerance", self.stall_tolerance, "[0, inf)");
        }
        if self.stall_window == 0 {
            return bad("stall_window", 0.0, "[1, inf)");
        }
        Ok(())
    }
}

/// Why an offline solve stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopReason {
    /// Strain residual below the tolerance (rule a).
    Residual,
    /// Relative decrease of J over the window below the stall tolerance (rule b).
    Stalled,
    /// Sweep budget exhausted (rule c).
    MaxSweeps,
}

/// Outcome of an offline solve.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Stopped by rule (a) or (b).
    Converged,
    /// Stopped by the sweep budget; the last iterate is usable but flagged.
    NotConverged,
}

/// Detected conditions that do not stop the solve (spec §3.4).
#[derive(Debug, Clone, PartialEq)]
pub enum Warning {
    /// Tip error above 0.05 L0 or a stretch above 1.5 at the end.
    Unreachable {
        /// Final tip error [m].
        tip_error: f64,
        /// Largest stretch ν3.
        max_stretch: f64,
    },
    /// The design must not be handed to the controller (spec §2.7); the message names where.
    DegenerateDesign(String),
    /// The starting shape is inside an obstacle (the penalty pushes it out).
    InitialPenetration {
        /// Obstacle index.
        obstacle: usize,
        /// Deepest node.
        node: usize,
        /// Depth [m].
        depth: f64,
    },
}

/// What an offline solve did (spec §3.2).
#[derive(Debug, Clone, PartialEq)]
pub struct SolveReport {
    /// Converged or not.
    pub outcome: Outcome,
    /// Which stopping rule fired.
    pub stop: StopReason,
    /// Iterations (strain updates attempted).
    pub iterations: usize,
    /// Sweeps (cost + gradient evaluations, including line-search trials).
    pub sweeps: usize,
    /// Final cost and its terms [J].
    pub cost: CostTerms,
    /// ξ_j q̂_j per obstacle [J].
    pub obstacle_costs: Vec<f64>,
    /// |r_N − r*| [m] (0 without a target).
    pub tip_error: f64,
    /// Final strain residual ε_res.
    pub residual: f64,
    /// Largest penetration of an obstacle by the arm's surface [m].
    pub max_penetration: f64,
    /// Steps rejected by the divergence guard or the line search.
    pub rejected_steps: usize,
    /// Wall time of the solve.
    pub wall_time: Duration,
    /// Detected conditions.
    pub warnings: Vec<Warning>,
}

impl SolveReport {
    /// True if the design may be handed to the energy-shaping controller.
    pub fn is_admissible(&self) -> bool {
        !self
            .warnings
            .iter()
            .any(|w| matches!(w, Warning::DegenerateDesign(_)))
    }
}

/// A solved design and its report.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// The design strains w̄.
    pub strains: StrainField,
    /// The report.
    pub report: SolveReport,
}

const MAX_FAILURES: usize = 30;
const ARMIJO_C1: f64 = 1e-4;
const MAX_HALVINGS: usize = 40;
/// Rules R/P reject a step that raises J by more than this relative amount (spec §3.4).
const RISE_TOLERANCE: f64 = 1e-3;

/// The iteration machinery shared by the offline and online solvers: the current iterate, its
/// cost and gradient, the L-BFGS memory and all scratch vectors (no allocation per iteration).
#[derive(Debug, Clone)]
struct Engine {
    statics: Statics,
    rule: UpdateRule,
    w: StrainField,
    grad: Vec<f64>,
    cost: CostTerms,
    trial: StrainField,
    trial_grad: Vec<f64>,
    dir: Vec<f64>,
    inv_p: Vec<f64>,
    inv_d: Vec<f64>,
    s_mem: Vec<Vec<f64>>,
    y_mem: Vec<Vec<f64>>,
    rho: Vec<f64>,
    alpha: Vec<f64>,
    mem_len: usize,
    mem_head: usize,
    gamma: f64,
    sweeps: usize,
    iterations: usize,
    failures: usize,
    rejected: usize,
}

fn dotv(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl Engine {
    fn new(statics: Statics, rule: UpdateRule) -> Self {
        let n = statics.n_elements();
        let len = 6 * n - 3;
        let inv_p: Vec<f64> = statics.preconditioner().iter().map(|p| 1.0 / p).collect();
        let mut inv_d = vec![0.0; len];
        for (j, l) in statics.rest_length().iter().enumerate() {
            inv_d[3 * j..3 * j + 3].fill(1.0 / l);
        }
        for (k, d) in statics.voronoi_length().iter().enumerate() {
            inv_d[3 * n + 3 * k..3 * n + 3 * k + 3].fill(1.0 / d);
        }
        let memory = match rule {
            UpdateRule::Lbfgs { memory } => memory,
            _ => 0,
        };
        let w0 = statics.rest().clone();
        Self {
            rule,
            trial: w0.clone(),
            w: w0,
            grad: vec![0.0; len],
            cost: CostTerms::default(),
            trial_grad: vec![0.0; len],
            dir: vec![0.0; len],
            inv_p,
            inv_d,
            s_mem: vec![vec![0.0; len]; memory],
            y_mem: vec![vec![0.0; len]; memory],
            rho: vec![0.0; memory],
            alpha: vec![0.0; memory],
            mem_len: 0,
            mem_head: 0,
            gamma: 1e-6,
            sweeps: 0,
            iterations: 0,
            failures: 0,
            rejected: 0,
            statics,
        }
    }

    fn evaluate(&mut self, task: &Task) {
        self.cost = self.statics.sweep(&self.w, task, &mut self.grad);
        self.sweeps += 1;
    }

    fn drop_memory(&mut self) {
        self.mem_len = 0;
        self.mem_head = 0;
    }

    fn is_good(cost: &CostTerms, grad: &[f64]) -> bool {
        cost.total.is_finite() && grad.iter().all(|g| g.is_finite())
    }

    fn diverged(&self) -> SolveError {
        let hint = match self.rule {
            UpdateRule::Lbfgs { .. } => "check the task (weights, targets) or reduce mu_tip",
            _ => "reduce eta or mu_tip",
        };
        SolveError::Diverged {
            iteration: self.iterations,
            last_cost: self.cost.total,
            hint,
        }
    }

    /// One iteration of the configured rule. Errors after 30 consecutive failures.
    fn iterate(&mut self, task: &Task) -> Result<(), SolveError> {
        self.iterations += 1;
        let ok = match self.rule {
            UpdateRule::Lbfgs { .. } => self.iterate_lbfgs(task),
            UpdateRule::Paper { eta, min_stretch } => {
                self.iterate_fixed(task, eta, Some(min_stretch))
            }
            UpdateRule::Preconditioned { eta } => self.iterate_fixed(task, eta, None),
        };
        if ok {
            self.failures = 0;
        } else {
            self.failures += 1;
            if self.failures >= MAX_FAILURES {
                return Err(self.diverged());
            }
        }
        Ok(())
    }

    fn is_lbfgs(&self) -> bool {
        matches!(self.rule, UpdateRule::Lbfgs { .. })
    }

    /// Account for `times` more iterations that each fail exactly as the last one did, with
    /// `trials` rejected line-search trials each, without evaluating them: the counters and the
    /// divergence limit end as if they had run. Only for a failure that left the state as it
    /// was (L-BFGS from an empty memory).
    fn repeat_failure(&mut self, times: usize, trials: usize) -> Result<(), SolveError> {
        for _ in 0..times {
            self.iterations += 1;
            self.rejected += trials;
            self.failures += 1;
            if self.failures >= MAX_FAILURES {
                return Err(self.diverged());
            }
        }
        Ok(())
    }

    /// Rules R and P: a fixed step. A step that makes J non-finite or raises it by more than 1e-3
    /// relative is rejected and retried with half the step (up to 30 halvings). The iteration
    /// counts as failed when the configured step itself was rejected, so a learning rate that
    /// diverges is reported after 30 iterations even though halved steps keep the iterate good.
    fn iterate_fixed(&mut self, task: &Task, eta: f64, min_stretch: Option<f64>) -> bool {
        let n = self.statics.n_elements();
        let scale = if min_stretch.is_some() {
            &self.inv_d
        } else {
            &self.inv_p
        };
        let mut step = eta;
        for attempt in 0..MAX_FAILURES {
            {
                let t = self.trial.as_mut_slice();
                let w = self.w.as_slice();
                for c in 0..t.len() {
                    t[c] = w[c] - step * scale[c] * self.grad[c];
                }
                if let Some(lo) = min_stretch {
                    for j in 0..n {
                        if t[3 * j + 2] < lo {
                            t[3 * j + 2] = lo;
                        }
                    }
                }
            }
            let c = self.statics.sweep(&self.trial, task, &mut self.trial_grad);
            self.sweeps += 1;
            if Self::is_good(&c, &self.trial_grad)
                && c.total <= self.cost.total + RISE_TOLERANCE * self.cost.total.abs()
            {
                std::mem::swap(&mut self.w, &mut self.trial);
                std::mem::swap(&mut self.grad, &mut self.trial_grad);
                self.cost = c;
                return attempt == 0;
            }
            self.rejected += 1;
            step *= 0.5;
        }
        false
    }

    /// Two-loop recursion: dir = −H∇J with H₀ = γP⁻¹.
    fn lbfgs_direction(&mut self) {
        let m = self.s_mem.len();
        self.dir.copy_from_slice(&self.grad);
        for i in 0..self.mem_len {
            let idx = (self.mem_head + m - 1 - i) % m;
            let a = self.rho[idx] * dotv(&self.s_mem[idx], &self.dir);
            self.alpha[idx] = a;
            for (d, y) in self.dir.iter_mut().zip(&self.y_mem[idx]) {
                *d -= a * y;
            }
        }
        for (d, p) in self.dir.iter_mut().zip(&self.inv_p) {
            *d *= self.gamma * p;
        }
        for i in (0..self.mem_len).rev() {
            let idx = (self.mem_head + m - 1 - i) % m;
            let b = self.rho[idx] * dotv(&self.y_mem[idx], &self.dir);
            let a = self.alpha[idx];
            for (d, s) in self.dir.iter_mut().zip(&self.s_mem[idx]) {
                *d += (a - b) * s;
            }
        }
        for d in self.dir.iter_mut() {
            *d = -*d;
        }
        self.statics.mask(&mut self.dir);
    }

    fn iterate_lbfgs(&mut self, task: &Task) -> bool {
        self.lbfgs_direction();
        let mut gd = dotv(&self.grad, &self.dir);
        if !(gd < 0.0 && gd.is_finite()) {
            // Not a descent direction: forget the memory and take a preconditioned (rule P) step.
            self.drop_memory();
            for ((d, g), p) in self.dir.iter_mut().zip(&self.grad).zip(&self.inv_p) {
                *d = -p * g;
            }
            gd = dotv(&self.grad, &self.dir);
            if !(gd < 0.0 && gd.is_finite()) {
                return false;
            }
        }
        let mut alpha = 1.0;
        for _ in 0..=MAX_HALVINGS {
            {
                let t = self.trial.as_mut_slice();
                let w = self.w.as_slice();
                for c in 0..t.len() {
                    t[c] = w[c] + alpha * self.dir[c];
                }
            }
            let c = self.statics.sweep(&self.trial, task, &mut self.trial_grad);
            self.sweeps += 1;
            if Self::is_good(&c, &self.trial_grad)
                && c.total <= self.cost.total + ARMIJO_C1 * alpha * gd
            {
                // New pair s = Δw, y = Δ∇J (reuse the direction buffer for s).
                let m = self.s_mem.len();
                let idx = self.mem_head;
                let (mut sy, mut ss, mut yy, mut ypy) = (0.0, 0.0, 0.0, 0.0);
                {
                    let t = self.trial.as_slice();
                    let w = self.w.as_slice();
                    let s = &mut self.s_mem[idx];
                    let y = &mut self.y_mem[idx];
                    for c in 0..t.len() {
                        s[c] = t[c] - w[c];
                        y[c] = self.trial_grad[c] - self.grad[c];
                        sy += s[c] * y[c];
                        ss += s[c] * s[c];
                        yy += y[c] * y[c];
                        ypy += y[c] * y[c] * self.inv_p[c];
                    }
                }
                if sy > 1e-16 * (ss * yy).sqrt() && ypy > 0.0 {
                    self.rho[idx] = 1.0 / sy;
                    self.mem_head = (self.mem_head + 1) % m;
                    self.mem_len = (self.mem_len + 1).min(m);
                    self.gamma = sy / ypy;
                }
                std::mem::swap(&mut self.w, &mut self.trial);
                std::mem::swap(&mut self.grad, &mut self.trial_grad);
                self.cost = c;
                return true;
            }
            self.rejected += 1;
            alpha *= 0.5;
        }
        self.drop_memory();
        false
    }
}

fn check_initial(statics: &Statics, w: &StrainField) -> Result<(), SolveError> {
    if w.n_elements() != statics.n_elements() {
        return Err(SolveError::BadInitial {
            reason: format!(
                "{} elements, the arm has {}",
                w.n_elements(),
                statics.n_elements()
            ),
        });
    }
    if !w.is_finite() {
        return Err(SolveError::BadInitial {
            reason: "non-finite entry".into(),
        });
    }
    Ok(())
}

/// Offline solver (spec §3.2): iterate from a start to the stopping rule, then report.
#[derive(Debug, Clone)]
pub struct OfflineSolver {
    engine: Engine,
    config: SolverConfig,
}

impl OfflineSolver {
    /// A solver for the arm `model` clamped as in `state` (node 0, element 0).
    pub fn new(
        model: &RodModel,
        state: &RodState,
        config: SolverConfig,
    ) -> Result<Self, SolveError> {
        config.validate()?;
        let statics = Statics::new(model, state, config.space, config.floor_diameter)
            .map_err(statics_error)?;
        Ok(Self {
            engine: Engine::new(statics, config.rule),
            config,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &SolverConfig {
        &self.config
    }

    /// The statics (last forward map, costates, design stiffnesses) of the last evaluation.
    pub fn statics(&self) -> &Statics {
        &self.engine.statics
    }

    /// Mutable statics, e.g. to evaluate the forward map of another field.
    pub fn statics_mut(&mut self) -> &mut Statics {
        &mut self.engine.statics
    }

    /// The current iterate (after a `Diverged` error: the last good strains).
    pub fn current(&self) -> &StrainField {
        &self.engine.w
    }

    /// Solve `task` from `initial` (default: the intrinsic strains, i.e. the straight arm).
    /// Errors on a bad task or start and on divergence; every other outcome is in the report.
    pub fn solve(
        &mut self,
        task: &Task,
        initial: Option<&StrainField>,
    ) -> Result<Solution, SolveError> {
        let start = Instant::now();
        task.validate(&self.engine.statics)?;
        let e = &mut self.engine;
        match initial {
            Some(w) => {
                check_initial(&e.statics, w)?;
                e.w.as_mut_slice().copy_from_slice(w.as_slice());
            }
            None => {
                let rest = e.statics.rest().clone();
                e.w.as_mut_slice().copy_from_slice(rest.as_slice());
            }
        }
        e.drop_memory();
        e.gamma = 1e-6;
        e.sweeps = 0;
        e.iterations = 0;
        e.failures = 0;
        e.rejected = 0;
        e.evaluate(task);
        let mut warnings = Vec::new();
        let (depth, obstacle, node) = e.statics.max_penetration(task);
        if depth > 0.0 {
            warnings.push(Warning::InitialPenetration {
                obstacle,
                node,
                depth,
            });
        }
        if !Engine::is_good(&e.cost, &e.grad) {
            return Err(e.diverged());
        }
        let window = self.config.stall_window;
        let mut history = vec![0.0; window + 1];
        history[0] = e.cost.total;
        let stop = loop {
            if e.statics.residual(&e.grad) <= self.config.tolerance {
                break StopReason::Residual;
            }
            if e.sweeps >= self.config.max_sweeps {
                break StopReason::MaxSweeps;
            }
            if e.iterations >= window {
                let old = history[(e.iterations - window) % (window + 1)];
                let now = e.cost.total;
                if (old - now) <= self.config.stall_tolerance * now.abs().max(f64::MIN_POSITIVE) {
                    break StopReason::Stalled;
                }
            }
            e.iterate(task)?;
            history[e.iterations % (window + 1)] = e.cost.total;
        };
        // Leave the statics at the final iterate (line-search trials may have overwritten it).
        e.evaluate(task);
        let outcome = if stop == StopReason::MaxSweeps {
            Outcome::NotConverged
        } else {
            Outcome::Converged
        };
        let st = &e.statics;
        let tip_error = st.tip_error(task);
        let max_stretch = (0..st.n_elements())
            .map(|j| e.w.nu(j)[2])
            .fold(f64::MIN, f64::max);
        let length = st.length();
        if task.target().is_some() && (tip_error > 0.05 * length || max_stretch > 1.5) {
            warnings.push(Warning::Unreachable {
                tip_error,
                max_stretch,
            });
        }
        if let Err(err) = e.w.check_admissible(st.voronoi_length()) {
            warnings.push(Warning::DegenerateDesign(err.to_string()));
        }
        let report = SolveReport {
            outcome,
            stop,
            iterations: e.iterations,
            sweeps: e.sweeps,
            cost: e.cost,
            obstacle_costs: st.obstacle_costs(task),
            tip_error,
            residual: st.residual(&e.grad),
            max_penetration: st.max_penetration(task).0,
            rejected_steps: e.rejected,
            wall_time: start.elapsed(),
            warnings,
        };
        Ok(Solution {
            strains: e.w.clone(),
            report,
        })
    }

    /// Grasp continuation (spec §3.2): solve with μ_grasp scaled by 1e-3, 1e-2, 1e-1, 1, each
    /// stage warm-started from the last. Returns the last stage's solution with the sweeps and
    /// iterations of all stages summed.
    pub fn solve_with_continuation(
        &mut self,
        task: &Task,
        initial: Option<&StrainField>,
    ) -> Result<Solution, SolveError> {
        let Some(grasp) = &task.grasp else {
            return self.solve(task, initial);
        };
        let mut w = initial.cloned();
        let (mut sweeps, mut iterations) = (0, 0);
        let mut last = None;
        for factor in [1e-3, 1e-2, 1e-1, 1.0] {
            let mut staged = task.clone();
            let mut g = grasp.clone();
            g.weight = match &grasp.weight {
                GraspWeight::Interval { weight, from, to } => GraspWeight::Interval {
                    weight: weight * factor,
                    from: *from,
                    to: *to,
                },
                GraspWeight::PerNode(v) => {
                    GraspWeight::PerNode(v.iter().map(|x| x * factor).collect())
                }
            };
            staged.grasp = Some(g);
            let sol = self.solve(&staged, w.as_ref())?;
            sweeps += sol.report.sweeps;
            iterations += sol.report.iterations;
            w = Some(sol.strains.clone());
            last = Some(sol);
        }
        let mut sol = last.expect("four stages ran");
        sol.report.sweeps = sweeps;
        sol.report.iterations = iterations;
        Ok(sol)
    }
}

fn statics_error(e: StaticsError) -> SolveError {
    match e {
        StaticsError::OutOfRange {
            field,
            value,
            range,
        } => SolveError::Config {
            field,
            value,
            range,
        },
        other => SolveError::BadInitial {
            reason: other.to_string(),
        },
    }
}

/// Settings of the online solver (spec §3.3).
#[derive(Debug, Clone, PartialEq)]
pub struct OnlineConfig {
    /// Iterations per control update (default 10; 1 with rule R or P is the paper-literal mode).
    pub iterations_per_update: usize,
    /// Optional per-update cap on |Δw̄| per component (flat like a `StrainField`).
    pub trust_region: Option<StrainField>,
}

impl Default for OnlineConfig {
    fn default() -> Self {
        Self {
            iterations_per_update: 10,
            trust_region: None,
        }
    }
}

impl OnlineConfig {
    /// The trust region of spec §5.4: per component |w_final − w°| · `update_period` / `form_time`,
    /// so that the design needs about `form_time` to form.
    pub fn trust_region_from(
        final_design: &StrainField,
        rest: &StrainField,
        update_period: f64,
        form_time: f64,
    ) -> StrainField {
        let mut cap = final_design.clone();
        for (c, (f, r)) in cap
            .as_mut_slice()
            .iter_mut()
            .zip(final_design.as_slice().iter().zip(rest.as_slice()))
        {
            *c = (f - r).abs() * update_period / form_time;
        }
        cap
    }
}

/// What one online update did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OnlineReport {
    /// Sweeps used by this update.
    pub sweeps: usize,
    /// Cost of the design in force after the update [J].
    pub cost: CostTerms,
    /// Tip error of the design in force [m].
    pub tip_error: f64,
    /// Strain residual of the design in force.
    pub residual: f64,
    /// False if the update failed and the previous design was kept.
    pub accepted: bool,
    /// True if the trust region limited some component.
    pub limited: bool,
}

/// Online solver (spec §3.3): warm-started iterations per control update; the L-BFGS memory is
/// kept across updates (dropped when the task's structure changes), the design in force is
/// always finite.
#[derive(Debug, Clone)]
pub struct OnlineSolver {
    engine: Engine,
    config: OnlineConfig,
    design: StrainField,
    structure: Option<(u8, usize, bool)>,
    reported_failure: bool,
    /// Count repeated failed iterations instead of running them (always, but for the test that
    /// compares the two).
    skip_repeats: bool,
}

impl OnlineSolver {
    /// An online solver for `model` clamped as in `state`, starting from the intrinsic strains
    /// (or `initial`). `solver.max_sweeps` and the stopping tolerances are not used online.
    pub fn new(
        model: &RodModel,
        state: &RodState,
        solver: SolverConfig,
        config: OnlineConfig,
        initial: Option<&StrainField>,
    ) -> Result<Self, SolveError> {
        solver.validate()?;
        if config.iterations_per_update == 0 {
            return Err(SolveError::Config {
                field: "iterations_per_update",
                value: 0.0,
                range: "[1, inf)",
            });
        }
        let statics = Statics::new(model, state, solver.space, solver.floor_diameter)
            .map_err(statics_error)?;
        let mut engine = Engine::new(statics, solver.rule);
        if let Some(w) = initial {
            check_initial(&engine.statics, w)?;
            engine.w = w.clone();
        }
        if let Some(tr) = &config.trust_region {
            check_initial(&engine.statics, tr)?;
        }
        let design = engine.w.clone();
        Ok(Self {
            engine,
            config,
            design,
            structure: None,
            reported_failure: false,
            skip_repeats: true,
        })
    }

    /// The design in force w̄ (finite, last good).
    pub fn design(&self) -> &StrainField {
        &self.design
    }

    /// The statics of the last evaluation.
    pub fn statics(&self) -> &Statics {
        &self.engine.statics
    }

    /// Total sweeps so far.
    pub fn sweeps(&self) -> usize {
        self.engine.sweeps
    }

    /// One control update for the task as it is now (target and obstacles sampled by the caller).
    /// On failure the previous design stays in force; the first failure in a row is returned as
    /// an error, later ones as a report with `accepted = false`.
    pub fn update(&mut self, task: &Task) -> Result<OnlineReport, SolveError> {
        task.validate(&self.engine.statics)?;
        let e = &mut self.engine;
        let key = task.structure();
        if self.structure != Some(key) {
            e.drop_memory();
            self.structure = Some(key);
        }
        let sweeps0 = e.sweeps;
        // The task changed since the last update: re-evaluate J and ∇J at the design in force.
        e.w.as_mut_slice().copy_from_slice(self.design.as_slice());
        e.evaluate(task);
        let mut result = Ok(());
        if Engine::is_good(&e.cost, &e.grad) {
            let iterations = self.config.iterations_per_update;
            let mut done = 0;
            while done < iterations && result.is_ok() {
                let fresh = e.mem_len == 0;
                let rejected = e.rejected;
                result = e.iterate(task);
                done += 1;
                // A failed L-BFGS iteration leaves the iterate, its gradient and γ as they were
                // and the memory empty. If the memory was empty before it too, each further
                // iteration of this update would repeat it bit for bit (same direction, same
                // rejected trials): count them (iterations, consecutive failures and their
                // limit, rejected trials) without sweeping. Near a converged design every line
                // search fails at round-off, and these repeats were most of the online cost.
                if self.skip_repeats && result.is_ok() && fresh && e.failures > 0 && e.is_lbfgs() {
                    let trials = e.rejected - rejected;
                    result = e.repeat_failure(iterations - done, trials);
                    done = iterations;
                }
            }
        } else {
            result = Err(e.diverged());
        }
        let mut limited = false;
        if result.is_ok() {
            if let Some(cap) = &self.config.trust_region {
                let (w, d) = (e.w.as_mut_slice(), self.design.as_slice());
                for c in 0..w.len() {
                    let lim = cap.as_slice()[c];
                    let dv = w[c] - d[c];
                    if dv.abs() > lim {
                        w[c] = d[c] + lim.copysign(dv);
                        limited = true;
                    }
                }
            }
            if !e.w.is_finite() {
                result = Err(e.diverged());
            }
        }
        match result {
            Ok(()) => {
                self.design.as_mut_slice().copy_from_slice(e.w.as_slice());
                self.reported_failure = false;
            }
            Err(err) => {
                e.w.as_mut_slice().copy_from_slice(self.design.as_slice());
                e.drop_memory();
                e.failures = 0;
                if !self.reported_failure {
                    self.reported_failure = true;
                    return Err(err);
                }
            }
        }
        // Report on the design in force (the last accepted trial is the last sweep unless the
        // trust region moved it or the update failed).
        if limited || self.reported_failure {
            e.evaluate(task);
        }
        let accepted = !self.reported_failure;
        Ok(OnlineReport {
            sweeps: e.sweeps - sweeps0,
            cost: e.cost,
            tip_error: e.statics.tip_error(task),
            residual: e.statics.residual(&e.grad),
            accepted,
            limited,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use octoarm_physics::StraightRod;

    /// Skipping the repeats of a failed iteration from an empty memory is exact: over updates
    /// that track a target, converge and then stall at round-off (where every line search
    /// fails), the designs, reports and counters equal those of running every iteration, bit
    /// for bit, with fewer sweeps. Checked for the divergence limit too (failures accumulate
    /// across stalled updates until `MAX_FAILURES` turns one into an error).
    #[test]
    fn skipping_repeated_failures_changes_nothing_but_the_sweeps() {
        let (model, state) = StraightRod::paper_arm().build().unwrap();
        let make = |skip: bool| {
            let mut s = OnlineSolver::new(
                &model,
                &state,
                SolverConfig::default(),
                OnlineConfig::default(),
                None,
            )
            .unwrap();
            s.skip_repeats = skip;
            s
        };
        let (mut fast, mut slow) = (make(true), make(false));
        let mut task = Task::reach([0.12, 0.09, 0.0], 1e3);
        let (mut failed, mut errors) = (0, 0);
        for u in 0..600 {
            // Moves for 0.2 s, then stays: the design converges and stalls.
            let t = (u.min(200) as f64) * 1e-3;
            task.set_target([0.12 - 0.05 * t, 0.09, 0.0]);
            let (a, b) = (fast.update(&task), slow.update(&task));
            match (&a, &b) {
                (Ok(ra), Ok(rb)) => {
                    assert_eq!(ra.cost, rb.cost, "update {u}");
                    assert_eq!(ra.tip_error.to_bits(), rb.tip_error.to_bits(), "update {u}");
                    assert_eq!(ra.residual.to_bits(), rb.residual.to_bits(), "update {u}");
                    assert_eq!(ra.accepted, rb.accepted, "update {u}");
                    assert!(ra.sweeps <= rb.sweeps, "update {u}");
                    failed += usize::from(!ra.accepted);
                }
                (Err(ea), Err(eb)) => {
                    assert_eq!(ea.to_string(), eb.to_string(), "update {u}");
                    errors += 1;
                }
                _ => panic!("update {u}: {a:?} vs {b:?}"),
            }
            assert_eq!(
                fast.design().as_slice(),
                slow.design().as_slice(),
                "update {u}"
            );
            let (x, y) = (&fast.engine, &slow.engine);
            assert_eq!(
                (x.iterations, x.failures, x.rejected, x.mem_len),
                (y.iterations, y.failures, y.rejected, y.mem_len),
                "update {u}"
            );
        }
        let (sf, ss) = (fast.sweeps(), slow.sweeps());
        println!(
            "{sf} against {ss} sweeps; {} rejected trials, {failed} failed updates, {errors} errors",
            fast.engine.rejected
        );
        // The case must reach the stalled regime, or it tests nothing.
        assert!(fast.engine.rejected > 1000, "{}", fast.engine.rejected);
        assert!(sf * 2 < ss, "{sf} vs {ss}");
    }
}
