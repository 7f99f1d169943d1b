//! Assembly, velocity analysis, point kinematics, energy and angular momentum.

use crate::model::SpatialMechanism;
use crate::solver::SpatialSolver;
use crate::{Orientation, Vec3};
use lash_mech::MechError;

/// Position analysis: Newton iterations on Φ(q, t) = 0 with the minimum-kinetic-energy step
/// δ = −M⁻¹Cᵀ S⁻¹ Φ in (ṙ, ω') space; a body's orientation turns by the body-frame rotation
/// vector δω' (p ← p ⊗ exp(δω'/2)). Returns the iterations spent.
pub fn assemble(mech: &SpatialMechanism, t: f64, q: &mut [f64], tolerance: f64) -> Result<usize, MechError> {
    let mut solver = SpatialSolver::new(mech);
    let zero = vec![0.0; mech.velocity_count()];
    let mut residual = vec![0.0; mech.constraint_count()];
    let mut delta = vec![0.0; mech.velocity_count()];
    let max_iterations = 50;
    for iteration in 0..max_iterations {
        solver.set_state(mech, t, q, &zero);
        let error = solver.constraint_error();
        if error <= tolerance {
            return Ok(iteration);
        }
        for (e, r) in residual.iter_mut().zip(&solver.rows) {
            *e = -r.phi;
        }
        solver.correction(&residual, &mut delta)?;
        for k in 0..mech.bodies.len() {
            for c in 0..3 {
                q[7 * k + c] += delta[6 * k + c];
            }
            let turn = Vec3::new(delta[6 * k + 3], delta[6 * k + 4], delta[6 * k + 5]);
            let p = crate::orientation(&q[7 * k + 3..7 * k + 7]) * Orientation::from_scaled_axis(turn);
            crate::write_orientation(&p, &mut q[7 * k + 3..7 * k + 7]);
        }
    }
    solver.set_state(mech, t, q, &zero);
    Err(MechError::AssemblyFailed { t, residual: solver.constraint_error(), iterations: max_iterations })
}

/// Velocity analysis: the velocities closest to `v` in kinetic energy that satisfy C v = ν
/// (corrected until max |C v − ν| ≤ 1e-12 of the velocities' scale, at most five times: once but
/// for redundant equations).
pub fn velocity_analysis(mech: &SpatialMechanism, t: f64, q: &[f64], v: &mut [f64]) -> Result<(), MechError> {
    let mut solver = SpatialSolver::new(mech);
    let mut residual = vec![0.0; mech.constraint_count()];
    let mut delta = vec![0.0; v.len()];
    for _ in 0..5 {
        solver.set_state(mech, t, q, v);
        // e = ν − C v.
        for (e, r) in residual.iter_mut().zip(&solver.rows) {
            *e = r.nu;
            for b in 0..2 {
                if let Some(k) = r.bodies[b] {
                    *e -= (0..6).map(|c| r.blocks[b][c] * v[6 * k + c]).sum::<f64>();
                }
            }
        }
        let scale = v.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-3);
        if residual.iter().all(|e| e.abs() <= 1e-12 * scale) {
            break;
        }
        solver.correction(&residual, &mut delta)?;
        for (x, d) in v.iter_mut().zip(&delta) {
            *x += d;
        }
    }
    Ok(())
}

/// Kinetic energy Σ ½ m |ṙ|² + ½ ω'ᵀ J' ω' \[J\].
pub fn kinetic_energy(mech: &SpatialMechanism, v: &[f64]) -> f64 {
    mech.bodies
        .iter()
        .enumerate()
        .map(|(k, b)| {
            let (lin, ang) =
                (Vec3::new(v[6 * k], v[6 * k + 1], v[6 * k + 2]), Vec3::new(v[6 * k + 3], v[6 * k + 4], v[6 * k + 5]));
            0.5 * b.mass * lin.norm_squared() + 0.5 * ang.dot(&(b.inertia * ang))
        })
        .sum()
}

/// Potential energy of gravity −Σ m g·r \[J\].
pub fn potential_energy(mech: &SpatialMechanism, q: &[f64]) -> f64 {
    mech.bodies
        .iter()
        .enumerate()
        .map(|(k, b)| -b.mass * mech.gravity.dot(&Vec3::new(q[7 * k], q[7 * k + 1], q[7 * k + 2])))
        .sum()
}

/// Angular momentum about the world origin Σ (m r × ṙ + A J' ω') [kg m²/s].
pub fn angular_momentum(mech: &SpatialMechanism, q: &[f64], v: &[f64]) -> Vec3 {
    mech.bodies
        .iter()
        .enumerate()
        .map(|(k, b)| {
            let r = Vec3::new(q[7 * k], q[7 * k + 1], q[7 * k + 2]);
            let lin = Vec3::new(v[6 * k], v[6 * k + 1], v[6 * k + 2]);
            let w = Vec3::new(v[6 * k + 3], v[6 * k + 4], v[6 * k + 5]);
            b.mass * r.cross(&lin) + crate::orientation(&q[7 * k + 3..7 * k + 7]) * (b.inertia * w)
        })
        .sum()
}

/// Position, velocity and acceleration of a body point (world frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpatialPoint {
    /// Position \[m\].
    pub position: Vec3,
    /// Velocity [m/s].
    pub velocity: Vec3,
    /// Acceleration [m/s²].
    pub acceleration: Vec3,
}

/// Kinematics of `point` (body frame, from the centroid) of body `k` from a solved state.
pub fn point_kinematics(solver: &SpatialSolver, k: usize, point: Vec3) -> SpatialPoint {
    let f = &solver.frames[k];
    let s = f.rotation * point;
    let a = &solver.accelerations[6 * k..6 * k + 6];
    let angular_acceleration = f.rotation * Vec3::new(a[3], a[4], a[5]);
    let w = f.angular_velocity;
    SpatialPoint {
        position: f.position + s,
        velocity: f.velocity + w.cross(&s),
        acceleration: Vec3::new(a[0], a[1], a[2]) + angular_acceleration.cross(&s) + w.cross(&w.cross(&s)),
    }
}
