"""Environment throughput against the raw simulator: ``python -m vertibench.bench``.

For 1, 8 and 64 environments (``--envs``), with and without map crops (``--crops``), it runs the vector environment
on the first tasks of a split (environment ``i`` on task ``i``) for ``--horizon`` steps from the start with a fixed
action, again and again for ``--seconds`` of wall time, and reports environment steps per second, the physics steps
per second they deliver (environment steps x physics steps per control step) and the same vehicles on the same
tasks with the same action stepped by ``Simulation::step`` alone, on the same number of threads. The trajectories
are the same, so the ratio is what the episode rules, observations, NumPy arrays and Python cost. Resets are timed
apart: a task's first start (settling the vehicle) and a repeated one (a clone of the settled start).
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from . import _core, make_vec
from ._spaces import default_task_set

ACTION = (0.0, 0.4, 0.0)


def measure(num_envs: int, crop_size: int, seconds: float, horizon: int, tasks: str, threads: int):
    env = make_vec(num_envs, tasks=tasks, crop_size=crop_size, max_time=1e9, task_order="cycle",
                   num_threads=threads)
    picks = [env.task_ids[i % len(env.task_ids)] for i in range(num_envs)]
    t0 = time.perf_counter()
    env.reset(seed=0, options={"tasks": picks})
    first_reset = time.perf_counter() - t0
    action = np.tile(np.array(ACTION), (num_envs, 1))
    step_s = reset_s = 0.0
    steps = resets = ends = 0
    while step_s < seconds:
        t0 = time.perf_counter()
        env.reset(options={"tasks": picks})
        reset_s += time.perf_counter() - t0
        resets += 1
        t0 = time.perf_counter()
        for _ in range(horizon):
            _, _, term, trunc, _ = env.step(action)
            ends += int(np.sum(term | trunc))
        step_s += time.perf_counter() - t0
        steps += horizon * num_envs
    per_control = round(env.control_period / env.physics_dt)
    raw_steps, raw_s = 0, 0.0
    while raw_s < seconds:
        n, s = _core.raw_throughput(num_envs, horizon * per_control, default_task_set(), tasks=tasks,
                                    action=ACTION, num_threads=threads)
        raw_steps, raw_s = raw_steps + n, raw_s + s
    return dict(
        env_rate=steps / step_s,
        physics_rate=steps * per_control / step_s,
        raw_rate=raw_steps / raw_s,
        first_reset_ms=first_reset * 1e3,
        reset_ms=reset_s / resets * 1e3,
        ends=ends,
    )


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--envs", default="1,8,64")
    ap.add_argument("--crops", default="0,32", help="crop sizes to measure (0: none)")
    ap.add_argument("--seconds", type=float, default=4.0, help="wall time of stepping per measurement")
    ap.add_argument("--horizon", type=int, default=150, help="steps per run from the start (150 = 7.8 s)")
    ap.add_argument("--tasks", default="low")
    ap.add_argument("--threads", type=int, default=None, help="threads (default: all cores)")
    args = ap.parse_args(argv)
    threads = args.threads or os.cpu_count()
    print(f"# vertibench {_core.SIM_VERSION}; {platform.machine()}, {os.cpu_count()} cores, {threads} threads; "
          f"tasks {args.tasks}; action {ACTION}; {args.horizon} steps per run; {time.strftime('%Y-%m-%d %H:%M')}")
    print("| envs | crop | env steps/s | physics steps/s | raw physics steps/s | env / raw | reset, first (ms) "
          "| reset, repeated (ms) | episode ends |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for n in (int(v) for v in args.envs.split(",")):
        for crop in (int(v) for v in args.crops.split(",")):
            m = measure(n, crop, args.seconds, args.horizon, args.tasks, threads)
            print(f"| {n} | {crop or '-'} | {m['env_rate']:,.0f} | {m['physics_rate']:,.0f} | {m['raw_rate']:,.0f} "
                  f"| {m['physics_rate'] / m['raw_rate']:.0%} | {m['first_reset_ms']:.1f} | {m['reset_ms']:.2f} "
                  f"| {m['ends']} |", flush=True)


if __name__ == "__main__":
    main()
