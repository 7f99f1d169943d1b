//! The estimator: summaries by regression, a posterior by the nearest bank draws, intervals
//! calibrated on full-model draws.
//!
//! * Summaries (semi-automatic approximate Bayesian computation, Fearnhead & Prangle 2012): each
//!   unknown (a clearance on a log scale, the others linear) is regressed on the standardised
//!   features and their squares (ridge least squares over the bank); the fitted value is that
//!   unknown's summary, the best guess of it the features allow.
//! * Posterior: per unknown, the bank draws nearest to the measurement in that unknown's summary;
//!   their values are its posterior sample, reported as median and 5–95 % quantiles. With several
//!   joints, the draws nearest in the clearances' summaries together give each joint's
//!   probability of being the worn one (the share of draws in which it has the largest clearance).
//! * Calibration (split conformal): the bank is the reduced model; the truth is the full one. On
//!   full-model draws of the preparation (seeds of their own), half give each unknown's median
//!   shift, the other half the factor by which its quantile interval must widen (or narrow) to hold
//!   90 % of truths. Held-out draws from the same generator are then covered 90 % of the time up
//!   to their finite number.

use crate::EstimateError;
use crate::setup::{Scale, Setup, Unknown};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// A draw of the preparation: its features and its true unknowns (natural units).
#[derive(Debug, Clone, PartialEq)]
pub struct Draw {
    /// Feature vector.
    pub features: Vec<f64>,
    /// True values of the unknowns.
    pub truth: Vec<f64>,
    /// Wall time of the measurement's feature extraction \[s\].
    pub seconds: f64,
}

/// How each unknown's interval is corrected by the calibration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    /// Added to the median (estimation scale).
    pub shift: f64,
    /// Factor on the distances from the median to the 5 % and 95 % quantiles.
    pub widen: f64,
    /// Calibration draws behind the factor.
    pub cases: usize,
}

/// A prepared estimator (stored as JSON by `lash estimate prepare`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Estimator {
    /// The setup it was prepared for.
    pub setup: Setup,
    /// Names of the clearance joints.
    pub joints: Vec<String>,
    /// The unknowns, in the order of every truth and summary vector.
    pub unknowns: Vec<Unknown>,
    /// Where the crank frequency is searched \[Hz\].
    pub speed_band_hz: (f64, f64),
    /// Mean of each feature over the bank.
    pub feature_mean: Vec<f64>,
    /// Spread of each feature over the bank.
    pub feature_scale: Vec<f64>,
    /// Regression coefficients: per unknown, over [1, z, z²] (z the standardised features).
    pub coefficients: Vec<Vec<f64>>,
    /// Residual spread of each regression (how well the features determine the unknown).
    pub summary_scale: Vec<f64>,
    /// Spread of each summary over the bank (the scale of summary distances).
    pub summary_spread: Vec<f64>,
    /// The bank's summaries (one vector per draw).
    pub bank_summaries: Vec<Vec<f64>>,
    /// The bank's truths on the estimation scale (one vector per draw).
    pub bank_truths: Vec<Vec<f64>>,
    /// Per unknown, the calibration (identity before [`Estimator::calibrate`]).
    pub calibration: Vec<Calibration>,
    /// The hidden signals' band calibration (None: the draws' own spread; an estimator
    /// prepared before the bands were calibrated).
    #[serde(default)]
    pub hidden_calibration: Option<crate::hidden::BandCalibration>,
}

/// One unknown's estimate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UnknownEstimate {
    /// Name.
    pub name: String,
    /// SI unit.
    pub unit: String,
    /// Posterior median.
    pub median: f64,
    /// 5 % quantile (calibrated).
    pub low: f64,
    /// 95 % quantile (calibrated).
    pub high: f64,
    /// The prior range.
    pub prior: [f64; 2],
}

/// The answer to a measurement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// Every unknown: clearances first, then crank speed and the nuisances.
    pub unknowns: Vec<UnknownEstimate>,
    /// With several clearance joints: each joint's probability of being the worn one.
    pub worn: Vec<(String, f64)>,
    /// Crank frequency the features were taken at \[Hz\].
    pub crank_frequency: f64,
    /// Per clearance joint, its posterior sample (natural units), mapped by the calibration as
    /// its interval is: the sample's 5 % and 95 % quantiles are the reported interval.
    pub clearance_draws: Vec<Vec<f64>>,
}

fn to_scale(u: &Unknown, v: f64) -> f64 {
    match u.scale {
        Scale::Log => v.max(1e-300).ln(),
        Scale::Linear => v,
    }
}

fn from_scale(u: &Unknown, v: f64) -> f64 {
    match u.scale {
        Scale::Log => v.exp(),
        Scale::Linear => v,
    }
}

/// The `q` quantile of sorted values (linear between order statistics).
pub(crate) fn quantile(sorted: &[f64], q: f64) -> f64 {
    let pos = q * (sorted.len() - 1) as f64;
    let (i, frac) = (pos.floor() as usize, pos.fract());
    let next = sorted[(i + 1).min(sorted.len() - 1)];
    sorted[i] + frac * (next - sorted[i])
}

/// The regression design row of standardised features: [1, z, z²].
fn design(z: &[f64]) -> Vec<f64> {
    std::iter::once(1.0).chain(z.iter().copied()).chain(z.iter().map(|v| v * v)).collect()
}

/// Raw posterior of one unknown: (median, 5 %, 95 %) on the estimation scale.
type Raw = (f64, f64, f64);

impl Estimator {
    /// Fits the summaries on the bank (the calibration is the identity until
    /// [`Estimator::calibrate`]).
    pub fn fit(
        setup: &Setup,
        joints: Vec<String>,
        unknowns: Vec<Unknown>,
        speed_band_hz: (f64, f64),
        bank: &[Draw],
    ) -> Result<Self, EstimateError> {
        let (n, p) = (bank.len(), bank.first().map_or(0, |d| d.features.len()));
        if n < 4 * (2 * p + 1) {
            return Err(EstimateError::Failure(format!("{n} bank draws are too few for {p} features")));
        }
        let mean: Vec<f64> = (0..p).map(|j| bank.iter().map(|d| d.features[j]).sum::<f64>() / n as f64).collect();
        let scale: Vec<f64> = (0..p)
            .map(|j| {
                let v = bank.iter().map(|d| (d.features[j] - mean[j]).powi(2)).sum::<f64>() / n as f64;
                if v > 1e-24 { v.sqrt() } else { 1.0 }
            })
            .collect();
        let standardise =
            |f: &[f64]| -> Vec<f64> { f.iter().zip(&mean).zip(&scale).map(|((v, m), s)| (v - m) / s).collect() };
        let rows: Vec<Vec<f64>> = bank.iter().map(|d| design(&standardise(&d.features))).collect();
        let terms = rows[0].len();
        let x = DMatrix::from_fn(n, terms, |i, j| rows[i][j]);
        let truths: Vec<Vec<f64>> =
            bank.iter().map(|d| d.truth.iter().zip(&unknowns).map(|(v, u)| to_scale(u, *v)).collect()).collect();
        let y = DMatrix::from_fn(n, unknowns.len(), |i, j| truths[i][j]);
        let mut normal = x.transpose() * &x;
        let ridge = 1e-6 * normal.trace() / terms as f64;
        for j in 1..terms {
            normal[(j, j)] += ridge;
        }
        let rhs = x.transpose() * &y;
        let solution = normal
            .cholesky()
            .ok_or_else(|| EstimateError::Failure("the regression's normal equations are singular".into()))?
            .solve(&rhs);
        let fitted = &x * &solution;
        let coefficients: Vec<Vec<f64>> =
            (0..unknowns.len()).map(|k| solution.column(k).iter().copied().collect()).collect();
        let summary_scale: Vec<f64> = (0..unknowns.len())
            .map(|k| {
                let r = (0..n).map(|i| (y[(i, k)] - fitted[(i, k)]).powi(2)).sum::<f64>() / n as f64;
                r.sqrt().max(1e-12)
            })
            .collect();
        let bank_summaries: Vec<Vec<f64>> = (0..n).map(|i| fitted.row(i).iter().copied().collect()).collect();
        let summary_spread = (0..unknowns.len())
            .map(|k| {
                let mean = bank_summaries.iter().map(|b| b[k]).sum::<f64>() / n as f64;
                (bank_summaries.iter().map(|b| (b[k] - mean).powi(2)).sum::<f64>() / n as f64).sqrt().max(1e-12)
            })
            .collect();
        Ok(Self {
            setup: setup.clone(),
            joints,
            calibration: vec![Calibration { shift: 0.0, widen: 1.0, cases: 0 }; unknowns.len()],
            hidden_calibration: None,
            unknowns,
            speed_band_hz,
            feature_mean: mean,
            feature_scale: scale,
            coefficients,
            summary_scale,
            summary_spread,
            bank_summaries,
            bank_truths: truths,
        })
    }

    /// The summaries of a feature vector.
    pub fn summaries(&self, features: &[f64]) -> Vec<f64> {
        let z: Vec<f64> =
            features.iter().zip(&self.feature_mean).zip(&self.feature_scale).map(|((v, m), s)| (v - m) / s).collect();
        let row = DVector::from_vec(design(&z));
        self.coefficients.iter().map(|c| row.dot(&DVector::from_column_slice(c))).collect()
    }

    /// Indices of the bank draws nearest to `summaries` in the summaries `dims`, each distance
    /// divided by that summary's spread over the bank.
    fn neighbours(&self, summaries: &[f64], dims: &[usize]) -> Vec<usize> {
        let spread: Vec<f64> = dims.iter().map(|&k| self.summary_spread[k]).collect();
        let mut distance: Vec<(f64, usize)> = self
            .bank_summaries
            .iter()
            .enumerate()
            .map(|(i, b)| (dims.iter().zip(&spread).map(|(&k, w)| ((b[k] - summaries[k]) / w).powi(2)).sum(), i))
            .collect();
        let k = self.setup.neighbours.min(distance.len());
        distance.select_nth_unstable_by(k - 1, |a, b| a.0.total_cmp(&b.0));
        distance.truncate(k);
        distance.into_iter().map(|(_, i)| i).collect()
    }

    /// The uncalibrated posterior of every unknown — each from the bank draws nearest in its own
    /// summary (the summary is the regression's best guess of it; conditioning on it alone keeps
    /// a sharply identified nuisance, the crank speed, from choosing the draws) — and the draws
    /// nearest in the clearances' summaries together.
    fn raw(&self, features: &[f64]) -> (Vec<Raw>, Vec<Vec<f64>>, Vec<usize>) {
        let summaries = self.summaries(features);
        let samples: Vec<Vec<f64>> = (0..self.unknowns.len())
            .map(|k| {
                let near = self.neighbours(&summaries, &[k]);
                let mut v: Vec<f64> = near.iter().map(|&i| self.bank_truths[i][k]).collect();
                v.sort_by(f64::total_cmp);
                v
            })
            .collect();
        let raw = samples.iter().map(|v| (quantile(v, 0.5), quantile(v, 0.05), quantile(v, 0.95))).collect();
        let clearances: Vec<usize> = (0..self.joints.len()).collect();
        (raw, samples, self.neighbours(&summaries, &clearances))
    }

    /// The calibrated (median, low, high) on the estimation scale, within the prior.
    fn calibrated(&self, k: usize, (median, low, high): Raw) -> Raw {
        let (u, c) = (&self.unknowns[k], self.calibration[k]);
        let (lo, hi) = (to_scale(u, u.low), to_scale(u, u.high));
        let m = median + c.shift;
        ((m).clamp(lo, hi), (m - c.widen * (median - low)).clamp(lo, hi), (m + c.widen * (high - median)).clamp(lo, hi))
    }

    /// The estimate from a feature vector taken at crank frequency `f0`.
    pub fn estimate(&self, features: &[f64], f0: f64) -> Estimate {
        let (raw, samples, near) = self.raw(features);
        let unknowns = raw
            .iter()
            .enumerate()
            .map(|(k, r)| {
                let u = &self.unknowns[k];
                let (m, lo, hi) = self.calibrated(k, *r);
                UnknownEstimate {
                    name: u.name.clone(),
                    unit: u.unit.clone(),
                    median: from_scale(u, m),
                    low: from_scale(u, lo),
                    high: from_scale(u, hi),
                    prior: [u.low, u.high],
                }
            })
            .collect();
        let joints = self.joints.len();
        let worn = if joints > 1 {
            let mut counts = vec![0usize; joints];
            for &i in &near {
                let t = &self.bank_truths[i][..joints];
                let j = (0..joints).max_by(|&a, &b| t[a].total_cmp(&t[b])).unwrap_or(0);
                counts[j] += 1;
            }
            self.joints.iter().zip(counts).map(|(j, c)| (j.clone(), c as f64 / near.len() as f64)).collect()
        } else {
            Vec::new()
        };
        let clearance_draws = (0..joints)
            .map(|k| {
                let (u, c, median) = (&self.unknowns[k], self.calibration[k], raw[k].0);
                let (lo, hi) = (to_scale(u, u.low), to_scale(u, u.high));
                samples[k]
                    .iter()
                    .map(|v| from_scale(u, (median + c.shift + c.widen * (v - median)).clamp(lo, hi)))
                    .collect()
            })
            .collect();
        Estimate { unknowns, worn, crank_frequency: f0, clearance_draws }
    }

    /// A joint posterior sample: the bank draws nearest in the clearances' summaries, each a full
    /// vector of unknowns (the order of [`Estimator::unknowns`]) with its clearances mapped by the
    /// calibration as the reported intervals are.
    pub fn posterior(&self, features: &[f64]) -> Vec<Vec<f64>> {
        let (raw, _, near) = self.raw(features);
        near.iter()
            .map(|&i| {
                // The bank keeps its truths on the estimation scale.
                let mut draw = self.bank_truths[i].clone();
                for (k, value) in draw.iter_mut().enumerate() {
                    let u = &self.unknowns[k];
                    if k < self.joints.len() {
                        let (c, median) = (self.calibration[k], raw[k].0);
                        let (lo, hi) = (to_scale(u, u.low), to_scale(u, u.high));
                        *value = (median + c.shift + c.widen * (*value - median)).clamp(lo, hi);
                    }
                    *value = from_scale(u, *value);
                }
                draw
            })
            .collect()
    }

    /// Calibrates the medians and intervals on full-model draws: even-numbered draws give each
    /// unknown's median shift, odd-numbered ones the conformal widening factor for 90 % coverage.
    pub fn calibrate(&mut self, draws: &[Draw]) -> Result<(), EstimateError> {
        if draws.len() < 20 {
            return Err(EstimateError::Failure(format!("{} calibration draws: at least 20 are needed", draws.len())));
        }
        let raws: Vec<Vec<Raw>> = draws.iter().map(|d| self.raw(&d.features).0).collect();
        for k in 0..self.unknowns.len() {
            let u = self.unknowns[k].clone();
            let truth = |i: usize| to_scale(&u, draws[i].truth[k]);
            let mut errors: Vec<f64> = (0..draws.len()).step_by(2).map(|i| truth(i) - raws[i][k].0).collect();
            errors.sort_by(f64::total_cmp);
            let shift = quantile(&errors, 0.5);
            let mut scores: Vec<f64> = (1..draws.len())
                .step_by(2)
                .map(|i| {
                    let (m, lo, hi) = raws[i][k];
                    let t = truth(i) - shift;
                    if t < m { (m - t) / (m - lo).max(1e-12) } else { (t - m) / (hi - m).max(1e-12) }
                })
                .collect();
            scores.sort_by(f64::total_cmp);
            let n = scores.len();
            // The conformal quantile: the ⌈0.9 (n + 1)⌉-th smallest score.
            let rank = ((0.9 * (n + 1) as f64).ceil() as usize).clamp(1, n);
            self.calibration[k] = Calibration { shift, widen: scores[rank - 1], cases: n };
        }
        Ok(())
    }
}

/// A measured file read and checked as the setup expects it: the measurement, its crank
/// frequency and its features.
fn read_measured(
    estimator: &Estimator,
    path: &std::path::Path,
) -> Result<(crate::Measurement, f64, Vec<f64>), EstimateError> {
    let setup = &estimator.setup;
    let expect = crate::measurement::Expect {
        channels: &setup.channels,
        sample_rate: setup.sample_rate,
        anti_alias: setup.anti_alias,
        window: setup.window,
        revolution: 1.0 / estimator.speed_band_hz.0,
    };
    let m = crate::Measurement::read(path, &expect)?;
    let band = match m.speed {
        Some(w) => (0.99 * w / std::f64::consts::TAU, 1.01 * w / std::f64::consts::TAU),
        None => estimator.speed_band_hz,
    };
    let (f0, features) = crate::prepare::measured_features(setup, band, &m.channels).ok_or_else(|| {
        EstimateError::Input(format!("{}: no crank frequency found in {:.1}–{:.1} Hz", path.display(), band.0, band.1))
    })?;
    Ok((m, f0, features))
}

/// A measured file's estimate: its features, the answer, and notes on what was done to the data.
pub fn estimate_file(estimator: &Estimator, path: &std::path::Path) -> Result<(Estimate, Vec<String>), EstimateError> {
    let (m, f0, features) = read_measured(estimator, path)?;
    Ok((estimator.estimate(&features, f0), m.notes))
}

/// As [`estimate_file`], with the hidden signals (each joint's contact force and eccentricity
/// over the measured window, with bands: [`crate::hidden`]), the impacts timed by the particle
/// filter of [`crate::track`] when `track` is given.
pub fn estimate_file_hidden(
    estimator: &Estimator,
    path: &std::path::Path,
    track: Option<crate::track::TrackOptions>,
) -> Result<(Estimate, crate::Hidden, Vec<String>), EstimateError> {
    let (m, f0, features) = read_measured(estimator, path)?;
    let hidden = crate::hidden::reconstruct(estimator, &features, f0, &m.channels[0], track)?;
    Ok((estimator.estimate(&features, f0), hidden, m.notes))
}

impl Estimator {
    /// Reads a prepared estimator (`lash estimate prepare`'s file).
    pub fn load(path: &std::path::Path) -> Result<Self, EstimateError> {
        let text = std::fs::read_to_string(path).map_err(|e| {
            EstimateError::Input(format!("--prepared {}: {e} (make one with `lash estimate prepare`)", path.display()))
        })?;
        serde_json::from_str(&text)
            .map_err(|e| EstimateError::Input(format!("--prepared {}: not a prepared estimator: {e}", path.display())))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A toy bank: one clearance and a nuisance, features = noisy functions of them.
    fn toy(n: usize, seed: u64, bias: f64) -> Vec<Draw> {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                let c: f64 = rng.random_range(50e-6..300e-6);
                let e: f64 = rng.random_range(0.5..0.95);
                let noise = |r: &mut rand_chacha::ChaCha8Rng| r.random_range(-1.0..1.0) * 0.05;
                let features = vec![c.ln() + bias + noise(&mut rng), e + noise(&mut rng), noise(&mut rng)];
                Draw { features, truth: vec![c, e], seconds: 0.0 }
            })
            .collect()
    }

    fn estimator(bank: &[Draw]) -> Estimator {
        let mut setup = crate::setup::builtin("A").unwrap();
        setup.neighbours = 100;
        let unknowns = vec![
            Unknown { name: "c".into(), unit: "m".into(), scale: Scale::Log, low: 50e-6, high: 300e-6 },
            Unknown { name: "e".into(), unit: "".into(), scale: Scale::Linear, low: 0.5, high: 0.95 },
        ];
        Estimator::fit(&setup, vec!["j".into()], unknowns, (70.0, 95.0), bank).unwrap()
    }

    /// Calibrated on draws of the generator the test data come from, the intervals cover about
    /// 90 % — on the bank's own generator, and on one with a model error (a shifted feature) that
    /// leaves the uncalibrated intervals far off.
    #[test]
    fn calibrated_intervals_cover_ninety_percent() {
        let mut e = estimator(&toy(6000, 1, 0.0));
        let coverage = |e: &Estimator, test: &[Draw]| {
            let hit = test
                .iter()
                .filter(|d| {
                    let u = &e.estimate(&d.features, 80.0).unknowns[0];
                    u.low <= d.truth[0] && d.truth[0] <= u.high
                })
                .count();
            hit as f64 / test.len() as f64
        };
        e.calibrate(&toy(400, 5, 0.0)).unwrap();
        let same = coverage(&e, &toy(1000, 2, 0.0));
        assert!((0.85..=0.95).contains(&same), "{same}");
        let mut e = estimator(&toy(6000, 1, 0.0));
        let shifted = toy(1000, 3, 0.3);
        let before = coverage(&e, &shifted);
        assert!(before < 0.5, "an uncalibrated model error leaves the truth out: {before}");
        e.calibrate(&toy(400, 4, 0.3)).unwrap();
        let after = coverage(&e, &shifted);
        assert!((0.85..=0.95).contains(&after), "{after}");
    }
}
