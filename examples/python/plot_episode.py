"""Drives one task with the Python PID in the gymnasium environment and plots the episode with matplotlib: the
driven path and the global path over the elevation map (obstacles outlined in black), and roll, pitch and speed
over time.

    python examples/python/plot_episode.py --task w017-t3 --out episode.png
"""

import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import vertibench as vb  # noqa: E402
from vertibench.baselines import PID  # noqa: E402
from vertibench.planner import make_observation  # noqa: E402


def drive(task_id: str):
    env = vb.make(task_id)
    obs, _ = env.reset(seed=0)
    pid = PID()
    pid.reset(env.task, env.vehicle, None)
    rows = [obs["state"]]
    while True:
        s = obs["state"]
        a = pid.act(make_observation((s[14], *s[:14])))
        obs, _, terminated, truncated, info = env.step(np.array([a.steering, a.throttle, a.brake]))
        rows.append(obs["state"])
        if terminated or truncated:
            return env.task, env.maps, np.array(rows), info


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--task", default="w017-t3")
    ap.add_argument("--out", default="episode.png")
    args = ap.parse_args()
    task, maps, states, info = drive(args.task)
    col = {name: k for k, name in enumerate(vb.STATE_FIELDS)}
    fig, (ax_map, ax_t) = plt.subplots(1, 2, figsize=(12, 5))
    ny, nx = maps.elevation.shape
    half_x, half_y = (nx - 1) / 2 * maps.cell, (ny - 1) / 2 * maps.cell
    im = ax_map.imshow(maps.elevation, origin="lower", extent=(-half_x, half_x, -half_y, half_y), cmap="terrain")
    ax_map.contour(maps.obstacles, levels=[0.5], colors="k", linewidths=0.6, origin="lower",
                   extent=(-half_x, half_x, -half_y, half_y))
    fig.colorbar(im, ax=ax_map, label="elevation (m)")
    ax_map.plot(task.path[:, 0], task.path[:, 1], "w--", lw=1, label="global path")
    ax_map.plot(states[:, col["x"]], states[:, col["y"]], "m-", lw=2, label="driven")
    ax_map.plot(*task.goal, "r*", ms=14, label="goal")
    ax_map.set_aspect("equal")
    ax_map.legend(loc="best")
    ax_map.set_title(f"{task.id} ({task.level}, {task.semantics}, {task.density}): {info['outcome']}")
    t = states[:, col["time"]]
    ax_t.plot(t, np.degrees(states[:, col["roll"]]), "r", label="roll (deg)")
    ax_t.plot(t, np.degrees(states[:, col["pitch"]]), "b", label="pitch (deg)")
    ax_t.plot(t, states[:, col["speed"]], "g", label="speed (m/s)")
    ax_t.axhline(0, color="0.7", lw=0.5)
    ax_t.set_xlabel("time (s)")
    ax_t.legend(loc="best")
    fig.tight_layout()
    fig.savefig(args.out, dpi=100)
    print(f"{task.id}: {info['outcome']} after {info['metrics']['time_s']:.1f} s; plot in {args.out}")


if __name__ == "__main__":
    main()
