//! Claims (issue 16, items 1, 3, 6, 8): octoarm never deletes or overwrites a file it did not
//! write, and an interrupted run keeps what it recorded. (1) `--out` into a folder that is not
//! octoarm's — even one holding a `summary.json` or `scenario.toml` or `report.md` — is refused
//! (exit 2), naming what is in the way, and everything in it survives; an octoarm output that a
//! user put a file into is refused the same way; octoarm's own output is replaced. (2) SIGINT /
//! SIGTERM during a run: the run records the state it stopped at, writes a valid output with
//! status "interrupted" and exits 130 / 143, leaving no partial folder; `paper` interrupted
//! writes a report that says which experiments ran. (3) A second octoarm writing the same place
//! is refused while the first runs; stale partial folders of dead processes are removed.
//! (4) A read-only output is refused before anything runs. (5) A full disk stops the run with one
//! message naming the file. (6) `--threads 0` and `--duration -1` are named errors (exit 2).
//!
//! Reference: the file system before and after (every file a user put there is compared byte for
//! byte); the outputs read back with the zip reader.

mod common;
use common::{bin, octoarm, snapshot, stderr, workspace, TINY};

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

/// Hidden partial, old or lock entries left in `dir`.
fn leftovers(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".partial-") || n.contains(".old-") || n.ends_with(".lock"))
        .collect()
}

#[test]
fn out_into_a_users_folder_is_refused_and_nothing_of_theirs_is_touched() {
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("p");
    std::fs::create_dir_all(p.join("notes")).unwrap();
    std::fs::write(p.join("scenario.toml"), TINY).unwrap();
    std::fs::write(p.join("summary.json"), "{\"mine\": true}").unwrap();
    std::fs::write(p.join("notes/thesis.md"), "years of work").unwrap();
    let before = snapshot(&p);
    let o = octoarm(&["run", "p/scenario.toml", "--out", "p"], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("not an octoarm output") && err.contains("notes/"),
        "{err}"
    );
    assert_eq!(snapshot(&p), before, "the user's folder changed");
    assert!(
        leftovers(tmp.path()).is_empty(),
        "{:?}",
        leftovers(tmp.path())
    );

    // The same for `paper`: a user's report.md and grasp/mydata.csv.
    let root = tmp.path().join("paper");
    std::fs::create_dir_all(root.join("grasp")).unwrap();
    std::fs::write(root.join("report.md"), "my report").unwrap();
    std::fs::write(root.join("grasp/mydata.csv"), "1,2,3").unwrap();
    let before = snapshot(&root);
    let o = octoarm(
        &["paper", "--out", "paper", "--duration", "0.001"],
        tmp.path(),
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("report.md"), "{}", stderr(&o));
    assert_eq!(snapshot(&root), before);
}

#[test]
fn octoarms_own_output_is_replaced_but_not_once_a_user_adds_a_file() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("s.toml"), TINY).unwrap();
    let run = || octoarm(&["run", "-q", "s.toml", "--out", "out"], tmp.path());
    assert!(run().status.success());
    let out = tmp.path().join("out");
    assert!(out.join(".octoarm").is_file(), "the marker");
    // Replaced whole: a second run works.
    let o = run();
    assert!(o.status.success(), "{}", stderr(&o));
    // A user's file inside: refused, file intact, output intact.
    std::fs::write(out.join("my_analysis.py"), "import numpy").unwrap();
    let before = snapshot(&out);
    let o = run();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("my_analysis.py") && stderr(&o).contains("did not write"),
        "{}",
        stderr(&o)
    );
    assert_eq!(snapshot(&out), before);
    assert!(leftovers(tmp.path()).is_empty());
}

#[test]
fn a_read_only_output_is_refused_before_the_run() {
    use std::os::unix::fs::PermissionsExt;
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("s.toml"), TINY).unwrap();
    let o = octoarm(&["run", "-q", "s.toml", "--out", "good"], tmp.path());
    assert!(o.status.success());
    let good = tmp.path().join("good");
    std::fs::set_permissions(&good, std::fs::Permissions::from_mode(0o555)).unwrap();
    let before = snapshot(&good);
    let o = octoarm(&["run", "-q", "s.toml", "--out", "good"], tmp.path());
    std::fs::set_permissions(&good, std::fs::Permissions::from_mode(0o755)).unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("read-only"), "{}", stderr(&o));
    assert_eq!(snapshot(&good), before);
    assert!(
        leftovers(tmp.path()).is_empty(),
        "{:?}",
        leftovers(tmp.path())
    );
}

/// A scenario that runs for many seconds (the paper's arm, 30 s simulated).
fn long_scenario(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(workspace().join("scenarios/arm_tip_force.toml"))
        .unwrap()
        .replace("duration = 2.0", "duration = 30.0");
    let p = dir.join("long.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// Start `octoarm run long.toml --out out` and wait until it has stepped for `after`.
fn start_long(dir: &Path, out: &str, after: Duration) -> std::process::Child {
    long_scenario(dir);
    let child = Command::new(bin())
        .args(["run", "-q", "long.toml", "--out", out])
        .current_dir(dir)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(after);
    child
}

fn signal(child: &std::process::Child, sig: &str) {
    let ok = Command::new("kill")
        .args([sig, &child.id().to_string()])
        .status()
        .unwrap()
        .success();
    assert!(ok);
}

fn trajectory_frames(dir: &Path) -> usize {
    let mut zip =
        zip::ZipArchive::new(std::fs::File::open(dir.join("trajectory.npz")).unwrap()).unwrap();
    let mut m = zip.by_name("time.npy").unwrap();
    let mut b = Vec::new();
    m.read_to_end(&mut b).unwrap();
    let header = u16::from_le_bytes([b[8], b[9]]) as usize;
    (b.len() - 10 - header) / 8
}

#[test]
fn sigint_and_sigterm_write_what_was_recorded_and_exit_130_and_143() {
    for (sig, code) in [("-INT", 130), ("-TERM", 143)] {
        let tmp = tempfile::tempdir().unwrap();
        let child = start_long(tmp.path(), "out", Duration::from_millis(1500));
        signal(&child, sig);
        let started = Instant::now();
        let o = child.wait_with_output().unwrap();
        assert!(
            started.elapsed() < Duration::from_secs(20),
            "stopping took {:?}",
            started.elapsed()
        );
        assert_eq!(o.status.code(), Some(code), "{sig}: {}", stderr(&o));
        assert!(stderr(&o).contains("interrupted"), "{}", stderr(&o));
        let out = tmp.path().join("out");
        let s = summary(&out);
        assert_eq!(s["status"], "interrupted", "{sig}");
        let frames = trajectory_frames(&out);
        assert!(frames > 2, "{sig}: {frames} frames");
        assert_eq!(s["frames"].as_u64().unwrap() as usize, frames);
        assert!(s["steps"].as_u64().unwrap() < s["planned_steps"].as_u64().unwrap());
        assert!(
            leftovers(tmp.path()).is_empty(),
            "{:?}",
            leftovers(tmp.path())
        );
    }
}

#[test]
fn a_second_writer_is_refused_and_stale_partials_are_cleaned() {
    let tmp = tempfile::tempdir().unwrap();
    // A stale partial folder of a process that no longer exists, with octoarm's marker.
    let stale = tmp.path().join(".out.partial-2147483600");
    std::fs::create_dir(&stale).unwrap();
    std::fs::write(
        stale.join(".octoarm"),
        "program = \"octoarm\"\nkind = \"partial\"\nrun = \"x\"\nentries = []\n",
    )
    .unwrap();
    std::fs::write(stale.join(".position.spool"), vec![0u8; 1 << 16]).unwrap();
    let first = start_long(tmp.path(), "out", Duration::from_millis(800));
    assert!(!stale.exists(), "the stale partial folder was not removed");
    std::fs::write(tmp.path().join("s.toml"), TINY).unwrap();
    let o = octoarm(&["run", "-q", "s.toml", "--out", "out"], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("another octoarm"), "{}", stderr(&o));
    signal(&first, "-INT");
    let o = first.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    assert!(
        leftovers(tmp.path()).is_empty(),
        "{:?}",
        leftovers(tmp.path())
    );
}

#[test]
fn an_interrupted_paper_says_which_experiments_ran() {
    let tmp = tempfile::tempdir().unwrap();
    let child = Command::new(bin())
        .args(["paper", "-q", "--out", "results", "--threads", "1"])
        .current_dir(tmp.path())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // One worker: the first experiment (C, about 10 s) is running.
    std::thread::sleep(Duration::from_millis(3000));
    signal(&child, "-INT");
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    let root = tmp.path().join("results");
    let report = std::fs::read_to_string(root.join("report.md")).unwrap();
    assert!(report.contains("**Interrupted**"), "{report}");
    assert!(report.contains("not run (interrupted)"), "{report}");
    let ran = summary(&root.join("obstacles"));
    assert_eq!(ran["status"], "interrupted");
    assert!(
        !root.join("grasp").exists(),
        "an experiment that was not started has no folder"
    );
    assert!(root.join(".octoarm").is_file());
}

#[test]
fn a_full_disk_stops_with_one_message_naming_the_file() {
    if unsafe_is_root() {
        let tmp = tempfile::tempdir().unwrap();
        let small = tmp.path().join("small");
        std::fs::create_dir(&small).unwrap();
        let mounted = Command::new("mount")
            .args(["-t", "tmpfs", "-o", "size=256k", "tmpfs"])
            .arg(&small)
            .status()
            .is_ok_and(|s| s.success());
        assert!(mounted, "as root, a tmpfs can be mounted for this test");
        let text = std::fs::read_to_string(workspace().join("scenarios/arm_tip_force.toml"))
            .unwrap()
            .replace("duration = 2.0", "duration = 0.5");
        std::fs::write(tmp.path().join("big.toml"), text).unwrap();
        let o = octoarm(&["run", "-q", "big.toml", "--out", "small/out"], tmp.path());
        let _ = Command::new("umount").arg(&small).status();
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains("No space left on device"), "{err}");
        assert!(err.contains("cannot write"), "{err}");
        assert!(!err.contains("ZipWriter drop failed"), "{err}");
        assert_eq!(err.matches("error:").count(), 1, "one message: {err}");
    } else {
        eprintln!("not root: the full-disk test needs to mount a tmpfs (CI runs as root)");
    }
}

fn unsafe_is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}

#[test]
fn threads_0_and_a_negative_duration_are_named_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let o = octoarm(&["paper", "--out", "r", "--threads", "0"], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("--threads") && stderr(&o).contains("1..=256"),
        "{}",
        stderr(&o)
    );
    std::fs::write(tmp.path().join("s.toml"), TINY).unwrap();
    let o = octoarm(&["run", "s.toml", "--duration", "-1"], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("time.duration = -1"), "{}", stderr(&o));
    assert!(!tmp.path().join("r").exists() && !tmp.path().join("results").exists());
}
