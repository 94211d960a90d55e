//! Strain-space statics of the clamped arm (spec §2.2–§2.5): the forward map from strains to the
//! centreline and frames, the task loads, the costates as the exact discrete adjoint, and the
//! gradient of the cost with respect to every strain. One call of `sweep` is one "sweep" of the
//! solver; it does not allocate. The update rules that use the gradient live in `solver`.

use crate::error::StaticsError;
use crate::strains::{StrainField, StrainSpace};
use crate::task::{Task, TipTerm};
use octoarm_physics::math::{cross, dot, mat_mul, mat_t_vec, mat_vec, norm, rodrigues, sub};
use octoarm_physics::{Mat3, RodModel, RodState, Vec3};
use std::f64::consts::PI;

/// The cost of one strain field, split into its terms [J].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CostTerms {
    /// J = strain + tip + grasp + obstacle.
    pub total: f64,
    /// V_h: quadratic strain energy with the design stiffnesses.
    pub strain: f64,
    /// ½ μ_tip |r_N − r*|², or −F·r_N in the tip-force mode.
    pub tip: f64,
    /// Σ_i ω_i μ_grasp,i Φ_grasp(r_i).
    pub grasp: f64,
    /// Σ_j ξ_j q̂_j(L0), all obstacles together.
    pub obstacle: f64,
}

/// exp(−[a]×) and the coefficients c = (1 − cos θ)/θ², d = (θ − sin θ)/θ³ of a = D̂κ (θ = |a|),
/// which the gradient reuses for J_r(−a) = I + c[a]× + d[a]×². Series below θ² = 1e-2.
/// The series divide (physics' `exp_neg_skew` multiplies by rounded reciprocals): the solver's
/// iteration counts and the paper runs are sensitive to the last bits, so they are kept.
#[inline]
fn rotation(a: Vec3) -> (Mat3, f64, f64) {
    let t2 = dot(a, a);
    let (s, c, d) = if t2 < 1e-2 {
        let s = 1.0 - t2 / 6.0 * (1.0 - t2 / 20.0 * (1.0 - t2 / 42.0 * (1.0 - t2 / 72.0)));
        let c = 0.5 * (1.0 - t2 / 12.0 * (1.0 - t2 / 30.0 * (1.0 - t2 / 56.0 * (1.0 - t2 / 90.0))));
        let d =
            (1.0 - t2 / 20.0 * (1.0 - t2 / 42.0 * (1.0 - t2 / 72.0 * (1.0 - t2 / 110.0)))) / 6.0;
        (s, c, d)
    } else {
        let t = t2.sqrt();
        let s = t.sin() / t;
        (s, (1.0 - t.cos()) / t2, (1.0 - s) / t2)
    };
    (rodrigues(a, s, c), c, d)
}

/// The statics of one arm: constants taken from the rod model (rest lengths, Voronoi lengths,
/// node weights, node radii, intrinsic strains, design stiffnesses, clamped base) and the
/// preallocated arrays of one sweep (centreline, frames, loads, costates).
#[derive(Debug, Clone)]
pub struct Statics {
    n: usize,
    length: f64,
    space: StrainSpace,
    free_nu: [bool; 3],
    free_kappa: [bool; 3],
    rest_length: Vec<f64>,
    voronoi_length: Vec<f64>,
    node_weight: Vec<f64>,
    node_radius: Vec<f64>,
    arc_length: Vec<f64>,
    base_position: Vec3,
    base_frame: Mat3,
    rest: StrainField,
    shear_design: Vec<Vec3>,
    bend_design: Vec<Vec3>,
    precond: Vec<f64>,
    // Sweep workspace.
    position: Vec<Vec3>,
    frame: Vec<Mat3>,
    rot_c: Vec<f64>,
    rot_d: Vec<f64>,
    load: Vec<Vec3>,
    force: Vec<Vec3>,
    couple: Vec<Vec3>,
}

impl Statics {
    /// Statics of `model` (clamped base) in the given strain space, with the clamped base
    /// position and frame (rows d1, d2, d3) taken from node 0 and element 0 of `state`, and the
    /// design stiffness floor of a section of diameter `floor_diameter` [m] (spec §2.7; 4 mm by
    /// default, 0 for the paper-literal problem). Node radii ρ_i are the element radii
    /// interpolated linearly to the nodes (exact for a linear taper).
    pub fn new(
        model: &RodModel,
        state: &RodState,
        space: StrainSpace,
        floor_diameter: f64,
    ) -> Result<Self, StaticsError> {
        if !(floor_diameter.is_finite() && floor_diameter >= 0.0) {
            return Err(StaticsError::OutOfRange {
                field: "floor_diameter",
                value: floor_diameter,
                range: "[0, inf)",
            });
        }
        Self::with_base(
            model,
            space,
            floor_diameter,
            state.position[0],
            state.director[0],
        )
    }

    fn with_base(
        model: &RodModel,
        space: StrainSpace,
        floor_diameter: f64,
        base_position: Vec3,
        base_frame: Mat3,
    ) -> Result<Self, StaticsError> {
        let n = model.n_elements;
        let (free_nu, free_kappa) = match space {
            StrainSpace::Full => ([true; 3], [true; 3]),
            StrainSpace::Planar => {
                // The out-of-plane director (along ±e_z) carries the in-plane bend; the other
                // transverse director carries the in-plane shear.
                let ez = |r: usize| base_frame[r][2].abs();
                let a = if ez(0) > 1.0 - 1e-9 {
                    0
                } else if ez(1) > 1.0 - 1e-9 {
                    1
                } else {
                    return Err(StaticsError::NotPlanar { frame: base_frame });
                };
                if ez(2) > 1e-9 {
                    return Err(StaticsError::NotPlanar { frame: base_frame });
                }
                let mut nu = [false, false, true];
                nu[1 - a] = true;
                let mut kappa = [false; 3];
                kappa[a] = true;
                (nu, kappa)
            }
        };
        let m = &model.material;
        let area = PI * floor_diameter * floor_diameter / 4.0;
        let second = area * area / (4.0 * PI);
        let alpha_g_a = m.shear_coefficient * m.shear_modulus * area;
        let shear_floor = [alpha_g_a, alpha_g_a, m.youngs_modulus * area];
        let bend_floor = [
            m.youngs_modulus * second,
            m.youngs_modulus * second,
            m.shear_modulus * 2.0 * second,
        ];
        let floor = |v: &Vec3, f: &Vec3| [v[0].max(f[0]), v[1].max(f[1]), v[2].max(f[2])];
        let shear_design: Vec<Vec3> = model
            .shear_stiffness
            .iter()
            .map(|s| floor(s, &shear_floor))
            .collect();
        let bend_design: Vec<Vec3> = model
            .bend_stiffness
            .iter()
            .map(|b| floor(b, &bend_floor))
            .collect();
        let mut precond = vec![0.0; 6 * n - 3];
        for j in 0..n {
            for c in 0..3 {
                precond[3 * j + c] = model.rest_length[j] * shear_design[j][c];
            }
        }
        for k in 0..n - 1 {
            for c in 0..3 {
                precond[3 * n + 3 * k + c] = model.rest_voronoi_length[k] * bend_design[k][c];
            }
        }
        // Node radii: linear interpolation of the element radii between element midpoints,
        // linear extrapolation at both ends.
        let l = &model.rest_length;
        let r = &model.radius;
        let mut node_radius = vec![0.0; n + 1];
        for i in 1..n {
            node_radius[i] = (r[i - 1] * l[i] + r[i] * l[i - 1]) / (l[i - 1] + l[i]);
        }
        node_radius[0] = (r[0] + (r[0] - r[1]) * l[0] / (l[0] + l[1])).max(0.0);
        node_radius[n] =
            (r[n - 1] + (r[n - 1] - r[n - 2]) * l[n - 1] / (l[n - 1] + l[n - 2])).max(0.0);
        Ok(Self {
            n,
            length: model.length(),
            space,
            free_nu,
            free_kappa,
            rest_length: model.rest_length.clone(),
            voronoi_length: model.rest_voronoi_length.clone(),
            node_weight: model.nodal_rest_length.clone(),
            node_radius,
            arc_length: model.node_arc_length.clone(),
            base_position,
            base_frame,
            rest: StrainField::intrinsic(model),
            shear_design,
            bend_design,
            precond,
            position: vec![base_position; n + 1],
            frame: vec![base_frame; n],
            rot_c: vec![0.0; n - 1],
            rot_d: vec![0.0; n - 1],
            load: vec![[0.0; 3]; n + 1],
            force: vec![[0.0; 3]; n],
            couple: vec![[0.0; 3]; n + 1],
        })
    }

    /// Number of elements n.
    pub fn n_elements(&self) -> usize {
        self.n
    }

    /// Rest length L0 of the arm [m].
    pub fn length(&self) -> f64 {
        self.length
    }

    /// The strain space (planar or full).
    pub fn space(&self) -> StrainSpace {
        self.space
    }

    /// True in the planar strain space.
    pub fn is_planar(&self) -> bool {
        self.space == StrainSpace::Planar
    }

    /// Which components of ν (per element) and κ (per interior point) are free.
    pub fn free_components(&self) -> ([bool; 3], [bool; 3]) {
        (self.free_nu, self.free_kappa)
    }

    /// Clamped base position r_0 [m].
    pub fn base_position(&self) -> Vec3 {
        self.base_position
    }

    /// Clamped base frame Q_0 (rows d1, d2, d3).
    pub fn base_frame(&self) -> Mat3 {
        self.base_frame
    }

    /// Local arm radius ρ_i at each node [m] (task geometry).
    pub fn node_radius(&self) -> &[f64] {
        &self.node_radius
    }

    /// Rest length ℓ̂_j per element [m].
    pub fn rest_length(&self) -> &[f64] {
        &self.rest_length
    }

    /// Rest Voronoi length D̂_k per interior point [m].
    pub fn voronoi_length(&self) -> &[f64] {
        &self.voronoi_length
    }

    /// Node weights ω_i [m] (trapezoid rule: ℓ̂_0/2, D̂_k, ℓ̂_{n−1}/2).
    pub fn node_weight(&self) -> &[f64] {
        &self.node_weight
    }

    /// Rest arc length s_i of each node [m].
    pub fn arc_length(&self) -> &[f64] {
        &self.arc_length
    }

    /// Intrinsic strains w° = (ν°, κ°).
    pub fn rest(&self) -> &StrainField {
        &self.rest
    }

    /// Design shear/stretch stiffness S^d per element [N] (floored).
    pub fn shear_design(&self) -> &[Vec3] {
        &self.shear_design
    }

    /// Design bend/twist stiffness B^d per interior point [N m²] (floored).
    pub fn bend_design(&self) -> &[Vec3] {
        &self.bend_design
    }

    /// The diagonal metric P = diag(ℓ̂_j S^d_j, D̂_k B^d_k), flat like a `StrainField`.
    pub fn preconditioner(&self) -> &[f64] {
        &self.precond
    }

    /// Centreline r_i of the last forward map [m], n + 1 nodes.
    pub fn position(&self) -> &[Vec3] {
        &self.position
    }

    /// Frames Q_j of the last forward map, n elements.
    pub fn frame(&self) -> &[Mat3] {
        &self.frame
    }

    /// Force costate n_j (lab) of the last sweep [N], per element: the internal force.
    pub fn force_costate(&self) -> &[Vec3] {
        &self.force
    }

    /// Couple costate m_i (lab) of the last sweep [N m], per node (m_0 unused, m_n = 0); the
    /// couple at interior point k is `couple_costate()[k + 1]`.
    pub fn couple_costate(&self) -> &[Vec3] {
        &self.couple
    }

    /// Zero the components the strain space does not free.
    pub fn mask(&self, v: &mut [f64]) {
        let n = self.n;
        for j in 0..n {
            for c in 0..3 {
                if !self.free_nu[c] {
                    v[3 * j + c] = 0.0;
                }
            }
        }
        for k in 0..n - 1 {
            for c in 0..3 {
                if !self.free_kappa[c] {
                    v[3 * n + 3 * k + c] = 0.0;
                }
            }
        }
    }

    /// Forward map (spec §2.2): Q_{k+1} = exp(−D̂_k[κ_k]×) Q_k, r_{j+1} = r_j + ℓ̂_j Q_jᵀ ν_j.
    pub fn forward(&mut self, w: &StrainField) {
        let n = self.n;
        debug_assert_eq!(w.n_elements(), n);
        let wd = w.as_slice();
        let frame = &mut self.frame[..n];
        let pos = &mut self.position[..n + 1];
        let dr = &self.voronoi_length[..n - 1];
        let lr = &self.rest_length[..n];
        frame[0] = self.base_frame;
        pos[0] = self.base_position;
        for k in 0..n - 1 {
            let o = 3 * n + 3 * k;
            let a = [dr[k] * wd[o], dr[k] * wd[o + 1], dr[k] * wd[o + 2]];
            let (r, c, d) = rotation(a);
            self.rot_c[k] = c;
            self.rot_d[k] = d;
            frame[k + 1] = mat_mul(&r, &frame[k]);
        }
        for j in 0..n {
            let t = mat_t_vec(&frame[j], [wd[3 * j], wd[3 * j + 1], wd[3 * j + 2]]);
            pos[j + 1] = [
                pos[j][0] + lr[j] * t[0],
                pos[j][1] + lr[j] * t[1],
                pos[j][2] + lr[j] * t[2],
            ];
        }
    }

    /// Task loads g_i = ∂G/∂r_i at the current centreline (spec §2.3) into the load array, and
    /// the task terms of the cost.
    fn task_loads(&mut self, task: &Task, terms: &mut CostTerms) {
        let n = self.n;
        let pos = &self.position[..n + 1];
        let g = &mut self.load[..n + 1];
        g.fill([0.0; 3]);
        match task.tip {
            TipTerm::None => {}
            TipTerm::Target { position, weight } => {
                let d = sub(pos[n], position);
                terms.tip = 0.5 * weight * dot(d, d);
                g[n] = [weight * d[0], weight * d[1], weight * d[2]];
            }
            TipTerm::Force(f) => {
                terms.tip = -dot(f, pos[n]);
                g[n] = [-f[0], -f[1], -f[2]];
            }
        }
        for o in &task.obstacles {
            let mut q = 0.0;
            for i in 1..=n {
                let d = sub(o.center, pos[i]);
                let reach = 0.5 * o.diameter + self.node_radius[i];
                let psi = reach * reach - dot(d, d);
                if psi > 0.0 {
                    let wgt = self.node_weight[i] * o.weight;
                    q += wgt * psi;
                    // ∇c = 2(p − r) while inside.
                    g[i] = [
                        g[i][0] + 2.0 * wgt * d[0],
                        g[i][1] + 2.0 * wgt * d[1],
                        g[i][2] + 2.0 * wgt * d[2],
                    ];
                }
            }
            terms.obstacle += q;
        }
        if let Some(gr) = &task.grasp {
            let eps = gr.smoothing;
            for i in 1..=n {
                let mu = gr.weight_at(i, self.arc_length[i], self.length);
                if mu == 0.0 {
                    continue;
                }
                let d = sub(pos[i], gr.center);
                let dist = norm(d);
                let zeta = dist - (gr.radius + self.node_radius[i]);
                let root = (zeta * zeta + eps * eps).sqrt();
                let wgt = self.node_weight[i] * mu;
                terms.grasp += wgt * (root - eps);
                if dist > 0.0 && root > 0.0 {
                    let f = wgt * zeta / root / dist;
                    g[i] = [g[i][0] + f * d[0], g[i][1] + f * d[1], g[i][2] + f * d[2]];
                }
            }
        }
    }

    /// Task terms of the cost at the current centreline (after `forward`), without the strain
    /// energy and without touching the costates.
    pub fn task_cost(&mut self, task: &Task) -> CostTerms {
        let mut t = CostTerms::default();
        self.task_loads(task, &mut t);
        t.total = t.tip + t.grasp + t.obstacle;
        t
    }

    /// One sweep (spec §2.5): forward map, task loads, backward costates, and the gradient
    /// ∂J/∂w written into `grad` (length 6n − 3, masked components zero). Returns the cost.
    pub fn sweep(&mut self, w: &StrainField, task: &Task, grad: &mut [f64]) -> CostTerms {
        let n = self.n;
        self.forward(w);
        let mut terms = CostTerms::default();
        self.task_loads(task, &mut terms);

        // Backward sweep (spec §2.4): n_{n−1} = −g_n, n_{j−1} = n_j − g_j;
        // m_n = 0, m_i = m_{i+1} + (r_{i+1} − r_i) × n_i.
        let g = &self.load[..n + 1];
        let pos = &self.position[..n + 1];
        let nf = &mut self.force[..n];
        let mc = &mut self.couple[..n + 1];
        nf[n - 1] = [-g[n][0], -g[n][1], -g[n][2]];
        for j in (1..n).rev() {
            nf[j - 1] = [nf[j][0] - g[j][0], nf[j][1] - g[j][1], nf[j][2] - g[j][2]];
        }
        mc[n] = [0.0; 3];
        for i in (1..n).rev() {
            let c = cross(sub(pos[i + 1], pos[i]), nf[i]);
            mc[i] = [
                mc[i + 1][0] + c[0],
                mc[i + 1][1] + c[1],
                mc[i + 1][2] + c[2],
            ];
        }
        mc[0] = [0.0; 3];

        // Gradient (spec §2.5) and strain energy.
        let wd = w.as_slice();
        let rd = self.rest.as_slice();
        let frame = &self.frame[..n];
        let grad = &mut grad[..6 * n - 3];
        let mut strain = 0.0;
        for j in 0..n {
            let o = 3 * j;
            let qn = mat_vec(&frame[j], nf[j]);
            let s = self.shear_design[j];
            let lj = self.rest_length[j];
            let mut e = 0.0;
            for c in 0..3 {
                let dv = wd[o + c] - rd[o + c];
                let sd = s[c] * dv;
                e += sd * dv;
                grad[o + c] = if self.free_nu[c] {
                    lj * (sd - qn[c])
                } else {
                    0.0
                };
            }
            strain += 0.5 * lj * e;
        }
        for k in 0..n - 1 {
            let o = 3 * n + 3 * k;
            let dk = self.voronoi_length[k];
            let a = [dk * wd[o], dk * wd[o + 1], dk * wd[o + 2]];
            let qm = mat_vec(&frame[k + 1], mc[k + 1]);
            // J_r(−D̂κ) Q m = v + c a×v + d a×(a×v).
            let axv = cross(a, qm);
            let aaxv = cross(a, axv);
            let (c1, d1) = (self.rot_c[k], self.rot_d[k]);
            let jm = [
                qm[0] + c1 * axv[0] + d1 * aaxv[0],
                qm[1] + c1 * axv[1] + d1 * aaxv[1],
                qm[2] + c1 * axv[2] + d1 * aaxv[2],
            ];
            let b = self.bend_design[k];
            let mut e = 0.0;
            for c in 0..3 {
                let dv = wd[o + c] - rd[o + c];
                let bd = b[c] * dv;
                e += bd * dv;
                grad[o + c] = if self.free_kappa[c] {
                    dk * (bd - jm[c])
                } else {
                    0.0
                };
            }
            strain += 0.5 * dk * e;
        }
        terms.strain = strain;
        terms.total = strain + terms.tip + terms.grasp + terms.obstacle;
        terms
    }

    /// Strain residual ε_res of a gradient (spec §3.2): the largest |(P⁻¹∂J)_c|, with the κ
    /// components multiplied by L0 so that both are dimensionless strains.
    pub fn residual(&self, grad: &[f64]) -> f64 {
        let off = 3 * self.n;
        let mut r: f64 = 0.0;
        for (c, (g, p)) in grad.iter().zip(&self.precond).enumerate() {
            let v = (g / p).abs() * if c >= off { self.length } else { 1.0 };
            r = r.max(v);
        }
        r
    }

    /// Distance from the tip of the last forward map to the task's target [m] (0 without one).
    pub fn tip_error(&self, task: &Task) -> f64 {
        task.target()
            .map_or(0.0, |t| norm(sub(self.position[self.n], t)))
    }

    /// Largest penetration of the last forward map into any obstacle,
    /// max_{i,j} ((φ_j + φ(s_i))/2 − |p_j − r_i|)₊ [m], with the obstacle and node index.
    pub fn max_penetration(&self, task: &Task) -> (f64, usize, usize) {
        let mut worst = (0.0, 0, 0);
        for (j, o) in task.obstacles.iter().enumerate() {
            for i in 1..=self.n {
                let p =
                    0.5 * o.diameter + self.node_radius[i] - norm(sub(o.center, self.position[i]));
                if p > worst.0 {
                    worst = (p, j, i);
                }
            }
        }
        worst
    }

    /// Each obstacle's term ξ_j q̂_j(L0) at the last forward map [J].
    pub fn obstacle_costs(&self, task: &Task) -> Vec<f64> {
        task.obstacles
            .iter()
            .map(|o| {
                (1..=self.n)
                    .map(|i| {
                        let d = sub(o.center, self.position[i]);
                        let reach = 0.5 * o.diameter + self.node_radius[i];
                        self.node_weight[i] * o.weight * (reach * reach - dot(d, d)).max(0.0)
                    })
                    .sum()
            })
            .collect()
    }

    /// The rod state (at rest) whose centreline and frames are the forward map of `w`: feeding
    /// it to the physics crate's strain measurement returns w (spec §7 test 1).
    pub fn state_of(&mut self, w: &StrainField) -> RodState {
        self.forward(w);
        RodState {
            time: 0.0,
            position: self.position.clone(),
            velocity: vec![[0.0; 3]; self.n + 1],
            director: self.frame.clone(),
            omega: vec![[0.0; 3]; self.n],
        }
    }
}
