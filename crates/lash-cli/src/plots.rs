//! SVG figures of `lash compare` (the reduced-interface-model papers' figures 2–3): a channel of the full and the reduced
//! model over time, overlaid on the ideal mechanism's (the clearance joint closed), with the crank
//! angle as a second axis when the crank turns at constant speed; and its one-sided amplitude
//! spectrum (Hann window) on a logarithmic amplitude axis, where the kilohertz impact content that
//! separates the models is visible. Tick labels are in engineering notation (`-100k`, `2.5m`).

use crate::CliError;
use lash_metrics::amplitude_spectrum;
use plotters::prelude::*;
use std::path::Path;

const FULL: RGBColor = RGBColor(31, 119, 180);
const REDUCED: RGBColor = RGBColor(214, 39, 40);
const IDEAL: RGBColor = RGBColor(40, 40, 40);

fn fail(path: &Path, e: impl std::fmt::Display) -> CliError {
    CliError::Failure(format!("{}: {e}", path.display()))
}

/// A number in engineering notation: at most four significant digits and an SI prefix
/// (`-1.073e5` → `-107.3k`, `0.0025` → `2.5m`, `0` → `0`).
pub fn engineering(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return if v == 0.0 { "0".into() } else { format!("{v}") };
    }
    const PREFIXES: [(i32, &str); 11] = [
        (-15, "f"),
        (-12, "p"),
        (-9, "n"),
        (-6, "µ"),
        (-3, "m"),
        (0, ""),
        (3, "k"),
        (6, "M"),
        (9, "G"),
        (12, "T"),
        (15, "P"),
    ];
    let exponent = (v.abs().log10().floor() as i32).div_euclid(3) * 3;
    let (e, prefix) = PREFIXES.iter().copied().find(|(e, _)| *e == exponent.clamp(-15, 15)).unwrap_or((0, ""));
    let scaled = v / 10f64.powi(e);
    let text = format!("{scaled:.3}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    format!("{text}{prefix}")
}

fn range(series: &[&[(f64, f64)]]) -> (f64, f64, f64, f64) {
    let pts = series.iter().flat_map(|s| s.iter());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for &(x, y) in pts {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    let pad = 0.05 * (y1 - y0).max(f64::MIN_POSITIVE);
    (x0, x1, y0 - pad, y1 + pad)
}

/// The curves of one figure.
struct Curves<'a> {
    full: &'a [(f64, f64)],
    reduced: &'a [(f64, f64)],
    ideal: Option<&'a [(f64, f64)]>,
}

/// Draws the curves into `path`; `log_y` puts the y axis on a logarithmic scale (values floored at
/// 1e-6 of the largest), `angle` adds a top axis of crank angle [°] = angle(x).
fn overlay(
    path: &Path,
    title: &str,
    (x_label, y_label): (&str, &str),
    curves: &Curves<'_>,
    log_y: bool,
    angle: Option<&dyn Fn(f64) -> f64>,
) -> Result<(), CliError> {
    let all: Vec<&[(f64, f64)]> =
        [Some(curves.full), Some(curves.reduced), curves.ideal].into_iter().flatten().collect();
    let (x0, x1, y0, y1) = range(&all);
    let root = SVGBackend::new(path, (1000, 440)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| fail(path, e))?;
    let mut builder = ChartBuilder::on(&root);
    builder.caption(title, ("sans-serif", 18)).margin(12).x_label_area_size(40).y_label_area_size(70);
    if angle.is_some() {
        builder.top_x_label_area_size(36);
    }
    let floor = y1.abs().max(y0.abs()) * 1e-6;
    let clamp = |v: &[(f64, f64)]| -> Vec<(f64, f64)> {
        v.iter().map(|&(x, y)| (x, if log_y { y.max(floor) } else { y })).collect()
    };
    macro_rules! draw {
        ($chart:expr) => {{
            let chart = &mut $chart;
            chart
                .draw_series(LineSeries::new(clamp(curves.full), FULL.stroke_width(2)))
                .map_err(|e| fail(path, e))?
                .label("full model (converged)")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], FULL.stroke_width(2)));
            chart
                .draw_series(LineSeries::new(clamp(curves.reduced), REDUCED.stroke_width(1)))
                .map_err(|e| fail(path, e))?
                .label("reduced interface model")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], REDUCED.stroke_width(1)));
            // The reference on top, dashed, so that it shows where the models deviate from it.
            if let Some(ideal) = curves.ideal {
                chart
                    .draw_series(DashedLineSeries::new(clamp(ideal), 6, 4, IDEAL.stroke_width(2)))
                    .map_err(|e| fail(path, e))?
                    .label("ideal mechanism (clearance joint closed)")
                    .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], IDEAL.stroke_width(2)));
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(|e| fail(path, e))?;
        }};
    }
    let x_fmt = |v: &f64| engineering(*v);
    let y_fmt = |v: &f64| engineering(*v);
    // Axis descriptions and engineering tick labels, the same on every kind of chart.
    macro_rules! mesh {
        ($chart:expr) => {
            $chart
                .configure_mesh()
                .x_desc(x_label)
                .y_desc(y_label)
                .x_label_formatter(&x_fmt)
                .y_label_formatter(&y_fmt)
                .draw()
                .map_err(|e| fail(path, e))?
        };
    }
    if log_y {
        let mut chart = builder
            .build_cartesian_2d(x0..x1, (floor.max(y0.max(f64::MIN_POSITIVE))..y1.max(floor * 10.0)).log_scale())
            .map_err(|e| fail(path, e))?;
        mesh!(chart);
        draw!(chart);
    } else if let Some(angle) = angle {
        let mut chart = builder
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| fail(path, e))?
            .set_secondary_coord(angle(x0)..angle(x1), y0..y1);
        mesh!(chart);
        chart
            .configure_secondary_axes()
            .x_desc("crank angle [°]")
            .x_label_formatter(&|v: &f64| format!("{v:.0}"))
            .draw()
            .map_err(|e| fail(path, e))?;
        draw!(chart);
    } else {
        let mut chart = builder.build_cartesian_2d(x0..x1, y0..y1).map_err(|e| fail(path, e))?;
        mesh!(chart);
        draw!(chart);
    }
    root.present().map_err(|e| fail(path, e))
}

/// One channel of the compared runs, sampled at `time` \[s\].
pub struct Channel<'a> {
    /// Channel name.
    pub name: &'a str,
    /// Its unit.
    pub unit: &'a str,
    /// Sample times \[s\].
    pub time: &'a [f64],
    /// The full model's samples.
    pub full: &'a [f64],
    /// The reduced model's samples.
    pub reduced: &'a [f64],
    /// The ideal mechanism's samples at the same times, when it has the channel.
    pub ideal: Option<&'a [f64]>,
}

/// Writes `<channel>.svg` (time series, crank angle on top when `crank_angle_deg` gives it from
/// the time \[s\]) and `<channel>_spectrum.svg` (amplitude up to `max_frequency`, logarithmic) into
/// `dir`. Returns the files written.
pub fn comparison_figures(
    dir: &Path,
    c: &Channel<'_>,
    crank_angle_deg: Option<&dyn Fn(f64) -> f64>,
    max_frequency: f64,
) -> Result<Vec<std::path::PathBuf>, CliError> {
    let series = |v: &[f64]| c.time.iter().zip(v).map(|(&t, &y)| (t * 1e3, y)).collect::<Vec<_>>();
    let (full, reduced, ideal) = (series(c.full), series(c.reduced), c.ideal.map(series));
    let timeseries = dir.join(format!("{}.svg", c.name));
    let angle_of_ms = crank_angle_deg.map(|f| move |ms: f64| f(ms * 1e-3));
    overlay(
        &timeseries,
        &if c.ideal.is_some() {
            format!("{}: full model, reduced model and ideal mechanism", c.name)
        } else {
            format!("{}: full and reduced model", c.name)
        },
        ("time [ms]", &format!("{} [{}]", c.name, c.unit)),
        &Curves { full: &full, reduced: &reduced, ideal: ideal.as_deref() },
        false,
        angle_of_ms.as_ref().map(|f| f as &dyn Fn(f64) -> f64),
    )?;
    let dt = if c.time.len() > 1 { c.time[1] - c.time[0] } else { 1.0 };
    let spectrum = |v: &[f64]| {
        let (f, a) = amplitude_spectrum(v, dt);
        f.into_iter().zip(a).filter(|(f, _)| *f > 0.0 && *f <= max_frequency).collect::<Vec<_>>()
    };
    let (sf, sr, si) = (spectrum(c.full), spectrum(c.reduced), c.ideal.map(spectrum));
    let spectrum_path = dir.join(format!("{}_spectrum.svg", c.name));
    overlay(
        &spectrum_path,
        &format!("{}: one-sided amplitude spectrum (Hann window), logarithmic", c.name),
        ("frequency [Hz]", &format!("amplitude [{}]", c.unit)),
        &Curves { full: &sf, reduced: &sr, ideal: si.as_deref() },
        true,
        None,
    )?;
    Ok(vec![timeseries, spectrum_path])
}

/// The posterior of each clearance joint as a histogram of its calibrated draws (µm), with the
/// median and the calibrated 90 % interval marked, one panel per joint.
pub fn posterior_figure(
    path: &Path,
    estimator: &lash_estimate::Estimator,
    e: &lash_estimate::Estimate,
) -> Result<(), CliError> {
    let joints = estimator.joints.len();
    let root = SVGBackend::new(path, (900, 320 * joints as u32)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| fail(path, e))?;
    for (j, area) in root.split_evenly((joints, 1)).iter().enumerate() {
        let u = &e.unknowns[j];
        let (lo, hi) = (u.prior[0] * 1e6, u.prior[1] * 1e6);
        let bins = 40usize;
        let width = (hi - lo) / bins as f64;
        let mut counts = vec![0u32; bins];
        for d in &e.clearance_draws[j] {
            let k = (((d * 1e6 - lo) / width).floor().max(0.0) as usize).min(bins - 1);
            counts[k] += 1;
        }
        let top = f64::from(counts.iter().copied().max().unwrap_or(1).max(1)) * 1.15;
        let worn =
            e.worn.get(j).map(|(_, p)| format!(", worn with probability {:.0} %", 100.0 * p)).unwrap_or_default();
        let mut chart = ChartBuilder::on(area)
            .caption(
                format!(
                    "{}: {:.1} µm (90 % interval {:.1}–{:.1} µm{worn})",
                    u.name,
                    u.median * 1e6,
                    u.low * 1e6,
                    u.high * 1e6
                ),
                ("sans-serif", 18),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(lo..hi, 0.0..top)
            .map_err(|e| fail(path, e))?;
        chart
            .configure_mesh()
            .x_desc("radial clearance [µm] (the prior's range)")
            .y_desc("posterior draws")
            .draw()
            .map_err(|e| fail(path, e))?;
        chart
            .draw_series(counts.iter().enumerate().map(|(k, &c)| {
                let x0 = lo + k as f64 * width;
                Rectangle::new([(x0, 0.0), (x0 + width, f64::from(c))], FULL.mix(0.6).filled())
            }))
            .map_err(|e| fail(path, e))?;
        chart
            .draw_series(DashedLineSeries::new(
                vec![(u.low * 1e6, 0.0), (u.low * 1e6, top)],
                6,
                4,
                IDEAL.stroke_width(1),
            ))
            .map_err(|e| fail(path, e))?;
        chart
            .draw_series(DashedLineSeries::new(
                vec![(u.high * 1e6, 0.0), (u.high * 1e6, top)],
                6,
                4,
                IDEAL.stroke_width(1),
            ))
            .map_err(|e| fail(path, e))?;
        chart
            .draw_series(LineSeries::new(vec![(u.median * 1e6, 0.0), (u.median * 1e6, top)], REDUCED.stroke_width(2)))
            .map_err(|e| fail(path, e))?;
    }
    root.present().map_err(|e| fail(path, e))
}

/// The hidden signals of an estimate over the first three crank revolutions of the window: per
/// signal (each joint's contact force, then its eccentricity) the draws' median and 5–95 % band,
/// impact onsets marked on the force.
pub fn hidden_figure(path: &Path, hidden: &lash_estimate::Hidden, crank_frequency: f64) -> Result<(), CliError> {
    let n = hidden.signals.first().map_or(0, |b| b.median.len());
    let shown = ((3.0 / crank_frequency * hidden.sample_rate).ceil() as usize).clamp(2, n.max(2)).min(n);
    let root = SVGBackend::new(path, (900, 260 * hidden.signals.len() as u32)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| fail(path, e))?;
    let ms = |i: usize| 1e3 * i as f64 / hidden.sample_rate;
    for (k, (band, area)) in hidden.signals.iter().zip(root.split_evenly((hidden.signals.len(), 1))).enumerate() {
        let (scale, unit) = if band.unit == "m" { (1e6, "µm") } else { (1.0, band.unit.as_str()) };
        let top = band.high[..shown].iter().fold(0.0f64, |a, &v| a.max(v * scale)) * 1.1 + 1e-12;
        let mut chart = ChartBuilder::on(&area)
            .caption(
                format!("{} (median of {} posterior draws, 5–95 % band)", band.name, hidden.draws),
                ("sans-serif", 16),
            )
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(64)
            .build_cartesian_2d(0.0..ms(shown), 0.0..top)
            .map_err(|e| fail(path, e))?;
        chart
            .configure_mesh()
            .x_desc("time from the window's start [ms]")
            .y_desc(format!("[{unit}]"))
            .draw()
            .map_err(|e| fail(path, e))?;
        let upper = (0..shown).map(|i| (ms(i), band.high[i] * scale));
        let lower = (0..shown).rev().map(|i| (ms(i), band.low[i] * scale));
        chart
            .draw_series(std::iter::once(Polygon::new(
                upper.chain(lower).collect::<Vec<_>>(),
                REDUCED.mix(0.2).filled(),
            )))
            .map_err(|e| fail(path, e))?;
        chart
            .draw_series(LineSeries::new((0..shown).map(|i| (ms(i), band.median[i] * scale)), REDUCED.stroke_width(1)))
            .map_err(|e| fail(path, e))?;
        if k % 2 == 0 {
            let onsets = hidden.onsets[k / 2].iter().filter(|&&i| i < shown);
            chart
                .draw_series(onsets.map(|&i| Circle::new((ms(i), 0.0), 4, FULL.filled())))
                .map_err(|e| fail(path, e))?;
        }
    }
    root.present().map_err(|e| fail(path, e))
}

#[cfg(test)]
mod tests {
    use super::engineering;

    #[test]
    fn tick_labels_are_in_engineering_notation() {
        for (v, text) in [
            (-100000.0, "-100k"),
            (107300.0, "107.3k"),
            (0.0025, "2.5m"),
            (0.0, "0"),
            (1.0, "1"),
            (-3.5e-7, "-350n"),
            (12.5, "12.5"),
            (2.0e6, "2M"),
        ] {
            assert_eq!(engineering(v), text, "{v}");
        }
    }
}
