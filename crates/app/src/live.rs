//! The live viewer's recorder (`octoarm run --view`): sampled with the trajectory's frames in
//! the one run loop, it keeps a copy of the newest frame's state and publishes it to the
//! viewer's hub at most at display rate (the final frame always), computing strains and the
//! desired shape only for the frames it publishes. It writes no file and never blocks the run.

use crate::output::OutputDir;
use crate::pipeline::{Moment, Recorder, RunInfo};
use anyhow::Result;
use octoarm_physics::{strains, RodModel, RodState, Vec3};
use octoarm_viewer::live::{LiveFrame, LiveHub, DISPLAY_RATE};
use serde_json::{Map, Value};
use std::sync::Arc;
use std::time::{Duration, Instant};

struct Rod {
    key: String,
    model: Arc<RodModel>,
    first_node: usize,
    first_element: usize,
    state: RodState,
    sigma: Vec<Vec3>,
    kappa: Vec<Vec3>,
}

/// Publishes frames of a running simulation to a `LiveHub`.
pub struct LiveRecorder {
    hub: Arc<LiveHub>,
    every: u64,
    planned: u64,
    rods: Vec<Rod>,
    controlled: Option<usize>,
    start: Instant,
    last_publish: Option<Instant>,
    interval: Duration,
    // The newest recorded state (time, steps) and whether it was published.
    time: f64,
    steps: u64,
    pending: bool,
}

impl LiveRecorder {
    /// A recorder of the rods of `system`, sampled every `every` steps (the trajectory's), for
    /// a run of `planned` steps; `controlled` is the controlled rod (its desired shape and
    /// target are sent too).
    pub fn new(
        hub: Arc<LiveHub>,
        system: &octoarm_physics::RodSystem,
        every: u64,
        planned: u64,
        controlled: Option<usize>,
    ) -> Self {
        let multi = system.rods().len() > 1;
        let rods = system
            .rods()
            .iter()
            .map(|r| {
                let n = r.n_elements();
                Rod {
                    key: if multi {
                        format!("{}/", r.name)
                    } else {
                        String::new()
                    },
                    model: Arc::clone(&r.model),
                    first_node: r.offsets().node,
                    first_element: r.offsets().element,
                    state: RodState {
                        time: 0.0,
                        position: vec![[0.0; 3]; n + 1],
                        velocity: Vec::new(),
                        director: vec![[[0.0; 3]; 3]; n],
                        omega: Vec::new(),
                    },
                    sigma: vec![[0.0; 3]; n],
                    kappa: vec![[0.0; 3]; n.saturating_sub(1)],
                }
            })
            .collect();
        Self {
            hub,
            every: every.max(1),
            planned,
            rods,
            controlled,
            start: Instant::now(),
            last_publish: None,
            interval: Duration::from_secs_f64(1.0 / DISPLAY_RATE),
            time: 0.0,
            steps: 0,
            pending: false,
        }
    }

    /// The stored newest frame as the hub's frame (strains computed now); `extra` holds the
    /// controlled rod's desired shape and target when known.
    fn frame(&mut self, extra: Option<(Vec<Vec3>, Option<Vec3>)>) -> LiveFrame {
        let mut arrays = Vec::new();
        let f32s = |v: &[Vec3]| -> Vec<f32> { v.iter().flatten().map(|&x| x as f32).collect() };
        for (r, rod) in self.rods.iter_mut().enumerate() {
            let n = rod.model.n_elements;
            strains(&rod.model, &rod.state, &mut rod.sigma, &mut rod.kappa);
            arrays.push((
                format!("{}position", rod.key),
                vec![n + 1, 3],
                f32s(&rod.state.position),
            ));
            arrays.push((
                format!("{}director", rod.key),
                vec![n, 3, 3],
                rod.state
                    .director
                    .iter()
                    .flatten()
                    .flatten()
                    .map(|&x| x as f32)
                    .collect(),
            ));
            arrays.push((format!("{}sigma", rod.key), vec![n, 3], f32s(&rod.sigma)));
            arrays.push((
                format!("{}kappa", rod.key),
                vec![n - 1, 3],
                f32s(&rod.kappa),
            ));
            if self.controlled == Some(r) {
                if let Some((desired, target)) = &extra {
                    if desired.len() == n + 1 {
                        arrays.push((format!("{}desired", rod.key), vec![n + 1, 3], f32s(desired)));
                    }
                    let t = target.unwrap_or([f64::NAN; 3]);
                    arrays.push((format!("{}target", rod.key), vec![3], f32s(&[t])));
                }
            }
        }
        LiveFrame {
            time: self.time,
            step: self.steps,
            planned: self.planned,
            wall: self.start.elapsed().as_secs_f64(),
            arrays,
        }
    }
}

impl Recorder for LiveRecorder {
    fn every(&self) -> u64 {
        self.every
    }

    fn record(&mut self, m: &mut Moment<'_>) -> Result<()> {
        // Keep the newest state (a copy of positions and directors: a few µs per sample).
        let s = m.state;
        for rod in &mut self.rods {
            let n = rod.model.n_elements;
            for (i, x) in rod.state.position.iter_mut().enumerate() {
                *x = s.position.get(rod.first_node + i);
            }
            for (j, q) in rod.state.director.iter_mut().enumerate().take(n) {
                *q = s.director.get(rod.first_element + j);
            }
        }
        self.time = s.time;
        self.steps = m.steps;
        self.pending = true;
        let now = Instant::now();
        let due = self
            .last_publish
            .map_or(true, |t| now.duration_since(t) >= self.interval)
            || m.steps >= self.planned;
        if due {
            let extra = self.controlled.and_then(|_| {
                let c = m.controllers.first_mut()?;
                let desired = c.desired_shape().map(<[Vec3]>::to_vec).unwrap_or_default();
                let target = c.signals(s.time, m.system, s).target;
                Some((desired, target))
            });
            let frame = self.frame(extra);
            self.hub.publish(frame);
            self.last_publish = Some(now);
            self.pending = false;
        }
        Ok(())
    }

    fn finish(&mut self, _out: &OutputDir, _run: &RunInfo) -> Result<Map<String, Value>> {
        // The run stopped early (failure, interrupt) at a frame not yet published.
        if self.pending {
            let frame = self.frame(None);
            self.hub.publish(frame);
            self.pending = false;
        }
        Ok(Map::new())
    }
}
