//! The serde mirror of a scenario file: one `…Config` struct per TOML section, with defaults.
//! Unknown keys are rejected everywhere. Validation is in `validate.rs`; turning a configuration
//! into physics and control objects is `build.rs`'s job.

use serde::de::{self, MapAccess, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::fmt;

/// A 3-vector as written in a scenario, `[x, y, z]`.
pub type Vec3 = [f64; 3];

/// The whole scenario file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioConfig {
    /// Free text shown in `check` and copied to `summary.json`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// `[rod]` (one rod) or `[[rod]]` (one or many): geometry, material, ends (required).
    #[serde(rename = "rod")]
    pub rods: Rods,
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
    /// `[[plane]]`: rigid planes (floors, walls), any number.
    #[serde(default, rename = "plane", skip_serializing_if = "Vec::is_empty")]
    pub planes: Vec<PlaneConfig>,
    /// `[[cylinder]]`: rigid finite cylinders, any number.
    #[serde(default, rename = "cylinder", skip_serializing_if = "Vec::is_empty")]
    pub cylinders: Vec<CylinderConfig>,
    /// `[[joint]]`: joints between rod ends, any number.
    #[serde(default, rename = "joint", skip_serializing_if = "Vec::is_empty")]
    pub joints: Vec<JointConfig>,
    /// `[initial_state]`: start from a frame of an earlier run's `trajectory.npz`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial_state: Option<InitialStateConfig>,
    /// `[controller]`: drive a rod with a controller; without it the rods run passively.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub controller: Option<ControllerConfig>,
    /// `[solver]`: how the controller's design w̄ is computed (controlled runs only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub solver: Option<SolverConfig>,
    /// `[[target]]`: task targets of the tip in time order (controlled runs only).
    #[serde(default, rename = "target", skip_serializing_if = "Vec::is_empty")]
    pub targets: Vec<TargetConfig>,
    /// `[via_path]`: a path the design target follows before the task target.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub via_path: Option<ViaPathConfig>,
    /// `[grasp]`: grasp a sphere instead of reaching (controlled runs only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grasp: Option<GraspConfig>,
    /// `[[acceptance]]`: claims about the run checked at its end (controlled runs only), reported
    /// in `summary.json` (and by `octoarm paper` in `report.md`).
    #[serde(default, rename = "acceptance", skip_serializing_if = "Vec::is_empty")]
    pub acceptance: Vec<AcceptanceConfig>,
    /// `[muscles]`: COOMM's muscles on a rod and the water around it (muscles-3d spec §1–3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub muscles: Option<MusclesConfig>,
    /// `[muscle_control]`: a design over activations solved before t = 0 and held with COOMM's
    /// ramp (muscles-3d spec §5–6); needs `[muscles]`, excludes `[controller]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub muscle_control: Option<MuscleControlConfig>,
}

/// The muscle table of `[muscles]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MuscleTableKind {
    /// COOMM's seven groups, thirteen fibres (spec §1.2).
    Coomm,
}

/// The rod damping of `[muscles]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MuscleDampingKind {
    /// COOMM's per-DOF rates (spec §3.2), replacing `[damping]` on this rod.
    Coomm,
    /// The `[damping]` section applies.
    Scenario,
}

/// `[muscles]`: muscles on one rod, its water and damping (muscles-3d spec §1–3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MusclesConfig {
    /// The rod with muscles; default the only rod.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rod: Option<String>,
    /// The muscle table; default "coomm".
    #[serde(default = "default_muscle_table")]
    pub table: MuscleTableKind,
    /// Morison drag with COOMM's coefficients (spec §3.1); default true.
    #[serde(default = "default_true")]
    pub drag: bool,
    /// "coomm" (default: COOMM's rates, spec §3.2) or "scenario" (`[damping]`).
    #[serde(default = "default_muscle_damping")]
    pub damping: MuscleDampingKind,
    /// Net weight in water, (ρ − ρ_w) g Â l̂ per element, half to each node (spec §3.3;
    /// `Load::net_weight`); default false (COOMM has none).
    #[serde(default)]
    pub net_weight: bool,
    /// Water density ρ_w of the net weight [kg/m³], in [0, inf); default 1022 (the water of
    /// the drag, spec §3.1).
    #[serde(
        default = "default_water_density",
        skip_serializing_if = "is_default_water_density"
    )]
    pub water_density: f64,
    /// Gravitational acceleration g of the net weight [m/s²], lab frame, finite; default
    /// (0, 0, −9.81).
    #[serde(
        default = "default_net_weight_gravity",
        skip_serializing_if = "is_default_net_weight_gravity"
    )]
    pub gravity: [f64; 3],
}

fn default_water_density() -> f64 {
    crate::build::WATER_DENSITY
}
fn is_default_water_density(v: &f64) -> bool {
    *v == crate::build::WATER_DENSITY
}
fn default_net_weight_gravity() -> [f64; 3] {
    [0.0, 0.0, -9.81]
}
fn is_default_net_weight_gravity(v: &[f64; 3]) -> bool {
    *v == default_net_weight_gravity()
}

/// What `[muscle_control]` designs for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MuscleTaskKind {
    /// Reach a tip point (and frame): spec §7 A, B.
    Reach,
    /// Wrap the distal arm around `[[cylinder]]` 0: spec §7 C.
    Grasp,
}

/// The target tip frame of a reach.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TipFrameKind {
    /// Point only (μ_Q = 0).
    None,
    /// COOMM's frame from the base and initial tip directions (spec §7 A).
    Coomm,
    /// COOMM's frame rolled by +90° about d*₃ (spec §7 B).
    CoommRolled,
}

/// `[muscle_control]`: the design over activations and the controller holding it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MuscleControlConfig {
    /// "reach" (default) or "grasp".
    #[serde(default = "default_muscle_task")]
    pub task: MuscleTaskKind,
    /// Reach: the tip point p* [m].
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "strict::opt_vec3"
    )]
    pub target: Option<Vec3>,
    /// Reach: instead of `target`, a reachable target pose drawn from this seed: the tip point
    /// and tip frame (weights ω = (1, 1, 1)) of the static equilibrium under random activations
    /// (per group, with probability ½ a linear profile a(s) between two U(0, 1) end values,
    /// else zero); for the 1000-target sweep. Excludes `target` and `frame`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_seed: Option<u64>,
    /// Reach: the tip frame; default "coomm".
    #[serde(default = "default_tip_frame")]
    pub frame: TipFrameKind,
    /// Stop the design as soon as spec §7 A's bounds hold (tip error ≤ 1.5e-4 L0, θ_Q ≤ 1e-3
    /// rad) instead of at convergence; default false (the sweep sets it).
    #[serde(default)]
    pub stop_at_bounds: bool,
    /// μ_p [N/m], ≥ 0; default 1e6.
    #[serde(default = "default_mu_p")]
    pub position_weight: f64,
    /// μ_Q [N m], ≥ 0; default 1e3.
    #[serde(default = "default_mu_q")]
    pub orientation_weight: f64,
    /// Grasp: attraction weight μ_g [N/m²], ≥ 0; default 1e6.
    #[serde(default = "default_mu_p")]
    pub attraction_weight: f64,
    /// Grasp: obstacle weight μ_o [N/m²], ≥ 0; default 1e7.
    #[serde(default = "default_mu_o")]
    pub obstacle_weight: f64,
    /// Grasp: sucker-side weight μ_s [N], ≥ 0; default 1e3.
    #[serde(default = "default_mu_q")]
    pub sucker_weight: f64,
    /// Grasp: continuation stages (weights × 10^(k − stages + 1)), in [1, 10]; default 4.
    #[serde(default = "default_grasp_stages")]
    pub stages: usize,
    /// Groups the design may use (others held at 0): names of "tm", "lm0".."lm3", "om_plus",
    /// "om_minus"; default all seven.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub groups: Option<Vec<String>>,
    /// L-BFGS iterations (per grasp stage), in [1, 100000]; default 2000.
    #[serde(default = "default_design_iterations")]
    pub max_iterations: usize,
    /// With `stop_at_bounds`: the design's multi-start, starts in all (the start from a = 0
    /// included), in [1, 1000]; 1 = no restart; default 8 (`DesignConfig::max_starts`; the
    /// rule is in docs/muscles.md "Multi-start").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_starts: Option<usize>,
    /// With `stop_at_bounds`: L-BFGS iterations over all starts, in [1, 10000000]; default
    /// 8000 (`DesignConfig::max_total_iterations`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_total_iterations: Option<usize>,
    /// Ramp of the activations [s], ≥ 0; default 1 (COOMM).
    #[serde(default = "default_one")]
    pub ramp: f64,
    /// Controller update interval [s], ≥ dt; default 2e-3 (500 Hz, COOMM).
    #[serde(default = "default_muscle_update")]
    pub update_interval: f64,
    /// Interval of `series.npz` samples [s], ≥ dt; default 1e-2.
    #[serde(default = "default_muscle_series")]
    pub series_interval: f64,
}

/// The rods of a scenario: a single `[rod]` table or an array `[[rod]]` of tables; written back
/// the way it was given.
#[derive(Debug, Clone, PartialEq)]
pub struct Rods {
    /// The rods, in order.
    pub list: Vec<RodConfig>,
    /// Given as one `[rod]` table (keys `rod.x`) rather than `[[rod]]` (keys `rod[i].x`).
    pub single: bool,
}

impl Serialize for Rods {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if self.single && self.list.len() == 1 {
            self.list[0].serialize(s)
        } else {
            self.list.serialize(s)
        }
    }
}

impl<'de> Deserialize<'de> for Rods {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct RodsVisitor;
        impl<'de> Visitor<'de> for RodsVisitor {
            type Value = Rods;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a [rod] table or an array of [[rod]] tables")
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Rods, A::Error> {
                let rod = RodConfig::deserialize(de::value::MapAccessDeserializer::new(map))?;
                Ok(Rods {
                    list: vec![rod],
                    single: true,
                })
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Rods, A::Error> {
                let list =
                    Vec::<RodConfig>::deserialize(de::value::SeqAccessDeserializer::new(seq))?;
                Ok(Rods {
                    list,
                    single: false,
                })
            }
        }
        d.deserialize_any(RodsVisitor)
    }
}

/// `[rod]` / `[[rod]]`: a straight rod, uniform or linearly tapered, based anywhere.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RodConfig {
    /// Name, unique, letters, digits, `_` and `-`; default `rod` (one rod) or `rod<i>`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
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
    /// Position of node 0 [m]; default the origin.
    #[serde(default, deserialize_with = "strict::vec3")]
    pub base_position: Vec3,
    /// d3 at rest (unit tangent, normalised); default [1, 0, 0].
    #[serde(default = "default_direction", deserialize_with = "strict::vec3")]
    pub direction: Vec3,
    /// d1 at rest, perpendicular to `direction`; default [0, 1, 0].
    #[serde(default = "default_normal", deserialize_with = "strict::vec3")]
    pub normal: Vec3,
    /// How the base is held; default "clamped".
    #[serde(default = "EndConfig::clamped")]
    pub base: EndConfig,
    /// How the tip is held; default "free".
    #[serde(default = "EndConfig::free")]
    pub tip: EndConfig,
    /// Uniform rest curvature κ° [1/m], material frame (κ1, κ2, κ3); default 0. Shorthand for a
    /// uniform `rest_kappa`.
    #[serde(default, deserialize_with = "strict::vec3")]
    pub rest_curvature: Vec3,
    /// Rest curvature/twist κ° [1/m] per interior node (material): a 3-vector (uniform), N − 1
    /// 3-vectors, or a piecewise-linear function of rest arc length `{ s = [...], value = [...] }`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rest_kappa: Option<Profile>,
    /// Rest shear/stretch σ° per element (material; σ°3 is the rest stretch − 1): a 3-vector, N
    /// 3-vectors, or `{ s, value }` evaluated at element midpoints.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rest_sigma: Option<Profile>,
    /// If given, the rest strains above are reached from a straight rod through this schedule:
    /// σ°(t), κ°(t) = f(t) × the given values.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rest_schedule: Option<ScheduleConfig>,
}

/// A field along a rod given as one value, one value per entry, or a function of s.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Profile {
    /// The same 3-vector everywhere.
    Uniform(Vec3),
    /// One 3-vector per element (σ°) or per interior node (κ°).
    PerEntry(Vec<Vec3>),
    /// Linear interpolation in rest arc length s [m] between samples (held outside).
    Function(ProfileFunction),
}

/// `{ s = [...], value = [[...], ...] }`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProfileFunction {
    /// Rest arc lengths [m], strictly increasing.
    pub s: Vec<f64>,
    /// One 3-vector per s.
    #[serde(deserialize_with = "strict::vec3_list")]
    pub value: Vec<Vec3>,
}

/// The end conditions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EndKind {
    /// Nothing enforced.
    Free,
    /// Position held, rotation free.
    Pinned,
    /// Position and frame held.
    Clamped,
    /// Clamped, following a prescribed motion.
    Driven,
}

/// An end condition: `"clamped"` or a table `{ kind = "driven", times, displacement, rotation }`.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum EndConfig {
    /// Only the kind (not "driven").
    Kind(EndKind),
    /// A table, required for "driven".
    Table(EndTable),
}

impl EndConfig {
    fn clamped() -> Self {
        EndConfig::Kind(EndKind::Clamped)
    }
    fn free() -> Self {
        EndConfig::Kind(EndKind::Free)
    }

    /// The kind.
    pub fn kind(&self) -> EndKind {
        match self {
            EndConfig::Kind(k) => *k,
            EndConfig::Table(t) => t.kind,
        }
    }
}

/// `{ kind, times, displacement, rotation }`: a driven end's motion relative to where it
/// starts (cosseratbench's `Motion`): at each time [s] (from 0) the end node has moved by
/// `displacement` [m] and the end frame turned by the rotation vector `rotation` [rad] (lab),
/// linear in between, held after the last.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EndTable {
    /// The kind.
    pub kind: EndKind,
    /// Sample times [s] (driven only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub times: Option<Vec<f64>>,
    /// Displacement at each time [m]; default all zero.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "strict::opt_vec3_list"
    )]
    pub displacement: Option<Vec<Vec3>>,
    /// Rotation vector at each time [rad]; default all zero.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "strict::opt_vec3_list"
    )]
    pub rotation: Option<Vec<Vec3>>,
}

/// Time schedule kinds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ScheduleKind {
    /// f = 1.
    Constant,
    /// f = min(1, t / duration).
    Ramp,
    /// f = 0 before `time`, 1 after.
    Step,
    /// f through (`times`, `values`).
    PiecewiseLinear,
}

/// `schedule = { kind = "ramp", duration = 0.5 }` and the like: a factor f(t).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScheduleConfig {
    /// The kind.
    pub kind: ScheduleKind,
    /// Ramp duration [s] (ramp).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub duration: Option<f64>,
    /// Switch-on time [s] (step).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time: Option<f64>,
    /// Sample times [s] (piecewise_linear).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub times: Option<Vec<f64>>,
    /// Factors at the sample times (piecewise_linear).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub values: Option<Vec<f64>>,
}

/// `[time]`: the time step and how long and how often to record.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "TimeToml", into = "TimeToml")]
pub struct TimeConfig {
    /// Time step Δt [s], > 0 (the only copy of dt; the stepper gets it from here). With
    /// `dt = "auto"` in the file, the value chosen when the scenario was loaded.
    pub dt: f64,
    /// `dt = "auto"`: dt is `AUTO_DT_FRACTION` (0.2) of the system's stable limit, rounded down
    /// to divide the shortest sampling interval, and the guard re-checks it against the limit
    /// of the deformed state (`octoarm_physics::auto_dt`).
    pub auto_dt: bool,
    /// Simulated duration [s], ≥ dt; rounded to a whole number of steps.
    pub duration: f64,
    /// Simulated time between recorded frames [s], ≥ dt; default 1e-3 s. Rounded to a whole
    /// number of steps; t = 0 and the final state are always recorded.
    pub save_interval: f64,
}

/// `time.dt` as written: seconds or the word "auto".
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DtToml {
    /// A time step in seconds.
    Seconds(f64),
    /// `"auto"`.
    Auto,
}

impl Serialize for DtToml {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Self::Seconds(v) => s.serialize_f64(*v),
            Self::Auto => s.serialize_str("auto"),
        }
    }
}

impl<'de> Deserialize<'de> for DtToml {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = DtToml;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a time step in seconds (e.g. 1.0e-5) or \"auto\"")
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<DtToml, E> {
                Ok(DtToml::Seconds(v))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<DtToml, E> {
                Ok(DtToml::Seconds(v as f64))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<DtToml, E> {
                Ok(DtToml::Seconds(v as f64))
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<DtToml, E> {
                if v == "auto" {
                    Ok(DtToml::Auto)
                } else {
                    Err(E::custom(format!(
                        "time.dt = \"{v}\" is not allowed: write a time step in seconds \
                         (> 0, e.g. 1.0e-5) or \"auto\" (0.2 × the stable limit)"
                    )))
                }
            }
        }
        d.deserialize_any(V)
    }
}

/// `[time]` as written in the file (see `TimeConfig`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeToml {
    /// Seconds, or "auto".
    pub dt: DtToml,
    /// Simulated duration [s].
    pub duration: f64,
    /// Simulated time between recorded frames [s].
    #[serde(default = "default_save_interval")]
    pub save_interval: f64,
}

impl TryFrom<TimeToml> for TimeConfig {
    type Error = String;
    fn try_from(t: TimeToml) -> Result<Self, String> {
        let (dt, auto_dt) = match t.dt {
            DtToml::Seconds(dt) => (dt, false),
            DtToml::Auto => (0.0, true),
        };
        Ok(Self {
            dt,
            auto_dt,
            duration: t.duration,
            save_interval: t.save_interval,
        })
    }
}

impl From<TimeConfig> for TimeToml {
    fn from(t: TimeConfig) -> Self {
        Self {
            dt: if t.auto_dt {
                DtToml::Auto
            } else {
                DtToml::Seconds(t.dt)
            },
            duration: t.duration,
            save_interval: t.save_interval,
        }
    }
}

/// How damping is integrated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DampingProtocol {
    /// octoarm's: the linear damping integrated exactly inside the kick,
    /// v ← e^(−νΔt) v + Δt φ1(νΔt) a (spec §8a).
    #[default]
    Exact,
    /// PyElastica's `AnalyticalLinearDamper(uniform_damping_constant = rate)`: the plain kick,
    /// then v ← e^(−νΔt) v, ω ← e^(−νΔt) ω (spec §8b).
    Pyelastica,
}

/// `[damping]`: viscous damping of every rod (spec §8).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DampingConfig {
    /// Mass-proportional decay rate ν_d [1/s], ≥ 0; default 0.
    #[serde(default)]
    pub rate: f64,
    /// The paper's per-unit-length coefficient γ [kg/(m s)], ≥ 0; default 0 (exact protocol only).
    #[serde(default)]
    pub gamma: f64,
    /// "exact" (default) or "pyelastica".
    #[serde(default)]
    pub protocol: DampingProtocol,
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
    /// Clamp formulation: 1 (default, the rigid clamped element of PyElastica) or 2 (the
    /// second-order clamp, docs/physics.md).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clamp_order: Option<u8>,
}

impl Default for NumericsConfig {
    fn default() -> Self {
        Self {
            energy_consistent: false,
            guard_interval: default_guard_interval(),
            clamp_order: None,
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
    /// Whether different rods touch each other; default false.
    #[serde(default, skip_serializing_if = "is_false")]
    pub rods: bool,
    /// Whether a rod touches itself; default false.
    #[serde(default, skip_serializing_if = "is_false")]
    pub self_contact: bool,
    /// Static Coulomb friction between rods: a number, or [forward, backward, lateral]; default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rod_friction: Option<FrictionValue>,
    /// Kinetic friction between rods (≤ the static one); default the static one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rod_kinetic_friction: Option<FrictionValue>,
    /// Friction regularisation η in (0, 1]: viscosity η m / Δt; default 0.5.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction_eta: Option<f64>,
    /// Stick-spring stiffness of obstacle friction / contact stiffness, in (0, 1]; default 0.5.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stick_stiffness: Option<f64>,
    /// Slip speed of rod–rod friction [m/s], > 0; default 1e-3.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slip_velocity: Option<f64>,
    /// The centreline rod–rod contact measures gaps on: "polyline" (default) or "smooth".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rod_geometry: Option<RodGeometryName>,
}

/// `[contact] rod_geometry`: straight segments between nodes, or their cubic B-spline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RodGeometryName {
    /// Straight segments (PyElastica's geometry).
    Polyline,
    /// The uniform cubic B-spline with the nodes as control points.
    Smooth,
}

impl Default for ContactConfig {
    fn default() -> Self {
        Self {
            beta: default_beta(),
            zeta: default_zeta(),
            rods: false,
            self_contact: false,
            rod_friction: None,
            rod_kinetic_friction: None,
            friction_eta: None,
            stick_stiffness: None,
            slip_velocity: None,
            rod_geometry: None,
        }
    }
}

fn is_false(b: &bool) -> bool {
    !*b
}

/// A friction coefficient: one number (isotropic) or three (forward, backward, lateral).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum FrictionValue {
    /// The same coefficient in every direction.
    Isotropic(f64),
    /// Forward (along the rod, base → tip), backward, lateral.
    Anisotropic([f64; 3]),
}

impl FrictionValue {
    /// The three coefficients.
    pub fn three(self) -> [f64; 3] {
        match self {
            FrictionValue::Isotropic(m) => [m; 3],
            FrictionValue::Anisotropic(m) => m,
        }
    }
}

/// `[[plane]]`: a rigid unbounded plane that every rod touches.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlaneConfig {
    /// A point on the plane [m].
    #[serde(deserialize_with = "strict::vec3")]
    pub point: Vec3,
    /// Normal towards the rods (any length > 0).
    #[serde(deserialize_with = "strict::vec3")]
    pub normal: Vec3,
    /// Static Coulomb friction (number or [forward, backward, lateral]); default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<FrictionValue>,
    /// Kinetic friction (≤ static); default the static one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kinetic_friction: Option<FrictionValue>,
}

/// `[[cylinder]]`: a rigid finite cylinder (a capsule: round ends) that every rod touches.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CylinderConfig {
    /// Centre of the axis at t = 0 [m].
    #[serde(deserialize_with = "strict::vec3")]
    pub center: Vec3,
    /// Axis direction (any length > 0).
    #[serde(deserialize_with = "strict::vec3")]
    pub axis: Vec3,
    /// Diameter [m], > 0.
    pub diameter: f64,
    /// Length of the axis [m], ≥ 0.
    pub length: f64,
    /// Constant velocity [m/s]; default 0.
    #[serde(default, deserialize_with = "strict::vec3")]
    pub velocity: Vec3,
    /// Static Coulomb friction (number or [forward, backward, lateral]); default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<FrictionValue>,
    /// Kinetic friction (≤ static); default the static one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kinetic_friction: Option<FrictionValue>,
}

/// The kinds of `[[load]]` (spec §9).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LoadKind {
    /// Uniform acceleration g [m/s²] on every node's mass (every rod unless `rod` is given).
    Gravity,
    /// Point force [N] on the tip node, lab frame.
    TipForce,
    /// Point force [N] on the node `node` (or nearest to arc length `s`), lab frame.
    NodeForce,
    /// Constant distributed force [N/m] per unit rest length, lab frame.
    UniformForce,
    /// Lab-frame point couple [N m] on the tip element.
    TipCouple,
    /// Lab-frame point couple [N m] on element `element` (or the one containing `s`).
    ElementCouple,
    /// Material-frame (follower) point couple [N m] on element `element` (or containing `s`).
    FollowerCouple,
    /// Lab-frame distributed couple [N m/m] per unit rest length.
    UniformCouple,
    /// Material-frame (follower) distributed couple [N m/m] per unit rest length.
    UniformFollowerCouple,
}

impl LoadKind {
    /// Unit of `value` for this kind.
    pub fn unit(self) -> &'static str {
        match self {
            LoadKind::Gravity => "m/s^2",
            LoadKind::TipForce | LoadKind::NodeForce => "N",
            LoadKind::UniformForce => "N/m",
            LoadKind::TipCouple | LoadKind::ElementCouple | LoadKind::FollowerCouple => "N m",
            LoadKind::UniformCouple | LoadKind::UniformFollowerCouple => "N m/m",
        }
    }

    /// The name used in scenario files.
    pub fn name(self) -> &'static str {
        match self {
            LoadKind::Gravity => "gravity",
            LoadKind::TipForce => "tip_force",
            LoadKind::NodeForce => "node_force",
            LoadKind::UniformForce => "uniform_force",
            LoadKind::TipCouple => "tip_couple",
            LoadKind::ElementCouple => "element_couple",
            LoadKind::FollowerCouple => "follower_couple",
            LoadKind::UniformCouple => "uniform_couple",
            LoadKind::UniformFollowerCouple => "uniform_follower_couple",
        }
    }

    /// Whether the load sits on one node (given by `node` or `s`).
    pub fn at_node(self) -> bool {
        matches!(self, LoadKind::NodeForce)
    }

    /// Whether the load sits on one element (given by `element` or `s`).
    pub fn at_element(self) -> bool {
        matches!(self, LoadKind::ElementCouple | LoadKind::FollowerCouple)
    }
}

/// `[[load]]`: one external load, scaled by an optional schedule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoadConfig {
    /// What the load is.
    pub kind: LoadKind,
    /// Vector value in the kind's unit, lab frame (material frame for follower couples).
    #[serde(deserialize_with = "strict::vec3")]
    pub value: Vec3,
    /// The rod it acts on, by name; default the only rod (gravity: every rod).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rod: Option<String>,
    /// Node index (node_force), in [0, N].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node: Option<usize>,
    /// Element index (element_couple, follower_couple), in [0, N − 1].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub element: Option<usize>,
    /// Rest arc length [m] instead of an index: the nearest node, or the element containing it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub s: Option<f64>,
    /// Ramp linearly from 0 over this time [s], ≥ 0 (shorthand for a ramp schedule; 0 = none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ramp_time: Option<f64>,
    /// Time factor of the load; default constant.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub schedule: Option<ScheduleConfig>,
}

/// The kinds of `[[obstacle]]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ObstacleKind {
    /// A rigid sphere.
    Sphere,
}

/// `[[obstacle]]`: one rigid obstacle (spec §10), touching every rod.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObstacleConfig {
    /// What the obstacle is.
    pub kind: ObstacleKind,
    /// Centre at t = 0 [m].
    #[serde(deserialize_with = "strict::vec3")]
    pub center: Vec3,
    /// Diameter [m], > 0.
    pub diameter: f64,
    /// Constant velocity of the centre [m/s]; default 0 (fixed).
    #[serde(default, deserialize_with = "strict::vec3")]
    pub velocity: Vec3,
    /// Static Coulomb friction (number or [forward, backward, lateral]); default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<FrictionValue>,
    /// Kinetic friction (≤ static); default the static one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kinetic_friction: Option<FrictionValue>,
}

/// The kinds of `[[joint]]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JointKindConfig {
    /// Relative position (PyElastica's FreeJoint).
    Free,
    /// Relative position and rotation except about `axis` (HingeJoint).
    Hinge,
    /// Relative position and orientation (FixedJoint).
    Fixed,
}

/// `[[joint]]`: penalty springs between two rod ends, e.g. `first = "body.tip"`,
/// `second = "arm.base"`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointConfig {
    /// What it constrains.
    pub kind: JointKindConfig,
    /// `"<rod name>.base"` or `"<rod name>.tip"`.
    pub first: String,
    /// The other end.
    pub second: String,
    /// Hinge axis, lab frame at t = 0 (hinge only).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "strict::opt_vec3"
    )]
    pub axis: Option<Vec3>,
    /// k [N/m], ≥ 0; default the softer end element's E Â/l̂.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiffness: Option<f64>,
    /// ν [N s/m], ≥ 0; default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub damping: Option<f64>,
    /// k_t [N m/rad], ≥ 0; default the end elements' weighted E I₁ over their mean length.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotational_stiffness: Option<f64>,
    /// ν_t [N m s/rad], ≥ 0; default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotational_damping: Option<f64>,
}

/// `[initial_state]`: positions, directors, velocities and angular velocities of every rod
/// from one frame of an earlier run's `trajectory.npz` (same rods, same element counts); the
/// run continues from that frame's time and step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialStateConfig {
    /// Path of the `trajectory.npz`, relative to the scenario file's folder.
    pub file: String,
    /// Frame index (negative counts from the end: −1 is the last); default −1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame: Option<i64>,
    /// Instead of `frame`: the frame recorded at this time [s] (within half a step).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time: Option<f64>,
}

/// The kinds of `[controller]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ControllerKind {
    /// The energy-shaping law (control spec §4) with the damping of `[damping]`.
    EnergyShaping,
}

/// `[controller]`: the closed loop of a controlled run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerConfig {
    /// The control law.
    pub kind: ControllerKind,
    /// The rod it controls, by name; default the only rod.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rod: Option<String>,
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
    /// A few warm-started iterations every `update_interval` (control spec §3.3).
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
    /// Iterations over which the relative decrease of J is measured, in [1, 1000000]; default 20.
    #[serde(default = "default_stall_window")]
    pub stall_window: usize,
    /// Stop when J fell by less than this relative amount over the window, ≥ 0; default 1e-12.
    #[serde(default = "default_stall_tolerance")]
    pub stall_tolerance: f64,
    /// Largest number of sweeps of an offline solve, in [1, 10000000]; default 20000.
    #[serde(default = "default_max_sweeps")]
    pub max_sweeps: usize,
    /// Online: simulated time between design updates [s], ≥ dt; default 1e-3.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub update_interval: Option<f64>,
    /// Deprecated: `update_interval` in steps (converted on load).
    #[serde(default, skip_serializing)]
    pub update_every: Option<u64>,
    /// Online: solver iterations per update, in [1, 100000]; default 10.
    #[serde(default = "default_iterations_per_update")]
    pub iterations_per_update: usize,
    /// Online: cap each strain's change per update so that the first design needs about this
    /// long to form [s], > 0; default none (no trust region).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trust_form_time: Option<f64>,
    /// Online: solve the design for the first target offline before t = 0 and start the online
    /// updates from it; default false.
    #[serde(default)]
    pub presolve: bool,
    /// Offline grasp: stages of the μ_grasp continuation, in [1, 1000]; default 4.
    #[serde(default = "default_grasp_stages")]
    pub grasp_stages: usize,
    /// Offline: apply each new design through a linear ramp of this length [s], ≥ 0; default 0.
    #[serde(default)]
    pub ramp_time: f64,
    /// Offline: simulated time between design switches and ramp increments [s], ≥ dt; default
    /// 1e-3.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ramp_interval: Option<f64>,
    /// Deprecated: `ramp_interval` in steps (converted on load).
    #[serde(default, skip_serializing)]
    pub ramp_every: Option<u64>,
}

/// `[[target]]`: a tip target in force from `from` on, r*(t) = position + velocity (t − from).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetConfig {
    /// Target at time `from` [m], lab frame.
    #[serde(deserialize_with = "strict::vec3")]
    pub position: Vec3,
    /// Start of this target [s], ≥ 0; default 0. Targets must be in time order.
    #[serde(default)]
    pub from: f64,
    /// Constant velocity [m/s]; default 0 (a static target).
    #[serde(default, deserialize_with = "strict::vec3")]
    pub velocity: Vec3,
}

/// `[via_path]`: the design target runs at constant speed along `points` from `start` to `end`
/// [s] and the task target takes over at `end`; the distance d is always to the task target.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViaPathConfig {
    /// Corner points [m], at least two.
    #[serde(deserialize_with = "strict::vec3_list")]
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
    #[serde(deserialize_with = "strict::vec3")]
    pub center: Vec3,
    /// Diameter of the sphere [m], > 0.
    pub diameter: f64,
    /// μ_grasp on the interval [N/m], > 0; default 1e3.
    #[serde(default = "default_mu_tip")]
    pub mu_grasp: f64,
    /// Grasping interval as fractions of L0, `[a, 1.0]` with 0 ≤ a < 1; default [0.4, 1.0].
    #[serde(default = "default_grasp_interval", deserialize_with = "strict::vec2")]
    pub interval: [f64; 2],
}

/// What an acceptance check measures (control spec §5.1 figures, from the series).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AcceptanceQuantity {
    /// d of the last sample before `time`.
    DistanceBefore,
    /// d of the first sample at or after `time`.
    DistanceAfter,
    /// d of the sample at `time` (the run must reach it).
    DistanceAt,
    /// Largest d over samples in [`from`, `to`] (the run must reach `to`).
    MaxDistance,
    /// Largest d(t) − d(0) over the run.
    DistanceRise,
    /// Settling time of segment `segment` (0-based; a new segment starts at each target),
    /// measured from the segment's start [s].
    SettlingTime,
    /// Largest penetration into a sphere over the samples [m].
    MaxPenetration,
    /// Largest design tip error / L0 of the online updates at or after `time`.
    DesignTipError,
    /// Muscle design: tip-point error / L0.
    MuscleDesignTipError,
    /// Muscle design: θ_Q [rad].
    MuscleDesignOrientationError,
    /// Muscle design: J.
    MuscleDesignCost,
    /// Muscle design: scaled equilibrium residual ρ_R.
    MuscleDesignResidual,
    /// Muscle design: max_k D̂_k |κ_k| [rad].
    MuscleDesignMaxTurn,
    /// Muscle design: ∫ a ds / L0 of `group`.
    MuscleGroupIntegral,
    /// Muscle design: ∫ (a_OM+ + a_OM−) ds / L0.
    MuscleObliqueIntegral,
    /// Muscle design: activations outside [0, 1] (count).
    MuscleActivationViolations,
    /// Muscle design: total twist Σ D̂ κ₃ [rad].
    MuscleDesignTwist,
    /// Muscle design (grasp): wrap angle [deg].
    MuscleDesignWrapAngle,
    /// Muscle design (grasp): penetration max(−ζ) [m].
    MuscleDesignPenetration,
    /// Muscle design (grasp): mean |ζ| [m].
    MuscleDesignMeanGap,
    /// Muscle design (grasp): max |ζ| [m].
    MuscleDesignMaxGap,
    /// Muscle design (grasp): sucker alignment ᾱ.
    MuscleDesignSuckerAlignment,
    /// Muscle run: tip-point error / L0 at `time`.
    TipErrorAt,
    /// Muscle run: θ_Q [rad] at `time`.
    OrientationErrorAt,
    /// Muscle run: largest rise of the tip error / L0 sampled every 0.5 s from `time` on.
    TipErrorRise,
    /// Muscle run: max over nodes |x_i(T) − x_i^design| / L0 at the end, if the run reached `time`.
    NodeDeviation,
    /// Muscle run: largest 𝓗 rise between samples from `time` on / (𝓗(time) − 𝓗(T)).
    HamiltonianRise,
    /// Muscle run: 𝓗(T) − 𝓗(time) [J].
    HamiltonianChange,
    /// Muscle run (grasp): largest penetration max(−ζ) over every sample up to `time` [m].
    GraspPenetration,
    /// Muscle run (grasp): wrap angle at the end, if the run reached `time` [deg].
    GraspWrapAngle,
    /// Muscle run (grasp): mean |ζ| at the end, if the run reached `time` [m].
    GraspMeanGap,
}

impl AcceptanceQuantity {
    /// Whether the quantity is about a `[muscle_control]` run.
    pub fn is_muscle(self) -> bool {
        use AcceptanceQuantity as Q;
        !matches!(
            self,
            Q::DistanceBefore
                | Q::DistanceAfter
                | Q::DistanceAt
                | Q::MaxDistance
                | Q::DistanceRise
                | Q::SettlingTime
                | Q::MaxPenetration
                | Q::DesignTipError
        )
    }
}

/// `[[acceptance]]`: a claim `min ≤ quantity ≤ max`, reported pass / fail / undecided (the
/// run ended before the time the claim is about).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AcceptanceConfig {
    /// The claim in words, as reported.
    pub claim: String,
    /// What is measured.
    pub quantity: AcceptanceQuantity,
    /// Time [s] (distance_before/after/at, design_tip_error).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time: Option<f64>,
    /// Start of the interval [s] (max_distance).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub from: Option<f64>,
    /// End of the interval [s] (max_distance).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub to: Option<f64>,
    /// Segment index (settling_time).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub segment: Option<usize>,
    /// Lower bound.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min: Option<f64>,
    /// Upper bound.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max: Option<f64>,
    /// A remark shown beside the verdict.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    /// The claim is known not to hold as stated (its `note` says why): it is still checked and
    /// reported, but its failure does not make `octoarm paper` exit with code 3.
    #[serde(default, skip_serializing_if = "is_false")]
    pub infeasible: bool,
    /// The muscle group of `muscle_group_integral` ("tm", "lm0".."lm3", "om_plus", "om_minus").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub group: Option<String>,
}

fn default_muscle_table() -> MuscleTableKind {
    MuscleTableKind::Coomm
}
fn default_muscle_damping() -> MuscleDampingKind {
    MuscleDampingKind::Coomm
}
fn default_muscle_task() -> MuscleTaskKind {
    MuscleTaskKind::Reach
}
fn default_tip_frame() -> TipFrameKind {
    TipFrameKind::Coomm
}
fn default_mu_p() -> f64 {
    1.0e6
}
fn default_mu_q() -> f64 {
    1.0e3
}
fn default_mu_o() -> f64 {
    1.0e7
}
fn default_design_iterations() -> usize {
    2000
}
fn default_one() -> f64 {
    1.0
}
fn default_muscle_update() -> f64 {
    2.0e-3
}
fn default_muscle_series() -> f64 {
    1.0e-2
}

/// The group names of `[muscle_control].groups` and `acceptance.group`, in group order.
pub const MUSCLE_GROUP_NAMES: [&str; 7] = ["tm", "lm0", "lm1", "lm2", "lm3", "om_plus", "om_minus"];

pub(crate) fn default_shear_coefficient() -> f64 {
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
fn default_iterations_per_update() -> usize {
    10
}
fn default_grasp_stages() -> usize {
    4
}
fn default_grasp_interval() -> [f64; 2] {
    [0.4, 1.0]
}

impl<'de> Deserialize<'de> for Profile {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct ProfileVisitor;
        impl<'de> Visitor<'de> for ProfileVisitor {
            type Value = Profile;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(
                    "a 3-vector [x, y, z], an array of 3-vectors or a table \
                     { s = [...], value = [[x, y, z], ...] }",
                )
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Profile, A::Error> {
                let mut entries = Vec::new();
                while let Some(e) = seq.next_element::<strict::Loose>()? {
                    entries.push(e);
                }
                if entries.is_empty() {
                    return Ok(Profile::PerEntry(Vec::new()));
                }
                if entries.iter().all(|e| matches!(e, strict::Loose::Num(_))) {
                    return strict::three(&entries)
                        .map(Profile::Uniform)
                        .map_err(de::Error::custom);
                }
                if entries.iter().all(|e| matches!(e, strict::Loose::Seq(_))) {
                    let mut out = Vec::with_capacity(entries.len());
                    for (i, e) in entries.iter().enumerate() {
                        let strict::Loose::Seq(inner) = e else {
                            unreachable!("checked above")
                        };
                        out.push(
                            strict::three(inner)
                                .map_err(|m| de::Error::custom(format!("entry [{i}]: {m}")))?,
                        );
                    }
                    return Ok(Profile::PerEntry(out));
                }
                Err(de::Error::custom(format!(
                    "expected 3 numbers [x, y, z] (uniform) or an array of 3-vectors \
                     [[x, y, z], ...], found {}",
                    strict::describe(&entries)
                )))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Profile, A::Error> {
                ProfileFunction::deserialize(de::value::MapAccessDeserializer::new(map))
                    .map(Profile::Function)
            }
        }
        d.deserialize_any(ProfileVisitor)
    }
}

impl<'de> Deserialize<'de> for EndConfig {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct EndVisitor;
        impl<'de> Visitor<'de> for EndVisitor {
            type Value = EndConfig;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(
                    "\"free\", \"pinned\", \"clamped\" or a table { kind = \"driven\", times = [...], \
                     displacement = [...], rotation = [...] }",
                )
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<EndConfig, E> {
                use de::IntoDeserializer;
                let found: Result<EndKind, E> = EndKind::deserialize(v.into_deserializer());
                found.map(EndConfig::Kind).map_err(|_: E| {
                    let kinds: Vec<String> = ["free", "pinned", "clamped", "driven"]
                        .map(String::from)
                        .to_vec();
                    let hint = super::nearest(v, &kinds)
                        .map(|k| format!("; did you mean \"{k}\"?"))
                        .unwrap_or_default();
                    E::custom(format!(
                        "expected \"free\", \"pinned\", \"clamped\" or a table {{ kind = \"driven\", \
                         times = [...], displacement = [...], rotation = [...] }}, found \"{v}\"{hint}"
                    ))
                })
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<EndConfig, A::Error> {
                EndTable::deserialize(de::value::MapAccessDeserializer::new(map))
                    .map(EndConfig::Table)
            }
        }
        d.deserialize_any(EndVisitor)
    }
}

/// Strict fixed-length numeric arrays: a 3-vector is exactly 3 numbers (integers allowed), never
/// cut or padded; anything else is an error saying so ("expected 3 numbers [x, y, z], found 6
/// entries: 4 numbers, a string and a boolean"), which the TOML layer locates at the key.
pub(crate) mod strict {
    use super::Vec3;
    use serde::de::{self, Deserialize, Deserializer, IgnoredAny, MapAccess, SeqAccess, Visitor};
    use std::fmt;

    /// One array entry as found: a number, an array, or something else (named).
    pub(crate) enum Loose {
        Num(f64),
        Seq(Vec<Loose>),
        Other(&'static str),
    }

    impl<'de> Deserialize<'de> for Loose {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            struct LooseVisitor;
            impl<'de> Visitor<'de> for LooseVisitor {
                type Value = Loose;
                fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                    f.write_str("a number")
                }
                fn visit_f64<E: de::Error>(self, v: f64) -> Result<Loose, E> {
                    Ok(Loose::Num(v))
                }
                fn visit_i64<E: de::Error>(self, v: i64) -> Result<Loose, E> {
                    Ok(Loose::Num(v as f64))
                }
                fn visit_u64<E: de::Error>(self, v: u64) -> Result<Loose, E> {
                    Ok(Loose::Num(v as f64))
                }
                fn visit_bool<E: de::Error>(self, _: bool) -> Result<Loose, E> {
                    Ok(Loose::Other("a boolean"))
                }
                fn visit_str<E: de::Error>(self, _: &str) -> Result<Loose, E> {
                    Ok(Loose::Other("a string"))
                }
                fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Loose, A::Error> {
                    let mut v = Vec::new();
                    while let Some(e) = seq.next_element::<Loose>()? {
                        v.push(e);
                    }
                    Ok(Loose::Seq(v))
                }
                fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Loose, A::Error> {
                    while map.next_entry::<IgnoredAny, IgnoredAny>()?.is_some() {}
                    Ok(Loose::Other("a table"))
                }
            }
            d.deserialize_any(LooseVisitor)
        }
    }

    /// "6 entries: 4 numbers, a string and a boolean".
    pub(crate) fn describe(entries: &[Loose]) -> String {
        let nums = entries
            .iter()
            .filter(|e| matches!(e, Loose::Num(_)))
            .count();
        let arrays = entries
            .iter()
            .filter(|e| matches!(e, Loose::Seq(_)))
            .count();
        let mut parts = Vec::new();
        match nums {
            0 => {}
            1 => parts.push("1 number".to_string()),
            k => parts.push(format!("{k} numbers")),
        }
        match arrays {
            0 => {}
            1 => parts.push("an array".to_string()),
            k => parts.push(format!("{k} arrays")),
        }
        for e in entries {
            if let Loose::Other(what) = e {
                if !parts.iter().any(|p| p == what) {
                    parts.push(what.to_string());
                }
            }
        }
        let list = match parts.len() {
            0 => String::new(),
            1 => parts[0].clone(),
            k => format!("{} and {}", parts[..k - 1].join(", "), parts[k - 1]),
        };
        let n = entries.len();
        format!("{n} {}: {list}", if n == 1 { "entry" } else { "entries" })
    }

    fn exactly<const K: usize>(entries: &[Loose], shape: &str) -> Result<[f64; K], String> {
        if entries.len() == K {
            let mut out = [0.0; K];
            let mut ok = true;
            for (o, e) in out.iter_mut().zip(entries) {
                match e {
                    Loose::Num(v) => *o = *v,
                    _ => ok = false,
                }
            }
            if ok {
                return Ok(out);
            }
        }
        Err(format!(
            "expected {K} numbers {shape}, found {}",
            describe(entries)
        ))
    }

    /// Exactly three numbers.
    pub(crate) fn three(entries: &[Loose]) -> Result<Vec3, String> {
        exactly::<3>(entries, "[x, y, z]")
    }

    struct Fixed<const K: usize>(&'static str);

    impl<'de, const K: usize> Visitor<'de> for Fixed<K> {
        type Value = [f64; K];
        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            write!(f, "{K} numbers {}", self.0)
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<[f64; K], A::Error> {
            let mut entries = Vec::new();
            while let Some(e) = seq.next_element::<Loose>()? {
                entries.push(e);
            }
            exactly::<K>(&entries, self.0).map_err(de::Error::custom)
        }
    }

    /// `[x, y, z]`.
    pub(crate) fn vec3<'de, D: Deserializer<'de>>(d: D) -> Result<Vec3, D::Error> {
        d.deserialize_seq(Fixed::<3>("[x, y, z]"))
    }

    /// `[a, b]`.
    pub(crate) fn vec2<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 2], D::Error> {
        d.deserialize_seq(Fixed::<2>("[a, b]"))
    }

    /// An optional `[x, y, z]` (with `#[serde(default)]`).
    pub(crate) fn opt_vec3<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Vec3>, D::Error> {
        vec3(d).map(Some)
    }

    /// `[[x, y, z], ...]`, each entry exactly 3 numbers.
    pub(crate) fn vec3_list<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<Vec3>, D::Error> {
        struct ListVisitor;
        impl<'de> Visitor<'de> for ListVisitor {
            type Value = Vec<Vec3>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an array of 3-vectors [[x, y, z], ...]")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<Vec3>, A::Error> {
                let mut out = Vec::new();
                while let Some(e) = seq.next_element::<Loose>()? {
                    let i = out.len();
                    let v = match &e {
                        Loose::Seq(inner) => three(inner),
                        other => Err(format!(
                            "expected 3 numbers [x, y, z], found {}",
                            describe(std::slice::from_ref(other)).trim_start_matches("1 entry: ")
                        )),
                    };
                    out.push(v.map_err(|m| de::Error::custom(format!("entry [{i}]: {m}")))?);
                }
                Ok(out)
            }
        }
        d.deserialize_seq(ListVisitor)
    }

    /// An optional `[[x, y, z], ...]` (with `#[serde(default)]`).
    pub(crate) fn opt_vec3_list<'de, D: Deserializer<'de>>(
        d: D,
    ) -> Result<Option<Vec<Vec3>>, D::Error> {
        vec3_list(d).map(Some)
    }
}
