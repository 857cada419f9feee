"""A training's outputs besides the weights: ``curve.csv``, ``curve.png`` (matplotlib, Agg) and the card
(``card.json``, ``card.md``): configuration, seed, task-set version, steps, wall time, throughput and where the
time went."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

from . import curriculum as cur

if TYPE_CHECKING:
    from .loop import Trainer

CURVE_FIELDS: tuple[str, ...] = (
    "steps", "wall_s", "success", "return", "eval_episodes", "episodes", "train_success", "curriculum", "stage",
    "gate_success", "levels_seen", "score_mean", "pg_loss", "v_loss", "entropy", "approx_kl", "clip_frac",
)


def write_curve_csv(rows: list[dict[str, Any]], path: Path) -> None:
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(CURVE_FIELDS), extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in CURVE_FIELDS})


def plot_curve(rows: list[dict[str, Any]], path: Path, title: str,
               stage_marks: list[tuple[int, str]] | None = None) -> None:
    """Held-out success rate and mean return against steps, with vertical marks where MCL's stages began."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps = [r["steps"] for r in rows]
    plr = any("levels_seen" in r for r in rows)
    fig, axes = plt.subplots(3 if plr else 2, 1, figsize=(7, 7.5 if plr else 5.5), sharex=True)
    a1, a2 = axes[0], axes[1]
    a1.plot(steps, [r["success"] for r in rows], marker=".", label="held-out success")
    if any("gate_success" in r for r in rows):
        a1.plot(steps, [r.get("gate_success", float("nan")) for r in rows], marker=".", ls="--",
                label="stage gate success")
    a1.set_ylabel("success rate")
    a1.set_ylim(-0.02, 1.02)
    a2.plot(steps, [r["return"] for r in rows], marker=".", color="C2")
    a2.set_ylabel("held-out mean return")
    if plr:
        a3 = axes[2]
        a3.plot(steps, [r.get("levels_seen", 0) for r in rows], marker=".", color="C3")
        a3.set_ylabel("levels seen", color="C3")
        b3 = a3.twinx()
        b3.plot(steps, [r.get("score_mean", 0.0) for r in rows], marker=".", color="C4")
        b3.set_ylabel("mean level score", color="C4")
    axes[-1].set_xlabel("environment steps")
    for step, label in stage_marks or []:
        for ax in (a1, a2):
            ax.axvline(step, color="grey", ls=":", lw=1)
        a1.annotate(label, (step, 1.0), fontsize=7, rotation=90, va="top", ha="right")
    a1.legend(loc="upper left", fontsize=8)
    a1.set_title(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def write_all(tr: "Trainer", meta: dict[str, Any]) -> dict[str, Any]:
    """Writes the curve and the card of a finished training and returns the card."""
    spec, out = tr.spec, tr.out
    write_curve_csv(tr.curve, out / "curve.csv")
    marks: list[tuple[int, str]] = []
    stages: list[dict[str, Any]] = []
    if isinstance(tr.curriculum, cur.Manual):
        for r in tr.curriculum.records:
            stages.append(dict(r.__dict__, selection=cur.MCL_STAGES[r.stage],
                               threshold=cur.MCL_THRESHOLDS[r.stage],
                               held_out_tasks=len(tr.stage_held_out[r.stage])))
            marks.append((r.start_step, f"stage {r.stage + 1}"))
    plot_curve(tr.curve, out / "curve.png", f"{spec.system}: seed {spec.seed}, {tr.step:,} steps", marks)
    train_s = sum(v for k, v in tr.times.items() if k != "eval")
    times = {k: round(v, 2) for k, v in sorted(tr.times.items())}
    times["other"] = round(max(0.0, tr.wall - sum(tr.times.values())), 2)
    last = tr.curve[-1] if tr.curve else {}
    card: dict[str, Any] = {
        "name": spec.system,
        "curriculum": meta["curriculum"],
        "command": spec.command,
        "seed": spec.seed,
        # The default set by the call that makes it, not by this machine's cache path.
        "task_set": str(tr.task_set) if spec.task_set is not None else "vertibench.tasks.training()",
        "task_set_seed": tr.info.seed,
        "task_set_version": tr.info.version,
        "train_tasks": len(tr.split.train),
        "held_out_tasks": len(tr.split.held_out),
        "steps": tr.step,
        "budget": spec.steps,
        "updates": tr.updates,
        "episodes": tr.episodes,
        "wall_s": round(tr.wall, 1),
        "steps_per_s": round(tr.step / tr.wall, 1) if tr.wall > 0 else None,
        "steps_per_s_training": round(tr.step / train_s, 1) if train_s > 0 else None,
        "time_s": times,
        "final_held_out_success": last.get("success"),
        "final_held_out_return": last.get("return"),
        "control_rate_hz": spec.control_rate_hz,
        "vehicle": spec.vehicle,
        "sim_version": meta["sim_version"],
        "ppo": spec.ppo.to_dict(),
        "eval": {"episodes": spec.eval_episodes, "every_updates": spec.eval_every,
                 "gate_episodes": spec.gate_episodes},
        "torch_threads": spec.threads,
    }
    if stages:
        card["mcl_stages"] = stages
    if isinstance(tr.curriculum, cur.PLR):
        p = tr.curriculum
        card["plr"] = {"temperature": p.temperature, "staleness": p.staleness, "replay_prob": p.replay_prob,
                       "min_seen": p.min_seen, "summary": p.summary()}
    (out / "card.json").write_text(json.dumps(card, indent=1) + "\n")
    (out / "card.md").write_text(card_markdown(card))
    return card


def _seed(seed: int | None) -> str:
    return "" if seed is None else f" (seed {seed})"


def card_markdown(c: dict[str, Any]) -> str:
    """The card as Markdown."""
    lines = [
        f"# {c['name']}: end-to-end learned baseline ({c['curriculum']} curriculum)",
        "",
        f"- command: `{c['command']}`",
        f"- task set: `{c['task_set']}`{_seed(c.get('task_set_seed'))} (version `{c['task_set_version']}`): "
        f"{c['train_tasks']} training tasks, "
        f"{c['held_out_tasks']} held out (worlds 9 mod 10)",
        f"- seed {c['seed']}; {c['steps']:,} steps ({c['updates']} updates, {c['episodes']:,} episodes) of a "
        f"{c['budget']:,}-step budget",
        f"- wall time {c['wall_s']} s: {c['steps_per_s']} steps/s overall, {c['steps_per_s_training']} steps/s "
        "in rollouts and updates (evaluations excluded)",
        f"- final held-out success {c['final_held_out_success']}, mean return {c['final_held_out_return']}",
        f"- vehicle {c['vehicle']} at {c['control_rate_hz']} Hz; simulator {c['sim_version']}",
        "",
        "## Where the time went (s)",
        "",
        "| part | s |",
        "|---|---|",
        *[f"| {k} | {v} |" for k, v in c["time_s"].items()],
        "",
        "## PPO",
        "",
        "| setting | value |",
        "|---|---|",
        *[f"| {k} | {v} |" for k, v in c["ppo"].items()],
        "",
    ]
    if "mcl_stages" in c:
        lines += ["## MCL stages", "", "Gates: deterministic episodes on every held-out task of the stage, each "
                  "equally often, at least the gate's episode count in all.", "",
                  "| stage | tasks | held-out tasks | threshold | start | end | last gate | ended |",
                  "|---|---|---|---|---|---|---|---|"]
        for s in c["mcl_stages"]:
            gate = "" if s["success"] is None else f"{s['success']:.2f} on {s['episodes']}"
            lines.append(f"| {s['stage'] + 1} | `{s['selection']}` | {s['held_out_tasks']} | {s['threshold']} | "
                         f"{s['start_step']:,} | "
                         f"{'' if s['end_step'] is None else format(s['end_step'], ',')} | {gate} | {s['ended']} |")
        forced = [s for s in c["mcl_stages"] if s["ended"] == "forced"]
        if forced:
            lines += ["", f"{len(forced)} stage(s) did not pass their gate within their share of the budget and "
                      "advanced anyway (ended `forced`)."]
        lines.append("")
    if "plr" in c:
        p = c["plr"]
        lines += ["## PLR", "", f"temperature {p['temperature']}, staleness {p['staleness']}, replay probability "
                  f"{p['replay_prob']}, unseen levels first until {p['min_seen']:.0%} seen; {p['summary']}", ""]
    return "\n".join(lines)
