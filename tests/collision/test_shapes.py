"""Collision shapes as records: one `ShapeKind` per kind, in the registry of `wsmap.collision.shapes`.

Each record's spheres contain its shape, its closed-form distance to a point is coal's, and a new
kind is one record: registered, it is read from a scene, a URDF and MJCF and checked like the others.
"""

import numpy as np
import pytest

import wsmap.collision.shapes as shapes_pkg
from wsmap import load
from wsmap.collision import (SHAPE_KINDS, SHAPES, CollisionChecker, CollisionError, Shape, ShapeKind, arm_model,
                             build_acm, from_urdf_collision, scene_from_dict, shape_kind)
from wsmap.collision.checks import bounding_spheres, coal_shape
from wsmap.collision.fields import scene_vector, urdf_numbers
from wsmap.collision.shapes import mjcf_shape_kind, urdf_shape_kind

SAMPLES = {
    "box": (0.3, 0.1, 0.05),
    "cylinder": (0.05, 0.7),
    "sphere": (0.2,),
    "capsule": (0.05, 0.4),
}
#: Half the edges of the box around each sample shape (m).
HALF = {"box": np.array([0.15, 0.05, 0.025]), "cylinder": np.array([0.05, 0.05, 0.35]),
        "sphere": np.array([0.2, 0.2, 0.2]), "capsule": np.array([0.05, 0.05, 0.25])}


def _pose(xyz, rpy=(0.0, 0.0, 0.0)):
    from wsmap.kinematics.urdf import rpy_matrix

    T = np.eye(4)
    T[:3, :3] = rpy_matrix(np.asarray(rpy, dtype=np.float64))
    T[:3, 3] = xyz
    return T


def _urdf(tmp_path, hand):
    """A one-joint arm whose flange carries the shape `hand` (a `<geometry>` child)."""
    p = tmp_path / "arm.urdf"
    p.write_text(f"""<robot name="one">
  <link name="base"><collision><geometry><sphere radius="0.05"/></geometry></collision></link>
  <link name="flange"><collision><geometry>{hand}</geometry></collision></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="flange"/><origin xyz="0 0 0.1"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>""")
    return p


def _mesh_shape():
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=1, radius=0.1)
    v = np.asarray(m.vertices) * [1.0, 2.0, 0.5]
    return Shape("mesh", (), _pose([0.1, 0, 0]), v, np.asarray(m.faces), source="egg")


def test_the_registry_lists_the_kinds_by_priority_one_module_each():
    assert SHAPES == ("box", "cylinder", "sphere", "capsule", "mesh", "surface") == tuple(SHAPE_KINDS.names())
    assert [r.priority for r in SHAPE_KINDS] == sorted(r.priority for r in SHAPE_KINDS)
    modules = {type(r).__module__ for r in SHAPE_KINDS}
    assert modules == {f"{shapes_pkg.__name__}.{name}" for name in SHAPES}
    for r in SHAPE_KINDS:
        if r.name == "surface":  # a scene's (a study's workpiece): URDF and MJCF have none
            assert r.urdf_tag is None and r.mjcf_type is None
            continue
        assert r.urdf_tag == r.name and r.mjcf_type == f"mjGEOM_{r.name.upper()}"
        assert shape_kind(r.name) is r is urdf_shape_kind(r.name)
    with pytest.raises(ValueError, match="already registered"):
        SHAPE_KINDS.register(shape_kind("box"))


def test_unknown_kinds_and_bad_sizes_are_errors_listing_the_kinds():
    with pytest.raises(CollisionError, match="unknown shape 'cone'; shapes are box, cylinder, sphere, capsule, mesh, "
                                             "surface"):
        Shape("cone", (1.0,), np.eye(4))
    with pytest.raises(CollisionError, match="a box has 3 size numbers, got 2"):
        Shape("box", (1.0, 1.0), np.eye(4))
    with pytest.raises(CollisionError, match="needs positive dimensions"):
        Shape("cylinder", (0.1, 0.0), np.eye(4))
    assert Shape("capsule", (0.1, 0.0), np.eye(4)).size == (0.1, 0.0)  # a capsule of length 0 is a sphere
    with pytest.raises(CollisionError, match="4 finite vertices"):
        Shape("mesh", (), np.eye(4), np.zeros((3, 3)), np.zeros((1, 3), dtype=int))


@pytest.mark.parametrize("kind", SHAPES)
def test_the_spheres_of_every_kind_contain_the_shape(kind):
    rng = np.random.default_rng(0)
    if kind in ("mesh", "surface"):
        m = _mesh_shape()
        s = Shape(kind, (), m.origin, m.vertices, m.faces)
    else:
        s = Shape(kind, SAMPLES[kind], _pose([0.1, 0.2, 0.3], [0.3, 0.2, 0.1]))
    if kind in ("mesh", "surface"):  # points of the convex hull: convex combinations of the vertices
        w = rng.dirichlet(np.ones(len(s.vertices)) * 0.05, 4000)
        inside = np.concatenate([w @ s.vertices, s.vertices])
    else:  # points of the box around the shape that the closed-form distance calls inside, and its corners
        half = HALF[kind]
        pts = np.concatenate([rng.uniform(-half, half, (20000, 3)), half * np.array(np.meshgrid(
            [-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T])
        inside = pts[s.record.point_distance(s.size, pts) == 0]
        assert len(inside) > 5000 or (kind == "box" and len(inside) == len(pts))
    for m in (1, 3, 6):
        c, r = bounding_spheres(s, m)
        assert len(r) <= m
        d = np.linalg.norm(inside[:, None] - c[None], axis=-1) - r
        assert (d.min(axis=1) <= 1e-12).all()


@pytest.mark.parametrize("kind", ["box", "cylinder", "sphere", "capsule"])
def test_the_closed_form_distance_to_a_point_is_coals(kind):
    import coal

    from wsmap.collision.checks import coal_transform

    s = Shape(kind, SAMPLES[kind], np.eye(4))
    geom, probe = coal_shape(s), coal.Sphere(1e-4)
    pts = np.random.default_rng(1).uniform(-0.6, 0.6, (300, 3))
    d = s.record.point_distance(s.size, pts)
    pts, d = pts[d > 0.01], d[d > 0.01]
    for p, dist in zip(pts, d):
        res = coal.DistanceResult()
        coal.distance(geom, coal_transform(np.eye(4)), probe, coal_transform(_pose(p)), coal.DistanceRequest(), res)
        assert res.min_distance + 1e-4 == pytest.approx(dist, abs=1e-6)
    assert shape_kind("mesh").point_distance((), pts) is None  # a mesh: its spheres stand in


# ---------------------------------------------------------------------------- a new kind is one record
class Ellipsoid(ShapeKind):
    """An ellipsoid of semi-axes (a, b, c) along x, y, z: the whole of what a new kind needs."""

    def bounding_spheres(self, shape, max_spheres):
        return np.zeros((1, 3)), np.array([max(shape.size)])

    def coal_geometry(self, shape):
        import coal

        return coal.Ellipsoid(*shape.size)

    def from_urdf(self, el, origin, label, what, folder):
        return Shape("ellipsoid", urdf_numbers(label, f"{what} <ellipsoid radii>", el.get("radii"), 3), origin)

    def from_mjcf(self, model, geom, pose):
        return Shape("ellipsoid", tuple(model.geom_size[geom]), pose)

    def from_scene(self, item, pose, label, name, folder):
        radii = scene_vector(label, f"obstacle {name!r} radii", item.get("radii"))
        if np.any(radii <= 0):
            raise CollisionError(f"{label}: obstacle {name!r}: radii must be positive, got {item.get('radii')!r}")
        return Shape("ellipsoid", tuple(radii), pose)


@pytest.fixture
def ellipsoid():
    record = SHAPE_KINDS.register(Ellipsoid(name="ellipsoid", priority=60, size_fields=("a", "b", "c"),
                                            urdf_tag="ellipsoid", mjcf_type="mjGEOM_ELLIPSOID",
                                            scene_keys=("radii",)))
    yield record
    SHAPE_KINDS.unregister("ellipsoid")


def test_a_new_kind_is_read_from_a_scene_and_checked_like_the_others(ellipsoid):
    scene = scene_from_dict({"obstacles": [{"shape": "ellipsoid", "radii": [0.3, 0.1, 0.1], "xyz": [0.4, 0, 0.4]}]})
    assert scene.obstacles[0].shape.record is ellipsoid and scene.describe()["obstacles"][0]["size"] == [0.3, 0.1, 0.1]
    model = arm_model("ur5e")
    model.acm = build_acm(model, samples=200)
    chk = CollisionChecker(model, scene)
    q = load("ur5e").random_q(400, np.random.default_rng(2))
    free = chk(q)
    assert not free.all() and free.any()
    assert np.array_equal(free, chk.exact(q))  # the spheres never accept what coal calls colliding
    with pytest.raises(CollisionError, match="ellipsoid\\) has unknown keys size"):
        scene_from_dict({"obstacles": [{"shape": "ellipsoid", "size": [1, 1, 1]}]}, "s")


def test_a_new_kind_is_read_from_urdf_and_mjcf(ellipsoid, tmp_path):
    mujoco = pytest.importorskip("mujoco")
    m = from_urdf_collision(_urdf(tmp_path, '<ellipsoid radii="0.05 0.04 0.03"/>'), ee_link="flange")
    assert m.links[-1].shapes[0].kind == "ellipsoid" and m.links[-1].shapes[0].size == (0.05, 0.04, 0.03)
    assert mjcf_shape_kind(int(mujoco.mjtGeom.mjGEOM_ELLIPSOID)) is ellipsoid


def test_an_unregistered_kind_is_unknown_everywhere(tmp_path):
    assert "ellipsoid" not in SHAPE_KINDS
    with pytest.raises(CollisionError, match="unknown shape <ellipsoid>; shapes are box, cylinder, sphere, capsule"):
        from_urdf_collision(_urdf(tmp_path, '<ellipsoid radii="0.05 0.04 0.03"/>'), ee_link="flange")
    with pytest.raises(CollisionError, match="unknown shape 'ellipsoid'"):
        scene_from_dict({"obstacles": [{"shape": "ellipsoid", "radii": [1, 1, 1]}]})
