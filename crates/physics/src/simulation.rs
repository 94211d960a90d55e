//! Time stepping of one rod (spec §6): position Verlet with the clamped base (§7), the
//! exponential damping kick (§8), external loads and contact (§9–§10), a caller-supplied load
//! hook for controllers, periodic re-orthonormalisation (§5) and the stability guard (§11).
//! The stage order lives once, in `Simulation::step_with`.

use crate::contact::{add_contact_forces, ContactParams, Sphere};
use crate::damping::{AnalyticalDamper, Damping, KickFactors};
use crate::energy::{energies, Energies};
use crate::error::{positive, ModelError, StepError};
use crate::internal::{turning_angle, InternalLoads};
use crate::loads::{ExternalLoads, Load};
use crate::math::{
    bjorck, dot, exp_neg_skew, exp_neg_skew_series, mat_mul, mat_vec, orthonormality_defect, Mat3,
    Vec3, EXP_SERIES_MAX_SQ,
};
use crate::model::{Boundary, RodModel};
use crate::state::RodState;

/// Numerical settings of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Time step Δt [s], > 0. The paper uses 1e-5 s.
    pub dt: f64,
    /// Add the energy-consistent tension corrections of eq. 4.5 (default off).
    pub energy_consistent: bool,
    /// Steps between stability-guard checks (default 100).
    pub guard_interval: u64,
    /// Steps between orthonormality checks of the frames (default 1000).
    pub orthonormality_interval: u64,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            dt: 1.0e-5,
            energy_consistent: false,
            guard_interval: 100,
            orthonormality_interval: 1000,
        }
    }
}

impl Settings {
    /// Settings with time step `dt` and defaults otherwise.
    pub fn with_dt(dt: f64) -> Self {
        Self {
            dt,
            ..Self::default()
        }
    }

    /// Check dt > 0 and intervals ≥ 1.
    pub fn validate(&self) -> Result<(), ModelError> {
        positive("dt", self.dt)?;
        if self.guard_interval == 0 {
            return Err(ModelError::CountOutOfRange {
                field: "guard_interval",
                value: 0,
                range: "[1, inf)",
            });
        }
        if self.orthonormality_interval == 0 {
            return Err(ModelError::CountOutOfRange {
                field: "orthonormality_interval",
                value: 0,
                range: "[1, inf)",
            });
        }
        Ok(())
    }
}

/// Length of the guard's energy window in checks (spec §11: the last 1e4 steps).
const ENERGY_WINDOW: usize = 128;

#[derive(Debug, Clone)]
struct Guard {
    reference_energy: f64,
    window: Vec<f64>,
    window_pos: usize,
    rest_checksum: f64,
    floor: f64,
}

/// One rod with its loads, obstacles, damping and settings, advanced by position Verlet.
/// All parts are public for reading; change loads, damping and obstacles through the `add_*` /
/// `set_*` methods, which validate.
#[derive(Debug, Clone)]
pub struct Simulation {
    /// The rod model (rest strains may be changed between steps).
    pub model: RodModel,
    /// The rod state.
    pub state: RodState,
    /// External loads applied at every force evaluation.
    pub loads: Vec<Load>,
    /// Rigid spheres in contact with the rod.
    pub obstacles: Vec<Sphere>,
    /// Contact penalty parameters.
    pub contact: ContactParams,
    /// Damping.
    pub damping: Damping,
    /// Numerical settings.
    pub settings: Settings,
    /// External loads of the last force evaluation (nodes lab, elements material).
    pub external: ExternalLoads,
    /// Internal loads and strains of the last force evaluation (at the mid-step state).
    pub internal: InternalLoads,
    steps: u64,
    clamp: (Vec3, Mat3),
    work: f64,
    dissipated: f64,
    kick: KickFactors,
    // J_j / e_j per element: the divisions of the dissipation sum, in their own vectorised loop.
    inertia_over_e: Vec<Vec3>,
    guard: Guard,
}

impl Simulation {
    /// A simulation of `state` under `model` with no loads, no damping and no obstacles.
    /// Errors if the state does not fit the model, holds non-finite values, or settings are bad.
    pub fn new(model: RodModel, state: RodState, settings: Settings) -> Result<Self, ModelError> {
        settings.validate()?;
        let n = model.n_elements;
        let checks = [
            ("position", state.position.len(), n + 1),
            ("velocity", state.velocity.len(), n + 1),
            ("director", state.director.len(), n),
            ("omega", state.omega.len(), n),
        ];
        for (field, len, expected) in checks {
            if len != expected {
                return Err(ModelError::BadLength {
                    field,
                    len,
                    expected,
                });
            }
        }
        for (field, arr) in [
            ("position", &state.position),
            ("velocity", &state.velocity),
            ("omega", &state.omega),
        ] {
            for v in arr.iter() {
                crate::error::finite_vec(field, *v)?;
            }
        }
        for q in &state.director {
            if q.iter().flatten().any(|v| !v.is_finite()) || orthonormality_defect(q) > 1e-9 {
                return Err(ModelError::BadVector {
                    field: "director",
                    value: q[0],
                    reason: "every director matrix must be finite and orthonormal to 1e-9",
                });
            }
        }
        let clamp = (state.position[0], state.director[0]);
        // Energy floor for the blow-up test: the strain energy of a 0.1 % uniform stretch.
        let floor: f64 = (0..n)
            .map(|j| 0.5 * model.rest_length[j] * model.shear_stiffness[j][2] * 1e-6)
            .sum();
        let mut sim = Self {
            external: ExternalLoads::zeros(n),
            internal: InternalLoads::new(n),
            model,
            state,
            loads: Vec::new(),
            obstacles: Vec::new(),
            contact: ContactParams::default(),
            damping: Damping::default(),
            settings,
            steps: 0,
            clamp,
            work: 0.0,
            dissipated: 0.0,
            kick: KickFactors::default(),
            inertia_over_e: vec![[0.0; 3]; n],
            guard: Guard {
                reference_energy: 0.0,
                window: vec![0.0; ENERGY_WINDOW],
                window_pos: 0,
                rest_checksum: 0.0,
                floor,
            },
        };
        sim.reset_energy_reference();
        // Size the kick-factor buffers now so that no step allocates.
        sim.kick.refresh(&sim.model, &sim.damping, sim.settings.dt);
        Ok(sim)
    }

    /// Add an external load after checking it against the model.
    pub fn add_load(&mut self, load: Load) -> Result<(), ModelError> {
        load.validate(&self.model)?;
        self.loads.push(load);
        Ok(())
    }

    /// Add a rigid sphere obstacle.
    pub fn add_obstacle(&mut self, sphere: Sphere) -> Result<(), ModelError> {
        sphere.validate()?;
        self.obstacles.push(sphere);
        Ok(())
    }

    /// Set the damping.
    pub fn set_damping(&mut self, damping: Damping) -> Result<(), ModelError> {
        damping.validate()?;
        self.damping = damping;
        Ok(())
    }

    /// Set the contact penalty parameters.
    pub fn set_contact(&mut self, contact: ContactParams) -> Result<(), ModelError> {
        contact.validate()?;
        self.contact = contact;
        Ok(())
    }

    /// Number of steps taken.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Accumulated work of the external loads W [J] (midpoint velocities, spec §12).
    pub fn external_work(&self) -> f64 {
        self.work
    }

    /// Accumulated energy removed by damping D [J].
    pub fn dissipated_energy(&self) -> f64 {
        self.dissipated
    }

    /// Energies of the current state against the model's rest strains.
    pub fn energies(&self) -> Energies {
        energies(&self.model, &self.state, self.settings.energy_consistent)
    }

    /// Base reaction force (lab) of the last force evaluation: −F_int of node 0 [N].
    pub fn base_reaction_force(&self) -> Vec3 {
        let f = self.internal.force[0];
        [-f[0], -f[1], -f[2]]
    }

    /// Advance one step with no extra loads.
    pub fn step(&mut self) -> Result<(), StepError> {
        self.step_with(|_, _, _, _| {})
    }

    /// Advance `n` steps, then run the guard on the final state.
    pub fn run(&mut self, n: u64) -> Result<(), StepError> {
        for _ in 0..n {
            self.step()?;
        }
        self.check()
    }

    /// Advance one step. `extra` is called at the force evaluation (spec §6 step 4) with the
    /// mid-step state and its internal loads, after the built-in loads and contact have been
    /// added, and may add its own forces (lab) and couples (material) — the controller hook.
    pub fn step_with<F>(&mut self, mut extra: F) -> Result<(), StepError>
    where
        F: FnMut(&RodModel, &RodState, &InternalLoads, &mut ExternalLoads),
    {
        let dt = self.settings.dt;
        let h = 0.5 * dt;
        self.kick.refresh(&self.model, &self.damping, dt);
        let t_start = self.state.time;

        // 1–2. Kinematic half-step and value constraints.
        self.drift(h);
        self.state.time = t_start + h;

        // 3. Internal loads at x(t+h), Q(t+h) with v(t), ω(t).
        self.internal.compute(
            &self.model,
            &self.state,
            &self.model.rest_sigma,
            &self.model.rest_kappa,
            true,
            self.settings.energy_consistent,
        );

        // 4. External loads, contact, then the caller's loads.
        self.external.clear();
        for load in &self.loads {
            load.apply(
                &self.model,
                &self.state,
                self.state.time,
                &mut self.external,
            );
        }
        if !self.obstacles.is_empty() {
            add_contact_forces(
                &self.model,
                &self.state,
                &self.obstacles,
                &self.contact,
                self.state.time,
                &mut self.external,
            );
        }
        extra(&self.model, &self.state, &self.internal, &mut self.external);

        // 5–6. Kick with exact damping, then rate constraints and the multiplicative damper.
        self.kick_velocities(dt);
        if let Some(damper) = self.damping.analytical {
            self.apply_analytical_damper(damper, dt);
        }

        // 7. Second kinematic half-step.
        self.drift(h);
        self.state.time = t_start + dt;
        self.steps += 1;

        // 8. Orthonormality and guard.
        if self.steps % self.settings.orthonormality_interval == 0 {
            self.reorthonormalise();
        }
        if self.steps % self.settings.guard_interval == 0 {
            self.check()?;
        }
        Ok(())
    }

    fn drift(&mut self, h: f64) {
        let n = self.model.n_elements;
        let x = &mut self.state.position[..n + 1];
        let v = &self.state.velocity[..n + 1];
        for i in 0..=n {
            x[i] = [
                x[i][0] + h * v[i][0],
                x[i][1] + h * v[i][1],
                x[i][2] + h * v[i][2],
            ];
        }
        let q = &mut self.state.director[..n];
        let w = &self.state.omega[..n];
        // |h ω| < 0.1 everywhere (the guard enforces |ω| dt ≤ 0.2) lets every frame take the
        // series form with no per-frame branch or libm call; it is bit-identical to
        // `exp_neg_skew` there.
        let series_ok = w.iter().fold(true, |ok, wj| {
            let a = [h * wj[0], h * wj[1], h * wj[2]];
            ok & (dot(a, a) < EXP_SERIES_MAX_SQ)
        });
        if series_ok {
            for (qj, wj) in q.iter_mut().zip(w) {
                let r = exp_neg_skew_series([h * wj[0], h * wj[1], h * wj[2]]);
                *qj = mat_mul(&r, qj);
            }
        } else {
            for (qj, wj) in q.iter_mut().zip(w) {
                let r = exp_neg_skew([h * wj[0], h * wj[1], h * wj[2]]);
                *qj = mat_mul(&r, qj);
            }
        }
        if self.model.boundary == Boundary::ClampedBase {
            self.state.position[0] = self.clamp.0;
            self.state.director[0] = self.clamp.1;
        }
    }

    fn kick_velocities(&mut self, dt: f64) {
        let n = self.model.n_elements;
        let first = usize::from(self.model.boundary == Boundary::ClampedBase);
        let m = &self.model;
        let k = &self.kick;
        let fi = &self.internal.force[..n + 1];
        let fe = &self.external.force[..n + 1];
        let v = &mut self.state.velocity[..n + 1];
        let mut work = 0.0;
        let mut diss = 0.0;
        for i in first..=n {
            let a = [
                (fi[i][0] + fe[i][0]) * m.inv_node_mass[i],
                (fi[i][1] + fe[i][1]) * m.inv_node_mass[i],
                (fi[i][2] + fe[i][2]) * m.inv_node_mass[i],
            ];
            let old = v[i];
            let new = [
                k.node_decay[i] * old[0] + k.node_kick[i] * a[0],
                k.node_decay[i] * old[1] + k.node_kick[i] * a[1],
                k.node_decay[i] * old[2] + k.node_kick[i] * a[2],
            ];
            let mid = [
                0.5 * (old[0] + new[0]),
                0.5 * (old[1] + new[1]),
                0.5 * (old[2] + new[2]),
            ];
            work += dot(fe[i], mid);
            diss += m.node_mass[i] * k.node_rate[i] * dot(mid, mid);
            v[i] = new;
        }
        let gamma_active = self.damping.gamma > 0.0;
        let ti = &self.internal.torque[..n];
        let ce = &self.external.couple[..n];
        let dil = &self.internal.dilatation[..n];
        let w = &mut self.state.omega[..n];
        let j_over_e = &mut self.inertia_over_e[..n];
        for ((je, jj), e) in j_over_e.iter_mut().zip(&m.inertia[..n]).zip(dil) {
            *je = [jj[0] / e, jj[1] / e, jj[2] / e];
        }
        for j in first..n {
            let e = dil[j];
            let (decay, kick, rate) = k.element(j, e, dt, gamma_active);
            let inv_j = m.inv_inertia[j];
            let old = w[j];
            let mut new = [0.0; 3];
            for c in 0..3 {
                let alpha = e * (ti[j][c] + ce[j][c]) * inv_j[c];
                new[c] = decay * old[c] + kick * alpha;
                let mid = 0.5 * (old[c] + new[c]);
                work += ce[j][c] * mid;
                diss += j_over_e[j][c] * rate * mid * mid;
            }
            w[j] = new;
        }
        if first == 1 {
            v[0] = [0.0; 3];
            w[0] = [0.0; 3];
        }
        self.work += dt * work;
        self.dissipated += dt * diss;
    }

    fn apply_analytical_damper(&mut self, damper: AnalyticalDamper, dt: f64) {
        let n = self.model.n_elements;
        let m = &self.model;
        let dil = &self.internal.dilatation;
        let mut removed = 0.0;
        for i in 0..=n {
            let f = match damper {
                AnalyticalDamper::Uniform { nu } | AnalyticalDamper::Legacy { nu } => {
                    (-nu * dt).exp()
                }
                AnalyticalDamper::Physical { translational, .. } => {
                    (-translational * dt * m.inv_node_mass[i]).exp()
                }
            };
            let v = &mut self.state.velocity[i];
            removed += 0.5 * m.node_mass[i] * (1.0 - f * f) * dot(*v, *v);
            *v = [f * v[0], f * v[1], f * v[2]];
        }
        for j in 0..n {
            let e = dil[j];
            for c in 0..3 {
                let f = match damper {
                    AnalyticalDamper::Uniform { nu } => (-nu * dt).exp(),
                    AnalyticalDamper::Physical { rotational, .. } => {
                        (-rotational * dt * m.inv_inertia[j][c]).exp().powf(e)
                    }
                    AnalyticalDamper::Legacy { nu } => {
                        let mut mass = 0.5 * (m.node_mass[j] + m.node_mass[j + 1]);
                        if j == 0 {
                            mass += 0.5 * m.node_mass[0];
                        }
                        if j == n - 1 {
                            mass += 0.5 * m.node_mass[n];
                        }
                        (-nu * dt * mass * m.inv_inertia[j][c]).exp().powf(e)
                    }
                };
                let w = &mut self.state.omega[j][c];
                removed += 0.5 * m.inertia[j][c] / e * (1.0 - f * f) * *w * *w;
                *w *= f;
            }
        }
        self.dissipated += removed;
    }

    fn reorthonormalise(&mut self) {
        let worst = self
            .state
            .director
            .iter()
            .map(orthonormality_defect)
            .fold(0.0, f64::max);
        // Trigger at half the 1e-12 bound that frames must keep (spec §5): under steady bending
        // the defect grows by up to ~5e-14 per 1000-step interval, so triggering at the bound
        // itself let it exceed 1e-12 between checks (1.09e-12 measured, tests/orthonormality.rs).
        if worst > 0.5e-12 {
            for q in self.state.director.iter_mut() {
                *q = bjorck(q);
            }
        }
    }

    fn rest_checksum(&self) -> f64 {
        let mut sum = 0.0;
        for (i, v) in self
            .model
            .rest_sigma
            .iter()
            .chain(self.model.rest_kappa.iter())
            .enumerate()
        {
            sum += (i as f64 + 1.0) * (v[0] + 2.0 * v[1] + 3.0 * v[2]);
        }
        sum
    }

    fn reset_energy_reference(&mut self) {
        let h = self.energies().total();
        self.guard.reference_energy = h;
        self.guard.window.fill(h);
        self.guard.rest_checksum = self.rest_checksum();
    }

    /// Largest suggested time step after an instability: min(dt/2, 0.2 · stable dt) [s].
    pub fn suggested_dt(&self) -> f64 {
        (0.5 * self.settings.dt).min(0.2 * self.model.stable_dt())
    }

    fn unstable(
        &self,
        what: &'static str,
        value: f64,
        domain: &'static str,
        index: usize,
        zigzag: bool,
    ) -> StepError {
        let dt = self.settings.dt;
        let suggested_dt = self.suggested_dt();
        let limit = self.model.stable_dt();
        let advice = if dt > 0.2 * limit {
            format!(
                "dt = {dt:e} s is above the recommended 0.2 × stable limit ({limit:.3e} s): reduce dt to {suggested_dt:e} s"
            )
        } else if zigzag {
            format!(
                "neighbouring elements alternate in sign (zig-zag growth of the non-variational model): \
                 set energy_consistent = true, or reduce dt from {dt:e} s to {suggested_dt:e} s"
            )
        } else {
            format!(
                "the rod may have no equilibrium under its loads (reduce the loads or add damping), \
                 or reduce dt from {dt:e} s to {suggested_dt:e} s"
            )
        };
        StepError::Unstable {
            what,
            value,
            domain,
            index,
            time: self.state.time,
            step: self.steps,
            dt,
            suggested_dt,
            advice,
        }
    }

    /// Run the stability guard on the current state now (spec §11). The stepper calls it every
    /// `guard_interval` steps; call it before recording a frame so that no non-finite data is
    /// ever written.
    pub fn check(&mut self) -> Result<(), StepError> {
        let n = self.model.n_elements;
        let s = &self.state;
        // Non-finite values first: nothing else is meaningful after them.
        for i in 0..=n {
            if s.position[i].iter().any(|v| !v.is_finite()) {
                return Err(self.unstable("position", f64::NAN, "node", i, false));
            }
            if s.velocity[i].iter().any(|v| !v.is_finite()) {
                return Err(self.unstable("velocity", f64::NAN, "node", i, false));
            }
        }
        for j in 0..n {
            if s.director[j].iter().flatten().any(|v| !v.is_finite()) {
                return Err(self.unstable("director", f64::NAN, "element", j, false));
            }
            if s.omega[j].iter().any(|v| !v.is_finite()) {
                return Err(self.unstable("angular velocity", f64::NAN, "element", j, false));
            }
        }
        // Strains.
        let m = &self.model;
        let strain_dev = |j: usize| -> Vec3 {
            let dx = [
                s.position[j + 1][0] - s.position[j][0],
                s.position[j + 1][1] - s.position[j][1],
                s.position[j + 1][2] - s.position[j][2],
            ];
            let q = mat_vec(&s.director[j], dx);
            [
                q[0] * m.inv_rest_length[j] - m.rest_sigma[j][0],
                q[1] * m.inv_rest_length[j] - m.rest_sigma[j][1],
                q[2] * m.inv_rest_length[j] - 1.0 - m.rest_sigma[j][2],
            ]
        };
        let zigzag = |j: usize, c: usize| -> bool {
            if j == 0 || j + 1 >= n {
                return false;
            }
            let (a, b, d) = (strain_dev(j - 1)[c], strain_dev(j)[c], strain_dev(j + 1)[c]);
            a * b < 0.0 && b * d < 0.0
        };
        for j in 0..n {
            let dx = [
                s.position[j + 1][0] - s.position[j][0],
                s.position[j + 1][1] - s.position[j][1],
                s.position[j + 1][2] - s.position[j][2],
            ];
            let e = dot(dx, dx).sqrt() * m.inv_rest_length[j];
            if !(0.5..=2.0).contains(&e) {
                return Err(self.unstable(
                    "dilatation e (allowed [0.5, 2])",
                    e,
                    "element",
                    j,
                    zigzag(j, 2),
                ));
            }
            let d = strain_dev(j);
            for c in 0..3 {
                if d[c].abs() > 0.5 {
                    return Err(self.unstable(
                        "strain |σ − σ°| (allowed ≤ 0.5)",
                        d[c],
                        "element",
                        j,
                        zigzag(j, c),
                    ));
                }
            }
        }
        for k in 0..n - 1 {
            let angle = turning_angle(&s.director[k + 1], &s.director[k]);
            if angle > 0.9 * std::f64::consts::PI {
                return Err(self.unstable(
                    "turning angle |κ|D̂ (allowed ≤ 0.9π)",
                    angle,
                    "voronoi point",
                    k,
                    false,
                ));
            }
        }
        // Rates.
        let dt = self.settings.dt;
        for j in 0..n {
            let w = dot(s.omega[j], s.omega[j]).sqrt();
            if w * dt > 0.2 {
                return Err(self.unstable(
                    "angular speed |ω| dt (allowed ≤ 0.2)",
                    w * dt,
                    "element",
                    j,
                    false,
                ));
            }
        }
        for i in 0..=n {
            let l = if i == 0 {
                m.rest_length[0]
            } else if i == n {
                m.rest_length[n - 1]
            } else {
                m.rest_length[i - 1].min(m.rest_length[i])
            };
            let v = dot(s.velocity[i], s.velocity[i]).sqrt();
            if v * dt > 0.1 * l {
                return Err(self.unstable(
                    "speed |v| dt / l̂ (allowed ≤ 0.1)",
                    v * dt / l,
                    "node",
                    i,
                    false,
                ));
            }
        }
        // Energy blow-up, with the reference reset whenever the rest strains were changed.
        if self.rest_checksum() != self.guard.rest_checksum {
            self.reset_energy_reference();
        }
        let h = self.energies().total();
        let window_max = self.guard.window.iter().copied().fold(0.0, f64::max);
        let bound = 100.0
            * self
                .guard
                .reference_energy
                .max(window_max)
                .max(self.guard.floor)
            + self.work.abs();
        if h > bound {
            return Err(self.unstable("total energy H [J]", h, "element", 0, false));
        }
        let window_len =
            ((10_000 / self.settings.guard_interval.max(1)) as usize).clamp(1, ENERGY_WINDOW);
        self.guard.window_pos = (self.guard.window_pos + 1) % window_len;
        self.guard.window[self.guard.window_pos] = h;
        Ok(())
    }
}
