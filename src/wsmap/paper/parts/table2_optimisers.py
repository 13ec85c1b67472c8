"""Table 2: the §6.1 network on block 5 with five full-batch optimisers and three losses.

Every optimiser with every loss (`wsmap.paper.tables.table2`), `sessions` sessions each,
the same epoch budget for all; cross entropy on logits (see `wsmap.paper.tables`). The
paper-scale runner (`wsmap.paper.full`, through `SCALE`) trains the Rprop + MSE cell and summarises it with the
same `wsmap.paper.tables.table2_summary`.
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
from ..published import PAPER_TABLE2
from ..scale import Data, Planner, Scale, Unit, step_runs
from ..specs import load_pair
from . import Part, register, save_figure, save_tables
from . import check_metrics as check_schema

#: The keys of each cell `<optimizer>_<loss>` of the metrics (`Metrics`).
CELL_KEYS = ("f_mean", "f_std", "f_sample_mean", "f_sample_std", "precision", "recall", "epochs", "seconds",
             "paper_f", "paper_f_std", "difference")


class Metrics(TypedDict):
    """`results/table2_optimisers.json`: besides these keys, one mapping per cell, keyed
    `<optimizer>_<loss>` (`rprop_mse`, ...), with the `CELL_KEYS` (F mean and σ over
    sessions, per-arm F mean and σ, precision, recall, epochs, seconds, the paper's F ± σ, difference)."""

    best_cell: str | None  #: the cell of highest mean F
    paper_best_cell: str  #: the paper's
    sessions: int
    train_samples: int
    total_training_seconds: float
    device: str
    config: dict


def check_metrics(metrics: Mapping) -> dict:
    """`metrics` unchanged when it holds `Metrics`' keys and, beside them, cells of exactly
    `CELL_KEYS`; else a `ValueError`."""
    return dict(check_schema(metrics, Metrics, PART.name, other=f"have cells not of {CELL_KEYS}:",
                             beside=lambda key, value: isinstance(value, dict) and tuple(value) == CELL_KEYS))


@dataclass
class Result:
    metrics: dict
    summary: pd.DataFrame  #: `wsmap.paper.tables.table2_summary`
    runs: pd.DataFrame
    cfg: Mapping

    def shown(self) -> pd.DataFrame:
        s = self.summary
        return s.assign(
            ours=[plus_minus(m, sd) for m, sd in zip(s.f_mean, s.f_std)],
            per_arm=[plus_minus(m, sd) for m, sd in zip(s.f_sample_mean, s.f_sample_std)],
            paper=[plus_minus(m, sd) for m, sd in zip(s.paper_f, s.paper_f_std)],
        )[["method", "loss", "sessions", "epochs", "seconds", "precision", "recall", "ours", "per_arm", "paper",
           "difference"]]

    def wide(self) -> pd.DataFrame:
        """Mean F by optimiser (rows) and loss (columns), ours beside the paper's."""
        s, cfg = self.summary, self.cfg
        ours = s.pivot(index="optimizer", columns="loss_key", values="f_mean").reindex(
            index=cfg["optimizers"], columns=cfg["losses"])
        paper = s.pivot(index="optimizer", columns="loss_key", values="paper_f").reindex(
            index=cfg["optimizers"], columns=cfg["losses"])
        return ours.join(paper, lsuffix=" (ours)", rsuffix=" (paper)")


def run(cfg: Mapping, out: Outputs, *, log=print) -> Result:
    """Train and score the grid of params section `cfg` on `out.data`'s dataset."""
    device = resolve_device(cfg["device"], f"{cfg.source} device")  # before any work: cuda without a GPU fails here
    train, test = load_pair(cfg["dataset"], out.data)
    config = TrainConfig(max_epochs=cfg["max_epochs"], max_fail=cfg["max_fail"], seed=cfg["seed"], device=device)
    log(f"{cfg['dataset']}: {len(train)} training arms (using {cfg['train_samples'] or len(train)}), "
        f"{len(test)} test arms, {train.n_nodes} nodes")
    runs = tables.table2(train, test, config=config, optimizers=cfg["optimizers"], losses=cfg["losses"],
                         sessions=cfg["sessions"], hidden=cfg["hidden"], train_samples=cfg["train_samples"])
    summary = tables.table2_summary(runs)
    if len(summary) != len(cfg["optimizers"]) * len(cfg["losses"]) or len(runs) != len(summary) * cfg["sessions"]:
        raise RuntimeError(f"Table 2 has {len(summary)} cells and {len(runs)} runs")
    best = summary.loc[summary.f_mean.idxmax()] if summary.f_mean.notna().any() else None
    paper_best = max(PAPER_TABLE2, key=lambda cell: PAPER_TABLE2[cell][0])  # (optimizer, loss) of the paper's best F
    cells = {f"{r.optimizer}_{r.loss_key}": {k: getattr(r, k) for k in CELL_KEYS} for r in summary.itertuples()}
    metrics = jsonable({
        **cells,
        "best_cell": None if best is None else f"{best.optimizer}_{best.loss_key}",
        "paper_best_cell": "_".join(paper_best),
        "sessions": int(cfg["sessions"]),
        "train_samples": int(summary.train_samples.iloc[0]),
        "total_training_seconds": float(runs.seconds.sum()),
        "device": str(device),
        "config": cfg,
    })
    return Result(check_metrics(metrics), summary, runs, cfg)


def save(result: Result, out: Outputs) -> None:
    save_tables(out, PART.name, result.summary, result.runs, result.shown(), result.metrics, tables.COUNT_COLUMNS)


def figures(result: Result, out: Outputs) -> list[Path]:
    """F by optimiser, one panel per loss (mean ± σ over sessions; the paper's beside)."""
    import matplotlib.pyplot as plt

    cfg, summary = result.cfg, result.summary
    fig, axes = plt.subplots(1, len(cfg["losses"]), figsize=(4.2 * len(cfg["losses"]), 4), sharey=True,
                             squeeze=False)
    for ax, loss in zip(axes[0], cfg["losses"]):
        rows = summary[summary.loss_key == loss].set_index("optimizer").reindex(cfg["optimizers"])
        x = np.arange(len(rows))
        ax.bar(x - 0.2, rows.f_mean, 0.4, yerr=np.nan_to_num(rows.f_std.to_numpy()), capsize=3, color="#1f4e79",
               label="ours (mean ± σ over sessions)")
        ax.bar(x + 0.2, rows.paper_f, 0.4, yerr=rows.paper_f_std, capsize=3, color="#bbbbbb", edgecolor="k",
               hatch="//", label="paper (± σ)")
        ax.set_xticks(x, rows.index)
        ax.set_title(tables.LOSS_LABELS.get(loss, loss))
        ax.set_ylim(0, 1.15)
    axes[0][0].set_ylabel("F-measure")
    axes[0][0].legend(loc="upper left", fontsize=8)
    fig.suptitle(f"Table 2: optimisers × losses, block 5 ({cfg['max_epochs']} epochs at most, "
                 f"{int(summary.train_samples.iloc[0])} arms)")
    return [save_figure(fig, out.figures / "table2_optimisers.png")]


def is_cell_key(key: str) -> bool:
    """A cell's key: `<optimizer>_<loss>.<one of CELL_KEYS>`."""
    cell, _, what = key.partition(".")
    return cell.count("_") == 1 and what in CELL_KEYS


# --------------------------------------------------------------------------------------------
# The paper's scale (`wsmap paper full table2`): the Rprop + MSE cell, one session per step
# --------------------------------------------------------------------------------------------


def scale_plan(cfg: Mapping, planner: Planner) -> list[Unit]:
    """The Rprop + MSE cell of params section `cfg` as one unit, a step per session."""
    values = {k: cfg[k] for k in ("dataset", "train_samples", "sessions", "max_epochs", "max_fail", "hidden", "seed")}
    values.update(optimizer="rprop", loss="mse", threshold=0.5)
    return [planner.unit("table2_rprop_mse", SCALE, cfg, planner.sessions(cfg), [cfg["dataset"]], values,
                         planner.train_config("rprop", "mse", cfg["max_epochs"], cfg["max_fail"], cfg["seed"],
                                              cfg.source),
                         "Table 2: Rprop + MSE cell")]


def scale_finalize(unit: Unit, steps: dict[str, dict], data: Data, out: Path) -> tuple[dict, list]:
    """The cell's `wsmap.paper.tables.table2_summary` over its sessions and their score rows
    (`runs`, with their `optimizer` and `loss`)."""
    runs = step_runs(steps)
    runs.insert(0, "loss", unit.values["loss"])
    runs.insert(0, "optimizer", unit.values["optimizer"])
    metrics = tables.table2_summary(runs).iloc[0].to_dict()
    metrics["runs"] = runs.to_dict("records")
    return metrics, []


SCALE = Scale(kind="table2", plan=scale_plan, finalize=scale_finalize, added_columns=("optimizer", "loss"))

PART = Part("table2_optimisers", "Table 2: optimisers and losses", 50, outputs=(
    "results/table2_optimisers.json", "tables/table2_optimisers.csv", "tables/table2_optimisers.md",
    "tables/table2_optimisers_display.csv", "tables/table2_optimisers_display.md",
    "tables/table2_optimisers_runs.csv", "tables/table2_optimisers_runs.md", "figures/table2_optimisers.png"), scale=SCALE)
register(PART)
