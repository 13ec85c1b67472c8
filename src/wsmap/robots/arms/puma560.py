"""The PUMA560 as the paper used it: MATLAB Robotics Toolbox 10 `mdl_puma560` with base height d1 = 0.

Standard DH; the paper's spherical-wrist family (`wsmap.robots.SPHERICAL_WRIST`) with
d3 = 0.15005, d4 = 0.4318, a2 = 0.4318, a3 = 0.0203 m. A `DHRobot`
without joint limits by default, as the paper ignored them.
"""

from __future__ import annotations

import numpy as np

from ...kinematics import DHRobot
from ..registry import register_constructor

PI = np.pi

SOURCE = "MATLAB Robotics Toolbox mdl_puma560 (the paper's arm, d1 = 0)"

#: Corke, MATLAB Robotics Toolbox 10, `mdl_puma560` (standard DH; toolbox d1 = 0.6718 m, the
#: paper's 0). Columns per joint, metres and radians.
D = (0.0, 0.0, 0.15005, 0.4318, 0.0, 0.0)
A = (0.0, 0.4318, 0.0203, 0.0, 0.0, 0.0)
ALPHA = (PI / 2, 0.0, -PI / 2, PI / 2, -PI / 2, 0.0)

#: PUMA560 joint limits in degrees (Corke's `mdl_puma560`); the paper ignores them.
PUMA560_QLIM_DEG = np.array(
    [[-160, 160], [-45, 225], [-225, 45], [-110, 170], [-100, 100], [-266, 266]], dtype=np.float64
)


def puma560(joint_limits: bool = False) -> DHRobot:
    """The PUMA560 as the paper used it (MATLAB toolbox 10 `mdl_puma560`, base height d1 = 0).

    At `q = 0` the flange sits at (0.4521, -0.15005, 0.4318) m. Joint limits
    (`PUMA560_QLIM_DEG`) are attached only when asked for, as the paper ignored them.
    """
    qlim = np.deg2rad(PUMA560_QLIM_DEG) if joint_limits else None
    return DHRobot(np.array(D), np.array(A), np.array(ALPHA), qlim=qlim, name="puma560")


def _load(joint_limits: bool | None = None) -> DHRobot:
    return puma560(joint_limits=bool(joint_limits))


#: The paper's arm comes first in the order of the named arms; no capsule model (the paper ignored
#: self-collision).
register_constructor("puma560", _load, SOURCE, priority=10, held_out=True)
