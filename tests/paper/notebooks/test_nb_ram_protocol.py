"""Smoke run of the ram_protocol notebook (params.smoke.yaml): the model file it saves scores the
held-out arms as its metrics say, every row of the table is there beside RAM's published numbers,
and a bad section is refused before any work."""

import json

import numpy as np
import pandas as pd
import pytest

from wsmap import datasets as ds
from wsmap import paths
from wsmap.learn import pose_model as pm
from wsmap.paper.parts import ram_protocol as part

SMOKE = paths.ROOT / "params.smoke.yaml"


@pytest.fixture(scope="module")
def out(smoke_notebook):
    return smoke_notebook("ram_protocol")


def test_ram_protocol_smoke(out):
    cfg = paths.load_params("ram_protocol", SMOKE)
    m = json.loads((out.results / "ram_protocol.json").read_text())
    assert m["arms"] == {"train": {"5": cfg["train_arms"], "6": cfg["train_arms"], "7": cfg["train_arms"]},
                         "test": {"5": cfg["test_arms"], "6": cfg["test_arms"], "7": cfg["test_arms"]}}
    assert m["poses"]["boundary"] == cfg["geodesics"] * cfg["per_geodesic"]
    assert m["model"]["training_arms"] == 3 * cfg["train_arms"]
    assert m["model"]["training_poses"] == 3 * cfg["train_arms"] * (cfg["poses"] + m["poses"]["boundary"])
    assert [(r["level"], r["samples"]) for r in m["fk_labels"]] == [
        (lv, b) for lv in cfg["fk"]["levels"] for b in cfg["fk"]["samples"]]
    assert m["ram_published"]["f1_random"] == ds.RAM_PUBLISHED["f1_random"] == 0.86
    assert "arXiv 2606.09108" in m["ram_published"]["source"]
    c = m["compute"]
    assert c["cpu_cores"] >= 1 and c["threads"] == cfg["threads"] and c["device"] == "cpu"
    assert c["train_label_cpu_seconds"] > 0 and c["train_cpu_seconds"] > 0 and c["core_hours"] > 0

    table = pd.read_csv(out.tables / "ram_protocol.csv")
    assert len(table) == 3 + len(m["fk_labels"]) + len(part.VARIANTS)
    ram_rows = table[table.source != "here"]
    assert list(ram_rows.f1_random) == [0.86, 0.91] and ram_rows.f1_boundary.iloc[0] == 0.78
    ours = table[table.source == "here"]
    assert ours[["f1_random", "f1_boundary"]].apply(lambda v: v.between(0, 1)).all().all()
    assert "| wsmap.reachable as it is" in (out.tables / "ram_protocol.md").read_text()
    assert (out.figures / "ram_protocol_f1.png").stat().st_size > 5_000


def test_the_saved_model_scores_the_held_out_arms_as_the_metrics_say(out):
    """The model file, reloaded, on the held-out arms drawn again from their seeds and labelled
    again: the same F1 per set as the metrics file (so the file is the model that was scored)."""
    cfg = paths.load_params("ram_protocol", SMOKE)
    m = json.loads((out.results / "ram_protocol.json").read_text())
    model, meta = pm.load_pose_model(out.models / "ram_pose.pt")
    assert meta["extra"]["stage"] == "ram_protocol" and model.threshold == m["model"]["threshold"]
    preds, truths = [], []
    for d in ds.RAM_DOFS:
        morphs = ds.sample_morphologies(cfg["test_arms"], d, seed=part.TEST_SEED + cfg["seed"])
        _, labels, T, _ = pm.pose_training_set(morphs, cfg["poses"], cfg["geodesics"], cfg["per_geodesic"],
                                               part.TEST_SEED + cfg["seed"], starts=cfg["starts"], with_poses=True)
        preds.append(pm.predict_poses(model, morphs, T))
        truths.append(labels)
    pred, truth = np.concatenate(preds), np.concatenate(truths)
    R = cfg["poses"]
    assert ds.ram_f1(pred[:, :R], truth[:, :R])[0] == pytest.approx(m["model"]["random"]["f1"])
    assert ds.ram_f1(pred[:, R:], truth[:, R:])[0] == pytest.approx(m["model"]["boundary"]["f1"])
    assert truth[:, :R].mean() == pytest.approx(m["reachable_share"]["random"])


@pytest.mark.parametrize("key, value, message", [
    ("arms_per_shard", 7, r"train_arms \(2\) must be a multiple of arms_per_shard \(7\)"),
    ("per_geodesic", 1, "per_geodesic must be an integer of at least 2, got 1"),
    ("test_arms", 1.5, "test_arms must be an integer of at least 1, got 1.5"),
    ("fk", {"samples": [1000, 500], "levels": [3]}, r"fk.samples must be increasing positive counts, got \[1000, 500\]"),
    ("fk", {"samples": [1000], "levels": [5]}, r"fk.levels must be among 1, 2, 3, 4 \(RAM's levels\), got \[5\]"),
])
def test_a_bad_section_is_refused_before_any_work(tmp_path, key, value, message):
    section = dict(paths.load_params("ram_protocol", SMOKE))
    section[key] = value
    cfg = paths.Params(section, "params.smoke.yaml section 'ram_protocol'")
    with pytest.raises(ValueError, match=f"^params.smoke.yaml section 'ram_protocol': {message}$"):
        part.run(cfg, paths.Outputs(tmp_path))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(__import__("torch").cuda.is_available(), reason="this machine has a GPU")
def test_device_cuda_without_a_gpu_fails_before_any_work(tmp_path):
    """The section's ``device`` is resolved before a shard is labelled or a folder made."""
    from wsmap.learn import DeviceUnavailableError

    section = dict(paths.load_params("ram_protocol", SMOKE))
    section["device"] = "cuda"
    cfg = paths.Params(section, "params.smoke.yaml section 'ram_protocol'")
    with pytest.raises(DeviceUnavailableError, match="section 'ram_protocol' device"):
        part.run(cfg, paths.Outputs(tmp_path))
    assert list(tmp_path.iterdir()) == []
