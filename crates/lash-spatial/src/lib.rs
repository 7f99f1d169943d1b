//! Spatial rigid multibody engine of lash.
//!
//! * [`model`]: bodies (mass, centroidal inertia tensor in the body frame, pose with a unit
//!   quaternion), joints between two markers (spherical, revolute, universal, cylindrical,
//!   translational), rotational drivers, loads (forces, torques, a motor's torque–speed line),
//!   gravity — plain data with a `validate()` that lists every problem with its field path.
//! * [`constraints`]: the joints' primitives (point coincidence, dot-1, dot-2, driven angle) as
//!   rows of Φ(q, t), its velocity Jacobian C (with respect to each body's centroid velocity in the
//!   world frame and angular velocity in its own frame), ν and γ.
//! * [`solver`]: the index-1 KKT system `[M Cᵀ; C 0][v̇; λ] = [Q; γ̂]` by the Schur complement
//!   `S = C M⁻¹ Cᵀ` with Baumgarte stabilisation `γ̂ = γ − 2α(C v − ν) − β²Φ`.
//! * [`subsystem`]: the macro subsystem of the reduced model of spherical clearance joints.
//! * [`system`]: the equations of motion as a `lash_ode::OdeSystem` on `y = [q; v]`.
//! * [`interface`]: effective interface terms (M̃, f̃, moment columns, propagation gains) of
//!   spherical clearance joints in a cut mechanism: the macro side of the reduced model.
//! * [`kinematics`]: assembly, velocity analysis, point kinematics, energy, angular momentum,
//!   joint reactions.
//!
//! Coordinates: body `k` owns `q[7k..7k+7] = (r_x, r_y, r_z, p_0, p_1, p_2, p_3)` — its centroid
//! in the world frame and its orientation as a quaternion (scalar first), and
//! `v[6k..6k+6] = (ṙ, ω')` — the centroid velocity in the world frame and the angular velocity in
//! the body frame (Newton–Euler: `m r̈ = f`, `J' ω̇' = n' − ω' × J' ω'`). The orientation matrix is
//! always taken from the normalised quaternion, and `ṗ = ½ p ⊗ (0, ω')` keeps |p| constant along
//! the exact flow; the integrator's drift of |p| is reported, never felt by the physics.

pub mod constraints;
pub mod interface;
pub mod kinematics;
pub mod model;
pub mod solver;
pub mod subsystem;
pub mod system;

pub use interface::{SpatialCoupledTerms, SphericalInterface, spatial_effective_terms, spatial_effective_terms_into};
pub use kinematics::{
    SpatialPoint, angular_momentum, assemble, kinetic_energy, point_kinematics, potential_energy, velocity_analysis,
};
pub use lash_mech::{Baumgarte, BodyId, MechError, Motion};
pub use model::{Marker, SpatialBody, SpatialDriver, SpatialJoint, SpatialJointKind, SpatialLoad, SpatialMechanism};
pub use solver::SpatialSolver;
pub use subsystem::{SpatialMechanismSubsystem, SpatialProbe};
pub use system::{ClosedJoints, SpatialSystem};

/// Spatial vector.
pub type Vec3 = nalgebra::Vector3<f64>;
/// 3 × 3 matrix.
pub type Mat3 = nalgebra::Matrix3<f64>;
/// Unit quaternion (orientation).
pub type Orientation = nalgebra::UnitQuaternion<f64>;

/// Position coordinates per body (centroid and quaternion).
pub const POSITION_COORDINATES: usize = 7;
/// Velocity coordinates per body (centroid velocity and angular velocity).
pub const VELOCITY_COORDINATES: usize = 6;

/// Orientation read from `q[3..7]` (scalar first), normalised.
#[inline]
pub fn orientation(p: &[f64]) -> Orientation {
    Orientation::from_quaternion(nalgebra::Quaternion::new(p[0], p[1], p[2], p[3]))
}

/// Writes an orientation to four coordinates (scalar first).
#[inline]
pub fn write_orientation(o: &Orientation, p: &mut [f64]) {
    let q = o.quaternion();
    p[0] = q.w;
    p[1] = q.i;
    p[2] = q.j;
    p[3] = q.k;
}

/// The position rates of `bodies` bodies: `ṙ = v` and `ṗ = ½ p ⊗ (0, ω')` (scalar −½ u·ω',
/// vector ½ (p₀ ω' + u × ω')), from positions `q` (7 per body) and velocities `v` (6 per body).
#[inline]
pub fn position_rates(bodies: usize, q: &[f64], v: &[f64], dq: &mut [f64]) {
    for k in 0..bodies {
        let (p, d) = (&q[7 * k..7 * k + 7], &mut dq[7 * k..7 * k + 7]);
        d[..3].copy_from_slice(&v[6 * k..6 * k + 3]);
        let (w, u) = (p[3], [p[4], p[5], p[6]]);
        let o = [v[6 * k + 3], v[6 * k + 4], v[6 * k + 5]];
        d[3] = -0.5 * (u[0] * o[0] + u[1] * o[1] + u[2] * o[2]);
        d[4] = 0.5 * (w * o[0] + u[1] * o[2] - u[2] * o[1]);
        d[5] = 0.5 * (w * o[1] + u[2] * o[0] - u[0] * o[2]);
        d[6] = 0.5 * (w * o[2] + u[0] * o[1] - u[1] * o[0]);
    }
}
