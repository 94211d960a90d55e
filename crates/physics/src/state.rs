//! The evolving state: `SystemState` holds every rod of a system in one structure-of-arrays store
//! (node positions and velocities in the lab frame, element directors, element angular
//! velocities in the material frame), the step count and time, and the work and dissipation
//! accumulated per rod. `RodState` is one rod as plain arrays of vectors, for building and
//! reading; `RodView` borrows one rod of a system store. The model lives in `model.rs`.

use crate::math::{Mat3, Vec3};
use crate::store::{Mat3s, Vec3s};

/// Positions, velocities, frames and angular velocities of one rod at one instant (SI units),
/// as arrays of vectors: the form in which rods are built, handed to controllers and recorded.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
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

/// The state of a whole rod system. Rod r occupies the node range and element range its
/// `Rod` entry in the system gives; there are no padding entries between rods.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct SystemState {
    /// Simulated time t = `origin + step · dt` [s] (computed from the step count, never summed).
    pub time: f64,
    /// Steps taken since the time origin.
    pub step: u64,
    /// Time at step 0 [s]; 0 unless the run started from a recorded state at another time.
    pub origin: f64,
    /// Node positions x [m], lab frame, all rods.
    pub position: Vec3s,
    /// Node velocities v [m/s], lab frame, all rods.
    pub velocity: Vec3s,
    /// Element directors Q (rows d1, d2, d3), all rods.
    pub director: Mat3s,
    /// Element angular velocities ω [rad/s], material frame, all rods.
    pub omega: Vec3s,
    /// Work of the external loads (loads, contact, joints, actuation) since t = 0 [J], per rod
    /// (midpoint velocities, spec §12).
    pub work: Vec<f64>,
    /// Energy removed by damping since t = 0 [J], per rod.
    pub dissipated: Vec<f64>,
    /// Stick springs of obstacle friction [m]: the tangential displacement held per element
    /// and frictional obstacle (obstacle-major: spheres, then planes with two per element —
    /// one at each end node —, then cylinders; system element order). The contact's only
    /// memory, so part of the state; sized by `RodSystem::fit_stick` (empty without
    /// frictional obstacles).
    #[cfg_attr(feature = "serde", serde(default))]
    pub stick: Vec<Vec3>,
}

impl SystemState {
    /// An empty state at t = 0 (rods are appended by the system builder).
    pub(crate) fn empty() -> Self {
        Self {
            time: 0.0,
            step: 0,
            origin: 0.0,
            position: Vec3s::default(),
            velocity: Vec3s::default(),
            director: Mat3s::default(),
            omega: Vec3s::default(),
            work: Vec::new(),
            dissipated: Vec::new(),
            stick: Vec::new(),
        }
    }

    /// Append one rod's arrays.
    pub(crate) fn push_rod(&mut self, s: &RodState) {
        self.position.extend(&s.position);
        self.velocity.extend(&s.velocity);
        self.director.extend(&s.director);
        self.omega.extend(&s.omega);
        self.work.push(0.0);
        self.dissipated.push(0.0);
    }

    /// Borrow the rod whose nodes start at `first_node` and elements at `first_element`, with
    /// `n` elements.
    #[inline]
    pub fn view(&self, first_node: usize, first_element: usize, n: usize) -> RodView<'_> {
        let nodes = first_node..first_node + n + 1;
        let elems = first_element..first_element + n;
        let p = &self.position;
        let v = &self.velocity;
        let w = &self.omega;
        RodView {
            n,
            position: [
                &p.x[nodes.clone()],
                &p.y[nodes.clone()],
                &p.z[nodes.clone()],
            ],
            velocity: [&v.x[nodes.clone()], &v.y[nodes.clone()], &v.z[nodes]],
            director: std::array::from_fn(|k| &self.director.m[k][elems.clone()]),
            omega: [&w.x[elems.clone()], &w.y[elems.clone()], &w.z[elems]],
        }
    }

    /// Copy of one rod's state as arrays of vectors (allocates).
    pub fn rod_state(&self, first_node: usize, first_element: usize, n: usize) -> RodState {
        RodState {
            time: self.time,
            position: self.position.to_vec(first_node..first_node + n + 1),
            velocity: self.velocity.to_vec(first_node..first_node + n + 1),
            director: self.director.to_vec(first_element..first_element + n),
            omega: self.omega.to_vec(first_element..first_element + n),
        }
    }

    /// Overwrite one rod's positions, velocities, directors and angular velocities.
    pub(crate) fn write_rod(&mut self, first_node: usize, first_element: usize, s: &RodState) {
        self.position.write(first_node, &s.position);
        self.velocity.write(first_node, &s.velocity);
        self.director.write(first_element, &s.director);
        self.omega.write(first_element, &s.omega);
    }
}

/// One rod of a system store, borrowed: component slices of its nodes and elements.
#[derive(Debug, Clone, Copy)]
pub struct RodView<'a> {
    /// Number of elements n.
    pub n: usize,
    /// x, y, z of the n + 1 node positions [m].
    pub position: [&'a [f64]; 3],
    /// x, y, z of the n + 1 node velocities [m/s].
    pub velocity: [&'a [f64]; 3],
    /// The nine director entries (row-major) of the n elements.
    pub director: [&'a [f64]; 9],
    /// The three material components of the n angular velocities [rad/s].
    pub omega: [&'a [f64]; 3],
}

/// Read access to one rod's state, whichever way it is stored: the energy and strain functions
/// take either a `RodView` of a system or a `&RodState`.
pub trait RodAccess {
    /// Number of elements n.
    fn n_elements(&self) -> usize;
    /// Position of node i [m].
    fn position(&self, i: usize) -> Vec3;
    /// Velocity of node i [m/s].
    fn velocity(&self, i: usize) -> Vec3;
    /// Director matrix of element j.
    fn director(&self, j: usize) -> Mat3;
    /// Angular velocity of element j [rad/s], material frame.
    fn omega(&self, j: usize) -> Vec3;
}

impl RodAccess for RodView<'_> {
    fn n_elements(&self) -> usize {
        self.n
    }
    #[inline(always)]
    fn position(&self, i: usize) -> Vec3 {
        [
            self.position[0][i],
            self.position[1][i],
            self.position[2][i],
        ]
    }
    #[inline(always)]
    fn velocity(&self, i: usize) -> Vec3 {
        [
            self.velocity[0][i],
            self.velocity[1][i],
            self.velocity[2][i],
        ]
    }
    #[inline(always)]
    fn director(&self, j: usize) -> Mat3 {
        let d = &self.director;
        [
            [d[0][j], d[1][j], d[2][j]],
            [d[3][j], d[4][j], d[5][j]],
            [d[6][j], d[7][j], d[8][j]],
        ]
    }
    #[inline(always)]
    fn omega(&self, j: usize) -> Vec3 {
        [self.omega[0][j], self.omega[1][j], self.omega[2][j]]
    }
}

impl RodAccess for RodState {
    fn n_elements(&self) -> usize {
        self.director.len()
    }
    #[inline(always)]
    fn position(&self, i: usize) -> Vec3 {
        self.position[i]
    }
    #[inline(always)]
    fn velocity(&self, i: usize) -> Vec3 {
        self.velocity[i]
    }
    #[inline(always)]
    fn director(&self, j: usize) -> Mat3 {
        self.director[j]
    }
    #[inline(always)]
    fn omega(&self, j: usize) -> Vec3 {
        self.omega[j]
    }
}
