"""The benchmark's datasets (``vb dataset generate``): expert demonstrations, random exploration and failure cases
in LeRobot v3's layout (``datasets/FORMAT.md``), read with pyarrow (``pip install 'vertibench[datasets]'``).

```python
import vertibench as vb
ds = vb.datasets.open("out/datasets/random")          # a LeRobot v3 directory
print(ds.episodes[["world_id", "outcome", "length"]].head())   # one row per episode (pandas)
frames = ds.frames()                                  # one row per control step (pandas)
for batch in ds.batches(256, shuffle=True, seed=0):   # dicts of NumPy arrays; crops rebuilt for lite datasets
    state, action, elevation = batch["observation.state"], batch["action"], batch["observation.elevation"]
vb.datasets.to_minari("out/datasets/random", "vertibench/nav/random-v0")   # minari.load_dataset reads it
```

Lite datasets store no crops: :meth:`Dataset.episode` and :meth:`Dataset.batches` rebuild them from the task set and
each frame's pose with the environment's own code, equal to what the environment observed.
"""

from __future__ import annotations

import copy
import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator, Sequence

import numpy as np

from . import _core
from . import tasks as task_sets

#: Frame features that hold one value per frame (everything else is a fixed-shape array).
_SCALARS = ("next.reward", "next.done", "next.terminated", "next.truncated", "timestamp", "frame_index",
            "episode_index", "index", "task_index")
_CROPS = ("observation.elevation", "observation.semantics")


def _pyarrow():
    try:
        import pyarrow.parquet as pq
    except ImportError:
        raise ImportError("vertibench.datasets needs pyarrow: pip install 'vertibench[datasets]'") from None
    return pq


def _column(table, name: str, shape: Sequence[int]) -> np.ndarray:
    """A fixed-shape list column as one array of ``(rows, *shape)``; a scalar column as ``(rows,)``."""
    col = table.column(name).combine_chunks()
    if not shape or name in _SCALARS:
        return col.to_numpy(zero_copy_only=False)
    flat = col
    for _ in shape:  # nested once per dimension (FORMAT.md)
        flat = flat.flatten()
    return flat.to_numpy(zero_copy_only=False).reshape(len(col), *shape)


@dataclass
class Dataset:
    """An open dataset: its ``info`` (``meta/info.json``), ``spec`` (what every episode shares: kind, variant,
    vehicle, scale, rate, crop, versions, seed) and ``episodes`` (a DataFrame, one row per episode)."""

    path: Path
    info: dict
    episodes: Any
    task_set: Path | None

    @property
    def spec(self) -> dict:
        return self.info["vertibench"]["spec"]

    @property
    def fps(self) -> float:
        return float(self.info["fps"])

    @property
    def features(self) -> dict:
        return self.info["features"]

    def __len__(self) -> int:
        return int(self.info["total_episodes"])

    def _data_files(self) -> list[Path]:
        return sorted((self.path / "data").glob("chunk-*/file-*.parquet"))

    def frames(self, columns: Sequence[str] | None = None):
        """Every frame as a pandas DataFrame (fixed-shape features as arrays per row)."""
        pq = _pyarrow()
        import pyarrow as pa

        tables = [pq.read_table(f, columns=list(columns) if columns else None) for f in self._data_files()]
        return pa.concat_tables(tables).to_pandas()

    def _arrays(self, table, crops: bool, world_ids: np.ndarray | None = None) -> dict[str, np.ndarray]:
        out: dict[str, np.ndarray] = {}
        for name, f in self.features.items():
            if name not in table.column_names:
                continue
            out[name] = _column(table, name, [] if name in _SCALARS else f["shape"])
        if "observation.semantics" in out:
            out["observation.semantics"] = out["observation.semantics"].astype(np.uint8)
        if crops and "observation.elevation" not in out:
            out.update(self._rebuild(out, world_ids))
        return out

    def _rebuild(self, arrays: dict, world_ids: np.ndarray | None) -> dict[str, np.ndarray]:
        """The crops of a lite dataset, rebuilt from the poses (x, y, z, yaw) on the task set."""
        maker = self._maker()
        state = arrays["observation.state"]
        poses = np.ascontiguousarray(state[:, [0, 1, 2, 5]], dtype=np.float64)
        if world_ids is None:
            world_ids = self._world_of(arrays["episode_index"])
        size = int(self.spec["crop"]["size"])
        elev = np.empty((len(poses), size, size), np.float32)
        sem = np.empty((len(poses), size, size), np.uint8)
        for w in np.unique(world_ids):
            rows = np.flatnonzero(world_ids == w)
            e, s, _ = maker.crops(int(w), poses[rows])
            elev[rows], sem[rows] = e, s
        return {"observation.elevation": elev, "observation.semantics": sem}

    def _world_of(self, episode_index: np.ndarray) -> np.ndarray:
        worlds = dict(zip(self.episodes["episode_index"], self.episodes["world_id"]))
        return np.array([worlds[int(e)] for e in episode_index], dtype=np.int64)

    def _maker(self):
        if getattr(self, "_crop_maker", None) is None:
            if self.task_set is None:
                raise ValueError(f"{self.path}: cannot rebuild crops without its task set (version "
                                 f"{self.spec['task_set_version']}): pass task_set= to vertibench.datasets.open")
            c = self.spec["crop"]
            self._crop_maker = _core.CropMaker(str(self.task_set), float(self.spec["scale"]), int(c["size"]),
                                               float(c["resolution"]))
        return self._crop_maker

    def episode(self, index: int, crops: bool = True) -> dict[str, np.ndarray]:
        """Episode ``index``'s frames as arrays (crops rebuilt for a lite dataset when ``crops``)."""
        pq = _pyarrow()
        rows = self.episodes[self.episodes["episode_index"] == index]
        if rows.empty:
            raise IndexError(f"episode {index} is not in {self.path} ({len(self)} episodes)")
        row = rows.iloc[0]
        f = self.path / self.info["data_path"].format(chunk_index=int(row["data/chunk_index"]),
                                                      file_index=int(row["data/file_index"]))
        table = pq.read_table(f, filters=[("episode_index", "=", int(index))])
        return self._arrays(table, crops, np.full(table.num_rows, int(row["world_id"])))

    def batches(self, batch_size: int = 256, *, crops: bool = True, shuffle: bool = False, seed: int | None = None,
                drop_last: bool = False) -> Iterator[dict[str, np.ndarray]]:
        """Frames in batches of ``batch_size`` as dicts of arrays; ``shuffle`` draws frames within each data file in
        a seeded order (files in a seeded order too)."""
        if batch_size < 1:
            raise ValueError(f"batch_size={batch_size} must be at least 1")
        pq = _pyarrow()
        rng = np.random.default_rng(seed)
        files = self._data_files()
        if shuffle:
            files = [files[i] for i in rng.permutation(len(files))]
        carry: dict[str, np.ndarray] | None = None
        for f in files:
            arrays = self._arrays(pq.read_table(f), crops)
            if shuffle:
                order = rng.permutation(len(arrays["index"]))
                arrays = {k: v[order] for k, v in arrays.items()}
            if carry is not None:
                arrays = {k: np.concatenate([carry[k], arrays[k]]) for k in arrays}
            n = len(arrays["index"])
            full = n - n % batch_size
            for start in range(0, full, batch_size):
                yield {k: v[start:start + batch_size] for k, v in arrays.items()}
            carry = {k: v[full:] for k, v in arrays.items()} if full < n else None
        if carry is not None and not drop_last:
            yield carry


def _find_task_set(spec: dict) -> Path | None:
    """The task set a dataset was made on, when this package can make it: the benchmark's, or a training set of
    the recorded seed."""
    version = spec["task_set_version"]
    if version == task_sets.benchmark_version():
        return task_sets.benchmark()
    seed = spec.get("task_set_seed")
    if seed is not None and seed != task_sets.BENCHMARK_SEED:
        path = task_sets.training(int(seed))
        if task_sets.info(path).version == version:
            return path
    return None


def open(path: str | os.PathLike, task_set: str | os.PathLike | None = None) -> Dataset:  # noqa: A001
    """Opens the dataset at ``path``. ``task_set``: the task set it was made on, for rebuilding crops of a lite
    dataset (default: found from the recorded version and seed, generated into the cache if needed)."""
    pq = _pyarrow()
    import pyarrow as pa

    path = Path(path)
    info_path = path / "meta" / "info.json"
    if not info_path.is_file():
        raise ValueError(f"path={str(path)!r} holds no dataset (no meta/info.json)")
    info = json.loads(info_path.read_text())
    if "vertibench" not in info:
        raise ValueError(f"{info_path}: not a vertibench dataset (no `vertibench` section)")
    files = sorted((path / "meta" / "episodes").glob("chunk-*/file-*.parquet"))
    episodes = pa.concat_tables([pq.read_table(f) for f in files]).to_pandas() if files else None
    if episodes is not None:
        episodes = episodes.sort_values("episode_index").reset_index(drop=True)
    spec = info["vertibench"]["spec"]
    if task_set is not None:
        found = Path(task_set)
        if task_sets.info(found).version != spec["task_set_version"]:
            raise ValueError(f"task_set={str(task_set)!r} is version {task_sets.info(found).version}, but the "
                             f"dataset was made on {spec['task_set_version']}")
    else:
        found = _find_task_set(spec)
    return Dataset(path, info, episodes, found)


def to_minari(path: str | os.PathLike, dataset_id: str, *, task_set: str | os.PathLike | None = None,
              crops: bool = True, description: str | None = None):
    """Exports the dataset at ``path`` to Minari (its Arrow layout) as ``dataset_id`` (e.g.
    ``"vertibench/nav/random-v0"``) under ``$MINARI_DATASETS_PATH``, with the environment's spaces and spec, so
    ``minari.load_dataset(dataset_id)`` reads it and ``recover_environment()`` makes the environment. Observations
    are the environment's (``state``, ``goal`` and, with ``crops``, its ``elevation``, ``semantics`` and ``obstacles``
    crops of the dataset's crop size, rebuilt from each pose), ``T + 1`` per episode with the final one recorded in the episode's metadata."""
    try:
        import minari
        from minari.data_collector import EpisodeBuffer
    except ImportError:
        raise ImportError("to_minari needs minari: pip install 'minari[arrow]'") from None
    import gymnasium as gym

    from . import ENV_ID
    from ._spaces import action_space, observation_space

    ds = open(path, task_set)
    size = int(ds.spec["crop"]["size"])
    obs_space = observation_space(size if crops else 0)
    buffers = []
    for _, row in ds.episodes.iterrows():
        a = ds.episode(int(row["episode_index"]), crops=False)
        state = np.concatenate([a["observation.state"], np.asarray(row["final_state"], np.float64)[None]])
        goal = np.concatenate([a["observation.goal"], np.asarray(row["final_goal"], np.float64)[None]])
        obs = {"state": state.astype(np.float64), "goal": goal.astype(np.float64)}
        if crops:
            # The environment's crops at every pose, the final one included (obstacles too: the spaces are the
            # environment's), rebuilt with its own code.
            poses = np.ascontiguousarray(state[:, [0, 1, 2, 5]], dtype=np.float64)
            obs["elevation"], obs["semantics"], obs["obstacles"] = ds._maker().crops(int(row["world_id"]), poses)
        buffers.append(EpisodeBuffer(
            id=int(row["episode_index"]), seed=int(row["seed"]), observations=obs,
            actions=a["action"].astype(np.float32), rewards=a["next.reward"].astype(np.float64),
            terminations=a["next.terminated"].astype(bool), truncations=a["next.truncated"].astype(bool)))
    kwargs = {"task_set": str(ds.task_set) if ds.task_set else None, "vehicle": ds.spec["vehicle"],
              "scale": float(ds.spec["scale"]), "control_rate_hz": ds.fps, "crop_size": size if crops else 0,
              "crop_resolution": float(ds.spec["crop"]["resolution"])}
    env_spec = copy.deepcopy(gym.spec(ENV_ID))
    env_spec.kwargs = kwargs
    return minari.create_dataset_from_buffers(
        dataset_id, buffers, env=env_spec, observation_space=obs_space, action_space=action_space(),
        algorithm_name=str(ds.spec["kind"]),
        description=description or f"vertibench {ds.spec['kind']} dataset ({ds.spec['variant']}), from {ds.path}",
        data_format="arrow",
    )
