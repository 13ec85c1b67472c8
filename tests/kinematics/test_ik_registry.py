"""The closed-form registry (wsmap.kinematics.ik.registry): which closed form solves which arm, a closed
form registered from outside is found by the library, the shared branch numbering, the answer type's
fields and reasons, and the closed forms against the numerical search."""

import numpy as np
import pytest

from wsmap import robots
from wsmap import workspace as ws
from wsmap.kinematics import (
    ClosedForm,
    DHRobot,
    IKReason,
    IKSolution,
    as_chain,
    closed_form_for,
    closed_forms,
    ikine_search,
    ikine_spherical_wrist,
    ikine_ur,
    register,
    require_closed_form,
    transl,
)
from wsmap.kinematics.ik import registry
from wsmap.kinematics.ik.registry import ELBOW, SHOULDER, WRIST

PI = np.pi


def test_the_closed_forms_are_asked_by_priority():
    assert [cf.name for cf in closed_forms()] == ["spherical_wrist", "spherical_wrist_offset", "ur"]


def test_closed_form_for_named_arms():
    assert closed_form_for(robots.puma560()).name == "spherical_wrist"
    assert closed_form_for(robots.puma560(joint_limits=True)).name == "spherical_wrist"
    assert closed_form_for(robots.sample_spherical_wrist(5, seed=0)).name == "spherical_wrist"
    assert closed_form_for(robots.load("ur5e")).name == "ur"
    assert closed_form_for(robots.load("panda")) is None
    assert closed_form_for(robots.sample_arbitrary_6dof(3, seed=0)) is None
    # the spherical-wrist DH family is given by DH numbers: the same arm as a chain is recognised by
    # its geometry, by the closed form with a shoulder offset
    assert closed_form_for(as_chain(robots.puma560())).name == "spherical_wrist_offset"
    assert closed_form_for("puma560") is None
    # a batch is recognised only when every arm is
    mixed = robots.sample_spherical_wrist(3, seed=1)
    d = np.array(mixed.d)
    d[1, 1] = 0.2  # d2 != 0: outside the DH family, a lateral offset of the geometric one
    assert closed_form_for(DHRobot(d, mixed.a, mixed.alpha)).name == "spherical_wrist_offset"
    alpha = np.array(mixed.alpha)
    alpha[1, 1] = 0.3  # axes 2 and 3 not parallel: outside every family
    assert closed_form_for(DHRobot(mixed.d, mixed.a, alpha)) is None


def test_require_closed_form_names_the_closed_forms():
    with pytest.raises(ValueError, match=r"method 'exact' has no closed form for panda \(closed forms: the "
                                         r"spherical-wrist DH family, the spherical-wrist family with a shoulder offset and the UR "
                                         r"family\); use method 'numerical'"):
        require_closed_form(robots.load("panda"))
    assert require_closed_form(robots.load("ur5e")).name == "ur"


def _planar_closed_form():
    """A closed form for a toy family, registered from outside the package: 2R arms in the plane
    (no robot of wsmap is one), exact by the law of cosines."""

    def recognise(robot):
        ok = isinstance(robot, DHRobot) and robot.n == 2 and robot.tool is None
        if not ok:
            return np.zeros(getattr(robot, "batch_shape", ()), dtype=bool)
        return np.all(robot.alpha == 0.0, axis=-1) & np.all(robot.d == 0.0, axis=-1)

    def require(robot):
        if not np.all(recognise(robot)):
            raise ValueError("not a planar 2R arm")

    def reachable(robot, T):
        T = np.asarray(T)
        r = np.hypot(T[..., 0, 3], T[..., 1, 3])
        a1, a2 = robot.a[..., 0], robot.a[..., 1]
        return (r <= a1 + a2 + 1e-12) & (r >= abs(a1 - a2) - 1e-12) & (np.abs(T[..., 2, 3]) < 1e-12)

    def solve(robot, T):
        ok = reachable(robot, T)[..., None] & np.ones(2, dtype=bool)
        shape = ok.shape
        return IKSolution(np.zeros(shape + (2,)), ok, np.zeros(shape, dtype=np.int64), np.full(shape, np.nan),
                          np.where(ok, IKReason.SOLVED, IKReason.OUT_OF_REACH).astype(np.int8))

    return ClosedForm(name="planar_2r", description="planar 2R arms", recognise=recognise, require=require,
                      solve=solve, reachable=reachable, priority=100)


def test_a_closed_form_registered_from_outside_is_used_by_the_maps():
    arm = DHRobot(d=[0.0, 0.0], a=[0.5, 0.3], alpha=[0.0, 0.0], name="planar")
    nodes = ws.cartesian_grid(-1, 1, 0.1)
    assert closed_form_for(arm) is None
    assert ws.resolve_method(arm, "auto") == "numerical"
    cf = register(_planar_closed_form())
    try:
        assert closed_form_for(arm) is cf
        assert closed_form_for(robots.puma560()).name == "spherical_wrist"
        assert ws.resolve_method(arm, "auto") == "exact"
        m, used = ws.constant_orientation_map(arm, nodes, return_method=True)
        assert used == "exact"
        np.testing.assert_array_equal(m, cf.reachable(arm, ws.target_poses(nodes, (0, 0, 0))))
        assert 0 < m.sum() < len(nodes)
        with pytest.raises(ValueError, match="'planar_2r' is already registered"):
            register(_planar_closed_form())
        with pytest.raises(ValueError, match="closed forms: the spherical-wrist DH family, the spherical-wrist "
                                             "family with a shoulder offset, the UR family and planar 2R arms"):
            require_closed_form(robots.load("panda"))
    finally:
        registry.unregister("planar_2r")
    assert closed_form_for(arm) is None
    with pytest.raises(TypeError, match="register takes a ClosedForm, got dict"):
        register({"name": "x"})


# --------------------------------------------------------------------------- branch numbering
def _bits(k):
    return bool(k & SHOULDER), bool(k & WRIST), bool(k & ELBOW)


def _check_branch_bits(q, valid, q1_branch0, elbow_angle):
    """Branch k's joint angles have the configuration of its bits: shoulder (q1 equals the shoulder-0
    solution or not), wrist (sign of sin q5) and elbow (sign of sin of the elbow angle)."""
    checked = 0
    for k in range(8):
        shoulder, wrist, elbow = _bits(k)
        v = valid[:, k]
        qk = q[v, k]
        s1 = np.abs(np.mod(qk[:, 0] - q1_branch0[v] + PI, 2 * PI) - PI) < 1e-9
        assert np.all(s1 != shoulder), k
        s5 = np.sin(qk[:, 4])
        assert np.all(s5 <= 1e-9 if wrist else s5 >= -1e-9), k
        se = np.sin(elbow_angle(qk))
        assert np.all(se <= 1e-9 if elbow else se >= -1e-9), k
        checked += v.sum()
    return checked


def test_both_closed_forms_number_their_branches_alike():
    rng = np.random.default_rng(0)
    # the spherical-wrist family: the shoulder solution 0 is q1 = φ + asin(d3/r) of the wrist centre,
    # the elbow angle q3 + atan2(d4, a3)
    puma = robots.puma560()
    T = puma.fkine(rng.uniform(-PI, PI, (300, 6)))
    sol = ikine_spherical_wrist(puma, T)
    p = T[:, :3, 3]  # the wrist centre (the flange origin of the family)
    d3, d4, a3 = puma.d[2], puma.d[3], puma.a[2]
    q1 = np.arctan2(p[:, 1], p[:, 0]) + np.arcsin(d3 / np.hypot(p[:, 0], p[:, 1]))
    n = _check_branch_bits(sol.q, sol.success, q1, lambda q: q[:, 2] + np.arctan2(d4, a3))
    assert n > 2000
    # the UR family: q1 = φ + asin(d4/r) of the wrist point p − d6·z, the elbow angle θ3
    ur = robots.load("ur5e")
    T = ur.fkine(ur.random_q(300, rng))
    sol = ikine_ur(ur, T)
    d4, d6 = 0.1333, 0.0996
    w = T[:, :3, 3] - d6 * T[:, :3, 2]
    q1 = np.arctan2(w[:, 1], w[:, 0]) + np.arcsin(d4 / np.hypot(w[:, 0], w[:, 1]))
    n = _check_branch_bits(sol.q, sol.success, q1, lambda q: q[:, 2])
    assert n > 2000


# --------------------------------------------------------------------------- the answer type
def test_closed_form_answers_say_why_a_branch_fails():
    limited = robots.puma560(joint_limits=True)
    q = np.deg2rad([10, 20, -30, 0, 150, 0])  # |q5| = 150 deg on every branch: outside the limits
    T = np.stack([limited.fkine(np.deg2rad([10, 20, -30, 0, 40, 0])), limited.fkine(q), transl([2.0, 0, 0])])
    sol = ikine_spherical_wrist(limited, T)
    assert sol.q.shape == (3, 8, 6)
    for f in ("success", "iterations", "residual", "reason"):
        assert getattr(sol, f).shape == (3, 8), f
    assert sol.reason.dtype == np.int8 and sol.iterations.dtype == np.int64 and sol.start is None
    assert (sol.iterations == 0).all() and np.isnan(sol.residual).all()
    np.testing.assert_array_equal(sol.reason == IKReason.SOLVED, sol.success)
    assert sol.success[0].any() and (sol.reason[0][~sol.success[0]] == IKReason.OUTSIDE_LIMITS).all()
    assert (sol.reason[1] == IKReason.OUTSIDE_LIMITS).all()
    assert (sol.reason[2] == IKReason.OUT_OF_REACH).all()
    # the UR family: the same reasons
    ur = robots.load("ur5e").replace(qlim=np.tile([-1.0, 1.0], (6, 1)))
    T = np.stack([ur.fkine(np.full(6, 0.5)), ur.fkine(np.array([0.5, 0.5, 0.5, 0.5, 2.5, 0.5])), transl([2.0, 0, 0])])
    sol = ikine_ur(ur, T)
    np.testing.assert_array_equal(sol.reason == IKReason.SOLVED, sol.success)
    assert sol.success[0].any()
    assert (sol.reason[1] == IKReason.OUTSIDE_LIMITS).any() and not sol.success[1].any()
    assert (sol.reason[2] == IKReason.OUT_OF_REACH).all()


def test_search_answers_say_why_a_target_fails():
    puma = robots.puma560(joint_limits=True)
    T = np.stack([puma.fkine(np.deg2rad([10, 20, -30, 0, 40, 0])), transl([3.0, 0, 0])])
    res = ikine_search(puma, T, starts=4)
    np.testing.assert_array_equal(res.success, [True, False])
    np.testing.assert_array_equal(res.reason, [IKReason.SOLVED, IKReason.OUT_OF_REACH])
    assert res.iterations[1] == 0 and np.isinf(res.residual[1]) and res.start[1] == -1
    # a pose inside the reach bound that only a configuration outside the limits reaches: no start
    # converges inside them
    q = np.deg2rad([10, 20, -30, 0, 150, 0])
    res = ikine_search(puma, puma.fkine(q), starts=4)
    assert not res.success and res.reason == IKReason.NO_CONVERGENCE and res.iterations > 0


# --------------------------------------------------------------------------- closed forms against the search
@pytest.mark.parametrize("name, limits", [("puma560", False), ("puma560", True), ("ur5e", None)])
def test_closed_forms_agree_with_the_search_on_reachability(name, limits):
    arm = robots.load(name, joint_limits=limits)
    cf = closed_form_for(arm)
    nodes = ws.cartesian_grid(-1, 1, 0.25)
    T = ws.target_poses(nodes, (PI, 0, 0), "standard")
    exact = cf.reachable(arm, T)
    np.testing.assert_array_equal(exact, cf.solve(arm, T).success.any(axis=-1))
    found = ikine_search(arm, T).success
    assert 0.1 < exact.mean() < 0.9
    assert not np.any(found & ~exact)  # the search's True is never wrong
    assert found.sum() >= exact.sum() - 1  # and it misses at most a node here
