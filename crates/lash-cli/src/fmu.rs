//! `lash fmu pack`: the FMUs as `.fmu` archives (FMI 3.0 co-simulation for x86_64-linux, and FMI
//! 2.0 co-simulation for linux64 from the same shared library).
//!
//! An archive holds `modelDescription.xml` (generated from the subsystem's variables by
//! `lash-fmi`), `binaries/x86_64-linux/<modelIdentifier>.so`, the cdylib built from `fmus/`
//! (`cargo build --release --workspace` builds it next to the `lash` binary), and
//! `resources/scenario.toml`, the scenario the generic binary builds its model from.

use crate::CliError;
use lash_catalog::FmiVersion;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The shared library of `identifier`, looked up next to the running binary.
fn library(identifier: &str) -> Result<PathBuf, CliError> {
    let exe = std::env::current_exe().map_err(|e| CliError::Failure(format!("cannot locate the lash binary: {e}")))?;
    let dir = exe.parent().unwrap_or(Path::new("."));
    let file = format!("lib{identifier}.so");
    [dir.join(&file), dir.join("deps").join(&file), dir.join("..").join(&file)]
        .into_iter()
        .find(|p| p.is_file())
        .ok_or_else(|| {
            CliError::Failure(format!(
                "{file} not found next to {}: build the FMU libraries with `cargo build --release --workspace`",
                exe.display()
            ))
        })
}

/// Writes `<out>/<identifier>.fmu` (FMI 3.0) or `<out>/<identifier>-fmi2.fmu` from a description and
/// the library.
fn pack_one(
    out: &Path,
    identifier: &str,
    version: FmiVersion,
    description: &str,
    scenario: &str,
) -> Result<PathBuf, CliError> {
    let lib = library(identifier)?;
    let binary = std::fs::read(&lib).map_err(|e| CliError::Failure(format!("{}: {e}", lib.display())))?;
    std::fs::create_dir_all(out).map_err(|e| CliError::Failure(format!("{}: {e}", out.display())))?;
    let (file_name, platform) = match version {
        FmiVersion::V3 => (format!("{identifier}.fmu"), "x86_64-linux"),
        FmiVersion::V2 => (format!("{identifier}-fmi2.fmu"), "linux64"),
    };
    let path = out.join(&file_name);
    let partial = out.join(format!("{file_name}.partial"));
    let fail = |e: &dyn std::fmt::Display| CliError::Failure(format!("{}: {e}", partial.display()));
    let file = std::fs::File::create(&partial).map_err(|e| fail(&e))?;
    let mut zip = zip::ZipWriter::new(file);
    let options = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    zip.start_file("modelDescription.xml", options).map_err(|e| fail(&e))?;
    zip.write_all(description.as_bytes()).map_err(|e| fail(&e))?;
    zip.start_file(format!("binaries/{platform}/{identifier}.so"), options).map_err(|e| fail(&e))?;
    zip.write_all(&binary).map_err(|e| fail(&e))?;
    zip.start_file(format!("resources/{}", lash_catalog::SCENARIO_RESOURCE), options).map_err(|e| fail(&e))?;
    zip.write_all(scenario.as_bytes()).map_err(|e| fail(&e))?;
    zip.finish().map_err(|e| fail(&e))?;
    std::fs::rename(&partial, &path).map_err(|e| fail(&e))?;
    Ok(path)
}

/// `lash fmu pack [SCENARIO] --out <dir>`.
pub fn pack(scenario: &lash_scenario::AnyScenario, out: &Path) -> Result<(), CliError> {
    if let Some(reason) = lash_catalog::reduced_refusal(scenario) {
        eprintln!("note: only the full-model FMU is packed: no mechanism and interface FMUs ({reason})");
    }
    for path in pack_quiet(scenario, out)? {
        println!("{}", path.display());
    }
    Ok(())
}

/// Packs every FMU of `scenario` into `out`; returns the archives written.
pub fn pack_quiet(scenario: &lash_scenario::AnyScenario, out: &Path) -> Result<Vec<PathBuf>, CliError> {
    let text = toml::to_string(scenario).map_err(|e| CliError::Failure(format!("the scenario as TOML: {e}")))?;
    // The archive's scenario must build the same models as the one given (same variables, same
    // token): checked by reading it back as the FMU will.
    let reread = lash_scenario::parse_any(&text)
        .map_err(|p| CliError::Failure(format!("the scenario written into the FMUs does not read back: {p}")))?;
    let descriptions = lash_catalog::descriptions(scenario)
        .map_err(|e| CliError::Input(format!("scenario {}: {}", scenario.name(), lash_core::error_chain(&e))))?;
    if lash_catalog::descriptions(&reread)? != descriptions {
        return Err(CliError::Failure(
            "the scenario written into the FMUs builds other models than the one given".into(),
        ));
    }
    descriptions
        .into_iter()
        .map(|(identifier, version, description)| pack_one(out, identifier, version, &description, &text))
        .collect()
}

/// "3 Float64, 1 Int32, …": the variables by kind, in the order kinds first appear.
fn kinds(variables: &[lash_core::Variable]) -> String {
    let mut counts: Vec<(lash_core::ValueKind, usize)> = Vec::new();
    for v in variables {
        match counts.iter_mut().find(|(k, _)| *k == v.kind) {
            Some((_, n)) => *n += 1,
            None => counts.push((v.kind, 1)),
        }
    }
    counts.iter().map(|(k, n)| format!("{n} {}", k.name())).collect::<Vec<_>>().join(", ")
}

/// `lash fmu check <file.fmu>`: structure (archive, description, binary, symbols, token) and a
/// smoke simulation of 10 steps of 1e-5 s with the start values; `isolate` runs the FMU in a child
/// process (each call waits at most `timeout` seconds), so that a crash or a hang is reported.
pub fn check(fmu: &Path, isolate: bool, timeout: f64) -> Result<(), CliError> {
    use lash_core::{Subsystem, Ticks};
    let cache = lash_fmi::import::default_cache();
    let (mut model, version): (Box<dyn Subsystem>, String) = if isolate {
        let timeout =
            std::time::Duration::try_from_secs_f64(timeout).ok().filter(|t| !t.is_zero()).ok_or_else(|| {
                CliError::Input(format!("--timeout: must be a positive number of seconds, got {timeout}"))
            })?;
        let host = std::env::current_exe().map_err(|e| CliError::Failure(format!("the lash executable: {e}")))?;
        let isolated = lash_fmi::isolate::IsolatedFmu::spawn(&host, fmu, &cache, "check", timeout)
            .map_err(|e| CliError::Input(format!("{}: {}", fmu.display(), lash_core::error_chain(&e))))?;
        let version = isolated.fmi_version().to_string();
        (Box::new(isolated), version)
    } else {
        let imported =
            lash_fmi::import::ImportedFmu::open(fmu, &cache, "check").map_err(|e| CliError::Input(format!("{e}")))?;
        let version = imported.fmi_version().to_string();
        (Box::new(imported), version)
    };
    let variables = model.variables().to_vec();
    let step = Ticks::from_seconds(1e-5).map_err(|e| CliError::Failure(e.to_string()))?;
    let fail = |e: lash_core::SubsystemError| CliError::Failure(format!("{}: smoke simulation: {e}", fmu.display()));
    model.setup(Ticks::ZERO, None).map_err(fail)?;
    model.initialize().map_err(fail)?;
    let numeric_outputs =
        || variables.iter().filter(|v| v.causality == lash_core::Causality::Output && v.kind.is_numeric());
    let outputs: Vec<u32> = numeric_outputs().map(|v| v.value_reference).collect();
    let mut values = vec![0.0; numeric_outputs().map(|v| v.len()).sum()];
    let mut stopped = String::new();
    for k in 0..10 {
        if let Some(stop) = model.do_step(Ticks(k * step.0), step).map_err(fail)?.stop(Ticks(k * step.0), step) {
            stopped = format!(" (the FMU {stop}, after {k} whole steps)");
            break;
        }
        model.get_f64(&outputs, &mut values).map_err(fail)?;
        if let Some(bad) = values.iter().position(|v| !v.is_finite()) {
            return Err(CliError::Failure(format!(
                "{}: smoke simulation: output element {bad} is {} after step {k}",
                fmu.display(),
                values[bad]
            )));
        }
    }
    model.terminate().map_err(fail)?;
    println!(
        "{}: FMI {version} co-simulation{}, {} variables ({}; {} numeric outputs read); symbols, token and 10 steps of 1e-5 s: OK{stopped}",
        fmu.display(),
        if isolate { " (isolated in a child process)" } else { "" },
        variables.len(),
        kinds(&variables),
        outputs.len()
    );
    Ok(())
}
