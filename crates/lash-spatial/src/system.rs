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
    /// The last evaluation's (t, y, ẏ), kept when [`SpatialSystem::remember_last_evaluation`] asked
    /// for it.
    last: Option<(f64, Vec<f64>, Vec<f64>)>,
}

impl SpatialSystem {
    /// The system of a validated mechanism.
    pub fn new(mechanism: SpatialMechanism) -> Self {
        let solver = SpatialSolver::new(&mechanism);
        Self { mechanism, solver, failure: None, evaluations: 0, last: None }
    }

    /// From now on, a right-hand side asked for at exactly the (t, y) of the previous one (bit for
    /// bit) returns the kept derivative without a solve. An integrator restarted where it stopped
    /// asks for that derivative first (the reduced model's macro side, one communication step
    /// after the other: one KKT solve saved per step, 10 % of them for E). The solver is then left
    /// as that evaluation (or a later `set_state` by its owner) left it.
    pub fn remember_last_evaluation(&mut self) {
        let n = self.mechanism.coordinate_count() + self.mechanism.velocity_count();
        self.last = Some((f64::NAN, vec![f64::NAN; n], vec![0.0; n]));
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
        if let Some((lt, ly, ld)) = &self.last
            && lt.to_bits() == t.to_bits()
            && ly.iter().zip(y).all(|(a, b)| a.to_bits() == b.to_bits())
        {
            dydt.copy_from_slice(ld);
            return;
        }
        self.evaluations += 1;
        let n = self.coordinates();
        if let Err(e) = self.evaluate(t, y) {
            self.failure.get_or_insert(e);
            dydt.fill(f64::NAN);
            if let Some(last) = &mut self.last {
                last.0 = f64::NAN; // nothing kept from a failed solve
            }
            return;
        }
        crate::position_rates(self.mechanism.bodies.len(), &y[..n], &y[n..], &mut dydt[..n]);
        dydt[n..].copy_from_slice(&self.solver.accelerations);
        if let Some((lt, ly, ld)) = &mut self.last {
            *lt = t;
            ly.copy_from_slice(y);
            ld.copy_from_slice(dydt);
        }
    }
}
