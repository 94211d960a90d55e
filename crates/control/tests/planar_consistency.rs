//! Claim (spec §7 test 3, §2.1, §1.2): with the planar mask, the 3D sweep is a consistent,
//! second-order discretisation of the paper's planar costate equations. For a prescribed smooth
//! planar strain field on the paper's tapered arm and a tip task, the couple costate
//! (Q_k m_k)_2 = e_z·m_k at every interior point converges to the paper's λ3(s_k), the lab force
//! costate n_j to the paper's constant (λ1, λ2), its material components ((Q_j n_j)_3, (Q_j n_j)_1)
//! to the paper's (n1, n2) at the element midpoints, and the masked gradient brackets to minus the
//! paper's pointwise Hamiltonian gradient (n1 − EA(ν1 − 1), n2 − α_c GA ν2, λ3 − EI κ), all with
//! error ratio ≈ 4 when ℓ̂ is halved (N = 25, 50, 100, 200). Also: the arm and the costates stay in
//! the plane (z = 0, n_z = 0, m_x = m_y = 0) and the masked gradient components are exactly zero.
//!
//! Independent reference: the paper's planar ODEs written in the paper's own variables, with the
//! analytic strain fields ν1(s) (stretch), ν2(s) (shear), κ(s) and the analytic taper φ(s):
//! θ' = κ, (x, y)' = ν1 a(θ) + ν2 b(θ) with a = (cos θ, sin θ), b = (−sin θ, cos θ), λ1, λ2 constant
//! (= μ_tip (r* − r(L0)), no running cost), λ3' = −ν1(−λ1 sin θ + λ2 cos θ) + ν2(λ1 cos θ + λ2 sin θ)
//! integrated backwards from λ3(L0) = 0, all with the trapezoid rule on a fine grid of
//! 51 200 intervals (no rotation matrices, no cross products, no code of the control crate).
//! The reference's own error is checked by comparison with the same integration on 25 600
//! intervals (trapezoid: 4× smaller on the finer grid) and must be ≤ 1e-2 of the smallest
//! discrete error, so it does not pollute the ratios.
//!
//! The simulator side is sampled per §1.2: simulator ν3 = paper ν1 and ν1 = paper ν2 at the element
//! midpoints s_{j+1/2}; simulator κ2 = paper κ at the interior nodes (our `kappa(k)` sits at node
//! k + 1, s = (k + 1) ℓ̂; its couple is `couple_costate()[k + 1]`, rotated by the distal frame
//! `frame()[k + 1]`). κ(0) = 0 is chosen on purpose: the clamped first half element carries no
//! curvature, which for κ(0) ≠ 0 is a genuine O(ℓ̂) modelling difference, not an error.
//!
//! Why the discrete solution is second order: in the plane all frame rotations are about e_z, so
//! θ_j = ℓ̂ Σ_{k ≤ j} κ(s_k) is the midpoint rule for θ(s_{j+1/2}) (the missing ∫_0^{ℓ̂/2} κ is
//! O(ℓ̂²) because κ(0) = 0); r_{j+1} − r_j = ℓ̂ ν(s_{j+1/2}) in the frame θ_j is the midpoint rule
//! for r; n_j is exact given r_N; and m_k = (r_N − r_k) × n is the continuous λ3(s_k) evaluated on
//! the discrete centreline. Every error is therefore C ℓ̂² + O(ℓ̂³).
//!
//! How a wrong implementation fails: a couple taken one node off (`couple_costate()[k]` or
//! `[k + 2]` for point k) or a frame update applied one element early or late is an O(ℓ̂) error
//! (ratio ≈ 2 < 3.5); a sign error in the κ rotation, in the cross product of the couple
//! recursion or in the tip load, or Qᵀ in place of Q (rows vs columns), is an O(1) error that
//! does not decrease at all; a wrong mask (e.g. freeing κ1 instead of κ2 for this frame) fails the
//! free-component check and zeroes the in-plane bend gradient (bracket error O(1)).
//!
//! Errors are relative (to max|λ3|, |(λ1, λ2)|, max|bracket|) and maxima over the points of each
//! grid; λ3 is also measured on the 24 interior nodes of the coarsest grid (s = i L0/25), which
//! are nodes of every grid, so that its ratio is the pointwise one.
//!
//! Tolerances: ratio ∈ [3.5, 4.5]. A first-order error gives 2 (checked by mutation: comparing
//! with `couple_costate()[k + 2]` gives ratios 1.98–2.00), so 3.5 separates the orders with
//! margin; the band allows the higher-order corrections (measured: 3.996–4.020 for the pointwise
//! and force errors; 3.64, 3.83, 3.92 for the all-node λ3 maximum, whose first node s = ℓ̂ moves
//! with N — see the assertion). Planarity and the constancy of n: 1e-12 relative (round-off of
//! ~N additions of O(1) terms). Masked gradient components: exactly 0 (the code writes 0).

mod common;
use common::*;
use octoarm_control::{Statics, StrainField, StrainSpace, Task};
use octoarm_physics::math::mat_vec;
use octoarm_physics::{Material, StraightRod};
use std::f64::consts::PI;

/// Nodes of the coarsest grid (s = i L0 / 25) are nodes of every grid.
const COMMON: usize = 25;
const MU_TIP: f64 = 1.0; // N/m: costates of the same size as the stiffness terms of the brackets.
const TARGET: [f64; 3] = [0.06, 0.12, 0.0];
const BASE_DIAMETER: f64 = 0.02;
const TIP_DIAMETER: f64 = 0.0004;
const E: f64 = 1.0e4;
const G: f64 = 1.0e3;

/// Paper's stretch ν1(s).
fn nu1(s: f64) -> f64 {
    1.0 + 0.04 * (2.0 * PI * s / L0).cos() + 0.02 * s / L0
}

/// Paper's shear ν2(s).
fn nu2(s: f64) -> f64 {
    0.03 * (PI * s / L0 + 0.3).sin()
}

/// Paper's curvature κ(s) [1/m], κ(0) = 0; total turning θ(L0) ≈ 2.27 rad.
fn kappa(s: f64) -> f64 {
    (6.0 / L0) * (1.5 * PI * s / L0).sin() + (3.0 / L0) * (s / L0).powi(2)
}

/// Paper's taper φ(s) (spec §1.3) and stiffnesses EA, α_c GA, EI of a disc section.
fn diameter(s: f64) -> f64 {
    BASE_DIAMETER + (TIP_DIAMETER - BASE_DIAMETER) * s / L0
}
fn ea(s: f64) -> f64 {
    E * PI * diameter(s).powi(2) / 4.0
}
fn alpha_ga(s: f64) -> f64 {
    Material::DEFAULT_SHEAR_COEFFICIENT * G * PI * diameter(s).powi(2) / 4.0
}
fn ei(s: f64) -> f64 {
    E * PI * diameter(s).powi(4) / 64.0
}

/// The paper's planar solution on a uniform grid of `m` intervals (trapezoid rule): θ, x, y, λ3
/// at the grid nodes and the constant (λ1, λ2).
struct Reference {
    m: usize,
    theta: Vec<f64>,
    lambda3: Vec<f64>,
    lambda: [f64; 2],
    tip: [f64; 2],
}

fn reference(m: usize) -> Reference {
    let h = L0 / m as f64;
    let s = |i: usize| i as f64 * h;
    let mut theta = vec![0.0; m + 1];
    for i in 0..m {
        theta[i + 1] = theta[i] + 0.5 * h * (kappa(s(i)) + kappa(s(i + 1)));
    }
    let drds = |i: usize| {
        let (c, sn) = (theta[i].cos(), theta[i].sin());
        let (a, b) = (nu1(s(i)), nu2(s(i)));
        [a * c - b * sn, a * sn + b * c]
    };
    let (mut x, mut y) = (0.0, 0.0);
    for i in 0..m {
        let (p, q) = (drds(i), drds(i + 1));
        x += 0.5 * h * (p[0] + q[0]);
        y += 0.5 * h * (p[1] + q[1]);
    }
    let lambda = [MU_TIP * (TARGET[0] - x), MU_TIP * (TARGET[1] - y)];
    let rhs = |i: usize| {
        let (c, sn) = (theta[i].cos(), theta[i].sin());
        let (l1, l2) = (lambda[0], lambda[1]);
        -nu1(s(i)) * (-l1 * sn + l2 * c) + nu2(s(i)) * (l1 * c + l2 * sn)
    };
    let mut lambda3 = vec![0.0; m + 1];
    for i in (0..m).rev() {
        // λ3(s_i) = λ3(s_{i+1}) − ∫_{s_i}^{s_{i+1}} λ3' ds.
        lambda3[i] = lambda3[i + 1] - 0.5 * h * (rhs(i) + rhs(i + 1));
    }
    Reference {
        m,
        theta,
        lambda3,
        lambda,
        tip: [x, y],
    }
}

impl Reference {
    /// Grid index of arc length `num/den · L0` (exact by construction of the grids).
    fn at(&self, num: usize, den: usize) -> usize {
        assert_eq!((self.m * num) % den, 0, "grid does not contain the point");
        self.m * num / den
    }
}

/// Relative errors of one discretisation against the reference.
#[derive(Debug, Clone, Copy)]
struct Errors {
    lambda3: f64,
    lambda3_common: f64,
    force_lab: f64,
    force_material: f64,
    bracket: f64,
}

fn discrete_errors(n: usize, refr: &Reference) -> Errors {
    let (model, state) = StraightRod::paper_arm().with_elements(n).build().unwrap();
    // Floor 0: the design stiffnesses are the rod's own, as in the paper.
    let mut st = Statics::new(&model, &state, StrainSpace::Planar, 0.0).unwrap();
    assert_eq!(
        st.free_components(),
        ([true, false, true], [false, true, false])
    );
    let dl = L0 / n as f64;
    let mut w = StrainField::intrinsic(&model);
    for j in 0..n {
        let s = (j as f64 + 0.5) * dl;
        // §1.2: simulator ν = (paper ν2, 0, paper ν1) in (d1, d2, d3).
        w.set_nu(j, [nu2(s), 0.0, nu1(s)]);
    }
    for k in 0..n - 1 {
        // Our interior point k sits at node k + 1.
        w.set_kappa(k, [0.0, kappa((k + 1) as f64 * dl), 0.0]);
    }
    let task = Task::reach(TARGET, MU_TIP);
    task.validate(&st).unwrap();
    let mut grad = vec![0.0; 6 * n - 3];
    st.sweep(&w, &task, &mut grad);

    let pos = st.position();
    let frame = st.frame();
    let nf = st.force_costate();
    let mc = st.couple_costate();
    let lam = refr.lambda;
    let lam_norm = lam[0].hypot(lam[1]);
    let l3_scale = refr.lambda3.iter().fold(0.0f64, |a, v| a.max(v.abs()));

    // Planarity (fixed-point set of the 3D model) and masked components.
    let ez_tol = 1e-12;
    for p in pos {
        assert!(p[2].abs() <= ez_tol * L0, "node off the plane: {p:?}");
    }
    for q in frame {
        assert!((q[1][2] - 1.0).abs() <= ez_tol, "d2 is not e_z: {q:?}");
    }
    for v in nf {
        assert!(v[2].abs() <= ez_tol * lam_norm, "n_z = {}", v[2]);
    }
    for v in mc {
        let worst = v[0].abs().max(v[1].abs());
        assert!(worst <= ez_tol * l3_scale, "in-plane couple {v:?}");
    }
    for j in 0..n {
        assert_eq!(grad[3 * j + 1], 0.0, "masked ν2 gradient at element {j}");
    }
    for k in 0..n - 1 {
        let o = 3 * n + 3 * k;
        assert_eq!(grad[o], 0.0, "masked κ1 gradient at point {k}");
        assert_eq!(grad[o + 2], 0.0, "masked κ3 gradient at point {k}");
    }
    // No running cost: n is the same on every element (to round-off).
    for v in nf {
        let d = (v[0] - nf[0][0]).hypot(v[1] - nf[0][1]);
        assert!(
            d <= 1e-12 * lam_norm,
            "n not constant: {v:?} vs {:?}",
            nf[0]
        );
    }

    // λ3 against (Q_k m_k)_2 at every interior point (node i = k + 1, distal frame i).
    let mut e_l3: f64 = 0.0;
    let mut e_l3_common: f64 = 0.0;
    let mut e_br: f64 = 0.0;
    let mut br_scale: f64 = 0.0;
    for k in 0..n - 1 {
        let i = k + 1;
        let l3 = mat_vec(&frame[i], mc[i])[1];
        let r = refr.at(i, n);
        e_l3 = e_l3.max((l3 - refr.lambda3[r]).abs());
        if (i * COMMON) % n == 0 {
            e_l3_common = e_l3_common.max((l3 - refr.lambda3[r]).abs());
        }
        // Bend bracket: ∂J/∂κ_2 / D̂ = EI κ − λ3 (J_r is exact identity on the in-plane axis).
        let s = i as f64 * dl;
        let paper = ei(s) * kappa(s) - refr.lambda3[r];
        let code = grad[3 * n + 3 * k + 1] / model.rest_voronoi_length[k];
        e_br = e_br.max((code - paper).abs());
        br_scale = br_scale.max(paper.abs());
    }
    // Force costates: lab (λ1, λ2) and material (n1, n2) = ((Q n)_3, (Q n)_1) at midpoints.
    let e_lab = (nf[0][0] - lam[0]).hypot(nf[0][1] - lam[1]);
    let mut e_mat: f64 = 0.0;
    let mut br_nu: Vec<(f64, f64)> = Vec::with_capacity(2 * n);
    for j in 0..n {
        let qn = mat_vec(&frame[j], nf[j]);
        let r = refr.at(2 * j + 1, 2 * n);
        let th = refr.theta[r];
        let n1 = lam[0] * th.cos() + lam[1] * th.sin();
        let n2 = -lam[0] * th.sin() + lam[1] * th.cos();
        e_mat = e_mat.max((qn[2] - n1).abs().max((qn[0] - n2).abs()));
        // Shear/stretch brackets: ∂J/∂ν / ℓ̂ = (α_c GA ν2 − n2, ·, EA(ν1 − 1) − n1).
        let s = (j as f64 + 0.5) * dl;
        br_nu.push((
            grad[3 * j + 2] / dl - (ea(s) * (nu1(s) - 1.0) - n1),
            grad[3 * j] / dl - (alpha_ga(s) * nu2(s) - n2),
        ));
        br_scale = br_scale
            .max((ea(s) * (nu1(s) - 1.0) - n1).abs())
            .max((alpha_ga(s) * nu2(s) - n2).abs());
    }
    for (a, b) in br_nu {
        e_br = e_br.max(a.abs()).max(b.abs());
    }
    Errors {
        lambda3: e_l3 / l3_scale,
        lambda3_common: e_l3_common / l3_scale,
        force_lab: e_lab / lam_norm,
        force_material: e_mat / lam_norm,
        bracket: e_br / br_scale,
    }
}

#[test]
fn planar_costates_converge_to_the_papers_equations_at_second_order() {
    let fine = reference(51_200);
    let coarse = reference(25_600);
    let ns = [25usize, 50, 100, 200];
    println!(
        "reference: tip ({:.6}, {:.6}) m, (λ1, λ2) = ({:.5e}, {:.5e}) N, max|λ3| = {:.4e} N m, θ(L0) = {:.4} rad",
        fine.tip[0],
        fine.tip[1],
        fine.lambda[0],
        fine.lambda[1],
        fine.lambda3.iter().fold(0.0f64, |a, v| a.max(v.abs())),
        fine.theta[fine.m]
    );
    // The reference's own error: |ref(h) − ref(2h)| ≈ 3 × error(ref(h)).
    let mut ref_err: f64 = 0.0;
    for i in 0..=coarse.m {
        ref_err = ref_err.max((fine.lambda3[2 * i] - coarse.lambda3[i]).abs());
    }
    let l3_scale = fine.lambda3.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let ref_err = ref_err / l3_scale / 3.0;
    let lam_err = (fine.lambda[0] - coarse.lambda[0]).hypot(fine.lambda[1] - coarse.lambda[1])
        / fine.lambda[0].hypot(fine.lambda[1])
        / 3.0;
    println!("reference error estimate: λ3 {ref_err:.2e}, (λ1, λ2) {lam_err:.2e} (relative)");

    let errors: Vec<Errors> = ns.iter().map(|&n| discrete_errors(n, &fine)).collect();
    println!("   N   λ3 (common) ratio   λ3 err     ratio   n lab err  ratio   n mat err  ratio   bracket err ratio");
    for (i, (n, e)) in ns.iter().zip(&errors).enumerate() {
        let ratio = |f: fn(&Errors) -> f64| {
            if i == 0 {
                f64::NAN
            } else {
                f(&errors[i - 1]) / f(e)
            }
        };
        println!(
            "{n:4}   {:.3e}  {:5.3}   {:.3e}  {:5.3}   {:.3e}  {:5.3}   {:.3e}  {:5.3}   {:.3e}  {:5.3}",
            e.lambda3_common,
            ratio(|e| e.lambda3_common),
            e.lambda3,
            ratio(|e| e.lambda3),
            e.force_lab,
            ratio(|e| e.force_lab),
            e.force_material,
            ratio(|e| e.force_material),
            e.bracket,
            ratio(|e| e.bracket),
        );
    }
    let smallest = errors.last().unwrap();
    assert!(
        ref_err <= 1e-2 * smallest.lambda3,
        "reference not accurate enough"
    );
    assert!(
        lam_err <= 1e-2 * smallest.force_lab,
        "reference not accurate enough"
    );
    for pair in errors.windows(2) {
        // All-node maximum of the λ3 error: its first node s = ℓ̂ moves with N, which adds a
        // relative O(ℓ̂) sampling term near the base (ratio 4(1 + cℓ̂)/(1 + cℓ̂/2) → 4 from below);
        // the spec's 3.5 still separates it from first order (2).
        let ratio = pair[0].lambda3 / pair[1].lambda3;
        assert!(
            (3.5..=4.5).contains(&ratio),
            "λ3 (all nodes): error ratio {ratio:.3} under halving ℓ̂"
        );
        for (name, a, b) in [
            (
                "λ3 (common nodes)",
                pair[0].lambda3_common,
                pair[1].lambda3_common,
            ),
            ("n (lab)", pair[0].force_lab, pair[1].force_lab),
            (
                "n (material)",
                pair[0].force_material,
                pair[1].force_material,
            ),
            ("brackets", pair[0].bracket, pair[1].bracket),
        ] {
            let ratio = a / b;
            assert!(
                (3.5..=4.5).contains(&ratio),
                "{name}: error ratio {ratio:.3} under halving ℓ̂ ({a:.3e} → {b:.3e})"
            );
        }
    }
    // And the errors are small in absolute terms at N = 200 (second order from an O(1) constant:
    // C (1/200)² with C of order 1 is ~1e-4; a mapping error would be O(1)).
    assert!(smallest.lambda3 < 1e-3);
    assert!(smallest.lambda3_common < 1e-3);
    assert!(smallest.force_lab < 1e-3);
    assert!(smallest.force_material < 1e-3);
    assert!(smallest.bracket < 1e-3);
}
