//! `lash compare`: the converged full model and the reduced model of one scenario, side by side.

use crate::CliError;
use lash_metrics as compare;
use lash_run::{AnyRunner, BuildOptions, FullRun, ReducedOptions, SpatialRun};
use lash_scenario::AnyScenario;
use std::path::Path;

/// Pointwise errors are also reported over this first window, through the first impacts \[s\].
const FIRST_WINDOW: f64 = 2e-3;

/// Upper end of the spectra drawn in the figures \[Hz\] (the reduced-interface-model papers show the low kilohertz range).
const FIGURE_MAX_FREQUENCY: f64 = 20_000.0;

/// A CSV written by a run as its header cells (`name [unit]`) and its rows (lash-sweep's reader,
/// the one of every time series).
fn read_csv(path: &Path) -> Result<(Vec<String>, Vec<Vec<f64>>), CliError> {
    let (names, columns) = lash_sweep::dataset::read_csv_series(path)?;
    let header = names.iter().map(|(n, u)| if u.is_empty() { n.clone() } else { format!("{n} [{u}]") }).collect();
    let rows = (0..columns.first().map_or(0, Vec::len)).map(|i| columns.iter().map(|c| c[i]).collect()).collect();
    Ok((header, rows))
}

fn read_json(path: &Path) -> Result<serde_json::Value, CliError> {
    let text = std::fs::read_to_string(path).map_err(|e| CliError::Failure(format!("{}: {e}", path.display())))?;
    serde_json::from_str(&text).map_err(|e| CliError::Failure(format!("{}: {e}", path.display())))
}

/// The full (or ideal) model's runner of a planar or spatial scenario.
fn full_runner(s: &AnyScenario, ideal: bool) -> AnyRunner {
    match s {
        AnyScenario::Planar(p) => AnyRunner::Full(Box::new(FullRun::new(p, BuildOptions { ideal }))),
        AnyScenario::Spatial(p) => AnyRunner::Spatial(Box::new(SpatialRun::new(p, ideal))),
    }
}

/// The reduced run's error estimate (crate::probe) beside the error the comparison measures
/// over the whole run, channel by channel: how well the estimate brackets the truth.
fn error_check(
    estimate: &Result<crate::probe::ErrorEstimate, crate::probe::NoEstimate>,
    metrics: &std::collections::BTreeMap<String, compare::ChannelComparison>,
) -> serde_json::Value {
    let estimate = match estimate {
        Ok(e) => e,
        Err(e) => return serde_json::json!({ "error": e.to_string() }),
    };
    let measured: serde_json::Map<String, serde_json::Value> = estimate
        .channels
        .iter()
        .filter_map(|c| {
            let m = metrics.get(&c.name)?;
            Some((c.name.clone(), ((m.rms_reduced - m.rms_full).abs() / m.rms_full).into()))
        })
        .collect();
    let parts: Vec<String> = estimate
        .channels
        .iter()
        .filter_map(|c| {
            let whole = measured.get(&c.name)?.as_f64()?;
            let terms = c
                .coupling_error
                .map_or(String::new(), |k| format!(" ({:.1} + {:.1})", 100.0 * c.rms_level_error, 100.0 * k));
            Some(format!("{} {:.1} %{terms} / {:.1} %", c.name, 100.0 * c.estimated_error, 100.0 * whole))
        })
        .collect();
    let coupling = if estimate.channels.iter().any(|c| c.coupling_error.is_some()) {
        " + one-way against two-way over the run"
    } else {
        ""
    };
    eprintln!(
        "  RMS level error of the reduced model, estimated (the first {:.4} s{coupling}) / measured over the run: {}",
        estimate.window_s,
        parts.join(", ")
    );
    if let Some(w) = estimate.coupling_warning() {
        eprintln!("  warning: {w}");
    }
    serde_json::json!({ "estimate": estimate, "whole_run_rms_level_error": measured })
}

/// The micro step when the user gave none, from the converged full run's impacts (its
/// `summary`; [`crate::probe::choose_micro_step`]), and why when it is not `options.micro_step`.
fn micro_step_for(summary: &lash_run::Summary, s: &AnyScenario, options: ReducedOptions) -> (f64, Option<String>) {
    let joints: Vec<(String, Option<f64>)> =
        summary.clearances.iter().map(|c| (c.name.clone(), c.median_impact_duration)).collect();
    crate::probe::choose_micro_step(options, s.simulation().output_interval, &joints, "over the whole run")
}

/// The written runs of a comparison: their timings, the reduced model's options as it ran, how
/// its micro step and coupling were chosen, and its error estimate.
struct Written {
    /// The reduced model's options, its micro step and coupling as chosen.
    options: ReducedOptions,
    /// Why the macro step is not the default, if it is not (chosen from the fastest rotation).
    macro_step_choice: Option<String>,
    /// Why the micro step is not the one asked for (chosen, then refined), if it is not.
    micro_step_choice: Option<String>,
    /// Why the coupling is two-way under `--coupling auto`, if it is.
    coupling_choice: Option<String>,
    /// The reduced run's error estimate (crate::probe), or why there is none.
    estimate: Result<crate::probe::ErrorEstimate, crate::probe::NoEstimate>,
    full: crate::run::Timing,
    reduced: crate::run::Timing,
    /// The full model by RK4 at the micro step: its timing, or why it did not run.
    fixed: Result<crate::run::Timing, String>,
    /// That scenario.
    fixed_scenario: AnyScenario,
    /// Whether the ideal mechanism's run (the figures' reference) succeeded.
    ideal_ok: bool,
}

/// Runs and writes the models of a comparison into `out`'s `full`, `reduced`, `full-fixed-step`
/// and `ideal`: the converged full model; the reduced model with the micro step chosen from the
/// full model's impacts unless `micro_step_given`, made again at a tenth of the step when it
/// does not hold a pressed contact, and in two-way coupling when `--coupling auto` finds one-way
/// coupling's error past its bound (with the error estimate that decides it); the full model by
/// RK4 at that step; the ideal mechanism.
fn written_runs(
    s: &AnyScenario,
    out: &Path,
    mut request: crate::ReducedRequest,
    quiet: bool,
) -> Result<Written, CliError> {
    let macro_step_choice = request.choose_macro_step(s, quiet);
    let crate::ReducedRequest { mut options, micro_step_given, coupling_auto, .. } = request;
    let refuse = |e: lash_run::RunError| CliError::Input(format!("the reduced model cannot run this scenario: {e}"));
    let csv = crate::output::Format::Csv;
    let settings = (s.simulation(), s.output());
    let (full, full_summary) = crate::run::run(s, settings, &mut full_runner(s, false), &out.join("full"), csv, quiet)?;
    let chooses = !micro_step_given && !options.error_controlled_micro;
    let mut micro_step_choice = None;
    if chooses {
        let (h, why) = micro_step_for(&full_summary, s, options);
        options.micro_step = h;
        if let (Some(why), false) = (&why, quiet) {
            eprintln!("note: {why}");
        }
        micro_step_choice = why;
    }
    let run_reduced = |options: ReducedOptions| {
        let mut runner = lash_run::runner(s, lash_run::Model::Reduced(options)).map_err(refuse)?;
        crate::run::run(s, settings, &mut runner, &out.join("reduced"), csv, quiet)
    };
    let (mut reduced, reduced_summary) = run_reduced(options)?;
    // A pressed contact the chosen step does not hold: again at a tenth of the step (as `lash run`).
    if chooses
        && let Some((finer, why)) =
            lash_run::micro_step_for_unheld_contacts(&reduced_summary, &options, s.simulation().output_interval)
    {
        if !quiet {
            eprintln!("note: {why}");
        }
        options.micro_step = finer;
        reduced = run_reduced(options)?.0;
        micro_step_choice = Some(micro_step_choice.map_or(why.clone(), |first| format!("{first}; then {why}")));
    }
    let probe = crate::probe::FullProbe::run(s, options.macro_step, true).map_err(crate::probe::NoEstimate::from);
    let rerun = |o| run_reduced(o).map(|(timing, _)| reduced = timing);
    let crate::probe::Estimated { options, estimate, coupling_choice } =
        crate::probe::estimate_and_choose_coupling(&probe, options, coupling_auto, quiet, rerun)?;
    // The full model at the reduced model's micro step with RK4 (the reduced-interface-model
    // papers' setting): the speed-up at equal step. It is not converged (impacts last about five
    // such steps), so its results are not compared, only its time; a blow-up is reported, not fatal.
    let mut fixed_scenario = s.clone();
    fixed_scenario.simulation_mut().integrator = lash_ode::Method::Rk4 { step: options.micro_step };
    let problems = fixed_scenario.validate();
    let fixed = if problems.is_empty() {
        let f = &fixed_scenario;
        crate::run::run(
            f,
            (f.simulation(), f.output()),
            &mut full_runner(f, false),
            &out.join("full-fixed-step"),
            csv,
            true,
        )
        .map(|(timing, _)| timing)
        .map_err(|e| e.to_string())
    } else {
        Err(format!("{problems}"))
    };
    // The ideal mechanism (clearance joints closed), drawn as the reference curve of the figures.
    let ideal_ok = crate::run::run(s, settings, &mut full_runner(s, true), &out.join("ideal"), csv, true).is_ok();
    Ok(Written {
        options,
        macro_step_choice,
        micro_step_choice,
        coupling_choice,
        estimate,
        full,
        reduced,
        fixed,
        fixed_scenario,
        ideal_ok,
    })
}

/// The models' simulation alone in rounds ([`crate::steady`]): the reduced model (`reduced`),
/// the converged full model and, when it ran (`with_fixed`), the full model by RK4 at the
/// micro step (`fixed`); their timings in that order, and the rounds.
fn steady_speedups(
    s: &AnyScenario,
    fixed: &AnyScenario,
    with_fixed: bool,
    reduced: crate::steady::Make<'_>,
) -> Result<(Vec<crate::steady::Timed>, usize), CliError> {
    let mut full_make = || -> Result<AnyRunner, lash_run::RunError> { Ok(full_runner(s, false)) };
    let mut fixed_make = || -> Result<AnyRunner, lash_run::RunError> { Ok(full_runner(fixed, false)) };
    let mut makers: Vec<crate::steady::Make<'_>> = vec![reduced, &mut full_make];
    if with_fixed {
        makers.push(&mut fixed_make);
    }
    crate::steady::time(&mut makers).map_err(|e| CliError::Failure(format!("timing the runs: {e}")))
}

/// The speed-up lines: against the converged full model and at equal step (from the rounds),
/// and for the whole written runs.
fn print_speedups(
    rounds: usize,
    (reduced, full, fixed): (crate::steady::Timed, crate::steady::Timed, Option<crate::steady::Timed>),
    (reduced_run, full_run): (&crate::run::Timing, &crate::run::Timing),
    fixed_run: &Result<crate::run::Timing, String>,
    micro_step: f64,
) {
    let plural = if rounds == 1 { "" } else { "s" };
    eprintln!(
        "speed-up against the converged full model, simulation alone ({rounds} round{plural}, models taking turns): {:.4} s vs {:.4} s → {:.1}×",
        full.median_s, reduced.median_s, full.ratio_to_first
    );
    match (fixed_run, fixed) {
        (Ok(_), Some(f)) => eprintln!(
            "  at equal step (the full model by RK4 at {micro_step} s): {:.4} s → {:.1}×; whole runs with the same CSV output (one each): {:.3} s vs {:.3} s → {:.1}×",
            f.median_s,
            f.ratio_to_first,
            full_run.total_s,
            reduced_run.total_s,
            full_run.total_s / reduced_run.total_s
        ),
        (Err(e), _) => eprintln!("  at equal step: the full model by RK4 at {micro_step} s failed ({e})"),
        _ => {}
    }
}

/// Every clearance joint, full against reduced, from the two summaries (which list them in the
/// scenario's order).
fn joint_statistics(sf: &serde_json::Value, sr: &serde_json::Value) -> Vec<serde_json::Value> {
    let clearances: Vec<&str> =
        sf["clearances"].as_array().into_iter().flatten().filter_map(|c| c["name"].as_str()).collect();
    clearances
        .iter()
        .enumerate()
        .map(|(j, joint)| {
            let pick =
                |key: &str| serde_json::json!({"full": sf["clearances"][j][key], "reduced": sr["clearances"][j][key]});
            serde_json::json!({
                "joint": joint,
                "impacts": pick("impacts"),
                "impacts_per_cycle": pick("impacts_per_cycle"),
                "contact_fraction": pick("contact_fraction"),
                "mean_contact_force": pick("mean_contact_force"),
                "max_eccentricity": pick("max_eccentricity"),
                "peak_normal_force": pick("peak_normal_force"),
            })
        })
        .collect()
}

/// One line per compared channel and one per clearance joint.
fn print_channels(
    metrics: &std::collections::BTreeMap<String, compare::ChannelComparison>,
    joint_statistics: &[serde_json::Value],
) {
    for (name, m) in metrics {
        eprintln!(
            "  {name:24} peak full {:.4e} / reduced {:.4e}, relative RMS error of reduced {:.3}, spectral distance {:.3}",
            m.peak_full, m.peak_reduced, m.relative_rms_error, m.spectral_distance
        );
    }
    for c in joint_statistics {
        let both = |key: &str| (c[key]["full"].clone(), c[key]["reduced"].clone());
        let ((fi, ri), (ff, rf)) = (both("impacts"), both("contact_fraction"));
        let fraction = |v: &serde_json::Value| v.as_f64().map_or("-".to_string(), |x| format!("{x:.3}"));
        eprintln!(
            "  {:24} impacts full {fi} / reduced {ri}, contact fraction full {} / reduced {}",
            c["joint"].as_str().unwrap_or(""),
            fraction(&ff),
            fraction(&rf)
        );
    }
}

/// `lash compare`: both models of `s`, written to `out`, compared; the reduced model's micro step
/// chosen from the full run's impacts unless `micro_step_given`.
pub fn run(
    s: &AnyScenario,
    out: &Path,
    request: crate::ReducedRequest,
    realisations: usize,
    quiet: bool,
) -> Result<(), CliError> {
    // Refused settings are said before the full model runs.
    lash_run::runner(s, lash_run::Model::Reduced(request.options))
        .map_err(|e| CliError::Input(format!("the reduced model cannot run this scenario: {e}")))?;
    let (name, mut roles, motion) = compared_roles(s);
    let (full_dir, reduced_dir, ideal_dir) = (out.join("full"), out.join("reduced"), out.join("ideal"));
    let comparison_path = out.join("comparison.json");
    if comparison_path.exists() {
        std::fs::remove_file(&comparison_path)
            .map_err(|e| CliError::Failure(format!("{}: {e}", comparison_path.display())))?;
    }
    let Written {
        options,
        macro_step_choice,
        micro_step_choice,
        coupling_choice,
        estimate,
        full: full_timing,
        reduced: reduced_timing,
        fixed: fixed_timing,
        fixed_scenario,
        ideal_ok,
    } = written_runs(s, out, request, quiet)?;

    // The headline speed-ups: each model's simulation alone, in rounds (crate::steady).
    let mut reduced_make = || lash_run::runner(s, lash_run::Model::Reduced(options));
    let (steady, rounds) = steady_speedups(s, &fixed_scenario, fixed_timing.is_ok(), &mut reduced_make)?;
    let (reduced_steady, full_steady, fixed_steady) = (steady[0], steady[1], steady.get(2).copied());

    let ideal_rows = if ideal_ok { Some(read_csv(&ideal_dir.join("timeseries.csv"))?) } else { None };
    let (hf, full) = read_csv(&full_dir.join("timeseries.csv"))?;
    let (hr, red) = read_csv(&reduced_dir.join("timeseries.csv"))?;
    let (sf, sr) = (read_json(&full_dir.join("summary.json"))?, read_json(&reduced_dir.join("summary.json"))?);
    let channels: Vec<String> = roles.iter().map(|(c, _)| c.clone()).collect();
    let mut metrics = compare::compare_series(&hf, &full, &hr, &red, &channels, FIRST_WINDOW)
        .map_err(|e| CliError::Failure(e.to_string()))?;
    // Channels that are zero to round-off in the full model (a slider's y on an x guide) say nothing.
    metrics.retain(|_, m| m.peak_full > 1e-6);
    roles.retain(|(c, _)| metrics.contains_key(c));
    let bounds = bounds_check(s, motion.as_ref(), (&hf, &full), (&hr, &red), &roles);
    let realisations = match realisations {
        0 | 1 => None,
        n => {
            let window = steady_window(s, motion.as_ref());
            Some(crate::realisations::check(s, n, &bounds, (&hr, &red), &roles, &window)?)
        }
    };
    let series = ((&hf[..], &full[..]), (&hr[..], &red[..]), ideal_rows.as_ref());
    let figures = all_figures(s, out, motion.as_ref(), series, metrics.keys(), ideal_ok)?;
    let speedup = serde_json::json!({
        "simulation_vs_converged_full": full_steady.ratio_to_first,
        "whole_run_equal_recording": full_timing.total_s / reduced_timing.total_s,
        "simulation_at_equal_step": fixed_steady.map(|f| f.ratio_to_first),
    });
    let joint_statistics = joint_statistics(&sf, &sr);
    let report = serde_json::json!({
        "scenario": name,
        "timing": {
            "clock": "wall time, one monotonic clock, runs one after the other in this process",
            "full": full_timing,
            "reduced": reduced_timing,
            "full_rk4_at_micro_step": fixed_timing.as_ref().ok(),
            "full_rk4_at_micro_step_error": fixed_timing.as_ref().err(),
        },
        "speedup": speedup,
        "speedup_note": "simulation_vs_converged_full: simulation alone (rows discarded), the median over rounds in which the models take turns for equal time, the converged full model against the reduced model; whole_run_equal_recording: both written runs, each writing the same channels at the same rate (one run each); simulation_at_equal_step: the full model by RK4 at the micro step (not converged) against the reduced model, simulation alone, likewise",
        "steady_timing": {
            "budget_s": crate::steady::BUDGET_S,
            "rounds": rounds,
            "reduced": reduced_steady,
            "converged_full": full_steady,
            "full_rk4_at_micro_step": fixed_steady,
        },
        "reduced_options": options,
        "macro_step_choice": macro_step_choice,
        "micro_step_choice": micro_step_choice,
        "coupling_choice": coupling_choice,
        "first_window_s": FIRST_WINDOW,
        "band_edges_hz": compare::BANDS.iter().map(|b| [b.0, if b.1.is_finite() { b.1 } else { -1.0 }]).collect::<Vec<_>>(),
        "channels": metrics,
        "error_estimate": error_check(&estimate, &metrics),
        "measurements": {
            "full": sf["measurements"],
            "reduced": sr["measurements"],
            "ideal": if ideal_ok { read_json(&ideal_dir.join("summary.json"))?["measurements"].clone() } else { serde_json::Value::Null },
        },
        "figures": figures,
        "clearances": joint_statistics,
        "bounds": bounds,
        "realisations": realisations,
    });
    let text = serde_json::to_string_pretty(&report).map_err(|e| CliError::Failure(e.to_string()))?;
    std::fs::write(&comparison_path, text + "\n")
        .map_err(|e| CliError::Failure(format!("{}: {e}", comparison_path.display())))?;
    print_speedups(
        rounds,
        (reduced_steady, full_steady, fixed_steady),
        (&reduced_timing, &full_timing),
        &fixed_timing,
        options.micro_step,
    );
    print_channels(&metrics, &joint_statistics);
    print_bounds(&bounds);
    if let Some(r) = &realisations {
        crate::realisations::print(r);
    }
    eprintln!("→ {}", comparison_path.display());
    Ok(())
}

/// The figures (the reduced-interface-model papers' figures 2–3) in `out/figures`: every
/// compared channel (`names`) over time — against crank angle when the first driver turns its
/// body at constant speed — and its spectrum, then each emulated measurement's; their paths.
fn all_figures<'a>(
    s: &AnyScenario,
    out: &Path,
    motion: Option<&lash_mech::Motion>,
    series: Series<'_>,
    names: impl Iterator<Item = &'a String>,
    ideal_ok: bool,
) -> Result<Vec<String>, CliError> {
    let figures_dir = out.join("figures");
    std::fs::create_dir_all(&figures_dir).map_err(|e| CliError::Failure(format!("{}: {e}", figures_dir.display())))?;
    let constant_speed = motion.and_then(|m| match m {
        lash_mech::Motion::ConstantSpeed { angle0, omega } => Some((*angle0, *omega)),
        _ => None,
    });
    let angle_of = constant_speed.map(|(angle0, omega)| move |t: f64| (angle0 + omega * t).to_degrees());
    let crank_angle = angle_of.as_ref().map(|f| f as &dyn Fn(f64) -> f64);
    let mut figures = channel_figures(out, &figures_dir, series, names, crank_angle)?;
    let dirs = [&out.join("full"), &out.join("reduced"), &out.join("ideal")];
    figures.extend(measurement_figures(s, out, &figures_dir, dirs, ideal_ok, crank_angle)?);
    Ok(figures)
}

/// What the comparison looks at, with the checks each gets: every sensor's accelerations, the
/// drivers' torques, the clearance joints' force magnitudes and the forces that drive each
/// emulated measurement; with the scenario's name and its first driver's motion.
fn compared_roles(s: &AnyScenario) -> (String, Vec<(String, compare::Role)>, Option<lash_mech::Motion>) {
    let (name, sensors, drivers, clearances, axes, motion) = match s {
        AnyScenario::Planar(p) => (
            p.name.clone(),
            p.sensors.iter().map(|x| x.name.clone()).collect::<Vec<_>>(),
            p.drivers.iter().map(|d| d.name.clone()).collect::<Vec<_>>(),
            p.clearances.iter().map(|c| c.joint.clone()).collect::<Vec<_>>(),
            &["ax", "ay"][..],
            p.drivers.first().map(|d| d.motion.clone()),
        ),
        AnyScenario::Spatial(p) => (
            p.name.clone(),
            p.sensors.iter().map(|x| x.name.clone()).collect(),
            p.drivers.iter().map(|d| d.name.clone()).collect(),
            p.clearances.iter().map(|c| c.joint.clone()).collect(),
            &["ax", "ay", "az"][..],
            p.drivers.first().map(|d| d.motion.clone()),
        ),
    };
    use compare::Role;
    let mut roles: Vec<(String, Role)> = Vec::new();
    for sensor in &sensors {
        roles.extend(axes.iter().map(|a| (format!("{sensor}.{a}"), Role::Sensor)));
    }
    roles.extend(drivers.iter().map(|d| (format!("{d}.torque"), Role::Load)));
    roles.extend(clearances.iter().map(|c| (format!("{c}.force"), Role::Contact)));
    // The forces that drive each emulated measurement (E's slider bearing force, on the guide).
    for m in &s.output().measurements {
        for f in &m.forces {
            if !roles.iter().any(|(c, _)| c == f) {
                roles.push((f.clone(), Role::Load));
            }
        }
    }
    (name, roles, motion)
}

/// The full and the reduced run's header and rows, and the ideal mechanism's when it ran.
type Series<'a> = ((&'a [String], &'a [Vec<f64>]), (&'a [String], &'a [Vec<f64>]), Option<&'a CsvRows>);

/// A CSV's header and rows ([`read_csv`]).
type CsvRows = (Vec<String>, Vec<Vec<f64>>);

/// The compared channels' figures over time and as spectra, full against reduced with the ideal
/// mechanism as the reference (the reduced-interface-model papers' figures 2–3); their paths
/// relative to `out`.
fn channel_figures<'a>(
    out: &Path,
    figures_dir: &Path,
    ((hf, full), (hr, red), ideal_rows): Series<'_>,
    names: impl Iterator<Item = &'a String>,
    crank_angle: Option<&dyn Fn(f64) -> f64>,
) -> Result<Vec<String>, CliError> {
    let col = |header: &[String], name: &str| header.iter().position(|h| h.starts_with(&format!("{name} [")));
    let mut figures = Vec::new();
    for name in names {
        let (Some(kf), Some(kr)) = (col(hf, name), col(hr, name)) else { continue };
        let unit = hf[kf].rsplit_once('[').map_or("", |(_, u)| u.trim_end_matches(']'));
        let time: Vec<f64> = full.iter().map(|r| r[0]).collect();
        let (yf, yr): (Vec<f64>, Vec<f64>) = full.iter().zip(red.iter()).map(|(a, b)| (a[kf], b[kr])).unzip();
        let yi: Option<Vec<f64>> = ideal_rows.as_ref().and_then(|(hi, rows)| {
            let ki = col(hi, name)?;
            (rows.len() == full.len()).then(|| rows.iter().map(|r| r[ki]).collect())
        });
        let channel = crate::plots::Channel { name, unit, time: &time, full: &yf, reduced: &yr, ideal: yi.as_deref() };
        for path in crate::plots::comparison_figures(figures_dir, &channel, crank_angle, FIGURE_MAX_FREQUENCY)? {
            figures.push(path.strip_prefix(out).unwrap_or(&path).display().to_string());
        }
    }
    Ok(figures)
}

/// Each emulated measurement as logged (the housing accelerometers at the logger's rate, after
/// the anti-alias filter): with clearance (full, reduced) against without (ideal), over time and
/// as spectra up to the logger's Nyquist frequency — the layout of the vibration studies.
fn measurement_figures(
    s: &AnyScenario,
    out: &Path,
    figures_dir: &Path,
    [full_dir, reduced_dir, ideal_dir]: [&std::path::PathBuf; 3],
    ideal_ok: bool,
    crank_angle: Option<&dyn Fn(f64) -> f64>,
) -> Result<Vec<String>, CliError> {
    let mut figures = Vec::new();
    for m in &s.output().measurements {
        let file = format!("measurement_{}.csv", m.name);
        let (hm, fm) = read_csv(&full_dir.join(&file))?;
        let (_, rm) = read_csv(&reduced_dir.join(&file))?;
        let im = if ideal_ok { Some(read_csv(&ideal_dir.join(&file))?.1) } else { None };
        if fm.len() < 2 || rm.len() != fm.len() {
            eprintln!(
                "  measurement {}: {} logged samples (the horizon ends before its steady-state window): no figures",
                m.name,
                fm.len()
            );
            continue;
        }
        let time: Vec<f64> = fm.iter().map(|r| r[0]).collect();
        for (k, header) in hm.iter().enumerate().skip(1) {
            let (name, unit) =
                header.split_once(" [").map_or((header.as_str(), ""), |(n, u)| (n, u.trim_end_matches(']')));
            let column = |rows: &[Vec<f64>]| rows.iter().map(|r| r[k]).collect::<Vec<f64>>();
            let (yf, yr) = (column(&fm), column(&rm));
            let yi = im.as_ref().filter(|rows| rows.len() == fm.len()).map(|rows| column(rows));
            let channel =
                crate::plots::Channel { name, unit, time: &time, full: &yf, reduced: &yr, ideal: yi.as_deref() };
            let nyquist = 0.5 * m.acquisition.sample_rate;
            for path in crate::plots::comparison_figures(figures_dir, &channel, crank_angle, nyquist)? {
                figures.push(path.strip_prefix(out).unwrap_or(&path).display().to_string());
            }
        }
    }
    Ok(figures)
}

/// Upper end of a sensor's band \[Hz\] when the scenario logs no measurement that says it (a
/// general-purpose accelerometer's usable range).
const SENSOR_BAND_HZ: f64 = 10_000.0;

/// The window of steady running and the sensors' band: from an emulated measurement's settling
/// time and anti-alias cut-off where the scenario has one; else past the first revolution of a
/// constant-speed driver (a quarter of the run without one), and [`SENSOR_BAND_HZ`].
fn steady_window(s: &AnyScenario, motion: Option<&lash_mech::Motion>) -> compare::Window {
    let simulation = s.simulation();
    let revolution = motion.and_then(|m| match *m {
        lash_mech::Motion::ConstantSpeed { omega, .. } if omega != 0.0 => {
            Some(2.0 * std::f64::consts::PI / omega.abs())
        }
        _ => None,
    });
    let start = simulation.start_time;
    match s.output().measurements.first() {
        Some(m) => {
            compare::Window { start: start + m.acquisition.settle, revolution, sensor_band_hz: m.acquisition.cutoff }
        }
        None => compare::Window {
            start: start + revolution.unwrap_or(0.25 * simulation.horizon),
            revolution,
            sensor_band_hz: SENSOR_BAND_HZ,
        },
    }
}

/// The stated bounds ([`compare::STATED`]) checked over the window of steady running; in
/// comparison.json as `bounds` (or why they could not be checked).
fn bounds_check(
    s: &AnyScenario,
    motion: Option<&lash_mech::Motion>,
    full: (&[String], &[Vec<f64>]),
    reduced: (&[String], &[Vec<f64>]),
    roles: &[(String, compare::Role)],
) -> serde_json::Value {
    let window = steady_window(s, motion);
    match compare::check_bounds(full, reduced, roles, &window, &compare::STATED) {
        Ok(checks) => serde_json::json!({
            "stated": compare::STATED,
            "window": window,
            "met": checks.iter().all(|c| c.met),
            "checks": checks,
        }),
        Err(e) => serde_json::json!({ "window": window, "error": format!("no window of steady running: {e}") }),
    }
}

/// One line for the bounds, and one per bound not met.
fn print_bounds(bounds: &serde_json::Value) {
    let start = bounds["window"]["start"].as_f64().unwrap_or(0.0);
    let Some(checks) = bounds["checks"].as_array() else {
        eprintln!("  bounds: not checked ({})", bounds["error"].as_str().unwrap_or(""));
        return;
    };
    let missed: Vec<&serde_json::Value> = checks.iter().filter(|c| c["met"] == false).collect();
    eprintln!(
        "  stated bounds over t ≥ {start:.4} s (steady running): {} of {} met",
        checks.len() - missed.len(),
        checks.len()
    );
    for c in missed {
        let (q, e, b) = (c["quantity"].as_str().unwrap_or(""), c["error"].as_f64(), c["bound"].as_f64());
        let (e, b) = (e.unwrap_or(f64::NAN), b.unwrap_or(f64::NAN));
        let (full, reduced) = (c["full"].as_f64().unwrap_or(f64::NAN), c["reduced"].as_f64().unwrap_or(f64::NAN));
        match c["kind"].as_str() {
            Some("onsets") => eprintln!(
                "    not met: {q}: full {full:.2} / reduced {reduced:.2} (bound: within a factor {b}, or one impact)"
            ),
            Some("ratio") => eprintln!("    not met: {q}: reduced/full {e:.2}× (bound: within a factor {b})"),
            _ => eprintln!("    not met: {q}: {:+.1} % (bound ±{:.0} %)", 100.0 * e, 100.0 * b),
        }
    }
}
