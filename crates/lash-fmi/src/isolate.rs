//! Out-of-process FMUs: an [`IsolatedFmu`] runs an FMU in a child process (the `lash` binary's
//! hidden `fmu host` command, which imports it with [`crate::import::ImportedFmu`]) and talks to
//! it over the child's standard input and output. A crash (`abort()`, a segfault) or a hang of the
//! FMU then ends only the child: the call that was under way fails with an error naming the
//! element, the FMU, the call, the simulation time and the signal (or the timeout), and the
//! master keeps the output it has. The price is a round trip between two processes per call
//! (measured by `lash bench fmu --isolate`).
//!
//! The protocol: each message is a little-endian `u32` length followed by a postcard-encoded
//! [`Request`] (parent to child) or [`Reply`] (child to parent). The child first sends
//! [`Reply::Hello`] with the FMU's variables, or [`Reply::Error`] if it cannot import it.

use lash_core::{SavedState, StepOutcome, Subsystem, SubsystemError, Ticks, ValueReference, Variable};
use serde::{Deserialize, Serialize};
use std::io::{BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

/// A call from the parent.
#[derive(Debug, Serialize, Deserialize)]
pub enum Request {
    /// [`Subsystem::setup`] (ticks).
    Setup(i64, Option<i64>),
    /// [`Subsystem::initialize`].
    Initialize,
    /// [`Subsystem::set_f64`].
    SetF64(Vec<ValueReference>, Vec<f64>),
    /// [`Subsystem::get_f64`] with the number of values.
    GetF64(Vec<ValueReference>, usize),
    /// [`Subsystem::set_string`].
    SetString(ValueReference, String),
    /// [`Subsystem::get_string`].
    GetString(ValueReference),
    /// [`Subsystem::do_step`] (ticks).
    DoStep(i64, i64),
    /// [`Subsystem::save_state`].
    SaveState,
    /// [`Subsystem::restore_state`] of a state saved earlier (its number).
    RestoreState(u64),
    /// [`Subsystem::terminate`].
    Terminate,
    /// [`Subsystem::set_binary`].
    SetBinary(ValueReference, Vec<u8>),
    /// [`Subsystem::get_binary`].
    GetBinary(ValueReference),
    /// [`Subsystem::configure`]; answered with [`Reply::Variables`].
    Configure(Vec<ValueReference>, Vec<f64>),
}

/// An answer from the child.
#[derive(Debug, Serialize, Deserialize)]
pub enum Reply {
    /// The FMU is imported: its FMI version and variables.
    Hello(String, Vec<Variable>),
    /// The call succeeded.
    Done,
    /// Values read.
    Values(Vec<f64>),
    /// Text read.
    Text(String),
    /// A step's outcome: 0 completed, 1 early return, 2 terminate; the time reached (ticks).
    Step(u8, i64),
    /// A state saved under this number.
    State(u64),
    /// The call failed: the message.
    Error(String),
    /// Bytes read.
    Bytes(Vec<u8>),
    /// The variables after a configuration (arrays resized).
    Variables(Vec<Variable>),
}

/// Writes one message with a single write (the reader wakes once per message).
fn write_message<T: Serialize>(w: &mut impl Write, message: &T) -> std::io::Result<()> {
    let mut frame = vec![0u8; 4];
    let frame = postcard::to_extend(message, std::mem::take(&mut frame)).map_err(std::io::Error::other)?;
    let mut frame = frame;
    let len = u32::try_from(frame.len() - 4).map_err(std::io::Error::other)?;
    frame[..4].copy_from_slice(&len.to_le_bytes());
    w.write_all(&frame)?;
    w.flush()
}

/// The largest message accepted (64 MiB: a description of 2²⁴ values and more).
const MAX_MESSAGE: u32 = 64 << 20;

fn read_message<T: for<'de> Deserialize<'de>>(r: &mut impl Read) -> std::io::Result<T> {
    let mut len = [0u8; 4];
    r.read_exact(&mut len)?;
    let len = u32::from_le_bytes(len);
    if len > MAX_MESSAGE {
        return Err(std::io::Error::other(format!("a message of {len} bytes")));
    }
    let mut bytes = vec![0u8; len as usize];
    r.read_exact(&mut bytes)?;
    postcard::from_bytes(&bytes).map_err(std::io::Error::other)
}

/// The child's side: imports `fmu` (unpacked under `cache`) as `name` and answers requests on
/// standard input and output until the parent closes them. Returns the process exit code.
pub fn serve(fmu: &Path, cache: &Path, name: &str) -> i32 {
    follow_parent();
    // Whole messages in one write each: a buffered writer over standard output, flushed per message.
    let (mut input, mut output) =
        (std::io::stdin().lock(), std::io::BufWriter::with_capacity(1 << 16, std::io::stdout().lock()));
    let mut model = match crate::import::ImportedFmu::open(fmu, cache, name) {
        Ok(m) => m,
        Err(e) => {
            let _ = write_message(&mut output, &Reply::Error(e.to_string()));
            return 2;
        }
    };
    let hello = Reply::Hello(model.fmi_version().to_string(), model.variables().to_vec());
    if write_message(&mut output, &hello).is_err() {
        return 1;
    }
    let mut input = std::io::BufReader::with_capacity(1 << 16, &mut input);
    let mut states: Vec<SavedState> = Vec::new();
    let error = |e: SubsystemError| Reply::Error(e.to_string());
    loop {
        let request: Request = match read_message(&mut input) {
            Ok(r) => r,
            Err(_) => return 0, // the parent closed the pipe: done
        };
        let reply = match request {
            Request::Setup(start, stop) => {
                model.setup(Ticks(start), stop.map(Ticks)).map_or_else(error, |_| Reply::Done)
            }
            Request::Initialize => model.initialize().map_or_else(error, |_| Reply::Done),
            Request::SetF64(refs, values) => model.set_f64(&refs, &values).map_or_else(error, |_| Reply::Done),
            Request::GetF64(refs, n) if n <= crate::import::MAX_ELEMENTS => {
                let mut values = vec![0.0; n];
                model.get_f64(&refs, &mut values).map_or_else(error, |_| Reply::Values(values))
            }
            Request::GetF64(_, n) => Reply::Error(format!("{n} values asked")),
            Request::SetString(vr, text) => model.set_string(vr, &text).map_or_else(error, |_| Reply::Done),
            Request::GetString(vr) => model.get_string(vr).map_or_else(error, Reply::Text),
            Request::DoStep(t, h) => match model.do_step(Ticks(t), Ticks(h)) {
                Ok(StepOutcome::Completed) => Reply::Step(0, t + h),
                Ok(StepOutcome::EarlyReturn { reached }) => Reply::Step(1, reached.0),
                Ok(StepOutcome::Terminate { reached }) => Reply::Step(2, reached.0),
                Err(e) => error(e),
            },
            Request::SaveState => match model.save_state() {
                Ok(s) => {
                    states.push(s);
                    Reply::State(states.len() as u64 - 1)
                }
                Err(e) => error(e),
            },
            Request::RestoreState(k) => match states.get(k as usize) {
                Some(s) => model.restore_state(s).map_or_else(error, |_| Reply::Done),
                None => Reply::Error(format!("no saved state {k}")),
            },
            Request::Terminate => model.terminate().map_or_else(error, |_| Reply::Done),
            Request::SetBinary(vr, bytes) => model.set_binary(vr, &bytes).map_or_else(error, |_| Reply::Done),
            Request::GetBinary(vr) => model.get_binary(vr).map_or_else(error, Reply::Bytes),
            Request::Configure(refs, values) => match model.configure(&refs, &values) {
                Ok(()) => Reply::Variables(model.variables().to_vec()),
                Err(e) => error(e),
            },
        };
        if write_message(&mut output, &reply).is_err() {
            return 1;
        }
    }
}

/// The variable through which [`IsolatedFmu::spawn`] tells the host its parent's process id.
const PARENT_VARIABLE: &str = "LASH_FMU_HOST_PARENT";

/// How often the host looks whether its parent still runs.
const PARENT_POLL: Duration = Duration::from_millis(50);

/// Ends this host process as soon as the process that started it is gone, however it ended
/// (a signal, a panic, `SIGKILL`): a thread compares the parent's process id with the one it
/// started with (the orphan is re-parented to init or a subreaper) every [`PARENT_POLL`], and
/// ends the process at once, without running exit handlers, since the FMU may be mid-call on
/// the serving thread. A parent id not met at the start (the parent died before) ends it at once.
fn follow_parent() {
    let parent = std::os::unix::process::parent_id();
    let expected = std::env::var(PARENT_VARIABLE).ok().and_then(|p| p.parse::<u32>().ok());
    let end = || {
        // SAFETY: `_exit` takes a status and never returns; it touches no Rust state.
        unsafe { libc::_exit(3) }
    };
    if expected.is_some_and(|p| p != parent) {
        end();
    }
    let watcher = std::thread::Builder::new().name("lash-fmu-host-parent".into()).spawn(move || {
        loop {
            std::thread::sleep(PARENT_POLL);
            if std::os::unix::process::parent_id() != parent {
                end();
            }
        }
    });
    if watcher.is_err() {
        end();
    }
}

/// What the calling thread and the watchdog share.
struct Watch {
    child: Mutex<Child>,
    /// When the call under way started (nanoseconds since [`origin`], plus one); 0 when idle.
    started: AtomicU64,
    /// Set by the watchdog when it killed a child that did not answer in time.
    timed_out: AtomicBool,
    /// Set when the FMU is dropped: the watchdog ends.
    closed: AtomicBool,
}

/// The instant the watchdog measures from.
fn origin() -> Instant {
    static ORIGIN: OnceLock<Instant> = OnceLock::new();
    *ORIGIN.get_or_init(Instant::now)
}

fn now_ns() -> u64 {
    origin().elapsed().as_nanos() as u64 + 1
}

/// The pipes to a live child.
struct Channel {
    input: ChildStdin,
    output: BufReader<ChildStdout>,
    /// Set once the child is gone: every later call fails with this message.
    dead: Option<String>,
}

/// An FMU in a child process, as a [`Subsystem`].
pub struct IsolatedFmu {
    name: String,
    fmu: PathBuf,
    fmi_version: String,
    variables: Vec<Variable>,
    timeout: Duration,
    time: Ticks,
    channel: Mutex<Channel>,
    watch: Arc<Watch>,
}

/// The name of a signal that ended a process.
fn signal_name(signal: i32) -> String {
    let name = match signal {
        1 => "SIGHUP",
        2 => "SIGINT",
        4 => "SIGILL",
        6 => "SIGABRT",
        7 => "SIGBUS",
        8 => "SIGFPE",
        9 => "SIGKILL",
        11 => "SIGSEGV",
        13 => "SIGPIPE",
        15 => "SIGTERM",
        _ => return format!("signal {signal}"),
    };
    format!("signal {signal} ({name})")
}

/// Why an isolated FMU could not be started.
#[derive(Debug, thiserror::Error)]
pub enum SpawnError {
    /// The host process or its watchdog thread could not be started.
    #[error("cannot start the {what}")]
    Start {
        /// The host program or the watchdog thread.
        what: String,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// The host started but did not import the FMU (its own message, or a broken exchange).
    #[error("{0}")]
    Import(String),
    /// The call to the host failed (crash, hang, broken pipe).
    #[error(transparent)]
    Call(#[from] SubsystemError),
}

impl IsolatedFmu {
    /// Starts `host` (a program that runs [`serve`]; lash's own binary with `fmu host`) for `fmu`,
    /// named `name`, FMUs unpacked under `cache`; every call waits at most `timeout` for its answer.
    ///
    /// A call is a write and a blocking read on the calling thread (one round trip between the
    /// processes); a watchdog thread, waking every `timeout / 8` (at most 0.1 s), kills a child
    /// whose call has run longer than `timeout`, which ends the read.
    pub fn spawn(host: &Path, fmu: &Path, cache: &Path, name: &str, timeout: Duration) -> Result<Self, SpawnError> {
        let mut child = Command::new(host)
            .env(PARENT_VARIABLE, std::process::id().to_string())
            .args(["fmu", "host"])
            .arg(fmu)
            .arg("--cache")
            .arg(cache)
            .arg("--name")
            .arg(name)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .map_err(|source| SpawnError::Start { what: format!("FMU host {}", host.display()), source })?;
        let (Some(input), Some(output)) = (child.stdin.take(), child.stdout.take()) else {
            return Err(SpawnError::Import("the FMU host has no pipes".into()));
        };
        let watch = Arc::new(Watch {
            child: Mutex::new(child),
            started: AtomicU64::new(0),
            timed_out: AtomicBool::new(false),
            closed: AtomicBool::new(false),
        });
        let period = (timeout / 8).clamp(Duration::from_millis(1), Duration::from_millis(100));
        let limit = timeout.as_nanos() as u64;
        let watched = watch.clone();
        std::thread::Builder::new()
            .name(format!("lash-fmu-watchdog-{name}"))
            .spawn(move || {
                while !watched.closed.load(Ordering::Acquire) {
                    std::thread::sleep(period);
                    let started = watched.started.load(Ordering::Acquire);
                    if started != 0 && now_ns().saturating_sub(started) > limit {
                        watched.timed_out.store(true, Ordering::Release);
                        if let Ok(mut child) = watched.child.lock() {
                            let _ = child.kill();
                        }
                        break;
                    }
                }
            })
            .map_err(|source| SpawnError::Start { what: "watchdog thread".into(), source })?;
        let mut isolated = Self {
            name: name.to_string(),
            fmu: fmu.to_path_buf(),
            fmi_version: String::new(),
            variables: Vec::new(),
            timeout,
            time: Ticks::ZERO,
            channel: Mutex::new(Channel { input, output: BufReader::with_capacity(1 << 16, output), dead: None }),
            watch,
        };
        match isolated.answer("import", None)? {
            Reply::Hello(version, variables) => {
                isolated.fmi_version = version;
                isolated.variables = variables;
                Ok(isolated)
            }
            Reply::Error(m) => Err(SpawnError::Import(m)),
            other => Err(SpawnError::Import(format!("the FMU host answered {other:?} to its start"))),
        }
    }

    /// The FMI version of the FMU ("3.0", "2.0").
    pub fn fmi_version(&self) -> &str {
        &self.fmi_version
    }

    /// Sends `request` (or only waits, for the greeting) and returns the answer; a crash, a hang
    /// or a broken pipe is an error naming the FMU, the call and the time, and ends the child.
    fn answer(&self, call: &str, request: Option<Request>) -> Result<Reply, SubsystemError> {
        let mut channel = self.channel.lock().map_err(|_| SubsystemError::Other("isolated FMU poisoned".into()))?;
        if let Some(m) = &channel.dead {
            return Err(SubsystemError::Other(m.clone()));
        }
        let at = format!("{} (isolated {}), {call} at t = {} s", self.name, self.fmu.display(), self.time.seconds());
        self.watch.started.store(now_ns(), Ordering::Release);
        let sent = match request {
            Some(r) => write_message(&mut channel.input, &r),
            None => Ok(()),
        };
        let reply = sent.and_then(|_| read_message::<Reply>(&mut channel.output));
        self.watch.started.store(0, Ordering::Release);
        match reply {
            Ok(reply) => Ok(reply),
            Err(e) => {
                let why = if self.watch.timed_out.load(Ordering::Acquire) {
                    self.reap();
                    format!("no answer within {} s: the FMU hangs (its process was killed)", self.timeout.as_secs_f64())
                } else {
                    self.ended(&format!("the FMU host stopped ({e})"))
                };
                channel.dead = Some(format!("{at}: {why}"));
                Err(SubsystemError::Other(format!("{at}: {why}")))
            }
        }
    }

    /// Waits for a killed child.
    fn reap(&self) {
        if let Ok(mut child) = self.watch.child.lock() {
            let _ = child.wait();
        }
    }

    /// The child is gone or going: how it ended, in words.
    fn ended(&self, what: &str) -> String {
        use std::os::unix::process::ExitStatusExt;
        let Ok(mut child) = self.watch.child.lock() else { return what.to_string() };
        let mut status = child.try_wait().ok().flatten();
        for _ in 0..20 {
            if status.is_some() {
                break;
            }
            std::thread::sleep(Duration::from_millis(10));
            status = child.try_wait().ok().flatten();
        }
        match status {
            Some(s) => match (s.signal(), s.code()) {
                (Some(sig), _) => format!("the FMU crashed with {}", signal_name(sig)),
                (None, Some(code)) => format!("the FMU host exited with code {code}"),
                _ => what.to_string(),
            },
            None => {
                let _ = child.kill();
                let _ = child.wait();
                format!("{what} (its process was killed)")
            }
        }
    }

    fn call(&self, call: &str, request: Request) -> Result<Reply, SubsystemError> {
        match self.answer(call, Some(request))? {
            Reply::Error(m) => Err(SubsystemError::Other(m)),
            reply => Ok(reply),
        }
    }

    fn done(&self, call: &str, request: Request) -> Result<(), SubsystemError> {
        match self.call(call, request)? {
            Reply::Done => Ok(()),
            other => Err(SubsystemError::Other(format!("{call}: unexpected answer {other:?}"))),
        }
    }
}

impl Drop for IsolatedFmu {
    fn drop(&mut self) {
        self.watch.closed.store(true, Ordering::Release);
        if let Ok(mut child) = self.watch.child.lock() {
            // The master has terminated the FMU: the child only waits for input now.
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

impl Subsystem for IsolatedFmu {
    fn name(&self) -> &str {
        &self.name
    }

    fn variables(&self) -> &[Variable] {
        &self.variables
    }

    fn setup(&mut self, start: Ticks, stop: Option<Ticks>) -> Result<(), SubsystemError> {
        self.time = start;
        self.done("setup", Request::Setup(start.0, stop.map(|s| s.0)))
    }

    fn initialize(&mut self) -> Result<(), SubsystemError> {
        self.done("initialize", Request::Initialize)
    }

    fn set_f64(&mut self, refs: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError> {
        self.done("set", Request::SetF64(refs.to_vec(), values.to_vec()))
    }

    fn get_f64(&self, refs: &[ValueReference], values: &mut [f64]) -> Result<(), SubsystemError> {
        match self.call("get", Request::GetF64(refs.to_vec(), values.len()))? {
            Reply::Values(v) if v.len() == values.len() => {
                values.copy_from_slice(&v);
                Ok(())
            }
            other => Err(SubsystemError::Other(format!("get: unexpected answer {other:?}"))),
        }
    }

    fn get_string(&self, vr: ValueReference) -> Result<String, SubsystemError> {
        match self.call("get_string", Request::GetString(vr))? {
            Reply::Text(t) => Ok(t),
            other => Err(SubsystemError::Other(format!("get_string: unexpected answer {other:?}"))),
        }
    }

    fn set_string(&mut self, vr: ValueReference, value: &str) -> Result<(), SubsystemError> {
        self.done("set_string", Request::SetString(vr, value.to_string()))
    }

    fn do_step(&mut self, t: Ticks, h: Ticks) -> Result<StepOutcome, SubsystemError> {
        self.time = t;
        let outcome = match self.call("do_step", Request::DoStep(t.0, h.0))? {
            Reply::Step(0, _) => StepOutcome::Completed,
            Reply::Step(1, r) => StepOutcome::EarlyReturn { reached: Ticks(r) },
            Reply::Step(2, r) => StepOutcome::Terminate { reached: Ticks(r) },
            other => return Err(SubsystemError::Other(format!("do_step: unexpected answer {other:?}"))),
        };
        self.time = outcome.reached(t, h);
        Ok(outcome)
    }

    fn time(&self) -> Ticks {
        self.time
    }

    fn save_state(&self) -> Result<SavedState, SubsystemError> {
        match self.call("save_state", Request::SaveState)? {
            Reply::State(k) => Ok(SavedState(Box::new((k, self.time)))),
            other => Err(SubsystemError::Other(format!("save_state: unexpected answer {other:?}"))),
        }
    }

    fn restore_state(&mut self, state: &SavedState) -> Result<(), SubsystemError> {
        let &(k, time) = state
            .0
            .downcast_ref::<(u64, Ticks)>()
            .ok_or_else(|| SubsystemError::Other("the saved state is not an isolated FMU's".into()))?;
        self.done("restore_state", Request::RestoreState(k))?;
        self.time = time;
        Ok(())
    }

    fn terminate(&mut self) -> Result<(), SubsystemError> {
        self.done("terminate", Request::Terminate)
    }

    fn get_binary(&self, vr: ValueReference) -> Result<Vec<u8>, SubsystemError> {
        match self.call("get_binary", Request::GetBinary(vr))? {
            Reply::Bytes(b) => Ok(b),
            other => Err(SubsystemError::Other(format!("get_binary: unexpected answer {other:?}"))),
        }
    }

    fn set_binary(&mut self, vr: ValueReference, value: &[u8]) -> Result<(), SubsystemError> {
        self.done("set_binary", Request::SetBinary(vr, value.to_vec()))
    }

    fn configure(&mut self, refs: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError> {
        match self.call("configure", Request::Configure(refs.to_vec(), values.to_vec()))? {
            Reply::Variables(v) => {
                self.variables = v;
                Ok(())
            }
            other => Err(SubsystemError::Other(format!("configure: unexpected answer {other:?}"))),
        }
    }
}
