"""Work-cell URDF scenes: the same obstacles as the equivalent scene file, frames against yourdfpy,
a map whose obstacles remove nodes checked with coal directly, bad cells, the command line."""

import json
import re

import numpy as np
import pytest
import trimesh

from wsmap import cli, load
from wsmap import workspace as ws
from wsmap.collision import (CollisionChecker, CollisionError, Scene, arm_model, build_acm, load_scene,
                             scene_from_dict, scene_from_urdf)
from wsmap.collision.named import default_geometry
from wsmap.kinematics.urdf import rpy_matrix
from wsmap.workspace import cartesian_grid, constant_orientation_map

DOWN = (np.pi, 0.0, 0.0)
NODES = cartesian_grid(-0.9, 0.9, 0.15)
#: where the arm stands in the cell: link ``pedestal``, at (0.1, 0.2, 0) m, turned 0.4 rad about z
MOUNT_XYZ, MOUNT_YAW = (0.1, 0.2, 0.0), 0.4

CELL = """<?xml version="1.0"?>
<robot name="cell">
  <link name="world"/>
  <link name="pedestal">
    <collision><origin xyz="0 0 -0.25"/><geometry><cylinder radius="0.12" length="0.5"/></geometry></collision>
  </link>
  <link name="table">
    <collision name="top"><origin xyz="0 0 -0.02"/><geometry><box size="0.4 0.8 0.04"/></geometry></collision>
    <collision name="leg"><origin xyz="0.15 0.35 -0.3"/><geometry><box size="0.04 0.04 0.56"/></geometry></collision>
  </link>
  <link name="post">
    <collision><origin xyz="0 0 0" rpy="1.5707963267948966 0 0"/>
      <geometry><cylinder radius="0.04" length="0.5"/></geometry></collision>
  </link>
  <link name="fixture">
    <collision><origin xyz="0 0 0.05" rpy="0 0 0.7"/><geometry><mesh filename="fixture.stl" scale="1 1 2"/></geometry>
    </collision>
  </link>
  <link name="fence">
    <collision><geometry><box size="0.05 2.0 1.0"/></geometry></collision>
  </link>
  <joint name="world_pedestal" type="fixed"><parent link="world"/><child link="pedestal"/>
    <origin xyz="0.1 0.2 0" rpy="0 0 0.4"/></joint>
  <joint name="pedestal_table" type="fixed"><parent link="pedestal"/><child link="table"/>
    <origin xyz="0.5 0 0.3"/></joint>
  <joint name="table_post" type="fixed"><parent link="table"/><child link="post"/>
    <origin xyz="-0.1 -0.2 0.25"/></joint>
  <joint name="pedestal_fixture" type="fixed"><parent link="pedestal"/><child link="fixture"/>
    <origin xyz="0.3 -0.45 0.1"/></joint>
  <joint name="world_fence" type="fixed"><parent link="world"/><child link="fence"/>
    <origin xyz="-0.55 0.2 0.5" rpy="0 0 0.1"/></joint>
</robot>
"""


def _write_cell(d, text=CELL):
    trimesh.creation.box((0.12, 0.08, 0.05)).export(d / "fixture.stl")
    (d / "cell.urdf").write_text(text)
    return d / "cell.urdf"


def _pose(xyz, rpy=(0.0, 0.0, 0.0)):
    T = np.eye(4)
    T[:3, :3] = rpy_matrix(np.asarray(rpy, dtype=np.float64))
    T[:3, 3] = xyz
    return T


def _equivalent_yaml(d):
    """The cell as a scene file, written by hand: what is below the pedestal in the arm's base
    frame (sums of the joints' and elements' offsets), the fence in the world frame."""
    scene = {"frame": "base", "obstacles": [
        {"name": "pedestal", "shape": "cylinder", "radius": 0.12, "length": 0.5, "xyz": [0, 0, -0.25]},
        {"name": "table/top", "shape": "box", "size": [0.4, 0.8, 0.04], "xyz": [0.5, 0, 0.28]},
        {"name": "table/leg", "shape": "box", "size": [0.04, 0.04, 0.56], "xyz": [0.65, 0.35, 0.0]},
        {"name": "post", "shape": "cylinder", "radius": 0.04, "length": 0.5, "xyz": [0.4, -0.2, 0.55],
         "rpy": [1.5707963267948966, 0, 0]},
        {"name": "fixture", "shape": "mesh", "file": "fixture.stl", "scale": [1, 1, 2], "xyz": [0.3, -0.45, 0.15],
         "rpy": [0, 0, 0.7]},
        {"name": "fence", "shape": "box", "size": [0.05, 2.0, 1.0], "xyz": [-0.55, 0.2, 0.5], "rpy": [0, 0, 0.1],
         "frame": "world"}]}
    (d / "cell.json").write_text(json.dumps(scene))
    return d / "cell.json"


def _mounted_panda():
    """The Panda standing on the pedestal: its chain's base is the pedestal's pose in the cell."""
    robot = load("panda")
    return robot.replace(base=_pose(MOUNT_XYZ, (0, 0, MOUNT_YAW)))


def _checker(robot, scene):
    # the geometry the command line gives a named arm (the fitted vendor capsules of the Panda)
    model = arm_model("panda", robot, geometry=default_geometry("panda", robot))
    model.acm = build_acm(model, samples=500)
    return CollisionChecker(model, scene)


def _world_poses(scene, base):
    return {o.name: o.pose(base) for o in scene.obstacles}


def test_link_frames_agree_with_yourdfpy(tmp_path):
    import yourdfpy

    path = _write_cell(tmp_path)
    urdf = yourdfpy.URDF.load(str(path), build_collision_scene_graph=False, load_meshes=False)
    mounted, world = scene_from_urdf(path, mount="pedestal"), scene_from_urdf(path)
    assert [o.name for o in world.obstacles] == ["pedestal", "table/top", "table/leg", "post", "fixture", "fence"]
    assert {o.frame for o in world.obstacles} == {"world"} and {o.frame for o in mounted.obstacles} == {"base"}
    assert world.floor is None and scene_from_urdf(path, floor=True).floor == 0.0
    T_mount = urdf.get_transform("pedestal", "world")
    for ob_w, ob_m in zip(world.obstacles, mounted.obstacles):
        link, _, cname = ob_w.name.partition("/")
        el = [c for c in urdf.link_map[link].collisions if not cname or c.name == cname][0]
        origin = np.eye(4) if el.origin is None else el.origin
        expected = urdf.get_transform(link, "world") @ origin
        np.testing.assert_allclose(ob_w.shape.origin, expected, atol=1e-12)
        np.testing.assert_allclose(T_mount @ ob_m.shape.origin, expected, atol=1e-12)
        assert ob_w.shape.kind == ob_m.shape.kind and ob_w.shape.size == ob_m.shape.size
    fixture = world.obstacles[4].shape
    v = fixture.vertices
    np.testing.assert_allclose(v.max(0) - v.min(0), [0.12, 0.08, 0.10])  # the mesh's scale 1 1 2


def test_a_cell_gives_the_map_of_the_equivalent_scene_file(tmp_path):
    path = _write_cell(tmp_path)
    robot = _mounted_panda()
    yaml_scene = load_scene(_equivalent_yaml(tmp_path))
    scenes = {"scene file": yaml_scene, "cell, mounted": load_scene(path, mount="pedestal"),
              "cell, world": load_scene(path)}
    poses = {k: _world_poses(s, robot.base) for k, s in scenes.items()}
    for k, p in poses.items():
        assert list(p) == list(poses["scene file"]), k
        for name in p:
            np.testing.assert_allclose(p[name], poses["scene file"][name], atol=1e-12, err_msg=f"{k}: {name}")
    nodes = NODES @ robot.base[:3, :3].T + robot.base[:3, 3]  # the grid around the arm, in the cell
    maps = {k: constant_orientation_map(robot, nodes, DOWN, convention="standard", collision=_checker(robot, s))
            for k, s in scenes.items()}
    assert maps["scene file"].sum() > 100
    for k, m in maps.items():
        np.testing.assert_array_equal(m, maps["scene file"], err_msg=k)


def _coal_geometry(shape):
    """coal's geometry of a shape, built here from its kind and size (a mesh: its convex hull)."""
    import coal

    k, s = shape.kind, shape.size
    if k == "box":
        return coal.Box(*s)
    if k == "cylinder":
        return coal.Cylinder(*s)
    if k == "capsule":
        return coal.Capsule(*s)
    if k == "sphere":
        return coal.Sphere(*s)
    hull = trimesh.Trimesh(shape.vertices, shape.faces).convex_hull
    pts = coal.StdVec_Vec3s()
    pts.extend([np.ascontiguousarray(p) for p in hull.vertices])
    return coal.Convex.convexHull(pts, False, None)


def _coal_hits(model, obstacles, q):
    """``(C, L, O)`` bool: moving link ``l`` touches obstacle ``o`` at configuration ``q[c]``, by
    coal directly (shape poses by the model's forward kinematics)."""
    import coal

    poses, link_of = model.shape_poses(q)
    shapes = [s for lk in model.links for s in lk.shapes]
    geoms = [_coal_geometry(s) for s in shapes]
    obs = [(_coal_geometry(o.shape), o.pose(model.chain.base)) for o in obstacles]
    tf = (lambda T: coal.Transform3s(np.ascontiguousarray(T[:3, :3]), np.ascontiguousarray(T[:3, 3])))
    out = np.zeros((len(q), len(model.links), len(obs)), dtype=bool)
    for c in range(len(q)):
        for si, g in enumerate(geoms):
            for k, (go, P) in enumerate(obs):
                res = coal.CollisionResult()
                if coal.collide(g, tf(poses[c, si]), go, tf(P), coal.CollisionRequest(), res):
                    out[c, link_of[si], k] = True
    return out


def _coal_self_hits(model, pairs, q):
    """``(C,)`` bool: some link pair of ``pairs`` (link indices) touches at ``q[c]``, by coal directly."""
    import coal

    poses, link_of = model.shape_poses(q)
    geoms = [_coal_geometry(s) for lk in model.links for s in lk.shapes]
    tf = (lambda T: coal.Transform3s(np.ascontiguousarray(T[:3, :3]), np.ascontiguousarray(T[:3, 3])))
    out = np.zeros(len(q), dtype=bool)
    for c in range(len(q)):
        for i, j in pairs:
            for a in np.flatnonzero(link_of == i):
                for b in np.flatnonzero(link_of == j):
                    if coal.collide(geoms[a], tf(poses[c, a]), geoms[b], tf(poses[c, b]), coal.CollisionRequest(),
                                    coal.CollisionResult()):
                        out[c] = True
    return out


def test_a_cell_removes_nodes_and_every_returned_solution_is_free_for_coal(tmp_path):
    path = _write_cell(tmp_path)
    robot = _mounted_panda()
    nodes = NODES @ robot.base[:3, :3].T + robot.base[:3, 3]
    scene = scene_from_urdf(path, mount="pedestal")
    chk = _checker(robot, scene)
    alone = constant_orientation_map(robot, nodes, DOWN, convention="standard", collision=_checker(robot, Scene()))
    free, q = constant_orientation_map(robot, nodes, DOWN, convention="standard", collision=chk, return_q=True)
    assert not (free & ~alone).any()
    assert alone.sum() - free.sum() >= 50  # the table, the post, the fixture and the fence take nodes
    assert np.all(np.isnan(q[~free])) and robot.within_limits(q[free]).all()
    np.testing.assert_allclose(robot.fkine(q[free]), ws.target_poses(nodes[free], DOWN, "standard"), atol=1e-6)
    # coal directly: no moving link touches an obstacle, except one it stands on at the default
    # configuration (the first link on the pedestal; the checker's rule, docs/collision.md)
    model = chk.model
    moving = np.array([lk.body > 0 for lk in model.links])
    standing = _coal_hits(model, scene.obstacles, np.zeros((1, 7)))[0]
    assert standing[moving].sum() == 1 and standing[np.flatnonzero(moving)[0], 0]  # link 1 on the pedestal
    hits = _coal_hits(model, scene.obstacles, q[free])
    assert not (hits[:, moving] & ~standing[moving]).any()
    assert not _coal_self_hits(model, chk.pairs, q[free]).any()  # and the pairs the matrix checks
    rand = robot.random_q(200, np.random.default_rng(0))  # (the helper catches what it should)
    self_hit = _coal_self_hits(model, chk.pairs, rand)
    assert self_hit.any() and np.array_equal(self_hit, ~CollisionChecker(model, Scene()).exact(rand))
    # and the chain's own solutions of the nodes the cell took did hit the cell, mostly
    _, q_alone = constant_orientation_map(robot, nodes, DOWN, convention="standard", collision=_checker(robot, Scene()),
                                          return_q=True)
    taken = np.flatnonzero(alone & ~free)
    hit = (_coal_hits(model, scene.obstacles, q_alone[taken])[:, moving] & ~standing[moving]).any(axis=(1, 2))
    assert hit.mean() > 0.9


@pytest.mark.parametrize("edit, message", [
    (lambda t: t.replace('type="fixed"><parent link="table"', 'type="revolute"><parent link="table"'),
     "joint 'table_post' is 'revolute'; a work cell is fixed links only"),
    (lambda t: t.replace("fixture.stl", "missing.stl"), "collision mesh .*missing.stl.*no such file"),
    (lambda t: re.sub(r"<collision.*?</collision>", "", t, flags=re.S), "has no <collision> elements"),
    (lambda t: t.replace('<box size="0.4 0.8 0.04"/>', '<box size="0.4 nan 0.04"/>'), "NaN"),
    (lambda t: t.replace('<box size="0.4 0.8 0.04"/>', '<box size="0.4 -0.8 0.04"/>'), "positive"),
    (lambda t: t.replace('<joint name="world_fence" type="fixed"><parent link="world"/>',
                         '<joint name="world_fence" type="fixed"><parent link="fence"/>'), "loop|root"),
    (lambda t: t.replace("<robot", "<robt").replace("</robot>", "</robt>"), "not <robot>"),
    (lambda t: t[:200], "is not XML"),
])
def test_bad_cells_are_one_line_errors_naming_the_file(tmp_path, edit, message):
    path = _write_cell(tmp_path, edit(CELL))
    with pytest.raises(CollisionError, match=message) as e:
        load_scene(path)
    assert "cell.urdf" in str(e.value) and "\n" not in str(e.value)


def test_bad_mounts_and_files(tmp_path):
    path = _write_cell(tmp_path)
    with pytest.raises(CollisionError, match="unknown mount link 'robot'; the links are: world, pedestal"):
        scene_from_urdf(path, mount="robot")
    with pytest.raises(CollisionError, match="nothere.urdf': no such file"):
        load_scene(tmp_path / "nothere.urdf")
    with pytest.raises(CollisionError, match="a mount link .* is for a work-cell URDF"):
        load_scene(_equivalent_yaml(tmp_path), mount="pedestal")
    with pytest.raises(CollisionError, match="floor must be"):
        scene_from_urdf(path, floor="low")
    assert scene_from_urdf(path, floor=-0.5).floor == -0.5
    assert scene_from_dict({"floor": True}).floor == 0.0


def test_the_command_line_reads_a_cell_by_its_suffix(tmp_path, capsys):
    path = _write_cell(tmp_path)
    out = tmp_path / "m.npz"
    common = ["--robot", "panda", "--acm-samples", "500", "--quiet"]
    assert cli.main(["map", *common, "--rpy", "pi", "0", "0", "--convention", "standard", "--step", "0.15",
                     "--lo", "-0.9", "--hi", "0.9", "--scene", str(path), "--mount", "pedestal",
                     "--out", str(out)]) == 0
    flat, nodes, _, settings = ws.load_map(out)
    col = settings["collision"]
    assert col["scene_file"] == str(path) and col["mount"] == "pedestal"
    assert [o["name"] for o in col["scene"]["obstacles"]][:2] == ["pedestal", "table/top"]
    robot = load("panda")
    expected = constant_orientation_map(robot, nodes, DOWN, convention="standard",
                                        collision=_checker(robot, scene_from_urdf(path, mount="pedestal")))
    np.testing.assert_array_equal(flat, expected)
    targets = tmp_path / "t.csv"
    targets.write_text("0.45 0.0 0.35 3.14159 0 0\n0.3 0.3 0.2 3.14159 0 0\n")
    place = ["place", *common, "--targets", str(targets), "--x", "-0.2", "0.2", "--y", "-0.2", "0.2", "--step",
             "0.2", "--yaws", "2", "--scene", str(path)]
    assert cli.main([*place, "--mount", "pedestal"]) == 0
    capsys.readouterr()
    # the cell's root as the world: its obstacles stay where they are while the candidate bases move
    # (each solution checked at its own base, CollisionChecker.at_bases)
    assert cli.main(place) == 0
    capsys.readouterr()
    assert cli.main(["map", *common, "--mount", "pedestal", "--collision", "--out", str(tmp_path / "x.npz")]) == 2
    assert "--mount names a link of a work-cell URDF" in capsys.readouterr().err
    bad = _write_cell(tmp_path, CELL.replace("fixture.stl", "gone.stl"))
    assert cli.main(["map", *common, "--scene", str(bad), "--out", str(tmp_path / "y.npz")]) == 2
    err = capsys.readouterr().err
    assert "cell.urdf" in err and "gone.stl" in err and err.count("\n") == 1 and not (tmp_path / "y.npz").exists()
