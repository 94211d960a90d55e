//! The controller from Python: the offline strain-space solver (statics for a reach task with
//! optional obstacles, or a tip force), its design (target strains and shape), and the
//! energy-shaping law that drives one rod of a `Simulation` to that design by writing the
//! simulation's actuation (constant internal stresses δn, δτ) between steps.
//!
//! Threads: like `Simulation`, the solver and the controller are frozen classes holding their
//! state behind a mutex, so sharing them between threads makes callers wait instead of raising
//! "Already borrowed". Lock order: controller, then simulation.

use crate::arrays::{mat3s, read_vec3, vec3s, ArrayPair};
use crate::rod::Simulation;
use crate::{lock, lock_detached, model_error, step_error};
use numpy::{PyArray2, PyArray3};
use octoarm_control as ctl;
use octoarm_control::{ShapingConfig, SolverConfig, StrainField, StrainSpace, Task};
use octoarm_physics::{RodModel, Vec3};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::sync::Mutex;

fn solve_error(e: ctl::SolveError) -> PyErr {
    match e {
        ctl::SolveError::Diverged { .. } => PyRuntimeError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

fn shaping_error(e: ctl::ShapingError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// Rod `r`'s model with the rest strains in force as its natural ones (what the solver designs
/// from, as the law's intrinsic strains are).
fn model_in_force(sim: &octoarm_physics::Simulation, r: usize) -> PyResult<RodModel> {
    let system = &sim.system;
    let mut model = (*system.rod(r).model).clone();
    let (sigma, kappa) = system.rest_strains(r);
    model.set_rest_strains(sigma, kappa).map_err(model_error)?;
    Ok(model)
}

/// A designed strain field w̄ = (ν̄, κ̄), its shape and the solver's report.
#[pyclass(module = "octoarm", frozen)]
pub struct Design {
    strains: StrainField,
    position: Vec<Vec3>,
    director: Vec<octoarm_physics::Mat3>,
    /// "converged" or "not converged".
    #[pyo3(get)]
    outcome: String,
    /// Iterations of the update rule.
    #[pyo3(get)]
    iterations: usize,
    /// Forward–backward sweeps.
    #[pyo3(get)]
    sweeps: usize,
    /// Total cost J [J].
    #[pyo3(get)]
    cost: f64,
    /// Distance of the designed tip to the target [m] (0 without a target).
    #[pyo3(get)]
    tip_error: f64,
    /// Strain residual at the end.
    #[pyo3(get)]
    residual: f64,
    /// Warnings, in words.
    #[pyo3(get)]
    warnings: Vec<String>,
}

#[pymethods]
impl Design {
    /// Full strains ν̄ = σ̄ + e3 per element, (n, 3), material frame.
    #[getter]
    fn nu<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let v: Vec<Vec3> = (0..self.strains.n_elements())
            .map(|j| self.strains.nu(j))
            .collect();
        vec3s(py, &v)
    }

    /// Curvatures κ̄ [1/m] per interior point, (n − 1, 3), material frame.
    #[getter]
    fn kappa<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let v: Vec<Vec3> = (0..self.strains.n_elements() - 1)
            .map(|k| self.strains.kappa(k))
            .collect();
        vec3s(py, &v)
    }

    /// Rest shear/stretch strains σ̄ = ν̄ − e3, (n, 3), ready for `Simulation.set_rest_strains`.
    #[getter]
    fn sigma<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        vec3s(py, &self.strains.to_rest_strains().0)
    }

    /// Designed centreline [m], (n + 1, 3), lab frame.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        vec3s(py, &self.position)
    }

    /// Designed directors, (n, 3, 3), rows d1, d2, d3.
    #[getter]
    fn directors<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f64>> {
        mat3s(py, &self.director)
    }

    fn __repr__(&self) -> String {
        format!(
            "Design(outcome={:?}, sweeps={}, tip_error={:e} m)",
            self.outcome, self.sweeps, self.tip_error
        )
    }
}

/// The offline strain-space solver (forward–backward sweep, L-BFGS by default) for one rod of a
/// `Simulation` (`rod=` its name; default the only rod): its model with the rest strains in force
/// as intrinsic strains, and its base pose as the clamped base. `space` is "planar" (default) or
/// "full".
#[pyclass(module = "octoarm", frozen)]
pub struct OfflineSolver {
    inner: Mutex<ctl::OfflineSolver>,
}

#[pymethods]
impl OfflineSolver {
    #[new]
    #[pyo3(signature = (sim, space = "planar", floor_diameter = 4.0e-3, max_sweeps = 20_000,
        rod = None))]
    fn new(
        py: Python<'_>,
        sim: &Simulation,
        space: &str,
        floor_diameter: f64,
        max_sweeps: usize,
        rod: Option<&str>,
    ) -> PyResult<Self> {
        let r = sim.rod_index(rod)?;
        let space = match space {
            "planar" => StrainSpace::Planar,
            "full" => StrainSpace::Full,
            other => {
                return Err(PyValueError::new_err(format!(
                    "space = {other:?} is not allowed; use \"planar\" or \"full\""
                )))
            }
        };
        let config = SolverConfig {
            space,
            floor_diameter,
            max_sweeps,
            ..SolverConfig::default()
        };
        let (model, state) = {
            let s = sim.lock(py);
            (model_in_force(&s, r)?, s.system.rod_state(&s.state, r))
        };
        let inner = ctl::OfflineSolver::new(&model, &state, config).map_err(solve_error)?;
        Ok(Self {
            inner: Mutex::new(inner),
        })
    }

    /// Solve the statics of a task (GIL released): reach `target` [m] with tip spring `mu_tip`
    /// [N/m] (paper 1e3), or hold a tip `force` [N]; `obstacles` is a list of
    /// (center [m], diameter [m], xi [N/m²]) spheres to avoid. Returns a `Design`.
    #[pyo3(signature = (target = None, mu_tip = 1.0e3, force = None, obstacles = Vec::new()))]
    fn solve(
        &self,
        py: Python<'_>,
        target: Option<&Bound<'_, PyAny>>,
        mu_tip: f64,
        force: Option<&Bound<'_, PyAny>>,
        obstacles: Vec<(Bound<'_, PyAny>, f64, f64)>,
    ) -> PyResult<Design> {
        let target = target.map(|t| read_vec3(t, "target")).transpose()?;
        let force = force.map(|f| read_vec3(f, "force")).transpose()?;
        let obstacles = obstacles
            .iter()
            .enumerate()
            .map(|(k, (c, d, xi))| Ok((read_vec3(c, &format!("obstacles[{k}] center"))?, *d, *xi)))
            .collect::<PyResult<Vec<(Vec3, f64, f64)>>>()?;
        let mut task = match (target, force) {
            (Some(t), None) => Task::reach(t, mu_tip),
            (None, Some(f)) => Task::tip_force(f),
            _ => {
                return Err(PyValueError::new_err(
                    "give exactly one of target (tip target [m]) or force (tip force [N])",
                ))
            }
        };
        for (center, diameter, xi) in obstacles {
            task = task.with_obstacle(center, diameter, xi);
        }
        let (solution, shape) = py
            .detach(|| {
                let mut solver = lock_detached(&self.inner);
                let solution = solver.solve(&task, None)?;
                let shape = solver.statics_mut().state_of(&solution.strains);
                Ok((solution, shape))
            })
            .map_err(solve_error)?;
        let r = &solution.report;
        Ok(Design {
            position: shape.position,
            director: shape.director,
            outcome: match r.outcome {
                ctl::Outcome::Converged => "converged".into(),
                ctl::Outcome::NotConverged => "not converged".into(),
            },
            iterations: r.iterations,
            sweeps: r.sweeps,
            cost: r.cost.total,
            tip_error: r.tip_error,
            residual: r.residual,
            warnings: r.warnings.iter().map(|w| format!("{w:?}")).collect(),
            strains: solution.strains,
        })
    }
}

/// The energy-shaping law on one rod of a `Simulation` (`rod=` its name; default the only rod):
/// makes a design the rod's shaped rest strains, writing the constant stresses δn = S(σ° − σ̄),
/// δτ = B(κ° − κ̄) into the simulation's actuation, which every step then applies. Creating it
/// sets the rod's mass-proportional damping rate to `damping_rate` ν_d [1/s] (default 10) and
/// writes the (zero) control of the intrinsic design.
#[pyclass(module = "octoarm", frozen)]
pub struct EnergyShapingController {
    inner: Mutex<ctl::EnergyShapingController>,
}

/// The model of the controller's rod in `sim`; errors if `sim` has no such rod of the same size
/// (another simulation than the one it was made for).
fn controlled_model<'s>(
    ctrl: &ctl::EnergyShapingController,
    sim: &'s octoarm_physics::Simulation,
) -> PyResult<&'s RodModel> {
    match sim.system.rods().get(ctrl.rod()) {
        Some(rod) if rod.n_elements() == ctrl.design().n_elements() => Ok(&rod.model),
        _ => Err(PyValueError::new_err(
            "sim is not the simulation this controller was made for (it has no rod like the \
             controller's)",
        )),
    }
}

/// Why a controlled step failed: a wrong argument or the stability guard.
enum Failure {
    Input(PyErr),
    Step(octoarm_physics::StepError),
}

impl From<PyErr> for Failure {
    fn from(e: PyErr) -> Self {
        Failure::Input(e)
    }
}

#[pymethods]
impl EnergyShapingController {
    #[new]
    #[pyo3(signature = (sim, damping_rate = 10.0, rod = None))]
    fn new(
        py: Python<'_>,
        sim: &Simulation,
        damping_rate: f64,
        rod: Option<&str>,
    ) -> PyResult<Self> {
        let r = sim.rod_index(rod)?;
        let config = ShapingConfig { damping_rate };
        let mut s = sim.lock(py);
        let mut inner =
            ctl::EnergyShapingController::for_rod(&s.system, r, config).map_err(shaping_error)?;
        let mut d = s.system.rod(r).damping;
        d.rate = damping_rate;
        s.system.set_damping(r, d).map_err(model_error)?;
        let s = &mut *s;
        inner.actuate(&s.system, &mut s.actuation);
        Ok(Self {
            inner: Mutex::new(inner),
        })
    }

    /// Put `design` in force (refuses degenerate designs with `ValueError`); the simulation's
    /// actuation is rewritten at the next `step`.
    fn set_design(&self, py: Python<'_>, sim: &Simulation, design: &Design) -> PyResult<()> {
        let mut ctrl = lock(py, &self.inner);
        let s = sim.lock(py);
        let model = controlled_model(&ctrl, &s)?;
        ctrl.set_design(model, &design.strains)
            .map_err(shaping_error)
    }

    /// Advance `sim` by `n` steps under the law (GIL released), then run the stability guard.
    #[pyo3(signature = (sim, n = 1))]
    fn step(&self, py: Python<'_>, sim: &Simulation, n: u64) -> PyResult<()> {
        py.detach(|| {
            let mut ctrl = lock_detached(&self.inner);
            let mut s = sim.lock_detached();
            controlled_model(&ctrl, &s)?;
            ctrl.run(&mut s, n).map_err(Failure::Step)?;
            s.check().map_err(Failure::Step)
        })
        .map_err(|e| match e {
            Failure::Input(e) => e,
            Failure::Step(e) => step_error(py, e),
        })
    }

    /// Shaped Hamiltonian [J] of the rod: kinetic energy + strain energy measured from the
    /// design.
    fn shaped_hamiltonian(&self, py: Python<'_>, sim: &Simulation) -> PyResult<f64> {
        let ctrl = lock(py, &self.inner);
        let s = sim.lock(py);
        let model = controlled_model(&ctrl, &s)?;
        let view = s.system.view(&s.state, ctrl.rod());
        Ok(ctrl.shaped_hamiltonian(model, &view))
    }

    /// The constant stresses of the design in force: (δn [N] per element (n, 3), δτ [N m] per
    /// interior point (n − 1, 3)), material frame.
    fn stresses<'py>(&self, py: Python<'py>) -> ArrayPair<'py> {
        let (n, t) = {
            let ctrl = lock(py, &self.inner);
            let (n, t) = ctrl.stresses();
            (n.to_vec(), t.to_vec())
        };
        (vec3s(py, &n), vec3s(py, &t))
    }
}
