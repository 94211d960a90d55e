//! Claim: a run continued from frame k of an earlier run's `trajectory.npz` (`[initial_state]`)
//! equals the uninterrupted run to the last bit: every array of every frame from k on, time
//! included, and the accumulated work and dissipation.
//!
//! Reference: the uninterrupted run itself. The scenario is chosen so that every part of the
//! state matters: a tapered arm with a ramped tip force (time-dependent: the continued run must
//! resume the time axis exactly, t = step · dt), a lab couple, gravity, per-length and
//! mass-proportional damping, a sphere it touches, and a frame interval that is not a multiple of
//! the guard or orthonormality intervals. Two rods (the second pinned at its base) check that
//! every rod of a system is restored.
//!
//! How a wrong implementation fails: dropping ω (angular velocities) or v, restarting the time at
//! 0 or summing it from t_k (ramps and obstacle motion shift), restarting the step count (the
//! periodic re-orthonormalisation falls on other steps), or not restoring the work and
//! dissipation integrals changes at least one array's bits.

mod common;
use common::octoarm;

use std::io::Read;
use std::path::{Path, PathBuf};

/// (name, data) of every `.npz` member.
fn members(path: &Path) -> Vec<(String, Vec<f64>, Vec<usize>)> {
    let mut zip = zip::ZipArchive::new(std::fs::File::open(path).unwrap()).unwrap();
    let mut out = Vec::new();
    for i in 0..zip.len() {
        let mut m = zip.by_index(i).unwrap();
        let name = m.name().trim_end_matches(".npy").to_string();
        let mut bytes = Vec::new();
        m.read_to_end(&mut bytes).unwrap();
        let header = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        let dict = String::from_utf8_lossy(&bytes[10..10 + header]).into_owned();
        let shape: Vec<usize> = dict
            .split("'shape': (")
            .nth(1)
            .unwrap()
            .split(')')
            .next()
            .unwrap()
            .split(',')
            .filter_map(|d| d.trim().parse().ok())
            .collect();
        let data = bytes[10 + header..]
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect();
        out.push((name, data, shape));
    }
    out
}

const SCENARIO: &str = r#"
[[rod]]
name = "arm"
n_elements = 40
length = 0.2
base_diameter = 0.02
tip_diameter = 0.004
density = 700.0
youngs_modulus = 1.0e4
shear_modulus = 1.0e3

[[rod]]
name = "feeler"
n_elements = 12
length = 0.1
base_diameter = 0.004
density = 700.0
youngs_modulus = 1.0e5
shear_modulus = 4.0e4
base_position = [0.0, 0.0, 0.05]
direction = [0.0, 1.0, 0.0]
normal = [0.0, 0.0, 1.0]
base = "pinned"

[time]
dt = 2.0e-5
duration = DURATION
save_interval = 7.0e-4

[damping]
rate = 2.0
gamma = 0.002

[[load]]
kind = "tip_force"
rod = "arm"
value = [0.0, 4.0e-5, 1.0e-5]
ramp_time = 0.03

[[load]]
kind = "tip_couple"
rod = "arm"
value = [0.0, 0.0, 2.0e-7]

[[load]]
kind = "gravity"
value = [0.0, 0.0, -0.5]

[[obstacle]]
kind = "sphere"
center = [0.1, 0.035, 0.0]
diameter = 0.04
"#;

#[test]
fn a_run_continued_from_a_frame_equals_the_uninterrupted_run_to_the_last_bit() {
    // Frame 71: t = 71 · 35 steps of 2e-5 s = 0.0497 s, not a multiple of the 100-step guard
    // interval nor of the 1000-step orthonormality interval.
    let (full, _) = assert_continuation_is_exact(SCENARIO, 0.0994, 71);
    assert!(
        full.len() > 2 * 12,
        "{} members: both rods' arrays",
        full.len()
    );
}

/// An arm lying on a floor with anisotropic static/kinetic friction and pressed sideways onto a
/// frictional sphere, pushed along the floor by a ramped tip force: the stick springs of both
/// obstacles (the contact's memory) are loaded at the restart frame, so dropping them — starting
/// the continued run with relaxed springs — changes the trajectory.
const FRICTION: &str = r#"
[rod]
n_elements = 30
length = 0.2
base_diameter = 0.02
tip_diameter = 0.004
density = 700.0
youngs_modulus = 1.0e4
shear_modulus = 1.0e3
base_position = [0.0, 0.0, 0.01]

[time]
dt = 2.0e-5
duration = DURATION
save_interval = 7.0e-4

[numerics]
clamp_order = 2

[damping]
rate = 5.0

[[load]]
kind = "gravity"
value = [0.0, 0.0, -9.81]

[[load]]
kind = "tip_force"
value = [0.0, 3.0e-3, 0.0]
ramp_time = 0.05

[[plane]]
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
friction = [0.2, 0.4, 0.6]
kinetic_friction = [0.15, 0.3, 0.5]

[[obstacle]]
kind = "sphere"
center = [0.15, 0.025, 0.01]
diameter = 0.03
friction = 0.5
"#;

#[test]
fn a_frictional_contact_continues_exactly_with_its_stick_springs() {
    let (full, k) = assert_continuation_is_exact(FRICTION, 0.0994, 71);
    let (_, stick, shape) = full
        .iter()
        .find(|m| m.0 == "contact_stick")
        .expect("trajectory.npz records the stick springs");
    let per: usize = shape[1..].iter().product();
    let loaded = stick[k * per..(k + 1) * per]
        .iter()
        .filter(|v| v.abs() > 1e-12)
        .count();
    assert!(
        loaded > 10,
        "the test needs loaded stick springs at frame {k}: {loaded} of {per} components"
    );
}

/// Run `scenario` for `duration`, continue it from frame `k` in a second run, and assert that
/// every member of the continued `trajectory.npz` equals the uninterrupted run's from frame k
/// on, bit for bit. Returns the uninterrupted run's members and k.
#[allow(clippy::type_complexity)]
fn assert_continuation_is_exact(
    scenario: &str,
    duration: f64,
    k: usize,
) -> (Vec<(String, Vec<f64>, Vec<usize>)>, usize) {
    let tmp = tempfile::tempdir().unwrap();
    let dir: PathBuf = tmp.path().to_path_buf();
    std::fs::write(
        dir.join("full.toml"),
        scenario.replace("DURATION", &format!("{duration}")),
    )
    .unwrap();
    let o = octoarm(&["run", "-q", "full.toml", "--out", "full"], &dir);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let full = members(&dir.join("full/trajectory.npz"));
    let time = &full.iter().find(|m| m.0 == "time").unwrap().1;
    let t_k = time[k];
    let rest = duration - t_k;
    let text = scenario.replace("DURATION", &format!("{rest}"))
        + &format!("\n[initial_state]\nfile = \"full/trajectory.npz\"\nframe = {k}\n");
    std::fs::write(dir.join("continued.toml"), text).unwrap();
    let o = octoarm(&["run", "-q", "continued.toml", "--out", "continued"], &dir);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let cont = members(&dir.join("continued/trajectory.npz"));

    let frames_full = time.len();
    let frames_cont = cont.iter().find(|m| m.0 == "time").unwrap().1.len();
    assert_eq!(frames_cont, frames_full - k, "frames from k to the end");
    assert!(full.len() > 12, "{} members", full.len());
    for (name, data, shape) in &full {
        let (_, c, cshape) = cont
            .iter()
            .find(|m| &m.0 == name)
            .unwrap_or_else(|| panic!("{name} missing from the continued run"));
        assert_eq!(&cshape[1..], &shape[1..], "{name}");
        let per: usize = shape[1..].iter().product();
        let expected = &data[k * per..];
        let differing = expected
            .iter()
            .zip(c)
            .filter(|(a, b)| a.to_bits() != b.to_bits())
            .count();
        assert_eq!(
            differing,
            0,
            "{name}: {differing} of {} values differ from the uninterrupted run",
            expected.len()
        );
    }
    (full, k)
}

/// Bad input for the stick springs of `[initial_state]`: a file whose `contact_stick` does not
/// fit the scenario's frictional obstacles, or holds a non-finite value, is refused naming the
/// array and what is needed (exit 2, nothing written); the file itself is left as it was.
#[test]
fn stick_springs_that_do_not_fit_or_are_not_finite_are_refused() {
    use ndarray::ArrayD;
    use ndarray_npy::{NpzReader, NpzWriter};
    let tmp = tempfile::tempdir().unwrap();
    let dir: PathBuf = tmp.path().to_path_buf();
    std::fs::write(dir.join("full.toml"), FRICTION.replace("DURATION", "0.01")).unwrap();
    let o = octoarm(&["run", "-q", "full.toml", "--out", "full"], &dir);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let continued = |scenario: &str, file: &str| {
        format!("{scenario}\n[initial_state]\nfile = \"{file}\"\nframe = 3\n")
            .replace("DURATION", "0.005")
    };

    // The sphere without friction: one obstacle's springs fewer than the file has.
    let frictionless = FRICTION.replace("friction = 0.5\n", "");
    std::fs::write(
        dir.join("fewer.toml"),
        continued(&frictionless, "full/trajectory.npz"),
    )
    .unwrap();
    let o = octoarm(&["run", "-q", "fewer.toml", "--out", "fewer"], &dir);
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("contact_stick") && err.contains("frictional obstacles need [60, 3]"),
        "{err}"
    );
    assert!(!dir.join("fewer").exists());

    // A NaN in frame 3's springs.
    let original = std::fs::read(dir.join("full/trajectory.npz")).unwrap();
    let mut reader =
        NpzReader::new(std::fs::File::open(dir.join("full/trajectory.npz")).unwrap()).unwrap();
    let names = reader.names().unwrap();
    let mut writer = NpzWriter::new(std::fs::File::create(dir.join("nan.npz")).unwrap());
    for name in names {
        let name = name.trim_end_matches(".npy").to_string();
        let mut a: ArrayD<f64> = reader.by_name(&name).unwrap();
        if name == "contact_stick" {
            a[[3, 7, 1]] = f64::NAN;
        }
        writer.add_array(name.as_str(), &a).unwrap();
    }
    writer.finish().unwrap();
    std::fs::write(dir.join("nan.toml"), continued(FRICTION, "nan.npz")).unwrap();
    let o = octoarm(&["run", "-q", "nan.toml", "--out", "nan"], &dir);
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("`contact_stick` of frame 3 holds NaN"),
        "{err}"
    );
    assert!(!dir.join("nan").exists());
    assert_eq!(
        std::fs::read(dir.join("full/trajectory.npz")).unwrap(),
        original
    );
}
