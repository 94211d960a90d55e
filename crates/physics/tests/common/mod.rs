//! Helpers shared by the physics tests: the initial condition of spec §13 (d), a rotation by
//! Rodrigues' formula with libm (independent of the crate's kernel), small vector norms, and the
//! plumbing that evaluates internal loads of a lone `RodState` (the kernels read a system store).
//! Each test file uses a part of them.
#![allow(dead_code)]

use octoarm_physics::{
    InternalLoads, Mat3, Mat3s, Offsets, RodModel, RodState, Simulation, SystemState, Vec3, Vec3s,
};

/// Every bit of a simulation's evolving state: time, step count and origin, positions,
/// velocities, angular velocities, directors, work, dissipation and the friction stick springs
/// (for tests that compare runs to the last bit).
pub fn state_bits(sim: &Simulation) -> Vec<u64> {
    let s = &sim.state;
    let mut out = vec![s.time.to_bits(), s.step, s.origin.to_bits()];
    for v in [&s.position, &s.velocity, &s.omega] {
        for a in [&v.x, &v.y, &v.z] {
            out.extend(a.iter().map(|x| x.to_bits()));
        }
    }
    for a in &s.director.m {
        out.extend(a.iter().map(|x| x.to_bits()));
    }
    out.extend(s.work.iter().map(|x| x.to_bits()));
    out.extend(s.dissipated.iter().map(|x| x.to_bits()));
    out.extend(s.stick.iter().flatten().map(|x| x.to_bits()));
    out
}

/// The spec's initial condition (§13 d) on a built straight arm: v_i = A (ŝ_i/L0)² (0, 1, 0.4),
/// ω_j = (0, 0, 2 A s̄_j / L0²) (material frame), node 0 and element 0 left at rest; `a` = A
/// [m/s].
pub fn set_case_d_velocities(model: &RodModel, state: &mut RodState, a: f64) {
    let l0 = model.length();
    for i in 1..=model.n_elements {
        let q = a * (model.node_arc_length[i] / l0).powi(2);
        state.velocity[i] = [0.0, q, 0.4 * q];
    }
    for j in 1..model.n_elements {
        state.omega[j] = [
            0.0,
            0.0,
            2.0 * a * model.element_midpoint_arc_length(j) / (l0 * l0),
        ];
    }
}

/// exp([a]×) by Rodrigues with libm (the identity below |a|² = 1e-20).
pub fn rotation(a: Vec3) -> Mat3 {
    let t2 = a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
    let k = [[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]];
    let (s, c) = if t2 < 1e-20 {
        (1.0, 0.5)
    } else {
        let t = t2.sqrt();
        (t.sin() / t, (1.0 - t.cos()) / t2)
    };
    let mut r = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let k2: f64 = (0..3).map(|m| k[i][m] * k[m][j]).sum();
            r[i][j] = if i == j { 1.0 } else { 0.0 } + s * k[i][j] + c * k2;
        }
    }
    r
}

/// R a.
pub fn rot(r: &Mat3, a: Vec3) -> Vec3 {
    [
        r[0][0] * a[0] + r[0][1] * a[1] + r[0][2] * a[2],
        r[1][0] * a[0] + r[1][1] * a[1] + r[1][2] * a[2],
        r[2][0] * a[0] + r[2][1] * a[1] + r[2][2] * a[2],
    ]
}

/// |a|.
pub fn norm(a: Vec3) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// a − b.
pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Largest |v| over `a` (0 for an empty slice), e.g. the fastest node's speed.
pub fn max_norm(a: &[Vec3]) -> f64 {
    a.iter().map(|v| norm(*v)).fold(0.0, f64::max)
}

/// The entries of a structure-of-arrays field as a vector of 3-vectors.
pub fn vecs(v: &Vec3s) -> Vec<Vec3> {
    v.to_vec(0..v.len())
}

/// A one-rod system store holding `s` (no validation, as the kernels need none).
pub fn system_state(s: &RodState) -> SystemState {
    SystemState {
        time: s.time,
        step: 0,
        origin: 0.0,
        position: Vec3s::from_slice(&s.position),
        velocity: Vec3s::from_slice(&s.velocity),
        director: Mat3s::from_slice(&s.director),
        omega: Vec3s::from_slice(&s.omega),
        work: vec![0.0],
        dissipated: vec![0.0],
        stick: Vec::new(),
    }
}

/// Internal loads of the lone rod state `s` against the given rest strains, by the stepper's
/// kernel (`with_velocity_terms`: the gyroscopic and unsteady-dilatation torques of eq. 4.3).
pub fn internal_loads(
    model: &RodModel,
    s: &RodState,
    rest_sigma: &[Vec3],
    rest_kappa: &[Vec3],
    with_velocity_terms: bool,
    energy_consistent: bool,
) -> InternalLoads {
    let mut out = InternalLoads::for_rod(model.n_elements);
    out.compute_rod(
        model,
        &system_state(s),
        Offsets::ZERO,
        rest_sigma,
        rest_kappa,
        with_velocity_terms,
        energy_consistent,
    );
    out
}
