"""Datasets from Python: crops rebuilt from poses equal what the environment observed."""

import numpy as np

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
