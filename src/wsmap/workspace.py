"""The classical algorithm: binary workspace maps by discretisation.

A *scope* is a grid of nodes, either positions at a fixed orientation (the constant-orientation
workspace, "R3") or orientations at a fixed point (the orientation workspace, "SO3"). A node is
``True`` when inverse kinematics has a solution for the node's target pose.

Node order (the paper's): the first coordinate varies fastest, then the second, then the third;
the 0-based flat index of node ``(i, j, k)`` is ``i + nx*j + nx*ny*k``. A flat map therefore
reshapes to a volume of shape ``(nz, ny, nx)`` (see :func:`map_to_volume`).

Pose conventions:

* ``"paper"``: ``T = Rx(r1)·Ry(r2)·Rz(r3) · transl(p)`` (the authors' code): the position tested is
  ``R·p``, not ``p``;
* ``"standard"``: ``T = transl(p) · R``.

They agree when ``R = I``.
"""

from __future__ import annotations

import os

import numpy as np

from .kinematics import (
    DHRobot,
    ikine_LM,
    ikine_spherical_wrist,
    require_spherical_wrist,
    rpy2r,
    wrist_centre_reachable,
)

__all__ = [
    "METHODS",
    "CONVENTIONS",
    "grid_axes",
    "cartesian_grid",
    "angle_grid",
    "target_poses",
    "constant_orientation_map",
    "orientation_map",
    "map_to_volume",
    "volume_to_map",
    "BLOCK_NODES",
    "N_BLOCKS",
    "block_slice",
    "CROP_3087",
    "available_memory",
]

METHODS = ("exact", "numerical")
CONVENTIONS = ("paper", "standard")

#: The paper's output blocks of the 21³ map: 7 consecutive blocks of 1323 nodes (3 z-layers each).
BLOCK_NODES = 1323
N_BLOCKS = 7
#: Table 1's "3086" crop: from 0-based flat index 5292 (z = 0.2) to z = 0.8, 3087 nodes.
CROP_3087 = slice(5292, 5292 + 3087)


def available_memory() -> int:
    """Bytes of memory available to this process (Linux ``MemAvailable``; physical size elsewhere)."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def _check_fits(nbytes: int, what: str) -> None:
    avail = available_memory()
    if nbytes > avail // 2:
        raise MemoryError(
            f"{what} needs {nbytes / 2**30:.2f} GiB, more than half the {avail / 2**30:.2f} GiB of memory "
            "available; use a coarser step or a smaller range"
        )


# --------------------------------------------------------------------------- grids
def _triple(name, x):
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 0:
        x = np.repeat(x, 3)
    if x.shape != (3,):
        raise ValueError(f"{name} must be a scalar or a 3-tuple, got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name} contains NaN or infinite values: {x.tolist()}")
    return x


def grid_axes(lo, hi, step) -> list[np.ndarray]:
    """The node values along each axis: ``lo + k·step`` for every ``k`` with the value ``<= hi``.

    ``lo``, ``hi`` and ``step`` are scalars or 3-tuples. Counting is exact up to rounding:
    ``[-1, 1]`` at 0.1 gives 21 values, ``[0, 2·pi]`` at ``pi/10`` gives 21.
    """
    lo, hi, step = _triple("lo", lo), _triple("hi", hi), _triple("step", step)
    if np.any(step <= 0):
        raise ValueError(f"step must be positive, got {step.tolist()}")
    if np.any(lo > hi):
        raise ValueError(f"lo must not exceed hi, got lo={lo.tolist()} hi={hi.tolist()}")
    span = (hi - lo) / step
    # the slack absorbs rounding in span (2·pi/(pi/10) is 20 to within an ulp, not exactly)
    counts = np.floor(span + 1e-9 * np.maximum(1.0, span)).astype(np.int64) + 1
    total = int(np.prod(counts.astype(np.float64)))
    _check_fits(total * 3 * 8, f"a grid of {counts.tolist()} = {total} nodes")
    return [lo[i] + step[i] * np.arange(counts[i]) for i in range(3)]


def _nodes(axes) -> np.ndarray:
    # meshgrid with 'ij' on (z, y, x) and reversing gives x fastest in C order
    zz, yy, xx = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    return np.stack([xx.ravel(), yy.ravel(), zz.ravel()], axis=-1)


def cartesian_grid(lo=-1.0, hi=1.0, step=0.1) -> np.ndarray:
    """Positions ``(N, 3)`` in metres on a regular grid, in the paper's node order (x fastest)."""
    return _nodes(grid_axes(lo, hi, step))


def angle_grid(lo=0.0, hi=2 * np.pi, step=np.pi / 10) -> np.ndarray:
    """Orientation angles ``(N, 3)`` (r1, r2, r3) in radians, in the paper's node order (r1 fastest)."""
    return _nodes(grid_axes(lo, hi, step))


# --------------------------------------------------------------------------- poses
def _check_choice(name, value, choices):
    if value not in choices:
        raise ValueError(f"unknown {name} {value!r}; choose one of {', '.join(choices)}")


def target_poses(positions, rpy, convention: str = "paper") -> np.ndarray:
    """Target poses ``(..., 4, 4)`` from positions ``(..., 3)`` (m) and angles ``(..., 3)`` (rad).

    ``"paper"``: ``Rx Ry Rz · transl(p)`` (position ``R·p``); ``"standard"``: ``transl(p) · R``.
    """
    _check_choice("convention", convention, CONVENTIONS)
    positions = np.asarray(positions, dtype=np.float64)
    if positions.shape[-1:] != (3,):
        raise ValueError(f"positions must have a last dimension of 3, got shape {positions.shape}")
    if not np.all(np.isfinite(positions)):
        raise ValueError("positions contain NaN or infinite values")
    rpy = np.asarray(rpy, dtype=np.float64)
    if not np.all(np.isfinite(rpy)):
        raise ValueError("orientation angles contain NaN or infinite values")
    R = rpy2r(rpy)
    shape = np.broadcast_shapes(positions.shape[:-1], R.shape[:-2])
    T = np.zeros(shape + (4, 4))
    T[..., :3, :3] = R
    if convention == "paper":
        T[..., :3, 3] = (R @ positions[..., None])[..., 0]
    else:
        T[..., :3, 3] = positions
    T[..., 3, 3] = 1.0
    return T


# --------------------------------------------------------------------------- maps
def _per_node(robot: DHRobot) -> DHRobot:
    """The same arms with a node axis inserted before the joints: batch ``(..., 1)``."""
    qlim = robot.qlim
    if qlim is not None and qlim.ndim > 2:
        qlim = qlim[..., None, :, :]
    return DHRobot(robot.d[..., None, :], robot.a[..., None, :], robot.alpha[..., None, :], qlim=qlim, tool=robot.tool)


def _map(arms, positions, rpy, convention, method, ik, chunk_elements, progress):
    """Shared driver: positions (N, 3) or (1, 3), rpy (3,) or (N, 3); returns (arms..., N) bool."""
    if not isinstance(arms, DHRobot):
        raise TypeError(f"arms must be a DHRobot, got {type(arms).__name__}")
    _check_choice("method", method, METHODS)
    _check_choice("convention", convention, CONVENTIONS)
    T = target_poses(positions, rpy, convention)  # (N, 4, 4)
    N = T.shape[0]
    batch = arms.batch_shape
    B = int(np.prod(batch, dtype=np.int64))
    _check_fits(B * N, f"a map of {B} arms x {N} nodes")
    flat = arms if batch == () else _flatten(arms)
    if method == "exact":
        require_spherical_wrist(arms)
    out = np.empty((max(B, 1), N), dtype=bool)
    per_chunk = max(1, chunk_elements // max(N, 1))
    for s in range(0, max(B, 1), per_chunk):
        sub = flat if batch == () else flat[s : s + per_chunk]
        node_arms = _per_node(sub)
        if method == "exact":
            if sub.qlim is None:
                # unlimited spherical wrist: every orientation is reachable at a reachable centre
                res = wrist_centre_reachable(node_arms, T[:, :3, 3])
            else:
                res = ikine_spherical_wrist(node_arms, T)[1].any(axis=-1)
        else:
            res = ikine_LM(node_arms, T, check_limits=sub.qlim is not None, **ik).success
        out[s : s + per_chunk] = np.broadcast_to(res, (out[s : s + per_chunk].shape[0], N))
        if progress is not None:
            progress(out[s : s + per_chunk].size)
    return out.reshape(batch + (N,))


def _flatten(arms: DHRobot) -> DHRobot:
    n = arms.n
    qlim = arms.qlim
    if qlim is not None and qlim.ndim > 2:
        qlim = np.broadcast_to(qlim, arms.batch_shape + (n, 2)).reshape(-1, n, 2)
    return DHRobot(arms.d.reshape(-1, n), arms.a.reshape(-1, n), arms.alpha.reshape(-1, n), qlim=qlim, tool=arms.tool)


def _check_nodes(name, nodes):
    nodes = np.asarray(nodes, dtype=np.float64)
    if nodes.ndim != 2 or nodes.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {nodes.shape}")
    if not np.all(np.isfinite(nodes)):
        raise ValueError(f"{name} contain NaN or infinite values")
    return nodes


def constant_orientation_map(
    arms: DHRobot,
    nodes,
    rpy=(0.0, 0.0, 0.0),
    method: str = "exact",
    convention: str = "paper",
    *,
    ik: dict | None = None,
    chunk_elements: int = 1 << 21,
    progress=None,
) -> np.ndarray:
    """Constant-orientation workspace ("R3"): which positions are reachable at orientation ``rpy``.

    Parameters
    ----------
    arms : DHRobot, one arm or a batch (batch shape ``(...)``)
    nodes : (N, 3) positions in metres, e.g. from :func:`cartesian_grid`
    rpy : (3,) angles (r1, r2, r3) in radians, ``R = Rx(r1)·Ry(r2)·Rz(r3)``
    method : ``"exact"`` (closed form, spherical-wrist family only) or ``"numerical"``
        (batched Levenberg–Marquardt from q0 = 0, any arm; ``ik`` passes its settings)
    convention : ``"paper"`` or ``"standard"`` (see the module docstring)

    Returns
    -------
    bool array ``(..., N)`` in node order. Joint limits are honoured when the arms carry them.
    """
    nodes = _check_nodes("nodes", nodes)
    rpy = _triple("rpy", rpy)
    return _map(arms, nodes, rpy, convention, method, ik or {}, chunk_elements, progress)


def orientation_map(
    arms: DHRobot,
    angle_nodes,
    point=(0.5, 0.5, 0.5),
    method: str = "exact",
    convention: str = "paper",
    *,
    ik: dict | None = None,
    chunk_elements: int = 1 << 21,
    progress=None,
) -> np.ndarray:
    """Orientation workspace ("SO3"): which orientations are reachable at the point ``point`` (m).

    ``angle_nodes`` (N, 3) are angles (r1, r2, r3) in radians, e.g. from :func:`angle_grid`.
    Under the paper convention the position tested is ``R·point``, so the map is really a test of
    positions on the sphere of radius ``|point|``. Other arguments as
    :func:`constant_orientation_map`; returns bool ``(..., N)``.
    """
    angle_nodes = _check_nodes("angle nodes", angle_nodes)
    point = _triple("point", point)
    return _map(arms, point[None, :], angle_nodes, convention, method, ik or {}, chunk_elements, progress)


# --------------------------------------------------------------------------- layout helpers
def map_to_volume(flat, shape) -> np.ndarray:
    """Flat map ``(..., nx*ny*nz)`` → volume ``(..., nz, ny, nx)``; ``shape`` is ``(nx, ny, nz)``."""
    flat = np.asarray(flat)
    nx, ny, nz = (int(s) for s in shape)
    if flat.shape[-1] != nx * ny * nz:
        raise ValueError(f"a map of {flat.shape[-1]} nodes does not fill a grid of shape {(nx, ny, nz)}")
    return flat.reshape(flat.shape[:-1] + (nz, ny, nx))


def volume_to_map(volume) -> np.ndarray:
    """Volume ``(..., nz, ny, nx)`` → flat map ``(..., nx*ny*nz)`` in node order."""
    volume = np.asarray(volume)
    if volume.ndim < 3:
        raise ValueError(f"a volume needs at least 3 dimensions (nz, ny, nx), got shape {volume.shape}")
    return volume.reshape(volume.shape[:-3] + (-1,))


def block_slice(block: int) -> slice:
    """Flat-index slice of the paper's output block ``block`` (0-based, 0..6) of the 21³ map.

    Block 4 (the paper's 1-based block 5, section 6.1) is 0-based indices 5292..6614, z in {0.2, 0.3, 0.4}.
    """
    if int(block) != block or not 0 <= block < N_BLOCKS:
        raise ValueError(f"block must be an integer in 0..{N_BLOCKS - 1}, got {block!r}")
    return slice(int(block) * BLOCK_NODES, (int(block) + 1) * BLOCK_NODES)
