//! octoarm, the application. Its library part (always built, used by the Python package):
//! scenario files (`scenario`), scenario → system and controllers (`build`, `initial`), the one
//! run pipeline (`pipeline`), its recorders (`recorder`, `series`, `acceptance`) and the output
//! files (`output`). With the `cli` feature (default), the command line's parts: figures
//! (`figures`, `paper_figures`, `projection`, `gif`, `plot`, `sweep_figures`), progress bars
//! (`progress`), `octoarm paper` (`paper`) and the live viewer's recorder (`live`). Parameter
//! sweeps (`sweep`) are library code, shared with Python. The physics lives in
//! `octoarm-physics`, the control in `octoarm-control`.

pub mod acceptance;
pub mod build;
pub mod estimate;
pub mod initial;
pub mod muscle_run;
pub mod outdir;
pub mod output;
pub mod pipeline;
pub mod recorder;
pub mod scenario;
pub mod series;
pub mod sweep;

#[cfg(feature = "cli")]
pub mod figures;
#[cfg(feature = "cli")]
pub mod gif;
#[cfg(feature = "cli")]
pub mod live;
#[cfg(feature = "cli")]
pub mod paper;
#[cfg(feature = "cli")]
pub mod paper_figures;
#[cfg(feature = "cli")]
mod plot;
#[cfg(feature = "cli")]
pub mod progress;
#[cfg(feature = "cli")]
pub mod projection;
#[cfg(feature = "cli")]
pub mod sweep_figures;

use scenario::{fmt_num, fmt_sci, fmt_vec, Scenario, ScenarioError};
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

/// Things worth changing in a valid scenario (time step against the stability limit, rounding,
/// obstacles overlapping a rod at rest, deprecated keys), each saying what to change.
pub fn advisories(
    scn: &Scenario,
    system: &octoarm_physics::RodSystem,
    state: &octoarm_physics::SystemState,
) -> Vec<String> {
    let cfg = &scn.config;
    let mut out = scn.notes.clone();
    let (dt, limit) = (cfg.time.dt, system.stable_dt());
    let whose = if system.rods().len() == 1 {
        "rod's"
    } else {
        "system's"
    };
    if dt > limit {
        out.push(format!(
            "time.dt = {dt:e} s exceeds this {whose} stable limit {limit:.3e} s: the run will become unstable; \
             set dt ≤ {:.2e} s",
            0.2 * limit
        ));
    } else if dt > 0.2 * limit {
        out.push(format!(
            "time.dt = {dt:e} s is above the recommended 0.2 × stable limit ({:.3e} s): fast tip modes are \
             inaccurate; set dt ≤ {:.2e} s",
            limit,
            0.2 * limit
        ));
    }
    // Whether `count` steps of dt miss `span` [s] by more than rounding.
    let off_grid = |count: f64, span: f64| (count * dt - span).abs() > 1e-9 * span;
    let steps = cfg.n_steps();
    if off_grid(steps as f64, cfg.time.duration) {
        out.push(format!(
            "time.duration = {} s is not a multiple of dt = {dt:e} s: running {steps} steps, to t = {:.9} s",
            fmt_num(cfg.time.duration),
            steps as f64 * dt
        ));
    }
    let every = cfg.save_every();
    if off_grid(every as f64, cfg.time.save_interval) {
        out.push(format!(
            "time.save_interval = {} s is not a multiple of dt = {dt:e} s: recording every {every} steps ({:.9} s)",
            fmt_num(cfg.time.save_interval),
            every as f64 * dt
        ));
    }
    for (i, o) in cfg.obstacles.iter().enumerate() {
        let r = 0.5 * o.diameter;
        let overlap = system.rods().iter().any(|rod| {
            let nodes = rod.nodes();
            (0..rod.n_elements()).any(|j| {
                let (a, b) = (
                    state.position.get(nodes.start + j),
                    state.position.get(nodes.start + j + 1),
                );
                let mid = [
                    0.5 * (a[0] + b[0]),
                    0.5 * (a[1] + b[1]),
                    0.5 * (a[2] + b[2]),
                ];
                let d = ((mid[0] - o.center[0]).powi(2)
                    + (mid[1] - o.center[1]).powi(2)
                    + (mid[2] - o.center[2]).powi(2))
                .sqrt();
                d < r + rod.model.radius[j]
            })
        });
        if overlap {
            out.push(format!(
                "obstacle[{i}] (center {}, diameter {}) overlaps a rod at rest: the contact force will push \
                 the rod out violently; move the obstacle",
                fmt_vec(o.center),
                o.diameter
            ));
        }
    }
    out
}

/// What `octoarm check` prints: the rods, the stable time step, the number of steps and frames,
/// loads, obstacles, joints and any advisories. Errors if the scenario cannot be built.
pub fn check_report(scn: &Scenario) -> Result<String, ScenarioError> {
    use std::fmt::Write;
    let (system, state) = build::build_system(scn)?;
    let cfg = &scn.config;
    let stable = system.stable_dt();
    let mut s = String::new();
    let _ = writeln!(s, "{}: valid scenario", scn.path.display());
    if let Some(d) = &cfg.description {
        let _ = writeln!(s, "  {d}");
    }
    for (r, rod) in cfg.rods.list.iter().zip(system.rods()) {
        let _ = writeln!(
            s,
            "  rod {}: {} elements, length {} m, diameter {} m -> {} m, mass {:.4e} kg, base {} at {}, tip {}",
            rod.name,
            r.n_elements,
            fmt_num(r.length),
            fmt_num(r.base_diameter),
            fmt_num(r.tip_diameter.unwrap_or(r.base_diameter)),
            rod.model.total_mass(),
            rod.base.condition.name(),
            fmt_vec(r.base_position),
            rod.tip.condition.name(),
        );
    }
    let _ = writeln!(
        s,
        "  stable dt: {stable:.3e} s (recommended <= {:.3e} s); dt = {} s{} is {:.3} x stable dt",
        0.2 * stable,
        fmt_sci(cfg.time.dt),
        if cfg.time.auto_dt { " (auto)" } else { "" },
        cfg.time.dt / stable
    );
    let _ = writeln!(
        s,
        "  steps: {} (duration {} s from t = {} s); frames: {} (every {} steps = {} s)",
        cfg.n_steps(),
        fmt_num(cfg.time.duration),
        fmt_num(state.time),
        cfg.n_frames(),
        cfg.save_every(),
        fmt_num(cfg.save_every() as f64 * cfg.time.dt)
    );
    let _ = writeln!(
        s,
        "  outputs: {}",
        estimate::describe(&estimate::estimate_outputs(scn))
    );
    let _ = writeln!(
        s,
        "  damping: rate = {} 1/s, gamma = {} kg/(m s), protocol {:?}",
        fmt_num(cfg.damping.rate),
        fmt_num(cfg.damping.gamma),
        cfg.damping.protocol
    );
    if cfg.loads.is_empty() {
        let _ = writeln!(s, "  loads: none");
    }
    for l in &cfg.loads {
        let sched = match (&l.schedule, l.ramp_time) {
            (Some(sc), _) => format!(", schedule {:?}", sc.kind).to_lowercase(),
            (None, Some(t)) if t > 0.0 => format!(", ramped over {} s", fmt_num(t)),
            _ => String::new(),
        };
        let on = l
            .rod
            .as_deref()
            .map(|r| format!(" on rod {r}"))
            .unwrap_or_default();
        let _ = writeln!(
            s,
            "  load: {} {} {}{on}{sched}",
            l.kind.name(),
            fmt_vec(l.value),
            l.kind.unit()
        );
    }
    for o in &cfg.obstacles {
        let _ = writeln!(
            s,
            "  obstacle: sphere, center {} m, diameter {} m",
            fmt_vec(o.center),
            fmt_num(o.diameter)
        );
    }
    for p in &cfg.planes {
        let _ = writeln!(
            s,
            "  plane: point {} m, normal {}",
            fmt_vec(p.point),
            fmt_vec(p.normal)
        );
    }
    for c in &cfg.cylinders {
        let _ = writeln!(
            s,
            "  cylinder: center {} m, axis {}, diameter {} m, length {} m",
            fmt_vec(c.center),
            fmt_vec(c.axis),
            fmt_num(c.diameter),
            fmt_num(c.length)
        );
    }
    if cfg.contact.rods || cfg.contact.self_contact {
        let _ = writeln!(
            s,
            "  contact: between rods {}, self contact {}",
            cfg.contact.rods, cfg.contact.self_contact
        );
    }
    for j in &cfg.joints {
        let _ = writeln!(s, "  joint: {:?} {} -- {}", j.kind, j.first, j.second);
    }
    if let Some(c) = &cfg.controller {
        let _ = writeln!(
            s,
            "  controller: {:?} on rod {}",
            c.kind,
            c.rod.as_deref().unwrap_or("?")
        );
    }
    let warnings = advisories(scn, &system, &state)
        .into_iter()
        .chain(build::task_advisories(scn, &system, &state))
        .chain(estimate::size_warning(scn));
    for w in warnings {
        let _ = writeln!(s, "  warning: {w}");
    }
    Ok(s)
}
