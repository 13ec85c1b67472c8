"""A surface obstacle is tested on its triangles: a concave part's hollow is free (its convex hull
would fill it), a closed surface's inside is not (the winding number), and coal agrees with an
independent point-in-solid test (trimesh)."""

import numpy as np
import pytest
import trimesh

from wsmap.collision import CollisionChecker, CollisionError, Obstacle, Scene, Shape, arm_model, build_acm
from wsmap.collision.checks import coal_collide, coal_shape
from wsmap.collision.shapes.surface import SURFACE, winding_number


def _pose(xyz):
    T = np.eye(4)
    T[:3, 3] = xyz
    return T


def _bracket():
    """A U-shaped channel 0.4 m long: floor and two walls 0.3 m high, open at the top (closed solid)."""
    parts = [trimesh.creation.box((0.4, 0.4, 0.02), _pose([0, 0, 0.01])),
             trimesh.creation.box((0.4, 0.02, 0.3), _pose([0, -0.19, 0.15])),
             trimesh.creation.box((0.4, 0.02, 0.3), _pose([0, 0.19, 0.15]))]
    return trimesh.util.concatenate(parts)


def test_the_hollow_of_a_concave_part_is_free_and_its_walls_are_not():
    m = _bracket()
    surface = Shape("surface", (), np.eye(4), m.vertices, m.faces, source="bracket")
    hull = Shape("mesh", (), np.eye(4), m.vertices, m.faces, source="bracket")
    ball = coal_shape(Shape("sphere", (0.05,), np.eye(4)))
    inside_hollow, in_wall = _pose([0, 0, 0.15]), _pose([0, 0.19, 0.15])
    assert not coal_collide(ball, inside_hollow, coal_shape(surface), np.eye(4))
    assert coal_collide(ball, inside_hollow, coal_shape(hull), np.eye(4))  # the hull fills the hollow
    assert coal_collide(ball, in_wall, coal_shape(surface), np.eye(4))


def test_winding_number_agrees_with_trimesh_inside_a_closed_solid():
    m = trimesh.creation.annulus(r_min=0.1, r_max=0.3, height=0.2)  # closed and concave (a hole)
    pts = np.random.default_rng(0).uniform(-0.35, 0.35, (400, 3))
    w = winding_number(np.asarray(m.vertices), np.asarray(m.faces), pts)
    np.testing.assert_array_equal(np.abs(w) > 0.5, m.contains(pts))


def test_a_link_wholly_inside_a_closed_surface_collides_and_inside_an_open_one_does_not():
    model = arm_model("ur5e")
    model.acm = build_acm(model, samples=300)
    q = model.chain.random_q(20, np.random.default_rng(1))
    # a closed 6 m box around the whole arm: no link touches a triangle, every link is inside it;
    # at_bases checks world obstacles against every moving link (none is a default contact there)
    box = trimesh.creation.box((6, 6, 6), _pose([0, 0, 0.5]))
    room = Obstacle("room", Shape("surface", (), np.eye(4), box.vertices, box.faces), frame="world")
    assert SURFACE.closed(room.shape)
    assert not CollisionChecker(model, Scene(obstacles=(room,)), self_collision=False).at_bases(q, np.eye(4)).any()
    # the same box without its lid is a sheet, not a solid: nothing is inside it
    lid = np.asarray(box.triangles_center)[:, 2] > 3.49
    sheet = Obstacle("open", Shape("surface", (), np.eye(4), box.vertices, box.faces[~lid]), frame="world")
    assert not SURFACE.closed(sheet.shape)
    assert CollisionChecker(model, Scene(obstacles=(sheet,)), self_collision=False).at_bases(q, np.eye(4)).all()


@pytest.mark.parametrize("closed", [True, False])
def test_the_fast_layer_never_accepts_what_the_exact_check_rejects_for_a_concave_surface(closed):
    model = arm_model("panda")
    model.acm = build_acm(model, samples=300)
    m = _bracket()
    faces = m.faces if closed else m.faces[np.asarray(m.triangles_center)[:, 2] < 0.299]
    ob = Obstacle("bracket", Shape("surface", (), _pose([0.45, 0, 0.2]), m.vertices, faces), frame="world")
    assert SURFACE.closed(ob.shape) == closed
    chk = CollisionChecker(model, Scene(floor=0.0, obstacles=(ob,)))
    q = model.chain.random_q(300, np.random.default_rng(3))
    fast, exact = chk(q), chk.exact(q)
    np.testing.assert_array_equal(fast, exact)
    assert 0.05 < fast.mean() < 0.95


@pytest.mark.parametrize("vertices, faces, message", [
    (np.zeros((4, 3)), np.array([[0, 1, 2]]), "no triangle has a positive area"),
    (np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [np.nan, 0, 0]]), np.array([[0, 1, 2]]), "must be finite"),
    (np.eye(3), np.array([[0, 1, 5]]), "indices of its 3 vertices"),
])
def test_degenerate_surfaces_are_one_line_errors(vertices, faces, message):
    with pytest.raises(CollisionError, match=message):
        Shape("surface", (), np.eye(4), vertices, faces, source="part.ply")


def test_the_spheres_of_an_open_sheet_contain_every_point_of_its_triangles():
    m = _bracket()
    lid = np.asarray(m.triangles_center)[:, 2] > 0.299  # the walls' tops off: an open sheet
    sheet = Shape("surface", (), np.eye(4), m.vertices, m.faces[~lid])
    assert not SURFACE.closed(sheet)
    c, r = SURFACE.bounding_spheres(sheet, 64)
    assert 6 < len(r) <= 64
    tri = sheet.vertices[sheet.faces]
    w = np.random.default_rng(0).dirichlet(np.ones(3), (len(tri), 20))  # points on every triangle
    pts = np.einsum("tkj,tjd->tkd", w, tri).reshape(-1, 3)
    d = np.linalg.norm(pts[:, None] - c[None], axis=-1) - r
    assert (d.min(axis=1) <= 1e-12).all()
