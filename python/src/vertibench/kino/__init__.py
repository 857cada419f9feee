"""Learned kinodynamic models for the hybrid planners (layout ``vertibench-kino-v1``, ``planners/learned/KINO.md``).

```sh
vb tasks generate --seed 11 --out out/kino-tasks                   # training worlds, never the benchmark's
vb dataset generate --kind random --task-set out/kino-tasks --hours 20 --out out/kino-data/random
vb dataset generate --kind expert --task-set out/kino-tasks --hours 10 --out out/kino-data/expert
python -m vertibench.kino train --data out/kino-data/random out/kino-data/expert --out out/kino --epochs 20
python -m vertibench.kino report --weights out/kino/kino.safetensors --data out/kino-data/random out/kino-data/expert
python -m vertibench.kino train --model tnt --data out/kino-data/random out/kino-data/expert --out out/tnt
```

The inputs and targets are made by the Rust planners' own code (:class:`vertibench._core.KinoData`); the weights
run in Rust (:class:`vertibench._core.KinoNet`, ``learned::kino::KinoNet``) exactly as the planners run them. ``--model
tal`` trains the terrain-attentive model (``vertibench-tal-v1``), ``--model tnt`` the traversability estimator
(``vertibench-tnt-v1``, :mod:`.trav`) whose grid the ``tnt`` planner adds to ``tal``'s rollout cost.
"""

#: The trainers' learning-rate schedules (``--lr-decay``; :func:`.train.learning_rate`).
LR_DECAYS = ("none", "cosine")
