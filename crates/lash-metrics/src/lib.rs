//! Comparison metrics of two runs sampled on one grid (the full and the reduced model, or any two),
//! chosen for chaotic impact responses, where pointwise errors say little (docs/validation.md):
//! peaks, RMS, pointwise errors (whole run and over the first impacts), Hann-windowed one-sided
//! amplitude spectra, their relative distance, and band powers; and the reduced model's stated
//! bounds, checked over a window of steady running ([`check_bounds`]).

mod bounds;

pub use bounds::{Bounds, Check, CheckKind, Role, STATED, Window, check_bounds};
use rustfft::{FftPlanner, num_complex::Complex};
use serde::Serialize;
use std::collections::BTreeMap;

/// Frequency bands \[Hz\] of the band powers (the last one ends at the Nyquist frequency).
pub const BANDS: [(f64, f64); 4] = [(0.0, 500.0), (500.0, 2_000.0), (2_000.0, 10_000.0), (10_000.0, f64::INFINITY)];

/// One-sided amplitude spectrum of a uniformly sampled signal (mean removed, Hann window,
/// amplitude-corrected: a sine of amplitude A shows a peak of ≈ A). Returns (frequencies, amplitudes).
pub fn amplitude_spectrum(signal: &[f64], dt: f64) -> (Vec<f64>, Vec<f64>) {
    let n = signal.len();
    if n < 2 {
        return (vec![], vec![]);
    }
    let mean = signal.iter().sum::<f64>() / n as f64;
    let window: Vec<f64> =
        (0..n).map(|k| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * k as f64 / (n - 1) as f64).cos()).collect();
    let gain: f64 = window.iter().sum();
    let mut buffer: Vec<Complex<f64>> =
        signal.iter().zip(&window).map(|(x, w)| Complex { re: (x - mean) * w, im: 0.0 }).collect();
    FftPlanner::new().plan_fft_forward(n).process(&mut buffer);
    let half = n / 2 + 1;
    let freqs = (0..half).map(|k| k as f64 / (n as f64 * dt)).collect();
    let amps = (0..half).map(|k| if k == 0 { 0.0 } else { 2.0 * buffer[k].norm() / gain }).collect();
    (freqs, amps)
}

/// Power (mean square of the sinusoids, Σ A²/2) of the spectrum in each of [`BANDS`].
pub fn band_powers(freqs: &[f64], amps: &[f64]) -> Vec<f64> {
    BANDS
        .iter()
        .map(|&(lo, hi)| freqs.iter().zip(amps).filter(|(f, _)| **f >= lo && **f < hi).map(|(_, a)| a * a / 2.0).sum())
        .collect()
}

/// Comparison of one channel.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelComparison {
    /// Unit.
    pub unit: String,
    /// Largest |value|, full model.
    pub peak_full: f64,
    /// Largest |value|, reduced model.
    pub peak_reduced: f64,
    /// RMS, full model.
    pub rms_full: f64,
    /// RMS, reduced model.
    pub rms_reduced: f64,
    /// ‖reduced − full‖₂ / ‖full‖₂ over the whole run (pointwise).
    pub relative_rms_error: f64,
    /// The same over the first `first_window_s` seconds (through the first impacts).
    pub relative_rms_error_first_window: f64,
    /// ‖A_reduced − A_full‖₂ / ‖A_full‖₂ of the amplitude spectra.
    pub spectral_distance: f64,
    /// Band powers of the full model, per [`BANDS`].
    pub band_powers_full: Vec<f64>,
    /// Band powers of the reduced model.
    pub band_powers_reduced: Vec<f64>,
}

/// Why two runs cannot be compared.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CompareError {
    /// Sample counts that differ, or fewer than two.
    #[error("the runs have {full} and {reduced} samples; they must match (≥ 2)")]
    Samples {
        /// Samples of the full run.
        full: usize,
        /// Samples of the reduced run.
        reduced: usize,
    },
    /// A channel one of the runs lacks.
    #[error("channel {0:?} is missing from one of the runs")]
    MissingChannel(String),
}

/// Compares the columns of two runs sampled on the same grid. `header`s carry units
/// (`name [unit]`); `channels` names the channels to compare.
pub fn compare_series(
    header_full: &[String],
    full: &[Vec<f64>],
    header_reduced: &[String],
    reduced: &[Vec<f64>],
    channels: &[String],
    first_window_s: f64,
) -> Result<BTreeMap<String, ChannelComparison>, CompareError> {
    if full.len() != reduced.len() || full.len() < 2 {
        return Err(CompareError::Samples { full: full.len(), reduced: reduced.len() });
    }
    let dt = full[1][0] - full[0][0];
    let find = |h: &[String], name: &str| h.iter().position(|c| c.starts_with(&format!("{name} [")));
    let mut out = BTreeMap::new();
    for name in channels {
        let (Some(kf), Some(kr)) = (find(header_full, name), find(header_reduced, name)) else {
            return Err(CompareError::MissingChannel(name.clone()));
        };
        let unit = header_full[kf].split('[').nth(1).unwrap_or("").trim_end_matches(']').to_string();
        let f: Vec<f64> = full.iter().map(|r| r[kf]).collect();
        let r: Vec<f64> = reduced.iter().map(|r| r[kr]).collect();
        let rel = |a: &[f64], b: &[f64]| {
            let e: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
            let n: f64 = a.iter().map(|x| x * x).sum();
            if n > 0.0 { (e / n).sqrt() } else { 0.0 }
        };
        let t0 = full[0][0];
        let first = full.iter().take_while(|row| row[0] - t0 <= first_window_s).count();
        let (freqs, af) = amplitude_spectrum(&f, dt);
        let (_, ar) = amplitude_spectrum(&r, dt);
        out.insert(
            name.clone(),
            ChannelComparison {
                unit,
                peak_full: f.iter().fold(0.0, |m, v| m.max(v.abs())),
                peak_reduced: r.iter().fold(0.0, |m, v| m.max(v.abs())),
                rms_full: bounds::rms(&f),
                rms_reduced: bounds::rms(&r),
                relative_rms_error: rel(&f, &r),
                relative_rms_error_first_window: rel(&f[..first], &r[..first]),
                spectral_distance: rel(&af, &ar),
                band_powers_full: band_powers(&freqs, &af),
                band_powers_reduced: band_powers(&freqs, &ar),
            },
        );
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sine_shows_its_amplitude_at_its_frequency() {
        let dt = 1e-5;
        let (a, f0) = (3.0, 1_250.0);
        let x: Vec<f64> =
            (0..8000).map(|k| 7.0 + a * (2.0 * std::f64::consts::PI * f0 * k as f64 * dt).sin()).collect();
        let (freqs, amps) = amplitude_spectrum(&x, dt);
        let (k, peak) = amps.iter().enumerate().fold((0, 0.0), |b, (k, &v)| if v > b.1 { (k, v) } else { b });
        assert!((freqs[k] - f0).abs() <= freqs[1], "peak at {} Hz", freqs[k]);
        assert!((peak - a).abs() < 0.02 * a, "peak amplitude {peak}");
        // Parseval-like check: the band holding f0 carries ≈ A²/2 (Hann spreads over neighbours).
        let p = band_powers(&freqs, &amps);
        assert!(p[1] > 0.6 * a * a / 2.0 && p[1] < 1.6 * a * a / 2.0, "band power {}", p[1]);
    }

    #[test]
    fn identical_runs_have_zero_distance_and_different_ones_do_not() {
        let h = vec!["time [s]".to_string(), "x [m]".to_string()];
        let a: Vec<Vec<f64>> = (0..100).map(|k| vec![k as f64 * 1e-3, (k as f64 * 0.3).sin()]).collect();
        let mut b = a.clone();
        let c = compare_series(&h, &a, &h, &b, &["x".to_string()], 0.01).unwrap();
        assert_eq!(c["x"].relative_rms_error, 0.0);
        assert_eq!(c["x"].spectral_distance, 0.0);
        for r in &mut b {
            r[1] *= 1.1;
        }
        let c = compare_series(&h, &a, &h, &b, &["x".to_string()], 0.01).unwrap();
        assert!((c["x"].relative_rms_error - 0.1).abs() < 1e-12);
        assert!((c["x"].spectral_distance - 0.1).abs() < 1e-12);
        assert!(compare_series(&h, &a, &h, &b[..50], &["x".to_string()], 0.01).is_err());
    }
}
