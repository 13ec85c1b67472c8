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
