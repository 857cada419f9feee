"""Environment throughput against the raw simulator: ``python -m vertibench.bench``.

For 1, 8 and 64 environments (``--envs``), with and without map crops, it steps the vector environment with a
fixed action (gentle left turn at half throttle, on the low-elevation rigid tasks, no time limit) and reports
environment steps per second and the physics steps per second they deliver (environment steps x physics steps
per control step), next to ``Simulation::step`` alone on the same vehicles, tasks and thread count. Resets (with
the start's settling) that episode ends cause during the run are part of the environment's cost and are counted.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from . import _core, make_vec
from ._spaces import default_task_set


def env_rate(num_envs: int, crop_size: int, seconds: float, tasks: str, threads: int | None):
    env = make_vec(num_envs, tasks=tasks, crop_size=crop_size, max_time=1e9, task_order="cycle", num_threads=threads)
    env.reset(seed=0)
    action = np.tile(np.array([0.3, 0.5, 0.0]), (num_envs, 1))
    env.step(action)
    steps = ends = 0
    t0 = time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        _, _, term, trunc, _ = env.step(action)
        steps += num_envs
        ends += int(np.sum(term | trunc))
    dt = time.perf_counter() - t0
    per_control = round(env.control_period / env.physics_dt)
    return steps / dt, steps * per_control / dt, ends


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--envs", default="1,8,64")
    ap.add_argument("--crops", default="0,64", help="crop sizes to measure (0: none)")
    ap.add_argument("--seconds", type=float, default=5.0, help="wall time per measurement")
    ap.add_argument("--tasks", default="low")
    ap.add_argument("--threads", type=int, default=None, help="threads (default: all cores)")
    args = ap.parse_args(argv)
    threads = args.threads or os.cpu_count()
    print(f"# vertibench {_core.SIM_VERSION}; {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"{threads} threads; tasks {args.tasks}; {time.strftime('%Y-%m-%d %H:%M')}")
    print("| envs | crop | env steps/s | physics steps/s | raw physics steps/s | env / raw | episode ends |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for n in (int(v) for v in args.envs.split(",")):
        raw_steps = max(2000, int(2e5 * args.seconds / n))
        steps, secs = _core.raw_throughput(n, raw_steps, default_task_set(), tasks=args.tasks, num_threads=threads)
        raw = steps / secs
        for crop in (int(v) for v in args.crops.split(",")):
            rate, physics, ends = env_rate(n, crop, args.seconds, args.tasks, threads)
            print(f"| {n} | {crop or '-'} | {rate:,.0f} | {physics:,.0f} | {raw:,.0f} | {physics / raw:.0%} | {ends} |")


if __name__ == "__main__":
    main()
