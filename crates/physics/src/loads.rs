//! External loads (spec §9): gravity, point and distributed forces, point, distributed and follower
//! couples, with optional linear ramps. Forces are lab frame on nodes; couples are accumulated in
//! the material frame of each element. Contact and control loads are added elsewhere.

use crate::error::{finite_vec, non_negative, ModelError};
use crate::math::{mat_vec, Vec3};
use crate::model::RodModel;
use crate::state::RodState;

/// External loads of one force evaluation: nodal forces (lab) and element couples (material).
#[derive(Debug, Clone, PartialEq)]
pub struct ExternalLoads {
    /// Force on each node [N], lab frame, n + 1 entries.
    pub force: Vec<Vec3>,
    /// Couple on each element [N m], material frame of that element, n entries.
    pub couple: Vec<Vec3>,
}

impl ExternalLoads {
    /// Zero loads for a rod of `n` elements.
    pub fn zeros(n_elements: usize) -> Self {
        Self {
            force: vec![[0.0; 3]; n_elements + 1],
            couple: vec![[0.0; 3]; n_elements],
        }
    }

    /// Reset to zero without reallocating.
    pub fn clear(&mut self) {
        self.force.fill([0.0; 3]);
        self.couple.fill([0.0; 3]);
    }
}

/// One external load. `ramp_time` > 0 scales a load by min(1, t / ramp_time).
#[derive(Debug, Clone, Copy, PartialEq)]
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
        /// Ramp duration [s]; 0 applies the full force at once.
        ramp_time: f64,
    },
    /// Constant distributed force per unit rest length [N/m], lab frame: F_i += p ℓ̂_i.
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
        /// Ramp duration [s]; 0 applies the full couple at once.
        ramp_time: f64,
    },
    /// Constant distributed couple per unit rest length [N m/m], lab frame: C_j += Q_j c l̂_j.
    UniformCouple {
        /// Couple per length [N], lab frame.
        couple_per_length: Vec3,
    },
    /// Constant distributed follower couple per unit rest length [N], material frame.
    FollowerCouple {
        /// Couple per length [N], material frame.
        couple_per_length: Vec3,
    },
}

impl Load {
    /// A tip force on node n of a rod with `n_elements` elements.
    pub fn tip_force(n_elements: usize, force: Vec3) -> Self {
        Load::NodeForce {
            node: n_elements,
            force,
            ramp_time: 0.0,
        }
    }

    /// A lab-frame tip couple on element n − 1.
    pub fn tip_couple(n_elements: usize, couple: Vec3) -> Self {
        Load::ElementCouple {
            element: n_elements - 1,
            couple,
            ramp_time: 0.0,
        }
    }

    /// Check indices and values against the model.
    pub fn validate(&self, model: &RodModel) -> Result<(), ModelError> {
        match *self {
            Load::Gravity { acceleration } => finite_vec("gravity", acceleration).map(|_| ()),
            Load::NodeForce {
                node,
                force,
                ramp_time,
            } => {
                if node > model.n_elements {
                    return Err(ModelError::CountOutOfRange {
                        field: "node",
                        value: node,
                        range: "[0, n_elements]",
                    });
                }
                finite_vec("force", force)?;
                non_negative("ramp_time", ramp_time).map(|_| ())
            }
            Load::UniformForce { force_per_length } => {
                finite_vec("force_per_length", force_per_length).map(|_| ())
            }
            Load::ElementCouple {
                element,
                couple,
                ramp_time,
            } => {
                if element >= model.n_elements {
                    return Err(ModelError::CountOutOfRange {
                        field: "element",
                        value: element,
                        range: "[0, n_elements - 1]",
                    });
                }
                finite_vec("couple", couple)?;
                non_negative("ramp_time", ramp_time).map(|_| ())
            }
            Load::UniformCouple { couple_per_length }
            | Load::FollowerCouple { couple_per_length } => {
                finite_vec("couple_per_length", couple_per_length).map(|_| ())
            }
        }
    }

    /// Add this load, evaluated at time `t` with the state `s`, to `out`.
    pub fn apply(&self, model: &RodModel, s: &RodState, t: f64, out: &mut ExternalLoads) {
        let ramp = |ramp_time: f64| {
            if ramp_time > 0.0 {
                (t / ramp_time).clamp(0.0, 1.0)
            } else {
                1.0
            }
        };
        match *self {
            Load::Gravity { acceleration: g } => {
                for (f, m) in out.force.iter_mut().zip(&model.node_mass) {
                    for c in 0..3 {
                        f[c] += m * g[c];
                    }
                }
            }
            Load::NodeForce {
                node,
                force,
                ramp_time,
            } => {
                let k = ramp(ramp_time);
                for c in 0..3 {
                    out.force[node][c] += k * force[c];
                }
            }
            Load::UniformForce {
                force_per_length: p,
            } => {
                for (f, l) in out.force.iter_mut().zip(&model.nodal_rest_length) {
                    for c in 0..3 {
                        f[c] += p[c] * l;
                    }
                }
            }
            Load::ElementCouple {
                element,
                couple,
                ramp_time,
            } => {
                let k = ramp(ramp_time);
                let m = mat_vec(&s.director[element], couple);
                for c in 0..3 {
                    out.couple[element][c] += k * m[c];
                }
            }
            Load::UniformCouple { couple_per_length } => {
                for j in 0..model.n_elements {
                    let m = mat_vec(&s.director[j], couple_per_length);
                    for c in 0..3 {
                        out.couple[j][c] += m[c] * model.rest_length[j];
                    }
                }
            }
            Load::FollowerCouple { couple_per_length } => {
                for j in 0..model.n_elements {
                    for c in 0..3 {
                        out.couple[j][c] += couple_per_length[c] * model.rest_length[j];
                    }
                }
            }
        }
    }
}
