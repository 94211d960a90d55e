//! The energy-shaping law (spec §4): the design strains w̄ become the rest strains of a shaped
//! potential, and the control u = 𝓛(x; σ̄, κ̄) − 𝓛(x; σ°, κ°) is what the constant internal
//! stresses δn = S(σ° − σ̄), δτ = B(κ° − κ̄) produce through the rod's geometry at every step
//! (elastic loads are affine in the rest strains). The law writes δn, δτ into the system's
//! `Actuation`; the stepper applies them. Damping is the simulator's damping module (§4.5).
//! Also the shaped Hamiltonian for the Lyapunov test. It does not solve for w̄.

use crate::error::ShapingError;
use crate::strains::StrainField;
use octoarm_physics::{
    energies_with_rest, Actuation, Energies, RodAccess, RodModel, RodSystem, Simulation, StepError,
    Vec3,
};

/// Settings of the law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShapingConfig {
    /// Mass-proportional damping rate ν_d [1/s] that `attach` sets in a `Simulation` (default
    /// 10 s⁻¹). A controller in the run pipeline uses the system's damping as it is.
    pub damping_rate: f64,
}

impl Default for ShapingConfig {
    fn default() -> Self {
        Self { damping_rate: 10.0 }
    }
}

/// Energy-shaping law of one rod of a system: holds the design in force as rest strains and the
/// constant stresses it implies, and writes them into the rod's slice of an `Actuation`.
#[derive(Debug, Clone)]
pub struct EnergyShapingController {
    config: ShapingConfig,
    rod: usize,
    design: StrainField,
    design_sigma: Vec<Vec3>,
    design_kappa: Vec<Vec3>,
    intrinsic_sigma: Vec<Vec3>,
    intrinsic_kappa: Vec<Vec3>,
    delta_stress: Vec<Vec3>,
    delta_couple: Vec<Vec3>,
    voronoi_length: Vec<f64>,
    written: bool,
}

impl EnergyShapingController {
    /// A law for a rod like `model` (its natural rest strains are the intrinsic strains σ°,
    /// κ°) whose design is the intrinsic strains (zero control). It acts on rod 0 of a system;
    /// see `for_rod`.
    pub fn new(model: &RodModel, config: ShapingConfig) -> Result<Self, ShapingError> {
        Self::with_intrinsic(model, &model.rest_sigma, &model.rest_kappa, 0, config)
    }

    /// A law for rod `rod` of `system`, with the rest strains in force there as intrinsic
    /// strains.
    pub fn for_rod(
        system: &RodSystem,
        rod: usize,
        config: ShapingConfig,
    ) -> Result<Self, ShapingError> {
        let (s, k) = system.rest_strains(rod);
        Self::with_intrinsic(&system.rod(rod).model, s, k, rod, config)
    }

    fn with_intrinsic(
        model: &RodModel,
        sigma: &[Vec3],
        kappa: &[Vec3],
        rod: usize,
        config: ShapingConfig,
    ) -> Result<Self, ShapingError> {
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
            rod,
            design: StrainField::from_rest_strains(sigma, kappa),
            design_sigma: sigma.to_vec(),
            design_kappa: kappa.to_vec(),
            intrinsic_sigma: sigma.to_vec(),
            intrinsic_kappa: kappa.to_vec(),
            delta_stress: vec![[0.0; 3]; n],
            delta_couple: vec![[0.0; 3]; n - 1],
            voronoi_length: model.rest_voronoi_length.clone(),
            written: false,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &ShapingConfig {
        &self.config
    }

    /// The rod it acts on.
    pub fn rod(&self) -> usize {
        self.rod
    }

    /// The design in force w̄.
    pub fn design(&self) -> &StrainField {
        &self.design
    }

    /// Design rest strains σ̄ = ν̄ − e3 (per element) and κ̄ (per interior point).
    pub fn design_rest_strains(&self) -> (&[Vec3], &[Vec3]) {
        (&self.design_sigma, &self.design_kappa)
    }

    /// The constant stresses δn = S(σ° − σ̄) per element and δτ = B(κ° − κ̄) per interior point.
    pub fn stresses(&self) -> (&[Vec3], &[Vec3]) {
        (&self.delta_stress, &self.delta_couple)
    }

    /// Put a new design in force (spec §4.7; written into the actuation by the next `actuate`).
    /// Refuses a degenerate design (turning angle ≥ π/2, stretch ≤ 0, non-finite) and keeps the
    /// previous one. The stiffnesses are the rod's own S and B (the design floor belongs to the
    /// solver only).
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
        self.written = false;
        Ok(())
    }

    /// Write δn, δτ into the rod's slices of `actuation`'s internal part.
    pub fn actuate(&mut self, system: &RodSystem, actuation: &mut Actuation) {
        let rod = system.rod(self.rod);
        let act = actuation.internal_mut();
        act.stress[rod.elements()].copy_from_slice(&self.delta_stress);
        act.couple[rod.interior()].copy_from_slice(&self.delta_couple);
        self.written = true;
    }

    /// Configure a `Simulation` for this law: set every rod's mass-proportional damping rate to
    /// ν_d (other damping terms are kept; they only add dissipation) and write the actuation.
    pub fn attach(&mut self, sim: &mut Simulation) -> Result<(), ShapingError> {
        let mut d = sim.damping();
        d.rate = self.config.damping_rate;
        sim.set_damping(d)?;
        self.actuate(&sim.system, &mut sim.actuation);
        Ok(())
    }

    /// Advance a `Simulation` one step under the law (writing the actuation first if the design
    /// changed since it was last written).
    pub fn step(&mut self, sim: &mut Simulation) -> Result<(), StepError> {
        if !self.written {
            self.actuate(&sim.system, &mut sim.actuation);
        }
        sim.step()
    }

    /// Advance `steps` steps under the law.
    pub fn run(&mut self, sim: &mut Simulation, steps: u64) -> Result<(), StepError> {
        for _ in 0..steps {
            self.step(sim)?;
        }
        Ok(())
    }

    /// Shaped Hamiltonian H̄_h (spec §4.6): kinetic energy plus the strain energy measured against
    /// the design rest strains w̄, with the physical stiffnesses [J]. `energy_consistent` selects
    /// the simulator's dilatation-scaled energy.
    pub fn shaped_energies(
        &self,
        model: &RodModel,
        state: &impl RodAccess,
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

    /// H̄_h of the state [J] in the default (not energy-consistent) model. For a simulation with
    /// `energy_consistent = true` use `shaped_energies(model, state, true).total()`: the
    /// Lyapunov function must use the simulation's own energy.
    pub fn shaped_hamiltonian(&self, model: &RodModel, state: &impl RodAccess) -> f64 {
        self.shaped_energies(model, state, false).total()
    }
}
