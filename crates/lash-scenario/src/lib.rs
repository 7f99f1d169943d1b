//! Scenario files of lash and the full-model runner.
//!
//! * [`schema`]: the TOML format (serde structs, units documented).
//! * [`parse`]: reads a file and returns either a valid [`Scenario`] or every problem, each with
//!   its field path (`bodies[1].mass: must be > 0, got -1`).
//! * [`builtin`]: scenarios A and B (and variants) by name.
//! * [`FullRun`]: builds the full (or ideal) model, integrates it, samples every output channel and
//!   returns a [`Summary`].

pub mod bench;
pub mod build;
pub mod builtin;
pub mod channels;
pub mod full_subsystem;
mod load;
pub mod parameters;
pub mod paths;
mod record;
pub mod reduced;
pub mod run;
pub mod schema;

pub use build::{BuildOptions, build_model};
pub use channels::{Channel, channel_names, channels};
pub use full_subsystem::FullSubsystem;
pub use load::{by_name_or_file, parse, read_file, validate};
pub use parameters::WithParameters;
pub use reduced::{ReducedOptions, ReducedRun};
pub use run::{ChannelStats, ClearanceSummary, FullRun, RunError, Runner, Summary};
pub use schema::Scenario;
