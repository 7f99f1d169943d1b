//! The full-model runner: integrates, samples every channel at the output interval, streams the
//! rows to a sink and returns a summary.

use crate::build::{BuildOptions, build_model};
use crate::record::Recorder;
use lash_contact::Impact;
use lash_core::BoxError;
use lash_full_model::FullModel;
use lash_mech::{BodyId, Motion, Vec2};
use lash_ode::{OdeError, OdeSystem};
use lash_scenario::channels::{Channel, Source, channel_sources};
use lash_scenario::schema::Scenario;
use serde::Serialize;
use std::collections::BTreeMap;

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Initial conditions could not be found.
    #[error("initial conditions: {0}")]
    Initial(#[from] lash_full_model::ModelError),
    /// The integration stopped.
    #[error("simulation failed at t = {t} s: {message}")]
    Simulation {
        /// Time reached.
        t: f64,
        /// What happened, naming the quantity.
        message: String,
    },
    /// The sink refused a row.
    #[error("writing output failed: {0}")]
    Output(BoxError),
    /// The scenario is outside what the chosen model covers.
    #[error("{0}")]
    Unsupported(String),
}

/// Statistics of one channel over all samples.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelStats {
    /// Unit.
    pub unit: &'static str,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
    /// Largest absolute value (the peak).
    pub max_abs: f64,
    /// Mean.
    pub mean: f64,
    /// Root mean square.
    pub rms: f64,
}

/// Per-clearance results.
#[derive(Debug, Clone, Serialize)]
pub struct ClearanceSummary {
    /// Joint name.
    pub name: String,
    /// Radial clearance \[m\].
    pub radial_clearance: f64,
    /// Number of contact onsets (impacts).
    pub impacts: usize,
    /// Impacts per driver revolution (when a constant-speed driver exists).
    pub impacts_per_cycle: Option<f64>,
    /// Fraction of the horizon spent in contact (from the located onsets and exits).
    pub contact_fraction: f64,
    /// Largest eccentricity over the samples \[m\].
    pub max_eccentricity: f64,
    /// Largest penetration over impacts \[m\].
    pub max_penetration: f64,
    /// Largest normal force over impacts \[N\].
    pub peak_normal_force: f64,
    /// Mean of |f_c| over the samples \[N\].
    pub mean_contact_force: f64,
    /// Median duration of the completed impacts \[s\] (none without a completed impact).
    pub median_impact_duration: Option<f64>,
    /// The first impacts (up to 20), with onset time, onset velocity, duration, peak force.
    pub first_impacts: Vec<Impact>,
    /// The output samples at which the joint was in contact, and those of them at which its
    /// contact carried no force (a fixed-step reduced run records them; see
    /// [`unloaded_contact_warnings`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contact_samples: Option<ContactSamples>,
}

/// A joint's output samples in contact, and those at which the contact carried no force.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct ContactSamples {
    /// Samples with positive penetration.
    pub in_contact: u64,
    /// Of those, the samples at which the contact force was zero.
    pub unloaded: u64,
}

impl ContactSamples {
    /// Whether the contact went unloaded at more than [`UNLOADED_CONTACT_SHARE`] of the samples
    /// in contact: a pressed contact the step does not hold.
    pub fn unheld(&self) -> bool {
        self.unloaded as f64 > UNLOADED_CONTACT_SHARE * self.in_contact as f64
    }
}

impl ClearanceSummary {
    /// The summary of one joint from its impacts (open ones included, exit time NaN) and the
    /// sampled largest eccentricity and mean force magnitude.
    pub fn from_impacts(
        name: String,
        radial_clearance: f64,
        impacts: Vec<Impact>,
        horizon: f64,
        period: Option<f64>,
        max_eccentricity: f64,
        mean_contact_force: f64,
    ) -> Self {
        let in_contact: f64 = impacts.iter().map(|i| if i.duration.is_nan() { 0.0 } else { i.duration }).sum();
        let mut durations: Vec<f64> = impacts.iter().map(|i| i.duration).filter(|d| d.is_finite()).collect();
        durations.sort_by(f64::total_cmp);
        let median_impact_duration = durations.get(durations.len() / 2).copied();
        Self {
            name,
            radial_clearance,
            impacts: impacts.len(),
            impacts_per_cycle: period.map(|p| impacts.len() as f64 / (horizon / p)),
            contact_fraction: in_contact / horizon,
            max_eccentricity,
            max_penetration: impacts.iter().map(|i| i.max_penetration).fold(0.0, f64::max),
            peak_normal_force: impacts.iter().map(|i| i.peak_force).fold(0.0, f64::max),
            mean_contact_force,
            median_impact_duration,
            first_impacts: impacts.into_iter().take(20).collect(),
            contact_samples: None,
        }
    }

    /// Whether a run with `integrator` held this joint's pressed contact: false for a fixed step
    /// whose recorded contact went unloaded too often ([`ContactSamples::unheld`]).
    pub fn holds_its_contact(&self, integrator: &lash_ode::Method) -> bool {
        !matches!(integrator, lash_ode::Method::Rk4 { .. }) || !self.contact_samples.is_some_and(|c| c.unheld())
    }
}

/// Warnings of clearance joints whose contact is in series with a bush whose viscosities give a
/// damping too fast to carry as a state (c/k below
/// [`lash_contact::clearance::SERIES_DAMPING_MIN_RELAXATION`]): the bush then follows its load
/// quasi-statically, its stiffness in series with the contact and its damping left out; the
/// contact law's damping acts alone. Said in the summary rather than passed over, so that a sweep
/// of small viscosities is not a silent no-op.
pub fn series_bush_warnings(scenario: &Scenario) -> Vec<String> {
    scenario
        .clearances
        .iter()
        .filter_map(|c| {
            let bush = c.bush.as_ref()?;
            let b = lash_bush::bonded_pin(bush).ok()?;
            (b.damping > 0.0 && !crate::build::damped_in_series(&b)).then(|| {
                format!(
                    "clearance joint {}: its bush's viscosities give a damping of {:.3e} N s/m (c/k = {:.1e} s, below \
                     {:.0e} s) that lash leaves out of the series with the contact (the bush follows its load \
                     quasi-statically; the contact law's damping acts alone)",
                    c.joint,
                    b.damping,
                    b.damping / b.stiffness,
                    lash_contact::clearance::SERIES_DAMPING_MIN_RELAXATION
                )
            })
        })
        .collect()
}

/// How far the velocity analysis may move a body's given initial velocity before the run says so,
/// relative to the given value.
const VELOCITY_CHANGE_NOTED: f64 = 0.05;

/// A warning for each body whose given initial velocity (centroid or angular) the velocity
/// analysis moved by more than 5 %: the given velocities are guesses made consistent with the
/// joints, and a free mechanism given inconsistent ones starts at other speeds — the user should
/// know. `qd` holds the bodies' consistent velocities in scenario order (3 per body).
pub fn initial_velocity_warnings(scenario: &Scenario, qd: &[f64]) -> Vec<String> {
    let mut warnings = Vec::new();
    for (k, body) in scenario.bodies.iter().enumerate() {
        let given = Vec2::from(body.velocity);
        let (consistent, omega) = (Vec2::new(qd[3 * k], qd[3 * k + 1]), qd[3 * k + 2]);
        let moved = |from: f64, change: f64| from != 0.0 && change > VELOCITY_CHANGE_NOTED * from.abs();
        if moved(body.angular_velocity, (omega - body.angular_velocity).abs()) {
            warnings.push(format!(
                "bodies.{}.angular_velocity: given {} rad/s, but the velocities given do not satisfy the joints; \
                 the nearest motion that does (mass-weighted) starts it at {omega:.4} rad/s (give every body's \
                 velocities consistent with the joints to start from the given one)",
                body.name, body.angular_velocity
            ));
        }
        if moved(given.norm(), (consistent - given).norm()) {
            warnings.push(format!(
                "bodies.{}.velocity: given [{}, {}] m/s, but the velocities given do not satisfy the joints; the \
                 nearest motion that does (mass-weighted) starts it at [{:.4}, {:.4}] m/s",
                body.name, given.x, given.y, consistent.x, consistent.y
            ));
        }
    }
    warnings
}

/// Fewer fixed steps per contact than this and the contact is not resolved: on scenario B (5000
/// rpm, 0.5 mm, impacts of ~50 µs) RK4 at 1e-5 s (5 steps per impact) puts the peak contact force
/// 23 % above the converged one and 6 steps 2.5 % below; from 7 steps on it is within 1 %
/// (docs/validation.md).
pub const STEPS_PER_CONTACT: f64 = 7.0;

/// Whether `span` is a whole number (one or more) of steps `h`, to rounding.
fn divides(h: f64, span: f64) -> bool {
    let ratio = span / h;
    ratio >= 1.0 - 1e-9 && (ratio - ratio.round()).abs() < 1e-9 * ratio
}

/// `largest`, then the steps below it on the ladder 5, 4, 2.5, 2, 1 × 10⁻ⁿ s over the decades
/// `n`, largest first: the steps lash chooses among (micro and macro).
fn step_ladder(largest: f64, n: std::ops::RangeInclusive<i32>) -> impl Iterator<Item = f64> {
    let ladder = n.flat_map(|n| [5.0, 4.0, 2.5, 2.0, 1.0].map(|m| m / 10f64.powi(n)));
    std::iter::once(largest).chain(ladder.filter(move |&h| h < largest * (1.0 - 1e-9)))
}

/// `largest`, then the steps below it on the ladder 5, 4, 2.5, 2, 1 × 10⁻ⁿ s (n = 5 … 7) that
/// divide both `macro_step` and `output_interval`, largest first: the micro steps lash chooses
/// among.
pub fn micro_step_ladder(largest: f64, macro_step: f64, output_interval: f64) -> Vec<f64> {
    step_ladder(largest, 5..=7).filter(|&h| divides(h, macro_step) && divides(h, output_interval)).collect()
}

/// The largest angle \[rad\] the fastest body turns in one macro step at the defaults: 16°. At
/// 5000 rpm a macro step of 1 ms (30°) leaves the linearly interpolated interface terms off
/// enough to move scenario A's RMS crank torque by −13 % against the converged full model; at
/// 0.5 ms (15°) by −4 %, and the planar built-ins miss 9 of their 124 stated bounds over 2 s
/// instead of 23 (docs/validation.md §6).
pub const MACRO_STEP_ANGLE: f64 = 16.0 * std::f64::consts::PI / 180.0;

/// The reduced model's macro step when the user gives none: `largest` or the largest step below
/// it on the ladder 5, 4, 2.5, 2, 1 × 10⁻ⁿ s that is a whole number of `micro_step`s and turns a
/// body rotating at `fastest` \[rad/s\] by at most [`MACRO_STEP_ANGLE`]; with the reason when
/// it is not `largest`. Nothing turning, or no such step: `largest`.
pub fn macro_step_for_rotation(largest: f64, micro_step: f64, fastest: Option<f64>) -> (f64, Option<String>) {
    let Some(omega) = fastest.filter(|w| w.is_finite() && *w > 0.0) else { return (largest, None) };
    let chosen =
        step_ladder(largest, 3..=6).filter(|&h| divides(micro_step, h)).find(|&h| omega * h <= MACRO_STEP_ANGLE);
    match chosen {
        Some(h) if h < largest => {
            let why = format!(
                "macro step {h:e} s: the fastest body turns at {:.0} rpm, {:.0}° per step at {largest:e} s \
                 (at most {:.0}° at the defaults)",
                omega * 60.0 / std::f64::consts::TAU,
                (omega * largest).to_degrees(),
                MACRO_STEP_ANGLE.to_degrees()
            );
            (h, Some(why))
        }
        _ => (largest, None),
    }
}

/// The reduced model's micro step when the user gives none: the largest of `largest` and the
/// steps below it on the ladder 5, 4, 2.5, 2, 1 × 10⁻ⁿ s that divide both the macro step and the
/// output interval and give each clearance joint's median impact duration in `medians` (from a
/// converged run, [`ClearanceSummary::median_impact_duration`]) at least [`STEPS_PER_CONTACT`]
/// steps. A joint without a completed impact (`None`) asks nothing. With impacts too short for
/// the ladder (under 0.7 µs) its finest step.
pub fn resolving_micro_step(
    largest: f64,
    macro_step: f64,
    output_interval: f64,
    medians: impl IntoIterator<Item = Option<f64>>,
) -> f64 {
    let shortest = medians.into_iter().flatten().fold(f64::INFINITY, f64::min);
    let candidates = micro_step_ladder(largest, macro_step, output_interval);
    candidates
        .iter()
        .copied()
        .find(|&h| shortest / h >= STEPS_PER_CONTACT)
        .or_else(|| candidates.last().copied())
        .unwrap_or(largest)
}

/// Warnings of a fixed-step run whose impacts last fewer than [`STEPS_PER_CONTACT`] steps (by the
/// median completed impact of each clearance joint); none for an adaptive integrator, which
/// locates every onset and exit.
pub fn resolution_warnings(integrator: &lash_ode::Method, clearances: &[ClearanceSummary]) -> Vec<String> {
    let lash_ode::Method::Rk4 { step } = *integrator else { return Vec::new() };
    clearances
        .iter()
        .filter_map(|c| {
            let d = c.median_impact_duration?;
            let steps = d / step;
            (steps < STEPS_PER_CONTACT).then(|| {
                format!(
                    "clearance joint {}: its impacts last a median of {steps:.1} steps of {step:e} s ({d:.2e} s); \
                     a fixed step needs about {STEPS_PER_CONTACT} per contact to resolve it, so its peak forces (and \
                     the impacts that follow) are not converged: take an adaptive integrator or a step of \
                     {:.0e} s or less",
                    c.name,
                    d / STEPS_PER_CONTACT
                )
            })
        })
        .collect()
}

/// Share of a joint's samples in contact at which its contact may carry no force before a
/// fixed-step run is said not to hold the contact. A full model (adaptive) shows none on the
/// built-ins, a stable reduced run 0–0.12 %; the unstable pressed contacts measured (F-0.25mm,
/// B-0.1mm) 2.8–57 % (docs/validation.md §6).
pub const UNLOADED_CONTACT_SHARE: f64 = 0.01;

/// Warnings of a fixed-step run in which a clearance joint, while in contact, often carries no
/// force ([`ClearanceSummary::holds_its_contact`]): the contact law's damping (at a slow onset the
/// hysteresis term of a law like Lankarani–Nikravesh outweighs the elastic one and the law clamps
/// the pull to zero) is too stiff for the step, so the journal chatters inside the bearing instead
/// of pressing on it and the joint's loads are wrong.
pub fn unloaded_contact_warnings(integrator: &lash_ode::Method, clearances: &[ClearanceSummary]) -> Vec<String> {
    let lash_ode::Method::Rk4 { step } = *integrator else { return Vec::new() };
    clearances
        .iter()
        .filter(|c| !c.holds_its_contact(integrator))
        .filter_map(|c| {
            let ContactSamples { in_contact, unloaded } = c.contact_samples?;
            Some(format!(
                "clearance joint {}: in contact at {in_contact} samples, it carries no force at {unloaded} of them \
                 ({:.1} %): a step of {step:e} s does not hold this pressed contact stable (the contact law's \
                 damping after a slow onset is too stiff for it), so the joint chatters and its loads are wrong; \
                 take a smaller --micro-step (a tenth), --micro dopri5, or --coupling two-way",
                c.name,
                100.0 * unloaded as f64 / in_contact as f64
            ))
        })
        .collect()
}

/// When a reduced run (its `summary`) did not hold a joint's pressed contact at
/// `options.micro_step` ([`ClearanceSummary::holds_its_contact`]): the step on the ladder at a
/// tenth of it or below (dividing the macro step and `output_interval`; [`micro_step_ladder`]),
/// and why; none when every contact was held or there is no finer step.
pub fn micro_step_for_unheld_contacts(
    summary: &Summary,
    options: &crate::ReducedOptions,
    output_interval: f64,
) -> Option<(f64, String)> {
    let unheld: Vec<&str> = summary
        .clearances
        .iter()
        .filter(|c| !c.holds_its_contact(&summary.integrator))
        .map(|c| c.name.as_str())
        .collect();
    if unheld.is_empty() {
        return None;
    }
    let h = options.micro_step;
    let ladder = micro_step_ladder(h, options.macro_step, output_interval);
    let finer = ladder.iter().copied().find(|&x| x <= 0.1 * h * (1.0 + 1e-9)).or(ladder.last().copied())?;
    (finer < h).then(|| {
        let why = format!(
            "micro step {finer:e} s: at {h:e} s the contact of {} carried no force at part of the samples in contact \
             (a pressed contact the step does not hold), so the run was made again at a tenth of the step",
            unheld.join(", ")
        );
        (finer, why)
    })
}

/// Summary of a run (written as summary.json).
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// Scenario name.
    pub scenario: String,
    /// "full", "ideal" or "reduced".
    pub model: &'static str,
    /// Integrator used.
    pub integrator: lash_ode::Method,
    /// Start time \[s\].
    pub start_time: f64,
    /// Horizon \[s\].
    pub horizon: f64,
    /// Output interval \[s\].
    pub output_interval: f64,
    /// Samples written.
    pub samples: u64,
    /// CPU time of the integration (this thread) \[s\].
    pub cpu_time_s: f64,
    /// Wall time of the integration \[s\].
    pub wall_time_s: f64,
    /// Accepted steps.
    pub steps: u64,
    /// Rejected steps.
    pub rejected_steps: u64,
    /// Right-hand-side evaluations.
    pub rhs_evaluations: u64,
    /// Contact events located.
    pub events: u64,
    /// Largest |Φ| over the samples [m or rad].
    pub max_constraint_error: f64,
    /// Per-channel statistics.
    pub channels: BTreeMap<String, ChannelStats>,
    /// Per-clearance results.
    pub clearances: Vec<ClearanceSummary>,
    /// What the user should know about the results' quality (a fixed step too coarse for the
    /// contacts: [`resolution_warnings`]).
    pub warnings: Vec<String>,
    /// Reduced model only: options, coupling counters and time split.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reduced: Option<crate::reduced::ReducedDetails>,
    /// Emulated vibration measurements (`[[output.measurements]]`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub measurements: Vec<crate::measure::MeasurementSummary>,
    /// The loggers' samples of those measurements (written to their own CSV files, not to JSON).
    #[serde(skip)]
    pub measured: Vec<crate::measure::MeasuredTable>,
}

impl Summary {
    /// The summary of a run of `scenario` by `model` ("full", "ideal", "reduced") with
    /// `integrator` over the scenario's simulation `sim`, whose integration took `cpu` and `wall`
    /// seconds and `ode`'s steps; nothing sampled yet (the runner fills in what it recorded).
    pub(crate) fn new(
        scenario: &str,
        model: &'static str,
        integrator: lash_ode::Method,
        sim: &lash_scenario::schema::SimulationSpec,
        (cpu, wall): (f64, f64),
        ode: &lash_ode::Stats,
    ) -> Self {
        Summary {
            scenario: scenario.to_string(),
            model,
            integrator,
            start_time: sim.start_time,
            horizon: sim.horizon,
            output_interval: sim.output_interval,
            samples: 0,
            cpu_time_s: cpu,
            wall_time_s: wall,
            steps: ode.steps,
            rejected_steps: ode.rejected,
            rhs_evaluations: ode.rhs_evaluations,
            events: ode.events,
            max_constraint_error: 0.0,
            channels: BTreeMap::new(),
            clearances: Vec::new(),
            warnings: Vec::new(),
            reduced: None,
            measurements: Vec::new(),
            measured: Vec::new(),
        }
    }
}

/// A prepared run.
pub struct FullRun {
    /// The model.
    pub model: FullModel,
    scenario: Scenario,
    ideal: bool,
    sources: Vec<(Channel, Source)>,
    selected: Vec<usize>,
    stresses: Vec<Option<std::sync::Arc<lash_bush::InterfaceStress>>>,
}

impl FullRun {
    /// Prepares a run of a validated scenario.
    pub fn new(scenario: &Scenario, options: BuildOptions) -> Self {
        let sources = channel_sources(scenario, options.ideal);
        let selected = lash_scenario::channels::selected_channels(scenario, &sources);
        Self {
            model: build_model(scenario, options),
            scenario: scenario.clone(),
            ideal: options.ideal,
            sources,
            selected,
            // The bushes' FE tables before the clock starts (none for the ideal mechanism).
            stresses: if options.ideal {
                vec![None; scenario.clearances.len()]
            } else {
                crate::build::interface_stresses(scenario)
            },
        }
    }

    /// Header of the written columns (time first), with units: `time [s]`, `slider.ax [m/s^2]`, …
    pub fn header(&self) -> Vec<String> {
        lash_scenario::channels::header(&self.sources, &self.selected)
    }

    /// Integrates over the scenario's horizon. `sink` receives each row (time first);
    /// `progress` the fraction done.
    pub fn execute(&mut self, sink: Sink<'_>, progress: &mut dyn FnMut(f64)) -> Result<Summary, RunError> {
        let sim = &self.scenario.simulation;
        let (t0, t_end) = (sim.start_time, sim.start_time + sim.horizon);
        let mut y = self.model.initial_state(t0)?;
        let n = self.model.mechanism.coordinate_count();
        let velocity_warnings = initial_velocity_warnings(&self.scenario, &y[n..2 * n]);
        let sensors = sensor_points(&self.scenario, &self.model.mechanism);
        let horizon = sim.horizon;
        let mut recorder = Recorder::new(&self.sources, &self.selected, sensors, self.model.contact_count())
            .with_stresses(&self.stresses);
        let names: Vec<&str> = self.sources.iter().map(|(c, _)| c.name.as_str()).collect();
        let mut measurements = crate::measure::MeasurementRecorder::new(&self.scenario.output.measurements, &names);
        let mut observer = |model: &mut FullModel, t: f64, y: &[f64]| -> Result<(), BoxError> {
            model.evaluate(t, y)?;
            let (q, qd) = (&y[..n], &y[n..2 * n]);
            recorder.record(t, model, q, qd, sink).map_err(SinkFailed::boxed)?;
            measurements.record(recorder.values());
            progress(((t - t0) / horizon).clamp(0.0, 1.0));
            Ok(())
        };
        let (result, (cpu, wall)) = timed_integration(
            &sim.integrator,
            &mut self.model,
            (t0, t_end, sim.output_interval),
            &mut y,
            &mut observer,
        );
        let ode_stats = match result {
            Ok(s) => s,
            Err(e) => return Err(self.explain(e)),
        };
        let (measurements, measured) = measurements
            .finish(t0, sim.output_interval)
            .map_err(|e| RunError::Simulation { t: t_end, message: e.to_string() })?;
        let period = driver_period(self.scenario.drivers.iter().map(|d| &d.motion));
        // Each clearance joint, then each guide's corners (a contact each).
        let corners = self
            .model
            .slots
            .iter()
            .flat_map(|s| (0..4).map(|k| (lash_contact::Clearance::name(s.corner(k)), s.clearance)));
        let contacts = self.model.clearances.iter().map(|c| (c.name.as_str(), c.radial_clearance())).chain(corners);
        let clearances: Vec<ClearanceSummary> = contacts
            .enumerate()
            .map(|(k, (name, clearance))| {
                let mut impacts = self.model.impacts()[k].clone();
                impacts.extend(self.model.open_impact(k, t_end));
                recorder.clearance_summary(k, name, clearance, impacts, horizon, period)
            })
            .collect();
        let model = if self.ideal { "ideal" } else { "full" };
        Ok(Summary {
            samples: recorder.samples,
            max_constraint_error: recorder.max_constraint_error,
            channels: recorder.channel_stats(),
            warnings: [
                velocity_warnings,
                crate::run::resolution_warnings(&sim.integrator, &clearances),
                series_bush_warnings(&self.scenario),
            ]
            .concat(),
            clearances,
            measurements,
            measured,
            ..Summary::new(&self.scenario.name, model, sim.integrator, sim, (cpu, wall), &ode_stats)
        })
    }

    /// Names the quantity behind an integrator error.
    fn explain(&mut self, e: OdeError) -> RunError {
        let cause = self.model.take_error();
        let mechanism = &self.model.mechanism;
        let n = self.model.dim() / 2;
        let non_finite = |index: usize, value: f64| {
            let k = index % n;
            let body = &mechanism.bodies[k / 3].name;
            let q = ["x", "y", "angle", "vx", "vy", "angular_velocity"][(k % 3) + if index >= n { 3 } else { 0 }];
            let mut message = format!("{body}.{q} became {value}: the simulation blew up");
            if let Some(c) = cause {
                message.push_str(&format!(" ({c})"));
            }
            message
        };
        let underflow = "a blow-up, or a force that jumps without an event, such as pure Coulomb friction once the \
                         slip stops: prefer the ambrosio or adams_stick_slip friction laws";
        integration_error(e, self.scenario.simulation.start_time, non_finite, underflow)
    }
}

/// Integrates `model` over `(t0, t_end)` with samples every `interval` to `observer`; the result
/// and the (CPU, wall) seconds it took.
pub(crate) fn timed_integration<S: OdeSystem>(
    method: &lash_ode::Method,
    model: &mut S,
    (t0, t_end, interval): (f64, f64, f64),
    y: &mut [f64],
    observer: &mut impl lash_ode::Observer<S>,
) -> (Result<lash_ode::Stats, OdeError>, (f64, f64)) {
    let cpu = cpu_time::ThreadTime::now();
    let wall = std::time::Instant::now();
    let result = lash_ode::integrate(method, model, t0, y, t_end, interval, observer);
    (result, (cpu.elapsed().as_secs_f64(), wall.elapsed().as_secs_f64()))
}

/// The run error of an integrator error: `non_finite` says which quantity a state index is,
/// `underflow` what a step-size underflow usually means for the model, a sink's error becomes
/// [`RunError::Output`].
pub(crate) fn integration_error(
    e: OdeError,
    start_time: f64,
    non_finite: impl FnOnce(usize, f64) -> String,
    underflow: &str,
) -> RunError {
    let simulation = |t: f64, message: String| RunError::Simulation { t, message };
    match e {
        OdeError::NonFinite { t, index, value } => simulation(t, non_finite(index, value)),
        OdeError::System { t, source } => simulation(t, lash_core::error_chain(&*source)),
        OdeError::StepSizeUnderflow { t, step } => {
            simulation(t, format!("step size fell to {step:e} s: the tolerances cannot be met ({underflow})"))
        }
        OdeError::Observer { t, source } => SinkFailed::sort(t, source),
        OdeError::Settings(m) => simulation(start_time, m),
    }
}

/// The sensors' bodies and points.
pub(crate) fn sensor_points(s: &Scenario, mech: &lash_mech::Mechanism) -> Vec<(BodyId, Vec2)> {
    s.sensors.iter().map(|x| (mech.body_id(&x.body).expect("validated"), Vec2::new(x.point[0], x.point[1]))).collect()
}

/// Period of the first constant-speed motion among `motions` (a scenario's drivers', planar or
/// spatial), if any.
pub(crate) fn driver_period<'a>(motions: impl IntoIterator<Item = &'a Motion>) -> Option<f64> {
    motions.into_iter().find_map(|m| match *m {
        Motion::ConstantSpeed { omega, .. } if omega != 0.0 => Some(2.0 * std::f64::consts::PI / omega.abs()),
        _ => None,
    })
}

/// An error of the sink, told apart from the model's own errors on their way through the
/// integrator's observer.
#[derive(Debug, thiserror::Error)]
#[error(transparent)]
pub(crate) struct SinkFailed(BoxError);

impl SinkFailed {
    /// The sink's error, marked as the sink's.
    pub(crate) fn boxed(e: BoxError) -> BoxError {
        Box::new(SinkFailed(e))
    }

    /// An observer's error at `t`: the sink's becomes [`RunError::Output`], any other (the model
    /// evaluated for the sample) [`RunError::Simulation`].
    pub(crate) fn sort(t: f64, e: BoxError) -> RunError {
        match e.downcast::<SinkFailed>() {
            Ok(sink) => RunError::Output(sink.0),
            Err(other) => RunError::Simulation { t, message: lash_core::error_chain(&*other) },
        }
    }
}

/// Where a run's rows go (time first, then the written channels); an error stops the run.
pub type Sink<'a> = &'a mut dyn FnMut(&[f64]) -> Result<(), BoxError>;

/// Anything that runs a scenario into rows and a summary (full, ideal or reduced model).
pub trait Runner {
    /// Column names with units, time first.
    fn header(&self) -> Vec<String>;
    /// Runs the horizon.
    fn execute(&mut self, sink: Sink<'_>, progress: &mut dyn FnMut(f64)) -> Result<Summary, RunError>;
}

/// Runs whose inherent `header` and `execute` are the trait's.
macro_rules! inherent_runner {
    ($($run:ty),*) => {$(
        impl Runner for $run {
            fn header(&self) -> Vec<String> {
                <$run>::header(self)
            }
            fn execute(&mut self, sink: Sink<'_>, progress: &mut dyn FnMut(f64)) -> Result<Summary, RunError> {
                <$run>::execute(self, sink, progress)
            }
        }
    )*};
}

inherent_runner!(
    FullRun,
    crate::reduced::ReducedRun,
    crate::spatial::SpatialRun,
    crate::spatial::SpatialReducedRun,
    crate::AnyRunner
);

#[cfg(test)]
mod tests {

    /// The unloaded-contact warning: said past 1 % of a joint's samples in contact, naming the
    /// joint, the share and the step; never for an adaptive integrator. The finer step it leads
    /// to reads the same counts.
    #[test]
    fn a_contact_that_often_carries_no_force_is_said() {
        let joint = |name: &str, unloaded: u64| ClearanceSummary {
            contact_samples: Some(ContactSamples { in_contact: 1000, unloaded }),
            ..ClearanceSummary::from_impacts(name.into(), 1e-4, Vec::new(), 1.0, None, 0.0, 0.0)
        };
        let clearances = vec![joint("held", 10), joint("chattering", 11)];
        let rk4 = lash_ode::Method::Rk4 { step: 1e-5 };
        let said = unloaded_contact_warnings(&rk4, &clearances);
        assert_eq!(said.len(), 1, "{said:?}");
        assert!(said[0].starts_with("clearance joint chattering: in contact at 1000 samples"), "{}", said[0]);
        assert!(said[0].contains("(1.1 %)") && said[0].contains("1e-5 s"), "{}", said[0]);
        let adaptive = lash_ode::Method::Dopri5(Default::default());
        let loose = vec![joint("a", 500), joint("b", 500)];
        assert!(unloaded_contact_warnings(&adaptive, &loose).is_empty());
        assert!(loose.iter().all(|c| c.holds_its_contact(&adaptive)));
        // The finer step it leads to: a tenth on the ladder, naming the joint; none when every
        // contact is held (or not counted).
        let summary = |clearances: Vec<ClearanceSummary>| Summary {
            scenario: "A".into(),
            model: "reduced",
            integrator: rk4,
            start_time: 0.0,
            horizon: 1.0,
            output_interval: 1e-5,
            samples: 0,
            cpu_time_s: 0.0,
            wall_time_s: 0.0,
            steps: 0,
            rejected_steps: 0,
            rhs_evaluations: 0,
            events: 0,
            max_constraint_error: 0.0,
            channels: Default::default(),
            clearances,
            warnings: Vec::new(),
            reduced: None,
            measurements: Vec::new(),
            measured: Vec::new(),
        };
        let options = crate::ReducedOptions::default();
        let (h, why) = micro_step_for_unheld_contacts(&summary(clearances), &options, 1e-5).expect("a finer step");
        assert_eq!(h, 1e-6);
        assert!(why.contains("the contact of chattering carried no force"), "{why}");
        assert!(micro_step_for_unheld_contacts(&summary(vec![joint("held", 10)]), &options, 1e-5).is_none());
        let uncounted = ClearanceSummary::from_impacts("x".into(), 1e-4, Vec::new(), 1.0, None, 0.0, 0.0);
        assert!(micro_step_for_unheld_contacts(&summary(vec![uncounted]), &options, 1e-5).is_none());
    }
    use super::*;

    #[test]
    fn the_micro_step_gives_each_median_impact_seven_steps() {
        let choose =
            |medians: &[Option<f64>], output: f64| resolving_micro_step(1e-5, 1e-3, output, medians.iter().copied());
        // Scenario A's crank pivot (95 µs): the default stands; B's rod–slider (55 µs, 5.5 steps
        // of 1e-5 s) and C's (47 µs) get 5e-6 s.
        assert_eq!(choose(&[Some(9.54e-5)], 1e-5), 1e-5);
        assert_eq!(choose(&[Some(5.48e-5)], 1e-5), 5e-6);
        assert_eq!(choose(&[Some(8.7e-5), Some(4.72e-5)], 1e-5), 5e-6);
        // 30 µs needs 4.3e-6 s: 4e-6 s where the output interval allows it, else 2.5e-6 s.
        assert_eq!(choose(&[Some(3.0e-5)], 2e-5), 4e-6);
        assert_eq!(choose(&[Some(3.0e-5)], 1e-5), 2.5e-6);
        // No completed impact asks nothing; impacts too short for the ladder get its finest step.
        assert_eq!(choose(&[None], 1e-5), 1e-5);
        assert_eq!(choose(&[Some(1e-7)], 1e-5), 1e-7);
        // A user's larger step is kept when the impacts allow it.
        let big = resolving_micro_step(2e-5, 1e-3, 2e-5, [Some(2e-4)]);
        assert_eq!(big, 2e-5);
    }

    #[test]
    fn the_macro_step_turns_the_fastest_body_by_at_most_its_angle() {
        let rpm = |n: f64| n * std::f64::consts::TAU / 60.0;
        let choose = |w: Option<f64>| macro_step_for_rotation(1e-3, 1e-5, w);
        // The built-ins' speeds, read from the scenarios: 5000 rpm (A's driver, A-motor's crank
        // given 5000 rpm and no driver), 3000 rpm (F), 250 rpm (E), 150 rad/s (G, free).
        let fastest = |name: &str| lash_scenario::any_by_name_or_file(name).unwrap().fastest_rotation();
        for (name, speed) in [("A", rpm(5000.0)), ("A-motor", rpm(5000.0)), ("F", rpm(3000.0)), ("G", 150.0)] {
            let w = fastest(name).unwrap();
            assert!((w - speed).abs() < 1e-9 * speed, "{name}: {w}");
        }
        assert!((fastest("E-0.5mm-250rpm").unwrap() - rpm(250.0)).abs() < 1e-9);
        // 30° at 1 ms: 0.5 ms (15°), said; 18° at 1 ms (3000 rpm): 0.5 ms; 6000 rpm: 18° at
        // 0.5 ms, so 0.4 ms; 250 rpm and 150 rad/s (8.6°) keep 1 ms; nothing turning keeps it.
        let (h, why) = choose(Some(rpm(5000.0)));
        assert_eq!(h, 5e-4);
        assert!(why.unwrap().contains("5000 rpm, 30° per step"));
        assert_eq!(choose(Some(rpm(3000.0))).0, 5e-4);
        assert_eq!(choose(Some(rpm(6000.0))).0, 4e-4);
        assert_eq!(choose(Some(rpm(250.0))), (1e-3, None));
        assert_eq!(choose(Some(150.0)), (1e-3, None));
        assert_eq!(choose(None), (1e-3, None));
        // Every choice is a whole number of micro steps and within the angle.
        for n in [100.0, 4000.0, 9000.0, 20_000.0, 100_000.0] {
            let (h, _) = macro_step_for_rotation(1e-3, 2e-5, Some(rpm(n)));
            assert!(rpm(n) * h <= MACRO_STEP_ANGLE && ((h / 2e-5) - (h / 2e-5).round()).abs() < 1e-9, "{n}: {h}");
        }
    }

    #[test]
    fn a_free_mechanism_started_at_inconsistent_velocities_says_which_it_changed() {
        // G's free slider-crank with the bodies' angular velocities given but their centroids'
        // left at rest: the velocity analysis starts the crank far slower than the 150 rad/s
        // given, and the run says so, naming the field; G as written (consistent) says nothing.
        let run = |scenario: &Scenario| {
            let mut s = scenario.clone();
            s.simulation.horizon = 1e-4;
            let mut full = FullRun::new(&s, BuildOptions::default());
            full.execute(&mut |_| Ok(()), &mut |_| {}).expect("runs").warnings
        };
        let consistent = lash_scenario::builtin::by_name("G").expect("built-in");
        assert!(run(&consistent).is_empty());
        let mut inconsistent = consistent.clone();
        for b in &mut inconsistent.bodies {
            b.velocity = [0.0, 0.0];
        }
        let warnings = run(&inconsistent);
        eprintln!("{warnings:#?}");
        let crank = warnings.iter().find(|w| w.starts_with("bodies.crank.angular_velocity: given 150 rad/s"));
        assert!(crank.is_some(), "{warnings:?}");
    }
}
