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
    /// The scenario marks the claim as known not to hold (`infeasible = true`).
    pub infeasible: bool,
}

fn within(v: f64, a: &AcceptanceConfig) -> bool {
    a.min.map_or(true, |m| v >= m) && a.max.map_or(true, |m| v <= m)
}

/// What a claim has seen of the series so far.
#[derive(Debug, Clone, Copy)]
enum Seen {
    /// d of the last sample before the time.
    Before(Option<f64>),
    /// d of the first sample at or after the time.
    After(Option<f64>),
    /// (|t − time|, d) of the sample nearest the time (the first of equals).
    At(Option<(f64, f64)>),
    /// Largest d over the interval.
    Max(f64),
    /// Decided from the derived figures or the controller's report.
    Summary,
}

/// The claims of a run, evaluated sample by sample (constant memory): `observe` every sample in
/// time order, then `checks`.
#[derive(Debug, Clone)]
pub struct Tracker {
    claims: Vec<AcceptanceConfig>,
    seen: Vec<Seen>,
    first: Option<f64>,
    max: f64,
    end: f64,
}

impl Tracker {
    /// A tracker of `claims`.
    pub fn new(claims: Vec<AcceptanceConfig>) -> Self {
        use AcceptanceQuantity as Q;
        let seen = claims
            .iter()
            .map(|a| match a.quantity {
                Q::DistanceBefore => Seen::Before(None),
                Q::DistanceAfter => Seen::After(None),
                Q::DistanceAt => Seen::At(None),
                Q::MaxDistance => Seen::Max(0.0),
                _ => Seen::Summary,
            })
            .collect();
        Self {
            claims,
            seen,
            first: None,
            max: 0.0,
            end: 0.0,
        }
    }

    /// One sample (in time order).
    pub fn observe(&mut self, x: &Sample) {
        self.end = x.time;
        self.first.get_or_insert(x.distance);
        self.max = self.max.max(x.distance);
        for (a, seen) in self.claims.iter().zip(self.seen.iter_mut()) {
            let t = a.time.unwrap_or(0.0);
            match seen {
                Seen::Before(d) => {
                    if x.time < t - 1e-9 {
                        *d = Some(x.distance);
                    }
                }
                Seen::After(d) => {
                    if d.is_none() && x.time >= t - 1e-9 {
                        *d = Some(x.distance);
                    }
                }
                Seen::At(best) => {
                    let gap = (x.time - t).abs();
                    if best.map_or(true, |(g, _)| gap.total_cmp(&g).is_lt()) {
                        *best = Some((gap, x.distance));
                    }
                }
                Seen::Max(m) => {
                    let (from, to) = (a.from.unwrap_or(0.0), a.to.unwrap_or(f64::INFINITY));
                    if x.time >= from - 1e-9 && x.time <= to + 1e-9 {
                        *m = m.max(x.distance);
                    }
                }
                Seen::Summary => {}
            }
        }
    }

    /// Evaluate every claim. `length` is L0 [m], `duration` the planned run length [s].
    pub fn checks(&self, summary: &ControlSummary, length: f64, duration: f64) -> Vec<Check> {
        let end = self.end;
        let reached = |t: f64| self.first.is_some() && end >= t - 1e-9;
        let short = |t: f64| format!("run ends at {end:.3} s, before {t} s");
        self.claims
            .iter()
            .zip(&self.seen)
            .map(|(a, seen)| {
                let (measured, pass) =
                    self.measure(a, seen, summary, length, duration, &reached, &short);
                Check {
                    claim: a.claim.clone(),
                    measured,
                    pass,
                    note: a.note.clone(),
                    infeasible: a.infeasible,
                }
            })
            .collect()
    }

    #[allow(clippy::too_many_arguments)]
    fn measure(
        &self,
        a: &AcceptanceConfig,
        seen: &Seen,
        summary: &ControlSummary,
        length: f64,
        duration: f64,
        reached: &dyn Fn(f64) -> bool,
        short: &dyn Fn(f64) -> String,
    ) -> (String, Option<bool>) {
        use AcceptanceQuantity as Q;
        let t = a.time.unwrap_or(0.0);
        let end = self.end;
        match (a.quantity, *seen) {
            (Q::DistanceBefore, Seen::Before(d)) => match d {
                Some(d) if reached(t) => (format!("{d:.4}"), Some(within(d, a))),
                _ => (short(t), None),
            },
            (Q::DistanceAfter, Seen::After(d)) => match d {
                Some(d) => (format!("{d:.4}"), Some(within(d, a))),
                None => (short(t), None),
            },
            (Q::DistanceAt, Seen::At(best)) => match best {
                Some((_, d)) if reached(t) => (format!("{d:.2e}"), Some(within(d, a))),
                _ => (short(t), None),
            },
            (Q::MaxDistance, Seen::Max(m)) => {
                let to = a.to.unwrap_or(duration);
                if !reached(to) {
                    return (short(to), None);
                }
                (format!("max {m:.4}"), Some(within(m, a)))
            }
            (Q::DistanceRise, _) => {
                let d0 = self.first.unwrap_or(f64::NAN);
                (
                    format!("d(0) = {d0:.4}, max {:.4}", self.max),
                    Some(within(self.max - d0, a)),
                )
            }
            (Q::SettlingTime, _) => {
                let k = a.segment.unwrap_or(0);
                let Some(g) = summary.segments.get(k) else {
                    return (format!("the run has no segment {k}"), None);
                };
                let bound = a.max.unwrap_or(f64::INFINITY);
                // The claim is about the segment up to start + bound (or the next target's
                // start): undecided until the run has got there. The last segment ends with the
                // run, which a shortened run ends early.
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
            (Q::MaxPenetration, _) => {
                let p = summary.max_penetration;
                (format!("{:.3} mm", p * 1e3), Some(within(p, a)))
            }
            (Q::DesignTipError, _) => {
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
            (q, _) if q.is_muscle() => ("a quantity of [muscle_control] runs".into(), None),
            _ => unreachable!("the tracker's state matches its claim"),
        }
    }
}

/// Evaluate every claim on a whole series. `length` is L0 [m], `duration` the planned run
/// length [s].
pub fn evaluate(
    claims: &[AcceptanceConfig],
    series: &[Sample],
    summary: &ControlSummary,
    length: f64,
    duration: f64,
) -> Vec<Check> {
    let mut tracker = Tracker::new(claims.to_vec());
    for x in series {
        tracker.observe(x);
    }
    tracker.checks(summary, length, duration)
}
