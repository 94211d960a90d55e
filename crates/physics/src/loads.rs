//! External loads (spec §9): gravity (and the net weight in water), point and distributed forces, point, distributed and
//! follower couples, each on one rod and scaled by a time `Schedule`. Forces are lab frame on
//! nodes; couples are accumulated in the material frame of each element. Contact, joints and
//! actuation are added elsewhere (`contact.rs`, `joints.rs`, `actuation.rs`).

use crate::error::{finite_vec, ModelError};
use crate::math::{mat_vec, Vec3};
use crate::model::RodModel;
use crate::schedule::Schedule;
use crate::state::{RodAccess, RodView};
use crate::store::Vec3s;

/// External loads of one force evaluation for a whole system: nodal forces (lab) and element
/// couples (material), in the system's node and element order.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct ExternalLoads {
    /// Force on each node [N], lab frame.
    pub force: Vec3s,
    /// Couple on each element [N m], material frame of that element.
    pub couple: Vec3s,
}

impl ExternalLoads {
    /// Zero loads for `n_nodes` nodes and `n_elements` elements.
    pub fn zeros(n_nodes: usize, n_elements: usize) -> Self {
        Self {
            force: Vec3s::zeros(n_nodes),
            couple: Vec3s::zeros(n_elements),
        }
    }

    /// Reset to zero without reallocating.
    pub fn clear(&mut self) {
        self.force.fill_zero();
        self.couple.fill_zero();
    }
}

/// One external load on one rod (its value at schedule factor 1).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Load {
    /// Uniform gravitational acceleration g [m/s²]: F_i += m_i g.
    Gravity {
        /// Acceleration [m/s²], lab frame.
        acceleration: Vec3,
    },
    /// Point force on one node [N], lab frame.
    NodeForce {
        /// Node index (n for the tip).
        node: usize,
        /// Force [N].
        force: Vec3,
    },
    /// Distributed force per unit rest length [N/m], lab frame: F_i += p ℓ̂_i.
    UniformForce {
        /// Force per length [N/m].
        force_per_length: Vec3,
    },
    /// Point couple on one element [N m], lab frame: C_j += Q_j M.
    ElementCouple {
        /// Element index (n − 1 for the tip).
        element: usize,
        /// Couple [N m], lab frame.
        couple: Vec3,
    },
    /// Point follower couple on one element [N m], material frame: C_j += M.
    FollowerElementCouple {
        /// Element index.
        element: usize,
        /// Couple [N m], material frame (turns with the element).
        couple: Vec3,
    },
    /// Distributed couple per unit rest length [N m/m], lab frame: C_j += Q_j c l̂_j.
    UniformCouple {
        /// Couple per length [N], lab frame.
        couple_per_length: Vec3,
    },
    /// Distributed follower couple per unit rest length [N], material frame: C_j += c l̂_j.
    FollowerCouple {
        /// Couple per length [N], material frame.
        couple_per_length: Vec3,
    },
    /// Morison drag (no added mass) per element (muscles-3d spec eq. 3.1, COOMM's `DragForce`):
    /// with the element-mean velocity u = Q_j ½(v_j + v_{j+1}) (material), the projected area
    /// P_j = 2 r_j l_j (current radius r̂_j/√e_j and length) and the wetted area π P_j,
    /// f = −½ ρ_w (c⊥ P|u₁|u₁, c⊥ P|u₂|u₂, c∥ π P|u₃|u₃), half of Q_jᵀ f on each node.
    Drag {
        /// Fluid density ρ_w [kg/m³], ≥ 0.
        fluid_density: f64,
        /// Normal drag coefficient c⊥ [-], ≥ 0.
        normal_coefficient: f64,
        /// Tangential drag coefficient c∥ [-], ≥ 0.
        tangential_coefficient: f64,
    },
}

impl Load {
    /// A tip force on node n of a rod with `n_elements` elements.
    pub fn tip_force(n_elements: usize, force: Vec3) -> Self {
        Load::NodeForce {
            node: n_elements,
            force,
        }
    }

    /// A lab-frame tip couple on element n − 1.
    pub fn tip_couple(n_elements: usize, couple: Vec3) -> Self {
        Load::ElementCouple {
            element: n_elements - 1,
            couple,
        }
    }

    /// COOMM's drag for `model` (spec §3.1): ρ_w = 1022 kg/m³, c⊥ = 0.41/(ρ_w r̄ l̄),
    /// c∥ = 0.033/(ρ_w π r̄ l̄), r̄ and l̄ the mean element radius and rest length (for a linear
    /// taper r̄ = (r_b + r_t)/2).
    pub fn coomm_drag(model: &RodModel) -> Self {
        let n = model.n_elements as f64;
        let r_mean = model.radius.iter().sum::<f64>() / n;
        let l_mean = model.rest_length.iter().sum::<f64>() / n;
        let rho = 1022.0;
        Load::Drag {
            fluid_density: rho,
            normal_coefficient: 0.41 / (rho * r_mean * l_mean),
            tangential_coefficient: 0.033 / (rho * std::f64::consts::PI * r_mean * l_mean),
        }
    }

    /// The net weight in water (muscles-3d spec §3.3; off unless added): per element
    /// (ρ − ρ_w) g Â_j l̂_j, half to each of its nodes, with ρ the rod's density. Built as
    /// `Gravity` with the reduced acceleration g (1 − ρ_w/ρ): the node masses are ½ ρ Â_j l̂_j
    /// per adjacent element, so this is the same load (to round-off), and the gravity
    /// potential of the energy bookkeeping stays its exact potential. Errors: `fluid_density`
    /// not in [0, inf) or `gravity` not finite, named.
    pub fn net_weight(
        model: &RodModel,
        fluid_density: f64,
        gravity: Vec3,
    ) -> Result<Self, ModelError> {
        crate::error::non_negative("net_weight.fluid_density", fluid_density)?;
        finite_vec("net_weight.gravity", gravity)?;
        let f = 1.0 - fluid_density / model.material.density;
        Ok(Load::Gravity {
            acceleration: [f * gravity[0], f * gravity[1], f * gravity[2]],
        })
    }

    /// The scenario name of the kind.
    pub fn kind_name(&self) -> &'static str {
        match self {
            Load::Gravity { .. } => "gravity",
            Load::NodeForce { .. } => "node_force",
            Load::UniformForce { .. } => "uniform_force",
            Load::ElementCouple { .. } => "element_couple",
            Load::FollowerElementCouple { .. } => "follower_element_couple",
            Load::UniformCouple { .. } => "uniform_couple",
            Load::FollowerCouple { .. } => "follower_couple",
            Load::Drag { .. } => "drag",
        }
    }

    /// Check indices and values against the model of the rod it acts on.
    pub fn validate(&self, model: &RodModel) -> Result<(), ModelError> {
        match *self {
            Load::Gravity { acceleration } => finite_vec("gravity", acceleration).map(|_| ()),
            Load::NodeForce { node, force } => {
                if node > model.n_elements {
                    return Err(ModelError::CountOutOfRange {
                        field: "node",
                        value: node,
                        range: "[0, n_elements]",
                    });
                }
                finite_vec("force", force).map(|_| ())
            }
            Load::UniformForce { force_per_length } => {
                finite_vec("force_per_length", force_per_length).map(|_| ())
            }
            Load::ElementCouple { element, couple }
            | Load::FollowerElementCouple { element, couple } => {
                if element >= model.n_elements {
                    return Err(ModelError::CountOutOfRange {
                        field: "element",
                        value: element,
                        range: "[0, n_elements - 1]",
                    });
                }
                finite_vec("couple", couple).map(|_| ())
            }
            Load::UniformCouple { couple_per_length }
            | Load::FollowerCouple { couple_per_length } => {
                finite_vec("couple_per_length", couple_per_length).map(|_| ())
            }
            Load::Drag {
                fluid_density,
                normal_coefficient,
                tangential_coefficient,
            } => {
                crate::error::non_negative("drag.fluid_density", fluid_density)?;
                crate::error::non_negative("drag.normal_coefficient", normal_coefficient)?;
                crate::error::non_negative("drag.tangential_coefficient", tangential_coefficient)
                    .map(|_| ())
            }
        }
    }

    /// Add this load times `k` on the rod `s` (model `model`, nodes from `first_node`, elements
    /// from `first_element` in `out`). `inline(always)`: compiled into the stepper's kernels
    /// (AVX2/FMA code in `step_avx2`).
    #[inline(always)]
    pub(crate) fn apply(
        &self,
        model: &RodModel,
        s: &RodView<'_>,
        k: f64,
        first_node: usize,
        first_element: usize,
        out: &mut ExternalLoads,
    ) {
        let n = model.n_elements;
        // Every product is formed as k · (value), so that k = 1 gives the unscaled value exactly.
        match *self {
            Load::Gravity { acceleration: g } => {
                for (i, m) in model.node_mass.iter().enumerate() {
                    out.force.add(
                        first_node + i,
                        [k * (m * g[0]), k * (m * g[1]), k * (m * g[2])],
                    );
                }
            }
            Load::NodeForce { node, force } => {
                out.force.add(
                    first_node + node,
                    [k * force[0], k * force[1], k * force[2]],
                );
            }
            Load::UniformForce {
                force_per_length: p,
            } => {
                for (i, l) in model.nodal_rest_length.iter().enumerate() {
                    out.force.add(
                        first_node + i,
                        [k * (p[0] * l), k * (p[1] * l), k * (p[2] * l)],
                    );
                }
            }
            Load::ElementCouple { element, couple } => {
                let m = mat_vec(&s.director(element), couple);
                out.couple
                    .add(first_element + element, [k * m[0], k * m[1], k * m[2]]);
            }
            Load::FollowerElementCouple { element, couple } => {
                out.couple.add(
                    first_element + element,
                    [k * couple[0], k * couple[1], k * couple[2]],
                );
            }
            Load::UniformCouple { couple_per_length } => {
                for j in 0..n {
                    let m = mat_vec(&s.director(j), couple_per_length);
                    let l = model.rest_length[j];
                    out.couple.add(
                        first_element + j,
                        [k * (m[0] * l), k * (m[1] * l), k * (m[2] * l)],
                    );
                }
            }
            Load::FollowerCouple {
                couple_per_length: c,
            } => {
                for j in 0..n {
                    let l = model.rest_length[j];
                    out.couple.add(
                        first_element + j,
                        [k * (c[0] * l), k * (c[1] * l), k * (c[2] * l)],
                    );
                }
            }
            Load::Drag {
                fluid_density: rho,
                normal_coefficient: cn,
                tangential_coefficient: ct,
            } => {
                let (p, v) = (&s.position, &s.velocity);
                let half = -0.5 * rho * k;
                let pi = std::f64::consts::PI;
                let (r, lr) = (&model.radius[..n], &model.rest_length[..n]);
                // Each node gets half of each adjacent element's force: carry the previous
                // element's half to its shared node (one store per node).
                let mut prev = [0.0; 3];
                for j in 0..n {
                    let dx = [
                        p[0][j + 1] - p[0][j],
                        p[1][j + 1] - p[1][j],
                        p[2][j + 1] - p[2][j],
                    ];
                    // P_j = 2 r_j l_j with the current radius r̂_j/√e_j, e_j = l_j/l̂_j:
                    // 2 r̂_j l_j/√(l_j/l̂_j) = 2 r̂_j √(l_j l̂_j) (one square root, no division).
                    let l = (dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2]).sqrt();
                    let area = 2.0 * r[j] * (l * lr[j]).sqrt();
                    let vm = [
                        0.5 * (v[0][j] + v[0][j + 1]),
                        0.5 * (v[1][j] + v[1][j + 1]),
                        0.5 * (v[2][j] + v[2][j + 1]),
                    ];
                    let q = s.director(j);
                    let u = mat_vec(&q, vm);
                    let an = half * cn * area;
                    let at = half * ct * pi * area;
                    let f = [
                        an * u[0].abs() * u[0],
                        an * u[1].abs() * u[1],
                        at * u[2].abs() * u[2],
                    ];
                    let fl = crate::math::mat_t_vec(&q, f);
                    let h = [0.5 * fl[0], 0.5 * fl[1], 0.5 * fl[2]];
                    out.force.add(
                        first_node + j,
                        [prev[0] + h[0], prev[1] + h[1], prev[2] + h[2]],
                    );
                    prev = h;
                }
                out.force.add(first_node + n, prev);
            }
        }
    }
}

/// A load on one rod of a system with its schedule.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct AppliedLoad {
    /// Index of the rod in the system.
    pub rod: usize,
    /// The load at factor 1.
    pub load: Load,
    /// Time factor.
    pub schedule: Schedule,
}
