//! The runner: scenario → model + state → simulation, the stepper loop with recording at the
//! scenario's save interval, and the run's outputs (trajectory, summary, resolved scenario,
//! figures) in one output directory. The physics crate never sees the scenario; this module is
//! the only place where scenario sections turn into physics types.

use crate::figures;
use crate::output::{write_json, OutputDir};
use crate::progress::Progress;
use crate::recorder::{streamed_arrays, Recorder, SERIES};
use crate::scenario::{fmt_vec, LoadKind, ObstacleKind, Scenario, ScenarioError};
use anyhow::{Context, Result};
use octoarm_physics::{
    ContactParams, Damping, Load, Material, ModelError, Settings, Simulation, Sphere, StepError,
    StraightRod,
};
use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;

/// How a run reports progress.
#[derive(Debug, Clone, Copy, Default)]
pub struct RunOptions {
    /// Show a progress bar on stderr once the run has taken more than a second (the caller
    /// decides whether stderr is a terminal and whether `--quiet` was given).
    pub progress: bool,
    /// Skip the figures (benchmarks).
    pub no_figures: bool,
}

/// What a run did.
#[derive(Debug, Clone)]
pub struct RunReport {
    /// Where the outputs are.
    pub out_dir: PathBuf,
    /// Steps taken.
    pub steps: u64,
    /// Steps a complete run takes.
    pub planned_steps: u64,
    /// Frames written to `trajectory.npz`.
    pub frames: usize,
    /// Wall time of the stepper loop including recording [s].
    pub loop_seconds: f64,
    /// Wall time of the whole run including writing the outputs [s].
    pub wall_seconds: f64,
    /// The instability that stopped the run, if any.
    pub failure: Option<StepError>,
}

/// The straight, clamped rod of a `[rod]` section (tip diameter resolved to the base's if absent).
pub fn straight_rod(r: &crate::scenario::RodConfig) -> StraightRod {
    StraightRod {
        n_elements: r.n_elements,
        length: r.length,
        base_diameter: r.base_diameter,
        tip_diameter: r.tip_diameter.unwrap_or(r.base_diameter),
        material: Material {
            density: r.density,
            youngs_modulus: r.youngs_modulus,
            shear_modulus: r.shear_modulus,
            shear_coefficient: r.shear_coefficient,
        },
        base_position: [0.0; 3],
        direction: r.direction,
        normal: r.normal,
        rest_curvature: r.rest_curvature,
        boundary: octoarm_physics::Boundary::ClampedBase,
    }
}

/// Build the simulation a scenario describes. A physics-side rejection is reported like a
/// scenario error, at the key it concerns.
pub fn build_simulation(scn: &Scenario) -> Result<Simulation, ScenarioError> {
    let cfg = &scn.config;
    let r = &cfg.rod;
    let located = |key: String, e: ModelError| ScenarioError {
        file: scn.path.clone(),
        line: scn.locate(&key),
        message: format!("{key}: {e}"),
    };
    let rod = straight_rod(r);
    let (model, state) = rod
        .build()
        .map_err(|e| located(format!("rod.{}", field_of(&e)), e))?;
    let settings = Settings {
        dt: cfg.time.dt,
        energy_consistent: cfg.numerics.energy_consistent,
        guard_interval: cfg.numerics.guard_interval,
        ..Settings::default()
    };
    let n = model.n_elements;
    let mut sim =
        Simulation::new(model, state, settings).map_err(|e| located("time.dt".into(), e))?;
    sim.set_damping(Damping {
        rate: cfg.damping.rate,
        gamma: cfg.damping.gamma,
        analytical: None,
    })
    .map_err(|e| located("damping".into(), e))?;
    sim.set_contact(ContactParams {
        beta: cfg.contact.beta,
        zeta: cfg.contact.zeta,
    })
    .map_err(|e| located("contact".into(), e))?;
    for (i, l) in cfg.loads.iter().enumerate() {
        let ramp_time = l.ramp_time.unwrap_or(0.0);
        let load = match l.kind {
            LoadKind::Gravity => Load::Gravity {
                acceleration: l.value,
            },
            LoadKind::TipForce => Load::NodeForce {
                node: n,
                force: l.value,
                ramp_time,
            },
            LoadKind::UniformForce => Load::UniformForce {
                force_per_length: l.value,
            },
            LoadKind::TipCouple => Load::ElementCouple {
                element: n - 1,
                couple: l.value,
                ramp_time,
            },
        };
        sim.add_load(load)
            .map_err(|e| located(format!("load[{i}].value"), e))?;
    }
    for (i, o) in cfg.obstacles.iter().enumerate() {
        let sphere = match o.kind {
            ObstacleKind::Sphere => Sphere {
                center: o.center,
                radius: 0.5 * o.diameter,
                velocity: o.velocity,
            },
        };
        sim.add_obstacle(sphere)
            .map_err(|e| located(format!("obstacle[{i}]"), e))?;
    }
    Ok(sim)
}

fn field_of(e: &ModelError) -> &'static str {
    match e {
        ModelError::OutOfRange { field, .. }
        | ModelError::CountOutOfRange { field, .. }
        | ModelError::BadVector { field, .. }
        | ModelError::BadLength { field, .. } => field,
    }
}

/// Things worth changing in a valid scenario (time step against the stability limit, rounding,
/// obstacles overlapping the rod at rest), each saying what to change.
pub fn advisories(scn: &Scenario, sim: &Simulation) -> Vec<String> {
    let cfg = &scn.config;
    let mut out = Vec::new();
    let (dt, limit) = (cfg.time.dt, sim.model.stable_dt());
    if dt > limit {
        out.push(format!(
            "time.dt = {dt:e} s exceeds this rod's stable limit {limit:.3e} s: the run will become unstable; \
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
            cfg.time.duration,
            steps as f64 * dt
        ));
    }
    let every = cfg.save_every();
    if off_grid(every as f64, cfg.time.save_interval) {
        out.push(format!(
            "time.save_interval = {} s is not a multiple of dt = {dt:e} s: recording every {every} steps ({:.9} s)",
            cfg.time.save_interval,
            every as f64 * dt
        ));
    }
    for (i, o) in cfg.obstacles.iter().enumerate() {
        let r = 0.5 * o.diameter;
        let overlap = (0..sim.model.n_elements).any(|j| {
            let (a, b) = (sim.state.position[j], sim.state.position[j + 1]);
            let mid = [
                0.5 * (a[0] + b[0]),
                0.5 * (a[1] + b[1]),
                0.5 * (a[2] + b[2]),
            ];
            let d = ((mid[0] - o.center[0]).powi(2)
                + (mid[1] - o.center[1]).powi(2)
                + (mid[2] - o.center[2]).powi(2))
            .sqrt();
            d < r + sim.model.radius[j]
        });
        if overlap {
            out.push(format!(
                "obstacle[{i}] (center {}, diameter {}) overlaps the rod at rest: the contact force will push \
                 the rod out violently; move the obstacle",
                fmt_vec(o.center),
                o.diameter
            ));
        }
    }
    out
}

/// Advance `sim` by `n_steps`, recording after every `save_every` steps and after the last
/// one (t = 0 must already be recorded). The guard runs before each recorded frame, so every
/// recorded frame is finite. Returns the instability that stopped the loop, if any.
pub fn step_loop(
    sim: &mut Simulation,
    n_steps: u64,
    save_every: u64,
    recorder: &mut Recorder,
    mut on_frame: impl FnMut(u64, f64),
) -> Result<Option<StepError>> {
    let guard_every = sim.settings.guard_interval;
    for step in 1..=n_steps {
        if let Err(e) = sim.step() {
            return Ok(Some(e));
        }
        if step % save_every == 0 || step == n_steps {
            // `step` already ran the guard on this state when the intervals coincide.
            if step % guard_every != 0 {
                if let Err(e) = sim.check() {
                    return Ok(Some(e));
                }
            }
            recorder.record(sim)?;
            on_frame(step, sim.state.time);
        }
    }
    Ok(None)
}

/// Run a scenario and write its outputs into `out`, which is committed (moved into place) at
/// the end, also after an instability. Errors are I/O or internal failures.
pub fn run(scn: &Scenario, out: OutputDir, opts: RunOptions) -> Result<RunReport> {
    let wall = Instant::now();
    let cfg = &scn.config;
    let mut sim = build_simulation(scn)?;
    for warning in advisories(scn, &sim) {
        tracing::warn!("{warning}");
    }
    let n_steps = cfg.n_steps();
    let save_every = cfg.save_every();
    let planned = cfg.n_frames() as usize;
    tracing::info!(
        "{}: {} steps of dt = {:e} s, {planned} frames, output {}",
        scn.path.display(),
        n_steps,
        cfg.time.dt,
        out.target().display()
    );
    let mut recorder = Recorder::new(&sim.model, planned, &out.path(""))?;
    let progress = Progress::new(opts.progress).bar(n_steps, "");

    let loop_start = Instant::now();
    let mut failure = sim.check().err();
    if failure.is_none() {
        recorder.record(&sim)?;
        failure = step_loop(&mut sim, n_steps, save_every, &mut recorder, |step, t| {
            progress.update(step, t)
        })?;
    }
    let loop_seconds = loop_start.elapsed().as_secs_f64();
    progress.finish();
    let steps = match &failure {
        Some(StepError::Unstable { step, .. }) => *step,
        None => n_steps,
    };
    tracing::info!("stepping done: {steps} steps in {loop_seconds:.2} s; writing outputs");

    recorder.finish(&out.path("trajectory.npz"))?;
    std::fs::write(out.path("scenario.toml"), scn.resolved_toml())
        .with_context(|| format!("cannot write {}", out.path("scenario.toml").display()))?;
    if !opts.no_figures {
        let title = match &failure {
            None => scn.name.clone(),
            Some(StepError::Unstable { time, .. }) => {
                format!("{} (unstable at t = {time:.4} s)", scn.name)
            }
        };
        if let Err(e) =
            figures::shapes_png(&out.path("shapes.png"), &recorder, &cfg.obstacles, &title)
        {
            tracing::warn!("shapes.png not written: {e:#}");
        }
        if let Err(e) = figures::energy_png(&out.path("energy.png"), &recorder, &title) {
            tracing::warn!("energy.png not written: {e:#}");
        }
    }
    let mut report = RunReport {
        out_dir: out.target().to_path_buf(),
        steps,
        planned_steps: n_steps,
        frames: recorder.frames(),
        loop_seconds,
        wall_seconds: 0.0,
        failure,
    };
    report.wall_seconds = wall.elapsed().as_secs_f64();
    let summary = summary_json(scn, &sim, &recorder, &report);
    write_json(&out.path("summary.json"), &summary)?;
    out.commit()?;
    Ok(report)
}

/// The `summary.json` of a run.
fn summary_json(
    scn: &Scenario,
    sim: &Simulation,
    rec: &Recorder,
    report: &RunReport,
) -> serde_json::Value {
    let cfg = &scn.config;
    let n = sim.model.n_elements;
    let last = rec.series.last().copied().unwrap_or([f64::NAN; 6]);
    let final_energies = json!({
        "translational": last[0],
        "rotational": last[1],
        "stretch": last[2],
        "bend": last[3],
        "kinetic": last[0] + last[1],
        "strain": last[2] + last[3],
        "total": last[0] + last[1] + last[2] + last[3],
        "external_work": last[4],
        "dissipated": last[5],
    });
    let failure = report.failure.as_ref().map(|e| {
        let StepError::Unstable {
            what,
            value,
            domain,
            index,
            time,
            step,
            dt,
            suggested_dt,
            advice,
        } = e;
        // The element at or next to the failure: node i → element max(i, 1) − 1 (the one ending
        // there), Voronoi point k → element k + 1 (the one starting there).
        let element = match *domain {
            "node" => index.max(&1) - 1,
            "voronoi point" => index + 1,
            _ => *index,
        };
        json!({
            "message": e.to_string(),
            "quantity": what,
            "value": value,
            "domain": domain,
            "index": index,
            "element": element.min(n - 1),
            "time": time,
            "step": step,
            "dt": dt,
            "suggested_dt": suggested_dt,
            "advice": advice,
        })
    });
    let mut arrays = serde_json::Map::new();
    let t = rec.frames();
    arrays.insert(
        "time".into(),
        json!({"shape": [t], "unit": "s", "domain": "frame"}),
    );
    for (name, shape, unit, domain) in streamed_arrays(n) {
        let mut full = vec![t];
        full.extend(shape);
        arrays.insert(
            name.into(),
            json!({"shape": full, "unit": unit, "domain": domain}),
        );
    }
    for (name, unit, meaning) in SERIES {
        arrays.insert(
            name.into(),
            json!({"shape": [t], "unit": unit, "domain": meaning}),
        );
    }
    json!({
        "program": "octoarm",
        "version": env!("CARGO_PKG_VERSION"),
        "scenario": scn.path.display().to_string(),
        "description": cfg.description,
        "status": if report.failure.is_some() { "unstable" } else { "completed" },
        "steps": report.steps,
        "planned_steps": report.planned_steps,
        "dt": cfg.time.dt,
        "stable_dt": sim.model.stable_dt(),
        "simulated_seconds": report.steps as f64 * cfg.time.dt,
        "final_time": rec.time.last().copied().unwrap_or(0.0),
        "wall_seconds": report.wall_seconds,
        "loop_seconds": report.loop_seconds,
        "us_per_step": if report.steps > 0 { report.loop_seconds * 1e6 / report.steps as f64 } else { 0.0 },
        "frames": t,
        "save_every_steps": cfg.save_every(),
        "final_tip_position": rec.tip.last().copied().unwrap_or([f64::NAN; 3]),
        "final_energies": final_energies,
        "failure": failure,
        "arrays": arrays,
    })
}
