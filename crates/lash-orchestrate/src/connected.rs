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

/// An output (or local) of one element feeding an input of another.
#[derive(Debug, Clone)]
pub struct Connection {
    /// (element, value reference) of the source.
    pub from: (usize, ValueReference),
    /// (element, value reference) of the input.
    pub to: (usize, ValueReference),
    /// The value in transit (its variant says what is carried).
    pub value: Carried,
}

/// A recorded variable: (element, value reference, number of elements).
pub type Probe = (usize, ValueReference, usize);

/// The connected master over a set of elements.
pub struct ConnectedMaster<'a> {
    elements: &'a mut [Element],
    connections: &'a mut [Connection],
    probes: Vec<Probe>,
    names: Vec<String>,
    start: Ticks,
    stop: Ticks,
    step: Ticks,
    ordering: Ordering,
}

impl<'a> ConnectedMaster<'a> {
    /// A master from `start` to `stop` (a whole, positive number of `step`s) recording `probes`
    /// (their signal names in `names`, one per recorded number).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        elements: &'a mut [Element],
        connections: &'a mut [Connection],
        probes: Vec<Probe>,
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
        let width: usize = probes.iter().map(|p| p.2).sum();
        if width != names.len() {
            return Err(MasterError::Settings(format!("{} signal names for {width} recorded numbers", names.len())));
        }
        Ok(Self { elements, connections, probes, names, start, stop, step, ordering })
    }

    fn fail(&self, k: usize, t: Ticks, source: SubsystemError) -> MasterError {
        MasterError::Element { name: self.elements[k].name.clone(), t, source }
    }

    /// Reads every connection's source (those into element `only_to`, if given).
    fn gather(&mut self, only_to: Option<usize>, t: Ticks) -> Result<(), MasterError> {
        for c in 0..self.connections.len() {
            let (from, to) = (self.connections[c].from, self.connections[c].to);
            if only_to.is_some_and(|k| k != to.0) {
                continue;
            }
            let source = &self.elements[from.0].model;
            let result = match &mut self.connections[c].value {
                Carried::Text(text) => source.get_string(from.1).map(|s| *text = s),
                Carried::Bytes(bytes) => source.get_binary(from.1).map(|b| *bytes = b),
                Carried::Numbers(buffer) => source.get_f64(&[from.1], buffer),
            };
            if let Err(e) = result {
                return Err(self.fail(from.0, t, e));
            }
        }
        Ok(())
    }

    /// Writes the carried values into the inputs of element `k`.
    fn scatter(&mut self, k: usize, t: Ticks) -> Result<(), MasterError> {
        for c in 0..self.connections.len() {
            let to = self.connections[c].to;
            if to.0 != k {
                continue;
            }
            let target = &mut self.elements[k].model;
            let result = match &self.connections[c].value {
                Carried::Text(text) => target.set_string(to.1, text),
                Carried::Bytes(bytes) => target.set_binary(to.1, bytes),
                Carried::Numbers(buffer) => target.set_f64(&[to.1], buffer),
            };
            if let Err(e) = result {
                return Err(self.fail(k, t, e));
            }
        }
        Ok(())
    }

    /// Reads the probes into `row`.
    fn read(&self, t: Ticks, row: &mut [f64]) -> Result<(), MasterError> {
        let mut at = 0;
        for &(k, vr, len) in &self.probes {
            if let Err(e) = self.elements[k].model.get_f64(&[vr], &mut row[at..at + len]) {
                return Err(self.fail(k, t, e));
            }
            at += len;
        }
        Ok(())
    }
}

impl Algorithm for ConnectedMaster<'_> {
    fn signal_names(&self) -> Vec<String> {
        self.names.clone()
    }

    /// Initialises the elements in order (each after its inputs' sources), then steps to the
    /// stop time. Observers are called at the start and at their intervals (whole multiples of
    /// the step); when an element ends the run early, every observer also gets the last
    /// communication point all elements completed.
    fn run(&mut self, observers: &mut [(&mut dyn Observer, Ticks)]) -> Result<MasterStats, MasterError> {
        let (start, stop, step) = (self.start, self.stop, self.step);
        let mut every = Vec::with_capacity(observers.len());
        for (_, interval) in observers.iter() {
            match interval.exact_ratio(step) {
                Some(d) if d >= 1 => every.push(d),
                _ => {
                    return Err(MasterError::Settings(format!(
                        "observer interval {} s is not a whole multiple of the step {} s",
                        interval.seconds(),
                        step.seconds()
                    )));
                }
            }
        }
        for k in 0..self.elements.len() {
            self.gather(Some(k), start)?;
            self.scatter(k, start)?;
            if let Err(source) = self.elements[k].model.initialize() {
                return Err(MasterError::Initialization { element: k, name: self.elements[k].name.clone(), source });
            }
        }
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
    }

    fn euler(x0: f64) -> Euler {
        let mut table = VariableTable::new();
        table.add("u", Causality::Input, Variability::Continuous, "1", "rate", &[], &[0.0]);
        table.add("x", Causality::Output, Variability::Continuous, "1", "state", &[], &[0.0]);
        Euler { variables: table.into_variables(), x: x0, u: 0.0, t: Ticks::ZERO, stop_at: None }
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
            Ok(())
        }
        fn set_f64(&mut self, _: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError> {
            self.u = values[0];
            Ok(())
        }
        fn get_f64(&self, _: &[ValueReference], values: &mut [f64]) -> Result<(), SubsystemError> {
            values[0] = self.x;
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
            Connection { from: (1, 1), to: (0, 0), value: Carried::Numbers(vec![0.0]) },
            Connection { from: (0, 1), to: (1, 0), value: Carried::Numbers(vec![0.0]) },
        ];
        let mut master = ConnectedMaster::new(
            &mut elements,
            &mut connections,
            vec![(0, 1, 1), (1, 1, 1)],
            vec!["first.x".into(), "second.x".into()],
            Ticks::ZERO,
            Ticks(h.0 * 4),
            h,
            ordering,
        )
        .unwrap();
        let mut rows = Vec::new();
        let mut observer = |t: Ticks, v: &[f64]| -> Result<(), String> {
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
