"""wsmap.workspace.reachable and the maps' numerical path for any arm (SerialChain or DHRobot)."""

import math

import numpy as np
import pytest

from wsmap import robots
from wsmap import workspace as ws
from wsmap.kinematics import as_chain, from_dh, ikine_LM, ikine_search

PI = math.pi


def planar(l1=0.7, l2=0.4, qlim=None):
    return from_dh(d=[0, 0], a=[l1, l2], alpha=[0, 0], qlim=qlim)


def test_reachable_shapes_broadcast_targets_and_arms():
    arms = robots.sample_spherical_wrist(3, seed=7)
    rng = np.random.default_rng(0)
    q = rng.uniform(-PI, PI, (5, 1, 6))
    T = arms.fkine(q)  # (5, 3, 4, 4): pose i of arm j
    assert ws.reachable(arms, T, starts=4).shape == (5, 3)
    assert ws.reachable(arms, T, starts=4).all()
    # one pose for every arm, one arm for many poses, a single pose
    assert ws.reachable(arms, T[0, 0], starts=4).shape == (3,)
    assert ws.reachable(arms[0], T[:, 0], starts=4).shape == (5,)
    out = ws.reachable(arms[0], T[0, 0], starts=4)
    assert out.shape == () and out.dtype == bool and bool(out)
    # a batch of chains: each element as if asked alone
    chains = as_chain(arms)
    far = T.copy()
    far[..., :3, 3] += 10.0  # out of reach of every arm
    both = np.concatenate([T, far], axis=0)  # (10, 3, 4, 4)
    got = ws.reachable(chains, both, starts=4)
    assert got.shape == (10, 3)
    assert got[:5].all() and not got[5:].any()
    for j in range(3):
        np.testing.assert_array_equal(ws.reachable(chains[j], both[:, j], starts=4), got[:, j])


def test_reachable_planar_annulus_and_limits():
    arm = planar()
    T = arm.fkine(np.array([[0.2, 0.5], [1.0, -2.5], [-2.0, 3.0]]))
    assert ws.reachable(arm, T).all()
    limited = planar(qlim=[[-1.0, 1.0], [-1.0, 1.0]])
    np.testing.assert_array_equal(ws.reachable(limited, T), [True, False, False])
    np.testing.assert_array_equal(ws.reachable(limited, T, joint_limits=False), [True, True, True])


def test_reachable_refuses_non_rigid_poses():
    T = np.eye(4)
    T[0, 0] = 1.5
    with pytest.raises(ValueError, match="target poses is not a rigid transform: .*orthonormal"):
        ws.reachable(planar(), T)
    with pytest.raises(ValueError, match="must have shape \\(..., 4, 4\\)"):
        ws.reachable(planar(), np.eye(3))


def test_maps_take_a_serial_chain():
    arms = robots.sample_spherical_wrist(2, seed=8)
    nodes = ws.cartesian_grid(-1, 1, 0.5)
    chain = as_chain(arms)
    exact = ws.constant_orientation_map(arms, nodes, (0.1, 0.2, 0.3), method="exact")
    num = ws.constant_orientation_map(chain, nodes, (0.1, 0.2, 0.3), method="numerical")
    assert num.shape == (2, 125)
    assert not np.any(num & ~exact) and (num == exact).mean() >= 0.99
    np.testing.assert_array_equal(num, ws.constant_orientation_map(arms, nodes, (0.1, 0.2, 0.3), method="numerical"))
    # a batch map equals one arm at a time, and small arm chunks change nothing
    for i in range(2):
        np.testing.assert_array_equal(num[i], ws.constant_orientation_map(chain[i], nodes, (0.1, 0.2, 0.3),
                                                                          method="numerical"))
    np.testing.assert_array_equal(num, ws.constant_orientation_map(chain, nodes, (0.1, 0.2, 0.3), method="numerical",
                                                                   chunk_elements=10))
    angles = ws.angle_grid(0, 2 * PI, PI / 2)
    so3 = ws.orientation_map(chain, angles, (0.3, 0.2, 0.1), method="numerical", convention="standard")
    assert so3.shape == (2, 125)
    np.testing.assert_array_equal(so3, ws.orientation_map(arms, angles, (0.3, 0.2, 0.1), convention="standard"))
    flat = ws.grid_map(chain[0], ws.grid_spec("R3", step=0.5), method="numerical",
                       ik={"solver": "independent", "starts": 8, "seed": 3})
    np.testing.assert_array_equal(flat, ikine_search(chain[0], ws.target_poses(nodes, (0, 0, 0)), starts=8,
                                                     seed=3).success)


def test_map_ik_settings_reach_the_solver():
    arm = robots.puma560(joint_limits=True)
    nodes = ws.cartesian_grid(-1, 1, 0.25)
    T = ws.target_poses(nodes, (PI, 0, 0))
    one = ws.constant_orientation_map(arm, nodes, (PI, 0, 0), method="numerical",
                                      ik={"solver": "independent", "starts": 1})
    np.testing.assert_array_equal(one, ikine_search(arm, T, starts=1).success)
    more = ws.constant_orientation_map(arm, nodes, (PI, 0, 0), method="numerical")
    assert one.sum() < more.sum()
    np.testing.assert_array_equal(more, ws.constant_orientation_map(arm, nodes, (PI, 0, 0), method="exact"))
    free = ws.constant_orientation_map(arm, nodes, (PI, 0, 0), method="numerical", ik={"joint_limits": False})
    np.testing.assert_array_equal(free, ws.constant_orientation_map(robots.puma560(), nodes, (PI, 0, 0)))


def test_paper_solver_is_the_papers_one_start_lm():
    puma = robots.puma560()
    nodes = ws.cartesian_grid(-1, 1, 0.25)
    T = ws.target_poses(nodes, (0, 0, 0))
    paper = ws.constant_orientation_map(puma, nodes, method="numerical", ik={"solver": "paper"})
    np.testing.assert_array_equal(paper, ikine_LM(puma, T).success)
    np.testing.assert_array_equal(paper, ws.constant_orientation_map(puma, nodes, method="numerical",
                                                                     ik={"solver": "paper", "starts": 1}))
    limited = robots.puma560(joint_limits=True)
    np.testing.assert_array_equal(
        ws.constant_orientation_map(limited, nodes, method="numerical", ik={"solver": "paper"}),
        ikine_LM(limited, T, check_limits=True).success)
    with pytest.raises(ValueError, match="the paper's solver has one start"):
        ws.constant_orientation_map(puma, nodes, method="numerical", ik={"solver": "paper", "starts": 4})
    with pytest.raises(ValueError, match="the paper's solver \\(ikine_LM\\) is for DHRobot arms"):
        ws.constant_orientation_map(as_chain(puma), nodes, method="numerical", ik={"solver": "paper"})
    with pytest.raises(ValueError, match="unknown solver 'magic'; choose one of search, independent, paper"):
        ws.constant_orientation_map(puma, nodes, method="numerical", ik={"solver": "magic"})


def test_exact_method_needs_the_closed_form_family():
    nodes = ws.cartesian_grid(-1, 1, 0.5)
    with pytest.raises(ValueError, match="method 'exact' has no closed form for panda"):
        ws.constant_orientation_map(robots.load("panda"), nodes, method="exact")
    with pytest.raises(TypeError, match="arms must be a DHRobot or a SerialChain"):
        ws.constant_orientation_map("puma560", nodes, method="numerical")


def test_refused_solutions_are_searched_again_from_elsewhere():
    """A predicate that refuses one elbow: the other elbow's solution exists (the closed form says
    where), and the rounds after a refused solution must find it. They started from q0 again and
    landed on the refused solution each time (34 of 187 found before)."""
    from wsmap.kinematics import closed_form_for

    arm = robots.load("ur5e")
    q = arm.random_q(400, np.random.default_rng(0))
    T = arm.fkine(q[q[:, 2] > 0.3])

    def elbow_down(qq):
        return qq[:, 2] < -0.3

    best = closed_form_for(arm).solve(arm, T)
    exists = (best.success & elbow_down(best.q.reshape(-1, 6)).reshape(best.success.shape)).any(axis=1)
    found, qf = ws.reachable(arm, T, starts=8, collision=elbow_down, return_q=True)
    assert elbow_down(qf[found]).all() and arm.within_limits(qf[found]).all()
    assert np.allclose(arm.fkine(qf[found]), T[found], atol=1e-8)
    assert (found & exists).sum() >= 0.9 * exists.sum()
