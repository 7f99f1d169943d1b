//! The full model of a scenario (mechanism with its clearance joints, integrated as one stiff
//! system) as a [`Subsystem`]: the model behind the full-model FMU, planar or spatial.
//!
//! Each `do_step(t, h)` integrates the scenario's own integrator (DOP853 by default, with event
//! location) from `t` to `t + h`, continuing with the step size the previous communication step
//! proposed, and samples every output channel of the scenario at `t + h` — the same channels, the
//! same computation as `lash run`. The model is closed (no inputs); its numbers are FMI
//! parameters through [`lash_scenario::parameters::WithParameters`].

use crate::record::Recorder;
use crate::run::sensor_points;
use crate::spatial::SpatialSampler;
use crate::{BuildOptions, build_model};
use lash_core::subsystem::{Phase, element_count};
use lash_core::{
    Causality, SavedState, StepOutcome, Subsystem, SubsystemError, Ticks, ValueReference, Variability, Variable,
    VariableTable,
};
use lash_full_model::SpatialFullModel;
use lash_full_model::full_model::FullModel;
use lash_mech::{BodyId, Vec2};
use lash_ode::{Method, OdeSystem};
use lash_scenario::AnyScenario;
use lash_scenario::channels::{Channel, Source, channel_sources};
use lash_scenario::spatial::{SpatialSource, spatial_channels};
use std::any::Any;

/// What the full-model subsystem needs of a model, planar or spatial.
trait FullEngine: Send {
    /// Consistent initial state at `t0`.
    fn initial_state(&mut self, t0: f64) -> Result<Vec<f64>, String>;
    /// Every channel at `(t, y)` into `outputs`.
    fn sample(&mut self, t: f64, y: &[f64], outputs: &mut [f64]) -> Result<(), String>;
    /// Integrates from `t0` to `t1` (first step `first_step`), events located.
    fn advance(
        &mut self,
        method: &Method,
        t0: f64,
        y: &mut [f64],
        t1: f64,
        first_step: Option<f64>,
    ) -> Result<lash_ode::Stats, String>;
    /// The model's history besides the state vector.
    fn snapshot(&self) -> Box<dyn Any + Send>;
    /// Returns to a [`FullEngine::snapshot`]; false when it is not this engine's.
    fn restore(&mut self, state: &dyn Any) -> bool;
}

/// A full model, planar or spatial, as the engine drives it.
trait Model: OdeSystem + Send + Sized {
    /// Its history besides the state vector.
    type Snapshot: Any + Send;
    /// Consistent initial state at `t0`.
    fn initial(&mut self, t0: f64) -> Result<Vec<f64>, String>;
    /// The cause the model kept of its last failed evaluation.
    fn cause(&mut self) -> Option<String>;
    /// Its history now.
    fn history(&self) -> Self::Snapshot;
    /// Returns to a [`Model::history`].
    fn go_back(&mut self, state: &Self::Snapshot);
}

/// Both full models carry the same inherent methods under these names.
macro_rules! full_model {
    ($model:ty, $snapshot:ty) => {
        impl Model for $model {
            type Snapshot = $snapshot;
            fn initial(&mut self, t0: f64) -> Result<Vec<f64>, String> {
                self.initial_state(t0).map_err(|e| e.to_string())
            }
            fn cause(&mut self) -> Option<String> {
                self.take_error().map(|e| e.to_string())
            }
            fn history(&self) -> Self::Snapshot {
                self.snapshot()
            }
            fn go_back(&mut self, state: &Self::Snapshot) {
                self.restore(state)
            }
        }
    };
}

full_model!(FullModel, lash_full_model::full_model::FullModelState);
full_model!(SpatialFullModel, lash_full_model::SpatialFullModelState);

/// How an engine reads every channel of its model at `(t, y)`.
trait Sampling<M>: Send {
    /// Every channel into `outputs`.
    fn sample(&mut self, model: &mut M, t: f64, y: &[f64], outputs: &mut [f64]) -> Result<(), String>;
}

/// A model and its sampling: the one [`FullEngine`] of both kinds.
struct Engine<M, S> {
    model: M,
    sampling: S,
}

impl<M: Model, S: Sampling<M>> FullEngine for Engine<M, S> {
    fn initial_state(&mut self, t0: f64) -> Result<Vec<f64>, String> {
        self.model.initial(t0)
    }

    fn sample(&mut self, t: f64, y: &[f64], outputs: &mut [f64]) -> Result<(), String> {
        self.sampling.sample(&mut self.model, t, y, outputs)
    }

    /// The error carries the model's own cause when it has one.
    fn advance(
        &mut self,
        method: &Method,
        t0: f64,
        y: &mut [f64],
        t1: f64,
        first_step: Option<f64>,
    ) -> Result<lash_ode::Stats, String> {
        let mut ignore = |_: &mut M, _: f64, _: &[f64]| -> Result<(), lash_core::BoxError> { Ok(()) };
        lash_ode::integrate_from(method, &mut self.model, t0, y, t1, t1 - t0, &mut ignore, first_step).map_err(|e| {
            let e = lash_core::error_chain(&e);
            match self.model.cause() {
                Some(cause) => format!("{e} ({cause})"),
                None => e,
            }
        })
    }

    fn snapshot(&self) -> Box<dyn Any + Send> {
        Box::new(self.model.history())
    }

    fn restore(&mut self, state: &dyn Any) -> bool {
        state.downcast_ref().map(|s| self.model.go_back(s)).is_some()
    }
}

/// The planar model's channels, through the recorder of a run.
struct PlanarSampling {
    sources: Vec<(Channel, Source)>,
    all: Vec<usize>,
    sensors: Vec<(BodyId, Vec2)>,
    stresses: Vec<Option<std::sync::Arc<lash_bush::InterfaceStress>>>,
}

impl Sampling<FullModel> for PlanarSampling {
    fn sample(&mut self, model: &mut FullModel, t: f64, y: &[f64], outputs: &mut [f64]) -> Result<(), String> {
        let n = model.mechanism.coordinate_count();
        let mut recorder = Recorder::new(&self.sources, &self.all, self.sensors.clone(), model.contact_count())
            .with_stresses(&self.stresses);
        model.evaluate(t, y).map_err(|e| e.to_string())?;
        let (q, qd) = (&y[..n], &y[n..2 * n]);
        let mut sink = |row: &[f64]| {
            outputs.copy_from_slice(&row[1..]);
            Ok(())
        };
        recorder.record(t, model, q, qd, &mut sink).map_err(|e| e.to_string())
    }
}

/// The spatial model's channels, through its sampler.
struct SpatialSampling {
    sources: Vec<(Channel, SpatialSource)>,
    sampler: SpatialSampler,
}

impl Sampling<SpatialFullModel> for SpatialSampling {
    fn sample(&mut self, model: &mut SpatialFullModel, t: f64, y: &[f64], outputs: &mut [f64]) -> Result<(), String> {
        model.evaluate(t, y).map_err(|e| e.to_string())?;
        self.sampler.sample(model, &self.sources, outputs);
        Ok(())
    }
}

/// The full model of one scenario (planar or spatial) as a co-simulation subsystem; one output
/// per channel.
pub struct FullSubsystem {
    name: String,
    engine: Box<dyn FullEngine>,
    method: Method,
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
    model: Box<dyn Any + Send>,
    y: Vec<f64>,
    time: Ticks,
    outputs: Vec<f64>,
    next_step: Option<f64>,
    phase: Phase,
}

impl FullSubsystem {
    /// The full model of a validated scenario.
    pub fn new(scenario: &AnyScenario) -> Self {
        let (engine, channels, name, method): (Box<dyn FullEngine>, Vec<Channel>, &str, Method) = match scenario {
            AnyScenario::Planar(s) => {
                let sources = channel_sources(s, false);
                let model = build_model(s, BuildOptions::default());
                let sensors = sensor_points(s, &model.mechanism);
                let channels = sources.iter().map(|(c, _)| c.clone()).collect();
                let all = (0..sources.len()).collect();
                let stresses = crate::build::interface_stresses(s);
                (
                    Box::new(Engine { model, sampling: PlanarSampling { sources, all, sensors, stresses } }),
                    channels,
                    &s.name,
                    s.simulation.integrator,
                )
            }
            AnyScenario::Spatial(s) => {
                let sources = spatial_channels(s, false);
                let model = crate::build_spatial(s, false);
                let sampler = SpatialSampler::new(s, &model);
                let channels = sources.iter().map(|(c, _)| c.clone()).collect();
                (
                    Box::new(Engine { model, sampling: SpatialSampling { sources, sampler } }),
                    channels,
                    &s.name,
                    s.simulation.integrator,
                )
            }
        };
        let mut table = VariableTable::new();
        for c in &channels {
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
        Self {
            name: format!("{name} full model"),
            engine,
            method,
            outputs: vec![0.0; channels.len()],
            variables: table.into_variables(),
            y: Vec::new(),
            time: Ticks(0),
            next_step: None,
            phase: Phase::Instantiated,
            stats: lash_ode::Stats::default(),
        }
    }

    /// Samples every channel at `(t, y)` into `outputs`.
    fn sample(&mut self, t: f64) -> Result<(), SubsystemError> {
        self.engine.sample(t, &self.y, &mut self.outputs).map_err(|message| SubsystemError::Simulation { t, message })
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
        self.y = self.engine.initial_state(t0).map_err(|message| SubsystemError::Simulation { t: t0, message })?;
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
        let result = self.engine.advance(&self.method, t0, &mut self.y, t1, self.next_step);
        match result {
            Ok(stats) => {
                self.next_step = (stats.next_step > 0.0).then_some(stats.next_step);
                self.stats.add(&stats);
            }
            Err(message) => {
                self.phase = Phase::Failed;
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
            model: self.engine.snapshot(),
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
        if !self.engine.restore(s.model.as_ref()) {
            return Err(SubsystemError::Other("the saved state is not this model's".into()));
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Steps `sub` `count` times by `h` from its current time; the outputs after each step.
    fn steps(sub: &mut FullSubsystem, count: usize, h: Ticks) -> Vec<Vec<f64>> {
        let refs: Vec<ValueReference> = (0..sub.variables().len() as ValueReference).collect();
        (0..count)
            .map(|_| {
                assert_eq!(sub.do_step(sub.time(), h).unwrap(), StepOutcome::Completed);
                let mut v = vec![0.0; refs.len()];
                sub.get_f64(&refs, &mut v).unwrap();
                v
            })
            .collect()
    }

    /// Both kinds of full model (planar A, spatial E) repeat a stretch of steps bit for bit after a
    /// restore, with contacts inside it (the contact modes and impacts are part of the state).
    #[test]
    fn a_restored_full_model_repeats_its_steps_exactly() {
        for name in ["A", "E"] {
            let scenario = lash_scenario::any_by_name_or_file(name).unwrap();
            let mut sub = FullSubsystem::new(&scenario);
            sub.setup(Ticks::ZERO, None).unwrap();
            sub.initialize().unwrap();
            let h = Ticks::from_seconds(1e-4).unwrap();
            steps(&mut sub, 50, h);
            let saved = sub.save_state().unwrap();
            let first = steps(&mut sub, 150, h);
            sub.restore_state(&saved).unwrap();
            let again = steps(&mut sub, 150, h);
            assert_eq!(first, again, "{name}");
            let force = sub.variables().iter().position(|v| v.name.ends_with(".force")).unwrap();
            assert!(first.iter().any(|v| v[force] > 0.0), "{name}: contacts inside the repeated stretch");
        }
    }
}
