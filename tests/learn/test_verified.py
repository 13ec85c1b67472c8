"""wsmap.learn.verified: the network's unsure nodes decided by the classical map."""

import math

import numpy as np
import pytest
import torch

import wsmap
from wsmap import learn
from wsmap import workspace as ws
from wsmap.learn import morph_model as mm
from wsmap.learn.training_range import ExtrapolationWarning
from wsmap.learn.verified import VerifiedMap, verified_morph_grid

GRID = (-1.0, 1.0, 0.2)


def _half_margin(model, arm):
    """The logit margin within which half of the grid's nodes lie (the median distance to the threshold's)."""
    x = torch.as_tensor(mm.morph_features([arm]), dtype=torch.float32)
    nodes = torch.as_tensor(ws.cartesian_grid(*GRID), dtype=torch.float32)
    with torch.no_grad():
        logits = model.logits_at(x, nodes)[0].numpy()
    return float(np.median(np.abs(logits - math.log(model.threshold / (1 - model.threshold)))))


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    torch.set_num_threads(1)
    torch.manual_seed(0)
    root = tmp_path_factory.mktemp("verified")
    sets = mm.build_morph_shards(root, 6, 2, 20, step=0.3, test_samples=2)[0][:2]
    tc = learn.TrainConfig(optimizer="adam", optimizer_kwargs={"lr": 3e-3}, loss="crossentropy", batch_size=4,
                           lr_decay="cosine", max_epochs=40, max_fail=1000, fractions=(0.9, 0.1, 0.0),
                           pos_weight=20.0)
    net, _ = mm.fit_morph_model(sets, mm.MorphModelConfig(encoder=(32,), latent=16, decoder=(32,)), tc)
    return net


@pytest.fixture(scope="module")
def ur5e_truth():
    arm = wsmap.load("ur5e")
    return arm, ws.constant_orientation_map(arm, ws.cartesian_grid(*GRID), (math.pi, 0, 0), method="exact")


def test_verified_nodes_are_classical_and_the_others_the_networks(model, ur5e_truth):
    arm, truth = ur5e_truth
    # the test's small network is far from sure anywhere: a margin that checks about half the nodes
    res = verified_morph_grid(model, arm, *GRID, margin=_half_margin(model, arm))
    assert isinstance(res, VerifiedMap) and res.method == "exact" and res.rounds >= 1
    network = mm.predict_morph_map(model, arm, ws.cartesian_grid(*GRID))
    assert np.array_equal(res.network, network)
    assert np.array_equal(res.values[res.verified], truth[res.verified])
    assert np.array_equal(res.values[~res.verified], network[~res.verified])
    assert 0 < res.fraction_verified < 1
    assert res.corrected == int((res.values != network).sum())
    # checking more can only bring the answer nearer the classical map
    more = verified_morph_grid(model, arm, *GRID, margin=_half_margin(model, arm) + 1, shell=2)
    assert (more.verified >= res.verified).all()
    assert (more.values != truth).sum() <= (res.values != truth).sum()


def test_every_node_checked_is_the_classical_map(model, ur5e_truth):
    arm, truth = ur5e_truth
    res = verified_morph_grid(model, arm, *GRID, margin=math.inf)
    assert res.verified.all() and res.rounds == 1 and np.array_equal(res.values, truth)


def test_verify_all_reports_no_unverified_node_reachable(model, ur5e_truth):
    arm, truth = ur5e_truth
    res = verified_morph_grid(model, arm, *GRID, margin=_half_margin(model, arm), verify="all")
    assert (res.verified | ~res.values).all()
    assert not (res.values & ~truth).any()  # no false positive


def test_a_numerical_arm_goes_through_the_search(model):
    arm = wsmap.load("panda")
    grid = (-0.8, 0.8, 0.4)
    with pytest.warns(ExtrapolationWarning, match="panda is outside the model's training range"):
        res = verified_morph_grid(model, arm, *grid, allow_extrapolation=True)
    assert res.method == "numerical"
    truth = ws.constant_orientation_map(arm, ws.cartesian_grid(*grid), (math.pi, 0, 0))
    assert np.array_equal(res.values[res.verified], truth[res.verified])


@pytest.mark.parametrize("kw, message", [
    ({"margin": -1}, "margin must be a non-negative number of logits, got -1"),
    ({"shell": 1.5}, "shell must be an integer >= 0, got 1.5"),
    ({"max_rounds": 0}, "max_rounds must be an integer >= 1, got 0"),
    ({"verify": "some"}, "verify must be one of 'unsure', 'all', got 'some'"),
])
def test_bad_settings_are_refused_before_any_work(model, kw, message, monkeypatch):
    def no_work(*a, **k):
        raise AssertionError("the classical map ran")

    monkeypatch.setattr(ws.maps, "constant_orientation_map", no_work)
    with pytest.raises(ValueError, match=message):
        verified_morph_grid(model, wsmap.load("ur5e"), *GRID, **kw)
