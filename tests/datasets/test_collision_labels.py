"""Collision-aware labels of a chain family: the spec's collision field (checks, identity, files),
labels that are a subset of the chain's, positive labels with free solutions, determinism."""

import json

import numpy as np
import pytest
import yaml

from wsmap import datasets, robots
from wsmap import workspace as ws
from wsmap.collision import CollisionChecker, Scene, arm_model, build_acm
from wsmap.datasets import DatasetError, DatasetSpec, LabelCollision, labels_for, load_dataset
from wsmap.paper.specs import PANDA7_TOOLDOWN, PANDA7_TOOLDOWN_FREE, dataset_spec

#: the panda7 tool-down spec on a coarser grid (13³ nodes): the same arms, a quicker map
SMALL = PANDA7_TOOLDOWN.replace(name="p7", step=0.2, samples=3)
FREE = SMALL.replace(name="p7_free", collision={"model": "panda"})
TABLE = {"floor": True, "obstacles": [{"name": "table", "shape": "box", "size": [0.5, 1.2, 0.04],
                                       "xyz": [0.55, 0.0, 0.25]}]}


@pytest.fixture(scope="module")
def labelled():
    scales = datasets.draw_scales(FREE)
    return scales, labels_for(scales, SMALL), labels_for(scales, FREE)


def test_the_registered_spec_is_panda7_tooldown_with_collision_free_labels():
    s = dataset_spec("panda7_tooldown_free")
    assert s is PANDA7_TOOLDOWN_FREE
    assert s.replace(name="panda7_tooldown", collision=None) == PANDA7_TOOLDOWN  # the same arms, grid, orientation
    assert s.collision == LabelCollision(model="panda", acm_samples=10000, acm_seed=0)
    np.testing.assert_array_equal(datasets.draw_scales(s.replace(samples=5)),
                                  datasets.draw_scales(PANDA7_TOOLDOWN.replace(samples=5)))
    assert datasets.test_spec(s).collision == s.collision
    assert "collision" not in PANDA7_TOOLDOWN.to_dict()  # files without it keep their bytes


def test_labels_with_collision_are_a_subset_of_the_chain_labels(labelled):
    _, chain, free = labelled
    assert not (free & ~chain).any()
    lost = chain.sum(1) - free.sum(1)
    assert np.all(lost > 0.1 * chain.sum(1)) and np.all(free.sum(1) > 0.5 * chain.sum(1))


def test_every_positive_label_has_a_free_solution(labelled):
    scales, _, free = labelled
    arms = robots.family_arm("panda7", scales)
    nodes = datasets.spec_nodes(FREE)
    T = ws.target_poses(nodes, FREE.fixed, FREE.convention)
    for b in range(2):
        arm = arms[b]
        # the checker built here, by hand, from the capsule model on this arm's chain
        model = arm_model("panda", arm)
        model.acm = build_acm(model, samples=10000, seed=0)
        chk = CollisionChecker(model, Scene(floor=0.0))
        ok, q = ws.constant_orientation_map(arm, nodes, FREE.fixed, method="numerical", convention="standard",
                                            collision=chk, return_q=True)
        np.testing.assert_array_equal(ok, free[b])
        assert arm.within_limits(q[ok]).all()
        np.testing.assert_allclose(arm.fkine(q[ok]), T[ok], atol=1e-6)
        assert chk.exact(q[ok]).all()  # coal alone, every enabled pair and the floor


def test_the_capsules_follow_each_arms_scaled_links(labelled):
    scales = labelled[0]
    arms = robots.family_arm("panda7", scales)
    panda = FREE.collision.checker(robots.family_arm("panda7", np.ones(6))).model
    for b in range(len(scales)):
        model = FREE.collision.checker(arms[b]).model
        # body 0 is the base ball, body k's capsules end at the next joint (the DH d then a)
        for lk, lp in zip(model.links, panda.links):
            ends = [s.origin[:3, 3] + s.origin[:3, 2] * s.size[1] / 2 for s in lk.shapes]
            assert [s.size[0] for s in lk.shapes] == [s.size[0] for s in lp.shapes]  # the Panda's radii
            np.testing.assert_allclose(ends[-1], arms[b].fixed[lk.body, :3, 3], atol=1e-12)
        lengths = np.array([sum(s.size[1] for s in lk.shapes) for lk in model.links])
        nominal = np.array([sum(s.size[1] for s in lk.shapes) for lk in panda.links])
        assert not np.allclose(lengths, nominal)


def test_a_scene_removes_more_and_self_collision_can_be_off(labelled):
    scales, chain, free = labelled
    table = labels_for(scales[:1], SMALL.replace(collision={"model": "panda", "scene": TABLE}))
    assert not (table & ~free[:1]).any() and table.sum() < free[0].sum()
    floor_spec = SMALL.replace(collision={"model": "panda", "self_collision": False})
    floor_only = labels_for(scales[:1], floor_spec)
    assert not (free[:1] & ~floor_only).any() and not (floor_only & ~chain[:1]).any()
    chk = floor_spec.collision.checker(robots.family_arm("panda7", scales[0]))
    assert len(chk.pairs) == 0 and chk.scene.floor == 0.0 and floor_only.sum() < chain[0].sum()
    radii = labels_for(scales[:1], SMALL.replace(collision={"link_radius": 0.01, "scene": {"floor": False}}))
    assert not (radii & ~chain[:1]).any() and radii.sum() >= 0.95 * chain[0].sum()  # thin links: nearly the chain's


def test_the_collision_settings_are_part_of_the_specs_identity(tmp_path):
    specs = [SMALL, FREE, FREE.replace(collision={"model": "panda", "acm_seed": 1}),
             FREE.replace(collision={"model": "panda", "scene": TABLE}),
             FREE.replace(collision={"link_radius": 0.05}), FREE.replace(collision={"link_radius": [0.05] * 8}),
             FREE.replace(collision={"model": "panda", "self_collision": False})]
    dicts = [json.dumps(s.to_dict(), sort_keys=True) for s in specs]
    assert len(set(dicts)) == len(specs) and len({hash(s) for s in specs}) == len(specs)
    for s in specs:  # round trips through YAML, as params files and file headers hold them
        assert DatasetSpec.from_dict(yaml.safe_load(yaml.safe_dump(s.to_dict()))) == s
        assert DatasetSpec.from_dict(json.loads(json.dumps(s.to_dict()))) == s
    assert FREE.replace(collision={"model": "panda", "acm_samples": 10000.0}) == FREE
    # a file built without collision (or with other settings) is refused for the collision spec
    one = SMALL.replace(samples=1, lo=-0.4, hi=0.4)
    path = tmp_path / "chain.npz"
    datasets.build_dataset(one, path, progress=False)
    with pytest.raises(DatasetError, match=r"built for a different spec \(collision: file has None, expected \{"):
        load_dataset(path, expect_spec=one.replace(collision={"model": "panda"}))
    free_path = tmp_path / "free.npz"
    datasets.build_dataset(one.replace(collision={"model": "panda"}), free_path, progress=False)
    with pytest.raises(DatasetError, match="'acm_seed': 0.*'acm_seed': 1"):
        load_dataset(free_path, expect_spec=one.replace(collision={"model": "panda", "acm_seed": 1}))
    ds = load_dataset(free_path, expect_spec=one.replace(collision={"model": "panda"}))
    assert ds.spec.collision == FREE.collision


def test_two_builds_are_byte_identical(tmp_path):
    spec = FREE.replace(samples=2, lo=-0.6, hi=0.6)
    a, b = tmp_path / "a.npz", tmp_path / "b.npz"
    datasets.build_dataset(spec, a, progress=False)
    datasets.build_dataset(spec, b, chunk=1, progress=False)
    assert a.read_bytes() == b.read_bytes()
    ds = load_dataset(a, expect_spec=spec)
    np.testing.assert_array_equal(ds.labels, labels_for(datasets.draw_scales(spec), spec))
    assert json.loads(bytes(np.load(a)["header"]))["spec"]["collision"]["model"] == "panda"


@pytest.mark.parametrize("collision, message", [
    ({"model": "panda", "radius": 1}, r"^collision: unknown key\(s\) radius; known: model, link_radius"),
    ({}, "give model .*'panda'.* or link_radius, not neither"),
    ({"model": "panda", "link_radius": 0.05}, "not both"),
    ({"model": "ur5e"}, "model 'ur5e' is not family 'panda7''s arm, 'panda'"),
    ({"link_radius": [0.05, 0.05]}, r"one radius or one per body \(0..7: 8\), got 2"),
    ({"link_radius": -0.05}, "link_radius must be a positive number"),
    ({"link_radius": [0.05] * 7 + [float("nan")]}, r"link_radius\[7\] must be a positive number"),
    ({"model": "panda", "scene": {"obstacles": [{"shape": "mesh", "file": "a.stl"}]}}, "primitives"),
    ({"model": "panda", "scene": {"obstacles": [{"shape": "box", "size": [1, -1, 1]}]}}, "must be positive"),
    ({"model": "panda", "scene": {"walls": 1}}, "unknown keys walls"),
    ({"model": "panda", "scene": [1]}, "scene must be a mapping"),
    ({"model": "panda", "scene": {"obstacles": 5}}, "obstacles must be a list"),
    ({"model": "panda", "self_collision": "yes"}, "self_collision must be true or false"),
    ({"model": "panda", "acm_samples": -1}, "acm_samples must be a whole number of at least 0"),
    ({"model": "panda", "acm_seed": 1.5}, "acm_seed must be a whole number"),
    ("panda", "must be a mapping"),
])
def test_bad_collision_settings_are_errors_naming_the_key(collision, message):
    with pytest.raises(ValueError, match=message) as e:
        SMALL.replace(collision=collision)
    assert "\n" not in str(e.value)


def test_collision_labels_are_for_chain_families():
    with pytest.raises(ValueError, match="collision labels are for the chain families.*'spherical_wrist'"):
        DatasetSpec("sw", collision={"link_radius": 0.05})


def test_a_model_with_fixed_capsule_coordinates_is_refused_for_a_scaled_family(monkeypatch):
    import wsmap.collision.named as named

    monkeypatch.setattr(named, "ALONG_LINKS", ("iiwa14",))  # as if the Panda's capsules were fixed numbers
    with pytest.raises(ValueError, match="capsule model of 'panda' has fixed coordinates.*give link_radius"):
        SMALL.replace(collision={"model": "panda"})
