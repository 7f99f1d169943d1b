//! Scenario data as FMI parameters of an exported subsystem.
//!
//! An FMU built from a scenario (the mechanism, the full model) exposes the scenario's numbers —
//! link data (joint points), masses, inertias, driver motion, gravity, loads, clearance radii and
//! law coefficients — as parameters named after the scenario's own names (`crank.mass`,
//! `crank_rod.point2`, `motor.motion.omega`, `crank_pivot.contact.restitution`). They may be set
//! until initialization; [`WithParameters`] then writes them into the scenario at their paths
//! ([`crate::paths::set_path`]), validates the edited scenario like a file, and builds the model
//! from it, so an FMU with edited parameters computes exactly what lash computes for the edited
//! scenario file.

use crate::load::AnyScenario;
use crate::paths::EditError;
use lash_core::{
    Causality, SavedState, StepOutcome, Subsystem, SubsystemError, Ticks, ValueReference, Variability, Variable,
};

/// One scenario parameter: a scalar or an array of numbers at scenario paths.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioParameter {
    /// FMI name (`crank.mass`, `crank_rod.point2`).
    pub name: String,
    /// Scenario path of each element (`bodies[0].mass`; `joints[1].point2[0]`, `…[1]`).
    pub paths: Vec<String>,
    /// SI unit, empty where the unit depends on other data (a stiffness whose unit follows the
    /// exponent).
    pub unit: &'static str,
    /// Its value(s) in the scenario.
    pub start: Vec<f64>,
    /// An array (even of one element), not a scalar.
    pub array: bool,
}

impl ScenarioParameter {
    /// The scenario field (the path without an element index for an array).
    pub fn field(&self) -> &str {
        let first = &self.paths[0];
        if self.array { first.rsplit_once('[').map(|x| x.0).unwrap_or(first) } else { first }
    }
}

/// Every number under `value` as parameters named `name_prefix` + key path.
fn leaves(name_prefix: &str, path_prefix: &str, key: &str, value: &toml::Value, out: &mut Vec<ScenarioParameter>) {
    match value {
        toml::Value::Float(_) | toml::Value::Integer(_) => out.push(ScenarioParameter {
            name: name_prefix.to_string(),
            paths: vec![path_prefix.to_string()],
            unit: lash_core::units::field_unit(key),
            start: vec![number(value)],
            array: false,
        }),
        toml::Value::Array(a) if !a.is_empty() && a.iter().all(|v| v.is_float() || v.is_integer()) => {
            out.push(ScenarioParameter {
                name: name_prefix.to_string(),
                paths: (0..a.len()).map(|i| format!("{path_prefix}[{i}]")).collect(),
                unit: lash_core::units::field_unit(key),
                start: a.iter().map(number).collect(),
                array: true,
            })
        }
        toml::Value::Table(t) => {
            for (k, v) in t {
                leaves(&format!("{name_prefix}.{k}"), &format!("{path_prefix}.{k}"), k, v, out);
            }
        }
        _ => {}
    }
}

fn number(v: &toml::Value) -> f64 {
    v.as_float().or_else(|| v.as_integer().map(|i| i as f64)).unwrap_or(f64::NAN)
}

/// Why a subsystem with scenario parameters could not be made, or its parameters not applied.
#[derive(Debug, thiserror::Error)]
pub enum ParameterError {
    /// The scenario could not be written as a table (to find its numbers).
    #[error("scenario {scenario:?} does not serialise")]
    Serialise {
        /// The scenario's name.
        scenario: String,
        /// Why.
        #[source]
        source: toml::ser::Error,
    },
    /// A parameter has the name of a model variable.
    #[error("two variables are named {0:?} (a scenario name clashes with a model variable)")]
    Duplicate(String),
    /// The parameters' values do not make a scenario.
    #[error("the parameters make no valid scenario")]
    Edit(#[from] EditError),
    /// The model could not be built from the scenario.
    #[error("the model could not be built from the scenario")]
    Build(#[source] BuildError),
}

/// Why a model could not be built from a scenario (the builder's own error, boxed).
pub type BuildError = Box<dyn std::error::Error + Send + Sync>;

fn scenario_table(s: &AnyScenario) -> Result<toml::Table, ParameterError> {
    s.to_table().map_err(|source| ParameterError::Serialise { scenario: s.name().to_string(), source })
}

/// The `name` of each item of the array `section` of a scenario table.
fn item_names(table: &toml::Table, section: &str) -> Vec<String> {
    let Some(toml::Value::Array(items)) = table.get(section) else { return Vec::new() };
    items.iter().map(|item| item.get("name").and_then(toml::Value::as_str).unwrap_or_default().to_string()).collect()
}

/// Every number of each item of the array `section`, named `<item name>.<key path>`.
fn named(table: &toml::Table, section: &str, names: &[String], out: &mut Vec<ScenarioParameter>) {
    let Some(toml::Value::Array(items)) = table.get(section) else { return };
    for (k, (item, name)) in items.iter().zip(names).enumerate() {
        if let toml::Value::Table(t) = item {
            for (key, v) in t {
                leaves(&format!("{name}.{key}"), &format!("{section}[{k}].{key}"), key, v, out);
            }
        }
    }
}

/// The mechanism's parameters (planar or spatial): gravity, each body's mass and inertia (and
/// products of inertia in space), each joint's points (and axes), each driver's motion, each
/// load's numbers.
pub fn mechanism_parameters(s: &AnyScenario) -> Result<Vec<ScenarioParameter>, ParameterError> {
    let table = scenario_table(s)?;
    let mut out = Vec::new();
    if let Some(g) = table.get("gravity") {
        leaves("gravity", "gravity", "gravity", g, &mut out);
    }
    if let Some(toml::Value::Array(bodies)) = table.get("bodies") {
        for (k, (body, name)) in bodies.iter().zip(item_names(&table, "bodies")).enumerate() {
            for key in ["mass", "inertia", "products"] {
                if let Some(v) = body.get(key) {
                    leaves(&format!("{name}.{key}"), &format!("bodies[{k}].{key}"), key, v, &mut out);
                }
            }
        }
    }
    named(&table, "joints", &item_names(&table, "joints"), &mut out);
    named(&table, "drivers", &item_names(&table, "drivers"), &mut out);
    let loads = match table.get("loads") {
        Some(toml::Value::Array(a)) => (0..a.len()).map(|k| format!("loads[{k}]")).collect(),
        _ => Vec::new(),
    };
    named(&table, "loads", &loads, &mut out);
    Ok(out)
}

/// The clearance joints' parameters (radii, contact and friction law coefficients), named after
/// the joint: `crank_pivot.bearing_radius`, `crank_pivot.contact.restitution`.
pub fn clearance_parameters(s: &AnyScenario) -> Result<Vec<ScenarioParameter>, ParameterError> {
    let table = scenario_table(s)?;
    let names: Vec<String> = match table.get("clearances") {
        Some(toml::Value::Array(items)) => items
            .iter()
            .map(|item| item.get("joint").and_then(toml::Value::as_str).unwrap_or_default().to_string())
            .collect(),
        _ => Vec::new(),
    };
    let mut out = Vec::new();
    named(&table, "clearances", &names, &mut out);
    Ok(out)
}

/// How a subsystem is built from a (validated) scenario.
pub type Builder<S> = fn(&AnyScenario) -> Result<S, BuildError>;

/// A subsystem built from a scenario, with scenario numbers as FMI parameters (appended after the
/// subsystem's own variables). Setting a parameter before initialization rebuilds the subsystem
/// from the edited scenario at initialization; inputs set before that are replayed on the rebuilt
/// one.
pub struct WithParameters<S: Subsystem> {
    base: toml::Table,
    build: Builder<S>,
    inner: S,
    parameters: Vec<ScenarioParameter>,
    values: Vec<f64>,
    offsets: Vec<usize>,
    changed: bool,
    variables: Vec<Variable>,
    first: ValueReference,
    experiment: Option<(Ticks, Option<Ticks>)>,
    pending: Vec<(bool, Vec<ValueReference>, Vec<f64>)>,
    initialized: bool,
}

impl<S: Subsystem> WithParameters<S> {
    /// Builds the subsystem from `scenario` and appends `parameters` to its variables.
    pub fn new(
        scenario: &AnyScenario,
        parameters: Vec<ScenarioParameter>,
        build: Builder<S>,
    ) -> Result<Self, ParameterError> {
        let inner = build(scenario).map_err(ParameterError::Build)?;
        let mut variables = inner.variables().to_vec();
        let first = variables.len() as ValueReference;
        let mut offsets = Vec::with_capacity(parameters.len() + 1);
        let mut values = Vec::new();
        for (k, p) in parameters.iter().enumerate() {
            offsets.push(values.len());
            values.extend_from_slice(&p.start);
            variables.push(Variable {
                name: p.name.clone(),
                value_reference: first + k as ValueReference,
                causality: Causality::Parameter,
                variability: Variability::Fixed,
                unit: p.unit.to_string(),
                description: format!("scenario field {}", p.field()),
                shape: if p.array { vec![p.paths.len()] } else { vec![] },
                start: p.start.clone(),
                kind: lash_core::ValueKind::Float64,
            });
        }
        offsets.push(values.len());
        if let Some(dup) = duplicate(&variables) {
            return Err(ParameterError::Duplicate(dup));
        }
        Ok(Self {
            base: scenario_table(scenario)?,
            build,
            inner,
            parameters,
            values,
            offsets,
            changed: false,
            variables,
            first,
            experiment: None,
            pending: Vec::new(),
            initialized: false,
        })
    }

    fn parameter_values(&self, k: usize) -> &[f64] {
        &self.values[self.offsets[k]..self.offsets[k + 1]]
    }

    /// The scenario with the parameters' current values, validated.
    pub fn edited_scenario(&self) -> Result<AnyScenario, EditError> {
        let edits = self
            .parameters
            .iter()
            .enumerate()
            .flat_map(|(k, p)| p.paths.iter().map(String::as_str).zip(self.parameter_values(k).iter().copied()));
        crate::paths::edited_any(&self.base, edits)
    }
}

fn duplicate(variables: &[Variable]) -> Option<String> {
    let mut names: Vec<&str> = variables.iter().map(|v| v.name.as_str()).collect();
    names.sort_unstable();
    names.windows(2).find(|w| w[0] == w[1]).map(|w| w[0].to_string())
}

impl<S: Subsystem> Subsystem for WithParameters<S> {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn variables(&self) -> &[Variable] {
        &self.variables
    }

    fn setup(&mut self, start: Ticks, stop: Option<Ticks>) -> Result<(), SubsystemError> {
        self.inner.setup(start, stop)?;
        self.experiment = Some((start, stop));
        Ok(())
    }

    fn initialize(&mut self) -> Result<(), SubsystemError> {
        if self.changed && !self.initialized {
            let scenario = self.edited_scenario().map_err(|problem| {
                let names: Vec<&str> = self
                    .parameters
                    .iter()
                    .enumerate()
                    .filter(|(k, p)| self.parameter_values(*k) != p.start.as_slice())
                    .map(|(_, p)| p.name.as_str())
                    .collect();
                SubsystemError::BadValue { name: names.join(", "), problem: lash_core::error_chain(&problem) }
            })?;
            let mut inner = (self.build)(&scenario)
                .map_err(|e| SubsystemError::Other(lash_core::error_chain(&ParameterError::Build(e))))?;
            let same = inner.variables().len() == self.first as usize
                && inner.variables().iter().zip(&self.variables).all(|(a, b)| a.name == b.name && a.shape == b.shape);
            if !same {
                return Err(SubsystemError::Other(
                    "the edited parameters change the model's variables (not supported by an FMU)".into(),
                ));
            }
            for (_, refs, values) in self.pending.iter().filter(|p| !p.0) {
                inner.set_f64(refs, values)?;
            }
            if let Some((start, stop)) = self.experiment {
                inner.setup(start, stop)?;
            }
            for (_, refs, values) in self.pending.iter().filter(|p| p.0) {
                inner.set_f64(refs, values)?;
            }
            self.inner = inner;
        }
        self.inner.initialize()?;
        self.initialized = true;
        self.pending = Vec::new();
        Ok(())
    }

    fn set_f64(&mut self, refs: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError> {
        if refs.iter().all(|&r| r < self.first) {
            self.inner.set_f64(refs, values)?;
            if !self.initialized {
                self.pending.push((self.experiment.is_some(), refs.to_vec(), values.to_vec()));
            }
            return Ok(());
        }
        // Mixed or parameter references: check everything first, then apply.
        let mut own_refs = Vec::new();
        let mut own_values = Vec::new();
        let mut updates = Vec::new();
        let mut at = 0;
        for &r in refs {
            let var = self.variables.get(r as usize).ok_or(SubsystemError::UnknownValueReference(r))?;
            let len = var.len();
            let Some(v) = values.get(at..at + len) else {
                let n = lash_core::subsystem::element_count(&self.variables, refs)?;
                return Err(SubsystemError::BadArguments(format!("{} values for {n} elements", values.len())));
            };
            at += len;
            if r < self.first {
                own_refs.push(r);
                own_values.extend_from_slice(v);
                continue;
            }
            if self.initialized {
                return Err(SubsystemError::BadValue {
                    name: var.name.clone(),
                    problem: "is a parameter (fixed): set it before initialization".into(),
                });
            }
            if let Some(bad) = v.iter().find(|x| !x.is_finite()) {
                return Err(SubsystemError::BadValue {
                    name: var.name.clone(),
                    problem: format!("{bad} is not finite"),
                });
            }
            updates.push(((r - self.first) as usize, v.to_vec()));
        }
        if at != values.len() {
            return Err(SubsystemError::BadArguments(format!("{} values for {at} elements", values.len())));
        }
        if !own_refs.is_empty() {
            self.set_f64(&own_refs, &own_values)?;
        }
        for (k, v) in updates {
            let (a, b) = (self.offsets[k], self.offsets[k + 1]);
            if self.values[a..b] != v[..] {
                self.values[a..b].copy_from_slice(&v);
                self.changed = true;
            }
        }
        Ok(())
    }

    fn get_f64(&self, refs: &[ValueReference], values: &mut [f64]) -> Result<(), SubsystemError> {
        if refs.iter().all(|&r| r < self.first) {
            return self.inner.get_f64(refs, values);
        }
        let n = lash_core::subsystem::element_count(&self.variables, refs)?;
        if n != values.len() {
            return Err(SubsystemError::BadArguments(format!("{} values for {n} elements", values.len())));
        }
        let mut at = 0;
        for &r in refs {
            let len = self.variables[r as usize].len();
            let out = &mut values[at..at + len];
            if r < self.first {
                self.inner.get_f64(&[r], out)?;
            } else {
                out.copy_from_slice(self.parameter_values((r - self.first) as usize));
            }
            at += len;
        }
        Ok(())
    }

    fn do_step(&mut self, t: Ticks, h: Ticks) -> Result<StepOutcome, SubsystemError> {
        self.inner.do_step(t, h)
    }

    fn do_steps(
        &mut self,
        t: Ticks,
        h: Ticks,
        record: &[bool],
        refs: &[ValueReference],
        rows: &mut [f64],
    ) -> lash_core::Steps {
        if refs.iter().all(|&r| r < self.first) {
            self.inner.do_steps(t, h, record, refs, rows)
        } else {
            lash_core::subsystem::steps_one_by_one(self, t, h, record, refs, rows)
        }
    }

    fn time(&self) -> Ticks {
        self.inner.time()
    }

    fn save_state(&self) -> Result<SavedState, SubsystemError> {
        self.inner.save_state()
    }

    fn restore_state(&mut self, state: &SavedState) -> Result<(), SubsystemError> {
        self.inner.restore_state(state)
    }

    fn terminate(&mut self) -> Result<(), SubsystemError> {
        self.inner.terminate()
    }
}
