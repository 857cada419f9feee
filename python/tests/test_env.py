"""The gymnasium environments: API conformance, determinism, auto-reset modes, reward terms and the benchmark's
episode rules."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from gymnasium.vector import AutoresetMode, SyncVectorEnv

import vertibench as vb

LOW = "1,2,3"


def test_single_env_passes_gymnasium_check_env_with_and_without_crops():
    check_env(vb.make(tasks=LOW), skip_render_check=True)
    env = vb.make(tasks=LOW, crop_size=16, crop_resolution=0.5)
    check_env(env, skip_render_check=True)
    obs, info = env.reset(seed=0)
    assert obs["elevation"].shape == (16, 16) and obs["elevation"].dtype == np.float32
    assert obs["obstacles"].max() <= 1
    assert info["task_id"] in env.task_ids


def test_single_env_passes_stable_baselines3_check_env():
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    sb3_check_env(vb.make(tasks=LOW, crop_size=8), warn=True)


def run(env, steps, seed):
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    trace = [obs]
    for _ in range(steps):
        a = rng.uniform(env.action_space.low, env.action_space.high).astype(np.float32)
        obs, reward, term, trunc, info = env.step(a)
        trace.append((obs, reward, term, trunc))
    return trace


def same(a, b):
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, tuple):
        return all(same(x, y) for x, y in zip(a, b))
    return np.array_equal(a, b)


def test_same_seed_gives_the_same_observations_and_another_seed_does_not():
    def trace(seed):
        return run(vb.make_vec(4, tasks="low", max_time=3.0, crop_size=8), 80, seed)

    first, again, other = trace(7), trace(7), trace(8)
    assert all(same(a, b) for a, b in zip(first, again))
    assert not same(first[0], other[0])


def test_vector_env_equals_gymnasiums_sync_vector_env_over_single_envs():
    # Short episodes, so that episodes end (truncated at the time limit, or terminated) and auto-reset within the run.
    kw = dict(tasks="low", max_time=2.0, crop_size=6)
    ours = vb.make_vec(3, **kw)
    ref = SyncVectorEnv([lambda: vb.make(**kw) for _ in range(3)])
    assert ours.metadata["autoreset_mode"] == ref.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    o1, _ = ours.reset(seed=11)
    o2, _ = ref.reset(seed=11)
    assert same(o1, o2)
    rng = np.random.default_rng(0)
    ends = 0
    for _ in range(120):
        a = rng.uniform([-1, 0, 0], [1, 1, 0.2], size=(3, 3)).astype(np.float32)
        r1 = ours.step(a)
        r2 = ref.step(a)
        for x, y in zip(r1[:4], r2[:4]):
            assert same(x, y)
        ends += int(np.sum(r1[2] | r1[3]))
    assert ends >= 3


def test_same_step_autoreset_returns_the_final_observation_in_info():
    env = vb.make_vec(2, tasks=LOW, max_time=1.0, autoreset_mode=AutoresetMode.SAME_STEP)
    env.reset(seed=3)
    for _ in range(40):
        obs, reward, term, trunc, info = env.step(np.tile([0.0, 1.0, 0.0], (2, 1)))
        done = term | trunc
        if done.any():
            break
    assert done.all(), "both episodes hit the 1 s time limit on the same step"
    assert trunc.all() and not term.any()
    assert info["_final_obs"].all()
    for i in range(2):
        final = info["final_obs"][i]
        assert final["state"][14] >= 1.0  # the time limit was reached
        assert obs["state"][i][14] == 0.0  # the new episode's first observation
        assert info["final_info"]["outcome"][i] == "timeout"


def test_disabled_autoreset_needs_an_explicit_reset_of_ended_environments():
    env = vb.make_vec(2, tasks=LOW, max_time=0.5, autoreset_mode=AutoresetMode.DISABLED)
    env.reset(seed=1)
    for _ in range(20):
        *_, term, trunc, info = env.step(np.zeros((2, 3)))
        if (term | trunc).all():
            break
    with pytest.raises(RuntimeError, match="call reset"):
        env.step(np.zeros((2, 3)))
    obs, info = env.reset(options={"reset_mask": np.array([True, False])})
    assert obs["state"][0][14] == 0.0


def test_next_step_autoreset_ignores_the_action_after_an_end_and_reports_it():
    env = vb.make_vec(1, tasks=LOW, max_time=0.5)
    env.reset(seed=2)
    for _ in range(20):
        _, _, term, trunc, info = env.step(np.zeros((1, 3)))
        if term[0] or trunc[0]:
            break
    assert info["_outcome"][0] and info["outcome"][0] == "timeout"
    obs, reward, term, trunc, info = env.step(np.array([[0.0, 1.0, 0.0]]))
    assert info["_reset"][0] and reward[0] == 0.0 and not term[0] and not trunc[0]
    assert obs["state"][0][14] == 0.0


def test_reward_is_the_sum_of_its_documented_terms():
    env = vb.make(tasks=LOW, reward={"roll": 2.0, "pitch": 3.0})
    obs, _ = env.reset(seed=4)
    for _ in range(60):
        # Steer at the goal (its bearing in the heading frame, P control) at full throttle.
        ahead, left = obs["goal"][0], obs["goal"][1]
        steering = float(np.clip(2.0 * np.arctan2(left, ahead), -1.0, 1.0))
        obs, reward, term, trunc, info = env.step(np.array([steering, 1.0, 0.0]))
        terms = info["reward_terms"]
        assert set(terms) == set(vb.REWARD_TERMS)
        assert reward == pytest.approx(sum(terms.values()))
        assert terms["roll"] <= 0.0 and terms["pitch"] <= 0.0
        roll, pitch = obs["state"][3], obs["state"][4]
        assert terms["roll"] == pytest.approx(-2.0 * (roll / np.radians(30)) ** 2)
        assert terms["pitch"] == pytest.approx(-3.0 * (pitch / np.radians(30)) ** 2)
        if term or trunc:
            break
    # Driving at the goal makes progress: the distance decrease over the last steps is positive.
    assert terms["progress"] > 0.0


def test_an_invalid_action_fails_the_episode_as_in_the_benchmark():
    env = vb.make(tasks=LOW)
    env.reset(seed=0)
    _, reward, term, trunc, info = env.step(np.array([0.0, 2.0, 0.0]))
    assert term and not trunc
    assert info["outcome"] == "planner_failure" and info["reason"] == "invalid_action"
    assert "throttle" in info["detail"]
    assert info["reward_terms"]["terminal"] == -vb.DEFAULT_REWARD["failure_penalty"]
    clipped = vb.make(tasks=LOW, clip_actions=True)
    clipped.reset(seed=0)
    _, _, term, _, _ = clipped.step(np.array([0.0, 2.0, 0.0]))
    assert not term


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(task="w999-t0"), "w999"),
        (dict(tasks="steep"), "steep"),
        (dict(tasks=""), "empty"),
        (dict(vehicle="tank"), "tank"),
        (dict(rules="strict"), "strict"),
        (dict(reward={"speed": 1.0}), "speed"),
        (dict(task_set="/nonexistent"), "nonexistent"),
        (dict(control_rate_hz=0.0), "control_rate_hz"),
    ],
)
def test_bad_options_are_refused_with_a_clear_error(kwargs, message):
    with pytest.raises(ValueError, match=message):
        vb.make(**kwargs)


def test_wrong_action_shape_is_refused():
    env = vb.make_vec(2, tasks=LOW)
    env.reset(seed=0)
    with pytest.raises(ValueError):
        env.step(np.zeros((3, 3)))


def test_a_task_can_be_chosen_at_reset_and_its_start_is_the_tasks():
    env = vb.make(tasks=LOW)
    obs, info = env.reset(seed=0, options={"task": "w002-t4"})
    assert info["task_id"] == env.task_id == "w002-t4"
    assert obs["goal"][2] > 10.0
    assert abs(obs["goal"][1]) < 0.05 * obs["goal"][2], "the vehicle starts facing the goal"


def test_gymnasium_wrappers_work_on_the_env():
    env = gym.wrappers.FlattenObservation(vb.make(tasks=LOW, crop_size=4))
    obs, _ = env.reset(seed=0)
    assert obs.shape == (15 + 3 + 3 * 16,)


def test_a_repeated_start_is_the_same_as_the_first():
    """Resets start from a clone of the task's settled start: bit-identical to settling it again."""
    env = vb.make(tasks="1,41", crop_size=4)  # a rigid and a deformable world

    def episode(task):
        obs, _ = env.reset(options={"task": task})
        trace = [obs]
        for k in range(60):
            obs, *_ = env.step(np.array([0.5 * np.sin(k / 7), 0.7, 0.0]))
            trace.append(obs)
        return trace

    for task in ["w001-t3", "w041-t2"]:
        first = episode(task)
        episode("w001-t0" if task != "w001-t0" else "w041-t0")
        assert all(same(a, b) for a, b in zip(first, episode(task))), task


def test_an_environment_under_a_perception_profile_observes_the_estimate_and_the_believed_map():
    """``perception=``: the state is the estimate, the crops are the believed map's with a ``known`` mask (unseen
    heights are not read as anything: ``known`` is 0 there), the ground-truth maps are withheld, and the noise is
    the same for the same task; under ``ideal`` nothing changes."""
    a = np.array([0.0, 0.6, 0.0], dtype=np.float32)

    def drive(env, steps=30):
        obs, _ = env.reset(seed=0)
        for _ in range(steps):
            obs, *_ = env.step(a)
        return obs

    truth = drive(vb.make("w001-t0", crop_size=24))
    noisy_env = vb.make("w001-t0", crop_size=24, perception="nominal")
    check_env(vb.make("w001-t0", crop_size=8, perception="nominal"), skip_render_check=True)
    noisy = drive(noisy_env)
    assert "known" not in truth and set(np.unique(noisy["known"])) == {0, 1}
    assert np.all(noisy["elevation"][noisy["known"] == 0] == 0.0)
    assert not np.array_equal(truth["state"], noisy["state"])
    assert noisy_env.observation_space.contains(noisy)
    with pytest.raises(ValueError, match="degrades the maps"):
        noisy_env.maps
    assert same(noisy, drive(vb.make("w001-t0", crop_size=24, perception="nominal")))
    assert same(truth, drive(vb.make("w001-t0", crop_size=24, perception="ideal")))
    vec = vb.make_vec(2, "w001-t0", crop_size=8, perception="degraded", task_order="cycle")
    obs, _ = vec.reset(seed=0)
    assert obs["known"].shape == (2, 8, 8) and vec.single_observation_space["known"].shape == (8, 8)
