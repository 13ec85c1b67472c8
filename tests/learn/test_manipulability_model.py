"""The spherical-wrist family's manipulability map: exact batch maps, the learned model, its metrics."""

import re

import numpy as np
import pytest
import torch

from wsmap import learn, robots
from wsmap import workspace as ws
from wsmap.kinematics import ikine_spherical_wrist
from wsmap.learn import ExtrapolationError, ExtrapolationWarning, ModelFileError

NODES = ws.cartesian_grid(-1.0, 1.0, 0.1)


def node_index(p):
    return int(np.argmin(np.linalg.norm(NODES - np.asarray(p), axis=1)))


@pytest.fixture(scope="module")
def tiny():
    torch.set_num_threads(1)
    X, Y = learn.manipulability_dataset(40, seed=3)
    config = learn.ManipulabilityTrainConfig(hidden=(16,), max_epochs=6, time_limit_s=None, lr_decay=None,
                                             batch_size=16, lr=3e-3, val_fraction=0.1, seed=0)
    model, result = learn.train_manipulability_model(X, Y, config)
    return X, Y, model, result


# ------------------------------------------------------------------ exact maps
def test_the_grid_is_the_paper_sec61_grid_and_pose():
    g = learn.manipulability_grid()
    np.testing.assert_array_equal(g["nodes"], NODES)
    assert g["nodes"].shape == (9261, 3) and g["rpy"] == (0.0, 0.0, 0.0)
    assert g["convention"] == "paper" and g["spec"] == "sec61"
    from wsmap.datasets import grid_nodes
    from wsmap.paper.specs import paper_spec

    spec = paper_spec("sec61")
    assert (spec.lo, spec.hi, spec.step, tuple(spec.fixed), spec.convention) == (
        g["lo"], g["hi"], g["step"], g["rpy"], g["convention"])
    np.testing.assert_array_equal(grid_nodes(spec), g["nodes"])


@pytest.mark.parametrize("rpy, convention", [((0.0, 0.0, 0.0), "paper"), ((0.3, 1.0, -2.0), "standard"),
                                              ((0.3, 1.0, -2.0), "paper")])
def test_batched_exact_maps_equal_the_per_arm_definition(rpy, convention):
    arms = robots.sample_spherical_wrist(4, seed=11)
    nodes = ws.cartesian_grid(-1.0, 1.0, 0.2)
    maps = ws.manipulability_maps(arms, nodes, rpy, convention=convention)
    assert maps.shape == (4, len(nodes)) and maps.dtype == np.float64
    for i in range(4):
        ref = ws.manipulability_map(arms[i], nodes, rpy, convention=convention)
        np.testing.assert_array_equal(maps[i] > 0, ref > 0)
        np.testing.assert_allclose(maps[i], ref, rtol=0, atol=1e-12)
    puma = robots.puma560()
    np.testing.assert_allclose(ws.manipulability_maps(puma, nodes, rpy, convention=convention),
                               ws.manipulability_map(puma, nodes, rpy, convention=convention), rtol=0, atol=1e-12)
    # any batch shape
    grid = robots.spherical_wrist(a2=arms.a[:, 1].reshape(2, 2), a3=arms.a[:, 2].reshape(2, 2),
                                  d3=arms.d[:, 2].reshape(2, 2), d4=arms.d[:, 3].reshape(2, 2))
    np.testing.assert_array_equal(ws.manipulability_maps(grid, nodes, rpy, convention=convention),
                                  maps.reshape(2, 2, -1))


def test_batched_exact_maps_refuse_what_they_cannot_map():
    with pytest.raises(ValueError, match=re.escape("manipulability_maps is for arms without joint limits; use "
                                                   "manipulability_map per arm")):
        ws.manipulability_maps(robots.puma560(joint_limits=True), NODES[:5])
    with pytest.raises(ValueError, match="needs arms of the spherical-wrist family"):
        ws.manipulability_maps(robots.sample_arbitrary_6dof(2, seed=0), NODES[:5])
    with pytest.raises(TypeError, match="arms must be a DHRobot of the spherical-wrist family, got str"):
        ws.manipulability_maps("puma", NODES[:5])


def test_dataset_targets_are_the_definition_per_arm_and_known_values():
    X, Y = learn.manipulability_dataset(3, seed=5)
    assert X.shape == (3, 4) and X.dtype == np.float64 and Y.shape == (3, 9261) and Y.dtype == np.float32
    # the draw order of sample_spherical_wrist: (d3, d4, a2, a3)
    np.testing.assert_array_equal(X, np.random.default_rng(5).uniform(0.0, 0.5, size=(3, 4)))
    arms = robots.sample_spherical_wrist(3, seed=5)
    for i in range(3):
        ref = ws.manipulability_map(arms[i], NODES, (0.0, 0.0, 0.0), convention="paper")
        np.testing.assert_allclose(Y[i], ref, rtol=1e-5, atol=1e-7)
    # a2 = d4 = 0.5 m, d3 = a3 = 0: at (0.5, 0, 0.5) the elbow is square, the wrist centre 0.5 m off
    # the base axis and the forearm can lie horizontal, so |det J| = a2·d4·1·0.5·1 = 0.125 m³
    m = learn.manipulability_targets([0.0, 0.5, 0.5, 0.0])
    assert m.shape == (9261,)
    assert m[node_index((0.5, 0.0, 0.5))] == pytest.approx(0.125, abs=1e-12)
    assert m[node_index((1.0, 0.0, 0.0))] == pytest.approx(0.0, abs=1e-6)  # stretched: elbow singular
    assert m[node_index((1.0, 0.0, 0.1))] == 0.0  # out of reach
    assert m[node_index((0.0, 0.0, 0.0))] == 0.0  # on the shoulder axis: shoulder singular


def test_targets_agree_with_robotics_toolbox_at_reachable_nodes():
    rtb = pytest.importorskip("roboticstoolbox")
    params = np.array([0.12, 0.35, 0.41, 0.08])
    arm = robots.spherical_wrist(a2=params[2], a3=params[3], d3=params[0], d4=params[1])
    m = learn.manipulability_targets(params)
    rob = rtb.DHRobot([rtb.RevoluteDH(d=d, a=a, alpha=al) for d, a, al in zip(arm.d, arm.a, arm.alpha)])
    idx = np.flatnonzero(m > 0)[:: max(1, np.count_nonzero(m) // 5)][:5]
    assert idx.size == 5
    T = ws.target_poses(NODES[idx], (0.0, 0.0, 0.0), "paper")
    sol = ikine_spherical_wrist(arm, T)
    q, valid = sol.q, sol.success
    for k, node in enumerate(idx):
        theirs = max(rob.manipulability(qi, method="yoshikawa") for qi in q[k][valid[k]])
        assert m[node] == pytest.approx(theirs, rel=1e-9, abs=1e-12)


# ------------------------------------------------------------------ the model
def test_a_tiny_model_trains_and_predicts(tiny):
    X, Y, model, result = tiny
    loss = np.ravel(np.asarray(result.history.loss, dtype=np.float64))
    assert loss[-1] < loss[0]
    assert isinstance(model, learn.ManipulabilityModel) and model.target == "linear" and model.scale > 0
    P = learn.predict_manipulability(model, X[:5])
    assert P.shape == (5, 9261) and P.dtype == np.float32 and np.all(P >= 0)
    one = learn.predict_manipulability(model, X[0])
    assert one.shape == (9261,)
    np.testing.assert_allclose(one, P[0], rtol=1e-5, atol=1e-7)
    arms = robots.spherical_wrist(a2=X[:5, 2], a3=X[:5, 3], d3=X[:5, 0], d4=X[:5, 1])
    np.testing.assert_allclose(learn.predict_manipulability(model, arms), P, rtol=1e-5, atol=1e-7)
    assert model.network.training_range.names == learn.PARAM_NAMES


def test_the_default_config_does_not_depend_on_the_machine_speed(monkeypatch):
    """The default is an epoch budget: a machine 1000 times slower (a clock that jumps 1000 s at
    every reading) trains the same model, epoch for epoch, as a fast one."""
    import dataclasses

    from wsmap.learn import training

    default = learn.ManipulabilityTrainConfig()
    assert default.time_limit_s is None and default.lr_decay == "cosine" and default.max_epochs == 60
    X, Y = learn.manipulability_dataset(24, seed=5)
    config = dataclasses.replace(default, hidden=(8,), max_epochs=5, batch_size=8, val_fraction=0.25)

    def run():
        torch.manual_seed(123)  # anything the config's seed does not reach would show up here
        model, result = learn.train_manipulability_model(X, Y, config)
        return [p.detach().clone() for p in model.network.parameters()], result

    fast, fast_result = run()
    clock = iter(range(0, 10**9, 1000))
    monkeypatch.setattr(training.time, "perf_counter", lambda: float(next(clock)))
    slow, slow_result = run()
    assert slow_result.history.time[-1] >= 1000  # the slow clock did run
    assert slow_result.stop_epoch == fast_result.stop_epoch == [5]
    for a, b in zip(fast, slow):
        torch.testing.assert_close(a, b, rtol=0, atol=0)


def test_the_sqrt_target_round_trips():
    net = learn.SubspaceMLP(learn.MLPConfig(n_inputs=4, n_outputs=9261, hidden=[4]))
    model = learn.ManipulabilityModel(net, "sqrt", 0.2)
    maps = np.array([[0.0, 0.01, 0.25]])
    np.testing.assert_allclose(model.encode(maps), [[0.0, 0.5, 2.5]], rtol=1e-6)
    np.testing.assert_allclose(model.decode(model.encode(maps)), maps, rtol=1e-6)
    assert model.decode(np.array([-1.0]))[0] == 0.0


def test_save_load_round_trip(tiny, tmp_path):
    X, _, model, _ = tiny
    path = learn.save_manipulability_model(model, tmp_path / "m.pt")
    back, meta = learn.load_manipulability_model(path)
    assert (back.target, back.scale, back.grid) == (model.target, model.scale, model.grid)
    assert meta["extra"]["kind"] == learn.MANIPULABILITY_KIND and meta["extra"]["output_unit"] == "m^3"
    np.testing.assert_array_equal(learn.predict_manipulability(back, X[:3]), learn.predict_manipulability(model, X[:3]))
    with pytest.raises(ExtrapolationError, match=re.escape("d3 = 0.9 is outside the trained range")):
        learn.predict_manipulability(back, [0.9, 0.2, 0.2, 0.2])
    other = learn.SubspaceMLP(learn.MLPConfig(n_inputs=4, n_outputs=3, hidden=[2]))
    learn.save(other, tmp_path / "other.pt")
    with pytest.raises(ModelFileError, match=re.escape(
            f"cannot load model {tmp_path / 'other.pt'}: not a manipulability model (extra kind None, expected "
            "'wsmap.manipulability')")):
        learn.load_manipulability_model(tmp_path / "other.pt")


# ------------------------------------------------------------------ metrics
def test_regression_metrics_of_known_arrays():
    true = np.array([[0.0, 1.0], [2.0, 3.0]])
    pred = np.array([[0.5, 1.0], [2.0, 2.0]])
    m = learn.regression_metrics(pred, true)
    # pooled: mean 1.5, SST 5, SSE 1.25; reachable (true > 0): mean 2, SST 2, SSE 1
    assert m["r2"] == pytest.approx(0.75) and m["mae"] == pytest.approx(0.375)
    assert m["r2_reachable"] == pytest.approx(0.5) and m["mae_reachable"] == pytest.approx(1 / 3)
    assert m["max_abs_error"] == pytest.approx(1.0) and (m["n_values"], m["n_reachable"]) == (4, 3)
    perfect = learn.regression_metrics(true, true)
    assert perfect["r2"] == 1.0 and perfect["mae"] == 0.0 and perfect["max_abs_error"] == 0.0
    assert np.isnan(learn.regression_metrics(np.ones(3), np.zeros(3))["r2"])
    assert np.isnan(learn.regression_metrics(np.ones(3), np.zeros(3))["r2_reachable"])


def test_regression_metrics_refuse_bad_arrays():
    with pytest.raises(ValueError, match=re.escape("pred and true must have the same shape; got (2, 3) and (3, 2)")):
        learn.regression_metrics(np.zeros((2, 3)), np.zeros((3, 2)))
    with pytest.raises(ValueError, match=re.escape("pred and true are empty")):
        learn.regression_metrics(np.zeros(0), np.zeros(0))
    with pytest.raises(ValueError, match=re.escape("pred and true must be finite")):
        learn.regression_metrics(np.array([np.nan]), np.array([1.0]))


# ------------------------------------------------------------------ bad input
SHAPE = "parameters must be (4,) or (B, 4) with B >= 1, columns (d3, d4, a2, a3) in m; got shape {}"


@pytest.mark.parametrize("bad", [np.zeros(3), np.zeros((2, 5)), np.zeros((0, 4)), np.zeros((1, 2, 4))])
def test_predict_refuses_wrong_shapes(tiny, bad):
    model = tiny[2]
    with pytest.raises(ValueError, match=re.escape(SHAPE.format(bad.shape))):
        learn.predict_manipulability(model, bad)


def test_predict_refuses_parameters_and_arms_outside_the_family(tiny):
    model = tiny[2]
    with pytest.raises(ValueError, match=re.escape("parameters contain NaN or infinite values")):
        learn.predict_manipulability(model, [0.1, np.nan, 0.1, 0.1])
    with pytest.raises(ExtrapolationError, match=re.escape(
            "the model refuses: the arm is outside its training range: a3 = -0.2 is outside the trained range")):
        learn.predict_manipulability(model, [0.1, 0.1, 0.1, -0.2])
    with pytest.raises(ExtrapolationError, match=re.escape("2 of 2 arms are outside its training range: "
                                                           "arm 0: d4 = 0.7 is outside the trained range")):
        learn.predict_manipulability(model, [[0.1, 0.7, 0.1, 0.1], [0.1, 0.8, 0.1, 0.1]])
    with pytest.warns(ExtrapolationWarning, match="Predicting anyway"):
        out = learn.predict_manipulability(model, [0.1, 0.7, 0.1, 0.1], allow_extrapolation=True)
    assert out.shape == (9261,)
    with pytest.raises(ValueError, match=re.escape("arms must have d1 = 0: the family's base height is fixed at 0 "
                                                   "and is not an input")):
        learn.predict_manipulability(model, robots.spherical_wrist(0.3, 0.1, 0.1, 0.3, d1=0.2))
    with pytest.raises(ValueError, match=re.escape("arms must have no joint limits: the family's maps (and the "
                                                   "paper's) ignore them")):
        learn.predict_manipulability(model, robots.puma560(joint_limits=True))
    with pytest.raises(ValueError, match=re.escape("arms must be of the spherical-wrist family (d = [d1, 0, d3, d4, "
                                                   "0, 0], a = [0, a2, a3, 0, 0, 0], alpha = [pi/2, 0, -pi/2, pi/2, "
                                                   "-pi/2, 0], no tool)")):
        learn.predict_manipulability(model, robots.sample_arbitrary_6dof(2, seed=0))
    with pytest.raises(TypeError, match=re.escape("expected a DHRobot of the spherical-wrist family or parameters "
                                                  "(B, 4) (d3, d4, a2, a3); got str")):
        learn.predict_manipulability(model, "puma")
    with pytest.raises(TypeError, match=re.escape("model must be a ManipulabilityModel; got SubspaceMLP")):
        learn.predict_manipulability(model.network, [0.1, 0.1, 0.1, 0.1])


def test_training_and_the_model_refuse_bad_input():
    X = np.full((4, 4), 0.2)
    with pytest.raises(ValueError, match=re.escape("targets must be (B, 9261) = (4, 9261) for 4 arms; got shape "
                                                   "(4, 9260)")):
        learn.train_manipulability_model(X, np.zeros((4, 9260), dtype=np.float32))
    with pytest.raises(ValueError, match=re.escape("targets must be finite and non-negative (manipulability maps "
                                                   "in m^3)")):
        learn.train_manipulability_model(X, np.full((4, 9261), -1.0, dtype=np.float32))
    with pytest.raises(ValueError, match=re.escape("training needs parameters (B, 4), not one arm")):
        learn.train_manipulability_model(X[0], np.zeros((1, 9261), dtype=np.float32))
    with pytest.raises(ValueError, match=re.escape("target must be one of ['linear', 'sqrt']; got 'log'")):
        learn.ManipulabilityTrainConfig(target="log")
    with pytest.raises(ValueError, match=re.escape("val_fraction must lie in (0, 1); got 0.0")):
        learn.ManipulabilityTrainConfig(val_fraction=0.0)
    net = learn.SubspaceMLP(learn.MLPConfig(n_inputs=84, n_outputs=9261, hidden=[2]))
    with pytest.raises(ValueError, match=re.escape("a manipulability network has 4 inputs (d3, d4, a2, a3), one "
                                                   "subspace and linear outputs; got n_inputs=84, n_subspaces=1, "
                                                   "output_kind='linear'")):
        learn.ManipulabilityModel(net, "linear", 1.0)
    net4 = learn.SubspaceMLP(learn.MLPConfig(n_inputs=4, n_outputs=9261, hidden=[2]))
    with pytest.raises(ValueError, match=re.escape("scale must be a positive finite number; got 0.0")):
        learn.ManipulabilityModel(net4, "linear", 0.0)
