//! `lash._lash`: the compiled half of lash's Python package (the Python half, `lash/__init__.py`,
//! wraps it in classes with pandas and batching). Everything here goes through the same Rust
//! paths as the command line: scenarios are parsed and validated by lash-scenario, runs are
//! built by [`lash_run::runner`], sweeps run through [`lash_cli::sweep::execute`] (limits
//! checked first), datasets are read by lash-sweep.
//!
//! Samples cross into Python once: a run's rows are appended to one `Vec<f64>` by the runner's
//! sink, and that vector becomes the numpy array's memory (no copy); a dataset's Parquet columns
//! are written once into the runs × samples × channels vector that numpy then owns. The GIL is
//! released while a run or a sweep simulates.

use lash_core::Problems;
use lash_scenario::AnyScenario;
use numpy::{IntoPyArray, PyArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;

pyo3::create_exception!(
    _lash,
    ScenarioError,
    PyValueError,
    "Invalid input: a scenario, sweep file, parameter path or option that lash refuses. The message \
     names each field and its problem; `problems` lists them as (field, message) pairs."
);
pyo3::create_exception!(
    _lash,
    SimulationError,
    PyRuntimeError,
    "A run or a sweep failed while simulating or writing its output."
);

/// A ScenarioError whose `problems` attribute holds (field, message) pairs.
fn input_error(py: Python<'_>, message: String, problems: &[(String, String)]) -> PyErr {
    let err = ScenarioError::new_err(message);
    let list = PyList::new(py, problems.iter().map(|(f, m)| (f.as_str(), m.as_str())));
    if let Ok(list) = list {
        let _ = err.value(py).setattr("problems", list);
    }
    err
}

/// A ScenarioError listing every problem of a scenario.
fn problems_error(py: Python<'_>, what: &str, p: &Problems) -> PyErr {
    let pairs: Vec<(String, String)> = p.0.iter().map(|p| (p.field.clone(), p.message.clone())).collect();
    input_error(py, format!("{what}: {p}"), &pairs)
}

/// A ScenarioError about one field.
fn field_error(py: Python<'_>, field: &str, message: String) -> PyErr {
    input_error(py, format!("{field}: {message}"), &[(field.to_string(), message)])
}

/// A CliError as the matching Python exception.
fn cli_error(py: Python<'_>, e: lash_cli::CliError) -> PyErr {
    match e {
        lash_cli::CliError::Input(m) => input_error(py, m, &[]),
        lash_cli::CliError::Failure(m) | lash_cli::CliError::Interrupted(m) => SimulationError::new_err(m),
    }
}

/// A planar or spatial mechanism with its clearance joints, simulation and output settings,
/// always valid: every constructor and every edit parses and validates it as `lash validate`
/// does, and raises ScenarioError naming each bad field.
#[pyclass(name = "Scenario", module = "lash._lash", from_py_object)]
#[derive(Clone)]
pub struct Scenario {
    inner: AnyScenario,
}

impl Scenario {
    fn from_text(py: Python<'_>, what: &str, text: &str) -> PyResult<Self> {
        lash_scenario::parse_any(text).map(|inner| Self { inner }).map_err(|p| problems_error(py, what, &p))
    }

    fn table(&self, py: Python<'_>) -> PyResult<toml::Table> {
        self.inner.to_table().map_err(|e| input_error(py, e.to_string(), &[]))
    }
}

#[pymethods]
impl Scenario {
    /// A built-in scenario by name (A, B, C, E-0.5mm-250rpm, F-…; see `builtin_names()`).
    #[staticmethod]
    fn builtin(py: Python<'_>, name: &str) -> PyResult<Self> {
        if let Some(s) = lash_scenario::builtin::by_name(name) {
            return Ok(Self { inner: AnyScenario::Planar(s) });
        }
        if let Some(s) = lash_scenario::builtin_spatial::spatial_by_name(name) {
            return Ok(Self { inner: AnyScenario::Spatial(s) });
        }
        Err(field_error(py, "name", format!("{name:?} is not a built-in scenario (built-ins: {})", names().join(", "))))
    }

    /// A scenario file (TOML, planar or spatial).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let text = std::fs::read_to_string(&path)
            .map_err(|e| input_error(py, format!("cannot read {}: {e}", path.display()), &[]))?;
        Self::from_text(py, &format!("invalid scenario {}", path.display()), &text)
    }

    /// A scenario from the text of a scenario file.
    #[staticmethod]
    fn from_toml(py: Python<'_>, text: &str) -> PyResult<Self> {
        Self::from_text(py, "invalid scenario", text)
    }

    /// A scenario from the JSON form of a scenario file (what `to_json` gives).
    #[staticmethod]
    fn from_json(py: Python<'_>, text: &str) -> PyResult<Self> {
        let value: toml::Value =
            serde_json::from_str(text).map_err(|e| input_error(py, format!("not a scenario as JSON: {e}"), &[]))?;
        let text = toml::to_string(&value).map_err(|e| input_error(py, format!("not a scenario table: {e}"), &[]))?;
        Self::from_text(py, "invalid scenario", &text)
    }

    /// The scenario as the text of a scenario file.
    fn to_toml(&self, py: Python<'_>) -> PyResult<String> {
        toml::to_string(&self.table(py)?).map_err(|e| input_error(py, e.to_string(), &[]))
    }

    /// The scenario as JSON (the same fields as the file).
    fn to_json(&self, py: Python<'_>) -> PyResult<String> {
        serde_json::to_string(&self.table(py)?).map_err(|e| input_error(py, e.to_string(), &[]))
    }

    /// The scenario as a dict of the file's fields (edit it and make a Scenario with `from_dict`).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        py.import("json")?.call_method1("loads", (self.to_json(py)?,))
    }

    /// A scenario from a dict of the file's fields, validated like a file.
    #[staticmethod]
    fn from_dict(py: Python<'_>, fields: &Bound<'_, PyAny>) -> PyResult<Self> {
        let text: String = py.import("json")?.call_method1("dumps", (fields,))?.extract()?;
        Self::from_json(py, &text)
    }

    /// The scenario's name.
    #[getter]
    fn name(&self) -> String {
        self.inner.name().to_string()
    }

    /// "planar" or "spatial".
    #[getter]
    fn space(&self) -> &'static str {
        match self.inner {
            AnyScenario::Planar(_) => "planar",
            AnyScenario::Spatial(_) => "spatial",
        }
    }

    /// The number at a field path (`clearances[0].bearing_radius`, `simulation.horizon`).
    fn get(&self, py: Python<'_>, path: &str) -> PyResult<f64> {
        lash_scenario::paths::get_path(&self.table(py)?, path).map_err(|e| field_error(py, path, e.problem.to_string()))
    }

    /// A copy with the numbers at the given field paths changed, validated like a file (the
    /// paths and validation of sweeps).
    fn with_values(&self, py: Python<'_>, values: &Bound<'_, PyDict>) -> PyResult<Self> {
        let values: Vec<(String, f64)> = values
            .iter()
            .map(|(k, v)| {
                let path: String =
                    k.extract().map_err(|_| field_error(py, "values", "paths must be strings".into()))?;
                let value: f64 = v.extract().map_err(|_| field_error(py, &path, format!("{v} is not a number")))?;
                Ok((path, value))
            })
            .collect::<PyResult<_>>()?;
        let table = self.table(py)?;
        let edits = values.iter().map(|(p, v)| (p.as_str(), *v));
        match lash_scenario::paths::edited_any(&table, edits) {
            Ok(inner) => Ok(Self { inner }),
            Err(lash_scenario::paths::EditError::Path(e)) => Err(field_error(py, &e.path, e.problem.to_string())),
            Err(lash_scenario::paths::EditError::Invalid(p)) => Err(problems_error(py, "invalid scenario", &p)),
        }
    }

    /// Every problem of the scenario (always none: a Scenario is validated when made and when
    /// edited); kept so that code written against files reads the same.
    fn validate(&self, py: Python<'_>) -> PyResult<()> {
        let p = self.inner.validate();
        if p.is_empty() { Ok(()) } else { Err(problems_error(py, "invalid scenario", &p)) }
    }

    /// (name, SI unit) of each output channel a run of this scenario can give.
    #[pyo3(signature = (ideal = false))]
    fn channels(&self, ideal: bool) -> Vec<(String, String)> {
        self.inner.channels(ideal).into_iter().map(|c| (c.name, c.unit.to_string())).collect()
    }

    fn __repr__(&self) -> String {
        format!("<lash.Scenario {:?} ({})>", self.inner.name(), self.space())
    }
}

/// The built-in scenarios' names.
fn names() -> Vec<&'static str> {
    lash_scenario::builtin::NAMES.iter().chain(lash_scenario::builtin_spatial::SPATIAL_NAMES.iter()).copied().collect()
}

/// The names of the built-in scenarios.
#[pyfunction]
fn builtin_names() -> Vec<&'static str> {
    names()
}

/// What a run returns to Python: the column names and units (time first), the samples as a
/// numpy array (samples × columns, time in column 0) and the summary as JSON.
type RunResult<'py> = (Vec<String>, Vec<String>, Bound<'py, PyAny>, String);

/// The reduced model's settings as Python names them: steps \[s\], `interpolation` ("linear",
/// "hermite", "zoh"), `coupling` ("auto", "one_way", "two_way"), `micro` ("rk4", "dopri5"),
/// `threaded`.
#[derive(Debug, Clone, Copy)]
struct ReducedSettings<'a> {
    macro_step: f64,
    micro_step: f64,
    interpolation: &'a str,
    coupling: &'a str,
    micro: &'a str,
    threaded: bool,
}

impl<'a> ReducedSettings<'a> {
    /// The settings as given, a step not given the default (lash chooses it later: see
    /// [`ReducedSettings::request`]).
    fn given(
        (macro_step, micro_step): (Option<f64>, Option<f64>),
        (interpolation, coupling, micro): (&'a str, &'a str, &'a str),
        threaded: bool,
    ) -> Self {
        let defaults = lash_run::ReducedOptions::default();
        Self {
            macro_step: macro_step.unwrap_or(defaults.macro_step),
            micro_step: micro_step.unwrap_or(defaults.micro_step),
            interpolation,
            coupling,
            micro,
            threaded,
        }
    }

    /// The options, or the field that is wrong.
    fn options(&self, py: Python<'_>) -> PyResult<lash_run::ReducedOptions> {
        for (field, v) in [("macro_step", self.macro_step), ("micro_step", self.micro_step)] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(field_error(py, field, format!("must be a positive step in seconds, got {v}")));
            }
        }
        let choice = |field: &str, value: &str, known: &[&str]| -> PyResult<usize> {
            known
                .iter()
                .position(|k| *k == value)
                .ok_or_else(|| field_error(py, field, format!("{value:?} is not one of {}", known.join(", "))))
        };
        use lash_orchestrate::{Execution, Interpolation};
        let interpolation = [Interpolation::Linear, Interpolation::CubicHermite, Interpolation::ZeroOrderHold]
            [choice("interpolation", self.interpolation, &["linear", "hermite", "zoh"])?];
        let coupling = [lash_core::Coupling::OneWay, lash_core::Coupling::OneWay, lash_core::Coupling::TwoWay]
            [choice("coupling", self.coupling, &["auto", "one_way", "two_way"])?];
        let error_controlled_micro = choice("micro", self.micro, &["rk4", "dopri5"])? == 1;
        Ok(lash_run::ReducedOptions {
            macro_step: self.macro_step,
            micro_step: self.micro_step,
            interpolation,
            coupling,
            execution: if self.threaded { Execution::Threaded } else { Execution::Sequential },
            error_controlled_micro,
            channels_only: false,
        })
    }

    /// The run as asked for (`lash_cli::ReducedRequest`), with whether each step was given.
    fn request(
        &self,
        py: Python<'_>,
        (macro_step_given, micro_step_given): (bool, bool),
    ) -> PyResult<lash_cli::ReducedRequest> {
        Ok(lash_cli::ReducedRequest {
            options: self.options(py)?,
            micro_step_given,
            macro_step_given,
            coupling_auto: self.coupling == "auto",
        })
    }
}

/// A reduced run's micro step when none is given, chosen as `lash run` chooses it (from the
/// converged full model's impacts over `probe`'s window); why, when it is not the default or the
/// probe failed. DOPRI5's communication step is kept.
fn choose_micro_step(
    probe: &Result<lash_cli::probe::FullProbe, lash_cli::probe::NoEstimate>,
    options: &mut lash_run::ReducedOptions,
) -> Option<String> {
    if options.error_controlled_micro {
        return None;
    }
    match probe.as_ref().map(|p| p.micro_step(*options)) {
        Ok((h, why)) => {
            options.micro_step = h;
            why
        }
        Err(e) => Some(format!("micro step kept at {:e} s: the full model's probe failed: {e}", options.micro_step)),
    }
}

/// Runs a scenario's full or reduced model and returns (names, units, samples, summary JSON).
#[pyfunction]
#[pyo3(signature = (
    scenario, model = "full", ideal = false, macro_step = None, micro_step = None,
    interpolation = "linear", coupling = "auto", micro = "rk4", threaded = false, error_estimate = false
))]
#[allow(clippy::too_many_arguments)]
fn run<'py>(
    py: Python<'py>,
    scenario: &Scenario,
    model: &str,
    ideal: bool,
    macro_step: Option<f64>,
    micro_step: Option<f64>,
    interpolation: &str,
    coupling: &str,
    micro: &str,
    threaded: bool,
    error_estimate: bool,
) -> PyResult<RunResult<'py>> {
    let given = micro_step;
    let settings = ReducedSettings::given((macro_step, micro_step), (interpolation, coupling, micro), threaded);
    let mut request = settings.request(py, (macro_step.is_some(), given.is_some()))?;
    let macro_choice = (model == "reduced").then(|| request.choose_macro_step(&scenario.inner, true)).flatten();
    let lash_cli::ReducedRequest { mut options, coupling_auto, .. } = request;
    // The converged full model over the first part of the run, as `lash run` runs it: over the
    // error estimate's window when one is asked for, else over the micro step's choice window.
    let reduced = model == "reduced" && !ideal;
    let probe = (reduced && (given.is_none() || error_estimate)).then(|| {
        let (s, h) = (&scenario.inner, options.macro_step);
        py.detach(|| lash_cli::probe::FullProbe::run(s, h, error_estimate).map_err(lash_cli::probe::NoEstimate::from))
    });
    let choice = match &probe {
        Some(p) if given.is_none() => choose_micro_step(p, &mut options),
        _ => None,
    };
    let model = match (model, ideal) {
        ("full", _) => lash_run::Model::Full { ideal },
        ("reduced", false) => lash_run::Model::Reduced(options),
        ("reduced", true) => {
            return Err(field_error(py, "ideal", "an ideal run has no clearance interface to reduce".into()));
        }
        (other, _) => return Err(field_error(py, "model", format!("{other:?} is neither \"full\" nor \"reduced\""))),
    };
    let scenario = scenario.inner.clone();
    let mut outcome = execute_in_memory(py, &scenario, model);
    // A pressed contact the chosen step does not hold: again at a tenth of the step (as `lash run`).
    let mut refined = None;
    if let (None, Ok((_, _, summary)), true) = (given, &outcome, reduced)
        && let Some((finer, why)) =
            lash_run::micro_step_for_unheld_contacts(summary, &options, scenario.simulation().output_interval)
    {
        options.micro_step = finer;
        outcome = execute_in_memory(py, &scenario, lash_run::Model::Reduced(options));
        refined = Some(why);
    }
    // The estimate, and under coupling "auto" the run again in two-way coupling when one-way
    // coupling's own error is past its bound (as `lash run`); the GIL is taken back for the run.
    let mut coupling_choice = None;
    let estimate = match &probe {
        Some(p) if error_estimate && outcome.is_ok() => Some(py.detach(|| {
            let rerun = |o| {
                outcome = Python::attach(|py| execute_in_memory(py, &scenario, lash_run::Model::Reduced(o)));
                Ok::<(), std::convert::Infallible>(())
            };
            let Ok(estimated) = lash_cli::probe::estimate_and_choose_coupling(p, options, coupling_auto, true, rerun);
            coupling_choice = estimated.coupling_choice;
            estimated.estimate
        })),
        _ => None,
    };
    let (header, values, summary) = outcome?;
    let notes = [
        ("macro_step_choice", macro_choice),
        ("micro_step_choice", choice),
        ("micro_step_refined", refined),
        ("coupling_choice", coupling_choice),
    ];
    let summary = summary_json(&summary, notes, estimate.as_ref())?;
    run_result(py, &header, values, summary)
}

/// A reduced run's summary as JSON, as `lash run` writes it: with how its steps and coupling were
/// chosen (`notes`: key and why, where there is one) and its error estimate, if asked for.
fn summary_json(
    summary: &lash_run::Summary,
    notes: [(&str, Option<String>); 4],
    estimate: Option<&Result<lash_cli::probe::ErrorEstimate, lash_cli::probe::NoEstimate>>,
) -> PyResult<String> {
    let mut summary = serde_json::to_value(summary).map_err(|e| SimulationError::new_err(e.to_string()))?;
    if let Some(map) = summary.as_object_mut() {
        for (key, why) in notes {
            if let Some(why) = why {
                map.insert(key.into(), why.into());
            }
        }
        if let Some(estimated) = estimate {
            lash_cli::probe::record(map, estimated);
        }
    }
    Ok(summary.to_string())
}

/// Runs a model of a scenario with its rows held in memory: (header, values row after row,
/// summary), or the error as Python sees it.
fn execute_in_memory(
    py: Python<'_>,
    scenario: &AnyScenario,
    model: lash_run::Model,
) -> PyResult<(Vec<String>, Vec<f64>, lash_run::Summary)> {
    // Ctrl-C (or any signal handler that raises) stops the run: the sink takes the GIL back every
    // 4096 rows to let Python check its signals (on this, the main, thread), which costs ~0.1 µs
    // per row-block.
    let mut interrupted: Option<PyErr> = None;
    // Built, checked and run without the GIL (the runner stays on this thread).
    let outcome = py.detach(|| -> Result<_, (&'static str, String)> {
        let mut runner = lash_run::runner(scenario, model).map_err(|e| ("model", e.to_string()))?;
        let header = runner.header();
        // Held in memory: refused before any work when it cannot fit (as `lash run` refuses).
        let sim = scenario.simulation();
        let rows = lash_cli::limits::samples(sim.horizon, sim.output_interval);
        let estimate = lash_cli::limits::Estimate {
            rows,
            columns: header.len() as u64,
            disk_bytes: 0,
            memory_bytes: rows.saturating_mul(header.len() as u64).saturating_mul(8),
        };
        lash_cli::limits::check(
            "the run",
            &estimate,
            std::path::Path::new("."),
            "shorten simulation.horizon, raise simulation.output_interval or list fewer output.channels",
        )
        .map_err(|e| ("limits", e.to_string()))?;
        let mut values: Vec<f64> = Vec::with_capacity((rows as usize + 1) * header.len());
        let mut count = 0u32;
        let mut sink = |row: &[f64]| keep_row(&mut values, &mut count, &mut interrupted, row);
        let summary = runner.execute(&mut sink, &mut |_| {}).map_err(|e| ("run", e.to_string()))?;
        Ok((header, values, summary))
    });
    if let Some(e) = interrupted {
        return Err(e);
    }
    outcome.map_err(|(what, m)| match what {
        "run" => SimulationError::new_err(m),
        "limits" => input_error(py, m, &[]),
        field => field_error(py, field, m),
    })
}

/// Keeps a row of a run held in memory; every 4096 rows Python checks its signals (Ctrl-C stops
/// the run: the error is kept in `interrupted`), which costs ~0.1 µs per row-block.
fn keep_row(
    values: &mut Vec<f64>,
    count: &mut u32,
    interrupted: &mut Option<PyErr>,
    row: &[f64],
) -> Result<(), lash_core::BoxError> {
    values.extend_from_slice(row);
    *count = count.wrapping_add(1);
    if *count & 4095 == 0
        && let Err(e) = Python::attach(|py| py.check_signals())
    {
        *interrupted = Some(e);
        return Err("interrupted".into());
    }
    Ok(())
}

/// Runs a system file (TOML, `.ssd`, `.ssp`: FMUs, plugins, built-ins) in memory and returns
/// (names, units, samples, summary JSON), as [`run`] does for a scenario. `step` and `stop`
/// override the file's communication step and horizon \[s\].
#[pyfunction]
#[pyo3(signature = (path, step = None, stop = None))]
fn run_system<'py>(py: Python<'py>, path: PathBuf, step: Option<f64>, stop: Option<f64>) -> PyResult<RunResult<'py>> {
    let mut interrupted: Option<PyErr> = None;
    let arg = path.to_string_lossy().into_owned();
    let outcome = py.detach(|| {
        let (mut values, mut count) = (Vec::new(), 0u32);
        let mut sink = |row: &[f64]| keep_row(&mut values, &mut count, &mut interrupted, row);
        lash_cli::system::run_rows(&arg, (step, stop), &mut sink).map(|(header, summary)| (header, values, summary))
    });
    if let Some(e) = interrupted {
        return Err(e);
    }
    let (header, values, summary) = outcome.map_err(|e| cli_error(py, e))?;
    run_result(py, &header, values, summary)
}

/// (names, units, samples as a samples × columns array, summary) of a run's rows.
fn run_result<'py>(py: Python<'py>, header: &[String], values: Vec<f64>, summary: String) -> PyResult<RunResult<'py>> {
    let width = header.len();
    let samples = values.len() / width.max(1);
    let array = values.into_pyarray(py).reshape([samples, width])?.into_any();
    let (names, units): (Vec<String>, Vec<String>) = header.iter().map(|h| split_header(h)).unzip();
    Ok((names, units, array, summary))
}

/// `name [unit]` → (name, unit).
fn split_header(h: &str) -> (String, String) {
    match h.split_once(" [") {
        Some((name, unit)) => (name.to_string(), unit.trim_end_matches(']').to_string()),
        None => (h.to_string(), String::new()),
    }
}

/// A sweep given as JSON text (a Python dict) as a sweep file's TOML text; its fields checked.
#[pyfunction]
fn sweep_toml(py: Python<'_>, json: &str) -> PyResult<String> {
    lash_cli::sweep::spec_toml_from_json(json).map_err(|e| cli_error(py, e))
}

/// `lash compare`: the converged full, the reduced and the ideal model of `scenario` into `out`
/// (as the command line writes them; the bounds against `realisations` converged realisations of
/// the full model), with `report` the page `out/report.html`; returns comparison.json's text.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn compare(
    py: Python<'_>,
    scenario: &Scenario,
    out: PathBuf,
    macro_step: Option<f64>,
    micro_step: Option<f64>,
    interpolation: &str,
    coupling: &str,
    micro: &str,
    report: bool,
    realisations: usize,
) -> PyResult<String> {
    if !(1..=64).contains(&realisations) {
        return Err(field_error(py, "realisations", format!("{realisations}: must be 1 to 64")));
    }
    // Without a step, the command line's choice (the macro step from the fastest rotation, the
    // micro step from the full run's impacts).
    let settings = ReducedSettings::given((macro_step, micro_step), (interpolation, coupling, micro), false);
    let request = settings.request(py, (macro_step.is_some(), micro_step.is_some()))?;
    let scenario = scenario.inner.clone();
    py.detach(|| lash_cli::compare_into(&scenario, &out, request, realisations, true, report))
        .map_err(|e| cli_error(py, e))?;
    std::fs::read_to_string(out.join("comparison.json")).map_err(|e| SimulationError::new_err(e.to_string()))
}

/// `lash report`: the page of a run's or a comparison's folder (default `folder/report.html`);
/// returns its path.
#[pyfunction]
#[pyo3(signature = (folder, out = None))]
fn report(py: Python<'_>, folder: PathBuf, out: Option<PathBuf>) -> PyResult<String> {
    let written = py.detach(|| lash_report::write_report(&folder, out.as_deref())).map_err(|e| match e {
        lash_report::ReportError::Input(m) => input_error(py, m, &[]),
        other => SimulationError::new_err(other.to_string()),
    })?;
    Ok(written.path.display().to_string())
}

/// Merges shard folders of one sweep into `out` (as `lash sweep merge`); returns the rows.
#[pyfunction]
fn merge(py: Python<'_>, inputs: Vec<PathBuf>, out: PathBuf) -> PyResult<u64> {
    py.detach(|| lash_sweep::merge(&inputs, &out)).map_err(|e| cli_error(py, lash_cli::sweep::map_error(e)))
}

/// Checks a sweep file and every run's scenario (as `lash validate` does); returns the summary
/// line.
#[pyfunction]
fn validate_sweep(py: Python<'_>, file: PathBuf) -> PyResult<String> {
    lash_cli::sweep::validate(&file).map_err(|e| cli_error(py, e))
}

/// Runs a sweep file (or one shard `"i/N"`) into `out`, resuming what an earlier call left
/// there; returns the report as JSON (failed runs are counted in it and listed in the dataset).
/// The sweep runs on a thread of its own while this (the main) thread checks Python's signals
/// every 50 ms: Ctrl-C stops it — runs in flight finish, the folder stays resumable — and
/// raises KeyboardInterrupt. `progress(done, total, failed)` is called from this thread once per
/// finished run, in order; an exception it raises stops the sweep the same way.
#[pyfunction]
#[pyo3(signature = (file, out, threads = None, shard = None, progress = None))]
fn sweep(
    py: Python<'_>,
    file: PathBuf,
    out: PathBuf,
    threads: Option<usize>,
    shard: Option<String>,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<String> {
    use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};
    let cancel = std::sync::Arc::new(AtomicBool::new(false));
    // Runs of the shard and runs done before this call: for `progress`; each finished run comes
    // through `finished` (its outcome), so `progress` is called once per run, in order.
    let (total, before) = (AtomicU64::new(0), AtomicU64::new(0));
    let (finished_tx, finished_rx) = crossbeam_channel::unbounded::<bool>();
    let on_event = |e: lash_sweep::Event| match e {
        lash_sweep::Event::Start { total: t, done: d } => {
            total.store(t, Relaxed);
            before.store(d, Relaxed);
        }
        lash_sweep::Event::Finished { ok } => {
            let _ = finished_tx.send(ok);
        }
    };
    let (done_tx, done_rx) = crossbeam_channel::bounded::<()>(1);
    let (report, interrupted) = std::thread::scope(|scope| {
        let worker = scope.spawn({
            let cancel = cancel.clone();
            let (file, out, shard, on_event) = (&file, &out, shard.as_deref(), &on_event);
            move || {
                let report = lash_cli::sweep::execute(file, out, (shard, threads, None), Some(cancel), on_event);
                let _ = done_tx.send(());
                report
            }
        });
        let mut interrupted: Option<PyErr> = None;
        let (mut done, mut failed) = (0u64, 0u64);
        let mut show = |ok: bool, interrupted: &mut Option<PyErr>| {
            done += 1;
            failed += u64::from(!ok);
            if let Some(callback) = &progress
                && interrupted.is_none()
                && let Err(e) = callback.call1((before.load(Relaxed) + done, total.load(Relaxed), failed))
            {
                cancel.store(true, Relaxed);
                *interrupted = Some(e);
            }
        };
        loop {
            let woke = py.detach(|| {
                crossbeam_channel::select! {
                    recv(finished_rx) -> ok => Some(ok.ok()),
                    recv(done_rx) -> _ => None,
                    default(std::time::Duration::from_millis(50)) => Some(None),
                }
            });
            match woke {
                None => break,
                Some(Some(ok)) => show(ok, &mut interrupted),
                Some(None) => {}
            }
            if interrupted.is_none()
                && let Err(e) = py.check_signals()
            {
                cancel.store(true, Relaxed);
                interrupted = Some(e);
            }
        }
        let report = py.detach(|| worker.join());
        while let Ok(ok) = finished_rx.try_recv() {
            show(ok, &mut interrupted);
        }
        (report, interrupted)
    });
    let report = report.map_err(|_| SimulationError::new_err("the sweep's thread panicked"))?;
    if let Some(e) = interrupted {
        return Err(e);
    }

    let report = report.map_err(|e| cli_error(py, e))?;
    serde_json::to_string(&report).map_err(|e| SimulationError::new_err(e.to_string()))
}

/// What `read_params` returns: the parameters' names and units, and the params table's run ids,
/// seeds, statuses, values (runs × parameters) and errors.
type ParamsResult<'py> =
    (Vec<String>, Vec<String>, Bound<'py, PyAny>, Bound<'py, PyAny>, Vec<String>, Bound<'py, PyAny>, Vec<String>);

/// Reads a sweep's output folder: all its samples as one array (see `read_runs` for the tuple).
#[pyfunction]
fn read_dataset(py: Python<'_>, dir: PathBuf) -> PyResult<RunsResult<'_>> {
    let data = py.detach(|| lash_sweep::dataset::read_dataset(&dir));
    let data = data.map_err(|e| input_error(py, e.to_string(), &[]))?;
    runs_result(py, data)
}

/// A dataset's arrays handed to numpy (no copy).
fn runs_result(py: Python<'_>, data: lash_sweep::dataset::DatasetArrays) -> PyResult<RunsResult<'_>> {
    let (runs, samples, width) = (data.run_ids.len(), data.time.len(), data.channels.len());
    let values = data.values.into_pyarray(py).reshape([runs, samples, width])?.into_any();
    let (names, units): (Vec<String>, Vec<String>) = data.channels.into_iter().unzip();
    Ok((data.run_ids.into_pyarray(py).into_any(), data.time.into_pyarray(py).into_any(), names, units, values))
}

/// Reads a sweep's params table (every run, failed ones too).
#[pyfunction]
fn read_params(py: Python<'_>, dir: PathBuf) -> PyResult<ParamsResult<'_>> {
    let params = py.detach(|| lash_sweep::dataset::read_params_table(&dir));
    let params = params.map_err(|e| input_error(py, e.to_string(), &[]))?;
    let (p_names, p_units): (Vec<String>, Vec<String>) = params.parameters.into_iter().unzip();
    let n = p_names.len();
    let rows = &params.rows;
    let mut table = Vec::with_capacity(rows.len() * n);
    for r in rows {
        table.extend_from_slice(&r.values);
    }
    let table = table.into_pyarray(py).reshape([rows.len(), n])?.into_any();
    Ok((
        p_names,
        p_units,
        rows.iter().map(|r| r.run_id).collect::<Vec<_>>().into_pyarray(py).into_any(),
        rows.iter().map(|r| r.seed).collect::<Vec<_>>().into_pyarray(py).into_any(),
        rows.iter().map(|r| r.status.clone()).collect(),
        table,
        rows.iter().map(|r| r.error.clone()).collect(),
    ))
}

/// What `read_runs` returns: run ids, sample times, channel names and units, and the values
/// (runs × samples × channels).
type RunsResult<'py> = (Bound<'py, PyAny>, Bound<'py, PyAny>, Vec<String>, Vec<String>, Bound<'py, PyAny>);

/// Reads the runs in row groups `groups` of a dataset (sorted; one row group per completed run)
/// without the rest of its samples.
#[pyfunction]
fn read_runs(py: Python<'_>, dir: PathBuf, mut groups: Vec<usize>) -> PyResult<RunsResult<'_>> {
    groups.sort_unstable();
    let data = py.detach(|| lash_sweep::dataset::read_runs(&dir, Some(&groups)));
    let data = data.map_err(|e| input_error(py, e.to_string(), &[]))?;
    runs_result(py, data)
}

/// The run id of each row group of a dataset (one per completed run), from its manifest and
/// the file's footer.
#[pyfunction]
fn read_layout(py: Python<'_>, dir: PathBuf) -> PyResult<Vec<u64>> {
    let layout = lash_sweep::dataset::read_layout(&dir).map_err(|e| input_error(py, e.to_string(), &[]))?;
    Ok(layout.into_iter().map(|(id, _)| id).collect())
}

/// Prepares an estimator for a setup (built-in "A", "C", "E" or a setup TOML file) into `out`
/// (JSON): a reduced-model sweep over the priors, the fit, a calibration on full-model runs, the
/// hidden signals' bands calibrated on `hidden_runs` full-model cases.
#[pyfunction]
#[pyo3(signature = (setup, out, bank_runs=None, calibration_runs=None, quiet=true, hidden_runs=None))]
fn prepare_estimator(
    py: Python<'_>,
    setup: String,
    out: PathBuf,
    bank_runs: Option<u64>,
    calibration_runs: Option<u64>,
    quiet: bool,
    hidden_runs: Option<u64>,
) -> PyResult<()> {
    let sizes = lash_cli::estimate::Sizes { bank_runs, calibration_runs, hidden_runs };
    let done = py.detach(|| lash_cli::estimate::prepare(&setup, &out, sizes, quiet));
    done.map_err(|e| cli_error(py, e))
}

/// The estimate of a measured file (CSV or Parquet) with a prepared estimator, as JSON text:
/// every unknown's median and 90 % interval, the worn-joint probabilities, the posterior draws.
#[pyfunction]
#[pyo3(signature = (measurement, prepared, track_impacts=None, track_draws=None))]
fn estimate_json(
    py: Python<'_>,
    measurement: PathBuf,
    prepared: PathBuf,
    track_impacts: Option<usize>,
    track_draws: Option<usize>,
) -> PyResult<String> {
    use lash_estimate::track::{BadTrackOption, TrackOptions};
    let track = match track_impacts.map(|p| TrackOptions::with(p, track_draws)).transpose() {
        Ok(_) if track_draws.is_some() && track_impacts.is_none() => {
            return Err(input_error(
                py,
                "track_draws: give track_impacts too (the draws are the filter's)".into(),
                &[],
            ));
        }
        Ok(track) => track,
        Err(BadTrackOption::Particles(m)) => return Err(input_error(py, format!("track_impacts: {m}"), &[])),
        Err(BadTrackOption::Draws(m)) => return Err(input_error(py, format!("track_draws: {m}"), &[])),
    };
    let result = py.detach(|| {
        let estimator = lash_estimate::Estimator::load(&prepared)?;
        let (estimate, hidden, notes) = lash_estimate::infer::estimate_file_hidden(&estimator, &measurement, track)?;
        Ok::<_, lash_estimate::EstimateError>(
            serde_json::json!({ "estimate": estimate, "hidden": hidden, "notes": notes }),
        )
    });
    match result {
        Ok(v) => Ok(v.to_string()),
        Err(lash_estimate::EstimateError::Input(m)) => Err(input_error(py, m, &[])),
        Err(lash_estimate::EstimateError::Measurement(e)) => Err(input_error(py, e.to_string(), &[])),
        Err(e) => Err(SimulationError::new_err(e.to_string())),
    }
}

/// Writes one emulated measurement of the converged full model (CSV, as the setup's logger
/// records it) with the given clearances [m], to try an estimator on.
#[pyfunction]
#[pyo3(signature = (prepared, clearances, out, speed=None, angle=1.0, gain=1.0, snr=40.0, seed=1))]
#[allow(clippy::too_many_arguments)]
fn emulate_measurement(
    py: Python<'_>,
    prepared: PathBuf,
    clearances: Vec<f64>,
    out: PathBuf,
    speed: Option<f64>,
    angle: f64,
    gain: f64,
    snr: f64,
    seed: u64,
) -> PyResult<()> {
    let case = lash_estimate::prepare::Case { clearances, speed, angle0: angle, gain, snr, seed };
    let done = py.detach(|| lash_cli::estimate::emulate(&prepared, &case, &out));
    done.map_err(|e| cli_error(py, e))
}

/// The module `lash._lash`.
#[pymodule]
fn _lash(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Scenario>()?;
    m.add_function(wrap_pyfunction!(builtin_names, m)?)?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(run_system, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_toml, m)?)?;
    m.add_function(wrap_pyfunction!(merge, m)?)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(report, m)?)?;
    m.add_function(wrap_pyfunction!(validate_sweep, m)?)?;
    m.add_function(wrap_pyfunction!(sweep, m)?)?;
    m.add_function(wrap_pyfunction!(read_dataset, m)?)?;
    m.add_function(wrap_pyfunction!(read_params, m)?)?;
    m.add_function(wrap_pyfunction!(read_runs, m)?)?;
    m.add_function(wrap_pyfunction!(read_layout, m)?)?;
    m.add_function(wrap_pyfunction!(prepare_estimator, m)?)?;
    m.add_function(wrap_pyfunction!(estimate_json, m)?)?;
    m.add_function(wrap_pyfunction!(emulate_measurement, m)?)?;
    m.add("ScenarioError", m.py().get_type::<ScenarioError>())?;
    m.add("SimulationError", m.py().get_type::<SimulationError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
