"""The training loop shared by RL, MCL and ACL: rollouts on the training tasks (each environment's next task chosen
by the curriculum), PPO updates, held-out evaluations, checkpoints (resumable) and the final export."""

from __future__ import annotations

import os
import sys
import time
from collections import defaultdict
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch

from .. import SIM_VERSION
from . import curriculum as cur
from . import report
from .policy import ActorCritic
from .ppo import PPOConfig, ReturnStd, Rollout, update
from .worlds import Inputs, Split, TrainError, check_task_set, env_action, evaluate, make_env, select

SYSTEMS: tuple[str, ...] = ("rl", "mcl", "acl")
CHECKPOINT = "checkpoint.pt"


@dataclass
class RunSpec:
    """What a training is: the system, its data, budget and seed (a checkpoint resumes only the same spec)."""

    system: str
    task_set: str
    out: str
    steps: int
    seed: int = 0
    eval_episodes: int = 100
    eval_every: int = 50
    gate_episodes: int = 50
    checkpoint_every: int = 10
    control_rate_hz: float = 20.0
    vehicle: str = "hmmwv"
    threads: int = 1
    command: str = ""
    ppo: PPOConfig = field(default_factory=PPOConfig)

    def identity(self) -> dict[str, Any]:
        """The settings a resumed run must share with its checkpoint."""
        d = asdict(self)
        for k in ("out", "steps", "command", "threads", "task_set"):
            d.pop(k)
        return d


class Trainer:
    """One training run; :meth:`run` trains to ``spec.steps`` (resuming from ``out/checkpoint.pt`` if there)."""

    def __init__(self, spec: RunSpec, resume: bool = False) -> None:
        if spec.system not in SYSTEMS:
            raise TrainError(f"unknown system {spec.system!r}: one of {', '.join(SYSTEMS)}")
        self.spec, self.cfg = spec, spec.ppo
        self.info = check_task_set(spec.task_set)
        self.task_set = Path(self.info.path)
        self.out = Path(spec.out)
        self.out.mkdir(parents=True, exist_ok=True)
        torch.set_num_threads(1)
        torch.manual_seed(spec.seed)
        self.rng = np.random.default_rng(spec.seed)
        self.split = Split.of(select(self.task_set, "all"))
        self.model = ActorCritic(self.cfg.hidden)
        self.opt = torch.optim.Adam(self.model.parameters(), lr=self.cfg.lr, eps=1e-5)
        self.curriculum = self._curriculum()
        self.retstd = ReturnStd(self.cfg.envs, self.cfg.gamma)
        self.step = self.updates = self.episodes = 0
        self.wall = 0.0
        self.times: dict[str, float] = defaultdict(float)
        self.curve: list[dict[str, Any]] = []
        self.recent: list[bool] = []
        ck = self.out / CHECKPOINT
        if ck.exists():
            self._load(ck)
        elif resume:
            raise TrainError(f"--resume: no checkpoint in {self.out}")

    # --- setup ---------------------------------------------------------------------------------------------------
    def _curriculum(self) -> cur.Uniform | cur.Manual | cur.PLR:
        n = len(self.split.train)
        if self.spec.system == "rl":
            return cur.Uniform(n)
        if self.spec.system == "acl":
            return cur.PLR(n)
        index = {t: i for i, t in enumerate(self.split.train)}
        stages, self.stage_held_out = [], []
        for spec in cur.MCL_STAGES:
            ids = select(self.task_set, spec)
            stages.append([index[t] for t in ids if t in index])
            held = [t for t in ids if t not in index]
            self.stage_held_out.append(held)
            if not held:
                raise TrainError(f"MCL stage {spec!r} has no held-out task in {self.task_set}")
        return cur.Manual(stages, budget=self.spec.steps, min_episodes=self.spec.gate_episodes)

    def _load(self, path: Path) -> None:
        ck = torch.load(path, map_location="cpu", weights_only=False)
        if ck["identity"] != self.spec.identity() or ck["task_set_version"] != self.info.version:
            raise TrainError(f"{path} was written by another training (system, seed, settings or task set differ): "
                             "give another --out or delete it")
        self.model.load_state_dict(ck["model"])
        self.opt.load_state_dict(ck["opt"])
        self.curriculum.load_state_dict(ck["curriculum"])
        if isinstance(self.curriculum, cur.Manual):
            self.curriculum.budget = self.spec.steps
        self.retstd.load_state_dict(ck["retstd"])
        self.rng.bit_generator.state = ck["rng"]
        torch.set_rng_state(ck["torch_rng"])
        self.step, self.updates, self.episodes = ck["step"], ck["updates"], ck["episodes"]
        self.wall, self.curve, self.recent = ck["wall"], ck["curve"], ck["recent"]
        self.times.update(ck["times"])
        print(f"vertibench.train: resuming {self.spec.system} from {path} at step {self.step:,}", file=sys.stderr)

    def _save(self) -> None:
        ck = {
            "identity": self.spec.identity(), "task_set_version": self.info.version, "model": self.model.state_dict(),
            "opt": self.opt.state_dict(), "curriculum": self.curriculum.state_dict(),
            "retstd": self.retstd.state_dict(), "rng": self.rng.bit_generator.state,
            "torch_rng": torch.get_rng_state(), "step": self.step, "updates": self.updates,
            "episodes": self.episodes, "wall": self.wall, "curve": self.curve, "recent": self.recent,
            "times": dict(self.times),
        }
        tmp = self.out / f".{CHECKPOINT}.{os.getpid()}.tmp"
        torch.save(ck, tmp)
        os.replace(tmp, self.out / CHECKPOINT)

    # --- the loop ------------------------------------------------------------------------------------------------
    def run(self) -> dict[str, Any]:
        """Trains to the budget, then exports ``policy.safetensors`` and writes the curve and the card."""
        cfg = self.cfg
        env = make_env(cfg.envs, self.split.train, self.task_set, self.spec.control_rate_hz)
        self.eval_env = make_env(min(cfg.envs, max(self.spec.eval_episodes, self.spec.gate_episodes)),
                                 self.split.held_out, self.task_set, self.spec.control_rate_hz)
        self.inputs = inputs = Inputs(env.vehicle)
        self.vehicle = env.vehicle
        buf = Rollout(cfg.rollout, cfg.envs)
        levels = np.array([self.curriculum.sample(self.rng) for _ in range(cfg.envs)])
        obs, _ = env.reset(seed=self.spec.seed + self.updates * 1_000_003,
                           options={"tasks": [self.split.train[k] for k in levels]})
        thr = np.zeros(cfg.envs)
        self.retstd.ret[:] = 0.0  # every episode starts here, a resumed run's too
        acc = np.zeros((cfg.envs, 2))  # PLR: positive value loss sum and step count of each running episode
        t = self._timer
        start = time.perf_counter() - self.wall
        vec, crop = t("features", lambda: inputs(obs, thr))
        if not self.curve:
            self._evaluate()
        while self.step < self.spec.steps:
            ends: list[tuple[int, int, int]] = []  # (env, rollout step, level)
            for k in range(cfg.rollout):
                t0 = time.perf_counter()
                a_np, logp, value = self.model.sample(vec, crop)
                t1 = time.perf_counter()
                self.times["inference"] += t1 - t0
                act = env_action(a_np)
                obs, r, term, trunc, info = env.step(act)
                self.times["env"] += time.perf_counter() - t1
                thr = act[:, 1].copy()
                done = term | trunc
                rs = np.clip(self.retstd.scale(r, done), -cfg.reward_clip, cfg.reward_clip)
                vec2, crop2 = t("features", lambda: inputs(obs, thr))
                cut = np.flatnonzero(trunc & ~term)
                if cut.size:  # time limit: bootstrap from the value of the final observation
                    with torch.no_grad():
                        v_end = self.model.value(torch.from_numpy(vec2[cut]), torch.from_numpy(crop2[cut]))
                    rs[cut] += cfg.gamma * v_end.numpy()
                buf.vec[k], buf.crop[k], buf.action[k] = vec, crop, a_np
                buf.logp[k], buf.value[k], buf.reward[k], buf.done[k] = logp, value, rs, done
                self.step += cfg.envs
                if done.any():
                    ended = np.flatnonzero(done)
                    picks: list[str | None] = [None] * cfg.envs
                    for i in ended:
                        ends.append((int(i), k, int(levels[i])))
                        self.episodes += 1
                        self.recent = (self.recent + [bool(info["success"][i])])[-200:]
                        levels[i] = self.curriculum.sample(self.rng)
                        picks[i] = self.split.train[levels[i]]
                    thr[done] = 0.0
                    t2 = time.perf_counter()
                    obs, _ = env.reset(options={"reset_mask": done, "tasks": picks})
                    self.times["env_reset"] += time.perf_counter() - t2
                    v_new, c_new = t("features", lambda: inputs(obs, thr, ended))
                    vec2[ended], crop2[ended] = v_new, c_new
                vec, crop = vec2, crop2
            t0 = time.perf_counter()
            with torch.no_grad():
                last_v = self.model.value(torch.from_numpy(vec), torch.from_numpy(crop)).numpy()
            buf.gae(last_v, cfg.gamma, cfg.lam)
            if isinstance(self.curriculum, cur.PLR):
                self._score_levels(buf, ends, acc)
            torch.set_num_threads(self.spec.threads)  # the update uses the cores; rollouts leave them to Rust
            stats = update(self.model, self.opt, buf, cfg, self.rng)
            torch.set_num_threads(1)
            self.times["update"] += time.perf_counter() - t0
            self.updates += 1
            self.wall = time.perf_counter() - start
            last = self.step >= self.spec.steps
            if self.updates % self.spec.eval_every == 0 or last:
                self._evaluate(stats)
                self.wall = time.perf_counter() - start
            if isinstance(self.curriculum, cur.Manual) and self.curriculum.check_deadline(self.step):
                print(f"vertibench.train: mcl stage {self.curriculum.stage} not passed within its budget share; "
                      f"advancing at step {self.step:,}", file=sys.stderr)
            if self.updates % self.spec.checkpoint_every == 0 or last:
                self._save()
        self.wall = time.perf_counter() - start
        self._save()
        env.close()
        self.eval_env.close()
        return self._finish()

    def _timer(self, key: str, fn: Any) -> Any:
        t0 = time.perf_counter()
        out = fn()
        self.times[key] += time.perf_counter() - t0
        return out

    def _score_levels(self, buf: Rollout, ends: list[tuple[int, int, int]], acc: np.ndarray) -> None:
        """PLR: each episode that ended in this rollout scores its level by the mean positive advantage over all
        its steps (running episodes carry their sums into the next rollout)."""
        assert isinstance(self.curriculum, cur.PLR)
        seg = np.zeros(buf.n, dtype=np.int64)
        for i, k, level in ends:
            pos = np.maximum(buf.adv[seg[i]:k + 1, i], 0.0)
            s, c = acc[i, 0] + pos.sum(), acc[i, 1] + pos.size
            self.curriculum.update(level, s / max(c, 1))
            acc[i] = 0.0
            seg[i] = k + 1
        for i in range(buf.n):
            pos = np.maximum(buf.adv[seg[i]:, i], 0.0)
            acc[i, 0] += pos.sum()
            acc[i, 1] += pos.size

    def _evaluate(self, stats: dict[str, float] | None = None) -> None:
        t0 = time.perf_counter()
        held = self.split.held_out
        tasks = [held[j % len(held)] for j in range(self.spec.eval_episodes)]
        ev = evaluate(self.model, self.eval_env, self.inputs, tasks)
        row: dict[str, Any] = {
            "steps": self.step, "wall_s": round(self.wall, 2), "success": ev["success"], "return": ev["return"],
            "eval_episodes": int(ev["episodes"]), "episodes": self.episodes,
            "train_success": float(np.mean(self.recent)) if self.recent else float("nan"),
            "curriculum": self.curriculum.summary(),
        }
        if isinstance(self.curriculum, cur.Manual):
            c = self.curriculum
            row["stage"] = c.stage + 1
            held_s = self.stage_held_out[c.stage]
            reps = -(-self.spec.gate_episodes // len(held_s))  # every held-out task of the stage, equally often
            gate = evaluate(self.model, self.eval_env, self.inputs, held_s * reps)
            row["gate_success"] = gate["success"]
            if c.gate(gate["success"], int(gate["episodes"]), self.step):
                print(f"vertibench.train: mcl stage {c.stage} passed ({gate['success']:.0%} on "
                      f"{int(gate['episodes'])} held-out episodes) at step {self.step:,}", file=sys.stderr)
        if isinstance(self.curriculum, cur.PLR):
            p = self.curriculum
            row["levels_seen"] = int(p.seen.sum())
            row["score_mean"] = float(p.scores[p.seen].mean()) if p.seen.any() else 0.0
        if stats:
            row.update({k: round(v, 5) for k, v in stats.items()})
        self.curve.append(row)
        self.times["eval"] += time.perf_counter() - t0
        print(f"vertibench.train {self.spec.system}: step {self.step:,} held-out success {ev['success']:.1%} "
              f"return {ev['return']:.1f} ({row['curriculum']})", file=sys.stderr, flush=True)

    def _finish(self) -> dict[str, Any]:
        spec = self.spec
        meta = {
            "control_rate_hz": f"{spec.control_rate_hz:g}", "vehicle": self.vehicle["name"], "name": spec.system,
            "task_set_version": self.info.version, "seed": spec.seed, "steps": self.step,
            "curriculum": {"rl": "uniform", "mcl": "manual", "acl": "plr"}[spec.system], "command": spec.command,
            "sim_version": SIM_VERSION, "wall_s": f"{self.wall:.1f}",
        }
        self.model.export(self.out / "policy.safetensors", meta)
        card = report.write_all(self, meta)
        return card
