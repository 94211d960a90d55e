//! Strains and internal loads of the discrete Cosserat rod (spec §2–§4): element stretch/shear,
//! Voronoi curvature/twist, the constitutive law, nodal forces and element torques, for every rod
//! of a system in the system's structure-of-arrays order. One fused kernel serves the stepper
//! (with the velocity-dependent torques) and `ElasticLoads` (without), which controllers use to
//! evaluate loads for other rest strains.

use crate::lanes::{gather3, load3, log_relative_x, store3, LANES, X};
use crate::math::{
    cross, cross_r, dot, dot_r, log_relative, mat_t_vec, mat_t_vec_r, mat_vec, mat_vec_r, Mat3,
    Real, Vec3,
};
use crate::model::RodModel;
use crate::muscles::{MuscleModel, MuscleScratch, Resultants, Strains, N_GROUPS};
use crate::state::{RodAccess, RodState, RodView, SystemState};
use crate::store::Vec3s;

/// Scratch arrays of one internal-load evaluation of a system; allocated once, reused every
/// step. Element fields are in system element order, interior fields in system interior order
/// (rod r's n − 1 points follow rod r − 1's), node fields in system node order.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct InternalLoads {
    /// Unit tangent t [-], lab frame, per element.
    pub tangent: Vec3s,
    /// Dilatation e = l/l̂, per element.
    pub dilatation: Vec<f64>,
    /// Shear/stretch strain σ (material), per element.
    pub sigma: Vec3s,
    /// Internal stress n = S(σ − σ°) [N] (material, reference form), per element.
    pub stress: Vec3s,
    /// Curvature/twist κ [1/m] (material), per interior point.
    pub kappa: Vec3s,
    /// Voronoi dilatation ε, per interior point.
    pub voronoi_dilatation: Vec<f64>,
    /// Internal couple τ = B(κ − κ°) [N m] (material, reference form), per interior point.
    pub couple: Vec3s,
    /// Net internal force on each node [N], lab frame.
    pub force: Vec3s,
    /// Net internal torque on each element [N m], material frame.
    pub torque: Vec3s,
    // Per rod, padded to its n + 1 nodes (node order): f_j = Qᵀn/e with f[n] = 0, and τ/ε³ and
    // ½ D̂ κ×τ/ε³ with slot k + 1 holding Voronoi point k and slots 0 and n zero.
    // Stored by component, so that the element-lane loops read and write them whole.
    elem_force: [Vec<f64>; 3],
    couple_pad: [Vec<f64>; 3],
    coupling_pad: [Vec<f64>; 3],
    // Element length l and 1/l, and 1/ε³ per interior point: the square roots and divisions,
    // computed in their own short loops so that they vectorise (spec §14).
    length: Vec<f64>,
    inv_length: Vec<f64>,
    inv_eps_cubed: Vec<f64>,
    /// Muscle force resultant n^μ [N] (material) per element of the last evaluation with
    /// muscles (spec eq. 2.5; zero where a rod had none).
    pub muscle_n: Vec3s,
    /// Muscle couple resultant τ^μ [N m] (material) per interior point of the last evaluation.
    pub muscle_tau: Vec3s,
    /// The muscles' share of `force` [N] (lab) per node, in the last evaluation with muscles.
    pub muscle_force: Vec3s,
    /// The muscles' share of `torque` [N m] (material) per element, in the last evaluation.
    pub muscle_couple: Vec3s,
    muscle_scratch: MuscleScratch,
    // Per rod, padded to its n + 1 nodes: Q_jᵀ n^μ_j, and τ^μ and ½ D̂ κ × τ^μ in slot k + 1.
    muscle_pad: [Vec<Vec3>; 3],
}

/// Muscles of one rod in an internal-load evaluation: the model and the activation of each group
/// on the rod's elements.
pub type MuscleInput<'a> = (&'a MuscleModel, [&'a [f64]; N_GROUPS]);

/// Where one rod's entries start in each index domain of a system.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Offsets {
    /// First node.
    pub node: usize,
    /// First element.
    pub element: usize,
    /// First interior (Voronoi) point.
    pub interior: usize,
}

impl Offsets {
    /// A lone rod: every domain starts at 0.
    pub const ZERO: Offsets = Offsets {
        node: 0,
        element: 0,
        interior: 0,
    };
}

impl InternalLoads {
    /// Buffers for a system with these totals.
    pub fn new(n_nodes: usize, n_elements: usize, n_interior: usize) -> Self {
        Self {
            tangent: Vec3s::zeros(n_elements),
            dilatation: vec![1.0; n_elements],
            sigma: Vec3s::zeros(n_elements),
            stress: Vec3s::zeros(n_elements),
            kappa: Vec3s::zeros(n_interior),
            voronoi_dilatation: vec![1.0; n_interior],
            couple: Vec3s::zeros(n_interior),
            force: Vec3s::zeros(n_nodes),
            torque: Vec3s::zeros(n_elements),
            elem_force: std::array::from_fn(|_| vec![0.0; n_nodes]),
            couple_pad: std::array::from_fn(|_| vec![0.0; n_nodes]),
            coupling_pad: std::array::from_fn(|_| vec![0.0; n_nodes]),
            length: vec![0.0; n_elements],
            inv_length: vec![0.0; n_elements],
            inv_eps_cubed: vec![0.0; n_interior],
            muscle_n: Vec3s::zeros(n_elements),
            muscle_tau: Vec3s::zeros(n_interior),
            muscle_force: Vec3s::zeros(n_nodes),
            muscle_couple: Vec3s::zeros(n_elements),
            muscle_scratch: MuscleScratch::new(n_elements),
            muscle_pad: [
                vec![[0.0; 3]; n_nodes],
                vec![[0.0; 3]; n_nodes],
                vec![[0.0; 3]; n_nodes],
            ],
        }
    }

    /// Buffers for one rod of `n` elements.
    pub fn for_rod(n: usize) -> Self {
        Self::new(n + 1, n, n - 1)
    }

    /// Evaluate strains, internal nodal forces and element torques of one rod of `state` (model
    /// `model`, at `at`) with the given rest strains (the rod's own slices). `with_velocity_terms`
    /// adds the gyroscopic and unsteady-dilatation torques (eq. 4.3); `energy_consistent` adds
    /// the tension corrections of eq. 4.5.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn compute_rod(
        &mut self,
        model: &RodModel,
        state: &SystemState,
        at: Offsets,
        rest_sigma: &[Vec3],
        rest_kappa: &[Vec3],
        with_velocity_terms: bool,
        energy_consistent: bool,
    ) {
        self.compute_rod_with_muscles(
            model,
            state,
            at,
            rest_sigma,
            rest_kappa,
            with_velocity_terms,
            energy_consistent,
            None,
        );
    }

    /// `compute_rod` with the rod's muscles fused into the internal loads (spec eqs. 2.6–2.7):
    /// f_j = Q_jᵀ(n_j/e_j + n^μ_j), τ̃_k = τ_k/ε_k³ + τ^μ_k, and the shear–stretch couple
    /// l̂_j ν_j × (n_j/e_j + n^μ_j). The muscles' share is also kept in `muscle_force` /
    /// `muscle_couple` (for the work of the actuation) and the resultants in `muscle_n` /
    /// `muscle_tau`.
    // `inline(always)`: compiled into the stepper's kernels (`step_avx2` gets AVX2/FMA code),
    // like `compute_rod`; without it every rod's internal loads ran as baseline x86-64 code.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn compute_rod_with_muscles(
        &mut self,
        model: &RodModel,
        state: &SystemState,
        at: Offsets,
        rest_sigma: &[Vec3],
        rest_kappa: &[Vec3],
        with_velocity_terms: bool,
        energy_consistent: bool,
        muscles: Option<MuscleInput<'_>>,
    ) {
        let n = model.n_elements;
        let rod = state.view(at.node, at.element, n);
        self.compute_view(
            model,
            &rod,
            at,
            rest_sigma,
            rest_kappa,
            with_velocity_terms,
            energy_consistent,
            muscles,
        );
    }

    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn compute_view(
        &mut self,
        model: &RodModel,
        rod: &RodView<'_>,
        at: Offsets,
        rest_sigma: &[Vec3],
        rest_kappa: &[Vec3],
        with_velocity_terms: bool,
        energy_consistent: bool,
        muscles: Option<MuscleInput<'_>>,
    ) {
        let n = model.n_elements;
        let (e0, n0, k0) = (at.element, at.node, at.interior);
        // Every slice is cut to its exact length first, so that the loops below index without
        // bounds checks.
        let (px, py, pz) = (
            &rod.position[0][..n + 1],
            &rod.position[1][..n + 1],
            &rod.position[2][..n + 1],
        );
        let (vx, vy, vz) = (
            &rod.velocity[0][..n + 1],
            &rod.velocity[1][..n + 1],
            &rod.velocity[2][..n + 1],
        );
        let qs: [&[f64]; 9] = std::array::from_fn(|k| &rod.director[k][..n]);
        let frame = |j: usize| -> Mat3 {
            [
                [qs[0][j], qs[1][j], qs[2][j]],
                [qs[3][j], qs[4][j], qs[5][j]],
                [qs[6][j], qs[7][j], qs[8][j]],
            ]
        };
        let frame_x = |j: usize| -> [[X; 3]; 3] {
            std::array::from_fn(|r| std::array::from_fn(|c| X::load(qs[3 * r + c], j)))
        };
        let (wx, wy, wz) = (&rod.omega[0][..n], &rod.omega[1][..n], &rod.omega[2][..n]);
        let lr = &model.rest_length[..n];
        let inv_lr = &model.inv_rest_length[..n];
        let stiff = &model.shear_stiffness[..n];
        let inertia = &model.inertia[..n];
        let s0 = &rest_sigma[..n];
        let dil = &mut self.dilatation[e0..e0 + n];
        let [fx, fy, fz] = &mut self.elem_force;
        let (fx, fy, fz) = (
            &mut fx[n0..n0 + n + 1],
            &mut fy[n0..n0 + n + 1],
            &mut fz[n0..n0 + n + 1],
        );
        let len = &mut self.length[e0..e0 + n];
        let inv_len = &mut self.inv_length[e0..e0 + n];

        // Lengths and dilatations first: a loop of square roots and divisions only, which LLVM
        // vectorises, unlike the long element loop below.
        for j in 0..n {
            let dx = [px[j + 1] - px[j], py[j + 1] - py[j], pz[j + 1] - pz[j]];
            let l = dot(dx, dx).sqrt();
            len[j] = l;
            inv_len[j] = 1.0 / l;
            dil[j] = l * inv_lr[j];
        }
        let (inv_len, dil) = (&*inv_len, &*dil);

        // Loop A: geometry, shear/stretch strain (eq. 2.2), stress, element force (eq. 4.1) and
        // the element-local torques (shear–stretch coupling, gyroscopic, unsteady dilatation).
        // Lanes across elements (`lanes::X`), the last n mod 4 elements one by one: the same
        // formula (`element_loads`) either way, so every element gets the same bits.
        {
            let (tgx, tgy, tgz) = split3(&mut self.tangent, e0, n);
            let (sgx, sgy, sgz) = split3(&mut self.sigma, e0, n);
            let (stx, sty, stz) = split3(&mut self.stress, e0, n);
            let (tqx, tqy, tqz) = split3(&mut self.torque, e0, n);
            let (p3, v3, w3) = ([px, py, pz], [vx, vy, vz], [wx, wy, wz]);
            let n4 = n - n % LANES;
            for j in (0..n4).step_by(LANES) {
                let (a, b) = (load3(p3, j), load3(p3, j + 1));
                let dx = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
                let rates = with_velocity_terms.then(|| {
                    let (a, b) = (load3(v3, j), load3(v3, j + 1));
                    (
                        [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                        load3(w3, j),
                        gather3(inertia, j),
                    )
                });
                let el = element_loads(
                    dx,
                    X::load(inv_len, j),
                    X::load(dil, j),
                    X::load(lr, j),
                    X::load(inv_lr, j),
                    &frame_x(j),
                    gather3(stiff, j),
                    gather3(s0, j),
                    rates,
                );
                store3(el.force, [fx, fy, fz], j);
                store3(el.tangent, [tgx, tgy, tgz], j);
                store3(el.sigma, [sgx, sgy, sgz], j);
                store3(el.stress, [stx, sty, stz], j);
                store3(el.torque, [tqx, tqy, tqz], j);
            }
            for j in n4..n {
                let dx = [px[j + 1] - px[j], py[j + 1] - py[j], pz[j + 1] - pz[j]];
                let rates = with_velocity_terms.then(|| {
                    (
                        [vx[j + 1] - vx[j], vy[j + 1] - vy[j], vz[j + 1] - vz[j]],
                        [wx[j], wy[j], wz[j]],
                        inertia[j],
                    )
                });
                let el = element_loads(
                    dx,
                    inv_len[j],
                    dil[j],
                    lr[j],
                    inv_lr[j],
                    &frame(j),
                    stiff[j],
                    s0[j],
                    rates,
                );
                (fx[j], fy[j], fz[j]) = (el.force[0], el.force[1], el.force[2]);
                let (t, sg, nn, tq) = (el.tangent, el.sigma, el.stress, el.torque);
                (tgx[j], tgy[j], tgz[j]) = (t[0], t[1], t[2]);
                (sgx[j], sgy[j], sgz[j]) = (sg[0], sg[1], sg[2]);
                (stx[j], sty[j], stz[j]) = (nn[0], nn[1], nn[2]);
                (tqx[j], tqy[j], tqz[j]) = (tq[0], tq[1], tq[2]);
            }
        }
        (fx[n], fy[n], fz[n]) = (0.0, 0.0, 0.0);

        // Loop B: curvature (eq. 2.3), Voronoi dilatation, couple (eq. 3.3), scaled by 1/ε³.
        let nk = n - 1;
        let dr = &model.rest_voronoi_length[..nk];
        let inv_dr = &model.inv_rest_voronoi[..nk];
        let bend = &model.bend_stiffness[..nk];
        let kap0 = &rest_kappa[..nk];
        let eps_out = &mut self.voronoi_dilatation[k0..k0 + nk];
        let [tbx, tby, tbz] = &mut self.couple_pad;
        let (tbx, tby, tbz) = (
            &mut tbx[n0..n0 + n + 1],
            &mut tby[n0..n0 + n + 1],
            &mut tbz[n0..n0 + n + 1],
        );
        let [hhx, hhy, hhz] = &mut self.coupling_pad;
        let (hhx, hhy, hhz) = (
            &mut hhx[n0..n0 + n + 1],
            &mut hhy[n0..n0 + n + 1],
            &mut hhz[n0..n0 + n + 1],
        );
        let inv_e3 = &mut self.inv_eps_cubed[k0..k0 + nk];
        for k in 0..nk {
            let eps = 0.5 * (dil[k] * lr[k] + dil[k + 1] * lr[k + 1]) * inv_dr[k];
            eps_out[k] = eps;
            inv_e3[k] = 1.0 / (eps * eps * eps);
        }
        let inv_e3 = &*inv_e3;
        let (kpx, kpy, kpz) = split3(&mut self.kappa, k0, nk);
        let (cpx, cpy, cpz) = split3(&mut self.couple, k0, nk);
        // Lanes across Voronoi points. `log_relative` per lane: its series for every lane, and
        // libm's atan2 only for the lanes outside the series' range (rare: turning angles
        // above 0.05 rad), so the loop has no branch per point in the common case.
        let nk4 = nk - nk % LANES;
        for k in (0..nk4).step_by(LANES) {
            let theta = log_relative_x(&frame_x(k + 1), &frame_x(k));
            let v = voronoi_loads(
                theta,
                X::load(inv_dr, k),
                X::load(dr, k),
                gather3(bend, k),
                gather3(kap0, k),
                X::load(inv_e3, k),
            );
            store3(v.scaled_couple, [tbx, tby, tbz], k + 1);
            store3(v.coupling, [hhx, hhy, hhz], k + 1);
            store3(v.kappa, [kpx, kpy, kpz], k);
            store3(v.couple, [cpx, cpy, cpz], k);
        }
        for k in nk4..nk {
            let v = voronoi_loads(
                log_relative(&frame(k + 1), &frame(k)).0,
                inv_dr[k],
                dr[k],
                bend[k],
                kap0[k],
                inv_e3[k],
            );
            let (a, b) = (v.scaled_couple, v.coupling);
            (tbx[k + 1], tby[k + 1], tbz[k + 1]) = (a[0], a[1], a[2]);
            (hhx[k + 1], hhy[k + 1], hhz[k + 1]) = (b[0], b[1], b[2]);
            let (kap, tau) = (v.kappa, v.couple);
            (kpx[k], kpy[k], kpz[k]) = (kap[0], kap[1], kap[2]);
            (cpx[k], cpy[k], cpz[k]) = (tau[0], tau[1], tau[2]);
        }
        for end in [0, n] {
            (tbx[end], tby[end], tbz[end]) = (0.0, 0.0, 0.0);
            (hhx[end], hhy[end], hhz[end]) = (0.0, 0.0, 0.0);
        }
        let (f, tb, hh) = ([fx, fy, fz], [tbx, tby, tbz], [hhx, hhy, hhz]);

        if let Some((mm, act)) = muscles {
            // Muscles (spec §2), from the strains just computed, fused into f, τ̃ and the
            // shear–stretch couple (eqs. 2.6–2.7).
            let strains = Strains {
                sigma: [
                    &self.sigma.x[e0..e0 + n],
                    &self.sigma.y[e0..e0 + n],
                    &self.sigma.z[e0..e0 + n],
                ],
                dilatation: dil,
                kappa: [
                    &self.kappa.x[k0..k0 + nk],
                    &self.kappa.y[k0..k0 + nk],
                    &self.kappa.z[k0..k0 + nk],
                ],
                voronoi_dilatation: eps_out,
            };
            let mut out = Resultants {
                force: [
                    &mut self.muscle_n.x[e0..e0 + n],
                    &mut self.muscle_n.y[e0..e0 + n],
                    &mut self.muscle_n.z[e0..e0 + n],
                ],
                couple: [
                    &mut self.muscle_tau.x[k0..k0 + nk],
                    &mut self.muscle_tau.y[k0..k0 + nk],
                    &mut self.muscle_tau.z[k0..k0 + nk],
                ],
                moment: None,
            };
            mm.resultants(act, &strains, &mut self.muscle_scratch, &mut out);
            let [ref mut mf, ref mut mtb, ref mut mhh] = self.muscle_pad;
            let (mf, mtb, mhh) = (
                &mut mf[n0..n0 + n + 1],
                &mut mtb[n0..n0 + n + 1],
                &mut mhh[n0..n0 + n + 1],
            );
            for j in 0..n {
                let g = e0 + j;
                let nm = self.muscle_n.get(g);
                let fl = mat_t_vec(&frame(j), nm);
                mf[j] = fl;
                for c in 0..3 {
                    f[c][j] += fl[c];
                }
                let sg = self.sigma.get(g);
                let cr = cross([sg[0], sg[1], 1.0 + sg[2]], nm);
                let cpl = [lr[j] * cr[0], lr[j] * cr[1], lr[j] * cr[2]];
                self.torque.add(g, cpl);
                self.muscle_couple.set(g, cpl);
            }
            mf[n] = [0.0; 3];
            mtb[0] = [0.0; 3];
            mhh[0] = [0.0; 3];
            mtb[n] = [0.0; 3];
            mhh[n] = [0.0; 3];
            for k in 0..nk {
                let tau = self.muscle_tau.get(k0 + k);
                let kt = cross(self.kappa.get(k0 + k), tau);
                let h = 0.5 * dr[k];
                let kt = [kt[0] * h, kt[1] * h, kt[2] * h];
                mtb[k + 1] = tau;
                mhh[k + 1] = kt;
                for c in 0..3 {
                    tb[c][k + 1] += tau[c];
                    hh[c][k + 1] += kt[c];
                }
            }
            for j in 0..n {
                let mut d = [0.0; 3];
                for c in 0..3 {
                    d[c] = mtb[j + 1][c] - mtb[j][c] + mhh[j + 1][c] + mhh[j][c];
                }
                self.muscle_couple.add(e0 + j, d);
            }
            self.muscle_force.set(n0, mf[0]);
            for i in 1..=n {
                let d = [
                    mf[i][0] - mf[i - 1][0],
                    mf[i][1] - mf[i - 1][1],
                    mf[i][2] - mf[i - 1][2],
                ];
                self.muscle_force.set(n0 + i, d);
            }
        }

        if energy_consistent {
            // Eq. 4.5: tension corrections that make the elastic loads the gradient of the
            // dilatation-scaled energies. b_k = (κ−κ°)·τ/ε⁴ feeds both neighbouring elements.
            for j in 0..n {
                let sg = self.sigma.get(e0 + j);
                let ds = [sg[0] - s0[j][0], sg[1] - s0[j][1], sg[2] - s0[j][2]];
                let mut coef = 0.5 * dot(ds, self.stress.get(e0 + j)) / (dil[j] * dil[j]);
                for k in [j.wrapping_sub(1), j] {
                    if k < nk {
                        let kp = self.kappa.get(k0 + k);
                        let dk = [kp[0] - kap0[k][0], kp[1] - kap0[k][1], kp[2] - kap0[k][2]];
                        coef += 0.75 * dot(dk, self.couple.get(k0 + k)) / eps_out[k].powi(4);
                    }
                }
                let t = self.tangent.get(e0 + j);
                for c in 0..3 {
                    f[c][j] -= coef * t[c];
                }
            }
        }

        // Loop C: bend/twist difference and bend–twist coupling average onto elements (eq. 4.3).
        let (tx, ty, tz) = (
            &mut self.torque.x[e0..e0 + n],
            &mut self.torque.y[e0..e0 + n],
            &mut self.torque.z[e0..e0 + n],
        );
        for j in 0..n {
            tx[j] += tb[0][j + 1] - tb[0][j] + hh[0][j + 1] + hh[0][j];
            ty[j] += tb[1][j + 1] - tb[1][j] + hh[1][j + 1] + hh[1][j];
            tz[j] += tb[2][j + 1] - tb[2][j] + hh[2][j + 1] + hh[2][j];
        }

        // Loop D: nodal forces F_i = f_i − f_{i−1} with f_{−1} = 0 (eq. 4.1).
        let (fx, fy, fz) = (
            &mut self.force.x[n0..n0 + n + 1],
            &mut self.force.y[n0..n0 + n + 1],
            &mut self.force.z[n0..n0 + n + 1],
        );
        fx[0] = f[0][0];
        fy[0] = f[1][0];
        fz[0] = f[2][0];
        for i in 1..=n {
            fx[i] = f[0][i] - f[0][i - 1];
            fy[i] = f[1][i] - f[1][i - 1];
            fz[i] = f[2][i] - f[2][i - 1];
        }
    }
}

/// Loop A's results for one element (eq. 2.2, 4.1, 4.3): unit tangent t (lab), strain σ and
/// stress n (material), element force Qᵀn/e (lab) and the element-local torque (material).
pub(crate) struct ElementLoads<S> {
    pub tangent: [S; 3],
    pub sigma: [S; 3],
    pub stress: [S; 3],
    pub force: [S; 3],
    pub torque: [S; 3],
}

/// One element of loop A, from its edge `dx` = x_{j+1} − x_j, 1/l, dilatation e, rest length
/// l̂ and 1/l̂, frame, shear stiffness and rest strain; `rates` = (v_{j+1} − v_j, ω_j, J_j) adds
/// the gyroscopic and unsteady-dilatation torques. The stepper (`f64`) and `batch` (lanes)
/// share it, so that both perform the same IEEE operations.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn element_loads<S: Real>(
    dx: [S; 3],
    inv_l: S,
    e: S,
    lr: S,
    inv_lr: S,
    qj: &[[S; 3]; 3],
    stiff: [S; 3],
    s0: [S; 3],
    rates: Option<([S; 3], [S; 3], [S; 3])>,
) -> ElementLoads<S> {
    let t = [dx[0] * inv_l, dx[1] * inv_l, dx[2] * inv_l];
    let inv_e = lr * inv_l;
    let qt = mat_vec_r(qj, t);
    let sg = [e * qt[0], e * qt[1], e * qt[2] - S::splat(1.0)];
    let nn = [
        stiff[0] * (sg[0] - s0[0]),
        stiff[1] * (sg[1] - s0[1]),
        stiff[2] * (sg[2] - s0[2]),
    ];
    let fl = mat_t_vec_r(qj, nn);
    let c = cross_r(qt, nn);
    let mut tq = [lr * c[0], lr * c[1], lr * c[2]];
    if let Some((dv, w, inertia)) = rates {
        let edot = dot_r(t, dv) * inv_lr;
        let g = [
            inertia[0] * w[0] * inv_e,
            inertia[1] * w[1] * inv_e,
            inertia[2] * w[2] * inv_e,
        ];
        let gw = cross_r(g, w);
        let r = edot * inv_e;
        tq = [
            tq[0] + gw[0] + g[0] * r,
            tq[1] + gw[1] + g[1] * r,
            tq[2] + gw[2] + g[2] * r,
        ];
    }
    ElementLoads {
        tangent: t,
        sigma: sg,
        stress: nn,
        force: [fl[0] * inv_e, fl[1] * inv_e, fl[2] * inv_e],
        torque: tq,
    }
}

/// Loop B's results for one Voronoi point (eq. 2.3, 3.3): curvature κ, couple τ, τ/ε³ and
/// ½ D̂ κ × τ/ε³ (material).
pub(crate) struct VoronoiLoads<S> {
    pub kappa: [S; 3],
    pub couple: [S; 3],
    pub scaled_couple: [S; 3],
    pub coupling: [S; 3],
}

/// One Voronoi point of loop B from the rotation vector Θ = Log(Q_{k+1} Q_kᵀ), 1/D̂, D̂, the
/// bend stiffness, the rest curvature and 1/ε³ (shared by the stepper and `batch`).
#[inline(always)]
pub(crate) fn voronoi_loads<S: Real>(
    theta: [S; 3],
    inv_dr: S,
    dr: S,
    bend: [S; 3],
    kap0: [S; 3],
    inv_e3: S,
) -> VoronoiLoads<S> {
    let kap = [-theta[0] * inv_dr, -theta[1] * inv_dr, -theta[2] * inv_dr];
    let tau = [
        bend[0] * (kap[0] - kap0[0]),
        bend[1] * (kap[1] - kap0[1]),
        bend[2] * (kap[2] - kap0[2]),
    ];
    let kt = cross_r(kap, tau);
    let hf = S::splat(0.5) * dr * inv_e3;
    VoronoiLoads {
        kappa: kap,
        couple: tau,
        scaled_couple: [tau[0] * inv_e3, tau[1] * inv_e3, tau[2] * inv_e3],
        coupling: [kt[0] * hf, kt[1] * hf, kt[2] * hf],
    }
}

/// The x, y, z slices of entries `first..first + n` of a field.
#[inline(always)]
fn split3(v: &mut Vec3s, first: usize, n: usize) -> (&mut [f64], &mut [f64], &mut [f64]) {
    (
        &mut v.x[first..first + n],
        &mut v.y[first..first + n],
        &mut v.z[first..first + n],
    )
}

/// Elastic loads (no velocity terms) of a lone rod state for arbitrary rest strains: the routine
/// 𝓛(x; σ_rest, κ_rest) of the energy-shaping law. Holds its own scratch; no allocation per call.
#[derive(Debug, Clone)]
pub struct ElasticLoads {
    inner: InternalLoads,
    state: SystemState,
    force: Vec<Vec3>,
    couple: Vec<Vec3>,
}

impl ElasticLoads {
    /// Buffers for a rod of `n` elements.
    pub fn new(n_elements: usize) -> Self {
        let n = n_elements;
        let mut state = SystemState::empty();
        state.push_rod(&RodState {
            time: 0.0,
            position: vec![[0.0; 3]; n + 1],
            velocity: vec![[0.0; 3]; n + 1],
            director: vec![[[0.0; 3]; 3]; n],
            omega: vec![[0.0; 3]; n],
        });
        Self {
            inner: InternalLoads::for_rod(n),
            state,
            force: vec![[0.0; 3]; n + 1],
            couple: vec![[0.0; 3]; n],
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
        self.state.write_rod(0, 0, s);
        self.inner.compute_rod(
            model,
            &self.state,
            Offsets::ZERO,
            rest_sigma,
            rest_kappa,
            false,
            energy_consistent,
        );
        for (i, f) in self.force.iter_mut().enumerate() {
            *f = self.inner.force.get(i);
        }
        for (j, c) in self.couple.iter_mut().enumerate() {
            *c = self.inner.torque.get(j);
        }
    }

    /// Nodal forces of the last evaluation [N], lab frame.
    pub fn force(&self) -> &[Vec3] {
        &self.force
    }

    /// Element couples of the last evaluation [N m], material frame.
    pub fn couple(&self) -> &[Vec3] {
        &self.couple
    }

    /// All strains and stresses of the last evaluation.
    pub fn details(&self) -> &InternalLoads {
        &self.inner
    }
}

/// Strains of a rod state without any load evaluation: σ per element and κ per interior point
/// (material frame). Writes into the given slices (lengths n and n − 1).
pub fn strains(model: &RodModel, s: &impl RodAccess, sigma: &mut [Vec3], kappa: &mut [Vec3]) {
    let n = model.n_elements;
    for j in 0..n {
        let (a, b) = (s.position(j), s.position(j + 1));
        let dx = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let m = mat_vec(&s.director(j), dx);
        sigma[j] = [
            m[0] * model.inv_rest_length[j],
            m[1] * model.inv_rest_length[j],
            m[2] * model.inv_rest_length[j] - 1.0,
        ];
    }
    for k in 0..n - 1 {
        let (theta, _) = log_relative(&s.director(k + 1), &s.director(k));
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
