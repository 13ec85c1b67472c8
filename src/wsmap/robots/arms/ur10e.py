"""Universal Robots UR10e, base (the controller's base frame) to the tool flange."""

from __future__ import annotations

from ..registry import register
from ._ur import ur_table

#: Universal Robots, "DH parameters for calculations of kinematics and dynamics" (UR10e, metres);
#: joint ranges ±360° from the UR10e User Manual (e-Series).
UR10E = ur_table("ur10e", "UR10e", d1=0.1807, a2=-0.6127, a3=-0.57155, d4=0.17415, d5=0.11985, d6=0.11655)

#: No capsule model (yet): `wsmap.collision.arm_model("ur10e")` refuses, naming the arms that have one.
register(UR10E, priority=50, held_out=True)
