"""The experiment glue: fitting on datasets, stacking block models, evaluating on test sets."""

import numpy as np
import pytest
import torch

from wsmap import datasets, workspace
from wsmap.learn.training import TrainConfig
from wsmap.paper import fitting, specs


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    torch.set_num_threads(1)
    d = tmp_path_factory.mktemp("data")
    specs.build_pair("table1_r3_step05", d, samples=120, test_samples=40, progress=False)
    return specs.load_pair("table1_r3_step05", d)


def test_build_pair_and_load_pair_check_the_test_stream(pair, tmp_path):
    train, test = pair
    assert (len(train), len(test)) == (120, 40) and train.n_nodes == test.n_nodes == 125
    assert test.spec.stream == "test" and train.spec.stream == "train"
    # a test file of another dataset is refused
    specs.build_pair("table1_r3_step1", tmp_path, samples=10, test_samples=5, progress=False)
    a, b = specs.dataset_paths("table1_r3_step05", tmp_path)
    c, d = specs.dataset_paths("table1_r3_step1", tmp_path)
    a.write_bytes(c.read_bytes())
    b.write_bytes(specs.dataset_paths("table1_r3_step1", tmp_path)[1].read_bytes())
    specs.load_pair("table1_r3_step05", tmp_path)  # consistent pair of step1 under another name: fine
    b.write_bytes(train.path.read_bytes())  # a training file posing as the test set
    with pytest.raises(datasets.DatasetError, match="is not the test set"):
        specs.load_pair("table1_r3_step05", tmp_path)
    with pytest.raises(ValueError, match="unknown dataset 'nope'"):
        specs.dataset_paths("nope", tmp_path)


def test_fit_is_reproducible_and_evaluate_matches_a_direct_computation(pair):
    train, test = pair
    cfg = TrainConfig(max_epochs=5, seed=3)
    r1 = fitting.fit(train, cfg, nodes=(0, 50), hidden=[8])
    r2 = fitting.fit(train, cfg, nodes=(0, 50), hidden=[8])
    assert r1[0].history.loss == r2[0].history.loss
    ev = fitting.evaluate(r1[0].model, test, nodes=(0, 50))
    pred = r1[0].model.predict(test.features).numpy()
    truth = test.labels[:, :50]
    tp = (pred & truth).sum()
    p, r = tp / pred.sum(), tp / truth.sum()
    assert ev["f"] == pytest.approx(2 * p * r / (p + r))
    assert ev["scores"].shape == (40, 50) and ev["nodes"] == 50


def test_fit_blocks_assembles_the_blocks_in_node_order(pair):
    train, test = pair
    blocks = [(0, 25), (25, 50), (50, 75), (75, 100), (100, 125)]
    model, results = fitting.fit_blocks(train, TrainConfig(max_epochs=2), blocks, hidden=[6])
    assert model.n_subspaces == 5 and len(results) == 5
    whole = model.score(test.features, assemble=True).numpy()
    for k, (a, b) in enumerate(blocks):
        np.testing.assert_array_equal(whole[:, a:b], results[k].model.score(test.features, key=0).numpy())
    ev = fitting.evaluate(model, test, assemble=True)
    assert ev["nodes"] == 125
    with pytest.raises(ValueError, match="give key=k or assemble=True"):
        fitting.evaluate(model, test)
    with pytest.raises(ValueError, match="same number of nodes"):
        fitting.fit_blocks(train, TrainConfig(max_epochs=1), [(0, 25), (25, 75)], hidden=[4])


def test_node_slices_are_checked():
    assert fitting.node_slice(None, 10) == slice(0, 10)
    assert fitting.node_slice((2, 5), 10) == slice(2, 5)
    assert fitting.node_slice(workspace.block_slice(4), 9261) == slice(5292, 6615)
    for bad in [(5, 5), (0, 11), (3, 2)]:
        with pytest.raises(ValueError, match="contiguous range"):
            fitting.node_slice(bad, 10)


def test_head_is_the_smaller_build(pair, tmp_path):
    train, _ = pair
    small = train.head(30)
    assert len(small) == 30 and small.n_nodes == 125 and small.spec.samples == 30
    datasets.build_dataset(datasets.scaled(train.spec, 30), tmp_path / "s.npz", progress=False)
    built = datasets.load_dataset(tmp_path / "s.npz")
    np.testing.assert_array_equal(small.features, built.features)
    np.testing.assert_array_equal(small.labels, built.labels)
    assert train.head(None) is train and train.head(10_000) is train
