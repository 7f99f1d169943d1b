//! `lash run <system.toml | system.ssd | system.ssp>`: a coupled system of FMUs, plugins and
//! built-in subsystems, written to `<out>/timeseries.csv` and `<out>/summary.json`.

use crate::CliError;
use std::io::Write;
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

/// Loads and runs a system file.
pub fn run(arg: &str, out: &Path, step: Option<f64>, stop: Option<f64>, quiet: bool) -> Result<(), CliError> {
    let path = Path::new(arg);
    let cache = std::env::temp_dir().join(format!("lash-system-{}", std::process::id()));
    let result = run_in(path, out, &cache, step, stop, quiet);
    let _ = std::fs::remove_dir_all(&cache);
    result
}

fn run_in(
    path: &Path,
    out: &Path,
    cache: &Path,
    step: Option<f64>,
    stop: Option<f64>,
    quiet: bool,
) -> Result<(), CliError> {
    let input = |m: String| CliError::Input(format!("{}: {m}", path.display()));
    let (mut spec, base) = if path.extension().is_some_and(|e| e == "ssd" || e == "ssp") {
        lash_system::ssp::load(path, cache, step).map_err(CliError::Input)?
    } else {
        let text = std::fs::read_to_string(path).map_err(|e| input(e.to_string()))?;
        let spec = lash_system::spec::parse(&text).map_err(input)?;
        (spec, path.parent().unwrap_or(Path::new(".")).to_path_buf())
    };
    if let Some(s) = step {
        spec.step = s;
    }
    if let Some(s) = stop {
        spec.stop = spec.start + s;
    }
    let mut system = lash_system::System::new(&spec, &base, cache).map_err(|e| input(e.to_string()))?;
    std::fs::create_dir_all(out).map_err(|e| CliError::Failure(format!("{}: {e}", out.display())))?;
    let csv_path = out.join("timeseries.csv");
    let fail = |e: &dyn std::fmt::Display| CliError::Failure(format!("{}: {e}", csv_path.display()));
    let mut csv = std::io::BufWriter::new(std::fs::File::create(&csv_path).map_err(|e| fail(&e))?);
    writeln!(csv, "{}", system.header().join(",")).map_err(|e| fail(&e))?;
    let mut line = String::new();
    let mut sink = |row: &[f64]| -> Result<(), String> {
        line.clear();
        for (i, v) in row.iter().enumerate() {
            if i > 0 {
                line.push(',');
            }
            line.push_str(&format!("{v:?}"));
        }
        writeln!(csv, "{line}").map_err(|e| e.to_string())
    };
    let summary = system.run(&mut sink).map_err(|e| match e {
        lash_system::SystemError::Input(m) => input(m),
        other => CliError::Failure(format!("{}: {other}", path.display())),
    })?;
    csv.flush().map_err(|e| fail(&e))?;
    let json = serde_json::to_string_pretty(&summary).map_err(|e| CliError::Failure(e.to_string()))?;
    std::fs::write(out.join("summary.json"), json + "\n").map_err(|e| CliError::Failure(e.to_string()))?;
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
