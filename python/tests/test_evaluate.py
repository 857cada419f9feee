"""In-process evaluation: a Python planner on the benchmark's runner, with ``vb eval``'s results and files."""

import json
import os
import subprocess

import numpy as np
import pandas as pd
import pytest

import vertibench as vb
from vertibench.baselines import PID

# Low, medium and high worlds with rigid, deformable and mixed ground: every kind of episode end.
TASKS = "1,2,3,40,41,77"
# Columns that depend on the machine or on the planner's label, not on the episode.
VOLATILE = {"wall_time_s", "planner"}


def compare(a: pd.DataFrame, b: pd.DataFrame, decimals: bool = False):
    """Equal episodes (``decimals``: ``b`` was read from ``episodes.csv``, which rounds floats)."""
    assert list(a.task_id) == list(b.task_id)
    for col in b.columns:
        if col in VOLATILE:
            continue
        x, y = a[col], b[col]
        if decimals and x.dtype.kind == "f":
            assert np.allclose(x, y, rtol=1e-6, atol=1e-3, equal_nan=True), f"column {col} differs"
        else:
            assert x.equals(y), f"column {col} differs"


def test_the_pid_baseline_in_python_gives_the_built_in_pids_episodes(tmp_path):
    py, py_summary = vb.evaluate(PID(), TASKS, out=tmp_path / "python", progress=False)
    rs, _ = vb.evaluate("pid", TASKS, out=tmp_path / "builtin", progress=False)
    assert len(py) == 60 and set(py.outcome) >= {"success"} and len(set(py.outcome)) >= 2
    compare(py, rs)
    assert py_summary["overall"]["episodes"] == 60
    for f in ["results.jsonl", "episodes.csv", "episodes.parquet", "summary.json", "summary.txt", "charts.svg"]:
        assert (tmp_path / "python" / f).is_file(), f


def test_the_python_evaluation_equals_vb_eval(tmp_path):
    """``vb eval`` itself (the binary the Rust tests build; ``VB_BIN``) against the Python PID."""
    vb_bin = os.environ.get("VB_BIN")
    if not vb_bin:
        pytest.skip("SKIPPED: VB_BIN (the vb binary) is not set; .ci/run sets it")
    subprocess.run(
        [vb_bin, "eval", "--planner", "pid", "--tasks", TASKS, "--out", str(tmp_path / "vb"),
         "--task-dir", vb.default_task_set()],
        check=True,
        capture_output=True,
    )
    py, _ = vb.evaluate(PID(), TASKS, out=tmp_path / "python", progress=False)
    csv = pd.read_csv(tmp_path / "vb" / "episodes.csv", keep_default_na=False, na_values=[""])
    compare(py, csv, decimals=True)
    assert (tmp_path / "python" / "episodes.csv").read_text().replace("pid-python", "pid").splitlines()[0] == (
        tmp_path / "vb" / "episodes.csv"
    ).read_text().splitlines()[0]


def test_the_environment_follows_the_benchmarks_rules(tmp_path):
    """The PID acting through the gymnasium environment ends every episode as the benchmark does."""
    ref, _ = vb.evaluate("pid", "1,40,77", out=tmp_path / "ref", progress=False)
    env = vb.make(tasks="1,40,77")
    from vertibench.planner import make_observation

    for row in ref.itertuples():
        obs, info = env.reset(seed=0, options={"task": row.task_id})
        pid = PID()
        pid.reset(env.task, env.vehicle, None)
        while True:
            s = obs["state"]
            state = (s[14], *s[:14])
            a = pid.act(make_observation(state))
            obs, _, term, trunc, info = env.step(np.array([a.steering, a.throttle, a.brake]))
            if term or trunc:
                break
        assert info["outcome"] == row.outcome, row.task_id
        assert info["metrics"]["time_s"] == row.time_s, row.task_id


class Crashes(vb.Planner):
    name = "crashes"

    def act(self, obs):
        if obs.time > 1.0:
            raise ZeroDivisionError("boom")
        return (0.0, 0.5, 0.0)


class Wild(vb.Planner):
    name = "wild"
    crop_size = 5

    def act(self, obs):
        assert obs.elevation.shape == (5, 5)
        return vb.Action(steering=0.0, throttle=float("nan"))


def test_a_crashing_or_misbehaving_planner_fails_its_episodes_with_the_reason(tmp_path):
    df, _ = vb.evaluate(Crashes(), "w001-t0,w001-t1", out=tmp_path / "c", progress=False)
    assert set(df.outcome) == {"planner_failure"} and set(df.reason) == {"planner_crash"}
    assert df.detail[0].endswith("ZeroDivisionError: boom") and "Traceback" in df.detail[0]
    df, _ = vb.evaluate(Wild(), "w001-t0", out=tmp_path / "w", progress=False)
    assert df.reason[0] == "invalid_action" and "throttle is not finite" in df.detail[0]


def test_an_evaluation_resumes_and_refuses_another_planners_directory(tmp_path):
    vb.evaluate("pid", "w001-t0", out=tmp_path / "r", progress=False)
    df, _ = vb.evaluate("pid", "w001-t0,w001-t1", out=tmp_path / "r", progress=False)
    assert list(df.task_id) == ["w001-t0", "w001-t1"]
    with pytest.raises(ValueError, match="holds results of planner pid"):
        vb.evaluate(PID(), "w001-t0", out=tmp_path / "r", progress=False)


def test_a_perception_profile_reaches_the_runner_and_the_summary(tmp_path):
    """``perception=``: the built-in PID under ``degraded`` drives differently from ``ideal`` and its summary names
    the profile; a map-reading planner is refused by a map-degrading profile with the reason."""
    ideal, _ = vb.evaluate("pid", "w001-t0,w040-t1", out=tmp_path / "ideal", progress=False)
    noisy, summary = vb.evaluate("pid", "w001-t0,w040-t1", out=tmp_path / "degraded", progress=False,
                                 perception="degraded")
    assert summary["perception"].startswith("degraded@")
    assert "perception" not in json.loads((tmp_path / "ideal" / "summary.json").read_text())
    assert not ideal.path_length_m.equals(noisy.path_length_m)
    with pytest.raises(ValueError, match="ground-truth maps"):
        vb.evaluate("mppi6-oracle", "w001-t0", out=tmp_path / "mppi", progress=False, perception="nominal")
    with pytest.raises(ValueError, match="unknown perception profile"):
        vb.evaluate("pid", "w001-t0", out=tmp_path / "fog", progress=False, perception="foggy")


class Mapping(PID):
    """PID that records, at every step, how much of the map it was given at reset it knows."""

    def reset(self, task, vehicle, maps):
        super().reset(task, vehicle, maps)
        self.maps, self.known = maps, []

    def act(self, obs):
        self.known.append(int(self.maps.known.sum()))
        return super().act(obs)


def test_a_python_planner_keeps_the_map_the_sensor_builds_under_nominal(tmp_path):
    """Under ``nominal`` a Python planner's ``Maps`` are its belief: unknown at the start, filled in place as the
    vehicle drives (never all known, never shrinking); under ``ideal`` they are the whole truth."""
    p = Mapping()
    vb.evaluate(p, "w001-t0", out=tmp_path / "nominal", progress=False, perception="nominal")
    assert p.maps.believed
    cells = p.maps.known.size
    assert 0 < p.known[1] < p.known[-1] < cells, (p.known[:3], p.known[-1], cells)
    assert all(a <= b for a, b in zip(p.known, p.known[1:]))
    assert np.isnan(p.maps.elevation).any() and np.isfinite(p.maps.elevation).any()
    vb.evaluate(p, "w001-t0", out=tmp_path / "ideal", progress=False)
    assert not p.maps.believed and set(p.known) == {cells}
