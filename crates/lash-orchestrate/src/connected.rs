//! The Gauss–Seidel and Jacobi masters: elements that exchange values through connections at one
//! communication step (integer ticks), each element stepping every `decimation` communication
//! steps, observed at whole multiples of the step.
//!
//! * **Gauss–Seidel**: the elements step in order, each after reading its inputs' sources, so an
//!   element sees the outputs its predecessors reached in the same communication step.
//! * **Jacobi**: every connection is read at the start of the step; all elements step from the
//!   same values (independent of the order).
//!
//! Every step goes through [`crate::advance`], so an early return or a stop request ends the run
//! cleanly (reported in [`MasterStats::stopped`]) and is never taken for a completed step.

use crate::{Algorithm, MasterError, MasterStats, Observer, advance};
use lash_core::{StopReason, Subsystem, SubsystemError, Ticks, ValueReference};

/// How the elements see each other's outputs within a communication step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ordering {
    /// Elements in order, each seeing its predecessors' new outputs.
    GaussSeidel,
    /// All elements from the outputs at the start of the step.
    Jacobi,
}

/// How the elements reach their initial values before the first step (both in the elements'
/// FMI initialization mode).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Initialization {
    /// In order: each element reads its inputs' sources (those before it already initialised,
    /// those after it still at their start values) and leaves initialization mode. Exact for an
    /// acyclic system written sources first.
    #[default]
    Ordered,
    /// As libcosim's fixed-step master does: all elements stay in initialization mode while
    /// inputs are set and outputs read, as many rounds as there are elements (so a value passes
    /// along a chain of any order, and a loop is iterated that often), then all leave it together.
    Iterated,
}

/// An element of a connected execution.
pub struct Element {
    /// Unique name (errors and stop reports name it).
    pub name: String,
    /// The subsystem, set up and given its parameters (not yet initialised).
    pub model: Box<dyn Subsystem>,
    /// The element steps every `decimation` communication steps (≥ 1), by that many steps at once.
    pub decimation: i64,
}

/// The value a connection carries between reads and writes.
#[derive(Debug, Clone, PartialEq)]
pub enum Carried {
    /// Numbers (any numeric kinds, as f64), one per element of the variable.
    Numbers(Vec<f64>),
    /// A String scalar.
    Text(String),
    /// A Binary scalar.
    Bytes(Vec<u8>),
}

/// One end of a connection, or a recorded quantity: a whole variable of an element, or a run of
/// its elements (row-major positions `offset..offset + count`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Port {
    /// The element (index into the master's elements).
    pub element: usize,
    /// The variable's value reference in that element.
    pub value_reference: ValueReference,
    /// The variable's number of elements (1 for a scalar).
    pub len: usize,
    /// The first element this port carries.
    pub offset: usize,
    /// How many elements it carries.
    pub count: usize,
}

impl Port {
    /// The whole variable `value_reference` (of `len` elements) of `element`.
    pub fn whole(element: usize, value_reference: ValueReference, len: usize) -> Self {
        Self { element, value_reference, len, offset: 0, count: len }
    }

    /// Element `offset` alone of a variable of `len` elements.
    pub fn element_of(element: usize, value_reference: ValueReference, len: usize, offset: usize) -> Self {
        Self { element, value_reference, len, offset, count: 1 }
    }

    fn is_whole(&self) -> bool {
        self.offset == 0 && self.count == self.len
    }
}

/// An output (or local) of one element feeding an input of another, whole or element by element
/// (an input fed element by element keeps its start value, or the value the system gave it, in
/// the elements nothing feeds, as libcosim does).
#[derive(Debug, Clone)]
pub struct Connection {
    /// The source.
    pub from: Port,
    /// The input (as many elements as the source).
    pub to: Port,
    /// The value in transit (its variant says what is carried; numbers: the source's whole
    /// variable).
    pub value: Carried,
}

/// The values an input variable is set to: connections write their elements into it, the whole
/// variable is set.
struct StagedInput {
    element: usize,
    value_reference: ValueReference,
    values: Vec<f64>,
}

/// The connected master over a set of elements.
pub struct ConnectedMaster<'a> {
    elements: &'a mut [Element],
    connections: &'a mut [Connection],
    /// Per connection, the staged input it writes (numbers only).
    staging: Vec<Option<usize>>,
    inputs: Vec<StagedInput>,
    probes: Vec<Port>,
    /// A whole variable read for a probe of part of it.
    scratch: Vec<f64>,
    names: Vec<String>,
    start: Ticks,
    stop: Ticks,
    step: Ticks,
    ordering: Ordering,
    initialization: Initialization,
}

impl<'a> ConnectedMaster<'a> {
    /// A master from `start` to `stop` (a whole, positive number of `step`s) recording `probes`
    /// (their signal names in `names`, one per recorded number).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        elements: &'a mut [Element],
        connections: &'a mut [Connection],
        probes: Vec<Port>,
        names: Vec<String>,
        start: Ticks,
        stop: Ticks,
        step: Ticks,
        ordering: Ordering,
    ) -> Result<Self, MasterError> {
        if step.0 <= 0 || Ticks(stop.0 - start.0).exact_ratio(step).is_none_or(|n| n < 1) {
            return Err(MasterError::Settings(format!(
                "the run from {} s to {} s is not a whole, positive number of steps of {} s",
                start.seconds(),
                stop.seconds(),
                step.seconds()
            )));
        }
        if let Some(e) = elements.iter().find(|e| e.decimation < 1) {
            return Err(MasterError::Settings(format!("element {:?}: decimation must be ≥ 1", e.name)));
        }
        let width: usize = probes.iter().map(|p| p.count).sum();
        if width != names.len() {
            return Err(MasterError::Settings(format!("{} signal names for {width} recorded numbers", names.len())));
        }
        let (staging, inputs) = Self::stage_inputs(elements, connections)?;
        let scratch = vec![0.0; probes.iter().map(|p| p.len).max().unwrap_or(0)];
        let initialization = Initialization::default();
        Ok(Self {
            elements,
            connections,
            staging,
            inputs,
            probes,
            scratch,
            names,
            start,
            stop,
            step,
            ordering,
            initialization,
        })
    }

    /// The same master, reaching its initial values as `initialization` says.
    pub fn with_initialization(mut self, initialization: Initialization) -> Self {
        self.initialization = initialization;
        self
    }

    /// Leaves every element's initialization mode with the inputs its sources give (see
    /// [`Initialization`]).
    fn initialize(&mut self) -> Result<(), MasterError> {
        let start = self.start;
        if self.initialization == Initialization::Iterated {
            for _ in 0..self.elements.len() {
                for k in 0..self.elements.len() {
                    self.scatter(k, start)?;
                }
                self.gather(None, start)?;
            }
        }
        for k in 0..self.elements.len() {
            if self.initialization == Initialization::Ordered {
                self.gather(Some(k), start)?;
            }
            self.scatter(k, start)?;
            if let Err(source) = self.elements[k].model.initialize() {
                return Err(MasterError::Initialization { element: k, name: self.elements[k].name.clone(), source });
            }
        }
        Ok(())
    }

    /// One staged input per input variable fed with numbers, starting from its start values.
    fn stage_inputs(
        elements: &[Element],
        connections: &[Connection],
    ) -> Result<(Vec<Option<usize>>, Vec<StagedInput>), MasterError> {
        let mut inputs: Vec<StagedInput> = Vec::new();
        let mut staging = Vec::with_capacity(connections.len());
        for c in connections {
            let (from, to) = (c.from, c.to);
            if !matches!(c.value, Carried::Numbers(_)) {
                staging.push(None);
                continue;
            }
            let fits = |p: Port| p.count >= 1 && p.offset + p.count <= p.len;
            if from.count != to.count || !fits(from) || !fits(to) {
                return Err(MasterError::Settings(format!(
                    "a connection of {} element(s) at {} of {} into {} element(s) at {} of {}",
                    from.count, from.offset, from.len, to.count, to.offset, to.len
                )));
            }
            let at = inputs.iter().position(|i| (i.element, i.value_reference) == (to.element, to.value_reference));
            let at = at.unwrap_or_else(|| {
                let start = lash_core::subsystem::variable(elements[to.element].model.variables(), to.value_reference)
                    .map(|v| v.start.clone())
                    .filter(|s| s.len() == to.len)
                    .unwrap_or_else(|| vec![0.0; to.len]);
                inputs.push(StagedInput { element: to.element, value_reference: to.value_reference, values: start });
                inputs.len() - 1
            });
            staging.push(Some(at));
        }
        Ok((staging, inputs))
    }

    /// Sets the value an input fed element by element holds where no connection writes (the
    /// value the system gave it); `false` when the input is not staged.
    pub fn preset_input(&mut self, element: usize, value_reference: ValueReference, values: &[f64]) -> bool {
        match self.inputs.iter_mut().find(|i| (i.element, i.value_reference) == (element, value_reference)) {
            Some(staged) if staged.values.len() == values.len() => {
                staged.values.copy_from_slice(values);
                true
            }
            _ => false,
        }
    }

    fn fail(&self, k: usize, t: Ticks, source: SubsystemError) -> MasterError {
        MasterError::Element { name: self.elements[k].name.clone(), t, source }
    }

    /// Reads every connection's source (those into element `only_to`, if given).
    fn gather(&mut self, only_to: Option<usize>, t: Ticks) -> Result<(), MasterError> {
        for c in 0..self.connections.len() {
            let (from, to) = (self.connections[c].from, self.connections[c].to);
            if only_to.is_some_and(|k| k != to.element) {
                continue;
            }
            let source = &self.elements[from.element].model;
            let vr = from.value_reference;
            let result = match &mut self.connections[c].value {
                Carried::Text(text) => source.get_string(vr).map(|s| *text = s),
                Carried::Bytes(bytes) => source.get_binary(vr).map(|b| *bytes = b),
                Carried::Numbers(buffer) => source.get_f64(&[vr], buffer).map(|()| {
                    if let Some(i) = self.staging[c] {
                        let carried = &buffer[from.offset..from.offset + from.count];
                        self.inputs[i].values[to.offset..to.offset + to.count].copy_from_slice(carried);
                    }
                }),
            };
            if let Err(e) = result {
                return Err(self.fail(from.element, t, e));
            }
        }
        Ok(())
    }

    /// Writes the carried values into the inputs of element `k`.
    fn scatter(&mut self, k: usize, t: Ticks) -> Result<(), MasterError> {
        for c in 0..self.connections.len() {
            let to = self.connections[c].to;
            if to.element != k {
                continue;
            }
            let target = &mut self.elements[k].model;
            let result = match &self.connections[c].value {
                Carried::Text(text) => target.set_string(to.value_reference, text),
                Carried::Bytes(bytes) => target.set_binary(to.value_reference, bytes),
                Carried::Numbers(_) => Ok(()),
            };
            if let Err(e) = result {
                return Err(self.fail(k, t, e));
            }
        }
        for input in self.inputs.iter().filter(|i| i.element == k) {
            if let Err(e) = self.elements[k].model.set_f64(&[input.value_reference], &input.values) {
                return Err(self.fail(k, t, e));
            }
        }
        Ok(())
    }

    /// Reads the probes into `row`.
    fn read(&mut self, t: Ticks, row: &mut [f64]) -> Result<(), MasterError> {
        let mut at = 0;
        for p in &self.probes {
            let model = &self.elements[p.element].model;
            let result = if p.is_whole() {
                model.get_f64(&[p.value_reference], &mut row[at..at + p.count])
            } else {
                let whole = &mut self.scratch[..p.len];
                model.get_f64(&[p.value_reference], whole).map(|()| {
                    row[at..at + p.count].copy_from_slice(&whole[p.offset..p.offset + p.count]);
                })
            };
            if let Err(e) = result {
                return Err(self.fail(p.element, t, e));
            }
            at += p.count;
        }
        Ok(())
    }
}

impl Algorithm for ConnectedMaster<'_> {
    fn signal_names(&self) -> Vec<String> {
        self.names.clone()
    }

    /// Initialises the elements (see [`Initialization`]), then steps to the stop time.
    /// Observers are called at the start and at their intervals (whole multiples of
    /// the step); when an element ends the run early, every observer also gets the last
    /// communication point all elements completed.
    fn run(&mut self, observers: &mut [(&mut dyn Observer, Ticks)]) -> Result<MasterStats, MasterError> {
        let (start, stop, step) = (self.start, self.stop, self.step);
        let every: Vec<i64> = crate::decimation(step, "step", observers)?.into_iter().map(|d| d as i64).collect();
        self.initialize()?;
        let mut row = vec![0.0; self.names.len()];
        self.read(start, &mut row)?;
        for (obs, _) in observers.iter_mut() {
            obs.observe(start, &row).map_err(MasterError::Observer)?;
        }
        let mut stopped: Option<(usize, StopReason)> = None;
        let n = (stop.0 - start.0) / step.0;
        let mut steps = 0;
        let started = std::time::Instant::now();
        'steps: for i in 0..n {
            let t = Ticks(start.0 + i * step.0);
            if self.ordering == Ordering::Jacobi {
                self.gather(None, t)?;
            }
            for k in 0..self.elements.len() {
                let d = self.elements[k].decimation;
                if i % d != 0 {
                    continue;
                }
                if self.ordering == Ordering::GaussSeidel {
                    self.gather(Some(k), t)?;
                }
                self.scatter(k, t)?;
                let h = Ticks(step.0 * d.min(n - i));
                match advance(&mut *self.elements[k].model, "element", t, h) {
                    Ok(None) => {}
                    // A stop requested at the end of a whole step lets the others finish this
                    // communication step, whose sample is recorded (as fmpy does); a decimated
                    // element's step ends beyond this point, so the run ends here.
                    Ok(Some(reason)) => {
                        stopped.get_or_insert((k, reason));
                        if d > 1 {
                            break 'steps;
                        }
                    }
                    Err(MasterError::Stopped { reason, .. }) => {
                        stopped.get_or_insert((k, reason));
                        break 'steps;
                    }
                    Err(MasterError::Subsystem { source, .. }) => return Err(self.fail(k, t, source)),
                    Err(other) => return Err(self.fail(k, t, SubsystemError::Other(other.to_string()))),
                }
            }
            steps += 1;
            let end = Ticks(t.0 + step.0);
            let due = |d: &i64| (i + 1) % d == 0 || stopped.is_some();
            if every.iter().any(due) {
                self.read(end, &mut row)?;
                for ((obs, _), d) in observers.iter_mut().zip(&every) {
                    if due(d) {
                        obs.observe(end, &row).map_err(MasterError::Observer)?;
                    }
                }
            }
            if stopped.is_some() {
                break;
            }
        }
        for k in 0..self.elements.len() {
            if let Err(e) = self.elements[k].model.terminate() {
                return Err(self.fail(k, Ticks(start.0 + steps * step.0), e));
            }
        }
        Ok(MasterStats {
            macro_steps: steps as u64,
            micro_steps: 0,
            macro_seconds: started.elapsed().as_secs_f64(),
            micro_seconds: 0.0,
            stopped: stopped.map(|(k, reason)| (self.elements[k].name.clone(), reason)),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lash_core::subsystem::{Causality, Variability, VariableTable};
    use lash_core::{SavedState, StepOutcome, Variable};

    /// From this time on, every step ends with this outcome.
    type StopAt = (Ticks, fn(Ticks, Ticks) -> StepOutcome);

    /// x(t + h) = x(t) + h u (explicit Euler of ẋ = u): input `u` (vr 0), output `x` (vr 1);
    /// from `stop_at` on, every step ends with `outcome`.
    struct Euler {
        variables: Vec<Variable>,
        x: f64,
        u: f64,
        t: Ticks,
        stop_at: Option<StopAt>,
        /// Takes its input into its initial state (x += u when leaving initialization), and its
        /// output feeds it through until then (x + u).
        pull: bool,
        initialized: bool,
    }

    fn euler(x0: f64) -> Euler {
        let mut table = VariableTable::new();
        table.add("u", Causality::Input, Variability::Continuous, "1", "rate", &[], &[0.0]);
        table.add("x", Causality::Output, Variability::Continuous, "1", "state", &[], &[0.0]);
        Euler {
            variables: table.into_variables(),
            x: x0,
            u: 0.0,
            t: Ticks::ZERO,
            stop_at: None,
            pull: false,
            initialized: false,
        }
    }

    impl Subsystem for Euler {
        fn name(&self) -> &str {
            "euler"
        }
        fn variables(&self) -> &[Variable] {
            &self.variables
        }
        fn setup(&mut self, start: Ticks, _: Option<Ticks>) -> Result<(), SubsystemError> {
            self.t = start;
            Ok(())
        }
        fn initialize(&mut self) -> Result<(), SubsystemError> {
            if self.pull {
                self.x += self.u;
            }
            self.initialized = true;
            Ok(())
        }
        fn set_f64(&mut self, _: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError> {
            self.u = values[0];
            Ok(())
        }
        fn get_f64(&self, _: &[ValueReference], values: &mut [f64]) -> Result<(), SubsystemError> {
            values[0] = if self.pull && !self.initialized { self.x + self.u } else { self.x };
            Ok(())
        }
        fn do_step(&mut self, t: Ticks, h: Ticks) -> Result<StepOutcome, SubsystemError> {
            if let Some((at, outcome)) = self.stop_at
                && t.0 + h.0 > at.0
            {
                let o = outcome(t, h);
                if let StepOutcome::EarlyReturn { reached } = o {
                    self.x += (reached.0 - t.0) as f64 * 1e-9 * self.u;
                    self.t = reached;
                } else {
                    self.x += h.seconds() * self.u;
                    self.t = Ticks(t.0 + h.0);
                }
                return Ok(o);
            }
            self.x += h.seconds() * self.u;
            self.t = Ticks(t.0 + h.0);
            Ok(StepOutcome::Completed)
        }
        fn time(&self) -> Ticks {
            self.t
        }
        fn save_state(&self) -> Result<SavedState, SubsystemError> {
            Ok(SavedState(Box::new((self.x, self.t))))
        }
        fn restore_state(&mut self, _: &SavedState) -> Result<(), SubsystemError> {
            Ok(())
        }
    }

    /// Two integrators in a loop, ẋ₀ = x₁, ẋ₁ = x₀ from (1, 0), coupled at h = 0.01 s over four
    /// steps; returns the recorded rows (t, x₀, x₁) and the statistics.
    fn cycle(ordering: Ordering, decimation: i64, stop_at: Option<StopAt>) -> (Vec<[f64; 3]>, MasterStats) {
        let h = Ticks::from_seconds(0.01).unwrap();
        let mut second = euler(0.0);
        second.stop_at = stop_at;
        let mut elements = vec![
            Element { name: "first".into(), model: Box::new(euler(1.0)), decimation: 1 },
            Element { name: "second".into(), model: Box::new(second), decimation },
        ];
        // u₀ = x₁, u₁ = x₀.
        let mut connections = vec![
            Connection { from: Port::whole(1, 1, 1), to: Port::whole(0, 0, 1), value: Carried::Numbers(vec![0.0]) },
            Connection { from: Port::whole(0, 1, 1), to: Port::whole(1, 0, 1), value: Carried::Numbers(vec![0.0]) },
        ];
        let mut master = ConnectedMaster::new(
            &mut elements,
            &mut connections,
            vec![Port::whole(0, 1, 1), Port::whole(1, 1, 1)],
            vec!["first.x".into(), "second.x".into()],
            Ticks::ZERO,
            Ticks(h.0 * 4),
            h,
            ordering,
        )
        .unwrap();
        let mut rows = Vec::new();
        let mut observer = |t: Ticks, v: &[f64]| -> Result<(), lash_core::BoxError> {
            rows.push([t.seconds(), v[0], v[1]]);
            Ok(())
        };
        let mut observers: [(&mut dyn Observer, Ticks); 1] = [(&mut observer, h)];
        let stats = master.run(&mut observers).unwrap();
        (rows, stats)
    }

    #[test]
    fn gauss_seidel_passes_new_outputs_within_a_step_and_jacobi_does_not() {
        // Closed forms of the two orderings for ẋ₀ = x₁, ẋ₁ = x₀ from (1, 0), h = 0.01:
        // Jacobi: (a, b) → (a + h b, b + h a); Gauss–Seidel (first steps first, then the second
        // reads the first's new x₀): (a, b) → (a + h b, b + h (a + h b)).
        let h = 0.01;
        let (mut ja, mut jb, mut ga, mut gb) = (1.0f64, 0.0f64, 1.0f64, 0.0f64);
        let (jacobi, _) = cycle(Ordering::Jacobi, 1, None);
        let (seidel, stats) = cycle(Ordering::GaussSeidel, 1, None);
        assert_eq!(stats.macro_steps, 4);
        assert_eq!(jacobi.len(), 5);
        for k in 1..5 {
            (ja, jb) = (ja + h * jb, jb + h * ja);
            let a = ga + h * gb;
            (ga, gb) = (a, gb + h * a);
            assert!((jacobi[k][1] - ja).abs() < 1e-15 && (jacobi[k][2] - jb).abs() < 1e-15, "{k}: {:?}", jacobi[k]);
            assert!((seidel[k][1] - ga).abs() < 1e-15 && (seidel[k][2] - gb).abs() < 1e-15, "{k}: {:?}", seidel[k]);
        }
        assert!(seidel[4][2] > jacobi[4][2], "the orderings differ");
    }

    #[test]
    fn ordered_and_iterated_initializations_in_closed_form() {
        // Two elements in a loop (u_a = y_b, u_b = y_a) that take their input into their initial
        // state and feed it through before: x_a = 1, x_b = 10.
        let start = |initialization: Initialization| {
            let h = Ticks::from_seconds(0.01).unwrap();
            let (mut a, mut b) = (euler(1.0), euler(10.0));
            (a.pull, b.pull) = (true, true);
            let mut elements = vec![
                Element { name: "a".into(), model: Box::new(a), decimation: 1 },
                Element { name: "b".into(), model: Box::new(b), decimation: 1 },
            ];
            let carried = || Carried::Numbers(vec![0.0]);
            let mut connections = vec![
                Connection { from: Port::whole(1, 1, 1), to: Port::whole(0, 0, 1), value: carried() },
                Connection { from: Port::whole(0, 1, 1), to: Port::whole(1, 0, 1), value: carried() },
            ];
            let probes = vec![Port::whole(0, 1, 1), Port::whole(1, 1, 1)];
            let names = vec!["a.x".into(), "b.x".into()];
            let mut master = ConnectedMaster::new(
                &mut elements,
                &mut connections,
                probes,
                names,
                Ticks::ZERO,
                h,
                h,
                Ordering::Jacobi,
            )
            .unwrap()
            .with_initialization(initialization);
            let mut first = None;
            let mut observer = |_: Ticks, v: &[f64]| -> Result<(), lash_core::BoxError> {
                first.get_or_insert([v[0], v[1]]);
                Ok(())
            };
            master.run(&mut [(&mut observer, h)]).unwrap();
            first.unwrap()
        };
        // Ordered: a reads b before b is initialised (10 + 0), then b reads a's initial 11.
        assert_eq!(start(Initialization::Ordered), [11.0, 21.0]);
        // Iterated, two rounds: round 1 passes the start outputs (u_a = 10, u_b = 1), round 2
        // the fed-through ones (u_a = 10 + 1, u_b = 1 + 10); both then leave initialization.
        assert_eq!(start(Initialization::Iterated), [12.0, 21.0]);
    }

    #[test]
    fn a_decimated_element_steps_every_d_steps_by_d_steps() {
        // The second steps at t = 0 and 0.02 by 0.02 from the value it read then.
        let (rows, _) = cycle(Ordering::GaussSeidel, 2, None);
        assert_eq!(rows[1][2], rows[2][2], "held between its steps: {rows:?}");
        assert!((rows[2][2] - 0.02 * 1.0).abs() < 1e-15, "one step of 0.02 from x₀(0) = 1: {rows:?}");
    }

    #[test]
    fn early_returns_and_stop_requests_end_the_run_and_are_reported() {
        let at = Ticks::from_seconds(0.02).unwrap();
        let early: fn(Ticks, Ticks) -> StepOutcome = |t, h| StepOutcome::EarlyReturn { reached: Ticks(t.0 + h.0 / 2) };
        let (rows, stats) = cycle(Ordering::GaussSeidel, 1, Some((at, early)));
        let (who, reason) = stats.stopped.expect("reported");
        assert_eq!(who, "second");
        assert!(matches!(reason, StopReason::EarlyReturn { .. }), "{reason:?}");
        assert_eq!(stats.macro_steps, 2, "the step that returned early is not counted as completed");
        assert_eq!(rows.last().unwrap()[0], 0.02, "no sample of the incomplete step: {rows:?}");
        let terminate: fn(Ticks, Ticks) -> StepOutcome = |t, h| StepOutcome::Terminate { reached: Ticks(t.0 + h.0) };
        let (rows, stats) = cycle(Ordering::GaussSeidel, 1, Some((at, terminate)));
        assert!(matches!(stats.stopped, Some((_, StopReason::Requested { .. }))));
        assert_eq!(stats.macro_steps, 3, "a stop requested at the end of a whole step keeps that step");
        assert_eq!(rows.last().unwrap()[0], 0.03, "{rows:?}");
    }
}
