//! `[initial_state]`: a frame of an earlier run's `trajectory.npz` as the initial state of every
//! rod (positions, velocities, directors, angular velocities), its time and step count, and the
//! work and dissipation recorded until then, so that a continued run equals the uninterrupted
//! one. Shapes are checked against the scenario's rods; nothing is reshaped or guessed.

use crate::output::{npz_names, read_npz_frame, read_npz_vector};
use crate::recorder::array_key;
use crate::scenario::{InitialStateConfig, Scenario, ScenarioError};
use octoarm_physics::{RodState, RodSystem, SystemState};

/// Overwrite `state` with the frame `init` names.
pub fn apply(
    scn: &Scenario,
    init: &InitialStateConfig,
    system: &RodSystem,
    state: &mut SystemState,
) -> Result<(), ScenarioError> {
    let path = scn.relative_path(&init.file);
    let at = |key: &str, msg: String| scn.error_at(key, format!("{key}: {msg}"));
    let names = npz_names(&path).map_err(|e| at("initial_state.file", format!("{e:#}")))?;
    let times =
        read_npz_vector(&path, "time").map_err(|e| at("initial_state.file", format!("{e:#}")))?;
    if times.is_empty() {
        return Err(at(
            "initial_state.file",
            format!("{} holds no frames", path.display()),
        ));
    }
    let frames = times.len();
    let index = match (init.frame, init.time) {
        (_, Some(t)) => {
            let half = 0.5 * system.settings().dt;
            times
                .iter()
                .position(|&x| (x - t).abs() <= half)
                .ok_or_else(|| {
                    at(
                        "initial_state.time",
                        format!(
                            "no frame of {} at t = {t} s (frames from {} s to {} s)",
                            path.display(),
                            times[0],
                            times[frames - 1]
                        ),
                    )
                })?
        }
        (Some(f), None) => {
            let i = if f < 0 { frames as i64 + f } else { f };
            if !(0..frames as i64).contains(&i) {
                return Err(at(
                    "initial_state.frame",
                    format!(
                        "{f} is outside the allowed range [-{frames}, {}]",
                        frames - 1
                    ),
                ));
            }
            i as usize
        }
        (None, None) => frames - 1,
    };
    let multi = system.rods().len() > 1;
    let dt = system.settings().dt;
    let t = times[index];
    for (r, rod) in system.rods().iter().enumerate() {
        let n = rod.n_elements();
        let key = |field: &str| array_key(multi, &rod.name, field);
        let read = |field: &str, shape: &[usize]| -> Result<Vec<f64>, ScenarioError> {
            let name = key(field);
            if !names.contains(&name) {
                return Err(at(
                    "initial_state.file",
                    format!(
                        "{} has no array `{name}` (rod \"{}\"; arrays: {})",
                        path.display(),
                        rod.name,
                        names.join(", ")
                    ),
                ));
            }
            let (got, values) = read_npz_frame(&path, &name, index)
                .map_err(|e| at("initial_state.file", format!("{e:#}")))?;
            if &got[1..] != shape {
                return Err(at(
                    "initial_state.file",
                    format!(
                        "`{name}` has frames of shape {:?}; rod \"{}\" with {n} elements needs {shape:?}",
                        &got[1..],
                        rod.name
                    ),
                ));
            }
            Ok(values)
        };
        let pos = read("position", &[n + 1, 3])?;
        let vel = read("velocity", &[n + 1, 3])?;
        let dir = read("director", &[n, 3, 3])?;
        let omega = read("omega", &[n, 3])?;
        let v3 = |v: &[f64]| v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let s = RodState {
            time: t,
            position: v3(&pos),
            velocity: v3(&vel),
            director: dir
                .chunks_exact(9)
                .map(|c| [[c[0], c[1], c[2]], [c[3], c[4], c[5]], [c[6], c[7], c[8]]])
                .collect(),
            omega: v3(&omega),
        };
        system
            .set_rod_state(state, r, &s)
            .map_err(|e| at("initial_state.file", format!("rod \"{}\": {e}", rod.name)))?;
        for (field, dst) in [
            ("external_work", &mut state.work[r]),
            ("dissipated_energy", &mut state.dissipated[r]),
        ] {
            let name = key(field);
            if names.contains(&name) {
                let (_, v) = read_npz_frame(&path, &name, index)
                    .map_err(|e| at("initial_state.file", format!("{e:#}")))?;
                *dst = v[0];
            }
        }
    }
    // Continue the step count when the frame lies on this run's step grid from t = 0 (so that
    // t = step · dt is bit-identical and the periodic checks fall on the same steps).
    let step = (t / dt).round();
    if step >= 0.0 && step * dt == t {
        state.origin = 0.0;
        state.step = step as u64;
    } else {
        state.origin = t;
        state.step = 0;
    }
    state.time = t;
    Ok(())
}
