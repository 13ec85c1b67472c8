"""The model as a stand-in for the classical algorithm: map_spec, predict_maps, files, the CLI."""

import re
import subprocess
import sys

import numpy as np
import pytest
import torch

from wsmap import cli, datasets, robots
from wsmap import workspace as ws
from wsmap.kinematics import DHRobot
from wsmap.learn.files import load, payload_checksum, save
from wsmap.learn.mapspec import make_map_spec
from wsmap.learn.network import MLPConfig, SubspaceMLP
from wsmap.learn.predictor import check_model_grid, predict_maps_from_file
from wsmap.learn.training import TrainConfig, split_indices, train
from wsmap.paper.specs import PAPER_SPECS
from wsmap.workspace.maps import register_map_predictor

torch.set_num_threads(1)  # tiny models; other work shares the CPU

SEC62 = PAPER_SPECS["sec62"]  # the 21³ grid on [-1, 1] m, all 9261 nodes, orientation 0
SMALL = datasets.scaled(PAPER_SPECS["table1_r3_step05"], 800)  # 5³ = 125 nodes, 36 features


def F(pred, truth):
    return 2 * np.sum(pred & truth) / (np.sum(pred) + np.sum(truth))


def family_features(spec, n=500, seed=0):
    """Features of ``n`` arms of the spherical-wrist family for ``spec``: the training range of a
    model of that family (what ``configure`` records from real training data)."""
    return datasets.features_for(robots.sample_spherical_wrist(n, seed=seed), spec)


def pattern_model(patterns, n_inputs, hidden=(3,)):
    """A logit model whose subspace k outputs ``patterns[k]`` (bool, (m,)) for every input: zero
    output weights, output bias +4 / -4. Predictions then show the output order exactly. Give it
    a training range (``set_training_range``) before predicting maps."""
    patterns = np.atleast_2d(np.asarray(patterns, dtype=bool))
    S, m = patterns.shape
    model = SubspaceMLP(MLPConfig(n_inputs=n_inputs, n_outputs=m, hidden=list(hidden), n_subspaces=S,
                                  output_kind="logit", init="torch"))
    with torch.no_grad():
        model.weights[-1].zero_()
        model.biases[-1].copy_(torch.as_tensor(np.where(patterns, 4.0, -4.0)))
    return model


@pytest.fixture(scope="module")
def puma_map():
    """PUMA560's exact 9261-node map on the sec62 grid (the classical algorithm)."""
    return ws.constant_orientation_map(robots.puma560(), datasets.grid_nodes(SEC62))


@pytest.fixture(scope="module")
def block_model(puma_map):
    """7 block subspaces of 1323 nodes that reproduce PUMA560's map when assembled."""
    model = pattern_model(puma_map.reshape(7, 1323), SEC62.n_features).set_map_spec(SEC62, assemble=True)
    return model.set_training_range(family_features(SEC62))


@pytest.fixture(scope="module")
def trained():
    """The improved recipe in miniature (4 free DH inputs standardised, logits, cross-entropy, Adam
    in minibatches) on 800 arms of the 125-node grid: ~2 s."""
    arms, _ = datasets.draw_samples(SMALL)
    X, Y = datasets.features_for(arms, SMALL), datasets.labels_for(arms, SMALL)
    cfg = MLPConfig(n_inputs=X.shape[1], n_outputs=Y.shape[1], hidden=[32, 32], init="torch",
                    input_columns=[2, 3, 7, 8], input_scaling="standardize", output_kind="logit")
    sp = split_indices(len(X), (0.85, 0.15, 0.0), 0)
    torch.manual_seed(0)
    model = SubspaceMLP(cfg).configure(X[sp.train])
    res = train(model, X, Y, TrainConfig(optimizer="adam", optimizer_kwargs={"lr": 1e-2}, batch_size=32,
                                         loss="crossentropy", max_epochs=25, max_fail=50), split=sp)
    return model.set_map_spec(SMALL), res


# ---------------------------------------------------------------------------------------------
# predict_maps
# ---------------------------------------------------------------------------------------------


def test_trained_model_round_trip_and_predict_equals_predict_on_features(tmp_path, trained):
    model, res = trained
    assert res.history.loss[-1][0] < 0.5 * res.history.loss[0][0]
    path = save(model, tmp_path / "m.pt", dataset_spec=SMALL, train_config=res.config)
    loaded, meta = load(path)
    assert loaded.map_spec == model.map_spec == meta["map_spec"]
    assert loaded.map_spec == {"dataset": SMALL.to_dict(), "nodes": [0, 125], "assemble": False, "subspace": 0,
                               "threshold": 0.5}
    arms, _ = datasets.draw_samples(datasets.test_spec(SMALL, 200))
    maps = loaded.predict_maps(arms)
    assert maps.dtype == np.bool_ and maps.shape == (200, 125)
    X = datasets.features_for(arms, SMALL)
    np.testing.assert_array_equal(loaded.map_features(arms), X)  # built from a cached row: same values
    np.testing.assert_array_equal(maps, loaded.predict(X).numpy()[0])
    np.testing.assert_array_equal(maps, model.predict_maps(arms))
    np.testing.assert_array_equal(maps, predict_maps_from_file(path, arms))
    # batches and thresholds
    np.testing.assert_array_equal(loaded.predict_maps(arms, batch_size=7), maps)
    scores = loaded.score(X).numpy()[0]
    np.testing.assert_array_equal(loaded.predict_maps(arms, threshold=0.9), scores > 0.9)
    assert (loaded.predict_maps(arms, threshold=0.9) <= maps).all()


def test_trained_model_maps_in_classical_node_order(trained):
    model, _ = trained
    arms, _ = datasets.draw_samples(datasets.test_spec(SMALL, 200))
    truth = ws.constant_orientation_map(arms, model.map_nodes())
    np.testing.assert_array_equal(model.map_nodes(), ws.cartesian_grid(-1, 1, 0.5))
    pred = model.predict_maps(arms)
    assert F(pred, truth) > 0.9
    # The map is not symmetric under swapping x and z: the same predictions score far worse
    # against the classical map in that order.
    swapped = ws.volume_to_map(np.swapaxes(ws.map_to_volume(truth, (5, 5, 5)), -1, -3))
    assert F(pred, swapped) < F(pred, truth) - 0.08


def test_assembled_blocks_give_the_classical_map(block_model, puma_map):
    puma = robots.puma560()
    pred = block_model.predict_maps(puma)
    assert pred.shape == (9261,) and pred.dtype == np.bool_
    np.testing.assert_array_equal(pred, puma_map)
    np.testing.assert_array_equal(block_model.map_nodes(), ws.cartesian_grid(-1, 1, 0.1))
    assert block_model.map_spec["nodes"] == [0, 9261] and block_model.map_spec["assemble"]
    # batches of any shape: (..., 9261)
    arms = DHRobot(np.broadcast_to(puma.d, (2, 3, 6)), puma.a, puma.alpha)
    out = block_model.predict_maps(arms)
    assert out.shape == (2, 3, 9261) and (out == puma_map).all()


def test_node_slice_and_selected_spec(puma_map):
    block5 = slice(5292, 6615)
    puma = robots.puma560()
    one = pattern_model(puma_map[block5], SEC62.n_features).set_training_range(family_features(SEC62))
    # one block model trained on columns 5292..6614 of the whole-grid labels
    one.set_map_spec(SEC62, nodes=(5292, 6615))
    np.testing.assert_array_equal(one.predict_maps(puma), ws.constant_orientation_map(puma, one.map_nodes()))
    np.testing.assert_array_equal(one.map_nodes(), datasets.grid_nodes(SEC62)[block5])
    # the section 6.1 spec labels exactly that block: the default coverage is the same
    one.set_map_spec(PAPER_SPECS["sec61"])
    assert one.map_spec["nodes"] == [5292, 6615]
    np.testing.assert_array_equal(one.predict_maps(puma), puma_map[block5])


def test_so3_spec_matches_orientation_map():
    spec = PAPER_SPECS["table1_so3_pi3"]  # 7³ = 343 angle nodes at the point (0.5, 0.5, 0.5)
    arms, _ = datasets.draw_samples(datasets.scaled(spec, 50))
    maps = ws.orientation_map(arms, datasets.grid_nodes(spec), spec.fixed, convention=spec.convention)
    k = int(np.flatnonzero((maps.sum(1) > 0) & (maps.sum(1) < 343))[0])  # an arm reaching some orientations
    arm, truth = arms[k], maps[k]
    model = pattern_model(truth, spec.n_features).set_map_spec(spec).set_training_range(datasets.features_for(arms, spec))
    np.testing.assert_array_equal(model.predict_maps(arm), truth)
    np.testing.assert_array_equal(model.map_nodes(), ws.angle_grid(0, 2 * np.pi, np.pi / 3))
    # an SO3 map's poses differ between the conventions (R·p against p): the other one is refused
    check_model_grid(model, convention="paper")
    with pytest.raises(ValueError, match=re.escape("convention standard (model: paper)")):
        check_model_grid(model, convention="standard")


def test_random_orientation_spec_needs_fixed():
    spec = PAPER_SPECS["table3_workspace"]  # one random orientation per sample, block 5
    model = SubspaceMLP(MLPConfig(n_inputs=spec.n_features, n_outputs=1323, hidden=[4])).set_map_spec(spec)
    arms, fixed = datasets.draw_samples(datasets.scaled(spec, 5))
    model.set_training_range(datasets.features_for(arms, spec, fixed))
    with pytest.raises(ValueError, match="pass fixed"):
        model.predict_maps(arms)
    out = model.predict_maps(arms, fixed)
    np.testing.assert_array_equal(out, model.predict(datasets.features_for(arms, spec, fixed)).numpy()[0])


# ---------------------------------------------------------------------------------------------
# errors
# ---------------------------------------------------------------------------------------------


def test_errors_of_predict_maps(block_model):
    puma = robots.puma560()
    bare = SubspaceMLP(MLPConfig(n_inputs=84, n_outputs=1323, hidden=[3]))
    assert bare.map_spec is None
    with pytest.raises(ValueError, match="no map_spec"):
        bare.predict_maps(puma)
    with pytest.raises(ValueError, match="6-joint arms .* got arms with 5 joints"):
        block_model.predict_maps(DHRobot(puma.d[:5], puma.a[:5], puma.alpha[:5]))
    with pytest.raises(ValueError, match="NaN"):  # the constructor refuses NaN ...
        DHRobot(np.r_[np.nan, puma.d[1:]], puma.a, puma.alpha)
    arms = robots.sample_spherical_wrist(4, seed=0)
    arms.d = arms.d.copy()
    arms.d[2, 3] = np.nan  # ... but the arrays can be replaced afterwards
    with pytest.raises(ValueError, match=r"DH column d contains NaN or infinite values \(arms \[2\]\)"):
        block_model.predict_maps(arms)
    with pytest.raises(ValueError, match="joint limits"):
        block_model.predict_maps(robots.puma560(joint_limits=True))
    with pytest.raises(ValueError, match=r"trained at the fixed orientation \(rad\) \[0.0, 0.0, 0.0\] only"):
        block_model.predict_maps(puma, fixed=(0.1, 0.0, 0.0))
    with pytest.raises(TypeError, match="DHRobot"):
        block_model.predict_maps(np.zeros((1, 18)))


def test_map_spec_validation():
    model = SubspaceMLP(MLPConfig(n_inputs=84, n_outputs=1323, hidden=[3], n_subspaces=7))
    with pytest.raises(ValueError, match="has 7 subspaces: set assemble=True"):
        model.set_map_spec(SEC62)
    with pytest.raises(ValueError, match=r"covers 1323 nodes \[0, 1323\) but the model gives 9261"):
        model.set_map_spec(SEC62, nodes=(0, 1323), assemble=True)
    with pytest.raises(ValueError, match="not within the nodes"):
        model.set_map_spec(PAPER_SPECS["sec61"], nodes=(0, 1323), subspace=2)
    with pytest.raises(ValueError, match="subspace must be an integer in 0..6"):
        model.set_map_spec(SEC62, nodes=(0, 1323), subspace=7)
    with pytest.raises(ValueError, match="unknown map_spec keys"):
        model.map_spec = {**make_map_spec(SEC62), "grid": 1}
    with pytest.raises(ValueError, match="threshold must be a finite number"):
        model.set_map_spec(SEC62, assemble=True, threshold=float("nan"))
    # one subspace of a stack stands for one block
    model.set_map_spec(SEC62, nodes=(1323, 2646), subspace=1, threshold=0.3)
    assert model.map_spec == {"dataset": SEC62.to_dict(), "nodes": [1323, 2646], "assemble": False,
                              "subspace": 1, "threshold": 0.3}
    copy = model.map_spec
    copy["threshold"] = 0.9  # the getter hands out a copy
    assert model.map_spec["threshold"] == 0.3
    model.map_spec = None
    assert model.map_spec is None


def test_load_refuses_an_invalid_map_spec(tmp_path, block_model):
    path = save(block_model, tmp_path / "m.pt")
    payload = torch.load(path, weights_only=True)
    payload["map_spec"]["nodes"] = [0, 1323]
    torch.save(payload, path)  # an edit without a new checksum is corruption
    with pytest.raises(ValueError, match="checksum mismatch"):
        load(path)
    torch.save({**payload, "checksum": payload_checksum(payload)}, path)  # a deliberate, re-sealed edit
    with pytest.raises(ValueError, match="invalid map_spec: map_spec covers 1323 nodes"):
        load(path)
    payload["map_spec"] = None
    torch.save({**payload, "checksum": payload_checksum(payload)}, path)
    assert load(path)[0].map_spec is None


# ---------------------------------------------------------------------------------------------
# workspace.grid_map(method="model"): registered by wsmap.learn.predictor
# ---------------------------------------------------------------------------------------------


def test_grid_map_model_method_is_the_predictor(tmp_path, block_model, puma_map):
    path = save(block_model, tmp_path / "puma_blocks.pt")
    grid = ws.grid_spec("R3", -1, 1, 0.1)
    flat, used = ws.grid_map(robots.puma560(), grid, method="model", model=path, return_method=True)
    assert used == "model"
    np.testing.assert_array_equal(flat, predict_maps_from_file(path, robots.puma560(), (0.0, 0.0, 0.0), grid=grid,
                                                               whole_grid=True))
    np.testing.assert_array_equal(flat, puma_map)
    with pytest.raises(TypeError, match="map predictor 'x' must be callable, got str"):
        register_map_predictor("x", "not a function")


def test_grid_map_model_method_needs_the_learned_library():
    """A classical user's wsmap.workspace has no "model" method until wsmap.learn is imported, and says so."""
    code = ("import sys, wsmap.robots as r, wsmap.workspace as ws\n"
            "from wsmap.workspace.maps import MAP_PREDICTORS\n"
            "try:\n"
            "    ws.grid_map(r.puma560(), ws.grid_spec('R3', step=0.5), method='model', model='m.pt')\n"
            "except ValueError as e:\n"
            "    print(e)\n"
            "assert 'torch' not in sys.modules\n"
            "import wsmap.learn\n"
            "print(sorted(MAP_PREDICTORS))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.splitlines()
    assert out == ["method 'model' is supplied by wsmap.learn (trained networks, needs torch): import wsmap.learn first",
                   "['model']"]


# ---------------------------------------------------------------------------------------------
# the command line: wsmap map --method model
# ---------------------------------------------------------------------------------------------


def test_cli_model_map_equals_predict_maps(tmp_path, block_model, puma_map):
    path = save(block_model, tmp_path / "puma_blocks.pt")
    out = tmp_path / "map.npz"
    assert cli.main(["map", "--robot", "puma560", "--method", "model", "--model", str(path), "--quiet",
                     "--out", str(out)]) == 0
    flat, nodes, grid, settings = ws.load_map(out)
    np.testing.assert_array_equal(flat, block_model.predict_maps(robots.puma560()))
    np.testing.assert_array_equal(flat, puma_map)  # the pattern model reproduces the classical map
    np.testing.assert_array_equal(nodes, block_model.map_nodes())
    assert grid["shape"] == [21, 21, 21] and settings["method"] == "model" and settings["model"] == str(path)
    # a DH-column arm goes through the same path
    arm = robots.sample_spherical_wrist(1, seed=3)[0]
    out2 = tmp_path / "arm.npz"
    argv = ["map", "--d", *map(str, arm.d), "--a", *map(str, arm.a), "--alpha", *map(str, arm.alpha),
            "--method", "model", "--model", str(path), "--quiet", "--out", str(out2)]
    assert cli.main(argv) == 0
    np.testing.assert_array_equal(ws.load_map(out2)[0], block_model.predict_maps(arm))


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--step", "0.5"], "maps a different grid: step [0.5, 0.5, 0.5] (model: [0.1, 0.1, 0.1])"),
        (["--scope", "SO3"], "maps a different grid: scope SO3 (model: R3)"),
        (["--rpy", "0", "0", "pi/2"], "trained at the fixed orientation"),
        (["--joint-limits"], "joint limits"),
    ],
)
def test_cli_model_refuses_what_the_model_cannot_map(tmp_path, capsys, block_model, extra, message):
    path = save(block_model, tmp_path / "blocks.pt")
    out = tmp_path / "x.npz"
    assert cli.main(["map", "--method", "model", "--model", str(path), *extra, "--quiet", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err, err
    assert not out.exists()


def test_cli_model_needs_a_whole_grid_model_with_a_map_spec(tmp_path, capsys, puma_map):
    one = pattern_model(puma_map[5292:6615], SEC62.n_features).set_map_spec(SEC62, nodes=(5292, 6615))
    one.set_training_range(family_features(SEC62))
    sliced = save(one, tmp_path / "block5.pt")
    one.map_spec = None
    bare = save(one, tmp_path / "bare.pt")
    for path, message in ((sliced, "covers nodes [5292, 6615) of its grid's 9261 only"),
                          (bare, "has no map_spec"), (tmp_path / "missing.pt", "no such file")):
        out = tmp_path / "x.npz"
        assert cli.main(["map", "--method", "model", "--model", str(path), "--quiet", "--out", str(out)]) == 2
        assert message in capsys.readouterr().err
        assert not out.exists()
