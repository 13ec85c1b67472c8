"""wsmap.robots.registry and wsmap.robots.arms: one module per named arm, each registering itself.

A named arm is one module of wsmap.robots.arms named as the arm; these tests hold that layout (every
arm module registers exactly one arm, under its file name, with a source and an explicit priority;
the folder is discovered, not listed), what an arm declares in its own module (its capsule collision
model, read by wsmap.collision.named, and whether the morphology families hold it out, read by
wsmap.robots.morph), and the registry's contract for a new arm: registering a table makes load(name)
build it; a duplicate name or a table that cannot describe an arm is refused with an error naming
what is wrong.
"""

from __future__ import annotations

import importlib.util
import pkgutil
import re

import numpy as np
import pytest

from wsmap import robots
from wsmap.collision import named
from wsmap.robots import arms, registry
from wsmap.robots.morph import HELD_OUT
from wsmap.robots.registry import ArmCapsules, ArmTable

ARM_MODULES = sorted(m.name for m in pkgutil.iter_modules(arms.__path__) if not m.name.startswith("_"))

PI = np.pi


def _table(**change) -> ArmTable:
    """A valid 2-joint planar arm (standard DH: a1 = 0.4, a2 = 0.3 m), with ``change`` applied."""
    fields = dict(name="planar2", title="planar test arm", convention="standard",
                  rows=((0.0, 0.4, 0.0, 0.0), (0.0, 0.3, 0.0, 0.0)), limits=((-90, 90), None),
                  limit_unit="deg", source="this test")
    fields.update(change)
    return ArmTable(**fields)


@pytest.fixture
def registered():
    """Register tables for one test (last: priority 1000 unless given) and leave the registry as it was
    afterwards."""
    before = registry.ARMS.records()

    def register(table, priority=1000, **fields):
        return registry.register(table, priority=priority, **fields)

    yield register
    for name in set(registry.ARMS.names()) - {arm.name for arm in before}:
        registry.ARMS.unregister(name)
    assert registry.ARMS.records() == before


# ------------------------------------------------------------------------------ the layout of arms/
def test_every_arm_module_is_registered_in_the_order_of_its_priority():
    # arms/__init__.py discovers every module: a new file is a new arm, nothing else to list
    assert sorted(robots.ROBOTS) == ARM_MODULES == sorted(registry.ARMS.names())
    assert list(robots.ROBOTS) == ["puma560", "panda", "iiwa14", "ur5e", "ur10e", "gen3"]
    assert [arm.priority for arm in registry.ARMS] == [10, 20, 30, 40, 50, 60]
    assert robots.ROBOTS is registry.ROBOTS and robots.NAMED is registry.NAMED and robots.ARMS is registry.ARMS
    assert list(robots.NAMED) == [n for n in robots.ROBOTS if n != "puma560"]  # puma560 is a DHRobot
    assert list(robots.SOURCES) == list(robots.ROBOTS) and len(robots.ROBOTS) == 6
    with pytest.raises(TypeError):
        robots.ROBOTS["other"] = robots.puma560  # a view of ARMS: arms register, nobody writes here


def test_each_arm_declares_its_collision_model_and_whether_it_is_held_out():
    # read from the arms' own modules: collision.named and robots.morph keep no list of their own
    assert {arm.name: arm.capsules is not None for arm in registry.ARMS} == {
        "puma560": False, "panda": True, "iiwa14": True, "ur5e": True, "ur10e": False, "gen3": False}
    assert list(named.ARM_MODELS) == ["panda", "iiwa14", "ur5e"]
    assert named.ALONG_LINKS == ("panda", "iiwa14")  # the UR5e's capsules are fixed numbers
    assert HELD_OUT == ("puma560", "panda", "iiwa14", "ur5e", "ur10e", "gen3")
    assert all(arm.held_out for arm in registry.ARMS)


@pytest.mark.parametrize("module", ARM_MODULES)
def test_each_arm_module_registers_exactly_one_arm_named_as_its_file(module, monkeypatch):
    # run the module's code again with the registry's two entry points recording instead of registering
    calls = []
    monkeypatch.setattr(registry, "register", lambda table, *, priority, capsules=None, held_out=False: calls.append(
        ("table", table.name, table, (priority, capsules, held_out))))
    monkeypatch.setattr(registry, "register_constructor", lambda name, constructor, source, *, priority,
                        capsules=None, held_out=False: calls.append(("constructor", name, source,
                                                                     (priority, capsules, held_out))))
    spec = importlib.util.find_spec(f"wsmap.robots.arms.{module}")
    spec.loader.exec_module(importlib.util.module_from_spec(spec))  # a fresh copy, not in sys.modules
    assert [name for _, name, _, _ in calls] == [module]
    kind, _, what, fields = calls[0]
    if kind == "table":
        assert what == robots.NAMED[module] and what.source.strip()
    else:
        assert what == robots.SOURCES[module] and what.strip()
    arm = registry.ARMS.get(module)
    assert fields == (arm.priority, arm.capsules, arm.held_out)


@pytest.mark.parametrize("name", list(robots.ROBOTS))
def test_every_named_arm_has_a_source(name):
    assert robots.SOURCES[name].strip()
    arm = robots.load(name)
    if name in robots.NAMED:
        assert arm.source == robots.SOURCES[name] == robots.NAMED[name].source
        assert robots.NAMED[name].source in robots.ROBOTS[name].__doc__


# ------------------------------------------------------------------------------ registering a new arm
def test_a_registered_table_loads_by_name_and_leaves_with_the_test(registered):
    table = registered(_table())
    assert list(robots.ROBOTS)[-1] == "planar2" and robots.NAMED["planar2"] is table
    assert "planar2" not in HELD_OUT and registry.ARMS.get("planar2").capsules is None  # by default
    arm = robots.load("Planar2")  # names are looked up in lower case
    assert arm.name == "planar2" and arm.n == 2 and arm.source == "this test"
    np.testing.assert_allclose(arm.qlim, [[-PI / 2, PI / 2], [-np.inf, np.inf]])
    # by hand: a planar 2R arm, link lengths 0.4 and 0.3 m
    q = np.array([0.3, -0.5])
    x = 0.4 * np.cos(q[0]) + 0.3 * np.cos(q.sum())
    y = 0.4 * np.sin(q[0]) + 0.3 * np.sin(q.sum())
    np.testing.assert_allclose(arm.fkine(q)[:3, 3], [x, y, 0.0], atol=1e-15)
    assert robots.load("planar2", joint_limits=False).qlim is None


def test_the_test_arm_is_gone_afterwards():
    # runs after the test above: the fixture restored the registry
    assert "planar2" not in robots.ROBOTS and "planar2" not in robots.NAMED and "planar2" not in robots.SOURCES
    with pytest.raises(ValueError, match=re.escape(
            "unknown robot 'planar2'; known robots: puma560, panda, iiwa14, ur5e, ur10e, gen3")):
        robots.load("planar2")


def test_a_duplicate_name_is_refused_and_registers_nothing(registered):
    before = list(robots.ROBOTS), dict(robots.NAMED)
    with pytest.raises(ValueError, match=re.escape(
            "a robot named 'panda' is already registered; known robots: puma560, panda, iiwa14, ur5e, ur10e, gen3")):
        registered(_table(name="panda"))
    with pytest.raises(ValueError, match="a robot named 'puma560' is already registered"):
        registry.register_constructor("puma560", robots.puma560, "again", priority=5)
    assert (list(robots.ROBOTS), dict(robots.NAMED)) == before
    assert robots.load("panda").n == 7  # still Franka's
    with pytest.raises(TypeError, match=r"^register\(\) takes an ArmTable, got dict$"):
        registered({"name": "planar2"})


@pytest.mark.parametrize("change, message", [
    (dict(limits=((-90, 90),)),
     "arm table 'planar2' has 2 rows (joints) but 1 limits: give one (lo, hi) or None (continuous) per joint"),
    (dict(limits=((-90, 90), None, None)),
     "arm table 'planar2' has 2 rows (joints) but 3 limits: give one (lo, hi) or None (continuous) per joint"),
    (dict(rows=((0.0, 0.4, 0.0, 0.0), (0.0, 0.3, 0.0))),
     "arm table 'planar2': row 2 must be four finite numbers (d, a, alpha, offset), got (0.0, 0.3, 0.0)"),
    (dict(rows=((0.0, 0.4, 0.0, 0.0), (0.0, float("nan"), 0.0, 0.0))),
     "arm table 'planar2': row 2 must be four finite numbers (d, a, alpha, offset), got (0.0, nan, 0.0, 0.0)"),
    (dict(rows=()), "arm table 'planar2': rows must be a non-empty tuple of (d, a, alpha, offset), one per joint"),
    (dict(limits=((90, -90), None)),
     "arm table 'planar2': limits of joint 1 must be None (continuous) or (lo, hi) with lo < hi, got (90, -90)"),
    (dict(flange=(0.1, 0.0)),
     "arm table 'planar2': flange must be None or four finite numbers (d, a, alpha, theta), got (0.1, 0.0)"),
    (dict(convention="craig"), "arm table 'planar2': convention must be one of standard, modified, got 'craig'"),
    (dict(limit_unit="grad"), "arm table 'planar2': limit_unit must be one of deg, rad, got 'grad'"),
    (dict(source="  "), "arm table 'planar2' has no source: name the document its numbers come from"),
    (dict(name="Planar2"), "arm table name must be a non-empty lower-case word (load() looks names up in "
                           "lower case), got 'Planar2'"),
])
def test_a_table_that_cannot_be_an_arm_is_refused(change, message, registered):
    before = list(robots.ROBOTS)
    with pytest.raises(ValueError, match="^" + re.escape(message) + "$"):
        registered(_table(**change))
    assert list(robots.ROBOTS) == before


def test_a_constructor_without_a_source_is_refused(registered):
    with pytest.raises(ValueError, match=r"^robot 'other' has no source: name the document its numbers come from$"):
        registry.register_constructor("other", robots.puma560, "", priority=5)
    assert "other" not in robots.ROBOTS


def test_a_registered_arm_is_listed_by_its_priority(registered):
    registered(_table(), priority=15)
    assert list(robots.ROBOTS) == ["puma560", "planar2", "panda", "iiwa14", "ur5e", "ur10e", "gen3"]
    with pytest.raises(ValueError, match=r"^named arm 'other': priority must be an int, got '5'$"):
        registry.register_constructor("other", robots.puma560, "a source", priority="5")
    assert "other" not in robots.ROBOTS


def test_a_registered_arm_declares_its_capsules(registered):
    capsules = ArmCapsules(radii=(0.05, 0.04, 0.03), source="this test's estimates")
    registered(_table(), capsules=capsules)
    assert registry.ARMS.get("planar2").capsules is capsules
    model = named.capsules_model(capsules, robots.load("planar2"))
    assert model.floor and model.source == "this test's estimates" and len(model.links) == 3
    with pytest.raises(ValueError, match=r"^robot 'other': capsules must be an ArmCapsules or None, got tuple$"):
        registry.register_constructor("other", robots.puma560, "a source", priority=5, capsules=(0.05,))
    with pytest.raises(ValueError, match=r"^robot 'other': held_out must be True or False, got 1$"):
        registry.register_constructor("other", robots.puma560, "a source", priority=5, held_out=1)


@pytest.mark.parametrize("fields, message", [
    (dict(radii=(0.1,), source=" "), "a capsule model needs a source: name the drawing or document its numbers "
                                     "come from"),
    (dict(source="s"), "a capsule model has either radii (along the links) or capsules (fixed), not neither"),
    (dict(radii=(0.1,), capsules=((0, (0, 0, 0), (0, 0, 1), 0.1),), source="s"),
     "a capsule model has either radii (along the links) or capsules (fixed), not both"),
])
def test_capsules_that_cannot_be_a_model_are_refused(fields, message):
    with pytest.raises(ValueError, match="^" + re.escape(message) + "$"):
        ArmCapsules(**fields)


# ------------------------------------------------------------------ issue 29: inputs that built the wrong arm
def test_an_empty_dh_table_is_refused():
    with pytest.raises(ValueError, match=r"^DH columns are empty: an arm needs at least one joint"):
        robots.from_dh([], [], [])


@pytest.mark.parametrize("value", ["no", "False", 0, 1, "yes"])
def test_joint_limits_takes_only_booleans(value):
    with pytest.raises(ValueError, match=r"^joint_limits must be True, False or None \(the arm's default\), got "):
        robots.load("ur5e", joint_limits=value)
    assert robots.load("ur5e", joint_limits=np.False_).qlim is None
    assert robots.load("ur5e", joint_limits=False).qlim is None and robots.load("ur5e").qlim is not None
