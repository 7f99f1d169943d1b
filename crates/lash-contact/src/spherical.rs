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

use crate::clearance::{ContactLaws, OneContact, contact_forces};
use crate::friction::FrictionLaw;
use crate::law::NormalForce;
use lash_core::lane::Real;
use lash_mech::BodyId;
use lash_spatial::Vec3;
use lash_spatial::constraints::BodyFrame;
use serde::Serialize;

/// a·b, summed as nalgebra sums a 3-vector's (so a run's values keep their bits).
#[inline(always)]
pub fn dot<R: Real>(a: [R; 3], b: [R; 3]) -> R {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// a × b, each component formed as nalgebra forms it.
#[inline(always)]
pub fn cross<R: Real>(a: [R; 3], b: [R; 3]) -> [R; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// The motion of a spherical clearance joint at one state ([`spherical_motion`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphericalMotion<R> {
    /// |e| \[m\].
    pub norm: R,
    /// n = e/|e| ((1, 0, 0) at the centre).
    pub normal: [R; 3],
    /// δ = |e| − c \[m\].
    pub penetration: R,
    /// δ̇ = ė·n [m/s].
    pub penetration_rate: R,
    /// The contact points' relative velocity's tangential part v_t [m/s].
    pub slip: [R; 3],
    /// |v_t| [m/s].
    pub speed: R,
}

/// The geometry and motion of a spherical clearance joint of clearance `clearance` and radii
/// `[R_J, R_B]` at eccentricity `e`, its rate `e_dot` and the ball's and socket's angular
/// velocities `[ω_J, ω_B]` (world frame), for one run or several side by side ([`Real`]): the
/// one source of [`SphericalClearance::evaluate_relative`] and of any lanes.
#[inline(always)]
pub fn spherical_motion<R: Real>(
    e: [R; 3],
    e_dot: [R; 3],
    [omega_journal, omega_bearing]: [[R; 3]; 2],
    [journal_radius, bearing_radius]: [R; 2],
    clearance: R,
) -> SphericalMotion<R> {
    let (zero, one) = (R::splat(0.0), R::splat(1.0));
    let norm = dot(e, e).sqrt();
    // One division, then products (three divisions were a fifth of the evaluation).
    let positive = norm.simd_gt(zero);
    let inverse = one / norm;
    let normal = [
        R::select(positive, e[0] * inverse, one),
        R::select(positive, e[1] * inverse, zero),
        R::select(positive, e[2] * inverse, zero),
    ];
    let penetration_rate = dot(e_dot, normal);
    let at = |r: R| normal.map(|x| x * r);
    let (spin_j, spin_b) = (cross(omega_journal, at(journal_radius)), cross(omega_bearing, at(bearing_radius)));
    let relative: [R; 3] = std::array::from_fn(|i| e_dot[i] + spin_j[i] - spin_b[i]);
    let along = dot(relative, normal);
    let slip: [R; 3] = std::array::from_fn(|i| relative[i] - normal[i] * along);
    SphericalMotion {
        norm,
        normal,
        penetration: norm - clearance,
        penetration_rate,
        slip,
        speed: dot(slip, slip).sqrt(),
    }
}

/// The force on the ball, −F_N n − F_T v_t/|v_t|, of a normal force `normal` and a friction force
/// `friction` at the motion `m` (no friction direction without slip).
#[inline(always)]
pub fn spherical_load<R: Real>(m: &SphericalMotion<R>, normal: R, friction: R) -> [R; 3] {
    let zero = R::splat(0.0);
    // −F_T v_t/|v_t| as one scale of the slip.
    let along_slip = R::select(m.speed.simd_gt(zero), friction / m.speed, zero);
    std::array::from_fn(|i| -(m.normal[i] * normal) - m.slip[i] * along_slip)
}

/// A spherical clearance joint's contact at one state ([`spherical_contact`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphericalContact<R> {
    /// The geometry and motion.
    pub motion: SphericalMotion<R>,
    /// F_N \[N\].
    pub normal_force: R,
    /// F_T (its magnitude) \[N\].
    pub friction_force: R,
    /// The force on the ball \[N\].
    pub load: [R; 3],
}

/// The contact of a spherical clearance joint with the laws `laws` ([`spherical_motion`]'s
/// arguments) for one run or several side by side: the one source of
/// [`SphericalClearance::evaluate_relative`] and of any lanes.
#[inline(always)]
pub fn spherical_contact<R: Real>(
    laws: &impl ContactLaws<R>,
    (e, e_dot): ([R; 3], [R; 3]),
    omega: [[R; 3]; 2],
    radii: [R; 2],
    clearance: R,
) -> SphericalContact<R> {
    let motion = spherical_motion(e, e_dot, omega, radii, clearance);
    let (normal_force, friction_force) =
        contact_forces(laws, (motion.penetration, motion.penetration_rate), motion.speed);
    let load = spherical_load(&motion, normal_force, friction_force);
    SphericalContact { motion, normal_force, friction_force, load }
}

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
        let v = |a: Vec3| [a.x, a.y, a.z];
        let laws = OneContact::<false> { law: &self.law, friction: &self.friction, onset, series: f64::INFINITY };
        let radii = [self.journal_radius, self.bearing_radius];
        let omega = [v(omega_journal), v(omega_bearing)];
        let c = spherical_contact(&laws, (v(e), v(e_dot)), omega, radii, self.radial_clearance());
        let m = &c.motion;
        SphericalContactState {
            journal_centre: Vec3::zeros(),
            eccentricity: e,
            eccentricity_norm: m.norm,
            normal: m.normal.into(),
            penetration: m.penetration,
            penetration_rate: m.penetration_rate,
            slip_velocity: m.slip.into(),
            normal_force: c.normal_force,
            friction_force: c.friction_force,
            force_on_journal: c.load.into(),
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

    /// A contact's laws over eight lanes, as the micro step's lanes hold them.
    struct TestLanes {
        law: (crate::law::LaneLaw, [lash_core::lane::F64x8; 4]),
        friction: (crate::friction::LaneFriction, [lash_core::lane::F64x8; 4]),
        onset: (lash_core::lane::F64x8, lash_core::lane::F64x8),
    }

    impl ContactLaws<lash_core::lane::F64x8> for TestLanes {
        fn normal_force(&self, delta: lash_core::lane::F64x8, rate: lash_core::lane::F64x8) -> lash_core::lane::F64x8 {
            let f = self.law.0.force(&self.law.1, (delta, rate), self.onset.0, self.onset.1);
            f.max(lash_core::lane::F64x8::ZERO)
        }
        fn friction_coefficient(&self, speed: lash_core::lane::F64x8) -> lash_core::lane::F64x8 {
            crate::friction::lane_coefficient(self.friction.0, &self.friction.1, speed)
        }
    }

    /// The spherical joint's contact over eight lanes ([`spherical_contact`] with every contact law
    /// and every friction law in their lane forms) is the scalar
    /// [`SphericalClearance::evaluate_relative`] lane by lane, bit for bit: free flight, the
    /// centre, contact with and without slip, a rolling ball, onsets below and above the floor.
    #[test]
    fn the_evaluation_in_lanes_is_the_scalar_one_bit_for_bit() {
        use crate::friction::LaneFriction;
        use crate::law::{LaneLaw, onset_reciprocal};
        use lash_core::lane::{F64x8, LANES};
        let c = 0.00025;
        let e: [[f64; 3]; LANES] = [
            [1e-4, 0.0, 0.0],
            [0.0, 0.0, 0.0],
            [c + 1e-6, 0.0, 0.0],
            [0.0, -(c + 3e-6), 1e-5],
            [1.5e-4, 1.5e-4, 1.5e-4],
            [-2e-4, 1e-4, 1.2e-4],
            [0.0, 0.0, c + 2e-5],
            [c * 0.6, c * 0.8, 0.0],
        ];
        let e_dot = [
            [0.3, 0.1, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 0.05, 0.0],
            [0.01, -0.2, 0.3],
            [0.0; 3],
            [-1.0, 2.0, 0.5],
            [0.2, 0.0, 1e-3],
            [0.0, 0.0, 0.4],
        ];
        let wj = [
            [0.0; 3],
            [0.0, 0.0, 5.0],
            [0.0, 0.0, -0.05 / 0.00575],
            [3.0, -2.0, 1.0],
            [0.0, 10.0, 0.0],
            [-4.0, 0.0, 2.0],
            [0.0; 3],
            [1.0, 1.0, 1.0],
        ];
        let wb = [[0.0; 3], [0.0; 3], [0.0; 3], [0.0, 1.0, 0.0], [0.0; 3], [2.0, 2.0, 0.0], [0.0, 0.0, 7.0], [0.0; 3]];
        let onset = [0.0, 1e-5, 0.2, 1.0, 3.0, 0.5, 1e-4, 0.05];
        let laws = [
            NormalForce::Power { stiffness: 1e10, exponent: 1.5 },
            NormalForce::KelvinVoigt { stiffness: 1e8, damping: 3e3 },
            NormalForce::Hysteresis { stiffness: 5e9, exponent: 1.5, chi: 0.3, floor: 1e-4 },
            NormalForce::AdamsImpact { stiffness: 1e10, exponent: 2.2, max_damping: 1e4, damping_depth: 2e-6 },
            NormalForce::Liu { factor: 3e9, clearance: c, chi: 0.2, floor: 1e-4 },
        ];
        let frictions = crate::friction::tests::laws();
        let lanes = |a: &[[f64; 3]; LANES]| -> [F64x8; 3] { std::array::from_fn(|i| F64x8(a.map(|v| v[i]))) };
        for (law, friction) in laws.iter().flat_map(|l| frictions.iter().map(move |f| (l, f))) {
            let joint = SphericalClearance { journal_point: Vec3::zeros(), law: *law, friction: *friction, ..ball() };
            let (kind, numbers) = LaneLaw::of(law);
            let (friction_kind, friction_numbers) = LaneFriction::of(friction);
            let radii = [joint.journal_radius, joint.bearing_radius].map(F64x8::splat);
            let o = F64x8(onset);
            let reciprocal = onset_reciprocal(o, F64x8::splat(kind.floor(&numbers)));
            let laws = TestLanes {
                law: (kind, numbers.map(F64x8::splat)),
                friction: (friction_kind, friction_numbers.map(F64x8::splat)),
                onset: (o, reciprocal),
            };
            let lanes_of = (lanes(&e), lanes(&e_dot));
            let c = spherical_contact(
                &laws,
                lanes_of,
                [lanes(&wj), lanes(&wb)],
                radii,
                F64x8::splat(joint.radial_clearance()),
            );
            let (m, normal, tangential, load) = (c.motion, c.normal_force, c.friction_force, c.load);
            let v = |a: [f64; 3]| Vec3::from(a);
            for l in 0..LANES {
                let s = joint.evaluate_relative(v(e[l]), v(e_dot[l]), v(wj[l]), v(wb[l]), onset[l]);
                let lane = [
                    m.norm[l],
                    m.penetration[l],
                    m.penetration_rate[l],
                    normal[l],
                    tangential[l],
                    m.normal[0][l],
                    m.normal[1][l],
                    m.normal[2][l],
                    m.slip[0][l],
                    m.slip[1][l],
                    m.slip[2][l],
                    load[0][l],
                    load[1][l],
                    load[2][l],
                ];
                let scalar = [
                    s.eccentricity_norm,
                    s.penetration,
                    s.penetration_rate,
                    s.normal_force,
                    s.friction_force,
                    s.normal.x,
                    s.normal.y,
                    s.normal.z,
                    s.slip_velocity.x,
                    s.slip_velocity.y,
                    s.slip_velocity.z,
                    s.force_on_journal.x,
                    s.force_on_journal.y,
                    s.force_on_journal.z,
                ];
                assert_eq!(lane.map(f64::to_bits), scalar.map(f64::to_bits), "{law:?}, {friction:?}, lane {l}");
            }
        }
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
