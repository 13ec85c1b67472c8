"""Scene files: YAML and JSON, the floor, obstacles in the base or world frame, bad input."""

import json

import numpy as np
import pytest
import trimesh

from wsmap.collision import CollisionChecker, CollisionError, arm_model, build_acm, load_scene


def test_yaml_and_json_scenes_read_the_same(tmp_path):
    d = {"floor": True, "frame": "base", "obstacles": [
        {"name": "table", "shape": "box", "size": [1, 0.8, 0.04], "xyz": [0.6, 0, -0.02]},
        {"shape": "cylinder", "radius": 0.05, "length": 0.6, "xyz": [0.4, 0.4, 0.3], "rpy": [0, 0.5, 0]},
        {"shape": "sphere", "radius": 0.1, "xyz": [0.5, -0.3, 0.5], "frame": "world"},
        {"shape": "mesh", "file": "bowl.stl", "scale": 2.0, "xyz": [0.5, 0, 0.1]}]}
    trimesh.creation.box((0.1, 0.1, 0.1)).export(tmp_path / "bowl.stl")
    (tmp_path / "s.json").write_text(json.dumps(d))
    import yaml

    (tmp_path / "s.yaml").write_text(yaml.safe_dump(d))
    a, b = load_scene(tmp_path / "s.json"), load_scene(tmp_path / "s.yaml")
    assert a.describe() == b.describe()
    assert a.floor == 0.0 and [o.name for o in a.obstacles] == ["table", "cylinder2", "sphere3", "mesh4"]
    assert a.obstacles[2].frame == "world"
    v = a.obstacles[3].shape.vertices
    np.testing.assert_allclose(v.max(0) - v.min(0), [0.2, 0.2, 0.2])


def test_an_obstacle_in_the_base_frame_moves_with_the_base(tmp_path):
    (tmp_path / "s.yaml").write_text("obstacles:\n  - {shape: sphere, radius: 0.1, xyz: [0, -0.233, 1.15]}\n")
    model = arm_model("ur5e")
    model.acm = build_acm(model, samples=200)
    up = np.array([[0.0, -np.pi / 2, 0.0, -np.pi / 2, 0.0, 0.0]])  # the flange at (0, -0.233, 1.079) m
    assert not CollisionChecker(model, load_scene(tmp_path / "s.yaml"))(up)[0]
    base = np.eye(4)
    base[0, 3] = 1.0
    moved = arm_model("ur5e", model.chain.replace(base=base))
    moved.acm = model.acm
    assert not CollisionChecker(moved, load_scene(tmp_path / "s.yaml"))(up)[0]  # base frame: moves along
    (tmp_path / "w.yaml").write_text("frame: world\nobstacles:\n"
                                     "  - {shape: sphere, radius: 0.1, xyz: [0, -0.233, 1.15]}\n")
    assert CollisionChecker(moved, load_scene(tmp_path / "w.yaml"))(up)[0]  # world frame: stays


@pytest.mark.parametrize("text, message", [
    ("floor: [1,\n", "is not YAML or JSON"),
    ('{"obstacles": [{"shape": "cone", "radius": 1}]}', "unknown shape 'cone'"),
    ('{"obstacles": [{"shape": "box", "size": [1, NaN, 1]}]}', "NaN"),
    ("obstacles:\n  - {shape: box, size: [1, -1, 1]}\n", "must be positive"),
    ("obstacles:\n  - {shape: cylinder, radius: .nan, length: 1}\n", "NaN"),
    ("obstacles:\n  - {shape: sphere, radius: 0.1, colour: red}\n", "unknown keys colour"),
    ("walls: 2\n", "unknown keys walls"),
    ("floor: high\n", "floor must be"),
    ("obstacles:\n  - {shape: mesh, file: nothere.stl}\n", "no such file"),
    ("", "is empty"),
])
def test_bad_scene_files_are_one_line_errors_naming_the_file(tmp_path, text, message):
    p = tmp_path / "scene.yaml"
    p.write_text(text)
    with pytest.raises(CollisionError, match=message) as e:
        load_scene(p)
    assert "scene.yaml" in str(e.value) and "\n" not in str(e.value)
