//! Core vocabulary shared by every lash crate: exact integer time ([`Ticks`]), validation
//! problems that name the field they concern ([`Problem`], [`Problems`]), and the FMI-shaped
//! [`Subsystem`] trait with its variable descriptions.
//!
//! No physics and no FFI live here.

mod names;
mod problems;
pub mod subsystem;
mod time;
pub mod units;

pub use names::{csv_header, did_you_mean};
pub use problems::{Problem, Problems, error_chain};
pub use subsystem::{
    Causality, Coupling, Phase, SavedState, StepOutcome, Steps, StopReason, Subsystem, SubsystemError, ValueKind,
    ValueReference, Variability, Variable, VariableTable, check_variable_table, split_element_name,
};
pub use time::{TICKS_PER_SECOND, Ticks, TicksError};
