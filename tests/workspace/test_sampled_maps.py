"""Maps from forward kinematics alone (``wsmap.workspace.fk_sampled_maps``): the same cells as a
slow, independent reading of the same samples, inside the exact map up to its tolerances, the
Haar share of a rotation ball, and the errors bad input gets."""

import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from wsmap import robots
from wsmap import workspace as ws
from wsmap.metrics import score_maps

TOOL_DOWN = (np.pi, 0.0, 0.0)


def _slow(arm, lo, hi, step, rpy, samples, angle_tol, seed, chunk, convention):
    """The same draws read another way: scipy's rotation angle, the nearest node by a k-d tree."""
    rng = np.random.default_rng(seed)
    q = np.concatenate([arm.random_q(min(chunk, samples - k), rng) for k in range(0, samples, chunk)])
    T = arm.fkine(q)
    R = Rotation.from_euler("XYZ", rpy).as_matrix()  # Rx Ry Rz, as rpy2r
    angle = (Rotation.from_matrix(R).inv() * Rotation.from_matrix(T[:, :3, :3])).magnitude()
    t = T[:, :3, 3] if convention == "standard" else T[:, :3, 3] @ R
    nodes = ws.cartesian_grid(lo, hi, step)
    d, idx = cKDTree(nodes).query(t, p=np.inf)
    keep = (angle <= angle_tol) & (d <= step / 2)
    out = np.zeros(len(nodes), dtype=bool)
    out[idx[keep]] = True
    return out


@pytest.mark.parametrize("convention", ["standard", "paper"])
def test_the_cells_are_those_an_independent_reading_of_the_samples_gives(convention):
    arm = robots.load("ur5e")
    args = dict(samples=30_000, angle_tol=0.5, seed=3, chunk=7_000)
    fast = ws.fk_sampled_maps(arm, -1.0, 1.0, 0.2, TOOL_DOWN, convention=convention, **args)
    slow = _slow(arm, -1.0, 1.0, 0.2, TOOL_DOWN, convention=convention, **args)
    assert fast.shape == (11 ** 3,) and fast.sum() > 20
    # a sample exactly on a cell face may round either way: allow a handful
    assert np.sum(fast != slow) <= 2


def test_a_batch_of_arms_gives_each_arm_its_own_cells():
    fam = robots.FAMILIES["morph6"]
    arms = fam.arms(fam.draw(3, seed=1))
    maps = ws.fk_sampled_maps(arms, -1.5, 1.5, 0.3, TOOL_DOWN, samples=20_000, angle_tol=0.6, seed=0)
    assert maps.shape == (3, 11 ** 3) and maps.dtype == bool
    assert len({m.tobytes() for m in maps}) == 3  # three arms, three maps
    again = ws.fk_sampled_maps(arms, -1.5, 1.5, 0.3, TOOL_DOWN, samples=20_000, angle_tol=0.6, seed=0)
    np.testing.assert_array_equal(maps, again)  # deterministic in the seed


def test_the_sampled_map_approaches_the_exact_one_from_inside():
    """Precision stays high (the cells it marks are the exact map's, up to the angle and half-cell
    tolerances) while recall grows with the samples: the approximation the module notes describe."""
    arm = robots.load("panda")
    nodes = ws.cartesian_grid(-1.0, 1.0, 0.2)
    exact = ws.constant_orientation_map(arm, nodes, TOOL_DOWN)
    few = ws.fk_sampled_maps(arm, -1.0, 1.0, 0.2, TOOL_DOWN, samples=20_000, angle_tol=0.3)
    many = ws.fk_sampled_maps(arm, -1.0, 1.0, 0.2, TOOL_DOWN, samples=300_000, angle_tol=0.3)
    s_few, s_many = score_maps(few[None], exact[None]), score_maps(many[None], exact[None])
    assert s_many["precision"] > 0.75 and s_few["precision"] > 0.75
    assert s_many["recall"] > s_few["recall"] + 0.2 and s_many["recall"] > 0.4
    assert np.all(many | ~few) or np.sum(few & ~many) < 3  # more samples add cells


def test_orientation_share_is_the_haar_measure_of_a_rotation_ball():
    R = Rotation.random(200_000, random_state=0)
    for tol in (0.3, 1.0, np.pi / 2):
        share = np.mean(R.magnitude() <= tol)
        expected = ws.orientation_share(tol)
        assert share == pytest.approx(expected, abs=4 * np.sqrt(expected / 200_000) + 1e-4)
    assert ws.orientation_share(np.pi) == pytest.approx(1.0)


@pytest.mark.parametrize("kwargs, message", [
    ({"samples": 0}, "samples must be a positive integer, got 0"),
    ({"samples": 1.5}, "samples must be a positive integer, got 1.5"),
    ({"angle_tol": 0.0}, r"angle_tol must be in \(0, pi\] rad, got 0.0"),
    ({"angle_tol": 4.0}, r"angle_tol must be in \(0, pi\] rad, got 4.0"),
    ({"convention": "craig"}, "unknown convention 'craig'; choose one of paper, standard"),
    ({"chunk": -1}, "chunk must be a positive integer, got -1"),
    ({"step": 0.0}, "step must be positive"),
    ({"rpy": (0.0, 1.0)}, "rpy must be 3 angles"),
])
def test_bad_input_is_refused_before_any_sample(kwargs, message):
    args = {"lo": -1.0, "hi": 1.0, "step": 0.2, "rpy": TOOL_DOWN, **kwargs}
    lo, hi, step, rpy = args.pop("lo"), args.pop("hi"), args.pop("step"), args.pop("rpy")
    with pytest.raises(ValueError, match=message):
        ws.fk_sampled_maps(robots.load("ur5e"), lo, hi, step, rpy, **args)
