//! Scenario files: the serde `…Config` mirror of each TOML section, defaults, validation with
//! ranges, and error messages that name the file, the line, the key and the allowed range
//! (unknown keys get the nearest valid name). It does not build models or run anything: see
//! `runner.rs`. To add a section, add a `…Config` struct, a field in `ScenarioConfig` and its
//! checks in `ScenarioConfig::validate`.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// A 3-vector as written in a scenario, `[x, y, z]`.
pub type Vec3 = [f64; 3];

/// The whole scenario file. Sections are tables; `[[load]]` and `[[obstacle]]` are arrays of
/// tables. Unknown keys are rejected everywhere.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioConfig {
    /// Free text shown in `check` and copied to `summary.json`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// `[rod]`: geometry and material of the arm (required).
    pub rod: RodConfig,
    /// `[time]`: time step, duration and recording interval (required).
    pub time: TimeConfig,
    /// `[damping]`: optional; each term defaults to 0.
    #[serde(default)]
    pub damping: DampingConfig,
    /// `[numerics]`: optional stepper settings.
    #[serde(default)]
    pub numerics: NumericsConfig,
    /// `[contact]`: optional penalty parameters of obstacle contact.
    #[serde(default)]
    pub contact: ContactConfig,
    /// `[[load]]`: external loads, any number.
    #[serde(default, rename = "load", skip_serializing_if = "Vec::is_empty")]
    pub loads: Vec<LoadConfig>,
    /// `[[obstacle]]`: rigid obstacles, any number.
    #[serde(default, rename = "obstacle", skip_serializing_if = "Vec::is_empty")]
    pub obstacles: Vec<ObstacleConfig>,
    /// `[controller]`: drive the arm with a controller (a controlled run, see `controlled.rs`);
    /// without it the rod runs passively under its loads.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub controller: Option<ControllerConfig>,
    /// `[solver]`: how the controller's design w̄ is computed (controlled runs only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub solver: Option<SolverConfig>,
    /// `[[target]]`: task targets of the tip in time order (controlled runs only).
    #[serde(default, rename = "target", skip_serializing_if = "Vec::is_empty")]
    pub targets: Vec<TargetConfig>,
    /// `[via_path]`: a path the design target follows before the task target (controlled runs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub via_path: Option<ViaPathConfig>,
    /// `[grasp]`: grasp a sphere instead of reaching (controlled runs only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grasp: Option<GraspConfig>,
}

/// The kinds of `[controller]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ControllerKind {
    /// The energy-shaping law (control spec §4) with the mass-proportional damping of
    /// `[damping] rate`.
    EnergyShaping,
}

/// `[controller]`: the closed loop of a controlled run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerConfig {
    /// The control law.
    pub kind: ControllerKind,
    /// Simulated time between samples of the scalar series (`series.npz`, `distance.csv`) [s],
    /// ≥ dt; default 1e-3.
    #[serde(default = "default_series_interval")]
    pub series_interval: f64,
}

/// How the design is scheduled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SolverModeKind {
    /// Every design solved before t = 0 (control spec §3.2).
    #[default]
    Offline,
    /// A few warm-started iterations every `update_every` steps (control spec §3.3).
    Online,
}

/// The solver's update rule (control spec §3.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RuleKind {
    /// Rule Q: L-BFGS in the stiffness metric.
    #[default]
    Lbfgs,
    /// Rule P: stiffness-preconditioned gradient step.
    Preconditioned,
    /// Rule R: the paper's plain Hamiltonian-gradient step.
    Paper,
}

/// `[solver]`: the forward–backward solver and the design schedule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolverConfig {
    /// "offline" (default) or "online".
    #[serde(default)]
    pub mode: SolverModeKind,
    /// "lbfgs" (default), "preconditioned" or "paper".
    #[serde(default)]
    pub rule: RuleKind,
    /// L-BFGS memory (rule lbfgs), in [1, 1000]; default 10.
    #[serde(default = "default_lbfgs_memory")]
    pub lbfgs_memory: usize,
    /// Step η (rules preconditioned, default 1, and paper, default 0.005 m²/N), > 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub eta: Option<f64>,
    /// Lower clamp of the stretch ν3 (rule paper), > 0; default 0.1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_stretch: Option<f64>,
    /// Tip weight μ_tip [N/m], ≥ 0; default 1e3.
    #[serde(default = "default_mu_tip")]
    pub mu_tip: f64,
    /// Obstacle weight ξ [N/m²], ≥ 0; default 1e5.
    #[serde(default = "default_xi")]
    pub xi: f64,
    /// Diameter of the design stiffness floor [m], ≥ 0; default 4e-3 (0 = paper-literal).
    #[serde(default = "default_floor")]
    pub design_floor_diameter: f64,
    /// Planar strains (the paper's problem in the x–y plane; default true) or all six.
    #[serde(default = "default_true")]
    pub planar: bool,
    /// Stop when the strain residual is at most this, > 0; default 1e-8.
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
    /// Iterations over which the relative decrease of J is measured, ≥ 1; default 20.
    #[serde(default = "default_stall_window")]
    pub stall_window: usize,
    /// Stop when J fell by less than this relative amount over the window, ≥ 0; default 1e-12.
    #[serde(default = "default_stall_tolerance")]
    pub stall_tolerance: f64,
    /// Largest number of sweeps of an offline solve, ≥ 1; default 20000.
    #[serde(default = "default_max_sweeps")]
    pub max_sweeps: usize,
    /// Online: steps between design updates, ≥ 1; default 100 (1 ms at dt = 1e-5 s).
    #[serde(default = "default_update_every")]
    pub update_every: u64,
    /// Online: solver iterations per update, ≥ 1; default 10.
    #[serde(default = "default_iterations_per_update")]
    pub iterations_per_update: usize,
    /// Online: cap each strain's change per update so that the first design needs about this
    /// long to form [s], > 0; default none (no trust region).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trust_form_time: Option<f64>,
    /// Online: solve the design for the first target offline before t = 0 and start the online
    /// updates from it (applied at once at t = 0); default false (start from the straight arm).
    #[serde(default)]
    pub presolve: bool,
    /// Offline grasp: stages of the μ_grasp continuation (scales 1e-3 … 1), ≥ 1; default 4.
    #[serde(default = "default_grasp_stages")]
    pub grasp_stages: usize,
    /// Offline: apply each new design through a linear ramp of this length [s], ≥ 0; default 0
    /// (switch at once).
    #[serde(default)]
    pub ramp_time: f64,
    /// Offline: steps between ramp increments, ≥ 1; default 100.
    #[serde(default = "default_update_every")]
    pub ramp_every: u64,
}

/// `[[target]]`: a tip target in force from `from` on, r*(t) = position + velocity (t − from).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetConfig {
    /// Target at time `from` [m], lab frame.
    pub position: Vec3,
    /// Start of this target [s], ≥ 0; default 0. Targets must be in time order.
    #[serde(default)]
    pub from: f64,
    /// Constant velocity [m/s]; default 0 (a static target).
    #[serde(default)]
    pub velocity: Vec3,
}

/// `[via_path]`: the design target runs at constant speed along `points` from `start` to `end`
/// [s] and the task target takes over at `end`; the distance d is always to the task target.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViaPathConfig {
    /// Corner points [m], at least two.
    pub points: Vec<Vec3>,
    /// Time at the first point [s], ≥ 0; default 0.
    #[serde(default)]
    pub start: f64,
    /// Time at the last point [s], > start.
    pub end: f64,
}

/// `[grasp]`: wrap the arm's `interval` around a sphere (control spec §5.5); the sphere is also
/// a physical obstacle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GraspConfig {
    /// Centre of the sphere [m].
    pub center: Vec3,
    /// Diameter of the sphere [m], > 0.
    pub diameter: f64,
    /// μ_grasp on the interval [N/m], > 0; default 1e3.
    #[serde(default = "default_mu_tip")]
    pub mu_grasp: f64,
    /// Grasping interval as fractions of L0, `[a, 1.0]` with 0 ≤ a < 1; default [0.4, 1.0].
    #[serde(default = "default_grasp_interval")]
    pub interval: [f64; 2],
}

/// `[rod]`: a straight rod, uniform or linearly tapered, clamped at the origin.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RodConfig {
    /// Number of elements N, in [2, 100000].
    pub n_elements: usize,
    /// Rest length [m], > 0.
    pub length: f64,
    /// Diameter at the base [m], > 0.
    pub base_diameter: f64,
    /// Diameter at the tip [m], > 0; default `base_diameter` (uniform rod). Linear taper between.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tip_diameter: Option<f64>,
    /// Density [kg/m³], > 0.
    pub density: f64,
    /// Young's modulus E [Pa], > 0.
    pub youngs_modulus: f64,
    /// Shear modulus G [Pa], > 0.
    pub shear_modulus: f64,
    /// α_c in the shear stiffness α_c G A, > 0; default 27/28.
    #[serde(default = "default_shear_coefficient")]
    pub shear_coefficient: f64,
    /// d3 at rest (unit tangent, normalised); default [1, 0, 0].
    #[serde(default = "default_direction")]
    pub direction: Vec3,
    /// d1 at rest, perpendicular to `direction`; default [0, 1, 0].
    #[serde(default = "default_normal")]
    pub normal: Vec3,
    /// Uniform rest curvature κ° [1/m], material frame (κ1, κ2, κ3); default 0.
    #[serde(default)]
    pub rest_curvature: Vec3,
}

/// `[time]`: the time step and how long and how often to record.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeConfig {
    /// Time step Δt [s], > 0 (the only copy of dt; the stepper gets it from here).
    pub dt: f64,
    /// Simulated duration [s], ≥ dt; rounded to a whole number of steps.
    pub duration: f64,
    /// Simulated time between recorded frames [s], ≥ dt; default 1e-3 s. Rounded to a whole
    /// number of steps; t = 0 and the final state are always recorded.
    #[serde(default = "default_save_interval")]
    pub save_interval: f64,
}

/// `[damping]`: viscous damping (spec §8a); both rates add when both are non-zero.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DampingConfig {
    /// Mass-proportional decay rate ν_d [1/s], ≥ 0; default 0.
    #[serde(default)]
    pub rate: f64,
    /// The paper's per-unit-length coefficient γ [kg/(m s)], ≥ 0; default 0.
    #[serde(default)]
    pub gamma: f64,
}

/// `[numerics]`: stepper settings other than dt.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NumericsConfig {
    /// Energy-consistent tension corrections (spec eq. 4.5); default false.
    #[serde(default)]
    pub energy_consistent: bool,
    /// Steps between stability-guard checks, in [1, 1000000]; default 100.
    #[serde(default = "default_guard_interval")]
    pub guard_interval: u64,
}

impl Default for NumericsConfig {
    fn default() -> Self {
        Self {
            energy_consistent: false,
            guard_interval: default_guard_interval(),
        }
    }
}

/// `[contact]`: penalty contact with obstacles (spec §10).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactConfig {
    /// Stiffness factor β (k = β E Â / l̂), > 0; default 1.
    #[serde(default = "default_beta")]
    pub beta: f64,
    /// Damping ratio ζ, ≥ 0; default 0.5.
    #[serde(default = "default_zeta")]
    pub zeta: f64,
}

impl Default for ContactConfig {
    fn default() -> Self {
        Self {
            beta: default_beta(),
            zeta: default_zeta(),
        }
    }
}

/// The kinds of `[[load]]` (spec §9).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LoadKind {
    /// Uniform acceleration g [m/s²] on every node's mass.
    Gravity,
    /// Point force [N] on the tip node, lab frame.
    TipForce,
    /// Constant distributed force [N/m] per unit rest length, lab frame.
    UniformForce,
    /// Lab-frame point couple [N m] on the tip element.
    TipCouple,
}

impl LoadKind {
    /// Unit of `value` for this kind.
    pub fn unit(self) -> &'static str {
        match self {
            LoadKind::Gravity => "m/s^2",
            LoadKind::TipForce => "N",
            LoadKind::UniformForce => "N/m",
            LoadKind::TipCouple => "N m",
        }
    }

    /// The name used in scenario files.
    pub fn name(self) -> &'static str {
        match self {
            LoadKind::Gravity => "gravity",
            LoadKind::TipForce => "tip_force",
            LoadKind::UniformForce => "uniform_force",
            LoadKind::TipCouple => "tip_couple",
        }
    }

    /// Whether a `ramp_time` may be given.
    pub fn can_ramp(self) -> bool {
        matches!(self, LoadKind::TipForce | LoadKind::TipCouple)
    }
}

/// `[[load]]`: one external load.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoadConfig {
    /// What the load is.
    pub kind: LoadKind,
    /// Vector value, lab frame, in the kind's unit (N, m/s², N/m or N m).
    pub value: Vec3,
    /// `tip_force` and `tip_couple` only: ramp linearly from 0 over this time [s], ≥ 0; default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ramp_time: Option<f64>,
}

/// The kinds of `[[obstacle]]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ObstacleKind {
    /// A rigid sphere.
    Sphere,
}

/// `[[obstacle]]`: one rigid obstacle (spec §10).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObstacleConfig {
    /// What the obstacle is.
    pub kind: ObstacleKind,
    /// Centre at t = 0 [m].
    pub center: Vec3,
    /// Diameter [m], > 0.
    pub diameter: f64,
    /// Constant velocity of the centre [m/s]; default 0 (fixed).
    #[serde(default)]
    pub velocity: Vec3,
}

fn default_shear_coefficient() -> f64 {
    27.0 / 28.0
}
fn default_direction() -> Vec3 {
    [1.0, 0.0, 0.0]
}
fn default_normal() -> Vec3 {
    [0.0, 1.0, 0.0]
}
fn default_save_interval() -> f64 {
    1.0e-3
}
fn default_guard_interval() -> u64 {
    100
}
fn default_beta() -> f64 {
    1.0
}
fn default_zeta() -> f64 {
    0.5
}
fn default_series_interval() -> f64 {
    1.0e-3
}
fn default_lbfgs_memory() -> usize {
    10
}
fn default_mu_tip() -> f64 {
    1.0e3
}
fn default_xi() -> f64 {
    1.0e5
}
fn default_floor() -> f64 {
    4.0e-3
}
fn default_true() -> bool {
    true
}
fn default_tolerance() -> f64 {
    1.0e-8
}
fn default_stall_window() -> usize {
    20
}
fn default_stall_tolerance() -> f64 {
    1.0e-12
}
fn default_max_sweeps() -> usize {
    20_000
}
fn default_update_every() -> u64 {
    100
}
fn default_iterations_per_update() -> usize {
    10
}
fn default_grasp_stages() -> usize {
    4
}
fn default_grasp_interval() -> [f64; 2] {
    [0.4, 1.0]
}

/// Largest accepted element count (memory and time grow with it; a typo guard).
pub const MAX_ELEMENTS: usize = 100_000;
/// Largest accepted number of steps (a typo guard: 1e10 steps are days of computing).
pub const MAX_STEPS: f64 = 1.0e10;

/// A scenario that failed to load: unreadable, not TOML, unknown or missing keys, wrong types,
/// or values outside their range. Display gives `file:line: …`.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioError {
    /// The scenario file.
    pub file: PathBuf,
    /// 1-based line (and column) of the offending key, when known.
    pub line: Option<(usize, usize)>,
    /// The message after the location.
    pub message: String,
}

impl fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some((line, col)) => {
                write!(f, "{}:{line}:{col}: {}", self.file.display(), self.message)
            }
            None => write!(f, "{}: {}", self.file.display(), self.message),
        }
    }
}

impl std::error::Error for ScenarioError {}

/// One value outside its range, found by `ScenarioConfig::validate`.
#[derive(Debug, Clone, PartialEq)]
pub struct Invalid {
    /// Dotted key path as written in the file, e.g. `rod.tip_diameter` or `load[1].value`
    /// (index 0-based among the `[[load]]` tables).
    pub key: String,
    /// The value, formatted as in TOML.
    pub value: String,
    /// The allowed range or rule, in words.
    pub range: String,
}

impl fmt::Display for Invalid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.value.is_empty() {
            // A rule about the section as a whole, not a value out of range.
            return write!(f, "{}: {}", self.key, self.range);
        }
        write!(
            f,
            "{} = {} is outside the allowed range {}",
            self.key, self.value, self.range
        )
    }
}

/// A scenario as loaded: the file it came from, its text and the resolved configuration.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// Path of the scenario file.
    pub path: PathBuf,
    /// Name used for the default output folder: the file stem.
    pub name: String,
    /// The resolved configuration (defaults filled in, validated).
    pub config: ScenarioConfig,
    source: String,
}

impl Scenario {
    /// Read, parse, resolve and validate a scenario file. Every failure is a `ScenarioError`
    /// naming the file and, where possible, the line and key.
    pub fn load(path: &Path) -> Result<Self, ScenarioError> {
        let source = std::fs::read_to_string(path).map_err(|e| ScenarioError {
            file: path.to_path_buf(),
            line: None,
            message: format!("cannot read the scenario file: {e}"),
        })?;
        Self::from_str(path, &source)
    }

    /// Parse, resolve and validate scenario text; `path` is used in messages and for the name.
    pub fn from_str(path: &Path, source: &str) -> Result<Self, ScenarioError> {
        let err = |span: Option<Range<usize>>, message: String| ScenarioError {
            file: path.to_path_buf(),
            line: span.map(|s| line_col(source, s.start)),
            message,
        };
        let mut config: ScenarioConfig =
            toml::from_str(source).map_err(|e| err(e.span(), explain_toml_error(source, &e)))?;
        config.resolve();
        config
            .validate()
            .map_err(|bad| err(key_span(source, &bad.key), bad.to_string()))?;
        let name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scenario".into());
        Ok(Self {
            path: path.to_path_buf(),
            name,
            config,
            source: source.to_string(),
        })
    }

    /// The original text of the file.
    pub fn source(&self) -> &str {
        &self.source
    }

    /// Line and column of a key path in the original file, if it is there.
    pub fn locate(&self, key: &str) -> Option<(usize, usize)> {
        key_span(&self.source, key).map(|s| line_col(&self.source, s.start))
    }

    /// The resolved scenario as TOML, with a header saying where it came from; parsing it
    /// gives the same configuration.
    pub fn resolved_toml(&self) -> String {
        let body = toml::to_string(&self.config).expect("a scenario always serialises");
        format!(
            "# Resolved by octoarm {} from {} (defaults filled in).\n# Re-run with: octoarm run scenario.toml\n\n{body}",
            env!("CARGO_PKG_VERSION"),
            self.path.display()
        )
    }
}

impl ScenarioConfig {
    /// Fill in defaults that depend on other keys, so that the written scenario is explicit.
    pub fn resolve(&mut self) {
        if self.rod.tip_diameter.is_none() {
            self.rod.tip_diameter = Some(self.rod.base_diameter);
        }
        for load in &mut self.loads {
            if load.kind.can_ramp() && load.ramp_time.is_none() {
                load.ramp_time = Some(0.0);
            }
        }
        if self.controller.is_some() && self.solver.is_none() {
            self.solver = Some(toml::from_str("").expect("every [solver] key has a default"));
        }
        if let Some(sv) = &mut self.solver {
            match sv.rule {
                RuleKind::Lbfgs => {}
                RuleKind::Preconditioned => {
                    sv.eta.get_or_insert(1.0);
                }
                RuleKind::Paper => {
                    sv.eta.get_or_insert(0.005);
                    sv.min_stretch.get_or_insert(0.1);
                }
            }
        }
    }

    /// Number of steps of the run: duration / dt rounded to the nearest integer (at least 1).
    pub fn n_steps(&self) -> u64 {
        ((self.time.duration / self.time.dt).round() as u64).max(1)
    }

    /// Steps between recorded frames: save_interval / dt rounded (at least 1).
    pub fn save_every(&self) -> u64 {
        ((self.time.save_interval / self.time.dt).round() as u64).max(1)
    }

    /// Number of frames a complete run records (t = 0, every `save_every` steps, the end).
    pub fn n_frames(&self) -> u64 {
        let (n, k) = (self.n_steps(), self.save_every());
        1 + n / k + u64::from(n % k != 0)
    }

    /// Check every value against its range; the first violation is returned.
    pub fn validate(&self) -> Result<(), Invalid> {
        let r = &self.rod;
        if !(2..=MAX_ELEMENTS).contains(&r.n_elements) {
            return Err(bad(
                "rod.n_elements",
                r.n_elements,
                format!("[2, {MAX_ELEMENTS}]"),
            ));
        }
        positive("rod.length", r.length)?;
        positive("rod.base_diameter", r.base_diameter)?;
        positive(
            "rod.tip_diameter",
            r.tip_diameter.unwrap_or(r.base_diameter),
        )?;
        positive("rod.density", r.density)?;
        positive("rod.youngs_modulus", r.youngs_modulus)?;
        positive("rod.shear_modulus", r.shear_modulus)?;
        positive("rod.shear_coefficient", r.shear_coefficient)?;
        let d3 = unit_vec("rod.direction", r.direction)?;
        let d1 = unit_vec("rod.normal", r.normal)?;
        let cos = d1[0] * d3[0] + d1[1] * d3[1] + d1[2] * d3[2];
        if cos.abs() > 1e-10 {
            return Err(bad_vec(
                "rod.normal",
                r.normal,
                format!("of vectors perpendicular to rod.direction = {} (cosine between them is {cos:.3e})", fmt_vec(r.direction)),
            ));
        }
        finite_vec("rod.rest_curvature", r.rest_curvature)?;

        let t = &self.time;
        positive("time.dt", t.dt)?;
        if !(t.duration.is_finite() && t.duration >= t.dt) {
            return Err(bad(
                "time.duration",
                t.duration,
                format!("[time.dt = {:e}, inf), finite", t.dt),
            ));
        }
        if t.duration / t.dt > MAX_STEPS {
            return Err(bad(
                "time.duration",
                t.duration,
                format!("of at most {MAX_STEPS:e} steps of dt = {:e} s", t.dt),
            ));
        }
        if !(t.save_interval.is_finite() && t.save_interval >= t.dt * (1.0 - 1e-9)) {
            return Err(bad(
                "time.save_interval",
                t.save_interval,
                format!("[time.dt = {:e}, inf), finite", t.dt),
            ));
        }

        non_negative("damping.rate", self.damping.rate)?;
        non_negative("damping.gamma", self.damping.gamma)?;
        if !(1..=1_000_000).contains(&self.numerics.guard_interval) {
            return Err(bad(
                "numerics.guard_interval",
                self.numerics.guard_interval,
                "[1, 1000000]",
            ));
        }
        positive("contact.beta", self.contact.beta)?;
        non_negative("contact.zeta", self.contact.zeta)?;

        for (i, load) in self.loads.iter().enumerate() {
            finite_vec(&format!("load[{i}].value"), load.value)?;
            match load.ramp_time {
                Some(ramp) if !load.kind.can_ramp() && ramp != 0.0 => {
                    return Err(bad(
                        &format!("load[{i}].ramp_time"),
                        ramp,
                        "of 0 for this kind: a ramp is only supported for kind = \"tip_force\" or \"tip_couple\"",
                    ));
                }
                Some(ramp) => non_negative(&format!("load[{i}].ramp_time"), ramp)?,
                None => {}
            }
        }
        for (i, ob) in self.obstacles.iter().enumerate() {
            finite_vec(&format!("obstacle[{i}].center"), ob.center)?;
            positive(&format!("obstacle[{i}].diameter"), ob.diameter)?;
            finite_vec(&format!("obstacle[{i}].velocity"), ob.velocity)?;
        }
        self.validate_control()
    }

    /// The sections of a controlled run: present only with `[controller]`, in range, and no
    /// passive-only feature (loads, moving obstacles, per-length damping, stepper settings).
    fn validate_control(&self) -> Result<(), Invalid> {
        let Some(ctrl) = &self.controller else {
            let needs = |key: &str| {
                bad(
                    key,
                    "",
                    "allowed only with [controller] (kind = \"energy_shaping\"); add it or remove this section",
                )
            };
            if self.solver.is_some() {
                return Err(needs("solver"));
            }
            if !self.targets.is_empty() {
                return Err(needs("target"));
            }
            if self.via_path.is_some() {
                return Err(needs("via_path"));
            }
            if self.grasp.is_some() {
                return Err(needs("grasp"));
            }
            return Ok(());
        };
        let t = &self.time;
        if !(ctrl.series_interval.is_finite() && ctrl.series_interval >= t.dt * (1.0 - 1e-9)) {
            return Err(bad(
                "controller.series_interval",
                ctrl.series_interval,
                format!("[time.dt = {:e}, inf), finite", t.dt),
            ));
        }
        if !self.loads.is_empty() {
            return Err(bad(
                "load",
                "",
                "a run with [controller] takes no [[load]]; remove the loads",
            ));
        }
        if self.damping.gamma != 0.0 {
            return Err(bad(
                "damping.gamma",
                self.damping.gamma,
                "of 0 with [controller]: the controller's damping is [damping] rate",
            ));
        }
        if self.numerics != NumericsConfig::default() {
            return Err(bad(
                "numerics",
                "",
                "a run with [controller] uses the default stepper settings (energy_consistent = false, guard_interval = 100); remove [numerics]",
            ));
        }
        for (i, ob) in self.obstacles.iter().enumerate() {
            if ob.velocity != [0.0; 3] {
                return Err(bad_vec(
                    &format!("obstacle[{i}].velocity"),
                    ob.velocity,
                    "of [0, 0, 0] with [controller]: controlled runs take fixed obstacles",
                ));
            }
        }
        if self.targets.is_empty() && self.grasp.is_none() {
            return Err(bad(
                "controller",
                "",
                "a controlled run needs at least one [[target]] or a [grasp]; add one",
            ));
        }
        if !self.targets.is_empty() && self.grasp.is_some() {
            return Err(bad(
                "grasp",
                "",
                "a grasp has no tip target: give either [[target]] or [grasp], not both",
            ));
        }
        let mut last_from = 0.0;
        for (i, tg) in self.targets.iter().enumerate() {
            finite_vec(&format!("target[{i}].position"), tg.position)?;
            finite_vec(&format!("target[{i}].velocity"), tg.velocity)?;
            non_negative(&format!("target[{i}].from"), tg.from)?;
            if i > 0 && tg.from <= last_from {
                return Err(bad(
                    &format!("target[{i}].from"),
                    tg.from,
                    format!(
                        "(target[{}].from = {last_from}, inf): targets in time order",
                        i - 1
                    ),
                ));
            }
            last_from = tg.from;
        }
        if let Some(v) = &self.via_path {
            if self.targets.is_empty() {
                return Err(bad(
                    "via_path",
                    "",
                    "needs a [[target]]: the path leads to the task target",
                ));
            }
            if v.points.len() < 2 {
                return Err(bad(
                    "via_path.points",
                    v.points.len(),
                    "of at least 2 points",
                ));
            }
            for p in &v.points {
                finite_vec("via_path.points", *p)?;
            }
            non_negative("via_path.start", v.start)?;
            if !(v.end.is_finite() && v.end > v.start) {
                return Err(bad(
                    "via_path.end",
                    v.end,
                    format!("(via_path.start = {}, inf), finite", v.start),
                ));
            }
        }
        if let Some(g) = &self.grasp {
            finite_vec("grasp.center", g.center)?;
            positive("grasp.diameter", g.diameter)?;
            positive("grasp.mu_grasp", g.mu_grasp)?;
            let [a, b] = g.interval;
            if !(a.is_finite() && (0.0..1.0).contains(&a) && b == 1.0) {
                return Err(bad(
                    "grasp.interval",
                    format!("[{a}, {b}]"),
                    "[a, 1.0] with 0 <= a < 1 (the interval ends at the tip)",
                ));
            }
        }
        let sv = self
            .solver
            .as_ref()
            .expect("resolve() fills [solver] for a controlled run");
        if !(1..=1000).contains(&sv.lbfgs_memory) {
            return Err(bad("solver.lbfgs_memory", sv.lbfgs_memory, "[1, 1000]"));
        }
        if let Some(eta) = sv.eta {
            positive("solver.eta", eta)?;
            if sv.rule == RuleKind::Preconditioned && eta > 1.0 {
                return Err(bad(
                    "solver.eta",
                    eta,
                    "(0, 1] for rule = \"preconditioned\"",
                ));
            }
        }
        if let Some(m) = sv.min_stretch {
            positive("solver.min_stretch", m)?;
        }
        non_negative("solver.mu_tip", sv.mu_tip)?;
        non_negative("solver.xi", sv.xi)?;
        non_negative("solver.design_floor_diameter", sv.design_floor_diameter)?;
        positive("solver.tolerance", sv.tolerance)?;
        non_negative("solver.stall_tolerance", sv.stall_tolerance)?;
        let at_least_one = |key: &str, v: u64| {
            if v >= 1 {
                Ok(())
            } else {
                Err(bad(key, v, "[1, inf)"))
            }
        };
        at_least_one("solver.stall_window", sv.stall_window as u64)?;
        at_least_one("solver.max_sweeps", sv.max_sweeps as u64)?;
        at_least_one("solver.update_every", sv.update_every)?;
        at_least_one(
            "solver.iterations_per_update",
            sv.iterations_per_update as u64,
        )?;
        at_least_one("solver.grasp_stages", sv.grasp_stages as u64)?;
        at_least_one("solver.ramp_every", sv.ramp_every)?;
        if let Some(tf) = sv.trust_form_time {
            positive("solver.trust_form_time", tf)?;
        }
        non_negative("solver.ramp_time", sv.ramp_time)?;
        Ok(())
    }
}

fn bad(key: &str, value: impl fmt::Display, range: impl Into<String>) -> Invalid {
    Invalid {
        key: key.to_string(),
        value: value.to_string(),
        range: range.into(),
    }
}

fn bad_vec(key: &str, value: Vec3, range: impl Into<String>) -> Invalid {
    Invalid {
        key: key.to_string(),
        value: fmt_vec(value),
        range: range.into(),
    }
}

/// `[x, y, z]` as TOML writes it.
pub fn fmt_vec(v: Vec3) -> String {
    format!("[{}, {}, {}]", v[0], v[1], v[2])
}

fn positive(key: &str, v: f64) -> Result<(), Invalid> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(bad(key, v, "(0, inf), finite"))
    }
}

fn non_negative(key: &str, v: f64) -> Result<(), Invalid> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(bad(key, v, "[0, inf), finite"))
    }
}

fn finite_vec(key: &str, v: Vec3) -> Result<(), Invalid> {
    if v.iter().all(|c| c.is_finite()) {
        Ok(())
    } else {
        Err(bad_vec(key, v, "of vectors with finite components"))
    }
}

fn unit_vec(key: &str, v: Vec3) -> Result<Vec3, Invalid> {
    finite_vec(key, v)?;
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if l > 0.0 && l.is_finite() {
        Ok([v[0] / l, v[1] / l, v[2] / l])
    } else {
        Err(bad_vec(key, v, "of non-zero vectors"))
    }
}

/// 1-based line and column of byte offset `at`.
pub fn line_col(source: &str, at: usize) -> (usize, usize) {
    let at = at.min(source.len());
    let before = &source[..at];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// Byte span of the key named by a dotted path with optional `[i]` indices, e.g.
/// `load[1].value`, found by re-parsing the text with spans. Falls back to the nearest enclosing
/// table that exists (a missing key is reported at its table).
pub fn key_span(source: &str, path: &str) -> Option<Range<usize>> {
    use toml_edit::TableLike;
    let doc = toml_edit::ImDocument::parse(source).ok()?;
    let mut best = None;
    let mut table: &dyn TableLike = doc.as_table();
    for part in path.split('.') {
        let (name, index) = match part.split_once('[') {
            Some((n, rest)) => (n, rest.trim_end_matches(']').parse::<usize>().ok()),
            None => (part, None),
        };
        let Some((key, item)) = table.get_key_value(name) else {
            return best;
        };
        best = key.span().or_else(|| item.span()).or(best);
        let next: Option<&dyn TableLike> = match index {
            Some(i) => {
                if let Some(t) = item.as_array_of_tables().and_then(|a| a.get(i)) {
                    best = t.span().or(best);
                    Some(t)
                } else {
                    // `load = [{ ... }, { ... }]`: an inline array of inline tables.
                    item.as_array()
                        .and_then(|a| a.get(i))
                        .and_then(|v| v.as_inline_table())
                        .map(|t| {
                            best = t.span().or(best.clone());
                            t as &dyn TableLike
                        })
                }
            }
            None => item.as_table_like(),
        };
        match next {
            Some(t) => table = t,
            None => return best,
        }
    }
    best
}

/// Turn a toml/serde error into one line: what is wrong and, for an unknown key or kind, the
/// nearest valid name and the full list.
fn explain_toml_error(source: &str, e: &toml::de::Error) -> String {
    let msg = e.message().trim().replace('\n', ": ");
    let found_at = e
        .span()
        .map(|s| source.get(s).unwrap_or("").to_string())
        .unwrap_or_default();
    if let Some(rest) = msg.strip_prefix("unknown field `") {
        let (name, expected) = split_unknown(rest);
        let section = e
            .span()
            .and_then(|s| section_of(source, s.start))
            .unwrap_or_default();
        let head = if section == name {
            format!("unknown section [{name}]")
        } else if section.is_empty() {
            format!("unknown key `{name}` at the top level")
        } else {
            format!("unknown key `{name}` in [{section}]")
        };
        return with_suggestion(head, &name, &expected);
    }
    if let Some(rest) = msg.strip_prefix("unknown variant `") {
        let (name, expected) = split_unknown(rest);
        return with_suggestion(format!("unknown kind \"{name}\""), &name, &expected);
    }
    if let Some(rest) = msg.strip_prefix("missing field `") {
        let name = rest.trim_end_matches('`');
        let section = e
            .span()
            .and_then(|s| section_of(source, s.start))
            .unwrap_or_default();
        let where_ = if section.is_empty() {
            String::new()
        } else {
            format!(" in [{section}]")
        };
        if found_at.is_empty() || section.is_empty() {
            // Missing whole sections are reported at the top level.
            return format!(
                "missing required {} `{name}`{where_}",
                if section.is_empty() {
                    "section or key"
                } else {
                    "key"
                }
            );
        }
        return format!("missing required key `{name}`{where_}");
    }
    let key = e
        .span()
        .and_then(|s| key_at(source, s.start))
        .map(|k| format!("{k}: "))
        .unwrap_or_default();
    format!("{key}{msg}")
}

/// From "name`, expected one of `a`, `b`" get ("name", ["a", "b"]).
fn split_unknown(rest: &str) -> (String, Vec<String>) {
    let (name, tail) = rest.split_once('`').unwrap_or((rest, ""));
    let expected = tail
        .split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect();
    (name.to_string(), expected)
}

fn with_suggestion(head: String, name: &str, expected: &[String]) -> String {
    let list = expected.join(", ");
    match nearest(name, expected) {
        Some(best) => format!("{head}; did you mean `{best}`? (allowed: {list})"),
        None => format!("{head} (allowed: {list})"),
    }
}

/// The candidate closest to `name` by edit distance, if it is close enough to be a typo
/// (distance at most a third of the longer name, or one is a prefix of the other).
pub fn nearest<'a>(name: &str, candidates: &'a [String]) -> Option<&'a str> {
    let lower = name.to_lowercase();
    candidates
        .iter()
        .map(|c| (levenshtein(&lower, &c.to_lowercase()), c))
        .filter(|(d, c)| {
            let longest = lower.chars().count().max(c.chars().count());
            *d * 3 <= longest.max(3) || c.starts_with(&lower) || lower.starts_with(c.as_str())
        })
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c.as_str())
}

/// Edit distance (insertions, deletions, substitutions) between two strings.
pub fn levenshtein(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diag = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let up = row[j + 1];
            row[j + 1] = (diag + usize::from(ca != cb)).min(row[j] + 1).min(up + 1);
            diag = up;
        }
    }
    row[b.len()]
}

/// The `[section]` or `[[section]]` header in force at byte offset `at` (by scanning the text).
fn section_of(source: &str, at: usize) -> Option<String> {
    // Include the line holding `at`: a missing-key error points at its table's header.
    let at = at.min(source.len());
    let end = source[at..].find('\n').map_or(source.len(), |i| at + i);
    let before = &source[..end];
    before.lines().rev().find_map(|line| {
        let t = line.trim();
        if t.starts_with('[') {
            Some(
                t.trim_start_matches('[')
                    .split(']')
                    .next()
                    .unwrap_or("")
                    .trim()
                    .to_string(),
            )
        } else {
            None
        }
    })
}

/// The dotted key whose value contains byte offset `at`, e.g. `rod.length`.
fn key_at(source: &str, at: usize) -> Option<String> {
    let doc = toml_edit::ImDocument::parse(source).ok()?;
    let mut path = Vec::new();
    find_key(doc.as_item(), at, &mut path).then(|| path.join("."))
}

fn find_key(item: &toml_edit::Item, at: usize, path: &mut Vec<String>) -> bool {
    if let Some(aot) = item.as_array_of_tables() {
        for (i, t) in aot.iter().enumerate() {
            let last = path.pop().unwrap_or_default();
            path.push(format!("{last}[{i}]"));
            for (k, v) in t.iter() {
                path.push(k.to_string());
                if leaf_or_inner(v, at, path) {
                    return true;
                }
                path.pop();
            }
            path.pop();
            path.push(last);
        }
        return false;
    }
    if let Some(table) = item.as_table_like() {
        for (k, v) in table.iter() {
            path.push(k.to_string());
            if leaf_or_inner(v, at, path) {
                return true;
            }
            path.pop();
        }
    }
    false
}

/// Tables and arrays of tables are searched inside; any other value matches by its span.
fn leaf_or_inner(v: &toml_edit::Item, at: usize, path: &mut Vec<String>) -> bool {
    if v.is_table_like() || v.is_array_of_tables() {
        find_key(v, at, path)
    } else {
        contains(v.span(), at)
    }
}

fn contains(span: Option<Range<usize>>, at: usize) -> bool {
    span.is_some_and(|s| s.start <= at && at < s.end.max(s.start + 1))
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = "[rod]\nn_elements = 10\nlength = 0.2\nbase_diameter = 0.02\ndensity = 700.0\n\
                           youngs_modulus = 1e4\nshear_modulus = 1e3\n\n[time]\ndt = 1e-5\nduration = 0.01\n";

    fn load(text: &str) -> Result<Scenario, ScenarioError> {
        Scenario::from_str(Path::new("s.toml"), text)
    }

    #[test]
    fn minimal_scenario_gets_defaults() {
        let s = load(MINIMAL).unwrap();
        assert_eq!(s.config.rod.tip_diameter, Some(0.02));
        assert_eq!(s.config.rod.shear_coefficient, 27.0 / 28.0);
        assert_eq!(s.config.time.save_interval, 1e-3);
        assert_eq!(s.config.n_steps(), 1000);
        assert_eq!(s.config.save_every(), 100);
        assert_eq!(s.config.n_frames(), 11);
    }

    #[test]
    fn resolved_toml_round_trips() {
        let text = format!("{MINIMAL}\n[[load]]\nkind = \"tip_force\"\nvalue = [0.0, 1e-5, 0.0]\n\n[[obstacle]]\nkind = \"sphere\"\ncenter = [0.1, 0.05, 0.0]\ndiameter = 0.04\n");
        let s = load(&text).unwrap();
        let again = load(&s.resolved_toml()).unwrap();
        assert_eq!(s.config, again.config);
    }

    #[test]
    fn frame_count_includes_a_final_partial_interval() {
        let mut s = load(MINIMAL).unwrap().config;
        s.time.duration = 0.01 + 5e-5; // 1005 steps, frames at 0, 100, ..., 1000, 1005
        assert_eq!(s.n_frames(), 12);
    }

    #[test]
    fn unknown_key_suggests_the_nearest() {
        let e = load(&MINIMAL.replace("density", "densty")).unwrap_err();
        assert_eq!(e.line.map(|l| l.0), Some(5));
        assert!(
            e.message
                .contains("unknown key `densty` in [rod]; did you mean `density`?"),
            "{e}"
        );
    }

    #[test]
    fn out_of_range_names_line_key_and_range() {
        let e = load(&MINIMAL.replace("length = 0.2", "length = -0.2")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "s.toml:3:1: rod.length = -0.2 is outside the allowed range (0, inf), finite"
        );
    }

    #[test]
    fn key_span_finds_array_of_table_entries() {
        let text = format!("{MINIMAL}\n[[load]]\nkind = \"gravity\"\nvalue = [0.0, 0.0, 0.0]\n[[load]]\nkind = \"tip_force\"\nvalue = [0.0, 1.0, 0.0]\n");
        let span = key_span(&text, "load[1].value").unwrap();
        assert_eq!(line_col(&text, span.start).0, 18);
    }

    #[test]
    fn levenshtein_basics() {
        assert_eq!(levenshtein("kitten", "sitting"), 3);
        assert_eq!(levenshtein("", "abc"), 3);
        let c: Vec<String> = ["gravity", "tip_force", "uniform_force", "tip_couple"]
            .map(String::from)
            .to_vec();
        assert_eq!(nearest("tipforce", &c), Some("tip_force"));
        assert_eq!(nearest("zzzzzzzzzz", &c), None);
    }
}
