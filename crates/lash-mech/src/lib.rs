//! Planar rigid multibody engine of lash.
//!
//! * [`model`]: bodies (centroid coordinates x, y, θ), ground, revolute and prismatic joints,
//!   rotational drivers, applied loads and gravity — plain data with a `validate()` that lists
//!   every problem with its field path.
//! * [`constraints`]: Φ(q, t), its Jacobian Φ_q, the velocity right side ν and the acceleration
//!   right side γ, evaluated joint by joint.
//! * [`solver`]: the index-1 KKT system `[M Φ_qᵀ; Φ_q 0][q̈; λ] = [Q; γ̂]` solved through the
//!   Schur complement `S = Φ_q M⁻¹ Φ_qᵀ` (M is block diagonal), with Baumgarte stabilisation
//!   `γ̂ = γ − 2α(Φ_q q̇ − ν) − β²Φ`. No allocation per solve.
//! * [`kinematics`]: assembly (position analysis), velocity analysis, point kinematics, kinetic
//!   energy, reactions.
//!
//! Coordinates: body `k` owns `q[3k..3k+3] = (x, y, θ)` of its centroid; the ground has none.
//! The state of a dynamic run is `y = [q; q̇]`.
//!
//! Spatial bodies (scenario E) will add a body kind with its own coordinate block and joint
//! kinds; the solver only sees Φ_q, γ and per-body inverse-mass blocks, so it carries over.

pub mod constraints;
pub mod dense;
pub mod interface;
pub mod kinematics;
mod kkt;
pub mod lanes;
pub mod model;
pub mod solver;
pub mod subsystem;

pub use interface::{
    ClearanceInterface, CoupledTerms, EffectiveTerms, GuideAxis, Interface, coupled_effective_terms,
    coupled_effective_terms_into, effective_terms, own_interface_load,
};
pub use kinematics::{
    PointKinematics, assemble, assemble_and_project, driver_torque, initial_guess, joint_reaction, kinetic_energy,
    point_kinematics, point_kinematics_at, velocity_analysis,
};
pub use lash_core::Coupling;
pub use model::{
    Baumgarte, Body, BodyId, BushingState, Driver, Joint, JointKind, Load, Mechanism, Motion, RadialCurve,
    bushing_state,
};
pub use solver::{MechError, Solver};
pub use subsystem::{MechanismSubsystem, Probe};

/// Planar vector.
pub type Vec2 = nalgebra::Vector2<f64>;

/// The vector rotated by +90°: ⊥(x, y) = (−y, x). For a body-fixed vector a = A(θ)s,
/// ȧ = θ̇ ⊥a.
#[inline]
pub fn perp(v: Vec2) -> Vec2 {
    Vec2::new(-v.y, v.x)
}

/// Planar cross product a × b (the z component).
#[inline]
pub fn cross(a: Vec2, b: Vec2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Pose of a body (or of the ground) read from the coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Centroid position \[m\].
    pub position: Vec2,
    /// Angle \[rad\].
    pub angle: f64,
    /// cos θ.
    pub cos: f64,
    /// sin θ.
    pub sin: f64,
    /// Centroid velocity [m/s].
    pub velocity: Vec2,
    /// Angular velocity [rad/s].
    pub angular_velocity: f64,
}

impl Pose {
    /// The ground: at rest at the origin.
    pub const GROUND: Pose = Pose {
        position: Vec2::new(0.0, 0.0),
        angle: 0.0,
        cos: 1.0,
        sin: 0.0,
        velocity: Vec2::new(0.0, 0.0),
        angular_velocity: 0.0,
    };

    /// The centroid x, y and the angle of `body` in coordinates `q`, without the trigonometry of
    /// [`Pose::of`] (what a recorded pose needs).
    #[inline]
    pub fn coordinates(body: BodyId, q: &[f64]) -> [f64; 3] {
        match body {
            BodyId::Ground => [0.0; 3],
            BodyId::Body(k) => [q[3 * k], q[3 * k + 1], q[3 * k + 2]],
        }
    }

    /// Pose of `body` from coordinates `q` and velocities `qd`.
    #[inline]
    pub fn of(body: BodyId, q: &[f64], qd: &[f64]) -> Pose {
        match body {
            BodyId::Ground => Pose::GROUND,
            BodyId::Body(k) => {
                let (sin, cos) = q[3 * k + 2].sin_cos();
                Pose {
                    position: Vec2::new(q[3 * k], q[3 * k + 1]),
                    angle: q[3 * k + 2],
                    cos,
                    sin,
                    velocity: Vec2::new(qd[3 * k], qd[3 * k + 1]),
                    angular_velocity: qd[3 * k + 2],
                }
            }
        }
    }

    /// A body-fixed vector `s` expressed in the world frame, A(θ)s.
    #[inline]
    pub fn rotate(&self, s: Vec2) -> Vec2 {
        Vec2::new(self.cos * s.x - self.sin * s.y, self.sin * s.x + self.cos * s.y)
    }
}
