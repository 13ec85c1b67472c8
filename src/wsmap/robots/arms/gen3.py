"""Kinova Gen3 (7 DoF), base to the tool flange (the interface module's output)."""

from __future__ import annotations

import numpy as np

from ..registry import ArmTable, register

PI = np.pi

#: Kinova "KINOVA Gen3 Ultra lightweight robot User Guide": the classic DH parameters of the 7 DoF
#: arm (the fixed "base to frame 1" row alpha = pi, frame 0's z down; joint angles theta_i = q_i + pi
#: for joints 2-7; the last row ends at the tool flange, the interface module's output) and the
#: joint ranges (software limits): joints 1, 3, 5, 7 unlimited, 2: ±128.9°, 4: ±147.8°, 6: ±120.3°.
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

#: No capsule model (yet): `wsmap.collision.arm_model("gen3")` refuses, naming the arms that have one.
register(GEN3, priority=60, held_out=True)
