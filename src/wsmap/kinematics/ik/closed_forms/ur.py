"""Closed-form inverse kinematics of the UR family: three parallel axes (Universal Robots' geometry),
registered as `"ur"`.

All 8 branches (shoulder × wrist × elbow, numbered as `wsmap.kinematics.ik.registry` says)
over arms and targets in float64; joint limits honoured up to multiples of 2·pi. Units: metres and
radians.

The solver is a numba loop over the targets spread over threads
(`wsmap.kinematics.lm_compiled.set_threads`), `_branches` per target. For maps,
`ur_reachable` stops at the first valid branch of each target and computes only what decides
it (no angle at all when no joint limit needs checking).

The family, in UR's standard DH convention (link `i` is `Rz(θ_i) Tz(d_i) Tx(a_i) Rx(α_i)`)::

    j:      1      2    3     4      5     6
    d:     d1     d2   d3    d4     d5    d6
    a:     a1     a2   a3     0      0    (flange)
    alpha: ±pi/2   0    0    ±pi/2  ±pi/2 (flange)

Joints 2, 3 and 4 turn about parallel axes, perpendicular to joint 1. What the solver accepts
beyond UR's published tables (each handled exactly, not approximated):

* `d2` and `d3` translate along the parallel axes, so only `d2 + d3 + d4` matters; it is
  reported as `d4`;
* `a1` (a shoulder offset along the arm plane);
* either sign of `alpha` at joints 1, 4 and 5: `Rx(-pi/2) = Rz(pi)·Rx(pi/2)·Rz(pi)`, so a
  mirrored twist is UR's twist with a half turn added to that joint and the next (and `a`
  negated, which only concerns `a1`);
* joint axes `+z` or `-z` and any joint offsets (`θ = ±(q + offset)`);
* anything before joint 1 (the chain's `base` and `F_0`) and after joint 6 (`F_6` beyond its
  translation along the joint-6 axis, which is `d6`, and the chain's `tool`): targets are
  mapped with `T' = base⁻¹ · T · flange⁻¹`.

The geometry (frame `k` is the frame after link `k`, with axes `xk`, `yk`, `zk`; `y1`
is the base `z` axis and `z1` the direction of the parallel axes): the wrist point
`p5 = p − d6·z6` lies at height `d4` along `z1` (shoulder, two solutions), the cosine of
`θ5` is `z6·z1` (wrist, two signs of
`θ5`), the frame-4 origin is `p5 − d5·z4` with `z4 ⟂ z1, z6` (its direction gives
`θ2 + θ3 + θ4`), and joints 2 and 3 form a planar two-link arm reaching the frame-4 origin in
the arm plane (elbow, two solutions). `θ6` is solved from the frames already fixed, so the
rotation is exact even close to the wrist singularity.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from numba import njit, prange

from ...arms import ArmBatch
from ...chain import PRISMATIC, SerialChain, as_chain
from ...._progress import notice
from ...lm_compiled import cache_dir, loadable, threads_for
from ...transforms import as_real_array, check_rigid
from ..geometry import dh_equivalent
from ..registry import ClosedForm, register, within_limits
from ..solution import IKReason, IKSolution
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike
    from wsmap.kinematics.chain import Arm

__all__ = ["UR_ALPHA", "URParameters", "ur_parameters", "is_ur_type", "require_ur_type", "ikine_ur",
           "ur_reachable"]

# the compiled branches cache beside the IK kernels, in a user directory (see lm_compiled's "Where the
# cache lives"); numba's setting put back at the end of the module
_NUMBA_CACHE_DIR_BEFORE = numba.config.CACHE_DIR
numba.config.CACHE_DIR = cache_dir()

#: UR's twists `alpha` (rad) of joints 1..6 (standard DH); joint 6's twist is part of the flange.
UR_ALPHA = np.array([np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0])

_TWO_PI = 2.0 * np.pi
# |z6 projected on the arm plane| below this: the wrist is singular (z6 = ±z1) and θ2+θ3+θ4 is
# free. Treating a nearly singular pose as singular costs a rotation error of at most this, in rad.
_SINGULAR = 1e-12
# Rigid-transform tolerance of the target check, as wsmap.kinematics.transforms.check_rigid.
_RIGID_TOL = 1e-6
#: The notice's estimate of `_run`'s first build (s): a first exact UR5e map in an empty cache took
#: 29.4 s of CPU (34.8 s wall) on the development machine, one thread (docs/install.md).
COMPILE_SECONDS = 30


class URParameters(NamedTuple):
    """A UR-type arm (or batch of arms) in the canonical form the solver uses.

    Lengths `d1, a1, a2, a3, d4, d5, d6` (m) have the robot's batch shape and are UR's standard DH
    values with `alpha = UR_ALPHA` exactly (`d4` includes `d2 + d3`; `a1` is 0 for UR's
    arms). Joint angles of the canonical table `θ` (rad) relate to the robot's joint coordinates
    `q` by `q = sign · θ − shift` (`sign`, `shift`: `(..., 6)`). The robot's flange pose
    is `T = base · T_UR(θ) · flange`, with `T_UR` UR's forward kinematics from the frame of
    joint 1 (z along joint 1) to the frame after `Tz(d6)`; `base`, `flange`: `(..., 4, 4)`.
    `qlim`: the robot's limits `(..., 6, 2)` (rad) or `None`.
    """

    d1: np.ndarray
    a1: np.ndarray
    a2: np.ndarray
    a3: np.ndarray
    d4: np.ndarray
    d5: np.ndarray
    d6: np.ndarray
    sign: np.ndarray
    shift: np.ndarray
    base: np.ndarray
    flange: np.ndarray
    qlim: np.ndarray | None


def _fmt(x) -> str:
    return f"{float(x):.6g}"


# entries (0,0), (1,0), (2,0), (0,1), (0,2), (1,3) of a 4 x 4 read row by row, and their values in
# Tz(d)·Tx(a)·Rx(alpha); |alpha| of UR's joints 1..5
_FORM_IDX = np.array([0, 4, 8, 1, 2, 7])
_FORM_REF = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
_ALPHA_ABS = np.abs(UR_ALPHA[:5])
# joints whose twist may be mirrored, and the half turns each mirror adds to joints 1..6
_FLIP_JOINTS = np.array([0, 3, 4])
_HALF_TURNS = np.pi * np.array([[1.0, 1.0, 0.0, 0.0, 0.0, 0.0],
                                [0.0, 0.0, 0.0, 1.0, 1.0, 0.0],
                                [0.0, 0.0, 0.0, 0.0, 1.0, 1.0]])


def _structure(chain: SerialChain, atol: float):
    """The UR-type test in a few whole-batch operations: `(ok, values)`.

    `ok` (`chain.batch_shape`) bool; `values = (F, d, a, alpha)`, the fixed transforms
    `(..., 7, 4, 4)` and the DH numbers `(..., 5)` of the links after joints 1..5, all with the
    chain's batch shape, or `None` when the joint count, kinds or axes rule every arm out. The
    same comparisons as `_explain`, which words the first failure (and is only run then).
    """
    batch = chain.batch_shape
    if chain.n != 6 or PRISMATIC in chain.kinds or np.abs(chain.axes[:, :2]).max() > atol:
        return np.zeros(batch, dtype=bool), None
    F = chain.fixed.view()
    F.flags.writeable = False  # what ur_parameters returns are views of it: read-only, as the chain's
    if F.shape[:-3] != batch:
        F = np.broadcast_to(F, batch + (7, 4, 4))
    L = F[..., 1:6, :, :].reshape(batch + (5, 16))
    form = np.abs(L[..., _FORM_IDX] - _FORM_REF).max(axis=-1)  # (..., 5)
    alpha = np.arctan2(L[..., 9], L[..., 5])
    d, a = L[..., 11], L[..., 3]
    np.maximum(form, np.abs(np.abs(alpha) - _ALPHA_ABS), out=form)
    ok = (form <= atol).all(axis=-1)
    ok &= np.abs(a[..., 3]) <= atol
    ok &= np.abs(a[..., 4]) <= atol
    return ok, (F, d, a, alpha)


def _explain(robot, atol: float):
    """Check the structure of every arm of the batch, joint by joint, with words.

    Returns `(chain, ok, why)`: `ok` (batch) bool; `why(idx)` the first difference of arm
    `idx` from the UR type (a sentence naming the joint). Slow; `_structure` decides.
    """
    chain = as_chain(robot)
    batch = chain.batch_shape
    none = np.zeros(batch, dtype=bool)
    if chain.n != 6:
        return chain, none, lambda idx: f"it has {chain.n} joints, the UR type has 6"
    for j, k in enumerate(chain.kinds):
        if k == PRISMATIC:
            return chain, none, lambda idx, j=j: f"joint {j + 1} is prismatic, the UR type has 6 revolute joints"
    for j, ax in enumerate(chain.axes):
        if abs(ax[0]) > atol or abs(ax[1]) > atol:
            return (chain, none, lambda idx, j=j, ax=ax: f"joint {j + 1}: axis ({', '.join(_fmt(x) for x in ax)}), "
                    f"the UR type turns about the z axis of the joint frame")

    F = np.broadcast_to(chain.fixed, batch + (7, 4, 4))
    L = F[..., 1:6, :, :]  # the links after joints 1..5, which must be Tz(d)·Tx(a)·Rx(alpha)
    form = np.max(np.abs(np.stack([L[..., 0, 0] - 1.0, L[..., 1, 0], L[..., 2, 0], L[..., 0, 1], L[..., 0, 2],
                                   L[..., 1, 3]], axis=-1)), axis=-1)  # (..., 5)
    a = L[..., 0, 3]
    alpha = np.arctan2(L[..., 2, 1], L[..., 1, 1])
    checks = []  # (joint index, ok (batch), message(idx))
    for j in range(5):
        checks.append((j, form[..., j] <= atol, lambda idx, j=j: (
            f"joint {j + 1}: the fixed transform after it is not of the form Tz(d)·Tx(a)·Rx(alpha) "
            f"(off by {_fmt(form[idx + (j,)])})")))
        if j in (0, 3, 4):
            ok_al = np.abs(np.abs(alpha[..., j]) - np.pi / 2) <= atol
            checks.append((j, ok_al, lambda idx, j=j: (
                f"joint {j + 1}: alpha {_fmt(alpha[idx + (j,)])} rad, the UR type has ±pi/2")))
        else:
            checks.append((j, np.abs(alpha[..., j]) <= atol, lambda idx, j=j: (
                f"joint {j + 1}: alpha {_fmt(alpha[idx + (j,)])} rad, the UR type has 0")))
        if j in (3, 4):
            checks.append((j, np.abs(a[..., j]) <= atol, lambda idx, j=j: (
                f"joint {j + 1}: a {_fmt(a[idx + (j,)])} m, the UR type has 0")))
    ok = np.ones(batch, dtype=bool)
    for _, good, _ in checks:
        ok &= good

    def why(idx):
        for _, good, msg in sorted(checks, key=lambda c: c[0]):
            if not good[idx]:
                return msg(idx)
        return "it is of the UR type"

    return chain, ok, why


def _canonical(robot, atol: float):
    """`(chain, ok, values)`: the robot's chain with `_structure`'s answer where every arm
    passes as described, else its standard-DH equivalent (`dh_equivalent`,
    from the joint axes in the base frame at the zero pose, so that a URDF whose joints turn about
    `y` is recognised) with `_structure`'s answer on it. `values` None where no arm passes."""
    chain = as_chain(robot)
    ok, values = _structure(chain, atol)
    if chain.n != 6 or np.all(ok):
        return chain, ok, values
    eq, same = dh_equivalent(chain)
    if eq is None:
        return chain, ok, values
    ok_eq, values_eq = _structure(eq, atol)
    ok_eq = ok_eq & same
    if not ok_eq.any():
        return chain, ok, values
    return eq, ok_eq, values_eq


def is_ur_type(robot: Arm, atol: float = 1e-9) -> np.ndarray:
    """True for each arm of the batch (shape `robot.batch_shape`) that `ikine_ur` solves.

    `robot`: a `SerialChain` or `DHRobot`. The test is on the numbers (`atol` on
    matrix entries, metres and radians): 6 revolute joints about `±z` of their frames, the fixed
    transforms after joints 1..5 of the form `Tz(d)·Tx(a)·Rx(alpha)` with `alpha` ±pi/2, 0, 0,
    ±pi/2, ±pi/2 and `a4 = a5 = 0`. Base, `F_0`, `F_6` and tool are free (see the module doc).
    An arm described otherwise (a URDF's joints about `y`, frames anywhere on the axes) is tested
    on its standard-DH equivalent, computed from the joint axes in the base frame at the zero pose
    (`wsmap.kinematics.ik.geometry.dh_equivalent`): the family is recognised from the arm's
    geometry, whatever frames describe it.
    """
    if not isinstance(robot, ArmBatch):
        return np.zeros((), dtype=bool)
    return _canonical(robot, atol)[1]


def _raise_not_ur(robot, atol):
    chain, ok, why = _explain(robot, atol)
    bad = np.argwhere(~ok)
    idx = tuple(int(i) for i in bad[0]) if bad.size else ()
    arm = f"arm {idx}: " if chain.batch_shape else ""
    raise ValueError(f"not an arm of the UR type (three parallel axes): {arm}{why(idx)}")


def require_ur_type(robot: Arm, atol: float = 1e-9) -> None:
    """Raise `ValueError` naming the first arm and joint that differ from the UR type."""
    if not np.all(is_ur_type(robot, atol)):
        _raise_not_ur(robot, atol)


def _rigid_inverse(T):
    R = np.swapaxes(T[..., :3, :3], -1, -2)
    out = np.zeros(T.shape)
    out[..., :3, :3] = R
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", R, T[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def ur_parameters(robot: Arm, atol: float = 1e-9) -> URParameters:
    """The canonical UR numbers of a UR-type arm (see `URParameters`); `ValueError` otherwise.

    `robot`: a `SerialChain` (e.g. `wsmap.robots.load("ur5e")`) or `DHRobot`, one
    arm or a batch. `base = chain.base · F_0` (the identity for a `DHRobot`);
    `flange = Tz(−d6) · F_6 · chain.tool` with `d6 = F_6[2, 3]`, the translation of `F_6`
    along joint 6 (it commutes with joint 6, so any split is exact).
    """
    chain, ok, values = _canonical(robot, atol)
    if not np.all(ok):
        _raise_not_ur(robot, atol)
    F, d, a, alpha = values
    # mirrored twists at joints 1, 4, 5: a half turn on that joint and the next (module doc)
    flip = (alpha[..., _FLIP_JOINTS] * UR_ALPHA[_FLIP_JOINTS] < 0).astype(float)  # (..., 3): f1, f4, f5
    half_turns = flip @ _HALF_TURNS  # (..., 6): pi·(f1, f1, 0, f4, f4 + f5, f5), exactly
    # the chain turns Rz(sign·(q + offset)); canonical θ = sign·(q + offset) + half_turns
    sign = np.sign(chain.axes[:, 2]) + np.zeros_like(half_turns)
    shift = sign * half_turns + chain.offset
    d6 = F[..., 6, 2, 3]
    flange = F[..., 6, :, :].copy()  # Tz(−d6) · F_6
    flange[..., 2, :] -= d6[..., None] * flange[..., 3, :]
    if chain.tool is not None:
        flange = flange @ chain.tool
    base = F[..., 0, :, :] if chain.base is None else chain.base @ F[..., 0, :, :]
    f1 = flip[..., 0]
    qlim = chain.qlim
    return URParameters(d1=d[..., 0], a1=a[..., 0] * (1.0 - 2.0 * f1), a2=a[..., 1], a3=a[..., 2],
                        d4=d[..., 1] + d[..., 2] + d[..., 3], d5=d[..., 4], d6=d6, sign=sign, shift=shift,
                        base=base, flange=flange, qlim=qlim)


@within_limits
def ikine_ur(robot: Arm, T: ArrayLike, atol: float = 1e-9) -> IKSolution:
    """All 8 closed-form solutions of a UR-type arm (shoulder × wrist × elbow).

    Parameters
    ----------
    robot : SerialChain or DHRobot of the UR type (`is_ur_type`), or its `URParameters`
        (from `ur_parameters`, to skip the structure check on repeated calls).
    T : array_like, shape (..., 4, 4)
        Target tool poses in the robot's world frame (`robot.fkine` convention: base → tool,
        metres), broadcasting with the robot's batch shape; rigid (else `ValueError`).
    atol : float
        Reach tolerance in metres: the wrist point may lie up to `atol` inside the shoulder
        cylinder `r >= |d4|` and the frame-4 origin up to `atol` outside the elbow annulus
        `||a2| − |a3|| <= ρ <= |a2| + |a3|`; such a branch is the nearest configuration, with a
        position error of at most about `atol`. Also the tolerance of the structure check.

    Returns
    -------
    `IKSolution` with a branch axis, `...` the broadcast of
    `T.shape[:-2]` and the robot's batch shape:

    q : (..., 8, 6) float64
        Joint coordinates (rad) in `[-pi, pi]`, except that a succeeding branch's angles are moved
        by whole turns into the robot's limits (`wsmap.kinematics.ik.registry.within_limits`).
        Branch `k = 4·shoulder + 2·wrist + elbow` (`wsmap.kinematics.ik.registry`), defined on the canonical angles `θ` (UR's table,
        `q = sign·θ − shift`, `URParameters`; for UR's own arms `θ = q`): shoulder 0:
        `θ1 = φ + asin(d4/r)`, 1: `φ + pi − asin(d4/r)`, with `(r, φ)` the polar coordinates
        of the wrist point `p − d6·z` in the joint-1 frame; wrist 0: `sin θ5 >= 0`, 1:
        `<= 0`; elbow 0: `sin θ3 >= 0`, 1: `<= 0`. Entries of branches that do not succeed
        are finite but meaningless.
    success : (..., 8) bool
        The branch reaches the pose (tolerance `atol`) and, if the robot has joint limits, every
        joint lies inside them up to a multiple of 2·pi (and `q` is moved there).
    reason : (..., 8) `OUT_OF_REACH` where the branch does not reach the pose, `OUTSIDE_LIMITS`
        where it reaches it outside the limits; `iterations` 0, `residual` NaN.

    Notes
    -----
    Singular wrist (`z6 = ±z1`, `sin θ5 = 0`): only `θ2 + θ3 + θ4` and `θ6` together are
    determined; the free angle is chosen so that the elbow is as close to a right angle as the
    position allows (the two wrist branches take the two mirror choices), which reaches the pose
    whenever any choice does. A free `θ1` (wrist point on the joint-1 axis with `d4 = 0`)
    takes 0 and pi. In these one-parameter families the limits are checked on the chosen member only.
    """
    prm, T = _front(robot, T, atol)
    q, valid = _ikine_compiled(prm, T, atol, full=True)
    reach = valid
    if prm.qlim is not None and not valid.all():
        # which failing branches reach the pose: the same solve without the limits
        reach = _ikine_compiled(prm._replace(qlim=None), T, atol, full=True)[1]
    reason = np.where(valid, IKReason.SOLVED, np.where(reach, IKReason.OUTSIDE_LIMITS, IKReason.OUT_OF_REACH))
    return IKSolution(q=q, success=valid, iterations=np.zeros(valid.shape, dtype=np.int64),
                      residual=np.full(valid.shape, np.nan), reason=reason.astype(np.int8))


def _front(robot, T, atol):
    """The checks of `ikine_ur` and `ur_reachable`: `(URParameters, T as float64)`."""
    prm = robot if isinstance(robot, URParameters) else ur_parameters(robot, atol)
    T = as_real_array("target poses", T)
    if T.ndim < 2 or T.shape[-2:] != (4, 4):
        raise ValueError(f"target poses must have shape (..., 4, 4), got {T.shape}")
    return prm, T


def ur_reachable(robot: Arm, T: ArrayLike, atol: float = 1e-9) -> np.ndarray:
    """True where some branch of `ikine_ur` succeeds: bool, shape `T.shape[:-2]` broadcast
    with the robot's batch shape.

    Stops at the first valid branch of each target and computes only what decides it: without
    joint limits that need checking (none, or each a full turn or more) no angle at all, only the
    reach, by square roots and divisions.
    """
    prm, T = _front(robot, T, atol)
    return _ikine_compiled(prm, T, atol, full=False)


# --------------------------------------------------------------------------- the compiled solver
#: Targets per task handed to a thread of the compiled kernel (every target costs about the same).
TARGETS_PER_TASK = 256
_INV_TWO_PI = 1.0 / _TWO_PI
_EYE4 = np.eye(4)
# placeholders of the compiled kernel's arguments (never written)
_NO_INDEX = np.zeros(0, dtype=np.int64)
_NO_MOUNT = np.zeros((1, 4, 4))
_NO_Q = np.zeros((0, 8, 6))
_NO_VALID = np.zeros((0, 8), dtype=bool)
# the per-arm row of the kernel: 7 lengths, then 6 each of sign, shift, lower and upper limit
_SIGN0, _SHIFT0, _LO0, _HI0, _NPAR = 7, 13, 19, 25, 31


def _ikine_compiled(prm, T, atol, full):
    """`ikine_ur` (`full`) or `ur_reachable` through `_run`.

    Per arm of the batch (`B` arms, shape `arms`): the canonical lengths `(B, 7)`, joint signs,
    shifts and limits `(B, 6)`, inverse mounts `(B, 4, 4)`; per target `i` (`M` of them, the
    broadcast of `T` and the arms) the index of its pose in `T` and of its arm (empty index
    arrays: the identity, resp. arm 0). Which mounts to apply and which joints to map and to check
    is decided once for the whole batch.
    """
    qlim = prm.qlim
    arms = np.broadcast_shapes(prm.d1.shape, prm.base.shape[:-2], prm.flange.shape[:-2], prm.sign.shape[:-1],
                               prm.shift.shape[:-1], () if qlim is None else qlim.shape[:-2])
    B = math.prod(arms)
    tshape = T.shape[:-2]
    shape = np.broadcast_shapes(tshape, arms)
    M = math.prod(shape)
    Tf = np.ascontiguousarray(T).reshape(-1, 4, 4)
    tix = _NO_INDEX if tshape == shape else np.broadcast_to(np.arange(Tf.shape[0]).reshape(tshape), shape).ravel()
    arm = _NO_INDEX if B == 1 else np.broadcast_to(np.arange(B).reshape(arms), shape).ravel()

    def per_arm(x, tail=()):  # (B,) + tail, float64, C order
        x = np.asarray(x, dtype=np.float64)
        if x.shape != arms + tail:
            x = np.broadcast_to(x, arms + tail)
        return np.ascontiguousarray(x.reshape((B,) + tail))

    # mounts: T' = base⁻¹ · T · flange⁻¹, skipped when exactly the identity; a
    # flange that is a pure translation along z folded into d6
    d6 = prm.d6
    base, flange = prm.base, prm.flange
    base_mode = not (base == _EYE4).all()
    Binv = per_arm(_rigid_inverse(base), (4, 4)) if base_mode else _NO_MOUNT
    flange_mode, Finv = 0, _NO_MOUNT
    if not (flange == _EYE4).all():
        fz = flange.copy()
        fz[..., 2, 3] = 0.0
        if (fz == _EYE4).all():
            flange_mode, d6 = 1, d6 + flange[..., 2, 3]
        else:
            flange_mode, Finv = 2, per_arm(_rigid_inverse(flange), (4, 4))
    # per arm: d1, a1, a2, a3, d4, d5, d6 (canonical), then sign, shift, lower and upper limit of
    # joints 1..6 (_arm_row)
    par = np.empty((B, _NPAR))
    for k, x in enumerate((prm.d1, prm.a1, prm.a2, prm.a3, prm.d4, prm.d5, d6)):
        par[:, k] = per_arm(x)
    par[:, _SIGN0:_SIGN0 + 6] = per_arm(prm.sign, (6,))
    par[:, _SHIFT0:_SHIFT0 + 6] = per_arm(prm.shift, (6,))
    sign, shift = par[:, _SIGN0:_SIGN0 + 6], par[:, _SHIFT0:_SHIFT0 + 6]
    mapped = ((sign != 1.0) | (shift != 0.0)).any(axis=0)
    if prm.qlim is None:
        par[:, _LO0:] = 0.0
        limited = np.zeros(6, dtype=bool)
    else:
        lim = per_arm(prm.qlim, (6, 2))
        par[:, _LO0:_LO0 + 6], par[:, _HI0:_HI0 + 6] = lim[..., 0], lim[..., 1]
        limited = (lim[..., 1] - lim[..., 0] < _TWO_PI).any(axis=0)
    bits = 1 << np.arange(6)
    ntask = (M + TARGETS_PER_TASK - 1) // TARGETS_PER_TASK
    bad = np.zeros(ntask, dtype=bool)
    if full:
        q, valid, reach = np.empty((M, 8, 6)), np.empty((M, 8), dtype=bool), np.empty(0, dtype=bool)
    else:
        q, valid, reach = _NO_Q, _NO_VALID, np.empty(M, dtype=bool)
    if not loadable(_run):  # its first build, once per machine (numba's cache): at 0 % on the bar for that long
        notice(f"compiling the UR closed form (numba, once per machine; about {COMPILE_SECONDS} s)...")
    # about 33 ns a pose on the reachability path: one thread below some 10^5 poses
    with threads_for(M, 4096 if full else 65536):
        _run(Tf, tix, arm, par, int(bits[mapped].sum()), int(bits[limited].sum()), base_mode, Binv, flange_mode, Finv,
             float(atol), M, full, q, valid, reach, bad)
    if bad.any():
        check_rigid("target poses", T)  # decides, and words the error
    if full:
        return q.reshape(shape + (8, 6)), valid.reshape(shape + (8,))
    return reach.reshape(shape)


@njit(cache=True, error_model="numpy")
def _wrap1(x):
    """`x` moved by a multiple of 2·pi into `[-pi, pi]` (rint is far cheaper than mod)."""
    return x - _TWO_PI * np.rint(x * _INV_TWO_PI)


@njit(cache=True, error_model="numpy")
def _clip1(x):
    """`np.clip(x, -1, 1)` of one number (NaN stays NaN)."""
    if x < -1.0:
        return -1.0
    if x > 1.0:
        return 1.0
    return x


@njit(cache=True, error_model="numpy")
def _joint(x, j, P, mapped):
    """Canonical angle `x` of joint `j` → the robot's `q_j`
    (`P`: the arm's row, `_arm_row`; `mapped`: bit `j` set where joint `j` is mapped)."""
    if mapped >> j & 1:
        return _wrap1(P[_SIGN0 + j] * x - P[_SHIFT0 + j])
    if j == 1 or j == 3:  # θ2, θ4 are sums of angles; the others are in [-pi, pi] already
        return _wrap1(x)
    return x


@njit(cache=True, error_model="numpy")
def _inside(x, j, P, limited):
    """`q_j = x` inside the arm's limits up to a multiple of 2·pi, as `dh.angle_in_range` (the
    same operations; `np.mod` by 2·pi is `fmod` moved into `[0, 2·pi)`); true unless bit
    `j` of `limited` is set."""
    if not limited >> j & 1:
        return True
    lo, hi = P[_LO0 + j], P[_HI0 + j]
    if hi - lo >= _TWO_PI:
        return True
    r = np.fmod(x - lo, _TWO_PI)
    if r < 0.0:
        r += _TWO_PI
    return lo + r <= hi + 1e-12 or r >= _TWO_PI - 1e-12


@njit(cache=True, error_model="numpy", inline="always")
def _wrist_joint(x, j, P, mapped, limited, ok, full, q, i, k0):
    """Wrist joint `j` (θ5 or θ6, shared by the two elbow branches `k0`, `k0 + 1` of target
    `i`) from its canonical angle `x`: written to `q` when `full`; returns `ok` and the
    joint inside the limits (`_joint`, `_inside`)."""
    x = _joint(x, j, P, mapped)
    ok = ok and _inside(x, j, P, limited)
    if full:
        q[i, k0, j] = x
        q[i, k0 + 1, j] = x
    return ok


@njit(cache=True, error_model="numpy", inline="always")
def _rigid_bad(T, t, tol):
    """Target `t` fails a quick rigidity test (NaN fails): `check_rigid`'s conditions
    (`RᵀR = I`, `a = n × o`, the bottom row) at a quarter of its tolerance, so what passes here
    passes there; a pose that fails is handed to `check_rigid`, which decides and words the
    error."""
    for c in range(3):
        for d in range(c, 3):
            g = T[t, 0, c] * T[t, 0, d] + T[t, 1, c] * T[t, 1, d] + T[t, 2, c] * T[t, 2, d]
            if not abs(g - (1.0 if c == d else 0.0)) <= tol:
                return True
    for i in range(3):
        i1, i2 = (i + 1) % 3, (i + 2) % 3
        x = T[t, i1, 0] * T[t, i2, 1] - T[t, i2, 0] * T[t, i1, 1] - T[t, i, 2]
        if not abs(x) <= tol:
            return True
    for c in range(4):
        if not abs(T[t, 3, c] - (1.0 if c == 3 else 0.0)) <= tol:
            return True
    return False


@njit(cache=True, error_model="numpy", inline="always")
def _left(L, b, T, t, r, c):
    """Entry `(r, c)` of `L[b] · T[t]`, summed left to right."""
    return L[b, r, 0] * T[t, 0, c] + L[b, r, 1] * T[t, 1, c] + L[b, r, 2] * T[t, 2, c] + L[b, r, 3] * T[t, 3, c]


@njit(cache=True, error_model="numpy", inline="always")
def _product(L, R, b, r, c):
    """Entry `(r, c)` of `L · R[b]` (`L` a 16-tuple read row by row), summed left to right."""
    return L[4 * r] * R[b, 0, c] + L[4 * r + 1] * R[b, 1, c] + L[4 * r + 2] * R[b, 2, c] + L[4 * r + 3] * R[b, 3, c]


@njit(cache=True, error_model="numpy", inline="always")
def _target(T, t, b, base_mode, Binv, flange_mode, Finv):
    """Rows 0..2 of `base⁻¹ · T[t] · flange⁻¹` (as the mount modes say), a 12-tuple row by row.

    Why tuples and `inline="always"`: a compiled call that takes arrays may keep atomic
    reference-count updates of them that numba's pruning misses where the code branches; at about
    a dozen per target they cost as much as the arithmetic (measured: 150 ns per target instead
    of 35). Inlined into the loop, with the target and the arm's numbers as plain tuples, none
    are left."""
    if base_mode:
        X = (_left(Binv, b, T, t, 0, 0), _left(Binv, b, T, t, 0, 1), _left(Binv, b, T, t, 0, 2),
             _left(Binv, b, T, t, 0, 3), _left(Binv, b, T, t, 1, 0), _left(Binv, b, T, t, 1, 1),
             _left(Binv, b, T, t, 1, 2), _left(Binv, b, T, t, 1, 3), _left(Binv, b, T, t, 2, 0),
             _left(Binv, b, T, t, 2, 1), _left(Binv, b, T, t, 2, 2), _left(Binv, b, T, t, 2, 3),
             T[t, 3, 0], T[t, 3, 1], T[t, 3, 2], T[t, 3, 3])
    else:
        X = (T[t, 0, 0], T[t, 0, 1], T[t, 0, 2], T[t, 0, 3], T[t, 1, 0], T[t, 1, 1], T[t, 1, 2], T[t, 1, 3],
             T[t, 2, 0], T[t, 2, 1], T[t, 2, 2], T[t, 2, 3], T[t, 3, 0], T[t, 3, 1], T[t, 3, 2], T[t, 3, 3])
    if flange_mode == 2:
        return (_product(X, Finv, b, 0, 0), _product(X, Finv, b, 0, 1), _product(X, Finv, b, 0, 2),
                _product(X, Finv, b, 0, 3), _product(X, Finv, b, 1, 0), _product(X, Finv, b, 1, 1),
                _product(X, Finv, b, 1, 2), _product(X, Finv, b, 1, 3), _product(X, Finv, b, 2, 0),
                _product(X, Finv, b, 2, 1), _product(X, Finv, b, 2, 2), _product(X, Finv, b, 2, 3))
    return (X[0], X[1], X[2], X[3], X[4], X[5], X[6], X[7], X[8], X[9], X[10], X[11])


@njit(cache=True, error_model="numpy")
def _arm_row(par, b):
    """Row `b` of the per-arm numbers as a 31-tuple (see `_ikine_compiled`)."""
    return (par[b, 0], par[b, 1], par[b, 2], par[b, 3], par[b, 4], par[b, 5], par[b, 6],
            par[b, 7], par[b, 8], par[b, 9], par[b, 10], par[b, 11], par[b, 12],
            par[b, 13], par[b, 14], par[b, 15], par[b, 16], par[b, 17], par[b, 18],
            par[b, 19], par[b, 20], par[b, 21], par[b, 22], par[b, 23], par[b, 24],
            par[b, 25], par[b, 26], par[b, 27], par[b, 28], par[b, 29], par[b, 30])


@njit(cache=True, error_model="numpy", inline="always")
def _wrist_regular(X0, Y0, cp, sp, nx1, nz, w, s5, u, d5, need6, need_psi):
    """The two wrist branches of a shoulder away from the wrist singularity: the frame-4 origins
    `(X_0, Y_0)`, `(X_1, Y_1)` in the arm plane, `ψ` and `θ6` of each (0 where not needed)."""
    th6_0 = th6_1 = psi0 = psi1 = 0.0
    if need6:
        x4n = cp * nx1 + sp * nz
        z4n = cp * nz - sp * nx1
        x4n = x4n * w + s5 * u
        th6_0 = math.atan2(z4n, x4n)
        th6_1 = th6_0 - math.copysign(math.pi, th6_0)
    if need_psi:
        psi0 = math.atan2(sp, cp)
        psi1 = psi0 + math.pi
    spd = sp * d5
    cpd = cp * d5
    X_0 = X0 - spd
    X_1 = X0 - (-spd)
    Y_0 = cpd + Y0
    Y_1 = -cpd + Y0
    return X_0, Y_0, X_1, Y_1, psi0, psi1, th6_0, th6_1


@njit(cache=True, error_model="numpy", inline="always")
def _wrist_singular(X0, Y0, nx1, nz, w, s5, u, d5, aa, need6, need_psi):
    """`_wrist_regular` at the wrist singularity (joint 4's angle free)."""
    th6_0 = th6_1 = psi0 = psi1 = 0.0
    # the free angle: |frame-4 origin|² aimed at a2² + a3², so the elbow is as close to a
    # right angle as the position allows
    pn = math.sqrt(X0 * X0 + Y0 * Y0)
    if pn < 1e-150 or abs(d5) < 1e-150:
        ex, ey, kappa = 1.0, 0.0, 0.0
    else:
        ex, ey = X0 / pn, Y0 / pn
        kappa = _clip1((aa - pn * pn - d5 * d5) / (2.0 * d5 * pn))
    perp = math.sqrt(1.0 - kappa * kappa)
    ex_0 = kappa * ex - perp * ey
    ey_0 = kappa * ey + perp * ex
    ex_1 = kappa * ex - (-perp) * ey
    ey_1 = kappa * ey + (-perp) * ex
    if need_psi:
        psi0 = math.atan2(-ex_0, ey_0)
        psi1 = math.atan2(-ex_1, ey_1)
    if need6:
        th6_0 = math.atan2(ey_0 * nz - (-ex_0) * nx1, w * (ey_0 * nx1 + (-ex_0) * nz) + s5 * u)
        th6_1 = math.atan2(ey_1 * nz - (-ex_1) * nx1, w * (ey_1 * nx1 + (-ex_1) * nz) + (-s5) * u)
    X_0 = X0 + d5 * ex_0
    Y_0 = Y0 + d5 * ey_0
    X_1 = X0 + d5 * ex_1
    Y_1 = Y0 + d5 * ey_1
    return X_0, Y_0, X_1, Y_1, psi0, psi1, th6_0, th6_1


@njit(cache=True, error_model="numpy", inline="always")
def _elbow(X, Y, rho2, psi, ok, aa, k1, fr, a2, a3, P, mapped, limited, full, q, valid, i, k0):
    """The two elbow branches `k0`, `k0 + 1` of a planar two-link arm `(a2, a3)` to the frame-4
    origin `(X, Y)`: whether one is valid. `full`: both written into row `i` of `q` and
    `valid`; else nothing is written and the answer comes at the first valid branch."""
    found = False
    c3 = rho2 - aa
    c3 = c3 * k1
    c3 = _clip1(c3 + fr)
    s3 = math.sqrt(1.0 - c3 * c3)
    gam = math.atan2(Y, X)
    th3 = math.atan2(s3, c3)
    beta = math.atan2(s3 * a3, c3 * a3 + a2)
    pg = psi - gam
    bt = beta - th3
    for el in range(2):
        if el == 0:
            t2, t3, t4 = gam - beta, th3, pg + bt
        else:
            t2, t3, t4 = gam + beta, -th3, pg - bt
        x2 = _joint(t2, 1, P, mapped)
        x3 = _joint(t3, 2, P, mapped)
        x4 = _joint(t4, 3, P, mapped)
        okl = ok and _inside(x2, 1, P, limited) and _inside(x3, 2, P, limited) and _inside(x4, 3, P, limited)
        if full:
            q[i, k0 + el, 1] = x2
            q[i, k0 + el, 2] = x3
            q[i, k0 + el, 3] = x4
            valid[i, k0 + el] = okl
            found = found or okl
        elif okl:
            return True
    return found


@njit(cache=True, error_model="numpy", inline="always")
def _wrist_branch(X, Y, psi, th6, t5, ok, lo2, hi2, aa, k1, fr, a2, a3, P, mapped, limited, full, need5, need6,
                  need_elbow, q, valid, i, k0):
    """The branches `k0`, `k0 + 1` of one shoulder and wrist branch (frame-4 origin `(X, Y)`,
    `ψ`, `θ6`, `θ5` = `t5`; `ok` whether the shoulder holds): whether one is valid. `full`:
    written into row `i` of `q` and `valid`; else nothing is written, and the answer comes
    as soon as it is known (the elbow only where a limit check needs it)."""
    rho2 = X * X
    rho2 = rho2 + Y * Y
    ok = ok and rho2 >= lo2 and rho2 <= hi2
    if not full and not ok:
        return False
    if need5:
        ok = _wrist_joint(t5, 4, P, mapped, limited, ok, full, q, i, k0)
    if need6:
        ok = _wrist_joint(th6, 5, P, mapped, limited, ok, full, q, i, k0)
    if not full and (not ok or not need_elbow):
        return ok
    # ---- elbow: a planar two-link arm (a2, a3) to (X, Y)
    return _elbow(X, Y, rho2, psi, ok, aa, k1, fr, a2, a3, P, mapped, limited, full, q, valid, i, k0)


@njit(cache=True, error_model="numpy", inline="always")
def _elbow_constants(a2, a3, atol):
    """The elbow's numbers: the reach `[lo_e, hi_e]` of the two-link arm `(a2, a3)` (with
    `atol`) and its squares, `1 / (2·a2·a3)` and 1 where that is infinite (`k1`, `fr`), and
    `a2² + a3²`."""
    L1, L2 = abs(a2), abs(a3)
    lo_e = abs(L1 - L2) - atol
    if not lo_e > 0.0:
        lo_e = 0.0
    hi_e = L1 + L2 + atol
    lo2, hi2 = lo_e * lo_e, hi_e * hi_e
    den = 2.0 * a2 * a3
    free = den == 0.0
    k1 = 0.0 if free else 1.0 / den
    fr = 1.0 if free else 0.0
    aa = a2 * a2 + a3 * a3
    return lo_e, hi_e, lo2, hi2, k1, fr, aa


@njit(cache=True, error_model="numpy", inline="always")
def _shortcut_bounds(r, wz, a1, d1, d5, lo_e, hi_e):
    """The squared bounds `(far2, near2)` of `|(X0, Y0)|` outside which the reach-only shortcut
    rules out both wrist branches of a shoulder (`near2` -1 where there is no inner bound)."""
    margin = 1e-9 * (r + abs(wz) + abs(a1) + abs(d1) + abs(d5) + hi_e)
    far = hi_e + abs(d5) + margin
    far2 = far * far
    near = lo_e - abs(d5) - margin
    near2 = near * near if near > 0.0 else -1.0
    return far2, near2


@njit(cache=True, error_model="numpy", inline="always")
def _wrist(n0, n1, o0, o1, z0, z1, c1, s1, ax1, az, nx1, nz, X0, Y0, d5, aa, need5, need6, need_psi):
    """The two wrist branches of shoulder `(c1, s1)`: `_wrist_regular`'s (or, at the wrist
    singularity, `_wrist_singular`'s) eight numbers and `θ5` of branch 0 (0 where not needed)."""
    u = v = w = s5 = 0.0
    if need5 or need6:
        u = n0 * s1 - n1 * c1
        v = o0 * s1 - o1 * c1
        w = z0 * s1 - z1 * c1
        s5 = math.sqrt(u * u + v * v)
    m = math.sqrt(ax1 * ax1 + az * az)
    sing = m < _SINGULAR
    fs = 1.0 if sing else 0.0
    m = m + fs
    cp = -(ax1 / m) + fs
    sp = -(az / m)
    th5 = math.atan2(s5, w) if need5 else 0.0
    if not sing:
        X_0, Y_0, X_1, Y_1, psi0, psi1, th6_0, th6_1 = _wrist_regular(X0, Y0, cp, sp, nx1, nz, w, s5, u, d5,
                                                                      need6, need_psi)
    else:
        X_0, Y_0, X_1, Y_1, psi0, psi1, th6_0, th6_1 = _wrist_singular(X0, Y0, nx1, nz, w, s5, u, d5, aa,
                                                                       need6, need_psi)
    return X_0, Y_0, X_1, Y_1, psi0, psi1, th6_0, th6_1, th5


@njit(cache=True, error_model="numpy", inline="always")
def _needs(full, limited):
    """Which angles `_branches` computes: all with `full`, else those a limit check needs
    (`limited` bit `j` for joint `j`): `(θ1, θ5, θ6, ψ, the elbow)`."""
    need1 = full or limited & 1 != 0
    need5 = full or limited & 16 != 0
    need6 = full or limited & 32 != 0
    need_psi = full or limited & 8 != 0
    need_elbow = full or limited & 14 != 0
    return need1, need5, need6, need_psi, need_elbow


@njit(cache=True, error_model="numpy", inline="always")
def _branches(A, P, mapped, limited, atol, full, q, valid, i):
    """The closed form of one target (the geometry is in the module notes); returns whether some
    branch is valid.

    `A`: rows 0..2 of the target in the joint-1 frame (mounts applied), a 12-tuple row by row;
    `P`: the arm's numbers (`_arm_row`); `mapped`, `limited`: bit `j` set where joint
    `j`'s angle is mapped (sign, shift) and where its limits are checked. `full` (a literal):
    every branch's `q` and `valid` written into row `i` of `q` (M, 8, 6) and `valid`
    (M, 8). Otherwise nothing is written, the search stops at the first valid branch, a branch is
    dropped as soon as its reach or a limit fails, and only the angles that some limit check needs
    are computed (none, without limits).
    """
    d1, a1, a2, a3, d4, d5, d6 = P[0], P[1], P[2], P[3], P[4], P[5], P[6]
    n0, o0, z0, p0, n1, o1, z1, p1, n2, o2, z2, p2 = A
    need1, need5, need6, need_psi, need_elbow = _needs(full, limited)
    found = False
    # ---- shoulder
    wx = p0 - d6 * z0
    wy = p1 - d6 * z1
    wz = p2 - d6 * z2
    nz, az = n2, z2
    r2 = wx * wx
    r2 = r2 + wy * wy
    r = math.sqrt(r2)
    reach_sh = r >= abs(d4) - atol
    if not full and not reach_sh:
        return False
    on_axis = 1.0 if r2 < 1e-200 else 0.0
    r = r + on_axis
    ux = wx / r
    uy = wy / r
    ux = ux + on_axis
    sd = _clip1(d4 / r)
    cd = math.sqrt(1.0 - sd * sd)
    lo_e, hi_e, lo2, hi2, k1, fr, aa = _elbow_constants(a2, a3, atol)
    Y0 = wz - d1
    # reach-only shortcut: the frame-4 origin lies at distance |d5| from the wrist point (X0, Y0)
    # in the arm plane, so |(X0, Y0)| outside [lo − |d5|, hi + |d5|] (with a margin far above
    # the rounding of these numbers) rules out both wrist branches of a shoulder before the
    # square root and divisions of the wrist; it only skips what the full computation rejects
    far2, near2 = _shortcut_bounds(r, wz, a1, d1, d5, lo_e, hi_e)
    for s in range(2):
        sg = 1.0 if s == 0 else -1.0
        c1 = sg * (ux * cd) - uy * sd
        s1 = sg * (uy * cd) + ux * sd
        ok1 = True
        if need1:
            x = _joint(math.atan2(s1, c1), 0, P, mapped)
            ok1 = _inside(x, 0, P, limited)
            if full:
                for k in range(4):
                    q[i, 4 * s + k, 0] = x
            elif not ok1:
                continue
        # ---- wrist
        nx1 = n0 * c1 + n1 * s1
        ax1 = z0 * c1 + z1 * s1
        X0 = wx * c1 + wy * s1
        X0 = X0 - a1
        if not full:
            P2 = X0 * X0 + Y0 * Y0
            if P2 > far2 or P2 < near2:
                continue
        # per wrist branch j: the frame-4 origin (X, Y) in the arm plane, ψ = θ2+θ3+θ4 and θ6
        X_0, Y_0, X_1, Y_1, psi0, psi1, th6_0, th6_1, th5 = _wrist(n0, n1, o0, o1, z0, z1, c1, s1, ax1, az, nx1, nz,
                                                                   X0, Y0, d5, aa, need5, need6, need_psi)
        for j in range(2):
            if j == 0:
                X, Y, psi, th6, t5 = X_0, Y_0, psi0, th6_0, th5
            else:
                X, Y, psi, th6, t5 = X_1, Y_1, psi1, th6_1, th5 * -1.0
            k0 = 4 * s + 2 * j
            ok = ok1 and reach_sh
            hit = _wrist_branch(X, Y, psi, th6, t5, ok, lo2, hi2, aa, k1, fr, a2, a3, P, mapped, limited, full,
                                need5, need6, need_elbow, q, valid, i, k0)
            if full:
                found = found or hit
            elif hit:
                return True
    return found


@njit(cache=True, parallel=True, error_model="numpy")
def _run(T, tix, arm, par, mapped, limited, base_mode, Binv, flange_mode, Finv, atol, M, full, q, valid, reach, bad):
    """Every target `i < M`: pose `T[tix[i]]` (`T[i]` if `tix` is empty) for arm `arm[i]`
    (0 if empty). `full`: all branches into `q` (M, 8, 6) and `valid` (M, 8); else
    reachability into `reach` (M,). `bad[task]`: a pose of the task failed the quick rigidity
    test. Targets go to threads in tasks of `TARGETS_PER_TASK`; each target is independent,
    so the results do not depend on the thread count."""
    ntask = bad.shape[0]
    tol = 0.25 * _RIGID_TOL
    for task in prange(ntask):
        flag = False
        for i in range(task * TARGETS_PER_TASK, min(M, (task + 1) * TARGETS_PER_TASK)):
            t = tix[i] if tix.shape[0] else i
            b = arm[i] if arm.shape[0] else 0
            if _rigid_bad(T, t, tol):
                flag = True
            A = _target(T, t, b, base_mode, Binv, flange_mode, Finv)
            P = _arm_row(par, b)
            if full:
                _branches(A, P, mapped, limited, atol, True, q, valid, i)
            else:
                reach[i] = _branches(A, P, mapped, limited, atol, False, q, valid, i)
        bad[task] = flag


register(ClosedForm(name="ur", description="the UR family", recognise=is_ur_type, require=require_ur_type,
                    solve=ikine_ur, reachable=ur_reachable, priority=30))


numba.config.CACHE_DIR = _NUMBA_CACHE_DIR_BEFORE
