//! The [`Subsystem`] trait: what the orchestrator, the FMI export layer and the FMU importer all
//! see of a model. It is shaped after FMI Co-Simulation (2.0 and 3.0):
//!
//! * variables described once ([`Variable`]: name, value reference, causality, variability, unit,
//!   shape, start value), addressed by value reference;
//! * a life cycle `setup → initialize → (set inputs, do_step, get outputs)* → terminate`;
//! * batched, typed get/set of `f64` values by value reference (arrays flattened row-major, as
//!   FMI 3.0 does; FMI 2.0 sees one scalar per element);
//! * `do_step(t, h)` in integer [`Ticks`], returning a [`StepOutcome`];
//! * save/restore of the complete state for rollback.
//!
//! No physics and no FFI here: the physics crates implement the trait, the FMI crate wraps it.

use crate::Ticks;
use std::any::Any;

/// A value reference: the handle of a variable (unique within one subsystem).
pub type ValueReference = u32;

/// How a variable takes part in the coupling (FMI causality).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Causality {
    /// Set before initialisation; constant during a run.
    Parameter,
    /// Set by the master between steps.
    Input,
    /// Read by the master between steps.
    Output,
    /// Internal quantity exposed for observation.
    Local,
}

/// How a variable changes in time (FMI variability).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Variability {
    /// Never changes after initialisation (structural parameters).
    Fixed,
    /// Changes only at communication points (discrete values, counters).
    Discrete,
    /// Changes continuously in time.
    Continuous,
}

/// The description of one variable.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Variable {
    /// Name, dotted for structure (`effective_force`, `slider.ax.gain`).
    pub name: String,
    /// Its handle.
    pub value_reference: ValueReference,
    /// Causality.
    pub causality: Causality,
    /// Variability.
    pub variability: Variability,
    /// SI unit (`kg`, `N`, `m/s^2`, `1` for dimensionless).
    pub unit: String,
    /// One line of description.
    pub description: String,
    /// Array dimensions, empty for a scalar (`[2, 2]` for M̃). Values are flattened row-major.
    pub shape: Vec<usize>,
    /// Start value(s), one per element.
    pub start: Vec<f64>,
}

impl Variable {
    /// Number of `f64` elements (product of the shape, 1 for a scalar).
    pub fn len(&self) -> usize {
        self.shape.iter().product()
    }

    /// True for a zero-sized array.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Builds the variable table of a subsystem, handing out value references in order.
#[derive(Debug, Default, Clone)]
pub struct VariableTable {
    variables: Vec<Variable>,
}

impl VariableTable {
    /// An empty table.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a variable and returns its value reference.
    #[allow(clippy::too_many_arguments)]
    pub fn add(
        &mut self,
        name: impl Into<String>,
        causality: Causality,
        variability: Variability,
        unit: &str,
        description: &str,
        shape: &[usize],
        start: &[f64],
    ) -> ValueReference {
        let vr = self.variables.len() as ValueReference;
        let len: usize = shape.iter().product();
        let start = if start.len() == len { start.to_vec() } else { vec![start.first().copied().unwrap_or(0.0); len] };
        self.variables.push(Variable {
            name: name.into(),
            value_reference: vr,
            causality,
            variability,
            unit: unit.to_string(),
            description: description.to_string(),
            shape: shape.to_vec(),
            start,
        });
        vr
    }

    /// The variables, in value-reference order.
    pub fn variables(&self) -> &[Variable] {
        &self.variables
    }

    /// Consumes the table.
    pub fn into_variables(self) -> Vec<Variable> {
        self.variables
    }
}

/// Looks a variable up by name.
pub fn find_variable<'a>(variables: &'a [Variable], name: &str) -> Option<&'a Variable> {
    variables.iter().find(|v| v.name == name)
}

/// How the macro and micro subsystems of the reduced interface model are coupled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Coupling {
    /// The ideal mechanism's motion is taken as the real one; f_c only feeds the sensors
    /// (seeds 000/001).
    #[default]
    OneWay,
    /// The impulse-averaged contact force acts back on the mechanism, which then runs without the
    /// clearance joint (needed when the motion is not prescribed, e.g. a torque-driven crank).
    TwoWay,
}

/// How a step ended. A master must look at every outcome: only [`StepOutcome::Completed`] means
/// that the subsystem reached `t + h` and may be stepped on; use [`StepOutcome::reached`] and
/// [`StepOutcome::stop`] rather than matching on `Completed` alone.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[must_use = "a step may end early or ask the simulation to stop: the master must honour it"]
pub enum StepOutcome {
    /// The whole step was taken.
    Completed,
    /// The subsystem stopped early at `reached` (for example at an event the master asked to
    /// see); FMI 3.0 `earlyReturn`. Its state is valid at `reached`.
    EarlyReturn {
        /// Time reached.
        reached: Ticks,
    },
    /// The subsystem asks the simulation to end (FMI 3.0 `terminateSimulation`, FMI 2.0
    /// `fmi2Discard` with `fmi2Terminated`). Its state is valid at `reached`; it must not be stepped
    /// again.
    Terminate {
        /// Time reached.
        reached: Ticks,
    },
}

impl StepOutcome {
    /// The time the subsystem reached, for a step from `t` of length `h`.
    pub fn reached(self, t: Ticks, h: Ticks) -> Ticks {
        match self {
            StepOutcome::Completed => Ticks(t.0 + h.0),
            StepOutcome::EarlyReturn { reached } | StepOutcome::Terminate { reached } => reached,
        }
    }

    /// `None` for a completed step, else why the master has to stop.
    pub fn stop(self, t: Ticks, h: Ticks) -> Option<StopReason> {
        match self {
            StepOutcome::Completed => None,
            StepOutcome::EarlyReturn { reached } if reached.0 >= t.0 + h.0 => None,
            StepOutcome::EarlyReturn { reached } => Some(StopReason::EarlyReturn { reached }),
            StepOutcome::Terminate { reached } => Some(StopReason::Requested { reached }),
        }
    }
}

/// Why a master ended a run before its stop time without an error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopReason {
    /// A subsystem asked the simulation to end at `reached`.
    Requested {
        /// Time the subsystem reached.
        reached: Ticks,
    },
    /// A subsystem returned early at `reached`, inside a communication step; lash's masters take
    /// no partial steps, so the run ends at the last communication point every element completed.
    EarlyReturn {
        /// Time the subsystem reached.
        reached: Ticks,
    },
}

impl std::fmt::Display for StopReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StopReason::Requested { reached } => {
                write!(f, "asked to stop the simulation at t = {} s", reached.seconds())
            }
            StopReason::EarlyReturn { reached } => write!(
                f,
                "returned early at t = {} s, inside a communication step (lash's masters take no partial steps)",
                reached.seconds()
            ),
        }
    }
}

/// Errors of a subsystem call. Messages name the variable or the quantity concerned.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SubsystemError {
    /// A value reference that the subsystem does not have.
    #[error("unknown value reference {0}")]
    UnknownValueReference(ValueReference),
    /// A value that cannot be accepted (causality, non-finite, out of range).
    #[error("variable {name}: {problem}")]
    BadValue {
        /// Variable name.
        name: String,
        /// What is wrong.
        problem: String,
    },
    /// Value and reference slices do not fit together.
    #[error("{0}")]
    BadArguments(String),
    /// A call out of the life-cycle order.
    #[error("{call} is not allowed in state {state}")]
    WrongState {
        /// The call made.
        call: &'static str,
        /// The state the subsystem is in.
        state: &'static str,
    },
    /// The simulation failed (a blow-up, a singular system), naming time and quantity.
    #[error("at t = {t} s: {message}")]
    Simulation {
        /// Time [s].
        t: f64,
        /// What happened.
        message: String,
    },
    /// Anything else (a loaded library's failure, an unsupported feature).
    #[error("{0}")]
    Other(String),
}

/// An opaque snapshot of a subsystem's complete state (FMI `FMUstate`).
pub struct SavedState(pub Box<dyn Any + Send>);

impl std::fmt::Debug for SavedState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SavedState(..)")
    }
}

/// A co-simulation subsystem (one FMU, one built-in model, one plugin).
///
/// Call order: [`setup`](Subsystem::setup) once, parameters set, [`initialize`](Subsystem::initialize),
/// then any number of `set_f64` / `do_step` / `get_f64`. Implementations must reject calls out of
/// order with [`SubsystemError::WrongState`] rather than panic.
pub trait Subsystem: Send {
    /// A short name for messages and traces.
    fn name(&self) -> &str;

    /// All variables. Contract: variable `i` has value reference `i` (positions and value
    /// references are one mapping; an importer renumbers a foreign model's references and
    /// translates them at its boundary). [`check_variable_table`] verifies it.
    fn variables(&self) -> &[Variable];

    /// Start time and optional stop time of the experiment (FMI `setupExperiment` /
    /// `enterInitializationMode` arguments). Parameters may be set after this call.
    fn setup(&mut self, start: Ticks, stop: Option<Ticks>) -> Result<(), SubsystemError>;

    /// Computes the initial state from parameters and inputs (FMI enter + exit initialisation mode).
    fn initialize(&mut self) -> Result<(), SubsystemError>;

    /// Sets values: `values` holds the elements of each referenced variable in turn.
    fn set_f64(&mut self, refs: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError>;

    /// Reads values: `values` receives the elements of each referenced variable in turn.
    fn get_f64(&self, refs: &[ValueReference], values: &mut [f64]) -> Result<(), SubsystemError>;

    /// Advances from `t` (must equal the subsystem's current time) by `h`.
    fn do_step(&mut self, t: Ticks, h: Ticks) -> Result<StepOutcome, SubsystemError>;

    /// The subsystem's current time.
    fn time(&self) -> Ticks;

    /// A snapshot of the complete state.
    fn save_state(&self) -> Result<SavedState, SubsystemError>;

    /// Returns to a snapshot taken from this subsystem.
    fn restore_state(&mut self, state: &SavedState) -> Result<(), SubsystemError>;

    /// Ends the run (FMI `terminate`).
    fn terminate(&mut self) -> Result<(), SubsystemError> {
        Ok(())
    }
}

/// The variable with value reference `vr` (its position, by the [`Subsystem::variables`] contract).
pub fn variable(variables: &[Variable], vr: ValueReference) -> Option<&Variable> {
    variables.get(vr as usize).filter(|v| v.value_reference == vr)
}

/// Checks the [`Subsystem::variables`] contract (variable `i` has value reference `i`) and that
/// names are unique; the error names the first offending variable.
pub fn check_variable_table(variables: &[Variable]) -> Result<(), String> {
    let mut names = std::collections::HashSet::with_capacity(variables.len());
    for (i, v) in variables.iter().enumerate() {
        if v.value_reference as usize != i {
            return Err(format!(
                "variable {:?} at position {i} has value reference {} (a subsystem's value references must be its positions)",
                v.name, v.value_reference
            ));
        }
        if !names.insert(v.name.as_str()) {
            return Err(format!("variable name {:?} is used twice", v.name));
        }
    }
    Ok(())
}

/// Total element count of the referenced variables, checking each reference.
pub fn element_count(variables: &[Variable], refs: &[ValueReference]) -> Result<usize, SubsystemError> {
    refs.iter().try_fold(0, |n, &vr| {
        variable(variables, vr).map(|v| n + v.len()).ok_or(SubsystemError::UnknownValueReference(vr))
    })
}

/// The life-cycle states shared by lash's built-in subsystems.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Created, not set up.
    Instantiated,
    /// Set up, parameters may change.
    Configured,
    /// Initialised: stepping allowed.
    Stepping,
    /// A step failed; only save/restore, reading and termination are allowed.
    Failed,
    /// Terminated.
    Terminated,
}

impl Phase {
    /// Name for messages.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Instantiated => "instantiated",
            Phase::Configured => "configured",
            Phase::Stepping => "stepping",
            Phase::Failed => "failed",
            Phase::Terminated => "terminated",
        }
    }

    /// Ok if `self` is one of `allowed`, otherwise the WrongState error for `call`.
    pub fn require(self, call: &'static str, allowed: &[Phase]) -> Result<(), SubsystemError> {
        if allowed.contains(&self) { Ok(()) } else { Err(SubsystemError::WrongState { call, state: self.name() }) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_hands_out_references_in_order_and_sizes_arrays() {
        let mut t = VariableTable::new();
        let a = t.add("effective_mass", Causality::Output, Variability::Continuous, "kg", "M", &[2, 2], &[0.0]);
        let b = t.add("effective_force", Causality::Output, Variability::Continuous, "N", "f", &[2], &[1.0, 2.0]);
        assert_eq!((a, b), (0, 1));
        assert_eq!(t.variables()[0].len(), 4);
        assert_eq!(t.variables()[0].start, vec![0.0; 4]);
        assert_eq!(t.variables()[1].start, vec![1.0, 2.0]);
        assert_eq!(element_count(t.variables(), &[1, 0, 1]).unwrap(), 8);
        assert_eq!(element_count(t.variables(), &[2]), Err(SubsystemError::UnknownValueReference(2)));
        assert_eq!(find_variable(t.variables(), "effective_force").unwrap().value_reference, 1);
    }

    #[test]
    fn phases_refuse_calls_out_of_order() {
        assert!(Phase::Stepping.require("do_step", &[Phase::Stepping]).is_ok());
        let e = Phase::Configured.require("do_step", &[Phase::Stepping]).unwrap_err();
        assert_eq!(e.to_string(), "do_step is not allowed in state configured");
    }
}
