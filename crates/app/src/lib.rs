//! octoarm, the application: scenario files (`scenario`), the runner that turns a scenario into a
//! simulation and steps it (`runner`), the recorder that streams frames (`recorder`), output files
//! (`output`), figures (`figures`) and progress bars (`progress`); controlled runs (`controlled`)
//! and the paper's experiments (`paper`, `paper_figures`, `gif`) on top of `octoarm-control`.
//! The physics lives in `octoarm-physics`; this crate owns files, the command line's work and
//! everything a user reads. The binary is a thin clap layer.

pub mod controlled;
pub mod figures;
pub mod gif;
pub mod output;
pub mod paper;
pub mod paper_figures;
mod plot;
pub mod progress;
pub mod recorder;
pub mod runner;
pub mod scenario;

use scenario::{Scenario, ScenarioError};
use std::path::PathBuf;

/// The default output directory of a scenario: `results/<file stem>`.
pub fn default_out_dir(scn: &Scenario) -> PathBuf {
    PathBuf::from("results").join(&scn.name)
}

/// Replace the scenario's duration (the `--duration` flag) and re-validate; the resolved
/// `scenario.toml` then records the new value so that the run can be repeated.
pub fn override_duration(scn: &mut Scenario, duration: f64) -> Result<(), ScenarioError> {
    scn.config.time.duration = duration;
    scn.config.validate().map_err(|bad| ScenarioError {
        file: scn.path.clone(),
        line: None,
        message: format!("--duration {duration}: {bad}"),
    })
}

/// What `octoarm check` prints: the rod, its stable time step, the number of steps and frames,
/// loads, obstacles and any advisories. Errors if the scenario cannot be built.
pub fn check_report(scn: &Scenario) -> Result<String, ScenarioError> {
    use std::fmt::Write;
    let sim = runner::build_simulation(scn)?;
    let cfg = &scn.config;
    let r = &cfg.rod;
    let m = &sim.model;
    let stable = m.stable_dt();
    let mut s = String::new();
    let _ = writeln!(s, "{}: valid scenario", scn.path.display());
    if let Some(d) = &cfg.description {
        let _ = writeln!(s, "  {d}");
    }
    let _ = writeln!(
        s,
        "  rod: {} elements, length {} m, diameter {} m -> {} m, mass {:.4e} kg",
        r.n_elements,
        r.length,
        r.base_diameter,
        r.tip_diameter.unwrap_or(r.base_diameter),
        m.total_mass()
    );
    let _ = writeln!(
        s,
        "  stable dt: {stable:.3e} s (recommended <= {:.3e} s); dt = {:e} s is {:.3} x stable dt",
        0.2 * stable,
        cfg.time.dt,
        cfg.time.dt / stable
    );
    let _ = writeln!(
        s,
        "  steps: {} (duration {} s); frames: {} (every {} steps = {} s)",
        cfg.n_steps(),
        cfg.time.duration,
        cfg.n_frames(),
        cfg.save_every(),
        cfg.save_every() as f64 * cfg.time.dt
    );
    let n = r.n_elements;
    let bytes_per_frame = 8 * (3 * (n + 1) * 2 + 9 * n + 3 * n + 3 * (n - 1) + 7);
    let _ = writeln!(
        s,
        "  trajectory.npz: {:.1} MB before compression",
        (bytes_per_frame as f64 * cfg.n_frames() as f64) / 1e6
    );
    let _ = writeln!(
        s,
        "  damping: rate = {} 1/s, gamma = {} kg/(m s)",
        cfg.damping.rate, cfg.damping.gamma
    );
    if cfg.loads.is_empty() {
        let _ = writeln!(s, "  loads: none");
    }
    for l in &cfg.loads {
        let ramp = match l.ramp_time {
            Some(t) if t > 0.0 => format!(", ramped over {t} s"),
            _ => String::new(),
        };
        let _ = writeln!(
            s,
            "  load: {} {} {}{ramp}",
            l.kind.name(),
            scenario::fmt_vec(l.value),
            l.kind.unit()
        );
    }
    for o in &cfg.obstacles {
        let _ = writeln!(
            s,
            "  obstacle: sphere, center {} m, diameter {} m",
            scenario::fmt_vec(o.center),
            o.diameter
        );
    }
    for w in runner::advisories(scn, &sim) {
        let _ = writeln!(s, "  warning: {w}");
    }
    Ok(s)
}
