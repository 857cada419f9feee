"""TNT's traversability estimator (Pan, Datar, Pokhrel et al., arXiv 2409.17479; the release's ``systems/TNT``),
layout ``vertibench-tnt-v1``: a map-to-map network from the terrain-attentive model's map at a decision's pose (32 x
32 cells of 0.5 m, heading-aligned, 3 m behind to 13 m ahead; ``KINO.md``) to a grid of traversability over the
same 16 m square: 16 x 16 cells of 1 m, each for 4 headings relative to the map's (ahead, left, back, right), each
with 5 channels in [0, 1] (:data:`CHANNELS`).

**Labels** come from our simulator's driving in the datasets, per frame over the :data:`WINDOW_S` after it: the
largest |roll| and |pitch| (/ 30 degrees, clipped), the wheels' mean |longitudinal slip|, stuck (moved less than
0.5 m x scale with the throttle on) and rollover (the episode ends in a rollover and its window reaches the tip: the
first frame of the final run of frames with |roll| above 30 degrees, or the last frame where there is none). A frame
whose window runs past the episode's end is labelled only if the episode ended stuck or rolled over (that end is what
the window would have seen). The tip, not the end, is what a rollover's label marks: a vehicle that tips and stays
leaning is only failed once the stuck rule's 10 s have passed, and its approach to the tip is what the map can
show. An **anchor** every :data:`ANCHOR_EVERY_S` of each episode gives one sample: its map, and
the labels of the frames of the next :data:`SPAN_S` in the map's window, each at its cell and relative heading (the
mean where several fall together). The release's estimator was trained on its own labels; its cost read the
vehicle-centred map with world coordinates (``learned-baselines.md`` section 1.4): here a rollout pose is
transformed into the map's frame (:func:`grid_index`, which the Rust planner mirrors)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import _core
from . import data as kd

LAYOUT = str(_core.TNT_LAYOUT)
CHANNELS = tuple(_core.TNT_CHANNELS)
HEADINGS = int(_core.TNT_HEADINGS)
GRID = int(_core.TNT_GRID)
#: Grid cell side and the window's extent, metres at scale 1 (the TAL map's square).
GRID_CELL = 1.0
AHEAD = 13.0
HALF_WIDTH = 8.0
WINDOW_S = 2.0
SPAN_S = 8.0
ANCHOR_EVERY_S = 1.0
ROLL_LIMIT = math.radians(30.0)
STUCK_M = 0.5
THROTTLE_ON = 0.2
#: Version of the label definitions (part of the trainer's sample cache key; in the card): 2 marks a rollover at
#: its tip (1 marked only the last :data:`WINDOW_S` before the episode's end).
LABELS_VERSION = 2


def tip_frame(e: kd.Episode) -> int | None:
    """The frame at which a rolled-over episode tipped (``None`` for any other outcome): the first of its final run
    of frames with |roll| above 30 degrees, or its last frame where the final frame does not lean that far."""
    if e.outcome != "rollover":
        return None
    over = np.abs(e.poses[:, 3]) > ROLL_LIMIT
    if not over[-1]:
        return len(e.poses) - 1
    upright = np.flatnonzero(~over)
    return 0 if len(upright) == 0 else int(upright[-1]) + 1


def frame_labels(e: kd.Episode, fps: float, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Labels ``f32 [n - 1, 5]`` of each action frame of ``e`` and whether each is defined (``bool [n - 1]``)."""
    n = len(e.actions)
    w = max(int(round(WINDOW_S * fps)), 1)
    ends = np.minimum(np.arange(n) + w, len(e.poses) - 1)
    complete = np.arange(n) + w <= len(e.poses) - 1
    # Running maxima of |roll| and |pitch| over [g, end]: a sliding maximum by a strided view over a padded array.
    pad = np.concatenate([np.abs(e.poses[:, 3:5]), np.zeros((w, 2))])
    windows = np.lib.stride_tricks.sliding_window_view(pad, w + 1, axis=0)[:n]  # [n, 2, w + 1]
    att = np.clip(windows.max(2) / ROLL_LIMIT, 0.0, 1.0)
    slip = np.zeros(n) if e.slip is None else np.asarray(e.slip, np.float64)
    c = np.concatenate([[0.0], np.cumsum(slip)])
    span = np.maximum(ends - np.arange(n), 1)
    mean_slip = np.clip((c[np.minimum(ends, n)] - c[np.arange(n)]) / span, 0.0, 1.0)
    t = np.concatenate([[0.0], np.cumsum(np.abs(e.actions[:, 1]))])
    throttle = (t[np.minimum(ends, n)] - t[np.arange(n)]) / span
    moved = np.hypot(*(e.poses[ends, :2] - e.poses[:n, :2]).T)
    stuck = (moved < STUCK_M * scale) & (throttle > THROTTLE_ON)
    tip = tip_frame(e)
    rolled = np.zeros(n, bool) if tip is None else ends >= tip
    labels = np.stack([att[:, 0], att[:, 1], mean_slip, stuck, rolled], axis=1).astype(np.float32)
    valid = complete | (e.outcome in ("rollover", "stuck"))
    return labels, valid


def grid_index(anchor: np.ndarray, poses: np.ndarray, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Flat index ``heading * GRID^2 + row * GRID + col`` of each pose ``[n, 6]`` in the grid of the map taken at
    ``anchor`` (``[6]`` or ``[n, 6]``), and whether it lies inside: row 0 ahead, column 0 left, as the map; the
    heading bin is the change of yaw rounded to a quarter turn (0 ahead, 1 left, 2 back, 3 right)."""
    anchor = np.broadcast_to(anchor, poses.shape)
    dx, dy = poses[:, 0] - anchor[:, 0], poses[:, 1] - anchor[:, 1]
    s, c = np.sin(anchor[:, 5]), np.cos(anchor[:, 5])
    fwd, left = c * dx + s * dy, -s * dx + c * dy
    row = np.floor((AHEAD * scale - fwd) / (GRID_CELL * scale)).astype(np.int64)
    col = np.floor((HALF_WIDTH * scale - left) / (GRID_CELL * scale)).astype(np.int64)
    dyaw = np.arctan2(np.sin(poses[:, 5] - anchor[:, 5]), np.cos(poses[:, 5] - anchor[:, 5]))
    heading = np.mod(np.round(dyaw / (math.pi / 2)).astype(np.int64), HEADINGS)
    inside = (row >= 0) & (row < GRID) & (col >= 0) & (col < GRID)
    return heading * GRID * GRID + np.clip(row, 0, GRID - 1) * GRID + np.clip(col, 0, GRID - 1), inside


@dataclass
class TravSamples:
    """One sample per anchor: its map ``f32 [n, 32, 32]`` and world; its labels as sparse entries sorted by anchor
    (``start[i]:start[i + 1]`` are anchor ``i``'s): the flat grid index ``i64 [m]`` and the mean labels ``f32 [m, 5]``."""

    map: np.ndarray
    world: np.ndarray
    start: np.ndarray
    cell: np.ndarray
    label: np.ndarray

    def __len__(self) -> int:
        return len(self.map)

    def entries(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The entries of anchors ``rows``: (position of each entry's anchor within ``rows``, cell, label)."""
        counts = self.start[rows + 1] - self.start[rows]
        owner = np.repeat(np.arange(len(rows)), counts)
        idx = np.repeat(self.start[rows] - np.concatenate([[0], np.cumsum(counts)[:-1]]), counts) + np.arange(
            counts.sum())
        return owner, self.cell[idx], self.label[idx]


def samples(eps: list[kd.Episode], maker: "_core.KinoData", fps: float, scale: float) -> TravSamples:
    """The anchors of ``eps`` with their maps and labels."""
    every = max(int(round(ANCHOR_EVERY_S * fps)), 1)
    span = max(int(round(SPAN_S * fps)), 1)
    maps, worlds, starts, cells, labels = [], [], [0], [], []
    for e in eps:
        lab, valid = frame_labels(e, fps, scale)
        anchors = np.arange(0, len(e.actions), every)
        if len(anchors) == 0:
            continue
        maps.append(maker.tal_inputs(e.world_id, e.poses[anchors], e.poses[anchors])[0].astype(np.float32))
        worlds.append(np.full(len(anchors), e.world_id, np.int64))
        for a in anchors:
            g = np.arange(a, min(a + span, len(e.actions)))
            g = g[valid[g]]
            idx, inside = grid_index(e.poses[a], e.poses[g], scale)
            idx, lab_g = idx[inside], lab[g[inside]]
            uniq, inv = np.unique(idx, return_inverse=True)
            sums = np.zeros((len(uniq), len(CHANNELS)), np.float64)
            np.add.at(sums, inv, lab_g)
            cells.append(uniq)
            labels.append((sums / np.bincount(inv, minlength=len(uniq))[:, None]).astype(np.float32))
            starts.append(starts[-1] + len(uniq))
    if not maps:
        raise ValueError("no episode has a frame to anchor a map at: the datasets are empty")
    return TravSamples(np.concatenate(maps), np.concatenate(worlds), np.asarray(starts, np.int64),
                       np.concatenate(cells).astype(np.int64), np.concatenate(labels))


def model(width: int = 16):
    """``forward(map [n, 32, 32]) -> [n, HEADINGS, 5, GRID, GRID]`` in [0, 1]: a 3 x 3 convolution at the map's
    resolution, a strided one to the grid's, a dilated one (receptive field 6.5 m, the vehicle and its
    surroundings), then a 1 x 1 convolution to the 20 outputs."""
    import torch
    from torch import nn

    class TravModel(nn.Module):
        layout = LAYOUT

        def __init__(self) -> None:
            super().__init__()
            self.conv1 = nn.Conv2d(1, 8, 3, padding=1)
            self.conv2 = nn.Conv2d(8, width, 3, stride=2, padding=1)
            self.conv3 = nn.Conv2d(width, width, 3, padding=2, dilation=2)
            self.out = nn.Conv2d(width, HEADINGS * len(CHANNELS), 1)

        def forward(self, m: torch.Tensor) -> torch.Tensor:
            x = torch.relu(self.conv1(m.unsqueeze(1)))
            x = torch.relu(self.conv3(torch.relu(self.conv2(x))))
            return torch.sigmoid(self.out(x)).view(-1, HEADINGS, len(CHANNELS), GRID, GRID)

    return TravModel()


def gather(pred, owner: np.ndarray, cell: np.ndarray):
    """The predictions ``[m, 5]`` at sparse entries (anchor position ``owner`` in the batch, flat ``cell``)."""
    import torch

    flat = pred.permute(0, 1, 3, 4, 2).reshape(pred.shape[0], HEADINGS * GRID * GRID, len(CHANNELS))
    return flat[torch.from_numpy(owner).to(flat.device), torch.from_numpy(cell).to(flat.device)]


def save(net, path, extra: dict[str, str]) -> None:
    """Writes ``net``'s weights with the layout's metadata (what the Rust reader checks) and ``extra``."""
    from safetensors.torch import save_file

    meta = {"format": LAYOUT, "channels": ",".join(CHANNELS), "headings": str(HEADINGS), "grid": f"{GRID}x{GRID}",
            "map": str(_core.TAL_MAP_META), **{k: str(v) for k, v in extra.items()}}
    save_file({k: v.detach().float().contiguous().clone() for k, v in net.state_dict().items()}, str(path),
              metadata=meta)
