"""lash from Python: co-simulation of mechanisms with joint clearances.

Load and edit scenarios, run the full or the reduced interface model, run sweeps into datasets
and read those datasets back as arrays for training::

    import lash

    a = lash.load("A").with_values({"simulation.horizon": 0.1})
    run = lash.run(a, model="reduced")
    run["slider.ax"]             # numpy array, one value per sample
    run.to_pandas()              # DataFrame indexed by time, units in .attrs["units"]

    lash.sweep("examples/sweep-grid.toml", "out/grid")
    data = lash.Dataset("out/grid")
    data.values.shape            # (runs, samples, channels)
    for x, y in data.batches(32):
        ...                      # x: parameters (batch, parameters), y: (batch, samples, channels)

Everything goes through the same Rust code as the ``lash`` command: the same validation (errors
are :class:`ScenarioError` naming each field), the same models, the same limits before work.
Samples are written once, into the memory numpy then owns; the GIL is released while lash
simulates.
"""

from __future__ import annotations

import json
import os
from typing import Any, Callable, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _lash
from ._lash import Scenario, ScenarioError, SimulationError, builtin_names

__version__: str = _lash.__version__

__all__ = [
    "Dataset",
    "Run",
    "RunsFailed",
    "Scenario",
    "ScenarioError",
    "SimulationError",
    "builtin_names",
    "compare",
    "design_sweep",
    "emulate_measurement",
    "estimate",
    "load",
    "merge",
    "prepare_estimator",
    "report",
    "run",
    "sweep",
    "validate",
]

PathLike = Union[str, "os.PathLike[str]"]


class RunsFailed(SimulationError):
    """A sweep finished but some of its runs failed.

    The dataset is complete otherwise: the failed runs are listed in it with their errors
    (:attr:`Dataset.failed`). ``report`` is the sweep's report (a dict).
    """

    def __init__(self, message: str, report: Dict[str, Any]):
        super().__init__(message)
        self.report = report


def load(source: PathLike) -> Scenario:
    """A built-in scenario by name (``"A"``, ``"E-0.5mm-250rpm"``, ...) or a scenario file."""
    text = os.fspath(source)
    if text in builtin_names():
        return Scenario.builtin(text)
    if not os.path.exists(text):
        message = f"{text!r} is neither a file nor a built-in scenario (built-ins: {', '.join(builtin_names())})"
        error = ScenarioError(f"scenario: {message}")
        error.problems = [("scenario", message)]
        raise error
    return Scenario.load(text)


def validate(path: PathLike) -> str:
    """Checks a scenario or sweep file as ``lash validate`` does; returns a one-line summary.

    Raises :class:`ScenarioError` naming every bad field (for a sweep: the runs whose scenario
    is invalid).
    """
    text = os.fspath(path)
    if _is_sweep(text):
        return _lash.validate_sweep(text)
    s = load(text)
    return f"{text}: valid ({s.space} scenario {s.name!r})"


def _is_sweep(path: str) -> bool:
    if not os.path.isfile(path):
        return False
    try:
        import tomllib  # Python 3.11+
    except ImportError:  # pragma: no cover - older Pythons read the key by hand
        with open(path, encoding="utf-8") as f:
            return any(line.strip().startswith("base") and "=" in line for line in f)
    with open(path, "rb") as f:
        try:
            return isinstance(tomllib.load(f).get("base"), str)
        except tomllib.TOMLDecodeError:
            return False


class Run:
    """The samples and summary of one run.

    ``samples`` holds time in column 0 and the channels after it; :attr:`time`, :attr:`values`
    and each channel (``run["slider.ax"]``) are views of it, not copies.
    """

    def __init__(self, names: List[str], units: List[str], samples: np.ndarray, summary: str):
        self.samples: np.ndarray = samples
        """All samples, samples × (1 + channels), time first."""
        self.channels: List[str] = names[1:]
        """Channel names, in column order of :attr:`values`."""
        self.units: Dict[str, str] = dict(zip(names, units))
        """SI unit of each channel (and of ``time``)."""
        self._summary_json = summary
        self._summary: Optional[Dict[str, Any]] = None
        self._index = {n: i for i, n in enumerate(names)}

    @property
    def summary(self) -> Dict[str, Any]:
        """What ``summary.json`` holds: statistics per channel, impacts per clearance joint,
        steps, warnings (parsed on first use)."""
        if self._summary is None:
            self._summary = json.loads(self._summary_json)
        return self._summary

    @property
    def time(self) -> np.ndarray:
        """Sample times [s]."""
        return self.samples[:, 0]

    @property
    def values(self) -> np.ndarray:
        """Samples × channels (a view)."""
        return self.samples[:, 1:]

    def __getitem__(self, channel: str) -> np.ndarray:
        try:
            return self.samples[:, self._index[channel]]
        except KeyError:
            raise KeyError(f"no channel {channel!r} in this run (channels: {', '.join(self.channels)})") from None

    def __len__(self) -> int:
        return self.samples.shape[0]

    def to_pandas(self) -> "Any":
        """The channels as a pandas DataFrame indexed by ``time`` [s]; units in ``.attrs["units"]``.

        The DataFrame is built on the same memory (pandas may copy if you write to it). Needs
        pandas: ``pip install "./crates/lash-py[pandas]"``.
        """
        try:
            import pandas as pd
        except ImportError:
            raise ImportError(
                'Run.to_pandas needs pandas: pip install pandas (or install lash with its extra, "lash[pandas]")'
            ) from None

        df = pd.DataFrame(self.values, columns=self.channels, index=pd.Index(self.time, name="time"), copy=False)
        df.attrs["units"] = {c: self.units[c] for c in self.channels}
        return df

    def __repr__(self) -> str:
        return f"<lash.Run {self.summary.get('scenario')!r} ({self.summary.get('model')}): {len(self)} samples × {len(self.channels)} channels>"


def _is_system(source: Any) -> bool:
    """True for a system file: ``.ssd``/``.ssp``, or TOML with a top-level ``elements`` list."""
    if isinstance(source, Scenario):
        return False
    path = os.fspath(source)
    if path.endswith((".ssd", ".ssp")):
        return True
    if not os.path.isfile(path):
        return False
    try:
        import tomllib
    except ImportError:  # pragma: no cover - older Pythons look for the key by hand
        with open(path, encoding="utf-8") as f:
            return any(line.strip().startswith("[[elements]]") for line in f)
    with open(path, "rb") as f:
        try:
            return isinstance(tomllib.load(f).get("elements"), list)
        except tomllib.TOMLDecodeError:
            return False


def run(
    scenario: Union[Scenario, PathLike],
    model: str = "full",
    *,
    ideal: bool = False,
    macro_step: Optional[float] = None,
    micro_step: Optional[float] = None,
    interpolation: str = "linear",
    coupling: str = "auto",
    micro: str = "rk4",
    threaded: bool = False,
    horizon: Optional[float] = None,
    step: Optional[float] = None,
    channels: Optional[Sequence[str]] = None,
    error_estimate: bool = False,
) -> Run:
    """Runs a scenario (a :class:`Scenario`, a built-in name or a file) or a system file.

    ``model`` is ``"full"`` (the monolithic model integrated to convergence; ``ideal=True``
    makes its clearance joints ideal) or ``"reduced"`` (the reduced interface model with macro
    step ``macro_step`` and micro step ``micro_step`` [s]; ``interpolation`` of the macro terms
    ``"linear"``, ``"hermite"`` or ``"zoh"``; ``coupling`` ``"one_way"``, ``"two_way"`` or
    ``"auto"`` — one-way, made again in two-way when the error estimate finds one-way coupling's
    own error past the stated 10 % and two-way the closer to the converged full model over the
    probe window (so one-way unless ``error_estimate=True``; the summary's ``coupling_choice``
    gives both figures);
    ``micro`` integrator ``"rk4"`` or the error-controlled ``"dopri5"``; ``threaded`` runs the
    macro subsystem on its own thread, same results). Without ``macro_step`` a reduced run's is
    chosen as ``lash run`` chooses it: 1e-3 s, or the largest step below in which the fastest
    body turns by at most 16° (5e-4 s at 5000 rpm; the summary's ``macro_step_choice`` says
    why). Without ``micro_step`` a reduced run's is
    chosen as ``lash run`` chooses it: 1e-5 s, or the largest step below that gives each
    clearance joint's impacts (their median duration in the converged full model over the first
    50 ms of the run) at least 7 steps — which costs that full-model run; the summary's
    ``micro_step_choice`` says why when it is not 1e-5 s. Give ``micro_step`` to skip it (many
    runs: a sweep). ``horizon`` [s] overrides the scenario's;
    ``channels`` selects the channels recorded (the scenario's ``output.channels``: fewer
    channels, less memory and time). ``error_estimate=True`` adds to a reduced run's summary its
    ``error_estimate``, as ``lash run`` writes it (on by default there): how far its RMS levels
    are likely from the converged full model's on the main channels — the full model over the
    first quarter of the run plus, for one-way coupling, one-way against two-way over the whole
    run — and a warning when one-way coupling itself is off; it costs those runs.

    A **system file** (TOML with ``[[elements]]``, SSP ``.ssd`` or ``.ssp``: FMUs, plugins and
    built-ins coupled, as ``lash run system.toml``) runs as written; ``horizon`` and ``step``
    override its stop time and communication step, and ``channels`` is its ``output.channels``.

    Raises :class:`ScenarioError` for invalid input (before any work, including a run whose
    samples would not fit in memory) and :class:`SimulationError` when the simulation fails.
    """
    if _is_system(scenario):
        if channels is not None or model != "full":
            raise ScenarioError(
                "a system file sets its own elements and output.channels: edit the file for model or channels"
            )
        return Run(*_lash.run_system(os.fspath(scenario), step, horizon))
    if step is not None:
        raise ScenarioError("step: the communication step of a system file; a scenario has macro_step and micro_step")
    s = scenario if isinstance(scenario, Scenario) else load(scenario)
    if horizon is not None:
        s = s.with_values({"simulation.horizon": horizon})
    if channels is not None:
        fields = s.to_dict()
        fields.setdefault("output", {})["channels"] = list(channels)
        s = Scenario.from_dict(fields)
    return Run(
        *_lash.run(s, model, ideal, macro_step, micro_step, interpolation, coupling, micro, threaded, error_estimate)
    )


def _sweep_file(spec: Mapping[str, Any], folder: str) -> str:
    """Writes a sweep given as a dict as a sweep file in ``folder``; a relative scenario file in
    ``base`` is taken from the current directory."""
    spec = dict(spec)
    base = spec.get("base")
    if isinstance(base, str) and os.path.isfile(base):
        spec["base"] = os.path.abspath(base)
    text = _lash.sweep_toml(json.dumps(spec, default=_plain))
    path = os.path.join(folder, "sweep.toml")
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)
    return path


def _plain(value: Any) -> Any:
    """numpy scalars and arrays (a design's columns) as plain Python numbers and lists."""
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not a number or a list of numbers")


def sweep(
    file: Union[PathLike, Mapping[str, Any]],
    out: PathLike,
    *,
    threads: Optional[int] = None,
    shard: Optional[str] = None,
    allow_failures: bool = False,
    progress: Optional[Callable[[int, int, int], Any]] = None,
) -> Dict[str, Any]:
    """Runs a sweep into the folder ``out`` (``lash sweep``), resuming what an earlier call left
    there; returns its report. ``file`` is a sweep file or the same fields as a dict
    (``{"base": "A", "sampling": "random", "runs": 64, "output": {...}, "parameters": [...]}``;
    :func:`design_sweep` builds one from a table of designs).

    ``threads``: worker threads (default one per core); ``shard``: ``"i/N"`` runs only that
    shard. When runs fail the dataset still holds the others and lists the failed runs with
    their errors; unless ``allow_failures``, :class:`RunsFailed` is raised then.
    ``progress(done, total, failed)`` is called once per finished run, in order (``done`` counts
    the runs of earlier calls too): a progress bar's hook. Ctrl-C (or an exception from ``progress``) stops the sweep;
    the runs in flight finish and calling ``sweep`` again resumes it.
    """
    if isinstance(file, Mapping):
        import tempfile

        with tempfile.TemporaryDirectory(prefix="lash-sweep-") as folder:
            return sweep(
                _sweep_file(file, folder),
                out,
                threads=threads,
                shard=shard,
                allow_failures=allow_failures,
                progress=progress,
            )
    report = json.loads(_lash.sweep(os.fspath(file), os.fspath(out), threads, shard, progress))
    if report["failed"] and not allow_failures:
        raise RunsFailed(
            f"{report['failed']} of {report['runs']} runs failed; the dataset in {os.fspath(out)} holds the "
            "others and lists the failed runs with their errors",
            report,
        )
    return report


def design_sweep(
    base: str,
    design: Any,
    out: PathLike,
    *,
    output: Mapping[str, Any],
    model: str = "reduced",
    seed: int = 0,
    horizon: Optional[float] = None,
    reduced: Optional[Mapping[str, float]] = None,
    **options: Any,
) -> Dict[str, Any]:
    """Runs one simulation per row of ``design`` into the folder ``out`` (a sweep with
    ``sampling = "rows"``): ``design`` is a pandas DataFrame or a dict of equally long columns,
    each column named by a scenario path (``"clearances[0].bearing_radius"``), each row a run.
    ``output`` is the sweep's ``[output]`` table (``{"channels": [...], "sample_rate": 1e4}``),
    ``reduced`` its ``[reduced]`` steps; ``options`` go to :func:`sweep` (threads, shard,
    allow_failures, progress). Returns the sweep's report.
    """
    columns = design.items() if hasattr(design, "items") else None
    if columns is None:
        raise TypeError("design: a pandas DataFrame or a dict of columns named by scenario paths")
    parameters = [{"path": str(path), "values": [float(v) for v in values]} for path, values in columns]
    spec: Dict[str, Any] = {
        "base": base,
        "model": model,
        "sampling": "rows",
        "seed": seed,
        "output": dict(output),
        "parameters": parameters,
    }
    if horizon is not None:
        spec["horizon"] = horizon
    if reduced is not None:
        spec["reduced"] = dict(reduced)
    return sweep(spec, out, **options)


def merge(shards: Sequence[PathLike], out: PathLike) -> int:
    """Merges the shard folders of one sweep (run with ``shard="i/N"``, possibly on other
    machines) into one dataset in ``out`` (``lash sweep merge``); returns its row count."""
    return _lash.merge([os.fspath(s) for s in shards], os.fspath(out))


def compare(
    scenario: Union[Scenario, PathLike],
    out: PathLike,
    *,
    report: bool = True,
    horizon: Optional[float] = None,
    macro_step: Optional[float] = None,
    micro_step: Optional[float] = None,
    interpolation: str = "linear",
    coupling: str = "auto",
    micro: str = "rk4",
    realisations: int = 1,
) -> Dict[str, Any]:
    """The converged full model, the reduced model and the ideal mechanism of a scenario side by
    side (``lash compare``): their runs, figures and ``comparison.json`` in ``out``, and with
    ``report`` the page ``out/report.html`` (see :func:`report`). The reduced model's options are
    :func:`run`'s; without ``macro_step`` it is chosen from the fastest rotation as :func:`run`
    chooses it (``macro_step_choice``); without ``micro_step`` it is chosen as the command line chooses it: 1e-5 s, or
    the largest step below that gives each clearance joint's impacts (their median duration in
    the full run) at least 7 steps (``comparison.json``'s ``micro_step_choice`` says why);
    ``coupling="auto"`` takes two-way coupling when the error estimate finds one-way coupling's
    own error past its bound and two-way the closer to the full model over the probe window
    (``coupling_choice`` says so). ``realisations`` > 1 holds the stated
    bounds against that many converged realisations of the full model (its atol moved up by
    rounding steps: where a pin rattles, each is another draw of the run's statistics);
    ``comparison.json``'s ``realisations`` says per check against how many it is met. Returns ``comparison.json`` as a dict (speed-ups, per-channel metrics, every
    clearance joint's impacts)."""
    s = scenario if isinstance(scenario, Scenario) else load(scenario)
    if horizon is not None:
        s = s.with_values({"simulation.horizon": horizon})
    text = _lash.compare(
        s, os.fspath(out), macro_step, micro_step, interpolation, coupling, micro, report, realisations
    )
    return json.loads(text)


def report(folder: PathLike, out: Optional[PathLike] = None) -> str:
    """Writes one self-contained HTML page of a run's folder (``lash run --out``) or a
    comparison's (``lash compare --out``, :func:`compare`): the mechanism animated from its
    bodies' poses, each clearance joint's journal orbit inside its clearance circle, every
    channel over time and crank angle (drag to zoom) and its spectrum on a log scale, the runs
    overlaid. Opens without network access. Returns the page's path (default
    ``folder/report.html``). Raises FileNotFoundError for a missing folder and
    :class:`ScenarioError` for a folder that holds no run."""
    folder = os.fspath(folder)
    if not os.path.isdir(folder):
        raise FileNotFoundError(f"{folder}: no such folder (a run's or a comparison's --out)")
    return _lash.report(folder, None if out is None else os.fspath(out))


class Dataset:
    """A sweep's dataset (its output folder) as arrays.

    * :attr:`values` — runs × samples × channels (the runs that completed, in run order);
    * :attr:`time` — the sample times [s], the same for every run;
    * :attr:`inputs` — runs × parameters, the varied parameters of each run of :attr:`values`;
    * :attr:`params` — every run (failed ones too) with seed, status, parameters and error,
      as a pandas DataFrame (a dict of arrays without pandas).

    ``lazy=True`` reads no samples up front (only the parameters, the layout and the first run):
    :meth:`batches` then reads each batch's runs from the file (one Parquet row group per run),
    so a dataset larger than memory can be trained on; :attr:`values` reads everything when
    first used.
    """

    def __init__(self, path: PathLike, *, lazy: bool = False):
        self.path: str = os.fspath(path)
        if not os.path.isdir(self.path):
            raise FileNotFoundError(f"{self.path}: no such dataset folder (a sweep's --out)")
        self.lazy: bool = lazy
        self._values: Optional[np.ndarray] = None
        if lazy:
            run_ids = np.asarray(_lash.read_layout(self.path), dtype=np.uint64)
            if len(run_ids) == 0:
                raise ScenarioError(f"{self.path}: the dataset has no completed run")
            _, time, names, units, _ = _lash.read_runs(self.path, [0])
        else:
            run_ids, time, names, units, values = _lash.read_dataset(self.path)
            self._values = values
        params = _lash.read_params(self.path)
        p_names, p_units, p_ids, p_seeds, p_status, p_values, p_errors = params
        self.run_ids: np.ndarray = run_ids
        """Run id of each run of :attr:`values` (and each row group of data.parquet)."""
        self.time: np.ndarray = time
        """Sample times [s]."""
        self.channels: List[str] = names
        """Channel names, in the order of the last axis of :attr:`values`."""
        self.units: Dict[str, str] = dict(zip(names, units))
        """SI unit of each channel."""
        self.parameters: List[str] = p_names
        """Varied parameters (scenario field paths), in column order."""
        self.parameter_units: Dict[str, str] = dict(zip(p_names, p_units))
        """SI unit of each parameter."""
        self._params = {
            "run_id": p_ids,
            "seed": p_seeds,
            "status": np.asarray(p_status, dtype=object),
            **{n: p_values[:, k] for k, n in enumerate(p_names)},
            "error": np.asarray(p_errors, dtype=object),
        }
        row_of = {int(r): i for i, r in enumerate(p_ids)}
        missing = [int(r) for r in run_ids if int(r) not in row_of]
        if missing:
            raise ScenarioError(f"{self.path}: runs {missing[:5]} have data but no row in params.parquet")
        self.inputs: np.ndarray = p_values[[row_of[int(r)] for r in run_ids]]
        """Parameters of each run of :attr:`values`, runs × parameters."""

    @property
    def values(self) -> np.ndarray:
        """Samples, runs × samples × channels (read on first use when the dataset is lazy)."""
        if self._values is None:
            self._values = _lash.read_dataset(self.path)[4]
        return self._values

    @property
    def params(self) -> "Any":
        """Every run's id, seed, status, parameter values and error (a DataFrame; units of the
        parameters in ``.attrs["units"]``), or a dict of arrays when pandas is not installed."""
        try:
            import pandas as pd
        except ImportError:
            return dict(self._params)
        df = pd.DataFrame(self._params)
        df.attrs["units"] = dict(self.parameter_units)
        return df

    @property
    def failed(self) -> List[Tuple[int, str]]:
        """(run id, error) of each failed run."""
        status, errors, ids = self._params["status"], self._params["error"], self._params["run_id"]
        return [(int(ids[i]), str(errors[i])) for i in range(len(ids)) if status[i] != "ok"]

    def channel(self, name: str) -> np.ndarray:
        """One channel of every run, runs × samples (a view)."""
        try:
            return self.values[:, :, self.channels.index(name)]
        except ValueError:
            raise KeyError(f"no channel {name!r} in {self.path} (channels: {', '.join(self.channels)})") from None

    def __len__(self) -> int:
        return len(self.run_ids)

    def __getitem__(self, index: int) -> Tuple[np.ndarray, np.ndarray]:
        """Run ``index`` (in :attr:`run_ids` order) as (inputs, values): its parameters and its
        samples × channels — a map-style dataset, so a PyTorch ``DataLoader`` takes it as it is::

            loader = torch.utils.data.DataLoader(lash.Dataset("out/sweep"), batch_size=32, shuffle=True)
            for inputs, values in loader: ...   # tensors: batch × parameters, batch × samples × channels

        A lazy dataset reads the one run from the file."""
        n = len(self)
        if not isinstance(index, (int, np.integer)):
            raise TypeError(f"a run index is an integer, got {type(index).__name__}")
        k = int(index) + n if index < 0 else int(index)
        if not 0 <= k < n:
            raise IndexError(f"run index {index} out of range for {n} runs")
        if self._values is not None:
            return self.inputs[k], self._values[k]
        return self.inputs[k], _lash.read_runs(self.path, [k])[4][0]

    def batches(
        self,
        batch_size: int,
        *,
        shuffle: bool = True,
        seed: int = 0,
        channels: Optional[Sequence[str]] = None,
        drop_last: bool = False,
    ) -> Iterator[Tuple[np.ndarray, np.ndarray]]:
        """Iterates over the runs in batches of ``batch_size``: (inputs, values) with inputs
        batch × parameters and values batch × samples × channels (``channels`` selects and orders
        them). ``shuffle`` draws the batches' runs from ``seed`` (the same seed, the same batches);
        within a batch the runs are in run order. A lazy dataset reads each batch from the file."""
        if batch_size < 1:
            raise ValueError(f"batch_size must be ≥ 1, got {batch_size}")
        columns = None
        if channels is not None:
            columns = []
            for c in channels:
                if c not in self.channels:
                    raise KeyError(f"no channel {c!r} in {self.path} (channels: {', '.join(self.channels)})")
                columns.append(self.channels.index(c))
        order = np.arange(len(self))
        if shuffle:
            np.random.default_rng(seed).shuffle(order)
        end = len(order) - (len(order) % batch_size if drop_last else 0)
        for start in range(0, end, batch_size):
            # Within a batch the runs come in file order (one sequential read when lazy).
            pick = np.sort(order[start : start + batch_size])
            if self._values is not None:
                y = self._values[pick]
            else:
                y = _lash.read_runs(self.path, [int(k) for k in pick])[4]
            if columns is not None:
                y = y[:, :, columns]
            yield self.inputs[pick], y

    def __repr__(self) -> str:
        runs, samples, channels = len(self), len(self.time), len(self.channels)
        return f"<lash.Dataset {self.path!r}: {runs} runs × {samples} samples × {channels} channels, {len(self.failed)} failed>"


def prepare_estimator(
    setup: str,
    out: PathLike,
    *,
    bank_runs: Optional[int] = None,
    calibration_runs: Optional[int] = None,
    quiet: bool = True,
    hidden_runs: Optional[int] = None,
) -> None:
    """Prepares an estimator once for ``setup`` (built-in ``"A"``, ``"C"``, ``"E"`` or a setup TOML
    file) and stores it as JSON in ``out``: a reduced-model sweep over the priors, the regression of
    every unknown on the vibration features, a calibration of the intervals on full-model runs and
    of the hidden signals' bands on ``hidden_runs`` full-model cases (``lash estimate prepare``).
    Raises ScenarioError for a bad setup."""
    _lash.prepare_estimator(str(setup), os.fspath(out), bank_runs, calibration_runs, quiet, hidden_runs)


def estimate(
    measurement: PathLike,
    prepared: PathLike,
    *,
    track_impacts: Optional[int] = None,
    track_draws: Optional[int] = None,
) -> Dict[str, Any]:
    """Diagnoses a machine from a measured file (CSV or Parquet: ``time [s]`` and the setup's
    channels with units) with an estimator made by :func:`prepare_estimator`.

    Returns a dict: ``unknowns`` (per unknown ``name``, ``unit``, ``median``, ``low`` and ``high``
    — the calibrated 5–95 % interval — and ``prior``), ``worn`` (with several clearance joints,
    ``[joint, probability]`` pairs), ``crank_frequency`` [Hz], ``clearance_draws`` (per clearance
    joint its calibrated posterior sample [m]), ``hidden`` (the virtual sensor: ``sample_rate``
    [Hz]; ``signals``, per joint its contact force [N] and eccentricity [m] at the measurement's
    instants, each a dict of numpy arrays ``median``, ``low``, ``high`` — the 5–95 % band over the
    posterior draws — with its ``name`` and ``unit``; per joint ``onsets`` (sample indices of impact
    onsets), ``force_rms`` and ``force_peak`` as [median, low, high]) and ``notes`` (what was done
    to the data). With ``track_impacts`` (a number of particles) the onsets are timed sample by
    sample by a particle filter on the micro model (``hidden["tracking"]`` says how well it followed
    the measurement; where it did not, the onsets are the draws'; where its simulations failed,
    ``hidden["tracking_failure"]`` says why and the onsets are the draws'); ``track_draws`` runs one filter
    on each of that many best-aligned posterior draws (default 4) and keeps the one that follows
    best. A bad file raises ScenarioError naming the column and the problem; a missing one
    FileNotFoundError."""
    path = os.fspath(measurement)
    if not os.path.exists(path):
        raise FileNotFoundError(path)
    result = json.loads(_lash.estimate_json(path, os.fspath(prepared), track_impacts, track_draws))
    answer = result["estimate"]
    hidden = result["hidden"]
    for signal in hidden["signals"]:
        for part in ("median", "low", "high"):
            signal[part] = np.asarray(signal[part], dtype=float)
    answer["hidden"] = hidden
    answer["notes"] = result["notes"]
    return answer


def emulate_measurement(
    prepared: PathLike,
    clearances: Sequence[float],
    out: PathLike,
    *,
    speed: Optional[float] = None,
    angle: float = 1.0,
    gain: float = 1.0,
    snr: float = 40.0,
    seed: int = 1,
) -> None:
    """Writes one measurement of the converged full model as the prepared setup's logger records
    it (CSV: ``time [s]`` and the setup's channels) — a machine whose clearances [m] you choose, to
    try :func:`estimate` on (``lash estimate emulate``)."""
    _lash.emulate_measurement(os.fspath(prepared), [float(c) for c in clearances], os.fspath(out), speed, angle, gain, snr, seed)

