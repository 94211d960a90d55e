//! How much a run writes, known before it starts: the uncompressed size of `trajectory.npz` and
//! (controlled runs) `series.npz` of a complete run, member by member (`.npy` header and float64
//! data of every array of every rod), so that `check` can show it and `run` can refuse a run
//! that would fill the disk. Zip framing (~100 bytes per member), `distance.csv` (~25 bytes a
//! sample), `summary.json`, `scenario.toml` and the figures are not counted.

use crate::output::npy_header;
use crate::scenario::{fmt_bytes, fmt_num, frames_of, steps_of, Scenario, ScenarioError};

/// Above this estimate `check` warns (and the command line refuses by default): 2 GB.
pub const OUTPUT_WARN_BYTES: u64 = 2_000_000_000;

/// The uncompressed bytes a complete run writes, by file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct OutputEstimate {
    /// Frames of `trajectory.npz`.
    pub frames: u64,
    /// Bytes of the `trajectory.npz` members (headers and data).
    pub trajectory: u64,
    /// Samples of `series.npz` (0 for a passive run).
    pub samples: u64,
    /// Bytes of the `series.npz` members (0 for a passive run).
    pub series: u64,
}

impl OutputEstimate {
    /// Both files together.
    pub fn total(&self) -> u64 {
        self.trajectory.saturating_add(self.series)
    }
}

/// Bytes of one `.npy` member of `rows` entries of `shape` each (header included).
fn member(rows: u64, shape: &[usize]) -> u64 {
    let per: u64 = shape.iter().map(|&d| d as u64).product();
    let mut full = vec![usize::try_from(rows).unwrap_or(usize::MAX)];
    full.extend_from_slice(shape);
    (npy_header(&full).len() as u64).saturating_add(rows.saturating_mul(per).saturating_mul(8))
}

/// The uncompressed size of the outputs of a complete run of `scn`, by file.
pub fn estimate_outputs(scn: &Scenario) -> OutputEstimate {
    let cfg = &scn.config;
    let frames = cfg.n_frames();
    let controlled = cfg
        .controller
        .as_ref()
        .and_then(|c| c.rod.as_deref())
        .and_then(|name| cfg.rod_index(name));
    let mut trajectory = member(frames, &[]);
    for (r, rod) in cfg.rods.list.iter().enumerate() {
        let n = rod.n_elements;
        for shape in [
            vec![n + 1, 3],
            vec![n + 1, 3],
            vec![n, 3, 3],
            vec![n, 3],
            vec![n, 3],
            vec![n - 1, 3],
        ] {
            trajectory = trajectory.saturating_add(member(frames, &shape));
        }
        // The six energy and work series.
        trajectory = trajectory.saturating_add(member(frames, &[]).saturating_mul(6));
        if controlled == Some(r) {
            trajectory = trajectory
                .saturating_add(member(frames, &[n + 1, 3]))
                .saturating_add(member(frames, &[3]).saturating_mul(2));
        }
    }
    let (mut samples, mut series) = (0, 0);
    if let (Some(c), Some(_)) = (&cfg.controller, controlled) {
        samples = frames_of(cfg.n_steps(), steps_of(c.series_interval, cfg.time.dt));
        let spheres = cfg.obstacles.len() + usize::from(cfg.grasp.is_some());
        // time, 10 scalar columns; tip and target; the spheres.
        series = member(samples, &[])
            .saturating_mul(11)
            .saturating_add(member(samples, &[3]).saturating_mul(2))
            .saturating_add(member(spheres as u64, &[4]));
    }
    OutputEstimate {
        frames,
        trajectory,
        samples,
        series,
    }
}

/// The uncompressed size of `trajectory.npz` (+ `series.npz`) a complete run of `scn` writes:
/// every array of every rod, float64, with its `.npy` header [bytes].
pub fn estimate_output_bytes(scn: &Scenario) -> u64 {
    estimate_outputs(scn).total()
}

/// One line for `check`: "trajectory.npz 19.3 GB (1000000001 frames) + series.npz 1.23 MB
/// (4001 samples) before compression".
pub fn describe(e: &OutputEstimate) -> String {
    let mut s = format!(
        "trajectory.npz {} ({} frames)",
        fmt_bytes(e.trajectory as f64),
        e.frames
    );
    if e.samples > 0 {
        s.push_str(&format!(
            " + series.npz {} ({} samples)",
            fmt_bytes(e.series as f64),
            e.samples
        ));
    }
    s.push_str(" before compression");
    s
}

/// What to change to write less, for warnings and refusals.
fn how_to_lower(scn: &Scenario) -> String {
    let cfg = &scn.config;
    let series = cfg
        .controller
        .as_ref()
        .map(|c| {
            format!(
                ", or controller.series_interval (now {} s)",
                fmt_num(c.series_interval)
            )
        })
        .unwrap_or_default();
    format!(
        "record less often: raise time.save_interval (now {} s; 10 times larger writes 10 times \
         less){series}; or shorten the run with --duration (now {} s)",
        fmt_num(cfg.time.save_interval),
        fmt_num(cfg.time.duration)
    )
}

/// The warning `check` prints above `OUTPUT_WARN_BYTES`, None below.
pub fn size_warning(scn: &Scenario) -> Option<String> {
    let e = estimate_outputs(scn);
    (e.total() > OUTPUT_WARN_BYTES).then(|| {
        format!(
            "a complete run writes about {} ({}), more than {}: {}",
            fmt_bytes(e.total() as f64),
            describe(&e),
            fmt_bytes(OUTPUT_WARN_BYTES as f64),
            how_to_lower(scn)
        )
    })
}

/// Refuse a run whose outputs would exceed `limit` bytes (the command line's `--max-output`):
/// an error at `time.save_interval` (exit 2, nothing written) with the estimate and how to
/// lower it.
pub fn check_output_size(scn: &Scenario, limit: u64) -> Result<OutputEstimate, ScenarioError> {
    let e = estimate_outputs(scn);
    if e.total() <= limit {
        return Ok(e);
    }
    Err(scn.error_at(
        "time.save_interval",
        format!(
            "a complete run would write about {} ({}), above the limit of {} (--max-output): {}; \
             or allow it with --max-output <bytes>",
            fmt_bytes(e.total() as f64),
            describe(&e),
            fmt_bytes(limit as f64),
            how_to_lower(scn)
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    const ROD: &str = "[rod]\nn_elements = 10\nlength = 0.2\nbase_diameter = 0.02\ndensity = 700.0\n\
                       youngs_modulus = 1e4\nshear_modulus = 1e3\n\n[time]\ndt = 1e-5\nduration = 0.01\n";

    #[test]
    fn passive_estimate_counts_every_member() {
        let scn = Scenario::from_str(Path::new("s.toml"), ROD).unwrap();
        let e = estimate_outputs(&scn);
        assert_eq!(e.frames, 11);
        assert_eq!(e.samples, 0);
        // 11 frames: time + 6 series (1 value) and the rod arrays (33 + 33 + 90 + 30 + 30 + 27
        // values), each with a 128-byte header (shapes of one to four axes fit in 128 bytes).
        let values = 11 * (1 + 6 + 33 + 33 + 90 + 30 + 30 + 27);
        assert_eq!(e.trajectory, 13 * 128 + 8 * values);
        assert_eq!(estimate_output_bytes(&scn), e.trajectory);
    }

    #[test]
    fn huge_runs_are_refused_with_the_estimate_and_what_to_change() {
        let text = ROD.replace("duration = 0.01", "duration = 1e5\nsave_interval = 1e-5");
        let scn = Scenario::from_str(Path::new("s.toml"), &text).unwrap();
        assert!(estimate_output_bytes(&scn) > 100 * OUTPUT_WARN_BYTES);
        let w = size_warning(&scn).unwrap();
        assert!(
            w.contains("save_interval") && w.contains("--duration"),
            "{w}"
        );
        let e = check_output_size(&scn, OUTPUT_WARN_BYTES).unwrap_err();
        let m = e.to_string();
        assert!(
            m.contains("s.toml:") && m.contains("TB") && m.contains("--max-output"),
            "{m}"
        );
        assert!(check_output_size(&scn, u64::MAX).is_ok());
    }
}
