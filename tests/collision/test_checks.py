"""The checker's guarantee (spheres never accept what coal calls colliding), coal against an
analytic distance, known folded configurations, and the allowed-collision matrix."""

import numpy as np
import pytest

from wsmap import load
from wsmap.collision import (CollisionChecker, CollisionError, Obstacle, Scene, Shape, arm_model, build_acm,
                             capsule_model)
from wsmap.collision.checks import coal_collide, coal_shape


def _segment_distance(p0, p1, q0, q1):
    """Distance between segments by dense sampling (an independent reference, ~1e-4 m)."""
    t = np.linspace(0, 1, 2001)
    a = p0 + t[:, None] * (p1 - p0)
    b = q0 + t[:, None] * (q1 - q0)
    from scipy.spatial import cKDTree

    return cKDTree(b).query(a)[0].min()


def test_coal_capsule_collision_agrees_with_the_segment_distance():
    rng = np.random.default_rng(0)
    chain = load("ur5e")
    for _ in range(200):
        p = rng.uniform(-0.3, 0.3, (4, 3))
        r = rng.uniform(0.02, 0.1, 2)
        m = capsule_model(chain, [(1, p[0], p[1], r[0]), (3, p[2], p[3], r[1])])
        s1, s2 = m.links[0].shapes[0], m.links[1].shapes[0]
        d = _segment_distance(*p) - r.sum()
        if abs(d) > 1e-3:
            assert coal_collide(coal_shape(s1), s1.origin, coal_shape(s2), s2.origin) == (d < 0)


@pytest.mark.parametrize("name", ["panda", "ur5e", "iiwa14"])
def test_the_fast_layer_never_accepts_what_the_exact_check_rejects(name):
    model = arm_model(name)
    model.acm = build_acm(model, samples=500)
    scene = Scene(floor=0.0, obstacles=(
        Obstacle("table", Shape("box", (0.6, 1.0, 0.05), _pose([0.5, 0, 0.3]))),
        Obstacle("post", Shape("cylinder", (0.05, 1.0), _pose([0.0, 0.45, 0.5]))),
        Obstacle("ball", Shape("sphere", (0.1,), _pose([-0.3, -0.3, 0.6]))),
    ))
    chk = CollisionChecker(model, scene)
    q = model.chain.random_q(1500, np.random.default_rng(2))
    fast, exact = chk(q), chk.exact(q)
    np.testing.assert_array_equal(fast, exact)  # the spheres only skip pairs that are apart
    assert 0.05 < fast.mean() < 0.95 and 0 < chk.stats.fast_fraction < 1


def _pose(xyz):
    T = np.eye(4)
    T[:3, 3] = xyz
    return T


def test_a_configuration_folded_into_itself_is_caught():
    # UR5e with the elbow folded shut: the forearm lies on the upper arm
    model = arm_model("ur5e")
    model.acm = build_acm(model, samples=500)
    chk = CollisionChecker(model, Scene())
    folded = np.array([0.0, -np.pi / 2, np.deg2rad(175), 0.0, 0.0, 0.0])
    assert not chk(folded[None])[0]
    assert ("upper_arm", "wrist_1") in chk.colliding(folded) or ("upper_arm", "wrist_2") in chk.colliding(folded)
    # stretched upright it is free; pointing into the floor it is not
    up = np.array([0.0, -np.pi / 2, 0.0, -np.pi / 2, 0.0, 0.0])
    assert chk(up[None])[0]
    floor = CollisionChecker(model)
    down = np.array([0.0, np.pi / 2, 0.0, 0.0, 0.0, 0.0])
    assert floor(up[None])[0] and not floor(down[None])[0]
    assert ("upper_arm", "floor") in floor.colliding(down) or ("forearm", "floor") in floor.colliding(down)


def test_the_matrix_disables_rigid_adjacent_default_and_never_pairs():
    model = arm_model("panda")
    acm = build_acm(model, samples=2000, seed=1, disable=[("link0", "link5")])
    d = {tuple(x[:2]): x[2] for x in acm.describe()["disabled"]}
    assert d[("link0", "link1")] == "adjacent" and d[("link1", "link3")] == "default"
    assert d[("link0", "link5")] == "user"
    assert ("link1", "link6") not in d and "never" in d.values()
    assert acm.samples == 2000 and acm.seed == 1
    # deterministic for a seed
    assert build_acm(model, samples=2000, seed=1).disabled == build_acm(model, samples=2000, seed=1).disabled


@pytest.mark.parametrize("disable, message", [
    ([("link1", "nolink")], "unknown link 'nolink'"),
    ([("link1", "link1")], "two different links"),
    (["link1"], "pairs of link names"),
])
def test_the_matrix_refuses_unknown_links(disable, message):
    with pytest.raises(CollisionError, match=message):
        build_acm(arm_model("panda"), samples=0, disable=disable)


def test_a_checker_needs_a_matrix():
    with pytest.raises(ValueError, match="no allowed-collision matrix"):
        CollisionChecker(arm_model("panda"))


def test_a_named_arm_without_a_model_is_refused():
    with pytest.raises(CollisionError, match="no collision model for robot 'puma560'"):
        arm_model("puma560")


def test_segment_distance_agrees_with_dense_sampling():
    from wsmap.collision.checks import segment_distance

    rng = np.random.default_rng(5)
    p = rng.uniform(-1, 1, (300, 4, 3))
    p[:20, 1] = p[:20, 0]  # points
    p[20:40, 3] = p[20:40, 2] + 1e-3 * (p[20:40, 1] - p[20:40, 0])  # near-parallel
    d = segment_distance(p[:, 0], p[:, 1], p[:, 2], p[:, 3])
    ref = np.array([_segment_distance(*x) for x in p])
    assert np.all(d <= ref + 1e-12) and np.all(ref - d < 2e-3)


def test_capsule_pairs_decided_in_numpy_agree_with_coal():
    from wsmap.collision import exact_pairs

    model = arm_model("panda")
    pairs = [(i, j) for i in range(8) for j in range(i + 2, 8)]
    q = model.chain.random_q(400, np.random.default_rng(9))
    ours = exact_pairs(model, pairs, q)
    chk = CollisionChecker(model, Scene(), pairs=np.array(pairs))
    from wsmap.collision import body_frames

    B = body_frames(model.chain, q)
    coal_only = np.array([[chk._pair_collides(B[c], i, j) for i, j in pairs] for c in range(len(q))])
    np.testing.assert_array_equal(ours, coal_only)
    assert ours.any()


def test_checker_for_builds_capsules_for_a_dh_arm_with_link_radii():
    from wsmap.collision import checker_for
    from wsmap.robots import puma560

    chk = checker_for(load("ur5e"), link_radius=0.05, samples=2000)
    assert chk.n == 6 and len(chk.pairs) > 0 and chk.scene.empty
    folded = np.array([[0.0, -np.pi / 2, np.deg2rad(178), 0.0, 0.0, 0.0]])  # the forearm on the upper arm
    assert not chk(folded)[0] and chk(np.array([[0.0, -np.pi / 2, 0.0, -np.pi / 2, 0.0, 0.0]]))[0]
    with pytest.raises(CollisionError, match="has no collision model"):
        checker_for(puma560())
