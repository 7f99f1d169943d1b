//! The sweep file (TOML): a base scenario, the parameters to vary by their scenario path, how to
//! sample them, the model and the sensor-like output.
//!
//! ```toml
//! base = "A"                    # a built-in scenario or a scenario file (relative to this file)
//! model = "reduced"             # reduced | full
//! sampling = "latin_hypercube"  # grid | random | latin_hypercube
//! runs = 200                    # for random and latin_hypercube
//! seed = 7
//! horizon = 0.1                 # optional: overrides simulation.horizon \[s\]
//!
//! [output]
//! channels = ["slider.ax"]
//! sample_rate = 10000.0         # Hz; 1/sample_rate must be a multiple of the model's step
//! noise = { "slider.ax" = 50.0 }  # standard deviation of additive Gaussian noise, channel units
//! anti_alias = { cutoff = 4000.0, order = 4 }  # optional: sample finer, low-pass, decimate
//! clean = true                  # optional: also store each channel without noise (<name>.clean)
//!
//! [[parameters]]
//! path = "clearances[0].bearing_radius"
//! uniform = { low = 0.01005, high = 0.0102 }
//! ```

use lash_core::Problems;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Which model each run integrates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ModelKind {
    /// The reduced interface model (default settings: h_m as `lash run` chooses it, h_r = 1e-5 s,
    /// RK4 micro).
    #[default]
    Reduced,
    /// The full model with the scenario's integrator.
    Full,
}

/// How the parameter values of the runs are chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Sampling {
    /// Cartesian product of every parameter's `values` / `linspace` (the last varies fastest).
    #[default]
    Grid,
    /// `runs` independent draws (uniform ranges, or a uniform choice among listed values).
    Random,
    /// `runs` points of a Latin hypercube: each parameter's range cut into `runs` equal strata,
    /// one point per stratum, strata paired by random permutations.
    LatinHypercube,
    /// A design matrix: every parameter's `values` hold one value per run (the same count for
    /// all; run i takes the i-th of each), as a table of designed experiments lists them.
    Rows,
}

/// `count` evenly spaced values from `start` to `stop` (both included).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Linspace {
    /// First value.
    pub start: f64,
    /// Last value.
    pub stop: f64,
    /// Number of values (≥ 1).
    pub count: u64,
}

/// A uniform range [low, high).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Range {
    /// Lower bound.
    pub low: f64,
    /// Upper bound.
    pub high: f64,
}

/// One varied parameter: a numeric field of the scenario and its values (exactly one of
/// `values`, `linspace`, `uniform`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Parameter {
    /// Scenario path, e.g. `clearances[0].bearing_radius`, `drivers[0].speed`,
    /// `clearances[0].friction.coefficient`.
    pub path: String,
    /// Listed values.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub values: Option<Vec<f64>>,
    /// Evenly spaced values.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub linspace: Option<Linspace>,
    /// A continuous range (random and Latin-hypercube sampling).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uniform: Option<Range>,
}

/// Channels and sensor-like sampling of the dataset.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Output {
    /// Channel names (as in `lash run` outputs); at least one.
    pub channels: Vec<String>,
    /// Sampling rate \[Hz\].
    pub sample_rate: f64,
    /// Standard deviation of additive Gaussian measurement noise per channel [channel units].
    #[serde(default)]
    pub noise: BTreeMap<String, f64>,
    /// Also write `data.csv` (the Parquet table is always written).
    #[serde(default)]
    pub csv: bool,
    /// A logger's anti-alias low-pass before the sampling: the runs are sampled at the base
    /// scenario's own output interval, filtered and decimated to `sample_rate` (without it, the
    /// runs are sampled at `sample_rate` directly, and content above half of it aliases).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub anti_alias: Option<AntiAlias>,
    /// Also store every channel without noise, as `<channel>.clean`.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub clean: bool,
}

/// The anti-alias filter of the dataset's sampling.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AntiAlias {
    /// Cut-off (−3 dB) \[Hz\], below half the sample rate.
    pub cutoff: f64,
    /// Butterworth order (even).
    #[serde(default = "default_order")]
    pub order: usize,
}

fn default_order() -> usize {
    4
}

/// Reduced-model step sizes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReducedSteps {
    /// Macro step h_m \[s\].
    pub macro_step: f64,
    /// Micro step h_r \[s\].
    pub micro_step: f64,
}

/// A sweep file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    /// Built-in scenario name or scenario file path (relative to the sweep file).
    pub base: String,
    /// Model of every run.
    #[serde(default)]
    pub model: ModelKind,
    /// How the runs' parameter values are chosen.
    #[serde(default)]
    pub sampling: Sampling,
    /// Number of runs (random and Latin-hypercube sampling).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub runs: Option<u64>,
    /// Sweep seed: parameter sampling and every run's noise seed derive from it.
    #[serde(default)]
    pub seed: u64,
    /// Overrides the base scenario's horizon \[s\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub horizon: Option<f64>,
    /// Reduced-model step sizes (defaults: as `lash run` takes them — 1e-3 s or less, at most 16°
    /// of the base scenario's fastest rotation per macro step — and 1e-5 s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reduced: Option<ReducedSteps>,
    /// Output channels and sampling.
    pub output: Output,
    /// The varied parameters (at least one).
    pub parameters: Vec<Parameter>,
}

impl SweepSpec {
    /// The number of runs the design lists: the product of the listed values' counts for a grid,
    /// `runs` otherwise.
    pub fn run_count(&self) -> u64 {
        match self.sampling {
            Sampling::Rows => self.parameters.first().and_then(|p| p.values.as_ref()).map_or(0, |v| v.len() as u64),
            Sampling::Grid => self
                .parameters
                .iter()
                .map(|p| match (&p.values, p.linspace) {
                    (Some(v), _) => v.len() as u64,
                    (None, Some(l)) => l.count,
                    _ => 0,
                })
                .fold(1u64, u64::saturating_mul),
            _ => self.runs.unwrap_or(0),
        }
    }

    /// Parses a sweep file, reporting every problem with its field path.
    pub fn parse(text: &str) -> Result<Self, Problems> {
        let spec: SweepSpec = toml::from_str(text).map_err(|e| {
            let mut p = Problems::new();
            let field = e.span().map(|s| field_at(text, s.start)).unwrap_or_else(|| "(file)".into());
            p.push(field, e.message().trim_end().to_string());
            p
        })?;
        let problems = spec.check();
        if problems.is_empty() { Ok(spec) } else { Err(problems) }
    }

    /// Checks everything that does not need the base scenario.
    pub fn check(&self) -> Problems {
        let mut p = Problems::new();
        if self.base.trim().is_empty() {
            p.push("base", "must name a built-in scenario or a scenario file");
        }
        if let Some(h) = self.horizon {
            p.positive("horizon", h);
        }
        if let Some(r) = self.reduced {
            p.positive("reduced.macro_step", r.macro_step);
            p.positive("reduced.micro_step", r.micro_step);
        }
        if self.model == ModelKind::Full && self.reduced.is_some() {
            p.push("reduced", "only applies to model = \"reduced\"");
        }
        p.positive("output.sample_rate", self.output.sample_rate);
        if self.output.channels.is_empty() {
            p.push("output.channels", "name at least one channel");
        }
        if let Some(a) = self.output.anti_alias {
            let logger = lash_measure::Acquisition {
                sample_rate: self.output.sample_rate,
                cutoff: a.cutoff,
                order: a.order,
                settle: 0.0,
            };
            p.extend_prefixed("output.anti_alias", logger.validate());
        }
        for (name, sigma) in &self.output.noise {
            p.non_negative(format!("output.noise.{name}"), *sigma);
            if !self.output.channels.contains(name) {
                p.push(format!("output.noise.{name}"), "is not one of output.channels");
            }
        }
        match (self.sampling, self.runs) {
            (Sampling::Grid | Sampling::Rows, Some(_)) => {
                p.push("runs", "grid and rows sampling take their run count from the parameter values; remove runs")
            }
            (Sampling::Random | Sampling::LatinHypercube, None) => {
                p.push("runs", "random and latin_hypercube sampling need runs = N")
            }
            (_, Some(0)) => p.push("runs", "must be ≥ 1"),
            _ => {}
        }
        if self.parameters.is_empty() {
            p.push("parameters", "vary at least one parameter ([[parameters]] with path and values)");
        }
        for k in 0..self.parameters.len() {
            self.check_parameter(k, &mut p);
        }
        p
    }

    /// The problems of parameter `k` (its path unique, one kind of values, finite, fit for the
    /// sampling).
    fn check_parameter(&self, k: usize, p: &mut Problems) {
        let par = &self.parameters[k];
        let f = |x: &str| format!("parameters[{k}].{x}");
        if self.parameters[..k].iter().any(|q| q.path == par.path) {
            p.push(f("path"), format!("{:?} is varied twice", par.path));
        }
        let given = [par.values.is_some(), par.linspace.is_some(), par.uniform.is_some()];
        if given.iter().filter(|g| **g).count() != 1 {
            p.push(f("values"), "give exactly one of values, linspace, uniform");
            return;
        }
        if self.sampling == Sampling::Rows && par.values.is_none() {
            p.push(f("values"), "rows sampling lists every run's value: give values (one per run)");
        }
        if let Some(v) = &par.values {
            if v.is_empty() {
                p.push(f("values"), "must not be empty");
            }
            let rows = self.run_count() as usize;
            if self.sampling == Sampling::Rows && v.len() != rows {
                p.push(
                    f("values"),
                    format!("rows sampling: {} values where parameters[0] has {rows} (one per run)", v.len()),
                );
            }
            for (i, x) in v.iter().enumerate() {
                p.finite(format!("parameters[{k}].values[{i}]"), *x);
            }
        }
        if let Some(l) = par.linspace {
            p.finite(f("linspace.start"), l.start);
            p.finite(f("linspace.stop"), l.stop);
            if l.count == 0 {
                p.push(f("linspace.count"), "must be ≥ 1");
            }
        }
        if let Some(r) = par.uniform {
            p.finite(f("uniform.low"), r.low);
            p.finite(f("uniform.high"), r.high);
            if !(r.low < r.high) {
                p.push(f("uniform"), format!("needs low < high, got [{}, {}]", r.low, r.high));
            }
            if self.sampling == Sampling::Grid {
                p.push(f("uniform"), "a continuous range cannot be gridded: use linspace, or sampling = \"random\"");
            }
        }
    }
}

/// The dotted key of the TOML line holding byte `offset` (best effort, for error messages).
fn field_at(text: &str, offset: usize) -> String {
    let upto = &text[..offset.min(text.len())];
    let mut table = String::new();
    for line in upto.lines() {
        let l = line.trim();
        if l.starts_with('[') {
            table = l.trim_matches(|c| c == '[' || c == ']').to_string();
        }
    }
    let line = upto.lines().last().unwrap_or("");
    let key = line.split('=').next().unwrap_or("").trim();
    match (table.is_empty(), key.is_empty() || key.starts_with('[')) {
        (true, true) => "(file)".into(),
        (true, false) => key.into(),
        (false, true) => table,
        (false, false) => format!("{table}.{key}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
base = "A"
sampling = "random"
runs = 4
[output]
channels = ["slider.ax"]
sample_rate = 10000.0
[[parameters]]
path = "clearances[0].bearing_radius"
uniform = { low = 0.01005, high = 0.0102 }
"#;

    #[test]
    fn a_good_file_parses() {
        let s = SweepSpec::parse(GOOD).unwrap();
        assert_eq!(s.runs, Some(4));
        assert_eq!(s.model, ModelKind::Reduced);
    }

    #[test]
    fn every_problem_is_listed_with_its_field() {
        let bad = GOOD.replace("runs = 4", "").replace("10000.0", "-1.0").replace("low = 0.01005", "low = 0.03");
        let p = SweepSpec::parse(&bad).unwrap_err().to_string();
        for field in ["runs", "output.sample_rate", "parameters[0].uniform"] {
            assert!(p.contains(field), "{field} missing in: {p}");
        }
    }

    #[test]
    fn unknown_keys_are_named() {
        let p = SweepSpec::parse(&GOOD.replace("runs = 4", "runs = 4\nsamples = 3")).unwrap_err().to_string();
        assert!(p.contains("samples"), "{p}");
    }
}
