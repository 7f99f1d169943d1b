//! `lash estimate`: clearance, worn joint and nuisances from a measured file
//! ([`lash_estimate`]), its one-time preparation, its validation on held-out full-model cases,
//! and the emulation of a measurement to try it on.

use crate::CliError;
use lash_estimate::{EstimateError, Estimator, Setup};
use std::path::Path;

fn cli(e: EstimateError) -> CliError {
    match e {
        EstimateError::Input(m) => CliError::Input(m),
        EstimateError::Measurement(e) => CliError::Input(e.to_string()),
        EstimateError::Dataset(e) => CliError::Failure(e.to_string()),
        EstimateError::Failure(m) => CliError::Failure(m),
        EstimateError::Sweep(lash_sweep::SweepError::Input(m)) => CliError::Input(m),
        EstimateError::Sweep(other) => CliError::Failure(other.to_string()),
        EstimateError::Run(e) => CliError::Failure(e.to_string()),
        EstimateError::Acquisition(e) => CliError::Input(e.to_string()),
    }
}

/// Progress lines on standard error, about every tenth of a stage.
fn progress(quiet: bool) -> impl Fn(&str, u64, u64) + Sync {
    move |stage: &str, done: u64, total: u64| {
        if !quiet && (done == total || done.is_multiple_of((total / 10).max(1))) {
            eprintln!("  {stage}: {done}/{total} runs");
        }
    }
}

/// A scratch folder for the sweeps, next to `out`.
fn work_folder(out: &Path) -> std::path::PathBuf {
    let parent = out.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    parent.join(format!(".lash-estimate-work-{}", std::process::id()))
}

fn write(path: &Path, text: &str) -> Result<(), CliError> {
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| CliError::Failure(format!("{}: {e}", parent.display())))?;
    }
    Ok(lash_sweep::dataset::write_atomic(path, text.as_bytes())?)
}

/// Reads a prepared estimator.
pub fn load(path: &Path) -> Result<Estimator, CliError> {
    Estimator::load(path).map_err(cli)
}

/// Sizes of a preparation that override the setup's (None: the setup's).
#[derive(Debug, Clone, Copy, Default)]
pub struct Sizes {
    /// Reduced-model runs of the bank.
    pub bank_runs: Option<u64>,
    /// Full-model runs of the unknowns' calibration.
    pub calibration_runs: Option<u64>,
    /// Full-model cases of the hidden signals' band calibration.
    pub hidden_runs: Option<u64>,
}

/// `lash estimate prepare [SETUP] --out FILE`.
pub fn prepare(setup: &str, out: &Path, sizes: Sizes, quiet: bool) -> Result<(), CliError> {
    let mut setup = Setup::load(setup).map_err(cli)?;
    setup.bank_runs = sizes.bank_runs.unwrap_or(setup.bank_runs);
    setup.calibration_runs = sizes.calibration_runs.unwrap_or(setup.calibration_runs);
    setup.hidden_calibration_runs = sizes.hidden_runs.unwrap_or(setup.hidden_calibration_runs);
    setup.check().map_err(cli)?;
    let work = work_folder(out);
    if !quiet {
        eprintln!(
            "preparing an estimator for {}: {} reduced-model runs × {} measurements, {} full-model runs to calibrate, {} to calibrate the hidden signals",
            setup.name,
            setup.bank_runs,
            setup.measurements_per_run,
            setup.calibration_runs,
            setup.hidden_calibration_runs
        );
    }
    let result = lash_estimate::prepare::prepare(&setup, &work, &progress(quiet));
    let _ = std::fs::remove_dir_all(&work);
    let (estimator, report) = result.map_err(cli)?;
    let json = serde_json::to_string(&estimator).map_err(|e| CliError::Failure(e.to_string()))?;
    write(out, &json)?;
    println!(
        "{}: {} bank draws ({} runs failed) in {:.1} s, fit {:.1} s, {} calibration draws ({} failed) in {:.1} s",
        out.display(),
        report.bank_draws,
        report.bank_failed,
        report.bank_s,
        report.fit_s,
        report.calibration_draws,
        report.calibration_failed,
        report.calibration_s
    );
    for (u, c) in estimator.unknowns.iter().zip(&estimator.calibration) {
        println!(
            "  {:<24} calibration: median shift {:+.4}, interval × {:.3} ({} cases)",
            u.name, c.shift, c.widen, c.cases
        );
    }
    if let Some(c) = &estimator.hidden_calibration {
        for (joint, f) in estimator.joints.iter().zip(&c.factors) {
            println!(
                "  {joint:<24} hidden signals: force band × {:.2}, eccentricity band × {:.2}, RMS range × {:.2}, peak range × {:.2} ({} cases, {:.1} s)",
                f[0], f[1], f[2], f[3], c.cases, report.hidden_s
            );
        }
    }
    Ok(())
}

/// A value with its unit for people (µm for clearances).
fn show(value: f64, unit: &str) -> String {
    match unit {
        "m" => format!("{:.1} µm", value * 1e6),
        "" => format!("{value:.3}"),
        u => format!("{value:.3} {u}"),
    }
}

/// `lash estimate MEASUREMENT --prepared FILE [--out DIR]`.
pub fn estimate(
    measurement: &Path,
    prepared: &Path,
    out: Option<&Path>,
    track: (Option<usize>, Option<usize>),
) -> Result<(), CliError> {
    let estimator = load(prepared)?;
    let setup = &estimator.setup;
    let track = tracking(track)?;
    let (e, hidden, notes) = lash_estimate::infer::estimate_file_hidden(&estimator, measurement, track).map_err(cli)?;
    let f0 = e.crank_frequency;
    println!("{} (setup {}, crank at {:.2} Hz = {:.0} rpm):", measurement.display(), setup.name, f0, f0 * 60.0);
    for note in &notes {
        println!("  note: {note}");
    }
    for u in &e.unknowns {
        println!(
            "  {:<24} {:>12}   90 % interval {} – {}   (prior {} – {})",
            u.name,
            show(u.median, &u.unit),
            show(u.low, &u.unit),
            show(u.high, &u.unit),
            show(u.prior[0], &u.unit),
            show(u.prior[1], &u.unit)
        );
    }
    if !e.worn.is_empty() {
        let worn: Vec<String> = e.worn.iter().map(|(j, p)| format!("{j} {:.0} %", 100.0 * p)).collect();
        println!("  worn joint: {}", worn.join(", "));
    }
    if hidden.calibration_cases > 0 {
        println!("  hidden signals (90 % bands calibrated on {} full-model cases):", hidden.calibration_cases);
    } else {
        println!(
            "  hidden signals (bands: the posterior draws' spread, not calibrated — an estimator prepared before bands were calibrated):"
        );
    }
    if let Some(t) = &hidden.tracking {
        print_tracking(t);
    }
    if let Some(why) = &hidden.tracking_failure {
        println!("  impact tracking failed ({why}): the onsets are the draws'");
    }
    for (j, onsets) in hidden.onsets.iter().enumerate() {
        let ([rms, rms_lo, rms_hi], [peak, peak_lo, peak_hi]) = (hidden.force_rms[j], hidden.force_peak[j]);
        println!(
            "  {:<24} RMS {rms:.0} N ({rms_lo:.0}–{rms_hi:.0}), peak {peak:.0} N ({peak_lo:.0}–{peak_hi:.0}), {} impact onsets",
            hidden.signals[2 * j].name,
            onsets.len()
        );
    }
    if let Some(out) = out {
        let json = serde_json::to_string_pretty(&e).map_err(|err| CliError::Failure(err.to_string()))?;
        write(&out.join("estimate.json"), &(json + "\n"))?;
        crate::plots::posterior_figure(&out.join("posterior.svg"), &estimator, &e)?;
        write(&out.join("hidden.csv"), &hidden_csv(&hidden))?;
        crate::plots::hidden_figure(&out.join("hidden.svg"), &hidden, f0)?;
        println!("  → {}/estimate.json, posterior.svg, hidden.csv, hidden.svg", out.display());
    }
    Ok(())
}

/// The impact tracking's line: its particles, the draws it ran on, its rescues, its innovation
/// and whether it follows the measurement.
fn print_tracking(t: &lash_estimate::track::TrackSummary) {
    let pct = |x: f64| format!("{:.0} %", 100.0 * x / t.measured_rms);
    let draws = match t.draw_innovations.len() {
        0 | 1 => String::new(),
        n => format!(
            ", a filter on each of {n} draws, their innovations {}; draw {}'s kept",
            t.draw_innovations.iter().map(|i| i.map_or("failed".into(), pct)).collect::<Vec<_>>().join(", "),
            t.draw + 1
        ),
    };
    let draws = match t.rescues {
        0 => draws,
        1 => format!("{draws}; every particle failed at one sample, the filter started again from its draw there"),
        r => format!("{draws}; every particle failed at {r} samples, the filter started again from its draw there"),
    };
    println!(
        "  impact tracking ({} particles{draws}): innovation {:.0} % of the measurement's RMS (the best draw alone {:.0} %): {}",
        t.particles,
        100.0 * t.innovation / t.measured_rms,
        100.0 * t.replay_residual / t.measured_rms,
        if t.follows {
            "it follows the measurement, the onsets are its own"
        } else {
            "it does not follow the measurement, the onsets are the draws'"
        }
    );
}

/// The hidden signals as a table: time from the window's start, then per signal its median and
/// band.
fn hidden_csv(hidden: &lash_estimate::Hidden) -> String {
    let mut header = vec!["time [s]".to_string()];
    for b in &hidden.signals {
        for part in ["median", "low", "high"] {
            header.push(format!("{}.{part} [{}]", b.name, b.unit));
        }
    }
    let mut text = lash_core::csv_header(&header) + "\n";
    let n = hidden.signals.first().map_or(0, |b| b.median.len());
    for i in 0..n {
        text.push_str(&format!("{}", i as f64 / hidden.sample_rate));
        for b in &hidden.signals {
            text.push_str(&format!(",{},{},{}", b.median[i], b.low[i], b.high[i]));
        }
        text.push('\n');
    }
    text
}

/// The prepared estimator of a validation, and its number of held-out cases checked.
fn held_out_estimator(prepared: &Path, cases: u64) -> Result<Estimator, CliError> {
    if cases == 0 {
        return Err(CliError::Input("--cases: at least one held-out case".into()));
    }
    load(prepared)
}

/// `lash estimate validate --prepared FILE [--cases N] [--seed S] [--out DIR]`.
pub fn validate(
    prepared: &Path,
    (cases, reduced): (u64, bool),
    seed: u64,
    out: Option<&Path>,
    quiet: bool,
) -> Result<(), CliError> {
    let estimator = held_out_estimator(prepared, cases)?;
    let work = work_folder(out.unwrap_or(prepared));
    let model = if reduced { lash_sweep::spec::ModelKind::Reduced } else { lash_sweep::spec::ModelKind::Full };
    let result = lash_estimate::validate::validate(&estimator, (cases, model), seed, &work, &progress(quiet));
    let _ = std::fs::remove_dir_all(&work);
    let report = result.map_err(cli)?;
    println!(
        "{}: {} held-out {}-model cases (seed {}, {} runs failed), simulated in {:.1} s",
        report.setup,
        report.cases,
        if reduced { "reduced" } else { "full" },
        report.seed,
        report.failed_runs,
        report.simulation_s
    );
    println!("  {:<24} {:>12} {:>12} {:>10}", "unknown", "RMSE", "prior RMSE", "coverage");
    for u in &report.unknowns {
        let fmt = |v: f64| if u.relative { format!("{:.1} %", 100.0 * v) } else { format!("{v:.4}") };
        println!("  {:<24} {:>12} {:>12} {:>9.1} %", u.name, fmt(u.rmse), fmt(u.prior_rmse), 100.0 * u.coverage);
    }
    println!(
        "  worn joint's clearance: relative RMSE {:.1} %, 90 % interval coverage {:.1} %",
        100.0 * report.worn_clearance_rmse,
        100.0 * report.worn_clearance_coverage
    );
    if let Some(a) = report.worn_joint_accuracy {
        println!("  worn joint found: {:.1} % of cases", 100.0 * a);
    }
    println!("  wall time per estimate (features + inference): {:.1} ms", 1e3 * report.seconds_per_estimate);
    if let Some(out) = out {
        let json = serde_json::to_string_pretty(&report).map_err(|e| CliError::Failure(e.to_string()))?;
        write(&out.join("validation.json"), &(json + "\n"))?;
    }
    Ok(())
}

/// The impact tracking's options for `--track-impacts PARTICLES [--track-draws DRAWS]`.
fn tracking(
    (particles, draws): (Option<usize>, Option<usize>),
) -> Result<Option<lash_estimate::track::TrackOptions>, CliError> {
    use lash_estimate::track::{BadTrackOption, TrackOptions};
    particles
        .map(|p| {
            TrackOptions::with(p, draws).map_err(|e| match e {
                BadTrackOption::Particles(m) => CliError::Input(format!("--track-impacts: {m}")),
                BadTrackOption::Draws(m) => CliError::Input(format!("--track-draws: {m}")),
            })
        })
        .transpose()
}

/// `lash estimate validate --prepared FILE --hidden SNR_DB [--cases N] [--seed S] [--out DIR]`.
pub fn validate_hidden(
    prepared: &Path,
    (cases, seed, snr_db): (u64, u64, f64),
    track: (Option<usize>, Option<usize>),
    out: Option<&Path>,
    quiet: bool,
) -> Result<(), CliError> {
    let estimator = held_out_estimator(prepared, cases)?;
    if !(snr_db.is_finite() && snr_db > 0.0) {
        return Err(CliError::Input(format!("--hidden: a signal-to-noise ratio in dB above 0, got {snr_db}")));
    }
    let track = tracking(track)?;
    let r = lash_estimate::hidden::validate_hidden(&estimator, (cases, seed, snr_db), track, &progress(quiet))
        .map_err(cli)?;
    println!(
        "{}: hidden signals of {} held-out full-model cases at {} dB (seed {}, {} left out)",
        r.setup, r.cases, r.snr_db, r.seed, r.failed
    );
    let pct = |v: f64| format!("{:.1} %", 100.0 * v);
    println!(
        "  force RMS error: median {}, 90 % of cases ≤ {}; within 10 %: {} of joints",
        pct(r.force_rms_error[0]),
        pct(r.force_rms_error[1]),
        pct(r.force_rms_within_10)
    );
    println!(
        "  force peak error: median {}, 90 % of cases ≤ {}; within 20 %: {} of joints",
        pct(r.force_peak_error[0]),
        pct(r.force_peak_error[1]),
        pct(r.force_peak_within_20)
    );
    let calibrated = match &estimator.hidden_calibration {
        Some(c) => format!("calibrated on {} full-model cases", c.cases),
        None => "the draws' own spread, not calibrated".to_string(),
    };
    println!(
        "  90 % ranges ({calibrated}) hold the true force RMS in {}, its peak in {} of joints",
        pct(r.force_rms_coverage),
        pct(r.force_peak_coverage)
    );
    println!(
        "  90 % bands hold the true force at {} of samples, the eccentricity at {}",
        pct(r.force_band_coverage),
        pct(r.eccentricity_band_coverage)
    );
    let found =
        r.impacts_found.map_or("none to find".into(), |v| format!("{} of them found within two samples", pct(v)));
    let real = r.onsets_true.map_or(String::new(), |v| format!(", {} of them true", pct(v)));
    println!("  impact onsets: {} true, {found}; {} reported{real}", r.impacts, r.onsets_reported);
    if let Some((particles, followed)) = r.tracking {
        println!(
            "  impact tracking ({particles} particles): followed the measurement in {followed} of {} cases (their onsets the filter's, the others' the draws'){}",
            r.cases,
            match r.tracking_failures {
                0 => String::new(),
                f => format!("; it could not run in {f} (its simulations failed)"),
            }
        );
    }
    println!("  wall time per case (estimate, re-simulation, alignment): {:.2} s", r.seconds_per_case);
    if let Some(out) = out {
        let json = serde_json::to_string_pretty(&r).map_err(|e| CliError::Failure(e.to_string()))?;
        write(&out.join("hidden-validation.json"), &(json + "\n"))?;
    }
    Ok(())
}

/// `lash estimate emulate --prepared FILE --clearance C[,C…] --out FILE.csv`: one measurement of the
/// converged full model, as the setup's logger would record it.
pub fn emulate(prepared: &Path, case: &lash_estimate::prepare::Case, out: &Path) -> Result<(), CliError> {
    let estimator = load(prepared)?;
    let setup = &estimator.setup;
    let work = work_folder(out);
    let result = lash_estimate::prepare::emulate(setup, case, &work);
    let _ = std::fs::remove_dir_all(&work);
    let channels = result.map_err(cli)?;
    let mut text = String::from("time [s]");
    for c in &setup.channels {
        text.push_str(&format!(",{} [{}]", c.name, c.unit));
    }
    text.push('\n');
    for i in 0..channels[0].len() {
        text.push_str(&format!("{}", i as f64 / setup.sample_rate));
        for c in &channels {
            text.push_str(&format!(",{}", c[i]));
        }
        text.push('\n');
    }
    write(out, &text)?;
    println!("{}: {} samples at {} Hz of the full model", out.display(), channels[0].len(), setup.sample_rate);
    Ok(())
}
