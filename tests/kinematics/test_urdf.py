"""wsmap.kinematics.urdf.from_urdf: transforms, limits, the chain it picks, and every bad input.

Small URDFs are written inline; the real ones are rtb-data's (iiwa 14 and Gen3 plain URDFs, the
Panda and UR5 xacros expanded offline by Robotics Toolbox), checked against Robotics Toolbox's own
forward kinematics of the same files and against the named arms of :mod:`wsmap.robots`.
"""

from __future__ import annotations

import os
import re

import numpy as np
import pytest

from frames import hom, max_err_up_to_tool
from wsmap import robots
from wsmap.kinematics import rotx, roty, rotz
from wsmap.kinematics.urdf import URDFError, URDFWarning, from_urdf

rtb = pytest.importorskip("roboticstoolbox")
rtbdata = pytest.importorskip("rtbdata")
XACRO = os.path.join(os.path.dirname(rtbdata.__file__), "xacro")
IIWA_URDF = os.path.join(XACRO, "kuka_description/kuka_lbr_iiwa/urdf/lbr_iiwa_14_r820.urdf")
GEN3_URDF = os.path.join(XACRO, "kortex_description/arms/gen3/7dof/urdf/GEN3_URDF_V12.urdf")

LIMIT = '<limit lower="-1" upper="1" effort="1" velocity="1"/>'


def link(name, mesh=None):
    if mesh is None:
        return f'<link name="{name}"/>'
    return f'<link name="{name}"><visual><geometry><mesh filename="{mesh}"/></geometry></visual></link>'


def joint(name, parent, child, type="revolute", xyz="0 0 0.1", rpy="0 0 0", axis="0 0 1", extra=LIMIT):
    return (f'<joint name="{name}" type="{type}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>{extra}</joint>')


def robot(*parts, name="r"):
    return f'<?xml version="1.0"?>\n<robot name="{name}">' + "".join(parts) + "</robot>"


def two_link(**kw):
    """a -j1-> b -j2-> c, j2 configurable."""
    return robot(link("a"), link("b"), link("c"), joint("j1", "a", "b"), joint("j2", "b", "c", **kw))


# ------------------------------------------------------------------------------ transforms and limits
def test_origin_rpy_and_axis_follow_the_urdf_convention():
    r, p, y = 0.3, -0.7, 1.1
    axis = np.array([1.0, 2.0, -2.0]) / 3.0
    urdf = robot(link("a"), link("b"), joint("j", "a", "b", xyz="0.1 -0.2 0.3", rpy=f"{r} {p} {y}",
                                                axis="1 2 -2"))
    arm = from_urdf(urdf)
    expected_origin = hom(rotz(y) @ roty(p) @ rotx(r), (0.1, -0.2, 0.3))  # R = Rz(yaw) Ry(pitch) Rx(roll)
    np.testing.assert_allclose(arm.fixed[0], expected_origin, atol=1e-15)
    np.testing.assert_allclose(arm.fixed[1], np.eye(4), atol=0)
    np.testing.assert_allclose(arm.axes[0], axis, atol=1e-15)
    q = 0.9  # Rodrigues: rotation by q about the (unit) axis, in the joint's frame
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    R = np.eye(3) + np.sin(q) * K + (1 - np.cos(q)) * K @ K
    np.testing.assert_allclose(arm.fkine([q]), expected_origin @ hom(R), atol=1e-14)


def test_fixed_joints_fold_into_the_neighbouring_transforms_and_limits_are_carried():
    urdf = robot(
        link("world"), link("base"), link("l1"), link("l2"), link("l3"), link("flange"),
        joint("mount", "world", "base", type="fixed", xyz="0 0 0.5", rpy="0 0 1.5707963267948966", extra=""),
        joint("j1", "base", "l1", type="continuous", xyz="0 0 0.2", extra=""),
        joint("bracket", "l1", "l2", type="fixed", xyz="0.3 0 0", rpy="1.5707963267948966 0 0", extra=""),
        joint("slide", "l2", "l3", type="prismatic", xyz="0 0.1 0", axis="1 0 0",
              extra='<limit lower="0.0" upper="0.25" effort="1" velocity="1"/>'),
        joint("j3", "l3", "flange", xyz="0 0 0.05", axis="0 -1 0",
              extra='<limit lower="-2" upper="0.5" effort="1" velocity="1"/>'),
    )
    arm = from_urdf(urdf, name="toy")
    assert (arm.n, arm.kinds, arm.name, arm.source) == (3, ("R", "P", "R"), "toy", "URDF text")
    assert arm.links == ("l1", "l3", "flange", "flange")
    np.testing.assert_array_equal(arm.qlim, [[-np.inf, np.inf], [0.0, 0.25], [-2.0, 0.5]])
    q = np.array([0.4, 0.1, -1.2])
    expected = (hom(rotz(np.pi / 2), (0, 0, 0.5)) @ hom(p=(0, 0, 0.2)) @ hom(rotz(q[0]))
                @ hom(rotx(np.pi / 2), (0.3, 0, 0)) @ hom(p=(0, 0.1, 0)) @ hom(p=(q[1], 0, 0))
                @ hom(p=(0, 0, 0.05)) @ hom(roty(-q[2])))
    np.testing.assert_allclose(arm.fkine(q), expected, atol=1e-14)
    assert arm.within_limits(q) and not arm.within_limits([0.0, 0.3, 0.0])


def test_all_continuous_is_unlimited_and_base_link_starts_the_chain_part_way():
    urdf = robot(link("a"), link("b"), link("c"), joint("j1", "a", "b", type="continuous", extra=""),
                 joint("j2", "b", "c", type="continuous", extra=""))
    assert from_urdf(urdf).qlim is None
    part = from_urdf(urdf, base_link="b")
    assert part.n == 1
    np.testing.assert_allclose(part.fkine([0.0])[:3, 3], [0, 0, 0.1])


def test_missing_meshes_never_matter(tmp_path):
    urdf = robot(link("a", mesh="package://no_such_package/meshes/base.stl"),
                 link("b", mesh=str(tmp_path / "missing.dae")), joint("j", "a", "b"))
    path = tmp_path / "arm.urdf"
    path.write_text(urdf)
    for source in (urdf, path, str(path)):
        arm = from_urdf(source)
        assert arm.n == 1
        np.testing.assert_allclose(arm.fkine([0.0])[:3, 3], [0, 0, 0.1])
    assert from_urdf(path).source == str(path)


def test_side_branches_are_ignored_off_the_chain():
    # a gripper: two fingers, one a mimic, and a floating marker; none is on the path to "flange"
    urdf = robot(link("a"), link("flange"), link("left"), link("right"), link("marker"),
                 joint("j", "a", "flange"),
                 joint("f1", "flange", "left", type="prismatic", axis="0 1 0"),
                 joint("f2", "flange", "right", type="prismatic", axis="0 -1 0",
                       extra=LIMIT + '<mimic joint="f1"/>'),
                 joint("float", "a", "marker", type="floating", extra=""))
    arm = from_urdf(urdf, ee_link="flange")
    assert arm.n == 1 and arm.links == ("flange", "flange")
    assert from_urdf(urdf, ee_link="left").kinds == ("R", "P")


# ------------------------------------------------------------------------------ bad input
@pytest.mark.parametrize("urdf, kwargs, message", [
    ("this is not <xml", {}, "URDF text is not XML: syntax error: line 1, column 0"),
    ("<robot name='r'><link name='a'/>", {}, "URDF text is not XML: no element found: line 1, column 32"),
    ("<model name='r'/>", {}, "URDF text: the root element is <model>, not <robot>"),
    ('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><xacro:include filename="arm.xacro"/></robot>',
     {}, "URDF text contains xacro (<xacro:include>): expand it to plain URDF first (e.g. with the xacro tool)"),
    (two_link(), {"ee_link": "tool0"}, "URDF text: unknown ee_link 'tool0'; the links are: a, b, c"),
    (two_link(), {"base_link": "world"}, "URDF text: unknown base_link 'world'; the links are: a, b, c"),
    (robot(link("a"), link("b"), joint("j", "a", "zz")), {},
     "URDF text: joint 'j' names an unknown child link 'zz'"),
    (two_link(), {"base_link": "c", "ee_link": "a"},
     "URDF text: no path from base link 'c' to end link 'a' ('a' is not below 'c')"),
    (robot(link("a"), link("b"), link("c"), link("d"), joint("j1", "a", "b"), joint("j2", "a", "c"),
           joint("j3", "b", "d"), joint("j4", "c", "d")), {},
     "URDF text: link 'd' has two parent joints, 'j3' and 'j4': a loop (a URDF must be a tree)"),
    (robot(link("a"), link("b"), link("c"), joint("j1", "a", "b"), joint("j2", "b", "c"), joint("j3", "c", "b")),
     {}, "URDF text: link 'b' has two parent joints, 'j1' and 'j3': a loop (a URDF must be a tree)"),
    (robot(link("a"), link("b"), link("c"), joint("j1", "b", "c"), joint("j2", "c", "b")), {},
     "URDF text: the joints form a loop: b -> c -> b"),
    (two_link(type="floating", extra=""), {}, "URDF text: joint 'j2' on the chain from 'a' to 'c' is floating; "
     "only revolute, continuous, prismatic and fixed joints are supported"),
    (two_link(type="planar", extra=""), {}, "URDF text: joint 'j2' on the chain from 'a' to 'c' is planar; "
     "only revolute, continuous, prismatic and fixed joints are supported"),
    (two_link(type="prismatic", extra=LIMIT + '<mimic joint="j1" multiplier="-1"/>'), {},
     "URDF text: joint 'j2' on the chain mimics 'j1', a revolute joint driving a prismatic one: the chain's "
     "variable would change units"),
    (two_link(type="ball"), {}, "URDF text: joint 'j2' has type 'ball'; URDF types are revolute, continuous, "
     "prismatic, fixed, floating, planar"),
    (two_link(xyz="0 nan 0.1"), {}, "URDF text: joint 'j2' <origin xyz> contains NaN or infinity: '0 nan 0.1'"),
    (two_link(rpy="0 0 inf"), {}, "URDF text: joint 'j2' <origin rpy> contains NaN or infinity: '0 0 inf'"),
    (two_link(xyz="0 0"), {}, "URDF text: joint 'j2' <origin xyz> is not three numbers: '0 0'"),
    (two_link(axis="0 0 NaN"), {}, "URDF text: joint 'j2' <axis xyz> contains NaN or infinity: '0 0 NaN'"),
    (two_link(axis="0 0 0"), {}, "URDF text: joint 'j2' has a zero <axis>"),
    (two_link(extra='<limit lower="1" upper="-1" effort="1" velocity="1"/>'), {},
     "URDF text: joint 'j2' has lower limit 1.0 above its upper limit -1.0"),
    (two_link(extra='<limit lower="nan" upper="1" effort="1" velocity="1"/>'), {},
     "URDF text: joint 'j2' has a NaN limit lower='nan'"),
    (two_link(extra=""), {}, "URDF text: revolute joint 'j2' has no <limit lower=... upper=...>"),
    (two_link(extra='<limit lower="-1" upper="1" velocity="1"/>'), {},
     "URDF text: joint 'j2' has a <limit> without 'effort' (the URDF specification requires effort and velocity "
     "on every <limit>)"),
    (two_link(type="prismatic", extra='<limit lower="0" upper="1" effort="1"/>'), {},
     "URDF text: joint 'j2' has a <limit> without 'velocity' (the URDF specification requires effort and velocity "
     "on every <limit>)"),
    (two_link().replace('<robot name="r">', "<robot>"), {},
     "URDF text: the <robot> element has no name (the URDF specification requires one)"),
    (robot(link("a"), link("b"), link("c"), joint("j1", "a", "b"), joint("j2", "a", "c")), {},
     "URDF text: the tree branches below 'a', so give ee_link; the candidate end links are: b, c"),
    (robot(link("a"), link("b"), joint("j", "a", "b", type="fixed", extra="")), {},
     "URDF text: no movable joint between 'a' and 'b'"),
    (robot(link("a"), link("b"), link("c"), joint("j", "a", "b")), {},
     "URDF text is not one tree: it has several root links (a, c); give base_link (wsmap map/place: --base LINK)"),
])
def test_bad_urdf_is_a_clear_error(urdf, kwargs, message):
    with pytest.raises(URDFError, match=f"^{re.escape(message)}$"):
        from_urdf(urdf, **kwargs)


def test_bad_files_are_named(tmp_path):
    bad = tmp_path / "broken.urdf"
    bad.write_text("<robot name='r'><link name='a'>")
    with pytest.raises(URDFError, match=f"^{re.escape(f'URDF file {str(bad)!r} is not XML: ')}"):
        from_urdf(bad)
    with pytest.raises(FileNotFoundError, match=re.escape(f"no such URDF file: {str(tmp_path / 'nope.urdf')!r}")):
        from_urdf(tmp_path / "nope.urdf")
    assert issubclass(URDFError, ValueError)


def test_a_real_gripper_mimic_joint_takes_its_drivers_value():
    import io

    import yourdfpy

    _, _, panda, _ = rtb.Robot.URDF_read("franka_description/robots/panda_arm_hand.urdf.xacro")
    with pytest.raises(URDFError, match="candidate end links are: panda_leftfinger, panda_rightfinger"):
        from_urdf(panda)
    # panda_finger_joint2 mimics panda_finger_joint1, off the chain to the right finger
    chain = from_urdf(panda, ee_link="panda_rightfinger")
    assert chain.n == 8 and chain.kinds[-1] == "P" and chain.qlim[-1].tolist() == [0.0, 0.04]
    model = yourdfpy.URDF.load(io.StringIO(panda), build_scene_graph=True, load_meshes=False)
    names = [f"panda_joint{i}" for i in range(1, 8)] + ["panda_finger_joint1"]
    for q in chain.random_q(10, np.random.default_rng(1)):
        model.update_cfg(dict(zip(names, q)))  # yourdfpy moves the mimic joint itself
        np.testing.assert_allclose(chain.fkine(q), model.get_transform("panda_rightfinger", "panda_link0"),
                                   atol=1e-14)


# ------------------------------------------------------------------------------ real URDFs (rtb-data)
def test_rtb_data_urdfs_match_robotics_toolbox_and_the_named_arms():
    rng = np.random.default_rng(11)
    _, _, panda_xacro, _ = rtb.Robot.URDF_read("franka_description/robots/panda_arm_hand.urdf.xacro")
    cases = [  # (our chain from the URDF, rtb's model of the same file, its flange link, named arm, tolerance)
        (from_urdf(panda_xacro, ee_link="panda_link8"), rtb.models.URDF.Panda(), "panda_link8", "panda", 1e-12),
        # the ROS-Industrial iiwa URDF puts A2 at x = -0.43624 mm and A4 at +0.43624 mm off the A1 line;
        # KUKA's dimensions have no such offset: < 1 mm (test_robots pins this down exactly)
        (from_urdf(IIWA_URDF, ee_link="tool0"), rtb.Robot.URDF(IIWA_URDF), "tool0", "iiwa14", 1e-3),
        # Kinova's URDF has 0.01 mm more precise lengths, 0.175 mm lateral offsets at joints 6-7 that the
        # DH table drops, and rpy rounded to 1.5708 / 3.1416: < 1 mm from the user guide's table
        (from_urdf(GEN3_URDF), rtb.Robot.URDF(GEN3_URDF), "EndEffector_Link", "gen3", 1e-3),
    ]
    for ours, theirs, flange, named, tol in cases:
        assert ours.n == 7 and ours.links[-1] == flange
        qs = robots.load(named).random_q(20, rng)
        err, C = max_err_up_to_tool(ours.fkine, lambda q: theirs.fkine(q, end=flange).A, qs)
        assert err < 1e-12, (named, err)  # the same file read by two parsers: equal, base and flange too
        np.testing.assert_allclose(C, np.eye(4), atol=1e-12)
        err, C = max_err_up_to_tool(ours.fkine, robots.load(named).fkine, qs)
        assert err < tol, (named, err)
        np.testing.assert_allclose(C, np.eye(4), atol=3e-4)  # same base frame, same flange frame
        rtb_lim = theirs.qlim.T
        finite = np.isfinite(ours.qlim[:, 0])
        np.testing.assert_array_equal(ours.qlim[finite], rtb_lim[finite])


def test_ur5_urdf_matches_ur_dh_table_with_the_ros_base_turned_half_a_turn():
    # ROS's base_link is UR's base frame turned by pi about z (the URDF's fixed joint to "base")
    _, _, ur5, _ = rtb.Robot.URDF_read("ur_description/urdf/ur5_joint_limited_robot.urdf.xacro")
    ours = from_urdf(ur5, ee_link="tool0")
    assert ours.n == 6 and ours.links[-1] == "tool0"
    dh = robots.from_dh(d=[0.089159, 0, 0, 0.10915, 0.09465, 0.0823], a=[0, -0.425, -0.39225, 0, 0, 0],
                        alpha=[np.pi / 2, 0, 0, np.pi / 2, -np.pi / 2, 0])  # UR's published UR5 table
    qs = np.random.default_rng(5).uniform(-np.pi, np.pi, (20, 6))
    err, C = max_err_up_to_tool(ours.fkine, dh.fkine, qs, B=hom(rotz(np.pi)))
    assert err < 1e-12
    np.testing.assert_allclose(C, np.eye(4), atol=1e-12)
    np.testing.assert_allclose(ours.qlim, np.tile([-np.pi, np.pi], (6, 1)))


def test_what_only_yourdfpy_trips_on_is_still_a_urdf_error():
    # a non-numeric effort off the chain: our checks do not read it, yourdfpy's parser does
    urdf = robot(link("a"), link("b"), link("c"), joint("j", "a", "b"),
                 joint("k", "a", "c", extra='<limit lower="0" upper="1" effort="lots" velocity="1"/>'))
    with pytest.raises(URDFError, match=r"^URDF text: yourdfpy cannot read it: ValueError: "):
        from_urdf(urdf, ee_link="b")


# ------------------------------------------------------------------------------ the specification's defaults
def test_a_limit_without_lower_and_upper_is_zero_as_the_spec_and_pinocchio_read_it():
    pin = pytest.importorskip("pinocchio")
    urdf = two_link(extra='<limit effort="1" velocity="1"/>')
    with pytest.warns(URDFWarning, match=r"^URDF text: joint 'j2' has a <limit> without lower and upper: read as 0 "
                                         r"\(the URDF specification's default\), limits \[0, 0\] so it cannot move$"):
        arm = from_urdf(urdf)
    model = pin.buildModelFromXML(urdf)
    np.testing.assert_array_equal(arm.qlim[1], [model.lowerPositionLimit[1], model.upperPositionLimit[1]])
    np.testing.assert_array_equal(arm.qlim[1], [0.0, 0.0])


def test_a_limit_without_lower_reads_it_as_zero_with_a_warning():
    with pytest.warns(URDFWarning, match=r"without lower: read as 0 .* limits \[0, 1\]$"):
        arm = from_urdf(two_link(type="prismatic", extra='<limit upper="1" effort="1" velocity="1"/>'))
    np.testing.assert_array_equal(arm.qlim[1], [0.0, 1.0])
    with pytest.raises(URDFError, match=r"^URDF text: joint 'j2' has lower limit 0.0 above its upper limit -1.0$"):
        with pytest.warns(URDFWarning):
            from_urdf(two_link(extra='<limit upper="-1" effort="1" velocity="1"/>'))


def test_a_namespace_on_robot_reads_as_the_same_chain():
    plain = two_link(xyz="0.1 0.2 0.3", rpy="0.1 0.2 0.3")
    spaced = plain.replace('<robot name="r">', '<robot name="r" xmlns="http://www.ros.org/urdf">')
    a, b = from_urdf(plain), from_urdf(spaced)
    np.testing.assert_array_equal(a.fixed, b.fixed)
    np.testing.assert_array_equal(a.qlim, b.qlim)
    assert b.links == a.links


def test_a_file_whose_name_holds_a_less_than_sign_is_read_as_a_file(tmp_path):
    f = tmp_path / "arm<v2>.urdf"
    f.write_text(two_link())
    arm = from_urdf(str(f))
    assert arm.n == 2 and arm.source == str(f)


def test_the_loop_check_is_linear_in_the_links(monkeypatch):
    # a chain of 1000 fixed links: the old check walked every link to the root (n²/2 parent look-ups)
    n = 1000
    parts = [link(f"l{i}") for i in range(n + 1)] + [joint("j0", "l0", "l1")]
    parts += [joint(f"j{i}", f"l{i}", f"l{i + 1}", type="fixed", extra="") for i in range(1, n)]
    from wsmap.kinematics import urdf as urdf_module

    calls = []
    real = urdf_module.URDFTree.parent
    monkeypatch.setattr(urdf_module.URDFTree, "parent", lambda self, link: calls.append(1) or real(self, link))
    arm = from_urdf(robot(*parts))
    assert arm.n == 1 and arm.links[-1] == f"l{n}"
    assert len(calls) <= 3 * n
