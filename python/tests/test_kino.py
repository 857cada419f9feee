"""vertibench.kino: the learned kinodynamic model's inputs and targets (made by the Rust planners' code), the Rust
forward pass against PyTorch's, refusals of foreign weights, and training and the accuracy report end to end on
tiny datasets made by `vb dataset generate`."""

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
pytest.importorskip("pyarrow")

import vertibench as vb  # noqa: E402
from vertibench import _core  # noqa: E402
from vertibench.kino import data as kd  # noqa: E402
from vertibench.kino import model as km  # noqa: E402


def poses_on(maker, world, n=40, seed=0):
    rng = np.random.default_rng(seed)
    p = np.zeros((n, 6))
    p[:, :2] = rng.uniform(-50, 50, (n, 2))
    p[:, 2] = rng.uniform(0, 3, n)
    p[:, 3:5] = rng.uniform(-0.2, 0.2, (n, 2))
    p[:, 5] = rng.uniform(-np.pi, np.pi, n)
    return p


def test_targets_applied_to_the_start_give_the_end_pose_and_features_are_deterministic():
    maker = _core.KinoData(vb.default_task_set(), "hmmwv", 1.0)
    now = poses_on(maker, 17)
    after = now + np.array([1.0, -0.5, 0.1, 0.02, -0.03, 0.3]) @ np.eye(6)
    after[:, 5] = np.arctan2(np.sin(after[:, 5]), np.cos(after[:, 5]))
    tgt = maker.targets(now, after, np.full(len(now), 0.25))
    assert tgt.shape == (len(now), 7) and tgt.dtype == np.float32 and np.all(tgt[:, 6] == 0.25)
    back = maker.apply(now, tgt)
    assert np.allclose(back[:, :5], after[:, :5], atol=1e-5)
    assert np.allclose(np.cos(back[:, 5] - after[:, 5]), 1.0, atol=1e-9)
    # The factors: 4 m/s x 0.25 s per position unit, 0.1 rad per angle unit.
    assert np.allclose(maker.target_factors, [1.0, 1.0, 1.0, 0.1, 0.1, 0.1, 1.0])
    act = np.tile([0.2, 0.6, 0.0], (len(now), 1))
    vec, crop = maker.features(17, now, now, np.zeros(len(now)), act)
    assert vec.shape == (len(now), 16) and crop.shape == (len(now), 16, 16)
    assert np.all(vec[:, :6] == 0), "a standing start has no previous change of pose"
    assert np.allclose(vec[:, 9:12], act) and np.all(np.abs(vec) <= 5) and np.all(np.abs(crop) <= 5)
    ground = vec[:, 12:16]
    assert np.all((ground[:, 0] > 0) ^ (ground[:, 1:].sum(1) == 1)), "rigid friction or exactly one soil"
    vec2, crop2 = maker.features(17, now, now, np.zeros(len(now)), act)
    assert np.array_equal(vec, vec2) and np.array_equal(crop, crop2)
    with pytest.raises(ValueError, match="expected"):
        maker.features(17, now[:3], now, np.zeros(len(now)), act)
    with pytest.raises(ValueError):
        _core.KinoData(vb.default_task_set(), "no-such-vehicle", 1.0)


def test_the_rust_forward_pass_equals_torchs_within_1e_5(tmp_path):
    torch.manual_seed(3)
    model = km.KinoModel(members=3, hidden=32).eval()
    path = tmp_path / "k.safetensors"
    km.save(model, path, {"name": "t"})
    rng = np.random.default_rng(0)
    vec = rng.uniform(-2, 2, (64, 16)).astype(np.float32)
    crop = rng.uniform(-1, 1, (64, 16, 16)).astype(np.float32)
    net = _core.KinoNet(str(path))
    assert net.metadata["format"] == _core.KINO_LAYOUT and net.metadata["ensemble"] == "3"
    got = net.predict(vec, crop)
    with torch.no_grad():
        want = model(torch.from_numpy(vec), torch.from_numpy(crop)).numpy()
    assert got.shape == want.shape == (64, 3, 7)
    assert np.max(np.abs(got - want)) < 1e-5
    again = km.load(path)
    with torch.no_grad():
        assert torch.equal(again(torch.from_numpy(vec), torch.from_numpy(crop)), torch.from_numpy(want))


def test_foreign_or_damaged_weights_are_refused_naming_what_differs(tmp_path):
    from safetensors.torch import save_file

    model = km.KinoModel(members=2, hidden=16)
    tensors = {k: v.detach().contiguous() for k, v in model.state_dict().items()}
    meta = km.metadata(model, {})
    cases = {
        "format": ({**meta, "format": "vertibench-policy-v1"}, tensors),
        "features": ({**meta, "features": "a,b"}, tensors),
        "ensemble": ({**meta, "ensemble": "0"}, tensors),
        "heads.1.out.weight": (meta, {k: v for k, v in tensors.items() if k != "heads.1.out.weight"}),
    }
    for word, (m, t) in cases.items():
        p = tmp_path / f"{word}.safetensors"
        save_file(t, str(p), metadata=m)
        with pytest.raises(ValueError, match=word.replace(".", r"\.")):
            _core.KinoNet(str(p))
    with pytest.raises(ValueError, match="No such file|not found|os error"):
        _core.KinoNet(str(tmp_path / "missing.safetensors"))


@pytest.fixture(scope="module")
def kino_data(tmp_path_factory):
    """Tiny random and expert datasets on the training set, made by `vb`."""
    vb_bin = os.environ.get("VB_BIN")
    if not vb_bin:
        pytest.skip("SKIPPED: VB_BIN (the vb binary) is unset: no `vb dataset generate` to make datasets with")
    root = tmp_path_factory.mktemp("kino")
    train = vb.tasks.training()
    for kind, hours in (("random", "0.2"), ("expert", "0.1")):
        subprocess.run([vb_bin, "dataset", "generate", "--kind", kind, "--task-set", str(train), "--hours", hours,
                        "--max-time", "20", "--out", str(root / kind)], check=True, capture_output=True,
                       timeout=900)
    return root


def run_kino(*args):
    return subprocess.run([sys.executable, "-m", "vertibench.kino", *map(str, args)], capture_output=True,
                          text=True, timeout=900)


def test_training_resumes_and_writes_weights_the_rust_reader_runs_and_a_report(kino_data, tmp_path):
    out = tmp_path / "kino"
    data = [kino_data / "random", kino_data / "expert"]
    args = ("--members", 2, "--hidden", 16, "--lr-decay", "cosine")
    r = run_kino("train", "--data", *data, "--out", out, "--epochs", 1, *args)
    assert r.returncode == 0, r.stderr
    r = run_kino("train", "--data", *data, "--out", out, "--epochs", 2, *args)
    assert r.returncode == 0, r.stderr
    assert "resumed at epoch 1" in r.stdout
    for f in ("kino.safetensors", "card.md", "card.json", "curve.csv", "curve.png", "checkpoint.pt"):
        assert (out / f).exists(), f
    card = json.loads((out / "card.json").read_text())
    assert card["epochs"] == 2 and {d["kind"] for d in card["data"]} == {"random", "expert"}
    assert card["lr_decay"] == "cosine" and "cosine decay" in (out / "card.md").read_text()
    assert card["device"] == "cpu" and "training on cpu" in (out / "card.md").read_text()
    assert card["heldout_samples"] > 0 and card["samples"] > card["heldout_samples"]
    assert len((out / "curve.csv").read_text().splitlines()) == 3
    net = _core.KinoNet(str(out / "kino.safetensors"))
    assert net.metadata["task_set_version"] == card["task_set_version"]
    r = run_kino("report", "--weights", out / "kino.safetensors", "--data", *data, "--out", tmp_path / "rep")
    assert r.returncode == 0, r.stderr
    rep = json.loads((tmp_path / "rep" / "accuracy.json").read_text())
    models = {(x["model"], x["horizon_s"]) for x in rep["rows"] if x["group"] == "all"}
    assert {("learned", 1.0), ("bicycle", 1.0), ("simulator", 1.0)} <= models
    # Our simulator restarted from the recorded observation follows the recording far better than the bicycle.
    at1 = {x["model"]: x for x in rep["rows"] if x["group"] == "all" and x["horizon_s"] == 1.0}
    assert at1["simulator"]["position_m"] < 0.5 * at1["bicycle"]["position_m"], at1
    assert "simulator_reduction_vs_bicycle" in rep
    for x in rep["rows"]:
        assert x["n"] > 0 and all(np.isfinite(x[k]) and x[k] >= 0 for k in ("position_m", "yaw_deg"))
    r = run_kino("train", "--data", tmp_path / "nothing", "--out", tmp_path / "k2")
    assert r.returncode == 2 and "error" in r.stderr


def test_a_device_pytorch_does_not_have_is_refused_before_any_data_is_read(tmp_path):
    for model in ("kino", "tnt"):
        r = run_kino("train", "--model", model, "--data", tmp_path / "nothing", "--out", tmp_path / model,
                     "--device", "tpu")
        assert r.returncode == 2 and "--device 'tpu'" in r.stderr, r.stderr
        if not torch.cuda.is_available():
            r = run_kino("train", "--model", model, "--data", tmp_path / "nothing", "--out", tmp_path / model,
                         "--device", "cuda")
            assert r.returncode == 2 and "no CUDA device" in r.stderr and "--device cpu" in r.stderr, r.stderr
        assert not (tmp_path / model).exists()


def test_the_learning_rate_is_held_or_decays_along_half_a_cosine_to_zero():
    from vertibench.kino.train import TrainSpec, learning_rate

    held = TrainSpec(data=[], out="", lr=2e-3)
    assert [learning_rate(held, p) for p in (0.0, 0.5, 1.0)] == [2e-3] * 3
    cos = TrainSpec(data=[], out="", lr=2e-3, lr_decay="cosine")
    assert learning_rate(cos, 0.0) == 2e-3
    assert abs(learning_rate(cos, 0.5) - 1e-3) < 1e-12 and abs(learning_rate(cos, 0.25) - 1e-3 * (1 + 0.5**0.5)) < 1e-12
    assert learning_rate(cos, 1.0) < 1e-18 and learning_rate(cos, 1.5) < 1e-18
    with pytest.raises(ValueError, match="lr_decay='step'"):
        learning_rate(TrainSpec(data=[], out="", lr_decay="step"), 0.5)


def test_samples_follow_the_episode_frames():
    e = kd.Episode(1, "low", np.cumsum(np.ones((13, 6)) * 0.1, axis=0), np.linspace(0, 1, 13), np.ones((12, 3)))
    i, b = kd.step_indices(len(e.poses))
    assert list(i) == list(range(13 - kd.STEP)) and list(b[:kd.STEP]) == list(range(kd.STEP))
    assert list(b[kd.STEP:]) == list(range(13 - 2 * kd.STEP))
    assert np.allclose(kd.mean_actions(e.actions, i), 1.0)


def test_tal_inputs_and_the_rust_attentive_forward_pass_equal_torchs(tmp_path):
    maker = _core.KinoData(vb.default_task_set(), "hmmwv", 1.0)
    anchor = poses_on(maker, 17, n=24, seed=4)
    now = anchor.copy()
    now[:, 0] += 3.0 * np.cos(anchor[:, 5])
    now[:, 1] += 3.0 * np.sin(anchor[:, 5])
    now[:, 5] += 0.2
    m, off = maker.tal_inputs(17, anchor, now)
    assert m.shape == (24, 32, 32) and off.shape == (24, 5) and m.dtype == off.dtype == np.float32
    # 3 m straight ahead of the anchor (/ 8 m), turned by 0.2 rad.
    assert np.allclose(off[:, 0], 3.0 / 8.0, atol=1e-6) and np.allclose(off[:, 1], 0.0, atol=1e-6)
    assert np.allclose(off[:, 3], np.sin(0.2), atol=1e-6) and np.allclose(off[:, 4], np.cos(0.2), atol=1e-6)
    m2, _ = maker.tal_inputs(17, anchor, anchor)
    assert np.array_equal(m, m2), "the map depends on the anchor only"

    torch.manual_seed(5)
    model = km.TalModel(members=3, hidden=24).eval()
    path = tmp_path / "t.safetensors"
    km.save(model, path, {"name": "t"})
    vec = np.random.default_rng(1).uniform(-2, 2, (24, 16)).astype(np.float32)
    net = _core.TalNet(str(path))
    assert net.metadata["format"] == _core.TAL_LAYOUT and net.metadata["map"] == _core.TAL_MAP_META
    got = net.predict(vec, m, off)
    with torch.no_grad():
        want = model(*(torch.from_numpy(x) for x in (vec, m, off))).numpy()
    assert got.shape == want.shape == (24, 3, 7)
    assert np.max(np.abs(got - want)) < 1e-5
    assert isinstance(km.load(path), km.TalModel)
    # Each reader refuses the other layout, saying which to use.
    with pytest.raises(ValueError, match="KinoNet"):
        _core.TalNet(_kino_file(tmp_path))
    with pytest.raises(ValueError, match="TalNet"):
        _core.KinoNet(str(path))


def _kino_file(tmp_path) -> str:
    p = tmp_path / "k.safetensors"
    km.save(km.KinoModel(members=1, hidden=8), p, {})
    return str(p)


def test_tal_samples_anchor_the_map_up_to_a_rollout_before_the_step(kino_data):
    train = vb.tasks.training()
    _, eps = kd.episodes(kino_data / "random")
    maker = _core.KinoData(str(train), "hmmwv", 1.0)
    s = kd.samples(eps[:3], maker, 1, "tal", np.random.default_rng(0))
    k = kd.samples(eps[:3], maker, 1, "kino")
    assert s.crop.shape[1:] == (32, 32) and s.offset.shape == (len(s), 5) and k.offset is None
    assert np.array_equal(s.vec, k.vec) and np.array_equal(s.target, k.target)
    # Recover each sample's anchor from its offset: within ANCHOR_STEPS model steps before it, never before frame 0.
    reach = int(_core.TAL_ANCHOR_STEPS) * kd.STEP
    for row in range(0, len(s), 7):
        e = eps[s.episode[row]]
        i = s.frame[row]
        cands = [a for a in range(max(i - reach + 1, 0), i + 1)
                 if np.allclose(maker.tal_inputs(e.world_id, e.poses[a:a + 1], e.poses[i:i + 1])[1][0],
                                s.offset[row], atol=1e-6)]
        assert cands, f"sample {row}: no anchor within a rollout before frame {i}"
    assert len(np.unique(s.offset[:, 0])) > 1, "the anchors vary"


def test_tal_trains_by_one_command_and_its_weights_run_in_rust_and_in_the_report(kino_data, tmp_path):
    out = tmp_path / "tal"
    data = [kino_data / "random", kino_data / "expert"]
    r = run_kino("train", "--model", "tal", "--data", *data, "--out", out, "--epochs", 1, "--members", 2,
                 "--hidden", 16)
    assert r.returncode == 0, r.stderr
    card = json.loads((out / "card.json").read_text())
    assert card["model"] == "tal" and card["layout"] == _core.TAL_LAYOUT and card["name"] == "tal"
    assert "vertibench-tal-v1" in (out / "card.md").read_text()
    net = _core.TalNet(str(out / "tal.safetensors"))
    assert net.metadata["offsets"] == ",".join(_core.TAL_OFFSETS)
    # The cached samples are the tal kind's; asking for the crop model makes them anew.
    assert json.loads((out / "data.json").read_text())["model"] == "tal"
    r = run_kino("report", "--weights", out / "tal.safetensors", "--data", *data, "--out", tmp_path / "rep")
    assert r.returncode == 0, r.stderr
    rep = json.loads((tmp_path / "rep" / "accuracy.json").read_text())
    assert any(x["model"] == "learned" and x["horizon_s"] == 5.0 for x in rep["rows"])


def test_traversability_labels_follow_the_frames_and_poses_land_in_the_maps_grid():
    from vertibench.kino import trav as tv

    fps, n = 20.0, 120  # 3 s driving at 2 m/s, then 3 s standing at full throttle
    x = np.concatenate([np.arange(60) * 0.1, np.full(61, 5.9)])
    poses = np.zeros((n + 1, 6))
    poses[:, 0] = x
    poses[:, 3] = np.where(np.arange(n + 1) == 30, np.radians(15.0), 0.0)  # one frame rolled 15 degrees
    act = np.tile([0.0, 1.0, 0.0], (n, 1))
    e = kd.Episode(1, "low", poses, np.zeros(n + 1), act, None, "stuck", np.full(n, 0.25))
    lab, valid = tv.frame_labels(e, fps, 1.0)
    assert lab.shape == (n, 5) and valid.all(), "a stuck end labels the frames whose window runs past it"
    roll, stuck = lab[:, 0], lab[:, 3]
    assert np.allclose(roll[:31], 0.5) and np.all(roll[31:] == 0), "frame 30 is in the windows of frames 0-30"
    assert np.allclose(lab[:, 2], 0.25) and np.all(lab[:, 4] == 0)
    assert stuck[0] == 0 and stuck[60] == 1 and stuck[119] == 1
    e.outcome = "off_map"
    assert not tv.frame_labels(e, fps, 1.0)[1][-1], "an off-map end leaves the last frames unlabelled"
    e.outcome = "rollover"
    lab, _ = tv.frame_labels(e, fps, 1.0)
    assert lab[-1, 4] == 1 and lab[-40, 4] == 1 and lab[-41, 4] == 0, "no lean past 30 deg: the end is the tip"
    e.poses[70:, 3] = np.radians(40.0)  # tips at frame 70 and stays leaning until the stuck rule ends it
    e.poses[90, 3] = np.radians(-35.0)  # a lean to the other side is still a lean past the threshold
    assert tv.tip_frame(e) == 70
    lab, _ = tv.frame_labels(e, fps, 1.0)
    assert np.all(lab[30:, 4] == 1) and np.all(lab[:30, 4] == 0), "frames whose 2 s window reaches the tip"
    e.poses[100, 3] = 0.0  # upright again at frame 100: the final lean starts at 101
    assert tv.tip_frame(e) == 101 and tv.frame_labels(e, fps, 1.0)[0][60, 4] == 0
    e.outcome = "stuck"
    assert tv.tip_frame(e) is None and np.all(tv.frame_labels(e, fps, 1.0)[0][:, 4] == 0)
    anchor = np.array([10.0, 20.0, 0.0, 0.0, 0.0, np.pi / 2])
    poses = np.array([[9.5, 25.5, 0, 0, 0, np.pi / 2],    # 5.5 m ahead, 0.5 m left, same heading
                      [7.5, 20.5, 0, 0, 0, np.pi],        # 0.5 m ahead, 2.5 m left, turned left
                      [10.0, 16.0, 0, 0, 0, np.pi / 2]])  # 4 m behind: outside
    idx, inside = tv.grid_index(anchor, poses, 1.0)
    assert list(inside) == [True, True, False]
    assert idx[0] == 0 * 256 + 7 * 16 + 7 and idx[1] == 1 * 256 + 12 * 16 + 5


def test_roc_auc_is_mann_whitneys_u_with_ties_counting_half():
    from vertibench.kino.trav_train import roc_auc

    score = np.array([0.1, 0.4, 0.35, 0.8])
    assert roc_auc(score, np.array([False, False, True, True])) == 0.75  # 3 of the 4 pairs ordered
    assert roc_auc(np.array([0.5, 0.5, 0.2]), np.array([True, False, False])) == 0.75  # a tie counts half
    assert roc_auc(score, np.array([True, True, False, False])) == 0.25
    assert roc_auc(score, np.zeros(4, bool)) is None and roc_auc(score, np.ones(4, bool)) is None


def test_the_held_out_report_ranks_each_event_by_its_channel_and_by_its_baseline_channel():
    import torch
    from vertibench.kino import trav as tv
    from vertibench.kino.trav_train import evaluate

    # Two anchors, each with three labelled cells; the "model" predicts each cell's roll label in the roll channel
    # and the opposite of its rollover label in the rollover channel.
    cells = np.array([0, 1, 2, 3, 4, 5], np.int64)
    label = np.zeros((6, len(tv.CHANNELS)), np.float32)
    ri, rr = tv.CHANNELS.index("roll"), tv.CHANNELS.index("rollover")
    label[:, rr] = [1, 0, 0, 1, 0, 0]
    label[:, ri] = [0.9, 0.1, 0.2, 0.8, 0.3, 0.1]
    s = tv.TravSamples(np.zeros((2, 32, 32), np.float32), np.zeros(2, np.int64), np.array([0, 3, 6]), cells, label)

    class Fixed(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.w = torch.nn.Parameter(torch.zeros(1))

        def forward(self, m):
            out = torch.full((len(m), tv.HEADINGS, len(tv.CHANNELS), tv.GRID, tv.GRID), 0.5)
            flat = out.permute(0, 1, 3, 4, 2).reshape(len(m), -1, len(tv.CHANNELS))
            for k, c in enumerate(cells):
                flat[k // 3, c, ri] = float(label[k, ri])
                flat[k // 3, c, rr] = 1.0 - float(label[k, rr])
            return flat.reshape(len(m), tv.HEADINGS, tv.GRID, tv.GRID, len(tv.CHANNELS)).permute(0, 1, 4, 2, 3)

    h = evaluate(Fixed(), s, np.array([0, 1]))
    assert h["positives_rollover"] == 2
    assert h["auc_rollover"] == 0.0 and h["auc_rollover_by_roll"] == 1.0
    assert h["auc_stuck"] is None and h["auc_stuck_by_slip"] is None  # no stuck cell


def test_tnt_trains_resumes_and_writes_weights_with_a_card(kino_data, tmp_path):
    from vertibench.kino import trav as tv

    out = tmp_path / "tnt"
    data = [kino_data / "random", kino_data / "expert"]
    r = run_kino("train", "--model", "tnt", "--data", *data, "--out", out, "--epochs", 1, "--batch", 64)
    assert r.returncode == 0, r.stderr
    r = run_kino("train", "--model", "tnt", "--data", *data, "--out", out, "--epochs", 2, "--batch", 64)
    assert r.returncode == 0, r.stderr
    assert "resumed at epoch 1" in r.stdout
    for f in ("tnt.safetensors", "card.md", "card.json", "curve.csv", "checkpoint.pt"):
        assert (out / f).exists(), f
    card = json.loads((out / "card.json").read_text())
    assert card["epochs"] == 2 and card["labelled_cells"] > 0 and card["heldout_anchors"] > 0
    assert all(0 <= card["heldout"][f"mae_{c}"] <= 1 for c in tv.CHANNELS)
    assert card["labels_version"] == tv.LABELS_VERSION and "ROC AUC" in (out / "card.md").read_text()
    aucs = [card["heldout"][f"auc_{c}"] for c in ("stuck", "rollover", "stuck_by_slip", "rollover_by_roll")]
    assert all(a is None or 0 <= a <= 1 for a in aucs)
    from safetensors import safe_open

    with safe_open(str(out / "tnt.safetensors"), framework="np") as f:
        assert f.metadata()["format"] == tv.LAYOUT and f.metadata()["channels"] == ",".join(tv.CHANNELS)
        assert f.get_tensor("out.weight").shape == (tv.HEADINGS * len(tv.CHANNELS), 16, 1, 1)


def test_the_rust_traversability_estimator_equals_torchs_and_looks_poses_up_as_the_trainer(tmp_path):
    from safetensors.torch import save_file

    from vertibench.kino import trav as tv

    torch.manual_seed(5)
    net = tv.model(16).eval()
    path = tmp_path / "t.safetensors"
    tv.save(net, path, {"name": "t"})
    maps = np.random.default_rng(1).uniform(-2, 2, (8, 32, 32)).astype(np.float32)
    got = _core.TravNet(str(path)).estimate(maps)
    with torch.no_grad():
        want = net(torch.from_numpy(maps)).numpy()
    assert got.shape == want.shape == (8, tv.HEADINGS, len(tv.CHANNELS), 16, 16)
    assert np.max(np.abs(got - want)) < 1e-5
    tensors = {k: v.detach().contiguous() for k, v in net.state_dict().items()}
    save_file(tensors, str(tmp_path / "bad.safetensors"), metadata={"format": tv.LAYOUT, "channels": "a,b"})
    with pytest.raises(ValueError, match="channels"):
        _core.TravNet(str(tmp_path / "bad.safetensors"))
    rng = np.random.default_rng(2)
    for scale in (1.0, 0.1):
        anchor = np.array([3.0, -7.0, 1.0, 0.1, -0.1, 2.5])
        poses = np.tile(anchor, (500, 1))
        poses[:, :2] += rng.uniform(-20, 20, (500, 2)) * scale
        poses[:, 5] = rng.uniform(-np.pi, np.pi, 500)
        idx, inside = tv.grid_index(anchor, poses, scale)
        assert inside.sum() > 50
        assert np.array_equal(np.where(inside, idx, -1), _core.tnt_grid_index(anchor, poses, scale))
