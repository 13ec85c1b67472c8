"""wsmap.workspace.files: a map file read back is checked against itself (issue 29: each of these
loaded, or raised a TypeError, before)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from wsmap import workspace as ws
from wsmap.workspace.files import MapFileError


def _write(path, **entries):
    """A map file with some entries replaced (``map``, ``nodes``, ``grid``, ``settings`` as given)."""
    grid = ws.grid_spec("R3", -0.5, 0.5, 0.5)
    base = dict(map=np.zeros(27, dtype=bool), nodes=ws.cartesian_grid(-0.5, 0.5, 0.5), grid=json.dumps(grid),
                settings=json.dumps({"kind": "constant"}))
    base.update(entries)
    with open(path, "wb") as f:
        np.savez(f, **base)
    return path


def test_a_good_file_loads(tmp_path):
    flat, nodes, grid, settings = ws.load_map(_write(tmp_path / "m.npz"))
    assert flat.shape == (27,) and grid["shape"] == [3, 3, 3] and settings == {"kind": "constant"}


@pytest.mark.parametrize("entries, message", [
    (dict(settings=json.dumps([1, 2])), "its settings is a JSON list, not an object"),
    (dict(grid="null"), "its grid is a JSON NoneType, not an object"),
    (dict(grid=json.dumps({**ws.grid_spec("R3", -1, 1, 0.5), "shape": [5, 5, 5]})), "its grid has 125 nodes, its map 27"),
    (dict(grid=json.dumps({"scope": "R3", "lo": [0, 0, 0]})), "its grid lacks hi, step, shape"),
    (dict(grid=json.dumps({**ws.grid_spec("R3", -0.5, 0.5, 0.5), "step": [0, 0.5, 0.5]})), "its grid is not a grid"),
    (dict(nodes=np.zeros((27, 3))), "its nodes are not its grid's (node 0 is [0.0, 0.0, 0.0], the grid's "
                                    "[-0.5, -0.5, -0.5])"),
    (dict(map=np.full(27, np.nan), settings=json.dumps({"kind": "index"})), "its map holds 27 NaN or infinite values"),
    (dict(map=np.full(27, 1.5), settings=json.dumps({"kind": "index"})), "a 'index' map lies in [0.0, 1.0], "
                                                                          "this one in [1.5, 1.5]"),
    (dict(map=np.full(27, -1.0), settings=json.dumps({"kind": "manipulability"})), "a 'manipulability' map lies "
                                                                                   "in [0.0, ], this one in [-1, -1]"),
])
def test_a_file_that_disagrees_with_itself_is_a_map_file_error(tmp_path, entries, message):
    path = _write(tmp_path / "m.npz", **entries)
    with pytest.raises(MapFileError) as e:
        ws.load_map(path)
    assert message in str(e.value) and str(e.value).startswith(str(path))


def test_a_npy_file_is_named_as_one(tmp_path):
    path = tmp_path / "m.npy"
    np.save(path, np.zeros(27))
    with pytest.raises(MapFileError, match=r"m.npy is a single numpy array \(.npy\), not a wsmap map file"):
        ws.load_map(path)
