"""The reachability search (wsmap.kinematics.ik.search): known answers against exact references,
joint limits inside the search, confirmation by forward kinematics, determinism."""

import math

import numpy as np
import pytest

from wsmap import robots
from wsmap import workspace as ws
from wsmap.kinematics import (DHRobot, SerialChain, as_chain, from_dh, ikine_LM, ikine_search, ikine_spherical_wrist,
                              rotx, rotz)
from wsmap.kinematics.ik.lm_reference import _project
from wsmap.kinematics.ik.reach_filter import reach_filter
from wsmap.kinematics.ik.search import DEFAULT_STARTS, FK_CONFIRM_TOL

PI = math.pi
TOOL_DOWN = (PI, 0.0, 0.0)  # R = Rx(pi)


def ur5e():
    return from_dh(d=[0.1625, 0, 0, 0.1333, 0.0997, 0.0996], a=[0, -0.425, -0.3922, 0, 0, 0],
                   alpha=[PI / 2, 0, 0, PI / 2, -PI / 2, 0], qlim=np.tile([-2 * PI, 2 * PI], (6, 1)), name="ur5e")


@pytest.fixture(scope="module")
def coarse():
    return ws.cartesian_grid(-1, 1, 0.2)  # 1331 nodes


def _compare(num, exact, nodes, label):
    """Zero false positives and recall >= 0.999, listing any mismatch."""
    fp = np.flatnonzero(num & ~exact)
    fn = np.flatnonzero(exact & ~num)
    assert fp.size == 0, f"{label}: false positives at {nodes[fp].round(3).tolist()}"
    recall = 1.0 - fn.size / max(int(exact.sum()), 1)
    assert recall >= 0.999, f"{label}: recall {recall:.4f}, missed {nodes[fn].round(3).tolist()}"


def _check_solutions(chain, res, T):
    """Every success: inside the limits and fkine(q) = T (position and rotation to the confirmation tolerance)."""
    ok = res.success
    q = res.q[ok]
    assert np.all(chain.within_limits(q))
    Tq = chain.fkine(q)
    assert np.abs(Tq[:, :3, 3] - T[ok][:, :3, 3]).max(initial=0) <= FK_CONFIRM_TOL
    assert np.abs(Tq[:, :3, :3] - T[ok][:, :3, :3]).max(initial=0) <= 2 * FK_CONFIRM_TOL
    assert np.all(res.start[ok] >= 0) and np.all(res.start[~ok] == -1)


# --------------------------------------------------------------------------- known answers
@pytest.mark.parametrize("rpy", [(0.0, 0.0, 0.0), TOOL_DOWN], ids=["R=I", "tool-down"])
def test_puma560_without_limits_equals_exact_map(coarse, rpy):
    puma = robots.puma560()
    exact = ws.constant_orientation_map(puma, coarse, rpy, method="exact", convention="standard")
    num = ws.constant_orientation_map(puma, coarse, rpy, method="numerical", convention="standard")
    assert 0.2 < exact.mean() < 0.5
    _compare(num, exact, coarse, f"PUMA560 {rpy}")


@pytest.mark.parametrize("rpy", [(0.0, 0.0, 0.0), TOOL_DOWN], ids=["R=I", "tool-down"])
def test_puma560_with_limits_equals_closed_form(coarse, rpy):
    puma = robots.puma560(joint_limits=True)
    T = ws.target_poses(coarse, rpy, "standard")
    exact = ikine_spherical_wrist(puma, T).success.any(axis=-1)
    assert exact.sum() < ws.constant_orientation_map(robots.puma560(), coarse, rpy, convention="standard").sum()
    res = ikine_search(puma, T)
    _compare(res.success, exact, coarse, f"PUMA560 + limits {rpy}")
    _check_solutions(as_chain(puma), res, T)


@pytest.mark.parametrize("rpy", [(0.0, 0.0, 0.0), TOOL_DOWN], ids=["R=I", "tool-down"])
def test_ur5e_against_eaik(coarse, rpy):
    eaik = pytest.importorskip("eaik.IK_DH")
    arm = ur5e()
    T = ws.target_poses(coarse, rpy, "standard")
    bot = eaik.DhRobot(np.array([PI / 2, 0, 0, PI / 2, -PI / 2, 0]), np.array([0, -0.425, -0.3922, 0, 0, 0]),
                       np.array([0.1625, 0, 0, 0.1333, 0.0997, 0.0996]))
    exact = np.zeros(len(T), dtype=bool)
    for i, sol in enumerate(bot.IK_batched(list(T), num_worker_threads=1)):
        Q = np.asarray(sol.Q).reshape(-1, 6)[~np.asarray(sol.is_LS, dtype=bool).reshape(-1)]
        # an exact EAIK solution; limits of ±2pi admit every angle
        exact[i] = bool(len(Q)) and bool(np.any(np.abs(arm.fkine(Q) - T[i]).max(axis=(-2, -1)) <= 1e-6))
    assert 0.2 < exact.mean() < 0.6
    res = ikine_search(arm, T)
    _compare(res.success, exact, coarse, f"UR5e {rpy}")
    _check_solutions(arm, res, T)
    # the map takes the chain too
    np.testing.assert_array_equal(ws.constant_orientation_map(arm, coarse, rpy, method="numerical",
                                                              convention="standard"), res.success)


def test_planar_2r_reaches_exactly_its_annulus():
    l1, l2 = 0.7, 0.4
    arm = from_dh(d=[0, 0], a=[l1, l2], alpha=[0, 0])
    rng = np.random.default_rng(1)
    # reachable: poses of random configurations (a 2R pose fixes both joints)
    T_in = arm.fkine(rng.uniform(-PI, PI, (300, 2)))
    # unreachable: positions outside the annulus |l1 - l2| <= r <= l1 + l2 (any orientation in the plane)
    r = np.concatenate([rng.uniform(0.0, l1 - l2 - 1e-3, 150), rng.uniform(l1 + l2 + 1e-3, 2.0, 150)])
    phi, yaw = rng.uniform(-PI, PI, 300), rng.uniform(-PI, PI, 300)
    T_out = np.zeros((300, 4, 4))
    T_out[:, :3, :3] = rotz(yaw)
    T_out[:, 0, 3], T_out[:, 1, 3], T_out[:, 3, 3] = r * np.cos(phi), r * np.sin(phi), 1.0
    res = ikine_search(arm, np.concatenate([T_in, T_out]))
    assert res.success[:300].all() and not res.success[300:].any()
    _check_solutions(arm, res, np.concatenate([T_in, T_out]))


def test_planar_3r_wrist_point_annulus():
    # poses (x, y, phi) of a planar 3R arm: reachable iff the wrist point (x, y) - l3 (cos phi, sin phi)
    # lies in the annulus |l1 - l2| <= r <= l1 + l2
    l1, l2, l3 = 0.5, 0.3, 0.1
    arm = from_dh(d=[0, 0, 0], a=[l1, l2, l3], alpha=[0, 0, 0])
    xs = np.linspace(-1.0, 1.0, 13)
    phis = np.linspace(-PI, PI, 8, endpoint=False) + 0.1
    X, Y, P = (a.ravel() for a in np.meshgrid(xs, xs, phis, indexing="ij"))
    T = np.zeros((X.size, 4, 4))
    T[:, 0, 0], T[:, 0, 1], T[:, 1, 0], T[:, 1, 1] = np.cos(P), -np.sin(P), np.sin(P), np.cos(P)
    T[:, 2, 2] = T[:, 3, 3] = 1.0
    T[:, 0, 3], T[:, 1, 3] = X, Y
    rw = np.hypot(X - l3 * np.cos(P), Y - l3 * np.sin(P))
    exact = (rw >= abs(l1 - l2)) & (rw <= l1 + l2)
    margin = (np.abs(rw - abs(l1 - l2)) > 1e-9) & (np.abs(rw - (l1 + l2)) > 1e-9)
    assert margin.all()  # no node exactly on a boundary circle
    res = ikine_search(arm, T)
    _compare(res.success, exact, np.stack([X, Y, P], -1), "planar 3R")


def test_prismatic_gantry_reaches_its_stroke_box():
    # three prismatic axes x, y, z with strokes: a pose with R = I is reachable iff p lies in the box
    strokes = np.array([[-0.2, 0.5], [0.0, 0.3], [-0.1, 0.1]])
    fixed = np.broadcast_to(np.eye(4), (4, 4, 4))
    arm = SerialChain(fixed, np.eye(3), "PPP", qlim=strokes)
    rng = np.random.default_rng(2)
    p = rng.uniform(-0.6, 0.6, (400, 3))
    T = np.broadcast_to(np.eye(4), (400, 4, 4)).copy()
    T[:, :3, 3] = p
    exact = np.all((p >= strokes[:, 0]) & (p <= strokes[:, 1]), axis=-1)
    res = ikine_search(arm, T, starts=4)
    np.testing.assert_array_equal(res.success, exact)
    _check_solutions(arm, res, T)
    # a tilted tool is never reachable by a gantry
    tilted = np.eye(4)
    tilted[:3, :3], tilted[:3, 3] = rotx(0.3), (0.1, 0.1, 0.0)
    assert not ikine_search(arm, tilted).success


# --------------------------------------------------------------------------- limits inside the search
def test_a_pose_reachable_only_outside_the_limits_is_unreachable():
    one = from_dh(d=[0], a=[1.0], alpha=[0], qlim=[[-0.5, 0.5]])
    T = one.fkine(np.array([[0.3], [2.0], [-0.5], [0.5]]))
    res = ikine_search(one, T)
    np.testing.assert_array_equal(res.success, [True, False, True, True])
    free = ikine_search(one, T, joint_limits=False)
    assert free.success.all()
    # 2R: a full planar pose fixes both joints; q2 = -1 is outside [0, 0.2]
    two = from_dh(d=[0, 0], a=[0.5, 0.4], alpha=[0, 0], qlim=[[-PI, PI], [0.0, 0.2]])
    T = two.fkine(np.array([[0.5, -1.0], [0.5, 0.1], [-2.0, 0.2]]))
    np.testing.assert_array_equal(ikine_search(two, T).success, [False, True, True])
    # the paper's LM converges to q2 = -1 and only afterwards finds it outside the limits; the search
    # starts from zeros projected into the limits and stays inside


def test_limits_beyond_pi_are_reached_through_the_equivalent_angle():
    # q1 in [2.5, 3.5] rad: the pose of q1 = -3.0 (= 3.283 rad) is reachable, that of q1 = 0 is not
    one = from_dh(d=[0], a=[1.0], alpha=[0], qlim=[[2.5, 3.5]])
    res = ikine_search(one, one.fkine(np.array([[-3.0], [0.0]])))
    np.testing.assert_array_equal(res.success, [True, False])
    assert 2.5 <= res.q[0, 0] <= 3.5
    np.testing.assert_allclose(res.q[0, 0], 2 * PI - 3.0, atol=1e-9)


def test_puma560_with_limits_finds_the_branch_inside_the_limits():
    # poses of random configurations inside the limits: reachable, even where LM from zeros
    # converges to another branch outside them
    puma = robots.puma560(joint_limits=True)
    rng = np.random.default_rng(3)
    lo, hi = puma.qlim[:, 0], puma.qlim[:, 1]
    q = lo + rng.random((300, 6)) * (hi - lo)
    T = puma.fkine(q)
    res = ikine_search(puma, T)
    assert res.success.mean() >= 0.999, np.flatnonzero(~res.success)
    _check_solutions(as_chain(puma), res, T)
    paper = ikine_LM(puma, T, check_limits=True).success
    assert paper.mean() < res.success.mean()


def test_projection_onto_the_limits():
    lo, hi = np.array([-1.0, 2.5, -0.5, -np.inf]), np.array([1.0, 3.5, 0.5, np.inf])
    rev = np.array([True, True, False, True])
    q = np.array([[0.5, 3.0, 0.2, 7.0],  # inside: unchanged (an unlimited joint is not wrapped here)
                  [1.2, -3.0, 0.9, -7.0],
                  [-2.9, 0.0, -0.9, 0.0],
                  [PI, 1.0, 0.0, 0.0]])
    out = _project(q, lo, hi, rev)
    np.testing.assert_array_equal(out[0], q[0])
    # 1.2 is 0.2 above hi: clipped; -3 + 2pi = 3.28 lies inside [2.5, 3.5]; the prismatic joint is clipped
    np.testing.assert_allclose(out[1], [1.0, -3.0 + 2 * PI, 0.5, -7.0])
    # -2.9 is 1.9 below lo = -1 and 2pi - 3.9 = 2.38 above hi (going round): lo. 0 is 2.5 below
    # lo = 2.5 and 2.78 above hi - 2pi: lo
    np.testing.assert_allclose(out[2], [-1.0, 2.5, -0.5, 0.0])
    # 1.0 is 1.5 below lo = 2.5 and 3.78 above hi - 2pi: lo
    np.testing.assert_allclose(out[3, 1:], [2.5, 0.0, 0.0])


# --------------------------------------------------------------------------- determinism
def test_same_seed_same_result_and_chunking_does_not_matter(coarse):
    puma = robots.puma560(joint_limits=True)
    T = ws.target_poses(coarse[::9], TOOL_DOWN, "standard")
    a = ikine_search(puma, T, starts=8, seed=5)
    # chunk 1: one target and one start at a time; chunk 40: blocks of starts over a few targets
    for chunk, part in ((1, slice(40, 70)), (40, slice(None))):
        b = ikine_search(puma, T[part], starts=8, seed=5, chunk=chunk)
        for f in ("q", "success", "iterations", "residual", "start"):
            np.testing.assert_array_equal(getattr(a, f)[part], getattr(b, f), err_msg=f"{f}, chunk {chunk}")
    # a pose gets the same starts wherever it sits: a subset, reversed, gives the same answers
    idx = np.flatnonzero(a.start > 0)[::-1]
    c = ikine_search(puma, T[idx], starts=8, seed=5)
    np.testing.assert_array_equal(c.q, a.q[idx])
    np.testing.assert_array_equal(c.start, a.start[idx])
    # early exit: fewer starts are a prefix of more
    d = ikine_search(puma, T, starts=3, seed=5)
    np.testing.assert_array_equal(d.success, (a.start >= 0) & (a.start < 3))
    # another seed: other random starts, still no false positive
    e = ikine_search(puma, T, starts=8, seed=6)
    assert not np.array_equal(e.start, a.start)


def test_dh_robot_and_its_chain_give_identical_results(coarse):
    puma = robots.puma560()
    T = ws.target_poses(coarse[::5], (0.3, 0.2, 0.1), "standard")
    a, b = ikine_search(puma, T, starts=4), ikine_search(as_chain(puma), T, starts=4)
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.success, b.success)


def test_batch_of_arms_equals_one_arm_at_a_time(coarse):
    arms = robots.sample_spherical_wrist(3, seed=4)
    T = ws.target_poses(coarse[::9], (0.0, 0.0, 0.0), "standard")
    batch = ikine_search(arms, T[:, None], starts=4)
    assert batch.success.shape == (len(T), 3) and batch.q.shape == (len(T), 3, 6)
    for i in range(3):
        one = ikine_search(arms[i], T, starts=4)
        np.testing.assert_array_equal(batch.success[:, i], one.success)
        np.testing.assert_array_equal(batch.q[:, i], one.q)


def test_default_starts_is_the_measured_one():
    assert DEFAULT_STARTS == 32


# --------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("bad, why", [
    (np.diag([2.0, 1.0, 1.0, 1.0]), "orthonormal"),
    (np.diag([1.0, 1.0, -1.0, 1.0]), "reflection"),
    (np.array([[1.0, 0.5, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]), "orthonormal"),
    (np.array([[1.0, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0.1, 0, 0, 1]]), "bottom row"),
])
def test_non_rigid_targets_are_refused(bad, why):
    T = np.broadcast_to(np.eye(4), (3, 4, 4)).copy()
    T[1] = bad
    with pytest.raises(ValueError, match=f"target poses is not a rigid transform \\(first at index \\(1,\\)\\).*{why}"):
        ikine_search(robots.puma560(), T)
    with pytest.raises(ValueError, match="not a rigid transform"):
        ws.reachable(ur5e(), bad)


@pytest.mark.parametrize("kw, message", [
    (dict(starts=0), "starts must be an integer >= 1"),
    (dict(starts=2.5), "starts must be an integer >= 1"),
    (dict(seed=-1), "seed must be a non-negative integer"),
    (dict(tol=0.0), "tol must be positive"),
    (dict(tol=1e-5), "confirm_tol .* must be at least tol"),
    (dict(tol=1e-300), r"^tol must be at least 1e-14 \(float64 forward kinematics is exact to about 1e-16 per metre"),
    (dict(seed=2**64), r"^seed must be a non-negative integer below 2\*\*64"),
    (dict(q0=np.zeros(5)), "last dimension of 6"),
])
def test_bad_settings(kw, message):
    with pytest.raises(ValueError, match=message):
        ikine_search(robots.puma560(), np.eye(4), **kw)


def test_robot_must_be_an_arm():
    with pytest.raises(TypeError, match="SerialChain or a DHRobot"):
        ikine_search("puma", np.eye(4))


def test_dh_robot_conversion_keeps_limits_and_tool():
    tool = np.eye(4)
    tool[2, 3] = 0.1
    arm = DHRobot([0.1, 0, 0], [0, 0.4, 0.3], [PI / 2, 0, 0], qlim=[[-1, 1]] * 3, tool=tool)
    chain = as_chain(arm)
    q = np.array([[0.3, -0.2, 0.5]])
    np.testing.assert_allclose(chain.fkine(q), arm.fkine(q), atol=1e-12)
    np.testing.assert_array_equal(chain.qlim, arm.qlim)


def _random_chain(rng, batch=()):
    """A chain with general axes, fixed transforms, offsets, a prismatic joint, a base and a tool."""
    from wsmap.kinematics import rpy2r

    n = 5
    F = np.zeros(batch + (n + 1, 4, 4))
    F[..., :3, :3] = rpy2r(rng.uniform(-PI, PI, batch + (n + 1, 3)))
    F[..., :3, 3] = rng.uniform(-0.3, 0.3, batch + (n + 1, 3))
    F[..., 3, 3] = 1.0
    axes = rng.normal(size=(n, 3))
    axes[1] = [0, 0, -1.0]
    base, tool = np.eye(4), np.eye(4)
    base[:3, :3], base[:3, 3] = rpy2r([0.1, 0.2, 0.3]), (0.1, -0.2, 0.3)
    tool[:3, :3], tool[:3, 3] = rpy2r([0.3, -0.1, 0.2]), (0.0, 0.05, 0.1)
    qlim = np.array([[-2, 2], [-3, 1], [-0.2, 0.3], [-PI, PI], [-1, 2.5]])
    return SerialChain(F, axes, "RRPRR", offset=rng.uniform(-1, 1, batch + (n,)), qlim=qlim, base=base, tool=tool)


def test_solver_kinematics_equal_the_chains():
    from wsmap.kinematics.ik.lm_reference import _Arm

    rng = np.random.default_rng(9)
    for chain, index in ((_random_chain(rng), None), (_random_chain(rng, (3,)), np.array([2, 0, 1, 1]))):
        q = rng.uniform(-1, 1, (4, chain.n))
        arm = _Arm(chain, index)
        R, p, w, o = arm.fk(q.T)
        ref_chain = chain if index is None else chain[index]
        T = ref_chain.fkine(q)
        np.testing.assert_allclose(np.moveaxis(R, -1, 0), T[:, :3, :3], atol=1e-12)
        np.testing.assert_allclose(p.T, T[:, :3, 3], atol=1e-12)
        J = np.moveaxis(arm.jacobian(p, w, o), -1, 0)
        np.testing.assert_allclose(J, ref_chain.jacob0(q), atol=1e-12)


def test_general_chain_poses_are_found_inside_the_limits():
    rng = np.random.default_rng(10)
    chain = _random_chain(rng)
    lo, hi = chain.qlim[:, 0], chain.qlim[:, 1]
    q = lo + rng.random((60, chain.n)) * (hi - lo)
    T = chain.fkine(q)
    # the pre-filter is sound: it never rejects a reachable pose (offsets on the slide included)
    assert reach_filter(chain, T, FK_CONFIRM_TOL).all()
    res = ikine_search(chain, T)
    assert res.success.all(), np.flatnonzero(~res.success)
    _check_solutions(chain, res, T)
    # far away: nothing (and the pre-filter answers without LM)
    far = T.copy()
    far[:, :3, 3] += 5.0
    out = ikine_search(chain, far)
    assert not out.success.any() and (out.iterations == 0).all()


def test_empty_and_single_targets():
    puma = robots.puma560()
    out = ikine_search(puma, np.zeros((0, 4, 4)))
    assert out.success.shape == (0,) and out.q.shape == (0, 6)
    one = ikine_search(puma, puma.fkine(np.full(6, 0.3)))
    assert one.success.shape == () and bool(one.success) and one.q.shape == (6,)


def test_reach_filters_are_sound_about_thefirst_axis_point():
    """The reach pre-filters bound the tool (the wrist point) from a point of the first joint's axis
    (the shoulder): never a reachable pose refused, on named arms and general chains (any axis, a
    slide, a base and a tool), and on the Panda far fewer candidates than a bound from the base."""
    from wsmap import robots
    from wsmap import workspace as ws
    from wsmap.kinematics.ik.reach_filter import first_axis_point, position_filter

    rng = np.random.default_rng(11)
    chains = [robots.load(n) for n in ("panda", "iiwa14", "gen3", "ur5e")] + [as_chain(robots.puma560())]
    chains += [_random_chain(rng) for _ in range(4)]
    for chain in chains:
        lim = np.clip(chain.qlim, -PI, PI) if chain.qlim is not None else np.tile([-PI, PI], (chain.n, 1))
        q = lim[:, 0] + rng.random((3000, chain.n)) * (lim[:, 1] - lim[:, 0])  # continuous joints: one turn
        T = chain.fkine(q)
        assert reach_filter(chain, T, 0.0).all()
        assert position_filter(chain, T[:, :3, 3], 0.0).all()
    # a batch of arms: each arm's own point
    batch = _random_chain(rng, (3,))
    centre, used = first_axis_point(batch)
    assert centre.shape == (3, 3) and used.shape == (3,)
    for b in range(3):
        one = batch[b]
        q = one.qlim[:, 0] + rng.random((500, one.n)) * (one.qlim[:, 1] - one.qlim[:, 0])
        assert position_filter(batch, one.fkine(q)[:, :3, 3], 0.0)[b].all()
    # the Panda: the shoulder (0, 0, 0.333) is the centre, not the base
    panda = robots.load("panda")
    centre, used = first_axis_point(panda)
    np.testing.assert_allclose(centre, [0, 0, 0.333], atol=1e-12)
    nodes = ws.cartesian_grid(-1.2, 1.2, 0.1)
    T = ws.target_poses(nodes, (PI, 0, 0), "standard")
    candidates = reach_filter(panda, T, FK_CONFIRM_TOL)
    reach = ws.constant_orientation_map(panda, nodes, (PI, 0, 0), method="numerical", convention="standard")
    assert not (reach & ~candidates).any()
    assert candidates.sum() < 0.4 * len(nodes) and candidates.sum() < 1.6 * reach.sum()


def test_tolerances_below_what_float64_reaches_are_refused_everywhere():
    from wsmap.kinematics import map_search
    from wsmap.kinematics.ik.solution import MIN_TOL

    T = robots.puma560().fkine(np.full(6, 0.3))
    with pytest.raises(ValueError, match=r"^tol must be at least 1e-14"):
        ikine_LM(robots.puma560(), T, tol=1e-300)
    with pytest.raises(ValueError, match=r"^tol must be at least 1e-14"):
        map_search(as_chain(robots.puma560()), T[None], np.full((1, 0), -1), tol=MIN_TOL / 2)
    # the floor itself still solves: 1e-14 is a hundredfold above float64's rounding
    assert ikine_search(robots.puma560(), T, tol=MIN_TOL).success
