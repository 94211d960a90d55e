//! The muscular arm in 3D (COOMM's muscles, muscles-3d spec) from Python: `MuscleDesign` (the
//! equilibrium for given activations, spec §4, and the SE(3) reach design over activations,
//! §5) and `MuscleShapingController` (hold a design with COOMM's ramp, §6). Activations cross
//! the boundary as (7, n) float64 arrays (group-major: row g is group g, `octoarm.MUSCLE_GROUPS`
//! names them), poses as a position (3,) and an orientation (3, 3) whose rows are d1, d2, d3.
//! `Simulation.coomm_arm` and `Simulation.set_activations` (rod.rs) build and drive the arm.

use crate::arrays::{mat3s, read_any, read_array, read_vec3, shape_str, vec3s};
use crate::rod::Simulation;
use crate::system::check_count;
use crate::{lock, lock_detached, model_error, step_error};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2};
use octoarm_control as ctl;
use octoarm_control::{Controller, DesignConfig, DesignOutcome, MuscleStatics, ReachTask};
use octoarm_physics as phys;
use octoarm_physics::math::norm;
use octoarm_physics::N_GROUPS;
use octoarm_physics::{Damping, Load, Mat3, MuscleModel, MuscleSpec, Settings, StraightRod, Vec3};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Mutex;

/// COOMM's arm (spec §1.1) with `n_elements` elements, its muscles (§1.2, cubic force–length),
/// optionally Morison drag (§3.1) and the `coomm` damping preset (§3.2); clamped base, free tip.
pub(crate) fn coomm_simulation(
    n_elements: usize,
    dt: f64,
    drag: bool,
    damping: bool,
) -> PyResult<phys::Simulation> {
    let rod = StraightRod::coomm_arm().with_elements(n_elements);
    let (density, base_radius) = (rod.material.density, 0.5 * rod.base_diameter);
    let (model, state) = rod.build().map_err(model_error)?;
    let drag_load = Load::coomm_drag(&model);
    let mut sim =
        phys::Simulation::new(model, state, Settings::with_dt(dt)).map_err(model_error)?;
    if damping {
        sim.set_damping(Damping::coomm(density, base_radius))
            .map_err(model_error)?;
    }
    if drag {
        sim.add_load(drag_load).map_err(model_error)?;
    }
    sim.set_muscles(Some(MuscleSpec::coomm()))
        .map_err(model_error)?;
    Ok(sim)
}

/// Read activations (7, n) in [0, 1]; `ValueError` names the entry out of range.
pub(crate) fn read_activations(
    obj: &Bound<'_, PyAny>,
    field: &str,
    n: usize,
) -> PyResult<Vec<f64>> {
    let a = read_array(obj, field, &[N_GROUPS, n])?;
    if let Some(i) = a.iter().position(|v| !(0.0..=1.0).contains(v)) {
        return Err(PyValueError::new_err(format!(
            "{field}[{}, {}] = {} is outside the allowed range [0, 1]",
            i / n,
            i % n,
            a[i]
        )));
    }
    Ok(a)
}

/// (7, n) array of group-major activations.
pub(crate) fn activation_array<'py>(
    py: Python<'py>,
    a: &[f64],
    n: usize,
) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_vec((N_GROUPS, n), a.to_vec())
        .expect("7 × n activations")
        .into_pyarray(py)
}

/// Read an orientation (3, 3) with orthonormal rows (to 1e-6) and determinant +1.
pub(crate) fn read_orientation(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<Mat3> {
    let v = read_array(obj, field, &[3, 3])?;
    let q: Mat3 = [[v[0], v[1], v[2]], [v[3], v[4], v[5]], [v[6], v[7], v[8]]];
    let defect = octoarm_physics::math::orthonormality_defect(&q);
    let det = q[0][0] * (q[1][1] * q[2][2] - q[1][2] * q[2][1])
        - q[0][1] * (q[1][0] * q[2][2] - q[1][2] * q[2][0])
        + q[0][2] * (q[1][0] * q[2][1] - q[1][1] * q[2][0]);
    if !(defect <= 1e-6 && det > 0.0) {
        return Err(PyValueError::new_err(format!(
            "{field} must be a rotation (orthonormal rows d1, d2, d3, determinant +1): its \
             orthonormality defect is {defect:e} (allowed ≤ 1e-6), its determinant {det}"
        )));
    }
    Ok(q)
}

fn outcome_name(o: DesignOutcome) -> &'static str {
    match o {
        DesignOutcome::Converged => "converged",
        DesignOutcome::Stalled => "stalled",
        DesignOutcome::NotConverged => "not_converged",
        DesignOutcome::LineSearchFailed => "line_search_failed",
        DesignOutcome::BoundsMet => "bounds_met",
    }
}

/// The statics and reach design of COOMM's muscular arm (spec §4–5) with `n_elements` elements
/// (≥ 4, default 100): `equilibrium(activations)` is the exact discrete equilibrium (Newton on
/// the banded Jacobian, warm-started from the last solution); `solve(target, ...)` minimises
/// J = ½ Σ l̂ a² + Φ_p + Φ_Q over a ∈ [0, 1]^{7×n} by projected L-BFGS with the exact adjoint
/// gradient. The arm is clamped at the origin along +x with d1 = −e_z (the COOMM frame).
#[pyclass(module = "octoarm", frozen)]
pub struct MuscleDesign {
    inner: Mutex<ctl::MuscleDesign>,
    n: usize,
    /// The straight arm's tip node [m].
    tip0: Vec3,
}

impl MuscleDesign {
    fn equilibrium_dict<'py>(
        py: Python<'py>,
        d: &ctl::MuscleDesign,
    ) -> PyResult<Bound<'py, PyDict>> {
        let st = d.statics();
        let pose = st.pose(st.solution());
        let out = PyDict::new(py);
        out.set_item("positions", vec3s(py, &pose.position))?;
        out.set_item("directors", mat3s(py, &pose.director))?;
        let n = st.n_elements();
        let p: Vec3 =
            std::array::from_fn(|c| 0.5 * (pose.position[n - 1][c] + pose.position[n][c]));
        out.set_item("tip", p.to_vec())?;
        out.set_item(
            "tip_orientation",
            mat3s(py, &pose.director[n - 1..]).get_item(0)?,
        )?;
        Ok(out)
    }
}

#[pymethods]
impl MuscleDesign {
    #[new]
    #[pyo3(signature = (n_elements = 100))]
    fn new(n_elements: i64) -> PyResult<Self> {
        let n = check_count("n_elements", n_elements, 4)?;
        let (model, state) = StraightRod::coomm_arm()
            .with_elements(n)
            .build()
            .map_err(model_error)?;
        let mm = MuscleModel::new(MuscleSpec::coomm(), &model).map_err(model_error)?;
        let st = MuscleStatics::new(&model, mm, state.position[0], state.director[0]);
        Ok(Self {
            inner: Mutex::new(ctl::MuscleDesign::new(st)),
            n,
            tip0: state.position[n],
        })
    }

    /// Number of elements n.
    #[getter]
    fn n_elements(&self) -> usize {
        self.n
    }

    /// The equilibrium for `activations` (7, n) in [0, 1] (GIL released): a dict with
    /// `positions` (n + 1, 3) [m], `directors` (n, 3, 3) (rows d1, d2, d3), `tip` (the last
    /// element's midpoint [m], a list of 3), `tip_orientation` (3, 3), `newton_iterations`,
    /// `picard_iterations` and `residual` (the scaled residual ρ_R). `RuntimeError` if no
    /// equilibrium is found.
    fn equilibrium<'py>(
        &self,
        py: Python<'py>,
        activations: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let a = read_activations(activations, "activations", self.n)?;
        let rep = py
            .detach(|| lock_detached(&self.inner).statics_mut().solve(&a, None))
            .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
        let d = lock(py, &self.inner);
        let out = Self::equilibrium_dict(py, &d)?;
        out.set_item("newton_iterations", rep.newton_iterations)?;
        out.set_item("picard_iterations", rep.picard_iterations)?;
        out.set_item("residual", rep.residual)?;
        Ok(out)
    }

    /// COOMM's target frame for the tip point `target` (3,) [m] (spec §7 A): returns
    /// (orientation (3, 3), weights (3,)): d3* = unit(target − straight tip), d2* = unit(b × d3*)
    /// with b = unit(target), d1* = d2* × d3*, weights (sin θ, sin θ, sin² θ), θ = ∠(b, d3*).
    /// `rolled=True` rolls the frame by +90° about d3* (spec §7 B).
    #[pyo3(signature = (target, rolled = false))]
    fn coomm_orientation<'py>(
        &self,
        py: Python<'py>,
        target: &Bound<'py, PyAny>,
        rolled: bool,
    ) -> PyResult<(Bound<'py, numpy::PyArray3<f64>>, Vec<f64>)> {
        let p = read_vec3(target, "target")?;
        if norm(p) < 1e-9
            || norm([
                p[0] - self.tip0[0],
                p[1] - self.tip0[1],
                p[2] - self.tip0[2],
            ]) < 1e-9
        {
            return Err(PyValueError::new_err(
                "target must differ from the base and from the straight arm's tip",
            ));
        }
        let mut task = ReachTask::coomm(p, [0.0; 3], self.tip0);
        if rolled {
            task = task.rolled();
        }
        let (q, w) = task.frame.expect("COOMM's task has a frame");
        Ok((mat3s(py, &[q]), w.to_vec()))
    }

    /// Design activations reaching the tip point `target` (3,) [m] and, if `orientation`
    /// (3, 3, rows d1*, d2*, d3*, a rotation) is given, the tip frame with per-director
    /// `orientation_weights` (3,) ≥ 0 (default 1, 1, 1; COOMM's are returned by
    /// `coomm_orientation`). Weights μ_p = `position_weight` [N/m] (default 1e6) and μ_Q =
    /// `orientation_weight` [N m] (default 1e3). Starts from `initial` (7, n) in [0, 1] (default
    /// zero: COOMM's start); `groups` (7 bools) masks groups (held at zero); stops after
    /// `max_iterations` (≥ 1, default 2000) or, with `stop_when` = (tip error [m], θ_Q [rad], J),
    /// as soon as all three are met; a design that misses them restarts from deterministic
    /// group levels (Halton), up to `max_starts` starts in all (default 8, 1 = no restart) and
    /// `max_total_iterations` (default 8000) iterations over all starts (docs/muscles.md,
    /// "Multi-start"). GIL released. Returns (activations (7, n), report dict: `outcome`,
    /// `iterations`, `evaluations`, `newton_iterations` (totals over the starts), `starts`,
    /// `winner` (0: the caller's start), `cost`, `activation_cost`, `position_cost`,
    /// `orientation_cost`, `tip_error` [m], `orientation_error` [rad], `at_zero`, `at_one`,
    /// `seconds`, and the design's equilibrium as in `equilibrium`).
    #[pyo3(signature = (target, orientation = None, orientation_weights = None,
        position_weight = 1.0e6, orientation_weight = 1.0e3, initial = None, groups = None,
        max_iterations = 2000, stop_when = None, max_starts = 8, max_total_iterations = 8000))]
    #[allow(clippy::too_many_arguments)]
    fn solve<'py>(
        &self,
        py: Python<'py>,
        target: &Bound<'py, PyAny>,
        orientation: Option<&Bound<'py, PyAny>>,
        orientation_weights: Option<&Bound<'py, PyAny>>,
        position_weight: f64,
        orientation_weight: f64,
        initial: Option<&Bound<'py, PyAny>>,
        groups: Option<Vec<bool>>,
        max_iterations: i64,
        stop_when: Option<(f64, f64, f64)>,
        max_starts: i64,
        max_total_iterations: i64,
    ) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyDict>)> {
        let n = self.n;
        let p = read_vec3(target, "target")?;
        let frame = match orientation {
            None => None,
            Some(o) => {
                let q = read_orientation(o, "orientation")?;
                let w = match orientation_weights {
                    None => [1.0; 3],
                    Some(w) => read_vec3(w, "orientation_weights")?,
                };
                if let Some(v) = w.iter().find(|v| **v < 0.0) {
                    return Err(PyValueError::new_err(format!(
                        "orientation_weights entry {v} is outside the allowed range [0, inf)"
                    )));
                }
                Some((q, w))
            }
        };
        for (name, v) in [
            ("position_weight", position_weight),
            ("orientation_weight", orientation_weight),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(PyValueError::new_err(format!(
                    "{name} = {v} is outside the allowed range [0, inf)"
                )));
            }
        }
        let a0 = match initial {
            None => vec![0.0; N_GROUPS * n],
            Some(a) => read_activations(a, "initial", n)?,
        };
        let mut config = DesignConfig {
            max_iterations: check_count("max_iterations", max_iterations, 1)?,
            stop_when,
            max_starts: check_count("max_starts", max_starts, 1)?,
            max_total_iterations: check_count("max_total_iterations", max_total_iterations, 1)?,
            ..DesignConfig::default()
        };
        config.validate().map_err(|e| {
            PyValueError::new_err(format!(
                "{} = {} is outside the allowed range {}",
                e.field, e.value, e.range
            ))
        })?;
        if let Some(g) = groups {
            if g.len() != N_GROUPS {
                return Err(PyValueError::new_err(format!(
                    "groups has {} entries, expected {N_GROUPS} (one per muscle group)",
                    g.len()
                )));
            }
            config.groups.copy_from_slice(&g);
        }
        if let Some((e, t, j)) = stop_when {
            if ![e, t, j].iter().all(|v| v.is_finite() && *v >= 0.0) {
                return Err(PyValueError::new_err(
                    "stop_when = (tip error, orientation error, cost) must be finite and ≥ 0",
                ));
            }
        }
        let task = ReachTask {
            target: p,
            position_weight,
            frame,
            orientation_weight,
        };
        let (a, rep, eq) = py.detach(|| {
            let mut d = lock_detached(&self.inner);
            d.config = config;
            let (a, rep) = d.solve(&task, &a0);
            // The statics' last solution is the last trial point: put the design's in force.
            let eq = d.statics_mut().solve(&a, None);
            (a, rep, eq)
        });
        let eq = eq.map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
        let d = lock(py, &self.inner);
        let out = Self::equilibrium_dict(py, &d)?;
        out.set_item("residual", eq.residual)?;
        out.set_item("outcome", outcome_name(rep.outcome))?;
        out.set_item("iterations", rep.iterations)?;
        out.set_item("evaluations", rep.evaluations)?;
        out.set_item("newton_iterations", rep.newton_iterations)?;
        out.set_item("starts", rep.starts)?;
        out.set_item("winner", rep.winner)?;
        out.set_item("cost", rep.costs.total)?;
        out.set_item("activation_cost", rep.costs.activation)?;
        out.set_item("position_cost", rep.costs.position)?;
        out.set_item("orientation_cost", rep.costs.orientation)?;
        out.set_item("tip_error", rep.costs.tip_error)?;
        out.set_item("orientation_error", rep.costs.orientation_error)?;
        out.set_item("at_zero", rep.at_zero)?;
        out.set_item("at_one", rep.at_one)?;
        out.set_item("seconds", rep.seconds)?;
        Ok((activation_array(py, &a, n), out))
    }

    fn __repr__(&self) -> String {
        format!("MuscleDesign(n_elements={})", self.n)
    }
}

/// Hold designed `activations` (7, n) in [0, 1] on a muscular `Simulation` (from
/// `Simulation.coomm_arm`) with COOMM's ramp a(t) = min(1, t / `ramp`) a* (`ramp` [s] ≥ 0,
/// default 1), written every `period` [s] (> 0, default 2 ms = 500 Hz; rounded to whole steps)
/// — spec §6.2. `step(sim, n)` advances the simulation under it.
#[pyclass(module = "octoarm", frozen)]
pub struct MuscleShapingController {
    inner: Mutex<ctl::MuscleShapingController>,
    n: usize,
}

#[pymethods]
impl MuscleShapingController {
    #[new]
    #[pyo3(signature = (activations, ramp = 1.0, period = 0.002, target = None))]
    fn new(
        activations: &Bound<'_, PyAny>,
        ramp: f64,
        period: f64,
        target: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let (shape, _) = read_any(activations, "activations")?;
        let n = match shape[..] {
            [g, n] if g == N_GROUPS && n >= 1 => n,
            _ => {
                return Err(PyValueError::new_err(format!(
                    "activations has shape {}, expected (7, n): one row per muscle group",
                    shape_str(&shape)
                )))
            }
        };
        let a = read_activations(activations, "activations", n)?;
        let target = target.map(|t| read_vec3(t, "target")).transpose()?;
        let inner =
            ctl::MuscleShapingController::new(0, a, ramp, period, target, Vec::new(), 0.0, 0.2)
                .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(Self {
            inner: Mutex::new(inner),
            n,
        })
    }

    /// Ramp factor min(1, t / ramp) at time `t` [s].
    fn factor(&self, py: Python<'_>, t: f64) -> f64 {
        lock(py, &self.inner).factor(t)
    }

    /// The designed activations (7, n).
    #[getter]
    fn activations<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let a = lock(py, &self.inner).activations().to_vec();
        activation_array(py, &a, self.n)
    }

    /// Advance `sim` (one muscular rod of n elements) by `n` steps (GIL released): at every
    /// step whose index is a multiple of the period (in steps) the activations are rewritten
    /// as factor(t) a*, then the step; the stability guard runs at the end.
    #[pyo3(signature = (sim, n = 1))]
    fn step(&self, py: Python<'_>, sim: &Simulation, n: u64) -> PyResult<()> {
        let elements = self.n;
        let result = py.detach(|| {
            let mut ctrl = lock_detached(&self.inner);
            let mut s = sim.lock_detached();
            let s = &mut *s;
            if s.system.rods().len() != 1
                || s.system.rod(0).n_elements() != elements
                || s.system.rod(0).muscles.is_none()
            {
                return Err(None);
            }
            let every = (ctrl.period() / s.settings().dt).round().max(1.0) as u64;
            for _ in 0..n {
                if s.steps() % every == 0 {
                    let t = s.time();
                    ctrl.update(t, &s.system, &s.state, &mut s.actuation)
                        .expect("validated activations");
                }
                s.step().map_err(Some)?;
            }
            s.check().map_err(Some)
        });
        match result {
            Ok(()) => Ok(()),
            Err(None) => Err(PyValueError::new_err(format!(
                "sim must be one muscular rod of {elements} elements (Simulation.coomm_arm)"
            ))),
            Err(Some(e)) => Err(step_error(py, e)),
        }
    }
}
