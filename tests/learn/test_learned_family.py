"""Map models of an arm family (wsmap.learn.family): the recipe learns, maps come out in node order
for the family's arms, and everything else is refused."""

import re

import numpy as np
import pytest

from wsmap import datasets, learn, robots
from wsmap.learn.family import (
    MapRecipe,
    evaluate_map_model,
    fit_map_model,
    learning_curve,
    map_scores,
    score_maps,
    varying_columns,
)
from wsmap.learn.training_range import ExtrapolationError
from wsmap.paper.specs import PANDA7_TOOLDOWN, PAPER_SPECS


pytestmark = pytest.mark.usefixtures("one_thread")  # tests/conftest.py


# ------------------------------------------------------------------ the recipe learns (exact labels)
@pytest.fixture(scope="module")
def sw_data(tmp_path_factory):
    """300 training and 200 held-out arms of the spherical-wrist family (section 6.2's spec, exact
    labels: milliseconds per arm)."""
    spec = datasets.scaled(PAPER_SPECS["sec62"], 300)
    path = tmp_path_factory.mktemp("sw") / "sec62.npz"
    datasets.build_dataset_files(spec, path, test_samples=200, progress=False)
    return datasets.load_dataset_files(path, datasets.test_path_for(path))


def test_the_recipe_beats_the_family_average_map(sw_data):
    train, test = sw_data
    model, result = fit_map_model(train, MapRecipe(hidden=(64,), epochs=40, lr=3e-3, batch_size=32))
    assert result.stop_reason == "max_epochs" and result.stop_epoch == 40
    hist = result.history.to_frame()
    assert hist["loss"].iloc[-1] < 0.5 * hist["loss"].iloc[0]
    ev = evaluate_map_model(model, test)
    # the baseline a network must beat: each node reachable where most training arms reach it
    average = np.broadcast_to(train.labels.mean(axis=0) > 0.5, test.labels.shape)
    base = score_maps(average, test.labels)
    assert ev["f"] > base["f"] + 0.05, (ev["f"], base["f"])
    assert ev["samples"] == 200 and ev["nodes"] == 9261
    assert ev["tp"] + ev["fn"] == int(test.labels.sum())
    # inputs are the 4 free DH parameters only
    assert [train.feature_names[c] for c in model.config.input_columns] == ["d_3", "d_4", "a_2", "a_3"]
    # predict_maps of the arms equals thresholding the scores of their feature rows
    arms = datasets.arms_from_features(test.features[:5])
    np.testing.assert_array_equal(model.predict_maps(arms), map_scores(model, test.features[:5]) > 0.5)


def test_learning_curve_rows_and_refusals(sw_data):
    train, test = sw_data
    rows = learning_curve(train, test, [40, 120], MapRecipe(hidden=(16,), epochs=3))
    assert [r["train_arms"] for r in rows] == [40, 120]
    assert all(0.0 <= r["f"] <= 1.0 and r["seconds"] > 0 and r["epochs"] == 3 for r in rows)
    with pytest.raises(ValueError, match=re.escape("training sizes must be in [20, 300] (the training arms "
                                                   "available); got [301]")):
        learning_curve(train, test, [40, 301])


def test_score_maps_known_counts():
    truth = np.array([[1, 1, 0, 0], [1, 0, 0, 0]], bool)
    pred = np.array([[1, 0, 1, 0], [1, 0, 0, 0]], bool)
    s = score_maps(pred, truth)
    assert (s["tp"], s["fp"], s["fn"]) == (2, 1, 1)
    assert s["precision"] == pytest.approx(2 / 3) and s["recall"] == pytest.approx(2 / 3)
    assert s["node_error"] == pytest.approx(2 / 8)
    np.testing.assert_allclose(s["f_per_sample"], [0.5, 1.0])


@pytest.mark.parametrize("kwargs, message", [
    (dict(hidden=()), "MapRecipe.hidden must be a non-empty list of positive integers; got ()"),
    (dict(hidden=(8, 0)), "MapRecipe.hidden must be a non-empty list of positive integers; got (8, 0)"),
    (dict(lr=0.0), "MapRecipe.lr must be a positive number; got 0.0"),
    (dict(epochs=0), "MapRecipe.epochs must be a positive integer; got 0"),
    (dict(batch_size=2.5), "MapRecipe.batch_size must be a positive integer; got 2.5"),
    (dict(validation_fraction=0.5), "MapRecipe.validation_fraction must be in (0, 0.5); got 0.5"),
])
def test_recipe_refusals(kwargs, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        MapRecipe(**kwargs)


def test_recipe_from_params_round_trip_and_unknown_keys():
    r = MapRecipe(hidden=(32, 16), epochs=5)
    assert MapRecipe.from_dict(r.to_dict()) == r
    with pytest.raises(ValueError, match=re.escape("unknown map recipe keys ['epoch']")):
        MapRecipe.from_dict({"epoch": 3})


def test_varying_columns():
    X = np.array([[1.0, 2.0, 3.0], [1.0, 2.5, 3.0]])
    assert varying_columns(X) == [1]
    with pytest.raises(ValueError, match=re.escape("features must be a matrix of at least 2 rows; got shape (3,)")):
        varying_columns(X[0])


# ------------------------------------------------------------------ the panda7 family's model
@pytest.fixture(scope="module")
def panda7_model(tmp_path_factory):
    """A small model of 24 panda7 arms (the real 25³ grid and numerical labels)."""
    spec = datasets.scaled(PANDA7_TOOLDOWN, 24)
    path = tmp_path_factory.mktemp("p7") / "panda7.npz"
    datasets.build_dataset(spec, path, progress=False)
    train = datasets.load_dataset(path)
    model, _ = fit_map_model(train, MapRecipe(hidden=(16,), epochs=2))
    return model, train


def test_panda7_maps_come_in_node_order_for_the_family(panda7_model, tmp_path):
    model, train = panda7_model
    scales = train.features[:4, :6]
    arms = robots.family_arm("panda7", scales)
    maps = model.predict_maps(arms)
    assert maps.shape == (4, 15625) and maps.dtype == bool
    np.testing.assert_array_equal(maps, map_scores(model, train.features[:4]) > 0.5)
    # one arm, a batch of any shape, or the scales themselves
    assert model.predict_maps(robots.family_arm("panda7", scales[0])).shape == (15625,)
    np.testing.assert_array_equal(model.predict_maps(scales.reshape(2, 2, 6)), maps.reshape(2, 2, -1))
    # the file round trip gives the same maps (model, meta = wsmap.learn.load(path))
    path = learn.save(model, tmp_path / "panda7_map.pt", dataset_spec=train.spec)
    loaded, meta = learn.load(path)
    np.testing.assert_array_equal(loaded.predict_maps(arms), maps)
    assert meta["map_spec"]["dataset"]["family"] == "panda7"


def test_panda7_model_refuses_other_arms(panda7_model):
    model, train = panda7_model
    with pytest.raises(TypeError, match="the model maps arms of the family 'panda7'"):
        model.predict_maps(robots.puma560())
    for other in ("iiwa14", "ur5e"):  # chains of other arms: the family reads no scales from them
        with pytest.raises(ValueError):
            model.predict_maps(robots.load(other))
    with pytest.raises(ValueError):
        model.predict_maps(np.ones((1, 5)))  # five scales for a family of six
    # inside the family's range but outside what 24 arms covered: refused unless asked
    lo = train.features[:, :6].min(axis=0)
    outside = np.where(lo > 0.71, 0.705, 1.0)[None, :] * np.ones((1, 6))
    with pytest.raises(ExtrapolationError):
        model.predict_maps(outside)
    with pytest.warns(Warning):
        model.predict_maps(outside, allow_extrapolation=True)
    # outside the family: the family's own refusal
    with pytest.raises(ValueError, match="scale"):
        model.predict_maps(np.full((1, 6), 1.5))
