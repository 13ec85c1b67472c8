"""Smoke run of the learned_maps notebook (params.smoke.yaml): the panda7 model it saves maps the
family's arms by itself, and its metrics, tables and figures are all there."""

import json

import numpy as np
import pandas as pd
import pytest

from wsmap import paths, robots
from wsmap.learn import files as model_files

SMOKE = paths.ROOT / "params.smoke.yaml"


@pytest.fixture(scope="module")
def out(smoke_notebook):
    return smoke_notebook("learned_maps")


def test_learned_maps_smoke(out):
    cfg = paths.load_params("learned_maps", SMOKE)
    metrics = json.loads((out.results / "learned_maps.json").read_text())
    p7 = metrics["panda7"]
    assert p7["train_arms"] == paths.load_params("datasets", SMOKE)["panda7_tooldown"]["samples"]
    assert 0.0 <= p7["f"] <= 1.0 and p7["epochs"] == cfg["panda7"]["recipe"]["epochs"]
    assert [r["train_arms"] for r in p7["curve"]] == [*cfg["panda7"]["curve"], p7["train_arms"]]
    assert p7["speed"]["classical_s"] > p7["speed"]["model_s"] > 0
    # the saved model maps the family's arms, in node order, and refuses others
    model, meta = model_files.load(out.models / "panda7_map.pt")
    assert meta["map_spec"]["dataset"]["family"] == "panda7"
    scales = np.full((2, 6), 1.0)
    maps = model.predict_maps(robots.family_arm("panda7", scales))
    assert maps.shape == (2, 15625) and maps.dtype == bool
    with pytest.raises(TypeError):
        model.predict_maps(robots.puma560())
    m = metrics["manipulability"]
    assert m["train_arms"] == cfg["manipulability"]["train_arms"] and np.isfinite(m["mae"])
    design = pd.read_csv(out.tables / "learned_maps_design.csv")
    assert set(design["family"]) == {"spherical_wrist", "panda7"}
    assert set(design["method"]) == {"gradient", "cmaes", "random"}
    for name in ("panda7_curve", "panda7_slices", "panda7_3d", "puma560_manipulability_predicted",
                 "puma560_manipulability_exact", "design_path", "panda7_design_map"):
        assert (out.figures / f"learned_maps_{name}.png").stat().st_size > 5_000, name
