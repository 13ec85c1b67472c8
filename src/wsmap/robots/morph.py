"""The `morph6` and `morph7` families: random serial arms of 6 and 7 revolute joints that
cover the real industrial and collaborative arms, for one map model of every arm.

An arm of these families is a canonical morphology (`wsmap.kinematics.morphology`) whose
first joint axis is the base `z` axis (`mount` the identity). Its parameters (the family's
`params`, the dataset's feature columns) are, per joint `i`, `a_i, alpha_i, d_i, theta_i,
lo_i, hi_i` (the canonical modified-DH row and the limits in the description's coordinate; a
range of a full turn or more written as `[-pi, pi]`, which reaches the same poses), then the
tool's translation `tool_x, tool_y, tool_z` (m, in frame n) and rotation vector `tool_rx,
tool_ry, tool_rz` (rad): `6 n + 6` numbers (42 for `morph6`, 48 for `morph7`). Metres and
radians.

The draw (`MorphFamily.draw`, one arm after the other from one generator, so the first
`k` arms of a seed are the arms of `count = k`), per joint row `(alpha_{i-1}, a_{i-1}, d_i,
theta_i)` of a modified-DH table (row 1: `a_0 = alpha_0 = 0`, `d_1 ~ U(0, 0.45)`):

* twist `alpha`: 0 (p 0.2), +pi/2 (0.35), -pi/2 (0.35), `U(-pi, pi)` (0.1);
* length `a`: 0 (p 0.55), else `U(0.02, 0.7)`; offset `d`: 0 (p 0.5), else `±U(0.02, 0.7)`;
* offset `theta`: 0 (p 0.5), pi (0.2), ±pi/2 (0.2), `U(-pi, pi)` (0.1);
* limits: a full turn (p 0.3), else half-width `U(1.4, pi)` about 0 (p 0.7) or about a centre
  `U(-2, 2)` (the Panda's joints 4 and 6 are such);
* tool: `Tz(t)` with `t ~ ±U(0, 0.25)` (plus a lateral `U(-0.1, 0.1)²` with p 0.2), rotated by
  `Rz(psi)`, `psi` in {0, ±pi/2, pi} (p 0.7), by `Rx(pi)·Rz(psi)` (0.2), or uniformly (0.1);
* every length (and the tool's offset) is scaled by `min(1, R / L)`, `R ~ U(0.5, 1.8)` and `L`
  the arm's length bound `sum_i sqrt(a_i² + d_i²) + |t|`, so no arm is much longer than a UR10e
  (1.78 m by the same bound);
* the arm is drawn again while its canonical description is outside the family's range (below),
  while its length bound is under 0.4 m (an arm that reaches a few grid nodes at most; the
  smallest real arms here have 0.9 m), or while it lies within `HOLD_OUT_RADIUS` of a held-out arm
  (`HELD_OUT`: the six named arms), in `morphology_distance`.

The table is then described canonically (`describe`): the
params are the canonical description, so `MorphFamily.params_of` of
`MorphFamily.arms` gives the params back.

The family's range (`MorphFamily.check_params`: what its datasets hold and a model trained
on them may be asked): `0 <= a <= 0.7`, `|d| <= 0.7`, `d_1` in `[0, 0.45]`, a joint range
of at least 2.8 rad (2·1.4), `|tool translation| <= 0.3`, length bound at most 1.8 m.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from functools import cached_property
from typing import ClassVar

import numpy as np

from ..kinematics import SerialChain
from ..kinematics.chain import from_dh
from ..kinematics.morphology import Morphology, describe, morphology_distance
from .families import FAMILIES, ArmFamily, FamilyRangeWarning, as_generator, check_count
from .registry import ARMS, load

__all__ = ["MorphFamily", "MORPH6", "MORPH7", "HELD_OUT", "HOLD_OUT_RADIUS", "MORPH_GRID", "morph_params",
           "morphology_of", "held_out_features"]

#: The named arms never drawn (and every arm a generalisation test uses): no arm of the families
#: lies within `HOLD_OUT_RADIUS` of them. Each arm says so in its own module (`held_out=True`
#: when it registers, `wsmap.robots.arms`); in the order of the named arms (today all six:
#: puma560, panda, iiwa14, ur5e, ur10e, gen3).
HELD_OUT: tuple[str, ...] = tuple(arm.name for arm in ARMS if arm.held_out)
#: Metres, in `morphology_distance` (e.g. all lengths within
#: ~4 cm and the twists, offsets, limits and tool the same).
HOLD_OUT_RADIUS = 0.1
#: Half-width (m) of the families' default grid, `[-1.5, 1.5]³`.
MORPH_GRID = 1.5

_JOINT_PARAMS = ("a", "alpha", "d", "theta", "lo", "hi")
_TOOL_PARAMS = ("tool_x", "tool_y", "tool_z", "tool_rx", "tool_ry", "tool_rz")
_MAX_LENGTH = 0.7
_MAX_D1 = 0.45
_MIN_RANGE = 2.8
_MAX_TOOL = 0.3
_MAX_BOUND = 1.8
#: the least length bound of a drawn arm (m): below it the arm reaches a few grid nodes at most
_MIN_BOUND = 0.4


def _rotvec_to_matrix(r) -> np.ndarray:
    """Rotation matrices `(..., 3, 3)` of rotation vectors `(..., 3)` (rad; Rodrigues)."""
    r = np.asarray(r, dtype=np.float64)
    th = np.linalg.norm(r, axis=-1)
    k = r / np.where(th > 0, th, 1.0)[..., None]
    K = np.zeros(r.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -k[..., 2], k[..., 1], -k[..., 0]
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = k[..., 2], -k[..., 1], k[..., 0]
    s, c = np.sin(th)[..., None, None], np.cos(th)[..., None, None]
    return np.eye(3) + s * K + (1 - c) * (K @ K)


def _matrix_to_rotvec(R) -> np.ndarray:
    """The rotation vector `(3,)` of one rotation matrix (angle in [0, pi])."""
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / 2  # sin(th)·axis
    th = np.arctan2(np.linalg.norm(v), (np.trace(R) - 1) / 2)  # precise also near 0 and pi, unlike arccos
    if th < 1e-12:
        return np.zeros(3)
    if np.pi - th < 1e-6:  # near a half turn: the axis from the symmetric part
        B = (R + np.eye(3)) / 2
        k = np.sqrt(np.clip(np.diag(B), 0, None))
        i = int(np.argmax(k))
        k = B[i] / k[i]
        k /= np.linalg.norm(k)
        # a half turn about k is one about -k: the first clearly non-zero component positive
        j = int(np.flatnonzero(np.abs(k) > 1e-6)[0])
        return th * (k if k[j] > 0 else -k)
    return th * v / np.linalg.norm(v)


def _length_bound(p: np.ndarray, n: int) -> float:
    """`sum_i sqrt(a_i² + d_i²) + |tool translation|` (m) of one arm's parameters: no point of the
    arm is farther than that from its base origin."""
    per = p[: 6 * n].reshape(n, 6)
    return float(np.sqrt(per[:, 0] ** 2 + per[:, 2] ** 2).sum() + np.linalg.norm(p[6 * n: 6 * n + 3]))


def morph_params(m: Morphology) -> np.ndarray:
    """The family parameters `(6 n + 6,)` of a canonical morphology (see the module notes)."""
    lim = m.limits
    full = (lim[:, 1] - lim[:, 0]) >= 2 * np.pi
    lim = np.where(full[:, None], np.array([-np.pi, np.pi]), lim)
    per = np.column_stack([m.mdh, lim])
    return np.concatenate([per.ravel(), m.tool[:3, 3], _matrix_to_rotvec(m.tool[:3, :3])])


def morphology_of(params, name: str | None = None) -> Morphology:
    """The `Morphology` of one arm's family parameters."""
    p = np.asarray(params, dtype=np.float64)
    n = (p.shape[-1] - 6) // 6
    per = p[: 6 * n].reshape(n, 6)
    tool = np.eye(4)
    tool[:3, :3] = _rotvec_to_matrix(p[6 * n + 3: 6 * n + 6])
    tool[:3, 3] = p[6 * n: 6 * n + 3]
    return Morphology(mdh=per[:, :4], qlim=per[:, 4:], mount=np.eye(4), tool=tool, name=name)


def held_out_features() -> dict[str, np.ndarray]:
    """Morphology features (`features`) of every arm of
    `HELD_OUT`, by name."""
    return dict(_held_out())


_HELD: list = []


def _held_out():
    if not _HELD:
        _HELD.extend((name, describe(load(name)).features()) for name in HELD_OUT)
    return _HELD


@dataclass(frozen=True)
class MorphFamily(ArmFamily):
    """Random arms of `n_joints` revolute joints over the range of real arms (module notes).

    `low` and `high` of `ArmFamily` are not used: every parameter has its
    own range, checked by `check_params`."""

    n_joints: int = 7

    chain: ClassVar[bool] = True
    feature_prefix: ClassVar[str] = ""
    grid: ClassVar[float] = MORPH_GRID

    @cached_property
    def _held(self) -> np.ndarray:
        return np.stack([f for _, f in _held_out()])

    # ------------------------------------------------------------------ the draw
    def _draw_table(self, rng: np.random.Generator):
        n = self.n_joints
        alpha = rng.choice([0.0, np.pi / 2, -np.pi / 2, np.nan], size=n, p=[0.2, 0.35, 0.35, 0.1])
        alpha = np.where(np.isnan(alpha), rng.uniform(-np.pi, np.pi, n), alpha)
        a = np.where(rng.random(n) < 0.55, 0.0, rng.uniform(0.02, _MAX_LENGTH, n))
        d = np.where(rng.random(n) < 0.5, 0.0, rng.uniform(0.02, _MAX_LENGTH, n) * rng.choice([-1.0, 1.0], n))
        theta = rng.choice([0.0, np.pi, np.pi / 2, -np.pi / 2, np.nan], size=n, p=[0.5, 0.2, 0.1, 0.1, 0.1])
        theta = np.where(np.isnan(theta), rng.uniform(-np.pi, np.pi, n), theta)
        alpha[0], a[0], d[0] = 0.0, 0.0, rng.uniform(0.0, _MAX_D1)
        full = rng.random(n) < 0.3
        half = rng.uniform(1.4, np.pi, n)
        centre = np.where(rng.random(n) < 0.7, 0.0, rng.uniform(-2.0, 2.0, n))
        qlim = np.where(full[:, None], np.array([-np.pi, np.pi]), np.column_stack([centre - half, centre + half]))
        t = np.array([0.0, 0.0, rng.uniform(0.0, 0.25) * rng.choice([-1.0, 1.0])])
        if rng.random() < 0.2:
            t[:2] = rng.uniform(-0.1, 0.1, 2)
        u = rng.random()
        psi = rng.choice([0.0, np.pi / 2, -np.pi / 2, np.pi])
        cz, sz = np.cos(psi), np.sin(psi)
        Rz = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
        if u < 0.7:
            R = Rz
        elif u < 0.9:
            R = np.diag([1.0, -1.0, -1.0]) @ Rz
        else:
            q = rng.standard_normal(4)
            q /= np.linalg.norm(q)
            R = _rotvec_to_matrix(2 * np.arccos(np.clip(q[0], -1, 1)) * q[1:] / max(np.linalg.norm(q[1:]), 1e-12))
        bound = np.sqrt(a ** 2 + d ** 2).sum() + np.linalg.norm(t)
        scale = min(1.0, rng.uniform(0.5, _MAX_BOUND) / bound) if bound > 0 else 1.0
        tool = np.eye(4)
        tool[:3, :3], tool[:3, 3] = R, t * scale
        return d * scale, a * scale, alpha, theta, qlim, tool

    def _one(self, rng: np.random.Generator) -> np.ndarray:
        while True:
            d, a, alpha, theta, qlim, tool = self._draw_table(rng)
            arm = from_dh(d, a, alpha, offset=theta, qlim=qlim, modified=True, flange=tool)
            p = morph_params(describe(arm))
            # the canonical rows can leave the range (offsets of coincident axes add up): drawn again
            if _length_bound(p, self.n_joints) >= _MIN_BOUND and not self.problems(p) and morphology_distance(morphology_of(p).features(), self._held).min() > HOLD_OUT_RADIUS:
                return p

    def draw(self, count: int, seed=None) -> np.ndarray:
        """The parameters `(count, 6 n + 6)` of `count` random arms (module notes), from
        `seed` (an int, `None` or a `numpy.random.Generator`), one arm after another."""
        count = check_count(count)
        rng = as_generator(seed)
        return np.stack([self._one(rng) for _ in range(count)])

    # ------------------------------------------------------------------ the range
    def problems(self, p: np.ndarray) -> list[str]:
        """What puts one arm's parameters `(6 n + 6,)` outside the family's range (empty: inside)."""
        n = self.n_joints
        per = p[: 6 * n].reshape(n, 6)
        out = []
        for i, (a, _alpha, d, _theta, lo, hi) in enumerate(per, 1):
            if not 0.0 <= a <= _MAX_LENGTH + 1e-12:
                out.append(f"a_{i} = {a:.4g} m is outside [0, {_MAX_LENGTH}]")
            dmax = _MAX_D1 if i == 1 else _MAX_LENGTH
            if not (-dmax - 1e-12 <= d <= dmax + 1e-12) or (i == 1 and d < -1e-12):
                out.append(f"d_{i} = {d:.4g} m is outside [{0 if i == 1 else -dmax}, {dmax}]")
            if hi - lo < _MIN_RANGE - 1e-9:
                out.append(f"joint {i} moves {hi - lo:.3g} rad, under the family's least range {_MIN_RANGE} rad")
        if abs(per[0, 0]) > 1e-9 or abs(per[0, 1]) > 1e-9:
            out.append("the first joint axis is not the base z axis (a_0 = alpha_0 = 0)")
        t = p[6 * n: 6 * n + 3]
        if np.linalg.norm(t) > _MAX_TOOL + 1e-12:
            out.append(f"the tool is {np.linalg.norm(t):.3g} m from the last axis' frame, more than {_MAX_TOOL} m")
        bound = _length_bound(p, n)
        if bound > _MAX_BOUND + 1e-9:
            out.append(f"the length bound sum(sqrt(a² + d²)) + |tool| is {bound:.3g} m, more than {_MAX_BOUND} m")
        return out

    def check_params(self, params, allow_extrapolation: bool = False, stacklevel: int = 2) -> np.ndarray:
        """`params` as float64 `(..., 6 n + 6)`, checked: the shape, finite values, and inside
        the family's range (module notes) -- outside it a `ValueError` naming the first problem,
        or with `allow_extrapolation` a `FamilyRangeWarning`."""
        if not isinstance(allow_extrapolation, (bool, np.bool_)):
            raise ValueError(f"allow_extrapolation must be True or False, got {allow_extrapolation!r}")
        try:
            s = np.array(params, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"parameters of family {self.name!r} must be numbers of shape (..., {self.n_params}), "
                             f"got {type(params).__name__}") from None
        if s.ndim == 0 or s.shape[-1] != self.n_params:
            raise ValueError(f"parameters of family {self.name!r} must have shape (..., {self.n_params}) "
                             f"({', '.join(self.params[:6])}, ... per joint, then the tool), got shape {s.shape}")
        if not np.all(np.isfinite(s)):
            raise ValueError(f"parameters of family {self.name!r} must be finite")
        flat = s.reshape(-1, self.n_params)
        for b, row in enumerate(flat):
            probs = self.problems(row)
            if probs:
                where = f" (arm {b})" if s.ndim > 1 else ""
                what = f"outside family {self.name!r}{where}: {probs[0]}"
                if not allow_extrapolation:
                    raise ValueError(f"{what}; pass allow_extrapolation=True to build the arm anyway")
                more = len(probs) - 1
                warnings.warn(f"{what}{f' (and {more} more)' if more else ''}; built anyway "
                              "(allow_extrapolation=True): the family's datasets and models have no such arm",
                              FamilyRangeWarning, stacklevel=stacklevel)
                break
        return s

    # ------------------------------------------------------------------ arms
    def arms(self, params, *, allow_extrapolation: bool = False, stacklevel: int = 2) -> SerialChain:
        """The arms `(...)` of `params` `(..., 6 n + 6)`: a `SerialChain` batch (modified
        DH, the tool in `F_n`, the limits of the params)."""
        s = self.check_params(params, allow_extrapolation, stacklevel + 1)
        n = self.n_joints
        per = s[..., : 6 * n].reshape(s.shape[:-1] + (n, 6))
        arm = from_dh(per[..., 2], per[..., 0], per[..., 1], offset=per[..., 3], qlim=per[..., 4:], modified=True,
                      name=self.name)
        tool = np.broadcast_to(np.eye(4), s.shape[:-1] + (4, 4)).copy()
        tool[..., :3, :3] = _rotvec_to_matrix(s[..., 6 * n + 3: 6 * n + 6])
        tool[..., :3, 3] = s[..., 6 * n: 6 * n + 3]
        fixed = arm.fixed.copy()
        fixed[..., n, :, :] = fixed[..., n, :, :] @ tool
        return arm.replace(fixed=fixed)

    def params_of(self, arms, atol: float = 1e-9) -> np.ndarray:
        """The parameters `(B, 6 n + 6)` of a batch `(B,)` of arms (or `(6 n + 6,)` of one arm):
        any arm of `n_joints` revolute joints whose first axis is the base `z` axis (its canonical
        description, `morph_params`); others are a `ValueError` naming the problem."""
        from ..kinematics import as_chain

        try:
            chain = as_chain(arms)
        except TypeError as e:
            raise TypeError(f"arms of family {self.name!r}: {e}") from None
        if chain.n != self.n_joints:
            raise ValueError(f"arms of family {self.name!r} have {self.n_joints} joints, got {chain.n}")
        one = chain.batch_shape == ()
        batch = [chain] if one else [chain[b] for b in range(chain.batch_shape[0])]
        rows = []
        for arm in batch:
            m = describe(arm)
            if np.abs(m.mount - np.eye(4)).max() > atol:
                raise ValueError(f"{arm.name or 'an arm'} is not of family {self.name!r}: its first joint axis is not "
                                 "the base z axis")
            rows.append(morph_params(m))
        return rows[0] if one else np.stack(rows)


def _family(n: int) -> MorphFamily:
    params = tuple(f"{k}_{i}" for i in range(1, n + 1) for k in _JOINT_PARAMS) + _TOOL_PARAMS
    return MorphFamily(name=f"morph{n}", title=f"random {n}R arms over the range of real arms", params=params,
                       low=-np.pi, high=np.pi, exact=False, n_joints=n)


#: Random 6R arms (module notes); 42 parameters.
MORPH6 = _family(6)
#: Random 7R arms (module notes); 48 parameters.
MORPH7 = _family(7)

for _f in (MORPH6, MORPH7):
    FAMILIES[_f.name] = _f
