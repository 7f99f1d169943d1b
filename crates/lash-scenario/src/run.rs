//! The full-model runner: integrates, samples every channel at the output interval, streams the
//! rows to a sink and returns a summary.

use crate::build::{BuildOptions, build_model};
use crate::channels::{Channel, Source, channel_sources};
use crate::schema::Scenario;
use lash_contact::{FullModel, Impact};
use lash_mech::{BodyId, Motion, Vec2, driver_torque, kinematics, point_kinematics};
use lash_ode::{OdeError, OdeSystem};
use serde::Serialize;
use std::collections::BTreeMap;

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Initial conditions could not be found.
    #[error("initial conditions: {0}")]
    Initial(#[from] lash_contact::ModelError),
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
    Output(String),
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
    /// Radial clearance [m].
    pub radial_clearance: f64,
    /// Number of contact onsets (impacts).
    pub impacts: usize,
    /// Impacts per driver revolution (when a constant-speed driver exists).
    pub impacts_per_cycle: Option<f64>,
    /// Fraction of the horizon spent in contact (from the located onsets and exits).
    pub contact_fraction: f64,
    /// Largest eccentricity over the samples [m].
    pub max_eccentricity: f64,
    /// Largest penetration over impacts [m].
    pub max_penetration: f64,
    /// Largest normal force over impacts [N].
    pub peak_normal_force: f64,
    /// Mean of |f_c| over the samples [N].
    pub mean_contact_force: f64,
    /// The first impacts (up to 20), with onset time, onset velocity, duration, peak force.
    pub first_impacts: Vec<Impact>,
}

/// Summary of a run (written as summary.json).
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// Scenario name.
    pub scenario: String,
    /// "full" or "ideal".
    pub model: &'static str,
    /// Integrator used.
    pub integrator: lash_ode::Method,
    /// Start time [s].
    pub start_time: f64,
    /// Horizon [s].
    pub horizon: f64,
    /// Output interval [s].
    pub output_interval: f64,
    /// Samples written.
    pub samples: u64,
    /// CPU time of the integration (this thread) [s].
    pub cpu_time_s: f64,
    /// Wall time of the integration [s].
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
}

/// A prepared run.
pub struct Run {
    /// The model.
    pub model: FullModel,
    scenario: Scenario,
    ideal: bool,
    sources: Vec<(Channel, Source)>,
    selected: Vec<usize>,
}

impl Run {
    /// Prepares a run of a validated scenario.
    pub fn new(scenario: &Scenario, options: BuildOptions) -> Self {
        let sources = channel_sources(scenario, options.ideal);
        let selected = if scenario.output.channels.is_empty() {
            (0..sources.len()).collect()
        } else {
            sources
                .iter()
                .enumerate()
                .filter(|(_, (c, _))| scenario.output.channels.contains(&c.name))
                .map(|(k, _)| k)
                .collect()
        };
        Self {
            model: build_model(scenario, options),
            scenario: scenario.clone(),
            ideal: options.ideal,
            sources,
            selected,
        }
    }

    /// Header of the written columns (time first), with units: `time [s]`, `slider.ax [m/s^2]`, …
    pub fn header(&self) -> Vec<String> {
        std::iter::once("time [s]".to_string())
            .chain(self.selected.iter().map(|&k| {
                let c = &self.sources[k].0;
                format!("{} [{}]", c.name, c.unit)
            }))
            .collect()
    }

    /// Integrates over the scenario's horizon. `sink` receives each row (time first);
    /// `progress` the fraction done.
    pub fn execute(
        &mut self,
        sink: &mut dyn FnMut(&[f64]) -> Result<(), String>,
        progress: &mut dyn FnMut(f64),
    ) -> Result<Summary, RunError> {
        let sim = &self.scenario.simulation;
        let (t0, t_end) = (sim.start_time, sim.start_time + sim.horizon);
        let mut y = self.model.initial_state(t0)?;
        let n = self.model.mechanism.coordinate_count();
        let sensors: Vec<(BodyId, Vec2)> = self
            .scenario
            .sensors
            .iter()
            .map(|s| (self.model.mechanism.body_id(&s.body).expect("validated"), Vec2::new(s.point[0], s.point[1])))
            .collect();
        let n_ch = self.sources.len();
        let mut sensor_values = vec![[0.0; 6]; sensors.len()];
        let mut values = vec![0.0; n_ch];
        let mut row = vec![0.0; self.selected.len() + 1];
        let mut stats = vec![(f64::INFINITY, f64::NEG_INFINITY, 0.0f64, 0.0f64); n_ch];
        let mut samples = 0u64;
        let mut max_phi = 0.0f64;
        let nc = self.model.clearances.len();
        let mut max_ecc = vec![0.0f64; nc];
        let mut sum_force = vec![0.0f64; nc];
        let horizon = sim.horizon;
        let sources = &self.sources;
        let selected = &self.selected;

        let mut observer = |model: &mut FullModel, t: f64, y: &[f64]| -> Result<(), String> {
            model.evaluate(t, y).map_err(|e| e.to_string())?;
            let (q, qd) = y.split_at(n);
            let qdd = &model.solver.accelerations;
            for (k, (body, point)) in sensors.iter().enumerate() {
                let p = point_kinematics(q, qd, qdd, *body, *point);
                sensor_values[k] =
                    [p.position.x, p.position.y, p.velocity.x, p.velocity.y, p.acceleration.x, p.acceleration.y];
            }
            for (v, (_, src)) in values.iter_mut().zip(sources) {
                *v = match *src {
                    Source::Sensor(k, quantity) => sensor_values[k][quantity as usize],
                    Source::Clearance(k, quantity) => {
                        let c = &model.contacts[k];
                        [
                            c.force_on_journal.x,
                            c.force_on_journal.y,
                            c.force_on_journal.norm(),
                            c.normal_force,
                            c.friction_force,
                            c.eccentricity.x,
                            c.eccentricity.y,
                            c.eccentricity_norm,
                            c.penetration,
                            c.penetration_rate,
                            c.slip_velocity,
                        ][quantity as usize]
                    }
                    Source::DriverTorque(k) => driver_torque(&model.mechanism, &model.solver, k),
                    Source::JointReaction(k, comp) => {
                        let r = kinematics::joint_reaction(&model.mechanism, &model.solver, k);
                        if comp == 0 { r.x } else { r.y }
                    }
                    Source::ConstraintError => model.solver.constraint_error(),
                };
            }
            for (k, c) in model.contacts.iter().enumerate() {
                max_ecc[k] = max_ecc[k].max(c.eccentricity_norm);
                sum_force[k] += c.force_on_journal.norm();
            }
            max_phi = max_phi.max(model.solver.constraint_error());
            for (s, &v) in stats.iter_mut().zip(values.iter()) {
                s.0 = s.0.min(v);
                s.1 = s.1.max(v);
                s.2 += v;
                s.3 += v * v;
            }
            samples += 1;
            row[0] = t;
            for (r, &k) in row[1..].iter_mut().zip(selected) {
                *r = values[k];
            }
            sink(&row)?;
            progress(((t - t0) / horizon).clamp(0.0, 1.0));
            Ok(())
        };

        let cpu0 = cpu_time::ThreadTime::now();
        let wall0 = std::time::Instant::now();
        let result = lash_ode::integrate(
            &sim.integrator,
            &mut self.model,
            t0,
            &mut y,
            t_end,
            sim.output_interval,
            &mut observer,
        );
        let cpu = cpu0.elapsed().as_secs_f64();
        let wall = wall0.elapsed().as_secs_f64();
        let ode_stats = match result {
            Ok(s) => s,
            Err(e) => return Err(self.explain(e)),
        };

        let period = self.scenario.drivers.iter().find_map(|d| match d.motion {
            Motion::ConstantSpeed { omega, .. } if omega != 0.0 => Some(2.0 * std::f64::consts::PI / omega.abs()),
            _ => None,
        });
        let clearances = (0..nc)
            .map(|k| {
                let c = &self.model.clearances[k];
                let mut impacts = self.model.impacts[k].clone();
                impacts.extend(self.model.open_impacts(t_end));
                let in_contact: f64 = impacts.iter().map(|i| if i.duration.is_nan() { 0.0 } else { i.duration }).sum();
                ClearanceSummary {
                    name: c.name.clone(),
                    radial_clearance: c.radial_clearance(),
                    impacts: impacts.len(),
                    impacts_per_cycle: period.map(|p| impacts.len() as f64 / (horizon / p)),
                    contact_fraction: in_contact / horizon,
                    max_eccentricity: max_ecc[k],
                    max_penetration: impacts.iter().map(|i| i.max_penetration).fold(0.0, f64::max),
                    peak_normal_force: impacts.iter().map(|i| i.peak_force).fold(0.0, f64::max),
                    mean_contact_force: sum_force[k] / samples.max(1) as f64,
                    first_impacts: impacts.into_iter().take(20).collect(),
                }
            })
            .collect();
        let channels = self
            .sources
            .iter()
            .zip(&stats)
            .map(|((c, _), s)| {
                let m = samples.max(1) as f64;
                (
                    c.name.clone(),
                    ChannelStats {
                        unit: c.unit,
                        min: s.0,
                        max: s.1,
                        max_abs: s.0.abs().max(s.1.abs()),
                        mean: s.2 / m,
                        rms: (s.3 / m).sqrt(),
                    },
                )
            })
            .collect();
        Ok(Summary {
            scenario: self.scenario.name.clone(),
            model: if self.ideal { "ideal" } else { "full" },
            integrator: sim.integrator,
            start_time: t0,
            horizon,
            output_interval: sim.output_interval,
            samples,
            cpu_time_s: cpu,
            wall_time_s: wall,
            steps: ode_stats.steps,
            rejected_steps: ode_stats.rejected,
            rhs_evaluations: ode_stats.rhs_evaluations,
            events: ode_stats.events,
            max_constraint_error: max_phi,
            channels,
            clearances,
        })
    }

    /// Names the quantity behind an integrator error.
    fn explain(&mut self, e: OdeError) -> RunError {
        let cause = self.model.take_error();
        match e {
            OdeError::NonFinite { t, index, value } => {
                let n = self.model.dim() / 2;
                let k = index % n;
                let body = &self.model.mechanism.bodies[k / 3].name;
                let q = ["x", "y", "angle", "vx", "vy", "angular_velocity"][(k % 3) + if index >= n { 3 } else { 0 }];
                let mut message = format!("{body}.{q} became {value}: the simulation blew up");
                if let Some(c) = cause {
                    message.push_str(&format!(" ({c})"));
                }
                RunError::Simulation { t, message }
            }
            OdeError::System { t, message } => RunError::Simulation { t, message },
            OdeError::StepSizeUnderflow { t, step } => RunError::Simulation {
                t,
                message: format!(
                    "step size fell to {step:e} s: the tolerances cannot be met (a blow-up, or a force that jumps \
                     without an event, such as pure Coulomb friction once the slip stops: prefer the ambrosio or \
                     adams_stick_slip friction laws)"
                ),
            },
            OdeError::Observer { t, message } => {
                if message.starts_with("output:") {
                    RunError::Output(message)
                } else {
                    RunError::Simulation { t, message }
                }
            }
            OdeError::Settings(m) => RunError::Simulation { t: self.scenario.simulation.start_time, message: m },
        }
    }
}
