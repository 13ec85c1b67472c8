"""Table 3: subspace, workspace and no-subspace embeddings, each model on every test set.

Three models of the same architecture (three tanh layers of 80, linear output, Rprop + MSE) on
three datasets sharing the inputs (84 features) and the outputs (block 5's 1323 nodes):
spherical-wrist arms at R = I (`subspace`), at an orientation drawn on SO(3) per arm
(`workspace`), arbitrary 6-DOF arms at a fixed orientation (`nosubspace`, numerical labels).
Each is tested on all three test sets (`wsmap.paper.tables.table3`); the paper-scale runner
(`wsmap.paper.full`, through `SCALE`) trains one embedding per unit and summarises with the same
`wsmap.paper.tables.table3_summary`.
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
from ..specs import load_pair
from ..scale import Data, Planner, Scale, Unit, f_line, step_runs
from . import Part, register, save_figure, save_tables

#: The keys of each (model embedding, test set) cell of the metrics.
CELL_KEYS = ("precision", "recall", "f", "precision_sample_mean", "precision_sample_std", "recall_sample_mean",
             "recall_sample_std", "f_sample_mean", "f_sample_std", "paper_precision", "paper_recall", "paper_f")


class Metrics(TypedDict):
    """`results/table3_embeddings.json`: besides these keys, one mapping per model embedding
    (`subspace`, `workspace`, `nosubspace`) of test set -> cell of `CELL_KEYS` (pooled
    and per-arm P, R, F; the paper's)."""

    test_positive_rate: dict[str, float]  #: fraction of reachable nodes in each test set
    train_samples: dict[str, int]
    epochs: dict[str, float]
    seconds: dict[str, float]  #: training wall time per model, mean over sessions
    total_training_seconds: float
    device: str
    config: dict


def check_metrics(metrics: Mapping, embeddings) -> dict:
    """`metrics` unchanged when it holds `Metrics`' keys and one mapping per embedding of
    test set -> cell of `CELL_KEYS`; else a `ValueError`."""
    fixed = tuple(Metrics.__annotations__)
    expected = set(fixed) | set(embeddings)
    bad = [e for e in embeddings if not all(tuple(c) == CELL_KEYS for c in metrics.get(e, {}).values())]
    if set(metrics) != expected or bad:
        raise ValueError(f"{PART.name}: metrics have keys {sorted(metrics)}, expected {sorted(expected)} "
                         f"(cells of {CELL_KEYS}; wrong: {bad})")
    return dict(metrics)


@dataclass
class Result:
    metrics: dict
    summary: pd.DataFrame  #: `wsmap.paper.tables.table3_summary`
    runs: pd.DataFrame
    cfg: Mapping

    @property
    def order(self) -> list[str]:
        return list(self.cfg["embeddings"])

    def shown(self) -> pd.DataFrame:
        s = self.summary
        return s.assign(
            precision_per_arm=[plus_minus(m, sd, 2) for m, sd in zip(s.precision_sample_mean, s.precision_sample_std)],
            recall_per_arm=[plus_minus(m, sd, 2) for m, sd in zip(s.recall_sample_mean, s.recall_sample_std)],
            f_per_arm=[plus_minus(m, sd, 2) for m, sd in zip(s.f_sample_mean, s.f_sample_std)],
            paper_precision_=[plus_minus(m, sd, 2) for m, sd in zip(s.paper_precision, s.paper_precision_std)],
            paper_recall_=[plus_minus(m, sd, 2) for m, sd in zip(s.paper_recall, s.paper_recall_std)],
            paper_f_=[plus_minus(m, sd, 2) for m, sd in zip(s.paper_f, s.paper_f_std)],
        )[["embedding", "test", "precision", "recall", "f", "precision_per_arm", "recall_per_arm", "f_per_arm",
           "paper_precision_", "paper_recall_", "paper_f_"]].rename(
            columns={"paper_precision_": "paper P", "paper_recall_": "paper R", "paper_f_": "paper F"})

    def wide(self, key: str) -> pd.DataFrame:
        """`key` (`precision`, `recall`, `f`, `paper_f`) by model (rows) and test set (columns)."""
        return self.summary.pivot(index="embedding", columns="test", values=key).reindex(index=self.order,
                                                                                         columns=self.order)

    def rates(self) -> pd.DataFrame:
        """Reachable nodes in each test set and predicted reachable by each model, beside P, R, F."""
        s, runs = self.summary, self.runs
        return s.assign(
            test_positive_rate=[float(runs[runs.test == t].positive_rate.iloc[0]) for t in s.test],
            predicted_positive_rate=[float((runs[(runs.embedding == e) & (runs.test == t)].predicted
                                            / (runs.test_samples * runs.nodes)).mean())
                                     for e, t in zip(s.embedding, s.test)],
        )[["embedding", "test", "test_positive_rate", "predicted_positive_rate", "precision", "recall", "f"]]


def run(cfg: Mapping, out: Outputs, *, log=print) -> Result:
    """Train the three models of params section `cfg` and test each on the three test sets."""
    device = resolve_device(cfg["device"], f"{cfg.source} device")  # before any work: cuda without a GPU fails here
    pairs = {emb: load_pair(name, out.data) for emb, name in cfg["embeddings"].items()}
    for emb, (tr, te) in pairs.items():
        log(f"{emb}: {len(tr)} training arms, {len(te)} test arms, {tr.n_nodes} nodes, "
            f"{tr.labels.mean():.1%} of training labels reachable")
    config = TrainConfig(optimizer=cfg["optimizer"], loss=cfg["loss"], max_epochs=cfg["max_epochs"],
                         max_fail=cfg["max_fail"], seed=cfg["seed"], device=device)
    runs = tables.table3(pairs, config=config, sessions=cfg["sessions"], hidden=cfg["hidden"],
                         train_samples=cfg["train_samples"])
    summary = tables.table3_summary(runs)
    order = list(cfg["embeddings"])
    if len(summary) != len(order) ** 2 or not set(summary.embedding) == set(order) == set(summary.test):
        raise RuntimeError(f"Table 3 has {len(summary)} cells, not {len(order)}²")
    cells = {emb: {} for emb in order}
    for r in summary.itertuples():
        cells[r.embedding][r.test] = {k: getattr(r, k) for k in CELL_KEYS}
    metrics = jsonable({
        **cells,
        "test_positive_rate": {t: float(runs[runs.test == t].positive_rate.iloc[0]) for t in order},
        "train_samples": {e: int(runs[runs.embedding == e].train_samples.iloc[0]) for e in order},
        "epochs": {e: float(runs[runs.embedding == e].epochs.mean()) for e in order},
        "seconds": {e: float(runs[(runs.embedding == e) & (runs.test == e)].seconds.mean()) for e in order},
        "total_training_seconds": float(runs[runs.test == runs.embedding].seconds.sum()),
        "device": str(device),
        "config": cfg,
    })
    return Result(check_metrics(metrics, order), summary, runs, cfg)


def save(result: Result, out: Outputs) -> None:
    save_tables(out, PART.name, result.summary, result.runs, result.shown(), result.metrics, tables.COUNT_COLUMNS)


def figures(result: Result, out: Outputs) -> list[Path]:
    """The 3 × 3 pooled F, ours beside the paper's."""
    import matplotlib.pyplot as plt

    order, cfg = result.order, result.cfg
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2))
    for ax, key, title in ((axes[0], "f", "ours (pooled F)"), (axes[1], "paper_f", "paper")):
        m = result.wide(key).to_numpy(dtype=float)
        ax.imshow(np.nan_to_num(m, nan=0.0), vmin=0, vmax=1, cmap="Blues")
        for i in range(len(order)):
            for j in range(len(order)):
                v = m[i, j]
                ax.text(j, i, "NaN" if np.isnan(v) else f"{v:.2f}", ha="center", va="center",
                        color="white" if (not np.isnan(v) and v > 0.6) else "black")
        ax.set_xticks(range(len(order)), order)
        ax.set_yticks(range(len(order)), order)
        ax.set_xlabel("test set")
        ax.set_ylabel("model (training embedding)")
        ax.set_title(title)
    fig.suptitle(f"Table 3: F-measure, [{', '.join(map(str, cfg['hidden']))}] networks")
    return [save_figure(fig, out.figures / "table3_embeddings.png")]


def is_cell_key(key: str) -> bool:
    """A cell's key: `<model embedding>.<test set>.<one of CELL_KEYS>`."""
    parts = key.split(".")
    return len(parts) == 3 and parts[2] in CELL_KEYS


# --------------------------------------------------------------------------------------------
# The paper's scale (`wsmap paper full table3`): one unit per embedding, one session per step
# --------------------------------------------------------------------------------------------


def scale_plan(cfg: Mapping, planner: Planner) -> list[Unit]:
    """A unit per embedding of params section `cfg` (`table3_<embedding>`), each reading all
    the embeddings' datasets (its model is tested on every test set); a step per session."""
    embeddings = dict(cfg["embeddings"])
    units = []
    for emb, dataset in embeddings.items():
        values = {"embedding": emb, "dataset": dataset, "embeddings": embeddings,
                  "train_samples": tables.per_dataset(cfg["train_samples"], emb), "sessions": cfg["sessions"],
                  "max_epochs": cfg["max_epochs"], "max_fail": cfg["max_fail"], "hidden": cfg["hidden"],
                  "seed": cfg["seed"], "optimizer": cfg["optimizer"], "loss": cfg["loss"], "threshold": 0.5}
        units.append(planner.unit(f"table3_{emb}", SCALE, cfg, planner.sessions(cfg), list(embeddings.values()),
                                  values, planner.train_config(cfg["optimizer"], cfg["loss"], cfg["max_epochs"],
                                                               cfg["max_fail"], cfg["seed"], cfg.source),
                                  f"Table 3: {emb} model on the three test sets"))
    return units


def scale_test_sets(unit: Unit, data: Data) -> dict:
    """Every embedding's test set, by embedding: a unit's model is scored on all three."""
    return {emb: data.pairs[name][1] for emb, name in unit.values["embeddings"].items()}


def scale_summary(unit: Unit, done: dict) -> str:
    """A finished session in one line: its F on its own embedding's test set."""
    rows = done["metrics"]["rows"]
    return f_line(next((r for r in rows if r["test"] == unit.values["embedding"]), rows[0]))


def scale_finalize(unit: Unit, steps: dict[str, dict], data: Data, out: Path) -> tuple[dict, list]:
    """The model's `wsmap.paper.tables.table3_summary` per test set (`tests`), its own test
    set's scores beside them, and the sessions' score rows (`runs`, with their `embedding`)."""
    emb = unit.values["embedding"]
    runs = step_runs(steps)
    runs.insert(0, "embedding", emb)
    summary = tables.table3_summary(runs)
    metrics = {"embedding": emb,
               "tests": {r["test"]: {k: v for k, v in r.items() if k not in ("embedding", "test")}
                         for r in summary.to_dict("records")}}
    own = metrics["tests"].get(emb, {})
    metrics.update(f_own=own.get("f"), precision_own=own.get("precision"), recall_own=own.get("recall"))
    metrics["runs"] = runs.to_dict("records")
    return metrics, []


SCALE = Scale(kind="table3", plan=scale_plan, finalize=scale_finalize, test_sets=scale_test_sets,
              summary=scale_summary, added_columns=("embedding",))

PART = Part("table3_embeddings", "Table 3: subspace, workspace and no-subspace embeddings", 60, outputs=(
    "results/table3_embeddings.json", "tables/table3_embeddings.csv", "tables/table3_embeddings.md",
    "tables/table3_embeddings_display.csv", "tables/table3_embeddings_display.md",
    "tables/table3_embeddings_runs.csv", "tables/table3_embeddings_runs.md", "figures/table3_embeddings.png"), scale=SCALE)
register(PART)
