"""The training worlds: the task set check (never the benchmark's), the held-out worlds (index 9 mod 10) used
only for evaluation, task selections by difficulty, the policy's inputs from the environment's observations (the
Rust features, ``_core.policy_features``) and the deterministic held-out evaluation."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import torch
from gymnasium.vector import AutoresetMode

from .. import _core
from .. import tasks as task_sets
from ..vector import VertibenchVectorEnv
from .policy import ActorCritic

#: A world is held out for evaluation when its index is this modulo 10 (w009, w019, ...).
HELD_OUT_MOD: int = 9


class TrainError(Exception):
    """Bad input to a training: reported as one line, never a traceback."""


def check_task_set(path: str | os.PathLike | None) -> task_sets.TaskSetInfo:
    """The task set's facts; refuses a missing directory and the benchmark's own set."""
    if path is None:
        path = task_sets.training()
    p = Path(path)
    if not (p / "manifest.json").is_file():
        raise TrainError(f"no task set in {p} (no manifest.json): make one with `vb tasks generate --seed N --out "
                         f"{p}` or leave --task-set out for vertibench.tasks.training()")
    try:
        info = task_sets.info(p)
    except ValueError as e:
        raise TrainError(f"task set {p} does not load: {e}") from None
    if info.version == task_sets.benchmark_version():
        raise TrainError(f"{p} is the benchmark's own task set (version {info.version}): never train on it; "
                         "use vertibench.tasks.training() or `vb tasks generate --seed N` with another seed")
    return info


def world_index(task_id: str) -> int:
    """``w017-t3`` -> 17."""
    return int(task_id.split("-")[0][1:])


def held_out(task_id: str) -> bool:
    return world_index(task_id) % 10 == HELD_OUT_MOD


def select(task_set: Path, spec: str) -> list[str]:
    """The task ids a selection (``all``, split names such as ``low+rigid``, ``,`` for unions) names, in id order,
    as the environment parses it."""
    env = VertibenchVectorEnv(1, tasks=spec, task_set=task_set, num_threads=1)
    try:
        return list(env.task_ids)
    finally:
        env.close()


@dataclass
class Split:
    """Training and held-out task ids of a task set (id order)."""

    train: list[str]
    held_out: list[str]

    @classmethod
    def of(cls, ids: Sequence[str]) -> "Split":
        train = [t for t in ids if not held_out(t)]
        test = [t for t in ids if held_out(t)]
        if not train or not test:
            raise TrainError(f"the task set has {len(train)} training and {len(test)} held-out tasks: it needs both "
                             "(held out: worlds whose index is 9 mod 10)")
        return cls(train, test)


class Inputs:
    """The policy's inputs from vector-environment observations: ``_core.policy_features`` (the Rust layout)."""

    def __init__(self, vehicle: dict[str, Any]) -> None:
        self.scale = float(vehicle["scale"])
        self.nominal_speed = float(vehicle["nominal_speed"])

    def __call__(self, obs: dict[str, np.ndarray], last_throttle: np.ndarray,
                 rows: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        def pick(a: np.ndarray) -> np.ndarray:
            return a if rows is None else np.ascontiguousarray(a[rows])

        thr = np.ascontiguousarray(last_throttle if rows is None else last_throttle[rows], dtype=np.float64)
        vec, crop = _core.policy_features(pick(obs["state"]), pick(obs["goal"]), thr, pick(obs["elevation"]),
                                          pick(obs["obstacles"]), self.scale, self.nominal_speed)
        return np.require(vec, np.float32, ["C", "W"]), np.require(crop, np.float32, ["C", "W"])


def make_env(n: int, task_ids: Sequence[str], task_set: Path, control_rate_hz: float) -> VertibenchVectorEnv:
    """``n`` environments over ``task_ids`` with the policy's crops (16 cells, default resolution); the caller resets
    ended environments (autoreset disabled) and picks their tasks."""
    return VertibenchVectorEnv(n, tasks=list(task_ids), task_set=task_set, crop_size=_core.POLICY_CROP_SIZE,
                               autoreset_mode=AutoresetMode.DISABLED, control_rate_hz=control_rate_hz)


def env_action(steer_throttle: np.ndarray) -> np.ndarray:
    """The environment's ``(steering, throttle, brake=0)`` from the policy's two clipped outputs."""
    a = np.zeros((steer_throttle.shape[0], 3), np.float64)
    a[:, :2] = np.clip(steer_throttle, -1.0, 1.0)
    return a


def evaluate(model: ActorCritic, env: VertibenchVectorEnv, inputs: Inputs, tasks: Sequence[str]) -> dict[str, float]:
    """Runs one deterministic episode (``clamp(mean)``) on each of ``tasks`` (repeats allowed) in ``env`` and
    returns ``success`` (rate), ``return`` (mean undiscounted return) and ``episodes``."""
    n = env.num_envs
    queue = list(tasks)
    k = len(queue)
    slot_task: list[int | None] = [None] * n
    first = [queue[i] if i < k else queue[0] for i in range(n)]
    for i in range(min(n, k)):
        slot_task[i] = i
    nxt = min(n, k)
    obs, _ = env.reset(options={"tasks": first})
    thr = np.zeros(n)
    ret = np.zeros(n)
    successes, returns, finished = 0, [], 0
    while finished < k:
        vec, crop = inputs(obs, thr)
        with torch.no_grad():
            a = model.act(torch.from_numpy(vec), torch.from_numpy(crop)).numpy()
        act = env_action(a)
        obs, r, term, trunc, info = env.step(act)
        thr = act[:, 1].copy()
        ret += r
        done = term | trunc
        if not done.any():
            continue
        picks: list[str | None] = [None] * n
        for i in map(int, np.flatnonzero(done)):
            if slot_task[i] is not None:
                finished += 1
                successes += int(bool(info["success"][i]))
                returns.append(float(ret[i]))
            if nxt < k:
                slot_task[i], picks[i] = nxt, queue[nxt]
                nxt += 1
            else:
                slot_task[i], picks[i] = None, queue[0]
        ret[done] = 0.0
        thr[done] = 0.0
        obs, _ = env.reset(options={"reset_mask": done, "tasks": picks})
    return {"success": successes / k, "return": float(np.mean(returns)), "episodes": float(k)}
