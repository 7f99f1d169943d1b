//! An error estimate for a reduced run, in two terms on the run's main channels (the sensors'
//! accelerations, each clearance joint's contact force and the driver torques):
//! - the window term: the converged full model and the reduced model run from the same start over
//!   a probe window (the first quarter of the run, at least 20 macro steps), compared by their
//!   RMS levels — method and step error together, as far as the window shows them;
//! - the coupling term (one-way runs): the one-way and the two-way reduced model over the whole
//!   run, compared likewise — what taking the ideal mechanism's motion for the real one costs,
//!   over the part of the run the window does not see (a joint that settles into a different
//!   regime later, as B's rod–slider pin does);
//! - the step term (two-way runs): the two-way run and the same at half the macro step over the
//!   whole run, extrapolated (Richardson) to the run's own step error: the coupling converges at
//!   first order in the macro step (measured, docs/validation.md §6), so the run is twice the
//!   difference away from its limit. For a rattling pin the difference is also the spread between
//!   realisations of a chaotic motion.
//!
//! The estimate is their sum (the triangle inequality, with the window term standing for the
//! two-way model's own distance from the full model); docs/validation.md §6 shows how it compares
//! with the whole-run error on the built-ins.

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
    /// |RMS(one-way) − RMS(two-way)| / RMS(two-way) over the whole run (none for a two-way run,
    /// or when the two-way run failed).
    pub coupling_error: Option<f64>,
    /// For a two-way run, 2 |RMS(h_m) − RMS(h_m / 2)| / RMS(h_m / 2) over the whole run: the run
    /// against itself at half the macro step, extrapolated at first order to its own step error
    /// (none for a one-way run, or when the run failed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub step_error: Option<f64>,
    /// The estimate: `rms_level_error` + `coupling_error` (one-way) or + `step_error` (two-way).
    pub estimated_error: f64,
}

/// The error estimate of a reduced run.
#[derive(Debug, Clone, Serialize)]
pub struct ErrorEstimate {
    /// Length of the probe window from the start \[s\].
    pub window_s: f64,
    /// Per main channel (channels at round-off in the full model are left out).
    pub channels: Vec<ChannelError>,
    /// Why there is no coupling term, when a one-way run has none (the two-way run failed), or
    /// no step term, when a two-way run has none (the run at half the macro step failed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coupling_error_missing: Option<String>,
    /// Wall time of the estimate (every model it ran) \[s\].
    pub wall_s: f64,
}

impl ErrorEstimate {
    /// The largest RMS level error over the channels (0 without any).
    pub fn worst_rms_level_error(&self) -> f64 {
        self.channels.iter().map(|c| c.rms_level_error).fold(0.0, f64::max)
    }

    /// The main channel whose RMS level one-way coupling moves most over the run against two-way
    /// coupling, and by how much, when that is past the stated RMS bound ([`lash_metrics::STATED`]).
    fn coupling_past_bound(&self) -> Option<(&str, f64)> {
        let (name, k) = self
            .channels
            .iter()
            .filter_map(|c| Some((c.name.as_str(), c.coupling_error?)))
            .max_by(|a, b| a.1.total_cmp(&b.1))?;
        (k > lash_metrics::STATED.rms).then_some((name, k))
    }

    /// A warning when one-way coupling alone moves a main channel's RMS level over the run by
    /// more than the stated RMS bound ([`lash_metrics::STATED`]): the two couplings part, which
    /// no finer step mends.
    pub fn coupling_warning(&self) -> Option<String> {
        self.coupling_past_bound().map(|(name, k)| {
            format!(
                "one-way coupling moves {name}'s RMS level by {:.1} % over the run against two-way coupling (the stated \
                 bound is {:.0} %): the mechanism's motion departs from the ideal one that one-way coupling takes, and \
                 finer steps do not mend it; the estimate carries the difference, and --coupling auto takes the \
                 coupling closer to the converged full model over the probe window (a guide stays one-way)",
                100.0 * k,
                100.0 * lash_metrics::STATED.rms
            )
        })
    }

    /// The channel with the largest RMS level error.
    pub fn worst_channel(&self) -> Option<String> {
        self.channels.iter().max_by(|a, b| a.rms_level_error.total_cmp(&b.rms_level_error)).map(|c| c.name.clone())
    }

    /// One line for the terminal.
    pub fn line(&self) -> String {
        let parts: Vec<String> = self
            .channels
            .iter()
            .map(|c| match c.coupling_error.or(c.step_error) {
                Some(k) => format!(
                    "{} {:.1} % ({:.1} % + {:.1} %)",
                    c.name,
                    100.0 * c.estimated_error,
                    100.0 * c.rms_level_error,
                    100.0 * k
                ),
                None => format!("{} {:.1} %", c.name, 100.0 * c.estimated_error),
            })
            .collect();
        let terms = if self.channels.iter().any(|c| c.coupling_error.is_some()) {
            format!(
                "against the converged full model over the first {:.4} s + one-way against two-way coupling over the run",
                self.window_s
            )
        } else if self.channels.iter().any(|c| c.step_error.is_some()) {
            format!(
                "against the converged full model over the first {:.4} s + the run against itself at half the macro step",
                self.window_s
            )
        } else {
            format!("against the converged full model over the first {:.4} s", self.window_s)
        };
        let missing = self.coupling_error_missing.as_ref().map_or(String::new(), |m| format!(" (no second term: {m})"));
        format!("error estimate of the RMS levels ({terms}): {}{missing}", parts.join(", "))
    }
}

/// The probe window of a run of `horizon` with macro step `macro_step` \[s\]: a quarter of the
/// run, at least 20 macro steps, in whole macro steps, at most the run.
pub fn window(horizon: f64, macro_step: f64) -> f64 {
    let steps = ((0.25 * horizon).max(20.0 * macro_step) / macro_step).ceil();
    (steps * macro_step).min(horizon)
}

/// The window the micro step is chosen over when no error estimate is asked for: the impacts
/// of the first [`CHOICE_WINDOW_S`] (at least 20 macro steps, at most [`window`]), so that a
/// long run does not pay a quarter of itself in the full model for its step.
pub fn choice_window(horizon: f64, macro_step: f64) -> f64 {
    let steps = (CHOICE_WINDOW_S.max(20.0 * macro_step) / macro_step).ceil();
    (steps * macro_step).min(window(horizon, macro_step))
}

/// See [`choice_window`] \[s\]: four revolutions at 5000 rpm.
pub const CHOICE_WINDOW_S: f64 = 0.05;

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

/// Why a probe or an error estimate could not be made.
#[derive(Debug, thiserror::Error)]
pub enum ProbeError {
    /// A run (the full model's probe, or the reduced run compared with it) failed.
    #[error(transparent)]
    Run(#[from] lash_run::RunError),
    /// The two runs could not be compared.
    #[error(transparent)]
    Compare(#[from] lash_metrics::CompareError),
}

/// Why a run has no error estimate: its probe or its estimate failed. Shared (a clone is a
/// pointer): one probe's failure is the reason of every estimate made against it.
#[derive(Debug, Clone, thiserror::Error)]
#[error(transparent)]
pub struct NoEstimate(std::sync::Arc<ProbeError>);

impl From<ProbeError> for NoEstimate {
    fn from(e: ProbeError) -> Self {
        Self(std::sync::Arc::new(e))
    }
}

/// Runs `model` of `scenario` and keeps its rows and summary.
fn rows(scenario: &AnyScenario, model: lash_run::Model) -> Result<Rows, ProbeError> {
    let mut runner = lash_run::runner(scenario, model)?;
    let header = runner.header();
    let mut rows = Vec::new();
    let summary = runner.execute(
        &mut |row: &[f64]| {
            rows.push(row.to_vec());
            Ok(())
        },
        &mut |_| {},
    )?;
    Ok(Rows { header, rows, summary })
}

/// A run's header, rows and summary.
struct Rows {
    header: Vec<String>,
    rows: Vec<Vec<f64>>,
    summary: lash_run::Summary,
}

/// The converged full model over a reduced run's probe window: the reference of the error
/// estimate, and the impacts the micro step is chosen for.
pub struct FullProbe {
    /// The probe's scenario: the run's, over the window, recording the main channels.
    scenario: AnyScenario,
    window_s: f64,
    /// The run's horizon \[s\] (the probe's scenario is cut to the window).
    horizon: f64,
    full: Rows,
    wall_s: f64,
}

impl FullProbe {
    /// Runs the converged full model of `scenario` over the probe window of a reduced run with
    /// macro step `macro_step`: [`window`] for an error estimate, [`choice_window`] for the
    /// micro step alone (`estimate` false).
    pub fn run(scenario: &AnyScenario, macro_step: f64, estimate: bool) -> Result<Self, ProbeError> {
        let clock = std::time::Instant::now();
        let mut s = scenario.clone();
        let horizon = s.simulation().horizon;
        let window_s = if estimate { window(horizon, macro_step) } else { choice_window(horizon, macro_step) };
        s.simulation_mut().horizon = window_s;
        s.output_mut().channels = main_channels(&s);
        s.output_mut().measurements.clear();
        let full = rows(&s, lash_run::Model::Full { ideal: false })?;
        Ok(Self { scenario: s, window_s, horizon, full, wall_s: clock.elapsed().as_secs_f64() })
    }

    /// The micro step for `options` when the user gave none ([`choose_micro_step`] for the
    /// probe's impacts), and why when it is not `options.micro_step`.
    pub fn micro_step(&self, options: lash_run::ReducedOptions) -> (f64, Option<String>) {
        let joints: Vec<(String, Option<f64>)> =
            self.full.summary.clearances.iter().map(|c| (c.name.clone(), c.median_impact_duration)).collect();
        let over = format!("over the first {} s", self.window_s);
        choose_micro_step(options, self.scenario.simulation().output_interval, &joints, &over)
    }

    /// The error estimate of the reduced model with `options` against this probe.
    pub fn estimate(&self, options: lash_run::ReducedOptions) -> Result<ErrorEstimate, ProbeError> {
        let clock = std::time::Instant::now();
        let channels = main_channels(&self.scenario);
        let reduced_options = lash_run::ReducedOptions { channels_only: true, ..options };
        let reduced = rows(&self.scenario, lash_run::Model::Reduced(reduced_options))?;
        let (full, n) = (&self.full, self.full.rows.len().min(reduced.rows.len()));
        let compared = lash_metrics::compare_series(
            &full.header,
            &full.rows[..n],
            &reduced.header,
            &reduced.rows[..n],
            &channels,
            0.0,
        )?;
        // A channel at round-off in the full model (a guided slider's transverse acceleration, ~1e-15
        // of its axial one) has no level to be off from.
        let largest = |unit: &str| compared.values().filter(|c| c.unit == unit).map(|c| c.rms_full).fold(0.0, f64::max);
        let channels = channels
            .iter()
            .filter_map(|name| {
                let c = compared.get(name)?;
                let rms_level_error = (c.rms_reduced - c.rms_full).abs() / c.rms_full;
                (c.rms_full > 1e-9 * largest(&c.unit)).then(|| ChannelError {
                    name: name.clone(),
                    rms_level_error,
                    spectral_distance: c.spectral_distance,
                    coupling_error: None,
                    step_error: None,
                    estimated_error: rms_level_error,
                })
            })
            .collect();
        let wall_s = self.wall_s + clock.elapsed().as_secs_f64();
        Ok(ErrorEstimate { window_s: self.window_s, channels, coupling_error_missing: None, wall_s })
    }

    /// The error estimate of a whole reduced run with `options`: [`FullProbe::estimate`]'s window
    /// term, plus over the whole run the coupling term for a one-way run or the step term for a
    /// two-way one (the second run's simulated fraction to `progress`: it is the long part).
    pub fn estimate_run(
        &self,
        options: lash_run::ReducedOptions,
        progress: &mut dyn FnMut(f64),
    ) -> Result<ErrorEstimate, ProbeError> {
        let clock = std::time::Instant::now();
        let mut e = self.estimate(options)?;
        let mut whole = self.scenario.clone();
        whole.simulation_mut().horizon = self.horizon;
        let names: Vec<String> = e.channels.iter().map(|c| c.name.clone()).collect();
        let run = |o: lash_run::ReducedOptions, progress: &mut dyn FnMut(f64)| {
            let o = lash_run::ReducedOptions { channels_only: true, ..o };
            whole_run_rms(&whole, lash_run::Model::Reduced(o), &names, progress)
        };
        let one_way = options.coupling == lash_core::Coupling::OneWay;
        // The run itself, and the one it is measured against: two-way, or itself at half the
        // macro step (and half the micro step where the halved macro step would not hold a whole
        // number of them).
        let other = if one_way {
            lash_run::ReducedOptions { coupling: lash_core::Coupling::TwoWay, ..options }
        } else {
            let macro_step = options.macro_step / 2.0;
            let ticks = |s: f64| lash_core::Ticks::from_seconds(s).ok();
            let whole_steps = ticks(macro_step)
                .zip(ticks(options.micro_step))
                .is_some_and(|(m, r)| lash_orchestrate::check_step_ratio(m, r).is_ok());
            let micro_step = if whole_steps { options.micro_step } else { options.micro_step / 2.0 };
            lash_run::ReducedOptions { macro_step, micro_step, ..options }
        };
        let own = run(options, &mut |_| {})?;
        match run(other, progress) {
            Ok(reference) => {
                // (The coupling converges at first order in the macro step: a run is twice its
                // distance from the run at half the step away from the limit.)
                let extrapolation = if one_way { 1.0 } else { 2.0 };
                for ((c, a), b) in e.channels.iter_mut().zip(own).zip(reference) {
                    let k = if b > 0.0 { extrapolation * (a - b).abs() / b } else { 0.0 };
                    if one_way {
                        c.coupling_error = Some(k);
                    } else {
                        c.step_error = Some(k);
                    }
                    c.estimated_error = c.rms_level_error + k;
                }
            }
            Err(why) if one_way => e.coupling_error_missing = Some(format!("the two-way run failed: {why}")),
            Err(why) => e.coupling_error_missing = Some(format!("the run at half the macro step failed: {why}")),
        }
        e.wall_s += clock.elapsed().as_secs_f64();
        Ok(e)
    }
}

/// The RMS of each of `channels` over a whole run of `model` of `scenario`, its rows streamed
/// into the sums (not kept: a long run's rows need not fit in memory); its progress to `progress`.
fn whole_run_rms(
    scenario: &AnyScenario,
    model: lash_run::Model,
    channels: &[String],
    progress: &mut dyn FnMut(f64),
) -> Result<Vec<f64>, ProbeError> {
    let mut runner = lash_run::runner(scenario, model)?;
    let header = runner.header();
    let columns: Vec<usize> = channels
        .iter()
        .map(|c| header.iter().position(|h| h.starts_with(&format!("{c} ["))))
        .collect::<Option<_>>()
        .ok_or_else(|| lash_metrics::CompareError::MissingChannel(channels.join(", ")))?;
    let (mut squares, mut rows) = (vec![0.0; channels.len()], 0usize);
    runner.execute(
        &mut |row: &[f64]| {
            rows += 1;
            for (sum, &k) in squares.iter_mut().zip(&columns) {
                *sum += row[k] * row[k];
            }
            Ok(())
        },
        progress,
    )?;
    Ok(squares.iter().map(|sum| (sum / rows.max(1) as f64).sqrt()).collect())
}

/// One setting `--tolerance` tried over the probe window.
#[derive(Debug, Clone, Serialize)]
pub struct Tried {
    /// Macro step \[s\].
    pub macro_step: f64,
    /// Micro step \[s\].
    pub micro_step: f64,
    /// The largest RMS level error over the main channels.
    pub worst_rms_level_error: f64,
    /// The channel it is on.
    pub worst_channel: String,
}

/// What `--tolerance` found: the settings the search stepped through, in order (each one
/// finer than the one before and with a smaller error), and whether the last, the one the run
/// takes, meets the tolerance over the probe window.
#[derive(Debug, Clone, Serialize)]
pub struct ToleranceSearch {
    /// The tolerance asked for: the largest RMS level error over the main channels.
    pub tolerance: f64,
    /// Whether the setting taken meets it.
    pub met: bool,
    /// The settings stepped through; the run takes the last (the smallest error).
    pub tried: Vec<Tried>,
}

impl ToleranceSearch {
    /// One line for the terminal.
    pub fn line(&self) -> String {
        let best = self.best();
        let setting = format!("macro step {:e} s, micro step {:e} s", best.macro_step, best.micro_step);
        if self.met {
            format!(
                "tolerance {:.1} %: met at {setting} (worst RMS level error over the window {:.1} %, {}; {} settings tried)",
                100.0 * self.tolerance,
                100.0 * best.worst_rms_level_error,
                best.worst_channel,
                self.tried.len()
            )
        } else {
            format!(
                "tolerance {:.1} %: not met — closest {:.1} % ({}) at {setting}; finer steps stopped improving, so the rest \
                 is the interface model's own error (one-way coupling, the ideal macro motion), not the steps'",
                100.0 * self.tolerance,
                100.0 * best.worst_rms_level_error,
                best.worst_channel
            )
        }
    }

    fn best(&self) -> &Tried {
        self.tried
            .iter()
            .min_by(|a, b| a.worst_rms_level_error.total_cmp(&b.worst_rms_level_error))
            .expect("at least one setting tried")
    }
}

impl FullProbe {
    /// The settings that meet `tolerance` (the largest RMS level error over the main channels,
    /// against the converged full model over the probe window), from `options` on: while the
    /// error is above it, the finer of a halved macro step and the next micro step down the
    /// ladder ([`lash_run::micro_step_ladder`]) that lowers it most, until it is met, neither
    /// lowers it, or `budget` settings are tried. Returns the setting with the smallest error.
    pub fn meet_tolerance(
        &self,
        options: lash_run::ReducedOptions,
        tolerance: f64,
        budget: usize,
    ) -> Result<(lash_run::ReducedOptions, ToleranceSearch), ProbeError> {
        let output_interval = self.scenario.simulation().output_interval;
        let tried_as = |o: lash_run::ReducedOptions, e: &ErrorEstimate| Tried {
            macro_step: o.macro_step,
            micro_step: o.micro_step,
            worst_rms_level_error: e.worst_rms_level_error(),
            worst_channel: e.worst_channel().unwrap_or_default(),
        };
        let mut current = options;
        let mut search =
            ToleranceSearch { tolerance, met: false, tried: vec![tried_as(current, &self.estimate(current)?)] };
        while search.tried.len() < budget {
            let worst = search.tried.last().expect("one").worst_rms_level_error;
            if worst <= tolerance {
                search.met = true;
                break;
            }
            let finer_micro =
                lash_run::micro_step_ladder(current.micro_step, current.macro_step, output_interval).get(1).copied();
            let candidates = [
                Some(lash_run::ReducedOptions { macro_step: current.macro_step / 2.0, ..current }),
                finer_micro.map(|h| lash_run::ReducedOptions { micro_step: h, ..current }),
            ];
            // A setting the run refuses (a step that does not divide the horizon) is no candidate.
            let best = candidates
                .into_iter()
                .flatten()
                .filter_map(|o| self.estimate(o).ok().map(|e| (o, e)))
                .min_by(|a, b| a.1.worst_rms_level_error().total_cmp(&b.1.worst_rms_level_error()));
            match best {
                Some((o, e)) if e.worst_rms_level_error() < worst => {
                    search.tried.push(tried_as(o, &e));
                    current = o;
                }
                _ => break,
            }
        }
        let best = search.best().clone();
        search.met = best.worst_rms_level_error <= tolerance;
        let chosen = lash_run::ReducedOptions { macro_step: best.macro_step, micro_step: best.micro_step, ..options };
        Ok((chosen, search))
    }
}

/// The micro step for `options` when the user gave none: [`lash_run::resolving_micro_step`]
/// from `options.micro_step` down, for the impacts of a converged full run (`joints`: each
/// clearance joint's name and median impact duration; `over`: the part of the run they come
/// from), and why when it is not `options.micro_step`.
pub fn choose_micro_step(
    options: lash_run::ReducedOptions,
    output_interval: f64,
    joints: &[(String, Option<f64>)],
    over: &str,
) -> (f64, Option<String>) {
    let (largest, macro_step) = (options.micro_step, options.macro_step);
    let h = lash_run::resolving_micro_step(largest, macro_step, output_interval, joints.iter().map(|j| j.1));
    let shortest = joints.iter().filter_map(|(n, d)| Some((d.as_ref()?, n))).min_by(|a, b| a.0.total_cmp(b.0));
    let why = shortest.filter(|_| h != largest).map(|(d, name)| {
        format!(
            "micro step {h:e} s, chosen for clearance joint {name}: its impacts last a median of {d:.2e} s in the \
             converged full model {over} ({:.1} steps of {largest:e} s; a contact needs about {} to be resolved); \
             --micro-step sets it",
            d / largest,
            lash_run::run::STEPS_PER_CONTACT
        )
    });
    (h, why)
}

/// Writes an error estimate, or why there is none, into a run's summary (as JSON) as
/// `error_estimate`, and the estimate's coupling warning into its `warnings`: what `lash run`
/// and Python's `lash.run` both record.
pub fn record(summary: &mut serde_json::Map<String, serde_json::Value>, estimated: &Result<ErrorEstimate, NoEstimate>) {
    let value = match estimated {
        Ok(e) => serde_json::to_value(e).unwrap_or_else(|e| serde_json::json!({ "error": e.to_string() })),
        Err(e) => serde_json::json!({ "error": e.to_string() }),
    };
    summary.insert("error_estimate".into(), value);
    let warning = estimated.as_ref().ok().and_then(ErrorEstimate::coupling_warning);
    if let (Some(w), Some(serde_json::Value::Array(warnings))) = (warning, summary.get_mut("warnings")) {
        warnings.push(w.into());
    }
}

/// The error estimate of a reduced run with `options` against `probe` ([`FullProbe::estimate_run`],
/// with a bar of its two-way run that shows after a second unless `quiet`), or why there is none.
pub fn estimate_against(
    probe: &Result<FullProbe, NoEstimate>,
    options: lash_run::ReducedOptions,
    quiet: bool,
) -> Result<ErrorEstimate, NoEstimate> {
    let probe = probe.as_ref().map_err(Clone::clone)?;
    let mut bar = crate::run::DelayedBar::new("simulated (the error estimate's second run)", quiet);
    let estimate = probe.estimate_run(options, &mut |f| bar.update(f));
    bar.finish();
    Ok(estimate?)
}

/// A written reduced run's options, error estimate and coupling choice
/// ([`estimate_and_choose_coupling`]).
#[derive(Debug, Clone)]
pub struct Estimated {
    /// The options the written run has.
    pub options: lash_run::ReducedOptions,
    /// Its error estimate, or why there is none.
    pub estimate: Result<ErrorEstimate, NoEstimate>,
    /// Why its coupling is not the one asked for, when it is not.
    pub coupling_choice: Option<String>,
}

/// A written reduced run's error estimate and, under `--coupling auto` (`auto`), its coupling.
/// The estimate of the run made with `options` (one-way) against `probe`; when its coupling term
/// is past the stated bound the two couplings part, and the choice goes to the one closer to the
/// converged full model over the probe window (the worst RMS level error over the main
/// channels): when that is two-way, `rerun` makes the run again with the two-way options and the
/// estimate is that run's. Which coupling is right is not known beforehand — B's two-way run
/// keeps rattling where the full model settles, F's one-way run stops where it rattles on
/// (docs/validation.md §6) — so the full model decides. Returns the options the written run
/// has, its estimate, and the choice with its figures ([`Estimated`]).
pub fn estimate_and_choose_coupling<E>(
    probe: &Result<FullProbe, NoEstimate>,
    options: lash_run::ReducedOptions,
    auto: bool,
    quiet: bool,
    rerun: impl FnOnce(lash_run::ReducedOptions) -> Result<(), E>,
) -> Result<Estimated, E> {
    let estimate = estimate_against(probe, options, quiet);
    let past = match &estimate {
        Ok(e) if auto => e.coupling_past_bound().map(|(name, k)| (name.to_string(), k, e.worst_rms_level_error())),
        _ => None,
    };
    let Some((name, k, one_way_worst)) = past else {
        return Ok(Estimated { options, estimate, coupling_choice: None });
    };
    let bound = 100.0 * lash_metrics::STATED.rms;
    let moved = format!(
        "in one-way coupling {name}'s RMS level over the run moved by {:.1} % against two-way coupling, past the stated \
         bound of {bound:.0} %",
        100.0 * k
    );
    if let Ok(p) = probe
        && let AnyScenario::Planar(s) = &p.scenario
        && let Some(g) = s.guides.first()
    {
        let why = format!(
            "one-way coupling, kept (--coupling auto): {moved}, but guide {:?} stays one-way: two-way coupling \
             prescribes the block's tilt and offset as a cubic over each macro step, which does not follow its \
             corners' impacts (scenario G: a third off the lateral acceleration at the default macro step, within 1 % \
             at 1e-4 s); --coupling two-way runs it two-way",
            g.joint
        );
        return Ok(Estimated { options, estimate, coupling_choice: Some(why) });
    }
    let two_way = lash_run::ReducedOptions {
        coupling: lash_core::Coupling::TwoWay,
        execution: lash_orchestrate::Execution::Sequential,
        ..options
    };
    // The decision reads the two-way window term alone; the step term over the whole run is
    // made only for a run that turns two-way.
    let two_way_window = probe.as_ref().map_err(Clone::clone).and_then(|p| Ok(p.estimate(two_way)?));
    let (closer, against) = match &two_way_window {
        Ok(t) => (
            t.worst_rms_level_error() < one_way_worst,
            format!(
                "over the first {} s the worst RMS level error against the converged full model is {:.1} % one-way, \
                 {:.1} % two-way",
                t.window_s,
                100.0 * one_way_worst,
                100.0 * t.worst_rms_level_error()
            ),
        ),
        Err(why) => (false, format!("the two-way run over the probe window failed ({why})")),
    };
    if !closer {
        let why = format!(
            "one-way coupling, kept (--coupling auto): {moved}, but {against}; --coupling two-way runs it two-way"
        );
        return Ok(Estimated { options, estimate, coupling_choice: Some(why) });
    }
    let why = format!(
        "two-way coupling, chosen (--coupling auto): {moved}, and {against}; --coupling one-way keeps the one-way run"
    );
    if !quiet {
        eprintln!("note: {why}");
    }
    rerun(two_way)?;
    let estimate = estimate_against(probe, two_way, quiet);
    Ok(Estimated { options: two_way, estimate, coupling_choice: Some(why) })
}

/// Adds to a reduced run's summary.json (written into `out`) its error estimate (`estimated`;
/// none when not asked for), the estimate's coupling warning
/// ([`ErrorEstimate::coupling_warning`]) to its warnings, and `notes` (how its steps and coupling
/// were chosen); prints the estimate. An estimate that failed is recorded as such: the run stands.
pub fn attach(
    estimated: Option<Result<ErrorEstimate, NoEstimate>>,
    notes: serde_json::Map<String, serde_json::Value>,
    out: &std::path::Path,
    quiet: bool,
) -> Result<(), crate::CliError> {
    let fail = |e: String| crate::CliError::Failure(e);
    match &estimated {
        Some(Ok(e)) => {
            if !quiet {
                eprintln!("{}", e.line());
            }
            if let Some(w) = e.coupling_warning() {
                eprintln!("warning: {w}");
            }
        }
        Some(Err(e)) => eprintln!("warning: no error estimate for this run: {e}"),
        None => {}
    }
    let path = out.join("summary.json");
    let text = std::fs::read_to_string(&path).map_err(|e| fail(format!("{}: {e}", path.display())))?;
    let mut summary: serde_json::Value = serde_json::from_str(&text).map_err(|e| fail(e.to_string()))?;
    if let Some(map) = summary.as_object_mut() {
        if let Some(estimated) = &estimated {
            record(map, estimated);
        }
        map.extend(notes);
    }
    let text = serde_json::to_string_pretty(&summary).map_err(|e| fail(e.to_string()))? + "\n";
    Ok(lash_sweep::dataset::write_atomic(&path, text.as_bytes())?)
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
    fn the_choice_window_is_short_for_long_runs() {
        assert!((choice_window(60.0, 1e-3) - 0.05).abs() < 1e-12);
        assert!((choice_window(0.036, 1e-3) - 0.02).abs() < 1e-12, "20 macro steps, as the estimate's");
        assert!((choice_window(0.01, 1e-3) - 0.01).abs() < 1e-12, "at most the run");
    }

    #[test]
    fn main_channels_are_accelerations_contact_forces_and_torques() {
        let a = AnyScenario::Planar(lash_scenario::builtin::by_name("A").unwrap());
        let names = main_channels(&a);
        assert_eq!(names, ["slider.ax", "slider.ay", "motor.torque", "crank_pivot.force"]);
    }
}
