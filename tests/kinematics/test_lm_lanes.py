"""The lane (SIMD) kernel against the scalar numba kernel, its tested reference.

The two run the same search with the same arithmetic per target; the compilers fuse multiply-adds
differently, so the answers agree to rounding: the same successes, the same succeeding starts and
failure reasons, ``q`` within 1e-8 where both succeed. A target's answer does not depend on its
lane, its neighbours, the lane count or the thread count (bit for bit).
"""

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from frames import random_chain
from wsmap import robots
from wsmap import workspace as ws
from wsmap.kinematics import as_chain, ikine_LM, ikine_search, lm_compiled, lm_lanes, map_search
from wsmap.kinematics import from_dh
from wsmap.kinematics.ik import kernel as ik_kernel
from wsmap.workspace.maps import _per_node

PI = np.pi


@pytest.fixture(autouse=True)
def _restore():
    threads, kernel = lm_compiled.threads(), lm_lanes.kernel()
    yield
    lm_compiled.set_threads(threads)
    lm_lanes.set_kernel(kernel)


def both(fn):
    """``fn()`` on the lane kernel and on the scalar one."""
    with lm_lanes.use_kernel("lanes"):
        a = fn()
    with lm_lanes.use_kernel("scalar"):
        b = fn()
    return a, b


def assert_agree(a, b, min_success=10):
    assert a.success.sum() >= min_success
    np.testing.assert_array_equal(a.success, b.success)
    np.testing.assert_array_equal(a.start, b.start)
    np.testing.assert_array_equal(a.reason, b.reason)
    ok = a.success
    # the same solution (angles modulo a turn: an unlimited joint may end on +pi or -pi) for nearly
    # every target; a redundant arm's run may part ways after a rounding difference and end
    # elsewhere on the same self-motion manifold (both confirmed by forward kinematics)
    d = np.abs(np.angle(np.exp(1j * (a.q[ok] - b.q[ok])))).max(axis=1)
    assert (d <= 1e-8).mean() >= 0.98, f"{(d > 1e-8).sum()} of {ok.sum()} solutions differ"
    # the same path, iteration for iteration, for nearly every target solved (a failed run's length
    # is chaotic: where it wanders, a rounding difference changes when it stops)
    first = ok & (a.start == 0)
    same = (a.iterations == b.iterations)[first].mean()
    assert same > 0.85, f"iteration counts agree on {same:.1%} of the targets solved by the first start"


def test_the_extension_is_built_and_the_default():
    # CI builds the package from source: a broken C++ build must fail here, not fall back quietly
    assert lm_lanes.available()
    assert lm_lanes.isa() in ("avx512", "avx2", "base")
    with pytest.MonkeyPatch.context() as mp:
        mp.delenv("WSMAP_KERNEL", raising=False)
        assert lm_lanes.set_kernel() == "lanes"
    assert lm_lanes.runs_on_lanes(7) and not lm_lanes.runs_on_lanes(lm_lanes.MAX_JOINTS + 1)


@pytest.mark.parametrize("name, lim, rpy", [("puma560", True, (0, 0, 0)), ("puma560", False, (PI, 0, 0)),
                                            ("ur5e", None, (PI, 0, 0)), ("panda", None, (PI, 0, 0)),
                                            ("iiwa14", None, (0.3, -0.2, 0.5)), ("gen3", None, (0.3, -0.2, 0.5))])
def test_search_agrees_with_the_scalar_kernel(name, lim, rpy):
    arm = robots.load(name, joint_limits=lim)
    T = ws.target_poses(ws.cartesian_grid(-1.2, 1.2, 0.2), rpy, "standard")
    a, b = both(lambda: ikine_search(arm, T, starts=6, seed=3))
    assert_agree(a, b)
    for s in (a, b):
        np.testing.assert_allclose(as_chain(arm).fkine(s.q[s.success]), T[s.success], atol=1e-6)


def test_position_only_and_the_paper_lm_agree():
    arm = robots.load("panda")
    T = ws.target_poses(ws.cartesian_grid(-1.2, 1.2, 0.2), (0, 0, 0), "standard")
    a, b = both(lambda: ikine_search(arm, T, starts=3, seed=1, position_only=True))
    assert_agree(a, b)
    # the paper's one-start LM, a batch of arms whose fixed rotations differ from arm to arm
    arms = robots.sample_spherical_wrist(4, seed=5)
    T = ws.target_poses(ws.cartesian_grid(-1, 1, 0.2), (0.3, 0.2, 0.1), "paper")
    a, b = both(lambda: ikine_LM(_per_node(arms), T))
    assert a.success.sum() > 100
    np.testing.assert_array_equal(a.success, b.success)
    np.testing.assert_array_equal(a.iterations[a.success], b.iterations[b.success])
    np.testing.assert_allclose(a.q[a.success], b.q[b.success], atol=1e-9)


def test_random_chains_prismatic_joints_and_a_batch_of_arms():
    rng = np.random.default_rng(11)
    # joints about arbitrary axes (Rodrigues), fixed rotations of every kind, unlimited joints
    for n in (3, 6, 7, 9):
        chain = random_chain(rng, n, unlimited=0.3)
        q = chain.random_q(150, rng)
        T = np.concatenate([np.asarray(chain.fkine(q)), ws.target_poses(rng.uniform(-1, 1, (50, 3)), (0, 0, 0),
                                                                           "standard")])
        a, b = both(lambda: ikine_search(chain, T, starts=4, seed=n))
        assert_agree(a, b, min_success=100)
    # a prismatic joint with limits
    gantry = from_dh([0.3, 0.0, 0.2, 0.0], [0.0, 0.4, 0.0, 0.1], [PI / 2, 0.0, PI / 2, 0.0],
                     prismatic=[False, False, True, False], qlim=[(-3, 3), (-2, 2), (0.05, 0.6), (-3, 3)])
    q = gantry.random_q(200, rng)
    T = np.asarray(gantry.fkine(q))
    a, b = both(lambda: ikine_search(gantry, T, starts=4, seed=2, position_only=True))
    assert_agree(a, b, min_success=150)
    # a batch of arms in one call: the lanes hold different arms at once
    arms = robots.sample_spherical_wrist(5, seed=8)
    nodes = ws.cartesian_grid(-1, 1, 0.25)
    T = ws.target_poses(nodes, (0.2, 0.1, 0.0), "standard")
    a, b = both(lambda: map_search(arms, T, ws.node_neighbours(nodes)))
    np.testing.assert_array_equal(a.success, b.success)
    np.testing.assert_allclose(a.q[a.success], b.q[b.success], atol=1e-8)


def test_a_huge_start_angle_takes_libms_sine():
    # beyond |x| = 1e5 the polynomials do not hold; both kernels take libm's values there
    arm = robots.load("puma560", joint_limits=False)
    T = np.asarray(arm.fkine(np.array([0.3, -0.5, 0.4, 0.2, 0.6, -0.3])))[None]
    q0 = np.full(6, 2.0e5)
    a, b = both(lambda: ikine_search(arm, T, starts=1, q0=q0, joint_limits=False))
    assert a.success[0] and b.success[0]
    np.testing.assert_allclose(a.q, b.q, atol=1e-8)


def test_a_half_turn_from_the_start_agrees():
    # targets a half turn about each axis of the start's tool frame: at the start the rotation
    # error's sine is 0 and its cosine -1, so the error's axis comes from the largest diagonal entry,
    # lane by lane (the register-blocked iteration of 6 and 7 joints, and the array one of 3)
    rng = np.random.default_rng(5)
    for arm, min_success in ((robots.load("puma560"), 3), (robots.load("panda"), 3), (random_chain(rng, 3), 0)):
        lim = np.asarray(as_chain(arm).limits)
        finite = np.isfinite(lim).all(axis=1)
        q0 = np.full(arm.n, 0.3)
        q0[finite] = lim[finite].mean(axis=1)
        T0 = np.asarray(arm.fkine(q0))
        T = np.repeat(T0[None], 6, axis=0)
        for k, flip in enumerate(([1.0, -1, -1], [-1.0, 1, -1], [-1.0, -1, 1]) * 2):
            T[k, :3, :3] = T0[:3, :3] @ np.diag(flip)
        T[3:, :3, 3] += 0.02  # and a small move of the tool
        a, b = both(lambda: ikine_search(arm, T, starts=3, q0=q0, seed=1))  # noqa: B023 - called at once
        np.testing.assert_array_equal(a.success, b.success)
        np.testing.assert_array_equal(a.start, b.start)
        np.testing.assert_array_equal(a.reason, b.reason)
        assert a.success.sum() >= min_success
        ok = a.success
        np.testing.assert_allclose(a.q[ok], b.q[ok], atol=1e-8)


def test_answers_do_not_depend_on_lanes_threads_or_order():
    arm = robots.load("panda")
    T = ws.target_poses(ws.cartesian_grid(-1, 1, 0.2), (PI, 0, 0), "standard")
    aa = ik_kernel.arm_arrays(as_chain(arm))
    keys = ik_kernel.pose_keys(0, T)
    M, n = len(T), arm.n
    qexp = np.zeros((M, 1, n))
    nexp = np.ones(M, dtype=np.int64)

    settings = lm_compiled.LMSettings(lm_compiled.MODE_SEARCH, 0, 3, 100, 20, 1e-10, 0.1, 1e-9, 1e-6, True)

    def targets_of(order):
        return lm_compiled.Targets(np.zeros(M, dtype=np.int64), np.ascontiguousarray(T[order, :3, :3]),
                                   np.ascontiguousarray(T[order, :3, 3]), keys[order], qexp, nexp)

    def run(order, lanes, threads, isa="auto"):
        out = lm_compiled.Answers(*ik_kernel.unsolved(M, n))
        lm_compiled.set_threads(threads)
        lm_lanes.run_targets(lm_compiled.KernelCall(targets_of(order), aa, settings, out), lanes=lanes, isa=isa)
        back = np.argsort(order)
        return tuple(x[back] for x in out)

    ident = np.arange(M)
    ref = run(ident, 8, 1)
    assert ref[1].sum() > 100
    perm = np.random.default_rng(0).permutation(M)
    for got in (run(perm, 8, 1), run(ident, 4, 1), run(perm, 16, 2), run(ident, 8, 2)):
        for x, y in zip(got, ref):
            np.testing.assert_array_equal(x, y)
    # the extension's own threads (three on this machine's two cores too), and two Python threads
    # calling it at once with one counter, two threads each: every target taken once, the same answers
    for lanes, threads in ((8, 3), (4, 2)):
        out = lm_compiled.Answers(*ik_kernel.unsolved(M, n))
        call = lm_compiled.KernelCall(targets_of(ident), aa, settings, out)
        lm_lanes._lanes.run_targets(call, np.zeros(1, dtype=np.int64), lanes, "auto", threads)
        for x, y in zip(out, ref):
            np.testing.assert_array_equal(x, y)
    out = lm_compiled.Answers(*ik_kernel.unsolved(M, n))
    call, counter = lm_compiled.KernelCall(targets_of(ident), aa, settings, out), np.zeros(1, dtype=np.int64)
    with ThreadPoolExecutor(2) as pool:
        for f in [pool.submit(lm_lanes._lanes.run_targets, call, counter, 8, "auto", 2) for _ in range(2)]:
            f.result()
    for x, y in zip(out, ref):
        np.testing.assert_array_equal(x, y)
    # the narrower builds: the same search to rounding
    for isa in ("avx2", "base"):
        if isa == "avx2" and lm_lanes.isa() == "base":
            continue
        got = run(ident, 8, 1, isa)
        np.testing.assert_array_equal(got[1], ref[1])
        np.testing.assert_allclose(got[0][ref[1]], ref[0][ref[1]], atol=1e-8)


def test_bad_input():
    with pytest.raises(ValueError, match="^kernel must be one of lanes, scalar, not 'fast'"):
        lm_lanes.set_kernel("fast")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("WSMAP_KERNEL", "fast")
        with pytest.raises(ValueError, match="^WSMAP_KERNEL must be one of lanes, scalar, not 'fast'"):
            lm_lanes.set_kernel()
    with pytest.raises(ValueError, match="isa must be 'auto', 'avx512', 'avx2' or 'base', not 'sse9'"):
        _call_with(isa="sse9")
    with pytest.raises(ValueError, match="lanes must be 4, 8 or 16"):
        _call_with(lanes=5)
    with pytest.raises(ValueError, match="^threads must be 1 to 1024, not 0$"):
        _call_with(threads=0)
    with pytest.raises(ValueError, match="targets.Rt has 9 elements, not 18"):
        _call_with(targets={"Rt": np.zeros((1, 3, 3))})
    with pytest.raises(ValueError, match="arm index out of range"):
        _call_with(targets={"arm": np.array([0, 3], dtype=np.int64)})
    # a field of the wrong type is named, not copied or converted (the out arrays are written in place)
    with pytest.raises(ValueError, match="^arms.off must be a C-contiguous float64 numpy array$"):
        _call_with(arms={"off": np.zeros((1, 6), dtype=np.float32)})
    with pytest.raises(ValueError, match="^out.q must be a C-contiguous float64 writable numpy array$"):
        _call_with(out={"q": np.zeros((6, 2)).T})
    with pytest.raises(ValueError, match="^settings.tol must be a Python float$"):
        _call_with(settings={"tol": 1})


def _call_with(lanes=8, isa="auto", threads=1, **over):
    """One call of the extension on two targets of the PUMA560, with the fields of each group of
    ``over`` (``targets={"Rt": ...}``) replacing those of the call."""
    M, n = 2, 6
    call = lm_compiled.KernelCall(
        targets=lm_compiled.Targets(arm=np.zeros(M, dtype=np.int64), Rt=np.tile(np.eye(3), (M, 1, 1)),
                                    pt=np.zeros((M, 3)), keys=np.zeros(M, dtype=np.uint64), qexp=np.zeros((M, 1, n)),
                                    nexp=np.ones(M, dtype=np.int64)),
        arms=ik_kernel.arm_arrays(as_chain(robots.load("puma560"))),
        settings=lm_compiled.LMSettings(mode=0, k_first=0, k_last=0, ilimit=10, rlimit=5, tol=1e-10, lam0=0.1,
                                        gtol=0.0, confirm_tol=1e-6, free_pass=True),
        out=lm_compiled.Answers(*ik_kernel.unsolved(M, n)))
    call = call._replace(**{group: getattr(call, group)._replace(**fields) for group, fields in over.items()})
    lm_lanes._lanes.run_targets(call, np.zeros(1, dtype=np.int64), lanes, isa, threads)


def test_the_lane_table_names_every_field_of_a_kernel_call():
    # lanes.hpp's table and lm_compiled.KernelCall: the same fields (a new LM setting is a field of
    # LMSettings and a line of the table); an extension built from other sources is not used
    assert sorted(lm_lanes._lanes.FIELDS) == sorted(lm_compiled.call_fields())
    assert len(lm_compiled.call_fields()) == len(set(lm_compiled.call_fields()))
    assert "settings.lam0" in lm_compiled.call_fields() and "arms.Rf" in lm_compiled.call_fields()


def test_the_lanes_atan2_is_within_two_ulp_of_libm():
    # the rotation angle of the pose error: atan2(|v|, (tr - 1) / 2), y >= 0, branch-free in the lanes
    rng = np.random.default_rng(4)
    y = np.concatenate([rng.uniform(0, 1.5, 20000), 10.0 ** rng.uniform(-300, 0, 2000), [0, 0, 1, 1e-12, 1, 2]])
    x = np.concatenate([rng.uniform(-1.5, 1.5, 20000), rng.uniform(-1, 1, 2000), [1, -1, 0, -1, -1e-12, 2]])
    ref = np.arctan2(y, x)
    isas = ["base"] + (["avx2"] if lm_lanes.isa() in ("avx2", "avx512") else []) + (["avx512"] if lm_lanes.isa() == "avx512" else [])
    for isa in isas:
        out = np.empty_like(x)
        lm_lanes._lanes.atan2(y, x, out, isa)
        assert (np.abs(out - ref) <= 2 * np.spacing(np.abs(ref))).all(), isa
        assert out[-6] == 0.0 and out[-5] == np.pi and out[-4] == np.pi / 2
    out = np.empty(2)
    lm_lanes._lanes.atan2(np.array([np.nan, 1.0]), np.array([1.0, np.nan]), out, "auto")
    assert np.isnan(out).all()
