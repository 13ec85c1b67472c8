"""The DVC-free runner: dataset building for a params file, and the errors it gives."""

import pytest

from wsmap import data as D
from wsmap.paper.pipeline import build_datasets, run_notebook


@pytest.fixture
def params_file(tmp_path):
    p = tmp_path / "params.yaml"
    p.write_text("datasets:\n  table1_r3_step1: {samples: 20, test_samples: 5}\n")
    return p


def test_build_datasets_builds_missing_pairs_once(tmp_path, params_file):
    data = tmp_path / "data"
    built = list(build_datasets(params_file, data))
    assert [name for name, _ in built] == ["table1_r3_step1"] and built[0][1] > 0
    train, test = D.load_pair("table1_r3_step1", data)
    assert (len(train), len(test)) == (20, 5)
    assert list(build_datasets(params_file, data)) == []  # already there: nothing to do
    assert [n for n, _ in build_datasets(params_file, data, rebuild=True)] == ["table1_r3_step1"]


def test_run_notebook_names_an_unknown_notebook(tmp_path):
    with pytest.raises(ValueError, match="unknown notebook 'nope'; known: .*sec61_subspace"):
        run_notebook("nope", root=tmp_path)


def test_a_failing_notebook_is_one_line_and_keeps_the_last_good_copy(tmp_path, capsys):
    """A root without the datasets: the notebook's own error in one line (no traceback), the
    executed copy with the traceback beside it, and the previous executed copy left in place."""
    from wsmap import cli, paths

    root = tmp_path / "root"
    executed = root / "results" / "notebooks"
    executed.mkdir(parents=True)
    (executed / "sec61_subspace.ipynb").write_text("the last good copy")
    code = cli.main(["paper", "run", "sec61_subspace", "--params", str(paths.ROOT / "params.smoke.yaml"),
                     "--root", str(root)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("wsmap: error: notebook sec61_subspace failed in cell ")
    assert f"FileNotFoundError: dataset file {root / 'data' / 'sec61.npz'} does not exist" in err
    assert (executed / "sec61_subspace.ipynb").read_text() == "the last good copy"
    assert "FileNotFoundError" in (executed / "sec61_subspace.failed.ipynb").read_text()
    assert sorted(p.name for p in executed.iterdir()) == ["sec61_subspace.failed.ipynb", "sec61_subspace.ipynb"]
