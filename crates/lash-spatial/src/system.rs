//! The equations of motion as an ODE on `y = [q; v]`.

use crate::model::SpatialMechanism;
use crate::solver::{SpatialError, SpatialSolver};
use lash_ode::OdeSystem;

/// A spatial mechanism with its solver: `ṙ = v`, `ṗ = ½ p ⊗ (0, ω')`, `v̇` from the KKT solve.
pub struct SpatialSystem {
    /// The mechanism.
    pub mechanism: SpatialMechanism,
    /// Its solver (frames, rows, v̇ and λ of the last evaluation).
    pub solver: SpatialSolver,
    /// The first failed solve, if any (the right side is NaN from then on).
    pub failure: Option<SpatialError>,
    /// Right-hand-side evaluations.
    pub evaluations: u64,
}

impl SpatialSystem {
    /// The system of a validated mechanism.
    pub fn new(mechanism: SpatialMechanism) -> Self {
        let solver = SpatialSolver::new(&mechanism);
        Self { mechanism, solver, failure: None, evaluations: 0 }
    }

    /// Position coordinates.
    pub fn coordinates(&self) -> usize {
        self.mechanism.coordinate_count()
    }

    /// Solves at `(t, y)`: frames, rows, v̇ and λ in the solver.
    pub fn evaluate(&mut self, t: f64, y: &[f64]) -> Result<(), SpatialError> {
        let n = self.coordinates();
        self.solver.set_state(&self.mechanism, t, &y[..n], &y[n..]);
        self.solver.solve(&self.mechanism)
    }

    /// The largest | |p| − 1 | of the bodies' quaternions in `y` (integration drift).
    pub fn quaternion_drift(&self, y: &[f64]) -> f64 {
        (0..self.mechanism.bodies.len()).fold(0.0, |m, k| {
            let p = &y[7 * k + 3..7 * k + 7];
            m.max(((p[0] * p[0] + p[1] * p[1] + p[2] * p[2] + p[3] * p[3]).sqrt() - 1.0).abs())
        })
    }
}

impl OdeSystem for SpatialSystem {
    fn dim(&self) -> usize {
        self.mechanism.coordinate_count() + self.mechanism.velocity_count()
    }

    fn rhs(&mut self, t: f64, y: &[f64], dydt: &mut [f64]) {
        self.evaluations += 1;
        let n = self.coordinates();
        if let Err(e) = self.evaluate(t, y) {
            self.failure.get_or_insert(e);
            dydt.fill(f64::NAN);
            return;
        }
        crate::position_rates(self.mechanism.bodies.len(), &y[..n], &y[n..], &mut dydt[..n]);
        dydt[n..].copy_from_slice(&self.solver.accelerations);
    }
}
