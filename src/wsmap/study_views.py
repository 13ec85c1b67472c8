"""Pictures of a reach study: the heat map of the scores on the workpiece, as a PNG (matplotlib), a
self-contained HTML page (plotly) and a PLY with vertex colours (MeshLab, RViz).

What they show
--------------
One arm of a `wsmap.workspace.study_files.StudyResult` at its best base (`results[arm][0]`): the
workpiece (its mesh where the targets came from one, else the targets' points), each target
coloured by its score (the combined `score`, or one named score), the targets not reached as grey
crosses, the arm's base frame and the workpiece frame (x, y, z axes drawn red, green, blue), and
the coverage "reached n of N (p %)".

Frames and conventions
----------------------
Everything is in the study's world frame (metres). The base frame is the result's `base` pose; the
workpiece frame is the pose the study placed the workpiece at (`settings["targets"]["pose"]`, 16
numbers, row-major), the world frame where there is none.

Colours
-------
One mapping for all three files (`score_rgb`): matplotlib's `viridis` over `[vmin, vmax]`, by default
`[0, the largest reached score]` (REACH's scores are at least 0, 0 the worst); a target not reached
is `UNREACHED_RGB`. A mesh vertex takes the value of its nearest target (`vertex_values`; Euclidean
distance in the world frame), so a vertex nearest an unreached target is grey. In the HTML page the
mesh's intensity is that value and the colour scale is viridis's 256 colours; an unreached vertex
has the intensity `vmin - band` (`band` = `UNREACHED_BAND` of the range), which the scale paints
grey below viridis, so one `mesh3d` trace holds both.

The module sits beside `wsmap.views` and `wsmap.viz`, not in `wsmap.workspace`: the classical
library imports no matplotlib (`tests/test_imports.py`).

Files are deterministic (the same result gives the same bytes: no time stamps, no software version
in the PNG, a fixed plotly `div` id) and written atomically, all or none (`save_views`).
"""

from __future__ import annotations

import io as _bytes_io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .io import atomic_paths, check_outputs
from .workspace.study import REACHED, STATUS

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .workspace.study_files import StudyResult

__all__ = ["COLORMAP", "UNREACHED_RGB", "UNREACHED_BAND", "PNG_SIZE", "HTML_DIV_ID", "HeatMap", "heat_map",
           "score_rgb", "vertex_values", "tool_angles", "png_bytes", "html_text", "ply_bytes", "save_views"]

#: The one colormap of the three files.
COLORMAP = "viridis"
#: The colour (uchar RGB) of a target not reached, and of the mesh vertices nearest one.
UNREACHED_RGB = (150, 150, 150)
#: The HTML colour scale's grey band below `vmin`, as a fraction of `vmax - vmin`.
UNREACHED_BAND = 0.05
#: The PNG's size in pixels (width, height): 10 x 8 inches at 100 dots per inch.
PNG_SIZE = (1000, 800)
_DPI = 100
#: The HTML page's plotly `div` id (fixed, so that the page's bytes are the same every time).
HTML_DIV_ID = "wsmap-study-heat-map"


@dataclass(frozen=True)
class HeatMap:
    """What the pictures show (see the module notes); every array in the world frame (m).

    arm : the arm's name
    points : (M, 3) the targets' surface points
    values : (M,) the score shown, NaN where not reached
    status : (M,) int8, each target's answer (`wsmap.workspace.study.STATUS`)
    label : the score's name, with its unit
    vmin, vmax : the colour range
    base, workpiece : (4, 4) the arm's base pose and the workpiece frame
    vertices, faces : (V, 3), (F, 3) the workpiece mesh, or None
    hover : (M,) one line of text per target: index, answer, score, solution (deg), tool angles
    """

    arm: str
    points: np.ndarray
    values: np.ndarray
    status: np.ndarray
    label: str
    vmin: float
    vmax: float
    base: np.ndarray
    workpiece: np.ndarray
    vertices: np.ndarray | None
    faces: np.ndarray | None
    hover: tuple

    @property
    def reached(self) -> np.ndarray:
        return np.isfinite(self.values)

    @property
    def title(self) -> str:
        n, total = int(self.reached.sum()), len(self.values)
        return f"{self.arm}: reached {n} of {total} ({100.0 * n / max(total, 1):.1f} %); colour: {self.label}"


def score_rgb(values, vmin: float, vmax: float) -> np.ndarray:
    """uint8 `(N, 3)` colours of `values` `(N,)`: `COLORMAP` over `[vmin, vmax]` (clipped), matplotlib's
    256-colour table in its own bytes (`cmap(t, bytes=True)`); `UNREACHED_RGB` for NaN."""
    import matplotlib

    v = np.asarray(values, dtype=np.float64).reshape(-1)
    ok = np.isfinite(v)
    t = np.clip((np.where(ok, v, vmin) - vmin) / (vmax - vmin), 0.0, 1.0)
    rgb = np.asarray(matplotlib.colormaps[COLORMAP](t, bytes=True))[:, :3].copy()
    rgb[~ok] = UNREACHED_RGB
    return rgb


def vertex_values(vertices, points, values) -> np.ndarray:
    """`(V,)` each vertex's value: that of its nearest point (Euclidean; NaN stays NaN).
    vertices `(V, 3)`, points `(M, 3)` (same frame, m), values `(M,)`."""
    from scipy.spatial import cKDTree

    _, nearest = cKDTree(np.asarray(points, dtype=np.float64)).query(np.asarray(vertices, dtype=np.float64))
    return np.asarray(values, dtype=np.float64)[nearest]


def tool_angles(variants) -> np.ndarray:
    """`(K, 2)` degrees: the turn about the tool axis in [0, 360) and the tilt of the tool axis of each
    tool-frame rotation `variants` `(K, 4, 4)` (`wsmap.workspace.study.tool_variants`). A variant
    `Rz(φ) Rz(α) Rx(θ) Rz(-α)` has z-x-z angles `(φ + α, θ, -α)`: the tilt is `θ`, the turn the sum of
    the first and third angles (`atan2(R10, R00)` when `θ = 0`)."""
    R = np.asarray(variants, dtype=np.float64)[:, :3, :3]
    tilt = np.arccos(np.clip(R[:, 2, 2], -1.0, 1.0))
    tilted = np.sin(tilt) > 1e-9
    first = np.arctan2(R[:, 0, 2], -R[:, 1, 2])
    third = np.arctan2(R[:, 2, 0], R[:, 2, 1])
    turn = np.where(tilted, first + third, np.arctan2(R[:, 1, 0], R[:, 0, 0]))
    turn = np.round(np.degrees(turn), 9) % 360.0  # rounded so that a turn of -1e-15 is 0, not 360
    return np.stack([turn, np.degrees(tilt)], axis=1)


def _workpiece_frame(settings) -> np.ndarray:
    pose = (settings or {}).get("targets", {}) if isinstance(settings, dict) else {}
    pose = pose.get("pose") if isinstance(pose, dict) else None
    if pose is None:
        return np.eye(4)
    T = np.asarray(pose, dtype=np.float64)
    if T.size != 16 or not np.all(np.isfinite(T)):
        raise ValueError(f"the study's settings targets.pose is not a 4x4 pose: {pose!r:.80}")
    return T.reshape(4, 4)


def _hover(index: int, status: int, value: float, q, angles, scores: dict) -> str:
    if status != REACHED:
        return f"target {index}: {STATUS[status]}"
    parts = [f"target {index}: reached", f"score {value:.4g}"]
    parts += [f"{k} {v:.4g}" for k, v in scores.items()]
    parts += ["q (deg) [" + ", ".join(f"{x:.1f}" for x in np.degrees(q)) + "]",
              f"tool turn {angles[0]:.1f} deg, tilt {angles[1]:.1f} deg"]
    return "<br>".join(parts)


def heat_map(result: StudyResult, *, arm: int = 0, score: str | None = None, vmin: float | None = None,
             vmax: float | None = None) -> HeatMap:
    """The heat map of arm `arm` (an index into `result.names`) at its best base: `score` None the
    combined score, or one name of the study's scores; the colour range `[vmin, vmax]` (default `[0,
    the largest reached value]`, `[0, 1]` when none is above 0). `ValueError` for an arm or score the
    result does not hold, or a range that is not finite and increasing."""
    if isinstance(arm, bool) or not isinstance(arm, (int, np.integer)) or not 0 <= arm < len(result.names):
        raise ValueError(f"the study has arms 0 to {len(result.names) - 1}, got arm {arm!r}")
    res = result.results[arm][0]
    if score is not None and score not in res.scores:
        raise ValueError(f"the study has no score {score!r}; it has: {', '.join(['score', *res.scores]) or 'none'}")
    values = np.asarray(res.score if score is None else res.scores[score], dtype=np.float64)
    values = np.where(np.asarray(res.status) == REACHED, values, np.nan)
    top = float(np.nanmax(values)) if np.isfinite(values).any() else 0.0
    lo = 0.0 if vmin is None else float(vmin)
    hi = (top if top > lo else lo + 1.0) if vmax is None else float(vmax)
    if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
        raise ValueError(f"the colour range must be finite with vmin < vmax, got [{lo}, {hi}]")
    label = f"{score} ({_unit(score)})" if score is not None else "score (" + " x ".join(res.scores) + ")"
    angles = tool_angles(result.variants)[np.maximum(np.asarray(res.variant), 0)]
    hover = tuple(_hover(m, int(s), values[m], res.q[m], angles[m], {k: float(v[m]) for k, v in res.scores.items()})
                  for m, s in enumerate(res.status))
    t = result.targets
    return HeatMap(arm=str(result.names[arm]), points=np.asarray(t.points, dtype=np.float64), values=values,
                   status=np.asarray(res.status), label=label, vmin=lo, vmax=hi,
                   base=np.asarray(res.base, dtype=np.float64), workpiece=_workpiece_frame(result.settings),
                   vertices=None if t.vertices is None else np.asarray(t.vertices, dtype=np.float64),
                   faces=None if t.faces is None else np.asarray(t.faces, dtype=np.int64), hover=hover)


def _unit(score: str) -> str:
    from .workspace.scores import SCORES

    return SCORES[score].unit if score in SCORES else "1"


def _frame_length(hm: HeatMap) -> float:
    """Axis length (m) of the drawn frames: a tenth of the scene's extent."""
    pts = [hm.points, hm.base[None, :3, 3], hm.workpiece[None, :3, 3]]
    if hm.vertices is not None:
        pts.append(hm.vertices)
    allp = np.concatenate(pts)
    return max(0.1 * float(np.ptp(allp, axis=0).max()), 1e-3)


# ------------------------------------------------------------------------------------------ PNG
def _draw_frame(ax, T: np.ndarray, length: float, name: str) -> None:
    o = T[:3, 3]
    for axis, colour in zip(range(3), ("tab:red", "tab:green", "tab:blue")):
        e = o + length * T[:3, axis]
        ax.plot([o[0], e[0]], [o[1], e[1]], [o[2], e[2]], color=colour, linewidth=2)
    ax.text(o[0], o[1], o[2], f" {name}", fontsize=9)


def _equal_box(ax, hm: HeatMap, length: float) -> None:
    pts = [hm.points, hm.base[None, :3, 3], hm.workpiece[None, :3, 3]]
    pts += [] if hm.vertices is None else [hm.vertices]
    allp = np.concatenate(pts)
    centre = (allp.min(axis=0) + allp.max(axis=0)) / 2
    half = max(float(np.ptp(allp, axis=0).max()) / 2 + length, 1e-3)
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")


def png_bytes(hm: HeatMap) -> bytes:
    """The heat map as a PNG `PNG_SIZE` pixels (matplotlib's Agg, no pyplot state), see the module notes."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    fig = Figure(figsize=(PNG_SIZE[0] / _DPI, PNG_SIZE[1] / _DPI), dpi=_DPI)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(projection="3d")
    if hm.vertices is not None:
        ax.add_collection3d(Poly3DCollection(hm.vertices[hm.faces], facecolor=(0.85, 0.85, 0.85, 0.35),
                                             edgecolor=(0.6, 0.6, 0.6, 0.15), linewidths=0.2))
    ok = hm.reached
    if ok.any():
        p = hm.points[ok]
        ax.scatter(p[:, 0], p[:, 1], p[:, 2], c=score_rgb(hm.values[ok], hm.vmin, hm.vmax) / 255.0, s=14,
                   depthshade=False, label=f"reached ({int(ok.sum())})")
    if (~ok).any():
        p = hm.points[~ok]
        ax.scatter(p[:, 0], p[:, 1], p[:, 2], color=np.array(UNREACHED_RGB) / 255.0, marker="x", s=18,
                   depthshade=False, label=f"not reached ({int((~ok).sum())})")
    length = _frame_length(hm)
    _draw_frame(ax, hm.base, length, "base")
    _draw_frame(ax, hm.workpiece, length, "workpiece")
    _equal_box(ax, hm, length)
    fig.colorbar(ScalarMappable(Normalize(hm.vmin, hm.vmax), COLORMAP), ax=ax, shrink=0.7, pad=0.08, label=hm.label)
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title(hm.title.replace("; colour", "\ncolour"), fontsize=11)
    buf = _bytes_io.BytesIO()
    fig.savefig(buf, format="png", dpi=_DPI, metadata={"Software": None})
    return buf.getvalue()


# ----------------------------------------------------------------------------------------- HTML
def _colorscale(band: float) -> list:
    """viridis's 256 colours over `[band, 1]` of the scale, grey below (the unreached band)."""
    import matplotlib

    rgb = np.asarray(matplotlib.colormaps[COLORMAP](np.arange(256), bytes=True))[:, :3].astype(int)
    grey = "rgb({},{},{})".format(*UNREACHED_RGB)
    scale = [[0.0, grey], [band, grey]] if band > 0 else []
    return scale + [[band + (1 - band) * i / 255, f"rgb({r},{g},{b})"] for i, (r, g, b) in enumerate(rgb)]


def _frame_traces(go, T: np.ndarray, length: float, name: str) -> list:
    o = T[:3, 3]
    out = []
    for axis, colour in zip(range(3), ("red", "green", "blue")):
        e = o + length * T[:3, axis]
        out.append(go.Scatter3d(x=[o[0], e[0]], y=[o[1], e[1]], z=[o[2], e[2]], mode="lines",
                                name=f"{name} {'xyz'[axis]}", line=dict(color=colour, width=6), hoverinfo="skip",
                                showlegend=False))
    out.append(go.Scatter3d(x=[o[0]], y=[o[1]], z=[o[2]], mode="markers+text", text=[name], name=name,
                            marker=dict(size=4, color="black"), hovertext=[f"{name} frame"], hoverinfo="text"))
    return out


def _mesh_trace(go, hm: HeatMap):
    span = hm.vmax - hm.vmin
    fraction = UNREACHED_BAND / (1 + UNREACHED_BAND)  # the grey band's share of [vmin - band, vmax]
    v = vertex_values(hm.vertices, hm.points, hm.values)
    intensity = np.where(np.isfinite(v), v, hm.vmin - UNREACHED_BAND * span)
    ticks = np.linspace(hm.vmin, hm.vmax, 5)
    return go.Mesh3d(x=hm.vertices[:, 0], y=hm.vertices[:, 1], z=hm.vertices[:, 2], i=hm.faces[:, 0],
                     j=hm.faces[:, 1], k=hm.faces[:, 2], intensity=intensity, intensitymode="vertex",
                     colorscale=_colorscale(fraction), cmin=hm.vmin - UNREACHED_BAND * span, cmax=hm.vmax,
                     colorbar=dict(title=dict(text=hm.label), tickvals=[hm.vmin - UNREACHED_BAND * span / 2,
                                                                        *ticks.tolist()],
                                   ticktext=["not reached", *[f"{t:.3g}" for t in ticks]]),
                     name="workpiece", hoverinfo="skip", flatshading=False)


def _target_traces(go, hm: HeatMap, colorbar: bool) -> list:
    ok, hover = hm.reached, np.array(hm.hover, dtype=object)
    p = hm.points
    out = [go.Scatter3d(x=p[ok, 0], y=p[ok, 1], z=p[ok, 2], mode="markers", name=f"reached ({int(ok.sum())})",
                        hovertext=hover[ok].tolist(), hoverinfo="text",
                        marker=dict(size=4, color=hm.values[ok], colorscale=_colorscale(0.0), cmin=hm.vmin,
                                    cmax=hm.vmax, showscale=colorbar,
                                    colorbar=dict(title=dict(text=hm.label)) if colorbar else None))]
    if (~ok).any():
        out.append(go.Scatter3d(x=p[~ok, 0], y=p[~ok, 1], z=p[~ok, 2], mode="markers",
                                name=f"not reached ({int((~ok).sum())})", hovertext=hover[~ok].tolist(),
                                hoverinfo="text", marker=dict(size=4, symbol="x",
                                                              color="rgb({},{},{})".format(*UNREACHED_RGB))))
    return out


def html_text(hm: HeatMap) -> str:
    """The heat map as one self-contained HTML page (plotly.js inlined: it opens offline): the mesh as
    one `mesh3d` trace with per-vertex intensity (or, without a mesh, the targets' markers carry the
    colour bar), the targets with hover text, the base and workpiece frames."""
    import plotly.graph_objects as go

    traces = [] if hm.vertices is None else [_mesh_trace(go, hm)]
    traces += _target_traces(go, hm, colorbar=hm.vertices is None)
    length = _frame_length(hm)
    traces += _frame_traces(go, hm.base, length, "base") + _frame_traces(go, hm.workpiece, length, "workpiece")
    fig = go.Figure(traces)
    fig.update_layout(title=dict(text=hm.title), legend=dict(x=0, y=1),
                      scene=dict(aspectmode="data", xaxis_title="x (m)", yaxis_title="y (m)", zaxis_title="z (m)"))
    return fig.to_html(include_plotlyjs=True, full_html=True, div_id=HTML_DIV_ID)


# ------------------------------------------------------------------------------------------ PLY
def _ascii_line(text: str) -> str:
    return " ".join(str(text).split()).encode("ascii", "replace").decode("ascii")


def ply_bytes(hm: HeatMap) -> bytes:
    """The heat map as a binary little-endian PLY: the mesh with per-vertex `red green blue` (uchar),
    or, without a mesh, the targets as a coloured point cloud; positions float32 (m, world frame)."""
    if hm.vertices is None:
        xyz, rgb, faces = hm.points, score_rgb(hm.values, hm.vmin, hm.vmax), None
    else:
        xyz, faces = hm.vertices, hm.faces
        rgb = score_rgb(vertex_values(hm.vertices, hm.points, hm.values), hm.vmin, hm.vmax)
    vert = np.zeros(len(xyz), dtype=[("xyz", "<f4", (3,)), ("rgb", "u1", (3,))])
    vert["xyz"], vert["rgb"] = xyz, rgb
    header = ["ply", "format binary_little_endian 1.0",
              f"comment wsmap reach study: {_ascii_line(hm.arm)} at its best base; x y z in m (world frame)",
              f"comment colour: {COLORMAP} of {_ascii_line(hm.label)} over [{hm.vmin:.6g}, {hm.vmax:.6g}]; grey "
              f"{' '.join(map(str, UNREACHED_RGB))}: not reached",
              f"element vertex {len(xyz)}", "property float x", "property float y", "property float z",
              "property uchar red", "property uchar green", "property uchar blue"]
    body = vert.tobytes()
    if faces is not None:
        header += [f"element face {len(faces)}", "property list uchar int vertex_indices"]
        face = np.zeros(len(faces), dtype=[("n", "u1"), ("v", "<i4", (3,))])
        face["n"], face["v"] = 3, faces
        body += face.tobytes()
    return ("\n".join(header + ["end_header"]) + "\n").encode("ascii") + body


# ---------------------------------------------------------------------------------------- files
def save_views(result: StudyResult, *, png=None, html=None, ply=None, arm: int = 0, score: str | None = None,
               vmin: float | None = None, vmax: float | None = None) -> list[Path]:
    """Write the heat map of arm `arm` (`heat_map`) to the paths given (`png`, `html`, `ply`; None
    skips one). The paths are checked before any work (`wsmap.io.check_outputs`: writable, distinct),
    each must have its format's suffix, and the three are written atomically together: all, or on an
    error none. Returns the paths written, in the order png, html, ply."""
    wanted = {"png": png, "html": html, "ply": ply}
    for kind, p in wanted.items():
        if p is not None and Path(p).suffix.lower() != f".{kind}":
            raise ValueError(f"the {kind} view {str(p)!r} must end in .{kind}")
    paths = check_outputs({f"outputs.{k}": p for k, p in wanted.items()})
    if not paths:
        return []
    hm = heat_map(result, arm=arm, score=score, vmin=vmin, vmax=vmax)
    render = {"png": png_bytes, "html": lambda h: html_text(h).encode("utf-8"), "ply": ply_bytes}
    data = [(paths[f"outputs.{k}"], render[k](hm)) for k in wanted if f"outputs.{k}" in paths]
    with atomic_paths([p for p, _ in data]) as tmps:
        for tmp, (_, blob) in zip(tmps, data):
            Path(tmp).write_bytes(blob)
    return [p for p, _ in data]

