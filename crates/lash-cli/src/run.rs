//! `lash run`: streams the CSV, then writes the summary; nothing is left looking complete on
//! failure (the CSV stays as `timeseries.csv.partial`, no summary.json).

use crate::CliError;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use lash_scenario::{Runner, Scenario};
use std::io::Write;
use std::path::Path;
use std::time::{Duration, Instant};

pub fn run(s: &Scenario, runner: &mut dyn Runner, out: &Path, quiet: bool) -> Result<(), CliError> {
    let fail = |what: &str, e: std::io::Error| CliError::Failure(format!("{what}: {e}"));
    std::fs::create_dir_all(out).map_err(|e| fail(&format!("cannot create {}", out.display()), e))?;
    let csv_path = out.join("timeseries.csv");
    let partial = out.join("timeseries.csv.partial");
    let summary_path = out.join("summary.json");
    // A previous complete result in this folder must not survive as if it belonged to this run.
    for p in [&csv_path, &summary_path] {
        if p.exists() {
            std::fs::remove_file(p).map_err(|e| fail(&format!("cannot remove old {}", p.display()), e))?;
        }
    }
    let file = std::fs::File::create(&partial).map_err(|e| fail(&format!("cannot create {}", partial.display()), e))?;
    let mut w = std::io::BufWriter::new(file);
    writeln!(w, "{}", runner.header().join(",")).map_err(|e| fail("writing the CSV header", e))?;

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
    let mut line = String::with_capacity(1024);
    let mut sink = |row: &[f64]| -> Result<(), String> {
        use std::fmt::Write as _;
        line.clear();
        for (k, v) in row.iter().enumerate() {
            if k > 0 {
                line.push(',');
            }
            let a = v.abs();
            if a == 0.0 || (1e-4..1e15).contains(&a) {
                let _ = write!(line, "{v}");
            } else {
                let _ = write!(line, "{v:e}");
            }
        }
        line.push('\n');
        w.write_all(line.as_bytes()).map_err(|e| format!("output: {e}"))
    };
    let result = runner.execute(&mut sink, &mut progress);
    bar.finish_and_clear();
    let summary = match result {
        Ok(s) => s,
        Err(e) => {
            let _ = w.flush();
            return Err(CliError::Failure(format!(
                "{e}\n(the samples up to the failure are in {}; no summary was written)",
                partial.display()
            )));
        }
    };
    w.flush().map_err(|e| fail("writing the CSV", e))?;
    drop(w);
    std::fs::rename(&partial, &csv_path).map_err(|e| fail("finishing the CSV", e))?;
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
