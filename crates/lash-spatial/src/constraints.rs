//! Constraint primitives and the joints built from them.
//!
//! Every equation is a row: Φ (position level), the row of C (so that Φ̇ = C v − ν) and γ (so that
//! Φ̈ = C v̇ − γ). C is written per body as six numbers: three for the centroid velocity ṙ (world
//! frame) and three for the angular velocity ω' (body frame). The primitives are derived in the
//! world frame, with ω = A ω' and, because `d(A ω')/dt = A ω̇'`, the angular acceleration
//! α = A ω̇'; a world-frame coefficient a of ω becomes Aᵀa for ω'.
//!
//! For a body-fixed vector u (world u = A u'): u̇ = ω × u, ü = α × u + ω × (ω × u). With
//! P = r + s the marker origin (s = A s'):
//!
//! * point coincidence, component e: Φ = e·(P_i − P_j); C: e, s_i × e | −e, −s_j × e;
//!   γ = −e·(ω_i × (ω_i × s_i) − ω_j × (ω_j × s_j)).
//! * dot-1: Φ = a_i·a_j; C: 0, a_i × a_j | 0, a_j × a_i;
//!   γ = −[(ω_i × (ω_i × a_i))·a_j + a_i·(ω_j × (ω_j × a_j)) + 2(ω_i × a_i)·(ω_j × a_j)].
//! * dot-2: Φ = a_i·d, d = P_j − P_i; C: −a_i, a_i × (d + s_i) | a_i, s_j × a_i;
//!   γ = −[(ω_i × (ω_i × a_i))·d + 2(ω_i × a_i)·ḋ + a_i·(ω_j × (ω_j × s_j) − ω_i × (ω_i × s_i))].
//! * driven angle θ(t) of x_J about z_I from x_I: with c = −sin θ x_I + cos θ y_I and
//!   b = ∂c/∂θ = −cos θ x_I − sin θ y_I, Φ = c·x_J; C: 0, c × x_J | 0, x_J × c; ν = −θ̇ b·x_J;
//!   γ = −[(ω_i × (ω_i × c))·g + 2θ̇(ω_i × b)·g + θ̈ b·g − θ̇² c·g + 2(ω_i × c + θ̇ b)·(ω_j × g)
//!   + c·(ω_j × (ω_j × g))] with g = x_J.

use crate::model::{SpatialJointKind, SpatialMechanism};
use crate::{Marker, Mat3, Vec3};
use lash_mech::BodyId;

/// A body's kinematic state in the world frame (the ground: the identity, at rest).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyFrame {
    /// Centroid \[m\].
    pub position: Vec3,
    /// Orientation matrix A (body to world).
    pub rotation: Mat3,
    /// Centroid velocity [m/s].
    pub velocity: Vec3,
    /// Angular velocity ω = A ω' (world frame) [rad/s].
    pub angular_velocity: Vec3,
}

impl BodyFrame {
    /// The ground.
    pub fn ground() -> Self {
        Self {
            position: Vec3::zeros(),
            rotation: Mat3::identity(),
            velocity: Vec3::zeros(),
            angular_velocity: Vec3::zeros(),
        }
    }

    /// The pose as seven numbers: the centroid, then the orientation as a unit quaternion
    /// (w, x, y, z) with w ≥ 0 (q and −q are one rotation; the sign is chosen so that a
    /// written pose is unique).
    pub fn pose(&self) -> [f64; 7] {
        let rotation = nalgebra::Rotation3::from_matrix_unchecked(self.rotation);
        let q = nalgebra::UnitQuaternion::from_rotation_matrix(&rotation);
        let sign = if q.w < 0.0 { -1.0 } else { 1.0 };
        let p = self.position;
        [p.x, p.y, p.z, sign * q.w, sign * q.i, sign * q.j, sign * q.k]
    }
}

/// One constraint equation.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Row {
    /// The two bodies the row involves (`None`: the ground, no block).
    pub bodies: [Option<usize>; 2],
    /// The row of C for each body: (ṙ, ω') coefficients.
    pub blocks: [[f64; 6]; 2],
    /// Φ.
    pub phi: f64,
    /// ν: the velocity equation is C v = ν.
    pub nu: f64,
    /// γ: the acceleration equation is C v̇ = γ.
    pub gamma: f64,
}

/// A marker's world quantities.
struct Side {
    body: Option<usize>,
    frame: BodyFrame,
    /// A s' \[m\].
    s: Vec3,
    /// Origin r + A s' \[m\].
    origin: Vec3,
    /// Its velocity [m/s].
    origin_velocity: Vec3,
    z: Vec3,
    x: Vec3,
    y: Vec3,
}

fn side(m: &Marker, frames: &[BodyFrame]) -> Side {
    let (body, frame) = match m.body {
        BodyId::Ground => (None, BodyFrame::ground()),
        BodyId::Body(k) => (Some(k), frames[k]),
    };
    let a = &frame.rotation;
    let s = a * m.point;
    let (z, x) = (a * m.z, a * m.x);
    let w = frame.angular_velocity;
    Side {
        body,
        frame,
        s,
        origin: frame.position + s,
        origin_velocity: frame.velocity + w.cross(&s),
        z,
        x,
        y: z.cross(&x),
    }
}

/// A row from its world-frame coefficients (linear and angular, each side).
#[allow(clippy::too_many_arguments)]
fn row(i: &Side, j: &Side, lin_i: Vec3, ang_i: Vec3, lin_j: Vec3, ang_j: Vec3, phi: f64, nu: f64, gamma: f64) -> Row {
    let block = |lin: Vec3, ang: Vec3, a: &Mat3| {
        let b = a.transpose() * ang;
        [lin.x, lin.y, lin.z, b.x, b.y, b.z]
    };
    Row {
        bodies: [i.body, j.body],
        blocks: [block(lin_i, ang_i, &i.frame.rotation), block(lin_j, ang_j, &j.frame.rotation)],
        phi,
        nu,
        gamma,
    }
}

/// ω × (ω × u).
#[inline]
fn centripetal(w: &Vec3, u: &Vec3) -> Vec3 {
    w.cross(&w.cross(u))
}

fn point(i: &Side, j: &Side, e: Vec3) -> Row {
    let (wi, wj) = (i.frame.angular_velocity, j.frame.angular_velocity);
    let gamma = -e.dot(&(centripetal(&wi, &i.s) - centripetal(&wj, &j.s)));
    row(i, j, e, i.s.cross(&e), -e, -j.s.cross(&e), e.dot(&(i.origin - j.origin)), 0.0, gamma)
}

fn dot1(i: &Side, j: &Side, ai: Vec3, aj: Vec3) -> Row {
    let (wi, wj) = (i.frame.angular_velocity, j.frame.angular_velocity);
    let gamma =
        -(centripetal(&wi, &ai).dot(&aj) + ai.dot(&centripetal(&wj, &aj)) + 2.0 * wi.cross(&ai).dot(&wj.cross(&aj)));
    row(i, j, Vec3::zeros(), ai.cross(&aj), Vec3::zeros(), aj.cross(&ai), ai.dot(&aj), 0.0, gamma)
}

fn dot2(i: &Side, j: &Side, ai: Vec3) -> Row {
    let (wi, wj) = (i.frame.angular_velocity, j.frame.angular_velocity);
    let d = j.origin - i.origin;
    let d_dot = j.origin_velocity - i.origin_velocity;
    let gamma = -(centripetal(&wi, &ai).dot(&d)
        + 2.0 * wi.cross(&ai).dot(&d_dot)
        + ai.dot(&(centripetal(&wj, &j.s) - centripetal(&wi, &i.s))));
    row(i, j, -ai, ai.cross(&(d + i.s)), ai, j.s.cross(&ai), ai.dot(&d), 0.0, gamma)
}

fn driven(i: &Side, j: &Side, (theta, rate, acceleration): (f64, f64, f64)) -> Row {
    let (wi, wj) = (i.frame.angular_velocity, j.frame.angular_velocity);
    let (sin, cos) = theta.sin_cos();
    let c = -sin * i.x + cos * i.y;
    let b = -cos * i.x - sin * i.y;
    let g = j.x;
    let terms = centripetal(&wi, &c).dot(&g) + 2.0 * rate * wi.cross(&b).dot(&g) + acceleration * b.dot(&g)
        - rate * rate * c.dot(&g)
        + 2.0 * (wi.cross(&c) + rate * b).dot(&wj.cross(&g))
        + c.dot(&centripetal(&wj, &g));
    row(i, j, Vec3::zeros(), c.cross(&g), Vec3::zeros(), g.cross(&c), c.dot(&g), -rate * b.dot(&g), -terms)
}

/// Evaluates every row of the mechanism at time `t` for the bodies' frames: the joints' rows in
/// joint order, then one row per driver. `rows` must hold `mech.constraint_count()` rows.
pub fn evaluate(mech: &SpatialMechanism, frames: &[BodyFrame], t: f64, rows: &mut [Row]) {
    let mut k = 0;
    let mut push = |r: Row| {
        rows[k] = r;
        k += 1;
    };
    for jt in &mech.joints {
        let (i, j) = (side(&jt.i, frames), side(&jt.j, frames));
        match jt.kind {
            SpatialJointKind::Spherical => {
                for e in [Vec3::x(), Vec3::y(), Vec3::z()] {
                    push(point(&i, &j, e));
                }
            }
            SpatialJointKind::Revolute => {
                for e in [Vec3::x(), Vec3::y(), Vec3::z()] {
                    push(point(&i, &j, e));
                }
                push(dot1(&i, &j, i.x, j.z));
                push(dot1(&i, &j, i.y, j.z));
            }
            SpatialJointKind::Universal => {
                for e in [Vec3::x(), Vec3::y(), Vec3::z()] {
                    push(point(&i, &j, e));
                }
                push(dot1(&i, &j, i.z, j.z));
            }
            SpatialJointKind::Cylindrical | SpatialJointKind::Translational => {
                push(dot1(&i, &j, i.x, j.z));
                push(dot1(&i, &j, i.y, j.z));
                push(dot2(&i, &j, i.x));
                push(dot2(&i, &j, i.y));
                if jt.kind == SpatialJointKind::Translational {
                    push(dot1(&i, &j, i.x, j.y));
                }
            }
        }
    }
    for d in &mech.drivers {
        let jt = &mech.joints[d.joint];
        let (i, j) = (side(&jt.i, frames), side(&jt.j, frames));
        push(driven(&i, &j, d.motion.eval(t)));
    }
    debug_assert_eq!(k, rows.len());
}

/// The world-frame state of marker `m`: origin, its velocity, and the z and x directions.
pub fn marker_world(m: &Marker, frames: &[BodyFrame]) -> (Vec3, Vec3, Vec3, Vec3) {
    let s = side(m, frames);
    (s.origin, s.origin_velocity, s.z, s.x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{SpatialBody, SpatialDriver, SpatialJoint};
    use crate::{Orientation, SpatialMechanism};
    use lash_mech::{Baumgarte, Motion};

    /// A smooth rigid motion: centroid, orientation R_z(α) R_y(β) R_x(γ) and their rates.
    struct Motion3 {
        seed: f64,
    }

    impl Motion3 {
        fn angles(&self, t: f64) -> ([f64; 3], [f64; 3]) {
            let s = self.seed;
            (
                [0.3 + 1.1 * s * t, 0.2 * (2.0 * t + s).sin(), 0.5 * s * t * t - 0.4],
                [1.1 * s, 0.4 * (2.0 * t + s).cos(), s * t],
            )
        }

        fn position(&self, t: f64) -> Vec3 {
            let s = self.seed;
            Vec3::new(0.1 * (1.3 * t * s).sin(), 0.05 * (0.7 * t).cos() * s, 0.02 * t * t + 0.01 * s)
        }

        fn velocity(&self, t: f64) -> Vec3 {
            let s = self.seed;
            Vec3::new(0.13 * s * (1.3 * t * s).cos(), -0.035 * (0.7 * t).sin() * s, 0.04 * t)
        }

        fn rotation(&self, t: f64) -> Orientation {
            let ([a, b, g], _) = self.angles(t);
            Orientation::from_axis_angle(&Vec3::z_axis(), a)
                * Orientation::from_axis_angle(&Vec3::y_axis(), b)
                * Orientation::from_axis_angle(&Vec3::x_axis(), g)
        }

        /// ω in the world frame.
        fn angular_velocity(&self, t: f64) -> Vec3 {
            let ([a, b, _], [ad, bd, gd]) = self.angles(t);
            let rz = Orientation::from_axis_angle(&Vec3::z_axis(), a);
            let ry = Orientation::from_axis_angle(&Vec3::y_axis(), b);
            ad * Vec3::z() + bd * (rz * Vec3::y()) + gd * (rz * ry * Vec3::x())
        }

        /// ω' in the body frame.
        fn body_angular_velocity(&self, t: f64) -> Vec3 {
            self.rotation(t).inverse() * self.angular_velocity(t)
        }

        fn frame(&self, t: f64) -> BodyFrame {
            BodyFrame {
                position: self.position(t),
                rotation: *self.rotation(t).to_rotation_matrix().matrix(),
                velocity: self.velocity(t),
                angular_velocity: self.angular_velocity(t),
            }
        }

        /// (r̈, ω̇') by central differences of the analytic rates.
        fn accelerations(&self, t: f64) -> [f64; 6] {
            let h = 1e-5;
            let a = (self.velocity(t + h) - self.velocity(t - h)) / (2.0 * h);
            let w = (self.body_angular_velocity(t + h) - self.body_angular_velocity(t - h)) / (2.0 * h);
            [a.x, a.y, a.z, w.x, w.y, w.z]
        }

        fn velocities(&self, t: f64) -> [f64; 6] {
            let (v, w) = (self.velocity(t), self.body_angular_velocity(t));
            [v.x, v.y, v.z, w.x, w.y, w.z]
        }
    }

    fn body(name: &str) -> SpatialBody {
        SpatialBody::at_rest(name, 1.0, Vec3::new(1.0, 1.0, 1.0), Vec3::zeros(), Orientation::identity())
    }

    /// Every joint kind between two moving bodies and, once more, with the ground; a driver on
    /// each revolute and cylindrical joint (a harmonic motion, so θ̈ ≠ 0).
    fn mechanism() -> SpatialMechanism {
        let marker = |body, p: [f64; 3], z: [f64; 3], x: [f64; 3]| {
            let z = Vec3::from(z).normalize();
            let x = Vec3::from(x);
            Marker::oriented(body, Vec3::from(p), z, (x - z * z.dot(&x)).normalize())
        };
        let (b0, b1) = (BodyId::Body(0), BodyId::Body(1));
        let kinds = [
            SpatialJointKind::Spherical,
            SpatialJointKind::Revolute,
            SpatialJointKind::Universal,
            SpatialJointKind::Cylindrical,
            SpatialJointKind::Translational,
        ];
        let mut joints = Vec::new();
        for (n, kind) in kinds.into_iter().enumerate() {
            let f = n as f64;
            for (i, j) in [(b0, b1), (BodyId::Ground, b1), (b0, BodyId::Ground)] {
                joints.push(SpatialJoint {
                    name: format!("{kind:?}{n}"),
                    kind,
                    i: marker(i, [0.1, -0.05 * f, 0.02], [0.2, 1.0, 0.3 * f], [1.0, 0.1, -0.2]),
                    j: marker(j, [-0.07, 0.03, 0.04 * f], [0.1 * f, 0.9, -0.2], [0.3, -0.1, 1.0]),
                });
            }
        }
        let drivers = joints
            .iter()
            .enumerate()
            .filter(|(_, j)| j.kind.rotates_about_axis())
            .map(|(k, j)| SpatialDriver {
                name: format!("drive {}", j.name),
                joint: k,
                motion: Motion::Harmonic { angle0: 0.4, omega: 3.0, amplitude: 0.2, frequency: 7.0, phase: 0.3 },
            })
            .collect();
        SpatialMechanism {
            bodies: vec![body("a"), body("b")],
            joints,
            drivers,
            loads: vec![],
            gravity: Vec3::zeros(),
            baumgarte: Baumgarte { alpha: 0.0, beta: 0.0 },
        }
    }

    #[test]
    fn nu_and_gamma_of_every_primitive_match_finite_differences_along_a_smooth_motion() {
        let mech = mechanism();
        let motions = [Motion3 { seed: 0.8 }, Motion3 { seed: -1.3 }];
        let m = mech.constraint_count();
        let rows_at = |t: f64| {
            let frames: Vec<BodyFrame> = motions.iter().map(|mo| mo.frame(t)).collect();
            let mut rows = vec![Row::default(); m];
            evaluate(&mech, &frames, t, &mut rows);
            rows
        };
        for t in [0.0, 0.37, 1.2] {
            let rows = rows_at(t);
            let h = 1e-4;
            let (plus, minus) = (rows_at(t + h), rows_at(t - h));
            let v: Vec<f64> = motions.iter().flat_map(|mo| mo.velocities(t)).collect();
            let a: Vec<f64> = motions.iter().flat_map(|mo| mo.accelerations(t)).collect();
            let times = |r: &Row, x: &[f64]| -> f64 {
                (0..2)
                    .filter_map(|b| r.bodies[b].map(|k| (0..6).map(|c| r.blocks[b][c] * x[6 * k + c]).sum::<f64>()))
                    .sum()
            };
            for (k, r) in rows.iter().enumerate() {
                let rate = (plus[k].phi - minus[k].phi) / (2.0 * h);
                let second = (plus[k].phi - 2.0 * r.phi + minus[k].phi) / (h * h);
                let (cv, ca) = (times(r, &v) - r.nu, times(r, &a) - r.gamma);
                assert!((rate - cv).abs() < 1e-7 * (1.0 + rate.abs()), "row {k} at t = {t}: Φ̇ {rate} vs C v − ν {cv}");
                assert!(
                    (second - ca).abs() < 2e-5 * (1.0 + second.abs()),
                    "row {k} at t = {t}: Φ̈ {second} vs C v̇ − γ {ca}"
                );
            }
        }
    }

    #[test]
    fn a_consistent_pose_has_zero_residuals() {
        // Two bodies placed so that every joint of a revolute pair holds: Φ = 0 for its rows.
        let mut mech = mechanism();
        mech.joints.truncate(4); // spherical (3 kinds of pair) and the first revolute
        mech.joints[3].j = Marker { body: BodyId::Body(1), ..mech.joints[3].i };
        mech.joints[3].i.body = BodyId::Body(0);
        mech.joints.drain(..3);
        mech.drivers.clear();
        let frame = BodyFrame::ground();
        let mut rows = vec![Row::default(); mech.constraint_count()];
        evaluate(&mech, &[frame, frame], 0.0, &mut rows);
        assert!(rows.iter().all(|r| r.phi.abs() < 1e-15), "{rows:?}");
    }
}
