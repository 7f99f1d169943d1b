//! FMU import (FMI 3.0 and FMI 2.0 co-simulation): unzip once into a cache, read
//! `modelDescription.xml` leniently, load the shared library with libloading into a typed
//! function table, and wrap the instance as a [`Subsystem`] that any lash master can drive.
//!
//! FMI 2.0 has scalars only; exporters write arrays as `name[1]`, `name[1,2]` (1-based, as lash's
//! own FMI 2.0 export does). Consecutive scalars that spell one whole array are regrouped into an
//! array variable whose element names are the scalars' own names (see `regroup`); any other
//! scalar keeps its name as spelled.
//!
//! Every failure is a clear error naming the file and the problem: a missing archive entry, an
//! unparsable description, a binary for another platform, a library that does not load, a missing
//! symbol, a refused instantiation (with the FMU's own log messages).

use lash_core::subsystem::{Causality, ValueKind, Variability};
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
    /// The archive was refused or could not be unpacked (the entry and the rule named).
    #[error("{path}: {source}")]
    Unpack {
        /// The archive.
        path: PathBuf,
        /// The cause.
        source: crate::archive::UnpackError,
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
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Description {
    /// `fmiVersion`.
    pub fmi_version: String,
    /// `modelName`.
    pub model_name: String,
    /// `instantiationToken` (3.0) or `guid` (2.0).
    pub token: String,
    /// `modelIdentifier` of the co-simulation interface.
    pub model_identifier: String,
    /// `generationTool` (empty when absent).
    pub generation_tool: String,
    /// `DefaultExperiment stepSize`, when given.
    pub default_step_size: Option<f64>,
    /// The variables of every type, in file order (FMI 3.0 aliases after their variable); the
    /// independent variable is left out.
    pub variables: Vec<Variable>,
    /// Per variable, per array axis: the FMU's value reference of the structural parameter that
    /// sizes it (`None`: a literal size). A sized axis holds the parameter's current value.
    pub dimension_refs: Vec<Vec<Option<u32>>>,
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

/// The most elements lash accepts in one FMU's variables (arrays included): 2²⁴ (128 MiB of
/// `f64`), so a description cannot make a master allocate without bound.
pub const MAX_ELEMENTS: usize = 1 << 24;

/// Why a `modelDescription.xml` cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum DescriptionError {
    /// Not well-formed XML.
    #[error("XML error at byte {position}")]
    Xml {
        /// Where the reader stopped.
        position: u64,
        /// The XML reader's error.
        #[source]
        source: quick_xml::Error,
    },
    /// Well-formed, but missing or contradicting what lash needs (the text names the element or
    /// variable).
    #[error("{0}")]
    Invalid(String),
}

impl From<String> for DescriptionError {
    fn from(message: String) -> Self {
        Self::Invalid(message)
    }
}

impl From<&str> for DescriptionError {
    fn from(message: &str) -> Self {
        Self::Invalid(message.into())
    }
}

/// Parses a model description.
pub fn parse_description(xml: &str) -> Result<Description, DescriptionError> {
    use quick_xml::events::Event;
    let mut reader = quick_xml::Reader::from_str(xml);
    let mut r = DescriptionReader::default();
    loop {
        let event = reader
            .read_event()
            .map_err(|source| DescriptionError::Xml { position: reader.buffer_position(), source })?;
        match &event {
            Event::Start(e) => r.element(e, false)?,
            Event::Empty(e) => r.element(e, true)?,
            Event::End(e) => {
                let name = e.name();
                r.end(name.as_ref());
            }
            Event::Eof => break,
            _ => {}
        }
    }
    r.finish()
}

/// The state of [`parse_description`] between XML events.
#[derive(Default)]
struct DescriptionReader {
    d: Description,
    /// The structural parameters sizing the axes of the variable being read.
    dims: Vec<Option<u32>>,
    /// The variable being read (FMI 3.0: a type element; FMI 2.0: a ScalarVariable, whose type
    /// comes from its child element), its aliases, and whether it came from a ScalarVariable.
    current: Option<Variable>,
    aliases: Vec<(String, Option<String>)>,
    scalar: bool,
    in_variables: bool,
    /// Inside an FMI 2.0 ScalarVariable element (its children are type elements, not variables).
    in_scalar: bool,
}

impl DescriptionReader {
    /// An element opens (`empty`: and closes at once).
    fn element(&mut self, e: &quick_xml::events::BytesStart<'_>, empty: bool) -> Result<(), DescriptionError> {
        let name = e.name();
        let element: &str = name.as_ref();
        let d = &mut self.d;
        match element {
            "fmiModelDescription" => {
                d.fmi_version = attr(e, "fmiVersion").unwrap_or_default();
                d.model_name = attr(e, "modelName").unwrap_or_default();
                d.token = attr(e, "instantiationToken").or_else(|| attr(e, "guid")).unwrap_or_default();
                d.generation_tool = attr(e, "generationTool").unwrap_or_default();
            }
            "CoSimulation" => d.model_identifier = attr(e, "modelIdentifier").unwrap_or_default(),
            "DefaultExperiment" => {
                d.default_step_size = attr(e, "stepSize")
                    .and_then(|s| s.trim().parse::<f64>().ok())
                    .filter(|h| h.is_finite() && *h > 0.0);
            }
            "ModelVariables" => self.in_variables = !empty,
            "Dimension" => self.dimension(e)?,
            "Alias" if self.current.is_some() => {
                let name = attr(e, "name").ok_or("an Alias without a name")?;
                self.aliases.push((name, attr(e, "description")));
            }
            // FMI 2.0: the type element inside a ScalarVariable gives its kind, unit and start.
            other if self.scalar && self.current.is_some() && ValueKind::from_element(other, true).is_some() => {
                if let (Some(v), Some(kind)) = (self.current.as_mut(), ValueKind::from_element(other, true)) {
                    v.kind = kind;
                    v.unit = attr(e, "unit").unwrap_or_default();
                    if let Some(start) = attr(e, "start") {
                        v.start = number_list(&start, kind);
                    }
                }
            }
            other
                if self.in_variables
                    && !self.in_scalar
                    && (other == "ScalarVariable" || ValueKind::from_element(other, false).is_some()) =>
            {
                self.variable(e, other, empty)?
            }
            _ => {}
        }
        Ok(())
    }

    /// A Dimension of the variable being read: a literal size, or the value reference of the
    /// structural parameter that sizes this axis (resolved from its start value at the end).
    fn dimension(&mut self, e: &quick_xml::events::BytesStart<'_>) -> Result<(), DescriptionError> {
        let Some(v) = self.current.as_mut() else { return Ok(()) };
        let literal = attr(e, "start").and_then(|s| s.trim().parse::<usize>().ok());
        let sized_by = attr(e, "valueReference").and_then(|s| s.trim().parse::<u32>().ok());
        let n = match (literal, sized_by) {
            (Some(n), _) => n,
            (None, Some(_)) => 0,
            (None, None) => {
                return Err(format!("variable {:?}: a Dimension needs a start or a valueReference", v.name).into());
            }
        };
        let total = v.shape.iter().try_fold(n, |a, &b| a.checked_mul(b));
        if total.is_none_or(|t| t > MAX_ELEMENTS) {
            return Err(format!("variable {:?}: its dimensions exceed {MAX_ELEMENTS} elements", v.name).into());
        }
        v.shape.push(n);
        self.dims.push(if literal.is_some() { None } else { sized_by });
        Ok(())
    }

    /// A variable's element (`element`: its name, a type or ScalarVariable) opens.
    fn variable(
        &mut self,
        e: &quick_xml::events::BytesStart<'_>,
        element: &str,
        empty: bool,
    ) -> Result<(), DescriptionError> {
        self.scalar = element == "ScalarVariable";
        self.in_scalar = self.scalar && !empty;
        let kind = ValueKind::from_element(element, false).unwrap_or(ValueKind::Float64);
        let causality = match attr(e, "causality").as_deref() {
            Some("independent") => return Ok(()),
            Some("parameter") => Causality::Parameter,
            Some("structuralParameter") => Causality::StructuralParameter,
            Some("input") => Causality::Input,
            Some("output") => Causality::Output,
            _ => Causality::Local,
        };
        let Some(vr) = attr(e, "valueReference").and_then(|v| v.trim().parse::<u32>().ok()) else {
            return Err(format!("variable {:?} has no valid valueReference", attr(e, "name")).into());
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
            start: attr(e, "start").map(|s| number_list(&s, kind)).unwrap_or_default(),
            kind,
        };
        self.dims.clear();
        if empty {
            self.d.variables.push(variable);
            self.d.dimension_refs.push(Vec::new());
        } else {
            self.current = Some(variable);
            self.aliases.clear();
        }
        Ok(())
    }

    /// An element closes: a variable read is complete with its FMI 3.0 aliases (further names
    /// of the same value reference).
    fn end(&mut self, name: &str) {
        let closes =
            if self.scalar { name == "ScalarVariable" } else { ValueKind::from_element(name, false).is_some() };
        if name == "ModelVariables" {
            self.in_variables = false;
        }
        if name == "ScalarVariable" {
            self.in_scalar = false;
        }
        if closes && let Some(v) = self.current.take() {
            let named: Vec<Variable> = self
                .aliases
                .drain(..)
                .map(|(name, description)| Variable {
                    name,
                    description: description.unwrap_or_else(|| v.description.clone()),
                    ..v.clone()
                })
                .collect();
            for _ in 0..=named.len() {
                self.d.dimension_refs.push(self.dims.clone());
            }
            self.d.variables.push(v);
            self.d.variables.extend(named);
        }
    }

    /// The description read: arrays sized by their structural parameters' start values, the
    /// version and a model identifier that is a C identifier checked.
    fn finish(self) -> Result<Description, DescriptionError> {
        let mut d = self.d;
        let start_values: Vec<(u32, Option<f64>)> =
            d.variables.iter().map(|v| (v.value_reference, v.start.first().copied())).collect();
        resize(&mut d.variables, &d.dimension_refs, |vr| {
            start_values.iter().find(|(r, _)| *r == vr).and_then(|(_, s)| *s)
        })?;
        if d.fmi_version.is_empty() {
            return Err("no fmiModelDescription element with an fmiVersion".into());
        }
        if d.model_identifier.is_empty() {
            return Err("no CoSimulation element with a modelIdentifier (only co-simulation FMUs are imported)".into());
        }
        // The identifier names the binary inside the archive: a C identifier (as the standard
        // asks), so that it can never be a path that leaves `binaries/<platform>/`.
        let mut chars = d.model_identifier.chars();
        let c_identifier = chars.next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
            && chars.all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !c_identifier {
            return Err(format!(
                "modelIdentifier {:?} is not a C identifier (letters, digits and '_', not starting with a digit)",
                d.model_identifier
            )
            .into());
        }
        Ok(d)
    }
}

/// A start value's numbers (`true`/`false` for a Boolean; what does not parse is left out).
fn number_list(s: &str, kind: ValueKind) -> Vec<f64> {
    s.split_whitespace()
        .filter_map(|x| match (kind, x) {
            (ValueKind::Boolean, "true") => Some(1.0),
            (ValueKind::Boolean, "false") => Some(0.0),
            _ => x.parse().ok(),
        })
        .collect()
}

/// Where lash keeps unpacked FMUs between runs: `$LASH_CACHE`, else `$XDG_CACHE_HOME/lash`, else
/// `~/.cache/lash`, else `lash-cache` in the temporary folder.
pub fn default_cache() -> PathBuf {
    let var = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty()).map(PathBuf::from);
    var("LASH_CACHE")
        .or_else(|| var("XDG_CACHE_HOME").map(|p| p.join("lash")))
        .or_else(|| var("HOME").map(|p| p.join(".cache").join("lash")))
        .unwrap_or_else(|| std::env::temp_dir().join("lash-cache"))
}

/// Gives every axis sized by a structural parameter the parameter's value (`value_of` its FMU
/// value reference) and checks the sizes: whole, non-negative, and at most [`MAX_ELEMENTS`] in all.
fn resize(
    variables: &mut [Variable],
    dimension_refs: &[Vec<Option<u32>>],
    value_of: impl Fn(u32) -> Option<f64>,
) -> Result<(), String> {
    for (v, refs) in variables.iter_mut().zip(dimension_refs) {
        for (axis, r) in refs.iter().enumerate() {
            let Some(r) = r else { continue };
            let value = value_of(*r).ok_or_else(|| {
                format!("variable {:?}: its size refers to value reference {r}, which has no value", v.name)
            })?;
            if !(value >= 0.0 && value.fract() == 0.0 && value <= MAX_ELEMENTS as f64) {
                return Err(format!(
                    "variable {:?}: size {value} (value reference {r}) is not a valid array size",
                    v.name
                ));
            }
            if let Some(n) = v.shape.get_mut(axis) {
                *n = value as usize;
            }
        }
    }
    let total = variables.iter().try_fold(0usize, |a, v| {
        v.shape.iter().try_fold(1usize, |p, &n| p.checked_mul(n)).and_then(|n| a.checked_add(n))
    });
    if total.is_none_or(|t| t > MAX_ELEMENTS) {
        return Err(format!("the variables hold more than {MAX_ELEMENTS} elements together"));
    }
    Ok(())
}

/// Unpacks `fmu` into `cache/fmus/<stem>-<SHA-256 of the archive, 16 hex digits>/` once and
/// returns that folder: the same archive is unpacked once and reused by every later run (and by
/// concurrent ones: each unpacks into its own temporary folder and the first rename wins); an
/// edited archive gets a new folder. The archive is untrusted: see [`crate::archive`] for what is
/// refused and the limits ([`UnpackLimits::from_env`](crate::archive::UnpackLimits::from_env)).
/// A failed unpack leaves nothing behind, and a folder left by a process that died while
/// unpacking is removed, so that it cannot change the next answer.
pub fn unpack(fmu: &Path, cache: &Path) -> Result<PathBuf, ImportError> {
    use sha2::Digest;
    let err = |m: String| ImportError::Archive { path: fmu.to_path_buf(), message: m };
    let unpack_error = |source| ImportError::Unpack { path: fmu.to_path_buf(), source };
    let limits = crate::archive::UnpackLimits::from_env().map_err(unpack_error)?;
    let size = std::fs::metadata(fmu).map_err(|e| err(e.to_string()))?.len();
    if size > limits.max_archive_bytes {
        return Err(err(format!("{size} bytes, more than the {} an FMU archive may have", limits.max_archive_bytes)));
    }
    let bytes = std::fs::read(fmu).map_err(|e| err(e.to_string()))?;
    let digest = sha2::Sha256::digest(&bytes);
    let hex: String = digest.iter().take(8).map(|b| format!("{b:02x}")).collect();
    let stem = fmu.file_stem().and_then(|s| s.to_str()).filter(|s| crate::archive::is_plain_name(s)).unwrap_or("fmu");
    let dir = cache.join("fmus").join(format!("{stem}-{hex}"));
    let complete = dir.join(COMPLETE_MARK);
    if complete.is_file() {
        return Ok(dir);
    }
    remove_residue(&dir);
    let nonce = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.subsec_nanos());
    let partial = dir.with_extension(format!("partial-{}-{nonce}", std::process::id()));
    std::fs::create_dir_all(&partial).map_err(|e| err(format!("cache folder {}: {e}", partial.display())))?;
    let unpacked = crate::archive::unpack_into(&bytes, &partial, &limits).map_err(unpack_error).and_then(|()| {
        std::fs::write(partial.join(COMPLETE_MARK), b"").map_err(|e| err(format!("{}: {e}", partial.display())))
    });
    if let Err(e) = unpacked {
        let _ = std::fs::remove_dir_all(&partial);
        return Err(e);
    }
    if std::fs::rename(&partial, &dir).is_err() {
        // Another run unpacked the same archive first: use its folder.
        let _ = std::fs::remove_dir_all(&partial);
        if !complete.is_file() {
            return Err(err(format!("cannot move the unpacked FMU to {}", dir.display())));
        }
    }
    Ok(dir)
}

/// The file that marks an unpacked folder as complete (written last, before the rename).
const COMPLETE_MARK: &str = ".lash-unpacked";

/// Removes what an earlier unpack of the same archive left: the folder itself when it is not
/// marked complete (made by an older lash or cut short), and `*.partial-<pid>-*` folders whose
/// process no longer runs.
fn remove_residue(dir: &Path) {
    if dir.exists() {
        let _ = std::fs::remove_dir_all(dir);
    }
    let (Some(parent), Some(name)) = (dir.parent(), dir.file_name().and_then(|n| n.to_str())) else { return };
    let Ok(entries) = std::fs::read_dir(parent) else { return };
    let prefix = format!("{name}.partial-");
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let Some(rest) = file_name.to_str().and_then(|n| n.strip_prefix(&prefix)) else { continue };
        let pid = rest.split('-').next().and_then(|p| p.parse::<u32>().ok());
        let alive = pid.is_some_and(|p| p == std::process::id() || Path::new(&format!("/proc/{p}")).exists());
        if !alive {
            let _ = std::fs::remove_dir_all(entry.path());
        }
    }
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
type GetBinary = unsafe extern "C" fn(*mut c_void, *const u32, usize, *mut usize, *mut *const u8, usize) -> i32;
type SetBinary = unsafe extern "C" fn(*mut c_void, *const u32, usize, *const usize, *const *const u8, usize) -> i32;
type SetState = unsafe extern "C" fn(*mut c_void, *mut c_void) -> i32;

type Instantiate2 =
    unsafe extern "C" fn(*const c_char, i32, *const c_char, *const c_char, *const Callbacks2, i32, i32) -> *mut c_void;
type Setup2 = unsafe extern "C" fn(*mut c_void, i32, f64, f64, i32, f64) -> i32;
type GetReal2 = unsafe extern "C" fn(*mut c_void, *const u32, usize, *mut f64) -> i32;
type SetReal2 = unsafe extern "C" fn(*mut c_void, *const u32, usize, *const f64) -> i32;
type DoStep2 = unsafe extern "C" fn(*mut c_void, f64, f64, i32) -> i32;
type GetBooleanStatus2 = unsafe extern "C" fn(*mut c_void, i32, *mut i32) -> i32;
type GetRealStatus2 = unsafe extern "C" fn(*mut c_void, i32, *mut f64) -> i32;

/// `fmi2StatusKind` values.
const FMI2_LAST_SUCCESSFUL_TIME: i32 = 2;
const FMI2_TERMINATED: i32 = 3;
/// `fmi2Discard` / `fmi3Discard`.
const DISCARD: i32 = 2;

/// `fmi2CallbackFunctions`. The logger is variadic in C (printf style): it is the C shim
/// `lash_fmi2_logger` (c/fmi2_logger.c), which expands the message and passes it to
/// [`log_message`]; it is declared here with its five fixed arguments (only its address is used).
#[repr(C)]
struct Callbacks2 {
    logger: unsafe extern "C" fn(*mut c_void, *const c_char, i32, *const c_char, *const c_char),
    allocate_memory: unsafe extern "C" fn(usize, usize) -> *mut c_void,
    free_memory: unsafe extern "C" fn(*mut c_void),
    step_finished: Option<unsafe extern "C" fn(*mut c_void, i32)>,
    component_environment: *mut c_void,
}

unsafe extern "C" {
    fn calloc(count: usize, size: usize) -> *mut c_void;
    fn free(pointer: *mut c_void);
    /// The C shim's variadic logger (c/fmi2_logger.c).
    fn lash_fmi2_logger(
        env: *mut c_void,
        instance: *const c_char,
        status: i32,
        category: *const c_char,
        format: *const c_char,
    );
    /// Where the shim sends expanded messages.
    fn lash_fmi2_set_log_sink(sink: unsafe extern "C" fn(*mut c_void, i32, *const c_char, *const c_char));
}

/// Points the C shim at [`log_message`] (once per process).
fn fmi2_logger() -> unsafe extern "C" fn(*mut c_void, *const c_char, i32, *const c_char, *const c_char) {
    static SINK: std::sync::Once = std::sync::Once::new();
    // SAFETY: sets a function pointer in the shim before any FMU can call the logger.
    SINK.call_once(|| unsafe { lash_fmi2_set_log_sink(log_message) });
    lash_fmi2_logger
}

unsafe extern "C" fn allocate_memory(count: usize, size: usize) -> *mut c_void {
    // SAFETY: the C allocator; FMUs free with `free_memory`.
    unsafe { calloc(count, size) }
}

unsafe extern "C" fn free_memory(pointer: *mut c_void) {
    // SAFETY: a pointer from `allocate_memory` (or null).
    unsafe { free(pointer) }
}

/// The FMI 2.0 functions lash calls, resolved once.
struct Functions2 {
    free: Free,
    setup: Setup2,
    enter_init: Unary,
    exit_init: Unary,
    terminate: Unary,
    get: GetReal2,
    set: SetReal2,
    do_step: DoStep2,
    get_state: GetState,
    set_state: SetState,
    free_state: GetState,
    /// `fmi2GetBooleanStatus` (asks whether a discarded step means "terminate").
    boolean_status: Option<GetBooleanStatus2>,
    /// `fmi2GetRealStatus` (the last successful time of a discarded step).
    real_status: Option<GetRealStatus2>,
}

/// The version-specific side of an imported FMU.
enum Api {
    V3 {
        functions: Functions,
        /// Per variable (position = lash value reference), the FMU's own value reference.
        native: Vec<u32>,
        /// True when every native reference equals its position: calls pass through untranslated.
        identity: bool,
        /// Translated value references of one call (reused).
        scratch: Mutex<Vec<u32>>,
    },
    V2 {
        functions: Functions2,
        /// Per (regrouped) variable, its FMI 2.0 scalar value references.
        scalars: Vec<Vec<u32>>,
        /// Expanded value references of one call (reused).
        scratch: Mutex<Vec<u32>>,
        /// Kept alive for the instance's lifetime (the FMU may keep a pointer to it).
        _callbacks: Box<Callbacks2>,
    },
}

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

/// PythonFMU binaries embed the Python interpreter but do not link libpython: the host process
/// must provide its symbols (as a Python host such as fmpy does). lash loads it once, globally:
/// `LASH_LIBPYTHON` names the library, else the `python3` on the PATH says where its own is.
fn preload_libpython() -> Result<(), String> {
    static LIBPYTHON: std::sync::OnceLock<Result<libloading::os::unix::Library, String>> = std::sync::OnceLock::new();
    let loaded = LIBPYTHON.get_or_init(|| {
        let path = match std::env::var("LASH_LIBPYTHON") {
            Ok(p) => PathBuf::from(p),
            Err(_) => {
                let script = "import os, sysconfig as s; print(os.path.join(s.get_config_var('LIBDIR'), s.get_config_var('LDLIBRARY')))";
                let out = std::process::Command::new("python3")
                    .args(["-c", script])
                    .output()
                    .map_err(|e| format!("set LASH_LIBPYTHON, or put python3 on the PATH ({e})"))?;
                PathBuf::from(String::from_utf8_lossy(&out.stdout).trim())
            }
        };
        let flags = libloading::os::unix::RTLD_NOW | libloading::os::unix::RTLD_GLOBAL;
        // SAFETY: loading libpython runs no Python code; its symbols become visible to the FMU.
        unsafe { libloading::os::unix::Library::open(Some(&path), flags) }
            .map_err(|e| format!("{}: {}", path.display(), lash_core::error_chain(&e)))
    });
    loaded.as_ref().map(|_| ()).map_err(Clone::clone)
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

/// A typed getter of either standard; the values pointer is untyped (every `fmi3GetX` /
/// `fmi2GetX` has the same shape apart from the element type, and pointers share one ABI).
#[derive(Clone, Copy)]
enum RawGet {
    V3(unsafe extern "C" fn(*mut c_void, *const u32, usize, *mut c_void, usize) -> i32),
    V2(unsafe extern "C" fn(*mut c_void, *const u32, usize, *mut c_void) -> i32),
}

/// A typed setter of either standard (see [`RawGet`]).
#[derive(Clone, Copy)]
enum RawSet {
    V3(unsafe extern "C" fn(*mut c_void, *const u32, usize, *const c_void, usize) -> i32),
    V2(unsafe extern "C" fn(*mut c_void, *const u32, usize, *const c_void) -> i32),
}

/// One kind's getter and setter with their names (None: the FMU lacks the symbol).
type Accessors = (ValueKind, &'static str, Option<RawGet>, &'static str, Option<RawSet>);

/// Every kind's accessors, resolved once (a missing one is an error only if a variable of that
/// kind is read or written).
struct Typed {
    accessors: Vec<Accessors>,
}

impl Typed {
    fn get(&self, kind: ValueKind) -> Result<(&'static str, RawGet), SubsystemError> {
        let &(_, name, f, ..) = self.find(kind)?;
        f.map(|f| (name, f)).ok_or_else(|| SubsystemError::Other(format!("the FMU has no {name}")))
    }

    fn set(&self, kind: ValueKind) -> Result<(&'static str, RawSet), SubsystemError> {
        let &(.., name, f) = self.find(kind)?;
        f.map(|f| (name, f)).ok_or_else(|| SubsystemError::Other(format!("the FMU has no {name}")))
    }

    fn find(&self, kind: ValueKind) -> Result<&Accessors, SubsystemError> {
        self.accessors
            .iter()
            .find(|a| a.0 == kind)
            .ok_or_else(|| SubsystemError::Other(format!("{} variables are not read or written by lash", kind.name())))
    }
}

/// How one element of a numeric kind is stored in the C arrays of a typed call.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Native {
    F64,
    F32,
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    /// FMI 3.0 `fmi3Boolean` (C `bool`, one byte).
    Bool8,
}

impl Native {
    /// The C representation of `kind` in FMI 3.0 (`v3`) or FMI 2.0.
    fn of(kind: ValueKind, v3: bool) -> Option<Self> {
        Some(match kind {
            ValueKind::Float64 => Native::F64,
            ValueKind::Float32 => Native::F32,
            ValueKind::Int8 => Native::I8,
            ValueKind::UInt8 => Native::U8,
            ValueKind::Int16 => Native::I16,
            ValueKind::UInt16 => Native::U16,
            ValueKind::Int32 => Native::I32,
            ValueKind::UInt32 => Native::U32,
            ValueKind::Int64 => Native::I64,
            ValueKind::UInt64 => Native::U64,
            ValueKind::Boolean if v3 => Native::Bool8,
            // fmi2Boolean is a C int; FMI 2.0 enumerations are fmi2Integer.
            ValueKind::Boolean => Native::I32,
            ValueKind::Enumeration if v3 => Native::I64,
            ValueKind::Enumeration => Native::I32,
            ValueKind::String | ValueKind::Binary | ValueKind::Clock => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Native::F64 | Native::I64 | Native::U64 => 8,
            Native::F32 | Native::I32 | Native::U32 => 4,
            Native::I16 | Native::U16 => 2,
            Native::I8 | Native::U8 | Native::Bool8 => 1,
        }
    }

    /// The element at the start of `b` (native byte order), as f64.
    fn read(self, b: &[u8]) -> f64 {
        macro_rules! get {
            ($t:ty) => {
                <$t>::from_ne_bytes(b[..std::mem::size_of::<$t>()].try_into().expect("sized")) as f64
            };
        }
        match self {
            Native::F64 => get!(f64),
            Native::F32 => get!(f32),
            Native::I8 => get!(i8),
            Native::U8 => get!(u8),
            Native::I16 => get!(i16),
            Native::U16 => get!(u16),
            Native::I32 => get!(i32),
            Native::U32 => get!(u32),
            Native::I64 => get!(i64),
            Native::U64 => get!(u64),
            Native::Bool8 => f64::from(u8::from(b[0] != 0)),
        }
    }

    /// Writes `v` (already checked against the variable's kind) at the start of `b`.
    fn write(self, v: f64, b: &mut [u8]) {
        macro_rules! put {
            ($t:ty) => {
                b[..std::mem::size_of::<$t>()].copy_from_slice(&(v as $t).to_ne_bytes())
            };
        }
        match self {
            Native::F64 => put!(f64),
            Native::F32 => put!(f32),
            Native::I8 => put!(i8),
            Native::U8 => put!(u8),
            Native::I16 => put!(i16),
            Native::U16 => put!(u16),
            Native::I32 => put!(i32),
            Native::U32 => put!(u32),
            Native::I64 => put!(i64),
            Native::U64 => put!(u64),
            Native::Bool8 => b[0] = u8::from(v != 0.0),
        }
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
    api: Api,
    instance: *mut c_void,
    log: Box<Log>,
    time: Ticks,
    /// The experiment set up and not yet begun: initialization mode is entered on the first call
    /// that needs it, so every parameter value set after [`Subsystem::setup`] reaches the FMU in
    /// its Instantiated state (where FMI puts start values, and where fmpy and libcosim set them).
    experiment: Mutex<Option<(Ticks, Option<Ticks>)>>,
    /// Initialization mode has been entered (the per-call check, without the lock).
    begun: std::sync::atomic::AtomicBool,
    /// The FMU archive (or plugin library) it came from, named in every error.
    origin: PathBuf,
    /// Accessors of every type.
    typed: Typed,
    /// True when every variable is Float64: values pass through one batched call.
    all_float64: bool,
    /// Per variable, whether it is Float64 (a call naming only those takes the batched path).
    float64: Vec<bool>,
    /// Bytes of one typed call (reused).
    bytes: Mutex<Vec<u8>>,
    /// Native value references of one typed call (reused).
    vr_scratch: Mutex<Vec<u32>>,
    /// `fmi3EnterConfigurationMode` and `fmi3ExitConfigurationMode` (FMI 3.0, when present).
    configuration: Option<(Unary, Unary)>,
    /// `fmi3GetBinary` and `fmi3SetBinary` (FMI 3.0, when present).
    binary: Option<(GetBinary, SetBinary)>,
    /// Every FMU state taken, freed with the instance (FMI has no way to free one from a
    /// `SavedState` alone).
    states: Mutex<Vec<Arc<FmuState>>>,
    // Declared last: dropped after the instance is freed.
    _library: libloading::Library,
}

// SAFETY: the instance is only used through `&mut self` (one thread at a time), as FMI requires.
unsafe impl Send for ImportedFmu {}

/// Regroups FMI 2.0 scalars `base[1]`, `base[1,1]`, … into array variables, so the same master
/// code drives an FMU of either version. A run of consecutive scalars of one base (same causality,
/// variability, kind and unit) becomes an array only when its 1-based indices fill the array's box
/// exactly once each, spelled as [`Variable::element_name`] spells them; its elements are placed by
/// their indices (row-major), not by their order in the file. Anything else (0-based names, gaps,
/// `x[1, 2]`, a base that is also a variable's name) stays a scalar named exactly as spelled, so
/// every element name lash prints is the FMU's own name for that value. Returns the variables
/// (value reference = position) and each one's scalar refs.
fn regroup(scalars: &[Variable]) -> (Vec<Variable>, Vec<Vec<u32>>) {
    let taken: std::collections::HashSet<&str> = scalars.iter().map(|v| v.name.as_str()).collect();
    let mut vars: Vec<Variable> = Vec::new();
    let mut refs: Vec<Vec<u32>> = Vec::new();
    let mut i = 0;
    while i < scalars.len() {
        let first = &scalars[i];
        let mut run = 1;
        if let Some((base, index)) = lash_core::split_element_name(&first.name) {
            while let Some(next) = scalars.get(i + run) {
                let same = lash_core::split_element_name(&next.name)
                    .is_some_and(|(b, ix)| b == base && ix.len() == index.len())
                    && (next.causality, next.variability, next.kind, &next.unit)
                        == (first.causality, first.variability, first.kind, &first.unit);
                if !same {
                    break;
                }
                run += 1;
            }
            if !taken.contains(base)
                && let Some((array, order)) = array_of(base, &scalars[i..i + run])
            {
                vars.push(Variable { value_reference: vars.len() as u32, ..array });
                refs.push(order);
                i += run;
                continue;
            }
        }
        for v in &scalars[i..i + run] {
            let mut var = v.clone();
            var.value_reference = vars.len() as u32;
            if var.start.is_empty() {
                var.start = vec![0.0];
            }
            vars.push(var);
            refs.push(vec![v.value_reference]);
        }
        i += run;
    }
    (vars, refs)
}

/// The array variable `base` whose elements are `run` (same base, same number of indices), with
/// the elements' scalar refs in row-major order; `None` unless the indices fill the box exactly.
fn array_of(base: &str, run: &[Variable]) -> Option<(Variable, Vec<u32>)> {
    let indices: Vec<Vec<usize>> =
        run.iter().map(|v| lash_core::split_element_name(&v.name).map(|(_, ix)| ix)).collect::<Option<_>>()?;
    let mut shape = indices[0].clone();
    for ix in &indices {
        for (m, i) in shape.iter_mut().zip(ix) {
            *m = (*m).max(*i);
        }
    }
    if shape.iter().try_fold(1usize, |n, &d| n.checked_mul(d)) != Some(run.len()) {
        return None;
    }
    let mut array = Variable { name: base.to_string(), shape, start: vec![0.0; run.len()], ..run[0].clone() };
    let mut order = vec![None; run.len()];
    for (v, ix) in run.iter().zip(&indices) {
        let at = array.element_position(ix)?;
        if order[at].replace(v.value_reference).is_some() {
            return None; // an element named twice
        }
        array.start[at] = v.start.first().copied().unwrap_or(0.0);
    }
    Some((array, order.into_iter().collect::<Option<Vec<u32>>>()?))
}

/// A symbol of `library` by its NUL-less name, as a function pointer of type `$ty`; a missing
/// one is an error naming it.
macro_rules! symbol {
    ($library:expr, $name:literal, $ty:ty) => {{
        // SAFETY: the symbol has this signature in fmi3Functions.h / fmi2Functions.h.
        let s: libloading::Symbol<'_, $ty> = unsafe { $library.get(concat!($name, "\0").as_bytes()) }
            .map_err(|e| format!("missing symbol {}: {}", $name, lash_core::error_chain(&e)))?;
        *s
    }};
}

/// An FMI 3.0 library's functions resolved and one co-simulation instance made (null where
/// the FMU refused): value references renumbered to positions, the native ones kept.
/// `names`: the instance name, the instantiation token and the log environment.
fn instantiate_v3(
    library: &libloading::Library,
    description: &mut Description,
    resources_dir: &Path,
    (cname, token, env): (&CString, &CString, *mut c_void),
) -> Result<(Api, *mut c_void), String> {
    let functions = Functions {
        instantiate: symbol!(library, "fmi3InstantiateCoSimulation", Instantiate),
        free: symbol!(library, "fmi3FreeInstance", Free),
        enter_init: symbol!(library, "fmi3EnterInitializationMode", EnterInit),
        exit_init: symbol!(library, "fmi3ExitInitializationMode", Unary),
        terminate: symbol!(library, "fmi3Terminate", Unary),
        get: symbol!(library, "fmi3GetFloat64", GetF64),
        set: symbol!(library, "fmi3SetFloat64", SetF64),
        do_step: symbol!(library, "fmi3DoStep", DoStep),
        get_state: symbol!(library, "fmi3GetFMUState", GetState),
        set_state: symbol!(library, "fmi3SetFMUState", SetState),
        free_state: symbol!(library, "fmi3FreeFMUState", GetState),
    };
    let resources = CString::new(format!("{}/", resources_dir.display())).unwrap_or_default();
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
            env,
            Some(log_message),
            std::ptr::null(),
        )
    };
    let native: Vec<u32> = description.variables.iter().map(|v| v.value_reference).collect();
    let identity = native.iter().enumerate().all(|(i, &r)| r as usize == i);
    for (i, v) in description.variables.iter_mut().enumerate() {
        v.value_reference = i as u32;
    }
    Ok((Api::V3 { functions, native, identity, scratch: Mutex::new(Vec::new()) }, instance))
}

/// An FMI 2.0 library's functions resolved and one co-simulation instance made (null where
/// the FMU refused): scalar variables regrouped into arrays. `names` as for
/// [`instantiate_v3`].
fn instantiate_v2(
    library: &libloading::Library,
    description: &mut Description,
    resources_dir: &Path,
    (cname, token, env): (&CString, &CString, *mut c_void),
) -> Result<(Api, *mut c_void), String> {
    let instantiate = symbol!(library, "fmi2Instantiate", Instantiate2);
    let functions = Functions2 {
        free: symbol!(library, "fmi2FreeInstance", Free),
        setup: symbol!(library, "fmi2SetupExperiment", Setup2),
        enter_init: symbol!(library, "fmi2EnterInitializationMode", Unary),
        exit_init: symbol!(library, "fmi2ExitInitializationMode", Unary),
        terminate: symbol!(library, "fmi2Terminate", Unary),
        get: symbol!(library, "fmi2GetReal", GetReal2),
        set: symbol!(library, "fmi2SetReal", SetReal2),
        do_step: symbol!(library, "fmi2DoStep", DoStep2),
        get_state: symbol!(library, "fmi2GetFMUstate", GetState),
        set_state: symbol!(library, "fmi2SetFMUstate", SetState),
        free_state: symbol!(library, "fmi2FreeFMUstate", GetState),
        // SAFETY: the symbols have these signatures in fmi2Functions.h.
        boolean_status: unsafe { library.get::<GetBooleanStatus2>(b"fmi2GetBooleanStatus\0") }.ok().map(|s| *s),
        // SAFETY: as above.
        real_status: unsafe { library.get::<GetRealStatus2>(b"fmi2GetRealStatus\0") }.ok().map(|s| *s),
    };
    let callbacks = Box::new(Callbacks2 {
        logger: fmi2_logger(),
        allocate_memory,
        free_memory,
        step_finished: None,
        component_environment: env,
    });
    let resources = CString::new(format!("file://{}/", resources_dir.display())).unwrap_or_default();
    // SAFETY: valid C strings and callbacks that outlive the instance; fmi2CoSimulation = 1.
    let instance = unsafe { instantiate(cname.as_ptr(), 1, token.as_ptr(), resources.as_ptr(), &*callbacks, 0, 0) };
    let (variables, scalars) = regroup(&description.variables);
    description.dimension_refs = vec![Vec::new(); variables.len()];
    description.variables = variables;
    Ok((Api::V2 { functions, scalars, scratch: Mutex::new(Vec::new()), _callbacks: callbacks }, instance))
}

impl ImportedFmu {
    /// Imports `fmu` (FMI 3.0 or 2.0 co-simulation; unpacked into `cache` once) and
    /// instantiates it.
    pub fn open(fmu: &Path, cache: &Path, instance_name: &str) -> Result<Self, ImportError> {
        let mut imported = Self::open_unpacked(fmu, cache, instance_name).map_err(|e| match e {
            // The library sits in the cache: say which FMU it came from.
            ImportError::Library { path, message } => {
                ImportError::Library { path, message: format!("{message} (from {})", fmu.display()) }
            }
            other => other,
        })?;
        imported.origin = fmu.to_path_buf();
        // The checks every master applies to a subsystem, here once for `fmu check` and `run` alike.
        lash_core::check_variable_table(&imported.description.variables)
            .map_err(|m| ImportError::Description { path: fmu.to_path_buf(), message: m.to_string() })?;
        Ok(imported)
    }

    fn open_unpacked(fmu: &Path, cache: &Path, instance_name: &str) -> Result<Self, ImportError> {
        let dir = unpack(fmu, cache)?;
        let xml = std::fs::read_to_string(dir.join("modelDescription.xml")).map_err(|e| ImportError::Archive {
            path: fmu.to_path_buf(),
            message: format!("modelDescription.xml: {e}"),
        })?;
        let description = parse_description(&xml)
            .map_err(|m| ImportError::Description { path: fmu.to_path_buf(), message: lash_core::error_chain(&m) })?;
        let v3 = description.fmi_version.starts_with("3.");
        if !v3 && !description.fmi_version.starts_with("2.") {
            return Err(ImportError::Description {
                path: fmu.to_path_buf(),
                message: format!("fmiVersion {:?}: lash imports FMI 3.0 and 2.0", description.fmi_version),
            });
        }
        let platform = if v3 { "x86_64-linux" } else { "linux64" };
        let lib_path = dir.join("binaries").join(platform).join(format!("{}.so", description.model_identifier));
        // Only a regular file of the unpacked archive is loaded (the unpacker makes no links;
        // checked again here, without following one).
        let regular = std::fs::symlink_metadata(&lib_path).is_ok_and(|m| m.file_type().is_file());
        if !regular {
            let platforms: Vec<String> = std::fs::read_dir(dir.join("binaries"))
                .map(|r| r.flatten().map(|e| e.file_name().to_string_lossy().into_owned()).collect())
                .unwrap_or_default();
            return Err(ImportError::Library {
                path: lib_path,
                message: format!("no binary for {platform} in the FMU (it has: {platforms:?})"),
            });
        }
        let lerr = |m: String| ImportError::Library { path: lib_path.clone(), message: m };
        // SAFETY: loading a shared library runs its initialisers; an FMU's binary is trusted
        // code by the user's choice of FMU.
        if description.generation_tool.starts_with("PythonFMU") {
            preload_libpython().map_err(|m| lerr(format!("a PythonFMU binary needs libpython in the process: {m}")))?;
        }
        let library = unsafe { libloading::Library::new(&lib_path) }
            .map_err(|e| lerr(format!("cannot load: {}", lash_core::error_chain(&e))))?;
        Self::with_library(description, &lib_path, library, &dir.join("resources"), instance_name)
    }

    /// A plugin: a shared library built with [`crate::export_plugin!`] (the FMI 3.0 functions
    /// plus `lash_plugin_model_description`, which returns its `modelDescription.xml`), loaded
    /// without an archive. Errors name the library and the cause.
    pub fn open_plugin(library_path: &Path, instance_name: &str) -> Result<Self, ImportError> {
        let lerr = |m: String| ImportError::Library { path: library_path.to_path_buf(), message: m };
        if !library_path.is_file() {
            return Err(lerr("no such file (build the plugin crate first: cargo build --release)".into()));
        }
        // SAFETY: loading a shared library runs its initialisers; a plugin is trusted code by the
        // user's choice.
        let library = unsafe { libloading::Library::new(library_path) }
            .map_err(|e| lerr(format!("cannot load: {}", lash_core::error_chain(&e))))?;
        // SAFETY: `export_plugin!` defines the symbol with this signature.
        let describe: libloading::Symbol<'_, unsafe extern "C" fn() -> *const c_char> =
            unsafe { library.get(b"lash_plugin_model_description\0") }.map_err(|e| {
                lerr(format!(
                    "not a lash plugin (missing symbol lash_plugin_model_description: {})",
                    lash_core::error_chain(&e)
                ))
            })?;
        // SAFETY: the function returns a static NUL-terminated string or null.
        let text = unsafe { describe() };
        if text.is_null() {
            return Err(lerr(
                "lash_plugin_model_description returned null (the plugin could not build its model)".into(),
            ));
        }
        // SAFETY: non-null, NUL-terminated, static.
        let xml = unsafe { CStr::from_ptr(text) }.to_string_lossy().into_owned();
        let description = parse_description(&xml).map_err(|m| ImportError::Description {
            path: library_path.to_path_buf(),
            message: lash_core::error_chain(&m),
        })?;
        if !description.fmi_version.starts_with("3.") {
            return Err(lerr(format!("plugin description has fmiVersion {:?}, expected 3.0", description.fmi_version)));
        }
        let resources = library_path.parent().unwrap_or(Path::new(".")).to_path_buf();
        Self::with_library(description, library_path, library, &resources, instance_name)
    }

    /// Resolves the functions of a loaded library and instantiates it.
    fn with_library(
        mut description: Description,
        lib_path: &Path,
        library: libloading::Library,
        resources_dir: &Path,
        instance_name: &str,
    ) -> Result<Self, ImportError> {
        let v3 = description.fmi_version.starts_with("3.");
        let lerr = |m: String| ImportError::Library { path: lib_path.to_path_buf(), message: m };
        let log: Box<Log> = Box::new(Mutex::new(Vec::new()));
        let cname = CString::new(instance_name).unwrap_or_default();
        let token = CString::new(description.token.clone()).unwrap_or_default();
        let env = &*log as *const Log as *mut c_void;
        let names = (&cname, &token, env);
        let (api, instance, call) = if v3 {
            let (api, instance) = instantiate_v3(&library, &mut description, resources_dir, names).map_err(lerr)?;
            (api, instance, "fmi3InstantiateCoSimulation")
        } else {
            let (api, instance) = instantiate_v2(&library, &mut description, resources_dir, names).map_err(lerr)?;
            (api, instance, "fmi2Instantiate")
        };
        let typed = Self::resolve_typed(&library, v3);
        let configuration = if v3 {
            // SAFETY: the symbols have the `Unary` signature in fmi3Functions.h.
            let enter = unsafe { library.get::<Unary>(b"fmi3EnterConfigurationMode\0") }.ok().map(|s| *s);
            // SAFETY: as above.
            let exit = unsafe { library.get::<Unary>(b"fmi3ExitConfigurationMode\0") }.ok().map(|s| *s);
            enter.zip(exit)
        } else {
            None
        };
        let binary = if v3 {
            // SAFETY: the symbols have these signatures in fmi3Functions.h.
            let get = unsafe { library.get::<GetBinary>(b"fmi3GetBinary\0") }.ok().map(|s| *s);
            // SAFETY: as above.
            let set = unsafe { library.get::<SetBinary>(b"fmi3SetBinary\0") }.ok().map(|s| *s);
            get.zip(set)
        } else {
            None
        };
        let float64: Vec<bool> = description.variables.iter().map(|v| v.kind == ValueKind::Float64).collect();
        let all_float64 = float64.iter().all(|&f| f);
        if instance.is_null() {
            let messages = log.lock().map(|l| l.join("; ")).unwrap_or_default();
            let messages = if messages.is_empty() {
                "the FMU logged nothing (a token/GUID that differs from its binary's, or a model that cannot start)"
                    .into()
            } else {
                messages
            };
            return Err(lerr(format!("{call} failed: {messages}")));
        }
        Ok(Self {
            name: instance_name.to_string(),
            description,
            api,
            instance,
            log,
            time: Ticks::ZERO,
            experiment: Mutex::new(None),
            begun: std::sync::atomic::AtomicBool::new(false),
            origin: lib_path.to_path_buf(),
            typed,
            all_float64,
            float64,
            bytes: Mutex::new(Vec::new()),
            vr_scratch: Mutex::new(Vec::new()),
            configuration,
            binary,
            states: Mutex::new(Vec::new()),
            _library: library,
        })
    }

    /// The parsed model description, as lash sees it: value references renumbered to positions
    /// (FMI 2.0: arrays regrouped); [`ImportedFmu::native_value_reference`] gives the FMU's own.
    pub fn description(&self) -> &Description {
        &self.description
    }

    /// The FMI version imported ("3.0", "2.0").
    pub fn fmi_version(&self) -> &str {
        &self.description.fmi_version
    }

    /// Enters initialization mode once the experiment is set up, if it has not been entered yet
    /// (every call that reads values checks: one load once it has).
    #[inline]
    fn enter_initialization(&self) -> Result<(), SubsystemError> {
        if self.begun.load(std::sync::atomic::Ordering::Relaxed) {
            return Ok(());
        }
        self.begin()
    }

    /// The first entry into initialization mode (see `enter_initialization`).
    #[cold]
    fn begin(&self) -> Result<(), SubsystemError> {
        use std::sync::atomic::Ordering::Relaxed;
        let Some((start, stop)) = self.experiment.lock().unwrap_or_else(|e| e.into_inner()).take() else {
            return Ok(());
        };
        self.begun.store(true, Relaxed);
        let (has_stop, stop) = (stop.is_some(), stop.map_or(0.0, Ticks::seconds));
        match &self.api {
            Api::V3 { functions: f, .. } => {
                // SAFETY: a live instance.
                let s = unsafe { (f.enter_init)(self.instance, false, 0.0, start.seconds(), has_stop, stop) };
                self.check("fmi3EnterInitializationMode", s)
            }
            Api::V2 { functions: f, .. } => {
                // SAFETY: a live instance.
                let s = unsafe { (f.enter_init)(self.instance) };
                self.check("fmi2EnterInitializationMode", s)
            }
        }
    }

    fn check(&self, call: &str, status: i32) -> Result<(), SubsystemError> {
        if status <= 1 {
            return Ok(());
        }
        let messages = self.log.lock().map(|mut l| std::mem::take(&mut *l).join("; ")).unwrap_or_default();
        Err(SubsystemError::Other(format!(
            "{} ({}): {call} returned status {status}: {messages}",
            self.name,
            self.origin.display()
        )))
    }

    /// FMI 3.0: the FMU's own value references of `refs` (lash's are positions), into the scratch
    /// buffer, or `refs` unchanged when the two numberings agree; calls `f` with them.
    fn with_native<R>(
        native: &[u32],
        identity: bool,
        scratch: &Mutex<Vec<u32>>,
        refs: &[ValueReference],
        f: impl FnOnce(&[u32]) -> R,
    ) -> Result<R, SubsystemError> {
        if let Some(&bad) = refs.iter().find(|&&r| r as usize >= native.len()) {
            return Err(SubsystemError::UnknownValueReference(bad));
        }
        if identity {
            return Ok(f(refs));
        }
        let mut buffer = scratch.lock().map_err(|_| SubsystemError::Other("importer scratch poisoned".into()))?;
        buffer.clear();
        buffer.extend(refs.iter().map(|&r| native[r as usize]));
        Ok(f(&buffer))
    }

    /// The FMU's own value reference of lash's variable `vr` (FMI 2.0: of its first scalar).
    pub fn native_value_reference(&self, vr: ValueReference) -> Option<u32> {
        match &self.api {
            Api::V3 { native, .. } => native.get(vr as usize).copied(),
            Api::V2 { scalars, .. } => scalars.get(vr as usize).and_then(|s| s.first().copied()),
        }
    }

    /// Every kind's accessors, by their standard names.
    fn resolve_typed(library: &libloading::Library, v3: bool) -> Typed {
        type G3 = unsafe extern "C" fn(*mut c_void, *const u32, usize, *mut c_void, usize) -> i32;
        type S3 = unsafe extern "C" fn(*mut c_void, *const u32, usize, *const c_void, usize) -> i32;
        type G2 = unsafe extern "C" fn(*mut c_void, *const u32, usize, *mut c_void) -> i32;
        type S2 = unsafe extern "C" fn(*mut c_void, *const u32, usize, *const c_void) -> i32;
        let kinds3: [(ValueKind, &'static str, &'static str); 13] = [
            (ValueKind::Float64, "fmi3GetFloat64", "fmi3SetFloat64"),
            (ValueKind::Float32, "fmi3GetFloat32", "fmi3SetFloat32"),
            (ValueKind::Int8, "fmi3GetInt8", "fmi3SetInt8"),
            (ValueKind::UInt8, "fmi3GetUInt8", "fmi3SetUInt8"),
            (ValueKind::Int16, "fmi3GetInt16", "fmi3SetInt16"),
            (ValueKind::UInt16, "fmi3GetUInt16", "fmi3SetUInt16"),
            (ValueKind::Int32, "fmi3GetInt32", "fmi3SetInt32"),
            (ValueKind::UInt32, "fmi3GetUInt32", "fmi3SetUInt32"),
            (ValueKind::Int64, "fmi3GetInt64", "fmi3SetInt64"),
            (ValueKind::UInt64, "fmi3GetUInt64", "fmi3SetUInt64"),
            (ValueKind::Boolean, "fmi3GetBoolean", "fmi3SetBoolean"),
            (ValueKind::Enumeration, "fmi3GetInt64", "fmi3SetInt64"),
            (ValueKind::String, "fmi3GetString", "fmi3SetString"),
        ];
        let kinds2: [(ValueKind, &'static str, &'static str); 5] = [
            (ValueKind::Float64, "fmi2GetReal", "fmi2SetReal"),
            (ValueKind::Int32, "fmi2GetInteger", "fmi2SetInteger"),
            (ValueKind::Boolean, "fmi2GetBoolean", "fmi2SetBoolean"),
            (ValueKind::Enumeration, "fmi2GetInteger", "fmi2SetInteger"),
            (ValueKind::String, "fmi2GetString", "fmi2SetString"),
        ];
        let symbol = |name: &str| -> Option<*const c_void> {
            let name = format!("{name}\0");
            // SAFETY: only the address is taken here; it is called with the signature of the
            // standard's header for that name.
            unsafe { library.get::<*const c_void>(name.as_bytes()) }.ok().map(|s| *s)
        };
        let accessors = if v3 {
            kinds3
                .iter()
                .map(|&(kind, get, set)| {
                    // SAFETY: the fmi3 typed accessors have the G3/S3 shapes (values pointer untyped).
                    let g = symbol(get).map(|p| RawGet::V3(unsafe { std::mem::transmute::<*const c_void, G3>(p) }));
                    // SAFETY: as above.
                    let s = symbol(set).map(|p| RawSet::V3(unsafe { std::mem::transmute::<*const c_void, S3>(p) }));
                    (kind, get, g, set, s)
                })
                .collect()
        } else {
            kinds2
                .iter()
                .map(|&(kind, get, set)| {
                    // SAFETY: the fmi2 typed accessors have the G2/S2 shapes (values pointer untyped).
                    let g = symbol(get).map(|p| RawGet::V2(unsafe { std::mem::transmute::<*const c_void, G2>(p) }));
                    // SAFETY: as above.
                    let s = symbol(set).map(|p| RawSet::V2(unsafe { std::mem::transmute::<*const c_void, S2>(p) }));
                    (kind, get, g, set, s)
                })
                .collect()
        };
        Typed { accessors }
    }

    fn variable(&self, vr: ValueReference) -> Result<&Variable, SubsystemError> {
        lash_core::subsystem::variable(&self.description.variables, vr).ok_or(SubsystemError::UnknownValueReference(vr))
    }

    /// True when every referenced variable is Float64 (unknown references are left to the
    /// batched call, which reports them).
    fn only_float64(&self, refs: &[ValueReference]) -> bool {
        self.all_float64 || refs.iter().all(|&r| self.float64.get(r as usize).is_none_or(|&f| f))
    }

    /// Reads variables of any numeric kind, one typed call each (the path of FMUs that are not
    /// all Float64).
    fn get_numeric(&self, refs: &[ValueReference], values: &mut [f64]) -> Result<(), SubsystemError> {
        let poisoned = || SubsystemError::Other("importer scratch poisoned".into());
        let mut vrs = self.vr_scratch.lock().map_err(|_| poisoned())?;
        let mut bytes = self.bytes.lock().map_err(|_| poisoned())?;
        let (mut i, mut at) = (0, 0);
        // Runs of references of one kind go through one typed call.
        while i < refs.len() {
            let kind = self.variable(refs[i])?.kind;
            let native = self.native_of(refs[i])?;
            vrs.clear();
            let mut n = 0;
            let mut j = i;
            while j < refs.len() && self.variable(refs[j])?.kind == kind {
                n += self.variable(refs[j])?.len();
                self.push_native_refs(refs[j], &mut vrs)?;
                j += 1;
            }
            let count = values.len();
            let out = values
                .get_mut(at..at + n)
                .ok_or_else(|| SubsystemError::BadArguments(format!("{count} values for more elements")))?;
            bytes.clear();
            bytes.resize(n * native.size(), 0);
            let (call, get) = self.typed.get(kind)?;
            let status = match get {
                // SAFETY: a live instance; `bytes` holds n elements of the kind's C type.
                RawGet::V3(f) => unsafe { f(self.instance, vrs.as_ptr(), vrs.len(), bytes.as_mut_ptr().cast(), n) },
                // SAFETY: as above (FMI 2.0: one scalar per element, vrs.len() == n).
                RawGet::V2(f) => unsafe { f(self.instance, vrs.as_ptr(), vrs.len(), bytes.as_mut_ptr().cast()) },
            };
            self.check(call, status)?;
            for (k, o) in out.iter_mut().enumerate() {
                *o = native.read(&bytes[k * native.size()..]);
            }
            at += n;
            i = j;
        }
        if at != values.len() {
            return Err(SubsystemError::BadArguments(format!("{} values for {at} elements", values.len())));
        }
        Ok(())
    }

    /// The C representation of variable `vr`'s values, or why it has none.
    fn native_of(&self, vr: ValueReference) -> Result<Native, SubsystemError> {
        let var = self.variable(vr)?;
        Native::of(var.kind, matches!(self.api, Api::V3 { .. })).ok_or_else(|| SubsystemError::BadValue {
            name: var.name.clone(),
            problem: format!("is a {} variable, not a number", var.kind.name()),
        })
    }

    /// Appends the FMU's own value references of `vr` (FMI 2.0: one per element) to `out`.
    fn push_native_refs(&self, vr: ValueReference, out: &mut Vec<u32>) -> Result<(), SubsystemError> {
        match &self.api {
            Api::V3 { native, .. } => {
                out.push(*native.get(vr as usize).ok_or(SubsystemError::UnknownValueReference(vr))?)
            }
            Api::V2 { scalars, .. } => {
                out.extend_from_slice(scalars.get(vr as usize).ok_or(SubsystemError::UnknownValueReference(vr))?)
            }
        }
        Ok(())
    }

    /// Writes variables of any numeric kind, each value checked against its kind.
    fn set_numeric(&mut self, refs: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError> {
        let mut at = 0;
        for &r in refs {
            let var = self.variable(r)?;
            let native =
                Native::of(var.kind, matches!(self.api, Api::V3 { .. })).ok_or_else(|| SubsystemError::BadValue {
                    name: var.name.clone(),
                    problem: format!("is a {} variable, not a number", var.kind.name()),
                })?;
            let n = var.len();
            let given = values
                .get(at..at + n)
                .ok_or_else(|| SubsystemError::BadArguments(format!("{} values for more elements", values.len())))?;
            let mut bytes = std::mem::take(
                &mut *self.bytes.lock().map_err(|_| SubsystemError::Other("importer scratch poisoned".into()))?,
            );
            bytes.clear();
            bytes.resize(n * native.size(), 0);
            for (k, &v) in given.iter().enumerate() {
                var.kind
                    .check(v)
                    .map_err(|p| SubsystemError::BadValue { name: var.name.clone(), problem: p.to_string() })?;
                native.write(v, &mut bytes[k * native.size()..]);
            }
            let mut vrs = Vec::with_capacity(n);
            self.push_native_refs(r, &mut vrs)?;
            let (call, set) = self.typed.set(var.kind)?;
            let status = match set {
                // SAFETY: a live instance; `bytes` holds n elements of the kind's C type.
                RawSet::V3(f) => unsafe { f(self.instance, vrs.as_ptr(), vrs.len(), bytes.as_ptr().cast(), n) },
                // SAFETY: as above.
                RawSet::V2(f) => unsafe { f(self.instance, vrs.as_ptr(), vrs.len(), bytes.as_ptr().cast()) },
            };
            if let Ok(mut scratch) = self.bytes.lock() {
                *scratch = bytes;
            }
            self.check(call, status)?;
            at += n;
        }
        if at != values.len() {
            return Err(SubsystemError::BadArguments(format!("{} values for {at} elements", values.len())));
        }
        Ok(())
    }

    /// A scalar Binary variable's native reference, or why not.
    fn binary_ref(&self, vr: ValueReference) -> Result<u32, SubsystemError> {
        let var = self.variable(vr)?;
        if var.kind != ValueKind::Binary || var.len() != 1 {
            return Err(SubsystemError::BadValue {
                name: var.name.clone(),
                problem: format!(
                    "is a {} variable with {} element(s), not a Binary scalar",
                    var.kind.name(),
                    var.len()
                ),
            });
        }
        self.native_value_reference(vr).ok_or(SubsystemError::UnknownValueReference(vr))
    }

    /// A scalar String variable's native reference, or why not.
    fn string_ref(&self, vr: ValueReference) -> Result<u32, SubsystemError> {
        let var = self.variable(vr)?;
        if var.kind != ValueKind::String || var.len() != 1 {
            return Err(SubsystemError::BadValue {
                name: var.name.clone(),
                problem: format!(
                    "is a {} variable with {} element(s), not a String scalar",
                    var.kind.name(),
                    var.len()
                ),
            });
        }
        self.native_value_reference(vr).ok_or(SubsystemError::UnknownValueReference(vr))
    }

    /// FMI 2.0: the scalar value references of `refs`, into the scratch buffer; calls `f` with
    /// them. Unknown references, or a value count other than the scalars', are errors.
    fn with_scalars<R>(
        scalars: &[Vec<u32>],
        scratch: &Mutex<Vec<u32>>,
        refs: &[ValueReference],
        values: usize,
        f: impl FnOnce(&[u32]) -> R,
    ) -> Result<R, SubsystemError> {
        let mut buffer = scratch.lock().map_err(|_| SubsystemError::Other("importer scratch poisoned".into()))?;
        buffer.clear();
        for &r in refs {
            buffer.extend_from_slice(scalars.get(r as usize).ok_or(SubsystemError::UnknownValueReference(r))?);
        }
        if buffer.len() != values {
            return Err(SubsystemError::BadArguments(format!("{values} values for {} elements", buffer.len())));
        }
        Ok(f(&buffer))
    }
}

impl Drop for ImportedFmu {
    fn drop(&mut self) {
        let states = self.states.get_mut().map(std::mem::take).unwrap_or_default();
        let (free_state, free) = match &self.api {
            Api::V3 { functions: f, .. } => (f.free_state, f.free),
            Api::V2 { functions, .. } => (functions.free_state, functions.free),
        };
        for s in states {
            let mut p = s.0;
            // SAFETY: a state from this instance, freed once, before the instance.
            unsafe { free_state(self.instance, &mut p) };
        }
        // SAFETY: the instance from instantiate, freed once; the library is still loaded.
        unsafe { free(self.instance) };
    }
}

impl Subsystem for ImportedFmu {
    fn name(&self) -> &str {
        &self.name
    }

    fn variables(&self) -> &[Variable] {
        &self.description.variables
    }

    /// FMI 2.0: `fmi2SetupExperiment`. Initialization mode is entered later, by the first call
    /// that needs it (see `enter_initialization`).
    fn setup(&mut self, start: Ticks, stop: Option<Ticks>) -> Result<(), SubsystemError> {
        self.time = start;
        if let Api::V2 { functions: f, .. } = &self.api {
            let (has_stop, stop) = (stop.is_some(), stop.map_or(0.0, Ticks::seconds));
            // SAFETY: a live instance.
            let s = unsafe { (f.setup)(self.instance, 0, 0.0, start.seconds(), i32::from(has_stop), stop) };
            self.check("fmi2SetupExperiment", s)?;
        }
        *self.experiment.lock().unwrap_or_else(|e| e.into_inner()) = Some((start, stop));
        Ok(())
    }

    fn initialize(&mut self) -> Result<(), SubsystemError> {
        self.enter_initialization()?;
        let (exit, call) = match &self.api {
            Api::V3 { functions: f, .. } => (f.exit_init, "fmi3ExitInitializationMode"),
            Api::V2 { functions, .. } => (functions.exit_init, "fmi2ExitInitializationMode"),
        };
        // SAFETY: a live instance.
        let s = unsafe { exit(self.instance) };
        self.check(call, s)
    }

    fn set_f64(&mut self, refs: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError> {
        if !self.only_float64(refs) {
            return self.set_numeric(refs, values);
        }
        match &self.api {
            Api::V3 { functions: f, native, identity, scratch } => {
                let instance = self.instance;
                let s = Self::with_native(native, *identity, scratch, refs, |vrs| {
                    // SAFETY: a live instance; slices with their lengths.
                    unsafe { (f.set)(instance, vrs.as_ptr(), vrs.len(), values.as_ptr(), values.len()) }
                })?;
                self.check("fmi3SetFloat64", s)
            }
            Api::V2 { functions: f, scalars, scratch, .. } => {
                let instance = self.instance;
                let s = Self::with_scalars(scalars, scratch, refs, values.len(), |vrs| {
                    // SAFETY: a live instance; equal lengths checked.
                    unsafe { (f.set)(instance, vrs.as_ptr(), vrs.len(), values.as_ptr()) }
                })?;
                self.check("fmi2SetReal", s)
            }
        }
    }

    fn get_f64(&self, refs: &[ValueReference], values: &mut [f64]) -> Result<(), SubsystemError> {
        self.enter_initialization()?;
        if !self.only_float64(refs) {
            return self.get_numeric(refs, values);
        }
        match &self.api {
            Api::V3 { functions: f, native, identity, scratch } => {
                let n = values.len();
                let s = Self::with_native(native, *identity, scratch, refs, |vrs| {
                    // SAFETY: a live instance; slices with their lengths.
                    unsafe { (f.get)(self.instance, vrs.as_ptr(), vrs.len(), values.as_mut_ptr(), n) }
                })?;
                self.check("fmi3GetFloat64", s)
            }
            Api::V2 { functions: f, scalars, scratch, .. } => {
                let n = values.len();
                let s = Self::with_scalars(scalars, scratch, refs, n, |vrs| {
                    // SAFETY: a live instance; equal lengths checked.
                    unsafe { (f.get)(self.instance, vrs.as_ptr(), vrs.len(), values.as_mut_ptr()) }
                })?;
                self.check("fmi2GetReal", s)
            }
        }
    }

    fn do_step(&mut self, t: Ticks, h: Ticks) -> Result<StepOutcome, SubsystemError> {
        let end = Ticks(t.0 + h.0);
        // A time the FMU reports, kept inside the step (an FMU's float may land a tick off).
        let at = |seconds: f64| Ticks::from_seconds(seconds).map_or(t, |r| Ticks(r.0.clamp(t.0, end.0)));
        match &self.api {
            Api::V3 { functions: f, .. } => {
                let (mut event, mut terminate, mut early, mut last) = (false, false, false, 0.0);
                // SAFETY: a live instance; output pointers to locals.
                let s = unsafe {
                    (f.do_step)(
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
                if terminate && s <= DISCARD {
                    self.time = if early || s == DISCARD { at(last) } else { end };
                    return Ok(StepOutcome::Terminate { reached: self.time });
                }
                self.check("fmi3DoStep", s)?;
                if early {
                    self.time = at(last);
                    return Ok(StepOutcome::EarlyReturn { reached: self.time });
                }
                self.time = end;
                Ok(StepOutcome::Completed)
            }
            Api::V2 { functions: f, .. } => {
                // SAFETY: a live instance.
                let s = unsafe { (f.do_step)(self.instance, t.seconds(), h.seconds(), 1) };
                if s == DISCARD
                    && let Some(status) = f.boolean_status
                {
                    let mut terminated = 0;
                    // SAFETY: a live instance, a pointer to a local.
                    let ok = unsafe { status(self.instance, FMI2_TERMINATED, &mut terminated) } <= 1;
                    if ok && terminated != 0 {
                        let mut last = t.seconds();
                        if let Some(real) = f.real_status {
                            // SAFETY: as above.
                            unsafe { real(self.instance, FMI2_LAST_SUCCESSFUL_TIME, &mut last) };
                        }
                        self.time = at(last);
                        return Ok(StepOutcome::Terminate { reached: self.time });
                    }
                }
                self.check("fmi2DoStep", s)?;
                self.time = end;
                Ok(StepOutcome::Completed)
            }
        }
    }

    fn time(&self) -> Ticks {
        self.time
    }

    fn save_state(&self) -> Result<SavedState, SubsystemError> {
        self.enter_initialization()?;
        let (get_state, call) = match &self.api {
            Api::V3 { functions: f, .. } => (f.get_state, "fmi3GetFMUState"),
            Api::V2 { functions, .. } => (functions.get_state, "fmi2GetFMUstate"),
        };
        let mut p = std::ptr::null_mut();
        // SAFETY: a live instance; a fresh state pointer.
        let s = unsafe { get_state(self.instance, &mut p) };
        self.check(call, s)?;
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
        let (set_state, call) = match &self.api {
            Api::V3 { functions: f, .. } => (f.set_state, "fmi3SetFMUState"),
            Api::V2 { functions, .. } => (functions.set_state, "fmi2SetFMUstate"),
        };
        // SAFETY: a state from this instance.
        let s = unsafe { set_state(self.instance, fmu_state.0) };
        self.check(call, s)?;
        self.time = *time;
        Ok(())
    }

    fn configure(&mut self, refs: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError> {
        let mut at = 0;
        let mut given: Vec<(u32, f64)> = Vec::new();
        for &r in refs {
            let var = self.variable(r)?;
            if var.causality != Causality::StructuralParameter || var.len() != 1 {
                return Err(SubsystemError::BadValue {
                    name: var.name.clone(),
                    problem: "is not a scalar structural parameter".into(),
                });
            }
            let native = self.native_value_reference(r).ok_or(SubsystemError::UnknownValueReference(r))?;
            given.push((native, *values.get(at).ok_or_else(|| SubsystemError::BadArguments("too few values".into()))?));
            at += 1;
        }
        if at != values.len() {
            return Err(SubsystemError::BadArguments(format!("{} values for {at} elements", values.len())));
        }
        let (enter, exit) = self
            .configuration
            .ok_or_else(|| SubsystemError::Other(format!("{}: the FMU has no configuration mode", self.name)))?;
        // SAFETY: a live, instantiated instance.
        let s = unsafe { enter(self.instance) };
        self.check("fmi3EnterConfigurationMode", s)?;
        let set = self.set_numeric(refs, values);
        // SAFETY: as above; configuration mode is left whatever the setting did.
        let s = unsafe { exit(self.instance) };
        set?;
        self.check("fmi3ExitConfigurationMode", s)?;
        // The arrays sized by these parameters take their new sizes (others keep theirs).
        let current: Vec<(u32, Option<f64>)> = self
            .description
            .variables
            .iter()
            .enumerate()
            .map(|(i, v)| (self.native_value_reference(i as u32).unwrap_or(u32::MAX), v.start.first().copied()))
            .collect();
        let value_of = |vr: u32| {
            given
                .iter()
                .find(|(r, _)| *r == vr)
                .map(|(_, v)| *v)
                .or_else(|| current.iter().find(|(r, _)| *r == vr).and_then(|(_, s)| *s))
        };
        let Description { variables, dimension_refs, .. } = &mut self.description;
        resize(variables, dimension_refs, value_of).map_err(SubsystemError::Other)?;
        for (vr, value) in refs.iter().zip(values) {
            if let Some(v) = self.description.variables.get_mut(*vr as usize) {
                v.start = vec![*value];
            }
        }
        Ok(())
    }

    fn get_string(&self, vr: ValueReference) -> Result<String, SubsystemError> {
        self.enter_initialization()?;
        let native = self.string_ref(vr)?;
        let (call, get) = self.typed.get(ValueKind::String)?;
        let mut text: *const c_char = std::ptr::null();
        let out = (&mut text as *mut *const c_char).cast::<c_void>();
        let status = match get {
            // SAFETY: a live instance; one string pointer written by the FMU.
            RawGet::V3(f) => unsafe { f(self.instance, &native, 1, out, 1) },
            // SAFETY: as above.
            RawGet::V2(f) => unsafe { f(self.instance, &native, 1, out) },
        };
        self.check(call, status)?;
        if text.is_null() {
            return Err(SubsystemError::Other(format!("{}: {call} returned a null string", self.name)));
        }
        // SAFETY: a NUL-terminated string owned by the FMU, valid until its next call.
        Ok(unsafe { CStr::from_ptr(text) }.to_string_lossy().into_owned())
    }

    fn set_string(&mut self, vr: ValueReference, value: &str) -> Result<(), SubsystemError> {
        let native = self.string_ref(vr)?;
        let text = CString::new(value).map_err(|_| SubsystemError::BadValue {
            name: self.variable(vr).map(|v| v.name.clone()).unwrap_or_default(),
            problem: "a string with a NUL character".into(),
        })?;
        let (call, set) = self.typed.set(ValueKind::String)?;
        let pointer = text.as_ptr();
        let values = (&pointer as *const *const c_char).cast::<c_void>();
        let status = match set {
            // SAFETY: a live instance; one string that outlives the call.
            RawSet::V3(f) => unsafe { f(self.instance, &native, 1, values, 1) },
            // SAFETY: as above.
            RawSet::V2(f) => unsafe { f(self.instance, &native, 1, values) },
        };
        self.check(call, status)
    }

    fn get_binary(&self, vr: ValueReference) -> Result<Vec<u8>, SubsystemError> {
        self.enter_initialization()?;
        let native = self.binary_ref(vr)?;
        let (get, _) =
            self.binary.ok_or_else(|| SubsystemError::Other(format!("{}: the FMU has no fmi3GetBinary", self.name)))?;
        let (mut size, mut data): (usize, *const u8) = (0, std::ptr::null());
        // SAFETY: a live instance; one size and one pointer written by the FMU.
        let status = unsafe { get(self.instance, &native, 1, &mut size, &mut data, 1) };
        self.check("fmi3GetBinary", status)?;
        if data.is_null() {
            return if size == 0 {
                Ok(Vec::new())
            } else {
                Err(SubsystemError::Other(format!("{}: fmi3GetBinary returned a null pointer", self.name)))
            };
        }
        if size > crate::import::MAX_ELEMENTS {
            return Err(SubsystemError::Other(format!("{}: fmi3GetBinary returned {size} bytes", self.name)));
        }
        // SAFETY: `size` bytes owned by the FMU, valid until its next call.
        Ok(unsafe { std::slice::from_raw_parts(data, size) }.to_vec())
    }

    fn set_binary(&mut self, vr: ValueReference, value: &[u8]) -> Result<(), SubsystemError> {
        let native = self.binary_ref(vr)?;
        let (_, set) =
            self.binary.ok_or_else(|| SubsystemError::Other(format!("{}: the FMU has no fmi3SetBinary", self.name)))?;
        let (size, data) = (value.len(), value.as_ptr());
        // SAFETY: a live instance; one value of `size` bytes that outlives the call.
        let status = unsafe { set(self.instance, &native, 1, &size, &data, 1) };
        self.check("fmi3SetBinary", status)
    }

    fn terminate(&mut self) -> Result<(), SubsystemError> {
        let (terminate, call) = match &self.api {
            Api::V3 { functions: f, .. } => (f.terminate, "fmi3Terminate"),
            Api::V2 { functions, .. } => (functions.terminate, "fmi2Terminate"),
        };
        // SAFETY: a live instance.
        let s = unsafe { terminate(self.instance) };
        self.check(call, s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scalar(name: &str, vr: u32, causality: Causality) -> Variable {
        Variable {
            name: name.into(),
            value_reference: vr,
            causality,
            variability: Variability::Continuous,
            unit: String::new(),
            description: String::new(),
            shape: Vec::new(),
            start: vec![vr as f64],
            kind: ValueKind::Float64,
        }
    }

    #[test]
    fn fmi3_aliases_are_further_names_of_one_value_reference() {
        let xml = r#"<fmiModelDescription fmiVersion="3.0" modelName="m" instantiationToken="t">
            <CoSimulation modelIdentifier="m"/>
            <DefaultExperiment stepSize="0.02"/>
            <ModelVariables>
              <Float64 name="time" valueReference="0" causality="independent"/>
              <Float64 name="x" valueReference="1003" causality="output" description="position">
                <Alias name="position"/><Alias name="q" description="generalized coordinate"/>
              </Float64>
              <Float64 name="v" valueReference="17" causality="output"/>
            </ModelVariables></fmiModelDescription>"#;
        let d = parse_description(xml).unwrap();
        let names: Vec<(&str, u32, &str)> =
            d.variables.iter().map(|v| (v.name.as_str(), v.value_reference, v.description.as_str())).collect();
        assert_eq!(
            names,
            [
                ("x", 1003, "position"),
                ("position", 1003, "position"),
                ("q", 1003, "generalized coordinate"),
                ("v", 17, "")
            ]
        );
        assert_eq!(d.default_step_size, Some(0.02));
    }

    #[test]
    fn fmi2_scalars_are_regrouped_into_arrays_whose_element_names_are_theirs() {
        let spelled = [
            // Column-major in the file: placed by index, not by order.
            scalar("m[1,1]", 10, Causality::Input),
            scalar("m[2,1]", 12, Causality::Input),
            scalar("m[1,2]", 11, Causality::Input),
            scalar("m[2,2]", 13, Causality::Input),
            scalar("f[1]", 20, Causality::Output),
            scalar("f[2]", 21, Causality::Output),
            scalar("w", 30, Causality::Output),
            scalar("odd[1]", 40, Causality::Output),
            scalar("odd[3]", 41, Causality::Output),
            scalar("zero[0]", 50, Causality::Output),
            scalar("zero[1]", 51, Causality::Output),
            scalar("w[1]", 60, Causality::Output),
            scalar("twice[1]", 70, Causality::Output),
            scalar("twice[1]", 71, Causality::Output),
        ];
        let (vars, refs) = regroup(&spelled);
        let names: Vec<&str> = vars.iter().map(|v| v.name.as_str()).collect();
        assert_eq!(
            names,
            ["m", "f", "w", "odd[1]", "odd[3]", "zero[0]", "zero", "w[1]", "twice[1]", "twice[1]"],
            "gaps, 0-based names, a base that is a variable's name and a repeated element stay as spelled \
             (`zero[1]` alone is a whole array of one, element name `zero[1]`)"
        );
        assert_eq!(vars[0].shape, vec![2, 2]);
        assert_eq!(refs[0], vec![10, 11, 12, 13], "row-major by index");
        assert_eq!(vars[0].start, vec![10.0, 11.0, 12.0, 13.0]);
        assert_eq!(vars[1].shape, vec![2]);
        assert!(vars[2].shape.is_empty());
        assert_eq!(refs[2], vec![30]);
        // Every element name lash prints is the FMU's own name for that scalar.
        let own: std::collections::HashMap<u32, &str> =
            spelled.iter().map(|v| (v.value_reference, v.name.as_str())).collect();
        for (v, r) in vars.iter().zip(&refs) {
            for (e, native) in r.iter().enumerate() {
                assert_eq!(v.element_name(e), own[native], "element {e} of {}", v.name);
            }
        }
        assert_eq!(vars.iter().map(|v| v.value_reference).collect::<Vec<_>>(), (0..10).collect::<Vec<u32>>());
    }
}
