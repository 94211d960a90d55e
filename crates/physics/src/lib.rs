//! octoarm-physics: a validated discrete 3D Cosserat rod (Gazzola et al. 2018, as specified in
//! `docs/cosserat-discretization.md`). It owns the rod model and state, internal and external
//! loads, damping, contact with rigid spheres, position-Verlet stepping and the stability guard.
//! It knows nothing of control, files or plotting.
//!
//! ```
//! use octoarm_physics::{Damping, Load, Settings, Simulation, StraightRod};
//! let (model, state) = StraightRod::paper_arm().build().unwrap();
//! let mut sim = Simulation::new(model, state, Settings::with_dt(1e-5)).unwrap();
//! sim.set_damping(Damping::mass_proportional(10.0)).unwrap();
//! sim.add_load(Load::tip_force(100, [0.0, 2e-5, 0.0])).unwrap();
//! sim.run(1000).unwrap();
//! assert!(sim.state.tip()[1] > 0.0);
//! ```

// Kernels walk several parallel per-node/per-element arrays with one index, as the spec's
// formulas do; zipping five iterators would not be clearer.
#![allow(clippy::needless_range_loop)]

pub mod contact;
pub mod damping;
pub mod energy;
pub mod error;
pub mod internal;
pub mod loads;
pub mod math;
pub mod model;
pub mod simulation;
pub mod state;

pub use contact::{contact_energy, max_penetration, ContactParams, Sphere};
pub use damping::{AnalyticalDamper, Damping};
pub use energy::{energies, energies_with_rest, Energies};
pub use error::{ModelError, StepError};
pub use internal::{strains, ElasticLoads, InternalLoads};
pub use loads::{ExternalLoads, Load};
pub use math::{Mat3, Vec3};
pub use model::{Boundary, Material, RodModel, StraightRod};
pub use simulation::{Settings, Simulation};
pub use state::RodState;
