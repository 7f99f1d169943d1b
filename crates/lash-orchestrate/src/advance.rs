//! The algorithm trait, why a run stops, and the one way every master steps a subsystem.

use super::*;

/// A coupling algorithm over its elements: the [`InterfaceMaster`] of the reduced model (two
/// elements, multirate, interpolated) and the [`ConnectedMaster`] (Gauss–Seidel or Jacobi over
/// connections). Whoever runs a coupled model — `lash run --model reduced`, system files, sweeps,
/// `lash bench` — drives it through this trait: signals by name, observers at their intervals,
/// one statistics record, every [`lash_core::StepOutcome`] honoured by [`advance`].
pub trait Algorithm {
    /// Names of the recorded signals, in the order observers receive them.
    fn signal_names(&self) -> Vec<String>;
    /// Initialises the elements and runs to the stop time; observers come with their intervals
    /// and are called at the start time too. An element that ends the run early without an error
    /// is reported in [`MasterStats::stopped`], not as an error.
    fn run(&mut self, observers: &mut [(&mut dyn Observer, Ticks)]) -> Result<MasterStats, MasterError>;
}

/// Why a coupled run stopped.
#[derive(Debug, thiserror::Error)]
pub enum MasterError {
    /// Settings that do not fit together.
    #[error("master settings: {0}")]
    Settings(String),
    /// Steps that do not fit together (ratios, coupling and execution).
    #[error("master settings: {0}")]
    Steps(#[from] StepError),
    /// A variable the coupling needs is missing or has the wrong causality or shape.
    #[error("subsystem {subsystem}: {problem}")]
    Variables {
        /// Which subsystem.
        subsystem: String,
        /// What is missing.
        problem: String,
    },
    /// A subsystem call failed.
    #[error("{subsystem} subsystem: {source}")]
    Subsystem {
        /// Which subsystem.
        subsystem: &'static str,
        /// The error.
        source: SubsystemError,
    },
    /// An observer refused a sample.
    #[error("observer: {0}")]
    Observer(lash_core::BoxError),
    /// An element of a connected execution failed.
    #[error("at t = {} s, element {name:?}: {source}", t.seconds())]
    Element {
        /// Its name.
        name: String,
        /// Communication point of the failing call.
        t: Ticks,
        /// What it said.
        source: SubsystemError,
    },
    /// An element of a connected execution refused its initialization.
    #[error("element {name:?}: initialization refused: {source}")]
    Initialization {
        /// Its index.
        element: usize,
        /// Its name.
        name: String,
        /// What it said.
        source: SubsystemError,
    },
    /// A subsystem ended the run without an error (it asked to stop, or returned early). The
    /// master turns this into [`MasterStats::stopped`]; it reaches callers only from
    /// [`advance`].
    #[error("{subsystem} subsystem {reason}")]
    Stopped {
        /// Which subsystem.
        subsystem: &'static str,
        /// Why.
        reason: StopReason,
    },
}

/// Steps `sub` from `t` by `h` and honours its [`lash_core::StepOutcome`]: `Ok(None)` when the
/// step was completed; `Ok(Some(reason))` when it was completed and the subsystem asks to stop
/// after it (the state at `t + h` is valid: record it, then end the run);
/// [`MasterError::Stopped`] when it returned early or asked to stop inside the step. Every master
/// steps subsystems through this function, so no outcome is mistaken for a completed step.
pub fn advance(
    sub: &mut dyn Subsystem,
    who: &'static str,
    t: Ticks,
    h: Ticks,
) -> Result<Option<StopReason>, MasterError> {
    let outcome = sub.do_step(t, h).map_err(|source| MasterError::Subsystem { subsystem: who, source })?;
    match outcome.stop(t, h) {
        None => Ok(None),
        Some(reason @ StopReason::Requested { reached }) if reached.0 == t.0 + h.0 => Ok(Some(reason)),
        Some(reason) => Err(MasterError::Stopped { subsystem: who, reason }),
    }
}

/// [`advance`] for consecutive steps taken in one call ([`Subsystem::do_steps`], one step per
/// element of `record`, the flagged ones' outputs `refs` read into `rows`): returns how many steps
/// completed (their rows are valid) and, as [`advance`] does, `Ok(None)` when all completed,
/// `Ok(Some(reason))` when the last completed and the subsystem asks to stop after it, and
/// [`MasterError::Stopped`] when one returned early or asked to stop inside its step (that step is
/// not counted).
pub fn advance_steps(
    sub: &mut dyn Subsystem,
    who: &'static str,
    t: Ticks,
    h: Ticks,
    record: &[bool],
    refs: &[ValueReference],
    rows: &mut [f64],
) -> (usize, Result<Option<StopReason>, MasterError>) {
    let steps = sub.do_steps(t, h, record, refs, rows);
    steps_outcome(steps, who, t, h, record.len())
}

/// What [`Subsystem::do_steps`]' result means for a master that asked for `asked` steps of `h`
/// from `t`: the steps completed, and a stop or an error ([`advance_steps`]).
pub(crate) fn steps_outcome(
    steps: lash_core::Steps,
    who: &'static str,
    t: Ticks,
    h: Ticks,
    asked: usize,
) -> (usize, Result<Option<StopReason>, MasterError>) {
    let outcome = match steps.last {
        Ok(outcome) => outcome,
        Err(source) => return (steps.taken, Err(MasterError::Subsystem { subsystem: who, source })),
    };
    if steps.taken == 0 {
        return (0, Ok(None));
    }
    let last = Ticks(t.0 + (steps.taken as i64 - 1) * h.0);
    match outcome.stop(last, h) {
        None if steps.taken == asked => (steps.taken, Ok(None)),
        None => (
            steps.taken,
            Err(MasterError::Subsystem {
                subsystem: who,
                source: SubsystemError::Other(format!(
                    "took {} of {} steps without saying why it stopped",
                    steps.taken, asked
                )),
            }),
        ),
        Some(reason @ StopReason::Requested { reached }) if reached.0 == last.0 + h.0 => {
            (steps.taken, Ok(Some(reason)))
        }
        Some(reason) => (steps.taken - 1, Err(MasterError::Stopped { subsystem: who, reason })),
    }
}

/// [`advance`] for a subsystem whose every stop ends the run at once (the macro subsystem of the
/// interface master, whose nodes run ahead of the micro steps).
pub(crate) fn advance_or_stop(
    sub: &mut dyn Subsystem,
    who: &'static str,
    t: Ticks,
    h: Ticks,
) -> Result<(), MasterError> {
    match advance(sub, who, t, h)? {
        None => Ok(()),
        Some(reason) => Err(MasterError::Stopped { subsystem: who, reason }),
    }
}
