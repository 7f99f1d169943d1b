//! FMU import (FMI 3.0 co-simulation; FMI 2.0 import is the next step): unzip once into a cache,
//! read `modelDescription.xml` leniently, load the shared library with libloading into a typed
//! function table, and wrap the instance as a [`Subsystem`] that any lash master can drive.
//!
//! Every failure is a clear error naming the file and the problem: a missing archive entry, an
//! unparsable description, a binary for another platform, a library that does not load, a missing
//! symbol, a refused instantiation (with the FMU's own log messages).

use lash_core::subsystem::{Causality, Variability};
use lash_core::{SavedState, StepOutcome, Subsystem, SubsystemError, Ticks, ValueReference, Variable};
use std::ffi::{CStr, CString, c_char, c_void};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// Why an FMU cannot be imported.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// Reading or unpacking the archive failed.
    #[error("{path}: {message}")]
    Archive {
        /// The archive.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// `modelDescription.xml` is missing something essential.
    #[error("{path}: modelDescription.xml: {message}")]
    Description {
        /// The archive.
        path: PathBuf,
        /// What is missing or malformed.
        message: String,
    },
    /// The shared library cannot be used.
    #[error("{path}: {message}")]
    Library {
        /// The library file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

/// What lash reads of a `modelDescription.xml` (leniently: unknown elements and attributes are
/// skipped, numbers in any float syntax, missing optional attributes defaulted).
#[derive(Debug, Clone, PartialEq)]
pub struct Description {
    /// `fmiVersion`.
    pub fmi_version: String,
    /// `modelName`.
    pub model_name: String,
    /// `instantiationToken` (3.0) or `guid` (2.0).
    pub token: String,
    /// `modelIdentifier` of the co-simulation interface.
    pub model_identifier: String,
    /// Float64 (3.0) / Real (2.0) variables; the independent variable is left out.
    pub variables: Vec<Variable>,
}

fn attr(e: &quick_xml::events::BytesStart<'_>, name: &str) -> Option<String> {
    e.attributes().flatten().find(|a| a.key.as_ref() == name).map(|a| {
        a.value
            .replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&quot;", "\"")
            .replace("&apos;", "'")
            .replace("&amp;", "&")
    })
}

/// Parses a model description.
pub fn parse_description(xml: &str) -> Result<Description, String> {
    use quick_xml::events::Event;
    let mut reader = quick_xml::Reader::from_str(xml);
    let mut d = Description {
        fmi_version: String::new(),
        model_name: String::new(),
        token: String::new(),
        model_identifier: String::new(),
        variables: Vec::new(),
    };
    let mut current: Option<Variable> = None;
    loop {
        let event = reader.read_event().map_err(|e| format!("XML error at byte {}: {e}", reader.buffer_position()))?;
        let (e, empty) = match &event {
            Event::Start(e) => (e, false),
            Event::Empty(e) => (e, true),
            Event::End(e) => {
                if matches!(e.name().as_ref(), "Float64" | "ScalarVariable")
                    && let Some(v) = current.take()
                {
                    d.variables.push(v);
                }
                continue;
            }
            Event::Eof => break,
            _ => continue,
        };
        match e.name().as_ref() {
            "fmiModelDescription" => {
                d.fmi_version = attr(e, "fmiVersion").unwrap_or_default();
                d.model_name = attr(e, "modelName").unwrap_or_default();
                d.token = attr(e, "instantiationToken").or_else(|| attr(e, "guid")).unwrap_or_default();
            }
            "CoSimulation" => d.model_identifier = attr(e, "modelIdentifier").unwrap_or_default(),
            "Float64" | "ScalarVariable" => {
                let causality = match attr(e, "causality").as_deref() {
                    Some("independent") => None,
                    Some("parameter") => Some(Causality::Parameter),
                    Some("input") => Some(Causality::Input),
                    Some("output") => Some(Causality::Output),
                    _ => Some(Causality::Local),
                };
                let Some(causality) = causality else { continue };
                let Some(vr) = attr(e, "valueReference").and_then(|v| v.trim().parse::<u32>().ok()) else {
                    return Err(format!("variable {:?} has no valid valueReference", attr(e, "name")));
                };
                let variable = Variable {
                    name: attr(e, "name").ok_or("a variable without a name")?,
                    value_reference: vr,
                    causality,
                    variability: match attr(e, "variability").as_deref() {
                        Some("constant" | "fixed" | "tunable") => Variability::Fixed,
                        Some("discrete") => Variability::Discrete,
                        _ => Variability::Continuous,
                    },
                    unit: attr(e, "unit").unwrap_or_default(),
                    description: attr(e, "description").unwrap_or_default(),
                    shape: Vec::new(),
                    start: attr(e, "start")
                        .map(|s| s.split_whitespace().filter_map(|x| x.parse().ok()).collect())
                        .unwrap_or_default(),
                };
                if empty {
                    d.variables.push(variable);
                } else {
                    current = Some(variable);
                }
            }
            "Dimension" => {
                if let Some(v) = current.as_mut() {
                    let n = attr(e, "start")
                        .and_then(|s| s.trim().parse::<usize>().ok())
                        .ok_or("a Dimension without a literal start (structural parameters are not supported)")?;
                    v.shape.push(n);
                }
            }
            "Real" => {
                // FMI 2.0: the type element inside ScalarVariable carries unit and start.
                if let Some(v) = current.as_mut() {
                    v.unit = attr(e, "unit").unwrap_or_default();
                    if let Some(s) = attr(e, "start").and_then(|s| s.trim().parse().ok()) {
                        v.start = vec![s];
                    }
                }
            }
            "Integer" | "Boolean" | "String" | "Enumeration" => current = None,
            _ => {}
        }
    }
    if d.fmi_version.is_empty() {
        return Err("no fmiModelDescription element with an fmiVersion".into());
    }
    if d.model_identifier.is_empty() {
        return Err("no CoSimulation element with a modelIdentifier (only co-simulation FMUs are imported)".into());
    }
    Ok(d)
}

/// Unpacks `fmu` into `cache/<stem>-<size>-<mtime>/` once and returns that folder.
pub fn unpack(fmu: &Path, cache: &Path) -> Result<PathBuf, ImportError> {
    let err = |m: String| ImportError::Archive { path: fmu.to_path_buf(), message: m };
    let meta = std::fs::metadata(fmu).map_err(|e| err(e.to_string()))?;
    let stamp =
        meta.modified().ok().and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok()).map_or(0, |d| d.as_nanos());
    let stem = fmu.file_stem().and_then(|s| s.to_str()).unwrap_or("fmu");
    let dir = cache.join(format!("{stem}-{}-{stamp}", meta.len()));
    if dir.join("modelDescription.xml").is_file() {
        return Ok(dir);
    }
    let file = std::fs::File::open(fmu).map_err(|e| err(e.to_string()))?;
    let mut archive = zip::ZipArchive::new(file).map_err(|e| err(format!("not a zip archive: {e}")))?;
    let partial = dir.with_extension("partial");
    let _ = std::fs::remove_dir_all(&partial);
    archive.extract(&partial).map_err(|e| err(format!("unpacking: {e}")))?;
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::rename(&partial, &dir).map_err(|e| err(e.to_string()))?;
    Ok(dir)
}

type Instantiate = unsafe extern "C" fn(
    *const c_char,
    *const c_char,
    *const c_char,
    bool,
    bool,
    bool,
    bool,
    *const u32,
    usize,
    *mut c_void,
    Option<unsafe extern "C" fn(*mut c_void, i32, *const c_char, *const c_char)>,
    *const c_void,
) -> *mut c_void;
type Free = unsafe extern "C" fn(*mut c_void);
type EnterInit = unsafe extern "C" fn(*mut c_void, bool, f64, f64, bool, f64) -> i32;
type Unary = unsafe extern "C" fn(*mut c_void) -> i32;
type GetF64 = unsafe extern "C" fn(*mut c_void, *const u32, usize, *mut f64, usize) -> i32;
type SetF64 = unsafe extern "C" fn(*mut c_void, *const u32, usize, *const f64, usize) -> i32;
type DoStep = unsafe extern "C" fn(*mut c_void, f64, f64, bool, *mut bool, *mut bool, *mut bool, *mut f64) -> i32;
type GetState = unsafe extern "C" fn(*mut c_void, *mut *mut c_void) -> i32;
type SetState = unsafe extern "C" fn(*mut c_void, *mut c_void) -> i32;

/// The FMI 3.0 functions lash calls, resolved once.
struct Functions {
    instantiate: Instantiate,
    free: Free,
    enter_init: EnterInit,
    exit_init: Unary,
    terminate: Unary,
    get: GetF64,
    set: SetF64,
    do_step: DoStep,
    get_state: GetState,
    set_state: SetState,
    free_state: GetState,
}

/// Log messages of one imported instance (its instance environment points here).
type Log = Mutex<Vec<String>>;

unsafe extern "C" fn log_message(env: *mut c_void, status: i32, _category: *const c_char, message: *const c_char) {
    if env.is_null() || message.is_null() {
        return;
    }
    // SAFETY: `env` is the `Log` this importer passed at instantiation; `message` a C string.
    let (log, text) = unsafe { (&*(env as *const Log), CStr::from_ptr(message).to_string_lossy().into_owned()) };
    if let Ok(mut l) = log.lock() {
        l.push(format!("[status {status}] {text}"));
    }
}

/// An FMU snapshot, freed with its instance.
struct FmuState(*mut c_void);
// SAFETY: an FMU state is an opaque handle owned by one instance, used from one thread at a time.
unsafe impl Send for FmuState {}
// SAFETY: the handle is only passed back to the FMU, never dereferenced here.
unsafe impl Sync for FmuState {}

/// An imported FMI 3.0 co-simulation FMU as a [`Subsystem`].
pub struct ImportedFmu {
    name: String,
    description: Description,
    functions: Functions,
    instance: *mut c_void,
    log: Box<Log>,
    time: Ticks,
    /// Every FMU state taken, freed with the instance (FMI has no way to free one from a
    /// `SavedState` alone).
    states: Mutex<Vec<Arc<FmuState>>>,
    // Declared last: dropped after the instance is freed.
    _library: libloading::Library,
}

// SAFETY: the instance is only used through `&mut self` (one thread at a time), as FMI requires.
unsafe impl Send for ImportedFmu {}

impl ImportedFmu {
    /// Imports `fmu` (unpacked into `cache` once) and instantiates it.
    pub fn open(fmu: &Path, cache: &Path, instance_name: &str) -> Result<Self, ImportError> {
        let dir = unpack(fmu, cache)?;
        let xml = std::fs::read_to_string(dir.join("modelDescription.xml")).map_err(|e| ImportError::Archive {
            path: fmu.to_path_buf(),
            message: format!("modelDescription.xml: {e}"),
        })?;
        let description =
            parse_description(&xml).map_err(|m| ImportError::Description { path: fmu.to_path_buf(), message: m })?;
        if !description.fmi_version.starts_with("3.") {
            return Err(ImportError::Description {
                path: fmu.to_path_buf(),
                message: format!("fmiVersion {:?}: this importer reads FMI 3.0", description.fmi_version),
            });
        }
        let lib_path = dir.join("binaries/x86_64-linux").join(format!("{}.so", description.model_identifier));
        if !lib_path.is_file() {
            let platforms: Vec<String> = std::fs::read_dir(dir.join("binaries"))
                .map(|r| r.flatten().map(|e| e.file_name().to_string_lossy().into_owned()).collect())
                .unwrap_or_default();
            return Err(ImportError::Library {
                path: lib_path,
                message: format!("no binary for x86_64-linux in the FMU (it has: {platforms:?})"),
            });
        }
        let lerr = |m: String| ImportError::Library { path: lib_path.clone(), message: m };
        // SAFETY: loading a shared library runs its initialisers; an FMU's binary is trusted
        // code by the user's choice of FMU.
        let library = unsafe { libloading::Library::new(&lib_path) }.map_err(|e| lerr(format!("cannot load: {e}")))?;
        macro_rules! sym {
            ($name:literal, $ty:ty) => {{
                // SAFETY: the symbol has this signature in fmi3Functions.h.
                let s: libloading::Symbol<'_, $ty> = unsafe { library.get(concat!($name, "\0").as_bytes()) }
                    .map_err(|e| lerr(format!("missing symbol {}: {e}", $name)))?;
                *s
            }};
        }
        let functions = Functions {
            instantiate: sym!("fmi3InstantiateCoSimulation", Instantiate),
            free: sym!("fmi3FreeInstance", Free),
            enter_init: sym!("fmi3EnterInitializationMode", EnterInit),
            exit_init: sym!("fmi3ExitInitializationMode", Unary),
            terminate: sym!("fmi3Terminate", Unary),
            get: sym!("fmi3GetFloat64", GetF64),
            set: sym!("fmi3SetFloat64", SetF64),
            do_step: sym!("fmi3DoStep", DoStep),
            get_state: sym!("fmi3GetFMUState", GetState),
            set_state: sym!("fmi3SetFMUState", SetState),
            free_state: sym!("fmi3FreeFMUState", GetState),
        };
        let log: Box<Log> = Box::new(Mutex::new(Vec::new()));
        let cname = CString::new(instance_name).unwrap_or_default();
        let token = CString::new(description.token.clone()).unwrap_or_default();
        let resources = CString::new(format!("{}/", dir.join("resources").display())).unwrap_or_default();
        // SAFETY: valid C strings; the log environment outlives the instance (freed in Drop first).
        let instance = unsafe {
            (functions.instantiate)(
                cname.as_ptr(),
                token.as_ptr(),
                resources.as_ptr(),
                false,
                false,
                false,
                false,
                std::ptr::null(),
                0,
                &*log as *const Log as *mut c_void,
                Some(log_message),
                std::ptr::null(),
            )
        };
        if instance.is_null() {
            let messages = log.lock().map(|l| l.join("; ")).unwrap_or_default();
            return Err(lerr(format!("fmi3InstantiateCoSimulation failed: {messages}")));
        }
        Ok(Self {
            name: instance_name.to_string(),
            description,
            functions,
            instance,
            log,
            time: Ticks::ZERO,
            states: Mutex::new(Vec::new()),
            _library: library,
        })
    }

    /// The parsed model description.
    pub fn description(&self) -> &Description {
        &self.description
    }

    fn check(&self, call: &str, status: i32) -> Result<(), SubsystemError> {
        if status <= 1 {
            return Ok(());
        }
        let messages = self.log.lock().map(|mut l| std::mem::take(&mut *l).join("; ")).unwrap_or_default();
        Err(SubsystemError::Other(format!("{}: {call} returned status {status}: {messages}", self.name)))
    }
}

impl Drop for ImportedFmu {
    fn drop(&mut self) {
        let states = self.states.get_mut().map(std::mem::take).unwrap_or_default();
        for s in states {
            let mut p = s.0;
            // SAFETY: a state from this instance, freed once, before the instance.
            unsafe { (self.functions.free_state)(self.instance, &mut p) };
        }
        // SAFETY: the instance from instantiate, freed once; the library is still loaded.
        unsafe { (self.functions.free)(self.instance) };
    }
}

impl Subsystem for ImportedFmu {
    fn name(&self) -> &str {
        &self.name
    }

    fn variables(&self) -> &[Variable] {
        &self.description.variables
    }

    fn setup(&mut self, start: Ticks, stop: Option<Ticks>) -> Result<(), SubsystemError> {
        self.time = start;
        // SAFETY: a live instance.
        let s = unsafe {
            (self.functions.enter_init)(
                self.instance,
                false,
                0.0,
                start.seconds(),
                stop.is_some(),
                stop.map_or(0.0, Ticks::seconds),
            )
        };
        self.check("fmi3EnterInitializationMode", s)
    }

    fn initialize(&mut self) -> Result<(), SubsystemError> {
        // SAFETY: a live instance.
        let s = unsafe { (self.functions.exit_init)(self.instance) };
        self.check("fmi3ExitInitializationMode", s)
    }

    fn set_f64(&mut self, refs: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError> {
        // SAFETY: a live instance; slices with their lengths.
        let s =
            unsafe { (self.functions.set)(self.instance, refs.as_ptr(), refs.len(), values.as_ptr(), values.len()) };
        self.check("fmi3SetFloat64", s)
    }

    fn get_f64(&self, refs: &[ValueReference], values: &mut [f64]) -> Result<(), SubsystemError> {
        // SAFETY: a live instance; slices with their lengths.
        let s = unsafe {
            (self.functions.get)(self.instance, refs.as_ptr(), refs.len(), values.as_mut_ptr(), values.len())
        };
        self.check("fmi3GetFloat64", s)
    }

    fn do_step(&mut self, t: Ticks, h: Ticks) -> Result<StepOutcome, SubsystemError> {
        let (mut event, mut terminate, mut early, mut last) = (false, false, false, 0.0);
        // SAFETY: a live instance; output pointers to locals.
        let s = unsafe {
            (self.functions.do_step)(
                self.instance,
                t.seconds(),
                h.seconds(),
                true,
                &mut event,
                &mut terminate,
                &mut early,
                &mut last,
            )
        };
        self.check("fmi3DoStep", s)?;
        self.time = Ticks(t.0 + h.0);
        Ok(if early {
            StepOutcome::EarlyReturn { reached: Ticks::from_seconds(last).unwrap_or(self.time) }
        } else {
            StepOutcome::Completed
        })
    }

    fn time(&self) -> Ticks {
        self.time
    }

    fn save_state(&self) -> Result<SavedState, SubsystemError> {
        let mut p = std::ptr::null_mut();
        // SAFETY: a live instance; a fresh state pointer.
        let s = unsafe { (self.functions.get_state)(self.instance, &mut p) };
        self.check("fmi3GetFMUState", s)?;
        let state = Arc::new(FmuState(p));
        if let Ok(mut all) = self.states.lock() {
            all.push(state.clone());
        }
        Ok(SavedState(Box::new((state, self.time))))
    }

    fn restore_state(&mut self, state: &SavedState) -> Result<(), SubsystemError> {
        let (fmu_state, time) = state
            .0
            .downcast_ref::<(Arc<FmuState>, Ticks)>()
            .ok_or_else(|| SubsystemError::Other("the saved state is not an imported FMU's".into()))?;
        // SAFETY: a state from this instance.
        let s = unsafe { (self.functions.set_state)(self.instance, fmu_state.0) };
        self.check("fmi3SetFMUState", s)?;
        self.time = *time;
        Ok(())
    }

    fn terminate(&mut self) -> Result<(), SubsystemError> {
        // SAFETY: a live instance.
        let s = unsafe { (self.functions.terminate)(self.instance) };
        self.check("fmi3Terminate", s)
    }
}
