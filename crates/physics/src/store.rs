//! The structure-of-arrays store of a rod system's evolving fields: a field of 3-vectors keeps its
//! x, y and z components in three contiguous arrays (`Vec3s`), a field of director matrices its
//! nine entries in nine (`Mat3s`). Rods are consecutive ranges of one store, with no padding
//! between them. Kernels read the component slices; everything else uses `get` / `set`.

use crate::math::{Mat3, Vec3};

/// A field of 3-vectors stored by component: `x[i]`, `y[i]`, `z[i]` are entry i.
#[derive(Debug, Clone, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Vec3s {
    /// First components.
    pub x: Vec<f64>,
    /// Second components.
    pub y: Vec<f64>,
    /// Third components.
    pub z: Vec<f64>,
}

impl Vec3s {
    /// `n` zero vectors.
    pub fn zeros(n: usize) -> Self {
        Self {
            x: vec![0.0; n],
            y: vec![0.0; n],
            z: vec![0.0; n],
        }
    }

    /// The store of a slice of vectors.
    pub fn from_slice(v: &[Vec3]) -> Self {
        Self {
            x: v.iter().map(|a| a[0]).collect(),
            y: v.iter().map(|a| a[1]).collect(),
            z: v.iter().map(|a| a[2]).collect(),
        }
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Whether the field has no entries.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Entry i.
    #[inline(always)]
    pub fn get(&self, i: usize) -> Vec3 {
        [self.x[i], self.y[i], self.z[i]]
    }

    /// Set entry i.
    #[inline(always)]
    pub fn set(&mut self, i: usize, v: Vec3) {
        self.x[i] = v[0];
        self.y[i] = v[1];
        self.z[i] = v[2];
    }

    /// Add `v` to entry i.
    #[inline(always)]
    pub fn add(&mut self, i: usize, v: Vec3) {
        self.x[i] += v[0];
        self.y[i] += v[1];
        self.z[i] += v[2];
    }

    /// Set every entry to zero without reallocating.
    pub fn fill_zero(&mut self) {
        self.x.fill(0.0);
        self.y.fill(0.0);
        self.z.fill(0.0);
    }

    /// Entries `range` as vectors (allocates; not for hot loops).
    pub fn to_vec(&self, range: std::ops::Range<usize>) -> Vec<Vec3> {
        range.map(|i| self.get(i)).collect()
    }

    /// Overwrite entries `first..first + v.len()` with `v`.
    pub fn write(&mut self, first: usize, v: &[Vec3]) {
        for (k, a) in v.iter().enumerate() {
            self.set(first + k, *a);
        }
    }

    /// Append the entries of `v`.
    pub fn extend(&mut self, v: &[Vec3]) {
        self.x.extend(v.iter().map(|a| a[0]));
        self.y.extend(v.iter().map(|a| a[1]));
        self.z.extend(v.iter().map(|a| a[2]));
    }

    /// Whether every component of every entry is finite.
    pub fn all_finite(&self) -> bool {
        self.x
            .iter()
            .chain(&self.y)
            .chain(&self.z)
            .all(|v| v.is_finite())
    }
}

/// A field of 3×3 matrices stored by entry: `m[3 r + c][j]` is row r, column c of matrix j. For
/// directors, row r is d_{r+1} in lab components.
#[derive(Debug, Clone, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Mat3s {
    /// The nine entry arrays, row-major.
    pub m: [Vec<f64>; 9],
}

impl Mat3s {
    /// `n` zero matrices.
    pub fn zeros(n: usize) -> Self {
        Self {
            m: std::array::from_fn(|_| vec![0.0; n]),
        }
    }

    /// The store of a slice of matrices.
    pub fn from_slice(v: &[Mat3]) -> Self {
        Self {
            m: std::array::from_fn(|k| v.iter().map(|q| q[k / 3][k % 3]).collect()),
        }
    }

    /// Number of matrices.
    pub fn len(&self) -> usize {
        self.m[0].len()
    }

    /// Whether the field has no entries.
    pub fn is_empty(&self) -> bool {
        self.m[0].is_empty()
    }

    /// Matrix j.
    #[inline(always)]
    pub fn get(&self, j: usize) -> Mat3 {
        let m = &self.m;
        [
            [m[0][j], m[1][j], m[2][j]],
            [m[3][j], m[4][j], m[5][j]],
            [m[6][j], m[7][j], m[8][j]],
        ]
    }

    /// Set matrix j.
    #[inline(always)]
    pub fn set(&mut self, j: usize, q: &Mat3) {
        for k in 0..9 {
            self.m[k][j] = q[k / 3][k % 3];
        }
    }

    /// Matrices `range` (allocates; not for hot loops).
    pub fn to_vec(&self, range: std::ops::Range<usize>) -> Vec<Mat3> {
        range.map(|j| self.get(j)).collect()
    }

    /// Overwrite matrices `first..first + v.len()` with `v`.
    pub fn write(&mut self, first: usize, v: &[Mat3]) {
        for (k, q) in v.iter().enumerate() {
            self.set(first + k, q);
        }
    }

    /// Append the matrices of `v`.
    pub fn extend(&mut self, v: &[Mat3]) {
        for (k, col) in self.m.iter_mut().enumerate() {
            col.extend(v.iter().map(|q| q[k / 3][k % 3]));
        }
    }

    /// Whether every entry is finite.
    pub fn all_finite(&self) -> bool {
        self.m.iter().flatten().all(|v| v.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips() {
        let v = vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]];
        let s = Vec3s::from_slice(&v);
        assert_eq!(s.to_vec(0..2), v);
        let q = vec![[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]]; 3];
        let m = Mat3s::from_slice(&q);
        assert_eq!(m.to_vec(0..3), q);
        assert_eq!(m.m[5][1], 6.0);
    }
}
