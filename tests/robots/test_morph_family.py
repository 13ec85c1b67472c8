"""The morph6 / morph7 families: deterministic draws, canonical parameters, the range, the named
arms held out (and inside the range), and their datasets rebuilt byte for byte."""

import warnings

import numpy as np
import pytest

import wsmap
from wsmap import datasets
from wsmap.kinematics import from_dh
from wsmap.kinematics.morphology import describe, morphology_distance
from wsmap.robots import FAMILIES, FamilyRangeWarning
from wsmap.robots.morph import HELD_OUT, HOLD_OUT_RADIUS, MORPH6, MORPH7, held_out_features, morph_params, morphology_of

FAMS = [MORPH6, MORPH7]


def _angle_close(a, b, atol=1e-9):
    return np.abs(np.angle(np.exp(1j * (a - b)))) <= atol


@pytest.mark.parametrize("fam", FAMS, ids=lambda f: f.name)
def test_draws_are_deterministic_prefixes_and_canonical(fam):
    P = fam.draw(40, 3)
    assert P.shape == (40, 6 * fam.n_joints + 6) and fam.n_params == P.shape[1]
    assert np.array_equal(fam.draw(15, 3), P[:15])
    assert not np.array_equal(fam.draw(15, 4), P[:15])
    assert all(not fam.problems(p) for p in P)
    back = fam.params_of(fam.arms(P))
    assert np.allclose(back, P, atol=1e-9)  # the parameters are the canonical description
    # arms(P) and each parameter row's morphology are the same arms
    q = np.random.default_rng(0).uniform(-3, 3, (40, fam.n_joints))
    one = np.stack([morphology_of(p).chain().fkine(qq) for p, qq in zip(P, q)])
    assert np.abs(fam.arms(P).fkine(q) - one).max() < 1e-12


def test_the_distribution_looks_like_real_arms():
    P = MORPH7.draw(300, 0)
    per = P[:, :42].reshape(300, 7, 6)
    alpha = per[:, 1:, 1]
    special = np.isclose(np.abs(alpha)[..., None], [0.0, np.pi / 2, np.pi], atol=1e-9).any(axis=-1)
    assert 0.75 < special.mean() < 0.95  # mostly 0 / ±pi/2 (up to the canonical sign), some general
    assert np.mean(per[:, :, 0] == 0) > 0.4 and per[:, :, 0].max() <= 0.7  # many zero lengths, none > 0.7 m
    width = per[:, :, 5] - per[:, :, 4]
    assert np.isclose(width, 2 * np.pi).mean() > 0.2 and width.min() >= 2.8 - 1e-9
    bound = np.sqrt(per[:, :, 0] ** 2 + per[:, :, 2] ** 2).sum(axis=1) + np.linalg.norm(P[:, 42:45], axis=1)
    assert bound.max() <= 1.8 + 1e-9 and bound.min() >= 0.4


def test_no_training_arm_is_near_a_held_out_arm():
    """The metric: morphology_distance (metres; lengths as they are, angles 0.2 m per unit of
    sin/cos, half-ranges 0.1 m per rad); no drawn arm within HOLD_OUT_RADIUS = 0.1 m of any of the
    six named arms, in the training streams of the benchmark's and the tests' seeds."""
    held = np.stack(list(held_out_features().values()))
    assert list(held_out_features()) == list(HELD_OUT)
    for fam in FAMS:
        for seed in (0, 1):
            F = np.stack([morphology_of(p).features() for p in fam.draw(300, seed)])
            d = morphology_distance(F[:, None, :], held[None, :, :])
            assert d.min() > HOLD_OUT_RADIUS, (fam.name, seed)
    # the held-out random arms (the test stream) are not training arms either
    spec = datasets.DatasetSpec("m", family="morph6", method="numerical", fixed=(np.pi, 0, 0), samples=50, seed=0,
                                convention="standard", step=0.5)
    train = datasets.draw_scales(spec)
    test = datasets.draw_scales(datasets.test_spec(spec, 50))
    Ft = np.stack([morphology_of(p).features() for p in train])
    Fs = np.stack([morphology_of(p).features() for p in test])
    assert morphology_distance(Fs[:, None], Ft[None]).min() > 0.05


@pytest.mark.parametrize("name", HELD_OUT)
def test_named_arms_are_inside_the_range_of_their_family(name):
    """Held out of the training data, but inside the distribution: a model is asked about them."""
    arm = wsmap.load(name)
    fam = FAMILIES[f"morph{arm.n}"]
    p = fam.params_of(arm)
    assert fam.problems(p) == []
    q = np.random.default_rng(1).uniform(-3, 3, (50, arm.n))
    m = describe(arm)
    # the family's arm of those parameters is the named arm (joint 1 counted the other way for Gen3)
    assert np.abs(fam.arms(p).fkine(q * m.signs) - wsmap.kinematics.as_chain(arm).fkine(q)).max() < 1e-12


def test_range_refusals_and_extrapolation():
    p = MORPH6.params_of(wsmap.load("ur5e"))
    long = p.copy()
    long[6 * 2] = 0.9  # a_3
    with pytest.raises(ValueError, match=r"outside family 'morph6': a_3 = 0.9 m is outside \[0, 0.7\]; pass "
                                         "allow_extrapolation=True"):
        MORPH6.arms(long)
    with pytest.warns(FamilyRangeWarning, match="a_3 = 0.9 m"):
        arm = MORPH6.arms(long, allow_extrapolation=True)
    assert arm.n == 6
    narrow = p.copy()
    narrow[6 * 1 + 4: 6 * 1 + 6] = (-1.0, 1.0)
    with pytest.raises(ValueError, match="joint 2 moves 2 rad, under the family's least range 2.8 rad"):
        MORPH6.check_params(narrow)
    with pytest.raises(ValueError, match=r"must have shape \(\.\.\., 42\)"):
        MORPH6.check_params(np.zeros(41))
    with pytest.raises(ValueError, match="must be finite"):
        MORPH6.check_params(np.full(42, np.nan))
    with pytest.raises(ValueError, match="have 7 joints, got 6"):
        MORPH7.params_of(wsmap.load("ur5e"))
    tilted = wsmap.load("ur5e").replace(base=np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]]))
    with pytest.raises(ValueError, match="first joint axis is not the base z axis"):
        MORPH6.params_of(tilted)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        MORPH6.check_params(p)


def test_dataset_of_a_morph_family_rebuilds_byte_for_byte(tmp_path):
    spec = datasets.DatasetSpec("m7", family="morph7", method="numerical", fixed=(np.pi, 0, 0), convention="standard",
                                samples=3, seed=2, step=0.5)
    assert spec.grid_shape == (7, 7, 7) and spec.lo == -1.5 and spec.n_arm_features == 48
    assert datasets.feature_names(spec)[:6] == ["a_1", "alpha_1", "d_1", "theta_1", "lo_1", "hi_1"]
    a, b = tmp_path / "a.npz", tmp_path / "b.npz"
    datasets.build_dataset(spec, a, progress=False)
    datasets.build_dataset(spec, b, chunk=1, progress=False)
    assert a.read_bytes() == b.read_bytes()
    ds = datasets.load_dataset(a, expect_spec=spec)
    # the labels are the numerical tool-down map of each arm
    arms = MORPH7.arms(ds.features[:, :48])
    nodes = datasets.spec_nodes(spec)
    for i in range(3):
        want = wsmap.workspace.constant_orientation_map(arms[i], nodes, (np.pi, 0, 0), method="numerical",
                                                        convention="standard")
        assert np.array_equal(ds.labels[i], want)


def test_morph_params_of_a_dh_arm():
    arm = from_dh([0.3, 0, 0, 0.4, 0, 0.1], [0, 0.2, 0.3, 0, 0, 0], [0, np.pi / 2, 0, np.pi / 2, -np.pi / 2, np.pi / 2],
                  modified=True, qlim=np.tile([-2.0, 2.0], (6, 1)))
    p = morph_params(describe(arm))
    assert MORPH6.problems(p) == []
    assert np.allclose(p[[0, 6, 12]], [0, 0.2, 0.3])
