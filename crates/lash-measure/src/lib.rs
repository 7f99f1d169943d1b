//! Emulated vibration measurements.
//!
//! A simulation gives the force a joint passes to the frame (the guide's reaction on the ground);
//! a test rig measures the vibration of a housing that carries the bearing and the
//! accelerometers. Two stages turn the first into the second:
//!
//! * [`Mount`]: the housing as a mass on a spring–damper to the ground along each axis
//!   (`m ẍ + c ẋ + k x = F(t)`, `k = m (2π f_n)²`, `c = 2 ζ √(k m)`), driven by the force samples,
//!   which are taken as linear between samples; the response is the exact solution of that input
//!   (the matrix exponential of the augmented system, computed once per mount and step), not an
//!   integration with an error of its own.
//! * [`Acquisition`]: a data logger — a Butterworth anti-alias low-pass (cascaded second-order
//!   sections from the `biquad` crate, run at the simulation's output rate), decimation to the
//!   logger's rate, the steady-state window (after a settling time), the mean removed (a piezo
//!   accelerometer does not see the constant part; a measured motor-only mean can be given
//!   instead), and the Hann-windowed amplitude spectrum of `lash-metrics` for the peak frequency,
//!   the peak amplitude and the RMS.

use biquad::{Biquad, Coefficients, DirectForm2Transposed, ToHertz, Type};
use lash_core::Problems;
use nalgebra::{Matrix4, Vector4};
use serde::{Deserialize, Serialize};

/// A housing on a spring–damper mount, the same along every axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mount {
    /// Housing mass (bearing and sensors) \[kg\].
    pub mass: f64,
    /// Natural frequency of the mounted housing f_n \[Hz\].
    pub natural_frequency: f64,
    /// Damping ratio ζ [-].
    pub damping_ratio: f64,
}

impl Mount {
    /// Every problem of the numbers.
    pub fn validate(&self) -> Problems {
        let mut p = Problems::new();
        p.positive("mass", self.mass);
        p.positive("natural_frequency", self.natural_frequency);
        p.non_negative("damping_ratio", self.damping_ratio);
        p
    }

    /// Stiffness k = m (2π f_n)² [N/m].
    pub fn stiffness(&self) -> f64 {
        self.mass * (2.0 * std::f64::consts::PI * self.natural_frequency).powi(2)
    }

    /// Damping c = 2 ζ √(k m) [N s/m].
    pub fn damping(&self) -> f64 {
        2.0 * self.damping_ratio * (self.stiffness() * self.mass).sqrt()
    }

    /// The housing's acceleration [m/s²] at the samples of `force` \[N\] (uniform step `dt`, linear
    /// between samples), starting at rest in its static position under the first sample.
    pub fn acceleration(&self, force: &[f64], dt: f64) -> Vec<f64> {
        let mut response = self.response(dt);
        force.iter().map(|&f| response.push(f)).collect()
    }

    /// The mount as a stream for force samples every `dt` ([`MountResponse::push`]): what
    /// [`Mount::acceleration`] computes, one sample at a time, holding only the housing's state.
    pub fn response(&self, dt: f64) -> MountResponse {
        let (m, k, c) = (self.mass, self.stiffness(), self.damping());
        // State (x, v, F, Ḟ) with Ḟ constant over a step: d/dt = A (x, v, F, Ḟ).
        #[rustfmt::skip]
        let a = Matrix4::new(
            0.0, 1.0, 0.0, 0.0,
            -k / m, -c / m, 1.0 / m, 0.0,
            0.0, 0.0, 0.0, 1.0,
            0.0, 0.0, 0.0, 0.0,
        );
        MountResponse { step: (a * dt).exp(), dt, mass: m, stiffness: k, damping: c, state: None }
    }
}

/// A mount driven sample by sample ([`Mount::response`]).
#[derive(Debug, Clone)]
pub struct MountResponse {
    /// The exact transition of (x, v, F, Ḟ) over one step.
    step: Matrix4<f64>,
    dt: f64,
    mass: f64,
    stiffness: f64,
    damping: f64,
    /// Displacement, velocity and force of the last sample (None before the first).
    state: Option<(f64, f64, f64)>,
}

impl MountResponse {
    /// The housing's acceleration [m/s²] at the next force sample \[N\]; the first sample finds the
    /// housing at rest in its static position under that force.
    pub fn push(&mut self, force: f64) -> f64 {
        let (x, v) = match self.state {
            None => (force / self.stiffness, 0.0),
            Some((x, v, previous)) => {
                let next = self.step * Vector4::new(x, v, previous, (force - previous) / self.dt);
                (next[0], next[1])
            }
        };
        self.state = Some((x, v, force));
        (force - self.damping * v - self.stiffness * x) / self.mass
    }
}

/// A data logger's acquisition chain.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Acquisition {
    /// Logger sampling rate \[Hz\] (the simulation's output interval must divide its period).
    pub sample_rate: f64,
    /// Anti-alias low-pass cut-off (−3 dB) \[Hz\], below half the sampling rate.
    pub cutoff: f64,
    /// Butterworth order of the anti-alias filter (even: cascaded second-order sections).
    #[serde(default = "default_order")]
    pub order: usize,
    /// Time from the run's start before the window of steady running begins \[s\].
    #[serde(default)]
    pub settle: f64,
}

fn default_order() -> usize {
    4
}

/// Why an acquisition chain cannot log samples at a simulation's output interval.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AcquisitionError {
    /// The output interval does not divide the logger's period.
    #[error("sample_rate {sample_rate} Hz: the output interval {dt} s must divide the logger's period {} s", 1.0 / sample_rate)]
    Period {
        /// The logger's rate \[Hz\].
        sample_rate: f64,
        /// The simulation's output interval \[s\].
        dt: f64,
    },
    /// The anti-alias filter cannot be designed at this rate.
    #[error("anti-alias filter at {cutoff} Hz for samples every {dt} s: {problem}")]
    Filter {
        /// Its cutoff \[Hz\].
        cutoff: f64,
        /// The simulation's output interval \[s\].
        dt: f64,
        /// What the filter design said.
        problem: String,
    },
}

impl Acquisition {
    /// Every problem of the numbers.
    pub fn validate(&self) -> Problems {
        let mut p = Problems::new();
        p.positive("sample_rate", self.sample_rate);
        p.positive("cutoff", self.cutoff);
        if self.cutoff.is_finite() && self.sample_rate.is_finite() && self.cutoff >= 0.5 * self.sample_rate {
            p.push("cutoff", format!("must be below half the sampling rate ({} Hz)", 0.5 * self.sample_rate));
        }
        if self.order == 0 || !self.order.is_multiple_of(2) || self.order > 16 {
            p.push("order", format!("must be even, 2 to 16 (cascaded second-order sections), got {}", self.order));
        }
        p.non_negative("settle", self.settle);
        p
    }

    /// The samples a logger would keep of `signal` (uniform step `dt` from time `t0`): low-passed,
    /// decimated, those from `t0 + settle` on, minus `baseline_mean` (None: minus their own mean,
    /// as an AC-coupled accelerometer). Errors name the setting that does not fit.
    pub fn acquire(&self, signal: &[f64], dt: f64, baseline_mean: Option<f64>) -> Result<Vec<f64>, AcquisitionError> {
        let mut logger = self.logger(dt)?;
        let mut kept = Vec::with_capacity(signal.len() / logger.every + 1);
        kept.extend(signal.iter().filter_map(|&x| logger.push(x)));
        let mean = baseline_mean.unwrap_or_else(|| kept.iter().sum::<f64>() / kept.len().max(1) as f64);
        kept.iter_mut().for_each(|x| *x -= mean);
        Ok(kept)
    }

    /// The chain as a stream for samples every `dt`: [`Logger::push`] one sample at a time, and it
    /// returns the logged ones (what [`Acquisition::acquire`] keeps, before the mean is removed),
    /// holding nothing but the filter's state.
    pub fn logger(&self, dt: f64) -> Result<Logger, AcquisitionError> {
        let ratio = 1.0 / (self.sample_rate * dt);
        let every = ratio.round();
        if !(every >= 1.0 && (ratio - every).abs() <= 1e-9 * ratio) {
            return Err(AcquisitionError::Period { sample_rate: self.sample_rate, dt });
        }
        let fs = (1.0 / dt).hz();
        let mut sections = Vec::with_capacity(self.order / 2);
        for k in 0..self.order / 2 {
            // Butterworth poles in pairs: Q_k = 1 / (2 cos((2k + 1) π / (2n))).
            let q = 1.0 / (2.0 * ((2 * k + 1) as f64 * std::f64::consts::PI / (2 * self.order) as f64).cos());
            let coefficients = Coefficients::<f64>::from_params(Type::LowPass, fs, self.cutoff.hz(), q)
                .map_err(|e| AcquisitionError::Filter { cutoff: self.cutoff, dt, problem: format!("{e:?}") })?;
            sections.push(DirectForm2Transposed::<f64>::new(coefficients));
        }
        Ok(Logger {
            sections,
            every: every as usize,
            first: (self.settle / dt).ceil() as usize,
            settling: (4.0 / (self.cutoff * dt)).ceil() as usize,
            index: 0,
        })
    }
}

/// An acquisition chain running sample by sample ([`Acquisition::logger`]).
#[derive(Debug, Clone)]
pub struct Logger {
    sections: Vec<DirectForm2Transposed<f64>>,
    /// Decimation factor.
    every: usize,
    /// First kept sample index (the settle time).
    first: usize,
    /// Filter steps run on the first sample before it (no step transient from zero).
    settling: usize,
    /// Samples pushed so far.
    index: usize,
}

impl Logger {
    /// Filters the next sample; returns the logged value when this sample is one the logger keeps.
    pub fn push(&mut self, x: f64) -> Option<f64> {
        if self.index == 0 {
            // Start the filter settled on the first value.
            for _ in 0..self.settling {
                let mut y = x;
                for s in self.sections.iter_mut() {
                    y = s.run(y);
                }
            }
        }
        let mut y = x;
        for s in self.sections.iter_mut() {
            y = s.run(y);
        }
        let i = self.index;
        self.index += 1;
        (i.is_multiple_of(self.every) && i >= self.first).then_some(y)
    }
}

/// What a vibration analyser reports of one axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Vibration {
    /// Frequency of the largest spectral line \[Hz\].
    pub peak_frequency: f64,
    /// Its amplitude (Hann-window corrected: a sine of amplitude A reads ≈ A).
    pub peak_amplitude: f64,
    /// RMS of the samples.
    pub rms: f64,
    /// Samples analysed.
    pub samples: usize,
}

/// Peak frequency, peak amplitude and RMS of logger samples at `sample_rate`.
pub fn analyse(samples: &[f64], sample_rate: f64) -> Vibration {
    let (freqs, amps) = lash_metrics::amplitude_spectrum(samples, 1.0 / sample_rate);
    let (peak_frequency, peak_amplitude) =
        freqs.iter().zip(&amps).fold((0.0, 0.0), |best, (&f, &a)| if a > best.1 { (f, a) } else { best });
    let rms = (samples.iter().map(|x| x * x).sum::<f64>() / samples.len().max(1) as f64).sqrt();
    Vibration { peak_frequency, peak_amplitude, rms, samples: samples.len() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn mount() -> Mount {
        Mount { mass: 1.05, natural_frequency: 150.0, damping_ratio: 0.05 }
    }

    #[test]
    fn a_harmonic_force_gives_the_closed_form_steady_acceleration() {
        // |a| / |F| = ω² / √((k − m ω²)² + (c ω)²) for F = F0 sin ωt, after the transient
        // (e^{−ζ ω_n t} ≈ 1e-12 after 6 s at ζ = 0.05, ω_n = 2π 150).
        let m = mount();
        let dt = 1e-5;
        for f in [40.0, 150.0, 400.0] {
            let w = 2.0 * PI * f;
            let force: Vec<f64> = (0..600_000).map(|i| 10.0 * (w * i as f64 * dt).sin()).collect();
            let a = m.acceleration(&force, dt);
            let tail = &a[a.len() - 100_000..];
            let amplitude = tail.iter().fold(0.0f64, |x, y| x.max(y.abs()));
            let (k, c) = (m.stiffness(), m.damping());
            let expected = 10.0 * w * w / ((k - m.mass * w * w).powi(2) + (c * w).powi(2)).sqrt();
            // Sampled peaks of a sine at 1e-5 s fall short by at most 1 − cos(ω dt/2).
            assert!((amplitude / expected - 1.0).abs() < 3e-4, "{f} Hz: {amplitude} vs {expected}");
        }
    }

    #[test]
    fn a_force_step_rings_at_the_damped_natural_frequency() {
        // Static under F0 at t = 0, then F jumps (linearly over one step) to 0: x(t) = x0 e^{−ζωt}
        // (cos ω_d t + ζ/√(1−ζ²) sin ω_d t); a = −(c v + k x)/m, compared at every sample.
        let m = mount();
        let (dt, f0) = (1e-5, 100.0);
        let mut force = vec![f0];
        force.extend(std::iter::repeat_n(0.0, 5000));
        let a = m.acceleration(&force, dt);
        let (wn, z) = (2.0 * PI * m.natural_frequency, m.damping_ratio);
        let wd = wn * (1.0 - z * z).sqrt();
        let x0 = f0 / m.stiffness();
        // The ramp over the first step shifts the free response by dt/2 to first order; compare
        // from the second step on with a tolerance that covers that ramp.
        for (i, &ai) in a.iter().enumerate().skip(2) {
            let t = i as f64 * dt - 0.5 * dt;
            let e = (-z * wn * t).exp();
            let x = x0 * e * ((wd * t).cos() + z / (1.0 - z * z).sqrt() * (wd * t).sin());
            let v = -x0 * e * wn / (1.0 - z * z).sqrt() * (wd * t).sin();
            let expected = -(m.damping() * v + m.stiffness() * x) / m.mass;
            assert!((ai - expected).abs() < 2e-3 * f0 / m.mass, "t = {t}: {ai} vs {expected}");
        }
    }

    #[test]
    fn the_logger_keeps_a_tone_below_its_cutoff_and_rejects_one_above_nyquist() {
        let acquisition = Acquisition { sample_rate: 500.0, cutoff: 200.0, order: 4, settle: 0.5 };
        let dt = 1e-5;
        let tone =
            |f: f64| -> Vec<f64> { (0..300_000).map(|i| 3.0 + 2.0 * (2.0 * PI * f * i as f64 * dt).sin()).collect() };
        // 50 Hz: passed (|H| = 1/√(1 + (50/200)^8) ≈ 0.99998 for the analogue prototype).
        let kept = acquisition.acquire(&tone(50.0), dt, None).expect("fits");
        assert_eq!(kept.len(), ((3.0 - 0.5) * 500.0) as usize);
        let v = analyse(&kept, 500.0);
        assert!((v.peak_frequency - 50.0).abs() <= 500.0 / kept.len() as f64, "{v:?}");
        assert!((v.peak_amplitude / 2.0 - 1.0).abs() < 0.02, "{v:?}");
        assert!((v.rms / (2.0 / 2f64.sqrt()) - 1.0).abs() < 0.01, "mean removed: {v:?}");
        // 1200 Hz would alias to 200 Hz without the filter; fourth order at 6× the cut-off: 1/6⁴.
        let kept = acquisition.acquire(&tone(1200.0), dt, None).expect("fits");
        let v = analyse(&kept, 500.0);
        assert!(v.rms < 2.0 / 2f64.sqrt() * 1.0 / 6f64.powi(4) * 1.2, "{v:?}");
        // At the cut-off, −3 dB.
        let kept = acquisition.acquire(&tone(200.0), dt, None).expect("fits");
        let v = analyse(&kept, 500.0);
        assert!((v.rms / (2.0 / 2f64.sqrt()) - std::f64::consts::FRAC_1_SQRT_2).abs() < 0.02, "{v:?}");
    }

    #[test]
    fn settings_that_do_not_fit_are_named() {
        let bad = Acquisition { sample_rate: 500.0, cutoff: 300.0, order: 3, settle: -1.0 };
        let fields: Vec<String> = bad.validate().0.into_iter().map(|p| p.field).collect();
        assert_eq!(fields, ["cutoff", "order", "settle"]);
        let ok = Acquisition { sample_rate: 300.0, cutoff: 100.0, order: 4, settle: 0.0 };
        let e = ok.acquire(&[0.0; 100], 1e-5 * 1.5, None).unwrap_err();
        assert_eq!(e, AcquisitionError::Period { sample_rate: 300.0, dt: 1e-5 * 1.5 });
        assert!(e.to_string().contains("sample_rate"), "{e}");
        let m = Mount { mass: 0.0, natural_frequency: -1.0, damping_ratio: 0.05 }.validate();
        assert_eq!(m.0.len(), 2);
    }
}
