//! Joints between rod ends (PyElastica's FreeJoint / HingeJoint / FixedJoint, after Zhang et al.
//! 2019): penalty springs and dampers on the relative position of two end nodes and, for hinge
//! and fixed joints, on the relative orientation of the two end elements. Forces are added to the
//! external loads (lab), couples to the element couples (material); each pair is equal and
//! opposite. Stiffness defaults come from the rods' own stiffness (`JointParams::default_for`).

use crate::ends::Side;
use crate::error::{non_negative, ModelError};
use crate::loads::ExternalLoads;
use crate::math::{dot, log_relative, mat_mul, mat_vec, transpose, Mat3, Vec3};
use crate::model::RodModel;

/// What a joint constrains.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum JointKind {
    /// Relative position only (a ball joint: PyElastica's FreeJoint).
    Free,
    /// Relative position and every relative rotation except about `axis` (PyElastica's
    /// HingeJoint). `axis` [-] is given in the lab frame at t = 0 and turns with the first
    /// rod's end element afterwards.
    Hinge {
        /// Hinge axis (normalised on build), lab frame at t = 0.
        axis: Vec3,
    },
    /// Relative position and orientation, held at their initial values (PyElastica's
    /// FixedJoint with the rest rotation of the initial state).
    Fixed,
}

impl JointKind {
    /// "free", "hinge" or "fixed".
    pub fn name(&self) -> &'static str {
        match self {
            JointKind::Free => "free",
            JointKind::Hinge { .. } => "hinge",
            JointKind::Fixed => "fixed",
        }
    }
}

/// One end of a joint: a rod and which of its ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct JointEnd {
    /// Index of the rod in the system.
    pub rod: usize,
    /// Its base or tip.
    pub side: Side,
}

/// Spring and damper constants of a joint.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct JointParams {
    /// Translational stiffness k [N/m]: F = k (x₂ − x₁) on the first end node.
    pub stiffness: f64,
    /// Translational damping ν [N s/m]: F += ν (v₂ − v₁) (the full relative velocity;
    /// PyElastica damps only its component along x₂ − x₁, which is undefined at zero gap).
    pub damping: f64,
    /// Rotational stiffness k_t [N m/rad] (hinge, fixed).
    pub rotational_stiffness: f64,
    /// Rotational damping ν_t [N m s/rad] (hinge, fixed).
    pub rotational_damping: f64,
}

impl JointParams {
    /// Defaults from the two rods' end elements: k = min E Â/l̂ (the axial stiffness of the
    /// softer end element, so the joint's frequency stays at the rods' own axial scale and never
    /// sets the time step), k_t = B̄/D̂ with B̄ the rest-length weighted bend stiffness E I₁ of the
    /// two end elements and D̂ the mean of their rest lengths (what the Voronoi point between
    /// them would have if the two rods were one: eq. 3.2), and no damping.
    pub fn default_for(a: (&RodModel, Side), b: (&RodModel, Side)) -> Self {
        let end = |(m, side): (&RodModel, Side)| {
            let j = side.element(m.n_elements);
            let l = m.rest_length[j];
            let e = m.material.youngs_modulus;
            (e * m.area[j] / l, e * m.second_moment[j][0], l)
        };
        let (ka, ba, la) = end(a);
        let (kb, bb, lb) = end(b);
        let bend = (la * ba + lb * bb) / (la + lb);
        Self {
            stiffness: ka.min(kb),
            damping: 0.0,
            rotational_stiffness: bend / (0.5 * (la + lb)),
            rotational_damping: 0.0,
        }
    }

    /// Check every constant (finite, ≥ 0).
    pub fn validate(&self) -> Result<(), ModelError> {
        non_negative("joint.stiffness", self.stiffness)?;
        non_negative("joint.damping", self.damping)?;
        non_negative("joint.rotational_stiffness", self.rotational_stiffness)?;
        non_negative("joint.rotational_damping", self.rotational_damping)?;
        Ok(())
    }
}

/// A joint between two rod ends of a system.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Joint {
    /// What it constrains.
    pub kind: JointKind,
    /// The first end (gets +F).
    pub first: JointEnd,
    /// The second end (gets −F).
    pub second: JointEnd,
    /// Spring and damper constants.
    pub params: JointParams,
    /// C = Q₁⁰ᵀ Q₂⁰ of the initial frames (the rest relative rotation), set on build.
    pub(crate) rest: Mat3,
    /// Hinge axis in the first end element's material frame, set on build.
    pub(crate) axis_material: Vec3,
}

impl Joint {
    /// A joint; its rest rotation and axis are taken from the initial state when the system is
    /// built.
    pub fn new(kind: JointKind, first: JointEnd, second: JointEnd, params: JointParams) -> Self {
        Self {
            kind,
            first,
            second,
            params,
            rest: crate::math::IDENTITY,
            axis_material: [0.0; 3],
        }
    }

    /// Record the rest relative rotation and the hinge axis from the initial end frames.
    pub(crate) fn set_rest(&mut self, q1: &Mat3, q2: &Mat3) -> Result<(), ModelError> {
        self.rest = mat_mul(&transpose(q1), q2);
        if let JointKind::Hinge { axis } = self.kind {
            let l2 = dot(axis, axis);
            let a = if l2.is_normal() && l2.is_finite() {
                let l = l2.sqrt();
                [axis[0] / l, axis[1] / l, axis[2] / l]
            } else {
                // Tiny or huge axes ([1e-300, 0, 0]): scaled by their largest component first.
                crate::math::normalize(axis).ok_or(ModelError::BadVector {
                    field: "joint.axis",
                    value: axis,
                    reason: "must be finite and non-zero",
                })?
            };
            self.axis_material = mat_vec(q1, a);
        }
        Ok(())
    }

    /// Add this joint's loads to `out`. `x`, `v` are the two end nodes' positions and
    /// velocities, `q`, `w` the two end elements' frames and material angular velocities; `node`
    /// and `element` their system indices.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn apply(
        &self,
        x: [Vec3; 2],
        v: [Vec3; 2],
        q: [&Mat3; 2],
        w: [Vec3; 2],
        node: [usize; 2],
        element: [usize; 2],
        out: &mut ExternalLoads,
    ) {
        let p = &self.params;
        let mut f = [0.0; 3];
        for c in 0..3 {
            f[c] = p.stiffness * (x[1][c] - x[0][c]) + p.damping * (v[1][c] - v[0][c]);
        }
        out.force.add(node[0], f);
        out.force.add(node[1], [-f[0], -f[1], -f[2]]);
        if matches!(self.kind, JointKind::Free) {
            return;
        }
        // Lab rotation vector θ of R = Q₂ᵀ Q₁ C: how far frame 2 has turned away from where the
        // rest rotation C puts it relative to frame 1. R = A Bᵀ with A = Q₂ᵀ, B = Cᵀ Q₁ᵀ.
        let a = transpose(q[1]);
        let b = mat_mul(&transpose(&self.rest), &transpose(q[0]));
        let (mut theta, _) = log_relative(&a, &b);
        // Relative angular velocity, lab: Q₂ᵀ ω₂ − Q₁ᵀ ω₁.
        let w2 = crate::math::mat_t_vec(q[1], w[1]);
        let w1 = crate::math::mat_t_vec(q[0], w[0]);
        let mut dw = [w2[0] - w1[0], w2[1] - w1[1], w2[2] - w1[2]];
        if matches!(self.kind, JointKind::Hinge { .. }) {
            let axis = crate::math::mat_t_vec(q[0], self.axis_material);
            let (ta, wa) = (dot(theta, axis), dot(dw, axis));
            for c in 0..3 {
                theta[c] -= ta * axis[c];
                dw[c] -= wa * axis[c];
            }
        }
        let mut tau = [0.0; 3];
        for c in 0..3 {
            tau[c] = -p.rotational_stiffness * theta[c] - p.rotational_damping * dw[c];
        }
        // τ acts on the second element, −τ on the first (lab), stored in material frames.
        out.couple.add(element[1], mat_vec(q[1], tau));
        let m1 = mat_vec(q[0], tau);
        out.couple.add(element[0], [-m1[0], -m1[1], -m1[2]]);
    }

    /// Elastic energy of the joint's springs [J]: ½ k |x₂ − x₁|² + ½ k_t |θ|² (θ without its
    /// axis component for a hinge).
    pub(crate) fn energy(&self, x: [Vec3; 2], q: [&Mat3; 2]) -> f64 {
        let d = [x[1][0] - x[0][0], x[1][1] - x[0][1], x[1][2] - x[0][2]];
        let mut e = 0.5 * self.params.stiffness * dot(d, d);
        if !matches!(self.kind, JointKind::Free) {
            let a = transpose(q[1]);
            let b = mat_mul(&transpose(&self.rest), &transpose(q[0]));
            let (mut theta, _) = log_relative(&a, &b);
            if matches!(self.kind, JointKind::Hinge { .. }) {
                let axis = crate::math::mat_t_vec(q[0], self.axis_material);
                let ta = dot(theta, axis);
                for c in 0..3 {
                    theta[c] -= ta * axis[c];
                }
            }
            e += 0.5 * self.params.rotational_stiffness * dot(theta, theta);
        }
        e
    }
}
