"""General serial chains: revolute and prismatic joints between fixed transforms, batched over arms.

A chain of `n` joints is::

    T(q) = base · F_0 · M_1(q_1 + offset_1) · F_1 · M_2(q_2 + offset_2) · F_2 ··· M_n(q_n + offset_n) · F_n · tool

where `F_i` are fixed homogeneous transforms (`(..., n + 1, 4, 4)`, leading dimensions a batch
of arms) and `M_i(x)` is a rotation by `x` (rad) about the unit axis `axes[i]` for a revolute
joint or a translation by `x` (m) along it for a prismatic joint, both in the joint's own frame
(the frame after `F_{i-1}`). Standard DH, modified DH (Craig) and URDF chains all take this form
(`from_dh`, `wsmap.kinematics.urdf`).

`base` places the chain's first frame in the world (e.g. a robot on a pedestal) and `tool` the
tool frame on the flange; `fkine` is base → tool, both default to the identity.

Joint limits `qlim` are `(..., n, 2)` `[lo, hi]` in rad (revolute) or m (prismatic); an
unlimited (continuous) revolute joint has `[-inf, inf]`. `qlim` is `None` when every joint is
unlimited.

Coupled joints (`Coupling`; URDF mimic joints, a parallelogram arm's passive joint): each of the
`n_joints` joints of the formula above is driven by one of the chain's `n` independent variables,
`q_full[j] = mult[j] · q[var[j]] + const[j]`. Then `n` (the joint coordinates every solver, map
and `fkine` takes) counts the variables, `qlim` `(..., n, 2)` holds the variables' limits (those
that keep every joint inside its own, `SerialChain.couple`), and `fixed`, `axes`, `kinds` and
`offset` stay per joint (`n_joints` of them). The Jacobian of the variables is the joints' Jacobian
times the coupling matrix `A` (`n_joints x n`, `A[j, var[j]] = mult[j]`): each variable's column is
the sum of its joints' columns times their multipliers. `uncoupled()` is the same joints free in
their own limits, a relaxation whose reachable set contains the coupled chain's. Without a coupling
(`coupling is None`, every chain built from a DH table) `n_joints == n` and nothing of the above
applies.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .arms import ArmBatch
from .dh import DHRobot
from .transforms import as_real_array, check_finite, check_rigid
from typing import TYPE_CHECKING, TypeAlias

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike

__all__ = ["SerialChain", "Coupling", "from_dh", "as_chain", "flatten_arms", "joint_motion", "REVOLUTE",
           "PRISMATIC"]

REVOLUTE = "R"
PRISMATIC = "P"


def _rotx(t):
    c, s = np.cos(t), np.sin(t)
    T = np.zeros(np.shape(t) + (4, 4))
    T[..., 0, 0] = 1.0
    T[..., 1, 1], T[..., 1, 2], T[..., 2, 1], T[..., 2, 2] = c, -s, s, c
    T[..., 3, 3] = 1.0
    return T


def _rotz(t):
    c, s = np.cos(t), np.sin(t)
    T = np.zeros(np.shape(t) + (4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 1, 0], T[..., 1, 1] = c, -s, s, c
    T[..., 2, 2] = 1.0
    T[..., 3, 3] = 1.0
    return T


def _trans(x, y, z):
    x, y, z = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float), np.asarray(z, float))
    T = np.zeros(x.shape + (4, 4))
    T[..., 0, 0] = T[..., 1, 1] = T[..., 2, 2] = T[..., 3, 3] = 1.0
    T[..., 0, 3], T[..., 1, 3], T[..., 2, 3] = x, y, z
    return T


def joint_motion(kind: str, axis: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The motion of one joint: `(..., 4, 4)`, rotation by `x` (rad) about the unit `axis` (3,)
    (Rodrigues) for `kind` `REVOLUTE`, translation by `x` (m) along it for `PRISMATIC`; `x` `(...)`."""
    T = np.zeros(x.shape + (4, 4))
    T[..., 3, 3] = 1.0
    if kind == PRISMATIC:
        T[..., 0, 0] = T[..., 1, 1] = T[..., 2, 2] = 1.0
        T[..., :3, 3] = x[..., None] * axis
        return T
    if axis[0] == 0.0 and axis[1] == 0.0:  # about ±z, the usual case: cheaper and exact
        t = x * axis[2]
        c, s = np.cos(t), np.sin(t)
        T[..., 0, 0], T[..., 0, 1], T[..., 1, 0], T[..., 1, 1] = c, -s, s, c
        T[..., 2, 2] = 1.0
        return T
    c, s = np.cos(x)[..., None, None], np.sin(x)[..., None, None]
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    T[..., :3, :3] = np.eye(3) + s * K + (1.0 - c) * (K @ K)
    return T


@dataclass(frozen=True, eq=False)
class Coupling:
    """How a chain's joints follow its independent variables: `q_full[j] = mult[j] · q[var[j]] + const[j]`.

    Parameters
    ----------
    var : ndarray of int, shape (n_joints,)
        The variable (`0 .. n - 1`) that drives each joint; every variable drives at least one.
    mult : ndarray, shape (n_joints,)
        Each joint's multiplier (finite, non-zero; rad per rad or m per m).
    const : ndarray, shape (n_joints,)
        Each joint's constant (rad or m), added after the multiplier.
    joint_limits : ndarray, shape (n_joints, 2)
        Each joint's own limits `[lo, hi]` in its own coordinate `q_full[j]` (`±inf` unlimited): what
        the variables' limits were narrowed by, and the limits of the relaxation
        (`SerialChain.uncoupled`).

    Notes
    -----
    `SerialChain.couple` builds one, checks it and derives the variables' limits.
    """

    var: np.ndarray
    mult: np.ndarray
    const: np.ndarray
    joint_limits: np.ndarray

    @property
    def n(self) -> int:
        """The number of independent variables."""
        return int(self.var.max()) + 1

    def matrix(self) -> np.ndarray:
        """The coupling matrix `A` `(n_joints, n)`: `q_full = A · q + const`."""
        A = np.zeros((self.var.size, self.n))
        A[np.arange(self.var.size), self.var] = self.mult
        return A

    def full(self, q: np.ndarray) -> np.ndarray:
        """The joint coordinates `(..., n_joints)` of variables `q` `(..., n)`."""
        return q[..., self.var] * self.mult + self.const

    def periodic(self, kinds: Sequence[str]) -> np.ndarray:
        """`(n,)` bool: variables that may move by whole turns with the pose unchanged, those that
        drive revolute joints only, each at an integer multiplier (a half-rate joint turns by half a
        turn when its driver turns by one)."""
        ok = np.array([k == REVOLUTE for k in kinds]) & (self.mult == np.round(self.mult))
        out = np.ones(self.n, dtype=bool)
        np.logical_and.at(out, self.var, ok)
        return out

    def key(self) -> tuple:
        """A hashable key of its content (memos of a chain's derived numbers)."""
        return tuple((a.shape, a.dtype.str, a.tobytes()) for a in (self.var, self.mult, self.const, self.joint_limits))


def _check_coupling(coupling: Coupling, kinds: tuple) -> Coupling:
    """`coupling` with its arrays as float64/int64 and checked against the joint `kinds`."""
    if not isinstance(coupling, Coupling):
        raise TypeError(f"coupling must be a Coupling (SerialChain.couple builds one), got {type(coupling).__name__}")
    nj = len(kinds)
    var = np.asarray(coupling.var)
    if var.shape != (nj,) or not np.issubdtype(var.dtype, np.integer):
        raise ValueError(f"coupling var must be {nj} integers (one variable per joint), got {var.dtype} {var.shape}")
    if var.min() < 0 or set(var.tolist()) != set(range(int(var.max()) + 1)):
        raise ValueError(f"coupling var must number the variables 0 .. n - 1, each driving a joint, got {var.tolist()}")
    mult = as_real_array("coupling multipliers", coupling.mult)
    const = as_real_array("coupling constants", coupling.const)
    lim = as_real_array("coupling joint limits", coupling.joint_limits)
    if mult.shape != (nj,) or const.shape != (nj,) or lim.shape != (nj, 2):
        raise ValueError(f"coupling mult and const must have shape ({nj},) and joint_limits ({nj}, 2), got "
                         f"{mult.shape}, {const.shape}, {lim.shape}")
    check_finite("coupling constants", const)
    if not np.all(np.isfinite(mult)) or np.any(mult == 0.0):
        j = int(np.flatnonzero(~np.isfinite(mult) | (mult == 0.0))[0])
        raise ValueError(f"the multiplier of joint {j + 1} is {mult[j]:g}: a coupling multiplier must be finite and "
                         "non-zero")
    for v in range(int(var.max()) + 1):
        joined = {kinds[j] for j in np.flatnonzero(var == v)}
        if len(joined) > 1:
            raise ValueError(f"variable {v + 1} drives revolute and prismatic joints "
                             f"({', '.join(str(j + 1) for j in np.flatnonzero(var == v))}): its unit would change")
    return Coupling(var.astype(np.int64), mult, const, lim)


class SerialChain(ArmBatch):
    """A serial arm (or a batch of arms sharing joint types and axes) of revolute and prismatic joints.

    Parameters
    ----------
    fixed : array_like, shape (..., n + 1, 4, 4)
        The fixed transforms `F_0 .. F_n` (rigid; metres). Leading dimensions are a batch of arms.
    axes : array_like, shape (n, 3)
        Joint axes in each joint's frame (normalised here).
    kinds : sequence of "R" / "P", length n
        Revolute or prismatic.
    offset : array_like, shape (..., n), optional
        Added to the joint coordinate before the motion (the manufacturer's zero against the model's).
    qlim : array_like, shape (..., n, 2), optional
        Joint limits `[lo, hi]`; `±inf` for a continuous joint. `None`: all unlimited.
    base, tool : array_like, shape (4, 4), optional
        World → chain and flange → tool transforms (rigid).
    name, source : str, optional
        The arm's name and where its numbers come from (a manufacturer document).
    links : sequence of str, optional
        Names of the frames after `F_0 .. F_n` (URDF link names), for messages.
    coupling : Coupling, optional
        How the joints follow independent variables (module notes; build it with `couple`). With
        one, `fixed`, `axes`, `kinds` and `offset` are per joint (`n_joints` of them) and `qlim`
        `(..., n, 2)` per variable. None (default): every joint is its own variable.
    """

    def __init__(self, fixed: ArrayLike, axes: ArrayLike, kinds: Sequence[str], offset: ArrayLike | None = None,
                 qlim: ArrayLike | None = None, base: ArrayLike | None = None, tool: ArrayLike | None = None,
                 name: str | None = None, source: str | None = None, links: Sequence[str] | None = None,
                 coupling: Coupling | None = None):
        fixed = as_real_array("fixed transforms", fixed)
        kinds = tuple(kinds)
        n = len(kinds)
        if any(k not in (REVOLUTE, PRISMATIC) for k in kinds):
            raise ValueError(f"joint kinds must be 'R' (revolute) or 'P' (prismatic), got {kinds}")
        if fixed.ndim < 3 or fixed.shape[-3:] != (n + 1, 4, 4):
            raise ValueError(f"fixed transforms must have shape (..., {n + 1}, 4, 4) for {n} joints, got {fixed.shape}")
        check_rigid("fixed transforms", fixed)
        axes = as_real_array("joint axes", axes)
        if axes.shape != (n, 3):
            raise ValueError(f"joint axes must have shape ({n}, 3), got {axes.shape}")
        check_finite("joint axes", axes)
        norms = np.linalg.norm(axes, axis=-1)
        if np.any(norms < 1e-12):
            raise ValueError(f"joint axis {int(np.argmin(norms))} is zero")
        self.fixed = fixed
        self.axes = axes / norms[:, None]
        self.kinds = kinds
        self.n_joints = n
        self.coupling = None if coupling is None else _check_coupling(coupling, kinds)
        var_kinds = kinds if coupling is None else self._variable_kinds()
        self.n = len(var_kinds)
        batch = fixed.shape[:-3]
        if offset is None:
            offset = np.zeros(n)
        offset = as_real_array("joint offsets", offset)
        if offset.shape[-1:] != (n,):
            raise ValueError(f"joint offsets must have a last dimension of {n}, got {offset.shape}")
        check_finite("joint offsets", offset)
        self.offset = offset
        n = self.n  # the limits are the variables'
        if qlim is not None:
            qlim = as_real_array("qlim", qlim)
            if qlim.shape[-2:] != (n, 2):
                raise ValueError(f"qlim must have shape (..., {n}, 2), got {qlim.shape}")
            if np.any(np.isnan(qlim)):
                raise ValueError("qlim contains NaN")
            bad = qlim[..., 0] > qlim[..., 1]
            if np.any(bad):
                j = int(np.argwhere(bad)[0][-1])
                raise ValueError(f"qlim of joint {j + 1} has its lower limit above its upper limit")
            prismatic = np.array([k == PRISMATIC for k in var_kinds])
            if np.any(~np.isfinite(qlim[..., prismatic, :])):
                j = int(np.flatnonzero(prismatic & np.any(~np.isfinite(qlim), axis=tuple(range(qlim.ndim - 2)) + (-1,)))[0])
                raise ValueError(f"prismatic joint {j + 1} needs finite limits (a slide has a stroke)")
            if np.all(np.isinf(qlim)):
                qlim = None
        elif any(k == PRISMATIC for k in kinds):
            raise ValueError("a chain with prismatic joints needs joint limits (qlim) for them")
        self.qlim = qlim
        self.base = None if base is None else self._one_transform("base", base)
        self.tool = None if tool is None else self._one_transform("tool", tool)
        self.name = name
        self.source = source
        self.links = tuple(links) if links is not None else None
        try:
            np.broadcast_shapes(batch, offset.shape[:-1], () if qlim is None else qlim.shape[:-2])
        except ValueError:
            raise ValueError(f"batch shapes do not broadcast: fixed {batch}, offset {offset.shape[:-1]}, "
                             f"qlim {None if qlim is None else qlim.shape[:-2]}") from None

    @staticmethod
    def _one_transform(name, T):
        T = as_real_array(name, T)
        if T.shape != (4, 4):
            raise ValueError(f"{name} must be a 4x4 homogeneous transform, got shape {T.shape}")
        return check_rigid(name, T)

    # ---------------------------------------------------------------- shape
    @property
    def batch_shape(self) -> tuple[int, ...]:
        """Leading (arm) dimensions: `()` for one arm."""
        shapes = [self.fixed.shape[:-3], self.offset.shape[:-1]]
        if self.qlim is not None:
            shapes.append(self.qlim.shape[:-2])
        return np.broadcast_shapes(*shapes)

    def _select(self, idx) -> "SerialChain":
        b = self.batch_shape
        fixed = np.broadcast_to(self.fixed, b + self.fixed.shape[-3:])[idx]
        offset = np.broadcast_to(self.offset, b + (self.n_joints,))[idx]
        qlim = None if self.qlim is None else np.broadcast_to(self.qlim, b + (self.n, 2))[idx]
        return self.replace(fixed=fixed, offset=offset, qlim=qlim)

    def replace(self, **changes) -> "SerialChain":
        """A copy with some constructor arguments changed (e.g. `qlim=None` for no limits)."""
        kw = dict(fixed=self.fixed, axes=self.axes, kinds=self.kinds, offset=self.offset, qlim=self.qlim,
                  base=self.base, tool=self.tool, name=self.name, source=self.source, links=self.links)
        if self.coupling is not None:  # only then: an uncoupled chain's replace is as it always was
            kw["coupling"] = self.coupling
        kw.update(changes)
        return SerialChain(**kw)

    # ---------------------------------------------------------------- coupled joints
    def _variable_kinds(self) -> tuple[str, ...]:
        c = self.coupling
        return tuple(self.kinds[int(np.flatnonzero(c.var == v)[0])] for v in range(c.n))

    @property
    def variable_kinds(self) -> tuple[str, ...]:
        """The kind of each of the `n` variables: `kinds` without a coupling, else the kind of the
        joints each drives (one kind per variable, `Coupling`)."""
        return self.kinds if self.coupling is None else self._variable_kinds()

    @property
    def periodic(self) -> np.ndarray:
        """`(n,)` bool: the variables a whole turn (2·pi) moves without changing the pose, those
        that may be shifted by whole turns into their limits: the revolute joints, and with a
        coupling the variables that drive revolute joints only, each at an integer multiplier
        (`Coupling.periodic`)."""
        if self.coupling is None:
            return np.array([k == REVOLUTE for k in self.kinds])
        return self.coupling.periodic(self.kinds)

    def full_q(self, q: ArrayLike) -> np.ndarray:
        """The joint coordinates `(..., n_joints)` of the variables `q` `(..., n)` (`q` itself, checked,
        without a coupling)."""
        q = self._check_q(q)
        return q if self.coupling is None else self.coupling.full(q)

    def couple(self, var: ArrayLike, mult: ArrayLike | None = None, const: ArrayLike | None = None,
               var_limits: ArrayLike | None = None, names: Sequence[str] | None = None,
               var_names: Sequence[str] | None = None) -> "SerialChain":
        """This chain's joints driven by fewer independent variables: `q_full[j] = mult[j] · q[var[j]] + const[j]`.

        Parameters
        ----------
        var : array_like of int, shape (n_joints,)
            The variable driving each joint, numbered `0 .. n - 1` (each variable drives a joint).
        mult, const : array_like, shape (n_joints,), optional
            Multipliers (finite, non-zero; default 1) and constants (rad or m; default 0).
        var_limits : array_like, shape (n, 2), optional
            Each variable's own limits (e.g. those of a URDF mimic joint's driver off the chain);
            default unlimited.
        names, var_names : sequence of str, optional
            The joints' and the variables' names for messages (default `joint 1`, ...,
            `variable 1`, ...).

        Returns
        -------
        SerialChain
            The coupled chain (module notes): `n` variables whose limits `qlim` are `var_limits`
            intersected with, for each joint a variable drives, the values that keep that joint inside
            its own limits (this chain's `qlim`, kept as `coupling.joint_limits`).

        Raises
        ------
        ValueError
            This chain is coupled already or a batch of arms; `var`, `mult` or `const` malformed; a
            zero or non-finite multiplier; a variable driving revolute and prismatic joints; a
            variable whose limits leave no value that keeps every joint it drives inside its own
            (the message names the joints).
        """
        if self.coupling is not None:
            raise ValueError("couple takes an uncoupled chain (its joints in their own limits); this one is coupled")
        if self.batch_shape != ():
            raise ValueError(f"couple takes one arm, got a batch of arms {self.batch_shape}")
        nj = self.n_joints
        var = np.asarray(var)
        if var.shape != (nj,) or not np.issubdtype(var.dtype, np.integer):
            raise ValueError(f"var must be {nj} integers (one variable per joint), got {var.dtype} {var.shape}")
        mult = np.ones(nj) if mult is None else as_real_array("mult", mult)
        const = np.zeros(nj) if const is None else as_real_array("const", const)
        names = [f"joint {j + 1}" for j in range(nj)] if names is None else list(names)
        own = np.array(self.limits, dtype=np.float64)
        coupling = _check_coupling(Coupling(var, mult, const, own), self.kinds)
        n = coupling.n
        var_names = [f"variable {v + 1}" for v in range(n)] if var_names is None else list(var_names)
        lim = np.tile([-np.inf, np.inf], (n, 1)) if var_limits is None else as_real_array("var_limits", var_limits)
        if lim.shape != (n, 2) or np.any(np.isnan(lim)) or np.any(lim[:, 0] > lim[:, 1]):
            raise ValueError(f"var_limits must be ({n}, 2) [lo, hi] rows with lo <= hi, got {lim.tolist()}")
        lim = lim.copy()
        with np.errstate(invalid="ignore"):  # the values of q that keep m·q + c inside [lo, hi]
            ends = (own - const[:, None]) / mult[:, None]
        ends = np.sort(ends, axis=1)
        for v in range(n):
            js = np.flatnonzero(coupling.var == v)
            lo, hi = max(lim[v, 0], ends[js, 0].max()), min(lim[v, 1], ends[js, 1].min())
            if lo > hi:
                raise ValueError(f"no value of {var_names[v]!r} inside its limits [{lim[v, 0]:g}, {lim[v, 1]:g}] keeps "
                                 + " and ".join(f"{names[j]!r} ({mult[j]:g} x {var_names[v]!r} + {const[j]:g}) inside "
                                                f"its own [{own[j, 0]:g}, {own[j, 1]:g}]" for j in js))
            lim[v] = lo, hi
        return SerialChain(self.fixed, self.axes, self.kinds, offset=self.offset, qlim=lim, base=self.base,
                           tool=self.tool, name=self.name, source=self.source, links=self.links, coupling=coupling)

    def without_revolute_limits(self) -> "SerialChain":
        """The same chain with its revolute joints unlimited, prismatic joints keeping their strokes
        (`joint_limits=False` of the searches); with a coupling, its joints' own limits
        (`Coupling.joint_limits`) too, so that the relaxation drops them as well."""
        qlim, coupling = self.qlim, self.coupling
        if qlim is not None:
            pris = np.array([k == PRISMATIC for k in self.variable_kinds])
            qlim = np.array(qlim, dtype=np.float64)
            qlim[..., ~pris, :] = [-np.inf, np.inf]
        if coupling is None:
            return self.replace(qlim=qlim)
        own = np.array(coupling.joint_limits, dtype=np.float64)
        own[[k != PRISMATIC for k in self.kinds]] = [-np.inf, np.inf]
        return self.replace(qlim=qlim, coupling=Coupling(coupling.var, coupling.mult, coupling.const, own))

    def uncoupled(self) -> "SerialChain":
        """The relaxation of a coupled chain: the same joints, each its own variable inside its own
        limits (`coupling.joint_limits`). Every pose the coupled chain reaches, it reaches (at
        `full_q(q)`), so a proof that a pose is out of its reach holds for the coupled chain (the
        certificates). The chain itself without a coupling."""
        if self.coupling is None:
            return self
        return SerialChain(self.fixed, self.axes, self.kinds, offset=self.offset, qlim=self.coupling.joint_limits,
                           base=self.base, tool=self.tool, name=self.name, source=self.source, links=self.links)

    @property
    def limits(self) -> np.ndarray:
        """`(..., n, 2)` limits with `±inf` for unlimited joints (never `None`)."""
        if self.qlim is None:
            return np.broadcast_to(np.array([-np.inf, np.inf]), (self.n, 2))
        return self.qlim

    def __repr__(self):
        name = f"{self.name!r}, " if self.name else ""
        coupled = "" if self.coupling is None else f", coupled joints={self.n_joints}"
        return (f"SerialChain({name}n={self.n}, joints={''.join(self.kinds)}{coupled}, batch_shape={self.batch_shape}, "
                f"qlim={'yes' if self.qlim is not None else 'no'})")

    # ---------------------------------------------------------------- kinematics
    def joint_frames(self, q: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Frames of every joint (before its motion) and the flange, in the world frame.

        Returns `(frames, T)`: `frames` `(..., n_joints, 4, 4)` (joint `i`'s axis is
        `frames[..., i, :3, :3] @ axes[i]`; `n_joints == n` without a coupling), and `T`
        `(..., 4, 4)` the tool pose.
        """
        q = self._check_q(q)
        x = (q if self.coupling is None else self.coupling.full(q)) + self.offset
        shape = np.broadcast_shapes(x.shape[:-1], self.batch_shape)
        T = np.broadcast_to(self.fixed[..., 0, :, :], shape + (4, 4))
        if self.base is not None:
            T = self.base @ T
        frames = np.empty(shape + (self.n_joints, 4, 4))
        for i in range(self.n_joints):  # a loop over joints, not over arms or configurations
            frames[..., i, :, :] = T
            T = T @ joint_motion(self.kinds[i], self.axes[i], x[..., i]) @ self.fixed[..., i + 1, :, :]
        if self.tool is not None:
            T = T @ self.tool
        return frames, T

    def fkine(self, q: ArrayLike) -> np.ndarray:
        """Forward kinematics: tool pose in the world (base) frame, `(..., 4, 4)`; `q` is `(..., n)`."""
        return self.joint_frames(q)[1]

    def jacob0(self, q: ArrayLike) -> np.ndarray:
        """Geometric Jacobian of the tool point in the world frame, `(..., 6, n)`: rows `[v; omega]`.
        With a coupling, of the variables: the joints' Jacobian `(..., 6, n_joints)` times the
        coupling matrix (`Coupling.matrix`), each variable's column the sum of its joints' columns
        times their multipliers."""
        frames, T = self.joint_frames(q)
        w = np.einsum("...ij,...j->...i", frames[..., :3, :3], self.axes)  # (..., n_joints, 3) world axes
        o = frames[..., :3, 3]
        pe = T[..., None, :3, 3]
        prismatic = np.array([k == PRISMATIC for k in self.kinds])
        Jv = np.where(prismatic[:, None], w, np.cross(w, pe - o))
        Jw = np.where(prismatic[:, None], 0.0, w)
        J = np.swapaxes(np.concatenate([Jv, Jw], axis=-1), -1, -2)
        return J if self.coupling is None else J @ self.coupling.matrix()

    def within_limits(self, q: ArrayLike, atol: float = 1e-9) -> np.ndarray:
        """True where every joint lies inside its limits (to `atol`); `q.shape[:-1]` broadcast."""
        q = self._check_q(q)
        if self.qlim is None:
            return np.ones(np.broadcast_shapes(q.shape[:-1], self.batch_shape), dtype=bool)
        return np.all((q >= self.qlim[..., 0] - atol) & (q <= self.qlim[..., 1] + atol), axis=-1)

    def random_q(self, count: int, rng: np.random.Generator) -> np.ndarray:
        """`(count, ..., n)` configurations drawn uniformly inside the limits (`[-pi, pi)` for an
        unlimited joint)."""
        lo = np.where(np.isfinite(self.limits[..., 0]), self.limits[..., 0], -np.pi)
        hi = np.where(np.isfinite(self.limits[..., 1]), self.limits[..., 1], np.pi)
        u = rng.random((count,) + np.broadcast_shapes(lo.shape, self.batch_shape + (self.n,)))
        with np.errstate(over="ignore", invalid="ignore"):
            q = lo + u * (hi - lo)
        # limits of ±1e308 overflow hi - lo: the same uniform draw as a convex combination there
        return np.where(np.isfinite(q), q, lo * (1.0 - u) + hi * u)


#: One arm, or a batch of arms (parameters with a leading batch dimension): a `DHRobot` (standard
#: DH) or a `SerialChain` (any serial arm). The annotation of every function that takes an arm.
Arm: TypeAlias = DHRobot | SerialChain


def from_dh(d: ArrayLike, a: ArrayLike, alpha: ArrayLike, offset: ArrayLike | None = None,
            qlim: ArrayLike | None = None, modified: bool = False, prismatic: ArrayLike | None = None,
            base: ArrayLike | None = None, tool: ArrayLike | None = None, flange: ArrayLike | None = None,
            name: str | None = None, source: str | None = None) -> SerialChain:
    """A chain from a DH table (columns `(..., n)`, metres and radians; batch dimensions allowed).

    Standard (distal) DH, as Corke's toolbox and the paper: link `i` is
    `Rz(θ_i) Tz(d_i) Tx(a_i) Rx(α_i)`. Modified DH (Craig; Franka, Kinova): link `i` is
    `Rx(α_{i-1}) Tx(a_{i-1}) Rz(θ_i) Tz(d_i)`, so `a` and `alpha` of row `i` act *before* joint `i`.
    A revolute joint has `θ_i = q_i + offset_i`; a prismatic joint (`prismatic[i]` True) has
    `θ_i = offset_i` fixed and moves along `z` from `d_i` by `q_i`. `flange` (4, 4) is a
    fixed transform after the last joint that belongs to the arm (e.g. Franka's `d = 0.107` m to the
    flange); `tool` is the user's tool on it.
    """
    d, a, alpha = (as_real_array(f"DH column {k}", x) for k, x in (("d", d), ("a", a), ("alpha", alpha)))
    for k, x in (("d", d), ("a", a), ("alpha", alpha)):
        if x.ndim == 0:
            raise ValueError(f"DH column {k} must have at least one dimension (one entry per joint)")
        check_finite(f"DH column {k}", x)
    if len({d.shape[-1], a.shape[-1], alpha.shape[-1]}) != 1:
        raise ValueError(f"DH columns disagree on the number of joints: d {d.shape}, a {a.shape}, alpha {alpha.shape}")
    if d.shape[-1] == 0:
        raise ValueError("DH columns are empty: an arm needs at least one joint (one entry of d, a and alpha each)")
    try:
        shape = np.broadcast_shapes(d.shape, a.shape, alpha.shape)
    except ValueError:
        raise ValueError(f"DH columns have batch shapes that do not broadcast: d {d.shape}, a {a.shape}, "
                         f"alpha {alpha.shape}") from None
    n = shape[-1]
    d, a, alpha = (np.broadcast_to(x, shape) for x in (d, a, alpha))
    off = np.zeros(n) if offset is None else as_real_array("offset", offset)
    if off.shape[-1:] != (n,):
        raise ValueError(f"offset must have a last dimension of {n}, got {off.shape}")
    check_finite("offset", off)
    pris = np.zeros(n, dtype=bool) if prismatic is None else np.asarray(prismatic, dtype=bool)
    if pris.shape != (n,):
        raise ValueError(f"prismatic must have one flag per joint ({n}), got shape {pris.shape}")
    kinds = [PRISMATIC if p else REVOLUTE for p in pris]
    if pris.any() and qlim is None:
        raise ValueError(f"prismatic joint {int(np.flatnonzero(pris)[0]) + 1} needs limits: give qlim")
    batch = np.broadcast_shapes(shape[:-1], off.shape[:-1])
    off_b = np.broadcast_to(off, batch + (n,))
    fixed = np.broadcast_to(np.eye(4), batch + (n + 1, 4, 4)).copy()
    # joint i's own fixed part: revolute Tz(d) ; prismatic Tz(d) Rz(θ) (Rz and Tz commute)
    own = np.where(pris, 0.0, 1.0)
    zpart = _trans(0.0, 0.0, np.broadcast_to(d, batch + (n,))) @ _rotz(np.where(pris, off_b, 0.0))
    xpart = _trans(np.broadcast_to(a, batch + (n,)), 0.0, 0.0) @ _rotx(np.broadcast_to(alpha, batch + (n,)))
    if not modified:
        for i in range(n):
            fixed[..., i + 1, :, :] = zpart[..., i, :, :] @ xpart[..., i, :, :]
    else:
        fixed[..., 0, :, :] = xpart[..., 0, :, :]
        for i in range(n):
            after = xpart[..., i + 1, :, :] if i + 1 < n else np.eye(4)
            fixed[..., i + 1, :, :] = zpart[..., i, :, :] @ after
    if flange is not None:
        flange = SerialChain._one_transform("flange", flange)
        fixed[..., n, :, :] = fixed[..., n, :, :] @ flange
    motion_offset = off_b * own  # prismatic joints carry θ in the fixed part
    return SerialChain(fixed, np.tile([0.0, 0.0, 1.0], (n, 1)), kinds, offset=motion_offset, qlim=qlim,
                       base=base, tool=tool, name=name, source=source)


def as_chain(robot: Arm) -> SerialChain:
    """`robot` as a `SerialChain`: a chain is returned as is, a `DHRobot` converted
    with `from_dh` (standard DH, same limits and tool); anything else is a `TypeError`."""
    if isinstance(robot, SerialChain):
        return robot
    if isinstance(robot, DHRobot):
        return from_dh(robot.d, robot.a, robot.alpha, qlim=robot.qlim, tool=robot.tool, name=robot.name)
    raise TypeError(f"robot must be a SerialChain or a DHRobot, got {type(robot).__name__}")


def flatten_arms(arms):
    """A batch of arms (`SerialChain` or `DHRobot`, batch shape `(...)`) as a flat
    batch `(B,)` of the same arms, in C order."""
    n = arms.n
    if isinstance(arms, SerialChain):
        b = arms.batch_shape
        qlim = None if arms.qlim is None else np.broadcast_to(arms.qlim, b + (n, 2)).reshape(-1, n, 2)
        fshape = arms.fixed.shape[-3:]
        nj = arms.n_joints
        return arms.replace(fixed=np.broadcast_to(arms.fixed, b + fshape).reshape((-1,) + fshape),
                            offset=np.broadcast_to(arms.offset, b + (nj,)).reshape(-1, nj), qlim=qlim)
    qlim = arms.qlim
    if qlim is not None and qlim.ndim > 2:
        qlim = np.broadcast_to(qlim, arms.batch_shape + (n, 2)).reshape(-1, n, 2)
    return DHRobot(arms.d.reshape(-1, n), arms.a.reshape(-1, n), arms.alpha.reshape(-1, n), qlim=qlim, tool=arms.tool)
