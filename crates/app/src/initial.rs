//! `[initial_state]`: a frame of an earlier run's `trajectory.npz` as the initial state of every
//! rod (positions, velocities, directors, angular velocities), its time and step count, and the
//! work and dissipation recorded until then, and the friction springs of the obstacles
//! (`contact_stick`; relaxed when the file has none), so that a continued run equals the
//! uninterrupted one. Shapes are checked against the scenario's rods and obstacles; nothing is
//! reshaped or guessed.

use crate::output::{npz_names, read_npz_frame, read_npz_vector};
use crate::recorder::{array_key, STICK_ARRAY};
use crate::scenario::{fmt_num, InitialStateConfig, Scenario, ScenarioError};
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
    // The frame count from the header (reading one value): a huge file is not read whole.
    let frames = match read_npz_frame(&path, "time", 0) {
        Ok((shape, _)) => shape.first().copied().unwrap_or(0),
        Err(e) if format!("{e:#}").contains("frame 0 requested") => 0,
        Err(e) => return Err(at("initial_state.file", format!("{e:#}"))),
    };
    if frames == 0 {
        return Err(at(
            "initial_state.file",
            format!("{} holds no frames", path.display()),
        ));
    }
    if frames > MAX_INITIAL_FRAMES {
        return Err(at(
            "initial_state.file",
            format!(
                "{} holds {frames} frames, more than the {MAX_INITIAL_FRAMES} octoarm reads to \
                 find one; is this a trajectory.npz?",
                path.display()
            ),
        ));
    }
    let times =
        read_npz_vector(&path, "time").map_err(|e| at("initial_state.file", format!("{e:#}")))?;
    if times.len() != frames {
        return Err(at(
            "initial_state.file",
            format!("{}: `time` is not a vector of frames", path.display()),
        ));
    }
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
                            "no frame of {} at t = {} s (frames from {} s to {} s)",
                            path.display(),
                            fmt_num(t),
                            fmt_num(times[0]),
                            fmt_num(times[frames - 1])
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
    if !t.is_finite() {
        return Err(at(
            "initial_state.file",
            format!(
                "{}: frame {index} has time {}, not a finite number",
                path.display(),
                fmt_num(t)
            ),
        ));
    }
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
                let value = v.first().copied().unwrap_or(f64::NAN);
                if !value.is_finite() {
                    return Err(at(
                        "initial_state.file",
                        format!(
                            "{}: `{name}` of frame {index} is {}, not a finite number",
                            path.display(),
                            fmt_num(value)
                        ),
                    ));
                }
                *dst = value;
            }
        }
    }
    let slots = system.stick_slots();
    if names.iter().any(|n| n == STICK_ARRAY) {
        let (got, values) = read_npz_frame(&path, STICK_ARRAY, index)
            .map_err(|e| at("initial_state.file", format!("{e:#}")))?;
        if got[1..] != [slots, 3] {
            return Err(at(
                "initial_state.file",
                format!(
                    "`{STICK_ARRAY}` has frames of shape {:?}; this scenario's frictional \
                     obstacles need [{slots}, 3] (continue a run with the obstacles it had)",
                    &got[1..]
                ),
            ));
        }
        if let Some(v) = values.iter().find(|v| !v.is_finite()) {
            return Err(at(
                "initial_state.file",
                format!(
                    "{}: `{STICK_ARRAY}` of frame {index} holds {}, not a finite number",
                    path.display(),
                    fmt_num(*v)
                ),
            ));
        }
        state.stick = values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
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
    // The energies of the frame must be finite (a frame of speed 1e160 m/s is finite but its
    // kinetic energy is not).
    let mut sigma = system.rest_sigma.clone();
    let mut kappa = system.rest_kappa.clone();
    if !system.rest_changes().is_empty() {
        system.rest_at(t, &mut sigma, &mut kappa);
    }
    let ec = system.settings().energy_consistent;
    for (r, rod) in system.rods().iter().enumerate() {
        let e = octoarm_physics::energies_with_rest(
            &rod.model,
            &system.view(state, r),
            &sigma[rod.elements()],
            &kappa[rod.interior()],
            ec,
        );
        let parts = [
            ("translational", e.translational),
            ("rotational", e.rotational),
            ("stretch", e.stretch),
            ("bend", e.bend),
        ];
        if let Some((what, v)) = parts.iter().find(|(_, v)| !v.is_finite()) {
            return Err(at(
                "initial_state.file",
                format!(
                    "{}: frame {index} of rod \"{}\" has a {what} energy of {} J (it overflows): \
                     not a state this rod can start from",
                    path.display(),
                    rod.name,
                    fmt_num(*v)
                ),
            ));
        }
    }
    Ok(())
}

/// Most frames of a `trajectory.npz` read to find the initial one (their times: 8 bytes each).
pub const MAX_INITIAL_FRAMES: usize = 1 << 25;
