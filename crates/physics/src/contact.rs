//! Contact of a rod with rigid spheres by a penalty force through the centreline (spec §10):
//! closest point on each element, penetration against the current radius, stiffness scaled with
//! the element's axial stiffness, never adhesive. Friction and self-contact are not modelled.

use crate::error::{finite_vec, non_negative, positive, ModelError};
use crate::loads::ExternalLoads;
use crate::math::{dot, norm, scale, sub, Vec3};
use crate::model::RodModel;
use crate::state::RodAccess;

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
}

impl Sphere {
    /// A fixed sphere.
    pub fn fixed(center: Vec3, radius: f64) -> Self {
        Self {
            center,
            radius,
            velocity: [0.0; 3],
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

    /// Check centre, radius and velocity.
    pub fn validate(&self) -> Result<(), ModelError> {
        finite_vec("obstacle.center", self.center)?;
        positive("obstacle.radius", self.radius)?;
        finite_vec("obstacle.velocity", self.velocity)?;
        Ok(())
    }
}

/// Penalty parameters: k_j = β E Â_j / l̂_j, c_j = 2 ζ √(k_j m̄_j).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct ContactParams {
    /// Stiffness factor β (default 1; up to ~20 for the arm at dt = 1e-5 s).
    pub beta: f64,
    /// Damping ratio ζ (default 0.5).
    pub zeta: f64,
}

impl Default for ContactParams {
    fn default() -> Self {
        Self {
            beta: 1.0,
            zeta: 0.5,
        }
    }
}

impl ContactParams {
    /// Check β > 0 and ζ ≥ 0.
    pub fn validate(&self) -> Result<(), ModelError> {
        positive("contact.beta", self.beta)?;
        non_negative("contact.zeta", self.zeta)?;
        Ok(())
    }
}

/// Geometry of an element's contact with one sphere, if they overlap.
struct Hit {
    u: f64,
    normal: Vec3,
    penetration: f64,
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
    let r = model.radius[j] / (l / model.rest_length[j]).sqrt();
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

/// Add the contact forces of every sphere on the rod `s` (nodes from `first_node` in `out`) at
/// time t.
pub(crate) fn add_contact_forces(
    model: &RodModel,
    s: &impl RodAccess,
    spheres: &[Sphere],
    params: &ContactParams,
    t: f64,
    first_node: usize,
    out: &mut ExternalLoads,
) {
    let e_mod = model.material.youngs_modulus;
    for sphere in spheres {
        let c = sphere.center_at(t);
        for j in 0..model.n_elements {
            let Some(hit) = element_hit(model, s, j, c, sphere.radius) else {
                continue;
            };
            let k = params.beta * e_mod * model.area[j] / model.rest_length[j];
            let damping = 2.0 * params.zeta * (k * model.element_mass[j]).sqrt();
            let (va, vb) = (s.velocity(j), s.velocity(j + 1));
            let vrel = [
                (1.0 - hit.u) * va[0] + hit.u * vb[0] - sphere.velocity[0],
                (1.0 - hit.u) * va[1] + hit.u * vb[1] - sphere.velocity[1],
                (1.0 - hit.u) * va[2] + hit.u * vb[2] - sphere.velocity[2],
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
        }
    }
}

/// Elastic energy stored in the penalty springs, Σ ½ k g² [J], with the spheres where they are at
/// time t (for Lyapunov and energy checks).
pub fn contact_energy(
    model: &RodModel,
    s: &impl RodAccess,
    spheres: &[Sphere],
    params: &ContactParams,
    t: f64,
) -> f64 {
    let mut energy = 0.0;
    for sphere in spheres {
        let c = sphere.center_at(t);
        for j in 0..model.n_elements {
            if let Some(hit) = element_hit(model, s, j, c, sphere.radius) {
                let k = params.beta * model.material.youngs_modulus * model.area[j]
                    / model.rest_length[j];
                energy += 0.5 * k * hit.penetration * hit.penetration;
            }
        }
    }
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
    let mut worst = (0.0, 0);
    for sphere in spheres {
        let c = sphere.center_at(t);
        for j in 0..model.n_elements {
            if let Some(hit) = element_hit(model, s, j, c, sphere.radius) {
                if hit.penetration > worst.0 {
                    worst = (hit.penetration, j);
                }
            }
        }
    }
    worst
}
