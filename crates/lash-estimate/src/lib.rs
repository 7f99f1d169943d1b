//! Diagnosis from measured vibration: how much play each clearance joint has, which joint is the
//! worn one, the nuisance parameters (crank speed, restitution, friction, sensor gain, noise), and
//! how sure the answer is.
//!
//! The method is simulation-based inference on lash's own data generation:
//!
//! * [`setup`]: what is estimated — the scenario, its measurement chain (channel, sample rate,
//!   anti-alias filter) and the priors of the unknowns; built-in setups for A and C.
//! * [`measurement`]: a measured file (CSV or Parquet) read as untrusted input: time stamps, units,
//!   NaN, clipping, sample rate and length checked, each problem named with its column.
//! * [`features`]: order-tracked vibration features that a sensor's gain, the start in the cycle and
//!   the crank speed do not move: the low orders relative to the first (amplitude and phase), the
//!   energy in and between the order lines per band, the impulsiveness of what is left.
//! * [`prepare`]: the one-time preparation: a sweep of the reduced model over the priors (vector
//!   lanes, Parquet), each run measured several times with fresh gain and noise, the features;
//!   a regression of every unknown on the features (the summaries); a calibration on a sweep of the
//!   **full** model with seeds of its own (split-conformal widths, a median shift). Stored as JSON.
//! * [`hidden`]: the virtual sensor: each joint's contact force and eccentricity over the measured
//!   window with bands, from posterior draws simulated again and aligned with the measurement.
//! * [`infer`]: an estimate: the summaries of the measurement, the bank's nearest draws in summary
//!   space (approximate Bayesian computation), their quantiles, calibrated.
//! * [`validate`]: held-out cases from the converged full model, with seeds the preparation never
//!   saw, measured as a real chain would (gain error, noise at 30–60 dB, anti-alias and decimation,
//!   speed off nominal, a random start in the cycle): RMSE, coverage, worn-joint accuracy, time.

pub mod features;
pub mod hidden;
pub mod infer;
pub mod measurement;
pub mod prepare;
pub mod setup;
pub mod track;
pub mod validate;

pub use hidden::Hidden;
pub use infer::{Estimate, Estimator, UnknownEstimate};
pub use measurement::Measurement;
pub use setup::Setup;

/// Why an estimate could not be made.
#[derive(Debug, thiserror::Error)]
pub enum EstimateError {
    /// The measurement, the setup or an option is wrong (the message names the field or column).
    #[error("{0}")]
    Input(String),
    /// A simulation, a file or the fitting failed.
    #[error("{0}")]
    Failure(String),
    /// The measurement file cannot be read (missing, unreadable, or a cell that is not a number:
    /// the file and column named) — an input error.
    #[error(transparent)]
    Measurement(lash_sweep::dataset::DatasetError),
    /// Reading the preparation's dataset failed.
    #[error(transparent)]
    Dataset(#[from] lash_sweep::dataset::DatasetError),
    /// A sweep of the preparation or validation failed.
    #[error(transparent)]
    Sweep(#[from] lash_sweep::SweepError),
    /// A model could not be built or run.
    #[error(transparent)]
    Run(#[from] lash_run::RunError),
    /// The logger's chain does not fit the simulation's output interval.
    #[error(transparent)]
    Acquisition(#[from] lash_measure::AcquisitionError),
}
