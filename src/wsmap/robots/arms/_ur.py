"""Universal Robots' DH layout, shared by the UR arms (`.ur5e`, `.ur10e`): not an arm.

UR publishes, per model, six lengths of one standard-DH layout: `d = (d1, 0, 0, d4, d5, d6)`,
`a = (0, a2, a3, 0, 0, 0)`, the twists `UR_ALPHA` and all offsets zero (the DH zero is
the controller's zero, the arm stretched out horizontally); base frame as the controller's, flange
at d6.
"""

from __future__ import annotations

import numpy as np

from ..registry import ArmTable

PI = np.pi

UR_ALPHA = (PI / 2, 0.0, 0.0, PI / 2, -PI / 2, 0.0)
UR_SOURCE = ("Universal Robots, 'DH parameters for calculations of kinematics and dynamics' (standard DH, "
             "base frame as the controller's, flange at d6); joint ranges ±360 deg on every joint from the "
             "{} User Manual (e-Series) technical specifications")


def ur_table(name, title, d1, a2, a3, d4, d5, d6) -> ArmTable:
    """The `ArmTable` of a UR arm from its six published lengths (metres); every joint ±360°."""
    d, a = (d1, 0.0, 0.0, d4, d5, d6), (0.0, a2, a3, 0.0, 0.0, 0.0)
    return ArmTable(name=name, title=title, convention="standard",
                    rows=tuple(zip(d, a, UR_ALPHA, (0.0,) * 6)),
                    limits=((-360, 360),) * 6, limit_unit="deg", source=UR_SOURCE.format(title))
