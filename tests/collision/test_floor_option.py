"""--floor Z / --no-floor: the floor explicit for every arm, recorded in the map file and said in the
summary line (a URDF arm's --collision used to add no floor without a word)."""

import json

import numpy as np
import pytest

from wsmap import cli
from wsmap import workspace as ws
from wsmap.collision.sources import CollisionSource

from test_srdf import SRDF, URDF  # the plate arm and its SRDF


@pytest.fixture
def arm(tmp_path):
    (tmp_path / "a.urdf").write_text(URDF)
    (tmp_path / "a.srdf").write_text(SRDF)  # the plate-l2 pair disabled: only a floor stops l2 below z = 0
    return tmp_path


def _map(arm, capsys, *extra):
    out = arm / "m.npz"
    argv = ["map", "--urdf", str(arm / "a.urdf"), "--srdf", str(arm / "a.srdf"), "--collision", "--step", "0.25",
            "--acm-samples", "200", "--rpy", "0", "pi/2", "0", "--out", str(out), *extra]
    assert cli.main(argv) == 0, capsys.readouterr().err
    line = capsys.readouterr().out
    flat, nodes, _, settings = ws.load_map(out)
    below = np.flatnonzero(np.all(np.isclose(nodes, [0.5, 0, -0.25]), axis=1))
    return bool(flat[below][0]), settings, line


def test_a_urdf_arm_has_no_floor_unless_asked_and_says_so(arm, capsys):
    free, settings, line = _map(arm, capsys)
    assert free and settings["collision"]["floor"] is None and "no floor" in line and "no floor" in settings["how"]
    free, settings, line = _map(arm, capsys, "--floor", "0")
    assert not free and settings["collision"]["floor"] == 0.0 and "floor at z = 0 m" in line
    free, settings, line = _map(arm, capsys, "--floor", "-0.3")  # below the tool's -0.25: l2 clears it
    assert free and settings["collision"]["floor"] == -0.3 and "floor at z = -0.3 m" in line


def test_no_floor_removes_the_scene_files_and_floor_replaces_it(arm, capsys):
    (arm / "s.json").write_text(json.dumps({"floor": 0.0}))
    free, settings, _ = _map(arm, capsys, "--scene", str(arm / "s.json"))
    assert not free and settings["collision"]["floor"] == 0.0
    free, settings, line = _map(arm, capsys, "--scene", str(arm / "s.json"), "--no-floor")
    assert free and settings["collision"]["floor"] is None and "no floor" in line
    free, settings, _ = _map(arm, capsys, "--scene", str(arm / "s.json"), "--floor", "-0.5")
    assert free and settings["collision"]["floor"] == -0.5


def test_a_named_arm_keeps_its_floor_unless_told():
    from wsmap import load

    robot = load("ur5e")
    assert CollisionSource(collision=True, acm_samples=50).build(robot, _Named()).scene.floor == 0.0
    assert CollisionSource(collision=True, acm_samples=50, floor=False).build(robot, _Named()).scene.floor is None
    assert CollisionSource(collision=True, acm_samples=50, floor=0.2).build(robot, _Named()).scene.floor == 0.2


class _Named:
    urdf = mjcf = ee = base = None
    has_dh = False
    name = "ur5e"


@pytest.mark.parametrize("extra, message", [
    (["--floor", "0"], "--floor/--no-floor is used with --collision or --scene"),
    (["--no-floor"], "--floor/--no-floor is used with --collision or --scene"),
    (["--collision", "--floor", "1e4"], "--floor must be a finite height of at most 1000 m in magnitude, got 10000"),
    (["--collision", "--floor", "0", "--no-floor"], "not allowed with argument"),
])
def test_bad_floor_options_exit_2(tmp_path, capsys, extra, message):
    try:
        code = cli.main(["map", "--robot", "panda", *extra, "--out", str(tmp_path / "o.npz")])
    except SystemExit as e:  # argparse's own usage errors
        code = e.code
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("wsmap") and err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "o.npz").exists()
