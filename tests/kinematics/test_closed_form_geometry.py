"""Closed forms recognised from any description of the arm (wsmap.kinematics.ik.geometry and the
closed forms that use it): ROS UR URDFs through the UR closed form, the KUKA KR series and PUMA's
URDF through the spherical-wrist closed form with a shoulder offset. Each from a URDF shipped with
rtbdata (xacro sources expanded in-process with the xacro package): the family recognised, every
solution a round trip through the chain's forward kinematics, the same solutions as EAIK (an
independent analytic solver, built here from the joint axes) on random poses, the closed-form map
equal to the numerical map, and the map summary naming the closed form."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

from wsmap import cli, robots
from wsmap import workspace as ws
from wsmap.kinematics import closed_form_for, from_dh
from wsmap.kinematics.ik.closed_forms.spherical_wrist_offset import (
    ikine_spherical_wrist_offset,
    is_spherical_wrist_offset,
    require_spherical_wrist_offset,
)
from wsmap.kinematics.ik.closed_forms.ur import ikine_ur, is_ur_type
from wsmap.kinematics.ik.geometry import dh_equivalent, joint_lines
from wsmap.kinematics.urdf import from_urdf

rtbdata = pytest.importorskip("rtbdata")
XACRO = os.path.join(os.path.dirname(rtbdata.__file__), "xacro")

UR10 = ("ur_description/urdf/ur10_robot.urdf.xacro", "base_link", "tool0")
UR3 = ("ur_description/urdf/ur3_robot.urdf.xacro", "base_link", "tool0")
UR5 = ("ur_description/urdf/ur5_joint_limited_robot.urdf.xacro", "base_link", "tool0")
KR16 = ("kuka_description/kuka_kr16/urdf/kr16_2.urdf", "base_link", "tool0")
KR210 = ("kuka_description/kuka_kr210/urdf/kr210l150.urdf", "base_link", "tool0")
IRB140 = ("abb_irb140/urdf/irb140.xacro", "base_link", "tool0")
PUMA = ("puma560_description/urdf/puma560_robot.urdf", None, None)
PANDA = ("franka_description/robots/panda_arm.urdf.xacro", None, None)
TWO_PI = 2 * np.pi


def urdf_text(rel: str) -> str:
    path = os.path.join(XACRO, rel)
    if not path.endswith(".xacro"):
        with open(path) as f:
            return f.read()
    xacro = pytest.importorskip("xacro")
    import xacro.substitution_args as sa

    # $(find pkg): rtbdata's folders, no ROS
    sa._eval_find = lambda pkg: os.path.join(XACRO, {"abb_irb140_support": "abb_irb140"}.get(pkg, pkg))
    return xacro.process_file(path).toxml()


def load(spec):
    rel, base, ee = spec
    return from_urdf(urdf_text(rel), base_link=base, ee_link=ee)


def eaik_solutions(chain, T):
    """EAIK's exact (non least-squares) solutions per pose, from the chain's joint axes at q = 0."""
    hp = pytest.importorskip("eaik.IK_HP")
    w, p, M = joint_lines(chain)
    bot = hp.HPRobot(w, np.vstack([p[0], np.diff(p, axis=0), M[:3, 3] - p[5]]))
    out = []
    for Tk in T:
        Te = Tk.copy()
        Te[:3, :3] = Tk[:3, :3] @ M[:3, :3].T  # EAIK's tool frame is the base's at q = 0
        sol = bot.IK(Te)
        out.append(np.asarray(sol.Q).reshape(-1, 6)[~np.asarray(sol.is_LS, dtype=bool).reshape(-1)])
    return out


def gap(Q, q):
    """Smallest largest-joint difference modulo 2·pi between q (6,) and the rows of Q (k, 6)."""
    if not len(Q):
        return np.inf
    return float(np.abs(np.mod(Q - q + np.pi, TWO_PI) - np.pi).max(axis=-1).min())


def same_solutions(mine_q, mine_ok, theirs, tol=1e-8):
    """Every EAIK solution is one of the valid branches and the counts agree (distinct solutions)."""
    for k, Q in enumerate(theirs):
        M = mine_q[k][mine_ok[k]]
        assert all(gap(M, qe) < tol for qe in Q), f"pose {k}: an EAIK solution is not among the closed form's"
        assert all(gap(Q, qm) < tol for qm in M), f"pose {k}: a closed-form branch is not among EAIK's"


def grid(chain, n=9):
    frames, tool = chain.joint_frames(np.zeros(chain.n))
    pts = np.concatenate([frames[:, :3, 3], tool[None, :3, 3]])
    R = float(np.linalg.norm(np.diff(pts, axis=0), axis=-1).sum())
    return ws.cartesian_grid(pts[0] - R, pts[0] + R, 2 * R / (n - 1) * 1.0001)


# ------------------------------------------------------------------------------------------ geometry
@pytest.mark.parametrize("spec", [UR10, KR16, PUMA, PANDA])
def test_dh_equivalent_has_the_same_kinematics(spec):
    chain = load(spec)
    eq, ok = dh_equivalent(chain)
    assert ok
    q = np.random.default_rng(0).uniform(-np.pi, np.pi, (100, chain.n))
    np.testing.assert_allclose(eq.fkine(q), chain.fkine(q), atol=1e-12)
    assert np.all(eq.axes[:, :2] == 0)
    L = eq.fixed[1:-1]  # Tz(d)·Tx(a)·Rx(alpha): x kept, no sideways translation
    np.testing.assert_allclose(L[:, :3, 0], np.tile([1.0, 0, 0], (chain.n - 1, 1)), atol=1e-12)
    np.testing.assert_allclose(L[:, 1, 3], 0.0, atol=1e-12)
    assert eq.qlim is chain.qlim


def test_dh_equivalent_of_a_batch_and_prismatic_refusal():
    lengths = np.array([[0.1625, -0.425, -0.3922, 0.1333, 0.0997, 0.0996], [0.15185, -0.24355, -0.2132, 0.13105,
                                                                          0.08535, 0.0921]])
    z = np.zeros(2)
    d = np.stack([lengths[:, 0], z, z, lengths[:, 3], lengths[:, 4], lengths[:, 5]], axis=-1)
    a = np.stack([z, lengths[:, 1], lengths[:, 2], z, z, z], axis=-1)
    arms = from_dh(d, a, np.tile([np.pi / 2, 0, 0, np.pi / 2, -np.pi / 2, 0], (2, 1)))
    eq, ok = dh_equivalent(arms)
    assert ok.shape == (2,) and ok.all()
    q = np.random.default_rng(1).uniform(-np.pi, np.pi, (20, 2, 6))
    np.testing.assert_allclose(eq.fkine(q), arms.fkine(q), atol=1e-12)
    gantry = from_dh([0, 0, 0], [0.1, 0.1, 0], [0, 0, 0], prismatic=[False, False, True],
                     qlim=[[-3, 3], [-3, 3], [0, 0.5]])
    assert dh_equivalent(gantry)[0] is None


# ------------------------------------------------------------------------------------------ UR URDFs
@pytest.mark.parametrize("spec", [UR10, UR3, UR5])
def test_ros_ur_urdfs_go_through_the_ur_closed_form(spec):
    chain = load(spec)
    assert is_ur_type(chain) and closed_form_for(chain).name == "ur"
    assert ws.resolve_method(chain) == "exact"
    rng = np.random.default_rng(2)
    q = rng.uniform(-np.pi, np.pi, (60, 6))
    T = chain.fkine(q)
    sol = ikine_ur(chain, T)
    err = np.abs(chain.fkine(np.moveaxis(sol.q, -2, 0)) - T).max(axis=(-1, -2)).T
    assert err[sol.success].max() < 1e-9
    assert all(gap(sol.q[k][sol.success[k]], q[k]) < 1e-7 for k in range(len(q)))
    same_solutions(sol.q, sol.success, eaik_solutions(chain, T))


def test_ur_urdf_closed_form_map_equals_the_numerical_map():
    chain = load(UR10)
    nodes = grid(chain)
    for rpy in ((0.0, 0.0, 0.0), (math.pi, 0.0, 0.0)):
        exact, method = ws.constant_orientation_map(chain, nodes, rpy, convention="standard", return_method=True)
        assert method == "exact"
        numerical = ws.constant_orientation_map(chain, nodes, rpy, method="numerical", convention="standard")
        np.testing.assert_array_equal(exact, numerical)
        assert 0 < exact.sum() < exact.size


# ------------------------------------------------------------------------- spherical wrist, offset
@pytest.mark.parametrize("spec", [KR16, KR210, IRB140, PUMA])
def test_offset_spherical_wrist_urdfs_agree_with_eaik(spec):
    chain = load(spec)
    assert is_spherical_wrist_offset(chain) and closed_form_for(chain).name == "spherical_wrist_offset"
    free = chain.replace(qlim=None)  # every branch, to compare the whole solution sets
    rng = np.random.default_rng(3)
    q = rng.uniform(-np.pi, np.pi, (80, 6))
    T = free.fkine(q)
    sol = ikine_spherical_wrist_offset(free, T)
    assert sol.q.shape == (80, 8, 6) and np.all(np.abs(sol.q) <= np.pi + 1e-12)
    assert sol.success.any(axis=-1).all()
    assert sol.residual[sol.success].max() <= 1e-9
    assert all(gap(sol.q[k][sol.success[k]], q[k]) < 1e-6 for k in range(len(q)))
    same_solutions(sol.q, sol.success, eaik_solutions(free, T))


def test_offset_spherical_wrist_honours_the_limits_and_broadcasts():
    chain = load(KR16)
    rng = np.random.default_rng(4)
    q = chain.random_q(40, rng)
    T = chain.fkine(q)
    sol = ikine_spherical_wrist_offset(chain, T)
    assert sol.success.any(axis=-1).all()
    inside = chain.within_limits(sol.q, atol=1e-9) | ~sol.success  # q in (-pi, pi]: KUKA's limits are < pi
    assert inside.all()
    free = ikine_spherical_wrist_offset(chain.replace(qlim=None), T)
    np.testing.assert_array_equal(sol.success, free.success & (sol.reason == 0))
    assert np.all(sol.success <= free.success)
    # two arms (a batch) times poses, as one at a time
    arms = chain.replace(fixed=np.stack([chain.fixed, chain.fixed]), offset=np.stack([chain.offset, chain.offset + 0.1]),
                         qlim=None)
    both = ikine_spherical_wrist_offset(arms, T[:, None])
    assert both.q.shape == (40, 2, 8, 6)
    one = ikine_spherical_wrist_offset(arms[1], T)
    np.testing.assert_array_equal(both.success[:, 1], one.success)
    np.testing.assert_allclose(both.q[:, 1][one.success], one.q[one.success], atol=1e-12)


def test_offset_spherical_wrist_map_equals_the_numerical_map():
    chain = load(KR16)
    nodes = grid(chain)
    for rpy in ((0.0, 0.0, 0.0), (math.pi, 0.0, 0.0)):
        exact, method = ws.constant_orientation_map(chain, nodes, rpy, convention="standard", return_method=True)
        assert method == "exact"
        numerical = ws.constant_orientation_map(chain, nodes, rpy, method="numerical", convention="standard")
        np.testing.assert_array_equal(exact, numerical)
        assert 0 < exact.sum() < exact.size


def test_cli_summary_names_the_closed_form(tmp_path, capsys):
    for spec, family in ((KR16, "spherical-wrist-offset"), (UR10, "ur")):
        urdf = tmp_path / "arm.urdf"
        urdf.write_text(urdf_text(spec[0]))
        out = tmp_path / "m.npz"
        assert cli.main(["map", "--urdf", str(urdf), "--ee", "tool0", "--step", "0.5", "--out", str(out)]) == 0
        assert f"exact constant map (closed form ({family} family), joint limits on)" in capsys.readouterr().out


def test_refusals_and_the_paper_family_keeps_its_closed_form():
    assert closed_form_for(robots.puma560()).name == "spherical_wrist"  # the DH family: its own, first
    assert not is_spherical_wrist_offset(load(UR10))
    with pytest.raises(ValueError, match=r"axis 6 misses the point where axes 4 and 5 meet by 0\.116 m"):
        require_spherical_wrist_offset(load(UR10))
    with pytest.raises(ValueError, match="it has 7 joints, the family has 6"):
        require_spherical_wrist_offset(robots.load("panda"))
    assert not np.any(is_spherical_wrist_offset(np.eye(4)))
