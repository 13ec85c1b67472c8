"""The maps roboticists use, for the named arms (beyond the paper).

For every named arm (`wsmap robots`): the reachability index over a set of orientations spread on
SO(3) (super-Fibonacci, seed), the reach and dexterous volumes, the PUMA560's manipulability map,
and base placement of a UR5e and a Panda for pick poses on a table (world frame, tool down). Arms
of a closed-form family are mapped exactly, the others by the numerical search.

What collisions remove (params `collision`): for each named arm with a collision model
(`wsmap.collision.named`: panda, ur5e, iiwa14) the tool-down map (`T = transl(p)·Rx(π)`,
standard convention) and the reachability index, three ways: the chain alone, with self-collision
and the floor, and with a table (a box in the base frame) as well; the volume each loses (m³, %);
and a base placement around a table in the world (targets on its top) ranked by the chain alone and
collision-aware (`wsmap.collision.CollisionChecker.at_bases` checks each candidate base).
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
from ...workspace.status import CERTIFIED, NOT_FOUND, node_status_over, orientation_status
from . import Part, check_metrics, register, save_figure


class CollisionPlacement(TypedDict):
    """The base placement around a world-frame table, chain alone against collision-aware."""

    arm: str
    targets: int
    chain_best: list  #: [x (m), y (m), yaw (deg), score] of the chain-only ranking's best base
    free_best: list  #: the same for the collision-aware ranking
    chain_best_free_score: float  #: what the chain-only choice reaches once collisions count
    best_changed: bool  #: whether the best base moved
    chain_seconds: float
    free_seconds: float


class Metrics(TypedDict):
    """`results/real_arms.json`."""

    arms: list[dict]  #: per arm: method, nodes, volumes (m³), mean index where reached, seconds; index nodes certified unreachable / not found and the certificates' seconds
    placement: list[dict]  #: per arm and rank: base x, y (m), yaw (deg), targets reached, score, seconds
    orientations: int
    step: float  #: grid step (m)
    puma560_manipulability_max: float
    #: per arm, kind (tooldown, index) and way (chain, self_floor, table): nodes, volume (m³), its
    #: loss against the chain (m³, %), the index-weighted volume Σ index·cell (m³) and its loss (%),
    #: seconds; the collision part's own grid step and orientations
    collision: list[dict]
    collision_placement: CollisionPlacement


PART = Part("real_arms", "The maps roboticists use, for real arms", 90, outputs=(
    "results/real_arms.json", "results/real_arms", "results/real_arms_html",
    "tables/real_arms_volumes.csv", "tables/real_arms_volumes.md",
    "tables/real_arms_placement.csv", "tables/real_arms_placement.md",
    *(f"figures/real_arms_index_{a}.png" for a in ("puma560", "panda", "iiwa14", "ur5e", "ur10e", "gen3")),
    "figures/real_arms_index_panda_3d.png", "figures/real_arms_puma560_manipulability.png",
    "figures/real_arms_puma560_manipulability_3d.png",
    "tables/real_arms_collision.csv", "tables/real_arms_collision.md",
    "tables/real_arms_collision_placement.csv", "tables/real_arms_collision_placement.md",
    "figures/real_arms_collision.png", "figures/real_arms_collision_placement.png"))

#: The three ways every collision map is computed (the `way` column), in order.
WAYS = ("chain", "self_floor", "table")
#: The tool-down orientation of the collision part (`T = transl(p)·Rx(π)`, standard convention).
TOOL_DOWN = (np.pi, 0.0, 0.0)


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
    collision: pd.DataFrame | None = None  #: the collision volumes (one row per arm, kind, way)
    collision_maps: dict | None = None  #: arm -> {"grid", "tooldown": {way: bool (N,)}, "index": {way: (N,)}}
    collision_placement: pd.DataFrame | None = None  #: the top bases of both rankings
    placement_scores: dict | None = None  #: "chain"/"free" -> score (ny, nx) best over headings; "x", "y"
    #: arm -> int8 (N,) each index node's answer over the orientations (`wsmap.node_status_over`:
    #: reached, certified unreachable, not found), from the sound filters and the closed forms
    index_status: dict | None = None

    def targets(self) -> pd.DataFrame:
        return pd.DataFrame([{"target": i, "x_m": p[0], "y_m": p[1], "z_m": p[2]}
                             for i, p in enumerate(self.cfg["placement"]["positions"])])


def run(cfg: Mapping, out: Outputs | None = None, *, log=print) -> Result:
    """The maps, volumes and placements of params section `cfg`."""
    step, k = cfg["step"], cfg["orientations"]
    orientations = workspace.orientation_samples(k, seed=cfg["seed"])
    arms = {name: robots.load(name) for name in cfg["arms"]}
    log(f"{len(arms)} arms, {k} orientations (super-Fibonacci), grid step {step} m")
    rows, index_maps, index_status = [], {}, {}
    for name, arm in arms.items():
        h = cfg["half_width"][name]
        grid = workspace.grid_spec("R3", -h, h, step)
        nodes = workspace.cartesian_grid(grid["lo"], grid["hi"], grid["step"])
        method = workspace.resolve_method(arm)
        # an untimed call on a few nodes first: the compiled kernels load (or compile, once per
        # machine and source) outside the timings
        few = nodes[:: max(1, len(nodes) // 8)]
        workspace.reachability_index(arm, few, orientations[:2])
        workspace.position_map(arm, few)
        t0 = time.perf_counter()
        index, bits = workspace.reachability_index(arm, nodes, orientations, return_bits=True)
        t_index = time.perf_counter() - t0
        # each node's answer: the certificates the map file of an index gets by default (budget 0:
        # the sound filters and the closed form's), over the N x K poses in blocks
        t0 = time.perf_counter()
        status = node_status_over(orientation_status(arm, nodes, orientations, bits, method, budget=0))
        t_status = time.perf_counter() - t0
        index_status[name] = status
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
                     "index_seconds": t_index, "reach_seconds": t_reach,
                     "nodes_certified_unreachable": int((status == CERTIFIED).sum()),
                     "nodes_not_found": int((status == NOT_FOUND).sum()), "status_seconds": t_status})
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
    c = cfg["collision"]
    table = table_obstacle(c["table"], "base")
    coll_rows, coll_maps = collision_volumes(c["arms"], c["step"], {a: cfg["half_width"][a] for a in c["arms"]},
                                             workspace.orientation_samples(c["orientations"], seed=cfg["seed"]),
                                             table, log=log)
    cp = collision_placement(c["placement"], log=log)
    metrics: Metrics = {"arms": rows, "placement": place_rows, "orientations": k, "step": step,
                        "puma560_manipulability_max": float(manip.max()), "collision": coll_rows,
                        "collision_placement": cp["metrics"]}
    return Result(check_metrics(metrics, Metrics, PART.name), pd.DataFrame(rows), pd.DataFrame(place_rows),
                  index_maps, manip, mgrid, cfg, pd.DataFrame(coll_rows), coll_maps, cp["table"], cp["scores"],
                  index_status)


def table_obstacle(spec: Mapping, frame: str):
    """The table of params (`size` [x, y, z] m, a solid box; `xyz` its centre, m) as a
    `wsmap.collision.Obstacle` in `frame` (`"base"` or `"world"`); a bad size or
    position is a `wsmap.collision.CollisionError` naming it (the scene files' checks)."""
    from ...collision import scene_from_dict

    item = {"name": "table", "shape": "box", "size": list(spec["size"]), "xyz": list(spec["xyz"])}
    return scene_from_dict({"frame": frame, "floor": True, "obstacles": [item]}, label="params real_arms table"
                           ).obstacles[0]


def _checkers(name: str, table):
    """The three ways of arm `name`: None (the chain), self-collision and the floor, and the
    floor and `table` as well (one model, one allowed-collision matrix)."""
    from ...collision import CollisionChecker, Scene, checker_for

    free = checker_for(name)
    return {"chain": None, "self_floor": free,
            "table": CollisionChecker(free.model, Scene(floor=0.0, obstacles=(table,)))}


def collision_volumes(arms, step: float, half_width: Mapping, orientations: np.ndarray, table, *,
                      log=print) -> tuple[list[dict], dict]:
    """What collisions remove from the tool-down map and the reachability index of each of
    `arms` (named arms with a capsule model) on the cube of half-width `half_width[arm]` (m)
    sampled at `step` (m), over `orientations` (K, 3, 3), three ways (`WAYS`); `table`
    an obstacle in the base frame (`table_obstacle`).

    Returns the rows (per arm, kind `tooldown`/`index` and way: `nodes` reached,
    `volume_m3` = nodes · step³ (the index: nodes with index > 0), `lost_m3` and `lost_pct`
    against the chain, `index_volume_m3` = Σ index · step³ (the tool-down map: its volume) and
    `index_lost_pct`, `volume_above_floor_m3` (nodes with z > 0; the z = 0 layer counts with
    the floor) and `lost_above_floor_pct` (the share of those lost: mostly what self-collision and
    the table take, the floor's cut of the lower half left aside; an arm reaching a node just above
    the floor can still dip into it), `seconds`) and the maps (arm -> `grid`, `tooldown`/`index`: way ->
    the map in node order)."""
    rows, maps = [], {}
    cell = step ** 3
    for name in arms:
        arm = robots.load(name)
        h = half_width[name]
        grid = workspace.grid_spec("R3", -h, h, step)
        nodes = workspace.cartesian_grid(grid["lo"], grid["hi"], grid["step"])
        ways = _checkers(name, table)
        above = nodes[:, 2] > 1e-9  # a grid's z = 0 layer lies at ±1e-16: it counts with the floor
        maps[name] = {"grid": grid, "tooldown": {}, "index": {}}
        for kind in ("tooldown", "index"):
            base = None
            for way, chk in ways.items():
                t0 = time.perf_counter()
                if kind == "tooldown":
                    m = workspace.constant_orientation_map(arm, nodes, TOOL_DOWN, convention="standard", collision=chk)
                    values = m.astype(np.float64)
                else:
                    values = workspace.reachability_index(arm, nodes, orientations, collision=chk)
                seconds = time.perf_counter() - t0
                maps[name][kind][way] = m if kind == "tooldown" else values
                vol, ivol = float((values > 0).sum() * cell), float(values.sum() * cell)
                # the floor alone takes every node below z = 0: the volume above it shows what
                # self-collision and the table take
                up = float(((values > 0) & above).sum() * cell)
                base = (vol, ivol, up) if base is None else base
                rows.append({"arm": name, "kind": kind, "way": way, "step_m": step,
                             "orientations": 1 if kind == "tooldown" else len(orientations),
                             "nodes": int((values > 0).sum()), "volume_m3": vol, "lost_m3": base[0] - vol,
                             "lost_pct": 100 * (base[0] - vol) / base[0] if base[0] else 0.0,
                             "index_volume_m3": ivol,
                             "index_lost_pct": 100 * (base[1] - ivol) / base[1] if base[1] else 0.0,
                             "volume_above_floor_m3": up,
                             "lost_above_floor_pct": 100 * (base[2] - up) / base[2] if base[2] else 0.0,
                             "seconds": seconds})
                log(f"{name} {kind} {way}: {vol:.3f} m³ (-{rows[-1]['lost_pct']:.1f} %; above the floor "
                    f"-{rows[-1]['lost_above_floor_pct']:.1f} %) in {seconds:.1f} s")
    return rows, maps


def collision_placement(spec: Mapping, *, log=print) -> dict:
    """Base placement of `spec["arm"]` around a table in the world (`spec["table"]`, see
    `table_obstacle`) for tool poses `spec["positions"]` (world, m) at `spec["rpy"]`
    (standard convention), candidates on `x` × `y` (m) at `step` with `yaws` headings, ranked
    twice: by the chain alone and collision-aware (self-collision, the floor and the table, checked
    from each candidate base). Returns `metrics` (`CollisionPlacement`), `table` (the
    `top` bases of each ranking, each with both rankings' scores `score_chain`, `score_free`) and `scores`
    (`chain`/`free`: the best score over the headings at each position, `(ny, nx)`, and the
    positions `x` (nx,), `y` (ny,), m)."""
    from ...collision import CollisionChecker, Scene, arm_model, build_acm

    arm = robots.load(spec["arm"])
    table = table_obstacle(spec["table"], "world")
    targets = np.stack([workspace.target_poses(p, spec["rpy"], "standard") for p in spec["positions"]])
    model = arm_model(spec["arm"])
    model.acm = build_acm(model)
    chk = CollisionChecker(model, Scene(floor=0.0, obstacles=(table,)))
    # ranked by reach alone (ties to the middle of the region), as this comparison was made: the
    # default tie-break by the solutions' manipulability already prefers bases beside the table
    kw = {"x": spec["x"], "y": spec["y"], "step": spec["step"], "yaws": spec["yaws"], "tiebreak": "centre"}
    runs, seconds = {}, {}
    for way, c in (("chain", None), ("free", chk)):
        t0 = time.perf_counter()
        runs[way] = workspace.base_placement(arm, targets, collision=c, **kw)
        seconds[way] = time.perf_counter() - t0
    key = {way: {(round(x, 9), round(y, 9), round(w, 9)): s for x, y, w, s in zip(p.x, p.y, p.yaw, p.score)}
           for way, p in runs.items()}

    def best(p):
        return [round(float(p.x[0]), 9) + 0.0, round(float(p.y[0]), 9) + 0.0, float(np.degrees(p.yaw[0])),
                float(p.score[0])]

    ch, fr = runs["chain"], runs["free"]
    chain_free = key["free"][(round(ch.x[0], 9), round(ch.y[0], 9), round(ch.yaw[0], 9))]
    changed = not (np.isclose(ch.x[0], fr.x[0]) and np.isclose(ch.y[0], fr.y[0]) and np.isclose(ch.yaw[0], fr.yaw[0]))
    rows = [{"ranking": way, "rank": r + 1, "x_m": round(float(p.x[r]), 9) + 0.0, "y_m": round(float(p.y[r]), 9) + 0.0,
             "yaw_deg": float(np.degrees(p.yaw[r])),
             **{f"score_{w}": float(key[w][(round(p.x[r], 9), round(p.y[r], 9), round(p.yaw[r], 9))]) for w in runs},
             "seconds": seconds[way]}
            for way, p in runs.items() for r in range(min(spec["top"], len(p.score)))]
    xs = np.unique(np.round(ch.x, 9))
    ys = np.unique(np.round(ch.y, 9))
    scores = {"x": xs, "y": ys}
    for way, p in runs.items():
        g = np.zeros((len(ys), len(xs)))
        np.maximum.at(g, (np.searchsorted(ys, np.round(p.y, 9)), np.searchsorted(xs, np.round(p.x, 9))), p.score)
        scores[way] = g
    metrics: CollisionPlacement = {"arm": spec["arm"], "targets": len(targets), "chain_best": best(ch),
                                   "free_best": best(fr), "chain_best_free_score": float(chain_free),
                                   "best_changed": bool(changed), "chain_seconds": seconds["chain"],
                                   "free_seconds": seconds["free"]}
    log(f"{spec['arm']} around the table: chain-only best {best(ch)[:2]} m reaches {ch.score[0]:.0%} "
        f"({chain_free:.0%} collision-free); collision-aware best {best(fr)[:2]} m {fr.score[0]:.0%} "
        f"({seconds['chain']:.1f} s, {seconds['free']:.1f} s)")
    return {"metrics": metrics, "table": pd.DataFrame(rows), "scores": scores}


def _levels(manip: np.ndarray) -> tuple[float, ...]:
    positive = manip[manip > 0]
    return tuple(float(v) for v in np.quantile(positive, [0.5, 0.9])) if positive.size else (0.5,)


def save(result: Result, out: Outputs) -> None:
    """The metrics file, the tables, and the 3-D views (`results/real_arms/`: PLY point clouds and
    GLB iso-surfaces of each index; `results/real_arms_html/`: the interactive view of
    `show_3d`, a standalone page carrying plotly.js, about 5 MB: DVC-cached, not committed)."""
    cfg = result.cfg
    views = out.results / "real_arms"
    views.mkdir(parents=True, exist_ok=True)
    status = result.index_status or {}
    for name, (index, grid) in result.index_maps.items():
        if (index > 0).any():
            save_ply(views / f"{name}_index.ply", index, grid, label="reachability index", status=status.get(name))
            save_glb(views / f"{name}_index.glb", index, grid, levels=cfg["iso_levels"], status=status.get(name))
    save_glb(views / "puma560_manipulability.glb", result.manipulability, result.manipulability_grid,
             levels=_levels(result.manipulability))
    show = cfg["show_3d"]
    index, grid = result.index_maps[show]
    html_dir = out.results / "real_arms_html"
    html_dir.mkdir(parents=True, exist_ok=True)
    save_html(html_dir / f"{show}_index.html", index, grid, kind="points", label="reachability index",
              title=f"{show}: reachability index over {cfg['orientations']} orientations", thresholds=VIEW_THRESHOLDS,
              cut_plane=True, status=status.get(show))
    write_table(result.volumes, out.tables / "real_arms_volumes")
    write_table(result.placement, out.tables / "real_arms_placement")
    write_table(result.collision, out.tables / "real_arms_collision")
    write_table(result.collision_placement, out.tables / "real_arms_collision_placement")
    write_json(result.metrics, out.results / "real_arms.json")


def figure_3d_of_shown(result: Result, stride: int = 1):
    """The interactive plotly view of `show_3d`'s index (the notebook shows it), on every
    `stride`-th node along each axis (the grid's step times `stride`, the same first node)."""
    show = result.cfg["show_3d"]
    index, grid = result.index_maps[show]
    status = (getattr(result, "index_status", None) or {}).get(show)
    if isinstance(stride, bool) or not isinstance(stride, int) or stride < 1:
        raise ValueError(f"stride must be a positive integer, got {stride!r}")
    if stride > 1:
        nx, ny, nz = grid["shape"]  # node order: x fastest
        index = np.asarray(index).reshape(nz, ny, nx)[::stride, ::stride, ::stride].ravel()
        if status is not None:
            status = np.asarray(status).reshape(nz, ny, nx)[::stride, ::stride, ::stride].ravel()
        shape = [len(range(0, n, stride)) for n in (nx, ny, nz)]
        step = [s * stride for s in grid["step"]]
        hi = [lo + (n - 1) * st for lo, n, st in zip(grid["lo"], shape, step)]
        grid = {**grid, "step": step, "shape": shape, "hi": hi}
    return figure_3d(index, grid, kind="points", label="reachability index",
                     title=f"{show}: reachability index over {result.cfg['orientations']} orientations",
                     thresholds=VIEW_THRESHOLDS, cut_plane=True, status=status)


def figures(result: Result, out: Outputs) -> list[Path]:
    """Index slices per arm, an iso-surface of `show_3d`'s index, the PUMA560's manipulability."""
    cfg, k = result.cfg, result.metrics["orientations"]
    paths = []
    status = result.index_status or {}
    for name, (index, grid) in result.index_maps.items():
        method = result.volumes.set_index("arm").loc[name, "method"]
        title = viz.map_title(name, get_kind("index"), orientations=k, summary=f"{method}, grid step {cfg['step']} m")
        fig = viz.plot_value_slices(index, grid["shape"], grid["lo"], grid["step"], label="reachability index",
                                    vmin=0, vmax=1, title=title, status=status.get(name), metadata=viz.png_metadata(
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
    if result.collision_maps:
        paths.append(save_figure(collision_figure(result), out.figures / "real_arms_collision.png"))
        paths.append(save_figure(placement_figure(result), out.figures / "real_arms_collision_placement.png"))
    return paths


_WAY_TITLES = {"chain": "chain alone", "self_floor": "+ self-collision, floor", "table": "+ table"}


def _section(values, grid, y: float = 0.0) -> tuple[np.ndarray, list]:
    """The x–z section of a map at the grid layer nearest `y` (m): `(nz, nx)` and the extent (m)."""
    nx, ny, nz = grid["shape"]
    lo, st = np.broadcast_to(grid["lo"], 3), np.broadcast_to(grid["step"], 3)
    j = int(np.clip(np.rint((y - lo[1]) / st[1]), 0, ny - 1))
    vol = np.asarray(values, dtype=np.float64).reshape(nz, ny, nx)  # node order: x fastest
    ext = [lo[0] - st[0] / 2, lo[0] + (nx - 0.5) * st[0], lo[2] - st[2] / 2, lo[2] + (nz - 0.5) * st[2]]
    return vol[:, j, :], ext


def collision_figure(result: Result):
    """One row per arm: the x–z section at y = 0 (m, base frame) of the tool-down map and of the
    reachability index, each the chain alone, with self-collision and the floor, and with the table
    (outlined): what a way keeps in colour, what collisions removed from the chain's map in red."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch, Rectangle

    cm = result.collision_maps
    c = result.cfg["collision"]
    tx, tz = c["table"]["xyz"][0], c["table"]["xyz"][2]
    sx, sz = c["table"]["size"][0], c["table"]["size"][2]
    fig, axes = plt.subplots(len(cm), 6, figsize=(17, 3.3 * len(cm) + 0.8), squeeze=False, sharey="row",
                             layout="constrained")
    red = ListedColormap(["#d62728"])
    im = None
    for r, (name, m) in enumerate(cm.items()):
        for k, kind in enumerate(("tooldown", "index")):
            chain = m[kind]["chain"]
            for w, way in enumerate(WAYS):
                ax = axes[r, 3 * k + w]
                sec, ext = _section(m[kind][way], m["grid"])
                removed, _ = _section((chain > 0) & ~(m[kind][way] > 0), m["grid"])
                ax.set_facecolor("#eeeeee")
                shown = np.ma.masked_where(sec <= 0, sec)
                if kind == "tooldown":
                    ax.imshow(shown, origin="lower", extent=ext, cmap=ListedColormap(["#1f4e79"]), vmin=0, vmax=1)
                else:
                    im = ax.imshow(shown, origin="lower", extent=ext, cmap="viridis", vmin=0, vmax=1)
                ax.imshow(np.ma.masked_where(~removed.astype(bool), removed), origin="lower", extent=ext, cmap=red,
                          vmin=0, vmax=1)
                if way == "table":
                    ax.add_patch(Rectangle((tx - sx / 2, tz - sz / 2), sx, sz, fill=False, ec="k", lw=1.2))
                ax.axhline(0.0, color="k", lw=0.6)
                row = result.collision.query("arm == @name and kind == @kind and way == @way").iloc[0]
                what = "tool down" if kind == "tooldown" else f"index ({int(row['orientations'])} orient.)"
                ax.set_title(f"{name}: {what}\n{_WAY_TITLES[way]}: {row['volume_m3']:.2f} m³"
                             + (f" (−{row['lost_pct']:.0f} %)" if way != "chain" else ""), fontsize=8)
                ax.set_xlabel("x (m)", fontsize=8)
                if 3 * k + w == 0:
                    ax.set_ylabel("z (m)", fontsize=8)
                ax.tick_params(labelsize=7)
    if im is not None:
        fig.colorbar(im, ax=axes[:, -1].tolist(), shrink=0.8, label="reachability index")
    fig.legend(handles=[Patch(color="#1f4e79", label="tool down reachable"),
                        Patch(color="#d62728", label="removed by collisions (the chain reaches it)"),
                        Patch(color="#eeeeee", label="unreachable")], loc="outside lower center", ncol=3, fontsize=8)
    fig.suptitle(f"What collisions remove: section y = 0 m, grid step {c['step']} m, capsule models, "
                 f"table (outlined) in the base frame", fontsize=10)
    return fig


def placement_figure(result: Result):
    """The base placement around the table: the best score over the headings at each base position
    (world frame, m), chain-only ranking beside collision-aware, the table top outlined, the
    targets dotted and each ranking's best base starred."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    sc = result.placement_scores
    spec = result.cfg["collision"]["placement"]
    m = result.metrics["collision_placement"]
    x, y = sc["x"], sc["y"]
    st = spec["step"]
    ext = [x[0] - st / 2, x[-1] + st / 2, y[0] - st / 2, y[-1] + st / 2]
    fig, axes = plt.subplots(1, 2, figsize=(10.5, 4.6), sharey=True)
    pts = np.asarray(spec["positions"])
    tx, ty = spec["table"]["xyz"][:2]
    sx, sy = spec["table"]["size"][:2]
    for ax, way, best, title in ((axes[0], "chain", m["chain_best"], "chain alone"),
                                 (axes[1], "free", m["free_best"], "self-collision, floor and the table")):
        im = ax.imshow(sc[way], origin="lower", extent=ext, cmap="viridis", vmin=0, vmax=1)
        ax.add_patch(Rectangle((tx - sx / 2, ty - sy / 2), sx, sy, fill=False, ec="w", lw=1.5))
        ax.plot(pts[:, 0], pts[:, 1], "o", ms=4, color="#ff7f0e", label="targets (tool down)")
        ax.plot(*best[:2], "*", ms=16, color="#d62728", mec="k", label=f"best: {best[3]:.0%} at {best[2]:.0f}°")
        if way == "free":
            cb = m["chain_best"]
            ax.plot(*cb[:2], "x", ms=10, mew=2, color="w",
                    label=f"chain's best: {m['chain_best_free_score']:.0%} collision-free")
        ax.set_title(f"{spec['arm']}: {title}", fontsize=9)
        ax.set_xlabel("base x (m, world)")
        ax.legend(fontsize=7, loc="upper left")
    axes[0].set_ylabel("base y (m, world)")
    fig.colorbar(im, ax=axes.tolist(), shrink=0.85, label="targets reached (best heading)")
    fig.suptitle(f"Base placement around a table (outlined): {len(pts)} targets on its top, {spec['yaws']} headings",
                 fontsize=10)
    return fig


register(PART)
