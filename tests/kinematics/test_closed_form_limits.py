"""Every q a closed form returns lies inside the joint limits (moved there by whole turns) and
reproduces its pose: maps with `return_q`, `base_placement`, the closed forms' own solves, and the
one place they all pass (`registry.into_limits`)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wsmap import robots
from wsmap.kinematics import DHRobot, IKReason, closed_form_for
from wsmap.kinematics.ik.registry import into_limits, solution_within_limits
from wsmap.kinematics.ik.solution import IKSolution
from wsmap.workspace import base_placement, cartesian_grid, constant_orientation_map, target_poses

TWO_PI = 2.0 * np.pi
D2R = np.pi / 180
NODES = cartesian_grid(-1.0, 1.0, 0.25)  # 9³ nodes
# a spherical-wrist arm with a shoulder offset in the FANUC LR Mate 200iD's DH numbers and limits
FANUC_QLIM = D2R * np.array([[-170, 170], [-100, 145], [-70, 213], [-190, 190], [-125, 125], [-360, 360]])


def fanuc_like(qlim=FANUC_QLIM) -> DHRobot:
    return DHRobot(d=[0.33, 0, 0, -0.335, 0, -0.08], a=[0.05, 0.33, 0.035, 0, 0, 0],
                   alpha=[-np.pi / 2, np.pi, -np.pi / 2, np.pi / 2, -np.pi / 2, np.pi], qlim=qlim, name="lrmate")


def ur5e(qlim=None):
    return robots.load("ur5e").replace(qlim=qlim)


ARMS = {"ur5e": (ur5e, 1.0), "fanuc": (fanuc_like, 0.8), "puma560": (lambda qlim: DHRobot(
    robots.puma560().d, robots.puma560().a, robots.puma560().alpha, qlim=qlim), 0.8)}


def _in_range_mod_2pi(q, lo, hi):
    """Independent check: some q + 2·pi·k (k = -3..3) within [lo, hi] (1e-12 either side, so that
    a tool-down pose's q4 = -4e-16 is inside [0, 1]), every joint."""
    k = np.arange(-3, 4).reshape((7,) + (1,) * q.ndim)
    shifted = q[None] + TWO_PI * k
    return np.any((shifted >= lo - 1e-12) & (shifted <= hi + 1e-12), axis=0).all(axis=-1)


def _check_map(arm, nodes, rpy):
    """The exact map with q: every reachable node's q inside the limits (1e-12) and FK-confirmed
    (1e-9); the node set that of the free arm's branches filtered by an independent limit check."""
    m, q = constant_orientation_map(arm, nodes, rpy, method="exact", return_q=True)
    T = target_poses(nodes, rpy)
    lo, hi = arm.qlim[:, 0], arm.qlim[:, 1]
    assert np.all((q[m] >= lo - 1e-12) & (q[m] <= hi + 1e-12))
    assert np.isnan(q[~m]).all()
    if m.any():
        assert np.abs(arm.fkine(q[m]) - T[m]).max() <= 1e-9
    free = closed_form_for(arm).solve(arm.replace(qlim=None) if hasattr(arm, "replace") else
                                      DHRobot(arm.d, arm.a, arm.alpha), T)
    expected = (free.success & _in_range_mod_2pi(free.q, lo, hi)).any(axis=-1)
    np.testing.assert_array_equal(m, expected)
    return m


limits = st.tuples(st.floats(-8.0, 6.0), st.floats(0.2, 8.0)).map(lambda t: [t[0], t[0] + t[1]])
fixed = st.sampled_from([[1.0, 5.0], [-7.0, -1.0], [-1.0, 1.0], [2.0, 9.0], [-TWO_PI, TWO_PI]])


@settings(max_examples=25, deadline=None)
@given(name=st.sampled_from(sorted(ARMS)), qlim=st.lists(st.one_of(limits, fixed), min_size=6, max_size=6),
       turns=st.sampled_from([-1, 1]), rpy=st.sampled_from([(np.pi, 0.0, 0.0), (0.0, 0.0, 0.0), (0.3, -1.2, 2.0)]))
def test_map_q_inside_random_limits_and_the_same_nodes_a_turn_away(name, qlim, turns, rpy):
    make, half = ARMS[name]
    qlim = np.array(qlim)
    nodes = NODES * half
    m = _check_map(make(qlim), nodes, rpy)
    # the same limits a whole turn away: the same reachable nodes (every joint at once)
    shifted = _check_map(make(qlim + turns * TWO_PI), nodes, rpy)
    np.testing.assert_array_equal(m, shifted)


@pytest.mark.parametrize("name", sorted(ARMS))
def test_limits_that_exclude_zero_keep_nodes_and_move_q(name):
    make, half = ARMS[name]
    qlim = np.tile([-np.pi, np.pi], (6, 1))
    qlim[0] = [1.0, 5.0]  # joint 1 only on the far side: most free solutions need a turn
    qlim[3] = [-7.0, -1.0]
    nodes = NODES * half
    m = _check_map(make(qlim), nodes, (np.pi, 0.0, 0.0))
    assert m.sum() > 20
    free_m, free_q = constant_orientation_map(make(None), nodes, (np.pi, 0.0, 0.0), method="exact", return_q=True)
    # the free solutions mostly have q1 < 1: the limited map's q did move by whole turns
    assert np.any(free_q[m][:, 0] < 1.0)
    assert m.sum() <= free_m.sum()


def test_a_default_fanuc_like_map_returns_its_q_inside_the_limits():
    arm = fanuc_like()
    assert closed_form_for(arm).name == "spherical_wrist_offset"
    m = _check_map(arm, cartesian_grid(-0.8, 0.8, 0.1), (np.pi, 0.0, 0.0))
    assert m.sum() > 1000


def test_base_placement_q_inside_the_limits():
    arm = fanuc_like()
    rng = np.random.default_rng(3)
    q = rng.uniform(FANUC_QLIM[:, 0], FANUC_QLIM[:, 1], (6, 6))
    targets = arm.fkine(q)
    targets[:, :2, 3] += 0.3  # the arm's own poses, the base moved
    p = base_placement(arm, targets, x=(0.0, 0.6), y=(0.0, 0.6), step=0.3, yaws=4)
    ok = ~np.isnan(p.q).any(axis=-1)
    assert ok.any()
    assert np.all((p.q[ok] >= FANUC_QLIM[:, 0]) & (p.q[ok] <= FANUC_QLIM[:, 1]))
    assert p.method == "exact"
    np.testing.assert_allclose(p.poses[0] @ arm.fkine(p.q[ok]), targets[ok], rtol=0, atol=1e-9)
    # the tie-break's joint margin is read off these solutions: inside the limits, in [0, 1]
    assert 0.0 <= p.joint_margin[0] <= 1.0


# --------------------------------------------------------------------------- the one place
def test_into_limits_moves_by_whole_turns_and_refuses_what_no_turn_brings_inside():
    lo = np.array([1.0, -7.0, -np.inf, -1.0, 0.0])
    hi = np.array([5.0, -1.0, 0.3, 1.0, 10.0])
    q = np.array([[-2.0, 2.0, 2.0, 0.5, -0.5],
                  [0.0, 0.0, 0.0, 2.0, 0.0]])  # row 1: q4 = 2 has no turn into [-1, 1]
    out, ok = into_limits(q, np.array([True, True]), lo, hi)
    np.testing.assert_allclose(out[0], [-2.0 + TWO_PI, 2.0 - TWO_PI, 2.0 - TWO_PI, 0.5, -0.5 + TWO_PI], rtol=0,
                               atol=1e-15)
    np.testing.assert_array_equal(ok, [True, False])
    np.testing.assert_array_equal(out[1], q[1])  # a refused row stays as it was
    # nothing to move: the inputs themselves
    q2 = np.zeros((3, 5))
    q2[:, 0] = 2.0
    out2, ok2 = into_limits(q2, np.ones(3, dtype=bool), lo[:], np.maximum(hi, 2.0))
    assert out2 is q2
    # failing rows are never moved; prismatic joints neither
    out3, _ = into_limits(q, np.array([False, True]), lo, hi, revolute=[False, True, True, True, True])
    np.testing.assert_array_equal(out3[0], q[0])
    # within the 1e-12 slack of a limit: the limit itself
    out4, ok4 = into_limits(np.array([[5.0 + 5e-13], [1.0 - 5e-13], [1.0 - 5e-12]]), np.ones(3, dtype=bool),
                            np.array([1.0]), np.array([5.0]))
    np.testing.assert_array_equal(out4[:2, 0], [5.0, 1.0])
    np.testing.assert_array_equal(ok4, [True, True, False])


def test_solution_within_limits_marks_a_refused_branch_outside_limits():
    arm = DHRobot(d=[0.0, 0.0], a=[0.5, 0.3], alpha=[0.0, 0.0], qlim=[[1.0, 2.0], [-1.0, 1.0]])
    q = np.array([[[1.5 - TWO_PI, 0.2], [1.5, 3.0]]])  # branch 0 needs a turn; branch 1 fits none
    sol = IKSolution(q, np.array([[True, True]]), np.zeros((1, 2), dtype=np.int64), np.full((1, 2), np.nan),
                     np.zeros((1, 2), dtype=np.int8))
    out = solution_within_limits(arm, sol)
    np.testing.assert_allclose(out.q[0, 0], [1.5, 0.2], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(out.success, [[True, False]])
    np.testing.assert_array_equal(out.reason, [[IKReason.SOLVED, IKReason.OUTSIDE_LIMITS]])
