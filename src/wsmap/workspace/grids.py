"""Grids of nodes and the layout of flat maps.

Node order (the paper's): the first coordinate varies fastest, then the second, then the third;
the 0-based flat index of node `(i, j, k)` is `i + nx*j + nx*ny*k`. A flat map therefore
reshapes to a volume of shape `(nz, ny, nx)` (see `map_to_volume`).
"""

from __future__ import annotations

import functools

import numpy as np

from ..io import available_memory
from ..kinematics.transforms import as_real_array
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike, Sequence

__all__ = ["grid_counts", "grid_axes", "cartesian_grid", "angle_grid", "map_to_volume", "volume_to_map", "BLOCK_NODES",
           "N_BLOCKS", "block_slice", "CROP_3087", "available_memory", "MAX_NODES", "node_neighbours",
           "check_fits", "triple"]

#: The paper's output blocks of the 21³ map: 7 consecutive blocks of 1323 nodes (3 z-layers each).
BLOCK_NODES = 1323
N_BLOCKS = 7
#: Table 1's "3086" crop: from 0-based flat index 5292 (z = 0.2) to z = 0.8, 3087 nodes.
CROP_3087 = slice(5292, 5292 + 3087)
#: Grids above this many nodes are refused before any memory is touched (a 1 mm grid over 2 m³).
MAX_NODES = 10**10

def check_fits(nbytes: int, what: str, advice: str = "use a coarser step or a smaller range") -> None:
    """A one-line `MemoryError` when `what` needs `nbytes` bytes, more than half the memory
    available (`available_memory`), before any work; `advice` says what to change."""
    avail = available_memory()
    if nbytes > avail // 2:
        raise MemoryError(
            f"{what} needs {nbytes / 2**30:.2f} GiB, more than half the {avail / 2**30:.2f} GiB of memory "
            f"available; {advice}"
        )


# --------------------------------------------------------------------------- grids
def triple(name: str, x: float | ArrayLike) -> np.ndarray:
    """`x` as three finite floats `(3,)` (a scalar repeated), or a one-line `ValueError` naming `name`."""
    x = as_real_array(name, x)
    if x.ndim == 0:
        x = np.repeat(x, 3)
    if x.shape != (3,):
        raise ValueError(f"{name} must be a scalar or a 3-tuple, got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name} contains NaN or infinite values: {x.tolist()}")
    return x


def grid_counts(lo: float | ArrayLike, hi: float | ArrayLike, step: float | ArrayLike, max_nodes: int = MAX_NODES,
                what: str = "this tool handles") -> tuple[int, int, int]:
    """Nodes along each axis of the grid `lo + k·step <= hi`, without allocating anything.

    `lo`, `hi` and `step` are scalars or 3-tuples. Refused (`ValueError`): non-finite or
    complex values, `step <= 0`, `lo > hi`, and grids of more than `max_nodes` nodes — checked
    in floating point first, because a tiny step (1e-300) overflows int64 and would wrap to 0 nodes.
    """
    lo, hi, step = triple("lo", lo), triple("hi", hi), triple("step", step)
    if np.any(step <= 0):
        raise ValueError(f"step must be positive, got {step.tolist()}")
    if np.any(lo > hi):
        raise ValueError(f"lo must not exceed hi on any axis, got lo={lo.tolist()} hi={hi.tolist()}")
    with np.errstate(over="ignore", invalid="ignore"):
        span = (hi - lo) / step
        # the slack absorbs rounding in span (2·pi/(pi/10) is 20 to within an ulp, not exactly)
        counts = np.floor(span + 1e-9 * np.maximum(1.0, span)) + 1.0
        total = float(np.prod(counts))
    if not (np.all(np.isfinite(counts)) and total <= max_nodes):
        raise ValueError(
            f"a grid from {lo.tolist()} to {hi.tolist()} at step {step.tolist()} has about {total:.3g} nodes, "
            f"more than the {max_nodes:.3g} {what}; use a coarser step or a smaller range"
        )
    return tuple(int(c) for c in counts)


def grid_axes(lo: float | ArrayLike, hi: float | ArrayLike, step: float | ArrayLike) -> list[np.ndarray]:
    """The node values along each axis: `lo + k·step` for every `k` with the value `<= hi`.

    `lo`, `hi` and `step` are scalars or 3-tuples. Counting is exact up to rounding:
    `[-1, 1]` at 0.1 gives 21 values, `[0, 2·pi]` at `pi/10` gives 21 (`grid_counts`).
    """
    counts = grid_counts(lo, hi, step)
    lo, step = triple("lo", lo), triple("step", step)
    total = int(np.prod(counts))
    check_fits(total * 3 * 8, f"a grid of {list(counts)} = {total} nodes")
    return [lo[i] + step[i] * np.arange(counts[i]) for i in range(3)]


def _nodes(axes) -> np.ndarray:
    # x fastest in C order, written into the one (N, 3) array by broadcasting: its 24 N bytes are
    # the whole peak (grid_axes counts them), where meshgrid's three copies and the stack took 48 N
    nx, ny, nz = (len(a) for a in axes)
    out = np.empty((nz, ny, nx, 3))
    out[..., 0] = axes[0][None, None, :]
    out[..., 1] = axes[1][None, :, None]
    out[..., 2] = axes[2][:, None, None]
    return out.reshape(-1, 3)


def cartesian_grid(lo: float | ArrayLike = -1.0, hi: float | ArrayLike = 1.0, step: float | ArrayLike = 0.1
                  ) -> np.ndarray:
    """Positions `(N, 3)` in metres on a regular grid, in the paper's node order (x fastest)."""
    return _nodes(grid_axes(lo, hi, step))


def angle_grid(lo: float | ArrayLike = 0.0, hi: float | ArrayLike = 2 * np.pi, step: float | ArrayLike = np.pi / 10
              ) -> np.ndarray:
    """Orientation angles `(N, 3)` (r1, r2, r3) in radians, in the paper's node order (r1 fastest)."""
    return _nodes(grid_axes(lo, hi, step))


# --------------------------------------------------------------------------- poses

# --------------------------------------------------------------------------- layout helpers
def map_to_volume(flat: ArrayLike, shape: Sequence[int]) -> np.ndarray:
    """Flat map `(..., nx*ny*nz)` → volume `(..., nz, ny, nx)`; `shape` is `(nx, ny, nz)`."""
    flat = np.asarray(flat)
    nx, ny, nz = (int(s) for s in shape)
    if flat.shape[-1] != nx * ny * nz:
        raise ValueError(f"a map of {flat.shape[-1]} nodes does not fill a grid of shape {(nx, ny, nz)}")
    return flat.reshape(flat.shape[:-1] + (nz, ny, nx))


def volume_to_map(volume: ArrayLike) -> np.ndarray:
    """Volume `(..., nz, ny, nx)` → flat map `(..., nx*ny*nz)` in node order."""
    volume = np.asarray(volume)
    if volume.ndim < 3:
        raise ValueError(f"a volume needs at least 3 dimensions (nz, ny, nx), got shape {volume.shape}")
    return volume.reshape(volume.shape[:-3] + (-1,))


def block_slice(block: int) -> slice:
    """Flat-index slice of the paper's output block `block` (0-based, 0..6) of the 21³ map.

    Block 4 (the paper's 1-based block 5, section 6.1) is 0-based indices 5292..6614, z in {0.2, 0.3, 0.4}.
    """
    if int(block) != block or not 0 <= block < N_BLOCKS:
        raise ValueError(f"block must be an integer in 0..{N_BLOCKS - 1}, got {block!r}")
    return slice(int(block) * BLOCK_NODES, (int(block) + 1) * BLOCK_NODES)



def node_neighbours(nodes: ArrayLike, k: int = 18, radius: float = 1.5) -> np.ndarray:
    """Each node's neighbours: `(N, k)` int indices of the `k` nearest other nodes within
    `radius` times the typical spacing, nearest first, `-1` where fewer (on a whole grid with the
    defaults: one column per offset, 6 face then 12 edge neighbours, `-1` off the grid).

    The typical spacing is the median distance from a node to its nearest neighbour, so on a cubic
    grid of step `h` the defaults give the 6 face neighbours (at `h`) then the 12 edge neighbours
    (at `h·√2`). Works for any node set (positions in m, or angles in rad); used by the numerical
    maps to start IK at a node from its neighbours' solutions.
    """
    nodes = np.asarray(nodes, dtype=np.float64)
    N = len(nodes)
    if N < 2 or k < 1:
        return np.full((N, max(k, 0)), -1, dtype=np.int64)
    if k == 18 and radius == 1.5:
        # a whole grid (the common case): index arithmetic, no tree
        shape = _grid_shape(nodes)
        if shape is not None:
            return _grid_neighbours(shape)
    from scipy.spatial import cKDTree
    tree = cKDTree(nodes)
    d1, _ = tree.query(nodes, k=2)
    spacing = float(np.median(d1[:, 1]))
    kk = min(k + 1, N)
    d, idx = tree.query(nodes, k=kk, distance_upper_bound=radius * spacing * (1 + 1e-9) if spacing > 0 else np.inf)
    idx = np.where(np.isinf(d), -1, idx)[:, 1:].astype(np.int64)
    if idx.shape[1] < k:
        idx = np.concatenate([idx, np.full((N, k - idx.shape[1]), -1, dtype=np.int64)], axis=1)
    return idx


def _grid_shape(nodes):
    """`(nx, ny, nz)` if `nodes` (N, 3) is a whole grid in node order (first coordinate
    fastest, one step along each axis), else None."""
    N = len(nodes)
    if nodes.ndim != 2 or nodes.shape[1] != 3:
        return None
    xs = [np.unique(nodes[:, c]) for c in range(3)]
    nx, ny, nz = (len(x) for x in xs)
    if nx * ny * nz != N or min(nx, ny, nz) < 2:
        return None
    if not all(np.allclose(np.diff(x), x[1] - x[0], rtol=1e-9, atol=0) for x in xs):
        return None
    idx = np.arange(N)
    ok = (nodes[:, 0] == xs[0][idx % nx]) & (nodes[:, 1] == xs[1][(idx // nx) % ny]) & (nodes[:, 2] == xs[2][idx // (nx * ny)])
    return (nx, ny, nz) if ok.all() else None


def _grid_neighbours(shape):
    """The 6 face then the 12 edge neighbours of every node of a whole grid, each column one offset
    (-1 where it falls off the grid); a fresh copy of a cached table (it depends only on the shape)."""
    return _grid_neighbours_cached(tuple(int(v) for v in shape)).copy()


@functools.lru_cache(maxsize=8)
def _grid_neighbours_cached(shape):
    nx, ny, nz = shape
    N = nx * ny * nz
    idx = np.arange(N)
    i, j, k = idx % nx, (idx // nx) % ny, idx // (nx * ny)
    offsets = sorted(((dx, dy, dz) for dz in (-1, 0, 1) for dy in (-1, 0, 1) for dx in (-1, 0, 1)
                      if abs(dx) + abs(dy) + abs(dz) in (1, 2)),
                     key=lambda o: (abs(o[0]) + abs(o[1]) + abs(o[2]), o[0] + nx * o[1] + nx * ny * o[2]))
    nb = np.empty((N, len(offsets)), dtype=np.int64)
    for c, (dx, dy, dz) in enumerate(offsets):
        inside = ((i + dx >= 0) & (i + dx < nx) & (j + dy >= 0) & (j + dy < ny) & (k + dz >= 0) & (k + dz < nz))
        nb[:, c] = np.where(inside, idx + (dx + nx * dy + nx * ny * dz), -1)
    return nb
