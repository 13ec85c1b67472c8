"""Bad inputs of the learn API give clear errors; the package layout (names, imports)."""

import ast
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

import wsmap
from wsmap import datasets, learn, robots
from wsmap.learn import MLPConfig, SubspaceMLP, TrainConfig, predict_maps_from_file, save, train
from wsmap.paper.specs import PAPER_SPECS

torch.set_num_threads(1)  # tiny models; the CPU is shared

SMALL = datasets.scaled(PAPER_SPECS["table1_r3_step05"], 200)  # 5³ grid, 36 features


@pytest.fixture(scope="module")
def model():
    arms, _ = datasets.draw_samples(SMALL)
    X = datasets.features_for(arms, SMALL)
    torch.manual_seed(0)
    cfg = MLPConfig(n_inputs=X.shape[1], n_outputs=125, hidden=[4], init="torch", output_kind="logit")
    return SubspaceMLP(cfg).configure(X).set_map_spec(SMALL)


@pytest.fixture(scope="module")
def X(model):
    return model.map_features(robots.sample_spherical_wrist(5, seed=2))


@pytest.mark.parametrize("t", [0, 1, -0.2, 1.5, float("nan"), float("inf"), True, "0.5", None])
def test_thresholds_outside_0_1_are_refused(model, X, t):
    with pytest.raises(ValueError, match="threshold must be"):
        model.predict(X, t)
    if t is not None:  # None means the map_spec's threshold in predict_maps
        with pytest.raises(ValueError, match="threshold must be"):
            model.predict_maps(robots.puma560(), threshold=t)
        with pytest.raises(ValueError, match="map_spec threshold must be"):
            SubspaceMLP(model.config).set_map_spec(SMALL, threshold=t)


@pytest.mark.parametrize("b", [0, -1, 2.5, True, "8"])
def test_bad_batch_sizes(model, X, b):
    with pytest.raises(ValueError, match="batch_size must be a positive integer or None"):
        model.predict(X, batch_size=b)
    with pytest.raises(ValueError, match="batch_size must be a positive integer or None"):
        model.predict_maps(robots.puma560(), batch_size=b)


def test_non_finite_features_are_refused_not_mapped_to_empty_maps(model, X):
    bad = X.copy()
    bad[3, 5] = np.nan
    with pytest.raises(ValueError, match=r"features contain NaN or infinite values \(rows \[3\]\)"):
        model.predict(bad)
    bad[3, 5] = np.inf
    with pytest.raises(ValueError, match="NaN or infinite"):
        model.score(torch.as_tensor(bad))
    with pytest.raises(ValueError, match="model expects 36 features, got 35"):
        model.predict(X[:, :-1])


def test_wrong_feature_layout_of_a_map_spec(model):
    with pytest.raises(ValueError, match="has 84 features per arm but the model expects 36"):
        SubspaceMLP(model.config).set_map_spec(PAPER_SPECS["sec62"], nodes=(0, 125))


def test_bad_fixed_orientation(model):
    puma = robots.puma560()
    with pytest.raises(ValueError, match="fixed contains NaN or infinite values"):
        model.predict_maps(puma, fixed=(np.nan, 0, 0))
    with pytest.raises(ValueError, match=r"fixed must have shape \(3,\) or \(1, 3\), got \(2,\)"):
        model.predict_maps(puma, fixed=(0, 0))
    with pytest.raises(ValueError, match="fixed must be 3 numbers"):
        model.predict_maps(puma, fixed=("a", "b", "c"))
    with pytest.raises(ValueError, match=r"trained at the fixed orientation \(rad\) \[0.0, 0.0, 0.0\] only"):
        model.predict_maps(puma, fixed=(0.1, 0, 0))


def test_bad_grids(tmp_path, model):
    path = save(model, tmp_path / "m.pt", dataset_spec=SMALL)
    puma = robots.puma560()
    grid = {"scope": "R3", "lo": -1, "hi": 1, "step": 0.5, "shape": [5, 5, 5]}
    assert predict_maps_from_file(path, puma, grid=grid).shape == (125,)
    for bad, message in (({**grid, "scope": "R4"}, "grid scope must be 'R3' or 'SO3'"),
                         ({**grid, "stepp": 0.1}, r"unknown grid keys \['stepp'\]"),
                         ({**grid, "lo": "minus one"}, "grid lo must be one number or three"),
                         ({**grid, "step": 0.1}, r"maps a different grid: step \[0.1, 0.1, 0.1\]"),
                         ({**grid, "shape": [5, 5, 6]}, r"shape \[5, 5, 6\] \(model: \[5, 5, 5\]\)"),
                         ([-1, 1, 0.5], "grid must be a dict")):
        with pytest.raises(ValueError, match=message):
            predict_maps_from_file(path, puma, grid=bad)
    # an R3 map at R = I is the same map in both conventions (the refusal of an SO3 model's other
    # convention is test_predictor's)
    np.testing.assert_array_equal(predict_maps_from_file(path, puma, convention="standard"),
                                  predict_maps_from_file(path, puma, convention="paper"))


def test_bad_training_data(model):
    X = model.map_features(robots.sample_spherical_wrist(30, seed=0))
    nan_x = X.copy()
    nan_x[4, 2] = np.nan
    with pytest.raises(ValueError, match=r"training features contain NaN or infinite values \(rows \[4\]"):
        SubspaceMLP(model.config).configure(nan_x)
    Y = np.zeros((30, 125), np.float32)
    with pytest.raises(ValueError, match=r"X contains NaN or infinite values \(rows \[4\]\)"):
        train(SubspaceMLP(model.config), nan_x, Y, TrainConfig(max_epochs=1))
    bad_y = Y.copy()
    bad_y[7, 0] = np.inf
    with pytest.raises(ValueError, match=r"Y contains NaN or infinite values \(rows \[7\]\)"):
        train(SubspaceMLP(model.config), X, bad_y, TrainConfig(max_epochs=1))
    bad_y3 = np.zeros((1, 30, 125), np.float32)
    bad_y3[0, 9, 1] = np.nan  # per-session targets (S, n, m)
    with pytest.raises(ValueError, match=r"Y contains NaN or infinite values \(rows \[9\]\)"):
        train(SubspaceMLP(model.config), X, bad_y3, TrainConfig(max_epochs=1))
    with pytest.raises(ValueError, match="no samples"):
        train(SubspaceMLP(model.config), X[:0], Y[:0], TrainConfig(max_epochs=1))
    # boolean labels are fine as they are
    res = train(SubspaceMLP(model.config), X, Y > 0, TrainConfig(optimizer="adam", batch_size=8, max_epochs=1))
    assert res.stop_reason == ["max_epochs"]


# ------------------------------------------------------------------ the layout


def test_public_names():
    for name in learn.__all__:
        assert hasattr(learn, name), name
    assert len(set(learn.__all__)) == len(learn.__all__)
    assert learn.ModelFileError is learn.files.ModelFileError and issubclass(learn.ExtrapolationError, ValueError)
    assert issubclass(learn.ExtrapolationWarning, UserWarning) and issubclass(learn.ModelFileError, ValueError)


def _learn_imports() -> dict[str, set[str]]:
    """Module -> the wsmap modules it imports (from its source, top level and inside functions)."""
    root = Path(learn.__file__).parent
    graph = {}
    for f in sorted(root.glob("*.py")):
        mod = "wsmap.learn" if f.stem == "__init__" else f"wsmap.learn.{f.stem}"
        deps = set()
        for node in ast.walk(ast.parse(f.read_text())):
            if isinstance(node, ast.ImportFrom) and node.level:
                base = "wsmap.learn" if node.level == 1 else "wsmap"
                target = f"{base}.{node.module}" if node.module else base
                deps.add(target)
                if node.module is None or target in ("wsmap", "wsmap.learn"):
                    deps.update(f"{target}.{a.name}" for a in node.names)
            elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("wsmap"):
                deps.add(node.module)
        graph[mod] = deps
    return graph


def test_learn_has_no_import_cycles_and_no_cli_or_paper():
    graph = _learn_imports()
    internal = {m: {d for d in deps if d in graph and d != "wsmap.learn"} for m, deps in graph.items()
                if m != "wsmap.learn"}
    seen, done = set(), set()

    def visit(m, path):
        assert m not in seen or m in done, f"import cycle: {' -> '.join([*path, m])}"
        if m in done:
            return
        seen.add(m)
        for d in internal[m]:
            visit(d, [*path, m])
        done.add(m)

    for m in internal:
        visit(m, [])
    outside = {d for deps in graph.values() for d in deps if not d.startswith("wsmap.learn")}
    assert not any(d.startswith(("wsmap.cli", "wsmap.paper")) for d in outside), outside
    code = ("import sys, wsmap.learn; "
            "bad = [m for m in sys.modules if m.startswith(('wsmap.cli', 'wsmap.paper'))]; "
            "assert not bad, bad")
    subprocess.run([sys.executable, "-c", code], check=True, cwd=Path(wsmap.__file__).parents[2])
