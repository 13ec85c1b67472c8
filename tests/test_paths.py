"""wsmap.paths: where a run writes and what it reads; a notebook opened by hand never writes over
the committed results."""

from __future__ import annotations

from pathlib import Path

from wsmap import paths


def test_a_pipeline_run_reads_and_writes_under_its_root(tmp_path):
    out = paths.notebook_outputs("report", tmp_path, log=lambda line: None)
    assert out.root == tmp_path.resolve() and out.inputs is out
    assert out.data == tmp_path.resolve() / "data" and out.data.is_dir()
    assert out.figures == tmp_path.resolve() / "figures" and out.executed.is_dir()


def test_a_notebook_opened_by_hand_writes_into_scratch_and_reads_the_project(tmp_path, monkeypatch):
    monkeypatch.setattr(paths, "SCRATCH", tmp_path / "scratch")
    lines = []
    out = paths.notebook_outputs("real_arms", None, log=lines.append)
    assert out.root == (tmp_path / "scratch" / "real_arms").resolve()
    for folder in (out.figures, out.tables, out.results, out.models, out.executed):
        assert folder.is_dir() and folder.is_relative_to(out.root)
    # what it reads: the project's datasets, models and metrics, never made by it
    assert out.inputs.root == paths.ROOT and out.data == paths.ROOT / "data"
    assert out.inputs.results == paths.RESULTS and out.inputs.models == paths.MODELS
    assert not (out.root / "data").exists()
    assert len(lines) == 1 and str(out.root) in lines[0] and "output_root = paths.ROOT" in lines[0]
    assert repr(out) == f"Outputs(root={str(out.root)!r}, inputs={str(paths.ROOT)!r})"


def test_scratch_is_ignored_by_git():
    ignored = (paths.ROOT / ".gitignore").read_text().splitlines()
    assert "/scratch/" in ignored
    assert paths.SCRATCH == Path(paths.ROOT) / "scratch"


def _checkout_like(folder: Path) -> Path:
    folder.mkdir(parents=True)
    (folder / "dvc.yaml").write_text("stages: {}\n")
    (folder / "params.yaml").write_text("{}\n")
    return folder


def test_a_wheel_install_finds_the_checkout_from_the_working_directory(tmp_path):
    # wsmap installed in site-packages (no dvc.yaml two levels up), run from a folder inside a checkout
    site = tmp_path / "venv" / "lib" / "python3.11"
    (site / "site-packages" / "wsmap").mkdir(parents=True)
    checkout = _checkout_like(tmp_path / "work" / "wsmap")
    inside = checkout / "notebooks" / "deeper"
    inside.mkdir(parents=True)
    assert paths.find_root({}, package_root=site, cwd=inside) == checkout.resolve()
    assert paths.find_root({}, package_root=site, cwd=checkout) == checkout.resolve()
    # dvc.yaml alone is not a checkout (a DVC project of someone else's)
    other = tmp_path / "other"
    other.mkdir()
    (other / "dvc.yaml").write_text("stages: {}\n")
    assert paths.find_root({}, package_root=site, cwd=other) == site.resolve()
    # WSMAP_ROOT wins, and the checkout that holds the package (an editable install) comes before cwd
    assert paths.find_root({"WSMAP_ROOT": str(other)}, package_root=site, cwd=inside) == other.resolve()
    editable = _checkout_like(tmp_path / "editable")
    assert paths.find_root({}, package_root=editable, cwd=inside) == editable.resolve()


def test_the_project_root_of_this_checkout_is_the_checkout():
    assert paths.find_root({}) == paths.ROOT == Path(__file__).resolve().parents[1]
