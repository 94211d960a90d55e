//! octoarm-control: the strain-space statics of the CyberOctopus arm, its task costs (tip target,
//! sphere obstacles, grasp), the forward–backward sweep with its update rules (offline and online),
//! the energy-shaping law that turns a designed strain field into actuation of the simulated rod
//! (`docs/control-algorithms.md`; Chang et al., CDC 2020), and controllers behind one trait
//! (`Controller`) that the application's run pipeline updates. It uses the physics crate only
//! through its public interface; it knows no experiments, files or recording.
//!
//! Index conventions follow the physics crate: `element` j = 0..n−1, `node` i = 0..n, `interior`
//! (Voronoi) point k = 0..n−2 between elements k and k + 1, i.e. at node k + 1. The control
//! specification numbers interior points from 1; its κ_k is our `kappa(k − 1)`.
//!
//! ```
//! use octoarm_control::{OfflineSolver, SolverConfig, Task};
//! use octoarm_physics::StraightRod;
//! let (model, state) = StraightRod::paper_arm().build().unwrap();
//! let mut solver = OfflineSolver::new(&model, &state, SolverConfig::default()).unwrap();
//! let task = Task::reach([0.09, 0.09, 0.0], 1.0e3);
//! let solution = solver.solve(&task, None).unwrap();
//! assert!(solution.report.tip_error < 2e-5);
//! ```

// Component loops `for c in 0..3` index several arrays at once, as the equations do.
#![allow(clippy::needless_range_loop)]

pub mod banded;
pub mod controller;
pub mod error;
pub mod muscle_design;
pub mod muscle_shaping;
pub mod muscle_statics;
pub mod shaping;
pub mod solver;
pub mod statics;
pub mod strains;
pub mod task;

pub use controller::{
    ControlError, ControlReport, Controller, DesignMode, GraspSpec, ShapingController,
    ShapingControllerConfig, Signals, SphereSpec, TargetPhase, TaskSchedule,
};
pub use error::{ShapingError, SolveError, StaticsError, TaskError};
pub use muscle_design::{
    restart_activations, CoommRelaxation, CoommRelaxationError, CoommRelaxationReport,
    DesignConfig, DesignConfigError, DesignCosts, DesignOutcome, DesignReport, DesignTask,
    GraspTask, MuscleDesign, ReachTask,
};
pub use muscle_shaping::MuscleShapingController;
pub use muscle_statics::{
    EquilibriumReport, JacobianKind, MuscleStatics, MuscleStaticsError, StaticsConfig,
};
pub use shaping::{EnergyShapingController, ShapingConfig};
pub use solver::{
    OfflineSolver, OnlineConfig, OnlineReport, OnlineSolver, Outcome, Solution, SolveReport,
    SolverConfig, StopReason, UpdateRule, Warning,
};
pub use statics::{CostTerms, Statics};
pub use strains::{StrainField, StrainSpace};
pub use task::{Grasp, GraspWeight, Obstacle, Task, TipTerm};
