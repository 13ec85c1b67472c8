"""The maps roboticists use, for the named arms (beyond the paper).

For every named arm (``wsmap robots``): the reachability index over a set of orientations spread on
SO(3) (super-Fibonacci, seed), the reach and dexterous volumes, the PUMA560's manipulability map,
and base placement of a UR5e and a Panda for pick poses on a table (world frame, tool down). Arms
of a closed-form family are mapped exactly, the others by the numerical search.
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
from ...io import write_json, write_table
from ...paths import Outputs
from ...views import figure_3d, iso_mesh, save_glb, save_html, save_ply
from ...workspace.kinds import get_kind
from . import Part, check_metrics, register, save_figure


class Metrics(TypedDict):
    """``results/real_arms.json``."""

    arms: list[dict]  #: per arm: method, nodes, volumes (m³), mean index where reached, seconds
    placement: list[dict]  #: per arm and rank: base x, y (m), yaw (deg), targets reached, score, seconds
    orientations: int
    step: float  #: grid step (m)
    puma560_manipulability_max: float


PART = Part("real_arms", "The maps roboticists use, for real arms", 90, outputs=(
    "results/real_arms.json", "results/real_arms", "results/real_arms_html",
    "tables/real_arms_volumes.csv", "tables/real_arms_volumes.md",
    "tables/real_arms_placement.csv", "tables/real_arms_placement.md",
    *(f"figures/real_arms_index_{a}.png" for a in ("puma560", "panda", "iiwa14", "ur5e", "ur10e", "gen3")),
    "figures/real_arms_index_panda_3d.png", "figures/real_arms_puma560_manipulability.png",
    "figures/real_arms_puma560_manipulability_3d.png"))


#: The interactive view's threshold slider: the nodes whose index is above each (0: every reached node).
VIEW_THRESHOLDS = tuple(round(0.1 * i, 1) for i in range(10))


@dataclass
class Result:
    metrics: Metrics
    volumes: pd.DataFrame
    placement: pd.DataFrame
    index_maps: dict  #: arm -> (reachability index per node, grid spec)
    manipulability: np.ndarray  #: the PUMA560's map
    manipulability_grid: dict
    cfg: Mapping

    def targets(self) -> pd.DataFrame:
        return pd.DataFrame([{"target": i, "x_m": p[0], "y_m": p[1], "z_m": p[2]}
                             for i, p in enumerate(self.cfg["placement"]["positions"])])


def run(cfg: Mapping, out: Outputs | None = None, *, log=print) -> Result:
    """The maps, volumes and placements of params section ``cfg``."""
    step, k = cfg["step"], cfg["orientations"]
    orientations = workspace.orientation_samples(k, seed=cfg["seed"])
    arms = {name: robots.load(name) for name in cfg["arms"]}
    log(f"{len(arms)} arms, {k} orientations (super-Fibonacci), grid step {step} m")
    rows, index_maps = [], {}
    for name, arm in arms.items():
        h = cfg["half_width"][name]
        grid = workspace.grid_spec("R3", -h, h, step)
        nodes = workspace.cartesian_grid(grid["lo"], grid["hi"], grid["step"])
        method = workspace.resolve_method(arm)
        t0 = time.perf_counter()
        index = workspace.reachability_index(arm, nodes, orientations)
        t_index = time.perf_counter() - t0
        t0 = time.perf_counter()
        reach = workspace.position_map(arm, nodes)
        t_reach = time.perf_counter() - t0
        cell = step ** 3
        index_maps[name] = (index, grid)
        rows.append({"arm": name, "method": method, "nodes": len(nodes), "orientations": k,
                     "reach_volume_m3": reach.sum() * cell,
                     "reachable_at_some_orientation_of_the_set_m3": (index > 0).sum() * cell,
                     "dexterous_volume_m3": (index == 1).sum() * cell,
                     "mean_index_where_reached": float(index[index > 0].mean()) if (index > 0).any() else 0.0,
                     "index_seconds": t_index, "reach_seconds": t_reach})
        log(f"{name}: {method}, index in {t_index:.1f} s, reach map in {t_reach:.1f} s")

    # the largest Yoshikawa manipulability over the closed form's 8 branches, 0 where unreachable
    h = cfg["half_width"]["puma560"]
    mgrid = workspace.grid_spec("R3", -h, h, step)
    mnodes = workspace.cartesian_grid(mgrid["lo"], mgrid["hi"], mgrid["step"])
    manip = workspace.manipulability_map(robots.puma560(), mnodes, cfg["manipulability_rpy"])
    positive = manip[manip > 0]
    log(f"max manipulability {manip.max():.4f}, median where reachable "
        f"{np.median(positive) if positive.size else 0:.4f}")

    t = cfg["placement"]
    targets = np.stack([workspace.target_poses(p, t["rpy"], "standard") for p in t["positions"]])
    place_rows = []
    for name in t["arms"]:
        t0 = time.perf_counter()
        pl = workspace.base_placement(robots.load(name), targets, x=t["x"], y=t["y"], step=t["step"], yaws=t["yaws"])
        seconds = time.perf_counter() - t0
        for r in range(t["top"]):
            place_rows.append({"arm": name, "rank": r + 1, "x_m": pl.x[r], "y_m": pl.y[r],
                               "yaw_deg": np.degrees(pl.yaw[r]), "targets_reached": int(pl.reached[r].sum()),
                               "score": pl.score[r], "seconds": seconds})
        log(f"{name}: best base {pl.best()['x']:+.2f}, {pl.best()['y']:+.2f} m, "
            f"{np.degrees(pl.best()['yaw']):.0f} deg reaches {pl.score[0]:.0%} of {len(targets)} targets "
            f"({seconds:.1f} s)")
    metrics: Metrics = {"arms": rows, "placement": place_rows, "orientations": k, "step": step,
                        "puma560_manipulability_max": float(manip.max())}
    return Result(check_metrics(metrics, Metrics, PART.name), pd.DataFrame(rows), pd.DataFrame(place_rows),
                  index_maps, manip, mgrid, cfg)


def _levels(manip: np.ndarray) -> tuple[float, ...]:
    positive = manip[manip > 0]
    return tuple(float(v) for v in np.quantile(positive, [0.5, 0.9])) if positive.size else (0.5,)


def save(result: Result, out: Outputs) -> None:
    """The metrics file, the tables, and the 3-D views (``results/real_arms/``: PLY point clouds and
    GLB iso-surfaces of each index; ``results/real_arms_html/``: the interactive view of
    ``show_3d``, a standalone page carrying plotly.js, about 5 MB: DVC-cached, not committed)."""
    cfg = result.cfg
    views = out.results / "real_arms"
    views.mkdir(parents=True, exist_ok=True)
    for name, (index, grid) in result.index_maps.items():
        if (index > 0).any():
            save_ply(views / f"{name}_index.ply", index, grid, label="reachability index")
            save_glb(views / f"{name}_index.glb", index, grid, levels=cfg["iso_levels"])
    save_glb(views / "puma560_manipulability.glb", result.manipulability, result.manipulability_grid,
             levels=_levels(result.manipulability))
    show = cfg["show_3d"]
    index, grid = result.index_maps[show]
    html_dir = out.results / "real_arms_html"
    html_dir.mkdir(parents=True, exist_ok=True)
    save_html(html_dir / f"{show}_index.html", index, grid, kind="points", label="reachability index",
              title=f"{show}: reachability index over {cfg['orientations']} orientations", thresholds=VIEW_THRESHOLDS,
              cut_plane=True)
    write_table(result.volumes, out.tables / "real_arms_volumes")
    write_table(result.placement, out.tables / "real_arms_placement")
    write_json(result.metrics, out.results / "real_arms.json")


def figure_3d_of_shown(result: Result):
    """The interactive plotly view of ``show_3d``'s index (the notebook shows it)."""
    show = result.cfg["show_3d"]
    index, grid = result.index_maps[show]
    return figure_3d(index, grid, kind="points", label="reachability index",
                     title=f"{show}: reachability index over {result.cfg['orientations']} orientations",
                     thresholds=VIEW_THRESHOLDS, cut_plane=True)


def figures(result: Result, out: Outputs) -> list[Path]:
    """Index slices per arm, an iso-surface of ``show_3d``'s index, the PUMA560's manipulability."""
    cfg, k = result.cfg, result.metrics["orientations"]
    paths = []
    for name, (index, grid) in result.index_maps.items():
        method = result.volumes.set_index("arm").loc[name, "method"]
        title = viz.map_title(name, get_kind("index"), orientations=k, summary=f"{method}, grid step {cfg['step']} m")
        fig = viz.plot_value_slices(index, grid["shape"], grid["lo"], grid["step"], label="reachability index",
                                    vmin=0, vmax=1, title=title, metadata=viz.png_metadata(
                                        {"arm": name, "kind": "index", "method": method, "orientations": k,
                                         "orientation_seed": cfg["seed"], "grid": grid}, title=title))
        paths.append(save_figure(fig, out.figures / f"real_arms_index_{name}.png"))
    show = cfg["show_3d"]
    index, grid = result.index_maps[show]
    ax = viz.render_mesh(iso_mesh(index, grid, 0.5),
                         title=f"{show}: where at least half of the {k} orientations are reachable",
                         lim=cfg["half_width"][show])
    paths.append(save_figure(ax.figure, out.figures / f"real_arms_index_{show}_3d.png"))
    manip, mgrid = result.manipulability, result.manipulability_grid
    title = viz.map_title("puma560", get_kind("manipulability"), rpy=cfg["manipulability_rpy"], convention="standard",
                          summary="exact: the largest of the 8 closed-form branches, 0 where unreachable")
    fig = viz.plot_value_slices(manip, mgrid["shape"], mgrid["lo"], mgrid["step"],
                                label=get_kind("manipulability").label, title=title, metadata=viz.png_metadata(
                                    {"arm": "puma560", "kind": "manipulability", "method": "exact",
                                     "rpy": cfg["manipulability_rpy"], "grid": mgrid}, title=title))
    paths.append(save_figure(fig, out.figures / "real_arms_puma560_manipulability.png"))
    ax = viz.render_mesh(iso_mesh(manip, mgrid, _levels(manip)[0]), title="PUMA560: manipulability above its median",
                         lim=cfg["half_width"]["puma560"])
    paths.append(save_figure(ax.figure, out.figures / "real_arms_puma560_manipulability_3d.png"))
    return paths


register(PART)
