"""MoveIt SRDF files: disabled pairs into the allowed-collision matrix, the planning group's chain and
end effector picking the arm, and a bad SRDF as one line."""

import re
from pathlib import Path

import numpy as np
import pytest

from wsmap import cli
from wsmap import workspace as ws
from wsmap.collision import checker_for, from_urdf_collision
from wsmap.collision.srdf import SRDFError, load_srdf

REACH = Path(__file__).resolve().parents[2] / "data" / "cells" / "reach_demo"
LIM = 'effort="1" velocity="1"'

#: A wide base plate, two arm links (l2 turned about y can hit the plate), a tool frame and a
#: camera frame beside the arm (so the tree branches: two leaves).
URDF = f"""<robot name="plate_arm">
  <link name="base"><collision><geometry><box size="1.2 1.2 0.1"/></geometry></collision></link>
  <link name="l1"><collision><origin xyz="0.25 0 0"/><geometry><box size="0.5 0.05 0.05"/></geometry></collision></link>
  <link name="l2"><collision><origin xyz="0.25 0 0"/><geometry><box size="0.5 0.05 0.05"/></geometry></collision></link>
  <link name="tool"/><link name="cam"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><origin xyz="0 0 0.25"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" {LIM}/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.5 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="2" {LIM}/></joint>
  <joint name="t" type="fixed"><parent link="l2"/><child link="tool"/><origin xyz="0.5 0 0"/></joint>
  <joint name="c" type="fixed"><parent link="base"/><child link="cam"/><origin xyz="0 0.5 1"/></joint>
</robot>"""

SRDF = """<?xml version="1.0"?>
<robot name="plate_arm">
  <group name="arm"><chain base_link="base" tip_link="tool"/></group>
  <group name="camera"><link name="cam"/></group>
  <end_effector name="probe" parent_link="tool" group="camera" parent_group="arm"/>
  <disable_collisions link1="base" link2="l2" reason="User"/>
  <disable_collisions link1="cam" link2="l2" reason="Never"/>
</robot>"""


@pytest.fixture
def files(tmp_path):
    (tmp_path / "a.urdf").write_text(URDF)
    (tmp_path / "a.srdf").write_text(SRDF)
    return tmp_path


def test_the_reach_demo_srdf_reads_as_moveit_wrote_it():
    text = (REACH / "sia20d.srdf").read_text()
    s = load_srdf(REACH / "sia20d.srdf", urdf=REACH / "sia20d.urdf")
    pairs = re.findall(r'<disable_collisions link1="(\w+)" link2="(\w+)" reason="(\w+)"', text)
    assert len(pairs) > 10 and s.disabled == tuple(pairs)
    assert s.groups == {"manipulator": ("base_link", "tcp")} and s.ends() == ("base_link", "tcp")


def test_disabled_pairs_are_never_checked(files):
    model = from_urdf_collision(files / "a.urdf", ee_link="tool")
    folded = np.array([[0.0, np.pi / 2]])  # l2 straight down through the plate
    plain = checker_for(model, samples=300)
    assert plain.acm.reason("base", "l2") is None and not plain(folded)[0]
    model = from_urdf_collision(files / "a.urdf", ee_link="tool")
    with_srdf = checker_for(model, samples=300, srdf=files / "a.srdf")
    assert with_srdf.acm.reason("base", "l2") == "srdf" and with_srdf(folded)[0]
    assert ["base", "l2", "srdf"] in with_srdf.acm.describe()["disabled"]
    # 'cam' has no collision geometry: its pair has nothing to disable
    assert all("cam" not in p for p in with_srdf.acm.describe()["disabled"])


def test_the_group_picks_the_chain_and_the_map_uses_the_matrix(files, capsys):
    out = files / "m.npz"
    # tool along -z (R = Ry(pi/2)): one pose, q = (0, pi/2), the tool at (0.5, 0, -0.25), l2 through the plate
    argv = ["map", "--urdf", str(files / "a.urdf"), "--step", "0.25", "--acm-samples", "200", "--quiet",
            "--rpy", "0", "pi/2", "0"]
    assert cli.main(argv + ["--out", str(out)]) == 2  # two leaves (tool, cam): the end link is needed
    assert "the tree branches" in capsys.readouterr().err
    assert cli.main(argv + ["--srdf", str(files / "a.srdf"), "--collision", "--out", str(out)]) == 0
    flat, nodes, grid, settings = ws.load_map(out)
    assert settings["ee"] == "tool" and settings["collision"]["srdf_file"] == str(files / "a.srdf")
    assert ["base", "l2", "srdf"] in settings["collision"]["acm"]["disabled"]
    assert cli.main(argv + ["--ee", "tool", "--collision", "--out", str(files / "plain.npz")]) == 0
    plain = ws.load_map(files / "plain.npz")[0]
    below = np.flatnonzero(np.all(np.isclose(nodes, [0.5, 0, -0.25]), axis=1))
    assert flat[below].all() and not plain[below].any()  # the plate stops l2 only without the SRDF's pair


@pytest.mark.parametrize("srdf, message", [
    (SRDF.replace('link2="l2" reason="User"', 'link2="l9"'),
     "<disable_collisions> 1 names link 'l9', which the URDF does not have"),
    (SRDF.replace('link1="cam" ', ''), "<disable_collisions> 2 has no link1= attribute"),
    (SRDF.replace('tip_link="tool"', ''), "the <chain> of group 'arm' has no tip_link= attribute"),
    (SRDF.replace('parent_link="tool"', 'parent_link="hand"'), "end effector 'probe' names link 'hand'"),
    (SRDF.replace('<robot name="plate_arm">', '<!DOCTYPE r [<!ENTITY a "aaaa">]><robot name="plate_arm">'),
     "declares the XML entity 'a' (line 2); an SRDF declares none"),
    (SRDF.replace('<robot name="plate_arm">', '<robot>'), "the <robot> element has no name"),
    (SRDF.replace('</robot>', ''), "is not XML"),
    ("<robot name='x'>" + "<g>" * 100 + "</g>" * 100 + "</robot>", "nests its elements deeper than 64 levels"),
])
def test_a_bad_srdf_is_one_line_exit_2(files, capsys, srdf, message):
    (files / "b.srdf").write_text(srdf)
    argv = ["map", "--urdf", str(files / "a.urdf"), "--srdf", str(files / "b.srdf"), "--collision",
            "--out", str(files / "o.npz")]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("wsmap: error: ") and err.count("\n") == 1 and message in err, err
    assert not (files / "o.npz").exists()
    with pytest.raises(SRDFError, match=re.escape(message)):
        load_srdf(files / "b.srdf", urdf=files / "a.urdf")


def test_srdf_options_are_checked(files, capsys):
    assert cli.main(["map", "--robot", "panda", "--srdf", str(files / "a.srdf"), "--out", str(files / "o.npz")]) == 2
    assert "--srdf goes with --urdf" in capsys.readouterr().err
    assert cli.main(["map", "--urdf", str(files / "a.urdf"), "--srdf", str(files / "none.srdf"),
                     "--out", str(files / "o.npz")]) == 2
    assert "no such SRDF file" in capsys.readouterr().err
    two = SRDF.replace('<group name="camera"><link name="cam"/></group>',
                       '<group name="half"><chain base_link="base" tip_link="l1"/></group>')
    assert load_srdf(two.encode()).ends() == ("base", "tool")  # the group the end effector hangs from
    with pytest.raises(SRDFError, match="several chain groups"):
        load_srdf(two.replace('parent_group="arm"', '').encode()).ends()
