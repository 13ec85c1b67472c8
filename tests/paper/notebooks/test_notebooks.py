"""Papermill smoke runs: every pipeline notebook end to end on params.smoke.yaml, into a temporary root."""

import json

import nbformat
import pytest

from wsmap import paths
from wsmap.paper.pipeline import run_notebook

SMOKE = paths.ROOT / "params.smoke.yaml"


def _notebooks():
    return sorted(p.stem for p in paths.NOTEBOOKS.glob("*.ipynb"))


def test_every_pipeline_notebook_has_a_smoke_section():
    smoke = paths.load_params(path=SMOKE)
    full = paths.load_params()
    # one section per notebook, plus the datasets every training notebook reads
    assert set(_notebooks()) | {"datasets"} == set(smoke) == set(full)
    assert set(smoke["datasets"]) == set(full["datasets"])


@pytest.mark.parametrize("name", _notebooks())
def test_source_notebooks_are_committed_without_outputs(name):
    nb = nbformat.read(paths.NOTEBOOKS / f"{name}.ipynb", as_version=4)
    assert all(not c.get("outputs") for c in nb.cells if c.cell_type == "code")
    assert any("parameters" in c.metadata.get("tags", []) for c in nb.cells)


def _audited_specs():
    """The specs the notebook audits (wsmap.paper.specs.audit_specs): every spherical-wrist
    (exact-label) spec of PAPER_SPECS, one per distinct grid / node selection / orientation /
    convention."""
    from wsmap.paper.specs import PAPER_SPECS

    seen, names = set(), []
    for s in PAPER_SPECS.values():
        key = (s.family, s.scope, s.lo, s.hi, s.step, s.select, s.fixed, s.convention)
        if s.method == "exact" and key not in seen:
            seen.add(key)
            names.append(s.name)
    return names


def test_classical_workspace_smoke(tmp_path):
    dest = run_notebook("classical_workspace", SMOKE, tmp_path, timeout=600)
    assert dest == tmp_path / "results" / "notebooks" / "classical_workspace.ipynb"
    metrics = json.loads((tmp_path / "results" / "classical_workspace.json").read_text())
    assert metrics["nodes"] == 9 ** 3
    assert metrics["numerical_false_positives"] == 0
    for fig in ("puma560_workspace_slices", "puma560_workspace_exact", "puma560_exact_vs_numerical", "puma560_conventions"):
        assert (tmp_path / "figures" / f"{fig}.png").stat().st_size > 5_000
    # label audit: one row per distinct spherical-wrist spec, audit_arms arms each
    import pandas as pd

    audit = pd.read_csv(tmp_path / "tables" / "label_audit.csv")
    expected = _audited_specs()
    assert list(audit["spec"]) == expected
    arms = paths.load_params("classical_workspace", SMOKE)["audit_arms"]
    assert (audit["arms"] == arms).all() and (audit["pairs"] == arms * audit["nodes"]).all()
    assert "| spec" in (tmp_path / "tables" / "label_audit.md").read_text()
    assert metrics["label_audit"]["specs"] == len(expected) and metrics["label_audit"]["arms"] == arms
    # the committed results were not touched by the smoke run
    assert not (paths.ROOT / "results" / "notebooks" / str(tmp_path.name)).exists()


@pytest.mark.parametrize("name", _notebooks())
def test_notebook_is_built_from_its_percent_source(name):
    """notebooks/py/NAME.py is the text that is edited and diffed; the .ipynb must be its build."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("nbsource", paths.ROOT / "tools" / "nbsource.py")
    nbsource = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(nbsource)
    built = nbsource.build((paths.NOTEBOOKS / "py" / f"{name}.py").read_text())
    committed = nbformat.read(paths.NOTEBOOKS / f"{name}.ipynb", as_version=4)
    assert [(c.cell_type, c.source) for c in committed.cells] == [(c.cell_type, c.source) for c in built.cells], (
        f"notebooks/{name}.ipynb is out of date: run python tools/nbsource.py notebooks/py/{name}.py "
        f"notebooks/{name}.ipynb")
