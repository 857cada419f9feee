"""Python planners: the :class:`Planner` base class and the types it sees.

A planner drives one episode at a time. :meth:`Planner.reset` gets the task (start, goal, global path, factors), the
vehicle's facts and the ground-truth maps of the world; :meth:`Planner.act` gets an :class:`Observation` at the
planner's control rate (``control_rate_hz``) and returns an :class:`Action` (or a ``(steering, throttle, brake)``
tuple). Simulated time is frozen while the planner thinks. An exception fails the episode with reason
``planner_crash`` (its traceback is the episode's detail); an out-of-range or NaN action fails it with reason
``invalid_action``.

The same planner runs in-process with :func:`vertibench.evaluate` and on the benchmark service with :func:`serve`
(``vb-submit exec -- python my_planner.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass
class Task:
    """A navigation task: world coordinates in m (x east, y north, origin at the map centre)."""

    id: str
    world_id: int
    index: int
    start: np.ndarray
    goal: np.ndarray
    #: The global path from start to goal (A* on the obstacle grid), ``(n, 2)``.
    path: np.ndarray
    level: str
    semantics: str
    density: str
    scale: float


@dataclass
class Maps:
    """Ground-truth maps of the world, sampled on its heightmap grid: ``elevation[iy, ix]`` (m) at
    ``x = (ix - (nx - 1) / 2) * cell``, ``y = (iy - (ny - 1) / 2) * cell``; ``semantics`` (release label ids: clay 0
    ... snow 9), ``obstacles`` (1 = occupied) and ``friction`` (Coulomb friction of rigid ground, 0 where
    deformable)."""

    elevation: np.ndarray
    semantics: np.ndarray
    obstacles: np.ndarray
    friction: np.ndarray
    cell: float

    def position(self, ix, iy):
        """World position of sample ``(ix, iy)``."""
        ny, nx = self.elevation.shape
        return (np.asarray(ix) - (nx - 1) / 2) * self.cell, (np.asarray(iy) - (ny - 1) / 2) * self.cell


@dataclass
class Observation:
    """The vehicle's ground-truth state and, when the planner asked for them (``crop_size > 0``), heading-aligned
    map crops of ``crop_size x crop_size`` cells of ``crop_resolution`` m (row 0 ahead, column 0 on the left):
    ``elevation`` in absolute height (m), ``semantics`` (255 off the map), ``obstacles`` (1 = occupied or off the
    map)."""

    time: float
    position: np.ndarray
    roll: float
    pitch: float
    yaw: float
    #: World-frame linear velocity, m/s.
    velocity: np.ndarray
    #: Chassis-frame angular velocity, rad/s.
    angular_velocity: np.ndarray
    #: Signed forward speed, m/s.
    speed: float
    #: Applied steering (after rate limits), normalised.
    steering: float
    elevation: np.ndarray | None = None
    semantics: np.ndarray | None = None
    obstacles: np.ndarray | None = None


@dataclass
class Action:
    """Steering in [-1, 1] (+1 is full left), throttle in [-1, 1] (negative: reverse), brake in [0, 1]."""

    steering: float = 0.0
    throttle: float = 0.0
    brake: float = 0.0


class Planner:
    """Base class of Python planners: override :meth:`reset` and :meth:`act`; set the class attributes ``name``,
    ``control_rate_hz`` and, for map crops in every observation, ``crop_size`` and ``crop_resolution`` (m)."""

    name: str = "python"
    control_rate_hz: float = 20.0
    crop_size: int = 0
    crop_resolution: float = 1.0

    def reset(self, task: Task, vehicle: dict, maps: Maps) -> None:
        """Prepares for a new episode (``vehicle``: name, scale, wheelbase, track, length, width, max_steer,
        skid_steer, nominal_speed, max_speed)."""

    def act(self, obs: Observation):
        """Returns the next :class:`Action` (or a ``(steering, throttle, brake)`` tuple)."""
        raise NotImplementedError("a Planner must implement act()")


def action_tuple(a) -> tuple[float, float, float]:
    """An action as ``(steering, throttle, brake)`` floats, from an :class:`Action`, a dict or a sequence."""
    if isinstance(a, Action):
        return float(a.steering), float(a.throttle), float(a.brake)
    if isinstance(a, dict):
        return float(a.get("steering", 0.0)), float(a.get("throttle", 0.0)), float(a.get("brake", 0.0))
    s, t, b = (float(v) for v in a)
    return s, t, b


def make_task(d: dict) -> Task:
    return Task(
        id=d["id"],
        world_id=int(d["world_id"]),
        index=int(d["index"]),
        start=np.asarray(d["start"], dtype=np.float64),
        goal=np.asarray(d["goal"], dtype=np.float64),
        path=np.asarray(d["path"], dtype=np.float64).reshape(-1, 2),
        level=d["level"],
        semantics=d["semantics"],
        density=d["density"],
        scale=float(d["scale"]),
    )


def make_observation(state, crops=None) -> Observation:
    """An observation from the state in protocol order (time, x, y, z, roll, pitch, yaw, vx, vy, vz, wx, wy, wz,
    speed, steering) and optional ``(elevation, semantics, obstacles)`` crops."""
    t, x, y, z, roll, pitch, yaw, vx, vy, vz, wx, wy, wz, speed, steering = state
    o = Observation(
        time=t,
        position=np.array([x, y, z]),
        roll=roll,
        pitch=pitch,
        yaw=yaw,
        velocity=np.array([vx, vy, vz]),
        angular_velocity=np.array([wx, wy, wz]),
        speed=speed,
        steering=steering,
    )
    if crops is not None:
        o.elevation, o.semantics, o.obstacles = crops
    return o


def env_observation(obs: Observation, goal) -> dict:
    """The gymnasium environments' observation for ``obs`` with the goal at ``goal`` (world x, y): ``state`` and
    ``goal`` vectors and, when ``obs`` has crops, ``elevation`` relative to the vehicle's height, ``semantics`` and
    ``obstacles``. A policy trained on the environments can then drive as a :class:`Planner` (see
    ``vertibench.sb3.PolicyPlanner``)."""
    x, y, z = (float(v) for v in obs.position)
    state = np.array([x, y, z, obs.roll, obs.pitch, obs.yaw, *obs.velocity, *obs.angular_velocity, obs.speed,
                      obs.steering, obs.time], dtype=np.float64)
    dx, dy = float(goal[0]) - x, float(goal[1]) - y
    s, c = math.sin(obs.yaw), math.cos(obs.yaw)
    d = {"state": state, "goal": np.array([c * dx + s * dy, -s * dx + c * dy, float(np.hypot(dx, dy))])}
    if obs.elevation is not None:
        d["elevation"] = obs.elevation - np.float32(z)
        d["semantics"] = obs.semantics
        d["obstacles"] = obs.obstacles
    return d


def serve(planner: Planner, address: str | None = None, **kwargs):
    """Serves ``planner`` over the benchmark's ``Planner`` gRPC protocol (:func:`vertibench.serve.serve`)."""
    from .serve import serve as _serve

    return _serve(planner, address, **kwargs)


def _core_reset(planner: Planner, task: dict, vehicle: dict, maps: dict, sim_dt: float) -> None:
    """Called by the native runner at the start of an episode."""
    planner.reset(make_task(task), vehicle, Maps(**maps))


def _core_act(planner: Planner, state, crops):
    """Called by the native runner at every control step."""
    return action_tuple(planner.act(make_observation(state, crops)))
