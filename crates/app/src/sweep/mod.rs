//! Parameter sweeps: a base scenario and a sweep file (TOML) of parameters addressed by scenario
//! path, run as many scenarios into one folder (`runs/<id>/` each, `results.csv` + `results.npz`,
//! `sweep.json`). `plan` resolves and checks the sweep, `dir` owns its folder and table, `local`
//! runs it on this machine's cores, `ray` (command line) hands the runs to the Python Ray
//! executor. Figures of a sweep are the command line's (`sweep_figures`).

pub mod dir;
pub mod local;
pub mod plan;
#[cfg(feature = "cli")]
pub mod ray;
pub mod table;

pub use dir::{Counts, Outcome, SweepDir};
pub use local::{run_local, Event, LocalOptions};
pub use plan::{
    run_id, Combine, Parameter, PlannedRun, RunCheck, Scale, SweepPlan, MAX_SWEEP_PARAMETERS,
    MAX_SWEEP_RUNS, MAX_SWEEP_VALUES,
};
pub use table::Row;
