//! `lash run`: streams the CSV, then writes the summary; nothing is left looking complete on
//! failure (the CSV stays as `timeseries.csv.partial`, no summary.json).

use crate::CliError;
use crate::output::CsvOutput;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use lash_scenario::{Runner, Scenario};
use std::path::Path;
use std::time::{Duration, Instant};

pub fn run(s: &Scenario, runner: &mut dyn Runner, out: &Path, quiet: bool) -> Result<(), CliError> {
    let fail = |what: &str, e: std::io::Error| CliError::Failure(format!("{what}: {e}"));
    let summary_path = out.join("summary.json");
    let mut csv = CsvOutput::create(out, &runner.header(), &["summary.json"])?;

    let bar = ProgressBar::with_draw_target(Some(1000), ProgressDrawTarget::hidden());
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_bar} {percent:>3}% simulated, ETA {eta}")
            .expect("static template"),
    );
    let started = Instant::now();
    let mut shown = false;
    let mut progress = |f: f64| {
        if !quiet && !shown && started.elapsed() > Duration::from_secs(1) {
            bar.set_draw_target(ProgressDrawTarget::stderr());
            shown = true;
        }
        bar.set_position((f * 1000.0) as u64);
    };
    let mut sink = |row: &[f64]| csv.row(row);
    let result = runner.execute(&mut sink, &mut progress);
    bar.finish_and_clear();
    let summary = match result {
        Ok(s) => s,
        Err(e) => {
            let kept = CsvOutput::kept(csv.abandon().as_deref());
            if crate::output::interrupted() {
                return Err(CliError::Interrupted(format!("{}: {kept}", crate::output::INTERRUPTED_MESSAGE)));
            }
            return Err(CliError::Failure(format!("{e}\n({kept})")));
        }
    };
    csv.finish()?;
    std::fs::write(out.join("scenario.toml"), toml::to_string(s).map_err(|e| CliError::Failure(e.to_string()))?)
        .map_err(|e| fail("writing scenario.toml", e))?;
    let json = serde_json::to_string_pretty(&summary).map_err(|e| CliError::Failure(e.to_string()))?;
    std::fs::write(&summary_path, json + "\n").map_err(|e| fail("writing summary.json", e))?;
    let impacts: Vec<String> =
        summary.clearances.iter().map(|c| format!("{}: {} impacts", c.name, c.impacts)).collect();
    eprintln!(
        "{} ({}): {} samples, {} steps ({} rejected), {:.3} s CPU{}{} → {}",
        summary.scenario,
        summary.model,
        summary.samples,
        summary.steps,
        summary.rejected_steps,
        summary.cpu_time_s,
        if impacts.is_empty() { "" } else { ", " },
        impacts.join(", "),
        out.display()
    );
    Ok(())
}
