//! Output channels: names and units, in CSV column order.

use crate::schema::Scenario;

/// One output channel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Channel {
    /// Name, e.g. `slider.ax`.
    pub name: String,
    /// SI unit, e.g. `m/s^2`.
    pub unit: &'static str,
}

/// What a channel measures (how the runner computes it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// Sensor k, quantity (0..6: x, y, vx, vy, ax, ay).
    Sensor(usize, u8),
    /// Clearance k, quantity (see CLEARANCE_QUANTITIES).
    Clearance(usize, u8),
    /// Driver k torque.
    DriverTorque(usize),
    /// Ideal joint k (of the cut or ideal mechanism) reaction on body1, component 0/1.
    JointReaction(usize, u8),
    /// max |Φ|.
    ConstraintError,
    /// Bushing k, quantity (see BUSHING_QUANTITIES).
    Bushing(usize, u8),
    /// Clearance k's largest von Mises stress at the pin–bush interface (a clearance with a bush).
    InterfaceStress(usize),
    /// Body k's pose, quantity (see [`POSE_QUANTITIES`]): what a report animates.
    BodyPose(usize, u8),
    /// Guide k (a translational clearance joint), quantity (see [`GUIDE_QUANTITIES`]).
    Guide(usize, u8),
}

/// The quantities of a guide's channels: the corners' resultant force on the block (x, y), the
/// block centre's offset from the guide's mid-line and its tilt, then each corner's normal force
/// and penetration (corners: rear top, front top, front bottom, rear bottom).
pub const GUIDE_QUANTITIES: [(&str, &str); 12] = [
    ("fx", "N"),
    ("fy", "N"),
    ("offset", "m"),
    ("tilt", "rad"),
    ("corner1.normal_force", "N"),
    ("corner2.normal_force", "N"),
    ("corner3.normal_force", "N"),
    ("corner4.normal_force", "N"),
    ("corner1.penetration", "m"),
    ("corner2.penetration", "m"),
    ("corner3.penetration", "m"),
    ("corner4.penetration", "m"),
];

/// The quantities of a body's pose channels: its centroid's position and its angle (the names
/// keep a body's pose apart from a sensor named like the body, whose channels are `x`, `y`, …).
pub const POSE_QUANTITIES: [(&str, &str); 3] = [("centroid_x", "m"), ("centroid_y", "m"), ("angle", "rad")];

/// The quantities of a bushing's channels: the force on the joint's body1 (x, y, magnitude) and
/// the deflection |d| of the two joint points.
pub const BUSHING_QUANTITIES: [(&str, &str); 4] = [("fx", "N"), ("fy", "N"), ("force", "N"), ("deflection", "m")];

const SENSOR_QUANTITIES: [(&str, &str); 6] =
    [("x", "m"), ("y", "m"), ("vx", "m/s"), ("vy", "m/s"), ("ax", "m/s^2"), ("ay", "m/s^2")];

/// The quantities of a clearance joint's channels: (suffix, unit), indexed by [`Source::Clearance`]'s
/// second field.
pub const CLEARANCE_QUANTITIES: [(&str, &str); 11] = [
    ("fx", "N"),
    ("fy", "N"),
    ("force", "N"),
    ("normal_force", "N"),
    ("friction_force", "N"),
    ("ex", "m"),
    ("ey", "m"),
    ("eccentricity", "m"),
    ("penetration", "m"),
    ("penetration_rate", "m/s"),
    ("slip_velocity", "m/s"),
];

/// `owner.quantity` (built without the formatting machinery: the channel list is made for every
/// run of a sweep).
pub(crate) fn dotted(owner: &str, quantity: &str) -> String {
    let mut name = String::with_capacity(owner.len() + 1 + quantity.len());
    name.push_str(owner);
    name.push('.');
    name.push_str(quantity);
    name
}

/// Channels of a scenario (time excluded), with what computes them.
pub fn channel_sources(s: &Scenario, ideal: bool) -> Vec<(Channel, Source)> {
    let mut out = Vec::new();
    for (k, sen) in s.sensors.iter().enumerate() {
        for (q, (name, unit)) in SENSOR_QUANTITIES.iter().enumerate() {
            out.push((Channel { name: dotted(&sen.name, name), unit }, Source::Sensor(k, q as u8)));
        }
    }
    if !ideal {
        for (k, c) in s.clearances.iter().enumerate() {
            for (q, (name, unit)) in CLEARANCE_QUANTITIES.iter().enumerate() {
                out.push((Channel { name: dotted(&c.joint, name), unit }, Source::Clearance(k, q as u8)));
            }
        }
        for (k, c) in s.clearances.iter().enumerate() {
            if c.bush.is_some() {
                out.push((Channel { name: dotted(&c.joint, "von_mises"), unit: "Pa" }, Source::InterfaceStress(k)));
            }
        }
        for (k, b) in s.bushings.iter().enumerate() {
            for (q, (name, unit)) in BUSHING_QUANTITIES.iter().enumerate() {
                out.push((Channel { name: dotted(&b.joint, name), unit }, Source::Bushing(k, q as u8)));
            }
        }
        for (k, g) in s.guides.iter().enumerate() {
            for (q, (name, unit)) in GUIDE_QUANTITIES.iter().enumerate() {
                out.push((Channel { name: dotted(&g.joint, name), unit }, Source::Guide(k, q as u8)));
            }
        }
    }
    for (k, d) in s.drivers.iter().enumerate() {
        out.push((Channel { name: dotted(&d.name, "torque"), unit: "N m" }, Source::DriverTorque(k)));
    }
    let mut k = 0;
    for j in &s.joints {
        if !ideal && s.is_cut(&j.name) {
            continue;
        }
        if j.kind == crate::schema::JointType::Revolute {
            out.push((Channel { name: dotted(&j.name, "fx"), unit: "N" }, Source::JointReaction(k, 0)));
            out.push((Channel { name: dotted(&j.name, "fy"), unit: "N" }, Source::JointReaction(k, 1)));
        } else {
            out.push((Channel { name: dotted(&j.name, "normal_force_x"), unit: "N" }, Source::JointReaction(k, 0)));
            out.push((Channel { name: dotted(&j.name, "normal_force_y"), unit: "N" }, Source::JointReaction(k, 1)));
        }
        k += 1;
    }
    out.push((Channel { name: "constraint_error".into(), unit: "m" }, Source::ConstraintError));
    for (k, b) in s.bodies.iter().enumerate() {
        for (q, (name, unit)) in POSE_QUANTITIES.iter().enumerate() {
            out.push((Channel { name: dotted(&b.name, name), unit }, Source::BodyPose(k, q as u8)));
        }
    }
    out
}

/// Indices into `sources` of the channels the scenario writes (`[output] channels`, or all).
pub fn selected_channels(s: &Scenario, sources: &[(Channel, Source)]) -> Vec<usize> {
    (0..sources.len())
        .filter(|&k| s.output.channels.is_empty() || s.output.channels.contains(&sources[k].0.name))
        .collect()
}

/// CSV header: `time [s]` then `name [unit]` of each selected channel.
pub fn header(sources: &[(Channel, Source)], selected: &[usize]) -> Vec<String> {
    std::iter::once("time [s]".to_string())
        .chain(selected.iter().map(|&k| format!("{} [{}]", sources[k].0.name, sources[k].0.unit)))
        .collect()
}

/// Names of all channels of a scenario (time excluded).
pub fn channel_names(s: &Scenario, ideal: bool) -> Vec<String> {
    channel_sources(s, ideal).into_iter().map(|(c, _)| c.name).collect()
}

/// All channels of a scenario (time excluded), in column order.
pub fn channels(s: &Scenario, ideal: bool) -> Vec<Channel> {
    channel_sources(s, ideal).into_iter().map(|(c, _)| c).collect()
}
