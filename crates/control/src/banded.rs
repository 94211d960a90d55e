//! A banded matrix and its LU factorisation with partial pivoting inside the band (the LAPACK
//! `gbtrf`/`gbtrs` scheme): lower bandwidth kl, upper bandwidth ku, the factors' upper bandwidth
//! grows to kl + ku through row exchanges. Used by the muscle statics (Newton on the banded
//! equilibrium Jacobian) and its adjoint (the transposed solve). Storage is row-wise, entry
//! (i, j) at i · width + (j − i + kl), width = 2 kl + ku + 1; nothing is allocated after `new`.

/// A square banded matrix, factored in place by `factor`.
#[derive(Debug, Clone)]
pub struct BandMatrix {
    n: usize,
    kl: usize,
    ku: usize,
    width: usize,
    a: Vec<f64>,
    pivot: Vec<usize>,
    factored: bool,
}

/// The factorisation met a zero pivot (the matrix is singular to working precision).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("singular banded matrix: zero pivot in column {column}")]
pub struct SingularMatrix {
    /// Column of the zero pivot.
    pub column: usize,
}

impl BandMatrix {
    /// A zero n × n matrix with lower bandwidth `kl` and upper bandwidth `ku`.
    pub fn new(n: usize, kl: usize, ku: usize) -> Self {
        let width = 2 * kl + ku + 1;
        Self {
            n,
            kl,
            ku,
            width,
            a: vec![0.0; n * width],
            pivot: vec![0; n],
            factored: false,
        }
    }

    /// Order n.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Lower and upper bandwidths (kl, ku) of the matrix as set.
    pub fn bandwidths(&self) -> (usize, usize) {
        (self.kl, self.ku)
    }

    /// Set every entry to zero (and forget a factorisation).
    pub fn clear(&mut self) {
        self.a.fill(0.0);
        self.factored = false;
    }

    /// Whether (i, j) lies in the band of the matrix as set.
    #[inline]
    pub fn in_band(&self, i: usize, j: usize) -> bool {
        j + self.kl >= i && j <= i + self.ku
    }

    /// Entry (i, j); zero outside the band.
    #[inline]
    pub fn get(&self, i: usize, j: usize) -> f64 {
        if j + self.kl >= i && j <= i + self.ku + self.kl {
            self.a[i * self.width + j + self.kl - i]
        } else {
            0.0
        }
    }

    /// Set entry (i, j), which must lie in the band.
    #[inline]
    pub fn set(&mut self, i: usize, j: usize, v: f64) {
        debug_assert!(self.in_band(i, j), "({i}, {j}) outside the band");
        self.a[i * self.width + j + self.kl - i] = v;
    }

    /// Add to entry (i, j), which must lie in the band.
    #[inline]
    pub fn add(&mut self, i: usize, j: usize, v: f64) {
        debug_assert!(self.in_band(i, j), "({i}, {j}) outside the band");
        self.a[i * self.width + j + self.kl - i] += v;
    }

    /// y = A x (before factoring).
    pub fn mul(&self, x: &[f64], y: &mut [f64]) {
        for i in 0..self.n {
            let lo = i.saturating_sub(self.kl);
            let hi = (i + self.ku + 1).min(self.n);
            y[i] = (lo..hi).map(|j| self.get(i, j) * x[j]).sum();
        }
    }

    /// LU factorisation with row pivoting inside the band, in place.
    pub fn factor(&mut self) -> Result<(), SingularMatrix> {
        let (n, kl, w) = (self.n, self.kl, self.width);
        let reach = self.ku + self.kl; // upper bandwidth of U
        for k in 0..n {
            let last = (k + kl).min(n - 1);
            let mut p = k;
            let mut best = self.a[k * w + kl].abs();
            for i in k + 1..=last {
                let v = self.a[i * w + k + kl - i].abs();
                if v > best {
                    best = v;
                    p = i;
                }
            }
            self.pivot[k] = p;
            if best == 0.0 || !best.is_finite() {
                return Err(SingularMatrix { column: k });
            }
            let jmax = (k + reach).min(n - 1);
            if p != k {
                for j in k..=jmax {
                    let (ik, ip) = (k * w + j + kl - k, p * w + j + kl - p);
                    self.a.swap(ik, ip);
                }
            }
            let d = 1.0 / self.a[k * w + kl];
            // Row k's U entries right of the pivot, columns k + 1..=jmax, and each row i below
            // as slices over the same columns (disjoint: row i starts after row k ends), so that
            // the update is a plain a·x + y loop the compiler vectorises.
            let cols = jmax - k;
            for i in k + 1..=last {
                let (head, tail) = self.a.split_at_mut(i * w);
                let rk = &head[k * w + kl + 1..k * w + kl + 1 + cols];
                let lik = kl + k - i;
                let l = tail[lik] * d;
                tail[lik] = l;
                if l != 0.0 {
                    let ri = &mut tail[lik + 1..lik + 1 + cols];
                    for (x, v) in ri.iter_mut().zip(rk) {
                        *x -= l * v;
                    }
                }
            }
        }
        self.factored = true;
        Ok(())
    }

    /// Solve A x = b in place (after `factor`).
    pub fn solve(&self, b: &mut [f64]) {
        assert!(self.factored, "factor first");
        let (n, kl, w) = (self.n, self.kl, self.width);
        let reach = self.ku + self.kl;
        let b = &mut b[..n];
        // L y = P b. Column k of L below the diagonal: entries (k + 1 + r, k) at stride w − 1.
        for k in 0..n {
            let p = self.pivot[k];
            if p != k {
                b.swap(k, p);
            }
            let bk = b[k];
            let last = (k + kl).min(n - 1);
            if last > k {
                let col = self.a[(k + 1) * w + kl - 1..].iter().step_by(w - 1);
                for (x, l) in b[k + 1..=last].iter_mut().zip(col) {
                    *x -= l * bk;
                }
            }
        }
        // U x = y: row k of U right of the diagonal is contiguous.
        for k in (0..n).rev() {
            let jmax = (k + reach).min(n - 1);
            let row = &self.a[k * w + kl..k * w + kl + 1 + jmax - k];
            // Four partial sums: the row's products are independent, a single running sum
            // would make the solve a chain of dependent additions.
            let (u, x) = (&row[1..], &b[k + 1..=jmax]);
            let mut part = [0.0; 4];
            let (uc, xc) = (u.chunks_exact(4), x.chunks_exact(4));
            let (ur, xr) = (uc.remainder(), xc.remainder());
            for (u4, x4) in uc.zip(xc) {
                for l in 0..4 {
                    part[l] += u4[l] * x4[l];
                }
            }
            let mut s = b[k] - ((part[0] + part[1]) + (part[2] + part[3]));
            for (u, x) in ur.iter().zip(xr) {
                s -= u * x;
            }
            b[k] = s / row[0];
        }
    }

    /// Solve Aᵀ x = b in place (after `factor`): Uᵀ z = b, Lᵀ y = z, x = Pᵀ y.
    pub fn solve_transposed(&self, b: &mut [f64]) {
        assert!(self.factored, "factor first");
        let (n, kl, w) = (self.n, self.kl, self.width);
        let reach = self.ku + self.kl;
        for k in 0..n {
            let mut s = b[k];
            for i in k.saturating_sub(reach)..k {
                s -= self.a[i * w + k + kl - i] * b[i];
            }
            b[k] = s / self.a[k * w + kl];
        }
        for k in (0..n).rev() {
            let mut s = b[k];
            for i in k + 1..=(k + kl).min(n - 1) {
                s -= self.a[i * w + k + kl - i] * b[i];
            }
            b[k] = s;
            let p = self.pivot[k];
            if p != k {
                b.swap(k, p);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
    }

    // Against a dense reference: A x = b and Aᵀ x = b solved to round-off on a random banded
    // matrix whose small diagonal forces row exchanges.
    #[test]
    fn banded_lu_solves_with_pivoting() {
        let (n, kl, ku) = (40, 3, 2);
        let mut seed = 7;
        let mut m = BandMatrix::new(n, kl, ku);
        for i in 0..n {
            for j in i.saturating_sub(kl)..(i + ku + 1).min(n) {
                let v = if i == j {
                    1e-3 * lcg(&mut seed)
                } else {
                    lcg(&mut seed)
                };
                m.set(i, j, v);
            }
        }
        let orig = m.clone();
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut b = vec![0.0; n];
        orig.mul(&x, &mut b);
        // Aᵀ x by hand.
        let mut bt = vec![0.0; n];
        for i in 0..n {
            for j in 0..n {
                bt[j] += orig.get(i, j) * x[i];
            }
        }
        m.factor().unwrap();
        assert!(m.pivot.iter().enumerate().any(|(k, &p)| p != k));
        m.solve(&mut b);
        m.solve_transposed(&mut bt);
        for i in 0..n {
            assert!((b[i] - x[i]).abs() < 1e-9, "{i}: {} vs {}", b[i], x[i]);
            assert!((bt[i] - x[i]).abs() < 1e-9, "{i}: {} vs {}", bt[i], x[i]);
        }
    }
}
