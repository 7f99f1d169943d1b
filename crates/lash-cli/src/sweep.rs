//! `lash sweep`: parameter sweeps to Parquet datasets, with a progress bar; `lash sweep merge`.

use crate::CliError;
use indicatif::{ProgressBar, ProgressStyle};
use lash_sweep::{Event, ExecuteOptions, SweepError};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

fn map_error(e: SweepError) -> CliError {
    match e {
        SweepError::Input(m) => CliError::Input(m),
        SweepError::Output(m) => CliError::Failure(m),
    }
}

/// Runs a sweep file (or one shard) into `out`.
pub fn run(file: &Path, out: &Path, shard: Option<&str>, threads: Option<usize>, quiet: bool) -> Result<(), CliError> {
    let shard = shard.map(lash_sweep::parse_shard).transpose().map_err(CliError::Input)?;
    if threads == Some(0) {
        return Err(CliError::Input("--threads must be ≥ 1".into()));
    }
    let plan = lash_sweep::load(file).map_err(map_error)?;
    let bar = if quiet { ProgressBar::hidden() } else { ProgressBar::new(0) };
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} runs, {msg} failed, {per_sec}, ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let failures = AtomicU64::new(0);
    bar.set_message("0");
    let on_event = |e: Event| match e {
        Event::Start { total, done } => {
            bar.set_length(total);
            bar.set_position(done);
            bar.reset_eta();
        }
        Event::Finished { ok } => {
            if !ok {
                let f = failures.fetch_add(1, Ordering::Relaxed) + 1;
                bar.set_message(f.to_string());
            }
            bar.inc(1);
        }
    };
    let report = lash_sweep::execute(&plan, &ExecuteOptions { out: out.to_path_buf(), shard, threads }, &on_event)
        .map_err(map_error)?;
    bar.finish_and_clear();
    let what = match shard {
        Some(s) => format!("shard {}/{} of {}", s.index, s.count, file.display()),
        None => file.display().to_string(),
    };
    eprintln!(
        "{what}: {} runs ({} already complete, {} run now, {} failed) in {:.2} s on {} threads → {}",
        report.runs,
        report.skipped,
        report.ran,
        report.failed,
        report.wall_s,
        report.threads,
        out.display()
    );
    if report.failed > 0 {
        // The dataset is complete (the failed runs are in it, with their errors): the exit code
        // says that it is not all data, so that a pipeline does not train on a silent gap.
        return Err(CliError::Failure(format!(
            "{} of {} runs failed; the dataset holds the others, and manifest.json and params.parquet list the \
             failed runs with status \"failed\" and their errors",
            report.failed, report.runs
        )));
    }
    Ok(())
}

/// Merges shard folders.
pub fn merge(inputs: &[PathBuf], out: &Path) -> Result<(), CliError> {
    let rows = lash_sweep::merge(inputs, out).map_err(map_error)?;
    eprintln!("merged {} shard folders: {rows} rows → {}", inputs.len(), out.display());
    Ok(())
}
