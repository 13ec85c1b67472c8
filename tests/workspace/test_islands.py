"""The numerical map finds every island (issue 41 item 2): global seeding of the map search
(`wsmap.kinematics.ik.fk_seeds`, `SearchSettings.fk_seeds`) starts every node left unsolved by
the first pass from the configurations of the sampled poses nearest its own, so that a reachable
region that no solved node borders, or a whole map where `q0` solves nothing, is searched too.

Judged against the closed forms (`method="exact"`): PUMA560's geometry with joint-limit windows
that exclude `q = 0`, whose reachable set at `R = I` falls apart into separate regions (an
`scipy.ndimage.label` component that the map without seeding never touches), and the UR5e and
PUMA560 on a small grid at both orientations."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import ndimage

from wsmap import load
from wsmap import workspace as ws
from wsmap.kinematics import from_dh, map_search
from wsmap.kinematics.chain import as_chain
from wsmap.kinematics.ik.fk_seeds import halton, nearest_starts, sample_configurations, sample_count
from wsmap.kinematics.ik.settings import SearchSettings
from wsmap.robots import puma560
from wsmap.robots.arms.puma560 import ALPHA, A, D

#: Limit windows (rad) on PUMA560's DH geometry, none containing q = 0 for every joint:
#: "island": two regions at R = I (52 and 17 nodes of the 13³ grid); without seeding the map
#: finds the 52 and none of the 17. "two islands": four regions (109, 64, 2, 1), the 109 missed.
#: "q0 solves nothing": two regions (69, 34), and the map without seeding is empty.
LIMITS = {
    "island": [[-1.11, -0.06], [1.11, 4.04], [-3.58, -2.16], [-0.2, 4.25], [-1.76, 0.69], [-0.28, 4.43]],
    "two islands": [[-1.24, 2.96], [-3.87, 0.98], [-4.82, -0.95], [-6.01, -0.07], [-0.69, 4.62], [2.09, 3.1]],
    "q0 solves nothing": [[-0.64, 0.72], [-0.56, 4.53], [-4.45, 0.89], [-4.22, -1.12], [-0.96, 1.6],
                          [-3.17, -0.7]],
}
NODES = ws.cartesian_grid(-0.9, 0.9, 0.15)  # 13³
SHAPE = (13, 13, 13)


def _components(reach):
    labels, count = ndimage.label(reach.reshape(SHAPE), structure=np.ones((3, 3, 3)))
    return labels.reshape(-1), count


@pytest.mark.parametrize("case", list(LIMITS))
def test_every_island_of_a_limited_puma_is_found(case):
    arm = from_dh(d=D, a=A, alpha=ALPHA, qlim=np.array(LIMITS[case]))
    exact = ws.constant_orientation_map(arm, NODES, (0.0, 0.0, 0.0), method="exact")
    labels, count = _components(exact)
    assert count >= 2
    before = ws.constant_orientation_map(arm, NODES, (0.0, 0.0, 0.0), method="numerical", ik={"fk_seeds": 0})
    # the case is what it claims: a whole region the map without seeding never touches
    untouched = [j for j in range(1, count + 1) if not before[labels == j].any()]
    assert untouched
    if case == "q0 solves nothing":
        assert not before.any()
    after, q = ws.constant_orientation_map(arm, NODES, (0.0, 0.0, 0.0), method="numerical", return_q=True)
    np.testing.assert_array_equal(after, exact)
    T = ws.target_poses(NODES[after], (0.0, 0.0, 0.0))
    np.testing.assert_allclose(arm.fkine(q[after]), T, atol=1e-6)
    assert arm.within_limits(q[after]).all()


@pytest.mark.parametrize("name", ["ur5e", "puma560", "puma560 limited"])
@pytest.mark.parametrize("rpy", [(math.pi, 0.0, 0.0), (0.0, 0.0, 0.0)], ids=["tool down", "R=I"])
def test_numerical_map_recalls_every_closed_form_node(name, rpy):
    # 17³ nodes at 0.125 m: the limited PUMA560 at R = I missed 3 nodes below its base without
    # seeding, three one-node islands (docs/recall.md)
    arm = puma560(joint_limits=True) if name == "puma560 limited" else load(name)
    nodes = ws.cartesian_grid(-1.0, 1.0, 0.125)
    exact = ws.constant_orientation_map(arm, nodes, rpy, method="exact")
    numerical = ws.constant_orientation_map(arm, nodes, rpy, method="numerical")
    assert exact.sum() > 100
    np.testing.assert_array_equal(numerical, exact)


def test_the_map_is_deterministic_and_seeding_only_adds():
    arm = from_dh(d=D, a=A, alpha=ALPHA, qlim=np.array(LIMITS["island"]))
    T = ws.target_poses(NODES, (0.0, 0.0, 0.0))
    nb = ws.node_neighbours(NODES)
    a = map_search(arm, T, nb)
    b = map_search(arm, T, nb)
    np.testing.assert_array_equal(a.success, b.success)
    np.testing.assert_array_equal(a.q, b.q)
    off = map_search(arm, T, nb, fk_seeds=0)
    assert np.all(off.success <= a.success) and a.success.sum() > off.success.sum()
    # the nodes a sampled configuration solved say so (start -3); the waves spread from them (-2)
    assert np.any(a.start == -3) and not np.any(off.start == -3)


def test_halton_known_values():
    np.testing.assert_allclose(halton(4, 3), [[1 / 2, 1 / 3, 1 / 5], [1 / 4, 2 / 3, 2 / 5], [3 / 4, 1 / 9, 3 / 5],
                                              [1 / 8, 4 / 9, 4 / 5]], rtol=0, atol=1e-15)


def test_samples_inside_the_limits_and_low_discrepancy():
    chain = from_dh(d=D, a=A, alpha=ALPHA, qlim=np.array(LIMITS["island"]))
    q = sample_configurations(chain, 4096, seed=7)
    lo, hi = chain.limits[:, 0], chain.limits[:, 1]
    assert q.shape == (4096, 6) and np.all((q >= lo) & (q < hi))
    np.testing.assert_array_equal(q, sample_configurations(chain, 4096, seed=7))
    assert not np.array_equal(q, sample_configurations(chain, 4096, seed=8))
    # every joint's projection fills its range evenly: 64 bins of 64 samples each, within 4 (an
    # i.i.d. uniform sample of this size strays by about 20)
    u = (q - lo) / (hi - lo)
    counts = np.stack([np.bincount((u[:, j] * 64).astype(int), minlength=64) for j in range(6)])
    assert np.abs(counts - 64).max() <= 4
    # joints without limits are drawn in [-pi, pi)
    free = sample_configurations(as_chain(puma560()), 256, seed=0)
    assert free.min() >= -math.pi and free.max() < math.pi


def test_a_sampled_pose_is_its_own_nearest_start():
    arm = load("ur5e")
    count = sample_count(1, 1000)
    assert count == 1024 and sample_count(0, 1000) == 0 and sample_count(3, 1000) == 4096
    q = sample_configurations(arm, count, seed=3)
    T = arm.fkine(q[[5, 500, 1000]])
    starts = nearest_starts(arm, T, np.zeros(3, dtype=int), np.arange(3), count, 1, 3)
    np.testing.assert_array_equal(starts[:, 0], q[[5, 500, 1000]])


def test_a_batch_of_arms_is_seeded_per_arm():
    arms = from_dh(d=np.array(D)[None].repeat(2, 0), a=np.array(A)[None].repeat(2, 0),
                   alpha=np.array(ALPHA)[None].repeat(2, 0),
                   qlim=np.array([LIMITS["island"], LIMITS["q0 solves nothing"]]))
    T = ws.target_poses(NODES, (0.0, 0.0, 0.0))
    res = map_search(arms, T, ws.node_neighbours(NODES))
    for b, case in enumerate(["island", "q0 solves nothing"]):
        one = from_dh(d=D, a=A, alpha=ALPHA, qlim=np.array(LIMITS[case]))
        np.testing.assert_array_equal(res.success[b], ws.constant_orientation_map(one, NODES, method="exact"))


def test_fk_seeds_is_checked():
    with pytest.raises(ValueError, match=r"^fk_seeds must be an integer >= 0, got -1$"):
        SearchSettings(fk_seeds=-1)
    with pytest.raises(ValueError, match=r"^solver 'independent' takes no fk_seeds"):
        SearchSettings(solver="independent", fk_seeds=1)
    assert SearchSettings().fk_seeds == 1 and SearchSettings(solver="independent").fk_seeds is None


def test_position_only_search_is_seeded_by_position():
    arm = from_dh(d=D, a=A, alpha=ALPHA, qlim=np.array(LIMITS["q0 solves nothing"]))
    T = ws.target_poses(NODES, (0.0, 0.0, 0.0))
    nb = ws.node_neighbours(NODES)
    on = map_search(arm, T, nb, position_only=True)
    off = map_search(arm, T, nb, position_only=True, fk_seeds=0)
    assert np.all(off.success <= on.success)
    assert np.any(on.start == -3)
    np.testing.assert_allclose(arm.fkine(on.q[on.success])[:, :3, 3], NODES[on.success], atol=1e-6)
    assert arm.within_limits(on.q[on.success]).all()
