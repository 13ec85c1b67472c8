"""The reach study's computation (`wsmap.workspace.study`), its scores and its file."""

from __future__ import annotations

import numpy as np
import pytest

from wsmap import robots, workspace as ws
from wsmap.kinematics.ik.search import ikine_search
from wsmap.workspace import scores as sc
from wsmap.workspace import study as st
from wsmap.workspace.study_files import StudyFileError, compare_studies, load_study, save_study


def _reachable_targets(arm, count, seed=0):
    """Tool poses of random configurations inside the limits: every one is reachable."""
    rng = np.random.default_rng(seed)
    lim = np.clip(np.asarray(arm.qlim), -np.pi, np.pi)
    q = rng.uniform(lim[:, 0], lim[:, 1], (count, arm.n))
    return arm.fkine(q)


def _targets_set(T):
    from wsmap.workspace.workpiece import TargetSet

    return TargetSet(points=T[:, :3, 3].copy(), normals=-T[:, :3, 2].copy(), poses=T, moved=np.zeros(len(T)),
                     vertices=None, faces=None, source="test")


# ------------------------------------------------------------------------------------ variants
def test_tool_variants_turn_about_the_tool_axis_and_tilt_within_the_cone():
    V = st.tool_variants(turns=4, cone=0.3, rings=2, per_ring=5)
    assert V.shape == (4 * (1 + 2 * 5), 4, 4)
    np.testing.assert_allclose(V[0], np.eye(4))
    R = V[:, :3, :3]
    np.testing.assert_allclose(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
    tilt = np.degrees(np.arccos(np.clip(R[:, 2, 2], -1, 1)))  # the angle of the tool's z from the target's
    assert set(np.round(tilt, 6)) == {0.0, round(np.degrees(0.15), 6), round(np.degrees(0.3), 6)}
    turns = st.tool_variants(turns=8)
    np.testing.assert_allclose(turns[:, :3, 2], np.tile([0, 0, 1.0], (8, 1)), atol=1e-12)  # z axis kept
    np.testing.assert_allclose(np.arctan2(turns[:, 1, 0], turns[:, 0, 0]) % (2 * np.pi), 2 * np.pi * np.arange(8) / 8,
                               atol=1e-12)


@pytest.mark.parametrize("kw, message", [
    (dict(turns=0), "turns must be an integer of at least 1"),
    (dict(cone=-0.1), "the cone's half-angle must be in [0, pi/2)"),
    (dict(cone=float("nan")), "the cone's half-angle"),
    (dict(rings=2), "rings of tilts need a cone half-angle above 0"),
])
def test_bad_tool_variants(kw, message):
    with pytest.raises(ValueError) as e:
        st.tool_variants(**kw)
    assert str(e.value).startswith(message)


# ---------------------------------------------------------------------------------- evaluation
@pytest.mark.parametrize("name", ["ur5e", "panda"])
def test_every_reachable_target_is_reached_with_a_confirmed_solution(name):
    arm = robots.load(name)
    T = _reachable_targets(arm, 60)
    res = st.evaluate_targets(arm, T, variants=st.tool_variants(turns=1))
    assert res.reached.all() and res.unconfirmed == 0
    F = arm.fkine(res.q)  # FK confirmation, inside the limits
    np.testing.assert_allclose(F, T, atol=2e-6)
    assert arm.within_limits(res.q).all()
    for name_ in ("manipulability", "joint_margin"):
        assert np.all(res.scores[name_] >= 0)
    np.testing.assert_allclose(res.score, res.scores["manipulability"] * res.scores["joint_margin"])


def test_targets_out_of_reach_are_certified_and_others_not():
    arm = robots.load("ur5e")
    far = ws.target_poses(np.array([[2.5, 0, 0.2], [0, -3, 1]]), (np.pi, 0, 0))
    near = _reachable_targets(arm, 5)
    res = st.evaluate_targets(arm, np.concatenate([far, near]), variants=st.tool_variants(turns=4))
    assert list(res.status) == [st.CERTIFIED] * 2 + [st.REACHED] * 5
    assert np.isnan(res.q[:2]).all() and (res.variant[:2] == -1).all() and np.isnan(res.score[:2]).all()


def test_a_certified_target_is_never_reached_by_a_256_start_search():
    arm = robots.load("panda")
    rng = np.random.default_rng(3)
    P = rng.uniform(-1.1, 1.1, (120, 3))
    T = ws.target_poses(P, (np.pi, 0, 0))
    res = st.evaluate_targets(arm, T, variants=st.tool_variants(turns=2))
    cert = res.status == st.CERTIFIED
    assert cert.sum() >= 10  # the box holds many targets out of reach
    E = st.end_poses(T[cert], np.eye(4), st.tool_variants(turns=2), np.eye(4)).reshape(-1, 4, 4)
    assert not ikine_search(arm, E, starts=256, seed=1).success.any()


def test_targets_only_the_branch_and_bound_proves_out_of_reach_are_certified():
    # border nodes of the Panda's tool-down map that the sound filters leave: the study certifies
    # them with the branch and bound, as a map's status does; reachable targets beside them are
    # reached, never certified; no certified one is reached by a 256-start search
    from wsmap.kinematics.ik.certificate import filter_certificate, joint_certificate

    arm = robots.load("panda")
    nodes = ws.cartesian_grid(-1, 1, 0.1)
    T = ws.target_poses(nodes, (np.pi, 0, 0))
    reached = ws.constant_orientation_map(arm, nodes, (np.pi, 0, 0))
    left = np.flatnonzero(~reached & ~filter_certificate(arm, T))
    some = left[::6]
    proved = some[joint_certificate(arm, T[some])]  # proved by the branch and bound alone
    assert proved.size >= 5
    targets = np.concatenate([T[proved[:8]], _reachable_targets(arm, 5, seed=4)])
    res = st.evaluate_targets(arm, targets, variants=st.tool_variants(turns=1))
    k = min(8, proved.size)
    assert list(res.status) == [st.CERTIFIED] * k + [st.REACHED] * 5
    assert not ikine_search(arm, T[proved[:8]], starts=256, seed=2).success.any()


def test_solutions_outside_the_limits_by_a_turn_are_moved_inside():
    arm = robots.load("ur5e")
    lim = np.asarray(arm.qlim).copy()
    lim[0] = [1.0, 5.0]  # joint 1 between 1 and 5 rad: the closed form's atan2 answers in (-pi, pi]
    narrow = arm.replace(qlim=lim)
    q = np.random.default_rng(4).uniform(np.maximum(lim[:, 0], -np.pi), np.minimum(lim[:, 1], np.pi), (40, 6))
    q[:, 0] = np.random.default_rng(5).uniform(1.0, 5.0, 40)
    res = st.evaluate_targets(narrow, narrow.fkine(q))
    assert res.reached.all()
    assert narrow.within_limits(res.q).all()
    assert (res.q[:, 0] > np.pi).any()  # some answers needed the turn


def test_fit_to_limits_moves_only_by_whole_turns():
    arm = robots.load("ur5e")
    q = np.array([[-3.0, 0, 0, 0, 0, 7.0]])
    lim = np.asarray(arm.qlim).copy()
    lim[0], lim[5] = [0.0, 6.0], [-1.0, 1.0]
    out = st.fit_to_limits(arm.replace(qlim=lim), q)
    np.testing.assert_allclose(out, [[-3.0 + 2 * np.pi, 0, 0, 0, 0, 7.0 - 2 * np.pi]])


# ------------------------------------------------------------------------------------- scores
def test_manipulability_is_yoshikawas_on_a_finite_difference_jacobian():
    arm = robots.load("ur5e")
    q = np.random.default_rng(6).uniform(-2, 2, (7, 6))
    h = 1e-6
    T0 = arm.fkine(q)
    J = np.zeros((len(q), 6, 6))
    for j in range(6):
        dq = np.zeros(6)
        dq[j] = h
        T1 = arm.fkine(q + dq)
        J[:, :3, j] = (T1[:, :3, 3] - T0[:, :3, 3]) / h
        dR = T1[:, :3, :3] @ np.swapaxes(T0[:, :3, :3], 1, 2)
        J[:, 3:, j] = np.stack([dR[:, 2, 1] - dR[:, 1, 2], dR[:, 0, 2] - dR[:, 2, 0], dR[:, 1, 0] - dR[:, 0, 1]], 1) / (2 * h)
    expected = np.sqrt(np.abs(np.linalg.det(J @ np.swapaxes(J, 1, 2))))
    np.testing.assert_allclose(sc.manipulability(arm, q), expected, rtol=1e-4)


def test_joint_margin_is_one_in_the_middle_and_zero_at_a_limit():
    arm = robots.load("panda")
    mid = np.asarray(arm.qlim).mean(axis=1)
    at = mid.copy()
    at[3] = arm.qlim[3][1]
    half = mid.copy()
    half[2] = mid[2] + (arm.qlim[2][1] - arm.qlim[2][0]) / 4
    np.testing.assert_allclose(sc.joint_margin(arm, np.stack([mid, at, half])), [1.0, 0.0, 0.5])
    assert sc.joint_margin(arm.replace(qlim=None), mid[None]).tolist() == [1.0]
    with pytest.raises(ValueError, match=r"^joint solutions must have shape \(M, 7\)"):
        sc.joint_margin(arm, mid)
    with pytest.raises(ValueError, match="^joint solutions must be finite"):
        sc.manipulability(arm, np.full((1, 7), np.nan))


# ------------------------------------------------------------------------------- base ranking
def test_the_base_ranking_is_the_brute_force_ranking():
    arm = robots.load("ur5e")
    T = ws.target_poses(np.array([[0.6, 0.2, 0.1], [0.7, -0.3, 0.2], [0.2, 0.6, 0.0], [1.2, 0.0, 0.1]]),
                        (np.pi, 0, 0))
    region = st.BaseRegion(x=(-0.4, 0.4), y=(-0.4, 0.4), step=0.2, yaws=4)
    V = st.tool_variants(turns=4)
    rk = st.rank_bases(arm, T, region, top=3, variants=V)
    cands = region.candidates()
    centre = np.zeros(2)
    every = sorted((st._key(st.evaluate_targets(arm, T, base=B, variants=V), B, centre, i), i)  # noqa: SLF001
                   for i, B in enumerate(cands))
    np.testing.assert_array_equal(rk.bases, cands[[i for _, i in every[:3]]])
    assert rk.verified <= len(cands)
    assert np.all(rk.bound + 1e-12 >= [r.coverage for r in [st.evaluate_targets(arm, T, base=B, variants=V)
                                                             for B in cands]])


def test_keep_out_zones_and_a_region_with_no_room():
    region = st.BaseRegion(x=(0, 0.2), y=(0, 0.2), step=0.1, yaws=1, keep_out=((0.05, 0.25, -1, 1),))
    assert np.allclose(np.unique(region.candidates()[:, 0, 3]), [0.0])
    with pytest.raises(ValueError, match="^the base region has no room"):
        st.BaseRegion(x=(0, 0.2), y=(0, 0.2), keep_out=((-1, 1, -1, 1),)).candidates()


# -------------------------------------------------------------------------------- study files
def _study(tmp_path, T, base=None):
    from wsmap.workspace.study_files import StudyResult

    arm = robots.load("ur5e")
    res = st.evaluate_targets(arm, T, base=base, variants=st.tool_variants(turns=2))
    return StudyResult(names=["ur5e"], targets=_targets_set(T), results=[[res]], variants=st.tool_variants(turns=2),
                       settings={"seed": 0})


def test_a_study_file_round_trips_and_is_deterministic(tmp_path):
    T = np.concatenate([_reachable_targets(robots.load("ur5e"), 6), ws.target_poses([[3.0, 0, 0]], (0, 0, 0))])
    a, b = tmp_path / "a.npz", tmp_path / "b.npz"
    save_study(a, _study(tmp_path, T))
    save_study(b, _study(tmp_path, T))
    assert a.read_bytes() == b.read_bytes()
    loaded = load_study(a)
    res = loaded.results(0, 0)
    assert loaded.arms == ["ur5e"] and list(res.status) == [st.REACHED] * 6 + [st.CERTIFIED]
    np.testing.assert_array_equal(loaded.arrays["targets/poses"], T)


def test_comparing_two_studies_names_the_targets_gained_and_lost(tmp_path):
    T = ws.target_poses(np.array([[0.3, 0, 0.2], [1.1, 0, 0.2], [-0.5, 0, 0.2]]), (np.pi, 0, 0))
    save_study(tmp_path / "a.npz", _study(tmp_path, T))
    shifted = np.eye(4)
    shifted[0, 3] = 0.5  # the base moved towards the far target, away from the one behind
    save_study(tmp_path / "b.npz", _study(tmp_path, T, base=shifted))
    diff = compare_studies(load_study(tmp_path / "a.npz"), load_study(tmp_path / "b.npz"))
    assert diff["gained"] == [1] and diff["lost"] == [2] and diff["targets"] == 3


def test_a_file_that_is_not_a_study_is_one_line(tmp_path):
    bad = tmp_path / "x.npz"
    bad.write_bytes(b"not a zip")
    with pytest.raises(StudyFileError, match=r"^study file .*: not a readable study file \(BadZipFile"):
        load_study(bad)
    np.savez(tmp_path / "m.npz", a=np.zeros(3))
    with pytest.raises(StudyFileError, match="no study.json"):
        load_study(tmp_path / "m.npz")
