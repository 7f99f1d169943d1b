//! The `lash` command line.
//!
//! ```text
//! lash run <scenario-file|A|B|…> [--model full|reduced] [--ideal] --out <dir>
//! lash run <system.toml|system.ssd|system.ssp> --out <dir>   # a coupled system of FMUs/plugins
//! lash compare <scenario> --out <dir>  # full (converged) vs reduced, comparison.json
//! lash validate <scenario-file>
//! lash scenarios                 # list the built-in scenarios
//! lash show <name>               # print a built-in scenario as TOML
//! lash channels <scenario>       # list output channels
//! lash bench [--quick] [sweep]   # benchmarks (full and reduced models; or sweep throughput)
//! lash bench fmu <file.fmu>      # one step of any FMU through lash's importer
//! lash sweep <sweep-file> --out <dir> [--shard i/N] [--threads N] [--quiet]
//! lash sweep merge <dir>... --out <dir>
//! lash fmu pack [SCENARIO] --out <dir>  # FMI 3.0 and 2.0 FMUs of a scenario's subsystems
//! lash fmu check <file.fmu>      # structure + smoke simulation of an FMI 3.0 or 2.0 FMU
//! lash estimate prepare [A|C|setup.toml] --out prepared.json   # one-time preparation
//! lash estimate <measured.csv> --prepared prepared.json [--out <dir>]  # clearance, worn joint, nuisances
//! lash estimate validate --prepared prepared.json [--cases 200]  # held-out full-model cases
//! ```
//!
//! Exit codes: 0 success, 1 simulation or output failure, 2 invalid input.

mod bench;
mod bush;
mod compare;
pub mod estimate;
mod fmu;
pub mod limits;
mod output;
mod plots;
pub mod probe;
mod realisations;
mod run;
mod steady;
pub mod sweep;
pub mod system;

use clap::{Parser, Subcommand, ValueEnum};
use std::process::ExitCode;

/// lash: co-simulation of mechanisms with joint clearances.
#[derive(Parser, Debug)]
#[command(name = "lash", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// Which model to run.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum ModelKind {
    /// The full (monolithic) multibody model with contact, integrated to convergence.
    Full,
    /// The reduced interface model (macro ideal mechanism + micro clearance interface).
    Reduced,
}

/// Interpolation across the macro step (reduced model).
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum InterpolationArg {
    /// Linear between the nodes at both ends (default).
    Linear,
    /// Cubic Hermite (slopes from neighbouring nodes).
    Hermite,
    /// Zero-order hold (for study: produces spurious impacts).
    Zoh,
}

/// Coupling of the reduced model.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum CouplingArg {
    /// One-way, unless the error estimate finds that one-way coupling alone moves a main
    /// channel's RMS level past the stated 10 % and two-way coupling is the closer to the
    /// converged full model over the probe window: then the run is made again in two-way (default).
    Auto,
    /// The ideal mechanism's motion is the real one (the reduced-interface-model papers' method).
    OneWay,
    /// The averaged contact force acts back on the mechanism.
    TwoWay,
}

/// Micro integrator of the reduced model.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum MicroArg {
    /// Fixed-step RK4 at --micro-step.
    Rk4,
    /// Error-controlled DOPRI5 with contact events (communication every --micro-step).
    Dopri5,
}

/// Settings of the reduced model.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct ReducedArgs {
    /// Reduced model: macro step h_m \[s\]. Without it, 1e-3 s or the largest step below it
    /// (5e-4, 4e-4, 2.5e-4, …, a whole number of micro steps) in which the fastest body of the
    /// mechanism turns by at most 16° (5e-4 s at 5000 rpm).
    #[arg(long)]
    macro_step: Option<f64>,
    /// Reduced model: micro step h_r \[s\]. Without it, 1e-5 s or the largest step below it
    /// (5e-6, 4e-6, 2.5e-6, …, dividing the macro step and the output interval) that gives each
    /// clearance joint's impacts at least 7 steps, by their median duration in the converged
    /// full model over the error estimate's window.
    #[arg(long)]
    micro_step: Option<f64>,
    /// Reduced model: interpolation of the macro terms across a macro step.
    #[arg(long, value_enum, default_value_t = InterpolationArg::Linear)]
    interpolation: InterpolationArg,
    /// Reduced model: one-way (as in the reduced-interface-model papers) or two-way coupling, or
    /// lash's choice from the error estimate.
    #[arg(long, value_enum, default_value_t = CouplingArg::Auto)]
    coupling: CouplingArg,
    /// Reduced model: run the macro subsystem on its own thread (one-way only; same results).
    #[arg(long)]
    threaded: bool,
    /// Reduced model: micro integrator.
    #[arg(long, value_enum, default_value_t = MicroArg::Rk4)]
    micro: MicroArg,
}

impl ReducedArgs {
    /// The run as asked for.
    fn request(&self) -> ReducedRequest {
        ReducedRequest {
            options: self.options(),
            micro_step_given: self.micro_step.is_some(),
            macro_step_given: self.macro_step.is_some(),
            coupling_auto: self.coupling == CouplingArg::Auto,
        }
    }

    fn options(&self) -> lash_run::ReducedOptions {
        lash_run::ReducedOptions {
            macro_step: self.macro_step.unwrap_or(lash_run::ReducedOptions::default().macro_step),
            micro_step: self.micro_step.unwrap_or(lash_run::ReducedOptions::default().micro_step),
            interpolation: match self.interpolation {
                InterpolationArg::Linear => lash_orchestrate::Interpolation::Linear,
                InterpolationArg::Hermite => lash_orchestrate::Interpolation::CubicHermite,
                InterpolationArg::Zoh => lash_orchestrate::Interpolation::ZeroOrderHold,
            },
            coupling: match self.coupling {
                CouplingArg::OneWay | CouplingArg::Auto => lash_core::Coupling::OneWay,
                CouplingArg::TwoWay => lash_core::Coupling::TwoWay,
            },
            execution: if self.threaded {
                lash_orchestrate::Execution::Threaded
            } else {
                lash_orchestrate::Execution::Sequential
            },
            error_controlled_micro: self.micro == MicroArg::Dopri5,
            channels_only: false,
        }
    }
}

/// The reduced run's probe: the converged full model over the run's first quarter.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct ProbeArgs {
    /// Reduced model: skip the error estimate (the converged full model over the run's first
    /// quarter, compared on the main channels; in summary.json as error_estimate).
    #[arg(long)]
    no_error_estimate: bool,
    /// Reduced model: the largest RMS level error (e.g. 0.05) allowed on the main channels
    /// against the converged full model over the error estimate's window; finer macro and
    /// micro steps are taken until it is met or stops improving (summary.json: tolerance).
    #[arg(long)]
    tolerance: Option<f64>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run a scenario and write timeseries.csv (or .parquet), summary.json and scenario.toml to --out.
    Run {
        /// A scenario file (TOML) or a built-in name (see `lash scenarios`); or a system file
        /// (TOML with `[[elements]]`, an SSP `.ssd` or `.ssp`).
        scenario: String,
        /// Model to run.
        #[arg(long, value_enum, default_value_t = ModelKind::Full)]
        model: ModelKind,
        /// Treat every clearance joint as an ideal revolute joint.
        #[arg(long)]
        ideal: bool,
        /// Output directory (created if missing).
        #[arg(long)]
        out: std::path::PathBuf,
        /// Override the horizon \[s\] (a system file: the stop time).
        #[arg(long)]
        horizon: Option<f64>,
        /// System files: the communication step \[s\] (overrides the file's).
        #[arg(long)]
        step: Option<f64>,
        /// File format of the time series: timeseries.csv or timeseries.parquet.
        #[arg(long, value_enum, default_value_t = output::Format::Csv)]
        format: output::Format,
        #[command(flatten)]
        reduced: ReducedArgs,
        #[command(flatten)]
        probe: ProbeArgs,
        /// No progress bar.
        #[arg(long)]
        quiet: bool,
    },
    /// Run the converged full model and the reduced model of a scenario; write both runs
    /// (full/, reduced/) and comparison.json (CPU times, speedup, peaks, RMS, pointwise and
    /// spectral errors, band powers, impact statistics).
    Compare {
        /// A scenario file (TOML) or a built-in name.
        scenario: String,
        /// Output directory.
        #[arg(long)]
        out: std::path::PathBuf,
        /// Override the horizon \[s\].
        #[arg(long)]
        horizon: Option<f64>,
        #[command(flatten)]
        reduced: ReducedArgs,
        /// No progress bar.
        #[arg(long)]
        quiet: bool,
        /// Also write OUT/report.html (as `lash report OUT`).
        #[arg(long)]
        report: bool,
        /// Hold the stated bounds against N converged realisations of the full model (its atol
        /// moved up by 0…N−1 rounding steps): where a pin rattles chaotically, each is another
        /// draw of the run's statistics, and a check reads "met against m of N".
        #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=64))]
        realisations: u32,
    },
    /// Write one self-contained HTML page of a run's or a comparison's folder: the mechanism
    /// animated, each clearance joint's orbit, every channel over time and crank angle, spectra.
    Report {
        /// The folder of `lash run --out` or `lash compare --out`.
        dir: std::path::PathBuf,
        /// The page [default: DIR/report.html].
        #[arg(long)]
        out: Option<std::path::PathBuf>,
    },
    /// Check a scenario, sweep or system file and list every problem.
    Validate {
        /// Scenario file or built-in name; or a sweep file (every run's scenario is checked); or a
        /// system file (TOML, .ssd or .ssp: its elements are loaded, not stepped).
        scenario: String,
    },
    /// List the built-in scenarios.
    Scenarios,
    /// Print a built-in scenario as a TOML scenario file.
    Show {
        /// Built-in name.
        name: String,
    },
    /// List the output channels of a scenario.
    Channels {
        /// Scenario file or built-in name.
        scenario: String,
        /// Channels of the ideal model.
        #[arg(long)]
        ideal: bool,
    },
    /// FMI: build the .fmu archives of lash's subsystems.
    Fmu {
        #[command(subcommand)]
        command: FmuCommand,
    },
    /// Benchmarks: cost of one RK4 step of the full model of scenario B, and wall time of the
    /// converged adaptive run of B over 0.036 s.
    Bench {
        /// Fewer repetitions.
        #[arg(long)]
        quick: bool,
        /// `sweep`: throughput of reduced-model sweeps of scenarios A and E (1 vs 2 threads, one run at a time vs side by side) instead;
        /// `fmu <file.fmu>`: the cost of one step of an FMU through lash's importer.
        #[arg(value_parser = ["sweep", "fmu"])]
        what: Option<String>,
        /// The FMU of `lash bench fmu`.
        file: Option<std::path::PathBuf>,
        /// `lash bench fmu`: also measure the FMU in a child process (isolated).
        #[arg(long)]
        isolate: bool,
    },
    /// Characterise a flexible bush by finite elements: bonded-pin and Hertz-pressure stiffness,
    /// Kelvin–Voigt damping, interface von Mises stress against Hertz (the study's bush without a
    /// file).
    Bush {
        /// A bush file (TOML: `[bush]` with radii, length, material, and `loads = [...]` in N).
        file: Option<std::path::PathBuf>,
        /// Print the table as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Parameter sweep of a scenario into a Parquet dataset (data.parquet, params.parquet,
    /// manifest.json): parallel, resumable (re-run the same command), shardable.
    #[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
    Sweep {
        #[command(subcommand)]
        command: Option<SweepCommand>,
        /// The sweep file (TOML; see examples/sweep-*.toml).
        #[arg(required = true)]
        file: Option<std::path::PathBuf>,
        /// Output folder (new, empty, or holding this sweep: then it resumes).
        #[arg(long, required = true)]
        out: Option<std::path::PathBuf>,
        /// Run only shard i of N (runs with id mod N = i), e.g. --shard 0/4.
        #[arg(long)]
        shard: Option<String>,
        /// Worker threads (default: one per core).
        #[arg(long)]
        threads: Option<usize>,
        /// Runs each worker simulates side by side (default 8: reduced runs with one clearance
        /// joint step their micro models together in vector lanes); 1: one at a time. The data
        /// are the same bit for bit either way.
        #[arg(long)]
        side_by_side: Option<usize>,
        /// No progress bar (batch systems).
        #[arg(long)]
        quiet: bool,
    },
    /// Diagnose a machine from its vibration: the clearance of each clearance joint, the worn
    /// joint and the nuisances, with calibrated 90 % intervals, from a measured CSV or Parquet file.
    #[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
    Estimate {
        #[command(subcommand)]
        command: Option<EstimateCommand>,
        /// The measured file: a time column `time [s]` and the setup's channels with units.
        #[arg(required = true)]
        measurement: Option<std::path::PathBuf>,
        /// The prepared estimator (`lash estimate prepare`).
        #[arg(long, required = true)]
        prepared: Option<std::path::PathBuf>,
        /// Folder for estimate.json and posterior.svg.
        #[arg(long)]
        out: Option<std::path::PathBuf>,
        /// Time each joint's impacts sample by sample with a particle filter of this many
        /// particles on the micro model (planar setups whose sensor the model propagates; about
        /// 10 s per 128 particles and second of C's measurement on two cores). Without it, the
        /// onsets are where most re-simulated draws begin a contact.
        #[arg(long, value_name = "PARTICLES")]
        track_impacts: Option<usize>,
        /// With --track-impacts: a filter on each of this many best-aligned posterior draws, the
        /// particles shared among them, the one that follows the measurement best reported
        /// (default 4).
        #[arg(long, value_name = "DRAWS", requires = "track_impacts")]
        track_draws: Option<usize>,
    },
}

/// `lash estimate …` subcommands.
#[derive(Subcommand, Debug)]
enum EstimateCommand {
    /// One-time preparation for a setup (built-in A, C or E, or a setup TOML file): a reduced-model
    /// sweep over the priors, the fit, a calibration on full-model runs; stored as JSON.
    Prepare {
        /// Built-in setup (A, C, E) or setup file.
        #[arg(default_value = "A")]
        setup: String,
        /// The prepared estimator's file.
        #[arg(long)]
        out: std::path::PathBuf,
        /// Reduced-model runs of the bank (default: the setup's).
        #[arg(long)]
        bank_runs: Option<u64>,
        /// Full-model runs of the calibration (default: the setup's).
        #[arg(long)]
        calibration_runs: Option<u64>,
        /// Full-model cases of the hidden signals' band calibration (default: the setup's; 0: none).
        #[arg(long)]
        hidden_runs: Option<u64>,
        /// No progress lines.
        #[arg(long)]
        quiet: bool,
    },
    /// Held-out cases from the converged full model, with seeds the preparation never used:
    /// relative RMSE, interval coverage, worn-joint accuracy, time per estimate.
    Validate {
        /// The prepared estimator.
        #[arg(long)]
        prepared: std::path::PathBuf,
        /// Held-out cases.
        #[arg(long, default_value_t = 200)]
        cases: u64,
        /// Seed of the held-out runs and measurements.
        #[arg(long, default_value_t = 20_261_128)]
        seed: u64,
        /// Held-out cases of the reduced model (the bank's own model) instead of the full one:
        /// tells the method's error from the reduced model's.
        #[arg(long)]
        reduced: bool,
        /// Score the hidden signals instead (the virtual sensor: each joint's contact force and
        /// eccentricity against the full model's, impact onsets), at this signal-to-noise ratio [dB].
        #[arg(long, value_name = "SNR_DB", conflicts_with = "reduced")]
        hidden: Option<f64>,
        /// With --hidden: time the impacts with the particle filter of this many particles (as
        /// `lash estimate --track-impacts`).
        #[arg(long, value_name = "PARTICLES", requires = "hidden")]
        track_impacts: Option<usize>,
        /// With --track-impacts: the draws filtered (as `lash estimate --track-draws`).
        #[arg(long, value_name = "DRAWS", requires = "track_impacts")]
        track_draws: Option<usize>,
        /// Folder for validation.json.
        #[arg(long)]
        out: Option<std::path::PathBuf>,
        /// No progress lines.
        #[arg(long)]
        quiet: bool,
    },
    /// One measurement of the converged full model as the setup's logger records it (CSV), to try
    /// the estimator on a machine whose clearance you choose.
    Emulate {
        /// The prepared estimator (its setup).
        #[arg(long)]
        prepared: std::path::PathBuf,
        /// Radial clearance of each clearance joint [m], comma-separated.
        #[arg(long, value_delimiter = ',', required = true)]
        clearance: Vec<f64>,
        /// Crank speed [rad/s] (default: the scenario's).
        #[arg(long)]
        speed: Option<f64>,
        /// Crank angle at the start [rad].
        #[arg(long, default_value_t = 1.0)]
        angle: f64,
        /// Sensor gain.
        #[arg(long, default_value_t = 1.0)]
        gain: f64,
        /// Signal-to-noise ratio [dB].
        #[arg(long, default_value_t = 40.0)]
        snr: f64,
        /// Seed of the noise.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// The CSV to write.
        #[arg(long)]
        out: std::path::PathBuf,
    },
}

/// `lash sweep …` subcommands.
#[derive(Subcommand, Debug)]
enum SweepCommand {
    /// Combine the complete output folders of all shards of one sweep into one dataset.
    Merge {
        /// The shard output folders.
        #[arg(required = true)]
        inputs: Vec<std::path::PathBuf>,
        /// Output folder of the merged dataset.
        #[arg(long)]
        out: std::path::PathBuf,
    },
}

/// `lash fmu …` subcommands.
#[derive(Subcommand, Debug)]
enum FmuCommand {
    /// Write the FMI 3.0 and 2.0 co-simulation FMUs of a scenario (clearance interface sized by its
    /// clearance joints, mechanism, full model) into --out; the scenario travels in each archive's
    /// resources/scenario.toml.
    Pack {
        /// A scenario file (TOML) or a built-in name; without it, scenario A with the slider and motor
        /// channels probed.
        scenario: Option<String>,
        /// Output directory.
        #[arg(long)]
        out: std::path::PathBuf,
    },
    /// Check an FMI 3.0 or 2.0 co-simulation FMU: archive, modelDescription.xml, binary, symbols, token,
    /// and a 10-step smoke simulation.
    Check {
        /// The .fmu file.
        fmu: std::path::PathBuf,
        /// Run the FMU in a child process: a crash or a hang is reported, not inherited.
        #[arg(long)]
        isolate: bool,
        /// With --isolate: the longest wait for one call \[s\].
        #[arg(long, default_value_t = 60.0)]
        timeout: f64,
    },
    /// (internal) Serve one FMU to a parent lash over standard input and output: the child
    /// process of an isolated element.
    #[command(hide = true)]
    Host {
        /// The .fmu file.
        fmu: std::path::PathBuf,
        /// Where FMUs are unpacked.
        #[arg(long)]
        cache: std::path::PathBuf,
        /// The element's name.
        #[arg(long)]
        name: String,
    },
}

/// Errors that decide the exit code.
#[derive(Debug)]
pub enum CliError {
    /// Invalid input (exit 2).
    Input(String),
    /// Failure while running or writing (exit 1).
    Failure(String),
    /// Ended by SIGINT/SIGTERM, saying what was kept (exit 130).
    Interrupted(String),
}

impl std::fmt::Display for CliError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CliError::Input(m) | CliError::Failure(m) | CliError::Interrupted(m) => f.write_str(m.trim_end()),
        }
    }
}

impl From<lash_sweep::dataset::DatasetError> for CliError {
    /// A file lash writes or reads back failed (exit 1).
    fn from(e: lash_sweep::dataset::DatasetError) -> Self {
        CliError::Failure(e.to_string())
    }
}

impl From<lash_catalog::CatalogError> for CliError {
    /// An exported model lash itself describes could not be made (exit 1).
    fn from(e: lash_catalog::CatalogError) -> Self {
        CliError::Failure(lash_core::error_chain(&e))
    }
}

/// Loads a scenario from a built-in name or a file path.
pub fn load_scenario(arg: &str) -> Result<lash_scenario::Scenario, CliError> {
    lash_scenario::by_name_or_file(arg).map_err(|e| CliError::Input(e.to_string()))
}

/// Runs the command line with the process arguments.
pub fn main() -> ExitCode {
    quiet_on_broken_pipe();
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() { ExitCode::from(2) } else { ExitCode::SUCCESS };
        }
    };
    match dispatch(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            match e {
                CliError::Input(_) => ExitCode::from(2),
                CliError::Failure(_) => ExitCode::from(1),
                CliError::Interrupted(_) => ExitCode::from(130),
            }
        }
    }
}

/// A reader that stops reading (`lash scenarios | head -3`) ends lash quietly, as a Unix tool ends
/// on SIGPIPE (exit 141), instead of a panic report from `println!`.
fn quiet_on_broken_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let message = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if message.starts_with("failed printing to stdout") && message.contains("Broken pipe") {
            std::process::exit(141);
        }
        default(info);
    }));
}

/// A reduced run as asked for: its options (one-way coupling under `--coupling auto`), whether
/// the macro and the micro step were given (else lash chooses them), and whether lash chooses the
/// coupling.
#[derive(Debug, Clone, Copy)]
pub struct ReducedRequest {
    /// The options, each step the default when none was given.
    pub options: lash_run::ReducedOptions,
    /// Whether the user gave the micro step.
    pub micro_step_given: bool,
    /// Whether the user gave the macro step.
    pub macro_step_given: bool,
    /// `--coupling auto`: where the error estimate finds one-way coupling's own error past the
    /// stated bound, the coupling closer to the converged full model over the probe window
    /// ([`probe::estimate_and_choose_coupling`]).
    pub coupling_auto: bool,
}

impl ReducedRequest {
    /// The macro step for `s` when none was given ([`lash_run::macro_step_for_rotation`] from the
    /// default, at the micro step given or the default one), with why it is not the default;
    /// printed unless `quiet`. One home for `lash run`, `lash compare` and Python.
    pub fn choose_macro_step(&mut self, s: &lash_scenario::AnyScenario, quiet: bool) -> Option<String> {
        if self.macro_step_given {
            return None;
        }
        let o = &mut self.options;
        let (h, why) = lash_run::macro_step_for_rotation(o.macro_step, o.micro_step, s.fastest_rotation());
        o.macro_step = h;
        if let (Some(why), false) = (&why, quiet) {
            eprintln!("note: {why}");
        }
        why
    }
}

/// `lash compare` (also the Python package's `lash.compare`): the runs, figures and
/// comparison.json in `out` (the bounds against `realisations` converged realisations of the
/// full model), and with `report` the page `out/report.html`.
pub fn compare_into(
    s: &lash_scenario::AnyScenario,
    out: &std::path::Path,
    request: ReducedRequest,
    realisations: usize,
    quiet: bool,
    report: bool,
) -> Result<(), CliError> {
    compare::run(s, out, request, realisations, quiet)?;
    if report { write_report(out, None) } else { Ok(()) }
}

/// What `lash run --model reduced` was asked for.
struct ReducedSettings {
    request: ReducedRequest,
    tolerance: Option<f64>,
    error_estimate: bool,
}

impl ReducedSettings {
    /// The settings, or what is wrong with `--tolerance`.
    fn checked(self) -> Result<Self, CliError> {
        match self.tolerance {
            Some(t) if !(t > 0.0 && t.is_finite()) => {
                Err(CliError::Input(format!("--tolerance {t}: must be a positive fraction (0.05 for 5 %)")))
            }
            Some(t) if !self.error_estimate => Err(CliError::Input(format!(
                "--tolerance {t}: it is met against the error estimate's probe, which --no-error-estimate skips"
            ))),
            _ => Ok(self),
        }
    }
}

/// `lash run --model reduced`: the converged full model over the probe window first (for the
/// error estimate, for the micro step when the user gave none, and for `--tolerance`), then the
/// run, then the estimate and how the steps were chosen into its summary.json.
fn run_reduced(
    s: &lash_scenario::AnyScenario,
    settings: ReducedSettings,
    out: &std::path::Path,
    format: output::Format,
    quiet: bool,
) -> Result<(), CliError> {
    let mut request = settings.request;
    let macro_step_choice = request.choose_macro_step(s, quiet);
    let ReducedRequest { mut options, micro_step_given, coupling_auto, .. } = request;
    let probe = (settings.error_estimate || !micro_step_given).then(|| {
        probe::FullProbe::run(s, options.macro_step, settings.error_estimate).map_err(probe::NoEstimate::from)
    });
    let mut notes = serde_json::Map::new();
    if let Some(why) = macro_step_choice {
        notes.insert("macro_step_choice".into(), why.into());
    }
    match &probe {
        Some(Ok(p)) => {
            options = steps_from_probe(p, options, (micro_step_given, settings.tolerance), &mut notes, quiet)?;
        }
        Some(Err(e)) if settings.tolerance.is_some() => {
            return Err(CliError::Failure(format!("--tolerance: the full model's probe failed: {e}")));
        }
        Some(Err(e)) if !micro_step_given => {
            eprintln!("warning: the micro step stays {:e} s: the full model's probe failed: {e}", options.micro_step);
        }
        _ => {}
    }
    let run_once = |options: lash_run::ReducedOptions| -> Result<lash_run::Summary, CliError> {
        let model = lash_run::Model::Reduced(options);
        let mut r = lash_run::runner(s, model).map_err(|e| CliError::Input(format!("--model reduced: {e}")))?;
        run::run(s, (s.simulation(), s.output()), &mut r, out, format, quiet).map(|(_, summary)| summary)
    };
    let summary = run_once(options)?;
    if !micro_step_given
        && !options.error_controlled_micro
        && let Some((finer, why)) =
            lash_run::micro_step_for_unheld_contacts(&summary, &options, s.simulation().output_interval)
    {
        if !quiet {
            eprintln!("note: {why}");
        }
        notes.insert("micro_step_refined".into(), why.into());
        options.micro_step = finer;
        run_once(options)?;
    }
    let estimated = match probe.as_ref().filter(|_| settings.error_estimate) {
        Some(p) => {
            let rerun = |o| run_once(o).map(|_| ());
            let estimated = probe::estimate_and_choose_coupling(p, options, coupling_auto, quiet, rerun)?;
            if let Some(why) = estimated.coupling_choice {
                notes.insert("coupling_choice".into(), why.into());
            }
            Some(estimated.estimate)
        }
        None if coupling_auto => {
            let why = "one-way: --coupling auto chooses from the error estimate, which --no-error-estimate skips";
            notes.insert("coupling_choice".into(), why.into());
            None
        }
        None => None,
    };
    probe::attach(estimated, notes, out, quiet)
}

/// The reduced run's options after the full model's probe `p`: the micro step chosen from its
/// impacts (unless `micro_step_given` or the micro step is error-controlled), then the settings
/// that meet `tolerance` where one is asked for; each choice noted in `notes`.
fn steps_from_probe(
    p: &probe::FullProbe,
    mut options: lash_run::ReducedOptions,
    (micro_step_given, tolerance): (bool, Option<f64>),
    notes: &mut serde_json::Map<String, serde_json::Value>,
    quiet: bool,
) -> Result<lash_run::ReducedOptions, CliError> {
    // (DOPRI5 locates every contact itself: its communication step is kept.)
    if !micro_step_given && !options.error_controlled_micro {
        let (h, why) = p.micro_step(options);
        options.micro_step = h;
        if let Some(why) = why {
            if !quiet {
                eprintln!("note: {why}");
            }
            notes.insert("micro_step_choice".into(), why.into());
        }
    }
    if let Some(tolerance) = tolerance {
        let (chosen, search) = p.meet_tolerance(options, tolerance, 8).map_err(|e| CliError::Failure(e.to_string()))?;
        options = chosen;
        eprintln!("{}", search.line());
        notes.insert("tolerance".into(), serde_json::to_value(&search).map_err(|e| CliError::Failure(e.to_string()))?);
    }
    Ok(options)
}

/// `lash report`: the page, and what it could not show.
pub fn write_report(dir: &std::path::Path, out: Option<&std::path::Path>) -> Result<(), CliError> {
    let written = lash_report::write_report(dir, out).map_err(|e| match e {
        lash_report::ReportError::Input(m) => CliError::Input(m),
        other => CliError::Failure(other.to_string()),
    })?;
    println!(
        "report of {} ({}): {} ({:.1} MB)",
        dir.display(),
        written.runs.join(", "),
        written.path.display(),
        written.bytes as f64 / 1e6
    );
    for note in &written.notes {
        println!("  note: {note}");
    }
    Ok(())
}

/// A scenario (built-in or file, planar or spatial) with a `--horizon` override, validated again.
fn load_with_horizon(arg: &str, horizon: Option<f64>) -> Result<lash_scenario::AnyScenario, CliError> {
    let mut s = lash_scenario::any_by_name_or_file(arg).map_err(|e| CliError::Input(e.to_string()))?;
    if let Some(h) = horizon {
        s.simulation_mut().horizon = h;
        let p = s.validate();
        if !p.is_empty() {
            return Err(CliError::Input(format!("--horizon {h}: {p}")));
        }
    }
    Ok(s)
}

/// `lash validate` of a scenario (a built-in's name or a file): its kind and its counts.
fn validate_scenario(scenario: &str) -> Result<(), CliError> {
    let (kind, bodies, joints, clearances) =
        match lash_scenario::any_by_name_or_file(scenario).map_err(|e| CliError::Input(e.to_string()))? {
            lash_scenario::AnyScenario::Planar(s) => ("planar", s.bodies.len(), s.joints.len(), s.clearances.len()),
            lash_scenario::AnyScenario::Spatial(s) => ("spatial", s.bodies.len(), s.joints.len(), s.clearances.len()),
        };
    println!("{scenario}: valid ({kind}; {bodies} bodies, {joints} joints, {clearances} clearance joints)");
    Ok(())
}

/// `lash scenarios`: each built-in's name and the first words of its description.
fn list_builtins() {
    for name in lash_scenario::builtin::NAMES {
        let s = lash_scenario::builtin::by_name(name).expect("listed");
        let first = s.description.split(':').next().unwrap_or("");
        println!("{name:30} {first}");
    }
    for name in lash_scenario::builtin_spatial::SPATIAL_NAMES {
        let s = lash_scenario::builtin_spatial::spatial_by_name(name).expect("listed");
        let first = s.description.split(". ").next().unwrap_or("");
        println!("{name:30} {first}");
    }
}

/// `lash show`: a built-in scenario as a TOML file.
fn show_builtin(name: &str) -> Result<(), CliError> {
    let (description, text) =
        match (lash_scenario::builtin::by_name(name), lash_scenario::builtin_spatial::spatial_by_name(name)) {
            (Some(s), _) => (s.description.split(':').next().unwrap_or("").to_string(), toml::to_string(&s)),
            (None, Some(s)) => (s.description.split(". ").next().unwrap_or("").to_string(), toml::to_string(&s)),
            (None, None) => {
                return Err(CliError::Input(format!(
                    "no built-in scenario {name:?} (built-ins: {}, {})",
                    lash_scenario::builtin::NAMES.join(", "),
                    lash_scenario::builtin_spatial::SPATIAL_NAMES.join(", ")
                )));
            }
        };
    println!("# lash scenario {name}: {description}");
    println!("# SI units throughout (m, kg, kg m^2, s, rad, N, Pa). Written by `lash show {name}`.");
    print!("{}", text.map_err(|e| CliError::Failure(e.to_string()))?);
    Ok(())
}

/// `lash channels`: a scenario's output channels with their units.
fn print_channels(scenario: &str, ideal: bool) -> Result<(), CliError> {
    let channels = match lash_scenario::any_by_name_or_file(scenario).map_err(|e| CliError::Input(e.to_string()))? {
        lash_scenario::AnyScenario::Planar(s) => lash_scenario::channels(&s, ideal),
        lash_scenario::AnyScenario::Spatial(s) => {
            lash_scenario::spatial::spatial_channels(&s, ideal).into_iter().map(|(c, _)| c).collect()
        }
    };
    for c in channels {
        println!("{} [{}]", c.name, c.unit);
    }
    Ok(())
}

/// `lash estimate prepare | validate | emulate`.
fn estimate_command(command: EstimateCommand) -> Result<(), CliError> {
    match command {
        EstimateCommand::Prepare { setup, out, bank_runs, calibration_runs, hidden_runs, quiet } => {
            estimate::prepare(&setup, &out, estimate::Sizes { bank_runs, calibration_runs, hidden_runs }, quiet)
        }
        EstimateCommand::Validate {
            prepared,
            cases,
            seed,
            reduced: _,
            hidden: Some(snr),
            track_impacts,
            track_draws,
            out,
            quiet,
        } => estimate::validate_hidden(
            &prepared,
            (cases, seed, snr),
            (track_impacts, track_draws),
            out.as_deref(),
            quiet,
        ),
        EstimateCommand::Validate { prepared, cases, seed, reduced, hidden: None, out, quiet, .. } => {
            estimate::validate(&prepared, (cases, reduced), seed, out.as_deref(), quiet)
        }
        EstimateCommand::Emulate { prepared, clearance, speed, angle, gain, snr, seed, out } => {
            let case = lash_estimate::prepare::Case { clearances: clearance, speed, angle0: angle, gain, snr, seed };
            estimate::emulate(&prepared, &case, &out)
        }
    }
}

/// `lash run`: a system file, or a scenario's full, ideal or reduced run.
fn run_command(command: Command) -> Result<(), CliError> {
    let Command::Run { scenario, model, ideal, out, horizon, step, format, reduced, probe, quiet } = command else {
        unreachable!("dispatched as lash run")
    };
    output::catch_interrupts();
    if system::is_system(&scenario) {
        return system::run(&scenario, &out, step, horizon, format, quiet);
    }
    if step.is_some() {
        return Err(CliError::Input("--step is for system files; scenarios set their integrator".into()));
    }
    let s = load_with_horizon(&scenario, horizon)?;
    let model = match model {
        ModelKind::Full => lash_run::Model::Full { ideal },
        ModelKind::Reduced if ideal => {
            return Err(CliError::Input("--ideal and --model reduced exclude each other".into()));
        }
        ModelKind::Reduced => lash_run::Model::Reduced(reduced.options()),
    };
    let lash_run::Model::Reduced(options) = model else {
        let mut r = lash_run::runner(&s, model).map_err(|e| CliError::Input(e.to_string()))?;
        return run::run(&s, (s.simulation(), s.output()), &mut r, &out, format, quiet).map(|_| ());
    };
    let settings = ReducedSettings {
        request: ReducedRequest { options, ..reduced.request() },
        tolerance: probe.tolerance,
        error_estimate: !probe.no_error_estimate,
    };
    run_reduced(&s, settings.checked()?, &out, format, quiet)
}

/// Runs one command of the command line.
fn dispatch(command: Command) -> Result<(), CliError> {
    match command {
        command @ Command::Run { .. } => run_command(command),
        Command::Compare { scenario, out, horizon, reduced, quiet, report, realisations } => {
            let s = load_with_horizon(&scenario, horizon)?;
            compare_into(&s, &out, reduced.request(), realisations as usize, quiet, report)
        }
        Command::Report { dir, out } => write_report(&dir, out.as_deref()),
        Command::Validate { scenario } if system::is_system(&scenario) => {
            println!("{}", system::validate(&scenario)?);
            Ok(())
        }
        Command::Validate { scenario } if sweep::is_sweep(&scenario) => {
            println!("{}", sweep::validate(std::path::Path::new(&scenario))?);
            Ok(())
        }
        Command::Validate { scenario } => validate_scenario(&scenario),
        Command::Bush { file, json } => bush::run(file.as_deref(), json),
        Command::Scenarios => {
            list_builtins();
            Ok(())
        }
        Command::Show { name } => show_builtin(&name),
        Command::Channels { scenario, ideal } => print_channels(&scenario, ideal),
        Command::Bench { quick, what, file, isolate } => match (what.as_deref(), file) {
            (Some("sweep"), None) => bench::sweep(quick),
            (Some("fmu"), Some(file)) => bench::fmu(&file, quick, isolate),
            (Some("fmu"), None) => Err(CliError::Input("lash bench fmu: give the .fmu file".into())),
            (_, Some(file)) => Err(CliError::Input(format!("lash bench: unexpected argument {}", file.display()))),
            _ => bench::run(quick),
        },
        Command::Sweep { command: Some(SweepCommand::Merge { inputs, out }), .. } => sweep::merge(&inputs, &out),
        Command::Sweep { command: None, file, out, shard, threads, side_by_side, quiet } => match (file, out) {
            (Some(file), Some(out)) => sweep::run(&file, &out, (shard.as_deref(), threads, side_by_side), quiet),
            _ => Err(CliError::Input("lash sweep: give a sweep file and --out <dir>".into())),
        },
        Command::Estimate { command: Some(command), .. } => estimate_command(command),
        Command::Estimate { command: None, measurement, prepared, out, track_impacts, track_draws } => {
            match (measurement, prepared) {
                (Some(m), Some(p)) => estimate::estimate(&m, &p, out.as_deref(), (track_impacts, track_draws)),
                _ => Err(CliError::Input("lash estimate: give a measured file and --prepared <file>".into())),
            }
        }
        Command::Fmu { command: FmuCommand::Pack { scenario, out } } => {
            let scenario = match scenario {
                Some(arg) => lash_scenario::any_by_name_or_file(&arg).map_err(|e| CliError::Input(e.to_string()))?,
                None => lash_scenario::AnyScenario::Planar(lash_catalog::default_scenario()?),
            };
            fmu::pack(&scenario, &out)
        }
        Command::Fmu { command: FmuCommand::Check { fmu, isolate, timeout } } => fmu::check(&fmu, isolate, timeout),
        Command::Fmu { command: FmuCommand::Host { fmu, cache, name } } => {
            std::process::exit(lash_fmi::isolate::serve(&fmu, &cache, &name))
        }
    }
}
