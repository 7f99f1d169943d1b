//! Effective interface terms of spherical clearance joints in a cut spatial mechanism (the
//! spatial counterpart of `lash_mech::interface`, docs/theory.md §8).
//!
//! The cut system is the mechanism with the k spherical clearance joints removed. Joint j's
//! interface coordinates are w_j = P_J − P_B (ball centre minus socket centre, world frame), so
//! n = 3k; `ẇ = J v`. With a force f_c on each ball (through its centre, −f_c on the socket) and
//! torques τ (world) on the ball's and the socket's bodies, the KKT solution is linear in them:
//!
//! ```text
//!     v̇ = v̇_free + G [f_c; τ],   ẅ = W f_c + W_τ τ + a_free,   M̃ = W⁻¹,   f̃ = M̃ a_free,
//! ```
//!
//! with a_free = J v̇_free + ω_J × (ω_J × s_J) − ω_B × (ω_B × s_B). The torques carry the friction
//! force's moments, R_J n × f on the ball's body and −R_B n × f on the socket's: both are fixed
//! multiples of one vector m = n × f, which depends on the contact normal. The micro model forms
//! m (three loads per joint), and the macro side gives one column per component of m: the
//! response to the torque pair (R_J e, −R_B e), so W_τ is n × 3k.

use crate::Vec3;
use crate::constraints::BodyFrame;
use crate::model::SpatialMechanism;
use crate::solver::SpatialSolver;
use lash_mech::BodyId;
use lash_mech::MechError;
use nalgebra::{DMatrix, DVector};

/// Where a spherical clearance joint is: the ball centre on one body, the socket centre on another.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphericalInterface {
    /// Body carrying the ball.
    pub journal_body: BodyId,
    /// Ball centre (body frame, from the centroid) \[m\].
    pub journal_point: Vec3,
    /// Body carrying the socket.
    pub bearing_body: BodyId,
    /// Socket centre \[m\].
    pub bearing_point: Vec3,
    /// Ball radius R_J \[m\]: the arm of the friction force's torque on the ball's body.
    pub journal_radius: f64,
    /// Socket radius R_B \[m\]: the arm of its torque on the socket's body.
    pub bearing_radius: f64,
}

/// Effective terms of k spherical interfaces at one state.
#[derive(Debug, Clone, PartialEq)]
pub struct SpatialCoupledTerms {
    /// Mobility W = J G_f (n × n) [1/kg].
    pub mobility: DMatrix<f64>,
    /// Effective mass M̃ = W⁻¹ \[kg\]; `None` when W is singular.
    pub effective_mass: Option<DMatrix<f64>>,
    /// Free interface accelerations a_free (n) [m/s²].
    pub free_acceleration: DVector<f64>,
    /// Effective forces f̃ = M̃ a_free (n) \[N\] (zero when W is singular).
    pub effective_force: DVector<f64>,
    /// W_τ (n × 3k): interface accelerations per unit friction load m = n × f of joint j (world
    /// x, y, z; columns 3j…3j+2), i.e. per torque pair R_J m on its ball body and −R_B m on its
    /// socket body [1/kg].
    pub moment_mobility: DMatrix<f64>,
    /// Generalized accelerations v̇ with no interface loads.
    pub free_accelerations: Vec<f64>,
    /// Columns of G (n + 3k): v̇ per unit force on each ball (3j + axis), then per unit friction
    /// load in the order of `moment_mobility`.
    pub gain: Vec<Vec<f64>>,
    /// Multipliers with no interface loads.
    pub free_lambda: Vec<f64>,
    /// Columns of Λ, in the order of `gain`.
    pub lambda_gain: Vec<Vec<f64>>,
    /// Work storage of [`spatial_effective_terms_into`]: a load vector, the bodies' frames.
    scratch: (Vec<f64>, Vec<BodyFrame>),
}

impl SpatialCoupledTerms {
    /// Zero terms for a cut mechanism of `velocities` velocity coordinates (6 per body) and
    /// `constraints` constraint rows with `joints` spherical clearance joints (the storage
    /// [`spatial_effective_terms_into`] fills).
    pub fn zeros(velocities: usize, constraints: usize, joints: usize) -> Self {
        let n = 3 * joints;
        Self {
            mobility: DMatrix::zeros(n, n),
            effective_mass: None,
            free_acceleration: DVector::zeros(n),
            effective_force: DVector::zeros(n),
            moment_mobility: DMatrix::zeros(n, n),
            free_accelerations: vec![0.0; velocities],
            gain: vec![vec![0.0; velocities]; 2 * n],
            free_lambda: vec![0.0; constraints],
            lambda_gain: vec![vec![0.0; constraints]; 2 * n],
            scratch: (vec![0.0; velocities], Vec::new()),
        }
    }
}

fn frame(frames: &[BodyFrame], id: BodyId) -> BodyFrame {
    match id {
        BodyId::Body(k) => frames[k],
        BodyId::Ground => BodyFrame::ground(),
    }
}

/// J x for a velocity-space vector x (6 per body: ṙ, ω'): ball point minus socket point.
fn interface_rate(iface: &SphericalInterface, frames: &[BodyFrame], x: &[f64]) -> Vec3 {
    let part = |body: BodyId, point: Vec3| -> Vec3 {
        match body {
            BodyId::Ground => Vec3::zeros(),
            BodyId::Body(k) => {
                let a = &frames[k].rotation;
                let w = a * Vec3::new(x[6 * k + 3], x[6 * k + 4], x[6 * k + 5]);
                Vec3::new(x[6 * k], x[6 * k + 1], x[6 * k + 2]) + w.cross(&(a * point))
            }
        }
    };
    part(iface.journal_body, iface.journal_point) - part(iface.bearing_body, iface.bearing_point)
}

/// Effective terms of the interfaces `joints` of the cut mechanism `cut` (every one of them
/// removed) at `(t, q, v)`. One factorisation serves the 1 + 3k + 3k solves.
pub fn spatial_effective_terms(
    cut: &SpatialMechanism,
    solver: &mut SpatialSolver,
    joints: &[SphericalInterface],
    t: f64,
    q: &[f64],
    v: &[f64],
) -> Result<SpatialCoupledTerms, MechError> {
    let mut terms = SpatialCoupledTerms::zeros(v.len(), cut.constraint_count(), joints.len());
    spatial_effective_terms_into(cut, solver, joints, t, q, v, &mut terms)?;
    Ok(terms)
}

/// [`spatial_effective_terms`] written into `terms` (made by [`SpatialCoupledTerms::zeros`] for
/// this mechanism and these joints, or by an earlier call): the same values; the macro subsystem
/// refreshes its terms this way at every communication point (the inverse of a coupled W above
/// one joint is the only allocation left).
pub fn spatial_effective_terms_into(
    cut: &SpatialMechanism,
    solver: &mut SpatialSolver,
    joints: &[SphericalInterface],
    t: f64,
    q: &[f64],
    v: &[f64],
    terms: &mut SpatialCoupledTerms,
) -> Result<(), MechError> {
    let k = joints.len();
    let n = 3 * k;
    assert!(
        terms.gain.len() == 2 * n && terms.free_accelerations.len() == v.len(),
        "the terms were made for another mechanism or joint count"
    );
    solver.set_state(cut, t, q, v);
    solver.solve(cut)?;
    terms.free_accelerations.copy_from_slice(&solver.accelerations);
    terms.free_lambda.copy_from_slice(&solver.lambda);
    let SpatialCoupledTerms { gain, lambda_gain, scratch: (load, frames), .. } = terms;
    frames.clone_from(&solver.frames);
    let frames = &*frames;
    let put = |load: &mut [f64], body: BodyId, force: Vec3, torque: Vec3| {
        if let BodyId::Body(b) = body {
            let n_body = frames[b].rotation.transpose() * torque;
            for c in 0..3 {
                load[6 * b + c] += force[c];
                load[6 * b + 3 + c] += n_body[c];
            }
        }
    };
    for (j, iface) in joints.iter().enumerate() {
        let (fj, fb) = (frame(frames, iface.journal_body), frame(frames, iface.bearing_body));
        let (sj, sb) = (fj.rotation * iface.journal_point, fb.rotation * iface.bearing_point);
        for axis in 0..3 {
            let e = Vec3::ith(axis, 1.0);
            load.fill(0.0);
            put(load, iface.journal_body, e, sj.cross(&e));
            put(load, iface.bearing_body, -e, sb.cross(&-e));
            let column = 3 * j + axis;
            solver.response(load, &mut gain[column], &mut lambda_gain[column]);
            // A unit friction load m = e: the torque pair on the ball's body and the socket's.
            load.fill(0.0);
            put(load, iface.journal_body, Vec3::zeros(), e * iface.journal_radius);
            put(load, iface.bearing_body, Vec3::zeros(), e * -iface.bearing_radius);
            let column = n + column;
            solver.response(load, &mut gain[column], &mut lambda_gain[column]);
        }
    }
    let centripetal = |f: &BodyFrame, s: Vec3| f.angular_velocity.cross(&f.angular_velocity.cross(&s));
    for (row, iface) in joints.iter().enumerate() {
        for c in 0..n {
            let w = interface_rate(iface, frames, &gain[c]);
            terms.mobility.fixed_view_mut::<3, 1>(3 * row, c).copy_from(&w);
        }
        for c in 0..n {
            let w = interface_rate(iface, frames, &gain[n + c]);
            terms.moment_mobility.fixed_view_mut::<3, 1>(3 * row, c).copy_from(&w);
        }
        let (fj, fb) = (frame(frames, iface.journal_body), frame(frames, iface.bearing_body));
        let a = interface_rate(iface, frames, &terms.free_accelerations)
            + centripetal(&fj, fj.rotation * iface.journal_point)
            - centripetal(&fb, fb.rotation * iface.bearing_point);
        terms.free_acceleration.fixed_view_mut::<3, 1>(3 * row, 0).copy_from(&a);
    }
    terms.effective_mass = invert(&terms.mobility);
    match &terms.effective_mass {
        Some(mt) => mt.mul_to(&terms.free_acceleration, &mut terms.effective_force),
        None => terms.effective_force.fill(0.0),
    }
    Ok(())
}

/// W⁻¹, or `None` when W is singular to working precision.
fn invert(w: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let scale = w.amax();
    let inverse = w.clone().lu().try_inverse()?;
    let condition = inverse.amax() * scale * w.nrows() as f64;
    (condition.is_finite() && condition < 1e12).then_some(inverse)
}
