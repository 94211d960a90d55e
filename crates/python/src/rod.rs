//! `Simulation`: one rod (any geometry and material, or the paper's arm), its loads, obstacles,
//! damping and rest strains, stepped with the GIL released; state read as NumPy copies.

use crate::arrays::{mat3s, read_vec3s, scalars, vec3s};
use crate::{model_error, step_error};
use numpy::{PyArray1, PyArray2, PyArray3, PyReadonlyArray2};
use octoarm_physics as phys;
use octoarm_physics::{Boundary, Damping, Load, Material, Settings, Sphere, StraightRod, Vec3};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::time::Instant;

/// One Cosserat rod with its loads, obstacles, damping and numerical settings (SI units).
/// Domains: nodes (n + 1), elements (n), interior points (n − 1). Array getters return copies.
#[pyclass(module = "octoarm")]
#[derive(Clone)]
pub struct Simulation {
    pub(crate) inner: phys::Simulation,
}

pub(crate) fn boundary_from(s: &str) -> PyResult<Boundary> {
    match s {
        "clamped" => Ok(Boundary::ClampedBase),
        "free" => Ok(Boundary::Free),
        other => Err(PyValueError::new_err(format!(
            "boundary = {other:?} is not allowed; use \"clamped\" or \"free\""
        ))),
    }
}

fn check_count(field: &str, value: i64, min: i64) -> PyResult<usize> {
    if value < min {
        return Err(PyValueError::new_err(format!(
            "{field} = {value} is outside the allowed range [{min}, inf)"
        )));
    }
    Ok(value as usize)
}

impl Simulation {
    pub(crate) fn from_rod(rod: &StraightRod, dt: f64, energy_consistent: bool) -> PyResult<Self> {
        let (model, state) = rod.build().map_err(model_error)?;
        let settings = Settings {
            energy_consistent,
            ..Settings::with_dt(dt)
        };
        let inner = phys::Simulation::new(model, state, settings).map_err(model_error)?;
        Ok(Self { inner })
    }
}

#[pymethods]
impl Simulation {
    /// Build a straight (optionally tapered, optionally pre-curved) rod. Defaults are the paper's
    /// arm: 100 elements, L = 0.2 m, diameter 2 cm → 0.04 cm, ρ = 700 kg/m³, E = 10 kPa,
    /// G = 1 kPa, along +x with d1 = e_y, clamped at the origin, dt = 1e-5 s.
    #[new]
    #[pyo3(signature = (
        n_elements = 100, length = 0.2, base_diameter = 0.02, tip_diameter = 0.0004,
        density = 700.0, youngs_modulus = 1.0e4, shear_modulus = 1.0e3,
        shear_coefficient = Material::DEFAULT_SHEAR_COEFFICIENT,
        base_position = [0.0, 0.0, 0.0], direction = [1.0, 0.0, 0.0], normal = [0.0, 1.0, 0.0],
        rest_curvature = [0.0, 0.0, 0.0], boundary = "clamped", dt = 1.0e-5,
        energy_consistent = false
    ))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        n_elements: i64,
        length: f64,
        base_diameter: f64,
        tip_diameter: f64,
        density: f64,
        youngs_modulus: f64,
        shear_modulus: f64,
        shear_coefficient: f64,
        base_position: Vec3,
        direction: Vec3,
        normal: Vec3,
        rest_curvature: Vec3,
        boundary: &str,
        dt: f64,
        energy_consistent: bool,
    ) -> PyResult<Self> {
        let rod = StraightRod {
            n_elements: check_count("n_elements", n_elements, 2)?,
            length,
            base_diameter,
            tip_diameter,
            material: Material {
                density,
                youngs_modulus,
                shear_modulus,
                shear_coefficient,
            },
            base_position,
            direction,
            normal,
            rest_curvature,
            boundary: boundary_from(boundary)?,
        };
        Self::from_rod(&rod, dt, energy_consistent)
    }

    /// The paper's arm (`StraightRod::paper_arm`) with `n_elements` elements and time step `dt`.
    #[staticmethod]
    #[pyo3(signature = (dt = 1.0e-5, n_elements = 100))]
    fn paper_arm(dt: f64, n_elements: i64) -> PyResult<Self> {
        let rod = StraightRod::paper_arm().with_elements(check_count("n_elements", n_elements, 2)?);
        Self::from_rod(&rod, dt, false)
    }

    /// An independent copy (model, state, loads, counters).
    fn copy(&self) -> Self {
        self.clone()
    }

    /// Advance `n` steps (GIL released), then run the stability guard on the final state.
    /// Raises `InstabilityError` if the guard fires (the state is kept as it was then).
    #[pyo3(signature = (n = 1))]
    fn step(&mut self, py: Python<'_>, n: i64) -> PyResult<()> {
        let n = check_count("n", n, 0)? as u64;
        let sim = &mut self.inner;
        py.detach(|| sim.run(n)).map_err(|e| step_error(py, e))
    }

    /// Add uniform gravity g [m/s²] (lab frame).
    fn add_gravity(&mut self, acceleration: Vec3) -> PyResult<()> {
        self.inner
            .add_load(Load::Gravity { acceleration })
            .map_err(model_error)
    }

    /// Add a point force [N] (lab) on `node` (default: the tip), ramped over `ramp_time` [s].
    #[pyo3(signature = (force, node = None, ramp_time = 0.0))]
    fn add_node_force(&mut self, force: Vec3, node: Option<i64>, ramp_time: f64) -> PyResult<()> {
        let n = self.inner.model.n_elements;
        let node = match node {
            None => n,
            Some(i) if (0..=n as i64).contains(&i) => i as usize,
            Some(i) => {
                return Err(PyValueError::new_err(format!(
                    "node = {i} is outside the allowed range [0, {n}]"
                )))
            }
        };
        self.inner
            .add_load(Load::NodeForce {
                node,
                force,
                ramp_time,
            })
            .map_err(model_error)
    }

    /// Add a distributed force per rest length [N/m] (lab).
    fn add_uniform_force(&mut self, force_per_length: Vec3) -> PyResult<()> {
        self.inner
            .add_load(Load::UniformForce { force_per_length })
            .map_err(model_error)
    }

    /// Add a point couple [N m] (lab) on `element` (default: the last), ramped over `ramp_time`.
    #[pyo3(signature = (couple, element = None, ramp_time = 0.0))]
    fn add_element_couple(
        &mut self,
        couple: Vec3,
        element: Option<i64>,
        ramp_time: f64,
    ) -> PyResult<()> {
        let n = self.inner.model.n_elements;
        let element = match element {
            None => n - 1,
            Some(i) if (0..n as i64).contains(&i) => i as usize,
            Some(i) => {
                return Err(PyValueError::new_err(format!(
                    "element = {i} is outside the allowed range [0, {}]",
                    n - 1
                )))
            }
        };
        self.inner
            .add_load(Load::ElementCouple {
                element,
                couple,
                ramp_time,
            })
            .map_err(model_error)
    }

    /// Add a distributed couple per rest length [N m/m]; `follower=True` makes it material-frame.
    #[pyo3(signature = (couple_per_length, follower = false))]
    fn add_uniform_couple(&mut self, couple_per_length: Vec3, follower: bool) -> PyResult<()> {
        let load = if follower {
            Load::FollowerCouple { couple_per_length }
        } else {
            Load::UniformCouple { couple_per_length }
        };
        self.inner.add_load(load).map_err(model_error)
    }

    /// Remove every external load.
    fn clear_loads(&mut self) {
        self.inner.loads.clear();
    }

    /// Add a rigid sphere obstacle: centre [m] at t = 0, radius [m] > 0, velocity [m/s].
    #[pyo3(signature = (center, radius, velocity = [0.0, 0.0, 0.0]))]
    fn add_obstacle(&mut self, center: Vec3, radius: f64, velocity: Vec3) -> PyResult<()> {
        self.inner
            .add_obstacle(Sphere {
                center,
                radius,
                velocity,
            })
            .map_err(model_error)
    }

    /// Set damping: mass-proportional `rate` ν_d [1/s] and the paper's per-length `gamma`
    /// [kg/(m s)], both ≥ 0.
    #[pyo3(signature = (rate = 0.0, gamma = 0.0))]
    fn set_damping(&mut self, rate: f64, gamma: f64) -> PyResult<()> {
        self.inner
            .set_damping(Damping {
                rate,
                gamma,
                analytical: None,
            })
            .map_err(model_error)
    }

    /// Set the rest strains: σ° (n, 3) per element and κ° [1/m] (n − 1, 3) per interior point,
    /// material frame.
    fn set_rest_strains(
        &mut self,
        sigma: PyReadonlyArray2<'_, f64>,
        kappa: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<()> {
        let n = self.inner.model.n_elements;
        let s = read_vec3s(&sigma, "sigma", n)?;
        let k = read_vec3s(&kappa, "kappa", n - 1)?;
        self.inner
            .model
            .set_rest_strains(&s, &k)
            .map_err(model_error)
    }

    /// Number of elements n.
    #[getter]
    fn n_elements(&self) -> usize {
        self.inner.model.n_elements
    }

    /// Time step [s].
    #[getter]
    fn dt(&self) -> f64 {
        self.inner.settings.dt
    }

    /// Largest stable time step estimate 2/ω_max [s].
    #[getter]
    fn stable_dt(&self) -> f64 {
        self.inner.model.stable_dt()
    }

    /// Simulated time [s].
    #[getter]
    fn time(&self) -> f64 {
        self.inner.state.time
    }

    /// Steps taken.
    #[getter]
    fn steps(&self) -> u64 {
        self.inner.steps()
    }

    /// Node positions [m], (n + 1, 3), lab frame (copy).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        vec3s(py, &self.inner.state.position)
    }

    /// Node velocities [m/s], (n + 1, 3), lab frame (copy).
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        vec3s(py, &self.inner.state.velocity)
    }

    /// Element directors Q, (n, 3, 3); row i is d_(i+1) in lab components (copy).
    #[getter]
    fn directors<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f64>> {
        mat3s(py, &self.inner.state.director)
    }

    /// Element angular velocities ω [rad/s], (n, 3), material frame (copy).
    #[getter]
    fn angular_velocities<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        vec3s(py, &self.inner.state.omega)
    }

    /// Tip (last node) position [m], (3,).
    #[getter]
    fn tip<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        scalars(py, &self.inner.state.tip())
    }

    /// Rest shear/stretch strains σ° (n, 3), material frame (copy).
    #[getter]
    fn rest_sigma<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        vec3s(py, &self.inner.model.rest_sigma)
    }

    /// Rest curvatures κ° [1/m] (n − 1, 3), material frame (copy).
    #[getter]
    fn rest_kappa<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        vec3s(py, &self.inner.model.rest_kappa)
    }

    /// Current strains: (σ (n, 3) dimensionless, κ (n − 1, 3) [1/m]), material frame.
    fn strains<'py>(
        &self,
        py: Python<'py>,
    ) -> (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>) {
        let n = self.inner.model.n_elements;
        let mut sigma = vec![[0.0; 3]; n];
        let mut kappa = vec![[0.0; 3]; n - 1];
        phys::strains(&self.inner.model, &self.inner.state, &mut sigma, &mut kappa);
        (vec3s(py, &sigma), vec3s(py, &kappa))
    }

    /// Energies [J]: translational, rotational, stretch, bend, kinetic, potential, total,
    /// external_work, dissipated.
    fn energies<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let e = self.inner.energies();
        let d = PyDict::new(py);
        d.set_item("translational", e.translational)?;
        d.set_item("rotational", e.rotational)?;
        d.set_item("stretch", e.stretch)?;
        d.set_item("bend", e.bend)?;
        d.set_item("kinetic", e.kinetic())?;
        d.set_item("potential", e.potential())?;
        d.set_item("total", e.total())?;
        d.set_item("external_work", self.inner.external_work())?;
        d.set_item("dissipated", self.inner.dissipated_energy())?;
        Ok(d)
    }

    /// Model constants per domain as a dict of copies: rest_length (n,), radius (n,),
    /// node_mass (n + 1,), shear_stiffness (n, 3), bend_stiffness (n − 1, 3).
    fn model<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let m = &self.inner.model;
        let d = PyDict::new(py);
        d.set_item("rest_length", scalars(py, &m.rest_length))?;
        d.set_item("radius", scalars(py, &m.radius))?;
        d.set_item("node_mass", scalars(py, &m.node_mass))?;
        d.set_item("shear_stiffness", vec3s(py, &m.shear_stiffness))?;
        d.set_item("bend_stiffness", vec3s(py, &m.bend_stiffness))?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        format!(
            "Simulation(n_elements={}, dt={:e}, time={}, steps={})",
            self.inner.model.n_elements,
            self.inner.settings.dt,
            self.inner.state.time,
            self.inner.steps()
        )
    }
}

/// Reference speed of the Rust loop: steps per second of `sim` (copied) advanced `steps` steps in
/// one call, GIL released. Used by the speed benchmark to compare with stepping from Python.
#[pyfunction]
pub fn rust_step_rate(py: Python<'_>, sim: &Simulation, steps: u64) -> PyResult<f64> {
    let mut s = sim.inner.clone();
    let t0 = Instant::now();
    py.detach(|| s.run(steps)).map_err(|e| step_error(py, e))?;
    Ok(steps as f64 / t0.elapsed().as_secs_f64())
}
