//! The full model of a scenario (mechanism with its clearance joints, integrated as one stiff
//! system) as a [`Subsystem`]: the model behind the full-model FMU.
//!
//! Each `do_step(t, h)` integrates the scenario's own integrator (DOP853 by default, with event
//! location) from `t` to `t + h`, continuing with the step size the previous communication step
//! proposed, and samples every output channel of the scenario at `t + h` — the same channels, the
//! same computation as `lash run`. The model is closed (no inputs); its numbers are FMI
//! parameters through [`lash_scenario::parameters::WithParameters`].

use crate::record::Recorder;
use crate::run::sensor_points;
use crate::{BuildOptions, build_model};
use lash_contact::full_model::{FullModel, FullModelState};
use lash_core::subsystem::{Phase, element_count};
use lash_core::{
    Causality, SavedState, StepOutcome, Subsystem, SubsystemError, Ticks, ValueReference, Variability, Variable,
    VariableTable,
};
use lash_mech::{BodyId, Vec2};
use lash_scenario::channels::{Channel, Source, channel_sources};
use lash_scenario::schema::Scenario;

/// The full model of one scenario as a co-simulation subsystem; one output per channel.
pub struct FullSubsystem {
    name: String,
    model: FullModel,
    scenario: Scenario,
    sources: Vec<(Channel, Source)>,
    all: Vec<usize>,
    sensors: Vec<(BodyId, Vec2)>,
    variables: Vec<Variable>,
    outputs: Vec<f64>,
    y: Vec<f64>,
    time: Ticks,
    next_step: Option<f64>,
    phase: Phase,
    /// Integrator counters summed over the steps taken.
    pub stats: lash_ode::Stats,
}

struct Snapshot {
    model: FullModelState,
    y: Vec<f64>,
    time: Ticks,
    outputs: Vec<f64>,
    next_step: Option<f64>,
    phase: Phase,
}

impl FullSubsystem {
    /// The full model of a validated scenario.
    pub fn new(scenario: &Scenario) -> Result<Self, String> {
        let sources = channel_sources(scenario, false);
        let mut table = VariableTable::new();
        for (c, _) in &sources {
            table.add(
                c.name.clone(),
                Causality::Output,
                Variability::Continuous,
                c.unit,
                &format!("channel {} of the full model (as written by `lash run`)", c.name),
                &[],
                &[0.0],
            );
        }
        let model = build_model(scenario, BuildOptions::default());
        let sensors = sensor_points(scenario, &model.mechanism);
        Ok(Self {
            name: format!("{} full model", scenario.name),
            all: (0..sources.len()).collect(),
            outputs: vec![0.0; sources.len()],
            sources,
            sensors,
            model,
            scenario: scenario.clone(),
            variables: table.into_variables(),
            y: Vec::new(),
            time: Ticks(0),
            next_step: None,
            phase: Phase::Instantiated,
            stats: lash_ode::Stats::default(),
        })
    }

    /// Samples every channel at `(t, y)` into `outputs`.
    fn sample(&mut self, t: f64) -> Result<(), SubsystemError> {
        let n = self.model.mechanism.coordinate_count();
        let mut recorder = Recorder::new(&self.sources, &self.all, self.sensors.clone(), self.model.clearances.len());
        self.model.evaluate(t, &self.y).map_err(|e| SubsystemError::Simulation { t, message: e.to_string() })?;
        let (q, qd) = self.y.split_at(n);
        let outputs = &mut self.outputs;
        let mut sink = |row: &[f64]| {
            outputs.copy_from_slice(&row[1..]);
            Ok(())
        };
        recorder
            .record(t, &self.model.mechanism, &self.model.solver, &self.model.contacts, q, qd, &mut sink)
            .map_err(|message| SubsystemError::Simulation { t, message })
    }
}

impl Subsystem for FullSubsystem {
    fn name(&self) -> &str {
        &self.name
    }

    fn variables(&self) -> &[Variable] {
        &self.variables
    }

    fn setup(&mut self, start: Ticks, _stop: Option<Ticks>) -> Result<(), SubsystemError> {
        self.phase.require("setup", &[Phase::Instantiated, Phase::Configured])?;
        self.time = start;
        self.phase = Phase::Configured;
        Ok(())
    }

    fn initialize(&mut self) -> Result<(), SubsystemError> {
        self.phase.require("initialize", &[Phase::Configured])?;
        let t0 = self.time.seconds();
        self.y =
            self.model.initial_state(t0).map_err(|e| SubsystemError::Simulation { t: t0, message: e.to_string() })?;
        self.sample(t0)?;
        self.phase = Phase::Stepping;
        Ok(())
    }

    fn set_f64(&mut self, refs: &[ValueReference], _values: &[f64]) -> Result<(), SubsystemError> {
        match refs.first() {
            None => Ok(()),
            Some(&r) => match self.variables.get(r as usize) {
                Some(v) => Err(SubsystemError::BadValue { name: v.name.clone(), problem: "is an output".into() }),
                None => Err(SubsystemError::UnknownValueReference(r)),
            },
        }
    }

    fn get_f64(&self, refs: &[ValueReference], values: &mut [f64]) -> Result<(), SubsystemError> {
        let n = element_count(&self.variables, refs)?;
        if n != values.len() {
            return Err(SubsystemError::BadArguments(format!("{} values for {n} elements", values.len())));
        }
        for (v, &r) in values.iter_mut().zip(refs) {
            *v = self.outputs[r as usize];
        }
        Ok(())
    }

    fn do_step(&mut self, t: Ticks, h: Ticks) -> Result<StepOutcome, SubsystemError> {
        self.phase.require("do_step", &[Phase::Stepping])?;
        if t != self.time {
            return Err(SubsystemError::BadArguments(format!(
                "do_step from {} s but the model is at {} s",
                t.seconds(),
                self.time.seconds()
            )));
        }
        let (t0, t1) = (t.seconds(), Ticks(t.0 + h.0).seconds());
        let mut ignore = |_: &mut FullModel, _: f64, _: &[f64]| -> Result<(), String> { Ok(()) };
        let result = lash_ode::integrate_from(
            &self.scenario.simulation.integrator,
            &mut self.model,
            t0,
            &mut self.y,
            t1,
            t1 - t0,
            &mut ignore,
            self.next_step,
        );
        match result {
            Ok(stats) => {
                self.next_step = (stats.next_step > 0.0).then_some(stats.next_step);
                self.stats.steps += stats.steps;
                self.stats.rejected += stats.rejected;
                self.stats.rhs_evaluations += stats.rhs_evaluations;
                self.stats.events += stats.events;
            }
            Err(e) => {
                self.phase = Phase::Failed;
                let message = match self.model.take_error() {
                    Some(cause) => format!("{e} ({cause})"),
                    None => e.to_string(),
                };
                return Err(SubsystemError::Simulation { t: t0, message });
            }
        }
        self.time = Ticks(t.0 + h.0);
        if let Err(e) = self.sample(t1) {
            self.phase = Phase::Failed;
            return Err(e);
        }
        Ok(StepOutcome::Completed)
    }

    fn time(&self) -> Ticks {
        self.time
    }

    fn save_state(&self) -> Result<SavedState, SubsystemError> {
        Ok(SavedState(Box::new(Snapshot {
            model: self.model.snapshot(),
            y: self.y.clone(),
            time: self.time,
            outputs: self.outputs.clone(),
            next_step: self.next_step,
            phase: self.phase,
        })))
    }

    fn restore_state(&mut self, state: &SavedState) -> Result<(), SubsystemError> {
        let s = state
            .0
            .downcast_ref::<Snapshot>()
            .ok_or_else(|| SubsystemError::Other("the saved state is not a full-model state".into()))?;
        self.model.restore(&s.model);
        self.y.clone_from(&s.y);
        self.time = s.time;
        self.outputs.clone_from(&s.outputs);
        self.next_step = s.next_step;
        self.phase = s.phase;
        Ok(())
    }

    fn terminate(&mut self) -> Result<(), SubsystemError> {
        self.phase = Phase::Terminated;
        Ok(())
    }
}
