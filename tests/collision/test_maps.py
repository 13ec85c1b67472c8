"""Collision-free maps: every positive node comes with a solution inside the limits, confirmed by
forward kinematics and free for the exact check; a node whose every solution collides is dropped."""

import numpy as np
import pytest

from wsmap import load, reachable
from wsmap.collision import CollisionChecker, Obstacle, Scene, Shape, arm_model, build_acm
from wsmap.kinematics import closed_form_for
from wsmap.workspace import cartesian_grid, constant_orientation_map, reachability_index, target_poses
from wsmap.workspace.orientations import orientation_samples

NODES = cartesian_grid(-1, 1, 0.2)
DOWN = (np.pi, 0.0, 0.0)


def _checker(name, **kw):
    model = arm_model(name)
    model.acm = build_acm(model, samples=1000)
    return CollisionChecker(model, **kw)


def _assert_solutions(robot, chk, ok, q, T):
    assert ok.any()
    assert np.all(np.isnan(q[~ok]))
    assert robot.within_limits(q[ok]).all()
    np.testing.assert_allclose(robot.fkine(q[ok]), T[ok], atol=1e-6)
    assert chk.exact(q[ok]).all()


def test_closed_form_keeps_a_free_branch_and_drops_nodes_whose_branches_all_collide():
    robot, chk = load("ur5e"), _checker("ur5e")
    T = target_poses(NODES, DOWN, "standard")
    chain_map = constant_orientation_map(robot, NODES, DOWN, convention="standard")
    ok, q = constant_orientation_map(robot, NODES, DOWN, convention="standard", collision=chk, return_q=True)
    _assert_solutions(robot, chk, ok, q, T)
    assert not (ok & ~chain_map).any()
    dropped = np.flatnonzero(chain_map & ~ok)
    assert dropped.size > 0
    # independently: every branch of the closed form at a dropped node collides (coal alone)
    sol = closed_form_for(robot).solve(robot, T[dropped])
    for i in range(dropped.size):
        branches = sol.q[i][sol.success[i]]
        assert branches.size and not chk.exact(branches).any()


def test_the_numerical_search_returns_free_solutions_only():
    robot = load("panda")
    scene = Scene(floor=0.0, obstacles=(Obstacle("table", Shape("box", (0.4, 1.0, 0.04), _at([0.6, 0, 0.4]))),))
    chk = _checker("panda", scene=scene)
    T = target_poses(NODES, DOWN, "standard")
    chain_map = constant_orientation_map(robot, NODES, DOWN, convention="standard")
    ok, q = constant_orientation_map(robot, NODES, DOWN, convention="standard", collision=chk, return_q=True)
    _assert_solutions(robot, chk, ok, q, T)
    assert not (ok & ~chain_map).any() and ok.sum() < chain_map.sum()


def _at(xyz):
    T = np.eye(4)
    T[:3, 3] = xyz
    return T


def test_the_search_keeps_looking_when_its_solutions_are_refused():
    # a predicate the closed form can apply to all 8 branches: the elbow on one side only. The
    # numerical search, refused its first solutions, has to find the other branch by itself.
    robot = load("ur5e")
    elbow = (lambda q: np.sin(q[:, 2]) > 0.05)
    nodes = cartesian_grid(-0.9, 0.9, 0.15)
    exact = constant_orientation_map(robot, nodes, DOWN, convention="standard", method="exact", collision=elbow)
    num, q = constant_orientation_map(robot, nodes, DOWN, convention="standard", method="numerical", collision=elbow,
                                      return_q=True)
    assert elbow(q[num]).all() and not (num & ~exact).any()
    assert num.sum() >= 0.98 * exact.sum() and exact.sum() > 100


def test_reachable_and_the_index_take_the_checker():
    robot, chk = load("panda"), _checker("panda")
    T = target_poses(NODES[::7], DOWN, "standard")
    ok, q = reachable(robot, T, collision=chk, return_q=True)
    _assert_solutions(robot, chk, ok, q, T)
    assert not (ok & ~reachable(robot, T)).any()
    R = orientation_samples(6, seed=0)
    nodes = cartesian_grid(-0.6, 0.6, 0.3)
    free, bits, qs = reachability_index(robot, nodes, R, collision=chk, return_bits=True, return_q=True)
    assert (free <= reachability_index(robot, nodes, R) + 1e-12).all()
    assert chk.exact(qs[bits]).all() and np.all(np.isnan(qs[~bits]))


def test_wrong_uses_are_refused():
    chk = _checker("ur5e")
    with pytest.raises(ValueError, match="another arm"):
        constant_orientation_map(load("ur10e"), NODES, collision=chk)
    with pytest.raises(ValueError, match="7 joints"):
        constant_orientation_map(load("ur5e"), NODES, collision=_checker("panda"))
    from wsmap.kinematics import DHRobot
    from wsmap.robots import puma560

    p = puma560()
    two = DHRobot(*(np.stack([x, x]) for x in (p.d, p.a, p.alpha)))
    with pytest.raises(ValueError, match="batch of arms"):
        constant_orientation_map(two, NODES, collision=lambda q: np.ones(len(q), bool))
    with pytest.raises(ValueError, match="paper's solver"):
        constant_orientation_map(puma560(), NODES, method="numerical", ik={"solver": "paper"},
                                 collision=lambda q: np.ones(len(q), bool))
    with pytest.raises(TypeError, match="predicate"):
        constant_orientation_map(load("ur5e"), NODES, collision="yes")


@pytest.mark.parametrize("name", ["ur5e", "panda"])
def test_base_placement_counts_collision_free_solutions(name):
    from wsmap.workspace import base_placement

    robot, chk = load(name), _checker(name)
    targets = target_poses(np.array([[0.3, 0.0, 0.05], [0.5, 0.2, 0.3], [0.2, -0.4, 0.1]]), DOWN, "standard")
    kw = dict(x=(-0.6, 0.6), y=(-0.6, 0.6), step=0.3, yaws=4)
    free = base_placement(robot, targets, collision=chk, **kw)
    chain = base_placement(robot, targets, **kw)
    assert free.score.max() <= chain.score.max() and (free.reached.sum() <= chain.reached.sum())
    got = np.isfinite(free.q[:, 0])
    assert got.sum() == free.reached[0].sum() and chk.exact(free.q[got]).all()
    np.testing.assert_allclose(free.poses[0] @ robot.fkine(free.q[got]), targets[got], atol=1e-6)


def test_base_placement_refuses_world_and_base_frame_obstacles_together():
    from wsmap.workspace import base_placement

    model = arm_model("ur5e")
    model.acm = build_acm(model, samples=200)
    both = Scene(0.0, (Obstacle("wall", Shape("box", (0.1, 2, 2), _at([1, 0, 1])), frame="world"),
                       Obstacle("post", Shape("box", (0.1, 0.1, 1), _at([0.5, 0, 0.5])), frame="base")))
    with pytest.raises(ValueError, match="world-frame or base-frame obstacles, not both"):
        base_placement(load("ur5e"), target_poses(np.array([[0.3, 0, 0.3]]), DOWN, "standard"),
                       collision=CollisionChecker(model, both))


class _SceneOnly:
    """A predicate that is no CollisionChecker but carries a world-frame scene."""

    def __init__(self, scene):
        self.scene = scene

    def __call__(self, q):
        return np.ones(len(q), dtype=bool)


def test_base_placement_refuses_world_frame_obstacles_without_a_checker():
    from wsmap.workspace import base_placement

    world = Scene(0.0, (Obstacle("wall", Shape("box", (0.1, 2, 2), _at([1, 0, 1])), frame="world"),))
    with pytest.raises(ValueError, match="give a wsmap.collision.CollisionChecker"):
        base_placement(load("ur5e"), target_poses(np.array([[0.3, 0, 0.3]]), DOWN, "standard"),
                       collision=_SceneOnly(world))


def test_the_orientation_map_and_the_index_kind_take_the_checker(tmp_path):
    from wsmap import cli
    from wsmap import workspace as ws
    from wsmap.workspace import angle_grid, orientation_map

    robot, chk = load("ur5e"), _checker("ur5e")
    angles = angle_grid(0, 2 * np.pi, np.pi / 3)
    free, q = orientation_map(robot, angles, (0.3, 0.2, 0.1), collision=chk, return_q=True)
    assert not (free & ~orientation_map(robot, angles, (0.3, 0.2, 0.1))).any() and chk.exact(q[free]).all()
    out = tmp_path / "i.npz"
    argv = ["map", "--robot", "panda", "--kind", "index", "--orientations", "6", "--step", "0.4", "--out", str(out),
            "--quiet"]
    assert cli.main(argv) == 0
    chain_index = ws.load_map(out)[0]
    assert cli.main(argv + ["--collision", "--acm-samples", "500"]) == 0
    free_index, _, _, settings = ws.load_map(out)
    assert (free_index <= chain_index + 1e-12).all() and free_index.sum() < chain_index.sum()
    assert settings["collision"]["scene"]["floor"] == 0.0
