"""A reach study of a URDF arm with MoveIt's SRDF: the disabled pairs in the allowed-collision matrix
(the same answers as `wsmap map --srdf`), the planning group picking the chain, the floor explicit
and recorded, and every bad robot entry one line before any work."""

import re

import numpy as np
import pytest
import yaml

from wsmap import workspace as ws
from wsmap.cli import main
from wsmap.jobs.config import ConfigError
from wsmap.jobs.study import StudyJob
from wsmap.robots.sources import ArmSource
from wsmap.workspace.study import CERTIFIED, NOT_FOUND, REACHED
from wsmap.workspace.study_files import load_study

LIM = 'effort="1" velocity="1"'

#: The plate arm of tests/collision/test_srdf.py: a wide base plate, two arm links (l2 turned about y can
#: hit the plate), a tool frame and a camera frame beside the arm (so the tree branches: two leaves).
URDF = f"""<robot name="plate_arm">
  <link name="base"><collision><geometry><box size="1.2 1.2 0.1"/></geometry></collision></link>
  <link name="l1"><collision><origin xyz="0.25 0 0"/><geometry><box size="0.5 0.05 0.05"/></geometry></collision></link>
  <link name="l2"><collision><origin xyz="0.25 0 0"/><geometry><box size="0.5 0.05 0.05"/></geometry></collision></link>
  <link name="tool"/><link name="cam"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><origin xyz="0 0 0.25"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" {LIM}/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.5 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="2" {LIM}/></joint>
  <joint name="t" type="fixed"><parent link="l2"/><child link="tool"/><origin xyz="0.5 0 0"/></joint>
  <joint name="c" type="fixed"><parent link="base"/><child link="cam"/><origin xyz="0 0.5 1"/></joint>
</robot>"""

SRDF = """<?xml version="1.0"?>
<robot name="plate_arm">
  <group name="arm"><chain base_link="base" tip_link="tool"/></group>
  <group name="camera"><link name="cam"/></group>
  <end_effector name="probe" parent_link="tool" group="camera" parent_group="arm"/>
  <disable_collisions link1="base" link2="l2" reason="User"/>
  <disable_collisions link1="cam" link2="l2" reason="Never"/>
</robot>"""


#: The map of the plate arm's tool pointing along -z (R = Ry(pi/2)): its one reachable pose, q = (0, pi/2),
#: puts the tool at (0.5, 0, -0.25) and link l2 through the base plate (tests/collision/test_srdf.py).
MAP = ["map", "--urdf", "a.urdf", "--step", "0.25", "--acm-samples", "200", "--quiet", "--rpy", "0", "pi/2", "0",
       "--convention", "standard", "--collision"]
BELOW = (0.5, 0.0, -0.25)


@pytest.fixture
def cell(tmp_path):
    (tmp_path / "a.urdf").write_text(URDF)
    (tmp_path / "a.srdf").write_text(SRDF)
    return tmp_path


def _study(cell, robot, collision=None, name="s", poses="t.csv"):
    d = {"robot": robot, "targets": {"poses": poses}, "scores": ["joint_margin"],
         "collision": {"acm_samples": 200, **(collision or {})}, "search": {"method": "numerical", "starts": 8},
         "outputs": {"study": f"{name}.npz"}}
    (cell / f"{name}.yaml").write_text(yaml.safe_dump(d))
    return cell / f"{name}.yaml"


def _map(cell, extra, out):
    argv = [a if a != "a.urdf" else str(cell / "a.urdf") for a in MAP]
    assert main(argv + extra + ["--out", str(cell / out)]) == 0
    return ws.load_map(cell / out)


def _targets_of_map(cell, nodes, settings):
    """Every node of the map as a study target (16-column CSV), the map's orientation and convention."""
    T = ws.target_poses(nodes, settings["rpy"], settings["convention"])
    np.savetxt(cell / "t.csv", T.reshape(len(T), 16), delimiter=",")


@pytest.mark.parametrize("srdf, floor", [(True, None), (False, None), (True, -0.2), (True, -0.3)])
def test_the_study_answers_as_the_map_with_the_srdf_and_the_floor(cell, srdf, floor):
    extra = (["--srdf", str(cell / "a.srdf")] if srdf else ["--ee", "tool"]) + (
        [] if floor is None else ["--floor", str(floor)])
    flat, nodes, grid, settings = _map(cell, extra, "m.npz")
    _targets_of_map(cell, nodes, settings)
    robot = {"urdf": "a.urdf", "srdf": "a.srdf"} if srdf else {"urdf": "a.urdf", "ee": "tool"}
    path = _study(cell, robot, {} if floor is None else {"floor": floor})
    assert main(["study", str(path), "-q"]) == 0
    study = load_study(cell / "s.npz")
    res = study.results()
    np.testing.assert_array_equal(res.status == REACHED, flat.astype(bool))  # node by node, as the map
    below = np.flatnonzero(np.all(np.isclose(nodes, BELOW), axis=1))
    # l2 passes through the plate (allowed only by the SRDF's pair) and reaches down to z = -0.25
    assert res.status[below[0]] == (REACHED if srdf and floor != -0.2 else NOT_FOUND)
    assert (res.status == CERTIFIED).sum() > 0  # the rest of the grid is mostly out of reach, proved
    arm = study.meta["settings"]["arms"][0]
    assert arm["srdf"] == (str(cell / "a.srdf") if srdf else None) and arm["ee"] == "tool"
    assert arm["floor"] == floor and settings["collision"]["floor"] == floor  # the same floor recorded by both
    assert study.meta["settings"]["collision"]["floor"] == floor


def test_the_group_picks_the_chain_and_the_floor_is_in_the_world_frame(cell):
    two = SRDF.replace('<group name="camera"><link name="cam"/></group>',
                       '<group name="half"><chain base_link="base" tip_link="l1"/></group>').replace(
        ' parent_group="arm"', '')
    (cell / "two.srdf").write_text(two)
    T = ws.target_poses(np.array([BELOW]), (0, np.pi / 2, 0), "standard")
    np.savetxt(cell / "t.csv", T.reshape(1, 16), delimiter=",")
    with pytest.raises(ConfigError, match=r"robot.srdf: SRDF '.*two.srdf' has several chain groups \(arm, half\): give "
                                          r"the group \(group\) or the end and base links \(ee, base\)"):
        StudyJob.from_file(_study(cell, {"urdf": "a.urdf", "srdf": "two.srdf"})).check()
    job = StudyJob.from_file(_study(cell, {"urdf": "a.urdf", "srdf": "two.srdf", "group": "arm"}))
    assert [(a.ee, a.base) for a in job.check().arms] == [("tool", "base")]
    assert job.run().results[0][0].status[0] == REACHED
    half = StudyJob.from_file(_study(cell, {"urdf": "a.urdf", "srdf": "two.srdf", "group": "half"}))
    assert half.check().robots[0].n == 1  # base to l1: one joint
    # the base lifted 0.1 m: l2 reaches down to z = -0.25 in the base frame, -0.15 in the world: 0.02 m
    # above a floor at world z = -0.17 (in the base frame it would cross it), below one at -0.1
    lifted = yaml.safe_load((cell / "s.yaml").read_text()) | {"base": {"pose": [0, 0, 0.1, 0, 0, 0]}}
    lifted |= {"robot": {"urdf": "a.urdf", "srdf": "a.srdf"}, "scores": ["clearance"],
               "targets": {"poses": "t.csv", "pose": [0, 0, 0.1, 0, 0, 0]}}
    results = {}
    for z in (-0.17, -0.1):
        lifted["collision"]["floor"] = z
        results[z] = StudyJob.from_dict(lifted, root=cell).run().results[0][0]
    assert results[-0.17].status[0] == REACHED and results[-0.1].status[0] == NOT_FOUND
    # REACH's clearance measures the same world floor: (0.02 / 0.025)^2, the plate's pair disabled
    assert results[-0.17].scores["clearance"][0] == pytest.approx((0.02 / 0.025) ** 2, abs=1e-4)


def test_an_srdf_without_collision_picks_the_chain_and_says_no_floor(cell):
    T = ws.target_poses(np.array([BELOW]), (0, np.pi / 2, 0), "standard")
    np.savetxt(cell / "t.csv", T.reshape(1, 16), delimiter=",")
    d = yaml.safe_load(_study(cell, {"urdf": "a.urdf", "srdf": "a.srdf"}).read_text())
    d.pop("collision")
    job = StudyJob.from_dict(d, root=cell)
    result = job.run()
    assert result.results[0][0].status[0] == REACHED  # kinematics only
    arm = result.settings["arms"][0]
    assert (arm["ee"], arm["base"], arm["floor"], arm["group"]) == ("tool", "base", None, None)
    # a Python job with the fields directly: the same chain
    direct = StudyJob(arms=(ArmSource(urdf=str(cell / "a.urdf")),), srdfs=(str(cell / "a.srdf"),),
                      targets=job.targets)
    assert direct.check().arms[0].ee == "tool"


@pytest.mark.parametrize("robot, collision, message", [
    ({"urdf": "a.urdf", "srdf": "a.srdf", "group": "wrist"}, {},
     r"robot.group: SRDF '.*a.srdf': no group 'wrist'; the groups are: arm, camera$"),
    ({"urdf": "a.urdf", "srdf": "bad.srdf"}, {},
     r"robot.srdf: SRDF file '.*bad.srdf': <disable_collisions> 1 names link 'l9', which the URDF does not have"),
    ({"urdf": "a.urdf", "srdf": "none.srdf"}, {}, r"robot.srdf: no such SRDF file: '.*none.srdf'"),
    ({"name": "ur5e", "srdf": "a.srdf"}, {},
     r"robot.srdf: MoveIt's SRDF describes a URDF arm \(urdf: FILE\); this arm is the named arm 'ur5e'"),
    ({"dh": {"d": [0, 0], "a": [0.5, 0.5], "alpha": [0, 0]}, "srdf": "a.srdf"}, {},
     r"robot.srdf: MoveIt's SRDF describes a URDF arm \(urdf: FILE\); this arm is DH columns"),
    ({"urdf": "a.urdf", "ee": "tool", "group": "arm"}, {},
     r"robot.group: 'arm' names a planning group of the arm's SRDF: give srdf: FILE"),
    ({"urdf": "a.urdf", "srdf": "a.srdf", "group": "arm", "ee": "tool", "base": "base"}, {},
     r"robot.group: the group picks the end and base links that ee and base do not give; both are given"),
    ({"urdf": "a.urdf", "srdf": "a.srdf", "group": "camera"}, {},
     r"robot.group: group 'camera' of SRDF '.*a.srdf' has no <chain> and no end effector; the groups with a "
     r"chain: arm"),
    ({"urdf": "a.urdf", "srdf": 3}, {}, r"robot.srdf: MoveIt's SRDF file of the URDF arm, got 3"),
    ({"urdf": "a.urdf", "srdf": "a.srdf"}, {"floor": "low"},
     r"collision.floor: the floor's height \(m, world frame; a finite number of magnitude at most 1000\) or "
     r"false for no floor, got 'low'"),
    ({"urdf": "a.urdf", "srdf": "a.srdf"}, {"floor": True}, r"collision.floor: .* or false for no floor, got True"),
    ({"urdf": "a.urdf", "srdf": "a.srdf"}, {"floor": 1e4}, r"collision.floor: .*, got 10000.0"),
])
def test_a_bad_robot_entry_is_one_line_before_any_work(cell, capsys, robot, collision, message):
    (cell / "bad.srdf").write_text(SRDF.replace('link2="l2" reason="User"', 'link2="l9"'))
    np.savetxt(cell / "t.csv", np.eye(4).reshape(1, 16), delimiter=",")
    path = _study(cell, robot, collision, name="bad")
    assert main(["study", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("wsmap: error: ") and err.count("\n") == 1, err
    assert re.search(message, err.strip()), err
    assert f"study file {str(path)!r}" in err
    assert not (cell / "bad.npz").exists()
    with pytest.raises(ConfigError, match=message):
        StudyJob.from_file(path).check()


def test_a_catalogue_names_the_arm_whose_srdf_is_wrong(cell, capsys):
    np.savetxt(cell / "t.csv", np.eye(4).reshape(1, 16), delimiter=",")
    path = _study(cell, None)
    d = yaml.safe_load(path.read_text())
    d.pop("robot")
    d["robots"] = ["ur5e", {"urdf": "a.urdf", "srdf": "a.srdf", "group": "hand"}]
    path.write_text(yaml.safe_dump(d))
    assert main(["study", str(path)]) == 2
    assert "robots[1].group: SRDF" in capsys.readouterr().err
