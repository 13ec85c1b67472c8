"""The fast Levenberg–Marquardt kernel (wsmap.kinematics.lm_kernel) against the reference implementation it replaced.

Run quickly with ``OMP_NUM_THREADS=1 .venv/bin/python -m pytest tests/test_lm_kernel.py -q``.
"""

import numpy as np
import pytest

from wsmap import robots
from wsmap.kinematics import lm_kernel as _lm
from wsmap import kinematics as K
from wsmap import workspace as ws
from wsmap.kinematics import pose_error
from wsmap.kinematics.dh import _jacob0


# --------------------------------------------------------------------------- the reference
def _reference_lm_chunk(dh, T, q, tool, ilimit, rlimit, tol, lam0):
    """The implementation of ``ikine_LM``'s chunk before wsmap.kinematics.lm_kernel (commit 940f8f8), verbatim:
    array of structures, ``np.linalg.solve`` per target, Jacobian for every trial."""
    m, n = q.shape
    d, a, alpha = dh[..., 0], dh[..., 1], dh[..., 2]
    success = np.zeros(m, dtype=bool)
    iters = np.zeros(m, dtype=np.int64)
    lam = np.full(m, float(lam0))
    rej = np.zeros(m, dtype=np.int64)

    J, Tc = _jacob0(d, a, alpha, q, tool)
    e = pose_error(Tc, T)
    enorm = np.linalg.norm(e, axis=-1)

    active = np.arange(m)  # indices still being solved
    # per-active-target state, compressed as targets leave
    qa, ea, na, Ja = q, e, enorm, J
    la, ra, ia = lam, rej, iters
    da, aa, ala, Ta = d, a, alpha, T
    eye = np.eye(n)

    while active.size:
        ia = ia + 1
        done = na <= tol
        stop = done | (ia > ilimit)
        if stop.any():
            q[active[stop]] = qa[stop]
            success[active[stop]] = done[stop]
            iters[active[stop]] = np.minimum(ia[stop], ilimit)
            enorm[active[stop]] = na[stop]
            keep = ~stop
            active = active[keep]
            qa, ea, na, Ja, la, ra, ia = qa[keep], ea[keep], na[keep], Ja[keep], la[keep], ra[keep], ia[keep]
            da, aa, ala, Ta = da[keep], aa[keep], ala[keep], Ta[keep]
            if not active.size:
                break
        Jt = np.swapaxes(Ja, -1, -2)
        H = Jt @ Ja + (la * la)[:, None, None] * eye
        g = (Jt @ ea[..., None])[..., 0]
        dq = np.linalg.solve(H, g[..., None])[..., 0]
        qn = qa + dq
        Jn, Tn = _jacob0(da, aa, ala, qn, tool)
        en = pose_error(Tn, Ta)
        nn = np.linalg.norm(en, axis=-1)
        better = nn < na
        # accepted: move, relax damping; rejected: stiffen damping, count
        qa = np.where(better[:, None], qn, qa)
        ea = np.where(better[:, None], en, ea)
        na = np.where(better, nn, na)
        Ja = np.where(better[:, None, None], Jn, Ja)
        la = np.where(better, la * 0.5, la * 2.0)
        ra = np.where(better, 0, ra + 1)
        failed = ra > rlimit
        if failed.any():
            idx = active[failed]
            q[idx] = qa[failed]
            success[idx] = False
            iters[idx] = ia[failed]
            enorm[idx] = na[failed]
            keep = ~failed
            active = active[keep]
            qa, ea, na, Ja, la, ra, ia = qa[keep], ea[keep], na[keep], Ja[keep], la[keep], ra[keep], ia[keep]
            da, aa, ala, Ta = da[keep], aa[keep], ala[keep], Ta[keep]
    return q, success, iters, enorm


def _inputs(robot, T, q0=None):
    T = np.asarray(T, dtype=np.float64)
    m = T.shape[0]
    dh = np.ascontiguousarray(np.broadcast_to(robot.dh, (m, robot.n, 3)))
    q0 = np.zeros((m, robot.n)) if q0 is None else np.asarray(q0, dtype=np.float64)
    return dh, T, q0


def _both(robot, T, q0=None, ilimit=500, rlimit=100, tol=1e-10, lam=0.1, **kw):
    dh, T, q0 = _inputs(robot, T, q0)
    ref = _reference_lm_chunk(dh, T, q0.copy(), robot.tool, ilimit, rlimit, tol, lam)
    new = _lm.lm_chunk(dh, T, q0, robot.tool, ilimit, rlimit, tol, lam, **kw)
    return ref, new


# --------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def puma():
    return robots.puma560()


@pytest.fixture(scope="module")
def grid_sample():
    """300 nodes of the paper's 21³ grid (about a third reachable), paper convention, rpy = 0."""
    nodes = ws.cartesian_grid(-1.0, 1.0, 0.1)
    pick = np.random.default_rng(11).choice(len(nodes), 300, replace=False)
    return ws.target_poses(nodes[pick], np.zeros(3))


@pytest.fixture(scope="module")
def unreachable(puma, grid_sample):
    exact = K.wrist_centre_reachable(puma, grid_sample[:, :3, 3])
    return grid_sample[~exact][:60]


# --------------------------------------------------------------------------- agreement with the reference
def test_success_mask_and_converged_iterations_match_reference(puma, grid_sample):
    (q_r, ok_r, it_r, res_r), (q_n, ok_n, it_n, res_n) = _both(puma, grid_sample)
    assert 50 < ok_r.sum() < 250  # a real mix of reachable and unreachable nodes
    np.testing.assert_array_equal(ok_n, ok_r)
    # converged targets follow the same path: rounding differences are far too small to matter
    np.testing.assert_array_equal(it_n[ok_n], it_r[ok_r])
    assert np.all(res_n[ok_n] <= 1e-10)
    # failures stop by the rejection limit or at ilimit; their residual is the local minimum's
    assert np.all(it_n[~ok_n] <= 500) and np.all(it_n[~ok_n] > 100)
    np.testing.assert_allclose(res_n[~ok_n], res_r[~ok_r], rtol=1e-6)
    # the exact map agrees too
    exact = K.wrist_centre_reachable(puma, grid_sample[:, :3, 3])
    assert not np.any(ok_n & ~exact)


def test_per_target_arms_and_a_tool_match_reference():
    rng = np.random.default_rng(3)
    arms = robots.sample_arbitrary_6dof(120, seed=4)
    tool = K.transl([0.01, -0.02, 0.05])
    tool[:3, :3] = K.rpy2r([0.1, -0.2, 0.3])
    arms = K.DHRobot(arms.d, arms.a, arms.alpha, tool=tool)
    q_true = rng.uniform(-np.pi, np.pi, (120, 6))
    T = arms.fkine(q_true)
    T[60:, :3, 3] *= 3.0  # half of them moved out of reach
    dh = arms.dh
    q0 = np.zeros((120, 6))
    q_r, ok_r, it_r, _ = _reference_lm_chunk(dh, T, q0.copy(), tool, 500, 100, 1e-10, 0.1)
    q_n, ok_n, it_n, _ = _lm.lm_chunk(dh, T, q0, tool, 500, 100, 1e-10, 0.1)
    np.testing.assert_array_equal(ok_n, ok_r)
    np.testing.assert_array_equal(it_n[ok_n], it_r[ok_r])
    assert ok_n[:60].sum() > 20 and not ok_n[60:].any()
    # one trial per loop (the path of large batches) gives the same bits as speculation
    one = _lm.lm_chunk(dh, T, q0, tool, 500, 100, 1e-10, 0.1, max_depth=1)
    for a, b in zip(one, (q_n, ok_n, it_n)):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("ilimit,rlimit", [(0, 100), (1, 100), (2, 0), (3, 1), (6, 2), (12, 0), (40, 3)])
def test_small_limits_match_reference(puma, grid_sample, ilimit, rlimit):
    (q_r, ok_r, it_r, res_r), (q_n, ok_n, it_n, res_n) = _both(puma, grid_sample[:120], ilimit=ilimit, rlimit=rlimit)
    np.testing.assert_array_equal(ok_n, ok_r)
    assert np.all(it_n <= ilimit)
    np.testing.assert_array_equal(it_n[ok_n], it_r[ok_r])
    if ilimit <= 12:
        # within a dozen iterations no unreachable target has reached the local minimum, where
        # accepting or rejecting depends on rounding, so every count and iterate agrees
        np.testing.assert_array_equal(it_n, it_r)
        np.testing.assert_allclose(q_n, q_r, atol=1e-9)
        np.testing.assert_allclose(res_n, res_r, rtol=1e-9, atol=1e-15)


def test_target_at_start_pose_succeeds_at_first_iteration(puma):
    T = puma.fkine(np.zeros(6))[None]
    for ilimit, expected in ((0, 0), (1, 1), (500, 1)):
        q, ok, it, res = _lm.lm_chunk(*_inputs(puma, T), None, ilimit, 100, 1e-10, 0.1)
        assert ok[0] and it[0] == expected and res[0] == 0.0


# --------------------------------------------------------------------------- exactness of the shortcuts
def test_stagnation_shortcut_changes_no_result(puma, unreachable):
    dh, T, q0 = _inputs(puma, unreachable)
    on = _lm.lm_chunk(dh, T, q0, None, 500, 100, 1e-10, 0.1, shortcut=True)
    off = _lm.lm_chunk(dh, T, q0, None, 500, 100, 1e-10, 0.1, shortcut=False)
    for a, b in zip(on, off):
        np.testing.assert_array_equal(a, b)
    assert not on[1].any()


def test_stagnation_shortcut_is_taken(puma, unreachable, monkeypatch):
    taken = []
    original = _lm._Kernel.stagnated

    def spy(self, blk):
        out = original(self, blk)
        taken.append(int(out.sum()))
        return out

    monkeypatch.setattr(_lm._Kernel, "stagnated", spy)
    _lm.lm_chunk(*_inputs(puma, unreachable), None, 500, 100, 1e-10, 0.1)
    assert sum(taken) > len(unreachable) // 2


def test_stagnation_shortcut_near_the_limits(puma, unreachable):
    # the closed form min(i + rlimit − r, ilimit) at both limits
    dh, T, q0 = _inputs(puma, unreachable)
    for ilimit, rlimit in ((60, 100), (120, 30), (200, 45)):
        on = _lm.lm_chunk(dh, T, q0, None, ilimit, rlimit, 1e-10, 0.1, shortcut=True)
        off = _lm.lm_chunk(dh, T, q0, None, ilimit, rlimit, 1e-10, 0.1, shortcut=False)
        np.testing.assert_array_equal(on[2], off[2])
        np.testing.assert_array_equal(on[0], off[0])


def test_speculation_and_threads_change_no_result(puma, grid_sample):
    dh, T, q0 = _inputs(puma, grid_sample)
    base = _lm.lm_chunk(dh, T, q0, None, 500, 100, 1e-10, 0.1, max_depth=1, threads=1)
    for kw in (dict(max_depth=4, threads=1), dict(max_depth=8, threads=2, merge_below=40)):
        other = _lm.lm_chunk(dh, T, q0, None, 500, 100, 1e-10, 0.1, **kw)
        for a, b in zip(base, other):
            np.testing.assert_array_equal(a, b)


def test_numpy_trigonometry_gives_the_same_success(puma, grid_sample):
    dh, T, q0 = _inputs(puma, grid_sample[:150])
    a = _lm.lm_chunk(dh, T, q0, None, 500, 100, 1e-10, 0.1, use_torch=False)
    b = _lm.lm_chunk(dh, T, q0, None, 500, 100, 1e-10, 0.1, use_torch=True)
    np.testing.assert_array_equal(a[1], b[1])


# --------------------------------------------------------------------------- through the public API
def test_round_trip_on_random_reachable_poses():
    rng = np.random.default_rng(21)
    arms = robots.sample_spherical_wrist(200, seed=22)
    q_true = rng.uniform(-np.pi, np.pi, (200, 6))
    T = arms.fkine(q_true)
    res = arms.ikine_LM(T, q0=q_true + rng.normal(0.0, 0.3, q_true.shape))
    assert res.success.mean() > 0.9
    ok = res.success
    np.testing.assert_allclose(arms[ok].fkine(res.q[ok]), T[ok], atol=1e-9)
    assert np.all(res.residual[ok] <= 1e-10)
    assert res.q.shape == (200, 6) and res.iterations.dtype == np.int64


def test_chunks_and_progress_are_kept(puma, grid_sample):
    seen = []
    whole = K.ikine_LM(puma, grid_sample[:90])
    parts = K.ikine_LM(puma, grid_sample[:90], chunk=32, progress=seen.append)
    assert seen == [32, 32, 26]
    # a target's arithmetic does not depend on the other targets in its chunk: identical bits
    for a, b in zip((whole.q, whole.success, whole.iterations, whole.residual),
                    (parts.q, parts.success, parts.iterations, parts.residual)):
        np.testing.assert_array_equal(a, b)
    one = K.ikine_LM(puma, grid_sample[7])
    assert one.iterations == whole.iterations[7] and np.array_equal(one.q, whole.q[7])


def test_default_threads_reads_the_environment(monkeypatch):
    monkeypatch.setenv("WSMAP_LM_THREADS", "3")
    assert _lm.default_threads() == 3
    monkeypatch.delenv("WSMAP_LM_THREADS")
    assert _lm.default_threads() == 1


def test_torch_threads_are_restored(puma, grid_sample):
    torch = pytest.importorskip("torch")
    before = torch.get_num_threads()
    try:
        torch.set_num_threads(2)
        _lm.lm_chunk(*_inputs(puma, grid_sample[:20]), None, 500, 100, 1e-10, 0.1)
        assert torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(before)
