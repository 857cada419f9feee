"""Type stubs of the native core (``vertibench._core``, a PyO3 extension). Use the documented Python API
(``vertibench.make``, ``make_vec``, ``evaluate``, ...) rather than these directly."""

from os import PathLike
from typing import Any

import numpy as np
import numpy.typing as npt

__version__: str
SIM_VERSION: str
BENCHMARK_SEED: int
STATE_FIELDS: list[str]
GOAL_FIELDS: list[str]
SPLITS: list[str]
PROTO_DESCRIPTOR_SET: bytes
POLICY_LAYOUT: str
POLICY_FEATURES: list[str]
POLICY_CROP_SIZE: int
KINO_LAYOUT: str
KINO_FEATURES: list[str]
KINO_TARGETS: list[str]
KINO_CROP_SIZE: int
KINO_CROP_META: str
KINO_CODE: int
KINO_STEP_FRAMES: int
TAL_LAYOUT: str
TAL_OFFSETS: list[str]
TAL_MAP_SIZE: int
TAL_MAP_META: str
TAL_ANCHOR_STEPS: int
TAL_EMBED: int
TAL_GATE_HIDDEN: int
TNT_LAYOUT: str
TNT_CHANNELS: list[str]
TNT_HEADINGS: int
TNT_GRID: int

def benchmark_task_dir(cache: str) -> str: ...
def benchmark_task_version() -> str: ...
def generate(out: str, seed: int, surface: str | None = None) -> tuple[str, str]: ...
def task_set_info(dir: str) -> tuple[str, int | None, str, int]: ...
def vehicles() -> list[str]: ...

class VecCore:
    num_envs: int
    task_ids: list[str]
    task_factors: list[tuple[str, str, str]]
    task_set_version: str
    crop_size: int
    crop_resolution: float
    believed: bool
    scale: float
    max_time: float
    vehicle: dict[str, Any]
    physics_dt: float
    control_period: float
    def __init__(
        self,
        num_envs: int,
        task_dir: str | PathLike[str],
        tasks: str = "all",
        vehicle: str = "hmmwv",
        scale: float | None = None,
        control_rate_hz: float = 20.0,
        crop_size: int = 0,
        crop_resolution: float | None = None,
        rules: str = "paper",
        max_time: float | None = None,
        reward: list[float] | None = None,
        autoreset: str = "next_step",
        task_order: str = "random",
        num_threads: int | None = None,
        perception: str = "ideal",
    ) -> None: ...
    def task(self, k: int) -> dict[str, Any]: ...
    def maps(self, k: int) -> dict[str, Any]: ...
    def picture(self, k: int, ppm: int) -> npt.NDArray[np.uint8]: ...
    def reset(
        self,
        seed: int | None = None,
        mask: npt.NDArray[np.bool_] | None = None,
        tasks: list[int | None] | None = None,
    ) -> tuple[dict[str, np.ndarray], list[int]]: ...
    def step(
        self, actions: npt.NDArray[np.float64]
    ) -> tuple[
        dict[str, np.ndarray],
        npt.NDArray[np.float64],
        npt.NDArray[np.bool_],
        npt.NDArray[np.bool_],
        npt.NDArray[np.bool_],
        list[int],
        list[tuple[int, dict[str, Any]]],
    ]: ...

def evaluate(
    planner: Any,
    out: str | PathLike[str],
    task_dir: str | PathLike[str],
    tasks: str = "all",
    vehicle: str = "hmmwv",
    scale: float | None = None,
    rules: str = "paper",
    progress: bool = True,
    identity: str | None = None,
    step_timeout: float | None = None,
    num_threads: int | None = None,
) -> tuple[dict[str, list[Any]], bool]: ...
def raw_throughput(
    num_envs: int,
    steps: int,
    task_dir: str | PathLike[str],
    tasks: str = "all",
    action: tuple[float, float, float] = (0.3, 0.5, 0.0),
    num_threads: int | None = None,
) -> tuple[int, float]: ...

def policy_features(
    state: np.ndarray,
    goal: np.ndarray,
    last_throttle: np.ndarray,
    elevation: np.ndarray,
    obstacles: np.ndarray,
    scale: float,
    nominal_speed: float,
) -> tuple[np.ndarray, np.ndarray]: ...

class PolicyNet:
    def __init__(self, path: str | PathLike[str]) -> None: ...
    @property
    def metadata(self) -> dict[str, str]: ...
    def act(self, vec: np.ndarray, crop: np.ndarray) -> np.ndarray: ...

class KinoData:
    def __init__(self, task_dir: str | PathLike[str], vehicle: str, scale: float) -> None: ...
    @property
    def vehicle(self) -> dict[str, Any]: ...
    @property
    def target_factors(self) -> list[float]: ...
    def features(
        self, world_id: int, before: np.ndarray, now: np.ndarray, steering: np.ndarray, action: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]: ...
    def targets(self, now: np.ndarray, after: np.ndarray, steering_after: np.ndarray) -> np.ndarray: ...
    def apply(self, now: np.ndarray, pred: np.ndarray) -> np.ndarray: ...
    def tal_inputs(self, world_id: int, anchor: np.ndarray, now: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...
    def simulate(self, world_id: int, states: np.ndarray, actions: np.ndarray, control_rate_hz: float) -> np.ndarray: ...

class KinoNet:
    def __init__(self, path: str | PathLike[str]) -> None: ...
    @property
    def metadata(self) -> dict[str, str]: ...
    def predict(self, vec: np.ndarray, crop: np.ndarray) -> np.ndarray: ...

class TravNet:
    def __init__(self, path: str | PathLike[str]) -> None: ...
    @property
    def metadata(self) -> dict[str, str]: ...
    def estimate(self, maps: np.ndarray) -> np.ndarray: ...

def tnt_grid_index(anchor: np.ndarray, poses: np.ndarray, scale: float) -> np.ndarray: ...

class TalNet:
    def __init__(self, path: str | PathLike[str]) -> None: ...
    @property
    def metadata(self) -> dict[str, str]: ...
    def predict(self, vec: np.ndarray, map: np.ndarray, offset: np.ndarray) -> np.ndarray: ...
