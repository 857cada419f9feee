"""Python planners: the :class:`Planner` base class and the types it sees.

A planner drives one episode at a time. :meth:`Planner.reset` gets the task (start, goal, global path, factors), the
vehicle's facts and the ground-truth maps of the world; :meth:`Planner.act` gets an :class:`Observation` at the
planner's control rate (``control_rate_hz``) and returns an :class:`Action` (or a ``(steering, throttle, brake)``
tuple). Simulated time is frozen while the planner thinks, but not the wall clock: a call past its deadline
(:func:`vertibench.evaluate`'s ``step_timeout``; the service's per-step deadline) fails the episode with reason
``planner_timeout``. An exception fails the episode with reason ``planner_crash`` (its traceback is the episode's
detail); an out-of-range or NaN action fails it with reason ``invalid_action``.

The same planner runs in-process with :func:`vertibench.evaluate` and on the benchmark service with :func:`serve`
(``vb-submit exec -- python my_planner.py``).
"""

from __future__ import annotations

import functools
import hashlib
import json
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
    deformable).

    Under a perception profile that degrades the maps (``believed``), they are what the planner believes: heights
    ``NaN`` where the vehicle's sensor has not seen yet (``known`` is the mask), patches as classified, the obstacles
    detected so far; the arrays are updated in place as the episode goes, so a planner that keeps them from
    ``reset`` always reads the map built so far."""

    elevation: np.ndarray
    semantics: np.ndarray
    obstacles: np.ndarray
    friction: np.ndarray
    cell: float
    believed: bool = False

    @property
    def known(self) -> np.ndarray:
        """Where the height is known (always everywhere under ground truth)."""
        return np.isfinite(self.elevation)

    def update(self, x0: int, y0: int, elevation: np.ndarray, obstacles: np.ndarray) -> None:
        """Pastes a rectangle of the believed maps from sample ``(x0, y0)`` (a ``MapUpdate``)."""
        ny, nx = elevation.shape
        self.elevation[y0:y0 + ny, x0:x0 + nx] = elevation
        self.obstacles[y0:y0 + ny, x0:x0 + nx] = obstacles

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
    ``control_rate_hz`` and, for map crops in every observation, ``crop_size`` and ``crop_resolution`` (m).

    A planner's identity is its class (``module.qualname``), its ``name`` and either its ``version`` (when set) or
    its :meth:`params`. :func:`vertibench.evaluate` stores it with the results and resumes an evaluation only with
    the same planner, so episodes of two planners never mix in one ``out=``."""

    name: str = "python"
    control_rate_hz: float = 20.0
    crop_size: int = 0
    crop_resolution: float = 1.0
    #: An explicit version (a string or a number): when set, it stands for the planner's parameters in its
    #: identity (bump it when the planner changes; :meth:`params` is then not looked at).
    version: str | int | None = None

    def __init_subclass__(cls, **kwargs):
        # Records the parameters a subclass's own constructor set, once it returns (see `params`).
        super().__init_subclass__(**kwargs)
        for method in ("__init__", "__post_init__"):
            if method in cls.__dict__:
                setattr(cls, method, _recording(cls, cls.__dict__[method]))

    def __init__(self):
        _record_params(self)

    def __post_init__(self):
        # A dataclass's generated constructor calls this.
        _record_params(self)

    def params(self) -> dict:
        """The planner's declared parameters, part of its identity (hashed) unless it sets ``version``.

        By default: its public instance attributes (names without a leading ``_``) as its constructor set them,
        those whose values are JSON data (numbers, strings, booleans, None, and lists, tuples and string-keyed dicts
        of them) or numpy arrays and scalars (an array counts by its dtype, shape and bytes); other values (a
        model object, a file handle) are left out. State set later, in :meth:`reset` or :meth:`act`, is not a
        parameter. Override it to return a dict of JSON data (or set ``version``) when that is not what tells two
        configurations of the planner apart."""
        recorded = self.__dict__.get("_vb_params")
        return dict(recorded) if recorded is not None else _json_params(self)

    def reset(self, task: Task, vehicle: dict, maps: Maps) -> None:
        """Prepares for a new episode (``vehicle``: name, scale, wheelbase, track, length, width, max_steer,
        skid_steer, nominal_speed, max_speed)."""

    def act(self, obs: Observation):
        """Returns the next :class:`Action` (or a ``(steering, throttle, brake)`` tuple)."""
        raise NotImplementedError("a Planner must implement act()")


class _NotJson(Exception):
    pass


def _json_value(v):
    """``v`` as JSON data (numpy arrays by dtype, shape and SHA-256 of their bytes); :class:`_NotJson` if it is not
    data."""
    if v is None or isinstance(v, (bool, int, float, str)):
        return v
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        if v.dtype.hasobject:
            raise _NotJson
        digest = hashlib.sha256(np.ascontiguousarray(v).tobytes()).hexdigest()
        return {"ndarray": {"dtype": v.dtype.str, "shape": list(v.shape), "sha256": digest}}
    if isinstance(v, (list, tuple)):
        return [_json_value(x) for x in v]
    if isinstance(v, dict):
        if not all(isinstance(k, str) for k in v):
            raise _NotJson
        return {k: _json_value(x) for k, x in v.items()}
    raise _NotJson


def _json_params(planner) -> dict:
    """The public instance attributes of ``planner`` that are JSON data (see :meth:`Planner.params`)."""
    out = {}
    for k, v in vars(planner).items():
        if k.startswith("_"):
            continue
        try:
            out[k] = _json_value(v)
        except _NotJson:
            pass
    return out


def _record_params(planner) -> None:
    planner.__dict__["_vb_params"] = _json_params(planner)


def _recording(cls, f):
    """``f`` (a constructor of ``cls``), then the parameters it set recorded when ``cls`` is the instance's class
    (a subclass's constructor records after its own)."""

    @functools.wraps(f)
    def wrapper(self, *args, **kwargs):
        f(self, *args, **kwargs)
        if type(self) is cls:
            _record_params(self)

    return wrapper


def identity(planner: Planner) -> dict:
    """The planner's identity as :func:`vertibench.evaluate` stores it (``planner.json`` in ``out``): ``kind``,
    ``name``, ``class`` and either ``version`` or ``params_sha256``: the SHA-256 of ``control_rate_hz``,
    ``crop_size``, ``crop_resolution`` and :meth:`Planner.params` as sorted, compact JSON (with ``params``
    themselves when they are short)."""
    cls = type(planner)
    d = {"kind": "python", "name": str(planner.name), "class": f"{cls.__module__}.{cls.__qualname__}"}
    version = getattr(planner, "version", None)
    if version is not None:
        d["version"] = str(version)
        return d
    params = planner.params()
    if not isinstance(params, dict):
        raise TypeError(f"{cls.__qualname__}.params() must return a dict, not {type(params).__name__}")
    # The settings the benchmark reads count as parameters too.
    settings = {"control_rate_hz": planner.control_rate_hz, "crop_size": planner.crop_size,
                "crop_resolution": planner.crop_resolution}
    try:
        params = {k: _json_value(v) for k, v in settings.items()} | {
            str(k): _json_value(v) for k, v in params.items()}
    except _NotJson:
        raise TypeError(f"{cls.__qualname__}.params() must return a dict of JSON data (numbers, strings, lists, "
                        "dicts, numpy arrays)") from None
    text = json.dumps(params, sort_keys=True, separators=(",", ":"))
    d["params_sha256"] = hashlib.sha256(text.encode()).hexdigest()
    if len(text) <= 4096:
        d["params"] = params
    return d


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


#: The maps each planner object was given at its last reset (by id), which believed-map updates go into.
_MAPS: dict[int, Maps] = {}


def _core_reset(planner: Planner, task: dict, vehicle: dict, maps: dict, sim_dt: float) -> None:
    """Called by the native runner at the start of an episode."""
    m = Maps(**maps)
    _MAPS[id(planner)] = m
    planner.reset(make_task(task), vehicle, m)


def _core_act(planner: Planner, state, crops, update=None):
    """Called by the native runner at every control step; ``update``: the patch of believed maps that changed since
    the last step (under a perception profile that degrades the maps), pasted into the planner's ``Maps``."""
    if update is not None and id(planner) in _MAPS:
        _MAPS[id(planner)].update(*update)
    return action_tuple(planner.act(make_observation(state, crops)))
