"""Where the project's files live: one place, independent of the working directory.

The project root is ``$WSMAP_ROOT`` when set, else the checkout that holds this package
(``src/wsmap`` → two levels up). Notebooks and pipeline stages take every path from here.
"""

from __future__ import annotations

import os
from pathlib import Path

ROOT = Path(os.environ.get("WSMAP_ROOT", Path(__file__).resolve().parents[2])).resolve()
PARAMS = ROOT / "params.yaml"
DATA = ROOT / "data"
MODELS = ROOT / "models"
FIGURES = ROOT / "figures"
TABLES = ROOT / "tables"
RESULTS = ROOT / "results"
NOTEBOOKS = ROOT / "notebooks"
EXECUTED = RESULTS / "notebooks"
PAPER = (ROOT / ".." / "shared" / "paper").resolve()


def load_params(section: str | None = None, path: Path | str | None = None) -> dict:
    """The pipeline's parameters (``params.yaml``), or one section of them."""
    import yaml

    path = Path(path) if path is not None else PARAMS
    with open(path) as f:
        params = yaml.safe_load(f) or {}
    if section is None:
        return params
    if section not in params:
        raise KeyError(f"{path} has no section {section!r}; sections: {', '.join(params)}")
    return params[section]


class Outputs:
    """The folders a pipeline run writes to, under one root (the project root by default).

    Smoke runs pass a temporary root so that they never overwrite the committed results.
    """

    def __init__(self, root: Path | str | None = None):
        self.root = Path(root).resolve() if root else ROOT
        self.data = self.root / "data"
        self.models = self.root / "models"
        self.figures = self.root / "figures"
        self.tables = self.root / "tables"
        self.results = self.root / "results"
        self.executed = self.results / "notebooks"

    def make(self) -> "Outputs":
        for p in (self.data, self.models, self.figures, self.tables, self.results, self.executed):
            p.mkdir(parents=True, exist_ok=True)
        return self

    def __repr__(self):
        return f"Outputs(root={str(self.root)!r})"
