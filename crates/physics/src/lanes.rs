//! The 4-lane f64 type of the SIMD kernels: `X`, a group of `LANES` numbers with lane-wise IEEE
//! arithmetic (LLVM turns each operation into one AVX2 instruction, or two SSE2 ones in the
//! baseline build). The stepper uses it with lanes across elements, `batch` with lanes across
//! rods; both instantiate the shared `Real` formulas of `math` and `internal` with it, so a lane
//! performs exactly the operations the `f64` code performs (no FMA, same order).

use crate::math::Real;

/// Number of lanes of `X`: 4 f64 fill one AVX2 register.
pub const LANES: usize = 4;

/// The lanes' storage.
pub(crate) type L = [f64; LANES];

/// `LANES` f64 lanes with lane-wise IEEE arithmetic.
#[derive(Debug, Clone, Copy)]
#[repr(transparent)]
pub(crate) struct X(pub L);

macro_rules! lanewise {
    ($tr:ident, $f:ident, $op:tt) => {
        impl std::ops::$tr for X {
            type Output = X;
            #[inline(always)]
            fn $f(self, o: X) -> X {
                let (a, b) = (self.0, o.0);
                X([a[0] $op b[0], a[1] $op b[1], a[2] $op b[2], a[3] $op b[3]])
            }
        }
    };
}
lanewise!(Add, add, +);
lanewise!(Sub, sub, -);
lanewise!(Mul, mul, *);
lanewise!(Div, div, /);

impl std::ops::Neg for X {
    type Output = X;
    #[inline(always)]
    fn neg(self) -> X {
        let a = self.0;
        X([-a[0], -a[1], -a[2], -a[3]])
    }
}

impl Real for X {
    #[inline(always)]
    fn splat(x: f64) -> X {
        X([x; LANES])
    }
}

impl X {
    /// Lane-wise square root (IEEE, correctly rounded like `f64::sqrt`).
    #[inline(always)]
    pub fn sqrt(self) -> X {
        let a = self.0;
        X([a[0].sqrt(), a[1].sqrt(), a[2].sqrt(), a[3].sqrt()])
    }

    /// Entries `j..j + LANES` of `s`.
    #[inline(always)]
    pub fn load(s: &[f64], j: usize) -> X {
        X(s[j..j + LANES].try_into().unwrap())
    }

    /// Write the lanes to entries `j..j + LANES` of `s`.
    #[inline(always)]
    pub fn store(self, s: &mut [f64], j: usize) {
        s[j..j + LANES].copy_from_slice(&self.0);
    }

    /// Component `c` of entries `j..j + LANES` of a slice of 3-vectors.
    #[inline(always)]
    pub fn gather(v: &[[f64; 3]], j: usize, c: usize) -> X {
        let v = &v[j..j + LANES];
        X([v[0][c], v[1][c], v[2][c], v[3][c]])
    }
}

/// `x` in every lane.
#[inline(always)]
pub(crate) fn s(x: f64) -> X {
    X::splat(x)
}

/// Entries `j..j + LANES` of three component slices.
#[inline(always)]
pub(crate) fn load3(v: [&[f64]; 3], j: usize) -> [X; 3] {
    [X::load(v[0], j), X::load(v[1], j), X::load(v[2], j)]
}

/// The 3-vectors `j..j + LANES` of a slice of 3-vectors, by component.
#[inline(always)]
pub(crate) fn gather3(v: &[[f64; 3]], j: usize) -> [X; 3] {
    [X::gather(v, j, 0), X::gather(v, j, 1), X::gather(v, j, 2)]
}

/// Write three lane groups to entries `j..j + LANES` of three component slices.
#[inline(always)]
pub(crate) fn store3(v: [X; 3], out: [&mut [f64]; 3], j: usize) {
    let [x, y, z] = out;
    v[0].store(x, j);
    v[1].store(y, j);
    v[2].store(z, j);
}

/// `math::log_relative`'s rotation vector of Q_a Q_bᵀ for four frame pairs: its series in every
/// lane, libm's atan2 (`log_factor_trig`) only in the lanes outside the series' range — per lane
/// the operations of the `f64` function, with no branch when every lane takes the series.
#[inline(always)]
pub(crate) fn log_relative_x(qa: &[[X; 3]; 3], qb: &[[X; 3]; 3]) -> [X; 3] {
    use crate::math::{asin_over_sin_series, log_factor_trig, log_parts, LOG_SERIES_MAX_SQ};
    let (w, c, s2) = log_parts(qa, qb);
    let mut factor = asin_over_sin_series(s2);
    let series = |l: usize| c.0[l] > 0.0 && s2.0[l] < LOG_SERIES_MAX_SQ;
    if !(series(0) & series(1) & series(2) & series(3)) {
        for l in (0..LANES).filter(|&l| !series(l)) {
            factor.0[l] = log_factor_trig(s2.0[l], c.0[l]).0;
        }
    }
    [factor * w[0], factor * w[1], factor * w[2]]
}
