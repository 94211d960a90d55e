//! Statics of the muscular arm for given activations (muscles-3d spec §4): the exact discrete
//! equilibrium of the stepper, R^ν_j = S_j(ν_j − ν°_j)/e_j + n^μ_j = 0 per element and
//! R^κ_k = B_k(κ_k − κ°_k)/ε_k³ + τ^μ_k = 0 per Voronoi point (eq. 4.1), in the strains
//! w = (ν_0, κ_0, ν_1, …, κ_{n−2}, ν_{n−1}) (interleaved, 6n − 3 unknowns), solved by Newton with a
//! banded Jacobian (half-bandwidth 11) and a banded LU; warm starts; COOMM's Picard iteration as
//! the fallback; the pose by the forward map. The muscle loads come from the physics crate's
//! kernel (`MuscleModel::resultants`), the same code the stepper runs.
//!
//! The Jacobian is the coloured central-difference one (23 colours, 46 residual evaluations);
//! the analytic Jacobian of spec §4.2 is not yet implemented (docs/muscles.md).

use crate::banded::BandMatrix;
use octoarm_physics::math::{exp_neg_skew, mat_mul, mat_t_vec};
use octoarm_physics::muscles::{MuscleScratch, Resultants, Strains};
use octoarm_physics::{Mat3, MuscleModel, RodModel, RodState, Vec3, N_GROUPS};

/// Half-bandwidth of the equilibrium Jacobian in the interleaved ordering.
pub const HALF_BAND: usize = 11;
const COLOURS: usize = 2 * HALF_BAND + 1;

/// Settings of the equilibrium solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StaticsConfig {
    /// Stop at scaled residual ρ_R ≤ this (dimensionless strain). Default 1e-12.
    pub tolerance: f64,
    /// Newton iterations before giving up (then Picard, then Newton once more). Default 30.
    pub max_newton: usize,
    /// Picard iterations of the fallback. Default 20 000.
    pub max_picard: usize,
    /// Central-difference step of the Jacobian. Default 1e-7.
    pub fd_step: f64,
}

impl Default for StaticsConfig {
    fn default() -> Self {
        Self {
            tolerance: 1e-12,
            max_newton: 30,
            max_picard: 20_000,
            fd_step: 1e-7,
        }
    }
}

/// The equilibrium could not be found.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MuscleStaticsError {
    /// Neither Newton nor the Picard fallback reached the tolerance.
    #[error("no equilibrium found: scaled residual {residual:e} after {iteration} iterations")]
    EquilibriumFailed {
        /// Iterations made (Newton + Picard).
        iteration: usize,
        /// Scaled residual ρ_R reached.
        residual: f64,
    },
    /// Activations of the wrong length or outside [0, 1].
    #[error("activations: {0}")]
    BadActivation(String),
}

/// Outcome of one solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EquilibriumReport {
    /// Newton iterations.
    pub newton_iterations: usize,
    /// Picard iterations of the fallback (0 if Newton converged).
    pub picard_iterations: usize,
    /// Final scaled residual ρ_R.
    pub residual: f64,
}

/// The statics of one muscular rod (clamped base at a given pose).
#[derive(Debug, Clone)]
pub struct MuscleStatics {
    model: RodModel,
    muscles: MuscleModel,
    base_position: Vec3,
    base_frame: Mat3,
    nu0: Vec<Vec3>,
    kappa0: Vec<Vec3>,
    // Kernel input and output, structure of arrays.
    sigma: [Vec<f64>; 3],
    dil: Vec<f64>,
    kappa: [Vec<f64>; 3],
    eps: Vec<f64>,
    n_mu: [Vec<f64>; 3],
    tau_mu: [Vec<f64>; 3],
    scratch: MuscleScratch,
    // Newton work arrays.
    jac: BandMatrix,
    r: Vec<f64>,
    rp: Vec<f64>,
    rm: Vec<f64>,
    dw: Vec<f64>,
    trial: Vec<f64>,
    w: Vec<f64>,
    /// Settings.
    pub config: StaticsConfig,
}

impl MuscleStatics {
    /// Statics of `model` with `muscles`, clamped at `base_position` with frame `base_frame`,
    /// against the model's natural rest strains.
    pub fn new(
        model: &RodModel,
        muscles: MuscleModel,
        base_position: Vec3,
        base_frame: Mat3,
    ) -> Self {
        let n = model.n_elements;
        assert_eq!(muscles.n_elements(), n, "muscles built for another model");
        let m = 6 * n - 3;
        let nu0 = model
            .rest_sigma
            .iter()
            .map(|s| [s[0], s[1], 1.0 + s[2]])
            .collect();
        let z = |k: usize| [vec![0.0; k], vec![0.0; k], vec![0.0; k]];
        let mut s = Self {
            model: model.clone(),
            muscles,
            base_position,
            base_frame,
            nu0,
            kappa0: model.rest_kappa.clone(),
            sigma: z(n),
            dil: vec![1.0; n],
            kappa: z(n - 1),
            eps: vec![1.0; n - 1],
            n_mu: z(n),
            tau_mu: z(n - 1),
            scratch: MuscleScratch::new(n),
            jac: BandMatrix::new(m, HALF_BAND, HALF_BAND),
            r: vec![0.0; m],
            rp: vec![0.0; m],
            rm: vec![0.0; m],
            dw: vec![0.0; m],
            trial: vec![0.0; m],
            w: vec![0.0; m],
            config: StaticsConfig::default(),
        };
        s.w = s.rest();
        s
    }

    /// Number of elements n.
    pub fn n_elements(&self) -> usize {
        self.model.n_elements
    }

    /// Number of unknowns 6n − 3.
    pub fn n_unknowns(&self) -> usize {
        6 * self.model.n_elements - 3
    }

    /// The muscle model.
    pub fn muscles(&self) -> &MuscleModel {
        &self.muscles
    }

    /// The rod model.
    pub fn model(&self) -> &RodModel {
        &self.model
    }

    /// The rest strains w° (interleaved).
    pub fn rest(&self) -> Vec<f64> {
        let n = self.n_elements();
        let mut w = vec![0.0; 6 * n - 3];
        for j in 0..n {
            w[6 * j..6 * j + 3].copy_from_slice(&self.nu0[j]);
            if j + 1 < n {
                w[6 * j + 3..6 * j + 6].copy_from_slice(&self.kappa0[j]);
            }
        }
        w
    }

    /// The last solution (interleaved strains).
    pub fn solution(&self) -> &[f64] {
        &self.w
    }

    /// ν_j of `w`.
    pub fn nu(w: &[f64], j: usize) -> Vec3 {
        [w[6 * j], w[6 * j + 1], w[6 * j + 2]]
    }

    /// κ_k of `w`.
    pub fn kappa(w: &[f64], k: usize) -> Vec3 {
        [w[6 * k + 3], w[6 * k + 4], w[6 * k + 5]]
    }

    /// Check activations: group-major `[7][n]`, finite, in [0, 1].
    pub fn check_activations(&self, a: &[f64]) -> Result<(), MuscleStaticsError> {
        let n = self.n_elements();
        if a.len() != N_GROUPS * n {
            return Err(MuscleStaticsError::BadActivation(format!(
                "length {} (expected 7 × {n} = {})",
                a.len(),
                N_GROUPS * n
            )));
        }
        if let Some((i, v)) = a
            .iter()
            .enumerate()
            .find(|(_, v)| !(0.0..=1.0).contains(*v))
        {
            return Err(MuscleStaticsError::BadActivation(format!(
                "group {} element {} = {v} is outside [0, 1]",
                i / n,
                i % n
            )));
        }
        Ok(())
    }

    // Kernel inputs from w, then the muscle resultants.
    fn load(&mut self, w: &[f64], a: &[f64]) {
        let n = self.n_elements();
        let lr = &self.model.rest_length;
        for j in 0..n {
            let v = Self::nu(w, j);
            self.sigma[0][j] = v[0];
            self.sigma[1][j] = v[1];
            self.sigma[2][j] = v[2] - 1.0;
            self.dil[j] = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        }
        for k in 0..n - 1 {
            let v = Self::kappa(w, k);
            for c in 0..3 {
                self.kappa[c][k] = v[c];
            }
            self.eps[k] = 0.5 * (lr[k] * self.dil[k] + lr[k + 1] * self.dil[k + 1])
                / self.model.rest_voronoi_length[k];
        }
        let act: [&[f64]; N_GROUPS] = std::array::from_fn(|g| &a[g * n..(g + 1) * n]);
        let strains = Strains {
            sigma: [&self.sigma[0], &self.sigma[1], &self.sigma[2]],
            dilatation: &self.dil,
            kappa: [&self.kappa[0], &self.kappa[1], &self.kappa[2]],
            voronoi_dilatation: &self.eps,
        };
        let [n0, n1, n2] = &mut self.n_mu;
        let [t0, t1, t2] = &mut self.tau_mu;
        let mut out = Resultants {
            force: [n0, n1, n2],
            couple: [t0, t1, t2],
            moment: None,
        };
        self.muscles
            .resultants(act, &strains, &mut self.scratch, &mut out);
    }

    /// The residual (eq. 4.1) of strains `w` under activations `a` (group-major `[7][n]`),
    /// interleaved like `w`, into `r`.
    pub fn residual(&mut self, w: &[f64], a: &[f64], r: &mut [f64]) {
        self.load(w, a);
        let n = self.n_elements();
        for j in 0..n {
            let s = self.model.shear_stiffness[j];
            let v = Self::nu(w, j);
            let inv_e = 1.0 / self.dil[j];
            for c in 0..3 {
                r[6 * j + c] = s[c] * (v[c] - self.nu0[j][c]) * inv_e + self.n_mu[c][j];
            }
        }
        for k in 0..n - 1 {
            let b = self.model.bend_stiffness[k];
            let v = Self::kappa(w, k);
            let e = self.eps[k];
            let inv = 1.0 / (e * e * e);
            for c in 0..3 {
                r[6 * k + 3 + c] = b[c] * (v[c] - self.kappa0[k][c]) * inv + self.tau_mu[c][k];
            }
        }
    }

    /// Scaled residual ρ_R = max(max_j |S_j⁻¹ R^ν_j|∞, L0 max_k |B_k⁻¹ R^κ_k|∞).
    pub fn scaled_norm(&self, r: &[f64]) -> f64 {
        let n = self.n_elements();
        let l0 = self.model.length();
        let mut m: f64 = 0.0;
        for j in 0..n {
            for c in 0..3 {
                m = m.max((r[6 * j + c] / self.model.shear_stiffness[j][c]).abs());
            }
        }
        for k in 0..n - 1 {
            for c in 0..3 {
                m = m.max(l0 * (r[6 * k + 3 + c] / self.model.bend_stiffness[k][c]).abs());
            }
        }
        if m.is_nan() {
            f64::INFINITY
        } else {
            m
        }
    }

    /// The coloured central-difference Jacobian ∂R/∂w at `w` into `jac` (band 11): columns
    /// 23 apart are perturbed together, ±h, 46 residual evaluations.
    pub fn jacobian_fd(&mut self, w: &[f64], a: &[f64], jac: &mut BandMatrix) {
        let m = self.n_unknowns();
        let h = self.config.fd_step;
        jac.clear();
        let mut wp = w.to_vec();
        let mut rp = std::mem::take(&mut self.rp);
        let mut rm = std::mem::take(&mut self.rm);
        for colour in 0..COLOURS {
            for col in (colour..m).step_by(COLOURS) {
                wp[col] = w[col] + h;
            }
            self.residual(&wp, a, &mut rp);
            for col in (colour..m).step_by(COLOURS) {
                wp[col] = w[col] - h;
            }
            self.residual(&wp, a, &mut rm);
            for col in (colour..m).step_by(COLOURS) {
                wp[col] = w[col];
                let lo = col.saturating_sub(HALF_BAND);
                let hi = (col + HALF_BAND).min(m - 1);
                for row in lo..=hi {
                    jac.set(row, col, (rp[row] - rm[row]) / (2.0 * h));
                }
            }
        }
        self.rp = rp;
        self.rm = rm;
    }

    /// Solve the equilibrium for activations `a` (group-major `[7][n]`), from `warm` or, if
    /// None, from the last solution of this solver (from w° on the first call). The solution is
    /// then `solution()`.
    pub fn solve(
        &mut self,
        a: &[f64],
        warm: Option<&[f64]>,
    ) -> Result<EquilibriumReport, MuscleStaticsError> {
        self.check_activations(a)?;
        let m = self.n_unknowns();
        let mut w = std::mem::take(&mut self.w);
        if let Some(x) = warm {
            assert_eq!(x.len(), m, "warm start length");
            w.copy_from_slice(x);
        }
        if !w.iter().all(|v| v.is_finite()) {
            w = self.rest();
        }
        let result = self.newton(&mut w, a).or_else(|(it, _)| {
            // Fallback: COOMM's Picard iteration from the rest strains, then Newton again.
            w = self.rest();
            let p = self.picard(&mut w, a, 1e-6);
            match self.newton(&mut w, a) {
                Ok(mut rep) => {
                    rep.picard_iterations = p;
                    rep.newton_iterations += it;
                    Ok(rep)
                }
                Err((it2, res)) => Err(MuscleStaticsError::EquilibriumFailed {
                    iteration: it + p + it2,
                    residual: res,
                }),
            }
        });
        if result.is_err() {
            w = self.rest();
        }
        self.w = w;
        result
    }

    fn newton(&mut self, w: &mut [f64], a: &[f64]) -> Result<EquilibriumReport, (usize, f64)> {
        let tol = self.config.tolerance;
        let mut r = std::mem::take(&mut self.r);
        let mut dw = std::mem::take(&mut self.dw);
        let mut trial = std::mem::take(&mut self.trial);
        let mut jac = std::mem::replace(&mut self.jac, BandMatrix::new(0, 0, 0));
        self.residual(w, a, &mut r);
        let mut rho = self.scaled_norm(&r);
        let mut it = 0;
        let mut ok = rho <= tol;
        while !ok && it < self.config.max_newton {
            it += 1;
            self.jacobian_fd(w, a, &mut jac);
            if jac.factor().is_err() {
                break;
            }
            for (d, v) in dw.iter_mut().zip(&r) {
                *d = -v;
            }
            jac.solve(&mut dw);
            let mut alpha = 1.0;
            let mut accepted = false;
            for _ in 0..30 {
                for ((t, x), d) in trial.iter_mut().zip(w.iter()).zip(&dw) {
                    *t = x + alpha * d;
                }
                self.residual(&trial, a, &mut r);
                let rt = self.scaled_norm(&r);
                if rt < rho {
                    rho = rt;
                    accepted = true;
                    w.copy_from_slice(&trial);
                    break;
                }
                alpha *= 0.5;
            }
            if !accepted {
                break;
            }
            ok = rho <= tol;
        }
        self.r = r;
        self.dw = dw;
        self.trial = trial;
        self.jac = jac;
        if ok {
            Ok(EquilibriumReport {
                newton_iterations: it,
                picard_iterations: 0,
                residual: rho,
            })
        } else {
            Err((it, rho))
        }
    }

    /// COOMM's fixed-point iteration (spec §4.2): ν_j = ν°_j − e_j S_j⁻¹ n^μ_j,
    /// κ_k = κ°_k − ε_k³ B_k⁻¹ τ^μ_k with the muscle loads and dilatations of the previous
    /// iterate, until ρ_R ≤ `tol` or `config.max_picard` iterations. Returns the iterations.
    pub fn picard(&mut self, w: &mut [f64], a: &[f64], tol: f64) -> usize {
        let n = self.n_elements();
        let mut r = std::mem::take(&mut self.r);
        let mut it = 0;
        while it < self.config.max_picard {
            self.residual(w, a, &mut r);
            if self.scaled_norm(&r) <= tol {
                break;
            }
            it += 1;
            for j in 0..n {
                let s = self.model.shear_stiffness[j];
                for c in 0..3 {
                    w[6 * j + c] = self.nu0[j][c] - self.dil[j] * self.n_mu[c][j] / s[c];
                }
            }
            for k in 0..n - 1 {
                let b = self.model.bend_stiffness[k];
                let e3 = self.eps[k] * self.eps[k] * self.eps[k];
                for c in 0..3 {
                    w[6 * k + 3 + c] = self.kappa0[k][c] - e3 * self.tau_mu[c][k] / b[c];
                }
            }
        }
        self.r = r;
        it
    }

    /// The pose of strains `w` by the forward map: Q_{k+1} = exp(−D̂_k[κ_k]×) Q_k,
    /// x_{j+1} = x_j + l̂_j Q_jᵀ ν_j, from the clamped base (velocities zero).
    pub fn pose(&self, w: &[f64]) -> RodState {
        let n = self.n_elements();
        let mut director = vec![self.base_frame; n];
        for k in 0..n - 1 {
            let d = self.model.rest_voronoi_length[k];
            let kap = Self::kappa(w, k);
            let r = exp_neg_skew([d * kap[0], d * kap[1], d * kap[2]]);
            director[k + 1] = mat_mul(&r, &director[k]);
        }
        let mut position = vec![self.base_position; n + 1];
        for j in 0..n {
            let v = Self::nu(w, j);
            let l = self.model.rest_length[j];
            let t = mat_t_vec(&director[j], [l * v[0], l * v[1], l * v[2]]);
            for c in 0..3 {
                position[j + 1][c] = position[j][c] + t[c];
            }
        }
        RodState {
            time: 0.0,
            position,
            velocity: vec![[0.0; 3]; n + 1],
            director,
            omega: vec![[0.0; 3]; n],
        }
    }
}
