"""Batched kinematics of serial revolute arms in standard (distal) Denavit–Hartenberg form.

Conventions (as in Corke's Robotics Toolbox and the paper):

* link transform ``A_i = Rz(q_i) · Tz(d_i) · Tx(a_i) · Rx(alpha_i)``, ``T = A_1 ··· A_n · tool``;
* lengths in metres, angles in radians, float64 throughout;
* every array may carry leading batch dimensions, which broadcast against each other:
  a ``DHRobot`` whose ``d`` has shape ``(B, 6)`` is a batch of ``B`` arms, and ``fkine(q)`` with
  ``q`` of shape ``(N, 1, 6)`` gives poses of shape ``(N, B, 4, 4)``.

The numerical inverse kinematics is the Levenberg–Marquardt iteration of the paper's Appendix,
run for a whole batch of targets at once: converged and failed targets leave the active set, so
the cost of one iteration is proportional to the number of targets still being solved.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "DHRobot",
    "IKResult",
    "rotx",
    "roty",
    "rotz",
    "rpy2r",
    "transl",
    "pose_error",
    "ikine_LM",
]


# --------------------------------------------------------------------------- elementary transforms
def rotx(theta):
    """Rotation about x by ``theta`` (rad); shape ``theta.shape + (3, 3)``."""
    theta = np.asarray(theta, dtype=np.float64)
    c, s = np.cos(theta), np.sin(theta)
    o, z = np.ones_like(theta), np.zeros_like(theta)
    return np.stack([o, z, z, z, c, -s, z, s, c], axis=-1).reshape(theta.shape + (3, 3))


def roty(theta):
    """Rotation about y by ``theta`` (rad); shape ``theta.shape + (3, 3)``."""
    theta = np.asarray(theta, dtype=np.float64)
    c, s = np.cos(theta), np.sin(theta)
    o, z = np.ones_like(theta), np.zeros_like(theta)
    return np.stack([c, z, s, z, o, z, -s, z, c], axis=-1).reshape(theta.shape + (3, 3))


def rotz(theta):
    """Rotation about z by ``theta`` (rad); shape ``theta.shape + (3, 3)``."""
    theta = np.asarray(theta, dtype=np.float64)
    c, s = np.cos(theta), np.sin(theta)
    o, z = np.ones_like(theta), np.zeros_like(theta)
    return np.stack([c, -s, z, s, c, z, z, z, o], axis=-1).reshape(theta.shape + (3, 3))


def rpy2r(rpy):
    """The paper's orientation angles ``(r1, r2, r3)`` → ``Rx(r1) · Ry(r2) · Rz(r3)``.

    ``rpy`` has shape ``(..., 3)`` (rad); the result has shape ``(..., 3, 3)``.
    """
    rpy = np.asarray(rpy, dtype=np.float64)
    if rpy.shape[-1:] != (3,):
        raise ValueError(f"orientation angles must have a last dimension of 3, got shape {rpy.shape}")
    return rotx(rpy[..., 0]) @ roty(rpy[..., 1]) @ rotz(rpy[..., 2])


def transl(p):
    """Pure translation: ``p`` of shape ``(..., 3)`` → homogeneous transform ``(..., 4, 4)``."""
    p = np.asarray(p, dtype=np.float64)
    T = np.zeros(p.shape[:-1] + (4, 4))
    T[..., :3, :3] = np.eye(3)
    T[..., :3, 3] = p
    T[..., 3, 3] = 1.0
    return T


def _check_finite(name, x):
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name} contains NaN or infinite values")


# --------------------------------------------------------------------------- the robot
class DHRobot:
    """A serial arm (or a batch of arms) of revolute joints in standard DH form.

    Parameters
    ----------
    d, a, alpha : array_like, shape (..., n)
        Link offsets (m), link lengths (m) and twists (rad). Leading dimensions are a batch of
        arms and must broadcast against each other.
    qlim : array_like, shape (n, 2) or (..., n, 2), optional
        Joint limits ``[lo, hi]`` in radians. ``None`` (the paper's setting) means unlimited.
    tool : array_like, shape (4, 4), optional
        Fixed transform from the last link frame to the tool frame.
    name : str, optional
    """

    def __init__(self, d, a, alpha, qlim=None, tool=None, name: str | None = None):
        d, a, alpha = (np.asarray(x, dtype=np.float64) for x in (d, a, alpha))
        for label, x in (("d", d), ("a", a), ("alpha", alpha)):
            if x.ndim == 0:
                raise ValueError(f"DH column {label} must have at least one dimension (one entry per joint)")
            _check_finite(f"DH column {label}", x)
        n = {d.shape[-1], a.shape[-1], alpha.shape[-1]}
        if len(n) != 1:
            raise ValueError(
                f"DH columns disagree on the number of joints: d {d.shape}, a {a.shape}, alpha {alpha.shape}"
            )
        try:
            shape = np.broadcast_shapes(d.shape, a.shape, alpha.shape)
        except ValueError:
            raise ValueError(
                f"DH columns have batch shapes that do not broadcast: d {d.shape}, a {a.shape}, alpha {alpha.shape}"
            ) from None
        self.d, self.a, self.alpha = (np.broadcast_to(x, shape) for x in (d, a, alpha))
        self.n = shape[-1]
        if qlim is not None:
            qlim = np.asarray(qlim, dtype=np.float64)
            if qlim.shape[-2:] != (self.n, 2):
                raise ValueError(f"qlim must have shape (..., {self.n}, 2), got {qlim.shape}")
            if np.any(np.isnan(qlim)):
                raise ValueError("qlim contains NaN")
            if np.any(qlim[..., 0] > qlim[..., 1]):
                raise ValueError("qlim has a lower limit above its upper limit")
        self.qlim = qlim
        if tool is not None:
            tool = np.asarray(tool, dtype=np.float64)
            if tool.shape != (4, 4):
                raise ValueError(f"tool must be a 4x4 homogeneous transform, got shape {tool.shape}")
            _check_finite("tool", tool)
        self.tool = tool
        self.name = name

    # ---------------------------------------------------------------- shape and indexing
    @property
    def batch_shape(self) -> tuple[int, ...]:
        """Leading dimensions of the DH arrays: ``()`` for one arm."""
        return self.d.shape[:-1]

    def __len__(self):
        if not self.batch_shape:
            raise TypeError("a single arm has no length; batch_shape is ()")
        return self.batch_shape[0]

    def __getitem__(self, idx) -> "DHRobot":
        """Select arms of a batch (numpy indexing on the batch dimensions)."""
        if not self.batch_shape:
            raise TypeError("a single arm cannot be indexed")
        qlim = self.qlim
        if qlim is not None and qlim.ndim > 2:
            qlim = qlim[idx]
        return DHRobot(self.d[idx], self.a[idx], self.alpha[idx], qlim=qlim, tool=self.tool, name=self.name)

    @property
    def dh(self) -> np.ndarray:
        """DH table ``(..., n, 3)`` with columns ``[d, a, alpha]``."""
        return np.stack([self.d, self.a, self.alpha], axis=-1)

    def __repr__(self):
        name = f"{self.name!r}, " if self.name else ""
        return f"DHRobot({name}n={self.n}, batch_shape={self.batch_shape}, qlim={'yes' if self.qlim is not None else 'no'})"

    # ---------------------------------------------------------------- kinematics
    def _check_q(self, q):
        q = np.asarray(q, dtype=np.float64)
        if q.ndim == 0 or q.shape[-1] != self.n:
            raise ValueError(f"joint coordinates must have a last dimension of {self.n}, got shape {q.shape}")
        _check_finite("joint coordinates", q)
        return q

    def link_frames(self, q) -> np.ndarray:
        """Frames of every link: ``(..., n + 1, 4, 4)``; index 0 is the base, n the flange (no tool)."""
        q = self._check_q(q)
        return _link_frames(self.d, self.a, self.alpha, q)

    def fkine(self, q) -> np.ndarray:
        """Forward kinematics: tool pose in the base frame, shape ``(..., 4, 4)``."""
        T = self.link_frames(q)[..., -1, :, :]
        return T @ self.tool if self.tool is not None else T

    def jacob0(self, q) -> np.ndarray:
        """Geometric Jacobian in the base frame, shape ``(..., 6, n)``: rows ``[v; omega]``."""
        q = self._check_q(q)
        return _jacob0(self.d, self.a, self.alpha, q, self.tool)[0]

    def ikine_LM(self, T, q0=None, **kwargs) -> "IKResult":
        """Numerical inverse kinematics of the paper's Appendix; see :func:`ikine_LM`."""
        return ikine_LM(self, T, q0=q0, **kwargs)

    def within_limits(self, q) -> np.ndarray:
        """True where every joint angle, up to a multiple of 2·pi, lies inside its limits.

        Without limits every configuration is within them. Shape: ``q.shape[:-1]`` broadcast with
        the limits' batch shape.
        """
        q = self._check_q(q)
        if self.qlim is None:
            return np.ones(q.shape[:-1], dtype=bool)
        return np.all(_angle_in_range(q, self.qlim[..., 0], self.qlim[..., 1]), axis=-1)


def _angle_in_range(q, lo, hi):
    """True where some ``q + 2·pi·k`` lies in ``[lo, hi]`` (elementwise, broadcasting)."""
    two_pi = 2.0 * np.pi
    # the smallest 2·pi-equivalent of q that is >= lo
    shifted = lo + np.mod(q - lo, two_pi)
    # a tiny slack so that an angle sitting exactly on a limit is not lost to rounding
    return (shifted <= hi + 1e-12) | ((hi - lo) >= two_pi)


def _link_frames(d, a, alpha, q):
    """All link frames, ``(..., n + 1, 4, 4)``, for broadcastable DH arrays and ``q``."""
    shape = np.broadcast_shapes(d.shape, q.shape)
    n = shape[-1]
    ct, st = np.cos(q), np.sin(q)
    ca, sa = np.cos(alpha), np.sin(alpha)
    A = np.zeros(shape + (4, 4))
    # A_i = Rz(q) Tz(d) Tx(a) Rx(alpha), written out
    A[..., 0, 0] = ct
    A[..., 0, 1] = -st * ca
    A[..., 0, 2] = st * sa
    A[..., 0, 3] = a * ct
    A[..., 1, 0] = st
    A[..., 1, 1] = ct * ca
    A[..., 1, 2] = -ct * sa
    A[..., 1, 3] = a * st
    A[..., 2, 1] = sa
    A[..., 2, 2] = ca
    A[..., 2, 3] = d
    A[..., 3, 3] = 1.0
    frames = np.empty(shape[:-1] + (n + 1, 4, 4))
    frames[..., 0, :, :] = np.eye(4)
    for i in range(n):  # a loop over joints, not over arms or targets
        frames[..., i + 1, :, :] = frames[..., i, :, :] @ A[..., i, :, :]
    return frames


def _jacob0(d, a, alpha, q, tool):
    """Base-frame geometric Jacobian ``(..., 6, n)`` and the tool pose ``(..., 4, 4)``."""
    frames = _link_frames(d, a, alpha, q)
    T = frames[..., -1, :, :]
    if tool is not None:
        T = T @ tool
    z = frames[..., :-1, :3, 2]  # joint axes z_{i-1}, (..., n, 3)
    o = frames[..., :-1, :3, 3]  # joint origins, (..., n, 3)
    pe = T[..., None, :3, 3]
    Jv = np.cross(z, pe - o)
    J = np.concatenate([Jv, z], axis=-1)  # (..., n, 6)
    return np.swapaxes(J, -1, -2), T


def pose_error(T_current, T_target) -> np.ndarray:
    """Differential motion from ``T_current`` to ``T_target`` in the base frame, ``(..., 6)``.

    Translation difference, then ``0.5 · Σ_k c_k × t_k`` over the rotation columns (Corke's
    ``tr2delta`` for small motions); it is zero exactly when the poses are equal.
    """
    dp = T_target[..., :3, 3] - T_current[..., :3, 3]
    dw = 0.5 * np.cross(T_current[..., :3, :3], T_target[..., :3, :3], axis=-2).sum(axis=-1)
    return np.concatenate([dp, dw], axis=-1)


# --------------------------------------------------------------------------- numerical IK
@dataclass
class IKResult:
    """Result of a batched inverse-kinematics solve; every field has the targets' batch shape.

    q : (..., n) joint angles (rad), the last accepted iterate (meaningful where ``success``)
    success : (...,) bool, error norm reached the tolerance
    iterations : (...,) int, iterations used
    residual : (...,) float, final error norm
    """

    q: np.ndarray
    success: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray


def ikine_LM(
    robot: DHRobot,
    T,
    q0=None,
    *,
    ilimit: int = 500,
    rlimit: int = 100,
    tol: float = 1e-10,
    lam: float = 0.1,
    check_limits: bool = False,
    chunk: int = 65536,
    progress=None,
) -> IKResult:
    """Levenberg–Marquardt inverse kinematics (the paper's Appendix), vectorised over targets.

    For each target pose the iteration is::

        e  = pose_error(fkine(q), T)                    # 6-vector, base frame
        dq = (JᵀJ + λ² I)⁻¹ Jᵀ e                        # J = jacob0(q)
        accept if |e(q + dq)| < |e(q)|:  q += dq, λ /= 2, rejections = 0
        else                             λ *= 2, rejections += 1, fail when rejections > rlimit

    stopping with success once ``|e| <= tol`` and with failure after ``ilimit`` iterations.
    Every target carries its own ``λ`` and counters; targets that stop leave the active set.

    Parameters
    ----------
    robot : DHRobot
        Its batch shape broadcasts with the targets' batch shape.
    T : array_like, shape (..., 4, 4)
        Target tool poses in the base frame.
    q0 : array_like, shape (n,) or (..., n), optional
        Start configurations (default zeros, the paper's).
    ilimit, rlimit, tol, lam :
        Iteration limit, consecutive-rejection limit, tolerance on the error norm, initial λ.
    check_limits : bool
        If True and the robot has joint limits, a converged solution outside them is a failure.
    chunk : int
        Targets solved together; bounds memory.
    progress : callable, optional
        Called with the number of targets finished after each chunk (e.g. ``tqdm.update``).
    """
    T = np.asarray(T, dtype=np.float64)
    if T.shape[-2:] != (4, 4):
        raise ValueError(f"target poses must have shape (..., 4, 4), got {T.shape}")
    _check_finite("target poses", T)
    for label, v in (("ilimit", ilimit), ("rlimit", rlimit)):
        if int(v) != v or v < 0:
            raise ValueError(f"{label} must be a non-negative integer, got {v!r}")
    if not (tol > 0 and np.isfinite(tol)):
        raise ValueError(f"tol must be positive and finite, got {tol!r}")
    if not (lam > 0 and np.isfinite(lam)):
        raise ValueError(f"lam must be positive and finite, got {lam!r}")
    n = robot.n
    q0 = np.zeros(n) if q0 is None else robot._check_q(q0)

    shape = np.broadcast_shapes(T.shape[:-2], robot.batch_shape, q0.shape[:-1])
    count = int(np.prod(shape, dtype=np.int64))
    Tf = np.broadcast_to(T, shape + (4, 4)).reshape(-1, 4, 4)
    dh = np.broadcast_to(robot.dh, shape + (n, 3)).reshape(-1, n, 3)
    qf = np.broadcast_to(q0, shape + (n,)).reshape(-1, n)

    q_out = np.empty((count, n))
    ok_out = np.zeros(count, dtype=bool)
    it_out = np.zeros(count, dtype=np.int64)
    res_out = np.empty(count)
    from . import _lm  # the batched kernel (structure of arrays, exact shortcuts)

    for s in range(0, count, chunk):
        sl = slice(s, min(s + chunk, count))
        q_out[sl], ok_out[sl], it_out[sl], res_out[sl] = _lm.lm_chunk(
            dh[sl], Tf[sl], qf[sl], robot.tool, ilimit, rlimit, tol, lam
        )
        if progress is not None:
            progress(sl.stop - sl.start)

    q_out = q_out.reshape(shape + (n,))
    ok = ok_out.reshape(shape)
    if check_limits and robot.qlim is not None:
        ok = ok & robot.within_limits(q_out)
    return IKResult(q_out, ok, it_out.reshape(shape), res_out.reshape(shape))


# --------------------------------------------------------------------------- closed-form IK
# The spherical-wrist family of the paper (PUMA-type geometry, Corke's ``ikine6s``):
#   j:     1     2    3     4     5     6
#   d:    d1     0   d3    d4     0     0
#   a:     0    a2   a3     0     0     0
#   alpha: pi/2  0  -pi/2  pi/2 -pi/2   0
# d1 (a base height) is allowed so that Corke's Python ``Puma560`` fits too; the paper's arms have d1 = 0.
SPHERICAL_WRIST_ALPHA = np.array([np.pi / 2, 0.0, -np.pi / 2, np.pi / 2, -np.pi / 2, 0.0])
_FREE_D = np.array([True, False, True, True, False, False])
_FREE_A = np.array([False, True, True, False, False, False])


def is_spherical_wrist(robot: DHRobot, atol: float = 1e-9) -> np.ndarray:
    """True for each arm of the batch that belongs to the spherical-wrist family (no tool)."""
    if robot.n != 6 or robot.tool is not None:
        return np.zeros(robot.batch_shape, dtype=bool)
    ok = np.all(np.abs(robot.alpha - SPHERICAL_WRIST_ALPHA) <= atol, axis=-1)
    ok &= np.all(np.abs(robot.d[..., ~_FREE_D]) <= atol, axis=-1)
    ok &= np.all(np.abs(robot.a[..., ~_FREE_A]) <= atol, axis=-1)
    return ok


def require_spherical_wrist(robot: DHRobot) -> None:
    """Raise ``ValueError`` naming the first arm outside the closed-form family."""
    ok = is_spherical_wrist(robot)
    if not np.all(ok):
        if robot.n != 6:
            why = f"it has {robot.n} joints, the family has 6"
        elif robot.tool is not None:
            why = "it carries a tool transform (the closed form solves for the wrist centre)"
        else:
            bad = tuple(int(i) for i in np.argwhere(~np.atleast_1d(ok))[0])
            why = f"arm {bad} has DH parameters outside d=[d1,0,d3,d4,0,0], a=[0,a2,a3,0,0,0], alpha=[pi/2,0,-pi/2,pi/2,-pi/2,0]"
        raise ValueError(f"method 'exact' needs arms of the spherical-wrist family: {why}; use method 'numerical'")


def wrist_centre_reachable(robot: DHRobot, p, atol: float = 1e-12) -> np.ndarray:
    """Closed-form reachability of wrist-centre positions for unlimited spherical-wrist arms.

    With unlimited joints and a spherical wrist every orientation is reachable wherever the wrist
    centre is, so a pose is reachable exactly when its position ``p`` satisfies::

        px² + py² >= d3²                                  (shoulder offset)
        (a2 − L)² <= px² + py² + (pz − d1)² − d3² <= (a2 + L)²,   L² = a3² + d4²   (elbow)

    ``p`` has shape ``(..., 3)`` broadcasting with the robot's batch shape; the result is bool.
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


def ikine_spherical_wrist(robot: DHRobot, T, atol: float = 1e-9):
    """All 8 closed-form solutions for spherical-wrist arms (shoulder × elbow × wrist flip).

    Parameters
    ----------
    robot : DHRobot of the spherical-wrist family (see :func:`is_spherical_wrist`)
    T : array_like, shape (..., 4, 4), target flange poses broadcasting with the robot batch

    Returns
    -------
    q : (..., 8, 6) joint angles in (-pi, pi]; branch ``k`` has shoulder ``k // 4``, elbow
        ``(k // 2) % 2`` and wrist flip ``k % 2``.
    valid : (..., 8) bool; the branch solves the pose (and, if the robot has joint limits, respects
        them up to multiples of 2·pi).
    """
    require_spherical_wrist(robot)
    T = np.asarray(T, dtype=np.float64)
    if T.shape[-2:] != (4, 4):
        raise ValueError(f"target poses must have shape (..., 4, 4), got {T.shape}")
    _check_finite("target poses", T)
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

    # wrist: R36 = R03ᵀ R = Rz(q4) · Ry(−q5) · Rz(q6)
    zeros = np.zeros(q2.shape + (3,))
    q123 = np.concatenate([np.stack([q1e, q2, q3], axis=-1), zeros], axis=-1)  # (..., 2, 2, 6)
    dh_b = [np.broadcast_to(x[..., None, None, :], q2.shape + (6,)) for x in (robot.d, robot.a, robot.alpha)]
    R03 = _link_frames(*dh_b, q123)[..., 3, :3, :3]
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
    wrist = np.stack(
        [
            np.stack([q4, q5, q6], axis=-1),
            np.stack([q4 + np.pi, -q5, q6 + np.pi], axis=-1),  # the flipped wrist
        ],
        axis=-2,
    )  # (..., 2, 2, 2, 3)
    arm = np.broadcast_to(np.stack([q1e, q2, q3], axis=-1)[..., None, :], wrist.shape)
    q = np.concatenate([arm, wrist], axis=-1).reshape(shape + (8, 6))
    q = np.mod(q + np.pi, 2 * np.pi) - np.pi
    q = np.where(q <= -np.pi, q + 2 * np.pi, q)

    valid = reach_sh[..., None, None, None] & reach_el[..., :, None, None]
    valid = np.broadcast_to(valid, shape + (2, 2, 2)).reshape(shape + (8,))
    if robot.qlim is not None:
        qlim = robot.qlim[..., None, :, :] if robot.qlim.ndim > 2 else robot.qlim
        valid &= np.all(_angle_in_range(q, qlim[..., 0], qlim[..., 1]), axis=-1)
    return q, valid
