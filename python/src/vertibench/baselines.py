"""Reference planners in Python: :class:`PID`, the benchmark's PID baseline re-implemented line by line (it gives
the built-in ``pid``'s results, which the tests check), and :func:`point_ahead`, its path follower."""

from __future__ import annotations

import math

import numpy as np

from .planner import Action, Planner


def point_ahead(path, pos, start: int, ahead: float):
    """Projects ``pos`` on the polyline ``path`` (searching segments from ``start`` on, so progress is monotone)
    and returns the point ``ahead`` m further along the path (its last point if it ends sooner) and the index of
    the segment the projection lies on."""
    n = len(path)
    if n < 2:
        return (tuple(path[0]) if n else tuple(pos)), 0
    first = min(start, n - 2)
    best = (math.inf, first, 0.0)
    for i in range(first, n - 1):
        ax, ay = path[i]
        bx, by = path[i + 1]
        dx, dy = bx - ax, by - ay
        len2 = dx * dx + dy * dy
        t = min(max(((pos[0] - ax) * dx + (pos[1] - ay) * dy) / len2, 0.0), 1.0) if len2 > 0.0 else 0.0
        d = _hypot(ax + t * dx - pos[0], ay + t * dy - pos[1])
        if d < best[0]:
            best = (d, i, t)
    _, seg, t = best
    remaining = ahead
    a = (
        path[seg][0] + t * (path[seg + 1][0] - path[seg][0]),
        path[seg][1] + t * (path[seg + 1][1] - path[seg][1]),
    )
    for b in path[seg + 1 :]:
        length = _hypot(b[0] - a[0], b[1] - a[1])
        if length >= remaining and length > 0.0:
            u = remaining / length
            return (a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1])), seg
        remaining -= length
        a = (b[0], b[1])
    return (path[-1][0], path[-1][1]), seg


def _hypot(x: float, y: float) -> float:
    # The C library's hypot, as Rust's f64::hypot (math.hypot is CPython's own and may differ in the last bit).
    return float(np.hypot(x, y))


def _clamp(v: float, lo: float, hi: float) -> float:
    return min(max(v, lo), hi)


class PID(Planner):
    """Local goal 10 m (scaled) ahead on the global path, heading P control (gain 1 per rad) with a steering rate
    limit of 0.5 per step, PI speed control to the vehicle's nominal speed, at 20 Hz."""

    name = "pid-python"
    control_rate_hz = 20.0

    def reset(self, task, vehicle, maps):
        self.path = [(float(x), float(y)) for x, y in task.path]
        self.progress = 0
        self.scale = task.scale
        self.speed = vehicle["nominal_speed"]
        self.steer = 0.0
        self.integral = 0.0

    def act(self, obs):
        x, y = float(obs.position[0]), float(obs.position[1])
        goal, self.progress = point_ahead(self.path, (x, y), self.progress, 10.0 * self.scale)
        e = math.atan2(goal[1] - y, goal[0] - x) - obs.yaw
        e = math.atan2(math.sin(e), math.cos(e))
        self.steer += _clamp(_clamp(e, -1.0, 1.0) - self.steer, -0.5, 0.5)
        err = self.speed - obs.speed
        self.integral = _clamp(self.integral + err / self.control_rate_hz, -2.0, 2.0)
        u = (1.0 * err + 0.3 * self.integral) / max(self.speed, 1e-6)
        return Action(self.steer, _clamp(u, 0.0, 1.0), _clamp(-u, 0.0, 1.0) * 0.5)
