"""The learned baselines' network (``planners/learned/POLICY.md``, layout ``vertibench-policy-v1``) in PyTorch:
the actor the Rust built-in planner runs, a critic on the same 156 inputs that training adds, and the export of the
actor to a safetensors weights file with POLICY.md's tensor names and metadata."""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Mapping

import numpy as np
import torch
from torch import nn

from .. import _core

#: Crop cells per side and channels (POLICY.md).
CROP_SIZE: int = 16
CROP_CHANNELS: int = 2
#: Vector features (POLICY.md: ``goal_cos`` ... ``throttle_1``).
N_FEATURES: int = 12
#: Flattened conv output: 16 channels x 3 x 3.
N_CROP: int = 16 * 3 * 3
#: Initial log standard deviation of the Gaussian policy: std 0.6 explores the whole action range without sending
#: most samples to its clipped ends, as std 1 would.
INIT_LOG_STD: float = -0.5
_HALF_LOG_2PI = 0.5 * math.log(2 * math.pi)


def _init(layer: nn.Module, gain: float) -> nn.Module:
    """Orthogonal weights of ``gain``, zero biases (the usual PPO initialisation)."""
    nn.init.orthogonal_(layer.weight, gain)  # type: ignore[arg-type]
    nn.init.zeros_(layer.bias)  # type: ignore[arg-type]
    return layer


class Encoder(nn.Module):
    """``crop [B,2,16,16] -> conv1 (8, 4x4, /2) -> ReLU -> conv2 (16, 3x3, /2) -> ReLU -> flatten (c, y, x)``."""

    def __init__(self) -> None:
        super().__init__()
        self.conv1 = _init(nn.Conv2d(CROP_CHANNELS, 8, 4, stride=2), math.sqrt(2))
        self.conv2 = _init(nn.Conv2d(8, 16, 3, stride=2), math.sqrt(2))

    def forward(self, crop: torch.Tensor) -> torch.Tensor:
        x = torch.relu(self.conv1(crop))
        x = torch.relu(self.conv2(x))
        return x.flatten(1)


class Head(nn.Module):
    """``fc1 (H) -> tanh -> fc2 (H) -> tanh -> out``; the actor's output layer is named ``mean``."""

    def __init__(self, hidden: int, out: int, out_name: str, out_gain: float) -> None:
        super().__init__()
        self.fc1 = _init(nn.Linear(N_CROP + N_FEATURES, hidden), math.sqrt(2))
        self.fc2 = _init(nn.Linear(hidden, hidden), math.sqrt(2))
        self.out_name = out_name
        setattr(self, out_name, _init(nn.Linear(hidden, out), out_gain))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = torch.tanh(self.fc1(x))
        x = torch.tanh(self.fc2(x))
        return getattr(self, self.out_name)(x)


class ActorCritic(nn.Module):
    """POLICY.md's actor (``enc``, ``pi``) plus a critic ``vf`` sharing the encoder and a state-independent
    ``log_std``. ``forward`` is not used: call :meth:`features`, :meth:`dist_and_value` or :meth:`act`."""

    def __init__(self, hidden: int = 64) -> None:
        super().__init__()
        self.hidden = hidden
        self.enc = Encoder()
        self.pi = Head(hidden, 2, "mean", 0.01)
        self.vf = Head(hidden, 1, "value", 1.0)
        self.log_std = nn.Parameter(torch.full((2,), INIT_LOG_STD))

    def features(self, vec: torch.Tensor, crop: torch.Tensor) -> torch.Tensor:
        """The 156 inputs: the crop's 144 conv features, then the 12 vector features."""
        return torch.cat([self.enc(crop), vec], dim=1)

    def dist_and_value(self, vec: torch.Tensor, crop: torch.Tensor) -> tuple[torch.distributions.Normal, torch.Tensor]:
        """The Gaussian policy over (steering, throttle) before clipping, and the value."""
        x = self.features(vec, crop)
        mean = self.pi(x)
        std = self.log_std.exp().expand_as(mean)
        return torch.distributions.Normal(mean, std), self.vf(x).squeeze(-1)

    @torch.inference_mode()
    def sample(self, vec: np.ndarray, crop: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A rollout step: sampled (unclipped) actions, their log-probabilities and the values, as NumPy arrays
        (the Gaussian written out: :meth:`dist_and_value` costs more than the network at these batch sizes)."""
        x = self.features(torch.from_numpy(vec), torch.from_numpy(crop))
        mean = self.pi(x)
        noise = torch.randn_like(mean)
        a = mean + self.log_std.exp() * noise
        logp = (-0.5 * noise.pow(2) - self.log_std - _HALF_LOG_2PI).sum(-1)
        return a.numpy(), logp.numpy(), self.vf(x).squeeze(-1).numpy()

    def value(self, vec: torch.Tensor, crop: torch.Tensor) -> torch.Tensor:
        return self.vf(self.features(vec, crop)).squeeze(-1)

    def act(self, vec: torch.Tensor, crop: torch.Tensor) -> torch.Tensor:
        """The deterministic action the built-in planner takes: ``clamp(mean, -1, 1)``."""
        return self.pi(self.features(vec, crop)).clamp(-1.0, 1.0)

    def actor_tensors(self) -> dict[str, np.ndarray]:
        """The exported tensors (POLICY.md's names and shapes), f32, contiguous."""
        state = self.state_dict()
        names = [f"enc.{c}.{p}" for c in ("conv1", "conv2") for p in ("weight", "bias")]
        names += [f"pi.{c}.{p}" for c in ("fc1", "fc2", "mean") for p in ("weight", "bias")]
        return {k: np.ascontiguousarray(state[k].detach().cpu().numpy().astype(np.float32)) for k in names}

    def export(self, path: str | os.PathLike, metadata: Mapping[str, object]) -> Path:
        """Writes the actor as a safetensors file with POLICY.md's fixed metadata plus ``metadata`` (every value as
        a string), to a temporary name then renamed, and returns the path."""
        from safetensors.numpy import save_file

        meta = {
            "format": _core.POLICY_LAYOUT,
            "features": ",".join(_core.POLICY_FEATURES),
            "crop": f"{CROP_CHANNELS}x{CROP_SIZE}x{CROP_SIZE}",
            "crop_cell_per_scale": "1.0",
            "action": "steering,throttle",
        }
        for k, v in metadata.items():
            if k in meta:
                raise ValueError(f"metadata key {k!r} is fixed by the layout")
            meta[k] = str(v)
        path = Path(path)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        save_file(self.actor_tensors(), str(tmp), metadata=meta)
        os.replace(tmp, path)
        return path


def load_actor(path: str | os.PathLike) -> tuple[ActorCritic, dict[str, str]]:
    """A torch :class:`ActorCritic` whose actor holds the weights of a ``policy.safetensors`` file (critic and
    log-std left at their initial values), and the file's metadata."""
    from safetensors import safe_open

    with safe_open(str(path), framework="numpy") as f:
        meta = dict(f.metadata() or {})
        tensors = {k: f.get_tensor(k) for k in f.keys()}
    if meta.get("format") != _core.POLICY_LAYOUT:
        raise ValueError(f"{path}: format {meta.get('format')!r} is not {_core.POLICY_LAYOUT!r}")
    model = ActorCritic(hidden=int(tensors["pi.fc1.weight"].shape[0]))
    model.load_state_dict({k: torch.from_numpy(v) for k, v in tensors.items()}, strict=False)
    return model, meta
