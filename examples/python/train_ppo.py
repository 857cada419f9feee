"""PPO (stable-baselines3) on vertibench's vector environment, trained on the low-elevation rigid worlds of a
training task set generated with another seed (never on the benchmark's own tasks), then evaluated on the
benchmark's low split with `vertibench.evaluate`.

    python examples/python/train_ppo.py --steps 500000    # training worlds: vertibench.tasks.training(seed=7)
    python examples/python/train_ppo.py --task-set DIR     # or any task set (never the benchmark's)

It reports the success rate of the untrained and the trained policy on training episodes (deterministic actions),
the training steps and wall time, and the trained policy's benchmark results (files in OUT/benchmark-low, readable
by `vb compare` and `vb leaderboard-static`).
"""

import argparse
import json
import time
from pathlib import Path

import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecNormalize

import vertibench as vb
from vertibench.sb3 import PolicyPlanner, SB3VecEnv


def success_rate(model, env: VecNormalize, episodes: int):
    """Success rate over the first `episodes` episodes that end, acting deterministically."""
    obs = env.reset()
    outcomes = []
    while len(outcomes) < episodes:
        action, _ = model.predict(obs, deterministic=True)
        obs, _, dones, infos = env.step(action)
        outcomes += [infos[i]["outcome"] for i in np.flatnonzero(dones)]
    outcomes = outcomes[:episodes]
    return sum(o == "success" for o in outcomes) / episodes, outcomes


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--task-set", default=None,
                    help="training task set (default: vertibench.tasks.training(--train-seed), made on first use)")
    ap.add_argument("--train-seed", type=int, default=vb.tasks.TRAINING_SEED)
    ap.add_argument("--tasks", default="low+rigid")
    ap.add_argument("--steps", type=int, default=500_000)
    ap.add_argument("--envs", type=int, default=16)
    ap.add_argument("--eval-episodes", type=int, default=100)
    ap.add_argument("--benchmark-tasks", default="low")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="out/ppo")
    args = ap.parse_args()
    if args.task_set is None:
        args.task_set = str(vb.tasks.training(args.train_seed))
    if not Path(args.task_set, "manifest.json").is_file():
        raise SystemExit(f"no task set in {args.task_set}: generate one with "
                         f"`python -c 'import vertibench as vb; vb.tasks.generate(seed=7, out=\"{args.task_set}\")'`")
    if vb.tasks.info(args.task_set).version == vb.tasks.benchmark_version():
        raise SystemExit(f"{args.task_set} is the benchmark's own task set: train on another seed's worlds")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    torch.manual_seed(args.seed)
    train = VecNormalize(SB3VecEnv(args.envs, tasks=args.tasks, task_set=args.task_set), gamma=0.99)
    train.seed(args.seed)
    model = PPO("MultiInputPolicy", train, n_steps=256, batch_size=1024, n_epochs=5, learning_rate=3e-4,
                gamma=0.99, ent_coef=0.0, seed=args.seed, device="cpu", verbose=0)

    def evaluate_on_training_tasks():
        probe = VecNormalize(SB3VecEnv(args.envs, tasks=args.tasks, task_set=args.task_set), training=False,
                             norm_reward=False)
        probe.obs_rms = train.obs_rms
        probe.seed(args.seed + 1000)
        return success_rate(model, probe, args.eval_episodes)

    before, _ = evaluate_on_training_tasks()
    print(f"untrained policy: success {before:.1%} on {args.eval_episodes} training episodes", flush=True)
    t0 = time.time()
    model.learn(total_timesteps=args.steps, progress_bar=False)
    wall = time.time() - t0
    after, outcomes = evaluate_on_training_tasks()
    print(f"trained {args.steps} steps in {wall:.0f} s ({args.steps / wall:,.0f} steps/s): success {after:.1%} on "
          f"{args.eval_episodes} training episodes ({ {o: outcomes.count(o) for o in set(outcomes)} })", flush=True)
    model.save(out / "ppo")
    train.save(str(out / "vecnormalize.pkl"))
    train.training = False
    episodes, summary = vb.evaluate(PolicyPlanner(model, train, name="ppo-low-rigid"), args.benchmark_tasks,
                                    out=out / f"benchmark-{args.benchmark_tasks}")
    bench = summary["overall"]["success_rate"]
    print(f"benchmark {args.benchmark_tasks} split: success {bench:.1%} over {len(episodes)} tasks")
    print(episodes.groupby("semantics").outcome.value_counts().unstack(fill_value=0))
    (out / "report.json").write_text(json.dumps({
        "steps": args.steps, "envs": args.envs, "wall_s": wall, "tasks": args.tasks, "task_set": args.task_set,
        "success_before": before, "success_after": after, "benchmark_tasks": args.benchmark_tasks,
        "benchmark_success": bench,
    }, indent=1))


if __name__ == "__main__":
    main()
