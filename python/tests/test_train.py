"""vertibench.train: the curricula (no training), PPO's advantages, the CLI end to end with tiny budgets (rl, mcl,
acl), resuming, refusals, and the exported weights run by the Rust inference (``_core.PolicyNet``) against the torch
actor."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("safetensors")
pytest.importorskip("matplotlib")

import vertibench as vb  # noqa: E402
from vertibench import _core  # noqa: E402
from vertibench.train import curriculum as cur  # noqa: E402
from vertibench.train.ppo import ReturnStd, Rollout  # noqa: E402

needs_bindings = pytest.mark.skipif(not hasattr(_core, "policy_features"),
                                    reason="the extension lacks the learned policy bindings")
OUTPUTS = ("policy.safetensors", "curve.csv", "curve.png", "card.md", "card.json", "checkpoint.pt")
TINY = ["--envs", "2", "--rollout", "16", "--minibatch", "16", "--eval-episodes", "2", "--eval-every", "1",
        "--gate-episodes", "2", "--checkpoint-every", "1", "--threads", "1"]


# --- curricula -------------------------------------------------------------------------------------------------
def manual(budget=1000, min_episodes=50):
    return cur.Manual([[0], [0, 1], [0, 1, 2], [0, 1, 2, 3], [0, 1, 2, 3, 4]], budget=budget,
                      min_episodes=min_episodes)


def test_mcl_gate_passes_only_at_its_threshold_with_enough_episodes():
    m = manual()
    assert not m.gate(0.99, 100, 10)  # stage 1 needs 1.0
    assert not m.gate(1.0, 49, 20)  # too few episodes
    assert m.stage == 0 and m.records[0].success == 1.0
    assert m.gate(1.0, 50, 30) and m.stage == 1
    assert m.records[0].ended == "passed" and m.records[0].end_step == 30 and m.records[1].start_step == 30
    assert not m.gate(0.9, 60, 40) and m.gate(1.0, 60, 50)
    assert not m.gate(0.79, 60, 60) and m.gate(0.8, 60, 70) and m.stage == 3
    assert m.gate(0.6, 60, 80) and m.stage == 4
    assert not m.gate(1.0, 60, 90) and m.stage == 4  # the last stage stays
    rng = np.random.default_rng(0)
    assert {m.sample(rng) for _ in range(200)} == {0, 1, 2, 3, 4}


def test_mcl_unused_budget_flows_on_and_forced_stages_are_recorded():
    m = manual(budget=1000)
    assert m.deadline() == 200
    assert not m.check_deadline(199)
    assert m.check_deadline(200) and m.records[0].ended == "forced" and m.stage == 1
    assert m.deadline() == 200 + 800 // 4
    m.gate(1.0, 50, 260)  # passes early: the 140 steps it did not use flow to the later stages
    assert m.stage == 2 and m.deadline() == 260 + 740 // 3
    state = m.state_dict()
    m2 = manual(budget=1000)
    m2.load_state_dict(json.loads(json.dumps(state)))
    assert m2.stage == 2 and [r.ended for r in m2.records] == ["forced", "passed", "running"]
    rng = np.random.default_rng(1)
    assert {m2.sample(rng) for _ in range(100)} == {0, 1, 2}


def test_plr_draws_unseen_levels_first_then_replays_by_rank_and_staleness():
    p = cur.PLR(10, temperature=0.3, staleness=0.3, replay_prob=0.5, min_seen=0.5)
    rng = np.random.default_rng(0)
    first = []
    for _ in range(5):  # below min_seen: only unseen levels
        lv = p.sample(rng)
        assert not p.seen[lv]
        p.update(lv, 0.0)
        first.append(lv)
    assert len(set(first)) == 5
    for lv, s in zip(first, [5.0, 4.0, 3.0, 2.0, 1.0]):
        p.update(lv, s)
    w = p.replay_weights()
    assert w.sum() == pytest.approx(1.0) and (w[~p.seen] == 0).all()
    order = [w[lv] for lv in first]
    assert order == sorted(order, reverse=True) and order[0] > 0.5  # rank prioritisation
    # Staleness alone: the level drawn longest ago is the most likely.
    q = cur.PLR(3, staleness=1.0, min_seen=0.0)
    q.seen[:] = True
    q.last_drawn[:] = [5, 1, 3]
    q.draws = 6
    assert np.argmax(q.replay_weights()) == 1
    # Replay probability: with every level seen, draws follow the replay weights.
    counts = np.bincount([p.sample(rng) for _ in range(4000)], minlength=10)
    unseen = ~p.seen
    assert counts[unseen].sum() > 0 and counts[first[0]] > counts[first[-1]]


def test_plr_temperature_and_state_roundtrip():
    hot, cold = cur.PLR(4, temperature=1.0, staleness=0.0), cur.PLR(4, temperature=0.1, staleness=0.0)
    for p in (hot, cold):
        for lv, s in enumerate([0.1, 0.4, 0.3, 0.2]):
            p.update(lv, s)
    assert cold.replay_weights()[1] > 0.99 > hot.replay_weights()[1] > hot.replay_weights()[2]
    p = cur.PLR(4, temperature=1.0, staleness=0.0)
    p.load_state_dict(json.loads(json.dumps({k: v.tolist() if hasattr(v, "tolist") else v
                                             for k, v in hot.state_dict().items()})))
    assert np.allclose(p.replay_weights(), hot.replay_weights()) and p.seen.all() and p.draws == hot.draws
    assert cur.positive_value_loss(np.array([-1.0, 2.0, 0.0, 1.0])) == 0.75


def test_gae_does_not_bootstrap_across_episode_ends():
    b = Rollout(3, 2)
    b.reward[:] = 1.0
    b.value[:] = 0.5
    b.done[1, 0] = True  # env 0's episode ends after step 1 (a truncation's bootstrap is in its reward)
    b.gae(np.array([10.0, 10.0], np.float32), gamma=0.9, lam=1.0)
    assert b.ret[1, 0] == pytest.approx(1.0)  # no value crosses the end
    assert b.ret[2, 0] == pytest.approx(1.0 + 0.9 * 10.0)
    assert b.ret[0, 1] == pytest.approx(1 + 0.9 + 0.81 + 0.729 * 10.0)
    s = ReturnStd(2, 0.99)
    out = s.scale(np.array([3.0, -3.0]), np.array([True, False]))
    assert np.isfinite(out).all() and s.ret[0] == 0.0 and s.ret[1] == -3.0


# --- the CLI ---------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def train_set():
    return vb.tasks.training()


def cli(*args, check=True):
    env = dict(os.environ, PYTHONWARNINGS="ignore")
    p = subprocess.run([sys.executable, "-m", "vertibench.train", *map(str, args)], capture_output=True, text=True,
                       env=env, timeout=300)
    if check:
        assert p.returncode == 0, p.stderr[-3000:]
    return p


@needs_bindings
@pytest.mark.parametrize("system", ["rl", "mcl", "acl"])
def test_each_system_trains_end_to_end_and_writes_every_file(system, train_set, tmp_path):
    out = tmp_path / system
    # acl's run leaves --task-set out: the default set, vertibench.tasks.training(), is the same one.
    named = system != "acl"
    cli(system, *(("--task-set", train_set) if named else ()), "--out", out, "--steps", 64, "--seed", 3, *TINY)
    for name in OUTPUTS:
        assert (out / name).stat().st_size > 0, name
    card = json.loads((out / "card.json").read_text())
    assert card["steps"] == 64 and card["updates"] == 2 and card["seed"] == 3 and card["name"] == system
    assert card["task_set_version"] == vb.tasks.info(train_set).version != vb.tasks.benchmark_version()
    # The card names the set as the command did, never by this machine's cache path, and gives its seed.
    assert card["task_set"] == (str(train_set) if named else "vertibench.tasks.training()")
    assert card["task_set_seed"] == 7 and "(seed 7)" in (out / "card.md").read_text()
    assert set(card["time_s"]) >= {"env", "features", "inference", "update", "eval"}
    rows = (out / "curve.csv").read_text().splitlines()
    assert rows[0].startswith("steps,wall_s,success,return") and len(rows) == 1 + 3  # step 0 and two updates
    net = _core.PolicyNet(str(out / "policy.safetensors"))
    meta = net.metadata
    assert meta["format"] == _core.POLICY_LAYOUT and meta["name"] == system and meta["seed"] == "3"
    assert meta["features"] == ",".join(_core.POLICY_FEATURES) and meta["crop"] == "2x16x16"
    assert meta["curriculum"] == {"rl": "uniform", "mcl": "manual", "acl": "plr"}[system]
    if system == "mcl":
        assert "mcl_stages" in card and "MCL stages" in (out / "card.md").read_text()
    if system == "acl":
        assert "plr" in card


@needs_bindings
def test_rust_inference_gives_the_torch_actors_actions(train_set, tmp_path):
    from vertibench.train.policy import ActorCritic, load_actor
    from vertibench.train.worlds import Inputs, env_action, make_env, select

    torch.manual_seed(0)
    model = ActorCritic()
    with torch.no_grad():  # a policy whose actions are not all near zero
        model.pi.mean.weight.mul_(100.0)
    path = model.export(tmp_path / "p.safetensors", {"name": "t", "control_rate_hz": "20", "vehicle": "hmmwv"})
    net = _core.PolicyNet(str(path))
    ids = select(train_set, "all")
    env = make_env(4, [ids[0], ids[11], ids[22], ids[33]], train_set, 20.0)
    inputs = Inputs(env.vehicle)
    obs, _ = env.reset(seed=0)
    thr = np.zeros(4)
    rng = np.random.default_rng(0)
    interior = 0
    for _ in range(30):
        vec, crop = inputs(obs, thr)
        with torch.no_grad():
            ours = model.act(torch.from_numpy(vec), torch.from_numpy(crop)).numpy()
        rust = net.act(vec, crop)
        assert rust.shape == (4, 2) and np.abs(rust - ours).max() < 1e-5
        interior += int((np.abs(ours) < 0.99).sum())
        act = env_action(rng.uniform(-1, 1, (4, 2)))
        obs, _, term, trunc, _ = env.step(act)
        thr = act[:, 1].copy()
        if (term | trunc).any():
            thr[term | trunc] = 0.0
            obs, _ = env.reset(options={"reset_mask": term | trunc})
    assert interior > 30  # not only clamped actions
    # A file of another layout is refused, naming what differs.
    from safetensors.numpy import save_file

    bad = tmp_path / "bad.safetensors"
    save_file(model.actor_tensors(), str(bad), metadata={**net.metadata, "crop": "2x32x32"})
    with pytest.raises(ValueError, match="crop"):
        _core.PolicyNet(str(bad))
    loaded, meta = load_actor(path)
    assert meta["name"] == "t"
    with torch.no_grad():
        assert torch.allclose(loaded.act(torch.from_numpy(vec), torch.from_numpy(crop)),
                              torch.from_numpy(net.act(vec, crop)), atol=1e-5)


@needs_bindings
def test_a_resumed_run_continues_from_its_checkpoint(train_set, tmp_path):
    out = tmp_path / "rl"
    cli("rl", "--task-set", train_set, "--out", out, "--steps", 32, *TINY)
    first = json.loads((out / "card.json").read_text())
    assert first["steps"] == 32 and first["updates"] == 1
    p = cli("rl", "--task-set", train_set, "--out", out, "--steps", 96, "--resume", *TINY)
    assert "resuming rl" in p.stderr and "at step 32" in p.stderr
    card = json.loads((out / "card.json").read_text())
    assert card["steps"] == 96 and card["updates"] == 3
    steps = [int(r.split(",")[0]) for r in (out / "curve.csv").read_text().splitlines()[1:]]
    assert steps == [0, 32, 64, 96]
    bad = cli("acl", "--task-set", train_set, "--out", out, "--steps", 96, *TINY, check=False)
    assert bad.returncode != 0 and "another training" in bad.stderr and "Traceback" not in bad.stderr


def test_bad_input_is_a_clear_error(tmp_path):
    for args, words in [
        (["ppo", "--out", tmp_path], "unknown system"),
        (["rl", "--out", tmp_path, "--steps", "-5"], "--steps must be > 0"),
        (["rl", "--out", tmp_path, "--task-set", tmp_path / "nowhere"], "no task set"),
        (["rl", "--out", tmp_path / "x", "--resume", "--task-set", vb.tasks.benchmark()], "benchmark's own"),
        (["rl", "--out", tmp_path / "y", "--resume", "--task-set", vb.tasks.training()], "no checkpoint"),
    ]:
        p = cli(*args, check=False)
        assert p.returncode != 0 and words in p.stderr, (args, p.stderr)
        assert "Traceback" not in p.stderr


def test_rollout_sampling_matches_the_update_distribution():
    from vertibench.train.policy import ActorCritic

    torch.manual_seed(1)
    model = ActorCritic()
    vec = np.random.default_rng(0).normal(size=(5, 12)).astype(np.float32)
    crop = np.random.default_rng(1).normal(size=(5, 2, 16, 16)).astype(np.float32)
    a, logp, v = model.sample(vec, crop)
    with torch.no_grad():
        dist, value = model.dist_and_value(torch.from_numpy(vec), torch.from_numpy(crop))
        assert np.allclose(dist.log_prob(torch.from_numpy(a)).sum(-1).numpy(), logp, atol=1e-5)
        assert np.allclose(value.numpy(), v) and not np.allclose(a, dist.mean.numpy())
