"""wsmap.kinematics.morphology: description -> chain -> FK is the arm it came from (named arms,
URDF arms, arbitrary chains), the canonical form is unique, known values, and every refusal."""

import os

import numpy as np
import pytest

import wsmap
from wsmap.kinematics import SerialChain, as_chain, from_dh
from wsmap.kinematics.morphology import (
    FEATURE_NAMES,
    N_FEATURES,
    MorphologyError,
    describe,
    mdh_transform,
    morphology_distance,
)
from wsmap.kinematics.urdf import from_urdf

rtbdata = pytest.importorskip("rtbdata")
XACRO = os.path.join(os.path.dirname(rtbdata.__file__), "xacro")
URDFS = {
    "iiwa14 (rtb-data)": (os.path.join(XACRO, "kuka_description/kuka_lbr_iiwa/urdf/lbr_iiwa_14_r820.urdf"), "tool0"),
    "gen3 (rtb-data)": (os.path.join(XACRO, "kortex_description/arms/gen3/7dof/urdf/GEN3_URDF_V12.urdf"), None),
}
try:
    import pybullet_data

    URDFS["panda (pybullet_data)"] = (os.path.join(pybullet_data.getDataPath(), "franka_panda/panda.urdf"),
                                      "panda_link8")
except ImportError:  # pragma: no cover - pybullet is a test dependency
    pass


def _fk_error(a, b, n, seed=0):
    q = np.random.default_rng(seed).uniform(-np.pi, np.pi, (200, n))
    return np.abs(as_chain(a).fkine(q) - as_chain(b).fkine(q)).max()


def _random_chain(n, seed):
    """A chain of arbitrary geometry: random fixed transforms, random axis directions, a base and a tool."""
    rng = np.random.default_rng(seed)

    def rigid():
        q = rng.standard_normal(4)
        q /= np.linalg.norm(q)
        w, x, y, z = q
        T = np.eye(4)
        T[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]
        T[:3, 3] = rng.uniform(-0.3, 0.3, 3)
        return T

    fixed = np.stack([rigid() for _ in range(n + 1)])
    return SerialChain(fixed, rng.standard_normal((n, 3)), "R" * n, offset=rng.uniform(-1, 1, n),
                       qlim=np.tile([-2.0, 2.5], (n, 1)), base=rigid(), tool=rigid(), name="random")


@pytest.mark.parametrize("name", list(wsmap.robots.ROBOTS))
def test_named_arm_round_trip_is_the_same_arm(name):
    arm = wsmap.load(name)
    m = describe(arm)
    assert m.n == arm.n and _fk_error(arm, m.chain(), arm.n) < 1e-12
    assert np.array_equal(m.qlim, as_chain(arm).limits)


@pytest.mark.parametrize("label", list(URDFS))
def test_urdf_arm_round_trip_is_the_same_arm(label):
    path, ee = URDFS[label]
    arm = from_urdf(path, ee_link=ee)
    m = describe(arm)
    assert _fk_error(arm, m.chain(), arm.n) < 1e-12
    # the URDF and the manufacturer's table describe one arm: the same canonical rows (URDF
    # meshes' frames are rounded to 0.1 mm)
    named = describe(wsmap.load(label.split()[0]))
    assert np.abs(m.mdh - named.mdh).max() < 1e-3


def test_nearly_parallel_axes_of_a_rounded_file_are_taken_as_parallel():
    """A UR5e whose parallel joints 2-4 are 1e-5 rad apart (as a URDF's rounded rpy leaves them):
    described as the nearest exact arm, its residual says how far, and the rebuilt chain is within
    about that much of the arm; the Kinova Gen3 6-DOF URDF (rpy 3.1416) is such an arm. Exact arms
    keep a residual of rounding."""
    ur = wsmap.load("ur5e")
    assert describe(ur).residual < 1e-12
    c = as_chain(ur)
    axes = c.axes.copy()
    axes[2] += 1e-5 * np.array([1.0, 1.0, 0.0])  # joint 3 (in its frame, z) tilted off joints 2 and 4
    bent = c.replace(axes=axes, name="bent ur5e")
    m = describe(bent)
    assert 1e-6 < m.residual < 1e-4
    assert _fk_error(bent, m.chain(), 6) < 1e-4
    assert np.abs(m.mdh[:, 2]).max() < 1.0  # no common normal kilometres down the axis
    gen3_6 = os.path.join(XACRO, "kortex_description/arms/gen3/6dof/urdf/GEN3-6DOF_NO-VISION_URDF_ARM_V01.urdf")
    arm = from_urdf(open(gen3_6).read(), name="gen3 6-DOF")
    m = describe(arm)
    assert m.n == 6 and m.residual < 1e-4 and _fk_error(arm, m.chain(), 6) < 1e-4


@pytest.mark.parametrize("n, seed", [(6, 0), (6, 1), (7, 2), (7, 3)])
def test_arbitrary_chain_round_trip_and_canonical_form(n, seed):
    arm = _random_chain(n, seed)
    m = describe(arm)
    assert _fk_error(arm, m.chain(), n) < 1e-12
    # the canonical form: its own description is itself
    again = describe(m.chain())
    for k in ("mdh", "mount", "tool", "signs"):
        assert np.allclose(getattr(again, k), getattr(m, k), atol=1e-9), k
    # Craig's rules: a >= 0, frame 0 on axis 1 (a_0 = alpha_0 = 0), the last row d = theta = 0
    assert np.all(m.mdh[:, 0] >= 0) and m.mdh[0, 0] == 0 and m.mdh[0, 1] == 0
    assert m.mdh[-1, 2] == 0 and m.mdh[-1, 3] == 0


def test_independent_fk_of_the_description_roboticstoolbox():
    """The description's rows are Craig's modified DH: Corke's RevoluteMDH links of the same rows
    (and the mount, tool) give the same poses."""
    rtb = pytest.importorskip("roboticstoolbox")
    for name in ("panda", "ur5e", "gen3"):
        m = describe(wsmap.load(name))
        links = [rtb.RevoluteMDH(a=a, alpha=al, d=d, offset=th) for a, al, d, th in m.mdh]
        robot = rtb.DHRobot(links, base=m.mount, tool=m.tool)
        q = np.random.default_rng(5).uniform(-np.pi, np.pi, (20, m.n)) * m.signs
        ours = m.chain().fkine(q * m.signs)
        theirs = np.stack([robot.fkine(qq).A for qq in q])
        assert np.abs(ours - theirs).max() < 1e-12, name


def test_known_values_ur5e_and_puma560():
    ur = describe(wsmap.load("ur5e"))
    # UR5e (standard DH d1 0.1625, a2 -0.425, a3 -0.3922, d4 0.1333, d5 0.0997, d6 0.0996): the
    # common normals give a = 0.425 and 0.3922 between the parallel axes 2-3 and 3-4
    assert np.allclose(ur.mdh[:, 0], [0, 0, 0.425, 0.3922, 0, 0])
    assert np.allclose(ur.mdh[:, 2], [0.1625, 0, 0, 0.1333, 0.0997, 0])
    assert np.allclose(ur.tool[:3, 3], [0, 0, 0.0996])
    assert np.allclose(np.abs(ur.mdh[:, 1]), [0, np.pi / 2, 0, 0, np.pi / 2, np.pi / 2])
    puma = describe(wsmap.load("puma560"))
    assert np.allclose(puma.mdh[:, 0], [0, 0, 0.4318, 0.0203, 0, 0])
    assert np.allclose(puma.mdh[:, 2], [0, 0, 0.15005, 0.4318, 0, 0])  # the paper's d3
    assert np.array_equal(ur.mount, np.eye(4)) and np.array_equal(ur.signs, np.ones(6))


def test_a_first_axis_pointing_down_is_turned_up():
    m = describe(wsmap.load("gen3"))  # Kinova's joint 1 turns about the base's -z
    assert m.signs.tolist() == [-1, 1, 1, 1, 1, 1, 1] and np.allclose(m.mount, np.eye(4))
    assert m.mdh[0, 2] == pytest.approx(0.2848)


def test_mdh_transform_is_rx_tx_rz_tz():
    a, al, d, th = 0.3, 0.7, -0.2, 1.1
    ca, sa, ct, st = np.cos(al), np.sin(al), np.cos(th), np.sin(th)
    Rx = np.array([[1, 0, 0, 0], [0, ca, -sa, 0], [0, sa, ca, 0], [0, 0, 0, 1]])
    Rz = np.array([[ct, -st, 0, 0], [st, ct, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    Tx, Tz = np.eye(4), np.eye(4)
    Tx[0, 3], Tz[2, 3] = a, d
    assert np.allclose(mdh_transform(a, al, d, th), Rx @ Tx @ Rz @ Tz, atol=1e-15)


def test_features_pad_six_joints_and_the_distance():
    f6 = describe(wsmap.load("ur5e")).features()
    f7 = describe(wsmap.load("panda")).features()
    assert f6.shape == f7.shape == (N_FEATURES,) == (len(FEATURE_NAMES),)
    assert f6[-1] == 1.0 and f7[-1] == 0.0 and np.all(f6[54:63] == 0.0)
    assert morphology_distance(f6, f6) == 0.0
    assert morphology_distance(f6, f7) > 1.0  # a 6-joint arm is never near a 7-joint one
    ur10 = describe(wsmap.load("ur10e")).features()
    assert 0.1 < morphology_distance(f6, ur10) < 1.0
    # a range of a full turn or more (UR: ±2 pi) reads as a full turn
    assert f6[FEATURE_NAMES.index("half_range_1")] == pytest.approx(np.pi)


def test_refusals_name_the_problem():
    with pytest.raises(MorphologyError, match="joint 2 is prismatic; a morphology has revolute joints only"):
        describe(from_dh([0.3, 0, 0.1, 0, 0, 0], [0] * 6, [0, np.pi / 2, 0, 0, 0, 0], prismatic=[0, 1, 0, 0, 0, 0],
                         qlim=np.tile([-1.0, 1.0], (6, 1)), name="slide"))
    with pytest.raises(MorphologyError, match="eight has 8 joints; a morphology has 6 or 7 revolute joints"):
        describe(from_dh([0.1] * 8, [0.1] * 8, [0.5] * 8, name="eight"))
    with pytest.raises(MorphologyError, match="describe\\(\\) takes one arm, got a batch of shape \\(2,\\)"):
        describe(from_dh(np.full((2, 6), 0.1), np.zeros((2, 6)), np.zeros((2, 6)), name="two"))
    with pytest.raises(MorphologyError, match="must be a SerialChain or a DHRobot"):
        describe("panda")
