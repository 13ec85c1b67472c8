"""Run time of the SL model against the classical algorithm (the paper's run-time figure).

The PUMA560's constant-orientation map (R = I, paper convention) on the 27-, 125- and 9261-node
grids, timed per method (`wsmap.paper.runtime.METHODS`: the paper's one-node-at-a-time LM,
batched LM, the exact closed form, the untrained paper network) by
`wsmap.paper.runtime.runtime_comparison`; mean ± σ over repeated calls, beside the paper's
`wsmap.paper.published.RUNTIME_SECONDS`.
"""

from __future__ import annotations

import os
import platform
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict

import numpy as np
import pandas as pd

from ...io import atomic_path, write_json
from ...learn.device import device_facts, resolve_device
from ...paths import Outputs
from .. import runtime
from ..published import RUNTIME_SECONDS
from . import Part, register, save_figure
from . import check_metrics as check_schema


class Metrics(TypedDict):
    """`results/runtime_comparison.json`: besides these keys, one mapping per method of
    `wsmap.paper.runtime.METHODS` that ran, grid nodes (as a string) -> mean seconds, and
    `<method>_std` -> σ (`wsmap.paper.runtime.metrics_from_table`)."""

    speedup: dict  #: `network_vs_<classical method>` -> grid -> classical mean / network mean
    paper: dict  #: the paper's `classical` and `network` seconds per grid
    per_node_extrapolated: dict[str, bool]  #: grid -> whether the per-node time was extrapolated
    settings: dict  #: the params section's timing settings
    machine: dict  #: CPUs, load, threads, device, versions


#: The table's columns, in order.
TABLE_COLUMNS = ["nodes", "step", "method", "label", "mean_s", "std_s", "min_s", "repeats", "timed_nodes",
                 "extrapolated", "agreement_with_exact", "paper_s", "speedup_vs_paper"]

PART = Part("runtime_comparison", "Run time of the SL model against the classical algorithm", 70, outputs=(
    "results/runtime_comparison.json", "tables/runtime_comparison.csv", "tables/runtime_comparison.md",
    "figures/runtime_comparison.png"))


def check_metrics(metrics: Mapping) -> dict:
    """`metrics` unchanged when it holds `Metrics`' keys and, beside them, only methods of
    `wsmap.paper.runtime.METHODS` (and their `_std`); else a `ValueError`."""
    methods = set(runtime.METHODS) | {f"{m}_std" for m in runtime.METHODS}
    return dict(check_schema(metrics, Metrics, PART.name, other="have unknown keys",
                             beside=lambda key, value: key in methods))


@dataclass
class Result:
    metrics: dict
    df: pd.DataFrame  #: `wsmap.paper.runtime.runtime_comparison`'s table

    @property
    def table(self) -> pd.DataFrame:
        return self.df[TABLE_COLUMNS].copy()


def run(cfg: Mapping, out: Outputs | None = None, *, log=print) -> Result:
    """Time every method on every grid of params section `cfg`."""
    import torch

    device = resolve_device(cfg["device"], f"{cfg.source} device")  # before any work: cuda without a GPU fails here
    torch.set_num_threads(int(cfg["torch_threads"]))
    machine = {
        "cpus": os.cpu_count(),
        "load_average_before": list(os.getloadavg()),
        "torch_threads": torch.get_num_threads(),
        "network_device": device_facts(device),
        "python": platform.python_version(),
        "torch": torch.__version__,
        "numpy": np.__version__,
    }
    df = runtime.runtime_comparison(
        cfg["steps"], lo=cfg["lo"], hi=cfg["hi"], rpy=cfg["rpy"],
        repeats=int(cfg["repeats"]), warmup=int(cfg["warmup"]),
        classical_repeats=int(cfg["classical_repeats"]), classical_warmup=int(cfg["classical_warmup"]),
        per_node_sample=int(cfg["per_node_sample"]), seed=int(cfg["seed"]), progress=log, device=device,
    )
    machine["load_average_after"] = list(os.getloadavg())
    if not (df["mean_s"] > 0).all():
        raise RuntimeError("a method took no time: the timings are broken")
    metrics = {
        **runtime.metrics_from_table(df),
        "paper": {"classical": {str(n): c for n, (c, _) in RUNTIME_SECONDS.items()},
                  "network": {str(n): w for n, (_, w) in RUNTIME_SECONDS.items()}},
        "per_node_extrapolated": {str(r.nodes): bool(r.extrapolated) for r in df.itertuples()
                                  if r.method == "classical_per_node_numerical"},
        "settings": {k: cfg[k] for k in ("steps", "lo", "hi", "rpy", "repeats", "warmup", "classical_repeats",
                                         "classical_warmup", "per_node_sample", "seed", "device")},
        "machine": machine,
    }
    return Result(check_metrics(metrics), df)


def table_markdown(result: Result) -> str:
    return result.table.drop(columns=["method", "step"]).to_markdown(index=False, floatfmt=".4g")


def save(result: Result, out: Outputs) -> None:
    """The metrics file and the table (CSV, and Markdown with its note)."""
    with atomic_path(out.tables / "runtime_comparison.csv") as tmp:
        result.table.to_csv(tmp, index=False)
    note = ("\n\nMean ± sigma (sample std) over `repeats` calls; per-node rows with extrapolated = True solved "
            "`timed_nodes` random nodes per repeat, scaled to the grid. Network: untrained paper network "
            "(inference time does not depend on the weights). paper_s: the paper's classical time for the classical "
            "rows, its network time for the network rows (MATLAB R2017b, Xeon E3-1505M).\n")
    with atomic_path(out.tables / "runtime_comparison.md") as tmp:
        tmp.write_text(table_markdown(result) + note)
    write_json(result.metrics, out.results / "runtime_comparison.json")


def figures(result: Result, out: Outputs) -> list[Path]:
    """Bars per grid (log scale, ± σ): the paper's classical and network times beside ours."""
    import matplotlib.pyplot as plt

    df = result.df
    grids = sorted(df["nodes"].unique())
    bars = [  # (label, values per grid, sigma per grid, colour, hatch)
        ("paper: classical (MATLAB, per node)", [RUNTIME_SECONDS[n][0] for n in grids], None, "#bbbbbb", "//"),
    ]
    colours = {"classical_per_node_numerical": "#d62728", "classical_batched_numerical": "#ff7f0e",
               "classical_exact": "#2ca02c", "network": "#1f4e79"}
    by = df.set_index(["method", "nodes"])
    for m, c in colours.items():
        if m == "network":
            bars.append(("paper: SL network", [RUNTIME_SECONDS[n][1] for n in grids], None, "#9ecae1", "//"))
        extrapolated = [str(n) for n in grids if by.loc[(m, n), "extrapolated"]]
        lab = runtime.METHODS[m] + (f" (extrapolated on {', '.join(extrapolated)})" if extrapolated else "")
        bars.append(("ours: " + lab, [by.loc[(m, n), "mean_s"] for n in grids],
                     [by.loc[(m, n), "std_s"] for n in grids], c, None))
    fig, ax = plt.subplots(figsize=(10, 6))
    width = 0.8 / len(bars)
    x = np.arange(len(grids))
    for i, (lab, vals, err, colour, hatch) in enumerate(bars):
        if err is not None:  # log scale: a lower bar of sigma >= mean is clipped at 10 % of the mean
            vals, err = np.asarray(vals), np.asarray(err)
            err = np.stack([np.minimum(err, 0.9 * vals), err])
        ax.bar(x + (i - (len(bars) - 1) / 2) * width, vals, width, yerr=err, capsize=3, label=lab, color=colour,
               hatch=hatch, edgecolor="black", linewidth=0.5)
    ax.set_yscale("log")
    ax.set_xticks(x)
    ax.set_xticklabels([f"{n} nodes" for n in grids])
    ax.set_ylabel("run time (s), mean ± σ, log scale\n(lower bar clipped where σ ≥ mean)")
    ax.set_title("PUMA560 workspace map: run time of the SL network and the classical algorithm")
    ax.grid(True, axis="y", which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=2)
    fig.tight_layout()
    return [save_figure(fig, out.figures / "runtime_comparison.png")]


def is_cell_key(key: str) -> bool:
    """A method's key: `<method or method_std>.<grid nodes>`."""
    method, _, nodes = key.partition(".")
    return method.removesuffix("_std") in runtime.METHODS and (not nodes or nodes.isdigit())


register(PART)
