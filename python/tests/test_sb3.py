"""The stable-baselines3 adapter and the policy-as-planner bridge."""

import numpy as np
import pytest

import vertibench as vb
from vertibench.planner import env_observation, make_observation

sb3 = pytest.importorskip("stable_baselines3")


def test_sb3_vec_env_resets_in_the_same_step_and_keeps_the_terminal_observation():
    from vertibench.sb3 import SB3VecEnv

    env = SB3VecEnv(3, tasks="1,2", max_time=1.0)
    env.seed(5)
    obs = env.reset()
    assert obs["state"].shape == (3, 15)
    total = np.zeros(3)
    for step in range(1, 40):
        obs, rewards, dones, infos = env.step(np.tile([0.0, 1.0, 0.0], (3, 1)))
        total += rewards
        if dones.any():
            break
    assert dones.all(), "every episode hits the 1 s time limit on the same step"
    for i, info in enumerate(infos):
        assert info["TimeLimit.truncated"] and info["outcome"] == "timeout"
        assert info["terminal_observation"]["state"][14] >= 1.0
        assert obs["state"][i][14] == 0.0, "the returned observation starts the next episode"
        assert info["episode"]["l"] == step
        assert info["episode"]["r"] == pytest.approx(total[i], rel=1e-5)


def test_ppo_runs_on_the_adapter_and_its_policy_drives_as_a_planner(tmp_path):
    from stable_baselines3 import PPO

    from vertibench.sb3 import PolicyPlanner, SB3VecEnv

    env = SB3VecEnv(4, tasks="low", max_time=5.0)
    model = PPO("MultiInputPolicy", env, n_steps=32, batch_size=64, n_epochs=1, device="cpu", seed=0)
    model.learn(256)
    df, _ = vb.evaluate(PolicyPlanner(model), "w001-t0", out=tmp_path / "policy", progress=False)
    assert df.reason[0] != "planner_crash", df.detail[0]
    # Trained further, it is another planner: its results do not mix with the first one's.
    model.learn(128)
    with pytest.raises(ValueError, match="out="):
        vb.evaluate(PolicyPlanner(model), "w001-t0,w001-t1", out=tmp_path / "policy", progress=False)


def test_env_observation_rebuilds_the_environments_observation_from_a_planners():
    env = vb.make(tasks="1", crop_size=8, crop_resolution=1.0)
    obs, _ = env.reset(seed=0)
    for _ in range(30):
        obs, *_ = env.step(np.array([0.4, 0.8, 0.0]))
    s = obs["state"]
    planner_obs = make_observation((s[14], *s[:14]))
    rebuilt = env_observation(planner_obs, env.task.goal)
    np.testing.assert_array_equal(rebuilt["state"], s)
    np.testing.assert_allclose(rebuilt["goal"], obs["goal"], rtol=1e-12, atol=1e-9)
