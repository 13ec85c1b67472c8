"""The three answers of a map node (issue 44): reached, certified unreachable, not found.

Soundness is the point: a certified pose must never be reachable. Two independent checks: the
forward kinematics of random configurations inside the limits (reachable by construction) is never
certified, and no certified pose near the workspace's border is reached by a 256-start search.
"""

from __future__ import annotations

import numpy as np
import pytest

import wsmap
from wsmap import robots
from wsmap import workspace as ws
from wsmap.kinematics import DHRobot, as_chain
from wsmap.kinematics.ik.certificate import certify, closed_form_certificate, joint_certificate
from wsmap.workspace.files import MapFileError, load_status
from wsmap.workspace.status import CERTIFIED, NOT_FOUND, REACHED

NUMERICAL = ["panda", "iiwa14", "gen3"]
EXACT = ["puma560", "ur5e"]


def _random_dh(seed):
    """A random 6R DH arm (lengths up to 0.4 m, twists anywhere) with limits of ±(1 .. π) rad."""
    rng = np.random.default_rng(seed)
    d, a = rng.uniform(0, 0.4, 6), rng.uniform(0, 0.4, 6)
    alpha = rng.uniform(-np.pi, np.pi, 6)
    half = rng.uniform(1.0, np.pi, 6)
    return DHRobot(d, a, alpha, qlim=np.stack([-half, half], axis=1))


def _inside(robot, count, rng):
    """`count` configurations inside the limits (a full turn where a joint has none)."""
    lim = np.asarray(as_chain(robot).limits, dtype=np.float64)
    lim = np.where(np.isfinite(lim), lim, np.array([-np.pi, np.pi]))
    return rng.uniform(lim[:, 0], lim[:, 1], (count, robot.n))


def _border_poses(robot, count, rng):
    """Poses near the reachable set's border: reachable poses moved by up to a third of the arm's
    length and turned by up to 0.3 rad, so that many are out of reach and many only just."""
    shift = np.linalg.norm(as_chain(robot).fixed[:, :3, 3], axis=-1).sum() / 3
    T = robot.fkine(_inside(robot, count, rng))
    T[:, :3, 3] += rng.uniform(-shift, shift, (count, 3))
    axis = rng.normal(size=(count, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    R = wsmap.rpy2r(np.zeros(3))[None].repeat(count, 0)
    angle = rng.uniform(0, 0.3, count)
    K = np.zeros((count, 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -axis[:, 2], axis[:, 1], -axis[:, 0]
    K = K - np.swapaxes(K, 1, 2)
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    R = R + s * K + (1 - c) * K @ K
    T[:, :3, :3] = R @ T[:, :3, :3]
    return T


@pytest.mark.parametrize("name", NUMERICAL + EXACT + ["dh0", "dh1", "dh2"])
def test_reachable_poses_are_never_certified(name):
    robot = _random_dh(int(name[2:])) if name.startswith("dh") else robots.load(name)
    rng = np.random.default_rng(1)
    T = robot.fkine(_inside(robot, 40, rng))
    method = "both" if wsmap.closed_form_for(robot) is not None else "numerical"
    assert not certify(robot, T, method=method).any()
    # the branch and bound alone, on poses the filters leave anyway
    assert not joint_certificate(robot, T[:10]).any()


@pytest.mark.parametrize("name", NUMERICAL + EXACT + ["dh3", "dh4"])
def test_no_certified_pose_is_reached_by_a_256_start_search(name):
    robot = _random_dh(int(name[2:])) if name.startswith("dh") else robots.load(name)
    rng = np.random.default_rng(2)
    T = _border_poses(robot, 60, rng)
    method = "both" if wsmap.closed_form_for(robot) is not None else "numerical"
    cert = certify(robot, T, method=method)
    assert cert.any()  # the test tests something
    assert not wsmap.reachable(robot, T[cert], starts=256, seed=5).any()


def test_the_branch_and_bound_certifies_what_the_filters_cannot():
    # nodes of the Panda's tool-down map that the three separate intervals leave: some are proved
    panda = robots.load("panda")
    nodes = ws.cartesian_grid(-1, 1, 0.1)
    T = ws.target_poses(nodes, (np.pi, 0, 0), "standard")
    reached = ws.constant_orientation_map(panda, nodes, (np.pi, 0, 0))
    from wsmap.kinematics.ik.certificate import filter_certificate

    left = np.flatnonzero(~reached & ~filter_certificate(panda, T))
    assert left.size > 50
    some = T[left[::20]]
    bnb = joint_certificate(panda, some, budget=200_000)  # a larger budget than the maps' default
    assert bnb.any()
    assert not wsmap.reachable(panda, some[bnb], starts=256, seed=9).any()


@pytest.mark.parametrize("name", EXACT)
def test_exact_status_agrees_with_the_closed_form(name):
    robot = robots.load(name)
    nodes = ws.cartesian_grid(-1, 1, 0.2)
    for rpy in [(np.pi, 0, 0), (0.3, -0.2, 0.5)]:
        reached, status = ws.constant_orientation_map(robot, nodes, rpy, return_status=True)
        T = ws.target_poses(nodes, rpy)
        cf = wsmap.closed_form_for(robot)
        np.testing.assert_array_equal(status == REACHED, cf.reachable(robot, T))
        np.testing.assert_array_equal(reached, status == REACHED)
        # every unreached node is certified by the closed form where it is regular: all but a few
        assert (status == NOT_FOUND).sum() <= 0.01 * (~reached).sum()
        cert = closed_form_certificate(robot, T)
        assert not (cert & reached).any()


def test_a_singular_pose_of_a_closed_form_is_not_certified():
    # d3 = 0 and the wrist centre on joint 1's axis: q1 is free, the closed form returns q1 = 0 and pi
    # only; with q1 limited to [0.5, 1] both fail, yet the pose is reachable (q1 = 0.7, the wrist
    # turns the rest), so it must not be certified
    arm = DHRobot([0.3, 0, 0, 0.4, 0, 0], [0, 0.4, 0, 0, 0, 0], [np.pi / 2, 0, -np.pi / 2, np.pi / 2, -np.pi / 2, 0],
                  qlim=np.array([[0.5, 1.0]] + [[-np.pi, np.pi]] * 5))
    cf = wsmap.closed_form_for(arm)
    assert cf is not None
    T = ws.target_poses(np.array([[0.0, 0.0, 0.9]]), (0.2, 0.3, 0.4))
    assert not cf.reachable(arm, T).any()  # the closed form misses it ...
    assert wsmap.reachable(arm, T, starts=64).all()  # ... the search finds it
    assert not closed_form_certificate(arm, T).any()
    assert not certify(arm, T, method="both").any()


def test_numerical_map_status(tmp_path):
    panda = robots.load("panda")
    nodes = ws.cartesian_grid(-1, 1, 0.2)
    reached, status, method = ws.constant_orientation_map(panda, nodes, (np.pi, 0, 0), return_status=True,
                                                          return_method=True)
    assert method == "numerical" and status.dtype == np.int8
    np.testing.assert_array_equal(reached, status == REACHED)
    assert (status == CERTIFIED).sum() > 0.9 * (~reached).sum()
    # the boolean default is unchanged
    np.testing.assert_array_equal(ws.constant_orientation_map(panda, nodes, (np.pi, 0, 0)), reached)
    # grid_map and grid_status give the same answers
    grid = ws.grid_spec("R3", -1, 1, 0.2)
    flat, st = ws.grid_map(panda, grid, rpy=(np.pi, 0, 0), return_status=True)
    np.testing.assert_array_equal(st, status)
    np.testing.assert_array_equal(wsmap.grid_status(panda, grid, flat, rpy=(np.pi, 0, 0)), status)


def test_orientation_map_status():
    puma = robots.puma560()
    angles = ws.angle_grid(0, 2 * np.pi, np.pi / 4)
    reached, status = ws.orientation_map(puma, angles, (0.5, 0.2, 0.1), return_status=True)
    np.testing.assert_array_equal(reached, status == REACHED)
    assert set(np.unique(status)) <= {REACHED, CERTIFIED, NOT_FOUND}


def test_status_in_the_map_file_round_trips(tmp_path):
    grid = ws.grid_spec("R3", -1, 1, 0.5)
    flat, status = ws.grid_map(robots.puma560(), grid, return_status=True)
    path = ws.save_map(tmp_path / "m.npz", flat, grid, {"robot": "puma560"}, status=status)
    back, _, _, settings = ws.load_map(path)
    np.testing.assert_array_equal(back, flat)
    np.testing.assert_array_equal(settings["status"], status)
    assert settings["status"].dtype == np.int8
    np.testing.assert_array_equal(load_status(path), status)
    # an old file without a status: reached or not found
    old = ws.save_map(tmp_path / "old.npz", flat, grid, {"robot": "puma560"})
    assert "status" not in ws.load_map(old)[3]
    np.testing.assert_array_equal(load_status(old), np.where(flat, REACHED, NOT_FOUND))


def test_a_status_that_disagrees_with_its_map_is_refused_before_writing(tmp_path):
    grid = ws.grid_spec("R3", -1, 1, 0.5)
    flat = np.zeros(125, dtype=bool)
    flat[3] = True
    bad = np.full(125, CERTIFIED, dtype=np.int8)  # node 3 is reached in the map
    with pytest.raises(ValueError, match="status and map disagree at node 3"):
        ws.save_map(tmp_path / "m.npz", flat, grid, {}, status=bad)
    with pytest.raises(ValueError, match="status codes are 0"):
        ws.save_map(tmp_path / "m.npz", flat, grid, {}, status=np.where(flat, 0, 7))
    with pytest.raises(ValueError, match=r"status and map disagree at node 3 \(status 1, map 1\)"):
        ws.save_map(tmp_path / "m.npz", flat.astype(float), grid, {}, status=bad)  # a float map: reached above 0
    assert not (tmp_path / "m.npz").exists()
    # a file whose stored status disagrees is not a consistent map file
    path = tmp_path / "x.npz"
    np.savez(path, map=flat, nodes=ws.cartesian_grid(-1, 1, 0.5), grid=__import__("json").dumps(grid),
             settings="{}", status=bad)
    with pytest.raises(MapFileError, match="disagree"):
        ws.load_map(path)


def test_the_command_line_prints_the_three_counts(tmp_path, capsys):
    from wsmap import cli

    out = tmp_path / "puma.npz"
    assert cli.main(["map", "--robot", "puma560", "--step", "0.2", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    status = load_status(out)
    counts = [int((status == c).sum()) for c in (REACHED, CERTIFIED, NOT_FOUND)]
    assert f"nodes: {counts[0]} reached, {counts[1]} certified unreachable, {counts[2]} not found" in printed
    assert counts[0] > 0 and counts[1] > 0


@pytest.mark.parametrize("name", ["panda", "iiwa14", "gen3", "dh5"])
def test_the_box_bounds_hold_every_configuration_of_the_box(name):
    # the branch and bound's one proof step: each invariant of every configuration in a box lies
    # within the box's bounds, and the five linear forms (d², g, h, k, m) within their remainders
    # of the centre's (sampled: 2000 boxes of every size, 20 configurations each)
    from wsmap.kinematics.ik import certificate as C

    robot = _random_dh(int(name[2:])) if name.startswith("dh") else robots.load(name)
    geo = C._geometry(as_chain(robot))
    ch, n = geo["chain"], robot.n
    rng = np.random.default_rng(3)
    F, Z, lo, hi = np.empty((n, 14)), np.empty((7, 9)), np.empty(13), np.empty(4)
    G, R = np.empty((7, n)), np.empty(5)  # rows 5, 6: the tilt forms
    e7, Rs7 = np.zeros(7), np.zeros(7)
    b = geo["ends"][:6].reshape(2, 3)
    worst = worst_lin = worst_tilt = 0.0
    missed = -1.0
    for _ in range(2000):
        c = rng.uniform(-np.pi, np.pi, n)
        hw = np.zeros(n)
        hw[1:n - 1] = rng.uniform(0, 1, n - 2) * 10.0 ** rng.uniform(-3, 0)
        C._box_bounds(ch.fixed, ch.axes, np.broadcast_to(ch.offset, (n,)).astype(float), geo["S"], geo["a0"],
                      geo["w_loc"], geo["radius"], geo["rigid"], n, c, hw, F, Z, lo, hi, G, R)
        delta = rng.uniform(-1, 1, (20, n)) * hw
        frames, _ = ch.joint_frames(c + delta)
        last = frames[:, n - 1]
        W = last[:, :3, :3] @ geo["w_loc"] + last[:, :3, 3]
        z = last[:, :3, :3] @ ch.axes[n - 1]
        u = W - geo["S"]
        inv = np.stack([np.linalg.norm(u, axis=1), np.einsum("ki,ki->k", u, z), u @ geo["a0"], z @ geo["a0"]])
        worst = max(worst, float((inv - hi[:, None]).max()), float((lo[:4, None] - inv).max()))
        five = np.stack([inv[0] ** 2, inv[1], inv[2], inv[3], np.cross(u, z) @ geo["a0"]])
        centre = np.array([lo[4] ** 2, lo[5], lo[6], lo[7], lo[8]])
        off = np.abs(five - centre[:, None] - G[:5] @ delta.T) - R[:, None]
        worst_lin = max(worst_lin, float(off.max()))
        # the tilt forms: b·z within R[3] of the centre's plus their linear part
        C._tilt_rows(F, ch.axes, Z[6], geo["ends"], n, hw, G, e7, Rs7, R[3], 0.0)
        tilt_off = np.abs(z @ b.T + e7[5:] - delta @ G[5:].T) - R[3]
        worst_tilt = max(worst_tilt, float(tilt_off.max()))
        # the narrowing keeps every configuration whose invariants are the pose's: the first one's
        e = five[:, 0] - centre
        Rs = R + 1e-12 * (1 + np.abs(five[:, 0]))
        L, H = np.empty(n), np.empty(n)
        lam = rng.normal(size=5)
        assert C._contract(e, G, Rs, lam, 5, n, hw, L, H, np.empty(n + 5))
        missed = max(missed, float(np.max(np.maximum(L - delta[0], delta[0] - H)[hw > 0], initial=-1.0)))
    assert worst <= 1e-12
    assert worst_lin <= 1e-12
    assert worst_tilt <= 1e-12
    assert missed <= 0.0


def _narrow_ends(seed, half0=0.8, half_last=0.5):
    """A random 6R arm (`_random_dh`) with joint 0 limited to ±half0 and the last joint to ±half_last."""
    arm = _random_dh(seed)
    lim = np.array(arm.qlim, dtype=np.float64)
    lim[0], lim[-1] = [-half0, half0], [-half_last, half_last]
    return DHRobot(arm.d, arm.a, arm.alpha, qlim=lim)


@pytest.mark.parametrize("seed", range(6))
def test_no_configuration_inside_random_limits_is_certified(seed):
    # the soundness property with every test of the branch and bound (the limits of joints 0 and
    # n-1 included): random 6R arms, random limits (narrow at both ends), the poses of random
    # configurations inside them, with and without a tool and a base
    rng = np.random.default_rng(100 + seed)
    arm = _narrow_ends(seed + 10, *rng.uniform(0.2, 2.0, 2))
    if seed % 2:
        tool = np.eye(4)
        tool[:3, 3] = rng.uniform(-0.1, 0.1, 3)
        arm = DHRobot(arm.d, arm.a, arm.alpha, qlim=arm.qlim, tool=tool)
    if seed % 3 == 2:  # a chain standing on a moved and turned base
        base = np.eye(4)
        base[:3, :3] = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        if np.linalg.det(base[:3, :3]) < 0:
            base[:3, 0] *= -1
        base[:3, 3] = rng.uniform(-0.5, 0.5, 3)
        # the same poses carried by the base get the same answers (some certified)
        B = _border_poses(arm, 40, rng)
        here = joint_certificate(arm, B)
        arm = as_chain(arm).replace(base=base)
        assert here.any()
        np.testing.assert_array_equal(joint_certificate(arm, base @ B), here)
    T = arm.fkine(_inside(arm, 60, rng))
    assert not joint_certificate(arm, T).any()
    assert not certify(arm, T).any()


def test_the_limits_of_joints_0_and_n_minus_1_certify_what_the_invariants_cannot():
    # configurations with joint 0 (then the last joint) outside narrow limits: the four invariants
    # do not see either joint, so before the end tests none was certified; now many are, and a
    # 256-start search reaches none of them
    from wsmap.kinematics.ik import certificate as C

    arm = _narrow_ends(0)
    rng = np.random.default_rng(0)
    lim = np.array(arm.qlim)
    q = rng.uniform(lim[:, 0], lim[:, 1], (80, 6))
    q[:40, 0] = rng.uniform(1.0, 2.5, 40) * rng.choice([-1, 1], 40)
    q[40:, 5] = rng.uniform(0.7, 2.5, 40) * rng.choice([-1, 1], 40)
    T = arm.fkine(q)
    old = C.BOX_TESTS
    try:
        C.BOX_TESTS = 0
        before = joint_certificate(arm, T)
    finally:
        C.BOX_TESTS = old
    after = joint_certificate(arm, T)
    assert not before.any()
    assert after[:40].sum() >= 20 and after[40:].sum() >= 4
    assert not wsmap.reachable(arm, T[after], starts=256, seed=5).any()


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_the_search_skipping_certified_border_nodes_finds_the_same_map(name, monkeypatch):
    from wsmap.kinematics.ik import search

    arm = robots.load(name)
    nodes = ws.cartesian_grid(-1, 1, 0.2)
    before = ws.constant_orientation_map(arm, nodes, (np.pi, 0, 0))
    seen = []
    real = search.joint_certificate

    def spy(*args, **kwargs):
        out = real(*args, **kwargs)
        seen.append(int(out.sum()))
        return out

    monkeypatch.setattr(search, "BORDER_CERTIFY_BUDGET", 20_000)
    monkeypatch.setattr(search, "joint_certificate", spy)
    after = ws.constant_orientation_map(arm, nodes, (np.pi, 0, 0))
    np.testing.assert_array_equal(after, before)
    assert sum(seen) > 0  # some border node was skipped


def test_a_node_over_its_orientations():
    status = np.array([[REACHED, CERTIFIED], [CERTIFIED, CERTIFIED], [CERTIFIED, NOT_FOUND], [NOT_FOUND, REACHED]],
                      dtype=np.int8)
    np.testing.assert_array_equal(wsmap.node_status_over(status), [REACHED, CERTIFIED, NOT_FOUND, REACHED])
    assert wsmap.node_status_over(status).dtype == np.int8


@pytest.mark.parametrize("name", ["panda", "ur5e"])
def test_the_reachability_index_status(name):
    # per node and orientation: reached exactly where the index's bits are, certified poses never
    # reached by a 256-start search; per node: certified where every orientation is
    arm = robots.load(name)
    nodes = ws.cartesian_grid(-1, 1, 0.25)
    R = ws.orientation_samples(6)
    index, bits, status, per_node = ws.reachability_index(arm, nodes, R, return_bits=True, return_status=True)
    assert status.shape == bits.shape and status.dtype == np.int8 and per_node.shape == (len(nodes),)
    np.testing.assert_array_equal(status == REACHED, bits)
    np.testing.assert_array_equal(index, bits.mean(axis=1))  # the index itself unchanged
    np.testing.assert_array_equal(per_node, wsmap.node_status_over(status))
    assert (status == CERTIFIED).sum() > 0.9 * (~bits).sum()
    assert ((per_node == CERTIFIED) == (status == CERTIFIED).all(axis=1)).all()
    T = np.zeros(bits.shape + (4, 4))
    T[..., :3, :3], T[..., :3, 3], T[..., 3, 3] = R[None], nodes[:, None], 1.0
    cert = np.flatnonzero((status == CERTIFIED).reshape(-1))
    some = T.reshape(-1, 4, 4)[cert[:: max(1, cert.size // 60)]]
    assert not wsmap.reachable(arm, some, starts=256, seed=7).any()


@pytest.mark.parametrize("name", NUMERICAL)
def test_no_reached_pose_with_an_aligned_last_axis_is_certified(name):
    # the tilt forms act where the last axis is (nearly) along joint 0's: the tool-down poses of the
    # map's own solutions are reachable by construction and must never be certified
    from wsmap.kinematics.ik import certificate as C

    arm = robots.load(name)
    nodes = ws.cartesian_grid(-1, 1, 0.1)
    reached, q = ws.constant_orientation_map(arm, nodes, (np.pi, 0, 0), return_q=True)
    T = arm.fkine(q[reached][::25])
    geo = C._geometry(as_chain(arm))
    tilt = C._pose_invariants(as_chain(arm), geo, T, C.CERTIFY_MARGIN)[0][:, 5]
    assert len(T) >= 20 and (tilt < C.TILT_MAX).all()
    assert not joint_certificate(arm, T).any()


@pytest.mark.parametrize("name, before_tests", [("panda", 15), ("gen3", 63)])
def test_the_new_box_tests_certify_more_of_the_tool_down_nodes(name, before_tests):
    # the tool-down nodes that the filters leave: at the default budget the tilt forms and the
    # shoulder-first split (the Panda: BOX_TESTS 63 against 15 before them), and the near joint of
    # the first pass (the Gen3: 127 against 63) certify more, and a 256-start search reaches none of
    # those
    from wsmap.kinematics.ik import certificate as C
    from wsmap.kinematics.ik.certificate import filter_certificate

    panda = robots.load(name)
    nodes = ws.cartesian_grid(-1, 1, 0.1)
    T = ws.target_poses(nodes, (np.pi, 0, 0), "standard")
    reached = ws.constant_orientation_map(panda, nodes, (np.pi, 0, 0))
    left = np.flatnonzero(~reached & ~filter_certificate(panda, T))
    some = T[left[::4]]
    old = C.BOX_TESTS
    try:
        C.BOX_TESTS = before_tests
        before = joint_certificate(panda, some)
    finally:
        C.BOX_TESTS = old
    after = joint_certificate(panda, some)
    assert after.sum() >= before.sum() + 10
    assert not wsmap.reachable(panda, some[after & ~before][:15], starts=256, seed=11).any()


def test_the_first_pass_bounds_a_near_joint_by_a_turn_and_a_shift():
    # the Gen3's joint 2 misses the shoulder point S by 11.8 mm: in the first pass (d and g alone) the
    # box's bounds leave it out, and d and g of every configuration of the box lie within them plus
    # the shift eps·min(hw, 2) (sampled: 1000 boxes of every size, 20 configurations each)
    from wsmap.kinematics.ik import certificate as C

    robot = robots.load("gen3")
    geo = C._geometry(as_chain(robot))
    ch, n, eps = geo["chain"], robot.n, geo["near"]
    assert np.flatnonzero(eps).tolist() == [2] and 0.011 < eps[2] < 0.0125
    rigid_b = geo["rigid"] | (eps > 0)
    rng = np.random.default_rng(4)
    F, Z, lo, hi = np.empty((n, 14)), np.empty((7, 9)), np.empty(13), np.empty(4)
    G, R = np.empty((7, n)), np.empty(5)
    worst = plain = -1.0
    for _ in range(1000):
        c = rng.uniform(-np.pi, np.pi, n)
        hw = np.zeros(n)
        hw[2:n - 1] = rng.uniform(0, 1, n - 3) * 10.0 ** rng.uniform(-3, 0.5)  # joint 1 rigid: 0 in this pass
        C._box_bounds(ch.fixed, ch.axes, np.broadcast_to(ch.offset, (n,)).astype(float), geo["S"], geo["a0"],
                      geo["w_loc"], geo["radius"], rigid_b, n, c, hw, F, Z, lo, hi, G, R)
        shift = C._near_shift(eps, hw, n)
        frames, _ = ch.joint_frames(c + rng.uniform(-1, 1, (20, n)) * hw)
        last = frames[:, n - 1]
        u = last[:, :3, :3] @ geo["w_loc"] + last[:, :3, 3] - geo["S"]
        z = last[:, :3, :3] @ ch.axes[n - 1]
        dg = np.stack([np.linalg.norm(u, axis=1), np.einsum("ki,ki->k", u, z)])
        out = max(float((dg - hi[:2, None]).max()), float((lo[:2, None] - dg).max()))
        worst = max(worst, out - shift)
        plain = max(plain, out)
    assert worst <= 1e-12
    assert plain > 1e-3  # the bounds alone miss configurations by millimetres: the shift is needed
