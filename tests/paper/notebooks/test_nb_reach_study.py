"""Papermill smoke run of the reach_study notebook (params.smoke.yaml, a temporary root)."""

import json

import pandas as pd

from wsmap import paths
from wsmap.paper.pipeline import run_notebook
from wsmap.workspace.study_files import load_study

SMOKE = paths.ROOT / "params.smoke.yaml"


def test_reach_study_smoke(tmp_path):
    cfg = paths.load_params("reach_study", SMOKE)
    run_notebook("reach_study", SMOKE, tmp_path, timeout=600)
    metrics = json.loads((tmp_path / "results" / "reach_study.json").read_text())
    table = pd.read_csv(tmp_path / "tables" / "reach_study.csv")
    assert set(table["cell"]) == set(cfg["cells"])
    assert set(table.loc[table["cell"] == "catalogue", "arm"]) == {"ur5e", "panda", "iiwa14"}
    counts = table["reached"] + table["certified_unreachable"] + table["not_found"]
    assert (counts == table["targets"]).all()
    # the demo's targets that REACH reached, wsmap reaches, and no other
    a = metrics["agreement"]["reach_demo"]
    assert a["reach_only"] == 0 and a["wsmap_only"] == 0 and a["both"] == a["reach_reached"] > 0
    assert (tmp_path / "figures" / "reach_study_heatmap.png").stat().st_size > 5_000
    html = (tmp_path / "results" / "reach_study_html" / "reach_demo.html").read_text()
    assert "mesh3d" in html or "scatter3d" in html
    study = load_study(tmp_path / "results" / "reach_study" / "catalogue.npz")
    assert study.arms == ["ur5e", "panda", "iiwa14"]
    # the committed study files name the cell's files relative to the checkout: the same bytes on every clone
    assert study.meta["source"] == "data/cells/reach_demo/part.pcd"
    assert str(paths.ROOT) not in json.dumps(study.meta)
