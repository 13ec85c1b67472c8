"""The compiled LM kernel against its numpy reference (wsmap.kinematics.ik.lm_reference), and the
neighbour-started map search."""

import numpy as np
import pytest

from wsmap import robots
from wsmap import workspace as ws
from wsmap.kinematics import as_chain, ikine_LM, ikine_search, ikine_spherical_wrist, lm_compiled, lm_lanes, map_search
from wsmap.kinematics.ik.lm_reference import ikine_LM_reference, ikine_search_reference
from wsmap.workspace.maps import _per_node

PI = np.pi


@pytest.fixture(autouse=True)
def _restore_threads():
    before = lm_compiled.threads()
    yield
    lm_compiled.set_threads(before)


def test_sincos_within_two_ulp_of_libm():
    rng = np.random.default_rng(0)
    x = np.concatenate([rng.uniform(-4, 4, 4000), rng.uniform(-1e5, 1e5, 2000), rng.uniform(-1e7, 1e7, 200),
                        np.arange(-8, 9) * PI / 4, [0.0, -0.0, 1e-300, 5e-324, 1e5, -1e5, 1e300]])
    got = np.array([lm_compiled._sincos(v) for v in x])
    for k, ref in enumerate((np.sin(x), np.cos(x))):
        # within 2 ulp of the result, or of 1 where the result is near zero (sin(pi): 1.2e-16)
        gap = np.maximum(np.spacing(np.abs(ref)), np.spacing(1.0) * (np.abs(x) < 1e5))
        assert (np.abs(got[:, k] - ref) <= 2 * gap).all()
    assert np.isnan([lm_compiled._sincos(v) for v in (np.nan, np.inf, -np.inf)]).all()


@pytest.mark.parametrize("kernel", lm_lanes.KERNELS)
@pytest.mark.parametrize("name, lim, rpy", [("puma560", True, (0, 0, 0)), ("ur5e", None, (PI, 0, 0)),
                                            ("panda", None, (PI, 0, 0)), ("gen3", None, (0.3, -0.2, 0.5))])
def test_compiled_search_equals_the_numpy_reference(name, lim, rpy, kernel):
    arm = robots.load(name, joint_limits=lim)
    T = ws.target_poses(ws.cartesian_grid(-1, 1, 0.25), rpy, "standard")
    with lm_lanes.use_kernel(kernel):  # the lane kernel (the default) and the scalar one
        c = ikine_search(arm, T, starts=6, seed=2)
    r = ikine_search_reference(arm, T, starts=6, seed=2)
    assert c.success.sum() > 20
    np.testing.assert_array_equal(c.success, r.success)
    np.testing.assert_array_equal(c.start, r.start)
    np.testing.assert_array_equal(c.reason, r.reason)
    both = c.success & r.success
    np.testing.assert_allclose(c.q[both], r.q[both], atol=1e-8)
    # iteration counts agree where the runs took the same path (all but rounding-chaotic failures)
    assert (c.iterations == r.iterations).mean() > 0.5
    # every success confirmed by the chain's own forward kinematics
    Tq = as_chain(arm).fkine(c.q[c.success])
    np.testing.assert_allclose(Tq, T[c.success], atol=1e-6)


@pytest.mark.parametrize("kernel", lm_lanes.KERNELS)
def test_compiled_paper_lm_equals_the_numpy_reference(kernel):
    arms = robots.sample_spherical_wrist(4, seed=5)
    T = ws.target_poses(ws.cartesian_grid(-1, 1, 0.2), (0.3, 0.2, 0.1), "paper")
    with lm_lanes.use_kernel(kernel):
        c = ikine_LM(_per_node(arms), T)
    r = ikine_LM_reference(_per_node(arms), T)
    assert c.success.sum() > 100
    np.testing.assert_array_equal(c.success, r.success)
    np.testing.assert_array_equal(c.iterations[c.success], r.iterations[r.success])
    np.testing.assert_allclose(c.q[c.success], r.q[r.success], atol=1e-9)
    # edge cases of the counting: a start already on the target, and ilimit = 0
    q = np.array([0.1, -0.4, 0.3, 0.2, 0.5, -0.1])
    Tq = arms[0].fkine(q)
    for il in (0, 5):
        with lm_lanes.use_kernel(kernel):
            a = ikine_LM(arms[0], Tq, q0=q, ilimit=il)
        b = ikine_LM_reference(arms[0], Tq, q0=q, ilimit=il)
        assert (a.success, a.iterations) == (b.success, b.iterations)


def test_results_do_not_depend_on_threads_or_chunks():
    arm = robots.load("panda")
    T = ws.target_poses(ws.cartesian_grid(-1, 1, 0.25), (PI, 0, 0), "standard")
    lm_compiled.set_threads(1)
    one = ikine_search(arm, T, starts=4)
    lm_compiled.set_threads(2)
    two = ikine_search(arm, T, starts=4, chunk=37)
    np.testing.assert_array_equal(one.success, two.success)
    np.testing.assert_array_equal(one.q, two.q)
    np.testing.assert_array_equal(one.iterations, two.iterations)


def test_node_neighbours_on_a_grid():
    nodes = ws.cartesian_grid(0, 0.4, 0.1)  # 5³
    nb = ws.node_neighbours(nodes)
    assert nb.shape == (125, 18)
    centre = 62  # (2, 2, 2)
    d = np.linalg.norm(nodes[nb[centre]] - nodes[centre], axis=1)
    np.testing.assert_allclose(d[:6], 0.1)
    np.testing.assert_allclose(d[6:], 0.1 * np.sqrt(2))
    corner = nb[0]
    assert (corner[:6] >= 0).sum() == 3 and (corner[6:] >= 0).sum() == 3  # 3 face and 3 edge neighbours
    # the same sets as the k-d tree path for any node set (a shuffled grid is no longer "a grid")
    perm = np.random.default_rng(0).permutation(125)
    tree = ws.node_neighbours(nodes[perm])
    inv = np.argsort(perm)
    for a in range(125):
        assert set(nb[a][nb[a] >= 0]) == set(perm[tree[inv[a]][tree[inv[a]] >= 0]])


@pytest.mark.parametrize("limits", [False, True])
def test_map_search_recall_against_the_closed_form(limits):
    arm = robots.puma560(joint_limits=limits)
    nodes = ws.cartesian_grid(-1, 1, 0.2)
    T = ws.target_poses(nodes, (PI, 0, 0), "standard")
    exact = ikine_spherical_wrist(arm, T).success.any(axis=-1)
    res = map_search(arm, T, ws.node_neighbours(nodes))
    assert not np.any(res.success & ~exact)  # never a false positive
    assert res.success.sum() == exact.sum()
    Tq = as_chain(arm).fkine(res.q[res.success])
    np.testing.assert_allclose(Tq, T[res.success], atol=1e-6)
    # seeds from neighbours did part of the work
    assert np.any(res.start == -2)
    # and it is the map's default numerical path
    np.testing.assert_array_equal(
        res.success, ws.constant_orientation_map(arm, nodes, (PI, 0, 0), method="numerical", convention="standard"))


def test_map_search_batches_and_determinism():
    arms = robots.sample_spherical_wrist(3, seed=4)
    nodes = ws.cartesian_grid(-1, 1, 0.25)
    T = ws.target_poses(nodes, (0.2, 0.1, 0.0), "standard")
    nb = ws.node_neighbours(nodes)
    batch = map_search(arms, T, nb)
    assert batch.success.shape == (3, len(nodes))
    for i in range(3):
        # the joint-limit bound runs for one arm only: the same nodes and solutions; without it
        # (the reference path) the same failed end points too
        one = map_search(arms[i], T, nb)
        np.testing.assert_array_equal(batch.success[i], one.success)
        np.testing.assert_array_equal(batch.q[i][one.success], one.q[one.success])
        np.testing.assert_array_equal(batch.q[i], map_search(arms[i], T, nb, limit_bound=False).q)
    exact = ikine_spherical_wrist(_per_node(arms), T).success.any(axis=-1)
    assert not np.any(batch.success & ~exact)


def test_map_search_bad_input():
    arm = robots.load("ur5e")
    T = ws.target_poses(ws.cartesian_grid(-1, 1, 0.5), (0, 0, 0), "standard")
    with pytest.raises(ValueError, match=r"neighbours must be an integer array of shape \(125, K\)"):
        map_search(arm, T, np.zeros((5, 3), dtype=int))
    with pytest.raises(ValueError, match=r"neighbours must be node indices in \[0, 125\) or -1"):
        map_search(arm, T, np.full((125, 2), 999))
    with pytest.raises(ValueError, match="retry must be an integer >= 0"):
        map_search(arm, T, ws.node_neighbours(T[:, :3, 3]), retry=-1)
    with pytest.raises(ValueError, match=r"target poses must have shape \(N, 4, 4\)"):
        map_search(arm, T[None], ws.node_neighbours(T[:, :3, 3]))


def test_holes_in_a_reachable_region_get_more_retries():
    """The iiwa14 from its URDF, tool down: three nodes near its axis at z = 0.8 m that four random
    retries missed and 64 independent starts find; the map's hole retries find them."""
    import os

    import rtbdata

    from wsmap.kinematics import ikine_search

    urdf = os.path.join(os.path.dirname(rtbdata.__file__),
                        "xacro/kuka_description/kuka_lbr_iiwa/urdf/lbr_iiwa_14_r820.urdf")
    arm = robots.from_urdf(urdf, ee_link="tool0")
    nodes = ws.cartesian_grid(-1, 1, 0.1)
    m = ws.constant_orientation_map(arm, nodes, (PI, 0, 0), convention="standard")
    layer = np.isclose(nodes[:, 2], 0.8)
    ref = ikine_search(arm, ws.target_poses(nodes[layer], (PI, 0, 0), "standard"), starts=64).success
    np.testing.assert_array_equal(m[layer], ref)
    for p in ([-0.1, -0.1, 0.8], [0.1, -0.1, 0.8], [0.1, 0.1, 0.8]):
        assert m[np.all(np.isclose(nodes, p), axis=1)].item()
    # with the holes' retries (and the border search after them) off, the first of them is missed:
    # the test can fail
    off = ws.constant_orientation_map(arm, nodes, (PI, 0, 0), convention="standard", method="numerical",
                                      ik={"hole_retry": 0, "border_starts": 0})
    assert off.sum() < m.sum()
