"""Which training task each environment runs next: the three systems differ only here.

- :class:`Uniform` (``rl``): every training task equally likely.
- :class:`Manual` (``mcl``): stages of increasing difficulty (:data:`MCL_STAGES`), advancing when the deterministic
  success rate on at least 50 held-out episodes of the stage's difficulty reaches the release's threshold
  (:data:`MCL_THRESHOLDS`; the episodes cover every held-out task of the stage equally often: on seed 7's set
  stages 1-5 hold out 10, 30, 50, 70 and 100 tasks, so stage 1 runs its 10 five times, stage 2 its 30 twice); a
  stage that has not passed when its share of the budget is spent advances anyway (the remaining budget is shared
  equally by the remaining stages, so unused budget flows on) and is recorded as forced.
- :class:`PLR` (``acl``): prioritized level replay (Jiang et al., 2021) with levels = training tasks, each
  environment of the vector on its own level. A level's score is the mean *positive value loss* of its last
  episode, ``mean_t max(A_t, 0)`` over its steps' GAE advantages; replay draws from ``(1 - rho) P_score + rho
  P_stale`` with ``P_score`` the rank transform ``(1 / rank)^(1 / beta)`` and ``P_stale`` proportional to the
  episodes since a level was last drawn.

How :class:`PLR` improves on the release's Verti-Selector (``learned-baselines.md`` 1.6):
  1. the score is a GAE advantage (positive value loss, Jiang et al.'s robust PLR), a regret estimate, instead of
     ``|r_t - V(s_t)|``, a one-step reward compared with a whole return that is large wherever rewards are large;
  2. temperature ``beta = 0.3`` instead of 0.1, whose ``1 / rank^10`` weights replay almost only the top level;
     staleness ``rho = 0.3`` so old scores get refreshed across hundreds of levels;
  3. every environment draws its own level at every episode end instead of one level for a whole 120k-step
     iteration, so a PPO batch mixes levels and the scores track the current policy.
All classes are plain NumPy; their state is a dict of arrays (:meth:`state_dict`) saved in checkpoints.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

#: MCL's five stages as task selections (the env's split syntax: ``,`` union, ``+`` intersection), each
#: containing the previous (no forgetting): flat rigid ground, then every low world, then medium rigid relief, then
#: every low and medium world, then everything (high relief and its deformable ground last).
MCL_STAGES: tuple[str, ...] = (
    "low+rigid",
    "low",
    "low,medium+rigid",
    "low,medium",
    "all",
)
#: The release's success thresholds of the five stages (``off_road_art_train.py``).
MCL_THRESHOLDS: tuple[float, ...] = (1.0, 1.0, 0.8, 0.6, 0.5)


class Uniform:
    """RL: uniform over the training tasks."""

    name = "uniform"

    def __init__(self, n_tasks: int) -> None:
        if n_tasks < 1:
            raise ValueError("no training tasks")
        self.n_tasks = n_tasks

    def sample(self, rng: np.random.Generator) -> int:
        return int(rng.integers(self.n_tasks))

    def summary(self) -> str:
        return f"uniform over {self.n_tasks}"

    def state_dict(self) -> dict[str, Any]:
        return {}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        pass


@dataclass
class StageRecord:
    """One MCL stage as it went: steps it started and ended at, its last gate measurement, how it ended."""

    stage: int
    start_step: int
    end_step: int | None = None
    success: float | None = None
    episodes: int = 0
    ended: str = "running"  # "passed", "forced" (its budget share spent) or "running"


@dataclass
class Manual:
    """MCL: ``stages[k]`` are the task indices of stage ``k`` (:data:`MCL_STAGES`), ``thresholds[k]`` its gate."""

    stages: Sequence[Sequence[int]]
    thresholds: Sequence[float] = MCL_THRESHOLDS
    budget: int = 1
    min_episodes: int = 50
    stage: int = 0
    records: list[StageRecord] = field(default_factory=list)
    name: str = "manual"

    def __post_init__(self) -> None:
        if len(self.stages) != len(self.thresholds):
            raise ValueError(f"{len(self.stages)} stages but {len(self.thresholds)} thresholds")
        if any(len(s) == 0 for s in self.stages):
            raise ValueError("an MCL stage has no training task")
        if not self.records:
            self.records = [StageRecord(0, 0)]

    @property
    def last(self) -> bool:
        return self.stage == len(self.stages) - 1

    def sample(self, rng: np.random.Generator) -> int:
        tasks = self.stages[self.stage]
        return int(tasks[int(rng.integers(len(tasks)))])

    def deadline(self) -> int:
        """The step at which the current stage advances even if its gate has not passed: its start plus the
        remaining budget shared equally by the remaining stages."""
        start = self.records[-1].start_step
        left = len(self.stages) - self.stage
        return start + max(0, self.budget - start) // left

    def gate(self, success: float, episodes: int, step: int) -> bool:
        """Records a held-out measurement of the current stage; advances (returns True) when it passes with at
        least ``min_episodes`` episodes."""
        rec = self.records[-1]
        rec.success, rec.episodes = success, episodes
        if not self.last and episodes >= self.min_episodes and success >= self.thresholds[self.stage]:
            self._advance(step, "passed")
            return True
        return False

    def check_deadline(self, step: int) -> bool:
        """Advances (returns True) when the current stage's share of the budget is spent."""
        if not self.last and step >= self.deadline():
            self._advance(step, "forced")
            return True
        return False

    def _advance(self, step: int, how: str) -> None:
        rec = self.records[-1]
        rec.end_step, rec.ended = step, how
        self.stage += 1
        self.records.append(StageRecord(self.stage, step))

    def summary(self) -> str:
        return f"stage {self.stage + 1}/{len(self.stages)}"

    def state_dict(self) -> dict[str, Any]:
        return {"stage": self.stage, "records": [r.__dict__.copy() for r in self.records]}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.stage = int(state["stage"])
        self.records = [StageRecord(**r) for r in state["records"]]


class PLR:
    """ACL: prioritized level replay over ``n_levels`` levels (see the module's docstring).

    ``sample`` draws an unseen level with probability ``1 - replay_prob`` (uniformly) while any is unseen and at
    least ``min_seen`` of the levels have been seen, otherwise replays a seen level; ``update(level, score)``
    records an episode's score."""

    name = "plr"

    def __init__(self, n_levels: int, *, temperature: float = 0.3, staleness: float = 0.3,
                 replay_prob: float = 0.5, min_seen: float = 0.1) -> None:
        if n_levels < 1:
            raise ValueError("no levels")
        if temperature <= 0 or not 0 <= staleness <= 1 or not 0 <= replay_prob <= 1:
            raise ValueError("PLR needs temperature > 0 and staleness, replay_prob in [0, 1]")
        self.n = n_levels
        self.temperature, self.staleness = temperature, staleness
        self.replay_prob, self.min_seen = replay_prob, min_seen
        self.scores = np.zeros(n_levels)
        self.seen = np.zeros(n_levels, dtype=bool)
        self.last_drawn = np.zeros(n_levels, dtype=np.int64)
        self.draws = 0

    def replay_weights(self) -> np.ndarray:
        """Probabilities of replaying each level (zero for unseen ones): rank-prioritised scores mixed with
        staleness."""
        w = np.zeros(self.n)
        idx = np.flatnonzero(self.seen)
        if idx.size == 0:
            return w
        order = np.argsort(-self.scores[idx], kind="stable")
        ranks = np.empty(idx.size)
        ranks[order] = np.arange(1, idx.size + 1)
        h = (1.0 / ranks) ** (1.0 / self.temperature)
        p_score = h / h.sum()
        stale = (self.draws - self.last_drawn[idx]).astype(float)
        p_stale = stale / stale.sum() if stale.sum() > 0 else np.full(idx.size, 1.0 / idx.size)
        w[idx] = (1 - self.staleness) * p_score + self.staleness * p_stale
        return w

    def sample(self, rng: np.random.Generator) -> int:
        unseen = np.flatnonzero(~self.seen)
        seen_frac = 1.0 - unseen.size / self.n
        explore = unseen.size > 0 and (seen_frac < self.min_seen or rng.random() >= self.replay_prob)
        if explore:
            level = int(unseen[rng.integers(unseen.size)])
        else:
            level = int(rng.choice(self.n, p=self.replay_weights()))
        self.draws += 1
        self.last_drawn[level] = self.draws
        return level

    def update(self, level: int, score: float) -> None:
        """Records the score of an episode on ``level`` (the latest replaces the previous one, as in PLR)."""
        self.scores[level] = score
        self.seen[level] = True

    def summary(self) -> str:
        if not self.seen.any():
            return "seen 0"
        s = self.scores[self.seen]
        return f"seen {int(self.seen.sum())}/{self.n} score mean {s.mean():.3g} max {s.max():.3g}"

    def state_dict(self) -> dict[str, Any]:
        return {"scores": self.scores.copy(), "seen": self.seen.copy(), "last_drawn": self.last_drawn.copy(),
                "draws": self.draws}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.scores = np.asarray(state["scores"], dtype=float).copy()
        self.seen = np.asarray(state["seen"], dtype=bool).copy()
        self.last_drawn = np.asarray(state["last_drawn"], dtype=np.int64).copy()
        self.draws = int(state["draws"])


def positive_value_loss(advantages: np.ndarray) -> float:
    """PLR's score of a stretch of steps: the mean of ``max(A_t, 0)``."""
    return float(np.maximum(advantages, 0.0).mean()) if advantages.size else 0.0
