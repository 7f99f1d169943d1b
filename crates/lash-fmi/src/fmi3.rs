//! The generic FMI 3.0 co-simulation export of any [`Subsystem`].
//!
//! Layers (after rust-fmi, with panics caught): the [`Exportable`] trait a model implements (safe
//! Rust); generic functions here that check every pointer, the instance's life-cycle state and the
//! arguments, catch panics, and map `Result` to an `fmi3Status` with a message through the
//! importer's logger; and the [`export_fmi3!`](crate::export_fmi3) macro, which writes the
//! `extern "C"` symbols of `fmi3Functions.h` as one-line forwards in the FMU's cdylib. Functions
//! outside co-simulation without event mode (model exchange, scheduled execution, clocks,
//! directional derivatives, serialisation) are present and return `fmi3Error` with a message.

use crate::description::{ModelInfo, time_value_reference};
use lash_core::{SavedState, StepOutcome, Subsystem, Ticks, ValueReference};
use std::ffi::{CStr, CString, c_char, c_void};
use std::panic::{AssertUnwindSafe, catch_unwind};

/// `fmi3Status`.
pub type Status = i32;
/// `fmi3OK`.
pub const OK: Status = 0;
/// `fmi3Warning`.
pub const WARNING: Status = 1;
/// `fmi3Discard`.
pub const DISCARD: Status = 2;
/// `fmi3Error`.
pub const ERROR: Status = 3;
/// `fmi3Fatal`.
pub const FATAL: Status = 4;

/// `fmi3LogMessageCallback`: (instanceEnvironment, status, category, message).
pub type LogMessage = Option<unsafe extern "C" fn(*mut c_void, Status, *const c_char, *const c_char)>;

/// `fmi2CallbackLogger`: (componentEnvironment, instanceName, status, category, message, ...).
pub type Fmi2Logger = unsafe extern "C" fn(*mut c_void, *const c_char, Status, *const c_char, *const c_char, ...);

/// The importer's logger, FMI 3.0 or FMI 2.0 style.
#[derive(Clone, Copy)]
pub enum Logger {
    /// No logger.
    None,
    /// FMI 3.0 `logMessage`.
    Fmi3(unsafe extern "C" fn(*mut c_void, Status, *const c_char, *const c_char)),
    /// FMI 2.0 `logger` (printf-style: the message is passed through "%s").
    Fmi2(Fmi2Logger),
}

impl Logger {
    /// Sends one message.
    ///
    /// # Safety
    /// The callback and `environment` must be what the importer gave at instantiation.
    pub(crate) unsafe fn send(
        &self,
        environment: *mut c_void,
        name: &CStr,
        status: Status,
        category: &str,
        text: &str,
    ) {
        let text = CString::new(format!("{}: {text}", name.to_string_lossy()))
            .unwrap_or_else(|_| c"(message with a NUL byte)".into());
        let category = CString::new(category).unwrap_or_default();
        match *self {
            Logger::None => {}
            // SAFETY: per the contract above.
            Logger::Fmi3(log) => unsafe { log(environment, status, category.as_ptr(), text.as_ptr()) },
            // SAFETY: per the contract above; "%s" keeps any '%' in the text literal.
            Logger::Fmi2(log) => unsafe {
                log(environment, name.as_ptr(), status, category.as_ptr(), c"%s".as_ptr(), text.as_ptr())
            },
        }
    }
}

/// A model that can be exported as an FMU: implemented by a marker type in the FMU crate.
pub trait Exportable: 'static {
    /// The subsystem behind the FMU.
    type Model: Subsystem;
    /// Model name, identifier, token, description, default experiment of `model`, an instance
    /// created from the same `resources` (a generic binary takes its identity from the model its
    /// resources describe).
    fn info(resources: Option<&std::path::Path>, model: &Self::Model) -> Result<ModelInfo, ExportError>;
    /// A fresh instance (the FMU's resources folder, if the importer gave one).
    fn create(resources: Option<&std::path::Path>) -> Result<Self::Model, ExportError>;
}

/// Why an exported model could not be made: the model's own error, with its causes (logged
/// through the importer's callback as `error: cause: …`).
pub type ExportError = Box<dyn std::error::Error + Send + Sync>;

/// Life-cycle state of an instance (FMI 3.0 co-simulation state machine, without event mode).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// After instantiation.
    Instantiated,
    /// Between enter and exit of initialisation mode.
    Initialization,
    /// Stepping.
    Step,
    /// After fmi3Terminate.
    Terminated,
    /// After an error: only get, reset, free, and state restore are allowed.
    Failed,
}

/// An FMU instance: the model, the importer's logger and the life-cycle state.
pub struct Instance<M: Exportable> {
    pub(crate) model: M::Model,
    name: CString,
    environment: *mut c_void,
    log: Logger,
    logging_on: bool,
    pub(crate) mode: Mode,
    resources: Option<std::path::PathBuf>,
    time_reference: ValueReference,
    start: Option<(Ticks, Option<Ticks>)>,
    /// Values set before initialisation mode, applied when the subsystem is set up.
    pub(crate) pending: Vec<(ValueReference, Vec<f64>)>,
    /// FMI 2.0 scalar value reference → (variable, element).
    pub(crate) scalars: Vec<(ValueReference, usize)>,
    /// FMI 2.0 setupExperiment: (start, stop).
    pub(crate) experiment: (f64, Option<f64>),
}

impl<M: Exportable> Instance<M> {
    fn message(&self, status: Status, category: &str, text: &str) {
        if status == OK && !self.logging_on {
            return;
        }
        // SAFETY: the importer promised a valid callback and environment at instantiation.
        unsafe { self.log.send(self.environment, &self.name, status, category, text) };
    }

    pub(crate) fn fail(&mut self, text: &str) -> Status {
        self.message(ERROR, "logStatusError", text);
        ERROR
    }

    pub(crate) fn require(&mut self, call: &str, allowed: &[Mode]) -> Result<(), Status> {
        if allowed.contains(&self.mode) {
            Ok(())
        } else {
            let mode = self.mode;
            Err(self.fail(&format!("{call} is not allowed in state {mode:?}")))
        }
    }
}

/// Runs `f` on the instance behind `instance`, catching panics and null pointers.
///
/// # Safety
/// `instance` must be null or a pointer returned by [`instantiate`] for the same `M` and not yet
/// freed.
pub unsafe fn with_instance<M: Exportable>(
    instance: *mut c_void,
    call: &str,
    f: impl FnOnce(&mut Instance<M>) -> Status,
) -> Status {
    if instance.is_null() {
        return ERROR;
    }
    // SAFETY: per the contract above.
    let inst = unsafe { &mut *(instance as *mut Instance<M>) };
    match catch_unwind(AssertUnwindSafe(|| f(&mut *inst))) {
        Ok(status) => status,
        Err(panic) => {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            inst.mode = Mode::Failed;
            inst.message(FATAL, "logStatusFatal", &format!("{call} panicked: {what}"));
            FATAL
        }
    }
}

/// Reads an optional C string.
///
/// # Safety
/// `s` must be null or point to a NUL-terminated string.
pub(crate) unsafe fn string(s: *const c_char) -> Option<String> {
    // SAFETY: per the contract above.
    (!s.is_null()).then(|| unsafe { CStr::from_ptr(s) }.to_string_lossy().into_owned())
}

/// A `file://` URI or a plain path to the resources folder.
fn resources_path(uri: &str) -> std::path::PathBuf {
    let p = uri.strip_prefix("file://").unwrap_or(uri);
    let p = if p.starts_with("//") { &p[1..] } else { p };
    std::path::PathBuf::from(p)
}

/// `fmi3InstantiateCoSimulation`.
///
/// # Safety
/// String arguments must be null or NUL-terminated; `log` must be null or a valid callback usable
/// with `environment` for the instance's lifetime.
#[allow(clippy::too_many_arguments)]
pub unsafe fn instantiate<M: Exportable>(
    name: *const c_char,
    token: *const c_char,
    resource_path: *const c_char,
    logging_on: bool,
    event_mode_used: bool,
    environment: *mut c_void,
    log: LogMessage,
) -> *mut c_void {
    let logger = log.map_or(Logger::None, Logger::Fmi3);
    // SAFETY: forwarded.
    unsafe { create_instance::<M>(name, token, resource_path, logging_on, event_mode_used, environment, logger) }
}

/// Instantiation shared by FMI 3.0 and FMI 2.0: checks the token, creates the model.
///
/// # Safety
/// String arguments must be null or NUL-terminated; `logger` must be usable with `environment`.
pub(crate) unsafe fn create_instance<M: Exportable>(
    name: *const c_char,
    token: *const c_char,
    resource_path: *const c_char,
    logging_on: bool,
    event_mode_used: bool,
    environment: *mut c_void,
    logger: Logger,
) -> *mut c_void {
    let result = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: forwarded from this function's contract.
        let (name, token, resources) = unsafe { (string(name), string(token), string(resource_path)) };
        let name = CString::new(name.unwrap_or_else(|| "lash".into())).unwrap_or_default();
        let resources = resources.filter(|r| !r.is_empty()).map(|r| resources_path(&r));
        // SAFETY: forwarded from this function's contract.
        let say = |text: String| unsafe { logger.send(environment, &name, ERROR, "logStatusError", &text) };
        if event_mode_used {
            say("event mode is not supported (hasEventMode=\"false\")".into());
            return std::ptr::null_mut();
        }
        let created = M::create(resources.as_deref())
            .and_then(|model| M::info(resources.as_deref(), &model).map(|info| (model, info)));
        match created {
            Err(e) => {
                say(format!("instantiation failed: {}", lash_core::error_chain(&*e)));
                std::ptr::null_mut()
            }
            Ok((_, info)) if token.as_deref() != Some(info.instantiation_token.as_str()) => {
                say(format!(
                    "wrong instantiation token {:?}: this binary with these resources is {} (modelDescription.xml \
                     and binary or resources do not match)",
                    token, info.instantiation_token
                ));
                std::ptr::null_mut()
            }
            Ok((model, _)) => {
                let time_reference = time_value_reference(model.variables());
                let scalars =
                    model.variables().iter().flat_map(|v| (0..v.len()).map(move |e| (v.value_reference, e))).collect();
                Box::into_raw(Box::new(Instance::<M> {
                    model,
                    name,
                    environment,
                    log: logger,
                    logging_on,
                    mode: Mode::Instantiated,
                    resources,
                    time_reference,
                    start: None,
                    pending: Vec::new(),
                    scalars,
                    experiment: (0.0, None),
                })) as *mut c_void
            }
        }
    }));
    result.unwrap_or(std::ptr::null_mut())
}

/// `fmi3FreeInstance`.
///
/// # Safety
/// `instance` must be null or a live pointer from [`instantiate`] for `M`; it is invalid afterwards.
pub unsafe fn free_instance<M: Exportable>(instance: *mut c_void) {
    if instance.is_null() {
        return;
    }
    let _ = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: per the contract above; the box was created by `instantiate`.
        drop(unsafe { Box::from_raw(instance as *mut Instance<M>) });
    }));
}

/// `fmi3EnterInitializationMode`.
///
/// # Safety
/// As [`with_instance`].
pub unsafe fn enter_initialization_mode<M: Exportable>(
    instance: *mut c_void,
    start_time: f64,
    stop_time_defined: bool,
    stop_time: f64,
) -> Status {
    let body = |inst: &mut Instance<M>| {
        if let Err(s) = inst.require("fmi3EnterInitializationMode", &[Mode::Instantiated]) {
            return s;
        }
        let start = match Ticks::from_seconds(start_time) {
            Ok(t) => t,
            Err(e) => return inst.fail(&format!("startTime: {e}")),
        };
        let stop = if stop_time_defined {
            match Ticks::from_seconds(stop_time) {
                Ok(t) if t >= start => Some(t),
                Ok(_) => return inst.fail("stopTime must not be before startTime"),
                Err(e) => return inst.fail(&format!("stopTime: {e}")),
            }
        } else {
            None
        };
        if let Err(e) = inst.model.setup(start, stop) {
            return inst.fail(&e.to_string());
        }
        for (vr, values) in std::mem::take(&mut inst.pending) {
            if let Err(e) = inst.model.set_f64(&[vr], &values) {
                return inst.fail(&format!("value set before initialisation: {e}"));
            }
        }
        inst.start = Some((start, stop));
        inst.mode = Mode::Initialization;
        OK
    };
    // SAFETY: forwarded.
    unsafe { with_instance::<M>(instance, "fmi3EnterInitializationMode", body) }
}

/// `fmi3ExitInitializationMode`.
///
/// # Safety
/// As [`with_instance`].
pub unsafe fn exit_initialization_mode<M: Exportable>(instance: *mut c_void) -> Status {
    let body = |inst: &mut Instance<M>| {
        if let Err(s) = inst.require("fmi3ExitInitializationMode", &[Mode::Initialization]) {
            return s;
        }
        match inst.model.initialize() {
            Ok(()) => {
                inst.mode = Mode::Step;
                OK
            }
            Err(e) => {
                inst.mode = Mode::Failed;
                inst.fail(&e.to_string())
            }
        }
    };
    // SAFETY: forwarded.
    unsafe { with_instance::<M>(instance, "fmi3ExitInitializationMode", body) }
}

/// `fmi3EnterStepMode` (only meaningful with event mode; accepted in step mode).
///
/// # Safety
/// As [`with_instance`].
pub unsafe fn enter_step_mode<M: Exportable>(instance: *mut c_void) -> Status {
    let body = |inst: &mut Instance<M>| inst.require("fmi3EnterStepMode", &[Mode::Step]).err().unwrap_or(OK);
    // SAFETY: forwarded.
    unsafe { with_instance::<M>(instance, "fmi3EnterStepMode", body) }
}

/// `fmi3Terminate`.
///
/// # Safety
/// As [`with_instance`].
pub unsafe fn terminate<M: Exportable>(instance: *mut c_void) -> Status {
    let body = |inst: &mut Instance<M>| {
        if let Err(s) = inst.require("fmi3Terminate", &[Mode::Step, Mode::Failed]) {
            return s;
        }
        let r = inst.model.terminate();
        inst.mode = Mode::Terminated;
        r.err().map_or(OK, |e| inst.fail(&e.to_string()))
    };
    // SAFETY: forwarded.
    unsafe { with_instance::<M>(instance, "fmi3Terminate", body) }
}

/// `fmi3Reset`: a fresh model, back to the instantiated state.
///
/// # Safety
/// As [`with_instance`].
pub unsafe fn reset<M: Exportable>(instance: *mut c_void) -> Status {
    let body = |inst: &mut Instance<M>| match M::create(inst.resources.as_deref()) {
        Ok(model) => {
            inst.model = model;
            inst.mode = Mode::Instantiated;
            inst.start = None;
            inst.pending.clear();
            OK
        }
        Err(e) => inst.fail(&format!("reset failed: {}", lash_core::error_chain(&*e))),
    };
    // SAFETY: forwarded.
    unsafe { with_instance::<M>(instance, "fmi3Reset", body) }
}

/// Checks a (pointer, length) pair and makes a slice; an empty length accepts a null pointer.
///
/// # Safety
/// A non-null `ptr` must point to `len` valid elements.
pub(crate) unsafe fn slice<'a, T>(ptr: *const T, len: usize) -> Option<&'a [T]> {
    if len == 0 {
        Some(&[])
    } else if ptr.is_null() {
        None
    } else {
        // SAFETY: per the contract above.
        Some(unsafe { std::slice::from_raw_parts(ptr, len) })
    }
}

/// As [`slice`], mutable.
///
/// # Safety
/// A non-null `ptr` must point to `len` valid, writable elements.
pub(crate) unsafe fn slice_mut<'a, T>(ptr: *mut T, len: usize) -> Option<&'a mut [T]> {
    if len == 0 {
        Some(&mut [])
    } else if ptr.is_null() {
        None
    } else {
        // SAFETY: per the contract above.
        Some(unsafe { std::slice::from_raw_parts_mut(ptr, len) })
    }
}

/// `fmi3GetFloat64`.
///
/// # Safety
/// As [`with_instance`]; `vrs` must hold `nvr` references and `values` `n_values` writable values.
pub unsafe fn get_float64<M: Exportable>(
    instance: *mut c_void,
    vrs: *const ValueReference,
    nvr: usize,
    values: *mut f64,
    n_values: usize,
) -> Status {
    let body = |inst: &mut Instance<M>| {
        if let Err(s) =
            inst.require("fmi3GetFloat64", &[Mode::Initialization, Mode::Step, Mode::Failed, Mode::Terminated])
        {
            return s;
        }
        // SAFETY: the caller's contract on (vrs, nvr) and (values, n_values).
        let (Some(vrs), Some(values)) = (unsafe { slice(vrs, nvr) }, unsafe { slice_mut(values, n_values) }) else {
            return inst.fail("fmi3GetFloat64: null valueReferences or values");
        };
        if !vrs.contains(&inst.time_reference) {
            // The common case in one call: the subsystem checks references and counts.
            return match inst.model.get_f64(vrs, values) {
                Ok(()) => OK,
                Err(e) => inst.fail(&format!("fmi3GetFloat64: {e}")),
            };
        }
        let mut at = 0;
        for &vr in vrs {
            let len = if vr == inst.time_reference {
                1
            } else {
                match inst.model.variables().get(vr as usize) {
                    Some(v) => v.len(),
                    None => return inst.fail(&format!("fmi3GetFloat64: unknown value reference {vr}")),
                }
            };
            let Some(out) = values.get_mut(at..at + len) else {
                return inst.fail(&format!("fmi3GetFloat64: nValues = {n_values} is too small"));
            };
            if vr == inst.time_reference {
                out[0] = inst.model.time().seconds();
            } else if let Err(e) = inst.model.get_f64(&[vr], out) {
                return inst.fail(&format!("fmi3GetFloat64: {e}"));
            }
            at += len;
        }
        if at != n_values {
            return inst.fail(&format!("fmi3GetFloat64: nValues = {n_values}, the references have {at}"));
        }
        OK
    };
    // SAFETY: forwarded.
    unsafe { with_instance::<M>(instance, "fmi3GetFloat64", body) }
}

/// `fmi3SetFloat64`.
///
/// # Safety
/// As [`with_instance`]; `vrs` must hold `nvr` references and `values` `n_values` values.
pub unsafe fn set_float64<M: Exportable>(
    instance: *mut c_void,
    vrs: *const ValueReference,
    nvr: usize,
    values: *const f64,
    n_values: usize,
) -> Status {
    let body = |inst: &mut Instance<M>| {
        if let Err(s) = inst.require("fmi3SetFloat64", &[Mode::Instantiated, Mode::Initialization, Mode::Step]) {
            return s;
        }
        // SAFETY: the caller's contract on (vrs, nvr) and (values, n_values).
        let (Some(vrs), Some(values)) = (unsafe { slice(vrs, nvr) }, unsafe { slice(values, n_values) }) else {
            return inst.fail("fmi3SetFloat64: null valueReferences or values");
        };
        if vrs.contains(&inst.time_reference) {
            return inst.fail("fmi3SetFloat64: time is the independent variable and cannot be set");
        }
        if inst.mode == Mode::Instantiated {
            // The subsystem is set up by fmi3EnterInitializationMode; values set before are
            // checked for size now and applied then.
            let mut at = 0;
            for &vr in vrs {
                let Some(len) = inst.model.variables().get(vr as usize).map(|v| v.len()) else {
                    return inst.fail(&format!("fmi3SetFloat64: unknown value reference {vr}"));
                };
                let Some(v) = values.get(at..at + len) else {
                    return inst.fail(&format!("fmi3SetFloat64: nValues = {n_values} is too small"));
                };
                inst.pending.push((vr, v.to_vec()));
                at += len;
            }
            return OK;
        }
        match inst.model.set_f64(vrs, values) {
            Ok(()) => OK,
            Err(e) => inst.fail(&format!("fmi3SetFloat64: {e}")),
        }
    };
    // SAFETY: forwarded.
    unsafe { with_instance::<M>(instance, "fmi3SetFloat64", body) }
}

/// `fmi3DoStep`.
///
/// # Safety
/// As [`with_instance`]; the four output pointers must be null or writable.
#[allow(clippy::too_many_arguments)]
pub unsafe fn do_step<M: Exportable>(
    instance: *mut c_void,
    current: f64,
    step: f64,
    event_handling_needed: *mut bool,
    terminate_simulation: *mut bool,
    early_return: *mut bool,
    last_successful_time: *mut f64,
) -> Status {
    let body = |inst: &mut Instance<M>| {
        if let Err(s) = inst.require("fmi3DoStep", &[Mode::Step]) {
            return s;
        }
        let now = inst.model.time();
        // Communication points arrive as floats accumulated by the importer: accept float noise.
        if (current - now.seconds()).abs() > 1e-9 * now.seconds().abs().max(1e-3) {
            return inst.fail(&format!(
                "fmi3DoStep: currentCommunicationPoint {current} s but the FMU is at {} s",
                now.seconds()
            ));
        }
        let h = match Ticks::from_seconds(step) {
            Ok(h) if h.0 > 0 => h,
            Ok(_) => return inst.fail(&format!("fmi3DoStep: communicationStepSize {step} must be > 0")),
            Err(e) => return inst.fail(&format!("fmi3DoStep: communicationStepSize: {e}")),
        };
        if let Some((_, Some(stop))) = inst.start
            && now.0 + h.0 > stop.0
        {
            return inst.fail(&format!("fmi3DoStep: the step would pass the stop time {} s", stop.seconds()));
        }
        let result = inst.model.do_step(now, h);
        let reached = inst.model.time().seconds();
        let (terminate, early) = match result {
            Ok(StepOutcome::Terminate { reached: r }) => (true, r.0 < now.0 + h.0),
            Ok(StepOutcome::EarlyReturn { .. }) => (false, true),
            _ => (false, false),
        };
        for (p, v) in [(event_handling_needed, false), (terminate_simulation, terminate), (early_return, early)] {
            if !p.is_null() {
                // SAFETY: per the contract above (fmi3Boolean is a C bool: one byte).
                unsafe { *p = v };
            }
        }
        if !last_successful_time.is_null() {
            // SAFETY: per the contract above.
            unsafe { *last_successful_time = reached };
        }
        match result {
            Ok(StepOutcome::Completed | StepOutcome::EarlyReturn { .. } | StepOutcome::Terminate { .. }) => OK,
            Err(e) => {
                inst.mode = Mode::Failed;
                inst.fail(&format!("fmi3DoStep: {e}"))
            }
        }
    };
    // SAFETY: forwarded.
    unsafe { with_instance::<M>(instance, "fmi3DoStep", body) }
}

/// `fmi3GetFMUState`: a snapshot (new, or overwriting `*state` when it is not null).
///
/// # Safety
/// As [`with_instance`]; `state` must be writable; `*state` null or from this function.
pub unsafe fn get_fmu_state<M: Exportable>(instance: *mut c_void, state: *mut *mut c_void) -> Status {
    let body = |inst: &mut Instance<M>| {
        if state.is_null() {
            return inst.fail("fmi3GetFMUState: null FMUState pointer");
        }
        let snapshot = match inst.model.save_state() {
            Ok(s) => (s, inst.mode, inst.start),
            Err(e) => return inst.fail(&e.to_string()),
        };
        // SAFETY: per the contract above.
        let slot = unsafe { &mut *state };
        if !slot.is_null() {
            // SAFETY: an earlier snapshot from this function.
            drop(unsafe { Box::from_raw(*slot as *mut (SavedState, Mode, Option<(Ticks, Option<Ticks>)>)) });
        }
        *slot = Box::into_raw(Box::new(snapshot)) as *mut c_void;
        OK
    };
    // SAFETY: forwarded.
    unsafe { with_instance::<M>(instance, "fmi3GetFMUState", body) }
}

/// `fmi3SetFMUState`.
///
/// # Safety
/// As [`with_instance`]; `state` must come from [`get_fmu_state`] of the same model type.
pub unsafe fn set_fmu_state<M: Exportable>(instance: *mut c_void, state: *mut c_void) -> Status {
    let body = |inst: &mut Instance<M>| {
        if state.is_null() {
            return inst.fail("fmi3SetFMUState: null FMUState");
        }
        // SAFETY: per the contract above.
        let (saved, mode, start) = unsafe { &*(state as *const (SavedState, Mode, Option<(Ticks, Option<Ticks>)>)) };
        match inst.model.restore_state(saved) {
            Ok(()) => {
                inst.mode = *mode;
                inst.start = *start;
                OK
            }
            Err(e) => inst.fail(&e.to_string()),
        }
    };
    // SAFETY: forwarded.
    unsafe { with_instance::<M>(instance, "fmi3SetFMUState", body) }
}

/// `fmi3FreeFMUState`.
///
/// # Safety
/// As [`with_instance`]; `state` must be null or point to null or a snapshot from [`get_fmu_state`].
pub unsafe fn free_fmu_state<M: Exportable>(instance: *mut c_void, state: *mut *mut c_void) -> Status {
    let body = |_: &mut Instance<M>| {
        // SAFETY: per the contract above: `state` is null or points to null or a snapshot.
        unsafe {
            if !state.is_null() && !(*state).is_null() {
                drop(Box::from_raw(*state as *mut (SavedState, Mode, Option<(Ticks, Option<Ticks>)>)));
                *state = std::ptr::null_mut();
            }
        }
        OK
    };
    // SAFETY: forwarded.
    unsafe { with_instance::<M>(instance, "fmi3FreeFMUState", body) }
}

/// Any function this FMU does not support: logs and returns `fmi3Error`.
///
/// # Safety
/// As [`with_instance`].
pub unsafe fn unsupported<M: Exportable>(instance: *mut c_void, call: &str) -> Status {
    // SAFETY: forwarded.
    unsafe { with_instance::<M>(instance, call, |inst| inst.fail(&format!("{call} is not supported by this FMU"))) }
}

/// `fmi3SetDebugLogging`.
///
/// # Safety
/// As [`with_instance`].
pub unsafe fn set_debug_logging<M: Exportable>(instance: *mut c_void, on: bool) -> Status {
    let body = |inst: &mut Instance<M>| {
        inst.logging_on = on;
        OK
    };
    // SAFETY: forwarded.
    unsafe { with_instance::<M>(instance, "fmi3SetDebugLogging", body) }
}

/// Writes the `extern "C"` symbols of `fmi3Functions.h` for the model type `$model`, each a
/// one-line forward to [`crate::fmi3`]. Use once in an FMU's cdylib crate.
#[macro_export]
macro_rules! export_fmi3 {
    ($model:ty) => {
        /// The `extern "C"` FMI 3.0 functions (also callable from Rust, for tests).
        pub mod fmi3_exports {
            #![allow(non_snake_case, clippy::missing_safety_doc, clippy::too_many_arguments, missing_docs)]
            use super::*;
            use std::ffi::{c_char, c_void};
            use $crate::fmi3 as f;
            type M = $model;
            type I = *mut c_void;
            type Vr = u32;
            type St = f::Status;

            #[unsafe(no_mangle)]
            pub extern "C" fn fmi3GetVersion() -> *const c_char {
                c"3.0".as_ptr()
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi3SetDebugLogging(i: I, on: bool, _n: usize, _c: *const *const c_char) -> St {
                unsafe { f::set_debug_logging::<M>(i, on) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi3InstantiateModelExchange(
                _name: *const c_char, _token: *const c_char, _res: *const c_char, _visible: bool, _logging: bool,
                _env: *mut c_void, _log: f::LogMessage,
            ) -> I {
                std::ptr::null_mut()
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi3InstantiateCoSimulation(
                name: *const c_char, token: *const c_char, res: *const c_char, _visible: bool, logging: bool,
                event_mode: bool, _early_return: bool, _required: *const Vr, _n_required: usize, env: *mut c_void,
                log: f::LogMessage, _intermediate: *const c_void,
            ) -> I {
                unsafe { f::instantiate::<M>(name, token, res, logging, event_mode, env, log) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi3InstantiateScheduledExecution(
                _name: *const c_char, _token: *const c_char, _res: *const c_char, _visible: bool, _logging: bool,
                _env: *mut c_void, _log: f::LogMessage, _clock: *const c_void, _lock: *const c_void,
                _unlock: *const c_void,
            ) -> I {
                std::ptr::null_mut()
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi3FreeInstance(i: I) {
                unsafe { f::free_instance::<M>(i) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi3EnterInitializationMode(
                i: I, _tol_defined: bool, _tol: f64, start: f64, stop_defined: bool, stop: f64,
            ) -> St {
                unsafe { f::enter_initialization_mode::<M>(i, start, stop_defined, stop) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi3ExitInitializationMode(i: I) -> St {
                unsafe { f::exit_initialization_mode::<M>(i) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi3EnterEventMode(i: I) -> St {
                unsafe { f::unsupported::<M>(i, "fmi3EnterEventMode") }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi3Terminate(i: I) -> St {
                unsafe { f::terminate::<M>(i) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi3Reset(i: I) -> St {
                unsafe { f::reset::<M>(i) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi3GetFloat64(i: I, vr: *const Vr, nvr: usize, v: *mut f64, nv: usize) -> St {
                unsafe { f::get_float64::<M>(i, vr, nvr, v, nv) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi3SetFloat64(i: I, vr: *const Vr, nvr: usize, v: *const f64, nv: usize) -> St {
                unsafe { f::set_float64::<M>(i, vr, nvr, v, nv) }
            }
            $crate::export_fmi3!(@unsupported_typed
                fmi3GetFloat32 fmi3GetInt8 fmi3GetUInt8 fmi3GetInt16 fmi3GetUInt16 fmi3GetInt32 fmi3GetUInt32
                fmi3GetInt64 fmi3GetUInt64 fmi3GetBoolean fmi3GetString fmi3SetFloat32 fmi3SetInt8 fmi3SetUInt8
                fmi3SetInt16 fmi3SetUInt16 fmi3SetInt32 fmi3SetUInt32 fmi3SetInt64 fmi3SetUInt64 fmi3SetBoolean
                fmi3SetString fmi3GetBinary fmi3SetBinary fmi3GetClock fmi3SetClock
                fmi3GetNumberOfVariableDependencies fmi3GetVariableDependencies fmi3SerializedFMUStateSize
                fmi3SerializeFMUState fmi3DeserializeFMUState fmi3DeSerializeFMUState fmi3GetDirectionalDerivative
                fmi3GetAdjointDerivative fmi3EnterConfigurationMode fmi3ExitConfigurationMode
                fmi3GetIntervalDecimal fmi3GetIntervalFraction fmi3GetShiftDecimal fmi3GetShiftFraction
                fmi3SetIntervalDecimal fmi3SetIntervalFraction fmi3SetShiftDecimal fmi3SetShiftFraction
                fmi3EvaluateDiscreteStates fmi3UpdateDiscreteStates fmi3EnterContinuousTimeMode
                fmi3CompletedIntegratorStep fmi3SetTime fmi3SetContinuousStates fmi3GetContinuousStateDerivatives
                fmi3GetEventIndicators fmi3GetContinuousStates fmi3GetNominalsOfContinuousStates
                fmi3GetNumberOfEventIndicators fmi3GetNumberOfContinuousStates fmi3GetOutputDerivatives
                fmi3ActivateModelPartition
            );
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi3GetFMUState(i: I, s: *mut *mut c_void) -> St {
                unsafe { f::get_fmu_state::<M>(i, s) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi3SetFMUState(i: I, s: *mut c_void) -> St {
                unsafe { f::set_fmu_state::<M>(i, s) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi3FreeFMUState(i: I, s: *mut *mut c_void) -> St {
                unsafe { f::free_fmu_state::<M>(i, s) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi3EnterStepMode(i: I) -> St {
                unsafe { f::enter_step_mode::<M>(i) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi3DoStep(
                i: I, t: f64, h: f64, _no_set_prior: bool, event: *mut bool, terminate: *mut bool,
                early: *mut bool, last: *mut f64,
            ) -> St {
                unsafe { f::do_step::<M>(i, t, h, event, terminate, early, last) }
            }
        }
    };
    (@unsupported_typed $($name:ident)*) => {
        $(
            /// Not supported by this FMU: logs and returns fmi3Error. (Its C arguments after the
            /// instance are not read, so one signature serves every such function.)
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn $name(i: I) -> St {
                unsafe { f::unsupported::<M>(i, stringify!($name)) }
            }
        )*
    };
}

/// The model description of a plugin, built once from its [`Exportable`] (null if the model
/// cannot be built, or on a panic).
pub fn plugin_description<M: Exportable>() -> *const std::ffi::c_char {
    static DESCRIPTION: std::sync::OnceLock<Option<std::ffi::CString>> = std::sync::OnceLock::new();
    let text = DESCRIPTION.get_or_init(|| {
        std::panic::catch_unwind(|| {
            let model = M::create(None).ok()?;
            let xml = crate::description::fmi3(&M::info(None, &model).ok()?, model.variables());
            std::ffi::CString::new(xml).ok()
        })
        .ok()
        .flatten()
    });
    text.as_ref().map_or(std::ptr::null(), |t| t.as_ptr())
}

/// Makes a cdylib a lash plugin: the FMI 3.0 functions of [`export_fmi3!`] plus
/// `lash_plugin_model_description`, so that `lash` (and [`crate::import::ImportedFmu::open_plugin`])
/// loads it straight from the shared library, without packing an FMU. `lash fmu pack`-style
/// archives can still be made from the same library.
#[macro_export]
macro_rules! export_plugin {
    ($model:ty) => {
        $crate::export_fmi3!($model);

        /// The plugin's `modelDescription.xml` (FMI 3.0), a static C string.
        #[unsafe(no_mangle)]
        pub extern "C" fn lash_plugin_model_description() -> *const std::ffi::c_char {
            $crate::fmi3::plugin_description::<$model>()
        }
    };
}
