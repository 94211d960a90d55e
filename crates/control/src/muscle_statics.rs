//! Statics of the muscular arm for given activations (muscles-3d spec §4): the exact discrete
//! equilibrium of the stepper, R^ν_j = S_j(ν_j − ν°_j)/e_j + n^μ_j = 0 per element and
//! R^κ_k = B_k(κ_k − κ°_k)/ε_k³ + τ^μ_k = 0 per Voronoi point (eq. 4.1), in the strains
//! w = (ν_0, κ_0, ν_1, …, κ_{n−2}, ν_{n−1}) (interleaved, 6n − 3 unknowns), solved by Newton with a
//! banded Jacobian (half-bandwidth 11) and a banded LU; warm starts; COOMM's Picard iteration as
//! the fallback; the pose by the forward map. The muscle loads come from the physics crate's
//! kernel (`MuscleModel::resultants`), the same code the stepper runs.
//!
//! The Jacobian is the analytic one of spec §4.2 (chain rule through the kernel, assembled in
//! the band); the coloured central-difference one (23 colours, 46 residual evaluations) is kept
//! as its test oracle and as an option (`JacobianKind::FiniteDifference`).

use crate::banded::BandMatrix;
use octoarm_physics::math::{add, cross, dot, exp_neg_skew, mat_mul, mat_t_vec, norm, scale, sub};
use octoarm_physics::muscles::{FibreKind, MuscleScratch, Resultants, Strains};
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
    /// Central-difference step of the finite-difference Jacobian. Default 1e-7.
    pub fd_step: f64,
    /// Which equilibrium Jacobian Newton (and the design's adjoint) uses. Default analytic.
    pub jacobian: JacobianKind,
    /// Chord iterations (spec §4.2): at most this many consecutive steps with the last factored
    /// Jacobian (from the previous Newton iteration, the previous solve or the design's adjoint)
    /// before a fresh one; a chord step is kept only if it cuts ρ_R by `chord_contraction`.
    /// Default 5; 0 = pure Newton.
    pub max_chord: usize,
    /// Required factor of decrease of ρ_R per chord step. Default 0.25.
    pub chord_contraction: f64,
}

/// How the equilibrium Jacobian ∂R/∂w is formed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum JacobianKind {
    /// Analytic (spec §4.2): one kernel-like pass, ≈ the cost of a few residuals.
    #[default]
    Analytic,
    /// Coloured central differences (23 colours, 46 residuals, step `fd_step`): the oracle.
    FiniteDifference,
}

impl Default for StaticsConfig {
    fn default() -> Self {
        Self {
            tolerance: 1e-12,
            max_newton: 30,
            max_picard: 20_000,
            fd_step: 1e-7,
            jacobian: JacobianKind::Analytic,
            max_chord: 5,
            chord_contraction: 0.25,
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
    /// Newton iterations (each with a fresh Jacobian).
    pub newton_iterations: usize,
    /// Chord iterations (with a Jacobian factored earlier).
    pub chord_iterations: usize,
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
    // Analytic Jacobian scratch: per element the muscle blocks ∂n_j/∂(ν_{j−1}, ν_j, ν_{j+1},
    // κ_{j−1}, κ_j) and ∂c_j/∂(same), c_j = Σ x × n; ν_j/e_j; per fibre x, ∂x/∂e (elements),
    // x̄, q, ∂q/∂e_k, ∂q/∂e_{k+1} (Voronoi points).
    blocks: Vec<[Mat3; 10]>,
    // Per element, summed over fibres: ∂n_j/∂e_i and ∂c_j/∂e_i, i = j − 1, j, j + 1.
    grad_e: Vec<[Vec3; 6]>,
    unit_nu: Vec<Vec3>,
    root_inv_e: Vec<(f64, f64)>,
    inv_de: Vec<f64>,
    fib_x: Vec<Vec3>,
    fib_dx: Vec<Vec3>,
    fib_xbar: Vec<Vec3>,
    fib_q: Vec<Vec3>,
    fib_dqa: Vec<Vec3>,
    fib_dqb: Vec<Vec3>,
    // Whether `jac` holds a factored Jacobian (of some nearby w and a: chord steps may use it).
    lu_ready: bool,
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
            blocks: vec![[[[0.0; 3]; 3]; 10]; n],
            grad_e: vec![[[0.0; 3]; 6]; n],
            root_inv_e: vec![(1.0, 1.0); n],
            inv_de: vec![1.0; n - 1],
            unit_nu: vec![[0.0; 3]; n],
            fib_x: vec![[0.0; 3]; n],
            fib_dx: vec![[0.0; 3]; n],
            fib_xbar: vec![[0.0; 3]; n - 1],
            fib_q: vec![[0.0; 3]; n - 1],
            fib_dqa: vec![[0.0; 3]; n - 1],
            fib_dqb: vec![[0.0; 3]; n - 1],
            lu_ready: false,
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

    /// The analytic Jacobian ∂R/∂w of the residual (eq. 4.1) at `w` under activations `a`
    /// (group-major `[7][n]`) into `jac` (band 11), spec §4.2: the elastic part directly, the
    /// muscle part by the chain rule through the kernel (2.1)–(2.5) — the fibre's strain ν^m,
    /// its length and force–length curve, the 1/e area, the current offsets r̂/√e and the
    /// current Voronoi length in x' — with e_j = |ν_j| and ε_k = (l̂_k e_k + l̂_{k+1} e_{k+1})/(2D̂_k)
    /// functions of w. At a kink of the cubic force–length curve it takes the branch in force
    /// (`ForceLength::derivative`). The coloured difference Jacobian `jacobian_fd` is its test
    /// oracle. No allocation.
    pub fn jacobian(&mut self, w: &[f64], a: &[f64], jac: &mut BandMatrix) {
        // Strains, e, ε as the residual sees them (the resultants themselves are not needed).
        self.load(w, a);
        let n = self.n_elements();
        let nk = n - 1;
        let lr = &self.model.rest_length;
        let dr = &self.model.rest_voronoi_length;
        let blk = &mut self.blocks;
        for b in blk.iter_mut() {
            *b = [[[0.0; 3]; 3]; 10];
        }
        for g in self.grad_e.iter_mut() {
            *g = [[0.0; 3]; 6];
        }
        // de_j/dν_j = ν_j/e_j.
        // e^(−1/2) and 1/e per element, shared by all fibres (square roots and divisions are
        // most of this function's cost).
        let te: &mut Vec<Vec3> = &mut self.unit_nu;
        for j in 0..n {
            let v = Self::nu(w, j);
            let e = self.dil[j];
            let inv_e = 1.0 / e;
            te[j] = [v[0] * inv_e, v[1] * inv_e, v[2] * inv_e];
            self.root_inv_e[j] = (1.0 / e.sqrt(), inv_e);
        }
        // 1/(D̂_k ε_k) per Voronoi point.
        for k in 0..nk {
            self.inv_de[k] = 1.0 / (0.5 * (lr[k] * self.dil[k] + lr[k + 1] * self.dil[k + 1]));
        }
        for m in &self.muscles.members {
            let act = &a[m.group * n..(m.group + 1) * n];
            if act.iter().all(|&v| v == 0.0) {
                continue;
            }
            let transverse = m.kind == FibreKind::Transverse;
            // Offsets at the current radius and their e-derivatives, per element.
            let x = &mut self.fib_x;
            let dx = &mut self.fib_dx;
            for j in 0..n {
                let (root, inv_e) = self.root_inv_e[j];
                x[j] = [m.offset[0][j] * root, m.offset[1][j] * root, 0.0];
                dx[j] = [-0.5 * x[j][0] * inv_e, -0.5 * x[j][1] * inv_e, 0.0];
            }
            // Per Voronoi point: x̄, q and ∂q/∂e_k, ∂q/∂e_{k+1}.
            let (xb, q, dqa, dqb) = (
                &mut self.fib_xbar,
                &mut self.fib_q,
                &mut self.fib_dqa,
                &mut self.fib_dqb,
            );
            for k in 0..nk {
                let kap = [self.kappa[0][k], self.kappa[1][k], self.kappa[2][k]];
                let inv = self.inv_de[k];
                xb[k] = scale(0.5, add(x[k], x[k + 1]));
                let xp = scale(inv, sub(x[k + 1], x[k]));
                q[k] = add(cross(kap, xb[k]), xp);
                // ∂x'/∂e_k = −dx_k/de_k /(D̂ε) − x' l̂_k/(2D̂ε), likewise for k + 1.
                dqa[k] = add(
                    cross(kap, scale(0.5, dx[k])),
                    sub(scale(-inv, dx[k]), scale(0.5 * lr[k] * inv, xp)),
                );
                dqb[k] = add(
                    cross(kap, scale(0.5, dx[k + 1])),
                    sub(scale(inv, dx[k + 1]), scale(0.5 * lr[k + 1] * inv, xp)),
                );
            }
            for j in 0..n {
                let mut vm = Self::nu(w, j);
                // ∂ν^m_j/∂e_{j−1}, ∂e_j, ∂e_{j+1}.
                let mut dve = [[0.0; 3]; 3];
                if j > 0 {
                    vm = add(vm, scale(0.5, q[j - 1]));
                    dve[0] = scale(0.5, dqa[j - 1]);
                    dve[1] = scale(0.5, dqb[j - 1]);
                }
                if j < nk {
                    vm = add(vm, scale(0.5, q[j]));
                    dve[1] = add(dve[1], scale(0.5, dqa[j]));
                    dve[2] = scale(0.5, dqb[j]);
                }
                let len = norm(vm);
                let inv_len = 1.0 / len;
                let t = scale(inv_len, vm);
                let (ell, dell) = if transverse {
                    let r = 1.0 / len.sqrt();
                    (r, -0.5 * r * inv_len)
                } else {
                    (len, 1.0)
                };
                let lam = ell * m.inv_rest_length[j];
                let amp = act[j] * m.max_force[j] * self.root_inv_e[j].1;
                let f = amp * m.force_length.value(lam);
                let df = amp * m.force_length.derivative(lam) * m.inv_rest_length[j] * dell;
                let nvec = scale(f, t);
                // M = ∂n/∂ν^m = F/|ν^m| (I − t tᵀ) + dF/d|ν^m| t tᵀ.
                // M = α I + β t tᵀ: applied to vectors and skew matrices without forming
                // products of 3 × 3 matrices.
                let (alpha, beta) = (f * inv_len, df - f * inv_len);
                let m_vec = |v: Vec3| add(scale(alpha, v), scale(beta * dot(t, v), t));
                let mut mm = [[0.0; 3]; 3];
                for r in 0..3 {
                    for c in 0..3 {
                        mm[r][c] = beta * t[r] * t[c];
                    }
                    mm[r][r] += alpha;
                }
                let xj = x[j];
                // ∂n/∂e_i (i = j−1, j, j+1) and ∂c/∂e_i, c = x_j × n_j.
                let mut g = [[0.0; 3]; 3];
                let mut gc = [[0.0; 3]; 3];
                for i in 0..3 {
                    g[i] = m_vec(dve[i]);
                    if i == 1 {
                        g[i] = sub(g[i], scale(self.root_inv_e[j].1, nvec));
                    }
                    gc[i] = cross(xj, g[i]);
                    if i == 1 {
                        gc[i] = add(gc[i], cross(dx[j], nvec));
                    }
                }
                // ∂n/∂κ_{j−1}, ∂n/∂κ_j: M [u]× with u = −½x̄, i.e. α[u]× + β t (t × u)ᵀ;
                // ∂c/∂κ = [x_j]× ∂n/∂κ (column by column).
                let b = &mut blk[j];
                for (kk, slot) in [(j.wrapping_sub(1), 3), (j, 4)] {
                    if kk >= nk {
                        continue;
                    }
                    let u = scale(-0.5, xb[kk]);
                    let su = skew(u);
                    let tu = cross(t, u);
                    let mut nk_ = [[0.0; 3]; 3];
                    for r in 0..3 {
                        for c in 0..3 {
                            nk_[r][c] = alpha * su[r][c] + beta * t[r] * tu[c];
                        }
                    }
                    acc(&mut b[slot], &nk_, 1.0);
                    acc_cross(&mut b[5 + slot], xj, &nk_);
                }
                // ∂/∂ν_i = (direct at i = j) + ∂/∂e_i (ν_i/e_i)ᵀ: the e-parts summed over the
                // fibres first, the outer products once per element below.
                acc(&mut b[1], &mm, 1.0);
                acc_cross(&mut b[6], xj, &mm);
                let ge = &mut self.grad_e[j];
                for i in 0..3 {
                    ge[i] = add(ge[i], g[i]);
                    ge[3 + i] = add(ge[3 + i], gc[i]);
                }
            }
        }
        // Assemble: muscle blocks plus the elastic part.
        jac.clear();
        let te = &self.unit_nu;
        for j in 0..n {
            let b = &mut blk[j];
            let ge = &self.grad_e[j];
            for i in 0..3 {
                let Some(col) = (j + i).checked_sub(1).filter(|&c| c < n) else {
                    continue;
                };
                let ti = te[col];
                for r in 0..3 {
                    for c in 0..3 {
                        b[i][r][c] += ge[i][r] * ti[c];
                        b[5 + i][r][c] += ge[3 + i][r] * ti[c];
                    }
                }
            }
            let b = &blk[j];
            let cols_nu = |i: usize| (j + i).checked_sub(1).filter(|&c| c < n);
            // Rows R^ν_j.
            for i in 0..3 {
                if let Some(c) = cols_nu(i) {
                    put(jac, 6 * j, 6 * c, &b[i], 1.0);
                }
            }
            for (slot, kk) in [(3, j.wrapping_sub(1)), (4, j)] {
                if kk < nk {
                    put(jac, 6 * j, 6 * kk + 3, &b[slot], 1.0);
                }
            }
            // c_j enters τ_{j−1} and τ_j with weight ½.
            for k in [j.wrapping_sub(1), j] {
                if k >= nk {
                    continue;
                }
                for i in 0..3 {
                    if let Some(c) = cols_nu(i) {
                        put(jac, 6 * k + 3, 6 * c, &b[5 + i], 0.5);
                    }
                }
                for (slot, kk) in [(3, j.wrapping_sub(1)), (4, j)] {
                    if kk < nk {
                        put(jac, 6 * k + 3, 6 * kk + 3, &b[5 + slot], 0.5);
                    }
                }
            }
            // Elastic: ∂(S(ν − ν°)/e)/∂ν_j = S/e − S(ν − ν°) tᵀ/e².
            let s = self.model.shear_stiffness[j];
            let v = Self::nu(w, j);
            let e = self.dil[j];
            for r in 0..3 {
                let sr = s[r] * (v[r] - self.nu0[j][r]) / (e * e);
                for c in 0..3 {
                    let d = if r == c { s[r] / e } else { 0.0 };
                    jac.add(6 * j + r, 6 * j + c, d - sr * te[j][c]);
                }
            }
        }
        // Elastic: ∂(B(κ − κ°)/ε³)/∂κ_k = B/ε³; through ε: −3B(κ − κ°)/ε⁴ · l̂_i/(2D̂_k) (ν_i/e_i)ᵀ.
        for k in 0..nk {
            let bs = self.model.bend_stiffness[k];
            let v = Self::kappa(w, k);
            let ep = self.eps[k];
            let inv3 = 1.0 / (ep * ep * ep);
            for r in 0..3 {
                jac.add(6 * k + 3 + r, 6 * k + 3 + r, bs[r] * inv3);
                let d = -3.0 * bs[r] * (v[r] - self.kappa0[k][r]) * inv3 / ep;
                for (i, l) in [(k, lr[k]), (k + 1, lr[k + 1])] {
                    let de = d * l / (2.0 * dr[k]);
                    for c in 0..3 {
                        jac.add(6 * k + 3 + r, 6 * i + c, de * te[i][c]);
                    }
                }
            }
        }
    }

    /// The equilibrium Jacobian of the kind `config.jacobian` at `w` under `a` into `jac`.
    pub fn equilibrium_jacobian(&mut self, w: &[f64], a: &[f64], jac: &mut BandMatrix) {
        match self.config.jacobian {
            JacobianKind::Analytic => self.jacobian(w, a, jac),
            JacobianKind::FiniteDifference => self.jacobian_fd(w, a, jac),
        }
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
        let (mut it, mut chords, mut run) = (0, 0, 0);
        let mut ok = rho <= tol;
        while !ok && it < self.config.max_newton {
            // A chord step with the factored Jacobian at hand, kept only if it contracts enough.
            if self.lu_ready && run < self.config.max_chord {
                for (d, v) in dw.iter_mut().zip(&r) {
                    *d = -v;
                }
                jac.solve(&mut dw);
                for ((t, x), d) in trial.iter_mut().zip(w.iter()).zip(&dw) {
                    *t = x + d;
                }
                self.residual(&trial, a, &mut dw);
                let rt = self.scaled_norm(&dw);
                if rt <= self.config.chord_contraction * rho {
                    chords += 1;
                    run += 1;
                    rho = rt;
                    w.copy_from_slice(&trial);
                    r.copy_from_slice(&dw);
                    ok = rho <= tol;
                    continue;
                }
            }
            // A Newton step: fresh Jacobian at w, halving while ρ_R does not decrease.
            it += 1;
            run = 0;
            self.equilibrium_jacobian(w, a, &mut jac);
            if jac.factor().is_err() {
                self.lu_ready = false;
                break;
            }
            self.lu_ready = true;
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
                chord_iterations: chords,
                picard_iterations: 0,
                residual: rho,
            })
        } else {
            Err((it + chords, rho))
        }
    }

    /// The adjoint solve of the design (spec §5.3): Kᵀ x = `rhs` in place, with the equilibrium
    /// Jacobian K at the last solution under activations `a`, formed (kind `config.jacobian`) and
    /// factored here; the factors then serve the next solve's chord steps.
    pub fn adjoint_solve(
        &mut self,
        a: &[f64],
        rhs: &mut [f64],
    ) -> Result<(), crate::banded::SingularMatrix> {
        let w = std::mem::take(&mut self.w);
        let mut jac = std::mem::replace(&mut self.jac, BandMatrix::new(0, 0, 0));
        self.equilibrium_jacobian(&w, a, &mut jac);
        let factored = jac.factor();
        self.lu_ready = factored.is_ok();
        if factored.is_ok() {
            jac.solve_transposed(rhs);
        }
        self.jac = jac;
        self.w = w;
        factored
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

/// [v]× (so that [v]× u = v × u).
fn skew(v: Vec3) -> Mat3 {
    [[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]]
}

/// dst += [x]× M (each column of M crossed with x).
fn acc_cross(dst: &mut Mat3, x: Vec3, m: &Mat3) {
    for c in 0..3 {
        let v = cross(x, [m[0][c], m[1][c], m[2][c]]);
        for r in 0..3 {
            dst[r][c] += v[r];
        }
    }
}

/// dst += s · src.
fn acc(dst: &mut Mat3, src: &Mat3, s: f64) {
    for r in 0..3 {
        for c in 0..3 {
            dst[r][c] += s * src[r][c];
        }
    }
}

/// Add s · block to the 3 × 3 block of `jac` at (row0, col0).
fn put(jac: &mut BandMatrix, row0: usize, col0: usize, block: &Mat3, s: f64) {
    for r in 0..3 {
        for c in 0..3 {
            jac.add(row0 + r, col0 + c, s * block[r][c]);
        }
    }
}
