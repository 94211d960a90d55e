//! The recorder: samples the simulation at the frames the runner asks for and streams them to
//! `trajectory.npz` on a writer thread (constant memory, compression off the stepping thread).
//! It keeps in memory only the small per-frame series (time, energies, tip) and a thinned set of
//! centrelines for the figures. It never mutates the simulation.

use crate::output::{write_member, SpooledArray};
use anyhow::{anyhow, Context, Result};
use octoarm_physics::{strains, RodModel, RodState, Simulation};
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;
use std::sync::mpsc::{self, Receiver, SyncSender};
use std::thread::JoinHandle;
use zip::ZipWriter;

/// Most centrelines kept in memory for `shapes.png`.
pub const MAX_SHAPES: usize = 200;
/// Frames that may wait for the writer thread before `record` blocks.
const QUEUE: usize = 64;

/// Names, per-frame shapes, units and domains of the streamed arrays, in `.npz` order after
/// `time`. N = number of elements.
pub fn streamed_arrays(n: usize) -> [(&'static str, Vec<usize>, &'static str, &'static str); 5] {
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

/// Per-frame scalar series written after the streamed arrays: name, unit, meaning.
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
        "work done by the external loads since t = 0",
    ),
    (
        "dissipated_energy",
        "J",
        "energy removed by damping since t = 0",
    ),
];

/// Streams frames of one rod to `trajectory.npz`.
pub struct Recorder {
    planned: usize,
    tx: Option<SyncSender<Vec<f64>>>,
    recycle: Receiver<Vec<f64>>,
    worker: Option<JoinHandle<Result<Vec<SpooledArray>>>>,
    shape_stride: usize,
    /// Time of each recorded frame [s].
    pub time: Vec<f64>,
    /// Per frame: the `SERIES` values in order.
    pub series: Vec<[f64; 6]>,
    /// Per frame: tip position [m].
    pub tip: Vec<[f64; 3]>,
    /// Thinned centrelines (time, node positions) for the figures, always ending with the last
    /// recorded frame once `finish` has run.
    pub shapes: Vec<(f64, Vec<[f64; 3]>)>,
    last: (f64, Vec<[f64; 3]>),
}

impl Recorder {
    /// A recorder for `planned` frames of a rod like `model`, spooling into `dir`.
    pub fn new(model: &RodModel, planned: usize, dir: &Path) -> Result<Self> {
        let n = model.n_elements;
        let members = streamed_arrays(n).map(|(name, shape, _, _)| (name, shape));
        let spools = SpooledArray::create_members(dir, members, planned)?;
        let (tx, rx) = mpsc::sync_channel::<Vec<f64>>(QUEUE);
        let (back, recycle) = mpsc::channel::<Vec<f64>>();
        let model = model.clone();
        let worker = std::thread::Builder::new()
            .name("octoarm-writer".into())
            .spawn(move || write_frames(model, rx, back, spools))
            .context("cannot start the writer thread")?;
        Ok(Self {
            planned,
            tx: Some(tx),
            recycle,
            worker: Some(worker),
            shape_stride: planned.div_ceil(MAX_SHAPES).max(1),
            time: Vec::with_capacity(planned),
            series: Vec::with_capacity(planned),
            tip: Vec::with_capacity(planned),
            shapes: Vec::new(),
            last: (0.0, Vec::new()),
        })
    }

    /// Frames recorded so far.
    pub fn frames(&self) -> usize {
        self.time.len()
    }

    /// Record the current state. Call `Simulation::check` first so that nothing non-finite is
    /// written. Errors if more frames than planned are recorded.
    pub fn record(&mut self, sim: &Simulation) -> Result<()> {
        if self.frames() == self.planned {
            return Err(anyhow!(
                "recorder: more than the {} planned frames",
                self.planned
            ));
        }
        let s = &sim.state;
        let e = sim.energies();
        self.time.push(s.time);
        self.series.push([
            e.translational,
            e.rotational,
            e.stretch,
            e.bend,
            sim.external_work(),
            sim.dissipated_energy(),
        ]);
        self.tip.push(s.tip());
        if (self.frames() - 1) % self.shape_stride == 0 {
            self.shapes.push((s.time, s.position.clone()));
        }
        self.last.0 = s.time;
        self.last.1.clear();
        self.last.1.extend_from_slice(&s.position);

        let mut buf = self.recycle.try_recv().unwrap_or_default();
        buf.clear();
        buf.extend(s.position.iter().flatten());
        buf.extend(s.velocity.iter().flatten());
        buf.extend(s.director.iter().flatten().flatten());
        if let Some(tx) = &self.tx {
            if tx.send(buf).is_err() {
                // The writer stopped on an I/O error; `finish` reports it.
                self.tx = None;
            }
        }
        Ok(())
    }

    /// Wait for the writer, then write `npz_path` with `time`, the streamed arrays and the
    /// series, holding exactly the frames recorded. Called on success and after a failed run.
    pub fn finish(&mut self, npz_path: &Path) -> Result<()> {
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
        let t = self.frames();
        let file = File::create(npz_path)
            .with_context(|| format!("cannot create {}", npz_path.display()))?;
        let mut npz = ZipWriter::new(BufWriter::with_capacity(1 << 16, file));
        write_member(&mut npz, "time", &[t], &self.time)?;
        for spool in spools {
            debug_assert_eq!(spool.frames(), t);
            spool.append_to(&mut npz)?;
        }
        let mut column = Vec::with_capacity(t);
        for (c, (name, _, _)) in SERIES.iter().enumerate() {
            column.clear();
            column.extend(self.series.iter().map(|row| row[c]));
            write_member(&mut npz, name, &[t], &column)?;
        }
        npz.finish()?.into_inner().map_err(|e| e.into_error())?;
        Ok(())
    }

    /// Frames planned for a complete run.
    pub fn planned(&self) -> usize {
        self.planned
    }
}

/// Writer thread: rebuild each frame's state, compute its strains and append every array.
fn write_frames(
    model: RodModel,
    rx: Receiver<Vec<f64>>,
    back: mpsc::Sender<Vec<f64>>,
    mut spools: Vec<SpooledArray>,
) -> Result<Vec<SpooledArray>> {
    let n = model.n_elements;
    let mut state = RodState {
        time: 0.0,
        position: vec![[0.0; 3]; n + 1],
        velocity: vec![[0.0; 3]; n + 1],
        director: vec![[[0.0; 3]; 3]; n],
        omega: vec![[0.0; 3]; n],
    };
    let mut sigma = vec![[0.0; 3]; n];
    let mut kappa = vec![[0.0; 3]; n - 1];
    let (np, nv) = (3 * (n + 1), 3 * (n + 1));
    for buf in rx {
        let (pos, rest) = buf.split_at(np);
        let (vel, dir) = rest.split_at(nv);
        for (x, c) in state.position.iter_mut().zip(pos.chunks_exact(3)) {
            *x = [c[0], c[1], c[2]];
        }
        for (q, c) in state.director.iter_mut().zip(dir.chunks_exact(9)) {
            *q = [[c[0], c[1], c[2]], [c[3], c[4], c[5]], [c[6], c[7], c[8]]];
        }
        strains(&model, &state, &mut sigma, &mut kappa);
        spools[0].push(pos)?;
        spools[1].push(vel)?;
        spools[2].push(dir)?;
        spools[3].push(sigma.as_flattened())?;
        spools[4].push(kappa.as_flattened())?;
        let _ = back.send(buf);
    }
    Ok(spools)
}
