//! The local web server (axum on a single-threaded tokio runtime in its own thread, bound to
//! 127.0.0.1 only): the embedded page and its assets, the catalog of runs, one run's data as a
//! binary message, and the live WebSocket. Nothing is fetched from elsewhere; nothing outside
//! the catalog's run folders is read.

use crate::live::{LiveHub, LiveStatus, DISPLAY_RATE};
use crate::runs::{load_run, Catalog};
use anyhow::{Context, Result};
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Query, State};
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use serde_json::json;
use std::collections::HashMap;
use std::net::{SocketAddr, TcpListener};
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::oneshot;

const INDEX: &str = include_str!("../assets/index.html");
const APP: &str = include_str!("../assets/app.js");
const STYLE: &str = include_str!("../assets/style.css");
const THREE: &str = include_str!("../assets/vendor/three.bundle.min.js");
const THREE_LICENSE: &str = include_str!("../assets/vendor/three.LICENSE");

/// What the server shows.
#[derive(Clone)]
pub enum Source {
    /// Recorded runs (`octoarm view PATH`).
    Folder(Arc<Catalog>),
    /// A running simulation (`octoarm run --view`).
    Live(Arc<LiveHub>),
}

/// A running server; stopped when dropped.
pub struct Server {
    addr: SocketAddr,
    stop: Option<oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Server {
    /// Bind 127.0.0.1:`port` (0: a free port) and serve `source` from a background thread.
    /// Errors if the port cannot be bound.
    pub fn start(source: Source, port: u16) -> Result<Self> {
        let listener = TcpListener::bind(("127.0.0.1", port))
            .with_context(|| format!("cannot listen on 127.0.0.1:{port}"))?;
        listener.set_nonblocking(true)?;
        let addr = listener.local_addr()?;
        let (tx, rx) = oneshot::channel::<()>();
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .context("cannot start the server's runtime")?;
        let thread = std::thread::Builder::new()
            .name("octoarm-viewer".into())
            .spawn(move || {
                runtime.block_on(async move {
                    let Ok(listener) = tokio::net::TcpListener::from_std(listener) else {
                        return;
                    };
                    let app = router(source);
                    let _ = axum::serve(listener, app)
                        .with_graceful_shutdown(async {
                            let _ = rx.await;
                        })
                        .await;
                });
                runtime.shutdown_timeout(Duration::from_millis(200));
            })
            .context("cannot start the server thread")?;
        Ok(Self {
            addr,
            stop: Some(tx),
            thread: Some(thread),
        })
    }

    /// The page's address, `http://127.0.0.1:PORT/`.
    pub fn url(&self) -> String {
        format!("http://{}/", self.addr)
    }

    /// The bound address.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        if let Some(tx) = self.stop.take() {
            let _ = tx.send(());
        }
        // Open WebSockets do not hold the graceful shutdown for long: the runtime is shut
        // down with a timeout after `serve` returns.
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn router(source: Source) -> Router {
    Router::new()
        .route(
            "/",
            get(|| async { asset(INDEX, "text/html; charset=utf-8") }),
        )
        .route(
            "/app.js",
            get(|| async { asset(APP, "text/javascript; charset=utf-8") }),
        )
        .route(
            "/style.css",
            get(|| async { asset(STYLE, "text/css; charset=utf-8") }),
        )
        .route(
            "/vendor/three.js",
            get(|| async { asset(THREE, "text/javascript; charset=utf-8") }),
        )
        .route(
            "/vendor/three.LICENSE",
            get(|| async { asset(THREE_LICENSE, "text/plain; charset=utf-8") }),
        )
        .route("/api/catalog", get(catalog))
        .route("/api/run", get(run_data))
        .route("/api/live", get(live))
        .with_state(source)
}

fn asset(body: &'static str, kind: &'static str) -> Response {
    (
        [
            (header::CONTENT_TYPE, kind),
            (header::CACHE_CONTROL, "no-cache"),
        ],
        body,
    )
        .into_response()
}

async fn catalog(State(source): State<Source>) -> Response {
    let body = match &source {
        Source::Folder(c) => c.to_json(),
        Source::Live(_) => json!({"kind": "live", "runs": []}),
    };
    (
        [(header::CONTENT_TYPE, "application/json")],
        body.to_string(),
    )
        .into_response()
}

async fn run_data(
    State(source): State<Source>,
    Query(q): Query<HashMap<String, String>>,
) -> Response {
    let Source::Folder(catalog) = source else {
        return (
            StatusCode::NOT_FOUND,
            "no recorded runs: this is a live view",
        )
            .into_response();
    };
    let id = q.get("id").map(String::as_str).unwrap_or(".");
    let Some(entry) = catalog.get(id) else {
        return (StatusCode::NOT_FOUND, format!("no run {id:?}")).into_response();
    };
    let dir = entry.dir.clone();
    let label = entry.label.clone();
    let id = id.to_string();
    let loaded = tokio::task::spawn_blocking(move || {
        load_run(&dir).map(|mut b| {
            b.set("id", json!(id));
            b.set("label", json!(label));
            b.encode()
        })
    })
    .await;
    match loaded {
        Ok(Ok(bytes)) => {
            ([(header::CONTENT_TYPE, "application/octet-stream")], bytes).into_response()
        }
        Ok(Err(e)) => (StatusCode::UNPROCESSABLE_ENTITY, format!("{e:#}")).into_response(),
        Err(e) => (StatusCode::INTERNAL_SERVER_ERROR, e.to_string()).into_response(),
    }
}

async fn live(State(source): State<Source>, ws: WebSocketUpgrade) -> Response {
    let Source::Live(hub) = source else {
        return (StatusCode::NOT_FOUND, "not a live view").into_response();
    };
    ws.on_upgrade(move |socket| stream(socket, hub))
}

/// Send the scene, then the newest frame at most `DISPLAY_RATE` times a second, and every
/// status change; the final frame is always sent before the final status.
async fn stream(mut socket: WebSocket, hub: Arc<LiveHub>) {
    hub.connected(1);
    let (mut frames, mut status) = hub.subscribe();
    let hello = json!({"type": "hello", "scene": hub.scene});
    let period = Duration::from_secs_f64(1.0 / DISPLAY_RATE);
    let mut sent_step: Option<u64> = None;
    let result: Result<(), axum::Error> = async {
        socket.send(Message::Text(hello.to_string().into())).await?;
        let first = status.borrow_and_update().clone();
        socket
            .send(Message::Text(first.to_json().to_string().into()))
            .await?;
        loop {
            let frame = frames.borrow_and_update().clone();
            if let Some(f) = frame {
                if sent_step != Some(f.step) {
                    sent_step = Some(f.step);
                    socket.send(Message::Binary(f.encode().into())).await?;
                }
            }
            if status.has_changed().unwrap_or(false) {
                let s = status.borrow_and_update().clone();
                if matches!(s, LiveStatus::Finished { .. }) {
                    // The last frame was published before the final status.
                    let last = frames.borrow_and_update().clone();
                    if let Some(f) = last {
                        if sent_step != Some(f.step) {
                            sent_step = Some(f.step);
                            socket.send(Message::Binary(f.encode().into())).await?;
                        }
                    }
                }
                socket
                    .send(Message::Text(s.to_json().to_string().into()))
                    .await?;
            }
            tokio::time::sleep(period).await;
            tokio::select! {
                r = frames.changed() => { if r.is_err() { break; } }
                r = status.changed() => {
                    if r.is_err() { break; }
                    // Re-mark it as changed for the status branch above.
                    status.mark_changed();
                }
                msg = socket.recv() => {
                    match msg {
                        None | Some(Err(_)) | Some(Ok(Message::Close(_))) => break,
                        _ => {}
                    }
                }
            }
        }
        Ok(())
    }
    .await;
    let _ = result;
    hub.connected(-1);
}

/// Open `url` in the desktop's browser if there is one (a display on Linux; `open` on macOS,
/// `start` on Windows); returns whether a browser was started. Never waits for it.
pub fn open_browser(url: &str) -> bool {
    use std::process::{Command, Stdio};
    let mut cmd = if cfg!(target_os = "macos") {
        let mut c = Command::new("open");
        c.arg(url);
        c
    } else if cfg!(windows) {
        let mut c = Command::new("cmd");
        c.args(["/C", "start", "", url]);
        c
    } else {
        let display = std::env::var_os("DISPLAY").is_some_and(|d| !d.is_empty())
            || std::env::var_os("WAYLAND_DISPLAY").is_some_and(|d| !d.is_empty());
        if !display {
            return false;
        }
        let mut c = Command::new("xdg-open");
        c.arg(url);
        c
    };
    cmd.stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .is_ok()
}
