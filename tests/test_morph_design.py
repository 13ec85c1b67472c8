"""wsmap.morph_design: the design space across twist patterns (its features are the canonical
description's, its arms the DH tables it says), the surrogate's gradient, the searches' answers
checked per task by reachable(), and the refusals."""

import math
import warnings

import numpy as np
import pytest
import torch

import wsmap
from wsmap import design, learn
from wsmap import morph_design as md
from wsmap.kinematics import from_dh
from wsmap.kinematics.morphology import describe
from wsmap.kinematics.transforms import rpy2r
from wsmap.learn import morph_model as mm


@pytest.fixture(scope="module")
def space():
    return md.MorphDesignSpace()


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    torch.set_num_threads(1)
    root = tmp_path_factory.mktemp("morphdesign")
    sets, _ = mm.build_morph_shards(root, 6, 1, 8, step=0.5)
    tc = learn.TrainConfig(optimizer="adam", optimizer_kwargs={"lr": 3e-3}, loss="crossentropy", batch_size=4,
                           lr_decay="cosine", max_epochs=4, max_fail=1000, fractions=(0.9, 0.1, 0.0))
    m, _ = mm.fit_morph_model(sets, mm.MorphModelConfig(encoder=(32,), latent=16, decoder=(32,)), tc)
    return m


def _random_designs(space, k, seed, zeros=0.5):
    rng = np.random.default_rng(seed)
    p = rng.uniform(space.low, space.high, size=(k, space.n_params))
    m = space.n_free
    p[:, m:2 * m] *= rng.random((k, m)) >= zeros  # many zero lengths: intersecting axes
    return p


def test_names_bounds_and_twist_codes(space):
    assert space.n_params == 15 and space.params[:2] == ("d_1", "d_2") and space.params[-1] == "twist_6"
    assert space.low[0] == 0 and space.high[0] == 0.45 and space.low[1] == -0.7 and space.high[5] == 0.7
    assert md.pattern_of([0.0, 0.32, 0.34, 0.66, 0.67, 1.0]).tolist() == [0, 0, 1, 1, 2, 2]
    assert len(space.patterns()) == 3 ** 5
    assert np.array_equal(md.pattern_of(space.codes(space.patterns())), space.patterns())


def test_tables_arms_and_length_are_the_design(space):
    m = space.n_free
    # a UR-like pattern: +pi/2, 0, 0, +pi/2, -pi/2
    p = np.concatenate([[0.16, 0.3, 0.2, 0.13, 0.1], [0.0, 0.42, 0.39, 0.0, 0.0], space.codes([1, 0, 0, 1, 2])])
    rows = space.tables(p)[0]
    assert np.allclose(rows[:, 1], [0, math.pi / 2, 0, 0, math.pi / 2, -math.pi / 2])
    # d_2 and d_3 sit on axes parallel to the next one: held at 0, not in the length
    assert np.allclose(rows[:, 2], [0.16, 0.0, 0.0, 0.13, 0.1, 0.0]) and np.allclose(rows[1:, 0], p[m:2 * m])
    assert space.total_length(p) == pytest.approx(0.16 + 0.13 + 0.1 + 0.42 + 0.39)
    assert float(space.total_length(torch.as_tensor(p))) == pytest.approx(float(space.total_length(p)))
    arm = space.arms(p[None])[0]
    ref = from_dh(rows[:, 2], rows[:, 0], rows[:, 1], qlim=np.tile([-math.pi, math.pi], (6, 1)), modified=True)
    q = np.random.default_rng(0).uniform(-3, 3, (20, 6))
    assert np.allclose(arm.fkine(q), ref.fkine(q), atol=1e-12)


def test_features_are_the_canonical_description(space):
    p = _random_designs(space, 200, seed=3)
    F = space.features(p).numpy()
    C = np.stack([describe(space.arms(p[i:i + 1])[0]).features() for i in range(len(p))])
    assert np.abs(F - C).max() < 1e-12


def test_features_gradient_matches_differences_inside_a_cell(space):
    p = _random_designs(space, 6, seed=4, zeros=0.0)
    x = torch.tensor(p, requires_grad=True)
    w = torch.as_tensor(np.random.default_rng(5).standard_normal(73))
    (space.features(x) @ w).sum().backward()
    m = space.n_free
    h = 1e-6
    for j in range(2 * m):
        e = np.zeros(space.n_params)
        e[j] = h
        fd = ((space.features(p + e).numpy() - space.features(p - e).numpy()) @ w.numpy()) / (2 * h)
        assert np.allclose(x.grad[:, j].numpy(), fd, atol=1e-6)
    assert torch.all(x.grad[:, 2 * m:] == 0)  # twist codes: no gradient


def test_surrogate_margins_are_the_model_at_the_tasks(space, model):
    tasks = np.array([[0.4, 0.0, 0.3], [0.0, -0.5, 0.2]])
    s = md.MorphSurrogate(model, space, tasks)
    p = _random_designs(space, 3, seed=6)
    g = s(torch.as_tensor(p))
    t = model.threshold
    for i in range(3):
        arm = space.arms(p[i:i + 1])[0]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            pred = mm.predict_morph_map(model, arm, tasks, allow_extrapolation=True)
        assert np.array_equal(pred, (g[i] > 1e-6).numpy()) or np.all(np.abs(g[i].numpy()) < 1e-4)
        X = torch.as_tensor(describe(arm).features()[None], dtype=torch.float32)
        with torch.no_grad():
            ref = model.logits_at(X, torch.as_tensor(tasks, dtype=torch.float32))[0].double() - math.log(t / (1 - t))
        assert torch.allclose(g[i], ref, atol=1e-4)


def _check_each_task(space, params, tasks):
    """Per task: reachable() with 128 starts of another seed, its solutions confirmed by FK."""
    arm = space.arms(np.asarray(params)[None])[0]
    T = np.stack([wsmap.transl(p) for p in tasks])
    T[:, :3, :3] = rpy2r(space.rpy)
    ok, q = wsmap.reachable(arm, T, starts=128, seed=11, return_q=True)
    assert np.allclose(arm.fkine(q[ok]), T[ok], atol=1e-8)
    return ok


def test_gradient_search_answer_is_checked_per_task(space, model):
    tasks = np.array([[0.35, 0.0, 0.25], [0.0, 0.35, 0.25], [-0.3, 0.0, 0.3]])
    pats = space.patterns()[::20]
    r = md.design_across_morphologies(model, tasks, space, patterns=pats, starts_per_pattern=1, steps=40,
                                      max_rounds=2, verify_top=4)
    assert r.params.shape == (space.n_params,) and r.total_length == pytest.approx(float(space.total_length(r.params)))
    check = _check_each_task(space, r.params, tasks)
    assert np.all(check[r.covered])  # every task the verification covers is reachable
    assert r.verified == bool(r.covered.all()) and (not r.verified or check.all())
    assert r.classical_calls <= 2 * 4 + 1 and r.surrogate_evals >= 40 * len(pats)


def test_cmaes_finds_a_verified_arm_on_the_classical_map(space):
    tasks = np.array([[0.35, 0.0, 0.25], [0.0, 0.35, 0.25]])
    r = design.design_by_cmaes(space, tasks, max_calls=600, seed=1)
    assert r.verified and _check_each_task(space, r.params, tasks).all()
    assert 0 < r.total_length < space.total_length(space.high)


def test_refusals_before_any_work(space, model):
    with pytest.raises(TypeError, match="MorphMapModel"):
        md.MorphSurrogate(object(), space, [[0.3, 0, 0.3]])
    with pytest.raises(ValueError, match=r"task 1 at \[2.0, 0.0, 0.0\] m lies outside the model's box"):
        md.MorphSurrogate(model, space, [[0.3, 0, 0.3], [2.0, 0, 0]])
    with pytest.raises(ValueError, match="trained on morph6, not on 7-joint arms"):
        md.MorphSurrogate(model, md.MorphDesignSpace(n_joints=7), [[0.3, 0, 0.3]])
    with pytest.raises(ValueError, match="n_joints must be 6 or 7"):
        md.MorphDesignSpace(n_joints=5)
    with pytest.raises(ValueError, match="limits must be finite"):
        md.MorphDesignSpace(limits=[[1, -1]] * 6)
    with pytest.raises(ValueError, match=r"patterns must be twist indices \(P, 5\)"):
        md.design_across_morphologies(model, [[0.3, 0, 0.3]], space, patterns=[[0, 1, 3, 0, 0]])
    with pytest.raises(ValueError, match="starts_per_pattern must be a positive integer"):
        md.design_across_morphologies(model, [[0.3, 0, 0.3]], space, starts_per_pattern=0)
    with pytest.raises(ValueError, match="unknown design method 'grid'"):
        md.compare_morph_designs(model, [[0.3, 0, 0.3]], space, methods=("grid",))
    with pytest.raises(ValueError, match="every start design must be finite and inside the bounds"):
        design.design_by_gradient(space, [[0.3, 0, 0.3]], md.MorphSurrogate(model, space, [[0.3, 0, 0.3]]),
                                  starts=np.full((1, 15), 5.0))
