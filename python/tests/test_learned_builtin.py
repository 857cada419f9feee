"""The committed learned baselines (issue 33): the Rust built-in planners ``rl``, ``mcl`` and ``acl`` (weights
compiled into the extension) and the same weights in Python: the PyTorch actor gives the same actions within 1e-5 on
real observations, and the Python planner's whole pipeline (observation, features, crops, last throttle, control
rate) with the Rust inference gives the built-in's episodes exactly. (Torch's episodes are not compared outcome by
outcome: its float32 sums run in another order, and the closed loop amplifies differences of 1e-14 into other
outcomes on some tasks; BENCHMARKS.md, issue 33.)"""

from pathlib import Path

import numpy as np
import pytest

import vertibench as vb
from vertibench import _core

torch = pytest.importorskip("torch")
pytest.importorskip("safetensors")
from vertibench.train.planner import TorchPolicyPlanner  # noqa: E402
from vertibench.train.policy import load_actor  # noqa: E402

WEIGHTS = Path(__file__).resolve().parents[2] / "planners" / "learned" / "weights"
TASKS = ["w003-t1", "w012-t4", "w027-t0", "w048-t7", "w061-t2", "w090-t5"]


def weights(name: str) -> Path:
    path = WEIGHTS / f"{name}.safetensors"
    if not path.is_file():
        pytest.skip(f"SKIPPED: no committed weights {path} (train them: python -m vertibench.train {name})")
    return path


@pytest.mark.parametrize("name", ["rl", "mcl", "acl"])
def test_the_builtin_and_the_torch_actor_agree_on_actions_and_outcomes(name, tmp_path):
    path = weights(name)
    # Actions on real observations of the benchmark's environment.
    env = vb.make_vec(4, tasks=TASKS, crop_size=_core.POLICY_CROP_SIZE)
    obs, _ = env.reset(seed=3)
    model, _ = load_actor(path)
    rust = _core.PolicyNet(path)
    last = np.zeros(4)
    for _ in range(40):
        vec, crop = _core.policy_features(obs["state"], obs["goal"], last, obs["elevation"], obs["obstacles"],
                                          env.vehicle["scale"], env.vehicle["nominal_speed"])
        with torch.inference_mode():
            ours = model.act(torch.from_numpy(np.array(vec)), torch.from_numpy(np.array(crop))).numpy()
        np.testing.assert_allclose(rust.act(vec, crop), ours, atol=1e-5)
        action = np.concatenate([ours, np.zeros((4, 1), np.float32)], axis=1)
        last = action[:, 1].astype(np.float64)
        obs, *_ = env.step(action)
    # Whole episodes: the built-in (Rust, compiled-in weights) and the Python planner with the Rust inference.
    built, _ = vb.evaluate(name, TASKS, out=tmp_path / "builtin", progress=False)
    planner = TorchPolicyPlanner(path, backend="rust")
    py, _ = vb.evaluate(planner, TASKS, out=tmp_path / "python", progress=False, step_timeout=None)
    b = built.set_index("task_id")
    p = py.set_index("task_id").loc[b.index]
    assert list(b.outcome) == list(p.outcome)
    assert list(b.path_length_m) == list(p.path_length_m)
    assert list(b.steps) == list(p.steps)
