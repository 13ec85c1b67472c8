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
from wsmap.learn import screening
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
    """The UR5e's map on GRID by the numerical search (the path a verified query runs with
    method="numerical") and by its closed form."""
    arm = wsmap.load("ur5e")
    nodes = ws.cartesian_grid(*GRID)
    return (arm, ws.constant_orientation_map(arm, nodes, (math.pi, 0, 0), method="numerical"),
            ws.constant_orientation_map(arm, nodes, (math.pi, 0, 0), method="exact"))


def test_verified_nodes_are_classical_and_the_others_the_networks(model, ur5e_truth):
    arm, truth, _ = ur5e_truth
    # the test's small network is far from sure anywhere: a margin that checks about half the nodes
    res = verified_morph_grid(model, arm, *GRID, margin=_half_margin(model, arm), method="numerical")
    assert isinstance(res, VerifiedMap) and res.method == "numerical" and res.rounds >= 1
    network = mm.predict_morph_map(model, arm, ws.cartesian_grid(*GRID))
    # the network is asked about the nodes the filters leave, and nowhere else
    assert np.array_equal(res.network, network & res.possible)
    assert not res.values[~res.possible].any() and not res.verified[~res.possible].any()
    assert np.array_equal(res.values[res.verified], truth[res.verified])
    rest = res.possible & ~res.verified
    assert np.array_equal(res.values[rest], network[rest])
    assert 0 < res.fraction_verified < 1
    assert res.corrected == int((res.values != res.network).sum())
    # checking more can only bring the answer nearer the classical map
    more = verified_morph_grid(model, arm, *GRID, margin=_half_margin(model, arm) + 1, shell=2, method="numerical")
    assert (more.verified >= res.verified).all()
    assert (more.values != truth).sum() <= (res.values != truth).sum()


def test_the_filters_rule_out_only_unreachable_nodes(model, ur5e_truth):
    from wsmap.kinematics.ik.certificate import filter_certificate

    arm, truth, exact = ur5e_truth
    res = verified_morph_grid(model, arm, *GRID, margin=0.0, shell=0, method="numerical")
    T = ws.target_poses(ws.cartesian_grid(*GRID), (math.pi, 0, 0))
    # the search's pre-filters, as the certificate module runs them on every pose
    assert np.array_equal(res.possible, ~filter_certificate(arm, T))
    assert not (exact & ~res.possible).any() and (~res.possible).sum() > len(T) // 2


def test_every_node_checked_is_the_classical_map(model, ur5e_truth):
    arm, truth, _ = ur5e_truth
    res = verified_morph_grid(model, arm, *GRID, margin=math.inf, method="numerical")
    assert res.verified.sum() == res.possible.sum() and res.rounds == 1 and np.array_equal(res.values, truth)


def test_a_closed_form_arm_is_its_closed_form_without_the_network(model, ur5e_truth, monkeypatch):
    arm, _, exact = ur5e_truth

    def no_network(*a, **k):
        raise AssertionError("the network ran")

    monkeypatch.setattr(type(model), "logits_at", no_network)
    res = verified_morph_grid(model, arm, *GRID)
    assert res.method == "exact" and res.network is None and res.corrected == 0
    assert res.verified.all() and np.array_equal(res.values, exact)


def test_verify_all_reports_no_unverified_node_reachable(model, ur5e_truth):
    arm, truth, _ = ur5e_truth
    res = verified_morph_grid(model, arm, *GRID, margin=_half_margin(model, arm), verify="all", method="numerical")
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
    assert not (truth & ~res.possible).any()


@pytest.mark.parametrize("lo, hi, step", [(-1.5, 1.5, 0.1), ([-1, -0.5, 0], [1, 0.5, 0.8], 0.2)])
def test_subset_neighbours_and_shell_agree_with_the_whole_grid(lo, hi, step):
    from wsmap.learn.verified import _dilate, _grid_neighbours_of, _shell
    from wsmap.workspace.grids import grid_counts, node_neighbours

    nodes = ws.cartesian_grid(lo, hi, step)
    counts = [int(c) for c in grid_counts(lo, hi, step)]
    rng = np.random.default_rng(0)
    idx = rng.choice(len(nodes), min(500, len(nodes)), replace=False)
    # the rows of the whole grid's neighbour table, in its column order, from index arithmetic alone
    assert np.array_equal(_grid_neighbours_of(idx, counts), node_neighbours(nodes)[idx])
    shape = (counts[2], counts[1], counts[0])
    for steps in (1, 2):
        for _ in range(10):
            possible = rng.random(len(nodes)) < 0.05
            network = (rng.random(len(nodes)) < 0.3) & possible
            vol = network.reshape(shape)
            whole = (_dilate(vol, steps) & _dilate(~vol, steps)).ravel() & possible
            assert np.array_equal(_shell(network, possible, shape, steps), whole)


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


def _key(coverage, cost, i):
    """An arm's place in a ranking: greater is better (coverage high, cost low, index low)."""
    return (coverage, -cost, -i)


def test_screening_by_the_sound_bound_is_the_exhaustive_ranking(model, catalogue):
    arms, targets, truth = catalogue
    cost = np.arange(len(arms))[::-1].astype(float)  # ties: the later arm first
    res = screen_arms(model, arms, targets, top=5, cost=cost)
    expected = np.lexsort((np.arange(len(arms)), cost, -truth))[:5]
    assert res.complete and res.predicted is None  # margin=inf: the network is not consulted
    assert np.array_equal(res.ranking, expected) and np.array_equal(res.coverage, truth[expected])
    # the bound is sound: no arm covers more than it
    assert res.bound.shape == (len(arms),) and (truth <= res.bound + 1e-12).all()
    assert np.array_equal(res.mapped_coverage, truth[res.mapped])  # classical coverages, never predicted ones
    # every arm left unmapped is bounded below the fifth of the ranking
    fifth = _key(truth[expected[-1]], cost[expected[-1]], expected[-1])
    for i in sorted(set(range(len(arms))) - set(res.mapped)):
        assert _key(res.bound[i], cost[i], i) <= fifth


def test_screening_maps_by_bound_and_stops_early(model, catalogue):
    arms, targets, truth = catalogue
    bound = screening.coverage_bounds(arms, targets, (math.pi, 0, 0))
    res = screen_arms(model, arms, targets, top=1)
    order = np.lexsort((np.arange(len(arms)), np.zeros(len(arms)), -bound))
    assert np.array_equal(res.bound, bound)
    assert np.array_equal(res.mapped, order[:len(res.mapped)])  # best bound first
    assert res.ranking[0] == np.lexsort((np.arange(len(arms)), -truth))[0]
    assert truth.max() == bound.max()  # the UR5e covers every target: no arm of a lower bound is mapped
    assert len(res.mapped) == int((bound == bound.max()).sum()) < len(arms)


def test_screening_with_the_network_bound(model, catalogue):
    arms, targets, truth = catalogue
    sound = screen_arms(model, arms, targets, top=3)
    res = screen_arms(model, arms, targets, top=3, margin=0.0)
    assert np.array_equal(res.predicted, screening.predicted_coverage(model, arms, targets))
    # the network's bound at margin 0 is its own predicted coverage, capped by the sound bound
    assert np.array_equal(res.bound, np.minimum(sound.bound, res.predicted))
    assert np.array_equal(res.coverage, truth[res.ranking])
    wide = screen_arms(model, arms, targets, top=3, margin=1e6)  # every target counts: the sound bound
    assert np.array_equal(wide.bound, sound.bound) and np.array_equal(wide.ranking, sound.ranking)


def test_screening_candidates_caps_the_classical_maps(model, catalogue):
    arms, targets, truth = catalogue
    res = screen_arms(model, arms, targets, top=2, candidates=2)
    assert len(res.mapped) == 2 and set(res.ranking) == set(res.mapped)
    full = screen_arms(model, arms, targets, top=2)
    assert res.complete == (len(full.mapped) <= 2)


@pytest.mark.parametrize("kw, message", [
    ({"top": 0}, "top must be a positive integer, got 0"),
    ({"margin": -1.0}, "margin must be a non-negative number of logits \\(inf: the sound bound alone\\), got -1.0"),
    ({"top": 5, "candidates": 2}, "candidates \\(2\\) must be at least top \\(5\\)"),
    ({"candidates": 0}, "candidates must be a positive integer or None, got 0"),
    ({"cost": [1.0, 2.0]}, "cost must be 13 finite numbers \\(one per arm\\), got shape \\(2,\\)"),
    ({"ik": {"starts": -1}}, "starts must be an integer >= 0, got -1"),
])
def test_screening_refuses_bad_settings(model, catalogue, kw, message, monkeypatch):
    arms, targets, _ = catalogue

    def no_work(*a, **k):
        raise AssertionError("the classical map ran")

    monkeypatch.setattr(ws.maps, "constant_orientation_map", no_work)
    with pytest.raises(ValueError, match=message):
        screen_arms(model, arms, targets, **kw)
