//! The description of a rod system from Python: `Rod` (a straight, optionally tapered and
//! pre-curved rod with a name and its two end conditions), `Motion` (the prescribed motion of a
//! driven end) and `Joint` (a joint between two rod ends, named "rod.base" / "rod.tip"), and
//! their assembly into a physics `RodSystem` (`build_system`, used by
//! `Simulation.from_rods`). These classes only hold and check parameters; nothing is simulated
//! here.

use crate::arrays::{read_vec3, read_vec3_or, read_vec3s, read_vector, scalars, vec3s};
use crate::model_error;
use numpy::{PyArray1, PyArray2};
use octoarm_physics as phys;
use octoarm_physics::{
    Damping, EndCondition, JointEnd, JointKind, JointParams, Material, RodSpec, RodState,
    RodSystem, Settings, Side, StraightRod, SystemBuilder, SystemState, Vec3,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use std::sync::Arc;

/// Check an integer count against its minimum; the error names the argument.
pub(crate) fn check_count(field: &str, value: i64, min: i64) -> PyResult<usize> {
    if value < min {
        return Err(PyValueError::new_err(format!(
            "{field} = {value} is outside the allowed range [{min}, inf)"
        )));
    }
    Ok(value as usize)
}

/// The `dt` argument of the constructors: a time step in seconds, or `"auto"` (0.2 of the
/// system's stable limit, re-chosen until the first step; `Simulation::use_auto_dt`).
#[derive(Clone, Copy, Debug)]
pub(crate) enum TimeStep {
    /// A fixed time step [s] (checked > 0 and finite by `Settings::validate`).
    Seconds(f64),
    /// The automatic time step.
    Auto,
}

impl TimeStep {
    /// Read `dt` (None: `default` seconds). A string other than "auto", or an object that is
    /// not a real number, is refused with the allowed values.
    pub(crate) fn read(obj: Option<&Bound<'_, PyAny>>, default: f64) -> PyResult<Self> {
        let Some(obj) = obj else {
            return Ok(Self::Seconds(default));
        };
        if let Ok(word) = obj.extract::<String>() {
            return if word == "auto" {
                Ok(Self::Auto)
            } else {
                Err(PyValueError::new_err(format!(
                    "dt = {word:?} is not allowed; give a time step in seconds in (0, inf) or \"auto\""
                )))
            };
        }
        obj.extract::<f64>().map(Self::Seconds).map_err(|_| {
            let kind = obj
                .get_type()
                .name()
                .map(|n| n.to_string())
                .unwrap_or_default();
            PyTypeError::new_err(format!(
                "dt must be a time step in seconds in (0, inf) or \"auto\", not {kind}"
            ))
        })
    }

    /// The seconds to build the settings with (a placeholder for "auto", replaced by `apply`).
    pub(crate) fn initial(self) -> f64 {
        match self {
            Self::Seconds(dt) => dt,
            Self::Auto => 1.0e-5,
        }
    }

    /// Switch a built simulation to the automatic time step if asked.
    pub(crate) fn apply(self, sim: &mut phys::Simulation) -> PyResult<()> {
        if let Self::Auto = self {
            sim.use_auto_dt().map_err(model_error)?;
        }
        Ok(())
    }
}

/// An end condition from Python: "free", "pinned", "clamped" or a `Motion` (a driven clamped
/// end). `field` ("base" or "tip") names the argument in errors.
pub(crate) fn end_condition(field: &str, obj: &Bound<'_, PyAny>) -> PyResult<EndCondition> {
    if let Ok(m) = obj.cast::<Motion>() {
        return Ok(EndCondition::Driven(m.get().inner.clone()));
    }
    let Ok(s) = obj.extract::<String>() else {
        return Err(PyTypeError::new_err(format!(
            "{field} must be \"free\", \"pinned\", \"clamped\" or a Motion, not {}",
            obj.get_type().name()?
        )));
    };
    match s.as_str() {
        "free" => Ok(EndCondition::Free),
        "pinned" => Ok(EndCondition::Pinned),
        "clamped" => Ok(EndCondition::Clamped),
        other => Err(PyValueError::new_err(format!(
            "{field} = {other:?} is not allowed; use \"free\", \"pinned\", \"clamped\" or a \
             Motion (a driven end)"
        ))),
    }
}

/// An end condition for Python: its name, or the `Motion` of a driven end.
pub(crate) fn end_condition_object(py: Python<'_>, c: &EndCondition) -> PyResult<Py<PyAny>> {
    Ok(match c {
        EndCondition::Driven(m) => Py::new(py, Motion { inner: m.clone() })?.into_any(),
        other => other.name().into_pyobject(py)?.into_any().unbind(),
    })
}

/// The prescribed motion of a driven (clamped, moving) rod end, relative to the end's pose at
/// the start: at each of `times` [s] (from 0, strictly increasing, at least two) the end node has
/// moved by `displacement` [m] (k, 3) and the end frame has turned by the rotation vector
/// `rotation` [rad] (k, 3; axis × angle, lab frame, about the end node); both are linear in
/// time between samples and held after the last. Omitted arrays are zero; both must be zero at
/// t = 0. With `slides_along` (a direction) the end node is not held along it but slides under
/// the loads on it.
#[pyclass(module = "octoarm", frozen)]
#[derive(Clone)]
pub struct Motion {
    pub(crate) inner: phys::Motion,
}

#[pymethods]
impl Motion {
    #[new]
    #[pyo3(signature = (times, displacement = None, rotation = None, slides_along = None))]
    fn new(
        times: &Bound<'_, PyAny>,
        displacement: Option<&Bound<'_, PyAny>>,
        rotation: Option<&Bound<'_, PyAny>>,
        slides_along: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let times = read_vector(times, "times")?;
        let k = times.len();
        let read = |a: Option<&Bound<'_, PyAny>>, field: &str| match a {
            Some(a) => read_vec3s(a, field, k),
            None => Ok(vec![[0.0; 3]; k]),
        };
        let inner = phys::Motion {
            displacement: read(displacement, "displacement")?,
            rotation: read(rotation, "rotation")?,
            times,
            slides_along: slides_along
                .map(|a| read_vec3(a, "slides_along"))
                .transpose()?,
        };
        inner.validate().map_err(model_error)?;
        Ok(Self { inner })
    }

    /// A motion turning the end at the constant angular velocity `rate` [rad/s] (lab frame)
    /// from t = 0 until `until` [s], then holding it.
    #[staticmethod]
    fn constant_rotation(rate: &Bound<'_, PyAny>, until: f64) -> PyResult<Self> {
        let rate = read_vec3(rate, "rate")?;
        let inner = phys::Motion::constant_rotation(rate, until);
        inner.validate().map_err(model_error)?;
        Ok(Self { inner })
    }

    /// Sample times [s], (k,).
    #[getter]
    fn times<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        scalars(py, &self.inner.times)
    }

    /// Displacement of the end node at each time [m], (k, 3), lab frame.
    #[getter]
    fn displacement<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        vec3s(py, &self.inner.displacement)
    }

    /// Rotation vector of the end frame at each time [rad], (k, 3), lab frame.
    #[getter]
    fn rotation<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        vec3s(py, &self.inner.rotation)
    }

    /// (displacement [m], rotation vector [rad]) at time `t` [s], each (3,).
    fn at<'py>(
        &self,
        py: Python<'py>,
        t: f64,
    ) -> (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>) {
        let (d, r) = self.inner.at(t);
        (scalars(py, &d), scalars(py, &r))
    }

    fn __repr__(&self) -> String {
        format!(
            "Motion({} samples, t = 0 .. {} s)",
            self.inner.times.len(),
            self.inner.times.last().copied().unwrap_or(0.0)
        )
    }
}

/// One rod of a system: a straight rod with a uniform or linearly tapered circular section
/// (optionally with a uniform rest curvature), its name (unique in a system) and its two end
/// conditions, each "free", "pinned" (node held, free to turn), "clamped" (node and frame held)
/// or a `Motion` (a driven clamped end). The defaults are the paper's arm: 100 elements,
/// L = 0.2 m, diameter 2 cm → 0.04 cm, ρ = 700 kg/m³, E = 10 kPa, G = 1 kPa, along +x with
/// d1 = e_y from the origin, base clamped, tip free. SI units. `positions` (n + 1, 3) and
/// `directors` (n, 3, 3; rows d1, d2, d3, orthonormal) optionally give the initial shape
/// instead of the straight one (the rest shape stays straight or pre-curved, with rest lengths
/// L / n); held ends are held where this shape puts them.
#[pyclass(module = "octoarm", frozen)]
#[derive(Clone)]
pub struct Rod {
    /// Name of the rod (unique in a system; joints and `rod=` arguments use it).
    #[pyo3(get)]
    name: String,
    geometry: StraightRod,
    base: EndCondition,
    tip: EndCondition,
    positions: Option<Vec<Vec3>>,
    directors: Option<Vec<phys::Mat3>>,
}

impl Rod {
    /// The physics rod: its model, initial state and end conditions.
    fn spec(&self) -> PyResult<RodSpec> {
        let (model, mut state) = self.geometry.build().map_err(model_error)?;
        if let Some(p) = &self.positions {
            state.position.clone_from(p);
        }
        if let Some(q) = &self.directors {
            state.director.clone_from(q);
        }
        Ok(RodSpec {
            name: self.name.clone(),
            model: Arc::new(model),
            state,
            base: self.base.clone(),
            tip: self.tip.clone(),
            damping: Damping::default(),
        })
    }
}

#[pymethods]
impl Rod {
    #[new]
    #[pyo3(signature = (
        name = "rod", n_elements = 100, length = 0.2, base_diameter = 0.02,
        tip_diameter = 0.0004, density = 700.0, youngs_modulus = 1.0e4, shear_modulus = 1.0e3,
        shear_coefficient = Material::DEFAULT_SHEAR_COEFFICIENT,
        base_position = None, direction = None, normal = None, rest_curvature = None, base = None, tip = None,
        positions = None, directors = None
    ))]
    #[pyo3(
        text_signature = "(name='rod', n_elements=100, length=0.2, base_diameter=0.02, \
        tip_diameter=0.0004, density=700.0, youngs_modulus=10000.0, shear_modulus=1000.0, \
        shear_coefficient=0.9642857142857143, base_position=(0.0, 0.0, 0.0), \
        direction=(1.0, 0.0, 0.0), normal=(0.0, 1.0, 0.0), rest_curvature=(0.0, 0.0, 0.0), \
        base='clamped', tip='free', positions=None, directors=None)"
    )]
    #[allow(clippy::too_many_arguments)]
    fn new(
        name: &str,
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
        base: Option<&Bound<'_, PyAny>>,
        tip: Option<&Bound<'_, PyAny>>,
        positions: Option<&Bound<'_, PyAny>>,
        directors: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let base_position = read_vec3_or(base_position, "base_position", [0.0; 3])?;
        let direction = read_vec3_or(direction, "direction", [1.0, 0.0, 0.0])?;
        let normal = read_vec3_or(normal, "normal", [0.0, 1.0, 0.0])?;
        let rest_curvature = read_vec3_or(rest_curvature, "rest_curvature", [0.0; 3])?;
        let n_el = check_count("n_elements", n_elements, 2)?;
        let positions = positions
            .map(|a| read_vec3s(a, "positions", n_el + 1))
            .transpose()?;
        let directors = directors
            .map(|a| crate::arrays::read_mat3s(a, "directors", n_el))
            .transpose()?;
        if name.is_empty() {
            return Err(PyValueError::new_err(
                "name = \"\" is not allowed: a rod needs a name",
            ));
        }
        let geometry = StraightRod {
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
        // Check the geometry now, so that a bad rod is reported where it is written.
        geometry.build().map_err(model_error)?;
        let base = base
            .map(|b| end_condition("base", b))
            .transpose()?
            .unwrap_or(EndCondition::Clamped);
        let tip = tip
            .map(|t| end_condition("tip", t))
            .transpose()?
            .unwrap_or(EndCondition::Free);
        let rod = Self {
            name: name.to_string(),
            geometry,
            base,
            tip,
            positions,
            directors,
        };
        // An initial shape is checked now too (finite, orthonormal frames).
        if rod.positions.is_some() || rod.directors.is_some() {
            let spec = rod.spec()?;
            let mut b = SystemBuilder::new(Settings::default());
            b.rod(spec);
            b.build().map_err(model_error)?;
        }
        Ok(rod)
    }

    /// Number of elements n.
    #[getter]
    fn n_elements(&self) -> usize {
        self.geometry.n_elements
    }

    /// Rest length L [m].
    #[getter]
    fn length(&self) -> f64 {
        self.geometry.length
    }

    /// Diameter at the base [m].
    #[getter]
    fn base_diameter(&self) -> f64 {
        self.geometry.base_diameter
    }

    /// Diameter at the tip [m].
    #[getter]
    fn tip_diameter(&self) -> f64 {
        self.geometry.tip_diameter
    }

    /// Density ρ [kg/m³].
    #[getter]
    fn density(&self) -> f64 {
        self.geometry.material.density
    }

    /// Young's modulus E [Pa].
    #[getter]
    fn youngs_modulus(&self) -> f64 {
        self.geometry.material.youngs_modulus
    }

    /// Shear modulus G [Pa].
    #[getter]
    fn shear_modulus(&self) -> f64 {
        self.geometry.material.shear_modulus
    }

    /// Shear coefficient α_c.
    #[getter]
    fn shear_coefficient(&self) -> f64 {
        self.geometry.material.shear_coefficient
    }

    /// Position of node 0 [m].
    #[getter]
    fn base_position(&self) -> Vec3 {
        self.geometry.base_position
    }

    /// Tangent d3 at rest.
    #[getter]
    fn direction(&self) -> Vec3 {
        self.geometry.direction
    }

    /// d1 at rest.
    #[getter]
    fn normal(&self) -> Vec3 {
        self.geometry.normal
    }

    /// Uniform rest curvature κ° [1/m], material frame.
    #[getter]
    fn rest_curvature(&self) -> Vec3 {
        self.geometry.rest_curvature
    }

    /// Base end condition: "free", "pinned", "clamped" or its `Motion`.
    #[getter]
    fn base(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        end_condition_object(py, &self.base)
    }

    /// Tip end condition: "free", "pinned", "clamped" or its `Motion`.
    #[getter]
    fn tip(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        end_condition_object(py, &self.tip)
    }

    fn __repr__(&self) -> String {
        format!(
            "Rod({:?}, n_elements={}, length={}, base={:?}, tip={:?})",
            self.name,
            self.geometry.n_elements,
            self.geometry.length,
            self.base.name(),
            self.tip.name()
        )
    }
}

/// Parse a joint end "rodname.base" / "rodname.tip".
fn joint_end(field: &str, s: &str) -> PyResult<(String, Side)> {
    let bad = || {
        PyValueError::new_err(format!(
            "{field} = {s:?} is not allowed; use \"<rod name>.base\" or \"<rod name>.tip\""
        ))
    };
    let (rod, side) = s.rsplit_once('.').ok_or_else(bad)?;
    let side = match side {
        "base" => Side::Base,
        "tip" => Side::Tip,
        _ => return Err(bad()),
    };
    if rod.is_empty() {
        return Err(bad());
    }
    Ok((rod.to_string(), side))
}

/// A joint between two rod ends, each "rodname.base" or "rodname.tip". `kind` is "free"
/// (positions only: a ball joint), "hinge" (positions and every relative rotation except about
/// `axis`, a lab-frame vector at t = 0 that turns with the first end) or "fixed" (positions and
/// orientation held at their initial relative values). Penalty spring and damper constants:
/// `stiffness` [N/m], `damping` [N s/m], `rotational_stiffness` [N m/rad], `rotational_damping`
/// [N m s/rad]; each omitted one takes the default of the two rods' end elements
/// (`JointParams::default_for`: the softer end's axial stiffness, the ends' bend stiffness over
/// their mean length, no damping).
#[pyclass(module = "octoarm", frozen)]
#[derive(Clone)]
pub struct Joint {
    /// "free", "hinge" or "fixed".
    #[pyo3(get)]
    kind: String,
    /// The first end, e.g. "arm.tip".
    #[pyo3(get)]
    first: String,
    /// The second end, e.g. "hand.base".
    #[pyo3(get)]
    second: String,
    /// Hinge axis (lab frame at t = 0), None unless kind = "hinge".
    #[pyo3(get)]
    axis: Option<Vec3>,
    /// Translational stiffness [N/m], None for the default.
    #[pyo3(get)]
    stiffness: Option<f64>,
    /// Translational damping [N s/m], None for the default.
    #[pyo3(get)]
    damping: Option<f64>,
    /// Rotational stiffness [N m/rad], None for the default.
    #[pyo3(get)]
    rotational_stiffness: Option<f64>,
    /// Rotational damping [N m s/rad], None for the default.
    #[pyo3(get)]
    rotational_damping: Option<f64>,
    ends: [(String, Side); 2],
}

#[pymethods]
impl Joint {
    #[new]
    #[pyo3(signature = (kind, first, second, axis = None, stiffness = None, damping = None,
        rotational_stiffness = None, rotational_damping = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        kind: &str,
        first: &str,
        second: &str,
        axis: Option<&Bound<'_, PyAny>>,
        stiffness: Option<f64>,
        damping: Option<f64>,
        rotational_stiffness: Option<f64>,
        rotational_damping: Option<f64>,
    ) -> PyResult<Self> {
        let axis = axis.map(|a| read_vec3(a, "axis")).transpose()?;
        match (kind, axis) {
            ("hinge", None) => {
                return Err(PyValueError::new_err(
                    "axis is required for kind = \"hinge\" (the hinge axis, lab frame at t = 0)",
                ))
            }
            ("hinge", Some(a)) => {
                let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
                if !(l.is_finite() && l > 0.0) {
                    return Err(PyValueError::new_err(format!(
                        "axis = {a:?} is invalid: it must be finite and non-zero"
                    )));
                }
            }
            ("free" | "fixed", Some(_)) => {
                return Err(PyValueError::new_err(format!(
                    "axis is only for kind = \"hinge\", not kind = {kind:?}"
                )))
            }
            ("free" | "fixed", None) => {}
            (other, _) => {
                return Err(PyValueError::new_err(format!(
                    "kind = {other:?} is not allowed; use \"free\", \"hinge\" or \"fixed\""
                )))
            }
        }
        for (field, v) in [
            ("stiffness", stiffness),
            ("damping", damping),
            ("rotational_stiffness", rotational_stiffness),
            ("rotational_damping", rotational_damping),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && v >= 0.0) {
                    return Err(PyValueError::new_err(format!(
                        "{field} = {v} is outside the allowed range [0, inf), finite"
                    )));
                }
            }
        }
        let ends = [joint_end("first", first)?, joint_end("second", second)?];
        if ends[0] == ends[1] {
            return Err(PyValueError::new_err(format!(
                "first = second = {first:?}: a joint joins two different rod ends"
            )));
        }
        Ok(Self {
            kind: kind.to_string(),
            first: first.to_string(),
            second: second.to_string(),
            axis,
            stiffness,
            damping,
            rotational_stiffness,
            rotational_damping,
            ends,
        })
    }

    fn __repr__(&self) -> String {
        format!(
            "Joint({:?}, {:?}, {:?})",
            self.kind, self.first, self.second
        )
    }
}

/// Names of rods for messages: "\"arm\", \"hand\"".
pub(crate) fn quoted(names: &[&str]) -> String {
    names
        .iter()
        .map(|n| format!("{n:?}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Assemble rods and joints into a rod system and its initial state (t = 0), with numerical
/// settings `settings`. Errors (`ValueError`) name the bad rod, joint end or parameter.
pub(crate) fn build_system(
    rods: &[Rod],
    joints: &[Joint],
    settings: Settings,
) -> PyResult<(RodSystem, SystemState)> {
    let mut b = SystemBuilder::new(settings);
    let mut specs: Vec<RodSpec> = Vec::with_capacity(rods.len());
    for r in rods {
        specs.push(r.spec()?);
    }
    let names: Vec<&str> = rods.iter().map(|r| r.name.as_str()).collect();
    let mut built = Vec::with_capacity(joints.len());
    for j in joints {
        let mut ends = [JointEnd {
            rod: 0,
            side: Side::Base,
        }; 2];
        for (k, ((name, side), field)) in j.ends.iter().zip(["first", "second"]).enumerate() {
            let rod = names.iter().position(|n| n == name).ok_or_else(|| {
                PyValueError::new_err(format!(
                    "joint {field} = {:?}: there is no rod called {name:?}; the rods are {}",
                    if k == 0 { &j.first } else { &j.second },
                    quoted(&names)
                ))
            })?;
            ends[k] = JointEnd { rod, side: *side };
        }
        let m = |e: JointEnd| (specs[e.rod].model.as_ref(), e.side);
        let mut params = JointParams::default_for(m(ends[0]), m(ends[1]));
        params.stiffness = j.stiffness.unwrap_or(params.stiffness);
        params.damping = j.damping.unwrap_or(params.damping);
        params.rotational_stiffness = j
            .rotational_stiffness
            .unwrap_or(params.rotational_stiffness);
        params.rotational_damping = j.rotational_damping.unwrap_or(params.rotational_damping);
        let kind = match (j.kind.as_str(), j.axis) {
            ("hinge", Some(axis)) => JointKind::Hinge { axis },
            ("fixed", _) => JointKind::Fixed,
            _ => JointKind::Free,
        };
        built.push(phys::Joint::new(kind, ends[0], ends[1], params));
    }
    for spec in specs {
        b.rod(spec);
    }
    for j in built {
        b.joint(j);
    }
    b.build().map_err(model_error)
}

/// One rod (`rod`, its initial state `state`) with the given ends, as a one-rod system named
/// "rod" (what `Simulation(...)` builds).
pub(crate) fn single_rod(
    rod: &StraightRod,
    base: EndCondition,
    tip: EndCondition,
    settings: Settings,
) -> PyResult<phys::Simulation> {
    let (model, state): (phys::RodModel, RodState) = rod.build().map_err(model_error)?;
    phys::Simulation::with_ends(model, state, base, tip, settings).map_err(model_error)
}
