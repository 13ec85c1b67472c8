"""The named arms: one module per arm, named as the arm, each ending by registering it.

Like Robotics Toolbox's `models/DH/`: a module holds one arm's short table of the manufacturer's
numbers (an `ArmTable`) with the document it comes from in a comment
and in its `source`, and ends with `register(TABLE)` (`wsmap.robots.registry`); then
`wsmap.robots.load(NAME)` builds it and `wsmap robots` lists it.

* `.puma560` — the paper's PUMA560 (MATLAB toolbox `mdl_puma560`, d1 = 0), a
  `DHRobot`;
* `.panda` — Franka Emika Panda (modified DH, flange row);
* `.iiwa14` — KUKA LBR iiwa 14 R820;
* `.ur5e`, `.ur10e` — Universal Robots e-Series (UR's DH layout: `._ur`);
* `.gen3` — Kinova Gen3, 7 DoF.

Every real arm has its base at the manufacturer's base (mounting flange) frame and its end at the
tool flange (no gripper), its joint zero and signs as the manufacturer's controller, and its joint
limits in radians (`±inf` for a continuous joint).

A new named arm is one new module here (`NAME.py`: its table and `register(...)` at its end),
its name added to the import line below, and its tests (tests/robots/). Modules whose name starts
with `_` are helpers shared by several arms, not arms.
"""

# Importing an arm module registers it. The order is the registry's, the order `wsmap robots`
# lists: the paper's arm first, then the real arms.
from . import puma560, panda, iiwa14, ur5e, ur10e, gen3  # noqa: F401, I001
