"""The border search of the map (wsmap.kinematics.ik.search.map_search, ``border_starts``): every node
that borders a solved node and that the per-pose search of ``reachable()`` reaches is in the map, by
construction. Checked on YuMi's right arm from its URDF (rtbdata), tool down, where the neighbour
waves and retries alone miss border nodes (issue 29), and against its settings' refusals."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

from wsmap import workspace as ws
from wsmap.kinematics import ikine_search, map_search
from wsmap.kinematics.ik.search import DEFAULT_STARTS, MAP_SETTINGS
from wsmap.kinematics.urdf import from_urdf

rtbdata = pytest.importorskip("rtbdata")


@pytest.fixture(scope="module")
def yumi_tool_down():
    urdf = os.path.join(os.path.dirname(rtbdata.__file__), "xacro/yumi_description/urdf/yumi.urdf")
    arm = from_urdf(urdf, base_link="yumi_body", ee_link="yumi_link_7_r")
    frames, tool = arm.joint_frames(np.zeros(arm.n))
    pts = np.concatenate([frames[:, :3, 3], tool[None, :3, 3]])
    R = float(np.linalg.norm(np.diff(pts, axis=0), axis=-1).sum())
    axes = [np.linspace(pts[0, i] - R, pts[0, i] + R, 21) for i in range(3)]
    nodes = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], axis=-1)
    return arm, nodes, ws.target_poses(nodes, (math.pi, 0.0, 0.0), "standard")


def _bordering(ok, nb):
    solved = np.where(nb >= 0, ok[np.where(nb >= 0, nb, 0)], False)
    return ~ok & solved.any(axis=1)


def test_every_border_node_that_reachable_finds_is_in_the_map(yumi_tool_down):
    arm, nodes, T = yumi_tool_down
    nb = ws.node_neighbours(nodes)
    res = map_search(arm, T, nb)
    assert res.success.sum() > 1000
    border = np.flatnonzero(_bordering(res.success, nb))
    per_pose = ikine_search(arm, T[border], starts=DEFAULT_STARTS, seed=0).success
    assert not per_pose.any(), f"{int(per_pose.sum())} border nodes reachable() finds are missing from the map"
    Tq = arm.fkine(res.q[res.success])
    np.testing.assert_allclose(Tq, T[res.success], atol=1e-6)
    assert arm.within_limits(res.q[res.success]).all()
    # without the border search the waves and retries miss border nodes that reachable() finds: the
    # test can fail; the border search only adds nodes
    before = map_search(arm, T, nb, border_starts=0)
    assert np.all(before.success <= res.success)
    missed = np.flatnonzero(res.success & ~before.success)
    assert missed.size > 0
    assert ws.reachable(arm, T[missed]).any()
    # and it is the map's default numerical path
    np.testing.assert_array_equal(
        res.success, ws.constant_orientation_map(arm, nodes, (math.pi, 0, 0), method="numerical",
                                                 convention="standard"))


def test_border_settings():
    assert MAP_SETTINGS["border_starts"] == DEFAULT_STARTS
    from wsmap import robots

    arm = robots.load("ur5e")
    nodes = ws.cartesian_grid(-1, 1, 0.5)
    T = ws.target_poses(nodes, (0, 0, 0), "standard")
    with pytest.raises(ValueError, match="border_starts must be an integer >= 0"):
        map_search(arm, T, ws.node_neighbours(nodes), border_starts=-1)
    with pytest.raises(ValueError, match="border_starts must be an integer >= 0"):
        map_search(arm, T, ws.node_neighbours(nodes), border_starts=2.5)
