//! Claim (spec §13 f and e-space): the linearised discrete rod vibrates at the Euler–Bernoulli
//! frequencies with the documented discretisation offsets: (f) the uniform cantilever's first
//! bending frequency is ω1 = ω1_EB (1 + 1/N) to 2e-3 (the clamp holds all of element 0, so
//! L_eff = L − l̂/2 and ω ∝ L_eff⁻²); (e, space) the free–free rod's first bending frequency
//! converges to ω_EB at second order in 1/N (error ratio ≥ 3.5 between N = 50 and 100).
//!
//! Independent reference: the Euler–Bernoulli beam frequencies ω = β² √(EI/(ρ A L⁴)) with the
//! roots β L = 1.875104, 4.694091 (clamped–free) and 4.730041 (free–free) of the characteristic
//! equations cos βL cosh βL = ∓1; the spec's discrete values (0.056151 and 0.35183 rad/s for the
//! N = 100 cantilever) come from an independent implementation.
//!
//! Method: the stiffness K = −∂F/∂q about the rest state is assembled column by column by central
//! differences (Richardson-extrapolated) of the elastic nodal forces and element torques (spec §4),
//! in the generalised coordinates δx_i (lab) and δφ_j (material, Q_j → exp(−[δφ_j]×) Q_j) of the
//! planar bending problem (x–y plane, rotations about d2 = e_z; the planar subspace is invariant,
//! §13 g). Constrained DOFs of the clamp are removed. The lowest modes of K φ = ω² M φ come from
//! inverse iteration (Cholesky) with the rigid-body modes deflated, and ω² is then refined by a
//! Rayleigh quotient whose K φ is a directional difference of the forces along the smooth mode
//! (insensitive to finite-difference error in the stiff shear and axial entries of K).
//!
//! How a wrong implementation fails: a wrong bending stiffness average (eq. 3.2), a wrong Voronoi
//! length in κ or in the torque, a missing shear–stretch couple, a wrong mass or inertia lumping, or
//! a wrong sign in the torque assembly moves ω1 by far more than 2e-3 or makes K non-symmetric; a
//! first-order error in the interior discretisation (e.g. curvature divided by an element instead
//! of a Voronoi length at non-uniform spacing, or torques mis-assigned by one index) turns the
//! free–free ratio from 4 into 2.

use octoarm_physics::math::{exp_neg_skew, mat_mul};
use octoarm_physics::{ElasticLoads, Material, RodModel, RodState, StraightRod};

/// One planar generalised coordinate.
#[derive(Debug, Clone, Copy)]
enum Dof {
    /// Lab x of node i.
    X(usize),
    /// Lab y of node i.
    Y(usize),
    /// Rotation of element j about its d2 (= e_z), material component 1.
    Phi(usize),
}

struct Linearised {
    model: RodModel,
    rest: RodState,
    dofs: Vec<Dof>,
    mass: Vec<f64>,
    /// Symmetrised stiffness, row-major, n × n.
    k: Vec<f64>,
    asymmetry: f64,
}

fn rod_material() -> Material {
    Material {
        density: 1000.0,
        youngs_modulus: 1.0e6,
        shear_modulus: 1.0e6 / 3.0,
        shear_coefficient: Material::DEFAULT_SHEAR_COEFFICIENT,
    }
}

/// ω_EB = (βL)² √(EI/(ρ A L⁴)) for the uniform rod of the cases (e), (f).
fn euler_bernoulli(beta_l: f64) -> f64 {
    let m = rod_material();
    let (r, l) = (1e-3f64, 1.0f64);
    let area = std::f64::consts::PI * r * r;
    let i = area * area / (4.0 * std::f64::consts::PI);
    beta_l * beta_l * (m.youngs_modulus * i / (m.density * area * l.powi(4))).sqrt()
}

fn perturb(s: &mut RodState, dof: Dof, amount: f64) {
    match dof {
        Dof::X(i) => s.position[i][0] += amount,
        Dof::Y(i) => s.position[i][1] += amount,
        Dof::Phi(j) => s.director[j] = mat_mul(&exp_neg_skew([0.0, amount, 0.0]), &s.director[j]),
    }
}

/// Generalised forces (nodal forces, element torques about d2) of a state.
fn generalised_force(lin: &Linearised, loads: &mut ElasticLoads, s: &RodState) -> Vec<f64> {
    loads.compute(
        &lin.model,
        s,
        &lin.model.rest_sigma,
        &lin.model.rest_kappa,
        false,
    );
    lin.dofs
        .iter()
        .map(|d| match *d {
            Dof::X(i) => loads.force()[i][0],
            Dof::Y(i) => loads.force()[i][1],
            Dof::Phi(j) => loads.couple()[j][1],
        })
        .collect()
}

/// K φ by a central directional difference of the forces along φ (Richardson-extrapolated).
fn stiffness_times(lin: &Linearised, loads: &mut ElasticLoads, phi: &[f64], h: f64) -> Vec<f64> {
    let diff = |loads: &mut ElasticLoads, h: f64| {
        let mut plus = lin.rest.clone();
        let mut minus = lin.rest.clone();
        for (d, p) in lin.dofs.iter().zip(phi) {
            perturb(&mut plus, *d, h * p);
            perturb(&mut minus, *d, -h * p);
        }
        let fp = generalised_force(lin, loads, &plus);
        let fm = generalised_force(lin, loads, &minus);
        fp.iter()
            .zip(&fm)
            .map(|(a, b)| -(a - b) / (2.0 * h))
            .collect::<Vec<f64>>()
    };
    let k1 = diff(loads, h);
    let k2 = diff(loads, 0.5 * h);
    k1.iter()
        .zip(&k2)
        .map(|(a, b)| (4.0 * b - a) / 3.0)
        .collect()
}

/// Linearise `rod` about its rest state; `clamped_base` removes the DOFs the clamp holds (node 0
/// and element 0), otherwise both ends are free.
fn linearise(rod: StraightRod, clamped_base: bool) -> Linearised {
    let (model, rest) = rod.build().unwrap();
    let n = model.n_elements;
    let first = usize::from(clamped_base);
    let mut dofs = Vec::new();
    let mut mass = Vec::new();
    for i in first..=n {
        dofs.extend([Dof::X(i), Dof::Y(i)]);
        mass.extend([model.node_mass[i], model.node_mass[i]]);
    }
    for j in first..n {
        dofs.push(Dof::Phi(j));
        mass.push(model.inertia[j][1]);
    }
    let nd = dofs.len();
    let mut lin = Linearised {
        model,
        rest,
        dofs,
        mass,
        k: vec![0.0; nd * nd],
        asymmetry: 0.0,
    };
    let mut loads = ElasticLoads::new(n);
    // Step: 1e-6 of an element length / 1e-6 rad. Round-off then costs ~1e-10 of the largest
    // entries and the O(h²) geometric nonlinearity is removed by the Richardson step.
    let l_hat = lin.model.rest_length[0];
    let mut kfull = vec![0.0; nd * nd];
    for b in 0..nd {
        let h = match lin.dofs[b] {
            Dof::Phi(_) => 1e-6,
            _ => 1e-6 * l_hat,
        };
        let mut e = vec![0.0; nd];
        e[b] = 1.0;
        let col = stiffness_times(&lin, &mut loads, &e, h);
        for a in 0..nd {
            kfull[a * nd + b] = col[a];
        }
    }
    let mut asym: f64 = 0.0;
    let mut largest: f64 = 0.0;
    for a in 0..nd {
        for b in 0..nd {
            asym = asym.max((kfull[a * nd + b] - kfull[b * nd + a]).abs());
            largest = largest.max(kfull[a * nd + b].abs());
            lin.k[a * nd + b] = 0.5 * (kfull[a * nd + b] + kfull[b * nd + a]);
        }
    }
    lin.asymmetry = asym / largest;
    lin
}

/// Dense Cholesky factor (lower, row-major) of an SPD matrix.
fn cholesky(a: &[f64], n: usize) -> Vec<f64> {
    let mut l = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..=i {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= l[i * n + k] * l[j * n + k];
            }
            if i == j {
                assert!(s > 0.0, "matrix not positive definite at row {i}");
                l[i * n + i] = s.sqrt();
            } else {
                l[i * n + j] = s / l[j * n + j];
            }
        }
    }
    l
}

fn cholesky_solve(l: &[f64], n: usize, b: &[f64]) -> Vec<f64> {
    let mut y = b.to_vec();
    for i in 0..n {
        for k in 0..i {
            y[i] -= l[i * n + k] * y[k];
        }
        y[i] /= l[i * n + i];
    }
    for i in (0..n).rev() {
        for k in i + 1..n {
            y[i] -= l[k * n + i] * y[k];
        }
        y[i] /= l[i * n + i];
    }
    y
}

fn dotv(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Remove from u its components along the orthonormal vectors `basis`, then normalise.
fn project_normalise(u: &mut [f64], basis: &[Vec<f64>]) {
    for b in basis {
        let c = dotv(u, b);
        for (x, y) in u.iter_mut().zip(b) {
            *x -= c * y;
        }
    }
    let nrm = dotv(u, u).sqrt();
    for x in u.iter_mut() {
        *x /= nrm;
    }
}

/// The `count` lowest flexible modes: (ω from the assembled K, ω from the directional Rayleigh
/// quotient). `rigid` lists the rigid-body modes (physical coordinates) to deflate.
fn lowest_frequencies(
    lin: &Linearised,
    rigid: &[Vec<f64>],
    count: usize,
    shift: f64,
) -> Vec<(f64, f64)> {
    let nd = lin.dofs.len();
    let sqm: Vec<f64> = lin.mass.iter().map(|m| m.sqrt()).collect();
    // A = M^-½ K M^-½ + shift·I (SPD once the rigid modes are deflated by projection).
    let mut a = vec![0.0; nd * nd];
    for r in 0..nd {
        for c in 0..nd {
            a[r * nd + c] = lin.k[r * nd + c] / (sqm[r] * sqm[c]);
        }
        a[r * nd + r] += shift;
    }
    let l = cholesky(&a, nd);
    // Orthonormal basis (in A-space) of the deflated subspace.
    let mut basis: Vec<Vec<f64>> = Vec::new();
    for r in rigid {
        let mut u: Vec<f64> = r.iter().zip(&sqm).map(|(x, s)| x * s).collect();
        project_normalise(&mut u, &basis);
        basis.push(u);
    }
    let mut loads = ElasticLoads::new(lin.model.n_elements);
    let mut out = Vec::new();
    for mode in 0..count {
        // Deterministic start with every component non-zero.
        let mut u: Vec<f64> = (0..nd)
            .map(|i| 1.0 + 0.37 * ((i * (mode + 3)) % 7) as f64)
            .collect();
        project_normalise(&mut u, &basis);
        let mut lambda = 0.0;
        for _ in 0..200 {
            let mut w = cholesky_solve(&l, nd, &u);
            project_normalise(&mut w, &basis);
            let aw: Vec<f64> = (0..nd)
                .map(|r| dotv(&a[r * nd..(r + 1) * nd], &w))
                .collect();
            let new_lambda = dotv(&w, &aw) - shift;
            u = w;
            let done = (new_lambda - lambda).abs() < 1e-14 * new_lambda.abs();
            lambda = new_lambda;
            if done {
                break;
            }
        }
        // Rayleigh quotient with K φ from a directional difference along the physical mode φ,
        // scaled so that its largest displacement is 1e-7 m.
        let phi: Vec<f64> = u.iter().zip(&sqm).map(|(x, s)| x / s).collect();
        let scale = lin
            .dofs
            .iter()
            .zip(&phi)
            .filter(|(d, _)| !matches!(d, Dof::Phi(_)))
            .map(|(_, p)| p.abs())
            .fold(0.0, f64::max);
        let kphi = stiffness_times(lin, &mut loads, &phi, 1e-7 / scale);
        let mphi: Vec<f64> = phi.iter().zip(&lin.mass).map(|(p, m)| p * m).collect();
        let lambda_r = dotv(&phi, &kphi) / dotv(&phi, &mphi);
        out.push((lambda.sqrt(), lambda_r.sqrt()));
        basis.push(u);
    }
    out
}

// (f) Uniform cantilever, N = 100: ω1 within 2e-3 of ω1_EB (1 + 1/N) (spec pass bound; the
// spec's discrete value 0.056151 is +1.00 %, i.e. 2e-5 from the formula, so 2e-3 is 100× the
// model's own deviation from the scaling law and 5× smaller than the 1/N offset it checks).
// ω2 is checked against the spec's discrete value 0.35183 to 5e-5 (its 5-digit rounding, 1.4e-5,
// plus the method's error, measured < 1e-6 by the agreement of the two estimates below).
#[test]
fn cantilever_first_frequencies() {
    let n = 100;
    let rod = StraightRod::uniform(n, 1.0, 2e-3, rod_material());
    let lin = linearise(rod, true);
    println!(
        "cantilever N = {n}: stiffness asymmetry |K - K^T|max / |K|max = {:.2e}",
        lin.asymmetry
    );
    // A conservative linearisation about a stress-free state is symmetric; what remains is
    // finite-difference error (~1e-10 of the largest entry).
    assert!(lin.asymmetry < 1e-7, "K not symmetric: {:e}", lin.asymmetry);
    let w_eb1 = euler_bernoulli(1.875_104_068_711_961);
    let w_eb2 = euler_bernoulli(4.694_091_132_974_175);
    let modes = lowest_frequencies(&lin, &[], 2, 0.0);
    let (w1_k, w1) = modes[0];
    let (w2_k, w2) = modes[1];
    let target = w_eb1 * (1.0 + 1.0 / n as f64);
    let dev = w1 / target - 1.0;
    println!(
        "omega1 = {w1:.8} rad/s (from K: {w1_k:.8}; spec discrete 0.056151; EB {w_eb1:.6}, {:+.3} %), \
         omega1/(omega_EB (1+1/N)) - 1 = {dev:.2e} (pass < 2e-3)",
        100.0 * (w1 / w_eb1 - 1.0)
    );
    println!(
        "omega2 = {w2:.7} rad/s (from K: {w2_k:.7}; spec discrete 0.35183; EB {w_eb2:.5}, {:+.3} %)",
        100.0 * (w2 / w_eb2 - 1.0)
    );
    assert!(
        dev.abs() < 2e-3,
        "omega1 = {w1}, expected {target} within 2e-3"
    );
    assert!((w2 / 0.35183 - 1.0).abs() < 5e-5, "omega2 = {w2}");
    assert!((w1 / 0.056151 - 1.0).abs() < 5e-5, "omega1 = {w1}");
}

/// First flexible bending frequency of the free–free rod with n elements: (from K, Rayleigh).
fn free_free_frequency(n: usize) -> (f64, f64, f64) {
    let rod = StraightRod::uniform(n, 1.0, 2e-3, rod_material());
    let lin = linearise(rod, false);
    // Planar rigid modes: translations along x and y, rotation about e_z through the origin
    // (δy_i = x_i, δφ_j = 1 about d2 = e_z).
    let nd = lin.dofs.len();
    let mut rigid = vec![vec![0.0; nd]; 3];
    for (b, d) in lin.dofs.iter().enumerate() {
        match *d {
            Dof::X(_) => rigid[0][b] = 1.0,
            Dof::Y(i) => {
                rigid[1][b] = 1.0;
                rigid[2][b] = lin.rest.position[i][0];
            }
            Dof::Phi(_) => rigid[2][b] = 1.0,
        }
    }
    let w_eb = euler_bernoulli(4.730_040_744_862_704);
    let (wk, w) = lowest_frequencies(&lin, &rigid, 1, 0.3 * w_eb * w_eb)[0];
    (wk, w, lin.asymmetry)
}

// (e, space) Free–free first bending frequency, N = 50 and 100: relative errors against
// Euler–Bernoulli (spec: −1.66e-3 and −4.22e-4) and their ratio ≥ 3.5 (spec pass bound; second
// order gives 4, first order 2). Both estimates of ω (assembled K and Rayleigh quotient) must
// agree to 1e-6, so that the method's error is two decades below the N = 100 error it resolves.
#[test]
fn free_free_bending_frequency_converges_at_second_order() {
    let w_eb = euler_bernoulli(4.730_040_744_862_704);
    let mut errs = Vec::new();
    for n in [50, 100] {
        let (wk, w, asym) = free_free_frequency(n);
        let err = w / w_eb - 1.0;
        println!(
            "free-free N = {n}: omega = {w:.8} rad/s (from K {wk:.8}), EB {w_eb:.6}, error {err:.3e} \
             (spec {}), asymmetry {asym:.1e}",
            if n == 50 { "-1.66e-3" } else { "-4.22e-4" }
        );
        assert!(
            (wk / w - 1.0).abs() < 1e-6,
            "the two frequency estimates disagree: {wk} vs {w}"
        );
        assert!(asym < 1e-7, "K not symmetric: {asym:e}");
        errs.push(err);
    }
    let ratio = errs[0] / errs[1];
    println!("error ratio N = 50 / N = 100: {ratio:.2} (spec 3.92, pass >= 3.5)");
    assert!(
        errs[0] < 0.0 && errs[1] < 0.0,
        "the discrete rod should be softer than Euler–Bernoulli"
    );
    assert!(ratio >= 3.5, "space convergence ratio {ratio} < 3.5");
}
