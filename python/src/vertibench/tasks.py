"""Task sets: the benchmark's own (compiled into the package), training sets generated from other seeds, and their
facts. Never train on the benchmark's tasks: :func:`training` gives a held-out set (no terrain group, patch, obstacle
or task in common with the benchmark) that needs nothing but this package.

- :func:`benchmark`: the benchmark's 100 worlds x 10 tasks, written from the package into the cache on first use.
- :func:`training`: a training set generated from ``seed`` into the cache on first use (about a minute).
- :func:`generate`: any seed's set (and its surface counterfactuals) into a directory of your choice: the same bytes
  as ``vb tasks generate --seed N [--surface KIND] --out DIR``.
- :func:`info`: a task set directory's version, seed, generator and world count (every file checked).

The cache is ``$VERTIBENCH_CACHE``, else ``$XDG_CACHE_HOME/vertibench``, else ``~/.cache/vertibench``.
"""

from __future__ import annotations

import os
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

from . import _core

#: The benchmark's master seed: ``generate(seed=BENCHMARK_SEED)`` regenerates the benchmark's own set.
BENCHMARK_SEED: int = _core.BENCHMARK_SEED
#: The seed :func:`training` uses by default (the README's and the examples' training worlds).
TRAINING_SEED: int = 7
#: Semantics kinds a surface counterfactual can put every world on.
SURFACES: tuple[str, ...] = ("rigid", "mixed", "deformable")


@dataclass(frozen=True)
class TaskSetInfo:
    """A task set directory and what its manifest says (checked against its files)."""

    path: Path
    #: Content hash of the world files; results carry it.
    version: str
    #: Master seed (None for imported sets).
    seed: int | None
    #: Where the heights came from, e.g. ``swae:d938278b28963625`` (with `` surface=KIND`` for a counterfactual).
    generator: str
    worlds: int


def cache_dir() -> Path:
    """Where the package keeps task sets: ``$VERTIBENCH_CACHE``, ``$XDG_CACHE_HOME/vertibench`` or
    ``~/.cache/vertibench``."""
    if os.environ.get("VERTIBENCH_CACHE"):
        return Path(os.environ["VERTIBENCH_CACHE"])
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "vertibench"


def benchmark() -> Path:
    """The benchmark's task set (version :func:`benchmark_version`), written from the package into the cache on
    first use and checked file by file on every call."""
    return Path(_core.benchmark_task_dir(str(cache_dir())))


def benchmark_version() -> str:
    """The version of the benchmark's task set this package carries."""
    return _core.benchmark_task_version()


def default_task_set() -> Path:
    """The task set environments and evaluations use when given none: ``$VB_TASK_DIR`` when set, else
    :func:`benchmark`."""
    env = os.environ.get("VB_TASK_DIR")
    return Path(env) if env else benchmark()


def info(path: str | os.PathLike) -> TaskSetInfo:
    """Opens the task set at ``path`` (every file hashed against the manifest's version) and returns its facts."""
    version, seed, generator, worlds = _core.task_set_info(str(path))
    return TaskSetInfo(Path(path), version, seed, generator, worlds)


def generate(*, seed: int, out: str | os.PathLike, surface: str | None = None) -> TaskSetInfo:
    """Generates the 100-world task set of master seed ``seed`` into ``out``: the same bytes as ``vb tasks generate
    --seed SEED --out OUT`` (``surface``: ``--surface KIND``, the set with every world on ground of that kind, a
    counterfactual with a version of its own). A seed whose terrain would repeat one of the benchmark's is refused,
    except the benchmark's own (:data:`BENCHMARK_SEED`)."""
    seed = _check_seed(seed)
    if surface is not None and surface not in SURFACES:
        raise ValueError(f"surface={surface!r} is not one of {SURFACES}")
    out = Path(out)
    _core.generate(str(out), seed, surface)
    return info(out)


def training(seed: int = TRAINING_SEED, *, surface: str | None = None) -> Path:
    """A training task set: seed ``seed``'s worlds (held out from the benchmark), generated into the cache on first
    use (about a minute; said on stderr) and reused after; keyed by the seed and the benchmark set's version, so a
    package whose generator changed makes its own."""
    seed = _check_seed(seed)
    if seed == BENCHMARK_SEED:
        raise ValueError(f"seed={seed} is the benchmark's own seed: train on another seed's worlds")
    name = f"seed-{seed}" + (f"-{surface}" if surface else "") + f"@{benchmark_version()}"
    root = cache_dir() / "tasks" / "training"
    target = root / name
    if _loads(target):
        return target
    root.mkdir(parents=True, exist_ok=True)
    tmp = root / f".{name}.{os.getpid()}.tmp"
    shutil.rmtree(tmp, ignore_errors=True)
    print(f"vertibench: generating training task set seed={seed} into {target} (first use)", file=sys.stderr)
    generate(seed=seed, out=tmp, surface=surface)
    if target.exists():
        shutil.rmtree(target, ignore_errors=True)
    try:
        tmp.rename(target)
    except OSError:
        if not _loads(target):
            raise
        shutil.rmtree(tmp, ignore_errors=True)
    return target


def _loads(path: Path) -> bool:
    if not (path / "manifest.json").exists():
        return False
    try:
        info(path)
        return True
    except ValueError:
        return False


def _check_seed(seed) -> int:
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise TypeError(f"seed={seed!r} must be an int")
    if not 0 <= seed < 2**64:
        raise ValueError(f"seed={seed} must be in [0, 2**64)")
    return seed
