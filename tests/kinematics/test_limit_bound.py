"""The joint-limit bound of the map search (wsmap.kinematics.ik.reach_filter.limit_filter, map_search's
``limit_bound``): it never rejects a pose that a configuration inside the limits reaches (named arms,
random chains with general axes, bases and tools, poses perturbed within the confirmation tolerance),
what it rejects is unreachable by a 128-start search, and the maps with and without it are identical
(same nodes, same solutions) on named arms and on URDF arms."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wsmap import robots
from wsmap import workspace as ws
from wsmap.kinematics import as_chain, ikine_search, map_search
from wsmap.kinematics.ik.reach_filter import limit_bounds, limit_filter, reach_filter
from wsmap.kinematics.ik.search import FK_CONFIRM_TOL

from frames import random_chain, random_rigid

ARMS = ("panda", "iiwa14", "gen3", "ur5e", "puma560")


def _perturbed(rng, T, tol):
    """Poses within ``tol`` (m in position, rad in rotation angle) of ``T``."""
    axis = rng.normal(size=T.shape[:-2] + (3,))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    K = np.zeros(T.shape[:-2] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -axis[..., 2], axis[..., 1], -axis[..., 0]
    K = K - np.swapaxes(K, -1, -2)
    ang = 0.99 * tol
    out = T.copy()
    out[..., :3, :3] = (np.eye(3) + math.sin(ang) * K + (1 - math.cos(ang)) * K @ K) @ T[..., :3, :3]
    step = rng.normal(size=T.shape[:-2] + (3,))
    out[..., :3, 3] += 0.99 * tol * step / np.linalg.norm(step, axis=-1, keepdims=True)
    return out


@settings(max_examples=25, deadline=None)
@given(arm=st.sampled_from(ARMS), seed=st.integers(0, 2**32 - 1))
def test_a_pose_inside_the_limits_is_never_rejected(arm, seed):
    chain = as_chain(robots.load(arm))
    rng = np.random.default_rng(seed)
    T = chain.fkine(chain.random_q(2000, rng))
    assert limit_filter(chain, T, FK_CONFIRM_TOL).all()
    assert limit_filter(chain, _perturbed(rng, T, FK_CONFIRM_TOL), FK_CONFIRM_TOL).all()


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 7))
def test_random_chains_keep_every_pose_inside_the_limits(seed, n):
    rng = np.random.default_rng(seed)
    chain = random_chain(rng, n, unlimited=0.2)  # a fifth of the joints without limits
    q = chain.random_q(3000, rng)
    # the limits' corners too, where the ranges' extremes sit
    q[:200] = np.where(rng.random((200, n)) < 0.5, np.nan_to_num(chain.limits[:, 0], neginf=-np.pi),
                       np.nan_to_num(chain.limits[:, 1], posinf=np.pi))
    T = chain.fkine(q)
    assert limit_filter(chain, T, FK_CONFIRM_TOL).all()
    assert limit_filter(chain, _perturbed(rng, T, FK_CONFIRM_TOL), FK_CONFIRM_TOL).all()


def test_the_bound_does_not_depend_on_base_or_tool():
    chain = as_chain(robots.load("panda"))
    rng = np.random.default_rng(3)
    moved = chain.replace(base=random_rigid(rng, 1, 0.5)[0], tool=random_rigid(rng, 1, 0.1)[0])
    assert limit_bounds(moved) is limit_bounds(chain)
    T = moved.fkine(moved.random_q(2000, rng))
    assert limit_filter(moved, T, FK_CONFIRM_TOL).all()
    assert limit_bounds(chain.replace(fixed=chain.fixed[None])) is None  # a batch: no bound


def _panda_tool_down():
    panda = robots.load("panda")
    nodes = ws.cartesian_grid(-1, 1, 0.1)
    return panda, nodes, ws.target_poses(nodes, (math.pi, 0, 0), "standard")


def test_what_it_rejects_is_unreachable_and_it_rejects_much():
    panda, nodes, T = _panda_tool_down()
    chain = as_chain(panda)
    wide = reach_filter(chain, T, FK_CONFIRM_TOL)
    rejected = np.flatnonzero(wide & ~limit_filter(chain, T, FK_CONFIRM_TOL))
    # the Panda's elbow limit keeps its wrist within 0.81 m of the shoulder, not the links' 0.95 m
    assert rejected.size > 600
    pick = np.random.default_rng(0).choice(rejected, 60, replace=False)
    assert not ikine_search(panda, T[pick], starts=128, seed=7).success.any()


def _urdf_arm(rel, base, ee):
    rtbdata = pytest.importorskip("rtbdata")
    return robots.from_urdf(os.path.join(os.path.dirname(rtbdata.__file__), rel), base_link=base, ee_link=ee)


@pytest.mark.parametrize("arm", ["panda", "iiwa14", "gen3", "yumi_r", "iiwa14_urdf"])
def test_same_map_with_and_without(arm):
    if arm == "yumi_r":
        robot = _urdf_arm("xacro/yumi_description/urdf/yumi.urdf", "yumi_body", "yumi_link_7_r")
    elif arm == "iiwa14_urdf":
        robot = _urdf_arm("xacro/kuka_description/kuka_lbr_iiwa/urdf/lbr_iiwa_14_r820.urdf", None, "tool0")
    else:
        robot = robots.load(arm)
    chain = as_chain(robot)
    frames, tool = chain.joint_frames(np.zeros(chain.n))
    pts = np.concatenate([frames[:, :3, 3], tool[None, :3, 3]])
    R = float(np.linalg.norm(np.diff(pts, axis=0), axis=-1).sum())
    axes = [np.linspace(pts[0, i] - R, pts[0, i] + R, 15) for i in range(3)]
    nodes = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], axis=-1)
    nb = ws.node_neighbours(nodes)
    for rpy in ((0.0, 0.0, 0.0), (math.pi, 0.0, 0.0)):
        T = ws.target_poses(nodes, rpy, "standard")
        on = map_search(robot, T, nb)
        off = map_search(robot, T, nb, limit_bound=False)
        np.testing.assert_array_equal(on.success, off.success)
        np.testing.assert_array_equal(on.q[on.success], off.q[off.success])
        assert on.success.sum() > 50
        assert on.iterations.sum() <= off.iterations.sum()
