//! The control variable: a strain field w = (ν, κ) with the full strain ν_j = σ_j + e3 on every
//! element and the curvature/twist κ_k on every interior point, both in the material frame, stored
//! flat so the solver can treat it as one vector. Also the planar/full choice of free components.
//! It does not know the rod's geometry; `statics` maps strains to shapes.

use octoarm_physics::{RodModel, RodState, Vec3};

/// Which strain components the solver may change.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StrainSpace {
    /// The paper's planar problem in the lab x–y plane: stretch ν3, the in-plane shear and the
    /// in-plane bend (for the project's frame d1 = e_y, d2 = e_z: ν1, ν3 and κ2), 3n − 1 numbers.
    /// The other components stay at their initial values.
    #[default]
    Planar,
    /// All six strains, 6n − 3 numbers.
    Full,
}

/// Strains of a rod with `n` elements: ν (full strain σ + e3, material frame) per element,
/// then κ [1/m] (material frame) per interior point, stored flat as 3n + 3(n − 1) numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct StrainField {
    n: usize,
    data: Vec<f64>,
}

impl StrainField {
    /// The zero field for `n` elements (not a valid shape: ν = 0 collapses every element).
    pub fn zeros(n: usize) -> Self {
        Self {
            n,
            data: vec![0.0; 6 * n - 3],
        }
    }

    /// The intrinsic (rest) strains of a model: ν° = σ° + e3, κ = κ°.
    pub fn intrinsic(model: &RodModel) -> Self {
        Self::from_rest_strains(&model.rest_sigma, &model.rest_kappa)
    }

    /// A field from rest strains σ (per element) and κ (per interior point), ν = σ + e3.
    /// Panics unless `kappa.len() + 1 == sigma.len()`.
    pub fn from_rest_strains(sigma: &[Vec3], kappa: &[Vec3]) -> Self {
        let n = sigma.len();
        assert_eq!(
            kappa.len() + 1,
            n,
            "kappa must have one entry fewer than sigma"
        );
        let mut w = Self::zeros(n);
        for (j, s) in sigma.iter().enumerate() {
            w.set_nu(j, [s[0], s[1], s[2] + 1.0]);
        }
        for (k, c) in kappa.iter().enumerate() {
            w.set_kappa(k, *c);
        }
        w
    }

    /// The strains of a rod state as the physics crate measures them (`octoarm_physics::strains`).
    pub fn from_state(model: &RodModel, state: &RodState) -> Self {
        let n = model.n_elements;
        let mut sigma = vec![[0.0; 3]; n];
        let mut kappa = vec![[0.0; 3]; n - 1];
        octoarm_physics::strains(model, state, &mut sigma, &mut kappa);
        Self::from_rest_strains(&sigma, &kappa)
    }

    /// Number of elements n.
    pub fn n_elements(&self) -> usize {
        self.n
    }

    /// Full strain ν_j = σ_j + e3 of element j (material frame).
    #[inline]
    pub fn nu(&self, j: usize) -> Vec3 {
        let d = &self.data[3 * j..3 * j + 3];
        [d[0], d[1], d[2]]
    }

    /// Set ν_j.
    #[inline]
    pub fn set_nu(&mut self, j: usize, v: Vec3) {
        self.data[3 * j..3 * j + 3].copy_from_slice(&v);
    }

    /// Curvature/twist κ_k [1/m] of interior point k (between elements k and k + 1).
    #[inline]
    pub fn kappa(&self, k: usize) -> Vec3 {
        let o = 3 * self.n + 3 * k;
        let d = &self.data[o..o + 3];
        [d[0], d[1], d[2]]
    }

    /// Set κ_k.
    #[inline]
    pub fn set_kappa(&mut self, k: usize, v: Vec3) {
        let o = 3 * self.n + 3 * k;
        self.data[o..o + 3].copy_from_slice(&v);
    }

    /// The flat vector (ν_0, …, ν_{n−1}, κ_0, …, κ_{n−2}), 6n − 3 numbers.
    pub fn as_slice(&self) -> &[f64] {
        &self.data
    }

    /// Mutable flat vector.
    pub fn as_mut_slice(&mut self) -> &mut [f64] {
        &mut self.data
    }

    /// Offset of the first κ entry in the flat vector (3n).
    pub fn kappa_offset(&self) -> usize {
        3 * self.n
    }

    /// True if every entry is finite.
    pub fn is_finite(&self) -> bool {
        self.data.iter().all(|v| v.is_finite())
    }

    /// Shear/stretch rest strains σ = ν − e3 written into `sigma` (length n) and κ into `kappa`
    /// (length n − 1): the form the simulator's load routine takes.
    pub fn write_rest_strains(&self, sigma: &mut [Vec3], kappa: &mut [Vec3]) {
        for (j, s) in sigma.iter_mut().enumerate().take(self.n) {
            let v = self.nu(j);
            *s = [v[0], v[1], v[2] - 1.0];
        }
        for (k, c) in kappa.iter_mut().enumerate().take(self.n - 1) {
            *c = self.kappa(k);
        }
    }

    /// σ = ν − e3 per element and κ per interior point, as new vectors.
    pub fn to_rest_strains(&self) -> (Vec<Vec3>, Vec<Vec3>) {
        let mut sigma = vec![[0.0; 3]; self.n];
        let mut kappa = vec![[0.0; 3]; self.n - 1];
        self.write_rest_strains(&mut sigma, &mut kappa);
        (sigma, kappa)
    }

    /// Largest |a − b| over all entries (∞ if the sizes differ).
    pub fn max_abs_diff(&self, other: &StrainField) -> f64 {
        if self.n != other.n {
            return f64::INFINITY;
        }
        self.data
            .iter()
            .zip(&other.data)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
    }
}

impl StrainField {
    /// Check that the field can be handed to the rod (spec §2.7): every entry finite, every
    /// turning angle D̂_k|κ_k| < π/2 and every stretch ν_{j,3} > 0. `voronoi_length` is the rest
    /// Voronoi length D̂ per interior point.
    pub fn check_admissible(
        &self,
        voronoi_length: &[f64],
    ) -> Result<(), crate::error::ShapingError> {
        use crate::error::ShapingError::DegenerateDesign;
        for j in 0..self.n {
            let v = self.nu(j);
            if v.iter().any(|x| !x.is_finite()) {
                let value = v
                    .iter()
                    .copied()
                    .find(|x| !x.is_finite())
                    .unwrap_or(f64::NAN);
                return Err(DegenerateDesign {
                    what: "strain nu",
                    value,
                    domain: "element",
                    index: j,
                    range: "finite",
                });
            }
            if v[2] <= 0.0 {
                return Err(DegenerateDesign {
                    what: "stretch nu3",
                    value: v[2],
                    domain: "element",
                    index: j,
                    range: "(0, inf)",
                });
            }
        }
        for (k, d) in voronoi_length.iter().enumerate().take(self.n - 1) {
            let c = self.kappa(k);
            if c.iter().any(|x| !x.is_finite()) {
                let value = c
                    .iter()
                    .copied()
                    .find(|x| !x.is_finite())
                    .unwrap_or(f64::NAN);
                return Err(DegenerateDesign {
                    what: "curvature kappa",
                    value,
                    domain: "interior point",
                    index: k,
                    range: "finite",
                });
            }
            let angle = d * (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
            if angle >= std::f64::consts::FRAC_PI_2 {
                return Err(DegenerateDesign {
                    what: "turning angle D|kappa|",
                    value: angle,
                    domain: "interior point",
                    index: k,
                    range: "[0, pi/2)",
                });
            }
        }
        Ok(())
    }
}
