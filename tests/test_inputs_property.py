"""Property-based tests (hypothesis) of the inputs everything else builds on: grids, DH tables, poses."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wsmap import robots
from wsmap import workspace as ws
from wsmap.kinematics import DHRobot, check_rigid, ikine_LM, ikine_search, rotx, rpy2r, transl

finite = st.floats(-10, 10, allow_nan=False, allow_infinity=False)
anything = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.complex_numbers(), st.integers(-10**30, 10**30))


@settings(max_examples=150, deadline=None)
@given(lo=st.floats(-5, 5), span=st.floats(0, 2), step=st.floats(0.05, 3))
def test_grid_counts_and_bounds(lo, span, step):
    hi = lo + span
    axes = ws.grid_axes(lo, hi, step)
    n = len(axes[0])
    assert n >= 1 and all(len(a) == n for a in axes)
    assert axes[0][0] == lo and axes[0][-1] <= hi + 1e-9 * max(1, abs(hi))
    # the next node would pass hi
    assert lo + n * step > hi - 1e-9 * max(1.0, span / step) * step
    nodes = ws.cartesian_grid(lo, hi, step)
    assert nodes.shape == (n**3, 3)
    np.testing.assert_array_equal(nodes[:n, 0], axes[0])  # x varies fastest


@settings(max_examples=150, deadline=None)
@given(lo=anything, hi=anything, step=anything)
def test_any_grid_input_is_a_grid_or_a_named_value_error(lo, hi, step):
    try:
        axes = ws.grid_axes(lo, hi, step)
    except (ValueError, MemoryError) as e:
        assert any(w in str(e) for w in ("lo", "hi", "step", "nodes", "GiB")), str(e)
        return
    assert all(len(a) >= 1 for a in axes)
    assert np.prod([len(a) for a in axes]) <= ws.MAX_NODES


@settings(max_examples=100, deadline=None)
@given(d=st.lists(anything, min_size=6, max_size=6))
def test_dh_columns_are_real_and_finite_or_refused(d):
    try:
        arm = DHRobot(d, np.zeros(6), np.zeros(6))
    except ValueError as e:
        assert "DH column d" in str(e)
        return
    assert arm.d.dtype == np.float64 and np.all(np.isfinite(arm.d))


@settings(max_examples=100, deadline=None)
@given(q=st.lists(finite, min_size=6, max_size=6), dh=st.lists(st.floats(-1, 1), min_size=12, max_size=12))
def test_fkine_is_a_rigid_transform(q, dh):
    arm = DHRobot(dh[:6], dh[6:], robots.puma560().alpha)
    T = arm.fkine(q)
    check_rigid("fkine", T, atol=1e-9)


@settings(max_examples=100, deadline=None)
@given(entries=st.lists(st.floats(-2, 2), min_size=16, max_size=16))
def test_non_rigid_targets_are_refused_by_ikine(entries):
    T = np.asarray(entries).reshape(4, 4)
    R = T[:3, :3]
    rigid = (np.allclose(R.T @ R, np.eye(3), atol=1e-6) and abs(np.linalg.det(R) - 1) < 1e-6
             and np.allclose(T[3], [0, 0, 0, 1], atol=1e-6))
    if rigid:  # practically never drawn
        return
    with pytest.raises(ValueError, match="not a rigid transform"):
        ikine_LM(robots.puma560(), T)


@pytest.mark.parametrize(
    "T, why",
    [
        (np.diag([2.0, 1, 1, 1]), "not orthonormal"),  # scale
        (np.array([[1, 0.5, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]]), "not orthonormal"),  # shear
        (np.diag([1.0, 1, -1, 1]), "reflection"),
        (np.vstack([np.eye(4)[:3], [1, 2, 3, 4]]), "bottom row"),
    ],
)
def test_ikine_refuses_non_rigid_targets_by_name(T, why):
    # these used to be reported as solved
    for solve in (lambda: ikine_LM(robots.puma560(), T),
                  lambda: ikine_search(robots.puma560(), T)):
        with pytest.raises(ValueError, match=f"target poses is not a rigid transform: .*{why}"):
            solve()


def test_a_batch_of_targets_names_the_first_bad_one():
    T = np.broadcast_to(transl([0.5, 0, 0]), (3, 4, 4)).copy()
    T[2, 0, 0] = 3.0
    with pytest.raises(ValueError, match=r"first at index \(2,\)"):
        ikine_LM(robots.puma560(), T)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(d=np.zeros(6) + 1j), "DH column d must be real numbers"),
        (dict(a=[0, 0, 0, 0, 0, "x"]), "DH column a must be real numbers"),
        (dict(tool=2 * np.eye(4)), "tool is not a rigid transform"),
        (dict(tool=np.diag([1.0, 1, -1, 1])), "tool is not a rigid transform"),
        (dict(tool=np.eye(4) + 1j), "tool must be real numbers"),
        (dict(qlim=np.zeros((6, 2)) + 1j), "qlim must be real numbers"),
    ],
)
def test_dhrobot_refuses_complex_and_non_rigid(kwargs, message):
    base = dict(d=np.zeros(6), a=np.zeros(6), alpha=np.zeros(6))
    with pytest.raises(ValueError, match=message):
        DHRobot(**{**base, **kwargs})


def test_a_rigid_tool_is_accepted_and_used():
    tool = transl([0, 0, 0.1]) @ np.pad(rotx(0.3), ((0, 1), (0, 1))) + np.diag([0, 0, 0, 0.0])
    tool[3, 3] = 1.0
    arm = DHRobot(robots.puma560().d, robots.puma560().a, robots.puma560().alpha, tool=tool)
    np.testing.assert_allclose(arm.fkine(np.zeros(6)), robots.puma560().fkine(np.zeros(6)) @ tool)


def test_target_poses_are_rigid():
    T = ws.target_poses(ws.cartesian_grid(-1, 1, 0.5), rpy2r([0.1, 0.2, 0.3]) is not None and [0.1, 0.2, 0.3])
    check_rigid("targets", T, atol=1e-12)
