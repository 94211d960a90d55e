//! Error types of the physics crate: bad model or settings input (`ModelError`) and a run that
//! went unstable (`StepError`). Every variant carries the data a user needs to fix the input.

/// Invalid input when building a rod, a load, an obstacle or the numerical settings.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelError {
    /// A number lies outside its allowed range (NaN and infinities included).
    #[error("{field} = {value} is outside the allowed range {range}")]
    OutOfRange {
        /// Name of the offending parameter, as a scenario file spells it.
        field: &'static str,
        /// The value given.
        value: f64,
        /// The allowed range, in words.
        range: &'static str,
    },
    /// An integer count lies outside its allowed range.
    #[error("{field} = {value} is outside the allowed range {range}")]
    CountOutOfRange {
        /// Name of the offending parameter.
        field: &'static str,
        /// The value given.
        value: usize,
        /// The allowed range, in words.
        range: &'static str,
    },
    /// A vector parameter is invalid (zero length, non-finite, not perpendicular, …).
    #[error("{field} = {value:?} is invalid: {reason}")]
    BadVector {
        /// Name of the offending parameter.
        field: &'static str,
        /// The value given.
        value: [f64; 3],
        /// What is wrong and what is allowed.
        reason: &'static str,
    },
    /// Two items that must have different names share one.
    #[error("{field} = {name:?} is used twice; names must be unique")]
    DuplicateName {
        /// Name of the field.
        field: &'static str,
        /// The repeated name.
        name: String,
    },
    /// An array has the wrong length.
    #[error("{field} has length {len}, expected {expected}")]
    BadLength {
        /// Name of the offending array.
        field: &'static str,
        /// The length given.
        len: usize,
        /// The length required.
        expected: usize,
    },
}

/// Helper: check that `value` is finite and strictly positive.
pub(crate) fn positive(field: &'static str, value: f64) -> Result<f64, ModelError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(ModelError::OutOfRange {
            field,
            value,
            range: "(0, inf), finite",
        })
    }
}

/// Helper: check that `value` is finite and non-negative.
pub(crate) fn non_negative(field: &'static str, value: f64) -> Result<f64, ModelError> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(ModelError::OutOfRange {
            field,
            value,
            range: "[0, inf), finite",
        })
    }
}

/// Helper: check that every component of a vector is finite.
pub(crate) fn finite_vec(field: &'static str, value: [f64; 3]) -> Result<[f64; 3], ModelError> {
    if value.iter().all(|v| v.is_finite()) {
        Ok(value)
    } else {
        Err(ModelError::BadVector {
            field,
            value,
            reason: "every component must be finite",
        })
    }
}

/// A simulation stopped by the stability guard (spec §11). The state is left as it was when
/// the guard fired, and whatever a caller recorded before stays valid.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StepError {
    /// A quantity became non-finite or left its admissible range.
    #[error(
        "unstable: {what} = {} at {}{domain} {index}, t = {time:.6} s (step {step}); {advice}",
        sig6(*.value),
        rod_prefix(.rod)
    )]
    Unstable {
        /// The quantity that failed (e.g. "dilatation e", "position").
        what: &'static str,
        /// Its value when the guard fired.
        value: f64,
        /// "node", "element" or "voronoi point".
        domain: &'static str,
        /// Index in that domain.
        index: usize,
        /// Name of the rod, in a system of several rods (None for a lone rod or a system-wide
        /// quantity).
        rod: Option<Box<str>>,
        /// Simulated time in s.
        time: f64,
        /// Step count.
        step: u64,
        /// The time step in use, s.
        dt: f64,
        /// A time step that should work, s.
        suggested_dt: f64,
        /// What to change, in words (contains the suggested dt or a flag to set).
        advice: String,
    },
}

/// A value in scientific notation with at most 6 significant digits (`1.02e-1`, `inf`).
fn sig6(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v:e}");
    }
    let s = format!("{v:.5e}");
    match s.split_once('e') {
        Some((m, e)) if m.contains('.') => {
            format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.'))
        }
        _ => s,
    }
}

fn rod_prefix(rod: &Option<Box<str>>) -> String {
    match rod {
        Some(name) => format!("rod `{name}`, "),
        None => String::new(),
    }
}
