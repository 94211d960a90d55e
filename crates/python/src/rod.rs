//! `Simulation`: one rod (any geometry and material, or the paper's arm) or a system of named
//! rods with joints, their loads, obstacles, damping and rest strains, stepped with the GIL
//! released; state read as NumPy copies and written with shape checks, per rod; exact pickling
//! and deep copies (the physics state serialised with postcard). The one-rod shortcuts
//! (`positions`, `tip`, …) refuse a system of several rods and point to `rod_state(name)`.
//!
//! Threads: the physics simulation sits behind a mutex (the class is frozen), so a
//! `Simulation` can be shared between Python threads: a reader (say `positions`) waits while
//! another thread steps it, with the GIL released while waiting, instead of raising
//! "Already borrowed". The lock is never held while Python code runs (arrays are read before
//! it is taken and NumPy copies made after it is released), so it cannot deadlock with the GIL.

use crate::arrays::{
    mat3s, read_mat3s, read_vec3, read_vec3_or, read_vec3s, scalars, vec3s, ArrayPair,
};
use crate::system::{
    build_system, check_count, end_condition, quoted, single_rod, Joint, Rod, TimeStep,
};
use crate::{lock, lock_detached, model_error, step_error};
use numpy::{PyArray1, PyArray2, PyArray3};
use octoarm_physics as phys;
use octoarm_physics::math::orthonormality_defect;
use octoarm_physics::{
    Damping, EndCondition, Load, Material, RodState, Schedule, Settings, Sphere, StraightRod,
    SystemState, Vec3, Workspace,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;

/// Start of a pickled simulation: a tag, then the format version.
const PICKLE_TAG: &[u8] = b"octoarm.Simulation";
/// Version of the pickle layout (bump when the serialised physics types change).
const PICKLE_FORMAT: u8 = 2;

/// One Cosserat rod, or a system of named rods joined by joints, with loads, obstacles, damping
/// and numerical settings (SI units). Domains per rod: nodes (n + 1), elements (n), interior
/// points (n − 1). Array getters return copies. Methods that concern one rod take `rod=` (a
/// rod's name; default: the only rod, an error naming the rods when there are several).
/// `pickle` and `copy.deepcopy` are exact: a restored copy steps to the same bits. Thread-safe:
/// calls from several threads are serialised (a reader waits for a running `step`).
#[pyclass(module = "octoarm", frozen)]
pub struct Simulation {
    /// The physics simulation; lock it with `lock` (GIL attached) or `lock_detached`.
    inner: Mutex<phys::Simulation>,
    /// Names and element counts of the rods, in system order (fixed at construction).
    rods: Vec<(String, usize)>,
}

fn boundary_from(s: &str) -> PyResult<(EndCondition, EndCondition)> {
    match s {
        "clamped" => Ok((EndCondition::Clamped, EndCondition::Free)),
        "free" => Ok((EndCondition::Free, EndCondition::Free)),
        other => Err(PyValueError::new_err(format!(
            "boundary = {other:?} is not allowed; use \"clamped\" or \"free\" (or base= / tip= \
             for \"pinned\", \"clamped\", \"free\" or a Motion at each end)"
        ))),
    }
}

/// The schedule of a load ramped over `ramp_time` [s] (0: constant).
fn ramp(ramp_time: f64) -> PyResult<Schedule> {
    if ramp_time == 0.0 {
        Ok(Schedule::Constant)
    } else if ramp_time.is_finite() && ramp_time > 0.0 {
        Ok(Schedule::Ramp {
            duration: ramp_time,
        })
    } else {
        Err(PyValueError::new_err(format!(
            "ramp_time = {ramp_time} is outside the allowed range [0, inf)"
        )))
    }
}

/// The arrays of one rod's state given from Python, read and checked (shapes, finite entries,
/// orthonormal directors) before the simulation is locked.
#[derive(Default)]
struct RodArrays {
    position: Option<Vec<Vec3>>,
    velocity: Option<Vec<Vec3>>,
    director: Option<Vec<phys::Mat3>>,
    omega: Option<Vec<Vec3>>,
}

impl RodArrays {
    /// Read the given arrays of a rod of `n` elements.
    fn read(
        n: usize,
        positions: Option<&Bound<'_, PyAny>>,
        velocities: Option<&Bound<'_, PyAny>>,
        directors: Option<&Bound<'_, PyAny>>,
        angular_velocities: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let director = directors
            .map(|a| read_mat3s(a, "directors", n))
            .transpose()?;
        for (j, q) in director.iter().flatten().enumerate() {
            let defect = orthonormality_defect(q);
            if defect > 1e-9 {
                return Err(PyValueError::new_err(format!(
                    "directors[{j}] is not orthonormal (|Q Qᵀ − I| = {defect:e}, allowed ≤ 1e-9)"
                )));
            }
        }
        Ok(Self {
            position: positions
                .map(|a| read_vec3s(a, "positions", n + 1))
                .transpose()?,
            velocity: velocities
                .map(|a| read_vec3s(a, "velocities", n + 1))
                .transpose()?,
            director,
            omega: angular_velocities
                .map(|a| read_vec3s(a, "angular_velocities", n))
                .transpose()?,
        })
    }

    /// Write the arrays into rod `r` of `state` (checked by the system; nothing is written on
    /// error).
    fn write(self, sim: &phys::Simulation, state: &mut SystemState, r: usize) -> PyResult<()> {
        let system = &sim.system;
        let mut s = system.rod_state(state, r);
        if let Some(v) = self.position {
            s.position = v;
        }
        if let Some(v) = self.velocity {
            s.velocity = v;
        }
        if let Some(v) = self.director {
            s.director = v;
        }
        if let Some(v) = self.omega {
            s.omega = v;
        }
        system.set_rod_state(state, r, &s).map_err(model_error)
    }
}

/// After the state was written from outside: a fresh workspace, so that the stability guard
/// takes its energy reference from the new state (as for a simulation built at it). The rest
/// of the workspace is scratch that every step rewrites.
fn state_written(sim: &mut phys::Simulation) {
    sim.workspace = Workspace::new(&sim.system, &sim.state);
}

impl Simulation {
    /// Wrap a physics simulation.
    pub(crate) fn from_inner(inner: phys::Simulation) -> Self {
        let rods = inner
            .system
            .rods()
            .iter()
            .map(|r| (r.name.clone(), r.n_elements()))
            .collect();
        Self {
            inner: Mutex::new(inner),
            rods,
        }
    }

    /// Lock the physics simulation from a thread attached to Python (see `crate::lock`).
    pub(crate) fn lock(&self, py: Python<'_>) -> MutexGuard<'_, phys::Simulation> {
        lock(py, &self.inner)
    }

    /// Lock the physics simulation from inside `py.detach` (GIL released).
    pub(crate) fn lock_detached(&self) -> MutexGuard<'_, phys::Simulation> {
        lock_detached(&self.inner)
    }

    /// A copy of the physics simulation (taken under the lock).
    pub(crate) fn snapshot(&self, py: Python<'_>) -> phys::Simulation {
        self.lock(py).clone()
    }

    fn names(&self) -> Vec<&str> {
        self.rods.iter().map(|(name, _)| name.as_str()).collect()
    }

    /// Number of elements of rod `r`.
    pub(crate) fn rod_elements(&self, r: usize) -> usize {
        self.rods[r].1
    }

    /// Index of the rod called `rod`, or of the only rod when `rod` is None.
    pub(crate) fn rod_index(&self, rod: Option<&str>) -> PyResult<usize> {
        let names = self.names();
        match rod {
            None if names.len() == 1 => Ok(0),
            None => Err(PyValueError::new_err(format!(
                "this simulation has {} rods ({}): pass rod=NAME to say which",
                names.len(),
                quoted(&names)
            ))),
            Some(name) => names.iter().position(|n| *n == name).ok_or_else(|| {
                PyValueError::new_err(format!(
                    "rod = {name:?} is not a rod of this simulation; its rods are {}",
                    quoted(&names)
                ))
            }),
        }
    }

    /// The only rod, for the one-rod shortcuts; `what` names the shortcut in the error.
    fn only_rod(&self, what: &str) -> PyResult<usize> {
        let names = self.names();
        if names.len() == 1 {
            return Ok(0);
        }
        Err(PyValueError::new_err(format!(
            "{what} is a one-rod shortcut, but this simulation has {} rods ({}): use \
             rod_state(name) (and rest_strains(rod=name), energies(rod=name), …) for one of them",
            names.len(),
            quoted(&names)
        )))
    }

    fn rod_state_dict<'py>(&self, py: Python<'py>, r: usize) -> PyResult<Bound<'py, PyDict>> {
        let s = {
            let sim = self.lock(py);
            sim.system.rod_state(&sim.state, r)
        };
        rod_state_to_dict(py, &s)
    }

    /// The state as bytes: tag, format, package version, then the postcard encoding of the
    /// physics simulation (system, state, actuation, workspace; every f64 as its 8 bytes).
    fn to_bytes_vec(&self, py: Python<'_>) -> PyResult<Vec<u8>> {
        let payload = postcard::to_allocvec(&*self.lock(py))
            .map_err(|e| PyValueError::new_err(format!("cannot serialise the simulation: {e}")))?;
        let version = env!("CARGO_PKG_VERSION").as_bytes();
        let mut out = Vec::with_capacity(PICKLE_TAG.len() + 2 + version.len() + payload.len());
        out.extend_from_slice(PICKLE_TAG);
        out.push(PICKLE_FORMAT);
        out.push(version.len() as u8);
        out.extend_from_slice(version);
        out.extend_from_slice(&payload);
        Ok(out)
    }

    fn from_bytes_slice(data: &[u8]) -> PyResult<Self> {
        let bad =
            |why: String| PyValueError::new_err(format!("not a pickled octoarm.Simulation: {why}"));
        let rest = data
            .strip_prefix(PICKLE_TAG)
            .ok_or_else(|| bad("the data does not start with its tag".into()))?;
        let [format, len, rest @ ..] = rest else {
            return Err(bad("the data is truncated".into()));
        };
        let len = *len as usize;
        if rest.len() < len {
            return Err(bad("the data is truncated".into()));
        }
        let (version, payload) = rest.split_at(len);
        let version = String::from_utf8_lossy(version);
        if *format != PICKLE_FORMAT || version != env!("CARGO_PKG_VERSION") {
            return Err(PyValueError::new_err(format!(
                "this simulation was pickled by octoarm {version} (format {format}); this is \
                 octoarm {} (format {PICKLE_FORMAT}): unpickle it with the version that wrote it",
                env!("CARGO_PKG_VERSION")
            )));
        }
        let (inner, left): (phys::Simulation, &[u8]) =
            postcard::take_from_bytes(payload).map_err(|e| bad(e.to_string()))?;
        if !left.is_empty() {
            return Err(bad(format!("{} bytes left over", left.len())));
        }
        let (sys, st) = (&inner.system, &inner.state);
        let sizes_fit = st.position.len() == sys.n_nodes()
            && st.velocity.len() == sys.n_nodes()
            && st.director.len() == sys.n_elements()
            && st.omega.len() == sys.n_elements()
            && st.work.len() == sys.rods().len()
            && st.dissipated.len() == sys.rods().len()
            && inner.actuation.shape() == (sys.n_nodes(), sys.n_elements(), sys.n_interior());
        if !sizes_fit {
            return Err(bad("its state does not fit its system".into()));
        }
        Ok(Self::from_inner(inner))
    }
}

/// One rod's state as the dict of copies `rod_state` returns.
fn rod_state_to_dict<'py>(py: Python<'py>, s: &RodState) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("positions", vec3s(py, &s.position))?;
    d.set_item("velocities", vec3s(py, &s.velocity))?;
    d.set_item("directors", mat3s(py, &s.director))?;
    d.set_item("angular_velocities", vec3s(py, &s.omega))?;
    d.set_item("time", s.time)?;
    Ok(d)
}

#[pymethods]
impl Simulation {
    /// Build one straight (optionally tapered, optionally pre-curved) rod. Defaults are the
    /// paper's arm: 100 elements, L = 0.2 m, diameter 2 cm → 0.04 cm, ρ = 700 kg/m³,
    /// E = 10 kPa, G = 1 kPa, along +x with d1 = e_y, clamped at the origin, dt = 1e-5 s.
    /// Ends: `boundary` "clamped" (base clamped, tip free: the default) or "free" (both free);
    /// or `base=` / `tip=` each "free", "pinned", "clamped" or a `Motion` (defaults clamped /
    /// free), not together with `boundary`. For several rods see `Simulation.from_rods`.
    #[new]
    #[pyo3(signature = (
        n_elements = 100, length = 0.2, base_diameter = 0.02, tip_diameter = 0.0004,
        density = 700.0, youngs_modulus = 1.0e4, shear_modulus = 1.0e3,
        shear_coefficient = Material::DEFAULT_SHEAR_COEFFICIENT,
        base_position = None, direction = None, normal = None, rest_curvature = None, boundary = None, dt = None,
        energy_consistent = false, base = None, tip = None
    ))]
    #[pyo3(text_signature = "(n_elements=100, length=0.2, base_diameter=0.02, \
        tip_diameter=0.0004, density=700.0, youngs_modulus=10000.0, shear_modulus=1000.0, \
        shear_coefficient=0.9642857142857143, base_position=(0.0, 0.0, 0.0), \
        direction=(1.0, 0.0, 0.0), normal=(0.0, 1.0, 0.0), rest_curvature=(0.0, 0.0, 0.0), \
        boundary=None, dt=1e-05, energy_consistent=False, base=None, tip=None)")]
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
        base_position: Option<&Bound<'_, PyAny>>,
        direction: Option<&Bound<'_, PyAny>>,
        normal: Option<&Bound<'_, PyAny>>,
        rest_curvature: Option<&Bound<'_, PyAny>>,
        boundary: Option<&str>,
        dt: Option<&Bound<'_, PyAny>>,
        energy_consistent: bool,
        base: Option<&Bound<'_, PyAny>>,
        tip: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let base_position = read_vec3_or(base_position, "base_position", [0.0; 3])?;
        let direction = read_vec3_or(direction, "direction", [1.0, 0.0, 0.0])?;
        let normal = read_vec3_or(normal, "normal", [0.0, 1.0, 0.0])?;
        let rest_curvature = read_vec3_or(rest_curvature, "rest_curvature", [0.0; 3])?;
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
        };
        let (mut b, mut t) = boundary_from(boundary.unwrap_or("clamped"))?;
        if boundary.is_some() && (base.is_some() || tip.is_some()) {
            return Err(PyValueError::new_err(
                "boundary and base= / tip= are alternatives: give boundary (\"clamped\" or \
                 \"free\") or the end conditions base= and tip=, not both",
            ));
        }
        if let Some(o) = base {
            b = end_condition("base", o)?;
        }
        if let Some(o) = tip {
            t = end_condition("tip", o)?;
        }
        let dt = TimeStep::read(dt, 1.0e-5)?;
        let settings = Settings {
            energy_consistent,
            ..Settings::with_dt(dt.initial())
        };
        let mut inner = single_rod(&rod, b, t, settings)?;
        dt.apply(&mut inner)?;
        Ok(Self::from_inner(inner))
    }

    /// The paper's arm (`StraightRod::paper_arm`) with `n_elements` elements and time step `dt`
    /// (seconds, or "auto").
    #[staticmethod]
    #[pyo3(signature = (dt = None, n_elements = 100),
        text_signature = "(dt=1e-05, n_elements=100)")]
    fn paper_arm(dt: Option<&Bound<'_, PyAny>>, n_elements: i64) -> PyResult<Self> {
        let dt = TimeStep::read(dt, 1.0e-5)?;
        let rod = StraightRod::paper_arm().with_elements(check_count("n_elements", n_elements, 2)?);
        let mut inner = single_rod(
            &rod,
            EndCondition::Clamped,
            EndCondition::Free,
            Settings::with_dt(dt.initial()),
        )?;
        dt.apply(&mut inner)?;
        Ok(Self::from_inner(inner))
    }

    /// COOMM's muscular arm (muscles-3d spec §1): 0.2 m, tapered 24 → 2.4 mm, E = 10 kPa, in
    /// the COOMM frame (along +x, d1 = −e_z), clamped at the origin, with its seven muscle
    /// groups (thirteen fibres, cubic force–length curve), Morison drag (`drag`, §3.1) and the
    /// `coomm` damping preset (`damping`, §3.2); `n_elements` ≥ 4 (default 100), time step `dt`
    /// [s] (default 1e-5, or "auto"). Drive it with `set_activations` or a
    /// `MuscleShapingController`.
    #[staticmethod]
    #[pyo3(signature = (dt = None, n_elements = 100, drag = true, damping = true),
        text_signature = "(dt=1e-05, n_elements=100, drag=True, damping=True)")]
    fn coomm_arm(
        dt: Option<&Bound<'_, PyAny>>,
        n_elements: i64,
        drag: bool,
        damping: bool,
    ) -> PyResult<Self> {
        let dt = TimeStep::read(dt, 1.0e-5)?;
        let n = check_count("n_elements", n_elements, 4)?;
        let mut inner = crate::muscle::coomm_simulation(n, dt.initial(), drag, damping)?;
        dt.apply(&mut inner)?;
        Ok(Self::from_inner(inner))
    }

    /// Set the muscle activations (7, n) in [0, 1], group-major (row g = group g of
    /// `octoarm.MUSCLE_GROUPS`), held until changed. Only for a muscular arm (`coomm_arm`).
    fn set_activations(&self, py: Python<'_>, activations: &Bound<'_, PyAny>) -> PyResult<()> {
        let r = self.only_rod("set_activations")?;
        let n = self.rod_elements(r);
        let a = crate::muscle::read_activations(activations, "activations", n)?;
        let mut s = self.lock(py);
        if s.system.rod(r).muscles.is_none() {
            return Err(PyValueError::new_err(
                "this simulation has no muscles: build it with Simulation.coomm_arm()",
            ));
        }
        for g in 0..phys::N_GROUPS {
            s.set_activation(g, &a[g * n..(g + 1) * n])
                .map_err(model_error)?;
        }
        Ok(())
    }

    /// The muscle activations in force (7, n), group-major (zeros if none were set).
    #[getter]
    fn activations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let r = self.only_rod("activations")?;
        let n = self.rod_elements(r);
        let a: Vec<f64> = {
            let s = self.lock(py);
            let e0 = s.system.rod(r).offsets().element;
            (0..phys::N_GROUPS)
                .flat_map(|g| s.actuation.group_activation(g)[e0..e0 + n].to_vec())
                .collect()
        };
        Ok(crate::muscle::activation_array(py, &a, n))
    }

    /// A system of rods (a sequence of `Rod`, names unique) joined by `joints` (a sequence of
    /// `Joint`), at rest in the rods' initial shapes at t = 0, undamped, time step `dt` [s].
    #[staticmethod]
    /// `clamp_order` 2 selects the second-order clamp (see docs/physics.md).
    #[pyo3(signature = (rods, joints = Vec::new(), dt = None, energy_consistent = false, clamp_order = 1),
        text_signature = "(rods, joints=(), dt=1e-05, energy_consistent=False, clamp_order=1)")]
    fn from_rods(
        rods: Vec<PyRef<'_, Rod>>,
        joints: Vec<PyRef<'_, Joint>>,
        dt: Option<&Bound<'_, PyAny>>,
        energy_consistent: bool,
        clamp_order: u8,
    ) -> PyResult<Self> {
        let dt = TimeStep::read(dt, 1.0e-5)?;
        let rods: Vec<Rod> = rods.iter().map(|r| (**r).clone()).collect();
        let joints: Vec<Joint> = joints.iter().map(|j| (**j).clone()).collect();
        let settings = Settings {
            energy_consistent,
            clamp_order,
            ..Settings::with_dt(dt.initial())
        };
        let (system, state) = build_system(&rods, &joints, settings)?;
        let mut inner = phys::Simulation::from_parts(system, state);
        dt.apply(&mut inner)?;
        Ok(Self::from_inner(inner))
    }

    /// An independent copy (system, state, actuation, counters and guard history).
    fn copy(&self, py: Python<'_>) -> Self {
        Self::from_inner(self.snapshot(py))
    }

    fn __copy__(&self, py: Python<'_>) -> Self {
        Self::from_inner(self.snapshot(py))
    }

    fn __deepcopy__(&self, py: Python<'_>, _memo: &Bound<'_, PyAny>) -> Self {
        Self::from_inner(self.snapshot(py))
    }

    /// The simulation as bytes (what pickle stores): restored by `Simulation.from_bytes` to the
    /// last bit, by the same octoarm version.
    fn to_bytes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let bytes = self.to_bytes_vec(py)?;
        Ok(PyBytes::new(py, &bytes))
    }

    /// A simulation from `to_bytes` (or a pickle's payload). Refuses data of another version.
    #[staticmethod]
    fn from_bytes(data: &[u8]) -> PyResult<Self> {
        Self::from_bytes_slice(data)
    }

    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, (Bound<'py, PyBytes>,))> {
        let restore = py
            .import("octoarm._octoarm")?
            .getattr("_simulation_from_bytes")?;
        Ok((restore, (self.to_bytes(py)?,)))
    }

    /// Advance `n` steps (GIL released), then run the stability guard on the final state.
    /// Raises `InstabilityError` if the guard fires (the state is kept as it was then). Other
    /// threads calling this simulation meanwhile wait until the steps are done.
    #[pyo3(signature = (n = 1))]
    fn step(&self, py: Python<'_>, n: i64) -> PyResult<()> {
        let n = check_count("n", n, 0)? as u64;
        py.detach(|| self.lock_detached().run(n))
            .map_err(|e| step_error(py, e))
    }

    /// Names of the rods, in system order.
    #[getter]
    fn rod_names(&self) -> Vec<String> {
        self.names().into_iter().map(String::from).collect()
    }

    /// Number of rods.
    #[getter]
    fn n_rods(&self) -> usize {
        self.rods.len()
    }

    /// State of one rod as a dict of copies: positions [m] (n + 1, 3) and velocities [m/s]
    /// (n + 1, 3), lab frame; directors (n, 3, 3), rows d1, d2, d3 in lab components;
    /// angular_velocities [rad/s] (n, 3), material frame; time [s].
    #[pyo3(signature = (name = None))]
    fn rod_state<'py>(&self, py: Python<'py>, name: Option<&str>) -> PyResult<Bound<'py, PyDict>> {
        let r = self.rod_index(name)?;
        self.rod_state_dict(py, r)
    }

    /// Overwrite any of one rod's positions (n + 1, 3), velocities (n + 1, 3), directors
    /// (n, 3, 3; orthonormal) and angular_velocities (n, 3). Shapes must match exactly and
    /// entries be finite; on any error nothing is written. Held ends keep their held pose (it
    /// is re-applied at the next step). The stability guard takes its energy reference from the
    /// new state.
    #[pyo3(signature = (name = None, *, positions = None, velocities = None, directors = None,
        angular_velocities = None))]
    fn set_rod_state(
        &self,
        py: Python<'_>,
        name: Option<&str>,
        positions: Option<&Bound<'_, PyAny>>,
        velocities: Option<&Bound<'_, PyAny>>,
        directors: Option<&Bound<'_, PyAny>>,
        angular_velocities: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let r = self.rod_index(name)?;
        let arrays = RodArrays::read(
            self.rod_elements(r),
            positions,
            velocities,
            directors,
            angular_velocities,
        )?;
        let mut sim = self.lock(py);
        let mut state = sim.state.clone();
        arrays.write(&sim, &mut state, r)?;
        sim.state = state;
        state_written(&mut sim);
        Ok(())
    }

    /// The state of every rod: {rod name: rod_state(name)}.
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        // One lock for all rods: a consistent snapshot.
        let states: Vec<RodState> = {
            let sim = self.lock(py);
            (0..self.rods.len())
                .map(|r| sim.system.rod_state(&sim.state, r))
                .collect()
        };
        let d = PyDict::new(py);
        for ((name, _), s) in self.rods.iter().zip(&states) {
            d.set_item(name, rod_state_to_dict(py, s)?)?;
        }
        Ok(d)
    }

    /// Overwrite the state of the rods named in `d` (as `state()` returns it: {rod name: {
    /// "positions": …, "velocities": …, "directors": …, "angular_velocities": …}}, any subset of
    /// rods and arrays; a "time" entry is ignored: time is the step count's). All or nothing.
    fn set_state(&self, py: Python<'_>, d: &Bound<'_, PyDict>) -> PyResult<()> {
        let mut writes = Vec::with_capacity(d.len());
        for (key, value) in d.iter() {
            let name: String = key.extract().map_err(|_| {
                PyValueError::new_err(format!(
                    "set_state takes {{rod name: {{array name: array}}}}; {key} is not a rod name"
                ))
            })?;
            let r = self.rod_index(Some(&name))?;
            let arrays = value.cast::<PyDict>().map_err(|_| {
                PyValueError::new_err(format!(
                    "set_state: the entry of rod {name:?} must be a dict of arrays"
                ))
            })?;
            let (mut p, mut v, mut q, mut w) = (None, None, None, None);
            for (k, a) in arrays.iter() {
                match k.extract::<String>()?.as_str() {
                    "positions" => p = Some(a),
                    "velocities" => v = Some(a),
                    "directors" => q = Some(a),
                    "angular_velocities" => w = Some(a),
                    "time" => {}
                    other => {
                        return Err(PyValueError::new_err(format!(
                            "set_state: rod {name:?} has an entry {other:?}; allowed are \
                             \"positions\", \"velocities\", \"directors\", \"angular_velocities\" \
                             (and \"time\", ignored)"
                        )))
                    }
                }
            }
            let n = self.rod_elements(r);
            let arrays = RodArrays::read(n, p.as_ref(), v.as_ref(), q.as_ref(), w.as_ref())?;
            writes.push((r, arrays));
        }
        let mut sim = self.lock(py);
        let mut state = sim.state.clone();
        for (r, arrays) in writes {
            arrays.write(&sim, &mut state, r)?;
        }
        sim.state = state;
        state_written(&mut sim);
        Ok(())
    }

    /// Add uniform gravity g [m/s²] (lab frame) on a rod.
    #[pyo3(signature = (acceleration, rod = None))]
    fn add_gravity(
        &self,
        py: Python<'_>,
        acceleration: &Bound<'_, PyAny>,
        rod: Option<&str>,
    ) -> PyResult<()> {
        let acceleration = read_vec3(acceleration, "acceleration")?;
        let r = self.rod_index(rod)?;
        self.lock(py)
            .system
            .add_load(r, Load::Gravity { acceleration }, Schedule::Constant)
            .map_err(model_error)
    }

    /// Add a point force [N] (lab) on `node` (default: the tip) of a rod, ramped linearly from 0
    /// over `ramp_time` [s] (0: at once).
    #[pyo3(signature = (force, node = None, ramp_time = 0.0, rod = None))]
    fn add_node_force(
        &self,
        py: Python<'_>,
        force: &Bound<'_, PyAny>,
        node: Option<i64>,
        ramp_time: f64,
        rod: Option<&str>,
    ) -> PyResult<()> {
        let force = read_vec3(force, "force")?;
        let r = self.rod_index(rod)?;
        let n = self.rod_elements(r);
        let node = match node {
            None => n,
            Some(i) if (0..=n as i64).contains(&i) => i as usize,
            Some(i) => {
                return Err(PyValueError::new_err(format!(
                    "node = {i} is outside the allowed range [0, {n}]"
                )))
            }
        };
        let schedule = ramp(ramp_time)?;
        self.lock(py)
            .system
            .add_load(r, Load::NodeForce { node, force }, schedule)
            .map_err(model_error)
    }

    /// Add a distributed force per rest length [N/m] (lab) on a rod.
    #[pyo3(signature = (force_per_length, rod = None))]
    fn add_uniform_force(
        &self,
        py: Python<'_>,
        force_per_length: &Bound<'_, PyAny>,
        rod: Option<&str>,
    ) -> PyResult<()> {
        let force_per_length = read_vec3(force_per_length, "force_per_length")?;
        let r = self.rod_index(rod)?;
        self.lock(py)
            .system
            .add_load(
                r,
                Load::UniformForce { force_per_length },
                Schedule::Constant,
            )
            .map_err(model_error)
    }

    /// Add a point couple [N m] on `element` (default: the last) of a rod, ramped over
    /// `ramp_time` [s]; lab frame, or material frame (turning with the element) with
    /// `follower=True`.
    #[pyo3(signature = (couple, element = None, ramp_time = 0.0, follower = false, rod = None))]
    fn add_element_couple(
        &self,
        py: Python<'_>,
        couple: &Bound<'_, PyAny>,
        element: Option<i64>,
        ramp_time: f64,
        follower: bool,
        rod: Option<&str>,
    ) -> PyResult<()> {
        let couple = read_vec3(couple, "couple")?;
        let r = self.rod_index(rod)?;
        let n = self.rod_elements(r);
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
        let load = if follower {
            Load::FollowerElementCouple { element, couple }
        } else {
            Load::ElementCouple { element, couple }
        };
        let schedule = ramp(ramp_time)?;
        self.lock(py)
            .system
            .add_load(r, load, schedule)
            .map_err(model_error)
    }

    /// Add a distributed couple per rest length [N m/m] on a rod; `follower=True` makes it
    /// material-frame.
    #[pyo3(signature = (couple_per_length, follower = false, rod = None))]
    fn add_uniform_couple(
        &self,
        py: Python<'_>,
        couple_per_length: &Bound<'_, PyAny>,
        follower: bool,
        rod: Option<&str>,
    ) -> PyResult<()> {
        let couple_per_length = read_vec3(couple_per_length, "couple_per_length")?;
        let r = self.rod_index(rod)?;
        let load = if follower {
            Load::FollowerCouple { couple_per_length }
        } else {
            Load::UniformCouple { couple_per_length }
        };
        self.lock(py)
            .system
            .add_load(r, load, Schedule::Constant)
            .map_err(model_error)
    }

    /// Remove every external load of every rod.
    fn clear_loads(&self, py: Python<'_>) {
        self.lock(py).system.clear_loads();
    }

    /// Add a rigid sphere obstacle (every rod touches it): centre [m] at t = 0, radius [m] > 0,
    /// velocity [m/s], Coulomb friction (see `add_plane`).
    #[pyo3(signature = (center, radius, velocity = None, friction = None, kinetic_friction = None),
        text_signature = "(self, center, radius, velocity=(0.0, 0.0, 0.0), friction=None, kinetic_friction=None)")]
    fn add_obstacle(
        &self,
        py: Python<'_>,
        center: &Bound<'_, PyAny>,
        radius: f64,
        velocity: Option<&Bound<'_, PyAny>>,
        friction: Option<&Bound<'_, PyAny>>,
        kinetic_friction: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let center = read_vec3(center, "center")?;
        let velocity = read_vec3_or(velocity, "velocity", [0.0; 3])?;
        let friction = read_friction(friction, kinetic_friction)?;
        self.lock(py)
            .add_obstacle(Sphere {
                center,
                radius,
                velocity,
                friction,
            })
            .map_err(model_error)
    }

    /// Add a rigid plane (every rod touches it): a `point` on it [m], its `normal` towards the
    /// rods, and Coulomb friction: `friction` the static coefficient (a number, or three numbers
    /// for sliding forward / backward along the rod and laterally), `kinetic_friction` the
    /// kinetic one (default: the static one).
    #[pyo3(signature = (point, normal, friction = None, kinetic_friction = None),
        text_signature = "(self, point, normal, friction=None, kinetic_friction=None)")]
    fn add_plane(
        &self,
        py: Python<'_>,
        point: &Bound<'_, PyAny>,
        normal: &Bound<'_, PyAny>,
        friction: Option<&Bound<'_, PyAny>>,
        kinetic_friction: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let point = read_vec3(point, "point")?;
        let normal = read_vec3(normal, "normal")?;
        let friction = read_friction(friction, kinetic_friction)?;
        self.lock(py)
            .add_plane(phys::Plane {
                point,
                normal,
                friction,
            })
            .map_err(model_error)
    }

    /// Add a rigid finite cylinder (a capsule: every point within `radius` of the axis segment
    /// of `length` centred on `center` along `axis`), moving at `velocity` [m/s], with Coulomb
    /// friction as `add_plane`.
    #[pyo3(signature = (center, axis, radius, length, velocity = None, friction = None, kinetic_friction = None),
        text_signature = "(self, center, axis, radius, length, velocity=(0.0, 0.0, 0.0), friction=None, kinetic_friction=None)")]
    #[allow(clippy::too_many_arguments)]
    fn add_cylinder(
        &self,
        py: Python<'_>,
        center: &Bound<'_, PyAny>,
        axis: &Bound<'_, PyAny>,
        radius: f64,
        length: f64,
        velocity: Option<&Bound<'_, PyAny>>,
        friction: Option<&Bound<'_, PyAny>>,
        kinetic_friction: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let center = read_vec3(center, "center")?;
        let axis = read_vec3(axis, "axis")?;
        let velocity = read_vec3_or(velocity, "velocity", [0.0; 3])?;
        let friction = read_friction(friction, kinetic_friction)?;
        self.lock(py)
            .add_cylinder(phys::Cylinder {
                center,
                axis,
                radius,
                length,
                velocity,
                friction,
            })
            .map_err(model_error)
    }

    /// Set the contact parameters: penalty stiffness factor `beta` (k = β E A / l) and damping
    /// ratio `zeta`; whether different rods touch (`rods`) and a rod touches itself
    /// (`self_contact`), with Coulomb friction between rods (`rod_friction`,
    /// `rod_kinetic_friction`, as `add_plane`); the friction regularisation `friction_eta`
    /// (viscosity η m / Δt), `stick_stiffness` (obstacle stick spring / k) and the rod–rod
    /// `slip_velocity` [m/s]; the centreline rod–rod contact measures gaps on,
    /// `rod_geometry` = "polyline" (straight segments) or "smooth" (the cubic B-spline of the
    /// nodes: a rope pressed mid-element stays there instead of sliding to a node).
    #[pyo3(signature = (beta = 1.0, zeta = 0.5, rods = false, self_contact = false,
        rod_friction = None, rod_kinetic_friction = None, friction_eta = 0.5,
        stick_stiffness = 0.5, slip_velocity = 1e-3, rod_geometry = "polyline"))]
    #[allow(clippy::too_many_arguments)]
    fn set_contact(
        &self,
        py: Python<'_>,
        beta: f64,
        zeta: f64,
        rods: bool,
        self_contact: bool,
        rod_friction: Option<&Bound<'_, PyAny>>,
        rod_kinetic_friction: Option<&Bound<'_, PyAny>>,
        friction_eta: f64,
        stick_stiffness: f64,
        slip_velocity: f64,
        rod_geometry: &str,
    ) -> PyResult<()> {
        let rod_friction = read_friction(rod_friction, rod_kinetic_friction)?;
        let rod_geometry = phys::RodGeometry::parse(rod_geometry).ok_or_else(|| {
            PyValueError::new_err(format!(
                "rod_geometry: {rod_geometry:?} is not one of \"polyline\", \"smooth\""
            ))
        })?;
        self.lock(py)
            .set_contact(phys::ContactParams {
                beta,
                zeta,
                friction_eta,
                stick_stiffness,
                slip_velocity,
                rods,
                self_contact,
                rod_friction,
                rod_geometry,
            })
            .map_err(model_error)
    }

    /// Remove every obstacle.
    fn clear_obstacles(&self, py: Python<'_>) {
        self.lock(py).system.clear_obstacles();
    }

    /// Set a rod's damping: mass-proportional `rate` ν_d [1/s] and the paper's per-length
    /// `gamma` [kg/(m s)], both ≥ 0.
    #[pyo3(signature = (rate = 0.0, gamma = 0.0, rod = None))]
    fn set_damping(
        &self,
        py: Python<'_>,
        rate: f64,
        gamma: f64,
        rod: Option<&str>,
    ) -> PyResult<()> {
        let r = self.rod_index(rod)?;
        self.lock(py)
            .system
            .set_damping(
                r,
                Damping {
                    rate,
                    gamma,
                    analytical: None,
                },
            )
            .map_err(model_error)
    }

    /// Set a rod's rest strains in force: σ° (n, 3) per element and κ° [1/m] (n − 1, 3) per
    /// interior point, material frame.
    #[pyo3(signature = (sigma, kappa, rod = None))]
    fn set_rest_strains(
        &self,
        py: Python<'_>,
        sigma: &Bound<'_, PyAny>,
        kappa: &Bound<'_, PyAny>,
        rod: Option<&str>,
    ) -> PyResult<()> {
        let r = self.rod_index(rod)?;
        let n = self.rod_elements(r);
        let s = read_vec3s(sigma, "sigma", n)?;
        let k = read_vec3s(kappa, "kappa", n - 1)?;
        self.lock(py)
            .system
            .set_rest_strains(r, &s, &k)
            .map_err(model_error)
    }

    /// A rod's rest strains in force (copies): (σ° (n, 3), κ° [1/m] (n − 1, 3)), material frame.
    #[pyo3(signature = (rod = None))]
    fn rest_strains<'py>(&self, py: Python<'py>, rod: Option<&str>) -> PyResult<ArrayPair<'py>> {
        let r = self.rod_index(rod)?;
        let (s, k) = {
            let sim = self.lock(py);
            let (s, k) = sim.system.rest_strains(r);
            (s.to_vec(), k.to_vec())
        };
        Ok((vec3s(py, &s), vec3s(py, &k)))
    }

    /// Number of elements n of the rod (one-rod shortcut).
    #[getter]
    fn n_elements(&self) -> PyResult<usize> {
        let r = self.only_rod("n_elements")?;
        Ok(self.rod_elements(r))
    }

    /// Time step [s]. With `dt="auto"`: 0.2 of the stable limit of the system as it is now
    /// (re-chosen when obstacles or contact are added, until the first step).
    #[getter]
    fn dt(&self, py: Python<'_>) -> f64 {
        self.lock(py).settings().dt
    }

    /// Whether the time step is automatic (`dt="auto"`); the guard then also stops a run whose
    /// dt exceeds 0.5 of the stable limit of the deformed state.
    #[getter]
    fn auto_dt(&self, py: Python<'_>) -> bool {
        self.lock(py).auto_dt
    }

    /// Largest stable time step estimate 2/ω_max of the system [s] (rods and joints).
    #[getter]
    fn stable_dt(&self, py: Python<'_>) -> f64 {
        self.lock(py).system.stable_dt()
    }

    /// Simulated time [s].
    #[getter]
    fn time(&self, py: Python<'_>) -> f64 {
        self.lock(py).time()
    }

    /// Steps taken.
    #[getter]
    fn steps(&self, py: Python<'_>) -> u64 {
        self.lock(py).steps()
    }

    /// Node positions [m], (n + 1, 3), lab frame (copy; one-rod shortcut).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let r = self.only_rod("positions")?;
        let v = {
            let sim = self.lock(py);
            sim.state.position.to_vec(sim.system.rod(r).nodes())
        };
        Ok(vec3s(py, &v))
    }

    /// Node velocities [m/s], (n + 1, 3), lab frame (copy; one-rod shortcut).
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let r = self.only_rod("velocities")?;
        let v = {
            let sim = self.lock(py);
            sim.state.velocity.to_vec(sim.system.rod(r).nodes())
        };
        Ok(vec3s(py, &v))
    }

    /// Element directors Q, (n, 3, 3); row i is d_(i+1) in lab components (copy; one-rod
    /// shortcut).
    #[getter]
    fn directors<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let r = self.only_rod("directors")?;
        let v = {
            let sim = self.lock(py);
            sim.state.director.to_vec(sim.system.rod(r).elements())
        };
        Ok(mat3s(py, &v))
    }

    /// Element angular velocities ω [rad/s], (n, 3), material frame (copy; one-rod shortcut).
    #[getter]
    fn angular_velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let r = self.only_rod("angular_velocities")?;
        let v = {
            let sim = self.lock(py);
            sim.state.omega.to_vec(sim.system.rod(r).elements())
        };
        Ok(vec3s(py, &v))
    }

    /// Tip (last node) position [m], (3,) (one-rod shortcut).
    #[getter]
    fn tip<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let r = self.only_rod("tip")?;
        let tip = {
            let sim = self.lock(py);
            sim.state.position.get(sim.system.rod(r).nodes().end - 1)
        };
        Ok(scalars(py, &tip))
    }

    /// Rest shear/stretch strains in force σ° (n, 3), material frame (copy; one-rod shortcut).
    #[getter]
    fn rest_sigma<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let r = self.only_rod("rest_sigma")?;
        let v = self.lock(py).system.rest_strains(r).0.to_vec();
        Ok(vec3s(py, &v))
    }

    /// Rest curvatures in force κ° [1/m] (n − 1, 3), material frame (copy; one-rod shortcut).
    #[getter]
    fn rest_kappa<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let r = self.only_rod("rest_kappa")?;
        let v = self.lock(py).system.rest_strains(r).1.to_vec();
        Ok(vec3s(py, &v))
    }

    /// A rod's current strains: (σ (n, 3) dimensionless, κ (n − 1, 3) [1/m]), material frame.
    #[pyo3(signature = (rod = None))]
    fn strains<'py>(&self, py: Python<'py>, rod: Option<&str>) -> PyResult<ArrayPair<'py>> {
        let r = self.rod_index(rod)?;
        let n = self.rod_elements(r);
        let mut sigma = vec![[0.0; 3]; n];
        let mut kappa = vec![[0.0; 3]; n - 1];
        {
            let sim = self.lock(py);
            let view = sim.system.view(&sim.state, r);
            phys::strains(&sim.system.rod(r).model, &view, &mut sigma, &mut kappa);
        }
        Ok((vec3s(py, &sigma), vec3s(py, &kappa)))
    }

    /// A rod's energies [J] against its rest strains in force: translational, rotational,
    /// stretch, bend, kinetic, potential, total, and its external_work and dissipated energy
    /// since t = 0.
    #[pyo3(signature = (rod = None))]
    fn energies<'py>(&self, py: Python<'py>, rod: Option<&str>) -> PyResult<Bound<'py, PyDict>> {
        let r = self.rod_index(rod)?;
        let (e, work, dissipated) = {
            let sim = self.lock(py);
            let e = phys::rod_energies(&sim.system, &sim.state, r);
            (e, sim.state.work[r], sim.state.dissipated[r])
        };
        let d = PyDict::new(py);
        d.set_item("translational", e.translational)?;
        d.set_item("rotational", e.rotational)?;
        d.set_item("stretch", e.stretch)?;
        d.set_item("bend", e.bend)?;
        d.set_item("kinetic", e.kinetic())?;
        d.set_item("potential", e.potential())?;
        d.set_item("total", e.total())?;
        d.set_item("external_work", work)?;
        d.set_item("dissipated", dissipated)?;
        Ok(d)
    }

    /// A rod's model constants per domain as a dict of copies: rest_length (n,), radius (n,),
    /// node_mass (n + 1,), shear_stiffness (n, 3), bend_stiffness (n − 1, 3).
    #[pyo3(signature = (rod = None))]
    fn model<'py>(&self, py: Python<'py>, rod: Option<&str>) -> PyResult<Bound<'py, PyDict>> {
        let r = self.rod_index(rod)?;
        // The model is shared (Arc) and never changes: read it after the lock.
        let m = Arc::clone(&self.lock(py).system.rod(r).model);
        let d = PyDict::new(py);
        d.set_item("rest_length", scalars(py, &m.rest_length))?;
        d.set_item("radius", scalars(py, &m.radius))?;
        d.set_item("node_mass", scalars(py, &m.node_mass))?;
        d.set_item("shear_stiffness", vec3s(py, &m.shear_stiffness))?;
        d.set_item("bend_stiffness", vec3s(py, &m.bend_stiffness))?;
        Ok(d)
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        let what = if self.rods.len() == 1 {
            format!("n_elements={}", self.rods[0].1)
        } else {
            format!("rods=[{}]", quoted(&self.names()))
        };
        let (dt, time, steps) = {
            let sim = self.lock(py);
            (sim.settings().dt, sim.time(), sim.steps())
        };
        format!("Simulation({what}, dt={dt:e}, time={time}, steps={steps})")
    }
}

/// Restore a pickled `Simulation` (the target of `Simulation.__reduce__`).
#[pyfunction]
#[pyo3(name = "_simulation_from_bytes")]
pub fn simulation_from_bytes(data: &[u8]) -> PyResult<Simulation> {
    Simulation::from_bytes_slice(data)
}

/// Reference speed of the Rust loop: steps per second of `sim` (copied) advanced `steps` steps in
/// one call, GIL released. Used by the speed benchmark to compare with stepping from Python.
#[pyfunction]
pub fn rust_step_rate(py: Python<'_>, sim: &Simulation, steps: u64) -> PyResult<f64> {
    let mut s = sim.snapshot(py);
    let t0 = Instant::now();
    py.detach(|| s.run(steps)).map_err(|e| step_error(py, e))?;
    Ok(steps as f64 / t0.elapsed().as_secs_f64())
}

/// Friction coefficients from Python: a number or three numbers (forward, backward, lateral)
/// for the static coefficient, and the kinetic one likewise (default: the static one).
fn read_friction(
    static_mu: Option<&Bound<'_, PyAny>>,
    kinetic: Option<&Bound<'_, PyAny>>,
) -> PyResult<phys::Friction> {
    let Some(static_mu) = static_mu else {
        if kinetic.is_some() {
            return Err(pyo3::exceptions::PyValueError::new_err(
                "kinetic_friction needs friction (the static coefficient) too",
            ));
        }
        return Ok(phys::Friction::NONE);
    };
    let three = |o: &Bound<'_, PyAny>, field: &str| -> PyResult<[f64; 3]> {
        if let Ok(x) = o.extract::<f64>() {
            Ok([x; 3])
        } else {
            read_vec3(o, field)
        }
    };
    let s = three(static_mu, "friction")?;
    let k = match kinetic {
        Some(k) => three(k, "kinetic_friction")?,
        None => s,
    };
    let f = phys::Friction {
        static_mu: s,
        kinetic_mu: k,
    };
    f.validate().map_err(model_error)?;
    Ok(f)
}
