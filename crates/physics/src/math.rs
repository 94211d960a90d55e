//! Small fixed-size vector and rotation kernels used by every hot loop: 3-vectors as `[f64; 3]`,
//! director matrices as `[[f64; 3]; 3]` (rows are d1, d2, d3), Rodrigues' exponential (spec §5)
//! and the numerically safe rotation logarithm (spec §2). No allocation, no dynamic dispatch.

/// A 3-vector, lab or material components as the caller states.
pub type Vec3 = [f64; 3];
/// A 3×3 matrix stored by rows; for directors the rows are d1, d2, d3 in lab components.
pub type Mat3 = [[f64; 3]; 3];

/// The identity matrix.
pub const IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// A number the shared kernels compute with: `f64`, or a group of `f64` lanes (`batch`) computed
/// lane by lane with the same IEEE operations. The kernels below are written once over `Real`
/// and the public `f64` functions call them, so a batched lane and a lone rod perform the same
/// operations in the same order (constants enter through `splat`, folded at compile time).
pub(crate) trait Real:
    Copy
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Div<Output = Self>
    + std::ops::Neg<Output = Self>
{
    /// The value `x` (in every lane).
    fn splat(x: f64) -> Self;
}

impl Real for f64 {
    #[inline(always)]
    fn splat(x: f64) -> f64 {
        x
    }
}

/// Dot product.
#[inline(always)]
pub fn dot(a: Vec3, b: Vec3) -> f64 {
    dot_r(a, b)
}

#[inline(always)]
pub(crate) fn dot_r<S: Real>(a: [S; 3], b: [S; 3]) -> S {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Cross product a × b.
#[inline(always)]
pub fn cross(a: Vec3, b: Vec3) -> Vec3 {
    cross_r(a, b)
}

#[inline(always)]
pub(crate) fn cross_r<S: Real>(a: [S; 3], b: [S; 3]) -> [S; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// a + b.
#[inline(always)]
pub fn add(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// a − b.
#[inline(always)]
pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// s · a.
#[inline(always)]
pub fn scale(s: f64, a: Vec3) -> Vec3 {
    [s * a[0], s * a[1], s * a[2]]
}

/// Euclidean norm.
#[inline(always)]
pub fn norm(a: Vec3) -> f64 {
    dot(a, a).sqrt()
}

/// The unit vector along `a`, or None for a zero or non-finite vector. Vectors whose squared
/// norm is a normal number are divided by their plain norm (bit for bit `a / |a|`); tiny or huge
/// ones (`[1e-300, 0, 0]`, `[1e200, 0, 0]`, whose squares underflow or overflow) are first
/// scaled by their largest component.
pub fn normalize(a: Vec3) -> Option<Vec3> {
    if !a.iter().all(|c| c.is_finite()) {
        return None;
    }
    let l2 = dot(a, a);
    if l2.is_normal() && l2.is_finite() {
        return Some(scale(1.0 / l2.sqrt(), a));
    }
    let m = a.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    if m == 0.0 {
        return None;
    }
    // Divide (1/m overflows for subnormal m).
    let b = [a[0] / m, a[1] / m, a[2] / m];
    Some(scale(1.0 / norm(b), b))
}

/// Q a: lab → material components when Q is a director matrix.
#[inline(always)]
pub fn mat_vec(q: &Mat3, a: Vec3) -> Vec3 {
    mat_vec_r(q, a)
}

#[inline(always)]
pub(crate) fn mat_vec_r<S: Real>(q: &[[S; 3]; 3], a: [S; 3]) -> [S; 3] {
    [dot_r(q[0], a), dot_r(q[1], a), dot_r(q[2], a)]
}

/// Qᵀ a: material → lab components when Q is a director matrix.
#[inline(always)]
pub fn mat_t_vec(q: &Mat3, a: Vec3) -> Vec3 {
    mat_t_vec_r(q, a)
}

#[inline(always)]
pub(crate) fn mat_t_vec_r<S: Real>(q: &[[S; 3]; 3], a: [S; 3]) -> [S; 3] {
    [
        q[0][0] * a[0] + q[1][0] * a[1] + q[2][0] * a[2],
        q[0][1] * a[0] + q[1][1] * a[1] + q[2][1] * a[2],
        q[0][2] * a[0] + q[1][2] * a[1] + q[2][2] * a[2],
    ]
}

/// A B.
#[inline(always)]
pub fn mat_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    mat_mul_r(a, b)
}

#[inline(always)]
pub(crate) fn mat_mul_r<S: Real>(a: &[[S; 3]; 3], b: &[[S; 3]; 3]) -> [[S; 3]; 3] {
    let mut c = [[S::splat(0.0); 3]; 3];
    for r in 0..3 {
        for col in 0..3 {
            c[r][col] = a[r][0] * b[0][col] + a[r][1] * b[1][col] + a[r][2] * b[2][col];
        }
    }
    c
}

/// A Bᵀ.
#[inline(always)]
pub fn mat_mul_t(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut c = [[0.0; 3]; 3];
    for r in 0..3 {
        for col in 0..3 {
            c[r][col] = dot(a[r], b[col]);
        }
    }
    c
}

/// Aᵀ.
#[inline(always)]
pub fn transpose(a: &Mat3) -> Mat3 {
    [
        [a[0][0], a[1][0], a[2][0]],
        [a[0][1], a[1][1], a[2][1]],
        [a[0][2], a[1][2], a[2][2]],
    ]
}

/// Largest |a|² for which `exp_neg_skew` uses the Taylor series of its coefficients (|a| < 0.1).
pub const EXP_SERIES_MAX_SQ: f64 = 0.01;

/// The rotation exp(−[a]×) by Rodrigues' formula (spec eq. 5.2–5.3). For |a| < 0.1 the
/// coefficients come from their Taylor series (error < 1e-17), so no libm call is made there.
#[inline(always)]
pub fn exp_neg_skew(a: Vec3) -> Mat3 {
    let t2 = dot(a, a);
    if t2 < EXP_SERIES_MAX_SQ {
        exp_neg_skew_series(a)
    } else {
        let t = t2.sqrt();
        rodrigues(a, t.sin() / t, (1.0 - t.cos()) / t2)
    }
}

/// `exp_neg_skew` by the series branch only: bit-identical to it for |a|² < `EXP_SERIES_MAX_SQ`,
/// branch-free for the stepper's loop over frames. Callers check the bound first.
/// The series multiplies by the rounded reciprocals 1/6, 1/20, … rather than dividing: that moves
/// s and c by at most an ulp of their correction terms (< 1e-19 for |a| < 0.1) and saves eight
/// divisions per frame, about 9 % of the step time (spec §14: precompute reciprocals).
#[inline(always)]
pub fn exp_neg_skew_series(a: Vec3) -> Mat3 {
    exp_neg_skew_series_r(a)
}

#[inline(always)]
pub(crate) fn exp_neg_skew_series_r<S: Real>(a: [S; 3]) -> [[S; 3]; 3] {
    let k = S::splat;
    let one = k(1.0);
    let t2 = dot_r(a, a);
    let s = one
        - t2 * k(1.0 / 6.0)
            * (one - t2 * k(1.0 / 20.0) * (one - t2 * k(1.0 / 42.0) * (one - t2 * k(1.0 / 72.0))));
    let c = k(0.5)
        * (one
            - t2 * k(1.0 / 12.0)
                * (one
                    - t2 * k(1.0 / 30.0)
                        * (one - t2 * k(1.0 / 56.0) * (one - t2 * k(1.0 / 90.0)))));
    rodrigues_r(a, s, c)
}

/// I − s[a]× + c[a]×² with s = sin θ/θ, c = (1 − cos θ)/θ² (θ = |a|): exp(−[a]×) from
/// coefficients the caller already has (the control crate's statics also needs c).
#[inline(always)]
pub fn rodrigues(a: Vec3, s: f64, c: f64) -> Mat3 {
    rodrigues_r(a, s, c)
}

#[inline(always)]
pub(crate) fn rodrigues_r<S: Real>(a: [S; 3], s: S, c: S) -> [[S; 3]; 3] {
    let (a0, a1, a2) = (a[0], a[1], a[2]);
    let one = S::splat(1.0);
    [
        [
            one - c * (a1 * a1 + a2 * a2),
            s * a2 + c * a0 * a1,
            -s * a1 + c * a0 * a2,
        ],
        [
            -s * a2 + c * a0 * a1,
            one - c * (a0 * a0 + a2 * a2),
            s * a0 + c * a1 * a2,
        ],
        [
            s * a1 + c * a0 * a2,
            -s * a0 + c * a1 * a2,
            one - c * (a0 * a0 + a1 * a1),
        ],
    ]
}

/// Largest s² = sin²θ for which `log_relative` uses the series of arcsin(s)/s (θ < 0.05 rad).
pub const LOG_SERIES_MAX_SQ: f64 = 0.0025;

/// Rotation vector Θ of R = Q_a Q_bᵀ (so that R = exp([Θ]×)), from the rows of the two
/// director matrices without forming R (spec §2, "numerically safe Log"). Returns Θ and the
/// rotation angle θ = |Θ| ∈ [0, π]. For θ near π the result is ill-conditioned; callers guard it.
#[inline(always)]
pub fn log_relative(qa: &Mat3, qb: &Mat3) -> (Vec3, f64) {
    let (w, c, s2) = log_parts(qa, qb);
    let (f, theta) = if c > 0.0 && s2 < LOG_SERIES_MAX_SQ {
        // arcsin(s)/s by its series; θ = arcsin(s) for c > 0.
        let f = asin_over_sin_series(s2);
        (f, f * s2.sqrt())
    } else {
        log_factor_trig(s2, c)
    };
    ([f * w[0], f * w[1], f * w[2]], theta)
}

/// The parts of `log_relative`: w = axial part of R (|w| = sin θ), c = cos θ and s² = |w|².
#[inline(always)]
pub(crate) fn log_parts<S: Real>(qa: &[[S; 3]; 3], qb: &[[S; 3]; 3]) -> ([S; 3], S, S) {
    // R_mn = d_m(a) · d_n(b)
    let r01 = dot_r(qa[0], qb[1]);
    let r10 = dot_r(qa[1], qb[0]);
    let r02 = dot_r(qa[0], qb[2]);
    let r20 = dot_r(qa[2], qb[0]);
    let r12 = dot_r(qa[1], qb[2]);
    let r21 = dot_r(qa[2], qb[1]);
    let trace = dot_r(qa[0], qb[0]) + dot_r(qa[1], qb[1]) + dot_r(qa[2], qb[2]);
    let half = S::splat(0.5);
    let w = [half * (r21 - r12), half * (r02 - r20), half * (r10 - r01)];
    let c = half * (trace - S::splat(1.0));
    (w, c, dot_r(w, w))
}

/// arcsin(s)/s by its series in s² (used where c > 0 and s² < `LOG_SERIES_MAX_SQ`).
#[inline(always)]
pub(crate) fn asin_over_sin_series<S: Real>(s2: S) -> S {
    let k = S::splat;
    k(1.0)
        + s2 * (k(1.0 / 6.0)
            + s2 * (k(3.0 / 40.0)
                + s2 * (k(5.0 / 112.0) + s2 * (k(35.0 / 1152.0) + s2 * k(63.0 / 2816.0)))))
}

/// The factor θ/s and the angle θ of `log_relative` outside its series branch (libm atan2).
#[inline(always)]
pub(crate) fn log_factor_trig(s2: f64, c: f64) -> (f64, f64) {
    let s = s2.sqrt();
    let theta = s.atan2(c);
    if s > 0.0 {
        (theta / s, theta)
    } else {
        // s = 0 and c < 0: a half turn; the axis is not recoverable from w. Callers treat
        // θ > 0.9π as a guard failure before using Θ.
        (0.0, std::f64::consts::PI)
    }
}

/// Largest entry of |Q Qᵀ − I|: the orthonormality defect of a director matrix.
pub fn orthonormality_defect(q: &Mat3) -> f64 {
    let g = mat_mul_t(q, q);
    let mut d: f64 = 0.0;
    for (r, row) in g.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            let target = if r == c { 1.0 } else { 0.0 };
            d = d.max((v - target).abs());
        }
    }
    d
}

/// One Björck step towards the nearest orthonormal matrix: Q ← ½ Q (3I − QᵀQ) (spec §5).
/// Exact zeros of a planar frame stay exact zeros.
pub fn bjorck(q: &Mat3) -> Mat3 {
    let qtq = mat_mul(&transpose(q), q);
    let mut m = [[0.0; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            m[r][c] = if r == c { 3.0 } else { 0.0 } - qtq[r][c];
        }
    }
    let p = mat_mul(q, &m);
    let mut out = [[0.0; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            out[r][c] = 0.5 * p[r][c];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn skew(a: Vec3) -> Mat3 {
        [[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]]
    }

    /// Reference exp of a skew matrix by a long Taylor series with scaling and squaring.
    fn expm_reference(a: Vec3) -> Mat3 {
        let k = 2;
        let sc = 1.0 / f64::from(1 << k);
        let m = skew(scale(sc, a));
        let mut term = IDENTITY;
        let mut sum = IDENTITY;
        for n in 1..30 {
            term = mat_mul(&term, &m);
            for row in term.iter_mut() {
                for v in row.iter_mut() {
                    *v /= n as f64;
                }
            }
            for r in 0..3 {
                for c in 0..3 {
                    sum[r][c] += term[r][c];
                }
            }
        }
        for _ in 0..k {
            sum = mat_mul(&sum, &sum);
        }
        sum
    }

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64) / ((1u64 << 53) as f64)
    }

    #[test]
    fn normalize_handles_tiny_huge_and_zero_vectors() {
        assert_eq!(normalize([1e-300, 0.0, 0.0]), Some([1.0, 0.0, 0.0]));
        assert_eq!(normalize([1e200, 0.0, 0.0]), Some([1.0, 0.0, 0.0]));
        assert_eq!(normalize([0.0, -5e-320, 0.0]), Some([0.0, -1.0, 0.0]));
        let u = normalize([3e-300, 4e-300, 0.0]).unwrap();
        assert!((u[0] - 0.6).abs() < 1e-15 && (u[1] - 0.8).abs() < 1e-15);
        assert_eq!(normalize([0.0; 3]), None);
        assert_eq!(normalize([f64::NAN, 1.0, 0.0]), None);
        assert_eq!(normalize([f64::INFINITY, 0.0, 0.0]), None);
        // Ordinary vectors: exactly a / |a|.
        let a = [0.3, -0.4, 1.2];
        assert_eq!(normalize(a), Some(scale(1.0 / norm(a), a)));
    }

    fn random_vec(seed: &mut u64, max_norm: f64) -> Vec3 {
        loop {
            let v = [
                2.0 * lcg(seed) - 1.0,
                2.0 * lcg(seed) - 1.0,
                2.0 * lcg(seed) - 1.0,
            ];
            let n = norm(v);
            if n > 1e-3 && n <= 1.0 {
                return scale(max_norm * lcg(seed) / n, v);
            }
        }
    }

    // Spec §13 (i1): Rodrigues agrees with an independent matrix exponential to 1e-14, on both
    // sides of the series/libm switch at θ = 0.1.
    #[test]
    fn rodrigues_matches_reference_exponential() {
        let mut seed = 7;
        let mut cases: Vec<Vec3> = (0..2000).map(|_| random_vec(&mut seed, 3.0)).collect();
        for t in [0.0, 1e-9, 0.0999999999, 0.1, 0.1000000001] {
            cases.push([t, 0.0, 0.0]);
            cases.push(scale(t / 3f64.sqrt(), [1.0, -1.0, 1.0]));
        }
        for a in cases {
            let r = exp_neg_skew(a);
            let reference = expm_reference(scale(-1.0, a));
            for i in 0..3 {
                for j in 0..3 {
                    assert!((r[i][j] - reference[i][j]).abs() < 1e-14, "a = {a:?}");
                }
            }
        }
    }

    // Spec §13 (i2): Log(exp([a]×)) = a for |a| ≤ 0.9π, across the series branch at s = 0.05.
    #[test]
    fn log_inverts_exp() {
        let mut seed = 11;
        let mut cases: Vec<Vec3> = (0..2000)
            .map(|_| random_vec(&mut seed, 0.9 * std::f64::consts::PI))
            .collect();
        for t in [0.0, 1e-12, 0.0499, 0.05, 0.0501, 0.05002] {
            cases.push([0.0, t, 0.0]);
            cases.push(scale(t / 2f64.sqrt(), [1.0, 0.0, -1.0]));
        }
        for a in cases {
            // exp([a]x) = exp(-[-a]x)
            let r = exp_neg_skew(scale(-1.0, a));
            let (theta_vec, theta) = log_relative(&r, &IDENTITY);
            let err = norm(sub(theta_vec, a));
            assert!(err <= 1e-13 * norm(a) + 1e-16, "a = {a:?}, err = {err:e}");
            assert!((theta - norm(a)).abs() <= 1e-13 * norm(a) + 1e-16);
        }
    }

    // Spec §13 (i5): 1e6 successive small random rotations keep Q orthonormal to 1e-12.
    #[test]
    fn repeated_rotations_stay_orthonormal() {
        let mut seed = 3;
        let mut q = IDENTITY;
        for _ in 0..1_000_000 {
            q = mat_mul(&exp_neg_skew(random_vec(&mut seed, 0.1)), &q);
        }
        assert!(
            orthonormality_defect(&q) < 1e-12,
            "{}",
            orthonormality_defect(&q)
        );
    }

    #[test]
    fn bjorck_restores_orthonormality_and_keeps_planar_zeros() {
        let mut q = [[0.0, 1.0 + 1e-9, 0.0], [0.0, 0.0, 1.0], [1.0, 2e-9, 0.0]];
        q = bjorck(&q);
        assert!(orthonormality_defect(&q) < 1e-15);
        assert_eq!(q[0][2], 0.0);
        assert_eq!(q[2][2], 0.0);
        assert_eq!(q[1][0], 0.0);
    }

    #[test]
    fn rotation_sense_matches_spec() {
        // ω = (0, Ω, 0) with d2 = e_z turns d3 counter-clockwise about e_z (spec §5 check).
        let q = [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]];
        let q1 = mat_mul(&exp_neg_skew([0.0, 0.01, 0.0]), &q);
        assert!(q1[2][1] > 0.0 && (q1[2][1] - 0.01f64.sin()).abs() < 1e-15);
    }
}
