"""Reachability maps in the HDF5 layout of Reuleaux (ROS `map_creator`), for base placement and
visualisation in the ROS world.

The layout, as `map_creator/src/hdf5_dataset.cpp` (`Hdf5Dataset::saveReachMapsToDataset`) of
`ros-industrial-consortium/reuleaux <https://github.com/ros-industrial-consortium/reuleaux>`_ writes
it and `load_reachability_map` / `create_inverse_reachability_map` read it:

* `/Spheres/sphere_dataset`: float64 `(S, 4)`, one row per *reachable* sphere (voxel centre):
  `x, y, z` (m, robot base frame; float32 values widened, bit for bit the poses' centres, as
  Reuleaux's inverse-map loader pairs poses with spheres by exact equality) and the reachability index `D = 100·R/N` (percent: `R` of
  the `N` poses tested at the sphere are reachable). Spheres with no reachable pose are absent.
  Its attribute `Resolution`: float32 `(1,)`, the distance between sphere centres (m).
* `/Poses/poses_dataset`: float32 `(M, 10)`, one row per reachable pose: the sphere centre
  `x, y, z`, then the pose as position `x, y, z` and quaternion `qx, qy, qz, qw` (scalar last,
  `geometry_msgs/Pose` order). Chunked, `maxshape (None, 10)`, chunks of `ceil(M/2)` rows.

What wsmap writes: the reachability index over a set of orientations (`reachability_index`
with `return_bits`): a node is a sphere, each reachable orientation `R_k` at it a pose
`T = transl(p)·R_k`. Reuleaux itself puts its poses on a small sphere of radius `resolution`
around the centre, each orientation pointing at the centre; wsmap's pose positions are the centre
itself (the pose IK was solved for), so a pose's position equals its sphere's. The index is
`100·mean` of the node's bits, in float64 (Reuleaux computes it in float32 before storing it as
float64; the two agree to ~1e-5 %). Other map kinds: `dexterous` exports the same spheres and
poses (its nodes are those at 100 %); `constant` exports its one orientation (`K = 1`, standard
convention); `reach`, `orientation` and `manipulability` are not reachability over a set of
orientations and do not export (`wsmap.workspace.kinds.MapKind.poses`). `docs/reuleaux.md`.

Needs h5py (`pip install 'wsmap[h5]'`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._optional import require
from ..io import atomic_path, check_output_path
from .grids import cartesian_grid, check_fits, grid_axes
from .orientations import check_rotations

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike, PathLike

__all__ = ["ReuleauxMap", "save_reuleaux", "load_reuleaux", "REULEAUX_SPHERES", "REULEAUX_POSES"]

#: The datasets' paths in the file (groups `/Spheres` and `/Poses`).
REULEAUX_SPHERES = "/Spheres/sphere_dataset"
REULEAUX_POSES = "/Poses/poses_dataset"
_RESOLUTION = "Resolution"
#: How far from 1 a pose's quaternion norm may be (float32 rows hold unit quaternions to about 1e-7).
_QUATERNION_TOL = 1e-3


class ReuleauxFileError(ValueError):
    """A file that is not a readable Reuleaux reachability map."""


def _h5py(why: str):
    return require("h5py", why=why)


def _quaternions(R: np.ndarray) -> np.ndarray:
    """Unit quaternions `(K, 4)` `(qx, qy, qz, qw)` of rotations `(K, 3, 3)`, `qw >= 0`."""
    from scipy.spatial.transform import Rotation

    q = Rotation.from_matrix(R).as_quat()  # scalar last, as geometry_msgs
    return np.where(q[:, 3:4] < 0, -q, q)


@dataclass(frozen=True)
class ReuleauxMap:
    """The content of a Reuleaux reachability file, as arrays (float64; the file stores poses in float32).

    Attributes:
        spheres: `(S, 3)` reachable sphere centres, m, robot base frame.
        ri: `(S,)` their reachability index in percent, `100·R/N`.
        pose_spheres: `(M, 3)` the sphere centre of each reachable pose, m.
        poses: `(M, 7)` the poses, position (m) and quaternion `qx, qy, qz, qw` (scalar last).
        resolution: the distance between sphere centres, m.
    """

    spheres: np.ndarray
    ri: np.ndarray
    pose_spheres: np.ndarray
    poses: np.ndarray
    resolution: float

    def __post_init__(self):
        for name, cols in (("spheres", 3), ("pose_spheres", 3), ("poses", 7)):
            a = np.asarray(getattr(self, name), dtype=np.float64)
            if a.ndim != 2 or a.shape[1] != cols:
                raise ValueError(f"{name} must have shape (n, {cols}), got {a.shape}")
            if not np.all(np.isfinite(a)):
                raise ValueError(f"{name} contain NaN or infinite values")
            object.__setattr__(self, name, a)
        ri = np.asarray(self.ri, dtype=np.float64)
        if ri.shape != (len(self.spheres),):
            raise ValueError(f"ri must have shape ({len(self.spheres)},), one per sphere, got {ri.shape}")
        if not np.all((ri >= 0) & (ri <= 100)):
            raise ValueError("ri is a percentage: every value must be in [0, 100]")
        object.__setattr__(self, "ri", ri)
        norm = np.linalg.norm(self.poses[:, 3:], axis=1)
        bad = np.flatnonzero(np.abs(norm - 1.0) > _QUATERNION_TOL)
        if bad.size:  # float32 rounding leaves about 1e-7; a zero quaternion is no rotation
            raise ValueError(f"poses hold {bad.size} quaternions that are not unit (pose {int(bad[0])} has norm "
                             f"{norm[bad[0]]:g}): not rotations")
        if len(self.pose_spheres) != len(self.poses):
            raise ValueError(f"pose_spheres ({len(self.pose_spheres)}) and poses ({len(self.poses)}) differ in length")
        res = float(self.resolution)
        if not (np.isfinite(res) and res > 0):
            raise ValueError(f"resolution must be a positive number of metres, got {self.resolution!r}")
        object.__setattr__(self, "resolution", res)

    # ------------------------------------------------------------------ from and to wsmap maps
    @classmethod
    def from_map(cls, grid: Mapping, bits: ArrayLike, orientations: ArrayLike) -> "ReuleauxMap":
        """The Reuleaux map of a reachability index: `grid` an R3 grid spec
        (`wsmap.workspace.grid_spec`, one step on every axis: Reuleaux has one resolution),
        `bits` bool `(N, K)` in its node order (x fastest), whether orientation `k` of
        `orientations` `(K, 3, 3)` is reachable at node `i` (`T = transl(p_i)·R_k`)."""
        nodes = _grid_nodes(grid)
        R = check_rotations("orientations", orientations)
        bits = np.asarray(bits)
        if bits.dtype != bool or bits.shape != (len(nodes), len(R)):
            raise ValueError(f"bits must be bool of shape ({len(nodes)}, {len(R)}) (nodes x orientations), "
                             f"got {bits.dtype} {bits.shape}")
        step = np.asarray(grid["step"], dtype=np.float64)
        # Reuleaux pairs poses with spheres by exact equality of the centres, the poses' read as
        # float32: the spheres must be those float32 values (widened), bit for bit
        nodes = _as_float32(nodes)
        reached = bits.any(axis=1)
        node, k = np.nonzero(bits)  # node-major, orientations in their order: the file's row order
        q = _quaternions(R)
        poses = np.concatenate([nodes[node], q[k]], axis=1)
        return cls(spheres=nodes[reached], ri=100.0 * bits[reached].mean(axis=1), pose_spheres=nodes[node],
                   poses=poses, resolution=float(step[0]))

    def orientations(self, tol: float = 1e-5) -> np.ndarray:
        """The distinct orientations `(K, 3, 3)` of the poses (quaternions equal up to sign within
        `tol`, the float32 storage), in the order they first appear."""
        from scipy.spatial.transform import Rotation

        return Rotation.from_quat(self._distinct(tol)).as_matrix()

    def _distinct(self, tol):
        q = self.poses[:, 3:]
        q = q / np.linalg.norm(q, axis=1, keepdims=True)
        keep: list[np.ndarray] = []
        # candidates after rounding (few), then a greedy merge by |q·q'|: q and -q are one rotation
        _, first = np.unique(np.round(np.where(q[:, 3:4] < 0, -q, q), 4), axis=0, return_index=True)
        for i in np.sort(first):
            if not keep or np.max(np.abs(np.asarray(keep) @ q[i])) < 1.0 - tol:
                keep.append(q[i])
        return np.asarray(keep).reshape(-1, 4)

    def to_map(self, grid: Mapping | None = None, orientations: ArrayLike | None = None,
               tol: float = 1e-5) -> tuple[np.ndarray, dict, np.ndarray, np.ndarray]:
        """A wsmap map of the file: `(index (N,), grid, bits (N, K), orientations (K, 3, 3))`.

        `index` is the file's `ri / 100` at its spheres and 0 at the other nodes (float64 in
        [0, 1], `wsmap.workspace.reachability_index`'s values); `bits[i, k]`: a pose at node
        `i` has orientation `k`. `grid` (default: the spheres' bounding box at the file's
        resolution) must hold every sphere on a node; `orientations` (default:
        `orientations`) must hold every pose's orientation (within `tol`)."""
        from scipy.spatial.transform import Rotation

        from .maps import grid_spec

        if grid is None:
            if not len(self.spheres):
                raise ValueError("the map has no spheres: give the grid")
            # the float32 centres' shortest decimals (-0.6, not -0.600000024), as for the resolution
            lo, hi = ([float(str(np.float32(v))) for v in f(axis=0)] for f in (self.spheres.min, self.spheres.max))
            grid = grid_spec("R3", lo, hi, self.resolution)
        nodes = _grid_nodes(grid)
        R = self.orientations(tol) if orientations is None else check_rotations("orientations", orientations)
        index = np.zeros(len(nodes))
        index[_node_index(grid, self.spheres, "a sphere")] = self.ri / 100.0
        bits = np.zeros((len(nodes), len(R)), dtype=bool)
        if len(self.poses):
            q = self.poses[:, 3:] / np.linalg.norm(self.poses[:, 3:], axis=1, keepdims=True)
            dots = np.abs(q @ Rotation.from_matrix(R).as_quat().T)  # (M, K)
            k = dots.argmax(axis=1)
            if np.any(dots[np.arange(len(k)), k] < 1.0 - tol):
                raise ValueError("a pose's orientation is not one of the orientations")
            bits[_node_index(grid, self.pose_spheres, "a pose's sphere"), k] = True
        return index, dict(grid), bits, R

    # ------------------------------------------------------------------ the file
    def save(self, path: PathLike) -> Path:
        """Write the map to `path` (`.h5`) in Reuleaux's layout (module docstring), atomically."""
        path = check_output_path(path, "Reuleaux map")
        if path.suffix != ".h5":
            raise ValueError(f"a Reuleaux map is an .h5 file (its loader insists), got {str(path)!r}")
        h5py = _h5py("a Reuleaux map (.h5)")
        rows = np.concatenate([self.pose_spheres, self.poses], axis=1).astype(np.float32)
        # centres as the float32 pose rows hold them, so Reuleaux's exact pairing finds every pose
        spheres = np.concatenate([_as_float32(self.spheres), self.ri[:, None]], axis=1)
        with atomic_path(path) as tmp:
            with h5py.File(tmp, "w") as f:
                poses = f.create_group("Poses")
                chunk = max(1, -(-len(rows) // 2))  # the writer's two chunks of ceil(M/2) rows
                poses.create_dataset("poses_dataset", data=rows, dtype=np.float32, maxshape=(None, 10),
                                     chunks=(chunk, 10))
                ds = f.create_group("Spheres").create_dataset("sphere_dataset", data=spheres, dtype=np.float64)
                ds.attrs.create(_RESOLUTION, np.array([self.resolution], dtype=np.float32), dtype=np.float32)
        return path

    @classmethod
    def load(cls, path: PathLike) -> "ReuleauxMap":
        """Read a Reuleaux reachability file (`ReuleauxFileError` naming what is missing)."""
        p = Path(path)
        if not p.is_file():
            raise ReuleauxFileError(f"{path}: no such file")
        h5py = _h5py("a Reuleaux map (.h5)")
        try:
            with h5py.File(p, "r") as f:
                for name in (REULEAUX_SPHERES, REULEAUX_POSES):
                    if name not in f:
                        raise ReuleauxFileError(f"{path}: not a Reuleaux reachability map (no {name})")
                spheres = _dataset(path, f[REULEAUX_SPHERES], 4)
                rows = _dataset(path, f[REULEAUX_POSES], 10)
                attr = f[REULEAUX_SPHERES].attrs.get(_RESOLUTION)
        except OSError as e:
            raise ReuleauxFileError(f"{path}: not an HDF5 file ({e})") from None
        except ReuleauxFileError:
            raise
        except (ValueError, TypeError) as e:  # an attribute h5py cannot read, a dataset of another kind
            raise ReuleauxFileError(f"{path}: not a Reuleaux reachability map ({type(e).__name__}: "
                                    f"{str(e)[:200]})") from None
        if attr is None:
            raise ReuleauxFileError(f"{path}: {REULEAUX_SPHERES} has no {_RESOLUTION} attribute")
        if spheres.ndim != 2 or spheres.shape[1] != 4 or rows.ndim != 2 or rows.shape[1] != 10:
            raise ReuleauxFileError(f"{path}: sphere_dataset must be (S, 4) and poses_dataset (M, 10), got "
                                    f"{spheres.shape} and {rows.shape}")
        try:
            m = cls(spheres=spheres[:, :3], ri=spheres[:, 3], pose_spheres=rows[:, :3], poses=rows[:, 3:],
                    # the float32 attribute's shortest decimal (0.08, not 0.0799999982): the grid's step
                    resolution=float(str(np.float32(np.ravel(attr)[0]))))
        except ValueError as e:
            raise ReuleauxFileError(f"{path}: {e}") from None
        _check_pose_spheres(path, m.spheres, m.pose_spheres)
        return m


def _dataset(path, ds, cols: int) -> np.ndarray:
    """The dataset `ds` as float64 `(rows, cols)`, its kind and size checked before it is read: a
    few kB of HDF5 can declare gigabytes (unwritten chunks read as zeros), or hold strings."""
    if not hasattr(ds, "dtype") or not hasattr(ds, "shape"):
        raise ReuleauxFileError(f"{path}: {ds.name} is not a dataset")
    if ds.dtype.kind not in "fiu":
        what = {"S": "byte strings", "U": "strings", "O": "strings or objects", "V": "compound records",
                "b": "booleans", "c": "complex numbers"}.get(ds.dtype.kind, str(ds.dtype)[:40])
        raise ReuleauxFileError(f"{path}: {ds.name} holds {what}, not numbers")
    if len(ds.shape) != 2 or ds.shape[1] != cols:
        raise ReuleauxFileError(f"{path}: {ds.name} must be (n, {cols}), got {ds.shape}")
    try:
        check_fits(8 * int(np.prod(ds.shape, dtype=np.float64)), f"{ds.name} of shape {ds.shape}",
                   "not a Reuleaux map this machine can read")
    except MemoryError as e:
        raise ReuleauxFileError(f"{path}: {e}") from None
    return np.asarray(ds[()], dtype=np.float64)


def _as_float32(points: np.ndarray) -> np.ndarray:
    """`points` rounded to float32 and widened back to float64 (the values a float32 row holds)."""
    return np.asarray(points, dtype=np.float32).astype(np.float64)


def _row_keys(points: np.ndarray) -> np.ndarray:
    """One opaque key per row of `points` `(n, 3)`: equal keys for rows equal in float32."""
    a = np.ascontiguousarray(np.asarray(points, dtype=np.float32) + np.float32(0))  # -0.0 -> 0.0
    return a.view(np.dtype((np.void, a.dtype.itemsize * 3))).ravel()


def _check_pose_spheres(path, spheres: np.ndarray, pose_spheres: np.ndarray) -> None:
    """`ReuleauxFileError` unless every pose's sphere centre is a sphere of the file (compared
    in float32, the precision of the pose rows: Reuleaux's loader pairs them by equality)."""
    missing = ~np.isin(_row_keys(pose_spheres), _row_keys(spheres))
    if np.any(missing):
        first = ", ".join(str(np.float32(v)) for v in pose_spheres[np.argmax(missing)])
        raise ReuleauxFileError(f"{path}: {int(missing.sum())} poses lie at no sphere of the file "
                                f"(the first at [{first}] m)")


def _grid_nodes(grid: Mapping) -> np.ndarray:
    if grid.get("scope", "R3") != "R3":
        raise ValueError(f"a Reuleaux map is over positions (an R3 grid), not {grid.get('scope')!r}")
    step = np.broadcast_to(np.asarray(grid["step"], dtype=np.float64), (3,))
    if not np.allclose(step, step[0], rtol=1e-9, atol=0):
        raise ValueError(f"a Reuleaux map has one resolution: the grid's steps differ ({step.tolist()} m)")
    return cartesian_grid(grid["lo"], grid["hi"], grid["step"])


def _node_index(grid: Mapping, points: np.ndarray, what: str) -> np.ndarray:
    """Flat node indices (x fastest) of `points` (n, 3) on `grid`; `ValueError` off the grid."""
    axes = grid_axes(grid["lo"], grid["hi"], grid["step"])
    lo = np.array([a[0] for a in axes])
    step = np.broadcast_to(np.asarray(grid["step"], dtype=np.float64), (3,))
    shape = np.array([len(a) for a in axes])
    ijk = np.rint((points - lo) / step).astype(np.int64)
    # float32 pose rows: within 1e-4 of a step (0.01 mm at 10 cm) is on the node
    off = np.abs(points - (lo + ijk * step)) > 1e-4 * step + 1e-6
    if np.any(off) or np.any(ijk < 0) or np.any(ijk >= shape):
        raise ValueError(f"{what} is not on a node of the grid")
    return ijk[:, 0] + shape[0] * (ijk[:, 1] + shape[1] * ijk[:, 2])


def save_reuleaux(path: PathLike, grid: Mapping, bits: ArrayLike, orientations: ArrayLike) -> Path:
    """Write a reachability index as a Reuleaux reachability map (`.h5`; module docstring).

    Parameters
    ----------
    path : the output file, `.h5`; written atomically (a temporary file renamed into place).
    grid : the R3 grid spec of the map (`wsmap.workspace.grid_spec`), one step on every axis (m).
    bits : bool `(N, K)`, orientation `k` reachable at node `i` (`T = transl(p_i)·R_k`):
        `reachability_index(..., return_bits=True)[1]`.
    orientations : `(K, 3, 3)` the rotations of the columns of `bits`.

    Returns
    -------
    Path
        The path written.

    Raises
    ------
    ValueError
        Before anything is written, for a bad grid, shapes or path.
    wsmap._optional.MissingDependency
        Without h5py.
    """
    check_output_path(path, "Reuleaux map")
    _h5py("a Reuleaux map (.h5)")
    return ReuleauxMap.from_map(grid, bits, orientations).save(path)


def load_reuleaux(path: PathLike) -> ReuleauxMap:
    """Read a Reuleaux reachability map (any writer's: Reuleaux's `map_creator` or
    `save_reuleaux`); `ReuleauxMap.to_map` turns it into a wsmap map."""
    return ReuleauxMap.load(path)
