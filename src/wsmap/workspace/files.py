"""Map files: one ``.npz`` per map with the map, its nodes, the grid, the orientation set (maps over
orientations) and the settings that made it (the arm, its source and limits, the method, the kind).

Arrays: ``map`` (N,) in node order — bool or float64 as the map's kind says
(:attr:`wsmap.workspace.kinds.MapKind.value_type`; bool for the paper's maps, reach and dexterous,
float64 for the reachability index and manipulability); ``nodes`` (N, 3) (m, or rad for an SO3 grid);
``orientations`` (K, 3, 3) when the map was made over a set of orientations; ``grid`` and
``settings`` as JSON strings. ``settings["kind"]``, where present, names a registered kind
(:mod:`wsmap.workspace.kinds`): its value type and scope are checked when a map is saved and loaded.
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np

from ..io import atomic_path
from .grids import cartesian_grid
from .kinds import get_kind
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import Any, ArrayLike, NDArray, PathLike

__all__ = ["save_map", "load_map", "MapFileError"]


class MapFileError(ValueError):
    """A file that is not a readable wsmap map."""


def _kind_mismatch(settings: dict, dtype, scope) -> str | None:
    """What is wrong with a map of ``dtype`` on a grid of ``scope`` for ``settings["kind"]``, or None
    (no kind recorded, or one that fits). An unknown kind is a ``ValueError`` naming the known ones."""
    name = settings.get("kind")
    if name is None:
        return None
    kind = get_kind(name)
    if np.dtype(dtype) != kind.dtype:
        return f"a {kind.name!r} map holds {kind.dtype} values, not {np.dtype(dtype)}"
    if scope != kind.scope:
        return f"a {kind.name!r} map lies on an {kind.scope} grid, not {scope!r}"
    return None


def save_map(path: PathLike, flat_map: ArrayLike, grid: dict, settings: dict, orientations: ArrayLike | None = None
            ) -> Path:
    """Write a map as ``.npz`` atomically (see the module notes); a bool map stays bool, any other is
    stored as float64 (finite values only). ``orientations`` (K, 3, 3): the set a map over
    orientations was made with. ``settings["kind"]``, if given, must be a registered kind whose value
    type and scope the map and grid have (``ValueError`` before anything is written). Returns ``path``."""
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
    if orientations is not None:
        extra["orientations"] = np.asarray(orientations, dtype=np.float64).reshape(-1, 3, 3)
    with atomic_path(path, suffix=".npz") as tmp:
        with open(tmp, "wb") as f:
            np.savez_compressed(f, map=flat_map, nodes=nodes, grid=json.dumps(grid), settings=json.dumps(settings),
                                **extra)
    return Path(path)


def load_map(path: PathLike) -> tuple[NDArray[Any], NDArray[np.float64], dict[str, Any], dict[str, Any]]:
    """Read a map written by :func:`save_map`: ``(map, nodes, grid, settings)``; a map over
    orientations has its set in ``settings["orientations"]`` ((K, 3, 3) array).

    A missing file is ``FileNotFoundError``; anything else unreadable is :class:`MapFileError`, as is
    a file whose ``settings["kind"]`` is not a registered kind (:mod:`wsmap.workspace.kinds`) or whose
    map's value type or grid's scope is not its kind's.
    """
    path = Path(path)
    if not path.is_file():
        if path.exists():
            raise MapFileError(f"{path} is not a file")
        raise FileNotFoundError(f"no map file at {path}")
    try:
        with np.load(path, allow_pickle=False) as z:
            flat, nodes = z["map"], z["nodes"]
            grid, settings = json.loads(str(z["grid"])), json.loads(str(z["settings"]))
            if "orientations" in z.files:
                settings["orientations"] = z["orientations"]
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError) as e:
        raise MapFileError(f"{path} is not a readable wsmap map file ({type(e).__name__}: {e})") from None
    if flat.dtype not in (np.dtype(bool), np.dtype(np.float64)) or flat.ndim != 1 or nodes.shape != (flat.shape[0], 3):
        raise MapFileError(f"{path} is not a wsmap map file: map {flat.shape} {flat.dtype}, nodes {nodes.shape}")
    try:
        problem = _kind_mismatch(settings, flat.dtype, grid.get("scope"))
    except ValueError as e:
        raise MapFileError(f"{path}: {e} (a kind's module must be imported, so registered, before its maps "
                           "load)") from None
    if problem:
        raise MapFileError(f"{path} is not a consistent wsmap map file: {problem}")
    return flat, nodes, grid, settings
