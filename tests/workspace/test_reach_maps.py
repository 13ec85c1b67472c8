"""Maps over orientations, manipulability and base placement: cases with known answers."""

import numpy as np
import pytest

from wsmap import robots
from wsmap import workspace as ws
from wsmap.kinematics import from_dh, rotx

PI = np.pi


def rz(phis):
    phis = np.asarray(phis, dtype=float)
    R = np.zeros(phis.shape + (3, 3))
    R[..., 0, 0], R[..., 0, 1], R[..., 1, 0], R[..., 1, 1], R[..., 2, 2] = (np.cos(phis), -np.sin(phis),
                                                                          np.sin(phis), np.cos(phis), 1.0)
    return R


# ------------------------------------------------------------------ orientation sets
def test_orientation_samples_are_rotations_spread_over_so3():
    R = ws.orientation_samples(500)
    assert R.shape == (500, 3, 3)
    np.testing.assert_allclose(np.swapaxes(R, 1, 2) @ R, np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-12)
    # uniform over SO(3): E[R] = 0; and no two samples nearly equal
    assert np.abs(R.mean(axis=0)).max() < 0.02
    from wsmap.workspace.orientations import rotation_angle

    d = rotation_angle(R[:, None], R[None]) + np.eye(500) * 10
    assert d.min() > 0.1
    # deterministic, and a seed turns the whole set
    np.testing.assert_array_equal(R, ws.orientation_samples(500))
    other = ws.orientation_samples(500, seed=1)
    assert not np.allclose(other, R)
    G = other[0] @ ws.orientation_samples(500, seed=None)[0].T
    np.testing.assert_allclose(other, G @ ws.orientation_samples(500, seed=None), atol=1e-12)


def test_approach_orientations_point_the_tool_z_axis():
    R = ws.approach_orientations(20, rolls=4)
    assert R.shape == (80, 3, 3)
    z = R[:, :, 2].reshape(20, 4, 3)
    np.testing.assert_allclose(z, z[:, :1].repeat(4, axis=1), atol=1e-12)  # the roll keeps the approach
    np.testing.assert_allclose(np.linalg.norm(z, axis=-1), 1.0)
    assert np.abs(z[:, 0].mean(axis=0)).max() < 0.05  # spread over the sphere
    ws.check_rotations("R", R)


@pytest.mark.parametrize("bad, message", [
    (np.zeros((0, 3, 3)), "orientations is empty"),
    (np.eye(3)[None] * 2, r"orientations\[0\] is not a rotation: RᵀR ≠ I"),
    (np.diag([1.0, 1.0, -1.0])[None], r"orientations\[0\] is not a rotation: det R = -1"),
    (np.zeros((2, 3)), r"orientations must have shape \(K, 3, 3\)"),
    (np.full((1, 3, 3), np.nan), "NaN"),
])
def test_bad_orientation_sets_are_refused(bad, message):
    with pytest.raises(ValueError, match=message):
        ws.reachability_index(robots.puma560(), np.zeros((1, 3)), bad)


@pytest.mark.parametrize("k", [0, -3, 2.5, True])
def test_bad_counts_are_refused(k):
    with pytest.raises(ValueError, match="must be a positive integer"):
        ws.orientation_samples(k)
    with pytest.raises(ValueError, match="must be a positive integer"):
        ws.approach_orientations(k)


# ------------------------------------------------------------------ known answers
@pytest.mark.parametrize("method", ["exact", "numerical"])
def test_puma_without_limits_index_is_the_wrist_centre_map(method):
    """PUMA560 without limits: its wrist reaches every orientation wherever the wrist centre is
    reachable (the flange sits on the centre), so the index is 0 or 1 and equals the R = I map."""
    puma = robots.puma560()
    nodes = ws.cartesian_grid(-1, 1, 0.2)
    idx = ws.reachability_index(puma, nodes, ws.orientation_samples(12), method=method)
    assert set(np.unique(idx)) <= {0.0, 1.0}
    ri = ws.constant_orientation_map(puma, nodes, method="exact", convention="standard")
    np.testing.assert_array_equal(idx == 1.0, ri)
    np.testing.assert_array_equal(ws.dexterous_map(puma, nodes, ws.orientation_samples(12), method=method), ri)
    np.testing.assert_array_equal(ws.position_map(puma, nodes), ri)


def planar3r():
    return from_dh([0.0, 0.0, 0.0], [0.5, 0.4, 0.2], [0.0, 0.0, 0.0], name="planar3r")


def test_planar_3r_index_and_reach_match_the_annulus():
    """Planar 3R (0.5, 0.4, 0.2 m): at heading phi the wrist point p - 0.2·(cos phi, sin phi) must lie
    in the annulus 0.1 <= r <= 0.9; the tool reaches 0 <= |p| <= 1.1 at some heading."""
    arm = planar3r()
    nodes = ws.cartesian_grid((-1.2, -1.2, 0.0), (1.2, 1.2, 0.0), 0.1)
    phis = np.linspace(0, 2 * PI, 12, endpoint=False)
    idx, bits = ws.reachability_index(arm, nodes, rz(phis), return_bits=True)
    w = nodes[:, None, :2] - 0.2 * np.stack([np.cos(phis), np.sin(phis)], -1)[None]
    r = np.linalg.norm(w, axis=-1)
    exact = (r >= 0.1 - 1e-9) & (r <= 0.9 + 1e-9)
    # never a false positive; every miss lies exactly on the boundary, reachable only at a
    # singular configuration where LM converges too slowly for tol 1e-10
    assert not np.any(bits & ~exact)
    miss = exact & ~bits
    assert np.all(np.isclose(r[miss], 0.1) | np.isclose(r[miss], 0.9))
    away = (np.abs(r - 0.1) > 1e-6) & (np.abs(r - 0.9) > 1e-6)
    np.testing.assert_array_equal(bits[away], exact[away])
    np.testing.assert_allclose(idx, bits.mean(axis=1))
    pm = ws.position_map(arm, nodes)
    rr = np.linalg.norm(nodes[:, :2], axis=1)
    inside = rr <= 1.1 - 1e-6
    np.testing.assert_array_equal(pm[inside | (rr > 1.1 + 1e-6)], inside[inside | (rr > 1.1 + 1e-6)])
    # nodes off the arm's plane are never reached
    off = ws.cartesian_grid((-0.5, -0.5, 0.1), (0.5, 0.5, 0.1), 0.25)
    assert not ws.position_map(arm, off).any()


def test_ur5e_index_numerical_agrees_with_the_closed_form():
    ur5e = robots.load("ur5e")
    nodes = ws.cartesian_grid(-1, 1, 0.2)
    R = ws.orientation_samples(8)
    exact, be = ws.reachability_index(ur5e, nodes, R, return_bits=True)
    num, bn = ws.reachability_index(ur5e, nodes, R, method="numerical", return_bits=True)
    assert not np.any(bn & ~be)
    assert (bn & be).sum() / be.sum() >= 0.99
    # the position map contains every orientation's map
    pm = ws.position_map(ur5e, nodes)
    assert not np.any(be.any(axis=1) & ~pm)


def test_manipulability_exact_numerical_and_an_independent_library():
    import roboticstoolbox as rtb

    puma = robots.puma560()
    nodes = ws.cartesian_grid(-1, 1, 0.2)
    exact = ws.manipulability_map(puma, nodes, (PI, 0, 0))
    num = ws.manipulability_map(puma, nodes, (PI, 0, 0), method="numerical")
    reach = ws.constant_orientation_map(puma, nodes, (PI, 0, 0), convention="standard")
    np.testing.assert_array_equal(exact > 0, reach)
    np.testing.assert_array_equal(num > 0, reach)
    assert np.all(num <= exact + 1e-9)  # one solution's value never beats the best branch
    assert np.all(exact[~reach] == 0)
    # Yoshikawa's measure against Robotics Toolbox's, at random configurations
    rob = rtb.DHRobot([rtb.RevoluteDH(d=d, a=a, alpha=al) for d, a, al in zip(puma.d, puma.a, puma.alpha)])
    q = np.random.default_rng(0).uniform(-PI, PI, (20, 6))
    ours = ws.yoshikawa(puma.jacob0(q))
    theirs = np.array([rob.manipulability(qi, method="yoshikawa") for qi in q])
    np.testing.assert_allclose(ours, theirs, rtol=1e-9, atol=1e-12)


def test_yoshikawa_of_known_jacobians():
    J = np.zeros((6, 6))
    J[np.arange(6), np.arange(6)] = [1, 2, 3, 1, 1, 0.5]
    assert ws.yoshikawa(J) == pytest.approx(3.0)
    J[5, 5] = 0.0
    assert ws.yoshikawa(J) == 0.0


# ------------------------------------------------------------------ base placement
@pytest.mark.parametrize("name", ["ur5e", "panda"])
def test_targets_from_a_known_base_are_placed_back_there(name):
    arm = robots.load(name)
    rng = np.random.default_rng(3)
    T0 = arm.fkine(arm.random_q(200, rng))
    far = np.argsort(-np.linalg.norm(T0[:, :3, 3], axis=1))[:20]  # near the reach limit: a sharp answer
    B0 = ws.floor_poses(0.3, -0.2, PI / 4)
    T = B0 @ T0[far]
    pl = ws.base_placement(arm, T, x=(-0.5, 0.5), y=(-0.5, 0.5), step=0.1, yaws=8)
    assert pl.score[0] == 1.0
    top = pl.score == 1.0
    # every base that reaches all the targets stands where they came from (the base joint's range
    # may absorb the heading)
    np.testing.assert_allclose(pl.x[top], 0.3, atol=1e-9)
    np.testing.assert_allclose(pl.y[top], -0.2, atol=1e-9)
    assert np.any(np.isclose(pl.yaw[top], PI / 4))
    # the best base's solutions reach the targets in its frame
    Tb = np.linalg.inv(pl.poses[0]) @ T
    np.testing.assert_allclose(arm.fkine(pl.q), Tb, atol=1e-6)
    assert np.all(np.diff(pl.score) <= 0)


@pytest.mark.parametrize("kw, message", [
    (dict(x=(1.0, -1.0)), r"x: lo \(1.0\) is above hi \(-1.0\)"),
    (dict(y=(0.0, np.nan)), "y must be a finite"),
    (dict(yaws=0), "yaws must be a positive integer"),
    (dict(step=0.0), "step must be positive"),
    (dict(yaws=2**40), r"^yaws must be at most 3600 \(headings 0.1° apart"),
    (dict(x=(-1e200, 1e200)), r"^a region of 2e\+201 x 21 positions x 8 headings is 3.36e\+203 candidate bases, more "
                              r"than 1e\+07"),
    (dict(step=1e-4), r"^a region of 2e\+04 x 2e\+04 positions x 8 headings is 3.2e\+09 candidate bases"),
])
def test_bad_placement_regions_are_refused(kw, message):
    with pytest.raises(ValueError, match=message):
        ws.base_placement(robots.load("ur5e"), np.eye(4), **kw)


def test_placement_refuses_more_targets_than_it_can_map():
    T = np.broadcast_to(np.eye(4), (ws.placement.MAX_TARGETS + 1, 4, 4))
    with pytest.raises(ValueError, match=r"^at most 100000 targets \(each is one map over every candidate base"):
        ws.base_placement(robots.load("ur5e"), T)


def test_placement_targets_must_be_rigid():
    T = np.eye(4)
    T[0, 0] = 2.0
    with pytest.raises(ValueError, match="targets is not a rigid transform"):
        ws.base_placement(robots.load("ur5e"), T)
    with pytest.raises(ValueError, match=r"targets must have shape \(M, 4, 4\) with M >= 1"):
        ws.base_placement(robots.load("ur5e"), np.zeros((0, 4, 4)))
    T = rotx(0.3)
    with pytest.raises(ValueError, match=r"targets must have shape"):
        ws.base_placement(robots.load("ur5e"), T[:3])


# ------------------------------------------------------------------ issue 29: edge inputs
def test_complex_nodes_are_refused_not_cast():
    arm = robots.load("panda")
    with pytest.raises(ValueError, match=r"^nodes must be real numbers, got complex values$"):
        ws.position_map(arm, np.array([[0.5 + 1j, 0.0, 0.3]]))
    with pytest.raises(ValueError, match=r"^nodes must be real numbers, got complex values$"):
        ws.manipulability_map(arm, np.array([[0.5, 0.0, 0.3 + 0j]]))


def test_a_tool_beyond_float64_range_reaches_nothing_without_an_index_error():
    arm = from_dh([0.3, 0.0, 0.0], [0.0, 0.3, 0.3], [np.pi / 2, 0.0, 0.0])  # a shoulder and an elbow: a solid shell
    far = arm.replace(tool=np.array([[1.0, 0, 0, 1e308], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]))
    nodes = ws.cartesian_grid(-0.5, 0.5, 0.5)
    with np.errstate(over="ignore", invalid="ignore"):
        assert not ws.position_map(far, nodes, samples=200).any()
    assert ws.position_map(arm, nodes, samples=200).any()


def test_placement_refuses_candidates_x_targets_beyond_the_memory():
    T = np.broadcast_to(np.eye(4), (1000, 4, 4))
    with pytest.raises(MemoryError, match=r"^8016008 candidate bases x 1000 targets needs .* GiB, more than half"):
        ws.base_placement(robots.load("ur5e"), T, x=(-0.5, 0.5), y=(-0.5, 0.5), step=0.001)


def test_orientation_sets_are_bounded():
    assert ws.orientation_samples(ws.orientations.MAX_ORIENTATIONS, seed=None).shape == (100_000, 3, 3)
    with pytest.raises(ValueError, match=r"^k \(the number of orientations\) must be at most 100000 \(neighbouring "
                                         r"orientations are then 3.6° apart"):
        ws.orientation_samples(10**10)


def _easy_targets(arm, n=3):
    """Targets made from the origin base at moderate reach: hundreds of candidate bases reach all."""
    q = np.array([[0.3, -1.2, 1.4, -1.5, -1.4, 0.2], [-0.4, -1.0, 1.1, -1.3, -1.6, 0.5],
                  [0.1, -1.5, 1.8, -1.8, -1.5, -0.3]])[:n]
    return arm.fkine(q)


def test_placement_ties_are_broken_by_the_mean_manipulability_of_the_solutions():
    from wsmap.kinematics.ik.solvers import get_solver
    from wsmap.workspace.scores import joint_margin, manipulability

    arm = robots.load("ur5e")
    T = _easy_targets(arm)
    pl = ws.base_placement(arm, T, x=(-0.5, 0.5), y=(-0.5, 0.5), step=0.1, yaws=4)
    top = pl.score == pl.score[0]
    assert top.sum() > 20  # the case the tie-break is for: many bases reach every target
    # within each score, the secondary score does not increase down the ranking
    for s in np.unique(pl.score):
        t = pl.manipulability[pl.score == s]
        assert np.all(np.diff(t) <= 1e-9 * np.abs(t[:-1]) + 1e-15)
    assert pl.manipulability[top].max() > pl.manipulability[top].min() * 1.01  # it does decide something
    # it is the mean Yoshikawa manipulability of the solutions the ranking reports: the best's q ...
    np.testing.assert_allclose(pl.manipulability[0], manipulability(arm, pl.q[pl.reached[0]]).mean(), rtol=1e-12)
    np.testing.assert_allclose(pl.joint_margin[0], joint_margin(arm, pl.q[pl.reached[0]]).mean(), rtol=1e-12)
    # bases at one point whose headings the base joint absorbs: one manipulability, then the joint margin
    same = (pl.score == pl.score[0]) & np.isclose(pl.manipulability, pl.manipulability[0], rtol=1e-9, atol=0)
    assert same.sum() > 1 and np.all(np.diff(pl.joint_margin[same]) <= 1e-9)
    # ... and any other base's, solved from it alone
    for k in (1, int(top.sum()) - 1, int(top.sum())):
        q = get_solver("closed_form").solve(arm, np.linalg.inv(pl.poses[k]) @ T).q
        ok = pl.reached[k]
        expected = manipulability(arm, q[ok]).mean() if ok.any() else 0.0
        np.testing.assert_allclose(pl.manipulability[k], expected, rtol=1e-9)
    # deterministic, and the grid holds exact multiples of the step: 0 is +0.0, never -0.0
    again = ws.base_placement(arm, T, x=(-0.5, 0.5), y=(-0.5, 0.5), step=0.1, yaws=4)
    np.testing.assert_array_equal(again.poses, pl.poses)
    for v in (pl.x, pl.y, pl.yaw):
        assert not np.any(np.signbit(v) & (v == 0.0))
    np.testing.assert_array_equal(np.unique(pl.x), np.round(np.arange(-5, 6) / 10, 12))
    assert 0.0 in pl.x and 0.0 in pl.y


def test_placement_by_reach_alone_ties_to_the_middle():
    arm = robots.load("ur5e")
    T = _easy_targets(arm, 2)
    pl = ws.base_placement(arm, T, x=(-0.4, 0.4), y=(-0.4, 0.4), step=0.2, yaws=2, tiebreak="centre")
    top = pl.score == pl.score[0]
    d = np.hypot(pl.x[top], pl.y[top])
    assert np.all(np.diff(d) >= -1e-12) and d[0] == 0.0
    with pytest.raises(ValueError, match=r"^tiebreak must be one of 'manipulability', 'centre', got 'random'$"):
        ws.base_placement(arm, T, tiebreak="random")
