//! The one-time preparation of an estimator, and the simulated, measured draws it and the
//! validation are made of.
//!
//! Draws come from lash's sweeps (random sampling over the priors, Parquet datasets; reduced runs
//! step eight at a time in vector lanes): each run's channel is sampled behind the logger's
//! anti-alias filter at the logger's rate, its start-up dropped, and then measured
//! [`Setup::measurements_per_run`] times as a sensor would: a gain error and white noise at a drawn
//! signal-to-noise ratio, from a seed of (purpose, run, measurement). The crank frequency is
//! estimated from the measured signal itself, as it is for a user's file.

use crate::EstimateError;
use crate::features;
use crate::infer::{Draw, Estimator};
use crate::setup::{Resolved, Setup};
use lash_sweep::spec::{AntiAlias, ModelKind, Output, Parameter, Range, ReducedSteps, Sampling};
use lash_sweep::{ExecuteOptions, SweepSpec};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use std::path::Path;

/// What a set of draws is for: each purpose has seeds of its own.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Purpose {
    /// The reduced-model bank of the preparation.
    Bank,
    /// The full-model calibration of the preparation.
    Calibration,
    /// Held-out full-model cases (never seen by the preparation).
    Validation,
}

impl Purpose {
    /// The sweep seed of this purpose for setup seed `seed` and worn joint `joint`.
    fn sweep_seed(self, seed: u64, joint: usize) -> u64 {
        let code = match self {
            Purpose::Bank => 0x6261_6e6b,
            Purpose::Calibration => 0x6361_6c69,
            Purpose::Validation => 0x7661_6c69,
        };
        seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ (code << 8) ^ joint as u64
    }
}

/// Progress of a preparation or validation: (stage, done, total).
pub type Progress<'a> = &'a (dyn Fn(&str, u64, u64) + Sync);

/// The sweep of the runs in which joint `worn` is the worn one.
fn sweep_spec(setup: &Setup, r: &Resolved, model: ModelKind, runs: u64, seed: u64, worn: usize) -> SweepSpec {
    let uniform = |path: String, low: f64, high: f64| Parameter {
        path,
        values: None,
        linspace: None,
        uniform: Some(Range { low, high }),
    };
    let mut parameters: Vec<Parameter> = r
        .journal_radii
        .iter()
        .enumerate()
        .map(|(j, rj)| {
            let [low, high] = if j == worn { setup.clearance } else { setup.healthy.unwrap_or(setup.clearance) };
            uniform(format!("clearances[{j}].bearing_radius"), rj + low, rj + high)
        })
        .collect();
    let w = &r.unknowns[r.joints.len()];
    parameters.push(uniform("drivers[0].motion.omega".into(), w.low, w.high));
    parameters.push(uniform("drivers[0].motion.angle0".into(), 0.0, std::f64::consts::TAU));
    parameters.extend(setup.nuisance.iter().map(|n| uniform(n.path.clone(), n.low, n.high)));
    SweepSpec {
        base: setup.base.clone(),
        model,
        sampling: Sampling::Random,
        runs: Some(runs),
        seed,
        // Past the window by a sample, in whole macro steps (the reduced model needs them).
        horizon: Some(
            ((setup.settle + setup.window + 1.0 / setup.sample_rate) / setup.macro_step).ceil() * setup.macro_step,
        ),
        reduced: Some(ReducedSteps { macro_step: setup.macro_step, micro_step: setup.micro_step }),
        output: Output {
            channels: setup.channels.iter().map(|c| c.name.clone()).collect(),
            sample_rate: setup.sample_rate,
            noise: Default::default(),
            csv: false,
            anti_alias: Some(AntiAlias { cutoff: setup.anti_alias, order: 4 }),
            clean: false,
        },
        parameters,
    }
}

/// A simulated run: its parameter values (the sweep's order) and its logged channels.
struct Run {
    id: u64,
    values: Vec<f64>,
    channels: Vec<Vec<f64>>,
}

/// Runs one sweep into `dir` and calls `each` with batches of its completed runs.
fn sweep_runs(
    spec: SweepSpec,
    (settle, samples_kept): (f64, usize),
    r: &Resolved,
    dir: &Path,
    progress: Progress<'_>,
    stage: &str,
    each: &mut dyn FnMut(Vec<Run>) -> Result<(), EstimateError>,
) -> Result<u64, EstimateError> {
    let fail = EstimateError::Failure;
    let text = toml::to_string(&spec).map_err(|e| fail(e.to_string()))?;
    let plan = lash_sweep::Plan::new(spec, text, r.scenario.clone())
        .map_err(|p| EstimateError::Input(format!("the {stage} sweep: {p}")))?;
    let total = plan.runs.len() as u64;
    let done = std::sync::atomic::AtomicU64::new(0);
    let options = ExecuteOptions {
        out: dir.to_path_buf(),
        shard: None,
        threads: None,
        cancel: None,
        side_by_side: lash_sweep::SIDE_BY_SIDE,
    };
    let report = lash_sweep::execute(&plan, &options, &|event| {
        if let lash_sweep::Event::Finished { .. } = event {
            let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            progress(stage, n, total);
        }
    })?;
    let params = lash_sweep::dataset::read_params_table(dir)?;
    let values_of: std::collections::HashMap<u64, &Vec<f64>> =
        params.rows.iter().map(|row| (row.run_id, &row.values)).collect();
    let layout = lash_sweep::dataset::read_layout(dir)?;
    for batch in (0..layout.len()).collect::<Vec<_>>().chunks(64) {
        let arrays = lash_sweep::dataset::read_runs(dir, Some(batch))?;
        let (samples, width) = (arrays.time.len(), arrays.channels.len());
        let start = arrays.time.iter().position(|&t| t >= settle - 1e-9).unwrap_or(samples);
        let end = (start + samples_kept).min(samples);
        let runs = arrays
            .run_ids
            .iter()
            .enumerate()
            .map(|(k, &id)| {
                let values = values_of.get(&id).map(|v| (*v).clone());
                let channels = (0..width)
                    .map(|c| (start..end).map(|s| arrays.values[(k * samples + s) * width + c]).collect())
                    .collect();
                values.map(|values| Run { id, values, channels })
            })
            .collect::<Option<Vec<Run>>>()
            .ok_or_else(|| fail(format!("{}: a run without its parameters", dir.display())))?;
        each(runs)?;
    }
    Ok(report.failed)
}

/// The truth vector of a run (the unknowns' order) from its sweep values, gain and SNR.
fn truth(setup: &Setup, r: &Resolved, values: &[f64], gain: f64, snr: f64) -> Vec<f64> {
    let joints = r.joints.len();
    let mut t: Vec<f64> = (0..joints).map(|j| values[j] - r.journal_radii[j]).collect();
    t.push(values[joints]);
    t.extend_from_slice(&values[joints + 2..joints + 2 + setup.nuisance.len()]);
    t.extend([gain, snr]);
    if joints > 1 {
        t.push(t[..joints].iter().copied().fold(f64::NEG_INFINITY, f64::max));
    }
    t
}

/// A measurement of `clean` as a sensor makes it: gain, then white noise at `snr` dB of the
/// channel's own RMS (about its mean).
pub fn measure(clean: &[f64], gain: f64, snr: f64, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let mean = clean.iter().sum::<f64>() / clean.len().max(1) as f64;
    let rms = (clean.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / clean.len().max(1) as f64).sqrt();
    let sigma = gain.abs() * rms * 10f64.powf(-snr / 20.0);
    clean
        .iter()
        .map(|v| {
            let n: f64 = StandardNormal.sample(rng);
            gain * v + sigma * n
        })
        .collect()
}

/// The crank frequency and features of measured channels.
pub fn measured_features(e: &Setup, band_hz: (f64, f64), channels: &[Vec<f64>]) -> Option<(f64, Vec<f64>)> {
    if e.envelope {
        let f0 = features::crank_frequency(&features::envelope(&channels[0]), e.sample_rate, band_hz)?;
        return Some((f0, features::housing_features(channels, e.sample_rate, f0, e.anti_alias)));
    }
    let f0 = features::crank_frequency(&channels[0], e.sample_rate, band_hz)?;
    Some((f0, features::features(channels, e.sample_rate, f0, e.anti_alias)))
}

/// Simulated, measured draws: `runs` runs of `model` (split evenly over the joints that may be
/// the worn one), each measured `per_run` times. Returns the draws and the failed runs.
pub fn draws(
    setup: &Setup,
    r: &Resolved,
    model: ModelKind,
    purpose: Purpose,
    (runs, per_run): (u64, u64),
    work: &Path,
    progress: Progress<'_>,
) -> Result<(Vec<Draw>, u64), EstimateError> {
    let joints = r.joints.len();
    let band = speed_band_hz(r);
    let mut all = Vec::new();
    let mut failed = 0;
    for worn in 0..joints {
        let n = runs / joints as u64 + u64::from((worn as u64) < runs % joints as u64);
        let seed = purpose.sweep_seed(setup.seed, worn);
        let spec = sweep_spec(setup, r, model, n, seed, worn);
        let dir = work.join(format!("{purpose:?}-{worn}").to_lowercase());
        let stage = format!(
            "{purpose:?} ({} model{})",
            if model == ModelKind::Full { "full" } else { "reduced" },
            if joints > 1 { format!(", joint {} worn", r.joints[worn]) } else { String::new() }
        );
        let kept = (setup.settle, (setup.window * setup.sample_rate).round() as usize);
        failed += sweep_runs(spec, kept, r, &dir, progress, &stage, &mut |batch: Vec<Run>| {
            let made: Vec<Draw> = batch
                .par_iter()
                .flat_map_iter(|run| {
                    (0..per_run).filter_map(move |m| {
                        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6d65_6173);
                        rng.set_stream(run.id * 1024 + m);
                        let gain = 1.0 + setup.gain_error * rng.random_range(-1.0..=1.0);
                        let snr = rng.random_range(setup.snr_db[0]..=setup.snr_db[1]);
                        let measured: Vec<Vec<f64>> =
                            run.channels.iter().map(|c| measure(c, gain, snr, &mut rng)).collect();
                        let clock = std::time::Instant::now();
                        let (_, features) = measured_features(setup, band, &measured)?;
                        let seconds = clock.elapsed().as_secs_f64();
                        Some(Draw { features, truth: truth(setup, r, &run.values, gain, snr), seconds })
                    })
                })
                .collect();
            all.extend(made);
            Ok(())
        })?;
        let _ = std::fs::remove_dir_all(&dir);
    }
    Ok((all, failed))
}

/// Where the crank frequency is searched: the prior's speeds, 2 % wider \[Hz\].
pub fn speed_band_hz(r: &Resolved) -> (f64, f64) {
    let w = &r.unknowns[r.joints.len()];
    (0.98 * w.low / std::f64::consts::TAU, 1.02 * w.high / std::f64::consts::TAU)
}

/// What a preparation did.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct PrepareReport {
    /// Bank draws (measurements of reduced-model runs).
    pub bank_draws: usize,
    /// Reduced-model runs that failed.
    pub bank_failed: u64,
    /// Calibration draws (full-model runs).
    pub calibration_draws: usize,
    /// Full-model runs that failed.
    pub calibration_failed: u64,
    /// Wall time of the bank \[s\].
    pub bank_s: f64,
    /// Wall time of the calibration \[s\].
    pub calibration_s: f64,
    /// Wall time of the fit \[s\].
    pub fit_s: f64,
    /// Wall time of the hidden signals' band calibration \[s\].
    #[serde(default)]
    pub hidden_s: f64,
}

/// Prepares an estimator for `setup`: the bank, the fit, the calibration. `work` holds the
/// sweeps while they run (removed after).
pub fn prepare(
    setup: &Setup,
    work: &Path,
    progress: Progress<'_>,
) -> Result<(Estimator, PrepareReport), EstimateError> {
    let r = setup.resolve()?;
    let mut report = PrepareReport::default();
    let clock = std::time::Instant::now();
    let (bank, failed) = draws(
        setup,
        &r,
        ModelKind::Reduced,
        Purpose::Bank,
        (setup.bank_runs, setup.measurements_per_run),
        work,
        progress,
    )?;
    (report.bank_draws, report.bank_failed, report.bank_s) = (bank.len(), failed, clock.elapsed().as_secs_f64());
    let clock = std::time::Instant::now();
    let mut estimator = Estimator::fit(setup, r.joints.clone(), r.unknowns.clone(), speed_band_hz(&r), &bank)?;
    report.fit_s = clock.elapsed().as_secs_f64();
    let clock = std::time::Instant::now();
    let (calibration, failed) =
        draws(setup, &r, ModelKind::Full, Purpose::Calibration, (setup.calibration_runs, 1), work, progress)?;
    estimator.calibrate(&calibration)?;
    (report.calibration_draws, report.calibration_failed, report.calibration_s) =
        (calibration.len(), failed, clock.elapsed().as_secs_f64());
    let clock = std::time::Instant::now();
    crate::hidden::calibrate_bands(&mut estimator, setup.hidden_calibration_runs, progress)?;
    report.hidden_s = clock.elapsed().as_secs_f64();
    Ok((estimator, report))
}

/// A case to emulate: what a user's machine would be.
#[derive(Debug, Clone, PartialEq)]
pub struct Case {
    /// Radial clearance of each clearance joint \[m\].
    pub clearances: Vec<f64>,
    /// Crank speed \[rad/s\] (None: the scenario's).
    pub speed: Option<f64>,
    /// Crank angle at the start of the run \[rad\].
    pub angle0: f64,
    /// Sensor gain.
    pub gain: f64,
    /// Signal-to-noise ratio \[dB\].
    pub snr: f64,
    /// Seed of the noise.
    pub seed: u64,
}

/// One emulated measurement of the converged full model in `case` (the nuisances at the
/// scenario's own values): the channels at the logger's rate over the setup's window.
pub fn emulate(setup: &Setup, case: &Case, work: &Path) -> Result<Vec<Vec<f64>>, EstimateError> {
    let r = setup.resolve()?;
    if case.clearances.len() != r.joints.len() {
        return Err(EstimateError::Input(format!(
            "--clearance: {} values for {} clearance joints ({})",
            case.clearances.len(),
            r.joints.len(),
            r.joints.join(", ")
        )));
    }
    if let Some(bad) = case.clearances.iter().find(|c| !(**c > 0.0 && c.is_finite())) {
        return Err(EstimateError::Input(format!("--clearance: {bad} is not a positive clearance")));
    }
    let mut spec = sweep_spec(setup, &r, ModelKind::Full, 1, case.seed, 0);
    spec.sampling = Sampling::Grid;
    spec.runs = None;
    let mut values: Vec<f64> = case.clearances.iter().zip(&r.journal_radii).map(|(c, rj)| rj + c).collect();
    values.extend([case.speed.unwrap_or(r.speed), case.angle0]);
    spec.parameters.truncate(values.len());
    for (p, v) in spec.parameters.iter_mut().zip(values) {
        (p.uniform, p.values) = (None, Some(vec![v]));
    }
    let dir = work.join("emulate");
    let kept = (setup.settle, (setup.window * setup.sample_rate).round() as usize);
    let mut channels = None;
    let failed = sweep_runs(spec, kept, &r, &dir, &|_, _, _| {}, "emulation", &mut |mut runs| {
        channels = runs.pop().map(|run| run.channels);
        Ok(())
    })?;
    let _ = std::fs::remove_dir_all(&dir);
    let channels = channels
        .filter(|_| failed == 0)
        .ok_or_else(|| EstimateError::Failure("the full-model run of the emulation failed".into()))?;
    let mut rng = ChaCha8Rng::seed_from_u64(case.seed);
    Ok(channels.iter().map(|c| measure(c, case.gain, case.snr, &mut rng)).collect())
}
