"""The reach study of real cells (beyond the paper; ROS-Industrial REACH's question).

Each cell of params `cells` is a study file under `data/cells/` (`wsmap study FILE` runs the same
job): REACH's own demo (a Motoman SIA20D, the part and its point cloud of `reach_ros`), compared
target by target with the results database REACH saved for it (`reach_db`), and a harder cell on
the same part: three named arms on a pedestal, the part lowered and checked as an obstacle on its
triangles, the tool free about its axis and within a tilt cone, the base searched over a region.
`stride` keeps every n-th target and `region_step` coarsens the base region (the smoke scale).

Outputs: per cell and arm the coverage, the reached / certified unreachable / not found counts,
the mean score, the best base and the seconds (`tables/reach_study.*`); the study files with their
heat maps (`results/reach_study/<cell>.npz` and `.ply`, `results/reach_study_html/<cell>.html`); the heat map of `heat_map` on its
part (`figures/reach_study_heatmap.png`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict

import numpy as np
import pandas as pd

from ... import paths
from ...io import write_json, write_table
from ...jobs.study import StudyJob
from ...paths import Outputs
from ...workspace.reach_db import read_reach_db
from ...workspace.study import REACHED
from ...workspace.study_files import StudyResult, save_study
from ...workspace.workpiece import TargetSet
from . import Part, check_metrics, register


class Agreement(TypedDict):
    """A cell's targets against REACH's saved answer (its last optimisation step)."""

    targets: int
    reach_reached: int
    wsmap_reached: int
    both: int
    reach_only: int  #: reached by REACH, not by wsmap
    wsmap_only: int


class Metrics(TypedDict):
    """`results/reach_study.json`."""

    cells: list[dict]  #: per cell and arm: targets, variants, coverage, counts, mean score, base, seconds
    agreement: dict  #: per cell with a REACH database: `Agreement`


PART = Part("reach_study", "The reach study of real cells", 92, outputs=(
    "results/reach_study.json", "results/reach_study", "results/reach_study_html", "tables/reach_study.csv",
    "tables/reach_study.md",
    "figures/reach_study_heatmap.png"))


@dataclass
class Result:
    metrics: dict
    table: pd.DataFrame
    studies: dict  #: cell -> StudyResult
    heat_map: str  #: the cell whose heat map is the figure (params `heat_map`)


def _thinned(targets: TargetSet, stride: int) -> TargetSet:
    keep = np.arange(0, len(targets), stride)
    return dataclasses.replace(targets, points=targets.points[keep], normals=targets.normals[keep],
                               poses=targets.poses[keep], moved=targets.moved[keep])


def study_cell(spec: Mapping, *, log=print) -> tuple[StudyJob, StudyResult, float]:
    """Run the study of `spec["file"]` (relative to `data/cells/`), every `spec["stride"]`-th target,
    its base region at `spec["region_step"]` (m) where given; returns the job, result and seconds."""
    job = StudyJob.from_file(paths.CELLS / spec["file"])
    if spec.get("region_step") and job.base.region is not None:
        region = dataclasses.replace(job.base.region, step=float(spec["region_step"]))
        job = dataclasses.replace(job, base=dataclasses.replace(job.base, region=region))
    plan = job.check()
    stride = int(spec.get("stride", 1))
    if stride > 1:
        plan.targets = _thinned(plan.targets, stride)
    t0 = time.perf_counter()
    result = job.run(plan)
    seconds = time.perf_counter() - t0
    log(f"{spec['file']}: {len(plan.targets)} targets x {len(result.variants)} variants, "
        f"{len(plan.robots)} arm(s) in {seconds:.1f} s")
    return job, result, seconds


def agreement(result: StudyResult, db_file: str, stride: int = 1) -> Agreement:
    """The first arm's answer at its best base against REACH's database `db_file` (under
    `data/cells/`), the same targets (every `stride`-th)."""
    db = read_reach_db(paths.CELLS / db_file)
    theirs = db.reached[db.final][::stride]
    ours = result.results[0][0].status == REACHED
    if len(theirs) != len(ours):
        raise ValueError(f"{db_file}: {len(theirs)} targets, the study has {len(ours)}")
    return Agreement(targets=len(ours), reach_reached=int(theirs.sum()), wsmap_reached=int(ours.sum()),
                     both=int((ours & theirs).sum()), reach_only=int((theirs & ~ours).sum()),
                     wsmap_only=int((ours & ~theirs).sum()))


def _rows(cell: str, result: StudyResult, seconds: float) -> list[dict]:
    rows = []
    for row in result.summary():
        x, y, z = (float(v) + 0.0 for v in row["base_xyz"])  # + 0.0: no "-0.000"
        rows.append({"cell": cell, "arm": row["arm"], "targets": len(result.targets),
                     "variants": len(result.variants), "coverage_pct": 100 * row["coverage"],
                     "reached": row["reached"], "certified_unreachable": row["certified unreachable"],
                     "not_found": row["not found"], "mean_score": row["mean_score"],
                     "base_x_m": x, "base_y_m": y, "base_z_m": z, "seconds": seconds})
    return rows


def run(cfg: Mapping, out: Outputs | None = None, *, log=print) -> Result:
    rows, agree, studies = [], {}, {}
    for cell, spec in cfg["cells"].items():
        _, result, seconds = study_cell(spec, log=log)
        studies[cell] = result
        rows += _rows(cell, result, seconds)
        if spec.get("reach_db"):
            agree[cell] = agreement(result, spec["reach_db"], int(spec.get("stride", 1)))
            log(f"{cell} against REACH's database: {agree[cell]}")
    metrics = check_metrics({"cells": rows, "agreement": agree}, Metrics, PART.name)
    return Result(metrics, pd.DataFrame(rows), studies, cfg["heat_map"])


def in_checkout(value, root: Path | None = None):
    """`value` (a study's settings: nested dicts, lists, strings) with every absolute path under the
    checkout `root` (default `paths.ROOT`) written relative to it, POSIX-style; other values as they
    are. The committed study files then hold the same bytes on every clone (a study run from the
    command line keeps its paths as given)."""
    root = Path(paths.ROOT if root is None else root).resolve()
    if isinstance(value, Mapping):
        return {k: in_checkout(v, root) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(in_checkout(v, root) for v in value)
    if isinstance(value, str) and Path(value).is_absolute() and Path(value).is_relative_to(root):
        return Path(value).relative_to(root).as_posix()
    return value


def save(result: Result, out: Outputs) -> None:
    folder = out.results / "reach_study"
    folder.mkdir(parents=True, exist_ok=True)
    for cell, study in result.studies.items():
        study = dataclasses.replace(study, settings=in_checkout(study.settings),
                                    targets=dataclasses.replace(study.targets, source=in_checkout(study.targets.source)))
        save_study(folder / f"{cell}.npz", study)
    write_json(result.metrics, out.results / "reach_study.json")
    write_table(result.table, out.tables / "reach_study", whole=("targets", "variants", "reached",
                                                                   "certified_unreachable", "not_found"))


def figures(result: Result, out: Outputs) -> list[Path]:
    """The heat map of the cell `result.heat_map` as PNG (the figure), its HTML and PLY beside the study files."""
    from ...study_views import save_views

    cell = result.heat_map
    html = out.results / "reach_study_html"
    html.mkdir(parents=True, exist_ok=True)
    png = out.figures / "reach_study_heatmap.png"
    save_views(result.studies[cell], png=png, html=html / f"{cell}.html",
               ply=out.results / "reach_study" / f"{cell}.ply")
    return [png]


register(PART)
