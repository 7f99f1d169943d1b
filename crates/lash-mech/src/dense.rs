//! A small dense SPD factorisation for the Schur complement.
//!
//! Why not nalgebra's `Cholesky<f64, Dyn>`: at the sizes of planar mechanisms (5–40 equations) its
//! generic-dimension machinery (column views, axpy per column, bounds checks) cost about as much as
//! all the rest of a right-hand-side evaluation (profiled with `perf` on scenario B: 11 % of the run
//! for the factorisation plus 9 % for the two triangular solves). This kernel works on one flat
//! row-major buffer that is reused for every evaluation, and is checked against nalgebra in tests.

/// Lower Cholesky factor L (row-major, n × n, upper part unused) of an SPD matrix, in place.
#[derive(Debug, Clone)]
pub struct SmallCholesky {
    n: usize,
    a: Vec<f64>,
    inv_diag: Vec<f64>,
}

impl SmallCholesky {
    /// A workspace for n × n matrices.
    pub fn new(n: usize) -> Self {
        Self { n, a: vec![0.0; n * n], inv_diag: vec![0.0; n] }
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

    /// Factors the lower triangle in place. Returns false if the matrix is not positive definite
    /// (numerically: a pivot ≤ 1e-14 × the largest diagonal entry).
    pub fn factor(&mut self) -> bool {
        let n = self.n;
        let a = &mut self.a[..n * n];
        let scale = (0..n).map(|i| a[i * n + i].abs()).fold(0.0, f64::max);
        let tiny = 1e-14 * scale;
        for j in 0..n {
            let (above, rest) = a.split_at_mut(j * n + n);
            let row_j = &above[j * n..];
            let d = row_j[j] - dot(&row_j[..j], &row_j[..j]);
            if !(d > tiny) {
                return false;
            }
            let d = d.sqrt();
            let inv = 1.0 / d;
            self.inv_diag[j] = inv;
            for row_i in rest.chunks_exact_mut(n) {
                row_i[j] = (row_i[j] - dot(&row_i[..j], &row_j[..j])) * inv;
            }
            above[j * n + j] = d;
        }
        true
    }

    /// Solves (L Lᵀ) x = b in place.
    pub fn solve_mut(&self, b: &mut [f64]) {
        let n = self.n;
        let a = &self.a[..n * n];
        let b = &mut b[..n];
        for i in 0..n {
            let row = &a[i * n..i * n + i];
            b[i] = (b[i] - dot(row, &b[..i])) * self.inv_diag[i];
        }
        for i in (0..n).rev() {
            let xi = b[i] * self.inv_diag[i];
            b[i] = xi;
            // Column i of L above the diagonal is row i of Lᵀ: subtract its contribution.
            let row = &a[i * n..i * n + i];
            for (bk, l) in b[..i].iter_mut().zip(row) {
                *bk -= l * xi;
            }
        }
    }
}

#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
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

    #[test]
    fn rejects_singular() {
        let mut c = SmallCholesky::new(2);
        c.matrix_mut().copy_from_slice(&[1.0, 1.0, 1.0, 1.0]);
        assert!(!c.factor());
    }
}
