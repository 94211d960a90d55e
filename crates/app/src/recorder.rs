//! The trajectory recorder: samples every rod of the system at the frames the pipeline asks for
//! and streams them to `trajectory.npz` on a writer thread (constant memory, compression off the
//! stepping thread). It keeps in memory only what the figures need: per-frame time, energies and
//! tips, thinned centrelines, and the controlled rod's frames with its desired shape and
//! targets. Array keys: `position`, … for a lone rod; `<rod name>/position`, … for several.

use crate::output::{write_member, OutputDir, SpooledArray};
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

/// Most centrelines kept in memory for `shapes.png`.
pub const MAX_SHAPES: usize = 200;
/// Most frames of the controlled rod kept in memory for the control figures and the GIF.
pub const MAX_CONTROL_FRAMES: usize = 2000;
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
    planned: usize,
    multi: bool,
    rods: Vec<RodInfo>,
    controlled: Option<usize>,
    tx: Option<SyncSender<Vec<f64>>>,
    recycle: Receiver<Vec<f64>>,
    worker: Option<JoinHandle<Result<Vec<SpooledArray>>>>,
    shape_stride: usize,
    control_stride: usize,
    /// Time of each recorded frame [s].
    pub time: Vec<f64>,
    /// Per rod, per frame: the `SERIES` values in order.
    pub series: Vec<Vec<[f64; 6]>>,
    /// Per rod, per frame: tip position [m].
    pub tips: Vec<Vec<Vec3>>,
    /// Thinned frames (time, every rod's centreline), ending with the last recorded frame once
    /// `finish` has run.
    pub shapes: Vec<(f64, Vec<Vec<Vec3>>)>,
    /// Frames of the controlled rod (thinned to at most `MAX_CONTROL_FRAMES`, the last kept).
    pub control_frames: Vec<ControlFrame>,
    last: (f64, Vec<Vec<Vec3>>),
    last_control: Option<ControlFrame>,
    // The rest strains in force at a frame (scheduled changes), filled once per frame.
    rest_sigma: Vec<Vec3>,
    rest_kappa: Vec<Vec3>,
    target: Vec<f64>,
    design_target: Vec<f64>,
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
        let mut members: Vec<(String, Vec<usize>)> = Vec::new();
        for (r, rod) in rods.iter().enumerate() {
            let n = rod.model.n_elements;
            for (field, shape, _, _) in rod_arrays(n) {
                members.push((array_key(multi, &rod.name, field), shape));
            }
            if controlled == Some(r) {
                members.push((array_key(multi, &rod.name, "desired"), vec![n + 1, 3]));
            }
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
            .spawn(move || write_frames(worker_rods, rx, back, spools))
            .context("cannot start the writer thread")?;
        let n_rods = rods.len();
        Ok(Self {
            every,
            planned,
            multi,
            controlled,
            tx: Some(tx),
            recycle,
            worker: Some(worker),
            shape_stride: planned.div_ceil(MAX_SHAPES).max(1),
            control_stride: planned.div_ceil(MAX_CONTROL_FRAMES).max(1),
            time: Vec::with_capacity(planned.min(1 << 20)),
            series: vec![Vec::new(); n_rods],
            tips: vec![Vec::new(); n_rods],
            shapes: Vec::new(),
            control_frames: Vec::new(),
            last: (0.0, Vec::new()),
            last_control: None,
            rest_sigma: system.rest_sigma.clone(),
            rest_kappa: system.rest_kappa.clone(),
            rods,
            target: Vec::new(),
            design_target: Vec::new(),
        })
    }

    /// Frames recorded so far.
    pub fn frames(&self) -> usize {
        self.time.len()
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
        self.time.push(s.time);
        let keep_shape = (self.frames() - 1) % self.shape_stride == 0;
        let mut shape_now = Vec::new();
        let mut buf = self.recycle.try_recv().unwrap_or_default();
        buf.clear();
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
            self.series[r].push([
                e.translational,
                e.rotational,
                e.stretch,
                e.bend,
                s.work[r],
                s.dissipated[r],
            ]);
            let n = rod.model.n_elements;
            let nodes = rod.first_node..rod.first_node + n + 1;
            let elems = rod.first_element..rod.first_element + n;
            self.tips[r].push(s.position.get(nodes.end - 1));
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
                self.target
                    .extend(target.unwrap_or([f64::NAN; 3]).iter().copied());
                self.design_target
                    .extend(design.unwrap_or([f64::NAN; 3]).iter().copied());
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
        write_member(&mut npz, "time", &[t], &self.time)?;
        for spool in spools {
            debug_assert_eq!(spool.frames(), t);
            spool.append_to(&mut npz)?;
        }
        let mut column = Vec::with_capacity(t);
        for (r, rod) in self.rods.iter().enumerate() {
            for (c, (name, _, _)) in SERIES.iter().enumerate() {
                column.clear();
                column.extend(self.series[r].iter().map(|row| row[c]));
                write_member(
                    &mut npz,
                    &array_key(self.multi, &rod.name, name),
                    &[t],
                    &column,
                )?;
            }
            if self.controlled == Some(r) {
                write_member(
                    &mut npz,
                    &array_key(self.multi, &rod.name, "target"),
                    &[t, 3],
                    &self.target,
                )?;
                write_member(
                    &mut npz,
                    &array_key(self.multi, &rod.name, "design_target"),
                    &[t, 3],
                    &self.design_target,
                )?;
            }
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
    for buf in rx {
        let mut at = 0;
        let mut spool = 0;
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
        let _ = back.send(buf);
    }
    Ok(spools)
}
