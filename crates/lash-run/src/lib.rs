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

/// Which model of a scenario to run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Model {
    /// The full model, integrated to convergence (`ideal`: its clearance joints as ideal joints).
    Full {
        /// Clearance joints as ideal joints.
        ideal: bool,
    },
    /// The reduced interface model with these options.
    Reduced(ReducedOptions),
}

/// The runner of `model` for a planar or spatial scenario: the one place that picks it (the
/// command line, sweeps and the Python package all come here). The error says why the model
/// cannot be built (a reduced model asked of an ideal run, an unsupported option).
pub fn runner(scenario: &lash_scenario::AnyScenario, model: Model) -> Result<Box<dyn Runner>, String> {
    use lash_scenario::AnyScenario::{Planar, Spatial};
    Ok(match (scenario, model) {
        (Planar(s), Model::Full { ideal }) => Box::new(FullRun::new(s, BuildOptions { ideal })),
        (Planar(s), Model::Reduced(o)) => Box::new(ReducedRun::new(s, o).map_err(|e| e.to_string())?),
        (Spatial(s), Model::Full { ideal }) => Box::new(SpatialRun::new(s, ideal)),
        (Spatial(s), Model::Reduced(o)) => Box::new(SpatialReducedRun::new(s, o).map_err(|e| e.to_string())?),
    })
}
