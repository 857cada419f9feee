"""Gymnasium integration as its maintainers expect it: registered ids, ``spec``, ``rgb_array`` rendering and
episode videos, pickling, explicit signatures a type checker sees, ``__version__``, and errors that name the
parameter."""

import importlib.metadata
import inspect
import pickle
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import vertibench as vb
from vertibench.render import VEHICLE, record_episode, save_video

TASK = "w017-t3"


def test_gym_make_and_make_vec_use_the_registered_id():
    env = gym.make(vb.ENV_ID, task=TASK, max_time=5.0)
    assert env.spec.id == vb.ENV_ID and env.spec.kwargs["task"] == TASK
    obs, info = env.reset(seed=0)
    assert info["task_id"] == TASK and obs["state"].shape == (len(vb.STATE_FIELDS),)
    venv = gym.make_vec(vb.ENV_ID, num_envs=3, tasks="low", max_time=5.0)
    assert isinstance(venv.unwrapped, vb.VertibenchVectorEnv) and venv.num_envs == 3
    obs, _ = venv.reset(seed=0)
    assert obs["state"].shape == (3, len(vb.STATE_FIELDS))
    sync = gym.make_vec(vb.ENV_ID, num_envs=2, vectorization_mode="sync", tasks="low")
    assert sync.reset(seed=0)[0]["goal"].shape == (2, 3)


def test_make_sets_the_spec_with_its_options():
    env = vb.make(TASK, crop_size=8)
    assert env.spec.id == vb.ENV_ID
    assert env.spec.kwargs["task"] == TASK and env.spec.kwargs["crop_size"] == 8
    # The spec rebuilds the same environment.
    again = gym.make(env.spec)
    assert again.unwrapped.task_ids == [TASK] and again.observation_space == env.observation_space


def test_rgb_array_frames_show_the_map_the_path_and_the_vehicle(tmp_path):
    env = vb.make(TASK, render_mode="rgb_array", render_ppm=2)
    env.reset(seed=0)
    first = env.render()
    assert first.dtype == np.uint8 and first.ndim == 3 and first.shape[2] == 3
    m = env.maps
    assert first.shape[:2] == (m.elevation.shape[0] * 2, m.elevation.shape[1] * 2)
    assert (np.all(first == VEHICLE, axis=2)).sum() > 4  # the vehicle is drawn
    assert (np.all(first == (220, 30, 30), axis=2)).sum() > 20  # the global path in red
    for _ in range(40):
        env.step(np.array([0.0, 0.8, 0.0], dtype=np.float32))
    later = env.render()
    # The vehicle moved: its pixels' centre moved towards the goal.
    def centre(img):
        ys, xs = np.nonzero(np.all(img == VEHICLE, axis=2))
        return np.array([xs.mean(), ys.mean()])
    assert np.linalg.norm(centre(later) - centre(first)) > 2
    assert vb.make(TASK).render() is None  # no render mode: gymnasium's convention, a warning and None


def test_record_episode_writes_a_gif_of_every_frame(tmp_path):
    pytest.importorskip("PIL")
    from PIL import Image

    env = vb.make(TASK, render_mode="rgb_array", render_ppm=1, max_time=3.0)
    info = record_episode(env, lambda obs: np.array([0.0, 0.5, 0.0], dtype=np.float32), tmp_path / "ep.gif",
                          every=5)
    assert info["outcome"] == "timeout"
    gif = Image.open(tmp_path / "ep.gif")
    durations = []
    for k in range(gif.n_frames):
        gif.seek(k)
        durations.append(gif.info["duration"])
    # The reset frame and every 5th of 60 steps, in real time (Pillow merges identical neighbours, adding up their
    # durations; GIF stores them in centiseconds).
    assert abs(sum(durations) - (1 + 60 // 5) * 250) <= (1 + 60 // 5) * 10 and gif.n_frames > 5
    with pytest.raises(ValueError, match="frames is empty"):
        save_video([], tmp_path / "none.gif")
    with pytest.raises(ValueError, match="render_mode='rgb_array'"):
        record_episode(vb.make(TASK), lambda o: (0, 0, 0), tmp_path / "x.gif")


def test_environments_pickle_by_their_options_and_run_the_same_episodes():
    env = vb.make(TASK, crop_size=4, max_time=5.0)
    copy = pickle.loads(pickle.dumps(env))
    venv = vb.make_vec(2, tasks="low", max_time=5.0)
    vcopy = pickle.loads(pickle.dumps(venv))
    assert vcopy.num_envs == 2 and vcopy.task_ids == venv.task_ids
    for e in (env, copy):
        e.reset(seed=3)
    a = np.array([0.2, 0.7, 0.0], dtype=np.float32)
    for _ in range(10):
        o1, r1, *_ = env.step(a)
        o2, r2, *_ = copy.step(a)
        assert r1 == r2 and all(np.array_equal(o1[k], o2[k]) for k in o1)


def test_signatures_are_explicit_and_a_type_checker_sees_them(tmp_path):
    for f in (vb.make, vb.make_vec, vb.evaluate, vb.VertibenchEnv, vb.VertibenchVectorEnv):
        params = inspect.signature(f).parameters.values()
        assert not any(p.kind is p.VAR_KEYWORD for p in params), f
    assert {"crop_size", "task_set", "num_threads", "autoreset_mode"} <= set(inspect.signature(vb.make_vec).parameters)
    mypy = shutil.which("mypy", path=str(Path(sys.executable).parent)) or shutil.which("mypy")
    if mypy is None:
        pytest.skip("SKIPPED: mypy is not installed (pip install mypy)")
    script = tmp_path / "typo.py"
    script.write_text(textwrap.dedent("""
        import vertibench as vb
        env = vb.make("w017-t3", crop_size=8)
        envs = vb.make_vec(4, crop_sise=8)
    """))
    r = subprocess.run([mypy, "--no-incremental", "--ignore-missing-imports", str(script)], capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 1, r.stdout + r.stderr
    assert 'Unexpected keyword argument "crop_sise"' in r.stdout and "typo.py:4" in r.stdout


def test_version_is_the_package_version():
    assert vb.__version__ == importlib.metadata.version("vertibench")


@pytest.mark.parametrize("kwargs, error, message", [
    (dict(crop_size=-1), ValueError, "crop_size=-1"),
    (dict(crop_size=2.5), TypeError, "crop_size=2.5"),
    (dict(control_rate_hz=0), ValueError, "control_rate_hz=0"),
    (dict(scale=-1.0), ValueError, "scale=-1.0"),
    (dict(max_time=float("nan")), ValueError, "max_time=nan"),
    (dict(rules="strict"), ValueError, "rules='strict'"),
    (dict(render_mode="human"), ValueError, "render_mode='human'"),
    (dict(vehicle="tank"), ValueError, "vehicle='tank'"),
    (dict(task_set="/nonexistent"), ValueError, "task_set='/nonexistent'"),
    (dict(reward={"speed": 1.0}), ValueError, "reward= has unknown weights"),
    (dict(tasks="low"), ValueError, "give task= .* or tasks= .*, not both"),
])
def test_bad_options_name_the_parameter(kwargs, error, message):
    with pytest.raises(error, match=message):
        vb.make(TASK, **kwargs)
    with pytest.raises(ValueError, match="parameter `tasks`: `lowish` is not"):
        vb.make(tasks="lowish")


def test_vector_options_name_the_parameter():
    with pytest.raises(ValueError, match="num_envs=-2"):
        vb.make_vec(-2)
    with pytest.raises(ValueError, match="num_threads=0"):
        vb.make_vec(2, num_threads=0)
    with pytest.raises(ValueError, match="task_order='shuffled'"):
        vb.make_vec(2, task_order="shuffled")
    with pytest.raises(ValueError, match="autoreset_mode='sometimes'"):
        vb.make_vec(2, autoreset_mode="sometimes")


def test_actions_of_the_wrong_shape_are_refused_not_reshaped():
    env = vb.make(TASK)
    env.reset(seed=0)
    for bad in (np.zeros((1, 3)), np.zeros((3, 1)), np.zeros(4)):
        with pytest.raises(ValueError, match=r"action has shape"):
            env.step(bad)
    venv = vb.make_vec(2, tasks="low")
    venv.reset(seed=0)
    with pytest.raises(ValueError, match=r"actions has shape \(3,\); expected \(2, 3\)"):
        venv.step(np.zeros(3))


def test_serve_without_grpc_names_the_extra(tmp_path):
    script = tmp_path / "planner.py"
    script.write_text(textwrap.dedent("""
        import sys
        sys.modules["grpc"] = None          # as after a plain `pip install vertibench`
        sys.modules["google"] = None
        import vertibench as vb
        class P(vb.Planner):
            def act(self, obs): return (0.0, 0.0, 0.0)
        vb.planner.serve(P())
    """))
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert r.returncode != 0 and "pip install 'vertibench[grpc]'" in r.stderr, r.stderr
