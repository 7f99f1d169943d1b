//! `lash sweep`: parameter sweeps to Parquet datasets, with a progress bar; `lash sweep merge`.

use crate::CliError;
use indicatif::{ProgressBar, ProgressStyle};
use lash_sweep::{Event, ExecuteOptions, SweepError};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// A sweep error as the command line reports it.
pub fn map_error(e: SweepError) -> CliError {
    match e {
        SweepError::Input(m) => CliError::Input(m),
        SweepError::Output(m) => CliError::Failure(m),
        SweepError::Dataset(e) => CliError::Failure(e.to_string()),
        SweepError::Interrupted(m) => CliError::Interrupted(m),
    }
}

/// Runs a sweep file (or one shard, `shard` as `i/N`) into `out` on `threads` workers (None: one
/// per core) that each simulate `side_by_side` runs at once (None: [`lash_sweep::SIDE_BY_SIDE`]),
/// after its limits are checked (limits.rs): the path every front end takes (the
/// command line, the Python package). `on_event` sees the start and each finished run; setting
/// `cancel` stops the sweep resumably. Runs that fail are in the report and the dataset; the
/// caller decides what a failure means to it.
pub fn execute(
    file: &Path,
    out: &Path,
    (shard, threads, side_by_side): (Option<&str>, Option<usize>, Option<usize>),
    cancel: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
    on_event: &(dyn Fn(Event) + Sync),
) -> Result<lash_sweep::Report, CliError> {
    let shard = shard.map(lash_sweep::parse_shard).transpose().map_err(|e| CliError::Input(e.to_string()))?;
    if threads == Some(0) {
        return Err(CliError::Input("threads must be ≥ 1".into()));
    }
    if side_by_side == Some(0) {
        return Err(CliError::Input("side_by_side must be ≥ 1 (1: one run at a time)".into()));
    }
    let side_by_side = side_by_side.unwrap_or(lash_sweep::SIDE_BY_SIDE);
    // Sized before the runs are listed (a design of 10⁹ runs is itself gigabytes).
    let (spec, text, base) = lash_sweep::read(file).map_err(map_error)?;
    let listed = spec.run_count();
    let runs = match shard {
        Some(s) => listed.div_ceil(s.count),
        None => listed,
    };
    let workers = threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let o = &spec.output;
    let horizon = spec.horizon.unwrap_or(base.simulation().horizon);
    // Each worker holds the runs it simulates side by side.
    let at_once = workers.saturating_mul(side_by_side) as u64;
    let mut estimate =
        crate::limits::sweep_estimate(runs, at_once, horizon, o.sample_rate, o.channels.len(), o.clean, o.csv);
    estimate.memory_bytes = estimate.memory_bytes.saturating_add(design_bytes(&spec));
    crate::limits::check(
        &format!("lash sweep {}", file.display()),
        &estimate,
        out,
        "fewer runs (or shards), a shorter horizon, a lower output.sample_rate or fewer output.channels",
    )?;
    let plan = lash_sweep::plan(file, (spec, text, base)).map_err(map_error)?;
    lash_sweep::execute(
        &plan,
        &ExecuteOptions { out: out.to_path_buf(), shard, threads, cancel, side_by_side },
        on_event,
    )
    .map_err(map_error)
}

/// `lash sweep`: [`execute`] with a progress bar; exit 1 when runs failed.
pub fn run(
    file: &Path,
    out: &Path,
    (shard, threads, side_by_side): (Option<&str>, Option<usize>, Option<usize>),
    quiet: bool,
) -> Result<(), CliError> {
    if threads == Some(0) {
        return Err(CliError::Input("--threads must be ≥ 1".into()));
    }
    if side_by_side == Some(0) {
        return Err(CliError::Input("--side-by-side must be ≥ 1 (1: one run at a time)".into()));
    }
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
    let report = execute(file, out, (shard, threads, side_by_side), None, &on_event)?;
    bar.finish_and_clear();
    let what = match shard {
        Some(s) => format!("shard {s} of {}", file.display()),
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

/// True when `arg` is a sweep file: TOML with a top-level `base` (the scenario it varies).
pub fn is_sweep(arg: &str) -> bool {
    let path = Path::new(arg);
    path.is_file()
        && std::fs::read_to_string(path)
            .ok()
            .and_then(|t| t.parse::<toml::Table>().ok())
            .is_some_and(|t| t.get("base").is_some_and(toml::Value::is_str))
}

/// Bytes of a sweep's design and journal in memory: each run's values and its record.
fn design_bytes(spec: &lash_sweep::SweepSpec) -> u64 {
    spec.run_count().saturating_mul(8 * spec.parameters.len() as u64 + 128)
}

/// `lash validate` of a sweep file: the file and its base scenario, then every run's scenario
/// (the base with the run's parameter values), as `lash sweep` would build them. Lists the first
/// ten runs whose scenario is invalid.
pub fn validate(file: &Path) -> Result<String, CliError> {
    // Sized before the runs are listed, as `lash sweep` sizes them.
    let (spec, text, base) = lash_sweep::read(file).map_err(map_error)?;
    let design = crate::limits::Estimate { rows: 0, columns: 0, disk_bytes: 0, memory_bytes: design_bytes(&spec) };
    crate::limits::check(
        &format!("lash validate {}", file.display()),
        &design,
        file.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new(".")),
        "fewer runs (a grid's runs are the product of its parameters' counts)",
    )?;
    let plan = lash_sweep::plan(file, (spec, text, base)).map_err(map_error)?;
    let mut bad = Vec::new();
    let mut count = 0;
    for run in &plan.runs {
        if let Err(e) = plan.scenario(run) {
            count += 1;
            if bad.len() < 10 {
                bad.push(format!("  - run {}: {e}", run.id));
            }
        }
    }
    if count > 0 {
        return Err(CliError::Input(format!(
            "invalid sweep file {}: {count} of {} runs have an invalid scenario:\n{}",
            file.display(),
            plan.runs.len(),
            bad.join("\n")
        )));
    }
    Ok(format!(
        "{}: valid (sweep of {}; {} runs, {} parameters, {} channels)",
        file.display(),
        plan.spec.base,
        plan.runs.len(),
        plan.spec.parameters.len(),
        plan.spec.output.channels.len()
    ))
}

/// A sweep given as JSON (Python's dict) written as a sweep file's TOML text, its fields checked
/// as a file's are.
pub fn spec_toml_from_json(json: &str) -> Result<String, CliError> {
    let spec: lash_sweep::SweepSpec =
        serde_json::from_str(json).map_err(|e| CliError::Input(format!("invalid sweep: {e}")))?;
    let problems = spec.check();
    if !problems.is_empty() {
        return Err(CliError::Input(format!("invalid sweep: {problems}")));
    }
    toml::to_string(&spec).map_err(|e| CliError::Failure(format!("the sweep as TOML: {e}")))
}

/// Merges shard folders (`lash sweep merge SHARD… --out DIR`).
pub fn merge(inputs: &[PathBuf], out: &Path) -> Result<(), CliError> {
    let rows = lash_sweep::merge(inputs, out).map_err(map_error)?;
    eprintln!("merged {} shard folders: {rows} rows → {}", inputs.len(), out.display());
    // As `lash sweep` does: a dataset with failed runs is complete but not all data.
    let manifest = lash_sweep::dataset::Manifest::read(out)?;
    let runs = manifest.map(|m| m.runs).unwrap_or_default();
    let failed = runs.iter().filter(|r| r.status != "ok").count();
    if failed > 0 {
        return Err(CliError::Failure(format!(
            "{failed} of {} runs failed; the merged dataset holds the others, and manifest.json and params.parquet \
             list the failed runs with status \"failed\" and their errors",
            runs.len()
        )));
    }
    Ok(())
}
