"""The reproduction report: every number the other parts measured beside the paper's.

Reads the metrics files the other parts wrote (``results/*.json``; their keys are the parts'
``Metrics`` schemas, :func:`wsmap.paper.report.unknown_keys` holds the report to them), the label
audit's table and the paper-scale results (``results/full/``), compares the committed params with
the paper-scale ones, and writes ``results/REPORT.md`` (:func:`wsmap.paper.report.write_report`).
It computes nothing new.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict

import numpy as np
import pandas as pd

from ... import paths as project_paths
from ...paths import Outputs
from .. import report
from . import Part, register, save_figure


class Metrics(TypedDict):
    """The report writes no metrics file: ``results/REPORT.md`` is its output."""


PART = Part("report", "The reproduction report", 110,
            reads=("classical_workspace", "sec61_subspace", "sec62_puma560", "table1_workspaces", "table2_optimisers",
                   "table3_embeddings", "runtime_comparison", "improved_model", "learned_maps"),
            outputs=("results/REPORT.md", "figures/reproduction_vs_paper.png"))


@dataclass
class Result:
    metrics: dict  #: every metrics file, by stem (:func:`wsmap.paper.report.load_metrics`)
    table: pd.DataFrame  #: one row per comparison
    reductions: list[dict]  #: where the committed params are smaller than the paper's
    cfg: Mapping

    @property
    def missing(self) -> pd.DataFrame:
        return self.table[self.table["ours"].isna()]


def run(cfg: Mapping, out: Outputs) -> Result:
    """Read the metrics in ``out.results`` and the two params files of section ``cfg``."""
    unknown = report.unknown_keys()
    if unknown:
        raise ValueError(f"the report reads keys no part's metrics schema has: {unknown}")
    metrics = report.load_metrics(out.results)
    rows = report.comparison_rows(metrics)
    table = pd.DataFrame([dict(section=r.section, what=r.what, ours=r.ours, paper=r.paper, difference=r.difference,
                               source=r.source) for r in rows])
    committed = project_paths.load_params(path=project_paths.ROOT / cfg["committed_params"])
    full = project_paths.load_params(path=project_paths.ROOT / cfg["full_params"])
    return Result(metrics, table, report.reductions(committed, full), cfg)


def save(result: Result, out: Outputs) -> Path:
    """``results/REPORT.md``, with the label audit (``tables/label_audit.md``) when it exists."""
    extra = {}
    audit = out.tables / "label_audit.md"
    if audit.exists():
        extra["Label audit: the paper's one-start numerical labels against exact ones"] = audit.read_text()
    return report.write_report(out.results, reductions=result.reductions, extra_sections=extra)


def figures(result: Result, out: Outputs) -> list[Path]:
    """Reproduced F-measures against the published ones."""
    import matplotlib.pyplot as plt

    table = result.table
    f_rows = table[table["what"].str.contains("F", regex=False) & table["paper"].notna() & table["ours"].notna()
                   & ~table["what"].str.contains("sigma")]
    fig, ax = plt.subplots(figsize=(7, 0.35 * len(f_rows) + 1.2))
    y = np.arange(len(f_rows))
    ax.barh(y - 0.2, f_rows["paper"], height=0.4, label="paper", color="0.7")
    ax.barh(y + 0.2, f_rows["ours"], height=0.4, label="this run", color="C0")
    ax.set_yticks(y, [f"{s}: {w}" for s, w in zip(f_rows["section"], f_rows["what"])], fontsize=7)
    ax.invert_yaxis()
    ax.set_xlim(min(0.5, float(np.nanmin(f_rows[["paper", "ours"]].to_numpy())) - 0.02), 1.0)
    ax.set_xlabel("F-measure")
    ax.legend(loc="lower right")
    ax.set_title("Reproduced F-measures against the paper's")
    fig.tight_layout()
    return [save_figure(fig, out.figures / "reproduction_vs_paper.png")]


register(PART)
