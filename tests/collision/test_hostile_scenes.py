"""Hostile scene files (issue 41): the scene reader is the job files' hardened one (alias bombs,
duplicate keys, deep nesting, huge files), and the sizes of a scene are bounded. Each problem is one
line naming the file, before anything is built."""

from __future__ import annotations

import json

import numpy as np
import pytest

from wsmap.collision import CollisionError, Obstacle, Scene, Shape, load_scene, scene_from_urdf

BILLION_LAUGHS = """a: &a ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]
b: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a]
c: &c [*b, *b, *b, *b, *b, *b, *b, *b, *b]
d: &d [*c, *c, *c, *c, *c, *c, *c, *c, *c]
e: &e [*d, *d, *d, *d, *d, *d, *d, *d, *d]
f: &f [*e, *e, *e, *e, *e, *e, *e, *e, *e]
g: &g [*f, *f, *f, *f, *f, *f, *f, *f, *f]
h: &h [*g, *g, *g, *g, *g, *g, *g, *g, *g]
i: &i [*h, *h, *h, *h, *h, *h, *h, *h, *h]
obstacles: *i
"""


def _one_line(exc, name):
    msg = str(exc.value)
    assert msg.startswith("scene file") and name in msg and "\n" not in msg, msg
    return msg


@pytest.mark.parametrize("name, text, message", [
    ("bomb.yaml", BILLION_LAUGHS, "YAML aliases (*name) are not allowed"),
    ("dup.yaml", "floor: true\nobstacles: []\nfloor: false\n", "line 3: duplicate key 'floor'"),
    ("dup.json", '{"floor": true, "floor": false}', "duplicate key 'floor'"),
    ("deep.yaml", "obstacles: " + "[" * 10_000 + "]" * 10_000 + "\n", "nested deeper than 32 levels"),
    ("deep.json", '{"obstacles": ' + "[" * 10_000 + "]" * 10_000 + "}", "nested deeper than 32 levels"),
    ("big.yaml", "# padding\n" * 200_000, "bytes, more than a job file holds"),
    ("int.yaml", "floor: " + "9" * 5000 + "\n", "an integer of 5000 digits"),
    ("tag.yaml", "floor: !!python/object/apply:os.system ['true']\n", "is not YAML or JSON"),
])
def test_hostile_scene_files_are_one_line_naming_the_file(tmp_path, name, text, message):
    p = tmp_path / name
    p.write_text(text)
    with pytest.raises(CollisionError) as e:
        load_scene(p)
    assert message in _one_line(e, name)


def test_json_text_in_a_yaml_file_and_yaml_syntax_errors_read_as_before(tmp_path):
    p = tmp_path / "s.yaml"
    p.write_text('{"floor": 0.1, "obstacles": [{"shape": "sphere", "radius": 0.1, "xyz": [0.5, 0, 0.5]}]}')
    scene = load_scene(p)
    assert scene.floor == 0.1 and scene.obstacles[0].shape.size == (0.1,)
    p.write_text("floor: [1,\n")
    with pytest.raises(CollisionError, match="is not YAML or JSON"):
        load_scene(p)


def test_more_obstacles_than_a_scene_holds_are_refused_before_any_is_built(tmp_path):
    p = tmp_path / "many.json"
    item = {"shape": "sphere", "radius": 0.01}
    p.write_text(json.dumps({"obstacles": [item] * 10_001}))
    with pytest.raises(CollisionError) as e:
        load_scene(p)
    assert "has 10001 obstacles, more than a scene may hold (10000)" in _one_line(e, "many.json")
    p.write_text(json.dumps({"obstacles": [item] * 10_000}))
    assert len(load_scene(p).obstacles) == 10_000
    one = Obstacle("s", Shape("sphere", (0.01,), np.eye(4)))
    with pytest.raises(CollisionError, match="a scene holds at most 10000 obstacles, got 10001"):
        Scene(None, (one,) * 10_001)


def test_a_work_cell_with_too_many_collision_elements_is_refused_before_its_meshes_are_read(tmp_path):
    col = '<collision><geometry><mesh filename="nowhere.stl"/></geometry></collision>'
    p = tmp_path / "cell.urdf"
    p.write_text(f'<robot name="c"><link name="w">{col * 10_001}</link></robot>')
    with pytest.raises(CollisionError, match=r"cell\.urdf' has 10001 <collision> elements, more than a scene may "
                                             r"hold \(10000\)"):
        scene_from_urdf(p)


@pytest.mark.parametrize("text, message", [
    ("floor: 1.0e+308\n", "floor must be true, false or a finite height in metres (at most 1000 in magnitude), "
                          "got 1e+308"),
    ("obstacles:\n  - {shape: box, size: [1, 1, 1.0e+300]}\n", "obstacle 'box1' size is beyond 1000"),
    ("obstacles:\n  - {shape: sphere, radius: 1.0e+300}\n", "obstacle 'sphere1' radius is beyond 1000"),
    ("obstacles:\n  - {shape: cylinder, radius: 0.1, length: 5000}\n", "obstacle 'cylinder1' length is beyond 1000"),
    ("obstacles:\n  - {shape: sphere, radius: 0.1, xyz: [0, 2000, 0]}\n", "obstacle 'sphere1' xyz is beyond 1000"),
    ("obstacles:\n  - {shape: box, size: {x: 1}}\n", "size must be 3 numbers, got a mapping (x)"),
    ("frame: [a, b]\n", "frame must be one of base, world, got 'a', 'b'"),
])
def test_values_beyond_a_kilometre_and_odd_values_are_sentences(tmp_path, text, message):
    p = tmp_path / "s.yaml"
    p.write_text(text)
    with pytest.raises(CollisionError) as e:
        load_scene(p)
    assert message in _one_line(e, "s.yaml")
