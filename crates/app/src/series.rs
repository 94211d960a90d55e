//! The control series recorder of a controlled run (control spec §5.1): every
//! `series_interval` the task distance, the shaped Hamiltonian and its parts, contact energy,
//! penetration and the design epoch, and after the following step the control effort and power
//! of the actuation that step applied. It writes `series.npz` and `distance.csv` and adds the
//! derived figures (segments, settling times, overshoot, effort integrals) and the scenario's
//! acceptance checks to `summary.json`.

use crate::acceptance::{self, Check};
use crate::output::{write_member, OutputDir, SpooledArray};
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

/// Most samples kept in memory for the figures once the series are spooled to disk
/// (`SeriesRecorder::spool_into`); beyond, every other one is dropped and the last is kept.
pub const MAX_KEPT_SAMPLES: usize = 1 << 16;

/// Where complete samples go: into memory (written at the end), or straight to the spools of
/// `series.npz` and to `distance.csv` (constant memory).
enum Sink {
    Memory,
    Spool {
        columns: Vec<SpooledArray>,
        csv: BufWriter<File>,
        csv_path: std::path::PathBuf,
    },
}

/// Records the control series of the run's (first) controller. By default every sample is kept
/// in `samples` and the files are written at the end; after `spool_into` the samples stream to
/// disk as they complete and `samples` keeps a bounded, evenly thinned copy for the figures.
/// The derived figures and the acceptance checks are accumulated sample by sample either way.
pub struct SeriesRecorder {
    every: u64,
    rod: usize,
    length: f64,
    spheres: Vec<Sphere>,
    velocity: Vec<Vec3>,
    omega: Vec<Vec3>,
    pending: bool,
    /// The latest sample, completed by the step that follows it.
    current: Option<Sample>,
    /// Efforts of the last completed sample (for a final sample no step followed).
    previous: Option<(f64, f64, f64)>,
    count: usize,
    stride: usize,
    last_kept: Option<Sample>,
    derived: Deriver,
    tracker: acceptance::Tracker,
    sink: Sink,
    /// The samples: all of them, or (spooled) a thinned copy of at most `MAX_KEPT_SAMPLES`,
    /// ending with the last sample once `finish` has run.
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
            spheres,
            velocity: vec![[0.0; 3]; n_elements + 1],
            omega: vec![[0.0; 3]; n_elements],
            pending: false,
            current: None,
            previous: None,
            count: 0,
            stride: 1,
            last_kept: None,
            derived: Deriver::new(&targets, grasp),
            tracker: acceptance::Tracker::new(acceptance),
            sink: Sink::Memory,
            samples: Vec::new(),
            summary: None,
            checks: Vec::new(),
        }
    }

    /// Stream the samples to the spools of `series.npz` (for `planned` samples, the count of a
    /// complete run) and to `distance.csv` in `out` as they complete, keeping only a thinned
    /// copy in memory. Call before the first sample.
    pub fn spool_into(&mut self, out: &OutputDir, planned: usize) -> Result<()> {
        let dir = out.path("");
        let mut members: Vec<(&str, Vec<usize>)> =
            vec![("time", vec![]), ("tip", vec![3]), ("target", vec![3])];
        for (name, _) in COLUMNS {
            members.push((name, vec![]));
        }
        let mut columns = Vec::with_capacity(members.len());
        for (name, shape) in members {
            // Hidden spool files beside trajectory.npz's (whose names have no "series-").
            let file = dir.join(format!(".series-{name}.spool"));
            columns.push(SpooledArray::create(file, name, &shape, planned)?);
        }
        let csv_path = out.path("distance.csv");
        let file = File::create(&csv_path)
            .with_context(|| format!("cannot create {}", csv_path.display()))?;
        let mut csv = BufWriter::new(file);
        writeln!(csv, "time,distance")
            .with_context(|| format!("cannot write {}", csv_path.display()))?;
        self.sink = Sink::Spool {
            columns,
            csv,
            csv_path,
        };
        Ok(())
    }

    /// Samples recorded so far.
    pub fn count(&self) -> usize {
        self.count
    }

    /// A sample is complete (its efforts known): fold it into the figures and checks and send
    /// it to its sink.
    fn complete(&mut self, sample: Sample) -> Result<()> {
        self.count += 1;
        self.previous = Some((
            sample.control_force_effort,
            sample.control_couple_effort,
            sample.control_power,
        ));
        self.derived.observe(&sample);
        self.tracker.observe(&sample);
        match &mut self.sink {
            Sink::Memory => self.samples.push(sample),
            Sink::Spool {
                columns,
                csv,
                csv_path,
            } => {
                columns[0].push(&[sample.time])?;
                columns[1].push(&sample.tip)?;
                columns[2].push(&sample.target)?;
                for (c, (_, f)) in COLUMNS.iter().enumerate() {
                    columns[3 + c].push(&[f(&sample)])?;
                }
                writeln!(csv, "{:.6},{:.9e}", sample.time, sample.distance)
                    .with_context(|| format!("cannot write {}", csv_path.display()))?;
                let index = self.count - 1;
                if index % self.stride == 0 {
                    self.samples.push(sample);
                    if self.samples.len() > MAX_KEPT_SAMPLES {
                        let kept: Vec<Sample> = self.samples.iter().step_by(2).copied().collect();
                        self.samples = kept;
                        self.stride *= 2;
                    }
                }
                self.last_kept = Some(sample);
            }
        }
        Ok(())
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
        if let Some(done) = self.current.take() {
            self.complete(done)?;
        }
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
        self.current = Some(Sample {
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
            if let Some(last) = &mut self.current {
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
        if let Some(last) = &mut self.current {
            last.control_force_effort = fe;
            last.control_couple_effort = ce;
            last.control_power = p;
        }
        Ok(())
    }

    fn finish(&mut self, out: &OutputDir, run: &RunInfo) -> Result<Map<String, Value>> {
        // The last sample has no following step: carry the previous effort (for the integrals;
        // 0 for a lone sample).
        if let Some(mut last) = self.current.take() {
            if last.control_force_effort.is_nan() {
                let (fe, ce, p) = self.previous.unwrap_or((0.0, 0.0, 0.0));
                last.control_force_effort = fe;
                last.control_couple_effort = ce;
                last.control_power = p;
            }
            self.complete(last)?;
        }
        let report = run.control.clone().unwrap_or_default();
        let summary = self.derived.summary(run.duration, report);
        match std::mem::replace(&mut self.sink, Sink::Memory) {
            Sink::Memory => {
                write_series(&out.path("series.npz"), &self.samples, &self.spheres)?;
                write_distance_csv(&out.path("distance.csv"), &self.samples)?;
            }
            Sink::Spool {
                columns,
                mut csv,
                csv_path,
            } => {
                let path = out.path("series.npz");
                let file = File::create(&path)
                    .with_context(|| format!("cannot create {}", path.display()))?;
                let mut npz = zip::ZipWriter::new(BufWriter::new(file));
                for c in columns {
                    c.append_to(&mut npz)?;
                }
                write_spheres(&mut npz, &self.spheres)?;
                npz.finish()?.into_inner().map_err(|e| e.into_error())?;
                csv.flush()
                    .with_context(|| format!("cannot write {}", csv_path.display()))?;
                if let Some(last) = self.last_kept.take() {
                    if self.samples.last().map(|s| s.time) != Some(last.time) {
                        self.samples.push(last);
                    }
                }
            }
        }
        self.checks = self.tracker.checks(&summary, self.length, run.duration);
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
                "samples": self.count,
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

/// One segment being accumulated.
#[derive(Debug, Clone, Copy)]
struct Segment {
    start: f64,
    distance_start: f64,
    distance_end: f64,
    settling: Option<f64>,
    overshoot: f64,
    r0: Vec3,
}

/// The derived figures of spec §5.1, accumulated sample by sample (constant memory).
#[derive(Debug, Clone)]
struct Deriver {
    starts: Vec<f64>,
    grasp: bool,
    /// Index of the segment of the last sample.
    at: usize,
    /// (segment index, figures) of the segments that have samples.
    segments: Vec<(usize, Segment)>,
    previous: Option<Sample>,
    last: Option<Sample>,
    force_effort: f64,
    couple_effort: f64,
    control_work: f64,
    max_penetration: f64,
}

impl Deriver {
    fn new(targets: &[TargetPhase], grasp: bool) -> Self {
        // Segments: task-target phases (a grasp is one segment).
        let mut starts: Vec<f64> = targets.iter().map(|p| p.from.max(0.0)).collect();
        if starts.is_empty() {
            starts.push(0.0);
        }
        starts[0] = 0.0;
        Self {
            starts,
            grasp,
            at: 0,
            segments: Vec::new(),
            previous: None,
            last: None,
            force_effort: 0.0,
            couple_effort: 0.0,
            control_work: 0.0,
            max_penetration: 0.0,
        }
    }

    fn observe(&mut self, s: &Sample) {
        self.max_penetration = self.max_penetration.max(s.penetration);
        // Integrals by the left rectangle rule on the sample grid.
        if let Some(p) = &self.previous {
            let h = s.time - p.time;
            self.force_effort += p.control_force_effort * h;
            self.couple_effort += p.control_couple_effort * h;
            self.control_work += p.control_power * h;
        }
        self.previous = Some(*s);
        self.last = Some(*s);
        // The segment of the sample: [start_k, start_{k+1}) (within 1e-12 s), the last open.
        let k_last = self.starts.len() - 1;
        while self.at < k_last && s.time >= self.starts[self.at + 1] - 1e-12 {
            self.at += 1;
        }
        let k = self.at;
        if s.time < self.starts[k] - 1e-12 {
            return;
        }
        if self.segments.last().map(|(i, _)| *i) != Some(k) {
            self.segments.push((
                k,
                Segment {
                    start: self.starts[k],
                    distance_start: s.distance,
                    distance_end: s.distance,
                    settling: Some(s.time),
                    overshoot: 0.0,
                    r0: s.tip,
                },
            ));
        }
        let grasp = self.grasp;
        let g = &mut self.segments.last_mut().expect("just pushed").1;
        g.distance_end = s.distance;
        if s.distance > SETTLING_BAND {
            g.settling = None;
        } else if g.settling.is_none() {
            g.settling = Some(s.time);
        }
        if !grasp {
            let line = sub(s.target, g.r0);
            let l2 = dot(line, line);
            if l2 > 0.0 {
                let p = dot(sub(s.tip, g.r0), line) / l2;
                g.overshoot = g.overshoot.max(p - 1.0);
            }
        }
    }

    fn summary(&self, duration: f64, report: ControlReport) -> ControlSummary {
        let mut out = ControlSummary {
            final_distance: f64::NAN,
            segments: Vec::new(),
            force_effort: 0.0,
            couple_effort: 0.0,
            control_work: 0.0,
            max_penetration: self.max_penetration,
            reached: false,
            report,
        };
        let Some(last) = &self.last else {
            return out;
        };
        out.final_distance = last.distance;
        out.reached = last.distance <= SETTLING_BAND;
        out.force_effort = self.force_effort;
        out.couple_effort = self.couple_effort;
        out.control_work = self.control_work;
        out.segments = self
            .segments
            .iter()
            .map(|(k, g)| SegmentSummary {
                start: g.start,
                end: self.starts.get(k + 1).copied().unwrap_or(duration),
                distance_start: g.distance_start,
                distance_end: g.distance_end,
                settling_time: g.settling,
                overshoot: g.overshoot,
            })
            .collect();
        out
    }
}

/// The scalar columns of `series.npz` after time, tip and target, in member order.
type Column = (&'static str, fn(&Sample) -> f64);
const COLUMNS: [Column; 10] = [
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

/// Derived figures (spec §5.1) from the series.
pub fn derive(
    series: &[Sample],
    targets: &[TargetPhase],
    grasp: bool,
    duration: f64,
    report: ControlReport,
) -> ControlSummary {
    let mut d = Deriver::new(targets, grasp);
    for s in series {
        d.observe(s);
    }
    d.summary(duration, report)
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
    for (name, f) in COLUMNS {
        write_member(&mut npz, name, &[t], &column(&f))?;
    }
    write_spheres(&mut npz, spheres)?;
    npz.finish()?.into_inner().map_err(|e| e.into_error())?;
    Ok(())
}

/// The `obstacles` member: one row (centre, diameter) per sphere.
fn write_spheres<W: Write + std::io::Seek>(
    npz: &mut zip::ZipWriter<W>,
    spheres: &[Sphere],
) -> Result<()> {
    let flat: Vec<f64> = spheres
        .iter()
        .flat_map(|s| [s.center[0], s.center[1], s.center[2], 2.0 * s.radius])
        .collect();
    write_member(npz, "obstacles", &[spheres.len(), 4], &flat)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::{AcceptanceConfig, AcceptanceQuantity};
    use std::io::Read;

    fn sample(k: usize) -> Sample {
        let t = k as f64 * 1e-3;
        Sample {
            time: t,
            tip: [0.2 - t * 0.1, t * 0.05, 0.0],
            target: [0.09, 0.09, 0.0],
            distance: 0.5 * (-3.0 * t).exp(),
            hamiltonian: 1.0 + t,
            kinetic: t,
            shaped_potential: 1.0,
            contact_energy: 0.0,
            control_force_effort: 2.0 + t,
            control_couple_effort: 3.0 - t,
            control_power: -t,
            penetration: 1e-4 * t,
            design_epoch: (k / 100) as u64,
        }
    }

    fn members(path: &std::path::Path) -> Vec<(String, Vec<u8>)> {
        let mut zip = zip::ZipArchive::new(File::open(path).unwrap()).unwrap();
        (0..zip.len())
            .map(|i| {
                let mut m = zip.by_index(i).unwrap();
                let mut bytes = Vec::new();
                m.read_to_end(&mut bytes).unwrap();
                (m.name().to_string(), bytes)
            })
            .collect()
    }

    #[test]
    fn spooled_series_equal_the_series_kept_in_memory() {
        let claim =
            |quantity, time: Option<f64>, from: Option<f64>, to: Option<f64>| AcceptanceConfig {
                claim: format!("{quantity:?}"),
                quantity,
                time,
                from,
                to,
                segment: (quantity == AcceptanceQuantity::SettlingTime).then_some(1),
                group: None,
                min: None,
                max: Some(0.3),
                note: None,
                infeasible: false,
            };
        use AcceptanceQuantity as Q;
        let claims = vec![
            claim(Q::DistanceBefore, Some(0.1), None, None),
            claim(Q::DistanceAfter, Some(0.1), None, None),
            claim(Q::DistanceAt, Some(0.25), None, None),
            claim(Q::MaxDistance, None, Some(0.05), Some(0.2)),
            claim(Q::DistanceRise, None, None, None),
            claim(Q::SettlingTime, None, None, None),
            claim(Q::MaxPenetration, None, None, None),
        ];
        let targets = vec![
            TargetPhase {
                from: 0.0,
                position: [0.09, 0.09, 0.0],
                velocity: [0.0; 3],
            },
            TargetPhase {
                from: 0.15,
                position: [0.0, 0.02, 0.0],
                velocity: [0.0; 3],
            },
        ];
        let spheres = vec![Sphere::fixed([0.1, 0.05, 0.0], 0.02)];
        let dir = tempfile::tempdir().unwrap();
        let run = RunInfo {
            duration: 0.3,
            control: None,
            failure: None,
        };
        let mut outputs = Vec::new();
        for spooled in [false, true] {
            let mut rec = SeriesRecorder::new(
                1,
                0,
                4,
                0.2,
                targets.clone(),
                false,
                spheres.clone(),
                claims.clone(),
            );
            let out = OutputDir::prepare(&dir.path().join(format!("out{spooled}"))).unwrap();
            if spooled {
                rec.spool_into(&out, 301).unwrap();
            }
            for k in 0..300 {
                rec.complete(sample(k)).unwrap();
            }
            // The last sample: no step followed it, its efforts are carried.
            let mut last = sample(300);
            last.control_force_effort = f64::NAN;
            last.control_couple_effort = f64::NAN;
            last.control_power = f64::NAN;
            rec.current = Some(last);
            let map = rec.finish(&out, &run).unwrap();
            assert_eq!(rec.count(), 301);
            assert_eq!(rec.samples.len(), 301);
            let npz = members(&out.path("series.npz"));
            let csv = std::fs::read(out.path("distance.csv")).unwrap();
            outputs.push((map, npz, csv, rec.checks.clone(), rec.samples.clone()));
        }
        let (a, b) = (&outputs[0], &outputs[1]);
        assert_eq!(a.0, b.0);
        assert_eq!(a.1, b.1);
        assert_eq!(a.2, b.2);
        assert_eq!(a.3, b.3);
        assert_eq!(a.4, b.4);
        // The checks and figures are those of the whole-series functions.
        let summary = derive(&a.4, &targets, false, 0.3, ControlReport::default());
        let checks = acceptance::evaluate(&claims, &a.4, &summary, 0.2, 0.3);
        assert_eq!(a.3, checks);
        assert_eq!(a.4[300].control_force_effort, a.4[299].control_force_effort);
        assert_eq!(summary.segments.len(), 2);
        // Decided but the settling time of the last segment, which the run ends before.
        assert!(a.3[..5].iter().all(|c| c.pass.is_some()), "{:?}", a.3);
        assert_eq!(a.3[5].pass, None, "{:?}", a.3);
    }
}
