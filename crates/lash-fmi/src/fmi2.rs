//! The generic FMI 2.0 co-simulation export, from the same instance and checks as FMI 3.0.
//!
//! FMI 2.0 has no arrays: every element of an array variable is a scalar of its own (value
//! references numbered in variable order, element order row-major; names `m[1,2]`), mapped back to
//! (variable, element) by the instance. Setting one element of an array sets the whole array with
//! the other elements unchanged. Functions outside co-simulation (model exchange, integer/boolean/
//! string variables, serialisation, derivatives) are present and return `fmi2Error`.

use crate::fmi3::{
    ERROR, Exportable, Fmi2Logger, Instance, Logger, Mode, OK, Status, create_instance, slice, slice_mut, with_instance,
};
use lash_core::Subsystem;
use std::ffi::{c_char, c_void};

/// `fmi2CallbackFunctions`.
#[repr(C)]
pub struct CallbackFunctions {
    /// Logger (variadic).
    pub logger: Option<Fmi2Logger>,
    /// Allocator (unused: lash allocates with Rust's allocator).
    pub allocate_memory: *const c_void,
    /// Deallocator (unused).
    pub free_memory: *const c_void,
    /// Asynchronous step callback (unused).
    pub step_finished: *const c_void,
    /// Passed back to the logger.
    pub component_environment: *mut c_void,
}

/// `fmi2Instantiate` (co-simulation only).
///
/// # Safety
/// String arguments must be null or NUL-terminated; `functions` null or valid for the instance's
/// lifetime.
pub unsafe fn instantiate<M: Exportable>(
    name: *const c_char,
    fmu_type: i32,
    guid: *const c_char,
    resource_location: *const c_char,
    functions: *const CallbackFunctions,
    logging_on: i32,
) -> *mut c_void {
    // SAFETY: per the contract above.
    let (logger, environment) = match unsafe { functions.as_ref() } {
        Some(f) => (f.logger.map_or(Logger::None, Logger::Fmi2), f.component_environment),
        None => (Logger::None, std::ptr::null_mut()),
    };
    if fmu_type != 1 {
        let name = c"lash";
        // SAFETY: per the contract above.
        unsafe {
            logger.send(
                environment,
                name,
                ERROR,
                "logStatusError",
                "only co-simulation (fmi2CoSimulation) is supported",
            )
        };
        return std::ptr::null_mut();
    }
    // SAFETY: forwarded.
    unsafe { create_instance::<M>(name, guid, resource_location, logging_on != 0, false, environment, logger) }
}

/// `fmi2SetupExperiment`: remembers start and stop for `fmi2EnterInitializationMode`.
///
/// # Safety
/// As [`with_instance`].
pub unsafe fn setup_experiment<M: Exportable>(
    instance: *mut c_void,
    start: f64,
    stop_defined: i32,
    stop: f64,
) -> Status {
    let body = |inst: &mut Instance<M>| {
        if let Err(s) = inst.require("fmi2SetupExperiment", &[Mode::Instantiated]) {
            return s;
        }
        inst.experiment = (start, (stop_defined != 0).then_some(stop));
        OK
    };
    // SAFETY: forwarded.
    unsafe { with_instance::<M>(instance, "fmi2SetupExperiment", body) }
}

/// `fmi2EnterInitializationMode`.
///
/// # Safety
/// As [`with_instance`].
pub unsafe fn enter_initialization_mode<M: Exportable>(instance: *mut c_void) -> Status {
    let mut experiment = (0.0, None);
    let read = |inst: &mut Instance<M>| {
        experiment = inst.experiment;
        OK
    };
    // SAFETY: forwarded.
    if unsafe { with_instance::<M>(instance, "fmi2EnterInitializationMode", read) } != OK {
        return ERROR;
    }
    let (start, stop) = experiment;
    // SAFETY: forwarded.
    unsafe { crate::fmi3::enter_initialization_mode::<M>(instance, start, stop.is_some(), stop.unwrap_or(0.0)) }
}

/// The current elements of variable `vr` (pending values before initialisation).
fn current<M: Exportable>(inst: &Instance<M>, vr: u32) -> Result<Vec<f64>, String> {
    let var = &inst.model.variables()[vr as usize];
    if inst.mode == Mode::Instantiated {
        return Ok(inst
            .pending
            .iter()
            .rev()
            .find(|(r, _)| *r == vr)
            .map_or_else(|| var.start.clone(), |p| p.1.clone()));
    }
    let mut v = vec![0.0; var.len()];
    inst.model.get_f64(&[vr], &mut v).map_err(|e| e.to_string())?;
    Ok(v)
}

/// `fmi2GetReal`.
///
/// # Safety
/// As [`with_instance`]; `vrs` and `values` must hold `nvr` elements.
pub unsafe fn get_real<M: Exportable>(instance: *mut c_void, vrs: *const u32, nvr: usize, values: *mut f64) -> Status {
    let body = |inst: &mut Instance<M>| {
        // SAFETY: the caller's contract on (vrs, nvr) and (values, nvr).
        let (Some(vrs), Some(values)) = (unsafe { slice(vrs, nvr) }, unsafe { slice_mut(values, nvr) }) else {
            return inst.fail("fmi2GetReal: null valueReferences or values");
        };
        for (out, &vr) in values.iter_mut().zip(vrs) {
            let Some(&(var, element)) = inst.scalars.get(vr as usize) else {
                return inst.fail(&format!("fmi2GetReal: unknown value reference {vr}"));
            };
            match current(inst, var) {
                Ok(v) => *out = v[element],
                Err(e) => return inst.fail(&format!("fmi2GetReal: {e}")),
            }
        }
        OK
    };
    // SAFETY: forwarded.
    unsafe { with_instance::<M>(instance, "fmi2GetReal", body) }
}

/// `fmi2SetReal`.
///
/// # Safety
/// As [`with_instance`]; `vrs` and `values` must hold `nvr` elements.
pub unsafe fn set_real<M: Exportable>(
    instance: *mut c_void,
    vrs: *const u32,
    nvr: usize,
    values: *const f64,
) -> Status {
    // Gather whole variables (current elements with the new ones written in), then set them
    // through the FMI 3.0 path, which checks causality, finiteness and state.
    let mut whole: Vec<(u32, Vec<f64>)> = Vec::new();
    let gather = |inst: &mut Instance<M>| {
        // SAFETY: the caller's contract on (vrs, nvr) and (values, nvr).
        let (Some(vrs), Some(values)) = (unsafe { slice(vrs, nvr) }, unsafe { slice(values, nvr) }) else {
            return inst.fail("fmi2SetReal: null valueReferences or values");
        };
        for (&value, &vr) in values.iter().zip(vrs) {
            let Some(&(var, element)) = inst.scalars.get(vr as usize) else {
                return inst.fail(&format!("fmi2SetReal: unknown value reference {vr}"));
            };
            if let Some(entry) = whole.iter_mut().find(|(r, _)| *r == var) {
                entry.1[element] = value;
            } else {
                match current(inst, var) {
                    Ok(mut v) => {
                        v[element] = value;
                        whole.push((var, v));
                    }
                    Err(e) => return inst.fail(&format!("fmi2SetReal: {e}")),
                }
            }
        }
        OK
    };
    // SAFETY: forwarded.
    if unsafe { with_instance::<M>(instance, "fmi2SetReal", gather) } != OK {
        return ERROR;
    }
    let refs: Vec<u32> = whole.iter().map(|(r, _)| *r).collect();
    let flat: Vec<f64> = whole.iter().flat_map(|(_, v)| v.iter().copied()).collect();
    // SAFETY: forwarded; the slices live across the call.
    unsafe { crate::fmi3::set_float64::<M>(instance, refs.as_ptr(), refs.len(), flat.as_ptr(), flat.len()) }
}

/// `fmi2DoStep`.
///
/// # Safety
/// As [`with_instance`].
pub unsafe fn do_step<M: Exportable>(instance: *mut c_void, current: f64, step: f64) -> Status {
    let none = std::ptr::null_mut();
    // SAFETY: forwarded; null output pointers are allowed.
    unsafe { crate::fmi3::do_step::<M>(instance, current, step, none, none, none, std::ptr::null_mut()) }
}

/// Writes the `extern "C"` symbols of `fmi2Functions.h` for `$model` (co-simulation), each a
/// one-line forward to [`crate::fmi2`] or [`crate::fmi3`]. Use once in an FMU's cdylib crate,
/// beside [`export_fmi3!`](crate::export_fmi3): the two standards' symbols do not collide.
#[macro_export]
macro_rules! export_fmi2 {
    ($model:ty) => {
        /// The `extern "C"` FMI 2.0 functions (also callable from Rust, for tests).
        pub mod fmi2_exports {
            #![allow(non_snake_case, clippy::missing_safety_doc, missing_docs)]
            use super::*;
            use std::ffi::{c_char, c_void};
            use $crate::{fmi2 as g, fmi3 as f};
            type M = $model;
            type C = *mut c_void;
            type St = f::Status;

            #[unsafe(no_mangle)]
            pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
                c"default".as_ptr()
            }
            #[unsafe(no_mangle)]
            pub extern "C" fn fmi2GetVersion() -> *const c_char {
                c"2.0".as_ptr()
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetDebugLogging(c: C, on: i32, _n: usize, _cat: *const *const c_char) -> St {
                unsafe { f::set_debug_logging::<M>(c, on != 0) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2Instantiate(
                name: *const c_char, kind: i32, guid: *const c_char, res: *const c_char,
                functions: *const g::CallbackFunctions, _visible: i32, logging: i32,
            ) -> C {
                unsafe { g::instantiate::<M>(name, kind, guid, res, functions, logging) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2FreeInstance(c: C) {
                unsafe { f::free_instance::<M>(c) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetupExperiment(
                c: C, _tol_defined: i32, _tol: f64, start: f64, stop_defined: i32, stop: f64,
            ) -> St {
                unsafe { g::setup_experiment::<M>(c, start, stop_defined, stop) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2EnterInitializationMode(c: C) -> St {
                unsafe { g::enter_initialization_mode::<M>(c) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2ExitInitializationMode(c: C) -> St {
                unsafe { f::exit_initialization_mode::<M>(c) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2Terminate(c: C) -> St {
                unsafe { f::terminate::<M>(c) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2Reset(c: C) -> St {
                unsafe { f::reset::<M>(c) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetReal(c: C, vr: *const u32, n: usize, v: *mut f64) -> St {
                unsafe { g::get_real::<M>(c, vr, n, v) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetReal(c: C, vr: *const u32, n: usize, v: *const f64) -> St {
                unsafe { g::set_real::<M>(c, vr, n, v) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2DoStep(c: C, t: f64, h: f64, _no_set_prior: i32) -> St {
                unsafe { g::do_step::<M>(c, t, h) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetFMUstate(c: C, s: *mut *mut c_void) -> St {
                unsafe { f::get_fmu_state::<M>(c, s) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetFMUstate(c: C, s: *mut c_void) -> St {
                unsafe { f::set_fmu_state::<M>(c, s) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2FreeFMUstate(c: C, s: *mut *mut c_void) -> St {
                unsafe { f::free_fmu_state::<M>(c, s) }
            }
            $crate::export_fmi2!(@unsupported
                fmi2GetInteger fmi2GetBoolean fmi2GetString fmi2SetInteger fmi2SetBoolean fmi2SetString
                fmi2SerializedFMUstateSize fmi2SerializeFMUstate fmi2DeSerializeFMUstate
                fmi2GetDirectionalDerivative fmi2SetRealInputDerivatives fmi2GetRealOutputDerivatives
                fmi2CancelStep fmi2GetStatus fmi2GetRealStatus fmi2GetIntegerStatus fmi2GetBooleanStatus
                fmi2GetStringStatus fmi2EnterEventMode fmi2NewDiscreteStates fmi2EnterContinuousTimeMode
                fmi2CompletedIntegratorStep fmi2SetTime fmi2SetContinuousStates fmi2GetDerivatives
                fmi2GetEventIndicators fmi2GetContinuousStates fmi2GetNominalsOfContinuousStates
            );
        }
    };
    (@unsupported $($name:ident)*) => {
        $(
            /// Not supported by this FMU: logs and returns fmi2Error. (Its C arguments after the
            /// component are not read, so one signature serves every such function.)
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn $name(c: C) -> St {
                unsafe { f::unsupported::<M>(c, stringify!($name)) }
            }
        )*
    };
}
