"""The kinodynamic models in PyTorch (``planners/learned/KINO.md``). ``kino`` (layout ``vertibench-kino-v1``): a small
CNN encoder of the 16x16 elevation crop to a 32-entry terrain code, shared by an ensemble of MLP heads (2 x
``hidden`` tanh) that each predict the 7 scaled targets. ``tal`` (``vertibench-tal-v1``): the same convolutions on a
32x32 map taken at an anchor pose, gated element-wise by a sigmoid of the pose's offset from the anchor and fused
into the terrain code the same heads read. Tensor names match the Rust readers (``learned::kino::{KinoNet,
TalNet}``)."""

from __future__ import annotations

import torch
from torch import nn

from .. import _core

FEATURES = len(_core.KINO_FEATURES)
TARGETS = len(_core.KINO_TARGETS)
CODE = int(_core.KINO_CODE)


class Convolutions(nn.Module):
    """The two convolutions both layouts start with: ``[n, S, S] -> [n, 16 x s x s]`` (``s`` = 3 on the 16x16 crop,
    7 on the 32x32 map)."""

    def __init__(self) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(1, 8, 3, stride=2)
        self.conv2 = nn.Conv2d(8, 16, 3, stride=2)

    def forward(self, terrain: torch.Tensor) -> torch.Tensor:
        return torch.relu(self.conv2(torch.relu(self.conv1(terrain.unsqueeze(1))))).flatten(1)


class Encoder(Convolutions):
    """The crop model's encoder: the convolutions, then a dense layer to the terrain code."""

    def __init__(self) -> None:
        super().__init__()
        self.code = nn.Linear(16 * 3 * 3, CODE)

    def forward(self, crop: torch.Tensor) -> torch.Tensor:
        return torch.relu(self.code(super().forward(crop)))


class Head(nn.Module):
    def __init__(self, hidden: int) -> None:
        super().__init__()
        self.fc1 = nn.Linear(CODE + FEATURES, hidden)
        self.fc2 = nn.Linear(hidden, hidden)
        self.out = nn.Linear(hidden, TARGETS)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.out(torch.tanh(self.fc2(torch.tanh(self.fc1(x)))))


class Ensemble(nn.Module):
    """What both layouts end in: ``members`` heads on the terrain code and the vector features."""

    layout: str

    def _add_heads(self, members: int, hidden: int) -> None:
        if not 1 <= members <= 16:
            raise ValueError(f"members={members} must be in 1..16")
        self.heads = nn.ModuleList(Head(hidden) for _ in range(members))

    @property
    def members(self) -> int:
        return len(self.heads)

    def _predict(self, code: torch.Tensor, vec: torch.Tensor) -> torch.Tensor:
        x = torch.cat([code, vec], dim=1)
        return torch.stack([h(x) for h in self.heads], dim=1)


class KinoModel(Ensemble):
    """``forward(vec [n, 16], crop [n, 16, 16]) -> [n, members, 7]``."""

    layout = str(_core.KINO_LAYOUT)

    def __init__(self, members: int = 4, hidden: int = 64) -> None:
        super().__init__()
        self.enc = Encoder()
        self._add_heads(members, hidden)

    def layout_metadata(self) -> dict[str, str]:
        return {"crop": str(_core.KINO_CROP_META)}

    def forward(self, vec: torch.Tensor, crop: torch.Tensor) -> torch.Tensor:
        return self._predict(self.enc(crop), vec)


class Attention(nn.Module):
    """Terrain attention: ``code = relu(fuse(embedding * sigmoid(gate2(sigmoid(gate1(offset))))))``."""

    def __init__(self) -> None:
        super().__init__()
        embed, hidden = int(_core.TAL_EMBED), int(_core.TAL_GATE_HIDDEN)
        self.gate1 = nn.Linear(len(_core.TAL_OFFSETS), hidden)
        self.gate2 = nn.Linear(hidden, embed)
        self.fuse = nn.Linear(embed, CODE)

    def forward(self, embedding: torch.Tensor, offset: torch.Tensor) -> torch.Tensor:
        gate = torch.sigmoid(self.gate2(torch.sigmoid(self.gate1(offset))))
        return torch.relu(self.fuse(embedding * gate))


class TalModel(Ensemble):
    """``forward(vec [n, 16], map [n, 32, 32], offset [n, 5]) -> [n, members, 7]``."""

    layout = str(_core.TAL_LAYOUT)

    def __init__(self, members: int = 4, hidden: int = 64) -> None:
        super().__init__()
        self.enc = Convolutions()
        self.att = Attention()
        self._add_heads(members, hidden)

    def layout_metadata(self) -> dict[str, str]:
        return {"offsets": ",".join(_core.TAL_OFFSETS), "map": str(_core.TAL_MAP_META)}

    def forward(self, vec: torch.Tensor, map: torch.Tensor, offset: torch.Tensor) -> torch.Tensor:
        return self._predict(self.att(self.enc(map), offset), vec)


#: The model kinds ``python -m vertibench.kino train --model`` offers.
MODELS = {"kino": KinoModel, "tal": TalModel}


def metadata(model: Ensemble, extra: dict[str, str]) -> dict[str, str]:
    """What a weights file records: the layout the Rust reader checks, then the card's entries."""
    meta = {
        "format": model.layout,
        "features": ",".join(_core.KINO_FEATURES),
        "targets": ",".join(_core.KINO_TARGETS),
        **model.layout_metadata(),
        "ensemble": str(model.members),
        "step_frames": str(_core.KINO_STEP_FRAMES),
    }
    meta.update({k: str(v) for k, v in extra.items()})
    return meta


def save(model: Ensemble, path, extra: dict[str, str]) -> None:
    from safetensors.torch import save_file

    tensors = {k: v.detach().float().contiguous().clone() for k, v in model.state_dict().items()}
    save_file(tensors, str(path), metadata=metadata(model, extra))


def load(path) -> Ensemble:
    from safetensors import safe_open

    with safe_open(str(path), framework="pt") as f:
        meta = f.metadata() or {}
        kinds = {m.layout: m for m in MODELS.values()}
        if meta.get("format") not in kinds:
            raise ValueError(f"{path}: format {meta.get('format')!r}, expected one of {sorted(kinds)}")
        state = {k: f.get_tensor(k) for k in f.keys()}
    model = kinds[meta["format"]](int(meta["ensemble"]), int(state["heads.0.fc1.weight"].shape[0]))
    model.load_state_dict(state)
    return model.eval()
