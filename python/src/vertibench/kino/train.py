"""Training a kinodynamic model on datasets (``python -m vertibench.kino train``): one-step regression of the
scaled targets, each ensemble member on its own bootstrap weights of the samples, Adam, a fixed seed; one epoch at a
time with a checkpoint after each (a run resumes from its ``--out`` directory), a learning curve (held-out RMSE per
target) and, at the end, the weights (``kino.safetensors`` or ``tal.safetensors``, by ``--model``) with their
card."""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import _core
from . import LR_DECAYS
from . import data as kd
from . import model as km


@dataclass
class TrainSpec:
    data: list[str]
    out: str
    model: str = "kino"
    task_set: str | None = None
    epochs: int = 20
    seed: int = 0
    members: int = 4
    hidden: int = 64
    batch: int = 512
    lr: float = 1e-3
    lr_decay: str = "none"
    stride: int = 1
    threads: int = 2
    device: str = "cpu"
    name: str = "kino"
    command: str = ""
    extra: dict = field(default_factory=dict)


def read_datasets(spec: TrainSpec, wheels: bool = False):
    """Each dataset of ``spec.data`` as ``(path, spec, episodes, maker, key)``, ``maker`` the inputs' maker on their
    task set and ``key`` (vehicle, scale, task-set version, simulator version); a dataset made from the benchmark's
    tasks, or one whose key differs from the first's, is refused."""
    maker, first = None, None
    for d in spec.data:
        ds_spec, eps = kd.episodes(d, spec.task_set, wheels=wheels)
        if ds_spec.get("analysis_only"):
            raise ValueError(f"{d} was made from the benchmark's own tasks (--allow-benchmark-tasks): a model "
                             f"trained on it would have seen the tasks it is evaluated on; generate a dataset "
                             f"on a training task set (vb tasks generate --seed N)")
        k = (ds_spec["vehicle"], float(ds_spec["scale"]), ds_spec["task_set_version"], ds_spec["sim_version"])
        if first is not None and k != first:
            raise ValueError(f"{d}: vehicle, scale, task set or simulator {k} differ from the first dataset's {first}")
        if maker is None:
            from .. import datasets as vbd

            task_dir = spec.task_set or vbd._find_task_set(ds_spec)
            if task_dir is None:
                raise ValueError(f"{d}: its task set (version {ds_spec['task_set_version']}) was not found: pass "
                                 f"--task-set DIR")
            maker = _core.KinoData(str(task_dir), ds_spec["vehicle"], float(ds_spec["scale"]))
        first = k
        yield d, ds_spec, eps, maker, k


def load_samples(spec: TrainSpec) -> tuple[kd.Samples, dict]:
    """The samples of every dataset (cached in ``out/samples.npz``) and what the card says about the data."""
    out = Path(spec.out)
    cache, about_path = out / "samples.npz", out / "data.json"
    if cache.exists() and about_path.exists():
        about = json.loads(about_path.read_text())
        if (about.get("data") == [str(Path(d).resolve()) for d in spec.data] and about.get("stride") == spec.stride
                and about.get("model", "kino") == spec.model and about.get("seed") == spec.seed):
            return kd.Samples.load(cache), about
    parts, about = [], {"data": [str(Path(d).resolve()) for d in spec.data], "stride": spec.stride,
                        "model": spec.model, "seed": spec.seed, "sets": []}
    # Which earlier step a terrain-attentive sample's map is anchored at: drawn from the training seed.
    rng = np.random.default_rng(spec.seed)
    for d, ds_spec, eps, maker, key in read_datasets(spec):
        s = kd.samples(eps, maker, spec.stride, spec.model, rng)
        # Episodes are numbered across datasets: this one's follow the last one's.
        s.episode = s.episode + (int(parts[-1].episode.max()) + 1 if parts else 0)
        parts.append(s)
        about["sets"].append({"path": str(d), "kind": ds_spec["kind"], "episodes": len(eps), "samples": len(s),
                              "seed": ds_spec["seed"],
                              "speed_profile": ds_spec.get("speed_profile", "constant"),
                              "task_set_version": ds_spec["task_set_version"],
                              "sim_version": ds_spec["sim_version"]})
    about.update(vehicle=key[0], scale=key[1], task_set_version=key[2], sim_version=key[3],
                 target_factors=list(maker.target_factors), vehicle_facts=dict(maker.vehicle))
    allv = kd.Samples.concatenate(parts)
    out.mkdir(parents=True, exist_ok=True)
    allv.save(cache)
    about_path.write_text(json.dumps(about, indent=1))
    return allv, about


def split(s: kd.Samples) -> tuple[np.ndarray, np.ndarray]:
    held = (s.world % 10) == kd.HELD_OUT
    return np.flatnonzero(~held), np.flatnonzero(held)


def rmse(model, s: kd.Samples, rows: np.ndarray, batch: int = 8192) -> np.ndarray:
    """Held-out RMSE per scaled target of the ensemble mean (computed on the model's device)."""
    import torch

    dev = device_of(model)
    se = np.zeros(km.TARGETS)
    with torch.no_grad():
        for a in range(0, len(rows), batch):
            r = rows[a:a + batch]
            p = model(*(torch.from_numpy(x).to(dev) for x in s.inputs(r))).mean(1).cpu().numpy()
            se += ((p - s.target[r]) ** 2).sum(0)
    return np.sqrt(se / max(len(rows), 1))


def device_of(model):
    """The device a model's parameters live on."""
    return next(model.parameters()).device


def torch_device(spec: TrainSpec):
    """The ``torch.device`` of ``spec.device`` (``cpu``, ``cuda`` or ``cuda:N``), refused with a clear message when
    PyTorch has no such device here. A GPU changes only the speed: the weights differ from a CPU run's in the last
    bits (its kernels sum in another order), and the card says which device trained them."""
    import torch

    try:
        dev = torch.device(spec.device)
    except RuntimeError as e:
        raise ValueError(f"--device {spec.device!r}: {e}") from None
    if dev.type == "cuda" and not torch.cuda.is_available():
        raise ValueError(f"--device {spec.device}: PyTorch sees no CUDA device here (torch {torch.__version__}); "
                         f"train with --device cpu")
    if dev.type not in ("cpu", "cuda"):
        raise ValueError(f"--device {spec.device!r}: expected cpu, cuda or cuda:N")
    return dev


def train(spec: TrainSpec, log=print) -> Path:
    import torch

    torch.set_num_threads(spec.threads)
    dev = torch_device(spec)
    out = Path(spec.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    s, about = load_samples(spec)
    data_s = time.monotonic() - t0
    tr, ho = split(s)
    if len(tr) == 0 or len(ho) == 0:
        raise ValueError(f"{len(tr)} training and {len(ho)} held-out samples: the data need worlds of both kinds "
                         f"(held out: world id 9 mod 10)")
    log(f"vertibench.kino: {len(tr)} training, {len(ho)} held-out samples ({data_s:.0f} s to make)")
    torch.manual_seed(spec.seed)
    if spec.model not in km.MODELS:
        raise ValueError(f"--model {spec.model!r}: expected one of {sorted(km.MODELS)}")
    model = km.MODELS[spec.model](spec.members, spec.hidden).to(dev)
    opt = torch.optim.Adam(model.parameters(), lr=spec.lr)
    rng = np.random.default_rng(spec.seed)
    # Bootstrap: member m weighs training sample i by a Poisson(1) count (drawn once).
    boot = rng.poisson(1.0, size=(len(tr), spec.members)).astype(np.float32)
    ckpt, curve_path = out / "checkpoint.pt", out / "curve.csv"
    epoch, curve, train_s = resume(ckpt, model, opt, rng, log, "vertibench.kino")
    # Everything a batch reads is on the device once: a batch copies nothing to it and waits for nothing from it.
    inputs, tgt = [torch.from_numpy(a).to(dev) for a in s.inputs()], torch.from_numpy(s.target).to(dev)
    bw, tr_d = torch.from_numpy(boot).to(dev), torch.from_numpy(tr).to(dev)
    while epoch < spec.epochs:
        e0 = time.monotonic()
        model.train()
        order = torch.from_numpy(rng.permutation(len(tr))).to(dev)
        total = torch.zeros((), dtype=torch.float64, device=dev)
        for a in range(0, len(order), spec.batch):
            set_learning_rate(opt, spec, (epoch + a / len(order)) / spec.epochs)
            r = order[a:a + spec.batch]
            rows = tr_d[r]
            pred = model(*(x[rows] for x in inputs))  # [b, m, 7]
            err = ((pred - tgt[rows].unsqueeze(1)) ** 2).mean(2)  # [b, m]
            w = bw[r]
            loss = (err * w).sum() / w.sum().clamp(min=1.0)
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += loss.detach().double() * len(r)
        epoch += 1
        model.eval()
        h = rmse(model, s, ho)
        train_s += time.monotonic() - e0
        row = {"epoch": epoch, "wall_s": round(train_s, 1), "train_loss": float(total) / len(order),
               **{f"heldout_rmse_{n}": float(v) for n, v in zip(_core.KINO_TARGETS, h)}}
        curve.append(row)
        log(f"vertibench.kino: epoch {epoch}/{spec.epochs} loss {row['train_loss']:.4f} held-out RMSE "
            + " ".join(f"{n} {v:.3f}" for n, v in zip(_core.KINO_TARGETS, h)))
        save_checkpoint(ckpt, model, opt, rng, epoch, curve, train_s)
        write_curve(curve, curve_path)
    return finish(spec, model.cpu(), s, ho, about, curve, train_s, data_s)


def learning_rate(spec: TrainSpec, progress: float) -> float:
    """The learning rate at ``progress`` (0 at the first batch, 1 at the end of ``spec.epochs``): ``spec.lr`` held
    (``none``), or decayed to zero along half a cosine (``cosine``), so the last epoch's weights are not a point of
    a noisy walk. A function of the progress alone: a resumed run continues the schedule exactly."""
    if spec.lr_decay == "none":
        return spec.lr
    if spec.lr_decay == "cosine":
        return spec.lr * 0.5 * (1.0 + math.cos(math.pi * min(max(progress, 0.0), 1.0)))
    raise ValueError(f"lr_decay={spec.lr_decay!r}: expected one of {LR_DECAYS}")


def set_learning_rate(opt, spec: TrainSpec, progress: float) -> None:
    """Sets every parameter group of ``opt`` to :func:`learning_rate` at ``progress``."""
    for g in opt.param_groups:
        g["lr"] = learning_rate(spec, progress)


def resume(ckpt: Path, model, opt, rng: np.random.Generator, log, who: str) -> tuple[int, list[dict], float]:
    """Restores a run from its checkpoint, if it has one: (epoch, curve, training seconds), else a fresh start."""
    import torch

    if not ckpt.exists():
        return 0, [], 0.0
    c = torch.load(ckpt, weights_only=False, map_location=device_of(model))
    model.load_state_dict(c["model"])
    opt.load_state_dict(c["opt"])
    rng.bit_generator.state = c["rng"]
    log(f"{who}: resumed at epoch {c['epoch']}")
    return c["epoch"], c["curve"], c["train_s"]


def save_checkpoint(ckpt: Path, model, opt, rng: np.random.Generator, epoch: int, curve: list[dict],
                    train_s: float) -> None:
    import torch

    torch.save({"model": model.state_dict(), "opt": opt.state_dict(), "epoch": epoch, "curve": curve,
                "train_s": train_s, "rng": rng.bit_generator.state}, ckpt)


def write_curve(curve: list[dict], path: Path) -> None:
    import csv

    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(curve[0]))
        w.writeheader()
        w.writerows(curve)


def finish(spec: TrainSpec, model, s: kd.Samples, ho: np.ndarray, about: dict, curve: list[dict], train_s: float,
           data_s: float) -> Path:
    out = Path(spec.out)
    h = rmse(model, s, ho)
    factors = np.asarray(about["target_factors"])
    physical = {n: float(v * f) for n, v, f in zip(_core.KINO_TARGETS, h, factors)}
    card = {
        "name": spec.name, "model": spec.model, "layout": model.layout, "command": spec.command, "seed": spec.seed, "epochs": spec.epochs,
        "members": spec.members, "hidden": spec.hidden, "batch": spec.batch, "lr": spec.lr, "device": spec.device,
        "lr_decay": spec.lr_decay, "samples": len(s), "heldout_samples": int(len(ho)), "train_s": round(train_s, 1),
        "data_s": round(data_s, 1), "heldout_rmse_scaled": {n: float(v) for n, v in zip(_core.KINO_TARGETS, h)},
        "heldout_rmse_one_step": physical, "data": about["sets"], "vehicle": about["vehicle"],
        "scale": about["scale"], "task_set_version": about["task_set_version"],
        "sim_version": about["sim_version"], "parameters": sum(p.numel() for p in model.parameters()),
        **spec.extra,
    }
    meta = {"name": spec.name, "seed": spec.seed, "epochs": spec.epochs, "vehicle": about["vehicle"],
            "scale": about["scale"], "task_set_version": about["task_set_version"],
            "sim_version": about["sim_version"], "command": spec.command,
            "heldout_rmse_one_step": json.dumps(physical)}
    weights = out / f"{spec.model}.safetensors"
    km.save(model, weights, meta)
    (out / "card.json").write_text(json.dumps(card, indent=1))
    from .report import write_card, plot_curve

    write_card(card, out / "card.md")
    plot_curve(curve, out / "curve.png", spec.name)
    return weights

