"""Type stubs of lash's compiled module (see the Rust crate lash-py)."""

from os import PathLike
from typing import Any, Callable, Dict, List, Optional, Tuple, Union

import numpy as np

__version__: str

class ScenarioError(ValueError):
    """Invalid input; ``problems`` lists (field, message) pairs."""

    problems: List[Tuple[str, str]]

class SimulationError(RuntimeError):
    """A run or a sweep failed while simulating or writing."""

class Scenario:
    """A planar or spatial scenario, validated when made and when edited."""

    @staticmethod
    def builtin(name: str) -> Scenario: ...
    @staticmethod
    def load(path: Union[str, PathLike[str]]) -> Scenario: ...
    @staticmethod
    def from_toml(text: str) -> Scenario: ...
    @staticmethod
    def from_json(text: str) -> Scenario: ...
    @staticmethod
    def from_dict(fields: Dict[str, Any]) -> Scenario: ...
    def to_toml(self) -> str: ...
    def to_json(self) -> str: ...
    def to_dict(self) -> Dict[str, Any]: ...
    @property
    def name(self) -> str: ...
    @property
    def space(self) -> str: ...
    def get(self, path: str) -> float: ...
    def with_values(self, values: Dict[str, float]) -> Scenario: ...
    def validate(self) -> None: ...
    def channels(self, ideal: bool = False) -> List[Tuple[str, str]]: ...

def builtin_names() -> List[str]: ...
def run(
    scenario: Scenario,
    model: str = "full",
    ideal: bool = False,
    macro_step: Optional[float] = None,
    micro_step: Optional[float] = None,
    interpolation: str = "linear",
    coupling: str = "auto",
    micro: str = "rk4",
    threaded: bool = False,
    error_estimate: bool = False,
) -> Tuple[List[str], List[str], np.ndarray, str]: ...
def run_system(
    path: Union[str, PathLike[str]], step: Optional[float] = None, stop: Optional[float] = None
) -> Tuple[List[str], List[str], np.ndarray, str]: ...
def sweep_toml(json: str) -> str: ...
def merge(inputs: List[Union[str, PathLike[str]]], out: Union[str, PathLike[str]]) -> int: ...
def compare(
    scenario: Scenario,
    out: Union[str, PathLike[str]],
    macro_step: Optional[float],
    micro_step: Optional[float],
    interpolation: str,
    coupling: str,
    micro: str,
    report: bool,
    realisations: int,
) -> str: ...
def report(folder: Union[str, PathLike[str]], out: Optional[Union[str, PathLike[str]]] = None) -> str: ...
def validate_sweep(file: Union[str, PathLike[str]]) -> str: ...
def sweep(
    file: Union[str, PathLike[str]],
    out: Union[str, PathLike[str]],
    threads: Optional[int] = None,
    shard: Optional[str] = None,
    progress: Optional[Callable[[int, int, int], Any]] = None,
) -> str: ...
def read_dataset(
    dir: Union[str, PathLike[str]],
) -> Tuple[np.ndarray, np.ndarray, List[str], List[str], np.ndarray]: ...
def read_params(
    dir: Union[str, PathLike[str]],
) -> Tuple[List[str], List[str], np.ndarray, np.ndarray, List[str], np.ndarray, List[str]]: ...
def read_runs(
    dir: Union[str, PathLike[str]], groups: List[int]
) -> Tuple[np.ndarray, np.ndarray, List[str], List[str], np.ndarray]: ...
def read_layout(dir: Union[str, PathLike[str]]) -> List[int]: ...
def prepare_estimator(
    setup: str,
    out: Union[str, PathLike[str]],
    bank_runs: Optional[int] = None,
    calibration_runs: Optional[int] = None,
    quiet: bool = True,
    hidden_runs: Optional[int] = None,
) -> None: ...
def estimate_json(
    measurement: Union[str, PathLike[str]],
    prepared: Union[str, PathLike[str]],
    track_impacts: Optional[int] = ...,
    track_draws: Optional[int] = ...,
) -> str: ...
def emulate_measurement(
    prepared: Union[str, PathLike[str]],
    clearances: List[float],
    out: Union[str, PathLike[str]],
    speed: Optional[float] = None,
    angle: float = 1.0,
    gain: float = 1.0,
    snr: float = 40.0,
    seed: int = 1,
) -> None: ...
