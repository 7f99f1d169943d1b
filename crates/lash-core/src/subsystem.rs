//! The [`Subsystem`] trait: what the orchestrator, the FMI export layer and the FMU importer all
//! see of a model. It is shaped after FMI Co-Simulation (2.0 and 3.0):
//!
//! * variables described once ([`Variable`]: name, value reference, causality, variability, unit,
//!   shape, start value), addressed by value reference;
//! * a life cycle `setup → initialize → (set inputs, do_step, get outputs)* → terminate`;
//! * batched, typed get/set of `f64` values by value reference (arrays flattened row-major, as
//!   FMI 3.0 does; FMI 2.0 sees one scalar per element);
//! * `do_step(t, h)` in integer [`Ticks`], returning a [`StepOutcome`];
//! * save/restore of the complete state for rollback.
//!
//! No physics and no FFI here: the physics crates implement the trait, the FMI crate wraps it.

use crate::Ticks;
use std::any::Any;

/// A value reference: the handle of a variable (unique within one subsystem).
pub type ValueReference = u32;

/// How a variable takes part in the coupling (FMI causality).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Causality {
    /// Set before initialisation; constant during a run.
    Parameter,
    /// Set by the master between steps.
    Input,
    /// Read by the master between steps.
    Output,
    /// Internal quantity exposed for observation.
    Local,
    /// A parameter that sizes arrays (FMI 3.0 `structuralParameter`): set through
    /// [`Subsystem::configure`] before [`Subsystem::setup`].
    StructuralParameter,
}

/// How a variable changes in time (FMI variability).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Variability {
    /// Never changes after initialisation (structural parameters).
    Fixed,
    /// Changes only at communication points (discrete values, counters).
    Discrete,
    /// Changes continuously in time.
    Continuous,
}

/// The type of a variable's values (FMI 3.0's types; FMI 2.0's Real, Integer, Boolean, String and
/// Enumeration map to Float64, Int32, Boolean, String and Enumeration).
///
/// Numeric kinds (every kind but String, Binary and Clock) are read and written through
/// [`Subsystem::get_f64`] / [`Subsystem::set_f64`]: a value converts exactly to `f64` (integers up
/// to 2⁵³ in magnitude; a Boolean is 0 or 1; an Enumeration its integer), and a value written must
/// be representable in the kind ([`ValueKind::check`]). Strings go through
/// [`Subsystem::get_string`] / [`Subsystem::set_string`], bytes through [`Subsystem::get_binary`] /
/// [`Subsystem::set_binary`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize)]
pub enum ValueKind {
    /// 64-bit float (FMI 2.0 Real).
    #[default]
    Float64,
    /// 32-bit float.
    Float32,
    /// 8-bit signed integer.
    Int8,
    /// 8-bit unsigned integer.
    UInt8,
    /// 16-bit signed integer.
    Int16,
    /// 16-bit unsigned integer.
    UInt16,
    /// 32-bit signed integer (FMI 2.0 Integer).
    Int32,
    /// 32-bit unsigned integer.
    UInt32,
    /// 64-bit signed integer.
    Int64,
    /// 64-bit unsigned integer.
    UInt64,
    /// Boolean (0 or 1 as a number).
    Boolean,
    /// Enumeration (its integer value; FMI 2.0 32-bit, FMI 3.0 64-bit).
    Enumeration,
    /// Text.
    String,
    /// Bytes (FMI 3.0), through [`Subsystem::get_binary`] / [`Subsystem::set_binary`].
    Binary,
    /// Clock (FMI 3.0, scheduled or event mode): listed, not read or written.
    Clock,
}

impl ValueKind {
    /// True for the kinds read and written as numbers.
    pub fn is_numeric(self) -> bool {
        !matches!(self, ValueKind::String | ValueKind::Binary | ValueKind::Clock)
    }

    /// The FMI 3.0 name of the type.
    pub fn name(self) -> &'static str {
        match self {
            ValueKind::Float64 => "Float64",
            ValueKind::Float32 => "Float32",
            ValueKind::Int8 => "Int8",
            ValueKind::UInt8 => "UInt8",
            ValueKind::Int16 => "Int16",
            ValueKind::UInt16 => "UInt16",
            ValueKind::Int32 => "Int32",
            ValueKind::UInt32 => "UInt32",
            ValueKind::Int64 => "Int64",
            ValueKind::UInt64 => "UInt64",
            ValueKind::Boolean => "Boolean",
            ValueKind::Enumeration => "Enumeration",
            ValueKind::String => "String",
            ValueKind::Binary => "Binary",
            ValueKind::Clock => "Clock",
        }
    }

    /// The kind named `name` (FMI 3.0 type element, or FMI 2.0 type element with `fmi2 = true`).
    pub fn from_element(name: &str, fmi2: bool) -> Option<Self> {
        Some(match name {
            "Real" if fmi2 => ValueKind::Float64,
            "Integer" if fmi2 => ValueKind::Int32,
            "Float64" => ValueKind::Float64,
            "Float32" => ValueKind::Float32,
            "Int8" => ValueKind::Int8,
            "UInt8" => ValueKind::UInt8,
            "Int16" => ValueKind::Int16,
            "UInt16" => ValueKind::UInt16,
            "Int32" => ValueKind::Int32,
            "UInt32" => ValueKind::UInt32,
            "Int64" => ValueKind::Int64,
            "UInt64" => ValueKind::UInt64,
            "Boolean" => ValueKind::Boolean,
            "Enumeration" => ValueKind::Enumeration,
            "String" => ValueKind::String,
            "Binary" => ValueKind::Binary,
            "Clock" => ValueKind::Clock,
            _ => return None,
        })
    }

    /// Whether `v` can be written to a variable of this kind without loss: finite, and for
    /// integer kinds integral and in range (Booleans 0 or 1); the error says why not.
    pub fn check(self, v: f64) -> Result<(), ValueError> {
        let integral = |low: f64, high: f64| {
            if v.fract() != 0.0 || !(low..=high).contains(&v) {
                Err(ValueError::NotInteger { value: v, kind: self, low, high })
            } else {
                Ok(())
            }
        };
        match self {
            _ if v.is_nan() => Err(ValueError::NotANumber(self)),
            ValueKind::Float64 => Ok(()),
            ValueKind::Float32 if v.is_finite() && (v as f32).is_infinite() => Err(ValueError::OutOfFloat32(v)),
            ValueKind::Float32 => Ok(()),
            ValueKind::Int8 => integral(-128.0, 127.0),
            ValueKind::UInt8 => integral(0.0, 255.0),
            ValueKind::Int16 => integral(-32768.0, 32767.0),
            ValueKind::UInt16 => integral(0.0, 65535.0),
            ValueKind::Int32 => integral(-2147483648.0, 2147483647.0),
            ValueKind::UInt32 => integral(0.0, 4294967295.0),
            // Integers beyond 2⁵³ are not all representable in f64: the exact range is refused
            // beyond it rather than rounded silently.
            ValueKind::Int64 | ValueKind::Enumeration => integral(-9007199254740992.0, 9007199254740992.0),
            ValueKind::UInt64 => integral(0.0, 9007199254740992.0),
            ValueKind::Boolean if v == 0.0 || v == 1.0 => Ok(()),
            ValueKind::Boolean => Err(ValueError::NotBoolean(v)),
            ValueKind::String | ValueKind::Binary | ValueKind::Clock => Err(ValueError::NotNumeric(self)),
        }
    }
}

/// The description of one variable.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Variable {
    /// Name, dotted for structure (`effective_force`, `slider.ax.gain`).
    pub name: String,
    /// Its handle.
    pub value_reference: ValueReference,
    /// Causality.
    pub causality: Causality,
    /// Variability.
    pub variability: Variability,
    /// SI unit (`kg`, `N`, `m/s^2`, `1` for dimensionless).
    pub unit: String,
    /// One line of description.
    pub description: String,
    /// Array dimensions, empty for a scalar (`[2, 2]` for M̃). Values are flattened row-major.
    pub shape: Vec<usize>,
    /// Start value(s), one per element (numeric kinds).
    pub start: Vec<f64>,
    /// The type of its values.
    pub kind: ValueKind,
}

impl Variable {
    /// Number of `f64` elements (product of the shape, 1 for a scalar).
    pub fn len(&self) -> usize {
        self.shape.iter().product()
    }

    /// True for a zero-sized array.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The name of element `e` (row-major position) in lash's one element syntax, the FMI 2.0
    /// structured convention: 1-based indices in brackets, comma-separated (`m[1,2]` is row 1,
    /// column 2). A scalar's only element is the variable's own name. CSV columns, system files and
    /// SSP connectors all use these names, so FMI 2.0 `x[1]` and element 0 of an array `x` are the
    /// same name for the same value.
    pub fn element_name(&self, e: usize) -> String {
        if self.shape.is_empty() {
            return self.name.clone();
        }
        let mut rest = e;
        let mut index = vec![0; self.shape.len()];
        for (k, &d) in self.shape.iter().enumerate().rev() {
            index[k] = rest % d.max(1) + 1;
            rest /= d.max(1);
        }
        format!("{}[{}]", self.name, index.iter().map(usize::to_string).collect::<Vec<_>>().join(","))
    }

    /// The row-major position of the element spelled by 1-based `index` (see
    /// [`Variable::element_name`]), or `None` when the index does not fit the shape.
    pub fn element_position(&self, index: &[usize]) -> Option<usize> {
        if index.len() != self.shape.len() || index.is_empty() {
            return None;
        }
        index.iter().zip(&self.shape).try_fold(0, |at, (&i, &d)| (1..=d).contains(&i).then(|| at * d + i - 1))
    }
}

/// Splits an element name `base[i]` or `base[i,j,…]` (1-based indices, no spaces, no leading
/// zeros: the spelling [`Variable::element_name`] writes) into its base and indices; `None` for any
/// other name.
pub fn split_element_name(name: &str) -> Option<(&str, Vec<usize>)> {
    let (base, rest) = name.split_once('[')?;
    let inner = rest.strip_suffix(']')?;
    let index = inner
        .split(',')
        .map(|i| {
            let canonical = !i.is_empty() && i.bytes().all(|b| b.is_ascii_digit()) && !i.starts_with('0');
            canonical.then(|| i.parse::<usize>().ok()).flatten()
        })
        .collect::<Option<Vec<_>>>()?;
    (!base.is_empty()).then_some((base, index))
}

/// Declares a subsystem's fixed value references, numbered by their position from 0 (no number
/// written by hand), and `DECLARED`, the count (where variables of run-time number start). The
/// table is then built with [`VariableTable::add_at`], which names each variable next to its
/// constant and checks the order.
///
/// ```
/// mod vr {
///     lash_core::value_references! {
///         /// Input u.
///         INPUT,
///         /// Output y.
///         OUTPUT,
///     }
/// }
/// assert_eq!((vr::INPUT, vr::OUTPUT, vr::DECLARED), (0, 1, 2));
/// ```
#[macro_export]
macro_rules! value_references {
    ($($(#[$meta:meta])* $name:ident),* $(,)?) => {
        $crate::value_references!(@at 0; $($(#[$meta])* $name,)*);
    };
    (@at $n:expr; $(#[$meta:meta])* $name:ident, $($rest:tt)*) => {
        $(#[$meta])*
        pub const $name: $crate::ValueReference = $n;
        $crate::value_references!(@at $n + 1; $($rest)*);
    };
    (@at $n:expr;) => {
        /// The number of value references declared above (the first one free for the variables
        /// whose number is known at run time only).
        pub const DECLARED: $crate::ValueReference = $n;
    };
}

/// Builds the variable table of a subsystem, handing out value references in order.
#[derive(Debug, Default, Clone)]
pub struct VariableTable {
    variables: Vec<Variable>,
    /// The first [`VariableTable::add_at`] whose value reference was not the next one.
    misplaced: Option<VariableTableError>,
}

impl VariableTable {
    /// An empty table.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a variable and returns its value reference.
    #[allow(clippy::too_many_arguments)]
    pub fn add(
        &mut self,
        name: impl Into<String>,
        causality: Causality,
        variability: Variability,
        unit: &str,
        description: &str,
        shape: &[usize],
        start: &[f64],
    ) -> ValueReference {
        let vr = self.variables.len() as ValueReference;
        let len: usize = shape.iter().product();
        let start = if start.len() == len { start.to_vec() } else { vec![start.first().copied().unwrap_or(0.0); len] };
        self.variables.push(Variable {
            name: name.into(),
            value_reference: vr,
            causality,
            variability,
            unit: unit.to_string(),
            description: description.to_string(),
            shape: shape.to_vec(),
            start,
            kind: ValueKind::Float64,
        });
        vr
    }

    /// [`VariableTable::add`] for a variable declared with [`value_references!`]: `vr` must be the
    /// next value reference; a table built out of order is reported by
    /// [`VariableTable::into_checked_variables`].
    #[allow(clippy::too_many_arguments)]
    pub fn add_at(
        &mut self,
        vr: ValueReference,
        name: &str,
        causality: Causality,
        variability: Variability,
        unit: &str,
        description: &str,
        shape: &[usize],
        start: &[f64],
    ) {
        let given = self.add(name, causality, variability, unit, description, shape, start);
        if given != vr && self.misplaced.is_none() {
            self.misplaced = Some(VariableTableError::Misplaced { name: name.to_string(), declared: vr, added: given });
        }
    }

    /// The variables, or the first variable added out of its declared order (a defect of the
    /// subsystem's code, reported instead of a panic).
    pub fn into_checked_variables(self) -> Result<Vec<Variable>, VariableTableError> {
        match self.misplaced {
            Some(m) => Err(m),
            None => Ok(self.variables),
        }
    }

    /// The variables, in value-reference order.
    pub fn variables(&self) -> &[Variable] {
        &self.variables
    }

    /// Consumes the table.
    pub fn into_variables(self) -> Vec<Variable> {
        self.variables
    }
}

/// Looks a variable up by name.
pub fn find_variable<'a>(variables: &'a [Variable], name: &str) -> Option<&'a Variable> {
    variables.iter().find(|v| v.name == name)
}

/// How the macro and micro subsystems of the reduced interface model are coupled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Coupling {
    /// The ideal mechanism's motion is taken as the real one; f_c only feeds the sensors
    /// (the reduced-interface-model papers).
    #[default]
    OneWay,
    /// The impulse-averaged contact force acts back on the mechanism, which then runs without the
    /// clearance joint (needed when the motion is not prescribed, e.g. a torque-driven crank).
    TwoWay,
}

/// The interface coordinates prescribed to the macro mechanism across one communication step in
/// two-way coupling: each coordinate the cubic Hermite from (e, ė) at `start` to (e, ė) at
/// `start + span`, and the mean friction load of each joint over the step. One home for every
/// macro subsystem (planar and spatial) that moves its closed clearance joints by them.
#[derive(Debug, Clone, PartialEq)]
pub struct PrescribedInterface {
    /// The step's start \[s\].
    pub start: f64,
    /// The step's length \[s\].
    pub span: f64,
    /// e then ė at the start (n each).
    pub from: Vec<f64>,
    /// e then ė at the end (n each).
    pub to: Vec<f64>,
    /// Mean friction load of each joint over the step (planar: F_T \[N\]; spherical: n × F_T).
    pub friction: Vec<f64>,
}

impl PrescribedInterface {
    /// Interface coordinates n.
    pub fn coordinates(&self) -> usize {
        self.from.len() / 2
    }

    /// e, ė, ë of coordinate `i` at `t` (held at the ends outside the step).
    #[inline]
    pub fn at(&self, t: f64, i: usize) -> [f64; 3] {
        let n = self.coordinates();
        let h = self.span;
        let s = ((t - self.start) / h).clamp(0.0, 1.0);
        let (s2, s3) = (s * s, s * s * s);
        let (ea, va) = (self.from[i], self.from[n + i]);
        let (eb, vb) = (self.to[i], self.to[n + i]);
        let e = ea * (2.0 * s3 - 3.0 * s2 + 1.0)
            + va * (h * (s3 - 2.0 * s2 + s))
            + eb * (-2.0 * s3 + 3.0 * s2)
            + vb * (h * (s3 - s2));
        let v = (ea * (6.0 * s2 - 6.0 * s)
            + va * (h * (3.0 * s2 - 4.0 * s + 1.0))
            + eb * (-6.0 * s2 + 6.0 * s)
            + vb * (h * (3.0 * s2 - 2.0 * s)))
            / h;
        let a =
            (ea * (12.0 * s - 6.0) + va * (h * (6.0 * s - 4.0)) + eb * (-12.0 * s + 6.0) + vb * (h * (6.0 * s - 2.0)))
                / (h * h);
        [e, v, a]
    }
}

/// The two-way coupling inputs of a macro subsystem (`eccentricity`, `eccentricity_rate`,
/// `friction_force`, three consecutive value references) and the eccentricities the last step
/// ended on: what the master hands over for the next step and what the step starts from. One home
/// for every macro subsystem (planar and spatial).
#[derive(Debug, Clone, PartialEq)]
pub struct TwoWayInputs {
    /// The value reference of `eccentricity` (then `eccentricity_rate`, `friction_force`).
    first: ValueReference,
    /// e then ė at the current time (2n).
    current: Vec<f64>,
    /// e then ė at the end of the next step (2n), as set.
    target: Vec<f64>,
    /// The mean friction loads over the next step (m), as set.
    friction: Vec<f64>,
}

impl TwoWayInputs {
    /// Inputs for n interface coordinates and m friction loads, all zero (the joints centred),
    /// `eccentricity` at value reference `first`.
    pub fn new(first: ValueReference, coordinates: usize, friction_loads: usize) -> Self {
        let zeros = |n| vec![0.0; n];
        Self { first, current: zeros(2 * coordinates), target: zeros(2 * coordinates), friction: zeros(friction_loads) }
    }

    /// Whether `vr` is one of the three inputs.
    pub fn holds(&self, vr: ValueReference) -> bool {
        (self.first..=self.first + 2).contains(&vr)
    }

    /// The value of input `vr` as set (`None`: not an input).
    pub fn get(&self, vr: ValueReference) -> Option<&[f64]> {
        let n = self.current.len() / 2;
        match vr.checked_sub(self.first)? {
            0 => Some(&self.target[..n]),
            1 => Some(&self.target[n..]),
            2 => Some(&self.friction),
            _ => None,
        }
    }

    /// `set_f64` of the inputs: every reference must be one of them and every value finite
    /// (checked before anything is written).
    pub fn set(
        &mut self,
        variables: &[Variable],
        refs: &[ValueReference],
        values: &[f64],
    ) -> Result<(), SubsystemError> {
        let count = element_count(variables, refs)?;
        if count != values.len() {
            return Err(SubsystemError::BadArguments(format!("{} values for {} elements", values.len(), count)));
        }
        let mut at = 0;
        for &r in refs {
            let var = &variables[r as usize];
            let v = &values[at..at + var.len()];
            let problem = if !self.holds(r) {
                Some("is not an input".to_string())
            } else {
                v.iter().find(|x| !x.is_finite()).map(|bad| format!("{bad} is not finite"))
            };
            if let Some(problem) = problem {
                return Err(SubsystemError::BadValue { name: var.name.clone(), problem });
            }
            at += var.len();
        }
        let n = self.current.len() / 2;
        let mut at = 0;
        for &r in refs {
            let len = variables[r as usize].len();
            let v = &values[at..at + len];
            match r - self.first {
                0 => self.target[..n].copy_from_slice(v),
                1 => self.target[n..].copy_from_slice(v),
                _ => self.friction.copy_from_slice(v),
            }
            at += len;
        }
        Ok(())
    }

    /// The prescription of the step from `start` over `span`: from the current eccentricities to
    /// the targets, under the mean friction loads set.
    pub fn prescription(&self, start: f64, span: f64) -> PrescribedInterface {
        PrescribedInterface {
            start,
            span,
            from: self.current.clone(),
            to: self.target.clone(),
            friction: self.friction.clone(),
        }
    }

    /// The step ended: its targets are the current eccentricities.
    pub fn step_done(&mut self) {
        self.current.clone_from(&self.target);
    }
}

/// What a macro subsystem (the planar or the spatial mechanism around its clearance joints) is as
/// an FMI-shaped model, whatever its mechanics: its name, its variables and their values (every
/// output flattened in value-reference order), its clock and life-cycle phase, and its two-way
/// inputs. One home for the calls of [`Subsystem`] that do not depend on the mechanics.
#[derive(Debug, Clone)]
pub struct MacroPorts {
    name: String,
    variables: Vec<Variable>,
    /// Where each variable's values start in `values` (one past the last at the end).
    offsets: Vec<usize>,
    /// The outputs' values (the inputs' are kept in `two_way`).
    pub values: Vec<f64>,
    /// The communication point reached.
    pub time: Ticks,
    /// The life-cycle phase.
    pub phase: Phase,
    /// The two-way inputs and the eccentricities the last step ended on.
    pub two_way: TwoWayInputs,
}

impl MacroPorts {
    /// The ports of a subsystem `name` with `variables` (checked), their values zero, at time zero,
    /// instantiated.
    pub fn new(name: &str, variables: Vec<Variable>, two_way: TwoWayInputs) -> Self {
        let mut offsets = Vec::with_capacity(variables.len() + 1);
        let mut at = 0;
        for v in &variables {
            offsets.push(at);
            at += v.len();
        }
        offsets.push(at);
        Self {
            name: name.to_string(),
            variables,
            offsets,
            values: vec![0.0; at],
            time: Ticks::ZERO,
            phase: Phase::Instantiated,
            two_way,
        }
    }

    /// The subsystem's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The variables.
    pub fn variables(&self) -> &[Variable] {
        &self.variables
    }

    /// Each variable's offset in [`MacroPorts::values`] (one past the last at the end).
    pub fn offsets(&self) -> &[usize] {
        &self.offsets
    }

    /// The range of output `vr`'s values.
    #[inline]
    pub fn range(&self, vr: ValueReference) -> std::ops::Range<usize> {
        self.offsets[vr as usize]..self.offsets[vr as usize + 1]
    }

    /// The value of output `vr` (its elements).
    pub fn output(&self, vr: ValueReference) -> &[f64] {
        &self.values[self.range(vr)]
    }

    /// The values to write, with each variable's offset in them.
    pub fn values_and_offsets(&mut self) -> (&mut [f64], &[usize]) {
        (&mut self.values, &self.offsets)
    }

    /// [`Subsystem::setup`]: the clock starts at `start`.
    pub fn setup(&mut self, start: Ticks) -> Result<(), SubsystemError> {
        self.phase.require("setup", &[Phase::Instantiated])?;
        self.time = start;
        self.phase = Phase::Configured;
        Ok(())
    }

    /// [`Subsystem::set_f64`]: only the two-way inputs may be set.
    pub fn set_f64(&mut self, refs: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError> {
        self.phase.require("set_f64", &[Phase::Configured, Phase::Stepping])?;
        self.two_way.set(&self.variables, refs, values)
    }

    /// [`Subsystem::get_f64`]: the inputs as set, the outputs as last computed.
    pub fn get_f64(&self, refs: &[ValueReference], values: &mut [f64]) -> Result<(), SubsystemError> {
        let count = element_count(&self.variables, refs)?;
        if count != values.len() {
            return Err(SubsystemError::BadArguments(format!("{} values for {} elements", values.len(), count)));
        }
        let input = |r: ValueReference| self.two_way.holds(r);
        let (mut at, mut i) = (0, 0);
        while i < refs.len() {
            let r = refs[i];
            let v = match self.two_way.get(r) {
                Some(v) => v,
                None => {
                    // Consecutive outputs are one stretch of the values: one copy (a master
                    // reads every output at every step).
                    let mut last = i;
                    while last + 1 < refs.len() && refs[last + 1] == refs[last] + 1 && !input(refs[last + 1]) {
                        last += 1;
                    }
                    let stretch = &self.values[self.offsets[r as usize]..self.offsets[refs[last] as usize + 1]];
                    i = last;
                    stretch
                }
            };
            values[at..at + v.len()].copy_from_slice(v);
            at += v.len();
            i += 1;
        }
        Ok(())
    }

    /// The checks of [`Subsystem::do_step`]: stepping, from the time reached, forward.
    pub fn check_step(&self, t: Ticks, h: Ticks) -> Result<(), SubsystemError> {
        self.phase.require("do_step", &[Phase::Stepping])?;
        if t != self.time || h.0 <= 0 {
            return Err(SubsystemError::BadArguments(format!(
                "do_step(t = {} s, h = {} s) but the subsystem is at {} s",
                t.seconds(),
                h.seconds(),
                self.time.seconds()
            )));
        }
        Ok(())
    }

    /// A step from `t` over `h` ended (in error or not): the clock moves to its end, and a
    /// two-way step's targets become the current eccentricities.
    pub fn step_ended(&mut self, t: Ticks, h: Ticks, coupling: Coupling) {
        self.time = Ticks(t.0 + h.0);
        if coupling == Coupling::TwoWay {
            self.two_way.step_done();
        }
    }

    /// Every output finite, or the first that is not.
    pub fn check_finite(&self) -> Result<(), NonFiniteOutput> {
        match self.values.iter().position(|v| !v.is_finite()) {
            None => Ok(()),
            Some(bad) => {
                let name = self.variables[self.offsets.partition_point(|&o| o <= bad) - 1].name.clone();
                Err(NonFiniteOutput { name, value: self.values[bad] })
            }
        }
    }

    /// The subsystem failed at the time reached with `message`.
    pub fn fail(&mut self, message: String) -> SubsystemError {
        self.phase = Phase::Failed;
        SubsystemError::Simulation { t: self.time.seconds(), message }
    }

    /// What [`Subsystem::save_state`] keeps of the ports: the clock, the phase, the outputs and
    /// the two-way inputs.
    pub fn saved(&self) -> SavedPorts {
        SavedPorts { time: self.time, phase: self.phase, values: self.values.clone(), two_way: self.two_way.clone() }
    }

    /// [`Subsystem::restore_state`] of the ports (no allocation where the sizes agree).
    pub fn restore(&mut self, saved: &SavedPorts) {
        self.time = saved.time;
        self.phase = saved.phase;
        self.values.clone_from(&saved.values);
        self.two_way.clone_from(&saved.two_way);
    }
}

/// The ports' part of a macro subsystem's saved state ([`MacroPorts::saved`]).
#[derive(Debug, Clone)]
pub struct SavedPorts {
    time: Ticks,
    phase: Phase,
    values: Vec<f64>,
    two_way: TwoWayInputs,
}

/// The calls of [`Subsystem`] that a macro subsystem answers from its [`MacroPorts`] field
/// `ports` alone (`name`, `variables`, `setup`, `set_f64`, `get_f64`, `time`), written once for
/// the planar and the spatial mechanism: used inside their `impl Subsystem` blocks.
#[macro_export]
macro_rules! subsystem_calls_of_ports {
    () => {
        fn name(&self) -> &str {
            self.ports.name()
        }
        fn variables(&self) -> &[$crate::Variable] {
            self.ports.variables()
        }
        fn setup(&mut self, start: $crate::Ticks, _stop: Option<$crate::Ticks>) -> Result<(), $crate::SubsystemError> {
            self.ports.setup(start)
        }
        fn set_f64(&mut self, refs: &[$crate::ValueReference], values: &[f64]) -> Result<(), $crate::SubsystemError> {
            self.ports.set_f64(refs, values)
        }
        fn get_f64(&self, refs: &[$crate::ValueReference], values: &mut [f64]) -> Result<(), $crate::SubsystemError> {
            self.ports.get_f64(refs, values)
        }
        fn time(&self) -> $crate::Ticks {
            self.ports.time
        }
    };
}

/// An output of a subsystem that is not finite (NaN or infinite): its variable and value.
#[derive(Debug, Clone, thiserror::Error)]
#[error("output {name} became {value}")]
pub struct NonFiniteOutput {
    /// The variable's name.
    pub name: String,
    /// Its value.
    pub value: f64,
}

/// How a step ended. A master must look at every outcome: only [`StepOutcome::Completed`] means
/// that the subsystem reached `t + h` and may be stepped on; use [`StepOutcome::reached`] and
/// [`StepOutcome::stop`] rather than matching on `Completed` alone.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[must_use = "a step may end early or ask the simulation to stop: the master must honour it"]
pub enum StepOutcome {
    /// The whole step was taken.
    Completed,
    /// The subsystem stopped early at `reached` (for example at an event the master asked to
    /// see); FMI 3.0 `earlyReturn`. Its state is valid at `reached`.
    EarlyReturn {
        /// Time reached.
        reached: Ticks,
    },
    /// The subsystem asks the simulation to end (FMI 3.0 `terminateSimulation`, FMI 2.0
    /// `fmi2Discard` with `fmi2Terminated`). Its state is valid at `reached`; it must not be stepped
    /// again.
    Terminate {
        /// Time reached.
        reached: Ticks,
    },
}

impl StepOutcome {
    /// The time the subsystem reached, for a step from `t` of length `h`.
    pub fn reached(self, t: Ticks, h: Ticks) -> Ticks {
        match self {
            StepOutcome::Completed => Ticks(t.0 + h.0),
            StepOutcome::EarlyReturn { reached } | StepOutcome::Terminate { reached } => reached,
        }
    }

    /// `None` for a completed step, else why the master has to stop.
    pub fn stop(self, t: Ticks, h: Ticks) -> Option<StopReason> {
        match self {
            StepOutcome::Completed => None,
            StepOutcome::EarlyReturn { reached } if reached.0 >= t.0 + h.0 => None,
            StepOutcome::EarlyReturn { reached } => Some(StopReason::EarlyReturn { reached }),
            StepOutcome::Terminate { reached } => Some(StopReason::Requested { reached }),
        }
    }
}

/// Why a master ended a run before its stop time without an error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopReason {
    /// A subsystem asked the simulation to end at `reached`.
    Requested {
        /// Time the subsystem reached.
        reached: Ticks,
    },
    /// A subsystem returned early at `reached`, inside a communication step; lash's masters take
    /// no partial steps, so the run ends at the last communication point every element completed.
    EarlyReturn {
        /// Time the subsystem reached.
        reached: Ticks,
    },
}

impl std::fmt::Display for StopReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StopReason::Requested { reached } => {
                write!(f, "asked to stop the simulation at t = {} s", reached.seconds())
            }
            StopReason::EarlyReturn { reached } => write!(
                f,
                "returned early at t = {} s, inside a communication step (lash's masters take no partial steps)",
                reached.seconds()
            ),
        }
    }
}

/// Errors of a subsystem call. Messages name the variable or the quantity concerned.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SubsystemError {
    /// A value reference that the subsystem does not have.
    #[error("unknown value reference {0}")]
    UnknownValueReference(ValueReference),
    /// A value that cannot be accepted (causality, non-finite, out of range).
    #[error("variable {name}: {problem}")]
    BadValue {
        /// Variable name.
        name: String,
        /// What is wrong.
        problem: String,
    },
    /// Value and reference slices do not fit together.
    #[error("{0}")]
    BadArguments(String),
    /// A call out of the life-cycle order.
    #[error("{call} is not allowed in state {state}")]
    WrongState {
        /// The call made.
        call: &'static str,
        /// The state the subsystem is in.
        state: &'static str,
    },
    /// The simulation failed (a blow-up, a singular system), naming time and quantity.
    #[error("at t = {t} s: {message}")]
    Simulation {
        /// Time \[s\].
        t: f64,
        /// What happened.
        message: String,
    },
    /// Anything else (a loaded library's failure, an unsupported feature).
    #[error("{0}")]
    Other(String),
}

/// An opaque snapshot of a subsystem's complete state (FMI `FMUstate`).
pub struct SavedState(pub Box<dyn Any + Send>);

impl std::fmt::Debug for SavedState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SavedState(..)")
    }
}

/// A co-simulation subsystem (one FMU, one built-in model, one plugin).
///
/// Call order: [`setup`](Subsystem::setup) once, parameters set, [`initialize`](Subsystem::initialize),
/// then any number of `set_f64` / `do_step` / `get_f64`. Implementations must reject calls out of
/// order with [`SubsystemError::WrongState`] rather than panic.
pub trait Subsystem: Send {
    /// A short name for messages and traces.
    fn name(&self) -> &str;

    /// All variables. Contract: variable `i` has value reference `i` (positions and value
    /// references are one mapping; an importer renumbers a foreign model's references and
    /// translates them at its boundary). [`check_variable_table`] verifies it.
    fn variables(&self) -> &[Variable];

    /// Start time and optional stop time of the experiment (FMI `setupExperiment` /
    /// `enterInitializationMode` arguments). Parameters may be set after this call.
    fn setup(&mut self, start: Ticks, stop: Option<Ticks>) -> Result<(), SubsystemError>;

    /// Computes the initial state from parameters and inputs (FMI enter + exit initialisation mode).
    fn initialize(&mut self) -> Result<(), SubsystemError>;

    /// Sets values: `values` holds the elements of each referenced variable in turn.
    fn set_f64(&mut self, refs: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError>;

    /// Reads values: `values` receives the elements of each referenced variable in turn.
    fn get_f64(&self, refs: &[ValueReference], values: &mut [f64]) -> Result<(), SubsystemError>;

    /// Advances from `t` (must equal the subsystem's current time) by `h`.
    fn do_step(&mut self, t: Ticks, h: Ticks) -> Result<StepOutcome, SubsystemError>;

    /// Takes one step of `h` from `t` per element of `record`, one after the other, and after
    /// each step whose flag is set and that reached its end reads `refs` into the next row of
    /// `rows` (a row holds the elements of `refs`, as [`Subsystem::get_f64`] writes them). Stops
    /// after the first step that does not complete (an early return inside the step, a request
    /// to terminate) and at the first error. The provided version is exactly that loop of
    /// `do_step` and `get_f64` ([`steps_one_by_one`]); a subsystem may take the steps without a
    /// call each (the micro subsystem of the reduced model does: its steps are ~100 ns, so a
    /// master's call and read per step cost as much as the step).
    fn do_steps(&mut self, t: Ticks, h: Ticks, record: &[bool], refs: &[ValueReference], rows: &mut [f64]) -> Steps {
        steps_one_by_one(self, t, h, record, refs, rows)
    }

    /// The subsystem's current time.
    fn time(&self) -> Ticks;

    /// A snapshot of the complete state.
    fn save_state(&self) -> Result<SavedState, SubsystemError>;

    /// Returns to a snapshot taken from this subsystem.
    fn restore_state(&mut self, state: &SavedState) -> Result<(), SubsystemError>;

    /// Sets structural parameters (FMI 3.0 configuration mode), before [`Subsystem::setup`].
    /// Arrays sized by them change shape: read [`Subsystem::variables`] again afterwards.
    fn configure(&mut self, refs: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError> {
        let _ = values;
        Err(SubsystemError::Other(format!(
            "{}: value references {refs:?}: no structural parameters (nothing to configure)",
            self.name()
        )))
    }

    /// Reads a String variable.
    fn get_string(&self, vr: ValueReference) -> Result<String, SubsystemError> {
        Err(SubsystemError::Other(format!("{}: value reference {vr}: no String variables", self.name())))
    }

    /// Writes a String variable (a parameter before initialization, or an input).
    fn set_string(&mut self, vr: ValueReference, value: &str) -> Result<(), SubsystemError> {
        let _ = value;
        Err(SubsystemError::Other(format!("{}: value reference {vr}: no String variables", self.name())))
    }

    /// Reads a Binary variable (FMI 3.0).
    fn get_binary(&self, vr: ValueReference) -> Result<Vec<u8>, SubsystemError> {
        Err(SubsystemError::Other(format!("{}: value reference {vr}: no Binary variables", self.name())))
    }

    /// Writes a Binary variable (a parameter before initialization, or an input).
    fn set_binary(&mut self, vr: ValueReference, value: &[u8]) -> Result<(), SubsystemError> {
        let _ = value;
        Err(SubsystemError::Other(format!("{}: value reference {vr}: no Binary variables", self.name())))
    }

    /// Ends the run (FMI `terminate`).
    fn terminate(&mut self) -> Result<(), SubsystemError> {
        Ok(())
    }
}

/// A subsystem of a type known where it is made (`InterfaceSubsystem`) or chosen at run time
/// (`dyn Subsystem`), seen as `dyn Subsystem`: what lets the interface master hold its
/// subsystems by their own types — so that code stepping several of them together gets them
/// typed, with no downcast — while its own work goes through the trait's calls.
pub trait AsSubsystem: Subsystem {
    /// The subsystem behind the trait's calls.
    fn as_subsystem(&self) -> &dyn Subsystem;
    /// The same, mutable.
    fn as_subsystem_mut(&mut self) -> &mut dyn Subsystem;
}

impl<S: Subsystem> AsSubsystem for S {
    fn as_subsystem(&self) -> &dyn Subsystem {
        self
    }
    fn as_subsystem_mut(&mut self) -> &mut dyn Subsystem {
        self
    }
}

impl AsSubsystem for dyn Subsystem + '_ {
    fn as_subsystem(&self) -> &dyn Subsystem {
        self
    }
    fn as_subsystem_mut(&mut self) -> &mut dyn Subsystem {
        self
    }
}

/// A boxed subsystem is a subsystem (every call forwarded, the provided ones included): a model
/// chosen at run time — a planar or a spatial scenario's — behind one type.
impl<S: Subsystem + ?Sized> Subsystem for Box<S> {
    fn name(&self) -> &str {
        (**self).name()
    }
    fn variables(&self) -> &[Variable] {
        (**self).variables()
    }
    fn setup(&mut self, start: Ticks, stop: Option<Ticks>) -> Result<(), SubsystemError> {
        (**self).setup(start, stop)
    }
    fn initialize(&mut self) -> Result<(), SubsystemError> {
        (**self).initialize()
    }
    fn set_f64(&mut self, refs: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError> {
        (**self).set_f64(refs, values)
    }
    fn get_f64(&self, refs: &[ValueReference], values: &mut [f64]) -> Result<(), SubsystemError> {
        (**self).get_f64(refs, values)
    }
    fn do_step(&mut self, t: Ticks, h: Ticks) -> Result<StepOutcome, SubsystemError> {
        (**self).do_step(t, h)
    }
    fn do_steps(&mut self, t: Ticks, h: Ticks, record: &[bool], refs: &[ValueReference], rows: &mut [f64]) -> Steps {
        (**self).do_steps(t, h, record, refs, rows)
    }
    fn time(&self) -> Ticks {
        (**self).time()
    }
    fn save_state(&self) -> Result<SavedState, SubsystemError> {
        (**self).save_state()
    }
    fn restore_state(&mut self, state: &SavedState) -> Result<(), SubsystemError> {
        (**self).restore_state(state)
    }
    fn configure(&mut self, refs: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError> {
        (**self).configure(refs, values)
    }
    fn get_string(&self, vr: ValueReference) -> Result<String, SubsystemError> {
        (**self).get_string(vr)
    }
    fn set_string(&mut self, vr: ValueReference, value: &str) -> Result<(), SubsystemError> {
        (**self).set_string(vr, value)
    }
    fn get_binary(&self, vr: ValueReference) -> Result<Vec<u8>, SubsystemError> {
        (**self).get_binary(vr)
    }
    fn set_binary(&mut self, vr: ValueReference, value: &[u8]) -> Result<(), SubsystemError> {
        (**self).set_binary(vr, value)
    }
    fn terminate(&mut self) -> Result<(), SubsystemError> {
        (**self).terminate()
    }
}

/// What [`Subsystem::do_steps`] did.
#[derive(Debug)]
#[must_use = "the steps may have ended early, failed or asked the simulation to stop: the master must honour it"]
pub struct Steps {
    /// Steps taken: `do_step` calls that returned an outcome (a step that failed is not
    /// counted). All but the last of them completed; the last one's outcome is in `last`.
    pub taken: usize,
    /// The outcome of the last step taken (`Completed` when none was asked for), or the error that
    /// ended the calls after `taken` steps.
    pub last: Result<StepOutcome, SubsystemError>,
}

/// The rows that `record` asks for, and their width: checks that `rows` holds them.
pub fn recorded_rows(
    variables: &[Variable],
    record: &[bool],
    refs: &[ValueReference],
    rows: &[f64],
) -> Result<usize, SubsystemError> {
    let flagged = record.iter().filter(|&&r| r).count();
    if flagged == 0 {
        return Ok(0);
    }
    let width = element_count(variables, refs)?;
    if rows.len() < flagged * width {
        return Err(SubsystemError::BadArguments(format!(
            "{} values for {flagged} rows of {width} elements",
            rows.len()
        )));
    }
    Ok(width)
}

/// [`Subsystem::do_steps`] as a loop of [`Subsystem::do_step`] and [`Subsystem::get_f64`] (its
/// provided version, and the fallback of subsystems that take their steps faster only in some
/// configurations).
pub fn steps_one_by_one<S: Subsystem + ?Sized>(
    sub: &mut S,
    t: Ticks,
    h: Ticks,
    record: &[bool],
    refs: &[ValueReference],
    rows: &mut [f64],
) -> Steps {
    let width = match recorded_rows(sub.variables(), record, refs, rows) {
        Ok(w) => w,
        Err(e) => return Steps { taken: 0, last: Err(e) },
    };
    let mut at = t;
    let mut row = 0;
    let mut last = StepOutcome::Completed;
    for (i, &flag) in record.iter().enumerate() {
        last = match sub.do_step(at, h) {
            Ok(outcome) => outcome,
            Err(e) => return Steps { taken: i, last: Err(e) },
        };
        let end = Ticks(at.0 + h.0);
        if flag && last.reached(at, h).0 >= end.0 {
            if let Err(e) = sub.get_f64(refs, &mut rows[row * width..(row + 1) * width]) {
                return Steps { taken: i, last: Err(e) };
            }
            row += 1;
        }
        if last.stop(at, h).is_some() {
            return Steps { taken: i + 1, last: Ok(last) };
        }
        at = end;
    }
    Steps { taken: record.len(), last: Ok(last) }
}

/// Why a number cannot be written to a variable of a [`ValueKind`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ValueError {
    /// NaN for any kind.
    #[error("NaN is not a {}", .0.name())]
    NotANumber(ValueKind),
    /// A finite number beyond the Float32 range.
    #[error("{0} is out of the Float32 range")]
    OutOfFloat32(f64),
    /// Not an integer in the kind's range.
    #[error("{value} is not a valid {} (an integer in [{low}, {high}])", .kind.name())]
    NotInteger {
        /// The number given.
        value: f64,
        /// The variable's kind.
        kind: ValueKind,
        /// Smallest value of the kind.
        low: f64,
        /// Largest value of the kind.
        high: f64,
    },
    /// A Boolean other than 0 or 1.
    #[error("{0} is not a Boolean (0 or 1)")]
    NotBoolean(f64),
    /// A kind that takes no number (String, Binary, Clock).
    #[error("a {} variable takes no number", .0.name())]
    NotNumeric(ValueKind),
}

/// A variable table that breaks the [`Subsystem::variables`] contract (a defect of the subsystem's
/// code, reported instead of a panic).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum VariableTableError {
    /// A variable added at another position than the value reference it was declared with.
    #[error("variable {name:?} is declared as value reference {declared} but added as {added}")]
    Misplaced {
        /// The variable.
        name: String,
        /// Its declared value reference.
        declared: ValueReference,
        /// The position it was added at.
        added: ValueReference,
    },
    /// A value reference that is not the variable's position.
    #[error(
        "variable {name:?} at position {position} has value reference {value_reference} (a subsystem's value references must be its positions)"
    )]
    NotItsPosition {
        /// The variable.
        name: String,
        /// Its position in the table.
        position: usize,
        /// Its value reference.
        value_reference: ValueReference,
    },
    /// Two variables with one name.
    #[error("variable name {0:?} is used twice")]
    DuplicateName(String),
}

/// The variable with value reference `vr` (its position, by the [`Subsystem::variables`] contract).
pub fn variable(variables: &[Variable], vr: ValueReference) -> Option<&Variable> {
    variables.get(vr as usize).filter(|v| v.value_reference == vr)
}

/// Checks the [`Subsystem::variables`] contract (variable `i` has value reference `i`) and that
/// names are unique; the error names the first offending variable.
pub fn check_variable_table(variables: &[Variable]) -> Result<(), VariableTableError> {
    let mut names = std::collections::HashSet::with_capacity(variables.len());
    for (i, v) in variables.iter().enumerate() {
        if v.value_reference as usize != i {
            return Err(VariableTableError::NotItsPosition {
                name: v.name.clone(),
                position: i,
                value_reference: v.value_reference,
            });
        }
        if !names.insert(v.name.as_str()) {
            return Err(VariableTableError::DuplicateName(v.name.clone()));
        }
    }
    Ok(())
}

/// Writes a column-major matrix of `rows` rows (nalgebra's storage, `column_major`) into `out` in
/// row-major order, the layout of FMI array variables.
pub fn row_major(out: &mut [f64], column_major: &[f64], rows: usize) {
    let columns = column_major.len() / rows.max(1);
    for (i, o) in out.iter_mut().enumerate() {
        *o = column_major[i / columns + (i % columns) * rows];
    }
}

/// Shape of a quantity with one value of shape `inner` per clearance joint: `inner ++ [joints]`,
/// or `inner` alone for a single joint (so one joint's variables keep their plain shapes).
pub fn per_joint_shape(joints: usize, inner: &[usize]) -> Vec<usize> {
    let mut shape = inner.to_vec();
    if joints > 1 {
        shape.push(joints);
    }
    shape
}

/// Total element count of the referenced variables, checking each reference.
pub fn element_count(variables: &[Variable], refs: &[ValueReference]) -> Result<usize, SubsystemError> {
    refs.iter().try_fold(0, |n, &vr| {
        variable(variables, vr).map(|v| n + v.len()).ok_or(SubsystemError::UnknownValueReference(vr))
    })
}

/// The life-cycle states shared by lash's built-in subsystems.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Created, not set up.
    Instantiated,
    /// Set up, parameters may change.
    Configured,
    /// Initialised: stepping allowed.
    Stepping,
    /// A step failed; only save/restore, reading and termination are allowed.
    Failed,
    /// Terminated.
    Terminated,
}

impl Phase {
    /// Name for messages.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Instantiated => "instantiated",
            Phase::Configured => "configured",
            Phase::Stepping => "stepping",
            Phase::Failed => "failed",
            Phase::Terminated => "terminated",
        }
    }

    /// Ok if `self` is one of `allowed`, otherwise the WrongState error for `call`.
    pub fn require(self, call: &'static str, allowed: &[Phase]) -> Result<(), SubsystemError> {
        if allowed.contains(&self) { Ok(()) } else { Err(SubsystemError::WrongState { call, state: self.name() }) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_way_inputs_are_set_checked_read_back_and_prescribed_from_where_the_last_step_ended() {
        let mut t = VariableTable::new();
        t.add("out", Causality::Output, Variability::Continuous, "1", "", &[], &[0.0]);
        for name in ["eccentricity", "eccentricity_rate", "friction_force"] {
            t.add(name, Causality::Input, Variability::Continuous, "1", "", &[2], &[0.0; 2]);
        }
        let vars = t.into_checked_variables().unwrap();
        let mut inputs = TwoWayInputs::new(1, 2, 2);
        assert!(!inputs.holds(0) && inputs.holds(1) && inputs.holds(3) && !inputs.holds(4));
        assert_eq!(inputs.get(0), None);
        inputs.set(&vars, &[1, 3], &[1e-4, -2e-4, 5.0, 6.0]).unwrap();
        inputs.set(&vars, &[2], &[0.1, 0.2]).unwrap();
        assert_eq!(inputs.get(1), Some(&[1e-4, -2e-4][..]));
        assert_eq!(inputs.get(2), Some(&[0.1, 0.2][..]));
        assert_eq!(inputs.get(3), Some(&[5.0, 6.0][..]));
        // A non-input or a non-finite value is refused by name, and nothing is written.
        let refused = |r: Result<(), SubsystemError>, name: &str| {
            assert!(matches!(r, Err(SubsystemError::BadValue { name: ref n, .. }) if n == name), "{r:?}");
        };
        refused(inputs.set(&vars, &[3, 0], &[0.0, 0.0, 1.0]), "out");
        refused(inputs.set(&vars, &[1], &[f64::NAN, 0.0]), "eccentricity");
        assert_eq!(inputs.get(3), Some(&[5.0, 6.0][..]));
        assert!(matches!(inputs.set(&vars, &[1], &[0.0]), Err(SubsystemError::BadArguments(_))));
        // The first step starts centred; the next from where the first ended.
        let first = inputs.prescription(0.0, 1e-3);
        assert_eq!(
            (first.from, first.to.clone(), first.friction),
            (vec![0.0; 4], vec![1e-4, -2e-4, 0.1, 0.2], vec![5.0, 6.0])
        );
        inputs.step_done();
        assert_eq!(inputs.prescription(1e-3, 1e-3).from, first.to);
    }

    #[test]
    fn macro_ports_read_outputs_and_inputs_in_any_order_step_forward_only_and_name_a_bad_output() {
        let mut t = VariableTable::new();
        t.add("mass", Causality::Output, Variability::Continuous, "kg", "", &[2, 2], &[0.0]);
        t.add("force", Causality::Output, Variability::Continuous, "N", "", &[2], &[0.0]);
        for name in ["eccentricity", "eccentricity_rate", "friction_force"] {
            t.add(name, Causality::Input, Variability::Continuous, "1", "", &[2], &[0.0; 2]);
        }
        t.add("torque", Causality::Output, Variability::Continuous, "N m", "", &[], &[0.0]);
        let mut ports = MacroPorts::new("m", t.into_checked_variables().unwrap(), TwoWayInputs::new(2, 2, 2));
        assert_eq!(ports.offsets(), &[0, 4, 6, 8, 10, 12, 13]);
        ports.values.iter_mut().enumerate().for_each(|(i, v)| *v = i as f64);
        // Calls out of the life cycle's order are refused.
        assert!(ports.set_f64(&[2], &[1.0, 2.0]).is_err());
        ports.setup(Ticks(5)).unwrap();
        ports.set_f64(&[2], &[1.0, 2.0]).unwrap();
        assert!(matches!(ports.set_f64(&[0], &[0.0; 4]), Err(SubsystemError::BadValue { .. })));
        // Outputs in one stretch (0, 1), an input between them, an output after; any order.
        let mut out = [0.0; 9];
        ports.get_f64(&[0, 1, 2, 5], &mut out).unwrap();
        assert_eq!(out, [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 1.0, 2.0, 12.0]);
        let mut out = [0.0; 3];
        ports.get_f64(&[5, 1], &mut out).unwrap();
        assert_eq!(out, [12.0, 4.0, 5.0]);
        assert!(matches!(ports.get_f64(&[5, 1], &mut [0.0; 2]), Err(SubsystemError::BadArguments(_))));
        // Steps start where the last ended and go forward.
        assert!(matches!(ports.check_step(Ticks(5), Ticks(1)), Err(SubsystemError::WrongState { .. })));
        ports.phase = Phase::Stepping;
        ports.check_step(Ticks(5), Ticks(1)).unwrap();
        assert!(matches!(ports.check_step(Ticks(4), Ticks(1)), Err(SubsystemError::BadArguments(_))));
        assert!(matches!(ports.check_step(Ticks(5), Ticks(0)), Err(SubsystemError::BadArguments(_))));
        ports.step_ended(Ticks(5), Ticks(3), Coupling::TwoWay);
        assert_eq!(ports.time, Ticks(8));
        assert_eq!(ports.two_way.prescription(0.0, 1.0).from, vec![1.0, 2.0, 0.0, 0.0]);
        // A non-finite output is named with its value.
        ports.check_finite().unwrap();
        ports.values[5] = f64::NAN;
        let bad = ports.check_finite().expect_err("a NaN output");
        assert_eq!((bad.name.as_str(), bad.to_string().as_str()), ("force", "output force became NaN"));
        let e = ports.fail("it broke".into());
        assert_eq!(ports.phase, Phase::Failed);
        assert!(matches!(e, SubsystemError::Simulation { message, .. } if message == "it broke"));
    }

    #[test]
    fn a_prescribed_coordinate_meets_its_end_values_and_its_rates_are_its_derivatives() {
        // e from 1e-4 (rate 0.3) to −2e-4 (rate −0.1) over 1 ms from t = 0.5 s; a second
        // coordinate held at rest.
        let p = PrescribedInterface {
            start: 0.5,
            span: 1e-3,
            from: vec![1e-4, 0.0, 0.3, 0.0],
            to: vec![-2e-4, 0.0, -0.1, 0.0],
            friction: vec![],
        };
        assert_eq!(p.coordinates(), 2);
        let close = |a: f64, b: f64, scale: f64| (a - b).abs() <= 1e-9 * scale;
        let [e0, v0, _] = p.at(0.5, 0);
        let [e1, v1, _] = p.at(0.501, 0);
        assert!(close(e0, 1e-4, 1e-4) && close(v0, 0.3, 1.0), "start: {e0}, {v0}");
        assert!(close(e1, -2e-4, 1e-4) && close(v1, -0.1, 1.0), "end: {e1}, {v1}");
        assert_eq!(p.at(0.5004, 1), [0.0; 3]);
        // Central differences of e and ė against ė and ë inside the step (their rounding, about
        // 1e-16 × 0.5 s / 1e-7 s relative to the rates, sets the tolerance).
        let d = 1e-7;
        let close = |a: f64, b: f64, scale: f64| (a - b).abs() <= 1e-6 * scale;
        for t in [0.5002, 0.5005, 0.5008] {
            let ([ea, va, _], [eb, vb, _], [_, v, a]) = (p.at(t - d, 0), p.at(t + d, 0), p.at(t, 0));
            assert!(close((eb - ea) / (2.0 * d), v, 1.0), "ė at {t}: {} vs {v}", (eb - ea) / (2.0 * d));
            assert!(close((vb - va) / (2.0 * d), a, 1e3), "ë at {t}: {} vs {a}", (vb - va) / (2.0 * d));
        }
        // Held outside the step.
        assert_eq!(p.at(0.7, 0)[0], p.at(0.501, 0)[0]);
    }

    #[test]
    fn element_names_are_one_based_row_major_and_read_back() {
        let mut t = VariableTable::new();
        t.add("m", Causality::Output, Variability::Continuous, "1", "", &[2, 3], &[0.0; 6]);
        t.add("v", Causality::Output, Variability::Continuous, "1", "", &[4], &[0.0; 4]);
        t.add("s", Causality::Output, Variability::Continuous, "1", "", &[], &[0.0]);
        let vars = t.into_checked_variables().unwrap();
        let names: Vec<String> = (0..6).map(|e| vars[0].element_name(e)).collect();
        assert_eq!(names, ["m[1,1]", "m[1,2]", "m[1,3]", "m[2,1]", "m[2,2]", "m[2,3]"]);
        assert_eq!((vars[1].element_name(0), vars[1].element_name(3)), ("v[1]".into(), "v[4]".into()));
        assert_eq!(vars[2].element_name(0), "s");
        for (v, n) in [(&vars[0], 6), (&vars[1], 4)] {
            for e in 0..n {
                let name = v.element_name(e);
                let (base, index) = split_element_name(&name).unwrap();
                assert_eq!((base, v.element_position(&index)), (v.name.as_str(), Some(e)), "{name}");
            }
        }
        assert_eq!(vars[0].element_position(&[3, 1]), None, "row 3 of 2");
        assert_eq!(vars[0].element_position(&[0, 1]), None, "1-based");
        assert_eq!(vars[1].element_position(&[1, 1]), None, "two indices for a vector");
        for odd in ["x[0]", "x[01]", "x[1, 2]", "x[]", "[1]", "x[1]y", "x", "x[a]"] {
            assert_eq!(split_element_name(odd), None, "{odd}: not the one element spelling");
        }
    }

    #[test]
    fn a_variable_added_out_of_its_declared_order_is_reported() {
        mod declared {
            crate::value_references! {
                /// First.
                FIRST,
                /// Second.
                SECOND,
            }
        }
        let mut t = VariableTable::new();
        t.add_at(declared::FIRST, "first", Causality::Output, Variability::Continuous, "1", "", &[], &[0.0]);
        t.add_at(declared::SECOND, "second", Causality::Output, Variability::Continuous, "1", "", &[], &[0.0]);
        assert_eq!(t.into_checked_variables().map(|v| v.len()), Ok(2));
        let mut t = VariableTable::new();
        t.add_at(declared::SECOND, "second", Causality::Output, Variability::Continuous, "1", "", &[], &[0.0]);
        let e = t.into_checked_variables().unwrap_err();
        assert_eq!(e, VariableTableError::Misplaced { name: "second".into(), declared: 1, added: 0 });
        assert!(e.to_string().contains("\"second\" is declared as value reference 1 but added as 0"), "{e}");
        assert_eq!(declared::DECLARED, 2);
    }

    #[test]
    fn table_hands_out_references_in_order_and_sizes_arrays() {
        let mut t = VariableTable::new();
        let a = t.add("effective_mass", Causality::Output, Variability::Continuous, "kg", "M", &[2, 2], &[0.0]);
        let b = t.add("effective_force", Causality::Output, Variability::Continuous, "N", "f", &[2], &[1.0, 2.0]);
        assert_eq!((a, b), (0, 1));
        assert_eq!(t.variables()[0].len(), 4);
        assert_eq!(t.variables()[0].start, vec![0.0; 4]);
        assert_eq!(t.variables()[1].start, vec![1.0, 2.0]);
        assert_eq!(element_count(t.variables(), &[1, 0, 1]).unwrap(), 8);
        assert_eq!(element_count(t.variables(), &[2]), Err(SubsystemError::UnknownValueReference(2)));
        assert_eq!(find_variable(t.variables(), "effective_force").unwrap().value_reference, 1);
    }

    #[test]
    fn value_kinds_accept_exactly_the_values_they_can_hold() {
        use ValueKind::*;
        for (kind, ok, bad) in [
            (Int8, [-128.0, 127.0], [128.0, 0.5]),
            (UInt8, [0.0, 255.0], [-1.0, 256.0]),
            (Int16, [-32768.0, 32767.0], [32768.0, 1.25]),
            (UInt16, [0.0, 65535.0], [65536.0, -0.5]),
            (Int32, [-2147483648.0, 2147483647.0], [2147483648.0, 1e10]),
            (UInt32, [0.0, 4294967295.0], [4294967296.0, -1.0]),
            (Int64, [-9007199254740992.0, 9007199254740992.0], [1e16, f64::INFINITY]),
            (UInt64, [0.0, 9007199254740992.0], [-1.0, 1e300]),
            (Boolean, [0.0, 1.0], [2.0, 0.5]),
            (Enumeration, [1.0, -3.0], [1.5, f64::NAN]),
            (Float32, [1e38, -1e-30], [1e39, f64::NAN]),
        ] {
            for v in ok {
                assert!(kind.check(v).is_ok(), "{kind:?} refused {v}");
            }
            for v in bad {
                assert!(kind.check(v).is_err(), "{kind:?} accepted {v}");
            }
        }
        assert!(Float64.check(f64::INFINITY).is_ok() && Float64.check(f64::NAN).is_err());
        assert!(String.check(0.0).is_err() && !String.is_numeric() && Boolean.is_numeric());
        assert_eq!(ValueKind::from_element("Integer", true), Some(Int32));
        assert_eq!(ValueKind::from_element("Integer", false), None);
        assert_eq!(ValueKind::from_element("UInt16", false), Some(UInt16));
    }

    #[test]
    fn phases_refuse_calls_out_of_order() {
        assert!(Phase::Stepping.require("do_step", &[Phase::Stepping]).is_ok());
        let e = Phase::Configured.require("do_step", &[Phase::Stepping]).unwrap_err();
        assert_eq!(e.to_string(), "do_step is not allowed in state configured");
    }
}
