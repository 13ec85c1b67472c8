"""Closed-form inverse kinematics of the spherical-wrist family (PUMA-type geometry), registered as
`"spherical_wrist"`.

All 8 branches (shoulder × wrist × elbow, numbered as `wsmap.kinematics.ik.registry` says),
vectorised over arms and targets; joint limits honoured up to multiples of 2·pi. Units: metres and
radians.
"""

from __future__ import annotations

import numpy as np

from ...dh import DHRobot, angle_in_range, link_frames
from ...transforms import check_rigid
from ..registry import ClosedForm, register, within_limits
from ..solution import IKReason, IKSolution
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike
    from wsmap.kinematics.chain import Arm

__all__ = ["SPHERICAL_WRIST_ALPHA", "is_spherical_wrist", "require_spherical_wrist", "wrist_centre_reachable",
           "ikine_spherical_wrist", "spherical_wrist_reachable", "spherical_wrist_manipulability"]


# The spherical-wrist family of the paper (PUMA-type geometry, Corke's `ikine6s`):
#   j:     1     2    3     4     5     6
#   d:    d1     0   d3    d4     0     0
#   a:     0    a2   a3     0     0     0
#   alpha: pi/2  0  -pi/2  pi/2 -pi/2   0
# d1 (a base height) is allowed so that Corke's Python `Puma560` fits too; the paper's arms have d1 = 0.
SPHERICAL_WRIST_ALPHA = np.array([np.pi / 2, 0.0, -np.pi / 2, np.pi / 2, -np.pi / 2, 0.0])
_FREE_D = np.array([True, False, True, True, False, False])
_FREE_A = np.array([False, True, True, False, False, False])


def is_spherical_wrist(robot: Arm, atol: float = 1e-9) -> np.ndarray:
    """True for each arm of the batch that belongs to the spherical-wrist family (a `DHRobot`
    without a tool); all False for any other robot."""
    if not isinstance(robot, DHRobot):
        return np.zeros(getattr(robot, "batch_shape", ()), dtype=bool)
    if robot.n != 6 or robot.tool is not None:
        return np.zeros(robot.batch_shape, dtype=bool)
    ok = np.all(np.abs(robot.alpha - SPHERICAL_WRIST_ALPHA) <= atol, axis=-1)
    ok &= np.all(np.abs(robot.d[..., ~_FREE_D]) <= atol, axis=-1)
    ok &= np.all(np.abs(robot.a[..., ~_FREE_A]) <= atol, axis=-1)
    return ok


def require_spherical_wrist(robot: Arm) -> None:
    """Raise `ValueError` naming the first arm outside the closed-form family."""
    ok = is_spherical_wrist(robot)
    if not np.all(ok):
        if not isinstance(robot, DHRobot):
            why = f"it is a {type(robot).__name__}, the family is given by DH parameters (a DHRobot)"
        elif robot.n != 6:
            why = f"it has {robot.n} joints, the family has 6"
        elif robot.tool is not None:
            why = "it carries a tool transform (the closed form solves for the wrist centre)"
        else:
            bad = tuple(int(i) for i in np.argwhere(~np.atleast_1d(ok))[0])
            why = f"arm {bad} has DH parameters outside d=[d1,0,d3,d4,0,0], a=[0,a2,a3,0,0,0], alpha=[pi/2,0,-pi/2,pi/2,-pi/2,0]"
        raise ValueError(f"method 'exact' needs arms of the spherical-wrist family: {why}; use method 'numerical'")


def wrist_centre_reachable(robot: DHRobot, p: ArrayLike, atol: float = 1e-12) -> np.ndarray:
    """Closed-form reachability of wrist-centre positions for unlimited spherical-wrist arms.

    With unlimited joints and a spherical wrist every orientation is reachable wherever the wrist
    centre is, so a pose is reachable exactly when its position `p` satisfies::

        px² + py² >= d3²                                  (shoulder offset)
        (a2 − L)² <= px² + py² + (pz − d1)² − d3² <= (a2 + L)²,   L² = a3² + d4²   (elbow)

    `p` has shape `(..., 3)` broadcasting with the robot's batch shape; the result is bool.
    """
    p = np.asarray(p, dtype=np.float64)
    d1, d3, d4 = robot.d[..., 0], robot.d[..., 2], robot.d[..., 3]
    a2, a3 = robot.a[..., 1], robot.a[..., 2]
    L2 = a3 * a3 + d4 * d4
    L = np.sqrt(L2)
    x, y, z = p[..., 0], p[..., 1], p[..., 2] - d1
    r2 = x * x + y * y
    rho2 = r2 + z * z - d3 * d3
    lo, hi = (a2 - L) ** 2, (a2 + L) ** 2
    return (r2 >= d3 * d3 - atol) & (rho2 >= lo - atol) & (rho2 <= hi + atol)


def _wrist_branches(robot, T, q1e, q2, q3):
    """The wrist angles `(q4, q5, q6)` of both wrist branches for the arm angles `q1e`, `q2`,
    `q3` (..., 2 shoulder, 2 elbow) of poses `T` (..., 4, 4): (..., 2 shoulder, 2 wrist, 2 elbow, 3)."""
    # wrist: R36 = R03ᵀ R = Rz(q4) · Ry(−q5) · Rz(q6)
    zeros = np.zeros(q2.shape + (3,))
    q123 = np.concatenate([np.stack([q1e, q2, q3], axis=-1), zeros], axis=-1)  # (..., 2, 2, 6)
    dh_b = [np.broadcast_to(x[..., None, None, :], q2.shape + (6,)) for x in (robot.d, robot.a, robot.alpha)]
    R03 = link_frames(*dh_b, q123)[..., 3, :3, :3]
    R = T[..., None, None, :3, :3]
    M = np.swapaxes(R03, -1, -2) @ R
    sb = np.hypot(M[..., 0, 2], M[..., 1, 2])
    b = np.arctan2(sb, M[..., 2, 2])  # in [0, pi]
    regular = sb > 1e-12
    q4 = np.where(regular, np.arctan2(M[..., 1, 2], M[..., 0, 2]), 0.0)
    q6 = np.where(
        regular,
        np.arctan2(M[..., 2, 1], -M[..., 2, 0]),
        # singular wrist: only q4 ± q6 is determined; put it all in q6
        np.where(M[..., 2, 2] > 0, np.arctan2(M[..., 1, 0], M[..., 0, 0]), np.arctan2(M[..., 1, 0], -M[..., 0, 0])),
    )
    q5 = -b
    return np.stack(
        [
            np.stack([q4 + np.pi, -q5, q6 + np.pi], axis=-1),  # wrist 0: sin q5 >= 0 (the flipped wrist)
            np.stack([q4, q5, q6], axis=-1),  # wrist 1: sin q5 <= 0
        ],
        axis=-3,
    )  # (..., 2 shoulder, 2 wrist, 2 elbow, 3)


@within_limits
def ikine_spherical_wrist(robot: DHRobot, T: ArrayLike, atol: float = 1e-9) -> IKSolution:
    """All 8 closed-form solutions for spherical-wrist arms.

    Parameters
    ----------
    robot : DHRobot of the spherical-wrist family (see `is_spherical_wrist`)
    T : array_like, shape (..., 4, 4), target flange poses broadcasting with the robot batch
    atol : reach tolerance of the shoulder and elbow tests, on squared distances (m²)

    Returns
    -------
    `IKSolution` with a branch axis: `q` (..., 8, 6) joint
    angles in (-pi, pi] (a succeeding branch's moved by whole turns into the robot's limits,
    `wsmap.kinematics.ik.registry.within_limits`), branch `k = 4·shoulder + 2·wrist + elbow`
    (`wsmap.kinematics.ik.registry`): shoulder 0 has `q1 = φ + asin(d3/r)` (`(r, φ)` the
    polar coordinates of the wrist centre); wrist 0 has `sin q5 >= 0` (the two wrist branches are
    each other's flip, `(q4 + pi, −q5, q6 + pi)`); elbow 0 has `sin(q3 + atan2(d4, a3)) >= 0`.
    `success` (..., 8): the branch solves the pose and, if the robot has joint limits, respects
    them up to multiples of 2·pi; `reason` `OUT_OF_REACH`
    where the shoulder or the elbow cannot reach the wrist centre, `OUTSIDE_LIMITS` where a
    reaching branch leaves the limits; `iterations` 0, `residual` NaN.
    """
    require_spherical_wrist(robot)
    T = check_rigid("target poses", T)
    shape = np.broadcast_shapes(T.shape[:-2], robot.batch_shape)
    T = np.broadcast_to(T, shape + (4, 4))
    d1, d3, d4 = (np.broadcast_to(robot.d[..., i], shape) for i in (0, 2, 3))
    a2, a3 = (np.broadcast_to(robot.a[..., i], shape) for i in (1, 2))

    px, py, pz = T[..., 0, 3], T[..., 1, 3], T[..., 2, 3] - d1
    r2 = px * px + py * py
    # shoulder: px·s1 − py·c1 = d3  →  q1 = φ + asin(d3/r)  or  φ + pi − asin(d3/r)
    reach_sh = r2 >= d3 * d3 - atol
    r = np.sqrt(np.maximum(r2, 1e-300))
    phi = np.arctan2(py, px)
    beta = np.arcsin(np.clip(d3 / r, -1.0, 1.0))
    q1 = np.stack([phi + beta, phi + np.pi - beta], axis=-1)  # (..., 2)
    c1, s1 = np.cos(q1), np.sin(q1)
    x1 = c1 * px[..., None] + s1 * py[..., None]  # planar reach in the arm plane, (..., 2)
    y1 = np.broadcast_to(pz[..., None], x1.shape)

    # elbow: a planar 2-link chain (a2, L) with the forearm pitched by γ = atan2(d4, a3)
    L = np.hypot(a3, d4)[..., None]
    gamma = np.arctan2(d4, a3)[..., None]
    A2 = a2[..., None]
    rho2 = x1 * x1 + y1 * y1
    denom = 2.0 * A2 * L
    degenerate = denom < 1e-12  # a2 = 0 or L = 0: the elbow angle is free, any value works
    D = np.where(degenerate, 1.0, (rho2 - A2 * A2 - L * L) / np.where(degenerate, 1.0, denom))
    reach_el = (rho2 >= (A2 - L) ** 2 - atol) & (rho2 <= (A2 + L) ** 2 + atol)
    psi = np.arccos(np.clip(D, -1.0, 1.0))  # q3 + γ, up to sign
    psi = np.stack([psi, -psi], axis=-1)  # (..., 2 shoulder, 2 elbow)
    X1, Y1 = x1[..., None], y1[..., None]
    q3 = psi - gamma[..., None]
    q2 = np.arctan2(Y1, X1) - np.arctan2(L[..., None] * np.sin(psi), A2[..., None] + L[..., None] * np.cos(psi))
    q1e = np.broadcast_to(q1[..., None], q2.shape)

    wrist = _wrist_branches(robot, T, q1e, q2, q3)  # (..., 2 shoulder, 2 wrist, 2 elbow, 3)
    arm = np.broadcast_to(np.stack([q1e, q2, q3], axis=-1)[..., None, :, :], wrist.shape)
    q = np.concatenate([arm, wrist], axis=-1).reshape(shape + (8, 6))
    q = np.mod(q + np.pi, 2 * np.pi) - np.pi
    q = np.where(q <= -np.pi, q + 2 * np.pi, q)

    reach = reach_sh[..., None, None, None] & reach_el[..., :, None, None]
    reach = np.broadcast_to(reach, shape + (2, 2, 2)).reshape(shape + (8,))
    valid = reach
    if robot.qlim is not None:
        qlim = robot.qlim[..., None, :, :] if robot.qlim.ndim > 2 else robot.qlim
        valid = reach & np.all(angle_in_range(q, qlim[..., 0], qlim[..., 1]), axis=-1)
    reason = np.where(valid, IKReason.SOLVED, np.where(reach, IKReason.OUTSIDE_LIMITS, IKReason.OUT_OF_REACH))
    return IKSolution(q=q, success=valid, iterations=np.zeros(valid.shape, dtype=np.int64),
                      residual=np.full(valid.shape, np.nan), reason=reason.astype(np.int8))


def spherical_wrist_reachable(robot: DHRobot, T: ArrayLike) -> np.ndarray:
    """Some branch of `ikine_spherical_wrist` succeeds: bool, `T.shape[:-2]` broadcast with
    the robot's batch shape. Without joint limits every orientation is reachable wherever the wrist
    centre is, so only the position is tested (`wrist_centre_reachable`)."""
    T = np.asarray(T, dtype=np.float64)
    if robot.qlim is None:
        return wrist_centre_reachable(robot, T[..., :3, 3])
    return ikine_spherical_wrist(robot, T).success.any(axis=-1)


def spherical_wrist_manipulability(d: np.ndarray, a: np.ndarray, T: np.ndarray, atol: float = 1e-9) -> np.ndarray:
    """The exact best Yoshikawa manipulability `√det(J Jᵀ)` over the 8 branches of unlimited
    spherical-wrist arms (the paper's DH family, `SPHERICAL_WRIST_ALPHA`, no tool) at poses `T`.

    Parameters
    ----------
    d, a : (b, 6) the arms' DH offsets and lengths (m)
    T : (N, 4, 4) flange poses in the base frame (m)
    atol : the reach tolerance of `ikine_spherical_wrist` (so the support is the closed form's map)

    Returns
    -------
    (b, N) float64, m³ (per rad³ of joint motion), 0 where no branch reaches the pose. `|det J|`
    factorises for the family (comments in the code), so no branch or Jacobian is built.
    """
    p, approach = T[:, :3, 3], T[:, :3, 2]
    d1, d3, d4 = d[:, 0:1], d[:, 2:3], d[:, 3:4]
    a2, a3 = a[:, 1:2], a[:, 2:3]
    px, py, pz = p[:, 0], p[:, 1], p[:, 2] - d1
    r2 = px * px + py * py
    # The reach tests and tolerances are ikine_spherical_wrist's, so the support is the same map.
    reach_sh = r2 >= d3 * d3 - atol
    x1 = np.sqrt(np.maximum(r2 - d3 * d3, 0.0))  # |planar reach in the arm plane|, equal on both shoulders
    L = np.hypot(a3, d4)
    gamma = np.arctan2(d4, a3)
    rho2 = x1 * x1 + pz * pz
    denom = 2.0 * a2 * L
    degenerate = denom < 1e-12
    c_psi = np.clip(np.where(degenerate, 1.0, (rho2 - a2 * a2 - L * L) / np.where(degenerate, 1.0, denom)), -1.0, 1.0)
    s_psi = np.sqrt(1.0 - c_psi * c_psi)
    reach_el = (rho2 >= (a2 - L) ** 2 - atol) & (rho2 <= (a2 + L) ** 2 + atol)
    # The wrist joints' axes meet at the flange (d6 = 0), so J is block triangular and
    # |det J| = |det J_arm| · |det J_wrist|: the wrist centre's 3x3 Jacobian in q1..q3,
    # a2 · L·|sin ψ| · |x1| (elbow and shoulder singularities), the same on all four arm branches,
    # times |sin q5| (wrist), which differs between them; the wrist flip keeps |sin q5|.
    arm_det = a2 * L * s_psi * x1
    r = np.sqrt(np.maximum(r2, 1e-300))
    phi = np.arctan2(py, px)
    beta = np.arcsin(np.clip(d3 / r, -1.0, 1.0))
    best = np.zeros(arm_det.shape)
    for q1, xs in ((phi + beta, x1), (phi + np.pi - beta, -x1)):
        c1, s1 = np.cos(q1), np.sin(q1)
        for sign in (1.0, -1.0):
            ps = sign * s_psi
            q23 = np.arctan2(pz, xs) - np.arctan2(L * ps, a2 + L * c_psi) + np.arctan2(ps, c_psi) - gamma
            s23 = np.sin(q23)
            # joint 4's axis z3 = (-c1·s23, -s1·s23, c23); cos q5 is its cosine with the approach
            c5 = -c1 * s23 * approach[:, 0] - s1 * s23 * approach[:, 1] + np.cos(q23) * approach[:, 2]
            best = np.maximum(best, np.sqrt(np.maximum(1.0 - c5 * c5, 0.0)))
    return np.where(reach_sh & reach_el, arm_det * best, 0.0)


register(ClosedForm(name="spherical_wrist", description="the spherical-wrist DH family",
                    recognise=is_spherical_wrist, require=require_spherical_wrist, solve=ikine_spherical_wrist,
                    reachable=spherical_wrist_reachable, priority=10))
