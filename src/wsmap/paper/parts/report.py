"""The reproduction report: every number the other parts measured beside the paper's.

Reads the metrics files the other parts wrote (`results/*.json`; their keys are the parts'
`Metrics` schemas, `wsmap.paper.report.unknown_keys` holds the report to them), the label
audit's table and the paper-scale results (`results/full/`), compares the committed params with
the paper-scale ones, and writes `results/REPORT.md` (`wsmap.paper.report.write_report`).
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
from ..published import PAPER_TABLE1
from . import Part, register, save_figure


class Metrics(TypedDict):
    """The report writes no metrics file: `results/REPORT.md` is its output."""


PART = Part("report", "The reproduction report", 110,
            reads=("classical_workspace", "sec61_subspace", "sec62_puma560", "table1_workspaces", "table2_optimisers",
                   "table3_embeddings", "runtime_comparison", "improved_model", "learned_maps"),
            outputs=("results/REPORT.md", "figures/reproduction_vs_paper.png"))


@dataclass
class Result:
    metrics: dict  #: every metrics file, by stem (`wsmap.paper.report.load_metrics`)
    table: pd.DataFrame  #: one row per comparison
    reductions: list[dict]  #: where the committed params are smaller than the paper's
    cfg: Mapping

    @property
    def missing(self) -> pd.DataFrame:
        return self.table[self.table["ours"].isna()]


def run(cfg: Mapping, out: Outputs) -> Result:
    """Read the metrics in `out.inputs.results` (the committed run's; `full/`: the paper-scale
    parts) and the two params files of section `cfg`. The table has one row per
    `wsmap.paper.report.COMPARISONS` entry: `section`, `what`, `ours` (the committed
    run), `paper_scale` (`wsmap paper full`'s number, NaN where there is none or it has not
    run; `paper_scale_note` says which: "—" no counterpart, "not run yet"), `paper`, `difference`
    (ours − paper), `source`."""
    unknown = report.unknown_keys()
    if unknown:
        raise ValueError(f"the report reads keys no part's metrics schema has: {unknown}")
    metrics = report.load_metrics(out.inputs.results)
    rows = report.comparison_rows(metrics, report.load_full(out.inputs.results / "full"))
    table = pd.DataFrame([dict(section=r.section, what=r.what, ours=r.ours,
                               paper_scale=r.full if r.full_run and r.full is not None else np.nan,
                               paper_scale_note=r.full_cell if isinstance(r.full_cell, str) else "",
                               paper=r.paper, difference=r.difference, source=r.source) for r in rows])
    committed = project_paths.load_params(path=project_paths.ROOT / cfg["committed_params"])
    full = project_paths.load_params(path=project_paths.ROOT / cfg["full_params"])
    return Result(metrics, table, report.reductions(committed, full), cfg)


def save(result: Result, out: Outputs) -> Path:
    """`results/REPORT.md`, with the label audit (`tables/label_audit.md`) when it exists."""
    extra = {}
    audit = out.inputs.tables / "label_audit.md"
    if audit.exists():
        extra["Label audit: the paper's one-start numerical labels against exact ones"] = audit.read_text()
    return report.write_report(out.inputs.results, out.results / "REPORT.md", reductions=result.reductions,
                               extra_sections=extra, full_dir=out.inputs.results / "full")


def _dataset_name(name: str) -> str:
    """A Table 1 dataset as the paper names it: `"R3, δ 0.5 (125 nodes)"` for `table1_r3_step05`."""
    row = PAPER_TABLE1[name]
    delta = row["delta"].replace("pi", "π")
    return f"{row['workspace']}, δ {delta} ({row['paper_nodes']} nodes)"


#: Table 1's dataset ids -> the paper's names of them (the bars' labels).
PAPER_TABLE1_NAMES = {name: _dataset_name(name) for name in PAPER_TABLE1}


def _f_rows(table: pd.DataFrame) -> pd.DataFrame:
    """The F-measure rows with a published number: the bars of `figures`."""
    what = table["what"]
    return table[what.str.contains("F", regex=False) & ~what.str.contains("sigma") & table["paper"].notna()
                 & table["ours"].notna()].reset_index(drop=True)


def _bar_label(section: str, what: str) -> str:
    # the report's own row name, without what every bar shares ("F-measure", "F"): the axis says it;
    # a Table 1 row names its dataset as the paper does, not by its file's id
    short = what.replace("F-measure, ", "").replace(", F mean", "").replace(", F", "")
    short = PAPER_TABLE1_NAMES.get(short, short)
    if short.startswith("F-measure"):
        short = short[len("F-measure"):].lstrip(", ")
    return f"{section}: {short}" if short else section


def figures(result: Result, out: Outputs) -> list[Path]:
    """Reproduced F-measures against the published ones: per row of the report (its names), the
    committed run, the paper-scale run where it exists (`results/full`) and the paper, each bar
    with its value; the legend sits below the axis, off the bars."""
    import matplotlib.pyplot as plt

    rows = _f_rows(result.table)
    series = [("paper", "paper", "0.65"), ("ours", "committed run (params.yaml)", "#9ecae1"),
              ("paper_scale", "paper scale, measured (params.full.yaml)", "#1f4e79")]
    n, k = len(rows), len(series)
    height = 0.8 / k
    fig, ax = plt.subplots(figsize=(10, 0.62 * n + 1.6), layout="constrained")
    y = np.arange(n)
    for i, (column, label, color) in enumerate(series):
        values = rows[column].to_numpy(dtype=float)
        pos = y - 0.4 + height * (i + 0.5)
        bars = ax.barh(pos, np.nan_to_num(values, nan=0.0), height=height * 0.92, color=color, label=label)
        notes = rows["paper_scale_note"] if column == "paper_scale" else [""] * n
        for bar, v, note in zip(bars, values, notes):
            text = f"{v:.3f}" if np.isfinite(v) else {"—": "no paper-scale run of this row"}.get(note, note)
            ax.text(max(bar.get_width(), 0.0) + 0.003, bar.get_y() + bar.get_height() / 2, text, va="center",
                    fontsize=7)
    lowest = float(np.nanmin(rows[[c for c, _, _ in series]].to_numpy(dtype=float)))
    ax.set_xlim(max(0.0, min(0.5, lowest - 0.05)), 1.06)
    ax.set_yticks(y, [_bar_label(s, w) for s, w in zip(rows["section"], rows["what"])], fontsize=8)
    ax.invert_yaxis()
    ax.set_xlabel("F-measure (pooled over test arms and nodes unless the row says per-arm)")
    ax.grid(True, axis="x", alpha=0.3)
    fig.legend(loc="outside lower center", ncol=k, fontsize=8, frameon=False)
    fig.suptitle("Reproduced F-measures against the paper's (results/REPORT.md)", fontsize=10)
    return [save_figure(fig, out.figures / "reproduction_vs_paper.png")]


register(PART)
