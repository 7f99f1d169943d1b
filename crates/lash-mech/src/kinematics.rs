//! Assembly, velocity analysis, point kinematics and energy.

use crate::model::{BodyId, Mechanism};
use crate::solver::{Correction, MechError, Solver};
use crate::{Pose, Vec2, perp};

/// Coordinates and velocities from the bodies' initial guesses.
pub fn initial_guess(mech: &Mechanism) -> (Vec<f64>, Vec<f64>) {
    let mut q = Vec::with_capacity(mech.coordinate_count());
    let mut qd = Vec::with_capacity(mech.coordinate_count());
    for b in &mech.bodies {
        q.extend_from_slice(&[b.position.x, b.position.y, b.angle]);
        qd.extend_from_slice(&[b.velocity.x, b.velocity.y, b.angular_velocity]);
    }
    (q, qd)
}

/// Position analysis: Newton iterations with the mass-weighted minimum-norm correction
/// Δq = −M⁻¹Φ_qᵀ(Φ_q M⁻¹ Φ_qᵀ)⁻¹Φ until max |Φ| ≤ `tol`. Returns the iterations spent. The solver
/// then holds Φ, Φ_q and ν of the assembled position, not γ nor the loads
/// ([`Solver::set_configuration`]): a [`Solver::set_state`] comes before any acceleration solve.
pub fn assemble(mech: &Mechanism, t: f64, q: &mut [f64], solver: &mut Solver, tol: f64) -> Result<usize, MechError> {
    with_correction(solver, q.len(), mech.constraint_count(), |solver, work| {
        assemble_with(mech, t, q, solver, tol, work)
    })
}

/// Position then velocity analysis at `t`: [`assemble`] to `tol`, then [`velocity_analysis`] —
/// the same operations and results, but the projection takes Φ_q and ν from the assembly's last
/// residual check instead of evaluating them again (both depend on q and t only). Afterwards the
/// solver holds Φ of the assembled position. Returns the Newton iterations spent.
pub fn assemble_and_project(
    mech: &Mechanism,
    t: f64,
    q: &mut [f64],
    qd: &mut [f64],
    solver: &mut Solver,
    tol: f64,
) -> Result<usize, MechError> {
    with_correction(solver, q.len(), mech.constraint_count(), |solver, work| {
        let iterations = assemble_with(mech, t, q, solver, tol, work)?;
        project_velocities(qd, solver, work)?;
        Ok(iterations)
    })
}

/// Runs `f` with the solver's correction work vectors, sized for `n` coordinates and `m` rows and
/// lent for the call (nothing is allocated after the first).
fn with_correction<R>(solver: &mut Solver, n: usize, m: usize, f: impl FnOnce(&mut Solver, &mut Correction) -> R) -> R {
    let mut work = std::mem::take(&mut solver.correction).sized(n, m);
    let result = f(solver, &mut work);
    solver.correction = work;
    result
}

fn assemble_with(
    mech: &Mechanism,
    t: f64,
    q: &mut [f64],
    solver: &mut Solver,
    tol: f64,
    work: &mut Correction,
) -> Result<usize, MechError> {
    let Correction { zeros, step, rhs: neg_phi, lambda } = work;
    const MAX_ITERATIONS: usize = 50;
    for it in 0..MAX_ITERATIONS {
        // (Φ, Φ_q and ν: a position analysis and the velocity projection after it need no γ
        // nor loads.)
        solver.set_configuration(mech, t, q, zeros);
        let residual = solver.constraint_error();
        if residual <= tol {
            return Ok(it);
        }
        solver.factor()?;
        for (o, p) in neg_phi.iter_mut().zip(&solver.phi) {
            *o = -p;
        }
        solver.solve_with(zeros, neg_phi, step, lambda);
        for (qi, d) in q.iter_mut().zip(step.iter()) {
            *qi += d;
        }
    }
    solver.set_state(mech, t, q, zeros);
    Err(MechError::AssemblyFailed { t, residual: solver.constraint_error(), iterations: MAX_ITERATIONS })
}

/// Velocity analysis: projects `qd` onto Φ_q q̇ = ν with the mass-weighted minimum-norm change.
pub fn velocity_analysis(
    mech: &Mechanism,
    t: f64,
    q: &[f64],
    qd: &mut [f64],
    solver: &mut Solver,
) -> Result<(), MechError> {
    with_correction(solver, q.len(), mech.constraint_count(), |solver, work| {
        velocity_analysis_with(mech, t, q, qd, solver, work)
    })
}

fn velocity_analysis_with(
    mech: &Mechanism,
    t: f64,
    q: &[f64],
    qd: &mut [f64],
    solver: &mut Solver,
    work: &mut Correction,
) -> Result<(), MechError> {
    solver.set_state(mech, t, q, qd);
    project_velocities(qd, solver, work)
}

/// The velocity projection with Φ_q and ν as the solver holds them.
fn project_velocities(qd: &mut [f64], solver: &mut Solver, work: &mut Correction) -> Result<(), MechError> {
    let Correction { zeros, step: dqd, rhs: residual, lambda } = work;
    solver.factor()?;
    for (a, r) in residual.iter_mut().enumerate() {
        *r = -(solver.jacobian_times(a, qd) - solver.nu[a]);
    }
    solver.solve_with(zeros, residual, dqd, lambda);
    for (v, d) in qd.iter_mut().zip(dqd.iter()) {
        *v += d;
    }
    Ok(())
}

/// Position, velocity and acceleration of a body point (world frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointKinematics {
    /// Position \[m\].
    pub position: Vec2,
    /// Velocity [m/s].
    pub velocity: Vec2,
    /// Acceleration [m/s²].
    pub acceleration: Vec2,
}

/// Kinematics of the point `local` (from the centroid, body frame) of `body`.
pub fn point_kinematics(q: &[f64], qd: &[f64], qdd: &[f64], body: BodyId, local: Vec2) -> PointKinematics {
    point_kinematics_at(&Pose::of(body, q, qd), qdd, body, local)
}

/// [`point_kinematics`] with the body's pose given ([`Pose::of`] at q, q̇): the same numbers,
/// without its sine and cosine taken again (a probe's several accelerations at one state).
pub fn point_kinematics_at(pose: &Pose, qdd: &[f64], body: BodyId, local: Vec2) -> PointKinematics {
    let a = pose.rotate(local);
    let (acc, alpha) = match body {
        BodyId::Ground => (Vec2::zeros(), 0.0),
        BodyId::Body(k) => (Vec2::new(qdd[3 * k], qdd[3 * k + 1]), qdd[3 * k + 2]),
    };
    let w = pose.angular_velocity;
    PointKinematics {
        position: pose.position + a,
        velocity: pose.velocity + perp(a) * w,
        acceleration: acc + perp(a) * alpha - a * (w * w),
    }
}

/// Kinetic energy ½ q̇ᵀ M q̇ \[J\].
pub fn kinetic_energy(mech: &Mechanism, qd: &[f64]) -> f64 {
    mech.bodies
        .iter()
        .enumerate()
        .map(|(k, b)| {
            0.5 * b.mass * (qd[3 * k] * qd[3 * k] + qd[3 * k + 1] * qd[3 * k + 1])
                + 0.5 * b.inertia * qd[3 * k + 2] * qd[3 * k + 2]
        })
        .sum()
}

/// Reaction force on body i of joint `k` \[N\] (world frame): −λ of its two rows (revolute), or
/// for a prismatic joint the normal force −λ₂ v and the moment −λ₁ (returned as (fx, fy)).
pub fn joint_reaction(mech: &Mechanism, solver: &Solver, k: usize) -> Vec2 {
    let row = mech.joint_row(k);
    let joint = &mech.joints[k];
    match joint.kind {
        crate::JointKind::Revolute => Vec2::new(-solver.lambda[row], -solver.lambda[row + 1]),
        crate::JointKind::Prismatic { .. } => {
            // Force part of −Φ_qᵀλ on body i's translational coordinates.
            // Block 0 of each row belongs to body i (Block::EMPTY when body i is the ground).
            let (r1, r2) = (&solver.jacobian[row][0], &solver.jacobian[row + 1][0]);
            let (l1, l2) = (solver.lambda[row], solver.lambda[row + 1]);
            Vec2::new(-(r1.d[0] * l1 + r2.d[0] * l2), -(r1.d[1] * l1 + r2.d[1] * l2))
        }
    }
}

/// Torque of driver `k` on its driven body about +z [N m]: −λ of its row.
pub fn driver_torque(mech: &Mechanism, solver: &Solver, k: usize) -> f64 {
    -solver.lambda[mech.driver_row(k)]
}
