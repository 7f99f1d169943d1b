//! `lash run <system.toml | system.ssd | system.ssp>`: a coupled system of FMUs, plugins and
//! built-in subsystems, written to `<out>/timeseries.csv` and `<out>/summary.json`.

use crate::CliError;
use crate::output::SeriesOutput;
use std::path::Path;

/// True when `arg` names a system file rather than a scenario: an `.ssd`/`.ssp` file, or TOML
/// with a top-level `elements` list.
pub fn is_system(arg: &str) -> bool {
    let path = Path::new(arg);
    if path.extension().is_some_and(|e| e == "ssd" || e == "ssp") {
        return true;
    }
    path.is_file()
        && std::fs::read_to_string(path)
            .ok()
            .and_then(|t| t.parse::<toml::Table>().ok())
            .is_some_and(|t| t.get("elements").is_some_and(toml::Value::is_array))
}

/// Loads and runs a system file. FMUs are unpacked once into lash's cache (kept between runs,
/// keyed by the archive's hash); an `.ssp` archive is unpacked into a temporary folder removed
/// afterwards.
pub fn run(
    arg: &str,
    out: &Path,
    step: Option<f64>,
    stop: Option<f64>,
    format: crate::output::Format,
    quiet: bool,
) -> Result<(), CliError> {
    let path = Path::new(arg);
    let cache = lash_fmi::import::default_cache();
    let scratch = std::env::temp_dir().join(format!("lash-system-{}", std::process::id()));
    let result = run_in(path, out, &cache, &scratch, (step, stop), format, quiet);
    let _ = std::fs::remove_dir_all(&scratch);
    result
}

/// Reads a system file (TOML, `.ssd` or `.ssp`, an archive unpacked into `scratch`) and builds the
/// system: every element instantiated (FMUs unpacked into `cache` and loaded), every connection
/// checked. `step` and `stop` override the file's.
fn load(
    path: &Path,
    cache: &Path,
    scratch: &Path,
    step: Option<f64>,
    stop: Option<f64>,
) -> Result<lash_system::System, CliError> {
    let input = |m: String| CliError::Input(format!("{}: {m}", path.display()));
    let (mut spec, base) = if path.extension().is_some_and(|e| e == "ssd" || e == "ssp") {
        let fallback = lash_system::ssp::Fallback { step, horizon: stop };
        lash_system::ssp::load(path, scratch, fallback).map_err(|e| CliError::Input(e.to_string()))?
    } else {
        let text = std::fs::read_to_string(path).map_err(|e| input(e.to_string()))?;
        let spec = lash_system::spec::parse(&text).map_err(|e| input(e.to_string().trim_end().to_string()))?;
        (spec, path.parent().unwrap_or(Path::new(".")).to_path_buf())
    };
    if let Some(s) = step {
        spec.step = s;
    }
    if let Some(s) = stop {
        spec.stop = spec.start + s;
    }
    lash_system::System::new(&spec, &base, cache).map_err(|e| input(e.to_string()))
}

/// Refuses a system run whose output cannot fit in `out` (rows × columns of the time series),
/// before anything is written.
fn sized(system: &lash_system::System, path: &Path, out: &Path, format: crate::output::Format) -> Result<(), CliError> {
    let rows = system.samples();
    let columns = system.header().len() as u64;
    let per_value = crate::limits::bytes_per_value(format);
    let estimate = crate::limits::Estimate {
        rows,
        columns,
        disk_bytes: rows.saturating_mul(columns).saturating_mul(per_value),
        memory_bytes: 0,
    };
    crate::limits::check(
        &format!("the system {}", path.display()),
        &estimate,
        out,
        "a shorter run (stop, or --horizon), a longer output.interval or fewer output.channels",
    )
}

/// `lash validate` of a system file: loads it as `lash run` would, without stepping it.
pub fn validate(arg: &str) -> Result<String, CliError> {
    let path = Path::new(arg);
    let cache = lash_fmi::import::default_cache();
    let scratch = std::env::temp_dir().join(format!("lash-validate-{}", std::process::id()));
    let result = load(path, &cache, &scratch, None, None);
    let _ = std::fs::remove_dir_all(&scratch);
    let system = result?;
    // Sized as `lash run` sizes it, against the file's folder.
    let folder = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    sized(&system, path, folder, crate::output::Format::Csv)?;
    Ok(format!("{arg}: valid (system; {} output channels)", system.header().len().saturating_sub(1)))
}

/// Runs a system file into memory (Python's `lash.run("system.toml")`): every row goes to
/// `on_row`; returns the header (`name [unit]`, time first) and the summary as JSON. Refused
/// before anything runs when its rows cannot fit in memory; an FMU that ends the run before its
/// stop time without being asked is an error, as for `lash run`.
pub fn run_rows(
    arg: &str,
    (step, stop): (Option<f64>, Option<f64>),
    on_row: &mut dyn FnMut(&[f64]) -> Result<(), lash_core::BoxError>,
) -> Result<(Vec<String>, String), CliError> {
    let path = Path::new(arg);
    let cache = lash_fmi::import::default_cache();
    let scratch = std::env::temp_dir().join(format!("lash-system-py-{}", std::process::id()));
    let loaded = load(path, &cache, &scratch, step, stop);
    let result = loaded.and_then(|mut system| {
        let header = system.header().to_vec();
        let (rows, columns) = (system.samples(), header.len() as u64);
        let estimate = crate::limits::Estimate {
            rows,
            columns,
            disk_bytes: 0,
            memory_bytes: rows.saturating_mul(columns).saturating_mul(8),
        };
        let advice = "a shorter run (stop), a longer output.interval or fewer output.channels";
        crate::limits::check(&format!("the system {}", path.display()), &estimate, Path::new("."), advice)?;
        let summary = system.run(on_row).map_err(|e| match e {
            lash_system::SystemError::Input(m) => CliError::Input(format!("{}: {m}", path.display())),
            other => CliError::Failure(format!("{}: {other}", path.display())),
        })?;
        if let Some(stop) = summary.stopped.as_ref().filter(|s| !s.requested) {
            return Err(CliError::Failure(format!(
                "{}: element {:?} {} before the stop time (at t = {} s)",
                path.display(),
                stop.element,
                stop.reason,
                stop.last_row_s
            )));
        }
        let json = serde_json::to_string(&summary).map_err(|e| CliError::Failure(e.to_string()))?;
        Ok((header, json))
    });
    let _ = std::fs::remove_dir_all(&scratch);
    result
}

fn run_in(
    path: &Path,
    out: &Path,
    cache: &Path,
    scratch: &Path,
    (step, stop): (Option<f64>, Option<f64>),
    format: crate::output::Format,
    quiet: bool,
) -> Result<(), CliError> {
    let input = |m: String| CliError::Input(format!("{}: {m}", path.display()));
    let mut system = load(path, cache, scratch, step, stop)?;
    sized(&system, path, out, format)?;
    let mut csv = SeriesOutput::create_as(out, system.header(), &["summary.json"], format)?;
    let result = system.run(&mut |row| csv.row(row).map_err(lash_core::BoxError::from));
    let summary = match result {
        Ok(s) => s,
        Err(e) => {
            let kept = SeriesOutput::kept(csv.abandon().as_deref());
            return Err(match e {
                _ if crate::output::interrupted() => {
                    CliError::Interrupted(format!("{}: {kept}", crate::output::INTERRUPTED_MESSAGE))
                }
                lash_system::SystemError::Input(m) => input(format!("{m}\n({kept})")),
                other => CliError::Failure(format!("{}: {other}\n({kept})", path.display())),
            });
        }
    };
    if let Some(stop) = summary.stopped.as_ref().filter(|s| !s.requested) {
        // Nobody asked for this end: the run failed to reach its stop time.
        let kept = SeriesOutput::kept(csv.abandon().as_deref());
        return Err(CliError::Failure(format!(
            "{}: element {:?} {} (lash instantiates FMUs with earlyReturnAllowed = false)\n(rows up to t = {} s: {kept})",
            path.display(),
            stop.element,
            stop.reason,
            stop.last_row_s,
        )));
    }
    let csv_path = csv.finish()?;
    let json = serde_json::to_string_pretty(&summary).map_err(|e| CliError::Failure(e.to_string()))?;
    std::fs::write(out.join("summary.json"), json + "\n").map_err(|e| CliError::Failure(e.to_string()))?;
    if let Some(stop) = &summary.stopped {
        // A stop the FMU asked for is a normal end (exit 0), said even with --quiet.
        eprintln!(
            "notice: element {:?} {}; the run ended there, rows up to t = {} s are in {}",
            stop.element,
            stop.reason,
            stop.last_row_s,
            csv_path.display()
        );
    }
    if !quiet {
        eprintln!(
            "{} (system): {} steps, {} samples, {:.3} s wall → {}",
            summary.system,
            summary.steps,
            summary.samples,
            summary.wall_time_s,
            out.display()
        );
    }
    Ok(())
}
