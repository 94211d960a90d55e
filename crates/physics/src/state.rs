//! The evolving rod state: node positions and velocities (lab frame), element director frames and
//! angular velocities (material frame), and the simulated time. Flat contiguous arrays, one per
//! field; the model that gives them meaning lives in `model.rs`.

use crate::math::{Mat3, Vec3};

/// Positions, velocities, frames and angular velocities of one rod at one instant (SI units).
#[derive(Debug, Clone, PartialEq)]
pub struct RodState {
    /// Simulated time t [s].
    pub time: f64,
    /// Node positions x [m], lab frame, n + 1 entries.
    pub position: Vec<Vec3>,
    /// Node velocities v [m/s], lab frame, n + 1 entries.
    pub velocity: Vec<Vec3>,
    /// Element director matrices Q, rows d1, d2, d3 in lab components, n entries.
    pub director: Vec<Mat3>,
    /// Element angular velocities ω [rad/s], material frame, n entries.
    pub omega: Vec<Vec3>,
}

impl RodState {
    /// Number of elements n.
    pub fn n_elements(&self) -> usize {
        self.director.len()
    }

    /// Position of the last node [m].
    pub fn tip(&self) -> Vec3 {
        self.position[self.position.len() - 1]
    }

    /// Apply a rigid motion x → R x + b, v → R v, Q → Q Rᵀ (ω unchanged, it is material).
    pub fn rigid_transform(&mut self, r: &Mat3, b: Vec3) {
        use crate::math::{add, mat_mul_t, mat_vec};
        for x in self.position.iter_mut() {
            *x = add(mat_vec(r, *x), b);
        }
        for v in self.velocity.iter_mut() {
            *v = mat_vec(r, *v);
        }
        for q in self.director.iter_mut() {
            *q = mat_mul_t(q, r);
        }
    }
}
