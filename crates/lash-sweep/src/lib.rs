//! Data generation at scale: parameter sweeps of a scenario into a Parquet dataset.
//!
//! * [`spec`]: the sweep file; [`plan`](mod@plan): the runs (grid, random, Latin hypercube; seeds);
//! * [`execute`]: runs a sweep (or one shard of it) in parallel with rayon — every run is
//!   independent and seeded from (sweep seed, run id), so results do not depend on the thread
//!   count —, writes each finished run at once (resumable), and assembles the dataset;
//! * [`merge`]: combines the output folders of all shards into the single-machine dataset;
//! * [`dataset`]: the files.

pub mod dataset;
pub mod plan;
pub mod spec;

use arrow_array::RecordBatch;
use dataset::{ChannelInfo, DatasetError, Manifest, ParamsRow, RunData, RunRecord, RunSource, Shard};
pub use plan::{Plan, RunSpec, run_seed};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use rayon::prelude::*;
use spec::ModelKind;
pub use spec::SweepSpec;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Why a sweep could not run.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// The sweep file, its base scenario or the options are wrong (nothing was run).
    #[error("{0}")]
    Input(String),
    /// The output folder could not be made or tidied, or runs of the shard did not finish.
    #[error("{0}")]
    Output(String),
    /// Reading or writing the dataset failed.
    #[error(transparent)]
    Dataset(#[from] dataset::DatasetError),
    /// Cancelled through [`ExecuteOptions::cancel`]: the finished runs are kept (journal and parts),
    /// and running the sweep again into the same folder resumes it.
    #[error("{0}")]
    Interrupted(String),
}

/// How to run a sweep.
#[derive(Debug, Clone)]
pub struct ExecuteOptions {
    /// Output folder.
    pub out: PathBuf,
    /// Run only this shard.
    pub shard: Option<Shard>,
    /// Worker threads (None: rayon's default, one per core).
    pub threads: Option<usize>,
    /// Set it to stop the sweep: runs in flight finish, no new run starts, and the execution
    /// returns [`SweepError::Interrupted`] with the folder resumable.
    pub cancel: Option<std::sync::Arc<AtomicBool>>,
    /// Runs a worker simulates side by side ([`SIDE_BY_SIDE`]; 1: one at a time) — reduced runs
    /// with one clearance joint step their micro models together in vector lanes, each with the
    /// result it has alone. A sweep with fewer runs than workers × this runs them one at a time.
    pub side_by_side: usize,
}

/// Runs a worker simulates side by side by default: as many as the micro models' vector lanes.
pub const SIDE_BY_SIDE: usize = lash_micro::lanes::LANES;

/// What happened to runs, for progress display.
#[derive(Debug, Clone, Copy)]
pub enum Event {
    /// The sweep starts: runs in this shard, and how many of them are already complete.
    Start {
        /// Runs of the shard.
        total: u64,
        /// Already complete (skipped).
        done: u64,
    },
    /// A run finished.
    Finished {
        /// Whether it succeeded.
        ok: bool,
    },
}

/// Totals of an execution.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct Report {
    /// Runs in the shard.
    pub runs: u64,
    /// Already complete before (skipped).
    pub skipped: u64,
    /// Run now.
    pub ran: u64,
    /// Failed (recorded), over the whole shard.
    pub failed: u64,
    /// Wall time \[s\].
    pub wall_s: f64,
    /// Sum over runs of simulation time \[s\] (all threads).
    pub simulate_s: f64,
    /// Sum over runs of part-writing time \[s\] (all threads).
    pub write_s: f64,
    /// Time spent assembling data.parquet and params.parquet \[s\].
    pub assemble_s: f64,
    /// Simulated mechanism time of the runs done now \[s\].
    pub simulated_s: f64,
    /// Threads used.
    pub threads: usize,
}

/// Loads a sweep file and its base scenario into a checked [`Plan`].
pub fn load(path: &Path) -> Result<Plan, SweepError> {
    plan(path, read(path)?)
}

/// The checked [`Plan`] of what [`read`] returned for `path` (named in the errors).
pub fn plan(
    path: &Path,
    (spec, text, base): (SweepSpec, String, lash_scenario::AnyScenario),
) -> Result<Plan, SweepError> {
    Plan::new(spec, text, base).map_err(|p| SweepError::Input(format!("invalid sweep file {}: {p}", path.display())))
}

/// Reads a sweep file (its own fields checked) and its base scenario, without listing the runs:
/// what a caller needs to size the job before [`Plan::new`] does the work.
pub fn read(path: &Path) -> Result<(SweepSpec, String, lash_scenario::AnyScenario), SweepError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| SweepError::Input(format!("cannot read sweep file {}: {e}", path.display())))?;
    let spec = SweepSpec::parse(&text)
        .map_err(|p| SweepError::Input(format!("invalid sweep file {}: {p}", path.display())))?;
    let builtin = lash_scenario::builtin::by_name(&spec.base).map(lash_scenario::AnyScenario::Planar).or_else(|| {
        lash_scenario::builtin_spatial::spatial_by_name(&spec.base).map(lash_scenario::AnyScenario::Spatial)
    });
    let base = match builtin {
        Some(s) => s,
        None => {
            let file = path.parent().unwrap_or(Path::new(".")).join(&spec.base);
            let t = std::fs::read_to_string(&file).map_err(|e| {
                SweepError::Input(format!(
                    "invalid sweep file {}: base: {:?} is neither a built-in scenario ({}) nor a readable file ({}: {e})",
                    path.display(),
                    spec.base,
                    lash_scenario::builtin::NAMES.join(", "),
                    file.display()
                ))
            })?;
            lash_scenario::parse_any(&t)
                .map_err(|p| SweepError::Input(format!("invalid base scenario {}: {p}", file.display())))?
        }
    };
    Ok((spec, text, base))
}

/// Parses `i/N` (0 ≤ i < N).
pub fn parse_shard(text: &str) -> Result<Shard, ShardError> {
    let bad = |problem: String| ShardError { text: text.to_string(), problem };
    let (i, n) = text.split_once('/').ok_or_else(|| bad("expected i/N, e.g. 0/4".into()))?;
    let number = |s: &str| s.trim().parse::<u64>().map_err(|_| bad(format!("{s:?} is not a whole number")));
    let (index, count) = (number(i)?, number(n)?);
    if count == 0 || index >= count {
        return Err(bad(format!("need 0 ≤ i < N, got i = {index}, N = {count}")));
    }
    Ok(Shard { index, count })
}

/// A `--shard` that is not `i/N` with 0 ≤ i < N.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("--shard {text:?}: {problem}")]
pub struct ShardError {
    /// What was given.
    pub text: String,
    /// What is wrong with it.
    pub problem: String,
}

/// The channels (name, unit) a run of the plan writes, in dataset order: the channels (with their
/// noise), then, with `clean = true`, each again without noise as `<name>.clean`.
fn channel_infos(plan: &Plan) -> Vec<ChannelInfo> {
    let all = plan.base.channels(false);
    let measurements = &plan.base.output().measurements;
    let unit = |name: &String| match plan::measured_force(measurements, name) {
        Some(_) => "m/s^2".to_string(),
        None => all.iter().find(|c| &c.name == name).map(|c| c.unit.to_string()).unwrap_or_default(),
    };
    let measured = plan.spec.output.channels.iter().map(|name| ChannelInfo { name: name.clone(), unit: unit(name) });
    let clean = plan
        .spec
        .output
        .channels
        .iter()
        .filter(|_| plan.spec.output.clean)
        .map(|name| ChannelInfo { name: format!("{name}.clean"), unit: unit(name) });
    measured.chain(clean).collect()
}

fn new_manifest(plan: &Plan, shard: Option<Shard>) -> Manifest {
    Manifest {
        lash_version: env!("CARGO_PKG_VERSION").to_string(),
        sweep_hash: plan.sweep_hash.clone(),
        scenario_hash: plan.scenario_hash.clone(),
        sweep_file: plan.text.clone(),
        seed: plan.spec.seed,
        total_runs: plan.runs.len() as u64,
        shard,
        channels: channel_infos(plan),
        parameters: plan.parameter_paths(),
        reduced: (plan.spec.model == ModelKind::Reduced).then(|| {
            let o = plan::reduced_options(&plan.spec, &plan.base);
            spec::ReducedSteps { macro_step: o.macro_step, micro_step: o.micro_step }
        }),
        status: "running".into(),
        runs: Vec::new(),
    }
}

/// What a run keeps of its runner's rows: where its channels are in them, the loggers of its
/// emulated measurement, and the samples kept so far.
struct Simulation {
    horizon: f64,
    index: Vec<usize>,
    /// Per channel, the mount its force drives (a measurement's logged axis) or None.
    mounts: Vec<Option<lash_measure::MountResponse>>,
    loggers: Vec<lash_measure::Logger>,
    data: RunData,
}

impl Simulation {
    /// The runner of run `run` of `plan`, and what keeps its `channels`.
    fn new(plan: &Plan, run: &RunSpec, channels: &[ChannelInfo]) -> Result<(lash_run::AnyRunner, Self), String> {
        let mut scenario = plan.scenario(run).map_err(|e| e.to_string())?;
        // The runner samples the forces; the sweep emulates the measurement as they stream.
        let measurements = std::mem::take(&mut scenario.output_mut().measurements);
        let (horizon, output_interval) = match &scenario {
            lash_scenario::AnyScenario::Planar(s) => (s.simulation.horizon, s.simulation.output_interval),
            lash_scenario::AnyScenario::Spatial(s) => (s.simulation.horizon, s.simulation.output_interval),
        };
        let model = match plan.spec.model {
            ModelKind::Full => lash_run::Model::Full { ideal: false },
            ModelKind::Reduced => lash_run::Model::Reduced(plan::reduced_options(&plan.spec, &plan.base)),
        };
        let runner = lash_run::runner(&scenario, model).map_err(|e| e.to_string())?;
        let header = runner.header();
        let name_of = |h: &String| h.split(" [").next().unwrap_or(h).to_string();
        // The simulated channels (the clean copies, if any, follow them in `channels`).
        let simulated = &channels[..plan.spec.output.channels.len()];
        let index: Vec<usize> = simulated
            .iter()
            .map(|c| {
                let name = plan::measured_force(&measurements, &c.name).unwrap_or(&c.name);
                header.iter().position(|h| name_of(h) == name).ok_or_else(|| format!("channel {name} not produced"))
            })
            .collect::<Result<_, _>>()?;
        let mounts = simulated
            .iter()
            .map(|c| plan::measured_axis(&measurements, &c.name).map(|(_, mount)| mount.response(output_interval)))
            .collect();
        // With an anti-alias filter the samples stream through the logger of each channel
        // (low-pass, decimation to the sample rate) as the run produces them: only the logged
        // rows are held.
        let loggers = match plan.spec.output.anti_alias {
            Some(a) => {
                let logger = lash_measure::Acquisition {
                    sample_rate: plan.spec.output.sample_rate,
                    cutoff: a.cutoff,
                    order: a.order,
                    settle: 0.0,
                };
                vec![logger.logger(output_interval).map_err(|e| e.to_string())?; index.len()]
            }
            None => Vec::new(),
        };
        // (Room for every row from the start: the run's samples are pushed one by one.)
        let interval = if loggers.is_empty() { output_interval } else { 1.0 / plan.spec.output.sample_rate };
        let rows = ((horizon / interval).ceil() as usize).saturating_add(2).min(1 << 24);
        let data = RunData {
            run_id: run.id,
            time: Vec::with_capacity(rows),
            columns: simulated.iter().map(|_| Vec::with_capacity(rows)).collect(),
        };
        Ok((runner, Self { horizon, index, mounts, loggers, data }))
    }

    /// Keeps a row of the runner (its channels, or what their loggers log).
    fn keep(&mut self, row: &[f64]) {
        let data = &mut self.data;
        let mut logged = false;
        for (k, (col, &i)) in data.columns.iter_mut().zip(&self.index).enumerate() {
            let value = match &mut self.mounts[k] {
                Some(mount) => mount.push(row[i]),
                None => row[i],
            };
            let kept = match self.loggers.get_mut(k) {
                Some(logger) => logger.push(value),
                None => Some(value),
            };
            if let Some(y) = kept {
                col.push(y);
                logged = true;
            }
        }
        if logged || data.columns.is_empty() {
            data.time.push(row[0]);
        }
    }

    /// The run's samples after it ran: the clean copies, then the measurement noise.
    fn finish(self, plan: &Plan, run: &RunSpec, channels: &[ChannelInfo]) -> (RunData, f64) {
        let mut data = self.data;
        // Clean copies (before the noise), after their channels.
        if plan.spec.output.clean {
            let clean: Vec<Vec<f64>> = data.columns.clone();
            data.columns.extend(clean);
        }
        // Measurement noise: one ChaCha8 stream per run, drawn row by row, channel by channel.
        let sigmas: Vec<f64> =
            channels.iter().map(|c| plan.spec.output.noise.get(&c.name).copied().unwrap_or(0.0)).collect();
        if sigmas.iter().any(|s| *s > 0.0) {
            let mut rng = ChaCha8Rng::seed_from_u64(run.seed);
            let normals: Vec<Option<Normal<f64>>> =
                sigmas.iter().map(|s| if *s > 0.0 { Normal::new(0.0, *s).ok() } else { None }).collect();
            for r in 0..data.time.len() {
                for (col, n) in data.columns.iter_mut().zip(&normals) {
                    if let Some(n) = n {
                        col[r] += n.sample(&mut rng);
                    }
                }
            }
        }
        (data, self.horizon)
    }
}

/// Simulates runs side by side ([`lash_run::execute_together`]: reduced runs of one-joint
/// interfaces step their micro models in vector lanes) and returns each one's samples (noise
/// added) and simulated time, or its error: for each run what simulating it alone gives, bit for
/// bit.
fn simulate(plan: &Plan, runs: &[&RunSpec], channels: &[ChannelInfo]) -> Vec<Result<(RunData, f64), String>> {
    let mut results: Vec<Option<Result<(RunData, f64), String>>> = runs.iter().map(|_| None).collect();
    let (mut members, mut runners, mut simulations) = (Vec::new(), Vec::new(), Vec::new());
    for (i, run) in runs.iter().enumerate() {
        match Simulation::new(plan, run, channels) {
            Ok((runner, s)) => {
                members.push(i);
                runners.push(runner);
                simulations.push(s);
            }
            Err(e) => results[i] = Some(Err(e)),
        }
    }
    let mut sinks: Vec<_> = simulations
        .iter_mut()
        .map(|s| {
            move |row: &[f64]| -> Result<(), lash_core::BoxError> {
                s.keep(row);
                Ok(())
            }
        })
        .collect();
    let outcomes = lash_run::execute_together(&mut runners, sinks.iter_mut().map(|s| s as _).collect());
    drop(sinks);
    for ((i, simulation), outcome) in members.into_iter().zip(simulations).zip(outcomes) {
        results[i] = Some(match outcome {
            Ok(_) => Ok(simulation.finish(plan, runs[i], channels)),
            Err(e) => Err(e.to_string()),
        });
    }
    results.into_iter().map(|r| r.expect("every run ends")).collect()
}

/// The open part is closed (and its runs journaled) once it holds this many runs…
const PART_RUNS: usize = 64;
/// …or once it is this old \[s\] (counting the run just finished as the time the next one will
/// take): a kill loses at most about this much of the runs finished.
const PART_SECONDS: f64 = 1.0;

/// A run handed by its worker to the assembler: its journal line (not yet pointing to a part),
/// the simulated time and its rows (None: failed).
struct Finished {
    record: RunRecord,
    simulated: f64,
    batch: Option<RecordBatch>,
}

/// Where run `r`'s rows are kept while its sweep runs: its part and row group (a journal written
/// by an earlier lash, without them: a file of its own).
fn part_source(out: &Path, r: &RunRecord) -> RunSource {
    match &r.part {
        Some(name) => RunSource { file: out.join("parts").join(name), row_group: r.row_group },
        None => RunSource { file: out.join("parts").join(format!("run-{:09}.parquet", r.run_id)), row_group: None },
    }
}

/// State shared by the workers: the journal, the journaled runs, the simulated time.
struct Shared {
    journal: std::fs::File,
    journal_path: PathBuf,
    records: BTreeMap<u64, RunRecord>,
    simulated_s: f64,
}

/// Appends the lines of `records` to the journal in one write, flushed, and keeps them.
fn append_journal(shared: &Mutex<Shared>, records: Vec<RunRecord>) -> Result<(), DatasetError> {
    let mut text = String::new();
    for r in &records {
        // (A record of numbers and strings: serde_json cannot fail on it.)
        text.push_str(&serde_json::to_string(r).expect("a run record is JSON"));
        text.push('\n');
    }
    let mut s = shared.lock().expect("lock");
    let s = &mut *s;
    s.journal.write_all(text.as_bytes()).and_then(|()| s.journal.flush()).map_err(|source| DatasetError::Io {
        action: "append to",
        path: s.journal_path.clone(),
        source,
    })?;
    s.records.extend(records.into_iter().map(|r| (r.run_id, r)));
    Ok(())
}

/// Reads the journal of finished runs (a torn last line, from a kill, is ignored).
fn read_journal(out: &Path) -> BTreeMap<u64, RunRecord> {
    let mut done = BTreeMap::new();
    if let Ok(text) = std::fs::read_to_string(out.join("runs.jsonl")) {
        for line in text.lines() {
            if let Ok(r) = serde_json::from_str::<RunRecord>(line) {
                done.insert(r.run_id, r);
            }
        }
    }
    done
}

/// Runs a sweep (or one shard) into `options.out`, resuming what an earlier, interrupted
/// execution of the same sweep left there.
pub fn execute(plan: &Plan, options: &ExecuteOptions, on_event: &(dyn Fn(Event) + Sync)) -> Result<Report, SweepError> {
    let start = Instant::now();
    let out = &options.out;
    if let Some(complete) = check_folder(plan, options, on_event, start)? {
        return Ok(complete);
    }
    std::fs::create_dir_all(out.join("parts"))
        .map_err(|e| SweepError::Output(format!("cannot create {}: {e}", out.display())))?;
    let manifest = new_manifest(plan, options.shard);
    manifest.write(out)?;

    let shard_runs: Vec<&RunSpec> = plan.runs.iter().filter(|r| options.shard.is_none_or(|s| s.holds(r.id))).collect();
    let mut done = read_journal(out);
    done.retain(|_, r| r.status != "ok" || part_source(out, r).file.exists());
    let pending: Vec<&RunSpec> = shard_runs.iter().copied().filter(|r| !done.contains_key(&r.id)).collect();
    on_event(Event::Start { total: shard_runs.len() as u64, done: shard_runs.len() as u64 - pending.len() as u64 });

    let channels = manifest.channels.clone();
    let schema = dataset::data_schema(&channels);
    let threads = options.threads.unwrap_or_else(rayon::current_num_threads).max(1);
    // Runs simulated side by side by one worker: a full group each where there are enough runs
    // to keep every worker busy, else one at a time.
    let group = if pending.len() >= threads * options.side_by_side { options.side_by_side.max(1) } else { 1 };
    let (journal, journal_path) = open_journal(out)?;
    // Runs finished by an earlier execution: where their rows are (None: failed).
    let earlier: BTreeMap<u64, Option<RunSource>> =
        done.iter().map(|(id, r)| (*id, (r.status == "ok").then(|| part_source(out, r)))).collect();
    let shared = Mutex::new(Shared { journal, journal_path, records: done, simulated_s: 0.0 });
    let halt = Halt { stop: AtomicBool::new(false), error: Mutex::new(None) };
    let cancelled = || options.cancel.as_ref().is_some_and(|c| c.load(Ordering::Relaxed));
    let pool = worker_pool(threads)?;
    // Workers only simulate; they hand each finished run to this thread, which does every write:
    // it keeps the run in the open part (for resumption; journaled once the part is closed) and
    // appends the runs to data.parquet in run order as they become available, so that
    // assembling the dataset overlaps with the simulations instead of following them, and a
    // worker never waits on a file.
    let (sender, receiver) = std::sync::mpsc::channel::<Finished>();
    let mut assembler = Assembler {
        out,
        schema: &schema,
        shared: &shared,
        writer: dataset::DataWriter::create(out, &schema, plan.spec.output.csv)?,
        part: None,
        order: &shard_runs,
        earlier,
        waiting: BTreeMap::new(),
        cursor: 0,
        assemble_s: 0.0,
    };
    let assembled: Result<(), DatasetError> = std::thread::scope(|scope| {
        let (pending, halt, channels, schema) = (&pending, &halt, &channels, &schema);
        scope.spawn(move || {
            pool.install(|| {
                pending.par_chunks(group).for_each_with(sender, |sender, runs| {
                    if !halt.stop.load(Ordering::Relaxed) && !cancelled() {
                        simulate_group(plan, runs, (channels, schema), sender, halt, on_event);
                    }
                });
            })
        });
        let assembled = assembler.assemble(&receiver);
        if assembled.is_err() {
            halt.stop.store(true, Ordering::Relaxed);
        }
        // The part still open (the last runs, or those finished before a stop or a write
        // error) is closed and journaled.
        if let Err(e) = assembler.close_part() {
            *halt.error.lock().expect("lock") = Some(e);
        }
        assembled
    });
    if let Some(e) = halt.error.into_inner().expect("lock") {
        return Err(e.into());
    }
    assembled?;
    let (writer, assemble_s) = (assembler.writer, assembler.assemble_s);
    let shared = shared.into_inner().expect("lock");
    if cancelled() {
        return Err(interrupted(shared.records.len(), shard_runs.len(), out));
    }
    let ran = Ran { pending: &pending, threads, assemble_s, start };
    complete(out, manifest, &shard_runs, shared, writer, ran)
}

/// The run journal of `out` (runs.jsonl), opened for appending, and its path.
fn open_journal(out: &Path) -> Result<(std::fs::File, PathBuf), SweepError> {
    let journal_path = out.join("runs.jsonl");
    let journal = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&journal_path)
        .map_err(|source| DatasetError::Io { action: "open", path: journal_path.clone(), source })?;
    Ok((journal, journal_path))
}

/// A pool of `threads` workers.
fn worker_pool(threads: usize) -> Result<rayon::ThreadPool, SweepError> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| SweepError::Input(format!("cannot start {threads} worker threads: {e}")))
}

/// The error of a sweep cancelled with `finished` of the shard's `total` runs kept in `out`.
fn interrupted(finished: usize, total: usize, out: &Path) -> SweepError {
    SweepError::Interrupted(format!(
        "interrupted: {finished} of {total} runs of the shard are finished and kept in {}; run the sweep again into \
         that folder to resume",
        out.display()
    ))
}

/// The output folder checked before a sweep runs into it: new, empty, or holding this very
/// sweep (and shard). `Some` where it holds this sweep complete (nothing to run: its report).
fn check_folder(
    plan: &Plan,
    options: &ExecuteOptions,
    on_event: &(dyn Fn(Event) + Sync),
    start: Instant,
) -> Result<Option<Report>, SweepError> {
    let out = &options.out;
    if let Some(m) = Manifest::read(out)? {
        if m.sweep_hash != plan.sweep_hash {
            return Err(SweepError::Input(format!(
                "--out {}: the folder holds another sweep's data (sweep hash {}…, this sweep {}…); choose another folder",
                out.display(),
                &m.sweep_hash[..12],
                &plan.sweep_hash[..12]
            )));
        }
        if m.shard != options.shard {
            return Err(SweepError::Input(format!(
                "--out {}: the folder holds shard {:?} of this sweep, not {:?}",
                out.display(),
                m.shard,
                options.shard
            )));
        }
        if m.status == "complete" {
            let runs = m.runs.len() as u64;
            on_event(Event::Start { total: runs, done: runs });
            let failed = m.runs.iter().filter(|r| r.status != "ok").count() as u64;
            let wall_s = start.elapsed().as_secs_f64();
            return Ok(Some(Report { runs, skipped: runs, failed, wall_s, ..Default::default() }));
        }
    } else if out.exists() && std::fs::read_dir(out).map(|mut d| d.next().is_some()).unwrap_or(false) {
        return Err(SweepError::Input(format!(
            "--out {}: the folder is not empty and holds no lash sweep manifest; choose a new or empty folder",
            out.display()
        )));
    }
    Ok(None)
}

/// What stops the workers: a stop asked (after a write error), and the first write error.
struct Halt {
    stop: AtomicBool,
    error: Mutex<Option<DatasetError>>,
}

/// A worker's share: `runs` simulated side by side, each handed to the assembler as it
/// finished (its rows as a batch of `schema`, or its error); a batch that cannot be made stops
/// the sweep.
fn simulate_group(
    plan: &Plan,
    runs: &[&RunSpec],
    (channels, schema): (&[ChannelInfo], &arrow_schema::SchemaRef),
    sender: &mut std::sync::mpsc::Sender<Finished>,
    halt: &Halt,
    on_event: &(dyn Fn(Event) + Sync),
) {
    let t0 = Instant::now();
    let results = simulate(plan, runs, channels);
    // The group's time, shared by its runs.
    let simulate_s = t0.elapsed().as_secs_f64() / runs.len() as f64;
    for (run, result) in runs.iter().zip(results) {
        let record = |status: &str, error, rows| RunRecord {
            run_id: run.id,
            seed: run.seed,
            status: status.into(),
            error,
            rows,
            simulate_s,
            write_s: 0.0,
            part: None,
            row_group: None,
        };
        let finished = match result {
            Ok((data, horizon)) => {
                let rows = data.time.len() as u64;
                match data.into_batch(schema) {
                    Ok(batch) => Finished { record: record("ok", None, rows), simulated: horizon, batch: Some(batch) },
                    Err(e) => {
                        *halt.error.lock().expect("lock") = Some(e);
                        halt.stop.store(true, Ordering::Relaxed);
                        return;
                    }
                }
            }
            Err(e) => Finished { record: record("failed", Some(e), 0), simulated: 0.0, batch: None },
        };
        let ok = finished.batch.is_some();
        // (The assembler is gone only after a write error, which stops the sweep.)
        if sender.send(finished).is_err() {
            return;
        }
        on_event(Event::Finished { ok });
    }
}

/// The thread that writes: keeps each finished run in the open part and walks the shard's runs
/// in order into the dataset.
struct Assembler<'a> {
    out: &'a Path,
    schema: &'a arrow_schema::SchemaRef,
    shared: &'a Mutex<Shared>,
    writer: dataset::DataWriter,
    /// The part being filled (closed and journaled when full).
    part: Option<dataset::PartWriter>,
    /// The shard's runs in dataset order.
    order: &'a [&'a RunSpec],
    /// Runs finished by an earlier execution: where their rows are (None: failed).
    earlier: BTreeMap<u64, Option<RunSource>>,
    /// Runs finished and not yet in the dataset (None: failed).
    waiting: BTreeMap<u64, Option<RecordBatch>>,
    /// The next run of `order` to go into the dataset.
    cursor: usize,
    /// Time spent appending to the dataset.
    assemble_s: f64,
}

impl Assembler<'_> {
    /// Takes every finished run until the workers are done.
    fn assemble(&mut self, receiver: &std::sync::mpsc::Receiver<Finished>) -> Result<(), DatasetError> {
        self.advance()?;
        for Finished { record, simulated, batch } in receiver {
            let id = record.run_id;
            match &batch {
                Some(batch) => {
                    // Into the open part; the part is closed and its runs journaled when it is full.
                    let simulate_s = record.simulate_s;
                    let p = match self.part.as_mut() {
                        Some(p) => p,
                        None => {
                            self.part.insert(dataset::PartWriter::create(&self.out.join("parts"), id, self.schema)?)
                        }
                    };
                    p.append(batch, record)?;
                    if p.age() + simulate_s >= PART_SECONDS || p.len() >= PART_RUNS {
                        self.close_part()?;
                    }
                }
                // Nothing to keep but the line.
                None => append_journal(self.shared, vec![record])?,
            }
            self.shared.lock().expect("lock").simulated_s += simulated;
            self.waiting.insert(id, batch);
            let t = Instant::now();
            self.advance()?;
            self.assemble_s += t.elapsed().as_secs_f64();
        }
        Ok(())
    }

    /// Appends to the dataset the runs that are next in order and finished.
    fn advance(&mut self) -> Result<(), DatasetError> {
        while self.cursor < self.order.len() {
            let id = self.order[self.cursor].id;
            if let Some(source) = self.earlier.get(&id) {
                if let Some(source) = source {
                    self.writer.append_file(source)?;
                }
            } else if let Some(data) = self.waiting.remove(&id) {
                if let Some(d) = data {
                    self.writer.append(&d)?;
                }
            } else {
                break;
            }
            self.cursor += 1;
        }
        Ok(())
    }

    /// Closes the open part, if any, and journals its runs.
    fn close_part(&mut self) -> Result<(), DatasetError> {
        match self.part.take() {
            Some(p) => append_journal(self.shared, p.close()?),
            None => Ok(()),
        }
    }
}

/// What an execution ran, for its report.
struct Ran<'a> {
    pending: &'a [&'a RunSpec],
    threads: usize,
    assemble_s: f64,
    start: Instant,
}

/// Every run of the shard finished: the dataset, params.parquet and the manifest written
/// complete, the parts and the journal removed; the report.
fn complete(
    out: &Path,
    manifest: Manifest,
    shard_runs: &[&RunSpec],
    shared: Shared,
    writer: dataset::DataWriter,
    ran: Ran<'_>,
) -> Result<Report, SweepError> {
    let io = SweepError::Output;
    let t_assemble = Instant::now();
    let records: Vec<RunRecord> = shard_runs.iter().filter_map(|r| shared.records.get(&r.id).cloned()).collect();
    if records.len() != shard_runs.len() {
        return Err(io(format!("{} runs of the shard did not finish", shard_runs.len() - records.len())));
    }
    writer.finish()?;
    let ran_ids: std::collections::HashSet<u64> = ran.pending.iter().map(|r| r.id).collect();
    let ran_sum = |f: fn(&RunRecord) -> f64| records.iter().filter(|r| ran_ids.contains(&r.run_id)).map(f).sum();
    let mut report = Report {
        runs: shard_runs.len() as u64,
        skipped: shard_runs.len() as u64 - ran.pending.len() as u64,
        ran: ran.pending.len() as u64,
        failed: records.iter().filter(|r| r.status != "ok").count() as u64,
        simulate_s: ran_sum(|r| r.simulate_s),
        write_s: ran_sum(|r| r.write_s),
        simulated_s: shared.simulated_s,
        threads: ran.threads,
        ..Default::default()
    };
    let params: Vec<ParamsRow> = shard_runs
        .iter()
        .map(|r| ParamsRow {
            run_id: r.id,
            seed: r.seed,
            status: shared.records.get(&r.id).map(|x| x.status.clone()).unwrap_or_default(),
            values: r.values.clone(),
            error: shared.records.get(&r.id).and_then(|x| x.error.clone()).unwrap_or_default(),
        })
        .collect();
    dataset::write_params(out, &manifest.parameters, &params)?;
    // (Where the rows were kept while the sweep ran is the journal's business only.)
    let runs = records.into_iter().map(|r| RunRecord { part: None, row_group: None, ..r }).collect();
    let manifest = Manifest { status: "complete".into(), runs, ..manifest };
    manifest.write(out)?;
    std::fs::remove_dir_all(out.join("parts")).map_err(|e| io(format!("cannot remove the parts folder: {e}")))?;
    std::fs::remove_file(out.join("runs.jsonl")).map_err(|e| io(format!("cannot remove the run journal: {e}")))?;
    report.assemble_s = ran.assemble_s + t_assemble.elapsed().as_secs_f64();
    report.wall_s = ran.start.elapsed().as_secs_f64();
    Ok(report)
}

/// The manifests of the complete shards in `inputs`: one sweep, each shard of it once, none
/// missing.
fn shard_manifests(inputs: &[PathBuf]) -> Result<Vec<Manifest>, SweepError> {
    let bad = SweepError::Input;
    if inputs.is_empty() {
        return Err(bad("merge: name the shard folders to merge".into()));
    }
    let mut manifests = Vec::new();
    for dir in inputs {
        let m = Manifest::read(dir).map_err(|e| bad(e.to_string()))?.ok_or_else(|| {
            bad(format!("merge: {} holds no manifest.json (not a sweep output folder)", dir.display()))
        })?;
        if m.status != "complete" {
            return Err(bad(format!(
                "merge: {} is not complete (status {}); finish that shard first",
                dir.display(),
                m.status
            )));
        }
        manifests.push(m);
    }
    let first = &manifests[0];
    let count = first.shard.map(|s| s.count).unwrap_or(1);
    let mut seen = vec![false; count as usize];
    for (dir, m) in inputs.iter().zip(&manifests) {
        if m.sweep_hash != first.sweep_hash {
            return Err(bad(format!(
                "merge: {} holds another sweep (hash {}… vs {}…)",
                dir.display(),
                &m.sweep_hash[..12],
                &first.sweep_hash[..12]
            )));
        }
        let s = m.shard.unwrap_or(Shard { index: 0, count: 1 });
        if s.count != count {
            return Err(bad(format!(
                "merge: {} is shard {}/{}, the others are out of {count}",
                dir.display(),
                s.index,
                s.count
            )));
        }
        if std::mem::replace(&mut seen[s.index as usize], true) {
            return Err(bad(format!("merge: shard {}/{count} is given twice", s.index)));
        }
    }
    let missing: Vec<String> =
        seen.iter().enumerate().filter(|(_, s)| !**s).map(|(i, _)| format!("{i}/{count}")).collect();
    if !missing.is_empty() {
        return Err(bad(format!("merge: shards {} are missing", missing.join(", "))));
    }
    Ok(manifests)
}

/// Combines the complete output folders of every shard of one sweep into `out`: the same
/// data.parquet, params.parquet and manifest as a single-machine execution.
pub fn merge(inputs: &[PathBuf], out: &Path) -> Result<u64, SweepError> {
    let bad = SweepError::Input;
    let manifests = shard_manifests(inputs)?;
    let first = &manifests[0];
    if let Some(m) = Manifest::read(out).map_err(|e| bad(e.to_string()))? {
        if m.sweep_hash != first.sweep_hash {
            return Err(bad(format!("--out {}: the folder holds another sweep's data", out.display())));
        }
    } else if out.exists() && std::fs::read_dir(out).map(|mut d| d.next().is_some()).unwrap_or(false) {
        return Err(bad(format!("--out {}: the folder is not empty and holds no lash sweep manifest", out.display())));
    }
    std::fs::create_dir_all(out).map_err(|e| SweepError::Output(format!("cannot create {}: {e}", out.display())))?;
    // Every run's location: (input, row group among that input's ok runs).
    let mut runs: Vec<(RunRecord, usize, Option<usize>)> = Vec::new();
    for (i, m) in manifests.iter().enumerate() {
        let mut rg = 0;
        for r in &m.runs {
            let group = (r.status == "ok").then(|| {
                rg += 1;
                rg - 1
            });
            runs.push((r.clone(), i, group));
        }
    }
    runs.sort_by_key(|(r, _, _)| r.run_id);
    let schema = dataset::data_schema(&first.channels);
    let sources: Vec<RunSource> = runs
        .iter()
        .filter_map(|(_, i, g)| g.map(|g| RunSource { file: inputs[*i].join("data.parquet"), row_group: Some(g) }))
        .collect();
    let csv = inputs[0].join("data.csv").exists();
    let rows = dataset::write_data(out, &schema, &sources, csv)?;
    let mut params = Vec::new();
    for dir in inputs {
        params.extend(dataset::read_params(dir, first.parameters.len())?);
    }
    params.sort_by_key(|p| p.run_id);
    dataset::write_params(out, &first.parameters, &params)?;
    let merged = Manifest { shard: None, runs: runs.into_iter().map(|(r, _, _)| r).collect(), ..first.clone() };
    merged.write(out)?;
    Ok(rows)
}
