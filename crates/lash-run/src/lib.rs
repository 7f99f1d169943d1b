//! Runners of lash: a scenario's model built and driven to sampled channels and a summary.
//!
//! * [`build`]: the full (or ideal) multibody model of a scenario ([`build_model`]).
//! * [`FullRun`]: integrates the full model to convergence and samples every output channel.
//! * [`ReducedRun`]: the reduced interface model — the ideal mechanism (macro) and the clearance
//!   interface (micro) as subsystems on lash-orchestrate's execution engine.
//! * [`SpatialRun`]: the full model (or the ideal mechanism) of a spatial scenario.
//! * [`FullSubsystem`]: the full model as a co-simulation subsystem (its FMU's model).
//! * Both runners implement [`Runner`] and return the same [`Summary`].

pub mod bench;
pub mod build;
pub mod full_subsystem;
pub mod measure;
mod record;
pub mod reduced;
pub mod run;
pub mod spatial;

pub use build::{BuildOptions, build_model};
pub use full_subsystem::FullSubsystem;
pub use reduced::{ReducedOptions, ReducedRun};
pub use run::{ChannelStats, ClearanceSummary, FullRun, RunError, Runner, Summary};
pub use spatial::{SpatialReducedRun, SpatialRun, build_spatial};
