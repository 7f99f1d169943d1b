//! A loaded system and its master.

use crate::spec::{Algorithm, ElementSource, ElementSpec, InterfaceSpec, SystemSpec};
use lash_core::{Causality, StopReason, Subsystem, SubsystemError, Ticks, ValueKind, ValueReference, Variable};
use lash_orchestrate::{
    Algorithm as _, Carried, ConnectedMaster, Connection, Element, Initialization, InterfaceMaster, MasterError,
    MasterOptions, Observer, Ordering, Port, Signal, StepError,
};
use std::path::Path;

/// Why a system cannot be built or run.
#[derive(Debug, thiserror::Error)]
pub enum SystemError {
    /// Bad input: the message names the field (`elements[1].fmu: …`).
    #[error("{0}")]
    Input(String),
    /// A subsystem failed while running, naming the element and the time (when the master
    /// knows it).
    #[error("{}element {element:?}: {message}", t.map(|t| format!("at t = {t} s, ")).unwrap_or_default())]
    Simulation {
        /// Time \[s\].
        t: Option<f64>,
        /// Element name.
        element: String,
        /// What it said.
        message: String,
    },
    /// The sink refused a row.
    #[error("output: {0}")]
    Output(lash_core::BoxError),
}

/// A parameter's value as it will be set: numbers (any numeric kind), text (a String) or bytes
/// (a Binary, given as hexadecimal text).
#[derive(Debug, Clone)]
enum Setting {
    Numbers(Vec<f64>),
    Text(String),
    Bytes(Vec<u8>),
}

/// Bytes from hexadecimal text (`"0a1B ff"`: pairs of hex digits, spaces and an optional `0x`
/// ignored).
fn hex_bytes(text: &str) -> Result<Vec<u8>, String> {
    let digits: Vec<u8> = text.trim().trim_start_matches("0x").bytes().filter(|b| !b.is_ascii_whitespace()).collect();
    if !digits.len().is_multiple_of(2) {
        return Err(format!("{text:?}: an odd number of hexadecimal digits"));
    }
    digits
        .chunks(2)
        .map(|pair| {
            std::str::from_utf8(pair)
                .ok()
                .and_then(|p| u8::from_str_radix(p, 16).ok())
                .ok_or_else(|| format!("{text:?}: not hexadecimal bytes"))
        })
        .collect()
}

/// The values the system file gives an element's parameters: (value reference, name, value).
type Parameters = Vec<(ValueReference, String, Setting)>;

/// A run that a subsystem ended before the stop time, without an error.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Stop {
    /// The element that stopped the run.
    pub element: String,
    /// Time the element reached \[s\].
    pub reached_s: f64,
    /// Time of the last recorded row \[s\].
    pub last_row_s: f64,
    /// What happened, in words.
    pub reason: String,
    /// True when the element asked to stop (FMI terminate); false for an early return.
    pub requested: bool,
}

/// What a run did.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RunSummary {
    /// System name.
    pub system: String,
    /// Communication steps completed by every element.
    pub steps: u64,
    /// Rows recorded.
    pub samples: u64,
    /// Wall time \[s\].
    pub wall_time_s: f64,
    /// Set when an element ended the run before the stop time.
    pub stopped: Option<Stop>,
}

/// A system ready to run.
pub struct System {
    name: String,
    elements: Vec<Element>,
    parameters: Vec<Parameters>,
    connections: Vec<Connection>,
    start: Ticks,
    stop: Ticks,
    step: Ticks,
    algorithm: Algorithm,
    initialization: crate::spec::Initialization,
    output_every: i64,
    channels: Vec<Port>,
    header: Vec<String>,
    interface: Option<InterfacePlan>,
}

/// The interface master's elements, options and signals.
struct InterfacePlan {
    mechanism: usize,
    clearance: usize,
    options: MasterOptions,
    signals: Vec<Signal>,
    units: Vec<String>,
    interval: Ticks,
}

fn ticks(field: &str, seconds: f64) -> Result<Ticks, SystemError> {
    Ticks::from_seconds(seconds).map_err(|e| SystemError::Input(format!("{field}: {e}")))
}

/// A user error (exit 2) with its message.
fn bad(message: String) -> SystemError {
    SystemError::Input(message)
}

/// `element.variable` split at the first dot.
fn split<'a>(field: &str, name: &'a str) -> Result<(&'a str, &'a str), SystemError> {
    name.split_once('.')
        .ok_or_else(|| SystemError::Input(format!("{field}: {name:?} is not of the form element.variable")))
}

/// How an element that names an FMU is run.
#[derive(Debug, Clone, Copy)]
enum Isolation {
    /// In this process.
    InProcess,
    /// In a child process, each call waiting at most this long.
    Child(std::time::Duration),
}

fn load(source: &ElementSource, name: &str, cache: &Path, isolation: Isolation) -> Result<Box<dyn Subsystem>, String> {
    if let (ElementSource::Fmu(path), Isolation::Child(timeout)) = (source, isolation) {
        let host = std::env::current_exe().map_err(|e| format!("the lash executable: {e}"))?;
        let isolated = lash_fmi::isolate::IsolatedFmu::spawn(&host, path, cache, name, timeout)
            .map_err(|e| format!("{}: {}", path.display(), lash_core::error_chain(&e)))?;
        return Ok(Box::new(isolated));
    }
    Ok(match source {
        ElementSource::Fmu(path) => {
            Box::new(lash_fmi::import::ImportedFmu::open(path, cache, name).map_err(|e| e.to_string())?)
        }
        ElementSource::Plugin(path) => {
            Box::new(lash_fmi::import::ImportedFmu::open_plugin(path, name).map_err(|e| e.to_string())?)
        }
        ElementSource::Builtin(id, scenario) => {
            let scenario = match scenario {
                Some(s) => lash_scenario::any_by_name_or_file(s).map_err(|e| format!("scenario: {e}"))?,
                None => lash_scenario::AnyScenario::Planar(
                    lash_catalog::default_scenario().map_err(|e| lash_core::error_chain(&e))?,
                ),
            };
            builtin(id, &scenario)?
        }
    })
}

/// A built-in subsystem of `scenario` by model identifier.
fn builtin(id: &str, scenario: &lash_scenario::AnyScenario) -> Result<Box<dyn Subsystem>, String> {
    let text = |e: lash_catalog::CatalogError| lash_core::error_chain(&e);
    Ok(match id {
        lash_catalog::INTERFACE => Box::new(lash_catalog::interface(scenario).map_err(text)?),
        lash_catalog::MECHANISM => Box::new(lash_catalog::mechanism(scenario).map_err(text)?),
        lash_catalog::FULL => Box::new(lash_catalog::full(scenario).map_err(text)?),
        other => {
            return Err(format!(
                "no built-in subsystem {other:?} (built-ins: {}, {}, {})",
                lash_catalog::INTERFACE,
                lash_catalog::MECHANISM,
                lash_catalog::FULL
            ));
        }
    })
}

/// The system's start, stop, step and output interval in ticks: the step positive and dividing
/// the span, the interval positive.
fn time_grid(spec: &SystemSpec) -> Result<(Ticks, Ticks, Ticks, Ticks), SystemError> {
    let start = ticks("start", spec.start)?;
    let stop = ticks("stop", spec.stop)?;
    let step = ticks("step", spec.step)?;
    if step.0 <= 0 {
        return Err(bad(format!("step: must be > 0, got {}", spec.step)));
    }
    if stop.0 <= start.0 {
        return Err(bad(format!("stop: must exceed start ({} s), got {}", spec.start, spec.stop)));
    }
    if (stop.0 - start.0) % step.0 != 0 {
        return Err(bad(format!("step: {} s does not divide stop − start = {} s", spec.step, spec.stop - spec.start)));
    }
    let interval = ticks("output.interval", spec.output.interval.unwrap_or(spec.step))?;
    if interval.0 <= 0 {
        return Err(bad(format!("output.interval: must be > 0, got {} s", interval.seconds())));
    }
    Ok((start, stop, step, interval))
}

/// Every element of `spec` loaded (names unique and without dots, decimation ≥ 1, isolation
/// settings valid), its variable table checked, its structural parameters configured, with its
/// parameter settings.
fn load_elements(spec: &SystemSpec, base: &Path, cache: &Path) -> Result<(Vec<Element>, Vec<Parameters>), SystemError> {
    let mut elements: Vec<Element> = Vec::new();
    let mut element_parameters: Vec<Parameters> = Vec::new();
    for (k, e) in spec.elements.iter().enumerate() {
        let field = format!("elements[{k}]");
        if e.name.is_empty() || e.name.contains('.') {
            return Err(bad(format!("{field}.name: {:?} must be non-empty and without dots", e.name)));
        }
        if elements.iter().any(|x| x.name == e.name) {
            return Err(bad(format!("{field}.name: {:?} is used twice", e.name)));
        }
        if e.decimation == 0 {
            return Err(bad(format!("{field}.decimation: must be ≥ 1")));
        }
        let source = e.source(base).map_err(|m| bad(format!("{field}: {m}")))?;
        let isolation = match (e.isolate, e.timeout, &source) {
            (false, None, _) => Isolation::InProcess,
            (false, Some(_), _) => return Err(bad(format!("{field}.timeout: only with isolate = true"))),
            (true, _, ElementSource::Fmu(_)) => {
                let seconds = e.timeout.unwrap_or(60.0);
                let timeout =
                    std::time::Duration::try_from_secs_f64(seconds).ok().filter(|t| !t.is_zero()).ok_or_else(|| {
                        bad(format!("{field}.timeout: must be a positive number of seconds, got {seconds}"))
                    })?;
                Isolation::Child(timeout)
            }
            (true, _, _) => return Err(bad(format!("{field}.isolate: only FMU elements run in a child process"))),
        };
        let model = load(&source, &e.name, cache, isolation).map_err(|m| bad(format!("{field} ({}): {m}", e.name)))?;
        lash_core::check_variable_table(model.variables()).map_err(|m| bad(format!("{field} ({}): {m}", e.name)))?;
        let mut model = model;
        let structural = configure_structural(&field, e, &mut *model)?;
        let parameters = parameter_settings(&field, k, e, &*model, &structural)?;
        elements.push(Element { name: e.name.clone(), model, decimation: i64::from(e.decimation) });
        element_parameters.push(parameters);
    }
    Ok((elements, element_parameters))
}

impl System {
    /// Loads every element of `spec` (paths relative to `base`; FMUs unpacked under `cache`) and
    /// checks names, connections, parameters, steps and channels. Every error names its field.
    pub fn new(spec: &SystemSpec, base: &Path, cache: &Path) -> Result<Self, SystemError> {
        if spec.elements.is_empty() {
            return Err(bad("elements: a system needs at least one element".into()));
        }
        let (start, stop, step, interval) = time_grid(spec)?;
        let (elements, element_parameters) = load_elements(spec, base, cache)?;
        if spec.algorithm == Algorithm::Interface {
            if spec.initialization != crate::spec::Initialization::Ordered {
                return Err(bad(
                    "initialization: only with algorithm = \"gauss_seidel\" or \"jacobi\" (the interface master initialises its two elements itself)".into(),
                ));
            }
            let plan = interface_plan(spec, &elements, start, stop, step, interval)?;
            let header = std::iter::once("time [s]".to_string())
                .chain(plan.signals.iter().zip(&plan.units).map(|(s, u)| format!("{} [{u}]", s.name())))
                .collect();
            return Ok(Self {
                name: spec.name.clone(),
                elements,
                parameters: element_parameters,
                connections: Vec::new(),
                start,
                stop,
                step,
                algorithm: spec.algorithm,
                initialization: spec.initialization,
                output_every: 1,
                channels: Vec::new(),
                header,
                interface: Some(plan),
            });
        }
        if interval.0 % step.0 != 0 {
            return Err(bad(format!(
                "output.interval: must be a positive multiple of the step {} s, got {} s",
                spec.step,
                interval.seconds()
            )));
        }
        if spec.interface.is_some() {
            return Err(bad("interface: only with algorithm = \"interface\"".into()));
        }
        let connections = connect(spec, &elements)?;
        let (channels, header) = recorded(spec, &elements)?;
        Ok(Self {
            name: spec.name.clone(),
            elements,
            parameters: element_parameters,
            connections,
            start,
            stop,
            step,
            algorithm: spec.algorithm,
            initialization: spec.initialization,
            output_every: interval.0 / step.0,
            channels,
            header,
            interface: None,
        })
    }

    /// Column names with units, time first.
    pub fn header(&self) -> &[String] {
        &self.header
    }

    /// Element `k`'s subsystem.
    /// Rows the run records (its first sample included), from the start, stop and output
    /// interval: what an output writer sizes before the run starts.
    pub fn samples(&self) -> u64 {
        let interval = self.interface.as_ref().map_or(self.step.0 * self.output_every, |plan| plan.interval.0);
        u64::try_from((self.stop.0 - self.start.0) / interval.max(1)).map_or(u64::MAX, |n| n.saturating_add(1))
    }

    /// Element `k`'s subsystem.
    pub fn element(&self, k: usize) -> &dyn Subsystem {
        &*self.elements[k].model
    }

    fn fail(&self, k: usize, t: Ticks, e: SubsystemError) -> SystemError {
        SystemError::Simulation { t: Some(t.seconds()), element: self.elements[k].name.clone(), message: e.to_string() }
    }

    /// An element's refused initialization: the user's to fix (exit 2) when the system file gave
    /// it parameter values (they are the likely cause, and the message lists them), a failure
    /// otherwise.
    fn refused_initialization(&self, k: usize, t: Ticks, e: SubsystemError) -> SystemError {
        let given: Vec<&str> = self.parameters[k].iter().map(|(_, n, _)| n.as_str()).collect();
        if given.is_empty() && !matches!(e, SubsystemError::BadValue { .. }) {
            return self.fail(k, t, e);
        }
        SystemError::Input(format!(
            "elements[{k}].parameters (element {:?}, given {given:?}): initialization refused: {e}",
            self.elements[k].name
        ))
    }

    /// Sets every element up for the run and gives it its parameter values.
    fn set_up(&mut self) -> Result<(), SystemError> {
        let (start, stop) = (self.start, self.stop);
        for k in 0..self.elements.len() {
            if let Err(e) = self.elements[k].model.setup(start, Some(stop)) {
                return Err(self.fail(k, start, e));
            }
            for p in 0..self.parameters[k].len() {
                let (vr, name, setting) = self.parameters[k][p].clone();
                let result = match &setting {
                    Setting::Numbers(values) => self.elements[k].model.set_f64(&[vr], values),
                    Setting::Text(text) => self.elements[k].model.set_string(vr, text),
                    Setting::Bytes(bytes) => self.elements[k].model.set_binary(vr, bytes),
                };
                if let Err(e) = result {
                    // A refused parameter value is the user's to fix (exit 2), named by its field.
                    let shown = match &setting {
                        Setting::Numbers(v) => format!("{v:?}"),
                        Setting::Text(t) => format!("{t:?}"),
                        Setting::Bytes(b) => format!("{} bytes", b.len()),
                    };
                    return Err(SystemError::Input(format!(
                        "elements[{k}].parameters.{name} (element {:?}): {shown} refused: {e}",
                        self.elements[k].name
                    )));
                }
            }
        }
        Ok(())
    }

    /// Sets up and parameterises every element, then hands the run to the coupling algorithm
    /// (Gauss–Seidel, Jacobi or the interface master) of lash-orchestrate; `sink` receives each
    /// recorded row (time first).
    pub fn run(
        &mut self,
        sink: &mut dyn FnMut(&[f64]) -> Result<(), lash_core::BoxError>,
    ) -> Result<RunSummary, SystemError> {
        let wall = std::time::Instant::now();
        if self.interface.is_some() {
            return self.run_interface(sink, wall);
        }
        self.set_up()?;
        let (start, stop, step) = (self.start, self.stop, self.step);
        let ordering = match self.algorithm {
            Algorithm::Jacobi => Ordering::Jacobi,
            _ => Ordering::GaussSeidel,
        };
        let names = self.header[1..].to_vec();
        let mut rows = Rows { sink, row: Vec::new(), samples: 0, last: start };
        let result = {
            let mut master = ConnectedMaster::new(
                &mut self.elements,
                &mut self.connections,
                self.channels.clone(),
                names,
                start,
                stop,
                step,
                ordering,
            )
            .map_err(|e| SystemError::Input(e.to_string()))?
            .with_initialization(match self.initialization {
                crate::spec::Initialization::Ordered => Initialization::Ordered,
                crate::spec::Initialization::Iterated => Initialization::Iterated,
            });
            // An input fed element by element keeps the value the system gave it elsewhere.
            for (k, parameters) in self.parameters.iter().enumerate() {
                for (vr, _, setting) in parameters {
                    if let Setting::Numbers(values) = setting {
                        master.preset_input(k, *vr, values);
                    }
                }
            }
            let mut observers: [(&mut dyn Observer, Ticks); 1] = [(&mut rows, Ticks(step.0 * self.output_every))];
            master.run(&mut observers)
        };
        let stats = match result {
            Ok(stats) => stats,
            Err(MasterError::Initialization { element, source, .. }) => {
                return Err(self.refused_initialization(element, start, source));
            }
            Err(MasterError::Element { name, t, source }) => {
                return Err(SystemError::Simulation {
                    t: Some(t.seconds()),
                    element: name,
                    message: source.to_string(),
                });
            }
            Err(MasterError::Observer(m)) => return Err(SystemError::Output(m)),
            Err(other) => {
                return Err(SystemError::Simulation { t: None, element: "master".into(), message: other.to_string() });
            }
        };
        let stopped = stats.stopped.map(|(element, reason)| stop_of(element, reason, rows.last));
        Ok(RunSummary {
            system: self.name.clone(),
            steps: stats.macro_steps,
            samples: rows.samples,
            wall_time_s: wall.elapsed().as_secs_f64(),
            stopped,
        })
    }
}

/// The system's one observer: rows (time first) into the sink.
struct Rows<'s> {
    sink: &'s mut dyn FnMut(&[f64]) -> Result<(), lash_core::BoxError>,
    row: Vec<f64>,
    samples: u64,
    last: Ticks,
}

impl Observer for Rows<'_> {
    fn observe(&mut self, t: Ticks, signals: &[f64]) -> Result<(), lash_core::BoxError> {
        self.last = t;
        self.row.clear();
        self.row.push(t.seconds());
        self.row.extend_from_slice(signals);
        self.samples += 1;
        (self.sink)(&self.row)
    }
}

/// The summary's account of a run that `element` ended early.
fn stop_of(element: String, reason: StopReason, last_row: Ticks) -> Stop {
    let (reached, requested) = match reason {
        StopReason::Requested { reached } => (reached, true),
        StopReason::EarlyReturn { reached } => (reached, false),
    };
    Stop {
        element,
        reached_s: reached.seconds(),
        last_row_s: last_row.seconds(),
        reason: reason.to_string(),
        requested,
    }
}

impl System {
    /// The interface master's run: both elements set up and parameterised here, initialised and
    /// stepped by [`InterfaceMaster`].
    fn run_interface(
        &mut self,
        sink: &mut dyn FnMut(&[f64]) -> Result<(), lash_core::BoxError>,
        wall: std::time::Instant,
    ) -> Result<RunSummary, SystemError> {
        let (start, stop) = (self.start, self.stop);
        self.set_up()?;
        let plan = self.interface.as_ref().expect("checked");
        let (m, c, options, signals, interval) =
            (plan.mechanism, plan.clearance, plan.options, plan.signals.clone(), plan.interval);
        let names = [self.elements[m].name.clone(), self.elements[c].name.clone()];
        let (first, second) = self.elements.split_at_mut(m.max(c));
        let (macro_el, micro_el) =
            if m < c { (&mut first[m], &mut second[0]) } else { (&mut second[0], &mut first[c]) };
        let mut master = InterfaceMaster::new(&mut *macro_el.model, &mut *micro_el.model, options, signals)
            .map_err(|e| SystemError::Input(format!("interface: {e}")))?;
        let mut rows = Rows { sink, row: Vec::new(), samples: 0, last: start };
        let mut observers: [(&mut dyn Observer, Ticks); 1] = [(&mut rows, interval)];
        let element = |who: &str| if who == "macro" { names[0].clone() } else { names[1].clone() };
        let stats = master.run(&mut observers).map_err(|e| match e {
            MasterError::Subsystem { subsystem, source } => SystemError::Simulation {
                t: match &source {
                    SubsystemError::Simulation { t, .. } => Some(*t),
                    _ => None,
                },
                element: element(subsystem),
                message: source.to_string(),
            },
            MasterError::Observer(m) => SystemError::Output(m),
            other => {
                SystemError::Simulation { t: None, element: "interface master".into(), message: other.to_string() }
            }
        })?;
        let (samples, last_row) = (rows.samples, rows.last);
        let steps = stats.macro_steps.min(((stop.0 - start.0) / self.step.0) as u64);
        let stopped = stats.stopped.map(|(who, reason)| stop_of(element(&who), reason, last_row));
        Ok(RunSummary { system: self.name.clone(), steps, samples, wall_time_s: wall.elapsed().as_secs_f64(), stopped })
    }
}

/// Checks an interface master's elements and signals.
fn interface_plan(
    spec: &SystemSpec,
    elements: &[Element],
    start: Ticks,
    stop: Ticks,
    step: Ticks,
    interval: Ticks,
) -> Result<InterfacePlan, SystemError> {
    let i: &InterfaceSpec = spec
        .interface
        .as_ref()
        .ok_or_else(|| bad("interface: algorithm = \"interface\" needs an [interface] table".into()))?;
    if !spec.connections.is_empty() {
        return Err(bad("connections: the interface master couples its two elements itself; give none".into()));
    }
    if elements.len() != 2 {
        return Err(bad(format!(
            "elements: the interface master couples exactly two elements, got {}",
            elements.len()
        )));
    }
    let index = |field: &str, name: &str| {
        elements
            .iter()
            .position(|e| e.name == name)
            .ok_or_else(|| bad(format!("interface.{field}: no element {name:?}")))
    };
    let (mechanism, clearance) = (index("mechanism", &i.mechanism)?, index("clearance", &i.clearance)?);
    if mechanism == clearance {
        return Err(bad("interface: mechanism and clearance must be different elements".into()));
    }
    let micro_step = ticks("interface.micro_step", i.micro_step)?;
    let options = MasterOptions {
        start,
        stop,
        macro_step: step,
        micro_step,
        interpolation: i.interpolation,
        coupling: i.coupling,
        execution: i.execution,
    };
    // The master's own check, reported against the file's fields.
    let field = |e: &StepError| match e {
        StepError::NotWholeMicroSteps { .. } | StepError::TooManyMicroSteps { .. } => "interface.micro_step",
        StepError::NotWholeMacroSteps { .. } => "step",
        StepError::OutputInterval { .. } => "output.interval",
        StepError::TwoWayThreaded => "interface.coupling",
    };
    options.check().and_then(|_| options.check_sampling(interval)).map_err(|e| bad(format!("{}: {e}", field(&e))))?;
    let (signals, units) = interface_signals(i, elements, (mechanism, clearance))?;
    Ok(InterfacePlan { mechanism, clearance, options, signals, units, interval })
}

/// The interface master's signals of `i` (each a propagated, micro or macro variable checked
/// against its element), with their units.
fn interface_signals(
    i: &InterfaceSpec,
    elements: &[Element],
    (mechanism, clearance): (usize, usize),
) -> Result<(Vec<Signal>, Vec<String>), SystemError> {
    let has = |k: usize, name: &str| find(elements[k].model.variables(), name).map(|v| v.len());
    let mut signals = Vec::new();
    let mut units = Vec::new();
    let unit =
        |k: usize, name: &str| find(elements[k].model.variables(), name).map(|v| v.unit.clone()).unwrap_or_default();
    for (n, sig) in i.signals.iter().enumerate() {
        let field = format!("interface.signals[{n}]");
        let name = sig.name.clone();
        let e = sig.element;
        let need = |k: usize, var: &str, len: usize| -> Result<(), SystemError> {
            match has(k, var) {
                None => Err(bad(format!("{field}: element {:?} has no variable {var:?}", elements[k].name))),
                Some(l) if l < len => Err(bad(format!("{field}: {var} has {l} element(s), element {e} asked"))),
                Some(_) => Ok(()),
            }
        };
        let signal = match (&sig.propagated, &sig.micro, &sig.macro_variable) {
            (Some(base), None, None) => {
                let (free, gain) = (format!("{base}_free"), format!("{base}_gain"));
                need(mechanism, &free, e + 1)?;
                // One row of gains (one per load: contact forces, then friction forces) per
                // element of the free value.
                let loads = has(mechanism, &gain).unwrap_or(0) / has(mechanism, &free).unwrap_or(1).max(1);
                need(mechanism, &gain, (e + 1) * loads.max(1))?;
                units.push(unit(mechanism, &free));
                Signal::Propagated { name, free: (free, e), gain: (gain, e * loads) }
            }
            (None, Some(var), None) => {
                need(clearance, var, e + 1)?;
                units.push(unit(clearance, var));
                Signal::Micro { name, variable: var.clone(), element: e }
            }
            (None, None, Some(var)) => {
                need(mechanism, var, e + 1)?;
                units.push(unit(mechanism, var));
                Signal::Macro { name, variable: var.clone(), element: e, derivative: None }
            }
            _ => return Err(bad(format!("{field}: give exactly one of propagated, micro, macro"))),
        };
        signals.push(signal);
    }
    Ok((signals, units))
}

/// Sets an element's structural parameters (FMI 3.0 configuration mode) before anything else:
/// they size arrays, so the other parameters and every connection are checked against the new
/// shapes. Returns their names.
fn configure_structural(field: &str, e: &ElementSpec, model: &mut dyn Subsystem) -> Result<Vec<String>, SystemError> {
    let (mut refs, mut values, mut names): (Vec<ValueReference>, Vec<f64>, Vec<String>) =
        (Vec::new(), Vec::new(), Vec::new());
    for (pname, value) in &e.parameters {
        let Some(v) = find(model.variables(), pname) else { continue };
        if v.causality != Causality::StructuralParameter {
            continue;
        }
        let number = match value.values().as_deref() {
            Some([x]) => *x,
            _ => {
                return Err(bad(format!("{field}.parameters.{pname}: a structural parameter takes one number")));
            }
        };
        v.kind.check(number).map_err(|p| bad(format!("{field}.parameters.{pname}: {p}")))?;
        refs.push(v.value_reference);
        values.push(number);
        names.push(pname.clone());
    }
    if !refs.is_empty() {
        model.configure(&refs, &values).map_err(|err| {
            bad(format!("{field}.parameters ({}): structural parameters {names:?} refused: {err}", e.name))
        })?;
    }
    Ok(names)
}

/// An element's parameter (and input) settings from the system file, each checked against its
/// variable; `structural` ones are already set.
fn parameter_settings(
    field: &str,
    k: usize,
    e: &ElementSpec,
    model: &dyn Subsystem,
    structural: &[String],
) -> Result<Parameters, SystemError> {
    let mut parameters = Vec::new();
    for (pname, value) in &e.parameters {
        if structural.contains(pname) {
            continue;
        }
        let (v, port) = resolve(model.variables(), pname, k).ok_or_else(|| {
            let settable = [Causality::Parameter, Causality::Input, Causality::StructuralParameter];
            let names = element_names(model.variables(), &settable);
            let hint = lash_core::did_you_mean(pname, names.iter().map(String::as_str));
            bad(format!("{field}.parameters.{pname}: no such parameter or input ({hint})"))
        })?;
        let text = match value {
            crate::spec::ParameterValue::Text(t) => Some(t.clone()),
            _ => None,
        };
        let setting = match (v.kind, value.values()) {
            (ValueKind::String, None) => Setting::Text(text.unwrap_or_default()),
            (ValueKind::String, Some(_)) => {
                return Err(bad(format!("{field}.parameters.{pname}: a String parameter takes text")));
            }
            (ValueKind::Binary, None) => Setting::Bytes(
                hex_bytes(&text.unwrap_or_default()).map_err(|m| bad(format!("{field}.parameters.{pname}: {m}")))?,
            ),
            (ValueKind::Binary, Some(_)) => {
                return Err(bad(format!(
                    "{field}.parameters.{pname}: a Binary parameter takes hexadecimal text (\"0a1b\")"
                )));
            }
            (kind, None) => {
                return Err(bad(format!(
                    "{field}.parameters.{pname}: a {} parameter takes a number, not text",
                    kind.name()
                )));
            }
            (kind, Some(values)) => {
                if values.len() != port.count {
                    return Err(bad(format!(
                        "{field}.parameters.{pname}: {} value(s) for {} element(s)",
                        values.len(),
                        port.count
                    )));
                }
                if let Some(problem) = values.iter().find_map(|&x| kind.check(x).err()) {
                    return Err(bad(format!("{field}.parameters.{pname}: {problem}")));
                }
                if port.count != port.len {
                    // One element: the array is set whole, from its start values and the
                    // other elements this system gives.
                    set_element(&mut parameters, v, port.offset, values[0]);
                    continue;
                }
                Setting::Numbers(values)
            }
        };
        parameters.push((v.value_reference, pname.clone(), setting));
    }
    Ok(parameters)
}

/// The element port and kind of `name` (`element.variable` or `element.variable[i,j]`), which
/// must have one of the causalities `want`; errors name `field` and the closest names.
fn lookup(elements: &[Element], field: &str, name: &str, want: &[Causality]) -> Result<(Port, ValueKind), SystemError> {
    let (el, var) = split(field, name)?;
    let k = elements.iter().position(|e| e.name == el).ok_or_else(|| bad(format!("{field}: no element {el:?}")))?;
    let variables = elements[k].model.variables();
    let (v, port) = resolve(variables, var, k).ok_or_else(|| {
        let names = element_names(variables, want);
        let hint = lash_core::did_you_mean(var, names.iter().map(String::as_str));
        bad(format!("{field}: element {el:?} has no variable {var:?} ({hint})"))
    })?;
    if !want.contains(&v.causality) {
        return Err(bad(format!("{field}: {name} is {:?}, expected {want:?}", v.causality)));
    }
    Ok((port, v.kind))
}

/// The system's connections, each checked: sizes, kinds, one source per input element.
fn connect(spec: &SystemSpec, elements: &[Element]) -> Result<Vec<Connection>, SystemError> {
    let lookup = |field: &str, name: &str, want: &[Causality]| lookup(elements, field, name, want);
    let mut connections = Vec::new();
    for (k, c) in spec.connections.iter().enumerate() {
        let (from, from_kind) =
            lookup(&format!("connections[{k}].from"), &c.from, &[Causality::Output, Causality::Local])?;
        let (to, to_kind) = lookup(&format!("connections[{k}].to"), &c.to, &[Causality::Input])?;
        if from.count != to.count {
            return Err(bad(format!(
                "connections[{k}]: {} has {} element(s), {} has {}",
                c.from, from.count, c.to, to.count
            )));
        }
        // Numbers connect across numeric kinds (the value passes as f64 and must fit the
        // input's kind when set); Strings connect to Strings; Binary and Clock not at all.
        let value = match (from_kind, to_kind) {
            (a, b) if a.is_numeric() && b.is_numeric() => Carried::Numbers(vec![0.0; from.len]),
            (ValueKind::String, ValueKind::String) if from.len == 1 => Carried::Text(String::new()),
            (ValueKind::Binary, ValueKind::Binary) if from.len == 1 => Carried::Bytes(Vec::new()),
            (a, b) => {
                return Err(bad(format!(
                    "connections[{k}]: {} is {}, {} is {}: lash connects numbers to numbers, String scalars to String scalars and Binary scalars to Binary scalars",
                    c.from,
                    a.name(),
                    c.to,
                    b.name()
                )));
            }
        };
        let overlaps = |x: &Connection| {
            (x.to.element, x.to.value_reference) == (to.element, to.value_reference)
                && x.to.offset < to.offset + to.count
                && to.offset < x.to.offset + x.to.count
        };
        if connections.iter().any(overlaps) {
            return Err(bad(format!("connections[{k}].to: {} is already connected", c.to)));
        }
        connections.push(Connection { from, to, value });
    }
    Ok(connections)
}

/// The recorded ports and the time series' header (time first), every name checked.
fn recorded(spec: &SystemSpec, elements: &[Element]) -> Result<(Vec<Port>, Vec<String>), SystemError> {
    let lookup = |field: &str, name: &str, want: &[Causality]| lookup(elements, field, name, want);
    let mut channels = Vec::new();
    let mut header = vec!["time [s]".to_string()];
    let mut add = |port: Port, v: &Variable, header: &mut Vec<String>| {
        let element = &elements[port.element].name;
        header.extend(
            (port.offset..port.offset + port.count).map(|i| format!("{element}.{} [{}]", v.element_name(i), v.unit)),
        );
        channels.push(port);
    };
    if spec.output.channels.is_empty() {
        // Every numeric output (String, Binary and Clock outputs are not recorded).
        for k in 0..elements.len() {
            for v in
                elements[k].model.variables().iter().filter(|v| v.causality == Causality::Output && v.kind.is_numeric())
            {
                add(Port::whole(k, v.value_reference, v.len()), v, &mut header);
            }
        }
    } else {
        for (i, name) in spec.output.channels.iter().enumerate() {
            let field = format!("output.channels[{i}]");
            let (port, kind) =
                lookup(&field, name, &[Causality::Output, Causality::Local, Causality::Parameter, Causality::Input])?;
            if !kind.is_numeric() {
                return Err(bad(format!(
                    "{field}: {name} is a {} variable; the time series records numbers only",
                    kind.name()
                )));
            }
            let v = lash_core::subsystem::variable(elements[port.element].model.variables(), port.value_reference)
                .ok_or_else(|| {
                    bad(format!("{field}: {name} has no variable for value reference {}", port.value_reference))
                })?
                .clone();
            add(port, &v, &mut header);
        }
    }
    if let Some(twice) = header.iter().enumerate().find_map(|(i, h)| header[..i].contains(h).then_some(h)) {
        return Err(bad(format!(
            "output: column {twice:?} would be written twice (a variable is named like another's element)"
        )));
    }
    Ok((channels, header))
}

fn find<'a>(variables: &'a [Variable], name: &str) -> Option<&'a Variable> {
    variables.iter().find(|v| v.name == name)
}

/// The variable `name` of element `k`, whole, or one element of an array spelled
/// `name[i]`, `name[i,j]` (1-based, see [`Variable::element_name`]).
fn resolve<'a>(variables: &'a [Variable], name: &str, k: usize) -> Option<(&'a Variable, Port)> {
    if let Some(v) = find(variables, name) {
        return Some((v, Port::whole(k, v.value_reference, v.len())));
    }
    let (base, index) = lash_core::split_element_name(name)?;
    let v = find(variables, base)?;
    let at = v.element_position(&index)?;
    Some((v, Port::element_of(k, v.value_reference, v.len(), at)))
}

/// Gives element `at` of array `v` the value `x` among `parameters` (a setting of the whole array,
/// started from its start values when the system gives none yet).
fn set_element(parameters: &mut Parameters, v: &Variable, at: usize, x: f64) {
    let existing = parameters.iter_mut().find(|(vr, _, _)| *vr == v.value_reference);
    if let Some((_, _, Setting::Numbers(values))) = existing {
        values[at] = x;
        return;
    }
    let mut values = if v.start.len() == v.len() { v.start.clone() } else { vec![0.0; v.len()] };
    values[at] = x;
    parameters.push((v.value_reference, v.name.clone(), Setting::Numbers(values)));
}

/// Every name [`resolve`] accepts among the variables of these causalities: whole variables and
/// their elements.
fn element_names(variables: &[Variable], want: &[Causality]) -> Vec<String> {
    let mut names = Vec::new();
    for v in variables.iter().filter(|v| want.contains(&v.causality)) {
        names.push(v.name.clone());
        if !v.shape.is_empty() {
            names.extend((0..v.len()).map(|e| v.element_name(e)));
        }
    }
    names
}
