"""The paper's LM (wsmap.kinematics.ik.lm.ikine_LM, the compiled kernel) against the numpy reference
(wsmap.kinematics.ik.lm_reference.ikine_LM_reference): the same successes and iteration counts, the
Appendix's counting at its edges, and the answer's fields."""

import numpy as np
import pytest

from wsmap import kinematics
from wsmap import robots
from wsmap import workspace as ws
from wsmap.kinematics import IKReason, lm_compiled
from wsmap.kinematics.ik.lm_reference import ikine_LM_reference


@pytest.fixture(scope="module")
def puma():
    return robots.puma560()


@pytest.fixture(scope="module")
def grid_sample():
    """300 nodes of the paper's 21³ grid (about a third reachable), paper convention, rpy = 0."""
    nodes = ws.cartesian_grid(-1.0, 1.0, 0.1)
    pick = np.random.default_rng(11).choice(len(nodes), 300, replace=False)
    return ws.target_poses(nodes[pick], np.zeros(3))


@pytest.fixture(scope="module")
def unreachable(puma, grid_sample):
    exact = kinematics.wrist_centre_reachable(puma, grid_sample[:, :3, 3])
    return grid_sample[~exact][:60]


def test_success_mask_and_converged_iterations_match_the_reference(puma, grid_sample):
    ref, new = ikine_LM_reference(puma, grid_sample), kinematics.ikine_LM(puma, grid_sample)
    assert 50 < ref.success.sum() < 250  # a real mix of reachable and unreachable nodes
    np.testing.assert_array_equal(new.success, ref.success)
    ok = new.success
    # converged targets follow the same path: rounding differences are far too small to matter
    np.testing.assert_array_equal(new.iterations[ok], ref.iterations[ok])
    assert np.all(new.residual[ok] <= 1e-10)
    # failures stop by the rejection limit (or stagnate towards it) or at ilimit
    assert np.all(new.iterations[~ok] <= 500) and np.all(new.iterations[~ok] > 100)
    np.testing.assert_allclose(new.residual[~ok], ref.residual[~ok], rtol=1e-6)
    # the exact map agrees too
    exact = kinematics.wrist_centre_reachable(puma, grid_sample[:, :3, 3])
    assert not np.any(ok & ~exact)


def test_per_target_arms_and_a_tool_match_the_reference():
    rng = np.random.default_rng(3)
    arms = robots.sample_arbitrary_6dof(120, seed=4)
    tool = kinematics.transl([0.01, -0.02, 0.05])
    tool[:3, :3] = kinematics.rpy2r([0.1, -0.2, 0.3])
    arms = kinematics.DHRobot(arms.d, arms.a, arms.alpha, tool=tool)
    T = arms.fkine(rng.uniform(-np.pi, np.pi, (120, 6)))
    T[60:, :3, 3] *= 3.0  # half of them moved out of reach
    ref, new = ikine_LM_reference(arms, T), kinematics.ikine_LM(arms, T)
    np.testing.assert_array_equal(new.success, ref.success)
    np.testing.assert_array_equal(new.iterations[new.success], ref.iterations[ref.success])
    assert new.success[:60].sum() > 20 and not new.success[60:].any()


@pytest.mark.parametrize("ilimit,rlimit", [(0, 100), (1, 100), (2, 0), (3, 1), (6, 2), (12, 0), (40, 3)])
def test_small_limits_match_the_reference(puma, grid_sample, ilimit, rlimit):
    T = grid_sample[:120]
    ref = ikine_LM_reference(puma, T, ilimit=ilimit, rlimit=rlimit)
    new = kinematics.ikine_LM(puma, T, ilimit=ilimit, rlimit=rlimit)
    np.testing.assert_array_equal(new.success, ref.success)
    assert np.all(new.iterations <= ilimit)
    np.testing.assert_array_equal(new.iterations[new.success], ref.iterations[ref.success])
    if ilimit <= 12:
        # within a dozen iterations no unreachable target has reached the local minimum, where
        # accepting or rejecting depends on rounding, so every count and iterate agrees
        np.testing.assert_array_equal(new.iterations, ref.iterations)
        np.testing.assert_allclose(new.q, ref.q, atol=1e-9)
        np.testing.assert_allclose(new.residual, ref.residual, rtol=1e-9, atol=1e-15)


def test_target_at_start_pose_succeeds_at_first_iteration(puma):
    T = puma.fkine(np.zeros(6))[None]
    for ilimit, expected in ((0, 0), (1, 1), (500, 1)):
        for solve in (kinematics.ikine_LM, ikine_LM_reference):
            res = solve(puma, T, ilimit=ilimit)
            assert res.success[0] and res.iterations[0] == expected and res.residual[0] == 0.0


def test_stagnated_failures_are_counted_to_their_limits(puma, unreachable):
    # a failure ends by more than rlimit rejections in a row or at ilimit, and a stagnated run is
    # counted to where its rejections (or ilimit) would have ended it: never fewer than
    # min(rlimit + 1, ilimit) iterations, in both implementations (where a failure stops at the
    # local minimum depends on rounding, so the counts of the two need not agree)
    for ilimit, rlimit in ((60, 100), (120, 30), (200, 45)):
        for solve in (kinematics.ikine_LM, ikine_LM_reference):
            res = solve(puma, unreachable, ilimit=ilimit, rlimit=rlimit)
            assert not res.success.any()
            assert np.all(res.iterations <= ilimit)
            assert np.all(res.iterations >= min(rlimit + 1, ilimit))
            assert (res.reason == IKReason.NO_CONVERGENCE).all()


def test_round_trip_on_random_reachable_poses():
    rng = np.random.default_rng(21)
    arms = robots.sample_spherical_wrist(200, seed=22)
    q_true = rng.uniform(-np.pi, np.pi, (200, 6))
    T = arms.fkine(q_true)
    res = kinematics.ikine_LM(arms, T, q0=q_true + rng.normal(0.0, 0.3, q_true.shape))
    assert res.success.mean() > 0.9
    ok = res.success
    np.testing.assert_allclose(arms[ok].fkine(res.q[ok]), T[ok], atol=1e-9)
    assert np.all(res.residual[ok] <= 1e-10)
    assert res.q.shape == (200, 6) and res.iterations.dtype == np.int64


def test_chunks_threads_and_progress_change_no_result(puma, grid_sample):
    seen = []
    whole = kinematics.ikine_LM(puma, grid_sample[:90])
    parts = kinematics.ikine_LM(puma, grid_sample[:90], chunk=32, progress=seen.append)
    assert seen == [32, 32, 26]
    before = lm_compiled.threads()
    try:
        lm_compiled.set_threads(1)
        one_thread = kinematics.ikine_LM(puma, grid_sample[:90])
    finally:
        lm_compiled.set_threads(before)
    # a target's arithmetic does not depend on the other targets in its chunk: identical bits
    for other in (parts, one_thread):
        for f in ("q", "success", "iterations", "residual", "reason"):
            np.testing.assert_array_equal(getattr(whole, f), getattr(other, f))
    one = kinematics.ikine_LM(puma, grid_sample[7])
    assert one.iterations == whole.iterations[7] and np.array_equal(one.q, whole.q[7])


def test_reasons_of_the_papers_lm():
    limited = robots.puma560(joint_limits=True)
    rng = np.random.default_rng(5)
    q = rng.uniform(-np.pi, np.pi, (60, 6))
    T = np.concatenate([limited.fkine(q), kinematics.transl([[2.0, 0, 0], [0, 2.5, 0]])])
    res = kinematics.ikine_LM(limited, T, q0=np.concatenate([q, np.zeros((2, 6))]), check_limits=True)
    converged = kinematics.ikine_LM(limited, T, q0=np.concatenate([q, np.zeros((2, 6))])).success
    outside = converged & ~limited.within_limits(res.q)
    assert outside.any() and res.success.any()
    np.testing.assert_array_equal(res.success, converged & ~outside)
    np.testing.assert_array_equal(res.reason == IKReason.SOLVED, res.success)
    np.testing.assert_array_equal(res.reason == IKReason.OUTSIDE_LIMITS, outside)
    np.testing.assert_array_equal(res.reason == IKReason.NO_CONVERGENCE, ~converged)
    assert res.reason.dtype == np.int8 and res.start is None
    assert (res.reason[-2:] == IKReason.NO_CONVERGENCE).all()


def test_ikine_LM_takes_dh_arms_only():
    with pytest.raises(TypeError, match="ikine_LM takes a DHRobot .* use wsmap.kinematics.ikine_search"):
        kinematics.ikine_LM(robots.load("ur5e"), np.eye(4))
