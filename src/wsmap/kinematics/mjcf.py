"""MJCF (MuJoCo's format) as a second source of serial chains, parsed by the `mujoco` package
(its compiled model: body frames, joint anchors and axes, angles in radians whatever the file's
`<compiler angle>`).

`from_mjcf` is the chain from the world body to a site or a body (the tool frame). Hinge joints
are revolute, slide joints prismatic; a joint's coordinate is MuJoCo's `qpos` (measured from the
joint's `ref`, `qpos0`); limits from `range` where `limited`. The collision geoms:
`wsmap.collision.mjcf.from_mjcf_collision`.

Coupled joints: an active `<equality><joint joint1="A" joint2="B" polycoef="a0 a1 0 0 0"/>` whose
`joint1` is on the chain makes `A` follow `B`, `qpos_A = qpos0_A + a0 + a1 · (qpos_B − qpos0_B)`
(MuJoCo's joint equality, a polynomial of degree one): the chain's variable is `B` (on the chain,
or off it with its own `range`), `A` a joint driven by it (`wsmap.kinematics.chain.Coupling`; the
variables' limits keep `A` inside its own). Refused with one line (`MJCFError`, naming the
joints): a polynomial of a higher degree, `a1 = 0` or no `joint2` (the joint held fixed), a driver
of another kind, a driver that follows a joint itself, a joint that two equalities drive, limits
that leave no common value. Equalities of joints off the chain, and inactive ones, change nothing
here.
"""

from __future__ import annotations

import os

import numpy as np

from .chain import PRISMATIC, REVOLUTE, SerialChain
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import PathLike

__all__ = ["MJCFError", "from_mjcf", "load_model", "pose_matrix", "chain_and_bodies"]


class MJCFError(ValueError):
    """An MJCF file that cannot be read as a serial chain; the message names the file and why."""


def load_model(path: PathLike):
    """MuJoCo's compiled model of an MJCF file.

    Parameters
    ----------
    path : path or str
        The MJCF file.

    Returns
    -------
    mujoco.MjModel
        The compiled model (angles in radians, whatever the file's `<compiler angle>`).

    Raises
    ------
    MJCFError
        No such file, or a file mujoco cannot read (its message, on one line).
    """
    import mujoco

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise MJCFError(f"no such MJCF file: {path!r}")
    try:
        return mujoco.MjModel.from_xml_path(path)
    except Exception as exc:  # mujoco's own message names the element
        msg = " ".join(str(exc).split())
        raise MJCFError(f"MJCF file {path!r}: mujoco cannot read it: {msg}") from None


def pose_matrix(pos, quat) -> np.ndarray:
    """A pose as MuJoCo gives one (a body, a geom or a site in its parent's frame).

    Parameters
    ----------
    pos : array_like
        The position `(3,)`, m.
    quat : array_like
        The quaternion `(w, x, y, z)`, `(4,)`; normalised here.

    Returns
    -------
    numpy.ndarray
        The homogeneous transform `(4, 4)`.
    """
    w, x, y, z = quat / np.linalg.norm(quat)
    T = np.eye(4)
    T[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    T[:3, 3] = pos
    return T


def _trans(p) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = p
    return T


def chain_and_bodies(m, path: str, site_or_body: str) -> tuple[SerialChain, dict[int, tuple[int, np.ndarray]]]:
    """The serial chain of a compiled MJCF model and where each of its MuJoCo bodies rides on it.

    Parameters
    ----------
    m : mujoco.MjModel
        The compiled model (`load_model`).
    path : str
        The MJCF file, for messages and the chain's `source` (its name is the file's stem).
    site_or_body : str
        The site or body whose frame is the tool frame.

    Returns
    -------
    chain : SerialChain
        As `from_mjcf`.
    bodies : dict
        MuJoCo body id -> `(k, T)`: the chain body `k` (0 the base, `k` moves with joint `k`) it
        rides on and its pose `T` `(4, 4)` in that body's frame; every body but the world (id 0)
        is there (bodies off the path with their parent, their joints at `qpos0`).

    Raises
    ------
    MJCFError
        An unknown site or body, a ball or free joint on the chain, no joint on the chain.
    """
    import mujoco

    sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, site_or_body)
    bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, site_or_body)
    if sid < 0 and bid < 0:
        sites = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SITE, i) for i in range(m.nsite)]
        raise MJCFError(f"MJCF file {path!r} has no site or body {site_or_body!r}; sites: "
                             f"{', '.join(s for s in sites if s) or 'none'}")
    end = int(m.site_bodyid[sid]) if sid >= 0 else bid
    tool = pose_matrix(m.site_pos[sid], m.site_quat[sid]) if sid >= 0 else np.eye(4)
    bodies = []
    b = end
    while b != 0:
        bodies.append(b)
        b = int(m.body_parentid[b])
    bodies.reverse()
    fixed, axes, kinds, offset, qlim, T, jids = [], [], [], [], [], np.eye(4), []
    place = {0: (0, np.eye(4))}
    for b in bodies:
        T = T @ pose_matrix(m.body_pos[b], m.body_quat[b])
        for j in range(int(m.body_jntadr[b]), int(m.body_jntadr[b] + m.body_jntnum[b])):
            jt = int(m.jnt_type[j])
            if jt not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
                name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
                raise MJCFError(f"MJCF file {path!r}: joint {name!r} on the chain is a ball or free joint; "
                                     "a serial chain has hinge and slide joints")
            a = m.jnt_pos[j]
            fixed.append(T @ _trans(a))
            T = _trans(-a)
            axes.append(np.array(m.jnt_axis[j], dtype=np.float64))
            kinds.append(REVOLUTE if jt == int(mujoco.mjtJoint.mjJNT_HINGE) else PRISMATIC)
            offset.append(-float(m.qpos0[m.jnt_qposadr[j]]))
            lim = m.jnt_range[j] if m.jnt_limited[j] else (-np.inf, np.inf)
            qlim.append((float(lim[0]), float(lim[1])))
            jids.append(j)
        place[b] = (len(kinds), T.copy())
    if not kinds:
        raise MJCFError(f"MJCF file {path!r}: no hinge or slide joint between the world and {site_or_body!r}")
    fixed.append(T @ tool)
    name = os.path.splitext(os.path.basename(path))[0]
    chain = SerialChain(np.stack(fixed), np.stack(axes), kinds, offset=np.array(offset), qlim=np.array(qlim),
                        name=name, source=path)
    chain = _coupled(m, path, chain, jids)
    # bodies off the path: with their parent, joints at qpos0 (a fixed pose)
    for b in range(1, m.nbody):
        if b in place:
            continue
        chainb = [b]
        while int(m.body_parentid[chainb[-1]]) not in place:
            chainb.append(int(m.body_parentid[chainb[-1]]))
        for c in reversed(chainb):
            k, Tp = place[int(m.body_parentid[c])]
            place[c] = (k, Tp @ pose_matrix(m.body_pos[c], m.body_quat[c]))
    return chain, place


def _joint_equalities(m, path: str, jids: list[int]) -> dict[int, tuple[int, float, float]]:
    """Chain joint position -> `(driver joint id, multiplier, constant)` of the active joint
    equalities whose `joint1` is on the chain (module notes), checked."""
    import mujoco

    def name(j):
        return mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)

    on = {j: i for i, j in enumerate(jids)}
    driven: dict[int, tuple[int, float, float]] = {}
    for e in range(m.neq):
        j1, j2 = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
        if int(m.eq_type[e]) != int(mujoco.mjtEq.mjEQ_JOINT) or not m.eq_active0[e] or j1 not in on:
            continue
        a = np.array(m.eq_data[e, :5], dtype=np.float64)
        where = f"MJCF file {path!r}: the joint equality on {name(j1)!r}"
        if j2 < 0 or a[1] == 0.0:
            raise MJCFError(f"{where} holds it at a constant (no joint2, or polycoef's a1 = 0): make it a fixed part "
                            "of its body instead")
        if np.any(a[2:] != 0.0):
            raise MJCFError(f"{where} is a polynomial of degree {int(np.flatnonzero(a)[-1])} in {name(j2)!r}; only "
                            "a linear coupling (polycoef a0 a1 0 0 0) is read")
        if int(m.jnt_type[j1]) != int(m.jnt_type[j2]):
            raise MJCFError(f"{where} couples it to {name(j2)!r}, a joint of another kind (hinge and slide)")
        if on[j1] in driven:
            raise MJCFError(f"{where}: two joint equalities drive {name(j1)!r}")
        q1, q2 = float(m.qpos0[m.jnt_qposadr[j1]]), float(m.qpos0[m.jnt_qposadr[j2]])
        driven[on[j1]] = (j2, float(a[1]), q1 + float(a[0]) - float(a[1]) * q2)
    for i, (j2, _, _) in driven.items():
        if j2 in on and on[j2] in driven:
            raise MJCFError(f"MJCF file {path!r}: joint {name(jids[i])!r} follows {name(j2)!r}, which follows "
                            f"{name(driven[on[j2]][0])!r} itself; couple both to one driver")
    return driven


def _coupled(m, path: str, chain: SerialChain, jids: list[int]) -> SerialChain:
    """`chain` with the joints that active joint equalities drive following their drivers (module
    notes); the chain itself where there are none."""
    import mujoco

    driven = _joint_equalities(m, path, jids)
    if not driven:
        return chain
    drivers = [driven[i] if i in driven else (j, 1.0, 0.0) for i, j in enumerate(jids)]
    order = list(dict.fromkeys(d for d, _, _ in drivers))
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in jids]
    limits = [(-np.inf, np.inf) if d in jids or not m.jnt_limited[d] else tuple(map(float, m.jnt_range[d]))
              for d in order]
    try:
        return chain.couple(np.array([order.index(d) for d, _, _ in drivers]), [mm for _, mm, _ in drivers],
                            [c for _, _, c in drivers], var_limits=np.array(limits), names=names,
                            var_names=[mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, d) for d in order])
    except ValueError as exc:
        raise MJCFError(f"MJCF file {path!r}: {exc}") from None


def from_mjcf(path: PathLike, site_or_body: str) -> SerialChain:
    """The serial chain of an MJCF file from the world body to the site or body `site_or_body`
    (its frame is the tool frame): fixed transforms from the bodies' `pos`/`quat` and the
    joints' anchors, axes as MuJoCo has them (body frame), `offset = -ref`, `qlim` from
    `range`. Errors (no such file, not MJCF, an unknown site, a ball joint) are an
    `MJCFError` naming the file."""
    m = load_model(path)
    return chain_and_bodies(m, os.fspath(path), site_or_body)[0]
