//! The TOML form of a system file.

use serde::Deserialize;
use std::collections::BTreeMap;

/// A whole system file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SystemSpec {
    /// Name (outputs, messages).
    pub name: String,
    /// Start time \[s\].
    #[serde(default)]
    pub start: f64,
    /// Stop time \[s\].
    pub stop: f64,
    /// Communication step \[s\].
    pub step: f64,
    /// Master algorithm.
    #[serde(default)]
    pub algorithm: Algorithm,
    /// How the elements reach their initial values (Gauss–Seidel and Jacobi).
    #[serde(default)]
    pub initialization: Initialization,
    /// The subsystems, stepped in this order.
    pub elements: Vec<ElementSpec>,
    /// Output → input connections.
    #[serde(default)]
    pub connections: Vec<ConnectionSpec>,
    /// What is recorded.
    #[serde(default)]
    pub output: OutputSpec,
    /// With `algorithm = "interface"`: the reduced interface model's coupling.
    #[serde(default)]
    pub interface: Option<InterfaceSpec>,
}

/// The reduced interface model's multirate coupling of a mechanism (macro) element and a
/// clearance-interface (micro) element: M̃, f̃ and their rates forward once per step (interpolated
/// across it), f_c back, and signals propagated at every micro step.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InterfaceSpec {
    /// The macro element (exports effective_mass, effective_force and the propagation maps).
    pub mechanism: String,
    /// The micro element (takes them, returns contact_force).
    pub clearance: String,
    /// Micro step h_r \[s\]; the system's `step` is the macro step h_m.
    pub micro_step: f64,
    /// Interpolation of the macro terms.
    #[serde(default)]
    pub interpolation: lash_orchestrate::Interpolation,
    /// One-way (default) or two-way.
    #[serde(default)]
    pub coupling: lash_core::Coupling,
    /// Sequential (default) or threaded.
    #[serde(default)]
    pub execution: lash_orchestrate::Execution,
    /// The recorded signals, in column order.
    pub signals: Vec<SignalSpec>,
}

/// A recorded signal of the interface master: exactly one of `propagated`, `micro`, `macro`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SignalSpec {
    /// Column name.
    pub name: String,
    /// Propagated to every micro step: `X` names the mechanism outputs `X_free` and `X_gain`
    /// (`slider.acceleration`, `motor.torque`); the value is `X_free[e] + X_gain[e,·] · f_c`.
    #[serde(default)]
    pub propagated: Option<String>,
    /// A clearance-element output at every micro step.
    #[serde(default)]
    pub micro: Option<String>,
    /// A mechanism output interpolated linearly across the macro step.
    #[serde(rename = "macro", default)]
    pub macro_variable: Option<String>,
    /// Element of the variable (row for `propagated`).
    #[serde(default)]
    pub element: usize,
}

/// Master algorithm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Algorithm {
    /// Elements in order, each seeing its predecessors' new outputs.
    #[default]
    GaussSeidel,
    /// All elements from the outputs at the start of the step.
    Jacobi,
    /// The reduced interface model's master over a mechanism and a clearance element (see
    /// [`InterfaceSpec`]).
    Interface,
}

/// How the elements of a Gauss–Seidel or Jacobi system reach their initial values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Initialization {
    /// In file order, each element after reading its inputs' sources (exact for an acyclic
    /// system written sources first).
    #[default]
    Ordered,
    /// As libcosim: all elements in initialization mode, inputs set and outputs read for as many
    /// rounds as there are elements, then all leave it.
    Iterated,
}

/// One element of the system.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ElementSpec {
    /// Unique name; variables are addressed as `name.variable`.
    pub name: String,
    /// An FMU (FMI 2.0 or 3.0 co-simulation), relative to the system file.
    #[serde(default)]
    pub fmu: Option<String>,
    /// A lash plugin (a cdylib built with `lash_fmi::export_plugin!`), relative to the file.
    #[serde(default)]
    pub plugin: Option<String>,
    /// A built-in subsystem: `lash_interface`, `lash_mechanism`, `lash_full`.
    #[serde(default)]
    pub builtin: Option<String>,
    /// Built-ins only: the scenario whose model the built-in is, a built-in scenario name or a
    /// scenario file relative to the system file (default: scenario A with the slider and motor
    /// channels probed, like `lash fmu pack` without a scenario).
    #[serde(default)]
    pub scenario: Option<String>,
    /// Steps every `decimation`-th communication point, by `decimation` communication steps.
    #[serde(default = "one")]
    pub decimation: u32,
    /// Parameter (or start) values by variable name: a number, or a list for an array.
    #[serde(default)]
    pub parameters: BTreeMap<String, ParameterValue>,
    /// Run the FMU in a child process: a crash or a hang of the FMU becomes an error naming the
    /// element, the time and the signal, and the output so far is kept (FMUs only).
    #[serde(default)]
    pub isolate: bool,
    /// With `isolate`: the longest wait for one call of the FMU \[s\] (default 60).
    #[serde(default)]
    pub timeout: Option<f64>,
}

fn one() -> u32 {
    1
}

/// A parameter value: a number, a Boolean, the elements of an array, or text (for a String
/// variable).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum ParameterValue {
    /// A scalar (any numeric variable: integers, enumerations and Booleans take whole numbers).
    Scalar(f64),
    /// A Boolean (`true` = 1, `false` = 0).
    Boolean(bool),
    /// An array's elements (row-major).
    Array(Vec<f64>),
    /// Text, for a String variable.
    Text(String),
}

impl ParameterValue {
    /// The value(s) as numbers; `None` for text.
    pub fn values(&self) -> Option<Vec<f64>> {
        match self {
            ParameterValue::Scalar(v) => Some(vec![*v]),
            ParameterValue::Boolean(b) => Some(vec![f64::from(u8::from(*b))]),
            ParameterValue::Array(v) => Some(v.clone()),
            ParameterValue::Text(_) => None,
        }
    }
}

/// Where an element comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum ElementSource {
    /// An FMU file.
    Fmu(std::path::PathBuf),
    /// A plugin library.
    Plugin(std::path::PathBuf),
    /// A built-in subsystem by model identifier, of a scenario (a built-in name or a file path
    /// resolved against the system file's folder; none: the default scenario).
    Builtin(String, Option<String>),
}

/// An element that does not name exactly one source.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum SourceError {
    /// A scenario given to an FMU or a plugin.
    #[error("scenario: only a built-in element takes a scenario (an FMU carries its own)")]
    ScenarioWithoutBuiltin,
    /// None, or more than one, of fmu, plugin, builtin.
    #[error("give exactly one of fmu, plugin, builtin")]
    NotExactlyOne,
}

impl ElementSpec {
    /// The one source the element names, resolved against the system file's folder.
    pub fn source(&self, base: &std::path::Path) -> Result<ElementSource, SourceError> {
        if self.scenario.is_some() && self.builtin.is_none() {
            return Err(SourceError::ScenarioWithoutBuiltin);
        }
        match (&self.fmu, &self.plugin, &self.builtin) {
            (Some(f), None, None) => Ok(ElementSource::Fmu(base.join(f))),
            (None, Some(p), None) => Ok(ElementSource::Plugin(base.join(p))),
            (None, None, Some(b)) => Ok(ElementSource::Builtin(
                b.clone(),
                self.scenario.as_ref().map(|s| {
                    let file = base.join(s);
                    if file.is_file() { file.display().to_string() } else { s.clone() }
                }),
            )),
            _ => Err(SourceError::NotExactlyOne),
        }
    }
}

/// A connection from an output to an input (`element.variable`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConnectionSpec {
    /// Source output.
    pub from: String,
    /// Target input.
    pub to: String,
}

/// Recording.
#[derive(Debug, Clone, PartialEq, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Sampling interval \[s\], a multiple of the step (default: the step).
    #[serde(default)]
    pub interval: Option<f64>,
    /// `element.variable` names (default: every output of every element).
    #[serde(default)]
    pub channels: Vec<String>,
}

/// Parses a TOML system file (the error names the line and the field).
pub fn parse(text: &str) -> Result<SystemSpec, toml::de::Error> {
    toml::from_str(text)
}
