//! SVG figures of `lash compare` (the seeds' figures 2–3): a channel of both models over time,
//! overlaid, and its one-sided amplitude spectrum (Hann window; the samples are uniform in time by
//! construction, both models being observed at exact multiples of the output interval).

use crate::CliError;
use lash_scenario::compare::amplitude_spectrum;
use plotters::prelude::*;
use std::path::Path;

const FULL: RGBColor = RGBColor(31, 119, 180);
const REDUCED: RGBColor = RGBColor(214, 39, 40);

fn fail(path: &Path, e: impl std::fmt::Display) -> CliError {
    CliError::Failure(format!("{}: {e}", path.display()))
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

/// Draws two series (full and reduced) into `path`.
fn overlay(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    full: &[(f64, f64)],
    reduced: &[(f64, f64)],
) -> Result<(), CliError> {
    let (x0, x1, y0, y1) = range(&[full, reduced]);
    let root = SVGBackend::new(path, (1000, 420)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| fail(path, e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| fail(path, e))?;
    chart.configure_mesh().x_desc(x_label).y_desc(y_label).draw().map_err(|e| fail(path, e))?;
    chart
        .draw_series(LineSeries::new(full.iter().copied(), FULL.stroke_width(2)))
        .map_err(|e| fail(path, e))?
        .label("full model (converged)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], FULL.stroke_width(2)));
    chart
        .draw_series(LineSeries::new(reduced.iter().copied(), REDUCED.stroke_width(1)))
        .map_err(|e| fail(path, e))?
        .label("reduced interface model")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], REDUCED.stroke_width(1)));
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|e| fail(path, e))?;
    root.present().map_err(|e| fail(path, e))
}

/// Writes `<channel>.svg` (time series) and `<channel>_spectrum.svg` (amplitude up to
/// `max_frequency`) into `dir`. Returns the files written.
pub fn comparison_figures(
    dir: &Path,
    channel: &str,
    unit: &str,
    time: &[f64],
    full: &[f64],
    reduced: &[f64],
    max_frequency: f64,
) -> Result<Vec<std::path::PathBuf>, CliError> {
    let series = |v: &[f64]| time.iter().zip(v).map(|(&t, &y)| (t * 1e3, y)).collect::<Vec<_>>();
    let timeseries = dir.join(format!("{channel}.svg"));
    overlay(
        &timeseries,
        &format!("{channel}: full vs reduced model"),
        "time [ms]",
        &format!("{channel} [{unit}]"),
        &series(full),
        &series(reduced),
    )?;
    let dt = if time.len() > 1 { time[1] - time[0] } else { 1.0 };
    let spectrum = |v: &[f64]| {
        let (f, a) = amplitude_spectrum(v, dt);
        f.into_iter().zip(a).filter(|(f, _)| *f <= max_frequency).collect::<Vec<_>>()
    };
    let spectrum_path = dir.join(format!("{channel}_spectrum.svg"));
    overlay(
        &spectrum_path,
        &format!("{channel}: one-sided amplitude spectrum (Hann window)"),
        "frequency [Hz]",
        &format!("amplitude [{unit}]"),
        &spectrum(full),
        &spectrum(reduced),
    )?;
    Ok(vec![timeseries, spectrum_path])
}
