//! Core vocabulary shared by every lash crate: exact integer time ([`Ticks`]), validation
//! problems that name the field they concern ([`Problem`], [`Problems`]), the FMI-shaped
//! [`Subsystem`] trait with its variable descriptions, and the number type of physics written
//! once for one run or eight side by side ([`lane::Real`]).
//!
//! No physics and no FFI live here.

pub mod lane;
mod names;
mod problems;
pub mod subsystem;
mod time;
pub mod units;

pub use names::{csv_header, did_you_mean};
pub use problems::{Problem, Problems, error_chain};
pub use subsystem::{
    AsSubsystem, Causality, Coupling, MacroPorts, Phase, PrescribedInterface, SavedPorts, SavedState, StepOutcome,
    Steps, StopReason, Subsystem, SubsystemError, TwoWayInputs, ValueError, ValueKind, ValueReference, Variability,
    Variable, VariableTable, VariableTableError, check_variable_table, split_element_name,
};
pub use time::{TICKS_PER_SECOND, Ticks, TicksError};

/// Any error with its chain of sources, for what callers plug in (an output sink, an observer, a
/// model builder): lash passes it on without knowing its type, and [`error_chain`] prints it.
pub type BoxError = Box<dyn std::error::Error + Send + Sync + 'static>;
