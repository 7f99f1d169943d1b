//! The execution engine of lash: its coupling algorithms behind one [`Algorithm`] trait — the
//! multirate coupling of the reduced interface model ([`InterfaceMaster`], below) and the
//! Gauss–Seidel/Jacobi master over elements and connections ([`ConnectedMaster`], in
//! [`connected`]); every subsystem step goes through [`advance`].
//!
//! The [`InterfaceMaster`] couples a macro subsystem (the mechanism; communication step h_m) and a
//! micro subsystem (the clearance interface; step h_r = h_m / N, N an integer in exact
//! [`Ticks`]). It sees both only through the [`Subsystem`] trait and a naming convention:
//!
//! | macro output | micro input |
//! |---|---|
//! | `effective_mass` (n×n), `effective_force` (n), `friction_moment_force` (n×m) | the same, plus `…_rate` |
//! | `journal_angular_velocity`, `journal_angular_acceleration` (r) | the same |
//! | `bearing_angular_velocity`, `bearing_angular_acceleration` (r) | the same for the bearings |
//!
//! for clearance joints with n interface coordinates, m friction loads and r angular velocity
//! components in all (planar revolute joints: n = 2k, m = r = k; spherical ones: n = 3k, m = 6k,
//! r = 3k; sizes read from the variables), and, back, the micro outputs `contact_force` (n) and
//! `friction_load` (m) every micro step (the loads of the propagated signals) and, in two-way
//! coupling, `eccentricity` and `eccentricity_rate` at the end of each macro step and the mean
//! friction loads over it (from `friction_impulse`), fed to the macro inputs `eccentricity`,
//! `eccentricity_rate` and `friction_force`.
//!
//! * **Interpolation** of the coupling inputs across the macro step: linear (default), cubic
//!   Hermite (slopes from neighbouring nodes, angular velocities with their exported derivatives),
//!   or zero-order hold (for study only: holding M̃ and f̃ over a macro step produces spurious impacts). The micro subsystem gets values and rates at
//!   each micro step.
//! * **One-way coupling**: the macro runs ahead (one node for linear, two for Hermite).
//!   **Two-way coupling** (predictor–corrector with rollback): the macro state at t_k is saved; the
//!   macro steps to t_k+1 with the eccentricity extrapolated (predictor); the micro subsystem
//!   integrates [t_k, t_k+1] between the two nodes; the macro is restored and steps again with the
//!   micro's eccentricity and rate at t_k+1 (corrector). The corrected node starts the next step.
//! * **Execution**: sequential, or (one-way) a threaded pipeline in which a producer thread steps the
//!   macro subsystem and sends its node frames over a bounded crossbeam channel while the calling
//!   thread integrates the micro subsystem. Both run the same arithmetic on the same frames, so the
//!   results are bit-identical.
//! * **Observers** receive the [`Signal`]s they asked for at their own interval (a multiple of h_r):
//!   micro outputs, macro outputs interpolated in time (cubic Hermite with a derivative, linear
//!   without), and propagated quantities `free + gain · f_c` (docs/theory.md §6: no solve in the micro
//!   loop).
//! * **Tracing**: a `macro_step` span per macro step and a `micro_interval` span per macro interval
//!   of micro steps.

pub mod connected;

pub use connected::{Carried, ConnectedMaster, Connection, Element, Initialization, Ordering, Port};

use crossbeam_channel::bounded;
use lash_core::{Causality, Coupling, StopReason, Subsystem, SubsystemError, Ticks, ValueReference, Variable};
use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// Interpolation of the macro terms across a macro step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Interpolation {
    /// Linear between the two nodes of the step (the default).
    #[default]
    Linear,
    /// Cubic Hermite with slopes from the neighbouring nodes (Catmull–Rom; one-sided at the ends).
    CubicHermite,
    /// Held at the first node (produces spurious impacts: for study only).
    ZeroOrderHold,
}

/// Sequential or threaded execution.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Execution {
    /// One thread.
    #[default]
    Sequential,
    /// Macro subsystem on a producer thread, micro subsystem on the calling thread (one-way only).
    Threaded,
}

/// Settings of a coupled run.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct MasterOptions {
    /// Start time.
    pub start: Ticks,
    /// Stop time (start + a whole number of macro steps).
    pub stop: Ticks,
    /// Macro communication step h_m.
    pub macro_step: Ticks,
    /// Micro communication step h_r (h_m / h_r an integer).
    pub micro_step: Ticks,
    /// Interpolation of the coupling inputs.
    pub interpolation: Interpolation,
    /// One-way or two-way.
    pub coupling: Coupling,
    /// Sequential or threaded.
    pub execution: Execution,
}

/// Steps that do not fit together; each names the quantities and their values.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StepError {
    /// The macro step is not a whole multiple of the micro step.
    #[error("macro step {macro_step} s is not a whole multiple of the micro step {micro_step} s")]
    NotWholeMicroSteps {
        /// Macro step \[s\].
        macro_step: f64,
        /// Micro step \[s\].
        micro_step: f64,
    },
    /// More micro steps per macro step than the master holds rows for.
    #[error(
        "micro step {micro_step} s: {ratio} micro steps per macro step of {macro_step} s, more than the \
         {MAX_MICRO_STEPS_PER_MACRO} whose rows the master holds at once (a micro step below {} s is not supported \
         at this macro step)",
        macro_step / MAX_MICRO_STEPS_PER_MACRO as f64
    )]
    TooManyMicroSteps {
        /// Micro step \[s\].
        micro_step: f64,
        /// Macro step \[s\].
        macro_step: f64,
        /// Micro steps per macro step.
        ratio: i64,
    },
    /// The run is not a whole, positive number of macro steps.
    #[error(
        "the run from {start} s to {stop} s (horizon) is not a whole, positive multiple of the macro step {macro_step} s"
    )]
    NotWholeMacroSteps {
        /// Start \[s\].
        start: f64,
        /// Stop \[s\].
        stop: f64,
        /// Macro step \[s\].
        macro_step: f64,
    },
    /// The output interval is not a whole multiple of the micro step.
    #[error("output interval {interval} s is not a whole multiple of the micro step {micro_step} s")]
    OutputInterval {
        /// Output interval \[s\].
        interval: f64,
        /// Micro step \[s\].
        micro_step: f64,
    },
    /// Two-way coupling asked to run threaded.
    #[error("two-way coupling runs sequentially: the macro step needs the micro result of the step before")]
    TwoWayThreaded,
}

impl MasterOptions {
    /// The one check of a master's steps, used by every runner and file format before anything
    /// is built: the macro step a whole multiple of the micro step, at most
    /// [`MAX_MICRO_STEPS_PER_MACRO`] times it; the run a whole, positive number of macro steps;
    /// two-way coupling sequential. Returns the micro steps per macro step.
    pub fn check(&self) -> Result<i64, StepError> {
        let ratio = check_step_ratio(self.macro_step, self.micro_step)?;
        if Ticks(self.stop.0 - self.start.0).exact_ratio(self.macro_step).is_none_or(|n| n < 1) {
            return Err(StepError::NotWholeMacroSteps {
                start: self.start.seconds(),
                stop: self.stop.seconds(),
                macro_step: self.macro_step.seconds(),
            });
        }
        if self.coupling == Coupling::TwoWay && self.execution == Execution::Threaded {
            return Err(StepError::TwoWayThreaded);
        }
        Ok(ratio)
    }

    /// Checks that samples every `interval` fall on micro steps.
    pub fn check_sampling(&self, interval: Ticks) -> Result<(), StepError> {
        match interval.exact_ratio(self.micro_step) {
            Some(n) if n >= 1 => Ok(()),
            _ => Err(StepError::OutputInterval { interval: interval.seconds(), micro_step: self.micro_step.seconds() }),
        }
    }
}

/// A quantity that observers can record.
#[derive(Debug, Clone, PartialEq)]
pub enum Signal {
    /// Element `element` of micro output `variable`, at every micro step.
    Micro {
        /// Signal name.
        name: String,
        /// Micro variable name.
        variable: String,
        /// Element index (row-major).
        element: usize,
    },
    /// Element of a macro output interpolated across the macro step: cubic Hermite when a
    /// derivative variable is given, linear otherwise.
    Macro {
        /// Signal name.
        name: String,
        /// Macro variable name.
        variable: String,
        /// Element index.
        element: usize,
        /// (variable, element) holding its time derivative.
        derivative: Option<(String, usize)>,
    },
    /// `free + Σ gain_c load_c` with the maps interpolated linearly and the loads the micro
    /// subsystem's contact forces (n) and friction loads (m) at the same instant.
    Propagated {
        /// Signal name.
        name: String,
        /// (variable, element) of the value at zero load.
        free: (String, usize),
        /// (variable, first element) of the n + m gains, one per load, in load order.
        gain: (String, usize),
    },
}

impl Signal {
    /// The signal's name.
    pub fn name(&self) -> &str {
        match self {
            Signal::Micro { name, .. } | Signal::Macro { name, .. } | Signal::Propagated { name, .. } => name,
        }
    }
}

/// Receives the requested signals at its interval.
pub trait Observer {
    /// Called with the time and the signal values (in the order the master was given them).
    fn observe(&mut self, t: Ticks, signals: &[f64]) -> Result<(), String>;
}

impl<F: FnMut(Ticks, &[f64]) -> Result<(), String>> Observer for F {
    fn observe(&mut self, t: Ticks, signals: &[f64]) -> Result<(), String> {
        self(t, signals)
    }
}

/// A coupling algorithm over its elements: the [`InterfaceMaster`] of the reduced model (two
/// elements, multirate, interpolated) and the [`ConnectedMaster`] (Gauss–Seidel or Jacobi over
/// connections). Whoever runs a coupled model — `lash run --model reduced`, system files, sweeps,
/// `lash bench` — drives it through this trait: signals by name, observers at their intervals,
/// one statistics record, every [`lash_core::StepOutcome`] honoured by [`advance`].
pub trait Algorithm {
    /// Names of the recorded signals, in the order observers receive them.
    fn signal_names(&self) -> Vec<String>;
    /// Initialises the elements and runs to the stop time; observers come with their intervals
    /// and are called at the start time too. An element that ends the run early without an error
    /// is reported in [`MasterStats::stopped`], not as an error.
    fn run(&mut self, observers: &mut [(&mut dyn Observer, Ticks)]) -> Result<MasterStats, MasterError>;
}

/// Why a coupled run stopped.
#[derive(Debug, thiserror::Error)]
pub enum MasterError {
    /// Settings that do not fit together.
    #[error("master settings: {0}")]
    Settings(String),
    /// Steps that do not fit together (ratios, coupling and execution).
    #[error("master settings: {0}")]
    Steps(#[from] StepError),
    /// A variable the coupling needs is missing or has the wrong causality or shape.
    #[error("subsystem {subsystem}: {problem}")]
    Variables {
        /// Which subsystem.
        subsystem: String,
        /// What is missing.
        problem: String,
    },
    /// A subsystem call failed.
    #[error("{subsystem} subsystem: {source}")]
    Subsystem {
        /// Which subsystem.
        subsystem: &'static str,
        /// The error.
        source: SubsystemError,
    },
    /// An observer refused a sample.
    #[error("observer: {0}")]
    Observer(String),
    /// An element of a connected execution failed.
    #[error("at t = {} s, element {name:?}: {source}", t.seconds())]
    Element {
        /// Its name.
        name: String,
        /// Communication point of the failing call.
        t: Ticks,
        /// What it said.
        source: SubsystemError,
    },
    /// An element of a connected execution refused its initialization.
    #[error("element {name:?}: initialization refused: {source}")]
    Initialization {
        /// Its index.
        element: usize,
        /// Its name.
        name: String,
        /// What it said.
        source: SubsystemError,
    },
    /// A subsystem ended the run without an error (it asked to stop, or returned early). The
    /// master turns this into [`MasterStats::stopped`]; it reaches callers only from
    /// [`advance`].
    #[error("{subsystem} subsystem {reason}")]
    Stopped {
        /// Which subsystem.
        subsystem: &'static str,
        /// Why.
        reason: StopReason,
    },
}

/// Steps `sub` from `t` by `h` and honours its [`lash_core::StepOutcome`]: `Ok(None)` when the
/// step was completed; `Ok(Some(reason))` when it was completed and the subsystem asks to stop
/// after it (the state at `t + h` is valid: record it, then end the run);
/// [`MasterError::Stopped`] when it returned early or asked to stop inside the step. Every master
/// steps subsystems through this function, so no outcome is mistaken for a completed step.
pub fn advance(
    sub: &mut dyn Subsystem,
    who: &'static str,
    t: Ticks,
    h: Ticks,
) -> Result<Option<StopReason>, MasterError> {
    let outcome = sub.do_step(t, h).map_err(|source| MasterError::Subsystem { subsystem: who, source })?;
    match outcome.stop(t, h) {
        None => Ok(None),
        Some(reason @ StopReason::Requested { reached }) if reached.0 == t.0 + h.0 => Ok(Some(reason)),
        Some(reason) => Err(MasterError::Stopped { subsystem: who, reason }),
    }
}

/// [`advance`] for consecutive steps taken in one call ([`Subsystem::do_steps`], one step per
/// element of `record`, the flagged ones' outputs `refs` read into `rows`): returns how many steps
/// completed (their rows are valid) and, as [`advance`] does, `Ok(None)` when all completed,
/// `Ok(Some(reason))` when the last completed and the subsystem asks to stop after it, and
/// [`MasterError::Stopped`] when one returned early or asked to stop inside its step (that step is
/// not counted).
pub fn advance_steps(
    sub: &mut dyn Subsystem,
    who: &'static str,
    t: Ticks,
    h: Ticks,
    record: &[bool],
    refs: &[ValueReference],
    rows: &mut [f64],
) -> (usize, Result<Option<StopReason>, MasterError>) {
    let steps = sub.do_steps(t, h, record, refs, rows);
    steps_outcome(steps, who, t, h, record.len())
}

/// What [`Subsystem::do_steps`]' result means for a master that asked for `asked` steps of `h`
/// from `t`: the steps completed, and a stop or an error ([`advance_steps`]).
fn steps_outcome(
    steps: lash_core::Steps,
    who: &'static str,
    t: Ticks,
    h: Ticks,
    asked: usize,
) -> (usize, Result<Option<StopReason>, MasterError>) {
    let outcome = match steps.last {
        Ok(outcome) => outcome,
        Err(source) => return (steps.taken, Err(MasterError::Subsystem { subsystem: who, source })),
    };
    if steps.taken == 0 {
        return (0, Ok(None));
    }
    let last = Ticks(t.0 + (steps.taken as i64 - 1) * h.0);
    match outcome.stop(last, h) {
        None if steps.taken == asked => (steps.taken, Ok(None)),
        None => (
            steps.taken,
            Err(MasterError::Subsystem {
                subsystem: who,
                source: SubsystemError::Other(format!(
                    "took {} of {} steps without saying why it stopped",
                    steps.taken, asked
                )),
            }),
        ),
        Some(reason @ StopReason::Requested { reached }) if reached.0 == last.0 + h.0 => {
            (steps.taken, Ok(Some(reason)))
        }
        Some(reason) => (steps.taken - 1, Err(MasterError::Stopped { subsystem: who, reason })),
    }
}

/// [`advance`] for a subsystem whose every stop ends the run at once (the macro subsystem of the
/// interface master, whose nodes run ahead of the micro steps).
fn advance_or_stop(sub: &mut dyn Subsystem, who: &'static str, t: Ticks, h: Ticks) -> Result<(), MasterError> {
    match advance(sub, who, t, h)? {
        None => Ok(()),
        Some(reason) => Err(MasterError::Stopped { subsystem: who, reason }),
    }
}

/// Counters and time split of a coupled run.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct MasterStats {
    /// Macro steps taken.
    pub macro_steps: u64,
    /// Micro steps taken.
    pub micro_steps: u64,
    /// Wall time in macro steps (their thread in threaded execution) \[s\].
    pub macro_seconds: f64,
    /// Wall time in micro steps, input interpolation and observers \[s\].
    pub micro_seconds: f64,
    /// Set when a subsystem ended the run before the stop time without an error: which one
    /// ("macro" or "micro" for the interface master, the element's name for the connected one)
    /// and why. Observers have every sample up to the last point all elements completed.
    #[serde(skip)]
    pub stopped: Option<(String, StopReason)>,
}

fn macro_err(source: SubsystemError) -> MasterError {
    MasterError::Subsystem { subsystem: "macro", source }
}

fn micro_err(source: SubsystemError) -> MasterError {
    MasterError::Subsystem { subsystem: "micro", source }
}

/// Offsets of each variable in the flat vector of all its elements.
fn offsets(vars: &[Variable]) -> Vec<usize> {
    let mut out = Vec::with_capacity(vars.len() + 1);
    let mut at = 0;
    for v in vars {
        out.push(at);
        at += v.len();
    }
    out.push(at);
    out
}

fn lookup(
    vars: &[Variable],
    who: &str,
    name: &str,
    causality: Causality,
    len: Option<usize>,
) -> Result<ValueReference, MasterError> {
    let v = vars.iter().find(|v| v.name == name).ok_or_else(|| MasterError::Variables {
        subsystem: who.to_string(),
        problem: format!("has no variable {name:?}"),
    })?;
    if v.kind != lash_core::ValueKind::Float64 {
        return Err(MasterError::Variables {
            subsystem: who.to_string(),
            problem: format!("variable {name:?} is {}, the coupling needs Float64", v.kind.name()),
        });
    }
    if v.causality != causality {
        return Err(MasterError::Variables {
            subsystem: who.to_string(),
            problem: format!("variable {name:?} is {:?}, the coupling needs {causality:?}", v.causality),
        });
    }
    if let Some(n) = len.filter(|&n| n != v.len()) {
        return Err(MasterError::Variables {
            subsystem: who.to_string(),
            problem: format!("variable {name:?} has {} elements, the coupling needs {n}", v.len()),
        });
    }
    Ok(v.value_reference)
}

/// Signals resolved to indices.
#[derive(Debug, Clone, Copy)]
enum Resolved {
    Micro(usize),
    Macro { value: usize, derivative: Option<usize> },
    Propagated { free: usize, gain: usize },
}

/// Frame-vector indices of the coupling quantities: for each micro input value (in input order),
/// the frame element it interpolates; angular velocities come with the element of their
/// derivative.
#[derive(Debug, Clone)]
struct CouplingIndex {
    /// (frame element, frame element of its derivative) for each value input.
    elements: Vec<(usize, Option<usize>)>,
    /// Where each input variable's values start in the input vector (values then rates).
    layout: Vec<(usize, usize)>,
}

/// What [`InterfaceMaster::run`] prepares before its first macro step (`InterfaceMaster::prepare`).
struct Prepared {
    per_macro: usize,
    fractions: Vec<f64>,
    macro_steps: usize,
    decimation: Vec<u64>,
    micro_inputs: Vec<ValueReference>,
    index: CouplingIndex,
    width_in: usize,
    target_inputs: Option<[ValueReference; 3]>,
    micro_outputs: Vec<ValueReference>,
    coupling_outputs: [ValueReference; 3],
    loads: usize,
    n: usize,
    k: usize,
    ecc_at: usize,
    rate_at: usize,
    impulse_at: usize,
    micro_width: usize,
    all_macro: Vec<ValueReference>,
    width: usize,
    first: Vec<f64>,
    ahead: usize,
    h_m: f64,
    stats: MasterStats,
    signals: Vec<f64>,
    table: SignalTable,
    micro_values: Vec<f64>,
    coupling_values: Vec<f64>,
}

impl CouplingIndex {
    /// The micro inputs at fraction `s` of the macro step `w`: each value and its rate (the
    /// rate 0 when inputs are held).
    fn fill(&self, w: &Window<'_>, kind: Interpolation, s: f64, inputs: &mut [f64]) {
        let mut elements = self.elements.iter();
        for &(values, rates) in &self.layout {
            for e in 0..rates - values {
                let &(value, derivative) = elements.next().expect("one element per input value");
                let (v, rate) = match derivative {
                    Some(d) => w.with_derivative(kind, value, d, s),
                    None => w.coupling(kind, value, s),
                };
                inputs[values + e] = v;
                inputs[rates + e] = if kind == Interpolation::ZeroOrderHold { 0.0 } else { rate };
            }
        }
    }
}

/// Which of the next `due.len()` micro steps an observer samples: a dry run of the countdowns
/// `left` (each observer's steps to its next sample; `decimation`, its interval in steps) in
/// `scratch`.
fn due_steps(left: &[u64], decimation: &[u64], scratch: &mut [u64], due: &mut [bool]) {
    scratch.copy_from_slice(left);
    for d in due.iter_mut() {
        *d = false;
        for (l, p) in scratch.iter_mut().zip(decimation) {
            *l -= 1;
            if *l == 0 {
                *d = true;
                *l = *p;
            }
        }
    }
}

/// The multirate master of the reduced interface model.
pub struct InterfaceMaster<'a> {
    macro_sub: &'a mut dyn Subsystem,
    micro_sub: &'a mut dyn Subsystem,
    options: MasterOptions,
    signals: Vec<Signal>,
}

/// Cubic Hermite value and derivative at `s` in [0, 1] over a step of length `h`.
#[inline]
fn hermite(a: f64, ma: f64, b: f64, mb: f64, s: f64, h: f64) -> (f64, f64) {
    let (s2, s3) = (s * s, s * s * s);
    let v = (2.0 * s3 - 3.0 * s2 + 1.0) * a
        + (s3 - 2.0 * s2 + s) * h * ma
        + (-2.0 * s3 + 3.0 * s2) * b
        + (s3 - s2) * h * mb;
    let d = ((6.0 * s2 - 6.0 * s) * a
        + (3.0 * s2 - 4.0 * s + 1.0) * h * ma
        + (-6.0 * s2 + 6.0 * s) * b
        + (3.0 * s2 - 2.0 * s) * h * mb)
        / h;
    (v, d)
}

/// The node window of one macro step: the nodes before, at the start, at the end and after.
struct Window<'f> {
    prev: Option<&'f [f64]>,
    a: &'f [f64],
    b: &'f [f64],
    next: Option<&'f [f64]>,
    h: f64,
}

impl Window<'_> {
    /// Slopes at a and b by finite differences (centred where the neighbour exists).
    #[inline]
    fn slopes(&self, i: usize) -> (f64, f64) {
        let (a, b) = (self.a[i], self.b[i]);
        let ma = self.prev.map_or((b - a) / self.h, |p| (b - p[i]) / (2.0 * self.h));
        let mb = self.next.map_or((b - a) / self.h, |n| (n[i] - a) / (2.0 * self.h));
        (ma, mb)
    }

    /// Value and rate of element `i` at fraction `s`.
    #[inline]
    fn coupling(&self, kind: Interpolation, i: usize, s: f64) -> (f64, f64) {
        let (a, b) = (self.a[i], self.b[i]);
        match kind {
            Interpolation::Linear => (a + (b - a) * s, (b - a) / self.h),
            Interpolation::ZeroOrderHold => (a, 0.0),
            Interpolation::CubicHermite => {
                let (ma, mb) = self.slopes(i);
                hermite(a, ma, b, mb, s, self.h)
            }
        }
    }

    /// Value and rate of element `i` whose derivative is element `d`.
    #[inline]
    fn with_derivative(&self, kind: Interpolation, i: usize, d: usize, s: f64) -> (f64, f64) {
        match kind {
            Interpolation::CubicHermite => hermite(self.a[i], self.a[d], self.b[i], self.b[d], s, self.h),
            _ => self.coupling(kind, i, s),
        }
    }
}

/// Where the macro frames come from: the macro stepped in place, or a producer thread.
enum Frames<'s> {
    /// `spare`: a frame the master is done with, whose storage the next frame takes.
    Local {
        sub: &'s mut dyn Subsystem,
        all: Vec<ValueReference>,
        width: usize,
        seconds: f64,
        spare: Option<Vec<f64>>,
    },
    Channel(crossbeam_channel::Receiver<Result<Vec<f64>, MasterError>>),
}

/// Two-way coupling inputs: value references of the macro's `eccentricity`, `eccentricity_rate`,
/// `friction_force` and their values (e, ė at the end of the step, mean F_T over it).
type Targets<'t> = (&'t [ValueReference; 3], &'t [f64]);

impl Frames<'_> {
    fn next(&mut self, t: Ticks, h: Ticks, targets: Option<Targets<'_>>) -> Result<Vec<f64>, MasterError> {
        match self {
            Frames::Local { sub, all, width, seconds, spare } => {
                let start = Instant::now();
                let frame = step_macro(&mut **sub, all, *width, t, h, targets, spare.take());
                *seconds += start.elapsed().as_secs_f64();
                frame
            }
            Frames::Channel(rx) => rx
                .recv()
                .map_err(|_| MasterError::Settings("the macro producer thread stopped without a result".into()))?,
        }
    }

    /// Hands back a frame the master is done with (its storage serves the next one).
    fn recycle(&mut self, frame: Option<Vec<f64>>) {
        if let Frames::Local { spare, .. } = self {
            *spare = frame;
        }
    }

    fn save(&mut self) -> Result<lash_core::SavedState, MasterError> {
        match self {
            Frames::Local { sub, .. } => sub.save_state().map_err(macro_err),
            Frames::Channel(_) => Err(MasterError::Settings("rollback needs sequential execution".into())),
        }
    }

    fn restore(&mut self, state: &lash_core::SavedState) -> Result<(), MasterError> {
        match self {
            Frames::Local { sub, .. } => sub.restore_state(state).map_err(macro_err),
            Frames::Channel(_) => Err(MasterError::Settings("rollback needs sequential execution".into())),
        }
    }
}

/// The macro outputs `all` (`width` numbers), in `spare`'s storage if given (no allocation).
fn read_frame(
    sub: &dyn Subsystem,
    all: &[ValueReference],
    width: usize,
    spare: Option<Vec<f64>>,
) -> Result<Vec<f64>, MasterError> {
    let mut frame = spare.unwrap_or_default();
    frame.resize(width, 0.0);
    sub.get_f64(all, &mut frame).map_err(macro_err)?;
    Ok(frame)
}

fn step_macro(
    sub: &mut dyn Subsystem,
    all: &[ValueReference],
    width: usize,
    t: Ticks,
    h: Ticks,
    targets: Option<Targets<'_>>,
    spare: Option<Vec<f64>>,
) -> Result<Vec<f64>, MasterError> {
    let _span = tracing::debug_span!("macro_step", t = t.seconds()).entered();
    if let Some((vrs, values)) = targets {
        sub.set_f64(vrs, values).map_err(macro_err)?;
    }
    advance_or_stop(sub, "macro", t, h)?;
    read_frame(sub, all, width, spare)
}

impl<'a> InterfaceMaster<'a> {
    /// A master over two subsystems that have been set up (not yet initialised).
    pub fn new(
        macro_sub: &'a mut dyn Subsystem,
        micro_sub: &'a mut dyn Subsystem,
        options: MasterOptions,
        signals: Vec<Signal>,
    ) -> Result<Self, MasterError> {
        let o = &options;
        for sub in [&*macro_sub, &*micro_sub] {
            lash_core::check_variable_table(sub.variables())
                .map_err(|problem| MasterError::Variables { subsystem: sub.name().to_string(), problem })?;
        }
        o.check()?;
        Ok(Self { macro_sub, micro_sub, options, signals })
    }

    /// Names of the signals, in observer order.
    pub fn signal_names(&self) -> Vec<String> {
        self.signals.iter().map(|s| s.name().to_string()).collect()
    }

    /// Everything a run needs before its first macro step: the coupling variables and signals
    /// resolved, both subsystems initialised, the first macro frame read and the micro inputs set
    /// from it, the first micro outputs read.
    fn prepare(&mut self, observers: &[(&mut dyn Observer, Ticks)]) -> Result<Prepared, MasterError> {
        let o = self.options;
        let per_macro = o.macro_step.exact_ratio(o.micro_step).expect("checked") as usize;
        // The fractions j / per_macro of the macro step at the micro steps' ends, divided once.
        let fractions: Vec<f64> = (0..=per_macro).map(|j| j as f64 / per_macro as f64).collect();
        let macro_steps = Ticks(o.stop.0 - o.start.0).exact_ratio(o.macro_step).expect("checked") as usize;
        let mut decimation = Vec::with_capacity(observers.len());
        for (_, interval) in observers.iter() {
            match interval.exact_ratio(o.micro_step) {
                Some(d) if d >= 1 => decimation.push(d as u64),
                _ => {
                    return Err(MasterError::Settings(format!(
                        "observer interval {} s is not a whole multiple of the micro step {} s",
                        interval.seconds(),
                        o.micro_step.seconds()
                    )));
                }
            }
        }

        // Resolve the coupling variables and the signals.
        let (mac_vars, mic_vars) = (self.macro_sub.variables(), self.micro_sub.variables());
        let (mac_name, mic_name) = (self.macro_sub.name().to_string(), self.micro_sub.name().to_string());
        let mac_off = offsets(mac_vars);
        let out = Causality::Output;
        // Sizes: n interface coordinates, r angular velocity components per side (planar: one
        // per joint; spherical: three), m friction loads (planar: one per joint, F_T; spherical:
        // three, n × F_T).
        let size = |name: &str| -> Result<usize, MasterError> {
            Ok(mac_vars[lookup(mac_vars, &mac_name, name, out, None)? as usize].len())
        };
        // The interface terms in effective-mass form (M̃, f̃, H) or, where the micro subsystem takes
        // them so (spherical joints), in mobility form (W, a_free, G = W H).
        let mobility_form = mic_vars.iter().any(|v| v.name == "mobility" && v.causality == Causality::Input);
        let [matrix, force, friction_map] = if mobility_form {
            ["mobility", "free_acceleration", "friction_mobility"]
        } else {
            ["effective_mass", "effective_force", "friction_moment_force"]
        };
        let (n, r) = (size(force)?, size("journal_angular_velocity")?);
        let moment_map = size(friction_map)?;
        if n == 0 || moment_map % n != 0 {
            return Err(MasterError::Variables {
                subsystem: mac_name.clone(),
                problem: format!("{friction_map} has {moment_map} elements, not a multiple of n = {n}"),
            });
        }
        let k = moment_map / n;
        let at = |name: &str, len: usize| -> Result<usize, MasterError> {
            Ok(mac_off[lookup(mac_vars, &mac_name, name, out, Some(len))? as usize])
        };
        let inp = Causality::Input;
        // (name, elements, derivative variable of the macro)
        let couplings: [(&str, usize, Option<&str>); 5] = [
            (matrix, n * n, None),
            (force, n, None),
            (friction_map, n * k, None),
            ("journal_angular_velocity", r, Some("journal_angular_acceleration")),
            ("bearing_angular_velocity", r, Some("bearing_angular_acceleration")),
        ];
        let mut micro_inputs = Vec::with_capacity(2 * couplings.len());
        let mut index = CouplingIndex { elements: Vec::new(), layout: Vec::new() };
        let mut width_in = 0;
        for (name, len, derivative) in couplings {
            let start = at(name, len)?;
            let derivative_start = derivative.map(|d| at(d, len)).transpose()?;
            let rate_name = derivative.map_or_else(|| format!("{name}_rate"), str::to_string);
            micro_inputs.push(lookup(mic_vars, &mic_name, name, inp, Some(len))?);
            micro_inputs.push(lookup(mic_vars, &mic_name, &rate_name, inp, Some(len))?);
            index.layout.push((width_in, width_in + len));
            width_in += 2 * len;
            for e in 0..len {
                index.elements.push((start + e, derivative_start.map(|d| d + e)));
            }
        }
        let target_inputs = match o.coupling {
            Coupling::TwoWay => Some([
                lookup(mac_vars, &mac_name, "eccentricity", Causality::Input, Some(n))?,
                lookup(mac_vars, &mac_name, "eccentricity_rate", Causality::Input, Some(n))?,
                lookup(mac_vars, &mac_name, "friction_force", Causality::Input, Some(k))?,
            ]),
            Coupling::OneWay => None,
        };
        // Micro outputs read every micro step: the loads (contact forces, friction loads) first,
        // then the signals'. Two-way coupling reads the eccentricities, their rates and the friction
        // impulses at the end of each macro step.
        let mut micro_outputs: Vec<ValueReference> = vec![
            lookup(mic_vars, &mic_name, "contact_force", out, Some(n))?,
            lookup(mic_vars, &mic_name, "friction_load", out, Some(k))?,
        ];
        let coupling_outputs = [
            lookup(mic_vars, &mic_name, "eccentricity", out, Some(n))?,
            lookup(mic_vars, &mic_name, "eccentricity_rate", out, Some(n))?,
            lookup(mic_vars, &mic_name, "friction_impulse", out, Some(k))?,
        ];
        let loads = n + k;
        let (ecc_at, rate_at, impulse_at) = (0, n, 2 * n);
        let mut resolved = Vec::with_capacity(self.signals.len());
        let element =
            |vars: &[Variable], who: &str, name: &str, e: usize| -> Result<(ValueReference, usize), MasterError> {
                let vr = vars.iter().find(|v| v.name == *name).map(|v| v.value_reference).ok_or_else(|| {
                    MasterError::Variables { subsystem: who.to_string(), problem: format!("has no variable {name:?}") }
                })?;
                if e >= vars[vr as usize].len() {
                    return Err(MasterError::Variables {
                        subsystem: who.to_string(),
                        problem: format!("variable {name:?} has no element {e}"),
                    });
                }
                Ok((vr, e))
            };
        let mac_index = |name: &str, e: usize| -> Result<usize, MasterError> {
            let (vr, e) = element(mac_vars, &mac_name, name, e)?;
            Ok(mac_off[vr as usize] + e)
        };
        for s in &self.signals {
            resolved.push(match s {
                Signal::Micro { variable, element: e, .. } => {
                    let (vr, e) = element(mic_vars, &mic_name, variable, *e)?;
                    let pos = micro_outputs.iter().position(|&v| v == vr).unwrap_or_else(|| {
                        micro_outputs.push(vr);
                        micro_outputs.len() - 1
                    });
                    let base: usize = micro_outputs[..pos].iter().map(|&v| mic_vars[v as usize].len()).sum();
                    Resolved::Micro(base + e)
                }
                Signal::Macro { variable, element: e, derivative, .. } => Resolved::Macro {
                    value: mac_index(variable, *e)?,
                    derivative: derivative.as_ref().map(|(v, e)| mac_index(v, *e)).transpose()?,
                },
                Signal::Propagated { free, gain, .. } => {
                    mac_index(&gain.0, gain.1 + loads - 1)?;
                    Resolved::Propagated { free: mac_index(&free.0, free.1)?, gain: mac_index(&gain.0, gain.1)? }
                }
            });
        }
        let micro_width: usize = micro_outputs.iter().map(|&v| mic_vars[v as usize].len()).sum();
        let all_macro: Vec<ValueReference> = mac_vars.iter().map(|v| v.value_reference).collect();
        let width = *mac_off.last().expect("offsets end");

        // Initialise.
        self.macro_sub.initialize().map_err(macro_err)?;
        self.micro_sub.initialize().map_err(micro_err)?;
        let first = read_frame(&*self.macro_sub, &all_macro, width, None)?;
        let ahead = match (o.coupling, o.interpolation) {
            (Coupling::OneWay, Interpolation::CubicHermite) => 2,
            _ => 1,
        };
        let h_m = o.macro_step.seconds();
        let stats = MasterStats::default();
        let signals = vec![0.0; resolved.len()];
        let table = SignalTable::new(&resolved, loads, h_m);
        // The micro inputs at the start (the first frame's values, no rate) before anything is
        // read: a micro joint that starts where it holds its load (a bushing) settles there, so
        // the first sample is already the settled one. (Each macro step sets them again.)
        {
            let w = Window { prev: None, a: &first, b: &first, next: None, h: h_m };
            let mut inputs = vec![0.0; width_in];
            let mut elements = index.elements.iter();
            for &(values, rates) in &index.layout {
                for e in 0..rates - values {
                    let &(value, derivative) = elements.next().expect("one element per input value");
                    inputs[values + e] = match derivative {
                        Some(d) => w.with_derivative(Interpolation::Linear, value, d, 0.0).0,
                        None => w.coupling(Interpolation::Linear, value, 0.0).0,
                    };
                }
            }
            self.micro_sub.set_f64(&micro_inputs, &inputs).map_err(micro_err)?;
        }
        let mut micro_values = vec![0.0; micro_width];
        self.micro_sub.get_f64(&micro_outputs, &mut micro_values).map_err(micro_err)?;
        let mut coupling_values = vec![0.0; 2 * n + k];
        self.micro_sub.get_f64(&coupling_outputs, &mut coupling_values).map_err(micro_err)?;
        Ok(Prepared {
            per_macro,
            fractions,
            macro_steps,
            decimation,
            micro_inputs,
            index,
            width_in,
            target_inputs,
            micro_outputs,
            coupling_outputs,
            loads,
            n,
            k,
            ecc_at,
            rate_at,
            impulse_at,
            micro_width,
            all_macro,
            width,
            first,
            ahead,
            h_m,
            stats,
            signals,
            table,
            micro_values,
            coupling_values,
        })
    }

    /// Initialises both subsystems and runs to the stop time. Each observer comes with its
    /// interval (a whole multiple of the micro step); all are called at the start time too.
    pub fn run(&mut self, observers: &mut [(&mut dyn Observer, Ticks)]) -> Result<MasterStats, MasterError> {
        let o = self.options;
        let Prepared {
            per_macro,
            fractions,
            macro_steps,
            decimation,
            micro_inputs,
            index,
            width_in,
            target_inputs,
            micro_outputs,
            coupling_outputs,
            loads,
            n,
            k,
            ecc_at,
            rate_at,
            impulse_at,
            micro_width,
            all_macro,
            width,
            first,
            ahead,
            h_m,
            mut stats,
            mut signals,
            mut table,
            micro_values,
            mut coupling_values,
        } = self.prepare(observers)?;
        let Self { macro_sub, micro_sub, .. } = self;
        let micro_sub: &mut dyn Subsystem = &mut **micro_sub;
        let macro_sub: &mut dyn Subsystem = &mut **macro_sub;
        let mut run = |frames: &mut Frames<'_>, stats: &mut MasterStats| -> Result<(), MasterError> {
            let mut window: VecDeque<Vec<f64>> = VecDeque::with_capacity(4);
            window.push_back(first.clone());
            let mut prev: Option<Vec<f64>> = None;
            let mut produced = 0usize;
            // Observers at the start.
            {
                let w = Window { prev: None, a: &window[0], b: &window[0], next: None, h: h_m };
                table.prepare(&w);
                table.fill(0.0, &micro_values[..loads], &micro_values, &mut signals);
                for (obs, _) in observers.iter_mut() {
                    obs.observe(o.start, &signals).map_err(MasterError::Observer)?;
                }
            }
            let mut micro_count = 0u64;
            let mut inputs = vec![0.0; width_in];
            // Two-way: the targets (e, ė at the step end, mean F_T over the step), the friction
            // impulses at the step start and the last step's mean friction forces.
            let mut targets = vec![0.0; 2 * n + k];
            let mut impulse_start = vec![0.0; k];
            let mut mean_friction = vec![0.0; k];
            // Countdown of each observer to its next sample (in micro steps): no division per step.
            let mut left = decimation.clone();
            // Which micro steps of an interval any observer samples (the micro outputs are read
            // only there), and the rows the micro subsystem records at them.
            let mut due = vec![false; per_macro];
            let mut scratch = left.clone();
            let mut rows = vec![0.0; per_macro * micro_width];
            for step in 0..macro_steps {
                let t_k = Ticks(o.start.0 + step as i64 * o.macro_step.0);
                // Two-way: save the macro at t_k and predict with the eccentricity extrapolated.
                // (Predictor: e + ė h_m, ė, and the last step's mean friction forces.)
                let saved = match &target_inputs {
                    Some(vrs) => {
                        let saved = frames.save()?;
                        for i in 0..n {
                            let (e, v) = (coupling_values[ecc_at + i], coupling_values[rate_at + i]);
                            targets[i] = e + v * h_m;
                            targets[n + i] = v;
                        }
                        targets[2 * n..].copy_from_slice(&mean_friction);
                        impulse_start.copy_from_slice(&coupling_values[impulse_at..impulse_at + k]);
                        Some((saved, vrs))
                    }
                    None => None,
                };
                while produced < (step + ahead).min(macro_steps) {
                    let t = Ticks(o.start.0 + produced as i64 * o.macro_step.0);
                    let predicted = saved.as_ref().map(|(_, vrs)| (*vrs, &targets[..]));
                    window.push_back(frames.next(t, o.macro_step, predicted)?);
                    produced += 1;
                    stats.macro_steps += 1;
                }
                let started = Instant::now();
                let _span = tracing::trace_span!("micro_interval", t = t_k.seconds()).entered();
                let w = Window {
                    prev: prev.as_deref(),
                    a: &window[0],
                    b: &window[1],
                    next: window.get(2).map(|v| v.as_slice()),
                    h: h_m,
                };
                table.prepare(&w);
                let kind = o.interpolation;
                // Linear and held inputs are exact as value + rate from the macro node: the micro
                // subsystem extrapolates u(t_k) + u̇ (τ − t_k) itself, so they are set once per
                // macro step (as FMI input derivatives). Cubic Hermite is set at every micro step.
                let every_micro_step = kind == Interpolation::CubicHermite;
                // Inputs held as value + rate are set once and the whole interval is one call of
                // the micro subsystem; cubic Hermite inputs are set before every micro step.
                let batch = if every_micro_step { 1 } else { per_macro };
                let mut j = 0;
                while j < per_macro {
                    index.fill(&w, kind, fractions[j], &mut inputs);
                    micro_sub.set_f64(&micro_inputs, &inputs).map_err(micro_err)?;
                    // The steps at which an observer is due.
                    let due = &mut due[..batch];
                    due_steps(&left, &decimation, &mut scratch, due);
                    let t = Ticks(t_k.0 + j as i64 * o.micro_step.0);
                    let (completed, outcome) =
                        advance_steps(micro_sub, "micro", t, o.micro_step, due, &micro_outputs, &mut rows);
                    micro_count += completed as u64;
                    // The samples of the completed steps, in order (the countdowns run for real).
                    let mut row = 0;
                    for (i, &sampled) in due[..completed].iter().enumerate() {
                        for l in left.iter_mut() {
                            *l -= 1;
                        }
                        if !sampled {
                            continue;
                        }
                        let micro = &rows[row * micro_width..(row + 1) * micro_width];
                        row += 1;
                        table.fill(fractions[j + i + 1], &micro[..loads], micro, &mut signals);
                        let t1 = Ticks(t.0 + (i as i64 + 1) * o.micro_step.0);
                        for (((obs, _), l), d) in observers.iter_mut().zip(left.iter_mut()).zip(&decimation) {
                            if *l == 0 {
                                *l = *d;
                                obs.observe(t1, &signals).map_err(MasterError::Observer)?;
                            }
                        }
                    }
                    stats.micro_steps = micro_count;
                    if let Some(reason) = outcome? {
                        return Err(MasterError::Stopped { subsystem: "micro", reason });
                    }
                    j += batch;
                }
                drop(_span);
                stats.micro_seconds += started.elapsed().as_secs_f64();
                if let Some((state, vrs)) = saved {
                    // Corrector: the macro steps again with the micro's eccentricities at t_k+1 and
                    // its mean friction forces over the step.
                    frames.restore(&state)?;
                    micro_sub.get_f64(&coupling_outputs, &mut coupling_values).map_err(micro_err)?;
                    targets[..2 * n].copy_from_slice(&coupling_values[..2 * n]);
                    for j in 0..k {
                        mean_friction[j] = (coupling_values[impulse_at + j] - impulse_start[j]) / h_m;
                    }
                    targets[2 * n..].copy_from_slice(&mean_friction);
                    window[1] = frames.next(t_k, o.macro_step, Some((vrs, &targets[..])))?;
                    stats.macro_steps += 1;
                }
                frames.recycle(std::mem::replace(&mut prev, window.pop_front()));
            }
            stats.micro_steps = micro_count;
            Ok(())
        };

        // A subsystem that stops the run ends it cleanly: the observers keep what they have.
        let mut run = |frames: &mut Frames<'_>, stats: &mut MasterStats| match run(frames, stats) {
            Err(MasterError::Stopped { subsystem, reason }) => {
                stats.stopped = Some((subsystem.to_string(), reason));
                Ok(())
            }
            other => other,
        };
        match o.execution {
            Execution::Sequential => {
                let mut frames = Frames::Local { sub: macro_sub, all: all_macro, width, seconds: 0.0, spare: None };
                run(&mut frames, &mut stats)?;
                if let Frames::Local { seconds, .. } = frames {
                    stats.macro_seconds = seconds;
                }
            }
            Execution::Threaded => {
                let (tx, rx) = bounded::<Result<Vec<f64>, MasterError>>(8);
                let origin = o.start;
                let result = std::thread::scope(|scope| {
                    let producer = scope.spawn(move || {
                        let started = Instant::now();
                        for k in 0..macro_steps {
                            let t = Ticks(origin.0 + k as i64 * o.macro_step.0);
                            let frame = step_macro(macro_sub, &all_macro, width, t, o.macro_step, None, None);
                            let failed = frame.is_err();
                            if tx.send(frame).is_err() || failed {
                                break;
                            }
                        }
                        started.elapsed()
                    });
                    let mut frames = Frames::Channel(rx);
                    let r = run(&mut frames, &mut stats);
                    drop(frames);
                    let macro_time = producer.join().unwrap_or(Duration::ZERO);
                    (r, macro_time)
                });
                result.0?;
                stats.macro_seconds = result.1.as_secs_f64();
            }
        }
        Ok(stats)
    }
}

/// How the micro subsystems of runs stepped together are advanced: as [`Subsystem::do_steps`] of
/// each (same `t`, `h`, flags and outputs for all), row buffer by row buffer — e.g. lash-contact's
/// `do_steps_together`, which steps suitable ones in lanes.
pub type GroupStep<'f> = dyn FnMut(
        &mut [&mut dyn Subsystem],
        Ticks,
        Ticks,
        &[bool],
        &[ValueReference],
        &mut [&mut [f64]],
    ) -> Vec<lash_core::Steps>
    + 'f;

/// What is done with the macro subsystems of runs stepped together before each of their macro
/// steps (the same `t` and `h` for all): nothing, or work that their `do_step(t, h)` then takes
/// instead of doing it alone — e.g. lash-mech's `kinematic_steps_ahead`, which analyses fully
/// driven mechanisms in lanes. It must leave each subsystem's results as its own `do_step` would
/// make them.
pub type GroupAhead<'f> = dyn FnMut(&mut [&mut dyn Subsystem], Ticks, Ticks) + 'f;

/// One run of [`InterfaceMaster::run_together`] between macro steps.
struct Lane {
    p: Prepared,
    window: VecDeque<Vec<f64>>,
    prev: Option<Vec<f64>>,
    /// A frame done with, whose storage the next macro frame takes.
    spare: Option<Vec<f64>>,
    produced: usize,
    inputs: Vec<f64>,
    left: Vec<u64>,
    rows: Vec<f64>,
    micro_count: u64,
}

impl<'a> InterfaceMaster<'a> {
    /// Runs several masters side by side, a macro step at a time, their micro subsystems advanced
    /// together by `step` once per macro step: each run's result is what its own
    /// [`InterfaceMaster::run`] gives (the same calls in the same order on its subsystems and
    /// observers). Runs together only masters with the same options, one-way coupling,
    /// sequential execution, inputs held as value and rate (not cubic Hermite), the same observer
    /// intervals and the same micro outputs; otherwise each runs alone.
    pub fn run_together(
        masters: &mut [InterfaceMaster<'a>],
        observers: &mut [&mut [(&mut dyn Observer, Ticks)]],
        step: &mut GroupStep<'_>,
        ahead: &mut GroupAhead<'_>,
    ) -> Vec<Result<MasterStats, MasterError>> {
        assert_eq!(masters.len(), observers.len(), "one observer list per master");
        let o = masters.first().map(|m| m.options);
        let intervals = |obs: &[(&mut dyn Observer, Ticks)]| obs.iter().map(|(_, t)| *t).collect::<Vec<_>>();
        let alike = o.is_some_and(|o| {
            o.coupling == Coupling::OneWay
                && o.execution == Execution::Sequential
                && o.interpolation != Interpolation::CubicHermite
                && masters.iter().all(|m| m.options == o)
                && observers.iter().all(|obs| intervals(obs) == intervals(observers[0]))
        });
        if !alike {
            return masters.iter_mut().zip(observers.iter_mut()).map(|(m, obs)| m.run(obs)).collect();
        }
        let o = o.expect("masters");
        let mut results: Vec<Option<Result<MasterStats, MasterError>>> = masters.iter().map(|_| None).collect();
        let mut lanes: Vec<Option<Lane>> = Vec::with_capacity(masters.len());
        for (i, (m, obs)) in masters.iter_mut().zip(observers.iter_mut()).enumerate() {
            let lane = m.prepare(obs).and_then(|mut p| {
                let w = Window { prev: None, a: &p.first, b: &p.first, next: None, h: p.h_m };
                p.table.prepare(&w);
                p.table.fill(0.0, &p.micro_values[..p.loads], &p.micro_values, &mut p.signals);
                for (ob, _) in obs.iter_mut() {
                    ob.observe(o.start, &p.signals).map_err(MasterError::Observer)?;
                }
                let mut window = VecDeque::with_capacity(4);
                window.push_back(p.first.clone());
                Ok(Lane {
                    inputs: vec![0.0; p.width_in],
                    left: p.decimation.clone(),
                    rows: vec![0.0; p.per_macro * p.micro_width],
                    window,
                    prev: None,
                    spare: None,
                    produced: 0,
                    micro_count: 0,
                    p,
                })
            });
            match lane {
                Ok(l) => lanes.push(Some(l)),
                Err(e) => {
                    results[i] = Some(Err(e));
                    lanes.push(None);
                }
            }
        }
        // The same outputs read from every micro subsystem (one list for the group call).
        let refs = lanes.iter().flatten().next().map(|l| l.p.micro_outputs.clone()).unwrap_or_default();
        if lanes.iter().flatten().any(|l| l.p.micro_outputs != refs) {
            for (i, lane) in lanes.iter_mut().enumerate() {
                if lane.take().is_some() {
                    results[i] = Some(Err(MasterError::Settings(
                        "runs stepped together must read the same micro outputs".into(),
                    )));
                }
            }
        }
        let (per_macro, macro_steps) = match lanes.iter().flatten().next() {
            Some(l) => (l.p.per_macro, l.p.macro_steps),
            None => (0, 0),
        };
        let kind = o.interpolation;
        let (mut due, mut scratch, mut due_at) = (vec![false; per_macro], Vec::new(), Vec::with_capacity(per_macro));
        for step_index in 0..macro_steps {
            let t_k = Ticks(o.start.0 + step_index as i64 * o.macro_step.0);
            // Each run: its macro step. (Timed for the group and shared, as the micro steps are:
            // two clock reads per run and macro step were ~1 % of a sweep of scenario A.)
            let started = Instant::now();
            let stepping = lanes.iter().flatten().count();
            // Macro step by macro step (the runs produce the same steps: same options), each
            // preceded by the group's `ahead`.
            loop {
                let due = |l: &Lane| l.produced < (step_index + l.p.ahead).min(macro_steps);
                let Some(produced) = lanes.iter().flatten().filter(|l| due(l)).map(|l| l.produced).min() else {
                    break;
                };
                let t = Ticks(o.start.0 + produced as i64 * o.macro_step.0);
                {
                    let mut subs: Vec<&mut dyn Subsystem> = Vec::with_capacity(lanes.len());
                    for (lane, m) in lanes.iter().zip(masters.iter_mut()) {
                        if lane.as_ref().is_some_and(|l| due(l) && l.produced == produced) {
                            subs.push(&mut *m.macro_sub);
                        }
                    }
                    ahead(&mut subs, t, o.macro_step);
                }
                for (i, (lane, m)) in lanes.iter_mut().zip(masters.iter_mut()).enumerate() {
                    let Some(l) = lane else { continue };
                    if !due(l) || l.produced != produced {
                        continue;
                    }
                    let stepped =
                        step_macro(&mut *m.macro_sub, &l.p.all_macro, l.p.width, t, o.macro_step, None, l.spare.take());
                    match stepped {
                        Ok(frame) => {
                            l.window.push_back(frame);
                            l.produced += 1;
                            l.p.stats.macro_steps += 1;
                        }
                        Err(e) => {
                            results[i] = Some(Self::ended(e, &mut l.p.stats));
                            *lane = None;
                        }
                    }
                }
            }
            let share = started.elapsed().as_secs_f64() / (stepping.max(1) as f64);
            // Each run: its micro inputs for the interval.
            for (i, (lane, m)) in lanes.iter_mut().zip(masters.iter_mut()).enumerate() {
                let Some(l) = lane else { continue };
                l.p.stats.macro_seconds += share;
                let prepared = {
                    let w = Window {
                        prev: l.prev.as_deref(),
                        a: &l.window[0],
                        b: &l.window[1],
                        next: l.window.get(2).map(|v| v.as_slice()),
                        h: l.p.h_m,
                    };
                    l.p.table.prepare(&w);
                    l.p.index.fill(&w, kind, 0.0, &mut l.inputs);
                    m.micro_sub.set_f64(&l.p.micro_inputs, &l.inputs).map_err(micro_err)
                };
                if let Err(e) = prepared {
                    results[i] = Some(Self::ended(e, &mut l.p.stats));
                    *lane = None;
                }
            }
            // The steps at which an observer is due (the same countdowns in every run).
            let Some(first) = lanes.iter().flatten().next() else { break };
            scratch.resize(first.left.len(), 0);
            due_steps(&first.left, &first.p.decimation, &mut scratch, &mut due);
            due_at.clear();
            due_at.extend((0..due.len()).filter(|&j| due[j]));
            // Every run's micro interval in one call.
            let started = Instant::now();
            let members: Vec<usize> = (0..lanes.len()).filter(|&i| lanes[i].is_some()).collect();
            let outcomes = {
                let mut subs: Vec<&mut dyn Subsystem> = Vec::with_capacity(members.len());
                let mut rows: Vec<&mut [f64]> = Vec::with_capacity(members.len());
                for (m, lane) in masters.iter_mut().zip(lanes.iter_mut()) {
                    if let Some(l) = lane {
                        subs.push(&mut *m.micro_sub);
                        rows.push(&mut l.rows[..]);
                    }
                }
                let t = t_k;
                step(&mut subs, t, o.micro_step, &due, &refs, &mut rows)
            };
            let share = started.elapsed().as_secs_f64() / members.len().max(1) as f64;
            // Each run: its samples, in order, to its observers.
            for (&i, steps) in members.iter().zip(outcomes) {
                let (Some(l), obs) = (lanes[i].as_mut(), &mut observers[i]) else { continue };
                l.p.stats.micro_seconds += share;
                let processed = (|| -> Result<(), MasterError> {
                    let (completed, outcome) = steps_outcome(steps, "micro", t_k, o.micro_step, due.len());
                    l.micro_count += completed as u64;
                    let width = l.p.micro_width;
                    // The countdowns reach zero only at the due steps: each is taken down to the
                    // next one at once (what one step at a time gives).
                    let mut counted = 0;
                    for (row, &j) in due_at.iter().take_while(|&&j| j < completed).enumerate() {
                        let steps = (j + 1 - counted) as u64;
                        counted = j + 1;
                        for c in l.left.iter_mut() {
                            *c -= steps;
                        }
                        let micro = &l.rows[row * width..(row + 1) * width];
                        l.p.table.fill(l.p.fractions[j + 1], &micro[..l.p.loads], micro, &mut l.p.signals);
                        let t1 = Ticks(t_k.0 + (j as i64 + 1) * o.micro_step.0);
                        for (((ob, _), c), d) in obs.iter_mut().zip(l.left.iter_mut()).zip(&l.p.decimation) {
                            if *c == 0 {
                                *c = *d;
                                ob.observe(t1, &l.p.signals).map_err(MasterError::Observer)?;
                            }
                        }
                    }
                    for c in l.left.iter_mut() {
                        *c -= (completed - counted) as u64;
                    }
                    l.p.stats.micro_steps = l.micro_count;
                    if let Some(reason) = outcome? {
                        return Err(MasterError::Stopped { subsystem: "micro", reason });
                    }
                    Ok(())
                })();
                if let Err(e) = processed {
                    results[i] = Some(Self::ended(e, &mut l.p.stats));
                    lanes[i] = None;
                    continue;
                }
                l.spare = std::mem::replace(&mut l.prev, l.window.pop_front());
            }
        }
        for (i, lane) in lanes.into_iter().enumerate() {
            if let Some(mut l) = lane {
                l.p.stats.micro_steps = l.micro_count;
                results[i] = Some(Ok(l.p.stats));
            }
        }
        results.into_iter().map(|r| r.expect("every run ends")).collect()
    }

    /// A run ended by `e`: a stop is a clean end (the observers keep what they have), anything
    /// else the run's error.
    fn ended(e: MasterError, stats: &mut MasterStats) -> Result<MasterStats, MasterError> {
        match e {
            MasterError::Stopped { subsystem, reason } => {
                stats.stopped = Some((subsystem.to_string(), reason));
                Ok(stats.clone())
            }
            other => Err(other),
        }
    }
}

impl Algorithm for InterfaceMaster<'_> {
    fn signal_names(&self) -> Vec<String> {
        InterfaceMaster::signal_names(self)
    }

    fn run(&mut self, observers: &mut [(&mut dyn Observer, Ticks)]) -> Result<MasterStats, MasterError> {
        InterfaceMaster::run(self, observers)
    }
}

/// The signals grouped by kind, with the node values of the current macro step laid out for the
/// evaluation at every sample ([`SignalTable::prepare`] once per macro step, then
/// [`SignalTable::fill`] per sample). Each value is computed with the same operations in the same
/// order as from the frames directly — a value at fraction s is `a + (b − a) s`, a propagated
/// signal `free(s) + Σ gain_c(s) L_c` over the loads that act, in load order — so the results are
/// bit for bit those of reading the frames; the layout only puts the propagated signals' gains of
/// one load side by side (one pass over the signals per acting load, which the compiler
/// vectorises) and takes the differences b − a once per macro step instead of once per sample.
struct SignalTable {
    /// (output position, micro output index).
    micro: Vec<(usize, usize)>,
    /// (output position, frame element of the value, frame element of its derivative).
    hermite: Vec<(usize, usize, usize)>,
    /// (output position, frame element).
    linear: Vec<(usize, usize)>,
    /// (output position, frame element of the free value, frame element of the first gain).
    propagated: Vec<(usize, usize, usize)>,
    /// Number of loads (contact forces, then friction loads).
    loads: usize,
    /// Macro step \[s\].
    step: f64,
    /// Per `hermite` entry: a, ȧ, b, ḃ of the current step.
    hermite_nodes: Vec<[f64; 4]>,
    /// Per `linear` entry: a, b − a.
    linear_nodes: Vec<[f64; 2]>,
    /// Free values at a and their differences b − a, per propagated signal.
    free: Vec<f64>,
    free_change: Vec<f64>,
    /// Gains at a and their differences, load-major: entry c P + p is load c of signal p.
    gain: Vec<f64>,
    gain_change: Vec<f64>,
    /// The propagated values being summed (one per propagated signal).
    sums: Vec<f64>,
}

/// [`SignalTable::fill_in`] compiled for the baseline, AVX2 and AVX-512 (`multiversion` detects the
/// CPU's features once and calls the widest copy): the same IEEE operations, so the same bits.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512vl+avx512dq", "x86_64+avx2"))]
fn fill_dispatched(table: &mut SignalTable, s: f64, loads: &[f64], micro: &[f64], out: &mut [f64]) {
    table.fill_in(s, loads, micro, out)
}

impl SignalTable {
    fn new(resolved: &[Resolved], loads: usize, step: f64) -> Self {
        let (mut micro, mut hermite, mut linear, mut propagated) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for (at, r) in resolved.iter().enumerate() {
            match *r {
                Resolved::Micro(i) => micro.push((at, i)),
                Resolved::Macro { value, derivative: Some(d) } => hermite.push((at, value, d)),
                Resolved::Macro { value, derivative: None } => linear.push((at, value)),
                Resolved::Propagated { free, gain } => propagated.push((at, free, gain)),
            }
        }
        let p = propagated.len();
        Self {
            hermite_nodes: vec![[0.0; 4]; hermite.len()],
            linear_nodes: vec![[0.0; 2]; linear.len()],
            free: vec![0.0; p],
            free_change: vec![0.0; p],
            gain: vec![0.0; p * loads],
            gain_change: vec![0.0; p * loads],
            sums: vec![0.0; p],
            micro,
            hermite,
            linear,
            propagated,
            loads,
            step,
        }
    }

    /// Takes the node values of the macro step `w`.
    fn prepare(&mut self, w: &Window<'_>) {
        for (n, &(_, value, d)) in self.hermite_nodes.iter_mut().zip(&self.hermite) {
            *n = [w.a[value], w.a[d], w.b[value], w.b[d]];
        }
        for (n, &(_, value)) in self.linear_nodes.iter_mut().zip(&self.linear) {
            *n = [w.a[value], w.b[value] - w.a[value]];
        }
        let count = self.propagated.len();
        for (p, &(_, free, gain)) in self.propagated.iter().enumerate() {
            self.free[p] = w.a[free];
            self.free_change[p] = w.b[free] - w.a[free];
            for c in 0..self.loads {
                self.gain[c * count + p] = w.a[gain + c];
                self.gain_change[c * count + p] = w.b[gain + c] - w.a[gain + c];
            }
        }
    }

    /// Every signal at fraction `s` of the prepared macro step, from the loads (contact forces,
    /// then friction loads) and the micro outputs. With four propagated signals or more, compiled
    /// for the baseline, AVX2 and AVX-512 (the CPU's, detected once): the same IEEE operations in
    /// wider registers and no fused multiply–add, so the bits do not depend on the CPU (E with
    /// four channels: the fill 5.9 → 4.8 % of the run; with one signal, a sweep of A, the dispatch
    /// measured ~2 % slower, so fewer signals are filled in the baseline set).
    #[inline]
    fn fill(&mut self, s: f64, loads: &[f64], micro: &[f64], out: &mut [f64]) {
        if self.propagated.len() < 4 {
            return self.fill_in(s, loads, micro, out);
        }
        fill_dispatched(self, s, loads, micro, out)
    }

    /// [`SignalTable::fill`] in the instruction set it was dispatched to.
    #[inline(always)]
    fn fill_in(&mut self, s: f64, loads: &[f64], micro: &[f64], out: &mut [f64]) {
        for &(at, i) in &self.micro {
            out[at] = micro[i];
        }
        for (&(at, _, _), n) in self.hermite.iter().zip(&self.hermite_nodes) {
            out[at] = hermite(n[0], n[1], n[2], n[3], s, self.step).0;
        }
        for (&(at, _), n) in self.linear.iter().zip(&self.linear_nodes) {
            out[at] = n[0] + n[1] * s;
        }
        let count = self.propagated.len();
        if count == 0 {
            return;
        }
        if count >= 4 {
            return self.fill_propagated_by_fours(s, loads, out);
        }
        if count == 1 {
            // One signal (a sweep's one propagated channel): the same operations in the same
            // order as the loops below, without their bookkeeping.
            let mut sum = self.free[0] + self.free_change[0] * s;
            for (c, &load) in loads[..self.loads].iter().enumerate() {
                if load != 0.0 {
                    sum += (self.gain[c] + self.gain_change[c] * s) * load;
                }
            }
            out[self.propagated[0].0] = sum;
            return;
        }
        // Equal lengths, written out: the loops then compile to straight vector code.
        let sums = &mut self.sums[..count];
        let (free, free_change) = (&self.free[..count], &self.free_change[..count]);
        for p in 0..count {
            sums[p] = free[p] + free_change[p] * s;
        }
        // Loads that do not act (a joint in free flight) add nothing and are skipped.
        for (c, &load) in loads[..self.loads].iter().enumerate() {
            if load == 0.0 {
                continue;
            }
            let (a, d) = (&self.gain[c * count..(c + 1) * count], &self.gain_change[c * count..(c + 1) * count]);
            for p in 0..count {
                sums[p] += (a[p] + d[p] * s) * load;
            }
        }
        for (&(at, _, _), v) in self.propagated.iter().zip(&self.sums) {
            out[at] = *v;
        }
    }

    /// The propagated signals of [`SignalTable::fill_in`], four at a time in fixed-size arrays
    /// (one vector register each in AVX2), the rest one by one: each signal's sum takes the same
    /// operations in the same order as one by one, so the bits are the same. The loop over any
    /// count of signals spent ~1 100 instructions per sample on E's four channels and twelve
    /// loads (its bookkeeping, not its arithmetic).
    #[inline(always)]
    fn fill_propagated_by_fours(&mut self, s: f64, loads: &[f64], out: &mut [f64]) {
        let count = self.propagated.len();
        let (free, free_change) = (&self.free[..count], &self.free_change[..count]);
        let loads = &loads[..self.loads];
        let whole = count - count % 4;
        for first in (0..whole).step_by(4) {
            let mut sums: [f64; 4] = std::array::from_fn(|q| free[first + q] + free_change[first + q] * s);
            for (c, &load) in loads.iter().enumerate() {
                if load == 0.0 {
                    continue;
                }
                let at = c * count + first;
                let a: &[f64; 4] = self.gain[at..at + 4].try_into().expect("four gains");
                let d: &[f64; 4] = self.gain_change[at..at + 4].try_into().expect("four changes");
                for q in 0..4 {
                    sums[q] += (a[q] + d[q] * s) * load;
                }
            }
            self.sums[first..first + 4].copy_from_slice(&sums);
        }
        for p in whole..count {
            let mut sum = free[p] + free_change[p] * s;
            for (c, &load) in loads.iter().enumerate() {
                if load != 0.0 {
                    sum += (self.gain[c * count + p] + self.gain_change[c * count + p] * s) * load;
                }
            }
            self.sums[p] = sum;
        }
        for (&(at, _, _), v) in self.propagated.iter().zip(&self.sums) {
            out[at] = *v;
        }
    }
}

/// The most micro steps one macro step may hold: the master keeps a macro step's micro rows in
/// one buffer, allocated before the run, so the ratio sizes memory.
pub const MAX_MICRO_STEPS_PER_MACRO: i64 = 100_000;

/// Checks that `macro_step` is a whole multiple of `micro_step`, at most
/// [`MAX_MICRO_STEPS_PER_MACRO`] times it; returns the ratio (part of [`MasterOptions::check`]).
pub fn check_step_ratio(macro_step: Ticks, micro_step: Ticks) -> Result<i64, StepError> {
    let ratio = macro_step
        .exact_ratio(micro_step)
        .ok_or(StepError::NotWholeMicroSteps { macro_step: macro_step.seconds(), micro_step: micro_step.seconds() })?;
    if ratio > MAX_MICRO_STEPS_PER_MACRO {
        return Err(StepError::TooManyMicroSteps {
            micro_step: micro_step.seconds(),
            macro_step: macro_step.seconds(),
            ratio,
        });
    }
    Ok(ratio)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn options(start: f64, stop: f64, macro_step: f64, micro_step: f64) -> MasterOptions {
        let t = |s: f64| Ticks::from_seconds(s).unwrap();
        MasterOptions {
            start: t(start),
            stop: t(stop),
            macro_step: t(macro_step),
            micro_step: t(micro_step),
            interpolation: Interpolation::Linear,
            coupling: Coupling::OneWay,
            execution: Execution::Sequential,
        }
    }

    /// The one check of a master's steps: each misfit is refused with its own variant (and the
    /// values in its message), a fitting setting gives its micro steps per macro step.
    #[test]
    fn the_steps_are_checked_in_one_place() {
        assert_eq!(options(0.0, 0.036, 1e-3, 1e-5).check(), Ok(100));
        assert_eq!(options(0.0, 0.036, 1e-3, 5e-6).check(), Ok(200));
        assert!(matches!(options(0.0, 0.036, 1e-3, 3e-6).check(), Err(StepError::NotWholeMicroSteps { .. })));
        assert!(matches!(
            options(0.0, 0.036, 1.0, 1e-6).check(),
            Err(StepError::TooManyMicroSteps { ratio: 1_000_000, .. })
        ));
        let e = options(0.0, 0.0365, 1e-3, 1e-5).check().unwrap_err();
        assert!(matches!(e, StepError::NotWholeMacroSteps { .. }) && e.to_string().contains("0.0365"), "{e}");
        assert!(matches!(options(0.0, 0.0, 1e-3, 1e-5).check(), Err(StepError::NotWholeMacroSteps { .. })));
        let two_way_threaded = MasterOptions {
            coupling: Coupling::TwoWay,
            execution: Execution::Threaded,
            ..options(0.0, 0.01, 1e-3, 1e-5)
        };
        assert_eq!(two_way_threaded.check(), Err(StepError::TwoWayThreaded));
        let o = options(0.0, 0.01, 1e-3, 5e-6);
        assert_eq!(o.check_sampling(Ticks::from_seconds(1e-5).unwrap()), Ok(()));
        assert!(matches!(o.check_sampling(Ticks::from_seconds(7e-6).unwrap()), Err(StepError::OutputInterval { .. })));
    }
}
