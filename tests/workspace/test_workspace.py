import numpy as np
import pytest

from wsmap import robots
from wsmap import workspace as ws


@pytest.fixture(scope="module")
def grid21():
    return ws.cartesian_grid(-1, 1, 0.1)


@pytest.mark.parametrize("step, n", [(1.0, 27), (0.5, 125), (0.1, 9261)])
def test_cartesian_grid_sizes(step, n):
    assert ws.cartesian_grid(-1, 1, step).shape == (n, 3)


@pytest.mark.parametrize("step, n", [(np.pi / 3, 343), (np.pi / 8, 4913), (np.pi / 10, 9261)])
def test_angle_grid_sizes(step, n):
    nodes = ws.angle_grid(0, 2 * np.pi, step)
    assert nodes.shape == (n, 3)
    assert np.isclose(nodes[:, 0].max(), 2 * np.pi)  # inclusive upper end


def test_node_order_first_coordinate_fastest(grid21):
    nx = ny = 21
    i, j, k = 3, 7, 11
    np.testing.assert_allclose(grid21[i + nx * j + nx * ny * k], [-1 + 0.1 * i, -1 + 0.1 * j, -1 + 0.1 * k], atol=1e-12)
    np.testing.assert_allclose(grid21[:3, 0], [-1.0, -0.9, -0.8])
    assert np.all(grid21[:21, 1] == -1.0)


def test_paper_block_5(grid21):
    # the paper's block 5 is 1-based flat indices 5293..6615: 0-based block 4, z in {0.2, 0.3, 0.4}
    s = ws.block_slice(4)
    assert (s.start + 1, s.stop) == (5293, 6615)
    np.testing.assert_allclose(np.unique(grid21[s, 2]), [0.2, 0.3, 0.4], atol=1e-12)
    starts = [grid21[ws.block_slice(b), 2][0] for b in range(7)]
    np.testing.assert_allclose(starts, [-1.0, -0.7, -0.4, -0.1, 0.2, 0.5, 0.8], atol=1e-12)
    crop = grid21[ws.CROP_3087]
    assert len(crop) == 3087 and np.isclose(crop[0, 2], 0.2) and np.isclose(crop[-1, 2], 0.8)
    with pytest.raises(ValueError, match="block must be an integer in 0..6"):
        ws.block_slice(7)


def test_volume_round_trip(grid21):
    flat = np.arange(9261)
    vol = ws.map_to_volume(flat, (21, 21, 21))
    assert vol[11, 7, 3] == 3 + 21 * 7 + 441 * 11
    np.testing.assert_array_equal(ws.volume_to_map(vol), flat)
    with pytest.raises(ValueError, match="does not fill a grid"):
        ws.map_to_volume(flat[:-1], (21, 21, 21))


def test_exact_and_numerical_maps_of_puma560_agree(grid21):
    puma = robots.puma560()
    exact = ws.constant_orientation_map(puma, grid21, method="exact")
    num = ws.constant_orientation_map(puma, grid21, method="numerical")
    assert exact.shape == num.shape == (9261,)
    # the numerical path can only miss reachable nodes, never invent them
    assert not np.any(num & ~exact)
    assert (num == exact).mean() > 0.99
    assert 0.2 < exact.mean() < 0.4


def test_conventions_agree_at_identity_and_differ_elsewhere(grid21):
    arms = robots.sample_spherical_wrist(20, seed=3)
    a = ws.constant_orientation_map(arms, grid21, (0, 0, 0), convention="paper")
    b = ws.constant_orientation_map(arms, grid21, (0, 0, 0), convention="standard")
    np.testing.assert_array_equal(a, b)
    rpy = (0.312, 5.6719, 5.936)
    a = ws.constant_orientation_map(arms, grid21, rpy, convention="paper")
    b = ws.constant_orientation_map(arms, grid21, rpy, convention="standard")
    assert 0.0 < (a != b).mean() < 0.2
    # the paper convention tests R·p: a rotated grid under "standard" gives the same answer
    from wsmap.kinematics import rpy2r

    R = rpy2r(np.array(rpy))
    c = ws.constant_orientation_map(arms, grid21 @ R.T, rpy, convention="standard")
    np.testing.assert_array_equal(a, c)


def test_batch_map_equals_per_arm_maps(grid21):
    arms = robots.sample_spherical_wrist(6, seed=4)
    batch = ws.constant_orientation_map(arms, grid21, (0.3, 0.2, 0.1))
    assert batch.shape == (6, 9261)
    for i in range(6):
        np.testing.assert_array_equal(batch[i], ws.constant_orientation_map(arms[i], grid21, (0.3, 0.2, 0.1)))


def test_orientation_map_paper_convention_is_a_sphere_test():
    nodes = ws.angle_grid(0, 2 * np.pi, np.pi / 3)
    arms = robots.sample_spherical_wrist(10, seed=5)
    m = ws.orientation_map(arms, nodes, (0.5, 0.5, 0.5))
    assert m.shape == (10, 343)
    std = ws.orientation_map(arms, nodes, (0.5, 0.5, 0.5), convention="standard")
    # at a fixed position every orientation is reachable or none is (unlimited spherical wrist)
    assert np.all(std.all(axis=1) | ~std.any(axis=1))


def test_joint_limits_shrink_the_exact_map(grid21):
    free = ws.constant_orientation_map(robots.puma560(), grid21)
    limited = ws.constant_orientation_map(robots.puma560(joint_limits=True), grid21)
    assert not np.any(limited & ~free)
    assert limited.sum() < free.sum()


def test_numerical_map_on_small_grid_with_limits_agrees_with_exact():
    nodes = ws.cartesian_grid(-1, 1, 0.5)
    limited = robots.puma560(joint_limits=True)
    exact = ws.constant_orientation_map(limited, nodes, method="exact")
    num = ws.constant_orientation_map(limited, nodes, method="numerical")
    assert not np.any(num & ~exact)


@pytest.mark.parametrize(
    "args, exc, message",
    [
        (dict(lo=-1, hi=1, step=0), ValueError, "step must be positive"),
        (dict(lo=-1, hi=1, step=-0.1), ValueError, "step must be positive"),
        (dict(lo=1, hi=-1, step=0.1), ValueError, "lo must not exceed hi"),
        (dict(lo=np.nan, hi=1, step=0.1), ValueError, "lo contains NaN"),
        (dict(lo=(0, 0), hi=1, step=0.1), ValueError, "lo must be a scalar or a 3-tuple"),
        (dict(lo=-1, hi=1, step=1e-3), MemoryError, "more than half"),
        (dict(lo=-1, hi=1, step=1e-5), ValueError, "about 8e\\+15 nodes"),
        # 1e-300 used to overflow the int64 node count and give a 0-node grid silently
        (dict(lo=-1, hi=1, step=1e-300), ValueError, "use a coarser step"),
        (dict(lo=-1e308, hi=1e308, step=1), ValueError, "use a coarser step"),
        (dict(lo=-1, hi=1, step=1j), ValueError, "step must be real numbers"),
    ],
)
def test_bad_grids(args, exc, message):
    with pytest.raises(exc, match=message):
        ws.cartesian_grid(**args)


def test_bad_map_arguments(grid21):
    puma = robots.puma560()
    with pytest.raises(ValueError, match="unknown method 'magic'; choose one of auto, exact, numerical"):
        ws.constant_orientation_map(puma, grid21, method="magic")
    with pytest.raises(ValueError, match="unknown convention 'zyx'"):
        ws.constant_orientation_map(puma, grid21, convention="zyx")
    with pytest.raises(ValueError, match=r"nodes must have shape \(N, 3\)"):
        ws.constant_orientation_map(puma, grid21[:, :2])
    with pytest.raises(ValueError, match="method 'exact' has no closed form .* spherical-wrist DH family, the "
                                         "spherical-wrist family with a shoulder offset and the UR family"):
        ws.constant_orientation_map(robots.sample_arbitrary_6dof(2, seed=0), grid21, method="exact")
    with pytest.raises(TypeError, match="arms must be a DHRobot"):
        ws.constant_orientation_map(np.zeros((3, 6)), grid21)
