//! Order-tracked vibration features of a measured window.
//!
//! A clearance shows in a slider's acceleration twice: the journal's orbit inside its bearing
//! moves the low crank orders by about c/L₁ of the first, and its impacts put energy between and
//! above the order lines. The features are built so that what the user does not control drops
//! out: everything is relative to the channel's own first order (a sensor's gain cancels), phases
//! are taken relative to the first order's (the start in the cycle cancels), and bands are in
//! orders of the crank frequency (the speed scales out; its logarithm is one feature of its own).
//!
//! Per channel: the complex ratios of orders 2…[`ORDERS`] to the first (real and imaginary
//! parts), the energy on the order lines and between them in [`BAND_EDGES`] (log₁₀, relative to
//! the first order), and of what remains after the low orders are removed its kurtosis, crest
//! factor and level (log). Then ln f₀.

use rustfft::FftPlanner;
use rustfft::num_complex::Complex64;

/// Highest crank order whose ratio to the first is a feature (and that is removed before the
/// impulsiveness features).
pub const ORDERS: usize = 12;

/// Band edges in crank orders (the last band ends at the anti-alias cut-off).
pub const BAND_EDGES: [f64; 6] = [0.3, 4.5, 9.5, 19.5, 39.5, 79.5];

/// Bins on either side of an order line counted as the line (a Hann window's main lobe is ±2).
const LINE_BINS: f64 = 3.0;

/// Features per channel (the crank frequency's comes once, after them).
pub const PER_CHANNEL: usize = 2 * (ORDERS - 1) + 2 * BAND_EDGES.len() + 3;

/// Floor of the logarithms (an empty band).
const FLOOR: f64 = 1e-14;

fn hann(n: usize) -> Vec<f64> {
    let m = n.max(2) as f64 - 1.0;
    (0..n).map(|i| 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / m).cos()).collect()
}

/// The windowed samples' Fourier sum at frequency `f` \[Hz\] (samples at `fs`).
fn dft_at(windowed: &[f64], fs: f64, f: f64) -> Complex64 {
    let step = Complex64::from_polar(1.0, -std::f64::consts::TAU * f / fs);
    let mut phasor = Complex64::new(1.0, 0.0);
    let mut sum = Complex64::new(0.0, 0.0);
    for (i, &x) in windowed.iter().enumerate() {
        sum += phasor * x;
        phasor *= step;
        if i % 1024 == 1023 {
            // Keep the recurrence on the unit circle.
            phasor /= phasor.norm();
        }
    }
    sum
}

/// The signal minus its mean, Hann-windowed.
fn windowed(x: &[f64]) -> Vec<f64> {
    let mean = x.iter().sum::<f64>() / x.len().max(1) as f64;
    x.iter().zip(hann(x.len())).map(|(v, w)| (v - mean) * w).collect()
}

/// The crank frequency \[Hz\] of a channel whose strongest line in `band` \[Hz\] is the first
/// order (a slider's acceleration): the largest bin of the windowed spectrum in the band, refined
/// to a fraction of a bin by maximising the energy of the first two orders.
pub fn crank_frequency(x: &[f64], fs: f64, band: (f64, f64)) -> Option<f64> {
    let w = windowed(x);
    let n = w.len();
    let mut buffer: Vec<Complex64> = w.iter().map(|&v| Complex64::new(v, 0.0)).collect();
    FftPlanner::new().plan_fft_forward(n).process(&mut buffer);
    let df = fs / n as f64;
    let (lo, hi) = ((band.0 / df).floor().max(1.0) as usize, ((band.1 / df).ceil() as usize).min(n / 2));
    let peak = (lo..=hi).max_by(|&a, &b| buffer[a].norm_sqr().total_cmp(&buffer[b].norm_sqr()))?;
    let energy = |f: f64| -> f64 { (1..=2).map(|k| dft_at(&w, fs, k as f64 * f).norm_sqr()).sum() };
    // Golden-section search over ±1.5 bins.
    let (mut a, mut b) = ((peak as f64 - 1.5) * df, (peak as f64 + 1.5) * df);
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (energy(c), energy(d));
    for _ in 0..30 {
        if fc > fd {
            (b, d, fd) = (d, c, fc);
            c = b - g * (b - a);
            fc = energy(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + g * (b - a);
            fd = energy(d);
        }
    }
    let f = 0.5 * (a + b);
    (f.is_finite() && f > 0.0).then_some(f)
}

/// The features of one channel at crank frequency `f0` (samples at `fs`, content up to `cutoff`).
fn channel_features(x: &[f64], fs: f64, f0: f64, cutoff: f64, out: &mut Vec<f64>) {
    let w = windowed(x);
    let n = w.len();
    let window_sum: f64 = hann(n).iter().sum();
    let orders: Vec<Complex64> = (1..=ORDERS).map(|k| dft_at(&w, fs, k as f64 * f0)).collect();
    let first = orders[0];
    let (a1, phase1) = (first.norm().max(FLOOR), first.arg());
    for (k, z) in orders.iter().enumerate().skip(1) {
        let order = (k + 1) as f64;
        let ratio = if order * f0 < cutoff {
            z * Complex64::from_polar(1.0, -order * phase1) / a1
        } else {
            Complex64::new(0.0, 0.0)
        };
        out.extend([ratio.re, ratio.im]);
    }
    // Energy on and between the order lines per band.
    let mut buffer: Vec<Complex64> = w.iter().map(|&v| Complex64::new(v, 0.0)).collect();
    FftPlanner::new().plan_fft_forward(n).process(&mut buffer);
    let df = fs / n as f64;
    let top = cutoff.min(0.45 * fs);
    // A slow crank seen for a few revolutions (a handful of bins between its orders) keeps a
    // quarter order on either side of each line for what lies between them.
    let line_half_width = (LINE_BINS * df).min(0.25 * f0);
    let mut line = [0.0; BAND_EDGES.len()];
    let mut between = [0.0; BAND_EDGES.len()];
    for (b, value) in buffer.iter().enumerate().take(n / 2).skip(1) {
        let f = b as f64 * df;
        let order = f / f0;
        if f > top || order < BAND_EDGES[0] {
            continue;
        }
        let band = BAND_EDGES.iter().rposition(|&e| order >= e).unwrap_or(0);
        let on_line = order.round() >= 1.0 && (order - order.round()).abs() * f0 <= line_half_width;
        let sums = if on_line { &mut line } else { &mut between };
        sums[band] += value.norm_sqr();
    }
    let reference = a1 * a1;
    out.extend(line.iter().chain(&between).map(|e| (e / reference + FLOOR).log10()));
    // What remains after the mean and the low orders: how impulsive, how large.
    let mean = x.iter().sum::<f64>() / n.max(1) as f64;
    let amplitudes: Vec<Complex64> = orders.iter().map(|z| z * (2.0 / window_sum)).collect();
    let steps: Vec<Complex64> =
        (1..=ORDERS).map(|k| Complex64::from_polar(1.0, std::f64::consts::TAU * k as f64 * f0 / fs)).collect();
    let mut phasors = amplitudes;
    let (mut m2, mut m4, mut peak) = (0.0f64, 0.0f64, 0.0f64);
    for &v in x {
        let low: f64 = phasors.iter().map(|p| p.re).sum();
        phasors.iter_mut().zip(&steps).for_each(|(p, s)| *p *= s);
        let r = v - mean - low;
        m2 += r * r;
        m4 += r * r * r * r;
        peak = peak.max(r.abs());
    }
    let (m2, m4) = (m2 / n as f64, m4 / n as f64);
    let amplitude1 = (2.0 * a1 / window_sum).max(FLOOR);
    out.extend([
        (m4 / (m2 * m2).max(FLOOR) + FLOOR).ln(),
        (peak / m2.sqrt().max(FLOOR) + FLOOR).ln(),
        (m2.sqrt() / amplitude1 + FLOOR).ln(),
    ]);
}

/// The feature vector of a measured window: [`PER_CHANNEL`] per channel, then ln f₀.
pub fn features(channels: &[Vec<f64>], fs: f64, f0: f64, cutoff: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(PER_CHANNEL * channels.len() + 1);
    for x in channels {
        channel_features(x, fs, f0, cutoff, &mut out);
    }
    out.push(f0.ln());
    out
}

/// Bands of equal width from 0 to the logged band's top in which a housing channel's spectral
/// shape is read ([`housing_features`]).
pub const SHAPE_BANDS: usize = 16;

/// Features per channel of a housing setup ([`housing_features`]).
pub const PER_HOUSING_CHANNEL: usize = PER_CHANNEL + SHAPE_BANDS + 1;

/// The envelope of a channel: the magnitude of its analytic signal (mean removed; the Hilbert
/// transform by FFT). A housing on a soft mount rings at its resonance after each impact, and the
/// crank orders that its own lines no longer carry (the mount passes a few per mille of them)
/// are the rhythm of that ringing: the envelope's lines.
pub fn envelope(x: &[f64]) -> Vec<f64> {
    let n = x.len();
    let mean = x.iter().sum::<f64>() / n.max(1) as f64;
    let mut buffer: Vec<Complex64> = x.iter().map(|&v| Complex64::new(v - mean, 0.0)).collect();
    let mut planner = FftPlanner::new();
    planner.plan_fft_forward(n).process(&mut buffer);
    // Positive frequencies doubled, negative ones removed (0 and Nyquist kept once).
    for (k, z) in buffer.iter_mut().enumerate() {
        let positive = k > 0 && 2 * k < n;
        let kept = k == 0 || 2 * k == n;
        *z *= if positive {
            2.0
        } else if kept {
            1.0
        } else {
            0.0
        };
    }
    planner.plan_fft_inverse(n).process(&mut buffer);
    buffer.iter().map(|z| z.norm() / n as f64).collect()
}

/// The features of a housing accelerometer's channels (a setup with `envelope`): per channel the
/// order features of its envelope (those of [`features`], at crank frequency `f0`), the share of
/// its energy in each of [`SHAPE_BANDS`] equal bands up to the logged band's top (log₁₀: the
/// mount's resonance and what excites it, free of the gain) and the logarithm of its RMS (the
/// level, which carries the sensor's gain error within its prior); then ln f₀.
pub fn housing_features(channels: &[Vec<f64>], fs: f64, f0: f64, cutoff: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(PER_HOUSING_CHANNEL * channels.len() + 1);
    for x in channels {
        channel_features(&envelope(x), fs, f0, cutoff, &mut out);
        let w = windowed(x);
        let n = w.len();
        let mut buffer: Vec<Complex64> = w.iter().map(|&v| Complex64::new(v, 0.0)).collect();
        FftPlanner::new().plan_fft_forward(n).process(&mut buffer);
        let top = cutoff.min(0.45 * fs);
        let df = fs / n as f64;
        let mut bands = [0.0; SHAPE_BANDS];
        for (b, z) in buffer.iter().enumerate().take(n / 2).skip(1) {
            let band = (b as f64 * df / top * SHAPE_BANDS as f64) as usize;
            if let Some(e) = bands.get_mut(band) {
                *e += z.norm_sqr();
            }
        }
        let total: f64 = bands.iter().sum::<f64>().max(FLOOR);
        out.extend(bands.iter().map(|e| (e / total + FLOOR).log10()));
        let mean = x.iter().sum::<f64>() / n.max(1) as f64;
        let rms = (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n.max(1) as f64).sqrt();
        out.push((rms + FLOOR).ln());
    }
    out.push(f0.ln());
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sum of orders with known amplitudes and phases, sampled at 10 kHz for 1 s.
    fn orders_signal(f0: f64, gain: f64, shift: f64, amplitudes: &[(f64, f64)]) -> Vec<f64> {
        (0..10_000)
            .map(|i| {
                let t = i as f64 / 10_000.0 + shift;
                gain * amplitudes
                    .iter()
                    .enumerate()
                    .map(|(k, (a, p))| a * (std::f64::consts::TAU * (k + 1) as f64 * f0 * t + p).cos())
                    .sum::<f64>()
            })
            .collect()
    }

    #[test]
    fn the_envelope_of_a_modulated_carrier_is_its_modulation() {
        // A 150 Hz ring whose amplitude follows 1 + 0.5 cos(2π 4.2 t), sampled at 500 Hz for 2 s.
        let fs = 500.0;
        let x: Vec<f64> = (0..1000)
            .map(|i| {
                let t = i as f64 / fs;
                let tau = std::f64::consts::TAU;
                (1.0 + 0.5 * (tau * 4.2 * t).cos()) * (tau * 150.0 * t).sin()
            })
            .collect();
        let e = envelope(&x);
        // Away from the ends (the transform is circular), within 2 %.
        for (i, v) in e.iter().enumerate().skip(100).take(800) {
            let t = i as f64 / fs;
            let exact = 1.0 + 0.5 * (std::f64::consts::TAU * 4.2 * t).cos();
            assert!((v - exact).abs() < 0.02, "sample {i}: {v} against {exact}");
        }
        // Its first line is the modulation's frequency.
        let f = crank_frequency(&e, fs, (3.7, 4.7)).unwrap();
        assert!((f - 4.2).abs() < 0.02, "{f}");
        assert_eq!(housing_features(&[x], fs, f, 200.0).len(), PER_HOUSING_CHANNEL + 1);
    }

    #[test]
    fn the_crank_frequency_is_found_to_a_fraction_of_a_bin() {
        let x = orders_signal(83.37, 1.0, 0.0, &[(1.0, 0.3), (0.4, 1.0), (0.05, 0.0)]);
        let f = crank_frequency(&x, 10_000.0, (70.0, 95.0)).unwrap();
        assert!((f - 83.37).abs() < 0.01, "{f}");
    }

    #[test]
    fn gain_and_start_in_the_cycle_drop_out_and_order_ratios_are_exact() {
        let orders = [(1.0, 0.3), (0.4, 1.0), (0.05, -0.5), (0.01, 2.0)];
        let a = features(&[orders_signal(83.0, 1.0, 0.0, &orders)], 10_000.0, 83.0, 4000.0);
        let b = features(&[orders_signal(83.0, 1.07, 0.0037, &orders)], 10_000.0, 83.0, 4000.0);
        assert_eq!(a.len(), PER_CHANNEL + 1);
        // The order ratios and line energies: the same for any gain and start.
        for k in 0..2 * (ORDERS - 1) + BAND_EDGES.len() {
            assert!((a[k] - b[k]).abs() < 2e-3 * (1.0 + a[k].abs()), "feature {k}: {} vs {}", a[k], b[k]);
        }
        // Order 2 relative to 1: amplitude 0.4, phase 1.0 − 2 × 0.3.
        let (re, im) = (a[0], a[1]);
        assert!(((re * re + im * im).sqrt() - 0.4).abs() < 2e-3, "{re} {im}");
        assert!((im.atan2(re) - 0.4).abs() < 1e-2, "{re} {im}");
    }
}
