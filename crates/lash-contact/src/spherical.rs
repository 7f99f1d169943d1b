//! The spherical clearance joint: a ball (journal) on one body inside a spherical socket (bearing)
//! on another (docs/theory.md, spatial mechanisms).
//!
//! Eccentricity e = r_J − r_B (ball centre minus socket centre, world frame), penetration
//! δ = |e| − c with c = R_B − R_J, normal n = e/|e|, penetration rate δ̇ = ė·n. The contact points
//! are P_J = r_J + R_J n on the ball and P_B = r_B + R_B n on the socket; their relative velocity
//! is v = ė + ω_J × R_J n − ω_B × R_B n, and its tangential part v_t = v − (v·n) n is the slip.
//! The force on the ball is f_J = −F_N n − F_T v_t/|v_t| with F_T = μ(|v_t|) F_N, applied at
//! P_J; the socket receives −f_J at P_B. The normal force passes through both centres; the
//! friction force has moments R_J n × f and R_B n × (−f) about them.

use crate::friction::FrictionLaw;
use crate::law::NormalForce;
use lash_mech::BodyId;
use lash_spatial::Vec3;
use lash_spatial::constraints::BodyFrame;
use serde::Serialize;

/// A spherical joint with radial clearance.
#[derive(Debug, Clone, PartialEq)]
pub struct SphericalClearance {
    /// Name used in outputs (usually the joint it replaces).
    pub name: String,
    /// Body carrying the ball.
    pub journal_body: BodyId,
    /// Ball centre on its body (body frame, from the centroid) \[m\].
    pub journal_point: Vec3,
    /// Body carrying the socket.
    pub bearing_body: BodyId,
    /// Socket centre on its body \[m\].
    pub bearing_point: Vec3,
    /// Ball radius R_J \[m\].
    pub journal_radius: f64,
    /// Socket radius R_B \[m\].
    pub bearing_radius: f64,
    /// Normal contact law.
    pub law: NormalForce,
    /// Friction law (its coefficient of the slip speed |v_t|).
    pub friction: FrictionLaw,
    /// Discrete state: contact closed since the last located onset.
    pub in_contact: bool,
    /// Discrete state: approach velocity δ̇⁻ captured at the last onset [m/s].
    pub onset_velocity: f64,
}

/// Geometry, kinematics and forces of one spherical clearance joint at one state (world frame).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct SphericalContactState {
    /// Ball centre \[m\].
    pub journal_centre: Vec3,
    /// Eccentricity e = r_J − r_B \[m\].
    pub eccentricity: Vec3,
    /// |e| \[m\].
    pub eccentricity_norm: f64,
    /// Normal n = e/|e|.
    pub normal: Vec3,
    /// Penetration δ = |e| − c \[m\] (negative: free flight).
    pub penetration: f64,
    /// Penetration rate δ̇ = ė·n [m/s] (positive: approaching).
    pub penetration_rate: f64,
    /// Slip velocity v_t of the ball's contact point relative to the socket's [m/s].
    pub slip_velocity: Vec3,
    /// Normal force F_N ≥ 0 \[N\].
    pub normal_force: f64,
    /// Friction force magnitude F_T ≥ 0 \[N\].
    pub friction_force: f64,
    /// Force on the ball f_J \[N\].
    pub force_on_journal: Vec3,
}

impl SphericalClearance {
    /// Radial clearance c = R_B − R_J \[m\].
    pub fn radial_clearance(&self) -> f64 {
        self.bearing_radius - self.journal_radius
    }

    /// Geometry and forces for the two bodies' frames (the ground's is the identity at rest).
    #[inline]
    pub fn evaluate(&self, journal: &BodyFrame, bearing: &BodyFrame, onset: f64) -> SphericalContactState {
        let sj = journal.rotation * self.journal_point;
        let sb = bearing.rotation * self.bearing_point;
        let rj = journal.position + sj;
        let e_dot = journal.velocity + journal.angular_velocity.cross(&sj)
            - bearing.velocity
            - bearing.angular_velocity.cross(&sb);
        let mut s = self.evaluate_relative(
            rj - bearing.position - sb,
            e_dot,
            journal.angular_velocity,
            bearing.angular_velocity,
            onset,
        );
        s.journal_centre = rj;
        s
    }

    /// Geometry and forces from the eccentricity, its rate and the bodies' angular velocities
    /// (world frame). `journal_centre` is left at zero. Always inlined: it is the micro step's
    /// contact evaluation, and a call there makes the step keep its values in memory.
    #[inline(always)]
    pub fn evaluate_relative(
        &self,
        e: Vec3,
        e_dot: Vec3,
        omega_journal: Vec3,
        omega_bearing: Vec3,
        onset: f64,
    ) -> SphericalContactState {
        let norm = e.norm();
        // One division, then products (three divisions were a fifth of the evaluation).
        let n = if norm > 0.0 { e * (1.0 / norm) } else { Vec3::x() };
        let delta = norm - self.radial_clearance();
        let delta_dot = e_dot.dot(&n);
        let fn_ = self.law.force(delta, delta_dot, onset);
        let relative =
            e_dot + omega_journal.cross(&(n * self.journal_radius)) - omega_bearing.cross(&(n * self.bearing_radius));
        let slip = relative - n * relative.dot(&n);
        let speed = slip.norm();
        let ft = if fn_ > 0.0 { self.friction.coefficient(speed) * fn_ } else { 0.0 };
        // −F_T v_t/|v_t| as one scale of the slip.
        let along_slip = if speed > 0.0 { ft / speed } else { 0.0 };
        SphericalContactState {
            journal_centre: Vec3::zeros(),
            eccentricity: e,
            eccentricity_norm: norm,
            normal: n,
            penetration: delta,
            penetration_rate: delta_dot,
            slip_velocity: slip,
            normal_force: fn_,
            friction_force: ft,
            force_on_journal: -(n * fn_) - slip * along_slip,
        }
    }

    /// World-frame arms from the ball body's and the socket body's centroids to the contact points.
    #[inline]
    pub fn arms(&self, journal: &BodyFrame, bearing: &BodyFrame, state: &SphericalContactState) -> (Vec3, Vec3) {
        (
            journal.rotation * self.journal_point + state.normal * self.journal_radius,
            bearing.rotation * self.bearing_point + state.normal * self.bearing_radius,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lash_spatial::Mat3;

    fn ball() -> SphericalClearance {
        SphericalClearance {
            name: "ball".into(),
            journal_body: BodyId::Body(0),
            journal_point: Vec3::new(0.1, 0.0, 0.0),
            bearing_body: BodyId::Ground,
            bearing_point: Vec3::zeros(),
            journal_radius: 0.00575,
            bearing_radius: 0.006,
            law: NormalForce::Power { stiffness: 1e10, exponent: 1.0 },
            friction: FrictionLaw::Coulomb { coefficient: 0.1 },
            in_contact: true,
            onset_velocity: 1.0,
        }
    }

    #[test]
    fn sign_conventions_of_a_pressed_spinning_ball() {
        // Ball centre displaced +z by c + δ, moving further +z and sliding +x, spinning about +y:
        // the normal force pushes it back (−z); the slip at the contact point (top of the ball)
        // is ė_x + (ω × R_J n)_x = 0.2 + ω_y R_J, so friction pushes it along −x.
        let c = SphericalClearance { journal_point: Vec3::zeros(), ..ball() };
        let delta = 1e-6;
        let journal = BodyFrame {
            position: Vec3::new(0.0, 0.0, 0.00025 + delta),
            rotation: Mat3::identity(),
            velocity: Vec3::new(0.2, 0.0, 0.3),
            angular_velocity: Vec3::new(0.0, 10.0, 0.0),
        };
        let s = c.evaluate(&journal, &BodyFrame::ground(), 1.0);
        assert!((s.penetration - delta).abs() < 1e-15, "{}", s.penetration);
        assert!((s.penetration_rate - 0.3).abs() < 1e-12);
        // ω × R_J n = (0, 10, 0) × (0, 0, R_J) = (10 R_J, 0, 0).
        assert!((s.slip_velocity.x - (0.2 + 10.0 * 0.00575)).abs() < 1e-12, "{:?}", s.slip_velocity);
        assert!(s.slip_velocity.y.abs() < 1e-15 && s.slip_velocity.z.abs() < 1e-15);
        assert!((s.normal_force - 1e4).abs() < 1e-6);
        assert!((s.force_on_journal - Vec3::new(-1e3, 0.0, -1e4)).norm() < 1e-6, "{:?}", s.force_on_journal);
        let (arm_j, arm_b) = c.arms(&journal, &BodyFrame::ground(), &s);
        assert!((arm_j - Vec3::new(0.0, 0.0, 0.00575)).norm() < 1e-12);
        assert!((arm_b - Vec3::new(0.0, 0.0, 0.006)).norm() < 1e-12);
    }

    #[test]
    fn free_flight_has_no_force_and_a_rolling_ball_no_friction() {
        let c =
            SphericalClearance { friction: FrictionLaw::Ambrosio { coefficient: 0.1, v0: 1e-4, v1: 1e-3 }, ..ball() };
        let s =
            c.evaluate_relative(Vec3::new(1e-4, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::zeros(), Vec3::zeros(), 1.0);
        assert_eq!((s.normal_force, s.friction_force), (0.0, 0.0));
        // Pressed along +x, the ball's centre moving +y at v and spinning about +z at −v/R_J: its
        // contact point rolls on the socket (v + ω × R_J n = 0), so there is no slip.
        let v = 0.05;
        let e = Vec3::new(c.radial_clearance() + 1e-6, 0.0, 0.0);
        let s = c.evaluate_relative(
            e,
            Vec3::new(0.0, v, 0.0),
            Vec3::new(0.0, 0.0, -v / c.journal_radius),
            Vec3::zeros(),
            1.0,
        );
        assert!(s.normal_force > 0.0 && s.friction_force == 0.0 && s.slip_velocity.norm() < 1e-15, "{s:?}");
    }
}
