"""An adapter for stable-baselines3: :class:`SB3VecEnv` exposes a vertibench vector environment as an SB3
``VecEnv``, so ``PPO("MultiInputPolicy", SB3VecEnv(...))`` trains on environments stepped in Rust threads.

It follows SB3's conventions: ``reset()`` returns only the observations, ``step_wait()`` returns ``(obs, rewards,
dones, infos)`` with one info dict per environment; an environment whose episode ended is reset at once and its last
observation is in ``infos[i]["terminal_observation"]``, with ``infos[i]["TimeLimit.truncated"]`` true when the
episode hit the time limit (so SB3 bootstraps from it). ``infos[i]["episode"]`` holds ``r`` (return), ``l``
(length) and ``t``, as SB3's ``Monitor`` writes it, so ``ep_rew_mean`` and ``ep_len_mean`` are logged; the other
entries are the environment's end-of-episode info (``outcome``, ``success``, ``metrics``, ...).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env.base_vec_env import VecEnv

from .planner import Planner, env_observation
from .vector import VertibenchVectorEnv


def _pick(batched: dict, i: int) -> dict:
    """Environment ``i``'s entries of a gymnasium vector info dict (masks dropped)."""
    return {k: _pick(v, i) if isinstance(v, dict) else v[i] for k, v in batched.items() if not k.startswith("_")}


class SB3VecEnv(VecEnv):
    """``num_envs`` vertibench environments as an SB3 ``VecEnv`` for training (keyword arguments as
    :func:`vertibench.make_vec`; actions are clipped to the action space by default, as SB3 expects of an
    environment). ``task_set`` defaults to the training set :func:`vertibench.tasks.training` (seed 7), never the
    benchmark's: pass ``task_set=`` for another."""

    render_mode = None

    def __init__(self, num_envs: int, tasks="all", clip_actions: bool = True, task_set=None, **kwargs):
        if task_set is None:
            from . import tasks as task_sets

            task_set = task_sets.training()
        self.venv = VertibenchVectorEnv(
            num_envs, tasks=tasks, task_set=task_set, autoreset_mode=AutoresetMode.SAME_STEP,
            clip_actions=clip_actions, **kwargs
        )
        super().__init__(num_envs, self.venv.single_observation_space, self.venv.single_action_space)
        self._actions = None
        self._returns = np.zeros(num_envs)
        self._lengths = np.zeros(num_envs, dtype=np.int64)
        self._time = 0.0

    def reset(self):
        seed = self._seeds[0]
        obs, info = self.venv.reset(seed=seed)
        self._reset_seeds()
        self.reset_infos = [{"task_id": t} for t in info["task_id"]]
        self._returns[:] = 0.0
        self._lengths[:] = 0
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self):
        obs, rewards, term, trunc, info = self.venv.step(self._actions)
        self._returns += rewards
        self._lengths += 1
        self._time += self.venv.control_period
        dones = term | trunc
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        for i in np.flatnonzero(dones):
            end = _pick(info["final_info"], i)
            end["terminal_observation"] = info["final_obs"][i]
            end["TimeLimit.truncated"] = bool(trunc[i] and not term[i])
            end["episode"] = {"r": float(self._returns[i]), "l": int(self._lengths[i]), "t": round(self._time, 6)}
            infos[i] = end
            self._returns[i] = 0.0
            self._lengths[i] = 0
        return obs, rewards.astype(np.float32), dones, infos

    def close(self) -> None:
        self.venv.close()

    # SB3's attribute plumbing: every environment shares the vector's settings.
    def get_attr(self, attr_name: str, indices=None):
        return [getattr(self.venv, attr_name, None) for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        setattr(self.venv, attr_name, value)

    def env_method(self, method_name: str, *args, indices=None, **kwargs):
        return [getattr(self.venv, method_name)(*args, **kwargs) for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class, indices=None):
        return [False for _ in self._get_indices(indices)]


class PolicyPlanner(Planner):
    """A trained SB3 policy as a :class:`vertibench.planner.Planner`, for :func:`vertibench.evaluate` and
    :func:`vertibench.serve.serve`: it builds the environments' observation (:func:`env_observation`), normalises it
    with ``vec_normalize`` when given (the ``VecNormalize`` the policy was trained with) and acts
    deterministically. ``crop_size`` and ``crop_resolution`` must be those of the training environments."""

    def __init__(self, model, vec_normalize=None, name: str = "sb3-policy", crop_size: int = 0,
                 crop_resolution: float = 1.0, control_rate_hz: float = 20.0):
        self.model = model
        self.vec_normalize = vec_normalize
        self.name = name
        self.crop_size = crop_size
        self.crop_resolution = crop_resolution
        self.control_rate_hz = control_rate_hz
        low, high = model.action_space.low, model.action_space.high
        self._low, self._high = low.astype(np.float64), high.astype(np.float64)

    def params(self) -> dict:
        """Its settings, the policy's weights and the observation normalisation's statistics (arrays count by
        their bytes): a retrained policy is another planner to :func:`vertibench.evaluate`'s resume."""
        p = super().params()
        p["policy"] = self.model.policy.parameters_to_vector()
        rms = getattr(self.vec_normalize, "obs_rms", None)
        if isinstance(rms, dict):
            p["obs_rms"] = {k: [r.mean, r.var] for k, r in rms.items()}
        elif rms is not None:
            p["obs_rms"] = [rms.mean, rms.var]
        return p

    def reset(self, task, vehicle, maps):
        self.goal = task.goal

    def act(self, obs):
        o = {k: v[None] for k, v in env_observation(obs, self.goal).items()}
        if self.vec_normalize is not None:
            o = self.vec_normalize.normalize_obs(o)
        action, _ = self.model.predict(o, deterministic=True)
        return tuple(np.clip(np.asarray(action, dtype=np.float64).reshape(3), self._low, self._high))
