//! Viscous damping (spec §8) of one rod: the rate-based module integrated exactly over the kick
//! (`rate` = mass-proportional ν_d, `gamma` = the paper's per-length γ; octoarm's default
//! protocol), and PyElastica's multiplicative "analytical linear damper" applied after the kick
//! (its protocol, for reproducing PyElastica runs). The stepper calls into here.

use crate::error::{non_negative, ModelError};
use crate::model::RodModel;

/// Damping of one rod. Both rate terms default to 0; when both are non-zero their decay rates add.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Damping {
    /// Mass-proportional rate ν_d [1/s]: every node and element loses velocity at this rate
    /// (F = −ν_d m v, C = −ν_d (J/e) ω). The paper-reproduction default is 10 s⁻¹.
    pub rate: f64,
    /// The paper's per-unit-length coefficient γ [kg/(m s)] (spec eq. 8.2):
    /// λ_i = γ ℓ̂_i / m_i on nodes, λ_j = e_j γ / (ρ Â_j) on elements.
    pub gamma: f64,
    /// Optional PyElastica-style multiplicative damper applied after the kick (operator split).
    pub analytical: Option<AnalyticalDamper>,
}

/// PyElastica's analytical linear damper (spec §8b), applied as v ← f v, ω ← f ω after the kick.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum AnalyticalDamper {
    /// Constant rate ν [1/s] on every DOF.
    Uniform {
        /// Rate [1/s].
        nu: f64,
    },
    /// Translational c_t [kg/s] and rotational c_r [kg m²/s] coefficients.
    Physical {
        /// Translational coefficient [kg/s].
        translational: f64,
        /// Rotational coefficient [kg m²/s].
        rotational: f64,
    },
    /// Per-DOF rates [1/s]: every node's velocity decays at `translational`, component c of
    /// every element's ω at `rotational[c]` (exact decay, no dilatation factor). The `coomm`
    /// preset (`Damping::coomm`) is of this kind.
    Rates {
        /// Node rate [1/s].
        translational: f64,
        /// Element rates about d1, d2, d3 [1/s].
        rotational: [f64; 3],
    },
    /// The deprecated parameterisation with a constant ν [1/s] scaled by element mass for rotation.
    Legacy {
        /// Rate [1/s].
        nu: f64,
    },
}

impl Damping {
    /// Mass-proportional damping at `rate` [1/s].
    pub fn mass_proportional(rate: f64) -> Self {
        Self {
            rate,
            ..Self::default()
        }
    }

    /// The paper's per-length damping with coefficient `gamma` [kg/(m s)].
    pub fn per_length(gamma: f64) -> Self {
        Self {
            gamma,
            ..Self::default()
        }
    }

    /// COOMM's rod damping (muscles-3d spec §3.2): PyElastica's damper with ν_j = c (r̂_j/r_b)² on
    /// forces and c (r̂_j/r_b)⁴ on torques, c = 0.05, is a uniform-rate damper with node rate
    /// c/(ρπr_b²) and element rates 4c/(ρπr_b⁴) about d1, d2 and half that about d3. `density` ρ
    /// [kg/m³] and `base_radius` r_b [m] of the arm.
    pub fn coomm(density: f64, base_radius: f64) -> Self {
        let c = 0.05;
        let pi = std::f64::consts::PI;
        let rot = 4.0 * c / (density * pi * base_radius.powi(4));
        Self {
            analytical: Some(AnalyticalDamper::Rates {
                translational: c / (density * pi * base_radius * base_radius),
                rotational: [rot, rot, 0.5 * rot],
            }),
            ..Self::default()
        }
    }

    /// Check every coefficient (finite, ≥ 0).
    pub fn validate(&self) -> Result<(), ModelError> {
        non_negative("damping.rate", self.rate)?;
        non_negative("damping.gamma", self.gamma)?;
        match self.analytical {
            None => {}
            Some(AnalyticalDamper::Uniform { nu }) | Some(AnalyticalDamper::Legacy { nu }) => {
                non_negative("damping.nu", nu)?;
            }
            Some(AnalyticalDamper::Physical {
                translational,
                rotational,
            }) => {
                non_negative("damping.translational", translational)?;
                non_negative("damping.rotational", rotational)?;
            }
            Some(AnalyticalDamper::Rates {
                translational,
                rotational,
            }) => {
                non_negative("damping.translational", translational)?;
                for r in rotational {
                    non_negative("damping.rotational", r)?;
                }
            }
        }
        Ok(())
    }

    /// Decay rate λ_i [1/s] of node i.
    pub fn node_rate(&self, model: &RodModel, i: usize) -> f64 {
        self.rate + self.gamma * model.nodal_rest_length[i] / model.node_mass[i]
    }

    /// Decay rate λ_j [1/s] of element j at dilatation e (the same for all three components).
    pub fn element_rate(&self, model: &RodModel, j: usize, e: f64) -> f64 {
        self.rate + e * self.gamma / (model.material.density * model.area[j])
    }
}

/// φ1(z) = (1 − e^{−z})/z, with its series for small z.
#[inline]
pub(crate) fn phi1(z: f64) -> f64 {
    if z < 1e-4 {
        1.0 - z / 2.0 + z * z / 6.0
    } else {
        (1.0 - (-z).exp()) / z
    }
}

/// Precomputed exponential-kick factors (spec eq. 8.3), v ← decay v + kick a, for every node and
/// element of a system (system order), refreshed per rod when dt or its damping changes.
#[derive(Debug, Clone, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub(crate) struct KickFactors {
    /// Per rod: (dt, rate, gamma) the rod's factors were computed for.
    pub keys: Vec<(f64, f64, f64)>,
    pub node_decay: Vec<f64>,
    pub node_kick: Vec<f64>,
    pub node_rate: Vec<f64>,
    /// Element rate at e = 1, and its decay/kick factors at e = 1.
    pub element_rate0: Vec<f64>,
    pub element_decay0: Vec<f64>,
    pub element_kick0: Vec<f64>,
    /// Per-length part of the element rate at e = 1 (scaled by e each step).
    pub element_gamma_rate: Vec<f64>,
}

impl KickFactors {
    /// Buffers for a system of `n_rods` rods, `n_nodes` nodes and `n_elements` elements; every
    /// rod is computed on the first `refresh_rod`.
    pub fn new(n_rods: usize, n_nodes: usize, n_elements: usize) -> Self {
        Self {
            keys: vec![(f64::NAN, f64::NAN, f64::NAN); n_rods],
            node_decay: vec![0.0; n_nodes],
            node_kick: vec![0.0; n_nodes],
            node_rate: vec![0.0; n_nodes],
            element_rate0: vec![0.0; n_elements],
            element_decay0: vec![0.0; n_elements],
            element_kick0: vec![0.0; n_elements],
            element_gamma_rate: vec![0.0; n_elements],
        }
    }

    /// Recompute rod `r`'s factors (nodes from `first_node`, elements from `first_element`) when
    /// dt or its damping coefficients changed. Writes in place: no allocation.
    pub fn refresh_rod(
        &mut self,
        r: usize,
        model: &RodModel,
        damping: &Damping,
        dt: f64,
        first_node: usize,
        first_element: usize,
    ) {
        let key = (dt, damping.rate, damping.gamma);
        if key == self.keys[r] {
            return;
        }
        self.keys[r] = key;
        let nn = model.n_nodes();
        let ne = model.n_elements;
        for i in 0..nn {
            let l = damping.node_rate(model, i);
            let k = first_node + i;
            self.node_rate[k] = l;
            self.node_decay[k] = (-l * dt).exp();
            self.node_kick[k] = dt * phi1(l * dt);
        }
        for j in 0..ne {
            let l = damping.element_rate(model, j, 1.0);
            let k = first_element + j;
            self.element_rate0[k] = l;
            self.element_decay0[k] = (-l * dt).exp();
            self.element_kick0[k] = dt * phi1(l * dt);
            self.element_gamma_rate[k] = damping.gamma / (model.material.density * model.area[j]);
        }
    }

    /// Decay and kick factors of element k (system index) at dilatation e, and its rate.
    #[inline(always)]
    pub fn element(&self, k: usize, e: f64, dt: f64, gamma_active: bool) -> (f64, f64, f64) {
        if !gamma_active {
            return (
                self.element_decay0[k],
                self.element_kick0[k],
                self.element_rate0[k],
            );
        }
        let lam0 = self.element_rate0[k];
        let lam = lam0 + (e - 1.0) * self.element_gamma_rate[k];
        let decay = if lam0 * dt < 1e-2 {
            // First-order correction of the precomputed factor (spec §8a).
            self.element_decay0[k] * (1.0 - (lam - lam0) * dt)
        } else {
            (-lam * dt).exp()
        };
        let z = lam * dt;
        let kick = if z < 1e-4 {
            dt * (1.0 - z / 2.0 + z * z / 6.0)
        } else {
            dt * (1.0 - decay) / z
        };
        (decay, kick, lam)
    }
}
