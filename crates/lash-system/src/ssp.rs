//! SSP system structures (`.ssd`, with `.ssv` parameter values; or an `.ssp` archive holding
//! `SystemStructure.ssd` and its resources), read into a [`SystemSpec`].
//!
//! What is read: the system's components (`ssd:Component` with `source`, FMUs; a source ending in
//! `.so` is a lash plugin), connections between component connectors, parameter bindings (inline
//! `ssv:ParameterValues` or a `source` `.ssv` file: Real, Integer, Enumeration, Boolean and String values), and the default experiment's
//! start and stop times (a file without a stop time takes the caller's horizon). SSP has no
//! communication step of its own: lash reads it from an `ssd:Annotation type="org.lash"` element
//! `<lash:Step value="…"/>`, else from `DefaultExperiment`'s `lash:step` attribute, else from the
//! Open Simulation Platform's `<osp:FixedStepMaster stepSize="…"/>` (libcosim's annotation), else
//! the caller gives it. A file with libcosim's annotation runs as libcosim runs it: Jacobi, with
//! the initial values iterated in initialization mode ([`Initialization::Iterated`]); any other
//! file runs Gauss–Seidel with ordered initialization, as a TOML system file does by default.
//!
//! Connectors name FMI variables exactly as their `modelDescription.xml` spells them; an FMI 2.0
//! array element (`p_Crane.e[1]`) is one element of the array lash regroups.

use crate::spec::{Algorithm, ConnectionSpec, ElementSpec, Initialization, OutputSpec, ParameterValue, SystemSpec};
use quick_xml::events::{BytesStart, Event};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Why an SSP system structure cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum SspError {
    /// Not well-formed XML.
    #[error("not valid XML: {0}")]
    Xml(quick_xml::Error),
    /// Well-formed, but missing or contradicting what lash needs (the text names the element).
    #[error("{0}")]
    Invalid(String),
    /// A file of the system, or the archive, that cannot be read or unpacked.
    #[error("{}: {problem}", path.display())]
    Read {
        /// The file or archive.
        path: PathBuf,
        /// What the file system or the unpacking said.
        problem: lash_core::BoxError,
    },
    /// What is wrong inside a file of the system.
    #[error("{}: {problem}", path.display())]
    In {
        /// The file.
        path: PathBuf,
        /// What is wrong in it.
        problem: Box<SspError>,
    },
}

impl From<String> for SspError {
    fn from(message: String) -> Self {
        Self::Invalid(message)
    }
}

fn unescape(v: &str) -> String {
    v.replace("&lt;", "<").replace("&gt;", ">").replace("&quot;", "\"").replace("&apos;", "'").replace("&amp;", "&")
}

fn attr(e: &BytesStart<'_>, name: &str) -> Option<String> {
    e.attributes().flatten().find(|a| a.key.as_ref() == name).map(|a| unescape(&a.value))
}

/// The local name of an element (`ssd:Component` → `Component`).
fn local(e: &BytesStart<'_>) -> String {
    e.local_name().as_ref().to_string()
}

/// The value of one SSV type element (`ssv:Real`, `ssv:Integer`, `ssv:Enumeration`,
/// `ssv:Boolean`, `ssv:String`) of parameter `name`, or `None` for another element.
fn ssv_value(tag: &str, value: Option<String>, name: &str) -> Result<Option<ParameterValue>, String> {
    let Some(v) = value else { return Ok(None) };
    Ok(match tag {
        "Real" | "Float64" | "Integer" | "Enumeration" => Some(ParameterValue::Scalar(
            v.trim().parse().map_err(|_| format!("parameter {name}: value {v:?} is not a number"))?,
        )),
        "Boolean" => Some(ParameterValue::Boolean(match v.trim() {
            "true" | "1" => true,
            "false" | "0" => false,
            other => return Err(format!("parameter {name}: value {other:?} is not a Boolean")),
        })),
        "String" => Some(ParameterValue::Text(v)),
        _ => None,
    })
}

/// Parameter values of an `.ssv` document (or an inline `ssv:ParameterValues`): `name → value`
/// (Real, Integer, Enumeration, Boolean and String parameters).
pub fn parse_ssv(xml: &str) -> Result<BTreeMap<String, ParameterValue>, SspError> {
    let mut reader = quick_xml::Reader::from_str(xml);
    let mut out = BTreeMap::new();
    let mut current: Option<String> = None;
    loop {
        match reader.read_event().map_err(SspError::Xml)? {
            Event::Start(e) | Event::Empty(e) => match local(&e).as_str() {
                "Parameter" => current = attr(&e, "name"),
                tag => {
                    if let Some(name) = &current
                        && let Some(value) = ssv_value(tag, attr(&e, "value"), name)?
                    {
                        out.insert(name.clone(), value);
                    }
                }
            },
            Event::Eof => break,
            _ => {}
        }
    }
    Ok(out)
}

/// What the caller gives where the file is silent.
#[derive(Debug, Clone, Copy, Default)]
pub struct Fallback {
    /// Communication step \[s\] when the file gives none.
    pub step: Option<f64>,
    /// Horizon \[s\] (stop − start) when the file has no stop time.
    pub horizon: Option<f64>,
}

/// Reads an `.ssd` file (component sources and `.ssv` files relative to its folder), or an `.ssp`
/// archive (unpacked under `cache`, confined and within the FMU archive limits).
pub fn load(path: &Path, cache: &Path, fallback: Fallback) -> Result<(SystemSpec, PathBuf), SspError> {
    let read = |at: &Path| {
        let path = at.to_path_buf();
        move |e: lash_core::BoxError| SspError::Read { path, problem: e }
    };
    let (ssd, base) = if path.extension().is_some_and(|e| e == "ssp") {
        // Untrusted like an FMU: confined to its folder, within the same limits.
        let limits = lash_fmi::archive::UnpackLimits::from_env().map_err(|e| read(path)(e.into()))?;
        let size = std::fs::metadata(path).map_err(|e| read(path)(e.into()))?.len();
        if size > limits.max_archive_bytes {
            let problem = format!("{size} bytes, more than the {} an archive may have", limits.max_archive_bytes);
            return Err(read(path)(problem.into()));
        }
        let bytes = std::fs::read(path).map_err(|e| read(path)(e.into()))?;
        let dir = cache.join(format!("ssp-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).map_err(|e| read(path)(format!("{}: {e}", dir.display()).into()))?;
        lash_fmi::archive::unpack_archive_into(&bytes, &dir, &limits, "SystemStructure.ssd")
            .map_err(|e| read(path)(e.into()))?;
        (dir.join("SystemStructure.ssd"), dir)
    } else {
        (path.to_path_buf(), path.parent().unwrap_or(Path::new(".")).to_path_buf())
    };
    let xml = std::fs::read_to_string(&ssd).map_err(|e| read(&ssd)(e.into()))?;
    let spec =
        parse_ssd(&xml, &base, fallback).map_err(|e| SspError::In { path: ssd.clone(), problem: Box::new(e) })?;
    Ok((spec, base))
}

/// Parses the text of an `.ssd`.
pub fn parse_ssd(xml: &str, base: &Path, fallback: Fallback) -> Result<SystemSpec, SspError> {
    let mut reader = quick_xml::Reader::from_str(xml);
    let mut r = SsdReader { name: String::from("system"), ..Default::default() };
    loop {
        let event = reader.read_event().map_err(SspError::Xml)?;
        let (e, empty) = match &event {
            Event::Start(e) => (e.clone(), false),
            Event::Empty(e) => (e.clone(), true),
            Event::End(end) => {
                r.end(end.local_name().as_ref() == "ParameterValues");
                continue;
            }
            Event::Eof => break,
            _ => continue,
        };
        if !empty {
            r.depth += 1;
        }
        if r.in_values {
            r.inline_value(&e)?;
        } else {
            r.element(&e, empty, base)?;
        }
    }
    r.finish(fallback)
}

/// The state of [`parse_ssd`] between XML events.
#[derive(Default)]
struct SsdReader {
    name: String,
    start: f64,
    stop: Option<f64>,
    /// The step of lash's own annotation, and of libcosim's fixed-step master.
    file_step: Option<f64>,
    osp_step: Option<f64>,
    elements: Vec<ElementSpec>,
    connections: Vec<ConnectionSpec>,
    /// The component being read (its index in `elements`) and the element depth it opened at.
    in_component: Option<usize>,
    depth_component: usize,
    depth: usize,
    /// Inside an inline ParameterValues block, and the parameter being read there.
    in_values: bool,
    parameter: Option<String>,
}

/// An optional number attribute (`what` names it in the error).
fn number(s: Option<String>, what: &str) -> Result<Option<f64>, String> {
    s.map(|v| v.trim().parse::<f64>().map_err(|_| format!("{what}: {v:?} is not a number"))).transpose()
}

impl SsdReader {
    /// An element closes (`values_end`: an inline ParameterValues block).
    fn end(&mut self, values_end: bool) {
        if values_end {
            self.in_values = false;
        }
        if self.in_component.is_some() && self.depth == self.depth_component {
            self.in_component = None;
        }
        self.depth = self.depth.saturating_sub(1);
    }

    /// An element of an inline parameter set: the same elements as an .ssv file.
    fn inline_value(&mut self, e: &BytesStart<'_>) -> Result<(), SspError> {
        match local(e).as_str() {
            "Parameter" => self.parameter = attr(e, "name"),
            tag => {
                if let (Some(k), Some(name)) = (self.in_component, &self.parameter)
                    && let Some(value) = ssv_value(tag, attr(e, "value"), name)?
                {
                    self.elements[k].parameters.insert(name.clone(), value);
                }
            }
        }
        Ok(())
    }

    /// An element of the system description opens (`empty`: and closes at once); parameter
    /// bindings are read from files relative to `base`.
    fn element(&mut self, e: &BytesStart<'_>, empty: bool, base: &Path) -> Result<(), SspError> {
        match local(e).as_str() {
            "SystemStructureDescription" => {
                if let Some(n) = attr(e, "name") {
                    self.name = n;
                }
            }
            "DefaultExperiment" => {
                self.start = number(attr(e, "startTime"), "DefaultExperiment startTime")?.unwrap_or(0.0);
                self.stop = number(attr(e, "stopTime"), "DefaultExperiment stopTime")?;
                if self.file_step.is_none() {
                    self.file_step = number(attr(e, "lash:step"), "DefaultExperiment lash:step")?;
                }
            }
            "Step" => self.file_step = number(attr(e, "value"), "lash:Step value")?,
            "FixedStepMaster" => self.osp_step = number(attr(e, "stepSize"), "osp:FixedStepMaster stepSize")?,
            "Component" => self.component(e, empty)?,
            "ParameterBinding" => {
                if let (Some(k), Some(src)) = (self.in_component, attr(e, "source")) {
                    let path = base.join(&src);
                    let text =
                        std::fs::read_to_string(&path).map_err(|err| format!("parameter binding {src}: {err}"))?;
                    let values =
                        parse_ssv(&text).map_err(|e| SspError::In { path: src.into(), problem: Box::new(e) })?;
                    bind(&mut self.elements[k], values);
                }
            }
            "ParameterValues" if !empty => self.in_values = true,
            "Connection" => {
                let get = |a: &str| attr(e, a).ok_or_else(|| format!("a Connection without {a}"));
                let (se, sc, ee, ec) =
                    (get("startElement"), get("startConnector"), get("endElement"), get("endConnector"));
                let connection = ConnectionSpec { from: format!("{}.{}", se?, sc?), to: format!("{}.{}", ee?, ec?) };
                self.connections.push(connection);
            }
            _ => {}
        }
        Ok(())
    }

    /// A Component: an FMU, or a plugin library (`.so`).
    fn component(&mut self, e: &BytesStart<'_>, empty: bool) -> Result<(), SspError> {
        let cname = attr(e, "name").ok_or_else(|| SspError::Invalid("a Component without a name".into()))?;
        let source = attr(e, "source").ok_or_else(|| format!("component {cname:?}: no source"))?;
        let mut spec = ElementSpec {
            name: cname,
            fmu: None,
            plugin: None,
            builtin: None,
            scenario: None,
            decimation: 1,
            parameters: BTreeMap::new(),
            isolate: false,
            timeout: None,
        };
        if source.ends_with(".so") {
            spec.plugin = Some(source);
        } else {
            spec.fmu = Some(source);
        }
        self.elements.push(spec);
        if !empty {
            self.in_component = Some(self.elements.len() - 1);
            self.depth_component = self.depth;
        }
        Ok(())
    }

    /// The system read: its stop time and step from the file or the fallback, libcosim's
    /// algorithm where the file was written for it.
    fn finish(self, fallback: Fallback) -> Result<SystemSpec, SspError> {
        let start = self.start;
        let stop = self
            .stop
            .or(fallback.horizon.map(|h| start + h))
            .ok_or_else(|| SspError::Invalid("no DefaultExperiment stopTime: add one, or pass --horizon".into()))?;
        let step = self.file_step.or(self.osp_step).or(fallback.step).ok_or_else(|| {
            SspError::Invalid(
                "no communication step: add <lash:Step value=\"…\"/> in an org.lash annotation, or pass --step".into(),
            )
        })?;
        // A file written for libcosim (its fixed-step master's annotation) runs as libcosim runs
        // it: Jacobi, the initial values iterated in initialization mode.
        let (algorithm, initialization) = match self.osp_step {
            Some(_) => (Algorithm::Jacobi, Initialization::Iterated),
            None => Default::default(),
        };
        Ok(SystemSpec {
            name: self.name,
            start,
            stop,
            step,
            algorithm,
            initialization,
            elements: self.elements,
            connections: self.connections,
            output: OutputSpec::default(),
            interface: None,
        })
    }
}

fn bind(element: &mut ElementSpec, values: BTreeMap<String, ParameterValue>) {
    element.parameters.extend(values);
}
