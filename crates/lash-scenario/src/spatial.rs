//! Spatial scenario files: the same conventions as planar ones (SI units, named bodies and
//! joints, every problem reported with its field path), with three-component vectors, inertia
//! tensors, unit-quaternion orientations and the spatial joint kinds. A file says
//! `space = "spatial"` at its top; everything else is like a planar file:
//!
//! ```toml
//! name = "pendulum"
//! space = "spatial"
//! gravity = [0.0, -9.81, 0.0]
//!
//! [[bodies]]
//! name = "rod"
//! mass = 0.4
//! inertia = [2e-5, 3e-3, 3e-3]          # principal moments along the body axes [kg m²]
//! position = [0.0, -0.15, 0.0]
//! orientation = [0.7071068, 0.0, 0.0, -0.7071068]   # unit quaternion (w, x, y, z)
//!
//! [[joints]]
//! name = "pivot"
//! type = "spherical"                    # spherical, revolute, universal, cylindrical, translational
//! body1 = "ground"
//! point1 = [0.0, 0.0, 0.0]
//! body2 = "rod"
//! point2 = [-0.15, 0.0, 0.0]
//! ```
//!
//! A joint's `axis1`/`axis2` (revolute, cylindrical, translational: the joint axis; universal:
//! each body's cross axis) and `reference1`/`reference2` (perpendicular to the axis: the zero of a
//! driver's angle, the rotation lock of a translational joint) are in body1's and body2's frames.
//! A driver names a revolute or cylindrical joint and prescribes the angle of reference2 about
//! axis1, measured from reference1.

use crate::load::element;
use crate::schema::{ClearanceSpec, OutputSpec, SimulationSpec};
use lash_contact::Material;
use lash_core::Problems;
use lash_mech::Motion;
use lash_spatial::SpatialJointKind;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashSet};

/// The marker of a spatial file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Space {
    /// Three-dimensional mechanism.
    Spatial,
}

/// A spatial scenario file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpatialScenario {
    /// Short name (used in outputs).
    pub name: String,
    /// Always `spatial`.
    pub space: Space,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// Gravity [m/s²].
    #[serde(default)]
    pub gravity: [f64; 3],
    /// Named materials.
    #[serde(default)]
    pub materials: BTreeMap<String, Material>,
    /// Moving bodies.
    pub bodies: Vec<SpatialBodySpec>,
    /// Ideal joints (a clearance turns one spherical joint into a spherical clearance joint).
    #[serde(default)]
    pub joints: Vec<SpatialJointSpec>,
    /// Rotational drivers.
    #[serde(default)]
    pub drivers: Vec<SpatialDriverSpec>,
    /// Applied loads.
    #[serde(default)]
    pub loads: Vec<SpatialLoadSpec>,
    /// Spherical clearance joints: `joint` names a spherical joint, `journal` the body with the ball.
    #[serde(default)]
    pub clearances: Vec<ClearanceSpec>,
    /// Body points whose position, velocity and acceleration are output.
    #[serde(default)]
    pub sensors: Vec<SpatialSensorSpec>,
    /// Time span, integrator, sampling.
    pub simulation: SimulationSpec,
    /// Output selection.
    #[serde(default)]
    pub output: OutputSpec,
}

fn identity() -> [f64; 4] {
    [1.0, 0.0, 0.0, 0.0]
}

/// A rigid body; points and directions elsewhere are given in its frame, from its centroid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpatialBodySpec {
    /// Unique name ("ground" is reserved).
    pub name: String,
    /// Mass \[kg\].
    pub mass: f64,
    /// Principal moments of inertia about the centroid along the body's x, y, z axes [kg m²].
    pub inertia: [f64; 3],
    /// Products of inertia (I_xy, I_xz, I_yz) of the centroidal tensor in the body frame [kg m²]
    /// (the tensor's off-diagonal entries are −I_xy, …; default 0).
    #[serde(default)]
    pub products: [f64; 3],
    /// Initial guess of the centroid position \[m\]; assembly makes it consistent.
    pub position: [f64; 3],
    /// Initial orientation as a unit quaternion (w, x, y, z) (normalised when read).
    #[serde(default = "identity")]
    pub orientation: [f64; 4],
    /// Initial guess of the centroid velocity [m/s]; velocity analysis makes it consistent.
    #[serde(default)]
    pub velocity: [f64; 3],
    /// Initial guess of the angular velocity in the body frame [rad/s].
    #[serde(default)]
    pub angular_velocity: [f64; 3],
}

/// An ideal joint between `body1` (marker I) and `body2` (marker J); either may be "ground".
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpatialJointSpec {
    /// Unique name.
    pub name: String,
    /// Kind.
    #[serde(rename = "type")]
    pub kind: SpatialJointKind,
    /// First body.
    pub body1: String,
    /// Joint point on body1 \[m\].
    pub point1: [f64; 3],
    /// Second body.
    pub body2: String,
    /// Joint point on body2 \[m\].
    pub point2: [f64; 3],
    /// Axis in body1's frame (all kinds but spherical).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis1: Option<[f64; 3]>,
    /// Axis in body2's frame (all kinds but spherical).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis2: Option<[f64; 3]>,
    /// Reference direction ⟂ axis1 in body1's frame (default: a perpendicular of axis1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference1: Option<[f64; 3]>,
    /// Reference direction ⟂ axis2 in body2's frame (default: reference1 carried into body2's
    /// frame through the initial poses, so that a driver's angle and a translational joint's
    /// rotation lock start at zero).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference2: Option<[f64; 3]>,
}

/// A rotational driver of a revolute or cylindrical joint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpatialDriverSpec {
    /// Unique name (the torque channel is `<name>.torque`).
    pub name: String,
    /// The driven joint.
    pub joint: String,
    /// Prescribed angle of reference2 about axis1, from reference1 \[rad\].
    pub motion: Motion,
}

/// An applied load.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum SpatialLoadSpec {
    /// Constant force in the world frame at a body point.
    Force {
        /// Loaded body.
        body: String,
        /// Point \[m\] (required: a point that defaulted to the body's origin would hide a
        /// forgotten field).
        point: [f64; 3],
        /// Force \[N\].
        force: [f64; 3],
    },
    /// Constant torque in the world frame.
    Torque {
        /// Loaded body.
        body: String,
        /// Torque [N m].
        torque: [f64; 3],
    },
    /// Motor in a revolute or cylindrical joint: T = stall_torque (1 − Ω / no_load_speed) about
    /// axis1, Ω the joint's relative angular velocity.
    Motor {
        /// The joint.
        joint: String,
        /// Torque at standstill [N m].
        stall_torque: f64,
        /// Speed at which the torque vanishes [rad/s] (> 0).
        no_load_speed: f64,
    },
}

/// A body point to observe.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpatialSensorSpec {
    /// Channel prefix.
    pub name: String,
    /// Body.
    pub body: String,
    /// Point on the body \[m\] (required).
    pub point: [f64; 3],
}

/// Top-level keys of a spatial file.
const TOP_KEYS: [&str; 13] = [
    "name",
    "space",
    "description",
    "gravity",
    "materials",
    "bodies",
    "joints",
    "drivers",
    "loads",
    "clearances",
    "sensors",
    "simulation",
    "output",
];

fn finite3(field: &str, v: [f64; 3]) -> Problems {
    let mut p = Problems::new();
    if !v.iter().all(|x| x.is_finite()) {
        p.push(field, format!("must be finite, got {v:?}"));
    }
    p
}

fn direction(p: &mut Problems, field: &str, v: Option<[f64; 3]>) {
    if let Some(v) = v
        && !(v.iter().all(|x| x.is_finite()) && v.iter().map(|x| x * x).sum::<f64>() > 0.0)
    {
        p.push(field, format!("must be a finite non-zero vector, got {v:?}"));
    }
}

fn validate_body(b: &SpatialBodySpec) -> Problems {
    let mut p = Problems::new();
    p.positive("mass", b.mass);
    for (k, m) in b.inertia.iter().enumerate() {
        p.positive(format!("inertia[{k}]"), *m);
    }
    p.0.extend(finite3("products", b.products).0);
    if p.is_empty() {
        let t = crate::spatial::inertia_tensor(b);
        if t.cholesky().is_none() {
            p.push("products", "the inertia tensor must be positive definite");
        } else {
            let e = t.symmetric_eigenvalues();
            let sum = e.sum();
            if (0..3).any(|k| e[k] > sum - e[k] + 1e-12 * sum) {
                p.push("inertia", format!("principal moments {e:?} break the triangle inequality of a rigid body"));
            }
        }
    }
    p.0.extend(finite3("position", b.position).0);
    p.0.extend(finite3("velocity", b.velocity).0);
    p.0.extend(finite3("angular_velocity", b.angular_velocity).0);
    let norm = b.orientation.iter().map(|x| x * x).sum::<f64>().sqrt();
    if !(norm.is_finite() && norm > 0.0) {
        p.push("orientation", format!("must be a non-zero quaternion (w, x, y, z), got {:?}", b.orientation));
    } else if (norm - 1.0).abs() > 1e-6 {
        p.push("orientation", format!("must be a unit quaternion (|q| = 1 within 1e-6), got |q| = {norm}"));
    }
    if b.name == "ground" || b.name.is_empty() {
        p.push("name", "must be non-empty and not the reserved \"ground\"");
    }
    p
}

fn validate_joint(j: &SpatialJointSpec) -> Problems {
    let mut p = Problems::new();
    p.0.extend(finite3("point1", j.point1).0);
    p.0.extend(finite3("point2", j.point2).0);
    let has_axis = j.kind != SpatialJointKind::Spherical;
    for (field, v) in [("axis1", j.axis1), ("axis2", j.axis2)] {
        match (has_axis, v) {
            (true, None) => p.push(field, format!("missing (required for a {:?} joint)", j.kind)),
            (false, Some(_)) => p.push(field, "a spherical joint has no axis"),
            _ => direction(&mut p, field, v),
        }
    }
    for (field, v) in [("reference1", j.reference1), ("reference2", j.reference2)] {
        if !has_axis && v.is_some() {
            p.push(field, "a spherical joint has no reference direction");
        }
        direction(&mut p, field, v);
    }
    let perpendicular = |a: Option<[f64; 3]>, r: Option<[f64; 3]>| match (a, r) {
        (Some(a), Some(r)) => {
            let (a, r) = (lash_spatial::Vec3::from(a), lash_spatial::Vec3::from(r));
            a.norm() > 0.0 && r.norm() > 0.0 && (a.dot(&r) / (a.norm() * r.norm())).abs() > 1e-9
        }
        _ => false,
    };
    if perpendicular(j.axis1, j.reference1) {
        p.push("reference1", "must be perpendicular to axis1");
    }
    if perpendicular(j.axis2, j.reference2) {
        p.push("reference2", "must be perpendicular to axis2");
    }
    if j.body1 == j.body2 {
        p.push("body2", "must differ from body1");
    }
    p
}

fn validate_load(l: &SpatialLoadSpec) -> Problems {
    let mut p = Problems::new();
    match l {
        SpatialLoadSpec::Force { point, force, .. } => {
            p.0.extend(finite3("point", *point).0);
            p.0.extend(finite3("force", *force).0);
        }
        SpatialLoadSpec::Torque { torque, .. } => p.0.extend(finite3("torque", *torque).0),
        SpatialLoadSpec::Motor { stall_torque, no_load_speed, .. } => {
            p.finite("stall_torque", *stall_torque);
            p.positive("no_load_speed", *no_load_speed);
        }
    }
    p
}

/// The centroidal inertia tensor of a body spec (body frame).
pub fn inertia_tensor(b: &SpatialBodySpec) -> lash_spatial::Mat3 {
    let ([ixx, iyy, izz], [ixy, ixz, iyz]) = (b.inertia, b.products);
    lash_spatial::Mat3::new(ixx, -ixy, -ixz, -ixy, iyy, -iyz, -ixz, -iyz, izz)
}

/// Parses and validates a spatial scenario from TOML text; on failure, every problem found.
pub fn parse_spatial(text: &str) -> Result<SpatialScenario, Problems> {
    parse_spatial_table(crate::load::toml_table(text)?)
}

/// [`parse_spatial`] of a parsed TOML table.
pub fn parse_spatial_table(table: toml::Table) -> Result<SpatialScenario, Problems> {
    crate::format::parse(table)
}

impl crate::format::Format for SpatialScenario {
    const TOP_KEYS: &'static [&'static str] = &TOP_KEYS;
    const REQUIRED: &'static [&'static str] = &["name", "space", "bodies", "simulation"];
    type Body = SpatialBodySpec;
    type Joint = SpatialJointSpec;
    type Driver = SpatialDriverSpec;
    type Load = SpatialLoadSpec;
    type Sensor = SpatialSensorSpec;
    type Gravity = [f64; 3];

    fn own_elements(table: &toml::Table, problems: &mut Problems) {
        element::<Space>(table, "space", problems);
    }
    crate::format::format_calls_of_the_module!();
    fn sensor(s: &SpatialSensorSpec) -> Problems {
        finite3("point", s.point)
    }
    fn gravity(g: &[f64; 3]) -> Problems {
        finite3("gravity", *g)
    }
}

/// Validates a spatial scenario built in code (the same checks as [`parse_spatial`]).
pub fn validate_spatial(s: &SpatialScenario) -> Problems {
    crate::format::validate(s)
}

/// Each spherical clearance on a spherical, undriven joint of the file, one per joint, with a
/// point-contact law and its materials.
fn check_spatial_clearances(s: &SpatialScenario, p: &mut Problems) {
    use crate::load::NeedsMaterials;
    let mut clearance_joints = HashSet::new();
    for (k, c) in s.clearances.iter().enumerate() {
        let f = |x: &str| format!("clearances[{k}].{x}");
        if c.bush.is_some() {
            p.push(f("bush"), "a flexible bush behind a spherical clearance is not there yet (planar joints only)");
        }
        if c.film.is_some() {
            p.push(
                f("film"),
                "an oil film in a spherical clearance joint is not there yet (planar revolute joints only)",
            );
        }
        match s.joints.iter().find(|j| j.name == c.joint) {
            None => p.push(f("joint"), format!("no joint called {:?}", c.joint)),
            Some(j) => {
                if j.kind != SpatialJointKind::Spherical {
                    p.push(
                        f("joint"),
                        format!(
                            "joint {:?} is {:?}; only spherical joints can have a spherical clearance",
                            c.joint, j.kind
                        ),
                    );
                }
                if c.journal != j.body1 && c.journal != j.body2 {
                    p.push(
                        f("journal"),
                        format!(
                            "must name one of joint {:?}'s bodies ({:?} or {:?}), got {:?}",
                            j.name, j.body1, j.body2, c.journal
                        ),
                    );
                }
                if s.drivers.iter().any(|d| d.joint == c.joint) {
                    p.push(f("joint"), "a driven joint cannot have clearance");
                }
            }
        }
        if !clearance_joints.insert(c.joint.as_str()) {
            p.push(f("joint"), format!("joint {:?} already has a clearance", c.joint));
        }
        if matches!(c.contact, lash_contact::ContactLaw::Liu { .. }) {
            p.push(
                f("contact.law"),
                "liu is a law of cylinders in line contact; a ball in a socket needs a point-contact law",
            );
        }
        let needs_materials = c.contact.needs_materials();
        for (field, m) in [("journal_material", &c.journal_material), ("bearing_material", &c.bearing_material)] {
            match m {
                Some(name) if !s.materials.contains_key(name) => {
                    p.push(f(field), format!("no material called {name:?} in [materials]"));
                }
                None if needs_materials => p.push(
                    f(field),
                    "missing: the contact law takes its stiffness from the materials (or give contact.stiffness)",
                ),
                _ => {}
            }
        }
    }
}

/// Names, references and counts across the file.
fn cross_check(s: &SpatialScenario) -> Problems {
    let mut p = Problems::new();
    let joints = s.joints.iter().map(|j| (j.name.as_str(), [j.body1.as_str(), j.body2.as_str()]));
    let bodies = crate::load::check_bodies_and_joints(&mut p, s.bodies.iter().map(|b| b.name.as_str()), joints);
    let rotating_joint =
        |p: &mut Problems, field: String, name: &str, what: &str| match s.joints.iter().find(|j| j.name == name) {
            None => p.push(field, format!("no joint called {name:?}")),
            Some(j) if !j.kind.rotates_about_axis() => {
                p.push(field, format!("joint {name:?} is {:?}: a {what} needs a revolute or cylindrical joint", j.kind))
            }
            Some(_) => {}
        };
    let mut driven = HashSet::new();
    for (k, d) in s.drivers.iter().enumerate() {
        rotating_joint(&mut p, format!("drivers[{k}].joint"), &d.joint, "driver");
        if !driven.insert(d.joint.as_str()) {
            p.push(format!("drivers[{k}].joint"), format!("joint {:?} already has a driver", d.joint));
        }
    }
    for (k, l) in s.loads.iter().enumerate() {
        match l {
            SpatialLoadSpec::Force { body, .. } | SpatialLoadSpec::Torque { body, .. } => {
                if !bodies.contains(body.as_str()) {
                    p.push(format!("loads[{k}].body"), format!("no moving body called {body:?}"));
                }
            }
            SpatialLoadSpec::Motor { joint, .. } => rotating_joint(&mut p, format!("loads[{k}].joint"), joint, "motor"),
        }
    }
    crate::load::check_sensors(&mut p, &bodies, s.sensors.iter().map(|sen| (sen.name.as_str(), sen.body.as_str())));
    check_spatial_clearances(s, &mut p);
    let velocities = 6 * s.bodies.len();
    // The full model's count: a joint with clearance is not a constraint there.
    let equations = s
        .joints
        .iter()
        .filter(|j| !s.clearances.iter().any(|c| c.joint == j.name))
        .map(|j| j.kind.equations())
        .sum::<usize>()
        + s.drivers.len();
    if equations > velocities {
        p.push(
            "joints",
            format!("{equations} constraint equations for {velocities} velocity coordinates: over-constrained"),
        );
    }
    let channels: Vec<(String, &str)> = spatial_channels(s, false).into_iter().map(|(c, _)| (c.name, c.unit)).collect();
    crate::load::check_output(&mut p, &s.output, &channels, s.simulation.output_interval);
    p
}

/// What a spatial channel measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpatialSource {
    /// Sensor k, quantity (0..9: x, y, z, vx, vy, vz, ax, ay, az).
    Sensor(usize, u8),
    /// Clearance k, quantity (see [`SPATIAL_CLEARANCE_QUANTITIES`]).
    Clearance(usize, u8),
    /// Driver k: its torque about the joint axis (on the driven body2).
    DriverTorque(usize),
    /// Ideal joint k (ideal or cut mechanism, in file order): reaction force on body1, component.
    JointReaction(usize, u8),
    /// Body k's angular velocity in its own frame, component.
    AngularVelocity(usize, u8),
    /// max |Φ|.
    ConstraintError,
    /// Body k's pose, quantity (see [`SPATIAL_POSE_QUANTITIES`]): what a report animates.
    BodyPose(usize, u8),
}

/// The quantities of a spatial body's pose channels: its centroid, then its orientation as a unit
/// quaternion with a non-negative scalar part.
pub const SPATIAL_POSE_QUANTITIES: [(&str, &str); 7] = [
    ("centroid_x", "m"),
    ("centroid_y", "m"),
    ("centroid_z", "m"),
    ("orientation_w", "1"),
    ("orientation_x", "1"),
    ("orientation_y", "1"),
    ("orientation_z", "1"),
];

const SENSOR_QUANTITIES: [(&str, &str); 9] = [
    ("x", "m"),
    ("y", "m"),
    ("z", "m"),
    ("vx", "m/s"),
    ("vy", "m/s"),
    ("vz", "m/s"),
    ("ax", "m/s^2"),
    ("ay", "m/s^2"),
    ("az", "m/s^2"),
];

/// Quantities of a spherical clearance joint's channels: (suffix, unit).
pub const SPATIAL_CLEARANCE_QUANTITIES: [(&str, &str); 13] = [
    ("fx", "N"),
    ("fy", "N"),
    ("fz", "N"),
    ("force", "N"),
    ("normal_force", "N"),
    ("friction_force", "N"),
    ("ex", "m"),
    ("ey", "m"),
    ("ez", "m"),
    ("eccentricity", "m"),
    ("penetration", "m"),
    ("penetration_rate", "m/s"),
    ("slip_velocity", "m/s"),
];

/// Channels of a spatial scenario (time excluded) with what computes them; `ideal`: clearance
/// joints are ideal spherical joints (their reactions instead of contact channels).
pub fn spatial_channels(s: &SpatialScenario, ideal: bool) -> Vec<(crate::Channel, SpatialSource)> {
    let mut out = Vec::new();
    let channel = |name: String, unit: &'static str| crate::Channel { name, unit };
    for (k, sen) in s.sensors.iter().enumerate() {
        for (q, (name, unit)) in SENSOR_QUANTITIES.iter().enumerate() {
            out.push((channel(crate::channels::dotted(&sen.name, name), unit), SpatialSource::Sensor(k, q as u8)));
        }
    }
    if !ideal {
        for (k, c) in s.clearances.iter().enumerate() {
            for (q, (name, unit)) in SPATIAL_CLEARANCE_QUANTITIES.iter().enumerate() {
                out.push((
                    channel(crate::channels::dotted(&c.joint, name), unit),
                    SpatialSource::Clearance(k, q as u8),
                ));
            }
        }
    }
    for (k, b) in s.bodies.iter().enumerate() {
        for (q, axis) in ["wx", "wy", "wz"].iter().enumerate() {
            out.push((
                channel(crate::channels::dotted(&b.name, axis), "rad/s"),
                SpatialSource::AngularVelocity(k, q as u8),
            ));
        }
    }
    for (k, d) in s.drivers.iter().enumerate() {
        out.push((channel(crate::channels::dotted(&d.name, "torque"), "N m"), SpatialSource::DriverTorque(k)));
    }
    let mut index = 0;
    for j in &s.joints {
        if !ideal && s.clearances.iter().any(|c| c.joint == j.name) {
            continue;
        }
        for (q, axis) in ["fx", "fy", "fz"].iter().enumerate() {
            out.push((
                channel(crate::channels::dotted(&j.name, axis), "N"),
                SpatialSource::JointReaction(index, q as u8),
            ));
        }
        index += 1;
    }
    out.push((channel("constraint_error".into(), "m"), SpatialSource::ConstraintError));
    for (k, b) in s.bodies.iter().enumerate() {
        for (q, (name, unit)) in SPATIAL_POSE_QUANTITIES.iter().enumerate() {
            out.push((channel(crate::channels::dotted(&b.name, name), unit), SpatialSource::BodyPose(k, q as u8)));
        }
    }
    out
}
