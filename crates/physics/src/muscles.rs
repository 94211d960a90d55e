//! Muscles of the 3D arm (muscles-3d spec §1–2, COOMM's model): up to seven activation groups,
//! each with one or more fibres placed in the cross-section at a fraction of the local (current)
//! radius, optionally wound as a helix. `MuscleSpec` describes the groups (`MuscleSpec::coomm()`
//! is COOMM's arm: one transverse, four longitudinal, two oblique groups of four), `MuscleModel`
//! is that description precomputed for one rod model (rest offsets, rest fibre lengths, maximum
//! forces), and `MuscleModel::resultants` is the kernel: from the strains of a rod (ν, e, κ, ε)
//! and the activations it returns the fibres' force resultant n^μ per element and couple τ^μ per
//! Voronoi point, both in the material frame (eqs. 2.1–2.5). The stepper fuses them into the
//! internal loads (`internal.rs`, eqs. 2.6–2.7); `add_external_form` is the equivalent
//! external-load form (2.8–2.9), kept as a test oracle.

use crate::error::ModelError;
use crate::loads::ExternalLoads;
use crate::math::{cross, mat_t_vec, Mat3, Vec3};
use crate::model::RodModel;
use std::f64::consts::PI;

/// Number of activation groups an actuation carries per element (COOMM's seven).
pub const N_GROUPS: usize = 7;

/// Orientation of a fibre.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum FibreKind {
    /// Transverse: on the axis, its length is |ν^m|^(−1/2) (the section thins as the arm
    /// stretches); it pushes (force sign −1).
    Transverse,
    /// Longitudinal: parallel to the axis at rest (helix turns 0); pulls.
    Longitudinal,
    /// Oblique: a helix about the axis (turns ≠ 0); pulls.
    Oblique,
}

/// Force–length curve f_ℓ(λ) of a fibre (spec eq. 1.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum ForceLength {
    /// f ≡ 1 (COOMM's default; the closed forms of spec §8).
    Flat,
    /// COOMM's cubic 3.06λ³ − 13.64λ² + 18.01λ − 6.44 where ≥ 0 and λ ≤ 2, else 0.
    Cubic,
    /// exp(−½((λ − 1)/0.25)²).
    Gaussian,
}

impl ForceLength {
    /// f_ℓ(λ).
    #[inline(always)]
    pub fn value(self, l: f64) -> f64 {
        match self {
            ForceLength::Flat => 1.0,
            ForceLength::Cubic => {
                let f = ((3.06 * l - 13.64) * l + 18.01) * l - 6.44;
                if f >= 0.0 && l <= 2.0 {
                    f
                } else {
                    0.0
                }
            }
            ForceLength::Gaussian => {
                let z = (l - 1.0) * 4.0;
                (-0.5 * z * z).exp()
            }
        }
    }

    /// df_ℓ/dλ (one-sided at the cubic's kinks: the derivative of the branch in force).
    #[inline(always)]
    pub fn derivative(self, l: f64) -> f64 {
        match self {
            ForceLength::Flat => 0.0,
            ForceLength::Cubic => {
                let f = ((3.06 * l - 13.64) * l + 18.01) * l - 6.44;
                if f >= 0.0 && l <= 2.0 {
                    (9.18 * l - 27.28) * l + 18.01
                } else {
                    0.0
                }
            }
            ForceLength::Gaussian => {
                let z = (l - 1.0) * 4.0;
                -16.0 * (l - 1.0) * (-0.5 * z * z).exp()
            }
        }
    }
}

/// One activation group: its fibres share one activation field.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct MuscleGroup {
    /// Name (e.g. "LM0"), for reports.
    pub name: String,
    /// Fibre kind of every member.
    pub kind: FibreKind,
    /// Angle φ⁰ of each member [rad], from d1 towards d2 (one entry per member).
    pub angles: Vec<f64>,
    /// Radial position ρ as a fraction of the local radius, in [0, 1].
    pub radial: f64,
    /// Helix turns n over the arm (φ = φ⁰ + 2π n s̄/L).
    pub turns: f64,
    /// Cross-section area of one member as a fraction φ of the arm's section, in (0, 1].
    pub area_fraction: f64,
    /// Maximum stress σ_max [Pa], > 0.
    pub max_stress: f64,
    /// Force–length curve.
    pub force_length: ForceLength,
}

/// The muscles of an arm: at most `N_GROUPS` groups; group g reads activation field g.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct MuscleSpec {
    /// The groups, in activation order.
    pub groups: Vec<MuscleGroup>,
}

/// Index of each COOMM group in the activation array.
pub mod group {
    /// Transverse muscle.
    pub const TM: usize = 0;
    /// Longitudinal muscle k (k = 0..3) is `LM0 + k`.
    pub const LM0: usize = 1;
    /// Oblique group winding with +6 turns (right-handed about d3).
    pub const OM_POS: usize = 5;
    /// Oblique group winding with −6 turns.
    pub const OM_NEG: usize = 6;
}

impl MuscleSpec {
    /// COOMM's arm (spec §1.2 table): TM, LM0..LM3, OM+, OM−, with the cubic force–length
    /// curve of its examples.
    pub fn coomm() -> Self {
        let cubic = ForceLength::Cubic;
        let mut groups = vec![MuscleGroup {
            name: "TM".into(),
            kind: FibreKind::Transverse,
            angles: vec![0.0],
            radial: 0.0,
            turns: 0.0,
            area_fraction: (4.5f64 * 4.5 - 2.0 * 2.0) / (12.0 * 12.0),
            max_stress: 15.0e3,
            force_length: cubic,
        }];
        for k in 0..4 {
            groups.push(MuscleGroup {
                name: format!("LM{k}"),
                kind: FibreKind::Longitudinal,
                angles: vec![k as f64 * PI / 2.0],
                radial: 7.5 / 12.0,
                turns: 0.0,
                area_fraction: (3.0f64 / 12.0).powi(2),
                max_stress: 10.0e3,
                force_length: cubic,
            });
        }
        for (name, turns) in [("OM+", 6.0), ("OM-", -6.0)] {
            groups.push(MuscleGroup {
                name: name.into(),
                kind: FibreKind::Oblique,
                angles: (0..4).map(|k| k as f64 * PI / 2.0).collect(),
                radial: 11.25 / 12.0,
                turns,
                area_fraction: (0.75f64 / 12.0).powi(2),
                max_stress: 100.0e3,
                force_length: cubic,
            });
        }
        Self { groups }
    }

    /// The same muscles with every group's force–length curve set to `f`.
    pub fn with_force_length(mut self, f: ForceLength) -> Self {
        for g in &mut self.groups {
            g.force_length = f;
        }
        self
    }

    /// Check counts and ranges; errors name the field.
    pub fn validate(&self) -> Result<(), ModelError> {
        if self.groups.is_empty() || self.groups.len() > N_GROUPS {
            return Err(ModelError::CountOutOfRange {
                field: "muscles.groups",
                value: self.groups.len(),
                range: "[1, 7]",
            });
        }
        for g in &self.groups {
            if g.angles.is_empty() || g.angles.len() > 64 {
                return Err(ModelError::CountOutOfRange {
                    field: "muscles.angles",
                    value: g.angles.len(),
                    range: "[1, 64]",
                });
            }
            for &a in &g.angles {
                in_range("muscles.angles", a, -1e3, 1e3, "[-1000, 1000] rad")?;
            }
            in_range("muscles.radial", g.radial, 0.0, 1.0, "[0, 1]")?;
            in_range("muscles.turns", g.turns, -1e3, 1e3, "[-1000, 1000]")?;
            in_range(
                "muscles.area_fraction",
                g.area_fraction,
                1e-12,
                1.0,
                "(0, 1]",
            )?;
            in_range(
                "muscles.max_stress",
                g.max_stress,
                0.0,
                1e12,
                "[0, 1e12] Pa",
            )?;
        }
        Ok(())
    }
}

fn in_range(
    field: &'static str,
    v: f64,
    lo: f64,
    hi: f64,
    range: &'static str,
) -> Result<(), ModelError> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(())
    } else {
        Err(ModelError::OutOfRange {
            field,
            value: v,
            range,
        })
    }
}

/// One fibre, precomputed for a rod model (per element arrays of length n).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Member {
    /// Its group (activation field).
    pub group: usize,
    /// Fibre kind.
    pub kind: FibreKind,
    /// Force–length curve.
    pub force_length: ForceLength,
    /// Rest offset ρ r̂_j (cos φ_j, sin φ_j) [m] in the material (d1, d2) plane: components 1, 2.
    pub offset: [Vec<f64>; 2],
    /// 1/ℓ°_j: inverse rest fibre length (eq. 2.3 on the reference state).
    pub inv_rest_length: Vec<f64>,
    /// ς σ_max φ Â_j [N]: the signed force at unit activation, f_ℓ = 1 and e = 1.
    pub max_force: Vec<f64>,
    /// The member two places before this one if it lies diametrically opposite (offsets exactly
    /// negated, e.g. LM2 of LM0, the third fibre of an oblique group of the first): the kernel
    /// then reuses that member's offsets and q with the sign flipped (bit-identical to computing
    /// them anew, and cheaper).
    #[cfg_attr(feature = "serde", serde(default))]
    pub antipode: Option<usize>,
}

/// The muscles of one rod model: every member's precomputed arrays and the rod's rest lengths.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct MuscleModel {
    /// The description it was built from.
    pub spec: MuscleSpec,
    /// Every member of every group, groups in order.
    pub members: Vec<Member>,
    rest_length: Vec<f64>,
    rest_voronoi: Vec<f64>,
}

/// Scratch of the kernel for rods of up to n elements; allocated once.
#[derive(Debug, Clone, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct MuscleScratch {
    // Per element: e^(−1/2), 1/e, Σ x × n (3); in two slots (member index parity, so that an
    // antipode finds its partner's): the member's offset (2).
    root: Vec<f64>,
    inv_e: Vec<f64>,
    x: [[Vec<f64>; 2]; 2],
    c: [Vec<f64>; 3],
    // Per Voronoi point, padded with zero ghosts at 0 and n, in the two slots: q (3);
    // 1/(D̂ ε) unpadded.
    q: [[Vec<f64>; 3]; 2],
    inv_de: Vec<f64>,
}

impl MuscleScratch {
    /// Scratch for rods of up to `n` elements.
    pub fn new(n: usize) -> Self {
        let z = || vec![0.0; n + 1];
        Self {
            root: z(),
            inv_e: z(),
            x: [[z(), z()], [z(), z()]],
            c: [z(), z(), z()],
            q: [[z(), z(), z()], [z(), z(), z()]],
            inv_de: z(),
        }
    }
}

/// Strains of one rod in structure-of-arrays form (material frame), the kernel's input: σ per
/// element (ν = σ + e3), e per element, κ and ε per Voronoi point.
#[derive(Debug, Clone, Copy)]
pub struct Strains<'a> {
    /// σ₁, σ₂, σ₃ per element.
    pub sigma: [&'a [f64]; 3],
    /// Dilatation e_j = |ν_j|.
    pub dilatation: &'a [f64],
    /// κ₁, κ₂, κ₃ per Voronoi point [1/m].
    pub kappa: [&'a [f64]; 3],
    /// Voronoi dilatation ε_k.
    pub voronoi_dilatation: &'a [f64],
}

/// Output of the kernel: n^μ per element [N] and τ^μ per Voronoi point [N m], material frame,
/// structure of arrays.
pub struct Resultants<'a> {
    /// n^μ components per element (overwritten).
    pub force: [&'a mut [f64]; 3],
    /// τ^μ components per Voronoi point (overwritten).
    pub couple: [&'a mut [f64]; 3],
    /// If given, the per-element moments C_j = Σ_m x_{m,j} × n^m_j (τ^μ_k = ½(C_k + C_{k+1}))
    /// are copied here (the design gradient, spec eq. 5.5, needs them per group).
    pub moment: Option<[&'a mut [f64]; 3]>,
}

impl MuscleModel {
    /// Precompute `spec` for `model` (rest offsets scale with the element radii, areas with the
    /// element areas; the helix phase uses the element mid arc length s̄_j / L).
    pub fn new(spec: MuscleSpec, model: &RodModel) -> Result<Self, ModelError> {
        spec.validate()?;
        let n = model.n_elements;
        let length = model.length();
        let mut members = Vec::new();
        for (g, grp) in spec.groups.iter().enumerate() {
            for &phi0 in &grp.angles {
                let mut offset = [vec![0.0; n], vec![0.0; n]];
                for j in 0..n {
                    let s = model.element_midpoint_arc_length(j);
                    let phi = phi0 + 2.0 * PI * grp.turns * s / length;
                    let r = grp.radial * model.radius[j];
                    offset[0][j] = r * phi.cos();
                    offset[1][j] = r * phi.sin();
                }
                // Diametrically opposite the member two places before (to round-off): make
                // the offsets exactly negated, so that the kernel may reuse that member's.
                let mut antipode = None;
                if let Some(p) = members.len().checked_sub(2) {
                    let other: &Member = &members[p];
                    let scale = model.radius.iter().fold(0.0f64, |m, r| m.max(*r));
                    let opposite = (0..n).all(|j| {
                        (offset[0][j] + other.offset[0][j]).abs() <= 1e-12 * scale
                            && (offset[1][j] + other.offset[1][j]).abs() <= 1e-12 * scale
                    });
                    if opposite {
                        for c in 0..2 {
                            for j in 0..n {
                                offset[c][j] = -other.offset[c][j];
                            }
                        }
                        antipode = Some(p);
                    }
                }
                let sign = if grp.kind == FibreKind::Transverse {
                    -1.0
                } else {
                    1.0
                };
                let max_force = (0..n)
                    .map(|j| sign * grp.max_stress * grp.area_fraction * model.area[j])
                    .collect();
                // Rest lengths: eq. 2.3 on the reference state (σ = κ = 0, e = ε = 1).
                let mut inv_rest_length = vec![0.0; n];
                let q = |k: usize| -> Vec3 {
                    let d = model.rest_voronoi_length[k];
                    [
                        (offset[0][k + 1] - offset[0][k]) / d,
                        (offset[1][k + 1] - offset[1][k]) / d,
                        0.0,
                    ]
                };
                for j in 0..n {
                    let mut nu = [0.0, 0.0, 1.0];
                    for k in [j.wrapping_sub(1), j] {
                        if k < n - 1 {
                            let qk = q(k);
                            for c in 0..3 {
                                nu[c] += 0.5 * qk[c];
                            }
                        }
                    }
                    let len = crate::math::norm(nu);
                    let l0 = if grp.kind == FibreKind::Transverse {
                        1.0 / len.sqrt()
                    } else {
                        len
                    };
                    inv_rest_length[j] = 1.0 / l0;
                }
                members.push(Member {
                    group: g,
                    kind: grp.kind,
                    force_length: grp.force_length,
                    offset,
                    inv_rest_length,
                    max_force,
                    antipode,
                });
            }
        }
        Ok(Self {
            spec,
            members,
            rest_length: model.rest_length.clone(),
            rest_voronoi: model.rest_voronoi_length.clone(),
        })
    }

    /// Number of elements of the rod it was built for.
    pub fn n_elements(&self) -> usize {
        self.rest_length.len()
    }

    /// Number of groups.
    pub fn n_groups(&self) -> usize {
        self.spec.groups.len()
    }

    /// The kernel (spec eqs. 2.1–2.5): muscle force n^μ per element and couple τ^μ per Voronoi
    /// point, material frame, for the strains `s` and activations `activation[g]` (n entries
    /// per group; groups beyond `n_groups` are ignored). A group whose activation is zero on
    /// every element is skipped (its loads are exactly zero).
    pub fn resultants(
        &self,
        activation: [&[f64]; N_GROUPS],
        s: &Strains<'_>,
        scratch: &mut MuscleScratch,
        out: &mut Resultants<'_>,
    ) {
        // The kernel chosen at run time: the same code compiled for AVX2 where the CPU has it
        // (four lanes for the square roots and divisions). No FMA is enabled and Rust never
        // contracts a·b + c on its own, so both paths give the same bits.
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: AVX2 is available on this CPU (checked just above).
                unsafe { self.resultants_avx2(activation, s, scratch, out) };
                return;
            }
        }
        self.resultants_portable(activation, s, scratch, out);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn resultants_avx2(
        &self,
        activation: [&[f64]; N_GROUPS],
        s: &Strains<'_>,
        scratch: &mut MuscleScratch,
        out: &mut Resultants<'_>,
    ) {
        self.resultants_portable(activation, s, scratch, out);
    }

    #[inline(always)]
    fn resultants_portable(
        &self,
        activation: [&[f64]; N_GROUPS],
        s: &Strains<'_>,
        scratch: &mut MuscleScratch,
        out: &mut Resultants<'_>,
    ) {
        let n = self.n_elements();
        let nk = n - 1;
        for c in 0..3 {
            out.force[c][..n].fill(0.0);
            out.couple[c][..nk].fill(0.0);
            scratch.c[c][..n].fill(0.0);
            for q in &mut scratch.q {
                q[c][0] = 0.0;
                q[c][n] = 0.0;
            }
        }
        let dil = &s.dilatation[..n];
        let eps = &s.voronoi_dilatation[..nk];
        let root = &mut scratch.root[..n];
        let inv_e = &mut scratch.inv_e[..n];
        for j in 0..n {
            let r = 1.0 / dil[j].sqrt();
            root[j] = r;
            inv_e[j] = r * r;
        }
        let inv_de = &mut scratch.inv_de[..nk];
        for k in 0..nk {
            inv_de[k] = 1.0 / (self.rest_voronoi[k] * eps[k]);
        }
        let (sx, sy, sz) = (&s.sigma[0][..n], &s.sigma[1][..n], &s.sigma[2][..n]);
        let (kx, ky, kz) = (&s.kappa[0][..nk], &s.kappa[1][..nk], &s.kappa[2][..nk]);
        let [ref mut cx, ref mut cy, ref mut cz] = scratch.c;
        let (cx, cy, cz) = (&mut cx[..n], &mut cy[..n], &mut cz[..n]);
        let [ref mut fx, ref mut fy, ref mut fz] = out.force;
        let (fx, fy, fz) = (&mut fx[..n], &mut fy[..n], &mut fz[..n]);
        // The member whose offsets and q each slot holds.
        let mut held: [Option<usize>; 2] = [None; 2];
        for (mi, m) in self.members.iter().enumerate() {
            let a = &activation[m.group][..n];
            if a.iter().all(|&v| v == 0.0) {
                continue;
            }
            let slot = mi % 2;
            // An antipode (offsets exactly −x of the member two places before) reuses that
            // member's x and q with the sign flipped when they are still held.
            let flipped = m.antipode.is_some() && m.antipode == held[slot];
            if !flipped {
                held[slot] = Some(mi);
                compute_offsets_and_q(
                    m,
                    n,
                    &scratch.root[..n],
                    &scratch.inv_de[..nk],
                    [kx, ky, kz],
                    &mut scratch.x[slot],
                    &mut scratch.q[slot],
                );
            }
            let inv_e = &scratch.inv_e[..n];
            let (q1, q2, q3) = (
                &scratch.q[slot][0][..n + 1],
                &scratch.q[slot][1][..n + 1],
                &scratch.q[slot][2][..n + 1],
            );
            let inv_l0 = &m.inv_rest_length[..n];
            let fmax = &m.max_force[..n];
            let acc = Accumulators {
                f: [&mut *fx, &mut *fy, &mut *fz],
                c: [&mut *cx, &mut *cy, &mut *cz],
            };
            let input = FibreInput {
                sigma: [sx, sy, sz],
                q: [q1, q2, q3],
                x: [&scratch.x[slot][0][..n], &scratch.x[slot][1][..n]],
                a,
                inv_e,
                inv_l0,
                fmax,
            };
            // One monomorphic loop per (kind, curve, sign): no branch inside the element loop.
            let transverse = m.kind == FibreKind::Transverse;
            if flipped {
                fibre_dispatch::<true>(&input, acc, transverse, m.force_length);
            } else {
                fibre_dispatch::<false>(&input, acc, transverse, m.force_length);
            }
        }
        if let Some(mo) = out.moment.as_mut() {
            mo[0][..n].copy_from_slice(cx);
            mo[1][..n].copy_from_slice(cy);
            mo[2][..n].copy_from_slice(cz);
        }
        let [ref mut tx, ref mut ty, ref mut tz] = out.couple;
        for k in 0..nk {
            tx[k] = 0.5 * (cx[k] + cx[k + 1]);
            ty[k] = 0.5 * (cy[k] + cy[k + 1]);
            tz[k] = 0.5 * (cz[k] + cz[k + 1]);
        }
    }

    /// Stored energy of the fibres (spec §6.3) [J]: per fibre and element
    /// W = l̂_j ∫ ς a σ_max φ Â_j f_ℓ(λ(ξ)) dξ from the rest |ν^m| to the current one (4-point
    /// Gauss–Legendre), with λ(ξ) = ξ/ℓ° (LM, OM) or ξ^{−1/2}/ℓ° (TM). Its gradient equals the
    /// kernel's loads only up to the 1/e area factor, the current radius and the Voronoi
    /// averaging (spec §6.1); the Lyapunov test allows for that. Allocates its own scratch (not
    /// for the step loop).
    pub fn stored_energy(&self, activation: [&[f64]; N_GROUPS], s: &Strains<'_>) -> f64 {
        let n = self.n_elements();
        let nk = n - 1;
        const GL: [(f64, f64); 4] = [
            (-0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
            (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
            (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
            (0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
        ];
        let mut total = 0.0;
        let mut x = vec![[0.0; 2]; n];
        let mut q = vec![[0.0; 3]; n + 1];
        for m in &self.members {
            let a = &activation[m.group][..n];
            if a.iter().all(|&v| v == 0.0) {
                continue;
            }
            for j in 0..n {
                let r = 1.0 / s.dilatation[j].sqrt();
                x[j] = [m.offset[0][j] * r, m.offset[1][j] * r];
            }
            for k in 0..nk {
                let inv = 1.0 / (self.rest_voronoi[k] * s.voronoi_dilatation[k]);
                let b = [0.5 * (x[k][0] + x[k + 1][0]), 0.5 * (x[k][1] + x[k + 1][1])];
                let kap = [s.kappa[0][k], s.kappa[1][k], s.kappa[2][k]];
                q[k + 1] = [
                    -kap[2] * b[1] + (x[k + 1][0] - x[k][0]) * inv,
                    kap[2] * b[0] + (x[k + 1][1] - x[k][1]) * inv,
                    kap[0] * b[1] - kap[1] * b[0],
                ];
            }
            let transverse = m.kind == FibreKind::Transverse;
            for j in 0..n {
                let v = [
                    s.sigma[0][j] + 0.5 * (q[j][0] + q[j + 1][0]),
                    s.sigma[1][j] + 0.5 * (q[j][1] + q[j + 1][1]),
                    1.0 + s.sigma[2][j] + 0.5 * (q[j][2] + q[j + 1][2]),
                ];
                let len = crate::math::norm(v);
                let l0 = 1.0 / m.inv_rest_length[j];
                let start = if transverse { 1.0 / (l0 * l0) } else { l0 };
                let (mid, half) = (0.5 * (len + start), 0.5 * (len - start));
                let mut integral = 0.0;
                for (t, wt) in GL {
                    let xi = mid + half * t;
                    let ell = if transverse { 1.0 / xi.sqrt() } else { xi };
                    integral += wt * m.force_length.value(ell * m.inv_rest_length[j]);
                }
                total += self.rest_length[j] * a[j] * m.max_force[j] * half * integral;
            }
        }
        total
    }

    /// The external-load form (spec eqs. 2.8–2.9) of resultants `n_mu` (per element) and
    /// `tau_mu` (per Voronoi point): lab node forces and material element couples added to
    /// `out` from node `first_node` and element `first_element`. `frames` are Q_j, `nu` the full
    /// strains ν_j and `kappa` the curvatures. The test oracle of the fused form.
    #[allow(clippy::too_many_arguments)]
    pub fn add_external_form(
        &self,
        frames: &[Mat3],
        nu: &[Vec3],
        kappa: &[Vec3],
        n_mu: &[Vec3],
        tau_mu: &[Vec3],
        first_node: usize,
        first_element: usize,
        out: &mut ExternalLoads,
    ) {
        let n = self.n_elements();
        for i in 0..=n {
            let mut f = [0.0; 3];
            if i < n {
                f = mat_t_vec(&frames[i], n_mu[i]);
            }
            if i > 0 {
                let g = mat_t_vec(&frames[i - 1], n_mu[i - 1]);
                f = [f[0] - g[0], f[1] - g[1], f[2] - g[2]];
            }
            out.force.add(first_node + i, f);
        }
        for j in 0..n {
            let mut c = [0.0; 3];
            if j < n - 1 {
                let kt = cross(kappa[j], tau_mu[j]);
                for a in 0..3 {
                    c[a] += tau_mu[j][a] + 0.5 * self.rest_voronoi[j] * kt[a];
                }
            }
            if j > 0 {
                let kt = cross(kappa[j - 1], tau_mu[j - 1]);
                for a in 0..3 {
                    c[a] += -tau_mu[j - 1][a] + 0.5 * self.rest_voronoi[j - 1] * kt[a];
                }
            }
            let s = cross(nu[j], n_mu[j]);
            for a in 0..3 {
                c[a] += self.rest_length[j] * s[a];
            }
            out.couple.add(first_element + j, c);
        }
    }
}

/// COOMM's cubic force–length curve, branch-free (a select) so that loops over it vectorise.
#[inline(always)]
fn cubic(l: f64) -> f64 {
    let f = ((3.06 * l - 13.64) * l + 18.01) * l - 6.44;
    if f >= 0.0 && l <= 2.0 {
        f
    } else {
        0.0
    }
}

#[inline(always)]
fn gaussian(l: f64) -> f64 {
    let z = (l - 1.0) * 4.0;
    (-0.5 * z * z).exp()
}

/// Offsets at the current radius r̂/√e (eq. 1.1) and q_k = κ_k × x̄_k + x'_k (eq. 2.1, x₃ = 0;
/// slot k + 1 of `q` holds point k, the ghosts 0 and n stay zero) for member `m`.
#[inline(always)]
fn compute_offsets_and_q(
    m: &Member,
    n: usize,
    root: &[f64],
    inv_de: &[f64],
    kappa: [&[f64]; 3],
    x: &mut [Vec<f64>; 2],
    q: &mut [Vec<f64>; 3],
) {
    let nk = n - 1;
    let (ox, oy) = (&m.offset[0][..n], &m.offset[1][..n]);
    let (root, inv_de) = (&root[..n], &inv_de[..nk]);
    let [kx, ky, kz] = kappa;
    let (kx, ky, kz) = (&kx[..nk], &ky[..nk], &kz[..nk]);
    let [ref mut x1, ref mut x2] = *x;
    let (x1, x2) = (&mut x1[..n], &mut x2[..n]);
    for j in 0..n {
        x1[j] = ox[j] * root[j];
        x2[j] = oy[j] * root[j];
    }
    let [ref mut q1, ref mut q2, ref mut q3] = *q;
    let (q1, q2, q3) = (&mut q1[1..n], &mut q2[1..n], &mut q3[1..n]);
    for k in 0..nk {
        let b1 = 0.5 * (x1[k] + x1[k + 1]);
        let b2 = 0.5 * (x2[k] + x2[k + 1]);
        let d1 = (x1[k + 1] - x1[k]) * inv_de[k];
        let d2 = (x2[k + 1] - x2[k]) * inv_de[k];
        q1[k] = -kz[k] * b2 + d1;
        q2[k] = kz[k] * b1 + d2;
        q3[k] = kx[k] * b2 - ky[k] * b1;
    }
}

/// `fibre_loop` for the fibre's kind and curve; `NEG`: the input's offsets and q are those of
/// the antipode (use −x, −q).
#[inline(always)]
fn fibre_dispatch<const NEG: bool>(
    input: &FibreInput<'_>,
    acc: Accumulators<'_>,
    transverse: bool,
    curve: ForceLength,
) {
    match (transverse, curve) {
        (false, ForceLength::Flat) => fibre_loop::<NEG>(input, acc, |l| l, |_| 1.0),
        (false, ForceLength::Cubic) => fibre_loop::<NEG>(input, acc, |l| l, cubic),
        (false, ForceLength::Gaussian) => fibre_loop::<NEG>(input, acc, |l| l, gaussian),
        (true, ForceLength::Flat) => fibre_loop::<NEG>(input, acc, |l| 1.0 / l.sqrt(), |_| 1.0),
        (true, ForceLength::Cubic) => fibre_loop::<NEG>(input, acc, |l| 1.0 / l.sqrt(), cubic),
        (true, ForceLength::Gaussian) => {
            fibre_loop::<NEG>(input, acc, |l| 1.0 / l.sqrt(), gaussian)
        }
    }
}

struct FibreInput<'a> {
    sigma: [&'a [f64]; 3],
    q: [&'a [f64]; 3],
    x: [&'a [f64]; 2],
    a: &'a [f64],
    inv_e: &'a [f64],
    inv_l0: &'a [f64],
    fmax: &'a [f64],
}

struct Accumulators<'a> {
    f: [&'a mut [f64]; 3],
    c: [&'a mut [f64]; 3],
}

/// Eqs. 2.2–2.5 for one fibre over all elements: ν^m, its length (`length` maps |ν^m| to ℓ),
/// f_ℓ(ℓ/ℓ°) (`curve`), n^m = F ν^m/|ν^m|, accumulated into n^μ and Σ x × n.
/// With `NEG` the fibre is the antipode of the one whose x and q are given: ν^m uses −q and
/// the moments −x (exactly what −x and −q stored would give: negation is exact in floating point).
#[inline(always)]
fn fibre_loop<const NEG: bool>(
    i: &FibreInput<'_>,
    acc: Accumulators<'_>,
    length: impl Fn(f64) -> f64,
    curve: impl Fn(f64) -> f64,
) {
    let n = i.a.len();
    let [sx, sy, sz] = i.sigma;
    let (sx, sy, sz) = (&sx[..n], &sy[..n], &sz[..n]);
    let [q1, q2, q3] = i.q;
    let (q1, q2, q3) = (&q1[..n + 1], &q2[..n + 1], &q3[..n + 1]);
    let (x1, x2) = (&i.x[0][..n], &i.x[1][..n]);
    let (a, inv_e, inv_l0, fmax) = (i.a, &i.inv_e[..n], &i.inv_l0[..n], &i.fmax[..n]);
    let Accumulators {
        f: [fx, fy, fz],
        c: [cx, cy, cz],
    } = acc;
    let (fx, fy, fz) = (&mut fx[..n], &mut fy[..n], &mut fz[..n]);
    let (cx, cy, cz) = (&mut cx[..n], &mut cy[..n], &mut cz[..n]);
    for j in 0..n {
        // Eq. 2.2: ν^m_j = ν_j + ½(q_{j−1} + q_j).
        let (h0, h1, h2) = (
            0.5 * (q1[j] + q1[j + 1]),
            0.5 * (q2[j] + q2[j + 1]),
            0.5 * (q3[j] + q3[j + 1]),
        );
        let (v0, v1, v2) = if NEG {
            (sx[j] - h0, sy[j] - h1, 1.0 + sz[j] - h2)
        } else {
            (sx[j] + h0, sy[j] + h1, 1.0 + sz[j] + h2)
        };
        let len = (v0 * v0 + v1 * v1 + v2 * v2).sqrt();
        let f = curve(length(len) * inv_l0[j]);
        // Eqs. 2.4–2.5: n = F t, F = ς a σ_max f_ℓ φ Â / e.
        let s = a[j] * fmax[j] * f * inv_e[j] / len;
        let (n0, n1, n2) = (s * v0, s * v1, s * v2);
        fx[j] += n0;
        fy[j] += n1;
        fz[j] += n2;
        if NEG {
            cx[j] -= x2[j] * n2;
            cy[j] += x1[j] * n2;
            cz[j] -= x1[j] * n1 - x2[j] * n0;
        } else {
            cx[j] += x2[j] * n2;
            cy[j] -= x1[j] * n2;
            cz[j] += x1[j] * n1 - x2[j] * n0;
        }
    }
}
