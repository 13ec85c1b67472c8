"""Universal Robots UR5e, base (the controller's base frame) to the tool flange."""

from __future__ import annotations

from ..registry import ArmCapsules, register
from ._ur import ur_table

#: Universal Robots, "DH parameters for calculations of kinematics and dynamics" (UR5e, metres);
#: joint ranges ±360° from the UR5e User Manual (e-Series).
UR5E = ur_table("ur5e", "UR5e", d1=0.1625, a2=-0.425, a3=-0.3922, d4=0.1333, d5=0.0997, d6=0.0996)

#: The capsule model (`wsmap.collision.named`): upper arm offset 0.138 m and forearm 0.007 m along
#: the parallel axes from the DH line (Universal Robots' ur_description visual parameters for the
#: UR5e: shoulder_offset, elbow_offset); base footprint 0.149 m across (UR5e User Manual, technical
#: specifications); the radii of the tubes and housings are estimates (`wsmap.collision.named`'s
#: notes). Fixed numbers: they do not follow an arm with other lengths.
UR5E_CAPSULES = ArmCapsules(
    capsules=(
        # (body, p0, p1, radius), metres, body frames of the UR5e's standard-DH chain
        (0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.06), 0.075),            # base
        (1, (0.0, 0.0, 0.0), (0.0, 0.0, 0.1625), 0.065),          # shoulder pan housing up to joint 2
        (2, (0.0, 0.0, 0.0), (0.0, 0.0, 0.138), 0.065),           # shoulder lift housing
        (2, (0.0, 0.0, 0.138), (-0.425, 0.0, 0.138), 0.055),      # upper arm tube
        (2, (-0.425, 0.0, 0.138), (-0.425, 0.0, 0.02), 0.055),    # elbow housing
        (3, (0.0, 0.0, 0.007), (-0.3922, 0.0, 0.007), 0.045),     # forearm tube
        (4, (0.0, 0.0, 0.0), (0.0, 0.0, 0.1333), 0.045),          # wrist 1 housing
        (5, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0997), 0.045),          # wrist 2 housing
        (6, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0996), 0.04),           # wrist 3 and the flange
    ),
    names=("base", "shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3"),
    source="UR5e capsules: ur_description offsets (0.138 m, 0.007 m), UR5e User Manual footprint; radii estimated",
)

register(UR5E, priority=40, capsules=UR5E_CAPSULES, held_out=True)
