//! The reduced model's stated bounds against the converged full model, checked over a window of
//! steady running (past the start-up): the statistics a vibration study reads — mean and RMS loads
//! of every joint, the sensors' RMS and band powers up to the sensor's band, impacts per revolution
//! — not pointwise errors, which a chaotic impact response makes large between any two models.

use crate::{BANDS, CompareError, amplitude_spectrum, band_powers};
use serde::Serialize;

/// The bounds, one table for every scenario (docs/validation.md states them and where they hold).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Bounds {
    /// A load's mean: |mean_reduced − mean_full| ≤ `mean` × RMS_full (relative to the RMS, so that
    /// a load whose mean is near zero is not judged by round-off).
    pub mean: f64,
    /// Every compared channel's RMS: |RMS_reduced / RMS_full − 1| ≤ `rms`.
    pub rms: f64,
    /// A sensor's power in each band below its band limit: the ratio reduced / full within
    /// [1 / `band_power`, `band_power`] (a factor 2 is ±3 dB).
    pub band_power: f64,
    /// Bands holding less than this fraction of the full model's power of the channel are not
    /// judged (a ratio of two negligible powers says nothing about the sensor's signal).
    pub band_share: f64,
    /// Impacts per revolution of each joint: the ratio reduced / full within
    /// [1 / `impacts`, `impacts`], or the counts within one of each other.
    pub impacts: f64,
}

/// The bounds lash states for the reduced model at its defaults.
pub const STATED: Bounds = Bounds { mean: 0.05, rms: 0.10, band_power: 2.0, band_share: 0.01, impacts: 1.5 };

/// Where the statistics are taken, and what the sensors see.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Window {
    /// Start of the window of steady running \[s\] (it ends with the run).
    pub start: f64,
    /// The driver's revolution \[s\], when it turns at constant speed (impacts are counted per
    /// revolution; otherwise per second).
    pub revolution: Option<f64>,
    /// Upper end of the sensors' band \[Hz\]: bands of [`BANDS`] starting below it are judged.
    pub sensor_band_hz: f64,
}

/// What a channel is, for the checks it gets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// A sensor's signal (acceleration): RMS and band powers.
    Sensor,
    /// A load (driver torque, joint force): mean and RMS.
    Load,
    /// A clearance joint's contact force magnitude: mean and RMS, and its impacts (onsets of a
    /// non-zero force) per revolution.
    Contact,
}

/// How a [`Check`]'s error reads and what holds it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CheckKind {
    /// A relative error (of the full model's RMS), held within ± the bound (RMS, mean).
    Relative,
    /// The ratio reduced / full, held within a factor (band powers).
    Ratio,
    /// Contact onsets: the ratio reduced / full within a factor, or one onset apart.
    Onsets,
}

/// One checked quantity.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Check {
    /// Channel and statistic, e.g. `slider.ax rms` or `crank_pivot.force impacts_per_revolution`.
    pub quantity: String,
    /// How its error reads.
    pub kind: CheckKind,
    /// The full model's value.
    pub full: f64,
    /// The reduced model's value.
    pub reduced: f64,
    /// The error in the bound's terms (relative error, or the ratio reduced / full for band
    /// powers and impacts; infinite, `null` in JSON, where the full model has no impact).
    pub error: f64,
    /// The bound it is held to (for ratios: the factor).
    pub bound: f64,
    /// Whether the bound holds.
    pub met: bool,
}

/// Checks `channels` (each with its role) of two runs sampled on one grid over `window`.
pub fn check_bounds(
    (header_full, full): (&[String], &[Vec<f64>]),
    (header_reduced, reduced): (&[String], &[Vec<f64>]),
    channels: &[(String, Role)],
    window: &Window,
    bounds: &Bounds,
) -> Result<Vec<Check>, CompareError> {
    if full.len() != reduced.len() || full.len() < 2 {
        return Err(CompareError::Samples { full: full.len(), reduced: reduced.len() });
    }
    let first = full.iter().position(|r| r[0] >= window.start).unwrap_or(full.len());
    if full.len() - first < 2 {
        return Err(CompareError::Samples { full: full.len() - first, reduced: reduced.len() - first });
    }
    let dt = full[1][0] - full[0][0];
    let span = full[full.len() - 1][0] - full[first][0] + dt;
    let find = |h: &[String], name: &str| h.iter().position(|c| c.starts_with(&format!("{name} [")));
    let mut checks = Vec::new();
    for (name, role) in channels {
        let (Some(kf), Some(kr)) = (find(header_full, name), find(header_reduced, name)) else {
            return Err(CompareError::MissingChannel(name.clone()));
        };
        let f: Vec<f64> = full[first..].iter().map(|r| r[kf]).collect();
        let r: Vec<f64> = reduced[first..].iter().map(|r| r[kr]).collect();
        let (rms_f, rms_r) = (rms(&f), rms(&r));
        let relative = |quantity: &str, a: f64, b: f64, scale: f64, bound: f64| {
            let error = if scale > 0.0 { (b - a) / scale } else { 0.0 };
            Check {
                quantity: format!("{name} {quantity}"),
                kind: CheckKind::Relative,
                full: a,
                reduced: b,
                error,
                bound,
                met: error.abs() <= bound,
            }
        };
        checks.push(relative("rms", rms_f, rms_r, rms_f, bounds.rms));
        if *role != Role::Sensor {
            checks.push(relative("mean", mean(&f), mean(&r), rms_f, bounds.mean));
        }
        if *role == Role::Sensor {
            checks.extend(band_checks(name, (&f, &r), dt, window.sensor_band_hz, bounds));
        }
        if *role == Role::Contact {
            let per = window.revolution.map_or(span, |p| span / p);
            let (nf, nr) = (onsets(&f) as f64, onsets(&r) as f64);
            let ratio = if nf > 0.0 {
                nr / nf
            } else if nr > 0.0 {
                f64::INFINITY
            } else {
                1.0
            };
            let unit = if window.revolution.is_some() { "impacts_per_revolution" } else { "impacts_per_second" };
            checks.push(Check {
                quantity: format!("{name} {unit}"),
                kind: CheckKind::Onsets,
                full: nf / per,
                reduced: nr / per,
                error: ratio,
                bound: bounds.impacts,
                met: (nr - nf).abs() <= 1.0 || (1.0 / bounds.impacts..=bounds.impacts).contains(&ratio),
            });
        }
    }
    Ok(checks)
}

/// The band-power checks of one sensor channel over the window.
fn band_checks(name: &str, (f, r): (&[f64], &[f64]), dt: f64, band_hz: f64, bounds: &Bounds) -> Vec<Check> {
    let (freqs, af) = amplitude_spectrum(f, dt);
    let (_, ar) = amplitude_spectrum(r, dt);
    let (pf, pr) = (band_powers(&freqs, &af), band_powers(&freqs, &ar));
    let total: f64 = pf.iter().sum();
    let mut checks = Vec::new();
    for (k, &(lo, hi)) in BANDS.iter().enumerate() {
        if lo >= band_hz || pf[k] < bounds.band_share * total {
            continue;
        }
        let ratio = pr[k] / pf[k];
        let band = if hi.is_finite() { format!("{lo:.0}-{hi:.0} Hz") } else { format!("above {lo:.0} Hz") };
        checks.push(Check {
            quantity: format!("{name} power {band}"),
            kind: CheckKind::Ratio,
            full: pf[k],
            reduced: pr[k],
            error: ratio,
            bound: bounds.band_power,
            met: (1.0 / bounds.band_power..=bounds.band_power).contains(&ratio),
        });
    }
    checks
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len().max(1) as f64
}

/// Root mean square (of a whole run in [`crate::compare_series`], of the window here).
pub(crate) fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

/// Onsets of contact in a sampled force magnitude: samples where it becomes non-zero.
fn onsets(force: &[f64]) -> usize {
    force.windows(2).filter(|w| w[0] <= 0.0 && w[1] > 0.0).count()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header() -> Vec<String> {
        ["time [s]", "s.ax [m/s^2]", "j.force [N]"].iter().map(|s| s.to_string()).collect()
    }

    /// A 1 kHz acceleration and a force that is on for 1 ms of every 4 ms (one revolution = 8 ms).
    fn run(amplitude: f64, force: f64, on_every: usize) -> Vec<Vec<f64>> {
        (0..4000)
            .map(|k| {
                let t = k as f64 * 1e-5;
                let on = (k / 100) % on_every == 0;
                vec![t, amplitude * (2.0 * std::f64::consts::PI * 1000.0 * t).sin(), if on { force } else { 0.0 }]
            })
            .collect()
    }

    fn checks(full: &[Vec<f64>], reduced: &[Vec<f64>]) -> Vec<Check> {
        let h = header();
        let window = Window { start: 0.008, revolution: Some(0.008), sensor_band_hz: 10_000.0 };
        let channels = [("s.ax".to_string(), Role::Sensor), ("j.force".to_string(), Role::Contact)];
        check_bounds((&h, full), (&h, reduced), &channels, &window, &STATED).unwrap()
    }

    #[test]
    fn equal_runs_meet_every_bound_and_the_statistics_are_those_of_the_signals() {
        let a = run(2.0, 50.0, 4);
        let c = checks(&a, &a);
        assert!(c.iter().all(|c| c.met), "{c:?}");
        let get = |q: &str| c.iter().find(|c| c.quantity == q).unwrap_or_else(|| panic!("{q}: {c:?}"));
        // A sine's RMS is A/√2; the force is on a quarter of the time.
        assert!((get("s.ax rms").full - 2.0 / 2f64.sqrt()).abs() < 1e-3);
        assert!((get("j.force mean").full - 12.5).abs() < 0.1);
        // 32 ms past the 8 ms start-up, one onset every 4 ms: two per 8 ms revolution.
        assert!((get("j.force impacts_per_revolution").full - 2.0).abs() < 0.3);
        // The sine's power A²/2 = 2 sits in the 500–2000 Hz band (the Hann window spreads it over
        // three bins, as in band_powers' own test); the other bands are not judged.
        let p = get("s.ax power 500-2000 Hz").full;
        assert!(p > 0.6 * 2.0 && p < 1.6 * 2.0, "{p}");
        assert_eq!(c.iter().filter(|c| c.quantity.contains("power")).count(), 1, "{c:?}");
    }

    #[test]
    fn each_bound_fails_where_its_statistic_leaves_it() {
        let full = run(2.0, 50.0, 4);
        // 12 % more acceleration: RMS fails (bound 10 %), band power 1.25× still holds (factor 2).
        let c = checks(&full, &run(2.24, 50.0, 4));
        let failed: Vec<&str> = c.iter().filter(|c| !c.met).map(|c| c.quantity.as_str()).collect();
        assert_eq!(failed, ["s.ax rms"]);
        // 1.5× the amplitude: power 2.25× fails too.
        let c = checks(&full, &run(3.0, 50.0, 4));
        assert!(c.iter().any(|c| c.quantity == "s.ax power 500-2000 Hz" && !c.met), "{c:?}");
        // Twice as many impacts, each as long: the mean, the RMS and the count fail.
        let c = checks(&full, &run(2.0, 50.0, 2));
        let failed: Vec<&str> = c.iter().filter(|c| !c.met).map(|c| c.quantity.as_str()).collect();
        assert_eq!(failed, ["j.force rms", "j.force mean", "j.force impacts_per_revolution"]);
    }

    #[test]
    fn a_window_past_the_run_is_refused() {
        let a = run(1.0, 1.0, 4);
        let h = header();
        let window = Window { start: 1.0, revolution: None, sensor_band_hz: 1e4 };
        assert!(check_bounds((&h, &a), (&h, &a), &[], &window, &STATED).is_err());
    }
}
