"""Named arms and the random arm families of the paper.

Every constructor returns a :class:`~wsmap.kinematics.DHRobot`; the samplers return a batch of
arms (batch shape ``(count,)``) drawn with a seed or a ``numpy.random.Generator``.
"""

from __future__ import annotations

import numpy as np

from .kinematics import SPHERICAL_WRIST_ALPHA, DHRobot

__all__ = [
    "PUMA560_QLIM_DEG",
    "puma560",
    "spherical_wrist",
    "sample_spherical_wrist",
    "sample_arbitrary_6dof",
    "from_name",
    "ROBOTS",
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


#: Named arms available to the command line and to :func:`from_name`.
ROBOTS = {"puma560": puma560}


def from_name(name: str, joint_limits: bool = False) -> DHRobot:
    """Look up a named arm (``'puma560'``); an unknown name is a ``ValueError`` listing the known ones."""
    key = name.lower()
    if key not in ROBOTS:
        raise ValueError(f"unknown robot {name!r}; known robots: {', '.join(sorted(ROBOTS))}")
    return ROBOTS[key](joint_limits=joint_limits)
