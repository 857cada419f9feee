"""What a kinodynamic model is worth: its card, its learning curve, and the open-loop accuracy report
(``python -m vertibench.kino report``): from start frames of held-out episodes, the model is rolled out over 1, 2
and 5 s with the recorded actions (each model step from its own predicted pose, crop and previous change of pose)
and compared with the recorded poses; beside it, the planar kinematic bicycle MPPI uses today (the vehicle's
wheelbase and steering range, the speed measured at the start held, no change of z, roll or pitch) and our simulator
itself restarted from the recorded observation (``KinoData.simulate``: the chassis state observed, wheels rolling,
suspension settled, soil undeformed; what a planner that sees only the observation could roll out: the bound a
learned model approaches). Errors: the horizontal position, |z|, |roll|, |pitch| and |yaw| at the horizon, by ground
under the start and elevation level."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .. import _core
from . import data as kd

HORIZONS_S = (1.0, 2.0, 5.0)
GROUNDS = ("rigid", "mud", "sand", "snow")
ERRORS = ("position_m", "z_m", "roll_deg", "pitch_deg", "yaw_deg")


def _kind(d: dict) -> str:
    """A dataset's kind, with a random one's speed profile when it is not the paper's constant one."""
    profile = d.get("speed_profile", "constant")
    return d["kind"] if profile == "constant" else f"{d['kind']} ({profile.replace('_', '-')})"


def write_card(card: dict, path: Path) -> None:
    lines = [f"# {card['name']}: learned kinodynamic model ({card.get('layout', 'vertibench-kino-v1')})", "",
             f"- command: `{card['command']}`",
             f"- data: " + "; ".join(f"{_kind(d)} {d['episodes']} episodes, {d['samples']} samples (seed "
                                     f"{d['seed']})" for d in card["data"]),
             f"- task set version {card['task_set_version']} (training worlds only; worlds 9 mod 10 held out), "
             f"simulator {card['sim_version']}, vehicle {card['vehicle']} at scale {card['scale']}",
             f"- seed {card['seed']}, {card['epochs']} epochs (learning rate {card['lr']:g}, "
             f"{card.get('lr_decay', 'none')} decay), {card['members']} members x {card['hidden']} "
             f"hidden, {card['parameters']} parameters; {card['train_s']} s training on "
             f"{card.get('device', 'cpu')}, {card['data_s']} s making samples",
             "", "## Held-out one-step error (RMSE of the ensemble mean, physical units)", "",
             "| target | RMSE |", "|---|---|"]
    for k, v in card["heldout_rmse_one_step"].items():
        unit = "m" if k in ("forward", "left", "up") else ("rad" if k != "steering" else "")
        lines.append(f"| {k} | {v:.4f} {unit} |")
    path.write_text("\n".join(lines) + "\n")


def plot_curve(curve: list[dict], path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    ep = [r["epoch"] for r in curve]
    for k in _core.KINO_TARGETS:
        ax.plot(ep, [r[f"heldout_rmse_{k}"] for r in curve], marker=".", label=k)
    ax.set_xlabel("epoch")
    ax.set_ylabel("held-out RMSE (scaled)")
    ax.set_yscale("log")
    ax.set_title(f"{title}: held-out one-step error")
    ax.legend(ncol=4, fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _wrap(a: np.ndarray) -> np.ndarray:
    return np.arctan2(np.sin(a), np.cos(a))


def _errors(pred: np.ndarray, true: np.ndarray) -> np.ndarray:
    """[n, 5]: horizontal position (m), |z| (m), |roll|, |pitch|, |yaw| (deg)."""
    return np.stack([np.hypot(*(pred[:, :2] - true[:, :2]).T), np.abs(pred[:, 2] - true[:, 2]),
                     *(np.degrees(np.abs(_wrap(pred[:, j] - true[:, j]))) for j in (3, 4, 5))], axis=1)


def rollout_model(predict, maker, e: kd.Episode, starts: np.ndarray, steps: int,
                  attention: bool = False) -> np.ndarray:
    """Poses ``[len(starts), 6]`` after ``steps`` model steps from each start, with the recorded actions. A
    terrain-attentive model (``attention``) takes a new map every ``TAL_ANCHOR_STEPS`` steps, at the predicted pose,
    as the planner does once per decision."""
    S = kd.STEP
    now = e.poses[starts].copy()
    before = e.poses[np.where(starts >= S, starts - S, starts)].copy()
    steer = e.steering[starts].copy()
    anchor = now
    for j in range(steps):
        act = kd.mean_actions(e.actions, starts + j * S)
        vec, crop = maker.features(e.world_id, before, now, steer, act)
        if attention:
            if j % int(_core.TAL_ANCHOR_STEPS) == 0:
                anchor = now.copy()
            pred = predict(vec, *maker.tal_inputs(e.world_id, anchor, now))
        else:
            pred = predict(vec, crop)
        after = maker.apply(now, pred)
        before, now, steer = now, after, pred[:, 6].astype(np.float64)
    return now


def rollout_bicycle(vehicle: dict, e: kd.Episode, starts: np.ndarray, frames: int, fps: float) -> np.ndarray:
    """The planar bicycle: x, y, yaw from the recorded steering commands at the start's speed."""
    p = e.poses[starts].copy()
    dt = 1.0 / fps
    v = np.hypot(*(e.poses[starts + 1, :2] - e.poses[starts, :2]).T) / dt
    L, smax = float(vehicle["wheelbase"]), float(vehicle["max_steer"])
    for k in range(frames):
        u = e.actions[starts + k, 0]
        p[:, 5] += v / L * np.tan(u * smax) * dt
        p[:, 0] += v * np.cos(p[:, 5]) * dt
        p[:, 1] += v * np.sin(p[:, 5]) * dt
    return p


def rollout_simulator(maker, e: kd.Episode, starts: np.ndarray, frames: int, fps: float) -> np.ndarray:
    """Our simulator from the recorded observation at each start, driven with the recorded actions."""
    acts = np.stack([e.actions[s:s + frames] for s in starts])
    return maker.simulate(e.world_id, e.states[starts], acts, fps)


def accuracy(weights: str | Path, data: list[str], task_set: str | None = None, every_s: float = 2.0,
             backend: str = "rust", simulator: bool = True) -> dict:
    """The open-loop report on the held-out episodes of ``data``: ``{"rows": [...], "reduction_vs_bicycle": ...,
    "simulator_reduction_vs_bicycle": ...}``, one row per (model, horizon, ground, level) with the mean errors and
    the count; models ``learned``, ``bicycle`` and (with ``simulator``) ``simulator``."""
    from safetensors import safe_open

    with safe_open(str(weights), framework="np") as f:
        attention = (f.metadata() or {}).get("format") == _core.TAL_LAYOUT
    if backend == "rust":
        net = (_core.TalNet if attention else _core.KinoNet)(str(weights))

        def predict(*inputs):
            return net.predict(*inputs).mean(1)
    else:
        import torch

        from .model import load

        m = load(weights)

        def predict(*inputs):
            with torch.no_grad():
                return m(*(torch.from_numpy(x) for x in inputs)).mean(1).numpy()
    records: list[tuple[str, float, str, str, np.ndarray]] = []
    maker = None
    for d in data:
        spec, eps = kd.episodes(d, task_set)
        fps = float(spec["control_rate_hz"])
        if maker is None:
            from .. import datasets as vbd

            maker = _core.KinoData(str(task_set or vbd._find_task_set(spec)), spec["vehicle"], float(spec["scale"]))
        every = max(int(round(every_s * fps)), 1)
        for e in eps:
            if e.world_id % 10 != kd.HELD_OUT:
                continue
            for h in HORIZONS_S:
                steps = int(round(h * fps / kd.STEP))
                frames = steps * kd.STEP
                starts = np.arange(0, len(e.poses) - frames - 1, every)
                if len(starts) == 0:
                    continue
                true = e.poses[starts + frames]
                g = maker.features(e.world_id, e.poses[starts], e.poses[starts], e.steering[starts],
                                   np.zeros((len(starts), 3)))[0][:, 12:16]
                ground = np.where(g[:, 0] > 0, 0, 1 + np.argmax(g[:, 1:], axis=1))
                models = [("learned", lambda: rollout_model(predict, maker, e, starts, steps, attention)),
                          ("bicycle", lambda: rollout_bicycle(maker.vehicle, e, starts, frames, fps))]
                if simulator:
                    models.append(("simulator", lambda: rollout_simulator(maker, e, starts, frames, fps)))
                for name, roll in models:
                    pred = roll()
                    err = _errors(pred, true)
                    for gi in np.unique(ground):
                        records.append((name, h, GROUNDS[gi], e.level, err[ground == gi]))
    return summarise(records)


def summarise(records) -> dict:
    rows = []
    keys = sorted({(r[0], r[1]) for r in records})
    for model, h in keys:
        sel = [r for r in records if r[0] == model and r[1] == h]
        for group, pick in [("all", lambda r: True)] + \
                [(f"ground={g}", (lambda g: lambda r: r[2] == g)(g)) for g in GROUNDS] + \
                [(f"level={lv}", (lambda lv: lambda r: r[3] == lv)(lv)) for lv in ("low", "medium", "high")]:
            errs = [r[4] for r in sel if pick(r)]
            if not errs:
                continue
            e = np.concatenate(errs)
            rows.append({"model": model, "horizon_s": h, "group": group, "n": int(len(e)),
                         **{k: float(v) for k, v in zip(ERRORS, e.mean(0))}})
    return {"rows": rows, "reduction_vs_bicycle": _reduction(rows, "learned"),
            "simulator_reduction_vs_bicycle": _reduction(rows, "simulator")}


def _reduction(rows: list[dict], model: str) -> dict:
    """``1 - model / bicycle`` of each mean error over all starts, by horizon."""
    out = {}
    for h in HORIZONS_S:
        a = {r["model"]: r for r in rows if r["horizon_s"] == h and r["group"] == "all"}
        if model in a and "bicycle" in a:
            out[f"{h:g}s"] = {k: 1.0 - a[model][k] / max(a["bicycle"][k], 1e-12) for k in ERRORS}
    return out


def markdown(report: dict) -> str:
    lines = ["| model | horizon | group | n | " + " | ".join(ERRORS) + " |", "|---" * (4 + len(ERRORS)) + "|"]
    for r in report["rows"]:
        lines.append(f"| {r['model']} | {r['horizon_s']:g} s | {r['group']} | {r['n']} | "
                     + " | ".join(f"{r[k]:.3f}" for k in ERRORS) + " |")
    for model, key in (("learned model", "reduction_vs_bicycle"), ("simulator", "simulator_reduction_vs_bicycle")):
        if not report.get(key):
            continue
        lines += ["", f"Error reduction of the {model} against the bicycle (1 - {model.split()[0]} / bicycle):", "",
                  "| horizon | " + " | ".join(ERRORS) + " |", "|---" * (1 + len(ERRORS)) + "|"]
        for h, v in report[key].items():
            lines.append(f"| {h} | " + " | ".join(f"{100 * v[k]:.0f}%" for k in ERRORS) + " |")
    return "\n".join(lines) + "\n"


def write(report: dict, out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / "accuracy.json").write_text(json.dumps(report, indent=1))
    (out / "accuracy.md").write_text(markdown(report))
