"""vertibench: the off-road mobility benchmark on vertically challenging terrain, from Python.

- :func:`make` and :func:`make_vec`: gymnasium environments (one, or a vector stepped in Rust threads).
- :mod:`vertibench.planner`: a base class for planners; :func:`vertibench.serve.serve` runs one for the benchmark
  service.
- :func:`evaluate`: run a Python planner on the benchmark in-process, writing ``vb eval``'s files.
"""

from __future__ import annotations

from gymnasium.vector import AutoresetMode

from . import _core
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

SIM_VERSION: str = _core.SIM_VERSION
#: Named splits of the task set accepted by ``tasks=`` (with ``"all"``, world ids and task ids like ``w017-t3``).
SPLITS: tuple[str, ...] = tuple(_core.SPLITS)


def vehicles() -> list[str]:
    """Names of the vehicles in the catalogue."""
    return list(_core.vehicles())


def make(task: str | None = None, **kwargs) -> VertibenchEnv:
    """One environment: on ``task`` (an id like ``"w017-t3"``) when given, else on tasks drawn from ``tasks=``.

    Keyword arguments: ``tasks`` (``"all"``, a split name such as ``"low"`` or ``"rigid"``, or ids), ``task_set`` (a
    task directory; default: the benchmark's), ``vehicle`` (``"hmmwv"``; see :func:`vehicles`), ``scale``,
    ``control_rate_hz`` (20), ``crop_size`` (0: no map crops) and ``crop_resolution`` (m per cell; default 1 m x the
    world scale), ``rules`` (``"paper"`` or ``"release"``), ``max_time`` (60 s), ``reward`` (weights, see
    :data:`DEFAULT_REWARD`), ``clip_actions`` (False: an out-of-range action fails the episode, as in the benchmark).
    """
    return VertibenchEnv(task, **kwargs)


def make_vec(num_envs: int, tasks="all", **kwargs) -> VertibenchVectorEnv:
    """``num_envs`` environments stepped together in Rust threads (the GIL released).

    Takes :func:`make`'s keyword arguments and ``autoreset_mode`` (gymnasium's ``AutoresetMode``; ``NEXT_STEP`` by
    default), ``task_order`` (``"random"``: each environment draws tasks uniformly from its own seeded generator;
    ``"cycle"``: environment ``i`` runs tasks ``i, i + n, ...``) and ``num_threads`` (default: all cores).
    """
    return VertibenchVectorEnv(num_envs, tasks=tasks, **kwargs)


__all__ = [
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
