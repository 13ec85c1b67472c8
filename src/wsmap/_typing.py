"""Generic type aliases of the public signatures: what an argument may be, for readers and type checkers.

The library's modules annotate with `from __future__ import annotations` and import these names
only under `typing.TYPE_CHECKING`, so nothing here runs when the package is used; the
documentation shows the annotations as written.

* `ArrayLike` / `NDArray` — numpy's: anything `np.asarray` takes; an ndarray of a dtype.
  Shapes, units and frames are in each function's docstring (metres, radians, the arm's base frame,
  node order x fastest);
* `PathLike` — a file path, `str` or `os.PathLike`;
* `Any`, `Callable`, `Iterable`, `Mapping`, `Sequence`, `Path` — the standard library's.

Only generic names live here: nothing of wsmap and no heavy third-party package, so this module
is the bottom of the import graph, type checking included. A module annotating with one of
wsmap's classes imports it from where it lives, under its own `TYPE_CHECKING` (an arm is
`wsmap.kinematics.chain.Arm`: a `DHRobot` or a `SerialChain`); one annotating with
pandas, torch or matplotlib imports those there too.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, TypeAlias

from numpy.typing import ArrayLike, NDArray

#: A file path.
PathLike: TypeAlias = str | os.PathLike

__all__ = ["PathLike", "Path", "ArrayLike", "NDArray", "Any", "Callable", "Iterable", "Mapping", "Sequence"]
