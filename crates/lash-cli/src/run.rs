//! `lash run`: streams the CSV, then writes the summary; nothing is left looking complete on
//! failure (the CSV stays as `timeseries.csv.partial`, no summary.json). The wall time of the run
//! is split, on one clock, into simulation and output (formatting and writing the CSV rows).

use crate::CliError;
use crate::output::SeriesOutput;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use lash_run::Runner;
use std::path::Path;
use std::time::{Duration, Instant};

/// A bar of the simulated fraction of a run that shows itself only once the run has taken a
/// second (a short run draws nothing), and never when `quiet`.
pub(crate) struct DelayedBar {
    bar: ProgressBar,
    started: Instant,
    shown: bool,
    quiet: bool,
    /// Per mille: the clock is read only when the bar would move.
    position: u64,
}

impl DelayedBar {
    /// A hidden bar labelled `what` ("simulated", …).
    pub(crate) fn new(what: &str, quiet: bool) -> Self {
        let bar = ProgressBar::with_draw_target(Some(1000), ProgressDrawTarget::hidden());
        let template = format!("{{spinner}} [{{elapsed_precise}}] {{wide_bar}} {{percent:>3}}% {what}, ETA {{eta}}");
        bar.set_style(ProgressStyle::with_template(&template).unwrap_or_else(|_| ProgressStyle::default_bar()));
        Self { bar, started: Instant::now(), shown: false, quiet, position: 0 }
    }

    /// The run is at fraction `f` of its time span.
    pub(crate) fn update(&mut self, f: f64) {
        let now = (f * 1000.0) as u64;
        if now == self.position {
            return;
        }
        self.position = now;
        if !self.quiet && !self.shown && self.started.elapsed() > Duration::from_secs(1) {
            self.bar.set_draw_target(ProgressDrawTarget::stderr());
            self.shown = true;
        }
        self.bar.set_position(now);
    }

    /// Clears the bar.
    pub(crate) fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

/// Wall times of one run on one monotonic clock [s]: the simulation (everything but the output),
/// the output (formatting and writing the rows, and the final flush), and the whole run.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Timing {
    /// Simulation alone \[s\].
    pub simulation_s: f64,
    /// Formatting and writing the CSV \[s\].
    pub output_s: f64,
    /// Both \[s\].
    pub total_s: f64,
}

/// Runs `runner` (built from scenario `s`, whose simulation and output settings are given) into
/// `out`, after checking that its output fits (limits.rs); its timing and summary.
pub fn run<S: serde::Serialize>(
    s: &S,
    (simulation, output): (&lash_scenario::schema::SimulationSpec, &lash_scenario::schema::OutputSpec),
    runner: &mut dyn Runner,
    out: &Path,
    format: crate::output::Format,
    quiet: bool,
) -> Result<(Timing, lash_run::Summary), CliError> {
    check_size((simulation, output), runner.header().len(), out, format, quiet)?;
    let fail = |what: &str, e: std::io::Error| CliError::Failure(format!("{what}: {e}"));
    let summary_path = out.join("summary.json");
    let mut csv = SeriesOutput::create_as(out, &runner.header(), &["summary.json"], format)?;
    remove_old_measurements(out)?;

    let mut bar = DelayedBar::new("simulated", quiet);
    let mut progress = |f: f64| bar.update(f);
    let mut sink = |row: &[f64]| csv.row(row).map_err(lash_core::BoxError::from);
    let run_started = Instant::now();
    let result = runner.execute(&mut sink, &mut progress);
    let mut total = run_started.elapsed();
    bar.finish();
    let summary = match result {
        Ok(s) => s,
        Err(e) => {
            let kept = SeriesOutput::kept(csv.abandon().as_deref());
            if crate::output::interrupted() {
                return Err(CliError::Interrupted(format!("{}: {kept}", crate::output::INTERRUPTED_MESSAGE)));
            }
            return Err(CliError::Failure(format!("{e}\n({kept})")));
        }
    };
    let flush = Instant::now();
    let mut output = csv.busy();
    csv.finish()?;
    for table in &summary.measured {
        let mut logged =
            SeriesOutput::create_named(out, &format!("measurement_{}.csv", table.name), &table.header, &[])?;
        for row in &table.rows {
            logged.row(row).map_err(|e| CliError::Failure(e.to_string()))?;
        }
        logged.finish()?; // inside the flush time below, which counts as output
    }
    let flushed = flush.elapsed();
    (output, total) = (output + flushed, total + flushed);
    let timing = Timing {
        simulation_s: (total - output).as_secs_f64(),
        output_s: output.as_secs_f64(),
        total_s: total.as_secs_f64(),
    };
    std::fs::write(out.join("scenario.toml"), toml::to_string(s).map_err(|e| CliError::Failure(e.to_string()))?)
        .map_err(|e| fail("writing scenario.toml", e))?;
    let mut json = serde_json::to_value(&summary).map_err(|e| CliError::Failure(e.to_string()))?;
    if let Some(map) = json.as_object_mut() {
        map.insert("timing".into(), serde_json::to_value(timing).map_err(|e| CliError::Failure(e.to_string()))?);
    }
    let json = serde_json::to_string_pretty(&json).map_err(|e| CliError::Failure(e.to_string()))?;
    std::fs::write(&summary_path, json + "\n").map_err(|e| fail("writing summary.json", e))?;
    print_run(&summary, &timing, out);
    Ok((timing, summary))
}

/// The run's output checked against the limits before it starts (limits.rs), with a note when
/// it writes more than 2 GB.
fn check_size(
    (simulation, output): (&lash_scenario::schema::SimulationSpec, &lash_scenario::schema::OutputSpec),
    columns: usize,
    out: &Path,
    format: crate::output::Format,
    quiet: bool,
) -> Result<(), CliError> {
    let measured: usize = output.measurements.iter().map(|m| m.forces.len()).sum();
    let estimate = crate::limits::run_estimate(
        simulation.horizon,
        simulation.output_interval,
        columns,
        measured,
        crate::limits::bytes_per_value(format),
    );
    crate::limits::check(
        "the run",
        &estimate,
        out,
        "shorten simulation.horizon (or --horizon), raise simulation.output_interval or list fewer output.channels",
    )?;
    if !quiet && estimate.disk_bytes > 2_000_000_000 {
        eprintln!(
            "note: this run writes up to {} ({} rows × {} values)",
            crate::limits::bytes(estimate.disk_bytes),
            estimate.rows,
            estimate.columns
        );
    }
    Ok(())
}

/// Removes an earlier run's measurement tables from `out`: they must not pass for this run's.
fn remove_old_measurements(out: &Path) -> Result<(), CliError> {
    let fail = |what: &str, e: std::io::Error| CliError::Failure(format!("{what}: {e}"));
    for entry in std::fs::read_dir(out).map_err(|e| fail("reading the output folder", e))?.flatten() {
        let name = entry.file_name().to_string_lossy().to_string();
        if name.starts_with("measurement_") && (name.ends_with(".csv") || name.ends_with(".csv.partial")) {
            std::fs::remove_file(entry.path()).map_err(|e| fail(&format!("removing the old {name}"), e))?;
        }
    }
    Ok(())
}

/// The run's line on the terminal (samples, steps, the time split, each joint's impacts, the
/// folder), then its warnings.
fn print_run(summary: &lash_run::Summary, timing: &Timing, out: &Path) {
    let impacts: Vec<String> =
        summary.clearances.iter().map(|c| format!("{}: {} impacts", c.name, c.impacts)).collect();
    eprintln!(
        "{} ({}): {} samples, {} steps ({} rejected), wall {:.3} s = simulation {:.3} s + output {:.3} s{}{} → {}",
        summary.scenario,
        summary.model,
        summary.samples,
        summary.steps,
        summary.rejected_steps,
        timing.total_s,
        timing.simulation_s,
        timing.output_s,
        if impacts.is_empty() { "" } else { ", " },
        impacts.join(", "),
        out.display()
    );
    for w in &summary.warnings {
        eprintln!("warning: {w}");
    }
}
