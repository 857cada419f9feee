"""Observation and action spaces of the vertibench environments, and the option checks they share."""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from . import _core

#: Names of the entries of ``obs["state"]``, in order: position (m), roll, pitch, yaw (rad), linear velocity in the
#: world frame (m/s), angular velocity in the chassis frame (rad/s), signed forward speed (m/s), applied steering
#: (normalised) and simulated time (s).
STATE_FIELDS: tuple[str, ...] = tuple(_core.STATE_FIELDS)
#: Names of the entries of ``obs["goal"]``: the goal in the vehicle's heading frame (m ahead, m to the left) and its
#: horizontal distance (m).
GOAL_FIELDS: tuple[str, ...] = tuple(_core.GOAL_FIELDS)
#: Names of the action's entries, in order.
ACTION_FIELDS: tuple[str, ...] = ("steering", "throttle", "brake")
#: Names of the reward terms (``info["reward_terms"]``), in order.
REWARD_TERMS: tuple[str, ...] = ("progress", "roll", "pitch", "terminal")


def action_space() -> spaces.Box:
    """Steering in [-1, 1] (+1 full left), throttle in [-1, 1] (negative: reverse), brake in [0, 1]."""
    return spaces.Box(
        low=np.array([-1.0, -1.0, 0.0], dtype=np.float32),
        high=np.array([1.0, 1.0, 1.0], dtype=np.float32),
        dtype=np.float32,
    )


def observation_space(crop_size: int, believed: bool = False) -> spaces.Dict:
    """The observation: ``state`` and ``goal`` vectors and, with ``crop_size > 0``, heading-aligned crops of
    ``crop_size x crop_size`` cells (row 0 ahead, column 0 on the left): ``elevation`` relative to the vehicle's
    height (m), ``semantics`` (release label ids, 255 off the map) and ``obstacles`` (1 = occupied or off the map).
    ``believed`` (a perception profile that degrades the maps): the crops are the believed map's, with ``known``
    (1 where the height has been seen; ``elevation`` is 0 elsewhere)."""
    d = {
        "state": spaces.Box(-np.inf, np.inf, (len(STATE_FIELDS),), np.float64),
        "goal": spaces.Box(-np.inf, np.inf, (len(GOAL_FIELDS),), np.float64),
    }
    if crop_size > 0:
        shape = (crop_size, crop_size)
        d["elevation"] = spaces.Box(-np.inf, np.inf, shape, np.float32)
        d["semantics"] = spaces.Box(0, 255, shape, np.uint8)
        d["obstacles"] = spaces.Box(0, 1, shape, np.uint8)
        if believed:
            d["known"] = spaces.Box(0, 1, shape, np.uint8)
    return spaces.Dict(d)


def reward_weights(reward: dict | None) -> list[float] | None:
    """The core's weight vector from a dict of weights (missing keys keep their defaults)."""
    if reward is None:
        return None
    defaults = dict(DEFAULT_REWARD)
    unknown = set(reward) - set(defaults)
    if unknown:
        raise ValueError(f"reward= has unknown weights {sorted(unknown)}; known: {sorted(defaults)}")
    defaults.update(reward)
    return [float(defaults[k]) for k in DEFAULT_REWARD]


#: Default reward weights. ``reward = progress + roll + pitch + terminal``, where ``progress = w_progress x`` the
#: decrease of the horizontal distance to the goal over the step (m, divided by the world scale), ``roll =
#: -w_roll x (roll / 30 deg)^2`` and ``pitch = -w_pitch x (pitch / 30 deg)^2`` at the end of the step (penalties: never
#: positive), and ``terminal = +success_bonus`` on success, ``-failure_penalty`` when the episode ends any other way
#: except the time limit (0 then).
DEFAULT_REWARD: dict[str, float] = {
    "progress": 1.0,
    "roll": 0.1,
    "pitch": 0.1,
    "success_bonus": 10.0,
    "failure_penalty": 10.0,
}


def task_spec(tasks) -> str:
    """``"all"``, a split name, or ids (a string, or a list of world ids and task ids) as one selection string."""
    if isinstance(tasks, str):
        if not tasks.strip():
            raise ValueError("tasks is empty: pass 'all', a split name or task ids")
        return tasks
    items = [str(t) for t in tasks]
    if not items:
        raise ValueError("tasks is empty: pass 'all', a split name or task ids")
    return ",".join(items)


def core_kwargs(
    task_set,
    tasks,
    vehicle: str,
    scale,
    control_rate_hz: float,
    crop_size: int,
    crop_resolution,
    rules: str,
    max_time,
    reward,
) -> dict:
    """Keyword arguments of ``_core.VecCore`` from the public options (shared by both environment kinds), each
    checked with an error that names it."""
    crop_size = check_int(crop_size, "crop_size", 0, 512)
    check_positive(control_rate_hz, "control_rate_hz")
    for name, value in (("scale", scale), ("crop_resolution", crop_resolution), ("max_time", max_time)):
        if value is not None:
            check_positive(value, name)
    if rules not in ("paper", "release"):
        raise ValueError(f"rules={rules!r} is not 'paper' or 'release'")
    known = list(_core.vehicles())
    if vehicle not in known:
        raise ValueError(f"vehicle={vehicle!r} is not a vehicle of the catalogue: {', '.join(known)}")
    if task_set is not None:
        from pathlib import Path

        if not (Path(task_set) / "manifest.json").is_file():
            raise ValueError(f"task_set={str(task_set)!r} holds no task set (no manifest.json): give a directory "
                             "made by vertibench.tasks.generate or vb tasks generate, or None for the benchmark's")
    return dict(
        task_dir=str(task_set) if task_set is not None else default_task_set(),
        tasks=task_spec(tasks),
        vehicle=vehicle,
        scale=scale,
        control_rate_hz=control_rate_hz,
        crop_size=int(crop_size),
        crop_resolution=crop_resolution,
        rules=rules,
        max_time=max_time,
        reward=reward_weights(reward),
    )


def check_int(value, name: str, lo: int, hi: int | None = None) -> int:
    """``value`` as an int in ``[lo, hi]``, or an error naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name}={value!r} must be an int")
    if value < lo or (hi is not None and value > hi):
        bound = f"at least {lo}" if hi is None else f"in {lo}..{hi}"
        raise ValueError(f"{name}={value} must be {bound}")
    return int(value)


def check_positive(value, name: str) -> float:
    """``value`` as a finite positive float, or an error naming ``name``."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name}={value!r} must be a number") from None
    if not (np.isfinite(v) and v > 0):
        raise ValueError(f"{name}={value} must be finite and positive")
    return v


def check_action_shape(action, shape: tuple[int, ...], name: str) -> np.ndarray:
    """``action`` as a float64 array of exactly ``shape`` (no silent reshaping of, say, (1, 3) or (3, 1) into
    (3,)), or an error naming ``name``."""
    try:
        a = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise TypeError(f"{name} must be numbers of shape {shape}: {e}") from None
    if a.shape != shape:
        raise ValueError(f"{name} has shape {a.shape}; expected {shape} (steering, throttle, brake)")
    return a


def default_task_set() -> str:
    """The benchmark's task set (``$VB_TASK_DIR`` when set), as a string; see :mod:`vertibench.tasks`."""
    from .tasks import default_task_set as _default

    return str(_default())
