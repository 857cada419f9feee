"""``python -m vertibench.train rl|mcl|acl --task-set DIR --out DIR [--steps N] [--seed S] [--envs E]
[--eval-episodes K] [--eval-every U] [--resume]``: trains an end-to-end learned baseline with PPO on training
worlds and writes, in OUT, ``policy.safetensors`` (the Rust built-in planner's weights, POLICY.md), ``curve.csv``,
``curve.png``, ``card.md``, ``card.json`` and ``checkpoint.pt`` (a run resumes from it automatically)."""

from __future__ import annotations

import argparse
import shlex
import sys
from dataclasses import replace

from .ppo import PPOConfig

DEFAULT_STEPS = 8_000_000


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="python -m vertibench.train", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("system", help="rl (uniform over the training tasks), mcl (manual curriculum) or acl "
                                   "(prioritized level replay)")
    ap.add_argument("--task-set", default=None, help="training task set directory (default: "
                                                      "vertibench.tasks.training(), seed 7); never the benchmark's")
    ap.add_argument("--out", required=True, help="output directory (a checkpoint there is resumed)")
    ap.add_argument("--steps", type=int, default=DEFAULT_STEPS, help="environment-step budget")
    ap.add_argument("--seed", type=int, default=0, help="seeds torch, NumPy and the environments")
    ap.add_argument("--envs", type=int, default=PPOConfig.envs, help="environments in the vector")
    ap.add_argument("--rollout", type=int, default=PPOConfig.rollout, help="steps per environment per update")
    ap.add_argument("--minibatch", type=int, default=PPOConfig.minibatch)
    ap.add_argument("--eval-episodes", type=int, default=100, help="held-out episodes per learning-curve point")
    ap.add_argument("--eval-every", type=int, default=50, help="updates between evaluations")
    ap.add_argument("--gate-episodes", type=int, default=50,
                    help="held-out episodes per MCL gate (the issue asks at least 50; less only for quick tests)")
    ap.add_argument("--checkpoint-every", type=int, default=10, help="updates between checkpoints")
    ap.add_argument("--control-rate", type=float, default=20.0, help="control rate, Hz (the policy's metadata)")
    ap.add_argument("--threads", type=int, default=1,
                    help="torch threads in PPO updates (rollouts use one: the environments step in Rust threads); "
                         "2 gained 15%% on an idle 2-core machine and lost 20x while another process held a core")
    ap.add_argument("--resume", action="store_true", help="require OUT's checkpoint (resumed anyway when there)")
    return ap


def _positive(name: str, v: float, zero_ok: bool = False) -> None:
    if v < 0 or (v == 0 and not zero_ok):
        raise SystemExit(f"vertibench.train: error: {name} must be {'>= 0' if zero_ok else '> 0'}, got {v}")


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    from .loop import SYSTEMS

    if args.system not in SYSTEMS:
        raise SystemExit(f"vertibench.train: error: unknown system {args.system!r}: one of {', '.join(SYSTEMS)}")
    for name in ("steps", "envs", "rollout", "minibatch", "eval_episodes", "eval_every", "gate_episodes",
                 "checkpoint_every", "control_rate", "threads"):
        _positive("--" + name.replace("_", "-"), getattr(args, name))
    try:
        import torch  # noqa: F401
        import safetensors  # noqa: F401
        import matplotlib  # noqa: F401
    except ImportError as e:
        raise SystemExit(f"vertibench.train: error: {e.name} is missing: pip install 'vertibench[train]'") from None
    from .loop import RunSpec, Trainer
    from .worlds import TrainError

    command = "python -m vertibench.train " + " ".join(shlex.quote(a) for a in (argv if argv is not None
                                                                                 else sys.argv[1:]))
    ppo = replace(PPOConfig(), envs=args.envs, rollout=args.rollout, minibatch=args.minibatch)
    spec = RunSpec(system=args.system, task_set=args.task_set, out=args.out, steps=args.steps, seed=args.seed,
                   eval_episodes=args.eval_episodes, eval_every=args.eval_every, gate_episodes=args.gate_episodes,
                   checkpoint_every=args.checkpoint_every, control_rate_hz=args.control_rate, threads=args.threads,
                   command=command, ppo=ppo)
    try:
        card = Trainer(spec, resume=args.resume).run()
    except (TrainError, OSError) as e:
        raise SystemExit(f"vertibench.train: error: {e}") from None
    except KeyboardInterrupt:
        raise SystemExit("vertibench.train: interrupted; run the same command again to resume from the last "
                         "checkpoint") from None
    print(f"vertibench.train {args.system}: {card['steps']:,} steps in {card['wall_s']} s "
          f"({card['steps_per_s']} steps/s); held-out success {card['final_held_out_success']}; wrote {args.out}")
    return 0
