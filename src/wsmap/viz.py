"""Drawing only: workspace maps (z-slices, voxels, surface meshes), training curves, prediction
errors, threshold sweeps, run-time bars, and writing figures and meshes to files.

Maps are flat boolean arrays in the paper's node order; `shape = (nx, ny, nz)` and the grid's
`lo`/`step` place them in space (metres for R3 maps, radians for SO3 maps). Everything that
draws returns a matplotlib `Figure` (or `Axes`); everything that writes a file writes it
atomically (`wsmap.io`). What is drawn is computed elsewhere: scores, outcomes, per-sample
errors and the statistics over sessions in `wsmap.metrics`, surface meshes of maps in
`wsmap.views` (`wsmap.views.iso_mesh`).

* maps: `plot_slices`, `plot_value_slices` (float maps), `plot_voxels`, `render_mesh`,
  `plot_meshes`, `export_mesh`, `save_figure`;
* curves over training sessions (`wsmap.metrics.session_curves`): `plot_mean_band` (the
  paper's "Average gradient (± sigma) of 10 training sessions"), `plot_training_curves`;
* predictions against the truth: `plot_sample_errors` (of `wsmap.metrics.per_sample_error`),
  `plot_sections` (TP/FP/FN/TN of a z-layer for a grid of arms, `wsmap.metrics.outcomes`),
  `plot_threshold_sweep`, `plot_error_histograms`;
* run time: `plot_runtimes`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .io import atomic_path
from .metrics import OUTCOME_NAMES, outcomes, session_mean_std
from .workspace.grids import map_to_volume
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from wsmap._typing import Any, ArrayLike, PathLike

__all__ = [
    "OUTCOME_COLORS", "plot_mean_band", "plot_training_curves", "plot_sample_errors", "plot_sections",
    "plot_threshold_sweep", "plot_error_histograms", "plot_runtimes", "plot_meshes", "export_mesh", "plot_slices",
    "plot_voxels", "save_figure", "render_mesh", "plot_value_slices", "map_title", "png_metadata", "MAP_COLORS",
    "COMPARE_COLORS", "CONVENTION_TEXT", "OBSTACLE_COLOR", "plane_section", "obstacle_meshes",
]

#: The colours of `wsmap.metrics.outcomes` codes 0..3 (`wsmap.metrics.OUTCOME_NAMES`).
OUTCOME_COLORS = ("#f4f4f4", "#1f4e79", "#ff9f1c", "#d62728")


def _plt():
    import matplotlib

    if matplotlib.get_backend().lower() not in ("agg", "module://matplotlib_inline.backend_inline"):
        try:
            import matplotlib.pyplot as plt  # noqa: F401  (a GUI backend may not exist headless)
        except ImportError:  # pragma: no cover
            matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


# --------------------------------------------------------------------------------------------
# Curves over sessions
# --------------------------------------------------------------------------------------------


def plot_mean_band(curves: ArrayLike, *, epochs: ArrayLike | None = None, ax: Axes | None = None, label: str = "mean",
                   color: str = "#1f4e79",
                   logy: bool = True, ylabel: str = "", title: str | None = None, show_sessions: bool = True) -> Figure:
    """Mean ± sigma over sessions (rows of `curves`, NaN = session stopped) per epoch.

    With `logy`, where `mean − sigma <= 0` the band's lower edge is the lowest session's
    value at that epoch (a log axis cannot show a non-positive edge). Individual sessions are drawn thin
    when `show_sessions`. Returns the Figure.
    """
    plt = _plt()
    curves = np.atleast_2d(np.asarray(curves, dtype=np.float64))
    epochs = np.arange(curves.shape[1]) if epochs is None else np.asarray(epochs)
    mean, std, _ = session_mean_std(curves)
    if ax is None:
        fig, ax = plt.subplots(figsize=(6.4, 4.0))
    else:
        fig = ax.figure
    if show_sessions and curves.shape[0] > 1:
        for row in curves:
            ax.plot(epochs, row, color=color, lw=0.5, alpha=0.25)
    lo, hi = mean - std, mean + std
    if logy:
        # a log axis cannot show mean - sigma <= 0 (one session's spike makes sigma > mean): the
        # band's lower edge then stops at the lowest session at that epoch
        positive = np.where(curves > 0, curves, np.inf)
        lowest = np.min(positive, axis=0)
        lowest = np.where(np.isfinite(lowest), lowest, np.nan)
        lo = np.where(lo > 0, lo, lowest)
    ax.fill_between(epochs, lo, hi, color=color, alpha=0.25, lw=0, label=f"{label} ± σ")
    ax.plot(epochs, mean, color=color, lw=1.6, label=f"{label} ({curves.shape[0]} sessions)")
    if logy:
        ax.set_yscale("log")
    ax.set_xlabel("epoch")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    # beside the axes, not on the curves (figures are saved with bbox_inches="tight")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    if title:
        ax.set_title(title)
    return fig


def plot_training_curves(histories: Sequence, labels: Sequence[str], *, best_epochs: Sequence[int] | None = None,
                         title: str | None = None) -> Figure:
    """Training (solid) and validation (dashed) loss per epoch of several single-session
    histories (e.g. the 7 block subspaces), log y; a dot marks each best (restored) epoch."""
    plt = _plt()
    if len(histories) != len(labels):
        raise ValueError("one label per history")
    fig, ax = plt.subplots(figsize=(7.0, 4.4))
    cmap = plt.get_cmap("viridis", max(len(histories), 2))
    for i, (h, lab) in enumerate(zip(histories, labels)):
        c = cmap(i)
        ax.plot(h.epoch, h.loss, color=c, lw=1.3, label=f"{lab}")
        if len(h.val_loss) and np.any(np.isfinite(np.asarray(h.val_loss, dtype=float))):
            ax.plot(h.epoch, h.val_loss, color=c, lw=1.0, ls="--")
        if best_epochs is not None:
            e = int(best_epochs[i])
            if 0 <= e < len(h.val_loss):
                ax.plot([e], [h.val_loss[e]], "o", color=c, ms=4)
    ax.set_yscale("log")
    ax.set_xlabel("epoch")
    ax.set_ylabel("MSE (solid: training, dashed: validation)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    if title:
        ax.set_title(title)
    return fig


# --------------------------------------------------------------------------------------------
# Predictions against the truth
# --------------------------------------------------------------------------------------------


def plot_sample_errors(errors: ArrayLike, *, title: str | None = None) -> Figure:
    """Per-sample error (`wsmap.metrics.per_sample_error`) of a test set: left, the error of every sample
    in test-set order with its mean and mean ± sigma; right, their histogram. Returns the Figure."""
    plt = _plt()
    e = 100.0 * np.asarray(errors, dtype=np.float64)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 3.8), gridspec_kw={"width_ratios": [2, 1]})
    idx = np.arange(1, e.size + 1)
    m, s = float(e.mean()), float(e.std())
    a1.plot(idx, e, ".", ms=2.5, color="#1f4e79", alpha=0.7, label="one test arm")
    a1.axhline(m, color="#d62728", lw=1.4, label=f"mean {m:.2f} %")
    a1.axhspan(max(m - s, 0), m + s, color="#d62728", alpha=0.12, label=f"± σ ({s:.2f} %)")
    a1.set_xlabel("test sample")
    a1.set_ylabel("nodes predicted wrongly (%)")
    a1.grid(True, alpha=0.3)
    a1.legend(fontsize=8, loc="upper right", framealpha=0.9)
    a2.hist(e, bins=30, color="#1f4e79")
    a2.set_xlabel("nodes predicted wrongly (%)")
    a2.set_ylabel("test samples")
    a2.grid(True, alpha=0.3)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_sections(pred: ArrayLike, truth: ArrayLike, shape: Sequence[int], *, layer: int, lo: float | ArrayLike = -1.0,
                  step: float | ArrayLike = 0.1, z_value: float | None = None, titles: Sequence[str] | None = None,
                  ncols: int = 5, title: str | None = None) -> Figure:
    """One panel per sample: z-layer `layer` of its predicted map against the exact one,
    coloured by outcome (TP/FP/FN/TN, `wsmap.metrics.outcomes`, `OUTCOME_COLORS`).

    Parameters
    ----------
    pred, truth
        bool `(samples, nx*ny*nz)` maps in node order (e.g. one block subspace,
        shape `(21, 21, 3)`).
    shape
        `(nx, ny, nz)` of those maps; `layer`: index into the z-layers.
    lo, step
        the grid's x/y origin and spacing (axis extents); `z_value`: the layer's z,
        for the title.
    titles
        one small title per panel.
    """
    plt = _plt()
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    codes = outcomes(pred, truth)
    if codes.ndim != 2:
        raise ValueError(f"pred and truth must be (samples, nodes); got {codes.shape}")
    vol = map_to_volume(codes, shape)  # (samples, nz, ny, nx)
    if not 0 <= layer < vol.shape[1]:
        raise ValueError(f"layer {layer} is outside the {vol.shape[1]} z-layers")
    n = vol.shape[0]
    ax_x, ax_y, _ = _axes_of(shape, lo, step)
    extent = _cell_extent(ax_x, ax_y, step)
    cmap = ListedColormap(list(OUTCOME_COLORS))
    fig, axes = _slice_grid(plt, n, ncols, extent, ("x", "y", "z"), "m", panel=2.0)
    for i, ax in enumerate(axes):
        ax.imshow(vol[i, layer], origin="lower", cmap=cmap, vmin=0, vmax=3, extent=extent,
                  interpolation="nearest")
        if titles is not None:
            ax.set_title(titles[i], fontsize=8)
    fig.legend(handles=[Patch(facecolor=OUTCOME_COLORS[k], label=OUTCOME_NAMES[k], edgecolor="0.6")
                        for k in (1, 2, 3, 0)],
               loc="outside lower center", ncol=4, fontsize=9, frameon=False)
    if title or z_value is not None:
        fig.suptitle((title or "") + (f" (z = {z_value:.2f} m)" if z_value is not None else ""), fontsize=11)
    return fig


def plot_threshold_sweep(sweep: Any, *, mark: float | None = 0.5, title: str | None = None) -> Figure:
    """Precision, recall and F of a `wsmap.metrics.Sweep` against the threshold; the best
    threshold and `mark` (the paper's 0.5) are marked."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.0, 4.0))
    th = np.asarray(sweep.thresholds)
    ax.plot(th, sweep.precision, color="#1f77b4", label="precision")
    ax.plot(th, sweep.recall, color="#2ca02c", label="recall")
    ax.plot(th, sweep.f, color="#d62728", lw=2, label="F-measure")
    if math.isfinite(sweep.best_threshold):
        ax.axvline(sweep.best_threshold, color="k", ls="--", lw=1,
                   label=f"best: t = {sweep.best_threshold:.2f}, F = {sweep.best_f:.4f}")
    if mark is not None:
        i = int(np.argmin(np.abs(th - mark)))
        ax.plot([th[i]], [sweep.f[i]], "o", color="#d62728", label=f"t = {th[i]:.2f}: F = {sweep.f[i]:.4f}")
    ax.set_xlabel("threshold (a node is reachable when output > threshold)")
    ax.set_ylabel("pooled value on the test set")
    ax.set_ylim(0, 1.02)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    if title:
        ax.set_title(title)
    return fig


def plot_error_histograms(hists: Sequence, labels: Sequence[str], *, ncols: int = 4, title: str | None = None
                         ) -> Figure:
    """One panel per `wsmap.metrics.ErrorHistogram` (errors = truth − output), bars split
    into truly reachable and unreachable nodes, log-scaled counts (most errors are near 0)."""
    plt = _plt()
    if len(hists) != len(labels):
        raise ValueError("one label per histogram")
    n = len(hists)
    ncols = max(1, min(ncols, n))
    nrows = int(math.ceil(n / ncols))
    fig, axes = plt.subplots(nrows, ncols, figsize=(3.2 * ncols, 2.6 * nrows + 0.5), squeeze=False,
                             sharex=True)
    for i, ax in enumerate(axes.flat):
        if i >= n:
            ax.axis("off")
            continue
        h = hists[i]
        w = np.diff(h.edges)
        ax.bar(h.edges[:-1], h.counts_unreachable, width=w, align="edge", color="#ff9f1c", label="truth 0")
        ax.bar(h.edges[:-1], h.counts_reachable, width=w, align="edge", bottom=h.counts_unreachable,
               color="#1f4e79", label="truth 1")
        ax.set_yscale("log")
        ax.set_title(f"{labels[i]}: mean {h.mean:+.3f}, σ {h.std:.3f}", fontsize=8)
        ax.axvline(0, color="k", lw=0.6)
        ax.grid(True, alpha=0.3)
        if i % ncols == 0:
            ax.set_ylabel("node predictions")
        if i >= n - ncols:
            ax.set_xlabel("error = truth − output")
    axes.flat[0].legend(fontsize=7)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


# --------------------------------------------------------------------------------------------
# Run time
# --------------------------------------------------------------------------------------------


def plot_runtimes(groups: dict[str, dict[str, np.ndarray]], *, unit: str = "ms", title: str | None = None) -> Figure:
    """Bars of mean ± sigma run time, one panel per group (e.g. `{"one arm": {"block 1":
    times, ...}, "1000 arms": {...}}`), one bar per model inside a group."""
    plt = _plt()
    scale = {"s": 1.0, "ms": 1e3, "us": 1e6}[unit]
    fig, axes = plt.subplots(1, len(groups), figsize=(5.2 * len(groups), 3.8), squeeze=False)
    for ax, (gname, times) in zip(axes.flat, groups.items()):
        names = list(times)
        means = [scale * float(np.mean(times[k])) for k in names]
        stds = [scale * float(np.std(times[k])) for k in names]
        colors = ["#1f4e79" if not k.startswith("assembled") else "#d62728" for k in names]
        ax.bar(range(len(names)), means, yerr=stds, color=colors, capsize=3)
        ax.set_xticks(range(len(names)))
        ax.set_xticklabels(names, rotation=45, ha="right", fontsize=8)
        ax.set_ylabel(f"run time ({unit}), mean ± σ")
        ax.set_title(gname, fontsize=9)
        ax.grid(True, axis="y", alpha=0.3)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


# --------------------------------------------------------------------------------------------
# Meshes
# --------------------------------------------------------------------------------------------


def plot_meshes(meshes: Sequence, titles: Sequence[str], *, lim: float = 1.0, colors: Sequence[str] | None = None,
                suptitle: str | None = None) -> Figure:
    """Meshes (e.g. `wsmap.views.iso_mesh`) rendered side by side (`render_mesh`, no
    OpenGL); a `None` or empty mesh gets an empty panel that says so."""
    plt = _plt()
    colors = colors or ["#1f4e79", "#2e7d32", "#8e44ad", "#d35400"]
    fig = plt.figure(figsize=(5.0 * len(meshes), 5.0))
    for i, (mesh, t) in enumerate(zip(meshes, titles)):
        ax = fig.add_subplot(1, len(meshes), i + 1, projection="3d")
        if mesh is None or len(mesh.faces) == 0:
            for setter in (ax.set_xlim, ax.set_ylim, ax.set_zlim):
                setter(-lim, lim)
            ax.set_title(f"{t}\n(no reachable node: empty)", fontsize=9)
            continue
        render_mesh(mesh, ax=ax, color=colors[i % len(colors)], title=t, lim=lim)
        ax.title.set_fontsize(9)
    if suptitle:
        fig.suptitle(suptitle)
    fig.tight_layout()
    return fig


def export_mesh(mesh: Any, path: PathLike) -> Path:
    """Write a `trimesh.Trimesh` atomically; the format comes from the suffix (`.stl`,
    `.glb`, `.ply`, `.obj`). Returns the path."""
    path = Path(path)
    fmt = path.suffix.lstrip(".").lower()
    if not fmt:
        raise ValueError(f"{path}: no suffix to choose the mesh format from")
    with atomic_path(path) as tmp:
        mesh.export(tmp, file_type=fmt)
    return path


# --------------------------------------------------------------------------------------------
# Maps
# --------------------------------------------------------------------------------------------


def _axes_of(shape, lo, step):
    lo = np.broadcast_to(np.asarray(lo, dtype=float), (3,))
    step = np.broadcast_to(np.asarray(step, dtype=float), (3,))
    return [lo[i] + step[i] * np.arange(int(shape[i])) for i in range(3)]


#: Colours of a binary map's slices: unreachable (light), reachable (dark).
MAP_COLORS = ("#f4f4f4", "#1f4e79")
#: `plot_slices(status=...)`: a node the search gave up on without a certificate ("not found"),
#: apart from both the reachable and the certified unreachable nodes.
NOT_FOUND_COLOR = "#ff9f1c"
#: Colours of two maps compared: in neither, first only, second only, both.
COMPARE_COLORS = ("#f4f4f4", "#d62728", "#ff9f1c", "#1f4e79")


def _units_of(labels: Sequence[str]) -> str:
    # the grid's axis names say its scope: x, y, z are metres (R3), anything else radians (SO3)
    return "m" if tuple(labels) == ("x", "y", "z") else "rad"


def _layers_shown(occupied: np.ndarray, max_panels: int, z: np.ndarray, name: str, units: str
                  ) -> tuple[np.ndarray, str]:
    """The z-layers to draw and a note on what was left out: layers with nothing to see are dropped
    (all of them but the middle one when the whole map is empty), and more than `max_panels`
    layers are thinned to `max_panels` of them as evenly as whole layers allow, the first and last
    non-empty layer kept; the note then names the layers drawn (`z` their values, `name` the
    axis, in `units`), since the gaps between them are not all equal."""
    nz = occupied.size
    keep = np.flatnonzero(occupied)
    notes = []
    if keep.size == 0:
        keep = np.array([nz // 2])
        notes.append("nothing reachable in any z-layer")
    elif keep.size < nz:
        notes.append(f"{nz - keep.size} empty z-layer{'s' if nz - keep.size > 1 else ''} left out")
    if keep.size > max_panels:
        pick = np.unique(np.round(np.linspace(0, keep.size - 1, max_panels)).astype(int))
        drawn = ", ".join(f"{v:.2f}" for v in np.asarray(z)[keep[pick]])
        notes.append(f"{pick.size} of {keep.size} non-empty z-layers shown: {name} = {drawn} {units}")
        keep = keep[pick]
    return keep, "; ".join(notes)


#: The colour of a scene's obstacles in the map pictures (outlines in the slices, solids in 3-D).
OBSTACLE_COLOR = "#d62728"


def plane_section(vertices: ArrayLike, faces: ArrayLike, z: float) -> np.ndarray:
    """Where the plane `z` cuts a triangle mesh: segments `(S, 2, 2)`, each two `(x, y)` points (the
    mesh's units). A triangle with corners on both sides of the plane (a corner on it counts as
    above) gives one segment, between the crossings of its two edges that change side.

    Examples
    --------
    >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 1.0]])
    >>> plane_section(v, [[0, 1, 2]], 0.5).round(2).tolist()
    [[[0.5, 0.5], [0.0, 0.5]]]
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    above = v[:, 2] >= z
    f = f[above[f].any(axis=1) & ~above[f].all(axis=1)]  # the triangles the plane cuts
    a, b = v[f], v[np.roll(f, -1, axis=1)]  # (T, 3 edges, 3): each edge's ends
    cross = (a[..., 2] >= z) != (b[..., 2] >= z)  # (T, 3): exactly two per triangle
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(cross, (z - a[..., 2]) / (b[..., 2] - a[..., 2]), 0.0)
    p = a[..., :2] + t[..., None] * (b[..., :2] - a[..., :2])
    order = np.argsort(~cross, axis=1, kind="stable")[:, :2]  # the two crossing edges first
    return np.take_along_axis(p, order[..., None], axis=1)


def _outline_obstacles(ax, obstacles, z: float) -> bool:
    """Draw where the plane `z` cuts each obstacle `(name, vertices, faces)` on the panel `ax`;
    whether anything was drawn."""
    from matplotlib.collections import LineCollection

    drawn = False
    for _, v, f in obstacles:
        seg = plane_section(v, f, z)
        if len(seg):
            ax.add_collection(LineCollection(seg, colors=OBSTACLE_COLOR, linewidths=1.2, zorder=3))
            drawn = True
    return drawn


def obstacle_meshes(obstacles: Sequence | None) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """The `obstacles=` of the map pictures (`plot_slices`, `wsmap.views.figure_3d`) checked: a
    list of `(name, vertices (V, 3) float64, faces (F, 3) int64)`; `ValueError` naming the obstacle
    whose faces do not index its vertices."""
    out = []
    for item in obstacles or ():
        name, v, f = item
        v, f = np.asarray(v, dtype=np.float64), np.asarray(f)
        if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3 or (f.size and (f.min() < 0
                                                                                         or f.max() >= len(v))):
            raise ValueError(f"obstacle {name!r}: vertices must be (V, 3) and faces (F, 3) indices into them, got "
                             f"{v.shape} and {f.shape}")
        out.append((str(name), v, f.astype(np.int64)))
    return out


def _slice_grid(plt, count: int, ncols: int | None, extent, labels, units: str, panel: float = 2.3):
    """`(fig, axes)`: `count` map panels of `panel` inches in rows of `ncols` (default: at
    most 6), sharing metre (or radian) ticks, the axis names on the outer panels only, in a
    constrained layout so that the colour bar, the legend and the titles never sit on the data."""
    if ncols:
        ncols = max(1, min(int(ncols), count))
    else:  # rows of at most 6, as even as they go (13 panels: 5, 5, 3 rather than 6, 6, 1)
        ncols = int(math.ceil(count / math.ceil(count / 6)))
    nrows = int(math.ceil(count / ncols))
    fig, grid = plt.subplots(nrows, ncols, figsize=(panel * ncols + 1.2, panel * nrows + 1.3), squeeze=False,
                             sharex=True, sharey=True, layout="constrained")
    axes = list(grid.flat)
    for k, ax in enumerate(axes):
        if k >= count:
            ax.axis("off")
            continue
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(extent[2], extent[3])
        ax.set_aspect("equal")
        ax.tick_params(labelsize=8)
        col = k % ncols
        # the panel below this one is off (a short last row): this one shows the x ticks
        last_in_column = k + ncols >= count
        if last_in_column:
            ax.set_xlabel(f"{labels[0]} ({units})", fontsize=9)
            ax.xaxis.set_tick_params(labelbottom=True)
        if col == 0:
            ax.set_ylabel(f"{labels[1]} ({units})", fontsize=9)
    return fig, axes[:count]


def _cell_extent(ax_x, ax_y, step):
    # imshow's extent is the outer edge of the cells: each node is the centre of its cell
    step = np.broadcast_to(np.asarray(step, dtype=float), (3,))
    return [ax_x[0] - step[0] / 2, ax_x[-1] + step[0] / 2, ax_y[0] - step[1] / 2, ax_y[-1] + step[1] / 2]


def plot_slices(flat_map: ArrayLike, shape: Sequence[int], lo: float | ArrayLike = -1.0, step: float | ArrayLike = 0.1,
                *, compare: ArrayLike | None = None, title: str | None = None, ncols: int | None = None,
                labels: Sequence[str] = ("x", "y", "z"), names: Sequence[str] = ("first only", "second only", "both"),
                max_panels: int = 24, metadata: dict | None = None, obstacles: Sequence | None = None,
                status: ArrayLike | None = None) -> Figure:
    """The z-layers of a BINARY map side by side, in the grid's units. Returns a matplotlib Figure.

    Parameters
    ----------
    flat_map
        bool `(nx*ny*nz,)` in node order (first coordinate fastest).
    shape
        `(nx, ny, nz)`; `lo`, `step`: the grid's origin and spacing (scalars or 3-tuples;
        metres for an R3 grid, radians for SO3), which place every cell: ticks in those units,
        each panel titled with its layer's value (`z = 0.30 m`).
    compare
        a second map of the same shape (e.g. exact labels against a prediction): the cells
        are coloured in `names` order as `flat_map` only, `compare` only, both
        (`COMPARE_COLORS`); without it reachable against unreachable (`MAP_COLORS`).
        A legend below the panels says which colour is which.
    title
        the figure's title, short (arm, kind, orientation, convention); the rest of the
        settings belong in `metadata`.
    ncols
        panels per row (default up to 6); `labels`: the axes' names (`("r1", "r2", "r3")`
        for SO3 maps: radians).
    max_panels
        at most this many panels: z-layers with no reachable node are left out and a
        longer stack is thinned to `max_panels` layers, as evenly as whole layers allow (the
        legend's title says what was left out and names the layers drawn).
    metadata
        text stored in the PNG by `save_figure` (`{"Description": ...}`).
    obstacles
        a scene's obstacles, `(name, vertices (V, 3), faces (F, 3))` triangle meshes in the
        grid's frame (m; `wsmap.collision.Scene.triangles`): each panel outlines where its
        layer's plane cuts them (`OBSTACLE_COLOR`, legend entry "obstacle").
    status
        the map's int8 node status `(N,)` (`wsmap.workspace.status`: reached, certified
        unreachable, not found), without `compare`: the nodes not found are drawn in
        `NOT_FOUND_COLOR` and the legend tells "certified unreachable" from "not found".

    Raises
    ------
    ValueError
        A map, `compare` or `status` that does not fit `shape`, `status` with `compare`,
        `max_panels < 1`, or an obstacle whose faces do not index its `(V, 3)` vertices.
    """
    plt = _plt()
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    if int(max_panels) < 1:
        raise ValueError(f"max_panels must be at least 1, got {max_panels}")
    obstacles = obstacle_meshes(obstacles)
    vol = map_to_volume(np.asarray(flat_map, dtype=bool), shape)  # (nz, ny, nx)
    ax_x, ax_y, ax_z = _axes_of(shape, lo, step)
    units = _units_of(labels)
    if status is not None:
        if compare is not None:
            raise ValueError("status= colours one map's nodes; it cannot be drawn with compare=")
        from .workspace.status import NOT_FOUND

        missing = map_to_volume(np.asarray(status) == NOT_FOUND, shape)
        img = np.where(missing, 2, vol.astype(int))
        colors, vmax = MAP_COLORS + (NOT_FOUND_COLOR,), 2
        handles = [Patch(facecolor=MAP_COLORS[1], label="reachable"),
                   Patch(facecolor=MAP_COLORS[0], edgecolor="0.6", label="certified unreachable"),
                   Patch(facecolor=NOT_FOUND_COLOR, label=f"not found ({int(missing.sum())})")]
    elif compare is None:
        img = vol.astype(int)
        colors, vmax = MAP_COLORS, 1
        handles = [Patch(facecolor=MAP_COLORS[1], label="reachable"),
                   Patch(facecolor=MAP_COLORS[0], edgecolor="0.6", label="unreachable")]
    else:
        other = map_to_volume(np.asarray(compare, dtype=bool), shape)
        img = vol * 1 + other * 2  # 0 none, 1 map only, 2 compare only, 3 both
        colors, vmax = COMPARE_COLORS, 3
        handles = [Patch(facecolor=c, label=n) for c, n in zip(COMPARE_COLORS[1:], names)]
        handles.append(Patch(facecolor=COMPARE_COLORS[0], edgecolor="0.6", label="neither"))
    layers, note = _layers_shown(img.reshape(img.shape[0], -1).any(axis=1), int(max_panels), ax_z, labels[2], units)
    extent = _cell_extent(ax_x, ax_y, step)
    fig, axes = _slice_grid(plt, layers.size, ncols, extent, labels, units)
    cmap = ListedColormap(list(colors))
    outlined = False
    for k, ax in zip(layers, axes):
        ax.imshow(img[k], origin="lower", cmap=cmap, vmin=0, vmax=vmax, extent=extent, interpolation="nearest")
        ax.set_title(f"{labels[2]} = {ax_z[k]:.2f} {units}", fontsize=9)
        outlined |= _outline_obstacles(ax, obstacles, ax_z[k])
    if outlined:
        from matplotlib.lines import Line2D

        handles.append(Line2D([], [], color=OBSTACLE_COLOR, linewidth=1.2, label="obstacle"))
    fig.legend(handles=handles, loc="outside lower center", ncol=len(handles), fontsize=9, frameon=False,
               title=note or None, title_fontsize=8)
    if title:
        fig.suptitle(title, fontsize=11)
    fig.wsmap_metadata = dict(metadata or {})
    return fig


def _not_found_volume(status, flat_shape, shape, unreachable) -> np.ndarray | None:
    """`plot_value_slices`' nodes not found as a `(nz, ny, nx)` bool volume, or None without a
    `status` (checked: the map's shape, and an `unreachable` value to set them apart from)."""
    if status is None:
        return None
    st = np.asarray(status)
    if st.shape != tuple(flat_shape):
        raise ValueError(f"status must have the map's shape {tuple(flat_shape)}, got {st.shape}")
    if unreachable is None:
        raise ValueError("status= draws the unreachable nodes in two colours; it needs unreachable= (a value)")
    from .workspace.status import NOT_FOUND

    return map_to_volume(st == NOT_FOUND, shape)


def plot_value_slices(values: ArrayLike, shape: Sequence[int], lo: float | ArrayLike, step: float | ArrayLike, *,
                      label: str, vmin: float | None = None, vmax: float | None = None, title: str | None = None,
                      ncols: int | None = None, labels: Sequence[str] = ("x", "y", "z"), cmap: str = "viridis",
                      max_panels: int = 24, unreachable: float | None = 0.0, metadata: dict | None = None,
                      obstacles: Sequence | None = None, status: ArrayLike | None = None) -> Figure:
    """The z-layers of a FLOAT map (e.g. a reachability index in [0, 1], a manipulability map >= 0)
    side by side in the grid's units, coloured by value, with one colour bar shared by every panel.
    Returns the Figure.

    Parameters
    ----------
    values
        the map, `(nx*ny*nz,)` finite numbers in node order (first coordinate fastest).
    shape
        `(nx, ny, nz)`; `lo`, `step`: the grid's origin and spacing (scalars or
        3-tuples; metres for R3 maps, radians for SO3): ticks in those units, each panel titled
        with its layer's value (`z = 0.30 m`).
    label
        the colour bar's label: what the value is, with its units (`"manipulability (m³)"`).
    vmin, vmax
        the colour range (default: the map's minimum and maximum), the same in every panel.
    labels
        the axes' names (`("r1", "r2", "r3")` for SO3 maps); `cmap`: a matplotlib colormap.
    max_panels
        at most this many panels: layers with no value above `vmin` (nothing reachable)
        are left out and a longer stack is thinned to `max_panels` layers, as evenly as whole
        layers allow (a note under the panels says what was left out and names the layers drawn).
    unreachable
        nodes of exactly this value (default 0: where an index or a manipulability
        map is unreachable) are drawn light grey, apart from the colour scale, with a legend entry
        "unreachable"; `None` colours them by value too.
    title
        short; `metadata`: text stored in the PNG by `save_figure`.
    obstacles
        a scene's obstacles, outlined in every panel as in `plot_slices`.
    status
        the map's int8 node status `(N,)` (`wsmap.workspace.status`: reached, certified
        unreachable, not found; needs `unreachable`): the nodes not found are drawn in
        `NOT_FOUND_COLOR` apart from the certified unreachable ones (light grey), the legend
        naming both with their counts ("certified unreachable (0) (M)", "not found (K)"), and
        layers holding only nodes not found are drawn too.

    Raises
    ------
    ValueError
        A map that does not fit `shape`, has NaN or infinite values, `vmax < vmin`,
        `max_panels < 1`, an obstacle as `plot_slices` refuses it, or a `status` of another
        shape or without `unreachable`.
    """
    plt = _plt()
    v = np.asarray(values)
    if v.dtype.kind not in "biuf":
        raise ValueError(f"values must be real numbers, got dtype {v.dtype}")
    v = v.astype(np.float64)
    if v.ndim != 1:
        raise ValueError(f"values must be a flat map (N,) in node order, got shape {v.shape}")
    bad = ~np.isfinite(v)
    if bad.any():
        raise ValueError(f"values contain {int(bad.sum())} NaN or infinite values (first at node {int(np.argmax(bad))})")
    if int(max_panels) < 1:
        raise ValueError(f"max_panels must be at least 1, got {max_panels}")
    obstacles = obstacle_meshes(obstacles)
    vol = map_to_volume(v, shape)
    lo_c = float(v.min()) if vmin is None else float(vmin)
    hi_c = float(v.max()) if vmax is None else float(vmax)
    if not (math.isfinite(lo_c) and math.isfinite(hi_c)) or hi_c < lo_c:
        raise ValueError(f"the colour range must be finite with vmin <= vmax, got vmin={lo_c}, vmax={hi_c}")
    ax_x, ax_y, ax_z = _axes_of(shape, lo, step)
    units = _units_of(labels)
    missing = _not_found_volume(status, v.shape, shape, unreachable)
    occupied = vol > lo_c if missing is None else (vol > lo_c) | missing
    layers, note = _layers_shown(occupied.reshape(vol.shape[0], -1).any(axis=1), int(max_panels), ax_z,
                                 labels[2], units)
    extent = _cell_extent(ax_x, ax_y, step)
    fig, axes = _slice_grid(plt, layers.size, ncols, extent, labels, units)
    import matplotlib
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    colours = matplotlib.colormaps[cmap] if isinstance(cmap, str) else cmap
    # "unreachable" is not a value on the scale: masked cells take the grey of the binary maps
    colours = colours.with_extremes(bad=MAP_COLORS[0])
    shown = np.ma.masked_equal(vol, unreachable) if unreachable is not None else vol
    image = None
    outlined = False
    for k, ax in zip(layers, axes):
        image = ax.imshow(shown[k], origin="lower", cmap=colours, vmin=lo_c, vmax=hi_c, extent=extent,
                          interpolation="nearest")
        if missing is not None and missing[k].any():  # over the grey: the nodes not found, in their colour
            ax.imshow(np.ma.masked_where(~missing[k], missing[k].astype(float)), origin="lower",
                      cmap=ListedColormap([NOT_FOUND_COLOR]), vmin=0, vmax=1, extent=extent, interpolation="nearest")
        ax.set_title(f"{labels[2]} = {ax_z[k]:.2f} {units}", fontsize=9)
        outlined |= _outline_obstacles(ax, obstacles, ax_z[k])
    cbar = fig.colorbar(image, ax=axes, shrink=0.9 if len(axes) > 6 else 1.0, aspect=30)
    cbar.set_label(label)
    if unreachable is not None or note or outlined:
        from matplotlib.lines import Line2D

        handles = [Patch(facecolor=MAP_COLORS[0], edgecolor="0.6", label=f"unreachable ({unreachable:g})")] \
            if unreachable is not None else []
        if missing is not None:
            from .workspace.status import CERTIFIED

            certified = int((np.asarray(status) == CERTIFIED).sum())
            handles = [Patch(facecolor=MAP_COLORS[0], edgecolor="0.6",
                             label=f"certified unreachable ({unreachable:g}): {certified}"),
                       Patch(facecolor=NOT_FOUND_COLOR, label=f"not found ({unreachable:g}): {int(missing.sum())}")]
        if outlined:
            handles.append(Line2D([], [], color=OBSTACLE_COLOR, linewidth=1.2, label="obstacle"))
        fig.legend(handles=handles, loc="outside lower center", fontsize=9, frameon=False, title=note or None,
                   title_fontsize=8, **({} if missing is None else {"ncol": len(handles)}))
    if title:
        fig.suptitle(title, fontsize=11)
    fig.wsmap_metadata = dict(metadata or {})
    return fig


def _angle_text(x: float) -> str:
    """An angle in radians as a reader writes it: a multiple of π/12 as `π/2`, `-3π/4`; else 3 decimals."""
    k = x / (math.pi / 12)
    if abs(k - round(k)) > 1e-9:
        return f"{x:.3f}"
    num, den = int(round(k)), 12
    if num == 0:
        return "0"
    g = math.gcd(abs(num), den)
    num, den = num // g, den // g
    head = {1: "π", -1: "-π"}.get(num, f"{num}π")
    return head if den == 1 else f"{head}/{den}"


#: How each pose convention reads (`wsmap.workspace.CONVENTIONS`).
CONVENTION_TEXT = {"paper": "paper convention T = R·transl(p)", "standard": "standard convention T = transl(p)·R"}


def map_title(arm: str, kind: Any, *, rpy: Sequence[float] | None = None, point: Sequence[float] | None = None,
              convention: str | None = None, orientations: int | None = None, summary: str | None = None,
              collision: str | None = None) -> str:
    """A map picture's short title: the arm, the kind, its orientation (or point) and its pose convention,
    for a collision-aware map a line `collision-free: <collision>` (what it is free of: `"scene
    table.yaml"`, `"self-collision only"`), and on the last line `summary` (e.g. `"1883 of 9261
    nodes reachable (numerical)"`).

    Parameters
    ----------
    arm
        the arm's name; `kind`: its `wsmap.workspace.kinds.MapKind` (what it reads
        decides what the title names: `rpy` in rad as `R = Rx·Ry·Rz`, `point` in m, the
        number of `orientations`).
    convention
        `"paper"` or `"standard"`; the kind's own convention wins where it fixes one.

    Examples
    --------
    >>> from wsmap.workspace.kinds import get_kind
    >>> map_title("panda", get_kind("constant"), rpy=(math.pi, 0, 0), convention="standard")
    'panda: constant map, rpy (π, 0, 0) rad, standard convention T = transl(p)·R'
    """
    # a float kind says what its value is (its label); a binary one is named by its kind
    head = f"{arm}: {kind.label if kind.value_type is float else kind.name + ' map'}"
    if "orientations" in kind.inputs and orientations is not None:
        head += f" over {int(orientations)} orientations"
    parts = [head]
    if "rpy" in kind.inputs and rpy is not None:
        parts.append("rpy (" + ", ".join(_angle_text(float(a)) for a in rpy) + ") rad")
    if "point" in kind.inputs and point is not None:
        parts.append("at (" + ", ".join(f"{float(c):g}" for c in point) + ") m")
    conv = kind.convention or convention
    if conv is not None:
        parts.append(CONVENTION_TEXT.get(conv, f"{conv} convention"))
    return ", ".join(parts) + (f"\ncollision-free: {collision}" if collision else "") + (f"\n{summary}" if summary else "")


def png_metadata(settings: dict, *, title: str | None = None) -> dict[str, str]:
    """PNG text chunks of a map picture: `Title`, `Software` (wsmap and its version) and
    `Description`, the map's settings as JSON (what the map file records; `wsmap.io.jsonable`)."""
    import json

    from ._version import __version__
    from .io import jsonable

    meta = {"Software": f"wsmap {__version__}", "Description": json.dumps(jsonable(settings), sort_keys=True)}
    if title:
        meta["Title"] = title.replace("\n", " — ")
    return meta


def plot_voxels(flat_map: ArrayLike, shape: Sequence[int], lo: float | ArrayLike = -1.0, step: float | ArrayLike = 0.1, *,
                ax: Axes | None = None, color: str = "#1f4e79", title: str | None = None) -> Axes:
    """Reachable nodes as a 3-D scatter (one point per node). Returns the Axes."""
    import matplotlib.pyplot as plt

    vol = map_to_volume(np.asarray(flat_map, dtype=bool), shape)
    ax_x, ax_y, ax_z = _axes_of(shape, lo, step)
    k, j, i = np.nonzero(vol)
    if ax is None:
        ax = plt.figure(figsize=(5, 5)).add_subplot(projection="3d")
    ax.scatter(ax_x[i], ax_y[j], ax_z[k], s=4, c=color, alpha=0.5, depthshade=True)
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_zlabel("z")
    ax.set_box_aspect((1, 1, 1))
    if title:
        ax.set_title(title)
    return ax


def render_mesh(mesh: Any, *, ax: Axes | None = None, color: str = "#1f4e79", title: str | None = None,
                elev: float = 25, azim: float = -60, lim: float = 1.0) -> Axes:
    """Draw a triangle mesh with matplotlib (headless, no OpenGL). Returns the Axes."""
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    if ax is None:
        ax = plt.figure(figsize=(5, 5)).add_subplot(projection="3d")
    tris = mesh.vertices[mesh.faces]
    # simple Lambert shading from a fixed light so that the shape reads without OpenGL
    light = np.array([0.4, -0.5, 0.77])
    shade = 0.35 + 0.65 * np.clip(mesh.face_normals @ light, 0, 1)
    base = np.array([int(color[i : i + 2], 16) / 255 for i in (1, 3, 5)])
    colors = np.clip(base[None, :] * shade[:, None] + 0.15 * (1 - shade[:, None]), 0, 1)
    ax.add_collection3d(Poly3DCollection(tris, facecolors=colors, edgecolor="none"))
    for setter in (ax.set_xlim, ax.set_ylim, ax.set_zlim):
        setter(-lim, lim)
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_zlabel("z")
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=elev, azim=azim)
    if title:
        ax.set_title(title)
    return ax


def save_figure(fig: Figure, path: PathLike, dpi: int = 120, *, metadata: dict | None = None) -> None:
    """Save a matplotlib figure atomically (PNG unless the suffix says otherwise) and close it.

    `metadata` (and the `wsmap_metadata` the map drawings attach, e.g. `png_metadata`)
    goes into a PNG's text chunks (`tEXt`: `Title`, `Description`, ...; read back with
    `PIL.Image.open(path).text`); other formats are written without it.
    """
    import matplotlib.pyplot as plt

    meta = {**getattr(fig, "wsmap_metadata", {}), **(metadata or {})}
    with atomic_path(path) as tmp:
        fmt = Path(path).suffix.lstrip(".").lower() or "png"
        fig.savefig(tmp, dpi=dpi, bbox_inches="tight", format=fmt,
                    metadata={str(k): str(v) for k, v in meta.items()} if meta and fmt == "png" else None)
    plt.close(fig)
