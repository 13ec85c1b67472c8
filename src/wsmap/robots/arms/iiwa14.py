"""KUKA LBR iiwa 14 R820, base (mounting flange) to the tool flange."""

from __future__ import annotations

import numpy as np

from ..registry import ArmCapsules, ArmTable, register

PI = np.pi

#: KUKA "LBR iiwa 7 R800, LBR iiwa 14 R820 Specifications": principal dimensions (base to A2
#: 0.360 m, A2 to A4 0.420 m, A4 to A6 0.400 m, A6 to the flange 0.126 m; A2/A4/A6 on the A1 line,
#: no lateral offsets) and the axis ranges (±170°, ±120°, ±170°, ±120°, ±170°, ±120°, ±175°). KUKA
#: publishes no DH table; this standard-DH table encodes those lengths with KUKA's axis directions
#: (A1 up; A2 about +y, A4 about -y, A6 about +y at the zero pose, the arm straight up), as the
#: ROS-Industrial description lbr_iiwa_14_r820 does.
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

#: The capsule model (`wsmap.collision.named`), from the KUKA specification's dimension drawing
#: (estimated, see `wsmap.collision.named`'s notes): housings about 0.15 m across at A1-A4,
#: narrowing towards the flange; one capsule along each DH link.
IIWA14_RADII = (0.10, 0.075, 0.075, 0.07, 0.07, 0.065, 0.06, 0.045)
IIWA14_CAPSULES = ArmCapsules(radii=IIWA14_RADII, source=(
    "capsules along the iiwa 14's DH links (KUKA principal dimensions 360/420/400/126 mm), radii "
    f"{list(IIWA14_RADII)} m (estimates of the housings of the specification's dimension drawing)"))

register(IIWA14, priority=30, capsules=IIWA14_CAPSULES, held_out=True)
