//! The reduced interface model (seeds 000/001, physics.md §4), one-way coupled, sequential.
//!
//! * Macro subsystem: the ideal mechanism (clearance joint made perfect). In this build it must be
//!   fully driven (no degree of freedom), so its motion at each macro node t_k = t0 + k h_m is the
//!   exact kinematic analysis; at each node it exports the cut system's effective terms (mobility W,
//!   a_free, the maps q̈_free, G, λ_free, Λ) and the bodies' angular velocities.
//! * Micro subsystem: [`lash_contact::micro::InterfaceModel`], RK4 at h_r between two nodes (the
//!   macro runs one step ahead), terms interpolated linearly (or held, for study).
//! * Sensors by propagation: q̈ = q̈_free + G f_c and λ = λ_free + Λ f_c at every micro step
//!   (maps interpolated linearly across the macro step); positions and velocities by cubic Hermite
//!   interpolation of the ideal motion. No solve in the micro loop.
//!
//! As in the seeds, f_c acts through the journal and bearing centres: the moment of friction about
//! the journal centre (R_J F_T) is not propagated.

use crate::build::{BuildOptions, build_model};
use crate::channels::{Channel, Source, channel_sources};
use crate::record::Recorder;
use crate::run::{RunError, Summary, driver_period, sensor_points};
use crate::schema::Scenario;
use lash_contact::micro::{InterfaceModel, Interpolation, NodeTerms};
use lash_core::Ticks;
use lash_mech::{EffectiveTerms, Interface, Mechanism, Solver, assemble, effective_terms, velocity_analysis};

/// Step sizes and interpolation of the reduced model.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ReducedOptions {
    /// Macro step h_m [s].
    pub macro_step: f64,
    /// Micro step h_r [s].
    pub micro_step: f64,
    /// Interpolation of the macro terms across a macro step.
    pub interpolation: Interpolation,
}

impl Default for ReducedOptions {
    fn default() -> Self {
        Self { macro_step: 1e-3, micro_step: 1e-5, interpolation: Interpolation::Linear }
    }
}

/// The ideal motion and effective terms at one macro node.
struct Node {
    t: f64,
    q: Vec<f64>,
    qd: Vec<f64>,
    qdd: Vec<f64>,
    terms: EffectiveTerms,
    micro: NodeTerms,
}

/// A prepared reduced-model run.
pub struct ReducedRun {
    scenario: Scenario,
    options: ReducedOptions,
    cut: Mechanism,
    ideal: Mechanism,
    interface: Interface,
    model: InterfaceModel,
    sources: Vec<(Channel, Source)>,
    selected: Vec<usize>,
}

impl ReducedRun {
    /// Prepares a run; refuses scenarios this build's reduced model does not cover.
    pub fn new(scenario: &Scenario, options: ReducedOptions) -> Result<Self, RunError> {
        let unsupported = |m: String| Err(RunError::Unsupported(m));
        if scenario.clearances.len() != 1 {
            return unsupported(format!(
                "the reduced model couples exactly one clearance joint; the scenario has {}",
                scenario.clearances.len()
            ));
        }
        let full = build_model(scenario, BuildOptions { ideal: false });
        let ideal = full.ideal_mechanism();
        if ideal.constraint_count() != ideal.coordinate_count() {
            return unsupported(format!(
                "the ideal mechanism has {} degrees of freedom; one-way coupling in this build needs a fully driven \
                 mechanism (two-way coupling is the next step)",
                ideal.coordinate_count() as i64 - ideal.constraint_count() as i64
            ));
        }
        let sim = &scenario.simulation;
        let ticks =
            |v: f64, what: &str| Ticks::from_seconds(v).map_err(|e| RunError::Unsupported(format!("{what}: {e}")));
        let (hm, hr) = (ticks(options.macro_step, "macro step")?, ticks(options.micro_step, "micro step")?);
        if hm.exact_ratio(hr).is_none() {
            return unsupported(format!(
                "macro step {} s is not a whole multiple of the micro step {} s",
                options.macro_step, options.micro_step
            ));
        }
        if ticks(sim.horizon, "horizon")?.exact_ratio(hm).is_none() {
            return unsupported(format!(
                "horizon {} s is not a whole multiple of the macro step {} s",
                sim.horizon, options.macro_step
            ));
        }
        if ticks(sim.output_interval, "output interval")?.exact_ratio(hr).is_none() {
            return unsupported(format!(
                "output interval {} s is not a whole multiple of the micro step {} s",
                sim.output_interval, options.micro_step
            ));
        }
        let joint = full.clearances[0].clone();
        let interface = Interface {
            journal_body: joint.journal_body,
            journal_point: joint.journal_point,
            bearing_body: joint.bearing_body,
            bearing_point: joint.bearing_point,
        };
        let sources = channel_sources(scenario, false);
        let selected = if scenario.output.channels.is_empty() {
            (0..sources.len()).collect()
        } else {
            (0..sources.len()).filter(|&k| scenario.output.channels.contains(&sources[k].0.name)).collect()
        };
        Ok(Self {
            scenario: scenario.clone(),
            options,
            cut: full.mechanism,
            ideal,
            interface,
            model: InterfaceModel::new(joint, options.interpolation),
            sources,
            selected,
        })
    }

    /// Header of the written columns (the same channels as the full model).
    pub fn header(&self) -> Vec<String> {
        std::iter::once("time [s]".to_string())
            .chain(self.selected.iter().map(|&k| format!("{} [{}]", self.sources[k].0.name, self.sources[k].0.unit)))
            .collect()
    }

    fn node(&self, t: f64, q_guess: &[f64], ideal: &mut Solver, cut: &mut Solver) -> Result<Node, RunError> {
        let mut q = q_guess.to_vec();
        assemble(&self.ideal, t, &mut q, ideal, 1e-13)
            .map_err(|e| RunError::Simulation { t, message: e.to_string() })?;
        let mut qd = vec![0.0; q.len()];
        velocity_analysis(&self.ideal, t, &q, &mut qd, ideal)
            .map_err(|e| RunError::Simulation { t, message: e.to_string() })?;
        let terms = effective_terms(&self.cut, cut, &self.interface, t, &q, &qd)
            .map_err(|e| RunError::Simulation { t, message: e.to_string() })?;
        let mut qdd = vec![0.0; q.len()];
        terms.accelerations(-terms.effective_force, &mut qdd);
        let omega = |b: lash_mech::BodyId| match b {
            lash_mech::BodyId::Body(k) => qd[3 * k + 2],
            lash_mech::BodyId::Ground => 0.0,
        };
        let micro = NodeTerms {
            time: t,
            mobility: terms.mobility,
            free_acceleration: terms.free_acceleration,
            journal_angular_velocity: omega(self.interface.journal_body),
            bearing_angular_velocity: omega(self.interface.bearing_body),
        };
        Ok(Node { t, q, qd, qdd, terms, micro })
    }

    /// Runs the horizon; rows go to `sink`, the fraction done to `progress`.
    pub fn execute(
        &mut self,
        sink: &mut dyn FnMut(&[f64]) -> Result<(), String>,
        progress: &mut dyn FnMut(f64),
    ) -> Result<Summary, RunError> {
        let sim = self.scenario.simulation.clone();
        let (hm, hr) = (self.options.macro_step, self.options.micro_step);
        let micro_per_macro = (hm / hr).round() as usize;
        let out_every = (sim.output_interval / hr).round() as usize;
        let macro_steps = (sim.horizon / hm).round() as usize;
        let t0 = sim.start_time;
        let n = self.cut.coordinate_count();
        let m = self.cut.constraint_count();
        let mut ideal_solver = Solver::new(&self.ideal);
        let mut cut_solver = Solver::new(&self.cut);
        let mut out_solver = Solver::new(&self.cut);
        let sensors = sensor_points(&self.scenario, &self.cut);
        let mut recorder = Recorder::new(&self.sources, &self.selected, sensors, 1);
        let (mut q, mut qd, mut lambda) = (vec![0.0; n], vec![0.0; n], vec![0.0; m]);

        let cpu0 = cpu_time::ThreadTime::now();
        let wall0 = std::time::Instant::now();
        let (q_guess, _) = lash_mech::kinematics::initial_guess(&self.ideal);
        let mut a = self.node(t0, &q_guess, &mut ideal_solver, &mut cut_solver)?;
        self.model.joint.in_contact = false;
        let mut contact = self.model.joint.evaluate_relative(
            lash_mech::Vec2::zeros(),
            lash_mech::Vec2::zeros(),
            a.micro.journal_angular_velocity,
            a.micro.bearing_angular_velocity,
            0.0,
        );
        // The sample at t0: journal centred, no contact force.
        self.output(&a, &a, 0.0, contact, &mut q, &mut qd, &mut lambda, &mut out_solver, &mut recorder, sink)
            .map_err(RunError::Output)?;
        let mut micro_steps = 0u64;
        for k in 0..macro_steps {
            let tb = t0 + (k + 1) as f64 * hm;
            let b = self.node(tb, &a.q, &mut ideal_solver, &mut cut_solver)?;
            for j in 0..micro_per_macro {
                let t = a.t + j as f64 * hr;
                contact = self.model.step(&a.micro, &b.micro, t, hr);
                micro_steps += 1;
                if !(contact.penetration <= 0.1 * self.model.joint.journal_radius)
                    || !contact.eccentricity_norm.is_finite()
                {
                    return Err(RunError::Simulation {
                        t: t + hr,
                        message: format!(
                            "penetration {:e} m of clearance joint {:?} in the micro model: the simulation blew up",
                            contact.penetration, self.model.joint.name
                        ),
                    });
                }
                if micro_steps as usize % out_every == 0 {
                    let theta = (j + 1) as f64 / micro_per_macro as f64;
                    self.output(
                        &a,
                        &b,
                        theta,
                        contact,
                        &mut q,
                        &mut qd,
                        &mut lambda,
                        &mut out_solver,
                        &mut recorder,
                        sink,
                    )
                    .map_err(RunError::Output)?;
                }
            }
            progress((k + 1) as f64 / macro_steps as f64);
            a = b;
        }
        let cpu = cpu0.elapsed().as_secs_f64();
        let wall = wall0.elapsed().as_secs_f64();
        let t_end = t0 + sim.horizon;
        let mut impacts = self.model.impacts.clone();
        impacts.extend(self.model.open_impacts(t_end));
        let events = 2 * self.model.impacts.len() as u64 + self.model.open_impacts(t_end).len() as u64;
        let c = &self.model.joint;
        let summary_c = recorder.clearance_summary(
            0,
            &c.name,
            c.radial_clearance(),
            impacts,
            sim.horizon,
            driver_period(&self.scenario),
        );
        Ok(Summary {
            scenario: self.scenario.name.clone(),
            model: "reduced",
            integrator: lash_ode::Method::Rk4 { step: hr },
            start_time: t0,
            horizon: sim.horizon,
            output_interval: sim.output_interval,
            samples: recorder.samples,
            cpu_time_s: cpu,
            wall_time_s: wall,
            steps: micro_steps,
            rejected_steps: 0,
            rhs_evaluations: 4 * micro_steps,
            events,
            max_constraint_error: recorder.max_constraint_error,
            channels: recorder.channel_stats(),
            clearances: vec![summary_c],
        })
    }

    /// One output sample at fraction `theta` of the macro step [a, b].
    #[allow(clippy::too_many_arguments)]
    fn output(
        &self,
        a: &Node,
        b: &Node,
        theta: f64,
        contact: lash_contact::ContactState,
        q: &mut [f64],
        qd: &mut [f64],
        lambda: &mut [f64],
        solver: &mut Solver,
        recorder: &mut Recorder<'_>,
        sink: &mut dyn FnMut(&[f64]) -> Result<(), String>,
    ) -> Result<(), String> {
        let h = b.t - a.t;
        let t = a.t + theta * h;
        let s = theta;
        let (h00, h10, h01, h11) = (
            2.0 * s * s * s - 3.0 * s * s + 1.0,
            s * s * s - 2.0 * s * s + s,
            -2.0 * s * s * s + 3.0 * s * s,
            s * s * s - s * s,
        );
        for k in 0..q.len() {
            q[k] = h00 * a.q[k] + h10 * h * a.qd[k] + h01 * b.q[k] + h11 * h * b.qd[k];
            qd[k] = h00 * a.qd[k] + h10 * h * a.qdd[k] + h01 * b.qd[k] + h11 * h * b.qdd[k];
        }
        let f = contact.force_on_journal;
        let lerp = |x: f64, y: f64| x + (y - x) * s;
        solver.set_state(&self.cut, t, q, qd);
        let (ta, tb) = (&a.terms, &b.terms);
        for k in 0..q.len() {
            solver.accelerations[k] = lerp(ta.free_accelerations[k], tb.free_accelerations[k])
                + lerp(ta.gain[0][k], tb.gain[0][k]) * f.x
                + lerp(ta.gain[1][k], tb.gain[1][k]) * f.y;
        }
        for r in 0..lambda.len() {
            lambda[r] = lerp(ta.free_lambda[r], tb.free_lambda[r])
                + lerp(ta.lambda_gain[0][r], tb.lambda_gain[0][r]) * f.x
                + lerp(ta.lambda_gain[1][r], tb.lambda_gain[1][r]) * f.y;
            solver.lambda[r] = lambda[r];
        }
        recorder.record(t, &self.cut, solver, &[contact], q, qd, sink)
    }
}
