"""``VertibenchEnv``: one vertibench environment as a ``gymnasium.Env``."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.utils import EzPickle

from . import _core
from .planner import Maps, make_task
from ._spaces import REWARD_TERMS, action_space, check_action_shape, check_int, core_kwargs, observation_space


class VertibenchEnv(gym.Env, EzPickle):
    """One environment (see :func:`vertibench.make` for the options).

    An episode is one benchmark task: the vehicle starts at rest at the task's start facing the goal and the episode
    follows ``vb eval``'s rules. ``terminated`` is true when the episode reached an end of the task (success,
    rollover, stuck, off the map, or an invalid action); ``truncated`` when it hit the time limit (``max_time``,
    60 s by default). ``info`` has the reward terms at every step and, at the end, ``outcome`` (``success``,
    ``rollover``, ``stuck``, ``timeout``, ``off_map``, ``planner_failure``), ``success``, ``reason``, ``detail`` and
    ``metrics`` (traversal time, roll and pitch, path length, energy, ...).

    ``render_mode="rgb_array"``: :meth:`render` returns a top view of the map (north up; hill shade tinted by
    semantic class, obstacles, the task's global path in red, start in green, goal in blue) with the path driven so
    far and the vehicle, ``render_ppm`` pixels per map sample (:func:`vertibench.render.record_episode` writes an
    episode's frames as a GIF). The environment pickles by its options (``EzPickle``): an unpickled copy is a new
    environment that needs ``reset()``.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(
        self,
        task: str | None = None,
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
        clip_actions: bool = False,
        render_mode: str | None = None,
        render_ppm: int = 3,
        perception: str = "ideal",
    ):
        EzPickle.__init__(
            self, task, tasks=tasks, task_set=task_set, vehicle=vehicle, scale=scale, control_rate_hz=control_rate_hz,
            crop_size=crop_size, crop_resolution=crop_resolution, rules=rules, max_time=max_time, reward=reward,
            clip_actions=clip_actions, render_mode=render_mode, render_ppm=render_ppm, perception=perception,
        )
        if task is not None and not (isinstance(tasks, str) and tasks == "all"):
            raise ValueError(f"give task= (one task) or tasks= (a selection), not both: task={task!r}, tasks={tasks!r}")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode={render_mode!r} is not None or 'rgb_array'")
        self.render_mode = render_mode
        self.render_ppm = check_int(render_ppm, "render_ppm", 1, 16)
        self._view = None
        self._core = _core.VecCore(
            1,
            autoreset="disabled",
            task_order="random",
            num_threads=1,
            perception=str(perception),
            **core_kwargs(
                task_set,
                task if task is not None else tasks,
                vehicle,
                scale,
                control_rate_hz,
                crop_size,
                crop_resolution,
                rules,
                max_time,
                reward,
            ),
        )
        self.observation_space = observation_space(self._core.crop_size, self._core.believed)
        self.action_space = action_space()
        self.clip_actions = clip_actions
        self.task_ids: list[str] = self._core.task_ids
        self.task_id: str | None = None
        self._lo = self.action_space.low.astype(np.float64)
        self._hi = self.action_space.high.astype(np.float64)
        self._seeded = False

    @property
    def vehicle(self) -> dict:
        """The vehicle's facts (name, scale, wheelbase, track, length, width, max_steer, ...)."""
        return self._core.vehicle

    @property
    def task(self):
        """The current episode's :class:`vertibench.planner.Task` (start, goal, global path, factors)."""
        if self.task_id is None:
            raise RuntimeError("call reset() first")
        return make_task(self._core.task(self.task_ids.index(self.task_id)))

    @property
    def maps(self):
        """The current episode's world maps (:class:`vertibench.planner.Maps`: elevation, semantics, obstacles,
        friction on the heightmap grid)."""
        if self.task_id is None:
            raise RuntimeError("call reset() first")
        if self._core.believed:
            raise ValueError("the perception profile degrades the maps: the ground-truth maps are not given; the "
                             "observations' crops are the believed ones (with their `known` mask)")
        return Maps(**self._core.maps(self.task_ids.index(self.task_id)))

    @property
    def control_period(self) -> float:
        """Simulated seconds per step."""
        return self._core.control_period

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """Starts an episode on a task drawn from the selection (``seed`` restarts the draws), or on
        ``options["task"]`` (a task id)."""
        super().reset(seed=seed)
        if seed is None and not self._seeded:
            seed = int(self.np_random.integers(0, 2**63 - 1))
        self._seeded = True
        task = (options or {}).get("task")
        pick = None if task is None else [self._task_index(task)]
        obs, tasks = self._core.reset(seed=seed, tasks=pick)
        self.task_id = self.task_ids[tasks[0]]
        obs = {k: v[0] for k, v in obs.items()}
        if self.render_mode == "rgb_array":
            self._start_view(tasks[0], obs)
        return obs, {"task_id": self.task_id}

    def step(self, action):
        a = check_action_shape(action, (3,), "action").reshape(1, 3)
        if self.clip_actions:
            a = np.clip(a, self._lo, self._hi)
        obs, terms, terminated, truncated, _, _, ended = self._core.step(a)
        info: dict[str, Any] = {
            "task_id": self.task_id,
            "reward_terms": {name: float(terms[0, k]) for k, name in enumerate(REWARD_TERMS)},
        }
        for _, e in ended:
            info.update(e)
        obs = {k: v[0] for k, v in obs.items()}
        self._last_state = obs["state"]
        return (
            obs,
            float(terms[0].sum()),
            bool(terminated[0]),
            bool(truncated[0]),
            info,
        )

    def render(self):
        """With ``render_mode="rgb_array"``: the current frame, ``(H, W, 3)`` uint8 (see the class docstring)."""
        if self.render_mode is None:
            gym.logger.warn("render() needs render_mode='rgb_array' when the environment is made")
            return None
        if self._view is None:
            raise RuntimeError("call reset() before render()")
        x, y, _, _, _, yaw = (float(v) for v in self._last_state[:6])
        v = self._core.vehicle
        return self._view.frame(x, y, yaw, float(v["length"]), float(v["width"]))

    def _start_view(self, k: int, obs) -> None:
        from .render import TopView

        m = self._core.maps(k)
        ny, nx = np.asarray(m["elevation"]).shape
        self._view = TopView(self._core.picture(k, self.render_ppm), self.render_ppm, nx, ny, float(m["cell"]))
        self._last_state = obs["state"]

    def _task_index(self, task_id: str) -> int:
        try:
            return self.task_ids.index(task_id)
        except ValueError:
            raise ValueError(f"task {task_id!r} is not among this environment's tasks") from None
