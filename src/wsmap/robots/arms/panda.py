"""Franka Emika Panda (FER), base `panda_link0` (the mounting flange) to the flange
(`panda_link8`), without the hand."""

from __future__ import annotations

import numpy as np

from ..registry import ArmCapsules, ArmTable, register

PI = np.pi

#: Franka Control Interface documentation, "Robot and interface specifications": the
#: Denavit–Hartenberg parameters (modified DH, Craig) with the flange row d = 0.107 m, and "Limits
#: for Panda" (joint space q_min, q_max, rad).
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

#: The capsule model (`wsmap.collision.named`), from the Franka Emika Panda datasheet's dimension
#: drawing (estimated, see `wsmap.collision.named`'s notes): joint housings about 0.13-0.14 m
#: across at joints 1-4, narrowing towards the wrist. Body k spans the DH link k (d along z, then a
#: along x), so body 0 is a ball at the base origin.
PANDA_RADII = (0.10, 0.07, 0.07, 0.065, 0.065, 0.06, 0.055, 0.045)
PANDA_CAPSULES = ArmCapsules(radii=PANDA_RADII, source=(
    "capsules along the Panda's modified-DH links (FCI 'Robot and interface specifications'), radii "
    f"{list(PANDA_RADII)} m (estimates of the housings of the Panda datasheet's dimension drawing)"))

register(PANDA, priority=20, capsules=PANDA_CAPSULES, held_out=True)
