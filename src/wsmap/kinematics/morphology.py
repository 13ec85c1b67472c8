"""The morphology description: one canonical record of any serial arm of 6 or 7 revolute joints.

Whatever an arm came from -- a standard or modified DH table, a named arm, a URDF -- it is a
`SerialChain`, and `describe` turns that chain into a
`Morphology`: per joint the modified-DH (Craig) parameters derived from the geometry of
the joint axes at the zero pose, the joint limits, and the two rigid transforms the DH rows cannot
hold (`mount`: the base frame to frame 0; `tool`: frame n to the tool). `Morphology.chain`
builds the chain back; its forward kinematics is the original arm's (to rounding, ~1e-15 m).

Why here and not in `wsmap.robots`: the description is a function of a chain's geometry
alone (a URDF arm and a DH arm get it the same way), and the kinematics layer imports nothing of
the named arms.

Canonical form (all lengths metres, angles radians, frames at `q = 0`, in the chain's world
frame, i.e. after its `base`)
-------------------------------------------------------------------------------------------------
Joint `i` (1-based) has the world axis `z_i` through the point `o_i`: the chain's axis with
its sign, except that a first axis pointing down (`z_1 · ẑ < 0`, Kinova's Gen3) is turned up;
`signs[i]` is then -1 and the description's joint coordinate is `-q_1` (the limits stay the
controller's, in `q`; `Morphology.features` writes them in the description's coordinate).

* frame 0: `z_0 = z_1`, origin the foot of the perpendicular from the world origin on axis 1,
  `x_0` the world `x` made perpendicular to `z_0` (the world `y` if `x` is along it);
  `mount` is the world → frame-0 transform, the identity for every arm whose first axis is the
  world `z` axis (all named arms, every arm of the `morph` family);
* frame `i` (`1 <= i < n`): `z_i` the axis, `x_i` along the common normal from axis `i` to
  axis `i+1`; where the axes intersect `x_i = z_i × z_{i+1}` (so `alpha_i` lies in (0, pi));
  where they are parallel the normal through the origin of frame `i`'s `x_{i-1}` foot point
  (so `d_{i+1}` of the next row carries the offset, Craig's choice); where they coincide
  `x_i = x_{i-1}`;
* frame `n`: `x_n = x_{n-1}`, origin on axis `n` at the foot of `x_{n-1}`: its row has
  `d_n = 0` and `theta_n = 0`; everything after it is `tool` (the flange and any tool);
* row `i` is `(a_{i-1}, alpha_{i-1}, d_i, theta_i)` with
  `T_{i-1,i}(q) = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i + q_i) Tz(d_i)`; `a_{i-1} >= 0`; the
  angles are wrapped to `(-pi, pi]`; `theta_i` is the joint's offset (controller zero against
  the DH zero). Row 1 has `a_0 = alpha_0 = 0`.

Joint limits are kept as the chain has them (`(n, 2)` rad, `±inf` for a continuous joint).

Padding: `Morphology.features` writes every arm as 7 joints; a 6-joint arm gets a zero 7th
row, the limits `[0, 0]` (a locked joint) and the flag `padded = 1`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .chain import PRISMATIC, SerialChain, as_chain, from_dh

__all__ = ["Morphology", "MorphologyError", "describe", "JOINTS", "FEATURE_NAMES", "N_FEATURES",
           "morphology_distance", "mdh_transform"]

#: Joint counts a morphology can have.
JOINTS = (6, 7)
#: Geometric tolerance (m, and rad-equivalent) below which two axes are parallel or intersect.
_EPS = 1e-9
#: Axes closer than this to parallel (rad) are taken as parallel, and a joint step may then differ
#: from its DH row by up to this much: URDF files round their numbers (`rpy="3.1416"` for pi),
#: which leaves axes that should be parallel 1e-5 rad apart and their common normal kilometres away.
SNAP = 1e-4


class MorphologyError(ValueError):
    """A robot that has no morphology description (not 6 or 7 revolute joints)."""


def _wrap(x):
    """Angles wrapped to `(-pi, pi]` (elementwise); within 1e-9 of -pi is pi (a half turn computed
    from rounded frames lands on either side of -pi; the description must not depend on which)."""
    w = np.mod(np.asarray(x, dtype=np.float64) + np.pi, 2 * np.pi) - np.pi
    return np.where(w <= -np.pi + 1e-9, np.pi, w)


def mdh_transform(a, alpha, d, theta) -> np.ndarray:
    """`Rx(alpha) Tx(a) Rz(theta) Tz(d)` as `(..., 4, 4)` (arguments broadcast; m, rad)."""
    a, alpha, d, theta = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (a, alpha, d, theta)))
    ca, sa, ct, st = np.cos(alpha), np.sin(alpha), np.cos(theta), np.sin(theta)
    T = np.zeros(a.shape + (4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 0, 3] = ct, -st, a
    T[..., 1, 0], T[..., 1, 1], T[..., 1, 2], T[..., 1, 3] = ca * st, ca * ct, -sa, -sa * d
    T[..., 2, 0], T[..., 2, 1], T[..., 2, 2], T[..., 2, 3] = sa * st, sa * ct, ca, ca * d
    T[..., 3, 3] = 1.0
    return T


def _frame(x, z, origin) -> np.ndarray:
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, np.cross(z, x), z, origin
    return T


def _unit_perp(v, z):
    """`v` made perpendicular to the unit `z` and normalised; `None` if `v` is along `z`."""
    p = v - np.dot(v, z) * z
    n = np.linalg.norm(p)
    return None if n < 1e-12 else p / n


def _inv(T):
    out = np.eye(4)
    out[:3, :3] = T[:3, :3].T
    out[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return out


@dataclass(frozen=True)
class Morphology:
    """The canonical description of one serial arm of 6 or 7 revolute joints (see the module notes).

    Attributes
    ----------
    mdh
        `(n, 4)` rows `(a_{i-1}, alpha_{i-1}, d_i, theta_i)` (m, rad, rad-offset).
    qlim
        `(n, 2)` joint limits `[lo, hi]` (rad; `±inf` continuous).
    mount
        `(4, 4)` world (base) frame → frame 0.
    tool
        `(4, 4)` frame n → tool (the flange and any tool on it).
    signs
        `(n,)` +1 or -1: the description's joint coordinate is `signs * q`.
    name
        the arm's name, for messages.
    residual
        the largest difference between a joint step of the arm and its DH row (m, and
        entries of rotation matrices): rounding for an exact DH arm; up to `SNAP` where
        nearly parallel axes were taken as parallel (the description is then of the nearest
        exact arm, and `chain` differs from the arm by about that much).
    """

    mdh: np.ndarray
    qlim: np.ndarray
    mount: np.ndarray
    tool: np.ndarray
    signs: np.ndarray | None = None
    name: str | None = None
    residual: float = 0.0

    def __post_init__(self):
        mdh = np.array(self.mdh, dtype=np.float64)
        if mdh.ndim != 2 or mdh.shape[1] != 4 or mdh.shape[0] not in JOINTS:
            raise MorphologyError(f"a morphology has 6 or 7 rows (a, alpha, d, theta), got shape {mdh.shape}")
        qlim = np.array(self.qlim, dtype=np.float64)
        if qlim.shape != (mdh.shape[0], 2):
            raise MorphologyError(f"qlim must have shape ({mdh.shape[0]}, 2), got {qlim.shape}")
        if not np.all(np.isfinite(mdh)) or np.any(np.isnan(qlim)):
            raise MorphologyError("a morphology's DH rows must be finite and its limits not NaN")
        object.__setattr__(self, "mdh", mdh)
        object.__setattr__(self, "qlim", qlim)
        object.__setattr__(self, "mount", np.array(self.mount, dtype=np.float64))
        object.__setattr__(self, "tool", np.array(self.tool, dtype=np.float64))
        signs = np.ones(mdh.shape[0]) if self.signs is None else np.array(self.signs, dtype=np.float64)
        if signs.shape != (mdh.shape[0],) or not np.all(np.abs(signs) == 1.0):
            raise MorphologyError(f"signs must be {mdh.shape[0]} values of +1 or -1, got {self.signs!r}")
        object.__setattr__(self, "signs", signs)

    @property
    def n(self) -> int:
        return self.mdh.shape[0]

    def chain(self) -> SerialChain:
        """The arm as a `SerialChain` (modified DH; mount in `F_0`, tool in `F_n`):
        base → tool, the limits of the description."""
        a, alpha, d, theta = self.mdh.T
        arm = from_dh(d, a, alpha, offset=theta, qlim=self.qlim, modified=True, flange=self.tool, name=self.name)
        fixed = arm.fixed.copy()
        fixed[0] = self.mount @ fixed[0]
        # a rotation by s·q about +z is one by q about s·z; the offset theta is in the description's coordinate
        axes = np.zeros((self.n, 3))
        axes[:, 2] = self.signs
        return arm.replace(fixed=fixed, axes=axes, offset=self.signs * theta)

    @property
    def limits(self) -> np.ndarray:
        """`(n, 2)` limits in the description's joint coordinate `signs * q` (rad)."""
        return np.where(self.signs[:, None] > 0, self.qlim, -self.qlim[:, ::-1])

    def features(self) -> np.ndarray:
        """The fixed-length vector `(N_FEATURES,)` a network reads (`FEATURE_NAMES`), padded
        to 7 joints. Angles as `(sin, cos)`; limits as the centre and half-width of the range,
        a range of a full turn or more (also `±inf`) written as centre 0, half-width pi (the same
        reachable set); the tool as its translation (m) and the third and first columns of its
        rotation; the mount is not a feature (it is the identity in the training distribution,
        `wsmap.robots.morph` checks it)."""
        rows = np.zeros((7, 4))
        rows[: self.n] = self.mdh
        lim = np.zeros((7, 2))
        lim[: self.n] = self.limits
        width = lim[:, 1] - lim[:, 0]
        full = width >= 2 * np.pi
        finite = np.where(full[:, None], 0.0, lim)
        centre = _wrap(0.5 * (finite[:, 0] + finite[:, 1]))
        half = np.where(full, np.pi, 0.5 * width)
        per_joint = np.stack([rows[:, 0], np.sin(rows[:, 1]), np.cos(rows[:, 1]), rows[:, 2],
                              np.sin(rows[:, 3]), np.cos(rows[:, 3]), np.sin(centre), np.cos(centre), half],
                             axis=1)
        if self.n == 6:
            per_joint[6] = 0.0
        tool = np.concatenate([self.tool[:3, 3], self.tool[:3, 2], self.tool[:3, 0]])
        return np.concatenate([per_joint.ravel(), tool, [float(self.n == 6)]])


_JOINT_FEATURES = ("a", "sin_alpha", "cos_alpha", "d", "sin_theta", "cos_theta", "sin_centre", "cos_centre",
                   "half_range")
#: Names of `Morphology.features`, in order: 9 per joint (7 joints), 9 of the tool, the flag.
FEATURE_NAMES = tuple(f"{k}_{i}" for i in range(1, 8) for k in _JOINT_FEATURES) + (
    "tool_x", "tool_y", "tool_z", "tool_zx", "tool_zy", "tool_zz", "tool_xx", "tool_xy", "tool_xz", "padded")
N_FEATURES = len(FEATURE_NAMES)
#: Scale of each feature in `morphology_distance`: lengths in metres as they are, the
#: dimensionless (sin, cos) pairs and direction cosines times 0.2 m (a twist error of 1 rad about
#: a 0.2 m link moves the next joint by about 0.2 m), half-ranges (rad) times 0.1 m, the flag 1 m
#: (a 6-joint arm is never near a 7-joint one).
_FEATURE_SCALE = np.array([{"a": 1.0, "d": 1.0, "half_range": 0.1}.get(k, 0.2) for k in _JOINT_FEATURES] * 7
                          + [1.0] * 3 + [0.2] * 6 + [1.0])


def morphology_distance(x, y) -> np.ndarray:
    """The distance (m) between morphology feature vectors `x` `(..., N_FEATURES)` and `y`
    (broadcast): the Euclidean norm of the feature difference with each feature scaled as
    `_FEATURE_SCALE` says (lengths in metres, angles as 0.2 m per unit of sin/cos). Two
    arms at distance 0 have the same geometry, limits and tool."""
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    return np.linalg.norm((x - y) * _FEATURE_SCALE, axis=-1)


def _describable(robot, name: str | None) -> SerialChain:
    """`robot` as one chain of 6 or 7 revolute joints, or the `MorphologyError` of `describe`."""
    try:
        chain = as_chain(robot)
    except TypeError as e:
        raise MorphologyError(str(e)) from None
    label = name or chain.name or "the arm"
    if chain.batch_shape != ():
        raise MorphologyError(f"{label}: describe() takes one arm, got a batch of shape {chain.batch_shape}")
    if PRISMATIC in chain.kinds:
        j = chain.kinds.index(PRISMATIC) + 1
        raise MorphologyError(f"{label}: joint {j} is prismatic; a morphology has revolute joints only")
    if chain.n not in JOINTS:
        raise MorphologyError(f"{label} has {chain.n} joints; a morphology has 6 or 7 revolute joints")
    return chain


def describe(robot, name: str | None = None) -> Morphology:
    """The canonical `Morphology` of one arm (a `SerialChain` or
    `DHRobot`, batch shape `()`) of 6 or 7 revolute joints.

    An arm with a prismatic joint, fewer than 6 or more than 7 joints, or a batch of arms is a
    `MorphologyError` naming what is wrong.
    """
    chain = _describable(robot, name)
    label = name or chain.name or "the arm"
    n = chain.n
    frames, T0 = chain.joint_frames(np.zeros(n))
    z = np.einsum("nij,nj->ni", frames[:, :3, :3], chain.axes)
    z /= np.linalg.norm(z, axis=1, keepdims=True)
    signs = np.ones(n)
    if z[0, 2] < -1e-12:  # a first axis pointing down: turn it up (and count its angle the other way)
        signs[0] = -1.0
    z = z * signs[:, None]
    o = frames[:, :3, 3]
    # frame 0: on axis 1, nearest the world origin, x from the world x
    origin = o[0] - np.dot(o[0], z[0]) * z[0]
    x = _unit_perp(np.array([1.0, 0.0, 0.0]), z[0])
    if x is None:
        x = _unit_perp(np.array([0.0, 1.0, 0.0]), z[0])
    F = [_frame(x, z[0], origin)]
    foot = origin  # where x_{i-1} meets axis i
    for i in range(n):
        if i + 1 < n:
            zi, zj, oi, oj = z[i], z[i + 1], o[i], o[i + 1]
            c = np.cross(zi, zj)
            if np.linalg.norm(c) > SNAP:
                # closest points of the two lines oi + t zi, oj + s zj
                w = oi - oj
                b = np.dot(zi, zj)
                den = 1.0 - b * b
                t = (b * np.dot(zj, w) - np.dot(zi, w)) / den
                s = (np.dot(zj, w) - b * np.dot(zi, w)) / den
                p, q = oi + t * zi, oj + s * zj
                gap = np.linalg.norm(q - p)
                xi = (q - p) / gap if gap > _EPS else c / np.linalg.norm(c)
                origin_i = p
            else:  # parallel axes: the normal through the foot of x_{i-1}
                origin_i = foot
                xi = _unit_perp(oj - foot, zi)
                if xi is None:  # coincident axes
                    xi = _unit_perp(F[-1][:3, 0], zi)
                    if xi is None:
                        xi = _unit_perp(F[-1][:3, 1], zi)
        else:  # the last frame: on axis n at the foot of x_{n-1}, x_n = x_{n-1}
            origin_i = foot
            xi = _unit_perp(F[-1][:3, 0], z[i])
            if xi is None:
                xi = _unit_perp(F[-1][:3, 1], z[i])
        Fi = _frame(xi, z[i], origin_i)
        F.append(Fi)
        if i + 1 < n:
            # the foot of x_i on axis i+1 (x_i's line meets it by construction)
            rel = o[i + 1] - origin_i
            tt = np.dot(rel, xi)
            foot = origin_i + tt * xi
    rows = np.empty((n, 4))
    residual = 0.0
    for i in range(n):
        rel = _inv(F[i]) @ F[i + 1]
        R, t = rel[:3, :3], rel[:3, 3]
        theta = np.arctan2(-R[0, 1], R[0, 0])
        alpha = np.arctan2(-R[1, 2], R[2, 2])
        d = -np.sin(alpha) * t[1] + np.cos(alpha) * t[2]
        rows[i] = (t[0], alpha, d, theta)
        err = np.abs(mdh_transform(t[0], alpha, d, theta) - rel).max()
        residual = max(residual, float(err))
        # the frames are built to make this a DH step (to SNAP where axes were snapped parallel)
        if err > SNAP:
            raise MorphologyError(f"{label}: frames {i} -> {i + 1} are not a modified-DH step (error {err:.2e})")
    rows[:, 1] = _wrap(rows[:, 1])
    rows[:, 3] = _wrap(rows[:, 3])
    # rounding leaves ±1e-17 where a length or angle is zero: zero, so that the description's
    # signs and zeros do not depend on the order the arm's transforms were multiplied in
    rows[np.abs(rows) < 1e-12] = 0.0
    mount = F[0]
    tool = _inv(F[n]) @ T0
    qlim = np.array(chain.limits, dtype=np.float64)
    return Morphology(mdh=rows, qlim=qlim, mount=mount, tool=tool, signs=signs, name=name or chain.name,
                      residual=residual)
