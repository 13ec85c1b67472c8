"""Papermill smoke run of the real_arms notebook (params.smoke.yaml, a temporary root)."""

import json

import pandas as pd

from wsmap import paths
from wsmap.paper.pipeline import run_notebook

SMOKE = paths.ROOT / "params.smoke.yaml"


def test_real_arms_smoke(tmp_path):
    cfg = paths.load_params("real_arms", SMOKE)
    run_notebook("real_arms", SMOKE, tmp_path, timeout=600)
    metrics = json.loads((tmp_path / "results" / "real_arms.json").read_text())
    assert [r["arm"] for r in metrics["arms"]] == cfg["arms"]
    vol = pd.read_csv(tmp_path / "tables" / "real_arms_volumes.csv")
    # dexterous within reachable within reach, for every arm
    assert (vol["dexterous_volume_m3"] <= vol["reachable_at_some_orientation_of_the_set_m3"] + 1e-12).all()
    assert (vol["reachable_at_some_orientation_of_the_set_m3"] <= vol["reach_volume_m3"] + 1e-12).all()
    assert set(vol.loc[vol["arm"].isin(["puma560", "ur5e", "ur10e"]), "method"]) == {"exact"}
    assert set(vol.loc[vol["arm"].isin(["panda", "iiwa14", "gen3"]), "method"]) == {"numerical"}
    place = pd.read_csv(tmp_path / "tables" / "real_arms_placement.csv")
    assert set(place["arm"]) == set(cfg["placement"]["arms"])
    for name in cfg["arms"]:
        assert (tmp_path / "figures" / f"real_arms_index_{name}.png").stat().st_size > 5_000
    coll = pd.read_csv(tmp_path / "tables" / "real_arms_collision.csv")
    assert set(coll["arm"]) == set(cfg["collision"]["arms"]) and set(coll["way"]) == {"chain", "self_floor", "table"}
    assert (coll.loc[coll["way"] == "chain", "lost_m3"] == 0).all() and (coll["lost_m3"] >= 0).all()
    assert metrics["collision_placement"]["best_changed"]
    for name in ("collision", "collision_placement"):
        assert (tmp_path / "figures" / f"real_arms_{name}.png").stat().st_size > 5_000
    html = (tmp_path / "results" / "real_arms_html" / f"{cfg['show_3d']}_index.html").read_text()
    assert "<script" in html and "<script src=\"http" not in html  # plotly.js inline: opens offline
    # each index node's answer: the closed-form arms decide every node; the counts match the views
    assert (vol.loc[vol["method"] == "exact", "nodes_not_found"] == 0).all()
    assert (vol["nodes_certified_unreachable"] > 0).all() and (vol["status_seconds"] >= 0).all()
    assert '"name":"not found (' in html and '"name":"certified unreachable (' in html
    import trimesh

    for r in metrics["arms"]:
        ply = tmp_path / "results" / "real_arms" / f"{r['arm']}_index.ply"
        raw = trimesh.load(ply).metadata["_ply_raw"]["vertex"]["data"]
        assert (raw["status"] == 2).sum() == r["nodes_not_found"]
