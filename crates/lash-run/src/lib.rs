//! Runners of lash: a scenario's model built and driven to sampled channels and a summary.
//!
//! * [`build`]: the full (or ideal) multibody model of a scenario ([`build_model`]).
//! * [`FullRun`]: integrates the full model to convergence and samples every output channel.
//! * [`ReducedRun`]: the reduced interface model — the ideal mechanism (macro) and the clearance
//!   interface (micro) as subsystems on lash-orchestrate's execution engine.
//! * [`SpatialRun`]: the full model (or the ideal mechanism) of a spatial scenario.
//! * [`FullSubsystem`]: the full model as a co-simulation subsystem (its FMU's model).
//! * Every runner implements [`Runner`] and returns the same [`Summary`]; [`runner`] picks one
//!   ([`AnyRunner`]).

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
pub use reduced::{ReducedOptions, ReducedParts, ReducedRun};
pub use run::{
    ChannelStats, ClearanceSummary, ContactSamples, FullRun, MACRO_STEP_ANGLE, RunError, Runner, Sink, Summary,
    macro_step_for_rotation, micro_step_for_unheld_contacts, micro_step_ladder, resolving_micro_step,
};
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

/// A runner of either model of either kind of scenario, as [`runner`] picks it. The variants
/// are the runners' own types: a batch ([`execute_together`]) finds its planar reduced runs by
/// matching, without asking a trait object what it is. (Boxed: the runners differ in size by
/// kilobytes.)
pub enum AnyRunner {
    /// A planar scenario's full (or ideal) model.
    Full(Box<FullRun>),
    /// A planar scenario's reduced model.
    Reduced(Box<ReducedRun>),
    /// A spatial scenario's full (or ideal) model.
    Spatial(Box<SpatialRun>),
    /// A spatial scenario's reduced model.
    SpatialReduced(Box<SpatialReducedRun>),
}

impl AnyRunner {
    /// Column names with units, time first ([`Runner::header`]).
    pub fn header(&self) -> Vec<String> {
        self.runner().header()
    }

    /// Runs the horizon ([`Runner::execute`]).
    pub fn execute(&mut self, sink: Sink<'_>, progress: &mut dyn FnMut(f64)) -> Result<Summary, RunError> {
        self.runner_mut().execute(sink, progress)
    }

    fn runner(&self) -> &dyn Runner {
        match self {
            AnyRunner::Full(r) => &**r,
            AnyRunner::Reduced(r) => &**r,
            AnyRunner::Spatial(r) => &**r,
            AnyRunner::SpatialReduced(r) => &**r,
        }
    }

    fn runner_mut(&mut self) -> &mut dyn Runner {
        match self {
            AnyRunner::Full(r) => &mut **r,
            AnyRunner::Reduced(r) => &mut **r,
            AnyRunner::Spatial(r) => &mut **r,
            AnyRunner::SpatialReduced(r) => &mut **r,
        }
    }
}

/// The runner of `model` for a planar or spatial scenario: the one place that picks it (the
/// command line, sweeps and the Python package all come here). The error says why the model
/// cannot be built (a reduced model asked of an ideal run, an unsupported option).
pub fn runner(scenario: &lash_scenario::AnyScenario, model: Model) -> Result<AnyRunner, RunError> {
    use lash_scenario::AnyScenario::{Planar, Spatial};
    Ok(match (scenario, model) {
        (Planar(s), Model::Full { ideal }) => AnyRunner::Full(Box::new(FullRun::new(s, BuildOptions { ideal }))),
        (Planar(s), Model::Reduced(o)) => AnyRunner::Reduced(Box::new(ReducedRun::new(s, o)?)),
        (Spatial(s), Model::Full { ideal }) => AnyRunner::Spatial(Box::new(SpatialRun::new(s, ideal))),
        (Spatial(s), Model::Reduced(o)) => AnyRunner::SpatialReduced(Box::new(SpatialReducedRun::new(s, o)?)),
    })
}

/// Executes several runners, run i's rows to `sinks[i]`, with the result each gives alone:
/// reduced runs go side by side, planar and spatial apart ([`ReducedRun::execute_together`],
/// [`SpatialReducedRun::execute_together`]: their micro models stepped in vector lanes where they
/// can be — the same rows and summaries bit for bit, the CPU and wall times shared), the others
/// one after the other. Nothing reports progress.
pub fn execute_together(runners: &mut [AnyRunner], sinks: Vec<Sink<'_>>) -> Vec<Result<Summary, RunError>> {
    assert_eq!(runners.len(), sinks.len(), "one sink per runner");
    let mut results: Vec<Option<Result<Summary, RunError>>> = runners.iter().map(|_| None).collect();
    let (mut planar, mut planar_sinks, mut planar_members) = (Vec::new(), Vec::new(), Vec::new());
    let (mut spatial, mut spatial_sinks, mut spatial_members) = (Vec::new(), Vec::new(), Vec::new());
    for (i, (runner, sink)) in runners.iter_mut().zip(sinks).enumerate() {
        match runner {
            AnyRunner::Reduced(run) => {
                planar.push(&mut **run);
                planar_sinks.push(sink);
                planar_members.push(i);
            }
            AnyRunner::SpatialReduced(run) => {
                spatial.push(&mut **run);
                spatial_sinks.push(sink);
                spatial_members.push(i);
            }
            other => results[i] = Some(other.execute(sink, &mut |_| {})),
        }
    }
    let planar = planar_members.into_iter().zip(ReducedRun::execute_together(&mut planar, planar_sinks));
    let spatial = spatial_members.into_iter().zip(SpatialReducedRun::execute_together(&mut spatial, spatial_sinks));
    for (i, r) in planar.chain(spatial) {
        results[i] = Some(r);
    }
    results.into_iter().map(|r| r.expect("every runner ran")).collect()
}
