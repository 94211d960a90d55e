//! Strains and internal loads of the discrete Cosserat rod (spec §2–§4): element stretch/shear,
//! Voronoi curvature/twist, the constitutive law, nodal forces and element torques. One fused
//! kernel serves the stepper (with the velocity-dependent torques) and `ElasticLoads` (without),
//! which controllers use to evaluate loads for other rest strains.

use crate::math::{cross, dot, log_relative, mat_t_vec, mat_vec, Mat3, Vec3};
use crate::model::RodModel;
use crate::state::RodState;

/// Scratch arrays of one internal-load evaluation; allocated once, reused every step.
#[derive(Debug, Clone)]
pub struct InternalLoads {
    /// Unit tangent t [-], lab frame, per element.
    pub tangent: Vec<Vec3>,
    /// Dilatation e = l/l̂, per element.
    pub dilatation: Vec<f64>,
    /// Shear/stretch strain σ (material), per element.
    pub sigma: Vec<Vec3>,
    /// Internal stress n = S(σ − σ°) [N] (material, reference form), per element.
    pub stress: Vec<Vec3>,
    /// Curvature/twist κ [1/m] (material), per interior point.
    pub kappa: Vec<Vec3>,
    /// Voronoi dilatation ε, per interior point.
    pub voronoi_dilatation: Vec<f64>,
    /// Internal couple τ = B(κ − κ°) [N m] (material, reference form), per interior point.
    pub couple: Vec<Vec3>,
    /// Net internal force on each node [N], lab frame, n + 1 entries.
    pub force: Vec<Vec3>,
    /// Net internal torque on each element [N m], material frame, n entries.
    pub torque: Vec<Vec3>,
    // f_j = Qᵀn/e, padded to n + 1 with f[n] = 0.
    elem_force: Vec<Vec3>,
    // τ/ε³ and ½ D̂ κ×τ/ε³, padded to n + 1: slot k + 1 holds Voronoi point k.
    couple_pad: Vec<Vec3>,
    coupling_pad: Vec<Vec3>,
    // Element length l and 1/l, and 1/ε³ per interior point: the square roots and divisions,
    // computed in their own short loops so that they vectorise (spec §14).
    length: Vec<f64>,
    inv_length: Vec<f64>,
    inv_eps_cubed: Vec<f64>,
}

impl InternalLoads {
    /// Buffers for a rod of `n` elements.
    pub fn new(n: usize) -> Self {
        Self {
            tangent: vec![[0.0; 3]; n],
            dilatation: vec![1.0; n],
            sigma: vec![[0.0; 3]; n],
            stress: vec![[0.0; 3]; n],
            kappa: vec![[0.0; 3]; n - 1],
            voronoi_dilatation: vec![1.0; n - 1],
            couple: vec![[0.0; 3]; n - 1],
            force: vec![[0.0; 3]; n + 1],
            torque: vec![[0.0; 3]; n],
            elem_force: vec![[0.0; 3]; n + 1],
            couple_pad: vec![[0.0; 3]; n + 1],
            coupling_pad: vec![[0.0; 3]; n + 1],
            length: vec![0.0; n],
            inv_length: vec![0.0; n],
            inv_eps_cubed: vec![0.0; n - 1],
        }
    }

    /// Evaluate strains, the internal nodal forces and element torques of `s` with the given rest
    /// strains. `with_velocity_terms` adds the gyroscopic and unsteady-dilatation torques (eq. 4.3);
    /// `energy_consistent` adds the tension corrections of eq. 4.5.
    pub fn compute(
        &mut self,
        model: &RodModel,
        s: &RodState,
        rest_sigma: &[Vec3],
        rest_kappa: &[Vec3],
        with_velocity_terms: bool,
        energy_consistent: bool,
    ) {
        let n = model.n_elements;
        let x = &s.position[..n + 1];
        let v = &s.velocity[..n + 1];
        let q = &s.director[..n];
        let w = &s.omega[..n];
        let lr = &model.rest_length[..n];
        let inv_lr = &model.inv_rest_length[..n];
        let stiff = &model.shear_stiffness[..n];
        let inertia = &model.inertia[..n];
        let s0 = &rest_sigma[..n];
        let tangent = &mut self.tangent[..n];
        let dil = &mut self.dilatation[..n];
        let sigma = &mut self.sigma[..n];
        let stress = &mut self.stress[..n];
        let f = &mut self.elem_force[..n + 1];
        let torque = &mut self.torque[..n];
        let len = &mut self.length[..n];
        let inv_len = &mut self.inv_length[..n];

        // Lengths and dilatations first: a loop of square roots and divisions only, which LLVM
        // vectorises, unlike the long element loop below.
        for j in 0..n {
            let dx = [
                x[j + 1][0] - x[j][0],
                x[j + 1][1] - x[j][1],
                x[j + 1][2] - x[j][2],
            ];
            let l = dot(dx, dx).sqrt();
            len[j] = l;
            inv_len[j] = 1.0 / l;
            dil[j] = l * inv_lr[j];
        }

        // Loop A: geometry, shear/stretch strain (eq. 2.2), stress, element force (eq. 4.1) and
        // the element-local torques (shear–stretch coupling, gyroscopic, unsteady dilatation).
        for j in 0..n {
            let dx = [
                x[j + 1][0] - x[j][0],
                x[j + 1][1] - x[j][1],
                x[j + 1][2] - x[j][2],
            ];
            let inv_l = inv_len[j];
            let t = [dx[0] * inv_l, dx[1] * inv_l, dx[2] * inv_l];
            let e = dil[j];
            let inv_e = lr[j] * inv_l;
            let qt = mat_vec(&q[j], t);
            let sg = [e * qt[0], e * qt[1], e * qt[2] - 1.0];
            let nn = [
                stiff[j][0] * (sg[0] - s0[j][0]),
                stiff[j][1] * (sg[1] - s0[j][1]),
                stiff[j][2] * (sg[2] - s0[j][2]),
            ];
            let fl = mat_t_vec(&q[j], nn);
            f[j] = [fl[0] * inv_e, fl[1] * inv_e, fl[2] * inv_e];
            let c = cross(qt, nn);
            let mut tq = [lr[j] * c[0], lr[j] * c[1], lr[j] * c[2]];
            if with_velocity_terms {
                let dv = [
                    v[j + 1][0] - v[j][0],
                    v[j + 1][1] - v[j][1],
                    v[j + 1][2] - v[j][2],
                ];
                let edot = dot(t, dv) * inv_lr[j];
                let g = [
                    inertia[j][0] * w[j][0] * inv_e,
                    inertia[j][1] * w[j][1] * inv_e,
                    inertia[j][2] * w[j][2] * inv_e,
                ];
                let gw = cross(g, w[j]);
                let r = edot * inv_e;
                tq = [
                    tq[0] + gw[0] + g[0] * r,
                    tq[1] + gw[1] + g[1] * r,
                    tq[2] + gw[2] + g[2] * r,
                ];
            }
            tangent[j] = t;
            sigma[j] = sg;
            stress[j] = nn;
            torque[j] = tq;
        }
        f[n] = [0.0; 3];

        // Loop B: curvature (eq. 2.3), Voronoi dilatation, couple (eq. 3.3), scaled by 1/ε³.
        let nk = n - 1;
        let dr = &model.rest_voronoi_length[..nk];
        let inv_dr = &model.inv_rest_voronoi[..nk];
        let bend = &model.bend_stiffness[..nk];
        let k0 = &rest_kappa[..nk];
        let kappa = &mut self.kappa[..nk];
        let eps_out = &mut self.voronoi_dilatation[..nk];
        let couple = &mut self.couple[..nk];
        let tb = &mut self.couple_pad[..n + 1];
        let hh = &mut self.coupling_pad[..n + 1];
        let inv_e3 = &mut self.inv_eps_cubed[..nk];
        for k in 0..nk {
            let eps = 0.5 * (dil[k] * lr[k] + dil[k + 1] * lr[k + 1]) * inv_dr[k];
            eps_out[k] = eps;
            inv_e3[k] = 1.0 / (eps * eps * eps);
        }
        for k in 0..nk {
            let (theta, _) = log_relative(&q[k + 1], &q[k]);
            let kap = [
                -theta[0] * inv_dr[k],
                -theta[1] * inv_dr[k],
                -theta[2] * inv_dr[k],
            ];
            let tau = [
                bend[k][0] * (kap[0] - k0[k][0]),
                bend[k][1] * (kap[1] - k0[k][1]),
                bend[k][2] * (kap[2] - k0[k][2]),
            ];
            let kt = cross(kap, tau);
            let hf = 0.5 * dr[k] * inv_e3[k];
            tb[k + 1] = [tau[0] * inv_e3[k], tau[1] * inv_e3[k], tau[2] * inv_e3[k]];
            hh[k + 1] = [kt[0] * hf, kt[1] * hf, kt[2] * hf];
            kappa[k] = kap;
            couple[k] = tau;
        }
        tb[0] = [0.0; 3];
        hh[0] = [0.0; 3];
        tb[n] = [0.0; 3];
        hh[n] = [0.0; 3];

        if energy_consistent {
            // Eq. 4.5: tension corrections that make the elastic loads the gradient of the
            // dilatation-scaled energies. b_k = (κ−κ°)·τ/ε⁴ feeds both neighbouring elements.
            for j in 0..n {
                let ds = [
                    sigma[j][0] - s0[j][0],
                    sigma[j][1] - s0[j][1],
                    sigma[j][2] - s0[j][2],
                ];
                let mut coef = 0.5 * dot(ds, stress[j]) / (dil[j] * dil[j]);
                for k in [j.wrapping_sub(1), j] {
                    if k < nk {
                        let dk = [
                            kappa[k][0] - k0[k][0],
                            kappa[k][1] - k0[k][1],
                            kappa[k][2] - k0[k][2],
                        ];
                        coef += 0.75 * dot(dk, couple[k]) / eps_out[k].powi(4);
                    }
                }
                for c in 0..3 {
                    f[j][c] -= coef * tangent[j][c];
                }
            }
        }

        // Loop C: bend/twist difference and bend–twist coupling average onto elements (eq. 4.3).
        for j in 0..n {
            for c in 0..3 {
                torque[j][c] += tb[j + 1][c] - tb[j][c] + hh[j + 1][c] + hh[j][c];
            }
        }

        // Loop D: nodal forces F_i = f_i − f_{i−1} with f_{−1} = 0 (eq. 4.1).
        let force = &mut self.force[..n + 1];
        force[0] = f[0];
        for i in 1..=n {
            force[i] = [
                f[i][0] - f[i - 1][0],
                f[i][1] - f[i - 1][1],
                f[i][2] - f[i - 1][2],
            ];
        }
    }
}

/// Elastic loads (no velocity terms) of a rod state for arbitrary rest strains: the routine
/// 𝓛(x; σ_rest, κ_rest) of the energy-shaping law. Holds its own scratch; no allocation per call.
#[derive(Debug, Clone)]
pub struct ElasticLoads {
    inner: InternalLoads,
}

impl ElasticLoads {
    /// Buffers for a rod of `n` elements.
    pub fn new(n_elements: usize) -> Self {
        Self {
            inner: InternalLoads::new(n_elements),
        }
    }

    /// Evaluate the elastic nodal forces (lab) and element couples (material) of `s` with the
    /// given rest strains. Panics if the slice lengths do not match the model.
    pub fn compute(
        &mut self,
        model: &RodModel,
        s: &RodState,
        rest_sigma: &[Vec3],
        rest_kappa: &[Vec3],
        energy_consistent: bool,
    ) {
        assert_eq!(rest_sigma.len(), model.n_elements, "rest_sigma length");
        assert_eq!(rest_kappa.len(), model.n_interior(), "rest_kappa length");
        self.inner
            .compute(model, s, rest_sigma, rest_kappa, false, energy_consistent);
    }

    /// Nodal forces of the last evaluation [N], lab frame.
    pub fn force(&self) -> &[Vec3] {
        &self.inner.force
    }

    /// Element couples of the last evaluation [N m], material frame.
    #[allow(clippy::misnamed_getters)] // the elastic couple is the element torque buffer
    pub fn couple(&self) -> &[Vec3] {
        &self.inner.torque
    }

    /// All strains and stresses of the last evaluation.
    pub fn details(&self) -> &InternalLoads {
        &self.inner
    }
}

/// Strains of a state without any load evaluation: σ per element and κ per interior point
/// (material frame). Writes into the given slices (lengths n and n − 1).
pub fn strains(model: &RodModel, s: &RodState, sigma: &mut [Vec3], kappa: &mut [Vec3]) {
    let n = model.n_elements;
    for j in 0..n {
        let dx = [
            s.position[j + 1][0] - s.position[j][0],
            s.position[j + 1][1] - s.position[j][1],
            s.position[j + 1][2] - s.position[j][2],
        ];
        let m = mat_vec(&s.director[j], dx);
        sigma[j] = [
            m[0] * model.inv_rest_length[j],
            m[1] * model.inv_rest_length[j],
            m[2] * model.inv_rest_length[j] - 1.0,
        ];
    }
    for k in 0..n - 1 {
        let (theta, _) = log_relative(&s.director[k + 1], &s.director[k]);
        kappa[k] = [
            -theta[0] * model.inv_rest_voronoi[k],
            -theta[1] * model.inv_rest_voronoi[k],
            -theta[2] * model.inv_rest_voronoi[k],
        ];
    }
}

/// Rotation angle |κ_k| D̂_k between neighbouring frames (for the guard).
pub(crate) fn turning_angle(q_next: &Mat3, q: &Mat3) -> f64 {
    log_relative(q_next, q).1
}
