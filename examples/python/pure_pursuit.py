"""A pure-pursuit planner in Python: it follows the task's global path with a look-ahead point and holds the
vehicle's nominal speed.

    python examples/python/pure_pursuit.py                      # serve it (what `vb-submit exec` runs)
    python examples/python/pure_pursuit.py --evaluate low       # run it in-process on the low-elevation split
    vb-submit validate exec -- python examples/python/pure_pursuit.py
"""

import argparse
import math

import vertibench as vb
from vertibench.baselines import point_ahead


class PurePursuit(vb.Planner):
    name = "pure-pursuit-python"
    control_rate_hz = 20.0

    def reset(self, task, vehicle, maps):
        self.path = [(float(x), float(y)) for x, y in task.path]
        self.progress = 0
        self.lookahead = 6.0 * vehicle["scale"]
        self.speed = vehicle["nominal_speed"]
        self.wheelbase = vehicle["wheelbase"]
        self.max_steer = max(vehicle["max_steer"], 1e-6)
        self.skid = vehicle["skid_steer"]

    def act(self, obs):
        x, y = float(obs.position[0]), float(obs.position[1])
        target, self.progress = point_ahead(self.path, (x, y), self.progress, self.lookahead)
        alpha = math.atan2(target[1] - y, target[0] - x) - obs.yaw
        alpha = math.atan2(math.sin(alpha), math.cos(alpha))
        if self.skid:
            steering = 2.0 * alpha
        else:
            steering = math.atan(2.0 * self.wheelbase * math.sin(alpha) / self.lookahead) / self.max_steer
        err = self.speed - obs.speed
        return vb.Action(
            steering=max(-1.0, min(1.0, steering)),
            throttle=max(0.0, min(1.0, err / self.speed)),
            brake=0.3 if err < -0.3 * self.speed else 0.0,
        )


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--evaluate", metavar="TASKS", help="run in-process on these tasks instead of serving")
    ap.add_argument("--out", default="out/pure-pursuit-python")
    args = ap.parse_args()
    if args.evaluate:
        episodes, summary = vb.evaluate(PurePursuit(), args.evaluate, out=args.out)
        print(episodes.groupby("level").outcome.value_counts().unstack(fill_value=0))
        print(f"success rate {summary['overall']['success_rate']:.1%}; files in {args.out}")
    else:
        from vertibench.serve import serve

        serve(PurePursuit())
