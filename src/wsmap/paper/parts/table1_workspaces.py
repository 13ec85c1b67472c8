"""Table 1: the §6.1 network trained on eight other maps of the spherical-wrist family.

Constant-orientation ("R3") maps over [-1, 1]³ at R = I (grid step 1, 0.5, and 0.1: block 5, the
crop to z = 0.8, the whole 21³ grid) and orientation ("SO3") maps over [0, 2π]³ at a fixed point;
one model per row (`wsmap.paper.tables.table1`), F pooled over every test arm and node.
The paper-scale runner (`wsmap.paper.full`, through `SCALE`) trains the same rows, one unit
per row and one session per step, and
summarises them with the same `wsmap.paper.tables.table1_summary`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict

import numpy as np
import pandas as pd

from ...io import jsonable, plus_minus
from ...learn.device import resolve_device
from ...learn.training import TrainConfig
from ...paths import Outputs
from .. import tables
from ..scale import Data, Planner, Scale, Unit, step_runs
from ..specs import whole_param
from . import Part, check_metrics, register, save_figure, save_tables


class Metrics(TypedDict):
    """`results/table1_workspaces.json`: per-dataset mappings (dataset name -> value) of the table's
    columns, and the run's totals."""

    f: dict[str, float]  #: pooled F, mean over sessions
    precision: dict[str, float]
    recall: dict[str, float]
    f_sample_mean: dict[str, float]  #: mean over test arms of each arm's F
    f_sample_std: dict[str, float]
    paper_f: dict[str, float]  #: `wsmap.paper.published.PAPER_TABLE1`
    difference: dict[str, float]  #: F − paper F
    nodes: dict[str, int]
    train_samples: dict[str, int]
    epochs: dict[str, float]  #: epochs run, mean over sessions
    seconds: dict[str, float]  #: training wall time, mean over sessions
    total_training_seconds: float
    device: str
    config: dict  #: the params section


@dataclass
class Result:
    metrics: Metrics
    table: pd.DataFrame  #: `wsmap.paper.tables.table1_summary`
    runs: pd.DataFrame  #: one row per (dataset, session)

    def shown(self) -> pd.DataFrame:
        """The table as the notebook shows it: ours beside the paper's, ± written out."""
        t = self.table
        return t.assign(
            f_sample=[plus_minus(m, s) for m, s in zip(t.f_sample_mean, t.f_sample_std)],
            paper=[plus_minus(m, s, 4) for m, s in zip(t.paper_f, t.paper_f_std)],
        )[["workspace", "delta", "nodes", "train_samples", "paper_samples", "epochs", "seconds", "precision",
           "recall", "f", "f_sample", "paper", "difference"]]


def run(cfg: Mapping, out: Outputs) -> Result:
    """Train and score one model per dataset of params section `cfg` (datasets in `out.data`)."""
    device = resolve_device(cfg["device"], f"{cfg.source} device")  # before any work: cuda without a GPU fails here
    config = TrainConfig(optimizer=cfg["optimizer"], loss=cfg["loss"], max_fail=cfg["max_fail"], seed=cfg["seed"],
                         device=device)
    table, runs = tables.table1(out.data, cfg["datasets"], config=config, train_samples=cfg["train_samples"],
                                max_epochs=cfg["max_epochs"], sessions=cfg["sessions"], hidden=cfg["hidden"])
    if list(table.dataset) != list(cfg["datasets"]):
        raise RuntimeError(f"Table 1 has rows {list(table.dataset)}, not {list(cfg['datasets'])}")

    def by_dataset(column):
        return {d: v for d, v in zip(table.dataset, table[column])}

    metrics = jsonable({
        "f": by_dataset("f"),
        "precision": by_dataset("precision"),
        "recall": by_dataset("recall"),
        "f_sample_mean": by_dataset("f_sample_mean"),
        "f_sample_std": by_dataset("f_sample_std"),
        "paper_f": by_dataset("paper_f"),
        "difference": by_dataset("difference"),
        "nodes": by_dataset("nodes"),
        "train_samples": by_dataset("train_samples"),
        "epochs": by_dataset("epochs"),
        "seconds": by_dataset("seconds"),
        "total_training_seconds": float(runs.seconds.sum()),
        "device": str(device),
        "config": cfg,
    })
    return Result(check_metrics(metrics, Metrics, PART.name), table, runs)


def save(result: Result, out: Outputs) -> None:
    """The metrics file and the three tables (summary, per run, as shown)."""
    save_tables(out, PART.name, result.table, result.runs, result.shown(), result.metrics, tables.COUNT_COLUMNS)


def figures(result: Result, out: Outputs) -> list[Path]:
    """Bars of our F beside the paper's, per workspace."""
    import matplotlib.pyplot as plt

    table = result.table
    labels = [f"{w} Δ={d}\n{n} nodes" for w, d, n in zip(table.workspace, table.delta, table.nodes)]
    x = np.arange(len(table))
    fig, ax = plt.subplots(figsize=(11, 4.2))
    ax.bar(x - 0.2, table.f, 0.4, label="ours (pooled F)", color="#1f4e79")
    ax.bar(x + 0.2, table.paper_f, 0.4, label="paper", color="#bbbbbb", edgecolor="k", hatch="//")
    for xi, f in zip(x, table.f):
        ax.text(xi - 0.2, (0 if np.isnan(f) else f) + 0.01, "NaN" if np.isnan(f) else f"{f:.3f}", ha="center",
                fontsize=8)
    ax.set_xticks(x, labels, fontsize=8)
    ax.set_ylim(0, 1.1)
    ax.set_ylabel("F-measure")
    ax.set_title("Table 1: F-measure of the [125, 100, 100, 125] network per workspace (Rprop + MSE)")
    ax.legend(loc="lower left")
    return [save_figure(fig, out.figures / "table1_workspaces.png")]


# --------------------------------------------------------------------------------------------
# The paper's scale (`wsmap paper full table1`): one unit per row, one session per step
# --------------------------------------------------------------------------------------------


def scale_plan(cfg: Mapping, planner: Planner) -> list[Unit]:
    """A unit per dataset (row) of params section `cfg`, named after it, with that dataset's
    `train_samples`, `max_epochs` and `sessions` (a number, or one per dataset); a step per
    session."""
    units = []
    for name in cfg["datasets"]:
        where = f"{cfg.source}, dataset {name!r}"
        max_epochs = whole_param(where, "max_epochs", tables.per_dataset(cfg["max_epochs"], name), 1)
        n_sessions = whole_param(where, "sessions", tables.per_dataset(cfg["sessions"], name), 1)
        values = {"dataset": name, "train_samples": tables.per_dataset(cfg["train_samples"], name),
                  "sessions": n_sessions, "max_epochs": max_epochs, "max_fail": cfg["max_fail"],
                  "hidden": cfg["hidden"], "seed": cfg["seed"], "optimizer": cfg["optimizer"], "loss": cfg["loss"],
                  "threshold": 0.5}
        units.append(planner.unit(name, SCALE, cfg, planner.sessions(cfg, n_sessions), [name], values,
                                  planner.train_config(cfg["optimizer"], cfg["loss"], max_epochs, cfg["max_fail"],
                                                       cfg["seed"], cfg.source),
                                  f"Table 1 row {name}"))
    return units


def scale_finalize(unit: Unit, steps: dict[str, dict], data: Data, out: Path) -> tuple[dict, list]:
    """The row's `wsmap.paper.tables.table1_summary` over its sessions, their number, and the
    sessions' score rows (`runs`, with their `dataset`)."""
    runs = step_runs(steps)
    runs.insert(0, "dataset", unit.values["dataset"])
    metrics = {**tables.table1_summary(runs).iloc[0].to_dict(), "sessions": int(len(runs))}
    metrics["runs"] = runs.to_dict("records")
    return metrics, []


SCALE = Scale(kind="table1", plan=scale_plan, finalize=scale_finalize, added_columns=("dataset",))

PART = Part("table1_workspaces", "Table 1: F-measures of other workspace models", 40, outputs=(
    "results/table1_workspaces.json", "tables/table1_workspaces.csv", "tables/table1_workspaces.md",
    "tables/table1_workspaces_display.csv", "tables/table1_workspaces_display.md",
    "tables/table1_workspaces_runs.csv", "tables/table1_workspaces_runs.md", "figures/table1_workspaces.png"), scale=SCALE)
register(PART)
