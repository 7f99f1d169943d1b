//! What a planar and a spatial scenario file share: the order in which a file is checked (every
//! top-level key known, the required ones present, each element parsed on its own so that one bad
//! body does not hide the problems of the others, then the values of every element that parsed,
//! then the references across the file). Each kind of file says only what is its own — its keys,
//! its element types and their value checks — through [`Format`].

use crate::load::{Prefixed, array, element, for_each_ok, validate_clearance_numbers, validate_simulation};
use crate::schema::{ClearanceSpec, OutputSpec, SimulationSpec};
use lash_contact::Material;
use lash_core::Problems;
use serde::de::DeserializeOwned;
use std::collections::BTreeMap;

/// A kind of scenario file (planar, spatial): its keys, element types and value checks.
pub(crate) trait Format: DeserializeOwned {
    /// The top-level keys it knows.
    const TOP_KEYS: &'static [&'static str];
    /// The top-level keys it requires.
    const REQUIRED: &'static [&'static str];
    /// A `[[bodies]]` element.
    type Body: DeserializeOwned;
    /// A `[[joints]]` element.
    type Joint: DeserializeOwned;
    /// A `[[drivers]]` element.
    type Driver: DeserializeOwned;
    /// A `[[loads]]` element.
    type Load: DeserializeOwned;
    /// A `[[sensors]]` element.
    type Sensor: DeserializeOwned;
    /// The `gravity` vector.
    type Gravity: DeserializeOwned;

    /// Parses its own single elements (checked right after `name`).
    fn own_elements(_table: &toml::Table, _problems: &mut Problems) {}
    /// Parses its own arrays (checked right after `clearances`).
    fn own_arrays(_table: &toml::Table, _problems: &mut Problems) {}
    /// The value checks of a body.
    fn body(b: &Self::Body) -> Problems;
    /// The value checks of a joint.
    fn joint(j: &Self::Joint) -> Problems;
    /// The value checks of a driver (its motion's, under `motion`).
    fn driver(d: &Self::Driver) -> Problems;
    /// The value checks of a load.
    fn load(l: &Self::Load) -> Problems;
    /// The value checks of a sensor.
    fn sensor(s: &Self::Sensor) -> Problems;
    /// The value checks of the gravity vector.
    fn gravity(g: &Self::Gravity) -> Problems;
    /// The parts the value checks read.
    fn parts(&self) -> Parts<'_, Self>;
    /// Names, references and counts across the file.
    fn cross_check(&self) -> Problems;
}

/// The calls of [`Format`] that a planar and a spatial scenario answer alike: each element's
/// checks by the module's own `validate_body`, `validate_joint` and `validate_load`, a driver's
/// motion, the parts by the same field names, the module's `cross_check`. Used inside each kind's
/// `impl Format` block (whose element types differ).
macro_rules! format_calls_of_the_module {
    () => {
        fn body(b: &Self::Body) -> Problems {
            validate_body(b)
        }
        fn joint(j: &Self::Joint) -> Problems {
            validate_joint(j)
        }
        fn driver(d: &Self::Driver) -> Problems {
            crate::format::motion_checks(d.motion.validate())
        }
        fn load(l: &Self::Load) -> Problems {
            validate_load(l)
        }
        fn parts(&self) -> crate::format::Parts<'_, Self> {
            crate::format::Parts {
                bodies: &self.bodies,
                joints: &self.joints,
                drivers: &self.drivers,
                loads: &self.loads,
                clearances: &self.clearances,
                sensors: &self.sensors,
                materials: &self.materials,
                simulation: &self.simulation,
                gravity: &self.gravity,
            }
        }
        fn cross_check(&self) -> Problems {
            cross_check(self)
        }
    };
}
pub(crate) use format_calls_of_the_module;

/// The parts of a scenario that [`validate`] checks.
pub(crate) struct Parts<'a, F: Format> {
    pub bodies: &'a [F::Body],
    pub joints: &'a [F::Joint],
    pub drivers: &'a [F::Driver],
    pub loads: &'a [F::Load],
    pub clearances: &'a [ClearanceSpec],
    pub sensors: &'a [F::Sensor],
    pub materials: &'a BTreeMap<String, Material>,
    pub simulation: &'a SimulationSpec,
    pub gravity: &'a F::Gravity,
}

/// Parses and validates a scenario of kind `F` from its TOML table; on failure, every problem.
pub(crate) fn parse<F: Format>(table: toml::Table) -> Result<F, Problems> {
    let mut problems = Problems::new();
    for key in table.keys() {
        if !F::TOP_KEYS.contains(&key.as_str()) {
            problems.push(key.clone(), format!("unknown section; expected one of {}", F::TOP_KEYS.join(", ")));
        }
    }
    for key in F::REQUIRED {
        if !table.contains_key(*key) {
            problems.push(*key, "missing (required)");
        }
    }
    structure::<F>(&table, &mut problems);
    let structural_ok = problems.is_empty();
    values::<F>(&table, &mut problems);
    if !structural_ok {
        return Err(problems);
    }
    let scenario: F = match toml::Value::Table(table).try_into() {
        Ok(s) => s,
        Err(e) => {
            problems.push("(file)", e.to_string().trim_end().to_string());
            return Err(problems);
        }
    };
    problems.0.extend(scenario.cross_check().0);
    problems.into_result().map(|()| scenario)
}

/// Element by element, so that one bad body does not hide the problems of the others.
fn structure<F: Format>(table: &toml::Table, problems: &mut Problems) {
    element::<String>(table, "name", problems);
    F::own_elements(table, problems);
    element::<String>(table, "description", problems);
    element::<F::Gravity>(table, "gravity", problems);
    element::<BTreeMap<String, Material>>(table, "materials", problems);
    element::<SimulationSpec>(table, "simulation", problems);
    element::<OutputSpec>(table, "output", problems);
    array::<F::Body>(table, "bodies", problems);
    array::<F::Joint>(table, "joints", problems);
    array::<F::Driver>(table, "drivers", problems);
    array::<F::Load>(table, "loads", problems);
    array::<ClearanceSpec>(table, "clearances", problems);
    F::own_arrays(table, problems);
    array::<F::Sensor>(table, "sensors", problems);
}

/// The value checks of every element that parsed.
fn values<F: Format>(table: &toml::Table, problems: &mut Problems) {
    for_each_ok::<F::Body>(table, "bodies", problems, F::body);
    for_each_ok::<F::Joint>(table, "joints", problems, F::joint);
    for_each_ok::<F::Driver>(table, "drivers", problems, F::driver);
    for_each_ok::<F::Load>(table, "loads", problems, F::load);
    for_each_ok::<ClearanceSpec>(table, "clearances", problems, validate_clearance_numbers);
    for_each_ok::<F::Sensor>(table, "sensors", problems, F::sensor);
    if let Some(Ok(sim)) = table.get("simulation").map(|v| v.clone().try_into::<SimulationSpec>()) {
        problems.extend_prefixed("simulation", validate_simulation(&sim));
    }
    if let Some(Ok(m)) = table.get("materials").map(|v| v.clone().try_into::<BTreeMap<String, Material>>()) {
        for (name, mat) in &m {
            problems.extend_prefixed_with(|| format!("materials.{name}"), mat.validate());
        }
    }
    if let Some(Ok(g)) = table.get("gravity").map(|v| v.clone().try_into::<F::Gravity>()) {
        problems.0.extend(F::gravity(&g).0);
    }
}

/// Validates a scenario built in code: the same checks as [`parse`].
pub(crate) fn validate<F: Format>(s: &F) -> Problems {
    let parts = s.parts();
    let mut p = Problems::new();
    let mut each = |key: &str, checks: &mut dyn Iterator<Item = Problems>| {
        for (k, problems) in checks.enumerate() {
            p.extend_prefixed_with(|| format!("{key}[{k}]"), problems);
        }
    };
    each("bodies", &mut parts.bodies.iter().map(F::body));
    each("joints", &mut parts.joints.iter().map(F::joint));
    each("drivers", &mut parts.drivers.iter().map(F::driver));
    each("loads", &mut parts.loads.iter().map(F::load));
    each("clearances", &mut parts.clearances.iter().map(validate_clearance_numbers));
    each("sensors", &mut parts.sensors.iter().map(F::sensor));
    for (name, m) in parts.materials {
        p.extend_prefixed_with(|| format!("materials.{name}"), m.validate());
    }
    p.extend_prefixed("simulation", validate_simulation(parts.simulation));
    p.0.extend(F::gravity(parts.gravity).0);
    p.0.extend(s.cross_check().0);
    p
}

/// A driver's checks are its motion's, under `motion`.
pub(crate) fn motion_checks(motion_problems: Problems) -> Problems {
    motion_problems.prefixed("motion")
}
