//! Time schedules: a dimensionless factor f(t) that scales a load or a rest-strain change
//! (constant, linear ramp, step, piecewise-linear). Evaluated by the stepper at the mid-step time
//! of each force evaluation; pure data, no callbacks.

use crate::error::ModelError;

/// A factor of simulated time t [s].
#[derive(Debug, Clone, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Schedule {
    /// f = 1.
    #[default]
    Constant,
    /// f = min(1, t / duration) for t ≥ 0 (duration > 0 s).
    Ramp {
        /// Ramp duration [s], > 0.
        duration: f64,
    },
    /// f = 0 before `time`, 1 from `time` on [s].
    Step {
        /// Switch-on time [s].
        time: f64,
    },
    /// f interpolated linearly through (`times`, `values`), held constant outside.
    PiecewiseLinear {
        /// Sample times [s], strictly increasing, at least one.
        times: Vec<f64>,
        /// Factor at each time.
        values: Vec<f64>,
    },
}

impl Schedule {
    /// The factor at time t.
    #[inline]
    pub fn factor(&self, t: f64) -> f64 {
        match self {
            Schedule::Constant => 1.0,
            // Bit-compatible with the earlier `ramp_time` loads: (t / T) clamped to [0, 1].
            Schedule::Ramp { duration } => (t / duration).clamp(0.0, 1.0),
            Schedule::Step { time } => {
                if t >= *time {
                    1.0
                } else {
                    0.0
                }
            }
            Schedule::PiecewiseLinear { times, values } => {
                let n = times.len();
                if t <= times[0] {
                    return values[0];
                }
                if t >= times[n - 1] {
                    return values[n - 1];
                }
                let i = times.partition_point(|&s| s <= t) - 1;
                let f = (t - times[i]) / (times[i + 1] - times[i]);
                values[i] + f * (values[i + 1] - values[i])
            }
        }
    }

    /// Whether the factor is 1 at every time (the stepper skips evaluating it).
    pub fn is_constant(&self) -> bool {
        matches!(self, Schedule::Constant)
    }

    /// Check the parameters; errors name the field.
    pub fn validate(&self) -> Result<(), ModelError> {
        match self {
            Schedule::Constant => Ok(()),
            Schedule::Ramp { duration } => {
                if duration.is_finite() && *duration > 0.0 {
                    Ok(())
                } else {
                    Err(ModelError::OutOfRange {
                        field: "schedule.duration",
                        value: *duration,
                        range: "(0, inf), finite",
                    })
                }
            }
            Schedule::Step { time } => {
                if time.is_finite() {
                    Ok(())
                } else {
                    Err(ModelError::OutOfRange {
                        field: "schedule.time",
                        value: *time,
                        range: "finite",
                    })
                }
            }
            Schedule::PiecewiseLinear { times, values } => {
                if times.is_empty() {
                    return Err(ModelError::CountOutOfRange {
                        field: "schedule.times",
                        value: 0,
                        range: "[1, inf) samples",
                    });
                }
                if values.len() != times.len() {
                    return Err(ModelError::BadLength {
                        field: "schedule.values",
                        len: values.len(),
                        expected: times.len(),
                    });
                }
                for v in values {
                    if !v.is_finite() {
                        return Err(ModelError::OutOfRange {
                            field: "schedule.values",
                            value: *v,
                            range: "finite",
                        });
                    }
                }
                if !times[0].is_finite() {
                    return Err(ModelError::OutOfRange {
                        field: "schedule.times",
                        value: times[0],
                        range: "finite, strictly increasing",
                    });
                }
                for w in times.windows(2) {
                    if !(w[1].is_finite() && w[1] > w[0]) {
                        return Err(ModelError::OutOfRange {
                            field: "schedule.times",
                            value: w[1],
                            range: "finite, strictly increasing",
                        });
                    }
                }
                Ok(())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn factors() {
        assert_eq!(Schedule::Constant.factor(3.0), 1.0);
        let r = Schedule::Ramp { duration: 2.0 };
        assert_eq!(r.factor(-1.0), 0.0);
        assert_eq!(r.factor(1.0), 0.5);
        assert_eq!(r.factor(5.0), 1.0);
        let s = Schedule::Step { time: 1.0 };
        assert_eq!((s.factor(0.999), s.factor(1.0)), (0.0, 1.0));
        let p = Schedule::PiecewiseLinear {
            times: vec![0.0, 1.0, 3.0],
            values: vec![0.0, 2.0, -2.0],
        };
        assert_eq!(p.factor(-1.0), 0.0);
        assert_eq!(p.factor(0.5), 1.0);
        assert_eq!(p.factor(2.0), 0.0);
        assert_eq!(p.factor(9.0), -2.0);
        assert!(p.validate().is_ok());
        assert!(Schedule::Ramp { duration: 0.0 }.validate().is_err());
    }
}
