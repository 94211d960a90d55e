//! `Simulation`: a convenience façade bundling a rod system, its state, its actuation input and
//! its workspace, with one-rod shortcuts (the first rod) for the common case of a single arm.
//! It adds no physics: `step` is `step::step` on its parts, which stay public.

use crate::actuation::Actuation;
use crate::contact::{ContactParams, Sphere};
use crate::damping::Damping;
use crate::ends::EndCondition;
use crate::energy::Energies;
use crate::error::{ModelError, StepError};
use crate::loads::Load;
use crate::math::Vec3;
use crate::model::RodModel;
use crate::schedule::Schedule;
use crate::state::{RodState, RodView, SystemState};
use crate::step::{self, Workspace};
use crate::system::{
    RodSpec, RodSystem, Settings, SystemBuilder, AUTO_DT_FRACTION, AUTO_DT_RECHECK,
};
use std::sync::Arc;

/// A rod system with its state, actuation and workspace, stepped by the one stepper.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Simulation {
    /// Rods, joints, loads, obstacles, rest strains in force and settings.
    pub system: RodSystem,
    /// The evolving state.
    pub state: SystemState,
    /// Actuation input, held over each step (controllers write it between steps).
    pub actuation: Actuation,
    /// Scratch and the loads of the last force evaluation.
    pub workspace: Workspace,
    /// The time step is automatic (`use_auto_dt`): while no step has been taken, every step
    /// re-chooses dt from the system as it is then (obstacles, contact or damping added after
    /// `use_auto_dt` count).
    #[cfg_attr(feature = "serde", serde(default))]
    pub auto_dt: bool,
}

impl Simulation {
    /// One rod clamped at its base, free at its tip (the paper's arm), undamped, no loads.
    /// Errors if the state does not fit the model, holds non-finite values, or settings are bad.
    pub fn new(model: RodModel, state: RodState, settings: Settings) -> Result<Self, ModelError> {
        Self::with_ends(
            model,
            state,
            EndCondition::Clamped,
            EndCondition::Free,
            settings,
        )
    }

    /// One rod with the given end conditions.
    pub fn with_ends(
        model: RodModel,
        state: RodState,
        base: EndCondition,
        tip: EndCondition,
        settings: Settings,
    ) -> Result<Self, ModelError> {
        let mut b = SystemBuilder::new(settings);
        b.rod(RodSpec {
            name: "rod".into(),
            model: Arc::new(model),
            state,
            base,
            tip,
            damping: Damping::default(),
        });
        let (system, state) = b.build()?;
        Ok(Self::from_parts(system, state))
    }

    /// A simulation of a built system at `state`.
    pub fn from_parts(system: RodSystem, state: SystemState) -> Self {
        let actuation = Actuation::for_system(&system);
        let workspace = Workspace::new(&system, &state);
        Self {
            system,
            state,
            actuation,
            workspace,
            auto_dt: false,
        }
    }

    /// Use the automatic time step: dt = `AUTO_DT_FRACTION` (0.2) of the system's stable limit
    /// 2/ω̂_max (rods, joints, contact springs), with the guard's re-check armed
    /// (`Settings::max_dt_fraction = AUTO_DT_RECHECK`: the run stops with the guard's message
    /// if deformation brings dt above 0.5 of the limit of the deformed state). Until the first
    /// step, changes to the system re-choose dt. Returns the dt chosen [s]; an error if the
    /// system has no finite positive stable limit.
    pub fn use_auto_dt(&mut self) -> Result<f64, ModelError> {
        self.auto_dt = true;
        self.choose_auto_dt()
    }

    /// dt = `AUTO_DT_FRACTION` × the stable limit of the system as it is now.
    fn choose_auto_dt(&mut self) -> Result<f64, ModelError> {
        let dt = AUTO_DT_FRACTION * self.system.stable_dt();
        if !(dt.is_finite() && dt > 0.0) {
            return Err(ModelError::OutOfRange {
                field: "dt = \"auto\" (0.2 × stable limit)",
                value: dt,
                range: "(0, inf): the system has no finite stable time step",
            });
        }
        let settings = Settings {
            dt,
            max_dt_fraction: Some(AUTO_DT_RECHECK),
            ..*self.system.settings()
        };
        self.system.set_settings(settings)?;
        Ok(dt)
    }

    /// Re-choose an automatic dt if no step has been taken yet (changes to the system since
    /// `use_auto_dt` count); a no-op otherwise.
    pub fn refresh_auto_dt(&mut self) -> Result<(), ModelError> {
        if self.auto_dt && self.state.step == 0 {
            self.choose_auto_dt()?;
        }
        Ok(())
    }

    /// The first rod's model.
    pub fn model(&self) -> &RodModel {
        &self.system.rod(0).model
    }

    /// Numerical settings.
    pub fn settings(&self) -> &Settings {
        self.system.settings()
    }

    /// The first rod of the state, borrowed.
    pub fn view(&self) -> RodView<'_> {
        self.system.view(&self.state, 0)
    }

    /// Copy of the first rod's state (allocates).
    pub fn rod_state(&self) -> RodState {
        self.system.rod_state(&self.state, 0)
    }

    /// Overwrite the first rod's state (see `RodSystem::set_rod_state`).
    pub fn set_rod_state(&mut self, s: &RodState) -> Result<(), ModelError> {
        self.system.set_rod_state(&mut self.state, 0, s)
    }

    /// Position of the first rod's last node [m].
    pub fn tip(&self) -> Vec3 {
        let r = self.system.rod(0);
        self.state.position.get(r.nodes().end - 1)
    }

    /// Simulated time [s].
    pub fn time(&self) -> f64 {
        self.state.time
    }

    /// Add a constant load on the first rod, after checking it against the model.
    pub fn add_load(&mut self, load: Load) -> Result<(), ModelError> {
        self.system.add_load(0, load, Schedule::Constant)
    }

    /// Add a load on the first rod scaled by a schedule.
    pub fn add_scheduled_load(&mut self, load: Load, schedule: Schedule) -> Result<(), ModelError> {
        self.system.add_load(0, load, schedule)
    }

    /// Add a rigid plane.
    pub fn add_plane(&mut self, plane: crate::contact::Plane) -> Result<(), ModelError> {
        self.system.add_plane(plane)?;
        self.system.fit_stick(&mut self.state);
        self.refresh_auto_dt()
    }

    /// Add a rigid finite cylinder.
    pub fn add_cylinder(&mut self, cylinder: crate::contact::Cylinder) -> Result<(), ModelError> {
        self.system.add_cylinder(cylinder)?;
        self.system.fit_stick(&mut self.state);
        self.refresh_auto_dt()
    }

    /// Add a rigid sphere obstacle.
    pub fn add_obstacle(&mut self, sphere: Sphere) -> Result<(), ModelError> {
        self.system.add_obstacle(sphere)?;
        self.system.fit_stick(&mut self.state);
        self.refresh_auto_dt()
    }

    /// Set the damping of every rod.
    pub fn set_damping(&mut self, damping: Damping) -> Result<(), ModelError> {
        self.system.set_damping_all(damping)?;
        self.refresh_auto_dt()
    }

    /// The first rod's damping.
    pub fn damping(&self) -> Damping {
        self.system.rod(0).damping
    }

    /// Set the contact penalty parameters.
    pub fn set_contact(&mut self, contact: ContactParams) -> Result<(), ModelError> {
        self.system.set_contact(contact)?;
        self.refresh_auto_dt()
    }

    /// Replace the first rod's rest strains in force.
    pub fn set_rest_strains(&mut self, sigma: &[Vec3], kappa: &[Vec3]) -> Result<(), ModelError> {
        self.system.set_rest_strains(0, sigma, kappa)
    }

    /// Steps taken since the time origin.
    pub fn steps(&self) -> u64 {
        self.state.step
    }

    /// Accumulated work of the external loads W [J] on every rod (midpoint velocities, spec
    /// §12).
    pub fn external_work(&self) -> f64 {
        self.state.work.iter().sum()
    }

    /// Accumulated energy removed by damping D [J], every rod.
    pub fn dissipated_energy(&self) -> f64 {
        self.state.dissipated.iter().sum()
    }

    /// Energies of the first rod against the rest strains in force.
    pub fn energies(&self) -> Energies {
        step::rod_energies(&self.system, &self.state, 0)
    }

    /// Base reaction force (lab) of the first rod at the last force evaluation: −F_int of node
    /// 0 [N].
    pub fn base_reaction_force(&self) -> Vec3 {
        let f = self
            .workspace
            .internal
            .force
            .get(self.system.rod(0).offsets().node);
        [-f[0], -f[1], -f[2]]
    }

    /// Give the first rod muscles built from `spec` for its model (or remove them with `None`).
    pub fn set_muscles(
        &mut self,
        spec: Option<crate::muscles::MuscleSpec>,
    ) -> Result<(), ModelError> {
        let m = match spec {
            Some(s) => Some(crate::muscles::MuscleModel::new(
                s,
                &self.system.rods[0].model,
            )?),
            None => None,
        };
        self.system.set_muscles(0, m)
    }

    /// Set the activation of group `g` (0..7) on the first rod's elements (n values in
    /// [0, 1]); switches the muscle activations on. Errors name the entry out of range.
    pub fn set_activation(&mut self, g: usize, values: &[f64]) -> Result<(), ModelError> {
        let rod = &self.system.rods[0];
        let n = rod.n_elements();
        if g >= crate::muscles::N_GROUPS {
            return Err(ModelError::CountOutOfRange {
                field: "activation group",
                value: g,
                range: "[0, 6]",
            });
        }
        if values.len() != n {
            return Err(ModelError::BadLength {
                field: "activation",
                len: values.len(),
                expected: n,
            });
        }
        if let Some(&v) = values.iter().find(|v| !(0.0..=1.0).contains(*v)) {
            return Err(ModelError::OutOfRange {
                field: "activation",
                value: v,
                range: "[0, 1]",
            });
        }
        let ne = self.system.n_elements();
        let e0 = rod.at.element;
        self.actuation.activations_mut()[g * ne + e0..g * ne + e0 + n].copy_from_slice(values);
        Ok(())
    }

    /// Advance one step. With an automatic dt, the first step first re-chooses it
    /// (`refresh_auto_dt`).
    pub fn step(&mut self) -> Result<(), StepError> {
        if self.auto_dt && self.state.step == 0 {
            // The mutators below refresh dt and report a failure; a system changed through its
            // public fields is refreshed here, and should its limit not be finite the dt chosen
            // before stays (the guard then reports any instability).
            let _ = self.refresh_auto_dt();
        }
        step::step(
            &self.system,
            &mut self.state,
            &self.actuation,
            &mut self.workspace,
        )
    }

    /// Advance `n` steps, then run the guard on the final state.
    pub fn run(&mut self, n: u64) -> Result<(), StepError> {
        for _ in 0..n {
            self.step()?;
        }
        self.check()
    }

    /// Run the stability guard on the current state now (spec §11).
    pub fn check(&mut self) -> Result<(), StepError> {
        step::check(&self.system, &self.state, &mut self.workspace)
    }

    /// Largest suggested time step after an instability [s].
    pub fn suggested_dt(&self) -> f64 {
        step::suggested_dt(&self.system)
    }
}
