//! From a sweep file to the list of runs: the base scenario, the parameter values of every run
//! (grid, random or Latin hypercube from the sweep seed), each run's noise seed, and the
//! scenario of one run (the base with its parameters written at their paths, then validated).

use crate::spec::{ModelKind, Parameter, Sampling, SweepSpec};
use lash_core::Problems;
use lash_scenario::AnyScenario;
use lash_scenario::paths::{EditError, set_path};
use rand::seq::SliceRandom;
use rand::{Rng, RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sha2::{Digest, Sha256};

/// One run of the sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSpec {
    /// Run id (0-based, dense).
    pub id: u64,
    /// The parameter values, in the order of the sweep file's parameters.
    pub values: Vec<f64>,
    /// Seed of the run's measurement noise, derived from (sweep seed, run id).
    pub seed: u64,
}

/// A checked sweep: the base scenario (TOML table) and all runs.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The sweep file.
    pub spec: SweepSpec,
    /// The sweep file's text (recorded in the manifest).
    pub text: String,
    /// The base scenario (planar or spatial), with the sweep's horizon and sampling applied.
    pub base: AnyScenario,
    /// The base prepared for the runs' edits.
    edits: lash_scenario::paths::EditBase,
    /// Every run.
    pub runs: Vec<RunSpec>,
    /// Hex SHA-256 of the base scenario (as serialized TOML).
    pub scenario_hash: String,
    /// Hex SHA-256 identifying the sweep: sweep file + base scenario + lash version.
    pub sweep_hash: String,
}

/// Seed of run `id`: the first word of the ChaCha8 stream `id` keyed by the sweep seed.
/// Independent of thread count, shard and order of execution.
pub fn run_seed(sweep_seed: u64, id: u64) -> u64 {
    let mut rng = ChaCha8Rng::seed_from_u64(sweep_seed);
    rng.set_stream(id);
    rng.next_u64()
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

impl Plan {
    /// Checks the sweep against its base scenario and lists the runs. Every problem found is
    /// reported with its field path; nothing is run.
    pub fn new(spec: SweepSpec, text: String, base: AnyScenario) -> Result<Self, Problems> {
        let mut base = base;
        let mut p = sampling(&spec, &mut base);
        // The base itself (with the sweep's horizon and sampling) must be valid; the sweep's
        // channels are checked below under their own field names. Its own emulated measurements
        // are the scenario's business, not the dataset's: a sweep samples channels — unless a
        // channel names one of their logged axes (`housing.ay`), which the sweep then logs from
        // its force through each run's own mount (whose parameters the sweep may vary).
        let measurements = std::mem::take(&mut base.output_mut().measurements);
        p.extend_prefixed("base", base.validate());
        let mut simulated: Vec<String> = Vec::new();
        for c in &spec.output.channels {
            let name = measured_force(&measurements, c).unwrap_or(c).to_string();
            if !simulated.contains(&name) {
                simulated.push(name);
            }
        }
        base.output_mut().channels = simulated;
        if spec.output.channels.iter().any(|c| measured_force(&measurements, c).is_some()) {
            base.output_mut().measurements = measurements.clone();
        }
        if spec.model == ModelKind::Reduced && base.interface_count() == 0 {
            p.push(
                "model",
                "the reduced model needs at least one clearance joint, guide or bushing; the base has none".to_string(),
            );
        }
        let base_table: toml::Table = match base.to_table() {
            Ok(t) => t,
            Err(e) => {
                p.push("base", format!("cannot be written as TOML: {e}"));
                return Err(p);
            }
        };
        // Every path must name an existing numeric field of the base.
        for (k, par) in spec.parameters.iter().enumerate() {
            let mut t = base_table.clone();
            if let Err(m) = set_path(&mut t, &par.path, 0.0) {
                p.push(format!("parameters[{k}].path"), m.to_string());
            }
        }
        let known: Vec<String> = base
            .channels(false)
            .into_iter()
            .map(|c| c.name)
            .chain(measurements.iter().flat_map(|m| m.channel_names()))
            .collect();
        for (i, c) in spec.output.channels.iter().enumerate() {
            if !known.iter().any(|k| k == c) {
                p.push(
                    format!("output.channels[{i}]"),
                    format!("{c:?} is not a channel of the base scenario (known: {})", known.join(", ")),
                );
            }
        }
        if p.is_empty() && spec.model == ModelKind::Reduced {
            // Step sizes, sampling and horizon must fit the reduced model's integer time grid:
            // building its runner for the base checks them once, before any run.
            let refused = lash_run::runner(&base, lash_run::Model::Reduced(reduced_options(&spec, &base))).err();
            if let Some(e) = refused {
                let field = if e.to_string().contains("output_interval") { "output.sample_rate" } else { "model" };
                p.push(field, format!("the reduced model refuses the base scenario: {e}"));
            }
        }
        if !p.is_empty() {
            return Err(p);
        }
        let runs = design(&spec);
        let scenario_toml = toml::to_string(&base_table).unwrap_or_default();
        let scenario_hash = hex(&Sha256::digest(scenario_toml.as_bytes()));
        let mut h = Sha256::new();
        h.update(env!("CARGO_PKG_VERSION").as_bytes());
        h.update([0]);
        h.update(serde_json::to_string(&spec).unwrap_or_default().as_bytes());
        h.update([0]);
        h.update(scenario_toml.as_bytes());
        let sweep_hash = hex(&h.finalize());
        let edits = lash_scenario::paths::EditBase::new(base_table);
        Ok(Self { spec, text, base, edits, runs, scenario_hash, sweep_hash })
    }

    /// Parameter paths, in order.
    pub fn parameter_paths(&self) -> Vec<String> {
        self.spec.parameters.iter().map(|p| p.path.clone()).collect()
    }

    /// The scenario of one run: the base with the run's values at their paths, validated.
    pub fn scenario(&self, run: &RunSpec) -> Result<AnyScenario, RunScenarioError> {
        let edits = self.spec.parameters.iter().map(|p| p.path.as_str()).zip(run.values.iter().copied());
        self.edits.edited(edits).map_err(|e| match e {
            EditError::Path(e) => RunScenarioError::Path(e),
            EditError::Invalid(p) => RunScenarioError::Invalid(p),
        })
    }
}

/// Why a run's values do not make a scenario.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RunScenarioError {
    /// A parameter path that names no number of the base scenario.
    #[error(transparent)]
    Path(#[from] lash_scenario::paths::PathError),
    /// The values together make an invalid scenario (every problem, with its field).
    #[error("invalid parameter combination: {0}")]
    Invalid(Problems),
}

/// Applies the sweep's horizon and sampling to `base`; the problems of the sampling.
fn sampling(spec: &SweepSpec, base: &mut AnyScenario) -> Problems {
    let mut p = Problems::new();
    if let Some(h) = spec.horizon {
        base.simulation_mut().horizon = h;
    }
    if spec.output.anti_alias.is_none() {
        base.simulation_mut().output_interval = 1.0 / spec.output.sample_rate;
    } else {
        // Sampled at the base's own interval, low-passed and decimated after each run.
        let dt = base.simulation_mut().output_interval;
        let ratio = 1.0 / (spec.output.sample_rate * dt);
        if (ratio - ratio.round()).abs() > 1e-9 * ratio || ratio.round() < 1.0 {
            p.push(
                "output.sample_rate",
                format!("with anti_alias, 1/sample_rate must be a whole multiple of the base's output_interval {dt} s"),
            );
        }
    }
    p
}

/// The force channel that drives `channel` when it is a logged axis of one of `measurements`
/// (`housing.ay` → `slider_guide.fy`), with the mount it drives.
pub fn measured_axis<'a>(
    measurements: &'a [lash_scenario::schema::MeasurementSpec],
    channel: &str,
) -> Option<(&'a str, lash_measure::Mount)> {
    measurements.iter().find_map(|m| {
        m.channel_names().iter().position(|n| n == channel).map(|axis| (m.forces[axis].as_str(), m.mount))
    })
}

/// The force channel of [`measured_axis`] alone.
pub fn measured_force<'a>(
    measurements: &'a [lash_scenario::schema::MeasurementSpec],
    channel: &str,
) -> Option<&'a str> {
    measured_axis(measurements, channel).map(|(force, _)| force)
}

/// Options of the reduced model for this sweep of `base`: the file's steps, or without them the
/// defaults `lash run` takes — the macro step from the base scenario's fastest rotation
/// ([`lash_run::macro_step_for_rotation`]), once for every run, so that runs at other speeds
/// still share it (and their lanes), and the micro step of 1e-5 s.
pub fn reduced_options(spec: &SweepSpec, base: &AnyScenario) -> lash_run::ReducedOptions {
    // (A run's summary is not part of the dataset: only its channels are computed.)
    let mut options = lash_run::ReducedOptions { channels_only: true, ..Default::default() };
    match spec.reduced {
        Some(r) => {
            options.macro_step = r.macro_step;
            options.micro_step = r.micro_step;
        }
        None => {
            let fastest = base.fastest_rotation();
            options.macro_step = lash_run::macro_step_for_rotation(options.macro_step, options.micro_step, fastest).0;
        }
    }
    options
}

/// A parameter's listed values: `values`, or `linspace`'s points (none for a `uniform` one).
fn listed(p: &Parameter) -> Vec<f64> {
    if let Some(v) = &p.values {
        return v.clone();
    }
    if let Some(l) = p.linspace {
        if l.count == 1 {
            return vec![l.start];
        }
        return (0..l.count).map(|i| l.start + (l.stop - l.start) * i as f64 / (l.count - 1) as f64).collect();
    }
    Vec::new()
}

/// `n` runs of a Latin hypercube over `pars` (one stratum of each parameter per run, shuffled
/// by `rng`; a listed parameter takes the value of its stratum's share of the list).
fn latin_hypercube(pars: &[Parameter], n: usize, rng: &mut ChaCha8Rng) -> Vec<Vec<f64>> {
    let mut columns: Vec<Vec<f64>> = Vec::with_capacity(pars.len());
    for p in pars {
        let mut strata: Vec<usize> = (0..n).collect();
        strata.shuffle(rng);
        let col = strata
            .iter()
            .map(|&s| {
                let u = (s as f64 + rng.random::<f64>()) / n as f64;
                match p.uniform {
                    Some(r) => r.low + (r.high - r.low) * u,
                    None => {
                        let l = listed(p);
                        l[((u * l.len() as f64) as usize).min(l.len() - 1)]
                    }
                }
            })
            .collect();
        columns.push(col);
    }
    (0..n).map(|i| columns.iter().map(|c| c[i]).collect()).collect()
}

/// The runs' parameter values.
fn design(spec: &SweepSpec) -> Vec<RunSpec> {
    let pars = &spec.parameters;
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    // Stream u64::MAX is reserved for the design; runs use streams 0, 1, 2, …
    rng.set_stream(u64::MAX);
    let values: Vec<Vec<f64>> = match spec.sampling {
        Sampling::Rows => {
            let rows = spec.run_count() as usize;
            (0..rows).map(|i| pars.iter().map(|p| listed(p)[i]).collect()).collect()
        }
        Sampling::Grid => {
            let axes: Vec<Vec<f64>> = pars.iter().map(listed).collect();
            let total: usize = axes.iter().map(Vec::len).product();
            (0..total)
                .map(|mut i| {
                    let mut v = vec![0.0; axes.len()];
                    for (k, axis) in axes.iter().enumerate().rev() {
                        v[k] = axis[i % axis.len()];
                        i /= axis.len();
                    }
                    v
                })
                .collect()
        }
        Sampling::Random => {
            let n = spec.runs.unwrap_or(0) as usize;
            (0..n)
                .map(|_| {
                    pars.iter()
                        .map(|p| match p.uniform {
                            Some(r) => rng.random_range(r.low..r.high),
                            None => {
                                let l = listed(p);
                                l[rng.random_range(0..l.len())]
                            }
                        })
                        .collect()
                })
                .collect()
        }
        Sampling::LatinHypercube => latin_hypercube(pars, spec.runs.unwrap_or(0) as usize, &mut rng),
    };
    values
        .into_iter()
        .enumerate()
        .map(|(i, values)| RunSpec { id: i as u64, values, seed: run_seed(spec.seed, i as u64) })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(text: &str) -> Result<Plan, Problems> {
        let spec = SweepSpec::parse(text)?;
        Plan::new(spec, text.to_string(), AnyScenario::Planar(lash_scenario::builtin::by_name("A").unwrap()))
    }

    const GRID: &str = r#"
base = "A"
[output]
channels = ["slider.ax"]
sample_rate = 10000.0
[[parameters]]
path = "clearances[0].bearing_radius"
values = [0.01005, 0.0101]
[[parameters]]
path = "drivers[0].motion.omega"
linspace = { start = 400.0, stop = 600.0, count = 3 }
"#;

    #[test]
    fn rows_take_the_ith_value_of_every_parameter_and_must_agree_in_count() {
        let rows = GRID
            .replace("base = \"A\"", "base = \"A\"\nsampling = \"rows\"")
            .replace("linspace = { start = 400.0, stop = 600.0, count = 3 }", "values = [400.0, 500.0]");
        let p = plan(&rows).unwrap();
        let values: Vec<Vec<f64>> = p.runs.iter().map(|r| r.values.clone()).collect();
        assert_eq!(values, vec![vec![0.01005, 400.0], vec![0.0101, 500.0]]);
        let uneven = rows.replace("values = [400.0, 500.0]", "values = [400.0, 500.0, 600.0]");
        let problems = plan(&uneven).expect_err("refused").to_string();
        assert!(problems.contains("parameters[1].values") && problems.contains("3 values"), "{problems}");
    }

    #[test]
    fn grid_is_the_cartesian_product_last_fastest() {
        let p = plan(GRID).unwrap();
        let v: Vec<Vec<f64>> = p.runs.iter().map(|r| r.values.clone()).collect();
        assert_eq!(v.len(), 6);
        assert_eq!(v[0], vec![0.01005, 400.0]);
        assert_eq!(v[1], vec![0.01005, 500.0]);
        assert_eq!(v[3], vec![0.0101, 400.0]);
        let s = p.scenario(&p.runs[4]).unwrap();
        let AnyScenario::Planar(s) = s else { panic!("planar base") };
        assert_eq!(s.clearances[0].bearing_radius, 0.0101);
    }

    #[test]
    fn latin_hypercube_puts_one_point_in_every_stratum() {
        let text = GRID
            .replace("values = [0.01005, 0.0101]", "uniform = { low = 0.0, high = 1.0 }")
            .replace("linspace = { start = 400.0, stop = 600.0, count = 3 }", "uniform = { low = 400.0, high = 600.0 }")
            .replace("base = \"A\"", "base = \"A\"\nsampling = \"latin_hypercube\"\nruns = 50\nseed = 3");
        // The strata are what is checked here; the design does not need valid scenarios.
        let p = plan(&text).unwrap();
        for k in 0..2 {
            let (lo, hi) = if k == 0 { (0.0, 1.0) } else { (400.0, 600.0) };
            let mut strata: Vec<usize> =
                p.runs.iter().map(|r| ((r.values[k] - lo) / (hi - lo) * 50.0) as usize).collect();
            strata.sort();
            assert_eq!(strata, (0..50).collect::<Vec<_>>(), "parameter {k}");
        }
        // Same seed, same design; another seed, another design.
        let again = plan(&text).unwrap();
        assert_eq!(again.runs, p.runs);
        let other = plan(&text.replace("seed = 3", "seed = 4")).unwrap();
        assert_ne!(other.runs[0].values, p.runs[0].values);
    }

    #[test]
    fn unknown_paths_and_channels_are_errors_naming_the_field() {
        let text =
            GRID.replace("drivers[0].motion.omega", "drivers[0].motion.omga").replace("\"slider.ax\"", "\"slider.az\"");
        let e = plan(&text).unwrap_err().to_string();
        assert!(e.contains("parameters[1].path") && e.contains("omga") && e.contains("omega"), "{e}");
        assert!(e.contains("output.channels[0]"), "{e}");
        let e = plan(&GRID.replace("drivers[0].motion.omega", "clearances[0].joint")).unwrap_err().to_string();
        assert!(e.contains("not a number"), "{e}");
        let e = plan(&GRID.replace("drivers[0].motion.omega", "drivers[3].motion.omega")).unwrap_err().to_string();
        assert!(e.contains("out of range"), "{e}");
    }

    #[test]
    fn an_invalid_combination_is_a_per_run_error() {
        let p = plan(&GRID.replace("values = [0.01005, 0.0101]", "values = [0.01005, 0.009]")).unwrap();
        let e = p.scenario(&p.runs[3]).unwrap_err();
        let RunScenarioError::Invalid(problems) = &e else { panic!("{e}") };
        assert!(
            problems.0.iter().any(|p| p.field.contains("bearing_radius") || p.field.contains("journal_radius")),
            "{e}"
        );
        assert!(p.scenario(&p.runs[0]).is_ok());
    }

    #[test]
    fn run_seeds_depend_on_sweep_seed_and_run_id_only() {
        assert_eq!(run_seed(7, 12), run_seed(7, 12));
        assert_ne!(run_seed(7, 12), run_seed(7, 13));
        assert_ne!(run_seed(7, 12), run_seed(8, 12));
    }
}
