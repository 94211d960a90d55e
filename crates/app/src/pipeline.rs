//! The one run pipeline, for passive and controlled runs alike: scenario → system + controllers
//! (`prepare`) → the one loop (controllers updated when due, the guard checked before every
//! recorded sample, one physics step at a time) → recorders → outputs, written under a temporary
//! name and committed whole. A run that fails (instability, controller error) keeps and writes
//! everything recorded until then. Figures are drawn by a caller-supplied `Figures` (the command
//! line's); this module draws nothing.

use crate::build;
use crate::output::{write_json, OutputDir};
use crate::recorder::TrajectoryRecorder;
use crate::scenario::{frames_of, steps_of, Scenario, ScenarioError};
use crate::series::SeriesRecorder;
use anyhow::{Context, Result};
use octoarm_control::{ControlReport, Controller};
use octoarm_physics::{step, Actuation, RodSystem, StepError, SystemState, Workspace};
use serde_json::{json, Map, Value};
use std::path::PathBuf;
use std::time::Instant;

/// What a recorder sees at a sample: the state at `state.time` and the controllers.
pub struct Moment<'a> {
    /// Steps taken in this run.
    pub steps: u64,
    /// The system.
    pub system: &'a RodSystem,
    /// Its state.
    pub state: &'a SystemState,
    /// The stepper's workspace (loads and actuation of the last step).
    pub workspace: &'a Workspace,
    /// The controllers (mutable: they compute their desired shapes lazily).
    pub controllers: &'a mut [Box<dyn Controller>],
}

/// What the recorders are told at the end.
#[derive(Debug, Clone)]
pub struct RunInfo {
    /// The planned duration [s].
    pub duration: f64,
    /// The controller's counters, for a controlled run.
    pub control: Option<ControlReport>,
    /// Why the run stopped early, if it did.
    pub failure: Option<Failure>,
}

/// Samples a run and writes its files at the end. The pipeline calls `record` at t = 0, every
/// `every()` steps and at the end (after the guard has passed the state), `after_step` after the
/// step that follows each sample, and `finish` once, also after a failure; `finish` writes its
/// files into the output folder and returns its part of `summary.json`.
pub trait Recorder {
    /// Steps between samples (≥ 1).
    fn every(&self) -> u64;
    /// Sample the state.
    fn record(&mut self, m: &mut Moment<'_>) -> Result<()>;
    /// After the step that follows a sample (e.g. to read the loads that step applied).
    fn after_step(&mut self, _m: &Moment<'_>) -> Result<()> {
        Ok(())
    }
    /// Write the files; return the keys this recorder adds to `summary.json`.
    fn finish(&mut self, out: &OutputDir, run: &RunInfo) -> Result<Map<String, Value>>;
}

/// A scenario turned into its system, initial state and controllers, ready to run.
pub struct Prepared {
    /// The rod system.
    pub system: RodSystem,
    /// Its initial state.
    pub state: SystemState,
    /// The controllers (offline designs already solved).
    pub controllers: Vec<Box<dyn Controller>>,
    /// The muscle design of a `[muscle_control]` run (its controller is in `controllers`).
    pub muscle: Option<Box<crate::muscle_run::MuscleDesignRun>>,
}

/// Build everything a run needs; any problem is a scenario error (nothing written yet).
pub fn prepare(scn: &Scenario) -> Result<Prepared, ScenarioError> {
    let (system, state) = build::build_system(scn)?;
    if scn.config.muscle_control.is_some() {
        let (c, design) = crate::muscle_run::design(scn, &system, &state)?;
        return Ok(Prepared {
            system,
            state,
            controllers: vec![Box::new(c)],
            muscle: Some(Box::new(design)),
        });
    }
    let controllers = build::build_controllers(scn, &system, &state)?;
    Ok(Prepared {
        system,
        state,
        controllers,
        muscle: None,
    })
}

/// Draws the figures of a run into its output folder (the command line's implementation draws
/// PNGs and a GIF; the Python package passes none).
pub trait Figures {
    /// Draw from the recorded data; failures are warnings, not errors.
    fn draw(&self, scn: &Scenario, data: &RunData, out: &OutputDir, title: &str);
}

/// Why a run stopped early.
#[derive(Debug, Clone, PartialEq)]
pub enum Failure {
    /// The stability guard fired.
    Unstable(StepError),
    /// A controller failed to update.
    Control(String),
    /// The run was stopped by a signal (its number: 2 SIGINT, 15 SIGTERM); the state at the
    /// stop was recorded.
    Interrupted(i32),
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Failure::Unstable(e) => write!(f, "{e}"),
            Failure::Control(e) => write!(f, "controller: {e}"),
            Failure::Interrupted(sig) => write!(f, "interrupted by signal {sig}"),
        }
    }
}

/// How a run reports progress and draws figures.
#[derive(Default)]
pub struct RunOptions<'a> {
    /// Called after every sample with (steps taken, simulated time).
    pub progress: Option<&'a (dyn Fn(u64, f64) + Sync)>,
    /// Draws the figures (None: no figures).
    pub figures: Option<&'a dyn Figures>,
    /// Set (to the signal's number) to stop the run: it records the current state, writes its
    /// outputs with status "interrupted" and returns. Checked before every step.
    pub stop: Option<&'a std::sync::atomic::AtomicUsize>,
}

/// The recorded data of a run, for figures and reports.
pub struct RunData {
    /// The trajectory recorder (times, energies, tips, thinned shapes, control frames).
    pub trajectory: TrajectoryRecorder,
    /// The control series (controlled runs).
    pub series: Option<SeriesRecorder>,
    /// The muscle run's series, design and checks (`[muscle_control]` runs).
    pub muscle: Option<crate::muscle_run::MuscleRecorder>,
    /// The rods' models and ends, for drawing.
    pub system: RodSystem,
}

/// What a run did.
pub struct RunReport {
    /// Where the outputs are.
    pub out_dir: PathBuf,
    /// Steps taken.
    pub steps: u64,
    /// Steps a complete run takes.
    pub planned_steps: u64,
    /// Frames written to `trajectory.npz`.
    pub frames: usize,
    /// Wall time of the stepping loop including recording [s].
    pub loop_seconds: f64,
    /// Wall time of the whole run including preparing and writing the outputs [s].
    pub wall_seconds: f64,
    /// Why the run stopped early, if it did.
    pub failure: Option<Failure>,
    /// The recorded data.
    pub data: RunData,
}

/// Steps a run of `scn` takes.
pub fn planned_steps(scn: &Scenario) -> u64 {
    scn.config.n_steps()
}

/// Run a prepared scenario and write its outputs into `out`, which is committed (moved into
/// place) at the end, also after a failure. Errors are I/O or internal failures.
pub fn run(
    scn: &Scenario,
    prepared: Prepared,
    out: OutputDir,
    opts: &RunOptions<'_>,
) -> Result<RunReport> {
    run_with(scn, prepared, out, opts, &mut [])
}

/// `run` with more recorders beside the trajectory and the series (e.g. the live viewer's):
/// each is sampled every `every()` steps and at the end, after the guard has passed the state,
/// in the same loop, and finished after the others (its `summary.json` keys are added).
pub fn run_with(
    scn: &Scenario,
    prepared: Prepared,
    out: OutputDir,
    opts: &RunOptions<'_>,
    extra: &mut [&mut dyn Recorder],
) -> Result<RunReport> {
    let wall = Instant::now();
    let cfg = &scn.config;
    let Prepared {
        system,
        mut state,
        mut controllers,
        muscle,
    } = prepared;
    let dt = system.settings().dt;
    let n_steps = cfg.n_steps();
    let save_every = cfg.save_every();
    let controlled = cfg
        .controller
        .as_ref()
        .and_then(|c| c.rod.as_deref())
        .and_then(|name| system.rod_index(name));
    tracing::info!(
        "{}: {} rod(s), {} steps of dt = {:e} s, {} frames{}, output {}",
        scn.path.display(),
        system.rods().len(),
        n_steps,
        dt,
        cfg.n_frames(),
        if controllers.is_empty() {
            ""
        } else {
            ", controlled"
        },
        out.target().display()
    );
    let mut trajectory = TrajectoryRecorder::new(
        &system,
        save_every,
        cfg.n_frames() as usize,
        controlled,
        &out,
    )?;
    let mut series = match (&cfg.controller, controlled) {
        (Some(c), Some(r)) => {
            let rod = system.rod(r);
            let schedule = build::task_schedule(cfg).expect("a controlled scenario");
            Some(SeriesRecorder::new(
                steps_of(c.series_interval, dt),
                r,
                rod.n_elements(),
                rod.model.length(),
                schedule.targets.clone(),
                schedule.grasp.is_some(),
                system.obstacles().to_vec(),
                cfg.acceptance.clone(),
            ))
        }
        _ => None,
    };
    // The series streams to disk as it is recorded, like the trajectory: memory stays bounded.
    if let Some(s) = &mut series {
        s.spool_into(&out, frames_of(n_steps, s.every()) as usize)?;
    }
    let mut muscle = muscle.map(|d| {
        let mc = cfg
            .muscle_control
            .as_ref()
            .expect("a muscle design comes from [muscle_control]");
        crate::muscle_run::MuscleRecorder::new(
            steps_of(mc.series_interval, dt),
            *d,
            &system,
            cfg.acceptance.clone(),
        )
    });
    let control_every: Vec<u64> = controllers
        .iter()
        .map(|c| steps_of(c.period(), dt))
        .collect();
    let mut actuation = Actuation::for_system(&system);
    let mut ws = Workspace::new(&system, &state);
    let guard_every = system.settings().guard_interval;
    let first_step = state.step;

    let loop_start = Instant::now();
    let mut failure = None;
    let mut steps = 0u64;
    for k in 0..=n_steps {
        let global = first_step + k;
        let stop = opts
            .stop
            .map_or(0, |s| s.load(std::sync::atomic::Ordering::Relaxed));
        // 1. Controllers due (never at the last instant: no step follows it).
        if k < n_steps && stop == 0 {
            for (c, every) in controllers.iter_mut().zip(&control_every) {
                if global % every == 0 {
                    if let Err(e) = c.update(state.time, &system, &state, &mut actuation) {
                        failure = Some(Failure::Control(e.to_string()));
                    }
                }
            }
            if failure.is_some() {
                break;
            }
        }
        // 2. Samples of the state at t, after the guard (which the step just ran if due); an
        // interrupted run records the state it stops at.
        let last = k == n_steps || stop != 0;
        let due_traj = k % trajectory.every() == 0 || last;
        let due_series = series.as_ref().is_some_and(|s| k % s.every() == 0 || last);
        let due_extra = !extra.is_empty() && extra.iter().any(|r| k % r.every() == 0 || last);
        let due_muscle = muscle.as_ref().is_some_and(|r| k % r.every() == 0 || last);
        if due_traj || due_series || due_extra || due_muscle {
            if k == 0 || global % guard_every != 0 {
                if let Err(e) = step::check(&system, &state, &mut ws) {
                    failure = Some(Failure::Unstable(e));
                    break;
                }
            }
            let mut m = Moment {
                steps: k,
                system: &system,
                state: &state,
                workspace: &ws,
                controllers: &mut controllers,
            };
            let npz = || {
                format!(
                    "recording {}",
                    out.target().join("trajectory.npz").display()
                )
            };
            if due_traj {
                trajectory.record(&mut m).with_context(npz)?;
            }
            if due_series {
                if let Some(s) = &mut series {
                    s.record(&mut m)?;
                }
            }
            if due_muscle {
                if let Some(r) = &mut muscle {
                    r.record(&mut m)?;
                }
            }
            if due_extra {
                for r in extra.iter_mut() {
                    if k % r.every() == 0 || last {
                        r.record(&mut m)?;
                    }
                }
            }
            if let Some(p) = opts.progress {
                p(k, state.time);
            }
        }
        if stop != 0 {
            failure = Some(Failure::Interrupted(stop as i32));
            break;
        }
        if k == n_steps {
            break;
        }
        // 3. One step.
        if let Err(e) = step::step(&system, &mut state, &actuation, &mut ws) {
            failure = Some(Failure::Unstable(e));
            steps = k + 1;
            break;
        }
        steps = k + 1;
        if due_series {
            if let Some(s) = &mut series {
                let m = Moment {
                    steps: k + 1,
                    system: &system,
                    state: &state,
                    workspace: &ws,
                    controllers: &mut controllers,
                };
                s.after_step(&m)?;
            }
        }
    }
    let loop_seconds = loop_start.elapsed().as_secs_f64();
    if let Some(Failure::Unstable(StepError::Unstable { step: s, .. })) = &failure {
        steps = s.saturating_sub(first_step);
    }
    tracing::info!("stepping done: {steps} steps in {loop_seconds:.2} s; writing outputs");

    let info = RunInfo {
        duration: cfg.time.duration,
        control: controllers.first().map(|c| c.report()),
        failure: failure.clone(),
    };
    let mut summary = Map::new();
    let target = out.target().to_path_buf();
    summary.extend(
        trajectory
            .finish(&out, &info)
            .with_context(|| format!("writing {}", target.join("trajectory.npz").display()))?,
    );
    if let Some(s) = &mut series {
        summary.extend(
            s.finish(&out, &info)
                .with_context(|| format!("writing the series of {}", target.display()))?,
        );
    }
    if let Some(r) = &mut muscle {
        summary.extend(
            r.finish(&out, &info)
                .with_context(|| format!("writing the muscle series of {}", target.display()))?,
        );
    }
    for r in extra.iter_mut() {
        summary.extend(r.finish(&out, &info)?);
    }
    std::fs::write(out.path("scenario.toml"), scn.resolved_toml())
        .with_context(|| format!("cannot write {}", out.path("scenario.toml").display()))?;
    let data = RunData {
        trajectory,
        series,
        muscle,
        system,
    };
    if let Some(fig) = opts.figures {
        let title = match &failure {
            None => scn.name.clone(),
            Some(Failure::Unstable(StepError::Unstable { time, .. })) => {
                format!("{} (unstable at t = {time:.4} s)", scn.name)
            }
            Some(Failure::Control(_)) => format!("{} (failed)", scn.name),
            Some(Failure::Interrupted(_)) => format!("{} (interrupted)", scn.name),
        };
        fig.draw(scn, &data, &out, &title);
    }
    let frames = data.trajectory.frames();
    let wall_seconds = wall.elapsed().as_secs_f64();
    let json = summary_json(
        scn,
        &data.system,
        summary,
        steps,
        n_steps,
        frames,
        loop_seconds,
        wall_seconds,
        failure.as_ref(),
        data.trajectory.time.last().copied().unwrap_or(0.0),
    );
    write_json(&out.path("summary.json"), &json)?;
    let out_dir = out.target().to_path_buf();
    out.commit()?;
    Ok(RunReport {
        out_dir,
        steps,
        planned_steps: n_steps,
        frames,
        loop_seconds,
        wall_seconds,
        failure,
        data,
    })
}

/// `summary.json`: the run's status and timing, the recorders' figures and the failure.
#[allow(clippy::too_many_arguments)]
fn summary_json(
    scn: &Scenario,
    system: &RodSystem,
    recorded: Map<String, Value>,
    steps: u64,
    planned: u64,
    frames: usize,
    loop_seconds: f64,
    wall_seconds: f64,
    failure: Option<&Failure>,
    final_time: f64,
) -> Value {
    let cfg = &scn.config;
    let dt = cfg.time.dt;
    let failure_json = failure.map(|f| match f {
        Failure::Unstable(e) => {
            let StepError::Unstable {
                what,
                value,
                domain,
                index,
                rod,
                time,
                step,
                dt,
                suggested_dt,
                advice,
            } = e;
            // The element at or next to the failure: node i → element max(i, 1) − 1 (the one
            // ending there), Voronoi point k → element k + 1 (the one starting there).
            let r = rod
                .as_deref()
                .and_then(|n| system.rod_index(n))
                .unwrap_or(0);
            let n = system.rod(r).n_elements();
            let element = match *domain {
                "node" => index.max(&1) - 1,
                "voronoi point" => index + 1,
                _ => *index,
            };
            json!({
                "kind": "unstable",
                "message": e.to_string(),
                "quantity": what,
                "value": value,
                "domain": domain,
                "index": index,
                "rod": rod,
                "element": element.min(n - 1),
                "time": time,
                "step": step,
                "dt": dt,
                "suggested_dt": suggested_dt,
                "advice": advice,
            })
        }
        Failure::Control(msg) => json!({
            "kind": "controller",
            "message": format!("controller: {msg}"),
        }),
        Failure::Interrupted(sig) => json!({
            "kind": "interrupted",
            "message": format!("interrupted by signal {sig} ({}); the state at the stop is the last frame",
                if *sig == 2 { "SIGINT" } else if *sig == 15 { "SIGTERM" } else { "signal" }),
            "signal": sig,
            "time": final_time,
        }),
    });
    let status = match failure {
        None => "completed",
        Some(Failure::Unstable(_)) => "unstable",
        Some(Failure::Control(_)) => "failed",
        Some(Failure::Interrupted(_)) => "interrupted",
    };
    let mut out = Map::new();
    out.insert("program".into(), json!("octoarm"));
    out.insert("version".into(), json!(env!("CARGO_PKG_VERSION")));
    out.insert("scenario".into(), json!(scn.path.display().to_string()));
    out.insert("name".into(), json!(scn.name));
    out.insert("description".into(), json!(cfg.description));
    out.insert("status".into(), json!(status));
    out.insert("steps".into(), json!(steps));
    out.insert("planned_steps".into(), json!(planned));
    out.insert("dt".into(), json!(dt));
    out.insert("stable_dt".into(), json!(system.stable_dt()));
    out.insert("simulated_seconds".into(), json!(steps as f64 * dt));
    out.insert("duration".into(), json!(cfg.time.duration));
    out.insert("wall_seconds".into(), json!(wall_seconds));
    out.insert("loop_seconds".into(), json!(loop_seconds));
    out.insert(
        "us_per_step".into(),
        json!(if steps > 0 {
            loop_seconds * 1e6 / steps as f64
        } else {
            0.0
        }),
    );
    out.insert("save_every_steps".into(), json!(cfg.save_every()));
    out.insert("frames".into(), json!(frames));
    out.insert("final_time".into(), json!(final_time));
    out.insert(
        "controlled".into(),
        json!(cfg.controller.is_some() || cfg.muscle_control.is_some()),
    );
    out.insert("failure".into(), json!(failure_json));
    out.insert("notes".into(), json!(scn.notes));
    // The recorders' keys: rods, final figures, control figures, acceptance, and `arrays`
    // (each trajectory.npz member's shape, unit and domain) and `series_arrays`.
    out.extend(recorded);
    Value::Object(out)
}
