//! Acceptance checks written in a scenario's `[[acceptance]]` tables (e.g. the paper's claims in
//! `scenarios/paper/*.toml`), evaluated on a controlled run's series and derived figures: each
//! claim passes, fails, or is undecided when the run ended before the time it is about.

use crate::scenario::{AcceptanceConfig, AcceptanceQuantity};
use crate::series::{ControlSummary, Sample};

/// One evaluated claim.
#[derive(Debug, Clone, PartialEq)]
pub struct Check {
    /// The claim, e.g. "d(4 s) ≤ 0.01".
    pub claim: String,
    /// The measured value(s), in words.
    pub measured: String,
    /// Pass, fail, or not decidable (None).
    pub pass: Option<bool>,
    /// The scenario's remark, if any.
    pub note: Option<String>,
}

fn within(v: f64, a: &AcceptanceConfig) -> bool {
    a.min.map_or(true, |m| v >= m) && a.max.map_or(true, |m| v <= m)
}

/// Evaluate every claim. `length` is L0 [m], `duration` the planned run length [s].
pub fn evaluate(
    claims: &[AcceptanceConfig],
    series: &[Sample],
    summary: &ControlSummary,
    length: f64,
    duration: f64,
) -> Vec<Check> {
    let end = series.last().map_or(0.0, |x| x.time);
    let reached = |t: f64| end >= t - 1e-9;
    let short = |t: f64| format!("run ends at {end:.3} s, before {t} s");
    claims
        .iter()
        .map(|a| {
            let (measured, pass) =
                measure(a, series, summary, length, duration, end, &reached, &short);
            Check {
                claim: a.claim.clone(),
                measured,
                pass,
                note: a.note.clone(),
            }
        })
        .collect()
}

#[allow(clippy::too_many_arguments)]
fn measure(
    a: &AcceptanceConfig,
    series: &[Sample],
    summary: &ControlSummary,
    length: f64,
    duration: f64,
    end: f64,
    reached: &dyn Fn(f64) -> bool,
    short: &dyn Fn(f64) -> String,
) -> (String, Option<bool>) {
    use AcceptanceQuantity as Q;
    let t = a.time.unwrap_or(0.0);
    match a.quantity {
        Q::DistanceBefore => match series.iter().rfind(|x| x.time < t - 1e-9) {
            Some(s) if reached(t) => (format!("{:.4}", s.distance), Some(within(s.distance, a))),
            _ => (short(t), None),
        },
        Q::DistanceAfter => match series.iter().find(|x| x.time >= t - 1e-9) {
            Some(s) => (format!("{:.4}", s.distance), Some(within(s.distance, a))),
            None => (short(t), None),
        },
        Q::DistanceAt => {
            if !reached(t) {
                return (short(t), None);
            }
            let s = series
                .iter()
                .min_by(|x, y| (x.time - t).abs().total_cmp(&(y.time - t).abs()))
                .expect("a run that reached t has samples");
            (format!("{:.2e}", s.distance), Some(within(s.distance, a)))
        }
        Q::MaxDistance => {
            let (from, to) = (a.from.unwrap_or(0.0), a.to.unwrap_or(duration));
            if !reached(to) {
                return (short(to), None);
            }
            let m = series
                .iter()
                .filter(|x| x.time >= from - 1e-9 && x.time <= to + 1e-9)
                .map(|x| x.distance)
                .fold(0.0, f64::max);
            (format!("max {m:.4}"), Some(within(m, a)))
        }
        Q::DistanceRise => {
            let d0 = series.first().map_or(f64::NAN, |x| x.distance);
            let max = series.iter().map(|x| x.distance).fold(0.0, f64::max);
            (
                format!("d(0) = {d0:.4}, max {max:.4}"),
                Some(within(max - d0, a)),
            )
        }
        Q::SettlingTime => {
            let k = a.segment.unwrap_or(0);
            let Some(g) = summary.segments.get(k) else {
                return (format!("the run has no segment {k}"), None);
            };
            let bound = a.max.unwrap_or(f64::INFINITY);
            // The claim is about the segment up to start + bound (or the next target's start):
            // undecided until the run has got there. The last segment ends with the run, which a
            // shortened run ends early.
            let last = k + 1 == summary.segments.len();
            let horizon = if !bound.is_finite() {
                g.end
            } else if last {
                g.start + bound
            } else {
                (g.start + bound).min(g.end)
            };
            if !reached(horizon) {
                return (short(horizon), None);
            }
            match g.settling_time {
                Some(s) => (
                    format!("{:.3} s", s - g.start),
                    Some(within(s - g.start, a)),
                ),
                None if end >= g.end - 1e-9 && !last => ("never settles".into(), Some(false)),
                None => (format!("not settled by {horizon} s"), Some(false)),
            }
        }
        Q::MaxPenetration => {
            let p = summary.max_penetration;
            (format!("{:.3} mm", p * 1e3), Some(within(p, a)))
        }
        Q::DesignTipError => {
            let worst = summary
                .report
                .update_tip_errors
                .iter()
                .filter(|e| e.0 >= t)
                .map(|e| e.1 / length)
                .fold(f64::NAN, f64::max);
            if worst.is_nan() {
                (short(t), None)
            } else {
                (format!("max {worst:.2e} L0"), Some(within(worst, a)))
            }
        }
    }
}
