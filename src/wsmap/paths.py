"""Where the project's files live: one place.

The project root (`find_root`) is `$WSMAP_ROOT` when set; else the checkout that holds this
package (`src/wsmap` → two levels up: a checkout, or an editable install of it); else, for a
package installed from a wheel (in site-packages, far from any checkout), the nearest folder at
or above the working directory that holds `dvc.yaml` and `params.yaml`. Notebooks and pipeline
stages take every path from here.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

#: The files that make a folder a checkout of the project (the pipeline and its parameters).
CHECKOUT_FILES = ("dvc.yaml", "params.yaml")


def _is_checkout(folder: Path) -> bool:
    return all((folder / name).is_file() for name in CHECKOUT_FILES)


def find_root(environ: Mapping[str, str] | None = None, *, package_root: Path | str | None = None,
              cwd: Path | str | None = None) -> Path:
    """The project root, resolved (see the module notes).

    Parameters
    ----------
    environ : mapping, optional
        The environment (default `os.environ`); its `WSMAP_ROOT`, when set and not empty, wins.
    package_root : path, optional
        Two levels above this package (default: this file's `parents[2]`, the checkout for a
        source or editable install, `lib/pythonX.Y` for a wheel).
    cwd : path, optional
        Where the search up for a checkout starts (default: the working directory).

    Returns
    -------
    pathlib.Path
        `WSMAP_ROOT`, else `package_root` if it is a checkout (a folder with `CHECKOUT_FILES`), else
        the nearest checkout at or above `cwd`, else `package_root` (so that `require_checkout`
        names it).
    """
    env = os.environ if environ is None else environ
    if env.get("WSMAP_ROOT"):
        return Path(env["WSMAP_ROOT"]).resolve()
    package = Path(__file__).resolve().parents[2] if package_root is None else Path(package_root).resolve()
    if _is_checkout(package):
        return package
    start = Path.cwd() if cwd is None else Path(cwd)
    for folder in (start.resolve(), *start.resolve().parents):
        if _is_checkout(folder):
            return folder
    return package


ROOT = find_root()
PARAMS = ROOT / "params.yaml"
DATA = ROOT / "data"
#: The committed work cells of the reach studies (`data/cells/<cell>/`: study files, parts, arms, licences).
CELLS = DATA / "cells"
MODELS = ROOT / "models"
FIGURES = ROOT / "figures"
TABLES = ROOT / "tables"
RESULTS = ROOT / "results"
NOTEBOOKS = ROOT / "notebooks"
EXECUTED = RESULTS / "notebooks"
#: Where a notebook opened by hand writes (git-ignored): never over the committed results.
SCRATCH = ROOT / "scratch"
PAPER = (ROOT / ".." / "shared" / "paper").resolve()


def require_checkout(what: str = "wsmap paper") -> Path:
    """The project root, or a `ValueError` saying that `what` needs a checkout of the repository
    (`dvc.yaml`, `params.yaml` and `notebooks/` at the root) and where it looked: an installed package (`pip install wsmap`) has
    the library but not the paper's notebooks, parameters and data."""
    if not (_is_checkout(ROOT) and NOTEBOOKS.is_dir()):
        where = (f"WSMAP_ROOT ({ROOT}) is not one: set it to the checkout" if os.environ.get("WSMAP_ROOT") else
                 f"neither {ROOT} (where wsmap is installed) nor a folder above the working directory {Path.cwd()} "
                 "is one: run it inside the checkout, or set WSMAP_ROOT to it")
        raise ValueError(f"{what} reproduces the paper and needs a checkout of the wsmap repository (dvc.yaml, "
                         f"params.yaml and notebooks/ at its root); {where}")
    return ROOT


def load_params(section: str | None = None, path: Path | str | None = None) -> dict:
    """The pipeline's parameters (`params.yaml` unless `path`), or one section of them.

    A missing file or section is a `ValueError` naming it.
    """
    import yaml

    path = Path(path) if path is not None else PARAMS
    if not path.is_file():
        raise ValueError(f"no parameters file at {path}")
    from .io import read_text

    text = read_text(path, f"{path} is", "a parameters file is YAML")
    try:
        params = yaml.safe_load(text) or {}
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise ValueError(f"{path} is not valid YAML{where}: {problem}") from None
    _check_size(params, path)
    if not isinstance(params, dict):
        raise ValueError(f"{path} must hold a mapping of sections, got {type(params).__name__}")
    if section is None:
        return params
    if section not in params:
        raise ValueError(f"{path} has no section {section!r}; sections: {', '.join(params)}")
    return params[section]


#: The most values a parameters file may hold once its YAML aliases are expanded (params.full.yaml
#: holds about a hundred): a few lines of nested aliases (an "alias bomb") expand to billions.
MAX_PARAMS_VALUES = 100_000


def _check_size(params, path) -> None:
    """`ValueError` when `params` holds more than `MAX_PARAMS_VALUES` values, each alias
    counted as often as it is used (a recursive alias, too, stops the count)."""
    stack, count = [params], 0
    while stack:
        v = stack.pop()
        count += 1
        if count > MAX_PARAMS_VALUES:
            raise ValueError(f"{path} holds more than {MAX_PARAMS_VALUES} values once its YAML aliases (*name) are "
                             "expanded: an alias bomb, or not a parameters file")
        if isinstance(v, dict):
            stack.extend(v.values())
        elif isinstance(v, list):
            stack.extend(v)


class Params(dict):
    """One notebook's parameters: a dict whose missing keys are an error naming file and section.

    Notebooks hold no defaults of their own; every value they read comes from the params file.
    """

    def __init__(self, values: dict, source: str):
        super().__init__(values)
        self.source = source

    def __missing__(self, key):
        raise KeyError(f"{self.source} has no parameter {key!r} (known: {', '.join(sorted(self)) or 'none'})")

    def get(self, key, *default):  # noqa: D401 - a default would hide a missing parameter
        raise TypeError("Params.get would hide a missing parameter; index with params[key]")


def notebook_params(name: str, params_file: Path | str | None = None) -> Params:
    """The parameters of notebook `name`: its section of `params_file` (default `params.yaml`).

    The same call serves papermill (which passes the chosen file) and a notebook opened by hand in
    JupyterLab (`params_file` left `None`).
    """
    path = Path(params_file) if params_file else PARAMS
    section = load_params(name, path)
    if not isinstance(section, dict):
        raise ValueError(f"{path} section {name!r} must be a mapping, got {type(section).__name__}")
    return Params(section, f"{path.name} section {name!r}")


class Outputs:
    """The folders a pipeline run writes to, under one root (the project root by default).

    Smoke runs pass a temporary root so that they never overwrite the committed results.
    `inputs`: the root whose `data/`, `models/`, `results/` and `tables/` hold what this
    run READS (the datasets, other stages' models and metrics; `inputs` is an `Outputs` of
    it); by default `root` itself, as a pipeline run reads what it wrote. A notebook opened by
    hand writes into `SCRATCH` and reads the project's (`notebook_outputs`).
    """

    def __init__(self, root: Path | str | None = None, inputs: Path | str | None = None):
        self.root = Path(root).resolve() if root else ROOT
        read = Path(inputs).resolve() if inputs else self.root
        self.inputs = self if read == self.root else Outputs(read)
        # datasets are only ever read by a run (the dataset stages write them): they come from inputs
        self.data = read / "data"
        self.models = self.root / "models"
        self.figures = self.root / "figures"
        self.tables = self.root / "tables"
        self.results = self.root / "results"
        self.executed = self.results / "notebooks"

    def make(self) -> "Outputs":
        """Create the folders (the datasets' too when this root is also the one read from)."""
        made = (self.models, self.figures, self.tables, self.results, self.executed)
        for p in (*made, self.data) if self.inputs is self else made:
            p.mkdir(parents=True, exist_ok=True)
        return self

    def __repr__(self):
        extra = "" if self.inputs is self else f", inputs={str(self.inputs.root)!r}"
        return f"Outputs(root={str(self.root)!r}{extra})"


def notebook_outputs(name: str, output_root: Path | str | None = None, *, log=print) -> Outputs:
    """Where notebook `name` writes, made: `output_root` when it is given (papermill and DVC
    always pass one: the project root, or a temporary root for the smoke runs), else, for a
    notebook opened by hand, `scratch/<name>/` (git-ignored), reading its inputs (datasets, other
    stages' models and metrics) from the project root, so that the committed `figures/`,
    `tables/`, `results/` and `models/` stay as the pipeline wrote them. Set `output_root =
    paths.ROOT` in the parameters cell to update the committed results from a notebook. `log`
    receives one line saying where the files go.
    """
    if output_root is not None:
        return Outputs(output_root).make()
    out = Outputs(SCRATCH / name, inputs=ROOT).make()
    log(f"{name}: opened by hand, writing into {out.root} (reading data, models and results from {ROOT}); "
        "set output_root = paths.ROOT in the parameters cell to update the committed results")
    return out
