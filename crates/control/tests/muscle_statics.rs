//! Claims (muscles-3d spec §4, §8.1–8.3, §8.4 iii, §8.5): the equilibrium of the muscular arm for
//! given activations, by Newton on the banded equilibrium Jacobian.
//!
//! Independent references: the closed forms of spec §8 (uniform rod; LM: uniform curvature and
//! shortening; TM: pure elongation; an OM group: the continuum helix, which the discrete one
//! matches to the chord error); a dense finite-difference Jacobian (the band and the colouring),
//! and the coloured one as the oracle of the analytic Jacobian; pure Newton for the chord steps;
//! COOMM's Picard iteration (a different algorithm with the same fixed point); and the dynamic
//! arm relaxed under the same activations (statics = dynamics, §8.5).
//!
//! How a wrong implementation fails: a wrong residual (1/e or 1/ε³ missing, a sign) moves the
//! closed-form numbers; a colouring that overlaps bands corrupts the Jacobian (dense comparison);
//! a missing chain-rule term of the analytic Jacobian (the 1/e area, the current radius, the
//! current Voronoi length, f_ℓ′) shows as an entry off by far more than 1e-6;
//! a forward map with the wrong rotation sign or frame order moves the tip; a statics that is not
//! the stepper's equilibrium leaves the relaxed dynamic arm elsewhere.

#![allow(clippy::needless_range_loop)]

use octoarm_control::banded::BandMatrix;
use octoarm_control::muscle_statics::HALF_BAND;
use octoarm_control::MuscleStatics;
use octoarm_physics::muscles::group;
use octoarm_physics::{
    Damping, ForceLength, MuscleModel, MuscleSpec, RodModel, Settings, Simulation, StraightRod,
    N_GROUPS,
};

const E: f64 = 1.0e4;

fn uniform_rod() -> StraightRod {
    let mut r = StraightRod::coomm_arm();
    r.base_diameter = 0.012;
    r.tip_diameter = 0.012;
    r
}

fn statics(rod: &StraightRod, f: ForceLength) -> (RodModel, MuscleStatics) {
    let (model, state) = rod.build().unwrap();
    let mm = MuscleModel::new(MuscleSpec::coomm().with_force_length(f), &model).unwrap();
    let st = MuscleStatics::new(&model, mm, state.position[0], state.director[0]);
    (model, st)
}

fn one_group(n: usize, g: usize, a: f64) -> Vec<f64> {
    let mut v = vec![0.0; N_GROUPS * n];
    v[g * n..(g + 1) * n].fill(a);
    v
}

fn smooth_activations(n: usize, seed: u64) -> Vec<f64> {
    let mut s = seed;
    let mut next = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 11) as f64) / ((1u64 << 53) as f64)
    };
    let mut a = vec![0.0; N_GROUPS * n];
    for g in 0..N_GROUPS {
        let (p, q, amp) = (next() * 6.0, next() * 4.0, 0.6 * next());
        for j in 0..n {
            a[g * n + j] = amp * (0.5 + 0.5 * (p + q * j as f64 / n as f64).sin());
        }
    }
    a
}

// §8.4 (iii): the analytic equilibrium Jacobian equals the coloured central-difference one (the
// oracle, itself checked against the dense one above) entrywise to 1e-6 of max |K|, and to 1e-6
// relative on every entry above 1e-3 of its row's largest, for each force–length curve, every
// group active (smooth random activations, lengths in the cubic's rising and falling parts) at a
// point off the equilibrium, on a short and on the full 100-element arm; nothing is set beyond
// the band. Newton with it converges to the same equilibrium as with the oracle in no more
// iterations.
#[test]
fn analytic_jacobian_matches_coloured_differences() {
    use octoarm_control::JacobianKind;
    for (n_el, curve, seed) in [
        (12, ForceLength::Cubic, 5),
        (12, ForceLength::Flat, 6),
        (12, ForceLength::Gaussian, 7),
        (100, ForceLength::Cubic, 8),
    ] {
        let rod = StraightRod::coomm_arm().with_elements(n_el);
        let (_, mut st) = statics(&rod, curve);
        let n = st.n_elements();
        let a = smooth_activations(n, seed);
        st.solve(&a, None).unwrap();
        let w: Vec<f64> = st
            .solution()
            .iter()
            .enumerate()
            .map(|(i, v)| v + 1e-3 * (0.7 * i as f64).sin())
            .collect();
        let m = st.n_unknowns();
        let mut fd = BandMatrix::new(m, HALF_BAND, HALF_BAND);
        let mut an = BandMatrix::new(m, HALF_BAND, HALF_BAND);
        st.jacobian(&w, &a, &mut an);
        // Spec §8.4 (iii): the oracle with its step h = 1e-7, entrywise to 1e-6 max |K|.
        st.jacobian_fd(&w, &a, &mut fd);
        let mut max: f64 = 0.0;
        for row in 0..m {
            for col in row.saturating_sub(HALF_BAND)..=(row + HALF_BAND).min(m - 1) {
                max = max.max(fd.get(row, col).abs());
            }
        }
        let mut worst_abs: f64 = 0.0;
        for row in 0..m {
            for col in row.saturating_sub(HALF_BAND)..=(row + HALF_BAND).min(m - 1) {
                worst_abs = worst_abs.max((an.get(row, col) - fd.get(row, col)).abs() / max);
            }
        }
        // Relative, entry by entry: at h = 1e-7 the differences' round-off (≈ 1e-16 |R|/h,
        // 1e-12 absolute, changing sign and size with h as 1/h) swamps the small entries; at
        // h = 1e-5 it is 100× smaller and the truncation error (h²) still negligible.
        st.config.fd_step = 1e-5;
        st.jacobian_fd(&w, &a, &mut fd);
        st.config.fd_step = 1e-7;
        let mut worst_rel: f64 = 0.0;
        for row in 0..m {
            let cols = row.saturating_sub(HALF_BAND)..=(row + HALF_BAND).min(m - 1);
            let row_max = cols
                .clone()
                .map(|c| fd.get(row, c).abs())
                .fold(0.0, f64::max);
            for col in cols {
                let (x, y) = (an.get(row, col), fd.get(row, col));
                if y.abs() >= 1e-3 * row_max {
                    worst_rel = worst_rel.max((x - y).abs() / y.abs());
                }
            }
        }
        eprintln!("n = {n_el}, {curve:?}: max |K_an − K_fd|/max|K| = {worst_abs:.1e}, relative {worst_rel:.1e}");
        assert!(worst_abs <= 1e-6, "{curve:?}, n = {n_el}: {worst_abs:e}");
        assert!(worst_rel <= 1e-6, "{curve:?}, n = {n_el}: {worst_rel:e}");
        // Newton with either Jacobian: the same equilibrium.
        st.config.jacobian = JacobianKind::FiniteDifference;
        let r_fd = st.solve(&a, Some(&st.rest())).unwrap();
        let w_fd = st.solution().to_vec();
        st.config.jacobian = JacobianKind::Analytic;
        let r_an = st.solve(&a, Some(&st.rest())).unwrap();
        assert!(
            r_an.newton_iterations <= r_fd.newton_iterations,
            "{r_an:?} {r_fd:?}"
        );
        let diff = st
            .solution()
            .iter()
            .zip(&w_fd)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(diff < 1e-10, "{diff:e}");
    }
}

// §8.4 (iii) for the oracle itself: the coloured central-difference Jacobian equals the dense
// one column by column, and nothing lies beyond |row − col| = 11.
#[test]
fn coloured_jacobian_matches_dense_and_is_banded() {
    let rod = StraightRod::coomm_arm().with_elements(12);
    let (_, mut st) = statics(&rod, ForceLength::Cubic);
    let n = st.n_elements();
    let a = smooth_activations(n, 3);
    st.solve(&a, None).unwrap();
    // A point off the equilibrium, so that every term is exercised.
    let w: Vec<f64> = st
        .solution()
        .iter()
        .enumerate()
        .map(|(i, v)| v + 1e-3 * (i as f64).sin())
        .collect();
    let m = st.n_unknowns();
    let mut band = BandMatrix::new(m, HALF_BAND, HALF_BAND);
    st.jacobian_fd(&w, &a, &mut band);
    let h = 1e-7;
    let (mut rp, mut rm) = (vec![0.0; m], vec![0.0; m]);
    let mut max: f64 = 0.0;
    let mut dense = vec![vec![0.0; m]; m];
    for col in 0..m {
        let mut wp = w.clone();
        wp[col] += h;
        st.residual(&wp, &a, &mut rp);
        wp[col] -= 2.0 * h;
        st.residual(&wp, &a, &mut rm);
        for row in 0..m {
            dense[row][col] = (rp[row] - rm[row]) / (2.0 * h);
            max = max.max(dense[row][col].abs());
        }
    }
    let mut widest = 0;
    for row in 0..m {
        for col in 0..m {
            let d = row.abs_diff(col);
            if d > HALF_BAND {
                assert_eq!(dense[row][col], 0.0, "({row}, {col}) outside the band");
            } else {
                if dense[row][col] != 0.0 {
                    widest = widest.max(d);
                }
                assert!(
                    (band.get(row, col) - dense[row][col]).abs() <= 1e-9 * max,
                    "({row}, {col}): {} vs {}",
                    band.get(row, col),
                    dense[row][col]
                );
            }
        }
    }
    assert_eq!(widest, HALF_BAND, "the band is reached");
}

fn lm_closed_form(a: f64, f: ForceLength) -> (f64, f64) {
    let c = a * 10.0e3 * 0.0625 / E;
    let rho = 0.625;
    let mut fl = 1.0;
    for _ in 0..300 {
        let e = 1.0 - c * fl;
        fl = f.value(e * (1.0 - 4.0 * c * rho * rho * fl));
    }
    let e = 1.0 - c * fl;
    (e, 4.0 * c * rho * fl * e.powf(1.5) / 0.006)
}

// §8.1 by the solver: LM0..LM3, flat (everywhere, and the discrete tip) and cubic (interior).
#[test]
fn longitudinal_closed_form_by_newton() {
    for f in [ForceLength::Flat, ForceLength::Cubic] {
        let (model, mut st) = statics(&uniform_rod(), f);
        let n = model.n_elements;
        for a in [1.0, 0.5] {
            let (e, k) = lm_closed_form(a, f);
            for lm in 0..4 {
                let rep = st
                    .solve(&one_group(n, group::LM0 + lm, a), Some(&st.rest()))
                    .unwrap();
                assert!(
                    rep.residual <= 1e-12 && rep.newton_iterations <= 10,
                    "{rep:?}"
                );
                let w = st.solution().to_vec();
                let phi = lm as f64 * std::f64::consts::FRAC_PI_2;
                let axis = [-phi.sin(), phi.cos(), 0.0];
                let (ks, js) = if f == ForceLength::Flat {
                    (0..n - 1, 0..n)
                } else {
                    (5..94, 5..94)
                };
                for kk in ks {
                    let kap = MuscleStatics::kappa(&w, kk);
                    for c in 0..3 {
                        assert!(
                            (kap[c] - k * axis[c]).abs() <= 1e-9 * k,
                            "{f:?} a={a} LM{lm} κ_{kk} = {kap:?}, expected {k} about {axis:?}"
                        );
                    }
                }
                for j in js {
                    let nu = MuscleStatics::nu(&w, j);
                    assert!(
                        (nu[2] / e - 1.0).abs() <= 1e-9,
                        "{f:?} a={a} e_{j} = {}",
                        nu[2]
                    );
                    // Flat: exact; cubic: the end elements' ghost halving reaches the interior
                    // at the spec's 1e-9 level.
                    let tol = if f == ForceLength::Flat { 1e-12 } else { 1e-9 };
                    assert!(nu[0].abs() < tol && nu[1].abs() < tol, "shear {nu:?}");
                }
                if f == ForceLength::Flat && lm == 0 {
                    // Discrete tip: x_N = l̂ e Σ_j (cos jθ₀, 0, −sin jθ₀), θ₀ = κ₂ D̂.
                    let th = k * 0.002;
                    let mut tip = [0.0; 3];
                    for j in 0..n {
                        tip[0] += 0.002 * e * (j as f64 * th).cos();
                        tip[2] -= 0.002 * e * (j as f64 * th).sin();
                    }
                    let pose = st.pose(&w);
                    for c in 0..3 {
                        assert!(
                            (pose.position[n][c] - tip[c]).abs() < 1e-9,
                            "tip {:?}",
                            pose.position[n]
                        );
                    }
                }
            }
        }
    }
}

// §8.2 by the solver: TM alone stretches the arm uniformly, no bending, no shear.
#[test]
fn transverse_closed_form_by_newton() {
    for (f, a, e_ref) in [
        (ForceLength::Flat, 1.0, 1.1692708),
        (ForceLength::Flat, 0.5, 1.0846354),
        (ForceLength::Cubic, 1.0, 1.1644353),
        (ForceLength::Cubic, 0.5, 1.0834897),
    ] {
        let (model, mut st) = statics(&uniform_rod(), f);
        let n = model.n_elements;
        st.solve(&one_group(n, group::TM, a), None).unwrap();
        let w = st.solution();
        for j in 0..n {
            let nu = MuscleStatics::nu(w, j);
            assert!(
                (nu[2] - e_ref).abs() < 1e-7,
                "{f:?} a={a}: e_{j} = {}",
                nu[2]
            );
            assert!(nu[0] == 0.0 && nu[1] == 0.0);
        }
        for k in 0..n - 1 {
            assert_eq!(MuscleStatics::kappa(w, k), [0.0; 3]);
        }
    }
}

// §8.3: a whole oblique group twists (κ₃ < 0 for OM+, > 0 for OM−) and shortens, with no
// bending or shear; against the continuum helix at Voronoi point 49.
#[test]
fn oblique_group_against_continuum_helix() {
    let (model, mut st) = statics(&uniform_rod(), ForceLength::Flat);
    let n = model.n_elements;
    let (r, rho) = (0.006, 0.9375);
    let e_over_g = 3.0;
    for (g, turns, a, e_spec, k_spec) in [
        (group::OM_POS, 6.0, 1.0, 0.88358, -81.149),
        (group::OM_POS, 6.0, 0.5, 0.94320, -46.064),
        (group::OM_NEG, -6.0, 1.0, 0.88358, 81.149),
    ] {
        // Continuum fixed point (spec §8.3).
        let c = a * 100.0e3 * 0.00390625 / E;
        let k0 = 2.0 * std::f64::consts::PI * turns / 0.2;
        let (mut e, mut k3): (f64, f64) = (1.0, 0.0);
        for _ in 0..2000 {
            let beta = rho * r / e.sqrt() * (k3 + k0 / e);
            let len = (e * e + beta * beta).sqrt();
            let e_new = 1.0 - 4.0 * c * e / len;
            let k_new = -8.0 * c * e_over_g * rho * e.powf(1.5) * beta / (r * len);
            e = 0.5 * (e + e_new);
            k3 = 0.5 * (k3 + k_new);
        }
        assert!((e / e_spec - 1.0).abs() < 2e-5, "continuum e = {e}");
        assert!((k3 / k_spec - 1.0).abs() < 2e-5, "continuum κ₃ = {k3}");
        st.solve(&one_group(n, g, a), Some(&st.rest())).unwrap();
        let w = st.solution();
        let kap = MuscleStatics::kappa(w, 49);
        let nu = MuscleStatics::nu(w, 49);
        assert!((nu[2] / e - 1.0).abs() < 2e-3, "e = {} vs {e}", nu[2]);
        assert!((kap[2] / k3 - 1.0).abs() < 2e-2, "κ₃ = {} vs {k3}", kap[2]);
        assert!(kap[2].signum() == k3.signum());
        assert!(kap[0].abs() < 1e-12 && kap[1].abs() < 1e-12, "{kap:?}");
        assert!(nu[0].abs() < 1e-12 && nu[1].abs() < 1e-12, "{nu:?}");
    }
    // One oblique fibre alone bends and shears (sign test only).
    let mut spec = MuscleSpec::coomm().with_force_length(ForceLength::Flat);
    spec.groups[group::OM_POS].angles.truncate(1);
    let (model2, state) = uniform_rod().build().unwrap();
    let mm = MuscleModel::new(spec, &model2).unwrap();
    let mut one = MuscleStatics::new(&model2, mm, state.position[0], state.director[0]);
    one.solve(&one_group(n, group::OM_POS, 1.0), None).unwrap();
    let w = one.solution();
    let bend = (0..n - 1)
        .map(|k| MuscleStatics::kappa(w, k)[0].hypot(MuscleStatics::kappa(w, k)[1]))
        .fold(0.0, f64::max);
    let shear = (0..n)
        .map(|j| MuscleStatics::nu(w, j)[0].hypot(MuscleStatics::nu(w, j)[1]))
        .fold(0.0, f64::max);
    assert!(bend > 1.0 && shear > 1e-4, "bend {bend}, shear {shear}");
}

// §4.2: Newton converges from w° for random activations on COOMM's arm; COOMM's Picard
// iteration (another algorithm) finds the same equilibrium; a warm start after a small change of
// the activations needs few iterations.
#[test]
fn newton_picard_and_warm_start_agree() {
    let (model, mut st) = statics(&StraightRod::coomm_arm(), ForceLength::Cubic);
    let n = model.n_elements;
    let a = smooth_activations(n, 11);
    let cold = st.solve(&a, Some(&st.rest())).unwrap();
    assert!(
        cold.newton_iterations <= 12 && cold.residual <= 1e-12,
        "{cold:?}"
    );
    let newton = st.solution().to_vec();
    let mut w = st.rest();
    let it = st.picard(&mut w, &a, 1e-11);
    assert!(it > 5 && it < 20_000, "Picard iterations {it}");
    for i in 0..w.len() {
        assert!(
            (w[i] - newton[i]).abs() < 1e-8 * (1.0 + newton[i].abs()),
            "{i}"
        );
    }
    let b: Vec<f64> = a.iter().map(|v| (v * 1.02).min(1.0)).collect();
    let mut pure = st.clone();
    let warm = st.solve(&b, None).unwrap();
    assert!(warm.newton_iterations <= 4, "{warm:?}");
    // Chord steps (the factors of the last Newton iteration reused) reach the equilibrium that
    // pure Newton (no chord) reaches from the same warm start.
    assert!(warm.chord_iterations > 0, "{warm:?}");
    pure.config.max_chord = 0;
    let p = pure.solve(&b, None).unwrap();
    assert_eq!(p.chord_iterations, 0);
    for (x, y) in st.solution().iter().zip(pure.solution()) {
        assert!((x - y).abs() < 1e-10 * (1.0 + y.abs()), "{x} vs {y}");
    }
    // Bad activations are refused with the entry named.
    let mut bad = a.clone();
    bad[3 * n + 7] = 1.5;
    let e = st.solve(&bad, None).unwrap_err().to_string();
    assert!(e.contains("group 3 element 7"), "{e}");
}

// §8.5: statics = dynamics. A short COOMM arm (20 elements) under smooth activations, ramped
// on over 0.2 s, relaxed with mass-proportional damping and no drag: every node ends within
// 1e-5 L0 of the static pose.
#[test]
fn statics_equals_relaxed_dynamics() {
    let rod = StraightRod::coomm_arm().with_elements(20);
    let (model, mut st) = statics(&rod, ForceLength::Cubic);
    let n = model.n_elements;
    let a = smooth_activations(n, 5);
    st.solve(&a, None).unwrap();
    let pose = st.pose(st.solution());
    let (model, state) = rod.build().unwrap();
    let dt = 5e-5;
    let mut sim = Simulation::new(model, state, Settings::with_dt(dt)).unwrap();
    sim.set_damping(Damping::mass_proportional(2.5)).unwrap();
    sim.set_muscles(Some(MuscleSpec::coomm())).unwrap();
    let ramp = 0.2;
    let mut steps = 0u64;
    loop {
        let t = steps as f64 * dt;
        if t <= ramp + dt {
            let k = (t / ramp).min(1.0);
            for g in 0..N_GROUPS {
                let v: Vec<f64> = a[g * n..(g + 1) * n].iter().map(|x| k * x).collect();
                sim.set_activation(g, &v).unwrap();
            }
        }
        sim.run(1000).unwrap();
        steps += 1000;
        let s = sim.rod_state();
        let vmax = s
            .velocity
            .iter()
            .map(|v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt())
            .fold(0.0, f64::max);
        if t > ramp && vmax < 1e-7 {
            break;
        }
        assert!(t < 40.0, "not at rest after 40 s (max |v| = {vmax:e})");
    }
    let s = sim.rod_state();
    let mut worst: f64 = 0.0;
    for i in 0..=n {
        let d = [
            s.position[i][0] - pose.position[i][0],
            s.position[i][1] - pose.position[i][1],
            s.position[i][2] - pose.position[i][2],
        ];
        worst = worst.max((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt());
    }
    assert!(worst < 1e-5 * 0.2, "largest node distance {worst:e} m");
    // The activations did move the arm far from straight.
    assert!(
        (pose.position[n][0] - 0.2).abs() > 0.01,
        "{:?}",
        pose.position[n]
    );
}
