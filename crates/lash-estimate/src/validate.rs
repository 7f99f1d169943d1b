//! Validation on held-out cases: truths from the converged full model (the scenario's own
//! error-controlled integrator), runs and measurements seeded apart from anything the preparation
//! used, measured by the same chain a user's sensor is emulated with — gain error, noise at a
//! drawn signal-to-noise ratio, anti-alias filter and decimation, crank speed off nominal, a
//! random start in the cycle. Nothing here feeds back into the estimator.

use crate::EstimateError;
use crate::infer::Estimator;
use crate::prepare::{Progress, Purpose, draws};
use crate::setup::Scale;
use lash_sweep::spec::ModelKind;
use serde::Serialize;
use std::path::Path;

/// How well one unknown is estimated.
#[derive(Debug, Clone, Serialize)]
pub struct UnknownScore {
    /// The unknown.
    pub name: String,
    /// Root-mean-square error of the median: relative to the truth for a clearance (log scale),
    /// in the unknown's unit otherwise.
    pub rmse: f64,
    /// The same error for the prior's midpoint as the estimate (what knowing nothing gives).
    pub prior_rmse: f64,
    /// Share of cases whose truth lies in the 5–95 % interval.
    pub coverage: f64,
    /// Whether `rmse` is relative.
    pub relative: bool,
}

/// The validation's figures.
#[derive(Debug, Clone, Serialize)]
pub struct ValidationReport {
    /// The setup.
    pub setup: String,
    /// Held-out cases estimated.
    pub cases: usize,
    /// Full-model runs that failed (left out).
    pub failed_runs: u64,
    /// Seed of the held-out runs.
    pub seed: u64,
    /// Every unknown.
    pub unknowns: Vec<UnknownScore>,
    /// Relative RMSE of the worn joint's clearance (the only one, with one joint).
    pub worn_clearance_rmse: f64,
    /// Coverage of the worn joint's clearance interval.
    pub worn_clearance_coverage: f64,
    /// With several joints: share of cases whose worn joint has the highest probability.
    pub worn_joint_accuracy: Option<f64>,
    /// Mean wall time of one estimate from measured samples (features and inference) \[s\].
    pub seconds_per_estimate: f64,
    /// Wall time of the held-out full-model runs \[s\].
    pub simulation_s: f64,
}

/// Estimates `cases` held-out cases of `model` (seed `seed`) and scores the answers. The full model
/// is the validation; the reduced model (the bank's own) tells the method's error from the
/// reduced model's.
pub fn validate(
    estimator: &Estimator,
    (cases, model): (u64, ModelKind),
    seed: u64,
    work: &Path,
    progress: Progress<'_>,
) -> Result<ValidationReport, EstimateError> {
    let mut setup = estimator.setup.clone();
    setup.seed = seed;
    let r = setup.resolve()?;
    let clock = std::time::Instant::now();
    let (held_out, failed) = draws(&setup, &r, model, Purpose::Validation, (cases, 1), work, progress)?;
    let simulation_s = clock.elapsed().as_secs_f64();
    if held_out.is_empty() {
        return Err(EstimateError::Failure("no held-out case could be simulated".into()));
    }
    let mut seconds = 0.0;
    let estimates: Vec<_> = held_out
        .iter()
        .map(|d| {
            let clock = std::time::Instant::now();
            let e = estimator.estimate(&d.features, 0.0);
            seconds += d.seconds + clock.elapsed().as_secs_f64();
            e
        })
        .collect();
    let n = held_out.len() as f64;
    let joints = estimator.joints.len();
    let unknowns = estimator
        .unknowns
        .iter()
        .enumerate()
        .map(|(k, u)| {
            let relative = u.scale == Scale::Log;
            let error =
                |estimate: f64, truth: f64| if relative { (estimate - truth) / truth } else { estimate - truth };
            let midpoint = 0.5 * (u.low + u.high);
            let (mut se, mut prior_se, mut hit) = (0.0, 0.0, 0usize);
            for (d, e) in held_out.iter().zip(&estimates) {
                let (t, est) = (d.truth[k], &e.unknowns[k]);
                se += error(est.median, t).powi(2);
                prior_se += error(midpoint, t).powi(2);
                hit += usize::from(est.low <= t && t <= est.high);
            }
            UnknownScore {
                name: u.name.clone(),
                rmse: (se / n).sqrt(),
                prior_rmse: (prior_se / n).sqrt(),
                coverage: hit as f64 / n,
                relative,
            }
        })
        .collect();
    let worn_of = |t: &[f64]| (0..joints).max_by(|&a, &b| t[a].total_cmp(&t[b])).unwrap_or(0);
    let (mut se, mut hit, mut right) = (0.0, 0usize, 0usize);
    // With several joints the worn one's clearance is an unknown of its own (the last).
    let worn_index = |j: usize| if joints > 1 { estimator.unknowns.len() - 1 } else { j };
    for (d, e) in held_out.iter().zip(&estimates) {
        let j = worn_of(&d.truth);
        let (t, est) = (d.truth[j], &e.unknowns[worn_index(j)]);
        se += ((est.median - t) / t).powi(2);
        hit += usize::from(est.low <= t && t <= est.high);
        let guess = (0..e.worn.len()).max_by(|&a, &b| e.worn[a].1.total_cmp(&e.worn[b].1)).unwrap_or(0);
        right += usize::from(guess == j);
    }
    Ok(ValidationReport {
        setup: estimator.setup.name.clone(),
        cases: held_out.len(),
        failed_runs: failed,
        seed,
        unknowns,
        worn_clearance_rmse: (se / n).sqrt(),
        worn_clearance_coverage: hit as f64 / n,
        worn_joint_accuracy: (joints > 1).then_some(right as f64 / n),
        seconds_per_estimate: seconds / n,
        simulation_s,
    })
}
