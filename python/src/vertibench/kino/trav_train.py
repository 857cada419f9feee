"""Training TNT's traversability estimator (``python -m vertibench.kino train --model tnt``): binary cross-entropy of
the predicted grid against the labelled cells of each anchor (:mod:`.trav`), Adam, a fixed seed, one epoch at a
time with a checkpoint after each (a run resumes from its ``--out``), a learning curve (held-out cross-entropy, mean
absolute error per channel and the ROC AUC of the rare events stuck and rollover, which an error cannot judge) and,
at the end, ``tnt.safetensors`` with its card. The card also gives each channel's error when predicting the training
labels' mean everywhere: what the map adds."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from . import data as kd
from . import trav as tv
from .report import _kind
from .train import (TrainSpec, device_of, read_datasets, resume, save_checkpoint, set_learning_rate, torch_device,
                    write_curve)


def load_samples(spec: TrainSpec) -> tuple[tv.TravSamples, dict]:
    """The anchors of every dataset (cached in ``out/trav-samples.npz``) and what the card says about the data."""
    out = Path(spec.out)
    cache, about_path = out / "trav-samples.npz", out / "data.json"
    key = {"data": [str(Path(d).resolve()) for d in spec.data], "model": "tnt", "labels": tv.LABELS_VERSION}
    if cache.exists() and about_path.exists():
        about = json.loads(about_path.read_text())
        if all(about.get(k) == v for k, v in key.items()):
            z = np.load(cache)
            return tv.TravSamples(*(z[k] for k in ("map", "world", "start", "cell", "label"))), about
    parts, about, first = [], {**key, "sets": []}, None
    for d, ds_spec, eps, maker, first in read_datasets(spec, wheels=True):
        s = tv.samples(eps, maker, float(ds_spec["control_rate_hz"]), float(ds_spec["scale"]))
        parts.append(s)
        about["sets"].append({"path": str(d), "kind": ds_spec["kind"], "episodes": len(eps), "samples": len(s),
                              "entries": int(len(s.cell)), "seed": ds_spec["seed"],
                              "speed_profile": ds_spec.get("speed_profile", "constant")})
    if first is None:
        raise ValueError("no datasets given")
    about.update(vehicle=first[0], scale=first[1], task_set_version=first[2], sim_version=first[3])
    offsets = np.cumsum([0] + [len(p.cell) for p in parts[:-1]])
    allv = tv.TravSamples(np.concatenate([p.map for p in parts]), np.concatenate([p.world for p in parts]),
                          np.concatenate([[0]] + [p.start[1:] + o for p, o in zip(parts, offsets)]),
                          np.concatenate([p.cell for p in parts]), np.concatenate([p.label for p in parts]))
    out.mkdir(parents=True, exist_ok=True)
    np.savez(cache, map=allv.map, world=allv.world, start=allv.start, cell=allv.cell, label=allv.label)
    about_path.write_text(json.dumps(about, indent=1))
    return allv, about


#: The event channels whose held-out ranking is also reported (ROC AUC of the prediction against a label >= 0.5).
EVENTS = ("stuck", "rollover")
#: Each event's baseline: the channel whose ranking of the same positives says whether the event's own channel adds
#: anything (a map that shows where large rolls happen ranks rollovers already; the question is which of them tip).
BASELINE = {"stuck": "slip", "rollover": "roll"}


def roc_auc(score: np.ndarray, positive: np.ndarray) -> float | None:
    """The probability that a random positive scores above a random negative, ties counting half (Mann-Whitney's
    U over the two counts); ``None`` without both classes."""
    pos, n = int(positive.sum()), len(positive)
    if pos == 0 or pos == n:
        return None
    _, inv, counts = np.unique(score, return_inverse=True, return_counts=True)
    rank = (np.cumsum(counts) - (counts - 1) / 2.0)[inv]  # the mean 1-based rank of each tie group
    return float((rank[positive].sum() - pos * (pos + 1) / 2.0) / (pos * (n - pos)))


def evaluate(model, s: tv.TravSamples, rows: np.ndarray, batch: int = 1024) -> dict:
    """Held-out cross-entropy, mean absolute error per channel and the event channels' ROC AUC (with their
    positives' count) over the labelled entries of ``rows`` (computed on the model's device)."""
    import torch

    dev = device_of(model)
    bce, mae, n = 0.0, np.zeros(len(tv.CHANNELS)), 0
    ev = [tv.CHANNELS.index(c) for c in EVENTS]
    scored = ev + [tv.CHANNELS.index(BASELINE[c]) for c in EVENTS]  # each event's channel, then its baseline's
    preds, labels = [], []
    with torch.no_grad():
        for a in range(0, len(rows), batch):
            r = rows[a:a + batch]
            owner, cell, lab = s.entries(r)
            p = tv.gather(model(torch.from_numpy(s.map[r]).to(dev)), owner, cell)
            y = torch.from_numpy(lab).to(dev)
            bce += float(torch.nn.functional.binary_cross_entropy(p, y, reduction="sum"))
            mae += (p - y).abs().sum(0).cpu().numpy()
            n += len(lab)
            preds.append(p[:, scored].cpu().numpy())
            labels.append(lab[:, ev])
    n = max(n, 1)
    out = {"bce": bce / (n * len(tv.CHANNELS)), **{f"mae_{c}": float(v / n) for c, v in zip(tv.CHANNELS, mae)}}
    pr = np.concatenate(preds or [np.zeros((0, len(scored)))])
    positive = np.concatenate(labels or [np.zeros((0, len(ev)))]) >= 0.5
    for j, c in enumerate(EVENTS):
        out[f"auc_{c}"] = roc_auc(pr[:, j], positive[:, j])
        out[f"auc_{c}_by_{BASELINE[c]}"] = roc_auc(pr[:, len(ev) + j], positive[:, j])
        out[f"positives_{c}"] = int(positive[:, j].sum())
    return out


def _fmt(v) -> str:
    return "-" if v is None else str(v) if isinstance(v, int) else f"{v:.3f}"


def train(spec: TrainSpec, log=print) -> Path:
    import torch

    torch.set_num_threads(spec.threads)
    dev = torch_device(spec)
    out = Path(spec.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    s, about = load_samples(spec)
    data_s = time.monotonic() - t0
    held = (s.world % 10) == kd.HELD_OUT
    tr, ho = np.flatnonzero(~held), np.flatnonzero(held)
    if len(tr) == 0 or len(ho) == 0:
        raise ValueError(f"{len(tr)} training and {len(ho)} held-out anchors: the data need worlds of both kinds "
                         f"(held out: world id 9 mod 10)")
    log(f"vertibench.kino tnt: {len(tr)} training, {len(ho)} held-out anchors, {len(s.cell)} labelled cells "
        f"({data_s:.0f} s to make)")
    torch.manual_seed(spec.seed)
    model = tv.model(spec.hidden).to(dev)
    opt = torch.optim.Adam(model.parameters(), lr=spec.lr)
    rng = np.random.default_rng(spec.seed)
    ckpt, curve_path = out / "checkpoint.pt", out / "curve.csv"
    epoch, curve, train_s = resume(ckpt, model, opt, rng, log, "vertibench.kino tnt")
    maps = torch.from_numpy(s.map).to(dev)
    while epoch < spec.epochs:
        e0 = time.monotonic()
        model.train()
        order = rng.permutation(tr)
        total, count = torch.zeros((), dtype=torch.float64, device=dev), 0
        for a in range(0, len(order), spec.batch):
            set_learning_rate(opt, spec, (epoch + a / len(order)) / spec.epochs)
            r = order[a:a + spec.batch]
            owner, cell, lab = s.entries(r)
            if len(lab) == 0:
                continue
            p = tv.gather(model(maps[torch.from_numpy(r).to(dev)]), owner, cell)
            loss = torch.nn.functional.binary_cross_entropy(p, torch.from_numpy(lab).to(dev))
            opt.zero_grad()
            loss.backward()
            opt.step()
            total, count = total + loss.detach().double() * len(lab), count + len(lab)
        epoch += 1
        model.eval()
        h = evaluate(model, s, ho)
        train_s += time.monotonic() - e0
        row = {"epoch": epoch, "wall_s": round(train_s, 1), "train_bce": float(total) / max(count, 1),
               **{f"heldout_{k}": v for k, v in h.items()}}
        curve.append(row)
        log(f"vertibench.kino tnt: epoch {epoch}/{spec.epochs} loss {row['train_bce']:.4f} held-out "
            + " ".join(f"{k} {_fmt(v)}" for k, v in h.items()))
        save_checkpoint(ckpt, model, opt, rng, epoch, curve, train_s)
        write_curve(curve, curve_path)
    return finish(spec, model.cpu(), s, tr, ho, about, curve, train_s, data_s)


def finish(spec: TrainSpec, model, s: tv.TravSamples, tr: np.ndarray, ho: np.ndarray, about: dict,
           curve: list[dict], train_s: float, data_s: float) -> Path:
    out = Path(spec.out)
    h = evaluate(model, s, ho)
    _, _, lab_tr = s.entries(tr)
    _, _, lab_ho = s.entries(ho)
    base = {c: float(np.abs(lab_ho[:, j] - lab_tr[:, j].mean()).mean()) for j, c in enumerate(tv.CHANNELS)}
    card = {"name": spec.name, "model": "tnt", "layout": tv.LAYOUT, "command": spec.command, "seed": spec.seed,
            "epochs": spec.epochs, "width": spec.hidden, "batch": spec.batch, "lr": spec.lr, "lr_decay": spec.lr_decay,
            "device": spec.device, "anchors": len(s), "labels_version": tv.LABELS_VERSION,
            "heldout_anchors": int(len(ho)), "labelled_cells": int(len(s.cell)), "train_s": round(train_s, 1),
            "data_s": round(data_s, 1), "heldout": h, "heldout_mae_of_the_mean": base, "data": about["sets"],
            "vehicle": about["vehicle"], "scale": about["scale"], "task_set_version": about["task_set_version"],
            "sim_version": about["sim_version"], "parameters": sum(p.numel() for p in model.parameters())}
    meta = {"name": spec.name, "seed": spec.seed, "epochs": spec.epochs, "vehicle": about["vehicle"],
            "scale": about["scale"], "task_set_version": about["task_set_version"],
            "sim_version": about["sim_version"], "command": spec.command, "heldout": json.dumps(h)}
    weights = out / "tnt.safetensors"
    tv.save(model, weights, meta)
    (out / "card.json").write_text(json.dumps(card, indent=1))
    lines = [f"# {spec.name}: traversability estimator ({tv.LAYOUT})", "", f"- command: `{spec.command}`",
             "- data: " + "; ".join(f"{_kind(d)} {d['episodes']} episodes, {d['samples']} anchors (seed {d['seed']})"
                                    for d in about["sets"]),
             f"- task set version {about['task_set_version']} (training worlds only; worlds 9 mod 10 held out), "
             f"simulator {about['sim_version']}, vehicle {about['vehicle']} at scale {about['scale']}",
             f"- seed {spec.seed}, {spec.epochs} epochs (learning rate {spec.lr:g}, {spec.lr_decay} decay), "
             f"width {spec.hidden}, {card['parameters']} parameters; "
             f"{card['train_s']} s training on {spec.device}, {card['data_s']} s making samples", "",
             "## Held-out error per labelled cell", "", "| channel | MAE | MAE of the training mean |", "|---|---|---|"]
    lines += [f"| {c} | {h[f'mae_{c}']:.4f} | {base[c]:.4f} |" for c in tv.CHANNELS]
    lines += ["", f"Held-out binary cross-entropy: {h['bce']:.4f}. Labels version {tv.LABELS_VERSION}.", "",
              "## Held-out ranking of the events (ROC AUC; predicting the mean everywhere: 0.5)", "",
              "| event | ROC AUC | ROC AUC of the baseline channel | held-out cells labelled >= 0.5 |",
              "|---|---|---|---|"]
    lines += [f"| {c} | {_fmt(h[f'auc_{c}'])} | {BASELINE[c]}: {_fmt(h[f'auc_{c}_by_{BASELINE[c]}'])} | "
              f"{h[f'positives_{c}']} |" for c in EVENTS]
    (out / "card.md").write_text("\n".join(lines) + "\n")
    return weights
