"""A trained policy as a :class:`vertibench.planner.Planner` in Python (the PyTorch actor), for
:func:`vertibench.evaluate` and :func:`vertibench.serve.serve`: what the Rust built-in planners ``rl``, ``mcl``
and ``acl`` do, from a ``policy.safetensors`` file, with the same features (``_core.policy_features``)."""

from __future__ import annotations

import os

import numpy as np
import torch

from .. import _core
from ..planner import Planner, env_observation
from .policy import load_actor


class TorchPolicyPlanner(Planner):
    """Drives with a weights file's actor, deterministically (``clamp(mean, -1, 1)``, brake 0), at the control rate
    the file records. ``scale`` is the vehicle's (its crops are ``16`` cells of ``scale`` m).

    ``backend="torch"`` runs the PyTorch actor; ``"rust"`` runs ``_core.PolicyNet``, the built-in planners' own
    inference, so its episodes are the built-in's bit for bit. The two agree within 1e-5 per action (float32 sums in
    another order), but a closed loop of 60 s of contacts amplifies any difference, down to 1e-14: expect the same
    success rate over many tasks, not the same outcome on every task (BENCHMARKS.md, issue 33)."""

    crop_size = int(_core.POLICY_CROP_SIZE)

    def __init__(self, path: str | os.PathLike, scale: float = 1.0, name: str | None = None,
                 backend: str = "torch"):
        if backend not in ("torch", "rust"):
            raise ValueError(f"backend={backend!r} is not 'torch' or 'rust'")
        self.model, meta = load_actor(path)
        self.model.eval()
        self.rust = _core.PolicyNet(path) if backend == "rust" else None
        self.backend = backend
        self.weights = str(path)
        self.name = name or meta.get("name", "policy")
        self.control_rate_hz = float(meta.get("control_rate_hz", 20.0))
        self.crop_resolution = float(scale)
        self.sha = _sha256(path)

    def params(self) -> dict:
        """The weights' SHA-256 and the crop resolution: another file is another planner."""
        return {"weights_sha256": self.sha, "crop_resolution": self.crop_resolution, "backend": self.backend}

    def reset(self, task, vehicle, maps):
        self.goal = task.goal
        self.scale = float(vehicle["scale"])
        self.nominal_speed = float(vehicle["nominal_speed"])
        self.last_throttle = 0.0

    def act(self, obs):
        o = env_observation(obs, self.goal)
        vec, crop = _core.policy_features(
            o["state"][None], o["goal"][None], np.array([self.last_throttle]),
            np.ascontiguousarray(o["elevation"][None], dtype=np.float32),
            np.ascontiguousarray(o["obstacles"][None], dtype=np.uint8), self.scale, self.nominal_speed)
        if self.rust is not None:
            a = self.rust.act(vec, crop)[0]
        else:
            with torch.inference_mode():
                a = self.model.act(torch.from_numpy(np.array(vec)), torch.from_numpy(np.array(crop)))[0].numpy()
        steering, throttle = float(a[0]), float(a[1])
        self.last_throttle = throttle
        return (steering, throttle, 0.0)


def _sha256(path: str | os.PathLike) -> str:
    import hashlib

    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()
