"""wsmap.learn.verified and wsmap.learn.screening: the network's unsure nodes and its best arms decided by the classical map."""

import math

import numpy as np
import pytest
import torch

import wsmap
from wsmap import learn
from wsmap import workspace as ws
from wsmap.learn import morph_model as mm
from wsmap.learn.training_range import ExtrapolationWarning
from wsmap.learn.screening import screen_arms
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


# ---------------------------------------------------------------------------------- catalogue screening
@pytest.fixture(scope="module")
def catalogue():
    from wsmap.robots import FAMILIES

    fam = FAMILIES["morph6"]
    arms = [fam.arms(p) for p in fam.draw(12, seed=5)] + [wsmap.load("ur5e")]
    targets = ws.cartesian_grid([0.2, -0.4, 0.0], [0.6, 0.4, 0.4], 0.2)
    truth = np.array([ws.constant_orientation_map(a, targets, (math.pi, 0, 0)).mean() for a in arms])
    return arms, targets, truth


def test_screening_every_arm_is_the_exhaustive_ranking(model, catalogue):
    arms, targets, truth = catalogue
    cost = np.arange(len(arms))[::-1].astype(float)  # ties: the later arm first
    res = screen_arms(model, arms, targets, top=5, candidates=len(arms), cost=cost)
    expected = np.lexsort((np.arange(len(arms)), cost, -truth))[:5]
    assert np.array_equal(res.ranking, expected) and np.array_equal(res.coverage, truth[expected])
    assert res.predicted.shape == (len(arms),) and ((0 <= res.predicted) & (res.predicted <= 1)).all()


def test_screening_maps_only_the_predicted_best(model, catalogue):
    arms, targets, truth = catalogue
    res = screen_arms(model, arms, targets, top=3, candidates=6, slack=0.0)
    assert len(res.candidates) == 6 and set(res.ranking) <= set(res.candidates)
    assert np.array_equal(res.candidates, np.lexsort((np.arange(len(arms)), np.zeros(len(arms)), -res.predicted))[:6])
    assert np.array_equal(res.coverage, truth[res.ranking])  # classical coverages, never predicted ones
    assert (np.diff(res.coverage) <= 0).all()


def test_screening_slack_prefers_cheap_arms_near_the_top(model, catalogue):
    arms, targets, truth = catalogue
    cost = np.linspace(2.0, 1.0, len(arms))
    res = screen_arms(model, arms, targets, top=3, candidates=5, cost=cost, slack=1.0)
    assert np.array_equal(res.candidates, np.argsort(cost)[:5])  # every arm is near: the cheapest five
    assert np.array_equal(res.coverage, truth[res.ranking])


@pytest.mark.parametrize("kw, message", [
    ({"top": 0}, "top must be a positive integer, got 0"),
    ({"slack": 2}, "slack must be a share of the targets in \\[0, 1\\], got 2"),
    ({"top": 5, "candidates": 2}, "candidates \\(2\\) must be at least top \\(5\\)"),
    ({"cost": [1.0, 2.0]}, "cost must be 13 finite numbers \\(one per arm\\), got shape \\(2,\\)"),
])
def test_screening_refuses_bad_settings(model, catalogue, kw, message):
    arms, targets, _ = catalogue
    with pytest.raises(ValueError, match=message):
        screen_arms(model, arms, targets, **kw)
