//! Energy shaping with muscles (muscles-3d spec §6): hold designed activations a* with COOMM's
//! ramp, a(t) = min(1, t/T_ramp) a*, updated every 2 ms (500 Hz). The activations shape the
//! arm's potential (elastic + fibres' stored energy), whose minimum is the designed equilibrium;
//! with the water's and the body's dissipation the shaped Hamiltonian is a Lyapunov function
//! after the ramp. No state feedback (open loop, as COOMM runs it).

use crate::controller::{ControlError, ControlReport, Controller, Signals};
use octoarm_physics::math::norm;
use octoarm_physics::{Actuation, RodSystem, SystemState, Vec3, N_GROUPS};

/// `MuscleShapingController { design, ramp: 1 s, update_hz: 500 }` of spec §6.2.
#[derive(Debug, Clone)]
pub struct MuscleShapingController {
    rod: usize,
    activations: Vec<f64>,
    ramp: f64,
    period: f64,
    target: Option<Vec3>,
    design_shape: Vec<Vec3>,
    design_tip_error: f64,
    length: f64,
}

impl MuscleShapingController {
    /// Hold `activations` (group-major `[7][n]` of rod `rod`, in [0, 1]) with a linear ramp of
    /// `ramp` seconds (≥ 0), updated every `period` seconds (> 0). `target` is the task's tip
    /// point (for the signals), `design_shape` the design's node positions, `design_tip_error`
    /// its tip error [m], `length` the arm's rest length L0 [m].
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        rod: usize,
        activations: Vec<f64>,
        ramp: f64,
        period: f64,
        target: Option<Vec3>,
        design_shape: Vec<Vec3>,
        design_tip_error: f64,
        length: f64,
    ) -> Result<Self, ControlError> {
        if !(ramp.is_finite() && ramp >= 0.0) {
            return Err(ControlError::OutOfRange {
                field: "ramp",
                value: ramp,
                range: "[0, inf) s",
            });
        }
        if !(period.is_finite() && period > 0.0) {
            return Err(ControlError::OutOfRange {
                field: "period",
                value: period,
                range: "(0, inf) s",
            });
        }
        if let Some(&v) = activations.iter().find(|v| !(0.0..=1.0).contains(*v)) {
            return Err(ControlError::OutOfRange {
                field: "activation",
                value: v,
                range: "[0, 1]",
            });
        }
        Ok(Self {
            rod,
            activations,
            ramp,
            period,
            target,
            design_shape,
            design_tip_error,
            length,
        })
    }

    /// COOMM's schedule: 1 s ramp, 500 Hz.
    pub fn coomm(
        rod: usize,
        activations: Vec<f64>,
        target: Option<Vec3>,
        design_shape: Vec<Vec3>,
        design_tip_error: f64,
        length: f64,
    ) -> Result<Self, ControlError> {
        Self::new(
            rod,
            activations,
            1.0,
            0.002,
            target,
            design_shape,
            design_tip_error,
            length,
        )
    }

    /// Ramp factor at time t.
    pub fn factor(&self, t: f64) -> f64 {
        if self.ramp <= 0.0 {
            1.0
        } else {
            (t / self.ramp).clamp(0.0, 1.0)
        }
    }

    /// The designed activations (group-major `[7][n]`).
    pub fn activations(&self) -> &[f64] {
        &self.activations
    }
}

impl Controller for MuscleShapingController {
    fn period(&self) -> f64 {
        self.period
    }

    fn update(
        &mut self,
        t: f64,
        system: &RodSystem,
        _state: &SystemState,
        actuation: &mut Actuation,
    ) -> Result<(), ControlError> {
        let rod = system.rod(self.rod);
        let n = rod.n_elements();
        let ne = system.n_elements();
        let e0 = rod.offsets().element;
        let k = self.factor(t);
        let act = actuation.activations_mut();
        for g in 0..N_GROUPS {
            for j in 0..n {
                act[g * ne + e0 + j] = k * self.activations[g * n + j];
            }
        }
        Ok(())
    }

    fn signals(&self, t: f64, system: &RodSystem, state: &SystemState) -> Signals {
        let v = system.view(state, self.rod);
        let n = v.n;
        let p: Vec3 = std::array::from_fn(|c| 0.5 * (v.position[c][n - 1] + v.position[c][n]));
        let distance = self
            .target
            .map(|q| norm([p[0] - q[0], p[1] - q[1], p[2] - q[2]]) / self.length)
            .unwrap_or(0.0);
        Signals {
            rod: self.rod,
            // The control is constant after the ramp: one epoch during it, one after.
            design_epoch: u64::from(t >= self.ramp),
            target: self.target,
            design_target: self.target,
            distance,
            shaped: None,
        }
    }

    fn desired_shape(&mut self) -> Option<&[Vec3]> {
        (!self.design_shape.is_empty()).then_some(&self.design_shape[..])
    }

    fn report(&self) -> ControlReport {
        ControlReport {
            design_tip_errors: vec![self.design_tip_error],
            ..ControlReport::default()
        }
    }
}
