//! Contact of rods with rigid obstacles (spec §10 and docs/physics.md "Contact"): spheres,
//! planes and finite cylinders (capsules), each fixed or moving with a constant velocity, by a
//! penalty force through the centreline — closest point on each element, penetration against the
//! current radius r̂_j/√e_j, stiffness k_j = β E Â_j / l̂_j, damping 2ζ√(k_j m̄_j), never
//! adhesive — and Coulomb friction regularised by a capped viscous law (static and kinetic,
//! isotropic or anisotropic forward/backward/lateral coefficients). Rod–rod and self contact
//! live in `rod_contact.rs`; both share `Friction` and `ContactParams`.

use crate::error::{finite_vec, non_negative, positive, ModelError};
use crate::loads::ExternalLoads;
use crate::math::{cross, dot, norm, scale, sub, Vec3};
use crate::model::RodModel;
use crate::state::RodAccess;

/// Coulomb friction coefficients, static and kinetic, each for sliding forward (along the
/// element's tangent, base → tip), backward and laterally (across the rod in the contact plane),
/// as PyElastica's anisotropic frictional plane. Isotropic friction has three equal entries.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Friction {
    /// Static coefficients μ_s [forward, backward, lateral], ≥ 0.
    pub static_mu: [f64; 3],
    /// Kinetic coefficients μ_k [forward, backward, lateral], 0 ≤ μ_k ≤ μ_s.
    pub kinetic_mu: [f64; 3],
}

impl Friction {
    /// No friction.
    pub const NONE: Friction = Friction {
        static_mu: [0.0; 3],
        kinetic_mu: [0.0; 3],
    };

    /// Isotropic Coulomb friction with one coefficient, static = kinetic = μ.
    pub fn coulomb(mu: f64) -> Self {
        Self::isotropic(mu, mu)
    }

    /// Isotropic friction with static μ_s and kinetic μ_k.
    pub fn isotropic(static_mu: f64, kinetic_mu: f64) -> Self {
        Self {
            static_mu: [static_mu; 3],
            kinetic_mu: [kinetic_mu; 3],
        }
    }

    /// Whether every coefficient is zero (the frictionless path, arithmetic unchanged).
    pub fn is_none(&self) -> bool {
        self.static_mu
            .iter()
            .chain(&self.kinetic_mu)
            .all(|&m| m == 0.0)
    }

    /// Check every coefficient is finite and ≥ 0, and μ_k ≤ μ_s.
    pub fn validate(&self) -> Result<(), ModelError> {
        for c in 0..3 {
            non_negative("friction.static", self.static_mu[c])?;
            non_negative("friction.kinetic", self.kinetic_mu[c])?;
            if self.kinetic_mu[c] > self.static_mu[c] {
                return Err(ModelError::OutOfRange {
                    field: "friction.kinetic",
                    value: self.kinetic_mu[c],
                    range: "[0, friction.static] (kinetic friction cannot exceed static)",
                });
            }
        }
        Ok(())
    }
}

/// A rigid sphere, fixed or moving with a prescribed velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Sphere {
    /// Centre [m] at t = 0.
    pub center: Vec3,
    /// Radius R [m], > 0.
    pub radius: f64,
    /// Constant velocity of the centre [m/s]; zero for a fixed obstacle.
    pub velocity: Vec3,
    /// Friction between the sphere and the rods (default none).
    #[cfg_attr(feature = "serde", serde(default))]
    pub friction: Friction,
}

impl Sphere {
    /// A fixed frictionless sphere.
    pub fn fixed(center: Vec3, radius: f64) -> Self {
        Self {
            center,
            radius,
            velocity: [0.0; 3],
            friction: Friction::NONE,
        }
    }

    /// Centre at time t.
    pub fn center_at(&self, t: f64) -> Vec3 {
        [
            self.center[0] + t * self.velocity[0],
            self.center[1] + t * self.velocity[1],
            self.center[2] + t * self.velocity[2],
        ]
    }

    /// Check centre, radius, velocity and friction.
    pub fn validate(&self) -> Result<(), ModelError> {
        finite_vec("obstacle.center", self.center)?;
        positive("obstacle.radius", self.radius)?;
        finite_vec("obstacle.velocity", self.velocity)?;
        self.friction.validate()
    }
}

/// A rigid, unbounded plane (a floor or a wall); rods stay on the side `normal` points to.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Plane {
    /// Any point on the plane [m].
    pub point: Vec3,
    /// Unit normal, towards the rods' side (normalised by `new` and on adding).
    pub normal: Vec3,
    /// Friction between the plane and the rods.
    pub friction: Friction,
}

impl Plane {
    /// A plane through `point` with normal `normal` (any length > 0) and `friction`.
    pub fn new(point: Vec3, normal: Vec3, friction: Friction) -> Self {
        Self {
            point,
            normal: normalised(normal),
            friction,
        }
    }

    /// Check the point, a non-zero finite normal (normalised here) and the friction.
    pub fn validate(&mut self) -> Result<(), ModelError> {
        finite_vec("plane.point", self.point)?;
        self.normal = unit_vector(
            "plane.normal",
            self.normal,
            "the normal must be a non-zero vector",
        )?;
        self.friction.validate()
    }
}

/// `v` scaled to unit length, or `v` itself when it is zero (validation refuses it later).
fn normalised(v: Vec3) -> Vec3 {
    let l = norm(v);
    if l > 0.0 {
        scale(1.0 / l, v)
    } else {
        v
    }
}

/// `v` (field `field`) checked finite and non-zero, and scaled to unit length.
fn unit_vector(field: &'static str, v: Vec3, reason: &'static str) -> Result<Vec3, ModelError> {
    finite_vec(field, v)?;
    let l = norm(v);
    if !(l > 0.0 && l.is_finite()) {
        return Err(ModelError::BadVector {
            field,
            value: v,
            reason,
        });
    }
    Ok(scale(1.0 / l, v))
}

/// A rigid finite cylinder with hemispherical caps (a capsule): every point within `radius` of
/// the axis segment of length `length` centred on `center`. Fixed, or moving with a constant
/// velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Cylinder {
    /// Centre of the axis segment at t = 0 [m].
    pub center: Vec3,
    /// Unit axis direction (normalised on adding).
    pub axis: Vec3,
    /// Radius [m], > 0.
    pub radius: f64,
    /// Length of the axis segment [m], ≥ 0 (0: a sphere).
    pub length: f64,
    /// Constant velocity [m/s]; zero for a fixed obstacle.
    pub velocity: Vec3,
    /// Friction between the cylinder and the rods.
    pub friction: Friction,
}

impl Cylinder {
    /// A fixed cylinder.
    pub fn fixed(center: Vec3, axis: Vec3, radius: f64, length: f64, friction: Friction) -> Self {
        Self {
            center,
            axis: normalised(axis),
            radius,
            length,
            velocity: [0.0; 3],
            friction,
        }
    }

    /// Check the geometry (normalising the axis), the velocity and the friction.
    pub fn validate(&mut self) -> Result<(), ModelError> {
        finite_vec("cylinder.center", self.center)?;
        self.axis = unit_vector(
            "cylinder.axis",
            self.axis,
            "the axis must be a non-zero vector",
        )?;
        positive("cylinder.radius", self.radius)?;
        non_negative("cylinder.length", self.length)?;
        finite_vec("cylinder.velocity", self.velocity)?;
        self.friction.validate()
    }

    /// End points of the axis segment at time t.
    pub fn axis_at(&self, t: f64) -> (Vec3, Vec3) {
        let c = [
            self.center[0] + t * self.velocity[0],
            self.center[1] + t * self.velocity[1],
            self.center[2] + t * self.velocity[2],
        ];
        let h = 0.5 * self.length;
        (
            [
                c[0] - h * self.axis[0],
                c[1] - h * self.axis[1],
                c[2] - h * self.axis[2],
            ],
            [
                c[0] + h * self.axis[0],
                c[1] + h * self.axis[1],
                c[2] + h * self.axis[2],
            ],
        )
    }
}

/// Penalty and friction parameters of contact (obstacles and rods):
/// k_j = β E Â_j / l̂_j, c_j = 2 ζ √(k_j m̄_j); friction: a stick spring κ k_j (obstacles) and
/// a viscosity η m̄_j / Δt, capped by Coulomb's μ F_n.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct ContactParams {
    /// Stiffness factor β (default 1; up to ~20 for the arm at dt = 1e-5 s).
    pub beta: f64,
    /// Damping ratio ζ (default 0.5).
    pub zeta: f64,
    /// Friction regularisation η in (0, 1] (default 0.5): the sticking viscosity is η m̄ / Δt,
    /// so a sticking contact creeps at about a Δt / η under a tangential acceleration a.
    #[cfg_attr(feature = "serde", serde(default = "default_eta"))]
    pub friction_eta: f64,
    /// Stick-spring stiffness of obstacle friction as a fraction of the normal penalty
    /// stiffness, in (0, 1] (default 0.5).
    #[cfg_attr(feature = "serde", serde(default = "default_stick"))]
    pub stick_stiffness: f64,
    /// Slip speed of rod–rod friction [m/s] (default 1e-3): below it the static coefficients
    /// apply, above the kinetic ones.
    #[cfg_attr(feature = "serde", serde(default = "default_slip"))]
    pub slip_velocity: f64,
    /// Whether different rods touch each other (default false).
    #[cfg_attr(feature = "serde", serde(default))]
    pub rods: bool,
    /// Whether a rod touches itself (default false).
    #[cfg_attr(feature = "serde", serde(default))]
    pub self_contact: bool,
    /// Friction between rods and within a rod (default none).
    #[cfg_attr(feature = "serde", serde(default))]
    pub rod_friction: Friction,
    /// The centreline rod–rod contact sees (default the polyline of the nodes).
    #[cfg_attr(feature = "serde", serde(default))]
    pub rod_geometry: RodGeometry,
}

/// The centreline that rod–rod and self contact measure gaps on (docs/physics.md "Rod–rod and
/// self contact").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
pub enum RodGeometry {
    /// Straight segments between nodes (PyElastica's geometry). A point contact in the middle
    /// of an element is a saddle there: a rope pressed mid-element slides towards a node.
    #[default]
    Polyline,
    /// The uniform cubic B-spline with the nodes as control points (C², it cuts a bent rope's
    /// corners by ≈ l²κ/6): contact carried by it is nearly independent of where along an
    /// element it acts, so a rope pressed mid-element stays there.
    Smooth,
}

impl RodGeometry {
    /// The geometry named `name` ("polyline" or "smooth").
    pub fn parse(name: &str) -> Option<RodGeometry> {
        match name {
            "polyline" => Some(RodGeometry::Polyline),
            "smooth" => Some(RodGeometry::Smooth),
            _ => None,
        }
    }

    /// Its name in scenarios and Python.
    pub fn name(self) -> &'static str {
        match self {
            RodGeometry::Polyline => "polyline",
            RodGeometry::Smooth => "smooth",
        }
    }
}

fn default_eta() -> f64 {
    0.5
}

fn default_stick() -> f64 {
    0.5
}

fn default_slip() -> f64 {
    1e-3
}

impl Default for ContactParams {
    fn default() -> Self {
        Self {
            beta: 1.0,
            zeta: 0.5,
            friction_eta: default_eta(),
            stick_stiffness: default_stick(),
            slip_velocity: default_slip(),
            rods: false,
            self_contact: false,
            rod_friction: Friction::NONE,
            rod_geometry: RodGeometry::Polyline,
        }
    }
}

impl ContactParams {
    /// Check β > 0, ζ ≥ 0, 0 < η ≤ 1, slip speed > 0 and the rod friction.
    pub fn validate(&self) -> Result<(), ModelError> {
        positive("contact.beta", self.beta)?;
        non_negative("contact.zeta", self.zeta)?;
        positive("contact.friction_eta", self.friction_eta)?;
        if self.friction_eta > 1.0 {
            return Err(ModelError::OutOfRange {
                field: "contact.friction_eta",
                value: self.friction_eta,
                range: "(0, 1]",
            });
        }
        positive("contact.stick_stiffness", self.stick_stiffness)?;
        if self.stick_stiffness > 1.0 {
            return Err(ModelError::OutOfRange {
                field: "contact.stick_stiffness",
                value: self.stick_stiffness,
                range: "(0, 1]",
            });
        }
        positive("contact.slip_velocity", self.slip_velocity)?;
        self.rod_friction.validate()
    }

    /// Whether rods touch each other or themselves.
    pub fn rod_contact(&self) -> bool {
        self.rods || self.self_contact
    }
}

/// The obstacles every rod touches, borrowed from the system.
#[derive(Debug, Clone, Copy, Default)]
pub struct Obstacles<'a> {
    /// Spheres.
    pub spheres: &'a [Sphere],
    /// Planes.
    pub planes: &'a [Plane],
    /// Cylinders.
    pub cylinders: &'a [Cylinder],
}

impl Obstacles<'_> {
    /// Whether there is no obstacle.
    pub fn is_empty(&self) -> bool {
        self.spheres.is_empty() && self.planes.is_empty() && self.cylinders.is_empty()
    }
}

/// Geometry of an element's contact with one sphere, if they overlap.
struct Hit {
    u: f64,
    normal: Vec3,
    penetration: f64,
}

#[inline]
fn current_radius(model: &RodModel, j: usize, l: f64) -> f64 {
    model.radius[j] / (l / model.rest_length[j]).sqrt()
}

#[inline]
fn element_hit(
    model: &RodModel,
    s: &impl RodAccess,
    j: usize,
    c: Vec3,
    radius: f64,
) -> Option<Hit> {
    let xa = s.position(j);
    let dx = sub(s.position(j + 1), xa);
    let l2 = dot(dx, dx);
    let l = l2.sqrt();
    let r = current_radius(model, j, l);
    let mid = [
        xa[0] + 0.5 * dx[0],
        xa[1] + 0.5 * dx[1],
        xa[2] + 0.5 * dx[2],
    ];
    if norm(sub(mid, c)) > radius + r + l {
        return None;
    }
    let u = (dot(sub(c, xa), dx) / l2).clamp(0.0, 1.0);
    let p = [xa[0] + u * dx[0], xa[1] + u * dx[1], xa[2] + u * dx[2]];
    let d = sub(p, c);
    let dist = norm(d);
    let g = radius + r - dist;
    if g <= 0.0 || dist == 0.0 {
        return None;
    }
    Some(Hit {
        u,
        normal: scale(1.0 / dist, d),
        penetration: g,
    })
}

/// Contact of element j's end `end` (0: node j, 1: node j + 1) with a plane: the penalty is
/// integrated along the element by the trapezoid rule, half of it at each end node, so that an
/// element standing on the plane presses with its lower end (a midpoint contact would let that
/// end sink by half an element) and a flat one with both.
#[inline]
fn plane_hit(
    model: &RodModel,
    s: &impl RodAccess,
    j: usize,
    end: usize,
    plane: &Plane,
) -> Option<Hit> {
    let xa = s.position(j);
    let dx = sub(s.position(j + 1), xa);
    let l = norm(dx);
    let r = current_radius(model, j, l);
    let x = s.position(j + end);
    let g = r - dot(sub(x, plane.point), plane.normal);
    (g > 0.0).then_some(Hit {
        u: end as f64,
        normal: plane.normal,
        penetration: g,
    })
}

/// Contact of element j with a cylinder's capsule at time t.
#[inline]
fn cylinder_hit(
    model: &RodModel,
    s: &impl RodAccess,
    j: usize,
    cyl: &Cylinder,
    t: f64,
) -> Option<Hit> {
    let xa = s.position(j);
    let xb = s.position(j + 1);
    let dx = sub(xb, xa);
    let l = norm(dx);
    let r = current_radius(model, j, l);
    let (qa, qb) = cyl.axis_at(t);
    let (u, v) = closest_points(xa, xb, qa, qb);
    let p = [xa[0] + u * dx[0], xa[1] + u * dx[1], xa[2] + u * dx[2]];
    let q = [
        qa[0] + v * (qb[0] - qa[0]),
        qa[1] + v * (qb[1] - qa[1]),
        qa[2] + v * (qb[2] - qa[2]),
    ];
    let d = sub(p, q);
    let dist = norm(d);
    let g = cyl.radius + r - dist;
    if g <= 0.0 || dist == 0.0 {
        return None;
    }
    Some(Hit {
        u,
        normal: scale(1.0 / dist, d),
        penetration: g,
    })
}

/// Parameters (u, v) in [0, 1]² of the closest points a0 + u (a1 − a0) and b0 + v (b1 − b0) of
/// two segments (degenerate and parallel segments handled; Ericson, Real-Time Collision
/// Detection §5.1.9).
pub fn closest_points(a0: Vec3, a1: Vec3, b0: Vec3, b1: Vec3) -> (f64, f64) {
    let d1 = sub(a1, a0);
    let d2 = sub(b1, b0);
    let r = sub(a0, b0);
    let a = dot(d1, d1);
    let e = dot(d2, d2);
    let f = dot(d2, r);
    const EPS: f64 = 1e-300;
    if a <= EPS && e <= EPS {
        return (0.0, 0.0);
    }
    if a <= EPS {
        return (0.0, (f / e).clamp(0.0, 1.0));
    }
    let c = dot(d1, r);
    if e <= EPS {
        return ((-c / a).clamp(0.0, 1.0), 0.0);
    }
    let b = dot(d1, d2);
    let denom = a * e - b * b;
    let mut s = if denom > 1e-14 * a * e {
        ((b * f - c * e) / denom).clamp(0.0, 1.0)
    } else {
        // Parallel: the midpoint of the overlap of a's projection onto b, so that two parallel
        // touching elements push through their common middle rather than an end.
        let t0 = (-c / a).clamp(0.0, 1.0);
        let t1 = ((b - c) / a).clamp(0.0, 1.0);
        0.5 * (t0 + t1)
    };
    let mut t = (b * s + f) / e;
    if t < 0.0 {
        t = 0.0;
        s = (-c / a).clamp(0.0, 1.0);
    } else if t > 1.0 {
        t = 1.0;
        s = ((b - c) / a).clamp(0.0, 1.0);
    }
    (s, t)
}

/// Scale a tangential force `f` onto the friction ellipse of `mu` ([forward, backward,
/// lateral]) at normal force `fn_` if it lies outside: returns the force and whether it was
/// outside. The forward/backward coefficient is chosen by the direction the force resists
/// (a force pointing backward resists forward sliding).
#[inline]
fn cap_friction(f: Vec3, tangent: Vec3, normal: Vec3, fn_: f64, mu: &[f64; 3]) -> (Vec3, bool) {
    let ta = sub(tangent, scale(dot(tangent, normal), normal));
    let la = norm(ta);
    let fl = norm(f);
    if fl == 0.0 {
        return (f, false);
    }
    let (ea, eb, mu_a, mu_b) = if la > 1e-9 {
        let ea = scale(1.0 / la, ta);
        let eb = cross(normal, ea);
        let fa = dot(f, ea);
        (ea, eb, if fa <= 0.0 { mu[0] } else { mu[1] }, mu[2])
    } else {
        // The element stands along the normal: every sliding direction is lateral.
        let ev = scale(1.0 / fl, f);
        (ev, cross(normal, ev), mu[2], mu[2])
    };
    let (mut fa, mut fb) = (dot(f, ea), dot(f, eb));
    let (cap_a, cap_b) = (mu_a * fn_, mu_b * fn_);
    if cap_a <= 0.0 {
        fa = 0.0;
    }
    if cap_b <= 0.0 {
        fb = 0.0;
    }
    let qa = if cap_a > 0.0 { fa / cap_a } else { 0.0 };
    let qb = if cap_b > 0.0 { fb / cap_b } else { 0.0 };
    let q = (qa * qa + qb * qb).sqrt();
    let outside =
        q > 1.0 || (cap_a <= 0.0 && dot(f, ea) != 0.0) || (cap_b <= 0.0 && dot(f, eb) != 0.0);
    if q > 1.0 {
        fa /= q;
        fb /= q;
    }
    (
        [
            fa * ea[0] + fb * eb[0],
            fa * ea[1] + fb * eb[1],
            fa * ea[2] + fb * eb[2],
        ],
        outside,
    )
}

/// Regularised Coulomb friction without memory (rod–rod contact): the viscous force −c v_t
/// capped on the static ellipse below the slip speed, on the kinetic one above.
#[inline]
pub(crate) fn friction_force(
    vt: Vec3,
    tangent: Vec3,
    normal: Vec3,
    fn_: f64,
    friction: &Friction,
    c: f64,
    slip: f64,
) -> Vec3 {
    let speed = norm(vt);
    if speed == 0.0 || fn_ <= 0.0 {
        return [0.0; 3];
    }
    let mu = if speed < slip {
        &friction.static_mu
    } else {
        &friction.kinetic_mu
    };
    cap_friction(scale(-c, vt), tangent, normal, fn_, mu).0
}

/// Coulomb friction with a stick spring (obstacle contact): the tangential displacement `stick`
/// since the contact last stuck grows by v_t Δt; the trial force −k_t δ − c v_t is kept while
/// it lies inside the static ellipse (sticking, no creep), otherwise it is scaled onto the
/// kinetic ellipse (sliding) and δ reset so that the spring alone carries that force.
#[allow(clippy::too_many_arguments)]
#[inline]
fn stick_friction(
    vt: Vec3,
    tangent: Vec3,
    normal: Vec3,
    fn_: f64,
    friction: &Friction,
    kt: f64,
    c: f64,
    dt: f64,
    stick: &mut Vec3,
) -> Vec3 {
    if fn_ <= 0.0 {
        *stick = [0.0; 3];
        return [0.0; 3];
    }
    let d = sub(*stick, scale(dot(*stick, normal), normal));
    let d = [d[0] + dt * vt[0], d[1] + dt * vt[1], d[2] + dt * vt[2]];
    let trial = [
        -kt * d[0] - c * vt[0],
        -kt * d[1] - c * vt[1],
        -kt * d[2] - c * vt[2],
    ];
    let (_, outside) = cap_friction(trial, tangent, normal, fn_, &friction.static_mu);
    if !outside {
        *stick = d;
        return trial;
    }
    let (f, _) = cap_friction(trial, tangent, normal, fn_, &friction.kinetic_mu);
    *stick = scale(-1.0 / kt, f);
    f
}

/// Normal and friction force of one contact on element j at parameter u, distributed to its
/// nodes ((1 − u), u). Without friction the arithmetic is the original sphere contact's.
#[allow(clippy::too_many_arguments)]
#[inline]
fn apply_hit(
    model: &RodModel,
    s: &impl RodAccess,
    j: usize,
    hit: &Hit,
    obstacle_velocity: Vec3,
    friction: &Friction,
    params: &ContactParams,
    dt: f64,
    first_node: usize,
    share: f64,
    stick: &mut Vec3,
    out: &mut ExternalLoads,
) {
    // `share` of the element's spring and mass at this contact (1, or ½ at each end node).
    let (k, mass) = if share == 1.0 {
        (
            params.beta * model.material.youngs_modulus * model.area[j] / model.rest_length[j],
            model.element_mass[j],
        )
    } else {
        (
            share * params.beta * model.material.youngs_modulus * model.area[j]
                / model.rest_length[j],
            share * model.element_mass[j],
        )
    };
    let damping = 2.0 * params.zeta * (k * mass).sqrt();
    let (va, vb) = (s.velocity(j), s.velocity(j + 1));
    let vrel = [
        (1.0 - hit.u) * va[0] + hit.u * vb[0] - obstacle_velocity[0],
        (1.0 - hit.u) * va[1] + hit.u * vb[1] - obstacle_velocity[1],
        (1.0 - hit.u) * va[2] + hit.u * vb[2] - obstacle_velocity[2],
    ];
    let vn = dot(vrel, hit.normal);
    let fnorm = (k * hit.penetration - damping * vn).max(0.0);
    let (wa, wb) = ((1.0 - hit.u) * fnorm, hit.u * fnorm);
    out.force.add(
        first_node + j,
        [wa * hit.normal[0], wa * hit.normal[1], wa * hit.normal[2]],
    );
    out.force.add(
        first_node + j + 1,
        [wb * hit.normal[0], wb * hit.normal[1], wb * hit.normal[2]],
    );
    if friction.is_none() {
        return;
    }
    let dx = sub(s.position(j + 1), s.position(j));
    let tangent = scale(1.0 / norm(dx), dx);
    let vt = sub(vrel, scale(vn, hit.normal));
    let c = params.friction_eta * mass / dt;
    let f = stick_friction(
        vt,
        tangent,
        hit.normal,
        fnorm,
        friction,
        params.stick_stiffness * k,
        c,
        dt,
        stick,
    );
    out.force.add(first_node + j, scale(1.0 - hit.u, f));
    out.force.add(first_node + j + 1, scale(hit.u, f));
}

/// Number of stick-spring slots the obstacles need for a system of `n_elements` elements: one
/// per element and obstacle with friction.
pub(crate) fn stick_slots(obstacles: Obstacles<'_>, n_elements: usize) -> usize {
    let with = |f: &Friction| usize::from(!f.is_none());
    // Planes hold two springs per element (one at each end node).
    let count = obstacles
        .spheres
        .iter()
        .map(|o| with(&o.friction))
        .sum::<usize>()
        + 2 * obstacles
            .planes
            .iter()
            .map(|o| with(&o.friction))
            .sum::<usize>()
        + obstacles
            .cylinders
            .iter()
            .map(|o| with(&o.friction))
            .sum::<usize>();
    count * n_elements
}

/// Add the contact forces of every obstacle on the rod `s` (nodes from `first_node`, elements
/// from `first_element` in the system) at time t, with time step dt; `stick` holds the stick
/// springs (`stick_slots` entries, obstacle-major, system element order).
#[allow(clippy::too_many_arguments)]
pub(crate) fn add_contact_forces(
    model: &RodModel,
    s: &impl RodAccess,
    obstacles: Obstacles<'_>,
    params: &ContactParams,
    t: f64,
    dt: f64,
    first_node: usize,
    first_element: usize,
    n_system_elements: usize,
    stick: &mut [Vec3],
    out: &mut ExternalLoads,
) {
    let mut slot_base = 0;
    let mut scratch = [0.0; 3];
    let mut next_base = |friction: &Friction| -> Option<usize> {
        if friction.is_none() {
            None
        } else {
            let b = slot_base;
            slot_base += n_system_elements;
            Some(b)
        }
    };
    for sphere in obstacles.spheres {
        let base = next_base(&sphere.friction);
        let c = sphere.center_at(t);
        for j in 0..model.n_elements {
            let slot = match base {
                Some(b) => &mut stick[b + first_element + j],
                None => &mut scratch,
            };
            let Some(hit) = element_hit(model, s, j, c, sphere.radius) else {
                *slot = [0.0; 3];
                continue;
            };
            apply_hit(
                model,
                s,
                j,
                &hit,
                sphere.velocity,
                &sphere.friction,
                params,
                dt,
                first_node,
                1.0,
                slot,
                out,
            );
        }
    }
    for plane in obstacles.planes {
        // Two stick springs per element (one at each end node).
        let base = next_base(&plane.friction);
        let base2 = next_base(&plane.friction);
        for j in 0..model.n_elements {
            for end in 0..2 {
                let slot = match (base, base2) {
                    (Some(b), Some(b2)) => &mut stick[[b, b2][end] + first_element + j],
                    _ => &mut scratch,
                };
                let Some(hit) = plane_hit(model, s, j, end, plane) else {
                    *slot = [0.0; 3];
                    continue;
                };
                apply_hit(
                    model,
                    s,
                    j,
                    &hit,
                    [0.0; 3],
                    &plane.friction,
                    params,
                    dt,
                    first_node,
                    0.5,
                    slot,
                    out,
                );
            }
        }
    }
    for cyl in obstacles.cylinders {
        let base = next_base(&cyl.friction);
        for j in 0..model.n_elements {
            let slot = match base {
                Some(b) => &mut stick[b + first_element + j],
                None => &mut scratch,
            };
            let Some(hit) = cylinder_hit(model, s, j, cyl, t) else {
                *slot = [0.0; 3];
                continue;
            };
            apply_hit(
                model,
                s,
                j,
                &hit,
                cyl.velocity,
                &cyl.friction,
                params,
                dt,
                first_node,
                1.0,
                slot,
                out,
            );
        }
    }
}

/// Every element's contact with every obstacle at time t: (element, penetration).
fn for_each_hit(
    model: &RodModel,
    s: &impl RodAccess,
    obstacles: Obstacles<'_>,
    t: f64,
    mut f: impl FnMut(usize, f64, f64),
) {
    for sphere in obstacles.spheres {
        let c = sphere.center_at(t);
        for j in 0..model.n_elements {
            if let Some(hit) = element_hit(model, s, j, c, sphere.radius) {
                f(j, hit.penetration, 1.0);
            }
        }
    }
    for plane in obstacles.planes {
        for j in 0..model.n_elements {
            for end in 0..2 {
                if let Some(hit) = plane_hit(model, s, j, end, plane) {
                    f(j, hit.penetration, 0.5);
                }
            }
        }
    }
    for cyl in obstacles.cylinders {
        for j in 0..model.n_elements {
            if let Some(hit) = cylinder_hit(model, s, j, cyl, t) {
                f(j, hit.penetration, 1.0);
            }
        }
    }
}

/// Elastic energy stored in the penalty springs of the spheres, Σ ½ k g² [J], with the spheres
/// where they are at time t (for Lyapunov and energy checks).
pub fn contact_energy(
    model: &RodModel,
    s: &impl RodAccess,
    spheres: &[Sphere],
    params: &ContactParams,
    t: f64,
) -> f64 {
    let obstacles = Obstacles {
        spheres,
        ..Obstacles::default()
    };
    obstacle_energy(model, s, obstacles, params, t)
}

/// Elastic energy stored in the penalty springs of every obstacle at time t [J].
pub fn obstacle_energy(
    model: &RodModel,
    s: &impl RodAccess,
    obstacles: Obstacles<'_>,
    params: &ContactParams,
    t: f64,
) -> f64 {
    let mut energy = 0.0;
    for_each_hit(model, s, obstacles, t, |j, g, share| {
        let k = params.beta * model.material.youngs_modulus * model.area[j] / model.rest_length[j];
        energy += 0.5 * share * k * g * g;
    });
    energy
}

/// Largest penetration of the rod's surface into any sphere at time t [m] (0 when there is no
/// contact), and the element where it occurs.
pub fn max_penetration(
    model: &RodModel,
    s: &impl RodAccess,
    spheres: &[Sphere],
    t: f64,
) -> (f64, usize) {
    let obstacles = Obstacles {
        spheres,
        ..Obstacles::default()
    };
    obstacle_penetration(model, s, obstacles, t)
}

/// Largest penetration of the rod's surface into any obstacle at time t [m], and its element.
pub fn obstacle_penetration(
    model: &RodModel,
    s: &impl RodAccess,
    obstacles: Obstacles<'_>,
    t: f64,
) -> (f64, usize) {
    let mut worst = (0.0, 0);
    for_each_hit(model, s, obstacles, t, |j, g, _| {
        if g > worst.0 {
            worst = (g, j);
        }
    });
    worst
}

/// Largest angular frequency [rad/s] a contact spring of stiffness β E Â_j / l̂_j can add to
/// element j's two nodes (against a rigid obstacle; `factor` 2 for two rods' elements).
pub fn contact_frequency(model: &RodModel, params: &ContactParams, factor: f64) -> f64 {
    let mut w2: f64 = 0.0;
    for j in 0..model.n_elements {
        let k = params.beta * model.material.youngs_modulus * model.area[j] / model.rest_length[j];
        let inv_m = model.inv_node_mass[j].max(model.inv_node_mass[j + 1]);
        w2 = w2.max(factor * k * inv_m);
    }
    w2.sqrt()
}
