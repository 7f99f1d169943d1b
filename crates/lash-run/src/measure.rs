//! Emulated vibration measurements of a run (`[[output.measurements]]`): the force channels are
//! kept at every sample, and after the run each drives its housing axis ([`lash_measure::Mount`])
//! whose acceleration the logger ([`lash_measure::Acquisition`]) samples. Shared by the full-model
//! runners (planar and spatial).

use lash_measure::{Vibration, analyse};
use lash_scenario::schema::MeasurementSpec;
use serde::Serialize;

/// One axis of a measurement.
#[derive(Debug, Clone, Serialize)]
pub struct AxisSummary {
    /// Logged channel (`housing.ax`).
    pub channel: String,
    /// The force channel driving it.
    pub force: String,
    /// What the logger's samples show (spectrum peak, amplitude, RMS).
    pub logged: Vibration,
    /// The housing's acceleration at every output sample over the same window, mean removed:
    /// its RMS [m/s²].
    pub clean_rms: f64,
    /// … and its largest absolute value [m/s²].
    pub clean_peak: f64,
}

/// Results of one measurement.
#[derive(Debug, Clone, Serialize)]
pub struct MeasurementSummary {
    /// Measurement name.
    pub name: String,
    /// Logger rate \[Hz\].
    pub sample_rate: f64,
    /// Start of the window of steady running \[s\].
    pub window_start: f64,
    /// Per axis.
    pub axes: Vec<AxisSummary>,
}

/// The logger's samples of one measurement (written as `measurement_<name>.csv`).
#[derive(Debug, Clone)]
pub struct MeasuredTable {
    /// Measurement name.
    pub name: String,
    /// Column names with units, time first.
    pub header: Vec<String>,
    /// Rows: time, then one value per axis.
    pub rows: Vec<Vec<f64>>,
}

/// Adds to `recorded` (indices into `names`) the force channels of `specs` not there yet: a
/// reduced run records them so that its measurements can be computed.
pub(crate) fn record_forces(recorded: &mut Vec<usize>, names: &[&str], specs: &[MeasurementSpec]) {
    for f in specs.iter().flat_map(|m| &m.forces) {
        let i = names.iter().position(|n| n == f).expect("validated measurement channel");
        if !recorded.contains(&i) {
            recorded.push(i);
        }
    }
}

/// Keeps the force channels of every measurement while a run samples.
pub(crate) struct MeasurementRecorder {
    specs: Vec<MeasurementSpec>,
    /// Per measurement, per axis: the index of the force channel among all channels.
    indices: Vec<Vec<usize>>,
    series: Vec<Vec<Vec<f64>>>,
}

/// A measurement whose logger cannot take the run's samples.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("output.measurements {name:?}: {problem}")]
pub struct MeasurementError {
    /// The measurement's name.
    pub name: String,
    /// What does not fit.
    pub problem: lash_measure::AcquisitionError,
}

impl MeasurementRecorder {
    /// For `specs` (validated) over the channels called `names`.
    pub fn new(specs: &[MeasurementSpec], names: &[&str]) -> Self {
        let indices: Vec<Vec<usize>> = specs
            .iter()
            .map(|m| m.forces.iter().map(|f| names.iter().position(|n| n == f).expect("validated channel")).collect())
            .collect();
        let series = indices.iter().map(|axes| vec![Vec::new(); axes.len()]).collect();
        Self { specs: specs.to_vec(), indices, series }
    }

    /// Adds one sample (all channel values).
    #[inline]
    pub fn record(&mut self, values: &[f64]) {
        for (axes, series) in self.indices.iter().zip(self.series.iter_mut()) {
            for (&i, s) in axes.iter().zip(series.iter_mut()) {
                s.push(values[i]);
            }
        }
    }

    /// Housing responses, logger samples and their analysis; `dt` the output interval, `t0` the
    /// first sample's time.
    pub fn finish(self, t0: f64, dt: f64) -> Result<(Vec<MeasurementSummary>, Vec<MeasuredTable>), MeasurementError> {
        let (mut summaries, mut tables) = (Vec::new(), Vec::new());
        for (spec, series) in self.specs.iter().zip(self.series) {
            let a = &spec.acquisition;
            let every = (1.0 / (a.sample_rate * dt)).round() as usize;
            let first = (a.settle / dt).ceil() as usize;
            let first_kept = first.div_ceil(every) * every;
            let channels = spec.channel_names();
            let mut axes = Vec::new();
            let mut columns = Vec::new();
            for ((force, samples), channel) in spec.forces.iter().zip(&series).zip(&channels) {
                let clean = spec.mount.acceleration(samples, dt);
                let logged = a
                    .acquire(&clean, dt, None)
                    .map_err(|problem| MeasurementError { name: spec.name.clone(), problem })?;
                let window = clean.get(first..).unwrap_or(&[]);
                let mean = window.iter().sum::<f64>() / window.len().max(1) as f64;
                let clean_rms =
                    (window.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / window.len().max(1) as f64).sqrt();
                let clean_peak = window.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                axes.push(AxisSummary {
                    channel: channel.clone(),
                    force: force.clone(),
                    logged: analyse(&logged, a.sample_rate),
                    clean_rms,
                    clean_peak,
                });
                columns.push(logged);
            }
            let rows = (0..columns.first().map_or(0, Vec::len))
                .map(|r| {
                    std::iter::once(t0 + (first_kept + r * every) as f64 * dt)
                        .chain(columns.iter().map(|c| c[r]))
                        .collect()
                })
                .collect();
            tables.push(MeasuredTable {
                name: spec.name.clone(),
                header: std::iter::once("time [s]".to_string())
                    .chain(channels.iter().map(|c| format!("{c} [m/s^2]")))
                    .collect(),
                rows,
            });
            summaries.push(MeasurementSummary {
                name: spec.name.clone(),
                sample_rate: a.sample_rate,
                window_start: t0 + first_kept as f64 * dt,
                axes,
            });
        }
        Ok((summaries, tables))
    }
}
