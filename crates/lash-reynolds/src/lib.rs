//! The Reynolds equation of a finite-length journal bearing, solved on a grid.
//!
//! The film between a journal of radius R and a bearing of radial clearance c, length L, oil of
//! viscosity μ: with e the journal centre minus the bearing centre, ė its rate, ω̄ the mean of the
//! two surfaces' angular velocities and d̂(φ) = (cos φ, sin φ) the direction of a point of the
//! film, the thickness is h = c − e·d̂ and the pressure p(φ, z) satisfies
//!
//! (1/R²) ∂/∂φ (h³ ∂p/∂φ) + ∂/∂z (h³ ∂p/∂z) = −12 μ w·d̂,  w = ė − ω̄ J e (J: a quarter turn),
//!
//! periodic in φ, p = 0 at both ends z = ±L/2. Second-order finite differences (h³ taken at the
//! cells' faces), the symmetric positive definite system factored by faer's sparse Cholesky; then
//! Gümbel's condition (the negative pressures, which a real film cannot hold, set to zero) and
//! the force −∫∫ p d̂ R dφ dz on the journal.
//!
//! This is the independent computation that lash-contact's closed-form film forces are checked
//! against (the short bearing as L/D → 0, the long bearing as L/D grows), and it tells where
//! each closed form holds for a bearing of finite length.

use faer::Side;
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMat, Triplet};
use std::f64::consts::PI;

/// A journal bearing of finite length with its oil.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bearing {
    /// The journal's radius R \[m\].
    pub radius: f64,
    /// The radial clearance c \[m\].
    pub clearance: f64,
    /// The bearing's length L \[m\].
    pub length: f64,
    /// The oil's dynamic viscosity μ \[Pa·s\].
    pub viscosity: f64,
}

/// The journal's motion relative to the bearing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// Eccentricity e (journal centre minus bearing centre) \[m\]; |e| < c.
    pub eccentricity: [f64; 2],
    /// Its rate ė \[m/s\].
    pub rate: [f64; 2],
    /// (ω_J + ω_B)/2 \[rad/s\].
    pub mean_rate: f64,
}

/// The grid: cells around the circumference and along the length.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Grid {
    /// Nodes around the circumference (periodic).
    pub circumferential: usize,
    /// Intervals along the length (the two end nodes are at ambient pressure).
    pub axial: usize,
}

/// The film's pressure field and its resultant.
#[derive(Debug, Clone, PartialEq)]
pub struct Film {
    /// The force of the film on the journal \[N\] (the bearing takes its opposite).
    pub force: [f64; 2],
    /// The largest pressure \[Pa\].
    pub peak_pressure: f64,
    /// The share of the film area that holds pressure (the rest has cavitated).
    pub pressurised: f64,
}

/// Why the film could not be solved.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReynoldsError {
    /// A number of the bearing, the motion or the grid is out of range.
    #[error("{field}: {problem}")]
    Input {
        /// The field.
        field: &'static str,
        /// What is wrong with it.
        problem: String,
    },
    /// The sparse factorisation failed.
    #[error("factoring the Reynolds equation: {0}")]
    Factor(String),
}

fn check(field: &'static str, ok: bool, problem: impl FnOnce() -> String) -> Result<(), ReynoldsError> {
    if ok { Ok(()) } else { Err(ReynoldsError::Input { field, problem: problem() }) }
}

impl Bearing {
    fn validate(&self, motion: &Motion, grid: &Grid) -> Result<(), ReynoldsError> {
        for (field, v) in [
            ("radius", self.radius),
            ("clearance", self.clearance),
            ("length", self.length),
            ("viscosity", self.viscosity),
        ] {
            check(field, v.is_finite() && v > 0.0, || format!("must be positive and finite, got {v}"))?;
        }
        let [ex, ey] = motion.eccentricity;
        let ratio = ex.hypot(ey) / self.clearance;
        check("eccentricity", ratio < 1.0, || format!("|e|/c must be below 1, got {ratio}"))?;
        let finite = motion.rate.iter().chain([&motion.mean_rate]).all(|v| v.is_finite());
        check("rate", finite, || "must be finite".into())?;
        check("circumferential", grid.circumferential >= 8, || {
            format!("needs 8 nodes or more, got {}", grid.circumferential)
        })?;
        check("axial", grid.axial >= 2, || format!("needs 2 intervals or more, got {}", grid.axial))
    }

    /// The film's pressure and force for `motion` on `grid`.
    pub fn solve(&self, motion: &Motion, grid: &Grid) -> Result<Film, ReynoldsError> {
        self.validate(motion, grid)?;
        let (n, m) = (grid.circumferential, grid.axial - 1);
        let (dphi, dz) = (2.0 * PI / n as f64, self.length / grid.axial as f64);
        let [ex, ey] = motion.eccentricity;
        let thickness = |phi: f64| self.clearance - ex * phi.cos() - ey * phi.sin();
        let w = [motion.rate[0] + motion.mean_rate * ey, motion.rate[1] - motion.mean_rate * ex];
        let index = |i: usize, j: usize| j * n + i;
        let mut triplets = Vec::with_capacity(5 * n * m);
        let mut rhs = faer::Mat::<f64>::zeros(n * m, 1);
        let r2 = self.radius * self.radius;
        for i in 0..n {
            let phi = i as f64 * dphi;
            let (plus, minus) = (thickness(phi + 0.5 * dphi).powi(3), thickness(phi - 0.5 * dphi).powi(3));
            let (around_plus, around_minus) = (plus / (r2 * dphi * dphi), minus / (r2 * dphi * dphi));
            let along = thickness(phi).powi(3) / (dz * dz);
            let source = 12.0 * self.viscosity * (w[0] * phi.cos() + w[1] * phi.sin());
            for j in 0..m {
                let row = index(i, j);
                // The lower triangle is what the factorisation reads.
                let mut push = |col: usize, v: f64| {
                    if col <= row {
                        triplets.push(Triplet::new(row, col, v));
                    }
                };
                push(row, around_plus + around_minus + 2.0 * along);
                push(index((i + 1) % n, j), -around_plus);
                push(index((i + n - 1) % n, j), -around_minus);
                if j + 1 < m {
                    push(index(i, j + 1), -along);
                }
                if j > 0 {
                    push(index(i, j - 1), -along);
                }
                rhs[(row, 0)] = source;
            }
        }
        let matrix = SparseColMat::<usize, f64>::try_new_from_triplets(n * m, n * m, &triplets)
            .map_err(|e| ReynoldsError::Factor(format!("{e:?}")))?;
        let symbolic = SymbolicLlt::try_new(matrix.symbolic(), Side::Lower)
            .map_err(|e| ReynoldsError::Factor(format!("{e:?}")))?;
        let llt = Llt::try_new_with_symbolic(symbolic, matrix.as_ref(), Side::Lower)
            .map_err(|e| ReynoldsError::Factor(format!("{e:?}")))?;
        let pressure = llt.solve(&rhs);
        Ok(self.resultant(n, m, (dphi, dz), |i, j| pressure[(index(i, j), 0)]))
    }

    /// Gümbel's condition and the force on the journal: the end nodes at ambient pressure, the
    /// interior nodes' cells of dz (trapezoid rule along the length, rectangle rule around).
    fn resultant(&self, n: usize, m: usize, (dphi, dz): (f64, f64), p: impl Fn(usize, usize) -> f64) -> Film {
        let (mut force, mut peak, mut pressurised) = ([0.0; 2], 0.0_f64, 0usize);
        for i in 0..n {
            let phi = i as f64 * dphi;
            for j in 0..m {
                let p = p(i, j).max(0.0);
                if p > 0.0 {
                    pressurised += 1;
                }
                peak = peak.max(p);
                let area = self.radius * dphi * dz;
                force[0] -= p * phi.cos() * area;
                force[1] -= p * phi.sin() * area;
            }
        }
        Film { force, peak_pressure: peak, pressurised: pressurised as f64 / (n * m) as f64 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A centred journal squeezed straight in: by symmetry the force opposes ė, and a grid twice
    /// as fine changes it by less than the discretisation's order predicts.
    #[test]
    fn centred_squeeze_opposes_the_motion_and_converges() {
        let b = Bearing { radius: 0.01, clearance: 5e-5, length: 0.01, viscosity: 0.04 };
        let motion = Motion { eccentricity: [0.0, 0.0], rate: [0.0, 0.01], mean_rate: 0.0 };
        let coarse = b.solve(&motion, &Grid { circumferential: 90, axial: 20 }).unwrap();
        let fine = b.solve(&motion, &Grid { circumferential: 180, axial: 40 }).unwrap();
        assert!(fine.force[0].abs() < 1e-9 * fine.force[1].abs(), "{:?}", fine.force);
        assert!(fine.force[1] < 0.0);
        assert!((fine.force[1] / coarse.force[1] - 1.0).abs() < 0.01, "{:?} {:?}", coarse.force, fine.force);
        assert!((fine.pressurised - 0.5).abs() < 0.02, "{}", fine.pressurised);
    }

    #[test]
    fn bad_numbers_are_named() {
        let b = Bearing { radius: 0.01, clearance: 5e-5, length: -0.01, viscosity: 0.04 };
        let motion = Motion { eccentricity: [0.0, 0.0], rate: [0.0, 0.0], mean_rate: 1.0 };
        let grid = Grid { circumferential: 90, axial: 20 };
        let e = b.solve(&motion, &grid).unwrap_err().to_string();
        assert!(e.starts_with("length:"), "{e}");
        let b = Bearing { length: 0.01, ..b };
        let far = Motion { eccentricity: [6e-5, 0.0], ..motion };
        assert!(b.solve(&far, &grid).unwrap_err().to_string().starts_with("eccentricity:"));
    }
}
