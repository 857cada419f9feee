"""``VertibenchVectorEnv``: a ``gymnasium.vector.VectorEnv`` whose environments all step in Rust threads with the
GIL released; every step returns whole-batch NumPy arrays."""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.utils import EzPickle
from gymnasium.vector.utils import batch_space

from . import _core
from ._spaces import REWARD_TERMS, action_space, check_action_shape, check_int, core_kwargs, observation_space

_MODES = {
    AutoresetMode.NEXT_STEP: "next_step",
    AutoresetMode.SAME_STEP: "same_step",
    AutoresetMode.DISABLED: "disabled",
}


class VertibenchVectorEnv(VectorEnv, EzPickle):
    """``num_envs`` vertibench environments (see :func:`vertibench.make_vec` for the options).

    ``step`` returns ``(obs, reward, terminated, truncated, info)`` with NumPy arrays over the environments;
    ``info["reward_terms"]`` holds each reward term per environment, ``info["task_id"]`` the task each one runs, and,
    for the environments whose episode ended on this step (mask ``info["_outcome"]``): ``outcome``, ``success``,
    ``reason``, ``detail`` and ``metrics`` (a dict of arrays). With ``autoreset_mode=SAME_STEP`` the last observation
    is in ``info["final_obs"]`` and the ended episode's info in ``info["final_info"]``, as gymnasium's own vector
    environments do. The vector pickles by its options (``EzPickle``): an unpickled copy needs ``reset()``.
    """

    def __init__(
        self,
        num_envs: int,
        *,
        tasks="all",
        task_set=None,
        vehicle: str = "hmmwv",
        scale: float | None = None,
        control_rate_hz: float = 20.0,
        crop_size: int = 0,
        crop_resolution: float | None = None,
        rules: str = "paper",
        max_time: float | None = None,
        reward: dict | None = None,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        task_order: str = "random",
        clip_actions: bool = False,
        num_threads: int | None = None,
        perception: str = "ideal",
    ):
        EzPickle.__init__(
            self, num_envs, tasks=tasks, task_set=task_set, vehicle=vehicle, scale=scale,
            control_rate_hz=control_rate_hz, crop_size=crop_size, crop_resolution=crop_resolution, rules=rules,
            max_time=max_time, reward=reward, autoreset_mode=autoreset_mode, task_order=task_order,
            clip_actions=clip_actions, num_threads=num_threads, perception=perception,
        )
        num_envs = check_int(num_envs, "num_envs", 1, 4096)
        if num_threads is not None:
            num_threads = check_int(num_threads, "num_threads", 1)
        if task_order not in ("random", "cycle"):
            raise ValueError(f"task_order={task_order!r} is not 'random' or 'cycle'")
        try:
            mode = AutoresetMode(autoreset_mode)
        except ValueError:
            modes = [m.value for m in AutoresetMode]
            raise ValueError(f"autoreset_mode={autoreset_mode!r} is not one of {modes}") from None
        self._core = _core.VecCore(
            num_envs,
            autoreset=_MODES[mode],
            task_order=task_order,
            num_threads=num_threads,
            perception=str(perception),
            **core_kwargs(
                task_set, tasks, vehicle, scale, control_rate_hz, crop_size, crop_resolution, rules, max_time, reward
            ),
        )
        self.num_envs = num_envs
        self.metadata = {"autoreset_mode": mode, "render_modes": []}
        self.single_observation_space = observation_space(self._core.crop_size, self._core.believed)
        self.single_action_space = action_space()
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.clip_actions = clip_actions
        self.task_ids: list[str] = self._core.task_ids
        self._task_ids = np.array(self.task_ids, dtype=object)
        self._tasks = np.zeros(num_envs, dtype=np.int64)
        self._lo = self.single_action_space.low.astype(np.float64)
        self._hi = self.single_action_space.high.astype(np.float64)

    # --- facts -------------------------------------------------------------------------------------------------
    @property
    def vehicle(self) -> dict:
        """The vehicle's facts (name, scale, wheelbase, track, length, width, max_steer, skid_steer, nominal_speed,
        max_speed)."""
        return self._core.vehicle

    @property
    def control_period(self) -> float:
        """Simulated seconds per step."""
        return self._core.control_period

    @property
    def physics_dt(self) -> float:
        """The simulator's fixed step, s (``control_period`` is a whole number of them)."""
        return self._core.physics_dt

    @property
    def task_set_version(self) -> str:
        return self._core.task_set_version

    # --- gymnasium API -----------------------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """Starts new episodes. ``seed`` restarts each environment's task draws (environment ``i`` uses
        ``seed + i``); ``options["reset_mask"]`` resets only some environments; ``options["tasks"]`` (one task id or
        None per environment) chooses their tasks."""
        options = options or {}
        mask = options.get("reset_mask")
        if mask is not None:
            mask = np.asarray(mask, dtype=bool)
        tasks = options.get("tasks")
        if tasks is not None:
            tasks = [None if t is None else self._task_index(t) for t in tasks]
        if seed is None and self._np_random is None:
            seed = int(np.random.SeedSequence().generate_state(1, np.uint64)[0] >> np.uint64(1))
        if seed is not None:
            self._np_random_seed = seed
            self._np_random = np.random.default_rng(seed)
        obs, task_index = self._core.reset(seed=seed, mask=mask, tasks=tasks)
        self._tasks[:] = task_index
        return obs, {"task_id": self._task_ids[self._tasks]}

    def step(self, actions):
        a = check_action_shape(actions, (self.num_envs, 3), "actions")
        if self.clip_actions:
            a = np.clip(a, self._lo, self._hi)
        obs, terms, terminated, truncated, was_reset, task_index, ended = self._core.step(a)
        self._tasks[:] = task_index
        reward = terms.sum(axis=1)
        info: dict[str, Any] = {
            "reward_terms": {name: terms[:, k] for k, name in enumerate(REWARD_TERMS)},
            "task_id": self._task_ids[self._tasks],
        }
        same_step = self.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
        for i, e in ended:
            if same_step:
                final_obs = {k: v[0] for k, v in e.pop("final_obs").items()}
                info = self._add_info(info, {"final_obs": final_obs, "final_info": dict(e)}, i)
            else:
                info = self._add_info(info, e, i)
        if was_reset.any():
            info["_reset"] = was_reset
        return obs, reward, terminated, truncated, info

    def close_extras(self, **kwargs):
        self._core = None

    def _task_index(self, task_id: str) -> int:
        try:
            return self.task_ids.index(task_id)
        except ValueError:
            raise ValueError(f"task {task_id!r} is not among this environment's tasks") from None
