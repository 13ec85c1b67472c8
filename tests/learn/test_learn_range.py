"""The training range (wsmap.learn.training_range): recorded from training data, saved, and enforced by
predict_maps / predict_maps_from_file / ``wsmap map --method model``."""

import warnings

import numpy as np
import pytest
import torch

from wsmap import cli, datasets, robots
from wsmap.kinematics import DHRobot
from wsmap.learn import (
    ExtrapolationError,
    ExtrapolationWarning,
    MLPConfig,
    ModelFileError,
    SubspaceMLP,
    TrainingRange,
    load,
    payload_checksum,
    predict_maps_from_file,
    save,
)
from wsmap.paper.specs import PAPER_SPECS

torch.set_num_threads(1)  # tiny models; the CPU is shared

SMALL = datasets.scaled(PAPER_SPECS["table1_r3_step05"], 300)  # 5³ = 125 nodes, 36 features, spherical wrist


@pytest.fixture(scope="module")
def family():
    arms, _ = datasets.draw_samples(SMALL)
    return arms, datasets.features_for(arms, SMALL)


@pytest.fixture(scope="module")
def model(family):
    _, X = family
    cfg = MLPConfig(n_inputs=X.shape[1], n_outputs=125, hidden=[4], init="torch", output_kind="logit")
    torch.manual_seed(0)
    return SubspaceMLP(cfg).configure(X).set_map_spec(SMALL)


def arm(d=(0, 0, 0.15, 0.43, 0, 0), a=(0, 0.43, 0.02, 0, 0, 0)):
    return DHRobot(np.asarray(d, float), np.asarray(a, float), robots.puma560().alpha)


def test_configure_records_the_range_of_the_training_features(model, family):
    _, X = family
    rng = model.training_range
    assert isinstance(rng, TrainingRange) and rng.samples == len(X)
    np.testing.assert_array_equal(rng.low, X.min(0))
    np.testing.assert_array_equal(rng.high, X.max(0))
    fixed = rng.fixed  # unnamed in memory: "feature j"; d_1 (column 0) is 0 for every arm of the family
    assert fixed["feature 0"] == 0.0 and "feature 2" not in fixed and "feature 3" not in fixed
    # a copy of a subspace keeps it; a stack keeps the intersection
    assert model.subspace(0).training_range == rng
    other = SubspaceMLP(model.config).configure(X[:50])
    stack = SubspaceMLP.from_models([model, other])
    np.testing.assert_array_equal(stack.training_range.low, np.maximum(X.min(0), X[:50].min(0)))
    np.testing.assert_array_equal(stack.training_range.high, np.minimum(X.max(0), X[:50].max(0)))
    bare = SubspaceMLP(model.config)
    assert bare.training_range is None and SubspaceMLP.from_models([model, bare]).training_range is None


def test_disjoint_ranges_do_not_stack(model, family):
    _, X = family
    shifted = SubspaceMLP(model.config).configure(X + np.r_[np.zeros(2), 5.0, np.zeros(X.shape[1] - 3)])
    with pytest.warns(UserWarning, match="training ranges do not overlap"):
        assert SubspaceMLP.from_models([model, shifted]).training_range is None


def test_arms_of_the_family_pass(model):
    test_arms, _ = datasets.draw_samples(datasets.test_spec(SMALL, 1000))  # independent arms of the same family
    maps = model.predict_maps(test_arms)
    assert maps.shape == (1000, 125)
    assert model.predict_maps(robots.puma560()).shape == (125,)


def test_a_9_m_link_is_refused_naming_parameter_value_and_range(model):
    rng = model.training_range
    with pytest.raises(ExtrapolationError) as e:
        model.predict_maps(arm(d=(0, 0, 0.15, 9.0, 0, 0)))
    msg = str(e.value)
    assert isinstance(e.value, ValueError)
    assert f"d_4 = 9 is outside the trained range [{rng.low[3]:.6g}, {rng.high[3]:.6g}]" in msg
    assert "table1_r3_step05" in msg and "allow_extrapolation=True" in msg
    # with allow_extrapolation: a loud warning and the network's answer
    with pytest.warns(ExtrapolationWarning, match="d_4 = 9 is outside the trained range"):
        out = model.predict_maps(arm(d=(0, 0, 0.15, 9.0, 0, 0)), allow_extrapolation=True)
    X = datasets.features_for(datasets.draw_samples(datasets.scaled(SMALL, 1))[0], SMALL)
    X[0, :18] = np.r_[[0, 0, 0.15, 9.0, 0, 0], [0, 0.43, 0.02, 0, 0, 0], robots.puma560().alpha]
    np.testing.assert_array_equal(out, model.predict(X).numpy()[0, 0])


def test_a_fixed_parameter_is_named_with_its_value(model):
    with pytest.raises(ExtrapolationError, match="d_1 = 0.3, but d_1 is fixed at 0 in the training arms"):
        model.predict_maps(arm(d=(0.3, 0, 0.15, 0.43, 0, 0)))
    alpha = robots.puma560().alpha.copy()
    alpha[1] = 1e-3  # a twist the family never has
    with pytest.raises(ExtrapolationError, match="alpha_2 = 0.001, but alpha_2 is fixed at 0"):
        model.predict_maps(DHRobot(arm().d, arm().a, alpha))
    # rounding of a fixed value is inside (pi/2 written out to 1e-9)
    alpha = robots.puma560().alpha + 1e-9
    model.predict_maps(DHRobot(arm().d, arm().a, alpha))


def test_within_tolerance_passes_beyond_it_is_refused(model):
    rng = model.training_range
    hi, width = rng.high[3], rng.high[3] - rng.low[3]
    model.predict_maps(arm(d=(0, 0, 0.15, hi + 0.015 * width, 0, 0)))
    with pytest.raises(ExtrapolationError, match="d_4"):
        model.predict_maps(arm(d=(0, 0, 0.15, hi + 0.03 * width, 0, 0)))


def test_batches_report_how_many_arms_and_which(model):
    arms = robots.sample_spherical_wrist(6, seed=1)
    d = arms.d.copy()
    d[2, 3], d[4, 2] = 2.0, -1.0
    with pytest.raises(ExtrapolationError) as e:
        model.predict_maps(DHRobot(d, arms.a, arms.alpha))
    msg = str(e.value)
    assert "2 of 6 arms are outside" in msg and "arm 4: d_3 = -1" in msg and "arm 2: d_4 = 2" in msg


def test_a_model_without_a_range_refuses_unless_allowed(model):
    bare = SubspaceMLP(model.config).set_map_spec(SMALL)
    with pytest.raises(ExtrapolationError, match="records no training range.*allow_extrapolation=True"):
        bare.predict_maps(robots.puma560())
    with pytest.warns(ExtrapolationWarning, match="records no training range"):
        assert bare.predict_maps(robots.puma560(), allow_extrapolation=True).shape == (125,)


def test_the_range_is_saved_with_names_and_enforced_from_the_file(tmp_path, model):
    path = save(model, tmp_path / "m.pt", dataset_spec=SMALL)
    loaded, meta = load(path)
    rng = loaded.training_range
    assert rng.names == tuple(datasets.feature_names(SMALL)) and rng.samples == model.training_range.samples
    np.testing.assert_array_equal(rng.low, model.training_range.low)
    stored = meta["training_range"]
    assert stored["fixed"]["d_1"] == 0.0 and stored["fixed"]["alpha_1"] == float(np.pi / 2)
    assert stored["fixed"]["r_1"] == 0.0 and "d_3" not in stored["fixed"] and "n_x_1" in stored["fixed"]
    assert stored["low"][3] == rng.low[3] and stored["high"][3] == rng.high[3]
    puma = robots.puma560()
    np.testing.assert_array_equal(predict_maps_from_file(path, puma), model.predict_maps(puma))
    far = arm(d=(0, 0, 0.15, 9.0, 0, 0))
    with pytest.raises(ExtrapolationError, match="d_4 = 9 is outside"):
        predict_maps_from_file(path, far)
    with pytest.warns(ExtrapolationWarning):
        predict_maps_from_file(path, far, allow_extrapolation=True)


def test_save_takes_the_range_from_training_data(tmp_path, model, family):
    arms, X = family
    bare = SubspaceMLP(model.config).set_map_spec(SMALL)

    class Data:  # what wsmap.datasets.load_dataset returns: .features and .spec
        features, spec = X, SMALL

    loaded, _ = load(save(bare, tmp_path / "m.pt", training_data=Data()))
    assert loaded.training_range.names[3] == "d_4"
    np.testing.assert_array_equal(loaded.training_range.high, X.max(0))
    assert bare.training_range is None  # saving does not change the model
    loaded, _ = load(save(bare, tmp_path / "m2.pt", training_data=X[:10]))
    np.testing.assert_array_equal(loaded.training_range.low, X[:10].min(0))


def test_the_command_line_refuses_a_9_m_link(tmp_path, capsys, model):
    path = save(model, tmp_path / "m.pt", dataset_spec=SMALL)
    argv = ["map", "--d", "0", "0", "0.15", "9", "0", "0", "--a", "0", "0.43", "0.02", "0", "0", "0",
            "--alpha", "pi/2", "0", "-pi/2", "pi/2", "-pi/2", "0", "--step", "0.5", "--method", "model",
            "--model", str(path), "--quiet", "--out", str(tmp_path / "o.npz")]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "d_4 = 9 is outside the trained range" in err
    assert not (tmp_path / "o.npz").exists()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert cli.main([*argv, "--allow-extrapolation"]) == 0
    assert any(issubclass(w.category, ExtrapolationWarning) for w in caught)


def test_random_orientation_columns_are_checked_too():
    spec = datasets.scaled(PAPER_SPECS["table3_workspace"], 200)  # one random orientation per arm
    arms, fixed = datasets.draw_samples(spec)
    model = SubspaceMLP(MLPConfig(n_inputs=spec.n_features, n_outputs=1323, hidden=[3]))
    model.configure(datasets.features_for(arms, spec, fixed)).set_map_spec(spec)
    model.predict_maps(arms[:3], fixed[:3])
    with pytest.raises(ExtrapolationError, match=r"r_1 = 7 is outside the trained range"):
        model.predict_maps(arms[:1], np.array([7.0, 1.0, 1.0]))


def test_training_range_validation(tmp_path, model):
    with pytest.raises(ValueError, match="NaN or infinite"):
        TrainingRange.from_features(np.array([[0.0, np.nan]]))
    with pytest.raises(ValueError, match="n >= 1"):
        TrainingRange.from_features(np.zeros((0, 3)))
    with pytest.raises(ValueError, match="low <= high"):
        TrainingRange([0.0, 1.0], [1.0, 0.0])
    with pytest.raises(ValueError, match="training data must be features"):
        TrainingRange.from_features(SMALL)
    r = TrainingRange([0.0, 1.0], [1.0, 1.0], names=["a", "b"], samples=4)
    assert TrainingRange.from_dict(r.to_dict()) == r and r.fixed == {"b": 1.0}
    with pytest.raises(ValueError, match="'fixed' does not match"):
        TrainingRange.from_dict({**r.to_dict(), "fixed": {"a": 0.0}})
    with pytest.raises(ValueError, match="unknown training range keys"):
        TrainingRange.from_dict({**r.to_dict(), "lo": []})
    with pytest.raises(ValueError, match="training range has 2 features, the model expects 36"):
        SubspaceMLP(model.config).training_range = r
    with pytest.raises(TypeError, match="set_training_range"):
        SubspaceMLP(model.config).training_range = np.zeros((2, 36))
    # a file whose range was edited (and re-sealed) into nonsense is refused
    path = save(model, tmp_path / "m.pt")
    payload = torch.load(path, weights_only=True)
    payload["training_range"]["low"][3] = 5.0  # above high
    torch.save({**payload, "checksum": payload_checksum(payload)}, path)
    with pytest.raises(ModelFileError, match="invalid training_range: .*low <= high"):
        load(path)
