"""Universal Robots UR5e, base (the controller's base frame) to the tool flange."""

from __future__ import annotations

from ..registry import register
from ._ur import ur_table

#: Universal Robots, "DH parameters for calculations of kinematics and dynamics" (UR5e, metres);
#: joint ranges ±360° from the UR5e User Manual (e-Series).
UR5E = ur_table("ur5e", "UR5e", d1=0.1625, a2=-0.425, a3=-0.3922, d4=0.1333, d5=0.0997, d6=0.0996)

register(UR5E)
