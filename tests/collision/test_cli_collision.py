"""wsmap map --collision / --scene: the map the library makes, its record in the file, bad input."""

import json

import numpy as np
import pytest

from wsmap import cli, load
from wsmap import workspace as ws
from wsmap.collision import CollisionChecker, arm_model, build_acm, default_geometry, load_scene

SCENE = {"floor": True, "obstacles": [{"name": "table", "shape": "box", "size": [0.6, 1.2, 0.05],
                                       "xyz": [0.6, 0, 0.3]}]}


def test_the_map_file_records_geometry_matrix_and_scene(tmp_path):
    (tmp_path / "table.json").write_text(json.dumps(SCENE))
    out = tmp_path / "m.npz"
    argv = ["map", "--robot", "ur5e", "--rpy", "pi", "0", "0", "--convention", "standard", "--step", "0.25",
            "--scene", str(tmp_path / "table.json"), "--acm-samples", "500", "--allow", "link0", "link6",
            "--out", str(out), "--quiet"]
    assert cli.main(argv) == 0
    flat, nodes, grid, settings = ws.load_map(out)
    col = settings["collision"]
    assert [o["name"] for o in col["scene"]["obstacles"]] == ["table"] and col["scene"]["floor"] == 0.0
    assert ["link0", "link6", "user"] in col["acm"]["disabled"] and col["acm"]["samples"] == 500
    assert [lk["name"] for lk in col["geometry"]["links"]][0] == "link0"  # the default: the vendor's hulls
    assert "collision-free" in settings["how"]
    model = arm_model("ur5e", geometry=default_geometry("ur5e"))
    model.acm = build_acm(model, samples=500, disable=[("link0", "link6")])
    expected = ws.constant_orientation_map(load("ur5e"), nodes, (np.pi, 0, 0), convention="standard",
                                           collision=CollisionChecker(model, load_scene(tmp_path / "table.json")))
    np.testing.assert_array_equal(flat, expected)
    assert 0 < flat.sum() < ws.constant_orientation_map(load("ur5e"), nodes, (np.pi, 0, 0),
                                                        convention="standard").sum()


def test_a_urdf_arm_takes_its_collision_elements(tmp_path):
    import pybullet_data
    import os

    path = os.path.join(pybullet_data.getDataPath(), "kuka_iiwa", "model.urdf")
    out = tmp_path / "k.npz"
    assert cli.main(["map", "--urdf", path, "--collision", "--acm-samples", "200", "--step", "0.5", "--out", str(out),
                     "--quiet"]) == 0
    assert ws.load_map(out)[3]["collision"]["geometry"]["links"][1]["shapes"][0]["kind"] == "mesh"


@pytest.mark.parametrize("extra, files, message", [
    (["--scene", "{d}/s.yaml"], {"s.yaml": "obstacles:\n  - {shape: cone}\n"}, "unknown shape 'cone'"),
    (["--scene", "{d}/s.yaml"], {"s.yaml": "floor: [1,\n"}, "is not YAML or JSON"),
    (["--scene", "{d}/s.json"], {"s.json": '{"obstacles": [{"shape": "sphere", "radius": NaN}]}'}, "NaN"),
    (["--scene", "{d}/s.yaml"], {"s.yaml": "obstacles:\n  - {shape: box, size: [1, 1, -1]}\n"}, "positive"),
    (["--collision", "--allow", "link1", "nolink"], {}, "unknown link 'nolink'"),
    (["--collision", "--robot", "puma560"], {}, "no collision model for robot 'puma560'"),
    (["--collision", "--kind", "reach"], {}, "--collision/--scene are used by --kind"),
    (["--allow", "link1", "link2"], {}, "--allow is used with --collision"),
    (["--collision", "--urdf", "{d}/a.urdf"], {"a.urdf": "MESH"}, "hand.stl' is empty"),
])
def test_bad_collision_input_exits_2_with_one_line_and_writes_nothing(tmp_path, capsys, extra, files, message):
    for name, text in files.items():
        if text == "MESH":
            (tmp_path / "hand.stl").write_bytes(b"")
            text = ('<robot name="r"><link name="b"/><link name="h"><collision><geometry><mesh filename="hand.stl"/>'
                    '</geometry></collision></link><joint name="j" type="revolute"><parent link="b"/><child link="h"/>'
                    '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>')
        (tmp_path / name).write_text(text)
    argv = ["map", *[x.format(d=tmp_path) for x in extra], "--out", str(tmp_path / "o.npz")]
    if "--robot" not in argv and "--urdf" not in argv:
        argv[1:1] = ["--robot", "panda"]
    code = cli.main(argv)
    err = capsys.readouterr().err
    assert code == 2 and message in err and err.count("\n") == 1 and err.startswith("wsmap: error: ")
    assert not (tmp_path / "o.npz").exists()


def test_place_takes_the_collision_options(tmp_path, capsys):
    (tmp_path / "t.csv").write_text("x,y,z,r1,r2,r3\n0.3,0,0.05,3.14159265,0,0\n0.5,0.2,0.3,3.14159265,0,0\n")
    argv = ["place", "--robot", "ur5e", "--targets", str(tmp_path / "t.csv"), "--x", "-0.6", "0.6", "--y", "-0.6",
            "0.6", "--step", "0.3", "--yaws", "4", "--acm-samples", "300"]
    assert cli.main(argv + ["--collision"]) == 0
    assert "collision-free" in capsys.readouterr().out
    # world-frame obstacles: each candidate base is checked where it stands
    (tmp_path / "w.yaml").write_text("frame: world\nobstacles:\n  - {shape: sphere, radius: 0.1, xyz: [1, 1, 1]}\n")
    assert cli.main(argv + ["--scene", str(tmp_path / "w.yaml")]) == 0
    capsys.readouterr()
    (tmp_path / "m.yaml").write_text("frame: world\nobstacles:\n  - {shape: sphere, radius: 0.1, xyz: [1, 1, 1]}\n"
                                     "  - {shape: sphere, radius: 0.1, xyz: [1, 1, 1], frame: base}\n")
    assert cli.main(argv + ["--scene", str(tmp_path / "m.yaml")]) == 2
    assert "not both in one scene" in capsys.readouterr().err
