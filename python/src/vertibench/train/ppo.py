"""A compact PPO (clipped surrogate, GAE, one Adam optimiser) for :class:`~vertibench.train.policy.ActorCritic`:
the rollout buffer, the reward scaling, advantage estimation and the update. The environment loop is in
:mod:`vertibench.train.loop`."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import torch

from .policy import ActorCritic, CROP_CHANNELS, CROP_SIZE, N_FEATURES


@dataclass
class PPOConfig:
    """One configuration for RL, MCL and ACL (their comparison is fair only with the same settings).

    32 environments x 128 steps = 4096 steps per update (6.4 s of driving per environment at 20 Hz: an episode lasts
    up to 60 s, so GAE bootstraps through the value, as in SB3's defaults); 4 epochs of minibatches of 1024 (16
    gradient steps per update: enough to use the batch, few enough that the update stays a small share of the time
    on 2 cores); Adam 3e-4, gamma 0.99 (a 5 s horizon at 20 Hz), lambda 0.95, clip 0.2, value coefficient 0.5, max
    gradient norm 0.5 and no entropy bonus (the release's PPO: SB3 defaults, ent 0); rewards scaled by a running
    standard deviation of the discounted return (clipped to +-10), since the success bonus and progress terms
    differ by orders of magnitude."""

    envs: int = 32
    rollout: int = 128
    epochs: int = 4
    minibatch: int = 1024
    lr: float = 3e-4
    gamma: float = 0.99
    lam: float = 0.95
    clip: float = 0.2
    vf_coef: float = 0.5
    ent_coef: float = 0.0
    max_grad_norm: float = 0.5
    reward_clip: float = 10.0
    hidden: int = 64

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


class ReturnStd:
    """Running standard deviation of each environment's discounted return (SB3's ``VecNormalize`` reward
    scaling): rewards are divided by it."""

    def __init__(self, n: int, gamma: float) -> None:
        self.gamma = gamma
        self.ret = np.zeros(n)
        self.mean, self.var, self.count = 0.0, 1.0, 1e-4

    def scale(self, reward: np.ndarray, done: np.ndarray) -> np.ndarray:
        """Updates the statistics with this step's rewards and returns them scaled; ``done`` ends returns."""
        self.ret = self.ret * self.gamma + reward
        x = self.ret
        b_mean, b_var, b_n = float(x.mean()), float(x.var()), x.size
        delta, tot = b_mean - self.mean, self.count + b_n
        m2 = self.var * self.count + b_var * b_n + delta**2 * self.count * b_n / tot
        self.mean, self.var, self.count = self.mean + delta * b_n / tot, m2 / tot, tot
        self.ret[done] = 0.0
        return reward / np.sqrt(self.var + 1e-8)

    @property
    def std(self) -> float:
        return float(np.sqrt(self.var + 1e-8))

    def state_dict(self) -> dict[str, Any]:
        return {"ret": self.ret.copy(), "mean": self.mean, "var": self.var, "count": self.count}

    def load_state_dict(self, s: dict[str, Any]) -> None:
        self.ret = np.asarray(s["ret"], dtype=float).copy()
        self.mean, self.var, self.count = float(s["mean"]), float(s["var"]), float(s["count"])


class Rollout:
    """``T x N`` steps: inputs, raw (unclipped) actions, their log-probabilities, values, scaled rewards (with
    truncated episodes' bootstrap already added) and episode ends."""

    def __init__(self, t: int, n: int) -> None:
        self.t, self.n = t, n
        self.vec = np.zeros((t, n, N_FEATURES), np.float32)
        self.crop = np.zeros((t, n, CROP_CHANNELS, CROP_SIZE, CROP_SIZE), np.float32)
        self.action = np.zeros((t, n, 2), np.float32)
        self.logp = np.zeros((t, n), np.float32)
        self.value = np.zeros((t, n), np.float32)
        self.reward = np.zeros((t, n), np.float32)
        self.done = np.zeros((t, n), bool)
        self.adv = np.zeros((t, n), np.float32)
        self.ret = np.zeros((t, n), np.float32)

    def gae(self, last_value: np.ndarray, gamma: float, lam: float) -> None:
        """Generalised advantage estimates and returns. ``done[t]`` ends the episode after step ``t`` (terminated
        or truncated: a truncated episode's reward already holds ``gamma V(final obs)``, so no bootstrap crosses
        it); ``last_value`` is the value of the observation after the last step."""
        a = np.zeros(self.n, np.float32)
        for t in reversed(range(self.t)):
            nxt = last_value if t == self.t - 1 else self.value[t + 1]
            live = 1.0 - self.done[t]
            delta = self.reward[t] + gamma * nxt * live - self.value[t]
            a = delta + gamma * lam * live * a
            self.adv[t] = a
        self.ret[:] = self.adv + self.value


def update(model: ActorCritic, opt: torch.optim.Optimizer, buf: Rollout, cfg: PPOConfig,
           rng: np.random.Generator) -> dict[str, float]:
    """PPO's epochs over the rollout; returns the last epoch's mean losses, approximate KL and clip fraction."""
    n = buf.t * buf.n
    vec = torch.from_numpy(buf.vec.reshape(n, N_FEATURES))
    crop = torch.from_numpy(buf.crop.reshape(n, CROP_CHANNELS, CROP_SIZE, CROP_SIZE))
    act = torch.from_numpy(buf.action.reshape(n, 2))
    logp_old = torch.from_numpy(buf.logp.reshape(n))
    adv_all = torch.from_numpy(buf.adv.reshape(n))
    ret = torch.from_numpy(buf.ret.reshape(n))
    mb = min(cfg.minibatch, n)
    stats: dict[str, list[float]] = {"pg_loss": [], "v_loss": [], "entropy": [], "approx_kl": [], "clip_frac": []}
    for epoch in range(cfg.epochs):
        perm = torch.from_numpy(rng.permutation(n))
        last = epoch == cfg.epochs - 1
        for start in range(0, n - mb + 1, mb):
            i = perm[start:start + mb]
            dist, v = model.dist_and_value(vec[i], crop[i])
            logp = dist.log_prob(act[i]).sum(-1)
            ratio = (logp - logp_old[i]).exp()
            adv = adv_all[i]
            adv = (adv - adv.mean()) / (adv.std() + 1e-8)
            pg = torch.max(-adv * ratio, -adv * ratio.clamp(1 - cfg.clip, 1 + cfg.clip)).mean()
            v_loss = 0.5 * (v - ret[i]).pow(2).mean()
            ent = dist.entropy().sum(-1).mean()
            loss = pg + cfg.vf_coef * v_loss - cfg.ent_coef * ent
            opt.zero_grad(set_to_none=True)
            loss.backward()
            torch.nn.utils.clip_grad_norm_(model.parameters(), cfg.max_grad_norm)
            opt.step()
            if last:
                with torch.no_grad():
                    lr_ = logp - logp_old[i]
                    stats["approx_kl"].append(float(((lr_.exp() - 1) - lr_).mean()))
                    stats["clip_frac"].append(float(((ratio - 1).abs() > cfg.clip).float().mean()))
                stats["pg_loss"].append(float(pg.detach()))
                stats["v_loss"].append(float(v_loss.detach()))
                stats["entropy"].append(float(ent.detach()))
    return {k: float(np.mean(v)) if v else 0.0 for k, v in stats.items()}
