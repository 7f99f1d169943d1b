//! An error estimate for a reduced run: the converged full model and the reduced model run from
//! the same start over a probe window (the first quarter of the run, at least 20 macro steps),
//! compared on the run's main channels — the sensors' accelerations, each clearance joint's
//! contact force and the driver torques. What it measures is the reduced model's distance from the
//! converged full model over that window (method and step error together); a run that changes
//! character after the window (a transient that dies, a joint that starts to rattle later) can
//! be farther off than its probe says (docs/validation.md §6 shows how it compares with the
//! whole-run error on the built-ins).

use lash_scenario::AnyScenario;
use serde::Serialize;

/// One channel's distance between the two models over the probe window.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelError {
    /// Channel name.
    pub name: String,
    /// |RMS(reduced) − RMS(full)| / RMS(full): how far the level is off.
    pub rms_level_error: f64,
    /// Relative distance of the two amplitude spectra (lash-metrics' spectral distance).
    pub spectral_distance: f64,
}

/// The error estimate of a reduced run.
#[derive(Debug, Clone, Serialize)]
pub struct ErrorEstimate {
    /// Length of the probe window from the start \[s\].
    pub window_s: f64,
    /// Per main channel (channels at round-off in the full model are left out).
    pub channels: Vec<ChannelError>,
    /// Wall time of the probe (both models) \[s\].
    pub wall_s: f64,
}

impl ErrorEstimate {
    /// The largest RMS level error over the channels (0 without any).
    pub fn worst_rms_level_error(&self) -> f64 {
        self.channels.iter().map(|c| c.rms_level_error).fold(0.0, f64::max)
    }

    /// One line for the terminal.
    pub fn line(&self) -> String {
        let parts: Vec<String> =
            self.channels.iter().map(|c| format!("{} {:.1} %", c.name, 100.0 * c.rms_level_error)).collect();
        format!(
            "error estimate (reduced against the converged full model over the first {:.4} s, RMS level): {}",
            self.window_s,
            parts.join(", ")
        )
    }
}

/// The probe window of a run of `horizon` with macro step `macro_step` \[s\]: a quarter of the
/// run, at least 20 macro steps, in whole macro steps, at most the run.
pub fn window(horizon: f64, macro_step: f64) -> f64 {
    let steps = ((0.25 * horizon).max(20.0 * macro_step) / macro_step).ceil();
    (steps * macro_step).min(horizon)
}

/// The main channels of a scenario: sensor accelerations, contact force magnitudes, driver torques.
pub fn main_channels(scenario: &AnyScenario) -> Vec<String> {
    let joints: Vec<String> = scenario.clearances().iter().map(|c| format!("{}.force", c.joint)).collect();
    scenario
        .channels(false)
        .into_iter()
        .map(|c| c.name)
        .filter(|n| n.ends_with(".ax") || n.ends_with(".ay") || n.ends_with(".az") || n.ends_with(".torque"))
        .chain(joints)
        .collect()
}

/// Runs `model` of `scenario` and keeps its rows.
fn rows(scenario: &AnyScenario, model: lash_run::Model) -> Result<(Vec<String>, Vec<Vec<f64>>), String> {
    let mut runner = lash_run::runner(scenario, model)?;
    let header = runner.header();
    let mut rows = Vec::new();
    runner
        .execute(
            &mut |row: &[f64]| {
                rows.push(row.to_vec());
                Ok(())
            },
            &mut |_| {},
        )
        .map_err(|e| e.to_string())?;
    Ok((header, rows))
}

/// The error estimate of the reduced model of `scenario` with `options` (its horizon the run's).
pub fn estimate(scenario: &AnyScenario, options: lash_run::ReducedOptions) -> Result<ErrorEstimate, String> {
    let clock = std::time::Instant::now();
    let mut s = scenario.clone();
    let window_s = window(s.simulation().horizon, options.macro_step);
    s.simulation_mut().horizon = window_s;
    let channels = main_channels(&s);
    s.output_mut().channels = channels.clone();
    s.output_mut().measurements.clear();
    let (header_full, full) = rows(&s, lash_run::Model::Full { ideal: false })?;
    let reduced_options = lash_run::ReducedOptions { channels_only: true, ..options };
    let (header_reduced, reduced) = rows(&s, lash_run::Model::Reduced(reduced_options))?;
    let n = full.len().min(reduced.len());
    let compared =
        lash_metrics::compare_series(&header_full, &full[..n], &header_reduced, &reduced[..n], &channels, 0.0)?;
    // A channel at round-off in the full model (a guided slider's transverse acceleration, ~1e-15
    // of its axial one) has no level to be off from.
    let largest = |unit: &str| compared.values().filter(|c| c.unit == unit).map(|c| c.rms_full).fold(0.0, f64::max);
    let channels = channels
        .iter()
        .filter_map(|name| {
            let c = compared.get(name)?;
            (c.rms_full > 1e-9 * largest(&c.unit)).then(|| ChannelError {
                name: name.clone(),
                rms_level_error: (c.rms_reduced - c.rms_full).abs() / c.rms_full,
                spectral_distance: c.spectral_distance,
            })
        })
        .collect();
    Ok(ErrorEstimate { window_s, channels, wall_s: clock.elapsed().as_secs_f64() })
}

/// Adds the error estimate of a reduced run (written into `out`) to its summary.json and prints
/// it. A probe that fails (the full model over the window) is recorded as such: the run stands.
pub fn attach(
    scenario: &AnyScenario,
    options: lash_run::ReducedOptions,
    out: &std::path::Path,
    quiet: bool,
) -> Result<(), crate::CliError> {
    let fail = |e: String| crate::CliError::Failure(e);
    let value = match estimate(scenario, options) {
        Ok(e) => {
            if !quiet {
                eprintln!("{}", e.line());
            }
            serde_json::to_value(&e).map_err(|e| fail(e.to_string()))?
        }
        Err(e) => {
            eprintln!("warning: no error estimate for this run: {e}");
            serde_json::json!({ "error": e })
        }
    };
    let path = out.join("summary.json");
    let text = std::fs::read_to_string(&path).map_err(|e| fail(format!("{}: {e}", path.display())))?;
    let mut summary: serde_json::Value = serde_json::from_str(&text).map_err(|e| fail(e.to_string()))?;
    if let Some(map) = summary.as_object_mut() {
        map.insert("error_estimate".into(), value);
    }
    let text = serde_json::to_string_pretty(&summary).map_err(|e| fail(e.to_string()))? + "\n";
    lash_sweep::dataset::write_atomic(&path, text.as_bytes()).map_err(fail)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_window_is_a_quarter_of_the_run_in_whole_macro_steps() {
        assert!((window(0.036, 1e-3) - 0.02).abs() < 1e-12, "20 macro steps at least");
        assert!((window(1.0, 1e-3) - 0.25).abs() < 1e-12);
        assert!((window(0.01, 1e-3) - 0.01).abs() < 1e-12, "at most the run");
    }

    #[test]
    fn main_channels_are_accelerations_contact_forces_and_torques() {
        let a = AnyScenario::Planar(lash_scenario::builtin::by_name("A").unwrap());
        let names = main_channels(&a);
        assert_eq!(names, ["slider.ax", "slider.ay", "motor.torque", "crank_pivot.force"]);
    }
}
