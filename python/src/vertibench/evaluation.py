"""``vertibench.evaluate``: the benchmark in-process, writing the same files as ``vb eval``."""

from __future__ import annotations

import json
from pathlib import Path

from . import _core
from ._spaces import default_task_set, task_spec


def evaluate(
    planner,
    tasks="all",
    *,
    out="out/python-eval",
    vehicle: str = "hmmwv",
    task_set=None,
    scale: float | None = None,
    rules: str = "paper",
    progress: bool = True,
):
    """Evaluates ``planner`` on the benchmark's tasks and returns ``(episodes, summary)``: a pandas DataFrame with
    ``vb eval``'s ``episodes.csv`` columns at full precision and the failure ``detail`` (one row per episode), and
    the ``summary.json`` dict (``summary["overall"]["success_rate"]``, breakdowns by level, semantics and density).

    ``planner`` is a :class:`vertibench.planner.Planner` (called back at its control rate, one episode at a time)
    or the name of a built-in planner (``"pid"``, ``"eh"``, ``"mppi"``, ``"mppi6"``; run in parallel). The episodes
    are those of ``vb eval``: the same runner, rules (``rules="paper"`` or ``"release"``) and results. ``out`` gets
    ``results.jsonl``, ``episodes.csv``, ``episodes.parquet``, ``summary.json``, ``summary.txt`` and ``charts.svg``;
    running again with the same ``out`` resumes an interrupted evaluation (Ctrl-C stops it cleanly), so
    ``vb compare`` and ``vb leaderboard-static`` read it like any other.
    """
    import pandas as pd

    out = Path(out)
    table = _core.evaluate(
        planner,
        str(out),
        str(task_set) if task_set is not None else default_task_set(),
        tasks=task_spec(tasks),
        vehicle=vehicle,
        scale=scale,
        rules=rules,
        progress=progress,
    )
    episodes = pd.DataFrame(table)
    summary = json.loads((out / "summary.json").read_text())
    return episodes, summary
