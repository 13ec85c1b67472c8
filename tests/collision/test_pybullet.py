"""The exact check against PyBullet on the same URDFs (pybullet_data's Panda and iiwa, with their
collision meshes): link frames, and collision yes/no for every pair the matrix does not disable
on a random sample of configurations (getClosestPoints at distance 0, DIRECT mode).

Both sides test the meshes' convex hulls. Bullet keeps a collision margin of about a millimetre
around a convex hull, so a pair closer than 2 mm (coal's own distance) may read "touching" in
PyBullet and "apart" here; every other pair must agree.
"""

import os

import numpy as np
import pytest

pybullet = pytest.importorskip("pybullet")
pybullet_data = pytest.importorskip("pybullet_data")

from wsmap.collision import CollisionChecker, Scene, body_frames, build_acm, from_urdf_collision  # noqa: E402
from wsmap.collision.checks import coal_transform  # noqa: E402

MARGIN = 2e-3  # m


def _distance(chk, B, i, j):
    import coal

    L = chk.layer
    d = np.inf
    for si in L.link_shapes[i]:
        for sj in L.link_shapes[j]:
            res = coal.DistanceResult()
            coal.distance(L.geoms[si], coal_transform(L.shape_pose(B, si)), L.geoms[sj],
                          coal_transform(L.shape_pose(B, sj)),
                          coal.DistanceRequest(), res)
            d = min(d, res.min_distance)
    return d


@pytest.mark.parametrize("urdf, ee", [("franka_panda/panda.urdf", "panda_hand"), ("kuka_iiwa/model.urdf", None)])
def test_collisions_agree_with_pybullet_on_a_random_sample(urdf, ee):
    path = os.path.join(pybullet_data.getDataPath(), urdf)
    model = from_urdf_collision(path, ee_link=ee)
    model.acm = build_acm(model, samples=1000, seed=0)
    chk = CollisionChecker(model, Scene())
    cid = pybullet.connect(pybullet.DIRECT)
    try:
        robot = pybullet.loadURDF(path, useFixedBase=True, physicsClientId=cid)
        index = {pybullet.getJointInfo(robot, j, physicsClientId=cid)[12].decode(): j
                 for j in range(pybullet.getNumJoints(robot, physicsClientId=cid))}
        index[pybullet.getBodyInfo(robot, physicsClientId=cid)[0].decode()] = -1
        movable = [j for j in range(pybullet.getNumJoints(robot, physicsClientId=cid))
                   if pybullet.getJointInfo(robot, j, physicsClientId=cid)[2] == pybullet.JOINT_REVOLUTE]
        assert len(movable) == model.chain.n
        q = model.chain.random_q(150, np.random.default_rng(7))
        fast = chk(q)
        pairs = model.acm.enabled_pairs()
        agree = near = colliding = 0
        for c in range(len(q)):
            for j, x in zip(movable, q[c]):
                pybullet.resetJointState(robot, j, x, physicsClientId=cid)
            B = body_frames(model.chain, q[c][None])[0]
            # the link frames agree (forward kinematics)
            for lk in model.links:
                if index[lk.name] >= 0:
                    st = pybullet.getLinkState(robot, index[lk.name], computeForwardKinematics=True,
                                               physicsClientId=cid)
                    np.testing.assert_allclose((B[lk.body] @ lk.frame)[:3, 3], st[4], atol=1e-6)
            mine = {tuple(sorted((model.index(a), model.index(b)))) for a, b in chk.colliding(q[c])}
            assert fast[c] == (not mine)
            for i, k in pairs:
                theirs = len(pybullet.getClosestPoints(robot, robot, 0.0, index[model.names[i]], index[model.names[k]],
                                                       physicsClientId=cid)) > 0
                colliding += (i, k) in mine
                if theirs == ((i, k) in mine):
                    agree += 1
                else:
                    d = _distance(chk, B, i, k)
                    assert abs(d) < MARGIN, (model.names[i], model.names[k], theirs, d)
                    near += 1
        total = len(q) * len(pairs)
        assert agree + near == total and near <= 0.02 * total and colliding > 0
    finally:
        pybullet.disconnect(cid)

