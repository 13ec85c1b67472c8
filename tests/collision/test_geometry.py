"""Collision geometry read from URDF <collision> elements: shapes, meshes, frames, bad files."""

import numpy as np
import pytest
import trimesh

from wsmap.collision import CollisionError, body_frames, capsules_along_links, from_urdf_collision
from wsmap.collision.checks import bounding_spheres
from wsmap.kinematics.urdf import from_urdf

URDF = """<robot name="two">
  <link name="base"><collision><origin xyz="0 0 0.05"/><geometry><cylinder radius="0.1" length="0.1"/></geometry></collision></link>
  <link name="upper"><collision><origin xyz="0.2 0 0" rpy="0 1.5707963 0"/><geometry><capsule radius="0.04" length="0.3"/></geometry></collision></link>
  <link name="fore"><collision><origin xyz="0.15 0 0"/><geometry><box size="0.3 0.05 0.05"/></geometry></collision></link>
  <link name="flange"/>
  <link name="hand"><collision><geometry>{HAND}</geometry></collision></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="upper"/><origin xyz="0 0 0.1" rpy="1.5707963 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="upper"/><child link="fore"/><origin xyz="0.4 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="f" type="fixed"><parent link="fore"/><child link="flange"/><origin xyz="0.3 0 0" rpy="0 0 0.3"/></joint>
  <joint name="h" type="fixed"><parent link="flange"/><child link="hand"/><origin xyz="0.02 0 0"/></joint>
</robot>"""


def write(tmp_path, hand='<sphere radius="0.03"/>', name="arm.urdf"):
    p = tmp_path / name
    p.write_text(URDF.replace("{HAND}", hand))
    return p


def test_links_ride_on_their_bodies_and_fixed_children_on_their_parents(tmp_path):
    m = from_urdf_collision(write(tmp_path), ee_link="flange")
    assert m.names == ("base", "upper", "fore", "hand")
    assert [lk.body for lk in m.links] == [0, 1, 2, 2]
    assert [lk.parent for lk in m.links] == [None, "base", "upper", "fore"]
    assert [s.kind for lk in m.links for s in lk.shapes] == ["cylinder", "capsule", "box", "sphere"]
    # the hand's frame is the flange's (fixed joint) plus 2 cm: compare with the chain's FK
    # the chain as the kinematics reads it (yourdfpy knows no <capsule>: a cylinder there)
    chain = from_urdf(write(tmp_path).read_text().replace("capsule", "cylinder"), ee_link="flange")
    q = np.random.default_rng(0).uniform(-2, 2, (5, 2))
    poses, link_of = m.shape_poses(q)
    hand = poses[:, list(link_of).index(3)]
    flange = chain.fkine(q)
    offset = np.eye(4)
    offset[0, 3] = 0.02
    np.testing.assert_allclose(hand, flange @ offset, atol=1e-12)


def test_body_frames_end_where_the_chain_ends():
    from wsmap import load

    for name in ("panda", "ur5e", "iiwa14"):
        chain = load(name)
        q = chain.random_q(4, np.random.default_rng(1))
        B = body_frames(chain, q)
        np.testing.assert_allclose(B[:, -1] @ chain.fixed[-1], chain.fkine(q), atol=1e-12)
        np.testing.assert_allclose(B[:, :-1] @ chain.fixed[:-1], chain.joint_frames(q)[0], atol=1e-12)


def test_meshes_are_read_through_trimesh_stl_obj_ply_dae(tmp_path):
    box = trimesh.creation.box((0.1, 0.2, 0.3))
    for ext in ("stl", "obj", "ply", "dae"):
        box.export(tmp_path / f"hand.{ext}")
        m = from_urdf_collision(write(tmp_path, f'<mesh filename="hand.{ext}" scale="2 1 1"/>'), ee_link="flange")
        v = m.links[-1].shapes[0].vertices
        np.testing.assert_allclose(v.max(axis=0) - v.min(axis=0), [0.2, 0.2, 0.3], atol=1e-6)


def test_package_urls_resolve_beside_the_urdf(tmp_path):
    (tmp_path / "meshes").mkdir()
    trimesh.creation.box((0.1, 0.1, 0.1)).export(tmp_path / "meshes" / "h.stl")
    m = from_urdf_collision(write(tmp_path, '<mesh filename="package://mypkg/meshes/h.stl"/>'), ee_link="flange")
    assert m.links[-1].shapes[0].source.endswith("h.stl")


@pytest.mark.parametrize("content, message", [
    (None, "no such file"),
    (b"", "is empty"),
    (b"this is not a mesh at all\n", "not a mesh"),
])
def test_bad_mesh_files_are_one_line_errors_naming_the_file(tmp_path, content, message):
    if content is not None:
        (tmp_path / "hand.stl").write_bytes(content)
    with pytest.raises(CollisionError, match=message) as e:
        from_urdf_collision(write(tmp_path, '<mesh filename="hand.stl"/>'), ee_link="flange")
    assert "hand.stl" in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize("hand, message", [
    ('<cone radius="1"/>', "unknown shape <cone>"),
    ('<sphere radius="nan"/>', "NaN"),
    ('<box size="1 -1 1"/>', "positive"),
    ('<cylinder radius="0.1"/>', "length"),
])
def test_bad_primitives_are_errors(tmp_path, hand, message):
    with pytest.raises(CollisionError, match=message):
        from_urdf_collision(write(tmp_path, hand), ee_link="flange")


def test_capsules_along_dh_links_cover_the_links():
    from wsmap.robots import puma560

    m = capsules_along_links(puma560(), 0.05)
    assert m.chain.n == 6 and {lk.body for lk in m.links} == set(range(7))
    with pytest.raises(CollisionError, match="positive"):
        capsules_along_links(puma560(), -0.1)


@pytest.mark.parametrize("shape", ["box", "cylinder", "capsule", "sphere", "mesh"])
def test_bounding_spheres_contain_the_shape(shape):
    from wsmap.collision import Shape

    if shape == "mesh":
        mesh = trimesh.creation.icosphere(2, 0.1)
        mesh.vertices *= [3.0, 1.0, 0.5]
        s = Shape("mesh", (), np.eye(4), mesh.vertices, mesh.faces)
        pts = trimesh.sample.volume_mesh(mesh, 5000)
        pts = np.concatenate([pts, mesh.vertices])
    else:
        size = {"box": (0.5, 0.1, 0.2), "cylinder": (0.05, 0.4), "capsule": (0.05, 0.4), "sphere": (0.1,)}[shape]
        s = Shape(shape, size, np.eye(4))
        tm = {"box": lambda: trimesh.creation.box(size), "cylinder": lambda: trimesh.creation.cylinder(*size),
              "capsule": lambda: trimesh.creation.capsule(size[1], size[0]),
              "sphere": lambda: trimesh.creation.icosphere(3, size[0])}[shape]()
        pts = np.concatenate([trimesh.sample.volume_mesh(tm, 5000), tm.vertices * (1 - 1e-9)])
    c, r = bounding_spheres(s)
    inside = (np.linalg.norm(pts[:, None] - c[None], axis=-1) <= r + 1e-9).any(axis=1)
    assert inside.all()
