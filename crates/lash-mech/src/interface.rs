//! Effective interface terms of a cut mechanism (physics.md §4; seeds 000/001).
//!
//! The cut system is the mechanism with one clearance joint removed. Its interface coordinate is
//! g(q) = r_J − r_B (journal centre minus bearing centre), J = ∂g/∂q, w = ġ = J q̇. With a force
//! f_c on the journal (−f_c on the bearing) the KKT solution is q̈ = q̈_free + G f_c, and
//!
//! ```text
//!     ẅ = W f_c + a_free,   W = J G,   a_free = J q̈_free + J̇ q̇,   M̃ = W⁻¹,   f̃ = M̃ a_free
//! ```
//!
//! so that M̃ ẅ = f̃ + f_c. One factorisation serves the three right-hand sides [Q | Jᵀe_x | Jᵀe_y];
//! the λ-parts of the same solves give joint reactions and driver torques as λ = λ_free + Λ f_c.

use crate::model::{BodyId, Mechanism};
use crate::solver::{MechError, Solver};
use crate::{Pose, Vec2, cross, perp};
use nalgebra::{DVector, Matrix2};

/// Where the interface is: the journal centre on one body, the bearing centre on another.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interface {
    /// Body carrying the journal.
    pub journal_body: BodyId,
    /// Journal centre (local, from the centroid) [m].
    pub journal_point: Vec2,
    /// Body carrying the bearing.
    pub bearing_body: BodyId,
    /// Bearing centre (local, from the centroid) [m].
    pub bearing_point: Vec2,
}

/// The effective terms of one interface at one state, with the maps that propagate f_c back.
#[derive(Debug, Clone, PartialEq)]
pub struct EffectiveTerms {
    /// Mobility W = J A Jᵀ [1/kg] (interface acceleration per unit interface force).
    pub mobility: Matrix2<f64>,
    /// Effective mass M̃ = W⁻¹ [kg]; `None` if W is singular (interface directions beyond the cut
    /// system's mobility: integrate ẅ = W f_c + a_free directly).
    pub effective_mass: Option<Matrix2<f64>>,
    /// Free interface acceleration a_free [m/s²] (f_c = 0).
    pub free_acceleration: Vec2,
    /// Effective force f̃ = M̃ a_free [N] (zero when W is singular).
    pub effective_force: Vec2,
    /// Generalized accelerations with f_c = 0.
    pub free_accelerations: Vec<f64>,
    /// Columns of G: q̈ per unit force along x and along y on the journal.
    pub gain: [Vec<f64>; 2],
    /// Multipliers with f_c = 0.
    pub free_lambda: Vec<f64>,
    /// Columns of Λ: λ per unit force along x and along y on the journal.
    pub lambda_gain: [Vec<f64>; 2],
}

impl EffectiveTerms {
    /// q̈ = q̈_free + G f_c.
    pub fn accelerations(&self, f_c: Vec2, out: &mut [f64]) {
        for k in 0..out.len() {
            out[k] = self.free_accelerations[k] + self.gain[0][k] * f_c.x + self.gain[1][k] * f_c.y;
        }
    }
}

/// J x for a coordinate-space vector x: the journal-minus-bearing point response (no velocity terms).
fn interface_rate(iface: &Interface, poses: &[Pose], x: &[f64]) -> Vec2 {
    let part = |body: BodyId, point: Vec2| -> Vec2 {
        match body {
            BodyId::Ground => Vec2::zeros(),
            BodyId::Body(k) => {
                let a = poses[k].rotate(point);
                Vec2::new(x[3 * k], x[3 * k + 1]) + perp(a) * x[3 * k + 2]
            }
        }
    };
    part(iface.journal_body, iface.journal_point) - part(iface.bearing_body, iface.bearing_point)
}

/// Effective terms of `iface` for the cut mechanism `mech` at `(t, q, q̇)`.
pub fn effective_terms(
    mech: &Mechanism,
    solver: &mut Solver,
    iface: &Interface,
    t: f64,
    q: &[f64],
    qd: &[f64],
) -> Result<EffectiveTerms, MechError> {
    let n = q.len();
    let m = mech.constraint_count();
    solver.set_state(mech, t, q, qd);
    solver.factor()?;
    solver.solve(mech, qd);
    let free_accelerations = solver.accelerations.clone();
    let free_lambda: Vec<f64> = solver.lambda.iter().copied().collect();
    let poses = solver.poses.clone();
    let zero_gamma = vec![0.0; m];
    let mut gain = [vec![0.0; n], vec![0.0; n]];
    let mut lambda_gain = [vec![0.0; m], vec![0.0; m]];
    let mut lambda = DVector::zeros(m);
    for (i, e) in [Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)].into_iter().enumerate() {
        // Jᵀ e: the unit force on the journal point and its opposite on the bearing point.
        let mut force = vec![0.0; n];
        for (body, point, sign) in
            [(iface.journal_body, iface.journal_point, 1.0), (iface.bearing_body, iface.bearing_point, -1.0)]
        {
            if let BodyId::Body(k) = body {
                let a = poses[k].rotate(point);
                force[3 * k] += sign * e.x;
                force[3 * k + 1] += sign * e.y;
                force[3 * k + 2] += sign * cross(a, e);
            }
        }
        solver.solve_with(&force, &zero_gamma, &mut gain[i], &mut lambda);
        lambda_gain[i].copy_from_slice(lambda.as_slice());
    }
    let w0 = interface_rate(iface, &poses, &gain[0]);
    let w1 = interface_rate(iface, &poses, &gain[1]);
    let mobility = Matrix2::new(w0.x, w1.x, w0.y, w1.y);
    // J̇ q̇ = −ω_J² a_J + ω_B² a_B.
    let centripetal = |body: BodyId, point: Vec2| -> Vec2 {
        match body {
            BodyId::Ground => Vec2::zeros(),
            BodyId::Body(k) => -poses[k].rotate(point) * (poses[k].angular_velocity * poses[k].angular_velocity),
        }
    };
    let free_acceleration = interface_rate(iface, &poses, &free_accelerations)
        + centripetal(iface.journal_body, iface.journal_point)
        - centripetal(iface.bearing_body, iface.bearing_point);
    let scale = mobility.abs().max();
    let effective_mass =
        if mobility.determinant().abs() > 1e-12 * scale * scale { mobility.try_inverse() } else { None };
    let effective_force = effective_mass.map_or(Vec2::zeros(), |mt| mt * free_acceleration);
    Ok(EffectiveTerms {
        mobility,
        effective_mass,
        free_acceleration,
        effective_force,
        free_accelerations,
        gain,
        free_lambda,
        lambda_gain,
    })
}
