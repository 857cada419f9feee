"""Pictures of episodes: ``render_mode="rgb_array"`` frames (a top view of the map, north up, with the task's global
path, the path driven so far and the vehicle) and :func:`save_video`, which writes frames as a GIF (Pillow) or, for
``.mp4``, through imageio when it is installed. :func:`record_episode` runs a policy for one episode and saves it.
"""

from __future__ import annotations

import math
import os
from typing import Callable, Sequence

import numpy as np

#: Colours of what a frame draws over the map.
DRIVEN = (250, 210, 30)
VEHICLE = (255, 40, 170)
VEHICLE_EDGE = (0, 0, 0)


class TopView:
    """Draws frames over one task's map picture (``base``: ``(H, W, 3)`` at ``ppm`` pixels per sample of a
    heightmap with ``nx x ny`` samples ``cell`` m apart, centred on the origin)."""

    def __init__(self, base: np.ndarray, ppm: int, nx: int, ny: int, cell: float):
        self.base, self.ppm, self.nx, self.ny, self.cell = base, ppm, nx, ny, cell
        self.trail: list[tuple[float, float]] = []

    def pixel(self, x: float, y: float) -> tuple[float, float]:
        """Pixel (column, row) of world point ``(x, y)``."""
        fx = x / self.cell + (self.nx - 1) / 2
        fy = y / self.cell + (self.ny - 1) / 2
        return (fx + 0.5) * self.ppm, (self.ny - 1 - fy + 0.5) * self.ppm

    def frame(self, x: float, y: float, yaw: float, length: float, width: float) -> np.ndarray:
        """The map with the trail up to ``(x, y)`` and the vehicle there, heading ``yaw``."""
        self.trail.append((x, y))
        img = self.base.copy()
        pts = [self.pixel(px, py) for px, py in self.trail]
        for a, b in zip(pts, pts[1:]):
            _line(img, a, b, max(1.0, self.ppm * 0.35), DRIVEN)
        c, s = math.cos(yaw), math.sin(yaw)
        half_l, half_w = max(length / 2, self.cell), max(width / 2, self.cell * 0.5)
        corners = [self.pixel(x + c * u - s * v, y + s * u + c * v)
                   for u, v in ((half_l, half_w), (half_l, -half_w), (-half_l, -half_w), (-half_l, half_w))]
        _polygon(img, corners, VEHICLE)
        nose = self.pixel(x + c * half_l, y + s * half_l)
        _line(img, self.pixel(x, y), nose, max(1.0, self.ppm * 0.3), VEHICLE_EDGE)
        return img


def _line(img: np.ndarray, a, b, width: float, colour) -> None:
    """A thick segment from pixel ``a`` to pixel ``b``."""
    h, w, _ = img.shape
    n = int(max(abs(b[0] - a[0]), abs(b[1] - a[1]))) + 1
    xs = np.linspace(a[0], b[0], n)
    ys = np.linspace(a[1], b[1], n)
    r = int(math.ceil(width / 2))
    for dx in range(-r, r + 1):
        for dy in range(-r, r + 1):
            if dx * dx + dy * dy <= (width / 2) ** 2 + 0.25:
                cx = np.clip(xs.astype(int) + dx, 0, w - 1)
                cy = np.clip(ys.astype(int) + dy, 0, h - 1)
                img[cy, cx] = colour


def _polygon(img: np.ndarray, corners, colour) -> None:
    """Fills a convex polygon given by pixel corners."""
    h, w, _ = img.shape
    xs = [p[0] for p in corners]
    ys = [p[1] for p in corners]
    x0, x1 = max(int(min(xs)), 0), min(int(max(xs)) + 1, w - 1)
    y0, y1 = max(int(min(ys)), 0), min(int(max(ys)) + 1, h - 1)
    if x0 > x1 or y0 > y1:
        return
    gx, gy = np.meshgrid(np.arange(x0, x1 + 1) + 0.5, np.arange(y0, y1 + 1) + 0.5)
    inside = np.ones_like(gx, dtype=bool)
    sign = None
    for (ax, ay), (bx, by) in zip(corners, corners[1:] + corners[:1]):
        cross = (bx - ax) * (gy - ay) - (by - ay) * (gx - ax)
        side = cross >= 0
        if sign is None:
            sign = side.mean() >= 0.5
        inside &= side if sign else ~side
    img[y0:y1 + 1, x0:x1 + 1][inside] = colour


def save_video(frames: Sequence[np.ndarray], path: str | os.PathLike, fps: float = 10.0) -> None:
    """Writes ``frames`` (``(H, W, 3)`` uint8) to ``path``: a GIF with Pillow (``pip install pillow``), or any format
    imageio knows (``.mp4`` needs ``imageio[ffmpeg]``)."""
    if len(frames) == 0:
        raise ValueError("frames is empty: nothing to write")
    if not fps > 0:
        raise ValueError(f"fps={fps} must be positive")
    path = os.fspath(path)
    if path.lower().endswith(".gif"):
        try:
            from PIL import Image
        except ImportError:
            raise ImportError("save_video(path='*.gif') needs Pillow: pip install pillow") from None
        images = [Image.fromarray(np.asarray(f, dtype=np.uint8)) for f in frames]
        images[0].save(path, save_all=True, append_images=images[1:], duration=int(round(1000 / fps)), loop=0)
        return
    try:
        import imageio.v3 as iio
    except ImportError:
        raise ImportError(f"save_video(path={path!r}) needs imageio (pip install 'imageio[ffmpeg]'); "
                          "or give a .gif path (Pillow)") from None
    iio.imwrite(path, np.stack(frames), fps=fps)


def record_episode(env, policy: Callable, path: str | os.PathLike, *, fps: float | None = None,
                   every: int = 1, seed: int | None = None, options: dict | None = None) -> dict:
    """Runs one episode of ``env`` (made with ``render_mode="rgb_array"``) with ``policy(obs) -> action``, writes
    every ``every``-th frame to ``path`` (:func:`save_video`; ``fps`` defaults to real time) and returns the last
    step's ``info`` (``outcome``, ``metrics``, ...)."""
    if getattr(env, "render_mode", None) != "rgb_array":
        raise ValueError("record_episode needs an environment made with render_mode='rgb_array'")
    if every < 1:
        raise ValueError(f"every={every} must be at least 1")
    obs, info = env.reset(seed=seed, options=options)
    frames = [env.render()]
    step = 0
    while True:
        obs, _, terminated, truncated, info = env.step(policy(obs))
        step += 1
        if step % every == 0 or terminated or truncated:
            frames.append(env.render())
        if terminated or truncated:
            break
    period = env.unwrapped.control_period * every
    save_video(frames, path, fps=fps if fps is not None else 1.0 / period)
    return info
