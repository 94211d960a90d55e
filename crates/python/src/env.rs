//! `ArmBatch`: the physics of the `octoarm/ArmReach-v0` environments, for many arms at once.
//! Each arm is a planar arm (paper geometry, fewer elements) commanded by rest curvatures on a
//! few segments; one action holds for one control period. The arms are one `RodBatch` (SIMD
//! lanes across arms, chunks of arms in parallel on a private rayon pool); every arm equals its
//! own `Simulation` stepped alone, bit for bit, whatever the thread count. Randomness (targets)
//! lives in Python.
//!
//! Failures are per arm: when the stability guard stops an arm during a control period, that
//! arm is put back to its state at the start of the period (the last state the guard passed:
//! finite, inside the observation bounds) and `step` reports the guard's error for it; the
//! other arms are unaffected. The environments end that arm's episode (truncated).
//!
//! Observation (float32, every component dimensionless and inside the finite bounds of
//! `observation_bounds`): node x, y / L0 in [−1.5, 1.5]; node vx, vy / (10 L0/s) in [−5, 5];
//! target x, y / L0 in [−1.5, 1.5]; lagged rest-curvature command per segment / max_curvature
//! in [−1, 1]; last (clipped) action in [−1, 1]. L0 = 0.2 m is the arm's rest length. Positions
//! and velocities are clipped to their bounds (the arm is inextensible enough never to reach
//! 1.5 L0; the velocity bound is ~6× the fastest node seen under bang-bang commands).

use crate::arrays::read_array;
use crate::{lock, lock_detached, model_error, rod::Simulation as PySimulation, step_error};
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use octoarm_physics::batch::LANES;
use octoarm_physics::{
    BatchError, Damping, RodBatch, Settings, Simulation, StepError, StraightRod, Vec3,
};
use pyo3::exceptions::{PyBaseException, PyValueError};
use pyo3::prelude::*;
use std::sync::Mutex;

/// Rest length L0 of the arm [m] (the paper's arm): the position scale of the observation.
const ARM_LENGTH: f64 = 0.2;
/// Bound of the normalised positions (node and target): |x| / L0 ≤ 1.5.
const POSITION_BOUND: f64 = 1.5;
/// Velocity scale of the observation [m/s]: 10 L0 per second.
const VELOCITY_SCALE: f64 = 10.0 * ARM_LENGTH;
/// Bound of the normalised velocities: |v| / VELOCITY_SCALE ≤ 5 (10 m/s).
const VELOCITY_BOUND: f64 = 5.0;

/// One arm of the batch besides its rod (a lane of the `RodBatch`): target, last action and the
/// lagged rest curvature per segment [1/m] (the actuator state), and the arm as it was at the
/// start of the current control period (restored if the stability guard stops it).
#[derive(Clone)]
struct Arm {
    target: [f64; 2],
    action: Vec<f64>,
    curvature: Vec<f64>,
    saved: Saved,
}

/// An arm's evolving part at the start of a control period.
#[derive(Clone)]
struct Saved {
    sim: Simulation,
    action: Vec<f64>,
    curvature: Vec<f64>,
}

/// The arms of a batch: their rods as one `RodBatch` (lane i = arm i) and the rest per arm.
struct Arms {
    rods: Rods,
    arms: Vec<Arm>,
    // The initial arm (every reset copies it) and scratch for observations.
    initial: Simulation,
    nodes: [Vec<f64>; 6],
    kappa: Vec<Vec3>,
}

/// Configuration shared by all arms of a batch (validated in `ArmBatch::new`).
#[derive(Clone, Copy)]
struct Config {
    n_segments: usize,
    max_curvature: f64,
    steps_per_action: u64,
    effort_weight: f64,
    activation_time: f64,
}

/// The segment (of `n_segments`) that interior point `k` (of `n_interior`) belongs to: the
/// points are split in order into `n_segments` nearly equal runs.
fn segment_of(k: usize, n_segments: usize, n_interior: usize) -> usize {
    k * n_segments / n_interior
}

/// Tip [x, y] of the rest shape of `sim`'s rod (clamped at the origin along +x) whose in-plane
/// rest curvature at interior point k is `curvature[segment_of(k)]` [1/m]: successive elements
/// turn by κ D̂ (rest Voronoi length D̂), which is the shape the arm settles to when a command is
/// held, as no other load acts on it.
fn rest_tip(sim: &Simulation, curvature: &[f64]) -> [f64; 2] {
    let model = &sim.system.rod(0).model;
    let n_interior = model.rest_voronoi_length.len();
    let (mut angle, mut tip) = (0.0_f64, [0.0_f64; 2]);
    for (e, &l) in model.rest_length.iter().enumerate() {
        if e > 0 {
            let k = e - 1;
            angle += curvature[segment_of(k, curvature.len(), n_interior)]
                * model.rest_voronoi_length[k];
        }
        tip[0] += l * angle.cos();
        tip[1] += l * angle.sin();
    }
    tip
}

/// The rods of the arms: a `RodBatch`, or for a single arm its `Simulation` (a batch of one
/// arm would compute three padding lanes for nothing: 1.6× the time of the lone rod's step).
/// Both step the same bits.
#[allow(clippy::large_enum_variant)]
enum Rods {
    Batch(RodBatch),
    One {
        sim: Simulation,
        failure: Option<StepError>,
    },
}

impl Rods {
    fn new(sim: &Simulation, n: usize) -> Result<Self, BatchError> {
        Ok(if n == 1 {
            Rods::One {
                sim: sim.clone(),
                failure: None,
            }
        } else {
            Rods::Batch(RodBatch::new(sim, n)?)
        })
    }

    fn simulation(&self, i: usize) -> Result<Simulation, BatchError> {
        match self {
            Rods::Batch(b) => b.simulation(i),
            Rods::One { sim, .. } => Ok(sim.clone()),
        }
    }

    fn set_lane(&mut self, i: usize, from: &Simulation) -> Result<(), BatchError> {
        match self {
            Rods::Batch(b) => b.set_lane(i, from),
            Rods::One { sim, failure } => {
                sim.clone_from(from);
                *failure = None;
                Ok(())
            }
        }
    }

    fn failure(&self, i: usize) -> Option<&StepError> {
        match self {
            Rods::Batch(b) => b.failure(i),
            Rods::One { failure, .. } => failure.as_ref(),
        }
    }

    /// `RodBatch::run_with` then `RodBatch::check`.
    fn run_and_check<F: Fn(usize, &mut [Vec3]) + Sync>(&mut self, steps: u64, update: &F) {
        match self {
            Rods::Batch(b) => {
                b.run_with(steps, Some(update));
                b.check();
            }
            Rods::One { sim, failure } => {
                let mut run = || {
                    for _ in 0..steps {
                        update(0, &mut sim.system.rest_kappa);
                        sim.step()?;
                    }
                    sim.check()
                };
                *failure = run().err();
            }
        }
    }

    fn rest_kappa(&self, i: usize, out: &mut [Vec3]) -> Result<(), BatchError> {
        match self {
            Rods::Batch(b) => b.rest_kappa(i, out),
            Rods::One { sim, .. } => {
                out.copy_from_slice(&sim.system.rest_kappa);
                Ok(())
            }
        }
    }

    fn nodes(&self, i: usize, pos: [&mut [f64]; 3], vel: [&mut [f64]; 3]) {
        match self {
            Rods::Batch(b) => {
                b.positions(i, pos).expect("lane of an arm");
                b.velocities(i, vel).expect("lane of an arm");
            }
            Rods::One { sim, .. } => {
                let s = &sim.state;
                for (o, v) in pos
                    .into_iter()
                    .zip([&s.position.x, &s.position.y, &s.position.z])
                {
                    o.copy_from_slice(v);
                }
                for (o, v) in vel
                    .into_iter()
                    .zip([&s.velocity.x, &s.velocity.y, &s.velocity.z])
                {
                    o.copy_from_slice(v);
                }
            }
        }
    }
}

/// The per-step actuator update of one arm inside a control period: the lagged rest curvature
/// of each segment follows its goal a · max_curvature (`c += α (goal − c)`), and every interior
/// point of the segment gets it as its in-plane rest curvature κ°₂. The lagged value of a
/// segment is read back from its first point (they are equal after every update, and at
/// reset and restore), so the rest curvatures are the whole actuator state inside a period.
fn lag_rest_curvature(kappa: &mut [Vec3], action: &[f64], cfg: &Config, alpha: f64) {
    let n_interior = kappa.len();
    let (mut segment, mut c) = (usize::MAX, 0.0);
    for (k, kap) in kappa.iter_mut().enumerate() {
        let s = segment_of(k, cfg.n_segments, n_interior);
        if s != segment {
            segment = s;
            let goal = action[s] * cfg.max_curvature;
            c = kap[1];
            c += alpha * (goal - c);
        }
        kap[1] = c;
    }
}

impl Arms {
    /// One control period of every arm under `actions` (n_envs × n_segments, finite; clipped
    /// to [−1, 1]) on `pool`: the arms the stability guard stops are put back to their state
    /// at the start of the period, and their errors returned.
    fn advance(
        &mut self,
        cfg: &Config,
        actions: &[f64],
        pool: Option<&rayon::ThreadPool>,
    ) -> Vec<Option<StepError>> {
        let m = cfg.n_segments;
        for (i, arm) in self.arms.iter_mut().enumerate() {
            arm.saved.sim = self.rods.simulation(i).expect("lane of an arm");
            arm.saved.action.copy_from_slice(&arm.action);
            arm.saved.curvature.copy_from_slice(&arm.curvature);
            for (dst, &a) in arm.action.iter_mut().zip(&actions[i * m..(i + 1) * m]) {
                *dst = a.clamp(-1.0, 1.0);
            }
        }
        // Muscle-like activation: the rest curvature follows the command with a first-order lag
        // of time constant `activation_time`, updated every time step (a step change of rest
        // curvature would shock the thin arm into the non-variational zig-zag mode).
        let alpha = if cfg.activation_time > 0.0 {
            1.0 - (-self.initial.settings().dt / cfg.activation_time).exp()
        } else {
            1.0
        };
        let arms = &self.arms;
        let update = |lane: usize, kappa: &mut [Vec3]| {
            lag_rest_curvature(kappa, &arms[lane].action, cfg, alpha);
        };
        let rods = &mut self.rods;
        let mut run = || rods.run_and_check(cfg.steps_per_action, &update);
        match pool {
            Some(p) => p.install(run),
            None => run(),
        }
        let mut errors = Vec::with_capacity(self.arms.len());
        for (i, arm) in self.arms.iter_mut().enumerate() {
            let error = self.rods.failure(i).cloned();
            if error.is_some() {
                // The failed state is dropped; the arm is back at the start of the period.
                self.rods
                    .set_lane(i, &arm.saved.sim)
                    .expect("an arm's own saved state fits its lane");
                arm.action.copy_from_slice(&arm.saved.action);
                arm.curvature.copy_from_slice(&arm.saved.curvature);
            } else {
                self.rods
                    .rest_kappa(i, &mut self.kappa)
                    .expect("lane of an arm");
                let n_interior = self.kappa.len();
                for (k, kap) in self.kappa.iter().enumerate() {
                    arm.curvature[segment_of(k, m, n_interior)] = kap[1];
                }
            }
            errors.push(error);
        }
        errors
    }

    /// Node positions and velocities of arm `i` into the scratch (x, y, z, vx, vy, vz).
    fn load_nodes(&mut self, i: usize) {
        let [x, y, z, vx, vy, vz] = &mut self.nodes;
        self.rods.nodes(i, [x, y, z], [vx, vy, vz]);
    }

    /// Distance [m] of arm `i`'s tip from its target (after `load_nodes(i)`).
    fn tip_distance(&self, i: usize) -> f64 {
        let [x, y, ..] = &self.nodes;
        let n = x.len() - 1;
        let t = self.arms[i].target;
        ((x[n] - t[0]).powi(2) + (y[n] - t[1]).powi(2)).sqrt()
    }

    /// Reward of arm `i` (after `load_nodes(i)`): −(tip distance [m]) − effort_weight · mean(a²).
    fn reward(&self, i: usize, cfg: &Config) -> f64 {
        let action = &self.arms[i].action;
        let effort = action.iter().map(|a| a * a).sum::<f64>() / cfg.n_segments as f64;
        -self.tip_distance(i) - cfg.effort_weight * effort
    }

    /// Observation of arm `i` (after `load_nodes(i)`; see the module docs): node x, y / L0;
    /// node vx, vy / (10 L0/s); target x, y / L0; lagged rest curvature / max_curvature per
    /// segment; last action. Each component is clipped to its bound (in f64, so the f32 value
    /// is inside the bound too).
    fn observe(&self, i: usize, cfg: &Config, out: &mut [f32]) {
        let arm = &self.arms[i];
        let [px, py, _, vx, vy, _] = &self.nodes;
        let pos = |x: f64| (x / ARM_LENGTH).clamp(-POSITION_BOUND, POSITION_BOUND) as f32;
        let vel = |v: f64| (v / VELOCITY_SCALE).clamp(-VELOCITY_BOUND, VELOCITY_BOUND) as f32;
        let mut o = 0;
        for (x, y) in px.iter().zip(py) {
            out[o] = pos(*x);
            out[o + 1] = pos(*y);
            o += 2;
        }
        for (vx, vy) in vx.iter().zip(vy) {
            out[o] = vel(*vx);
            out[o + 1] = vel(*vy);
            o += 2;
        }
        out[o] = pos(arm.target[0]);
        out[o + 1] = pos(arm.target[1]);
        o += 2;
        for c in &arm.curvature {
            out[o] = (c / cfg.max_curvature).clamp(-1.0, 1.0) as f32;
            o += 1;
        }
        for (dst, a) in out[o..].iter_mut().zip(&arm.action) {
            *dst = *a as f32;
        }
    }
}

/// Half-width of the rendered window about the base [m]: 1.1 L0, beyond any reachable node.
const RENDER_HALF_WIDTH: f64 = 1.1 * ARM_LENGTH;

/// The picture of one arm (see `ArmBatch::render`).
fn render_arm(
    sim: &Simulation,
    target: [f64; 2],
    width: usize,
    height: usize,
) -> octoarm_viewer::raster::Image {
    use octoarm_viewer::raster::{draw_rod, Image, View};
    let mut img = Image::new(width, height, [250, 250, 250]);
    let half = RENDER_HALF_WIDTH;
    let view = View::fit([-half, -half], [half, half], width, height, 0.0);
    // A 5 cm grid, the axes through the base a little darker.
    let line = view.len_px(0.0004).max(1.0);
    for k in -4i32..=4 {
        let at = 0.05 * k as f64;
        let shade = if k == 0 {
            [205, 205, 205]
        } else {
            [228, 228, 228]
        };
        let [x, _] = view.to_px([at, 0.0]);
        img.fill_rect(x - 0.5 * line, x + 0.5 * line, 0.0, height as f64, shade);
        let [_, y] = view.to_px([0.0, at]);
        img.fill_rect(0.0, width as f64, y - 0.5 * line, y + 0.5 * line, shade);
    }
    // The clamp: a dark block behind the base.
    let [x0, y0] = view.to_px([-0.012, 0.02]);
    let [x1, y1] = view.to_px([0.0, -0.02]);
    img.fill_rect(x0, x1, y0, y1, [60, 60, 60]);
    // The target: a red disc of 6 mm radius with a white centre.
    let [tx, ty] = view.to_px(target);
    img.fill_disc(tx, ty, view.len_px(0.006).max(3.0), [220, 20, 30]);
    img.fill_disc(tx, ty, view.len_px(0.002).max(1.0), [255, 255, 255]);
    // The arm with its true radius (one rod: the system's nodes in order).
    let s = &sim.state;
    let nodes: Vec<[f64; 2]> = s
        .position
        .x
        .iter()
        .zip(&s.position.y)
        .map(|(&x, &y)| [x, y])
        .collect();
    draw_rod(
        &mut img,
        &view,
        &nodes,
        &sim.system.rod(0).model.radius,
        [123, 63, 196],
    );
    img
}

/// Many planar arms stepped in parallel (rayon, `num_threads` workers; default all cores).
/// Arguments: `n_envs` ≥ 1; `n_elements` ≥ 4 (default 20); `n_segments` in [1, n_elements − 1]
/// (default 4); `max_curvature` [1/m] > 0 (default 20); `control_period` [s] (default 0.01) a
/// whole multiple of `dt` [s] (default 5e-5); `damping_rate` [1/s] ≥ 0 (default 10);
/// `effort_weight` ≥ 0 (default 0.01); `activation_time` [s] ≥ 0, the lag of the rest
/// curvature behind the command (default 0.05); `tip_diameter` [m] > 0 (default 4 mm: the paper's
/// 0.4 mm tip shears past the stability guard under bang-bang commands at this resolution).
///
/// Thread-safe: the arms sit behind a mutex, so calls from other threads wait while one steps.
#[pyclass(module = "octoarm", frozen)]
pub struct ArmBatch {
    arms: Mutex<Arms>,
    n_envs: usize,
    n_nodes: usize,
    cfg: Config,
    pool: Option<rayon::ThreadPool>,
    obs_dim: usize,
    control_period: f64,
}

impl ArmBatch {
    fn obs(&self, arms: &mut Arms) -> Array2<f32> {
        let mut out = Array2::<f32>::zeros((self.n_envs, self.obs_dim));
        for (i, mut row) in out.rows_mut().into_iter().enumerate() {
            arms.load_nodes(i);
            arms.observe(
                i,
                &self.cfg,
                row.as_slice_mut()
                    .expect("rows of a standard array are contiguous"),
            );
        }
        out
    }
}

fn bad(field: &str, value: impl std::fmt::Display, range: &str) -> PyErr {
    PyValueError::new_err(format!(
        "{field} = {value} is outside the allowed range {range}"
    ))
}

#[pymethods]
impl ArmBatch {
    #[new]
    #[pyo3(signature = (n_envs = 1, n_elements = 20, n_segments = 4, max_curvature = 20.0,
        control_period = 0.01, dt = 5.0e-5, damping_rate = 10.0, effort_weight = 0.01,
        tip_diameter = 0.004, activation_time = 0.05, num_threads = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        n_envs: i64,
        n_elements: i64,
        n_segments: i64,
        max_curvature: f64,
        control_period: f64,
        dt: f64,
        damping_rate: f64,
        effort_weight: f64,
        tip_diameter: f64,
        activation_time: f64,
        num_threads: Option<i64>,
    ) -> PyResult<Self> {
        if n_envs < 1 {
            return Err(bad("n_envs", n_envs, "[1, inf)"));
        }
        if n_elements < 4 {
            return Err(bad("n_elements", n_elements, "[4, inf)"));
        }
        if n_segments < 1 || n_segments >= n_elements {
            return Err(bad("n_segments", n_segments, "[1, n_elements - 1]"));
        }
        if !(max_curvature.is_finite() && max_curvature > 0.0) {
            return Err(bad("max_curvature", max_curvature, "(0, inf)"));
        }
        if !(dt.is_finite() && dt > 0.0) {
            return Err(bad("dt", dt, "(0, inf)"));
        }
        if !(control_period.is_finite() && control_period >= dt) {
            return Err(bad("control_period", control_period, "[dt, inf)"));
        }
        let steps = (control_period / dt).round();
        if ((steps * dt - control_period) / control_period).abs() > 1e-9 {
            return Err(PyValueError::new_err(format!(
                "control_period = {control_period} must be a whole multiple of dt = {dt}"
            )));
        }
        if !(activation_time.is_finite() && activation_time >= 0.0) {
            return Err(bad("activation_time", activation_time, "[0, inf)"));
        }
        if !(effort_weight.is_finite() && effort_weight >= 0.0) {
            return Err(bad("effort_weight", effort_weight, "[0, inf)"));
        }
        // Arms are stepped in chunks of `LANES`; a batch of one chunk runs on the calling
        // thread, more chunks on a private pool (one worker per core by default).
        let pool = match num_threads {
            Some(t) if t < 1 => return Err(bad("num_threads", t, "[1, inf)")),
            _ if n_envs as usize <= LANES => None,
            Some(t) => Some(t as usize),
            None => Some(0), // rayon: one worker per core
        };
        let pool = pool
            .map(|t| {
                rayon::ThreadPoolBuilder::new()
                    .num_threads(t)
                    .build()
                    .map_err(|e| PyValueError::new_err(e.to_string()))
            })
            .transpose()?;
        let rod = StraightRod {
            tip_diameter,
            ..StraightRod::paper_arm().with_elements(n_elements as usize)
        };
        let (model, state) = rod.build().map_err(model_error)?;
        let mut sim = Simulation::new(model, state, Settings::with_dt(dt)).map_err(model_error)?;
        sim.set_damping(Damping::mass_proportional(damping_rate))
            .map_err(model_error)?;
        let n_segments = n_segments as usize;
        let arm = Arm {
            saved: Saved {
                sim: sim.clone(),
                action: vec![0.0; n_segments],
                curvature: vec![0.0; n_segments],
            },
            target: [0.1, 0.1],
            action: vec![0.0; n_segments],
            curvature: vec![0.0; n_segments],
        };
        let n_nodes = n_elements as usize + 1;
        let rods =
            Rods::new(&sim, n_envs as usize).map_err(|e| PyValueError::new_err(e.to_string()))?;
        let arms = Arms {
            rods,
            arms: vec![arm; n_envs as usize],
            nodes: std::array::from_fn(|_| vec![0.0; n_nodes]),
            kappa: vec![[0.0; 3]; n_elements as usize - 1],
            initial: sim,
        };
        Ok(Self {
            arms: Mutex::new(arms),
            n_envs: n_envs as usize,
            n_nodes,
            cfg: Config {
                n_segments,
                max_curvature,
                steps_per_action: steps as u64,
                effort_weight,
                activation_time,
            },
            pool,
            obs_dim: 4 * n_nodes + 2 + 2 * n_segments,
            control_period,
        })
    }

    /// Number of arms.
    #[getter]
    fn n_envs(&self) -> usize {
        self.n_envs
    }

    /// Length of one observation.
    #[getter]
    fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    /// Lower and upper bounds of one observation, each (obs_dim,) float32 (finite; every
    /// observation lies inside them): ±1.5 for positions and target (÷ L0), ±5 for velocities
    /// (÷ 10 L0/s), ±1 for the lagged rest curvatures (÷ max_curvature) and the last action.
    fn observation_bounds<'py>(
        &self,
        py: Python<'py>,
    ) -> (Bound<'py, PyArray1<f32>>, Bound<'py, PyArray1<f32>>) {
        let n_nodes = self.n_nodes;
        let mut high = vec![POSITION_BOUND as f32; 2 * n_nodes];
        high.resize(4 * n_nodes, VELOCITY_BOUND as f32);
        high.resize(4 * n_nodes + 2, POSITION_BOUND as f32);
        high.resize(self.obs_dim, 1.0);
        debug_assert_eq!(high.len(), self.obs_dim);
        let low: Vec<f32> = high.iter().map(|h| -h).collect();
        (
            Array1::from_vec(low).into_pyarray(py),
            Array1::from_vec(high).into_pyarray(py),
        )
    }

    /// Rest length L0 of the arm [m]: observed positions and target are divided by it.
    #[getter]
    fn length(&self) -> f64 {
        ARM_LENGTH
    }

    /// Velocity scale [m/s] (10 L0/s): observed velocities are divided by it.
    #[getter]
    fn velocity_scale(&self) -> f64 {
        VELOCITY_SCALE
    }

    /// Length of one action (= n_segments).
    #[getter]
    fn action_dim(&self) -> usize {
        self.cfg.n_segments
    }

    /// Simulated seconds per environment step.
    #[getter]
    fn control_period(&self) -> f64 {
        self.control_period
    }

    /// Time steps per environment step.
    #[getter]
    fn steps_per_action(&self) -> u64 {
        self.cfg.steps_per_action
    }

    /// Tips [m] of the arm's rest shapes under commands (k, action_dim) in [−1, 1] (clipped, as
    /// actions; any real dtype, finite): where the tip settles when a command is held, as no
    /// other load acts on the arm. Returns (k, 2) float64. Used to draw reachable targets.
    fn rest_tips<'py>(
        &self,
        py: Python<'py>,
        commands: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let m = self.cfg.n_segments;
        let k = commands.len()?;
        let c = read_array(commands, "commands", &[k, m])?;
        let arms = lock(py, &self.arms);
        let sim = &arms.initial;
        let mut out = Array2::<f64>::zeros((k, 2));
        let mut curvature = vec![0.0; m];
        for (row, cmd) in c.chunks(m).enumerate() {
            for (dst, a) in curvature.iter_mut().zip(cmd) {
                *dst = a.clamp(-1.0, 1.0) * self.cfg.max_curvature;
            }
            let tip = rest_tip(sim, &curvature);
            out[[row, 0]] = tip[0];
            out[[row, 1]] = tip[1];
        }
        Ok(out.into_pyarray(py))
    }

    /// Reset the arms `indices` (default: all; distinct, in [0, n_envs − 1]) to rest with the
    /// given targets (k, 2) [m] (any real dtype), each coordinate within ±1.5 L0 = ±0.3 m;
    /// returns the observations of all arms, (n_envs, obs_dim) float32. All or nothing: on an
    /// error no arm is reset.
    #[pyo3(signature = (targets, indices = None))]
    fn reset<'py>(
        &self,
        py: Python<'py>,
        targets: &Bound<'py, PyAny>,
        indices: Option<Vec<i64>>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let n = self.n_envs;
        let indices: Vec<usize> = match indices {
            None => (0..n).collect(),
            Some(v) => v
                .into_iter()
                .map(|i| match usize::try_from(i) {
                    Ok(i) if i < n => Ok(i),
                    _ => Err(bad("index", i, &format!("[0, {}] (n_envs - 1)", n - 1))),
                })
                .collect::<PyResult<_>>()?,
        };
        for (k, i) in indices.iter().enumerate() {
            if indices[..k].contains(i) {
                return Err(PyValueError::new_err(format!(
                    "indices name arm {i} twice; each arm is reset once"
                )));
            }
        }
        let t = read_array(targets, "targets", &[indices.len(), 2])?;
        let limit = POSITION_BOUND * ARM_LENGTH;
        for target in t.chunks_exact(2) {
            for (name, &v) in ["target x", "target y"].iter().zip(target) {
                if v.abs() > limit {
                    return Err(bad(name, v, &format!("[{}, {limit}]", -limit)));
                }
            }
        }
        let obs = {
            let mut guard = lock(py, &self.arms);
            let arms: &mut Arms = &mut guard;
            for (target, &i) in t.chunks_exact(2).zip(&indices) {
                arms.rods
                    .set_lane(i, &arms.initial)
                    .expect("the initial arm fits every lane");
                let arm = &mut arms.arms[i];
                arm.target = [target[0], target[1]];
                arm.action.fill(0.0);
                arm.curvature.fill(0.0);
            }
            self.obs(arms)
        };
        Ok(obs.into_pyarray(py))
    }

    /// Apply actions (n_envs, action_dim) in [−1, 1] (clipped; any real dtype, finite: NaN or
    /// ±inf is refused naming its entry; the shape must match exactly) for one control period
    /// on every arm (GIL released, parallel). Returns (observations (n_envs, obs_dim) float32,
    /// rewards (n_envs,) float64, tip distances (n_envs,) float64 [m], failures): `failures`
    /// is a list with, per arm, None or the `InstabilityError` of the stability guard that
    /// stopped it during this period. A stopped arm is back at its state at the start of the
    /// period (its observation, reward and distance are those of that state); reset it.
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &self,
        py: Python<'py>,
        actions: &Bound<'py, PyAny>,
    ) -> PyResult<(
        Bound<'py, PyArray2<f32>>,
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray1<f64>>,
        Vec<Option<Py<PyBaseException>>>,
    )> {
        let (n, m) = (self.n_envs, self.cfg.n_segments);
        let a = read_array(actions, "actions", &[n, m])?;
        let cfg = self.cfg;
        let (obs, rewards, dist, errors) = py.detach(|| {
            let mut guard = lock_detached(&self.arms);
            let arms: &mut Arms = &mut guard;
            let errors = arms.advance(&cfg, &a, self.pool.as_ref());
            let (mut rewards, mut dist) = (Vec::with_capacity(n), Vec::with_capacity(n));
            for i in 0..n {
                arms.load_nodes(i);
                rewards.push(arms.reward(i, &cfg));
                dist.push(arms.tip_distance(i));
            }
            (self.obs(arms), rewards, dist, errors)
        });
        let failures = errors
            .into_iter()
            .map(|e| e.map(|e| step_error(py, e).into_value(py)))
            .collect();
        Ok((
            obs.into_pyarray(py),
            Array1::from_vec(rewards).into_pyarray(py),
            Array1::from_vec(dist).into_pyarray(py),
            failures,
        ))
    }

    /// An RGB image of arm `index`, shape (height, width, 3), dtype uint8: the arm drawn with
    /// its true (tapered) radius, its target, the clamp at the origin and a 5 cm grid, in a
    /// fixed window of ±0.22 m (±1.1 L0) about the base, x right and y up. `width` and
    /// `height` in [16, 4096] pixels (default 400 × 400). Rendered in Rust, no display needed.
    #[pyo3(signature = (index, width = 400, height = 400))]
    fn render<'py>(
        &self,
        py: Python<'py>,
        index: i64,
        width: i64,
        height: i64,
    ) -> PyResult<Bound<'py, numpy::PyArray3<u8>>> {
        let n = self.n_envs;
        let i = usize::try_from(index)
            .ok()
            .filter(|&i| i < n)
            .ok_or_else(|| bad("index", index, &format!("[0, {}] (n_envs - 1)", n - 1)))?;
        let size = |name: &str, v: i64| {
            usize::try_from(v)
                .ok()
                .filter(|v| (16..=4096).contains(v))
                .ok_or_else(|| bad(name, v, "[16, 4096]"))
        };
        let (w, h) = (size("width", width)?, size("height", height)?);
        let image = {
            let arms = lock(py, &self.arms);
            let sim = arms.rods.simulation(i).expect("lane of an arm");
            render_arm(&sim, arms.arms[i].target, w, h)
        };
        let array = numpy::ndarray::Array3::from_shape_vec((h, w, 3), image.pixels)
            .expect("an image of height × width × 3 bytes");
        Ok(array.into_pyarray(py))
    }

    /// A copy of arm `index` as a `Simulation` (for plotting or inspection).
    fn simulation(&self, py: Python<'_>, index: i64) -> PyResult<PySimulation> {
        let n = self.n_envs;
        let i = usize::try_from(index)
            .ok()
            .filter(|&i| i < n)
            .ok_or_else(|| bad("index", index, &format!("[0, {}] (n_envs - 1)", n - 1)))?;
        let sim = lock(py, &self.arms)
            .rods
            .simulation(i)
            .expect("lane of an arm");
        Ok(PySimulation::from_inner(sim))
    }
}
