//! Hidden signals: each clearance joint's contact force and eccentricity over the measured
//! window, with bands — the virtual sensor.
//!
//! The reduced model maps each joint's contact force to every sensor through its propagation
//! terms, so a simulation that reproduces the measured vibration carries the forces that made it.
//! Draws of the posterior (clearances calibrated, nuisances from the same bank draws) are
//! simulated again with the reduced model at the crank speed measured from the file itself; each
//! run's sensor channel (a housing accelerometer's: its force through the draw's mount), passed
//! through the logger's anti-alias filter, is aligned with the measurement (with an envelope
//! setup, envelope with envelope) by the lag (within one crank revolution, at the simulation's resolution) that
//! correlates best — the sensor's gain does not matter, its start in the cycle is found — and the
//! run's joint signals are read at the measurement's sample instants. Per sample, the draws'
//! median and 5–95 % range are the estimate and its band. Impact onsets are where most draws
//! begin a contact.

use crate::EstimateError;
use crate::infer::Estimator;
use crate::setup::Resolved;
use serde::{Deserialize, Serialize};

/// Posterior draws simulated for the hidden signals.
pub const DRAWS: usize = 24;

/// One hidden signal over the measured window, at the measurement's sample instants.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Band {
    /// `<joint>.force` (contact force magnitude) or `<joint>.eccentricity`.
    pub name: String,
    /// SI unit.
    pub unit: String,
    /// Median over the draws, per sample.
    pub median: Vec<f64>,
    /// 5 % quantile, per sample.
    pub low: Vec<f64>,
    /// 95 % quantile, per sample.
    pub high: Vec<f64>,
}

/// The hidden signals of a measurement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Hidden {
    /// Sample rate of the signals (the measurement's) \[Hz\].
    pub sample_rate: f64,
    /// Per joint, its force then its eccentricity.
    pub signals: Vec<Band>,
    /// Per joint, the samples where most draws begin a contact (impact onsets).
    pub onsets: Vec<Vec<usize>>,
    /// Per joint, its force's RMS over the window: median and 5–95 % range of the draws' RMS.
    pub force_rms: Vec<[f64; 3]>,
    /// Per joint, its force's peak over the window: median and 5–95 % range of the draws' peaks.
    pub force_peak: Vec<[f64; 3]>,
    /// Draws simulated, and those whose run failed (left out).
    pub draws: usize,
    /// Draws whose run failed.
    pub failed: usize,
    /// Full-model cases the bands were calibrated on (0: the draws' own spread, not calibrated).
    #[serde(default)]
    pub calibration_cases: usize,
    /// Where the onsets come from the impact tracking filter: how it ran and how well it follows
    /// the measurement.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tracking: Option<crate::track::TrackSummary>,
    /// Why the impact tracking asked for gave no filter (every replayed draw's run or every
    /// filter's particles failed): the onsets are the draws'.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tracking_failure: Option<String>,
}

/// How the hidden signals' bands are widened to hold the converged full model's truth: split
/// conformal, as the unknowns' intervals (docs/theory.md §10). Each factor multiplies the
/// distances from the median to the band's edges.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BandCalibration {
    /// Per joint: the factors of its force band, its eccentricity band (per sample), its force
    /// RMS range and its force peak range (per case).
    pub factors: Vec<[f64; 4]>,
    /// Full-model cases behind them.
    pub cases: usize,
}

/// Share of truths a calibrated band holds.
const BAND_COVERAGE: f64 = 0.9;

/// The edges of `(median, low, high)` widened by `factor` (the signals are magnitudes: ≥ 0).
fn widen(median: f64, low: f64, high: f64, factor: f64) -> (f64, f64) {
    ((median - factor * (median - low)).max(0.0), median + factor * (high - median))
}

/// How far outside `(median, low, high)` the truth lies, in units of the band's half-width on its
/// side (≤ 1: inside). `floor` keeps a band of zero width (every draw equal) finite.
fn score(median: f64, low: f64, high: f64, truth: f64, floor: f64) -> f64 {
    if truth >= median {
        (truth - median) / (high - median).max(floor)
    } else {
        (median - truth) / (median - low).max(floor)
    }
}

/// The ⌈0.9 (n + 1)⌉-th smallest score (split conformal).
fn conformal(scores: &mut [f64]) -> f64 {
    scores.sort_by(f64::total_cmp);
    let k = ((BAND_COVERAGE * (scores.len() + 1) as f64).ceil() as usize).clamp(1, scores.len().max(1)) - 1;
    scores.get(k).copied().unwrap_or(1.0)
}

impl BandCalibration {
    /// Widens the bands and ranges of `hidden`.
    pub fn apply(&self, hidden: &mut Hidden) {
        for (j, f) in self.factors.iter().enumerate() {
            for (band, factor) in hidden.signals[2 * j..2 * j + 2].iter_mut().zip(&f[..2]) {
                for i in 0..band.median.len() {
                    (band.low[i], band.high[i]) = widen(band.median[i], band.low[i], band.high[i], *factor);
                }
            }
            for (range, factor) in [(&mut hidden.force_rms[j], f[2]), (&mut hidden.force_peak[j], f[3])] {
                (range[1], range[2]) = widen(range[0], range[1], range[2], factor);
            }
        }
        hidden.calibration_cases = self.cases;
    }

    /// The factors from uncalibrated reconstructions of full-model cases and their truths.
    fn from_cases(cases: &[(Truth, Hidden)]) -> Self {
        let joints = cases.first().map_or(0, |(t, _)| t.joints.len());
        let factors = (0..joints)
            .map(|j| {
                let mut per_sample = [Vec::new(), Vec::new()];
                let (mut rms_scores, mut peak_scores) = (Vec::new(), Vec::new());
                for (truth, hidden) in cases {
                    let (force, eccentricity) = &truth.joints[j];
                    for (k, signal) in [force, eccentricity].into_iter().enumerate() {
                        let band = &hidden.signals[2 * j + k];
                        let floor = 1e-3 * rms(&band.median).max(1e-300);
                        per_sample[k].extend(
                            signal
                                .iter()
                                .enumerate()
                                .map(|(i, &t)| score(band.median[i], band.low[i], band.high[i], t, floor)),
                        );
                    }
                    let ([m, l, h], [pm, pl, ph]) = (hidden.force_rms[j], hidden.force_peak[j]);
                    rms_scores.push(score(m, l, h, rms(force), 1e-3 * m.max(1e-300)));
                    peak_scores.push(score(pm, pl, ph, peak(force), 1e-3 * pm.max(1e-300)));
                }
                let [forces, eccentricities] = &mut per_sample;
                [conformal(forces), conformal(eccentricities), conformal(&mut rms_scores), conformal(&mut peak_scores)]
            })
            .collect();
        Self { factors, cases: cases.len() }
    }
}

/// Calibrates the hidden signals' bands of `estimator` on `cases` full-model cases (seeds of
/// their own, SNRs spread over the prior), reconstructed as a user's measurement is.
pub fn calibrate_bands(
    estimator: &mut Estimator,
    cases: u64,
    progress: crate::prepare::Progress<'_>,
) -> Result<(), EstimateError> {
    use rayon::prelude::*;
    estimator.hidden_calibration = None;
    if cases == 0 {
        return Ok(());
    }
    let setup = &estimator.setup;
    let r = setup.resolve()?;
    let band_hz = crate::prepare::speed_band_hz(&r);
    let seed = setup.seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ 0x0062_616e_6463_616c;
    let done = std::sync::atomic::AtomicU64::new(0);
    let frozen: &Estimator = estimator;
    let reconstructed: Vec<(Truth, Hidden)> = (0..cases)
        .into_par_iter()
        .filter_map(|i| {
            let snr = setup.snr_db[0] + (setup.snr_db[1] - setup.snr_db[0]) * (i as f64 + 0.5) / cases as f64;
            let case = held_out(&frozen.setup, &r, seed, i, snr).and_then(|t| {
                let (f0, features) = crate::prepare::measured_features(setup, band_hz, &t.measured)?;
                let hidden = reconstruct(frozen, &features, f0, &t.measured[0], None).ok()?;
                Some((t, hidden))
            });
            progress(
                "Hidden-signal calibration (full model)",
                done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1,
                cases,
            );
            case
        })
        .collect();
    let needed = (cases as usize).div_ceil(2).max(5);
    if reconstructed.len() < needed {
        return Err(EstimateError::Failure(format!(
            "the hidden signals' calibration: {} of {cases} full-model cases could be reconstructed ({needed} needed)",
            reconstructed.len()
        )));
    }
    estimator.hidden_calibration = Some(BandCalibration::from_cases(&reconstructed));
    Ok(())
}

/// One signal of every draw (a series per draw).
type Series = Vec<Vec<f64>>;

/// A run's signals at the simulation's output interval: the sensor channel filtered by the
/// logger's anti-alias filter, then per joint force and eccentricity.
struct Simulated {
    sensor: Vec<f64>,
    joints: Vec<(Vec<f64>, Vec<f64>)>,
    dt: f64,
}

/// How a run carries each of the sensor channels `names`: the runner channel, and for a
/// measurement's logged axis (`housing.ay`) the mount its force drives. The scenario's own
/// measurement is taken out (the runner need not emulate it after the run).
fn sensors_of(
    scenario: &mut lash_scenario::AnyScenario,
    names: &[String],
) -> Vec<(String, Option<lash_measure::Mount>)> {
    let measurements = std::mem::take(&mut scenario.output_mut().measurements);
    names
        .iter()
        .map(|channel| match lash_sweep::plan::measured_axis(&measurements, channel) {
            Some((force, mount)) => (force.to_string(), Some(mount)),
            None => (channel.clone(), None),
        })
        .collect()
}

/// The sensor's signal at the simulation's output interval `dt` from its runner channel:
/// through the mount (if any), then the logger's anti-alias filter; with an envelope setup, its
/// envelope (what the alignment compares).
fn sensor_signal(
    setup: &crate::setup::Setup,
    column: &[f64],
    mount: Option<lash_measure::Mount>,
    dt: f64,
) -> Result<Vec<f64>, EstimateError> {
    let chain = lash_measure::Acquisition { sample_rate: 1.0 / dt, cutoff: setup.anti_alias, order: 4, settle: 0.0 };
    let mut logger = chain.logger(dt)?;
    let driven = match mount {
        Some(m) => m.acceleration(column, dt),
        None => column.to_vec(),
    };
    let filtered: Vec<f64> = driven.into_iter().filter_map(|x| logger.push(x)).collect();
    Ok(if setup.envelope { crate::features::envelope(&filtered) } else { filtered })
}

/// The scenario edits of one posterior draw (unknowns in the estimator's order), at crank
/// frequency `f0`, the crank starting at angle 0.
fn edits(estimator: &Estimator, r: &Resolved, draw: &[f64], f0: f64) -> Vec<(String, f64)> {
    let joints = r.joints.len();
    let mut e: Vec<(String, f64)> =
        (0..joints).map(|j| (format!("clearances[{j}].bearing_radius"), r.journal_radii[j] + draw[j])).collect();
    e.push(("drivers[0].motion.omega".into(), std::f64::consts::TAU * f0));
    e.push(("drivers[0].motion.angle0".into(), 0.0));
    for (k, n) in estimator.setup.nuisance.iter().enumerate() {
        e.push((n.path.clone(), draw[joints + 1 + k]));
    }
    e
}

/// The channels a run records: the sensors', then each joint's force and eccentricity.
fn joint_channels(sensors: Vec<String>, r: &Resolved) -> Vec<String> {
    let mut channels = sensors;
    for j in &r.joints {
        channels.extend([format!("{j}.force"), format!("{j}.eccentricity")]);
    }
    channels
}

/// Where each of `channels` is in the rows of `runner` (a runner orders its columns its own way:
/// the spatial one by body, joint and clearance).
fn columns(runner: &dyn lash_run::Runner, channels: &[String]) -> Result<Vec<usize>, EstimateError> {
    let header = runner.header();
    channels
        .iter()
        .map(|c| {
            header
                .iter()
                .position(|h| h.split(" [").next() == Some(c.as_str()))
                .ok_or_else(|| EstimateError::Failure(format!("the run does not record {c}")))
        })
        .collect()
}

/// The scenario of one posterior draw at crank frequency `f0` (its horizon the base's).
fn draw_scenario(
    estimator: &Estimator,
    r: &Resolved,
    base: &lash_scenario::paths::EditBase,
    draw: &[f64],
    f0: f64,
) -> Result<lash_scenario::AnyScenario, EstimateError> {
    let e = edits(estimator, r, draw, f0);
    base.edited(e.iter().map(|(p, v)| (p.as_str(), *v)))
        .map_err(|e| EstimateError::Failure(format!("a posterior draw's scenario: {e:?}")))
}

/// Simulates the draws with the reduced model (side by side in vector lanes), over the settle
/// time, the window and two revolutions more (room for the alignment).
fn simulate(
    estimator: &Estimator,
    r: &Resolved,
    draws: &[Vec<f64>],
    f0: f64,
) -> Result<Vec<Option<Simulated>>, EstimateError> {
    let setup = &estimator.setup;
    let table = toml::Table::try_from(&r.scenario).map_err(|e| EstimateError::Failure(e.to_string()))?;
    let base = lash_scenario::paths::EditBase::new(table);
    let horizon = ((setup.settle + setup.window + 2.0 / f0) / setup.macro_step).ceil() * setup.macro_step;
    let options = lash_run::ReducedOptions {
        macro_step: setup.macro_step,
        micro_step: setup.micro_step,
        channels_only: true,
        ..Default::default()
    };
    let mut runners = Vec::with_capacity(draws.len());
    let mut mounts = Vec::with_capacity(draws.len());
    let mut indices = Vec::with_capacity(draws.len());
    let mut dt = 0.0;
    for draw in draws {
        let mut scenario = draw_scenario(estimator, r, &base, draw, f0)?;
        scenario.simulation_mut().horizon = horizon;
        let (sensor, mount) = sensors_of(&mut scenario, &[setup.channels[0].name.clone()]).remove(0);
        mounts.push(mount);
        let channels = joint_channels(vec![sensor], r);
        scenario.output_mut().channels = channels.clone();
        dt = scenario.simulation().output_interval;
        let runner = lash_run::runner(&scenario, lash_run::Model::Reduced(options))?;
        indices.push(columns(&runner, &channels)?);
        runners.push(runner);
    }
    let mut rows: Vec<Vec<Vec<f64>>> = vec![Vec::new(); draws.len()];
    let results = {
        let mut keep: Vec<_> = rows
            .iter_mut()
            .map(|r| {
                move |row: &[f64]| -> Result<(), lash_core::BoxError> {
                    r.push(row.to_vec());
                    Ok(())
                }
            })
            .collect();
        let sinks: Vec<lash_run::Sink<'_>> = keep.iter_mut().map(|s| s as lash_run::Sink<'_>).collect();
        lash_run::execute_together(&mut runners, sinks)
    };
    let mut out = Vec::with_capacity(draws.len());
    for (((result, rows), mount), index) in results.into_iter().zip(rows).zip(mounts).zip(indices) {
        let ok = result.is_ok() && rows.iter().all(|row| row.iter().all(|v| v.is_finite()));
        if !ok {
            out.push(None);
            continue;
        }
        let column = |c: usize| rows.iter().map(|row| row[index[c]]).collect::<Vec<f64>>();
        let sensor = sensor_signal(setup, &column(0), mount, dt)?;
        let joints = (0..r.joints.len()).map(|j| (column(1 + 2 * j), column(2 + 2 * j))).collect();
        out.push(Some(Simulated { sensor, joints, dt }));
    }
    Ok(out)
}

/// The fine-sample index where the measurement's first sample falls in `sim`: the lag, within
/// one revolution after the settle time, whose samples correlate best with `measured` (each
/// side's mean removed; the sensor's gain does not matter).
fn align(sim: &Simulated, measured: &[f64], fs: f64, f0: f64, settle: f64) -> Option<(f64, usize)> {
    let every = (1.0 / (fs * sim.dt)).round() as usize;
    let first = (settle / sim.dt).round() as usize;
    let period = (1.0 / (f0 * sim.dt)).ceil() as usize;
    let n = measured.len();
    if first + period + (n - 1) * every >= sim.sensor.len() {
        return None;
    }
    let mean_m = measured.iter().sum::<f64>() / n as f64;
    let mut best = (f64::NEG_INFINITY, first);
    for lag in first..first + period {
        let (mut dot, mut sum, mut sq) = (0.0, 0.0, 0.0);
        for (i, m) in measured.iter().enumerate() {
            let y = sim.sensor[lag + i * every];
            dot += (m - mean_m) * y;
            sum += y;
            sq += y * y;
        }
        let var = (sq - sum * sum / n as f64).max(1e-300);
        let score = dot / var.sqrt();
        if score > best.0 {
            best = (score, lag);
        }
    }
    Some(best)
}

/// The `q` quantile of `v` (sorted in place; [`crate::infer`]'s interpolation).
fn quantile(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    crate::infer::quantile(v, q)
}

/// Samples where a contact begins in the majority of `draws` (force > 0 after none).
fn onsets(draws: &[Vec<f64>]) -> Vec<usize> {
    let n = draws.first().map_or(0, Vec::len);
    let contact = |i: usize| 2 * draws.iter().filter(|d| d[i] > 0.0).count() > draws.len();
    (1..n).filter(|&i| contact(i) && !contact(i - 1)).collect()
}

/// One signal's band over the draws (each a series of the same length): per sample the median
/// and the 5 % and 95 % quantiles.
fn band(name: String, unit: &str, draws: &[Vec<f64>]) -> Band {
    let n = draws.first().map_or(0, Vec::len);
    let (mut median, mut low, mut high) = (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
    let mut column = vec![0.0; draws.len()];
    for i in 0..n {
        column.iter_mut().zip(draws).for_each(|(c, d)| *c = d[i]);
        median.push(quantile(&mut column, 0.5));
        low.push(quantile(&mut column, 0.05));
        high.push(quantile(&mut column, 0.95));
    }
    Band { name, unit: unit.into(), median, low, high }
}

/// The hidden signals of a measurement whose reference channel is `measured` (the first channel,
/// at the setup's sample rate), whose features are `features`, taken at crank frequency `f0`.
pub fn reconstruct(
    estimator: &Estimator,
    features: &[f64],
    f0: f64,
    measured: &[f64],
    track: Option<crate::track::TrackOptions>,
) -> Result<Hidden, EstimateError> {
    let setup = &estimator.setup;
    let r = setup.resolve()?;
    let posterior = estimator.posterior(features);
    let step = (posterior.len() / DRAWS).max(1);
    let chosen: Vec<Vec<f64>> = posterior.into_iter().step_by(step).take(DRAWS).collect();
    let simulated = simulate(estimator, &r, &chosen, f0)?;
    let fs = setup.sample_rate;
    // What the alignment compares: the measured channel, or its envelope (as the runs' sensor).
    let reference = if setup.envelope { crate::features::envelope(measured) } else { measured.to_vec() };
    // Per joint: force draws and eccentricity draws, each a series at the measured instants.
    let joints = r.joints.len();
    let mut series: Vec<(Series, Series)> = vec![(Vec::new(), Vec::new()); joints];
    let mut failed = 0;
    // Each draw's alignment: (score, draw, lag).
    let mut aligned: Vec<(f64, usize, usize)> = Vec::new();
    for (d, sim) in simulated.iter().enumerate() {
        let Some((score, lag)) = sim.as_ref().and_then(|s| align(s, &reference, fs, f0, setup.settle)) else {
            failed += 1;
            continue;
        };
        aligned.push((score, d, lag));
        let sim = sim.as_ref().expect("aligned");
        let every = (1.0 / (fs * sim.dt)).round() as usize;
        let at = |x: &[f64]| (0..measured.len()).map(|i| x[lag + i * every]).collect::<Vec<f64>>();
        for (j, (force, eccentricity)) in sim.joints.iter().enumerate() {
            series[j].0.push(at(force));
            series[j].1.push(at(eccentricity));
        }
    }
    if series.first().is_none_or(|s| s.0.len() < DRAWS / 2) {
        return Err(EstimateError::Failure(format!(
            "the hidden signals: {failed} of {} posterior draws could not be simulated or aligned",
            chosen.len()
        )));
    }
    // A summary of a signal (its RMS, its peak) is estimated from each draw's own: the median
    // series is smoother than any draw, and its peak lower than theirs.
    let summary = |draws: &[Vec<f64>], of: fn(&[f64]) -> f64| {
        let mut v: Vec<f64> = draws.iter().map(|d| of(d)).collect();
        [quantile(&mut v, 0.5), quantile(&mut v, 0.05), quantile(&mut v, 0.95)]
    };
    let mut signals = Vec::with_capacity(2 * joints);
    let (mut found, mut force_rms, mut force_peak) = (Vec::new(), Vec::new(), Vec::new());
    for (j, (force, eccentricity)) in series.iter().enumerate() {
        signals.push(band(format!("{}.force", r.joints[j]), "N", force));
        signals.push(band(format!("{}.eccentricity", r.joints[j]), "m", eccentricity));
        found.push(onsets(force));
        force_rms.push(summary(force, rms));
        force_peak.push(summary(force, peak));
    }
    let mut hidden = Hidden {
        sample_rate: fs,
        signals,
        onsets: found,
        force_rms,
        force_peak,
        draws: chosen.len(),
        failed,
        calibration_cases: 0,
        tracking: None,
        tracking_failure: None,
    };
    if let Some(c) = &estimator.hidden_calibration {
        c.apply(&mut hidden);
    }
    if let Some(options) = track {
        // The best-aligned draws first.
        aligned.sort_by(|a, b| b.0.total_cmp(&a.0));
        let best: Vec<_> = aligned
            .iter()
            .take(options.draws.max(1))
            .map(|&(_, d, lag)| (chosen[d].as_slice(), simulated[d].as_ref().expect("aligned"), lag))
            .collect();
        hidden.take_tracked(track_impacts(estimator, &r, f0, &best, measured, options))?;
    }
    Ok(hidden)
}

impl Hidden {
    /// The impact tracking's summary, and its onsets where its particles follow the measurement.
    /// A tracking whose simulations failed (the replays, or every particle of every filter)
    /// leaves the draws' onsets and says why; an input error is the estimate's.
    fn take_tracked(
        &mut self,
        tracked: Result<Option<crate::track::Tracked>, EstimateError>,
    ) -> Result<(), EstimateError> {
        match tracked {
            Ok(Some(t)) => {
                if t.summary.follows {
                    self.onsets = t.onsets;
                }
                self.tracking = Some(t.summary);
            }
            Ok(None) => {}
            Err(e @ (EstimateError::Failure(_) | EstimateError::Run(_))) => {
                self.tracking_failure = Some(lash_core::error_chain(&e));
            }
            Err(e) => return Err(e),
        }
        Ok(())
    }
}

/// The impacts tracked through `measured` by a particle filter on the micro sides of the
/// one-way runs of `draws` (each with its simulation, aligned at its lag); `None` where the
/// setup's sensor is not one the filter can predict (a mounted housing's, an envelope, a spatial
/// mechanism).
fn track_impacts(
    estimator: &Estimator,
    r: &Resolved,
    f0: f64,
    draws: &[(&[f64], &Simulated, usize)],
    measured: &[f64],
    options: crate::track::TrackOptions,
) -> Result<Option<crate::track::Tracked>, EstimateError> {
    let setup = &estimator.setup;
    let table = toml::Table::try_from(&r.scenario).map_err(|e| EstimateError::Failure(e.to_string()))?;
    let base = lash_scenario::paths::EditBase::new(table);
    let mut replays = Vec::with_capacity(draws.len());
    let mut lost = None;
    // The draws share the setup's output interval.
    let every = draws.first().map_or(1, |d| (1.0 / (setup.sample_rate * d.1.dt)).round() as usize);
    for &(draw, sim, lag) in draws {
        let lash_scenario::AnyScenario::Planar(mut scenario) = draw_scenario(estimator, r, &base, draw, f0)? else {
            return Ok(None);
        };
        let sensor = &setup.channels[0].name;
        if setup.envelope || lash_sweep::plan::measured_axis(&scenario.output.measurements, sensor).is_some() {
            return Ok(None);
        }
        let rows = lag + measured.len() * every + 1;
        scenario.simulation.horizon = ((rows as f64 * sim.dt) / setup.macro_step).ceil() * setup.macro_step;
        let options_run = lash_run::ReducedOptions {
            macro_step: setup.macro_step,
            micro_step: setup.micro_step,
            ..Default::default()
        };
        // A draw whose reduced run fails (about 1 % of C's blow up at its micro step) is left
        // out of the filter; the others carry it.
        let replay = match crate::track::Replay::record(&scenario, options_run, sensor) {
            Ok(replay) => replay,
            Err(e @ EstimateError::Failure(_)) => {
                lost = Some(e);
                continue;
            }
            Err(e) => return Err(e),
        };
        // The sensor's gain: the measurement regressed on the aligned draw's sensor.
        let x: Vec<f64> = (0..measured.len()).map(|k| sim.sensor[lag + k * every]).collect();
        let (mx, my) = (x.iter().sum::<f64>() / x.len() as f64, measured.iter().sum::<f64>() / x.len() as f64);
        let sxy: f64 = x.iter().zip(measured).map(|(a, b)| (a - mx) * (b - my)).sum();
        let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
        let gain = if sxx > 0.0 { sxy / sxx } else { 1.0 };
        replays.push((replay, lag, gain));
    }
    if let (true, Some(e)) = (replays.is_empty(), lost) {
        return Err(e);
    }
    let candidates: Vec<_> =
        replays.iter().map(|(replay, lag, gain)| crate::track::Candidate { replay, lag: *lag, gain: *gain }).collect();
    let chain =
        lash_measure::Acquisition { sample_rate: setup.sample_rate, cutoff: setup.anti_alias, order: 4, settle: 0.0 };
    crate::track::track(&candidates, chain, measured, every, options).map(Some)
}

/// How well the hidden signals follow the converged full model's (one figure per case and joint).
#[derive(Debug, Clone, Serialize)]
pub struct HiddenReport {
    /// The setup.
    pub setup: String,
    /// Held-out full-model cases reconstructed (their runs and estimates succeeded).
    pub cases: usize,
    /// Cases left out (a failed full-model run, no crank frequency, or too few aligned draws).
    pub failed: usize,
    /// Seed of the held-out cases.
    pub seed: u64,
    /// Signal-to-noise ratio of the emulated measurements \[dB\].
    pub snr_db: f64,
    /// |RMS(estimate) − RMS(truth)| / RMS(truth) of each joint's force: median and 90 % quantile.
    pub force_rms_error: [f64; 2],
    /// Share of (case, joint) whose force RMS is within 10 %.
    pub force_rms_within_10: f64,
    /// |peak(estimate) − peak(truth)| / peak(truth): median and 90 % quantile.
    pub force_peak_error: [f64; 2],
    /// Share within 20 %.
    pub force_peak_within_20: f64,
    /// Share of (case, joint) whose true force RMS lies in the draws' 5–95 % range.
    pub force_rms_coverage: f64,
    /// Share of (case, joint) whose true force peak lies in the draws' 5–95 % range.
    pub force_peak_coverage: f64,
    /// Share of samples whose true force lies in the 5–95 % band.
    pub force_band_coverage: f64,
    /// Share of samples whose true eccentricity lies in its band.
    pub eccentricity_band_coverage: f64,
    /// True impact onsets (over all cases).
    pub impacts: usize,
    /// Impact onsets the reconstruction reported (over all cases).
    pub onsets_reported: usize,
    /// Share of the true onsets with an estimated one within two samples (none: no true onset).
    pub impacts_found: Option<f64>,
    /// Share of the estimated onsets with a true one within two samples (none: no onset
    /// reported).
    pub onsets_true: Option<f64>,
    /// Mean wall time of one case's hidden signals (estimate, re-simulation, alignment) \[s\].
    pub seconds_per_case: f64,
    /// With impact tracking: its particles, and the cases where they followed the measurement
    /// (whose onsets are the filter's; the others' are the draws').
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tracking: Option<(usize, usize)>,
    /// With impact tracking: the cases where it could not run (every replayed draw's run or
    /// every particle failed; their onsets are the draws').
    pub tracking_failures: usize,
}

/// One held-out case: its emulated measurement, and per joint the true force and eccentricity
/// at the measurement's instants.
struct Truth {
    /// Every measured channel (the first is the reference).
    measured: Vec<Vec<f64>>,
    joints: Vec<(Vec<f64>, Vec<f64>)>,
}

/// Case `i` of the held-out set: parameters drawn from the priors with a stream of `seed` of its
/// own, the converged full model run, its sensor channels logged and measured at `snr_db`.
fn held_out(setup: &crate::setup::Setup, r: &Resolved, seed: u64, i: u64, snr_db: f64) -> Option<Truth> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x6869_6464_656e);
    rng.set_stream(i);
    let joints = r.joints.len();
    let worn = rng.random_range(0..joints);
    let mut edits: Vec<(String, f64)> = (0..joints)
        .map(|j| {
            let [low, high] = if j == worn { setup.clearance } else { setup.healthy.unwrap_or(setup.clearance) };
            (format!("clearances[{j}].bearing_radius"), r.journal_radii[j] + rng.random_range(low..high))
        })
        .collect();
    let w = &r.unknowns[joints];
    edits.push(("drivers[0].motion.omega".into(), rng.random_range(w.low..w.high)));
    edits.push(("drivers[0].motion.angle0".into(), rng.random_range(0.0..std::f64::consts::TAU)));
    edits.extend(setup.nuisance.iter().map(|n| (n.path.clone(), rng.random_range(n.low..n.high))));
    let gain = 1.0 + setup.gain_error * rng.random_range(-1.0..=1.0);
    let table = toml::Table::try_from(&r.scenario).ok()?;
    let mut scenario =
        lash_scenario::paths::EditBase::new(table).edited(edits.iter().map(|(p, v)| (p.as_str(), *v))).ok()?;
    scenario.simulation_mut().horizon = setup.settle + setup.window + 2.0 / setup.sample_rate;
    let names: Vec<String> = setup.channels.iter().map(|c| c.name.clone()).collect();
    let (sensors, mounts): (Vec<String>, Vec<_>) = sensors_of(&mut scenario, &names).into_iter().unzip();
    let (logged, instants, at) = logged_full_run(setup, scenario, sensors, &mounts, r)?;
    let measured = logged.iter().map(|x| crate::prepare::measure(x, gain, snr_db, &mut rng)).collect();
    let truth = |c: usize| instants.iter().map(|&k| at[c][k]).collect::<Vec<f64>>();
    Some(Truth { measured, joints: (0..joints).map(|j| (truth(2 * j), truth(2 * j + 1))).collect() })
}

/// Runs the converged full model of `scenario` recording `sensors` and the joints' signals; returns
/// the sensors as the logger keeps them over the window (each through its mount, if any), the
/// kept samples' row indices, and each joint signal (force, eccentricity per joint) at every row.
#[allow(clippy::type_complexity)]
fn logged_full_run(
    setup: &crate::setup::Setup,
    mut scenario: lash_scenario::AnyScenario,
    sensors: Vec<String>,
    mounts: &[Option<lash_measure::Mount>],
    r: &Resolved,
) -> Option<(Vec<Vec<f64>>, Vec<usize>, Vec<Vec<f64>>)> {
    let count = sensors.len();
    let channels = joint_channels(sensors, r);
    scenario.output_mut().channels = channels.clone();
    let dt = scenario.simulation().output_interval;
    let mut runner = lash_run::runner(&scenario, lash_run::Model::Full { ideal: false }).ok()?;
    let index = columns(&runner, &channels).ok()?;
    let mut rows: Vec<Vec<f64>> = Vec::new();
    runner
        .execute(
            &mut |row: &[f64]| {
                rows.push(index.iter().map(|&i| row[i]).collect());
                Ok(())
            },
            &mut |_| {},
        )
        .ok()?;
    let chain = lash_measure::Acquisition {
        sample_rate: setup.sample_rate,
        cutoff: setup.anti_alias,
        order: 4,
        settle: setup.settle,
    };
    let n = (setup.window * setup.sample_rate).round() as usize;
    let mut logged = Vec::with_capacity(count);
    let mut instants = Vec::with_capacity(n);
    for (c, mount) in mounts.iter().enumerate() {
        let mut logger = chain.logger(dt).ok()?;
        let mut response = mount.map(|m| m.response(dt));
        let mut kept = Vec::with_capacity(n);
        for (k, row) in rows.iter().enumerate() {
            let value = response.as_mut().map_or(row[c], |m| m.push(row[c]));
            if let Some(y) = logger.push(value) {
                kept.push(y);
                if c == 0 {
                    instants.push(k);
                }
            }
        }
        if kept.len() < n {
            return None;
        }
        kept.truncate(n);
        logged.push(kept);
    }
    instants.truncate(n);
    let joint_signals = (count..channels.len()).map(|c| rows.iter().map(|row| row[c]).collect()).collect();
    Some((logged, instants, joint_signals))
}

/// Relative error of `estimate` against `truth`.
fn relative(estimate: f64, truth: f64) -> f64 {
    (estimate - truth).abs() / truth.abs().max(1e-300)
}

/// Root mean square of a series.
pub fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

/// Largest value of a series (0 for none).
pub fn peak(x: &[f64]) -> f64 {
    x.iter().copied().fold(0.0, f64::max)
}

/// Share of samples of `truth` inside `band`.
fn inside(band: &Band, truth: &[f64]) -> (usize, usize) {
    let hit = truth.iter().enumerate().filter(|&(i, &t)| band.low[i] <= t && t <= band.high[i]).count();
    (hit, truth.len())
}

/// Scores the hidden signals on `cases` held-out full-model cases measured at `snr_db`.
pub fn validate_hidden(
    estimator: &Estimator,
    (cases, seed, snr_db): (u64, u64, f64),
    track: Option<crate::track::TrackOptions>,
    progress: crate::prepare::Progress<'_>,
) -> Result<HiddenReport, EstimateError> {
    use rayon::prelude::*;
    let setup = &estimator.setup;
    let r = setup.resolve()?;
    let band_hz = crate::prepare::speed_band_hz(&r);
    let done = std::sync::atomic::AtomicU64::new(0);
    let results: Vec<Option<(Truth, Hidden, f64)>> = (0..cases)
        .into_par_iter()
        .map(|i| {
            let truth = held_out(setup, &r, seed, i, snr_db);
            let clock = std::time::Instant::now();
            let hidden = truth.as_ref().and_then(|t| {
                let (f0, features) = crate::prepare::measured_features(setup, band_hz, &t.measured)?;
                reconstruct(estimator, &features, f0, &t.measured[0], track).ok()
            });
            let seconds = clock.elapsed().as_secs_f64();
            progress("hidden signals", done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1, cases);
            truth.zip(hidden).map(|(t, h)| (t, h, seconds))
        })
        .collect();
    let ok: Vec<&(Truth, Hidden, f64)> = results.iter().flatten().collect();
    if ok.is_empty() {
        return Err(EstimateError::Failure("no held-out case could be reconstructed".into()));
    }
    let (mut rms_errors, mut peak_errors) = (Vec::new(), Vec::new());
    let (mut force_in, mut ecc_in, mut samples, mut rms_in, mut peak_in) = (0, 0, 0, 0, 0);
    let (mut impacts, mut found, mut onsets, mut real) = (0, 0, 0, 0);
    for (truth, hidden, _) in &ok {
        for (j, (force, eccentricity)) in truth.joints.iter().enumerate() {
            let (f, e) = (&hidden.signals[2 * j], &hidden.signals[2 * j + 1]);
            let (truth_rms, truth_peak) = (rms(force), peak(force));
            rms_errors.push(relative(hidden.force_rms[j][0], truth_rms));
            peak_errors.push(relative(hidden.force_peak[j][0], truth_peak));
            rms_in += usize::from((hidden.force_rms[j][1]..=hidden.force_rms[j][2]).contains(&truth_rms));
            peak_in += usize::from((hidden.force_peak[j][1]..=hidden.force_peak[j][2]).contains(&truth_peak));
            force_in += inside(f, force).0;
            ecc_in += inside(e, eccentricity).0;
            samples += force.len();
            let true_onsets: Vec<usize> = (1..force.len()).filter(|&i| force[i] > 0.0 && force[i - 1] <= 0.0).collect();
            let near = |a: &[usize], b: usize| a.iter().any(|&x| x.abs_diff(b) <= 2);
            impacts += true_onsets.len();
            found += true_onsets.iter().filter(|&&t| near(&hidden.onsets[j], t)).count();
            onsets += hidden.onsets[j].len();
            real += hidden.onsets[j].iter().filter(|&&o| near(&true_onsets, o)).count();
        }
    }
    let quantiles = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let q = |p: f64| v[((p * (v.len() - 1) as f64).round() as usize).min(v.len() - 1)];
        [q(0.5), q(0.9)]
    };
    let share = |v: &[f64], limit: f64| v.iter().filter(|&&e| e <= limit).count() as f64 / v.len() as f64;
    let ratio = |a: usize, b: usize| if b == 0 { f64::NAN } else { a as f64 / b as f64 };
    Ok(HiddenReport {
        setup: setup.name.clone(),
        cases: ok.len(),
        failed: results.len() - ok.len(),
        seed,
        snr_db,
        force_rms_within_10: share(&rms_errors, 0.1),
        force_rms_coverage: ratio(rms_in, rms_errors.len()),
        force_peak_coverage: ratio(peak_in, peak_errors.len()),
        force_rms_error: quantiles(&mut rms_errors),
        force_peak_within_20: share(&peak_errors, 0.2),
        force_peak_error: quantiles(&mut peak_errors),
        force_band_coverage: ratio(force_in, samples),
        eccentricity_band_coverage: ratio(ecc_in, samples),
        impacts,
        onsets_reported: onsets,
        impacts_found: (impacts > 0).then(|| ratio(found, impacts)),
        onsets_true: (onsets > 0).then(|| ratio(real, onsets)),
        seconds_per_case: ok.iter().map(|c| c.2).sum::<f64>() / ok.len() as f64,
        tracking: track
            .map(|t| (t.particles, ok.iter().filter(|c| c.1.tracking.as_ref().is_some_and(|s| s.follows)).count())),
        tracking_failures: ok.iter().filter(|c| c.1.tracking_failure.is_some()).count(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Cases whose truth is the median plus Gaussian noise of unit spread, with raw bands of
    /// ±`half` around the median.
    fn gaussian_cases(count: u64, half: f64, stream: u64) -> Vec<(Truth, Hidden)> {
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        rng.set_stream(stream);
        (0..count)
            .map(|c| {
                let median: Vec<f64> = (0..500).map(|i| 10.0 + (i as f64 * 0.01 + c as f64).sin()).collect();
                let mut noisy = || -> Vec<f64> {
                    median
                        .iter()
                        .map(|m| {
                            let unit: f64 = StandardNormal.sample(&mut rng);
                            m + unit
                        })
                        .collect()
                };
                let (force, eccentricity) = (noisy(), noisy());
                let band = |name: &str| Band {
                    name: name.into(),
                    unit: String::new(),
                    median: median.clone(),
                    low: median.iter().map(|m| m - half).collect(),
                    high: median.iter().map(|m| m + half).collect(),
                };
                let (r, p) = (rms(&force), peak(&force));
                let hidden = Hidden {
                    sample_rate: 1.0,
                    signals: vec![band("f"), band("e")],
                    onsets: vec![Vec::new()],
                    force_rms: [[r, r - 0.01, r + 0.01]].to_vec(),
                    force_peak: [[p, p - 0.01, p + 0.01]].to_vec(),
                    draws: DRAWS,
                    failed: 0,
                    calibration_cases: 0,
                    tracking: None,
                    tracking_failure: None,
                };
                (Truth { measured: Vec::new(), joints: vec![(force, eccentricity)] }, hidden)
            })
            .collect()
    }

    #[test]
    fn calibrated_bands_hold_ninety_percent_of_gaussian_truths() {
        // Raw bands of ±0.8225 σ hold 59 % of the samples; the 90 % band of a unit Gaussian is
        // ±1.645 σ, so the factor is 2 (closed form), and fresh cases are then held 90 % of the time.
        let calibration = BandCalibration::from_cases(&gaussian_cases(40, 0.8225, 1));
        let [force, eccentricity, ..] = calibration.factors[0];
        assert!((force - 2.0).abs() < 0.06 && (eccentricity - 2.0).abs() < 0.06, "{force} {eccentricity}");
        let (mut held, mut total) = (0, 0);
        for (truth, mut hidden) in gaussian_cases(40, 0.8225, 2) {
            calibration.apply(&mut hidden);
            assert_eq!(hidden.calibration_cases, 40);
            let (h, n) = inside(&hidden.signals[0], &truth.joints[0].0);
            (held, total) = (held + h, total + n);
        }
        let coverage = held as f64 / total as f64;
        assert!((0.88..=0.92).contains(&coverage), "{coverage}");
    }

    #[test]
    fn the_alignment_finds_a_shift_and_ignores_the_gain() {
        // A two-tone "sensor" at 1e-5 s, measured from fine sample 12 345 on every 10th sample,
        // with a gain of 0.7 and an offset: the lag found is that sample.
        let (dt, f0) = (1e-5, 83.0);
        let signal =
            |t: f64| (std::f64::consts::TAU * f0 * t).sin() + 0.4 * (2.0 * std::f64::consts::TAU * f0 * t).cos();
        let sensor: Vec<f64> = (0..60_000).map(|i| signal(i as f64 * dt)).collect();
        let measured: Vec<f64> = (0..3000).map(|i| 0.7 * sensor[12_345 + 10 * i] + 3.0).collect();
        let sim = Simulated { sensor, joints: Vec::new(), dt };
        assert_eq!(align(&sim, &measured, 1e4, f0, 0.115).map(|a| a.1), Some(12_345));
    }

    #[test]
    fn onsets_are_where_most_draws_begin_a_contact() {
        let draws = vec![
            vec![0.0, 0.0, 1.0, 1.0, 0.0, 2.0],
            vec![0.0, 1.0, 1.0, 1.0, 0.0, 0.0],
            vec![0.0, 0.0, 3.0, 0.0, 0.0, 1.0],
        ];
        assert_eq!(onsets(&draws), vec![2, 5]);
    }

    /// A tracking whose simulations failed leaves the draws' onsets and says why (the estimate
    /// goes on); a tracking that follows replaces them; an input error stays the estimate's.
    #[test]
    fn a_failed_tracking_keeps_the_draws_onsets() {
        let (_, mut hidden) = gaussian_cases(1, 1.0, 0).remove(0);
        hidden.onsets = vec![vec![3, 9]];
        let failure = EstimateError::Failure("impact tracking: every particle failed by sample 51".into());
        hidden.take_tracked(Err(failure)).expect("the estimate goes on");
        assert_eq!(hidden.onsets, vec![vec![3, 9]]);
        assert!(hidden.tracking.is_none());
        assert!(hidden.tracking_failure.as_deref().is_some_and(|w| w.contains("every particle failed")));
        let input = EstimateError::Input("--track-draws: must be at least 1".into());
        assert!(matches!(hidden.take_tracked(Err(input)), Err(EstimateError::Input(_))));
        let summary = crate::track::TrackSummary {
            particles: 8,
            resamplings: 1,
            rescues: 0,
            measured_rms: 1.0,
            replay_residual: 0.3,
            innovation: 0.1,
            follows: true,
            draw: 0,
            draw_innovations: vec![Some(0.1)],
        };
        let tracked = crate::track::Tracked { onsets: vec![vec![4]], contact: vec![Vec::new()], summary };
        hidden.take_tracked(Ok(Some(tracked))).expect("taken");
        assert_eq!(hidden.onsets, vec![vec![4]]);
        assert!(hidden.tracking.as_ref().is_some_and(|t| t.follows));
    }
}
