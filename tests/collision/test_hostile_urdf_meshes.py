"""Mesh names of a URDF that try to leave the description's tree (issue 41): `package://` names
that climb with `..`, relative names above the package, devices. Each is one line naming the URDF
and the link; the legitimate layouts (`package://`, `../meshes`) still read."""

from __future__ import annotations

import pytest
import trimesh

from wsmap.collision import CollisionError, from_urdf_collision
from wsmap.collision.shapes.mesh import resolve_mesh


def _urdf(path, filename):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(
        f'<robot name="r"><link name="b"/><link name="h"><collision><geometry><mesh filename="{filename}"/>'
        '</geometry></collision></link><joint name="j" type="revolute"><parent link="b"/><child link="h"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>')
    return path


def _box(path):
    path.parent.mkdir(parents=True, exist_ok=True)
    trimesh.creation.box((0.05, 0.05, 0.05)).export(path)
    return path


@pytest.fixture
def workspace(tmp_path):
    """src/arm_pkg/{package.xml, urdf/arm.urdf, meshes/hand.stl}, src/other_pkg/meshes/hand.stl and a
    "secret" mesh beside src/, outside every package."""
    (tmp_path / "src" / "arm_pkg").mkdir(parents=True)
    (tmp_path / "src" / "arm_pkg" / "package.xml").write_text("<package/>")
    _box(tmp_path / "src" / "arm_pkg" / "meshes" / "hand.stl")
    _box(tmp_path / "src" / "other_pkg" / "meshes" / "hand.stl")
    _box(tmp_path / "secret.stl")
    return tmp_path


@pytest.mark.parametrize("filename", [
    "package://arm_pkg/meshes/hand.stl",          # found in an ancestor folder, with the package's name
    "package://other_pkg/meshes/hand.stl",        # another package of the same workspace
    "../meshes/hand.stl",                         # the ROS layout: urdf/ beside meshes/
])
def test_the_usual_layouts_read(workspace, filename):
    urdf = _urdf(workspace / "src" / "arm_pkg" / "urdf" / "arm.urdf", filename)
    model = from_urdf_collision(urdf)
    assert model.links[-1].shapes[0].source.endswith("hand.stl")


@pytest.mark.parametrize("filename, message", [
    ("package://../../secret.stl", "mesh 'package://../../secret.stl' climbs out of its package"),
    ("package://arm_pkg/../../../secret.stl", "climbs out of its package"),
    ("package://arm_pkg//etc/passwd", "climbs out of its package"),
    ("package://", "climbs out of its package"),
    ("../../../secret.stl", "mesh '../../../secret.stl' climbs out of the description's tree"),
    ("../../other_pkg/meshes/hand.stl", "climbs out of the description's tree"),
])
def test_names_that_climb_out_are_one_line_naming_the_urdf_and_the_link(workspace, filename, message):
    urdf = _urdf(workspace / "src" / "arm_pkg" / "urdf" / "arm.urdf", filename)
    with pytest.raises(CollisionError) as e:
        from_urdf_collision(urdf)
    msg = str(e.value)
    assert msg.startswith(f"URDF file {str(urdf)!r}: link 'h' <collision>") and message in msg and "\n" not in msg


def test_without_a_package_xml_a_relative_name_may_climb_one_folder(tmp_path):
    _box(tmp_path / "robot" / "meshes" / "hand.stl")
    _box(tmp_path / "elsewhere.stl")
    assert resolve_mesh("../meshes/hand.stl", str(tmp_path / "robot" / "urdf")) == str(
        tmp_path / "robot" / "meshes" / "hand.stl")
    with pytest.raises(CollisionError, match="climbs out of the description's tree"):
        resolve_mesh("../../elsewhere.stl", str(tmp_path / "robot" / "urdf"))


@pytest.mark.parametrize("filename, message", [("file:///dev/zero", "no such file"), ("/dev/zero", "no such file")])
def test_a_device_is_never_read(tmp_path, filename, message):
    # an absolute name is the author's; a device there would be read forever: it is no file
    urdf = _urdf(tmp_path / "arm.urdf", filename)
    with pytest.raises(CollisionError, match=f"collision mesh '/dev/zero': {message}"):
        from_urdf_collision(urdf)
