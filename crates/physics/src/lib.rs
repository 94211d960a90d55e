//! octoarm-physics: validated discrete 3D Cosserat rods (Gazzola et al. 2018, as specified in
//! `docs/cosserat-discretization.md`) in systems of many rods. It owns the rod models, the
//! system (rods, end conditions, joints, loads with schedules, obstacles, rest strains in force),
//! the structure-of-arrays state, the actuation input, internal and external loads, damping,
//! contact with rigid spheres, planes and cylinders (with friction), rod–rod and self contact, the one position-Verlet stepper and the stability guard. It knows
//! nothing of control, files or plotting.
//!
//! ```
//! use octoarm_physics::{Damping, Load, Settings, Simulation, StraightRod};
//! let (model, state) = StraightRod::paper_arm().build().unwrap();
//! let mut sim = Simulation::new(model, state, Settings::with_dt(1e-5)).unwrap();
//! sim.set_damping(Damping::mass_proportional(10.0)).unwrap();
//! sim.add_load(Load::tip_force(100, [0.0, 2e-5, 0.0])).unwrap();
//! sim.run(1000).unwrap();
//! assert!(sim.tip()[1] > 0.0);
//! ```

// Kernels walk several parallel per-node/per-element arrays with one index, as the spec's
// formulas do; zipping five iterators would not be clearer.
#![allow(clippy::needless_range_loop)]

pub mod actuation;
pub mod batch;
pub mod contact;
pub mod damping;
pub mod ends;
pub mod energy;
pub mod error;
pub mod internal;
pub mod joints;
pub mod kernel;
mod lanes;
pub mod loads;
pub mod math;
pub mod model;
pub mod muscles;
pub mod rod_contact;
pub mod schedule;
pub mod simulation;
pub mod state;
pub mod step;
pub mod store;
pub mod system;

pub use actuation::Actuation;
pub use batch::{BatchError, RodBatch};
pub use contact::{
    closest_points, contact_energy, max_penetration, obstacle_energy, obstacle_penetration,
    ContactParams, Cylinder, Friction, Obstacles, Plane, RodGeometry, Sphere,
};
pub use damping::{AnalyticalDamper, Damping};
pub use ends::{EndCondition, Motion, Side};
pub use energy::{energies, energies_with_rest, Energies};
pub use error::{ModelError, StepError};
pub use internal::{strains, ElasticLoads, InternalLoads, Offsets};
pub use joints::{Joint, JointEnd, JointKind, JointParams};
pub use kernel::Kernel;
pub use loads::{AppliedLoad, ExternalLoads, Load};
pub use math::{Mat3, Vec3};
pub use model::{Material, RodModel, StraightRod};
pub use muscles::{FibreKind, ForceLength, MuscleGroup, MuscleModel, MuscleSpec, N_GROUPS};
pub use rod_contact::{min_rod_gap, neighbour_elements};
pub use schedule::Schedule;
pub use simulation::Simulation;
pub use state::{RodAccess, RodState, RodView, SystemState};
pub use step::{check, joint_energy, rod_energies, step, Workspace};
pub use store::{Mat3s, Vec3s};
pub use system::{
    auto_dt, RestChange, Rod, RodSpec, RodSystem, Settings, SystemBuilder, AUTO_DT_FRACTION,
    AUTO_DT_RECHECK,
};
