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

mod advance;
pub mod connected;
#[cfg(test)]
mod mock;
mod options;
mod signal;
mod signal_table;
mod stepper;
mod together;

pub use advance::{Algorithm, MasterError, advance, advance_steps};
use advance::{advance_or_stop, steps_outcome};
pub use connected::{Carried, ConnectedMaster, Connection, Element, Initialization, Ordering, Port};
pub use options::{Execution, Interpolation, MAX_MICRO_STEPS_PER_MACRO, MasterOptions, StepError, check_step_ratio};
pub use signal::{Observer, Signal};
use signal_table::SignalTable;
use stepper::Stepper;
pub use together::GroupAhead;

use crossbeam_channel::bounded;
use lash_core::{
    AsSubsystem, Causality, Coupling, StopReason, Subsystem, SubsystemError, Ticks, ValueReference, Variable,
};
use std::collections::VecDeque;
use std::time::{Duration, Instant};

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

/// The multirate master of the reduced interface model, over a macro subsystem of type `Ma` and a
/// micro subsystem of type `Mi` (either `dyn Subsystem`, the default, or a concrete type: runs
/// stepped together hand their subsystems to the group's own code by that type).
pub struct InterfaceMaster<'a, Ma: AsSubsystem + ?Sized = dyn Subsystem, Mi: AsSubsystem + ?Sized = dyn Subsystem> {
    macro_sub: &'a mut Ma,
    micro_sub: &'a mut Mi,
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
    Local { sub: &'s mut dyn Subsystem, all: Vec<ValueReference>, width: usize, seconds: f64 },
    Channel(crossbeam_channel::Receiver<Result<Vec<f64>, MasterError>>),
}

/// Two-way coupling inputs: value references of the macro's `eccentricity`, `eccentricity_rate`,
/// `friction_force` and their values (e, ė at the end of the step, mean F_T over it).
type Targets<'t> = (&'t [ValueReference; 3], &'t [f64]);

impl Frames<'_> {
    /// The macro frame of the step from `t`, in `spare`'s storage where the macro steps here.
    fn next(
        &mut self,
        t: Ticks,
        h: Ticks,
        targets: Option<Targets<'_>>,
        spare: Option<Vec<f64>>,
    ) -> Result<Vec<f64>, MasterError> {
        match self {
            Frames::Local { sub, all, width, seconds } => {
                let start = Instant::now();
                let frame = step_macro(&mut **sub, all, *width, t, h, targets, spare);
                *seconds += start.elapsed().as_secs_f64();
                frame
            }
            Frames::Channel(rx) => rx
                .recv()
                .map_err(|_| MasterError::Settings("the macro producer thread stopped without a result".into()))?,
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

/// Each observer's interval in steps of `step` (the `what`: "micro step", "step").
fn decimation(step: Ticks, what: &str, observers: &[(&mut dyn Observer, Ticks)]) -> Result<Vec<u64>, MasterError> {
    observers
        .iter()
        .map(|(_, interval)| match interval.exact_ratio(step) {
            Some(d) if d >= 1 => Ok(d as u64),
            _ => Err(MasterError::Settings(format!(
                "observer interval {} s is not a whole multiple of the {what} {} s",
                interval.seconds(),
                step.seconds()
            ))),
        })
        .collect()
}

/// The coupling's inputs of the micro subsystem, resolved.
struct Couplings {
    micro_inputs: Vec<ValueReference>,
    index: CouplingIndex,
    width_in: usize,
    target_inputs: Option<[ValueReference; 3]>,
    /// Interface coordinates.
    n: usize,
    /// Friction loads.
    k: usize,
}

/// Both subsystems' variables, looked up by name.
struct Sides<'s> {
    mac_vars: &'s [Variable],
    mic_vars: &'s [Variable],
    mac_name: String,
    mic_name: String,
    mac_off: Vec<usize>,
}

impl<'s> Sides<'s> {
    fn of(macro_sub: &'s dyn Subsystem, micro_sub: &'s dyn Subsystem) -> Self {
        let (mac_vars, mic_vars) = (macro_sub.variables(), micro_sub.variables());
        Sides {
            mac_vars,
            mic_vars,
            mac_name: macro_sub.name().to_string(),
            mic_name: micro_sub.name().to_string(),
            mac_off: offsets(mac_vars),
        }
    }

    fn macro_var(&self, name: &str, causality: Causality, len: Option<usize>) -> Result<ValueReference, MasterError> {
        lookup(self.mac_vars, &self.mac_name, name, causality, len)
    }

    fn micro(&self, name: &str, causality: Causality, len: Option<usize>) -> Result<ValueReference, MasterError> {
        lookup(self.mic_vars, &self.mic_name, name, causality, len)
    }

    /// Where macro output `name` (of `len` elements) starts in a frame.
    fn frame_at(&self, name: &str, len: usize) -> Result<usize, MasterError> {
        Ok(self.mac_off[self.macro_var(name, Causality::Output, Some(len))? as usize])
    }

    /// The coupling variables: sizes n (interface coordinates), r (angular velocity components
    /// per side; planar: one per joint, spherical: three) and k (friction loads; planar: one
    /// per joint, F_T; spherical: three, n × F_T) read from the macro's outputs; the interface
    /// terms in effective-mass form (M̃, f̃, H) or, where the micro subsystem takes them so
    /// (spherical joints), in mobility form (W, a_free, G = W H).
    fn couplings(&self, coupling: Coupling) -> Result<Couplings, MasterError> {
        let size = |name: &str| -> Result<usize, MasterError> {
            Ok(self.mac_vars[self.macro_var(name, Causality::Output, None)? as usize].len())
        };
        let mobility_form = self.mic_vars.iter().any(|v| v.name == "mobility" && v.causality == Causality::Input);
        let [matrix, force, friction_map] = if mobility_form {
            ["mobility", "free_acceleration", "friction_mobility"]
        } else {
            ["effective_mass", "effective_force", "friction_moment_force"]
        };
        let (n, r) = (size(force)?, size("journal_angular_velocity")?);
        let moment_map = size(friction_map)?;
        if n == 0 || moment_map % n != 0 {
            return Err(MasterError::Variables {
                subsystem: self.mac_name.clone(),
                problem: format!("{friction_map} has {moment_map} elements, not a multiple of n = {n}"),
            });
        }
        let k = moment_map / n;
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
            let start = self.frame_at(name, len)?;
            let derivative_start = derivative.map(|d| self.frame_at(d, len)).transpose()?;
            let rate_name = derivative.map_or_else(|| format!("{name}_rate"), str::to_string);
            micro_inputs.push(self.micro(name, Causality::Input, Some(len))?);
            micro_inputs.push(self.micro(&rate_name, Causality::Input, Some(len))?);
            index.layout.push((width_in, width_in + len));
            width_in += 2 * len;
            for e in 0..len {
                index.elements.push((start + e, derivative_start.map(|d| d + e)));
            }
        }
        let target_inputs = match coupling {
            Coupling::TwoWay => Some([
                self.macro_var("eccentricity", Causality::Input, Some(n))?,
                self.macro_var("eccentricity_rate", Causality::Input, Some(n))?,
                self.macro_var("friction_force", Causality::Input, Some(k))?,
            ]),
            Coupling::OneWay => None,
        };
        Ok(Couplings { micro_inputs, index, width_in, target_inputs, n, k })
    }

    /// Element `e` of variable `name` of one side.
    fn element(vars: &[Variable], who: &str, name: &str, e: usize) -> Result<(ValueReference, usize), MasterError> {
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
    }

    /// Where element `e` of macro variable `name` is in a frame.
    fn macro_index(&self, name: &str, e: usize) -> Result<usize, MasterError> {
        let (vr, e) = Self::element(self.mac_vars, &self.mac_name, name, e)?;
        Ok(self.mac_off[vr as usize] + e)
    }

    /// The signals resolved to frame elements and micro outputs; the micro outputs they read are
    /// appended to `micro_outputs` (after the `loads`).
    fn signals(
        &self,
        signals: &[Signal],
        loads: usize,
        micro_outputs: &mut Vec<ValueReference>,
    ) -> Result<Vec<Resolved>, MasterError> {
        let mut resolved = Vec::with_capacity(signals.len());
        for s in signals {
            resolved.push(match s {
                Signal::Micro { variable, element: e, .. } => {
                    let (vr, e) = Self::element(self.mic_vars, &self.mic_name, variable, *e)?;
                    let pos = micro_outputs.iter().position(|&v| v == vr).unwrap_or_else(|| {
                        micro_outputs.push(vr);
                        micro_outputs.len() - 1
                    });
                    let base: usize = micro_outputs[..pos].iter().map(|&v| self.mic_vars[v as usize].len()).sum();
                    Resolved::Micro(base + e)
                }
                Signal::Macro { variable, element: e, derivative, .. } => Resolved::Macro {
                    value: self.macro_index(variable, *e)?,
                    derivative: derivative.as_ref().map(|(v, e)| self.macro_index(v, *e)).transpose()?,
                },
                Signal::Propagated { free, gain, .. } => {
                    self.macro_index(&gain.0, gain.1 + loads - 1)?;
                    Resolved::Propagated {
                        free: self.macro_index(&free.0, free.1)?,
                        gain: self.macro_index(&gain.0, gain.1)?,
                    }
                }
            });
        }
        Ok(resolved)
    }
}

impl<'a, Ma: AsSubsystem + ?Sized, Mi: AsSubsystem + ?Sized> InterfaceMaster<'a, Ma, Mi> {
    /// A master over two subsystems that have been set up (not yet initialised).
    pub fn new(
        macro_sub: &'a mut Ma,
        micro_sub: &'a mut Mi,
        options: MasterOptions,
        signals: Vec<Signal>,
    ) -> Result<Self, MasterError> {
        let o = &options;
        for sub in [macro_sub.as_subsystem(), micro_sub.as_subsystem()] {
            lash_core::check_variable_table(sub.variables())
                .map_err(|e| MasterError::Variables { subsystem: sub.name().to_string(), problem: e.to_string() })?;
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
        let decimation = decimation(o.micro_step, "micro step", observers)?;
        let sides = Sides::of(self.macro_sub.as_subsystem(), self.micro_sub.as_subsystem());
        let c = sides.couplings(o.coupling)?;
        let (n, k) = (c.n, c.k);
        let loads = n + k;
        // Micro outputs read every micro step: the loads (contact forces, friction loads) first,
        // then the signals'. Two-way coupling reads the eccentricities, their rates and the friction
        // impulses at the end of each macro step.
        let out = Causality::Output;
        let mut micro_outputs: Vec<ValueReference> =
            vec![sides.micro("contact_force", out, Some(n))?, sides.micro("friction_load", out, Some(k))?];
        let coupling_outputs = [
            sides.micro("eccentricity", out, Some(n))?,
            sides.micro("eccentricity_rate", out, Some(n))?,
            sides.micro("friction_impulse", out, Some(k))?,
        ];
        let resolved = sides.signals(&self.signals, loads, &mut micro_outputs)?;
        let mic_vars = self.micro_sub.variables();
        let micro_width: usize = micro_outputs.iter().map(|&v| mic_vars[v as usize].len()).sum();
        let all_macro: Vec<ValueReference> = self.macro_sub.variables().iter().map(|v| v.value_reference).collect();
        let width = *sides.mac_off.last().expect("offsets end");

        // Initialise.
        self.macro_sub.initialize().map_err(macro_err)?;
        self.micro_sub.initialize().map_err(micro_err)?;
        let first = read_frame(self.macro_sub.as_subsystem(), &all_macro, width, None)?;
        let ahead = match (o.coupling, o.interpolation) {
            (Coupling::OneWay, Interpolation::CubicHermite) => 2,
            _ => 1,
        };
        let h_m = o.macro_step.seconds();
        let table = SignalTable::new(&resolved, loads, h_m);
        self.set_initial_inputs(&first, &c, h_m)?;
        let mut micro_values = vec![0.0; micro_width];
        self.micro_sub.get_f64(&micro_outputs, &mut micro_values).map_err(micro_err)?;
        let mut coupling_values = vec![0.0; 2 * n + k];
        self.micro_sub.get_f64(&coupling_outputs, &mut coupling_values).map_err(micro_err)?;
        Ok(Prepared {
            per_macro,
            fractions,
            macro_steps,
            decimation,
            micro_inputs: c.micro_inputs,
            index: c.index,
            width_in: c.width_in,
            target_inputs: c.target_inputs,
            micro_outputs,
            coupling_outputs,
            loads,
            n,
            k,
            ecc_at: 0,
            rate_at: n,
            impulse_at: 2 * n,
            micro_width,
            all_macro,
            width,
            first,
            ahead,
            h_m,
            stats: MasterStats::default(),
            signals: vec![0.0; resolved.len()],
            table,
            micro_values,
            coupling_values,
        })
    }

    /// The micro inputs at the start (the first frame's values, no rate) before anything is
    /// read: a micro joint that starts where it holds its load (a bushing) settles there, so the
    /// first sample is already the settled one. (Each macro step sets them again.)
    fn set_initial_inputs(&mut self, first: &[f64], c: &Couplings, h_m: f64) -> Result<(), MasterError> {
        let w = Window { prev: None, a: first, b: first, next: None, h: h_m };
        let mut inputs = vec![0.0; c.width_in];
        let mut elements = c.index.elements.iter();
        for &(values, rates) in &c.index.layout {
            for e in 0..rates - values {
                let &(value, derivative) = elements.next().expect("one element per input value");
                inputs[values + e] = match derivative {
                    Some(d) => w.with_derivative(Interpolation::Linear, value, d, 0.0).0,
                    None => w.coupling(Interpolation::Linear, value, 0.0).0,
                };
            }
        }
        self.micro_sub.set_f64(&c.micro_inputs, &inputs).map_err(micro_err)
    }

    /// Initialises both subsystems and runs to the stop time. Each observer comes with its
    /// interval (a whole multiple of the micro step); all are called at the start time too.
    pub fn run(&mut self, observers: &mut [(&mut dyn Observer, Ticks)]) -> Result<MasterStats, MasterError> {
        let o = self.options;
        let p = self.prepare(observers)?;
        let macro_side = MacroSide { all: p.all_macro.clone(), width: p.width, steps: p.macro_steps };
        let mut s = Stepper::start(p, observers, o.start)?;
        let Self { macro_sub, micro_sub, .. } = self;
        let micro_sub = micro_sub.as_subsystem_mut();
        let mut run = |frames: &mut Frames<'_>| -> Result<(), MasterError> {
            for step in 0..s.p.macro_steps {
                let t_k = Ticks(o.start.0 + step as i64 * o.macro_step.0);
                // Two-way: save the macro at t_k and predict with the eccentricity extrapolated.
                let saved = match s.p.target_inputs {
                    Some(vrs) => Some((frames.save()?, vrs)),
                    None => None,
                };
                if saved.is_some() {
                    s.predict();
                }
                while let Some(t) = s.wants_frame(step, &o) {
                    let spare = s.take_spare();
                    let predicted = saved.as_ref().map(|(_, vrs)| (vrs, s.targets()));
                    let frame = frames.next(t, o.macro_step, predicted, spare)?;
                    s.push_frame(frame);
                }
                s.micro_interval(&o, micro_sub, observers, t_k)?;
                if let Some((saved, vrs)) = saved {
                    // Corrector: the macro steps again with the micro's eccentricities at t_k+1
                    // and its mean friction forces over the step.
                    frames.restore(&saved)?;
                    s.correct(micro_sub)?;
                    let frame = frames.next(t_k, o.macro_step, Some((&vrs, s.targets())), None)?;
                    s.replace_end(frame);
                }
                s.end_step();
            }
            Ok(())
        };
        // A subsystem that stops the run ends it cleanly: the observers keep what they have.
        let mut stopped = None;
        let mut run = |frames: &mut Frames<'_>| match run(frames) {
            Err(MasterError::Stopped { subsystem, reason }) => {
                stopped = Some((subsystem.to_string(), reason));
                Ok(())
            }
            other => other,
        };
        let macro_seconds = execute(&o, macro_sub.as_subsystem_mut(), macro_side, &mut run)?;
        let stats = s.stats();
        stats.macro_seconds = macro_seconds;
        stats.stopped = stopped;
        Ok(stats.clone())
    }
}

/// The macro outputs of a run as [`execute`] reads them, and its number of macro steps.
struct MacroSide {
    all: Vec<ValueReference>,
    width: usize,
    steps: usize,
}

/// Runs `run` over the macro frames of `sub`: produced on this thread as it asks for them
/// (sequential), or by a producer thread over a bounded channel (threaded, one-way). Returns the
/// wall time spent in macro steps.
fn execute(
    o: &MasterOptions,
    sub: &mut dyn Subsystem,
    m: MacroSide,
    run: &mut dyn FnMut(&mut Frames<'_>) -> Result<(), MasterError>,
) -> Result<f64, MasterError> {
    match o.execution {
        Execution::Sequential => {
            let mut frames = Frames::Local { sub, all: m.all, width: m.width, seconds: 0.0 };
            run(&mut frames)?;
            match frames {
                Frames::Local { seconds, .. } => Ok(seconds),
                Frames::Channel(_) => unreachable!("sequential frames are local"),
            }
        }
        Execution::Threaded => {
            let (tx, rx) = bounded::<Result<Vec<f64>, MasterError>>(8);
            let (origin, h) = (o.start, o.macro_step);
            let (result, macro_time) = std::thread::scope(|scope| {
                let producer = scope.spawn(move || {
                    let started = Instant::now();
                    for k in 0..m.steps {
                        let t = Ticks(origin.0 + k as i64 * h.0);
                        let frame = step_macro(sub, &m.all, m.width, t, h, None, None);
                        let failed = frame.is_err();
                        if tx.send(frame).is_err() || failed {
                            break;
                        }
                    }
                    started.elapsed()
                });
                let mut frames = Frames::Channel(rx);
                let r = run(&mut frames);
                drop(frames);
                (r, producer.join().unwrap_or(Duration::ZERO))
            });
            result?;
            Ok(macro_time.as_secs_f64())
        }
    }
}

/// How the micro subsystems (of type `Mi`) of runs stepped together are advanced: as
/// [`Subsystem::do_steps`] of each (same `t`, `h`, flags and outputs for all), row buffer by row
/// buffer — e.g. lash-micro's `do_steps_together`, which steps suitable ones in lanes.
pub type GroupStep<'f, Mi = dyn Subsystem> = dyn FnMut(&mut [&mut Mi], Ticks, Ticks, &[bool], &[ValueReference], &mut [&mut [f64]]) -> Vec<lash_core::Steps>
    + 'f;

impl<Ma: AsSubsystem + ?Sized, Mi: AsSubsystem + ?Sized> Algorithm for InterfaceMaster<'_, Ma, Mi> {
    fn signal_names(&self) -> Vec<String> {
        InterfaceMaster::signal_names(self)
    }

    fn run(&mut self, observers: &mut [(&mut dyn Observer, Ticks)]) -> Result<MasterStats, MasterError> {
        InterfaceMaster::run(self, observers)
    }
}
