"""The reach_study part writes the paths of a study's settings relative to the checkout, so that its
committed study files are byte-identical on every clone."""

from pathlib import Path

from wsmap.paper.parts.reach_study import in_checkout


def test_paths_under_the_checkout_become_relative_and_nothing_else_changes(tmp_path):
    root = tmp_path / "checkout"
    settings = {"source": str(root / "data/cells/a/study.yaml"), "targets": {"points": str(root / "data/p.pcd")},
                "arms": [{"urdf": str(root / "x.urdf"), "name": "sia20d"}], "elsewhere": "/opt/arm.urdf",
                "relative": "data/q.pcd", "turns": 4, "cone": 15.0, "none": None,
                "pair": (str(root / "m.stl"), 1)}
    out = in_checkout(settings, root)
    assert out == {"source": "data/cells/a/study.yaml", "targets": {"points": "data/p.pcd"},
                   "arms": [{"urdf": "x.urdf", "name": "sia20d"}], "elsewhere": "/opt/arm.urdf",
                   "relative": "data/q.pcd", "turns": 4, "cone": 15.0, "none": None, "pair": ("m.stl", 1)}
    # a sibling folder whose name starts with the checkout's is not inside it
    assert in_checkout(str(tmp_path / "checkout2" / "f"), root) == str(tmp_path / "checkout2" / "f")
    assert in_checkout(str(root), root) == "."
