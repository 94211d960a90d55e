//! The control series recorder of a controlled run (control spec §5.1): every
//! `series_interval` the task distance, the shaped Hamiltonian and its parts, contact energy,
//! penetration and the design epoch, and after the following step the control effort and power
//! of the actuation that step applied. It writes `series.npz` and `distance.csv` and adds the
//! derived figures (segments, settling times, overshoot, effort integrals) and the scenario's
//! acceptance checks to `summary.json`.

use crate::acceptance::{self, Check};
use crate::output::{write_member, OutputDir};
use crate::pipeline::{Moment, Recorder, RunInfo};
use anyhow::{Context, Result};
use octoarm_control::{ControlReport, TargetPhase};
use octoarm_physics::math::{dot, sub};
use octoarm_physics::{contact_energy, max_penetration, Sphere, Vec3};
use serde_json::{json, Map, Value};
use std::fs::File;
use std::io::{BufWriter, Write};

/// Band of the settling time, d ≤ 0.02 (normalised by L0; spec §5.1).
pub const SETTLING_BAND: f64 = 0.02;

/// One sample of the scalar series (spec §5.1), SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time [s].
    pub time: f64,
    /// Tip position [m].
    pub tip: Vec3,
    /// Task target in force [m] (NaN for a grasp).
    pub target: Vec3,
    /// d/L0 (tip distance) or d_D (grasp's weighted mean surface gap / L0).
    pub distance: f64,
    /// Shaped Hamiltonian H̄_h = kinetic + shaped potential + contact energy [J].
    pub hamiltonian: f64,
    /// Kinetic energy [J].
    pub kinetic: f64,
    /// Strain energy measured from w̄ [J].
    pub shaped_potential: f64,
    /// Contact penalty energy [J].
    pub contact_energy: f64,
    /// Σ_i |F^u_i|²/ω_i [N²/m] of the actuation over the step that follows the sample.
    pub control_force_effort: f64,
    /// Σ_j |C^u_j|²/ℓ̂_j [N² m].
    pub control_couple_effort: f64,
    /// Σ F^u·v + Σ C^u·ω [W] with the velocities at the sample.
    pub control_power: f64,
    /// Largest penetration of the arm's surface into a sphere [m].
    pub penetration: f64,
    /// Counter of design changes: constant between changes of w̄ (Lyapunov intervals).
    pub design_epoch: u64,
}

/// Derived figures of one segment (constant task target, or the whole run).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentSummary {
    /// Start [s].
    pub start: f64,
    /// End [s].
    pub end: f64,
    /// d at the start (after a switch: the jump).
    pub distance_start: f64,
    /// d at the end of the segment (last sample before the next one).
    pub distance_end: f64,
    /// First time [s] after which d ≤ 0.02 for the rest of the segment (None if never).
    pub settling_time: Option<f64>,
    /// max(0, max_t p(t) − 1) with p the progress along the start-to-target line (spec §5.1).
    pub overshoot: f64,
}

/// Derived figures of a controlled run (spec §5.1).
#[derive(Debug, Clone, PartialEq)]
pub struct ControlSummary {
    /// d (or d_D) at the end.
    pub final_distance: f64,
    /// Segments of constant task target (or the whole run).
    pub segments: Vec<SegmentSummary>,
    /// ∫ Σ|F^u|²/ω dt [N² s/m].
    pub force_effort: f64,
    /// ∫ Σ|C^u|²/ℓ̂ dt [N² m s].
    pub couple_effort: f64,
    /// ∫ control power dt [J].
    pub control_work: f64,
    /// Largest penetration over the samples [m].
    pub max_penetration: f64,
    /// True if the end distance is within the settling band 0.02.
    pub reached: bool,
    /// The controller's counters and design figures.
    pub report: ControlReport,
}

/// Records the control series of the run's (first) controller.
pub struct SeriesRecorder {
    every: u64,
    rod: usize,
    length: f64,
    targets: Vec<TargetPhase>,
    grasp: bool,
    spheres: Vec<Sphere>,
    acceptance: Vec<crate::scenario::AcceptanceConfig>,
    velocity: Vec<Vec3>,
    omega: Vec<Vec3>,
    pending: bool,
    /// The samples so far.
    pub samples: Vec<Sample>,
    /// Derived figures, after `finish`.
    pub summary: Option<ControlSummary>,
    /// Acceptance checks, after `finish`.
    pub checks: Vec<Check>,
}

impl SeriesRecorder {
    /// A recorder sampling rod `rod` every `every` steps; `length` is L0 (the model's, as the
    /// distance uses), `targets` the task targets (segments), `grasp` whether it is a grasp.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        every: u64,
        rod: usize,
        n_elements: usize,
        length: f64,
        targets: Vec<TargetPhase>,
        grasp: bool,
        spheres: Vec<Sphere>,
        acceptance: Vec<crate::scenario::AcceptanceConfig>,
    ) -> Self {
        Self {
            every,
            rod,
            length,
            targets,
            grasp,
            spheres,
            acceptance,
            velocity: vec![[0.0; 3]; n_elements + 1],
            omega: vec![[0.0; 3]; n_elements],
            pending: false,
            samples: Vec::new(),
            summary: None,
            checks: Vec::new(),
        }
    }
}

impl Recorder for SeriesRecorder {
    fn every(&self) -> u64 {
        self.every
    }

    fn record(&mut self, m: &mut Moment<'_>) -> Result<()> {
        let s = m.state;
        let t = s.time;
        let Some(c) = m.controllers.first() else {
            return Ok(());
        };
        let sig = c.signals(t, m.system, s);
        let rod = m.system.rod(self.rod);
        let view = m.system.view(s, self.rod);
        let contact = contact_energy(&rod.model, &view, &self.spheres, m.system.contact(), t);
        let (pen, _) = max_penetration(&rod.model, &view, &self.spheres, t);
        let shaped = sig.shaped.unwrap_or_default();
        let n = rod.n_elements();
        let first = rod.offsets();
        for (i, v) in self.velocity.iter_mut().enumerate() {
            *v = s.velocity.get(first.node + i);
        }
        for (j, w) in self.omega.iter_mut().enumerate() {
            *w = s.omega.get(first.element + j);
        }
        self.samples.push(Sample {
            time: t,
            tip: s.position.get(first.node + n),
            target: sig.target.unwrap_or([f64::NAN; 3]),
            distance: sig.distance,
            hamiltonian: shaped.total() + contact,
            kinetic: shaped.kinetic(),
            shaped_potential: shaped.potential(),
            contact_energy: contact,
            control_force_effort: f64::NAN,
            control_couple_effort: f64::NAN,
            control_power: f64::NAN,
            penetration: pen,
            design_epoch: sig.design_epoch,
        });
        self.pending = true;
        Ok(())
    }

    fn after_step(&mut self, m: &Moment<'_>) -> Result<()> {
        if !self.pending {
            return Ok(());
        }
        self.pending = false;
        let rod = m.system.rod(self.rod);
        let model = &rod.model;
        let at = rod.offsets();
        let (Some(f), Some(c)) = (
            m.workspace.actuation_force(),
            m.workspace.actuation_couple(),
        ) else {
            if let Some(last) = self.samples.last_mut() {
                last.control_force_effort = 0.0;
                last.control_couple_effort = 0.0;
                last.control_power = 0.0;
            }
            return Ok(());
        };
        let (mut fe, mut ce, mut p) = (0.0, 0.0, 0.0);
        for k in 0..=model.n_elements {
            let fk = f.get(at.node + k);
            let w = model.nodal_rest_length[k];
            if w > 0.0 {
                fe += dot(fk, fk) / w;
            }
            p += dot(fk, self.velocity[k]);
        }
        for j in 0..model.n_elements {
            let cj = c.get(at.element + j);
            ce += dot(cj, cj) / model.rest_length[j];
            p += dot(cj, self.omega[j]);
        }
        if let Some(last) = self.samples.last_mut() {
            last.control_force_effort = fe;
            last.control_couple_effort = ce;
            last.control_power = p;
        }
        Ok(())
    }

    fn finish(&mut self, out: &OutputDir, run: &RunInfo) -> Result<Map<String, Value>> {
        // The last sample has no following step: carry the previous effort (for the integrals).
        let len = self.samples.len();
        if len >= 2 && self.samples[len - 1].control_force_effort.is_nan() {
            let prev = self.samples[len - 2];
            let last = &mut self.samples[len - 1];
            last.control_force_effort = prev.control_force_effort;
            last.control_couple_effort = prev.control_couple_effort;
            last.control_power = prev.control_power;
        }
        let report = run.control.clone().unwrap_or_default();
        let summary = derive(
            &self.samples,
            &self.targets,
            self.grasp,
            run.duration,
            report,
        );
        write_series(&out.path("series.npz"), &self.samples, &self.spheres)?;
        write_distance_csv(&out.path("distance.csv"), &self.samples)?;
        self.checks = acceptance::evaluate(
            &self.acceptance,
            &self.samples,
            &summary,
            self.length,
            run.duration,
        );
        let s = &summary;
        let mut map = Map::new();
        map.insert(
            "control".into(),
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
                "sweeps": s.report.sweeps,
                "failed_updates": s.report.failed_updates,
                "design_tip_errors": s.report.design_tip_errors,
                "design_penetrations": s.report.design_penetrations,
                "samples": self.samples.len(),
                "units": {
                    "distance": "1 (d / L0; grasp: weighted mean surface gap / L0)",
                    "settling_time": "s (first time after which d <= 0.02 for the rest of the segment)",
                    "control_force_effort": "N^2 s / m",
                    "control_couple_effort": "N^2 m s",
                    "control_work": "J",
                    "max_penetration": "m",
                },
            }),
        );
        map.insert(
            "acceptance".into(),
            Value::Array(
                self.checks
                    .iter()
                    .map(|c| json!({"claim": c.claim, "measured": c.measured, "pass": c.pass, "note": c.note}))
                    .collect(),
            ),
        );
        map.insert(
            "series_arrays".into(),
            json!([
                "time",
                "tip",
                "target",
                "distance",
                "hamiltonian",
                "kinetic",
                "shaped_potential",
                "contact_energy",
                "control_force_effort",
                "control_couple_effort",
                "control_power",
                "penetration",
                "design_epoch",
                "obstacles"
            ]),
        );
        self.summary = Some(summary);
        Ok(map)
    }
}

/// Derived figures (spec §5.1) from the series.
pub fn derive(
    series: &[Sample],
    targets: &[TargetPhase],
    grasp: bool,
    duration: f64,
    report: ControlReport,
) -> ControlSummary {
    let mut out = ControlSummary {
        final_distance: f64::NAN,
        segments: Vec::new(),
        force_effort: 0.0,
        couple_effort: 0.0,
        control_work: 0.0,
        max_penetration: series.iter().map(|s| s.penetration).fold(0.0, f64::max),
        reached: false,
        report,
    };
    let Some(last) = series.last() else {
        return out;
    };
    out.final_distance = last.distance;
    out.reached = last.distance <= SETTLING_BAND;
    // Integrals by the left rectangle rule on the sample grid.
    for w in series.windows(2) {
        let h = w[1].time - w[0].time;
        out.force_effort += w[0].control_force_effort * h;
        out.couple_effort += w[0].control_couple_effort * h;
        out.control_work += w[0].control_power * h;
    }
    // Segments: task-target phases (a grasp is one segment).
    let mut starts: Vec<f64> = targets.iter().map(|p| p.from.max(0.0)).collect();
    if starts.is_empty() {
        starts.push(0.0);
    }
    starts[0] = 0.0;
    for (k, &start) in starts.iter().enumerate() {
        let end = starts.get(k + 1).copied().unwrap_or(duration);
        let seg: Vec<&Sample> = series
            .iter()
            .filter(|s| s.time >= start - 1e-12 && (s.time < end - 1e-12 || k + 1 == starts.len()))
            .collect();
        let Some(first) = seg.first() else { continue };
        let last = seg[seg.len() - 1];
        let mut settling = Some(first.time);
        for s in &seg {
            if s.distance > SETTLING_BAND {
                settling = None;
            } else if settling.is_none() {
                settling = Some(s.time);
            }
        }
        let mut overshoot: f64 = 0.0;
        if !grasp {
            let r0 = first.tip;
            for s in &seg {
                let line = sub(s.target, r0);
                let l2 = dot(line, line);
                if l2 > 0.0 {
                    let p = dot(sub(s.tip, r0), line) / l2;
                    overshoot = overshoot.max(p - 1.0);
                }
            }
        }
        out.segments.push(SegmentSummary {
            start,
            end,
            distance_start: first.distance,
            distance_end: last.distance,
            settling_time: settling,
            overshoot,
        });
    }
    out
}

/// `series.npz`: the scalar series of control spec §5.1 and the spheres.
fn write_series(path: &std::path::Path, series: &[Sample], spheres: &[Sphere]) -> Result<()> {
    let t = series.len();
    let file = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut npz = zip::ZipWriter::new(BufWriter::new(file));
    let column = |f: &dyn Fn(&Sample) -> f64| -> Vec<f64> { series.iter().map(f).collect() };
    let flat3 =
        |f: &dyn Fn(&Sample) -> [f64; 3]| -> Vec<f64> { series.iter().flat_map(f).collect() };
    write_member(&mut npz, "time", &[t], &column(&|s| s.time))?;
    write_member(&mut npz, "tip", &[t, 3], &flat3(&|s| s.tip))?;
    write_member(&mut npz, "target", &[t, 3], &flat3(&|s| s.target))?;
    type Column = (&'static str, fn(&Sample) -> f64);
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
        write_member(&mut npz, name, &[t], &column(&f))?;
    }
    let flat: Vec<f64> = spheres
        .iter()
        .flat_map(|s| [s.center[0], s.center[1], s.center[2], 2.0 * s.radius])
        .collect();
    write_member(&mut npz, "obstacles", &[spheres.len(), 4], &flat)?;
    npz.finish()?.into_inner().map_err(|e| e.into_error())?;
    Ok(())
}

/// `distance.csv`: `time,distance` (s; d/L0, or d_D for a grasp), one row per sample.
fn write_distance_csv(path: &std::path::Path, series: &[Sample]) -> Result<()> {
    let file = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut w = BufWriter::new(file);
    writeln!(w, "time,distance")?;
    for s in series {
        writeln!(w, "{:.6},{:.9e}", s.time, s.distance)?;
    }
    w.flush()?;
    Ok(())
}
