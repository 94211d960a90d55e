//! Error types of the control crate, one enum per module boundary: building the statics of a rod
//! model, checking a task, solving, and driving the rod with the energy-shaping law. Every input
//! error names the field, the value and the allowed range. Detected outcomes that still give a
//! usable answer (unreachable target, initial penetration) are `solver::Warning`s, not errors.

use octoarm_physics::{ModelError, Vec3};

/// Problems building the strain-space statics of a rod model.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StaticsError {
    /// A scalar setting outside its range.
    #[error("{field} = {value} is outside the allowed range {range}")]
    OutOfRange {
        /// Name of the setting.
        field: &'static str,
        /// Value given.
        value: f64,
        /// Allowed range.
        range: &'static str,
    },
    /// The planar strain space needs a base frame with d3 in the x–y plane and one transverse
    /// director along ±e_z.
    #[error("planar strains need a base frame with one transverse director along ±e_z and d3 in the x–y plane; base frame rows are {frame:?}")]
    NotPlanar {
        /// Base director matrix (rows d1, d2, d3).
        frame: [[f64; 3]; 3],
    },
    /// The model has a free base; the statics needs a clamped base.
    #[error("the strain-space statics needs a rod clamped at its base and free at its tip")]
    FreeBase,
}

/// A task that cannot be solved as given.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TaskError {
    /// A scalar outside its range (negative weight, non-positive diameter, …).
    #[error("{field} = {value} is outside the allowed range {range}")]
    OutOfRange {
        /// Name of the field, e.g. `obstacles[1].diameter`.
        field: String,
        /// Value given.
        value: f64,
        /// Allowed range.
        range: &'static str,
    },
    /// A point that must lie in the plane of a planar task does not.
    #[error("{field} = {value:?} is off the plane z = {plane_z} of the planar strain space (|Δz| must be ≤ 1e-12 m)")]
    OffPlane {
        /// Name of the field.
        field: String,
        /// Point given [m].
        value: Vec3,
        /// z of the arm's plane [m].
        plane_z: f64,
    },
    /// A target farther from the base than 1.5 L0.
    #[error("target {value:?} is {distance} m from the base; the allowed range is [0, {limit}] m (1.5 L0)")]
    TargetTooFar {
        /// Target [m].
        value: Vec3,
        /// Distance to the base [m].
        distance: f64,
        /// 1.5 L0 [m].
        limit: f64,
    },
    /// An obstacle that contains the clamped base.
    #[error("obstacles[{index}] (centre {center:?}, diameter {diameter} m) contains the base: distance {distance} m < {limit} m = (diameter + base diameter)/2")]
    ObstacleContainsBase {
        /// Index of the obstacle.
        index: usize,
        /// Centre [m].
        center: Vec3,
        /// Diameter [m].
        diameter: f64,
        /// Distance from the base to the centre [m].
        distance: f64,
        /// Smallest allowed distance [m].
        limit: f64,
    },
    /// Per-node grasp weights of the wrong length.
    #[error("grasp.weight has {len} node weights, expected {expected} (one per node)")]
    BadLength {
        /// Length given.
        len: usize,
        /// Expected length.
        expected: usize,
    },
}

/// Failures of the forward–backward solver.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SolveError {
    /// The task was rejected before the first sweep.
    #[error("bad task: {0}")]
    Task(#[from] TaskError),
    /// A setting of the solver is out of range.
    #[error("{field} = {value} is outside the allowed range {range}")]
    Config {
        /// Name of the setting.
        field: &'static str,
        /// Value given.
        value: f64,
        /// Allowed range.
        range: &'static str,
    },
    /// The warm start has the wrong size or non-finite entries.
    #[error("initial strain field: {reason}")]
    BadInitial {
        /// What is wrong.
        reason: String,
    },
    /// The iteration failed 30 times in a row (non-finite cost, or rules R/P: the cost rose by
    /// more than 1e-3 relative at the configured step). The last good strains are kept.
    #[error("solver diverged at iteration {iteration} (last good cost {last_cost:e} J); {hint}")]
    Diverged {
        /// Iteration at which the solver gave up.
        iteration: usize,
        /// Cost of the last good iterate [J].
        last_cost: f64,
        /// What to change.
        hint: &'static str,
    },
}

/// Problems configuring or running the energy-shaping controller.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ShapingError {
    /// The design cannot be handed to the rod (spec §2.7): a turning angle D̂|κ| ≥ π/2 or a
    /// stretch ν3 ≤ 0, or a non-finite entry.
    #[error("degenerate design: {what} = {value} at {domain} {index} (allowed {range})")]
    DegenerateDesign {
        /// Quantity.
        what: &'static str,
        /// Value found.
        value: f64,
        /// `element` or `interior point`.
        domain: &'static str,
        /// Index in that domain.
        index: usize,
        /// Allowed range.
        range: &'static str,
    },
    /// The design has a different number of elements than the rod.
    #[error("design has {len} elements, the rod has {expected}")]
    BadLength {
        /// Elements in the design.
        len: usize,
        /// Elements of the rod.
        expected: usize,
    },
    /// A controller setting out of range.
    #[error("{field} = {value} is outside the allowed range {range}")]
    OutOfRange {
        /// Name of the setting.
        field: &'static str,
        /// Value given.
        value: f64,
        /// Allowed range.
        range: &'static str,
    },
    /// The physics crate rejected a setting (damping).
    #[error("physics: {0}")]
    Model(#[from] ModelError),
}
