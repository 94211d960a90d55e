//! The trajectory recorder: samples every rod of the system at the frames the pipeline asks for
//! and streams every array of them (time, states, strains, energies, targets) to
//! `trajectory.npz` on a writer thread (compression off the stepping thread). Its memory does
//! not grow with the run's length: for the figures it keeps a bounded, evenly thinned copy of
//! the per-frame time, energies and tips (at most `MAX_PLOT_FRAMES`, the last frame always
//! included), a bounded number of centrelines and of the controlled rod's frames. Array keys:
//! `position`, … for a lone rod; `<rod name>/position`, … for several.

use crate::output::{OutputDir, SpooledArray};
use crate::pipeline::{Moment, Recorder, RunInfo};
use anyhow::{anyhow, Context, Result};
use octoarm_physics::{energies_with_rest, strains, RodModel, RodState, Vec3};
use serde_json::{json, Map, Value};
use std::fs::File;
use std::io::BufWriter;
use std::sync::mpsc::{self, Receiver, SyncSender};
use std::sync::Arc;
use std::thread::JoinHandle;
use zip::ZipWriter;

/// Most centrelines kept in memory for `shapes.png` (fewer for very long rods: at most
/// `MAX_KEPT_POINTS` points in all).
pub const MAX_SHAPES: usize = 200;
/// Most frames of the controlled rod kept in memory for the control figures and the GIF (fewer
/// for very long rods: at most `MAX_KEPT_POINTS` points in all).
pub const MAX_CONTROL_FRAMES: usize = 2000;
/// Most frames of time, energies and tips kept in memory for the figures (fewer with many rods:
/// at most `MAX_PLOT_VALUES` numbers in all); beyond, every other one is dropped (the stride
/// doubles) and the last frame is always kept. `trajectory.npz` has every frame.
pub const MAX_PLOT_FRAMES: usize = 1 << 14;
/// Numbers of the per-frame figure data kept in memory (time, 6 energies and a tip per rod).
pub const MAX_PLOT_VALUES: usize = 1 << 22;
/// Centreline points kept in memory for the figures, each of `shapes` and `control_frames`.
pub const MAX_KEPT_POINTS: usize = 4_000_000;
/// Frames that may wait for the writer thread before `record` blocks.
const QUEUE: usize = 64;

/// The `.npz` key of a rod's array: `field` for a lone rod, `<rod>/field` in a system.
pub fn array_key(multi: bool, rod: &str, field: &str) -> String {
    if multi {
        format!("{rod}/{field}")
    } else {
        field.to_string()
    }
}

/// Names, per-frame shapes, units and domains of a rod's streamed arrays. N = elements.
pub fn rod_arrays(n: usize) -> [(&'static str, Vec<usize>, &'static str, &'static str); 6] {
    [
        ("position", vec![n + 1, 3], "m", "node, lab frame"),
        ("velocity", vec![n + 1, 3], "m/s", "node, lab frame"),
        (
            "director",
            vec![n, 3, 3],
            "1",
            "element, rows d1, d2, d3 in lab components",
        ),
        (
            "omega",
            vec![n, 3],
            "rad/s",
            "element, angular velocity, material frame",
        ),
        (
            "sigma",
            vec![n, 3],
            "1",
            "element, shear/stretch strain, material frame (sigma3 = e - 1 stretch)",
        ),
        (
            "kappa",
            vec![n - 1, 3],
            "1/m",
            "interior node (Voronoi point), curvature/twist, material frame",
        ),
    ]
}

/// Per-frame scalar series of each rod: name, unit, meaning.
pub const SERIES: [(&str, &str, &str); 6] = [
    ("energy_translational", "J", "kinetic energy of the nodes"),
    (
        "energy_rotational",
        "J",
        "kinetic energy of the element rotations",
    ),
    ("energy_stretch", "J", "shear/stretch strain energy"),
    ("energy_bend", "J", "bend/twist strain energy"),
    (
        "external_work",
        "J",
        "work done by the external loads (loads, contact, joints, actuation) since t = 0",
    ),
    (
        "dissipated_energy",
        "J",
        "energy removed by damping since t = 0",
    ),
];

/// The `.npz` key of the obstacles' friction springs (`SystemState::stick`), per frame
/// [slots, 3], written when the system has frictional obstacles: what `[initial_state]` needs
/// to continue a frictional contact exactly.
pub const STICK_ARRAY: &str = "contact_stick";

/// One frame of the controlled rod kept for the control figures.
#[derive(Debug, Clone, PartialEq)]
pub struct ControlFrame {
    /// Time [s].
    pub time: f64,
    /// Centreline [m].
    pub position: Vec<Vec3>,
    /// The controller's desired shape [m] (empty if it has none).
    pub desired: Vec<Vec3>,
    /// Task target in force (None for a grasp).
    pub target: Option<Vec3>,
}

struct RodInfo {
    name: String,
    model: Arc<RodModel>,
    first_node: usize,
    first_element: usize,
}

/// Streams frames of every rod to `trajectory.npz` (and keeps the figures' data).
pub struct TrajectoryRecorder {
    every: u64,
    // Stick springs per frame (0: no frictional obstacle, no `contact_stick` member).
    stick_slots: usize,
    planned: usize,
    multi: bool,
    rods: Vec<RodInfo>,
    controlled: Option<usize>,
    tx: Option<SyncSender<Vec<f64>>>,
    recycle: Receiver<Vec<f64>>,
    worker: Option<JoinHandle<Result<Vec<SpooledArray>>>>,
    shape_stride: usize,
    control_stride: usize,
    recorded: usize,
    plot_stride: usize,
    plot_cap: usize,
    /// Time of the frames kept for the figures [s]: every frame of a run of up to
    /// `MAX_PLOT_FRAMES` frames, else evenly thinned; the last recorded frame is included once
    /// `finish` has run.
    pub time: Vec<f64>,
    /// Per rod, per kept frame: the `SERIES` values in order.
    pub series: Vec<Vec<[f64; 6]>>,
    /// Per rod, per kept frame: tip position [m].
    pub tips: Vec<Vec<Vec3>>,
    /// Thinned frames (time, every rod's centreline), ending with the last recorded frame once
    /// `finish` has run.
    pub shapes: Vec<(f64, Vec<Vec<Vec3>>)>,
    /// Frames of the controlled rod (thinned to at most `MAX_CONTROL_FRAMES`, the last kept).
    pub control_frames: Vec<ControlFrame>,
    last: (f64, Vec<Vec<Vec3>>),
    last_plot: Option<(f64, Vec<[f64; 6]>, Vec<Vec3>)>,
    last_control: Option<ControlFrame>,
    // The rest strains in force at a frame (scheduled changes), filled once per frame.
    rest_sigma: Vec<Vec3>,
    rest_kappa: Vec<Vec3>,
}

impl TrajectoryRecorder {
    /// A recorder of `planned` frames, one every `every` steps, of the rods of `system`,
    /// spooling into `out`. `controlled` is the controlled rod, whose desired shape and targets
    /// are recorded too.
    pub fn new(
        system: &octoarm_physics::RodSystem,
        every: u64,
        planned: usize,
        controlled: Option<usize>,
        out: &OutputDir,
    ) -> Result<Self> {
        let multi = system.rods().len() > 1;
        let rods: Vec<RodInfo> = system
            .rods()
            .iter()
            .map(|r| RodInfo {
                name: r.name.clone(),
                model: Arc::clone(&r.model),
                first_node: r.offsets().node,
                first_element: r.offsets().element,
            })
            .collect();
        // Member order of trajectory.npz: time, every rod's arrays, every rod's series.
        let mut members: Vec<(String, Vec<usize>)> = vec![("time".to_string(), Vec::new())];
        for (r, rod) in rods.iter().enumerate() {
            let n = rod.model.n_elements;
            for (field, shape, _, _) in rod_arrays(n) {
                members.push((array_key(multi, &rod.name, field), shape));
            }
            if controlled == Some(r) {
                members.push((array_key(multi, &rod.name, "desired"), vec![n + 1, 3]));
            }
        }
        for (r, rod) in rods.iter().enumerate() {
            for (name, _, _) in SERIES {
                members.push((array_key(multi, &rod.name, name), Vec::new()));
            }
            if controlled == Some(r) {
                for name in ["target", "design_target"] {
                    members.push((array_key(multi, &rod.name, name), vec![3]));
                }
            }
        }
        let stick_slots = system.stick_slots();
        if stick_slots > 0 {
            members.push((STICK_ARRAY.to_string(), vec![stick_slots, 3]));
        }
        let spools = SpooledArray::create_members(
            &out.path(""),
            members.iter().map(|(n, s)| (n.as_str(), s.clone())),
            planned,
        )?;
        let (tx, rx) = mpsc::sync_channel::<Vec<f64>>(QUEUE);
        let (back, recycle) = mpsc::channel::<Vec<f64>>();
        let worker_rods: Vec<(Arc<RodModel>, bool)> = rods
            .iter()
            .enumerate()
            .map(|(r, rod)| (Arc::clone(&rod.model), controlled == Some(r)))
            .collect();
        let worker = std::thread::Builder::new()
            .name("octoarm-writer".into())
            .spawn(move || write_frames(worker_rods, stick_slots, rx, back, spools))
            .context("cannot start the writer thread")?;
        let n_rods = rods.len();
        let nodes: usize = rods.iter().map(|r| r.model.n_elements + 1).sum();
        let max_shapes = (MAX_KEPT_POINTS / nodes.max(1)).clamp(2, MAX_SHAPES);
        let control_nodes = controlled.map_or(1, |r| 2 * (rods[r].model.n_elements + 1));
        let max_control = (MAX_KEPT_POINTS / control_nodes).clamp(2, MAX_CONTROL_FRAMES);
        Ok(Self {
            every,
            stick_slots,
            planned,
            multi,
            controlled,
            tx: Some(tx),
            recycle,
            worker: Some(worker),
            shape_stride: planned.div_ceil(max_shapes).max(1),
            control_stride: planned.div_ceil(max_control).max(1),
            recorded: 0,
            plot_stride: 1,
            plot_cap: (MAX_PLOT_VALUES / (1 + 9 * n_rods)).clamp(64, MAX_PLOT_FRAMES),
            time: Vec::new(),
            series: vec![Vec::new(); n_rods],
            tips: vec![Vec::new(); n_rods],
            shapes: Vec::new(),
            control_frames: Vec::new(),
            last: (0.0, Vec::new()),
            last_plot: None,
            last_control: None,
            rest_sigma: system.rest_sigma.clone(),
            rest_kappa: system.rest_kappa.clone(),
            rods,
        })
    }

    /// Frames recorded so far (all written to `trajectory.npz`).
    pub fn frames(&self) -> usize {
        self.recorded
    }

    /// Keep a frame's time, energies and tips for the figures: every `plot_stride`-th frame,
    /// halving the kept frames (doubling the stride) when there are more than `plot_cap`.
    fn keep_for_plots(&mut self, time: f64, series: &[[f64; 6]], tips: &[Vec3]) {
        let index = self.recorded - 1;
        if index % self.plot_stride == 0 {
            self.time.push(time);
            for (r, (e, tip)) in series.iter().zip(tips).enumerate() {
                self.series[r].push(*e);
                self.tips[r].push(*tip);
            }
            if self.time.len() > self.plot_cap {
                fn halve<T: Copy>(v: &mut Vec<T>) {
                    let kept: Vec<T> = v.iter().step_by(2).copied().collect();
                    *v = kept;
                }
                halve(&mut self.time);
                self.series.iter_mut().for_each(halve);
                self.tips.iter_mut().for_each(halve);
                self.plot_stride *= 2;
            }
        }
        match &mut self.last_plot {
            Some((t, e, p)) => {
                *t = time;
                e.copy_from_slice(series);
                p.copy_from_slice(tips);
            }
            None => self.last_plot = Some((time, series.to_vec(), tips.to_vec())),
        }
    }

    /// Frames planned for a complete run.
    pub fn planned(&self) -> usize {
        self.planned
    }

    /// Whether the arrays are keyed by rod name.
    pub fn multi(&self) -> bool {
        self.multi
    }

    /// Names of the rods in order.
    pub fn rod_names(&self) -> Vec<String> {
        self.rods.iter().map(|r| r.name.clone()).collect()
    }
}

impl Recorder for TrajectoryRecorder {
    fn every(&self) -> u64 {
        self.every
    }

    fn record(&mut self, m: &mut Moment<'_>) -> Result<()> {
        if self.frames() == self.planned {
            return Err(anyhow!(
                "recorder: more than the {} planned frames",
                self.planned
            ));
        }
        let s = m.state;
        self.recorded += 1;
        let keep_shape = (self.frames() - 1) % self.shape_stride == 0;
        let mut shape_now = Vec::new();
        let mut buf = self.recycle.try_recv().unwrap_or_default();
        buf.clear();
        buf.push(s.time);
        let n_rods = self.rods.len();
        let mut energies = Vec::with_capacity(n_rods);
        let mut tips = Vec::with_capacity(n_rods);
        // Per rod after its arrays: the 6 series values, then target and design target.
        let mut series_values: Vec<f64> = Vec::with_capacity(12 * n_rods);
        self.last.0 = s.time;
        self.last.1.resize(self.rods.len(), Vec::new());
        let (rest_sigma, rest_kappa) = if m.system.rest_changes().is_empty() {
            (&m.system.rest_sigma, &m.system.rest_kappa)
        } else {
            m.system
                .rest_at(s.time, &mut self.rest_sigma, &mut self.rest_kappa);
            (&self.rest_sigma, &self.rest_kappa)
        };
        let ec = m.system.settings().energy_consistent;
        for (r, rod) in self.rods.iter().enumerate() {
            let sys_rod = m.system.rod(r);
            let e = energies_with_rest(
                &rod.model,
                &m.system.view(s, r),
                &rest_sigma[sys_rod.elements()],
                &rest_kappa[sys_rod.interior()],
                ec,
            );
            let row = [
                e.translational,
                e.rotational,
                e.stretch,
                e.bend,
                s.work[r],
                s.dissipated[r],
            ];
            energies.push(row);
            series_values.extend(row);
            let n = rod.model.n_elements;
            let nodes = rod.first_node..rod.first_node + n + 1;
            let elems = rod.first_element..rod.first_element + n;
            tips.push(s.position.get(nodes.end - 1));
            let centreline = s.position.to_vec(nodes.clone());
            if keep_shape {
                shape_now.push(centreline.clone());
            }
            self.last.1[r] = centreline;
            for i in nodes.clone() {
                buf.extend(s.position.get(i));
            }
            for i in nodes {
                buf.extend(s.velocity.get(i));
            }
            for j in elems.clone() {
                buf.extend(s.director.get(j).iter().flatten());
            }
            for j in elems {
                buf.extend(s.omega.get(j));
            }
            if self.controlled == Some(r) {
                let desired: Vec<Vec3> = m
                    .controllers
                    .first_mut()
                    .and_then(|c| c.desired_shape().map(<[Vec3]>::to_vec))
                    .unwrap_or_else(|| vec![[f64::NAN; 3]; n + 1]);
                buf.extend(desired.iter().flatten());
                let sig = m
                    .controllers
                    .first()
                    .map(|c| c.signals(s.time, m.system, s));
                let target = sig.and_then(|x| x.target);
                let design = sig.and_then(|x| x.design_target);
                series_values.extend(target.unwrap_or([f64::NAN; 3]));
                series_values.extend(design.unwrap_or([f64::NAN; 3]));
                let frame = ControlFrame {
                    time: s.time,
                    position: self.last.1[r].clone(),
                    desired,
                    target,
                };
                if (self.frames() - 1) % self.control_stride == 0 {
                    self.control_frames.push(frame.clone());
                }
                self.last_control = Some(frame);
            }
        }
        if keep_shape {
            self.shapes.push((s.time, shape_now));
        }
        buf.extend_from_slice(&series_values);
        if self.stick_slots > 0 {
            // The pipeline adds no obstacle during a run, so the springs keep the size they had
            // when the recorder was made (relaxed ones, should that ever change).
            if s.stick.len() == self.stick_slots {
                buf.extend(s.stick.iter().flatten());
            } else {
                buf.resize(buf.len() + 3 * self.stick_slots, 0.0);
            }
        }
        self.keep_for_plots(s.time, &energies, &tips);
        if let Some(tx) = &self.tx {
            if tx.send(buf).is_err() {
                // The writer stopped on an I/O error; `finish` reports it.
                self.tx = None;
            }
        }
        Ok(())
    }

    fn finish(&mut self, out: &OutputDir, _run: &RunInfo) -> Result<Map<String, Value>> {
        self.tx = None;
        let spools = self
            .worker
            .take()
            .ok_or_else(|| anyhow!("recorder already finished"))?
            .join()
            .map_err(|_| anyhow!("the writer thread panicked"))??;
        if self.shapes.last().map_or(true, |(t, _)| *t != self.last.0) && !self.last.1.is_empty() {
            self.shapes.push(self.last.clone());
        }
        if let Some((t, e, p)) = self.last_plot.take() {
            if self.time.last() != Some(&t) {
                self.time.push(t);
                for (r, (e, p)) in e.into_iter().zip(p).enumerate() {
                    self.series[r].push(e);
                    self.tips[r].push(p);
                }
            }
        }
        if let Some(f) = self.last_control.take() {
            if self
                .control_frames
                .last()
                .map_or(true, |l| l.time != f.time)
            {
                self.control_frames.push(f);
            }
        }
        let t = self.frames();
        let path = out.path("trajectory.npz");
        let file =
            File::create(&path).with_context(|| format!("cannot create {}", path.display()))?;
        let mut npz = ZipWriter::new(BufWriter::with_capacity(1 << 16, file));
        for spool in spools {
            debug_assert_eq!(spool.frames(), t);
            spool.append_to(&mut npz)?;
        }
        npz.finish()?.into_inner().map_err(|e| e.into_error())?;

        // summary.json: each array's shape, unit and domain, and each rod's final figures.
        let mut arrays = Map::new();
        arrays.insert(
            "time".into(),
            json!({"shape": [t], "unit": "s", "domain": "frame"}),
        );
        let mut rods = Vec::new();
        for (r, rod) in self.rods.iter().enumerate() {
            let n = rod.model.n_elements;
            let key = |f: &str| array_key(self.multi, &rod.name, f);
            for (name, shape, unit, domain) in rod_arrays(n) {
                let mut full = vec![t];
                full.extend(shape);
                arrays.insert(
                    key(name),
                    json!({"shape": full, "unit": unit, "domain": domain}),
                );
            }
            for (name, unit, meaning) in SERIES {
                arrays.insert(
                    key(name),
                    json!({"shape": [t], "unit": unit, "domain": meaning}),
                );
            }
            if self.controlled == Some(r) {
                arrays.insert(
                    key("desired"),
                    json!({"shape": [t, n + 1, 3], "unit": "m", "domain": "node, the controller's desired shape (forward map of the design in force)"}),
                );
                for f in ["target", "design_target"] {
                    arrays.insert(
                        key(f),
                        json!({"shape": [t, 3], "unit": "m", "domain": "frame, lab frame (NaN when none)"}),
                    );
                }
            }
            let last = self.series[r].last().copied().unwrap_or([f64::NAN; 6]);
            rods.push(json!({
                "name": rod.name,
                "n_elements": n,
                "final_tip_position": self.tips[r].last().copied().unwrap_or([f64::NAN; 3]),
                "final_energies": final_energies(&last),
            }));
        }
        if self.stick_slots > 0 {
            arrays.insert(
                STICK_ARRAY.into(),
                json!({"shape": [t, self.stick_slots, 3], "unit": "m", "domain": "friction stick \
                    spring of an obstacle at an element (spheres, planes two per element, \
                    cylinders; system element order), lab frame"}),
            );
        }
        let mut map = Map::new();
        map.insert("frames".into(), json!(t));
        if !self.multi {
            let r = &rods[0];
            map.insert("final_tip_position".into(), r["final_tip_position"].clone());
            map.insert("final_energies".into(), r["final_energies"].clone());
        }
        map.insert("rods".into(), Value::Array(rods));
        map.insert("arrays".into(), Value::Object(arrays));
        Ok(map)
    }
}

fn final_energies(last: &[f64; 6]) -> Value {
    json!({
        "translational": last[0],
        "rotational": last[1],
        "stretch": last[2],
        "bend": last[3],
        "kinetic": last[0] + last[1],
        "strain": last[2] + last[3],
        "total": last[0] + last[1] + last[2] + last[3],
        "external_work": last[4],
        "dissipated": last[5],
    })
}

/// Writer thread: rebuild each frame's rod states, compute their strains and append every
/// array in member order.
fn write_frames(
    rods: Vec<(Arc<RodModel>, bool)>,
    stick_slots: usize,
    rx: Receiver<Vec<f64>>,
    back: mpsc::Sender<Vec<f64>>,
    mut spools: Vec<SpooledArray>,
) -> Result<Vec<SpooledArray>> {
    let mut states: Vec<RodState> = rods
        .iter()
        .map(|(m, _)| {
            let n = m.n_elements;
            RodState {
                time: 0.0,
                position: vec![[0.0; 3]; n + 1],
                velocity: vec![[0.0; 3]; n + 1],
                director: vec![[[0.0; 3]; 3]; n],
                omega: vec![[0.0; 3]; n],
            }
        })
        .collect();
    let mut sigma: Vec<Vec<Vec3>> = rods
        .iter()
        .map(|(m, _)| vec![[0.0; 3]; m.n_elements])
        .collect();
    let mut kappa: Vec<Vec<Vec3>> = rods
        .iter()
        .map(|(m, _)| vec![[0.0; 3]; m.n_elements - 1])
        .collect();
    // Spools: time, then each rod's arrays (6, +1 desired), then each rod's series (6, +2).
    let series_spool: Vec<usize> = {
        let mut at = 1 + rods.iter().map(|(_, c)| 6 + usize::from(*c)).sum::<usize>();
        rods.iter()
            .map(|(_, c)| {
                let first = at;
                at += 6 + 2 * usize::from(*c);
                first
            })
            .collect()
    };
    for buf in rx {
        spools[0].push(&buf[..1])?;
        let mut at = 1;
        let mut spool = 1;
        for (r, (model, controlled)) in rods.iter().enumerate() {
            let n = model.n_elements;
            let (np, nd, nw) = (3 * (n + 1), 9 * n, 3 * n);
            let pos = &buf[at..at + np];
            let vel = &buf[at + np..at + 2 * np];
            let dir = &buf[at + 2 * np..at + 2 * np + nd];
            let omg = &buf[at + 2 * np + nd..at + 2 * np + nd + nw];
            at += 2 * np + nd + nw;
            let st = &mut states[r];
            for (x, c) in st.position.iter_mut().zip(pos.chunks_exact(3)) {
                *x = [c[0], c[1], c[2]];
            }
            for (q, c) in st.director.iter_mut().zip(dir.chunks_exact(9)) {
                *q = [[c[0], c[1], c[2]], [c[3], c[4], c[5]], [c[6], c[7], c[8]]];
            }
            strains(model, st, &mut sigma[r], &mut kappa[r]);
            spools[spool].push(pos)?;
            spools[spool + 1].push(vel)?;
            spools[spool + 2].push(dir)?;
            spools[spool + 3].push(omg)?;
            spools[spool + 4].push(sigma[r].as_flattened())?;
            spools[spool + 5].push(kappa[r].as_flattened())?;
            spool += 6;
            if *controlled {
                spools[spool].push(&buf[at..at + np])?;
                at += np;
                spool += 1;
            }
        }
        for (r, (_, controlled)) in rods.iter().enumerate() {
            let first = series_spool[r];
            for c in 0..6 {
                spools[first + c].push(&buf[at + c..at + c + 1])?;
            }
            at += 6;
            if *controlled {
                spools[first + 6].push(&buf[at..at + 3])?;
                spools[first + 7].push(&buf[at + 3..at + 6])?;
                at += 6;
            }
        }
        if stick_slots > 0 {
            spools
                .last_mut()
                .expect("the stick member is the last")
                .push(&buf[at..at + 3 * stick_slots])?;
            at += 3 * stick_slots;
        }
        debug_assert_eq!(at, buf.len());
        let _ = back.send(buf);
    }
    Ok(spools)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::Scenario;
    use octoarm_control::Controller;
    use octoarm_physics::Workspace;
    use std::path::Path;

    const ROD: &str = "[rod]\nn_elements = 4\nlength = 0.2\nbase_diameter = 0.02\ndensity = 700.0\n\
                       youngs_modulus = 1e4\nshear_modulus = 1e3\n\n[time]\ndt = 1e-3\nduration = 1.0\n";

    #[test]
    fn figure_data_stays_bounded_while_every_frame_is_written() {
        let scn = Scenario::from_str(Path::new("s.toml"), ROD).unwrap();
        let (system, mut state) = crate::build::build_system(&scn).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let out = OutputDir::prepare(&dir.path().join("out")).unwrap();
        let frames = 1000;
        let mut rec = TrajectoryRecorder::new(&system, 1, frames, None, &out).unwrap();
        rec.plot_cap = 64;
        let ws = Workspace::new(&system, &state);
        let mut controllers: Vec<Box<dyn Controller>> = Vec::new();
        for k in 0..frames {
            state.time = k as f64 * 1e-3;
            let mut m = Moment {
                steps: k as u64,
                system: &system,
                state: &state,
                workspace: &ws,
                controllers: &mut controllers,
            };
            rec.record(&mut m).unwrap();
            assert!(rec.time.len() <= 65, "{}", rec.time.len());
        }
        let info = RunInfo {
            duration: 1.0,
            control: None,
            failure: None,
        };
        let summary = rec.finish(&out, &info).unwrap();
        assert_eq!(summary["frames"], frames);
        assert_eq!(rec.frames(), frames);
        // Evenly thinned (stride 16 after two halvings of 64), the last frame appended.
        assert!(rec.time.len() <= 65);
        assert_eq!(rec.time[1] - rec.time[0], 16e-3);
        assert_eq!(*rec.time.last().unwrap(), 0.999);
        assert_eq!(rec.series[0].len(), rec.time.len());
        assert_eq!(rec.tips[0].len(), rec.time.len());
        // trajectory.npz has every frame.
        let time = crate::output::read_npz_vector(&out.path("trajectory.npz"), "time").unwrap();
        assert_eq!(time.len(), frames);
        assert_eq!(time[999], 0.999);
        let e = crate::output::read_npz_vector(&out.path("trajectory.npz"), "energy_bend").unwrap();
        assert_eq!(e.len(), frames);
    }
}
