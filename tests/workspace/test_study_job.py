"""The study job from its file: the workpiece as an obstacle on its triangles, the direction of a
cloud's normals, the same bytes twice, and every bad field a one-line error before anything is
written."""

import numpy as np
import pytest
import trimesh

from wsmap.cli import main
from wsmap.jobs.config import ConfigError
from wsmap.jobs.study import StudyJob
from wsmap.workspace.study_files import load_study

CELL = """robot: ur5e
tcp: [0, 0, 0.1, 0, 0, 0]
targets: {mesh: box.stl, spacing: 0.1}
orientation: {turns: 2}
collision: {workpiece: box.stl, acm_samples: 300}
outputs: {study: out.npz}
"""


@pytest.fixture
def cell(tmp_path):
    b = trimesh.creation.box((0.3, 0.3, 0.3))
    b.apply_translation([0.45, 0, 0.15])
    b.export(tmp_path / "box.stl")
    (tmp_path / "study.yaml").write_text(CELL)
    return tmp_path


def test_the_workpiece_is_an_obstacle_and_every_solution_is_free_of_it(cell):
    job = StudyJob.from_file(cell / "study.yaml")
    plan = job.check()
    with_part = job.run(plan).results[0][0]
    free = StudyJob.from_dict({**_yaml(cell), "collision": {"acm_samples": 300}}, root=cell)
    without = free.run().results[0][0]
    ok_with, ok_without = with_part.status == 0, without.status == 0
    assert not (ok_with & ~ok_without).any()  # the part only takes targets away
    assert (ok_without & ~ok_with).any()  # and here it does: the arm would pass through the box
    checker = plan.checkers[0]
    assert checker.scene.obstacles[-1].shape.kind == "surface"
    assert checker.exact(with_part.q[ok_with]).all()  # coal alone agrees: free of the part


def _yaml(cell):
    import yaml

    return yaml.safe_load((cell / "study.yaml").read_text())


def test_the_heat_maps_are_written_beside_the_study(cell):
    import yaml

    d = {**_yaml(cell), "scores": ["manipulability", "clearance"],
         "outputs": {"study": "out.npz", "png": "h.png", "html": "h.html", "ply": "h.ply", "score": "clearance"}}
    (cell / "views.yaml").write_text(yaml.safe_dump(d))
    assert main(["study", str(cell / "views.yaml"), "-q"]) == 0
    ply = trimesh.load(cell / "h.ply", process=False)
    assert len(ply.faces) == 12 and (cell / "h.png").stat().st_size > 0
    assert "mesh3d" in (cell / "h.html").read_text()
    res = load_study(cell / "out.npz").results()
    ok = res.status == 0
    assert ok.any() and np.all((res.scores["clearance"][ok] >= 0) & (res.scores["clearance"][ok] <= 1))


def test_the_same_file_gives_the_same_bytes(cell, capsys):
    assert main(["study", str(cell / "study.yaml"), "-q"]) == 0
    first = (cell / "out.npz").read_bytes()
    assert main(["study", str(cell / "study.yaml"), "-q"]) == 0
    assert (cell / "out.npz").read_bytes() == first
    study = load_study(cell / "out.npz")
    assert study.meta["settings"]["collision"]["workpiece"].endswith("box.stl")


def test_tool_z_along_points_the_tool_along_the_clouds_normals(tmp_path):
    pts = np.array([[0.4, 0.0, 0.2], [0.4, 0.1, 0.2]])
    n = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    np.savetxt(tmp_path / "c.csv", np.hstack([pts, n]), delimiter=",", header="x,y,z,nx,ny,nz", comments="")
    spec = {"robot": "ur5e", "targets": {"points": "c.csv"}}
    against = StudyJob.from_dict(spec, root=tmp_path).targets.load().poses
    along = StudyJob.from_dict({**spec, "targets": {"points": "c.csv", "tool_z": "along"}},
                               root=tmp_path).targets.load().poses
    np.testing.assert_allclose(against[:, :3, 2], -n)
    np.testing.assert_allclose(along[:, :3, 2], n)


@pytest.mark.parametrize("change, message", [
    ({"targets": {"mesh": "box.stl", "spacing": 0.1, "tool_z": "along"}}, "targets.tool_z: says which way a point"),
    ({"targets": {"points": "box.stl", "tool_z": "up"}}, "targets.tool_z: against .* or along"),
    ({"collision": {"workpiece": 3}}, "collision.workpiece: the workpiece's mesh file"),
    ({"collision": {"workpiece": "nothing.stl"}}, "nothing.stl.*no such file"),
    ({"collision": {"work_piece": "box.stl"}}, "work_piece"),
    ({"targets": {"mesh": "box.stl", "spacing": -1}}, "targets.spacing: must be positive"),
    ({"collision": None, "scores": ["clearance"]}, "scores: clearance measures the distance to collision"),
    ({"outputs": {"png": "x.jpg"}}, "outputs.png: the png heat map's file must end in .png"),
    ({"outputs": {"score": "beauty"}}, "outputs.score: the score the heat map shows"),
])
def test_bad_fields_are_one_line_errors_and_nothing_is_written(cell, capsys, change, message):
    import yaml

    d = {**_yaml(cell), **change}
    (cell / "bad.yaml").write_text(yaml.safe_dump(d))
    assert main(["study", str(cell / "bad.yaml")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    import re

    assert re.search(message, err), err
    assert not (cell / "out.npz").exists()
    with pytest.raises(ConfigError):
        StudyJob.from_dict(d, root=cell).check()


def test_progress_is_told_of_every_arm(cell):

    d = {**_yaml(cell), "robots": ["ur5e", "puma560"], "collision": None}
    d.pop("robot")
    job = StudyJob.from_dict(d, root=cell)
    told = []
    result = job.run(progress=told.append)
    assert told == [1, 1] and len(result.results) == 2
    with pytest.raises(ValueError, match="progress must be"):
        job.run(progress="yes")
