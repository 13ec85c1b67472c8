"""Closed-form IK of the UR family (wsmap.kinematics.ik.closed_forms.ur): round trips through forward
kinematics, agreement with EAIK on the 21³ grid, joint limits, refusals, broadcasting, mounts; the
solver checked against itself on random arms and poses (the reach-only path against the full solve,
the limits against an independent range check, every success against forward kinematics, any
thread count)."""

import numpy as np
import pytest

from wsmap import robots
from wsmap.kinematics import DHRobot, IKReason, SerialChain, from_dh, lm_compiled, rotx, rpy2r
from wsmap.kinematics.ik.closed_forms import ur as closed_form_ur
from wsmap.kinematics.ik.closed_forms.ur import (
    UR_ALPHA,
    ikine_ur,
    is_ur_type,
    require_ur_type,
    ur_parameters,
    ur_reachable,
)
from wsmap.workspace import cartesian_grid

from frames import hom

TWO_PI = 2 * np.pi
QLIM_360 = np.tile([-TWO_PI, TWO_PI], (6, 1))

# UR's published DH (d1, a2, a3, d4, d5, d6), metres
UR_DH = {
    "ur3e": (0.15185, -0.24355, -0.2132, 0.13105, 0.08535, 0.0921),
    "ur5e": (0.1625, -0.425, -0.3922, 0.1333, 0.0997, 0.0996),
    "ur10e": (0.1807, -0.6127, -0.57155, 0.17415, 0.11985, 0.11655),
    "ur16e": (0.1807, -0.4784, -0.36, 0.17415, 0.11985, 0.11655),
}


def _table(d1, a2, a3, d4, d5, d6):
    """UR DH columns d, a, alpha (arrays broadcast over a batch of lengths)."""
    d1, a2, a3, d4, d5, d6 = np.broadcast_arrays(*(np.asarray(x, float) for x in (d1, a2, a3, d4, d5, d6)))
    z = np.zeros_like(d1)
    d = np.stack([d1, z, z, d4, d5, d6], axis=-1)
    a = np.stack([z, a2, a3, z, z, z], axis=-1)
    return d, a, np.broadcast_to(UR_ALPHA, d.shape)


def _ur(name, qlim=QLIM_360) -> SerialChain:
    return from_dh(*_table(*UR_DH[name]), qlim=qlim, name=name)


def _random_rigid(rng, size=()):
    R = rpy2r(rng.uniform(-np.pi, np.pi, size + (3,)))
    T = np.zeros(size + (4, 4))
    T[..., :3, :3], T[..., :3, 3], T[..., 3, 3] = R, rng.uniform(-0.5, 0.5, size + (3,)), 1.0
    return T


def _fk_error(chain, Q, T):
    """Largest entry of |fkine(Q) − T| per branch; Q (..., 8, 6), T (..., 4, 4) → (..., 8)."""
    Tq = chain.fkine(np.moveaxis(Q, -2, 0))  # branches first: the arm batch stays last
    return np.moveaxis(np.abs(Tq - T).max(axis=(-1, -2)), 0, -1)


def _angle_gap(Q, q):
    """Largest joint difference modulo 2·pi between branches Q (..., 8, 6) and q (..., 6) → (..., 8)."""
    d = np.mod(Q - q[..., None, :] + np.pi, TWO_PI) - np.pi
    return np.abs(d).max(axis=-1)


def _check_round_trip(chain, q, fk_tol=1e-9, q_tol=1e-7):
    T = chain.fkine(q)
    sol = ikine_ur(chain, T)
    Q, valid = sol.q, sol.success
    assert Q.shape == T.shape[:-2] + (8, 6) and valid.shape == T.shape[:-2] + (8,)
    assert np.all(np.abs(Q) <= np.pi + 1e-12)
    err = _fk_error(chain, Q, T)
    assert np.all(valid.any(axis=-1)), "a pose reached by q has no valid branch"
    assert err[valid].max() < fk_tol
    gap = np.where(valid, _angle_gap(Q, q), np.inf).min(axis=-1)
    assert gap.max() < q_tol, f"q not recovered: worst gap {gap.max():.3g} rad"
    return Q, valid


# ------------------------------------------------------------------------------------------ round trips
@pytest.mark.parametrize("name", sorted(UR_DH))
def test_round_trip_published_arms(name):
    chain = robots.load(name) if name in robots.ROBOTS else _ur(name)
    assert is_ur_type(chain)
    q = chain.random_q(400, np.random.default_rng(1))
    _check_round_trip(chain, q)


def test_named_tables_are_the_published_ones():
    for name in ("ur5e", "ur10e"):
        p = ur_parameters(robots.load(name))
        d1, a2, a3, d4, d5, d6 = UR_DH[name]
        np.testing.assert_allclose([p.d1, p.a1, p.a2, p.a3, p.d4, p.d5, p.d6], [d1, 0, a2, a3, d4, d5, d6],
                                   atol=1e-15)
        np.testing.assert_array_equal(p.base, np.eye(4))
        np.testing.assert_array_equal(p.flange, np.eye(4))
        np.testing.assert_array_equal(p.sign, np.ones(6))
        np.testing.assert_array_equal(p.shift, np.zeros(6))


def test_round_trip_random_variants_batched():
    # every DH length of each published arm times U(0.7, 1.3): a batch of 32 arms, 40 poses each
    rng = np.random.default_rng(2)
    base = np.array([UR_DH[k] for k in sorted(UR_DH)] * 8)  # (32, 6)
    lengths = base * rng.uniform(0.7, 1.3, base.shape)
    arms = from_dh(*_table(*lengths.T), qlim=QLIM_360)
    assert arms.batch_shape == (32,) and is_ur_type(arms).all()
    q = arms.random_q(40, rng)  # (40, 32, 6)
    _check_round_trip(arms, q)


def test_round_trip_generalised_ur_type():
    # mirrored twists at joints 1, 4, 5, axes -z, joint offsets, d2 + d3, a1, F_6 with a6 and a twist
    rng = np.random.default_rng(3)
    for trial in range(12):
        d1, a2, a3, d4, d5, d6 = np.array(UR_DH["ur10e"]) * rng.uniform(0.7, 1.3, 6)
        flips = rng.integers(0, 2, 3) * 2 - 1
        alpha = UR_ALPHA.copy()
        alpha[[0, 3, 4]] *= flips
        alpha[5] = rng.uniform(-np.pi, np.pi)
        d = [d1, rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), d4, d5, d6]
        a = [rng.uniform(-0.1, 0.1), a2, a3, 0.0, 0.0, rng.uniform(-0.1, 0.1)]
        chain = from_dh(d, a, alpha, offset=rng.uniform(-np.pi, np.pi, 6), qlim=QLIM_360)
        axes = chain.axes * rng.choice([-1.0, 1.0], (6, 1))
        chain = chain.replace(axes=axes)
        assert is_ur_type(chain), trial
        p = ur_parameters(chain)
        np.testing.assert_allclose(p.d4, d[1] + d[2] + d4, atol=1e-15)
        q = chain.random_q(100, rng)
        _check_round_trip(chain, q)


def test_mounted_base_flange_and_tool():
    rng = np.random.default_rng(4)
    ur = _ur("ur5e")
    for _ in range(5):
        fixed = ur.fixed.copy()
        fixed[0] = _random_rigid(rng) @ fixed[0]  # a mount before joint 1
        fixed[6] = fixed[6] @ _random_rigid(rng)  # a flange adapter after joint 6
        chain = ur.replace(fixed=fixed, base=_random_rigid(rng), tool=_random_rigid(rng))
        _check_round_trip(chain, chain.random_q(100, rng))
    # a tool that is a pure offset along the flange axis (folded into d6 by the solver)
    tool = hom(p=(0, 0, 0.2))
    _check_round_trip(ur.replace(tool=tool), ur.random_q(100, rng))


def test_dhrobot_input_matches_the_chain():
    d, a, alpha = _table(*UR_DH["ur3e"])
    tool = hom(rotx(0.3), (0.01, 0.02, 0.05))
    dh = DHRobot(d, a, alpha, qlim=QLIM_360, tool=tool)
    chain = from_dh(d, a, alpha, qlim=QLIM_360, tool=tool)
    q = chain.random_q(50, np.random.default_rng(5))
    T = chain.fkine(q)
    sol = ikine_ur(dh, T)
    Q1, V1 = sol.q, sol.success
    sol = ikine_ur(chain, T)
    Q2, V2 = sol.q, sol.success
    np.testing.assert_array_equal(V1, V2)
    np.testing.assert_allclose(Q1, Q2, atol=1e-12)
    _check_round_trip(chain, q)


# ------------------------------------------------------------------------------------------ singular poses
@pytest.mark.parametrize("q5", [0.0, np.pi, 1e-13, -1e-9, np.pi - 1e-10])
def test_singular_wrist_is_solved(q5):
    chain = _ur("ur5e")
    rng = np.random.default_rng(6)
    q = chain.random_q(300, rng)
    q[:, 4] = q5
    T = chain.fkine(q)
    sol = ikine_ur(chain, T)
    Q, valid = sol.q, sol.success
    assert valid.any(axis=-1).all()
    assert _fk_error(chain, Q, T)[valid].max() < 1e-9


def test_singular_wrist_reaches_where_the_elbow_needs_the_free_angle():
    # q5 = 0 with the arm nearly stretched: only some choices of the free angle q2+q3+q4 reach
    chain = _ur("ur5e")
    rng = np.random.default_rng(7)
    q = chain.random_q(300, rng)
    q[:, 2] = rng.uniform(-0.05, 0.05, 300)
    q[:, 4] = 0.0
    T = chain.fkine(q)
    sol = ikine_ur(chain, T)
    Q, valid = sol.q, sol.success
    assert valid.any(axis=-1).all()
    assert _fk_error(chain, Q, T)[valid].max() < 1e-9


# ------------------------------------------------------------------------------------------ EAIK
def _eaik_labels(chain, T, lengths=UR_DH["ur5e"]):
    """EAIK's reachability of each pose (a returned solution whose FK matches T to 1e-6) and the
    number of such solutions."""
    eaik_dh = pytest.importorskip("eaik.IK_DH")
    d, a, alpha = (np.array(x) for x in _table(*lengths))
    solver = eaik_dh.DhRobot(alpha, a, d)
    sols = solver.IK_batched(T, 1) if hasattr(solver, "IK_batched") else [solver.IK(t) for t in T]
    Q = np.zeros((len(T), 8, 6))
    present = np.zeros((len(T), 8), dtype=bool)
    for i, s in enumerate(sols):
        k = s.num_solutions()
        Q[i, :k], present[i, :k] = s.Q, True
    ok = present & (_fk_error(chain, Q, T) <= 1e-6)
    return ok.any(axis=-1), ok.sum(axis=-1)


@pytest.mark.parametrize("orientation", ["identity", "tool_down"])
def test_agrees_with_eaik_on_the_ur5e_grid(orientation):
    chain = robots.load("ur5e")
    p = cartesian_grid(-1, 1, 0.1)
    R = np.eye(3) if orientation == "identity" else rotx(np.pi)
    T = np.broadcast_to(hom(R), (len(p), 4, 4)).copy()
    T[:, :3, 3] = p
    reach_eaik, count_eaik = _eaik_labels(chain, T)
    sol = ikine_ur(chain, T)
    Q, valid = sol.q, sol.success
    assert len(p) == 9261 and 2500 < reach_eaik.sum() < 3500
    mismatch = np.flatnonzero(valid.any(axis=-1) != reach_eaik)
    assert mismatch.size == 0, f"labels differ at nodes {mismatch[:10]} (positions {p[mismatch[:3]]})"
    np.testing.assert_array_equal(valid.sum(axis=-1), count_eaik)  # the same number of branches too
    assert _fk_error(chain, Q, T)[valid].max() < 1e-9
    np.testing.assert_array_equal(ur_reachable(chain, T), reach_eaik)


def test_agrees_with_eaik_on_random_arms_and_orientations():
    # UR lengths times U(0.7, 1.3) with random signs, random poses (positions in a 2.2 m cube)
    rng = np.random.default_rng(13)
    for _ in range(3):
        lengths = np.array(UR_DH["ur5e"]) * rng.uniform(0.7, 1.3, 6) * rng.choice([-1.0, 1.0], 6)
        chain = from_dh(*_table(*lengths))
        T = np.zeros((1500, 4, 4))
        T[:, :3, :3], T[:, :3, 3], T[:, 3, 3] = rpy2r(rng.uniform(-np.pi, np.pi, (1500, 3))), \
            rng.uniform(-1.1, 1.1, (1500, 3)), 1.0
        reach_eaik, count_eaik = _eaik_labels(chain, T, lengths)
        sol = ikine_ur(chain, T)
        valid = sol.success
        assert 0.1 < reach_eaik.mean() < 0.6
        np.testing.assert_array_equal(valid.any(axis=-1), reach_eaik)
        np.testing.assert_array_equal(valid.sum(axis=-1), count_eaik)


# ------------------------------------------------------------------------------------------ joint limits
def _in_range_mod_2pi(Q, lo, hi):
    """Independent check: some Q + 2·pi·k (k = -3..3) within [lo, hi], every joint."""
    k = np.arange(-3, 4).reshape((7,) + (1,) * Q.ndim)
    shifted = Q[None] + TWO_PI * k
    return np.any((shifted >= lo - 1e-12) & (shifted <= hi + 1e-12), axis=0).all(axis=-1)


def test_joint_limits_up_to_full_turns():
    rng = np.random.default_rng(8)
    free = _ur("ur10e", qlim=None)
    q = free.random_q(400, rng)
    T = free.fkine(q)
    sol = ikine_ur(free, T)
    Q0, V0 = sol.q, sol.success
    # narrowed limits: random intervals of 0.5..5 rad placed anywhere in [-2pi, 2pi]; one joint
    # keeps a full turn (no check), one is half-open (-inf, hi]
    width = rng.uniform(0.5, 5.0, 6)
    lo = rng.uniform(-TWO_PI, TWO_PI - width)
    qlim = np.stack([lo, lo + width], axis=-1)
    qlim[2] = [-np.pi, np.pi]
    qlim[5] = [-np.inf, 0.3]
    limited = free.replace(qlim=qlim)
    sol = ikine_ur(limited, T)
    Q, V = sol.q, sol.success
    expected = V0 & _in_range_mod_2pi(Q0, qlim[:, 0], qlim[:, 1])
    np.testing.assert_array_equal(V, expected)
    assert 0 < V.sum() < V0.sum()  # the limits do cut branches, not all of them
    # the limits only filter and move angles by whole turns: failing branches as they were, every
    # valid branch the free solution's angles plus whole turns, inside the limits itself
    np.testing.assert_array_equal(Q[~V], Q0[~V])
    turns = (Q[V] - Q0[V]) / TWO_PI
    np.testing.assert_allclose(turns, np.rint(turns), rtol=0, atol=1e-12)
    assert np.all((Q[V] >= qlim[:, 0]) & (Q[V] <= qlim[:, 1]))
    assert np.any(turns != 0)  # some angle did need a turn
    assert limited.within_limits(Q[V]).all()


def test_batched_limits_per_arm():
    rng = np.random.default_rng(9)
    arms = from_dh(*_table(*np.array([UR_DH["ur5e"], UR_DH["ur16e"]]).T),
                   qlim=np.array([QLIM_360, np.tile([-1.0, 1.0], (6, 1))]))
    q = rng.uniform(-1, 1, (30, 2, 6))
    T = arms.fkine(q)
    sol = ikine_ur(arms, T)
    Q, V = sol.q, sol.success
    assert V[:, 0].any(axis=-1).all() and V[:, 1].any(axis=-1).all()
    np.testing.assert_array_equal(V[:, 1], V[:, 1] & _in_range_mod_2pi(Q[:, 1], -1.0, 1.0))
    assert V[:, 1].sum() < V[:, 0].sum()


# ------------------------------------------------------------------------------------------ refusals
def test_puma560_is_refused_naming_joint_3():
    puma = robots.puma560()
    assert not is_ur_type(puma)
    with pytest.raises(ValueError, match=r"joint 3: alpha -1\.5708 rad, the UR type has 0"):
        require_ur_type(puma)
    with pytest.raises(ValueError, match="joint 3"):
        ikine_ur(puma, np.eye(4))


def test_panda_is_refused():
    panda = robots.load("panda")
    with pytest.raises(ValueError, match="it has 7 joints, the UR type has 6"):
        require_ur_type(panda)
    six = SerialChain(panda.fixed[:7], panda.axes[:6], panda.kinds[:6])  # its first six joints
    with pytest.raises(ValueError, match=r"joint 2: alpha 1\.5708 rad, the UR type has 0"):
        require_ur_type(six)


@pytest.mark.parametrize(
    "change, message",
    [
        (dict(alpha=1, value=0.3), r"joint 2: alpha 0\.3 rad, the UR type has 0"),
        (dict(alpha=4, value=0.0), r"joint 5: alpha 0 rad, the UR type has ±pi/2"),
        (dict(a=3, value=0.05), r"joint 4: a 0\.05 m, the UR type has 0"),
        (dict(a=4, value=-0.02), r"joint 5: a -0\.02 m, the UR type has 0"),
    ],
)
def test_refusal_names_the_joint_and_the_difference(change, message):
    d, a, alpha = (np.array(x) for x in _table(*UR_DH["ur5e"]))
    if "alpha" in change:
        alpha[change["alpha"]] = change["value"]
    else:
        a[change["a"]] = change["value"]
    chain = from_dh(d, a, alpha)
    assert not is_ur_type(chain)
    with pytest.raises(ValueError, match=message):
        require_ur_type(chain)


def test_refusals_of_kinds_axes_and_forms():
    ur = _ur("ur5e")
    with pytest.raises(ValueError, match="joint 3 is prismatic"):
        require_ur_type(SerialChain(ur.fixed, ur.axes, "RRPRRR", qlim=np.tile([-1.0, 1.0], (6, 1))))
    axes = ur.axes.copy()
    axes[1] = [0.0, 1.0, 0.0]
    with pytest.raises(ValueError, match=r"joint 2: axis \(0, 1, 0\)"):
        require_ur_type(ur.replace(axes=axes))
    fixed = ur.fixed.copy()
    c, s = np.cos(0.01), np.sin(0.01)
    fixed[3, :3, :3] = fixed[3, :3, :3] @ np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])  # joint 4 tilted
    with pytest.raises(ValueError, match=r"joint 3: the fixed transform after it is not of the form"):
        require_ur_type(ur.replace(fixed=fixed))


def test_a_sideways_offset_is_still_the_ur_geometry():
    # a sideways offset after joint 3 is not Tz·Tx·Rx as written, but joint 4 stays parallel to 2 and
    # 3: the arm is of the UR type, recognised on its standard-DH equivalent
    ur = _ur("ur5e")
    fixed = ur.fixed.copy()
    fixed[3, 1, 3] = 0.01
    arm = ur.replace(fixed=fixed)
    assert not closed_form_ur._structure(arm, 1e-9)[0] and is_ur_type(arm)
    _check_round_trip(arm, np.random.default_rng(3).uniform(-np.pi, np.pi, (50, 6)))


def test_batch_refusal_names_the_arm():
    lengths = np.array([UR_DH["ur5e"], UR_DH["ur3e"], UR_DH["ur10e"]])
    d, a, alpha = (np.array(x) for x in _table(*lengths.T))
    alpha[1, 2] = 0.2
    arms = from_dh(d, a, alpha)
    np.testing.assert_array_equal(is_ur_type(arms), [True, False, True])
    with pytest.raises(ValueError, match=r"arm \(1,\): joint 3: alpha 0\.2 rad"):
        require_ur_type(arms)


@pytest.mark.parametrize(
    "T, message",
    [
        (np.diag([2.0, 1.0, 1.0, 1.0]), "not orthonormal"),
        (np.diag([1.0, 1.0, -1.0, 1.0]), "reflection"),
        (np.array([[1.0, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0.1, 0, 0, 1]]), "bottom row"),
        (np.full((4, 4), np.nan), "NaN"),
    ],
)
def test_non_rigid_targets_are_refused(T, message):
    good = np.broadcast_to(np.eye(4), (5, 4, 4)).copy()
    good[3] = T
    with pytest.raises(ValueError, match=message):
        ikine_ur(_ur("ur5e"), good)
    with pytest.raises(ValueError, match=message):
        ur_reachable(_ur("ur5e"), good)
    with pytest.raises(ValueError, match="shape"):
        ikine_ur(_ur("ur5e"), np.eye(3))
    # a non-rigid target that only one arm of a batch sees (the compiled kernel reads targets by index)
    arms = from_dh(*_table(*np.array([UR_DH["ur5e"], UR_DH["ur3e"]]).T))
    with pytest.raises(ValueError, match=message):
        ur_reachable(arms, good[:, None])


# ------------------------------------------------------------------------------------------ broadcasting
def test_arms_times_targets_broadcast_like_one_at_a_time():
    rng = np.random.default_rng(10)
    lengths = np.array([UR_DH[k] for k in sorted(UR_DH)]) * rng.uniform(0.8, 1.2, (4, 6))
    lim = np.tile([-3.0, 3.0], (4, 6, 1))
    lim[1, 3] = [-0.5, 2.0]
    arms = from_dh(*_table(*lengths.T), qlim=lim)
    T = arms[0].fkine(arms[0].random_q(7, rng))[:, None]  # (7, 1, 4, 4)
    T[2, 0, :3, 3] = [3.0, 0.0, 0.0]  # out of reach of all
    sol = ikine_ur(arms, T)
    Q, V = sol.q, sol.success
    assert Q.shape == (7, 4, 8, 6) and V.shape == (7, 4, 8)
    for b in range(4):
        sol = ikine_ur(arms[b], T[:, 0])
        Qb, Vb = sol.q, sol.success
        np.testing.assert_array_equal(V[:, b], Vb)
        np.testing.assert_allclose(Q[:, b], Qb, atol=1e-12)
        for n in (0, 2, 5):
            sol = ikine_ur(arms[b], T[n, 0])
            Qn, Vn = sol.q, sol.success
            assert Qn.shape == (8, 6)
            np.testing.assert_array_equal(V[n, b], Vn)
            np.testing.assert_allclose(Q[n, b], Qn, atol=1e-12)
    assert not V[2].any()
    # precomputed parameters give the same answer
    sol = ikine_ur(ur_parameters(arms), T)
    Qp, Vp = sol.q, sol.success
    np.testing.assert_array_equal(Vp, V)
    np.testing.assert_array_equal(Qp, Q)


def test_more_targets_than_one_block():
    chain = _ur("ur3e")
    q = chain.random_q(5000, np.random.default_rng(11))
    _check_round_trip(chain, q)


# ------------------------------------------------------------------------------------------ conventions
def test_branch_order_and_reach_tolerance():
    chain = _ur("ur5e")
    rng = np.random.default_rng(12)
    q = chain.random_q(200, rng)
    T = chain.fkine(q)
    sol = ikine_ur(chain, T)
    Q, V = sol.q, sol.success
    assert V.any(axis=-1).all() and V.mean() > 0.8
    k = np.arange(8)
    wrist, elbow = (k // 2) % 2, k % 2
    assert np.all(np.where(wrist == 0, Q[..., 4] >= 0, Q[..., 4] <= 0))
    assert np.all(np.where(elbow == 0, Q[..., 2] >= 0, Q[..., 2] <= 0))
    assert np.all(Q[:, 0:4, 0] == Q[:, 0:1, 0]) and np.all(Q[:, 4:8, 0] == Q[:, 4:5, 0])
    # shoulder 0: θ1 − φ = asin(d4 / r) of the wrist point p − d6·z
    d4, d6 = UR_DH["ur5e"][3], UR_DH["ur5e"][5]
    w = T[:, :3, 3] - d6 * T[:, :3, 2]
    phi = np.arctan2(w[:, 1], w[:, 0])
    delta = np.arcsin(d4 / np.hypot(w[:, 0], w[:, 1]))
    np.testing.assert_allclose(np.mod(Q[:, 0, 0] - phi - delta + np.pi, TWO_PI) - np.pi, 0, atol=1e-12)
    np.testing.assert_allclose(np.mod(Q[:, 4, 0] - phi + delta, TWO_PI) - np.pi, 0, atol=1e-12)

    # the stretched arm: q3 = 0 is on the elbow boundary of its (shoulder, wrist) pair; a hair
    # further is out of that pair's reach (both elbows), unless atol allows it
    q0 = np.array([0.3, -0.7, 0.0, 0.4, 1.1, -0.2])
    T0 = chain.fkine(q0)
    sol = ikine_ur(chain, T0)
    Q0, V0 = sol.q, sol.success
    assert _fk_error(chain, Q0, T0)[V0].max() < 1e-9
    k0 = int(np.argmin(np.where(V0, _angle_gap(Q0, q0), np.inf)))
    pair = [k0 - k0 % 2, k0 - k0 % 2 + 1]
    assert V0[pair].all()
    frames = chain.joint_frames(q0)[0]
    out = frames[3, :3, 3] - frames[1, :3, 3]  # shoulder → wrist-1 axis: the stretched direction
    T1 = T0.copy()
    T1[:3, 3] += 1e-6 * out / np.linalg.norm(out)  # 1 µm beyond the stretched elbow
    assert not ikine_ur(chain, T1).success[pair].any()
    sol = ikine_ur(chain, T1, atol=1e-5)
    Q2, V2 = sol.q, sol.success
    assert V2[pair].all() and _fk_error(chain, Q2, T1)[pair].max() < 1.5e-6

    # the wrist point on the shoulder cylinder r = |d4| (upper arm vertical, ψ = 0): a hair
    # inside, no branch reaches
    q0 = np.array([0.7, np.pi / 2, 0.0, -np.pi / 2, 0.8, 0.1])
    T0 = chain.fkine(q0)
    w0 = T0[:3, 3] - d6 * T0[:3, 2]
    np.testing.assert_allclose(np.hypot(w0[0], w0[1]), d4, atol=1e-12)
    sol = ikine_ur(chain, T0)
    Q0, V0 = sol.q, sol.success
    assert V0.any() and _fk_error(chain, Q0, T0)[V0].max() < 1e-9
    T1 = T0.copy()
    T1[:2, 3] -= 1e-6 * w0[:2] / np.hypot(w0[0], w0[1])
    assert not ur_reachable(chain, T1)
    sol = ikine_ur(chain, T1, atol=1e-5)
    Q2, V2 = sol.q, sol.success
    assert V2.any() and _fk_error(chain, Q2, T1)[V2].max() < 1.5e-6


# ------------------------------------------------------------------------------------------ random arms and poses
def _random_arms(rng, B, generalised=True, limited=True):
    """A batch of B UR-type arms: lengths of the published arms times U(0.7, 1.3) with random signs;
    ``generalised``: mirrored twists, offsets, d2 + d3, a1, a twisted F_6 with a6, -z axes, a base
    and a tool; ``limited``: per-arm limits of every kind (narrow, a full turn, half-open, none)."""
    lengths = np.array([UR_DH[k] for k in sorted(UR_DH)])[rng.integers(0, 4, B)]
    lengths = lengths * rng.uniform(0.7, 1.3, (B, 6)) * rng.choice([-1.0, 1.0], (B, 6))
    d, a, alpha = (np.array(x) for x in _table(*lengths.T))
    offset = None
    if generalised:
        alpha[:, [0, 3, 4]] *= rng.choice([-1.0, 1.0], (B, 3))
        alpha[:, 5] = rng.uniform(-np.pi, np.pi, B)
        d[:, 1:3] = rng.uniform(-0.1, 0.1, (B, 2))
        a[:, 0], a[:, 5] = rng.uniform(-0.1, 0.1, B), rng.uniform(-0.1, 0.1, B)
        offset = rng.uniform(-np.pi, np.pi, (B, 6))
    qlim = None
    if limited:
        width = rng.uniform(0.5, 5.0, (B, 6))
        lo = rng.uniform(-TWO_PI, TWO_PI - width)
        qlim = np.stack([lo, lo + width], axis=-1)
        kind = rng.integers(0, 4, (B, 6))
        qlim[kind == 1] = [-np.pi, np.pi]  # a full turn: no check
        qlim[kind == 2, 0] = -np.inf  # half-open
        qlim[kind == 3] = [-TWO_PI, TWO_PI]
    arms = from_dh(d, a, alpha, offset=offset, qlim=qlim)
    if generalised:
        arms = arms.replace(axes=arms.axes * rng.choice([-1.0, 1.0], (6, 1)), base=_random_rigid(rng),
                            tool=_random_rigid(rng))
    return arms


def _poses(rng, arms, n):
    """(n, B, 4, 4) poses for a batch of arms: FK of random q (some with a singular wrist, q5 in
    {0, pi, 1e-13}, some with the elbow stretched, q3 = 0, some nudged by ±atol·(1 ± 1e-3) along
    a random direction, on the reach tolerance), and random poses in a 2.4 m cube."""
    free = arms.replace(qlim=None)
    q = free.random_q(n, rng)  # (n, B, 6)
    k = n // 8
    q[:k, :, 4] = rng.choice([0.0, np.pi, 1e-13, -1e-13], (k, q.shape[1]))
    q[k:2 * k, :, 2] = 0.0
    T = free.fkine(q)
    step = rng.normal(size=(k, q.shape[1], 3))
    step *= 1e-9 * rng.choice([1 - 1e-3, 1 + 1e-3], (k, q.shape[1], 1)) / np.linalg.norm(step, axis=-1, keepdims=True)
    T[2 * k:3 * k, :, :3, 3] += step
    m = n // 3
    T[-m:] = _random_rigid(rng, (m, q.shape[1]))
    T[-m:, :, :3, 3] *= 2.4
    return T


def _assert_consistent(robot, T, atol=1e-9):
    """The solver against itself and independent checks: the limits only filter and move angles
    by whole turns (the angles are those of the arm without limits, a valid branch's moved into the
    limits), a branch succeeds exactly where the unlimited arm's branch does and its angles lie
    inside the limits by :func:`_in_range_mod_2pi`, ``reason`` says which failed, the reach-only
    path agrees with the full solve, and every success reproduces the pose by forward kinematics.
    Returns ``success``."""
    sol = ikine_ur(robot, T, atol)
    Q, V = sol.q, sol.success
    free = ikine_ur(robot.replace(qlim=None), T, atol)
    np.testing.assert_array_equal(free.q[~V], Q[~V])
    turns = (Q - free.q) / TWO_PI
    np.testing.assert_allclose(turns, np.rint(turns), rtol=0, atol=1e-12)
    assert np.all(np.abs(free.q) <= np.pi + 1e-12)
    if robot.qlim is None:
        np.testing.assert_array_equal(V, free.success)
        np.testing.assert_array_equal(free.q, Q)
    else:
        lim = np.broadcast_to(robot.qlim, robot.batch_shape + (6, 2))[..., None, :, :]
        np.testing.assert_array_equal(V, free.success & _in_range_mod_2pi(free.q, lim[..., 0], lim[..., 1]))
        inside = (Q >= lim[..., 0]) & (Q <= lim[..., 1])
        assert inside.all(axis=-1)[V].all()
    expected = np.where(V, IKReason.SOLVED, np.where(free.success, IKReason.OUTSIDE_LIMITS, IKReason.OUT_OF_REACH))
    np.testing.assert_array_equal(sol.reason, expected)
    np.testing.assert_array_equal(ur_reachable(robot, T, atol), V.any(axis=-1))
    if V.any():
        assert _fk_error(robot, Q, T)[V].max() < 2 * atol + 1e-8
    return V


@pytest.mark.parametrize("generalised, limited", [(False, False), (False, True), (True, False), (True, True)])
def test_consistent_on_random_arms_poses_and_limits(generalised, limited):
    rng = np.random.default_rng(20 + 2 * generalised + limited)
    arms = _random_arms(rng, 24, generalised, limited)
    T = _poses(rng, arms, 160)  # (160, 24, 4, 4): 3840 targets, two tasks' worth and more
    V = _assert_consistent(arms, T)
    reach = V.any(axis=-1)
    assert 0.2 < reach.mean() < 0.8 and 0 < V.sum() < V.size  # neither trivial nor empty
    # one arm at a time, and the targets shared by all arms (broadcast inside the kernel)
    for b in (0, 7):
        _assert_consistent(arms[b], T[:, b])
    _assert_consistent(arms, T[:, :1])
    # a looser reach tolerance moves the boundary cases
    _assert_consistent(arms, T[:48], atol=1e-5)


def test_limits_on_the_boundary():
    # limits that put one joint of a valid branch 1e-9 rad inside or outside (by multiples of 2·pi),
    # or exactly on the upper limit (inside: the check allows 1e-12 above it). Not exactly on the
    # lower limit: the solver's check (as dh.angle_in_range) has no slack below, the independent
    # one of _in_range_mod_2pi has 1e-12
    rng = np.random.default_rng(30)
    ur = _ur("ur5e", qlim=None)
    T = ur.fkine(ur.random_q(64, rng))
    sol = ikine_ur(ur, T)
    Q, V = sol.q, sol.success
    B = 32
    qlim = np.tile(QLIM_360, (B, 1, 1))
    for b in range(B):
        n = rng.integers(0, len(T))
        k = rng.choice(np.flatnonzero(V[n]))
        j = rng.integers(0, 6)
        x = Q[n, k, j] + TWO_PI * rng.integers(-1, 2)
        width = rng.uniform(0.1, 3.0)
        eps = rng.choice([-1e-9, 1e-9])
        mode = b % 3
        if mode == 0:
            qlim[b, j] = [x + eps, x + eps + width]
        elif mode == 1:
            qlim[b, j] = [x - eps - width, x - eps]
        else:
            qlim[b, j] = [x - width, x]
    arms = from_dh(*_table(*np.tile(UR_DH["ur5e"], (B, 1)).T), qlim=qlim)
    V = _assert_consistent(arms, T[:, None])
    assert 0 < V.sum() < V.size


def test_consistent_on_the_ur5e_grid_and_at_the_shoulder_axis():
    chain = robots.load("ur5e")
    p = cartesian_grid(-1, 1, 0.1)
    for R in (np.eye(3), rotx(np.pi), rpy2r([0.3, -1.2, 2.0])):
        T = np.broadcast_to(hom(R), (len(p), 4, 4)).copy()
        T[:, :3, 3] = p
        _assert_consistent(chain, T)
    # wrist point on the joint-1 axis, with and without d4 (free θ1) and a1
    for d4, a1 in ((0.0, 0.0), (0.1333, 0.0), (0.0, 0.05)):
        d, a, alpha = (np.array(x) for x in _table(*UR_DH["ur5e"]))
        d[3], a[0] = d4, a1
        arm = from_dh(d, a, alpha)
        T = np.broadcast_to(hom(rotx(np.pi), (0.0, 0.0, 0.3)), (3, 4, 4)).copy()
        T[:, 2, 3] = (0.3, 0.5, 0.1625)
        T[:, :3, 3] -= (UR_DH["ur5e"][5] * T[:, :3, 2])  # flange such that the wrist point is on the axis
        _assert_consistent(arm, T)


def test_empty_and_single_targets():
    ur = _ur("ur10e")
    for T in (np.zeros((0, 4, 4)), np.eye(4), ur.fkine(np.array([0.1, -1.0, 1.2, 0.3, 0.0, 2.0]))):
        sol = ikine_ur(ur, T)
        assert sol.q.shape == T.shape[:-2] + (8, 6)
        assert sol.success.shape == sol.reason.shape == sol.iterations.shape == T.shape[:-2] + (8,)
        assert ur_reachable(ur, T).shape == T.shape[:-2]
        _assert_consistent(ur, T)


def test_results_do_not_depend_on_the_thread_count():
    rng = np.random.default_rng(40)
    arms = _random_arms(rng, 8, generalised=True, limited=True)
    T = _poses(rng, arms, 400)  # 3200 targets: several tasks per thread
    before = lm_compiled.threads()
    try:
        out = {}
        for n in sorted({1, 2, lm_compiled.set_threads(None)}):
            lm_compiled.set_threads(n)
            sol = ikine_ur(arms, T)
            out[n] = (sol.q, sol.success, sol.reason, ur_reachable(arms, T))
        ref = out[1]
        for n, res in out.items():
            for x, y in zip(res, ref):
                np.testing.assert_array_equal(x, y, err_msg=f"{n} threads")
    finally:
        lm_compiled.set_threads(before)


def test_the_fast_structure_check_decides_as_the_worded_one():
    # small changes around atol of what the test reads (twists, a4, a5, sideways offsets, tilts of
    # the link frames), in a batch: _structure (is_ur_type) and _explain (the message) agree per arm
    rng = np.random.default_rng(50)
    B = 600
    d, a, alpha = (np.array(x) for x in _table(*np.tile(UR_DH["ur5e"], (B, 1)).T))
    step = lambda: rng.choice([-2e-9, -5e-10, 0.0, 0.0, 0.0, 5e-10, 2e-9, 0.3], B)  # noqa: E731
    j = rng.integers(0, 5, B)
    rows = np.arange(B)
    alpha[rows, j] += step()
    a[rows, rng.choice([3, 4], B)] += step()
    arms = from_dh(d, a, alpha)
    fixed = arms.fixed.copy()
    k = rng.integers(1, 6, B)
    fixed[rows, k, 1, 3] += step()  # a sideways offset: not Tz·Tx·Rx
    tilt = np.where(rng.random(B) < 0.5, step(), 0.0)
    Ry = np.broadcast_to(np.eye(4), (B, 4, 4)).copy()
    Ry[:, 0, 0] = Ry[:, 2, 2] = np.cos(tilt)
    Ry[:, 0, 2], Ry[:, 2, 0] = np.sin(tilt), -np.sin(tilt)
    k = rng.integers(1, 6, B)
    fixed[rows, k] = fixed[rows, k] @ Ry
    arms = arms.replace(fixed=fixed)
    ok = closed_form_ur._structure(arms, 1e-9)[0]  # on the numbers as given (is_ur_type also tries the geometry)
    _, ok_words, _ = closed_form_ur._explain(arms, 1e-9)
    np.testing.assert_array_equal(ok, ok_words)
    assert 0.05 < ok.mean() < 0.95
