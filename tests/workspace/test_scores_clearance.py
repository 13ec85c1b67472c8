"""The clearance score (REACH's distance penalty) and `CollisionChecker.distance`, against coal's own
distance query on geometry built here from the model's shape sizes (the UR5e's estimated capsules:
`geometry="capsules"`, primitives coal builds from their sizes)."""

from __future__ import annotations

import coal
import numpy as np
import pytest
import trimesh

from wsmap import robots
from wsmap.collision import checker_for
from wsmap.collision.geometry import Shape, body_frames
from wsmap.collision.scene import Obstacle, Scene
from wsmap.workspace import scores as sc
from wsmap.workspace import study as st

#: UR5e upright, the wrist turned so that the last capsule points sideways, away from the others.
Q_UP = np.array([0.0, -np.pi / 2, 0.0, -np.pi / 2, 0.0, 0.0])
BALL = 0.05  # the obstacle's radius (m)


def _pose(xyz):
    T = np.eye(4)
    T[:3, 3] = xyz
    return T


def _tip(q):
    """The end capsule of the UR5e at `q`: its far end (world, m), its axis, its radius."""
    chk = checker_for("ur5e", geometry="capsules")
    link = chk.model.links[-1]
    (shape,) = link.shapes
    radius, length = shape.size
    T = body_frames(chk.model.chain, q[None])[0, link.body] @ shape.origin
    axis = T[:3, 2]
    return T[:3, 3] + axis * length / 2, axis, radius


def _checker_with_ball(centre, frame="world"):
    scene = Scene(floor=0.0, obstacles=(Obstacle("ball", Shape("sphere", (BALL,), _pose(centre)), frame=frame),))
    return checker_for("ur5e", scene, geometry="capsules")


def _ball_at_gap(gap, q=Q_UP):
    """A checker whose ball lies on the end capsule's axis, `gap` m beyond its tip."""
    tip, axis, radius = _tip(q)
    return _checker_with_ball(tip + axis * (radius + BALL + gap))


def _coal_geometry(shape):
    if shape.kind == "capsule":
        return coal.Capsule(shape.size[0], shape.size[1])
    if shape.kind == "sphere":
        return coal.Sphere(shape.size[0])
    if shape.kind == "surface":  # the triangles themselves, as coal's BVH
        bvh = coal.BVHModelOBBRSS()
        bvh.beginModel(len(shape.faces), len(shape.vertices))
        bvh.addVertices(np.ascontiguousarray(shape.vertices, dtype=np.float64))
        bvh.addTriangles(np.ascontiguousarray(shape.faces, dtype=np.int64))
        bvh.endModel()
        return bvh
    raise AssertionError(f"no test geometry for {shape.kind}")


def _coal_clearance(chk, q):
    """The brute-force clearance: coal's distance for every checked pair, no bounds, no pruning."""
    B = body_frames(chk.model.chain, q[None])[0]
    links = chk.model.links
    tf = (lambda T: coal.Transform3s(T[:3, :3].copy(), T[:3, 3].copy()))

    def dist(ga, Ta, gb, Tb):
        return coal.distance(ga, tf(Ta), gb, tf(Tb), coal.DistanceRequest(), coal.DistanceResult())

    def placed(li):
        return [(_coal_geometry(s), B[links[li].body] @ s.origin) for s in links[li].shapes]

    d = [dist(ga, Ta, gb, Tb) for i, j in chk.pairs for ga, Ta in placed(i) for gb, Tb in placed(j)]
    obs = chk.scene.obstacles
    for m, li in enumerate(chk.moving):
        for k, ob in enumerate(obs):
            if not chk.scene_allowed[m, k]:
                d += [dist(ga, Ta, _coal_geometry(ob.shape), ob.shape.origin) for ga, Ta in placed(li)]
        if not chk.scene_allowed[m, len(obs)]:
            floor = coal.Halfspace(np.array([0.0, 0.0, 1.0]), chk.scene.floor)
            d += [dist(ga, Ta, floor, np.eye(4)) for ga, Ta in placed(li)]
    return max(min(d), 0.0)


# ------------------------------------------------------------------------------------- distance
def test_a_ball_beyond_the_tool_flange_is_at_its_known_distance():
    chk = _ball_at_gap(0.01)
    d = chk.distance(Q_UP[None])
    np.testing.assert_allclose(d, [0.01], atol=1e-9)
    np.testing.assert_allclose(d, [_coal_clearance(chk, Q_UP)], atol=1e-12)
    # REACH's demo settings: (0.01 / 0.025)^2
    np.testing.assert_allclose(sc.clearance(robots.load("ur5e"), Q_UP[None], collision=chk), [0.16], atol=1e-8)


@pytest.mark.parametrize("gap", [-1e-6, -0.02])
def test_touching_or_overlapping_is_zero_clearance_and_a_zero_score(gap):
    chk = _ball_at_gap(gap)
    assert abs(_ball_at_gap(0.0).distance(Q_UP[None])[0]) < 1e-12  # touching, to rounding
    assert chk.distance(Q_UP[None]).tolist() == [0.0]
    assert not chk(Q_UP[None])[0]  # the checker calls it a collision too
    assert sc.clearance(robots.load("ur5e"), Q_UP[None], collision=chk).tolist() == [0.0]


def test_the_distance_is_coals_minimum_over_every_checked_pair():
    chk = _checker_with_ball([0.35, 0.15, 0.45])
    q = np.random.default_rng(7).uniform(-np.pi, np.pi, (60, 6))
    d = chk.distance(q)
    expected = np.array([_coal_clearance(chk, x) for x in q])
    np.testing.assert_allclose(d, expected, atol=1e-9)
    assert ((d == 0) == ~chk(q)).all()  # zero exactly where the checker finds a collision
    assert 0 < (d == 0).sum() < len(q)  # both kinds are in the sample
    capped = chk.distance(q, cap=0.05)
    np.testing.assert_allclose(capped, np.minimum(expected, 0.05), atol=1e-9)


def test_world_obstacles_are_measured_from_the_base():
    centre = np.array([0.35, 0.15, 0.45])
    base = _pose([0.3, -0.2, 0.0])
    base[:2, :2] = [[0.0, -1.0], [1.0, 0.0]]  # turned a quarter about z
    q = np.random.default_rng(8).uniform(-np.pi, np.pi, (20, 6))
    moved = _checker_with_ball(base[:3, :3] @ centre + base[:3, 3]).distance(q, base)
    np.testing.assert_allclose(moved, _checker_with_ball(centre).distance(q), atol=1e-9)
    with pytest.raises(ValueError, match="^distance with bases takes world-frame obstacles only"):
        _checker_with_ball(centre, frame="base").distance(q, base)


def test_a_concave_surface_is_measured_on_its_triangles_and_its_inside_is_zero():
    ring = trimesh.creation.annulus(r_min=0.25, r_max=0.4, height=0.1)  # a closed ring around the arm
    ring.apply_translation([0.0, 0.0, 0.5])
    scene = Scene(floor=0.0, obstacles=(Obstacle("ring", Shape("surface", (), np.eye(4), ring.vertices, ring.faces),
                                                 frame="world"),))
    chk = checker_for("ur5e", scene, geometry="capsules")
    q = np.random.default_rng(10).uniform(-np.pi, np.pi, (400, 6))
    q = q[checker_for("ur5e", geometry="capsules")(q)][:40]  # free of the floor and of each other: the ring decides
    d = chk.distance(q)
    np.testing.assert_allclose(d, [_coal_clearance(chk, x) if chk(x[None])[0] else 0.0 for x in q], atol=1e-9)
    assert ((d == 0) == ~chk(q)).all() and 5 <= (d > 0).sum() <= 35
    # a closed 6 m box around the whole arm: no triangle near any link, yet every link is inside it
    box = trimesh.creation.box((6, 6, 6))
    room = Obstacle("room", Shape("surface", (), np.eye(4), box.vertices, box.faces), frame="world")
    inside = checker_for("ur5e", Scene(obstacles=(room,)), geometry="capsules").distance(q, np.eye(4))
    assert inside.tolist() == [0.0] * len(q)


# ---------------------------------------------------------------------------------------- score
def test_the_score_follows_reachs_power_clipped_to_one():
    arm = robots.load("ur5e")
    for gap in (0.005, 0.02, 0.025, 0.1):
        chk = _ball_at_gap(gap)
        d = _coal_clearance(chk, Q_UP)  # the gap, or a nearer pair of links (0.076 m apart) past it
        assert d == pytest.approx(min(gap, 0.0759), abs=1e-3)
        expected = min(1.0, (d / sc.CLEARANCE_THRESHOLD) ** sc.CLEARANCE_EXPONENT)
        np.testing.assert_allclose(sc.clearance(arm, Q_UP[None], collision=chk), [expected], atol=1e-8)
        np.testing.assert_allclose(sc.clearance(arm, Q_UP[None], collision=chk, threshold=0.2, exponent=1),
                                   [min(1.0, d / 0.2)], atol=1e-8)
    assert sc.SCORES["clearance"].needs_collision
    assert sc.SCORES["clearance"].settings == {"threshold_m": 0.025, "exponent": 2.0}


def test_score_values_gives_the_checker_and_base_to_the_clearance_only():
    arm = robots.load("ur5e")
    chk = _ball_at_gap(0.01)
    np.testing.assert_allclose(sc.score_values("clearance", arm, Q_UP[None], collision=chk, base=np.eye(4)), [0.16],
                               atol=1e-8)
    np.testing.assert_array_equal(sc.score_values("manipulability", arm, Q_UP[None], collision=chk),
                                  sc.manipulability(arm, Q_UP[None]))
    with pytest.raises(ValueError, match="^unknown score 'reach'; known: manipulability, joint_margin, clearance$"):
        sc.score_values("reach", arm, Q_UP[None])


def test_the_score_on_a_studys_solutions():
    """The clearance of a study's reached solutions, scored as the study would (checker at the base)."""
    arm = robots.load("ur5e")
    chk = _checker_with_ball([0.35, 0.15, 0.45])
    T = arm.fkine(np.random.default_rng(9).uniform(-2, 2, (12, 6)))
    res = st.evaluate_targets(arm, T, collision=chk)
    q = res.q[res.reached]
    assert len(q) >= 3
    s = sc.score_values("clearance", arm, q, collision=chk, base=res.base)
    expected = np.array([min(1.0, (_coal_clearance(chk, x) / 0.025) ** 2) for x in q])
    np.testing.assert_allclose(s, expected, atol=1e-9)
    assert (s > 0).all()  # every reached solution is collision-free


@pytest.mark.parametrize("kw, message", [
    (dict(collision=None), "the clearance score needs the arm's collision checker"),
    (dict(collision=lambda q: np.ones(len(q), bool)), "the clearance score needs the arm's collision checker"),
    (dict(threshold=0.0), "clearance threshold must be a positive finite number, got 0.0"),
    (dict(exponent=float("nan")), "clearance exponent must be a positive finite number, got nan"),
])
def test_bad_clearance_settings_are_one_line(kw, message):
    kw = {"collision": _ball_at_gap(0.01), **kw}
    with pytest.raises(ValueError) as e:
        sc.clearance(robots.load("ur5e"), Q_UP[None], **kw)
    assert str(e.value).startswith(message) and "\n" not in str(e.value)
