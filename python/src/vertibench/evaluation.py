"""``vertibench.evaluate``: the benchmark in-process, writing the same files as ``vb eval``."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import sys
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING

from . import _core
from ._spaces import check_int, check_positive, default_task_set, task_spec
from .planner import Planner, identity

if TYPE_CHECKING:
    import pandas as pd


def _check_planner(planner) -> None:
    """A TypeError or ValueError naming ``planner`` unless it is a built-in's name or a usable :class:`Planner`."""
    if isinstance(planner, str):
        return
    if isinstance(planner, type) and issubclass(planner, Planner):
        raise TypeError(f"planner must be a Planner instance, not the class {planner.__qualname__}: pass "
                        f"{planner.__qualname__}()")
    if not isinstance(planner, Planner):
        raise TypeError("planner must be a vertibench.Planner (an instance of a subclass) or the name of a built-in "
                        f"planner such as \"pid\", not {type(planner).__name__}")
    check_positive(planner.control_rate_hz, "planner.control_rate_hz")
    if check_int(planner.crop_size, "planner.crop_size", 0, 512) > 0:
        check_positive(planner.crop_resolution, "planner.crop_resolution")
    if not isinstance(planner.name, str) or not planner.name:
        raise ValueError(f"planner.name={planner.name!r} must be a non-empty string")


class _Terminated(KeyboardInterrupt):
    """SIGTERM during :func:`evaluate`: stops it as Ctrl-C does."""


def _on_sigterm(signum, frame):
    raise _Terminated(f"signal {signum}")


@contextlib.contextmanager
def _stop_signals() -> Iterator[None]:
    """While an evaluation runs in the main thread: SIGTERM stops it as Ctrl-C does (finished episodes kept), unless
    the program handles SIGTERM itself; and a process that ignores SIGINT (a background job of a non-interactive
    shell, where Python leaves it ignored) is told that Ctrl-C cannot stop it."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        print(f"vertibench.evaluate: SIGINT is ignored in this process (pid {os.getpid()}; a background job of a "
              "non-interactive shell ignores it), so Ctrl-C cannot stop this evaluation: send SIGTERM to stop it "
              "and keep what finished", file=sys.stderr, flush=True)
    previous = signal.getsignal(signal.SIGTERM)
    if previous != signal.SIG_DFL:
        yield
        return
    signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def evaluate(
    planner: Planner | str,
    tasks: str | Iterable[str | int] = "all",
    *,
    out: str | os.PathLike[str] = "out/python-eval",
    vehicle: str = "hmmwv",
    task_set: str | os.PathLike[str] | None = None,
    scale: float | None = None,
    rules: str = "paper",
    step_timeout: float | None = 1.0,
    num_threads: int | None = None,
    progress: bool = True,
    perception: str | os.PathLike[str] = "ideal",
) -> tuple[pd.DataFrame, dict]:
    """Evaluates ``planner`` on the benchmark's tasks and returns ``(episodes, summary)``: a pandas DataFrame with
    ``vb eval``'s ``episodes.csv`` columns at full precision and the failure ``detail`` (one row per episode), and
    the ``summary.json`` dict (``summary["overall"]["success_rate"]``, breakdowns by level, semantics and density)
    with ``summary["complete"]``: True when every selected episode ran, False when Ctrl-C stopped the evaluation.

    ``planner`` is a :class:`vertibench.planner.Planner` (called back at its control rate, one episode at a time,
    in the calling thread) or the name of a built-in planner (``"pid"``, ``"eh"``, ``"mppi"``, ``"mppi-release"``, ``"mppi6-oracle"``, ``"rl"``, ...; run in
    parallel on ``num_threads`` threads, default: all cores). ``tasks`` is ``"all"``, a split name, or ids (world
    ids and task ids like ``"w001-t0"``; a comma-separated string or a list). The episodes are those of
    ``vb eval``: the same runner, rules (``rules="paper"`` or ``"release"``), ``vehicle``, world ``scale`` (default:
    the vehicle's) and results; ``task_set`` is a task directory (default: the benchmark's).

    ``step_timeout`` (seconds, default 1 as on the benchmark service; None: no limit) is the wall-clock deadline
    of a Python planner's :meth:`~vertibench.planner.Planner.act` (its ``reset`` gets at least 10 s). Simulated
    time stays frozen while the planner thinks; a call past its deadline fails the episode with reason
    ``planner_timeout`` and the evaluation goes on. A call still running in Python is stopped there (a
    ``StepTimeout``, a ``BaseException``, is raised in it); one blocked in native code fails once it returns.

    ``out`` gets ``results.jsonl`` (one line per finished episode), ``planner.json`` (the planner's identity, see
    :class:`~vertibench.planner.Planner`), ``episodes.csv``, ``episodes.parquet``, ``summary.json``,
    ``summary.txt`` and ``charts.svg``, so ``vb compare`` and ``vb leaderboard-static`` read it like any other.
    Ctrl-C (or SIGTERM, unless the program handles SIGTERM itself) stops the evaluation within a second: the
    episodes that finished are kept in ``out``, written and returned (``summary["complete"]`` is False). A process
    that ignores SIGINT (started as a background job of a non-interactive shell: Python keeps it ignored) is told
    on stderr that Ctrl-C cannot stop it. Calling again with the same ``out`` resumes: it says so on
    stderr and runs only the missing episodes; ``out`` holding another planner's (or configuration's) results is
    refused with a ValueError.

    ``perception`` is what the planner perceives: ``"ideal"`` (ground truth, the default), ``"nominal"``,
    ``"degraded"`` or a profile's TOML file (``perception/PROFILES.md``), as ``vb eval --perception``; the rows
    carry it, and a planner that reads the ground-truth maps is refused by a profile that degrades them.
    """
    import pandas as pd  # a core dependency

    _check_planner(planner)
    if scale is not None:
        scale = check_positive(scale, "scale")
    if step_timeout is not None:
        step_timeout = check_positive(step_timeout, "step_timeout")
    if num_threads is not None:
        num_threads = check_int(num_threads, "num_threads", 1)
    if rules not in ("paper", "release"):
        raise ValueError(f"rules={rules!r} is not 'paper' or 'release'")
    known = list(_core.vehicles())
    if vehicle not in known:
        raise ValueError(f"vehicle={vehicle!r} is not a vehicle of the catalogue: {', '.join(known)}")
    if task_set is not None and not (Path(task_set) / "manifest.json").is_file():
        raise ValueError(f"task_set={str(task_set)!r} holds no task set (no manifest.json): give a directory made "
                         "by vertibench.tasks.generate or vb tasks generate, or None for the benchmark's")
    out = Path(out)
    with _stop_signals():
        table, complete = _core.evaluate(
            planner,
            str(out),
            str(task_set) if task_set is not None else default_task_set(),
            tasks=task_spec(tasks),
            vehicle=vehicle,
            scale=scale,
            rules=rules,
            progress=bool(progress),
            identity=None if isinstance(planner, str) else json.dumps(identity(planner)),
            step_timeout=step_timeout,
            num_threads=num_threads,
            perception=str(perception),
        )
    episodes = pd.DataFrame(table)
    summary = json.loads((out / "summary.json").read_text())
    summary["complete"] = complete
    return episodes, summary
