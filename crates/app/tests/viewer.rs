//! `octoarm view` and `run --view` from the command line, without a browser: the server listens
//! on 127.0.0.1 at the port it prints, serves the page, the catalog and a run's data (arrays
//! named as in trajectory.npz, thinned to the frames it says), refuses ids outside the catalog,
//! stops with exit 0 on SIGINT; a path holding no run and a busy port are refused with exit 2;
//! `--port` without `--view` is a usage error. (The page itself is tested in headless Chromium
//! by crates/viewer/tests/test_viewer_browser.py.)

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, Command, Stdio};

const TINY: &str = r#"
[rod]
n_elements = 10
length = 0.2
base_diameter = 0.02
tip_diameter = 0.01
density = 700.0
youngs_modulus = 1.0e4
shear_modulus = 1.0e3
[time]
dt = 1.0e-4
duration = 0.05
save_interval = 1.0e-3
[[load]]
kind = "tip_force"
value = [0.0, 1.0e-4, 0.0]
"#;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_octoarm"))
}

/// Start `octoarm view` (or any command printing the viewer's URL first); return the child and
/// the address.
fn start(args: &[&str]) -> (Child, String) {
    let mut child = bin()
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let url = line
        .trim()
        .strip_prefix("octoarm viewer: ")
        .unwrap_or_else(|| panic!("no URL line: {line:?}"))
        .to_string();
    assert!(url.starts_with("http://127.0.0.1:"), "{url}");
    let addr = url
        .trim_start_matches("http://")
        .trim_end_matches('/')
        .to_string();
    (child, addr)
}

/// One HTTP/1.1 GET (connection closed after): status code and body.
fn get(addr: &str, path: &str) -> (u16, Vec<u8>) {
    let mut s = TcpStream::connect(addr).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut raw = Vec::new();
    s.read_to_end(&mut raw).unwrap();
    let head_end = raw.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
    let head = String::from_utf8_lossy(&raw[..head_end]).to_string();
    let status: u16 = head.split(' ').nth(1).unwrap().parse().unwrap();
    let mut body = raw[head_end + 4..].to_vec();
    if head
        .to_ascii_lowercase()
        .contains("transfer-encoding: chunked")
    {
        let mut out = Vec::new();
        let mut rest = &body[..];
        loop {
            let eol = rest.windows(2).position(|w| w == b"\r\n").unwrap();
            let size =
                usize::from_str_radix(std::str::from_utf8(&rest[..eol]).unwrap(), 16).unwrap();
            if size == 0 {
                break;
            }
            out.extend_from_slice(&rest[eol + 2..eol + 2 + size]);
            rest = &rest[eol + 2 + size + 2..];
        }
        body = out;
    }
    (status, body)
}

fn interrupt(child: &mut Child) -> i32 {
    Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    child.wait().unwrap().code().unwrap_or(-1)
}

fn record(dir: &Path) -> std::path::PathBuf {
    let scn = dir.join("tiny.toml");
    std::fs::write(&scn, TINY).unwrap();
    let out = dir.join("out");
    let o = bin()
        .args([
            "run",
            scn.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "-q",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out
}

#[test]
fn view_serves_a_run_and_only_its_catalog() {
    let dir = tempfile::tempdir().unwrap();
    let out = record(dir.path());
    let (mut child, addr) = start(&["view", out.to_str().unwrap(), "--no-open", "--port", "0"]);
    let (code, page) = get(&addr, "/");
    assert_eq!(code, 200);
    assert!(String::from_utf8_lossy(&page).contains("app.js"));
    let (code, three) = get(&addr, "/vendor/three.js");
    assert_eq!(code, 200);
    assert!(three.len() > 100_000, "three.js is embedded");
    let (code, cat) = get(&addr, "/api/catalog");
    assert_eq!(code, 200);
    let cat: serde_json::Value = serde_json::from_slice(&cat).unwrap();
    assert_eq!(cat["kind"], "run");
    assert_eq!(cat["runs"][0]["id"], ".");
    // The run's data: a JSON header, then float32 arrays named as in trajectory.npz.
    let (code, blob) = get(&addr, "/api/run?id=.");
    assert_eq!(code, 200);
    let len = u32::from_le_bytes(blob[..4].try_into().unwrap()) as usize;
    let header: serde_json::Value = serde_json::from_slice(&blob[4..4 + len]).unwrap();
    assert_eq!(header["frames"], 51);
    assert_eq!(header["frames_total"], 51);
    let arrays = header["arrays"].as_array().unwrap();
    let pos = arrays
        .iter()
        .find(|a| a["name"] == "trajectory/position")
        .expect("positions sent");
    assert_eq!(pos["shape"], serde_json::json!([51, 11, 3]));
    // The base node of frame 0 is at the origin, the rest along +x (the rod at rest).
    let data = &blob[4 + len..];
    let at = |k: usize| {
        let o = 4 * (pos["offset"].as_u64().unwrap() as usize + k);
        f32::from_le_bytes(data[o..o + 4].try_into().unwrap())
    };
    assert_eq!(at(0), 0.0);
    assert!((at(30) - 0.2).abs() < 1e-6, "{}", at(30));
    assert_eq!(
        header["scene"]["rods"][0]["radius"]
            .as_array()
            .unwrap()
            .len(),
        10
    );
    for bad in ["/api/run?id=..", "/api/run?id=/etc", "/nothing"] {
        assert_eq!(get(&addr, bad).0, 404, "{bad}");
    }
    assert!(
        get(&addr, "/api/live").0 >= 400,
        "no live stream in a replay"
    );
    assert_eq!(interrupt(&mut child), 0);
}

#[test]
fn view_refuses_what_is_not_a_run_and_a_busy_port() {
    let dir = tempfile::tempdir().unwrap();
    let o = bin()
        .args(["view", dir.path().to_str().unwrap(), "--no-open"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("holds no run"));
    let out = record(dir.path());
    let (mut child, addr) = start(&["view", out.to_str().unwrap(), "--no-open"]);
    let port = addr.rsplit(':').next().unwrap();
    let o = bin()
        .args(["view", out.to_str().unwrap(), "--no-open", "--port", port])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("cannot listen on 127.0.0.1"));
    assert_eq!(interrupt(&mut child), 0);
    let o = bin()
        .args(["run", "x.toml", "--port", "8080"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--view"));
}
