//! The energy-shaping law (spec §4): the design strains w̄ become the rest strains of a shaped
//! potential, and the control u = 𝓛(x; σ̄, κ̄) − 𝓛(x; σ°, κ°) is added to the rod through the
//! simulator's external-load hook each step; damping is the simulator's mass-proportional damping
//! module (§4.5). Also the shaped Hamiltonian for the Lyapunov test. It does not solve for w̄.

use crate::error::ShapingError;
use crate::strains::StrainField;
use octoarm_physics::math::{cross, mat_t_vec};
use octoarm_physics::{
    energies_with_rest, ElasticLoads, Energies, ExternalLoads, InternalLoads, RodModel, RodState,
    Simulation, StepError, Vec3,
};

/// How the conservative part of the law is evaluated. Both give the same loads to round-off
/// (test `shaping_equivalence`); the default is the fast one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LawEvaluation {
    /// The literal law: two calls of the physics crate's `ElasticLoads` (design and intrinsic
    /// rest strains) and their difference. About one internal-load evaluation more per step than
    /// the affine form; the only correct choice with the energy-consistent correction on.
    TwoLoadEvaluations,
    /// Elastic loads are affine in the rest strains, so the difference is the load routine fed
    /// with the constant stresses n̂ = S(σ° − σ̄), τ̂ = B(κ° − κ̄) (spec §4.2, written out), using
    /// the strains and dilatations the simulator has just computed for the same mid-step state.
    /// No logarithm or square root per step. Falls back to `TwoLoadEvaluations` when the
    /// simulation uses the energy-consistent correction (not affine in the rest strains).
    #[default]
    Affine,
}

/// Settings of the controller.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShapingConfig {
    /// Mass-proportional damping rate ν_d [1/s] configured in the simulator (default 10 s⁻¹).
    pub damping_rate: f64,
    /// Evaluation of the conservative part (default `Affine`).
    pub evaluation: LawEvaluation,
}

impl Default for ShapingConfig {
    fn default() -> Self {
        Self {
            damping_rate: 10.0,
            evaluation: LawEvaluation::Affine,
        }
    }
}

/// Energy-shaping controller of one rod. Holds the design in force as rest strains and the
/// constant stresses it implies; `apply` is the body of the simulator's load hook.
#[derive(Debug, Clone)]
pub struct EnergyShapingController {
    config: ShapingConfig,
    design: StrainField,
    design_sigma: Vec<Vec3>,
    design_kappa: Vec<Vec3>,
    intrinsic_sigma: Vec<Vec3>,
    intrinsic_kappa: Vec<Vec3>,
    delta_stress: Vec<Vec3>,
    delta_couple: Vec<Vec3>,
    loads_design: ElasticLoads,
    loads_rest: ElasticLoads,
    elem_force: Vec<Vec3>,
    pad_couple: Vec<Vec3>,
    pad_coupling: Vec<Vec3>,
    voronoi_length: Vec<f64>,
    energy_consistent: bool,
}

impl EnergyShapingController {
    /// A controller for `model` whose design is the intrinsic strains (zero control).
    pub fn new(model: &RodModel, config: ShapingConfig) -> Result<Self, ShapingError> {
        if !(config.damping_rate.is_finite() && config.damping_rate >= 0.0) {
            return Err(ShapingError::OutOfRange {
                field: "damping_rate",
                value: config.damping_rate,
                range: "[0, inf)",
            });
        }
        let n = model.n_elements;
        Ok(Self {
            config,
            design: StrainField::intrinsic(model),
            design_sigma: model.rest_sigma.clone(),
            design_kappa: model.rest_kappa.clone(),
            intrinsic_sigma: model.rest_sigma.clone(),
            intrinsic_kappa: model.rest_kappa.clone(),
            delta_stress: vec![[0.0; 3]; n],
            delta_couple: vec![[0.0; 3]; n - 1],
            loads_design: ElasticLoads::new(n),
            loads_rest: ElasticLoads::new(n),
            elem_force: vec![[0.0; 3]; n + 1],
            pad_couple: vec![[0.0; 3]; n + 1],
            pad_coupling: vec![[0.0; 3]; n + 1],
            voronoi_length: model.rest_voronoi_length.clone(),
            energy_consistent: false,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &ShapingConfig {
        &self.config
    }

    /// The design in force w̄.
    pub fn design(&self) -> &StrainField {
        &self.design
    }

    /// Design rest strains σ̄ = ν̄ − e3 (per element) and κ̄ (per interior point).
    pub fn design_rest_strains(&self) -> (&[Vec3], &[Vec3]) {
        (&self.design_sigma, &self.design_kappa)
    }

    /// Put a new design in force (applied at once; spec §4.7). Refuses a degenerate design
    /// (turning angle ≥ π/2, stretch ≤ 0, non-finite) and keeps the previous one. The stiffnesses
    /// are the rod's own S and B (the design floor belongs to the solver only).
    pub fn set_design(&mut self, model: &RodModel, w: &StrainField) -> Result<(), ShapingError> {
        if w.n_elements() != model.n_elements {
            return Err(ShapingError::BadLength {
                len: w.n_elements(),
                expected: model.n_elements,
            });
        }
        w.check_admissible(&self.voronoi_length)?;
        self.design.clone_from(w);
        w.write_rest_strains(&mut self.design_sigma, &mut self.design_kappa);
        for j in 0..model.n_elements {
            let s = model.shear_stiffness[j];
            for c in 0..3 {
                self.delta_stress[j][c] =
                    s[c] * (self.intrinsic_sigma[j][c] - self.design_sigma[j][c]);
            }
        }
        for k in 0..model.n_interior() {
            let b = model.bend_stiffness[k];
            for c in 0..3 {
                self.delta_couple[k][c] =
                    b[c] * (self.intrinsic_kappa[k][c] - self.design_kappa[k][c]);
            }
        }
        Ok(())
    }

    /// Configure the simulation for this controller: set the damping module's mass-proportional
    /// rate to ν_d (other damping terms are kept; they only add dissipation) and note whether the
    /// energy-consistent correction is on.
    pub fn attach(&mut self, sim: &mut Simulation) -> Result<(), ShapingError> {
        let mut d = sim.damping;
        d.rate = self.config.damping_rate;
        sim.set_damping(d)?;
        self.energy_consistent = sim.settings.energy_consistent;
        Ok(())
    }

    /// Advance the simulation one step under the law.
    pub fn step(&mut self, sim: &mut Simulation) -> Result<(), StepError> {
        self.energy_consistent = sim.settings.energy_consistent;
        sim.step_with(|m, s, i, e| self.apply(m, s, i, e))
    }

    /// Advance `steps` steps under the law.
    pub fn run(&mut self, sim: &mut Simulation, steps: u64) -> Result<(), StepError> {
        for _ in 0..steps {
            self.step(sim)?;
        }
        Ok(())
    }

    /// The body of the load hook: add u = 𝓛(x; σ̄, κ̄) − 𝓛(x; σ°, κ°) to `out` (forces lab,
    /// couples material). `internal` must be the simulator's evaluation at the same state.
    pub fn apply(
        &mut self,
        model: &RodModel,
        state: &RodState,
        internal: &InternalLoads,
        out: &mut ExternalLoads,
    ) {
        let affine = self.config.evaluation == LawEvaluation::Affine && !self.energy_consistent;
        if affine {
            self.apply_affine(model, state, internal, out);
        } else {
            self.apply_two(model, state, out);
        }
    }

    fn apply_two(&mut self, model: &RodModel, state: &RodState, out: &mut ExternalLoads) {
        let ec = self.energy_consistent;
        self.loads_design
            .compute(model, state, &self.design_sigma, &self.design_kappa, ec);
        self.loads_rest.compute(
            model,
            state,
            &self.intrinsic_sigma,
            &self.intrinsic_kappa,
            ec,
        );
        for (o, (a, b)) in out.force.iter_mut().zip(
            self.loads_design
                .force()
                .iter()
                .zip(self.loads_rest.force()),
        ) {
            for c in 0..3 {
                o[c] += a[c] - b[c];
            }
        }
        for (o, (a, b)) in out.couple.iter_mut().zip(
            self.loads_design
                .couple()
                .iter()
                .zip(self.loads_rest.couple()),
        ) {
            for c in 0..3 {
                o[c] += a[c] - b[c];
            }
        }
    }

    fn apply_affine(
        &mut self,
        model: &RodModel,
        state: &RodState,
        internal: &InternalLoads,
        out: &mut ExternalLoads,
    ) {
        let n = model.n_elements;
        let q = &state.director[..n];
        let dil = &internal.dilatation[..n];
        let sigma = &internal.sigma[..n];
        let lr = &model.rest_length[..n];
        let ns = &self.delta_stress[..n];
        let f = &mut self.elem_force[..n + 1];
        let couple = &mut out.couple[..n];
        // Element forces f_j = Q_jᵀ n̂_j / e_j and the shear–stretch couple (Q_j t_j) × n̂_j ℓ̂_j,
        // with Q_j t_j = (σ_j + e3)/e_j.
        for j in 0..n {
            let inv_e = 1.0 / dil[j];
            let fl = mat_t_vec(&q[j], ns[j]);
            f[j] = [fl[0] * inv_e, fl[1] * inv_e, fl[2] * inv_e];
            let s = lr[j] * inv_e;
            let qt = [sigma[j][0] * s, sigma[j][1] * s, (sigma[j][2] + 1.0) * s];
            let c = cross(qt, ns[j]);
            couple[j] = [
                couple[j][0] + c[0],
                couple[j][1] + c[1],
                couple[j][2] + c[2],
            ];
        }
        f[n] = [0.0; 3];
        // Bend/twist: τ̂/ε³ differences and the averaged ½ D̂ κ × τ̂/ε³ (slot k + 1 = interior k).
        let tb = &mut self.pad_couple[..n + 1];
        let hh = &mut self.pad_coupling[..n + 1];
        let kap = &internal.kappa[..n - 1];
        let eps = &internal.voronoi_dilatation[..n - 1];
        let dr = &model.rest_voronoi_length[..n - 1];
        let tau = &self.delta_couple[..n - 1];
        tb[0] = [0.0; 3];
        hh[0] = [0.0; 3];
        tb[n] = [0.0; 3];
        hh[n] = [0.0; 3];
        for k in 0..n - 1 {
            let inv_e3 = 1.0 / (eps[k] * eps[k] * eps[k]);
            let kt = cross(kap[k], tau[k]);
            let h = 0.5 * dr[k] * inv_e3;
            tb[k + 1] = [tau[k][0] * inv_e3, tau[k][1] * inv_e3, tau[k][2] * inv_e3];
            hh[k + 1] = [kt[0] * h, kt[1] * h, kt[2] * h];
        }
        for j in 0..n {
            for c in 0..3 {
                couple[j][c] += tb[j + 1][c] - tb[j][c] + hh[j + 1][c] + hh[j][c];
            }
        }
        let force = &mut out.force[..n + 1];
        for c in 0..3 {
            force[0][c] += f[0][c];
        }
        for i in 1..=n {
            for c in 0..3 {
                force[i][c] += f[i][c] - f[i - 1][c];
            }
        }
    }

    /// Shaped Hamiltonian H̄_h (spec §4.6): kinetic energy plus the strain energy measured against
    /// the design rest strains w̄, with the physical stiffnesses [J]. `energy_consistent` selects
    /// the simulator's dilatation-scaled energy.
    pub fn shaped_energies(
        &self,
        model: &RodModel,
        state: &RodState,
        energy_consistent: bool,
    ) -> Energies {
        energies_with_rest(
            model,
            state,
            &self.design_sigma,
            &self.design_kappa,
            energy_consistent,
        )
    }

    /// H̄_h of the state [J] (`shaped_energies(..).total()`).
    pub fn shaped_hamiltonian(&self, model: &RodModel, state: &RodState) -> f64 {
        self.shaped_energies(model, state, self.energy_consistent)
            .total()
    }
}
