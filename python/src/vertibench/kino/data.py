"""Model steps from datasets: every frame of every episode that has a model step after it becomes one sample
(inputs from :class:`vertibench._core.KinoData`, the Rust planners' own code; targets the change of pose over the
next ``KINO_STEP_FRAMES`` frames). Held out: worlds whose id is 9 mod 10, as for the learned policies."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import _core
from .. import datasets as vb_datasets

STEP = int(_core.KINO_STEP_FRAMES)
#: Held-out worlds: ``world_id % 10 == HELD_OUT``.
HELD_OUT = 9


@dataclass
class Episode:
    """One episode's frames: poses ``[n, 6]`` (x y z roll pitch yaw), applied steering ``[n]``, actions ``[n, 3]``
    and the whole observed states ``[n, 15]`` (``observation.state``; ``None`` when not read); the frame after its
    last action is appended, so it has ``n`` poses and ``n - 1`` actions. ``outcome`` is how it ended; ``slip``
    (``[n - 1]``, read with ``wheels=True``) the mean |longitudinal slip| of the wheels in contact at each frame."""

    world_id: int
    level: str
    poses: np.ndarray
    steering: np.ndarray
    actions: np.ndarray
    states: np.ndarray | None = None
    outcome: str = ""
    slip: np.ndarray | None = None


def _slip(wheels: np.ndarray) -> np.ndarray:
    """Mean |slip| of the wheels in contact (``observation.wheels`` fields: sinkage, slip, normal load, contact)."""
    contact = wheels[:, :, 3] > 0.5
    n = np.maximum(contact.sum(1), 1)
    return np.where(contact, np.abs(wheels[:, :, 1]), 0.0).sum(1) / n


def episodes(path: str | Path, task_set: str | Path | None = None,
             wheels: bool = False) -> tuple[dict, list[Episode]]:
    """A dataset's spec and its episodes (read once, file by file; with ``wheels`` also each frame's slip)."""
    pq = vb_datasets._pyarrow()
    ds = vb_datasets.open(path, task_set)
    meta = ds.episodes.set_index("episode_index")
    out: list[Episode] = []
    for f in ds._data_files():
        cols = ["observation.state", "action", "episode_index"] + (["observation.wheels"] if wheels else [])
        a = ds._arrays(pq.read_table(f, columns=cols), crops=False)
        ep = a["episode_index"]
        bounds = np.flatnonzero(np.diff(ep)) + 1
        for rows in np.split(np.arange(len(ep)), bounds):
            if len(rows) == 0:
                continue
            e = int(ep[rows[0]])
            row = meta.loc[e]
            state = np.concatenate([a["observation.state"][rows], np.asarray(row["final_state"])[None, :]])
            out.append(Episode(int(row["world_id"]), str(row["level"]),
                               np.ascontiguousarray(state[:, :6]), np.ascontiguousarray(state[:, 13]),
                               np.asarray(a["action"][rows], np.float64), np.ascontiguousarray(state),
                               str(row["outcome"]),
                               _slip(np.asarray(a["observation.wheels"][rows], np.float64)) if wheels else None))
    return ds.spec, out


def step_indices(n_poses: int) -> tuple[np.ndarray, np.ndarray]:
    """Start frames ``i`` with a whole model step after them (``i + STEP < n_poses``) and the frame one step
    before each (``i - STEP``, or ``i`` itself in the first step: a standing start)."""
    i = np.arange(max(n_poses - STEP, 0))
    return i, np.where(i >= STEP, i - STEP, i)


def mean_actions(actions: np.ndarray, i: np.ndarray) -> np.ndarray:
    """The action held over each step from frame ``i``: the mean of its ``STEP`` frames' actions."""
    c = np.concatenate([np.zeros((1, actions.shape[1])), np.cumsum(actions, axis=0)])
    return (c[i + STEP] - c[i]) / STEP


FIELDS = ("vec", "crop", "target", "world", "episode", "frame", "offset")


@dataclass
class Samples:
    vec: np.ndarray  # f32 [n, 16]
    crop: np.ndarray  # f32 [n, 16, 16] (kino), or the anchor's map [n, 32, 32] (tal)
    target: np.ndarray  # f32 [n, 7]
    world: np.ndarray  # i64 [n]
    episode: np.ndarray  # i64 [n]: index into the episode list
    frame: np.ndarray  # i64 [n]
    offset: np.ndarray | None = None  # f32 [n, 5]: the pose's offset from the map's anchor (tal only)

    def __len__(self) -> int:
        return len(self.target)

    def inputs(self, rows=None) -> list[np.ndarray]:
        """The model's inputs (of ``rows``): ``[vec, crop]``, and the offset for a terrain-attentive model."""
        cols = [self.vec, self.crop] + ([self.offset] if self.offset is not None else [])
        return [c if rows is None else c[rows] for c in cols]

    def take(self, rows: np.ndarray) -> "Samples":
        return Samples(*(None if getattr(self, k) is None else getattr(self, k)[rows] for k in FIELDS))

    def save(self, path: Path) -> None:
        np.savez(path, **{k: getattr(self, k) for k in FIELDS if getattr(self, k) is not None})

    @classmethod
    def load(cls, path: Path) -> "Samples":
        z = np.load(path)
        return cls(*(z[k] if k in z else None for k in FIELDS))

    @classmethod
    def concatenate(cls, parts: list["Samples"]) -> "Samples":
        return cls(*(None if getattr(parts[0], k) is None else np.concatenate([getattr(p, k) for p in parts])
                     for k in FIELDS))


def samples(eps: list[Episode], maker: "_core.KinoData", stride: int = 1, model: str = "kino",
            rng: np.random.Generator | None = None) -> Samples:
    """Every ``stride``-th model step of ``eps`` as samples. For ``model="tal"`` the input terrain is the map at an
    anchor ``lag`` model steps before the step (``lag`` drawn from ``rng`` in ``0..TAL_ANCHOR_STEPS``, the anchor
    no earlier than the episode's first frame) and the offset of the step's pose from it."""
    if model not in ("kino", "tal"):
        raise ValueError(f"model {model!r}: expected 'kino' or 'tal'")
    rng = rng if rng is not None else np.random.default_rng(0)
    parts = []
    for k, e in enumerate(eps):
        i, b = step_indices(len(e.poses))
        i, b = i[::stride], b[::stride]
        if len(i) == 0:
            continue
        act = mean_actions(e.actions, i)
        vec, crop = maker.features(e.world_id, e.poses[b], e.poses[i], e.steering[i], act)
        offset = None
        if model == "tal":
            lag = rng.integers(0, int(_core.TAL_ANCHOR_STEPS), len(i))
            a = np.maximum(i - lag * STEP, 0)
            crop, offset = maker.tal_inputs(e.world_id, e.poses[a], e.poses[i])
        tgt = maker.targets(e.poses[i], e.poses[i + STEP], e.steering[i + STEP])
        parts.append(Samples(vec.astype(np.float32), crop.astype(np.float32), tgt.astype(np.float32),
                             np.full(len(i), e.world_id, np.int64), np.full(len(i), k, np.int64),
                             i.astype(np.int64), offset))
    if not parts:
        raise ValueError("no episode has a whole model step: the datasets are empty or too short")
    return Samples.concatenate(parts)
