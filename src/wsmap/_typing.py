"""Type aliases of the public signatures: what an argument may be, for readers and type checkers.

The library's modules annotate with `from __future__ import annotations` and import these names
only under `typing.TYPE_CHECKING`, so nothing here runs when the package is used; the
documentation shows the annotations as written.

* `Arm` — one arm or a batch of arms: a `wsmap.kinematics.DHRobot` (standard DH,
  batched over arms) or a `wsmap.kinematics.SerialChain` (any serial arm);
* `ArrayLike` / `NDArray` — numpy's: anything `np.asarray` takes; an ndarray of a dtype.
  Shapes, units and frames are in each function's docstring (metres, radians, the arm's base frame,
  node order x fastest);
* `PathLike` — a file path, `str` or `os.PathLike`.
"""

from __future__ import annotations

import os
from pathlib import Path
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any, TypeAlias

import numpy as np
import pandas as pd
import torch
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from .datasets.spec import DatasetSpec
from .datasets.store import Dataset
from .kinematics.chain import SerialChain
from .kinematics.dh import DHRobot
from .learn.network import SubspaceMLP
from .learn.training import TrainConfig
from .paths import Outputs

#: One arm, or a batch of arms (parameters with a leading batch dimension).
Arm: TypeAlias = DHRobot | SerialChain
#: A file path.
PathLike: TypeAlias = str | os.PathLike

__all__ = ["Arm", "PathLike", "Path", "ArrayLike", "NDArray", "Any", "Callable", "Iterable", "Mapping", "Sequence", "np", "pd",
           "torch", "Axes", "Figure", "DatasetSpec", "Dataset", "SubspaceMLP", "TrainConfig", "Outputs"]
