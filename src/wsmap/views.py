"""3-D views and exchange files of workspace maps: iso-surfaces, glTF scenes, point clouds, and
interactive plotly figures (in a notebook or as standalone HTML).

A map here is a flat array `values` of one number per node of a grid, in the paper's node order
(first coordinate fastest, `wsmap.workspace.grids`): a boolean map (read as 0/1), a
reachability index in [0, 1], a manipulability map >= 0, ... The grid is a description
`{"scope", "lo", "hi", "step", "shape"}` (`wsmap.workspace.grid_spec`; 3-lists, `shape`
is `(nx, ny, nz)`; `hi` and `scope` are optional here). Node `(i, j, k)` lies at
`lo + (i, j, k) * step`: metres in the arm's base frame for an `"R3"` grid, radians
`(r1, r2, r3)` for an `"SO3"` grid. Every coordinate written or drawn here is such a node
coordinate (the grid's frame and units).

* `iso_mesh` — the iso-surface of a map at one level (`trimesh.Trimesh`);
* `save_glb` — coloured, semi-transparent iso-surfaces at several levels in one `.glb`;
* `save_ply` — the nodes above a threshold as a coloured point cloud `.ply` (with the value);
* `figure_3d` / `save_html` — a plotly figure (points or iso-surfaces) and a
  standalone HTML file of it with plotly.js inline (opens without a network).

Input is checked before anything is written (`ValueError` that says what is wrong: a map that does
not fit the grid, NaN or infinite values, no levels, ...); files are written atomically
(`wsmap.io`): a failed call leaves the target as it was. Flat matplotlib drawings of maps
(z-slices) are in `wsmap.viz` (`wsmap.viz.plot_value_slices` for float maps).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ._optional import require
from .io import atomic_path, check_output_path
from .workspace.grids import grid_counts, map_to_volume
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import Any, ArrayLike, PathLike, Sequence

__all__ = ["GLTF_FROM_GRID", "iso_mesh", "save_glb", "save_ply", "figure_3d", "save_html", "axis_titles"]

#: Transform of every node in the `.glb` scenes: the grid's frame (z up) to glTF's (y up):
#: `(x, y, z) -> (x, z, -y)`. The meshes' own vertices stay in the grid's frame.
GLTF_FROM_GRID = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])

_AXES = {"R3": (("x", "y", "z"), "m"), "SO3": (("r1", "r2", "r3"), "rad")}


# --------------------------------------------------------------------------------------------
# Checks
# --------------------------------------------------------------------------------------------


def _grid_parts(grid) -> tuple[str, tuple[int, int, int], np.ndarray, np.ndarray]:
    """`(scope, shape, lo, step)` of a grid description, checked."""
    if not isinstance(grid, Mapping):
        raise ValueError(f"grid must be a dict with 'lo', 'step' and 'shape' (see wsmap.workspace.grid_spec), "
                         f"got {type(grid).__name__}")
    missing = [k for k in ("lo", "step", "shape") if k not in grid]
    if missing:
        raise ValueError(f"grid is missing {missing} (a grid has 'scope', 'lo', 'hi', 'step', 'shape')")
    scope = grid.get("scope", "R3")
    if scope not in _AXES:
        raise ValueError(f"grid scope must be one of {sorted(_AXES)}, got {scope!r}")
    parts = []
    for name in ("lo", "step"):
        try:
            x = np.broadcast_to(np.asarray(grid[name], dtype=np.float64), (3,)).copy()
        except (TypeError, ValueError):
            raise ValueError(f"grid {name!r} must be a number or 3 numbers, got {grid[name]!r}") from None
        if not np.all(np.isfinite(x)):
            raise ValueError(f"grid {name!r} contains NaN or infinite values: {x.tolist()}")
        parts.append(x)
    lo, step = parts
    if np.any(step <= 0):
        raise ValueError(f"grid 'step' must be positive, got {step.tolist()}")
    shape_in = np.asarray(grid["shape"])
    whole = shape_in.dtype.kind in "iu" or (shape_in.dtype.kind == "f" and np.all(shape_in == np.round(shape_in)))
    if shape_in.shape != (3,) or not whole:
        raise ValueError(f"grid 'shape' must be 3 whole numbers (nx, ny, nz), got {grid['shape']!r}")
    shape = tuple(int(s) for s in shape_in)
    if min(shape) < 1:
        raise ValueError(f"grid 'shape' must be at least 1 on every axis, got {list(shape)}")
    if "hi" in grid and grid["hi"] is not None:
        counts = grid_counts(lo, grid["hi"], step)
        if tuple(counts) != shape:
            raise ValueError(f"grid 'shape' {list(shape)} does not match lo={lo.tolist()}, hi={grid['hi']!r}, "
                             f"step={step.tolist()} ({list(counts)} nodes per axis)")
    return scope, shape, lo, step


def _values(values, shape, what: str = "values") -> np.ndarray:
    """Flat float64 `(N,)` copy of a map that fits `shape` and is finite everywhere."""
    a = np.asarray(values)
    if a.dtype.kind not in "biuf":
        raise ValueError(f"{what} must be real numbers or booleans, got dtype {a.dtype}")
    n = int(np.prod(shape))
    if a.ndim != 1:
        raise ValueError(f"{what} must be a flat map (N,) in node order, got shape {a.shape}")
    if a.shape[0] != n:
        raise ValueError(f"{what} has {a.shape[0]} nodes but the grid {list(shape)} has {n}")
    a = a.astype(np.float64)
    bad = ~np.isfinite(a)
    if bad.any():
        raise ValueError(f"{what} contains {int(bad.sum())} NaN or infinite values (first at node {int(np.argmax(bad))})")
    return a


def _number(name: str, x) -> float:
    try:
        f = float(x)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number, got {x!r}") from None
    if isinstance(x, (complex, np.complexfloating)) or not math.isfinite(f):
        raise ValueError(f"{name} must be a finite real number, got {x!r}")
    return f


def _levels(levels) -> list[float]:
    if isinstance(levels, (str, bytes)):
        raise ValueError(f"levels must be numbers, got {levels!r}")
    try:
        seq = list(np.atleast_1d(np.asarray(levels, dtype=object)))
    except TypeError:
        raise ValueError(f"levels must be one number or a sequence of numbers, got {levels!r}") from None
    if not seq:
        raise ValueError("levels is empty: give at least one level")
    out = [_number("every level", v) for v in seq]
    if len(set(out)) != len(out):
        raise ValueError(f"levels must be distinct, got {out}")
    return out


def _norm_range(v: np.ndarray, vmin, vmax) -> tuple[float, float]:
    lo = float(v.min()) if vmin is None else _number("vmin", vmin)
    hi = float(v.max()) if vmax is None else _number("vmax", vmax)
    if hi < lo:
        raise ValueError(f"vmax ({hi}) must not be below vmin ({lo})")
    return lo, hi


def _cmap(colormap):
    import matplotlib

    try:
        return matplotlib.colormaps[colormap] if isinstance(colormap, str) else matplotlib.colormaps.get_cmap(colormap)
    except (KeyError, ValueError, TypeError):
        raise ValueError(f"unknown colormap {colormap!r} (a matplotlib colormap name such as 'viridis')") from None


def _rgba(values, lo: float, hi: float, cmap, alpha: float = 1.0) -> np.ndarray:
    """uint8 `(n, 4)` colours of `values` on `cmap` over `[lo, hi]` (mid colour when lo == hi)."""
    v = np.asarray(values, dtype=np.float64)
    t = np.full(v.shape, 0.5) if hi == lo else np.clip((v - lo) / (hi - lo), 0.0, 1.0)
    rgba = np.asarray(cmap(t), dtype=np.float64).reshape(-1, 4)
    rgba[:, 3] = alpha
    return np.round(255 * rgba).astype(np.uint8)


def axis_titles(grid: Mapping[str, Any]) -> tuple[str, str, str]:
    """Axis titles with units of a grid: `("x (m)", "y (m)", "z (m)")` for R3, `("r1 (rad)", ...)` for SO3."""
    names, unit = _AXES[_grid_parts(grid)[0]]
    return tuple(f"{n} ({unit})" for n in names)


def _node_status(status, shape) -> np.ndarray | None:
    """A map's node status checked against the map's node count (None stays None)."""
    if status is None:
        return None
    st = np.asarray(status)
    if st.shape != (int(np.prod(shape)),) or not np.isin(st, (0, 1, 2)).all():
        raise ValueError(f"status must be the map's {int(np.prod(shape))} node codes (0 reached, 1 certified "
                         f"unreachable, 2 not found), got shape {st.shape}")
    return st.astype(np.uint8)


def _not_found_rgba() -> np.ndarray:
    """uint8 `(4,)` of `wsmap.viz.NOT_FOUND_COLOR`, opaque (the PLY's and GLB's not-found nodes)."""
    from matplotlib.colors import to_rgba

    from .viz import NOT_FOUND_COLOR

    return np.round(255 * np.asarray(to_rgba(NOT_FOUND_COLOR))).astype(np.uint8)


def _node_coords(shape, lo, step) -> np.ndarray:
    """`(N, 3)` node coordinates in node order (x fastest)."""
    axes = [lo[i] + step[i] * np.arange(shape[i]) for i in range(3)]
    zz, yy, xx = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    return np.stack([xx.ravel(), yy.ravel(), zz.ravel()], axis=-1)


def _empty_mesh():
    trimesh = require("trimesh", why="a 3-D mesh")

    return trimesh.Trimesh(vertices=np.zeros((0, 3)), faces=np.zeros((0, 3), dtype=np.int64), process=False)


def _iso(v: np.ndarray, shape, lo, step, level: float):
    trimesh = require("trimesh", why="an iso-surface")
    marching_cubes = require("skimage.measure", extra="views", why="an iso-surface").marching_cubes

    vmin, vmax = float(v.min()), float(v.max())
    if not vmax > level:
        return _empty_mesh()
    # the layer around the grid takes the map's lowest value (below the level: surfaces close at the
    # grid's border); a map above the level everywhere gets a layer as far below as its top is above
    pad = vmin if vmin < level else 2.0 * level - vmax
    vol = map_to_volume(v, shape)  # (nz, ny, nx)
    padded = np.pad(vol, 1, constant_values=pad).transpose(2, 1, 0)  # (x, y, z): vertex columns x, y, z
    verts, faces, _, _ = marching_cubes(np.ascontiguousarray(padded), level=level)
    verts = lo + (verts - 1.0) * step
    # the (z, y, x) -> (x, y, z) transpose is a reflection: reverse the winding so normals point
    # out of the region above the level
    return trimesh.Trimesh(vertices=verts, faces=faces[:, ::-1], process=True)


# --------------------------------------------------------------------------------------------
# Meshes and exchange files
# --------------------------------------------------------------------------------------------


def iso_mesh(values: ArrayLike, grid: Mapping[str, Any], level: float) -> Any:
    """Iso-surface of a map at `level` as a `trimesh.Trimesh` (marching cubes).

    Parameters
    ----------
    values
        the map, `(N,)` numbers (or booleans) in node order, finite.
    grid
        its grid (`lo`, `step`, `shape`; see the module docstring).
    level
        the value of the surface (same units as `values`).

    Returns
    -------
    trimesh.Trimesh
        The closed surface around the nodes above `level`: vertices `(V, 3)` in the grid's frame
        and units (metres for R3 grids), faces wound so normals point away from the values above
        `level`. The volume is padded by one layer of the map's lowest value (below `level`) so
        the surface closes where the region touches the grid's border (half way to a border node
        of value `2·level` or less, nearer to it above). An empty mesh (0 vertices, 0 faces) when
        no node is above `level` — including a level at or above the map's maximum.
    """
    _, shape, lo, step = _grid_parts(grid)
    v = _values(values, shape)
    return _iso(v, shape, lo, step, _number("level", level))


def save_glb(path: PathLike, values: ArrayLike, grid: Mapping[str, Any],
             levels: float | Sequence[float] = (0.25, 0.5, 0.75), colormap: str = "viridis", *, opacity: float = 0.45,
             vmin: float | None = None, vmax: float | None = None, status: ArrayLike | None = None) -> Path:
    """Write a glTF binary scene (`.glb`) of the map's iso-surfaces, one per level.

    Each non-empty `iso_mesh` becomes one geometry (and node) named `"level <value>"`, with a
    double-sided, semi-transparent (`opacity`, alpha blending) PBR material of the `colormap`
    colour of its level over `[vmin, vmax]` (default: the map's range). Levels that no node is
    above are skipped. Vertices are in the grid's frame and units (metres for R3, which is glTF's unit);
    each node carries `GLTF_FROM_GRID` so viewers (y up) show the grid's z axis up.
    `trimesh.load(path)` gives a `Scene` whose `geometry` are the surfaces in the grid's frame.

    With the map's node `status` (`(N,)` int8, `wsmap.workspace.status`), the nodes *not found*
    (neither reached nor certified unreachable) are one more geometry, a point cloud named
    `"not found"` coloured `wsmap.viz.NOT_FOUND_COLOR` (none where every node is decided).

    `ValueError` before anything is written: a bad map or grid, no levels, a non-finite level,
    no level that any node is above (nothing to draw), an unknown colormap, a bad path.
    Written atomically. Returns the path.
    """
    require("trimesh", why="a .glb view")
    require("skimage", why="a .glb view")
    import trimesh
    from trimesh.visual import TextureVisuals
    from trimesh.visual.material import PBRMaterial

    path = check_output_path(path, "glb")
    _, shape, lo, step = _grid_parts(grid)
    v = _values(values, shape)
    lv = _levels(levels)
    opacity = _number("opacity", opacity)
    if not 0.0 < opacity <= 1.0:
        raise ValueError(f"opacity must be in (0, 1], got {opacity}")
    cmap = _cmap(colormap)
    st = _node_status(status, v.shape)
    cl, ch = _norm_range(v, vmin, vmax)
    scene = trimesh.Scene()
    for level in lv:
        mesh = _iso(v, shape, lo, step, level)
        if len(mesh.faces) == 0:
            continue
        rgba = _rgba([level], cl, ch, cmap, opacity)[0]
        name = f"level {level:g}"
        mesh.visual = TextureVisuals(material=PBRMaterial(
            name=name, baseColorFactor=rgba, alphaMode="BLEND", doubleSided=True, metallicFactor=0.0,
            roughnessFactor=0.8))
        scene.add_geometry(mesh, node_name=name, geom_name=name, transform=GLTF_FROM_GRID)
    if not scene.geometry:
        raise ValueError(f"no node is above any of the levels {lv} (the map lies in [{v.min():g}, {v.max():g}]): "
                         "no surface to write")
    if st is not None:
        from .workspace.status import NOT_FOUND

        missing = np.flatnonzero(st == NOT_FOUND)
        if missing.size:
            cloud = trimesh.PointCloud(_node_coords(shape, lo, step)[missing],
                                       colors=np.tile(_not_found_rgba(), (missing.size, 1)))
            scene.add_geometry(cloud, node_name="not found", geom_name="not found", transform=GLTF_FROM_GRID)
    with atomic_path(path, suffix=".glb") as tmp:
        Path(tmp).write_bytes(scene.export(file_type="glb"))
    return path


def save_ply(path: PathLike, values: ArrayLike, grid: Mapping[str, Any], threshold: float = 0.0,
             colormap: str = "viridis", *, vmin: float | None = None, vmax: float | None = None, label: str = "value",
             status: ArrayLike | None = None) -> Path:
    """Write the nodes whose value is above `threshold` as a coloured point cloud (binary `.ply`).

    One vertex per such node, in node order: `x, y, z` (float32, the grid's frame and units,
    metres for R3), `red, green, blue, alpha` (uchar, the `colormap` colour of the value over
    `[vmin, vmax]`, default the map's range; alpha 255) and `value` (float32, the map's value,
    a scalar field for tools such as CloudCompare). The header's comments say the units and
    `label`. `trimesh.load(path)` gives a `PointCloud` with `colors`.

    With the map's node `status` (`(N,)` int8, `wsmap.workspace.status`), the nodes *not found*
    (neither reached nor certified unreachable) follow as vertices of their own, coloured
    `wsmap.viz.NOT_FOUND_COLOR` (orange), and every vertex carries a `status` property (uchar:
    0 reached, 2 not found); the certified unreachable nodes, the empty space, are not written.

    `ValueError` before anything is written: a bad map or grid, a non-finite threshold, no node
    above the threshold (nothing to write), an unknown colormap, a bad path. Written atomically.
    Returns the path.
    """
    path = check_output_path(path, "ply")
    scope, shape, lo, step = _grid_parts(grid)
    v = _values(values, shape)
    threshold = _number("threshold", threshold)
    cmap = _cmap(colormap)
    if "\n" in str(label) or "\r" in str(label):
        raise ValueError("label must be one line")
    st = _node_status(status, v.shape)
    cl, ch = _norm_range(v, vmin, vmax)
    keep = np.flatnonzero(v > threshold)
    if keep.size == 0:
        raise ValueError(f"no node is above the threshold {threshold:g} (the map lies in [{v.min():g}, {v.max():g}]): "
                         "no point to write")
    rgba = _rgba(v[keep], cl, ch, cmap)
    fields = [("xyz", "<f4", (3,)), ("rgba", "u1", (4,)), ("value", "<f4")]
    comments = []
    if st is not None:
        from .viz import NOT_FOUND_COLOR
        from .workspace.status import NOT_FOUND

        missing = np.flatnonzero(st == NOT_FOUND)
        rgba = np.concatenate([rgba, np.broadcast_to(_not_found_rgba(), (missing.size, 4))])
        keep = np.concatenate([keep, missing])
        fields.append(("status", "u1"))
        comments = [f"comment status: 0 reached, 2 not found ({missing.size} nodes, coloured {NOT_FOUND_COLOR}); "
                    "the certified unreachable nodes are not written"]
    names, unit = _AXES[scope]
    data = np.zeros(keep.size, dtype=fields)
    data["xyz"], data["rgba"], data["value"] = _node_coords(shape, lo, step)[keep], rgba, v[keep]
    if st is not None:
        data["status"] = st[keep]
    header = "\n".join([
        "ply", "format binary_little_endian 1.0",
        f"comment wsmap: nodes with value > {threshold:g}; x y z = {' '.join(names)} in {unit} (grid frame)",
        f"comment value: {label}; colour: {getattr(cmap, 'name', 'colormap')} over [{cl:g}, {ch:g}]", *comments,
        f"element vertex {keep.size}",
        "property float x", "property float y", "property float z",
        "property uchar red", "property uchar green", "property uchar blue", "property uchar alpha",
        "property float value", *(["property uchar status"] if st is not None else []), "end_header", ""])
    with atomic_path(path, suffix=".ply") as tmp:
        with open(tmp, "wb") as f:
            f.write(header.encode("ascii", "replace"))
            f.write(data.tobytes())
    return path


# --------------------------------------------------------------------------------------------
# plotly
# --------------------------------------------------------------------------------------------


def _point_traces(go, v: np.ndarray, xyz: np.ndarray, hover: str, label: str, threshold: float,
                  thresholds: Sequence[float] | None, marker_size: float, opacity: float | None
                  ) -> tuple[list, list[dict]]:
    """`figure_3d`'s `"points"` traces (one per threshold, the first visible) and the steps of
    the threshold slider (none for a single threshold)."""
    if thresholds is None:
        ts = [_number("threshold", threshold)]
    else:
        if isinstance(thresholds, (str, bytes)) or np.ndim(thresholds) != 1 or len(thresholds) == 0:
            raise ValueError(f"thresholds must be a non-empty sequence of numbers, got {thresholds!r}")
        ts = sorted(set(_number("every threshold", t) for t in thresholds))
        ts = [t for t in ts if v.max() > t] or ts[:1]  # a threshold above the whole map shows nothing
    traces = []
    for t in ts:
        keep = np.flatnonzero(v > t)
        if keep.size == 0:
            raise ValueError(f"no node is above the threshold {t:g} (the map lies in "
                             f"[{v.min():g}, {v.max():g}]): no point to draw")
        traces.append(go.Scatter3d(
            x=xyz[keep, 0], y=xyz[keep, 1], z=xyz[keep, 2], mode="markers",
            name=label if thresholds is None else f"{label} > {t:g}", visible=not traces,
            marker=dict(size=float(marker_size), color=v[keep], coloraxis="coloraxis"),
            opacity=0.8 if opacity is None else float(opacity),
            hovertemplate=hover + "%{marker.color:.4g}<extra></extra>"))
    if thresholds is None:
        return traces, []
    # the slider restyles these traces only (by index): a scene's obstacles after them stay shown
    steps = [dict(method="restyle", label=f"{t:g}", args=[{"visible": [j == i for j in range(len(ts))]},
                                                          list(range(len(ts)))])
             for i, t in enumerate(ts)]
    return traces, steps


def _iso_traces(go, v: np.ndarray, shape: tuple[int, int, int], xyz: np.ndarray, hover: str, label: str,
                levels: float | Sequence[float], opacity: float | None) -> list:
    """`figure_3d`'s `"iso"` traces: one `go.Isosurface` per level that some node is above."""
    lv = _levels(levels)
    # plotly's volume traces take the nodes of an 'ij' meshgrid (x slowest): transpose
    vol = map_to_volume(v, shape).transpose(2, 1, 0).ravel()
    gxyz = xyz.reshape(shape[2], shape[1], shape[0], 3).transpose(2, 1, 0, 3).reshape(-1, 3)
    traces = [go.Isosurface(
        x=gxyz[:, 0], y=gxyz[:, 1], z=gxyz[:, 2], value=vol, isomin=level, isomax=level, surface_count=1,
        caps=dict(x_show=False, y_show=False, z_show=False), coloraxis="coloraxis", name=f"{label} = {level:g}",
        opacity=0.35 if opacity is None else float(opacity), showlegend=True,
        hovertemplate=hover + f"{level:g}<extra></extra>")
        for level in lv if v.max() > level]
    if not traces:
        raise ValueError(f"no node is above any of the levels {lv} (the map lies in [{v.min():g}, {v.max():g}]): "
                         "no surface to draw")
    return traces


def _cut_plane(shape, lo: np.ndarray, step: np.ndarray, axis_title: str, below_slider: bool
               ) -> tuple[list[list[float]], dict]:
    """`figure_3d`'s `cut_plane`: the scene's axis ranges (half a step beyond the outer nodes,
    so that their ends do not clip them) and the slider that ends the third axis at a layer."""
    half = 0.5 * step
    ranges = [[float(lo[i] - half[i]), float(lo[i] + step[i] * (shape[i] - 1) + half[i])] for i in range(3)]
    layers = lo[2] + step[2] * np.arange(shape[2])
    cuts = [dict(method="relayout", label=f"{z:.2f}",
                 args=[{"scene.zaxis.range": [ranges[2][0], float(z + half[2])]}]) for z in layers]
    slider = dict(active=len(cuts) - 1, steps=cuts, currentvalue=dict(prefix=f"{axis_title} ≤ "),
                  pad=dict(t=10, b=10), x=0.05, len=0.9, y=-0.12 if below_slider else 0.0, yanchor="top")
    return ranges, slider


def _obstacle_traces(go, obstacles) -> list:
    """`figure_3d`'s obstacles as `Mesh3d` traces (checked as `wsmap.viz.plot_slices` checks them)."""
    from .viz import OBSTACLE_COLOR, obstacle_meshes

    return [go.Mesh3d(x=v[:, 0], y=v[:, 1], z=v[:, 2], i=f[:, 0], j=f[:, 1], k=f[:, 2], name=f"obstacle: {name}",
                      color=OBSTACLE_COLOR, opacity=0.4, flatshading=True, showlegend=True, hoverinfo="name")
            for name, v, f in obstacle_meshes(obstacles)]


def _status_traces(go, status, flat_shape, xyz: np.ndarray, hover: str) -> list:
    """`figure_3d`'s status traces: the nodes not found (shown) and the certified unreachable ones
    (legend only), each named with its count; none without a `status`."""
    if status is None:
        return []
    from .viz import NOT_FOUND_COLOR
    from .workspace.status import CERTIFIED, NOT_FOUND

    st = np.asarray(status)
    if st.shape != tuple(flat_shape):
        raise ValueError(f"status must have the map's shape {tuple(flat_shape)}, got {st.shape}")
    where = hover.rsplit("<br>", 1)[0]  # the coordinates, without the value
    out = []
    for code, name, marker, visible in (
            (NOT_FOUND, "not found", dict(size=4.0, color=NOT_FOUND_COLOR, symbol="diamond-open"), True),
            (CERTIFIED, "certified unreachable", dict(size=1.5, color="#9a9a9a"), "legendonly")):
        keep = np.flatnonzero(st == code)
        out.append(go.Scatter3d(x=xyz[keep, 0], y=xyz[keep, 1], z=xyz[keep, 2], mode="markers",
                                name=f"{name} ({keep.size})", marker=marker, visible=visible, showlegend=True,
                                hovertemplate=where + f"<br>{name}<extra></extra>"))
    return out


def figure_3d(values: ArrayLike, grid: Mapping[str, Any], *, kind: str = "points", title: str | None = None,
              label: str = "reachability index", threshold: float = 0.0,
              levels: float | Sequence[float] = (0.25, 0.5, 0.75), colormap: str = "Viridis",
              vmin: float | None = None, vmax: float | None = None, marker_size: float = 3.0,
              opacity: float | None = None, thresholds: Sequence[float] | None = None, cut_plane: bool = False,
              obstacles: Sequence | None = None, status: ArrayLike | None = None) -> Any:
    """An interactive plotly `Figure` of a map (notebooks: display it; files: `save_html`).

    Parameters
    ----------
    values, grid
        the map `(N,)` in node order and its grid (module docstring).
    kind
        `"points"` — one `Scatter3d` marker per node whose value is above `threshold`
        (node order), coloured by value; `"iso"` — one `go.Isosurface` trace per level of
        `levels` that some node is above (each exactly at its level, caps off).
    title
        the figure's title; `label`: the colour bar's title (what the value is, with units).
    colormap
        a plotly colour scale name; `vmin`/`vmax`: its range (default: the map's).
    marker_size
        points' size in pixels; `opacity`: the traces' (default 0.8 points, 0.35 iso).
    thresholds
        points only: several thresholds (e.g. `np.linspace(0, 0.9, 10)` for an index
        map), one trace each (the nodes above it), and a slider "value >" under the scene
        that shows one at a time (the lowest first; `threshold` is then not used).
    cut_plane
        a second slider, "z ≤" (the grid's third axis): the scene's third axis range
        ends at the chosen layer, and plotly hides what lies beyond it, so that the inside
        of the map shows; the scene then keeps the whole grid's proportions and x/y ranges
        (`aspectmode="manual"`).
    obstacles
        a scene's obstacles, `(name, vertices (V, 3), faces (F, 3))` triangle meshes in the
        grid's frame (m; `wsmap.collision.Scene.triangles`): one translucent `Mesh3d` trace
        each, named `obstacle: <name>`, in `wsmap.viz.OBSTACLE_COLOR`.
    status
        the map's int8 node status `(N,)` (`wsmap.workspace.status`): two more traces after
        the map's, each a point per node: `not found (K)`, open diamonds in
        `wsmap.viz.NOT_FOUND_COLOR` (shown), and `certified unreachable (M)`, small grey dots
        (hidden until its legend entry is clicked: they are most of a box).

    Notes
    -----
    All traces share `layout.coloraxis` (one colour bar titled `label`). The scene's axes are
    titled with their units (`x (m)`, ... for R3; `r1 (rad)`, ... for SO3) and keep the grid's
    proportions (`aspectmode="data"`).

    Raises
    ------
    ValueError
        A bad map or grid, an unknown `kind`, no node above `threshold` (points)
        or above any level (iso), no levels, a `status` of another shape than the map's.
    """
    go = require("plotly.graph_objects", extra="views", why="a 3-D view")

    scope, shape, lo, step = _grid_parts(grid)
    v = _values(values, shape)
    if kind not in ("points", "iso"):
        raise ValueError(f"kind must be 'points' or 'iso', got {kind!r}")
    cl, ch = _norm_range(v, vmin, vmax)
    if ch == cl:
        cl, ch = cl - 0.5, ch + 0.5
    xyz = _node_coords(shape, lo, step)
    names, unit = _AXES[scope]
    hover = (f"{names[0]} = %{{x:.3f}} {unit}<br>{names[1]} = %{{y:.3f}} {unit}<br>"
             f"{names[2]} = %{{z:.3f}} {unit}<br>{label} = ")
    if kind == "points":
        traces, steps = _point_traces(go, v, xyz, hover, label, threshold, thresholds, marker_size, opacity)
    else:
        traces, steps = _iso_traces(go, v, shape, xyz, hover, label, levels, opacity), []
    fig = go.Figure(data=traces + _status_traces(go, status, v.shape, xyz, hover) + _obstacle_traces(go, obstacles))
    titles = [f"{n} ({unit})" for n in names]
    sliders = []
    if steps:
        sliders.append(dict(active=0, steps=steps, currentvalue=dict(prefix=f"{label} > "), pad=dict(t=10, b=10),
                            x=0.05, len=0.9, y=0.0, yanchor="top"))
    if cut_plane:
        ranges, cut_slider = _cut_plane(shape, lo, step, titles[2], bool(steps))
        sliders.append(cut_slider)
    fig.update_layout(
        title=title,
        coloraxis=dict(colorscale=colormap, cmin=cl, cmax=ch, colorbar=dict(title=dict(text=label))),
        scene=dict(aspectmode="data", xaxis=dict(title=dict(text=titles[0])), yaxis=dict(title=dict(text=titles[1])),
                   zaxis=dict(title=dict(text=titles[2]))),
        margin=dict(l=0, r=0, t=40 if title else 10, b=0),
        legend=dict(x=0, y=1),
    )
    if sliders:
        fig.update_layout(sliders=sliders, margin=dict(b=60 * len(sliders) + 20))
    if cut_plane:
        extent = np.array([r[1] - r[0] for r in ranges])
        ratio = extent / extent.max()
        fig.update_layout(scene=dict(
            aspectmode="manual", aspectratio=dict(x=float(ratio[0]), y=float(ratio[1]), z=float(ratio[2])),
            xaxis=dict(range=ranges[0], autorange=False), yaxis=dict(range=ranges[1], autorange=False),
            zaxis=dict(range=ranges[2], autorange=False)))
    return fig

def save_html(path: PathLike, values: ArrayLike, grid: Mapping[str, Any], **kw) -> Path:
    """Write `figure_3d` `(values, grid, **kw)` as one standalone HTML file.

    plotly.js is embedded (`include_plotlyjs=True`, about 5 MB): the file opens in a browser
    without a network. The browser needs WebGL for the 3-D scene. `ValueError` (bad input, see
    `figure_3d`; bad path) before anything is written; written atomically. Returns the path.
    """
    path = check_output_path(path, "html")
    fig = figure_3d(values, grid, **kw)
    with atomic_path(path, suffix=".html") as tmp:
        fig.write_html(str(tmp), include_plotlyjs=True, full_html=True, config={"responsive": True})
    return path
