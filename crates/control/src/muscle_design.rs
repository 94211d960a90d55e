//! The SE(3) design over activations (muscles-3d spec §5) for reaching: minimise
//! J(a) = ½ Σ_g Σ_j l̂_j a²_{g,j} + Φ(x(a), Q(a)) over a ∈ [0, 1]^{7×n}, with the tip-point cost
//! Φ_p = ½ μ_p |p − p*|² (p the last element's midpoint) and the tip-orientation cost
//! Φ_Q = μ_Q Σ_m ω_m (1 − d_m · d*_m), subject to the exact discrete equilibrium (4.1) of
//! `MuscleStatics`. The gradient is the exact discrete adjoint: the costate sweep of the forward
//! map (5.3–5.4), one transposed solve with the factored equilibrium Jacobian, and the
//! unit-activation group resultants (5.5). The optimiser is projected L-BFGS on b = √l̂ a (5.6),
//! with group masks (groups held at zero). Grasp costs: `GraspTask` (attraction, obstacle,
//! sucker side) behind the `DesignTask` trait. COOMM's relaxation with its approximate gradient
//! (5.5), for cross-checks only: `MuscleDesign::relax_coomm`.

use crate::muscle_statics::{MuscleStatics, MuscleStaticsError};
use octoarm_physics::math::{cross, dot, log_relative, mat_vec, norm, Mat3};
use octoarm_physics::muscles::{Resultants, Strains};
use octoarm_physics::{RodModel, RodState, Vec3, N_GROUPS};
use std::time::Instant;

/// A reach task: tip point and, optionally, tip frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReachTask {
    /// Target tip point p* [m].
    pub target: Vec3,
    /// Tip-point weight μ_p [N/m] (COOMM: 1e6).
    pub position_weight: f64,
    /// Target frame Q* (rows d*_1, d*_2, d*_3, orthonormal) and per-director weights ω; None for
    /// a point-only task.
    pub frame: Option<(Mat3, Vec3)>,
    /// Orientation weight μ_Q [N m] (COOMM: 1e3).
    pub orientation_weight: f64,
}

impl ReachTask {
    /// COOMM's reach task (spec §7 A): target `p`, frame from the base direction b = unit(p)
    /// and d*_3 = unit(p − tip0) (tip0 the straight arm's tip), d*_2 = unit(b × d*_3),
    /// d*_1 = d*_2 × d*_3, weights ω = (sin θ, sin θ, sin² θ) with θ = ∠(b, d*_3) — the
    /// orthonormal equivalent of COOMM's unnormalised target matrix. μ_p = 1e6, μ_Q = 1e3.
    pub fn coomm(p: Vec3, base: Vec3, tip0: Vec3) -> Self {
        let unit = |v: Vec3| {
            let l = norm(v);
            [v[0] / l, v[1] / l, v[2] / l]
        };
        let b = unit([p[0] - base[0], p[1] - base[1], p[2] - base[2]]);
        let d3 = unit([p[0] - tip0[0], p[1] - tip0[1], p[2] - tip0[2]]);
        let d2 = unit(cross(b, d3));
        let d1 = cross(d2, d3);
        let s = norm(cross(b, d3));
        Self {
            target: p,
            position_weight: 1e6,
            frame: Some(([d1, d2, d3], [s, s, s * s])),
            orientation_weight: 1e3,
        }
    }

    /// The same task with the target frame rolled by +90° about d*_3: rows (d*_2, −d*_1, d*_3)
    /// (spec §7 B).
    pub fn rolled(mut self) -> Self {
        if let Some((q, w)) = self.frame {
            self.frame = Some(([q[1], [-q[0][0], -q[0][1], -q[0][2]], q[2]], w));
        }
        self
    }
}

/// A task cost Φ(x, Q) of the design (spec §5.1) and its loads (5.2).
pub trait DesignTask {
    /// Add Φ and its parts (and task errors) at `pose` to `costs` (`total` is Φ); with `loads`
    /// = (g, c), add the node loads g_i = ∂Φ/∂x_i (n + 1) and the element lab couples c_j (n),
    /// δΦ = Σ c_j · δθ_j for lab rotations of the directors.
    fn cost(
        &self,
        model: &RodModel,
        pose: &RodState,
        costs: &mut DesignCosts,
        loads: Option<(&mut [Vec3], &mut [Vec3])>,
    );
}

impl DesignTask for ReachTask {
    fn cost(
        &self,
        _model: &RodModel,
        pose: &RodState,
        costs: &mut DesignCosts,
        loads: Option<(&mut [Vec3], &mut [Vec3])>,
    ) {
        let x = &pose.position;
        let q = &pose.director;
        let n = q.len();
        let p = [
            0.5 * (x[n - 1][0] + x[n][0]),
            0.5 * (x[n - 1][1] + x[n][1]),
            0.5 * (x[n - 1][2] + x[n][2]),
        ];
        let d = [
            p[0] - self.target[0],
            p[1] - self.target[1],
            p[2] - self.target[2],
        ];
        let mp = self.position_weight;
        costs.position = 0.5 * mp * dot(d, d);
        costs.tip_error = norm(d);
        let mut tip_couple = [0.0; 3];
        if let Some((qs, om)) = self.frame {
            let mq = self.orientation_weight;
            for m in 0..3 {
                costs.orientation += mq * om[m] * (1.0 - dot(q[n - 1][m], qs[m]));
                let c = cross(q[n - 1][m], qs[m]);
                for k in 0..3 {
                    tip_couple[k] -= mq * om[m] * c[k];
                }
            }
            costs.orientation_error = log_relative(&q[n - 1], &qs).1;
        }
        costs.total += costs.position + costs.orientation;
        if let Some((g, c)) = loads {
            // The tip point gives ½ μ_p (p − p*) to nodes n − 1 and n.
            for i in [n - 1, n] {
                for k in 0..3 {
                    g[i][k] += 0.5 * mp * d[k];
                }
            }
            for k in 0..3 {
                c[n - 1][k] += tip_couple[k];
            }
        }
    }
}

/// COOMM's grasp of a cylinder with the distal arm (spec §5.1): attraction onto the sphere of
/// radius R + r̂_j about the centre c, the capped-cylinder obstacle, and the sucker side (d1
/// towards c), weighted by w_j = ½(1 + tanh(100 (s_j − 0.3))), s_j = j/(n − 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GraspTask {
    /// Cylinder centre c [m].
    pub center: Vec3,
    /// Unit axis.
    pub axis: Vec3,
    /// Radius R [m].
    pub radius: f64,
    /// Length L_c [m].
    pub length: f64,
    /// μ_g [N/m²] (COOMM: 1e6).
    pub attraction_weight: f64,
    /// μ_o [N/m²] (1e7).
    pub obstacle_weight: f64,
    /// μ_s [N] (1e3).
    pub sucker_weight: f64,
}

impl GraspTask {
    /// COOMM's weights for a cylinder (centre, unit axis, radius, length).
    pub fn coomm(center: Vec3, axis: Vec3, radius: f64, length: f64) -> Self {
        Self {
            center,
            axis,
            radius,
            length,
            attraction_weight: 1e6,
            obstacle_weight: 1e7,
            sucker_weight: 1e3,
        }
    }

    /// The same task with every weight multiplied by `f` (a continuation stage).
    pub fn scaled(mut self, f: f64) -> Self {
        self.attraction_weight *= f;
        self.obstacle_weight *= f;
        self.sucker_weight *= f;
        self
    }

    /// The distal weight w_j of element j of n.
    pub fn weight(j: usize, n: usize) -> f64 {
        let s = j as f64 / (n - 1) as f64;
        0.5 * (1.0 + (100.0 * (s - 0.3)).tanh())
    }
}

impl DesignTask for GraspTask {
    fn cost(
        &self,
        model: &RodModel,
        pose: &RodState,
        costs: &mut DesignCosts,
        mut loads: Option<(&mut [Vec3], &mut [Vec3])>,
    ) {
        let x = &pose.position;
        let q = &pose.director;
        let n = q.len();
        let (c, a, rr) = (self.center, self.axis, self.radius);
        for j in 0..n {
            let l = model.rest_length[j];
            let w = Self::weight(j, n);
            let p: Vec3 = std::array::from_fn(|k| 0.5 * (x[j][k] + x[j + 1][k]));
            let r_surf = rr + model.radius[j];
            let dp = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
            let dist = norm(dp);
            let mut gp = [0.0; 3];
            // Attraction onto the sphere |p − c| = R + r̂_j.
            let gap = dist - r_surf;
            if gap > 0.0 {
                costs.attraction += 0.5 * l * self.attraction_weight * w * gap * gap;
                for k in 0..3 {
                    gp[k] += l * self.attraction_weight * w * gap * dp[k] / dist;
                }
            }
            // Obstacle: radial penetration within the cylinder's length.
            let z = dot(dp, a);
            let radial = [dp[0] - z * a[0], dp[1] - z * a[1], dp[2] - z * a[2]];
            let rho = norm(radial);
            let pen = r_surf - rho;
            if pen > 0.0 && z.abs() <= 0.5 * self.length && rho > 0.0 {
                costs.obstacle += 0.5 * l * self.obstacle_weight * pen * pen;
                for k in 0..3 {
                    gp[k] -= l * self.obstacle_weight * pen * radial[k] / rho;
                }
            }
            // Sucker side: d1 towards c.
            if dist > 0.0 {
                let u = [-dp[0] / dist, -dp[1] / dist, -dp[2] / dist];
                let d1 = q[j][0];
                let du = dot(d1, u);
                let ms = l * self.sucker_weight * w;
                costs.sucker += ms * (1.0 - du);
                if let Some((_, cl)) = loads.as_mut() {
                    let t = cross(d1, u);
                    for k in 0..3 {
                        gp[k] += ms * (d1[k] - du * u[k]) / dist;
                        cl[j][k] -= ms * t[k];
                    }
                }
            }
            if let Some((gl, _)) = loads.as_mut() {
                for k in 0..3 {
                    gl[j][k] += 0.5 * gp[k];
                    gl[j + 1][k] += 0.5 * gp[k];
                }
            }
        }
        costs.total += costs.attraction + costs.obstacle + costs.sucker;
    }
}

/// Settings of the design solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DesignConfig {
    /// Iteration limit (`NotConverged` beyond). Default 2000.
    pub max_iterations: usize,
    /// L-BFGS memory. Default 10.
    pub memory: usize,
    /// Stop when ‖P(b − g) − b‖∞ ≤ this × √l̂. Default 1e-9.
    pub gradient_tolerance: f64,
    /// Stop when J decreased by less than this (relative) over 20 iterations. Default 1e-9.
    pub relative_decrease: f64,
    /// Groups the design may use (false: held at zero, the `GroupMask` of spec §7).
    pub groups: [bool; N_GROUPS],
    /// Stop as soon as the tip error [m], θ_Q [rad] and J are all at or below these (e.g. spec
    /// §7 A's acceptance bounds, for timing); None: run to convergence.
    pub stop_when: Option<(f64, f64, f64)>,
    /// Multi-start (with `stop_when` only): starts in all, the caller's included, in
    /// [1, 1000]; 1 = no restart. Default 8 (on the sweep's targets that miss the bounds from
    /// a = 0, the winning start was at most restart 6, docs/muscles.md).
    pub max_starts: usize,
    /// Multi-start: L-BFGS iterations over all starts, ≥ 1; no restart begins once they are
    /// spent, and a restart gets at most what remains. Default 8000 (4 × `max_iterations`).
    pub max_total_iterations: usize,
}

/// A `DesignConfig` setting outside its range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("DesignConfig.{field} = {value} is outside the allowed range {range}")]
pub struct DesignConfigError {
    /// Name of the setting.
    pub field: &'static str,
    /// Value given.
    pub value: String,
    /// Allowed range.
    pub range: &'static str,
}

impl DesignConfig {
    /// Check every setting; the error names the field, the value and the allowed range.
    pub fn validate(&self) -> Result<(), DesignConfigError> {
        let bad = |field, value: String, range| {
            Err(DesignConfigError {
                field,
                value,
                range,
            })
        };
        if self.max_iterations < 1 {
            return bad(
                "max_iterations",
                self.max_iterations.to_string(),
                "[1, inf)",
            );
        }
        if self.memory < 1 {
            return bad("memory", self.memory.to_string(), "[1, inf)");
        }
        for (field, v) in [
            ("gradient_tolerance", self.gradient_tolerance),
            ("relative_decrease", self.relative_decrease),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return bad(field, v.to_string(), "[0, inf), finite");
            }
        }
        if let Some((tip, angle, j)) = self.stop_when {
            if [tip, angle, j].iter().any(|v| v.is_nan() || *v < 0.0) {
                return bad(
                    "stop_when",
                    format!("({tip}, {angle}, {j})"),
                    "each in [0, inf]",
                );
            }
        }
        if !(1..=1000).contains(&self.max_starts) {
            return bad("max_starts", self.max_starts.to_string(), "[1, 1000]");
        }
        if self.max_total_iterations < 1 {
            return bad(
                "max_total_iterations",
                self.max_total_iterations.to_string(),
                "[1, inf)",
            );
        }
        Ok(())
    }
}

impl Default for DesignConfig {
    fn default() -> Self {
        Self {
            max_iterations: 2000,
            memory: 10,
            gradient_tolerance: 1e-9,
            relative_decrease: 1e-9,
            groups: [true; N_GROUPS],
            stop_when: None,
            max_starts: 8,
            max_total_iterations: 8000,
        }
    }
}

/// Why the design stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DesignOutcome {
    /// The projected gradient vanished.
    Converged,
    /// J stopped decreasing (relative decrease below the tolerance over 20 iterations).
    Stalled,
    /// The iteration limit was reached (the last iterate is returned).
    NotConverged,
    /// No descent step could be found (equilibrium failures or a non-descent direction).
    LineSearchFailed,
    /// The bounds of `DesignConfig::stop_when` were met.
    BoundsMet,
}

/// Costs of one evaluation.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DesignCosts {
    /// J = R + Φ (Φ_p + Φ_Q, or Φ_g + Φ_o + Φ_s).
    pub total: f64,
    /// Activation cost R = ½ Σ l̂ a².
    pub activation: f64,
    /// Tip-point cost Φ_p.
    pub position: f64,
    /// Tip-orientation cost Φ_Q.
    pub orientation: f64,
    /// Grasp attraction Φ_g.
    pub attraction: f64,
    /// Grasp obstacle Φ_o.
    pub obstacle: f64,
    /// Grasp sucker side Φ_s.
    pub sucker: f64,
    /// Tip-point error |p − p*| [m].
    pub tip_error: f64,
    /// Orientation error θ_Q = |Log(Q_{n−1} Q*ᵀ)| [rad] (0 without a frame).
    pub orientation_error: f64,
}

/// The design report (spec §5.6).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DesignReport {
    /// Why it stopped.
    pub outcome: DesignOutcome,
    /// L-BFGS iterations.
    pub iterations: usize,
    /// Cost evaluations (each an equilibrium solve).
    pub evaluations: usize,
    /// Newton iterations (fresh Jacobians) summed over the evaluations.
    pub newton_iterations: usize,
    /// Chord iterations (reused factors) summed over the evaluations.
    pub chord_iterations: usize,
    /// Costs at the result.
    pub costs: DesignCosts,
    /// Activations at 0 and at 1.
    pub at_zero: usize,
    /// Activations at 1.
    pub at_one: usize,
    /// Wall time [s].
    pub seconds: f64,
    /// Starts run (1 without multi-start; see `MuscleDesign::try_solve`).
    pub starts: usize,
    /// The start whose design is returned (0: the caller's start point; k ≥ 1: restart k).
    pub winner: usize,
}

/// COOMM's design iteration (spec §5.5), for cross-checks only: the relaxation
/// a ← clip_[0,1](a − η (a − â)) towards the "target activation" â, COOMM's frozen-Jacobian
/// estimate of −∂Φ/∂a / l̂ (`MuscleDesign::coomm_target`), from a given start (COOMM: a = 0).
/// An early-stopped descent on Φ, not a minimiser of (5.1); `MuscleDesign::solve` is the design
/// solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoommRelaxation {
    /// Relaxation factor η, in (0, 1]. Default 1e-8 (COOMM's).
    pub eta: f64,
    /// Iterations at most, ≥ 1. Default 100 000 (COOMM's per target).
    pub max_iterations: usize,
    /// Stop when the mean squared change of a over one iteration is below this, ≥ 0.
    /// Default 1e-12 (COOMM's; never reached in its runs).
    pub change_tolerance: f64,
    /// Equilibrium per iteration: false (default) the exact one (`MuscleStatics::solve`,
    /// warm-started); true COOMM's single Picard pass (spec §4.2) from the previous iterate's
    /// strains (from the rest strains at the start), so Φ and â are taken at a lagging,
    /// not exact, equilibrium as in COOMM.
    pub picard_pass: bool,
}

impl Default for CoommRelaxation {
    fn default() -> Self {
        Self {
            eta: 1e-8,
            max_iterations: 100_000,
            change_tolerance: 1e-12,
            picard_pass: false,
        }
    }
}

/// Why `MuscleDesign::relax_coomm` could not run or stopped early.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CoommRelaxationError {
    /// A setting outside its range.
    #[error("CoommRelaxation.{field} = {value} is outside the allowed range {range}")]
    Invalid {
        /// Name of the setting.
        field: &'static str,
        /// Value given.
        value: String,
        /// Allowed range.
        range: &'static str,
    },
    /// The equilibrium failed at an iterate (or the start activations were refused).
    #[error("relaxation iteration {iteration}: {source}")]
    Equilibrium {
        /// Relaxation iteration at which it failed.
        iteration: usize,
        /// The statics' error.
        source: MuscleStaticsError,
    },
}

impl CoommRelaxation {
    /// Check every setting; the error names the field, the value and the allowed range.
    pub fn validate(&self) -> Result<(), CoommRelaxationError> {
        let bad = |field, value: String, range| {
            Err(CoommRelaxationError::Invalid {
                field,
                value,
                range,
            })
        };
        if !(self.eta > 0.0 && self.eta <= 1.0) {
            return bad("eta", self.eta.to_string(), "(0, 1]");
        }
        if self.max_iterations < 1 {
            return bad(
                "max_iterations",
                self.max_iterations.to_string(),
                "[1, inf)",
            );
        }
        if !(self.change_tolerance >= 0.0 && self.change_tolerance.is_finite()) {
            return bad(
                "change_tolerance",
                self.change_tolerance.to_string(),
                "[0, inf), finite",
            );
        }
        Ok(())
    }
}

/// The result of `MuscleDesign::relax_coomm`.
#[derive(Debug, Clone, PartialEq)]
pub struct CoommRelaxationReport {
    /// Relaxation iterations made.
    pub iterations: usize,
    /// True if it stopped on `change_tolerance` (else on `max_iterations`).
    pub converged: bool,
    /// Costs of the returned activations (at their exact equilibrium).
    pub costs: DesignCosts,
    /// Task cost Φ = J − R at every iterate, the start's first and the returned one's last
    /// (`iterations + 1` values; with `picard_pass` at the Picard strains, the last at the exact
    /// equilibrium).
    pub task_cost: Vec<f64>,
    /// Mean squared change of a in the last iteration.
    pub last_change: f64,
    /// Equilibrium Newton iterations summed over the iterates.
    pub newton_iterations: usize,
    /// Wall time [s].
    pub seconds: f64,
}

/// The design problem of one muscular arm.
#[derive(Debug, Clone)]
pub struct MuscleDesign {
    statics: MuscleStatics,
    /// Settings.
    pub config: DesignConfig,
    grad_w: Vec<f64>,
    n_unit: Vec<[Vec<f64>; 3]>,
    c_unit: Vec<[Vec<f64>; 3]>,
    t_unit: Vec<[Vec<f64>; 3]>,
    newton_total: usize,
    chord_total: usize,
}

impl MuscleDesign {
    /// A design problem on `statics` (its model, muscles and base).
    pub fn new(statics: MuscleStatics) -> Self {
        let n = statics.n_elements();
        let m = statics.n_unknowns();
        let z = |k: usize| [vec![0.0; k], vec![0.0; k], vec![0.0; k]];
        Self {
            statics,
            config: DesignConfig::default(),
            grad_w: vec![0.0; m],
            n_unit: (0..N_GROUPS).map(|_| z(n)).collect(),
            c_unit: (0..N_GROUPS).map(|_| z(n)).collect(),
            t_unit: (0..N_GROUPS).map(|_| z(n - 1)).collect(),
            newton_total: 0,
            chord_total: 0,
        }
    }

    /// The statics (its last solution is the design's equilibrium).
    pub fn statics(&self) -> &MuscleStatics {
        &self.statics
    }

    /// Mutable statics (settings).
    pub fn statics_mut(&mut self) -> &mut MuscleStatics {
        &mut self.statics
    }

    /// Task cost Φ and its gradient with respect to the strains (the exact discrete adjoint of
    /// the forward map, eqs. 5.2–5.4), for strains `w`; `grad` gets ∂Φ/∂w (interleaved).
    pub fn task_gradient<T: DesignTask + ?Sized>(
        &self,
        task: &T,
        w: &[f64],
        grad: Option<&mut [f64]>,
    ) -> DesignCosts {
        let st = &self.statics;
        let n = st.n_elements();
        let pose = st.pose(w);
        let x = &pose.position;
        let q = &pose.director;
        let mut costs = DesignCosts::default();
        let Some(grad) = grad else {
            task.cost(st.model(), &pose, &mut costs, None);
            return costs;
        };
        // Node loads g_i = ∂Φ/∂x_i and element lab couples c_j (5.2).
        let mut gl = vec![[0.0; 3]; n + 1];
        let mut cl = vec![[0.0; 3]; n];
        task.cost(st.model(), &pose, &mut costs, Some((&mut gl, &mut cl)));
        let g = |i: usize| gl[i];
        let c = |j: usize| cl[j];
        let mut force = [-g(n)[0], -g(n)[1], -g(n)[2]];
        let mut couple = [0.0; 3];
        for j in (0..n).rev() {
            // ∂Φ/∂ν_j = −l̂_j Q_j n_j.
            let l = st.model().rest_length[j];
            let qn = mat_vec(&q[j], force);
            for c3 in 0..3 {
                grad[6 * j + c3] = -l * qn[c3];
            }
            // m_{j−1} from m_j (ghost m_{n−1} = 0).
            let dx = [
                x[j + 1][0] - x[j][0],
                x[j + 1][1] - x[j][1],
                x[j + 1][2] - x[j][2],
            ];
            let t = cross(dx, force);
            let cj = c(j);
            for c3 in 0..3 {
                couple[c3] += t[c3] - cj[c3];
            }
            if j >= 1 {
                let k = j - 1;
                // ∂Φ/∂κ_k = −D̂_k J_r(−D̂_k κ_k) Q_{k+1} m_k.
                let dk = st.model().rest_voronoi_length[k];
                let kap = MuscleStatics::kappa(w, k);
                let phi = [-dk * kap[0], -dk * kap[1], -dk * kap[2]];
                let v = mat_vec(&q[k + 1], couple);
                let jr = right_jacobian(phi, v);
                for c3 in 0..3 {
                    grad[6 * k + 3 + c3] = -dk * jr[c3];
                }
                let gj = g(j);
                for c3 in 0..3 {
                    force[c3] -= gj[c3];
                }
            }
        }
        costs
    }

    /// J(a) and, with `grad`, ∂J/∂a (group-major `[7][n]`): equilibrium (warm-started from the
    /// last one), task cost, adjoint (K ᵀλ = ∇_w Φ with the equilibrium Jacobian) and eq. 5.5.
    pub fn evaluate<T: DesignTask + ?Sized>(
        &mut self,
        task: &T,
        a: &[f64],
        grad: Option<&mut [f64]>,
    ) -> Result<DesignCosts, MuscleStaticsError> {
        let rep = self.statics.solve(a, None)?;
        self.newton_total += rep.newton_iterations;
        self.chord_total += rep.chord_iterations;
        let n = self.statics.n_elements();
        let lr = self.statics.model().rest_length.clone();
        let mut reg = 0.0;
        for g in 0..N_GROUPS {
            for j in 0..n {
                reg += 0.5 * lr[j] * a[g * n + j] * a[g * n + j];
            }
        }
        let w = self.statics.solution().to_vec();
        let Some(grad) = grad else {
            let mut c = self.task_gradient(task, &w, None);
            c.activation = reg;
            c.total += reg;
            return Ok(c);
        };
        let mut gw = std::mem::take(&mut self.grad_w);
        let mut c = self.task_gradient(task, &w, Some(&mut gw));
        c.activation = reg;
        c.total += reg;
        // Adjoint: Kᵀ λ = ∇_w Φ (K factored at the solution; the next solve's chord steps
        // reuse the factors).
        let factored = self.statics.adjoint_solve(a, &mut gw);
        if let Err(e) = factored {
            self.grad_w = gw;
            return Err(MuscleStaticsError::EquilibriumFailed {
                iteration: e.column,
                residual: f64::NAN,
            });
        }
        // Unit-activation resultants per group at the solution (spec eq. 5.5).
        self.unit_resultants(&w);
        for g in 0..N_GROUPS {
            let (nu, cu) = (&self.n_unit[g], &self.c_unit[g]);
            for j in 0..n {
                let mut v = lr[j] * a[g * n + j];
                for c3 in 0..3 {
                    v -= gw[6 * j + c3] * nu[c3][j];
                    let mut lk = 0.0;
                    if j >= 1 {
                        lk += gw[6 * (j - 1) + 3 + c3];
                    }
                    if j + 1 < n {
                        lk += gw[6 * j + 3 + c3];
                    }
                    v -= 0.5 * lk * cu[c3][j];
                }
                grad[g * n + j] = v;
            }
        }
        self.grad_w = gw;
        Ok(c)
    }

    fn unit_resultants(&mut self, w: &[f64]) {
        let st = &self.statics;
        let n = st.n_elements();
        let model = st.model();
        let mut sigma = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        let mut dil = vec![0.0; n];
        let mut kappa = [vec![0.0; n - 1], vec![0.0; n - 1], vec![0.0; n - 1]];
        let mut eps = vec![0.0; n - 1];
        for j in 0..n {
            let v = MuscleStatics::nu(w, j);
            sigma[0][j] = v[0];
            sigma[1][j] = v[1];
            sigma[2][j] = v[2] - 1.0;
            dil[j] = norm(v);
        }
        for k in 0..n - 1 {
            let v = MuscleStatics::kappa(w, k);
            for c in 0..3 {
                kappa[c][k] = v[c];
            }
            eps[k] = 0.5 * (model.rest_length[k] * dil[k] + model.rest_length[k + 1] * dil[k + 1])
                / model.rest_voronoi_length[k];
        }
        let strains = Strains {
            sigma: [&sigma[0], &sigma[1], &sigma[2]],
            dilatation: &dil,
            kappa: [&kappa[0], &kappa[1], &kappa[2]],
            voronoi_dilatation: &eps,
        };
        let ones = vec![1.0; n];
        let zeros = vec![0.0; n];
        let mut scratch = octoarm_physics::muscles::MuscleScratch::new(n);
        for g in 0..N_GROUPS {
            let act: [&[f64]; N_GROUPS] =
                std::array::from_fn(|h| if h == g { &ones[..] } else { &zeros[..] });
            let [n0, n1, n2] = &mut self.n_unit[g];
            let [c0, c1, c2] = &mut self.c_unit[g];
            let [t0, t1, t2] = &mut self.t_unit[g];
            let mut out = Resultants {
                force: [n0, n1, n2],
                couple: [t0, t1, t2],
                moment: Some([c0, c1, c2]),
            };
            st.muscles()
                .resultants(act, &strains, &mut scratch, &mut out);
        }
    }

    /// COOMM's "target activation" â (spec §5.5) at activations `a` (group-major `[7][n]`,
    /// into `a_hat`), and J(a). The equilibrium is the exact one (warm-started from the last);
    /// COOMM takes one Picard pass per iteration instead. Costates: the sweep (5.3) of the lab
    /// force n_j and couple m_k (the discrete form of COOMM's continuum quadrature), in the
    /// material frame with J_r ≈ I (n_j ← Q_j n_j, m_k ← Q_{k+1} m_k). With the frozen Jacobian
    /// K ≈ diag(S/e, B/ε) (ε where the equilibrium has ε³):
    /// â_{g,j} = −n_j · e_j S_j⁻¹ n^{g,1}_j − ½ (c_j + c_{j+1}),
    /// c_{k+1} = m_k · ε_k B_k⁻¹ τ^{g,1}_k on nodes 1..n−1, c_0 and c_n extrapolated linearly;
    /// n^{g,1}, τ^{g,1} the group's element force and Voronoi couple at unit activation. −l̂ â
    /// approximates ∂Φ/∂a (the exact one: `evaluate` minus l̂ a).
    pub fn coomm_target<T: DesignTask + ?Sized>(
        &mut self,
        task: &T,
        a: &[f64],
        a_hat: &mut [f64],
    ) -> Result<DesignCosts, MuscleStaticsError> {
        let costs = self.evaluate(task, a, None)?;
        let w = self.statics.solution().to_vec();
        self.target_at(task, &w, a_hat);
        Ok(costs)
    }

    /// â of `coomm_target` at strains `w` (not necessarily an equilibrium).
    fn target_at<T: DesignTask + ?Sized>(&mut self, task: &T, w: &[f64], a_hat: &mut [f64]) {
        let st = &self.statics;
        let n = st.n_elements();
        let model = st.model();
        let pose = st.pose(w);
        let (x, q) = (&pose.position, &pose.director);
        let mut gl = vec![[0.0; 3]; n + 1];
        let mut cl = vec![[0.0; 3]; n];
        task.cost(
            model,
            &pose,
            &mut DesignCosts::default(),
            Some((&mut gl, &mut cl)),
        );
        // Material-frame costates: force on elements, couple on Voronoi points.
        let mut nf = vec![[0.0; 3]; n];
        let mut mc = vec![[0.0; 3]; n - 1];
        let mut force = [-gl[n][0], -gl[n][1], -gl[n][2]];
        let mut couple = [0.0; 3];
        for j in (0..n).rev() {
            nf[j] = mat_vec(&q[j], force);
            let dx: Vec3 = std::array::from_fn(|c| x[j + 1][c] - x[j][c]);
            let t = cross(dx, force);
            for c in 0..3 {
                couple[c] += t[c] - cl[j][c];
            }
            if j >= 1 {
                mc[j - 1] = mat_vec(&q[j], couple);
                for c in 0..3 {
                    force[c] -= gl[j][c];
                }
            }
        }
        self.unit_resultants(w);
        let st = &self.statics;
        let model = st.model();
        let mut node = vec![0.0; n + 1];
        for g in 0..N_GROUPS {
            let (nu, tu) = (&self.n_unit[g], &self.t_unit[g]);
            for k in 0..n - 1 {
                let (e0, e1) = (
                    norm(MuscleStatics::nu(w, k)),
                    norm(MuscleStatics::nu(w, k + 1)),
                );
                let eps = 0.5 * (model.rest_length[k] * e0 + model.rest_length[k + 1] * e1)
                    / model.rest_voronoi_length[k];
                let b = model.bend_stiffness[k];
                node[k + 1] = (0..3).map(|c| mc[k][c] * eps * tu[c][k] / b[c]).sum();
            }
            if n >= 3 {
                node[0] = 2.0 * node[1] - node[2];
                node[n] = 2.0 * node[n - 1] - node[n - 2];
            } else {
                node[0] = node[1];
                node[n] = node[n - 1];
            }
            for j in 0..n {
                let e = norm(MuscleStatics::nu(w, j));
                let s = model.shear_stiffness[j];
                let axial: f64 = (0..3).map(|c| nf[j][c] * e * nu[c][j] / s[c]).sum();
                a_hat[g * n + j] = -axial - 0.5 * (node[j] + node[j + 1]);
            }
        }
    }

    /// COOMM's relaxation (spec §5.5, for cross-checks only): from `a0`, per iteration the
    /// target activation â at the current a (`coomm_target` at the exact equilibrium, or at
    /// one Picard pass with `cfg.picard_pass`) and
    /// a ← clip_[0,1](a − η (a − â)); stop after `cfg.max_iterations` or when the mean squared
    /// change is below `cfg.change_tolerance`. Returns the last activations and the report (Φ at
    /// every iterate). An invalid `cfg` or an equilibrium failure is an error.
    pub fn relax_coomm<T: DesignTask + ?Sized>(
        &mut self,
        task: &T,
        a0: &[f64],
        cfg: &CoommRelaxation,
    ) -> Result<(Vec<f64>, CoommRelaxationReport), CoommRelaxationError> {
        cfg.validate()?;
        let start = Instant::now();
        self.newton_total = 0;
        self.chord_total = 0;
        let fail = |iteration, source| CoommRelaxationError::Equilibrium { iteration, source };
        // Start activations outside [0, 1] are refused, not clipped.
        self.statics.check_activations(a0).map_err(|e| fail(0, e))?;
        let mut a: Vec<f64> = a0.to_vec();
        let mut a_hat = vec![0.0; a.len()];
        let mut task_cost = Vec::with_capacity(cfg.max_iterations.min(1 << 20) + 1);
        let (mut it, mut converged, mut last_change) = (0, false, f64::NAN);
        let mut w = self.statics.rest();
        let max_picard = self.statics.config.max_picard;
        while it < cfg.max_iterations {
            let phi = if cfg.picard_pass {
                self.statics
                    .check_activations(&a)
                    .map_err(|e| fail(it, e))?;
                self.statics.config.max_picard = 1;
                self.statics.picard(&mut w, &a, 0.0);
                self.statics.config.max_picard = max_picard;
                if !w.iter().all(|v| v.is_finite()) {
                    let e = MuscleStaticsError::EquilibriumFailed {
                        iteration: it,
                        residual: f64::NAN,
                    };
                    return Err(fail(it, e));
                }
                let phi = self.task_gradient(task, &w, None).total;
                self.target_at(task, &w, &mut a_hat);
                phi
            } else {
                let c = self
                    .coomm_target(task, &a, &mut a_hat)
                    .map_err(|e| fail(it, e))?;
                c.total - c.activation
            };
            task_cost.push(phi);
            it += 1;
            let mut change = 0.0;
            for (v, h) in a.iter_mut().zip(&a_hat) {
                let next = (*v - cfg.eta * (*v - h)).clamp(0.0, 1.0);
                change += (next - *v) * (next - *v);
                *v = next;
            }
            last_change = change / a.len() as f64;
            if last_change < cfg.change_tolerance {
                converged = true;
                break;
            }
        }
        let costs = self.evaluate(task, &a, None).map_err(|e| fail(it, e))?;
        task_cost.push(costs.total - costs.activation);
        let report = CoommRelaxationReport {
            iterations: it,
            converged,
            costs,
            task_cost,
            last_change,
            newton_iterations: self.newton_total,
            seconds: start.elapsed().as_secs_f64(),
        };
        Ok((a, report))
    }

    /// Design activations for `task` from `a0` (group-major `[7][n]`, clipped to the bounds)
    /// by projected L-BFGS on b = √l̂ a (spec §5.6), with the multi-start of
    /// `DesignConfig::max_starts` when `stop_when` is set (see `try_solve`).
    ///
    /// Panics with the `DesignConfigError` message if `config` is invalid (`try_solve` returns
    /// it instead).
    pub fn solve<T: DesignTask + ?Sized>(
        &mut self,
        task: &T,
        a0: &[f64],
    ) -> (Vec<f64>, DesignReport) {
        match self.try_solve(task, a0) {
            Ok(out) => out,
            Err(e) => panic!("invalid design config: {e}"),
        }
    }

    /// Design activations for `task` from `a0`; an invalid `config` is an error.
    ///
    /// Multi-start (the problem is not convex, spec §5.6): with `stop_when` set, a start that
    /// ends without meeting the bounds (a local minimum, a stall, a failed line search or the
    /// iteration limit) is followed by restarts k = 1, 2, … < `max_starts` from
    /// `restart_activations(k)` — per-group uniform levels from the Halton sequence — each
    /// with at most `max_iterations` and together with the earlier starts at most
    /// `max_total_iterations` iterations (no restart begins once the budget is spent). The first
    /// start that meets the bounds wins at once; if none does, the lowest J wins (the earliest
    /// on a tie). A first start that meets the bounds is returned exactly as without
    /// multi-start. Without `stop_when` there is one start. The report's `iterations`,
    /// `evaluations`, Newton and chord iterations and `seconds` are totals over the starts; its
    /// outcome, costs and bound counts are the winner's, whose equilibrium is left in
    /// `statics()`. Deterministic: the same input (with the statics' last equilibrium, which
    /// warm-starts start 0's first solve) gives the same bits.
    pub fn try_solve<T: DesignTask + ?Sized>(
        &mut self,
        task: &T,
        a0: &[f64],
    ) -> Result<(Vec<f64>, DesignReport), DesignConfigError> {
        self.config.validate()?;
        let start = Instant::now();
        let n = self.statics.n_elements();
        let stop = self.config.stop_when;
        let met = |r: &DesignReport| {
            stop.is_some_and(|(tip, angle, j)| {
                r.costs.tip_error <= tip && r.costs.orientation_error <= angle && r.costs.total <= j
            })
        };
        let (a, first) = self.solve_start(task, a0, self.config.max_iterations);
        if self.config.stop_when.is_none() || self.config.max_starts <= 1 || met(&first) {
            return Ok((a, first));
        }
        let mut total = first;
        let (mut best_a, mut best) = (a, first);
        let mut best_w = self.statics.solution().to_vec();
        let rest = self.statics.rest();
        let mut a_k = vec![0.0; N_GROUPS * n];
        for k in 1..self.config.max_starts {
            if total.iterations >= self.config.max_total_iterations {
                break;
            }
            let limit = self
                .config
                .max_iterations
                .min(self.config.max_total_iterations - total.iterations);
            restart_activations(k, n, &mut a_k);
            // Each restart's equilibrium starts from the straight arm, not from the previous
            // start's pose: the starts are independent of their order.
            let _ = self.statics.solve(&a_k, Some(&rest));
            let (a, rep) = self.solve_start(task, &a_k, limit);
            total.starts += 1;
            total.iterations += rep.iterations;
            total.evaluations += rep.evaluations;
            total.newton_iterations += rep.newton_iterations;
            total.chord_iterations += rep.chord_iterations;
            let won = met(&rep);
            // A start that could not begin (iterations 0, failed) never wins over one that ran.
            let better =
                rep.iterations > 0 && (rep.costs.total < best.costs.total || best.iterations == 0);
            if won || better {
                best = DesignReport { winner: k, ..rep };
                best_a = a;
                best_w.copy_from_slice(self.statics.solution());
            }
            if won {
                break;
            }
        }
        if best.winner + 1 != total.starts {
            // Leave the winner's equilibrium in the statics (its own solution as the warm start:
            // the solve finds the residual already below the tolerance).
            let _ = self.statics.solve(&best_a, Some(&best_w));
        }
        let report = DesignReport {
            iterations: total.iterations,
            evaluations: total.evaluations,
            newton_iterations: total.newton_iterations,
            chord_iterations: total.chord_iterations,
            starts: total.starts,
            seconds: start.elapsed().as_secs_f64(),
            ..best
        };
        Ok((best_a, report))
    }

    /// One start of projected L-BFGS from `a0` with at most `max_iterations` iterations.
    fn solve_start<T: DesignTask + ?Sized>(
        &mut self,
        task: &T,
        a0: &[f64],
        max_iterations: usize,
    ) -> (Vec<f64>, DesignReport) {
        let start = Instant::now();
        self.newton_total = 0;
        self.chord_total = 0;
        let n = self.statics.n_elements();
        let nv = N_GROUPS * n;
        let lr = self.statics.model().rest_length.clone();
        let scale: Vec<f64> = (0..nv).map(|i| lr[i % n].sqrt()).collect();
        let upper: Vec<f64> = (0..nv)
            .map(|i| {
                if self.config.groups[i / n] {
                    scale[i]
                } else {
                    0.0
                }
            })
            .collect();
        let proj = |b: &mut [f64]| {
            for (v, u) in b.iter_mut().zip(&upper) {
                *v = v.clamp(0.0, *u);
            }
        };
        let to_a = |b: &[f64], a: &mut [f64]| {
            for i in 0..nv {
                a[i] = (b[i] / scale[i]).clamp(0.0, 1.0);
            }
        };
        let mut b: Vec<f64> = (0..nv).map(|i| a0[i] * scale[i]).collect();
        proj(&mut b);
        let mut a = vec![0.0; nv];
        to_a(&b, &mut a);
        let mut ga = vec![0.0; nv];
        let mut evaluations = 1;
        let mut costs = match self.evaluate(task, &a, Some(&mut ga)) {
            Ok(c) => c,
            Err(_) => {
                let report = self.report(
                    DesignOutcome::LineSearchFailed,
                    0,
                    1,
                    DesignCosts::default(),
                    &a,
                    start,
                );
                return (a, report);
            }
        };
        let mut g: Vec<f64> = (0..nv).map(|i| ga[i] / scale[i]).collect();
        let mut s_hist: Vec<Vec<f64>> = Vec::new();
        let mut y_hist: Vec<Vec<f64>> = Vec::new();
        let mut history = vec![costs.total];
        let mut outcome = DesignOutcome::NotConverged;
        let mut it = 0;
        let (mut bt, mut gt, mut at) = (vec![0.0; nv], vec![0.0; nv], vec![0.0; nv]);
        let mut d = vec![0.0; nv];
        let tol =
            self.config.gradient_tolerance * scale.iter().copied().fold(f64::INFINITY, f64::min);
        let met = |c: &DesignCosts, stop: Option<(f64, f64, f64)>| {
            stop.is_some_and(|(tip, angle, j)| {
                c.tip_error <= tip && c.orientation_error <= angle && c.total <= j
            })
        };
        while it < max_iterations {
            if met(&costs, self.config.stop_when) {
                outcome = DesignOutcome::BoundsMet;
                break;
            }
            // Projected-gradient test.
            let pg = (0..nv)
                .map(|i| ((b[i] - g[i]).clamp(0.0, upper[i]) - b[i]).abs())
                .fold(0.0, f64::max);
            if pg <= tol {
                outcome = DesignOutcome::Converged;
                break;
            }
            it += 1;
            // Free set: not at a bound with the gradient pointing outward.
            let free: Vec<bool> = (0..nv)
                .map(|i| {
                    upper[i] > 0.0
                        && !((b[i] <= 0.0 && g[i] > 0.0) || (b[i] >= upper[i] && g[i] < 0.0))
                })
                .collect();
            two_loop(&g, &free, &s_hist, &y_hist, &mut d);
            let mut slope: f64 = (0..nv).map(|i| d[i] * g[i]).sum();
            if slope.is_nan() || slope >= 0.0 {
                s_hist.clear();
                y_hist.clear();
                for i in 0..nv {
                    d[i] = if free[i] { -g[i] } else { 0.0 };
                }
                slope = (0..nv).map(|i| d[i] * g[i]).sum();
                if slope.is_nan() || slope >= 0.0 {
                    outcome = DesignOutcome::Converged;
                    break;
                }
            }
            let mut alpha = 1.0;
            let mut accepted = None;
            for _ in 0..30 {
                for i in 0..nv {
                    bt[i] = b[i] + alpha * d[i];
                }
                proj(&mut bt);
                to_a(&bt, &mut at);
                evaluations += 1;
                // The cost alone for the Armijo test; the gradient (adjoint solve and the unit
                // resultants) only at the accepted point, whose equilibrium is then at hand
                // (the solve finds its residual already below the tolerance).
                let mut shrink = 0.5;
                if let Ok(ct) = self.evaluate(task, &at, None) {
                    let dec: f64 = (0..nv).map(|i| g[i] * (bt[i] - b[i])).sum();
                    if ct.total <= costs.total + 1e-4 * dec.min(0.0) && ct.total < costs.total {
                        if let Ok(ct) = self.evaluate(task, &at, Some(&mut ga)) {
                            for i in 0..nv {
                                gt[i] = ga[i] / scale[i];
                            }
                            accepted = Some(ct);
                            break;
                        }
                    }
                    // Backtrack to the minimiser of the quadratic through J(b), its slope `dec`
                    // along the trial step and J(trial), kept within [0.1, 0.5] of the step
                    // (Nocedal & Wright §3.5): far fewer equilibrium solves than halving when
                    // the step was much too long.
                    let curv = ct.total - costs.total - dec;
                    if dec < 0.0 && curv > 0.0 && curv.is_finite() {
                        shrink = (-dec / (2.0 * curv)).clamp(0.1, 0.5);
                    }
                }
                alpha *= shrink;
            }
            let Some(ct) = accepted else {
                // Restore the equilibrium of the current iterate for the report.
                let _ = self.evaluate(task, &a, None);
                outcome = DesignOutcome::LineSearchFailed;
                break;
            };
            let s: Vec<f64> = (0..nv).map(|i| bt[i] - b[i]).collect();
            let y: Vec<f64> = (0..nv).map(|i| gt[i] - g[i]).collect();
            let sy: f64 = s.iter().zip(&y).map(|(p, q)| p * q).sum();
            let (ns, ny) = (
                s.iter().map(|v| v * v).sum::<f64>().sqrt(),
                y.iter().map(|v| v * v).sum::<f64>().sqrt(),
            );
            if sy > 1e-12 * ns * ny {
                s_hist.push(s);
                y_hist.push(y);
                if s_hist.len() > self.config.memory {
                    s_hist.remove(0);
                    y_hist.remove(0);
                }
            }
            b.copy_from_slice(&bt);
            g.copy_from_slice(&gt);
            a.copy_from_slice(&at);
            costs = ct;
            history.push(costs.total);
            if history.len() > 20 {
                let old = history[history.len() - 21];
                if (old - costs.total) <= self.config.relative_decrease * old.abs() {
                    outcome = DesignOutcome::Stalled;
                    break;
                }
            }
        }
        let report = self.report(outcome, it, evaluations, costs, &a, start);
        (a, report)
    }

    /// The grasp continuation of spec §5.6: solve with the task's weights × 10^(k − stages + 1)
    /// for k = 0..stages, each stage warm-started from the last (`config.max_iterations` per
    /// stage). The report sums iterations, evaluations, Newton iterations and time; its costs
    /// and outcome are the last stage's.
    pub fn solve_continuation(
        &mut self,
        task: &GraspTask,
        stages: usize,
        a0: &[f64],
    ) -> (Vec<f64>, DesignReport) {
        let stages = stages.max(1);
        let mut a = a0.to_vec();
        let mut total: Option<DesignReport> = None;
        for k in 0..stages {
            let f = 10f64.powi(k as i32 + 1 - stages as i32);
            let (next, rep) = self.solve(&task.scaled(f), &a);
            a = next;
            total = Some(match total {
                None => rep,
                Some(t) => DesignReport {
                    iterations: t.iterations + rep.iterations,
                    evaluations: t.evaluations + rep.evaluations,
                    newton_iterations: t.newton_iterations + rep.newton_iterations,
                    seconds: t.seconds + rep.seconds,
                    ..rep
                },
            });
        }
        (a, total.expect("at least one stage"))
    }

    fn report(
        &self,
        outcome: DesignOutcome,
        iterations: usize,
        evaluations: usize,
        costs: DesignCosts,
        a: &[f64],
        start: Instant,
    ) -> DesignReport {
        DesignReport {
            outcome,
            iterations,
            evaluations,
            newton_iterations: self.newton_total,
            chord_iterations: self.chord_total,
            costs,
            at_zero: a.iter().filter(|v| **v <= 0.0).count(),
            at_one: a.iter().filter(|v| **v >= 1.0).count(),
            seconds: start.elapsed().as_secs_f64(),
            starts: 1,
            winner: 0,
        }
    }
}

/// Start point of restart k ≥ 1 of the multi-start (group-major `[7][n]` into `a`): group g
/// at the uniform level h_{p_g}(k), the radical inverse of k in the g-th prime base (2, 3, 5,
/// 7, 11, 13, 17) — the Halton sequence over the seven group levels. Why: the reachable poses
/// are made by group levels anywhere in [0, 1]; a low-discrepancy sequence covers that cube
/// evenly with few points and is deterministic. (Also tried on the 25 sweep targets that miss
/// from a = 0, 8 starts each: all met the bounds with Halton levels, the fewest total
/// iterations of five rules — docs/muscles.md "Multi-start".)
pub fn restart_activations(k: usize, n: usize, a: &mut [f64]) {
    const BASES: [usize; N_GROUPS] = [2, 3, 5, 7, 11, 13, 17];
    for (g, &base) in BASES.iter().enumerate() {
        let (mut f, mut level, mut i) = (1.0, 0.0, k);
        while i > 0 {
            f /= base as f64;
            level += f * (i % base) as f64;
            i /= base;
        }
        a[g * n..(g + 1) * n].fill(level);
    }
}

/// J_r(φ) v with J_r(φ) = I − (1 − cos θ)/θ² [φ]× + (θ − sin θ)/θ³ [φ]×² (control spec §2.5).
fn right_jacobian(phi: Vec3, v: Vec3) -> Vec3 {
    let t2 = dot(phi, phi);
    let (a, b) = if t2 < 1e-8 {
        (0.5 - t2 / 24.0, 1.0 / 6.0 - t2 / 120.0)
    } else {
        let t = t2.sqrt();
        ((1.0 - t.cos()) / t2, (t - t.sin()) / (t2 * t))
    };
    let pv = cross(phi, v);
    let ppv = cross(phi, pv);
    [
        v[0] - a * pv[0] + b * ppv[0],
        v[1] - a * pv[1] + b * ppv[1],
        v[2] - a * pv[2] + b * ppv[2],
    ]
}

/// L-BFGS two-loop recursion on the free set: d = −H g (zero on the active set).
fn two_loop(g: &[f64], free: &[bool], s: &[Vec<f64>], y: &[Vec<f64>], d: &mut [f64]) {
    let nv = g.len();
    let dotf =
        |p: &[f64], q: &[f64]| -> f64 { (0..nv).filter(|&i| free[i]).map(|i| p[i] * q[i]).sum() };
    for i in 0..nv {
        d[i] = if free[i] { g[i] } else { 0.0 };
    }
    let m = s.len();
    let mut alpha = vec![0.0; m];
    for k in (0..m).rev() {
        let rho = dotf(&y[k], &s[k]);
        if rho <= 0.0 {
            continue;
        }
        alpha[k] = dotf(&s[k], d) / rho;
        for i in 0..nv {
            if free[i] {
                d[i] -= alpha[k] * y[k][i];
            }
        }
    }
    let gamma = if m > 0 {
        let sy = dotf(&s[m - 1], &y[m - 1]);
        let yy = dotf(&y[m - 1], &y[m - 1]);
        if sy > 0.0 && yy > 0.0 {
            sy / yy
        } else {
            1.0
        }
    } else {
        1.0
    };
    for v in d.iter_mut() {
        *v *= gamma;
    }
    for k in 0..m {
        let rho = dotf(&y[k], &s[k]);
        if rho <= 0.0 {
            continue;
        }
        let beta = dotf(&y[k], d) / rho;
        for i in 0..nv {
            if free[i] {
                d[i] += (alpha[k] - beta) * s[k][i];
            }
        }
    }
    for v in d.iter_mut() {
        *v = -*v;
    }
}
