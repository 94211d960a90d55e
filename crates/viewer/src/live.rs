//! The live stream of a running simulation: the run's recorder publishes frames into a
//! `LiveHub` (never blocking: the newest frame replaces the previous one), and each connected
//! page is sent the newest frame at display rate over its WebSocket, then the run's final
//! status (completed, or the guard's failure message). The hub knows nothing of the physics:
//! frames are named float32 arrays.

use crate::blob::Blob;
use serde_json::{json, Value};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::watch;

/// Frames per second sent to a page at most.
pub const DISPLAY_RATE: f64 = 30.0;

/// One frame of a running simulation.
#[derive(Debug, Clone, Default)]
pub struct LiveFrame {
    /// Simulated time [s].
    pub time: f64,
    /// Steps taken.
    pub step: u64,
    /// Steps of the complete run.
    pub planned: u64,
    /// Wall time since the run started [s].
    pub wall: f64,
    /// Named arrays (e.g. `position` or `left/position`, as in `trajectory.npz`): name, shape
    /// and values.
    pub arrays: Vec<(String, Vec<usize>, Vec<f32>)>,
}

impl LiveFrame {
    /// The frame as the page's binary message.
    pub fn encode(&self) -> Vec<u8> {
        let mut b = Blob::new();
        b.set("type", json!("frame"));
        b.set("time", json!(self.time));
        b.set("step", json!(self.step));
        b.set("planned", json!(self.planned));
        b.set("wall", json!(self.wall));
        for (name, shape, values) in &self.arrays {
            b.push(name.clone(), shape.clone(), values.clone());
        }
        b.encode()
    }
}

/// The state of the run, as the page shows it.
#[derive(Debug, Clone, PartialEq)]
pub enum LiveStatus {
    /// Not started (waiting for a page, or preparing).
    Waiting,
    /// Stepping.
    Running,
    /// Stopped: `status` as in `summary.json` (completed, unstable, failed, interrupted), the
    /// failure's message if any, and the output folder.
    Finished {
        /// `completed`, `unstable`, `failed` or `interrupted`.
        status: String,
        /// The guard's (or controller's) message.
        message: Option<String>,
        /// Where the outputs were written.
        out_dir: String,
    },
}

impl LiveStatus {
    /// The status as the page's JSON message.
    pub fn to_json(&self) -> Value {
        match self {
            LiveStatus::Waiting => json!({"type": "status", "state": "waiting"}),
            LiveStatus::Running => json!({"type": "status", "state": "running"}),
            LiveStatus::Finished {
                status,
                message,
                out_dir,
            } => json!({
                "type": "status", "state": "finished", "status": status,
                "message": message, "out_dir": out_dir,
            }),
        }
    }
}

/// Shared between the run (publisher) and the server (subscribers).
pub struct LiveHub {
    /// The scene (rods, radii, obstacles, targets) and run facts, sent first to every page.
    pub scene: Value,
    frame: watch::Sender<Option<Arc<LiveFrame>>>,
    status: watch::Sender<LiveStatus>,
    clients: AtomicUsize,
    published: AtomicUsize,
}

impl LiveHub {
    /// A hub for a run whose scene is `scene` (see `scene::scene_of`), plus `title`.
    pub fn new(scene: Value) -> Arc<Self> {
        Arc::new(Self {
            scene,
            frame: watch::channel(None).0,
            status: watch::channel(LiveStatus::Waiting).0,
            clients: AtomicUsize::new(0),
            published: AtomicUsize::new(0),
        })
    }

    /// Publish a frame: it replaces the previous one (never blocks on the pages).
    pub fn publish(&self, frame: LiveFrame) {
        self.frame.send_replace(Some(Arc::new(frame)));
        self.published.fetch_add(1, Ordering::Relaxed);
    }

    /// Frames published so far.
    pub fn published(&self) -> usize {
        self.published.load(Ordering::Relaxed)
    }

    /// Set the run's status.
    pub fn set_status(&self, status: LiveStatus) {
        self.status.send_replace(status);
    }

    /// Pages connected now.
    pub fn clients(&self) -> usize {
        self.clients.load(Ordering::Relaxed)
    }

    /// Wait until a page has connected, at most `timeout`, or until `cancel()` is true;
    /// returns whether one did.
    pub fn wait_for_client(&self, timeout: Duration, cancel: impl Fn() -> bool) -> bool {
        let start = Instant::now();
        while self.clients() == 0 {
            if start.elapsed() >= timeout || cancel() {
                return false;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        true
    }

    pub(crate) fn subscribe(
        &self,
    ) -> (
        watch::Receiver<Option<Arc<LiveFrame>>>,
        watch::Receiver<LiveStatus>,
    ) {
        (self.frame.subscribe(), self.status.subscribe())
    }

    pub(crate) fn connected(&self, delta: isize) {
        if delta > 0 {
            self.clients.fetch_add(1, Ordering::Relaxed);
        } else {
            self.clients.fetch_sub(1, Ordering::Relaxed);
        }
    }
}
