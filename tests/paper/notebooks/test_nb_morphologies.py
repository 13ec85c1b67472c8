"""Smoke run of the morphologies notebook (params.smoke.yaml): the model it saves maps a named arm
by itself, every method is scored on the held-out arms, the hold-out is kept, and its files are there."""

import json

import numpy as np
import pandas as pd
import pytest

from wsmap import paths, robots
from wsmap import workspace as ws
from wsmap.learn import morph_model as mm
from wsmap.paper.parts import morphologies as part
from wsmap.robots.morph import HELD_OUT, HOLD_OUT_RADIUS

SMOKE = paths.ROOT / "params.smoke.yaml"


@pytest.fixture(scope="module")
def out(smoke_notebook):
    return smoke_notebook("morphologies")


def test_morphologies_smoke(out):
    cfg = paths.load_params("morphologies", SMOKE)
    metrics = json.loads((out.results / "morphologies.json").read_text())
    per_family = cfg["shards"] * cfg["arms_per_shard"]
    assert metrics["train_arms"] == {"morph6": per_family, "morph7": per_family}
    assert metrics["test_arms"] == {"morph6": cfg["test_arms"], "morph7": cfg["test_arms"]}
    assert metrics["nodes"] == 7 ** 3 and metrics["arms_per_second"] > 0
    assert set(metrics["pooled"]) == set(part.METHODS) and set(metrics["named"]) == set(HELD_OUT)
    assert metrics["hold_out"]["least_distance"] > HOLD_OUT_RADIUS
    assert all(metrics["train"][m]["epochs"] == cfg["train"]["epochs"] for m in ("model", "fk_model"))
    arms = pd.read_csv(out.tables / "morphologies_arms.csv")
    assert len(arms) == (1 + len(HELD_OUT)) * len(part.METHODS) + len(cfg["family"])
    # the family baseline: the panda7 model on the Panda, its row in the table
    fam = metrics["family"]["panda"]
    assert fam["family"] == "panda7" and fam["train_arms"] == cfg["family"]["panda"]["samples"]
    row = arms[(arms.arms == "panda") & (arms.method == "family_model")]
    assert len(row) == 1 and np.isclose(row.f.iloc[0], fam["f"], equal_nan=True)
    # the design study: every method's answer, verified or not, and its DH table
    design = pd.read_csv(out.tables / "morphologies_design.csv")
    assert list(design.method) == ["gradient", "cmaes", "random"]
    for m, a in metrics["design"]["answers"].items():
        assert np.shape(a["dh_modified"]) == (6, 4) and a["total_length_m"] > 0, m
    assert list(pd.read_csv(out.tables / "morphologies_speed.csv").arm) == ["held-out morph7 arm", *cfg["speed_arms"]]
    # the saved model maps a named arm by itself, as the table scored it
    model, meta = mm.load_morph_model(out.models / "morph.pt")
    nodes = ws.cartesian_grid(-1.5, 1.5, cfg["step"])
    pred = mm.predict_morph_map(model, robots.load("ur5e"), nodes, allow_extrapolation=True)
    truth = ws.constant_orientation_map(robots.load("ur5e"), nodes, mm.TOOL_DOWN, convention="standard")
    from wsmap.metrics import score_maps

    f = float(score_maps(pred[None], truth[None])["f"])
    assert np.isclose(f, metrics["named"]["ur5e"]["model"]["f"], equal_nan=True)
    _, fk_meta = mm.load_morph_model(out.models / "morph_fk.pt")
    assert fk_meta["extra"]["labels"] == "forward kinematics only"
    for name in ("f", "slices"):
        assert (out.figures / f"morphologies_{name}.png").stat().st_size > 5_000, name
    assert (out.root / "data" / "morph").is_dir()


def test_family_baseline_entries_are_checked_before_any_work():
    with pytest.raises(ValueError, match=r"morphologies: family.panda.family 'panda9' is not a family; known: "):
        part._family_members({"panda": {"family": "panda9"}}, "morphologies")
    with pytest.raises(ValueError, match=r"morphologies: family.ur5e: the arm is not a member of 'panda7'"):
        part._family_members({"ur5e": {"family": "panda7"}}, "morphologies")
    members = part._family_members({"panda": {"family": "panda7"}}, "morphologies")
    assert np.array_equal(members["panda"], np.ones(6))


@pytest.mark.skipif(__import__("torch").cuda.is_available(), reason="this machine has a GPU")
def test_device_cuda_without_a_gpu_fails_before_any_work(tmp_path):
    """The section's ``device`` is resolved first: cuda on a machine without one is an error naming
    the setting, before a shard is labelled or a folder made."""
    import yaml

    from wsmap.learn import DeviceUnavailableError

    params = yaml.safe_load(SMOKE.read_text())
    params["morphologies"]["device"] = "cuda"
    path = tmp_path / "params.cuda.yaml"
    path.write_text(yaml.safe_dump(params))
    cfg = paths.notebook_params("morphologies", path)
    out = paths.Outputs(tmp_path / "out")
    with pytest.raises(DeviceUnavailableError, match="section 'morphologies' device"):
        part.run(cfg, out)
    assert not (tmp_path / "out" / "data").exists()
