import numpy as np
import pytest

from wsmap import kinematics
from wsmap import robots


@pytest.fixture
def puma():
    return robots.puma560()


def test_puma560_zero_pose_matches_published(puma):
    # NOTES.md: at q = 0 the tool sits at (0.4521, -0.15005, 0.4318)
    T = puma.fkine(np.zeros(6))
    np.testing.assert_allclose(T[:3, 3], [0.4521, -0.15005, 0.4318], atol=1e-12)
    np.testing.assert_allclose(T[:3, :3], np.eye(3), atol=1e-12)


def test_puma560_nominal_pose_matches_corke(puma):
    # Corke's Puma560 (d1 = 0.6718) at qn = [0, pi/4, pi, 0, pi/4, 0] puts the tool at
    # (0.5963, -0.1501, 0.6574); the paper's arm has d1 = 0, so z is lower by 0.6718.
    qn = np.array([0, np.pi / 4, np.pi, 0, np.pi / 4, 0])
    T = puma.fkine(qn)
    np.testing.assert_allclose(T[:3, 3], [0.5963, -0.1501, 0.6574 - 0.6718], atol=5e-5)
    np.testing.assert_allclose(T[:3, :3], [[0, 0, 1], [0, 1, 0], [-1, 0, 0]], atol=1e-12)


def test_fkine_broadcasts_over_arms_and_configurations():
    arms = robots.sample_spherical_wrist(5, seed=1)
    q = np.random.default_rng(2).uniform(-np.pi, np.pi, (7, 1, 6))
    T = arms.fkine(q)
    assert T.shape == (7, 5, 4, 4)
    one = kinematics.DHRobot(arms.d[3], arms.a[3], arms.alpha[3])
    np.testing.assert_allclose(T[4, 3], one.fkine(q[4, 0]), atol=1e-14)


def test_jacob0_matches_finite_differences():
    rng = np.random.default_rng(3)
    arms = robots.sample_arbitrary_6dof(4, seed=4)
    q = rng.uniform(-np.pi, np.pi, (4, 6))
    J = arms.jacob0(q)
    assert J.shape == (4, 6, 6)
    h = 1e-6
    T0 = arms.fkine(q)
    for j in range(6):
        dq = np.zeros(6)
        dq[j] = h
        Tp, Tm = arms.fkine(q + dq), arms.fkine(q - dq)
        dp = (Tp[..., :3, 3] - Tm[..., :3, 3]) / (2 * h)
        dR = (Tp[..., :3, :3] - Tm[..., :3, :3]) / (2 * h)
        W = dR @ np.swapaxes(T0[..., :3, :3], -1, -2)  # skew(omega)
        omega = np.stack([W[..., 2, 1], W[..., 0, 2], W[..., 1, 0]], axis=-1)
        np.testing.assert_allclose(J[..., :3, j], dp, atol=1e-8)
        np.testing.assert_allclose(J[..., 3:, j], omega, atol=1e-8)


def test_pose_error_zero_iff_equal_and_small_rotation_is_angle():
    T = robots.puma560().fkine(np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6]))
    np.testing.assert_allclose(kinematics.pose_error(T, T), 0.0, atol=1e-15)
    R = kinematics.rotz(1e-4)
    T2 = T.copy()
    T2[:3, :3] = R @ T[:3, :3]
    np.testing.assert_allclose(kinematics.pose_error(T, T2), [0, 0, 0, 0, 0, 1e-4], atol=1e-10)


def test_ikine_LM_round_trip_on_reachable_poses():
    rng = np.random.default_rng(5)
    arms = robots.sample_spherical_wrist(50, seed=6)
    q_true = rng.uniform(-np.pi, np.pi, (50, 6))
    T = arms.fkine(q_true)
    res = kinematics.ikine_LM(arms, T, q0=q_true + rng.normal(0, 0.2, q_true.shape))
    assert res.success.mean() > 0.9
    err = np.abs(arms.fkine(res.q)[res.success] - T[res.success]).max()
    assert err < 1e-9
    assert np.all(res.residual[res.success] <= 1e-10)


def test_ikine_LM_fails_on_unreachable_target(puma):
    T = kinematics.transl([2.0, 0.0, 0.0])  # far outside the 0.9 m reach
    res = kinematics.ikine_LM(puma, T)
    assert not res.success
    assert res.iterations > 100  # ran until the rejection or iteration limit
    assert res.residual > 1.0


def test_ikine_LM_settings_are_used(puma):
    T = puma.fkine(np.array([0.3, -0.4, 0.5, 0.1, 0.7, -0.2]))
    assert kinematics.ikine_LM(puma, T).success
    assert not kinematics.ikine_LM(puma, T, ilimit=1).success


def test_closed_form_all_branches_reproduce_the_pose():
    rng = np.random.default_rng(7)
    arms = robots.sample_spherical_wrist(200, seed=8)
    T = arms.fkine(rng.uniform(-np.pi, np.pi, (200, 6)))
    sol = kinematics.ikine_spherical_wrist(arms, T)
    q, valid = sol.q, sol.success
    assert q.shape == (200, 8, 6) and valid.shape == (200, 8)
    assert valid.all()
    Tq = kinematics.DHRobot(arms.d[:, None], arms.a[:, None], arms.alpha[:, None]).fkine(q)
    np.testing.assert_allclose(Tq, np.broadcast_to(T[:, None], Tq.shape), atol=1e-9)
    # the 8 branches are distinct configurations for a generic pose
    assert np.all(np.ptp(q[:, :, 1], axis=1) > 1e-6)


def test_closed_form_rejects_unreachable_and_other_arms(puma):
    sol = kinematics.ikine_spherical_wrist(puma, kinematics.transl([2.0, 0.0, 0.0]))
    assert not sol.success.any()
    other = robots.sample_arbitrary_6dof(2, seed=0)
    with pytest.raises(ValueError, match="spherical-wrist family"):
        kinematics.ikine_spherical_wrist(other, kinematics.transl([0.3, 0.0, 0.0]))


def test_joint_limits_reject_what_they_must():
    limited = robots.puma560(joint_limits=True)
    # joint 5 limited to [-100, 100] deg: a pose needing |q5| = 150 deg on every branch is out
    q = np.deg2rad([10, 20, -30, 0, 150, 0])
    T = limited.fkine(q)
    valid = kinematics.ikine_spherical_wrist(limited, T).success
    sol = kinematics.ikine_spherical_wrist(robots.puma560(), T)
    free_q, free_valid = sol.q, sol.success
    assert free_valid.all()
    ok_by_limits = limited.within_limits(free_q)
    np.testing.assert_array_equal(valid, ok_by_limits)
    assert not ok_by_limits.all()
    # 2*pi-equivalence: 350 deg on joint 6 is -10 deg, inside [-266, 266]
    assert limited.within_limits(np.deg2rad([0, 0, 0, 0, 0, 350]))
    assert not limited.within_limits(np.deg2rad([170, 0, 0, 0, 0, 0]))


def test_wrist_centre_reachability_agrees_with_closed_form():
    arms = robots.sample_spherical_wrist(30, seed=9)
    p = np.random.default_rng(10).uniform(-1, 1, (30, 500, 3))
    T = kinematics.transl(p)
    node_arms = kinematics.DHRobot(arms.d[:, None], arms.a[:, None], arms.alpha[:, None])
    reach = kinematics.wrist_centre_reachable(node_arms, p)
    valid = kinematics.ikine_spherical_wrist(node_arms, T).success
    np.testing.assert_array_equal(reach, valid.any(axis=-1))
    assert 0.05 < reach.mean() < 0.95


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(d=np.zeros(6), a=np.zeros(5), alpha=np.zeros(6)), "disagree on the number of joints"),
        (dict(d=[0, np.nan, 0], a=np.zeros(3), alpha=np.zeros(3)), "NaN"),
        (dict(d=np.zeros((2, 6)), a=np.zeros((3, 6)), alpha=np.zeros(6)), "do not broadcast"),
        (dict(d=np.zeros(6), a=np.zeros(6), alpha=np.zeros(6), qlim=np.zeros((5, 2))), "qlim must have shape"),
        (dict(d=np.zeros(6), a=np.zeros(6), alpha=np.zeros(6), tool=np.eye(3)), "tool must be a 4x4"),
    ],
)
def test_bad_dh_input_is_named(kwargs, message):
    with pytest.raises(ValueError, match=message):
        kinematics.DHRobot(**kwargs)


def test_bad_q_and_targets(puma):
    with pytest.raises(ValueError, match="last dimension of 6"):
        puma.fkine(np.zeros(5))
    with pytest.raises(ValueError, match="NaN"):
        puma.fkine(np.full(6, np.nan))
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 4, 4\)"):
        kinematics.ikine_LM(puma, np.eye(3))
    with pytest.raises(ValueError, match="tol must be positive"):
        kinematics.ikine_LM(puma, np.eye(4), tol=-1)


def test_unknown_robot_is_named():
    with pytest.raises(ValueError, match="unknown robot 'kuka'; known robots: puma560"):
        robots.from_name("kuka")


def test_samplers_follow_the_paper_distribution():
    arms = robots.sample_spherical_wrist(2000, seed=11)
    assert arms.batch_shape == (2000,)
    assert kinematics.is_spherical_wrist(arms).all()
    free = np.concatenate([arms.d[:, [2, 3]], arms.a[:, [1, 2]]], axis=1)
    assert free.min() >= 0 and free.max() <= 0.5 and abs(free.mean() - 0.25) < 0.01
    assert not np.allclose(robots.sample_spherical_wrist(3, seed=1).d, robots.sample_spherical_wrist(3, seed=2).d)
    np.testing.assert_array_equal(robots.sample_spherical_wrist(3, seed=1).d, robots.sample_spherical_wrist(3, seed=1).d)
    arb = robots.sample_arbitrary_6dof(100, seed=12)
    assert not kinematics.is_spherical_wrist(arb).any()
    assert arb.alpha.min() >= 0 and arb.alpha.max() <= 0.5


def test_random_q_inside_limits_of_1e308_is_finite_and_uniform():
    arm = robots.load("panda")
    wide = arm.replace(qlim=np.tile([-1e308, 1e308], (arm.n, 1)))
    q = wide.random_q(2000, np.random.default_rng(0))
    assert np.all(np.isfinite(q)) and wide.within_limits(q).all()
    assert abs(np.mean(q > 0) - 0.5) < 0.05  # both halves of the range
    # ordinary limits draw the very same numbers as before (lo + u (hi - lo))
    u = np.random.default_rng(1).random((5, arm.n))
    lo, hi = arm.qlim[:, 0], arm.qlim[:, 1]
    np.testing.assert_array_equal(arm.random_q(5, np.random.default_rng(1)), lo + u * (hi - lo))
