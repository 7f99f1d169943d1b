//! The spatial mechanism as data: bodies, joints between markers, drivers, loads.

use crate::{Mat3, Orientation, POSITION_COORDINATES, VELOCITY_COORDINATES, Vec3};
use lash_core::Problems;
use lash_mech::{Baumgarte, BodyId, Motion};
use serde::{Deserialize, Serialize};

/// A rigid body. Local points and directions are given in its own frame, from its centroid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpatialBody {
    /// Name used in outputs and errors.
    pub name: String,
    /// Mass \[kg\].
    pub mass: f64,
    /// Inertia tensor about the centroid in the body frame [kg m²] (symmetric positive definite).
    pub inertia: Mat3,
    /// Initial centroid position in the world frame \[m\] (assembly corrects it).
    pub position: Vec3,
    /// Initial orientation (body frame to world frame).
    pub orientation: Orientation,
    /// Initial centroid velocity in the world frame [m/s] (velocity analysis corrects it).
    pub velocity: Vec3,
    /// Initial angular velocity in the body frame [rad/s].
    pub angular_velocity: Vec3,
}

impl SpatialBody {
    /// A body at rest at `position` with the given orientation and principal inertias along its
    /// own axes.
    pub fn at_rest(name: &str, mass: f64, principal: Vec3, position: Vec3, orientation: Orientation) -> Self {
        Self {
            name: name.to_string(),
            mass,
            inertia: Mat3::from_diagonal(&principal),
            position,
            orientation,
            velocity: Vec3::zeros(),
            angular_velocity: Vec3::zeros(),
        }
    }
}

/// A joint frame on a body (ADAMS's marker): an origin and two orthogonal unit directions, in the
/// body's frame (the world frame for the ground). Its y axis is z × x.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Marker {
    /// The body carrying it.
    pub body: BodyId,
    /// Origin, from the centroid \[m\].
    pub point: Vec3,
    /// z direction (the joint axis for revolute, cylindrical and translational joints).
    pub z: Vec3,
    /// x direction (orthogonal to z; the reference of a driver's angle).
    pub x: Vec3,
}

impl Marker {
    /// A marker whose directions are the body's own x and z axes.
    pub fn at(body: BodyId, point: Vec3) -> Self {
        Self { body, point, z: Vec3::z(), x: Vec3::x() }
    }

    /// A marker with axis `z` and reference `x` (normalised here).
    pub fn oriented(body: BodyId, point: Vec3, z: Vec3, x: Vec3) -> Self {
        Self { body, point, z: z.normalize(), x: x.normalize() }
    }
}

/// Kinds of joint, by what they make of the two markers I (on body i) and J (on body j).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SpatialJointKind {
    /// Origins coincide (3 equations).
    Spherical,
    /// Origins coincide, z axes parallel (5).
    Revolute,
    /// Origins coincide, z axes perpendicular (4): a Cardan joint whose cross carries z_I and z_J.
    Universal,
    /// z axes parallel, J's origin on I's z line (4).
    Cylindrical,
    /// A cylindrical joint without rotation about the axis (5): prismatic, translational.
    Translational,
}

impl SpatialJointKind {
    /// Number of constraint equations.
    pub fn equations(self) -> usize {
        match self {
            Self::Spherical => 3,
            Self::Universal | Self::Cylindrical => 4,
            Self::Revolute | Self::Translational => 5,
        }
    }

    /// Whether a driver or motor may act about its axis (a rotation about z is free).
    pub fn rotates_about_axis(self) -> bool {
        matches!(self, Self::Revolute | Self::Cylindrical)
    }
}

/// A joint between marker `i` and marker `j`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpatialJoint {
    /// Name used in outputs and errors.
    pub name: String,
    /// Kind.
    pub kind: SpatialJointKind,
    /// Marker I.
    pub i: Marker,
    /// Marker J.
    pub j: Marker,
}

/// Prescribed rotation of a revolute or cylindrical joint: the angle of x_J about z_I, measured
/// from x_I (right-handed), follows `motion`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpatialDriver {
    /// Name used in outputs and errors.
    pub name: String,
    /// Index of the driven joint.
    pub joint: usize,
    /// Prescribed angle θ(t).
    pub motion: Motion,
}

/// An applied load.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum SpatialLoad {
    /// A constant force (world frame) at a body point (body frame, from the centroid).
    Force {
        /// Loaded body.
        body: usize,
        /// Point of application \[m\].
        point: Vec3,
        /// Force \[N\].
        force: Vec3,
    },
    /// A constant torque (world frame) [N m].
    Torque {
        /// Loaded body.
        body: usize,
        /// Torque [N m].
        torque: Vec3,
    },
    /// A motor in a revolute or cylindrical joint with a linear torque–speed line (a DC motor):
    /// T = stall_torque · (1 − Ω / no_load_speed) about z_I on body j (and −T on body i), Ω the
    /// joint's relative angular velocity about z_I.
    Motor {
        /// Index of the joint.
        joint: usize,
        /// Torque at standstill [N m].
        stall_torque: f64,
        /// Speed at which the torque vanishes [rad/s] (> 0).
        no_load_speed: f64,
    },
}

/// A spatial mechanism.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpatialMechanism {
    /// Moving bodies.
    pub bodies: Vec<SpatialBody>,
    /// Joints.
    pub joints: Vec<SpatialJoint>,
    /// Rotational drivers.
    pub drivers: Vec<SpatialDriver>,
    /// Applied loads.
    pub loads: Vec<SpatialLoad>,
    /// Gravitational acceleration in the world frame [m/s²].
    pub gravity: Vec3,
    /// Constraint stabilisation.
    pub baumgarte: Baumgarte,
}

impl SpatialMechanism {
    /// Position coordinates (7 per body).
    pub fn coordinate_count(&self) -> usize {
        POSITION_COORDINATES * self.bodies.len()
    }

    /// Velocity coordinates (6 per body).
    pub fn velocity_count(&self) -> usize {
        VELOCITY_COORDINATES * self.bodies.len()
    }

    /// Constraint equations (joints and drivers).
    pub fn constraint_count(&self) -> usize {
        self.joints.iter().map(|j| j.kind.equations()).sum::<usize>() + self.drivers.len()
    }

    /// The initial state `[q; v]` from the bodies' initial poses and velocities (not assembled).
    pub fn initial_state(&self) -> Vec<f64> {
        let n = self.bodies.len();
        let mut y = vec![0.0; (POSITION_COORDINATES + VELOCITY_COORDINATES) * n];
        let (q, v) = y.split_at_mut(POSITION_COORDINATES * n);
        for (k, b) in self.bodies.iter().enumerate() {
            q[7 * k..7 * k + 3].copy_from_slice(b.position.as_slice());
            crate::write_orientation(&b.orientation, &mut q[7 * k + 3..7 * k + 7]);
            v[6 * k..6 * k + 3].copy_from_slice(b.velocity.as_slice());
            v[6 * k + 3..6 * k + 6].copy_from_slice(b.angular_velocity.as_slice());
        }
        y
    }

    /// Every problem, with its field path.
    pub fn validate(&self) -> Problems {
        let mut p = Problems::new();
        if self.bodies.is_empty() {
            p.push("bodies", "a mechanism needs at least one moving body");
        }
        for (k, b) in self.bodies.iter().enumerate() {
            validate_body(&mut p, k, b);
        }
        self.validate_joints(&mut p);
        for (k, d) in self.drivers.iter().enumerate() {
            self.check_rotating_joint(&mut p, format!("drivers[{k}].joint"), d.joint, "a driver");
            p.extend_prefixed(&format!("drivers[{k}].motion"), d.motion.validate());
        }
        for (k, l) in self.loads.iter().enumerate() {
            self.validate_load(&mut p, k, l);
        }
        finite_vector(&mut p, "gravity".into(), &self.gravity);
        p.non_negative("baumgarte.alpha", self.baumgarte.alpha);
        p.non_negative("baumgarte.beta", self.baumgarte.beta);
        let (n, m) = (self.velocity_count(), self.constraint_count());
        if m > n {
            p.push("joints", format!("{m} constraint equations for {n} velocity coordinates: over-constrained"));
        }
        p
    }

    /// Each joint's markers: existing bodies, finite points, orthonormal axes; two bodies.
    fn validate_joints(&self, p: &mut Problems) {
        for (k, jt) in self.joints.iter().enumerate() {
            for (side, m) in [("i", &jt.i), ("j", &jt.j)] {
                let f = |s: &str| format!("joints[{k}].{side}.{s}");
                if let BodyId::Body(b) = m.body
                    && b >= self.bodies.len()
                {
                    p.push(f("body"), format!("body index {b} does not exist"));
                }
                finite_vector(p, f("point"), &m.point);
                for (name, d) in [("z", &m.z), ("x", &m.x)] {
                    if !d.iter().all(|x| x.is_finite()) || (d.norm() - 1.0).abs() > 1e-9 {
                        p.push(f(name), format!("must be a unit vector, got |{name}| = {}", d.norm()));
                    }
                }
                if m.z.dot(&m.x).abs() > 1e-9 {
                    p.push(f("x"), format!("must be orthogonal to z (x·z = {:e})", m.z.dot(&m.x)));
                }
            }
            if jt.i.body == jt.j.body {
                p.push(format!("joints[{k}].j.body"), "a joint connects two different bodies");
            }
        }
    }

    /// Joint `joint`, named at `field`, exists and turns about an axis (what `who` needs).
    fn check_rotating_joint(&self, p: &mut Problems, field: String, joint: usize, who: &str) {
        match self.joints.get(joint) {
            None => p.push(field, format!("joint index {joint} does not exist")),
            Some(j) if !j.kind.rotates_about_axis() => p.push(
                field,
                format!("joint {:?} is {:?}: {who} needs a revolute or cylindrical joint", j.name, j.kind),
            ),
            Some(_) => {}
        }
    }

    /// Load `k`: its body or joint exists, its numbers are finite (a motor's speed positive).
    fn validate_load(&self, p: &mut Problems, k: usize, l: &SpatialLoad) {
        let f = |s: &str| format!("loads[{k}].{s}");
        let body_exists = |p: &mut Problems, body: usize| {
            if body >= self.bodies.len() {
                p.push(f("body"), format!("body index {body} does not exist"));
            }
        };
        match l {
            SpatialLoad::Force { body, point, force } => {
                body_exists(p, *body);
                finite_vector(p, f("point"), point);
                finite_vector(p, f("force"), force);
            }
            SpatialLoad::Torque { body, torque } => {
                body_exists(p, *body);
                finite_vector(p, f("torque"), torque);
            }
            SpatialLoad::Motor { joint, stall_torque, no_load_speed } => {
                self.check_rotating_joint(p, f("joint"), *joint, "a motor");
                p.finite(f("stall_torque"), *stall_torque);
                p.positive(f("no_load_speed"), *no_load_speed);
            }
        }
    }
}

/// Each component of `v` finite (named `field.x`, `.y`, `.z`).
fn finite_vector(p: &mut Problems, field: String, v: &Vec3) {
    for (c, x) in ["x", "y", "z"].iter().zip(v.iter()) {
        p.finite(format!("{field}.{c}"), *x);
    }
}

/// Body `k`: positive mass, a rigid body's inertia tensor (finite, symmetric, positive definite,
/// principal moments obeying the triangle inequality), finite state.
fn validate_body(p: &mut Problems, k: usize, b: &SpatialBody) {
    let f = |s: &str| format!("bodies[{k}].{s}");
    p.positive(f("mass"), b.mass);
    let j = &b.inertia;
    if !j.iter().all(|x| x.is_finite()) {
        p.push(f("inertia"), "must be finite");
    } else if (j - j.transpose()).abs().max() > 1e-12 * j.abs().max() {
        p.push(f("inertia"), "must be symmetric");
    } else if j.cholesky().is_none() {
        p.push(f("inertia"), "must be positive definite");
    } else {
        // Principal moments of a rigid body obey the triangle inequality.
        let e = j.symmetric_eigenvalues();
        let (a, b2, c) = (e[0], e[1], e[2]);
        let slack = 1e-12 * (a + b2 + c);
        if a > b2 + c + slack || b2 > a + c + slack || c > a + b2 + slack {
            p.push(f("inertia"), format!("principal moments {e:?} break the triangle inequality of a rigid body"));
        }
    }
    finite_vector(p, f("position"), &b.position);
    finite_vector(p, f("velocity"), &b.velocity);
    finite_vector(p, f("angular_velocity"), &b.angular_velocity);
    if !b.orientation.coords.iter().all(|x| x.is_finite()) {
        p.push(f("orientation"), "must be finite");
    }
}
