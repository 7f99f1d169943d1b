//! The scenario file format (TOML). Units are SI throughout: m, kg, kg m², s, rad, N, Pa.

use lash_contact::{ContactLaw, FrictionLaw, Material};
use lash_mech::{Baumgarte, Motion};
use lash_ode::Method;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A whole scenario file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Short name (used in outputs).
    pub name: String,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// Gravity [m/s²].
    #[serde(default)]
    pub gravity: [f64; 2],
    /// Named materials.
    #[serde(default)]
    pub materials: BTreeMap<String, Material>,
    /// Moving bodies.
    pub bodies: Vec<BodySpec>,
    /// Ideal joints (a clearance turns one revolute joint into a clearance joint).
    #[serde(default)]
    pub joints: Vec<JointSpec>,
    /// Rotational drivers.
    #[serde(default)]
    pub drivers: Vec<DriverSpec>,
    /// Applied loads.
    #[serde(default)]
    pub loads: Vec<LoadSpec>,
    /// Clearance joints.
    #[serde(default)]
    pub clearances: Vec<ClearanceSpec>,
    /// Revolute joints made flexible by a bush (no clearance).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub bushings: Vec<BushingSpec>,
    /// Prismatic joints with clearance (a block in a guide).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub guides: Vec<GuideSpec>,
    /// Body points whose position, velocity and acceleration are output.
    #[serde(default)]
    pub sensors: Vec<SensorSpec>,
    /// Time span, integrator, sampling.
    pub simulation: SimulationSpec,
    /// Output selection.
    #[serde(default)]
    pub output: OutputSpec,
}

impl Scenario {
    /// Whether the joint called `joint` leaves the full model's mechanism: a clearance, a bushing
    /// or a guide replaces it.
    pub fn is_cut(&self, joint: &str) -> bool {
        self.clearances.iter().any(|c| c.joint == joint)
            || self.bushings.iter().any(|b| b.joint == joint)
            || self.guides.iter().any(|g| g.joint == joint)
    }
}

/// A rigid body. Points elsewhere in the file are given from its centroid, in its frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// Unique name ("ground" is reserved).
    pub name: String,
    /// Mass \[kg\].
    pub mass: f64,
    /// Moment of inertia about the centroid [kg m²].
    pub inertia: f64,
    /// Initial guess of the centroid position \[m\]; assembly makes it consistent.
    pub position: [f64; 2],
    /// Initial guess of the angle \[rad\].
    #[serde(default)]
    pub angle: f64,
    /// Initial guess of the centroid velocity [m/s]; velocity analysis makes it consistent.
    #[serde(default)]
    pub velocity: [f64; 2],
    /// Initial guess of the angular velocity [rad/s].
    #[serde(default)]
    pub angular_velocity: f64,
}

/// Joint kinds of the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JointType {
    /// Pin joint.
    Revolute,
    /// Slider joint.
    Prismatic,
}

/// An ideal joint between `body1` and `body2` (either may be "ground").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointSpec {
    /// Unique name.
    pub name: String,
    /// Kind.
    #[serde(rename = "type")]
    pub kind: JointType,
    /// First body.
    pub body1: String,
    /// Joint point on body1 \[m\] (required: a joint placed at the body's origin by default would
    /// hide a forgotten field).
    pub point1: [f64; 2],
    /// Second body.
    pub body2: String,
    /// Joint point on body2 \[m\] (required).
    pub point2: [f64; 2],
    /// Prismatic only: sliding axis in body2's frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f64; 2]>,
    /// Prismatic only: fixed angle θ1 − θ2 \[rad\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub angle_offset: Option<f64>,
}

/// A rotational driver.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriverSpec {
    /// Unique name (the torque channel is `<name>.torque`).
    pub name: String,
    /// Driven body.
    pub body: String,
    /// Reference body.
    #[serde(default = "ground")]
    pub reference: String,
    /// Prescribed angle θ_body − θ_reference.
    pub motion: Motion,
}

fn ground() -> String {
    "ground".into()
}

/// An applied load.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum LoadSpec {
    /// Constant force in the world frame at a body point.
    Force {
        /// Loaded body.
        body: String,
        /// Point \[m\] (required: a point that defaulted to the body's origin would hide a
        /// forgotten field).
        point: [f64; 2],
        /// Force \[N\].
        force: [f64; 2],
    },
    /// Constant torque about +z.
    Torque {
        /// Loaded body.
        body: String,
        /// Torque [N m].
        torque: f64,
    },
    /// Motor with a linear torque–speed line (DC motor) about +z:
    /// T = stall_torque (1 − ω / no_load_speed).
    Motor {
        /// Driven body.
        body: String,
        /// Torque at standstill [N m].
        stall_torque: f64,
        /// Speed at which the torque vanishes [rad/s] (> 0).
        no_load_speed: f64,
    },
}

/// Turns the revolute joint `joint` into a clearance joint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClearanceSpec {
    /// Name of a revolute joint in `joints`.
    pub joint: String,
    /// Which of that joint's bodies carries the journal (pin); the other has the bearing (hole).
    pub journal: String,
    /// Journal radius R_J \[m\].
    pub journal_radius: f64,
    /// Bearing radius R_B \[m\] (> R_J).
    pub bearing_radius: f64,
    /// Journal material (name in `materials`), used for Hertz stiffness.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub journal_material: Option<String>,
    /// Bearing material (name in `materials`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bearing_material: Option<String>,
    /// Normal contact law.
    pub contact: ContactLaw,
    /// Friction law (required: write `friction = { law = "none" }` for a frictionless joint, so
    /// that a forgotten block is an error and not a frictionless joint).
    pub friction: FrictionLaw,
    /// A flexible bush whose bore is the bearing (flexible-imperfect joint): its structural
    /// (bonded-pin) stiffness by finite elements acts in series with the contact law. Its
    /// `inner_radius` must be `bearing_radius` and its `pin_radius` `journal_radius`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bush: Option<lash_bush::BushSpec>,
    /// An oil film (a lubricated joint): the hydrodynamic force of the short or long bearing
    /// acts in every mode, the contact law adds to it where the journal touches.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub film: Option<lash_contact::Film>,
}

/// Turns the prismatic joint `joint` into a translational clearance joint: a rectangular block on
/// the `slider` body, centred on that body's joint point with its long side along the joint's
/// axis, moving between two guide faces on the other body, `clearance` off each long side.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GuideSpec {
    /// Name of a prismatic joint in `joints`.
    pub joint: String,
    /// Which of that joint's bodies carries the block; the other carries the guide.
    pub slider: String,
    /// The block's length along the guide \[m\].
    pub length: f64,
    /// The block's height across the guide \[m\].
    pub height: f64,
    /// Clearance c between each long face of the block and the guide face opposite \[m\] (> 0).
    pub clearance: f64,
    /// Normal contact law of a corner on a face (its `stiffness` is required: a corner on a flat
    /// face has no radii to take a Hertz stiffness from).
    pub contact: ContactLaw,
    /// Friction law along the guide (required, as for a clearance joint).
    pub friction: FrictionLaw,
}

/// Makes the revolute joint `joint` flexible: its two points are joined by an isotropic
/// spring–damper (a bush pressed in one body around a pin of the other, without clearance) instead
/// of the ideal constraint. The stiffness and damping are given, or computed from the bush by
/// finite elements (the bonded-pin case of `lash bush`); or the radial force follows a given
/// curve of the deflection (a measured characteristic, say), with a given damping.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BushingSpec {
    /// Name of a revolute joint in `joints`.
    pub joint: String,
    /// Radial stiffness [N/m] (instead of `bush`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiffness: Option<f64>,
    /// Radial damping [N s/m] (with `stiffness`; 0 unless given).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub damping: Option<f64>,
    /// The bush, characterised by finite elements (instead of `stiffness`): its bore must fit the
    /// pin (inner_radius = pin_radius).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bush: Option<lash_bush::BushSpec>,
    /// The radial force as a curve of the deflection (instead of `stiffness` and `bush`): points
    /// `deflections` \[m\] and `forces` \[N\], both increasing from the origin, joined by power laws.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub curve: Option<lash_mech::RadialCurve>,
}

/// Why a bushing has no stiffness.
#[derive(Debug, thiserror::Error)]
pub enum BushingError {
    /// Neither a stiffness nor a bush is given.
    #[error("bushing {joint:?}: give stiffness or bush")]
    Unspecified {
        /// The bushing's joint.
        joint: String,
    },
    /// The bush's finite-element solution failed.
    #[error("bushing {joint:?}: {problem}")]
    Solve {
        /// The bushing's joint.
        joint: String,
        /// The solver's error.
        problem: lash_bush::SolveError,
    },
}

impl BushingSpec {
    /// (stiffness [N/m], damping [N s/m]): as given, or the bush's bonded-pin values by finite
    /// elements (computed once per bush in a process).
    pub fn stiffness_damping(&self) -> Result<(f64, f64), BushingError> {
        if let Some(c) = &self.curve {
            // The secant at the first point stands for the stiffness (its small-deflection value).
            let secant = c.forces.first().zip(c.deflections.first()).map_or(f64::NAN, |(f, u)| f / u);
            return Ok((secant, self.damping.unwrap_or(0.0)));
        }
        match (&self.bush, self.stiffness) {
            (Some(bush), _) => {
                let b = lash_bush::bonded_pin(bush)
                    .map_err(|problem| BushingError::Solve { joint: self.joint.clone(), problem })?;
                Ok((b.stiffness, b.damping))
            }
            (None, Some(k)) => Ok((k, self.damping.unwrap_or(0.0))),
            (None, None) => Err(BushingError::Unspecified { joint: self.joint.clone() }),
        }
    }
}

/// A body point to observe.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorSpec {
    /// Channel prefix.
    pub name: String,
    /// Body.
    pub body: String,
    /// Point on the body \[m\] (required).
    pub point: [f64; 2],
}

/// Time span and integrator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimulationSpec {
    /// Start time \[s\].
    #[serde(default)]
    pub start_time: f64,
    /// Length of the run \[s\].
    pub horizon: f64,
    /// Output sampling interval \[s\].
    pub output_interval: f64,
    /// Integration method.
    pub integrator: Method,
    /// Constraint stabilisation (default α = β = 1000 1/s).
    #[serde(default)]
    pub baumgarte: Baumgarte,
}

/// Output selection.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Channels to write (by name, e.g. "slider.ax"); empty writes all.
    #[serde(default)]
    pub channels: Vec<String>,
    /// Emulated vibration measurements computed from the run.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub measurements: Vec<MeasurementSpec>,
}

/// An emulated vibration measurement: a housing on a compliant mount driven by force channels
/// (one per axis, e.g. a guide's reaction on the ground), logged by a data logger.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasurementSpec {
    /// Name: the logged channels are `<name>.ax`, `<name>.ay` (and `<name>.az`).
    pub name: String,
    /// The force channel driving each axis \[N\] (one to three).
    pub forces: Vec<String>,
    /// The housing and its mount.
    pub mount: lash_measure::Mount,
    /// The logger.
    pub acquisition: lash_measure::Acquisition,
}

impl MeasurementSpec {
    /// The logged channel names, one per force.
    pub fn channel_names(&self) -> Vec<String> {
        ["ax", "ay", "az"].iter().take(self.forces.len()).map(|a| format!("{}.{a}", self.name)).collect()
    }
}
