//! A small dense SPD factorisation for the Schur complement.
//!
//! Why not nalgebra's `Cholesky<f64, Dyn>`: at the sizes of planar mechanisms (5–40 equations) its
//! generic-dimension machinery (column views, axpy per column, bounds checks) cost about as much as
//! all the rest of a right-hand-side evaluation (profiled with `perf` on scenario B: 11 % of the run
//! for the factorisation plus 9 % for the two triangular solves). This kernel works on one flat
//! row-major buffer that is reused for every evaluation, and is checked against nalgebra in tests.

use lash_core::lane::Real;

/// Lower Cholesky factor L (row-major, n × n, upper part unused) of an SPD matrix, in place.
#[derive(Debug, Clone)]
pub struct SmallCholesky {
    n: usize,
    a: Vec<f64>,
    inv_diag: Vec<f64>,
    /// Column of the first structural non-zero of each row (its profile); all zeros for a dense
    /// matrix. L has the same profile (Cholesky fills nothing left of it).
    first: Vec<usize>,
    /// Some row starts right of column 0 and the order is above the unrolled kernels'.
    profiled: bool,
}

impl SmallCholesky {
    /// A workspace for n × n matrices.
    pub fn new(n: usize) -> Self {
        Self { n, a: vec![0.0; n * n], inv_diag: vec![0.0; n], first: vec![0; n], profiled: false }
    }

    /// Declares the profile of the matrices to factor: row i has no non-zero left of column
    /// `first[i]` (≤ i). Above the unrolled orders (12), factoring and solving then skip what lies
    /// left of the profile, where L is zero: the same operations on the non-zeros, in the same
    /// order, so the results are bit for bit those of the dense kernel. (The spatial slider-crank's
    /// ideal mechanism, 17 equations in a chain of joints: a third of the dense work.)
    ///
    /// # Panics
    /// If `first` has not n entries or some `first[i] > i`.
    pub fn set_profile(&mut self, first: &[usize]) {
        assert!(
            first.len() == self.n && first.iter().enumerate().all(|(i, &f)| f <= i),
            "a profile has one first column per row, at or left of the diagonal"
        );
        self.first.copy_from_slice(first);
        self.profiled = self.n > 12 && first.iter().any(|&f| f > 0);
    }

    /// Column of the first entry of row `i` that factoring reads: the profile's when the
    /// profiled kernel is used, else 0.
    #[inline]
    pub fn first_column(&self, i: usize) -> usize {
        if self.profiled { self.first[i] } else { 0 }
    }

    /// Order n.
    pub fn order(&self) -> usize {
        self.n
    }

    /// Mutable access to the matrix to factor (row-major; only the lower triangle is read).
    #[inline]
    pub fn matrix_mut(&mut self) -> &mut [f64] {
        &mut self.a
    }

    /// The factor's storage (row-major L, n × n) and the reciprocals of its diagonal, for a
    /// factor formed elsewhere by the same operations (`lanes`).
    pub(crate) fn parts_mut(&mut self) -> (&mut [f64], &mut [f64]) {
        (&mut self.a[..], &mut self.inv_diag[..])
    }

    /// Takes the leading n × n block of `other`'s factor (of order ≥ n): the factor of the
    /// leading block of the matrix `other` factored, bit for bit (column j of L depends only on
    /// columns 0..=j of the matrix's rows at and below j, computed in the same order).
    ///
    /// # Panics
    /// If `other` is of a lower order.
    pub fn copy_leading_block(&mut self, other: &SmallCholesky) {
        let (n, m) = (self.n, other.n);
        assert!(m >= n, "the leading block of a smaller factor");
        for i in 0..n {
            self.a[i * n..i * n + i + 1].copy_from_slice(&other.a[i * m..i * m + i + 1]);
        }
        self.inv_diag.copy_from_slice(&other.inv_diag[..n]);
    }

    /// Factors the lower triangle in place. Returns false if the matrix is not positive definite
    /// (numerically: a pivot ≤ 1e-14 × the largest diagonal entry).
    pub fn factor(&mut self) -> bool {
        let n = self.n;
        let (a, inv) = (&mut self.a[..], &mut self.inv_diag[..]);
        // Orders of planar mechanisms are small: a copy of the kernel per order up to 12 lets the
        // compiler unroll the loops and drop the bounds checks.
        match n {
            0 => true,
            1 => factor_n::<1>(a, inv),
            2 => factor_n::<2>(a, inv),
            3 => factor_n::<3>(a, inv),
            4 => factor_n::<4>(a, inv),
            5 => factor_n::<5>(a, inv),
            6 => factor_n::<6>(a, inv),
            7 => factor_n::<7>(a, inv),
            8 => factor_n::<8>(a, inv),
            9 => factor_n::<9>(a, inv),
            10 => factor_n::<10>(a, inv),
            11 => factor_n::<11>(a, inv),
            12 => factor_n::<12>(a, inv),
            _ if self.profiled => factor_with(n, a, inv, &self.first[..n]),
            _ => factor_dyn(n, a, inv),
        }
    }

    /// Solves (L Lᵀ) x = b in place.
    pub fn solve_mut(&self, b: &mut [f64]) {
        let (a, inv) = (&self.a[..], &self.inv_diag[..]);
        match self.n {
            0 => {}
            1 => solve_n::<1>(a, inv, b),
            2 => solve_n::<2>(a, inv, b),
            3 => solve_n::<3>(a, inv, b),
            4 => solve_n::<4>(a, inv, b),
            5 => solve_n::<5>(a, inv, b),
            6 => solve_n::<6>(a, inv, b),
            7 => solve_n::<7>(a, inv, b),
            8 => solve_n::<8>(a, inv, b),
            9 => solve_n::<9>(a, inv, b),
            10 => solve_n::<10>(a, inv, b),
            11 => solve_n::<11>(a, inv, b),
            12 => solve_n::<12>(a, inv, b),
            n if self.profiled => solve_with((n, n), a, inv, &self.first[..n], b),
            n => solve_dyn(n, a, inv, b),
        }
    }
}

#[inline(always)]
fn factor_n<const N: usize>(a: &mut [f64], inv: &mut [f64]) -> bool {
    factor_dyn(N, a, inv)
}

#[inline(always)]
fn solve_n<const N: usize>(a: &[f64], inv: &[f64], b: &mut [f64]) {
    solve_dyn(N, a, inv, b)
}

/// Where each row's structural non-zeros start: nowhere but column 0 for a dense matrix (known at
/// compile time, so the dense kernels carry no profile look-ups), or a profile per row.
pub(crate) trait Profile: Copy {
    /// First column of row `i` that can be non-zero.
    fn first(self, i: usize) -> usize;
}

/// No profile: every row from column 0.
#[derive(Clone, Copy)]
pub(crate) struct Dense;

impl Profile for Dense {
    #[inline(always)]
    fn first(self, _: usize) -> usize {
        0
    }
}

impl Profile for &[usize] {
    #[inline(always)]
    fn first(self, i: usize) -> usize {
        self[i]
    }
}

#[inline(always)]
fn factor_dyn(n: usize, a: &mut [f64], inv: &mut [f64]) -> bool {
    factor_with(n, a, inv, Dense)
}

#[inline(always)]
fn solve_dyn(n: usize, a: &[f64], inv: &[f64], b: &mut [f64]) {
    solve_with((n, n), &a[..n * n], inv, Dense, b)
}

/// L Lᵀ = A in place (lower triangle, row-major), over the profile `p`: a product with a k left
/// of a row's profile is exactly zero, so skipping it changes nothing else. Written over `Real`:
/// one mechanism's matrix (f64) or several side by side (the macro lanes' Schur complements),
/// the same operations in the same order; whether each is positive definite (a pivot above 1e-14
/// of the largest diagonal entry). One matrix stops at its first failing pivot; lanes go on (a
/// failing lane is redone alone).
#[inline(always)]
pub(crate) fn factor_with<R: Real, P: Profile>(n: usize, a: &mut [R], inv: &mut [R], p: P) -> R::Mask {
    let a = &mut a[..n * n];
    let inv = &mut inv[..n];
    let zero = R::splat(0.0);
    let mut scale = zero;
    for i in 0..n {
        scale = scale.max(a[i * n + i].abs());
    }
    let tiny = R::splat(1e-14) * scale;
    let mut ok = zero.simd_le(zero);
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in p.first(j)..j {
            d = d - a[j * n + k] * a[j * n + k];
        }
        ok = ok & d.simd_gt(tiny);
        if R::WIDTH == 1 && !R::all(ok) {
            return ok;
        }
        let d = d.sqrt();
        let r = R::splat(1.0) / d;
        a[j * n + j] = d;
        inv[j] = r;
        for i in (j + 1)..n {
            if p.first(i) > j {
                continue;
            }
            let mut s = a[i * n + j];
            for k in p.first(i).max(p.first(j))..j {
                s = s - a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s * r;
        }
    }
    ok
}

/// (L Lᵀ) x = b in place for the leading `n` × `n` block of a factor stored with row stride
/// `stride` (a cut mechanism's solve with its ideal mechanism's factor), over the profile `p`
/// (one system, or several side by side).
#[inline(always)]
pub(crate) fn solve_with<R: Real, P: Profile>((n, stride): (usize, usize), a: &[R], inv: &[R], p: P, b: &mut [R]) {
    let inv = &inv[..n];
    let b = &mut b[..n];
    for i in 0..n {
        let mut s = b[i];
        for k in p.first(i)..i {
            s = s - a[i * stride + k] * b[k];
        }
        b[i] = s * inv[i];
    }
    for i in (0..n).rev() {
        let xi = b[i] * inv[i];
        b[i] = xi;
        for k in p.first(i)..i {
            b[k] = b[k] - a[i * stride + k] * xi;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    #[test]
    fn agrees_with_nalgebra() {
        for n in [1usize, 2, 7, 13] {
            // A = B Bᵀ + n I, deterministic entries.
            let b = DMatrix::from_fn(n, n, |i, j| ((i * 7 + j * 3) % 11) as f64 / 11.0 - 0.4);
            let a = &b * b.transpose() + DMatrix::identity(n, n) * n as f64;
            let rhs = DVector::from_fn(n, |i, _| (i as f64).sin());
            let expected = a.clone().cholesky().unwrap().solve(&rhs);
            let mut c = SmallCholesky::new(n);
            for i in 0..n {
                for j in 0..n {
                    c.matrix_mut()[i * n + j] = a[(i, j)];
                }
            }
            assert!(c.factor());
            let mut x: Vec<f64> = rhs.iter().copied().collect();
            c.solve_mut(&mut x);
            for i in 0..n {
                assert!((x[i] - expected[i]).abs() < 1e-12, "n = {n}");
            }
        }
    }

    /// An SPD matrix of order 17 with a profile (a chain of blocks, as a spatial slider-crank's
    /// Schur complement): the profiled kernel equals the dense one bit for bit and
    /// nalgebra's Cholesky to round-off.
    #[test]
    fn a_profiled_factor_is_the_dense_one_bit_for_bit() {
        let n = 17;
        // E's ideal mechanism: a revolute (rows 0–4) and two spherical joints (5–7, 8–10) in a
        // chain to a translational joint (11–15), then the crank's driver (16), which shares the
        // crank with the first eight rows.
        let first: Vec<usize> = (0..n)
            .map(|i| match i {
                0..=7 | 16 => 0,
                8..=10 => 5,
                _ => 8,
            })
            .collect();
        let a = DMatrix::from_fn(n, n, |i, j| {
            let (hi, lo) = (i.max(j), i.min(j));
            if lo < first[hi] {
                0.0
            } else if i == j {
                12.0 + (i % 3) as f64
            } else {
                ((i * 5 + j * 3) % 7) as f64 / 7.0 - 0.45
            }
        });
        let rhs = DVector::from_fn(n, |i, _| (i as f64 * 0.7).cos());
        let fill = |c: &mut SmallCholesky| {
            for i in 0..n {
                for j in 0..n {
                    c.matrix_mut()[i * n + j] = a[(i, j)];
                }
            }
        };
        let (mut dense, mut profiled) = (SmallCholesky::new(n), SmallCholesky::new(n));
        profiled.set_profile(&first);
        assert_eq!(profiled.first_column(13), 8);
        fill(&mut dense);
        fill(&mut profiled);
        assert!(dense.factor() && profiled.factor());
        let (mut x, mut y): (Vec<f64>, Vec<f64>) = (rhs.iter().copied().collect(), rhs.iter().copied().collect());
        dense.solve_mut(&mut x);
        profiled.solve_mut(&mut y);
        assert_eq!(x, y);
        let expected = a.clone().cholesky().expect("SPD").solve(&rhs);
        for i in 0..n {
            assert!((y[i] - expected[i]).abs() < 1e-12 * expected.amax(), "{i}: {} vs {}", y[i], expected[i]);
        }
    }

    #[test]
    #[should_panic(expected = "at or left of the diagonal")]
    fn a_profile_right_of_the_diagonal_is_refused() {
        SmallCholesky::new(3).set_profile(&[0, 2, 0]);
    }

    #[test]
    fn rejects_singular() {
        let mut c = SmallCholesky::new(2);
        c.matrix_mut().copy_from_slice(&[1.0, 1.0, 1.0, 1.0]);
        assert!(!c.factor());
    }
}
