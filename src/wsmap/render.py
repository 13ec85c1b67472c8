"""Looking at workspace maps: z-slice plots, 3-D voxel views, surface meshes (marching cubes).

Maps are flat boolean arrays in the paper's node order; ``shape = (nx, ny, nz)`` and the grid's
``lo``/``step`` place them in space (metres for R3 maps, radians for SO3 maps).
"""

from __future__ import annotations

import numpy as np

from .io import atomic_path
from .workspace import map_to_volume

__all__ = ["plot_slices", "plot_voxels", "map_to_mesh", "save_figure", "render_mesh"]


def _axes_of(shape, lo, step):
    lo = np.broadcast_to(np.asarray(lo, dtype=float), (3,))
    step = np.broadcast_to(np.asarray(step, dtype=float), (3,))
    return [lo[i] + step[i] * np.arange(int(shape[i])) for i in range(3)]


def plot_slices(flat_map, shape, lo=-1.0, step=0.1, *, compare=None, title=None, ncols=7, labels=("x", "y", "z")):
    """One panel per z-layer: reachable nodes dark. Returns a matplotlib Figure.

    With ``compare`` (a second map of the same shape, e.g. exact labels against a prediction) the
    panels colour agreement (reachable in both), only-in-``flat_map`` and only-in-``compare``.
    """
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    vol = map_to_volume(np.asarray(flat_map, dtype=bool), shape)
    ax_x, ax_y, ax_z = _axes_of(shape, lo, step)
    nz = vol.shape[0]
    ncols = min(ncols, nz)
    nrows = int(np.ceil(nz / ncols))
    fig, axes = plt.subplots(nrows, ncols, figsize=(1.9 * ncols, 2.0 * nrows + 0.4), squeeze=False)
    if compare is None:
        img = vol.astype(int)
        cmap = ListedColormap(["#f4f4f4", "#1f4e79"])
        vmax = 1
    else:
        other = map_to_volume(np.asarray(compare, dtype=bool), shape)
        img = vol * 1 + other * 2  # 0 none, 1 map only, 2 compare only, 3 both
        cmap = ListedColormap(["#f4f4f4", "#d62728", "#ff9f1c", "#1f4e79"])
        vmax = 3
    extent = [ax_x[0], ax_x[-1], ax_y[0], ax_y[-1]]
    for k, ax in enumerate(axes.flat):
        ax.set_xticks([])
        ax.set_yticks([])
        if k >= nz:
            ax.axis("off")
            continue
        ax.imshow(img[k], origin="lower", cmap=cmap, vmin=0, vmax=vmax, extent=extent, interpolation="nearest")
        ax.set_title(f"{labels[2]} = {ax_z[k]:.2f}", fontsize=8)
    if compare is not None:
        from matplotlib.patches import Patch

        fig.legend(
            handles=[Patch(color=c, label=l) for c, l in zip(cmap.colors[1:], ["first only", "second only", "both"])],
            loc="lower center",
            ncol=3,
            fontsize=8,
        )
    if title:
        fig.suptitle(title)
    fig.tight_layout(rect=(0, 0.04 if compare is not None else 0, 1, 1))
    return fig


def plot_voxels(flat_map, shape, lo=-1.0, step=0.1, *, ax=None, color="#1f4e79", title=None):
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


def map_to_mesh(flat_map, shape, lo=-1.0, step=0.1):
    """Surface of the reachable region as a ``trimesh.Trimesh`` (marching cubes at level 0.5).

    The volume is padded by one empty node on every side so that the surface is closed where the
    workspace touches the grid's border. Vertices are in the grid's units.
    """
    import trimesh
    from skimage.measure import marching_cubes

    vol = map_to_volume(np.asarray(flat_map, dtype=bool), shape)
    if not vol.any():
        raise ValueError("the map has no reachable node: there is no surface to mesh")
    padded = np.pad(vol.astype(np.float32), 1)
    # (z, y, x) volume → transpose to (x, y, z) so that vertex columns are x, y, z
    verts, faces, _, _ = marching_cubes(padded.transpose(2, 1, 0), level=0.5)
    lo = np.broadcast_to(np.asarray(lo, dtype=float), (3,))
    step = np.broadcast_to(np.asarray(step, dtype=float), (3,))
    verts = lo + (verts - 1.0) * step
    # swapping the x and z axes is a reflection: reverse the winding so normals point outwards
    return trimesh.Trimesh(vertices=verts, faces=faces[:, ::-1], process=True)


def render_mesh(mesh, *, ax=None, color="#1f4e79", title=None, elev=25, azim=-60, lim=1.0):
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


def save_figure(fig, path, dpi: int = 120) -> None:
    """Save a matplotlib figure atomically (PNG unless the suffix says otherwise) and close it."""
    import matplotlib.pyplot as plt

    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, bbox_inches="tight")
    plt.close(fig)
