"""Families of arms (wsmap.robots.FAMILIES, one definition for the whole package); the panda7 family
(scaled Franka Panda) and its tool-down experience, built in one process or on Dask."""

import re
import socket
import time
import warnings

import numpy as np
import pytest

from wsmap import datasets, robots
from wsmap import workspace as ws
from wsmap.cli import main
from wsmap.kinematics import SerialChain
from wsmap.paper.specs import DATASET_SPECS, EXTENSION_SPECS, PAPER_SPECS, PANDA7_TOOLDOWN, dataset_spec

NOMINAL = np.array([0.333, 0.316, 0.384, 0.0825, -0.0825, 0.088])  # d1, d3, d5, a4, a5, a7 (m)


pytestmark = pytest.mark.usefixtures("one_thread")  # tests/conftest.py


def _fk_at_zero_by_hand(s):
    """Flange pose at q = 0 from Franka's modified-DH table (worked out by hand): the arm stands up,
    the a-offsets along base x, the flange (d = 0.107 m) pointing down."""
    T = np.eye(4)
    T[:3, :3] = np.diag([1.0, -1.0, -1.0])  # Rx(pi)
    T[0, 3] = 0.0825 * s[3] - 0.0825 * s[4] + 0.088 * s[5]
    T[2, 3] = 0.333 * s[0] + 0.316 * s[1] + 0.384 * s[2] - 0.107
    return T


# --------------------------------------------------------------------------- the family
def test_scales_of_one_give_the_panda():
    panda, arm = robots.load("panda"), robots.family_arm("panda7", np.ones(6))
    assert isinstance(arm, SerialChain) and arm.batch_shape == () and arm.n == 7 and arm.name == "panda7"
    q = np.random.default_rng(0).uniform(panda.qlim[:, 0], panda.qlim[:, 1], size=(200, 7))
    np.testing.assert_array_equal(arm.fkine(q), panda.fkine(q))
    np.testing.assert_array_equal(arm.qlim, panda.qlim)
    np.testing.assert_array_equal(robots.PANDA7.nominal, NOMINAL)
    np.testing.assert_allclose(arm.fkine(np.zeros(7)), _fk_at_zero_by_hand(np.ones(6)), atol=1e-15)


def test_scaled_lengths_by_hand_and_batch_shape():
    rng = np.random.default_rng(1)
    scales = rng.uniform(0.7, 1.3, size=(2, 3, 6))
    arms = robots.family_arm("panda7", scales)
    assert arms.batch_shape == (2, 3)
    T0 = arms.fkine(np.zeros(7))
    assert T0.shape == (2, 3, 4, 4)
    for idx in np.ndindex(2, 3):
        np.testing.assert_allclose(T0[idx], _fk_at_zero_by_hand(scales[idx]), atol=1e-14)
    # each scaled length sits in its fixed transform (modified DH: a_{i-1} before joint i, d_i after it)
    F = arms.fixed
    np.testing.assert_allclose(F[..., 1, 2, 3], 0.333 * scales[..., 0], rtol=1e-15)
    np.testing.assert_allclose(F[..., 3, 2, 3], 0.316 * scales[..., 1], rtol=1e-15)
    np.testing.assert_allclose(F[..., 5, 2, 3], 0.384 * scales[..., 2], rtol=1e-15)
    np.testing.assert_allclose(F[..., 3, 0, 3], 0.0825 * scales[..., 3], rtol=1e-15)
    np.testing.assert_allclose(F[..., 4, 0, 3], -0.0825 * scales[..., 4], rtol=1e-15)
    np.testing.assert_allclose(F[..., 6, 0, 3], 0.088 * scales[..., 5], rtol=1e-15)
    # one arm of a batch is that arm alone; away from q = 0 too
    q = rng.uniform(-1, 1, size=7)
    np.testing.assert_allclose(arms.fkine(q)[1, 2], robots.family_arm("panda7", scales[1, 2]).fkine(q), atol=1e-15)
    np.testing.assert_allclose(robots.family_params("panda7", arms), scales, rtol=1e-15)


def test_sampling_is_deterministic_in_range_and_a_prefix():
    arms, s = robots.sample_family("panda7", 50, seed=7)
    arms2, s2 = robots.sample_family("panda7", 50, seed=np.random.default_rng(7))
    np.testing.assert_array_equal(s, s2)
    np.testing.assert_array_equal(arms.fixed, arms2.fixed)
    np.testing.assert_array_equal(arms.fixed, robots.family_arm("panda7", s).fixed)
    assert s.shape == (50, 6) and arms.batch_shape == (50,)
    assert s.min() >= 0.7 and s.max() < 1.3 and s.min() < 0.75 and s.max() > 1.25
    np.testing.assert_array_equal(robots.sample_family("panda7", 5, seed=7)[1], s[:5])
    assert not np.array_equal(robots.sample_family("panda7", 5, seed=8)[1], s[:5])


def test_refusals_name_the_problem():
    with pytest.raises(ValueError, match=re.escape("unknown arm family 'panda8'; known families: spherical_wrist, "
                                                   "arbitrary_6dof, puma560, panda7, morph6, morph7")):
        robots.family_arm("panda8", np.ones(6))
    with pytest.raises(ValueError, match="known families: spherical_wrist, arbitrary_6dof, puma560, panda7, morph6, morph7"):
        robots.sample_family("ur", 3, seed=0)
    bad = np.ones((2, 6))
    bad[1, 4] = 1.35
    with pytest.raises(ValueError) as e:
        robots.family_arm("panda7", bad)
    assert str(e.value) == ("scale of a5 (arm 1) is 1.35, outside the range [0.7, 1.3] of family 'panda7'; "
                            "pass allow_extrapolation=True to build the arm anyway")
    with pytest.raises(ValueError) as e:
        robots.family_arm("panda7", [0.69, 1, 1, 1, 1, 1])
    assert str(e.value) == ("scale of d1 is 0.69, outside the range [0.7, 1.3] of family 'panda7'; "
                            "pass allow_extrapolation=True to build the arm anyway")
    for shape in [(5,), (), (3, 7), (0,)]:
        with pytest.raises(ValueError, match=re.escape(
                f"scales of family 'panda7' must have shape (..., 6): one factor per parameter "
                f"(d1, d3, d5, a4, a5, a7) in that order, got shape {shape}")):
            robots.family_arm("panda7", np.ones(shape))
    with pytest.raises(ValueError, match="must be numbers of shape"):
        robots.family_arm("panda7", "one")
    with pytest.raises(ValueError, match=re.escape("scale of a4 is nan: scales must be positive and finite")):
        robots.family_arm("panda7", [1, 1, 1, np.nan, 1, 1])
    with pytest.raises(ValueError, match=re.escape("scale of d3 is -1.0: scales must be positive and finite")):
        robots.family_arm("panda7", [1, -1, 1, 1, 1, 1], allow_extrapolation=True)
    with pytest.raises(ValueError, match="allow_extrapolation must be True or False"):
        robots.family_arm("panda7", np.ones(6), allow_extrapolation="yes")
    with pytest.raises(ValueError, match="count must be a positive integer"):
        robots.sample_family("panda7", 0, seed=0)
    with pytest.raises(ValueError, match="not of family 'panda7'"):
        robots.family_params("panda7", robots.load("iiwa14"))
    with pytest.raises(ValueError, match="not of family 'panda7'"):
        robots.family_params("panda7", robots.load("panda", joint_limits=False))


def test_extrapolation_builds_with_a_loud_warning():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        arm = robots.family_arm("panda7", [1, 1, 1, 1, 1.35, 1.5], allow_extrapolation=True)
    assert [w.category for w in caught] == [robots.FamilyRangeWarning]
    assert str(caught[0].message).startswith("scale of a5 is 1.35, outside the range [0.7, 1.3] of family 'panda7' "
                                             "(and 1 more scale(s) out of range); built anyway")
    assert caught[0].filename == __file__  # points at the caller
    np.testing.assert_allclose(arm.fkine(np.zeros(7)), _fk_at_zero_by_hand([1, 1, 1, 1, 1.35, 1.5]), atol=1e-15)


# --------------------------------------------------------------------------- every family, one list
def test_one_list_of_families_used_everywhere():
    from wsmap import design
    from wsmap.learn import manipulability

    assert list(robots.FAMILIES) == ["spherical_wrist", "arbitrary_6dof", "puma560", "panda7", "morph6", "morph7"]
    assert datasets.FAMILIES == tuple(robots.FAMILIES) and datasets.CHAIN_FAMILIES == ("panda7", "morph6", "morph7")
    assert [f.exact for f in robots.FAMILIES.values()] == [True, False, True, False, False, False]
    for name, fam in design.DESIGN_FAMILIES.items():
        assert fam.family is robots.FAMILIES[name] and sorted(fam.params) == sorted(fam.family.params)
    assert design.DESIGN_FAMILIES["spherical_wrist"].method == "exact"
    assert design.DESIGN_FAMILIES["panda7"].method == "numerical"
    assert manipulability.PARAM_NAMES == robots.SPHERICAL_WRIST.params == ("d3", "d4", "a2", "a3")
    assert manipulability.FAMILY_RANGE == (0.0, 0.5)
    spec = datasets.DatasetSpec("x", family="arbitrary_6dof", method="numerical", beta=0.3)
    assert spec.arm_family.name == "arbitrary_6dof" and (spec.arm_family.low, spec.arm_family.high) == (0.0, 0.3)
    assert PANDA7_TOOLDOWN.arm_family is robots.PANDA7


def test_dh_families_are_the_paper_samplers_and_read_back():
    # the paper's draws: (count, 4) U(0, beta) in the order d3, d4, a2, a3, and (count, 3, 6) rows d, a, alpha
    u = np.random.default_rng(3).uniform(0.0, 0.4, size=(5, 4))
    sw = robots.sample_spherical_wrist(5, seed=3, beta=0.4)
    by_hand = robots.spherical_wrist(a2=u[:, 2], a3=u[:, 3], d3=u[:, 0], d4=u[:, 1])
    for k in ("d", "a", "alpha"):
        np.testing.assert_array_equal(getattr(sw, k), getattr(by_hand, k))
    arms, params = robots.sample_family("spherical_wrist", 5, seed=3)
    np.testing.assert_array_equal(robots.family_params("spherical_wrist", arms), params)
    np.testing.assert_array_equal(robots.family_params("spherical_wrist", robots.puma560()),
                                  [0.15005, 0.4318, 0.4318, 0.0203])
    u = np.random.default_rng(4).uniform(0.0, 0.5, size=(3, 3, 6))
    arb = robots.sample_arbitrary_6dof(3, seed=4)
    np.testing.assert_array_equal(np.stack([arb.d, arb.a, arb.alpha], axis=1), u)
    np.testing.assert_array_equal(robots.family_params("arbitrary_6dof", arb), u.reshape(3, 18))
    puma, none = robots.sample_family("puma560", 2, seed=0)
    assert none.shape == (2, 0) and puma.batch_shape == (2,)
    np.testing.assert_array_equal(puma.a, np.tile(robots.puma560().a, (2, 1)))
    with pytest.raises(ValueError, match=re.escape("these arms are not of family 'spherical_wrist'")):
        robots.family_params("spherical_wrist", arb)
    with pytest.raises(ValueError, match=re.escape("these arms are not of family 'spherical_wrist'")):
        robots.family_params("spherical_wrist", robots.puma560(joint_limits=True))
    with pytest.raises(TypeError, match="arms of family 'spherical_wrist' must be a DHRobot, got SerialChain"):
        robots.family_params("spherical_wrist", robots.load("panda"))
    with pytest.raises(ValueError) as e:
        robots.family_arm("spherical_wrist", [0.1, 0.2, 0.3, 0.6])
    assert str(e.value) == ("a3 is 0.6, outside the range [0.0, 0.5] of family 'spherical_wrist'; "
                            "pass allow_extrapolation=True to build the arm anyway")
    with pytest.raises(ValueError, match=re.escape("parameters of family 'spherical_wrist' must have shape (..., 4)")):
        robots.family_arm("spherical_wrist", np.ones(3))
    with pytest.raises(ValueError, match=re.escape("beta must be positive and finite, got 0")):
        robots.sample_spherical_wrist(3, beta=0)
    with pytest.raises(ValueError, match=re.escape("the range of family 'spherical_wrist' must have low < high")):
        robots.SPHERICAL_WRIST.with_range(high=-1.0)


# --------------------------------------------------------------------------- the spec
def test_panda7_tooldown_spec():
    s = PANDA7_TOOLDOWN
    assert dataset_spec("panda7_tooldown") is s and "panda7_tooldown" in DATASET_SPECS
    assert "panda7_tooldown" not in PAPER_SPECS and set(EXTENSION_SPECS) == {"panda7_tooldown", "panda7_tooldown_free"}
    assert (s.family, s.scope, s.convention, s.method, s.fixed) == ("panda7", "R3", "standard", "numerical",
                                                                     (np.pi, 0.0, 0.0))
    assert s.grid_shape == (25, 25, 25) and s.n_nodes == 15625 and s.n_features == 6 + 75 + 3
    nodes = datasets.spec_nodes(s)
    np.testing.assert_allclose(nodes[[0, 1, 25, 625, -1]],
                               [[-1.2, -1.2, -1.2], [-1.1, -1.2, -1.2], [-1.2, -1.1, -1.2], [-1.2, -1.2, -1.1],
                                [1.2, 1.2, 1.2]], atol=1e-12)  # first coordinate fastest
    names = datasets.feature_names(s)
    assert names[:6] == ["scale_d1", "scale_d3", "scale_d5", "scale_a4", "scale_a5", "scale_a7"]
    assert names[6] == "n_x_1" and names[-3:] == ["r_1", "r_2", "r_3"] and len(names) == s.n_features
    T = ws.target_poses(nodes[:1], s.fixed, s.convention)[0]  # tool down: transl(p)·Rx(pi)
    np.testing.assert_allclose(T[:3, :3], np.diag([1.0, -1.0, -1.0]), atol=1e-15)
    np.testing.assert_allclose(T[:3, 3], nodes[0])
    assert datasets.DatasetSpec.from_dict(s.to_dict()) == s
    # defaults of the family: the 1.2 m grid
    t = datasets.DatasetSpec("t", family="panda7", method="numerical", step=0.6)
    assert (t.lo, t.hi) == (-1.2, 1.2)


@pytest.mark.parametrize("changes, message", [
    (dict(method="exact"), "family 'panda7' has no closed form"),
    (dict(fixed="random"), "family 'panda7' needs a fixed orientation"),
    (dict(starts=20), "starts=20 would change nothing"),
    (dict(beta=1.0, tol=1e-9), "tol=1e-09, beta=1.0 would change nothing"),
])
def test_spec_refuses_what_the_family_cannot_honour(changes, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        PANDA7_TOOLDOWN.replace(**changes)


def test_features_and_labels_of_the_family():
    spec = datasets.scaled(PANDA7_TOOLDOWN, 3).replace(step=0.3)  # 9³ nodes: fast
    arms, fixed = datasets.draw_samples(spec)
    scales = datasets.draw_scales(spec)
    np.testing.assert_array_equal(arms.fixed, robots.family_arm("panda7", scales).fixed)
    X = datasets.features_for(scales, spec, fixed)
    assert X.shape == (3, spec.n_features)
    np.testing.assert_array_equal(X[:, :6], scales)
    np.testing.assert_allclose(datasets.features_for(arms, spec), X, rtol=1e-15)  # scales read back from the chains
    np.testing.assert_array_equal(datasets.arms_from_features(X, spec).fixed, arms.fixed)
    L = datasets.labels_for(arms, spec, fixed)
    np.testing.assert_array_equal(L, datasets.labels_for(scales, spec))
    ref = ws.constant_orientation_map(arms, datasets.spec_nodes(spec), (np.pi, 0, 0), method="numerical",
                                      convention="standard")
    np.testing.assert_array_equal(L, ref)
    assert 0 < L.sum() < L.size
    with pytest.raises(ValueError, match="has no closed form"):
        datasets.labels_for(arms, spec, method="exact")
    with pytest.raises(ValueError, match="q0 sets the paper's LM starts"):
        datasets.labels_for(arms, spec, q0=np.zeros((1, 7)))
    with pytest.raises(TypeError, match="not a DHRobot"):
        datasets.features_for(robots.puma560(), spec)
    with pytest.raises(ValueError, match="outside the range"):
        datasets.features_for(np.full((1, 6), 2.0), spec)
    with pytest.raises(ValueError, match="no scale factors"):
        datasets.draw_scales(PAPER_SPECS["sec61"])


# --------------------------------------------------------------------------- dataset files
SMALL = datasets.scaled(PANDA7_TOOLDOWN, 6)  # the real 25³ grid, 6 arms


@pytest.fixture(scope="module")
def single_process(tmp_path_factory):
    """The single-process build of 6 arms: (path, bytes)."""
    path = tmp_path_factory.mktemp("single") / "panda7.npz"
    datasets.build_dataset(SMALL, path, progress=False)
    return path, path.read_bytes()


def test_build_is_deterministic_checksummed_and_labelled_by_the_map(single_process, tmp_path):
    path, raw = single_process
    ds = datasets.load_dataset(path, expect_spec=SMALL)
    assert ds.features.shape == (6, 84) and ds.labels.shape == (6, 15625)
    np.testing.assert_array_equal(ds.features[:, :6], robots.sample_family(
        "panda7", 6, seed=np.random.default_rng(np.random.SeedSequence(1401, spawn_key=(0, 0))))[1])
    arm0 = robots.family_arm("panda7", ds.features[0, :6])
    nodes = ws.cartesian_grid(-1.2, 1.2, 0.1)
    np.testing.assert_array_equal(ds.labels[0], ws.constant_orientation_map(
        arm0, nodes, (np.pi, 0, 0), method="numerical", convention="standard",
        ik={"border_starts": 0, "fk_seeds": 0}))
    # the map's default search adds its border search and its global seeding to what the labels run:
    # only nodes, only a few
    full = ws.constant_orientation_map(arm0, nodes, (np.pi, 0, 0), method="numerical", convention="standard")
    assert not (ds.labels[0] & ~full).any() and (full & ~ds.labels[0]).sum() <= 0.001 * full.sum()
    assert (ds.labels.mean(axis=1) > 0.05).all()
    # the first 3 arms again, by the command line: the same rows, and the same bytes twice
    out = tmp_path / "three.npz"
    assert main(["data", "build", "panda7_tooldown", "--samples", "3", "--test-samples", "1", "--out", str(out),
                 "--quiet"]) == 0
    first = out.read_bytes()
    train, test = datasets.load_dataset_files(out)
    np.testing.assert_array_equal(train.features, ds.features[:3])
    np.testing.assert_array_equal(train.labels, ds.labels[:3])
    assert test.spec.stream == "test" and len(test) == 1
    datasets.build_dataset(datasets.scaled(PANDA7_TOOLDOWN, 3), out, progress=False)
    assert out.read_bytes() == first
    # the checksum guards the labels
    flipped = bytearray(first)
    body = bytes(flipped).find(b"labels_packed.npy")
    assert body > 0
    damaged = tmp_path / "damaged.npz"
    flipped[body + 200] ^= 0x10
    damaged.write_bytes(bytes(flipped))
    with pytest.raises(datasets.DatasetError, match=re.escape(str(damaged))):
        datasets.load_dataset(damaged)


def test_dask_build_is_byte_identical(single_process, tmp_path):
    _, raw = single_process
    out = tmp_path / "dask.npz"
    datasets.build_dataset(SMALL, out, chunk=1, progress=False, workers=2)  # 6 tasks on 2 single-threaded processes
    assert out.read_bytes() == raw


def test_dask_build_of_a_paper_dataset_is_byte_identical(tmp_path):
    spec = datasets.scaled(PAPER_SPECS["table3_workspace"], 50)  # exact labels, one random orientation per arm
    datasets.build_dataset(spec, tmp_path / "single.npz", progress=False)
    datasets.build_dataset(spec, tmp_path / "dask.npz", chunk=7, progress=False, workers=2)
    assert (tmp_path / "dask.npz").read_bytes() == (tmp_path / "single.npz").read_bytes()


def test_unreachable_scheduler_fails_fast_and_writes_nothing(tmp_path):
    with socket.socket() as sock:  # a free local port: nothing listens there
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    out = tmp_path / "new" / "panda7.npz"
    t0 = time.perf_counter()
    with pytest.raises(datasets.SchedulerError, match=re.escape(f"no Dask scheduler answered at {address!r} within 2 s")):
        datasets.build_dataset_files(SMALL, out, test_samples=2, scheduler=address, connect_timeout=2, progress=False)
    assert time.perf_counter() - t0 < 10
    assert not (tmp_path / "new").exists()
    # the command line: one line, exit code 2, nothing written
    assert main(["data", "build", "panda7_tooldown", "--samples", "2", "--out", str(out), "--scheduler", address,
                 "--connect-timeout", "1", "--quiet"]) == 2
    assert not (tmp_path / "new").exists()


def test_cluster_arguments_are_checked():
    with pytest.raises(ValueError, match="give one or the other"):
        datasets.build_dataset_files(SMALL, "x.npz", workers=2, scheduler="tcp://127.0.0.1:1")
    with pytest.raises(ValueError, match="workers must be at least 1"):
        datasets.build_dataset(SMALL, "x.npz", workers=0)
    with pytest.raises(ValueError, match="scheduler must be a Dask scheduler address"):
        datasets.build_dataset(SMALL, "x.npz", scheduler=8786)
    with pytest.raises(ValueError, match="connect_timeout must be a positive number"):
        datasets.build_dataset(SMALL, "x.npz", scheduler="tcp://127.0.0.1:1", connect_timeout=0)
    assert main(["data", "build", "panda7_tooldown", "--out", "x.npz", "--workers", "2", "--scheduler",
                 "tcp://127.0.0.1:1"]) == 2
