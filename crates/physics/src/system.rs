//! A rod system: many rods in one store, each with a (shared) model, its two end conditions and
//! damping, plus joints between rod ends, external loads with schedules, rigid obstacles, the
//! rest strains in force and the numerical settings. `SystemBuilder` assembles rods and their
//! initial states into a `RodSystem` and its `SystemState`; the stepper (`step.rs`) reads the
//! system and never changes it.

use crate::contact::{contact_frequency, ContactParams, Cylinder, Obstacles, Plane, Sphere};
use crate::damping::Damping;
use crate::ends::{End, EndCondition, Side};
use crate::error::{finite_vec, positive, ModelError};
use crate::internal::Offsets;
use crate::joints::Joint;
use crate::loads::{AppliedLoad, Load};
use crate::math::{orthonormality_defect, Mat3, Vec3};
use crate::model::RodModel;
use crate::schedule::Schedule;
use crate::state::{RodAccess, RodState, RodView, SystemState};
use std::sync::Arc;

/// Numerical settings of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Settings {
    /// Time step Δt [s], > 0. The paper uses 1e-5 s. The only copy of dt.
    pub dt: f64,
    /// Add the energy-consistent tension corrections of eq. 4.5 (default off).
    pub energy_consistent: bool,
    /// Steps between stability-guard checks (default 100).
    pub guard_interval: u64,
    /// Steps between orthonormality checks of the frames (default 1000).
    pub orthonormality_interval: u64,
    /// Order of the clamped (and driven) end formulation: 1 (default) holds the end element's
    /// frame rigid, as PyElastica (first-order accurate in the element length); 2 holds only
    /// the end node and joins the end element to the clamp frame by a half-Voronoi bending
    /// spring (a ghost element at the clamp; second order). See docs/physics.md.
    #[cfg_attr(feature = "serde", serde(default = "default_clamp_order"))]
    pub clamp_order: u8,
    /// Largest allowed dt / stable limit of the *current, deformed* state
    /// (`RodSystem::stable_dt_at`), re-checked by the guard every `guard_interval` steps;
    /// `None` (default): not checked. The automatic time step sets `AUTO_DT_RECHECK`.
    #[cfg_attr(feature = "serde", serde(default))]
    pub max_dt_fraction: Option<f64>,
}

/// Fraction of the stable limit 2/ω̂_max that the automatic time step uses: the spec's
/// recommended operating point (§11). At ω̂_max Δt = 0.4 the fastest (tip shear–rotation)
/// mode keeps its frequency to (ωΔt)²/24 ≈ 0.7 % and position Verlet stays 5× inside its
/// stability bound; the same fraction is what the guard suggests after an instability.
pub const AUTO_DT_FRACTION: f64 = 0.2;

/// The guard's re-check of an automatic time step: dt must stay ≤ this fraction of the stable
/// limit re-estimated at the deformed state (a factor 2 inside ω̂_max Δt < 2; deformation may
/// raise ω̂_max by 2.5× before it fires).
pub const AUTO_DT_RECHECK: f64 = 0.5;

/// The automatic time step for a system whose stable limit is `stable_dt` and whose sampling
/// interval is `interval` (recording, control): the largest dt ≤ `AUTO_DT_FRACTION ·
/// stable_dt` that divides `interval` into a whole number of steps, so that samples fall on
/// steps exactly. Returns `None` when either input is not finite and positive.
pub fn auto_dt(stable_dt: f64, interval: f64) -> Option<f64> {
    let target = AUTO_DT_FRACTION * stable_dt;
    if !(target.is_finite() && target > 0.0 && interval.is_finite() && interval > 0.0) {
        return None;
    }
    let steps = (interval / target).ceil().max(1.0);
    let dt = interval / steps;
    // Rounding may leave interval / steps a hair above the target: one more step then.
    Some(if dt > target {
        interval / (steps + 1.0)
    } else {
        dt
    })
}

fn default_clamp_order() -> u8 {
    1
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            dt: 1.0e-5,
            energy_consistent: false,
            guard_interval: 100,
            orthonormality_interval: 1000,
            clamp_order: default_clamp_order(),
            max_dt_fraction: None,
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
        if !(1..=2).contains(&self.clamp_order) {
            return Err(ModelError::CountOutOfRange {
                field: "clamp_order",
                value: usize::from(self.clamp_order),
                range: "{1, 2}",
            });
        }
        if self.orthonormality_interval == 0 {
            return Err(ModelError::CountOutOfRange {
                field: "orthonormality_interval",
                value: 0,
                range: "[1, inf)",
            });
        }
        if let Some(f) = self.max_dt_fraction {
            if !(f > 0.0 && f <= 1.0) {
                return Err(ModelError::OutOfRange {
                    field: "max_dt_fraction",
                    value: f,
                    range: "(0, 1]",
                });
            }
        }
        Ok(())
    }
}

/// One rod of a system.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Rod {
    /// Name (unique in the system; used in output keys and messages).
    pub name: String,
    /// Geometry and material, shared with every other rod built from the same model.
    pub model: Arc<RodModel>,
    /// The base (node 0, element 0) and how it is held.
    pub base: End,
    /// The tip (node n, element n − 1) and how it is held.
    pub tip: End,
    /// Damping of this rod.
    pub damping: Damping,
    /// Muscles of this rod (spec muscles-3d §1–2), driven by the actuation's activations.
    pub muscles: Option<Arc<crate::muscles::MuscleModel>>,
    pub(crate) at: Offsets,
}

impl Rod {
    /// Number of elements n.
    pub fn n_elements(&self) -> usize {
        self.model.n_elements
    }

    /// Where this rod's nodes, elements and interior points start in the system's arrays.
    pub fn offsets(&self) -> Offsets {
        self.at
    }

    /// This rod's nodes in the system's node order.
    pub fn nodes(&self) -> std::ops::Range<usize> {
        self.at.node..self.at.node + self.model.n_elements + 1
    }

    /// This rod's elements in the system's element order.
    pub fn elements(&self) -> std::ops::Range<usize> {
        self.at.element..self.at.element + self.model.n_elements
    }

    /// This rod's interior points in the system's interior order.
    pub fn interior(&self) -> std::ops::Range<usize> {
        self.at.interior..self.at.interior + self.model.n_elements - 1
    }

    /// The end on `side`.
    pub fn end(&self, side: Side) -> &End {
        match side {
            Side::Base => &self.base,
            Side::Tip => &self.tip,
        }
    }
}

/// A scheduled change of one rod's rest strains: the rest strains in force at time t are the
/// system's `rest_sigma` / `rest_kappa` plus f(t) times these.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct RestChange {
    /// Index of the rod.
    pub rod: usize,
    /// Change of σ° per element (n entries), or empty for none.
    pub sigma: Vec<Vec3>,
    /// Change of κ° [1/m] per interior point (n − 1 entries), or empty for none.
    pub kappa: Vec<Vec3>,
    /// Time factor f(t).
    pub schedule: Schedule,
}

/// Everything about a system that the stepper reads: rods, joints, loads, obstacles, contact
/// parameters, the rest strains in force, and the settings. Build it with `SystemBuilder`.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct RodSystem {
    /// Numerical settings (change through `set_settings`, which validates).
    pub(crate) settings: Settings,
    pub(crate) rods: Vec<Rod>,
    pub(crate) joints: Vec<Joint>,
    pub(crate) loads: Vec<AppliedLoad>,
    pub(crate) obstacles: Vec<Sphere>,
    #[cfg_attr(feature = "serde", serde(default))]
    pub(crate) planes: Vec<Plane>,
    #[cfg_attr(feature = "serde", serde(default))]
    pub(crate) cylinders: Vec<Cylinder>,
    pub(crate) contact: ContactParams,
    /// Rest shear/stretch strains in force σ° (material), per element of the system. Controllers
    /// and users may change them between steps (entries must stay finite).
    pub rest_sigma: Vec<Vec3>,
    /// Rest curvatures in force κ° [1/m] (material), per interior point of the system.
    pub rest_kappa: Vec<Vec3>,
    pub(crate) rest_changes: Vec<RestChange>,
    pub(crate) n_nodes: usize,
    pub(crate) n_elements: usize,
    pub(crate) n_interior: usize,
}

impl RodSystem {
    /// The numerical settings.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// Replace the numerical settings.
    pub fn set_settings(&mut self, settings: Settings) -> Result<(), ModelError> {
        settings.validate()?;
        self.settings = settings;
        Ok(())
    }

    /// The rods, in system order.
    pub fn rods(&self) -> &[Rod] {
        &self.rods
    }

    /// Rod `r`.
    pub fn rod(&self, r: usize) -> &Rod {
        &self.rods[r]
    }

    /// Index of the rod called `name`.
    pub fn rod_index(&self, name: &str) -> Option<usize> {
        self.rods.iter().position(|r| r.name == name)
    }

    /// The joints.
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    /// The loads with their rods and schedules.
    pub fn loads(&self) -> &[AppliedLoad] {
        &self.loads
    }

    /// The rigid obstacles (every rod touches every obstacle).
    pub fn obstacles(&self) -> &[Sphere] {
        &self.obstacles
    }

    /// The rigid planes.
    pub fn planes(&self) -> &[Plane] {
        &self.planes
    }

    /// The rigid cylinders.
    pub fn cylinders(&self) -> &[Cylinder] {
        &self.cylinders
    }

    /// Every obstacle, borrowed.
    pub fn obstacle_set(&self) -> Obstacles<'_> {
        Obstacles {
            spheres: &self.obstacles,
            planes: &self.planes,
            cylinders: &self.cylinders,
        }
    }

    /// Number of stick springs the frictional obstacles need (`SystemState::stick`).
    pub fn stick_slots(&self) -> usize {
        crate::contact::stick_slots(self.obstacle_set(), self.n_elements)
    }

    /// Size `state.stick` for the obstacles now present: all springs zero (relaxed) if their
    /// number changed (an obstacle was added), untouched otherwise. Allocates only then.
    pub fn fit_stick(&self, state: &mut SystemState) {
        let slots = self.stick_slots();
        if state.stick.len() != slots {
            state.stick.clear();
            state.stick.resize(slots, [0.0; 3]);
        }
    }

    /// Contact penalty parameters.
    pub fn contact(&self) -> &ContactParams {
        &self.contact
    }

    /// Scheduled rest-strain changes.
    pub fn rest_changes(&self) -> &[RestChange] {
        &self.rest_changes
    }

    /// Total number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.n_nodes
    }

    /// Total number of elements.
    pub fn n_elements(&self) -> usize {
        self.n_elements
    }

    /// Total number of interior points.
    pub fn n_interior(&self) -> usize {
        self.n_interior
    }

    /// Add a load on rod `rod` with a schedule, after checking both.
    pub fn add_load(
        &mut self,
        rod: usize,
        load: Load,
        schedule: Schedule,
    ) -> Result<(), ModelError> {
        let r = self.rods.get(rod).ok_or(ModelError::CountOutOfRange {
            field: "load.rod",
            value: rod,
            range: "[0, number of rods - 1]",
        })?;
        load.validate(&r.model)?;
        schedule.validate()?;
        self.loads.push(AppliedLoad {
            rod,
            load,
            schedule,
        });
        Ok(())
    }

    /// Remove every load.
    pub fn clear_loads(&mut self) {
        self.loads.clear();
    }

    /// Add a rigid sphere obstacle.
    pub fn add_obstacle(&mut self, sphere: Sphere) -> Result<(), ModelError> {
        sphere.validate()?;
        self.obstacles.push(sphere);
        Ok(())
    }

    /// Add a rigid plane (its normal is normalised).
    pub fn add_plane(&mut self, mut plane: Plane) -> Result<(), ModelError> {
        plane.validate()?;
        self.planes.push(plane);
        Ok(())
    }

    /// Add a rigid finite cylinder (its axis is normalised).
    pub fn add_cylinder(&mut self, mut cylinder: Cylinder) -> Result<(), ModelError> {
        cylinder.validate()?;
        self.cylinders.push(cylinder);
        Ok(())
    }

    /// Remove every obstacle (spheres, planes, cylinders).
    pub fn clear_obstacles(&mut self) {
        self.obstacles.clear();
        self.planes.clear();
        self.cylinders.clear();
    }

    /// Set the contact penalty parameters.
    pub fn set_contact(&mut self, contact: ContactParams) -> Result<(), ModelError> {
        contact.validate()?;
        self.contact = contact;
        Ok(())
    }

    /// Set the damping of rod `rod`.
    pub fn set_damping(&mut self, rod: usize, damping: Damping) -> Result<(), ModelError> {
        damping.validate()?;
        self.rods[rod].damping = damping;
        Ok(())
    }

    /// Give rod `rod` muscles (or remove them with `None`). Errors if the muscle model was
    /// built for another number of elements.
    pub fn set_muscles(
        &mut self,
        rod: usize,
        muscles: Option<crate::muscles::MuscleModel>,
    ) -> Result<(), ModelError> {
        let r = self.rods.get_mut(rod).ok_or(ModelError::CountOutOfRange {
            field: "muscles.rod",
            value: rod,
            range: "[0, number of rods - 1]",
        })?;
        if let Some(m) = &muscles {
            if m.n_elements() != r.n_elements() {
                return Err(ModelError::BadLength {
                    field: "muscles (elements of the model it was built for)",
                    len: m.n_elements(),
                    expected: r.n_elements(),
                });
            }
        }
        r.muscles = muscles.map(Arc::new);
        Ok(())
    }

    /// Set the damping of every rod.
    pub fn set_damping_all(&mut self, damping: Damping) -> Result<(), ModelError> {
        damping.validate()?;
        for r in &mut self.rods {
            r.damping = damping;
        }
        Ok(())
    }

    /// Replace rod `rod`'s rest strains in force (σ° per element, κ° per interior point).
    /// Errors on wrong lengths or non-finite entries, leaving the system unchanged.
    pub fn set_rest_strains(
        &mut self,
        rod: usize,
        sigma: &[Vec3],
        kappa: &[Vec3],
    ) -> Result<(), ModelError> {
        let r = &self.rods[rod];
        let n = r.n_elements();
        check_rest(sigma, kappa, n)?;
        let (e, k) = (r.elements(), r.interior());
        self.rest_sigma[e].copy_from_slice(sigma);
        self.rest_kappa[k].copy_from_slice(kappa);
        Ok(())
    }

    /// Rod `rod`'s rest strains in force (σ°, κ°), without scheduled changes.
    pub fn rest_strains(&self, rod: usize) -> (&[Vec3], &[Vec3]) {
        let r = &self.rods[rod];
        (
            &self.rest_sigma[r.elements()],
            &self.rest_kappa[r.interior()],
        )
    }

    /// Add a scheduled rest-strain change (see `RestChange`).
    pub fn add_rest_change(&mut self, change: RestChange) -> Result<(), ModelError> {
        let r = self
            .rods
            .get(change.rod)
            .ok_or(ModelError::CountOutOfRange {
                field: "rest_change.rod",
                value: change.rod,
                range: "[0, number of rods - 1]",
            })?;
        let n = r.n_elements();
        if !change.sigma.is_empty() && change.sigma.len() != n {
            return Err(ModelError::BadLength {
                field: "rest_change.sigma",
                len: change.sigma.len(),
                expected: n,
            });
        }
        if !change.kappa.is_empty() && change.kappa.len() != n - 1 {
            return Err(ModelError::BadLength {
                field: "rest_change.kappa",
                len: change.kappa.len(),
                expected: n - 1,
            });
        }
        for v in change.sigma.iter().chain(&change.kappa) {
            finite_vec("rest_change", *v)?;
        }
        change.schedule.validate()?;
        self.rest_changes.push(change);
        Ok(())
    }

    /// The rest strains in force at time t for the whole system, written into `sigma` and
    /// `kappa` (system-sized): `rest_sigma` / `rest_kappa` plus the scheduled changes.
    pub fn rest_at(&self, t: f64, sigma: &mut [Vec3], kappa: &mut [Vec3]) {
        sigma.copy_from_slice(&self.rest_sigma);
        kappa.copy_from_slice(&self.rest_kappa);
        for ch in &self.rest_changes {
            let f = ch.schedule.factor(t);
            let r = &self.rods[ch.rod];
            for (dst, d) in sigma[r.elements()].iter_mut().zip(&ch.sigma) {
                for c in 0..3 {
                    dst[c] += f * d[c];
                }
            }
            for (dst, d) in kappa[r.interior()].iter_mut().zip(&ch.kappa) {
                for c in 0..3 {
                    dst[c] += f * d[c];
                }
            }
        }
    }

    /// Borrow rod `rod` of `state`.
    pub fn view<'a>(&self, state: &'a SystemState, rod: usize) -> RodView<'a> {
        let r = &self.rods[rod];
        state.view(r.at.node, r.at.element, r.n_elements())
    }

    /// Copy of rod `rod`'s state (allocates).
    pub fn rod_state(&self, state: &SystemState, rod: usize) -> RodState {
        let r = &self.rods[rod];
        state.rod_state(r.at.node, r.at.element, r.n_elements())
    }

    /// Overwrite rod `rod`'s positions, velocities, frames and angular velocities in `state`
    /// (e.g. an initial perturbation). Errors on a wrong size or non-finite / non-orthonormal
    /// input; held ends keep their held pose (it is re-applied at the next step).
    pub fn set_rod_state(
        &self,
        state: &mut SystemState,
        rod: usize,
        s: &RodState,
    ) -> Result<(), ModelError> {
        let r = &self.rods[rod];
        check_state(&r.model, s)?;
        state.write_rod(r.at.node, r.at.element, s);
        Ok(())
    }

    /// Largest natural frequency estimate of the system [rad/s]: the rods' (spec §11) and each
    /// joint's spring on the two end masses and inertias.
    pub fn max_frequency(&self) -> f64 {
        let w: f64 = self
            .rods
            .iter()
            .map(|r| r.model.max_frequency())
            .fold(0.0, f64::max);
        w.max(self.other_max_frequency())
    }

    /// `max_frequency` re-estimated at the deformed `state` [rad/s]: per element j, the axial
    /// and bending zig-zag term 4E/(ρ l̂²) scaled by the stiffening of the current strains,
    /// max(1/e_j², 1/ε³ of its Voronoi points) (the force n/e and the couple τ/ε³ of spec §3),
    /// and the shear–rotation term 4πα_cG/(ρÂ) scaled by max(1, e_j²) (the shear couple's
    /// lever arm e l̂). Equal to `max_frequency` at rest; joints and contact as there.
    pub fn max_frequency_at(&self, state: &SystemState) -> f64 {
        self.fastest_element_at(state)
            .0
            .max(self.other_max_frequency())
    }

    /// The part of `max_frequency` that does not depend on the state: joints and contact.
    pub(crate) fn other_max_frequency(&self) -> f64 {
        self.joint_frequency().max(self.contact_max_frequency())
    }

    /// The rods' part of `max_frequency_at`: (ω̂ [rad/s], rod, element where it is largest).
    pub(crate) fn fastest_element_at(&self, state: &SystemState) -> (f64, usize, usize) {
        let (mut w2, mut at): (f64, (usize, usize)) = (0.0, (0, 0));
        for (r, rod) in self.rods.iter().enumerate() {
            let m = &rod.model;
            let s = self.view(state, r);
            let n = m.n_elements;
            let mat = &m.material;
            let e = |j: usize| -> f64 {
                let (a, b) = (s.position(j), s.position(j + 1));
                let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
                (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() * m.inv_rest_length[j]
            };
            let eps = |k: usize, ek: f64, ek1: f64| -> f64 {
                (ek * m.rest_length[k] + ek1 * m.rest_length[k + 1])
                    / (m.rest_length[k] + m.rest_length[k + 1])
            };
            let mut prev = e(0);
            let mut prev_eps = f64::INFINITY;
            for j in 0..n {
                let ej = prev;
                let next = if j + 1 < n { e(j + 1) } else { f64::NAN };
                let eps_next = if j + 1 < n {
                    eps(j, ej, next)
                } else {
                    f64::INFINITY
                };
                let soft = prev_eps.min(eps_next).powi(3).min(ej * ej);
                let axial =
                    4.0 * mat.youngs_modulus / (mat.density * m.rest_length[j].powi(2)) / soft;
                let shear_rot =
                    4.0 * std::f64::consts::PI * mat.shear_coefficient * mat.shear_modulus
                        / (mat.density * m.area[j])
                        * (ej * ej).max(1.0);
                let w = axial + shear_rot;
                // A non-finite strain makes the estimate infinite (stable limit 0), not NaN.
                let w = if w.is_nan() { f64::INFINITY } else { w };
                if w > w2 {
                    (w2, at) = (w, (r, j));
                }
                prev = next;
                prev_eps = eps_next;
            }
        }
        (w2.sqrt(), at.0, at.1)
    }

    /// The stable limit 2 / `max_frequency_at(state)` [s] of the deformed state.
    pub fn stable_dt_at(&self, state: &SystemState) -> f64 {
        2.0 / self.max_frequency_at(state)
    }

    /// Largest angular frequency of the joints' springs on their end masses and inertias.
    fn joint_frequency(&self) -> f64 {
        let mut w: f64 = 0.0;
        for j in &self.joints {
            let ends = [j.first, j.second];
            let mut inv_m = 0.0;
            let mut inv_j: f64 = 0.0;
            for e in ends {
                let m = &self.rods[e.rod].model;
                inv_m += m.inv_node_mass[e.side.node(m.n_elements)];
                let ii = m.inv_inertia[e.side.element(m.n_elements)];
                inv_j += ii[0].max(ii[1]).max(ii[2]);
            }
            let p = &j.params;
            let w2 = (p.stiffness * inv_m).max(p.rotational_stiffness * inv_j);
            w = w.max(w2.sqrt());
        }
        w
    }

    /// Largest angular frequency the contact springs can add [rad/s] (0 without contact):
    /// β E Â_j / l̂_j on the lighter node of element j, twice that between two rods' elements.
    pub fn contact_max_frequency(&self) -> f64 {
        let factor = if self.contact.rod_contact() {
            2.0
        } else if !self.obstacle_set().is_empty() {
            1.0
        } else {
            return 0.0;
        };
        self.rods
            .iter()
            .map(|r| contact_frequency(&r.model, &self.contact, factor))
            .fold(0.0, f64::max)
    }

    /// Largest stable time step of position Verlet for this system, 2/ω̂_max [s] (spec §11).
    pub fn stable_dt(&self) -> f64 {
        2.0 / self.max_frequency()
    }
}

pub(crate) fn check_rest(sigma: &[Vec3], kappa: &[Vec3], n: usize) -> Result<(), ModelError> {
    if sigma.len() != n {
        return Err(ModelError::BadLength {
            field: "rest_sigma",
            len: sigma.len(),
            expected: n,
        });
    }
    if kappa.len() != n - 1 {
        return Err(ModelError::BadLength {
            field: "rest_kappa",
            len: kappa.len(),
            expected: n - 1,
        });
    }
    for v in sigma {
        finite_vec("rest_sigma", *v)?;
    }
    for v in kappa {
        finite_vec("rest_kappa", *v)?;
    }
    Ok(())
}

/// Check that a rod state fits a model: lengths, finite values, orthonormal frames.
pub(crate) fn check_state(model: &RodModel, state: &RodState) -> Result<(), ModelError> {
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
            finite_vec(field, *v)?;
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
    // Coincident neighbouring nodes give an element of zero length (1/l in every kernel).
    for i in 0..n {
        let d = crate::math::sub(state.position[i + 1], state.position[i]);
        if crate::math::dot(d, d) == 0.0 {
            return Err(ModelError::CountOutOfRange {
                field: "position (coincident neighbouring nodes: an element of zero length)",
                value: i,
                range: "no two neighbouring nodes at the same point",
            });
        }
    }
    Ok(())
}

/// One rod to put into a system.
#[derive(Debug, Clone)]
pub struct RodSpec {
    /// Name, unique in the system.
    pub name: String,
    /// Model (shared when the same `Arc` is given to several rods).
    pub model: Arc<RodModel>,
    /// Initial state.
    pub state: RodState,
    /// Base end condition.
    pub base: EndCondition,
    /// Tip end condition.
    pub tip: EndCondition,
    /// Damping.
    pub damping: Damping,
}

impl RodSpec {
    /// A rod clamped at its base, free at its tip, undamped: the paper's arm's ends.
    pub fn cantilever(name: &str, model: Arc<RodModel>, state: RodState) -> Self {
        Self {
            name: name.to_string(),
            model,
            state,
            base: EndCondition::Clamped,
            tip: EndCondition::Free,
            damping: Damping::default(),
        }
    }
}

/// Assembles rods and joints into a system and its initial state.
#[derive(Debug, Clone)]
pub struct SystemBuilder {
    settings: Settings,
    rods: Vec<RodSpec>,
    joints: Vec<Joint>,
}

impl SystemBuilder {
    /// An empty system with these settings.
    pub fn new(settings: Settings) -> Self {
        Self {
            settings,
            rods: Vec::new(),
            joints: Vec::new(),
        }
    }

    /// Add a rod; returns its index.
    pub fn rod(&mut self, spec: RodSpec) -> usize {
        self.rods.push(spec);
        self.rods.len() - 1
    }

    /// Add a joint between two rod ends (by index).
    pub fn joint(&mut self, joint: Joint) {
        self.joints.push(joint);
    }

    /// Validate everything and build the system and its state (at the rods' initial states,
    /// t = 0). Held ends keep the pose they have in the initial state; joints take their rest
    /// rotation from it. Errors name the first bad input.
    pub fn build(self) -> Result<(RodSystem, SystemState), ModelError> {
        self.settings.validate()?;
        if self.rods.is_empty() {
            return Err(ModelError::CountOutOfRange {
                field: "rods",
                value: 0,
                range: "[1, inf)",
            });
        }
        let mut state = SystemState::empty();
        let mut rods = Vec::with_capacity(self.rods.len());
        let (mut rest_sigma, mut rest_kappa) = (Vec::new(), Vec::new());
        let mut at = Offsets::ZERO;
        for (i, spec) in self.rods.iter().enumerate() {
            if self.rods[..i].iter().any(|o| o.name == spec.name) {
                return Err(ModelError::DuplicateName {
                    field: "rod.name",
                    name: spec.name.clone(),
                });
            }
            let m = &spec.model;
            let n = m.n_elements;
            check_state(m, &spec.state)?;
            spec.damping.validate()?;
            for c in [&spec.base, &spec.tip] {
                if let EndCondition::Driven(motion) = c {
                    motion.validate()?;
                }
            }
            rods.push(Rod {
                name: spec.name.clone(),
                model: Arc::clone(m),
                base: End::at_rod_end(spec.base.clone(), Side::Base, m, &spec.state),
                tip: End::at_rod_end(spec.tip.clone(), Side::Tip, m, &spec.state),
                damping: spec.damping,
                muscles: None,
                at,
            });
            state.push_rod(&spec.state);
            rest_sigma.extend_from_slice(&m.rest_sigma);
            rest_kappa.extend_from_slice(&m.rest_kappa);
            at = Offsets {
                node: at.node + n + 1,
                element: at.element + n,
                interior: at.interior + n - 1,
            };
        }
        let mut joints = self.joints;
        for j in &mut joints {
            for e in [j.first, j.second] {
                if e.rod >= rods.len() {
                    return Err(ModelError::CountOutOfRange {
                        field: "joint.rod",
                        value: e.rod,
                        range: "[0, number of rods - 1]",
                    });
                }
            }
            if j.first == j.second {
                return Err(ModelError::BadVector {
                    field: "joint",
                    value: [j.first.rod as f64, 0.0, 0.0],
                    reason: "a joint joins two different rod ends",
                });
            }
            j.params.validate()?;
            let frame = |e: crate::joints::JointEnd| -> Mat3 {
                let r = &rods[e.rod];
                state
                    .director
                    .get(r.at.element + e.side.element(r.n_elements()))
            };
            let (q1, q2) = (frame(j.first), frame(j.second));
            j.set_rest(&q1, &q2)?;
        }
        let system = RodSystem {
            settings: self.settings,
            n_nodes: at.node,
            n_elements: at.element,
            n_interior: at.interior,
            rods,
            joints,
            loads: Vec::new(),
            obstacles: Vec::new(),
            planes: Vec::new(),
            cylinders: Vec::new(),
            contact: ContactParams::default(),
            rest_sigma,
            rest_kappa,
            rest_changes: Vec::new(),
        };
        Ok((system, state))
    }
}
