"""Datasets from Python (``vertibench.datasets``): read what ``vb dataset generate`` wrote; crops of a lite dataset
rebuilt from poses equal what the environment observed (and the full variant stored); Minari export."""

import os
import subprocess

import numpy as np
import pytest

import vertibench as vb
from vertibench import _core


def test_crops_rebuilt_from_poses_equal_the_environments():
    env = vb.make("w017-t3", crop_size=16, crop_resolution=0.7)
    obs, _ = env.reset(seed=0)
    seen, poses = [], []
    for k in range(30):
        s = obs["state"]
        seen.append(obs)
        poses.append([s[0], s[1], s[2], s[5]])
        obs, *_ = env.step(np.array([0.4 * np.sin(k / 5), 0.7, 0.0], dtype=np.float32))
    maker = _core.CropMaker(vb.default_task_set(), env.task.scale, 16, 0.7)
    elev, sem, occ = maker.crops(17, np.array(poses))
    for k, o in enumerate(seen):
        assert np.array_equal(elev[k], o["elevation"])
        assert np.array_equal(sem[k], o["semantics"])
        assert np.array_equal(occ[k], o["obstacles"])


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """A small expert dataset in both variants and a random one, on the training set, made by `vb`."""
    vb_bin = os.environ.get("VB_BIN")
    if not vb_bin:
        pytest.skip("SKIPPED: VB_BIN (the vb binary) is unset: no `vb dataset generate` to make datasets with")
    root = tmp_path_factory.mktemp("datasets")
    train = vb.tasks.training()
    out = {}
    for name, args in [("lite", ["--kind", "expert", "--hours", "0.03"]),
                       ("full", ["--kind", "expert", "--hours", "0.03", "--variant", "full", "--crop-size", "16"]),
                       ("random", ["--kind", "random", "--hours", "0.05", "--max-time", "20"])]:
        if name == "lite":
            args = args + ["--crop-size", "16"]
        subprocess.run([vb_bin, "dataset", "generate", "--task-set", str(train), "--out", str(root / name), *args],
                       check=True, capture_output=True, timeout=900)
        out[name] = root / name
    return out


def test_open_gives_episodes_frames_and_batches(made):
    ds = vb.datasets.open(made["random"])
    assert ds.spec["kind"] == "random" and len(ds) == len(ds.episodes) > 1
    frames = ds.frames()
    assert len(frames) == ds.info["total_frames"] == ds.episodes["length"].sum()
    ep = ds.episode(1)
    n = int(ds.episodes.loc[1, "length"])
    assert ep["observation.state"].shape == (n, 15) and ep["observation.state"].dtype == np.float64
    assert ep["observation.wheels"].shape == (n, 4, 4) and ep["observation.elevation"].shape == (n, 32, 32)
    assert np.array_equal(ep["frame_index"], np.arange(n))
    seen = np.concatenate([b["index"] for b in ds.batches(100, shuffle=True, seed=3, crops=False)])
    assert sorted(seen.tolist()) == list(range(len(frames)))
    again = np.concatenate([b["index"] for b in ds.batches(100, shuffle=True, seed=3, crops=False)])
    assert np.array_equal(seen, again)
    with pytest.raises(IndexError, match="episode 99999"):
        ds.episode(99999)
    with pytest.raises(ValueError, match="holds no dataset"):
        vb.datasets.open(made["random"] / "meta")


def test_lite_crops_rebuilt_equal_the_full_variants_stored_crops(made):
    lite, full = vb.datasets.open(made["lite"]), vb.datasets.open(made["full"])
    assert lite.spec["variant"] == "lite" and full.spec["variant"] == "full"
    assert len(lite) == len(full) > 0
    for i in range(min(len(lite), 3)):
        a, b = lite.episode(i), full.episode(i)
        assert np.array_equal(a["observation.state"], b["observation.state"])
        assert np.array_equal(a["observation.elevation"].astype(np.float16), b["observation.elevation"])
        assert np.array_equal(a["observation.semantics"], b["observation.semantics"])


def test_an_expert_episode_starts_with_the_environments_observation(made):
    ds = vb.datasets.open(made["lite"])
    row = ds.episodes.iloc[0]
    assert row["task_id"] is not None and row["outcome"] == "success"
    env = vb.make(row["task_id"], task_set=ds.task_set, crop_size=16)
    obs, _ = env.reset(seed=0)
    ep = ds.episode(0)
    assert np.array_equal(ep["observation.state"][0], obs["state"])
    assert np.array_equal(ep["observation.goal"][0], obs["goal"])
    assert np.array_equal(ep["observation.elevation"][0], obs["elevation"])
    assert np.array_equal(ep["observation.semantics"][0], obs["semantics"])


def test_to_minari_exports_what_minari_loads(made, tmp_path, monkeypatch):
    minari = pytest.importorskip("minari")
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    ds = vb.datasets.open(made["random"])
    vb.datasets.to_minari(made["random"], "vertibench/nav/random-v0")
    m = minari.load_dataset("vertibench/nav/random-v0")
    assert m.total_episodes == len(ds) and m.total_steps == ds.info["total_frames"]
    ep = next(iter(m.iterate_episodes([0])))
    n = int(ds.episodes.loc[0, "length"])
    assert ep.observations["state"].shape == (n + 1, 15) and ep.actions.shape == (n, 3)
    assert ep.observations["elevation"].shape == (n + 1, 32, 32)
    assert np.isclose(ep.rewards.sum(), ds.episode(0, crops=False)["next.reward"].sum(), rtol=1e-5)
    env = m.recover_environment()
    assert env.observation_space == m.observation_space
