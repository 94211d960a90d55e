//! What the arm should do, as cost terms on the centreline (spec §2.3): a tip target (spring of
//! stiffness μ_tip) or a fixed tip force (statics), sphere obstacles as penalised augmented states
//! (weight ξ), and a grasp running cost μ_grasp(s)·Φ_grasp on the smoothed surface gap to a
//! sphere. Owns validation of the task (§3.4); evaluating the terms is `statics`' job.

use crate::error::TaskError;
use crate::statics::Statics;
use octoarm_physics::math::{norm, sub};
use octoarm_physics::Vec3;

/// The terminal (tip) term of the cost.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum TipTerm {
    /// No tip term.
    #[default]
    None,
    /// Spring of stiffness `weight` = μ_tip [N/m] from the tip node to `position` [m]:
    /// cost ½ μ_tip |r_N − r*|².
    Target {
        /// Target r* [m], lab frame.
        position: Vec3,
        /// μ_tip [N/m], ≥ 0 (paper: 1e3).
        weight: f64,
    },
    /// Statics-only mode: a fixed force F [N] (lab) on the tip, cost −F·r_N; with no other term
    /// the solution is the rod's static shape under that force.
    Force(Vec3),
}

/// A sphere the arm must stay out of (spec §2.3): cost ξ Σ_i ω_i max(Ψ_i, 0) with
/// Ψ_i = ((φ + φ(s_i))/2)² − |p − r_i|².
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Obstacle {
    /// Centre p [m], lab frame.
    pub center: Vec3,
    /// Diameter φ [m], > 0.
    pub diameter: f64,
    /// Penalty weight ξ [N/m²], ≥ 0 (paper: 1e5).
    pub weight: f64,
}

/// The grasp weight μ_grasp(s) along the arm [N/m].
#[derive(Debug, Clone, PartialEq)]
pub enum GraspWeight {
    /// `weight` on the closed arc-length interval [from, to] [m], zero elsewhere; the paper's is
    /// μ_tip on [0.4 L0, L0].
    Interval {
        /// Weight [N/m], ≥ 0.
        weight: f64,
        /// Start of the interval (rest arc length) [m].
        from: f64,
        /// End of the interval [m].
        to: f64,
    },
    /// One weight per node [N/m], n + 1 entries, each ≥ 0 (node 0 carries no cost).
    PerNode(Vec<f64>),
}

/// Grasp running cost: pull the arm's surface onto a sphere (spec §2.3),
/// Φ = √(ζ² + ε²) − ε with the surface gap ζ_i = |r_i − p| − (R + ρ_i).
#[derive(Debug, Clone, PartialEq)]
pub struct Grasp {
    /// Centre p_g of the object [m].
    pub center: Vec3,
    /// Radius R_g of the object [m], > 0.
    pub radius: f64,
    /// μ_grasp(s).
    pub weight: GraspWeight,
    /// Smoothing ε [m], ≥ 0; default 1 mm (0 is the paper's plain distance).
    pub smoothing: f64,
}

impl Grasp {
    /// The paper's grasp of a sphere: μ_grasp = `weight` on [0.4 L0, L0], ε = 1 mm.
    pub fn paper(center: Vec3, radius: f64, weight: f64, arm_length: f64) -> Self {
        Self {
            center,
            radius,
            weight: GraspWeight::Interval {
                weight,
                from: 0.4 * arm_length,
                to: arm_length,
            },
            smoothing: 1.0e-3,
        }
    }

    /// μ_grasp at node i with rest arc length s [m] of an arm of length `length`.
    #[inline]
    pub fn weight_at(&self, i: usize, s: f64, length: f64) -> f64 {
        match &self.weight {
            // The interval is closed; allow for round-off in the accumulated arc length.
            GraspWeight::Interval { weight, from, to } => {
                let tol = 1e-9 * length;
                if s >= from - tol && s <= to + tol {
                    *weight
                } else {
                    0.0
                }
            }
            GraspWeight::PerNode(w) => w[i],
        }
    }
}

/// A task: any combination of a tip term, obstacles and a grasp. `Task::default()` is empty
/// (the solution is the rest shape).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Task {
    /// Tip term.
    pub tip: TipTerm,
    /// Sphere obstacles.
    pub obstacles: Vec<Obstacle>,
    /// Grasp running cost (the grasped sphere should also be listed as an obstacle).
    pub grasp: Option<Grasp>,
}

impl Task {
    /// Reach `target` [m] with tip weight μ_tip [N/m].
    pub fn reach(target: Vec3, mu_tip: f64) -> Self {
        Self {
            tip: TipTerm::Target {
                position: target,
                weight: mu_tip,
            },
            ..Self::default()
        }
    }

    /// Statics only: the static shape under a tip force [N] (lab frame).
    pub fn tip_force(force: Vec3) -> Self {
        Self {
            tip: TipTerm::Force(force),
            ..Self::default()
        }
    }

    /// Add a sphere obstacle (centre [m], diameter [m], weight ξ [N/m²]).
    pub fn with_obstacle(mut self, center: Vec3, diameter: f64, xi: f64) -> Self {
        self.obstacles.push(Obstacle {
            center,
            diameter,
            weight: xi,
        });
        self
    }

    /// Add a grasp; the grasped sphere is also added as an obstacle with weight ξ (spec §2.3).
    pub fn with_grasp(mut self, grasp: Grasp, xi: f64) -> Self {
        self.obstacles.push(Obstacle {
            center: grasp.center,
            diameter: 2.0 * grasp.radius,
            weight: xi,
        });
        self.grasp = Some(grasp);
        self
    }

    /// Move the tip target (keeps the weight); no effect for other tip terms.
    pub fn set_target(&mut self, target: Vec3) {
        if let TipTerm::Target { position, .. } = &mut self.tip {
            *position = target;
        }
    }

    /// The tip target, if any.
    pub fn target(&self) -> Option<Vec3> {
        match self.tip {
            TipTerm::Target { position, .. } => Some(position),
            _ => None,
        }
    }

    /// A key that changes when terms are added or removed (not when they move); the online
    /// solver drops its quasi-Newton memory when it changes.
    pub fn structure(&self) -> (u8, usize, bool) {
        let tip = match self.tip {
            TipTerm::None => 0,
            TipTerm::Target { .. } => 1,
            TipTerm::Force(_) => 2,
        };
        (tip, self.obstacles.len(), self.grasp.is_some())
    }

    /// Check the task against the arm (spec §3.4): weights ≥ 0 and finite, diameters > 0,
    /// planar points in the plane, no obstacle containing the base, target within 1.5 L0.
    pub fn validate(&self, statics: &Statics) -> Result<(), TaskError> {
        let length = statics.length();
        let base = statics.base_position();
        let planar = statics.is_planar();
        let check_point = |field: String, p: Vec3| -> Result<(), TaskError> {
            for (c, v) in p.iter().enumerate() {
                if !v.is_finite() {
                    return Err(TaskError::OutOfRange {
                        field: format!("{field}[{c}]"),
                        value: *v,
                        range: "finite",
                    });
                }
            }
            if planar && (p[2] - base[2]).abs() > 1e-12 {
                return Err(TaskError::OffPlane {
                    field,
                    value: p,
                    plane_z: base[2],
                });
            }
            Ok(())
        };
        let non_negative = |field: String, v: f64| -> Result<(), TaskError> {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(TaskError::OutOfRange {
                    field,
                    value: v,
                    range: "[0, inf)",
                })
            }
        };
        let positive = |field: String, v: f64| -> Result<(), TaskError> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(TaskError::OutOfRange {
                    field,
                    value: v,
                    range: "(0, inf)",
                })
            }
        };
        match self.tip {
            TipTerm::None => {}
            TipTerm::Target { position, weight } => {
                non_negative("tip.weight (mu_tip)".into(), weight)?;
                check_point("tip.position".into(), position)?;
                let distance = norm(sub(position, base));
                if distance > 1.5 * length {
                    return Err(TaskError::TargetTooFar {
                        value: position,
                        distance,
                        limit: 1.5 * length,
                    });
                }
            }
            TipTerm::Force(f) => {
                for (c, v) in f.iter().enumerate() {
                    if !v.is_finite() {
                        return Err(TaskError::OutOfRange {
                            field: format!("tip.force[{c}]"),
                            value: *v,
                            range: "finite",
                        });
                    }
                }
                if planar && f[2] != 0.0 {
                    return Err(TaskError::OutOfRange {
                        field: "tip.force[2]".into(),
                        value: f[2],
                        range: "0 (planar)",
                    });
                }
            }
        }
        let base_diameter = 2.0 * statics.node_radius()[0];
        for (index, o) in self.obstacles.iter().enumerate() {
            check_point(format!("obstacles[{index}].center"), o.center)?;
            positive(format!("obstacles[{index}].diameter"), o.diameter)?;
            non_negative(format!("obstacles[{index}].weight (xi)"), o.weight)?;
            let distance = norm(sub(o.center, base));
            let limit = 0.5 * (o.diameter + base_diameter);
            if distance < limit {
                return Err(TaskError::ObstacleContainsBase {
                    index,
                    center: o.center,
                    diameter: o.diameter,
                    distance,
                    limit,
                });
            }
        }
        if let Some(g) = &self.grasp {
            check_point("grasp.center".into(), g.center)?;
            positive("grasp.radius".into(), g.radius)?;
            non_negative("grasp.smoothing (epsilon)".into(), g.smoothing)?;
            match &g.weight {
                GraspWeight::Interval { weight, from, to } => {
                    non_negative("grasp.weight (mu_grasp)".into(), *weight)?;
                    for (f, v) in [("grasp.weight.from", *from), ("grasp.weight.to", *to)] {
                        if !v.is_finite() {
                            return Err(TaskError::OutOfRange {
                                field: f.into(),
                                value: v,
                                range: "finite",
                            });
                        }
                    }
                }
                GraspWeight::PerNode(w) => {
                    if w.len() != statics.n_elements() + 1 {
                        return Err(TaskError::BadLength {
                            len: w.len(),
                            expected: statics.n_elements() + 1,
                        });
                    }
                    for (i, v) in w.iter().enumerate() {
                        non_negative(format!("grasp.weight[{i}] (mu_grasp)"), *v)?;
                    }
                }
            }
        }
        Ok(())
    }
}
