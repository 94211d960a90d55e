//! End conditions of a rod (spec §7, generalised): each end, base and tip alike, is free,
//! pinned (node position held, rotation free), clamped (end node and end element frame held) or
//! driven (clamped, following a prescribed `Motion`). The held pose is the rod's initial pose,
//! captured when the system is built. The stepper calls `hold_values` after every kinematic
//! half-step and `hold_rates` after every kick.

use crate::error::{finite_vec, ModelError};
use crate::math::{cross, dot, mat_mul_t, mat_vec, norm, Mat3, Vec3, IDENTITY};

/// Which end of a rod.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Side {
    /// Node 0 and element 0.
    Base,
    /// Node n and element n − 1.
    Tip,
}

impl Side {
    /// The end node of a rod with `n` elements.
    pub fn node(self, n: usize) -> usize {
        match self {
            Side::Base => 0,
            Side::Tip => n,
        }
    }

    /// The end element of a rod with `n` elements.
    pub fn element(self, n: usize) -> usize {
        match self {
            Side::Base => 0,
            Side::Tip => n - 1,
        }
    }

    /// "base" or "tip".
    pub fn name(self) -> &'static str {
        match self {
            Side::Base => "base",
            Side::Tip => "tip",
        }
    }
}

/// How one end of a rod is held.
#[derive(Debug, Clone, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum EndCondition {
    /// Nothing is enforced (zero force and couple: the natural condition).
    #[default]
    Free,
    /// The end node stays at its initial position; the end element turns freely.
    Pinned,
    /// The end node and the end element's frame stay at their initial values (PyElastica's
    /// `OneEndFixedBC`; the paper's clamped base).
    Clamped,
    /// A clamped end whose node and frame follow a prescribed motion from their initial values.
    Driven(Motion),
}

impl EndCondition {
    /// Whether the end node's position is held (pinned, clamped, driven).
    pub fn holds_position(&self) -> bool {
        !matches!(self, EndCondition::Free)
    }

    /// Whether the end element's frame is held (clamped, driven).
    pub fn holds_frame(&self) -> bool {
        matches!(self, EndCondition::Clamped | EndCondition::Driven(_))
    }

    /// The unit direction a driven end slides along, if it does.
    pub fn slide_axis(&self) -> Option<Vec3> {
        match self {
            EndCondition::Driven(m) => m.slide_axis(),
            _ => None,
        }
    }

    /// Whether the end node is kicked by the forces on it (free, or sliding along a direction).
    pub fn node_moves(&self) -> bool {
        !self.holds_position() || self.slide_axis().is_some()
    }

    /// "free", "pinned", "clamped" or "driven".
    pub fn name(&self) -> &'static str {
        match self {
            EndCondition::Free => "free",
            EndCondition::Pinned => "pinned",
            EndCondition::Clamped => "clamped",
            EndCondition::Driven(_) => "driven",
        }
    }
}

/// A prescribed motion of a driven end relative to its initial pose: at each of `times` the end
/// node has moved by `displacement` and the end frame has turned by the rotation vector
/// `rotation` (axis × angle [rad], lab frame, about the end node), both interpolated linearly
/// between samples and held after the last (cosseratbench's `Motion`). Angles beyond π are
/// allowed (a rotation vector of 10 rad about d3 is more than a turn and a half of twist).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Motion {
    /// Sample times [s], starting at 0, strictly increasing, at least two.
    pub times: Vec<f64>,
    /// Displacement of the end node at each time [m], lab frame; zero at time 0.
    pub displacement: Vec<Vec3>,
    /// Rotation vector of the end frame at each time [rad], lab frame; zero at time 0.
    pub rotation: Vec<Vec3>,
    /// A direction along which the end node is not held but slides freely under the loads on
    /// it (cosseratbench's `slides_along`); the displacement's component along it is ignored.
    /// Normalised by `validate`.
    #[cfg_attr(feature = "serde", serde(default))]
    pub slides_along: Option<Vec3>,
}

impl Motion {
    /// A motion turning the end at constant angular velocity `rate` [rad/s] (lab) until `until`.
    pub fn constant_rotation(rate: Vec3, until: f64) -> Self {
        Self {
            times: vec![0.0, until],
            displacement: vec![[0.0; 3]; 2],
            rotation: vec![
                [0.0; 3],
                [rate[0] * until, rate[1] * until, rate[2] * until],
            ],
            slides_along: None,
        }
    }

    /// The unit slide direction, if the end slides.
    pub fn slide_axis(&self) -> Option<Vec3> {
        self.slides_along.map(|a| {
            let l = norm(a);
            [a[0] / l, a[1] / l, a[2] / l]
        })
    }

    /// Check the samples; errors name the field.
    pub fn validate(&self) -> Result<(), ModelError> {
        let n = self.times.len();
        if n < 2 {
            return Err(ModelError::CountOutOfRange {
                field: "motion.times",
                value: n,
                range: "[2, inf) samples",
            });
        }
        for (field, len) in [
            ("motion.displacement", self.displacement.len()),
            ("motion.rotation", self.rotation.len()),
        ] {
            if len != n {
                return Err(ModelError::BadLength {
                    field,
                    len,
                    expected: n,
                });
            }
        }
        if self.times[0] != 0.0 {
            return Err(ModelError::OutOfRange {
                field: "motion.times[0]",
                value: self.times[0],
                range: "{0}: a motion starts at t = 0",
            });
        }
        for w in self.times.windows(2) {
            if !(w[1].is_finite() && w[1] > w[0]) {
                return Err(ModelError::OutOfRange {
                    field: "motion.times",
                    value: w[1],
                    range: "strictly increasing, finite",
                });
            }
        }
        for v in self.displacement.iter().chain(&self.rotation) {
            finite_vec("motion", *v)?;
        }
        if let Some(a) = self.slides_along {
            finite_vec("motion.slides_along", a)?;
            if norm(a) == 0.0 {
                return Err(ModelError::BadVector {
                    field: "motion.slides_along",
                    value: a,
                    reason: "the slide direction must be a non-zero vector",
                });
            }
        }
        if self.displacement[0] != [0.0; 3] || self.rotation[0] != [0.0; 3] {
            return Err(ModelError::BadVector {
                field: "motion",
                value: if self.displacement[0] != [0.0; 3] {
                    self.displacement[0]
                } else {
                    self.rotation[0]
                },
                reason: "displacement and rotation must be zero at t = 0 (a motion starts where the end is)",
            });
        }
        Ok(())
    }

    /// Interval index and fraction in [0, 1] of time t (held after the last sample).
    fn segment(&self, t: f64) -> (usize, f64, bool) {
        let n = self.times.len();
        if t >= self.times[n - 1] {
            return (n - 2, 1.0, true);
        }
        if t <= 0.0 {
            return (0, 0.0, false);
        }
        let i = self.times.partition_point(|&s| s <= t) - 1;
        let f = (t - self.times[i]) / (self.times[i + 1] - self.times[i]);
        (i, f, false)
    }

    /// Displacement [m] and rotation vector [rad] at time t.
    pub fn at(&self, t: f64) -> (Vec3, Vec3) {
        let (i, f, _) = self.segment(t);
        let lerp = |a: Vec3, b: Vec3| {
            [
                a[0] + f * (b[0] - a[0]),
                a[1] + f * (b[1] - a[1]),
                a[2] + f * (b[2] - a[2]),
            ]
        };
        (
            lerp(self.displacement[i], self.displacement[i + 1]),
            lerp(self.rotation[i], self.rotation[i + 1]),
        )
    }

    /// Velocity [m/s] and angular velocity [rad/s] (lab) of the end at time t: zero after the
    /// last sample; the angular velocity of exp([r(t)]×) is J_l(r) ṙ with J_l the left Jacobian.
    pub fn rates(&self, t: f64) -> (Vec3, Vec3) {
        let (i, _, done) = self.segment(t);
        if done || t < 0.0 {
            return ([0.0; 3], [0.0; 3]);
        }
        let h = self.times[i + 1] - self.times[i];
        let d = |a: Vec3, b: Vec3| [(b[0] - a[0]) / h, (b[1] - a[1]) / h, (b[2] - a[2]) / h];
        let v = d(self.displacement[i], self.displacement[i + 1]);
        let rdot = d(self.rotation[i], self.rotation[i + 1]);
        let (_, r) = self.at(t);
        (v, left_jacobian(r, rdot))
    }
}

/// exp([r]×) with libm (rotation vectors of any size).
pub fn rotation_matrix(r: Vec3) -> Mat3 {
    let t2 = dot(r, r);
    let (s, c) = if t2 < 1e-8 {
        (1.0 - t2 / 6.0, 0.5 - t2 / 24.0)
    } else {
        let t = t2.sqrt();
        (t.sin() / t, (1.0 - t.cos()) / t2)
    };
    let k = [[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]];
    let mut m = IDENTITY;
    for a in 0..3 {
        for b in 0..3 {
            let k2 = k[a][0] * k[0][b] + k[a][1] * k[1][b] + k[a][2] * k[2][b];
            m[a][b] += s * k[a][b] + c * k2;
        }
    }
    m
}

/// J_l(r) u = u + (1 − cos θ)/θ² r × u + (θ − sin θ)/θ³ r × (r × u).
fn left_jacobian(r: Vec3, u: Vec3) -> Vec3 {
    let t = norm(r);
    let (a, b) = if t < 1e-4 {
        (0.5 - t * t / 24.0, 1.0 / 6.0 - t * t / 120.0)
    } else {
        ((1.0 - t.cos()) / (t * t), (t - t.sin()) / (t * t * t))
    };
    let ru = cross(r, u);
    let rru = cross(r, ru);
    [
        u[0] + a * ru[0] + b * rru[0],
        u[1] + a * ru[1] + b * rru[1],
        u[2] + a * ru[2] + b * rru[2],
    ]
}

/// One end of one rod with its held (or starting) pose, as the stepper uses it.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct End {
    /// The condition.
    pub condition: EndCondition,
    /// Initial position of the end node [m] (held, or the start of a motion).
    pub position: Vec3,
    /// Initial frame of the end element (held, or the start of a motion).
    pub frame: Mat3,
    /// Initial frame at the end node itself: `frame` turned back over the half element between
    /// the element's centre and the node by the curvature of the nearest Voronoi point. The
    /// second-order clamp's ghost frame Q_c (held, or the start of a motion); equal to `frame`
    /// for a rod that starts straight near this end.
    pub node_frame: Mat3,
}

impl End {
    /// The end at its initial pose, with the end node's frame equal to the end element's.
    pub fn new(condition: EndCondition, position: Vec3, frame: Mat3) -> Self {
        Self {
            condition,
            position,
            frame,
            node_frame: frame,
        }
    }

    /// The end at the initial pose of `side` of a rod with `model` and `state`: the end node's
    /// position, the end element's frame, and the frame at the node extrapolated from the end
    /// element's over half its rest length with the initial curvature κ of the nearest Voronoi
    /// point held constant (second-order accurate in the element length; a rod of one element
    /// has no Voronoi point and keeps the element's frame). Why: the ghost spring of
    /// `clamp_order = 2` sits between the clamp and the end element's centre, so the clamp must
    /// hold the frame the rod has at the node. Holding the element's frame instead tilts the
    /// clamp by κ l̂/2: a clamp that bends a rod started curved, or one started in its curved rest
    /// shape out of equilibrium.
    pub fn at_rod_end(
        condition: EndCondition,
        side: Side,
        model: &crate::model::RodModel,
        state: &crate::state::RodState,
    ) -> Self {
        let n = model.n_elements;
        let j = side.element(n);
        let frame = state.director[j];
        let mut end = Self::new(condition, state.position[side.node(n)], frame);
        if n >= 2 {
            let k = match side {
                Side::Base => 0,
                Side::Tip => n - 2,
            };
            // κ_k = −Log(Q_{k+1} Q_kᵀ)/D̂_k; the ghost gives −Log(Q_0 Q_cᵀ)/(l̂_0/2) at the base
            // and −Log(Q_c Q_{n−1}ᵀ)/(l̂_{n−1}/2) at the tip, equal to κ_k when
            // Q_c = exp(−f Θ) Q_0 (base) or exp(f Θ) Q_{n−1} (tip), Θ = Log(Q_{k+1} Q_kᵀ).
            let (theta, _) = crate::math::log_relative(&state.director[k + 1], &state.director[k]);
            let f = 0.5 * model.rest_length[j] * model.inv_rest_voronoi[k];
            let sign = match side {
                Side::Base => -f,
                Side::Tip => f,
            };
            let turn = rotation_matrix([sign * theta[0], sign * theta[1], sign * theta[2]]);
            end.node_frame = crate::math::mat_mul(&turn, &frame);
        }
        end
    }

    /// The frame the end node must have at time t (the second-order clamp's ghost frame): the
    /// initial `node_frame`, turned by the motion for a driven end.
    #[inline]
    pub fn node_frame_at(&self, t: f64) -> Mat3 {
        match &self.condition {
            EndCondition::Driven(m) => {
                let (_, r) = m.at(t);
                mat_mul_t(&self.node_frame, &rotation_matrix(r))
            }
            _ => self.node_frame,
        }
    }

    /// Position [m] and frame the end must have at time t.
    #[inline]
    pub fn pose(&self, t: f64) -> (Vec3, Mat3) {
        match &self.condition {
            EndCondition::Driven(m) => {
                let (d, r) = m.at(t);
                let x = [
                    self.position[0] + d[0],
                    self.position[1] + d[1],
                    self.position[2] + d[2],
                ];
                // Directors turn as d_m → R d_m, i.e. Q → Q Rᵀ.
                (x, mat_mul_t(&self.frame, &rotation_matrix(r)))
            }
            _ => (self.position, self.frame),
        }
    }

    /// Velocity [m/s] and material angular velocity [rad/s] of the end at time t, with its
    /// frame `q` at that time.
    #[inline]
    pub fn rates(&self, t: f64, q: &Mat3) -> (Vec3, Vec3) {
        match &self.condition {
            EndCondition::Driven(m) => {
                let (v, w) = m.rates(t);
                (v, mat_vec(q, w))
            }
            _ => ([0.0; 3], [0.0; 3]),
        }
    }
}
