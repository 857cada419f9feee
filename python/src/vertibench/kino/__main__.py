"""``python -m vertibench.kino train|report ...``."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from . import LR_DECAYS


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    p = argparse.ArgumentParser(prog="python -m vertibench.kino", description=__doc__)
    sub = p.add_subparsers(dest="cmd", required=True)
    t = sub.add_parser("train", help="train a model on datasets (resumes from --out)")
    t.add_argument("--data", nargs="+", required=True, help="dataset directories (vb dataset generate)")
    t.add_argument("--task-set", help="their task set (found from the datasets' version when omitted)")
    t.add_argument("--out", required=True)
    t.add_argument("--model", choices=("kino", "tal", "tnt"), default="kino",
                   help="kino: a crop under every predicted pose (mppi6, wmvct); tal: terrain attention over one map "
                        "per decision (tal); tnt: the traversability estimator, a map-to-map network (tnt)")
    t.add_argument("--epochs", type=int, default=20)
    t.add_argument("--seed", type=int, default=0)
    t.add_argument("--members", type=int, default=4)
    t.add_argument("--hidden", type=int, help="heads' width (kino, tal: 64) or convolutions' (tnt: 16)")
    t.add_argument("--batch", type=int, default=512)
    t.add_argument("--lr", type=float, default=1e-3)
    t.add_argument("--lr-decay", choices=LR_DECAYS, default="none",
                   help="the learning rate held (none) or decayed to zero along half a cosine over --epochs")
    t.add_argument("--stride", type=int, default=1, help="use every N-th model step of each episode")
    t.add_argument("--threads", type=int, default=2)
    t.add_argument("--device", default="cpu",
                   help="PyTorch device to train on: cpu (default), cuda or cuda:N (only the speed changes; the card "
                        "says which)")
    t.add_argument("--name", help="the card's name (default: the model kind)")
    r = sub.add_parser("report", help="open-loop accuracy on held-out episodes against the bicycle model")
    r.add_argument("--weights", required=True)
    r.add_argument("--data", nargs="+", required=True)
    r.add_argument("--task-set")
    r.add_argument("--out", help="directory for accuracy.json and accuracy.md (printed when omitted)")
    r.add_argument("--every", type=float, default=2.0, help="seconds between start frames")
    r.add_argument("--no-simulator", action="store_true",
                   help="leave out our simulator restarted from the recorded observation")
    a = p.parse_args(argv)
    try:
        if a.cmd == "train":
            from .train import TrainSpec, train

            hidden = a.hidden if a.hidden is not None else (16 if a.model == "tnt" else 64)
            if a.epochs < 1 or a.batch < 1 or a.stride < 1 or hidden < 1 or not a.lr > 0:
                p.error("--epochs, --batch, --stride and --hidden must be at least 1 and --lr positive")
            cmd = "python -m vertibench.kino " + " ".join(shlex.quote(x) for x in argv)
            spec = TrainSpec(data=a.data, out=a.out, model=a.model, task_set=a.task_set, epochs=a.epochs, seed=a.seed,
                             members=a.members, hidden=hidden, batch=a.batch, lr=a.lr, lr_decay=a.lr_decay, stride=a.stride,
                             threads=a.threads, device=a.device, name=a.name or a.model, command=cmd)
            if a.model == "tnt":
                from .trav_train import train as train_tnt

                w = train_tnt(spec)
            else:
                w = train(spec)
            print(f"vertibench.kino: weights {w}")
        else:
            from . import report as rp

            rep = rp.accuracy(a.weights, a.data, a.task_set, a.every, simulator=not a.no_simulator)
            if a.out:
                rp.write(rep, Path(a.out))
                print(f"vertibench.kino: report in {a.out}/accuracy.md")
            else:
                print(rp.markdown(rep))
    except (ValueError, FileNotFoundError) as e:
        print(f"vertibench.kino: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
