//! Actuation as data: what controllers (the energy-shaping law, later muscles) write between
//! steps and the stepper reads in its load stage. Per element an added internal stress (material
//! frame), per interior point an added internal couple (material), per node an external force
//! (lab) and per element an external couple (material), and the muscle activations `[7][n]`
//! (group-major, system element order; read only for rods with muscles). The internal part enters exactly as a
//! change of the constitutive stresses would (spec §4 with n + δn and τ + δτ); the stepper
//! never calls back into a controller.

use crate::internal::{InternalLoads, Offsets};
use crate::loads::ExternalLoads;
use crate::math::{cross, mat_t_vec, Mat3, Vec3};
use crate::model::RodModel;
use crate::store::Vec3s;

/// The actuation input of a system, held constant over each step. Starts (and `clear`s) at zero
/// with both parts off; writing through `internal_mut` / `external_mut` switches a part on.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Actuation {
    internal_stress: Vec<Vec3>,
    internal_couple: Vec<Vec3>,
    force: Vec<Vec3>,
    couple: Vec<Vec3>,
    // Muscle activations, group-major: entry g · n_elements + j is group g on element j.
    activation: Vec<f64>,
    internal_on: bool,
    external_on: bool,
    muscles_on: bool,
}

/// Mutable access to the internal part of an actuation.
pub struct InternalActuation<'a> {
    /// Added internal stress δn [N] per element (system order), material frame.
    pub stress: &'a mut [Vec3],
    /// Added internal couple δτ [N m] per interior point (system order), material frame.
    pub couple: &'a mut [Vec3],
}

/// Mutable access to the external part of an actuation.
pub struct ExternalActuation<'a> {
    /// External force [N] per node (system order), lab frame.
    pub force: &'a mut [Vec3],
    /// External couple [N m] per element (system order), material frame.
    pub couple: &'a mut [Vec3],
}

impl Actuation {
    /// Zero actuation for a system with these totals.
    pub fn zeros(n_nodes: usize, n_elements: usize, n_interior: usize) -> Self {
        Self {
            internal_stress: vec![[0.0; 3]; n_elements],
            internal_couple: vec![[0.0; 3]; n_interior],
            force: vec![[0.0; 3]; n_nodes],
            couple: vec![[0.0; 3]; n_elements],
            activation: vec![0.0; crate::muscles::N_GROUPS * n_elements],
            internal_on: false,
            external_on: false,
            muscles_on: false,
        }
    }

    /// Zero actuation sized for `system` (the only size `step` accepts).
    pub fn for_system(system: &crate::system::RodSystem) -> Self {
        Self::zeros(system.n_nodes(), system.n_elements(), system.n_interior())
    }

    /// Set everything to zero and both parts off.
    pub fn clear(&mut self) {
        self.internal_stress.fill([0.0; 3]);
        self.internal_couple.fill([0.0; 3]);
        self.force.fill([0.0; 3]);
        self.couple.fill([0.0; 3]);
        self.activation.fill(0.0);
        self.internal_on = false;
        self.external_on = false;
        self.muscles_on = false;
    }

    /// The muscle activations for writing, group-major (`[7][n_elements]`: entry g · n + j is
    /// group g on element j, system element order); switches them on. Values belong in [0, 1].
    pub fn activations_mut(&mut self) -> &mut [f64] {
        self.muscles_on = true;
        &mut self.activation
    }

    /// The muscle activations, group-major `[7][n_elements]`.
    pub fn activations(&self) -> &[f64] {
        &self.activation
    }

    /// Activation of group `g` on every element of the system.
    pub fn group_activation(&self, g: usize) -> &[f64] {
        let ne = self.internal_stress.len();
        &self.activation[g * ne..(g + 1) * ne]
    }

    /// Whether the muscle activations are on.
    pub fn has_muscles(&self) -> bool {
        self.muscles_on
    }

    /// The seven groups' activations on elements `range` (one rod).
    pub fn rod_activations(
        &self,
        range: std::ops::Range<usize>,
    ) -> [&[f64]; crate::muscles::N_GROUPS] {
        let ne = self.internal_stress.len();
        std::array::from_fn(|g| &self.activation[g * ne + range.start..g * ne + range.end])
    }

    /// The internal part, for writing; switches it on.
    pub fn internal_mut(&mut self) -> InternalActuation<'_> {
        self.internal_on = true;
        InternalActuation {
            stress: &mut self.internal_stress,
            couple: &mut self.internal_couple,
        }
    }

    /// The external part, for writing; switches it on.
    pub fn external_mut(&mut self) -> ExternalActuation<'_> {
        self.external_on = true;
        ExternalActuation {
            force: &mut self.force,
            couple: &mut self.couple,
        }
    }

    /// Added internal stress δn per element [N] (material).
    pub fn internal_stress(&self) -> &[Vec3] {
        &self.internal_stress
    }

    /// Added internal couple δτ per interior point [N m] (material).
    pub fn internal_couple(&self) -> &[Vec3] {
        &self.internal_couple
    }

    /// External force per node [N] (lab).
    pub fn force(&self) -> &[Vec3] {
        &self.force
    }

    /// External couple per element [N m] (material).
    pub fn couple(&self) -> &[Vec3] {
        &self.couple
    }

    /// Whether the internal part is on.
    pub fn has_internal(&self) -> bool {
        self.internal_on
    }

    /// Whether the external part is on.
    pub fn has_external(&self) -> bool {
        self.external_on
    }

    /// Whether every entry is finite (checked by the stepper's callers before a step).
    pub fn all_finite(&self) -> bool {
        self.internal_stress
            .iter()
            .chain(&self.internal_couple)
            .chain(&self.force)
            .chain(&self.couple)
            .flatten()
            .chain(&self.activation)
            .all(|v| v.is_finite())
    }

    /// Number of (nodes, elements, interior points) it is sized for.
    pub fn shape(&self) -> (usize, usize, usize) {
        (
            self.force.len(),
            self.internal_stress.len(),
            self.internal_couple.len(),
        )
    }
}

/// Scratch of the actuation stage: padded per-rod element forces and couple differences, and the
/// nodal forces and element couples the actuation produced in the last step (for effort and
/// power diagnostics).
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub(crate) struct ActuationScratch {
    elem_force: Vec<Vec3>,
    pad_couple: Vec<Vec3>,
    pad_coupling: Vec<Vec3>,
    /// Nodal force of the actuation in the last step [N], lab.
    pub force: Vec3s,
    /// Element couple of the actuation in the last step [N m], material.
    pub couple: Vec3s,
}

impl ActuationScratch {
    pub fn new(n_nodes: usize, n_elements: usize) -> Self {
        Self {
            elem_force: vec![[0.0; 3]; n_nodes],
            pad_couple: vec![[0.0; 3]; n_nodes],
            pad_coupling: vec![[0.0; 3]; n_nodes],
            force: Vec3s::zeros(n_nodes),
            couple: Vec3s::zeros(n_elements),
        }
    }

    /// Add the internal actuation of one rod to `out` (and record it): the loads of the
    /// constant stresses δn, δτ through the rod's current geometry, i.e. the spec §4 load
    /// routine with n̂ = δn and τ̂ = δτ, using the strains and dilatations the internal stage has
    /// just computed for the same mid-step state. With `energy_consistent`, whose tension
    /// correction (eq. 4.5) is quadratic in the stresses, δn and δτ act as the rest-strain change
    /// δσ° = −δn/S, δκ° = −δτ/B would, and the difference of the corrections is added too.
    #[allow(clippy::too_many_arguments)]
    pub fn add_internal_rod(
        &mut self,
        model: &RodModel,
        director: &[&[f64]; 9],
        internal: &InternalLoads,
        stress: &[Vec3],
        couple_in: &[Vec3],
        rest: (&[Vec3], &[Vec3]),
        energy_consistent: bool,
        at: Offsets,
        out: &mut ExternalLoads,
    ) {
        let n = model.n_elements;
        let (n0, e0, k0) = (at.node, at.element, at.interior);
        let lr = &model.rest_length[..n];
        let f = &mut self.elem_force[n0..n0 + n + 1];
        // Element forces f_j = Q_jᵀ δn_j / e_j and the shear–stretch couple (Q_j t_j) × δn_j l̂_j,
        // with Q_j t_j = (σ_j + e3)/e_j.
        for j in 0..n {
            let q = director;
            let qj: Mat3 = [
                [q[0][j], q[1][j], q[2][j]],
                [q[3][j], q[4][j], q[5][j]],
                [q[6][j], q[7][j], q[8][j]],
            ];
            let inv_e = 1.0 / internal.dilatation[e0 + j];
            let fl = mat_t_vec(&qj, stress[j]);
            f[j] = [fl[0] * inv_e, fl[1] * inv_e, fl[2] * inv_e];
            let s = lr[j] * inv_e;
            let sg = internal.sigma.get(e0 + j);
            let qt = [sg[0] * s, sg[1] * s, (sg[2] + 1.0) * s];
            let c = cross(qt, stress[j]);
            out.couple.add(e0 + j, c);
            self.couple.set(e0 + j, c);
        }
        f[n] = [0.0; 3];
        if energy_consistent {
            let (s0, k0r) = rest;
            let dot = crate::math::dot;
            // n = S ds with ds = σ − σ°; the actuated stress is n + δn = S(ds + δn/S).
            let bend_term = |k: usize| {
                let kp = internal.kappa.get(k0 + k);
                let tau = internal.couple.get(k0 + k);
                let b = model.bend_stiffness[k];
                let mut dk = [0.0; 3];
                let mut dk2 = [0.0; 3];
                let mut tau2 = [0.0; 3];
                for c in 0..3 {
                    dk[c] = kp[c] - k0r[k][c];
                    dk2[c] = dk[c] + couple_in[k][c] / b[c];
                    tau2[c] = tau[c] + couple_in[k][c];
                }
                let eps = internal.voronoi_dilatation[k0 + k];
                0.75 * (dot(dk2, tau2) - dot(dk, tau)) / eps.powi(4)
            };
            for j in 0..n {
                let sg = internal.sigma.get(e0 + j);
                let nn = internal.stress.get(e0 + j);
                let st = model.shear_stiffness[j];
                let mut ds = [0.0; 3];
                let mut ds2 = [0.0; 3];
                let mut n2 = [0.0; 3];
                for c in 0..3 {
                    ds[c] = sg[c] - s0[j][c];
                    ds2[c] = ds[c] + stress[j][c] / st[c];
                    n2[c] = nn[c] + stress[j][c];
                }
                let e = internal.dilatation[e0 + j];
                let mut coef = 0.5 * (dot(ds2, n2) - dot(ds, nn)) / (e * e);
                for k in [j.wrapping_sub(1), j] {
                    if k < n - 1 {
                        coef += bend_term(k);
                    }
                }
                let t = internal.tangent.get(e0 + j);
                for c in 0..3 {
                    f[j][c] -= coef * t[c];
                }
            }
        }
        // Bend/twist: δτ/ε³ differences and the averaged ½ D̂ κ × δτ/ε³ (slot k + 1 = interior k).
        let tb = &mut self.pad_couple[n0..n0 + n + 1];
        let hh = &mut self.pad_coupling[n0..n0 + n + 1];
        let dr = &model.rest_voronoi_length[..n - 1];
        tb[0] = [0.0; 3];
        hh[0] = [0.0; 3];
        tb[n] = [0.0; 3];
        hh[n] = [0.0; 3];
        for k in 0..n - 1 {
            let eps = internal.voronoi_dilatation[k0 + k];
            let inv_e3 = 1.0 / (eps * eps * eps);
            let tau = couple_in[k];
            let kt = cross(internal.kappa.get(k0 + k), tau);
            let h = 0.5 * dr[k] * inv_e3;
            tb[k + 1] = [tau[0] * inv_e3, tau[1] * inv_e3, tau[2] * inv_e3];
            hh[k + 1] = [kt[0] * h, kt[1] * h, kt[2] * h];
        }
        for j in 0..n {
            let mut d = [0.0; 3];
            for c in 0..3 {
                d[c] = tb[j + 1][c] - tb[j][c] + hh[j + 1][c] + hh[j][c];
            }
            out.couple.add(e0 + j, d);
            self.couple.add(e0 + j, d);
        }
        out.force.add(n0, f[0]);
        self.force.set(n0, f[0]);
        for i in 1..=n {
            let d = [
                f[i][0] - f[i - 1][0],
                f[i][1] - f[i - 1][1],
                f[i][2] - f[i - 1][2],
            ];
            out.force.add(n0 + i, d);
            self.force.set(n0 + i, d);
        }
    }
}
