"""The classical workspace map of the PUMA560 (the paper's section 1 and Appendix).

A grid of positions at a fixed orientation, inverse kinematics at every node, one bit per node:
the exact closed-form map against the paper's numerical path (one-start Levenberg–Marquardt from
q0 = 0), the two pose conventions side by side, and the label audit (how the paper's numerical path
would label the datasets' (arm, node) pairs, `wsmap.datasets.audit_table` on
`wsmap.paper.specs.audit_specs`).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict

import numpy as np
import pandas as pd

from ... import robots, viz, workspace
from ...datasets import audit_table
from ...io import atomic_path, write_json
from ...paths import Outputs
from ...views import iso_mesh
from ...workspace.kinds import get_kind
from ..specs import audit_specs
from . import Part, check_metrics, register, save_figure


class LabelAudit(TypedDict):
    arms: int  #: random arms per spec (audit stream)
    specs: int  #: distinct spherical-wrist dataset specs audited
    pairs: int  #: (arm, node) pairs labelled both ways
    false_negatives: int  #: reachable nodes the numerical path misses
    false_positives: int  #: nodes it solves that the exact test rejects
    fn_rate_pooled: float
    fn_rate_max: float
    agreement_min: float
    seconds_exact: float
    seconds_numerical: float
    by_spec: dict  #: spec -> {fn_rate, fp_rate, agreement}


class Metrics(TypedDict):
    """`results/classical_workspace.json`."""

    nodes: int
    reachable_exact: int  #: nodes of the PUMA560's exact map at `rpy`
    reachable_numerical: int  #: nodes the paper's one-start LM finds
    numerical_false_negatives: int
    numerical_false_positives: int
    exact_numerical_agreement: float  #: fraction of nodes where the two agree
    conventions_equal_at_identity: bool
    conventions_differ_fraction_rotated: float  #: fraction of nodes where the conventions differ at `rotated_rpy`
    label_audit: LabelAudit


PART = Part("classical_workspace", "The classical workspace map of the PUMA560", 10, outputs=(
    "results/classical_workspace.json", "results/puma560_workspace_exact.stl",
    "tables/label_audit.csv", "tables/label_audit.md",
    "figures/puma560_workspace_slices.png", "figures/puma560_workspace_exact.png",
    "figures/puma560_exact_vs_numerical.png", "figures/puma560_conventions.png"))


@dataclass
class Result:
    metrics: Metrics
    shape: tuple[int, int, int]
    exact: np.ndarray  #: the exact map at `rpy` (flat, node order)
    numerical: np.ndarray  #: the paper's numerical map
    paper_convention: np.ndarray  #: the map at `rotated_rpy`, paper's convention
    standard_convention: np.ndarray
    mesh: object  #: marching-cubes mesh of `exact`
    audit: pd.DataFrame
    seconds: dict[str, float]  #: exact, numerical, audit
    cfg: Mapping

    def audit_markdown(self) -> str:
        return self.audit.to_markdown(index=False, floatfmt=".4g")


def run(cfg: Mapping, out: Outputs | None = None, *, log=print) -> Result:
    """The maps and the audit of params section `cfg` (nothing is read from `out`)."""
    axes = workspace.grid_axes(cfg["lo"], cfg["hi"], cfg["step"])
    shape = tuple(len(a) for a in axes)
    nodes = workspace.cartesian_grid(cfg["lo"], cfg["hi"], cfg["step"])
    puma = robots.puma560()
    log(f"{len(nodes)} nodes, grid shape {shape}")
    exact = workspace.constant_orientation_map(puma, nodes, cfg["rpy"], method="exact", convention="paper")
    mesh = iso_mesh(exact, {"lo": cfg["lo"], "step": cfg["step"], "shape": shape}, 0.5)
    log(f"mesh: {len(mesh.vertices)} vertices, watertight={mesh.is_watertight}, volume={mesh.volume:.3f} m^3")

    t0 = time.perf_counter()
    # the paper's one-start LM (ikine_LM from q0 = 0); the default numerical path is the multi-start search
    numerical = workspace.constant_orientation_map(puma, nodes, cfg["rpy"], method="numerical",
                                                   convention="paper", ik={"solver": "paper"})
    t_num = time.perf_counter() - t0
    t0 = time.perf_counter()
    workspace.constant_orientation_map(puma, nodes, cfg["rpy"], method="exact", convention="paper")
    t_exact = time.perf_counter() - t0
    fn = int(np.sum(exact & ~numerical))
    fp = int(np.sum(numerical & ~exact))
    agreement = float(np.mean(exact == numerical))
    log(f"agreement {agreement:.4%}; numerical misses {fn} reachable nodes, invents {fp}")
    log(f"exact map {t_exact * 1e3:.2f} ms, batched numerical map {t_num:.2f} s")

    # The authors' code builds the target as Rx Ry Rz · transl(p) (it tests the position R·p); the
    # usual convention is transl(p) · R. They agree at R = I and differ at Table 3's orientation.
    rot = cfg["rotated_rpy"]
    paper_conv = workspace.constant_orientation_map(puma, nodes, rot, convention="paper")
    standard_conv = workspace.constant_orientation_map(puma, nodes, rot, convention="standard")
    at_identity_equal = bool(np.array_equal(
        exact, workspace.constant_orientation_map(puma, nodes, cfg["rpy"], convention="standard")))
    differ = float(np.mean(paper_conv != standard_conv))
    log(f"identical at R = I: {at_identity_equal}; at rpy={rot}: {differ:.2%} of nodes differ")

    t0 = time.perf_counter()
    audit = pd.DataFrame(audit_table(audit_specs(), n_arms=int(cfg["audit_arms"])))
    t_audit = time.perf_counter() - t0
    log(f"audit of {len(audit)} specs x {int(audit['arms'].iloc[0])} arms in {t_audit:.1f} s")
    label_audit: LabelAudit = {
        "arms": int(audit["arms"].iloc[0]),
        "specs": len(audit),
        "pairs": int(audit["pairs"].sum()),
        "false_negatives": int(audit["false_negatives"].sum()),
        "false_positives": int(audit["false_positives"].sum()),
        "fn_rate_pooled": float(audit["false_negatives"].sum() / max(1, audit["exact_positives"].sum())),
        "fn_rate_max": float(audit["fn_rate"].max()),
        "agreement_min": float(audit["agreement"].min()),
        "seconds_exact": float(audit["seconds_exact"].sum()),
        "seconds_numerical": float(audit["seconds_numerical"].sum()),
        # write_json turns NaN (a rate of an empty class) into null: JSON has no NaN
        "by_spec": {r.spec: {k: float(getattr(r, k)) for k in ("fn_rate", "fp_rate", "agreement")}
                    for r in audit.itertuples()},
    }
    metrics: Metrics = {
        "nodes": int(exact.size),
        "reachable_exact": int(exact.sum()),
        "reachable_numerical": int(numerical.sum()),
        "numerical_false_negatives": fn,
        "numerical_false_positives": fp,
        "exact_numerical_agreement": agreement,
        "conventions_equal_at_identity": at_identity_equal,
        "conventions_differ_fraction_rotated": differ,
        "label_audit": check_metrics(label_audit, LabelAudit, f"{PART.name} label_audit"),
    }
    return Result(check_metrics(metrics, Metrics, PART.name), shape, exact, numerical, paper_conv, standard_conv,
                  mesh, audit, {"exact": t_exact, "numerical": t_num, "audit": t_audit}, cfg)


def save(result: Result, out: Outputs) -> None:
    """The metrics file, the exact map's mesh (STL) and the label audit's tables."""
    result.mesh.export(out.results / "puma560_workspace_exact.stl")
    audit = result.audit
    with atomic_path(out.tables / "label_audit.csv") as tmp:
        audit.to_csv(tmp, index=False)
    with atomic_path(out.tables / "label_audit.md") as tmp:
        tmp.write_text(
            result.audit_markdown() + f"\n\n{int(audit['arms'].iloc[0])} random arms per spec (audit stream, seed "
            "0). Exact: closed-form wrist-centre test; numerical: the paper's LM (q0 = 0, one start, tol 1e-10, "
            "ilimit 500, rlimit 100), every success confirmed by forward kinematics. fn_rate: of exact "
            "positives; fp_rate: of exact negatives. Seconds on the machine that ran the stage.\n")
    write_json(result.metrics, out.results / "classical_workspace.json")


def figures(result: Result, out: Outputs) -> list[Path]:
    """Slices and surface of the exact map, exact against numerical, the two conventions."""
    r, cfg = result, result.cfg
    m = r.metrics
    constant = get_kind("constant")
    title = viz.map_title("PUMA560", constant, rpy=cfg["rpy"], convention="paper",
                          summary=f"{r.exact.sum()} of {r.exact.size} nodes reachable (exact, closed form)")
    paths = [save_figure(viz.plot_slices(r.exact, r.shape, cfg["lo"], cfg["step"], title=title),
                         out.figures / "puma560_workspace_slices.png")]
    ax = viz.render_mesh(r.mesh, title="PUMA560 constant-orientation workspace (exact)",
                         lim=max(abs(cfg["lo"]), abs(cfg["hi"])))
    paths.append(save_figure(ax.figure, out.figures / "puma560_workspace_exact.png"))
    fig = viz.plot_slices(r.exact, r.shape, cfg["lo"], cfg["step"], compare=r.numerical,
                          names=("exact only (the LM missed it)", "the LM only", "both"),
                          title=viz.map_title("PUMA560", constant, rpy=cfg["rpy"], convention="paper",
                                              summary=f"exact against the paper's one-start LM: agreement "
                                                      f"{m['exact_numerical_agreement']:.4f}, "
                                                      f"{m['numerical_false_negatives']} missed, "
                                                      f"{m['numerical_false_positives']} extra"))
    paths.append(save_figure(fig, out.figures / "puma560_exact_vs_numerical.png"))
    fig = viz.plot_slices(r.paper_convention, r.shape, cfg["lo"], cfg["step"], compare=r.standard_convention,
                          names=("T = R·transl(p) only (paper)", "T = transl(p)·R only (standard)", "both"),
                          title=viz.map_title("PUMA560", constant, rpy=cfg["rotated_rpy"],
                                              summary=f"the two pose conventions: "
                                                      f"{m['conventions_differ_fraction_rotated']:.1%} of nodes differ"))
    paths.append(save_figure(fig, out.figures / "puma560_conventions.png"))
    return paths


register(PART)
