//! Energies of a rod state (spec §12): translational and rotational kinetic energy and the
//! stretch/shear and bend/twist strain energies, for the default model or the dilatation-scaled
//! energy-consistent variant. Pure functions of a model and one rod's state (a system's view or a
//! lone `RodState`); no allocation.

use crate::math::{dot, log_relative, mat_vec, Vec3};
use crate::model::RodModel;
use crate::state::RodAccess;

/// The energies of one state [J].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Energies {
    /// ½ Σ m_i |v_i|².
    pub translational: f64,
    /// ½ Σ ω_j · (J_j/e_j) ω_j.
    pub rotational: f64,
    /// Stretch/shear energy U_s.
    pub stretch: f64,
    /// Bend/twist energy U_b.
    pub bend: f64,
}

impl Energies {
    /// Kinetic energy.
    pub fn kinetic(&self) -> f64 {
        self.translational + self.rotational
    }

    /// Strain (potential) energy.
    pub fn potential(&self) -> f64 {
        self.stretch + self.bend
    }

    /// Total H = K_t + K_r + U_s + U_b.
    pub fn total(&self) -> f64 {
        self.kinetic() + self.potential()
    }
}

/// Energies of `s` measured against the given rest strains. With `energy_consistent` the strain
/// energies carry the factors 1/e and 1/ε³ (eq. 12.2 with p = 1, q = 3).
pub fn energies_with_rest(
    model: &RodModel,
    s: &impl RodAccess,
    rest_sigma: &[Vec3],
    rest_kappa: &[Vec3],
    energy_consistent: bool,
) -> Energies {
    let n = model.n_elements;
    let mut out = Energies::default();
    for i in 0..=n {
        let v = s.velocity(i);
        out.translational += 0.5 * model.node_mass[i] * dot(v, v);
    }
    let mut prev_len = 0.0;
    for j in 0..n {
        let (a, b) = (s.position(j), s.position(j + 1));
        let dx = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let l = dot(dx, dx).sqrt();
        let e = l * model.inv_rest_length[j];
        let w = s.omega(j);
        let jj = model.inertia[j];
        out.rotational +=
            0.5 * (jj[0] * w[0] * w[0] + jj[1] * w[1] * w[1] + jj[2] * w[2] * w[2]) / e;
        let m = mat_vec(&s.director(j), dx);
        let st = model.shear_stiffness[j];
        let ds = [
            m[0] * model.inv_rest_length[j] - rest_sigma[j][0],
            m[1] * model.inv_rest_length[j] - rest_sigma[j][1],
            m[2] * model.inv_rest_length[j] - 1.0 - rest_sigma[j][2],
        ];
        let density = st[0] * ds[0] * ds[0] + st[1] * ds[1] * ds[1] + st[2] * ds[2] * ds[2];
        let scale = if energy_consistent { 1.0 / e } else { 1.0 };
        out.stretch += 0.5 * model.rest_length[j] * density * scale;
        if j > 0 {
            let k = j - 1;
            let (theta, _) = log_relative(&s.director(j), &s.director(k));
            let inv_d = model.inv_rest_voronoi[k];
            let dk = [
                -theta[0] * inv_d - rest_kappa[k][0],
                -theta[1] * inv_d - rest_kappa[k][1],
                -theta[2] * inv_d - rest_kappa[k][2],
            ];
            let b = model.bend_stiffness[k];
            let density = b[0] * dk[0] * dk[0] + b[1] * dk[1] * dk[1] + b[2] * dk[2] * dk[2];
            let scale = if energy_consistent {
                let eps = 0.5 * (prev_len + l) * inv_d;
                1.0 / (eps * eps * eps)
            } else {
                1.0
            };
            out.bend += 0.5 * model.rest_voronoi_length[k] * density * scale;
        }
        prev_len = l;
    }
    out
}

/// Energies of `s` against the model's natural rest strains.
pub fn energies(model: &RodModel, s: &impl RodAccess, energy_consistent: bool) -> Energies {
    energies_with_rest(
        model,
        s,
        &model.rest_sigma,
        &model.rest_kappa,
        energy_consistent,
    )
}
