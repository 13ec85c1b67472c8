"""Obstacles that enclose the arm or touch it away from its base (issue 41): they were taken for
something the arm stands on (touching a moving link at the default configuration) and never
checked, so the arm inside a solid box was free everywhere. coal decides directly here. The UR5e's
estimated capsules (`geometry="capsules"`): their shoulder capsule reaches down to the base's foot,
so it stands on the floor and on a pedestal (the vendor hulls' shoulder, the default, does not)."""

from __future__ import annotations

import coal
import numpy as np
import pytest

from wsmap.collision import Obstacle, Scene, Shape, body_frames, checker_for
from wsmap.collision.checks import coal_shape, coal_transform


def _pose(xyz):
    T = np.eye(4)
    T[:3, 3] = xyz
    return T


def _coal_hits(chk, q, k):
    """Per configuration: does any moving link's shape intersect obstacle `k`, by coal alone."""
    model, ob = chk.model, chk.scene.obstacles[k]
    g_ob = coal_shape(ob.shape)
    B = body_frames(model.chain, q)
    out = np.zeros(len(q), dtype=bool)
    for c in range(len(q)):
        for link in model.links:
            if link.body == 0:
                continue
            for s in link.shapes:
                res = coal.CollisionResult()
                if coal.collide(coal_shape(s), coal_transform(B[c, link.body] @ s.origin), g_ob,
                                coal_transform(ob.pose(model.chain.base)), coal.CollisionRequest(), res) > 0:
                    out[c] = True
    return out


@pytest.mark.parametrize("shape", [Shape("box", (3.0, 3.0, 3.0), _pose([0, 0, 0.5])),
                                   Shape("sphere", (2.0,), _pose([0, 0, 0.5])),
                                   Shape("cylinder", (2.0, 3.0), _pose([0, 0, 0.5]))])
def test_the_arm_inside_a_solid_obstacle_collides_everywhere(shape):
    chk = checker_for("ur5e", Scene(0.0, (Obstacle("cage", shape),)), samples=200, geometry="capsules")
    q = chk.model.chain.random_q(40, np.random.default_rng(1))
    assert _coal_hits(chk, q, 0).all()  # coal: every configuration has a link inside the cage
    assert not chk(q).any() and not chk.exact(q).any()
    assert not chk.scene_allowed[:, 0].any()  # no link stands on the cage
    assert chk.scene_allowed[0, 1]  # the first link still stands on the floor


def test_an_obstacle_touching_the_arm_away_from_its_base_is_checked():
    # a ball where the flange is at the default configuration: a shelf the arm was folded against
    probe = checker_for("ur5e", Scene(0.0), samples=200, geometry="capsules")
    q0 = np.zeros((1, probe.model.chain.n))
    flange = body_frames(probe.model.chain, q0)[0, -1, :3, 3]
    chk = checker_for("ur5e", Scene(0.0, (Obstacle("shelf", Shape("sphere", (0.05,), _pose(flange))),)), samples=200, geometry="capsules")
    assert _coal_hits(chk, q0, 0)[0] and not chk(q0)[0] and not chk.scene_allowed[:, 0].any()
    q = q0 + np.random.default_rng(2).normal(scale=0.15, size=(60, q0.shape[1]))  # about the default
    hit = _coal_hits(chk, q, 0)
    assert hit.any() and not hit.all()
    assert not (chk(q) & hit).any()  # wherever coal sees the ball touched, the checker says colliding


def test_a_pedestal_under_the_base_still_carries_the_arm():
    pedestal = Obstacle("pedestal", Shape("cylinder", (0.12, 0.5), _pose([0, 0, -0.25])))
    chk = checker_for("ur5e", Scene(None, (pedestal,)), samples=200, geometry="capsules")
    q0 = np.zeros((1, chk.model.chain.n))
    assert chk.scene_allowed[:, 0].any() and chk(q0)[0]
    sunk = Obstacle("pedestal", Shape("cylinder", (0.12, 0.5), _pose([0, 0, -0.2])))  # 5 cm above the base
    assert not checker_for("ur5e", Scene(None, (sunk,)), samples=200, geometry="capsules").scene_allowed[:, 0].any()
