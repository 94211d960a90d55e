//! `MuscleBatch`: the physics of `octoarm/MuscleReach3D-v0` for many arms at once. Each arm is
//! COOMM's muscular arm (muscles-3d spec §1–3: seven muscle groups, Morison drag, the `coomm`
//! damping preset) with fewer elements, commanded by the seven group activations per segment;
//! one action holds for one control period. Arms are stepped in parallel on a private rayon
//! pool; each arm's arithmetic is sequential and independent of the others, so results are
//! bit-identical whatever the thread count. Randomness (targets) lives in Python; reachable
//! target poses come from the exact statics (`reachable_pose`).
//!
//! Failures are per arm, as in `ArmBatch`: an arm stopped by the stability guard is put back to
//! its state at the start of the period and `step` reports the guard's error for it.
//!
//! Observation (float32, every component dimensionless and inside the finite bounds of
//! `observation_bounds`): node x, y, z / L0 in [−1.5, 1.5]; node velocities / (10 L0/s) in
//! [−5, 5]; tip frame (rows d1, d2, d3 of the last element) in [−1, 1]; target point / L0 in
//! [−1.5, 1.5]; target frame in [−1, 1]; (target − tip) / L0 in [−3, 3]; lagged activations
//! per group and segment in [0, 1]; last (clipped) action in [0, 1].

use crate::arrays::read_array;
use crate::muscle::{coomm_simulation, read_orientation};
use crate::{lock, lock_detached, model_error, rod::Simulation as PySimulation, step_error};
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3};
use octoarm_control::MuscleStatics;
use octoarm_physics::math::log_relative;
use octoarm_physics::{Mat3, MuscleModel, MuscleSpec, Simulation, StepError, Vec3, N_GROUPS};
use pyo3::exceptions::{PyBaseException, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use rayon::prelude::*;
use std::sync::Mutex;

/// Rest length L0 of COOMM's arm [m].
const ARM_LENGTH: f64 = 0.2;
const POSITION_BOUND: f64 = 1.5;
const VELOCITY_SCALE: f64 = 10.0 * ARM_LENGTH;
const VELOCITY_BOUND: f64 = 5.0;
const ERROR_BOUND: f64 = 3.0;

#[derive(Clone, Copy)]
struct Config {
    n_elements: usize,
    n_segments: usize,
    steps_per_action: u64,
    activation_time: f64,
    effort_weight: f64,
    orientation_weight: f64,
}

impl Config {
    fn n_actions(&self) -> usize {
        N_GROUPS * self.n_segments
    }
}

#[derive(Clone)]
struct Saved {
    sim: Simulation,
    action: Vec<f64>,
    activation: Vec<f64>,
}

#[derive(Clone)]
struct Arm {
    sim: Simulation,
    initial: Simulation,
    target: Vec3,
    target_frame: Mat3,
    /// Last clipped action, group-major [7][n_segments].
    action: Vec<f64>,
    /// Lagged activation per group and segment (the actuator state).
    activation: Vec<f64>,
    saved: Saved,
}

impl Arm {
    fn advance(&mut self, cfg: &Config, action: &[f64]) -> Result<(), StepError> {
        self.saved.sim.clone_from(&self.sim);
        self.saved.action.copy_from_slice(&self.action);
        self.saved.activation.copy_from_slice(&self.activation);
        let result = self.run_period(cfg, action);
        if result.is_err() {
            std::mem::swap(&mut self.sim, &mut self.saved.sim);
            self.action.copy_from_slice(&self.saved.action);
            self.activation.copy_from_slice(&self.saved.activation);
        }
        result
    }

    /// Activations follow the clipped action with a first-order lag of time constant
    /// `activation_time`, updated every time step; element j of segment s = ⌊j S / n⌋ takes
    /// its segment's value.
    fn run_period(&mut self, cfg: &Config, action: &[f64]) -> Result<(), StepError> {
        for (dst, &a) in self.action.iter_mut().zip(action) {
            *dst = a.clamp(0.0, 1.0);
        }
        let alpha = if cfg.activation_time > 0.0 {
            1.0 - (-self.sim.settings().dt / cfg.activation_time).exp()
        } else {
            1.0
        };
        let (n, s) = (cfg.n_elements, cfg.n_segments);
        for _ in 0..cfg.steps_per_action {
            for (c, a) in self.activation.iter_mut().zip(&self.action) {
                *c += alpha * (a - *c);
            }
            let act = self.sim.actuation.activations_mut();
            for g in 0..N_GROUPS {
                for j in 0..n {
                    act[g * n + j] = self.activation[g * s + j * s / n];
                }
            }
            self.sim.step()?;
        }
        self.sim.check()
    }

    /// Tip point (the last element's midpoint) and tip frame.
    fn tip(&self) -> (Vec3, Mat3) {
        let s = &self.sim.state;
        let n = s.director.len();
        let p = s.position.get(n);
        let q = s.position.get(n - 1);
        (
            [
                0.5 * (p[0] + q[0]),
                0.5 * (p[1] + q[1]),
                0.5 * (p[2] + q[2]),
            ],
            s.director.get(n - 1),
        )
    }

    fn errors(&self) -> (f64, f64) {
        let (p, q) = self.tip();
        let d = ((p[0] - self.target[0]).powi(2)
            + (p[1] - self.target[1]).powi(2)
            + (p[2] - self.target[2]).powi(2))
        .sqrt();
        (d, log_relative(&q, &self.target_frame).1)
    }

    /// −d / L0 − orientation_weight · θ_Q / π − effort_weight · mean(a²).
    fn reward(&self, cfg: &Config) -> f64 {
        let (d, theta) = self.errors();
        let effort = self.action.iter().map(|a| a * a).sum::<f64>() / cfg.n_actions() as f64;
        -d / ARM_LENGTH
            - cfg.orientation_weight * theta / std::f64::consts::PI
            - cfg.effort_weight * effort
    }

    fn observe(&self, out: &mut [f32]) {
        let s = &self.sim.state;
        let pos = |x: f64| (x / ARM_LENGTH).clamp(-POSITION_BOUND, POSITION_BOUND) as f32;
        let vel = |v: f64| (v / VELOCITY_SCALE).clamp(-VELOCITY_BOUND, VELOCITY_BOUND) as f32;
        let unit = |v: f64| v.clamp(-1.0, 1.0) as f32;
        let mut o = 0;
        let mut put = |v: f32| {
            out[o] = v;
            o += 1;
        };
        for i in 0..s.position.len() {
            for c in s.position.get(i) {
                put(pos(c));
            }
        }
        for i in 0..s.velocity.len() {
            for c in s.velocity.get(i) {
                put(vel(c));
            }
        }
        let (p, q) = self.tip();
        for row in q {
            for c in row {
                put(unit(c));
            }
        }
        for c in self.target {
            put(pos(c));
        }
        for row in self.target_frame {
            for c in row {
                put(unit(c));
            }
        }
        for (t, c) in self.target.iter().zip(p) {
            put(((t - c) / ARM_LENGTH).clamp(-ERROR_BOUND, ERROR_BOUND) as f32);
        }
        for &a in &self.activation {
            put(a.clamp(0.0, 1.0) as f32);
        }
        for &a in &self.action {
            put(a as f32);
        }
    }
}

fn bad(field: &str, value: impl std::fmt::Display, range: &str) -> PyErr {
    PyValueError::new_err(format!(
        "{field} = {value} is outside the allowed range {range}"
    ))
}

/// Half-width of each rendered panel about its centre [m].
const RENDER_HALF_WIDTH: f64 = 1.1 * ARM_LENGTH;

/// One orthographic panel: the arm projected on the plane of lab axes (`a`, `b`).
fn render_panel(
    arm: &Arm,
    width: usize,
    height: usize,
    a: usize,
    b: usize,
) -> octoarm_viewer::raster::Image {
    use octoarm_viewer::raster::{draw_rod, Image, View};
    let mut img = Image::new(width, height, [250, 250, 250]);
    let half = RENDER_HALF_WIDTH;
    let view = View::fit([-half, -half], [half, half], width, height, 0.0);
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
    let [x0, y0] = view.to_px([-0.012, 0.02]);
    let [x1, y1] = view.to_px([0.0, -0.02]);
    img.fill_rect(x0, x1, y0, y1, [60, 60, 60]);
    let [tx, ty] = view.to_px([arm.target[a], arm.target[b]]);
    img.fill_disc(tx, ty, view.len_px(0.006).max(3.0), [220, 20, 30]);
    img.fill_disc(tx, ty, view.len_px(0.002).max(1.0), [255, 255, 255]);
    let s = &arm.sim.state;
    let nodes: Vec<[f64; 2]> = (0..s.position.len())
        .map(|i| {
            let p = s.position.get(i);
            [p[a], p[b]]
        })
        .collect();
    draw_rod(
        &mut img,
        &view,
        &nodes,
        &arm.sim.system.rod(0).model.radius,
        [123, 63, 196],
    );
    img
}

/// Many COOMM muscular arms stepped in parallel (rayon, `num_threads` workers; default all
/// cores). Arguments: `n_envs` ≥ 1; `n_elements` ≥ 4 (default 20); `n_segments` in
/// [1, n_elements] (default 4); `control_period` [s] (default 0.05) a whole multiple of `dt`
/// [s] (default 5e-5); `activation_time` [s] ≥ 0, the lag of the activations behind the
/// command (default 0.05); `effort_weight` ≥ 0 (default 0.01); `orientation_weight` ≥ 0
/// (default 0.1).
#[pyclass(module = "octoarm", frozen)]
pub struct MuscleBatch {
    arms: Mutex<Vec<Arm>>,
    statics: Mutex<MuscleStatics>,
    n_envs: usize,
    cfg: Config,
    pool: Option<rayon::ThreadPool>,
    obs_dim: usize,
    control_period: f64,
}

impl MuscleBatch {
    fn obs(&self, arms: &[Arm]) -> Array2<f32> {
        let mut out = Array2::<f32>::zeros((arms.len(), self.obs_dim));
        for (arm, mut row) in arms.iter().zip(out.rows_mut()) {
            arm.observe(row.as_slice_mut().expect("contiguous rows"));
        }
        out
    }

    fn index(&self, index: i64) -> PyResult<usize> {
        let n = self.n_envs;
        usize::try_from(index)
            .ok()
            .filter(|&i| i < n)
            .ok_or_else(|| bad("index", index, &format!("[0, {}] (n_envs - 1)", n - 1)))
    }
}

#[pymethods]
impl MuscleBatch {
    #[new]
    #[pyo3(signature = (n_envs = 1, n_elements = 20, n_segments = 4, control_period = 0.05,
        dt = 5.0e-5, activation_time = 0.05, effort_weight = 0.01, orientation_weight = 0.1,
        num_threads = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        n_envs: i64,
        n_elements: i64,
        n_segments: i64,
        control_period: f64,
        dt: f64,
        activation_time: f64,
        effort_weight: f64,
        orientation_weight: f64,
        num_threads: Option<i64>,
    ) -> PyResult<Self> {
        if n_envs < 1 {
            return Err(bad("n_envs", n_envs, "[1, inf)"));
        }
        if n_elements < 4 {
            return Err(bad("n_elements", n_elements, "[4, inf)"));
        }
        if n_segments < 1 || n_segments > n_elements {
            return Err(bad("n_segments", n_segments, "[1, n_elements]"));
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
        for (name, v) in [
            ("activation_time", activation_time),
            ("effort_weight", effort_weight),
            ("orientation_weight", orientation_weight),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(bad(name, v, "[0, inf)"));
            }
        }
        let pool = match num_threads {
            Some(t) if t < 1 => return Err(bad("num_threads", t, "[1, inf)")),
            Some(1) => None,
            Some(t) => Some(t as usize),
            None if n_envs == 1 => None,
            None => Some(0),
        };
        let pool = pool
            .map(|t| {
                rayon::ThreadPoolBuilder::new()
                    .num_threads(t)
                    .build()
                    .map_err(|e| PyValueError::new_err(e.to_string()))
            })
            .transpose()?;
        let n = n_elements as usize;
        let s = n_segments as usize;
        let sim = coomm_simulation(n, dt, true, true)?;
        let model = sim.system.rod(0).model.clone();
        let mm = MuscleModel::new(MuscleSpec::coomm(), &model).map_err(model_error)?;
        let statics = MuscleStatics::new(
            &model,
            mm,
            sim.state.position.get(0),
            sim.state.director.get(0),
        );
        let (p0, q0) = {
            let arm0 = &sim.state;
            let a = arm0.position.get(n - 1);
            let b = arm0.position.get(n);
            (
                [
                    0.5 * (a[0] + b[0]),
                    0.5 * (a[1] + b[1]),
                    0.5 * (a[2] + b[2]),
                ],
                arm0.director.get(n - 1),
            )
        };
        let arm = Arm {
            initial: sim.clone(),
            saved: Saved {
                sim: sim.clone(),
                action: vec![0.0; N_GROUPS * s],
                activation: vec![0.0; N_GROUPS * s],
            },
            sim,
            target: p0,
            target_frame: q0,
            action: vec![0.0; N_GROUPS * s],
            activation: vec![0.0; N_GROUPS * s],
        };
        let n_nodes = n + 1;
        Ok(Self {
            arms: Mutex::new(vec![arm; n_envs as usize]),
            statics: Mutex::new(statics),
            n_envs: n_envs as usize,
            cfg: Config {
                n_elements: n,
                n_segments: s,
                steps_per_action: steps as u64,
                activation_time,
                effort_weight,
                orientation_weight,
            },
            pool,
            obs_dim: 6 * n_nodes + 9 + 3 + 9 + 3 + 2 * N_GROUPS * s,
            control_period,
        })
    }

    /// Number of arms.
    #[getter]
    fn n_envs(&self) -> usize {
        self.n_envs
    }

    /// Elements per arm.
    #[getter]
    fn n_elements(&self) -> usize {
        self.cfg.n_elements
    }

    /// Segments per arm (each group's activation is constant on a segment).
    #[getter]
    fn n_segments(&self) -> usize {
        self.cfg.n_segments
    }

    /// Length of one observation.
    #[getter]
    fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    /// Length of one action (7 × n_segments).
    #[getter]
    fn action_dim(&self) -> usize {
        self.cfg.n_actions()
    }

    /// Rest length L0 of the arm [m].
    #[getter]
    fn length(&self) -> f64 {
        ARM_LENGTH
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

    /// Lower and upper bounds of one observation, each (obs_dim,) float32 (see the module docs).
    fn observation_bounds<'py>(
        &self,
        py: Python<'py>,
    ) -> (Bound<'py, PyArray1<f32>>, Bound<'py, PyArray1<f32>>) {
        let nn = 3 * (self.cfg.n_elements + 1);
        let na = self.cfg.n_actions();
        let mut lo = Vec::with_capacity(self.obs_dim);
        let mut hi = Vec::with_capacity(self.obs_dim);
        let mut push = |k: usize, l: f64, h: f64| {
            lo.resize(lo.len() + k, l as f32);
            hi.resize(hi.len() + k, h as f32);
        };
        push(nn, -POSITION_BOUND, POSITION_BOUND);
        push(nn, -VELOCITY_BOUND, VELOCITY_BOUND);
        push(9, -1.0, 1.0);
        push(3, -POSITION_BOUND, POSITION_BOUND);
        push(9, -1.0, 1.0);
        push(3, -ERROR_BOUND, ERROR_BOUND);
        push(2 * na, 0.0, 1.0);
        debug_assert_eq!(lo.len(), self.obs_dim);
        (
            Array1::from_vec(lo).into_pyarray(py),
            Array1::from_vec(hi).into_pyarray(py),
        )
    }

    /// The static tip pose of the arm under constant `activations` (7, n_segments) in [0, 1]
    /// (segment values spread over their elements): (position (3,) [m], orientation (3, 3),
    /// rows d1, d2, d3), the exact discrete equilibrium (Newton from the straight arm). A pose
    /// made so is reachable by construction. `RuntimeError` if no equilibrium is found.
    #[allow(clippy::type_complexity)]
    fn reachable_pose<'py>(
        &self,
        py: Python<'py>,
        activations: &Bound<'py, PyAny>,
    ) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray3<f64>>)> {
        let (n, s) = (self.cfg.n_elements, self.cfg.n_segments);
        let a = read_array(activations, "activations", &[N_GROUPS, s])?;
        if let Some(i) = a.iter().position(|v| !(0.0..=1.0).contains(v)) {
            return Err(bad(
                &format!("activations[{}, {}]", i / s, i % s),
                a[i],
                "[0, 1]",
            ));
        }
        let full: Vec<f64> = (0..N_GROUPS * n)
            .map(|k| a[(k / n) * s + (k % n) * s / n])
            .collect();
        let pose = py.detach(|| {
            let mut st = lock_detached(&self.statics);
            let rest = st.rest();
            st.solve(&full, Some(&rest)).map(|_| st.pose(st.solution()))
        });
        let pose = pose.map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        let p: Vec<f64> = (0..3)
            .map(|c| 0.5 * (pose.position[n - 1][c] + pose.position[n][c]))
            .collect();
        Ok((
            Array1::from_vec(p).into_pyarray(py),
            crate::arrays::mat3s(py, &pose.director[n - 1..]),
        ))
    }

    /// Reset the arms `indices` (default all; distinct, in [0, n_envs − 1]) to the straight arm
    /// at rest with target points `positions` (k, 3) [m] (each coordinate within ±1.5 L0) and
    /// target frames `orientations` (k, 3, 3) (rotations); returns every arm's observation
    /// (n_envs, obs_dim) float32. All or nothing.
    #[pyo3(signature = (positions, orientations, indices = None))]
    fn reset<'py>(
        &self,
        py: Python<'py>,
        positions: &Bound<'py, PyAny>,
        orientations: &Bound<'py, PyAny>,
        indices: Option<Vec<i64>>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let n = self.n_envs;
        let indices: Vec<usize> = match indices {
            None => (0..n).collect(),
            Some(v) => v
                .into_iter()
                .map(|i| self.index(i))
                .collect::<PyResult<_>>()?,
        };
        for (k, i) in indices.iter().enumerate() {
            if indices[..k].contains(i) {
                return Err(PyValueError::new_err(format!(
                    "indices name arm {i} twice; each arm is reset once"
                )));
            }
        }
        let k = indices.len();
        let p = read_array(positions, "positions", &[k, 3])?;
        let limit = POSITION_BOUND * ARM_LENGTH;
        if let Some(i) = p.iter().position(|v| v.abs() > limit) {
            return Err(bad(
                &format!("positions[{}, {}]", i / 3, i % 3),
                p[i],
                &format!("[{}, {limit}]", -limit),
            ));
        }
        let q_flat = read_array(orientations, "orientations", &[k, 3, 3])?;
        let mut frames = Vec::with_capacity(k);
        for (r, m) in q_flat.chunks_exact(9).enumerate() {
            let arr = numpy::ndarray::Array2::from_shape_vec((3, 3), m.to_vec())
                .expect("3 × 3")
                .into_pyarray(py);
            frames.push(read_orientation(
                arr.as_any(),
                &format!("orientations[{r}]"),
            )?);
        }
        let obs = {
            let mut arms = lock(py, &self.arms);
            for ((t, q), &i) in p.chunks_exact(3).zip(frames).zip(&indices) {
                let arm = &mut arms[i];
                arm.sim.clone_from(&arm.initial);
                arm.target = [t[0], t[1], t[2]];
                arm.target_frame = q;
                arm.action.fill(0.0);
                arm.activation.fill(0.0);
            }
            self.obs(&arms)
        };
        Ok(obs.into_pyarray(py))
    }

    /// Apply actions (n_envs, action_dim) in [0, 1] (clipped; finite; group-major per arm:
    /// entry g · n_segments + s is group g on segment s) for one control period on every arm
    /// (GIL released, parallel). Returns (observations (n_envs, obs_dim) float32, rewards
    /// (n_envs,), tip distances (n_envs,) [m], orientation errors θ_Q (n_envs,) [rad], failures:
    /// per arm None or the `InstabilityError` that stopped it; a stopped arm is back at its
    /// state at the start of the period).
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &self,
        py: Python<'py>,
        actions: &Bound<'py, PyAny>,
    ) -> PyResult<(
        Bound<'py, PyArray2<f32>>,
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray1<f64>>,
        Vec<Option<Py<PyBaseException>>>,
    )> {
        let (n, m) = (self.n_envs, self.cfg.n_actions());
        let a = read_array(actions, "actions", &[n, m])?;
        let cfg = self.cfg;
        let (obs, rewards, dist, theta, errors) = py.detach(|| {
            let mut guard = lock_detached(&self.arms);
            let arms: &mut Vec<Arm> = &mut guard;
            let errors: Vec<Option<StepError>> = match self.pool.as_ref() {
                None => arms
                    .iter_mut()
                    .zip(a.chunks(m))
                    .map(|(arm, act)| arm.advance(&cfg, act).err())
                    .collect(),
                Some(pool) => pool.install(|| {
                    arms.par_iter_mut()
                        .zip(a.par_chunks(m))
                        .with_max_len(1)
                        .map(|(arm, act)| arm.advance(&cfg, act).err())
                        .collect()
                }),
            };
            let rewards: Vec<f64> = arms.iter().map(|arm| arm.reward(&cfg)).collect();
            let (dist, theta): (Vec<f64>, Vec<f64>) = arms.iter().map(Arm::errors).unzip();
            (self.obs(arms), rewards, dist, theta, errors)
        });
        let failures = errors
            .into_iter()
            .map(|e| e.map(|e| step_error(py, e).into_value(py)))
            .collect();
        Ok((
            obs.into_pyarray(py),
            Array1::from_vec(rewards).into_pyarray(py),
            Array1::from_vec(dist).into_pyarray(py),
            Array1::from_vec(theta).into_pyarray(py),
            failures,
        ))
    }

    /// An RGB image of arm `index`, (height, width, 3) uint8: two orthographic views side by
    /// side, top (x right, y up) and front (x right, z up), each a fixed ±0.22 m window about
    /// the base with a 5 cm grid, the arm with its true radius and the target (red). `width` and
    /// `height` in [32, 4096] pixels (default 800 × 400). Rendered in Rust.
    #[pyo3(signature = (index, width = 800, height = 400))]
    fn render<'py>(
        &self,
        py: Python<'py>,
        index: i64,
        width: i64,
        height: i64,
    ) -> PyResult<Bound<'py, numpy::PyArray3<u8>>> {
        let i = self.index(index)?;
        let size = |name: &str, v: i64| {
            usize::try_from(v)
                .ok()
                .filter(|v| (32..=4096).contains(v))
                .ok_or_else(|| bad(name, v, "[32, 4096]"))
        };
        let (w, h) = (size("width", width)?, size("height", height)?);
        let (wl, wr) = (w / 2, w - w / 2);
        let pixels = {
            let arms = lock(py, &self.arms);
            let left = render_panel(&arms[i], wl, h, 0, 1);
            let right = render_panel(&arms[i], wr, h, 0, 2);
            let mut px = Vec::with_capacity(w * h * 3);
            for r in 0..h {
                px.extend_from_slice(&left.pixels[r * wl * 3..(r + 1) * wl * 3]);
                px.extend_from_slice(&right.pixels[r * wr * 3..(r + 1) * wr * 3]);
            }
            px
        };
        let array = numpy::ndarray::Array3::from_shape_vec((h, w, 3), pixels)
            .expect("an image of height × width × 3 bytes");
        Ok(array.into_pyarray(py))
    }

    /// A copy of arm `index` as a `Simulation`.
    fn simulation(&self, py: Python<'_>, index: i64) -> PyResult<PySimulation> {
        let i = self.index(index)?;
        let sim = lock(py, &self.arms)[i].sim.clone();
        Ok(PySimulation::from_inner(sim))
    }
}
