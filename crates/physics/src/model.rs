//! The rod model: geometry, material, stiffnesses, masses and natural rest strains of one rod
//! (spec §1, §3). It is built once, validated, and shared (read-only) by every rod of a system
//! that uses it; the rest strains in force during a run belong to the system (`system.rs`), the
//! evolving state to `state.rs`.

use crate::error::{finite_vec, positive, ModelError};
use crate::math::{cross, dot, scale, Mat3, Vec3};
use crate::state::RodState;
use std::f64::consts::PI;

/// Material constants of a rod (SI units).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Material {
    /// Mass density ρ [kg/m³], > 0.
    pub density: f64,
    /// Young's modulus E [Pa], > 0.
    pub youngs_modulus: f64,
    /// Shear modulus G [Pa], > 0; an input, never derived from a Poisson ratio.
    pub shear_modulus: f64,
    /// Shear coefficient α_c in the shear stiffness α_c G A; default 27/28 (spec §3).
    pub shear_coefficient: f64,
}

impl Material {
    /// Default shear coefficient α_c = 27/28, as in current PyElastica releases.
    pub const DEFAULT_SHEAR_COEFFICIENT: f64 = 27.0 / 28.0;

    /// Check every constant and name the first bad one.
    pub fn validate(&self) -> Result<(), ModelError> {
        positive("density", self.density)?;
        positive("youngs_modulus", self.youngs_modulus)?;
        positive("shear_modulus", self.shear_modulus)?;
        positive("shear_coefficient", self.shear_coefficient)?;
        Ok(())
    }
}

/// Everything about one rod that does not change during a run, except the rest strains.
/// Domains: `node` (n + 1), `element` (n), `interior` Voronoi point (n − 1, between elements k
/// and k + 1, at node k + 1).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct RodModel {
    /// Number of elements n ≥ 2.
    pub n_elements: usize,
    /// Material constants.
    pub material: Material,
    /// Rest length l̂ [m], per element.
    pub rest_length: Vec<f64>,
    /// Rest Voronoi length D̂ [m], per interior point.
    pub rest_voronoi_length: Vec<f64>,
    /// Nodal share of rest length ℓ̂ [m], per node (half an element at each end).
    pub nodal_rest_length: Vec<f64>,
    /// Rest arc length of each node [m] (0 at the base).
    pub node_arc_length: Vec<f64>,
    /// Rest radius r̂ [m], per element.
    pub radius: Vec<f64>,
    /// Rest area Â [m²], per element.
    pub area: Vec<f64>,
    /// Second moments of area (I1, I2, I3 = polar) [m⁴], per element.
    pub second_moment: Vec<Vec3>,
    /// Element mass ρ Â l̂ [kg], per element.
    pub element_mass: Vec<f64>,
    /// Lumped mass [kg], per node.
    pub node_mass: Vec<f64>,
    /// Mass second moment of inertia J (diagonal, material frame) [kg m²], per element.
    pub inertia: Vec<Vec3>,
    /// Shear/stretch stiffness S = diag(α_c G Â, α_c G Â, E Â) [N], per element (eq. 3.1).
    pub shear_stiffness: Vec<Vec3>,
    /// Bend/twist stiffness B = diag(E I1, E I2, G I3) [N m²], per interior point, rest-length
    /// weighted average of the neighbouring elements (eq. 3.2).
    pub bend_stiffness: Vec<Vec3>,
    /// Natural rest shear/stretch strain σ° (material frame), per element; default 0. A system
    /// starts each rod with these; the rest strains in force are the system's.
    pub rest_sigma: Vec<Vec3>,
    /// Natural rest curvature/twist κ° [1/m] (material frame), per interior point; default 0.
    pub rest_kappa: Vec<Vec3>,
    pub(crate) inv_rest_length: Vec<f64>,
    pub(crate) inv_rest_voronoi: Vec<f64>,
    pub(crate) inv_node_mass: Vec<f64>,
    pub(crate) inv_inertia: Vec<Vec3>,
}

impl RodModel {
    /// Build a model from per-element rest lengths and radii (circular cross-sections).
    /// Errors name the first non-positive or non-finite entry.
    pub fn from_elements(
        rest_length: &[f64],
        radius: &[f64],
        material: Material,
    ) -> Result<Self, ModelError> {
        material.validate()?;
        let n = rest_length.len();
        if n < 2 {
            return Err(ModelError::CountOutOfRange {
                field: "n_elements",
                value: n,
                range: "[2, inf)",
            });
        }
        if radius.len() != n {
            return Err(ModelError::BadLength {
                field: "radius",
                len: radius.len(),
                expected: n,
            });
        }
        for &l in rest_length {
            positive("rest_length", l)?;
        }
        for &r in radius {
            positive("radius", r)?;
        }
        let Material {
            density: rho,
            youngs_modulus: e,
            shear_modulus: g,
            shear_coefficient: alpha,
        } = material;
        let area: Vec<f64> = radius.iter().map(|r| PI * r * r).collect();
        let second_moment: Vec<Vec3> = area
            .iter()
            .map(|a| {
                let i = a * a / (4.0 * PI);
                [i, i, 2.0 * i]
            })
            .collect();
        let element_mass: Vec<f64> = (0..n).map(|j| rho * area[j] * rest_length[j]).collect();
        let mut node_mass = vec![0.0; n + 1];
        let mut nodal_rest_length = vec![0.0; n + 1];
        for j in 0..n {
            node_mass[j] += 0.5 * element_mass[j];
            node_mass[j + 1] += 0.5 * element_mass[j];
            nodal_rest_length[j] += 0.5 * rest_length[j];
            nodal_rest_length[j + 1] += 0.5 * rest_length[j];
        }
        let mut node_arc_length = vec![0.0; n + 1];
        for j in 0..n {
            node_arc_length[j + 1] = node_arc_length[j] + rest_length[j];
        }
        let inertia: Vec<Vec3> = (0..n)
            .map(|j| scale(rho * rest_length[j], second_moment[j]))
            .collect();
        let shear_stiffness: Vec<Vec3> = area
            .iter()
            .map(|a| [alpha * g * a, alpha * g * a, e * a])
            .collect();
        let element_bend: Vec<Vec3> = second_moment
            .iter()
            .map(|i| [e * i[0], e * i[1], g * i[2]])
            .collect();
        let rest_voronoi_length: Vec<f64> = (0..n - 1)
            .map(|k| 0.5 * (rest_length[k] + rest_length[k + 1]))
            .collect();
        let bend_stiffness: Vec<Vec3> = (0..n - 1)
            .map(|k| {
                let (la, lb) = (rest_length[k], rest_length[k + 1]);
                let mut b = [0.0; 3];
                for c in 0..3 {
                    b[c] = (lb * element_bend[k + 1][c] + la * element_bend[k][c]) / (la + lb);
                }
                b
            })
            .collect();
        Ok(Self {
            n_elements: n,
            material,
            inv_rest_length: rest_length.iter().map(|l| 1.0 / l).collect(),
            inv_rest_voronoi: rest_voronoi_length.iter().map(|d| 1.0 / d).collect(),
            inv_node_mass: node_mass.iter().map(|m| 1.0 / m).collect(),
            inv_inertia: inertia
                .iter()
                .map(|j| [1.0 / j[0], 1.0 / j[1], 1.0 / j[2]])
                .collect(),
            rest_length: rest_length.to_vec(),
            rest_voronoi_length,
            nodal_rest_length,
            node_arc_length,
            radius: radius.to_vec(),
            area,
            second_moment,
            element_mass,
            node_mass,
            inertia,
            shear_stiffness,
            bend_stiffness,
            rest_sigma: vec![[0.0; 3]; n],
            rest_kappa: vec![[0.0; 3]; n - 1],
        })
    }

    /// Number of nodes, n + 1.
    pub fn n_nodes(&self) -> usize {
        self.n_elements + 1
    }

    /// Number of interior (Voronoi) points, n − 1.
    pub fn n_interior(&self) -> usize {
        self.n_elements - 1
    }

    /// Total rest length [m].
    pub fn length(&self) -> f64 {
        self.node_arc_length[self.n_elements]
    }

    /// Total mass [kg].
    pub fn total_mass(&self) -> f64 {
        self.node_mass.iter().sum()
    }

    /// Rest arc length of the midpoint of element j [m].
    pub fn element_midpoint_arc_length(&self, j: usize) -> f64 {
        self.node_arc_length[j] + 0.5 * self.rest_length[j]
    }

    /// Estimate of the largest natural frequency ω̂_max [rad/s] of the linearised rod (spec §11):
    /// max over elements of 4E/(ρ l̂²) + 4π α_c G/(ρ Â) (zig-zag plus shear–rotation).
    pub fn max_frequency(&self) -> f64 {
        let m = &self.material;
        let mut w2: f64 = 0.0;
        for j in 0..self.n_elements {
            let axial = 4.0 * m.youngs_modulus / (m.density * self.rest_length[j].powi(2));
            let shear_rot =
                4.0 * PI * m.shear_coefficient * m.shear_modulus / (m.density * self.area[j]);
            w2 = w2.max(axial + shear_rot);
        }
        w2.sqrt()
    }

    /// Largest stable time step of position Verlet for this rod, 2/ω̂_max [s] (spec §11).
    pub fn stable_dt(&self) -> f64 {
        2.0 / self.max_frequency()
    }

    /// Recommended operating time step, 0.2 × `stable_dt` [s].
    pub fn recommended_dt(&self) -> f64 {
        0.2 * self.stable_dt()
    }

    /// Replace the rest strains (σ° per element, κ° per interior point). Errors on wrong lengths
    /// or non-finite entries, leaving the model unchanged.
    pub fn set_rest_strains(&mut self, sigma: &[Vec3], kappa: &[Vec3]) -> Result<(), ModelError> {
        if sigma.len() != self.n_elements {
            return Err(ModelError::BadLength {
                field: "rest_sigma",
                len: sigma.len(),
                expected: self.n_elements,
            });
        }
        if kappa.len() != self.n_interior() {
            return Err(ModelError::BadLength {
                field: "rest_kappa",
                len: kappa.len(),
                expected: self.n_interior(),
            });
        }
        for v in sigma {
            finite_vec("rest_sigma", *v)?;
        }
        for v in kappa {
            finite_vec("rest_kappa", *v)?;
        }
        self.rest_sigma.copy_from_slice(sigma);
        self.rest_kappa.copy_from_slice(kappa);
        Ok(())
    }
}

/// A straight rod with a uniform or linearly tapered circular section, the usual way to make a
/// model and its rest state in one call. `paper_arm()` is the CyberOctopus arm of the paper.
#[derive(Debug, Clone, PartialEq)]
pub struct StraightRod {
    /// Number of elements n ≥ 2.
    pub n_elements: usize,
    /// Rest length L [m], > 0.
    pub length: f64,
    /// Diameter at the base [m], > 0.
    pub base_diameter: f64,
    /// Diameter at the tip [m], > 0; equal to `base_diameter` for a uniform rod. The radius of
    /// element j is half the linear profile at its midpoint (eq. 1.1).
    pub tip_diameter: f64,
    /// Material constants.
    pub material: Material,
    /// Position of node 0 [m].
    pub base_position: Vec3,
    /// Unit tangent d3 at rest (normalised on build).
    pub direction: Vec3,
    /// d1 at rest, perpendicular to `direction` (normalised on build).
    pub normal: Vec3,
    /// Uniform rest curvature κ° [1/m] in the material frame (κ1, κ2, κ3); default 0.
    pub rest_curvature: Vec3,
}

impl StraightRod {
    /// The paper's arm: L0 = 0.2 m, 100 elements, diameter 2 cm → 0.04 cm, E = 10 kPa,
    /// G = 1 kPa, ρ = 700 kg/m³, α_c = 27/28, along +x with d1 = e_y, based at the origin.
    pub fn paper_arm() -> Self {
        Self {
            n_elements: 100,
            length: 0.2,
            base_diameter: 0.02,
            tip_diameter: 0.0004,
            material: Material {
                density: 700.0,
                youngs_modulus: 1.0e4,
                shear_modulus: 1.0e3,
                shear_coefficient: Material::DEFAULT_SHEAR_COEFFICIENT,
            },
            base_position: [0.0; 3],
            direction: [1.0, 0.0, 0.0],
            normal: [0.0, 1.0, 0.0],
            rest_curvature: [0.0; 3],
        }
    }

    /// COOMM's arm (muscles-3d spec §1.1): L0 = 0.2 m, 100 elements, radius 12 mm → 1.2 mm,
    /// ρ = 1050 kg/m³, E = 10 kPa, G = E/3 (Poisson ratio 0.5), α_c = 0.964 (PyElastica 0.2.2),
    /// along +x from the origin in the COOMM frame d1 = −e_z, d2 = e_y.
    pub fn coomm_arm() -> Self {
        Self {
            n_elements: 100,
            length: 0.2,
            base_diameter: 0.024,
            tip_diameter: 0.0024,
            material: Material {
                density: 1050.0,
                youngs_modulus: 1.0e4,
                shear_modulus: 1.0e4 / 3.0,
                shear_coefficient: 0.964,
            },
            base_position: [0.0; 3],
            direction: [1.0, 0.0, 0.0],
            normal: [0.0, 0.0, -1.0],
            rest_curvature: [0.0; 3],
        }
    }

    /// A uniform rod along +x with d1 = e_y, based at the origin.
    pub fn uniform(n_elements: usize, length: f64, diameter: f64, material: Material) -> Self {
        Self {
            n_elements,
            length,
            base_diameter: diameter,
            tip_diameter: diameter,
            material,
            base_position: [0.0; 3],
            direction: [1.0, 0.0, 0.0],
            normal: [0.0, 1.0, 0.0],
            rest_curvature: [0.0; 3],
        }
    }

    /// The same rod with `n` elements.
    pub fn with_elements(mut self, n: usize) -> Self {
        self.n_elements = n;
        self
    }

    /// Validate every field and build the model and its straight rest state (at rest, t = 0).
    pub fn build(&self) -> Result<(RodModel, RodState), ModelError> {
        if self.n_elements < 2 {
            return Err(ModelError::CountOutOfRange {
                field: "n_elements",
                value: self.n_elements,
                range: "[2, inf)",
            });
        }
        positive("length", self.length)?;
        positive("base_diameter", self.base_diameter)?;
        positive("tip_diameter", self.tip_diameter)?;
        self.material.validate()?;
        finite_vec("base_position", self.base_position)?;
        finite_vec("rest_curvature", self.rest_curvature)?;
        let d3 = unit("direction", self.direction)?;
        let d1 = unit("normal", self.normal)?;
        if dot(d1, d3).abs() > 1e-10 {
            return Err(ModelError::BadVector {
                field: "normal",
                value: self.normal,
                reason: "must be perpendicular to direction (|normal·direction| ≤ 1e-10 after normalising)",
            });
        }
        // Remove the residual non-orthogonality so that the frame is orthonormal to round-off.
        let d1 = unit(
            "normal",
            [
                d1[0] - dot(d1, d3) * d3[0],
                d1[1] - dot(d1, d3) * d3[1],
                d1[2] - dot(d1, d3) * d3[2],
            ],
        )?;
        let d2 = cross(d3, d1);
        let n = self.n_elements;
        let dl = self.length / n as f64;
        let radius: Vec<f64> = (0..n)
            .map(|j| {
                let s = (j as f64 + 0.5) * dl;
                0.5 * (self.tip_diameter * s + self.base_diameter * (self.length - s)) / self.length
            })
            .collect();
        let mut model = RodModel::from_elements(&vec![dl; n], &radius, self.material)?;
        model.rest_kappa = vec![self.rest_curvature; n - 1];
        let frame: Mat3 = [d1, d2, d3];
        let position = (0..=n)
            .map(|i| {
                let s = i as f64 * dl;
                [
                    self.base_position[0] + s * d3[0],
                    self.base_position[1] + s * d3[1],
                    self.base_position[2] + s * d3[2],
                ]
            })
            .collect();
        let state = RodState {
            time: 0.0,
            position,
            velocity: vec![[0.0; 3]; n + 1],
            director: vec![frame; n],
            omega: vec![[0.0; 3]; n],
        };
        Ok((model, state))
    }
}

fn unit(field: &'static str, v: Vec3) -> Result<Vec3, ModelError> {
    finite_vec(field, v)?;
    crate::math::normalize(v).ok_or(ModelError::BadVector {
        field,
        value: v,
        reason: "must have non-zero length",
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: f64, b: f64) -> f64 {
        (a / b - 1.0).abs()
    }

    // Spec §13 (i6): the paper arm's derived table to 5 significant digits.
    #[test]
    fn paper_arm_derived_table() {
        let (m, _) = StraightRod::paper_arm().build().unwrap();
        let tol = 5e-5;
        assert!(rel(m.radius[0], 9.951e-3) < tol);
        assert!(rel(m.radius[99], 0.249e-3) < 1e-3); // given to 3 digits
        assert!(rel(m.area[0], 3.1109e-4) < tol);
        assert!(rel(m.area[99], 1.9478e-7) < tol);
        assert!(rel(m.second_moment[0][0], 7.7012e-9) < tol);
        assert!(rel(m.second_moment[99][0], 3.0192e-15) < tol);
        assert!(rel(m.node_mass[0], 2.1776e-4) < tol);
        assert!(rel(m.node_mass[100], 1.3635e-7) < tol);
        assert!(rel(m.inertia[0][0], 1.0782e-8) < tol);
        assert!(rel(m.inertia[0][2], 2.1563e-8) < tol);
        assert!(rel(m.inertia[99][0], 4.2268e-15) < tol);
        assert!(rel(m.inertia[99][2], 8.4537e-15) < tol);
        assert!(rel(m.shear_stiffness[0][0], 0.29998) < tol);
        assert!(rel(m.shear_stiffness[0][2], 3.11088) < tol);
        assert!(rel(m.shear_stiffness[99][0], 1.8783e-4) < tol);
        assert!(rel(m.shear_stiffness[99][2], 1.9478e-3) < tol);
        assert!(rel(m.bend_stiffness[0][0], 7.5517e-5) < tol);
        assert!(rel(m.bend_stiffness[0][2], 1.5103e-5) < tol);
        assert!(rel(m.bend_stiffness[98][0], 7.2031e-11) < tol);
        assert!(rel(m.bend_stiffness[98][2], 1.4406e-11) < tol);
        assert!(rel(m.total_mass(), 1.49595e-2) < tol);
        // S with alpha_c = 4/3
        let mut arm = StraightRod::paper_arm();
        arm.material.shear_coefficient = 4.0 / 3.0;
        let (m43, _) = arm.build().unwrap();
        assert!(rel(m43.shear_stiffness[0][0], 0.41478) < tol);
        assert!(rel(m43.shear_stiffness[99][0], 2.5971e-4) < tol);
    }

    #[test]
    fn stable_dt_matches_spec_estimate() {
        let mut arm = StraightRod::paper_arm();
        arm.material.shear_coefficient = 4.0 / 3.0;
        let (m, _) = arm.build().unwrap();
        // Spec §11: combined estimate 11712 rad/s -> 1.71e-4 s for alpha_c = 4/3.
        assert!(
            rel(m.max_frequency(), 11712.0) < 1e-3,
            "{}",
            m.max_frequency()
        );
        let (m, _) = StraightRod::paper_arm().build().unwrap();
        assert!(rel(m.stable_dt(), 1.97e-4) < 5e-3, "{}", m.stable_dt());
    }
}
