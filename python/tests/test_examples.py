"""The examples in examples/python run as their docstrings say."""

import subprocess
import sys

from test_service import ROOT

EXAMPLES = ROOT / "examples" / "python"


def test_plot_episode_writes_a_picture(tmp_path):
    out = tmp_path / "episode.png"
    r = subprocess.run([sys.executable, str(EXAMPLES / "plot_episode.py"), "--task", "w002-t1", "--out", str(out)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 20_000
    assert "w002-t1:" in r.stdout


def test_pure_pursuit_evaluates_in_process(tmp_path):
    r = subprocess.run([sys.executable, str(EXAMPLES / "pure_pursuit.py"), "--evaluate", "w001-t0,w001-t1", "--out",
                        str(tmp_path / "pp")], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "success rate" in r.stdout and (tmp_path / "pp" / "episodes.csv").is_file()


def test_train_ppo_refuses_a_missing_training_set_with_the_command_that_makes_one(tmp_path):
    r = subprocess.run([sys.executable, str(EXAMPLES / "train_ppo.py"), "--task-set", str(tmp_path / "none")],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode != 0 and "vb.tasks.generate(seed=7" in r.stderr


def test_train_ppo_refuses_the_benchmarks_own_tasks():
    import vertibench as vb

    r = subprocess.run([sys.executable, str(EXAMPLES / "train_ppo.py"), "--task-set", str(vb.tasks.benchmark())],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode != 0 and "benchmark's own task set" in r.stderr
