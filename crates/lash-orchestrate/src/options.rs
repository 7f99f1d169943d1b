//! The interface master's settings and their one check.

use super::*;

/// Interpolation of the macro terms across a macro step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Interpolation {
    /// Linear between the two nodes of the step (the default).
    #[default]
    Linear,
    /// Cubic Hermite with slopes from the neighbouring nodes (Catmull–Rom; one-sided at the ends).
    CubicHermite,
    /// Held at the first node (produces spurious impacts: for study only).
    ZeroOrderHold,
}

/// Sequential or threaded execution.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Execution {
    /// One thread.
    #[default]
    Sequential,
    /// Macro subsystem on a producer thread, micro subsystem on the calling thread (one-way only).
    Threaded,
}

/// Settings of a coupled run.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct MasterOptions {
    /// Start time.
    pub start: Ticks,
    /// Stop time (start + a whole number of macro steps).
    pub stop: Ticks,
    /// Macro communication step h_m.
    pub macro_step: Ticks,
    /// Micro communication step h_r (h_m / h_r an integer).
    pub micro_step: Ticks,
    /// Interpolation of the coupling inputs.
    pub interpolation: Interpolation,
    /// One-way or two-way.
    pub coupling: Coupling,
    /// Sequential or threaded.
    pub execution: Execution,
}

/// Steps that do not fit together; each names the quantities and their values.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StepError {
    /// The macro step is not a whole multiple of the micro step.
    #[error("macro step {macro_step} s is not a whole multiple of the micro step {micro_step} s")]
    NotWholeMicroSteps {
        /// Macro step \[s\].
        macro_step: f64,
        /// Micro step \[s\].
        micro_step: f64,
    },
    /// More micro steps per macro step than the master holds rows for.
    #[error(
        "micro step {micro_step} s: {ratio} micro steps per macro step of {macro_step} s, more than the \
         {MAX_MICRO_STEPS_PER_MACRO} whose rows the master holds at once (a micro step below {} s is not supported \
         at this macro step)",
        macro_step / MAX_MICRO_STEPS_PER_MACRO as f64
    )]
    TooManyMicroSteps {
        /// Micro step \[s\].
        micro_step: f64,
        /// Macro step \[s\].
        macro_step: f64,
        /// Micro steps per macro step.
        ratio: i64,
    },
    /// The run is not a whole, positive number of macro steps.
    #[error(
        "the run from {start} s to {stop} s (horizon) is not a whole, positive multiple of the macro step {macro_step} s"
    )]
    NotWholeMacroSteps {
        /// Start \[s\].
        start: f64,
        /// Stop \[s\].
        stop: f64,
        /// Macro step \[s\].
        macro_step: f64,
    },
    /// The output interval is not a whole multiple of the micro step.
    #[error("output interval {interval} s is not a whole multiple of the micro step {micro_step} s")]
    OutputInterval {
        /// Output interval \[s\].
        interval: f64,
        /// Micro step \[s\].
        micro_step: f64,
    },
    /// Two-way coupling asked to run threaded.
    #[error("two-way coupling runs sequentially: the macro step needs the micro result of the step before")]
    TwoWayThreaded,
}

impl MasterOptions {
    /// The one check of a master's steps, used by every runner and file format before anything
    /// is built: the macro step a whole multiple of the micro step, at most
    /// [`MAX_MICRO_STEPS_PER_MACRO`] times it; the run a whole, positive number of macro steps;
    /// two-way coupling sequential. Returns the micro steps per macro step.
    pub fn check(&self) -> Result<i64, StepError> {
        let ratio = check_step_ratio(self.macro_step, self.micro_step)?;
        if Ticks(self.stop.0 - self.start.0).exact_ratio(self.macro_step).is_none_or(|n| n < 1) {
            return Err(StepError::NotWholeMacroSteps {
                start: self.start.seconds(),
                stop: self.stop.seconds(),
                macro_step: self.macro_step.seconds(),
            });
        }
        if self.coupling == Coupling::TwoWay && self.execution == Execution::Threaded {
            return Err(StepError::TwoWayThreaded);
        }
        Ok(ratio)
    }

    /// Checks that samples every `interval` fall on micro steps.
    pub fn check_sampling(&self, interval: Ticks) -> Result<(), StepError> {
        match interval.exact_ratio(self.micro_step) {
            Some(n) if n >= 1 => Ok(()),
            _ => Err(StepError::OutputInterval { interval: interval.seconds(), micro_step: self.micro_step.seconds() }),
        }
    }
}

/// The most micro steps one macro step may hold: the master keeps a macro step's micro rows in
/// one buffer, allocated before the run, so the ratio sizes memory.
pub const MAX_MICRO_STEPS_PER_MACRO: i64 = 100_000;

/// Checks that `macro_step` is a whole multiple of `micro_step`, at most
/// [`MAX_MICRO_STEPS_PER_MACRO`] times it; returns the ratio (part of [`MasterOptions::check`]).
pub fn check_step_ratio(macro_step: Ticks, micro_step: Ticks) -> Result<i64, StepError> {
    let ratio = macro_step
        .exact_ratio(micro_step)
        .ok_or(StepError::NotWholeMicroSteps { macro_step: macro_step.seconds(), micro_step: micro_step.seconds() })?;
    if ratio > MAX_MICRO_STEPS_PER_MACRO {
        return Err(StepError::TooManyMicroSteps {
            micro_step: micro_step.seconds(),
            macro_step: macro_step.seconds(),
            ratio,
        });
    }
    Ok(ratio)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn options(start: f64, stop: f64, macro_step: f64, micro_step: f64) -> MasterOptions {
        let t = |s: f64| Ticks::from_seconds(s).unwrap();
        MasterOptions {
            start: t(start),
            stop: t(stop),
            macro_step: t(macro_step),
            micro_step: t(micro_step),
            interpolation: Interpolation::Linear,
            coupling: Coupling::OneWay,
            execution: Execution::Sequential,
        }
    }

    /// The one check of a master's steps: each misfit is refused with its own variant (and the
    /// values in its message), a fitting setting gives its micro steps per macro step.
    #[test]
    fn the_steps_are_checked_in_one_place() {
        assert_eq!(options(0.0, 0.036, 1e-3, 1e-5).check(), Ok(100));
        assert_eq!(options(0.0, 0.036, 1e-3, 5e-6).check(), Ok(200));
        assert!(matches!(options(0.0, 0.036, 1e-3, 3e-6).check(), Err(StepError::NotWholeMicroSteps { .. })));
        assert!(matches!(
            options(0.0, 0.036, 1.0, 1e-6).check(),
            Err(StepError::TooManyMicroSteps { ratio: 1_000_000, .. })
        ));
        let e = options(0.0, 0.0365, 1e-3, 1e-5).check().unwrap_err();
        assert!(matches!(e, StepError::NotWholeMacroSteps { .. }) && e.to_string().contains("0.0365"), "{e}");
        assert!(matches!(options(0.0, 0.0, 1e-3, 1e-5).check(), Err(StepError::NotWholeMacroSteps { .. })));
        let two_way_threaded = MasterOptions {
            coupling: Coupling::TwoWay,
            execution: Execution::Threaded,
            ..options(0.0, 0.01, 1e-3, 1e-5)
        };
        assert_eq!(two_way_threaded.check(), Err(StepError::TwoWayThreaded));
        let o = options(0.0, 0.01, 1e-3, 5e-6);
        assert_eq!(o.check_sampling(Ticks::from_seconds(1e-5).unwrap()), Ok(()));
        assert!(matches!(o.check_sampling(Ticks::from_seconds(7e-6).unwrap()), Err(StepError::OutputInterval { .. })));
    }
}
