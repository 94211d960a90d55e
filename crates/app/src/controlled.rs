//! Controlled runs: a scenario with `[controller]` is turned into an `ExperimentSpec` of
//! `octoarm-control` (`experiment_spec`) and run by its driver; the frames stream into
//! `trajectory.npz` and the outputs of control spec §5.1 are written (series, distance CSV,
//! summary, figures). The paper command (`paper.rs`) runs four of these; figures are drawn by
//! `paper_figures.rs`. The physics and the control law are the control crate's.

use crate::output::{write_json, write_member, OutputDir, SpooledArray};
use crate::paper::{acceptance, Check};
use crate::paper_figures::{self, FigureFrame};
use crate::progress::RunBar;
use crate::runner::straight_rod;
use crate::scenario::{RuleKind, Scenario, SolverModeKind};
use anyhow::{Context, Result};
use octoarm_control::{
    run_experiment, ExperimentOutcome, ExperimentSink, ExperimentSpec, Frame, GraspSpec,
    SolverMode, SphereSpec, StrainSpace, TargetPhase, UpdateRule,
};
use octoarm_physics::{strains, ContactParams, RodModel, RodState};
use serde_json::json;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;
use zip::ZipWriter;

/// The experiment a controlled scenario describes, or None for a passive scenario (no
/// `[controller]`). The scenario must be validated (`Scenario::load` does it).
pub fn experiment_spec(scn: &Scenario) -> Option<ExperimentSpec> {
    let cfg = &scn.config;
    let ctrl = cfg.controller.as_ref()?;
    let sv = cfg.solver.clone().unwrap_or_else(|| {
        toml::from_str::<crate::scenario::SolverConfig>("").expect("[solver] has defaults")
    });
    let rule = match sv.rule {
        RuleKind::Lbfgs => UpdateRule::Lbfgs {
            memory: sv.lbfgs_memory,
        },
        RuleKind::Preconditioned => UpdateRule::Preconditioned {
            eta: sv.eta.unwrap_or(1.0),
        },
        RuleKind::Paper => UpdateRule::Paper {
            eta: sv.eta.unwrap_or(0.005),
            min_stretch: sv.min_stretch.unwrap_or(0.1),
        },
    };
    let mode = match sv.mode {
        SolverModeKind::Offline => SolverMode::Offline,
        SolverModeKind::Online => SolverMode::Online {
            update_every: sv.update_every,
            iterations_per_update: sv.iterations_per_update,
            trust_form_time: sv.trust_form_time,
            presolve: sv.presolve,
        },
    };
    let (via_points, via_until) = match &cfg.via_path {
        Some(v) => (TargetPhase::polyline(&v.points, v.start, v.end), v.end),
        None => (Vec::new(), 0.0),
    };
    Some(ExperimentSpec {
        name: scn.name.clone(),
        arm: straight_rod(&cfg.rod),
        dt: cfg.time.dt,
        duration: cfg.time.duration,
        damping_rate: cfg.damping.rate,
        mu_tip: sv.mu_tip,
        xi: sv.xi,
        solver: octoarm_control::SolverConfig {
            space: if sv.planar {
                StrainSpace::Planar
            } else {
                StrainSpace::Full
            },
            floor_diameter: sv.design_floor_diameter,
            rule,
            tolerance: sv.tolerance,
            stall_window: sv.stall_window,
            stall_tolerance: sv.stall_tolerance,
            max_sweeps: sv.max_sweeps,
        },
        targets: cfg
            .targets
            .iter()
            .map(|t| TargetPhase {
                from: t.from,
                position: t.position,
                velocity: t.velocity,
            })
            .collect(),
        via_points,
        via_until,
        obstacles: cfg
            .obstacles
            .iter()
            .map(|o| SphereSpec {
                center: o.center,
                diameter: o.diameter,
            })
            .collect(),
        grasp: cfg.grasp.as_ref().map(|g| GraspSpec {
            object: SphereSpec {
                center: g.center,
                diameter: g.diameter,
            },
            weight: g.mu_grasp,
            from_fraction: g.interval[0],
        }),
        mode,
        grasp_stages: sv.grasp_stages,
        ramp_time: sv.ramp_time,
        ramp_every: sv.ramp_every,
        contact: ContactParams {
            beta: cfg.contact.beta,
            zeta: cfg.contact.zeta,
        },
        series_interval: ctrl.series_interval,
        frame_interval: cfg.time.save_interval,
    })
}

/// Steps the driver takes for `spec` (the length of its progress bar).
pub fn total_steps(spec: &ExperimentSpec) -> u64 {
    (spec.duration / spec.dt).round() as u64
}

/// Frames the driver emits for `spec`: t = 0, every frame interval, and the end.
pub fn planned_frames(spec: &ExperimentSpec) -> usize {
    let total = total_steps(spec);
    let every = ((spec.frame_interval / spec.dt).round() as u64).max(1);
    (1 + total / every + u64::from(total % every != 0)) as usize
}

/// Names and per-frame shapes of the streamed members of a controlled `trajectory.npz`.
fn streamed(n: usize) -> [(&'static str, Vec<usize>); 6] {
    [
        ("position", vec![n + 1, 3]),
        ("velocity", vec![n + 1, 3]),
        ("director", vec![n, 3, 3]),
        ("sigma", vec![n, 3]),
        ("kappa", vec![n - 1, 3]),
        ("desired", vec![n + 1, 3]),
    ]
}

/// Streams the driver's frames into spooled `.npz` members and keeps the centrelines for the
/// figures (a 4 s run at 10 ms is 401 frames of ~5 kB each); moves the run's progress bar.
struct TrajectorySink {
    model: RodModel,
    dt: f64,
    bar: RunBar,
    state: RodState,
    sigma: Vec<[f64; 3]>,
    kappa: Vec<[f64; 3]>,
    spools: Vec<SpooledArray>,
    time: Vec<f64>,
    target: Vec<f64>,
    design_target: Vec<f64>,
    frames: Vec<FigureFrame>,
    error: Option<anyhow::Error>,
}

impl TrajectorySink {
    fn new(spec: &ExperimentSpec, dir: &Path, bar: RunBar) -> Result<Self> {
        let (model, state) = spec.arm.build()?;
        let n = model.n_elements;
        let planned = planned_frames(spec);
        let spools = SpooledArray::create_members(dir, streamed(n), planned)?;
        Ok(Self {
            model,
            dt: spec.dt,
            bar,
            state,
            sigma: vec![[0.0; 3]; n],
            kappa: vec![[0.0; 3]; n - 1],
            spools,
            time: Vec::with_capacity(planned),
            target: Vec::with_capacity(3 * planned),
            design_target: Vec::with_capacity(3 * planned),
            frames: Vec::with_capacity(planned),
            error: None,
        })
    }

    fn push(&mut self, f: &Frame) -> Result<()> {
        self.state.position.copy_from_slice(&f.position);
        self.state.director.copy_from_slice(&f.director);
        strains(&self.model, &self.state, &mut self.sigma, &mut self.kappa);
        self.spools[0].push(f.position.as_flattened())?;
        self.spools[1].push(f.velocity.as_flattened())?;
        self.spools[2].push(f.director.as_flattened().as_flattened())?;
        self.spools[3].push(self.sigma.as_flattened())?;
        self.spools[4].push(self.kappa.as_flattened())?;
        self.spools[5].push(f.desired.as_flattened())?;
        self.time.push(f.time);
        self.target
            .extend(f.target.unwrap_or([f64::NAN; 3]).iter().copied());
        self.design_target
            .extend(f.design_target.unwrap_or([f64::NAN; 3]).iter().copied());
        self.frames.push(FigureFrame {
            time: f.time,
            position: f.position.clone(),
            desired: f.desired.clone(),
            target: f.target,
        });
        Ok(())
    }

    /// Write `trajectory.npz` with the frames received (all of them, or those before a failure).
    fn finish(self, path: &Path) -> Result<Vec<FigureFrame>> {
        if let Some(e) = self.error {
            return Err(e.context("recording the frames"));
        }
        let t = self.time.len();
        let file =
            File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
        let mut npz = ZipWriter::new(BufWriter::with_capacity(1 << 16, file));
        write_member(&mut npz, "time", &[t], &self.time)?;
        for spool in self.spools {
            spool.append_to(&mut npz)?;
        }
        write_member(&mut npz, "target", &[t, 3], &self.target)?;
        write_member(&mut npz, "design_target", &[t, 3], &self.design_target)?;
        npz.finish()?.into_inner().map_err(|e| e.into_error())?;
        Ok(self.frames)
    }
}

impl ExperimentSink for TrajectorySink {
    fn frame(&mut self, frame: &Frame) {
        if self.error.is_none() {
            if let Err(e) = self.push(frame) {
                self.error = Some(e);
            }
        }
    }

    fn progress(&mut self, time: f64, _duration: f64) {
        self.bar.update((time / self.dt).round() as u64, time);
    }
}

/// What a controlled run produced.
#[derive(Debug)]
pub struct ControlledRun {
    /// Experiment (scenario) name.
    pub name: String,
    /// Where its outputs are.
    pub out_dir: PathBuf,
    /// Series and derived figures; None if the run failed.
    pub outcome: Option<ExperimentOutcome>,
    /// Why the run failed, if it did.
    pub failure: Option<String>,
    /// Frames written to `trajectory.npz`.
    pub frames: usize,
    /// Acceptance checks (paper experiments only).
    pub checks: Vec<Check>,
    /// Wall time of the run including its outputs [s].
    pub wall_seconds: f64,
}

/// Run a controlled scenario into `out` (committed at the end, also after a failed run) and
/// write trajectory.npz, series.npz, distance.csv, summary.json, scenario.toml, shapes.png and
/// shapes.gif (figures unless `figures` is false). `bar` shows the stepping (`total_steps(spec)`
/// long) and is removed when it ends. Errors are I/O or internal failures; a run the driver
/// stops is reported in `ControlledRun::failure`.
pub fn run(
    scn: &Scenario,
    spec: &ExperimentSpec,
    out: OutputDir,
    figures: bool,
    bar: RunBar,
) -> Result<ControlledRun> {
    let wall = Instant::now();
    tracing::info!(
        "{}: controlled run, {} s at dt = {:e} s, output {}",
        spec.name,
        spec.duration,
        spec.dt,
        out.target().display()
    );
    let mut sink = TrajectorySink::new(spec, &out.path(""), bar)?;
    let result = run_experiment(spec, &mut sink);
    sink.bar.finish();
    let frames = sink.finish(&out.path("trajectory.npz"))?;
    let (outcome, failure) = match result {
        Ok(o) => (Some(o), None),
        Err(e) => (None, Some(format!("{}: {e}", spec.name))),
    };
    std::fs::write(out.path("scenario.toml"), scn.resolved_toml())
        .with_context(|| format!("cannot write {}", out.path("scenario.toml").display()))?;
    let checks = outcome.as_ref().map(acceptance).unwrap_or_default();
    if let Some(o) = &outcome {
        write_series(&out.path("series.npz"), o)?;
        write_distance_csv(&out.path("distance.csv"), o)?;
    }
    if figures && !frames.is_empty() {
        let title = match &failure {
            None => spec.name.clone(),
            Some(_) => format!("{} (failed)", spec.name),
        };
        if let Err(e) = paper_figures::shapes_png(&out.path("shapes.png"), spec, &frames, &title) {
            tracing::warn!("{}: shapes.png not written: {e:#}", spec.name);
        }
        if let Err(e) = paper_figures::shapes_gif(&out.path("shapes.gif"), spec, &frames) {
            tracing::warn!("{}: shapes.gif not written: {e:#}", spec.name);
        }
    }
    let mut run = ControlledRun {
        name: spec.name.clone(),
        out_dir: out.target().to_path_buf(),
        outcome,
        failure,
        frames: frames.len(),
        checks,
        wall_seconds: 0.0,
    };
    run.wall_seconds = wall.elapsed().as_secs_f64();
    write_json(&out.path("summary.json"), &summary_json(scn, spec, &run))?;
    out.commit()?;
    Ok(run)
}

/// `series.npz`: the scalar series of control spec §5.1 and the spheres.
fn write_series(path: &Path, o: &ExperimentOutcome) -> Result<()> {
    let t = o.series.len();
    let file = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut npz = ZipWriter::new(BufWriter::new(file));
    let flat3 = |f: &dyn Fn(&octoarm_control::Sample) -> [f64; 3]| -> Vec<f64> {
        o.series.iter().flat_map(f).collect()
    };
    write_member(&mut npz, "time", &[t], &o.column(|s| s.time))?;
    write_member(&mut npz, "tip", &[t, 3], &flat3(&|s| s.tip))?;
    write_member(&mut npz, "target", &[t, 3], &flat3(&|s| s.target))?;
    type Column = (&'static str, fn(&octoarm_control::Sample) -> f64);
    let columns: [Column; 10] = [
        ("distance", |s| s.distance),
        ("hamiltonian", |s| s.hamiltonian),
        ("kinetic", |s| s.kinetic),
        ("shaped_potential", |s| s.shaped_potential),
        ("contact_energy", |s| s.contact_energy),
        ("control_force_effort", |s| s.control_force_effort),
        ("control_couple_effort", |s| s.control_couple_effort),
        ("control_power", |s| s.control_power),
        ("penetration", |s| s.penetration),
        ("design_epoch", |s| s.design_epoch as f64),
    ];
    for (name, f) in columns {
        write_member(&mut npz, name, &[t], &o.column(f))?;
    }
    let spheres = o.spec.spheres();
    let flat: Vec<f64> = spheres
        .iter()
        .flat_map(|s| [s.center[0], s.center[1], s.center[2], s.diameter])
        .collect();
    write_member(&mut npz, "obstacles", &[spheres.len(), 4], &flat)?;
    npz.finish()?.into_inner().map_err(|e| e.into_error())?;
    Ok(())
}

/// `distance.csv`: `time,distance` (s; d/L0, or d_D for a grasp), one row per sample.
fn write_distance_csv(path: &Path, o: &ExperimentOutcome) -> Result<()> {
    let file = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut w = BufWriter::new(file);
    writeln!(w, "time,distance")?;
    for s in &o.series {
        writeln!(w, "{:.6},{:.9e}", s.time, s.distance)?;
    }
    w.flush()?;
    Ok(())
}

fn summary_json(scn: &Scenario, spec: &ExperimentSpec, run: &ControlledRun) -> serde_json::Value {
    let n = spec.arm.n_elements;
    let f = run.frames;
    let figures = run.outcome.as_ref().map(|o| {
        let s = &o.summary;
        json!({
            "final_distance": s.final_distance,
            "reached": s.reached,
            "segments": s.segments.iter().map(|g| json!({
                "start": g.start,
                "end": g.end,
                "distance_start": g.distance_start,
                "distance_end": g.distance_end,
                "settling_time": g.settling_time,
                "overshoot": g.overshoot,
            })).collect::<Vec<_>>(),
            "control_force_effort": s.force_effort,
            "control_couple_effort": s.couple_effort,
            "control_work": s.control_work,
            "max_penetration": s.max_penetration,
            "sweeps": s.sweeps,
            "failed_updates": s.failed_updates,
            "design_tip_errors": s.design_tip_errors,
            "design_penetrations": s.design_penetrations,
            "experiment_wall_seconds": s.wall_time.as_secs_f64(),
            "samples": o.series.len(),
        })
    });
    json!({
        "program": "octoarm",
        "version": env!("CARGO_PKG_VERSION"),
        "scenario": scn.path.display().to_string(),
        "description": scn.config.description,
        "experiment": spec.name,
        "status": if run.failure.is_some() { "failed" } else { "completed" },
        "failure": run.failure,
        "dt": spec.dt,
        "duration": spec.duration,
        "length": spec.arm.length,
        "frames": f,
        "wall_seconds": run.wall_seconds,
        "summary": figures,
        "units": {
            "distance": "1 (d / L0; grasp: weighted mean surface gap / L0)",
            "settling_time": "s (first time after which d <= 0.02 for the rest of the segment)",
            "control_force_effort": "N^2 s / m",
            "control_couple_effort": "N^2 m s",
            "control_work": "J",
            "max_penetration": "m",
        },
        "acceptance": run.checks.iter().map(|c| json!({
            "claim": c.claim,
            "measured": c.measured,
            "pass": c.pass,
        })).collect::<Vec<_>>(),
        "arrays": {
            "trajectory.npz": {
                "time": [f], "position": [f, n + 1, 3], "velocity": [f, n + 1, 3],
                "director": [f, n, 3, 3], "sigma": [f, n, 3], "kappa": [f, n - 1, 3],
                "desired": [f, n + 1, 3], "target": [f, 3], "design_target": [f, 3],
            },
            "series.npz": ["time", "tip", "target", "distance", "hamiltonian", "kinetic",
                "shaped_potential", "contact_energy", "control_force_effort",
                "control_couple_effort", "control_power", "penetration", "design_epoch",
                "obstacles"],
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::paper::paper_scenarios;
    use crate::scenario::Scenario;

    /// The scenario files under scenarios/paper/ and the control crate's `paper_a()`…`paper_d()`
    /// are two descriptions of the same experiments: `octoarm run scenarios/paper/X.toml` and
    /// `octoarm paper` must run exactly the driver's spec, field by field.
    #[test]
    fn paper_scenarios_resolve_to_the_drivers_specs() {
        let scenarios = paper_scenarios(None).unwrap();
        let expected = ExperimentSpec::paper_all();
        assert_eq!(scenarios.len(), expected.len());
        for (scn, want) in scenarios.iter().zip(&expected) {
            let got = experiment_spec(scn).expect("a controlled scenario");
            assert_eq!(&got, want, "{}", scn.path.display());
            // The file on disk is the compiled-in text, and its resolved form re-runs the same.
            let disk = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../..")
                .join(&scn.path);
            let from_disk = Scenario::load(&disk).unwrap();
            assert_eq!(experiment_spec(&from_disk).as_ref(), Some(want));
            let again = Scenario::from_str(&scn.path, &scn.resolved_toml()).unwrap();
            assert_eq!(experiment_spec(&again).as_ref(), Some(want));
        }
    }

    #[test]
    fn passive_scenarios_have_no_spec_and_control_sections_need_a_controller() {
        let text = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/arm_tip_force.toml"),
        )
        .unwrap();
        let scn = Scenario::from_str(Path::new("p.toml"), &text).unwrap();
        assert!(experiment_spec(&scn).is_none());
        let e = Scenario::from_str(
            Path::new("p.toml"),
            &format!("{text}\n[[target]]\nposition = [0.1, 0.1, 0.0]\n"),
        )
        .unwrap_err();
        assert!(
            e.to_string()
                .contains("target: allowed only with [controller]"),
            "{e}"
        );
    }

    #[test]
    fn control_sections_report_unknown_keys_and_ranges_with_lines() {
        let (_, _, text) = crate::paper::SCENARIOS[0];
        let e = Scenario::from_str(Path::new("a.toml"), &text.replace("mu_tip =", "mu_tipp ="))
            .unwrap_err();
        assert!(
            e.message
                .contains("unknown key `mu_tipp` in [solver]; did you mean `mu_tip`?"),
            "{e}"
        );
        assert!(e.line.is_some());
        let e = Scenario::from_str(
            Path::new("a.toml"),
            &text.replace("from = 1.8", "from = -1.8"),
        )
        .unwrap_err();
        let line = text
            .lines()
            .position(|l| l.starts_with("from = 1.8"))
            .unwrap()
            + 1;
        assert_eq!(e.line.map(|l| l.0), Some(line), "{e}");
        assert!(e.message.contains("target[1].from = -1.8"), "{e}");
    }
}
