"""The kinodynamic model in PyTorch (layout ``vertibench-kino-v1``, ``planners/learned/KINO.md``): a small CNN encoder
of the 16x16 elevation crop to a 32-entry terrain code, shared by an ensemble of MLP heads (2 x ``hidden`` tanh) that
each predict the 7 scaled targets. Tensor names match the Rust reader (``learned::kino::KinoNet``)."""

from __future__ import annotations

import torch
from torch import nn

from .. import _core

FEATURES = len(_core.KINO_FEATURES)
TARGETS = len(_core.KINO_TARGETS)
CODE = int(_core.KINO_CODE)


class Encoder(nn.Module):
    def __init__(self) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(1, 8, 3, stride=2)
        self.conv2 = nn.Conv2d(8, 16, 3, stride=2)
        self.code = nn.Linear(16 * 3 * 3, CODE)

    def forward(self, crop: torch.Tensor) -> torch.Tensor:
        x = torch.relu(self.conv1(crop.unsqueeze(1)))
        x = torch.relu(self.conv2(x))
        return torch.relu(self.code(x.flatten(1)))


class Head(nn.Module):
    def __init__(self, hidden: int) -> None:
        super().__init__()
        self.fc1 = nn.Linear(CODE + FEATURES, hidden)
        self.fc2 = nn.Linear(hidden, hidden)
        self.out = nn.Linear(hidden, TARGETS)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.out(torch.tanh(self.fc2(torch.tanh(self.fc1(x)))))


class KinoModel(nn.Module):
    """``forward(vec [n, 16], crop [n, 16, 16]) -> [n, members, 7]``."""

    def __init__(self, members: int = 4, hidden: int = 64) -> None:
        super().__init__()
        if not 1 <= members <= 16:
            raise ValueError(f"members={members} must be in 1..16")
        self.enc = Encoder()
        self.heads = nn.ModuleList(Head(hidden) for _ in range(members))

    @property
    def members(self) -> int:
        return len(self.heads)

    def forward(self, vec: torch.Tensor, crop: torch.Tensor) -> torch.Tensor:
        x = torch.cat([self.enc(crop), vec], dim=1)
        return torch.stack([h(x) for h in self.heads], dim=1)


def metadata(model: KinoModel, extra: dict[str, str]) -> dict[str, str]:
    """What a weights file records: the layout the Rust reader checks, then the card's entries."""
    meta = {
        "format": str(_core.KINO_LAYOUT),
        "features": ",".join(_core.KINO_FEATURES),
        "targets": ",".join(_core.KINO_TARGETS),
        "crop": str(_core.KINO_CROP_META),
        "ensemble": str(model.members),
        "step_frames": str(_core.KINO_STEP_FRAMES),
    }
    meta.update({k: str(v) for k, v in extra.items()})
    return meta


def save(model: KinoModel, path, extra: dict[str, str]) -> None:
    from safetensors.torch import save_file

    tensors = {k: v.detach().float().contiguous().clone() for k, v in model.state_dict().items()}
    save_file(tensors, str(path), metadata=metadata(model, extra))


def load(path) -> KinoModel:
    from safetensors import safe_open

    with safe_open(str(path), framework="pt") as f:
        meta = f.metadata() or {}
        if meta.get("format") != _core.KINO_LAYOUT:
            raise ValueError(f"{path}: format {meta.get('format')!r}, expected {_core.KINO_LAYOUT!r}")
        state = {k: f.get_tensor(k) for k in f.keys()}
    model = KinoModel(int(meta["ensemble"]), int(state["heads.0.fc1.weight"].shape[0]))
    model.load_state_dict(state)
    return model.eval()
