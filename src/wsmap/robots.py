"""Named arms and the random arm families of the paper.

* :func:`load` — a named arm: the paper's ``puma560`` (a :class:`~wsmap.kinematics.DHRobot`) and
  real arms from their manufacturers' published kinematics (:class:`~wsmap.kinematics.SerialChain`),
  each one :class:`ArmTable` in :data:`NAMED` with the document it comes from;
* :func:`from_dh` (standard or modified DH) and :func:`from_urdf` — any other serial arm;
* :func:`puma560`, :func:`spherical_wrist` and the samplers of the paper's arm families (batches of
  :class:`~wsmap.kinematics.DHRobot`, batch shape ``(count,)``, drawn with a seed or a
  ``numpy.random.Generator``).

Every named arm has its base at the manufacturer's base (mounting flange) frame and its end at the
tool flange (no gripper), its joint zero and signs as the manufacturer's controller, and its joint
limits in radians (``±inf`` for a continuous joint; ``qlim`` is ``None`` when no joint is limited).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .kinematics import SPHERICAL_WRIST_ALPHA, DHRobot, SerialChain
from .kinematics.chain import from_dh
from .kinematics.urdf import URDFError, from_urdf

__all__ = [
    "PUMA560_QLIM_DEG",
    "puma560",
    "spherical_wrist",
    "sample_spherical_wrist",
    "sample_arbitrary_6dof",
    "ArmTable",
    "NAMED",
    "ROBOTS",
    "load",
    "from_name",
    "from_dh",
    "from_urdf",
    "URDFError",
]

#: PUMA560 joint limits in degrees (Corke's ``mdl_puma560``); the paper ignores them.
PUMA560_QLIM_DEG = np.array(
    [[-160, 160], [-45, 225], [-225, 45], [-110, 170], [-100, 100], [-266, 266]], dtype=np.float64
)


def spherical_wrist(a2, a3, d3, d4, d1=0.0, qlim=None, name=None) -> DHRobot:
    """A 6-DOF arm of the paper's spherical-wrist family (metres).

    The DH table (standard DH) is ``d = [d1, 0, d3, d4, 0, 0]``, ``a = [0, a2, a3, 0, 0, 0]``,
    ``alpha = [pi/2, 0, -pi/2, pi/2, -pi/2, 0]``. Arguments may be arrays of one shape: a batch.
    """
    a2, a3, d3, d4, d1 = np.broadcast_arrays(*(np.asarray(x, dtype=np.float64) for x in (a2, a3, d3, d4, d1)))
    z = np.zeros_like(a2)
    d = np.stack([d1, z, d3, d4, z, z], axis=-1)
    a = np.stack([z, a2, a3, z, z, z], axis=-1)
    alpha = np.broadcast_to(SPHERICAL_WRIST_ALPHA, d.shape)
    return DHRobot(d, a, alpha, qlim=qlim, name=name)


def puma560(joint_limits: bool = False) -> DHRobot:
    """The PUMA560 as the paper used it (MATLAB toolbox 10 ``mdl_puma560``, base height d1 = 0).

    At ``q = 0`` the flange sits at (0.4521, -0.15005, 0.4318) m. Joint limits
    (:data:`PUMA560_QLIM_DEG`) are attached only when asked for, as the paper ignored them.
    """
    qlim = np.deg2rad(PUMA560_QLIM_DEG) if joint_limits else None
    return spherical_wrist(a2=0.4318, a3=0.0203, d3=0.15005, d4=0.4318, qlim=qlim, name="puma560")


# ------------------------------------------------------------------------------------------ named arms
@dataclass(frozen=True)
class ArmTable:
    """One arm's published kinematics: a DH table, its joint limits, and the document they come from.

    ``rows`` are per joint ``(d, a, alpha, offset)`` (metres, radians); in the modified (Craig)
    convention ``a`` and ``alpha`` of row ``i`` are ``a_{i-1}``, ``alpha_{i-1}`` (they act before
    joint ``i``), as :func:`wsmap.kinematics.chain.from_dh` takes them. ``offset`` is added to the
    joint angle (the manufacturer's zero against the DH zero). ``mount`` is a fixed DH row
    ``(d, a, alpha, theta)`` of the same convention before joint 1 (Kinova's "base to frame 1"),
    ``flange`` one after the last joint (Franka's flange row). ``limits`` are per joint
    ``(lo, hi)`` in ``limit_unit`` as published, ``None`` for a continuous joint.
    """

    name: str
    title: str
    convention: str  # "standard" (distal, Corke) or "modified" (Craig)
    rows: tuple
    limits: tuple
    limit_unit: str  # "deg" or "rad"
    source: str
    mount: tuple | None = None
    flange: tuple | None = None

    @property
    def n(self) -> int:
        return len(self.rows)

    @property
    def qlim(self) -> np.ndarray:
        """``(n, 2)`` limits in radians, ``±inf`` for continuous joints."""
        lim = np.array([(-np.inf, np.inf) if x is None else x for x in self.limits], dtype=np.float64)
        return np.deg2rad(lim) if self.limit_unit == "deg" else lim

    def row_transform(self, row) -> np.ndarray:
        """The 4x4 transform of one fixed DH row ``(d, a, alpha, theta)`` in this table's convention."""
        d, a, alpha, theta = (float(x) for x in row)
        ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
        Rz = np.array([[ct, -st, 0, 0], [st, ct, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
        Rx = np.array([[1, 0, 0, 0], [0, ca, -sa, 0], [0, sa, ca, 0], [0, 0, 0, 1.0]])
        Tz, Tx = np.eye(4), np.eye(4)
        Tz[2, 3], Tx[0, 3] = d, a
        return Rz @ Tz @ Tx @ Rx if self.convention == "standard" else Rx @ Tx @ Rz @ Tz

    def chain(self, joint_limits: bool = True) -> SerialChain:
        """The arm as a :class:`SerialChain` (base frame → tool flange)."""
        d, a, alpha, offset = np.array(self.rows, dtype=np.float64).T
        flange = None if self.flange is None else self.row_transform(self.flange)
        arm = from_dh(d, a, alpha, offset=offset, qlim=self.qlim if joint_limits else None,
                      modified=self.convention == "modified", flange=flange, name=self.name, source=self.source)
        if self.mount is not None:
            fixed = arm.fixed.copy()
            fixed[..., 0, :, :] = self.row_transform(self.mount) @ fixed[..., 0, :, :]
            arm = arm.replace(fixed=fixed)
        return arm


PI = np.pi

#: Franka Emika Panda (FER). Franka Control Interface documentation, "Robot and interface
#: specifications": the Denavit–Hartenberg parameters (modified DH, Craig) with the flange row
#: d = 0.107 m, and "Limits for Panda" (joint space q_min, q_max, rad). Base: panda_link0 (the
#: mounting flange); end: the flange (panda_link8), without the hand.
PANDA = ArmTable(
    name="panda",
    title="Franka Emika Panda",
    convention="modified",
    #      d_i      a_{i-1}   alpha_{i-1}  offset
    rows=((0.333,   0.0,      0.0,         0.0),
          (0.0,     0.0,      -PI / 2,     0.0),
          (0.316,   0.0,      PI / 2,      0.0),
          (0.0,     0.0825,   PI / 2,      0.0),
          (0.384,   -0.0825,  -PI / 2,     0.0),
          (0.0,     0.0,      PI / 2,      0.0),
          (0.0,     0.088,    PI / 2,      0.0)),
    flange=(0.107, 0.0, 0.0, 0.0),
    limits=((-2.8973, 2.8973), (-1.7628, 1.7628), (-2.8973, 2.8973), (-3.0718, -0.0698),
            (-2.8973, 2.8973), (-0.0175, 3.7525), (-2.8973, 2.8973)),
    limit_unit="rad",
    source="Franka Control Interface docs, 'Robot and interface specifications': DH table (modified DH, "
           "flange d = 0.107 m) and 'Limits for Panda' (q_min/q_max)",
)

#: KUKA LBR iiwa 14 R820. KUKA "LBR iiwa 7 R800, LBR iiwa 14 R820 Specifications": principal
#: dimensions (base to A2 0.360 m, A2 to A4 0.420 m, A4 to A6 0.400 m, A6 to the flange 0.126 m;
#: A2/A4/A6 on the A1 line, no lateral offsets) and the axis ranges (±170°, ±120°, ±170°, ±120°,
#: ±170°, ±120°, ±175°). KUKA publishes no DH table; this standard-DH table encodes those lengths
#: with KUKA's axis directions (A1 up; A2 about +y, A4 about -y, A6 about +y at the zero pose,
#: the arm straight up), as the ROS-Industrial description lbr_iiwa_14_r820 does.
IIWA14 = ArmTable(
    name="iiwa14",
    title="KUKA LBR iiwa 14 R820",
    convention="standard",
    #      d_i     a_i   alpha_i   offset
    rows=((0.360,  0.0,  -PI / 2,  0.0),
          (0.0,    0.0,  PI / 2,   0.0),
          (0.420,  0.0,  PI / 2,   0.0),
          (0.0,    0.0,  -PI / 2,  0.0),
          (0.400,  0.0,  -PI / 2,  0.0),
          (0.0,    0.0,  PI / 2,   0.0),
          (0.126,  0.0,  0.0,      0.0)),
    limits=((-170, 170), (-120, 120), (-170, 170), (-120, 120), (-170, 170), (-120, 120), (-175, 175)),
    limit_unit="deg",
    source="KUKA 'LBR iiwa 7 R800, LBR iiwa 14 R820' specification: principal dimensions 360/420/400/126 mm "
           "and axis ranges A1-A7 ±170/±120/±170/±120/±170/±120/±175 deg",
)

_UR_ALPHA = (PI / 2, 0.0, 0.0, PI / 2, -PI / 2, 0.0)
_UR_SOURCE = ("Universal Robots, 'DH parameters for calculations of kinematics and dynamics' (standard DH, "
              "base frame as the controller's, flange at d6); joint ranges ±360 deg on every joint from the "
              "{} User Manual (e-Series) technical specifications")


def _ur(name, title, d1, a2, a3, d4, d5, d6) -> ArmTable:
    d, a = (d1, 0.0, 0.0, d4, d5, d6), (0.0, a2, a3, 0.0, 0.0, 0.0)
    return ArmTable(name=name, title=title, convention="standard",
                    rows=tuple(zip(d, a, _UR_ALPHA, (0.0,) * 6)),
                    limits=((-360, 360),) * 6, limit_unit="deg", source=_UR_SOURCE.format(title))


#: Universal Robots UR5e and UR10e: UR's published DH parameters (all offsets zero: the DH zero is
#: the controller's zero, the arm stretched out horizontally).
UR5E = _ur("ur5e", "UR5e", d1=0.1625, a2=-0.425, a3=-0.3922, d4=0.1333, d5=0.0997, d6=0.0996)
UR10E = _ur("ur10e", "UR10e", d1=0.1807, a2=-0.6127, a3=-0.57155, d4=0.17415, d5=0.11985, d6=0.11655)

#: Kinova Gen3 (7 DoF). Kinova "KINOVA Gen3 Ultra lightweight robot User Guide": the classic DH
#: parameters of the 7 DoF arm (the fixed "base to frame 1" row alpha = pi, frame 0's z down; joint
#: angles theta_i = q_i + pi for joints 2-7; the last row ends at the tool flange, the interface
#: module's output) and the joint ranges (software limits): joints 1, 3, 5, 7 unlimited, 2: ±128.9°,
#: 4: ±147.8°, 6: ±120.3°.
GEN3 = ArmTable(
    name="gen3",
    title="Kinova Gen3 (7 DoF)",
    convention="standard",
    mount=(0.0, 0.0, PI, 0.0),
    #      d_i                   a_i   alpha_i  offset
    rows=((-(0.1564 + 0.1284),  0.0,  PI / 2,  0.0),
          (-(0.0054 + 0.0064),  0.0,  PI / 2,  PI),
          (-(0.2104 + 0.2104),  0.0,  PI / 2,  PI),
          (-(0.0064 + 0.0064),  0.0,  PI / 2,  PI),
          (-(0.2084 + 0.1059),  0.0,  PI / 2,  PI),
          (0.0,                 0.0,  PI / 2,  PI),
          (-(0.1059 + 0.0615),  0.0,  PI,      PI)),
    limits=(None, (-128.9, 128.9), None, (-147.8, 147.8), None, (-120.3, 120.3), None),
    limit_unit="deg",
    source="Kinova 'KINOVA Gen3 Ultra lightweight robot' User Guide: classic DH parameters of the 7 DoF robot "
           "(with the base to frame 1 transform) and joint ranges (2: ±128.9, 4: ±147.8, 6: ±120.3 deg; "
           "1, 3, 5, 7 unlimited)",
)

#: The real arms by name, each from its manufacturer's published kinematics.
NAMED: dict[str, ArmTable] = {t.name: t for t in (PANDA, IIWA14, UR5E, UR10E, GEN3)}


def _named(table: ArmTable):
    def make(joint_limits: bool | None = None) -> SerialChain:
        return table.chain(joint_limits=True if joint_limits is None else bool(joint_limits))

    make.__name__ = table.name
    make.__doc__ = f"The {table.title} (base → tool flange). Source: {table.source}."
    return make


def _puma560(joint_limits: bool | None = None) -> DHRobot:
    return puma560(joint_limits=bool(joint_limits))


#: Constructors of every named arm, ``name -> f(joint_limits=None)``; the paper's ``puma560`` first.
ROBOTS = {"puma560": _puma560, **{name: _named(t) for name, t in NAMED.items()}}


def load(name: str, joint_limits: bool | None = None) -> DHRobot | SerialChain:
    """A named arm: ``puma560`` (the paper's :class:`DHRobot`, d1 = 0), ``panda``, ``iiwa14``,
    ``ur5e``, ``ur10e``, ``gen3`` (:class:`SerialChain`).

    ``joint_limits`` ``None`` is the arm's default: the manufacturer's limits for a real arm, none
    for ``puma560`` (as the paper). ``True``/``False`` attach or drop them. The robot has ``.n``,
    ``.qlim`` (``(n, 2)`` rad, ``±inf`` for a continuous joint, ``None`` when unlimited) and
    ``.fkine(q)`` (base → flange). An unknown name is a ``ValueError`` listing the known ones.
    """
    key = str(name).lower()
    if key not in ROBOTS:
        raise ValueError(f"unknown robot {name!r}; known robots: {', '.join(ROBOTS)}")
    return ROBOTS[key](joint_limits=joint_limits)


def from_name(name: str, joint_limits: bool | None = None) -> DHRobot | SerialChain:
    """Look up a named arm: :func:`load`."""
    return load(name, joint_limits=joint_limits)


# ------------------------------------------------------------------------------------------ samplers
def _rng(seed) -> np.random.Generator:
    return seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)


def _check_count(count):
    if int(count) != count or count < 1:
        raise ValueError(f"count must be a positive integer, got {count!r}")
    return int(count)


def sample_spherical_wrist(count: int, seed=None, beta: float = 0.5) -> DHRobot:
    """``count`` arms of the spherical-wrist family with d3, d4, a2, a3 ~ U(0, beta), independent.

    The draw order per arm is (d3, d4, a2, a3): one ``(count, 4)`` uniform array.
    """
    count = _check_count(count)
    if not (beta > 0 and np.isfinite(beta)):
        raise ValueError(f"beta must be positive and finite, got {beta!r}")
    u = _rng(seed).uniform(0.0, beta, size=(count, 4))
    return spherical_wrist(a2=u[:, 2], a3=u[:, 3], d3=u[:, 0], d4=u[:, 1], name="spherical_wrist")


def sample_arbitrary_6dof(count: int, seed=None, beta: float = 0.5) -> DHRobot:
    """``count`` arbitrary 6-DOF arms (Table 3): every d_i, a_i, alpha_i ~ U(0, beta) (m, rad).

    The draw is one ``(count, 3, 6)`` uniform array: rows d, a, alpha.
    """
    count = _check_count(count)
    if not (beta > 0 and np.isfinite(beta)):
        raise ValueError(f"beta must be positive and finite, got {beta!r}")
    u = _rng(seed).uniform(0.0, beta, size=(count, 3, 6))
    return DHRobot(u[:, 0], u[:, 1], u[:, 2], name="arbitrary_6dof")
