//! Claims (muscles-3d spec §8.1–8.3, 8.6–8.8): the muscle kernel, the drag and the `coomm`
//! damping preset.
//!
//! Independent references: the closed forms of spec §8 for one muscle group on a uniform rod
//! (derived by hand from eqs. 2.1–2.5 and 4.1; their numbers were reproduced by COOMM's statics):
//! a longitudinal muscle LMk at uniform activation holds the arm at uniform stretch
//! e = 1 − c f and curvature κ = 4cρ f e^{3/2}/r̂ about d3 × u (towards the muscle); the transverse
//! muscle at uniform stretch e = 1 + c_T f(e^{−1/2}) with no bending. The discrete equilibrium is
//! pointwise (spec §4.1), so the configuration built from those strains must have zero net
//! internal load (elastic + muscle) on every free node and element — exactly for the flat curve,
//! away from the two ghost-halved end elements for the cubic one. Further: the external-load
//! form (2.8–2.9) against the fused one; conservation (Σ F = 0), linearity, zero activation;
//! the sign of the oblique groups' twist couple; the drag totals of §8.7 by hand; the damping
//! rates of §3.2.
//!
//! How a wrong implementation fails: a wrong sign of the fibre offset, κ × x̄ in the wrong order,
//! a missing ½ in eq. 2.2, areas without 1/e, radii without e^{−1/2}, or the wrong sign of TM
//! leave a residual of the order of the muscle force; a missing ½ D̂ κ × τ^μ or shear–stretch
//! couple breaks the fused/external agreement; wrong drag areas or node shares change the totals.

#![allow(clippy::needless_range_loop)]

mod common;

use common::{rotation, system_state};
use octoarm_physics::math::{cross, mat_t_vec, norm};
use octoarm_physics::muscles::{group, MuscleScratch, Resultants, Strains};
use octoarm_physics::{
    Damping, EndCondition, ExternalLoads, ForceLength, InternalLoads, Load, Mat3, MuscleModel,
    MuscleSpec, Offsets, RodModel, RodState, Settings, Simulation, StraightRod, Vec3, N_GROUPS,
};

const E: f64 = 1.0e4;

/// Spec §8's uniform rod: L0 = 0.2 m, N = 100, r̂ = 6 mm, E = 10 kPa, G = E/3, COOMM frame.
fn uniform_rod() -> StraightRod {
    let mut r = StraightRod::coomm_arm();
    r.base_diameter = 0.012;
    r.tip_diameter = 0.012;
    r
}

/// COOMM's muscles with curve `f`; the tests activate one group only (the others are skipped
/// exactly by the kernel).
fn one_group(_g: usize, f: ForceLength) -> MuscleSpec {
    MuscleSpec::coomm().with_force_length(f)
}

/// A rod of uniform strain ν = (0, 0, e) and curvature κ (material), built by the forward map
/// Q_{k+1} = exp(−D̂[κ]×) Q_k, x_{j+1} = x_j + l̂ Q_jᵀ ν (rotation with libm, independent of
/// the crate's kernels).
fn uniform_strain_state(model: &RodModel, q0: Mat3, e: f64, kappa: Vec3) -> RodState {
    let n = model.n_elements;
    let mut director = vec![q0; n];
    for k in 0..n - 1 {
        let d = model.rest_voronoi_length[k];
        let r = rotation([-d * kappa[0], -d * kappa[1], -d * kappa[2]]);
        let q = director[k];
        let mut next = [[0.0; 3]; 3];
        for a in 0..3 {
            for b in 0..3 {
                next[a][b] = (0..3).map(|c| r[a][c] * q[c][b]).sum();
            }
        }
        director[k + 1] = next;
    }
    let mut position = vec![[0.0; 3]; n + 1];
    for j in 0..n {
        let t = mat_t_vec(&director[j], [0.0, 0.0, e * model.rest_length[j]]);
        position[j + 1] = [
            position[j][0] + t[0],
            position[j][1] + t[1],
            position[j][2] + t[2],
        ];
    }
    RodState {
        time: 0.0,
        position,
        velocity: vec![[0.0; 3]; n + 1],
        director,
        omega: vec![[0.0; 3]; n],
    }
}

fn coomm_frame() -> Mat3 {
    [[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]
}

/// Activations `[7][n]` with group g at `a`, others 0.
fn activation(n: usize, g: usize, a: f64) -> Vec<Vec<f64>> {
    let mut v = vec![vec![0.0; n]; N_GROUPS];
    v[g].fill(a);
    v
}

fn groups(v: &[Vec<f64>]) -> [&[f64]; N_GROUPS] {
    std::array::from_fn(|g| v[g].as_slice())
}

/// Internal loads (no velocity terms) of `s` with muscles at activations `act` (None: none).
fn loads(
    model: &RodModel,
    mm: Option<&MuscleModel>,
    act: &[Vec<f64>],
    s: &RodState,
) -> InternalLoads {
    let n = model.n_elements;
    let mut out = InternalLoads::for_rod(n);
    out.compute_rod_with_muscles(
        model,
        &system_state(s),
        Offsets::ZERO,
        &vec![[0.0; 3]; n],
        &vec![[0.0; 3]; n - 1],
        false,
        false,
        mm.map(|m| (m, groups(act))),
    );
    out
}

/// Largest |F_i| over nodes `nodes` and |C_j| over elements `elems`.
fn residual(
    l: &InternalLoads,
    nodes: std::ops::Range<usize>,
    elems: std::ops::Range<usize>,
) -> (f64, f64) {
    let f = nodes.map(|i| norm(l.force.get(i))).fold(0.0, f64::max);
    let c = elems.map(|j| norm(l.torque.get(j))).fold(0.0, f64::max);
    (f, c)
}

fn lm_closed_form(a: f64, f: ForceLength) -> (f64, f64, f64) {
    let spec = MuscleSpec::coomm();
    let g = &spec.groups[group::LM0];
    let c = a * g.max_stress * g.area_fraction / E;
    let rho = g.radial;
    // Fixed point f = f_ℓ(λ(f)), λ = e(1 − 4cρ²f), e = 1 − cf (spec eq. 8.1).
    let mut fl = 1.0;
    for _ in 0..200 {
        let e = 1.0 - c * fl;
        fl = f.value(e * (1.0 - 4.0 * c * rho * rho * fl));
    }
    let e = 1.0 - c * fl;
    let k = 4.0 * c * rho * fl * e.powf(1.5) / 0.006;
    (e, k, fl)
}

// Spec §8.1, flat f_ℓ: LM0..LM3 at a = 1 and 0.5; exact equilibrium everywhere; e, κ and LM0's
// discrete tip as the spec gives them.
#[test]
fn longitudinal_muscle_closed_form_flat() {
    let (model, _) = uniform_rod().build().unwrap();
    let n = model.n_elements;
    for (a, e_ref, k_ref, tip_ref) in [
        (1.0, 0.9375, 23.638814, [-0.0387242, 0.0, -0.0399798]),
        (0.5, 0.96875, 12.415275, [0.0494831, 0.0, -0.1391410]),
    ] {
        let (e, k, _) = lm_closed_form(a, ForceLength::Flat);
        assert!((e - e_ref).abs() < 1e-12, "e = {e}");
        assert!((k / k_ref - 1.0).abs() < 5e-8, "κ2 = {k}");
        let mm = MuscleModel::new(one_group(group::LM0, ForceLength::Flat), &model).unwrap();
        for lm in 0..4 {
            let phi = lm as f64 * std::f64::consts::FRAC_PI_2;
            let u = [phi.cos(), phi.sin(), 0.0];
            let kappa = [-k * u[1], k * u[0], 0.0];
            let s = uniform_strain_state(&model, coomm_frame(), e, kappa);
            if lm == 0 {
                let tip = s.position[n];
                for c in 0..3 {
                    assert!(
                        (tip[c] - tip_ref[c]).abs() < 1e-7,
                        "tip {tip:?} vs {tip_ref:?}"
                    );
                }
            }
            let act = activation(n, group::LM0 + lm, a);
            let l = loads(&model, Some(&mm), &act, &s);
            // Scale: the muscle force and its moment.
            let fm = a * 10.0e3 * 0.0625 * model.area[0];
            let (rf, rc) = residual(&l, 1..n + 1, 1..n);
            assert!(
                rf < 1e-9 * fm,
                "LM{lm} a={a}: node residual {rf:e} vs {fm:e}"
            );
            assert!(
                rc < 1e-9 * fm * 0.00375,
                "LM{lm} a={a}: couple residual {rc:e}"
            );
            // A wrong sign or direction: the same state without muscles is far from equilibrium.
            let bare = loads(&model, None, &act, &s);
            let (bf, _) = residual(&bare, 1..n + 1, 1..n);
            assert!(bf > 1e-3 * fm);
        }
    }
}

// Spec §8.1, cubic f_ℓ: the fixed point's numbers; equilibrium away from the end elements.
#[test]
fn longitudinal_muscle_closed_form_cubic() {
    let (model, _) = uniform_rod().build().unwrap();
    let n = model.n_elements;
    for (a, e_ref, k_ref) in [(1.0, 0.943340, 21.63043), (0.5, 0.969700, 12.05558)] {
        let (e, k, _) = lm_closed_form(a, ForceLength::Cubic);
        assert!((e - e_ref).abs() < 1e-6, "e = {e}");
        assert!((k / k_ref - 1.0).abs() < 1e-6, "κ2 = {k}");
        let mm = MuscleModel::new(one_group(group::LM0, ForceLength::Cubic), &model).unwrap();
        let s = uniform_strain_state(&model, coomm_frame(), e, [0.0, k, 0.0]);
        let act = activation(n, group::LM0, a);
        let l = loads(&model, Some(&mm), &act, &s);
        let fm = a * 10.0e3 * 0.0625 * model.area[0];
        let (rf, rc) = residual(&l, 2..n - 1, 2..n - 2);
        assert!(rf < 1e-9 * fm, "a={a}: node residual {rf:e}");
        assert!(rc < 1e-9 * fm * 0.00375, "a={a}: couple residual {rc:e}");
        // The ghost halving of eq. 2.2 does act at the ends.
        let (ef, _) = residual(&l, n..n + 1, 0..0);
        assert!(ef > 1e-6 * fm, "end residual {ef:e}");
    }
}

// Spec §8.2: TM alone elongates the arm, no bending: e = 1 + c_T f_ℓ(e^{−1/2}).
#[test]
fn transverse_muscle_closed_form() {
    let (model, _) = uniform_rod().build().unwrap();
    let n = model.n_elements;
    let spec = MuscleSpec::coomm();
    let g = &spec.groups[group::TM];
    for (f, a, e_ref) in [
        (ForceLength::Flat, 1.0, 1.1692708),
        (ForceLength::Flat, 0.5, 1.0846354),
        (ForceLength::Cubic, 1.0, 1.1644353),
        (ForceLength::Cubic, 0.5, 1.0834897),
    ] {
        let c = a * g.max_stress * g.area_fraction / E;
        let mut e: f64 = 1.0;
        for _ in 0..200 {
            e = 1.0 + c * f.value(1.0 / e.sqrt());
        }
        assert!((e - e_ref).abs() < 1e-7, "{f:?} a={a}: e = {e}");
        let mm = MuscleModel::new(one_group(group::TM, f), &model).unwrap();
        let s = uniform_strain_state(&model, coomm_frame(), e, [0.0; 3]);
        let l = loads(&model, Some(&mm), &activation(n, group::TM, a), &s);
        let fm = a * g.max_stress * g.area_fraction * model.area[0];
        let (rf, rc) = residual(&l, 1..n + 1, 1..n);
        assert!(rf < 1e-9 * fm, "{f:?} a={a}: node residual {rf:e}");
        assert!(rc < 1e-15, "{f:?} a={a}: couple residual {rc:e}");
        // TM pushes: its resultant is compressive along ν (n₃ < 0), parallel to ν.
        let nm = l.muscle_n.get(50);
        assert!(nm[2] < 0.0 && nm[0].abs() < 1e-18 && nm[1].abs() < 1e-18);
    }
}

fn kernel(mm: &MuscleModel, l: &InternalLoads, act: &[Vec<f64>]) -> (Vec<Vec3>, Vec<Vec3>) {
    let n = mm.n_elements();
    let mut nx = vec![vec![0.0; n]; 3];
    let mut tx = vec![vec![0.0; n - 1]; 3];
    let mut scratch = MuscleScratch::new(n);
    {
        let [a, b, c] = &mut nx[..] else {
            unreachable!()
        };
        let [d, e, f] = &mut tx[..] else {
            unreachable!()
        };
        let s = Strains {
            sigma: [&l.sigma.x, &l.sigma.y, &l.sigma.z],
            dilatation: &l.dilatation,
            kappa: [&l.kappa.x, &l.kappa.y, &l.kappa.z],
            voronoi_dilatation: &l.voronoi_dilatation,
        };
        let mut out = Resultants {
            force: [a, b, c],
            couple: [d, e, f],
            moment: None,
        };
        mm.resultants(groups(act), &s, &mut scratch, &mut out);
    }
    (
        (0..n).map(|j| [nx[0][j], nx[1][j], nx[2][j]]).collect(),
        (0..n - 1).map(|k| [tx[0][k], tx[1][k], tx[2][k]]).collect(),
    )
}

// Spec §8.3 (kernel part) and §8.6: on the straight tapered reference state a whole oblique
// group gives a twist couple of the sign that twists OM+ to κ₃ < 0 (τ^μ₃ > 0; OM− the
// opposite) and no net bending; a single oblique member bends and shears; TM is purely axial;
// every member has λ = 1, so the flat and cubic curves give the same loads up to f_ℓ(1) = 0.99.
#[test]
fn oblique_twist_sign_and_reference_state() {
    let (model, s) = StraightRod::coomm_arm().build().unwrap();
    let n = model.n_elements;
    let mm = MuscleModel::new(
        MuscleSpec::coomm().with_force_length(ForceLength::Flat),
        &model,
    )
    .unwrap();
    let cubic = MuscleModel::new(MuscleSpec::coomm(), &model).unwrap();
    let l0 = loads(&model, None, &activation(n, 0, 0.0), &s);
    for (g, sign) in [(group::OM_POS, 1.0), (group::OM_NEG, -1.0)] {
        let act = activation(n, g, 1.0);
        let (nm, tau) = kernel(&mm, &l0, &act);
        for k in 5..n - 6 {
            assert!(
                sign * tau[k][2] > 0.0,
                "OM group {g}: τ₃ at {k} = {:e}",
                tau[k][2]
            );
            let scale = tau[k][2].abs();
            assert!(tau[k][0].abs() < 1e-9 * scale && tau[k][1].abs() < 1e-9 * scale);
            // Four symmetric fibres: no net shear force; the group shortens (n₃ > 0 pulls).
            assert!(nm[k][0].abs() < 1e-9 * nm[k][2] && nm[k][1].abs() < 1e-9 * nm[k][2]);
        }
        let (nc, tc) = kernel(&cubic, &l0, &act);
        for j in 0..n {
            for c in 0..3 {
                assert!((nc[j][c] - 0.99 * nm[j][c]).abs() <= 1e-12 * norm(nm[j]));
            }
        }
        assert!((tc[50][2] - 0.99 * tau[50][2]).abs() < 1e-12 * tau[50][2].abs());
    }
    // One oblique member: lateral force and bending couple.
    let mut one = MuscleSpec::coomm().with_force_length(ForceLength::Flat);
    one.groups[group::OM_POS].angles.truncate(1);
    let m1 = MuscleModel::new(one, &model).unwrap();
    let (nm, tau) = kernel(&m1, &l0, &activation(n, group::OM_POS, 1.0));
    let lateral = (0..n).map(|j| nm[j][0].hypot(nm[j][1])).fold(0.0, f64::max);
    let bend = (0..n - 1)
        .map(|k| tau[k][0].hypot(tau[k][1]))
        .fold(0.0, f64::max);
    assert!(lateral > 0.1 * nm[50][2] && bend > 0.0);
    // TM on the reference state: purely axial.
    let (nm, tau) = kernel(&mm, &l0, &activation(n, group::TM, 1.0));
    for j in 0..n {
        assert!(nm[j][0] == 0.0 && nm[j][1] == 0.0 && nm[j][2] < 0.0);
    }
    assert!(tau.iter().all(|t| *t == [0.0; 3]));
}

/// A smooth, deformed, moving state of the COOMM arm (bent, twisted, sheared, stretched).
fn deformed_state(model: &RodModel) -> RodState {
    let n = model.n_elements;
    let mut s = uniform_strain_state(model, coomm_frame(), 1.02, [3.0, -4.0, 6.0]);
    for j in 0..=n {
        let t = j as f64 / n as f64;
        s.position[j][1] += 0.003 * (3.0 * t).sin();
        s.position[j][2] += 0.002 * t * t;
        s.velocity[j] = [0.01 * t, -0.02 * t * t, 0.015 * (2.0 * t).sin()];
    }
    for j in 0..n {
        let t = j as f64 / n as f64;
        let r = rotation([0.05 * (5.0 * t).sin(), 0.03 * t, -0.04 * t * t]);
        let q = s.director[j];
        let mut out = [[0.0; 3]; 3];
        for a in 0..3 {
            for b in 0..3 {
                out[a][b] = (0..3).map(|c| q[a][c] * r[c][b]).sum();
            }
        }
        s.director[j] = out;
        s.omega[j] = [2.0 * t, -1.0, 3.0 * t * t];
    }
    s
}

fn random_activations(n: usize) -> Vec<Vec<f64>> {
    let mut seed = 12345u64;
    let mut next = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64) / ((1u64 << 53) as f64)
    };
    (0..N_GROUPS)
        .map(|g| {
            let (p, q) = (next(), next());
            (0..n)
                .map(|j| {
                    (0.5 + 0.5 * (p * 7.0 + q * 11.0 * j as f64 / n as f64 + g as f64).sin()) * 0.8
                })
                .collect()
        })
        .collect()
}

// Spec §8.6 and eqs. 2.8–2.9: the fused loads equal the bare elastic loads plus the
// external-load form to round-off; Σ F^μ = 0; linear in a; zero activation changes nothing.
#[test]
fn fused_equals_external_form_and_invariances() {
    let (model, _) = StraightRod::coomm_arm().build().unwrap();
    let n = model.n_elements;
    let mm = MuscleModel::new(MuscleSpec::coomm(), &model).unwrap();
    let s = deformed_state(&model);
    let act = random_activations(n);
    let fused = loads(&model, Some(&mm), &act, &s);
    let bare = loads(&model, None, &act, &s);
    let (nm, tau) = kernel(&mm, &bare, &act);
    let nu: Vec<Vec3> = (0..n)
        .map(|j| {
            let g = bare.sigma.get(j);
            [g[0], g[1], 1.0 + g[2]]
        })
        .collect();
    let kappa: Vec<Vec3> = (0..n - 1).map(|k| bare.kappa.get(k)).collect();
    let mut ext = ExternalLoads::zeros(n + 1, n);
    mm.add_external_form(&s.director, &nu, &kappa, &nm, &tau, 0, 0, &mut ext);
    let fscale = (0..=n).map(|i| norm(ext.force.get(i))).fold(0.0, f64::max);
    let cscale = (0..n).map(|j| norm(ext.couple.get(j))).fold(0.0, f64::max);
    assert!(fscale > 1e-4 && cscale > 1e-7, "{fscale:e} {cscale:e}");
    for i in 0..=n {
        let (a, b, c) = (fused.force.get(i), bare.force.get(i), ext.force.get(i));
        for k in 0..3 {
            assert!((a[k] - b[k] - c[k]).abs() < 1e-12 * fscale, "node {i}");
        }
        let m = fused.muscle_force.get(i);
        for k in 0..3 {
            assert!(
                (m[k] - c[k]).abs() < 1e-12 * fscale,
                "muscle force node {i}"
            );
        }
    }
    for j in 0..n {
        let (a, b, c) = (fused.torque.get(j), bare.torque.get(j), ext.couple.get(j));
        for k in 0..3 {
            assert!((a[k] - b[k] - c[k]).abs() < 1e-12 * cscale, "element {j}");
        }
    }
    // Σ_i F^μ_i = 0 (internal forces).
    let mut sum = [0.0; 3];
    for i in 0..=n {
        let f = fused.muscle_force.get(i);
        for k in 0..3 {
            sum[k] += f[k];
        }
    }
    assert!(norm(sum) < 1e-15 * fscale * n as f64, "{sum:?}");
    // Linear in a: loads(a) + loads(b) = loads(a + b).
    let half: Vec<Vec<f64>> = act
        .iter()
        .map(|v| v.iter().map(|x| 0.3 * x).collect())
        .collect();
    let rest: Vec<Vec<f64>> = act
        .iter()
        .map(|v| v.iter().map(|x| 0.7 * x).collect())
        .collect();
    let (n1, t1) = kernel(&mm, &bare, &half);
    let (n2, t2) = kernel(&mm, &bare, &rest);
    let nmax = nm.iter().map(|v| norm(*v)).fold(0.0, f64::max);
    let tmax = tau.iter().map(|v| norm(*v)).fold(0.0, f64::max);
    for j in 0..n {
        for k in 0..3 {
            assert!((n1[j][k] + n2[j][k] - nm[j][k]).abs() < 1e-14 * nmax);
        }
    }
    for j in 0..n - 1 {
        for k in 0..3 {
            assert!((t1[j][k] + t2[j][k] - tau[j][k]).abs() < 1e-14 * tmax);
        }
    }
    // Zero activation: exactly the bare loads.
    let zero = loads(&model, Some(&mm), &activation(n, 0, 0.0), &s);
    for i in 0..=n {
        assert_eq!(zero.force.get(i), bare.force.get(i));
    }
    for j in 0..n {
        assert_eq!(zero.torque.get(j), bare.torque.get(j));
    }
    // TM force parallel to ν on the deformed state.
    let (nt, _) = kernel(&mm, &bare, &activation(n, group::TM, 0.7));
    for j in 0..n {
        let c = cross(nt[j], nu[j]);
        assert!(norm(c) < 1e-14 * norm(nt[j]) * norm(nu[j]));
    }
}

// Spec §1.2–2 step 3: the rest fibre lengths of the tapered COOMM arm.
#[test]
fn rest_lengths_follow_taper_and_helix() {
    let (model, _) = StraightRod::coomm_arm().build().unwrap();
    let mm = MuscleModel::new(MuscleSpec::coomm(), &model).unwrap();
    let lm = &mm.members[1];
    assert!((1.0 / lm.inv_rest_length[50] - 1.000570).abs() < 1e-6);
    assert!((1.0 / lm.inv_rest_length[0] - 1.000142).abs() < 1e-6);
    assert!((1.0 / lm.inv_rest_length[99] - 1.000142).abs() < 1e-6);
    assert_eq!(mm.members[0].inv_rest_length[10], 1.0);
    // OM at mid-arm: ν^m = e3 + ½(q_{j−1} + q_j) = e3 + (x_{j+1} − x_{j−1})/(2 l̂) on a uniform
    // grid, x_j = ρ r̂_j (cos φ_j, sin φ_j): a chord over two elements (Δφ = 0.377 rad each), so
    // ℓ° lies 1.4 % below the continuum helix's sqrt(1 + (ρ r̂ 2πn/L)²).
    let om = &mm.members[5];
    let x = |j: usize| {
        let phi = 2.0 * std::f64::consts::PI * 6.0 * (j as f64 + 0.5) / 100.0;
        let r = model.radius[j] * 11.25 / 12.0;
        [r * phi.cos(), r * phi.sin()]
    };
    let (a, b) = (x(49), x(51));
    let v = [(b[0] - a[0]) / 0.004, (b[1] - a[1]) / 0.004];
    let discrete = (1.0 + v[0] * v[0] + v[1] * v[1]).sqrt();
    assert!((1.0 / om.inv_rest_length[50] / discrete - 1.0).abs() < 1e-12);
    let r = model.radius[50] * 11.25 / 12.0;
    let cont = (1.0 + (r * 2.0 * std::f64::consts::PI * 6.0 / 0.2).powi(2)).sqrt();
    let ratio = 1.0 / om.inv_rest_length[50] / cont;
    assert!(ratio < 1.0 && ratio > 0.98, "{ratio}");
    // Base values of spec §1.1.
    assert!((model.radius[0] - 11.946e-3).abs() < 1e-6);
    assert!((model.radius[99] - 1.254e-3).abs() < 1e-6);
    assert!((model.shear_stiffness[0][2] - 4.4833).abs() < 1e-4);
    assert!((model.shear_stiffness[0][0] - 1.4406).abs() < 1e-4);
    assert!((model.total_mass() - 0.03515).abs() < 1e-5);
}

// Spec §8.7: the straight arm translating rigidly: total drag −41 v|v| across, −3.3 v|v| along,
// split ½/½ between an element's nodes.
#[test]
fn drag_totals_by_hand() {
    for (dir, coef) in [
        ([0.0, 1.0, 0.0], 41.0),
        ([1.0, 0.0, 0.0], 3.3),
        ([0.0, 0.0, -1.0], 41.0),
    ] {
        let (model, mut s) = StraightRod::coomm_arm().build().unwrap();
        let v = -0.07;
        for x in &mut s.velocity {
            *x = [v * dir[0], v * dir[1], v * dir[2]];
        }
        let drag = Load::coomm_drag(&model);
        let mut sim = Simulation::with_ends(
            model.clone(),
            s,
            EndCondition::Free,
            EndCondition::Free,
            Settings::default(),
        )
        .unwrap();
        sim.add_load(drag).unwrap();
        sim.step().unwrap();
        let f = &sim.workspace.external.force;
        let mut total = [0.0; 3];
        for i in 0..=model.n_elements {
            for c in 0..3 {
                total[c] += f.get(i)[c];
            }
        }
        let expect = -coef * v * v.abs();
        for c in 0..3 {
            assert!(
                (total[c] - expect * dir[c]).abs() < 1e-12 * coef * v * v,
                "{total:?}"
            );
        }
        // Node shares: node 0 carries half of element 0's drag, node 1 half of elements 0 and 1.
        let el = |j: usize| coef / 100.0 * model.radius[j] / 6.6e-3 * v * v.abs();
        let f0 = f.get(0);
        let f1 = f.get(1);
        let d0 = f0[0] * dir[0] + f0[1] * dir[1] + f0[2] * dir[2];
        let d1 = f1[0] * dir[0] + f1[1] * dir[1] + f1[2] * dir[2];
        assert!((d0 + 0.5 * el(0)).abs() < 1e-12 * el(0).abs());
        assert!((d1 + 0.5 * (el(0) + el(1))).abs() < 1e-12 * el(0).abs());
    }
}

// Spec §3.2 and §8.8: the `coomm` preset's rates, and free decay at those rates.
#[test]
fn coomm_damping_rates_and_free_decay() {
    let d = Damping::coomm(1050.0, 0.012);
    let Some(octoarm_physics::AnalyticalDamper::Rates {
        translational,
        rotational,
    }) = d.analytical
    else {
        panic!("coomm is a per-DOF rate damper");
    };
    assert!((translational - 0.10526).abs() < 1e-5);
    assert!((rotational[0] - 2923.9).abs() < 0.1 && rotational[1] == rotational[0]);
    assert!((rotational[2] - 1461.96).abs() < 0.01);
    // Free decay: uniform translation and uniform twist rate of a free straight rod are
    // strain-free, so only the damper changes them.
    let (model, mut s) = StraightRod::coomm_arm().build().unwrap();
    for x in &mut s.velocity {
        *x = [0.01, -0.02, 0.03];
    }
    for w in &mut s.omega {
        *w = [0.0, 0.0, 0.5];
    }
    let mut sim = Simulation::with_ends(
        model,
        s,
        EndCondition::Free,
        EndCondition::Free,
        Settings::default(),
    )
    .unwrap();
    sim.set_damping(d).unwrap();
    let steps = 200;
    sim.run(steps).unwrap();
    let t = steps as f64 * 1e-5;
    let kv = (-translational * t).exp();
    let kw = (-rotational[2] * t).exp();
    let st = sim.rod_state();
    for v in &st.velocity {
        let expect = [0.01 * kv, -0.02 * kv, 0.03 * kv];
        for c in 0..3 {
            assert!(
                (v[c] - expect[c]).abs() < 1e-9 * 0.03,
                "{v:?} vs {expect:?}"
            );
        }
    }
    for w in &st.omega {
        assert!((w[2] / (0.5 * kw) - 1.0).abs() < 1e-9, "{w:?}");
        assert!(w[0].abs() < 1e-12 && w[1].abs() < 1e-12);
    }
}

// Muscles in the stepper: LM0 at a = 0.3 bends the damped COOMM arm towards −e_z (its side);
// the work done by the muscles is counted, so the guard never trips; energy bookkeeping closes.
#[test]
fn lm0_bends_the_arm_towards_its_side() {
    let (model, s) = StraightRod::coomm_arm().build().unwrap();
    let n = model.n_elements;
    let mut sim = Simulation::new(model.clone(), s, Settings::default()).unwrap();
    sim.set_damping(Damping::mass_proportional(20.0)).unwrap();
    sim.set_muscles(Some(MuscleSpec::coomm())).unwrap();
    sim.set_activation(group::LM0, &vec![0.3; n]).unwrap();
    sim.run(20_000).unwrap();
    let tip = sim.tip();
    assert!(tip[2] < -0.01 && tip[1].abs() < 1e-12, "tip {tip:?}");
    assert!(sim.external_work() > 0.0);
    // Activation outside [0, 1] is refused with its value.
    assert!(sim.set_activation(group::LM0, &vec![1.5; n]).is_err());
    assert!(sim.set_activation(7, &vec![0.5; n]).is_err());
}

// The kernel's antipode reuse (a fibre diametrically opposite the one two places before takes
// that fibre's offsets and q with the sign flipped): the pairs are the expected ones (LM2/LM0,
// LM3/LM1 and the third and fourth fibre of each oblique group), and the kernel's loads equal
// those computed anew for every fibre (antipodes cleared) to the last bit, on a deformed state
// with random activations — negation is exact, so any other difference is a bug.
#[test]
fn antipode_reuse_is_bit_identical() {
    let (model, _) = StraightRod::coomm_arm().build().unwrap();
    let n = model.n_elements;
    let mm = MuscleModel::new(MuscleSpec::coomm(), &model).unwrap();
    let pairs: Vec<(usize, usize)> = mm
        .members
        .iter()
        .enumerate()
        .filter_map(|(i, m)| m.antipode.map(|p| (i, p)))
        .collect();
    assert_eq!(pairs, [(3, 1), (4, 2), (7, 5), (8, 6), (11, 9), (12, 10)]);
    let mut plain = mm.clone();
    for m in &mut plain.members {
        m.antipode = None;
    }
    let s = deformed_state(&model);
    let act = random_activations(n);
    let bare = loads(&model, None, &act, &s);
    let (n1, t1) = kernel(&mm, &bare, &act);
    let (n2, t2) = kernel(&plain, &bare, &act);
    assert!(n1.iter().any(|v| norm(*v) > 0.0));
    for j in 0..n {
        for k in 0..3 {
            assert_eq!(n1[j][k].to_bits(), n2[j][k].to_bits(), "force {j} {k}");
        }
    }
    for j in 0..n - 1 {
        for k in 0..3 {
            assert_eq!(t1[j][k].to_bits(), t2[j][k].to_bits(), "couple {j} {k}");
        }
    }
}
