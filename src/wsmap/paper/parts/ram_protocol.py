"""RAM's protocol: wsmap's labels and its pose-conditioned network scored the way RAM scores (issue 42).

RAM (Walter et al., *RAM: Reachability Across Morphologies*, arXiv 2606.09108; code TimWalter/ram)
reports, for held-out random arms of 5-7 revolute joints, F1 0.86 on random poses and 0.78 on a
boundary set, and F1 0.91 of its FK-sampling training labels against exact ones
(`wsmap.datasets.RAM_PUBLISHED`). Its checkpoint is not reachable from here, so its published
numbers stand beside ours. `wsmap.datasets.ram` rebuilds its protocol (arms, poses, labels, F1;
where each detail comes from is in that module's notes).

This part, from its params section:

* **Arms and poses**: `train_arms` RAM arms per joint count (5, 6, 7) in resumable shards of
  `arms_per_shard` (`wsmap.learn.pose_model.build_pose_shards`, seeds `seed ..`), and
  `test_arms` held-out arms per joint count from an independent stream (seed `TEST_SEED +
  seed`); per arm `poses` of RAM's random poses and `geodesics` x `per_geodesic` poses of its
  boundary set. The reference labels: RAM's label definition (IK with its capsule
  self-collision) computed by wsmap's search (`ik_labels`, `starts` starts and 8 rounds of
  other first starts); RAM's FK poses of 5-joint arms labelled reachable without IK, as RAM does.
* **(a) wsmap's classical labels against RAM's definition** on the held-out arms' poses: without
  self-collision (the kinematic reach), with RAM's IK budget (`RAM_IK_STARTS` starts, no extra
  rounds) and `wsmap.reachable` as it is (`starts` starts, no extra rounds).
* **(b) an FK-sampling labeller like RAM's** (`fk_labels`: configurations uniform over the full
  turn mark their SE(3) cells) at the levels `fk.levels` and the budgets `fk.samples` per arm,
  against the reference labels (RAM's authors: 0.91 at level 3).
* **(c) the pose-conditioned network** (`wsmap.learn.pose_model`) trained on the training
  shards' exact labels, its threshold chosen on its validation arms, scored on the held-out arms.

F1 is RAM's (`ram_f1`: per arm, then the mean over arms), per set (random poses, boundary set).
The compute is recorded beside it: wall and process CPU seconds of the labels and of the
training, the CPU cores the process may use, the threads and the training device. The trained
network is the stage's model file (`models/ram_pose.pt`).
"""

from __future__ import annotations

import os
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypedDict

import numpy as np
import pandas as pd
import torch

from ...datasets import ram
from ...io import write_json, write_table
from ...kinematics import lm_compiled
from ...learn import TrainConfig
from ...learn import pose_model as pm
from ...learn.device import resolve_device
from ...paths import Outputs
from . import Part, check_metrics, register, save_figure

#: Where RAM's numbers come from, as the README cites it.
RAM_SOURCE = "Walter et al., arXiv 2606.09108 (code TimWalter/ram)"
#: RAM's compute for its published network (issue 42): 3·10⁴ training arms, 360 H100-hours of
#: data (FK sampling), 57 h of training.
RAM_COMPUTE = "3·10⁴ arms; 360 H100-hours of FK-sampled data, 57 h of training"
#: RAM's IK budget for its test labels: Levenberg-Marquardt from 10 random seeds (`kinematics.py`).
RAM_IK_STARTS = 10
#: The held-out arms' seed is this plus `seed`: a stream no training shard draws from.
TEST_SEED = 10_000
#: The two pose sets, in the tables' order.
SETS = ("random", "boundary")
#: (a): the label variants scored against the reference, in the table's order.
VARIANTS = ("kinematic", "ram_budget", "reachable")


class Metrics(TypedDict):
    """`results/ram_protocol.json`."""

    arms: dict  #: "train" and "test": arms per joint count ("5", "6", "7")
    poses: dict  #: per arm: random, geodesics, per_geodesic, boundary (= geodesics * per_geodesic); starts
    reachable_share: dict  #: set -> share of the held-out poses reachable by the reference labels
    labels: dict  #: (a) variant -> set -> {f1, f1_min (worst arm), f1_by_dof, reachable_share}
    fk_labels: list  #: (b) one row per (level, samples): level, samples, and per set f1, f1_by_dof, reachable_share
    model: dict  #: (c) set -> {f1, f1_by_dof}; threshold, epochs, best_epoch, training_arms, training_poses
    ram_published: dict  #: RAM's F1s (random, boundary, FK labels) and its source
    compute: dict  #: seconds (wall and process CPU) of every label kind and of the training, cpu_cores, threads, device


PART = Part("ram_protocol", "RAM's protocol: wsmap's labels and pose network beside RAM's numbers", 107, outputs=(
    "data/ram_pose", "models/ram_pose.pt", "results/ram_protocol.json",
    "tables/ram_protocol.csv", "tables/ram_protocol.md", "figures/ram_protocol_f1.png"))


@dataclass
class Result:
    metrics: Metrics
    model: Any  #: the trained `PoseMapModel`
    table: pd.DataFrame  #: one row per labeller or network: F1 per set, beside RAM's published rows


@dataclass
class _HeldOut:
    """The held-out arms of one joint count: RAM tables, poses, reference labels, FK-pose mask."""

    dof: int
    morphs: np.ndarray  # (n, dof + 1, 3)
    T: np.ndarray  # (n, P, 4, 4)
    labels: np.ndarray  # (n, P) bool
    known: np.ndarray  # (n, P) bool


def _check(cfg: Mapping) -> dict:
    """The section's counts as integers (one-line `ValueError` naming the key, before any work)."""
    where = getattr(cfg, "source", "ram_protocol")
    n = {"train_arms": cfg["train_arms"], "arms_per_shard": cfg["arms_per_shard"], "test_arms": cfg["test_arms"],
         "poses": cfg["poses"], "geodesics": cfg["geodesics"], "per_geodesic": cfg["per_geodesic"],
         "starts": cfg["starts"], "threads": cfg["threads"], "seed": cfg["seed"]}
    for key, v in n.items():
        low = {"per_geodesic": 2, "seed": 0}.get(key, 1)
        if isinstance(v, bool) or not isinstance(v, int) or v < low:
            raise ValueError(f"{where}: {key} must be an integer of at least {low}, got {v!r}")
    if n["train_arms"] % n["arms_per_shard"]:
        raise ValueError(f"{where}: train_arms ({n['train_arms']}) must be a multiple of arms_per_shard "
                         f"({n['arms_per_shard']})")
    samples, levels = list(cfg["fk"]["samples"]), list(cfg["fk"]["levels"])
    if not samples or any(isinstance(b, bool) or not isinstance(b, int) or b < 1 for b in samples) or \
            any(b1 <= b0 for b0, b1 in zip(samples, samples[1:])):
        raise ValueError(f"{where}: fk.samples must be increasing positive counts, got {samples!r}")
    if not levels or any(v not in ram.RAM_R3_DIVISIONS for v in levels):
        raise ValueError(f"{where}: fk.levels must be among 1, 2, 3, 4 (RAM's levels), got {levels!r}")
    n["fk"] = {"samples": samples, "levels": levels}
    return n


def _f1(pred: np.ndarray, truth: np.ndarray, dofs: np.ndarray) -> dict:
    """RAM's F1 of `(arms, poses)` labels: the mean, the worst arm's and the mean per joint count."""
    f, per = ram.ram_f1(pred, truth)
    return {"f1": f, "f1_min": float(per.min()),
            "f1_by_dof": {str(d): float(per[dofs == d].mean()) for d in np.unique(dofs)}}


def _held_out(n: dict) -> tuple[list[_HeldOut], float, float]:
    """The held-out arms of every joint count with their poses and reference labels; wall and CPU
    seconds of the labels."""
    sets, w0, c0 = [], time.perf_counter(), time.process_time()
    for d in ram.RAM_DOFS:
        morphs = ram.sample_morphologies(n["test_arms"], d, seed=TEST_SEED + n["seed"])
        _, labels, T, known = pm.pose_training_set(morphs, n["poses"], n["geodesics"], n["per_geodesic"],
                                                   TEST_SEED + n["seed"], starts=n["starts"], with_poses=True)
        sets.append(_HeldOut(d, morphs, T, labels, known))
    return sets, time.perf_counter() - w0, time.process_time() - c0


def _variants(test: list[_HeldOut], starts: int) -> tuple[dict[str, np.ndarray], float]:
    """(a): each label variant of every held-out pose `(arms, P)` (a loop over arms, each a batch of
    its poses), the FK poses labelled reachable as in the reference; wall seconds."""
    out = {v: [] for v in VARIANTS}
    t0 = time.perf_counter()
    for h in test:
        for m, T, known in zip(h.morphs, h.T, h.known):
            check = ram.ram_collision(m)
            out["kinematic"].append(ram.ik_labels(m, T, self_collision=False, starts=starts) | known)
            out["ram_budget"].append(ram.ik_labels(m, T, starts=RAM_IK_STARTS, rounds=0, collision=check) | known)
            out["reachable"].append(ram.ik_labels(m, T, starts=starts, rounds=0, collision=check) | known)
    return {v: np.array(p) for v, p in out.items()}, time.perf_counter() - t0


def _fk(test: list[_HeldOut], fk: dict, seed: int) -> tuple[np.ndarray, float]:
    """(b): FK-sampling labels `(arms, levels, budgets, P)` of every held-out pose; wall seconds."""
    out, t0, k = [], time.perf_counter(), 0
    for h in test:
        for m, T in zip(h.morphs, h.T):
            out.append(ram.fk_labels(m, T, fk["samples"], seed=seed + k, level=fk["levels"]))
            k += 1
    return np.array(out), time.perf_counter() - t0


def _train_config(t: Mapping, seed: int, device: str) -> TrainConfig:
    return TrainConfig(optimizer="adam", optimizer_kwargs={"lr": float(t["lr"])}, loss="crossentropy",
                       batch_size=int(t["batch_size"]), lr_decay="cosine", max_epochs=int(t["epochs"]), max_fail=1000,
                       fractions=(0.95, 0.05, 0.0), seed=seed, device=device)


def run(cfg: Mapping, out: Outputs) -> Result:
    """Draw RAM's arms and poses, label them, score (a), (b) and (c) per set (module notes).
    `cfg`: the `ram_protocol` params section."""
    n = _check(cfg)
    device = resolve_device(cfg["device"], f"{getattr(cfg, 'source', 'ram_protocol')} device")  # before any work
    model_cfg = pm.PoseModelConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in cfg["model"].items()})
    torch.set_num_threads(n["threads"])
    lm_compiled.set_threads(n["threads"])
    R, B = n["poses"], n["geodesics"] * n["per_geodesic"]
    kw = {"random": R, "geodesics": n["geodesics"], "per_geodesic": n["per_geodesic"], "starts": n["starts"]}

    w0 = time.perf_counter()
    shards = pm.build_pose_shards(Path(out.root) / "data" / "ram_pose", ram.RAM_DOFS,
                                  n["train_arms"] // n["arms_per_shard"], n["arms_per_shard"], first_seed=n["seed"], **kw)
    train_label_wall = time.perf_counter() - w0
    test, test_wall, test_cpu = _held_out(n)
    variants, variant_wall = _variants(test, n["starts"])
    fk, fk_wall = _fk(test, n["fk"], n["seed"])

    w0, c0 = time.perf_counter(), time.process_time()
    model, res = pm.fit_pose_model(shards, model_cfg, _train_config(cfg["train"], n["seed"], str(device)),
                                   seed=n["seed"])
    train_wall, train_cpu = time.perf_counter() - w0, time.process_time() - c0

    dofs = np.concatenate([np.full(len(h.morphs), h.dof) for h in test])
    truth = np.concatenate([h.labels for h in test])
    pred = np.concatenate([pm.predict_poses(model, h.morphs, h.T) for h in test])
    cols = {"random": slice(0, R), "boundary": slice(R, R + B)}
    labels = {v: {s: _f1(variants[v][:, c], truth[:, c], dofs) | {"reachable_share": float(variants[v][:, c].mean())}
                  for s, c in cols.items()} for v in VARIANTS}
    fk_rows = [{"level": int(lv), "samples": int(b),
                **{s: _f1(fk[:, li, bi, c], truth[:, c], dofs) | {"reachable_share": float(fk[:, li, bi, c].mean())}
                   for s, c in cols.items()}}
               for li, lv in enumerate(n["fk"]["levels"]) for bi, b in enumerate(n["fk"]["samples"])]
    label_cpu = float(sum(s.cpu_seconds for s in shards))
    metrics: Metrics = {
        "arms": {"train": {str(d): n["train_arms"] for d in ram.RAM_DOFS},
                 "test": {str(d): n["test_arms"] for d in ram.RAM_DOFS}},
        "poses": {"random": R, "geodesics": n["geodesics"], "per_geodesic": n["per_geodesic"], "boundary": B,
                  "starts": n["starts"]},
        "reachable_share": {s: float(truth[:, c].mean()) for s, c in cols.items()},
        "labels": labels,
        "fk_labels": fk_rows,
        "model": {**{s: _f1(pred[:, c], truth[:, c], dofs) for s, c in cols.items()},
                  "threshold": float(model.threshold), "epochs": int(res.stop_epoch), "best_epoch": int(res.best_epoch),
                  "training_arms": int(sum(len(s.morphs) for s in shards)),
                  "training_poses": int(sum(s.labels.size for s in shards)),
                  "training_reachable_share": float(np.mean(np.concatenate([s.labels.ravel() for s in shards])))},
        "ram_published": {**ram.RAM_PUBLISHED, "source": RAM_SOURCE, "compute": RAM_COMPUTE},
        "compute": {
            "train_label_cpu_seconds": label_cpu,  # the shards' own record: kept when a shard is reused
            "train_label_wall_seconds": train_label_wall,  # this run's: near 0 when every shard was there
            "train_label_cpu_seconds_per_arm": label_cpu / sum(len(s.morphs) for s in shards),
            "test_label_wall_seconds": test_wall, "test_label_cpu_seconds": test_cpu,
            "variant_label_wall_seconds": variant_wall, "fk_label_wall_seconds": fk_wall,
            "fk_label_seconds_per_arm": fk_wall / len(dofs),
            "train_wall_seconds": train_wall, "train_cpu_seconds": train_cpu,
            "core_hours": (label_cpu + test_cpu + train_cpu) / 3600.0,
            "cpu_cores": len(os.sched_getaffinity(0)), "threads": n["threads"], "device": str(device)},
    }
    check_metrics(metrics, Metrics, "ram_protocol")
    return Result(metrics, model, _table(metrics, n["fk"]))


def _table(metrics: Metrics, fk: dict) -> pd.DataFrame:
    """One row per labeller or network, F1 per set, RAM's published rows beside ours."""
    c = metrics["compute"]
    pub = metrics["ram_published"]
    mdl = metrics["model"]
    rows = [
        {"what": "RAM's network on held-out arms (published)", "source": RAM_SOURCE, "f1_random": pub["f1_random"],
         "f1_boundary": pub["f1_boundary"], "compute": RAM_COMPUTE},
        {"what": "wsmap pose model on held-out arms (exact IK labels)", "source": "here",
         "f1_random": mdl["random"]["f1"], "f1_boundary": mdl["boundary"]["f1"],
         "compute": f"{mdl['training_arms']} arms; labels {c['train_label_cpu_seconds']:.0f} core-s, training "
                    f"{c['train_cpu_seconds']:.0f} core-s ({c['device']}, threads: {c['threads']})"},
        {"what": "RAM's FK labels against exact, level 3 (published, one F1)", "source": RAM_SOURCE,
         "f1_random": pub["f1_fk_labels"], "f1_boundary": np.nan, "compute": "GPU, 30-600 s per arm"},
    ]
    for r in metrics["fk_labels"]:
        rows.append({"what": f"FK labels against exact, level {r['level']}, {r['samples']:,} samples per arm",
                     "source": "here", "f1_random": r["random"]["f1"], "f1_boundary": r["boundary"]["f1"],
                     "compute": f"{c['fk_label_seconds_per_arm']:.1f} s per arm for all levels and budgets"})
    names = {"kinematic": "wsmap labels without self-collision, against RAM's definition",
             "ram_budget": f"wsmap labels, RAM's IK budget ({RAM_IK_STARTS} starts, no extra rounds)",
             "reachable": f"wsmap.reachable as it is ({metrics['poses']['starts']} starts, no extra rounds)"}
    for v in VARIANTS:
        rows.append({"what": names[v], "source": "here", "f1_random": metrics["labels"][v]["random"]["f1"],
                     "f1_boundary": metrics["labels"][v]["boundary"]["f1"], "compute": ""})
    return pd.DataFrame(rows)


def save(result: Result, out: Outputs) -> None:
    """The model file, the table and the metrics file."""
    m = result.metrics
    pm.save_pose_model(result.model, out.models / "ram_pose.pt",
                       extra={"f1_random": m["model"]["random"]["f1"], "f1_boundary": m["model"]["boundary"]["f1"],
                              "held_out_arms": m["arms"]["test"], "stage": "ram_protocol"})
    write_table(result.table, out.tables / "ram_protocol")
    write_json(m, out.results / "ram_protocol.json")


def figures(result: Result, out: Outputs) -> list[Path]:
    """F1 per set of every row of the table (RAM's published numbers hatched)."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    t = result.table
    fig, ax = plt.subplots(figsize=(9, 0.42 * len(t) + 1.6))
    y = np.arange(len(t))[::-1]
    colours = {"random": "tab:blue", "boundary": "tab:orange"}
    for k, s in enumerate(SETS):
        v = t[f"f1_{s}"].to_numpy(dtype=float)
        bars = ax.barh(y + (0.2 if k == 0 else -0.2), np.nan_to_num(v), 0.4, color=colours[s])
        for b, src in zip(bars, t.source):
            if src != "here":
                b.set_hatch("//")
    ax.set_yticks(y, list(t.what), fontsize=7)
    ax.set_xlim(0, 1)
    ax.set_xlabel("F1 (RAM's: per arm, mean over arms)")
    arms = sum(result.metrics["arms"]["test"].values())
    ax.set_title(f"RAM's protocol, {arms} held-out RAM arms (5-7 joints)", fontsize=9)
    handles = [Patch(color=colours[s], label=f"{s} poses") for s in SETS]
    handles.append(Patch(facecolor="white", edgecolor="black", hatch="//", label=f"RAM, published ({RAM_SOURCE})"))
    ax.legend(handles=handles, fontsize=7, loc="upper center", bbox_to_anchor=(0.4, -0.09), ncol=3, frameon=False)
    ax.grid(True, axis="x", alpha=0.3)
    fig.tight_layout()
    return [save_figure(fig, out.figures / "ram_protocol_f1.png")]


register(PART)
