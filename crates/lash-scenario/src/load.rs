//! Reading a scenario file: every problem of the file at once, each with its field path.

use crate::schema::*;
use lash_core::Problems;
use serde::de::DeserializeOwned;
use std::collections::HashSet;

/// Top-level keys of a scenario file.
const TOP_KEYS: [&str; 14] = [
    "name",
    "description",
    "gravity",
    "materials",
    "bodies",
    "joints",
    "drivers",
    "loads",
    "clearances",
    "bushings",
    "guides",
    "sensors",
    "simulation",
    "output",
];

/// Why a scenario argument could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file cannot be read.
    #[error("cannot read {}: {source}", .path.display())]
    Read {
        /// The file.
        path: std::path::PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The file reads but is not a valid scenario: every problem with its field path.
    #[error("invalid scenario {}: {source}", .path.display())]
    Invalid {
        /// The file.
        path: std::path::PathBuf,
        /// The problems.
        source: Problems,
    },
    /// A spatial scenario where a planar one is needed.
    #[error("scenario {0} is spatial: this command takes planar scenarios only so far")]
    Spatial(String),
    /// Neither a file nor a built-in scenario.
    #[error("scenario {name:?} is neither a file nor a built-in scenario (built-ins: {built_ins})")]
    Unknown {
        /// The argument.
        name: String,
        /// The built-in names, comma-separated.
        built_ins: String,
    },
}

/// Reads and parses a scenario file; the message names the file and lists every problem.
pub fn read_file(path: &std::path::Path) -> Result<Scenario, LoadError> {
    match read_any(path)? {
        AnyScenario::Planar(s) => Ok(s),
        AnyScenario::Spatial(_) => Err(LoadError::Spatial(path.display().to_string())),
    }
}

/// A built-in scenario by name (`A`, `C`, …), or else a scenario file: the one way every command,
/// system file and FMU resolves a scenario argument.
pub fn by_name_or_file(arg: &str) -> Result<Scenario, LoadError> {
    if let Some(s) = crate::builtin::by_name(arg) {
        return Ok(s);
    }
    if crate::builtin_spatial::spatial_by_name(arg).is_some() {
        return Err(LoadError::Spatial(format!("{arg:?}")));
    }
    let path = std::path::Path::new(arg);
    if !path.exists() {
        return Err(LoadError::Unknown { name: arg.to_string(), built_ins: crate::builtin::NAMES.join(", ") });
    }
    read_file(path)
}

/// A planar or a spatial scenario (written as its own file format).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(untagged)]
pub enum AnyScenario {
    /// A planar mechanism (the default of a file).
    Planar(Scenario),
    /// A spatial mechanism (`space = "spatial"`).
    Spatial(crate::spatial::SpatialScenario),
}

impl AnyScenario {
    /// The scenario's name.
    pub fn name(&self) -> &str {
        match self {
            AnyScenario::Planar(s) => &s.name,
            AnyScenario::Spatial(s) => &s.name,
        }
    }

    /// Its time span, integrator and sampling.
    pub fn simulation(&self) -> &SimulationSpec {
        match self {
            AnyScenario::Planar(s) => &s.simulation,
            AnyScenario::Spatial(s) => &s.simulation,
        }
    }

    /// Its clearance joints.
    pub fn clearances(&self) -> &[crate::schema::ClearanceSpec] {
        match self {
            AnyScenario::Planar(s) => &s.clearances,
            AnyScenario::Spatial(s) => &s.clearances,
        }
    }

    /// Its time span, integrator and sampling.
    pub fn simulation_mut(&mut self) -> &mut SimulationSpec {
        match self {
            AnyScenario::Planar(s) => &mut s.simulation,
            AnyScenario::Spatial(s) => &mut s.simulation,
        }
    }

    /// Its output selection.
    pub fn output(&self) -> &OutputSpec {
        match self {
            AnyScenario::Planar(s) => &s.output,
            AnyScenario::Spatial(s) => &s.output,
        }
    }

    /// Its output selection, to edit.
    pub fn output_mut(&mut self) -> &mut OutputSpec {
        match self {
            AnyScenario::Planar(s) => &mut s.output,
            AnyScenario::Spatial(s) => &mut s.output,
        }
    }

    /// The fastest rotation at the start \[rad/s\]: the largest |ω| of the drivers' motions at
    /// the start time and of the bodies' given initial angular velocities (`None`: nothing turns).
    pub fn fastest_rotation(&self) -> Option<f64> {
        let t0 = self.simulation().start_time;
        let (drivers, bodies): (Vec<f64>, Vec<f64>) = match self {
            AnyScenario::Planar(s) => (
                s.drivers.iter().map(|d| d.motion.eval(t0).1).collect(),
                s.bodies.iter().map(|b| b.angular_velocity).collect(),
            ),
            AnyScenario::Spatial(s) => (
                s.drivers.iter().map(|d| d.motion.eval(t0).1).collect(),
                s.bodies.iter().map(|b| b.angular_velocity.iter().map(|w| w * w).sum::<f64>().sqrt()).collect(),
            ),
        };
        drivers.into_iter().chain(bodies).map(f64::abs).filter(|w| *w > 0.0).reduce(f64::max)
    }

    /// Number of interfaces the reduced model couples: the clearance joints, the guides
    /// (translational clearance joints) and the bushings.
    pub fn interface_count(&self) -> usize {
        match self {
            AnyScenario::Planar(s) => s.clearances.len() + s.guides.len() + s.bushings.len(),
            AnyScenario::Spatial(s) => s.clearances.len(),
        }
    }

    /// Number of clearance joints.
    pub fn clearance_count(&self) -> usize {
        match self {
            AnyScenario::Planar(s) => s.clearances.len(),
            AnyScenario::Spatial(s) => s.clearances.len(),
        }
    }

    /// Every problem, with its field path.
    pub fn validate(&self) -> Problems {
        match self {
            AnyScenario::Planar(s) => validate(s),
            AnyScenario::Spatial(s) => crate::spatial::validate_spatial(s),
        }
    }

    /// The channels of its runs (`ideal`: clearance joints as ideal joints).
    pub fn channels(&self, ideal: bool) -> Vec<crate::Channel> {
        match self {
            AnyScenario::Planar(s) => crate::channels::channels(s, ideal),
            AnyScenario::Spatial(s) => crate::spatial::spatial_channels(s, ideal).into_iter().map(|(c, _)| c).collect(),
        }
    }

    /// The scenario as a TOML table.
    pub fn to_table(&self) -> Result<toml::Table, toml::ser::Error> {
        match self {
            AnyScenario::Planar(s) => toml::Table::try_from(s),
            AnyScenario::Spatial(s) => toml::Table::try_from(s),
        }
    }
}

/// Parses a planar or spatial scenario (by its `space` key) from TOML text.
pub fn parse_any(text: &str) -> Result<AnyScenario, Problems> {
    parse_any_table(toml_table(text)?)
}

/// [`parse_any`] of a parsed TOML table (a sweep's edited base: no round trip through text).
pub fn parse_any_table(table: toml::Table) -> Result<AnyScenario, Problems> {
    if is_spatial(&table)? {
        crate::spatial::parse_spatial_table(table).map(AnyScenario::Spatial)
    } else {
        parse_table(table).map(AnyScenario::Planar)
    }
}

/// Whether a scenario table describes a spatial mechanism (`space = "spatial"`) or a planar one
/// (no `space` key); any other `space` is a problem.
pub(crate) fn is_spatial(table: &toml::Table) -> Result<bool, Problems> {
    match table.get("space") {
        None => Ok(false),
        Some(toml::Value::String(s)) if s == "spatial" => Ok(true),
        Some(other) => {
            let mut p = Problems::new();
            p.push("space", format!("must be \"spatial\" (or left out for a planar mechanism), got {other}"));
            Err(p)
        }
    }
}

/// Reads a planar or spatial scenario file; the message names the file and lists every problem.
pub fn read_any(path: &std::path::Path) -> Result<AnyScenario, LoadError> {
    let text = std::fs::read_to_string(path).map_err(|source| LoadError::Read { path: path.to_path_buf(), source })?;
    parse_any(&text).map_err(|source| LoadError::Invalid { path: path.to_path_buf(), source })
}

/// A built-in scenario (planar or spatial) by name, or else a scenario file of either kind.
pub fn any_by_name_or_file(arg: &str) -> Result<AnyScenario, LoadError> {
    if let Some(s) = crate::builtin::by_name(arg) {
        return Ok(AnyScenario::Planar(s));
    }
    if let Some(s) = crate::builtin_spatial::spatial_by_name(arg) {
        return Ok(AnyScenario::Spatial(s));
    }
    let path = std::path::Path::new(arg);
    if !path.exists() {
        let built_ins =
            format!("{}, {}", crate::builtin::NAMES.join(", "), crate::builtin_spatial::SPATIAL_NAMES.join(", "));
        return Err(LoadError::Unknown { name: arg.to_string(), built_ins });
    }
    read_any(path)
}

/// Parses and validates a scenario from TOML text. On failure, returns every problem found.
pub fn parse(text: &str) -> Result<Scenario, Problems> {
    parse_table(toml_table(text)?)
}

/// The TOML table of a scenario text, or the syntax error as the file's problem.
pub(crate) fn toml_table(text: &str) -> Result<toml::Table, Problems> {
    toml::from_str(text).map_err(|e| {
        let mut p = Problems::new();
        p.push("(file)", format!("not valid TOML: {}", e.to_string().trim_end()));
        p
    })
}

/// [`parse`] of a parsed TOML table.
pub fn parse_table(table: toml::Table) -> Result<Scenario, Problems> {
    crate::format::parse(table)
}

impl crate::format::Format for Scenario {
    const TOP_KEYS: &'static [&'static str] = &TOP_KEYS;
    const REQUIRED: &'static [&'static str] = &["name", "bodies", "simulation"];
    type Body = BodySpec;
    type Joint = JointSpec;
    type Driver = DriverSpec;
    type Load = LoadSpec;
    type Sensor = SensorSpec;
    type Gravity = [f64; 2];

    fn own_arrays(table: &toml::Table, problems: &mut Problems) {
        array::<BushingSpec>(table, "bushings", problems);
        array::<GuideSpec>(table, "guides", problems);
    }
    crate::format::format_calls_of_the_module!();
    fn sensor(s: &SensorSpec) -> Problems {
        finite2("point", s.point)
    }
    fn gravity(g: &[f64; 2]) -> Problems {
        finite2("gravity", *g)
    }
}

/// Validates a scenario built in code (the same checks as [`parse`]).
pub fn validate(s: &Scenario) -> Problems {
    crate::format::validate(s)
}

pub(crate) trait Prefixed {
    fn prefixed(self, prefix: &str) -> Problems;
}
impl Prefixed for Problems {
    fn prefixed(self, prefix: &str) -> Problems {
        let mut p = Problems::new();
        p.extend_prefixed(prefix, self);
        p
    }
}

/// Turns a serde message into (field suffix, message).
fn split_serde_message(msg: &str) -> (Option<String>, String) {
    let msg = msg.trim_end();
    let quoted = |prefix: &str| -> Option<String> {
        let start = msg.find(prefix)? + prefix.len();
        let end = msg[start..].find('`')? + start;
        Some(msg[start..end].to_string())
    };
    if let Some(f) = quoted("missing field `") {
        return (Some(f), "missing (required)".into());
    }
    if let Some(f) = quoted("unknown field `") {
        let rest = msg.split_once(", expected").map(|(_, r)| format!("unknown field; expected{r}"));
        return (Some(f), rest.unwrap_or_else(|| "unknown field".into()));
    }
    if let Some((head, tail)) = msg.rsplit_once("\nin `") {
        let field = tail.trim_end_matches('`').to_string();
        return (Some(field), head.to_string());
    }
    (None, msg.to_string())
}

fn push_serde(problems: &mut Problems, path: &str, err: impl std::fmt::Display) {
    let (field, message) = split_serde_message(&err.to_string());
    match field {
        Some(f) => problems.push(format!("{path}.{f}"), message),
        None => problems.push(path, message),
    }
}

pub(crate) fn element<T: DeserializeOwned>(table: &toml::Table, key: &str, problems: &mut Problems) {
    if let Some(v) = table.get(key)
        && let Err(e) = v.clone().try_into::<T>()
    {
        push_serde(problems, key, e);
    }
}

pub(crate) fn array<T: DeserializeOwned>(table: &toml::Table, key: &str, problems: &mut Problems) {
    match table.get(key) {
        None => {}
        Some(toml::Value::Array(items)) => {
            for (k, v) in items.iter().enumerate() {
                if let Err(e) = v.clone().try_into::<T>() {
                    push_serde(problems, &format!("{key}[{k}]"), e);
                }
            }
        }
        Some(_) => problems.push(key, format!("must be an array of tables ([[{key}]])")),
    }
}

pub(crate) fn for_each_ok<T: DeserializeOwned>(
    table: &toml::Table,
    key: &str,
    problems: &mut Problems,
    check: impl Fn(&T) -> Problems,
) {
    if let Some(toml::Value::Array(items)) = table.get(key) {
        for (k, v) in items.iter().enumerate() {
            if let Ok(item) = v.clone().try_into::<T>() {
                problems.extend_prefixed_with(|| format!("{key}[{k}]"), check(&item));
            }
        }
    }
}

fn finite2(field: &str, v: [f64; 2]) -> Problems {
    let mut p = Problems::new();
    if !(v[0].is_finite() && v[1].is_finite()) {
        p.push(field, format!("must be finite, got [{}, {}]", v[0], v[1]));
    }
    p
}

fn validate_body(b: &BodySpec) -> Problems {
    let mut p = Problems::new();
    p.positive("mass", b.mass);
    p.positive("inertia", b.inertia);
    p.0.extend(finite2("position", b.position).0);
    p.0.extend(finite2("velocity", b.velocity).0);
    p.finite("angle", b.angle);
    p.finite("angular_velocity", b.angular_velocity);
    if b.name == "ground" || b.name.is_empty() {
        p.push("name", "must be non-empty and not the reserved \"ground\"");
    }
    p
}

fn validate_joint(j: &JointSpec) -> Problems {
    let mut p = Problems::new();
    p.0.extend(finite2("point1", j.point1).0);
    p.0.extend(finite2("point2", j.point2).0);
    match j.kind {
        JointType::Revolute => {
            if j.axis.is_some() {
                p.push("axis", "only a prismatic joint has an axis");
            }
            if j.angle_offset.is_some() {
                p.push("angle_offset", "only a prismatic joint has an angle_offset");
            }
        }
        JointType::Prismatic => match j.axis {
            None => p.push("axis", "missing (required for a prismatic joint)"),
            Some(a) => {
                if !(a[0].is_finite() && a[1].is_finite() && a[0].hypot(a[1]) > 0.0) {
                    p.push("axis", format!("must be a finite non-zero vector, got [{}, {}]", a[0], a[1]));
                }
            }
        },
    }
    if let Some(o) = j.angle_offset {
        p.finite("angle_offset", o);
    }
    if j.body1 == j.body2 {
        p.push("body2", "must differ from body1");
    }
    p
}

fn validate_load(l: &LoadSpec) -> Problems {
    let mut p = Problems::new();
    match l {
        LoadSpec::Force { point, force, .. } => {
            p.0.extend(finite2("point", *point).0);
            p.0.extend(finite2("force", *force).0);
        }
        LoadSpec::Torque { torque, .. } => p.finite("torque", *torque),
        LoadSpec::Motor { stall_torque, no_load_speed, .. } => {
            p.finite("stall_torque", *stall_torque);
            p.positive("no_load_speed", *no_load_speed);
        }
    }
    p
}

pub(crate) fn validate_clearance_numbers(c: &ClearanceSpec) -> Problems {
    let mut p = Problems::new();
    p.positive("journal_radius", c.journal_radius);
    p.positive("bearing_radius", c.bearing_radius);
    if c.journal_radius.is_finite() && c.bearing_radius.is_finite() && c.journal_radius >= c.bearing_radius {
        p.push(
            "journal_radius",
            format!(
                "must be smaller than bearing_radius ({} m), got {} m: the clearance c = R_B − R_J must be > 0",
                c.bearing_radius, c.journal_radius
            ),
        );
    }
    p.extend_prefixed("contact", c.contact.validate());
    p.extend_prefixed("friction", c.friction.validate());
    p
}

/// The guides' numbers and their joints (`[[guides]]`).
fn check_guides(s: &Scenario, p: &mut Problems) {
    let mut seen = HashSet::new();
    for (k, g) in s.guides.iter().enumerate() {
        let f = |x: &str| format!("guides[{k}].{x}");
        match s.joints.iter().find(|j| j.name == g.joint) {
            None => p.push(f("joint"), format!("no joint called {:?}", g.joint)),
            Some(j) if j.kind != JointType::Prismatic => p.push(
                f("joint"),
                format!("joint {:?} is not prismatic; a revolute joint takes its clearance in [[clearances]]", g.joint),
            ),
            Some(j) if g.slider != j.body1 && g.slider != j.body2 => p.push(
                f("slider"),
                format!(
                    "must name one of joint {:?}'s bodies ({:?} or {:?}), got {:?}",
                    j.name, j.body1, j.body2, g.slider
                ),
            ),
            Some(_) => {}
        }
        if !seen.insert(g.joint.as_str()) {
            p.push(f("joint"), format!("joint {:?} already has a guide", g.joint));
        }
        p.positive(f("length"), g.length);
        p.positive(f("height"), g.height);
        p.positive(f("clearance"), g.clearance);
        p.extend_prefixed(&f("contact"), g.contact.validate());
        p.extend_prefixed(&f("friction"), g.friction.validate());
        if matches!(g.contact, lash_contact::ContactLaw::Liu { .. }) {
            p.push(f("contact.law"), "\"liu\" is the law of a pin in a bore; a corner on a face takes another");
        } else if g.contact.needs_materials() {
            p.push(
                f("contact.stiffness"),
                "missing: a corner on a flat face has no radii to take a Hertz stiffness from",
            );
        }
    }
}

pub(crate) fn validate_simulation(s: &SimulationSpec) -> Problems {
    let mut p = Problems::new();
    p.finite("start_time", s.start_time);
    p.positive("horizon", s.horizon);
    p.positive("output_interval", s.output_interval);
    if s.output_interval.is_finite() && s.horizon.is_finite() && s.output_interval > s.horizon {
        p.push("output_interval", format!("must not exceed the horizon ({} s)", s.horizon));
    }
    // Time runs on integer ticks: an interval below one tick would be a zero step.
    let tick = 1.0 / lash_core::TICKS_PER_SECOND as f64;
    if s.output_interval > 0.0 && s.output_interval < tick {
        p.push("output_interval", format!("{} s is below lash's time resolution ({tick:e} s)", s.output_interval));
    }
    match &s.integrator {
        lash_ode::Method::Rk4 { step } => {
            p.positive("integrator.step", *step);
            if *step > 0.0 && s.output_interval > 0.0 {
                let r = s.output_interval / step;
                if (r - r.round()).abs() > 1e-9 * r || r.round() < 1.0 {
                    p.push(
                        "integrator.step",
                        format!(
                            "output_interval {} s must be a whole multiple of the step {step} s",
                            s.output_interval
                        ),
                    );
                }
                let r = s.horizon / step;
                if (r - r.round()).abs() > 1e-9 * r {
                    p.push(
                        "integrator.step",
                        format!("horizon {} s must be a whole multiple of the step {step} s", s.horizon),
                    );
                }
            }
        }
        lash_ode::Method::Dopri5(o) | lash_ode::Method::Dop853(o) => {
            p.positive("integrator.rtol", o.rtol);
            p.positive("integrator.atol", o.atol);
            p.positive("integrator.initial_step", o.initial_step);
            p.positive("integrator.max_step", o.max_step);
            p.positive("integrator.min_step", o.min_step);
            if o.min_step > o.max_step {
                p.push("integrator.min_step", "must not exceed max_step");
            }
            if s.output_interval > 0.0 && o.min_step > 0.0 && s.output_interval < o.min_step {
                p.push(
                    "output_interval",
                    format!(
                        "{} s is below the integrator's min_step ({} s): samples closer than any step it may take",
                        s.output_interval, o.min_step
                    ),
                );
            }
        }
    }
    p.non_negative("baumgarte.alpha", s.baumgarte.alpha);
    p.non_negative("baumgarte.beta", s.baumgarte.beta);
    p
}

/// Names, references and counts across the file.
fn cross_check(s: &Scenario) -> Problems {
    let mut p = Problems::new();
    check_references(s, &mut p);
    let clearance_joints = check_clearances(s, &mut p);
    check_guides(s, &mut p);
    check_bushings(s, &clearance_joints, &mut p);
    let coords = 3 * s.bodies.len();
    let equations = 2 * s.joints.len().saturating_sub(s.bushings.len()) + s.drivers.len();
    if equations > coords {
        p.push("joints", format!("{equations} constraint equations for {coords} coordinates: over-constrained"));
    }
    let channels: Vec<(String, &str)> =
        crate::channels::channels(s, false).into_iter().map(|c| (c.name, c.unit)).collect();
    check_output(&mut p, &s.output, &channels, s.simulation.output_interval);
    p
}

/// The `[output]` table against the scenario's channels (name, unit), planar or spatial: its
/// measurements, and each channel it names.
pub(crate) fn check_output(p: &mut Problems, output: &OutputSpec, channels: &[(String, &str)], output_interval: f64) {
    p.0.extend(validate_measurements(output, channels, output_interval).0);
    for (k, c) in output.channels.iter().enumerate() {
        if !channels.iter().any(|(n, _)| n == c) {
            p.push(format!("output.channels[{k}]"), format!("no channel called {c:?}; see `lash channels <scenario>`"));
        }
    }
}

/// Unique names of bodies, joints and sensors; the bodies that joints, drivers, loads and sensors name.
fn check_references(s: &Scenario, p: &mut Problems) {
    let joints = s.joints.iter().map(|j| (j.name.as_str(), [j.body1.as_str(), j.body2.as_str()]));
    let bodies = check_bodies_and_joints(p, s.bodies.iter().map(|b| b.name.as_str()), joints);
    let body_ok = |name: &str| name == "ground" || bodies.contains(name);
    for (k, d) in s.drivers.iter().enumerate() {
        for (field, name) in [("body", &d.body), ("reference", &d.reference)] {
            if !body_ok(name) {
                p.push(format!("drivers[{k}].{field}"), format!("no body called {name:?}"));
            }
        }
        if d.body == d.reference {
            p.push(format!("drivers[{k}].reference"), "must differ from the driven body");
        }
    }
    for (k, l) in s.loads.iter().enumerate() {
        let (LoadSpec::Force { body, .. } | LoadSpec::Torque { body, .. } | LoadSpec::Motor { body, .. }) = l;
        if !bodies.contains(body.as_str()) {
            p.push(format!("loads[{k}].body"), format!("no moving body called {body:?}"));
        }
    }
    check_sensors(p, &bodies, s.sensors.iter().map(|sen| (sen.name.as_str(), sen.body.as_str())));
}

/// What planar and spatial files check alike first: unique body names, unique joint names, and
/// each joint's two bodies (`joints`: name, [body1, body2]) among the bodies or the ground.
/// Returns the bodies' names.
pub(crate) fn check_bodies_and_joints<'a>(
    p: &mut Problems,
    bodies: impl Iterator<Item = &'a str>,
    joints: impl Iterator<Item = (&'a str, [&'a str; 2])>,
) -> HashSet<&'a str> {
    let mut names = HashSet::new();
    for (k, b) in bodies.enumerate() {
        if !names.insert(b) {
            p.push(format!("bodies[{k}].name"), format!("{b:?} is used by another body"));
        }
    }
    let body_ok = |name: &str| name == "ground" || names.contains(name);
    let mut joint_names = HashSet::new();
    for (k, (joint, ends)) in joints.enumerate() {
        if !joint_names.insert(joint) {
            p.push(format!("joints[{k}].name"), format!("{joint:?} is used by another joint"));
        }
        for (field, name) in ["body1", "body2"].into_iter().zip(ends) {
            if !body_ok(name) {
                p.push(format!("joints[{k}].{field}"), format!("no body called {name:?}"));
            }
        }
    }
    names
}

/// Each sensor (`sensors`: name, body) on one of `bodies` or the ground, and its name unique —
/// planar and spatial files alike.
pub(crate) fn check_sensors<'a>(
    p: &mut Problems,
    bodies: &HashSet<&str>,
    sensors: impl Iterator<Item = (&'a str, &'a str)>,
) {
    let mut names = HashSet::new();
    for (k, (sensor, body)) in sensors.enumerate() {
        if body != "ground" && !bodies.contains(body) {
            p.push(format!("sensors[{k}].body"), format!("no body called {body:?}"));
        }
        if !names.insert(sensor) {
            p.push(format!("sensors[{k}].name"), format!("{sensor:?} is used by another sensor"));
        }
    }
}

/// Each clearance on a revolute joint of the file, one per joint, with its bush and materials: the joints that have one.
fn check_clearances<'a>(s: &'a Scenario, p: &mut Problems) -> HashSet<&'a str> {
    let mut clearance_joints = HashSet::new();
    for (k, c) in s.clearances.iter().enumerate() {
        let f = |x: &str| format!("clearances[{k}].{x}");
        match s.joints.iter().find(|j| j.name == c.joint) {
            None => p.push(f("joint"), format!("no joint called {:?}", c.joint)),
            Some(j) => {
                if j.kind != JointType::Revolute {
                    p.push(
                        f("joint"),
                        format!(
                            "joint {:?} is not revolute; a prismatic joint takes its clearance in [[guides]]",
                            c.joint
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
            }
        }
        if !clearance_joints.insert(c.joint.as_str()) {
            p.push(f("joint"), format!("joint {:?} already has a clearance", c.joint));
        }
        if let Some(bush) = &c.bush {
            let problems = bush.check(&f("bush."));
            if c.bearing_material.is_some() {
                p.push(f("bearing_material"), "leave it out: with a bush, the bearing's material is the bush's");
            }
            if bush.inner_radius != c.bearing_radius {
                p.push(
                    f("bush.inner_radius"),
                    format!("must be the bearing radius {} m (the bush's bore is the bearing)", c.bearing_radius),
                );
            }
            if bush.pin_radius != c.journal_radius {
                p.push(f("bush.pin_radius"), format!("must be the journal radius {} m", c.journal_radius));
            }
            if problems.is_empty()
                && let Err(e) = lash_bush::bonded_pin(bush).and_then(|_| lash_bush::InterfaceStress::of(bush))
            {
                p.push(f("bush"), e.to_string());
            }
            p.0.extend(problems.0);
        }
        if let Some(film) = &c.film {
            p.extend_prefixed(&f("film"), film.validate());
            if c.bush.is_some() {
                p.push(f("film"), "an oil film with a flexible bush behind the bearing is not there yet (give the joint one or the other)");
            }
        }
        let needs_materials = c.contact.needs_materials();
        let bearing = if c.bush.is_some() { &None } else { &c.bearing_material };
        for (field, m) in [("journal_material", &c.journal_material), ("bearing_material", bearing)] {
            match m {
                Some(name) if !s.materials.contains_key(name) => {
                    p.push(f(field), format!("no material called {name:?} in [materials]"));
                }
                None if needs_materials && !(field == "bearing_material" && c.bush.is_some()) => {
                    p.push(
                        f(field),
                        "missing: the contact law takes its stiffness from the materials (or give contact.stiffness)",
                    );
                }
                _ => {}
            }
        }
    }
    clearance_joints
}

/// Each bushing on a revolute joint without a clearance, one per joint, with one stiffness source.
fn check_bushings(s: &Scenario, clearance_joints: &HashSet<&str>, p: &mut Problems) {
    let mut bushing_joints = HashSet::new();
    for (k, b) in s.bushings.iter().enumerate() {
        let f = |x: &str| format!("bushings[{k}].{x}");
        match s.joints.iter().find(|j| j.name == b.joint) {
            None => p.push(f("joint"), format!("no joint called {:?}", b.joint)),
            Some(j) if j.kind != JointType::Revolute => {
                p.push(f("joint"), format!("joint {:?} is not revolute; only revolute joints take a bush", b.joint))
            }
            Some(_) => {}
        }
        if clearance_joints.contains(b.joint.as_str()) {
            p.push(
                f("joint"),
                format!(
                    "joint {:?} has a clearance: contact in series with a flexible bush is not there yet (give the \
                     joint either a clearance or a bushing)",
                    b.joint
                ),
            );
        }
        if !bushing_joints.insert(b.joint.as_str()) {
            p.push(f("joint"), format!("joint {:?} already has a bushing", b.joint));
        }
        if let Some(curve) = &b.curve {
            if b.stiffness.is_some() || b.bush.is_some() {
                p.push(f("curve"), "give one of stiffness, bush or curve");
            }
            p.0.extend(curve.check(&f("curve")).0);
        }
        match (&b.bush, b.stiffness) {
            _ if b.curve.is_some() => {}
            (Some(_), Some(_)) => p.push(f("stiffness"), "give either stiffness or bush, not both"),
            (None, None) => p.push(f("stiffness"), "missing: give stiffness [N/m] (and damping) or a bush"),
            (None, Some(k)) => {
                if !(k > 0.0 && k.is_finite()) {
                    p.push(f("stiffness"), format!("must be > 0 N/m, got {k}"));
                }
            }
            (Some(bush), None) => {
                let problems = bush.check(&f("bush."));
                if problems.is_empty()
                    && let Err(e) = b.stiffness_damping()
                {
                    p.push(f("bush"), e.to_string());
                }
                p.0.extend(problems.0);
                if bush.inner_radius != bush.pin_radius {
                    p.push(
                        f("bush.inner_radius"),
                        format!(
                            "a bushing's bore fits its pin (inner_radius = pin_radius = {} m); a bore with clearance \
                             (contact in series with the bush) is not there yet",
                            bush.pin_radius
                        ),
                    );
                }
                if b.damping.is_some() {
                    p.push(f("damping"), "comes from the bush's viscosities: give it only with stiffness or curve");
                }
            }
        }
        if let Some(c) = b.damping
            && !(c >= 0.0 && c.is_finite())
        {
            p.push(f("damping"), format!("must be ≥ 0 N s/m, got {c}"));
        }
    }
}

/// The measurements of `output` against the scenario's channels (name, unit) and output interval.
pub(crate) fn validate_measurements(
    output: &OutputSpec,
    channels: &[(String, &str)],
    output_interval: f64,
) -> Problems {
    let mut p = Problems::new();
    let mut names = HashSet::new();
    for (k, m) in output.measurements.iter().enumerate() {
        let f = |x: &str| format!("output.measurements[{k}].{x}");
        if m.name.is_empty() || !names.insert(m.name.as_str()) {
            p.push(f("name"), format!("{:?} must be non-empty and unique", m.name));
        }
        if m.forces.is_empty() || m.forces.len() > 3 {
            p.push(f("forces"), format!("needs one to three force channels (one per axis), got {}", m.forces.len()));
        }
        for (a, force) in m.forces.iter().enumerate() {
            match channels.iter().find(|(n, _)| n == force) {
                None => p.push(
                    format!("{}[{a}]", f("forces")),
                    format!("no channel called {force:?}; see `lash channels <scenario>`"),
                ),
                Some((_, unit)) if *unit != "N" => {
                    p.push(format!("{}[{a}]", f("forces")), format!("channel {force:?} is in {unit}, not a force in N"))
                }
                Some(_) => {}
            }
        }
        p.extend_prefixed(&f("mount"), m.mount.validate());
        let acquisition = m.acquisition.validate();
        if acquisition.is_empty() && output_interval > 0.0 {
            let ratio = 1.0 / (m.acquisition.sample_rate * output_interval);
            if (ratio - ratio.round()).abs() > 1e-9 * ratio || ratio.round() < 1.0 {
                p.push(
                    f("acquisition.sample_rate"),
                    format!(
                        "the logger's period {} s must be a whole multiple of simulation.output_interval {output_interval} s",
                        1.0 / m.acquisition.sample_rate
                    ),
                );
            }
        }
        p.extend_prefixed(&f("acquisition"), acquisition);
    }
    p
}

/// Helpers on contact laws used by validation.
pub(crate) trait NeedsMaterials {
    fn needs_materials(&self) -> bool;
}

impl NeedsMaterials for lash_contact::ContactLaw {
    fn needs_materials(&self) -> bool {
        use lash_contact::ContactLaw as L;
        match self {
            L::Hertz { stiffness, .. } | L::AdamsImpact { stiffness, .. } => stiffness.is_none(),
            L::KelvinVoigt { .. } => false,
            L::HuntCrossley(h) | L::LankaraniNikravesh(h) | L::Gonthier(h) | L::Flores(h) | L::HuGuo(h) => {
                h.stiffness.is_none()
            }
            L::Liu { .. } => true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serde_messages_become_field_paths() {
        assert_eq!(split_serde_message("missing field `mass`\n").0.as_deref(), Some("mass"));
        let (f, m) = split_serde_message("invalid type: string \"x\", expected f64\nin `mass`\n");
        assert_eq!(f.as_deref(), Some("mass"));
        assert!(m.contains("expected f64"));
        assert_eq!(split_serde_message("unknown field `mas`, expected one of `a`").0.as_deref(), Some("mas"));
    }

    #[test]
    fn a_guide_names_its_bad_fields() {
        let g = crate::builtin::by_name("G").unwrap();
        let problems = |edit: &dyn Fn(&mut Scenario)| {
            let mut s = g.clone();
            edit(&mut s);
            validate(&s).to_string()
        };
        let p = problems(&|s| s.guides[0].joint = "crank_rod".into());
        assert!(p.contains("guides[0].joint") && p.contains("not prismatic"), "{p}");
        let p = problems(&|s| s.guides[0].slider = "rod".into());
        assert!(p.contains("guides[0].slider") && p.contains("\"slider\" or \"ground\""), "{p}");
        let p = problems(&|s| {
            s.guides[0].height = -0.05;
            s.guides[0].clearance = 0.0;
        });
        assert!(p.contains("guides[0].height") && p.contains("guides[0].clearance"), "{p}");
        let p = problems(&|s| {
            let lash_contact::ContactLaw::Flores(h) = &mut s.guides[0].contact else { panic!("G's law") };
            h.stiffness = None;
        });
        assert!(p.contains("guides[0].contact.stiffness") && p.contains("no radii"), "{p}");
        let p = problems(&|s| s.guides.push(s.guides[0].clone()));
        assert!(p.contains("guides[1].joint") && p.contains("already has a guide"), "{p}");
        let p = problems(&|s| {
            let mut c = crate::builtin::by_name("B").unwrap().clearances[0].clone();
            c.joint = "slider_guide".into();
            s.clearances.push(c);
        });
        assert!(p.contains("clearances[0].joint") && p.contains("[[guides]]"), "{p}");
    }

    #[test]
    fn output_intervals_below_the_time_resolution_or_the_minimum_step_are_refused() {
        let base = crate::builtin::by_name("B").unwrap().simulation;
        let problems = |interval: f64| {
            let mut s = base.clone();
            s.output_interval = interval;
            let p = validate_simulation(&s);
            if p.is_empty() { String::new() } else { p.to_string() }
        };
        assert!(problems(1e-5).is_empty(), "{}", problems(1e-5));
        let tiny = problems(1e-16);
        assert!(tiny.contains("output_interval") && tiny.contains("time resolution"), "{tiny}");
        let lash_ode::Method::Dop853(o) = base.integrator else { panic!("B is adaptive") };
        let below = problems(o.min_step / 2.0);
        assert!(below.contains("output_interval") && below.contains("min_step"), "{below}");
    }

    #[test]
    fn a_film_with_meaningless_numbers_or_beside_a_bush_is_named() {
        let text = toml::to_string(&crate::builtin::by_name("A-lubricated").unwrap()).unwrap();
        let bad = text
            .replace("viscosity = 0.2", "viscosity = -0.2")
            .replace("mixed_fraction = 0.05", "mixed_fraction = 1.5");
        let p = parse(&bad).unwrap_err().to_string();
        assert!(p.contains("clearances[0].film.viscosity") && p.contains("clearances[0].film.mixed_fraction"), "{p}");
        let unknown = text.replace("bearing = \"short\"", "bearing = \"finite\"");
        let p = parse(&unknown).unwrap_err().to_string();
        assert!(p.contains("film") && p.contains("short"), "{p}");
        let mut s = crate::builtin::by_name("F-flexible-imperfect").unwrap();
        s.clearances[0].film = crate::builtin::by_name("A-lubricated").unwrap().clearances[0].film;
        let p = validate(&s).to_string();
        assert!(p.contains("clearances[0].film") && p.contains("bush"), "{p}");
    }
}
