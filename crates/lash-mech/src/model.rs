//! The mechanism as data: bodies, joints, drivers, loads.

use crate::Vec2;
use lash_core::Problems;
use serde::{Deserialize, Serialize};

/// A body reference: the ground or a moving body by index.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum BodyId {
    /// The fixed ground frame.
    Ground,
    /// Moving body number `k` (`Mechanism::bodies[k]`).
    Body(usize),
}

/// A rigid planar body. Local points are given relative to its centroid, in its own frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Body {
    /// Name used in outputs and errors.
    pub name: String,
    /// Mass \[kg\].
    pub mass: f64,
    /// Moment of inertia about the centroid [kg m²].
    pub inertia: f64,
    /// Initial guess of the centroid position \[m\] (assembly corrects it).
    pub position: Vec2,
    /// Initial guess of the angle \[rad\].
    pub angle: f64,
    /// Initial guess of the centroid velocity [m/s] (velocity analysis corrects it).
    pub velocity: Vec2,
    /// Initial guess of the angular velocity [rad/s].
    pub angular_velocity: f64,
}

/// Kind of an ideal joint between body `i` and body `j`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum JointKind {
    /// Point `point_i` of body i coincides with point `point_j` of body j (2 equations).
    Revolute,
    /// Body i slides along the axis `axis_j` (unit, in j's frame) through `point_j`, at a fixed
    /// relative angle `angle_offset` = θ_i − θ_j (2 equations).
    Prismatic {
        /// Sliding direction in body j's frame (normalised on use).
        axis_j: Vec2,
        /// Fixed relative angle θ_i − θ_j \[rad\].
        angle_offset: f64,
    },
}

/// An ideal joint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Joint {
    /// Name used in outputs and errors.
    pub name: String,
    /// Kind and kind-specific data.
    pub kind: JointKind,
    /// First body.
    pub body_i: BodyId,
    /// Joint point on body i (local, from its centroid) \[m\].
    pub point_i: Vec2,
    /// Second body.
    pub body_j: BodyId,
    /// Joint point on body j (local, from its centroid) \[m\].
    pub point_j: Vec2,
}

impl Joint {
    /// Number of scalar constraint equations.
    pub fn equations(&self) -> usize {
        2
    }
}

/// Prescribed relative angle θ_i − θ_j = f(t).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Motion {
    /// f(t) = angle0 + ω t.
    ConstantSpeed {
        /// Angle at t = 0 \[rad\].
        #[serde(default)]
        angle0: f64,
        /// Angular speed ω [rad/s].
        omega: f64,
    },
    /// f(t) = Σ c_k t^k.
    Polynomial {
        /// Coefficients c_0, c_1, … [rad, rad/s, rad/s², …].
        coefficients: Vec<f64>,
    },
    /// f(t) = angle0 + ω t + A sin(Ω t + φ): a speed ripple on a constant speed.
    Harmonic {
        /// Angle at t = 0 of the mean motion \[rad\].
        #[serde(default)]
        angle0: f64,
        /// Mean angular speed ω [rad/s].
        omega: f64,
        /// Ripple amplitude A \[rad\].
        amplitude: f64,
        /// Ripple circular frequency Ω [rad/s].
        frequency: f64,
        /// Ripple phase φ \[rad\].
        #[serde(default)]
        phase: f64,
    },
}

impl Motion {
    /// (f, f', f'') at time t.
    pub fn eval(&self, t: f64) -> (f64, f64, f64) {
        match self {
            Motion::ConstantSpeed { angle0, omega } => (angle0 + omega * t, *omega, 0.0),
            Motion::Polynomial { coefficients } => (
                derivative_horner(coefficients, t, 0),
                derivative_horner(coefficients, t, 1),
                derivative_horner(coefficients, t, 2),
            ),
            Motion::Harmonic { angle0, omega, amplitude, frequency, phase } => {
                let (s, c) = (frequency * t + phase).sin_cos();
                (
                    angle0 + omega * t + amplitude * s,
                    omega + amplitude * frequency * c,
                    -amplitude * frequency * frequency * s,
                )
            }
        }
    }

    /// Problems of the motion's numbers.
    pub fn validate(&self) -> Problems {
        let mut p = Problems::new();
        match self {
            Motion::ConstantSpeed { angle0, omega } => {
                p.finite("angle0", *angle0);
                p.finite("omega", *omega);
            }
            Motion::Polynomial { coefficients } => {
                if coefficients.is_empty() {
                    p.push("coefficients", "needs at least one coefficient");
                }
                for (k, c) in coefficients.iter().enumerate() {
                    p.finite(format!("coefficients[{k}]"), *c);
                }
            }
            Motion::Harmonic { angle0, omega, amplitude, frequency, phase } => {
                p.finite("angle0", *angle0);
                p.finite("omega", *omega);
                p.finite("amplitude", *amplitude);
                p.non_negative("frequency", *frequency);
                p.finite("phase", *phase);
            }
        }
        p
    }
}

/// d-th derivative of the polynomial Σ c_k t^k at t.
fn derivative_horner(c: &[f64], t: f64, d: usize) -> f64 {
    let mut acc = 0.0;
    for k in (d..c.len()).rev() {
        let factor: usize = ((k - d + 1)..=k).product();
        acc = acc * t + factor as f64 * c[k];
    }
    acc
}

/// A rotational driver: θ_body − θ_reference = motion(t).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Driver {
    /// Name used in outputs and errors.
    pub name: String,
    /// Driven body.
    pub body: BodyId,
    /// Reference body (usually the ground).
    pub reference: BodyId,
    /// Prescribed relative angle.
    pub motion: Motion,
}

/// An applied load.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Load {
    /// A constant force (world frame) at a body point.
    Force {
        /// Loaded body.
        body: usize,
        /// Point of application (local, from the centroid) \[m\].
        point: Vec2,
        /// Force in the world frame \[N\].
        force: Vec2,
    },
    /// A constant torque about +z [N m].
    Torque {
        /// Loaded body.
        body: usize,
        /// Torque [N m].
        torque: f64,
    },
    /// A motor with a linear torque–speed characteristic about +z (a DC motor):
    /// T = stall_torque · (1 − ω / no_load_speed), ω the body's absolute angular velocity.
    Motor {
        /// Driven body.
        body: usize,
        /// Torque at standstill [N m].
        stall_torque: f64,
        /// Speed at which the torque vanishes [rad/s] (> 0).
        no_load_speed: f64,
    },
    /// A bushing: an isotropic spring–damper joining a point of body i to a point of body j (a
    /// revolute joint made flexible). The force on i is −F(|d|) d/|d| − c ḋ with d = p_i − p_j the
    /// separation of the two points, F(u) = k u (linear) or the radial `curve`; j takes the
    /// opposite force at its point.
    Bushing {
        /// Body carrying the first point (the journal's).
        body_i: BodyId,
        /// Its point (local) \[m\].
        point_i: Vec2,
        /// Body carrying the second point (the bore's).
        body_j: BodyId,
        /// Its point (local) \[m\].
        point_j: Vec2,
        /// Radial stiffness k [N/m].
        stiffness: f64,
        /// Radial damping c [N s/m].
        damping: f64,
        /// The radial force as a curve of the deflection (`stiffness` then is its secant at the
        /// first point); None: linear.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        curve: Option<RadialCurve>,
    },
}

/// A bushing's radial force as a function of its deflection, through points (u_i, F_i) that both
/// increase from the origin: a power law between neighbouring points (linear in ln u and ln F, the
/// shape of a contact whose width grows with its load), the secant F₀/u₀ below the first point and
/// the last segment's power law beyond the last.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RadialCurve {
    /// Deflections u_i \[m\], increasing, > 0.
    pub deflections: Vec<f64>,
    /// Forces F_i \[N\], increasing, > 0.
    pub forces: Vec<f64>,
}

impl RadialCurve {
    /// The segment (its first point k and exponent p) that holds deflection `u` ≥ u₀ (force
    /// `f` ≥ F₀ when `by_force`).
    fn segment(&self, value: f64, by_force: bool) -> (usize, f64) {
        let (x, y) = (&self.deflections, &self.forces);
        let n = x.len();
        if n < 2 {
            return (0, 1.0);
        }
        let axis = if by_force { y } else { x };
        let k = axis.partition_point(|v| *v <= value).clamp(1, n - 1) - 1;
        (k, (y[k + 1] / y[k]).ln() / (x[k + 1] / x[k]).ln())
    }

    /// F(u) \[N\] at deflection `u` ≥ 0 \[m\].
    pub fn force(&self, u: f64) -> f64 {
        let (x, y) = (&self.deflections, &self.forces);
        if u <= x[0] {
            return y[0] * (u / x[0]);
        }
        let (k, p) = self.segment(u, false);
        y[k] * (u / x[k]).powf(p)
    }

    /// The deflection u \[m\] at which the force is `force` ≥ 0 \[N\] (the inverse of [`RadialCurve::force`]).
    pub fn deflection(&self, force: f64) -> f64 {
        let (x, y) = (&self.deflections, &self.forces);
        if force <= y[0] {
            return x[0] * (force / y[0]);
        }
        let (k, p) = self.segment(force, true);
        x[k] * (force / y[k]).powf(1.0 / p)
    }

    /// Problems of the points, under `field`.
    pub fn check(&self, field: &str) -> Problems {
        let mut p = Problems::new();
        let (x, y) = (&self.deflections, &self.forces);
        if x.is_empty() || x.len() != y.len() {
            p.push(
                field,
                format!("needs as many deflections as forces, at least one (got {} and {})", x.len(), y.len()),
            );
            return p;
        }
        for (name, v) in [("deflections", x), ("forces", y)] {
            if !v.iter().all(|a| *a > 0.0 && a.is_finite()) || !v.windows(2).all(|w| w[1] > w[0]) {
                p.push(format!("{field}.{name}"), format!("must be positive, finite and increasing, got {v:?}"));
            }
        }
        p
    }
}

/// The state of a bushing: separation d = p_i − p_j, its rate, and the force on body i.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BushingState {
    /// Separation of the two points \[m\].
    pub deflection: Vec2,
    /// Its rate [m/s].
    pub deflection_rate: Vec2,
    /// Force on body i (−k d − c ḋ) \[N\].
    pub force: Vec2,
}

/// A bushing's state from the two bodies' poses (`pose_i`, `pose_j`): linear with `stiffness`, or
/// along `curve`.
pub fn bushing_state(
    pose_i: &crate::Pose,
    point_i: Vec2,
    pose_j: &crate::Pose,
    point_j: Vec2,
    (stiffness, curve): (f64, Option<&RadialCurve>),
    damping: f64,
) -> (BushingState, Vec2, Vec2) {
    let (ai, aj) = (pose_i.rotate(point_i), pose_j.rotate(point_j));
    let deflection = pose_i.position + ai - pose_j.position - aj;
    let velocity = |p: &crate::Pose, a: Vec2| p.velocity + Vec2::new(-a.y, a.x) * p.angular_velocity;
    let deflection_rate = velocity(pose_i, ai) - velocity(pose_j, aj);
    let spring = match curve {
        None => deflection * stiffness,
        Some(c) => {
            let u = deflection.norm();
            if u > 0.0 { deflection * (c.force(u) / u) } else { Vec2::zeros() }
        }
    };
    let force = -(spring + deflection_rate * damping);
    (BushingState { deflection, deflection_rate, force }, ai, aj)
}

/// Baumgarte constraint stabilisation: Φ̈ + 2α Φ̇ + β² Φ = 0.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Baumgarte {
    /// Velocity-error gain α [1/s].
    pub alpha: f64,
    /// Position-error gain β [1/s].
    pub beta: f64,
}

impl Default for Baumgarte {
    fn default() -> Self {
        // Critically damped drift correction with a time constant of ~1 ms: far slower than the
        // smallest adaptive steps, fast against drift growth over a crank turn.
        Self { alpha: 1.0e3, beta: 1.0e3 }
    }
}

/// A planar mechanism.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Mechanism {
    /// Moving bodies.
    pub bodies: Vec<Body>,
    /// Ideal joints.
    pub joints: Vec<Joint>,
    /// Rotational drivers.
    pub drivers: Vec<Driver>,
    /// Applied loads.
    pub loads: Vec<Load>,
    /// Gravity acceleration [m/s²].
    pub gravity: Vec2,
    /// Constraint stabilisation gains.
    pub baumgarte: Baumgarte,
}

impl Mechanism {
    /// Number of coordinates (3 per moving body).
    pub fn coordinate_count(&self) -> usize {
        3 * self.bodies.len()
    }

    /// Number of scalar constraint equations (joints, then drivers).
    pub fn constraint_count(&self) -> usize {
        self.joints.iter().map(Joint::equations).sum::<usize>() + self.drivers.len()
    }

    /// Index of the first equation of joint `k` among all constraint rows.
    pub fn joint_row(&self, k: usize) -> usize {
        self.joints[..k].iter().map(Joint::equations).sum()
    }

    /// Row of driver `k`.
    pub fn driver_row(&self, k: usize) -> usize {
        self.joints.iter().map(Joint::equations).sum::<usize>() + k
    }

    /// Index of the body called `name`, or the ground for `"ground"`.
    pub fn body_id(&self, name: &str) -> Option<BodyId> {
        if name == "ground" {
            return Some(BodyId::Ground);
        }
        self.bodies.iter().position(|b| b.name == name).map(BodyId::Body)
    }

    /// Every problem of the mechanism's data, with field paths.
    pub fn validate(&self) -> Problems {
        let mut p = Problems::new();
        if self.bodies.is_empty() {
            p.push("bodies", "a mechanism needs at least one moving body");
        }
        for (k, b) in self.bodies.iter().enumerate() {
            let f = |s: &str| format!("bodies[{k}].{s}");
            p.positive(f("mass"), b.mass);
            p.positive(f("inertia"), b.inertia);
            p.finite(f("position.x"), b.position.x);
            p.finite(f("position.y"), b.position.y);
            p.finite(f("angle"), b.angle);
            p.finite(f("velocity.x"), b.velocity.x);
            p.finite(f("velocity.y"), b.velocity.y);
            p.finite(f("angular_velocity"), b.angular_velocity);
            if self.bodies[..k].iter().any(|o| o.name == b.name) || b.name == "ground" {
                p.push(f("name"), format!("name {:?} is used twice (or is the reserved \"ground\")", b.name));
            }
        }
        self.validate_joints_and_drivers(&mut p);
        for (k, l) in self.loads.iter().enumerate() {
            self.validate_load(&mut p, k, l);
        }
        p.finite("gravity.x", self.gravity.x);
        p.finite("gravity.y", self.gravity.y);
        p.non_negative("baumgarte.alpha", self.baumgarte.alpha);
        p.non_negative("baumgarte.beta", self.baumgarte.beta);
        let (n, m) = (self.coordinate_count(), self.constraint_count());
        if m > n {
            p.push(
                "joints",
                format!("{m} constraint equations for {n} coordinates: the mechanism is over-constrained"),
            );
        }
        p
    }

    /// A problem at `field` where body `id` does not exist.
    fn check_body(&self, p: &mut Problems, field: String, id: BodyId) {
        if let BodyId::Body(k) = id
            && k >= self.bodies.len()
        {
            p.push(field, format!("body index {k} does not exist"));
        }
    }

    /// Joints: existing, different bodies, finite points, a prismatic joint's axis; drivers:
    /// existing, different bodies and a valid motion.
    fn validate_joints_and_drivers(&self, p: &mut Problems) {
        for (k, j) in self.joints.iter().enumerate() {
            let f = |s: &str| format!("joints[{k}].{s}");
            self.check_body(p, f("body1"), j.body_i);
            self.check_body(p, f("body2"), j.body_j);
            if j.body_i == j.body_j {
                p.push(f("body2"), "a joint needs two different bodies");
            }
            for (name, v) in [("point1", j.point_i), ("point2", j.point_j)] {
                p.finite(format!("joints[{k}].{name}.x"), v.x);
                p.finite(format!("joints[{k}].{name}.y"), v.y);
            }
            if let JointKind::Prismatic { axis_j, angle_offset } = &j.kind {
                if !(axis_j.norm() > 0.0 && axis_j.norm().is_finite()) {
                    p.push(f("axis"), "must be a finite non-zero vector");
                }
                p.finite(f("angle_offset"), *angle_offset);
            }
        }
        for (k, d) in self.drivers.iter().enumerate() {
            self.check_body(p, format!("drivers[{k}].body"), d.body);
            self.check_body(p, format!("drivers[{k}].reference"), d.reference);
            if d.body == d.reference {
                p.push(format!("drivers[{k}].reference"), "must differ from the driven body");
            }
            p.extend_prefixed(&format!("drivers[{k}].motion"), d.motion.validate());
        }
    }

    /// Load `k`: existing bodies, finite numbers, a motor's speed and a bushing's stiffness
    /// positive, a bushing's curve valid.
    fn validate_load(&self, p: &mut Problems, k: usize, l: &Load) {
        let f = |s: &str| format!("loads[{k}].{s}");
        match l {
            Load::Force { body, point, force } => {
                self.check_body(p, f("body"), BodyId::Body(*body));
                for (n, v) in [("point", point), ("force", force)] {
                    p.finite(format!("loads[{k}].{n}.x"), v.x);
                    p.finite(format!("loads[{k}].{n}.y"), v.y);
                }
            }
            Load::Torque { body, torque } => {
                self.check_body(p, f("body"), BodyId::Body(*body));
                p.finite(f("torque"), *torque);
            }
            Load::Motor { body, stall_torque, no_load_speed } => {
                self.check_body(p, f("body"), BodyId::Body(*body));
                p.finite(f("stall_torque"), *stall_torque);
                p.positive(f("no_load_speed"), *no_load_speed);
            }
            Load::Bushing { body_i, body_j, stiffness, damping, curve, .. } => {
                self.check_body(p, f("body_i"), *body_i);
                self.check_body(p, f("body_j"), *body_j);
                if body_i == body_j {
                    p.push(f("body_j"), "must differ from body_i");
                }
                p.positive(f("stiffness"), *stiffness);
                p.non_negative(f("damping"), *damping);
                if let Some(c) = curve {
                    p.0.extend(c.check(&f("curve")).0);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::RadialCurve;

    #[test]
    fn a_radial_curve_passes_through_its_points_and_inverts() {
        let c = RadialCurve { deflections: vec![1e-6, 3e-6, 8e-6], forces: vec![5.0, 19.62, 80.0] };
        for (u, f) in c.deflections.iter().zip(&c.forces) {
            assert!((c.force(*u) / f - 1.0).abs() < 1e-14, "F({u}) = {} ≠ {f}", c.force(*u));
            assert!((c.deflection(*f) / u - 1.0).abs() < 1e-14);
        }
        // Linear through the origin below the first point, a power law between points and beyond.
        assert_eq!(c.force(0.0), 0.0);
        assert!((c.force(0.5e-6) - 2.5).abs() < 1e-14);
        let p = (80.0f64 / 19.62).ln() / (8.0f64 / 3.0).ln();
        for u in [4e-6, 7.9e-6, 2e-5] {
            let expected = 19.62 * (u / 3e-6f64).powf(p);
            assert!((c.force(u) / expected - 1.0).abs() < 1e-13, "F({u})");
            assert!((c.deflection(expected) / u - 1.0).abs() < 1e-13, "u({expected})");
        }
        // Increasing everywhere (checked on a fine grid across the points).
        let mut last = 0.0;
        for i in 1..2000 {
            let f = c.force(i as f64 * 1e-8);
            assert!(f > last, "not increasing at {} m", i as f64 * 1e-8);
            last = f;
        }
        assert!(c.check("curve").is_empty());
        let bad = RadialCurve { deflections: vec![1e-6, 1e-6], forces: vec![1.0] };
        assert!(!bad.check("curve").is_empty());
    }
}
