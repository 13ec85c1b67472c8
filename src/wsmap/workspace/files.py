"""Map files: one ``.npz`` per map with the map, its nodes, the grid and the settings that made it."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np

from ..io import atomic_path
from .grids import cartesian_grid

__all__ = ["save_map", "load_map", "MapFileError"]


class MapFileError(ValueError):
    """A file that is not a readable wsmap map."""


def save_map(path, flat_map, grid: dict, settings: dict) -> Path:
    """Write a map as ``.npz`` atomically: ``map`` (bool, node order), ``nodes`` (float64 ``(N, 3)``),
    ``grid`` and ``settings`` (JSON strings). Returns ``path``."""
    nodes = cartesian_grid(grid["lo"], grid["hi"], grid["step"])
    flat_map = np.asarray(flat_map, dtype=bool)
    if flat_map.shape != (len(nodes),):
        raise ValueError(f"a map of shape {flat_map.shape} does not fit a grid of {len(nodes)} nodes")
    with atomic_path(path, suffix=".npz") as tmp:
        with open(tmp, "wb") as f:
            np.savez_compressed(f, map=flat_map, nodes=nodes, grid=json.dumps(grid), settings=json.dumps(settings))
    return Path(path)


def load_map(path):
    """Read a map written by :func:`save_map`: ``(map, nodes, grid, settings)``.

    A missing file is ``FileNotFoundError``; anything else unreadable is :class:`MapFileError`.
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
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError) as e:
        raise MapFileError(f"{path} is not a readable wsmap map file ({type(e).__name__}: {e})") from None
    if flat.dtype != bool or nodes.shape != (flat.shape[0], 3):
        raise MapFileError(f"{path} is not a wsmap map file: map {flat.shape} {flat.dtype}, nodes {nodes.shape}")
    return flat, nodes, grid, settings
