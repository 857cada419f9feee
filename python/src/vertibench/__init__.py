"""vertibench: the off-road mobility benchmark on vertically challenging terrain, from Python.

- :func:`make` and :func:`make_vec`: gymnasium environments (one, or a vector stepped in Rust threads); also
  registered with gymnasium as ``"vertibench/Nav-v0"`` (``gym.make("vertibench/Nav-v0", task="w017-t3")``,
  ``gym.make_vec("vertibench/Nav-v0", num_envs=8)``).
- :mod:`vertibench.tasks`: the benchmark's task set (carried by the package) and training sets generated from other
  seeds (:func:`vertibench.tasks.training`); never train on the benchmark's tasks.
- :mod:`vertibench.planner`: a base class for planners; :func:`vertibench.serve.serve` runs one for the benchmark
  service.
- :func:`evaluate`: run a Python planner on the benchmark in-process, writing ``vb eval``'s files.
- :mod:`vertibench.render`: top-view frames and episode videos.
"""

from __future__ import annotations

from os import PathLike
from typing import Sequence

import gymnasium as gym
from gymnasium.vector import AutoresetMode

from . import _core, datasets, tasks
from ._spaces import (
    ACTION_FIELDS,
    DEFAULT_REWARD,
    GOAL_FIELDS,
    REWARD_TERMS,
    STATE_FIELDS,
    default_task_set,
)
from .env import VertibenchEnv
from .evaluation import evaluate
from .planner import Action, Observation, Planner
from .vector import VertibenchVectorEnv

__version__: str = _core.__version__
SIM_VERSION: str = _core.SIM_VERSION
#: The gymnasium id of the navigation environment (its vector entry point is :class:`VertibenchVectorEnv`).
ENV_ID = "vertibench/Nav-v0"
#: Named splits of the task set accepted by ``tasks=`` (with ``"all"``, world ids and task ids like ``w017-t3``).
SPLITS: tuple[str, ...] = tuple(_core.SPLITS)


def vehicles() -> list[str]:
    """Names of the vehicles in the catalogue."""
    return list(_core.vehicles())


def make(
    task: str | None = None,
    *,
    tasks: str | Sequence[str | int] = "all",
    task_set: str | PathLike | None = None,
    vehicle: str = "hmmwv",
    scale: float | None = None,
    control_rate_hz: float = 20.0,
    crop_size: int = 0,
    crop_resolution: float | None = None,
    rules: str = "paper",
    max_time: float | None = None,
    reward: dict[str, float] | None = None,
    clip_actions: bool = False,
    render_mode: str | None = None,
    render_ppm: int = 3,
    perception: str = "ideal",
) -> VertibenchEnv:
    """One environment: on ``task`` (an id like ``"w017-t3"``) when given, else on tasks drawn from ``tasks``.

    ``tasks``: ``"all"``, a split name such as ``"low"`` or ``"rigid"`` (``,`` a union, ``+`` an intersection), or
    ids; ``task_set``: a task directory (default: the benchmark's, :func:`vertibench.tasks.benchmark`; train on
    :func:`vertibench.tasks.training`); ``vehicle``: see :func:`vehicles`; ``scale``: world scale (default: the
    vehicle's); ``control_rate_hz``: steps per simulated second; ``crop_size``: map crops of that many cells a side
    in every observation (0: none) at ``crop_resolution`` m per cell (default 1 m x the world scale); ``rules``:
    ``"paper"`` or ``"release"``; ``max_time``: the time limit, s (60); ``reward``: weights (see
    :data:`DEFAULT_REWARD`); ``clip_actions``: clip actions to the action space (default: an out-of-range action
    fails the episode, as in the benchmark); ``render_mode``: ``"rgb_array"`` for top-view frames of
    ``render_ppm`` pixels per map sample; ``perception``: a perception profile (``"ideal"``, ``"nominal"``,
    ``"degraded"`` or a TOML file; perception/PROFILES.md) between the truth and the observations, as in ``vb eval
    --perception`` (the state is the estimate and, under a map-degrading profile, the crops are the believed map's,
    ``NaN`` where unseen; rewards stay the truth's). The environment's ``spec`` is that of :data:`ENV_ID` with these
    options.
    """
    options = dict(
        tasks=tasks, task_set=task_set, vehicle=vehicle, scale=scale, control_rate_hz=control_rate_hz,
        crop_size=crop_size, crop_resolution=crop_resolution, rules=rules, max_time=max_time, reward=reward,
        clip_actions=clip_actions, render_mode=render_mode, render_ppm=render_ppm, perception=perception,
    )
    env = VertibenchEnv(task, **options)
    env.spec = _spec(dict(task=task, **options))
    return env


def make_vec(
    num_envs: int,
    tasks: str | Sequence[str | int] = "all",
    *,
    task_set: str | PathLike | None = None,
    vehicle: str = "hmmwv",
    scale: float | None = None,
    control_rate_hz: float = 20.0,
    crop_size: int = 0,
    crop_resolution: float | None = None,
    rules: str = "paper",
    max_time: float | None = None,
    reward: dict[str, float] | None = None,
    clip_actions: bool = False,
    autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
    task_order: str = "random",
    num_threads: int | None = None,
    perception: str = "ideal",
) -> VertibenchVectorEnv:
    """``num_envs`` environments stepped together in Rust threads (the GIL released).

    Takes :func:`make`'s options and ``autoreset_mode`` (gymnasium's ``AutoresetMode``; ``NEXT_STEP`` by default),
    ``task_order`` (``"random"``: each environment draws tasks uniformly from its own seeded generator; ``"cycle"``:
    environment ``i`` runs tasks ``i, i + n, ...``) and ``num_threads`` (default: every core, at most one per
    environment).
    """
    return VertibenchVectorEnv(
        num_envs, tasks=tasks, task_set=task_set, vehicle=vehicle, scale=scale, control_rate_hz=control_rate_hz,
        crop_size=crop_size, crop_resolution=crop_resolution, rules=rules, max_time=max_time, reward=reward,
        clip_actions=clip_actions, autoreset_mode=autoreset_mode, task_order=task_order, num_threads=num_threads,
        perception=perception,
    )


def _register() -> None:
    """Registers :data:`ENV_ID` with gymnasium (once per process)."""
    if ENV_ID not in gym.registry:
        gym.register(
            id=ENV_ID,
            entry_point="vertibench.env:VertibenchEnv",
            vector_entry_point="vertibench.vector:VertibenchVectorEnv",
        )


def _spec(kwargs: dict):
    """:data:`ENV_ID`'s spec with ``kwargs``, as ``gym.make`` would set it."""
    import copy

    spec = copy.deepcopy(gym.spec(ENV_ID))
    spec.kwargs = kwargs
    return spec


_register()

__all__ = [
    "ENV_ID",
    "__version__",
    "datasets",
    "tasks",
    "ACTION_FIELDS",
    "AutoresetMode",
    "DEFAULT_REWARD",
    "GOAL_FIELDS",
    "REWARD_TERMS",
    "SIM_VERSION",
    "SPLITS",
    "STATE_FIELDS",
    "VertibenchEnv",
    "VertibenchVectorEnv",
    "Action",
    "Observation",
    "Planner",
    "default_task_set",
    "evaluate",
    "make",
    "make_vec",
    "vehicles",
]
