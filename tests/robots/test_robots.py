"""wsmap.robots: the named arms against independent implementations, load(), from_dh().

The named arms come from manufacturers' tables (one module per arm in wsmap.robots.arms, collected
in wsmap.robots.NAMED); here each is compared with Robotics Toolbox for Python (its rtb-data URDFs,
read by rtb's own parser) at random configurations, up to a constant tool transform estimated at
q = 0 with the base frames related by a known transform, so any other configuration checks joint
zeros, signs, axes and lengths.
"""

from __future__ import annotations

import os
import re

import numpy as np
import pytest

from frames import hom, inv, max_err_up_to_tool
from wsmap import robots
from wsmap.kinematics import DHRobot, SerialChain, from_dh, rotx, rotz
from wsmap.kinematics.urdf import from_urdf
from wsmap.robots.arms._ur import ur_table

rtb = pytest.importorskip("roboticstoolbox")
rtbdata = pytest.importorskip("rtbdata")
XACRO = os.path.join(os.path.dirname(rtbdata.__file__), "xacro")
IIWA_URDF = os.path.join(XACRO, "kuka_description/kuka_lbr_iiwa/urdf/lbr_iiwa_14_r820.urdf")

NAMES = ["puma560", "panda", "iiwa14", "ur5e", "ur10e", "gen3"]


@pytest.fixture(scope="module")
def rng():
    return np.random.default_rng(2024)


# ------------------------------------------------------------------------------ the named arms vs rtb
@pytest.mark.parametrize("name, model, flange, tol", [
    ("panda", "Panda", "panda_link8", 1e-12),
    # rtb's LBR is the ROS-Industrial URDF, whose A2/A4 sit -/+0.43624 mm off the A1 line (KUKA's
    # dimensions have none): 0.8 mm at worst; test_iiwa14_differs_from_the_urdf_only_by_its_offsets
    ("iiwa14", "LBR", "tool0", 1e-3),
    # rtb's KinovaGen3 is ros_kortex's URDF: lengths to 0.01 mm (the guide's to 0.1 mm), 0.175 mm
    # lateral offsets at joints 6-7 that the DH table drops, rpy rounded to 1.5708: 0.53 mm at worst
    ("gen3", "KinovaGen3", "end_effector_link", 1e-3),
])
def test_named_arm_matches_robotics_toolbox_urdf(name, model, flange, tol, rng):
    arm = robots.load(name)
    theirs = getattr(rtb.models.URDF, model)()
    qs = arm.random_q(20, rng)
    err, C = max_err_up_to_tool(arm.fkine, lambda q: theirs.fkine(q, end=flange).A, qs)
    assert err < tol, err
    # same base frame (B = I, not estimated) and the same flange frame
    np.testing.assert_allclose(C, np.eye(4), atol=3e-4)


def test_puma560_matches_robotics_toolbox_dh_up_to_its_base_height(rng):
    arm = robots.load("puma560")
    theirs = rtb.models.DH.Puma560()
    qs = rng.uniform(-np.pi, np.pi, (20, 6))
    d1 = theirs.links[0].d  # 0.67183 in rtb, 0 in the paper
    err, C = max_err_up_to_tool(arm.fkine, lambda q: theirs.fkine(q).A, qs, B=hom(p=(0, 0, -d1)))
    assert err < 1e-12
    np.testing.assert_allclose(C, np.eye(4), atol=1e-12)


def test_limits_equal_robotics_toolbox_where_it_has_them():
    np.testing.assert_array_equal(robots.load("panda").qlim, rtb.models.URDF.Panda().qlim.T)
    # KUKA's ±170/±120/±175 deg; the URDF writes them as 2.9668/2.0942/3.0541 rad (0.015 deg short)
    np.testing.assert_allclose(robots.load("iiwa14").qlim, rtb.models.URDF.LBR().qlim.T, atol=3e-4)
    # Gen3: the continuous joints agree (unlimited); joints 2/4/6 are the user guide's ±128.9/±147.8/±120.3
    # deg, tighter than ros_kortex's URDF (±2.41/±2.66/±2.23 rad = ±138.1/±152.4/±127.8 deg)
    gen3, urdf = robots.load("gen3").qlim, rtb.models.URDF.KinovaGen3().qlim.T
    continuous = [0, 2, 4, 6]
    assert np.all(np.isinf(gen3[continuous]))
    np.testing.assert_allclose(gen3[[1, 3, 5]], np.deg2rad([[-128.9, 128.9], [-147.8, 147.8], [-120.3, 120.3]]))
    np.testing.assert_array_equal(urdf[[1, 3, 5]], [[-2.41, 2.41], [-2.66, 2.66], [-2.23, 2.23]])
    # puma560 (paper: MATLAB toolbox mdl_puma560): joints 1, 5, 6 as rtb-python; 2-4 are MATLAB's
    puma = np.deg2rad(robots.PUMA560_QLIM_DEG)
    theirs = rtb.models.DH.Puma560().qlim.T
    np.testing.assert_allclose(puma[[0, 4, 5]], theirs[[0, 4, 5]], atol=1e-12)
    np.testing.assert_allclose(robots.load("puma560", joint_limits=True).qlim, puma)


def test_iiwa14_differs_from_the_urdf_only_by_its_offsets():
    # Zero the ROS-Industrial URDF's ±0.43624 mm x-offsets of A2 and A4: then it is KUKA's arm exactly.
    text = open(IIWA_URDF).read()
    assert text.count('xyz="-0.00043624 0 0.36"') == 1 and text.count('xyz="0.00043624 0 0.42"') == 1
    text = text.replace('xyz="-0.00043624 0 0.36"', 'xyz="0 0 0.36"').replace('xyz="0.00043624 0 0.42"',
                                                                                'xyz="0 0 0.42"')
    arm, urdf = robots.load("iiwa14"), from_urdf(text, ee_link="tool0")
    qs = arm.random_q(20, np.random.default_rng(3))
    np.testing.assert_allclose(arm.fkine(qs), urdf.fkine(qs), atol=1e-12)


@pytest.mark.parametrize("name, rtb_model, cb3_lengths", [
    # UR's published tables for the CB3 UR5 / UR10, which rtb-data describes as URDFs
    ("ur5e", "UR5", dict(d1=0.089159, a2=-0.425, a3=-0.39225, d4=0.10915, d5=0.09465, d6=0.0823)),
    ("ur10e", "UR10", dict(d1=0.1273, a2=-0.612, a3=-0.5723, d4=0.163941, d5=0.1157, d6=0.0922)),
])
def test_ur_e_series_against_eaik_and_the_structure_of_rtb_ur_urdf(name, rtb_model, cb3_lengths, rng):
    """No independent model of the e-series is installed, so two checks, each partial:

    1. eaik's ``DhRobot(alpha, a, d).fwdKin`` on the same table: proves our standard-DH forward
       kinematics of the e-series numbers (convention, zero offsets, flange at d6), not the numbers.
    2. The same builder (wsmap.robots.arms._ur.ur_table: UR's alpha column, zero offsets, base =
       UR's base frame, end = the flange) with UR's published CB3 UR5/UR10 lengths equals rtb's UR5/UR10 URDF
       (tool0 in the URDF's "base" frame, UR's controller frame) exactly, with C = I: the axis
       layout, joint zero and signs, base and flange frames are UR's. The e-series changes only the
       six lengths, which are checked against UR's document by their literal values.
    """
    arm, table = robots.load(name), robots.NAMED[name]
    eaik = pytest.importorskip("eaik.IK_DH")
    d, a, alpha, offset = np.array(table.rows).T
    assert np.all(offset == 0)
    theirs = eaik.DhRobot(alpha, a, d)
    qs = arm.random_q(20, rng)
    assert max(np.abs(arm.fkine(q) - theirs.fwdKin(q)).max() for q in qs) < 1e-12

    cb3 = ur_table("cb3", "cb3", **cb3_lengths).chain()
    np.testing.assert_array_equal(cb3.axes, arm.axes)
    np.testing.assert_array_equal(cb3.offset, arm.offset)
    urdf = getattr(rtb.models.URDF, rtb_model)()

    def tool0_in_base(q):
        return inv(urdf.fkine(q, end="base").A) @ urdf.fkine(q, end="tool0").A

    err, C = max_err_up_to_tool(cb3.fkine, tool0_in_base, qs)
    assert err < 1e-12
    np.testing.assert_allclose(C, np.eye(4), atol=1e-12)


def test_the_tables_hold_the_manufacturers_numbers():
    ur5e, ur10e = robots.NAMED["ur5e"], robots.NAMED["ur10e"]
    d, a, alpha, _ = np.array(ur5e.rows).T
    np.testing.assert_array_equal(d, [0.1625, 0, 0, 0.1333, 0.0997, 0.0996])
    np.testing.assert_array_equal(a, [0, -0.425, -0.3922, 0, 0, 0])
    np.testing.assert_array_equal(alpha, [np.pi / 2, 0, 0, np.pi / 2, -np.pi / 2, 0])
    d, a, _, _ = np.array(ur10e.rows).T
    np.testing.assert_array_equal(d, [0.1807, 0, 0, 0.17415, 0.11985, 0.11655])
    np.testing.assert_array_equal(a, [0, -0.6127, -0.57155, 0, 0, 0])
    for name in ("ur5e", "ur10e"):
        np.testing.assert_allclose(robots.load(name).qlim, np.tile([-2 * np.pi, 2 * np.pi], (6, 1)))
    np.testing.assert_allclose(robots.load("iiwa14").qlim[:, 1], np.deg2rad([170, 120, 170, 120, 170, 120, 175]))
    for table in robots.NAMED.values():
        assert table.source and robots.load(table.name).source == table.source


def test_zero_poses_by_hand_from_the_manufacturers_tables():
    # Panda: x = a4 + a5 + a7 = 0.088, z = d1 + d3 + d5 - d_flange = 0.926, flange z pointing down
    T = robots.load("panda").fkine(np.zeros(7))
    np.testing.assert_allclose(T, hom(np.diag([1.0, -1.0, -1.0]), (0.088, 0, 0.926)), atol=1e-12)
    # Gen3: straight up; the lateral lengths of joints 2 and 4 to -y, the others up
    T = robots.load("gen3").fkine(np.zeros(7))
    y = -(0.0054 + 0.0064) - (0.0064 + 0.0064)
    z = (0.1564 + 0.1284) + (0.2104 + 0.2104) + (0.2084 + 0.1059) + (0.1059 + 0.0615)
    np.testing.assert_allclose(T, hom(p=(0, y, z)), atol=1e-12)
    # iiwa 14: straight up, 0.360 + 0.420 + 0.400 + 0.126
    np.testing.assert_allclose(robots.load("iiwa14").fkine(np.zeros(7)), hom(p=(0, 0, 1.306)), atol=1e-12)
    # UR5e: stretched out along -x at the height d1 - d5, flange offset -(d4 + d6) in y
    T = robots.load("ur5e").fkine(np.zeros(6))
    np.testing.assert_allclose(T, hom(rotx(np.pi / 2), (-0.425 - 0.3922, -0.1333 - 0.0996, 0.1625 - 0.0997)),
                               atol=1e-12)


# ------------------------------------------------------------------------------ load / from_name
def test_load_returns_each_arm_with_its_default_limits():
    for name in NAMES:
        arm = robots.load(name)
        assert arm.name == name and arm.n == (6 if name in ("puma560", "ur5e", "ur10e") else 7)
        if name == "puma560":
            assert isinstance(arm, DHRobot) and arm.qlim is None  # the paper's arm, limits off
        else:
            assert isinstance(arm, SerialChain) and arm.qlim.shape == (arm.n, 2)
        assert arm.fkine(np.zeros((3, arm.n))).shape == (3, 4, 4)
    assert robots.load("PANDA", joint_limits=False).qlim is None
    assert robots.load("puma560", joint_limits=True).qlim.shape == (6, 2)
    assert list(robots.ROBOTS) == NAMES
    np.testing.assert_array_equal(robots.from_name("gen3").qlim, robots.load("gen3").qlim)


def test_unknown_robot_lists_the_known_ones():
    with pytest.raises(ValueError, match=re.escape(
            "unknown robot 'kuka'; known robots: puma560, panda, iiwa14, ur5e, ur10e, gen3")):
        robots.load("kuka")


def test_joint_limits_are_honoured():
    panda = robots.load("panda")
    inside = panda.random_q(200, np.random.default_rng(0))
    assert panda.within_limits(inside).all()
    assert not panda.within_limits(np.zeros(7))  # joint 4 must stay in [-3.0718, -0.0698]
    gen3 = robots.load("gen3")
    q = np.zeros(7)
    q[[0, 2, 4, 6]] = 100.0  # continuous joints: any angle
    assert gen3.within_limits(q)
    q[1] = np.deg2rad(129.0)
    assert not gen3.within_limits(q)


# ------------------------------------------------------------------------------ from_dh
def test_modified_dh_is_craigs_product():
    rng = np.random.default_rng(7)
    d, a, alpha, q, off = (rng.uniform(-1, 1, 5) for _ in range(5))
    flange = hom(rotz(0.3), (0.0, 0.0, 0.107))
    arm = robots.from_dh(d, a, alpha, offset=off, modified=True, flange=flange)

    def Rx(t):
        return hom(rotx(t))

    def Rz(t):
        return hom(rotz(t))

    def Tx(x):
        return hom(p=(x, 0, 0))

    def Tz(z):
        return hom(p=(0, 0, z))

    T = np.eye(4)
    for i in range(5):  # link i: Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)
        T = T @ Rx(alpha[i]) @ Tx(a[i]) @ Rz(q[i] + off[i]) @ Tz(d[i])
    np.testing.assert_allclose(arm.fkine(q), T @ flange, atol=1e-14)
    # and standard DH is the paper's DHRobot
    std = robots.from_dh(d, a, alpha)
    np.testing.assert_allclose(std.fkine(q), DHRobot(d, a, alpha).fkine(q), atol=1e-14)


@pytest.mark.parametrize("modified", [False, True])
def test_from_dh_batches_over_arms(modified):
    rng = np.random.default_rng(8)
    d, a, alpha = (rng.uniform(-0.5, 0.5, (4, 6)) for _ in range(3))
    offset = rng.uniform(-1, 1, (4, 6))
    arms = robots.from_dh(d, a, alpha, offset=offset, modified=modified)
    assert arms.batch_shape == (4,)
    q = rng.uniform(-np.pi, np.pi, (10, 1, 6))
    T = arms.fkine(q)
    assert T.shape == (10, 4, 4, 4)
    for k in range(4):
        one = robots.from_dh(d[k], a[k], alpha[k], offset=offset[k], modified=modified)
        np.testing.assert_allclose(T[:, k], one.fkine(q[:, 0]), atol=1e-14)
        np.testing.assert_allclose(arms[k].fkine(q[:, 0]), one.fkine(q[:, 0]), atol=1e-14)


def test_bad_dh_input_is_named():
    with pytest.raises(ValueError, match=r"^prismatic joint 2 needs limits: give qlim$"):
        from_dh([0.1, 0.2], [0, 0], [0, 0], prismatic=[False, True])
    with pytest.raises(ValueError, match=r"^prismatic joint 2 needs finite limits \(a slide has a stroke\)$"):
        from_dh([0.1, 0.2], [0, 0], [0, 0], prismatic=[False, True], qlim=[[-1, 1], [-np.inf, np.inf]])
    with pytest.raises(ValueError, match=r"^qlim of joint 2 has its lower limit above its upper limit$"):
        robots.from_dh([0.1, 0.2], [0, 0], [0, 0], qlim=[[-1, 1], [1, -1]])
    slide = from_dh([0.1, 0.2], [0, 0], [0, 0], prismatic=[False, True], qlim=[[-1, 1], [0, 0.5]])
    np.testing.assert_allclose(slide.fkine([0.0, 0.25])[:3, 3], [0, 0, 0.55])
