"""The sound pre-filter of the reachability search (wsmap.kinematics.ik.reach_filter.reach_filter) with the
wrist-point bound for a fixed orientation: it never excludes a pose that forward kinematics reaches
(named arms, random DH arms, random chains with any axes, base and tool), and it leaves the maps'
answers as they were while the search does less work."""

import math

import numpy as np
import pytest

from wsmap import robots
from wsmap import workspace as ws
from wsmap.kinematics import as_chain, ikine_spherical_wrist, rotx, ur_reachable
from wsmap.kinematics.ik import memo
from wsmap.kinematics.ik import search
from wsmap.kinematics.ik.reach_filter import reach_filter
from wsmap.kinematics.ik.search import FK_CONFIRM_TOL, map_search

from frames import random_chain

PI = math.pi


def _perturbed(rng, T, tol):
    """Poses within ``tol`` (position m, rotation angle rad) of ``T``: what the confirmation accepts."""
    K = T.shape[:-2]
    axis = rng.normal(size=K + (3,))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    ang = 0.99 * tol
    Kx = np.zeros(K + (3, 3))
    Kx[..., 0, 1], Kx[..., 0, 2], Kx[..., 1, 2] = -axis[..., 2], axis[..., 1], -axis[..., 0]
    Kx = Kx - np.swapaxes(Kx, -1, -2)
    dR = np.eye(3) + math.sin(ang) * Kx + (1 - math.cos(ang)) * Kx @ Kx
    out = T.copy()
    out[..., :3, :3] = dR @ T[..., :3, :3]
    step = rng.normal(size=K + (3,))
    out[..., :3, 3] += 0.99 * tol * step / np.linalg.norm(step, axis=-1, keepdims=True)
    return out


def _assert_keeps_fk_poses(chain, rng, count):
    q = chain.random_q(count, rng)
    T = chain.fkine(q)
    assert reach_filter(chain, T, FK_CONFIRM_TOL).all()
    assert reach_filter(chain, _perturbed(rng, T, FK_CONFIRM_TOL), FK_CONFIRM_TOL).all()


@pytest.mark.parametrize("name", list(robots.ROBOTS))
@pytest.mark.parametrize("limits", [None, False])
def test_named_arms_keep_every_fk_pose(name, limits):
    _assert_keeps_fk_poses(as_chain(robots.load(name, joint_limits=limits)), np.random.default_rng(0), 50000)


def test_random_dh_arms_keep_every_fk_pose():
    rng = np.random.default_rng(1)
    for arms in (robots.sample_arbitrary_6dof(40, seed=2), robots.sample_spherical_wrist(40, seed=3)):
        _assert_keeps_fk_poses(as_chain(arms), rng, 2000)  # (2000, 40) poses, each of its arm


def test_random_chains_keep_every_fk_pose():
    rng = np.random.default_rng(4)
    for k in range(40):
        _assert_keeps_fk_poses(random_chain(rng, 2 + k % 6), rng, 5000)


def test_bound_is_tight_for_the_puma560():
    """For the PUMA560 without limits the bound is the exact reach (the wrist centre's shell with its
    shoulder-offset cylinder), so no unreachable node of the grid is left to the search."""
    puma = robots.puma560()
    nodes = ws.cartesian_grid(-1, 1, 0.1)
    for R in (np.eye(3), rotx(PI)):
        T = ws.target_poses(nodes, (0, 0, 0), "standard")
        T[:, :3, :3] = R
        exact = ikine_spherical_wrist(puma, T).success.any(axis=-1)
        possible = reach_filter(as_chain(puma), T, FK_CONFIRM_TOL)
        assert possible[exact].all()
        assert possible.sum() == exact.sum()
        # the bound without the wrist orbit (the sum of link lengths) keeps over 1700 more
        assert reach_filter(as_chain(puma), T, FK_CONFIRM_TOL, wrist_orbit=False).sum() > exact.sum() + 1700


@pytest.mark.parametrize("name", ["puma560", "ur5e"])
def test_same_map_with_less_work(name, monkeypatch):
    arm = robots.load(name)
    nodes = ws.cartesian_grid(-1, 1, 0.1)
    nb = ws.grids.node_neighbours(nodes)
    for R in (np.eye(3), rotx(PI)):
        T = ws.target_poses(nodes, (0, 0, 0), "standard")
        T[:, :3, :3] = R
        # the wrist orbit's share alone (the joint-limit bound off in both)
        new = map_search(arm, T, nb, limit_bound=False)
        with monkeypatch.context() as m:
            m.setattr(search, "reach_filter", lambda *a, **k: reach_filter(*a, wrist_orbit=False, **k))
            old = map_search(arm, T, nb, limit_bound=False)
        assert np.array_equal(new.success, old.success)
        assert new.iterations.sum() < 0.4 * old.iterations.sum()
        exact = ikine_spherical_wrist(arm, T).success.any(axis=-1) if name == "puma560" else ur_reachable(arm, T)
        assert np.array_equal(new.success, exact)


def test_one_arm_and_a_batch_agree():
    """The one-arm path (the second test only where the first passed) and the batch path agree."""
    nodes = ws.cartesian_grid(-1, 1, 0.1)
    T = ws.target_poses(nodes, (PI, 0, 0), "standard")
    for name in ("puma560", "ur5e", "panda"):
        chain = as_chain(robots.load(name))
        one = reach_filter(chain, T, FK_CONFIRM_TOL)
        batch = chain.replace(fixed=chain.fixed[None], offset=chain.offset[None])
        assert batch.batch_shape == (1,)
        assert np.array_equal(one, reach_filter(batch, T[:, None], FK_CONFIRM_TOL)[:, 0])
        assert np.array_equal(one[:5], [reach_filter(chain, t, FK_CONFIRM_TOL) for t in T[:5]])


def test_memos_follow_the_arms_numbers():
    """The search memoises per-arm numbers by content: equal arms share them, another arm does not."""
    from wsmap.kinematics import ikine_search

    arm = robots.puma560()
    assert memo.as_chain_memo(arm) is memo.as_chain_memo(robots.puma560())
    T = arm.fkine(np.full(6, 0.3))
    assert ikine_search(arm, T).success
    short = robots.spherical_wrist(a2=0.2159, a3=0.0203, d3=0.15005, d4=0.2159)
    assert memo.as_chain_memo(short) is not memo.as_chain_memo(arm)
    assert not ikine_search(short, T).success  # out of its reach
    assert ikine_search(arm, T).success
