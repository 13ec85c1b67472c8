"""Map files: one `.npz` per map with the map, its nodes, the grid, the orientation set (maps over
orientations) and the settings that made it (the arm, its source and limits, the method, the kind).

Arrays: `map` (N,) in node order — bool or float64 as the map's kind says
(`wsmap.workspace.kinds.MapKind.value_type`; bool for the paper's maps, reach and dexterous,
float64 for the reachability index and manipulability); `nodes` (N, 3) (m, or rad for an SO3 grid);
`orientations` (K, 3, 3) when the map was made over a set of orientations; `status` (N,) int8
when the map carries each node's answer (`wsmap.workspace.status`: 0 reached, 1 certified
unreachable, 2 not found; reached exactly where the map is True or above 0); `pose_status`
(N, K) int8, a map over a set of orientations' answer at each node and orientation (with
`status` and `orientations`; the node's answer is its kind's `MapKind.over` of them and the
map its kind's `MapKind.from_bits` of the reached ones); `grid` and `settings` as JSON
strings. `settings["kind"]`, where present, names a registered kind (`wsmap.workspace.kinds`):
its value type and scope are checked when a map is saved and loaded. The members are optional
and none is versioned: a file without `status` (written before it existed, or by a network's
prediction) reads as reached where the map is and not found elsewhere (`load_status`), and a
file without an optional member is written byte for byte as before it existed.
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np

from ..io import atomic_path
from ..safe_load import check_npz, loads_json
from .grids import cartesian_grid, grid_counts
from .kinds import get_kind
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import Any, ArrayLike, NDArray, PathLike

__all__ = ["save_map", "load_map", "load_status", "MapFileError"]


class MapFileError(ValueError):
    """A file that is not a readable wsmap map."""


def _kind_mismatch(settings: dict, dtype, scope) -> str | None:
    """What is wrong with a map of `dtype` on a grid of `scope` for `settings["kind"]`, or None
    (no kind recorded, or one that fits). An unknown kind is a `ValueError` naming the known ones."""
    name = settings.get("kind")
    if name is None:
        return None
    kind = get_kind(name)
    if np.dtype(dtype) != kind.dtype:
        return f"a {kind.name!r} map holds {kind.dtype} values, not {np.dtype(dtype)}"
    if scope != kind.scope:
        return f"a {kind.name!r} map lies on an {kind.scope} grid, not {scope!r}"
    return None


def save_map(path: PathLike, flat_map: ArrayLike, grid: dict, settings: dict, orientations: ArrayLike | None = None,
             status: ArrayLike | None = None, pose_status: ArrayLike | None = None) -> Path:
    """Write a map as `.npz` atomically (see the module notes); a bool map stays bool, any other is
    stored as float64 (finite values only). `orientations` (K, 3, 3): the set a map over
    orientations was made with. `status` (N,) int codes of `wsmap.workspace.status` (`REACHED`
    exactly where the map is True, or above 0). `pose_status` (N, K) int codes at each node and
    orientation of a map over `orientations` (with `status`, and `settings["kind"]` a kind over
    a set of orientations: `status` must be its `MapKind.over` of them, the map its
    `MapKind.from_bits` of the reached ones). `settings["kind"]`, if given, must be a
    registered kind whose value type and scope the map and grid have. Every disagreement is a
    one-line `ValueError` before anything is written. Returns `path`."""
    nodes = cartesian_grid(grid["lo"], grid["hi"], grid["step"])
    flat_map = np.asarray(flat_map)
    if flat_map.dtype != bool:
        flat_map = flat_map.astype(np.float64)
        if not np.all(np.isfinite(flat_map)):
            raise ValueError("a map must hold finite values")
    if flat_map.shape != (len(nodes),):
        raise ValueError(f"a map of shape {flat_map.shape} does not fit a grid of {len(nodes)} nodes")
    problem = _kind_mismatch(settings, flat_map.dtype, grid.get("scope"))
    if problem:
        raise ValueError(problem)
    extra = {}
    if status is not None:
        extra["status"] = _check_status(flat_map, status)
    if orientations is not None:
        extra["orientations"] = np.asarray(orientations, dtype=np.float64).reshape(-1, 3, 3)
    if pose_status is not None:  # last: a file without it keeps its bytes
        extra["pose_status"] = _check_pose_status(flat_map, extra.get("status"), pose_status,
                                                  extra.get("orientations"), settings.get("kind"))
    with atomic_path(path, suffix=".npz") as tmp:
        with open(tmp, "wb") as f:
            np.savez_compressed(f, map=flat_map, nodes=nodes, grid=json.dumps(grid), settings=json.dumps(settings),
                                **extra)
    return Path(path)


def load_map(path: PathLike) -> tuple[NDArray[Any], NDArray[np.float64], dict[str, Any], dict[str, Any]]:
    """Read a map written by `save_map`: `(map, nodes, grid, settings)`; a map over
    orientations has its set in `settings["orientations"]` ((K, 3, 3) array), a map with each
    node's answer its int8 codes in `settings["status"]` ((N,) array; see `load_status`), and
    one with the answer at each node and orientation in `settings["pose_status"]` ((N, K)).

    A missing file is `FileNotFoundError`; anything else unreadable is `MapFileError`, as is
    a file whose `settings["kind"]` is not a registered kind (`wsmap.workspace.kinds`) or whose
    map's value type or grid's scope is not its kind's, and one that disagrees with itself: a grid
    that is not a valid grid or does not have the map's number of nodes, nodes that are not the
    grid's, a float map with NaN or infinite values or values outside its kind's range (an index
    outside [0, 1], a negative manipulability), or a status that is not the map's (a code outside
    0-2, a shape other than the map's, reached where the map is not or not where it is, a node's
    answer other than its orientations', or orientations' answers that do not give the map).
    """
    path = Path(path)
    if not path.is_file():
        if path.exists():
            raise MapFileError(f"{path} is not a file")
        raise FileNotFoundError(f"no map file at {path}")
    try:
        check_npz(path, text=("grid", "settings"))  # the headers first: numbers only, as many bytes as declared
        z = np.load(path, allow_pickle=False)
        if not isinstance(z, np.lib.npyio.NpzFile):
            raise MapFileError(f"{path} is a single numpy array (.npy), not a wsmap map file (.npz, written by "
                               "save_map)")
        with z:
            flat, nodes = z["map"], z["nodes"]
            grid, settings = loads_json(str(z["grid"])), loads_json(str(z["settings"]))  # bounded nesting
            for name, entry in (("grid", grid), ("settings", settings)):
                if not isinstance(entry, dict):
                    raise MapFileError(f"{path} is not a wsmap map file: its {name} is a JSON "
                                       f"{type(entry).__name__}, not an object")
            if "orientations" in z.files:
                settings["orientations"] = z["orientations"]
            if "status" in z.files:
                settings["status"] = z["status"]
            if "pose_status" in z.files:
                settings["pose_status"] = z["pose_status"]
    except (OSError, ValueError, KeyError, TypeError, zipfile.BadZipFile, EOFError) as e:
        if isinstance(e, MapFileError):
            raise
        raise MapFileError(f"{path} is not a readable wsmap map file ({type(e).__name__}: {e})") from None
    if flat.dtype not in (np.dtype(bool), np.dtype(np.float64)) or flat.ndim != 1 or nodes.shape != (flat.shape[0], 3):
        raise MapFileError(f"{path} is not a wsmap map file: map {flat.shape} {flat.dtype}, nodes {nodes.shape}")
    _check_grid(path, flat, nodes, grid)
    try:
        problem = _kind_mismatch(settings, flat.dtype, grid.get("scope"))
    except ValueError as e:
        raise MapFileError(f"{path}: {e} (a kind's module must be imported, so registered, before its maps "
                           "load)") from None
    if problem:
        raise MapFileError(f"{path} is not a consistent wsmap map file: {problem}")
    if flat.dtype != bool:
        _check_values(path, flat, settings.get("kind"))
    _check_stored_status(path, flat, settings)
    return flat, nodes, grid, settings


def _check_stored_status(path, flat, settings) -> None:
    """The statuses read back (in `settings["status"]` and `settings["pose_status"]`, where
    stored), as int8 codes agreeing with the map; a `MapFileError` naming the disagreement."""
    try:
        if "status" in settings:
            settings["status"] = _check_status(flat, settings["status"])
        if "pose_status" in settings:
            settings["pose_status"] = _check_pose_status(flat, settings.get("status"), settings["pose_status"],
                                                         settings.get("orientations"), settings.get("kind"))
    except ValueError as e:
        raise MapFileError(f"{path} is not a consistent wsmap map file: {e}") from None


def load_status(path: PathLike, *, per_pose: bool = False) -> NDArray[np.int8]:
    """The int8 status `(N,)` of a map file (`wsmap.workspace.status`): the stored one, or, for a
    file written without it, `REACHED` where the map is True (a float map: above 0) and
    `NOT_FOUND` elsewhere (no certificate was recorded). `per_pose`: the status `(N, K)` at each
    node and orientation of a map over a set of orientations instead; a file that does not store
    it (the orientations' answers cannot be told from the map) is a `MapFileError`."""
    from .status import NOT_FOUND, REACHED

    flat, _, _, settings = load_map(path)
    if per_pose:
        if settings.get("pose_status") is None:
            raise MapFileError(f"{path} stores no status per node and orientation (pose_status): it was written "
                               "without one, or is not a map over a set of orientations")
        return settings["pose_status"]
    status = settings.get("status")
    if status is None:
        return np.where(_reached(flat), REACHED, NOT_FOUND).astype(np.int8)
    return status


def _reached(flat) -> np.ndarray:
    """Where a map `flat` says its node is reached: True, or a value above 0."""
    return flat if flat.dtype == bool else flat > 0


def _check_codes(st, shape, what: str) -> np.ndarray:
    """`st` as int8 codes of `shape` (0, 1 or 2), or a one-line `ValueError` naming `what`."""
    st = np.asarray(st)
    if st.shape != tuple(shape) or not np.issubdtype(st.dtype, np.integer):
        raise ValueError(f"{what} must be integer codes of shape {tuple(shape)}, got {st.dtype} {st.shape}")
    if st.size and (st.min() < 0 or st.max() > 2):
        raise ValueError(f"{what} codes are 0 (reached), 1 (certified unreachable) or 2 (not found), got "
                         f"{int(st.min())}..{int(st.max())}")
    return st.astype(np.int8)


def _check_status(flat, status) -> np.ndarray:
    """`status` as int8 `(N,)` codes agreeing with the map `flat`: `REACHED` (0) exactly where it
    is True (a float map: above 0), 1 or 2 elsewhere (a one-line `ValueError` naming what differs)."""
    from .status import REACHED

    st = _check_codes(status, flat.shape, "a status")
    reached = _reached(flat)
    if np.any((st == REACHED) != reached):
        bad = int(np.argmax((st == REACHED) != reached))
        value = bool(flat[bad]) if flat.dtype == bool else f"{flat[bad]:g}"
        raise ValueError(f"status and map disagree at node {bad} (status {int(st[bad])}, map {value})")
    return st


def _check_pose_status(flat, status, pose_status, orientations, kind_name) -> np.ndarray:
    """`pose_status` as int8 `(N, K)` codes of a map over `orientations` (K, 3, 3) of the kind
    `kind_name` with node status `status` (N,) (already checked): the kind's `over` of them is
    `status`, its `from_bits` of the reached ones the map (a one-line `ValueError` otherwise)."""
    from .status import REACHED

    if status is None or orientations is None:
        raise ValueError("a status per node and orientation (pose_status) comes with the nodes' status and the "
                         "orientations")
    kind = get_kind(kind_name) if kind_name is not None else None
    if kind is None or kind.over is None:
        raise ValueError(f"a status per node and orientation belongs to a kind over a set of orientations, not to "
                         f"{'a map without a kind' if kind is None else repr(kind.name)}")
    st = _check_codes(pose_status, (flat.shape[0], len(orientations)), "a status per node and orientation")
    node = np.asarray(kind.over(st))
    if np.any(node != status):
        bad = int(np.argmax(node != status))
        raise ValueError(f"the status of node {bad} ({int(status[bad])}) is not its orientations' ({int(node[bad])})")
    values = np.asarray(kind.from_bits(st == REACHED), dtype=flat.dtype)
    if np.any(values != flat):
        bad = int(np.argmax(values != flat))
        raise ValueError(f"the map at node {bad} ({flat[bad]}) is not what its orientations' status gives "
                         f"({values[bad]})")
    return st


def _check_values(path, flat, kind_name) -> None:
    """The values of a float map read back: finite, inside the range of its kind `kind_name`
    (None: no kind recorded) (a `MapFileError` naming the disagreement)."""
    if not np.all(np.isfinite(flat)):
        raise MapFileError(f"{path} is not a consistent wsmap map file: its map holds "
                           f"{int((~np.isfinite(flat)).sum())} NaN or infinite values")
    if kind_name is None:
        return
    kind = get_kind(kind_name)
    lo, hi = kind.value_range
    if (lo is not None and flat.min(initial=lo) < lo) or (hi is not None and flat.max(initial=hi) > hi):
        raise MapFileError(f"{path} is not a consistent wsmap map file: a {kind.name!r} map lies in "
                           f"[{'' if lo is None else lo}, {'' if hi is None else hi}], this one in "
                           f"[{flat.min():g}, {flat.max():g}]")


def _check_grid(path, flat, nodes, grid) -> None:
    """The grid record of a map file read back: a grid (`wsmap.workspace.grid_spec`) of as many
    nodes as the map, whose nodes are the file's (a `MapFileError` naming the disagreement)."""
    what = f"{path} is not a consistent wsmap map file"
    missing = [k for k in ("scope", "lo", "hi", "step", "shape") if k not in grid]
    if missing:
        raise MapFileError(f"{what}: its grid lacks {', '.join(missing)}")
    try:
        counts = grid_counts(grid["lo"], grid["hi"], grid["step"])
    except (TypeError, ValueError) as e:
        raise MapFileError(f"{what}: its grid is not a grid ({e})") from None
    if not isinstance(grid["shape"], list) or [int(c) for c in counts] != grid["shape"]:
        raise MapFileError(f"{what}: its grid's shape {grid['shape']!r} is not the {list(counts)} of its lo, hi, step")
    if int(np.prod(counts)) != flat.shape[0]:
        raise MapFileError(f"{what}: its grid has {int(np.prod(counts))} nodes, its map {flat.shape[0]}")
    expected = cartesian_grid(grid["lo"], grid["hi"], grid["step"])
    scale = max(1.0, float(np.abs(expected).max(initial=0.0)))
    if not np.allclose(nodes, expected, rtol=0.0, atol=1e-9 * scale):
        bad = int(np.argmax(np.any(~np.isclose(nodes, expected, rtol=0.0, atol=1e-9 * scale), axis=1)))
        raise MapFileError(f"{what}: its nodes are not its grid's (node {bad} is {nodes[bad].tolist()}, the grid's "
                           f"{expected[bad].tolist()})")
