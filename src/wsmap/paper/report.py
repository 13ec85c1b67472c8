"""The reproduction report: every reproduced number beside the paper's, with the difference.

:data:`PAPER` holds the published numbers (``../shared/paper/NOTES.md``, "Published figures to
compare with"). :func:`comparison_rows` reads the metrics JSON files the pipeline notebooks write
(``results/NAME.json``) and pairs each number with the paper's; :func:`write_report` turns them
into ``results/REPORT.md``, with the departures from the paper (:data:`DEPARTURES`) and the
reductions of the committed parameters against the paper's scale.

A number that a stage has not produced (its JSON missing, or the key absent) is reported as
missing, never filled in.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..io import atomic_path, markdown_table
from .published import PAPER

__all__ = ["PAPER", "DEPARTURES", "Row", "markdown_table", "lookup", "comparison_rows", "reductions", "write_report"]

#: Where the project departs from the paper, and why (the report lists them all).
DEPARTURES: list[tuple[str, str]] = [
    ("Scale of the committed run",
     "`params.yaml` trains on fewer samples, epochs and sessions than the paper so that `dvc repro` "
     "fits in 45 minutes on 2 CPU cores; the README lists each reduction and the full-scale command."),
    ("Labels",
     "Spherical-wrist labels are exact (closed-form wrist-centre test), as the authors' published labels "
     "were; arbitrary 6-DOF labels (Table 3) come from the batched LM with several starts (the paper "
     "does not say how its were made). The label audit table measures how the paper's one-start "
     "numerical path would differ."),
    ("Pose convention",
     "The paper's convention `T = Rx Ry Rz · transl(p)` is reproduced (the datasets use it); the "
     "usual `transl(p) · R` is available and compared in the classical-workspace notebook."),
    ("Original code's quirks",
     "The original numerical path marked an empty IK result as reachable and forced `search` on; "
     "its 5-DOF labels were all zero. None of this is reproduced."),
    ("Cross entropy",
     "Cross entropy is computed on logits (sigmoid output) rather than MATLAB's cross entropy on a "
     "linear output layer."),
    ("Run time",
     "Our classical numbers are measured on this machine (2-core CPU, Python), the paper's on MATLAB "
     "R2017b on a Xeon E3-1505M; only ratios within one table are like for like."),
    ("Improved model",
     "Beyond the paper: inputs reduced to the four free DH parameters and standardised, wider layers, "
     "cross entropy on logits, Adam with minibatches; it stands beside, not in place of, the paper's "
     "setting."),
]


@dataclass
class Row:
    """One line of the report: what, ours, the paper's, where ours comes from."""

    section: str
    what: str
    ours: float | None
    paper: float | None
    source: str
    note: str = ""

    @property
    def difference(self) -> float | None:
        if self.ours is None or self.paper is None or not _finite(self.ours) or not _finite(self.paper):
            return None
        return self.ours - self.paper


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and math.isfinite(v)


def lookup(metrics: dict[str, Any], key: str):
    """``metrics[a][b]...`` for ``key = "a.b..."``; ``None`` where any part is missing."""
    cur: Any = metrics
    for part in key.split("."):
        if isinstance(cur, dict) and part in cur:
            cur = cur[part]
        elif isinstance(cur, list) and part.isdigit() and int(part) < len(cur):
            cur = cur[int(part)]
        else:
            return None
    if isinstance(cur, bool) or not isinstance(cur, (int, float)):
        return None
    return float(cur)


def load_metrics(results_dir) -> dict[str, dict]:
    """Every ``results/*.json`` (the stages' metrics) by stem; unreadable files raise ``ValueError``."""
    out = {}
    for p in sorted(Path(results_dir).glob("*.json")):
        try:
            out[p.stem] = json.loads(p.read_text())
        except json.JSONDecodeError as e:
            raise ValueError(f"metrics file {p} is not valid JSON ({e})") from None
    return out


#: (section, what, metrics file, key in it, PAPER key or None, note)
COMPARISONS: list[tuple[str, str, str, str, str | None, str]] = [
    ("Run time", "classical, 9261 nodes, per-node numerical (s)", "runtime_comparison",
     "classical_per_node_numerical.9261", "classical_time_9261", "extrapolated from a sample of nodes"),
    ("Run time", "classical, 125 nodes, per-node numerical (s)", "runtime_comparison",
     "classical_per_node_numerical.125", "classical_time_125", ""),
    ("Run time", "classical, 27 nodes, per-node numerical (s)", "runtime_comparison",
     "classical_per_node_numerical.27", "classical_time_27", ""),
    ("Run time", "classical, 9261 nodes, batched numerical (s)", "runtime_comparison",
     "classical_batched_numerical.9261", None, "not in the paper"),
    ("Run time", "classical, 9261 nodes, exact (s)", "runtime_comparison", "classical_exact.9261", None,
     "not in the paper"),
    ("Run time", "network, 9261 nodes (s)", "runtime_comparison", "network.9261", "network_time_9261", ""),
    ("Run time", "network, 125 nodes (s)", "runtime_comparison", "network.125", "network_time_125", ""),
    ("Run time", "network, 27 nodes (s)", "runtime_comparison", "network.27", "network_time_27", ""),
    ("Section 6.1", "F-measure, block 5, mean over sessions", "sec61_subspace", "f_mean", "sec61_f_mean", ""),
    ("Section 6.1", "F-measure, sigma over sessions", "sec61_subspace", "f_std", "sec61_f_std", ""),
    ("Section 6.1", "best-threshold F (sweep)", "sec61_subspace", "best_threshold_f", "sec61_best_threshold_f", ""),
    ("Section 6.2", "F-measure, full 9261 map from 7 block models", "sec62_puma560", "f_full", "table1_r3_full",
     "the paper reports Table 1's single 9261-output model"),
    ("Section 6.2", "F-measure, PUMA560 predicted vs exact", "sec62_puma560", "puma560_f", None, "not in the paper"),
    *[("Table 1", f"F-measure, {name}", "table1_workspaces", f"f.{name}", name, "")
      for name in ("table1_r3_step1", "table1_r3_step05", "table1_r3_block5", "table1_r3_crop3087",
                   "table1_r3_full", "table1_so3_pi3", "table1_so3_pi8", "table1_so3_pi10")],
    ("Table 2", "Rprop + MSE, F mean", "table2_optimisers", "rprop_mse.f_mean", "table2_rprop_mse_f_mean", ""),
    ("Table 2", "Rprop + MSE, F sigma", "table2_optimisers", "rprop_mse.f_std", "table2_rprop_mse_f_std",
     "ours: sigma of the pooled F over sessions; the paper does not say over what its sigma is taken"),
    ("Table 2", "Rprop + MSE, per-arm F mean", "table2_optimisers", "rprop_mse.f_sample_mean",
     "table2_rprop_mse_f_mean", "F of each test arm's map, averaged"),
    ("Table 2", "Rprop + MSE, per-arm F sigma", "table2_optimisers", "rprop_mse.f_sample_std",
     "table2_rprop_mse_f_std", "sigma over test arms: the paper's 0.1258 is of this size"),
    ("Table 3", "subspace model, own test set, precision", "table3_embeddings", "subspace.subspace.precision",
     "table3_subspace_precision", ""),
    ("Table 3", "subspace model, own test set, recall", "table3_embeddings", "subspace.subspace.recall",
     "table3_subspace_recall", ""),
    ("Table 3", "subspace model, own test set, F", "table3_embeddings", "subspace.subspace.f", "table3_subspace_f", ""),
    ("Beyond the paper", "improved model, full 9261 map, F", "improved_model", "f", "table1_r3_full",
     "paper: its full-map model"),
    ("Beyond the paper", "improved model, PUMA560 predicted vs exact, F", "improved_model", "puma560_f", None, ""),
    ("Beyond the paper", "improved model, one 9261-node map (s)", "improved_model", "seconds_per_map",
     "network_time_9261", ""),
]


def _leaves(d: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(d, dict):
        out: dict[str, Any] = {}
        for k, v in d.items():
            out.update(_leaves(v, f"{prefix}.{k}" if prefix else str(k)))
        return out
    return {prefix: d}


def reductions(committed: dict[str, Any], full: dict[str, Any]) -> list[dict[str, Any]]:
    """Every parameter whose committed value (``params.yaml``) differs from the paper-scale one
    (``params.full.yaml``), as rows ``{stage, parameter, committed, paper scale}``; nested
    sections are flattened to dotted names (``train_samples.table1_r3_full``). A parameter
    present in only one of the two files is listed with ``None`` on the other side."""
    rows = []
    for stage in dict.fromkeys([*committed, *full]):
        c, f = _leaves(committed.get(stage, {})), _leaves(full.get(stage, {}))
        for key in dict.fromkeys([*c, *f]):
            if c.get(key) != f.get(key):
                rows.append({"stage": stage, "parameter": key, "committed": c.get(key), "paper scale": f.get(key)})
    return rows


def comparison_rows(metrics: dict[str, dict]) -> list[Row]:
    """One :class:`Row` per entry of :data:`COMPARISONS`, ours read from ``metrics``."""
    rows = []
    for section, what, stem, key, paper_key, note in COMPARISONS:
        ours = lookup(metrics.get(stem, {}), key)
        paper = PAPER.get(paper_key) if paper_key else None
        rows.append(Row(section, what, ours, paper, f"results/{stem}.json: {key}", note))
    return rows


def write_report(results_dir, path=None, *, reductions: list[dict] | None = None,
                 extra_sections: dict[str, str] | None = None) -> Path:
    """Write the report (default ``results_dir/REPORT.md``) atomically; returns its path.

    ``reductions``: rows ``{parameter, committed, paper}`` listing where the committed run is
    smaller than the paper's; ``extra_sections``: title → Markdown appended (e.g. the label audit).
    """
    results_dir = Path(results_dir)
    path = Path(path) if path else results_dir / "REPORT.md"
    rows = comparison_rows(load_metrics(results_dir))
    lines = [
        "# Reproduction report",
        "",
        "Generated by the `report` stage from the metrics the pipeline wrote (`results/*.json`); every "
        "number below is measured by this run, next to the paper's (NOTES.md). Difference = ours − paper. "
        "\"missing\" means the stage did not produce the number; \"—\": the paper gives none.",
        "",
    ]
    for section in dict.fromkeys(r.section for r in rows):
        lines += [f"## {section}", ""]
        lines.append(markdown_table(
            [dict(what=r.what, ours=r.ours, paper="—" if r.paper is None else r.paper,
                  difference="—" if r.paper is None else r.difference, source=r.source, note=r.note)
             for r in rows if r.section == section], missing="missing"))
    if reductions:
        lines += ["## Committed scale against the paper's", "", markdown_table(reductions, missing="missing")]
    for title, body in (extra_sections or {}).items():
        lines += [f"## {title}", "", body.rstrip() + "\n"]
    lines += ["## Where the project departs from the paper", ""]
    lines += [f"- **{t}.** {why}" for t, why in DEPARTURES]
    text = "\n".join(lines) + "\n"
    with atomic_path(path) as tmp:
        Path(tmp).write_text(text)
    return path
