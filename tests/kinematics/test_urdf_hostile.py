"""Hostile URDFs (issue 41): limits of ±1e308 read as the continuous joint they mean (the same map),
entity bombs and deep nesting refused in one line before a tree is built."""

from __future__ import annotations

import re

import numpy as np
import pytest

from wsmap import cli
from wsmap import workspace as ws
from wsmap.kinematics.urdf import URDFError, from_urdf

rtb = pytest.importorskip("roboticstoolbox")

ARM = """<?xml version="1.0"?>
<robot name="r3"><link name="a"/><link name="b"/><link name="c"/><link name="t"/>
<joint name="j1" type="TYPE"><parent link="a"/><child link="b"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>LIMIT</joint>
<joint name="j2" type="revolute"><parent link="b"/><child link="c"/><origin xyz="0 0 0.3"/><axis xyz="0 1 0"/>
<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
<joint name="tool" type="fixed"><parent link="c"/><child link="t"/><origin xyz="0.3 0 0"/></joint>
</robot>"""


def _arm(lo, hi):
    return ARM.replace("TYPE", "revolute").replace("LIMIT", f'<limit lower="{lo}" upper="{hi}" effort="1" velocity="1"/>')


@pytest.mark.parametrize("lo, hi", [("-1e308", "1e308"), ("0", "1e308"), ("-1e7", "0"), ("-inf", "inf")])
def test_limits_beyond_a_million_radians_read_as_a_continuous_joint(lo, hi):
    cont = from_urdf(ARM.replace("TYPE", "continuous").replace("LIMIT", ""))
    wide = from_urdf(_arm(lo, hi))
    np.testing.assert_array_equal(wide.limits, cont.limits)
    assert np.isinf(wide.limits[0]).all() and wide.limits[1].tolist() == [-3, 3]


def test_limits_within_a_million_radians_are_kept():
    assert from_urdf(_arm("-1e6", "1e6")).limits[0].tolist() == [-1e6, 1e6]


def test_limits_far_out_but_less_than_a_turn_apart_are_refused():
    with pytest.raises(URDFError, match=r"joint 'j1' has limits \[1e\+07, 1e\+07\] rad, beyond ±1e\+06 rad yet less "
                                        r"than a turn apart"):
        from_urdf(_arm("10000000", "10000001"))


def test_a_panda_joint_of_1e308_maps_as_the_same_joint_declared_continuous():
    # before: panda_joint4 at ±1e308 lost node (0, 0.2, -0.2) that the continuous joint reaches
    _, _, xml, _ = rtb.Robot.URDF_read("franka_description/robots/panda_arm_hand.urdf.xacro")
    j4 = re.search(r'<joint name="panda_joint4".*?</joint>', xml, re.S).group(0)
    wide = xml.replace(j4, re.sub(r'lower="[^"]*" upper="[^"]*"', 'lower="-1e308" upper="1e308"', j4))
    cont = xml.replace(j4, j4.replace('type="revolute"', 'type="continuous"'))
    nodes = ws.cartesian_grid(-0.4, 0.4, 0.2)
    maps = [ws.constant_orientation_map(from_urdf(x, ee_link="panda_link8"), nodes, (np.pi, 0, 0),
                                        convention="standard", method="numerical") for x in (wide, cont)]
    assert maps[1][np.flatnonzero((np.abs(nodes - [0, 0.2, -0.2]) < 1e-9).all(axis=1))[0]]
    np.testing.assert_array_equal(maps[0], maps[1])
    assert maps[0].sum() > 10


BOMB = ('<?xml version="1.0"?>\n<!DOCTYPE r [<!ENTITY a "aaaaaaaaaa">'
        + "".join(f'<!ENTITY {c} "{("&" + p + ";") * 10}">' for p, c in zip("abcdefgh", "bcdefghi"))
        + ']>\n<robot name="&i;"><link name="a"/></robot>')
SMALL_BOMB = ('<?xml version="1.0"?>\n<!DOCTYPE r [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;">]>\n'
              '<robot name="&b;"><link name="a"/></robot>')
EXTERNAL = '<?xml version="1.0"?>\n<!DOCTYPE r [<!ENTITY x SYSTEM "file:///etc/passwd">]>\n<robot name="&x;"/>'
DEEP = '<robot name="r"><link name="a"/>' + "<x>" * 10_000 + "</x>" * 10_000 + "</robot>"


@pytest.mark.parametrize("text, message", [
    (BOMB, "declares the XML entity 'a' (line 2); a URDF declares none"),
    (SMALL_BOMB, "declares the XML entity 'a' (line 2)"),
    (EXTERNAL, "declares the XML entity 'x' (line 2)"),
    (DEEP, "nests its elements deeper than 64 levels (at line 1)"),
])
def test_entity_bombs_and_deep_nesting_are_one_line_before_a_tree_is_built(tmp_path, text, message):
    p = tmp_path / "arm.urdf"
    p.write_text(text)
    with pytest.raises(URDFError) as e:
        from_urdf(p)
    assert str(e.value).startswith(f"URDF file {str(p)!r}") and message in str(e.value)
    assert "\n" not in str(e.value)
    from wsmap.collision import CollisionError, from_urdf_collision, load_scene

    with pytest.raises(URDFError, match=re.escape(message)):  # ET.tostring recursed on DEEP before
        from_urdf_collision(p)
    with pytest.raises(CollisionError, match=re.escape(message)):  # a work cell
        load_scene(p)


def test_the_command_line_says_so_in_one_line_and_writes_nothing(tmp_path, capsys):
    p = tmp_path / "arm.urdf"
    p.write_text(DEEP)
    assert cli.main(["map", "--urdf", str(p), "--kind", "reach", "--step", "0.5", "--quiet",
                     "--out", str(tmp_path / "m.npz")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "nests its elements deeper than 64 levels" in err and "Traceback" not in err
    assert [x.name for x in tmp_path.iterdir()] == ["arm.urdf"]
