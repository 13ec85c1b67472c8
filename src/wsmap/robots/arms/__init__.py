"""The named arms: one module per arm, named as the arm, each ending by registering it.

Like Robotics Toolbox's `models/DH/`: a module holds one arm's short table of the manufacturer's
numbers (an `ArmTable`) with the document it comes from in a comment and in its `source`, its
capsule collision model (an `ArmCapsules`, or none) and whether the morphology families hold it
out, and ends with `register(TABLE, priority=..., capsules=..., held_out=...)`
(`wsmap.robots.registry`); then `wsmap.robots.load(NAME)` builds it, `wsmap robots` lists it,
`wsmap.collision.arm_model(NAME)` builds its capsules and `wsmap.robots.morph.HELD_OUT` holds it.

* `.puma560` — the paper's PUMA560 (MATLAB toolbox `mdl_puma560`, d1 = 0), a
  `DHRobot` (priority 10: listed first);
* `.panda` — Franka Emika Panda (modified DH, flange row; 20);
* `.iiwa14` — KUKA LBR iiwa 14 R820 (30);
* `.ur5e`, `.ur10e` — Universal Robots e-Series (UR's DH layout: `._ur`; 40, 50);
* `.gen3` — Kinova Gen3, 7 DoF (60).

Every real arm has its base at the manufacturer's base (mounting flange) frame and its end at the
tool flange (no gripper), its joint zero and signs as the manufacturer's controller, and its joint
limits in radians (`±inf` for a continuous joint).

A new named arm is one new module here (`NAME.py`: its table, its capsules and its registration
with an explicit priority at its end) and its tests (tests/robots/); `discover` imports every
module of the folder. Modules whose name starts with `_` are helpers shared by several arms, not
arms.
"""

from ..._plugins import discover

# Importing an arm module registers it; the order the arms are listed in is their priority.
discover(__name__, __path__)
