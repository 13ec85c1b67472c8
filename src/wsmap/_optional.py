"""Optional dependencies: one place that says which extra of `pip install wsmap[...]` brings a module.

The classical tool (`pip install wsmap`) needs numpy, scipy, numba, tqdm, pyyaml and matplotlib;
everything else is an extra (`pyproject.toml`, `docs/install.md`). A part that needs an optional
module calls `require` *before* any work, so a missing one is one line naming the extra to
install (the command line turns it into `wsmap: error: ...`, exit 2) instead of a traceback after
the map was computed.
"""

from __future__ import annotations

import importlib
from types import ModuleType

__all__ = ["EXTRAS", "MissingDependency", "require"]

#: The extra of `pip install wsmap[EXTRA]` that brings each optional module (import name -> extra).
EXTRAS = {
    "yourdfpy": "urdf",
    "plotly": "views",
    "trimesh": "views",
    "skimage": "views",
    "distributed": "cluster",
    "dask": "cluster",
    "torch": "learn",
    "pandas": "learn",
    "cma": "learn",
    "h5py": "h5",
    "coal": "collision",
    "mujoco": "mjcf",
    "papermill": "paper",
}

#: What the distribution is called on PyPI where it differs from the import name.
_DISTRIBUTIONS = {"skimage": "scikit-image", "distributed": "dask[distributed]", "dask": "dask[distributed]"}


class MissingDependency(ImportError, ValueError):
    """An optional module is not installed. A `ValueError` too, so the command line reports it as
    bad input (one line, exit 2) and library callers may catch either."""


def require(module: str, *, extra: str | None = None, why: str | None = None) -> ModuleType:
    """Import and return the optional `module`; `MissingDependency` naming the extra otherwise.

    Parameters
    ----------
    module
        the import name (`"plotly"`, `"skimage"`, `"yourdfpy"`, ...).
    extra
        the `pip install wsmap[EXTRA]` that brings it (default: `EXTRAS`'s entry).
    why
        what needs it, for the message (`"--html"`, `"a URDF arm"`); default the module.

    Raises
    ------
    MissingDependency
        `"<why> needs <dist>, which is not installed: pip install 'wsmap[<extra>]'"`.
    """
    extra = extra or EXTRAS.get(module.split(".")[0])
    try:
        return importlib.import_module(module)
    except ImportError as e:
        top = module.split(".")[0]
        dist = _DISTRIBUTIONS.get(top, top)
        how = f"pip install 'wsmap[{extra}]'" if extra else f"pip install {dist}"
        inner = getattr(e, "name", None)
        # a dependency of the module missing (a partial install) is named too: the extra brings it
        what = ("which is not installed" if inner in (None, top, module)
                else f"whose dependency {inner} is not installed")
        raise MissingDependency(f"{why or module} needs {dist}, {what}: {how}") from None
